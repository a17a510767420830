"""The at-sea options of the commands that sail an FMU (and the reference ship).

``--current-mps C --current-to-deg D`` (a uniform, steady current over ground, setting
towards D clockwise from North) and ``--wind-mps W --wind-from-deg D`` (a steady true
wind over ground, from D): each speed needs its direction and each direction its
speed; the bounds are ``synthesize``'s for the same options. Without them the commands
sail in calm water, as before these options existed.
"""

from __future__ import annotations

import argparse
import math
from typing import Any

from scenarios.cli.synthesize import add_current_and_wind_options
from scenarios.sea import SeaEnvironment

__all__ = ["add_sea_arguments", "check_sea_usage", "sea_environment"]

# (speed option, direction option, what the direction is): each needs the other.
_PAIRS = (
    ("current_mps", "current_to_deg", "the direction it sets towards"),
    ("wind_mps", "wind_from_deg", "the direction it comes from"),
)


def add_sea_arguments(parser: argparse.ArgumentParser, *, correction: bool = False) -> None:
    """Add the group "at sea" to ``parser``; with ``correction`` also --no-current-correction."""
    sea = parser.add_argument_group(
        "at sea",
        "a uniform steady current and a steady wind over ground; the FMU gets them through "
        "its environment inputs (its windage from params.json carries the wind load)",
    )
    add_current_and_wind_options(sea)
    if correction:
        sea.add_argument(
            "--no-current-correction",
            action="store_true",
            help="judge and compare the turns' raw indices even when they show a drift",
        )


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def check_sea_usage(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser``, the command's subparser) for a speed or direction without the other."""
    for speed, direction, what in _PAIRS:
        if getattr(args, speed) is not None and getattr(args, direction) is None:
            parser.error(f"{_option(speed)} needs {_option(direction)} ({what})")
        if getattr(args, direction) is not None and getattr(args, speed) is None:
            parser.error(f"{_option(direction)} needs {_option(speed)}")


def sea_environment(args: Any) -> SeaEnvironment | None:
    """Return the environment the options ask for; None when none is given (calm water)."""
    if args.current_mps is None and args.wind_mps is None:
        return None
    return SeaEnvironment(
        current_speed_mps=args.current_mps or 0.0,
        current_to_rad=math.radians(args.current_to_deg or 0.0),
        wind_speed_mps=args.wind_mps or 0.0,
        wind_from_rad=math.radians(args.wind_from_deg or 0.0),
    )
