"""``python -m identifier crossval LOG.csv ... --train ...``: predict held-out logs.

Identifies on the training logs and predicts the held-out ones with
:func:`identifier.crossval.run_cross_validation`; prints
:func:`identifier.crossval.format_table`, writes the results as JSON on request.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from fmu_model import DEFAULT_MODEL, model_names
from fmu_model.atomic import write_atomic
from identifier.cli.common import (
    DATA_ERRORS,
    add_length_argument,
    add_windage_argument,
    error,
    os_error_text,
)
from identifier.crossval import KINDS, format_table, run_cross_validation
from identifier.current import CURRENT_MODES
from identifier.identify import METHODS, FitSettings
from identifier.wind import read_windage
from trials.conditions import MODEL_SCALE_MAX_LENGTH_M
from trials.logs import read_log

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``crossval`` command to the subparsers ``sub`` of ``python -m identifier``."""
    cv = sub.add_parser(
        "crossval",
        help="identify on some logs, predict the held-out ones",
        description=(
            "Cross-validate a model structure: identify on the training logs, replay the "
            "held-out logs' rudder and rpm (the track), sail their zig-zags closed loop in "
            "their logged condition, and compare track and manoeuvre indices."
        ),
    )
    cv.add_argument("logs", nargs="+", metavar="LOG.csv", help="trial logs (DESIGN.md format)")
    cv.add_argument(
        "--train",
        nargs="+",
        metavar="KIND|FILE",
        default=[],
        help="training logs: turning, zigzag or log files (given here or among LOGS)",
    )
    cv.add_argument(
        "--test",
        nargs="+",
        metavar="KIND|FILE",
        default=[],
        help="held-out logs (default: every log not trained on)",
    )
    cv.add_argument(
        "--leave-one-out", action="store_true", help="one fold per log, trained on all others"
    )
    cv.add_argument("--model", default=DEFAULT_MODEL, choices=model_names())
    cv.add_argument(
        "--method",
        choices=METHODS,
        default=METHODS[0],
        help="identification procedure (default: output-error; ekf: the seed paper)",
    )
    cv.add_argument(
        "--current",
        choices=CURRENT_MODES,
        help="uniform current estimated with the training logs' coefficients, and the "
        "held-out logs predicted in it (fit's --current; default: constant for a ship, "
        f"auto below L = {MODEL_SCALE_MAX_LENGTH_M:g} m; with per-log, each held-out log in "
        "the current its own speed log shows, else in the training logs' mean with the "
        "component across its approach as the approach shows it)",
    )
    add_length_argument(cv, " (default: from logs)")
    add_windage_argument(
        cv,
        "the held-out logs are replayed in their logged wind and their zig-zags sailed "
        "again in its mean",
    )
    cv.add_argument("--json", metavar="OUT", help="write the results as JSON")
    cv.add_argument(
        "--plot",
        metavar="DIR",
        help="write a figure per held-out log, logged vs predicted (fold<k>-<log>.png)",
    )
    cv.add_argument("--quiet", action="store_true", help="no table on stdout")
    return cv


def run(args: argparse.Namespace) -> int:
    """Run ``python -m identifier crossval`` for parsed ``args``; return the exit status."""
    if args.leave_one_out and (args.train or args.test):
        return error("--leave-one-out takes no --train/--test", status=2)
    if not args.leave_one_out and not args.train:
        return error("give --train KIND|FILE... or --leave-one-out", status=2)
    try:
        paths = list(dict.fromkeys(args.logs))
        known = {Path(p).resolve() for p in paths}
        for item in (*args.train, *args.test):
            if item not in KINDS and Path(item).resolve() not in known:
                paths.append(item)
                known.add(Path(item).resolve())
        windage = None if args.windage is None else read_windage(args.windage)
        logs = [read_log(p) for p in paths]
        cv = run_cross_validation(
            logs,
            FitSettings(
                model=args.model, method=args.method, current=args.current, windage=windage
            ),
            train=args.train,
            test=args.test,
            leave_one_out_=args.leave_one_out,
            length_m=args.length_m,
        )
        if args.json:
            write_atomic(args.json, json.dumps(cv.to_json_dict(), indent=2, allow_nan=False) + "\n")
        figures = []
        if args.plot:
            from identifier.plots import write_held_out_plots

            figures = write_held_out_plots(cv, args.plot)
    except DATA_ERRORS as exc:
        return error(str(exc))
    except OSError as exc:
        return error(os_error_text(exc))
    for fold in cv.folds:
        for warning in fold.warnings:
            print(f"warning: {warning}", file=sys.stderr)
    if not args.quiet:
        print(format_table(cv))
        for path in ([args.json] if args.json else []) + figures:
            print(f"wrote {path}")
    return 0
