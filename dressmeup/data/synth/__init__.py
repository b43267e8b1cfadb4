"""The built-in synthetic dataset generator (see :func:`generate_dataset`)."""

from __future__ import annotations

from dressmeup.data.synth.config import GENERATOR_VERSION, SynthConfig, synth_config
from dressmeup.data.synth.drape import DrapeSettings, drape
from dressmeup.data.synth.generate import generate_dataset
from dressmeup.data.synth.stats import summarize_stats

__all__ = ["DrapeSettings", "GENERATOR_VERSION", "SynthConfig", "drape", "generate_dataset",
           "summarize_stats", "synth_config"]
