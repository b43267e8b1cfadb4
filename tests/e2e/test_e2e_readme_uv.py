"""The README's UV journey runs as shown: its submission is scored."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def test_readme_uv_journey_scores(tmp_path, monkeypatch, capsys):
    from dressmeup.cli import main

    text = (REPO / "README.md").read_text()
    block = re.search(r"### UV parameterisation\s+```bash\n(.*?)```", text, re.S).group(1)
    commands = [shlex.split(ln.split("#")[0]) for ln in block.splitlines() if ln.strip()]
    # the neural method's training is the slow part and not what this checks
    quick = [c for c in commands if "neural" not in c and "train-uvparam" not in c]
    assert any(c[1] == "score" for c in quick), "the README should show how to score"
    monkeypatch.chdir(tmp_path)
    for cmd in quick:
        assert cmd[0] == "dressmeup"
        if cmd[1] == "score":
            cmd = [*cmd, "--workers", "1"]
        assert main(cmd[1:]) == 0, (cmd, capsys.readouterr().err)
    assert "3/3 items scored" in capsys.readouterr().out
