"""Bounded image reading: the header's size is checked before any pixel is decoded.

A 40000 x 40000 PNG of zeros is a few megabytes on disk and 4.8 GB decoded. Every image the
toolkit reads from a user (garment textures, dataset atlases, capture frames) goes through
:func:`image_header` first: the image is opened lazily (Pillow reads the header only), its
pixel count is checked against the ``image_pixels`` limit of :mod:`dressmeup.limits`
(Pillow's own ``MAX_IMAGE_PIXELS`` is set to the same limit), and optionally its chunks are
verified (``verify=True``: checksums and structure without decoding). :func:`read_image`
decodes afterwards. Every failure is an :class:`~dressmeup.errors.InputError` naming the
file.
"""

from __future__ import annotations

import io
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from PIL import Image, UnidentifiedImageError

from dressmeup.errors import InputError
from dressmeup.limits import IMAGE_PIXELS, LimitError, bounded_file

_DAMAGE = (UnidentifiedImageError, OSError, ValueError, SyntaxError, EOFError)


@dataclass(frozen=True)
class ImageHeader:
    """What an image file's header declares."""

    width: int
    height: int
    mode: str
    format: str | None


def _open(source):
    """Pillow's lazy open with its bomb check at the policy's limit (twice the limit raises,
    between one and two times warns: both become our limit error)."""
    limit = IMAGE_PIXELS.value()
    Image.MAX_IMAGE_PIXELS = limit
    with warnings.catch_warnings():
        warnings.simplefilter("error", Image.DecompressionBombWarning)
        return Image.open(io.BytesIO(source) if isinstance(source, (bytes, bytearray))
                          else source)


def image_header(path: str | os.PathLike | bytes, what: str = "image",
                 verify: bool = False) -> ImageHeader:
    """The size and mode an image declares, checked against the ``image_pixels`` limit.

    Parameters
    ----------
    path : the image file (PNG, JPEG, ... anything Pillow reads), or its bytes.
    what : how messages name it (``"texture"``, ``"colour frame"``).
    verify : also check the file's structure and checksums (Pillow's ``verify``; nothing is
        decoded).

    Raises
    ------
    FileNotFoundError, InputError
        Missing, not a regular file, not an image, damaged, or over the pixel limit.
    """
    if isinstance(path, (bytes, bytearray)):
        source, path = bytes(path), "(in memory)"
    else:
        source = path = bounded_file(path, what)
    try:
        with _open(source) as im:
            head = ImageHeader(int(im.width), int(im.height), str(im.mode), im.format)
            IMAGE_PIXELS.check(head.width * head.height, f"{what} {path}",
                               f"image of {head.width} x {head.height}")
            if verify:
                im.verify()
    except LimitError:
        raise
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise LimitError(f"{what} {path}: {exc}; the limit is image_pixels "
                         f"({IMAGE_PIXELS.value():,} pixels): {IMAGE_PIXELS.how_to_raise()}",
                         IMAGE_PIXELS) from exc
    except _DAMAGE as exc:
        raise InputError(f"{what} {path}: not a readable image ({type(exc).__name__}: "
                         f"{exc})") from exc
    return head


def read_image(path: str | os.PathLike | bytes, what: str = "image",
               mode: str | None = "RGB") -> np.ndarray:
    """Decode an image after :func:`image_header`'s checks.

    Returns
    -------
    (h, w, c) or (h, w) uint8/uint16 ndarray, converted to ``mode`` when given.

    Raises
    ------
    FileNotFoundError, InputError
    """
    image_header(path, what)
    try:
        with _open(path if isinstance(path, (bytes, bytearray)) else Path(path)) as im:
            return np.asarray(im.convert(mode) if mode else im)
    except (Image.DecompressionBombError, Image.DecompressionBombWarning) as exc:
        raise LimitError(f"{what} {path}: {exc}", IMAGE_PIXELS) from exc
    except _DAMAGE as exc:
        raise InputError(f"{what} {path}: not a readable image ({type(exc).__name__}: "
                         f"{exc})") from exc
