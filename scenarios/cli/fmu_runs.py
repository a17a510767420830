"""Commands that drive one FMU: ``turning-circle``, ``zigzag``, ``spiral``, ``pullout``, ``imo``.

Speed and propeller speed default to the FMU's start values (``u0``, ``propeller_rpm``);
the steering-gear rate to 2.34 deg/s (KVLCC2 full scale, a typical large ship's). Each
manoeuvre prints its metrics and can write them as JSON (``--json``), the trajectory as
a trial log (``--csv``) and a figure (``--plot``); ``imo`` judges the standard set
against IMO MSC.137(76) (``--strict``: exit 3 when a criterion fails).

A turning circle of 720° or more of heading change (``--heading-change-deg``; a log
given to ``--like``) is also corrected for the current it drifted in, by IMO
MSC/Circ.1053 3.4.2.5 (``trials.current_correction``): the raw and the corrected
indices are printed side by side with the drift, and IMO §5.3.1 judges the corrected
ones when the drift exceeds 1 % of the approach speed, else the raw ones (the text and
the JSON say which). The record of such a run gains ``current_corrected``: the
corrected indices (the keys of the raw ones), the drift (``drift_north_mps``,
``drift_east_mps``, ``drift_speed_mps``, ``drift_direction_deg`` towards, their
``spread_*`` over the heading pairs, ``n_pairs``, ``first_heading_change_deg``,
``last_heading_change_deg``, ``mean_period_s``), ``threshold_mps``, ``applied`` and
``imo_basis``, ``imo_reason`` (with ``imo_criteria`` for a 35° or maximum-rudder
turn). A logged turning circle's ``logged`` record gains the same for the log, and a
corrected log is sailed again at its speed through the water and compared corrected.
``--no-current-correction`` keeps the raw values for both.

At sea (``--current-mps C --current-to-deg D``, ``--wind-mps W --wind-from-deg D``,
``scenarios.cli.sea``) the FMU sails in that steady current and wind through its
environment inputs (``scenarios.fmu_plant``); the text names the environment and the
JSON record gains ``environment`` (``current_mps``, ``current_to_deg``, ``wind_mps``,
``wind_from_deg``). A turning circle continued to 720° is then corrected as above (the
drift a wind adds is taken out with the current's, as on a trial); ``imo`` continues
its 35° turns to 720° and judges them so, and says which values it judged. Without
these options every command sails in calm water, as before.

With ``--params`` (the params.json the FMU was built from, checked against it) every
command also says whether its runs go beyond what the identification's logs reached
(``fmu_model.envelope``): the axes and sides after the metrics, and ``extrapolation`` in
the JSON (``scenarios.report.extrapolation_record``; ``imo`` writes it as null without
``--params``).
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np

from fmu_model import argtypes, load_params
from fmu_model.envelope import Envelope, trajectory_envelope
from fmu_model.environment import apparent_wind, ground_velocity_body
from fmu_model.interface import logged_envelope
from identifier.conventions import log_problem
from identifier.current import (
    CURRENT_DISAGREEMENT_MPS,
    CURRENT_DISAGREEMENT_SIGMAS,
    placed_speed_log,
    speed_log_current,
)
from identifier.smoothing import SmoothedTrack, deglitched_log, smooth_log, smoothed_trajectory
from identifier.split import several_manoeuvres
from identifier.wind import mean_true_wind_ne, speed_and_source
from scenarios.cli.common import (
    EXIT_GATE_FAILED,
    PROG,
    STEERING_RATE_HELP,
    make_bars,
    sim_progress,
    steering_rate_deg_s,
)
from scenarios.cli.sea import add_sea_arguments, sea_environment
from scenarios.errors import ScenarioError
from scenarios.fmu_checks import (
    FmuInfo,
    check_environment,
    check_params_match,
    check_rudder,
    open_fmu,
    read_fmu_info,
)
from scenarios.imo import Criterion, TurningJudgement, turning_ability_in_current
from scenarios.records import (
    Condition,
    ManeuverRun,
    beyond_logs,
    current_correction_record,
    environment_record,
)
from scenarios.report import (
    criteria_table,
    extrapolation_lines,
    extrapolation_record,
    format_table,
    sea_lines,
    write_json,
)
from scenarios.runs import (
    STANDARD_LIMIT_L_OVER_U,
    imo_criteria,
    measure,
    run_standard_set,
    simulate,
)
from scenarios.sea import SeaEnvironment
from trials.conditions import (
    LoggedCondition,
    log_trajectory,
    logged_condition,
    maneuver_indices,
)
from trials.current_correction import (
    REFERENCE,
    CurrentCorrection,
    correct_turning_circle,
    remove_drift,
)
from trials.logs import ManeuverLog, at_midship, read_log
from trials.maneuvers import (
    Program,
    pullout,
    spiral,
    turning_circle,
    zigzag,
)
from trials.metrics import MetricsError, pullout_metrics, spiral_metrics, steady_yaw_rate

__all__ = [
    "DEFAULT_SPIRAL_STEPS_DEG",
    "add_fmu_commands",
    "run_imo_command",
    "run_pullout_command",
    "run_spiral_command",
    "run_turning_circle_command",
    "run_zigzag_command",
]

DEFAULT_SPIRAL_STEPS_DEG = (
    "25,20,15,10,5,2,0,-2,-5,-10,-15,-20,-25,-20,-15,-10,-5,-2,0,2,5,10,15,20,25"
)
# Spiral and pull-out legs default to this many L/U each (600 s for KVLCC2 full scale).
_DEFAULT_HOLD_L_OVER_U = 15.0
# Steady yaw rate of a spiral step: mean over this last fraction of the hold.
_STEADY_FRACTION = 0.3
# IMO 5.3.1 judges a turn at 35 deg or the maximum rudder; this much less still counts
# (a log's rudder plateau is read from the log).
_IMO_RUDDER_SLACK_RAD = math.radians(0.5)
# --like warns of a logged mean true wind of this much or more [m/s] that the run does not
# sail in: a 20 m/s head wind moved a 100 m ship's 10/10 overshoots by 4-5 deg (a car
# carrier's windage, tests/test_identify_at_sea.py); the load goes as the square of the
# speed, so 5 m/s moves them some 0.3 deg, what a 1 Hz log's overshoots resolve.
LOGGED_WIND_WARNING_MPS = 5.0
# The turning indices shown raw and current-corrected: (key without unit, label).
_TURNING_LINES = (
    ("advance", "advance"),
    ("transfer", "transfer"),
    ("tactical_diameter", "tactical diameter"),
    ("steady_diameter", "steady diameter"),
)


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


# ------------------------------------------------------------------------ parsers


def add_fmu_commands(sub: Any, common: argparse.ArgumentParser) -> None:
    """Add the commands on one FMU to the subparsers ``sub`` (``common``: ``--quiet``)."""
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
        metavar="R",
        help=STEERING_RATE_HELP,
    )
    fmu_run.add_argument(
        "--dt-s", type=argtypes.positive, default=0.1, metavar="S", help="communication step [s]"
    )
    fmu_run.add_argument(
        "--params",
        metavar="FILE",
        help="params.json the FMU was built from: say which runs go beyond what its logs "
        "reached (the model extrapolates there)",
    )
    add_sea_arguments(fmu_run)

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
    outputs.add_argument(
        "--like",
        metavar="LOG.csv",
        help="sail a logged turning circle or zig-zag again in its own condition (approach "
        "speed, rpm, rudder amplitude and rate, switch headings; these options are then "
        "ignored) and print the logged indices beside the predicted ones",
    )
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
        help="stop after this heading change [deg] (default 540; from 720 on the drift in a "
        "current is estimated and taken out, IMO MSC/Circ.1053 3.4.2.5)",
    )
    p.add_argument(
        "--no-current-correction",
        action="store_true",
        help="judge and compare the raw indices even when the turn shows a drift",
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
    p.add_argument(
        "--no-current-correction",
        action="store_true",
        help="at sea: judge the turns' raw indices even when they show a drift",
    )


# ------------------------------------------------------------------------ helpers


def _condition(args: argparse.Namespace, info: FmuInfo) -> Condition:
    speed = args.speed_mps if args.speed_mps is not None else info.speed_mps
    if not speed > 0.0:
        raise ScenarioError(
            f"{info.path}: the FMU has no positive start speed u0; pass --speed-mps"
        )
    rpm = args.rpm if args.rpm is not None else info.rpm
    rate_deg_s, warning = steering_rate_deg_s(args.rudder_rate_deg_s, info.length_m)
    if warning is not None and not getattr(args, "like", None):  # --like: the log's rate
        print(f"warning: {info.path}: {warning}", file=sys.stderr)
    return Condition(speed, rpm / 60.0, math.radians(rate_deg_s), args.dt_s)


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


def _at_sea(args: argparse.Namespace, info: FmuInfo) -> SeaEnvironment | None:
    """Return the environment the options ask for, checked against the FMU; None in calm water."""
    environment = sea_environment(args)
    if environment is not None:
        check_environment(info)
    return environment


def _sea_record(args: argparse.Namespace, record: dict[str, Any]) -> dict[str, Any]:
    """``record`` with ``environment`` at sea (unchanged in calm water)."""
    environment = sea_environment(args)
    if environment is not None:
        record["environment"] = environment_record(environment)
    return record


def _sea_text(args: argparse.Namespace, info: FmuInfo) -> list[str]:
    """Return the lines naming the environment (none in calm water)."""
    environment = sea_environment(args)
    if environment is None:
        return []
    lines = [f"  at sea: {environment.describe()}"]
    if environment.has_wind and not info.has_windage:
        lines.append(
            "  the FMU has no windage (frontal_area = lateral_area = 0): the wind does not act "
            "on it"
        )
    return lines


def _sensors(
    trajectory: np.ndarray, environment: SeaEnvironment | None
) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None]:
    """Return what a sea trial's log carries beside the track: speed log and anemometer.

    (``stw_mps``, ``wind_speed_mps``, ``wind_angle_rad``): at sea the run's speed through
    the water along the ship (the FMU's u) and, in a wind, the apparent wind an anemometer
    measures (``fmu_model.environment.apparent_wind`` of the true wind and the velocity
    over ground, the current added), so that the written run is a log ``identifier fit``
    takes the current and wind out of; None each in calm water (the log as before).
    """
    if environment is None:
        return None, None, None
    u, v, psi = trajectory["u_mps"], trajectory["v_mps"], trajectory["psi_rad"]
    if not environment.has_wind:
        return np.array(u), None, None
    current_n, current_e, _, _ = environment.current_ne(0.0)  # the CLI's is steady
    u_ground, v_ground = ground_velocity_body(u, v, psi, current_n, current_e)
    speed, angle = apparent_wind(
        environment.wind_speed_mps, environment.wind_from_rad, psi, u_ground, v_ground
    )
    return np.array(u), np.asarray(speed), np.mod(angle, 2.0 * np.pi)


def _write_csv(
    path: str,
    trajectory: np.ndarray,
    info: FmuInfo,
    source: str,
    environment: SeaEnvironment | None,
) -> None:
    from trials.logs import ManeuverLog, write_log

    stw_mps, wind_speed_mps, wind_angle_rad = _sensors(trajectory, environment)
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
        stw_mps=stw_mps,
        wind_speed_mps=wind_speed_mps,
        wind_angle_rad=wind_angle_rad,
    )
    write_log(path, log)


def _source(args: argparse.Namespace, info: FmuInfo, program: Program, condition: Condition) -> str:
    c = condition.as_dict()
    text = (
        f"simulated {program.name} ({PROG} {args.command}) on {Path(info.path).name}: "
        f"U {c['speed_mps']:.6g} m/s, {c['rpm']:.6g} rpm, rudder rate "
        f"{c['rudder_rate_deg_s']:.4g} deg/s, step {c['dt_s']:g} s"
    )
    environment = sea_environment(args)
    if environment is not None:
        text += f"; at sea: {environment.describe()}"
    return text


def _run_on_fmu(
    args: argparse.Namespace, info: FmuInfo, program: Program, condition: Condition
) -> np.ndarray:
    environment = _at_sea(args, info)
    with (
        open_fmu(args.fmu, environment) as plant,
        sim_progress(program.name, args.quiet) as progress,
    ):
        return simulate(plant, program, condition, progress)


class _MeasuredRun(NamedTuple):
    """What :func:`_measured_run` sailed, and with ``--like`` what was logged."""

    program: Program
    condition: Condition
    trajectory: np.ndarray
    record: dict[str, Any]
    lines: list[str]
    """The lines that report the log's current (none without one)."""
    logged: np.ndarray | None
    """The log as the run's figure overlays it (:func:`logged_run`); None without one."""


def logged_run(logged: np.ndarray, execute_time_s: float, trajectory: np.ndarray) -> np.ndarray:
    """Return a logged manoeuvre laid over a run of it, for the run's figure.

    ``logged``, the log's smoothed trajectory (the one its indices are read off,
    ``identifier.smoothing.smoothed_trajectory``), from the start of ``trajectory`` on,
    its time from its execute point at ``execute_time_s`` [s], turned and moved so that
    at execute it is where the run is at time 0, with the run's heading: predicted and
    logged then part where the model does.
    """
    traj = np.array(logged, copy=True)
    here = [np.interp(execute_time_s, traj["time_s"], traj[k]) for k in ("x_m", "y_m", "psi_rad")]
    there = [np.interp(0.0, trajectory["time_s"], trajectory[k]) for k in ("x_m", "y_m", "psi_rad")]
    turn = there[2] - here[2]
    north, east = traj["x_m"] - here[0], traj["y_m"] - here[1]
    traj["x_m"] = there[0] + math.cos(turn) * north - math.sin(turn) * east
    traj["y_m"] = there[1] + math.sin(turn) * north + math.cos(turn) * east
    traj["psi_rad"] += turn
    traj["time_s"] -= execute_time_s
    return traj[traj["time_s"] >= trajectory["time_s"][0]]


def _figure_runs(
    args: argparse.Namespace, info: FmuInfo, trajectory: np.ndarray, logged: np.ndarray | None
) -> list[tuple[str, np.ndarray]]:
    """Return the runs of a turning circle's or zig-zag's figure: the log first, if any."""
    predicted = (info.model_name, trajectory)
    if logged is None:
        return [predicted]
    return [(f"logged ({Path(args.like).name})", logged), predicted]


def _measured_run(
    args: argparse.Namespace, info: FmuInfo, program: Program, condition: Condition
) -> _MeasuredRun:
    """Run a turning circle or zig-zag after ``--approach-s``; its JSON record of metrics.

    With ``--like LOG.csv`` the program and condition are the log's
    (``trials.conditions.logged_condition``; a log in another convention, or without a
    straight approach, is a data error: ``identifier.conventions.log_problem``), and the
    record gains the log's own indices, read off its smoothed track
    (``identifier.smoothing.smoothed_trajectory``), under ``"logged"``. A logged turning
    circle of 720° or more is corrected for its current (:func:`_corrected_log`): the
    record's ``logged`` gains ``current_corrected``, and when the drift counts the ship
    sails the corrected log's condition (its approach speed through the water).
    """
    logged: dict[str, Any] | None = None
    lines: list[str] = []
    overlay: tuple[np.ndarray, float] | None = None
    if args.like:
        log = at_midship(read_log(args.like))  # judged and deglitched as fit does
        track = smooth_log(log)
        problem = log_problem(log, info.length_m, track)
        if problem is not None:
            message, sample = problem
            at = "" if sample is None else f"sample {sample}: "
            raise ScenarioError(f"{args.like}: {at}{message}")
        if (several := several_manoeuvres(log, info.length_m, track)) is not None:
            print(f"warning: {args.like}: {several}", file=sys.stderr)
        log = deglitched_log(log, track)  # a compass spike is no overshoot
        limit_s = _limit_s(args, info, condition)
        like = logged_condition(log, max_time_s=limit_s)
        if like.program.kind != program.kind:
            raise ScenarioError(
                f"{args.like}: the log is a {like.program.kind} manoeuvre, not a {program.kind}"
            )
        check_rudder(info, like.program.rudder_rad)
        smoothed = smoothed_trajectory(log, track)
        current: dict[str, Any] | None = None
        corrected: _CorrectedLog | None = None
        if like.program.kind == "turning":
            corrected, current, lines = _corrected_log(args, info, log, smoothed, like)
            if corrected is not None:
                like = logged_condition(corrected.log, max_time_s=limit_s)
        overlay = (smoothed if corrected is None else corrected.smoothed), like.execute_time_s
        if corrected is None and getattr(args, "current_mps", None) is None:
            _warn_of_logged_current(args.like, log, track)
        if info.has_windage and getattr(args, "wind_mps", None) is None:
            _warn_of_logged_wind(args.like, log, track)
        program = like.program
        condition = Condition(like.speed_mps, like.n_rps, like.rudder_rate_radps, args.dt_s)
        angles = (program.rudder_rad, program.heading_rad)
        logged = {**maneuver_indices(program.kind, smoothed, like.execute_time_s, angles)}
        if current is not None:
            logged["current_corrected"] = current
    program = replace(program, approach_s=args.approach_s)
    trajectory = _run_on_fmu(args, info, program, condition)
    run = ManeuverRun(program, trajectory, measure(program, trajectory))
    record = {**run.metrics_dict(info.length_m), "run": _run_record(args, info, program, condition)}
    _sea_record(args, record)
    if logged is not None:
        record["logged"] = {"log": args.like, **logged}
    laid = None if overlay is None else logged_run(*overlay, trajectory)
    return _MeasuredRun(program, condition, trajectory, record, lines, laid)


def _judged_by_imo(info: FmuInfo, rudder_rad: float) -> bool:
    """Whether IMO 5.3.1 applies to a turn at ``rudder_rad``: 35 deg or the FMU's maximum."""
    full = min(math.radians(35.0), info.rudder_limit_rad)
    return abs(rudder_rad) >= full - _IMO_RUDDER_SLACK_RAD


def _current_of_turn(
    args: argparse.Namespace,
    info: FmuInfo,
    trajectory: np.ndarray,
    execute_time_s: float,
    rudder_rad: float,
    *,
    velocities: Literal["ground", "water"],
    where: str,
) -> tuple[CurrentCorrection, dict[str, Any], list[str]] | None:
    """Correct a turning circle for its current; return that, its JSON record and text lines.

    None when the turn does not allow one (less than 720 deg of heading change).
    ``velocities``: ``"water"`` for a simulated run, ``"ground"`` for a log.
    """
    try:
        correction = correct_turning_circle(trajectory, execute_time_s, velocities=velocities)
    except MetricsError:
        return None
    judgement = turning_ability_in_current(
        correction.raw, correction, info.length_m, correct=not args.no_current_correction
    )
    judged = _judged_by_imo(info, rudder_rad)
    record = current_correction_record(correction, judgement, info.length_m)
    if judged:
        record["imo_criteria"] = [c.as_dict() for c in judgement.criteria]
    return correction, record, _current_lines(correction, judgement, where, judged)


def _current_lines(
    correction: CurrentCorrection,
    judgement: TurningJudgement,
    where: str,
    judged: bool,
) -> list[str]:
    """Text: the drift, raw and corrected indices side by side, the IMO basis."""
    e = correction.estimate
    lines = [
        f"  current in {where} ({REFERENCE}, {e.n_pairs} heading pairs one turn apart from "
        f"{math.degrees(e.first_heading_change_rad):.0f} to "
        f"{math.degrees(e.last_heading_change_rad):.0f} deg): drift {e.speed_mps:.3f} m/s "
        f"towards {math.degrees(e.direction_rad):.1f} deg (N {e.drift_north_mps:+.4f}, "
        f"E {e.drift_east_mps:+.4f} m/s; spread {e.spread_north_mps:.4f}, "
        f"{e.spread_east_mps:.4f} m/s)",
        f"  {'':<18} {'raw':>11}  {'corrected':>11}",
    ]
    for key, label in _TURNING_LINES:
        raw = getattr(correction.raw, f"{key}_m")
        corrected = getattr(correction.corrected, f"{key}_m")
        if raw is not None and corrected is not None:
            lines.append(f"  {label:<18} {raw:9.1f} m  {corrected:9.1f} m")
    values = "current-corrected" if judgement.corrected else "raw"
    if judged:
        lines.append(f"  IMO MSC.137(76) 5.3.1 judged on the {values} values ({judgement.reason}):")
        lines.extend(f"    {c.describe()}" for c in judgement.criteria)
    else:
        lines.append(f"  {values} values stand ({judgement.reason})")
    return lines


def _warn_of_logged_current(path: str, log: ManeuverLog, track: SmoothedTrack) -> None:
    """Warn when ``log``'s speed log shows a current its run is not sailed in.

    The logged indices are over the ground, the FMU's run in still water unless
    ``--current-mps`` says otherwise: a current the speed log shows
    (``identifier.current.speed_log_current``) of ``CURRENT_DISAGREEMENT_MPS`` or more,
    and ``CURRENT_DISAGREEMENT_SIGMAS`` of its σ, makes them differ by its drift.
    """
    found = speed_log_current([placed_speed_log(log)], [track])
    if found is None:
        return
    north, east = (float(c) for c in found.current_ne)
    speed = math.hypot(north, east)
    sigma = math.sqrt(float(np.max(np.linalg.eigvalsh(found.covariance))))
    if speed < max(CURRENT_DISAGREEMENT_MPS, CURRENT_DISAGREEMENT_SIGMAS * sigma):
        return
    towards = math.degrees(math.atan2(east, north)) % 360.0
    print(
        f"warning: {path}: its speed log shows a current of {speed:.2f} m/s towards "
        f"{towards:.0f} deg, whose drift the logged indices carry; the run sails in still "
        f"water: give --current-mps {speed:.2f} --current-to-deg {towards:.0f} to sail it in "
        "that current",
        file=sys.stderr,
    )


def _warn_of_logged_wind(path: str, log: ManeuverLog, track: SmoothedTrack) -> None:
    """Warn when ``log`` carries a wind of :data:`LOGGED_WIND_WARNING_MPS` or more.

    Its mean true wind (``identifier.wind.mean_true_wind_ne``) loaded the logged run; the
    FMU's run, with its windage, is sailed in still air unless ``--wind-mps`` says
    otherwise.
    """
    wind = mean_true_wind_ne(log, track)
    if wind is None:
        return
    speed, from_rad = speed_and_source(wind)
    if speed < LOGGED_WIND_WARNING_MPS:
        return
    source = round(math.degrees(from_rad)) % 360
    print(
        f"warning: {path}: its anemometer shows a mean true wind of {speed:.1f} m/s from "
        f"{source} deg, which loaded the logged run; the run sails in still air: give "
        f"--wind-mps {speed:.1f} --wind-from-deg {source} to sail it in that wind",
        file=sys.stderr,
    )


class _CorrectedLog(NamedTuple):
    """A logged turning circle with its current's drift taken out (:func:`_corrected_log`)."""

    log: ManeuverLog
    """The log, its positions corrected (what its condition is read off)."""
    smoothed: np.ndarray
    """Its smoothed trajectory, corrected (what the figure draws)."""


def _corrected_log(
    args: argparse.Namespace,
    info: FmuInfo,
    log: ManeuverLog,
    smoothed: np.ndarray,
    like: LoggedCondition,
) -> tuple[_CorrectedLog | None, dict[str, Any] | None, list[str]]:
    """Correct a logged turning circle for its current, when it shows one.

    The drift is estimated on the log's ``smoothed`` trajectory (the one its indices are
    read off). Returns (the corrected log, or None when the correction is not applied;
    the ``current_corrected`` record, or None when the log covers less than 720 deg; the
    text lines).
    """
    found = _current_of_turn(
        args,
        info,
        smoothed,
        like.execute_time_s,
        like.program.rudder_rad,
        velocities="ground",
        where="the log",
    )
    if found is None:
        return None, None, []
    correction, record, lines = found
    if not record["applied"]:
        return None, record, lines
    e = correction.estimate
    raw = remove_drift(log_trajectory(log), e.drift_north_mps, e.drift_east_mps, e.execute_time_s)
    corrected = replace(log, x_m=raw["x_m"], y_m=raw["y_m"])
    return _CorrectedLog(corrected, correction.trajectory), record, lines


def _logged_lines(record: dict[str, Any]) -> list[str]:
    """Lines "logged vs predicted" of a ``--like`` run (none without it).

    A log corrected for its current is compared with its corrected indices, and so is
    a run sailed in a current whose correction counts (``--current-mps``).
    """
    logged = record.get("logged")
    if logged is None:
        return []
    current = logged.get("current_corrected")
    corrected = current is not None and current["applied"]
    sailed: dict[str, Any] = record.get("current_corrected") or {}
    predicted_corrected = bool(sailed.get("applied"))
    lines = [f"  as logged in {logged['log']}{', current-corrected' if corrected else ''}:"]
    if predicted_corrected:
        lines.append("  predicted: the run's current-corrected indices")
    for key, value in logged.items():
        if key in ("log", "current_corrected"):
            continue
        if corrected:
            value = current.get(key)  # a steady diameter only where the turn reaches 540 deg
        if value is None or record.get(key) is None:
            continue
        predicted = sailed.get(key) if predicted_corrected else None
        if predicted is None:
            predicted = record[key]
        unit = key.rsplit("_", 1)[-1]
        lines.append(
            f"  {key:<22} logged {value:9.2f} {unit}  predicted {predicted:9.2f} {unit}  "
            f"difference {predicted - value:+8.2f} {unit}"
        )
    return lines


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
        source = _source(args, info, program, condition)
        _write_csv(args.csv, trajectory, info, source, sea_environment(args))
    if args.plot and figure is not None:
        from scenarios.plots import save_png

        save_png(figure(), args.plot)


def _params_envelope(args: argparse.Namespace, info: FmuInfo) -> Envelope | None:
    """Return the envelope of the logs of ``--params`` (checked against the FMU), if given."""
    if args.params is None:
        return None
    params = load_params(args.params)
    check_params_match(info, params, args.params)
    return logged_envelope(params)


def _extrapolation(
    envelope: Envelope | None,
    program: Program,
    trajectory: np.ndarray,
    info: FmuInfo,
    record: dict[str, Any],
) -> list[str]:
    """Judge one run against the logs' ``envelope``: into ``record``; the lines to print."""
    if envelope is None:
        return []
    beyond = {program.name: envelope.beyond(trajectory_envelope(trajectory, info.length_m))}
    record["extrapolation"] = extrapolation_record(envelope, beyond)
    return extrapolation_lines(envelope, beyond)


def _header(info: FmuInfo, program: Program, condition: Condition) -> str:
    return (
        f"{program.name} on {info.model_name} (L = {info.length_m:g} m): U = "
        f"{condition.speed_mps:.4g} m/s, {condition.n_rps * 60.0:.4g} rpm, rudder rate "
        f"{math.degrees(condition.rudder_rate_radps):.3g} deg/s, step {condition.dt_s:g} s"
    )


def _title(info: FmuInfo, program: Program) -> str:
    return f"{program.name}: {info.model_name}"


# ----------------------------------------------------------------------- commands


def run_turning_circle_command(args: argparse.Namespace) -> int:
    """Run ``turning-circle``: print advance, transfer, diameters; return the exit status."""
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg)
    check_rudder(info, rudder)
    envelope = _params_envelope(args, info)
    condition = _condition(args, info)
    program = turning_circle(
        rudder,
        heading_change_rad=math.radians(args.heading_change_deg),
        max_time_s=_limit_s(args, info, condition),
    )
    sailed = _measured_run(args, info, program, condition)
    program, condition, trajectory, record = sailed[:4]
    current_lines: list[str] = []
    found = _current_of_turn(
        args, info, trajectory, 0.0, program.rudder_rad, velocities="water", where="this run"
    )
    if found is not None:
        record["current_corrected"] = found[1]
        current_lines = found[2]
    elif sea_environment(args) is not None:
        current_lines = [
            f"  raw values: the current correction ({REFERENCE}) needs 720 deg of heading "
            "change (--heading-change-deg 720)"
        ]

    def figure() -> Any:
        from scenarios.plots import trajectory_figure

        return trajectory_figure(
            [("", _figure_runs(args, info, trajectory, sailed.logged))],
            info.length_m,
            title=_title(info, program),
        )

    beyond_lines = _extrapolation(envelope, program, trajectory, info, record)
    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition), *_sea_text(args, info)]
    for key, label in _TURNING_LINES:
        if f"{key}_m" in record:
            lines.append(f"  {label:<18} {record[f'{key}_m']:9.1f} m  {record[f'{key}_L']:7.3f} L")
    lines.append(f"  {'time to 90 deg':<18} {record['time_to_90_s']:9.1f} s")
    lines.append(f"  {'speed loss':<18} {record['speed_loss_pct']:9.1f} %")
    print("\n".join(lines + current_lines + sailed.lines + _logged_lines(record) + beyond_lines))
    return 0


def run_zigzag_command(args: argparse.Namespace) -> int:
    """Run ``zigzag``: print the overshoots and times; return the exit status."""
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg) * (-1.0 if args.port_first else 1.0)
    check_rudder(info, rudder)
    envelope = _params_envelope(args, info)
    condition = _condition(args, info)
    program = zigzag(
        rudder,
        math.radians(args.heading_deg),
        n_reversals=args.reversals,
        max_time_s=_limit_s(args, info, condition),
    )
    sailed = _measured_run(args, info, program, condition)
    program, condition, trajectory, record = sailed[:4]

    def figure() -> Any:
        from scenarios.plots import zigzag_figure

        runs = _figure_runs(args, info, trajectory, sailed.logged)
        return zigzag_figure(runs, title=_title(info, program))

    beyond_lines = _extrapolation(envelope, program, trajectory, info, record)
    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition), *_sea_text(args, info)]
    if sea_environment(args) is not None:
        lines.append("  overshoots and times as sailed (no current correction for a zig-zag)")
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
    print("\n".join(lines + _logged_lines(record) + beyond_lines))
    return 0


def run_spiral_command(args: argparse.Namespace) -> int:
    """Run ``spiral``: print r(δ) and the loop width; return the exit status."""
    info = read_fmu_info(args.fmu)
    steps = tuple(math.radians(d) for d in args.rudder_steps_deg)
    for step in steps:
        check_rudder(info, step)
    envelope = _params_envelope(args, info)
    condition = _condition(args, info)
    hold = _hold_s(args.hold_s, info, condition)
    program = replace(spiral(steps, hold_s=hold), approach_s=args.approach_s)
    trajectory = _run_on_fmu(args, info, program, condition)
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
    _sea_record(args, record)

    def figure() -> Any:
        from scenarios.plots import spiral_figure

        return spiral_figure(
            [(info.model_name, metrics.rudder_rad, metrics.yaw_rate_radps)],
            title=_title(info, program),
        )

    beyond_lines = _extrapolation(envelope, program, trajectory, info, record)
    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [
        _header(info, program, condition),
        *_sea_text(args, info),
        "  rudder [deg]  steady r [deg/s]  r L/U [-]",
    ]
    for d, r, rn in zip(
        record["rudder_deg"],
        record["steady_yaw_rate_degps"],
        record["steady_yaw_rate_nondim"],
        strict=True,
    ):
        lines.append(f"  {d:12.1f}  {r:16.4f}  {rn:9.4f}")
    verdict = "stable (no loop)" if metrics.is_stable else f"loop {metrics.loop_width_deg:.1f} deg"
    lines.append(f"  hysteresis: {verdict}")
    print("\n".join(lines + beyond_lines))
    return 0


def run_pullout_command(args: argparse.Namespace) -> int:
    """Run ``pullout``: print the residual yaw rate and decay time; return the exit status."""
    info = read_fmu_info(args.fmu)
    rudder = math.radians(args.rudder_deg)
    check_rudder(info, rudder)
    envelope = _params_envelope(args, info)
    condition = _condition(args, info)
    turn_s = _hold_s(args.turn_s, info, condition)
    release_s = _hold_s(args.release_s, info, condition)
    program = replace(
        pullout(rudder, turn_s=turn_s, release_s=release_s), approach_s=args.approach_s
    )
    trajectory = _run_on_fmu(args, info, program, condition)
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
    _sea_record(args, record)

    def figure() -> Any:
        from scenarios.plots import pullout_figure

        return pullout_figure([(info.model_name, trajectory)], title=_title(info, program))

    beyond_lines = _extrapolation(envelope, program, trajectory, info, record)
    _save_outputs(args, info, program, condition, trajectory, record, figure)
    lines = [_header(info, program, condition), *_sea_text(args, info)]
    lines.append(f"  {'yaw rate at release':<26} {record['initial_yaw_rate_degps']:9.4f} deg/s")
    lines.append(f"  {'residual yaw rate':<26} {record['residual_yaw_rate_degps']:9.4f} deg/s")
    if metrics.time_constant_s is not None:
        lines.append(f"  {'decay time constant':<26} {metrics.time_constant_s:9.1f} s")
    print("\n".join(lines + beyond_lines))
    return 0


def _criteria_text(criteria: Sequence[Criterion]) -> str:
    return format_table(*criteria_table(criteria))


def _failed_summary(criteria: Sequence[Criterion]) -> str:
    failed = [c for c in criteria if not c.passed]
    return "; ".join(c.name for c in failed)


def run_imo_command(args: argparse.Namespace) -> int:
    """Run ``imo``: print the criteria; return 0, or 3 with ``--strict`` and a failure."""
    info = read_fmu_info(args.fmu)
    check_rudder(info, math.radians(35.0))
    envelope = _params_envelope(args, info)
    condition = _condition(args, info)
    environment = _at_sea(args, info)
    make = make_bars(args.quiet)
    bar = make("imo", 4, "run")
    try:
        with open_fmu(args.fmu, environment) as plant:
            runs = run_standard_set(
                plant,
                condition,
                info.length_m,
                on_run=lambda _name: bar.update(1),
                at_sea=environment is not None,
                current_correction=not args.no_current_correction,
            )
    finally:
        bar.close()
    criteria = imo_criteria(runs, info.length_m, condition.speed_mps)
    passed = all(c.passed for c in criteria)
    beyond = None if envelope is None else beyond_logs(envelope, runs, info.length_m)
    if args.json:
        write_json(
            args.json,
            _sea_record(
                args,
                {
                    "fmu": info.path,
                    "model_name": info.model_name,
                    "length_m": info.length_m,
                    "condition": condition.as_dict(),
                    "passed": passed,
                    "criteria": [c.as_dict() for c in criteria],
                    "runs": {r.program.name: r.metrics_dict(info.length_m) for r in runs},
                    "extrapolation": extrapolation_record(envelope, beyond),
                },
            ),
        )
    print(
        f"IMO MSC.137(76) criteria of {info.model_name} (L = {info.length_m:g} m, "
        f"V = {condition.speed_mps:.4g} m/s, {condition.n_rps * 60.0:.4g} rpm)"
    )
    if environment is not None:
        print("\n".join(sea_lines(environment, [("", runs, info.length_m)])))
        for line in _sea_text(args, info)[1:]:
            print(line.strip())
    print(_criteria_text(criteria))
    for line in extrapolation_lines(envelope, beyond):
        print(line)
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
