"""Fixtures of the runs tests: the bench fixture dataset and edition (tests/bench/conftest.py)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_spec = importlib.util.spec_from_file_location(
    "bench_fixtures", Path(__file__).resolve().parents[1] / "bench" / "conftest.py")
bench_fixtures = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_fixtures)


@pytest.fixture(scope="session")
def bench_data(tmp_path_factory) -> Path:
    return bench_fixtures.build_fixture_dataset(tmp_path_factory.mktemp("runs-data"))


@pytest.fixture(scope="session")
def bench_edition(tmp_path_factory) -> Path:
    return bench_fixtures.write_edition(tmp_path_factory.mktemp("runs-ed") / "bench-fixture-v1.json")
