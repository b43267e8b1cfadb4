"""A build-dataset killed between sessions and run again writes the same dataset.json build
record as a build that never stopped, and leaves no lock file behind."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

from dressmeup.cli import main
from dressmeup.io.outlock import lock_path


def _sessions(tmp_path):
    sessions = tmp_path / "sessions"
    for name, seed in (("S00-P0", "1"), ("S01-P0", "2"), ("S02-P0", "3")):
        assert main(["synth-capture", "mannequin", "--out", str(sessions / name), "--scale",
                     "0.2", "--seed", seed]) == 0
        info = json.loads((sessions / name / "session.json").read_text())
        info["subject_id"] = f"M{seed}"  # three subjects: three sets of samples
        (sessions / name / "session.json").write_text(json.dumps(info))
    return sessions


def _killed_after(sessions, out, n_sessions: int) -> int:
    """Run build-dataset in a child that dies like ``kill -9`` (no cleanup) when session
    ``n_sessions + 1`` starts; return the child's exit status."""
    code = textwrap.dedent(f"""
        import os
        import dressmeup.data.from_captures as fc
        from dressmeup.cli import main
        real, calls = fc.build_session, []
        def dying(job):
            calls.append(job)
            if len(calls) > {n_sessions}:
                os._exit(137)
            return real(job)
        fc.build_session = dying
        main(["build-dataset", {str(sessions)!r}, "--out", {str(out)!r}, "--voxel", "0.02",
              "--body", "none", "--target-faces", "500", "--no-texture"])
    """)
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env={**__import__("os").environ, "DRESSMEUP_NO_PROGRESS": "1"}
                          ).returncode


def test_a_build_killed_between_sessions_resumes_to_the_same_record(tmp_path):
    sessions = _sessions(tmp_path)
    common = ["--voxel", "0.02", "--body", "none", "--target-faces", "500", "--no-texture"]
    whole = tmp_path / "whole"
    assert main(["build-dataset", str(sessions), "--out", str(whole), *common]) == 0
    expected = json.loads((whole / "dataset.json").read_text())["build"]
    assert sorted(expected["sessions"]) == ["S00-P0", "S01-P0", "S02-P0"]
    for n in (1, 2):
        out = tmp_path / f"out{n}"
        assert _killed_after(sessions, out, n) == 137
        assert main(["build-dataset", str(sessions), "--out", str(out), *common]) == 0
        info = json.loads((out / "dataset.json").read_text())
        assert info["complete"] is True and info["n_samples"] == json.loads(
            (whole / "dataset.json").read_text())["n_samples"]
        assert info["build"] == expected, n
        assert not lock_path(out).exists()  # the dead run's lock file is gone too
