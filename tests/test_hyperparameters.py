"""The one --param rule (dressmeup.hyperparameters) and the one hardware string."""

from __future__ import annotations

import math

import pytest

from dressmeup.errors import InputError
from dressmeup.hyperparameters import parse_params, parse_value


@pytest.mark.parametrize("text, want", [
    ("None", None), ("none", None), ("NULL", None),
    ("true", True), ("False", False),
    ("3", 3), ("-2", -2), (" 7 ", 7),
    ("0.5", 0.5), ("1e-3", 0.001), ("inf", math.inf),
    ("[64, 64]", [64, 64]), ('{"a": 1}', {"a": 1}), ('"3"', "3"), ('"None"', "None"),
    ("heat", "heat"), ("a=b", "a=b"), ("", ""), ("0x10", "0x10"),
])
def test_parse_value_rule(text, want):
    got = parse_value(text)
    assert got == want and type(got) is type(want)


def test_nan_is_a_float():
    assert math.isnan(parse_value("nan"))


def test_none_is_none_not_the_string():
    # the two old parsers disagreed here (one gave None, the other the string "None")
    assert parse_params(["x=None", "y=none"]) == {"x": None, "y": None}


def test_parse_params_keys_values_and_errors():
    assert parse_params(["width=256", "lr=1e-4", "mode=heat", "eq=a=b", "width=128"]) == \
        {"width": 128, "lr": 1e-4, "mode": "heat", "eq": "a=b"}
    with pytest.raises(InputError, match="--param 'width': expected KEY=VALUE"):
        parse_params(["width"])
    with pytest.raises(InputError, match="expected KEY=VALUE"):
        parse_params(["=3"])
    with pytest.raises(InputError, match="not valid JSON"):
        parse_params(["sizes=[1, 2"])


def test_hardware_string():
    import os

    from dressmeup.bench.scoring.provenance import cpu_model, environment, hardware

    h = hardware()
    assert h == f"{cpu_model()}, {os.cpu_count()} cores" and cpu_model().strip()
    assert set(environment()) == {"host", "platform", "python"}


def test_cpu_model_reads_the_model_name_and_falls_back_to_platform(monkeypatch):
    import builtins
    import io
    import platform

    from dressmeup.bench.scoring import provenance

    real_open = builtins.open

    def fake(text):
        def opener(path, *a, **k):
            if str(path) == "/proc/cpuinfo":
                if text is None:
                    raise OSError("no cpuinfo")
                return io.StringIO(text)
            return real_open(path, *a, **k)
        return opener

    monkeypatch.setattr(builtins, "open", fake("processor\t: 0\nmodel name\t: Intel(R) Xeon(R) Gold 6438Y+\n"
                                               "processor\t: 1\nmodel name\t: Intel(R) Xeon(R) Gold 6438Y+\n"))
    assert provenance.cpu_model() == "Intel(R) Xeon(R) Gold 6438Y+"
    assert provenance.hardware().startswith("Intel(R) Xeon(R) Gold 6438Y+, ")
    monkeypatch.setattr(builtins, "open", fake(None))
    assert provenance.cpu_model() == (platform.processor() or platform.machine())
    monkeypatch.setattr(builtins, "open", fake("processor\t: 0\n"))
    assert provenance.cpu_model() == (platform.processor() or platform.machine())
