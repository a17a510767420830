"""Manoeuvres run and measured: one programme on a plant, the standard set, IMO verdicts.

:func:`simulate` runs a programme on a plant (an FMU, the reference ship, a model) at
an approach condition through the one programme runner (``trials.run.run_program``);
:func:`measure` takes its ITTC/IMO metrics; :func:`run_standard_set` does both for the
standard set; :func:`imo_criteria` judges the standard runs; :func:`reference_runs`
is the standard set of a reference ship (cached). Problems are
:class:`scenarios.errors.ScenarioError`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from scenarios.errors import ScenarioError
from scenarios.imo import Criterion, evaluate
from scenarios.records import Condition, ManeuverRun
from scenarios.synthesize import reference_ship
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


def run_standard_set(
    plant: Plant,
    condition: Condition,
    length_m: float,
    *,
    on_run: Callable[[str], object] | None = None,
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

    """
    runs = []
    for program in standard_set(length_m, condition.speed_mps):
        trajectory = simulate(plant, program, condition)
        runs.append(ManeuverRun(program, trajectory, measure(program, trajectory)))
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

    Turning ability from the 35° turns, initial turning ability from the 10/10 zig-zag
    (its first leg is 10° rudder held until 10° of heading change: the track distance
    to that point), yaw checking from the 10/10 and 20/20 zig-zags.

    Parameters
    ----------
    runs : sequence of ManeuverRun
        E.g. from :func:`run_standard_set`.
    length_m : float
        Ship length L [m].
    speed_mps : float
        Test speed V [m/s].

    """
    turning = [r.metrics for r in _find(runs, "turning", 35.0)]
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
    return evaluate(
        length_m,
        turning=[m for m in turning if isinstance(m, TurningMetrics)],
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
def _reference_runs_cached(name: str, scale: str, dt_s: float) -> _ReferenceRuns:
    ship = reference_ship(name, scale)
    condition = Condition(ship.speed_mps, ship.n_rps, ship.rudder_rate_radps, dt_s)
    runs = run_standard_set(ship.plant, condition, ship.length_m)
    for run in runs:
        run.trajectory.setflags(write=False)  # shared by every caller of the cache
    return _ReferenceRuns(ship.name, ship.source, ship.length_m, condition, runs)


def reference_runs(
    name: str = "kvlcc2", scale: str = "full", dt_s: float = 0.1
) -> tuple[str, str, float, Condition, tuple[ManeuverRun, ...]]:
    """Run the standard set on a reference ship at its approach condition (cached).

    Returns
    -------
    tuple
        (vessel name, description, length [m], condition, runs); the trajectories are
        read-only.

    """
    try:
        ref = _reference_runs_cached(name, scale, float(dt_s))
    except ValueError as exc:  # unknown vessel or scale
        raise ScenarioError(str(exc)) from None
    return ref.name, ref.description, ref.length_m, ref.condition, ref.runs
