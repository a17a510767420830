"""The argument types every command line shares (fmu_model.argtypes)."""

from __future__ import annotations

import argparse
import math

import pytest

from fmu_model import argtypes


@pytest.mark.parametrize(
    ("parse", "text", "value"),
    [
        (argtypes.finite, "-2.5", -2.5),
        (argtypes.positive, "1e-3", 1e-3),
        (argtypes.non_negative, "0", 0.0),
        (argtypes.positive_or_inf, "inf", math.inf),
        (argtypes.positive_or_inf, "0.1", 0.1),
        (argtypes.count(0), "0", 0),
        (argtypes.count(1), "12", 12),
        (argtypes.within(0.0, 6000.0, "rpm", low_open=True), "1e-9", 1e-9),
        (argtypes.within(0.0, 6000.0, "rpm", low_open=True), "6000", 6000.0),
    ],
)
def test_valid_words_are_parsed(parse, text: str, value: float) -> None:
    assert parse(text) == value


@pytest.mark.parametrize(
    ("parse", "text", "message"),
    [
        (argtypes.finite, "abc", "expected a number, got 'abc'"),
        (argtypes.finite, "nan", "expected a finite number, got 'nan'"),
        (argtypes.positive, "inf", "expected a finite number, got 'inf'"),
        (argtypes.positive, "0", "expected a positive number, got '0'"),
        (argtypes.non_negative, "-1e-9", "expected a number >= 0, got '-1e-9'"),
        (argtypes.positive_or_inf, "nan", "expected a positive number or inf, got 'nan'"),
        (argtypes.positive_or_inf, "-inf", "expected a positive number or inf, got '-inf'"),
        (argtypes.positive_or_inf, "x", "expected a number or inf, got 'x'"),
        (argtypes.count(1), "0", "expected a whole number >= 1, got '0'"),
        (
            argtypes.within(0.0, 60.0, "rpm", low_open=True),
            "0",
            "expected a number above 0 and at most 60 rpm, got '0'",
        ),
        (
            argtypes.within(0.0, math.inf, low_open=True),
            "0",
            "expected a number > 0 or inf, got '0'",
        ),
        (argtypes.count(0), "1.5", "expected a whole number, got '1.5'"),
    ],
)
def test_bad_words_are_usage_errors(parse, text: str, message: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError) as info:
        parse(text)
    assert str(info.value) == message
