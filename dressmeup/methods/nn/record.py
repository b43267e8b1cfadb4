"""What a training record says of the machine that trained a network."""

from __future__ import annotations

import os
from typing import Any

from dressmeup.bench.scoring.provenance import cpu_model


def training_machine() -> dict[str, Any]:
    """The machine of a training run, for its record.

    Returns
    -------
    dict with ``cpu`` (the processor's model name, :func:`~dressmeup.bench.scoring.provenance.cpu_model`),
    ``cores`` (logical cores of the machine), ``torch`` (version string) and ``threads``
    (torch's intra-op threads in this process).
    """
    # heavy: torch (~1.1 s to import)
    import torch

    return {"cpu": cpu_model(), "cores": os.cpu_count(), "torch": torch.__version__,
            "threads": torch.get_num_threads()}
