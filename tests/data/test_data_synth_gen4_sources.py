"""Generator 4's source rule: a garment's source is its first target on the design body
whose motion succeeds; tracks are relations to it; without one the garment has no sample."""

from __future__ import annotations

import json

import numpy as np
import pytest

import dressmeup.data.synth.dataset4 as d4
from dressmeup.data import Dataset
from dressmeup.data.synth.config import synth_config
from dressmeup.data.synth.dataset4 import Gen4Config, generate_gen4, make_plan, track_of
from dressmeup.data.synth.generator4 import DressedSample, SimulationFailed

DESIGN = {"bodies": [6, 0, 0], "poses_per_family": [2, 0, 0], "garments": [1, 0, 0],
          "categories": ["bottomwear"], "families": ["standing", "walking"], "fits": ["loose"],
          "targets": {"re-pose": [2, 0, 0], "re-shape": [1, 0, 0], "cross": [1, 0, 0]}}


def _config():
    return synth_config(version="4.0.0", body_model="procedural", plan=DESIGN,
                        splits=("train",), edge_length=0.08, write_scan=False,
                        texture_size=8)


@pytest.fixture
def fake_dress(monkeypatch):
    """Dressing without physics, in this process: ``fails`` holds the ``(shape, pose)``
    bytes whose motion fails; ``calls`` every ``(shape, pose)`` dressed."""
    state = {"fails": set(), "calls": []}

    def dress(kit, built, shape, pose, sim):
        key = (np.asarray(shape, np.float64).tobytes(), np.asarray(pose, np.float64).tobytes())
        state["calls"].append(key)
        if key in state["fails"]:
            raise SimulationFailed("sub-step budget spent")
        stats = {"inside_area_pct": 0.0, "self_intersecting_faces": 0,
                 "unconverged_frames": 0, "intersection_free": True, "cpu_s": 0.0}
        return DressedSample(built.vertices + 0.001, np.zeros((3, 3)), stats)

    monkeypatch.setattr(d4, "dress", dress)
    monkeypatch.setattr(d4, "run_ready_jobs", serial_ready_jobs)
    return state


def serial_ready_jobs(job, ready, workers=1, executor=None):
    """:func:`~dressmeup.data.synth.jobs.run_ready_jobs` in this process, one at a time."""
    waiting = list(ready())
    while waiting:
        waiting.sort(key=lambda pi: pi[0])
        item = waiting.pop(0)[1]
        yield item, job(item)
        waiting += ready()


def _key(plan, sid, pid):
    return (np.asarray(plan["subjects"][sid]["shape"], np.float64).tobytes(),
            np.asarray(plan["poses"][pid]["pose"], np.float64).tobytes())


def test_track_of_is_the_relation_to_the_source():
    assert track_of(("S1", "P1"), ("S1", "P1")) == "source"
    assert track_of(("S1", "P2"), ("S1", "P1")) == "re-pose"
    assert track_of(("S2", "P1"), ("S1", "P1")) == "re-shape"
    assert track_of(("S2", "P2"), ("S1", "P1")) == "cross"


def test_a_failed_source_passes_to_the_first_re_pose_target(tmp_path, fake_dress):
    c = _config()
    plan = make_plan(c, Gen4Config.from_synth(c))
    (gid, g), = plan["garments"].items()
    src, rp1, rp2, rs, cr = g["targets"]
    assert (src.track, rp1.track, rs.track) == ("source", "re-pose", "re-shape")
    fake_dress["fails"] = {_key(plan, src.sid, src.pid)}
    root = generate_gen4(tmp_path / "d", c)

    info = json.loads((root / "dataset.json").read_text())
    assert info["garments"][gid]["source"] == f"{rp1.sid}-{gid}-{rp1.pid}"
    failed = json.loads((root / "generator" / "failed"
                         / f"{src.sid}-{gid}-{src.pid}.json").read_text())
    assert failed["track"] == "source" and "budget" in failed["failed"]
    ds = Dataset(root)
    assert sorted(ds.manifest["sample_id"]) == sorted(
        f"{t.sid}-{gid}-{t.pid}" for t in (rp1, rp2, rs, cr))
    stats = {t: json.loads((root / "generator" / "stats" / f"{t.sid}-{gid}-{t.pid}.json")
                           .read_text())["track"] for t in (rp1, rp2, rs, cr)}
    # the re-shape target was planned in the failed source's pose: cross to the new source
    assert stats[rp1] == "source" and stats[rp2] == "re-pose" and stats[rs] == "cross"
    assert stats[cr] == ("re-shape" if cr.pid == rp1.pid else "cross")
    pairs = {p.target.sample_id: p.track for p in ds.retarget_pairs("train")
             if p.source.sample_id == f"{rp1.sid}-{gid}-{rp1.pid}"}
    assert pairs[f"{rs.sid}-{gid}-{rs.pid}"] == "cross"

    # a run killed before the declaration caught up is brought up to date on resume
    info["garments"][gid]["source"] = f"{src.sid}-{gid}-{src.pid}"
    (root / "dataset.json").write_text(json.dumps(info))
    generate_gen4(root, c)
    again = json.loads((root / "dataset.json").read_text())
    assert again["garments"][gid]["source"] == f"{rp1.sid}-{gid}-{rp1.pid}"


def test_without_a_motion_on_the_design_body_the_garment_has_no_sample(tmp_path, fake_dress):
    c = _config()
    plan = make_plan(c, Gen4Config.from_synth(c))
    (gid, g), = plan["garments"].items()
    home = [t for t in g["targets"] if t.sid == g["design_subject"]]
    fake_dress["fails"] = {_key(plan, t.sid, t.pid) for t in home}
    root = generate_gen4(tmp_path / "d", c)

    assert len(fake_dress["calls"]) == len(home)  # the other bodies are not simulated
    records = {p.stem: json.loads(p.read_text())
               for p in (root / "generator" / "failed").glob("*.json")}
    assert len(records) == len(g["targets"])
    for t in g["targets"]:
        r = records[f"{t.sid}-{gid}-{t.pid}"]
        assert ("no source" in r["failed"]) == (t.sid != g["design_subject"])
    info = json.loads((root / "dataset.json").read_text())
    assert info["garments"][gid]["source"] == f"{home[0].sid}-{gid}-{home[0].pid}"
    assert info["n_samples"] == 0


def reversed_ready_jobs(job, ready, workers=1, executor=None):
    """Completion order against the priorities: of the items ready, the last runs first."""
    waiting = list(ready())
    while waiting:
        waiting.sort(key=lambda pi: pi[0])
        item = waiting.pop()[1]
        yield item, job(item)
        waiting += ready()


class Killed(Exception):
    """A run stopped from outside."""


def test_results_in_any_order_and_resumes_write_one_dataset(tmp_path, fake_dress,
                                                            monkeypatch):
    """Results written in completion order, over a killed run and its resume: the same
    files as one serial run, and no target simulated twice once written."""
    c = _config()
    plan = make_plan(c, Gen4Config.from_synth(c))
    (gid, g), = plan["garments"].items()
    src = g["targets"][0]
    fake_dress["fails"] = {_key(plan, src.sid, src.pid)}
    serial = generate_gen4(tmp_path / "serial", c)

    fake_dress["calls"].clear()
    monkeypatch.setattr(d4, "run_ready_jobs", reversed_ready_jobs)
    dress = d4.dress

    def dying(*args):
        if len(fake_dress["calls"]) == 3:  # the three design-body targets are done
            raise Killed
        return dress(*args)

    monkeypatch.setattr(d4, "dress", dying)
    with pytest.raises(Killed):
        generate_gen4(tmp_path / "resumed", c)
    part = tmp_path / "resumed"
    assert (part / "generator" / "failed" / f"{src.sid}-{gid}-{src.pid}.json").is_file()
    assert len(list((part / "generator" / "stats").glob("*.json"))) == 2
    monkeypatch.setattr(d4, "dress", dress)
    resumed = generate_gen4(part, c)
    assert len(fake_dress["calls"]) == len(g["targets"]) == len(set(fake_dress["calls"]))
    # the rows came in another order (the cross target before the re-shape one)
    assert (resumed / "manifest.parquet").read_bytes() == (serial / "manifest.parquet").read_bytes()
    for sub in ("stats", "failed", "garments", "rest"):
        a = {p.name: p.read_bytes() for p in (serial / "generator" / sub).iterdir()}
        b = {p.name: p.read_bytes() for p in (resumed / "generator" / sub).iterdir()}
        assert a == b, sub
