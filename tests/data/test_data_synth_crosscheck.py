"""The Blender path of benchmarks/studies/generator4_crosscheck.py: a small sheet falls on a
box with Blender's cloth (skipped without bpy).

Blender runs in a fresh interpreter: bpy must be imported before pymeshlab / open3d (another
Embree library hides its symbols), which other test modules of the same session load."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

if importlib.util.find_spec("bpy") is None:
    pytest.skip("bpy (the crosscheck extra) is not installed", allow_module_level=True)

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "studies" / "generator4_crosscheck.py"
RUN = """
import json, sys, importlib.util
import numpy as np
spec = importlib.util.spec_from_file_location("xcheck", sys.argv[1])
x = importlib.util.module_from_spec(spec)
spec.loader.exec_module(x)
from dressmeup.data.synth.dynamics import DynamicsSettings
d = np.load(sys.argv[2])
frames = int(d["frames"])
out, info = x.blender_cloth(d["V"], d["F"], [d["B"]] * (frames + 1), d["BF"], d["up"],
                            DynamicsSettings(), 1.0 / 30.0, d["support"],
                            [d["V"]] * (frames + 1), quality=5, collision_quality=2)
np.save(sys.argv[3], out)
print(json.dumps({k: v for k, v in info.items() if k != "settings"}))
"""


def _sheet(n: int = 13, size: float = 0.36, height: float = 0.08):
    """An ``n x n`` grid sheet (y up) centred above the origin, triangulated."""
    t = np.linspace(-size / 2, size / 2, n)
    x, z = np.meshgrid(t, t, indexing="ij")
    V = np.stack([x.ravel(), np.full(n * n, height), z.ravel()], axis=1)
    i = np.arange(n - 1)[:, None] * n + np.arange(n - 1)[None, :]
    a, b, c, d = i.ravel(), i.ravel() + 1, i.ravel() + n, i.ravel() + n + 1
    F = np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])
    return V, F


def _box(half: float = 0.1):
    """A box ``2 half`` wide, its top face at y = 0, outward triangles."""
    V = np.array([[x, y, z] for x in (-half, half) for y in (-2 * half, 0.0)
                  for z in (-half, half)], np.float64)
    F = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1],
                  [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    return V, F


def test_sheet_falls_on_box_keeps_order_and_pin(tmp_path):
    V, F = _sheet()
    B, BF = _box()
    frames = 12
    support = np.zeros(len(V))
    support[0] = 1.0  # one corner (over the floor, outside the box) pinned where it is
    np.savez(tmp_path / "case.npz", V=V, F=F, B=B, BF=BF, up=np.array([0.0, 1.0, 0.0]),
             support=support, frames=frames)
    res = subprocess.run([sys.executable, "-c", RUN, str(SCRIPT), str(tmp_path / "case.npz"),
                          str(tmp_path / "out.npy")], capture_output=True, text=True,
                         timeout=120)
    assert res.returncode == 0, res.stderr[-2000:]
    info = json.loads(res.stdout.strip().splitlines()[-1])
    out = np.load(tmp_path / "out.npy")
    assert out.shape == V.shape and info["frames"] == frames and info["pinned"] == 1
    on_top = (np.abs(V[:, 0]) < 0.08) & (np.abs(V[:, 2]) < 0.08)
    # the middle fell and lies on the box's top, outside it (Blender's contact distance)
    assert np.all(out[on_top, 1] < 0.02)
    assert np.all(out[on_top, 1] > 0.0)
    # the free corner opposite the pin hangs over the side, below the top
    assert out[-1, 1] < -0.01
    # the pinned corner stays near its anchor (an elastic pin); the order is kept: the flat
    # middle keeps its layout (it may slide as a whole: no friction) and every edge keeps
    # about its length (a permuted read-back would not)
    assert np.linalg.norm(out[0] - V[0]) < 0.03
    slide = out[on_top][:, [0, 2]] - V[on_top][:, [0, 2]]
    assert np.abs(slide - slide.mean(axis=0)).max() < 0.005
    E = np.unique(np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), 1), axis=0)
    rest = np.linalg.norm(V[E[:, 0]] - V[E[:, 1]], axis=1)
    strain = np.abs(np.linalg.norm(out[E[:, 0]] - out[E[:, 1]], axis=1) / rest - 1)
    assert np.median(strain) < 0.05 and strain.max() < 0.3
