"""``python -m scenarios synthesize``: reference-ship trial logs, DIR/<manoeuvre>.csv."""

from __future__ import annotations

import argparse
from typing import Any

from fmu_model import argtypes
from scenarios.cli.common import make_bars
from scenarios.synthesize import MANEUVERS, synthesize_logs

__all__ = ["add_synthesize_command", "run_synthesize_command"]


def add_synthesize_command(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``synthesize`` to the subparsers ``sub``; ``common`` is the ``--quiet`` parent."""
    p = sub.add_parser(
        "synthesize", parents=[common], help="synthetic trial logs from a reference ship"
    )
    p.add_argument("--vessel", choices=("kvlcc2",), default="kvlcc2")
    p.add_argument(
        "--maneuver",
        action="append",
        required=True,
        choices=sorted(MANEUVERS),
        help="manoeuvre to log (repeat for several)",
    )
    p.add_argument("--scale", choices=("full", "model"), default="full")
    p.add_argument("--rate-hz", type=argtypes.positive, default=1.0, help="logger rate [Hz]")
    p.add_argument("--position-noise-m", type=argtypes.non_negative, default=1.0, metavar="S")
    p.add_argument("--heading-noise-deg", type=argtypes.non_negative, default=0.1, metavar="S")
    p.add_argument(
        "--seed", type=argtypes.count(0), default=0, help="run seed; each manoeuvre derives its own"
    )
    p.add_argument("--approach-s", type=argtypes.non_negative, default=60.0, help="approach [s]")
    p.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")


def run_synthesize_command(args: argparse.Namespace) -> int:
    """Write the logs and print their paths; return the exit status."""
    bar = make_bars(args.quiet)("synthesize", len(args.maneuver), "log")
    try:
        paths = synthesize_logs(
            args.output,
            args.maneuver,
            vessel=args.vessel,
            scale=args.scale,
            rate_hz=args.rate_hz,
            position_noise_m=args.position_noise_m,
            heading_noise_deg=args.heading_noise_deg,
            seed=args.seed,
            approach_s=args.approach_s,
            on_log=lambda _path: bar.update(1),
        )
    finally:
        bar.close()
    for path in paths:
        print(path)
    return 0
