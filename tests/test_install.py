"""The install CI makes: constraints.txt pins every dependency of every extra, and
.ci/setup.sh installs through it."""

from __future__ import annotations

import re
from pathlib import Path

import tomllib
from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

REPO = Path(__file__).resolve().parents[1]


def test_constraints_cover_every_requirement_and_setup_uses_them():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    reqs = [Requirement(r) for r in project["dependencies"]]
    for extra in project["optional-dependencies"].values():
        reqs += [Requirement(r) for r in extra]
    text = (REPO / "constraints.txt").read_text()
    pinned = {canonicalize_name(m) for m in re.findall(r"^([A-Za-z0-9_.\-]+)==", text, re.M)}
    unpinned_line = next((ln for ln in text.splitlines() if "unpinned" in ln), "")
    unpinned = {canonicalize_name(x.strip()) for x in unpinned_line.split(":")[-1].split(",")
                if x.strip()}
    missing = sorted({canonicalize_name(r.name) for r in reqs
                      if r.marker is None or r.marker.evaluate()} - pinned - unpinned)
    assert not missing, f"re-run python .ci/make_constraints.py: {missing} not in constraints.txt"
    assert "torch==2.13.0\n" in text
    setup = (REPO / ".ci" / "setup.sh").read_text()
    assert "-c constraints.txt -e" in setup
    assert "bench" in re.search(r'^EXTRAS="([^"]*)"', setup, re.M).group(1)
