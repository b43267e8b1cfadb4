"""Shared pieces of the format adapters: an in-memory sample collection with the same API
as :class:`dressmeup.data.Dataset`, and a restricted pickle loader."""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dressmeup.body.safe_pickle import safe_load_pickle
from dressmeup.data.dataset import ID_FIELDS, RetargetPair, Sample, make_pairs
from dressmeup.errors import InputError


def clean_id(text: str) -> str:
    """Make a valid id from foreign names: any other character becomes ``_``."""
    out = re.sub(r"[^A-Za-z0-9_-]", "_", str(text))
    return out or "_"


def load_pickle(path) -> Any:
    """Load a pickle of plain numpy data without running code (reuses the body stage's
    restricted unpickler)."""

    return safe_load_pickle(path)


@dataclass
class ReadReport:
    """What an adapter found and what it skipped, for users to check an import at a glance.

    Attributes
    ----------
    dataset : adapter name (``cloth3d``, ``4ddress``, ``thuman``).
    root : folder read.
    skipped : ``(what, why)`` for every sequence, frame or garment left out.
    notes : conventions applied that a user should know (e.g. a gender assumed).
    """

    dataset: str
    root: str
    skipped: list[tuple[str, str]] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def skip(self, what: str, why: str) -> None:
        """Record one thing left out and the reason."""
        self.skipped.append((str(what), str(why)))

    def note(self, text: str) -> None:
        """Record a convention applied (each text once)."""
        if text not in self.notes:
            self.notes.append(text)

    def summary(self, samples: Sequence[Sample], max_skipped: int = 20) -> str:
        """Counts per subject / garment / frame, then the skipped items grouped by reason."""
        subj = Counter(s.subject_id for s in samples)
        garm = {s.garment_id for s in samples}
        poses = {(s.garment_id, s.pose_id) for s in samples}
        cats = Counter(s.category for s in samples)
        lines = [f"{self.dataset} at {self.root}: {len(samples)} samples, {len(subj)} subjects, "
                 f"{len(garm)} garments, {len(poses)} garment-frames; categories: "
                 + (", ".join(f"{k} {v}" for k, v in sorted(cats.items())) or "none")]
        for sid, n in sorted(subj.items()):
            g = sorted({s.garment_id for s in samples if s.subject_id == sid})
            lines.append(f"  subject {sid}: {n} samples, garments {', '.join(g)}")
        if self.skipped:
            by_reason = Counter(why for _, why in self.skipped)
            lines.append(f"skipped {len(self.skipped)}:")
            for why, n in by_reason.most_common():
                ex = [w for w, y in self.skipped if y == why][:3]
                lines.append(f"  {n} x {why} (e.g. {', '.join(ex)})")
        for n in self.notes:
            lines.append(f"note: {n}")
        return "\n".join(lines)


class SampleCollection:
    """Samples read by an adapter, with the :class:`~dressmeup.data.Dataset` API
    (``len``, indexing by position or id, iteration, ``filter``, ``retarget_pairs``,
    ``manifest`` as pandas) and the adapter's :class:`ReadReport` as ``report``."""

    def __init__(self, samples: Sequence[Sample], source: str = "",
                 report: ReadReport | None = None) -> None:
        self._samples = list(samples)
        self.source = source
        self.report = report if report is not None else ReadReport("", source)

    def __len__(self) -> int:
        return len(self._samples)

    def __iter__(self) -> Iterator[Sample]:
        return iter(self._samples)

    def __getitem__(self, index: int | str) -> Sample:
        if isinstance(index, str):
            for s in self._samples:
                if s.sample_id == index:
                    return s
            raise KeyError(f"no sample {index!r}")
        return self._samples[index]

    def __repr__(self) -> str:
        return f"SampleCollection({self.source!r}, {len(self)} samples)"

    @property
    def manifest(self):
        """The samples' rows (ids, category fields and whatever the adapter adds) as pandas."""
        # heavy: pandas (~0.4 s to import)
        import pandas as pd

        return pd.DataFrame([s.row for s in self._samples])

    def filter(self, split=None, category=None, subject=None, garment=None, pose=None,
               garment_type=None) -> SampleCollection:
        """Samples matching every given value (one value or a list)."""
        out = self._samples
        for attr, val in (("split", split), ("category", category), ("subject_id", subject),
                          ("garment_id", garment), ("pose_id", pose),
                          ("garment_type", garment_type)):
            if val is None:
                continue
            vals = {val} if isinstance(val, str) else set(val)
            out = [s for s in out if s.row[attr] in vals]
        return SampleCollection(out, self.source, self.report)

    def samples(self) -> list[Sample]:
        """All samples."""
        return list(self._samples)

    def retarget_pairs(self, split: str | None = None) -> list[RetargetPair]:
        """Ordered pose pairs of each garment (see :func:`dressmeup.data.dataset.make_pairs`)."""
        view = self if split is None else self.filter(split=split)
        return make_pairs(view.samples())


def make_row(**fields: Any) -> dict[str, Any]:
    """A sample row with every :data:`ID_FIELDS` entry present (defaults: split ``test``)."""
    row = {"split": "test", **fields}
    missing = [f for f in ID_FIELDS if f not in row]
    if missing:
        raise InputError(f"row lacks {missing}")
    return row


def as_array(value: Any, name: str, source: str) -> np.ndarray:
    """A float64 array from pickled data (numpy, lists, or torch tensors saved as arrays)."""

    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{source}: field {name!r} is not numeric ({exc})") from exc
