"""Run manoeuvres on FMUs and reference ships; validation; the end-to-end demo pipeline.

The functions behind ``python -m scenarios``: they print nothing and report progress
through callbacks, raising :class:`ScenarioError` (one line) for bad input data.

The demo pipeline (:func:`run_demo`), DESIGN.md "The data flow" end to end::

    OUT/logs/<manoeuvre>.csv   synthetic KVLCC2 trial logs (noisy, seeds fixed)
    OUT/params.json            identified coefficients (identifier.identify)
    OUT/<vessel>.fmu           native FMI 2.0 co-simulation FMU (fmu_model.export_native)
    OUT/report/                validation against the reference ship (scenarios.report),
                               with the 95 % intervals from the identified covariance
                               (scenarios.uncertainty on a local dask cluster)
"""

from __future__ import annotations

import functools
import math
import os
import time
import zlib
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

import numpy as np

from fmu_model.variants import DEFAULT_MODEL
from scenarios.imo import Criterion, evaluate
from scenarios.maneuvers import Program, standard_set
from scenarios.metrics import (
    MetricsError,
    TurningMetrics,
    ZigzagMetrics,
    distance_at_heading_change,
    turning_metrics,
    zigzag_metrics,
)
from scenarios.report import (
    Condition,
    ManeuverRun,
    Validation,
    interval_counts,
    uncertainty_bands,
    write_report,
)
from scenarios.run import FmuPlant, Plant, run_program
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log

if TYPE_CHECKING:
    from distributed import Client

    from fmu_model import ModelParameters

__all__ = [
    "STANDARD_LIMIT_L_OVER_U",
    "Bar",
    "BarFactory",
    "DemoConfig",
    "DemoResult",
    "FmuInfo",
    "ScenarioError",
    "check_params_match",
    "check_rudder",
    "imo_criteria",
    "maneuver_seed",
    "measure",
    "open_fmu",
    "read_fmu_info",
    "reference_runs",
    "run_demo",
    "run_standard_set",
    "simulate",
    "synthesize_logs",
    "validate",
    "with_uncertainty",
]


STANDARD_LIMIT_L_OVER_U = 60.0
"""Time limit of every standard manoeuvre, in units of L/U (``standard_set``)."""

# Variables an FMU must have to be driven by scenarios.run.FmuPlant.
_REQUIRED_VARIABLES = (
    "rudder_angle",
    "propeller_rpm",
    "u",
    "v",
    "r",
    "x",
    "y",
    "psi",
    "length",
    "u0",
    "v0",
    "r0",
    "x0",
    "y0",
    "psi0",
)


class ScenarioError(RuntimeError):
    """Bad input to a scenario (FMU, option, manoeuvre); ``str()`` is one line."""

    def __init__(self, message: str) -> None:
        super().__init__(message.replace("\r", "\\r").replace("\n", "\\n"))


class Bar(Protocol):
    """A progress bar (``tqdm`` is one)."""

    def update(self, n: float = 1) -> object:
        """Advance by ``n``."""

    def close(self) -> None:
        """Finish the bar."""


BarFactory = Callable[[str, float | None, str], Bar]
"""``make_bar(description, total or None, unit)`` → a :class:`Bar`."""


class _NoBar:
    def update(self, n: float = 1) -> object:
        return None

    def close(self) -> None:
        return None


def _no_bar(description: str, total: float | None, unit: str) -> Bar:
    return _NoBar()


# ------------------------------------------------------------------------------ FMUs


@dataclass(frozen=True)
class FmuInfo:
    """What the scenarios need from an FMU's modelDescription.xml.

    Attributes
    ----------
    path : str
        The FMU file.
    model_name : str
        ``modelName``.
    length_m : float
        Start value of ``length`` [m].
    speed_mps : float
        Start value of ``u0``, the default approach speed [m/s].
    rpm : float
        Start value of ``propeller_rpm``, the default propeller speed [rpm].
    rudder_limit_rad : float
        Largest |rudder_angle| the FMU accepts (its declared max; π when none) [rad].
    max_step_s : float or None
        Start value of ``max_step``, the FMU's largest internal step, if declared [s].
    parameters : mapping of str to float
        Start values of every variable of causality ``parameter`` that has one (the
        model's coefficients among them) [SI].

    """

    path: str
    model_name: str
    length_m: float
    speed_mps: float
    rpm: float
    rudder_limit_rad: float
    max_step_s: float | None
    parameters: Mapping[str, float] = field(default_factory=dict)


def _float_or_none(value: object) -> float | None:
    if value is None or value == "":
        return None
    try:
        return float(str(value))
    except ValueError:
        return None


def read_fmu_info(path: str | os.PathLike[str]) -> FmuInfo:
    """Read the start values and limits the scenarios use from an FMU.

    Raises
    ------
    ScenarioError
        The file is missing, not an FMU, or lacks a variable of the project's FMU
        interface (DESIGN.md "FMU interface").

    """
    name = os.fspath(path)
    if not os.path.exists(name):
        raise ScenarioError(f"{name}: no such FMU file")
    if not os.path.isfile(name):
        raise ScenarioError(f"{name}: is not a file; expected an .fmu")
    from fmpy import read_model_description

    try:
        md = read_model_description(name)
    except Exception as exc:  # fmpy raises plain Exception for invalid files
        raise ScenarioError(f"{name}: not a readable FMU ({exc})") from None
    variables = {v.name: v for v in md.modelVariables}
    missing = [k for k in _REQUIRED_VARIABLES if k not in variables]
    if missing:
        raise ScenarioError(
            f"{name}: not a ship FMU of this project's interface; missing {', '.join(missing)}"
        )
    length = _float_or_none(variables["length"].start)
    if length is None or not (math.isfinite(length) and length > 0.0):
        raise ScenarioError(f"{name}: the FMU's 'length' has no positive start value")
    limits = [
        abs(x)
        for x in (
            _float_or_none(variables["rudder_angle"].min),
            _float_or_none(variables["rudder_angle"].max),
        )
        if x is not None
    ]
    max_step = variables.get("max_step")
    parameters = {
        v.name: start
        for v in md.modelVariables
        if v.causality == "parameter" and (start := _float_or_none(v.start)) is not None
    }
    return FmuInfo(
        path=name,
        model_name=str(md.modelName),
        length_m=length,
        speed_mps=_float_or_none(variables["u0"].start) or 0.0,
        rpm=_float_or_none(variables["propeller_rpm"].start) or 0.0,
        rudder_limit_rad=min(limits) if limits else math.pi,
        max_step_s=None if max_step is None else _float_or_none(max_step.start),
        parameters=parameters,
    )


@contextmanager
def open_fmu(path: str | os.PathLike[str]) -> Iterator[FmuPlant]:
    """Open an FMU as a plant (:class:`scenarios.run.FmuPlant`); close it on exit.

    Raises
    ------
    ScenarioError
        The FMU cannot be loaded or instantiated on this platform.

    """
    read_fmu_info(path)  # clear errors for a missing or foreign file first
    try:
        plant = FmuPlant(path)
    except Exception as exc:  # fmpy: OSError, plain Exception, FMICallException
        raise ScenarioError(f"{os.fspath(path)}: cannot load the FMU ({exc})") from None
    try:
        yield plant
    finally:
        plant.close()


def check_params_match(info: FmuInfo, params: ModelParameters, source: str = "") -> None:
    """Raise :class:`ScenarioError` unless ``params`` are the ones the FMU was built from.

    The FMU's model name must be the vessel name, its ``length`` the ship length, and
    every coefficient of the parameters' structure a parameter of the FMU whose start
    value equals the coefficient (to 1e-12 relative; the exporters write the shortest
    text that parses back to the same double).

    Parameters
    ----------
    info : FmuInfo
        From :func:`read_fmu_info`.
    params : ModelParameters
        E.g. the params.json the FMU is said to come from.
    source : str, optional
        Where ``params`` come from (a path), to begin the message with.

    """
    what = f"the parameters ({params.model}, vessel {params.vessel_name!r})"
    if source:
        what = f"{source}: {what}"
    problems = []
    if info.model_name != params.vessel_name:
        problems.append(f"the FMU's model is {info.model_name!r}")
    if not math.isclose(info.length_m, params.length_m, rel_tol=1e-12):
        problems.append(f"L = {params.length_m:g} m but the FMU's is {info.length_m:g} m")
    missing = [name for name in params.names if name not in info.parameters]
    if missing:
        problems.append(f"the FMU has no parameter {', '.join(missing)}")
    else:
        differ = [
            f"{name} = {value:.6g} but {info.parameters[name]:.6g} in the FMU"
            for name, value in params.as_dict().items()
            if not math.isclose(info.parameters[name], value, rel_tol=1e-12)
        ]
        if differ:
            more = f" (and {len(differ) - 3} more)" if len(differ) > 3 else ""
            problems.append(", ".join(differ[:3]) + more)
    if problems:
        raise ScenarioError(f"{what} do not match the FMU {info.path}: {'; '.join(problems)}")


def check_rudder(info: FmuInfo, rudder_rad: float) -> None:
    """Raise :class:`ScenarioError` when |``rudder_rad``| exceeds the FMU's limit."""
    if abs(rudder_rad) > info.rudder_limit_rad * (1.0 + 1e-12):
        raise ScenarioError(
            f"rudder angle {math.degrees(rudder_rad):g} deg is beyond the FMU's limit of "
            f"±{math.degrees(info.rudder_limit_rad):g} deg ({info.path})"
        )


# -------------------------------------------------------------------------- running


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
        The FMU reported an error or the simulation diverged.

    """
    from fmpy.fmi1 import FMICallException

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


def validate(
    fmu_path: str | os.PathLike[str],
    *,
    reference: str = "kvlcc2",
    scale: str = "full",
    dt_s: float = 0.1,
    on_run: Callable[[str], object] | None = None,
    params: ModelParameters | None = None,
    uncertainty_samples: int = 0,
    uncertainty_dt_s: float = 0.5,
    seed: int = 0,
    scheduler: str | None = None,
    n_workers: int = 2,
    params_source: str = "",
) -> Validation:
    """Run the standard set on an FMU and on a reference ship, same approach condition.

    Both ships start at the reference ship's approach speed and propeller speed and use
    its steering-gear rate (an identified model of that ship is meant to reproduce it
    there). With ``params`` and ``uncertainty_samples`` > 0 the predicted quantities
    also get their 95 % intervals (:func:`with_uncertainty`).

    Parameters
    ----------
    fmu_path : path-like
        The predicted model.
    reference : str
        Reference vessel (``scenarios.synthesize.reference_ship``).
    scale : str
        ``"full"`` or ``"model"``.
    dt_s : float
        Communication step of both [s].
    on_run : callable, optional
        Called with a label after each of the eight runs.
    params : ModelParameters, optional
        The parameters the FMU was built from, with their covariance; checked against
        the FMU (:func:`check_params_match`) before anything runs.
    uncertainty_samples : int
        Monte-Carlo samples for the intervals; 0 for none.
    uncertainty_dt_s : float
        Step of the Monte-Carlo runs [s].
    seed : int
        Seed of the draw.
    scheduler : str, optional
        Address of a dask scheduler for the Monte Carlo; default a local cluster.
    n_workers : int
        Workers of that local cluster.
    params_source : str, optional
        Where ``params`` come from (e.g. the params.json path), for the report.

    Raises
    ------
    ScenarioError
        Bad FMU, parameters that do not match it or have no covariance, a run that does
        not give its metrics, an FMU error.

    """
    info = read_fmu_info(fmu_path)
    check_rudder(info, math.radians(35.0))
    if params is not None:
        check_params_match(info, params, params_source)
    if params is not None and uncertainty_samples > 0 and params.covariance is None:
        raise ScenarioError(
            f"{params_source or 'the parameters'}: no covariance, so no uncertainty to "
            "sample; identify with a covariance or leave out the uncertainty"
        )
    ref_name, description, ref_length, condition, ref = reference_runs(reference, scale, dt_s)
    if on_run is not None:
        for run in ref:
            on_run(f"reference {run.program.name}")
    with open_fmu(fmu_path) as plant:
        predicted = run_standard_set(
            plant,
            condition,
            ref_length,
            on_run=None if on_run is None else lambda name: on_run(f"predicted {name}"),
        )
    warnings = []
    if abs(info.length_m - ref_length) > 1e-9 * ref_length:
        warnings.append(
            f"the FMU's ship length ({info.length_m:g} m) differs from the reference's "
            f"({ref_length:g} m); the errors compare metres"
        )
    if info.speed_mps > 0.0 and abs(info.speed_mps / condition.speed_mps - 1.0) > 0.01:
        warnings.append(
            f"the FMU's start speed u0 = {info.speed_mps:.4g} m/s differs from the approach "
            f"speed {condition.speed_mps:.4g} m/s used for both ships"
        )
    validation = Validation(
        fmu_path=info.path,
        model_name=info.model_name,
        model_length_m=info.length_m,
        reference_name=ref_name,
        reference_description=description,
        reference_length_m=ref_length,
        condition=condition,
        reference=ref,
        predicted=predicted,
        criteria=tuple(imo_criteria(predicted, info.length_m, condition.speed_mps)),
        reference_criteria=tuple(imo_criteria(ref, ref_length, condition.speed_mps)),
        warnings=tuple(warnings),
    )
    if params is None or uncertainty_samples <= 0:
        return validation
    return with_uncertainty(
        validation,
        params,
        n_samples=uncertainty_samples,
        dt_s=uncertainty_dt_s,
        seed=seed,
        scheduler=scheduler,
        n_workers=n_workers,
        source=params_source,
    )


def with_uncertainty(
    validation: Validation,
    params: ModelParameters,
    *,
    n_samples: int = 100,
    dt_s: float = 0.5,
    seed: int = 0,
    scheduler: str | None = None,
    client: Client | None = None,
    n_workers: int = 2,
    processes: bool = True,
    chunk_size: int | None = None,
    source: str = "",
) -> Validation:
    """Return ``validation`` with the 95 % intervals of its predicted quantities.

    Runs ``scenarios.uncertainty.monte_carlo_metrics`` on the validation's programs at
    its approach condition (the reference ship's speed, propeller speed and rudder
    rate) and locates each interval at the predicted value
    (``scenarios.report.uncertainty_bands``). The intervals cover the coefficient
    uncertainty from identification only, not model-structure error.

    Parameters
    ----------
    validation : Validation
        From :func:`validate`.
    params : ModelParameters
        The parameters the validated FMU was built from, with their covariance.
    n_samples : int
        Coefficient sets to draw.
    dt_s : float
        Communication step of the Monte-Carlo runs [s].
    seed : int
        Seed of the draw.
    scheduler : str, optional
        Address of a running dask scheduler (``"tcp://host:8786"``).
    client : distributed.Client, optional
        An existing client (not closed here).
    n_workers : int
        Workers of the local cluster made when neither of the two is given.
    processes : bool
        Whether that local cluster's workers are processes (else threads of this one).
    chunk_size : int, optional
        Samples per task. Default on a local cluster: one task per worker process, or
        a single task for thread workers (they share the GIL); the cost of a task is
        set by its number of steps much more than by its number of ships. Default on
        a given scheduler or client: ``monte_carlo_metrics``'s.
    source : str, optional
        Where ``params`` come from, for the report.

    Raises
    ------
    ScenarioError
        The parameters do not match the FMU, have no usable covariance, or the
        settings are invalid.

    """
    from scenarios.uncertainty import UncertaintyError, monte_carlo_metrics

    check_params_match(read_fmu_info(validation.fmu_path), params, source)
    c = validation.condition
    if chunk_size is None and scheduler is None and client is None:
        chunk_size = max(1, math.ceil(n_samples / max(1, n_workers)) if processes else n_samples)
    try:
        result = monte_carlo_metrics(
            params,
            [run.program for run in validation.predicted],
            n_samples=n_samples,
            seed=seed,
            dt_s=dt_s,
            rudder_rate_radps=c.rudder_rate_radps,
            speed_mps=c.speed_mps,
            n_rps=c.n_rps,
            scheduler=scheduler,
            client=client,
            n_workers=n_workers,
            processes=processes,
            chunk_size=chunk_size,
        )
    except UncertaintyError as exc:
        raise ScenarioError(f"{source or 'uncertainty'}: {exc}") from None
    bands = uncertainty_bands(result, validation.rows, source=source)
    return replace(validation, uncertainty=bands)


# ----------------------------------------------------------------------- synthesis


def maneuver_seed(seed: int, maneuver: str) -> int:
    """Noise seed of one manoeuvre's log, derived from a run seed and the manoeuvre name.

    ``SeedSequence([seed, crc32(name)])``: each manoeuvre gets its own noise, and the
    same manoeuvre the same noise whatever else is synthesised with it.
    """
    if seed < 0:
        raise ScenarioError(f"seed must be non-negative, got {seed}")
    sequence = np.random.SeedSequence([seed, zlib.crc32(maneuver.encode("utf-8"))])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def synthesize_logs(
    directory: str | os.PathLike[str],
    maneuvers: Sequence[str],
    *,
    vessel: str = "kvlcc2",
    scale: str = "full",
    rate_hz: float = 1.0,
    position_noise_m: float = 1.0,
    heading_noise_deg: float = 0.1,
    seed: int = 0,
    approach_s: float = 60.0,
    on_log: Callable[[Path], object] | None = None,
) -> list[Path]:
    """Write one synthetic trial log per manoeuvre, ``directory/<manoeuvre>.csv``.

    Parameters
    ----------
    directory : path-like
        Output folder (created).
    maneuvers : sequence of str
        Names from ``scenarios.synthesize.MANEUVERS``.
    vessel, scale : str
        Reference ship and scale (``reference_ship``).
    rate_hz, position_noise_m, heading_noise_deg, approach_s
        As ``synthesize_log`` [Hz, m, deg, s].
    seed : int
        Run seed; each manoeuvre's noise seed is :func:`maneuver_seed` of it.
    on_log : callable, optional
        Called with each path written.

    Returns
    -------
    list of pathlib.Path
        The logs, in the order of ``maneuvers``.

    """
    from identifier.logs import write_log

    unknown = [m for m in maneuvers if m not in MANEUVERS]
    if unknown:
        raise ScenarioError(
            f"unknown manoeuvre(s) {', '.join(unknown)} (known: {', '.join(MANEUVERS)})"
        )
    try:
        ship = reference_ship(vessel, scale)
    except ValueError as exc:
        raise ScenarioError(str(exc)) from None
    written = []
    for name in dict.fromkeys(maneuvers):  # once each, in order
        log = synthesize_log(
            ship,
            MANEUVERS[name](),
            rate_hz=rate_hz,
            position_noise_m=position_noise_m,
            heading_noise_deg=heading_noise_deg,
            seed=maneuver_seed(seed, name),
            approach_s=approach_s,
        )
        path = Path(directory) / f"{name}.csv"
        write_log(path, log)
        written.append(path)
        if on_log is not None:
            on_log(path)
    return written


# ---------------------------------------------------------------------------- demo


@dataclass(frozen=True)
class DemoConfig:
    """Settings of the demo pipeline.

    Attributes
    ----------
    vessel, scale : str
        Reference ship that plays the real ship.
    maneuvers : tuple of str
        Trial logs to synthesise and identify from.
    rate_hz, position_noise_m, heading_noise_deg : float
        Logger rate [Hz] and noise [m, deg].
    seed : int
        Run seed of the logs' noise (:func:`maneuver_seed`).
    model : str
        Model structure to identify.
    validation_dt_s : float
        Communication step of the validation runs [s].
    refine : bool
        Output-error refinement after the EKF (``identify --refine``; guarded).
    uncertainty_samples : int
        Monte-Carlo samples of the identified coefficients for the report's 95 %
        intervals; 0 for none.
    uncertainty_dt_s : float
        Communication step of the Monte-Carlo runs [s].
    uncertainty_workers : int
        Workers of the local dask cluster of the Monte Carlo.
    uncertainty_processes : bool
        Whether those workers are processes (else threads, which start at once).

    """

    vessel: str = "kvlcc2"
    scale: str = "full"
    maneuvers: tuple[str, ...] = ("turning-35", "zigzag-10", "zigzag-20")
    rate_hz: float = 1.0
    position_noise_m: float = 1.0
    heading_noise_deg: float = 0.1
    seed: int = 1
    model: str = DEFAULT_MODEL
    refine: bool = True
    validation_dt_s: float = 0.1
    uncertainty_samples: int = 100
    uncertainty_dt_s: float = 0.5
    uncertainty_workers: int = 2
    uncertainty_processes: bool = True

    @classmethod
    def quick(cls) -> DemoConfig:
        """Return the shorter configuration for tests: 0.5 s step, 20 samples on threads."""
        return cls(validation_dt_s=0.5, uncertainty_samples=20, uncertainty_processes=False)


@dataclass(frozen=True)
class DemoResult:
    """What the demo produced, and how long each stage took [s]."""

    logs: tuple[Path, ...]
    params_path: Path
    fmu_path: Path
    report_dir: Path
    report_files: tuple[Path, ...]
    validation: Validation
    identification_warnings: tuple[str, ...]
    stage_seconds: dict[str, float] = field(default_factory=dict)


def run_demo(
    out_dir: str | os.PathLike[str],
    config: DemoConfig | None = None,
    *,
    on_stage: Callable[[str, float, str], None] | None = None,
    make_bar: BarFactory | None = None,
) -> DemoResult:
    """Reference-ship logs → identification → native FMU → validation report.

    Parameters
    ----------
    out_dir : path-like
        Output folder; layout in the module docstring.
    config : DemoConfig, optional
        Default :class:`DemoConfig`.
    on_stage : callable, optional
        Called after each stage with its name, duration [s] and a one-line summary.
    make_bar : BarFactory, optional
        Progress bars for the long stages.

    Stages, each reported to ``on_stage``: ``synthesize``, ``identify``, ``build FMU``,
    ``validate``, ``uncertainty`` (when ``config.uncertainty_samples`` > 0) and
    ``report``.

    Raises
    ------
    ScenarioError, identifier.errors.IdentificationError, fmu_model.errors.FmuBuildError
        A stage failed.

    """
    from fmu_model import save_params
    from fmu_model.export_native import build_native_fmu, model_identifier
    from identifier.identify import FitSettings, identify
    from identifier.logs import read_log

    config = config or DemoConfig()
    bar_factory = make_bar or _no_bar
    out = Path(out_dir)
    seconds: dict[str, float] = {}

    def stage_done(name: str, start: float, summary: str) -> None:
        seconds[name] = time.perf_counter() - start
        if on_stage is not None:
            on_stage(name, seconds[name], summary)

    start = time.perf_counter()
    bar = bar_factory("synthesize", len(config.maneuvers), "log")
    try:
        logs = synthesize_logs(
            out / "logs",
            config.maneuvers,
            vessel=config.vessel,
            scale=config.scale,
            rate_hz=config.rate_hz,
            position_noise_m=config.position_noise_m,
            heading_noise_deg=config.heading_noise_deg,
            seed=config.seed,
            on_log=lambda _path: bar.update(1),
        )
    finally:
        bar.close()
    stage_done("synthesize", start, f"{len(logs)} trial logs in {out / 'logs'}")

    start = time.perf_counter()
    trial_logs = [read_log(path) for path in logs]
    bar = bar_factory("identify", 2 * sum(log.n_samples for log in trial_logs), "sample")
    try:

        def advance(n: int) -> None:
            bar.update(n)

        settings = FitSettings(model=config.model, refine=config.refine)
        result = identify(trial_logs, settings, progress=advance)
    finally:
        bar.close()
    params_path = out / "params.json"
    save_params(params_path, result.params)
    stage_done("identify", start, f"{config.model} coefficients in {params_path}")

    start = time.perf_counter()
    fmu_path = out / f"{model_identifier(result.params.vessel_name)}.fmu"
    build_native_fmu(result.params, fmu_path)
    stage_done("build FMU", start, f"native FMI 2.0 co-simulation FMU {fmu_path}")

    start = time.perf_counter()
    bar = bar_factory("validate", 8, "run")
    try:
        validation = validate(
            fmu_path,
            reference=config.vessel,
            scale=config.scale,
            dt_s=config.validation_dt_s,
            on_run=lambda _name: bar.update(1),
        )
    finally:
        bar.close()
    trained = ", ".join(config.maneuvers)
    validation = replace(
        validation,
        warnings=(
            *validation.warnings,
            f"the model was identified from the logs {trained} only: every other "
            "manoeuvre in the comparison is a prediction of one it has not seen",
        ),
    )
    stage_done(
        "validate",
        start,
        f"{len(validation.rows)} quantities vs {validation.reference_name}, "
        f"step {config.validation_dt_s:g} s",
    )

    if config.uncertainty_samples > 0:
        start = time.perf_counter()
        validation = with_uncertainty(
            validation,
            result.params,
            n_samples=config.uncertainty_samples,
            dt_s=config.uncertainty_dt_s,
            n_workers=config.uncertainty_workers,
            processes=config.uncertainty_processes,
            source=str(params_path),
        )
        inside, judged = interval_counts(validation.rows)
        stage_done(
            "uncertainty",
            start,
            f"{config.uncertainty_samples} Monte-Carlo samples on "
            f"{config.uncertainty_workers} local "
            f"{'worker processes' if config.uncertainty_processes else 'worker threads'}; "
            "reference inside the 95 % "
            f"interval for {inside} of {judged} quantities",
        )

    start = time.perf_counter()
    report_dir = out / "report"
    files = write_report(validation, report_dir)
    stage_done("report", start, f"report in {report_dir / 'report.md'}")

    return DemoResult(
        logs=tuple(logs),
        params_path=params_path,
        fmu_path=fmu_path,
        report_dir=report_dir,
        report_files=tuple(files),
        validation=validation,
        identification_warnings=tuple(result.warnings),
        stage_seconds=seconds,
    )
