"""The secret that seeds a generated edition's test split.

The generator and an edition's public seed are public, so anyone could regenerate a test
split seeded by them, withheld answers included. An edition with a secret test split seeds
every random draw of its test split (garment parameters, design bodies, target bodies and
poses, pairs) from a secret instead, through :func:`derive_seed`; train and val stay seeded
by the public seed. The edition publishes only :func:`commitment` of the secret (its sha256),
and later, when the edition is retired, the secret itself: the test split then becomes
reproducible and checkable against the commitment (docs/benchmark.md, "Secret test splits").

A secret is 32 random bytes, stored as a text file of 64 lowercase hex characters (an
optional trailing newline). :func:`read_secret` does not check the file's permissions: how
a secret is guarded is the store's business (a maintainers' store may be readable by a
group); ``dressmeup edition secret`` writes a new one readable by its owner only (0600).
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import re
import secrets
import struct

from dressmeup.errors import InputError

__all__ = ["SECRET_BYTES", "commitment", "derive_seed", "new_secret", "parse_secret",
           "read_secret", "write_new_secret"]

#: bytes of a secret (its text form is twice as many hex characters)
SECRET_BYTES = 32
_HEX_RE = re.compile(r"[0-9a-f]{64}")
#: the first element of every message :func:`derive_seed` authenticates (domain separation)
_SEED_DOMAIN = "dressmeup-seed/1"


def new_secret() -> str:
    """A new secret: :data:`SECRET_BYTES` bytes from :mod:`secrets`, as 64 lowercase hex
    characters."""
    return secrets.token_hex(SECRET_BYTES)


def write_new_secret(path: str | os.PathLike) -> str:
    """Write a new secret (:func:`new_secret`, and a newline) to the new file ``path``,
    readable and writable by its owner only (mode 0600); return its :func:`commitment`.

    Raises
    ------
    InputError
        ``path`` exists (a secret is never overwritten: an edition may commit to it) or
        cannot be created.
    """
    text = new_secret()
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
    except FileExistsError:
        raise InputError(f"{path} already exists: a secret is never overwritten (an edition "
                         "may commit to it); choose another file") from None
    except OSError as exc:
        raise InputError(f"cannot create the secret file {path} ({exc.strerror or exc}); "
                         "does its folder exist?") from exc
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, 0o600)  # whatever the umask
        with os.fdopen(fd, "w", encoding="ascii") as f:
            fd = -1
            f.write(text + "\n")
    except BaseException:
        if fd >= 0:
            os.close(fd)
        os.unlink(path)  # no half-written secret left behind
        raise
    return commitment(bytes.fromhex(text))


def parse_secret(text: str, where: str) -> bytes:
    """The secret bytes of its text form (64 lowercase hex characters, an optional trailing
    newline); ``where`` names the text's origin in the error.

    Raises
    ------
    InputError
        Any other text (the message never repeats the text: it may be a secret).
    """
    if not isinstance(text, str):
        raise InputError(f"{where}: a secret is a string of 64 lowercase hex characters, got "
                         f"{type(text).__name__}")
    body = text[:-1] if text.endswith("\n") else text
    if not _HEX_RE.fullmatch(body):
        raise InputError(f"{where}: a secret is exactly 64 lowercase hex characters (an "
                         f"optional trailing newline), got {len(body)} characters"
                         f"{'' if len(body) != 64 else ' that are not all 0-9a-f'}; make one "
                         "with 'dressmeup edition secret --out FILE'")
    return bytes.fromhex(body)


def read_secret(path: str | os.PathLike) -> bytes:
    """The secret stored in the file ``path`` (see the module docstring), as
    :data:`SECRET_BYTES` bytes.

    Raises
    ------
    InputError
        The file is missing, unreadable, not UTF-8 or not a secret; the message names it.
    """
    try:
        with open(path, "rb") as f:
            raw = f.read(2 * SECRET_BYTES + 2)  # a secret file is 65 bytes at most
    except OSError as exc:
        raise InputError(f"secret file {path}: cannot read it ({exc.strerror or exc})") from exc
    if len(raw) > 2 * SECRET_BYTES + 1:
        raise InputError(f"secret file {path}: longer than a secret (64 lowercase hex "
                         "characters and an optional trailing newline); is it the right file?")
    try:
        text = raw.decode("ascii")
    except UnicodeDecodeError:
        text = "\0" * len(raw)  # reported by its length below
    return parse_secret(text, f"secret file {path}")


def commitment(secret: bytes) -> str:
    """The public commitment to ``secret``: the sha256 hex digest of its bytes (not of its
    hex text)."""
    _check_bytes(secret)
    return hashlib.sha256(secret).hexdigest()


def derive_seed(secret: bytes, *labels: str | int) -> list[int]:
    """Seed words of one random draw, derived from ``secret`` and the draw's ``labels``.

    The words are the HMAC-SHA256, keyed by ``secret``, of the compact JSON array
    ``["dressmeup-seed/1", *labels]`` (ASCII, no spaces), read as eight big-endian uint32:
    ``np.random.default_rng(derive_seed(secret, "test", "garment", 3))``. Distinct labels
    give independent streams, and without the secret none can be told from random.

    Parameters
    ----------
    secret : :data:`SECRET_BYTES` bytes.
    labels : one or more strings or integers naming the draw (not booleans).

    Returns
    -------
    list of 8 int in [0, 2**32).
    """
    _check_bytes(secret)
    if not labels:
        raise ValueError("derive_seed: give at least one label naming the draw")
    for label in labels:
        if isinstance(label, bool) or not isinstance(label, (str, int)):
            raise TypeError(f"derive_seed: labels are strings or integers, got "
                            f"{type(label).__name__} {label!r}")
    message = json.dumps([_SEED_DOMAIN, *labels], separators=(",", ":"), ensure_ascii=True)
    digest = hmac.new(secret, message.encode("ascii"), hashlib.sha256).digest()
    return list(struct.unpack(">8I", digest))


def _check_bytes(secret: bytes) -> None:
    if not isinstance(secret, bytes) or len(secret) != SECRET_BYTES:
        what = f"{len(secret)} bytes" if isinstance(secret, bytes) else type(secret).__name__
        raise TypeError(f"secret: expected {SECRET_BYTES} bytes (read_secret or "
                        f"parse_secret), got {what}")
