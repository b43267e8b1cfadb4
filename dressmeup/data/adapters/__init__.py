"""Readers of published garment-dataset layouts into the same :class:`~dressmeup.data.Sample`
API: CLOTH3D, THuman2.x and 4D-DRESS (see docs/dataset-format.md for what was verified)."""

from __future__ import annotations

from dressmeup.data.adapters.base import SampleCollection
from dressmeup.data.adapters.cloth3d import read_cloth3d, read_pc2, write_pc2
from dressmeup.data.adapters.dress4d import read_4ddress
from dressmeup.data.adapters.thuman import read_thuman

__all__ = ["SampleCollection", "read_4ddress", "read_cloth3d", "read_pc2", "read_thuman",
           "write_pc2"]
