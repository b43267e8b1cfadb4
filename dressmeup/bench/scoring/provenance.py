"""Where a number was made: the one description of the machine for submissions and results.

``hardware()`` goes into ``submission.json`` (``"hardware"``) of every baseline run (CLI,
demo, benchmark scripts); ``environment()`` is the machine part of a result's provenance.
"""

from __future__ import annotations

import os
import platform
import socket

__all__ = ["hardware", "environment"]


def hardware() -> str:
    """The processor and core count, e.g. ``"x86_64 CPU, 2 cores"``.

    Returns
    -------
    str : ``platform.processor()`` (or the machine type when that is empty), ``" CPU, "``, the
    number of logical cores and ``" cores"``.
    """
    return f"{platform.processor() or platform.machine()} CPU, {os.cpu_count()} cores"


def environment() -> dict[str, str]:
    """Host name, platform string and Python version of this process.

    Returns
    -------
    dict with ``host``, ``platform``, ``python`` (str each).
    """
    return {"host": socket.gethostname(), "platform": platform.platform(),
            "python": platform.python_version()}
