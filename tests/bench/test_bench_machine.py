"""Whether this machine reproduces an edition's pinned data, asked before generating
(dressmeup.bench.machine, dressmeup.data.synth.probe, ``dressmeup synth --edition``)."""

from __future__ import annotations

import pytest

from dressmeup.bench import load_edition
from dressmeup.bench import machine as machine_mod
from dressmeup.bench.edition import edition_from_dict, list_editions
from dressmeup.bench.machine import load_probe_pin, machine_differs, portable
from dressmeup.cli import main
from dressmeup.data.synth.probe import ProbeResult, probe_v3
from dressmeup.errors import InputError

TINY_V3 = "synth-retarget-tiny-v3"


def _other_machine(monkeypatch):
    """The probe as an Intel Xeon computes it: the pinned sample, another digest."""
    pin = load_probe_pin(TINY_V3)
    monkeypatch.setattr(machine_mod, "probe_v3",
                        lambda params, seed: ProbeResult(pin["sample"], "5e" * 32, 1.0))
    return pin


def test_a_machine_that_computes_other_numbers_is_told_before_anything_is_written(
        monkeypatch, tmp_path, capsys):
    import dressmeup.data.synth as synth

    pin = _other_machine(monkeypatch)

    def no_generation(*a, **k):
        raise AssertionError("the generator ran")

    monkeypatch.setattr(synth, "generate_dataset", no_generation)
    out = tmp_path / "data"
    assert main(["synth", str(out), "--edition", TINY_V3]) == 2
    captured = capsys.readouterr()
    err = captured.err
    assert err.count("\n") == 1 and err.startswith("dressmeup synth: error: edition " + TINY_V3)
    assert f"dressmeup edition fetch {TINY_V3} --from SOURCE --out DIR" in err
    assert "--allow-other-data" in err and pin["sample"] in err
    assert f"{'5e' * 6}... instead of {pin['sha256'][:12]}..." in err
    assert captured.out == ""
    assert not out.exists() and list(tmp_path.iterdir()) == []  # nothing written, no lock left


def test_allow_other_data_generates_without_asking(monkeypatch, tmp_path, capsys):
    import dressmeup.data.synth as synth

    def no_probe(*a, **k):
        raise AssertionError("probed")

    def generator_reached(*a, **k):
        raise InputError("the generator was reached")

    monkeypatch.setattr(machine_mod, "probe_v3", no_probe)
    monkeypatch.setattr(synth, "generate_dataset", generator_reached)
    assert main(["synth", str(tmp_path / "d"), "--edition", TINY_V3,
                 "--allow-other-data"]) == 2
    assert "the generator was reached" in capsys.readouterr().err


def test_allow_other_data_needs_an_edition(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "d"), "--allow-other-data"]) == 2
    assert "--allow-other-data goes with --edition" in capsys.readouterr().err


def test_every_edition_of_generator_2_ships_a_probe_pin_and_no_portable_one_does():
    for name in list_editions():
        ed = load_edition(name)
        pin = ed.dataset
        v2x = (pin is not None and pin.kind == "generated" and ed.task != "uvparam"
               and str(pin.params.get("version", "")).startswith("2."))
        probe = load_probe_pin(ed)
        if v2x and pin.expected_manifest_sha256:
            assert probe is not None, name
            assert probe["edition_hash"] == ed.hash and probe["generator_version"] == "2.1.0"
            assert len(probe["sha256"]) == 64 and not portable(ed)
        elif portable(ed):
            assert probe is None, name
            assert machine_differs(ed) == (None, None)  # nothing is run
    assert portable("synth-retarget-tiny-v4") and portable("synth-uvparam-mini-v1")
    assert portable("synth-retarget-tiny-v5") and portable("synth-retarget-mini-v5")
    assert not portable(TINY_V3) and not portable("synth-retarget-tiny-v2")


def test_a_probe_pin_of_a_changed_edition_is_refused():
    d = load_edition(TINY_V3).to_dict()
    d["options"]["n_samples"] = 1000  # same name, another hash
    with pytest.raises(InputError, match="pin its probe again"):
        load_probe_pin(edition_from_dict(d, source="test"))


@pytest.mark.cpu_kernels
def test_the_probe_predicts_whether_the_data_reproduce_the_pin(other_data):
    """On a machine of the pinning family (these AMD EPYCs) the probe passes and the data
    are the pinned ones; where the data differ (the Intel Xeon) the probe must say so."""
    from dressmeup import runs
    from dressmeup.cache import cache_dir

    ed = load_edition(TINY_V3)
    data = runs.build_data(ed, cache_dir("e2e") / f"{ed.name}-{ed.hash[:10]}")
    reproduces = other_data(ed, data) is None
    why, probe = machine_differs(ed)
    assert probe is not None and probe.sample == "S02-G01-P1"
    assert (why is None) == reproduces, why


@pytest.mark.cpu_kernels
def test_the_probe_sees_other_float_kernels(monkeypatch):
    """torch's AVX2 kernels instead of the canonical portable ones change v3 data on the
    pinning machine (docs/synthetic-data.md): the probe's digest changes with them."""
    from dressmeup.data.synth import jobs

    if "avx2" not in open("/proc/cpuinfo").read():
        pytest.skip("needs an x86 CPU with AVX2")
    ed = load_edition(TINY_V3)
    monkeypatch.setitem(jobs.CANONICAL_ENV, "ATEN_CPU_CAPABILITY", "avx2")
    res = probe_v3(ed.dataset.params, ed.dataset.seed)
    assert res.sample == load_probe_pin(ed)["sample"]
    assert res.sha256 != load_probe_pin(ed)["sha256"]


def test_designed_garments_needs_a_generator_4_edition(tmp_path, capsys):
    assert main(["synth", str(tmp_path / "d"), "--designed-garments"]) == 2
    assert "--designed-garments goes with --edition" in capsys.readouterr().err
    assert main(["synth", str(tmp_path / "e"), "--edition", "synth-retarget-tiny-v4",
                 "--designed-garments"]) == 2
    assert "not made by generator 4" in capsys.readouterr().err
    assert not (tmp_path / "e").exists()
