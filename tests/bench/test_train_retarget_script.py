"""``benchmarks/train_retarget_weights.py`` refuses to train on a shipped edition's test
garment: for generator 4 it compares the training split's garments with the test garments
of every v5 edition whose secret is published, and names the sealed ones."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def script():
    from tests.bench.conftest import benchmark_script

    return benchmark_script("train_retarget_weights")


def test_generator4_plan_keys_follow_the_secret(script):
    from dressmeup.bench import load_edition

    pin = load_edition("synth-retarget-tiny-v5").dataset
    sealed = script._plan(pin.params, pin.seed)
    opened = script._plan(pin.params, pin.seed, pin.published_secret)
    assert not any(v["split"] == "test" for v in sealed.values())  # no secret: no test split
    test = {g: v for g, v in opened.items() if v["split"] == "test"}
    assert len(test) == 2 and set(sealed) <= set(opened)


class _Data:
    def __init__(self, info):
        self.info = info


def test_a_training_garment_that_is_a_test_garment_is_refused(script, monkeypatch, capsys):
    from dressmeup.bench import load_edition

    pin = load_edition("synth-retarget-tiny-v5").dataset
    test = {g: v for g, v in script._plan(pin.params, pin.seed, pin.published_secret).items()
            if v["split"] == "test"}
    gen = {"name": pin.generator, "version": pin.generator_version, "seed": pin.seed,
           "params": pin.params}
    mine = {"G900": {"key": "another garment", "split": "train"}}
    data = _Data({"generator": gen, "garments": {"G900": {"split": "train"}}})
    real = script._plan

    def plan(params, seed, secret=None):
        return mine if params is gen["params"] else real(params, seed, secret)

    monkeypatch.setattr(script, "_plan", plan)
    script._check_no_test_garments(data, "train", [])
    said = capsys.readouterr().out
    assert "synth-retarget-tiny-v5" in said and "unpublished secret" in said
    assert "synth-retarget-v5" in said.split("unpublished secret")[1]
    g, rec = next(iter(test.items()))
    mine["G900"]["key"] = rec["key"]  # the same design as tiny-v5's test garment
    with pytest.raises(SystemExit, match=f"training garment G900 is test garment {g} of "
                                         "edition synth-retarget-tiny-v5"):
        script._check_no_test_garments(data, "train", [])
