"""Generator 4's plan: splits drawn from their own streams (the test split from the secret),
targets that mean their track, garments worn only by bodies they fit."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.data.synth.config import synth_config
from dressmeup.data.synth.dataset4 import Gen4Config, dataset_info, make_plan
from dressmeup.data.synth.plan4 import (
    FIT_CLEARANCE,
    FIT_SHARE,
    FIT_SLACK,
    PlanDesign,
    fits,
    region_radii,
)
from dressmeup.errors import InputError

SECRET = bytes(range(32))
OTHER = bytes(range(1, 33))
DESIGN = {"bodies": [6, 3, 6], "poses_per_family": [1, 1, 1], "garments": [1, 1, 1],
          "categories": ["topwear", "bottomwear"], "families": ["standing", "walking"],
          "targets": {"re-pose": [1, 1, 1], "re-shape": [1, 1, 1], "cross": [1, 0, 2]}, "fits": ["regular", "loose"]}


def _plan(splits=("train", "val", "test"), secret=SECRET, **design):
    c = synth_config(version="4.0.0", body_model="procedural", plan={**DESIGN, **design},
                     splits=tuple(splits), secret=secret)
    return make_plan(c, Gen4Config.from_synth(c))


@pytest.fixture(scope="module")
def plan():
    return _plan()


def test_every_type_comes_in_every_fit():
    p = _plan(splits=("train",), garments=[9, 0, 0], categories=["bottomwear"],
              fits=["tight", "regular", "loose"],
              targets={"re-pose": [1, 0, 0], "re-shape": [0, 0, 0], "cross": [0, 0, 0]})
    kinds = [(g["type"], g["fit"]) for g in p["garments"].values()]
    assert len(kinds) == 9 and len(set(kinds)) == 9  # 3 types x 3 fits, each once


def test_fits_rule_analytic():
    design = {"chest": 0.14, "waist": 0.13, "hips": 0.15}
    off = 0.012
    limit = FIT_SHARE * off - FIT_CLEARANCE
    just_in = {k: v + limit - 1e-6 for k, v in design.items()}
    just_out = {**design, "hips": design["hips"] + limit + 1e-6}
    assert fits("bottomwear", off, design, just_in)
    assert not fits("bottomwear", off, design, just_out)
    assert fits("topwear", off, design, just_out)  # a top does not care about the hips
    too_small = {**design, "chest": design["chest"] - FIT_SLACK - 1e-6}
    assert not fits("topwear", off, design, too_small)
    assert fits("bottomwear", off, design, too_small)


def test_region_radii_of_a_cylinder():
    """Points on a vertical cylinder of radius r: every region's radius is r."""
    from dressmeup.data.synth.garments import BodyFrame

    t = np.linspace(0, 2 * np.pi, 64, endpoint=False)
    ring = np.c_[0.1 * np.cos(t), np.zeros_like(t), 0.1 * np.sin(t)]
    V = np.vstack([ring + [0.3, y, -0.2] for y in (0.0, 0.1, 0.2)])
    labels = np.array(["spine2"] * 64 + ["spine1"] * 64 + ["pelvis"] * 64)
    frame = BodyFrame(np.array([0.0, 1, 0]), np.array([1.0, 0, 0]), np.array([0.0, 0, 1]))
    r = region_radii(V, labels, frame)
    assert r == pytest.approx({"chest": 0.1, "waist": 0.1, "hips": 0.1}, abs=1e-9)


def test_targets_mean_their_track(plan):
    for gid, g in plan["garments"].items():
        src, *rest = g["targets"]
        assert src.track == "source" and src.sid == g["design_subject"]
        assert len({(t.sid, t.pid) for t in g["targets"]}) == len(g["targets"])
        for t in rest:
            same_subject, same_pose = t.sid == src.sid, t.pid == src.pid
            expected = {"re-pose": (True, False), "re-shape": (False, True),
                        "cross": (False, False)}[t.track]
            assert (same_subject, same_pose) == expected, (gid, t)
            assert plan["subjects"][t.sid]["split"] == g["split"]
            assert plan["poses"][t.pid]["split"] == g["split"]


def test_splits_are_disjoint_and_ids_stable(plan):
    by_split = {}
    for s in plan["subjects"].values():
        by_split.setdefault(s["split"], set()).add(tuple(s["shape"]))
    assert not by_split["train"] & by_split["test"] and not by_split["val"] & by_split["test"]
    assert sorted(plan["subjects"])[0] == "S001" and "S010" in plan["subjects"]  # val block
    poses = {p: tuple(np.ravel(v["pose"])) for p, v in plan["poses"].items()}
    test = {v for p, v in poses.items() if plan["poses"][p]["split"] == "test"}
    train = {v for p, v in poses.items() if plan["poses"][p]["split"] == "train"}
    assert test and not test & train


def test_public_splits_do_not_depend_on_the_secret(plan):
    alone = _plan(splits=("train", "val"), secret=None)
    other = _plan(secret=OTHER)
    for key in ("subjects", "poses", "garments"):
        public = {k: v for k, v in plan[key].items() if v["split"] != "test"}
        assert alone[key].keys() == public.keys()
        assert repr(alone[key]) == repr(public)
        assert repr({k: v for k, v in other[key].items() if v["split"] != "test"}) == repr(public)
    test = {k: v for k, v in plan["garments"].items() if v["split"] == "test"}
    test_other = {k: v for k, v in other["garments"].items() if v["split"] == "test"}
    assert test.keys() == test_other.keys()
    assert [g["params"] for g in test.values()] != [g["params"] for g in test_other.values()]


def test_garments_fit_their_targets(plan):
    from dressmeup.data.synth.dataset4 import _kit

    kit = _kit("procedural")
    radii = {}
    for sid, s in plan["subjects"].items():
        V, frame = kit.rest(np.asarray(s["shape"]))
        radii[sid] = region_radii(V, kit.labels, frame)
    for g in plan["garments"].values():
        for t in g["targets"]:
            assert fits(g["category"], g["params"]["offset"], radii[g["design_subject"]],
                        radii[t.sid])


def test_dataset_json_hides_parameters_and_secret(plan):
    c = synth_config(version="4.0.0", body_model="procedural", plan=DESIGN, secret=SECRET)
    info = dataset_info(c, Gen4Config.from_synth(c), plan)
    text = repr(info)
    assert SECRET.hex() not in text and "params'" not in repr(info["garments"])
    assert info["generator"]["params"]["test_split_commitment"] == (
        "630dcd2966c4336691125448bbb25b4ff412a49c732db2c8abc1b8581bd710dd")
    for gid, g in info["garments"].items():
        assert set(g) == {"split", "type", "category", "source"}
        assert g["source"].split("-")[1] == gid


def test_test_split_needs_the_secret(tmp_path):
    from dressmeup.data.synth import generate_dataset

    with pytest.raises(InputError, match="secret"):
        generate_dataset(tmp_path / "d", version="4.0.0", body_model="procedural", plan=DESIGN)
    with pytest.raises(InputError, match="plan, motion, dynamics"):
        generate_dataset(tmp_path / "d", version="3.0.0", plan=DESIGN)
    with pytest.raises(InputError, match="unknown setting"):
        PlanDesign.from_dict({"bodys": [1, 1, 1]})


def test_split_garments_are_the_plans(plan):
    """The garments alone (as a training script checks them against other editions' test
    garments) are the full plan's, split by split, the test split only with its secret."""
    from dressmeup.data.synth.generator4 import load_body_kit
    from dressmeup.data.synth.plan4 import split_garments

    kit = load_body_kit("procedural")
    design = PlanDesign.from_dict(DESIGN)
    for split, secret in (("train", None), ("val", None), ("test", SECRET)):
        subjects, garments = split_garments(split, design, kit, 0, secret)
        want = {g: {k: v for k, v in rec.items() if k != "targets"}
                for g, rec in plan["garments"].items() if rec["split"] == split}
        assert garments == want
        assert subjects == {s: v for s, v in plan["subjects"].items() if v["split"] == split}
    with pytest.raises(InputError, match="secret"):
        split_garments("test", design, kit, 0, None)
