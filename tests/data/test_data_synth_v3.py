"""Generator 2.1.0: one garment on several bodies, identical poses, splits,
pinned manifests that a fresh run (other thread settings, kernels, float32 rounding)
regenerates exactly."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from dressmeup import runs
from dressmeup.bench import load_edition
from dressmeup.bench.tasks.common import manifest_sha256
from dressmeup.data import Dataset
from dressmeup.data.synth.common import SUBJECTS, plan_2x

#: generator 2.1.0's data and their pins: what this module tests is that dependence on the
#: CPU's float kernels (a known other machine's manifest is an expected failure)
pytestmark = pytest.mark.cpu_kernels

TINY = "synth-retarget-tiny-v3"


@pytest.fixture(scope="module")
def tiny():
    from dressmeup.cache import cache_dir

    ed = load_edition(TINY)
    return runs.build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}")


def test_plan_of_the_full_edition():
    ed = load_edition("synth-retarget-v3")
    p = ed.dataset.params
    plan = plan_2x(p["subjects"], p["poses"], tuple(p["garments_per_split"]), ed.dataset.seed)
    by = {}
    for g in plan["garments"].values():
        by.setdefault(g["category"], []).append(g["split"])
    assert sorted(by) == ["bottomwear", "dress", "topwear"]
    for splits in by.values():
        assert (splits.count("train"), splits.count("val"), splits.count("test")) == (6, 2, 4)
    # garments differ: no two share type and parameters
    keys = {json.dumps([g["type"], g["params"]], sort_keys=True)
            for g in plan["garments"].values()}
    assert len(keys) == len(plan["garments"])
    # the subjects span the phenotype range: weight and height at both extremes
    shapes = np.array([s["shape"] for s in plan["subjects"].values()])
    for col in (3, 4):  # weight, height
        assert shapes[:, col].min() == 0.0 and shapes[:, col].max() == 1.0
    assert len({tuple(s) for _, s in SUBJECTS}) == len(SUBJECTS)


def test_tiny_garments_are_worn_by_every_subject_in_identical_poses(tiny):
    ds = Dataset(tiny)
    m = ds.manifest
    assert m["topology_shared"].all()
    for _, grp in m.groupby("garment_id"):
        assert grp["subject_id"].nunique() == 2 and grp["garment_faces"].nunique() == 1
    for pid, grp in m.groupby("pose_id"):
        poses = [ds[s].body().pose for s in grp["sample_id"]]
        assert all(np.array_equal(poses[0], p) for p in poses[1:]), pid
        shapes = {tuple(ds[s].body().shape) for s in grp["sample_id"]}
        assert len(shapes) == 2


def test_tiny_garments_stay_outside_the_body(tiny):
    stats = [json.loads(p.read_text()) for p in (tiny / "generator" / "stats").glob("*.json")]
    assert stats
    # every vertex ends at least the clearance (3 mm) outside the closest body surface; the
    # few that still test inside (winding number) sit where the body intersects itself (a
    # heavy body's arm and torso): 3 mm outside one part is inside the other
    assert min(s["min_signed_distance_m"] for s in stats) > -0.0035


def test_tiny_manifest_is_the_pinned_one(tiny, other_data):
    known = other_data(TINY, tiny)  # an unknown manifest fails here
    if known:  # a known reproducibility bug, reported as such (docs/synthetic-data.md)
        pytest.xfail(f"this machine generates other data: {known}")
    assert manifest_sha256(tiny) == load_edition(TINY).dataset.expected_manifest_sha256


def _regenerate(edition: str, out, env: dict) -> str:
    code = textwrap.dedent(f"""
        from dressmeup.runs import build_data
        build_data({edition!r}, {str(out)!r})
    """)
    subprocess.run([sys.executable, "-c", code], check=True, env={**os.environ, **env},
                   capture_output=True)
    return manifest_sha256(out)


#: a "different machine" as far as one machine can emulate it: thread pools of another size
#: and torch's portable (non-SIMD) kernels
OTHER_MACHINE = {"OMP_NUM_THREADS": "2", "MKL_NUM_THREADS": "2", "OPENBLAS_NUM_THREADS": "2",
                 "ATEN_CPU_CAPABILITY": "default", "DRESSMEUP_NO_PROGRESS": "1"}


def test_tiny_regenerates_identically_with_other_threads_and_kernels(tiny, tmp_path):
    # the same data as this machine's default run (the pinned manifest on the machine that
    # pinned it: test_tiny_manifest_is_the_pinned_one)
    assert _regenerate(TINY, tmp_path / "tiny", OTHER_MACHINE) == manifest_sha256(tiny)


#: sitecustomize for the generator's worker processes: shifts the float32 frame of
#: ``geometry.proximity.closest_points`` (open3d's BVH) by FRAME_SHIFT metres, so the BVH rounds
#: every coordinate differently, as another CPU's code may; the float64 arithmetic is unchanged
SHIFT_FLOAT32_FRAME = textwrap.dedent("""
    import inspect, os, textwrap
    import dressmeup.geometry.proximity as px
    src = textwrap.dedent(inspect.getsource(px.closest_points))
    line = "center = V.mean(axis=0)\\n"
    assert src.count(line) == 1, "closest_points changed: update the test's float32 shift"
    src = src.replace(line, "center = V.mean(axis=0) + " + os.environ["FRAME_SHIFT"] + "\\n")
    ns = dict(vars(px))
    exec(compile(src, px.__file__, "exec"), ns)
    px.closest_points = ns["closest_points"]
""")


def test_tiny_does_not_depend_on_the_float32_rounding_of_closest_faces(tiny, tmp_path):
    """Generator 2.0.0 let the BVH's float32 pick decide among equally close faces, and a
    1e-7 m shift changed the data (as another CPU did); 2.1.0 decides in float64."""
    (tmp_path / "site").mkdir()
    (tmp_path / "site" / "sitecustomize.py").write_text(SHIFT_FLOAT32_FRAME)
    path = os.pathsep.join([str(tmp_path / "site"), os.environ.get("PYTHONPATH", "")])
    env = {"PYTHONPATH": path, "FRAME_SHIFT": "1e-7", "DRESSMEUP_NO_PROGRESS": "1"}
    assert _regenerate(TINY, tmp_path / "tiny", env) == manifest_sha256(tiny)


@pytest.mark.slow
def test_mini_regenerates_identically(tmp_path, other_data):
    """The demo's edition (anny body): about 8 CPU minutes."""
    ed = "synth-retarget-mini-v3"
    expected = load_edition(ed).dataset.expected_manifest_sha256
    got = _regenerate(ed, tmp_path / "mini", OTHER_MACHINE)
    known = other_data(ed, tmp_path / "mini")  # an unknown manifest fails here
    if known:  # a known reproducibility bug, reported as such (docs/synthetic-data.md)
        pytest.xfail(f"this machine generates other data: {known}")
    assert got == expected


def test_generator_2_0_0_is_refused_with_the_reason(tmp_path):
    from dressmeup.data.synth import generate_dataset
    from dressmeup.errors import InputError

    with pytest.raises(InputError, match="2.1.0.*float32 rounding"):
        generate_dataset(tmp_path / "d", version="2.0.0", subjects=1, poses=1)
    assert not (tmp_path / "d").exists()
