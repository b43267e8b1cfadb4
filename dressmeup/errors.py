"""Exception types shared by every stage.

Errors a user can hit derive from :class:`DressmeupError` so that the CLI can print them as
one clear line (which file, which field, what to do) instead of a traceback.
"""

from __future__ import annotations


class DressmeupError(Exception):
    """Base class of the toolkit's own errors."""


class InputError(DressmeupError, ValueError):
    """Bad user input: a file, field or argument that does not fit the contract."""


class MissingModelError(DressmeupError, FileNotFoundError):
    """A user-supplied model file (e.g. SMPL) is missing; the message says where to put it."""
