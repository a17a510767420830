"""``python -m identifier fit LOG.csv ... -o params.json``: identify one vessel's model."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fmu_model import DEFAULT_MODEL, argtypes, model_names, save_params
from fmu_model.interface import logged_envelope
from fmu_model.kernels import numba_compilations
from fmu_model.variants import family_name
from identifier.cli.common import (
    DATA_ERRORS,
    add_length_argument,
    add_windage_argument,
    error,
    os_error_text,
)
from identifier.current import CURRENT_MODES, SPEED_LOG_SCALE_STD, CurrentEstimate
from identifier.identify import (
    ALPHA_RANGE,
    HEADING_NOISE_RANGE_DEG,
    MAX_SUBSTEP_RANGE_S,
    METHODS,
    PARAM_RANDOM_WALK_RANGE,
    POSITION_NOISE_RANGE_M,
    SPEED_LOG_SCALE_STD_RANGE,
    FitSettings,
    IdentificationResult,
    identify,
)
from identifier.preparation import vessel_length
from identifier.wind import read_windage
from trials.conditions import MODEL_SCALE_MAX_LENGTH_M
from trials.logs import read_log

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``fit`` command to the subparsers ``sub`` of ``python -m identifier``."""
    fit = sub.add_parser("fit", help="identify coefficients from trial logs")
    fit.add_argument(
        "logs",
        nargs="+",
        metavar="LOG.csv",
        help="trial logs (DESIGN.md format), in any order: the EKF runs through them by "
        "their largest rudder angle, smallest first (its estimate weighs the last most); "
        "with --current drifting in the order they were sailed (their time_origin_utc, "
        "else the order given), the current walking through the time between them too",
    )
    fit.add_argument("-o", "--output", required=True, metavar="params.json")
    fit.add_argument("--model", default=DEFAULT_MODEL, choices=model_names())
    add_length_argument(fit, " (default: from logs)")
    fit.add_argument(
        "--initial",
        choices=("equation-error", "zero"),
        default="equation-error",
        help="EKF start: least-squares fit (default) or the paper's zero start with P0 = alpha I",
    )
    fit.add_argument(
        "--alpha",
        type=argtypes.within(*ALPHA_RANGE),
        default=1.0,
        help="alpha of --initial zero, {:g} to {:g} (default 1)".format(*ALPHA_RANGE),
    )
    fit.add_argument(
        "--measurements",
        choices=("track", "velocities"),
        default="track",
        help="EKF measures the logged track (default) or smoothed u, v, r (the paper)",
    )
    fit.add_argument(
        "--max-substep-s",
        type=argtypes.within(*MAX_SUBSTEP_RANGE_S, "s"),
        default=0.1,
        help=f"largest Euler substep of the EKF [s], at least {MAX_SUBSTEP_RANGE_S[0]:g} "
        "(inf: one step per sample, the paper; default 0.1)",
    )
    fit.add_argument(
        "--param-random-walk",
        type=argtypes.within(*PARAM_RANDOM_WALK_RANGE),
        default=1e-4,
        metavar="RHO",
        help="relative random walk of the coefficients per sample, or per L/U/40 of "
        "faster logs, {:g} to {:g} (default 1e-4)".format(*PARAM_RANDOM_WALK_RANGE),
    )
    fit.add_argument(
        "--position-noise-m",
        type=argtypes.within(*POSITION_NOISE_RANGE_M, "m"),
        help="logger position noise [m], {:g} to {:g} (default: from the logs)".format(
            *POSITION_NOISE_RANGE_M
        ),
    )
    fit.add_argument(
        "--heading-noise-deg",
        type=argtypes.within(*HEADING_NOISE_RANGE_DEG, "deg"),
        help="logger heading noise [deg], {:g} to {:g} (default: from the logs)".format(
            *HEADING_NOISE_RANGE_DEG
        ),
    )
    fit.add_argument("--plot", metavar="DIR", help="write track, velocity, convergence PNGs")
    fit.add_argument("--quiet", action="store_true", help="no progress bar, no summary")
    fit.add_argument(
        "--method",
        choices=METHODS,
        default=METHODS[0],
        help="output-error: refine the EKF estimate by output error, guarded (default: "
        "predicts held-out manoeuvres best); ekf: the EKF estimate (the seed paper)",
    )
    fit.add_argument(
        "--current",
        choices=CURRENT_MODES,
        help="uniform current estimated with the coefficients: constant (a ship's default; "
        "per-log where the logs' approaches or speed logs show different currents), "
        "drifting (a random walk), per-log (one constant current per log: runs sailed at "
        "other times of the tide), none (still water; the default with --measurements "
        "velocities) or auto (a constant one where its fit predicts the training logs' tracks "
        "twice as close as still water's, else none; constant with a speed log; the default "
        "below L = "
        f"{MODEL_SCALE_MAX_LENGTH_M:g} m, a model's size)",
    )
    low_pct, high_pct = (100.0 * f for f in SPEED_LOG_SCALE_STD_RANGE)
    fit.add_argument(
        "--speed-log-scale-std-pct",
        type=argtypes.within(low_pct, high_pct, "%"),
        default=100.0 * SPEED_LOG_SCALE_STD,
        metavar="PCT",
        help="prior sigma of the speed log's (stw_mps) scale error [%% of the speed], "
        f"{low_pct:g} to {high_pct:g} (default {100.0 * SPEED_LOG_SCALE_STD:g}: IMO "
        "MSC.96(72)'s 2 %% as two sigma); the current and the scale error are fitted together",
    )
    add_windage_argument(fit, "and the FMU applies it")
    return fit


def run(args: argparse.Namespace) -> int:
    """Run ``python -m identifier fit`` for parsed ``args``; return the exit status."""
    try:
        return _fit(args)
    except DATA_ERRORS as exc:
        return error(str(exc))
    except OSError as exc:
        return error(os_error_text(exc))


def _summary(result: IdentificationResult, *, current_asked: bool = True) -> str:
    """Return the kept estimate (value, σ) per coefficient, nominal point, current, rates.

    The identifiable column is the EKF's judgement (``identifier.identify.CoefficientReport``:
    excitation, collinearity and the EKF posterior's σ against its estimate), the same
    whichever estimate is kept; value and σ are the kept estimate's. ``current_asked``:
    whether ``--current`` was given (else the ship's size chose it, and the summary says so).
    """
    p = result.params
    units = p.units()
    kept = dict(zip(p.names, p.coefficients, strict=True))
    sigma = np.full(len(p.names), math.nan) if p.std is None else p.std
    std = dict(zip(p.names, sigma, strict=True))
    lines = [f"{'coef':>6} {'value':>14} {'std':>11} {'unit':>9}  identifiable (EKF)"]
    for c in result.coefficients:
        lines.append(
            f"{c.name:>6} {kept[c.name]:>14.6g} {std[c.name]:>11.3g} {units[c.name]:>9}  "
            + ("yes" if c.identifiable else "no")
        )
    lines.append(
        f"nominal: {p.nominal_speed_mps:.3f} m/s through the water at "
        f"{p.nominal_n_rps * 60.0:.1f} rpm; L = {p.length_m:g} m"
    )
    cur, choice = result.current, result.current_choice
    if cur is None and choice is not None:
        lines.append("current (auto → none): still water")
    if cur is not None:
        lines.extend(_current_lines(cur, cur.mode if choice is None else "auto → " + cur.mode))
    if choice is not None:
        defaulted = (
            "" if current_asked else f", a model's default: L < {MODEL_SCALE_MAX_LENGTH_M:g} m"
        )
        lines.append(f"current choice (auto{defaulted}): {choice.kept}, as {choice.reason}")
    ls = result.equation_error
    rates = f"regression on {ls.rows:,} rows at {ls.sample_interval_s:g} s (about L/U/40"
    shape = p.identification.get("shape")
    if shape is not None:
        rates += f"; shape search on {shape['rows']:,} of them, {shape['evaluations']} shapes"
    samples = sum(log.n_samples for log in result.logs)
    lines.append(f"{rates}); the EKF on all {samples:,} samples")
    envelope = logged_envelope(p)
    if envelope is not None:
        lines.append(
            f"the logs reach: {envelope.describe()} (predictions beyond extrapolate: "
            "validate --params says which)"
        )
    return "\n".join(lines)


def _current_lines(cur: CurrentEstimate, mode: str) -> list[str]:
    """Return the summary's lines of the current: it (each log's too), and its speed log."""
    each = (cur, *cur.logs)
    model_form = any(np.any(c.model_form) for c in each)
    alone = [c.speed_log for c in each if c.speed_log is not None]
    lines = []
    for c in each:
        std_n, std_e = c.std_mps
        label = mode if c.log is None else f"{mode}, {Path(c.log).name}"
        lines.append(
            f"current ({label}{', their mean' if c.logs else ''}): {c.speed_mps:.3f} m/s "
            f"towards {math.degrees(c.to_rad):.1f} deg (North {c.north_mps:+.3f} ± "
            f"{std_n:.3f}, East {c.east_mps:+.3f} ± {std_e:.3f} m/s)"
        )
    if not model_form:
        lines[0] += "; the ± are the identification noise only" + (
            "" if alone else ", no speed log measures the hull's share"
        )
    log = cur.speed_log_ekf
    if log is not None and alone:
        measured = (
            f"{log.samples:,} samples measured ({log.rejected:,} rejected), "
            f"noise {log.noise_mps:.3f} m/s"
        )
        if log.transverse_noise_mps is not None:
            measured += (
                f"; transverse axis {log.transverse_samples:,} ({log.transverse_rejected:,} "
                f"rejected), noise {log.transverse_noise_mps:.3f} m/s"
            )
        shows = "; ".join(
            f"North {f.current_ne[0]:+.3f} ± {math.sqrt(f.covariance[0, 0]):.3f}, East "
            f"{f.current_ne[1]:+.3f} ± {math.sqrt(f.covariance[1, 1]):.3f} m/s"
            for f in alone
        )
        lines.append(
            f"speed log: {measured}, scale error {100.0 * log.scale_error:+.2f} "
            f"± {100.0 * log.scale_error_std:.2f} %; alone it shows {shows}"
            + ("; the current's ± include the two estimates' distance (model form)"
               if model_form else "")
        )  # fmt: skip
    return lines


def _fit(args: argparse.Namespace) -> int:
    if args.current not in (None, "none") and args.measurements == "velocities":
        return error(
            f"--current {args.current} needs --measurements track (the smoothed velocities of "
            "'velocities' are over the ground)",
            status=2,
        )
    windage = None if args.windage is None else read_windage(args.windage)
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
        method=args.method,
        current=args.current,
        speed_log_scale_std=args.speed_log_scale_std_pct / 100.0,
        windage=windage,
    )
    total = 2 * sum(log.n_samples for log in logs)
    compiled_before = numba_compilations()[0]
    vessel_length(logs, args.length_m)  # a log's missing length prints alone, before the bar
    with tqdm(total=total, unit="sample", disable=args.quiet, file=sys.stderr) as bar:
        result = identify(
            logs,
            settings,
            length_m=args.length_m,
            progress=bar.update,
            stage=bar.set_description_str,
        )
    save_params(args.output, result.params)
    for warning in result.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    if not args.quiet:
        for note in result.notes:
            print(f"note: {note}", file=sys.stderr)
        compiled = numba_compilations()[0] - compiled_before
        if compiled:
            fitted = family_name(result.params.model)  # prime-rudder-thrust if refitted
            print(
                f"note: compiled {compiled} numba functions (cached now: the first fit of "
                f"{fitted} with these settings on this machine); `python -m scenarios "
                f"warm-up --model {fitted}` does it ahead, in a process of its own",
                file=sys.stderr,
            )
    if args.plot:
        from identifier.plots import write_plots

        for path in write_plots(result, args.plot):
            if not args.quiet:
                print(f"wrote {path}")
    if not args.quiet:
        print(_summary(result, current_asked=args.current is not None))
        if result.refinement is not None:
            r = result.refinement
            print(
                f"output error from the {r.initial_method} estimate: kept the {r.kept} one "
                f"({r.reason}); cost {r.initial.cost:.4g} -> "
                f"{r.refined.cost:.4g}, position RMS {r.initial.position_rms_L:.3f} -> "
                f"{r.refined.position_rms_L:.3f} L"
            )
        elif result.settings.method == "ekf":
            print("kept the EKF estimate (--method ekf)")
        else:
            print("kept the EKF estimate: the output-error refinement was skipped (warning above)")
        print(f"wrote {args.output}")
    return 0
