"""Manoeuvres run and measured: one programme on a plant, the standard set, IMO verdicts.

:func:`simulate` runs a programme on a plant (an FMU, the reference ship, a model) at
an approach condition through the one programme runner (``trials.run.run_program``);
:func:`measure` takes its ITTC/IMO metrics; :func:`run_standard_set` does both for the
standard set; :func:`imo_criteria` judges the standard runs; :func:`reference_runs`
is the standard set of a reference ship (cached), in calm water or at sea. Problems
are :class:`scenarios.errors.ScenarioError`.

At sea (a plant sailing in a current or a wind) the standard set's 35° turns are
continued to 720° of heading change and corrected for the drift they show, IMO
MSC/Circ.1053 3.4.2.5 (``trials.current_correction``; the velocities of a simulated
run are through the water); IMO 5.3.1 then judges the corrected indices of a turn
whose drift exceeds 1 % of its approach speed, the raw ones of the others
(``scenarios.imo.turning_ability_in_current``), as a trial would: the drift a wind
adds is taken out with the current's. The zig-zags and the initial turning distance
(over ground) are judged as sailed.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from scenarios.errors import ScenarioError
from scenarios.imo import Criterion, evaluate, turning_ability
from scenarios.records import Condition, ManeuverRun, TurnCorrection
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import reference_ship
from trials.current_correction import IMO_MIN_HEADING_CHANGE_RAD, correct_turning_circle
from trials.maneuvers import Program, standard_set
from trials.metrics import (
    MetricsError,
    TurningMetrics,
    ZigzagMetrics,
    distance_at_heading_change,
    turning_metrics,
    zigzag_metrics,
)
from trials.run import Plant, run_program

__all__ = [
    "MAX_STEPS",
    "STANDARD_LIMIT_L_OVER_U",
    "correct_turn",
    "imo_criteria",
    "measure",
    "reference_runs",
    "run_standard_set",
    "simulate",
    "too_many_steps",
]

STANDARD_LIMIT_L_OVER_U = 60.0
"""Time limit of every standard manoeuvre, in units of L/U (``standard_set``)."""

MAX_STEPS = 10_000_000
"""Most communication steps a programme may take: the runner reserves memory for all of
them (64 bytes a step and ship), and no manoeuvre needs more (KVLCC2's 35° turn at
0.1 s may take 24 000); more means a step or a speed given in the wrong unit."""


def too_many_steps(program: Program, dt_s: float) -> str | None:
    """Why ``program`` cannot run at the step ``dt_s`` [s], or None.

    The reason is the number of steps ``trials.run.run_batch`` reserves room for (the
    approach and every leg's time limit, one step for a leg without one) when it is
    over :data:`MAX_STEPS`, or beyond the floating-point range.
    """
    limits_s = program.approach_s + sum(leg.until.time_s or 0.0 for leg in program.legs)
    steps = limits_s / dt_s + len(program.legs) + 1
    if steps <= MAX_STEPS:  # also False for nan
        return None
    return (
        f"{program.name}: {limits_s:.3g} s of time limits in steps of {dt_s:.3g} s are "
        f"{steps:.3g} steps, more than {MAX_STEPS:.0e}; take a longer step or a shorter "
        "time limit (by default 60 L/U: the slower the approach, the longer)"
    )


def simulate(
    plant: Plant,
    program: Program,
    condition: Condition,
    progress: Callable[[float], None] | None = None,
) -> np.ndarray:
    """Run ``program`` on ``plant`` at ``condition``; the trajectory (``TRAJECTORY_DTYPE``).

    Raises
    ------
    ScenarioError
        The FMU reported an error, the simulation diverged, or the programme's time
        limits take more than :data:`MAX_STEPS` steps (:func:`too_many_steps`).

    """
    from fmpy.fmi1 import FMICallException

    problem = too_many_steps(program, condition.dt_s)
    if problem is not None:
        raise ScenarioError(problem)
    try:
        return run_program(
            plant,
            program,
            speed_mps=condition.speed_mps,
            n_rps=condition.n_rps,
            rudder_rate_radps=condition.rudder_rate_radps,
            dt_s=condition.dt_s,
            progress=progress,
        )
    except FMICallException as exc:
        raise ScenarioError(f"{program.name}: the FMU reported an error ({exc})") from None
    except FloatingPointError as exc:
        raise ScenarioError(str(exc)) from None


def measure(program: Program, trajectory: np.ndarray) -> TurningMetrics | ZigzagMetrics:
    """Metrics of a turning circle or zig-zag run (``program.kind``).

    Raises
    ------
    ScenarioError
        The run does not give the metrics (e.g. a turn that never reaches 180°), with
        the manoeuvre's name.

    """
    try:
        if program.kind == "turning":
            return turning_metrics(trajectory)
        if program.kind == "zigzag":
            return zigzag_metrics(trajectory, program.rudder_rad, program.heading_rad)
    except MetricsError as exc:
        raise ScenarioError(f"{program.name}: {exc}") from None
    raise ValueError(f"no standard metrics for a {program.kind!r} manoeuvre")


def correct_turn(run: ManeuverRun, *, enabled: bool = True) -> ManeuverRun:
    """Return a simulated turning run with its current correction (MSC/Circ.1053 3.4.2.5).

    The correction (``trials.current_correction.correct_turning_circle``, velocities
    through the water) needs 720° of heading change; a shorter run gets a
    :class:`~scenarios.records.TurnCorrection` without one, judged raw.

    Parameters
    ----------
    run : ManeuverRun
        A turning circle, executed at t = 0.
    enabled : bool
        False: judge the raw indices whatever the drift.

    """
    try:
        correction = correct_turning_circle(run.trajectory, 0.0, velocities="water")
    except MetricsError:
        correction = None
    return replace(run, current=TurnCorrection(correction, enabled))


def run_standard_set(
    plant: Plant,
    condition: Condition,
    length_m: float,
    *,
    on_run: Callable[[str], object] | None = None,
    at_sea: bool = False,
    current_correction: bool = True,
) -> tuple[ManeuverRun, ...]:
    """Run ``standard_set`` (35° turns both ways, 10/10 and 20/20 zig-zags) on a plant.

    Parameters
    ----------
    plant : Plant
        The ship.
    condition : Condition
        Approach condition and step.
    length_m : float
        Ship length that sets the time limit, 60 L/U [m].
    on_run : callable, optional
        Called with the program name after each run.
    at_sea : bool
        The plant sails in a current or a wind: the turns are continued to 720° and
        corrected for their drift (:func:`correct_turn`; module docstring).
    current_correction : bool
        At sea, False judges the turns' raw indices whatever their drift.

    """
    turn = IMO_MIN_HEADING_CHANGE_RAD if at_sea else math.radians(540.0)
    runs = []
    for program in standard_set(length_m, condition.speed_mps, turn_heading_change_rad=turn):
        trajectory = simulate(plant, program, condition)
        run = ManeuverRun(program, trajectory, measure(program, trajectory))
        if at_sea and program.kind == "turning":
            run = correct_turn(run, enabled=current_correction)
        runs.append(run)
        if on_run is not None:
            on_run(program.name)
    return tuple(runs)


def _find(runs: Sequence[ManeuverRun], kind: str, rudder_deg: float) -> list[ManeuverRun]:
    return [
        r
        for r in runs
        if r.program.kind == kind
        and abs(abs(math.degrees(r.program.rudder_rad)) - rudder_deg) < 1e-6
    ]


def imo_criteria(runs: Sequence[ManeuverRun], length_m: float, speed_mps: float) -> list[Criterion]:
    """IMO MSC.137(76) verdicts from standard runs (``scenarios.imo.evaluate``).

    Turning ability from the 35° turns (a turn sailed at sea on its raw or its
    current-corrected indices, :meth:`ManeuverRun.judgement`), initial turning ability
    from the 10/10 zig-zag (its first leg is 10° rudder held until 10° of heading
    change: the track distance to that point), yaw checking from the 10/10 and 20/20
    zig-zags.

    Parameters
    ----------
    runs : sequence of ManeuverRun
        E.g. from :func:`run_standard_set`.
    length_m : float
        Ship length L [m].
    speed_mps : float
        Test speed V [m/s].

    """
    turning: list[Criterion] = []
    for run in _find(runs, "turning", 35.0):
        judgement = run.judgement(length_m)
        if judgement is not None:
            turning.extend(judgement.criteria)
        elif isinstance(run.metrics, TurningMetrics):
            turning.extend(turning_ability(run.metrics, length_m))
    zz10 = _find(runs, "zigzag", 10.0)
    zz20 = _find(runs, "zigzag", 20.0)
    initial = None
    if zz10:
        try:
            initial = distance_at_heading_change(zz10[0].trajectory, math.radians(10.0))
        except MetricsError as exc:
            raise ScenarioError(f"{zz10[0].program.name}: {exc}") from None
    z10 = zz10[0].metrics if zz10 else None
    z20 = zz20[0].metrics if zz20 else None
    assert z10 is None or isinstance(z10, ZigzagMetrics)
    assert z20 is None or isinstance(z20, ZigzagMetrics)
    return turning + evaluate(
        length_m,
        initial_turning_distance_m=initial,
        zigzag_10=z10,
        zigzag_20=z20,
        speed_mps=speed_mps,
    )


@dataclass(frozen=True)
class _ReferenceRuns:
    name: str
    description: str
    length_m: float
    condition: Condition
    runs: tuple[ManeuverRun, ...]


@functools.lru_cache(maxsize=8)
def _reference_runs_cached(
    name: str,
    scale: str,
    dt_s: float,
    environment: SeaEnvironment | None,
    current_correction: bool,
) -> _ReferenceRuns:
    ship = reference_ship(name, scale, environment)
    condition = Condition(ship.speed_mps, ship.n_rps, ship.rudder_rate_radps, dt_s)
    runs = run_standard_set(
        ship.plant,
        condition,
        ship.length_m,
        at_sea=environment is not None,
        current_correction=current_correction,
    )
    for run in runs:
        run.trajectory.setflags(write=False)  # shared by every caller of the cache
    return _ReferenceRuns(ship.name, ship.source, ship.length_m, condition, runs)


def reference_runs(
    name: str = "kvlcc2",
    scale: str = "full",
    dt_s: float = 0.1,
    *,
    environment: SeaEnvironment | None = None,
    current_correction: bool = True,
) -> tuple[str, str, float, Condition, tuple[ManeuverRun, ...]]:
    """Run the standard set on a reference ship at its approach condition (cached).

    Parameters
    ----------
    name, scale : str
        The reference ship (``scenarios.synthesize.reference_ship``).
    dt_s : float
        Communication step [s].
    environment : SeaEnvironment, optional
        Current and wind it sails in (its own windage, ``scenarios.kvlcc2``); the
        turns are then continued to 720° and corrected (:func:`run_standard_set`).
    current_correction : bool
        At sea, False judges the turns' raw indices whatever their drift.

    Returns
    -------
    tuple
        (vessel name, description, length [m], condition, runs); the trajectories are
        read-only. The description names the environment.

    """
    try:
        ref = _reference_runs_cached(
            name, scale, float(dt_s), environment, bool(current_correction)
        )
    except ValueError as exc:  # unknown vessel or scale
        raise ScenarioError(str(exc)) from None
    return ref.name, ref.description, ref.length_m, ref.condition, ref.runs
