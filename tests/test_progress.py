"""Progress reporting: a bar on a terminal, timed plain lines in a log, nothing when off."""

from __future__ import annotations

import io
import itertools

import pytest

from dressmeup import progress as progress_mod
from dressmeup.progress import progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _stderr(monkeypatch, stream: io.StringIO) -> io.StringIO:
    """Replace stderr by ``stream`` (in the test's body: pytest's capture swaps stderr back
    after fixtures) with reporting switched on."""
    monkeypatch.delenv("DRESSMEUP_NO_PROGRESS", raising=False)
    monkeypatch.setattr("sys.stderr", stream)
    return stream


@pytest.fixture
def log(monkeypatch):
    """Returns a function giving a file-like log (not a terminal) as stderr; the clock
    advances 10 s at each reading."""
    clock = itertools.count(0.0, 10.0)
    monkeypatch.setattr(progress_mod, "monotonic", lambda: next(clock))
    return lambda: _stderr(monkeypatch, io.StringIO())


def test_log_lines_show_share_elapsed_and_time_left(log, monkeypatch):
    stream = log()
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 15.0)
    assert list(progress(range(4), desc="fit")) == [0, 1, 2, 3]
    lines = stream.getvalue().splitlines()
    # clock: start 0, items at 10 (too soon), 20 (line), 30 (too soon), 40 (line), end 50
    assert lines == ["fit: 2/4 (50 %), 00:20 elapsed, ~00:20 left",
                     "fit: 4/4 (100 %), 00:40 elapsed, ~00:00 left",
                     "fit: done, 4 items in 00:50"]
    assert "\r" not in stream.getvalue()


def test_resumed_work_counts_what_was_done_but_not_in_the_rate(log, monkeypatch):
    stream = log()
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 15.0)
    # 96 of 100 items done before this run; 4 left at 10 s each: 40 s, not 40 s x 96
    assert list(progress(range(4), desc="synth", total=100, initial=96)) == [0, 1, 2, 3]
    assert stream.getvalue().splitlines() == ["synth: 98/100 (98 %), 00:20 elapsed, ~00:20 left",
                                              "synth: 100/100 (100 %), 00:40 elapsed, ~00:00 left",
                                              "synth: done, 4 items in 00:50"]
    stream = log()
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 0.0)
    assert list(progress(range(2), desc="synth", initial=8)) == [0, 1]
    assert stream.getvalue().splitlines()[0] == "synth: 9/10 (90 %), 00:10 elapsed, ~00:10 left"


def test_log_lines_without_a_length_count_items(log, monkeypatch):
    stream = log()
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 0.0)
    assert list(progress((i for i in range(2)), desc="geodesics")) == [0, 1]
    assert stream.getvalue().splitlines() == ["geodesics: 1 done, 00:10 elapsed",
                                           "geodesics: 2 done, 00:20 elapsed",
                                           "geodesics: done, 2 items in 00:30"]


def test_short_work_in_a_log_prints_nothing(log):
    stream = log()
    assert list(progress(range(2), desc="quick")) == [0, 1]  # 20 s < LINE_INTERVAL_S (30 s)
    assert stream.getvalue() == ""


def test_terminal_gets_a_bar(monkeypatch):
    stream = _stderr(monkeypatch, _Terminal())
    assert list(progress(range(3), desc="bar")) == [0, 1, 2]
    assert "\r" in stream.getvalue() and "bar:" in stream.getvalue()


@pytest.mark.parametrize("how", ["environment", "argument"])
def test_switched_off_prints_nothing(how, log, monkeypatch):
    stream = log()
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 0.0)
    if how == "environment":
        monkeypatch.setenv("DRESSMEUP_NO_PROGRESS", "1")
        items = list(progress(range(3), desc="off"))
    else:
        items = list(progress(range(3), desc="off", disable=True))
    assert items == [0, 1, 2] and stream.getvalue() == ""


def test_one_long_call_prints_a_line_now_and_then(monkeypatch):
    """``working``: the body model's build (one call, minutes) is not silent."""
    import time

    from dressmeup.progress import working

    monkeypatch.delenv("DRESSMEUP_NO_PROGRESS", raising=False)
    lines: list[str] = []
    with working("building the anny body model", every=0.05, write=lines.append):
        time.sleep(0.3)
    assert len(lines) >= 3 and lines[0].startswith("building the anny body model: 00:0")
    assert lines[-1].startswith("building the anny body model: done in ")
    lines.clear()
    with working("quick", every=5.0, write=lines.append):
        pass
    assert lines == []
    monkeypatch.setenv("DRESSMEUP_NO_PROGRESS", "1")
    with working("off", every=0.01, write=lines.append):
        time.sleep(0.05)
    assert lines == []


def test_the_body_model_build_prints_progress(monkeypatch, log, tmp_path):
    """A slow anny build (a stand-in module: the real first build takes minutes) prints
    lines in a log while it runs."""
    import sys
    import time
    import types

    from dressmeup.body import anny_model

    fake = types.ModuleType("anny")
    fake.paths = types.SimpleNamespace(download_noncommercial_data=None,
                                       set_anny_cache_path=lambda p: None)
    fake.Anny = lambda **kw: time.sleep(0.35) or "model"
    monkeypatch.setitem(sys.modules, "anny", fake)
    monkeypatch.setitem(sys.modules, "anny.paths", fake.paths)
    monkeypatch.setattr(anny_model, "_configure_caches", lambda: tmp_path)
    monkeypatch.setattr(progress_mod, "LINE_INTERVAL_S", 0.1)
    monkeypatch.delenv("DRESSMEUP_NO_PROGRESS", raising=False)
    stream = log()
    model, _seconds, _path = anny_model.build_anny(prune_cache=False)
    lines = stream.getvalue().splitlines()
    assert model == "model" and len(lines) >= 2
    assert lines[0].startswith("building the anny body model") and "elapsed" in lines[0]
    assert "done in" in lines[-1]
