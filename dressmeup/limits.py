"""Resource bounds of everything the toolkit reads or is asked to make: one policy, here.

A hostile or careless input (a 200-byte pickle that builds a billion objects, a 2 MB
``.npz`` declaring a 2.4 GB array, a 195 KB manifest of two million rows, a PNG declaring
40000 x 40000 pixels, a request for two billion surface samples) is refused *before* the
memory or the time is spent, with an error that names the file or option, the amount, the
limit and how to raise it: every limit reads the environment variable
``DRESSMEUP_MAX_<NAME>`` (an integer, with an optional ``K``/``M``/``G``/``T`` suffix of
powers of 1024: ``DRESSMEUP_MAX_ARRAY_BYTES=4G``), which the command line's
``dressmeup --max array_bytes=4G COMMAND`` sets for one run. docs/limits.md lists them
(generated from :data:`LIMITS` and compared by the tests).
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass
from pathlib import Path

from dressmeup.errors import InputError

_SUFFIX = {"": 1, "K": 1 << 10, "M": 1 << 20, "G": 1 << 30, "T": 1 << 40}


class LimitError(InputError):
    """An input or a request beyond one of the :data:`LIMITS` (the message says which and
    how to raise it)."""

    def __init__(self, message: str, limit: Limit):
        super().__init__(message)
        self.limit = limit


def _fmt(n: int | float, unit: str) -> str:
    if unit == "bytes":
        for size, name in ((1 << 40, "TiB"), (1 << 30, "GiB"), (1 << 20, "MiB"),
                           (1 << 10, "KiB")):
            if n >= size:
                return f"{int(n):,} bytes ({n / size:.3g} {name})"
        return f"{int(n)} bytes"
    return f"{int(n):,}" + (f" {unit}" if unit == "pixels" else "")


@dataclass(frozen=True)
class Limit:
    """One bound: ``name`` (its environment variable is ``DRESSMEUP_MAX_<NAME>``), the
    ``default``, the ``unit`` (``bytes`` or what is counted), ``what`` it bounds (the words
    of its errors) and ``doc``, where it applies (the table of docs/limits.md)."""

    name: str
    default: int
    unit: str
    what: str
    doc: str = ""

    @property
    def env(self) -> str:
        """The environment variable that sets this limit."""
        return "DRESSMEUP_MAX_" + self.name.upper()

    def value(self) -> int:
        """The limit in force: the environment variable when set, else the default.

        Raises
        ------
        InputError
            The environment variable is not a positive integer (with an optional suffix).
        """
        raw = os.environ.get(self.env, "").strip()
        if not raw:
            return self.default
        m = re.fullmatch(r"(\d+)\s*([KMGT]?)(?:i?B)?", raw, re.I)
        if not m or int(m.group(1)) <= 0:
            raise InputError(f"{self.env}={raw!r}: expected a positive integer, optionally with "
                             "a K, M, G or T suffix (powers of 1024)")
        return int(m.group(1)) * _SUFFIX[m.group(2).upper()]

    def how_to_raise(self) -> str:
        """How to raise it: the command line's ``--max`` or the environment variable."""
        return (f"raise it with 'dressmeup --max {self.name}=N ...' or the environment "
                f"variable {self.env}")

    def check(self, amount: int | float, source: str, what: str | None = None,
              limit: int | None = None) -> None:
        """Refuse ``amount`` (of ``what`` in ``source``) beyond the limit.

        Parameters
        ----------
        amount : what the input declares or the request asks for.
        source : the file or option that asks (the message starts with it).
        what : what is counted (default: the limit's own description).
        limit : an explicit bound for this call (a caller's tighter one), else :meth:`value`.

        Raises
        ------
        LimitError
        """
        bound = self.value() if limit is None else limit
        if amount > bound:
            raise LimitError(
                f"{source}: {what or self.what} {_fmt(amount, self.unit)}, over the limit "
                f"of {_fmt(bound, self.unit)} ({self.name}); {self.how_to_raise()} if this "
                "is intended", self)


JSON_BYTES = Limit("json_bytes", 64 << 20, "bytes", "JSON file size",
                   "every JSON file read: dataset.json, editions, session.json, rig.json, "
                   "summary.json, submission.json, keypoints, archive indexes, scheduler "
                   "files (a JSON document takes several times its size in memory)")
MESH_BYTES = Limit("mesh_bytes", 1 << 30, "bytes", "mesh file size",
                   "PLY/OBJ meshes and point files, checked before reading (the OBJ reader "
                   "holds Python lists, about twice the file)")
ARRAY_BYTES = Limit("array_bytes", 1 << 30, "bytes", "declared array size (uncompressed)",
                    "the arrays of one .npy/.npz (scans, body parameters, keypoints), a "
                    "Parquet table's row groups, a checkpoint's members and a sparse matrix's "
                    "dense form, as their headers declare them, before anything is inflated; "
                    "the geodesic matrix an edition's options.max_vertices asks for")
PREDICTION_BYTES = Limit("prediction_bytes", 512 << 20, "bytes",
                         "declared prediction size (uncompressed)",
                         "one prediction file of a submission, from its headers")
NPZ_MEMBERS = Limit("npz_members", 256, "count", "arrays in one .npz",
                    "arrays in one .npz (a submission item, body parameters and model files "
                    "hold a few)")
PICKLE_BYTES = Limit("pickle_bytes", 2 << 30, "bytes", "pickle file size",
                     "SMPL-family model pickles, published datasets' fits and labels, a "
                     "checkpoint's data.pkl")
PICKLE_OBJECTS = Limit("pickle_objects", 2_000_000, "count", "objects the pickle builds",
                       "objects a pickle would build, each shared reference counted again "
                       "(a 200-byte \"billion laughs\" builds 10^9), scanned from its opcodes "
                       "before anything is unpickled")
TABLE_ROWS = Limit("table_rows", 1_000_000, "count", "table rows",
                   "rows of a manifest or a per-item result table, from the Parquet footer "
                   "before reading; an edition's pairs.per_track (pairs per source garment)")
IMAGE_PIXELS = Limit("image_pixels", 100_000_000, "pixels", "image size",
                     "pixels of an image read (texture, atlas, capture frame) from its header "
                     "before decoding (Pillow's MAX_IMAGE_PIXELS is set to it), and of the "
                     "images a command is asked to make (--texture-size, synth-capture "
                     "--scale, an edition's options.overlap_resolution grid)")
SURFACE_SAMPLES = Limit("surface_samples", 20_000_000, "count", "surface samples per mesh",
                        "surface samples per mesh (metrics --samples, an edition's "
                        "options.n_samples)")
SAMPLES = Limit("samples", 1_000_000, "count", "samples",
                "samples the synthetic generator is asked to write in one run "
                "(--subjects x --garments x --poses)")
MESH_FACES = Limit("mesh_faces", 50_000_000, "count", "faces of one mesh",
                   "faces of one mesh a command is asked to make (synth --edge-length: a "
                   "garment of up to 2 m^2)")
FRAMES = Limit("frames", 100_000, "count", "frames",
               "frames one command renders (synth-capture --frames x cameras)")
ARCHIVE_MEMBERS = Limit("archive_members", 10_000_000, "count", "files in one archive",
                        "files an archive index lists (edition fetch/verify) and members of "
                        "a checkpoint archive")
WORKERS = Limit("workers", 1024, "count", "worker processes",
                "worker processes or threads of one command (--workers, --threads)")

LIMITS: tuple[Limit, ...] = (JSON_BYTES, MESH_BYTES, ARRAY_BYTES, PREDICTION_BYTES,
                             NPZ_MEMBERS, PICKLE_BYTES, PICKLE_OBJECTS, TABLE_ROWS,
                             IMAGE_PIXELS, SURFACE_SAMPLES, SAMPLES, MESH_FACES, FRAMES,
                             ARCHIVE_MEMBERS, WORKERS)


def bounded_file(path: str | os.PathLike, what: str = "file",
                 limit: Limit | None = None) -> Path:
    """``path`` as a Path when it is a regular file within ``limit`` (a byte limit, e.g.
    :data:`PICKLE_BYTES`; None: any size).

    Raises
    ------
    FileNotFoundError
        Nothing at ``path``.
    InputError
        A folder or special file; :class:`LimitError` when larger than the limit.
    """
    path = Path(path)
    if not path.is_file():
        if not path.exists():
            raise FileNotFoundError(2, "No such file or directory", str(path))
        raise InputError(f"{what} {path}: not a regular file")
    if limit is not None:
        limit.check(path.stat().st_size, f"{what} {path}")
    return path


def by_name(name: str) -> Limit:
    """The limit called ``name`` (e.g. ``"array_bytes"``).

    Raises
    ------
    InputError
        No such limit (the message lists them).
    """
    for lim in LIMITS:
        if lim.name == name:
            return lim
    raise InputError(f"no limit named {name!r}; limits: {', '.join(x.name for x in LIMITS)}")


def markdown_table() -> str:
    """The policy as a Markdown table (docs/limits.md holds it)."""
    lines = ["| limit | default | what it bounds | raise it with |", "|---|---|---|---|"]
    for lim in LIMITS:
        lines.append(f"| `{lim.name}` | {_fmt(lim.default, lim.unit)} | {lim.doc} | "
                     f"`--max {lim.name}=N`, `{lim.env}` |")
    return "\n".join(lines)
