"""The built-in synthetic dataset generator (see :func:`generate_dataset`)."""

from __future__ import annotations

from dressmeup.data.synth.drape import DrapeSettings, drape
from dressmeup.data.synth.generate import GENERATOR_VERSION, generate_dataset
from dressmeup.data.synth.stats import summarize_stats

__all__ = ["DrapeSettings", "GENERATOR_VERSION", "drape", "generate_dataset", "summarize_stats"]
