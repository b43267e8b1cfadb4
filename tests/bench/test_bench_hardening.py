"""Hardening of the bench side: modes, killed runs, overwrite wording."""

from __future__ import annotations

import os
import stat
import subprocess
import sys
import textwrap

import pytest

from dressmeup.errors import InputError


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_submissions_and_results_are_readable_by_others(bench_data, bench_edition, tmp_path):
    from dressmeup.bench import score_submission

    from .conftest import gt_predictions, make_submission

    old = os.umask(0o022)
    try:
        sub = make_submission(tmp_path / "sub", gt_predictions(bench_data, bench_edition),
                              bench_edition, "GT")
        res = score_submission(sub, bench_edition, bench_data, tmp_path / "res", workers=1,
                               show_progress=False)
    finally:
        os.umask(old)
    files = [*sub.iterdir(), *res.path.iterdir()]
    assert files and all(_mode(f) == 0o644 for f in files), [(f, oct(_mode(f))) for f in files]


def test_killed_score_leaves_nothing_that_blocks_a_rerun(bench_data, bench_edition, scored,
                                                         tmp_path):
    """Kill a score run while it writes the result: the re-run succeeds."""
    out = tmp_path / "res"
    code = textwrap.dedent(f"""
        import os, signal
        import dressmeup.io.atomic as A
        orig = A.atomic_write_text
        def killer(path, text):
            orig(path, text)
            os.kill(os.getpid(), signal.SIGKILL)
        A.atomic_write_text = killer
        from dressmeup.bench import score_submission
        score_submission({str(scored["gt"]["sub"])!r}, {str(bench_edition)!r},
                         {str(bench_data)!r}, {str(out)!r}, workers=1, show_progress=False)
    """)
    proc = subprocess.run([sys.executable, "-c", code], check=False)
    assert proc.returncode == -9
    assert not out.exists()
    from dressmeup.bench import score_submission

    res = score_submission(scored["gt"]["sub"], bench_edition, bench_data, out, workers=1,
                           show_progress=False)
    assert (res.path / "summary.json").is_file()


def test_killed_baseline_leaves_no_orphan_predictions(bench_edition, tmp_path):
    """A kill between two prediction files leaves no submission folder at all."""
    out = tmp_path / "sub"
    code = textwrap.dedent(f"""
        import os, signal
        import numpy as np
        import dressmeup.bench.scoring.submission as S
        n = [0]
        orig = np.savez
        def savez(*a, **k):
            orig(*a, **k)
            n[0] += 1
            if n[0] == 2:
                os.kill(os.getpid(), signal.SIGKILL)
        np.savez = savez
        S.write_submission({str(out)!r}, {{"a": np.zeros((3, 3)), "b": np.ones((3, 3)),
                                          "c": np.ones((3, 3))}},
                           edition={str(bench_edition)!r}, method="m")
    """)
    proc = subprocess.run([sys.executable, "-c", code], check=False)
    assert proc.returncode == -9
    assert not out.exists()


def test_cli_says_the_overwrite_option(bench_data, bench_edition, tmp_path, capsys):
    from dressmeup.cli import main

    out = tmp_path / "sub"
    out.mkdir()
    (out / "x.npz").write_bytes(b"")
    status = main(["baseline", "retarget", "--method", "rigid", "--data", str(bench_data),
                   "--edition", str(bench_edition), "--out", str(out)])
    err = capsys.readouterr().err
    assert status == 2
    assert "--overwrite" in err and "overwrite=True" not in err


def test_overwrite_merges_into_an_existing_submission(bench_edition, tmp_path):
    import numpy as np

    from dressmeup.bench import write_submission

    out = tmp_path / "sub"
    write_submission(out, {"a": np.zeros((3, 3))}, edition=bench_edition, method="m")
    with pytest.raises(InputError, match="overwrite"):
        write_submission(out, {"b": np.zeros((3, 3))}, edition=bench_edition, method="m")
    write_submission(out, {"b": np.ones((3, 3))}, edition=bench_edition, method="m2",
                     overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == ["a.npz", "b.npz", "submission.json"]
    assert [p.name for p in tmp_path.iterdir()] == ["sub"]


def test_score_refuses_a_moved_ground_truth_garment(bench_data, bench_edition, scored,
                                                    tmp_path):
    """A GT garment moved by 5 cm no longer matches the manifest: nothing is scored."""
    import shutil

    from dressmeup.bench import score_submission
    from dressmeup.data import Dataset
    from dressmeup.data.integrity import ChecksumError
    from dressmeup.io.mesh import load_mesh, save_mesh

    data = tmp_path / "data"
    shutil.copytree(bench_data, data)
    row = Dataset(data).manifest.iloc[1]
    path = data / row["garment_path"]
    m = load_mesh(path)
    save_mesh(path, m.vertices + [0.05, 0.0, 0.0], m.faces)
    with pytest.raises(ChecksumError, match=str(row["garment_path"])):
        score_submission(scored["gt"]["sub"], bench_edition, data, tmp_path / "res",
                         workers=1, show_progress=False)
    assert not (tmp_path / "res").exists()
    assert scored["gt"]["res"].summary["dataset"]["files_verified"] > 0


def test_a_folder_holding_only_a_stale_temp_file_does_not_block_score(bench_data,
                                                                       bench_edition, scored,
                                                                       tmp_path):
    """What an older toolkit's killed score left: a hidden 0-byte temp file, invisible to ls."""
    from dressmeup.bench import score_submission

    out = tmp_path / "res"
    out.mkdir()
    (out / ".summary.k2j3h4.tmp.json").write_bytes(b"")
    res = score_submission(scored["gt"]["sub"], bench_edition, bench_data, out, workers=1,
                           show_progress=False)
    assert sorted(p.name for p in res.path.iterdir()) == ["edition.json", "per_sample.parquet",
                                                           "summary.json"]
