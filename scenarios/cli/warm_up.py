"""``python -m scenarios warm-up``: compile a model family's machine code ahead of its first fit.

What it does and why: :mod:`scenarios.warm_up`. ``make`` runs it once after installing.
"""

from __future__ import annotations

import argparse
from typing import Any

from fmu_model import DEFAULT_MODEL, model_names
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
        default=DEFAULT_MODEL,
        choices=model_names(),
        help=f"model structure or family (default {DEFAULT_MODEL})",
    )


def run_warm_up_command(args: argparse.Namespace) -> int:
    """Run ``warm-up`` and print what it compiled; return the exit status."""
    progress(
        f"warm-up: fitting {WARM_UP_MANEUVER} with {args.model} (about 45 s the first time)",
        args.quiet,
    )
    done = warm_up(args.model)
    print(
        f"warm-up of {args.model}: {done.compiled} numba functions compiled, {done.loaded} "
        f"loaded from the caches in {done.seconds:.1f} s (kernel cache {done.kernel_cache})"
    )
    return 0
