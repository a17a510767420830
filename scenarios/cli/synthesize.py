"""``python -m scenarios synthesize``: reference-ship trial logs, DIR/<manoeuvre>.csv.

With ``--gnss-jump-pct P`` (``--compass-spike-pct P``) P % of the samples carry a GNSS
jump of 50-1000 m (a compass spike of 5-180°), as a receiver logs them
(``scenarios.synthesize.with_gnss_jumps``); the ``# source:`` line says so.

At sea with ``--current-mps C --current-to-deg D`` (optionally changing linearly,
``--current-change-mps-per-h``, ``--current-veer-deg-per-h``) and/or ``--wind-mps W
--wind-from-deg D`` (optionally gusty, ``--gust-std-mps S [--gust-time-s T]``); every
value at the ship's scale. The logs then carry ``stw_mps`` (and ``stw_transverse_mps``
with ``--speed-log-axes 2``) and, with a wind, ``wind_speed_mps`` and ``wind_angle_deg``
(``scenarios.synthesize``); their ``# source:`` line names the environment. Without these
options the logs are the calm-water ones.
"""

from __future__ import annotations

import argparse
import math
from typing import Any, Final

from fmu_model import argtypes
from scenarios.cli.common import make_bars
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import (
    MANEUVERS,
    REFERENCE_VESSELS,
    SPEED_LOG_AXES,
    default_logging,
    synthesize_logs,
    write_windage,
)
from trials.logs import MAX_ON_BOARD_M

__all__ = ["add_synthesize_command", "check_synthesize_usage", "run_synthesize_command"]

MAX_CURRENT_MPS = 5.0
"""Largest ``--current-mps`` [m/s] (10 kn: beyond all but a few tidal races)."""
MAX_WIND_MPS = 40.0
"""Largest ``--wind-mps`` [m/s] (hurricane force is 33 m/s; the apparent wind, gusts and
the ship's own speed added, stays within the log's 100 m/s)."""
MAX_GUST_STD_MPS = 5.0
"""Largest ``--gust-std-mps`` [m/s]."""
MAX_DIRECTION_DEG = 360.0
"""Largest |``--current-to-deg``|, |``--wind-from-deg``| [deg]."""
MAX_GLITCH_PCT = 10.0
"""Largest ``--gnss-jump-pct``, ``--compass-spike-pct`` [%] (a receiver glitching more
often than one fix in ten is broken, not glitching)."""
_SECONDS_PER_HOUR = 3600.0


def add_synthesize_command(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``synthesize`` to the subparsers ``sub``; ``common`` is the ``--quiet`` parent."""
    p = sub.add_parser(
        "synthesize", parents=[common], help="synthetic trial logs from a reference ship"
    )
    p.add_argument(
        "--vessel",
        choices=REFERENCE_VESSELS,
        default="kvlcc2",
        help="reference ship: kvlcc2 (MMG), mariner (Abkowitz) or tanker (Van Berlekom & "
        "Goddard; the last two full scale, calm water)",
    )
    p.add_argument(
        "--maneuver",
        action="append",
        required=True,
        choices=sorted(MANEUVERS),
        help="manoeuvre to log (repeat for several)",
    )
    p.add_argument("--scale", choices=("full", "model"), default="full")
    full, model = default_logging("full"), default_logging("model")
    p.add_argument(
        "--rate-hz",
        type=argtypes.positive,
        help=f"logger rate [Hz] (default {full.rate_hz:g}; {model.rate_hz:.2g} at model scale, "
        "Froude-scaled, as are the position noise and the approach)",
    )
    p.add_argument(
        "--position-noise-m",
        type=argtypes.non_negative,
        metavar="S",
        help=f"position noise, standard deviation [m] (default {full.position_noise_m:g}; "
        f"{model.position_noise_m:.2g} at model scale)",
    )
    p.add_argument(
        "--heading-noise-deg",
        type=argtypes.non_negative,
        default=full.heading_noise_deg,
        metavar="S",
        help="heading noise, standard deviation [deg] (default %(default)s)",
    )
    p.add_argument(
        "--seed", type=argtypes.count(0), default=0, help="run seed; each manoeuvre derives its own"
    )
    p.add_argument(
        "--approach-s",
        type=argtypes.non_negative,
        help=f"approach [s] (default {full.approach_s:g}; {model.approach_s:.2g} at model scale)",
    )
    on_board = argtypes.within(-MAX_ON_BOARD_M, MAX_ON_BOARD_M, "m")
    p.add_argument(
        "--gnss-x-m",
        type=on_board,
        default=0.0,
        metavar="X",
        help="the GNSS antenna's position forward of midship [m] (the logged positions are "
        "its; default 0)",
    )
    p.add_argument(
        "--gnss-y-m",
        type=on_board,
        default=0.0,
        metavar="Y",
        help="the GNSS antenna's position to starboard of the centre line [m] (default 0)",
    )
    glitch = argtypes.within(0.0, MAX_GLITCH_PCT, "%")
    p.add_argument(
        "--gnss-jump-pct",
        type=glitch,
        default=0.0,
        metavar="P",
        help="GNSS glitches: P %% of the fixes jump 50-1000 m in any direction (default 0)",
    )
    p.add_argument(
        "--compass-spike-pct",
        type=glitch,
        default=0.0,
        metavar="P",
        help="compass glitches: P %% of the headings spike 5-180 deg either way (default 0)",
    )
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    sea = p.add_argument_group(
        "at sea",
        "a uniform current and a wind, at the ship's scale (docs/kvlcc2_environment.md); "
        "the logs then carry stw_mps and, with a wind, wind_speed_mps and wind_angle_deg",
    )
    add_current_and_wind_options(sea)
    sea.add_argument(
        "--current-change-mps-per-h",
        type=argtypes.within(-MAX_CURRENT_MPS, MAX_CURRENT_MPS, "m/s per hour"),
        metavar="R",
        help="linear change of the current speed over the run [m/s per hour] (default 0)",
    )
    sea.add_argument(
        "--current-veer-deg-per-h",
        type=argtypes.within(-360.0, 360.0, "deg per hour"),
        metavar="R",
        help="linear change of the current direction, clockwise positive [deg per hour]",
    )
    sea.add_argument(
        "--gust-std-mps",
        type=argtypes.within(0.0, MAX_GUST_STD_MPS, "m/s"),
        metavar="S",
        help="gusts: standard deviation of a first-order Gauss-Markov wind speed [m/s]",
    )
    sea.add_argument(
        "--speed-log-axes",
        type=int,
        choices=SPEED_LOG_AXES,
        metavar="N",
        help="the speed log's axes: 1 along the ship (stw_mps; the default), 2 across it "
        "too (stw_transverse_mps, a Doppler log's)",
    )
    sea.add_argument(
        "--speed-log-x-m",
        type=argtypes.within(-MAX_ON_BOARD_M, MAX_ON_BOARD_M, "m"),
        metavar="X",
        help="a two-axis log's position forward of midship [m] (default 0, amidships)",
    )
    sea.add_argument(
        "--gust-time-s",
        type=argtypes.within(0.1, 3600.0, "s"),
        metavar="T",
        help="gusts: correlation time [s] (default 60 s at full scale, Froude-scaled)",
    )


# (option, the option it needs): an option given without the one it belongs to
_NEEDS = (
    ("current_to_deg", "current_mps"),
    ("current_change_mps_per_h", "current_mps"),
    ("current_veer_deg_per_h", "current_mps"),
    ("wind_from_deg", "wind_mps"),
    ("gust_std_mps", "wind_mps"),
    ("gust_time_s", "gust_std_mps"),
)
_SEA: Final = ("current_mps", "wind_mps")  # options that put the ship at sea


def add_current_and_wind_options(group: Any) -> None:
    """Add --current-mps, --current-to-deg, --wind-mps, --wind-from-deg to an argument group.

    Steady, uniform, over ground; the bounds of this module. Shared by ``synthesize`` and
    the scenario commands at sea (``scenarios.cli.sea``).
    """
    group.add_argument(
        "--current-mps",
        type=argtypes.within(0.0, MAX_CURRENT_MPS, "m/s"),
        metavar="C",
        help="current speed over ground [m/s] (needs --current-to-deg)",
    )
    group.add_argument(
        "--current-to-deg",
        type=argtypes.within(-MAX_DIRECTION_DEG, MAX_DIRECTION_DEG, "deg"),
        metavar="D",
        help="direction the current sets towards, clockwise from North [deg]",
    )
    group.add_argument(
        "--wind-mps",
        type=argtypes.within(0.0, MAX_WIND_MPS, "m/s"),
        metavar="W",
        help="(mean) true wind speed over ground [m/s] (needs --wind-from-deg)",
    )
    group.add_argument(
        "--wind-from-deg",
        type=argtypes.within(-MAX_DIRECTION_DEG, MAX_DIRECTION_DEG, "deg"),
        metavar="D",
        help="direction the true wind comes from, clockwise from North [deg]",
    )


def _option(name: str) -> str:
    return "--" + name.replace("_", "-")


def check_synthesize_usage(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser``, the synthesize subparser) for an environment option out of place."""
    if args.current_mps is not None and args.current_to_deg is None:
        parser.error("--current-mps needs --current-to-deg (the direction it sets towards)")
    if args.wind_mps is not None and args.wind_from_deg is None:
        parser.error("--wind-mps needs --wind-from-deg (the direction it comes from)")
    for name, needed in _NEEDS:
        if getattr(args, name) is not None and getattr(args, needed) is None:
            parser.error(f"{_option(name)} needs {_option(needed)}")
    if args.speed_log_axes is not None and all(getattr(args, n) is None for n in _SEA):
        parser.error("--speed-log-axes needs --current-mps or --wind-mps (a log at sea)")
    if args.speed_log_x_m is not None and args.speed_log_axes != 2:
        parser.error("--speed-log-x-m needs --speed-log-axes 2 (a transverse axis)")


def _environment(args: argparse.Namespace) -> SeaEnvironment | None:
    """Return the environment the options ask for; None when none is given."""
    if args.current_mps is None and args.wind_mps is None:
        return None
    return SeaEnvironment(
        current_speed_mps=args.current_mps or 0.0,
        current_to_rad=math.radians(args.current_to_deg or 0.0),
        current_change_mps2=(args.current_change_mps_per_h or 0.0) / _SECONDS_PER_HOUR,
        current_veer_radps=math.radians(args.current_veer_deg_per_h or 0.0) / _SECONDS_PER_HOUR,
        wind_speed_mps=args.wind_mps or 0.0,
        wind_from_rad=math.radians(args.wind_from_deg or 0.0),
        gust_std_mps=args.gust_std_mps or 0.0,
        gust_time_s=args.gust_time_s,
    )


def _given(value: float | None, default: float) -> float:
    return default if value is None else value


def run_synthesize_command(args: argparse.Namespace) -> int:
    """Write the logs and print their paths; return the exit status."""
    logger = default_logging(args.scale)
    bar = make_bars(args.quiet)("synthesize", len(args.maneuver), "log")
    try:
        paths = synthesize_logs(
            args.output,
            args.maneuver,
            vessel=args.vessel,
            scale=args.scale,
            rate_hz=_given(args.rate_hz, logger.rate_hz),
            position_noise_m=_given(args.position_noise_m, logger.position_noise_m),
            heading_noise_deg=args.heading_noise_deg,
            seed=args.seed,
            approach_s=_given(args.approach_s, logger.approach_s),
            environment=_environment(args),
            speed_log_axes=args.speed_log_axes or 1,
            speed_log_x_m=args.speed_log_x_m or 0.0,
            gnss_x_m=args.gnss_x_m,
            gnss_y_m=args.gnss_y_m,
            gnss_jump_fraction=args.gnss_jump_pct / 100.0,
            compass_spike_fraction=args.compass_spike_pct / 100.0,
            on_log=lambda _path: bar.update(1),
        )
    finally:
        bar.close()
    if args.wind_mps:  # what `identifier fit --windage` needs to take the wind out
        paths.append(write_windage(args.output, args.vessel, args.scale))
    for path in paths:
        print(path)
    return 0
