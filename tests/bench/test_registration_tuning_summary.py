"""The summary of ``benchmarks/registration_tuning_data.py --fit --seeds``: means per seed
and the scans whose fit moves between seeds (a start that flips on a float-level change)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="module")
def tuning():
    from tests.bench.conftest import benchmark_script

    return benchmark_script("registration_tuning_data")


def _row(sample, seed, v2v, pose="bowing", category="dress"):
    return {"sample": sample, "seed": seed, "v2v_mm": v2v, "pose": pose, "category": category,
            "cpu_s": 50.0}


def test_summary_means_per_seed_and_spread(tuning):
    rows = [_row("S01", 0, 10.0), _row("S01", 1, 200.0), _row("S02", 0, 8.0),
            _row("S02", 1, 9.0, pose="picking-up")]
    lines = tuning.summary(rows)
    assert "seed 0            v2v    9.0 mm (2 fits)" in lines
    assert "seed 1            v2v  104.5 mm (2 fits)" in lines
    spread = [ln for ln in lines if ln.startswith("seed spread")]
    assert [ln.split() for ln in spread] == [  # S02 moved 1 mm: not listed
        ["seed", "spread", "S01", "190.0", "mm", "(10.0,", "200.0)"]]
    assert lines[-1] == "all v2v 56.8 mm, CPU 50.0 s/fit"


def test_seed_in_options_is_refused(tuning, tmp_path):
    (tmp_path / "manifest.parquet").write_bytes(b"")  # made already: no generation
    with pytest.raises(SystemExit, match="--seeds"):
        tuning.main([str(tmp_path), "--fit", str(tmp_path / "o.json"),
                     "--options", '{"seed": 3}'])
    with pytest.raises(SystemExit, match="comma list of integers"):
        tuning.main([str(tmp_path), "--fit", str(tmp_path / "o.json"), "--seeds", "a,b"])
