"""``python -m scenarios warm-up``: compile a model family's machine code ahead of its first fit.

What it does and why: :mod:`scenarios.warm_up`. ``make`` runs it once after installing.
"""

from __future__ import annotations

import argparse
from typing import Any

from fmu_model import DEFAULT_MODEL, model_names
from identifier.identify import fixed_thrust_model
from scenarios.cli.common import progress
from scenarios.warm_up import WARM_UP_MANEUVER, warm_up

__all__ = ["add_warm_up_command", "run_warm_up_command"]


def add_warm_up_command(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``warm-up`` to the subparsers ``sub``; ``common`` is the ``--quiet`` parent."""
    p = sub.add_parser(
        "warm-up",
        parents=[common],
        help="compile the identification's numba code once (a first fit does it otherwise)",
        description=f"Fit a KVLCC2 {WARM_UP_MANEUVER} log under every current mode, so that "
        "the smoother, the EKF and the replay of the model family are compiled and cached on "
        "disk; every later fit on this machine loads them.",
    )
    p.add_argument(
        "--model",
        choices=model_names(),
        help=f"model structure or family (default: {DEFAULT_MODEL} and "
        f"{fixed_thrust_model(DEFAULT_MODEL)}, which a default fit of logs at one rpm may be "
        "refitted as)",
    )


def run_warm_up_command(args: argparse.Namespace) -> int:
    """Run ``warm-up`` and print what it compiled; return the exit status."""
    models = [args.model] if args.model else [DEFAULT_MODEL, fixed_thrust_model(DEFAULT_MODEL)]
    for model in filter(None, models):
        progress(
            f"warm-up: fitting {WARM_UP_MANEUVER} with {model} (about 45 s the first time)",
            args.quiet,
        )
        done = warm_up(model)
        print(
            f"warm-up of {model}: {done.compiled} numba functions compiled, {done.loaded} "
            f"loaded from the caches in {done.seconds:.1f} s (kernel cache {done.kernel_cache})"
        )
    return 0
