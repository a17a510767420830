"""Command line of the scenarios: ``python -m scenarios <command>`` (DESIGN.md contract).

Commands::

    synthesize      reference-ship trial logs, DIR/<manoeuvre>.csv
    turning-circle  turning circle on an FMU: advance, transfer, tactical diameter
    zigzag          zig-zag δ/ψ on an FMU: overshoots and times
    spiral          Dieudonné spiral on an FMU: r(δ) and the loop width
    pullout         pull-out on an FMU: residual yaw rate, decay time constant
    imo             IMO MSC.137(76) criteria of an FMU (--strict: gate)
    validate        standard set on an FMU and a reference ship, report (--max-error-pct: gate;
                    --params: 95 % intervals from the identified covariance)
    uncertainty     Monte-Carlo 95 % intervals of the standard manoeuvres from params.json
    demo            logs -> identification -> native FMU -> validation report with intervals

Speed and propeller speed default to the FMU's start values (``u0``, ``propeller_rpm``);
the steering-gear rate to 2.34 deg/s (KVLCC2 full scale, a typical large ship's).

Exit status: 0 success; 1 data error (missing or foreign FMU, rudder beyond the FMU's
limit, a run that does not give its metrics, unreadable files); 2 usage error
(argparse); 3 a gate failed (``imo --strict``, ``validate --max-error-pct``). Errors and
gate verdicts are one line on stderr, never a traceback. Progress goes to stderr
(``--quiet`` silences it); results to stdout. Every file is written atomically.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from fmu_model import ParamsFormatError, argtypes
from fmu_model.errors import FmuBuildError
from identifier.errors import IdentificationError, LogFormatError
from scenarios.imo import Criterion
from scenarios.maneuvers import (
    DEFAULT_RUDDER_RATE_DEG_S,
    Program,
    pullout,
    spiral,
    turning_circle,
    zigzag,
)
from scenarios.metrics import (
    MetricsError,
    pullout_metrics,
    spiral_metrics,
    steady_yaw_rate,
)
from scenarios.pipeline import (
    STANDARD_LIMIT_L_OVER_U,
    Bar,
    DemoConfig,
    FmuInfo,
    ScenarioError,
    check_rudder,
    imo_criteria,
    measure,
    open_fmu,
    read_fmu_info,
    run_demo,
    run_standard_set,
    simulate,
    synthesize_logs,
    validate,
)
from scenarios.report import (
    ComparisonRow,
    Condition,
    ManeuverRun,
    Validation,
    comparison_table,
    criteria_table,
    failing_rows,
    format_table,
    interval_counts,
    write_json,
    write_report,
)
from scenarios.synthesize import MANEUVERS
from scenarios.uncertainty import (
    add_cluster_arguments,
    add_uncertainty_command,
    run_uncertainty_command,
)

PROG = "python -m scenarios"
EXIT_DATA_ERROR = 1
EXIT_GATE_FAILED = 3
DEFAULT_UNCERTAINTY_SAMPLES = 100
DEFAULT_SPIRAL_STEPS_DEG = (
    "25,20,15,10,5,2,0,-2,-5,-10,-15,-20,-25,-20,-15,-10,-5,-2,0,2,5,10,15,20,25"
)
# Spiral and pull-out legs default to this many L/U each (600 s for KVLCC2 full scale).
_DEFAULT_HOLD_L_OVER_U = 15.0
# Steady yaw rate of a spiral step: mean over this last fraction of the hold.
_STEADY_FRACTION = 0.3


# ---------------------------------------------------------------- argument types


def _non_zero(text: str) -> float:
    value = argtypes.finite(text)
    if value == 0.0:
        raise argparse.ArgumentTypeError("expected a non-zero angle (the sign gives the side)")
    return value


def _angle_list(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(part) for part in text.split(",") if part.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected comma-separated angles in degrees, got {text!r}"
        ) from None
    if len(values) < 2 or not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError(f"expected at least two finite angles, got {text!r}")
    return values


# ------------------------------------------------------------------------ parser


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``python -m scenarios``."""
    return _build_parsers()[0]


def _build_parsers() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """Return the parser of ``python -m scenarios`` and its subcommands' parsers by name."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Manoeuvres, IMO criteria and validation reports for ship FMUs.",
        epilog="Exit status: 0 ok, 1 data error, 2 usage error, 3 gate failed.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--quiet", action="store_true", help="no progress on stderr")

    fmu_run = argparse.ArgumentParser(add_help=False, parents=[common])
    fmu_run.add_argument("--fmu", required=True, metavar="F", help="FMI 2.0 co-simulation FMU")
    fmu_run.add_argument(
        "--speed-mps",
        type=argtypes.positive,
        metavar="U",
        help="approach speed [m/s] (default: u0)",
    )
    fmu_run.add_argument(
        "--rpm",
        type=argtypes.non_negative,
        metavar="N",
        help="propeller speed [rpm] (default: start)",
    )
    fmu_run.add_argument(
        "--rudder-rate-deg-s",
        type=argtypes.positive,
        default=DEFAULT_RUDDER_RATE_DEG_S,
        metavar="R",
        help=f"steering-gear rate [deg/s] (default {DEFAULT_RUDDER_RATE_DEG_S})",
    )
    fmu_run.add_argument(
        "--dt-s", type=argtypes.positive, default=0.1, metavar="S", help="communication step [s]"
    )

    outputs = argparse.ArgumentParser(add_help=False, parents=[fmu_run])
    outputs.add_argument("--json", metavar="OUT", help="write the metrics as JSON")
    outputs.add_argument("--csv", metavar="OUT", help="write the trajectory as a trial log")
    outputs.add_argument("--plot", metavar="PNG", help="write a figure")
    outputs.add_argument(
        "--max-time-s", type=argtypes.positive, metavar="S", help="time limit (default 60 L/U)"
    )
    outputs.add_argument(
        "--approach-s",
        type=argtypes.non_negative,
        default=0.0,
        metavar="S",
        help="straight run before execute, recorded with negative times [s] (default 0)",
    )

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

    p = sub.add_parser("turning-circle", parents=[outputs], help="turning circle on an FMU")
    p.add_argument(
        "--rudder-deg",
        type=_non_zero,
        default=35.0,
        metavar="DEG",
        help="rudder [deg], < 0 turns to port",
    )
    p.add_argument(
        "--heading-change-deg",
        type=argtypes.positive,
        metavar="DEG",
        default=540.0,
        help="stop after this heading change [deg] (default 540)",
    )

    p = sub.add_parser("zigzag", parents=[outputs], help="zig-zag test on an FMU")
    p.add_argument(
        "--rudder-deg",
        type=argtypes.positive,
        default=10.0,
        metavar="DEG",
        help="rudder angle [deg]",
    )
    p.add_argument(
        "--heading-deg",
        type=argtypes.positive,
        default=10.0,
        metavar="DEG",
        help="check heading [deg]",
    )
    p.add_argument("--port-first", action="store_true", help="first rudder to port")
    p.add_argument(
        "--reversals",
        type=argtypes.count(1),
        default=4,
        metavar="N",
        help="rudder reversals (default 4)",
    )

    p = sub.add_parser("spiral", parents=[outputs], help="Dieudonné spiral on an FMU")
    p.add_argument(
        "--rudder-steps-deg",
        type=_angle_list,
        default=_angle_list(DEFAULT_SPIRAL_STEPS_DEG),
        metavar="LIST",
        help=f'rudder angles in order [deg] (default "{DEFAULT_SPIRAL_STEPS_DEG}")',
    )
    p.add_argument("--hold-s", type=argtypes.positive, help="hold per step [s] (default 15 L/U)")

    p = sub.add_parser("pullout", parents=[outputs], help="pull-out test on an FMU")
    p.add_argument(
        "--rudder-deg",
        type=_non_zero,
        default=20.0,
        metavar="DEG",
        help="rudder [deg], < 0 to port",
    )
    p.add_argument(
        "--turn-s", type=argtypes.positive, help="steady turn before release [s] (15 L/U)"
    )
    p.add_argument("--release-s", type=argtypes.positive, help="run after release [s] (15 L/U)")

    p = sub.add_parser("imo", parents=[fmu_run], help="IMO MSC.137(76) criteria of an FMU")
    p.add_argument("--strict", action="store_true", help="exit 3 when any criterion fails")
    p.add_argument("--json", metavar="OUT", help="write the criteria as JSON")

    p = sub.add_parser("validate", parents=[common], help="FMU vs reference ship report")
    p.add_argument("--fmu", required=True, metavar="F", help="FMI 2.0 co-simulation FMU")
    p.add_argument("--reference", choices=("kvlcc2",), default="kvlcc2")
    p.add_argument("--scale", choices=("full", "model"), default="full")
    p.add_argument("--report", required=True, metavar="DIR", help="report folder")
    p.add_argument(
        "--max-error-pct",
        type=argtypes.non_negative,
        metavar="P",
        help="exit 3 when any |error| exceeds P %% (overshoot angles: relative error too)",
    )
    p.add_argument("--dt-s", type=argtypes.positive, default=0.1, metavar="S", help="step [s]")
    band = p.add_argument_group(
        "uncertainty",
        "95 % intervals of the predicted quantities from the coefficient covariance "
        "(identification noise only, not model-structure error)",
    )
    band.add_argument(
        "--params",
        metavar="FILE",
        help="params.json the FMU was built from, with its covariance: adds the intervals",
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

    add_uncertainty_command(sub)

    p = sub.add_parser("demo", parents=[common], help="the whole pipeline on KVLCC2")
    p.add_argument("--out", default="build/demo", metavar="DIR", help="output folder")
    p.add_argument("--quick", action="store_true", help="shorter configuration (tests)")
    return parser, dict(sub.choices)


# ------------------------------------------------------------------------ helpers


def _progress(message: str, quiet: bool) -> None:
    if not quiet:
        print(message, file=sys.stderr, flush=True)


def _bar(quiet: bool) -> Callable[[str, float | None, str], Bar]:
    def make(description: str, total: float | None, unit: str) -> Bar:
        return tqdm(
            desc=description,
            total=total,
            unit=unit,
            disable=True if quiet else None,  # None: only on a terminal
            file=sys.stderr,
            leave=False,
            dynamic_ncols=True,
        )

    return make


@contextmanager
def _sim_progress(label: str, quiet: bool) -> Iterator[Callable[[float], None]]:
    """Yield a ``run_program`` progress callback counting simulated seconds (tqdm)."""
    with tqdm(
        desc=label,
        unit="s",
        disable=True if quiet else None,  # None: only on a terminal
        file=sys.stderr,
        leave=False,
        dynamic_ncols=True,
    ) as bar:

        def update(t_s: float) -> None:
            bar.update(max(0, int(t_s) - bar.n))

        yield update


def _condition(args: argparse.Namespace, info: FmuInfo) -> Condition:
    speed = args.speed_mps if args.speed_mps is not None else info.speed_mps
    if not speed > 0.0:
        raise ScenarioError(
            f"{info.path}: the FMU has no positive start speed u0; pass --speed-mps"
        )
    rpm = args.rpm if args.rpm is not None else info.rpm
    return Condition(speed, rpm / 60.0, math.radians(args.rudder_rate_deg_s), args.dt_s)


def _limit_s(args: argparse.Namespace, info: FmuInfo, condition: Condition) -> float:
    if getattr(args, "max_time_s", None) is not None:
        return float(args.max_time_s)
    return STANDARD_LIMIT_L_OVER_U * info.length_m / condition.speed_mps


def _hold_s(value: float | None, info: FmuInfo, condition: Condition) -> float:
    return (
        value if value is not None else _DEFAULT_HOLD_L_OVER_U * info.length_m / condition.speed_mps
    )


def _run_record(
    args: argparse.Namespace, info: FmuInfo, program: Program, condition: Condition
) -> dict[str, Any]:
    return {
        "command": args.command,
        "fmu": info.path,
        "model_name": info.model_name,
        "length_m": info.length_m,
        "maneuver": program.name,
        **condition.as_dict(),
        "approach_s": program.approach_s,
    }


def _write_csv(path: str, trajectory: np.ndarray, info: FmuInfo, source: str) -> None:
    from identifier.logs import ManeuverLog, write_log

    log = ManeuverLog(
        time_s=trajectory["time_s"],
        x_m=trajectory["x_m"],
        y_m=trajectory["y_m"],
        heading_rad=trajectory["psi_rad"],
        rudder_rad=trajectory["rudder_rad"],
        n_rps=trajectory["n_rps"],
        metadata={
            "vessel": " ".join(info.model_name.split()) or "ship",
            "length_m": repr(info.length_m),
            "source": source,
            "execute_time_s": "0.0",
        },
    )
    write_log(path, log)


def _source(command: str, info: FmuInfo, program: Program, condition: Condition) -> str:
    c = condition.as_dict()
    return (
        f"simulated {program.name} ({PROG} {command}) on {Path(info.path).name}: "
        f"U {c['speed_mps']:.6g} m/s, {c['rpm']:.6g} rpm, rudder rate "
        f"{c['rudder_rate_deg_s']:.4g} deg/s, step {c['dt_s']:g} s"
    )


def _run_on_fmu(args: argparse.Namespace, program: Program, condition: Condition) -> np.ndarray:
    with open_fmu(args.fmu) as plant, _sim_progress(program.name, args.quiet) as progress:
        return simulate(plant, program, condition, progress)


def _save_outputs(
    args: argparse.Namespace,
    info: FmuInfo,
    program: Program,
    condition: Condition,
    trajectory: np.ndarray,
    record: dict[str, Any],
    figure: Callable[[], Any] | None,
) -> None:
    if args.json:
        write_json(args.json, record)
    if args.csv:
        _write_csv(args.csv, trajectory, info, _source(args.command, info, program, condition))
    if args.plot and figure is not None:
        from scenarios.plots import save_png

        save_png(figure(), args.plot)


def _header(info: FmuInfo, program: Program, condition: Condition) -> str:
    return (
        f"{program.name} on {info.model_name} (L = {info.length_m:g} m): U = "
        f"{condition.speed_mps:.4g} m/s, {condition.n_rps * 60.0:.4g} rpm, rudder rate "
        f"{math.degrees(condition.rudder_rate_radps):.3g} deg/s, step {condition.dt_s:g} s"
    )


# ----------------------------------------------------------------------- commands


def _synthesize(args: argparse.Namespace) -> int:
    bar = _bar(args.quiet)("synthesize", len(args.maneuver), "log")
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


def _turning_circle(args: argparse.Namespace) -> int:
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg)
    check_rudder(info, rudder)
    condition = _condition(args, info)
    program = turning_circle(
        rudder,
        heading_change_rad=math.radians(args.heading_change_deg),
        max_time_s=_limit_s(args, info, condition),
    )
    program = replace(program, approach_s=args.approach_s)
    trajectory = _run_on_fmu(args, program, condition)
    run = ManeuverRun(program, trajectory, measure(program, trajectory))
    record = {**run.metrics_dict(info.length_m), "run": _run_record(args, info, program, condition)}

    def figure() -> Any:
        from scenarios.plots import trajectory_figure

        return trajectory_figure(
            [("", [(info.model_name, trajectory)])], info.length_m, title=_title(info, program)
        )

    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition)]
    for key, label in (
        ("advance", "advance"),
        ("transfer", "transfer"),
        ("tactical_diameter", "tactical diameter"),
        ("steady_diameter", "steady diameter"),
    ):
        if f"{key}_m" in record:
            lines.append(f"  {label:<18} {record[f'{key}_m']:9.1f} m  {record[f'{key}_L']:7.3f} L")
    lines.append(f"  {'time to 90 deg':<18} {record['time_to_90_s']:9.1f} s")
    lines.append(f"  {'speed loss':<18} {record['speed_loss_pct']:9.1f} %")
    print("\n".join(lines))
    return 0


def _zigzag(args: argparse.Namespace) -> int:
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg) * (-1.0 if args.port_first else 1.0)
    check_rudder(info, rudder)
    condition = _condition(args, info)
    program = zigzag(
        rudder,
        math.radians(args.heading_deg),
        n_reversals=args.reversals,
        max_time_s=_limit_s(args, info, condition),
    )
    program = replace(program, approach_s=args.approach_s)
    trajectory = _run_on_fmu(args, program, condition)
    run = ManeuverRun(program, trajectory, measure(program, trajectory))
    record = {**run.metrics_dict(info.length_m), "run": _run_record(args, info, program, condition)}

    def figure() -> Any:
        from scenarios.plots import zigzag_figure

        return zigzag_figure([(info.model_name, trajectory)], title=_title(info, program))

    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition)]
    for key, label, unit in (
        ("first_overshoot_deg", "1st overshoot", "deg"),
        ("second_overshoot_deg", "2nd overshoot", "deg"),
        ("third_overshoot_deg", "3rd overshoot", "deg"),
        ("initial_turning_time_s", "initial turning", "s"),
        ("time_to_check_yaw_s", "time to check yaw", "s"),
        ("period_s", "period", "s"),
    ):
        if key in record:
            lines.append(f"  {label:<18} {record[key]:9.2f} {unit}")
    print("\n".join(lines))
    return 0


def _spiral(args: argparse.Namespace) -> int:
    info = read_fmu_info(args.fmu)
    steps = tuple(math.radians(d) for d in args.rudder_steps_deg)
    for step in steps:
        check_rudder(info, step)
    condition = _condition(args, info)
    hold = _hold_s(args.hold_s, info, condition)
    program = replace(spiral(steps, hold_s=hold), approach_s=args.approach_s)
    trajectory = _run_on_fmu(args, program, condition)
    end = float(trajectory["time_s"][-1])
    rates = []
    for i in range(len(steps)):
        t_end = min((i + 1) * hold, end)
        rates.append(steady_yaw_rate(trajectory, t_end - _STEADY_FRACTION * hold, t_end))
    metrics = spiral_metrics(steps, rates)
    scale = info.length_m / condition.speed_mps
    record: dict[str, Any] = {
        "rudder_deg": [math.degrees(d) for d in metrics.rudder_rad],
        "steady_yaw_rate_degps": [math.degrees(r) for r in metrics.yaw_rate_radps],
        "steady_yaw_rate_nondim": [r * scale for r in metrics.yaw_rate_radps],
        "loop_width_deg": metrics.loop_width_deg,
        "loop_low_deg": None
        if metrics.loop_low_rad is None
        else math.degrees(metrics.loop_low_rad),
        "loop_high_deg": (
            None if metrics.loop_high_rad is None else math.degrees(metrics.loop_high_rad)
        ),
        "stable": metrics.is_stable,
        "hold_s": hold,
        "steady_window_s": _STEADY_FRACTION * hold,
        "run": _run_record(args, info, program, condition),
    }

    def figure() -> Any:
        from scenarios.plots import spiral_figure

        return spiral_figure(
            [(info.model_name, metrics.rudder_rad, metrics.yaw_rate_radps)],
            title=_title(info, program),
        )

    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition), "  rudder [deg]  steady r [deg/s]  r L/U [-]"]
    for d, r, rn in zip(
        record["rudder_deg"],
        record["steady_yaw_rate_degps"],
        record["steady_yaw_rate_nondim"],
        strict=True,
    ):
        lines.append(f"  {d:12.1f}  {r:16.4f}  {rn:9.4f}")
    verdict = "stable (no loop)" if metrics.is_stable else f"loop {metrics.loop_width_deg:.1f} deg"
    lines.append(f"  hysteresis: {verdict}")
    print("\n".join(lines))
    return 0


def _pullout(args: argparse.Namespace) -> int:
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg)
    check_rudder(info, rudder)
    condition = _condition(args, info)
    turn_s = _hold_s(args.turn_s, info, condition)
    release_s = _hold_s(args.release_s, info, condition)
    program = replace(
        pullout(rudder, turn_s=turn_s, release_s=release_s), approach_s=args.approach_s
    )
    trajectory = _run_on_fmu(args, program, condition)
    metrics = pullout_metrics(trajectory, turn_s)

    def deg(value: float | None) -> float | None:
        return None if value is None else math.degrees(value)

    record: dict[str, Any] = {
        "rudder_deg": args.rudder_deg,
        "release_time_s": metrics.release_time_s,
        "initial_yaw_rate_degps": math.degrees(metrics.initial_yaw_rate_radps),
        "residual_yaw_rate_degps": math.degrees(metrics.residual_yaw_rate_radps),
        "fitted_residual_yaw_rate_degps": deg(metrics.fitted_residual_yaw_rate_radps),
        "time_constant_s": metrics.time_constant_s,
        "run": _run_record(args, info, program, condition),
    }

    def figure() -> Any:
        from scenarios.plots import pullout_figure

        return pullout_figure([(info.model_name, trajectory)], title=_title(info, program))

    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition)]
    lines.append(f"  {'yaw rate at release':<26} {record['initial_yaw_rate_degps']:9.4f} deg/s")
    lines.append(f"  {'residual yaw rate':<26} {record['residual_yaw_rate_degps']:9.4f} deg/s")
    if metrics.time_constant_s is not None:
        lines.append(f"  {'decay time constant':<26} {metrics.time_constant_s:9.1f} s")
    print("\n".join(lines))
    return 0


def _criteria_text(criteria: Sequence[Criterion]) -> str:
    return format_table(*criteria_table(criteria))


def _failed_summary(criteria: Sequence[Criterion]) -> str:
    failed = [c for c in criteria if not c.passed]
    return "; ".join(c.name for c in failed)


def _imo(args: argparse.Namespace) -> int:
    info = read_fmu_info(args.fmu)
    check_rudder(info, math.radians(35.0))
    condition = _condition(args, info)
    make = _bar(args.quiet)
    bar = make("imo", 4, "run")
    try:
        with open_fmu(args.fmu) as plant:
            runs = run_standard_set(
                plant, condition, info.length_m, on_run=lambda _name: bar.update(1)
            )
    finally:
        bar.close()
    criteria = imo_criteria(runs, info.length_m, condition.speed_mps)
    passed = all(c.passed for c in criteria)
    if args.json:
        write_json(
            args.json,
            {
                "fmu": info.path,
                "model_name": info.model_name,
                "length_m": info.length_m,
                "condition": condition.as_dict(),
                "passed": passed,
                "criteria": [c.as_dict() for c in criteria],
                "runs": {r.program.name: r.metrics_dict(info.length_m) for r in runs},
            },
        )
    print(
        f"IMO MSC.137(76) criteria of {info.model_name} (L = {info.length_m:g} m, "
        f"V = {condition.speed_mps:.4g} m/s, {condition.n_rps * 60.0:.4g} rpm)"
    )
    print(_criteria_text(criteria))
    n_pass = sum(c.passed for c in criteria)
    print(f"verdict: {'PASS' if passed else 'FAIL'} ({n_pass} of {len(criteria)} criteria pass)")
    if args.strict and not passed:
        print(
            f"{PROG} imo: FAIL: {len(criteria) - n_pass} of {len(criteria)} IMO criteria "
            f"fail: {_failed_summary(criteria)}",
            file=sys.stderr,
        )
        return EXIT_GATE_FAILED
    return 0


def _gate_line(rows: Sequence[ComparisonRow], max_error_pct: float, total: int) -> str:
    parts = [f"{r.label} {'n/a' if r.error_pct is None else f'{r.error_pct:+.1f} %'}" for r in rows]
    return (
        f"{PROG} validate: FAIL: {len(rows)} of {total} quantities differ by more than "
        f"{max_error_pct:g} %: {'; '.join(parts)}"
    )


def _validate(args: argparse.Namespace) -> int:
    from fmu_model import load_params

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
        _progress(
            f"validate: then {samples} Monte-Carlo samples of {args.params} "
            f"(step {args.uncertainty_dt_s:g} s) on {where}",
            args.quiet,
        )
    bar = _bar(args.quiet)("validate", 8, "run")
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
    print(format_table(*comparison_table(validation.rows)))
    if validation.uncertainty is not None:
        inside, judged = interval_counts(validation.rows)
        print(
            f"95 % intervals: {validation.uncertainty.n_samples} Monte-Carlo samples of the "
            f"identified coefficients (identification noise only, not model-structure "
            f"error); reference inside for {inside} of {judged} quantities"
        )
    for warning in validation.warnings:
        print(f"warning: {warning}")
    n_pass = sum(c.passed for c in validation.criteria)
    print(
        f"IMO criteria of the predicted model: {'PASS' if validation.imo_passed else 'FAIL'} "
        f"({n_pass} of {len(validation.criteria)} pass)"
    )


def _demo(args: argparse.Namespace) -> int:
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
        _progress(f"[{index}/{len(stages)}] {name:<10} {seconds:6.1f} s  {summary}", args.quiet)

    result = run_demo(args.out, config, on_stage=on_stage, make_bar=_bar(args.quiet))
    for warning in result.identification_warnings:
        print(f"identification warning: {warning}", file=sys.stderr)
    _print_validation(result.validation)
    print(f"demo finished in {time.perf_counter() - start:.1f} s")
    print(f"params: {result.params_path}")
    print(f"FMU:    {result.fmu_path}")
    print(f"report: {result.report_dir / 'report.md'}")
    return 0


def _title(info: FmuInfo, program: Program) -> str:
    return f"{program.name}: {info.model_name}"


_COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "synthesize": _synthesize,
    "turning-circle": _turning_circle,
    "zigzag": _zigzag,
    "spiral": _spiral,
    "pullout": _pullout,
    "imo": _imo,
    "validate": _validate,
    "demo": _demo,
    "uncertainty": run_uncertainty_command,
}


def _check_validate_usage(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    """Exit 2 (``parser``, the validate subparser) for options that need --params."""
    if args.params is not None:
        return
    if args.uncertainty_samples:
        parser.error("--uncertainty-samples needs --params (the FMU's params.json)")
    if args.scheduler is not None:
        parser.error("--scheduler needs --params (the FMU's params.json)")


def _fail(command: str, message: str) -> int:
    text = message.replace("\r", "\\r").replace("\n", "\\n")
    print(f"{PROG} {command}: error: {text}", file=sys.stderr)
    return EXIT_DATA_ERROR


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0, 1 data error, 3 gate failed).

    Usage errors exit through argparse with status 2.
    """
    parser, commands = _build_parsers()
    args = parser.parse_args(argv)
    if args.command == "validate":
        _check_validate_usage(commands["validate"], args)
    try:
        return _COMMANDS[args.command](args)
    except (
        ScenarioError,
        MetricsError,
        ParamsFormatError,
        LogFormatError,
        IdentificationError,
        FmuBuildError,
    ) as exc:
        return _fail(args.command, str(exc))
    except OSError as exc:
        if exc.filename:
            return _fail(args.command, f"{exc.filename}: {exc.strerror or exc}")
        return _fail(args.command, str(exc))
