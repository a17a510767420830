"""Argument types shared by the command lines (``identifier``, ``scenarios``, ``build_fmu.py``).

Each turns one command-line word into a value or raises ``argparse.ArgumentTypeError``
with the message argparse prints after ``argument --name:`` (exit status 2).
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable


def finite(text: str) -> float:
    """Parse a finite number."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"expected a finite number, got {text!r}")
    return value


def positive(text: str) -> float:
    """Parse a positive finite number."""
    value = finite(text)
    if value <= 0.0:
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def non_negative(text: str) -> float:
    """Parse a finite number ≥ 0."""
    value = finite(text)
    if value < 0.0:
        raise argparse.ArgumentTypeError(f"expected a number >= 0, got {text!r}")
    return value


def positive_or_inf(text: str) -> float:
    """Parse a positive number or ``inf`` (``math.inf``); reject 0, negatives and nan."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or inf, got {text!r}") from None
    if not value > 0.0:  # also false for nan
        raise argparse.ArgumentTypeError(f"expected a positive number or inf, got {text!r}")
    return value


def within(
    low: float, high: float, unit: str = "", *, low_open: bool = False
) -> Callable[[str], float]:
    """Return a parser of numbers in the closed range [``low``, ``high``].

    ``high`` may be ``math.inf``: then the word ``inf`` itself is accepted (e.g. "no
    limit"), and the message reads "a number >= low or inf". ``unit`` (e.g. ``"m"``) is
    shown after the bounds in the message. ``low_open``: ``low`` itself is rejected
    (the range (``low``, ``high``], "a number above low and at most high").
    """
    suffix = f" {unit}" if unit else ""
    if math.isinf(high):
        wanted = f"a number {'>' if low_open else '>='} {low:g}{suffix} or inf"
    elif low_open:
        wanted = f"a number above {low:g} and at most {high:g}{suffix}"
    else:
        wanted = f"a number from {low:g} to {high:g}{suffix}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}") from None
        above = low < value if low_open else low <= value
        if not (above and value <= high):  # also false for nan
            raise argparse.ArgumentTypeError(f"expected {wanted}, got {text!r}")
        return value

    parse.__name__ = f"within({low:g}, {high:g})"
    return parse


def count(minimum: int) -> Callable[[str], int]:
    """Return a parser of whole numbers ≥ ``minimum``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
        if value < minimum:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}")
        return value

    parse.__name__ = f"count(minimum={minimum})"
    return parse
