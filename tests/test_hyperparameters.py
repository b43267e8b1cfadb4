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

    from dressmeup.bench.scoring.provenance import environment, hardware

    h = hardware()
    assert h.endswith(f" CPU, {os.cpu_count()} cores") and len(h) > len(" CPU, 1 cores")
    assert set(environment()) == {"host", "platform", "python"}
