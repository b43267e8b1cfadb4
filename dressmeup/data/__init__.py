"""dressmeup.data: the dataset layout, Parquet manifest, Dataset API, adapters, synthetic data.

>>> from dressmeup.data import Dataset                  # doctest: +SKIP
>>> ds = Dataset("path/to/dataset")                      # doctest: +SKIP
>>> pairs = ds.retarget_pairs("test")                    # doctest: +SKIP
"""

from __future__ import annotations

from dressmeup.data.dataset import Dataset, GarmentMesh, RetargetPair, Sample
from dressmeup.data.splits import split_by_garment
from dressmeup.data.synth import generate_dataset as _gen
from dressmeup.data.validate import ValidationReport, validate_dataset
from dressmeup.data.writer import DatasetWriter

__all__ = ["Dataset", "DatasetWriter", "GarmentMesh", "RetargetPair", "Sample", "TorchDataset",
           "ValidationReport", "generate_dataset", "split_by_garment", "validate_dataset"]


def __getattr__(name: str):
    if name == "TorchDataset":  # imports torch: only on demand
        # heavy: torch (~1.1 s to import)
        from dressmeup.data.torch_dataset import TorchDataset

        return TorchDataset
    raise AttributeError(f"module 'dressmeup.data' has no attribute {name!r}")


def generate_dataset(*args, **kwargs):
    """Build the synthetic dataset (see :func:`dressmeup.data.synth.generate_dataset`)."""

    return _gen(*args, **kwargs)
