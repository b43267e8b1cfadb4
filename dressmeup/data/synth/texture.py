"""Procedural garment textures (stripes, checks, dots or mottled plain) in UV space."""

from __future__ import annotations

import colorsys

import numpy as np

PATTERNS = ("stripes", "checks", "dots", "plain")


def procedural_texture(rng: np.random.Generator, size: int = 256) -> tuple[np.ndarray, str]:
    """A seeded ``(size, size, 3) uint8`` texture and its pattern name."""
    pattern = PATTERNS[int(rng.integers(len(PATTERNS)))]
    h = rng.uniform()
    c1 = np.array(colorsys.hsv_to_rgb(h, rng.uniform(0.35, 0.8), rng.uniform(0.45, 0.9)))
    c2 = np.array(colorsys.hsv_to_rgb((h + rng.uniform(0.3, 0.7)) % 1.0, rng.uniform(0.2, 0.7),
                                      rng.uniform(0.7, 1.0)))
    v, u = np.mgrid[0:size, 0:size] / size
    freq = rng.uniform(8, 24)
    if pattern == "stripes":
        a = rng.uniform(0, np.pi)
        m = (np.sin(2 * np.pi * freq * (u * np.cos(a) + v * np.sin(a))) > 0.3).astype(float)
    elif pattern == "checks":
        m = ((np.floor(u * freq) + np.floor(v * freq)) % 2).astype(float)
    elif pattern == "dots":
        fu, fv = (u * freq) % 1 - 0.5, (v * freq) % 1 - 0.5
        m = (fu**2 + fv**2 < 0.09).astype(float)
    else:
        m = np.zeros_like(u)
    noise = rng.normal(0, 0.03, size=(size, size, 1))
    img = c1 * (1 - m[..., None]) + c2 * m[..., None] + noise
    return (np.clip(img, 0, 1) * 255).astype(np.uint8), pattern
