"""Command line of the identifier: ``python -m identifier fit LOG.csv ... -o params.json``.

Exit status: 0 success, 1 data error (bad log, bad settings for the data, diverging
identification), 2 usage error. Errors are one line on stderr, never a traceback.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Sequence

from tqdm import tqdm

from fmu_model import DEFAULT_MODEL, ParamsFormatError, argtypes, model_names, save_params
from identifier import batch, crossval, ingest
from identifier.errors import IdentificationError, LogFormatError
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.logs import read_log


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``python -m identifier``."""
    parser = argparse.ArgumentParser(
        prog="python -m identifier",
        description="Identify ship manoeuvring models from trial logs.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    fit = sub.add_parser("fit", help="identify coefficients from trial logs")
    fit.add_argument("logs", nargs="+", metavar="LOG.csv", help="trial logs (DESIGN.md format)")
    fit.add_argument("-o", "--output", required=True, metavar="params.json")
    fit.add_argument("--model", default=DEFAULT_MODEL, choices=model_names())
    fit.add_argument(
        "--length-m", type=argtypes.positive, help="ship length [m] (default: from logs)"
    )
    fit.add_argument(
        "--initial",
        choices=("equation-error", "zero"),
        default="equation-error",
        help="EKF start: least-squares fit (default) or the paper's zero start with P0 = alpha I",
    )
    fit.add_argument("--alpha", type=argtypes.positive, default=1.0, help="alpha of --initial zero")
    fit.add_argument(
        "--measurements",
        choices=("track", "velocities"),
        default="track",
        help="EKF measures the logged track (default) or smoothed u, v, r (the paper)",
    )
    fit.add_argument(
        "--max-substep-s",
        type=argtypes.positive_or_inf,
        default=0.1,
        help="largest Euler substep of the EKF [s] (inf: one step per sample, the paper)",
    )
    fit.add_argument("--param-random-walk", type=float, default=1e-4, metavar="RHO")
    fit.add_argument("--position-noise-m", type=argtypes.positive, help="logger position noise [m]")
    fit.add_argument(
        "--heading-noise-deg", type=argtypes.positive, help="logger heading noise [deg]"
    )
    fit.add_argument("--plot", metavar="DIR", help="write track, velocity, convergence PNGs")
    fit.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    fit.add_argument(
        "--refine", action="store_true", help="output-error refinement after the EKF (guarded)"
    )
    batch.add_parser(sub)
    ingest.add_parser(sub)
    crossval.add_parser(sub)
    return parser


def _summary(result: IdentificationResult) -> str:
    units = result.params.units()
    lines = [f"{'coef':>6} {'value':>14} {'std':>11} {'unit':>9}  identifiable"]
    for c in result.coefficients:
        lines.append(
            f"{c.name:>6} {c.value:>14.6g} {c.std:>11.3g} {units[c.name]:>9}  "
            + ("yes" if c.identifiable else "no")
        )
    p = result.params
    lines.append(
        f"nominal: {p.nominal_speed_mps:.3f} m/s at {p.nominal_n_rps * 60.0:.1f} rpm; "
        f"L = {p.length_m:g} m"
    )
    return "\n".join(lines)


def _fit(args: argparse.Namespace) -> int:
    logs = [read_log(path) for path in args.logs]
    settings = FitSettings(
        model=args.model,
        initial=args.initial,
        alpha=args.alpha,
        measurements=args.measurements,
        max_substep_s=args.max_substep_s,
        param_random_walk=args.param_random_walk,
        position_noise_m=args.position_noise_m,
        heading_noise_rad=(
            None if args.heading_noise_deg is None else math.radians(args.heading_noise_deg)
        ),
        refine=args.refine,
    )
    total = 2 * sum(log.n_samples for log in logs)
    with tqdm(total=total, unit="sample", disable=args.quiet, file=sys.stderr) as bar:
        result = identify(logs, settings, length_m=args.length_m, progress=bar.update)
    save_params(args.output, result.params)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    if args.plot:
        from identifier.plots import write_plots

        for path in write_plots(result, args.plot):
            if not args.quiet:
                print(f"wrote {path}")
    if not args.quiet:
        print(_summary(result))
        if result.refinement is not None:
            r = result.refinement
            print(
                f"output error from the {r.initial_method} estimate: kept the {r.kept} one; "
                f"cost {r.initial.cost:.4g} -> "
                f"{r.refined.cost:.4g}, position RMS {r.initial.position_rms_L:.3f} -> "
                f"{r.refined.position_rms_L:.3f} L"
            )
        print(f"wrote {args.output}")
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    args = build_parser().parse_args(argv)
    if args.command == "batch":
        return batch.main(args)
    if args.command == "convert":
        return ingest.main(args)
    if args.command == "crossval":
        return crossval.main(args)
    try:
        return _fit(args)
    except (LogFormatError, IdentificationError, ParamsFormatError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {exc.filename or ''}: {exc.strerror or exc}", file=sys.stderr)
        return 1
