"""Commands that write a validation report: ``validate`` (an FMU) and ``demo`` (the pipeline).

``validate`` runs the standard set on an FMU and on a reference ship and writes the
report (``--max-error-pct``: exit 3 when a quantity differs by more; ``--params``: 95 %
intervals from the identified covariance; ``--current-mps``/``--wind-mps``: both
ships at sea, ``scenarios.cli.sea``); ``demo`` synthesises logs, identifies, builds a
native FMU and validates it.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from fmu_model import argtypes, load_params
from scenarios.cli.common import EXIT_GATE_FAILED, PROG, make_bars, progress
from scenarios.cli.sea import add_sea_arguments, sea_environment
from scenarios.cli.uncertainty import add_cluster_arguments
from scenarios.demo import DemoConfig, run_demo
from scenarios.records import ComparisonRow, Validation, failing_rows, interval_counts
from scenarios.report import (
    comparison_table,
    extrapolation_lines,
    format_table,
    sea_lines,
    uncertainty_scope,
    write_report,
)
from scenarios.synthesize import REFERENCE_VESSELS
from scenarios.validation import validate

__all__ = [
    "DEFAULT_UNCERTAINTY_SAMPLES",
    "add_demo_command",
    "add_validate_command",
    "check_validate_usage",
    "run_demo_command",
    "run_validate_command",
]

DEFAULT_UNCERTAINTY_SAMPLES = 100


def add_validate_command(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``validate`` to the subparsers ``sub``; ``common`` is the ``--quiet`` parent."""
    p = sub.add_parser("validate", parents=[common], help="FMU vs reference ship report")
    p.add_argument("--fmu", required=True, metavar="F", help="FMI 2.0 co-simulation FMU")
    p.add_argument(
        "--reference",
        choices=REFERENCE_VESSELS,
        default="kvlcc2",
        help="reference ship the FMU is compared with (as synthesize --vessel)",
    )
    p.add_argument("--scale", choices=("full", "model"), default="full")
    p.add_argument("--report", required=True, metavar="DIR", help="report folder")
    p.add_argument(
        "--max-error-pct",
        type=argtypes.non_negative,
        metavar="P",
        help="exit 3 when any |error| exceeds P %% (overshoot angles: relative error too)",
    )
    p.add_argument("--dt-s", type=argtypes.positive, default=0.1, metavar="S", help="step [s]")
    add_sea_arguments(p, correction=True)
    band = p.add_argument_group(
        "uncertainty",
        "95 % intervals of the predicted quantities from the coefficient covariance and "
        "the spread of the fit's alternative estimates; which manoeuvres go beyond the logs",
    )
    band.add_argument(
        "--params",
        metavar="FILE",
        help="params.json the FMU was built from, with its covariance: adds the intervals "
        "and says which manoeuvres go beyond what its logs reached",
    )
    band.add_argument(
        "--uncertainty-samples",
        type=argtypes.count(0),
        metavar="N",
        help=f"Monte-Carlo samples (default {DEFAULT_UNCERTAINTY_SAMPLES} with --params; "
        "0: no intervals)",
    )
    band.add_argument(
        "--uncertainty-dt-s",
        type=argtypes.positive,
        default=0.5,
        metavar="S",
        help="step of the Monte-Carlo runs [s] (default 0.5)",
    )
    band.add_argument(
        "--seed", type=argtypes.count(0), default=0, help="seed of the draw (default 0)"
    )
    add_cluster_arguments(band)


def add_demo_command(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add ``demo`` to the subparsers ``sub``; ``common`` is the ``--quiet`` parent."""
    p = sub.add_parser("demo", parents=[common], help="the whole pipeline on KVLCC2")
    p.add_argument("--out", default="build/demo", metavar="DIR", help="output folder")
    p.add_argument("--quick", action="store_true", help="shorter configuration (tests)")


def check_validate_usage(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser``, the validate subparser) for options that need --params."""
    if args.params is not None:
        return
    if args.uncertainty_samples:
        parser.error("--uncertainty-samples needs --params (the FMU's params.json)")
    if args.scheduler is not None:
        parser.error("--scheduler needs --params (the FMU's params.json)")


def _gate_line(rows: Sequence[ComparisonRow], max_error_pct: float, total: int) -> str:
    parts = [f"{r.label} {'n/a' if r.error_pct is None else f'{r.error_pct:+.1f} %'}" for r in rows]
    return (
        f"{PROG} validate: FAIL: {len(rows)} of {total} quantities differ by more than "
        f"{max_error_pct:g} %: {'; '.join(parts)}"
    )


def run_validate_command(args: argparse.Namespace) -> int:
    """Run ``validate``: write the report; return 0, or 3 when the error gate fails."""
    params = None if args.params is None else load_params(args.params)
    samples = 0
    if params is not None:
        samples = (
            DEFAULT_UNCERTAINTY_SAMPLES
            if args.uncertainty_samples is None
            else args.uncertainty_samples
        )
    if samples:
        where = args.scheduler or f"{args.workers} local workers"
        progress(
            f"validate: then {samples} Monte-Carlo samples of {args.params} "
            f"(step {args.uncertainty_dt_s:g} s) on {where}",
            args.quiet,
        )
    bar = make_bars(args.quiet)("validate", 8, "run")
    try:
        validation = validate(
            args.fmu,
            reference=args.reference,
            scale=args.scale,
            dt_s=args.dt_s,
            on_run=lambda _name: bar.update(1),
            params=params,
            uncertainty_samples=samples,
            uncertainty_dt_s=args.uncertainty_dt_s,
            seed=args.seed,
            scheduler=args.scheduler,
            n_workers=args.workers,
            params_source=args.params or "",
            environment=sea_environment(args),
            current_correction=not args.no_current_correction,
        )
    finally:
        bar.close()
    files = write_report(validation, args.report, max_error_pct=args.max_error_pct)
    _print_validation(validation)
    print(f"report: {files[-1]}")
    if args.max_error_pct is not None:
        failing = failing_rows(validation.rows, args.max_error_pct)
        if failing:
            print(_gate_line(failing, args.max_error_pct, len(validation.rows)), file=sys.stderr)
            return EXIT_GATE_FAILED
    return 0


def _print_validation(validation: Validation) -> None:
    print(
        f"predicted {Path(validation.fmu_path).name} vs reference {validation.reference_name} "
        f"(step {validation.condition.dt_s:g} s)"
    )
    if validation.environment is not None:
        sides = [
            ("reference", validation.reference, validation.reference_length_m),
            ("predicted", validation.predicted, validation.model_length_m),
        ]
        print("\n".join(sea_lines(validation.environment, sides)))
    print(format_table(*comparison_table(validation.rows, validation.extrapolation)))
    for line in extrapolation_lines(validation.envelope, validation.extrapolation):
        print(line)
    if validation.uncertainty is not None:
        inside, judged = interval_counts(validation.rows)
        print(
            f"95 % intervals: {validation.uncertainty.n_samples} Monte-Carlo samples of the "
            f"identified coefficients ({uncertainty_scope(validation.uncertainty)}); "
            f"reference inside for {inside} of {judged} quantities"
        )
    for warning in validation.warnings:
        print(f"warning: {warning}")
    n_pass = sum(c.passed for c in validation.criteria)
    print(
        f"IMO criteria of the predicted model: {'PASS' if validation.imo_passed else 'FAIL'} "
        f"({n_pass} of {len(validation.criteria)} pass)"
    )


def run_demo_command(args: argparse.Namespace) -> int:
    """Run ``demo``: the pipeline, then print where its products are; return the exit status."""
    config = DemoConfig.quick() if args.quick else DemoConfig()
    stages = (
        "synthesize",
        "identify",
        "build FMU",
        "validate",
        *(("uncertainty",) if config.uncertainty_samples > 0 else ()),
        "report",
    )
    start = time.perf_counter()

    def on_stage(name: str, seconds: float, summary: str) -> None:
        index = stages.index(name) + 1 if name in stages else 0
        progress(f"[{index}/{len(stages)}] {name:<10} {seconds:6.1f} s  {summary}", args.quiet)

    result = run_demo(args.out, config, on_stage=on_stage, make_bar=make_bars(args.quiet))
    for warning in result.identification_warnings:
        print(f"identification warning: {warning}", file=sys.stderr)
    for note in result.identification_notes:
        progress(f"identification note: {note}", args.quiet)
    _print_validation(result.validation)
    print(f"demo finished in {time.perf_counter() - start:.1f} s")
    print(f"params: {result.params_path}")
    print(f"FMU:    {result.fmu_path}")
    print(f"report: {result.report_dir / 'report.md'}")
    return 0
