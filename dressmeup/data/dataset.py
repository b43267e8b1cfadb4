"""The `Dataset` API: load garments, bodies and splits in three lines.

>>> from dressmeup.data import Dataset                         # doctest: +SKIP
>>> ds = Dataset("my-dataset").filter(split="test")            # doctest: +SKIP
>>> for pair in ds.retarget_pairs("test"):                      # doctest: +SKIP
...     g = pair.source.garment(); body = pair.target.body()

Samples load lazily: a :class:`Sample` only holds its manifest row until ``garment()``,
``body()`` or ``scan()`` is called. Readers of other layouts (:mod:`dressmeup.data.adapters`)
build the same :class:`Sample` objects with their own loaders.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dressmeup.body.params import BodyParams
from dressmeup.data import layout
from dressmeup.data.manifest import read_manifest
from dressmeup.data.parts import withheld_fields, withheld_message
from dressmeup.errors import InputError
from dressmeup.io.jsonio import read_json
from dressmeup.io.mesh import load_mesh

ID_FIELDS = ("sample_id", "subject_id", "garment_id", "pose_id", "category", "garment_type",
             "split")


@dataclass
class GarmentMesh:
    """A garment mesh.

    Attributes
    ----------
    vertices : (n, 3) float64, metres.
    faces : (m, 3) int64.
    uv : (k, 2) float64 or None; per corner when ``uv_faces`` is given, else per vertex.
    uv_faces : (m, 3) int64 or None.
    texture_path : path of the texture image or None.
    texture_image : (h, w, 3) uint8 texture held in memory (row 0 = top, as in a PNG), for
        readers whose texture is not an image file (4D-DRESS atlases), or None.
    """

    vertices: np.ndarray
    faces: np.ndarray
    uv: np.ndarray | None = None
    uv_faces: np.ndarray | None = None
    texture_path: Path | None = None
    texture_image: np.ndarray | None = None


_PLY_VERTEX = ["property double x", "property double y", "property double z"]
_PLY_FACE = "property list uchar int vertex_indices"
_PLY_TEX = "property list uchar double texcoord"


def _plausible_size(header: bytes, body_bytes: int) -> bool:
    """True when the body is exactly what the writer's layout needs for the declared counts
    (so a huge or damaged file is never read whole on this fast path)."""
    n = m = None
    has_uv = b"property list uchar double texcoord" in header
    for ln in header.decode("ascii", "replace").splitlines():
        parts = ln.split()
        if len(parts) == 3 and parts[0] == "element":
            try:
                if parts[1] == "vertex":
                    n = int(parts[2])
                elif parts[1] == "face":
                    m = int(parts[2])
            except ValueError:
                return False
    if n is None or m is None:
        return False
    return body_bytes == 24 * n + (13 + (49 if has_uv else 0)) * m


def read_dataset_ply(path: str | os.PathLike) -> GarmentMesh | None:
    """Fast path for the exact binary PLY layout that :func:`dressmeup.io.mesh.save_mesh`
    writes (float64 xyz; triangles; optional per-corner ``texcoord``): one
    ``numpy.frombuffer`` per element. Returns None for any other layout (the caller then
    uses the general reader), and validates like it (finite, faces in range, non-empty).
    """
    path = Path(path)
    if not path.is_file():
        return None  # a folder, FIFO or missing file: the general reader names the fault
    with open(path, "rb") as fh:
        head = fh.read(65536)
    end = head.find(b"end_header\n")
    if not head.startswith(b"ply\n") or end < 0:
        return None  # not this layout: the general reader checks the header and names faults
    data = head
    if path.stat().st_size > len(head):
        if not _plausible_size(head[:end], path.stat().st_size - end - len(b"end_header\n")):
            return None
        with open(path, "rb") as fh:
            data = fh.read()
    lines = [ln.strip() for ln in data[:end].decode("ascii", "replace").splitlines()[1:]]
    tex = None
    for ln in lines:
        if ln.lower().startswith("comment texturefile"):
            tex = ln.split(None, 2)[2].strip() if len(ln.split(None, 2)) == 3 else None
    body = [ln for ln in lines if ln and not ln.startswith(("comment", "obj_info"))]
    if len(body) not in (7, 8) or body[0] != "format binary_little_endian 1.0":
        return None
    if not (body[1].startswith("element vertex ") and body[5].startswith("element face ")):
        return None
    if body[2:5] != _PLY_VERTEX or body[6] != _PLY_FACE:
        return None
    has_uv = len(body) == 8
    if has_uv and body[7] != _PLY_TEX:
        return None
    try:
        n, m = int(body[1].split()[2]), int(body[5].split()[2])
    except ValueError:
        return None
    fdt = [("n", "u1"), ("i", "<i4", (3,))] + ([("nt", "u1"), ("t", "<f8", (6,))]
                                               if has_uv else [])
    fdt = np.dtype(fdt)
    start = end + len(b"end_header\n")
    if len(data) < start + 24 * n + fdt.itemsize * m or n == 0 or m == 0:
        return None
    V = np.frombuffer(data, "<f8", 3 * n, start).reshape(n, 3).copy()
    rec = np.frombuffer(data, fdt, m, start + 24 * n)
    if np.any(rec["n"] != 3) or (has_uv and np.any(rec["nt"] != 6)):
        return None
    F = rec["i"].astype(np.int64)
    if not np.isfinite(V).all() or F.min() < 0 or F.max() >= n:
        return None  # let the general reader raise its precise error
    uv = uvf = None
    if has_uv:
        uv = rec["t"].reshape(-1, 2).copy()
        uvf = np.arange(3 * m, dtype=np.int64).reshape(m, 3)
    tpath = None
    if tex:
        cand = path.parent / tex
        tpath = cand if cand.is_file() else None
    return GarmentMesh(V, F, uv, uvf, tpath)


class Sample:
    """One garment worn in one pose: ids, category fields and lazy loaders.

    Parameters
    ----------
    row : manifest row (at least the :data:`ID_FIELDS`).
    root : dataset root the row's paths are relative to (None for adapter samples).
    loaders : optional ``{"garment": f, "body": f, "scan": f}`` overriding file loading
        (adapters); each ``f`` takes no argument.
    """

    def __init__(self, row: dict[str, Any], root: str | os.PathLike | None = None,
                 loaders: dict[str, Callable[[], Any]] | None = None) -> None:
        self.row = dict(row)
        self.root = None if root is None else Path(root)
        self._loaders = dict(loaders or {})
        for f in ID_FIELDS:
            if f not in self.row:
                raise InputError(f"sample row lacks field {f!r}: {self.row}")

    sample_id = property(lambda self: self.row["sample_id"])
    subject_id = property(lambda self: self.row["subject_id"])
    garment_id = property(lambda self: self.row["garment_id"])
    pose_id = property(lambda self: self.row["pose_id"])
    category = property(lambda self: self.row["category"])
    garment_type = property(lambda self: self.row["garment_type"])
    split = property(lambda self: self.row["split"])

    def __repr__(self) -> str:
        return (f"Sample({self.sample_id!r}, garment={self.garment_id!r}, pose={self.pose_id!r}, "
                f"{self.category}/{self.garment_type}, split={self.split!r})")

    def path(self, field: str) -> Path | None:
        """Absolute path of ``<field>_path`` (``garment``, ``texture``, ``scan``, ``body``)."""
        rel = self.row.get(f"{field}_path")
        if rel is None or (isinstance(rel, float) and np.isnan(rel)):
            return None
        if self.root is None:
            return Path(rel)
        return layout.resolve_inside(self.root, rel, f"{self.sample_id}.{field}_path")

    def _check_withheld(self, field: str) -> None:
        """Raise when this row of a public part withholds ``field``."""
        if field in withheld_fields(self.row):
            raise InputError(withheld_message(self.root, f"the {field} of sample "
                                                         f"{self.sample_id}"))

    def garment(self) -> GarmentMesh:
        """Load the garment mesh (vertices in metres, UVs and texture when present)."""
        if "garment" in self._loaders:
            return self._loaders["garment"]()
        p = self.path("garment")
        if p is None:
            self._check_withheld("garment")
            raise InputError(f"sample {self.sample_id}: no garment file")
        fast = read_dataset_ply(p)
        if fast is not None:
            return fast

        m = load_mesh(p)
        return GarmentMesh(m.vertices, m.faces, m.uv, m.uv_faces, m.texture_path)

    def body(self) -> Any:
        """Load the registered body parameters (:class:`dressmeup.body.BodyParams`) or None."""
        if "body" in self._loaders:
            return self._loaders["body"]()
        p = self.path("body")
        if p is None:
            self._check_withheld("body")
            return None

        return BodyParams.load(p)

    def scan(self) -> tuple[np.ndarray, np.ndarray] | None:
        """Load the clothed scan as ``(V (n,3) float64, F (m,3) int64)``, or None."""
        if "scan" in self._loaders:
            return self._loaders["scan"]()
        p = self.path("scan")
        if p is None:
            self._check_withheld("scan")
            return None

        m = load_mesh(p)
        return m.vertices, m.faces


#: Retargeting tracks (docs/spec.md section 4.2: the three kinds of pairs of a garment worn by several subjects).
TRACKS = ("re-pose", "re-shape", "cross")


def pair_track(source: Sample, target: Sample) -> str:
    """Track of a pair of samples of one garment.

    ``re-pose``: same subject, other pose; ``re-shape``: other subject, same pose id (the
    generator gives identical pose arrays to every subject); ``cross``: other subject and other
    pose.
    """
    if source.subject_id == target.subject_id:
        return "re-pose"
    return "re-shape" if source.pose_id == target.pose_id else "cross"


@dataclass(frozen=True)
class RetargetPair:
    """A retargeting task: move ``source``'s garment onto ``target``'s body (same garment).

    Attributes
    ----------
    pair_id : ``f"{source.sample_id}__to__{target.sample_id}"``.
    source, target : two different samples of the same garment (another pose and/or another
        wearer); ``target.garment()`` is the ground truth.
    """

    pair_id: str
    source: Sample
    target: Sample

    @property
    def track(self) -> str:
        """``re-pose``, ``re-shape`` or ``cross`` (see :func:`pair_track`)."""
        return pair_track(self.source, self.target)


def make_pairs(samples: Sequence[Sample]) -> list[RetargetPair]:
    """Every ordered pair of distinct samples of each garment, sorted by pair id.

    A garment worn by one subject (DressMeUp, generator 1.x) gives every ordered pair of its
    poses (docs/spec.md section 4); a garment worn by several subjects (generator 2.x) also gives
    the re-shape and cross pairs (:attr:`RetargetPair.track`). Pairs never cross splits: a
    garment whose samples disagree on the split is an error.
    """
    by_garment: dict[str, list[Sample]] = {}
    for s in samples:
        by_garment.setdefault(s.garment_id, []).append(s)
    pairs = []
    for g, group in by_garment.items():
        if len({s.split for s in group}) > 1:
            raise InputError(f"garment {g!r} has samples in several splits "
                             f"{sorted({s.split for s in group})}; splits go by garment")
        group = sorted(group, key=lambda s: (s.subject_id, s.pose_id))
        for a in group:
            for b in group:
                if (a.subject_id, a.pose_id) != (b.subject_id, b.pose_id):
                    pairs.append(RetargetPair(f"{a.sample_id}__to__{b.sample_id}", a, b))
    return sorted(pairs, key=lambda p: p.pair_id)


class Dataset:
    """A DressMeUp-style dataset on disk (docs/spec.md section 3).

    Parameters
    ----------
    root : dataset folder holding ``dataset.json`` and ``manifest.parquet``.

    Raises
    ------
    FileNotFoundError
        When ``root`` has no manifest.
    InputError
        When the manifest is damaged or of an unsupported version.
    """

    def __init__(self, root: str | os.PathLike, _table: Any = None) -> None:
        self.root = Path(root)
        if _table is None:
            mpath = self.root / layout.MANIFEST
            if not mpath.is_file():
                raise FileNotFoundError(f"{mpath} not found: {self.root} is not a dressmeup "
                                        "dataset (run 'dressmeup synth' to make one)")
            _table = read_manifest(mpath).to_pandas()
            dup = _table["sample_id"][_table["sample_id"].duplicated()].unique()
            if len(dup):
                raise InputError(f"{mpath}: duplicate sample_id {', '.join(map(str, dup[:5]))}"
                                 " (each sample must appear once; run 'dressmeup "
                                 "validate-dataset' for every problem)")
        self._df = _table.reset_index(drop=True)

    @property
    def info(self) -> dict[str, Any]:
        """The contents of ``dataset.json`` (empty when absent).

        Raises
        ------
        InputError
            When ``dataset.json`` is not UTF-8 JSON fitting the dataset schema.
        """

        p = self.root / layout.DATASET_JSON
        return read_json(p, "dataset") if p.is_file() else {}

    @property
    def manifest(self):
        """The manifest rows of this (possibly filtered) view as a ``pandas.DataFrame`` copy."""
        return self._df.copy()

    def __len__(self) -> int:
        return len(self._df)

    def __getitem__(self, index: int | str) -> Sample:
        """A sample by position or by ``sample_id``."""
        if isinstance(index, str):
            hit = np.flatnonzero(self._df["sample_id"].to_numpy() == index)
            if len(hit) == 0:
                raise KeyError(f"no sample {index!r} in {self.root}")
            index = int(hit[0])
        if not -len(self) <= index < len(self):
            raise IndexError(f"sample index {index} out of range for {len(self)} samples")
        return Sample(self._df.iloc[index].to_dict(), self.root)

    def __iter__(self) -> Iterator[Sample]:
        for i in range(len(self)):
            yield self[i]

    def __repr__(self) -> str:
        return f"Dataset({str(self.root)!r}, {len(self)} samples)"

    def filter(self, split: str | Sequence[str] | None = None,
               category: str | Sequence[str] | None = None,
               subject: str | Sequence[str] | None = None,
               garment: str | Sequence[str] | None = None,
               pose: str | Sequence[str] | None = None,
               garment_type: str | Sequence[str] | None = None) -> Dataset:
        """A view with only the matching samples (each argument: one value or a list)."""
        df = self._df
        for col, val in (("split", split), ("category", category), ("subject_id", subject),
                         ("garment_id", garment), ("pose_id", pose),
                         ("garment_type", garment_type)):
            if val is None:
                continue
            vals = [val] if isinstance(val, str) else list(val)
            df = df[df[col].isin(vals)]
        return Dataset(self.root, _table=df)

    def samples(self) -> list[Sample]:
        """All samples of this view."""
        return list(self)

    def retarget_pairs(self, split: str | None = None) -> list[RetargetPair]:
        """Every ordered pair of poses of each garment in ``split`` (all splits when None).

        Returns
        -------
        list of :class:`RetargetPair` sorted by ``pair_id``; 5 poses of a garment give 20 pairs.
        """
        view = self if split is None else self.filter(split=split)
        return make_pairs(view.samples())

    def torch(self, load_body: bool = True, load_scan: bool = False):
        """A ``torch.utils.data.Dataset`` over this view
        (see :class:`dressmeup.data.torch_dataset.TorchDataset`)."""
        # heavy: torch (~1.1 s to import)
        from dressmeup.data.torch_dataset import TorchDataset

        return TorchDataset(self, load_body=load_body, load_scan=load_scan)
