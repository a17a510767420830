"""From trial logs to identified coefficients: smoothing → equation error → EKF.

This is the seed paper's procedure (Shi et al. 2009, section 4): the raw track and
heading are smoothed with a constant-acceleration Kalman filter and the RTS
fixed-interval smoother (``identifier.smoothing``), u, v, r are derived from the
smoothed states (eq. (9)), and the coefficients are estimated by the augmented-state
EKF (``identifier.ekf``). Where the paper starts the EKF from zero coefficients with
P(0) = α I, the default here starts from the equation-error least-squares fit on the
same smoothed data (``identifier.equation_error``), with its covariance inflated as
prior; ``initial="zero"`` gives the paper's start. For a model family
(``prime-rudder``) the shape constants not given in the model name are chosen first
from the same data (``identifier.shape``). By default (``method="output-error"``) the
estimate is then refined by output error on the whole logs (``identifier.output_error``),
guarded: the refined estimate is kept only when the guards of
reference/model_structures.md §6–§7 pass, else the better-replaying start. That is
the procedure that predicts held-out manoeuvres best (benchmarks/fidelity.md,
benchmarks/hsva.md); ``method="ekf"`` keeps the EKF estimate, the paper's algorithm.
The EKF runs through several logs by their largest rudder angle
(``identifier.preparation.ekf_order``), so the logs given in any order give one model; a
drifting current runs through them in the order sailed (``sailed_order`` there: by their
time origins, else as given), and walks through the time between them too. The logs are
made ready for every fit alike by ``identifier.preparation`` (checked, smoothed,
deglitched), and what an estimate leaves in doubt is said by ``identifier.diagnostics``.

A ``prime-rudder`` estimate whose free thrust X_nn·n²L + X_un·u·n is not a propeller's
(``identifier.diagnostics.thrust_warning``: no thrust at bollard, or one that grows with
the speed; logs at one rpm fix the thrust at the approach only) is refitted as
``prime-rudder-thrust``, a thrust of fixed open-water slope, with the same settings (a
``prime-rudder-offset`` one as ``prime-rudder-offset-thrust``, the default
``prime-rudder-slipstream`` as ``prime-rudder-slipstream-thrust``, a ``prime-crossflow``
one as ``prime-crossflow-thrust``): the free split would make the ship lose its thrust as it
slows in a hard turn (benchmarks/hsva.md, "The propeller thrust is why"). The result says
so (a note, ``identification.thrust``); fits of other families with such a thrust are
warned about.

A uniform current is estimated with the coefficients (``identifier.current``): by default
a constant one for a ship, and for a model (L < 20 m) ``current="auto"``
(``identifier.current.default_current``). With "auto" the whole fit is made twice, with a
constant current and in still water, and the current is kept only where its fit's
open-loop predictions of the training logs stay at most half as far from their tracks
over the ground (``identifier.current.choose_current``): a basin's runs keep still water
where the current the estimator would find there is the structure's error. Logs with a
speed log are fitted with the current alone (the log measures it). ``current="per-log"``
gives each log a current of its own (runs at other times of the tide); where the logs'
approaches or speed logs show different currents (``identifier.current.current_disagreement``)
a ship's default and "auto" take it, and a current asked for as one warns.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np

from fmu_model import DEFAULT_MODEL, ModelParameters, ModelStructure, get_model
from fmu_model.envelope import Envelope, envelope_of, union
from fmu_model.environment import Windage
from fmu_model.variants import (
    PRIME_CROSSFLOW,
    PRIME_CROSSFLOW_THRUST,
    PRIME_RUDDER,
    PRIME_RUDDER_OFFSET,
    PRIME_RUDDER_OFFSET_THRUST,
    PRIME_RUDDER_SLIPSTREAM,
    PRIME_RUDDER_SLIPSTREAM_THRUST,
    PRIME_RUDDER_THRUST,
    family_name,
    parse_family,
)
from identifier.current import (
    ALONG_COURSE_STARTS,
    ALTERNATION_MAX_SAMPLES,
    ALTERNATION_WINDOWS,
    CURRENT_EVIDENCE_RATIO,
    CURRENT_MODES,
    CURRENT_PRIOR_STD_MPS,
    DEFAULT_CURRENT,
    DRIFTING_RANDOM_WALK_MPS,
    MAX_CURRENT_ITERATIONS,
    PER_LOG,
    SHAPE_PASSES,
    SPEED_LOG_SCALE_STD,
    CurrentChoice,
    CurrentEstimate,
    SpeedLogFit,
    SpeedLogInEkf,
    approach_course,
    choose_current,
    current_disagreement,
    current_model_form,
    current_tolerance_mps,
    default_current,
    initial_current,
    speed_log_current,
    speed_log_noise_mps,
    water_frame,
    water_segments,
    weighted_mean_current,
)
from identifier.diagnostics import (
    centripetal_warning,
    heading_span_warning,
    model_current_warning,
    neutral_helm_note,
    one_sided_model,
    reversal_warning,
    thrust_warning,
    turn_warning,
)
from identifier.ekf import (
    EkfResult,
    EkfSegment,
    EkfSettings,
    SpeedLogMeasurement,
    ekf_identify,
    sample_windows,
)
from identifier.equation_error import EquationErrorFit, equation_error_fit
from identifier.output_error import (
    RefinementResult,
    covers_turn,
    refine_output_error,
    track_distance_m,
)
from identifier.preparation import SmoothedLogs, smooth_logs, vessel_length, vessel_name
from identifier.shape import ShapeSelection, select_shape
from identifier.smoothing import SmoothedTrack
from trials.conditions import (
    execute_index,
)
from trials.errors import IdentificationError
from trials.logs import ManeuverLog

# Ranges of the numeric settings, the command line's usage errors (README, "Plausibility
# bounds"). α of the paper's start, P(0) = α I: prior standard deviations from 1e-6 to
# 1e6 in the coefficients' units.
ALPHA_RANGE = (1e-12, 1e12)
# Relative random walk ρ of the coefficients per step: 0 keeps them constant, 1 adds the
# whole prior variance at every step, beyond which the prior means nothing.
PARAM_RANDOM_WALK_RANGE = (0.0, 1.0)
# Logger noise: from a micrometre (motion capture of a model is 1e-4 m) to a kilometre
# [m]; from 1e-6 deg to 90 deg (a heading noise of 90 deg or more says nothing).
POSITION_NOISE_RANGE_M = (1e-6, 1e3)
HEADING_NOISE_RANGE_DEG = (1e-6, 90.0)
# Largest Euler substep of the EKF [s]: 1 ms (a thousand substeps per second of log)
# to inf (one step per sample, the paper's).
MAX_SUBSTEP_RANGE_S = (1e-3, math.inf)
# Prior σ of a speed log's scale error, a fraction of the speed: from 1e-6 (a log taken as
# exact) to 0.5 (a log that says little of the speed).
SPEED_LOG_SCALE_STD_RANGE = (1e-6, 0.5)
METHODS = ("output-error", "ekf")
"""Identification procedures: guarded output-error refinement (default), the paper's EKF."""
MAX_REFINE_STEPS = 5_000
"""Largest number of RK4 steps of one replay of all logs the refinement takes on. Each
of its hundreds of objective evaluations replays every log from execute to the end, in
steps of 0.05 L/U (2 s for KVLCC2 at full scale: 5,000 steps are 2.8 h of manoeuvres,
a few minutes of refinement); beyond it the EKF estimate is kept, with a warning."""


@dataclass(frozen=True)
class FitSettings:
    """Settings of one identification.

    Parameters
    ----------
    model : str
        Registered model structure.
    initial : {"equation-error", "zero"}
        EKF start: least-squares fit with its covariance × ``prior_inflation``², or
        the paper's θ(0) = 0, P(0) = α I.
    alpha : float
        α of the paper's start.
    prior_inflation : float
        Standard-deviation multiplier of the least-squares covariance used as prior.
    param_random_walk : float
        Relative random walk of the coefficients per regression interval of the
        equation error (about L/U/40; per sample of slower logs; see ``EkfSettings``).
    position_noise_m, heading_noise_rad : float, optional
        Measurement noise of the logs; estimated from the data when None.
    measurements : {"track", "velocities"}
        EKF measurements: the logged track (default) or the smoothed u, v, r (paper).
    max_substep_s : float
        Largest Euler substep of the EKF's discretisation [s] (``math.inf``: the paper's
        one step per sample).
    max_relative_std : float
        A coefficient whose posterior σ exceeds this fraction of its magnitude is
        reported as not identifiable from the logs.
    max_variance_inflation : float
        ... and so is one whose regressor is this collinear with the others in the data
        (variance inflation factor, ``EquationErrorFit.variance_inflation``).
    method : {"output-error", "ekf"}
        "output-error": after the EKF, refine by output error on the whole logs
        (``identifier.output_error.refine_output_error``, default settings), starting from
        the equation-error estimate (the EKF's when that one's replay diverges), and
        keeping that start when the guards fire; "ekf": the EKF estimate (the paper).
    current : {"constant", "none", "drifting", "per-log", "auto"}, optional
        Uniform current estimated with the coefficients (``identifier.current``):
        constant over all logs, none (still water, the paper's), a random walk, a
        constant one of each log's own (runs at other times of the tide); "auto"
        fits a constant one and none and keeps the current where its fit predicts the
        training logs' tracks twice as close (``identifier.current.choose_current``; a
        constant one straight away when the logs carry a speed log). None (the default):
        by the ship's size, constant for a ship, auto below a model's 20 m
        (``identifier.current.default_current``); :func:`identify`'s result carries the
        mode taken.
    speed_log_scale_std : float
        Prior standard deviation of the speed log's scale error, a fraction of the speed
        (the EKF's, ``identifier.ekf.SpeedLogMeasurement``, and the separate fit's,
        ``identifier.current.speed_log_current``); used when logs carry ``stw_mps``.
    windage : Windage, optional
        The vessel's windage: the load of the logs' measured wind is taken out
        (``identifier.wind``) and the windage goes into params.json (the FMU applies the
        same load to its wind inputs); None: logs with wind are fitted as they are.

    """

    model: str = DEFAULT_MODEL
    initial: str = "equation-error"
    alpha: float = 1.0
    prior_inflation: float = 10.0
    param_random_walk: float = 1e-4
    position_noise_m: float | None = None
    heading_noise_rad: float | None = None
    measurements: str = "track"
    max_substep_s: float = 0.1
    max_relative_std: float = 0.5
    max_variance_inflation: float = 1e4
    method: str = "output-error"
    current: str | None = None
    speed_log_scale_std: float = SPEED_LOG_SCALE_STD
    windage: Windage | None = None


@dataclass(frozen=True)
class CoefficientReport:
    """Estimate and identifiability of one coefficient."""

    name: str
    value: float
    std: float
    relative_std: float
    contribution: float
    variance_inflation: float
    excited: bool
    identifiable: bool


@dataclass(frozen=True)
class IdentificationResult:
    """Everything an identification produced (the CLI writes ``params``)."""

    params: ModelParameters
    logs: tuple[ManeuverLog, ...]
    tracks: tuple[SmoothedTrack, ...]
    equation_error: EquationErrorFit
    ekf: EkfResult
    coefficients: tuple[CoefficientReport, ...]
    warnings: tuple[str, ...]
    settings: FitSettings
    refinement: RefinementResult | None = None  # both fits with method "output-error"
    current: CurrentEstimate | None = None  # None in still water ("none", or kept by "auto")
    current_choice: CurrentChoice | None = None  # with settings.current == "auto"
    notes: tuple[str, ...] = ()  # what was done to the data (glitches rejected)

    @property
    def not_identifiable(self) -> tuple[str, ...]:
        """Names of the coefficients the logs do not determine."""
        return tuple(c.name for c in self.coefficients if not c.identifiable)


def _sha256(log: ManeuverLog) -> str | None:
    if log.path is None or not Path(log.path).is_file():
        return None
    return hashlib.sha256(Path(log.path).read_bytes()).hexdigest()


def _replay_steps(logs: Sequence[ManeuverLog], length_m: float, speed_mps: float) -> int:
    """RK4 steps of one output-error replay of every log from execute (0.05 L/U each)."""
    step_s = 0.05 * length_m / max(speed_mps, 1e-3)
    duration_s = sum(float(log.time_s[-1] - log.time_s[execute_index(log)]) for log in logs)
    return math.ceil(duration_s / step_s)


def _json_safe(settings: dict[str, object]) -> dict[str, object]:
    """Return the settings for params.json, a non-finite number (``inf``) as text."""
    return {
        key: str(value) if isinstance(value, float) and not math.isfinite(value) else value
        for key, value in settings.items()
    }


def _approach_samples(log: ManeuverLog) -> int:
    """Return how many of the log's first samples make its approach (at least 3)."""
    return max(execute_index(log), 3)


def _nominal(logs: Sequence[ManeuverLog], segments: Sequence[EkfSegment]) -> tuple[float, float]:
    """Approach speed u [m/s] and propeller speed [rev/s]: means over the logs' approaches."""
    speeds, revs = [], []
    for log, segment in zip(logs, segments, strict=True):
        end = _approach_samples(log)
        speeds.append(float(np.mean(segment.velocities[:end, 0])))
        revs.append(float(np.mean(log.n_rps[:end])))
    return float(np.mean(speeds)), float(np.mean(revs))


def _envelope(
    logs: Sequence[ManeuverLog], segments: Sequence[EkfSegment], length_m: float
) -> Envelope:
    """Return what the logs reached (``fmu_model.envelope``), from their smoothed velocities.

    ``segments`` with the velocities through the water (the current taken out); U₀ is
    the mean speed before the execute, as the nominal speed (:func:`_nominal`).
    """
    return union(
        envelope_of(
            seg.rudder_rad,
            seg.velocities[:, 2],
            np.hypot(seg.velocities[:, 0], seg.velocities[:, 1]),
            seg.n_rps,
            length_m,
            approach_samples=_approach_samples(log),
        )
        for log, seg in zip(logs, segments, strict=True)
    )


def _structure_and_start(
    settings: FitSettings,
    segments: Sequence[EkfSegment],
    length_m: float,
    speed_mps: float,
    n_rps: float,
) -> tuple[ShapeSelection | None, ModelStructure, EquationErrorFit]:
    """Choose the family's shape (if one is to be chosen), fit the equation-error start."""
    family, fixed = parse_family(settings.model) or (None, {})
    shape = None
    if family is not None and family.to_search(fixed):
        shape = select_shape(family, segments, length_m, speed_mps, n_rps, fixed=fixed)
    structure = get_model(settings.model) if shape is None else shape.structure
    ls = equation_error_fit(structure, segments, length_m, settings.prior_inflation)
    if not (np.all(np.isfinite(ls.theta)) and np.all(np.isfinite(ls.covariance))):
        raise IdentificationError(
            "the equation-error fit is not finite (the model's terms overflow or divide by "
            "zero on these logs)"
        )
    return shape, structure, ls


def _run_ekf(
    settings: FitSettings,
    structure: ModelStructure,
    ls: EquationErrorFit,
    segments: Sequence[EkfSegment],
    length_m: float,
    progress: Callable[[int], None] | None,
    current_ne: np.ndarray | None = None,
    current_random_walk_mps: float = 0.0,
    speed_log: SpeedLogMeasurement | None = None,
) -> EkfResult:
    """Run the augmented-state EKF from the start ``settings.initial`` (and a current).

    ``current_ne``: the current's prior mean (North, East) [m/s] at the first sample, of
    σ :data:`CURRENT_PRIOR_STD_MPS`, (2,) or one row per segment (a current each,
    ``identifier.ekf.ekf_identify``); None estimates no current. ``speed_log``: measure the
    segments' speed logs (with a current only).
    """
    if settings.initial == "equation-error":
        theta0 = ls.theta
        cov0 = ls.covariance * settings.prior_inflation**2
    else:
        theta0 = np.zeros(structure.n_coefficients)
        cov0 = settings.alpha * np.eye(structure.n_coefficients)
    return ekf_identify(
        structure,
        segments,
        theta0,
        cov0,
        length_m,
        EkfSettings(
            state_process_std=(
                float(ls.residual_std[0]),
                float(ls.residual_std[1]),
                float(ls.residual_std[2]),
            ),
            process_noise_interval_s=ls.sample_interval_s,
            param_random_walk=settings.param_random_walk,
            measurements=settings.measurements,
            max_substep_s=settings.max_substep_s,
            current_random_walk_mps=current_random_walk_mps,
        ),
        progress=progress,
        current0=current_ne,
        current_covariance0=None if current_ne is None else CURRENT_PRIOR_STD_MPS**2 * np.eye(2),
        speed_log=speed_log,
    )


def _estimate_current(
    settings: FitSettings,
    segments: Sequence[EkfSegment],
    tracks: Sequence[SmoothedTrack],
    logs: Sequence[ManeuverLog],
    length_m: float,
    progress: Callable[[int], None] | None,
    stage: Callable[[str], None],
    notes: list[str],
) -> tuple[ShapeSelection | None, ModelStructure, EquationErrorFit, EkfResult, CurrentEstimate]:
    """Estimate current and coefficients together (``identifier.current``).

    The equation-error start is fitted on the velocities through the water for the
    current so far (from what a speed log shows alone, ``speed_log_current``, else from
    what the approaches show, ``initial_current``), the EKF estimates the current with
    the coefficients from it, until the current settles (:func:`_alternate`). A speed log
    (a plausible one, :meth:`SpeedLogFit.implausible`) is a measurement of every pass,
    its scale error a state (:func:`_with_speed_log`). A last EKF pass over every sample
    (with progress, and the random walk of a drifting current) gives the estimate. A start
    from the approaches alone that the EKF cannot follow is retried along their course
    (:func:`_retried_along_the_course`; its note goes to ``notes``).
    """
    per_log = settings.current == PER_LOG
    alone, ignored, measurement, segments = _with_speed_log(settings, segments, tracks, logs)
    if per_log:  # (logs, 2): each log's own start, as below for one
        current = np.array([
            initial_current([log], [track]) if fit is None else fit.current_ne
            for log, track, fit in zip(logs, tracks, alone, strict=True)
        ])  # fmt: skip
    else:
        current = initial_current(logs, tracks) if alone[0] is None else alone[0].current_ne
    alternate = partial(
        _alternate, settings, segments, tracks, logs, length_m,
        measurement=measurement, stage=stage,
    )  # fmt: skip
    if not per_log and alone[0] is None and measurement is None:  # the approaches' start
        settled = _retried_along_the_course(alternate, current, logs, tracks, segments, notes)
    else:
        settled = alternate(current)
    shape, structure, ls = settled.shape, settled.structure, settled.start
    current, iterations = settled.current, settled.iterations
    if settled.unsettled_mps:
        notes.append(
            f"current: not settled after {iterations} EKF passes (the last moved it "
            f"{settled.unsettled_mps:.3f} m/s, more than its tolerance): the last pass's start "
            "is kept, which the EKF followed; the logs barely determine the current"
        )
    stage("EKF on every sample")
    walk = DRIFTING_RANDOM_WALK_MPS if settings.current == "drifting" else 0.0
    ekf = _run_ekf(
        settings, structure, ls, segments, length_m, progress, current, walk, measurement
    )
    assert ekf.current is not None and ekf.current_covariance is not None
    in_ekf = None
    if measurement is not None:
        assert ekf.speed_log_scale_error is not None and ekf.speed_log_scale_error_std is not None
        in_ekf = SpeedLogInEkf(
            scale_error=ekf.speed_log_scale_error,
            scale_error_std=ekf.speed_log_scale_error_std,
            noise_mps=measurement.noise_std_mps,
            samples=ekf.speed_log_samples[0],
            rejected=ekf.speed_log_samples[1],
            transverse_noise_mps=measurement.transverse_noise_std_mps,
            transverse_samples=ekf.speed_log_transverse_samples[0],
            transverse_rejected=ekf.speed_log_transverse_samples[1],
        )
    assert settings.current is not None  # identify() took the ship's default
    if per_log:
        estimate = _per_log_estimate(ekf, alone, segments, iterations, ignored, in_ekf)
    else:
        model_form = np.zeros((2, 2))
        if alone[0] is not None and in_ekf is not None and settings.current == "constant":
            model_form = current_model_form(ekf.current, alone[0])
        estimate = CurrentEstimate.of(
            ekf.current,
            ekf.current_covariance,
            settings.current,
            iterations=iterations,
            speed_log=alone[0],
            speed_log_ignored=ignored,
            speed_log_ekf=in_ekf,
            model_form=model_form,
        )
    return shape, structure, ls, ekf, estimate


def _with_speed_log(
    settings: FitSettings,
    segments: Sequence[EkfSegment],
    tracks: Sequence[SmoothedTrack],
    logs: Sequence[ManeuverLog],
) -> tuple[list[SpeedLogFit | None], str | None, SpeedLogMeasurement | None, list[EkfSegment]]:
    """Return what the speed logs show alone, and the segments that measure them in the EKF.

    Returns the current each speed log shows alone (``speed_log_current``: one for all
    the logs, or with ``per-log`` one per log; None without a log), why they were
    ignored (a log that is implausible, :meth:`SpeedLogFit.implausible`: then every log
    is taken as without one), the EKF's measurement of them (its noise from the logs,
    ``speed_log_noise_mps``; None without) and the segments carrying them.
    """
    if settings.current == PER_LOG:
        alone = [
            speed_log_current([log], [track], settings.speed_log_scale_std)
            for log, track in zip(logs, tracks, strict=True)
        ]
        labels = [f"{seg.name}: " for seg in segments]
    else:
        alone, labels = [speed_log_current(logs, tracks, settings.speed_log_scale_std)], [""]
    ignored = next(
        (label + why for label, fit in zip(labels, alone, strict=True)
         if fit is not None and (why := fit.implausible()) is not None),
        None,
    )  # fmt: skip
    if ignored is not None:
        alone = [None] * len(alone)  # a broken log: the track alone, as without one
    if all(fit is None for fit in alone):
        return alone, ignored, None, list(segments)
    noise_mps = speed_log_noise_mps(logs)
    assert noise_mps is not None  # a log carries stw_mps
    measurement = SpeedLogMeasurement(
        noise_mps,
        settings.speed_log_scale_std,
        speed_log_noise_mps(logs, "stw_transverse_mps"),  # a two-axis log's other axis
    )
    measured = [
        replace(
            seg,
            speed_log_mps=log.stw_mps,
            speed_log_transverse_mps=log.stw_transverse_mps,
            speed_log_x_m=log.on_board_m("speed_log_x_m") or 0.0,  # given with the axis
        )
        for seg, log in zip(segments, logs, strict=True)
    ]
    return alone, ignored, measurement, measured


@dataclass(frozen=True)
class _Settled:
    """Where :func:`_alternate` settled.

    The shape, structure and start, the current (North, East) [m/s], the EKF passes
    made, and the last converged pass's RMS distance of its filtered positions from the
    logged ones, summed over its windows [m]; when the current did not settle, how far
    the last pass moved it [m/s] (0 when it settled).
    """

    shape: ShapeSelection | None
    structure: ModelStructure
    start: EquationErrorFit
    current: np.ndarray
    iterations: int
    track_rms_m: float
    unsettled_mps: float = 0.0


def _alternate(
    settings: FitSettings,
    segments: Sequence[EkfSegment],
    tracks: Sequence[SmoothedTrack],
    logs: Sequence[ManeuverLog],
    length_m: float,
    current: np.ndarray,
    measurement: SpeedLogMeasurement | None,
    stage: Callable[[str], None],
) -> _Settled:
    """Alternate the equation-error start and the EKF's current until the current settles.

    From ``current`` (North, East) [m/s], (2,) or one row per log with ``per-log``: the
    shape and the start are fitted through the water for the current so far, the EKF
    (its prior of the current the current so far, of σ :data:`CURRENT_PRIOR_STD_MPS`)
    finds the next, until it moves less than its tolerance (``current_tolerance_mps``);
    the shape is chosen for the starting current and once more for the settled one
    (:data:`SHAPE_PASSES`). The passes run on windows of long logs
    (:data:`ALTERNATION_MAX_SAMPLES`) and report no progress; when one diverges (a start
    the filter cannot follow) the alternation stops where the last pass that converged
    started, and so it does when the current has not settled after the last pass (it
    wanders at the level of its noise: the next start is one the EKF never ran from; a
    Mariner fit from one turning circle diverged there).
    """
    per_log = settings.current == PER_LOG
    iterations = 0
    settling = sample_windows(segments, ALTERNATION_MAX_SAMPLES, ALTERNATION_WINDOWS)
    sources = [source for source, _ in settling]
    settled = None  # the last pass that converged
    moved_mps = math.inf  # the current's change in the last pass
    for _ in range(SHAPE_PASSES):
        water = water_segments(segments, tracks, current)
        speed_mps, n_rps = _nominal(logs, water)
        stage("equation-error start")
        shape, structure, ls = _structure_and_start(settings, water, length_m, speed_mps, n_rps)
        del water  # N × 3 velocities: a long log's memory is bounded by what is held
        for _ in range(MAX_CURRENT_ITERATIONS):
            stage(f"current: EKF pass {iterations + 1}")
            try:
                ekf = _run_ekf(
                    settings,
                    structure,
                    ls,
                    [window for _, window in settling],
                    length_m,
                    None,
                    current[sources] if per_log else current,
                    speed_log=measurement,
                )
            except IdentificationError:
                if settled is None:
                    raise
                # A start the EKF cannot follow: keep the last it followed.
                return replace(settled, iterations=iterations)
            assert ekf.current is not None and ekf.current_covariance is not None
            track_rms_m = sum(position for position, _ in ekf.track_rms)
            settled = _Settled(shape, structure, ls, current, iterations, track_rms_m)
            found = ekf.current
            if per_log:  # each log's from its last window (a log without one keeps its own)
                found = current.copy()
                for window, source in enumerate(sources):
                    found[source] = ekf.current[window]
            change = float(np.max(np.abs(found - current)))
            moved_mps = change if change >= current_tolerance_mps(ekf.current_covariance) else 0.0
            current = found
            iterations += 1
            ls = equation_error_fit(
                structure,
                water_segments(segments, tracks, current),
                length_m,
                settings.prior_inflation,
            )
            if not moved_mps:
                break
    assert settled is not None
    if moved_mps:  # not settled: where the last pass the EKF followed started
        return replace(settled, iterations=iterations, unsettled_mps=moved_mps)
    return _Settled(shape, structure, ls, current, iterations, settled.track_rms_m)


def _retried_along_the_course(
    alternate: Callable[[np.ndarray], _Settled],
    current: np.ndarray,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    segments: Sequence[EkfSegment],
    notes: list[str],
) -> _Settled:
    """``alternate`` (:func:`_alternate` bound to the fit) from the approaches' ``current``.

    Approaches on one heading do not show the current along it, and the start
    (``initial_current``, no speed log) takes that component 0. When the EKF cannot
    follow that start (its first pass diverges: the hull fitted through water that runs
    at the wrong speed), the alternation starts again with the along component at ∓ and
    ± each share of the approach speed in :data:`ALONG_COURSE_STARTS` in turn, and keeps
    of the starts of one share that settle the one whose EKF follows the logged track
    closest; a note says so.
    """
    try:
        return alternate(current)
    except IdentificationError:
        course = approach_course(logs, tracks)
        if course is None:
            raise
        speed_mps, _ = _nominal(logs, segments)
        for share in ALONG_COURSE_STARTS:
            settled = []
            for along_mps in (-share * speed_mps, share * speed_mps):
                try:
                    settled.append(alternate(current + along_mps * course))
                except IdentificationError:
                    continue
            if settled:
                best = min(settled, key=lambda s: s.track_rms_m)
                notes.append(
                    "current: the EKF diverged from the start the approaches show "
                    f"({current[0]:+.2f} / {current[1]:+.2f} m/s North / East, none along "
                    f"their course); started again {share:.0%} of the approach speed along "
                    f"it either way, settled at {best.current[0]:+.2f} / "
                    f"{best.current[1]:+.2f} m/s"
                )
                return best
        raise


def _per_log_estimate(
    ekf: EkfResult,
    alone: Sequence[SpeedLogFit | None],
    segments: Sequence[EkfSegment],
    iterations: int,
    ignored: str | None,
    in_ekf: SpeedLogInEkf | None,
) -> CurrentEstimate:
    """Return the current of ``--current per-log``: each log's, and their weighted mean.

    Each log's current carries what its own speed log showed alone and, with the EKF
    measuring the logs, what the EKF made of them (one log, one calibration) and the
    model-form term of the two estimates' distance (``current_model_form``); the mean's
    covariance is of the mean, those terms included.
    """
    assert ekf.current is not None and ekf.current_covariance is not None
    logs = tuple(
        CurrentEstimate.of(
            c,
            covariance,
            PER_LOG,
            iterations=iterations,
            speed_log=fit,
            speed_log_ekf=None if fit is None else in_ekf,
            model_form=np.zeros((2, 2))
            if fit is None or in_ekf is None
            else current_model_form(c, fit),
            log=seg.name,
        )
        for c, covariance, fit, seg in zip(
            ekf.current, ekf.current_covariance, alone, segments, strict=True
        )
    )
    mean, covariance = weighted_mean_current(
        ekf.current, np.array([c.total_covariance for c in logs])
    )
    return CurrentEstimate.of(
        mean,
        covariance,
        PER_LOG,
        iterations=iterations,
        speed_log_ignored=ignored,
        speed_log_ekf=in_ekf,
        logs=logs,
    )


def _no_stage(name: str) -> None:
    """Ignore a stage name (``identify`` without a ``stage`` callback)."""


def identify(
    logs: Sequence[ManeuverLog],
    settings: FitSettings | None = None,
    *,
    length_m: float | None = None,
    progress: Callable[[int], None] | None = None,
    stage: Callable[[str], None] | None = None,
) -> IdentificationResult:
    """Identify the coefficients of ``settings.model`` from trial logs.

    Parameters
    ----------
    logs : sequence of ManeuverLog
        One manoeuvre each, in any order: the EKF runs through them in
        :func:`~identifier.preparation.ekf_order` (with ``settings.current == "drifting"``
        in the order sailed, :func:`~identifier.preparation.sailed_order`); the result's
        logs, tracks and EKF histories are in that order.
    settings : FitSettings, optional
        Defaults when omitted.
    length_m : float, optional
        Ship length [m]; read from the logs' metadata when omitted.
    progress : callable, optional
        Called with numbers of samples processed (smoothing and EKF).
    stage : callable, optional
        Called with the name of each stage as it begins ("smoothing <log>",
        "equation-error start" (with a family's shape search), "current: EKF pass <k>",
        "EKF on every sample", "output-error refinement"): what a progress bar shows
        while no samples are counted.

    Raises
    ------
    IdentificationError
        No logs, no ship length or one out of bounds, logs of different vessels, coarse
        sampling, a track too fast for a ship or of a ship that does not move, no rudder
        excitation in any log, or a diverging EKF.

    """
    settings = settings or FitSettings()
    if not logs:
        raise IdentificationError("no logs given")
    if settings.initial not in ("equation-error", "zero"):
        raise ValueError(f"unknown initial guess {settings.initial!r}")
    low, high = SPEED_LOG_SCALE_STD_RANGE
    if not low <= settings.speed_log_scale_std <= high:
        raise ValueError(
            f"speed_log_scale_std must be from {low:g} to {high:g}, "
            f"got {settings.speed_log_scale_std!r}"
        )
    if settings.method not in METHODS:
        raise ValueError(f"unknown method {settings.method!r} (known: {', '.join(METHODS)})")
    if settings.current is not None and settings.current not in CURRENT_MODES:
        known = ", ".join(CURRENT_MODES)
        raise ValueError(f"unknown current {settings.current!r} (known: {known})")
    if settings.current not in (None, "none") and settings.measurements != "track":
        raise ValueError('a current is estimated only with measurements="track"')
    length = vessel_length(logs, length_m)
    by_default = settings.current is None
    if by_default:
        settings = replace(settings, current=default_current(length, settings.measurements))
    vessel = vessel_name(logs)
    # Every result below is checked (the smoothed track, the equation-error fit, the
    # EKF's states and covariance), so numpy's overflow and division warnings would only
    # repeat on stderr what the error says.
    stage = stage or _no_stage
    with np.errstate(all="ignore"):
        data = smooth_logs(
            logs,
            length_m=length,
            position_noise_m=settings.position_noise_m,
            heading_noise_rad=settings.heading_noise_rad,
            measurements=settings.measurements,
            windage=settings.windage,
            drifting=settings.current == "drifting",
            progress=progress,
            stage=stage,
        )
        helm_note = neutral_helm_note(data, settings.model)
        if helm_note is not None:
            data = replace(data, notes=(*data.notes, helm_note))
        symmetric = one_sided_model(data.logs, settings.model)
        if symmetric is not None:  # one side's turns do not determine the asymmetry
            settings = replace(settings, model=symmetric[0])
            data = replace(data, notes=(*data.notes, symmetric[1]))
        if settings.current in (DEFAULT_CURRENT, "drifting", "auto"):  # one current for all
            settings, data = _one_current_or_per_log(settings, data, by_default=by_default)
        if settings.current == "none" and any(log.stw_mps is not None for log in data.logs):
            unused = "the speed log (stw_mps) is measured with a current only: not used here"
            data = replace(data, notes=(*data.notes, f"{unused} (--current none)"))
        fit = partial(_fit_thrust_ruled, data, length=length, vessel=vessel)
        if settings.current == "auto":
            return _fit_auto_current(data, settings, fit, progress, stage)
        result = fit(settings, progress, stage)
    warning = model_current_warning(length, result.current)
    return result if warning is None else replace(result, warnings=(*result.warnings, warning))


def _one_current_or_per_log(
    settings: FitSettings, data: SmoothedLogs, *, by_default: bool
) -> tuple[FitSettings, SmoothedLogs]:
    """Check a fit of one current for all the logs against what the logs show, once.

    Where the logs' approaches or speed logs show different currents
    (``identifier.current.current_disagreement``, no hull model in it), a ship's default
    and ``auto`` fit each log in its own (``current="per-log"``) and a note says why; a
    current asked for as one (``constant``, ``drifting``) is fitted as asked, with a
    warning. For ``auto`` (a model's default) the finding is the evidence of a current it
    asks for: currents that differ are not all still water. One current for runs in two
    tides takes their difference into the hull: 10–18 points of the calm-water 35° turn
    on the KVLCC2 reference (ebb after flood, 0.5 m/s), per log 0.6–3.8
    (benchmarks/environment.md, "Runs in another tide"). ``settings`` and ``data`` as
    they are where the logs agree.
    """
    found = current_disagreement(data.logs, data.tracks, data.names)
    if not found:
        return settings, data
    shown = f"the logs were sailed in different currents ({'; '.join(found)})"
    if by_default or settings.current == "auto":
        note = (
            f"{shown}: each is fitted in its own (--current per-log, what the default and "
            "auto take where the logs show that; --current constant for one)"
        )
        return replace(settings, current=PER_LOG), replace(data, notes=(*data.notes, note))
    warning = (
        f"{shown}: one current for all of them puts the difference into the hull; fit runs "
        "of other times of the tide with --current per-log (a strong wind's leeway drifts "
        "approaches on other headings too)"
    )
    return settings, replace(data, warnings=(*data.warnings, warning))


def _fit_auto_current(
    data: SmoothedLogs,
    settings: FitSettings,
    fit: Callable[
        [FitSettings, Callable[[int], None] | None, Callable[[str], None]], IdentificationResult
    ],
    progress: Callable[[int], None] | None,
    stage: Callable[[str], None],
) -> IdentificationResult:
    """:func:`identify`'s fit with ``current="auto"``: a constant current or none.

    ``fit(settings, progress, stage)`` fits ``data``. Logs with a speed log the fit uses
    are fitted with a current (the log measures it). Otherwise both are fitted and the
    current is kept where the logs show it (``identifier.current.choose_current``); both
    results are held until then, so a long log's EKF histories twice. Where one of the two
    fits fails (``IdentificationError``) the other is kept, and the reason says so; where
    both fail, the second's error is raised.
    """
    still_water = replace(settings, current="none")
    try:
        with_current = fit(
            replace(settings, current="constant"), progress, _labelled(stage, "with a current")
        )
    except IdentificationError as exc:
        still = fit(still_water, progress, _labelled(stage, "in still water"))
        reason = f"the fit with a current failed ({exc})"
        return _with_choice(still, settings, CurrentChoice("none", {}, reason))
    current = with_current.current
    assert current is not None
    if current.measured:  # not when the log was refused as broken
        reason = "the logs carry a speed log (stw_mps), which measures the current"
        return _with_choice(with_current, settings, CurrentChoice("constant", {}, reason))
    try:
        still = fit(still_water, None, _labelled(stage, "in still water"))
    except IdentificationError as exc:
        reason = f"the still-water fit failed ({exc})"
        return _with_choice(with_current, settings, CurrentChoice("constant", {}, reason))
    fits = {"constant": with_current, "none": still}
    rms = {mode: _training_track_rms_m(result, data) for mode, result in fits.items()}
    kept_mode = choose_current(rms)
    apart = {
        mode: _distance_text(rms[mode], " (RMS)" if mode == "constant" else "") for mode in rms
    }
    reason = (
        f"predicted open loop from execute, the training logs stay {apart['constant']} from "
        f"their tracks with a current of {current.speed_mps:.3f} m/s towards "
        f"{math.degrees(current.to_rad):.0f} deg, {apart['none']} in still water (a current is "
        f"kept where it divides the distance by {CURRENT_EVIDENCE_RATIO:g})"
    )
    return _with_choice(fits[kept_mode], settings, CurrentChoice(kept_mode, rms, reason))


def _distance_text(rms_m: float, what: str = "") -> str:
    """Return ``rms_m`` [m] and ``what`` it is for the current choice's reason.

    A diverging prediction's ``math.inf`` is said as what it means.
    """
    return f"{rms_m:.3g} m{what}" if math.isfinite(rms_m) else "no distance (a prediction diverges)"


def _labelled(stage: Callable[[str], None], label: str) -> Callable[[str], None]:
    """Return ``stage`` with ``label`` before every stage name (which fit of auto's)."""

    def labelled(name: str) -> None:
        stage(f"{label}: {name}")

    return labelled


def _training_track_rms_m(result: IdentificationResult, data: SmoothedLogs) -> float:
    """RMS distance of ``result``'s predictions of its training logs from their tracks [m].

    Every sample after each log's execute counts alike; a fit with a current predicts the
    track through the water (``water_frame``), which is the one over the ground less the
    current's drift. ``math.inf`` when a prediction diverges.
    """
    distances = []
    currents = None if result.current is None else result.current.vectors(len(data.logs))
    for i, (log, track) in enumerate(zip(data.logs, data.tracks, strict=True)):
        if currents is not None:
            log, track = water_frame(log, track, currents[i])
        distances.append(track_distance_m(result.params, log, track))
    pooled = np.concatenate(distances)
    return math.sqrt(float(np.mean(pooled**2))) if np.all(np.isfinite(pooled)) else math.inf


def _with_choice(
    result: IdentificationResult, settings: FitSettings, choice: CurrentChoice
) -> IdentificationResult:
    """Return the kept mode's ``result`` with ``choice``, its settings' current as asked.

    The settings are the kept fit's (a thrust refit's model, say) but for ``current``,
    which stays ``settings.current`` ("auto"); ``environment.current`` is the mode kept.
    """
    kept_settings = replace(result.settings, current=settings.current)
    identification = result.params.identification
    environment = {**identification["environment"], "current_choice": choice.as_dict()}
    params = replace(
        result.params,
        identification={
            **identification,
            "settings": _json_safe(asdict(kept_settings)),
            "environment": environment,
        },
    )
    return replace(result, params=params, settings=kept_settings, current_choice=choice)


def _fit_thrust_ruled(
    data: SmoothedLogs,
    settings: FitSettings,
    progress: Callable[[int], None] | None,
    stage: Callable[[str], None],
    *,
    length: float,
    vessel: str,
) -> IdentificationResult:
    """Return :func:`_fit`'s result, refitted with a thrust of fixed slope if need be.

    Refitted (``fixed_thrust_model``) when the free thrust is not a propeller's
    (:func:`~identifier.diagnostics.thrust_warning`), and recorded why.
    """
    result = _fit(data, settings, length, vessel, progress, stage)
    fixed_slope = fixed_thrust_model(settings.model)
    if fixed_slope is None or thrust_warning(result.params) is None:
        return result
    free = result.params.as_dict()
    del result  # a long log's EKF histories: not held twice (issue 17)
    stage("refit with a thrust of fixed open-water slope")
    try:
        refit = _fit(data, replace(settings, model=fixed_slope), length, vessel, None, stage)
    except IdentificationError as exc:  # the free split again (deterministic), warned
        failed = f"the refit as {fixed_slope} failed ({exc}); kept {settings.model}"
        kept = _fit(data, settings, length, vessel, None, stage)
        return replace(kept, notes=(*kept.notes, failed))
    why = (
        f"{settings.model}'s thrust came out not a propeller's (X_nn = {free['X_nn']:.3g}, "
        f"X_un = {free['X_un']:.3g}: the logs do not split it); refitted as "
        f"{family_name(fixed_slope)}, a thrust of fixed open-water slope"
    )
    identification = {**refit.params.identification, "thrust": why}
    return replace(
        refit,
        params=replace(refit.params, identification=identification),
        notes=(*refit.notes, why),
    )


_FIXED_THRUST_FAMILIES = {
    PRIME_RUDDER.name: PRIME_RUDDER_THRUST.name,
    PRIME_RUDDER_OFFSET.name: PRIME_RUDDER_OFFSET_THRUST.name,
    PRIME_CROSSFLOW.name: PRIME_CROSSFLOW_THRUST.name,
    PRIME_RUDDER_SLIPSTREAM.name: PRIME_RUDDER_SLIPSTREAM_THRUST.name,
}
"""The family a fit of the key family is refitted as when its thrust is not a propeller's."""


def fixed_thrust_model(model: str) -> str | None:
    """Return the model a fit is refitted as when its thrust is not a propeller's.

    ``prime-rudder-thrust`` for ``prime-rudder``, ``prime-rudder-offset-thrust`` for
    ``prime-rudder-offset``, ``prime-rudder-slipstream-thrust`` for
    ``prime-rudder-slipstream`` and ``prime-crossflow-thrust`` for ``prime-crossflow`` (bare
    or with constants, which the refit fixes as well); None
    for every other model, whose thrust :func:`~identifier.diagnostics.thrust_warning`
    only warns about.
    """
    parsed = parse_family(model)
    if parsed is None:
        return None
    family, fixed = parsed
    fixed_family = _FIXED_THRUST_FAMILIES.get(family.name)
    if fixed_family is None:
        return None
    if not fixed:
        return fixed_family
    return f"{fixed_family}[" + ",".join(f"{k}={v!r}" for k, v in fixed.items()) + "]"


def _fit(
    data: SmoothedLogs,
    settings: FitSettings,
    length: float,
    vessel: str,
    progress: Callable[[int], None] | None,
    stage: Callable[[str], None],
) -> IdentificationResult:
    """Identify ``settings.model`` from the smoothed logs (:func:`identify`'s fit)."""
    logs, tracks, segments = data.logs, data.tracks, data.segments
    warnings = list(data.warnings)
    notes = list(data.notes)
    current = None
    if settings.current == "none":
        nominal_speed_mps, nominal_n_rps = _nominal(logs, segments)
        envelope = _envelope(logs, segments, length)
        stage("equation-error start")
        shape, structure, ls = _structure_and_start(
            settings, segments, length, nominal_speed_mps, nominal_n_rps
        )
        stage("EKF on every sample")
        ekf = _run_ekf(settings, structure, ls, segments, length, progress)
    else:
        shape, structure, ls, ekf, current = _estimate_current(
            settings, segments, tracks, logs, length, progress, stage, notes
        )
        water = water_segments(segments, tracks, current.vectors(len(segments)))
        nominal_speed_mps, nominal_n_rps = _nominal(logs, water)
        envelope = _envelope(logs, water, length)
        del water  # a copy of every velocity: not held through the refinement
        if current.speed_log_ignored is not None:
            warnings.append(f"the speed log (stw_mps) was not used: {current.speed_log_ignored}")
        span = heading_span_warning(current, tracks)
        if span is not None:
            warnings.append(span)
    reports = _coefficient_reports(structure, ekf, ls, settings)
    params = ModelParameters(
        model=structure.name,
        coefficients=ekf.theta,
        length_m=length,
        vessel_name=vessel,
        nominal_speed_mps=nominal_speed_mps,
        nominal_n_rps=nominal_n_rps,
        covariance=ekf.covariance,
        windage=settings.windage,
        identification={
            "method": "smoothing (CA Kalman + RTS) -> augmented-state EKF (Shi et al. 2009)",
            "logs": [
                {"path": name, "sha256": _sha256(log)}
                for name, log in zip(data.names, logs, strict=True)
            ],
            "settings": _json_safe(asdict(settings)),
            **({} if shape is None else {"shape": shape.as_dict()}),
            "environment": {"current": "none"} if current is None else current.as_dict(),
            "envelope": envelope.as_dict(),
            "noise": [
                {"position_m": t.position_noise_m, "heading_deg": math.degrees(t.heading_noise_rad)}
                for t in tracks
            ],
            "created": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        },
    )
    weak = [c.name for c in reports if not c.identifiable]
    if weak:
        warnings.append(
            "not identifiable from these logs (not excited, collinear with other terms, or "
            f"posterior std above {settings.max_relative_std:.0%} of the value): " + ", ".join(weak)
        )
    held = [t.coefficient for t in structure.terms if t.prior_std is not None]
    for left_open in (
        turn_warning(
            weak,
            turn_logged=covers_turn(tracks),
            largest_rudder_rad=max(envelope.rudder_max_rad),
            held=held,
        ),
        reversal_warning(logs),
    ):
        if left_open is not None:
            warnings.append(left_open)
    refinement = None
    steps = _replay_steps(logs, length, nominal_speed_mps)
    if settings.method == "output-error" and steps > MAX_REFINE_STEPS:
        warnings.append(
            f"output-error refinement skipped: one replay of these logs takes {steps:,} RK4 "
            f"steps (at most {MAX_REFINE_STEPS:,}: hundreds of replays would take too long); "
            "kept the EKF estimate. Fit the manoeuvres alone, or use --method ekf"
        )
    elif settings.method == "output-error":
        stage("output-error refinement")
        refinement = _refine(params, ls, settings, logs, tracks, current)
        params = refinement.params
        warnings.extend(refinement.warnings)
    warnings.extend(w for w in (thrust_warning(params), centripetal_warning(params)) if w)
    estimates = {
        "ekf": dict(zip(structure.coefficient_names, map(float, ekf.theta), strict=True)),
        "equation-error": dict(zip(structure.coefficient_names, map(float, ls.theta), strict=True)),
    }
    if refinement is not None:
        estimates["output-error"] = refinement.refined.params.as_dict()
    params = replace(params, identification={**params.identification, "estimates": estimates})
    return IdentificationResult(
        params=params,
        logs=data.given,
        tracks=tuple(tracks),
        equation_error=ls,
        ekf=ekf,
        coefficients=reports,
        warnings=tuple(warnings),
        notes=tuple(notes),
        settings=settings,
        refinement=refinement,
        current=current,
    )


def _coefficient_reports(
    structure: ModelStructure, ekf: EkfResult, ls: EquationErrorFit, settings: FitSettings
) -> tuple[CoefficientReport, ...]:
    """Each coefficient of the EKF's estimate with its σ and whether the logs determine it.

    Identifiable: excited in the logs, a variance inflation of its equation-error column
    within ``settings.max_variance_inflation`` and a posterior σ within
    ``settings.max_relative_std`` of the value.
    """
    std = np.sqrt(np.diag(ekf.covariance))
    return tuple(
        CoefficientReport(
            name=name,
            value=float(value),
            std=float(s),
            relative_std=float(s / abs(value)) if value != 0.0 else math.inf,
            contribution=float(c),
            variance_inflation=float(vif),
            excited=bool(rms > 0.0),
            identifiable=bool(
                rms > 0.0
                and vif <= settings.max_variance_inflation
                and s <= settings.max_relative_std * abs(value)
            ),
        )
        for name, value, s, c, rms, vif in zip(
            structure.coefficient_names,
            ekf.theta,
            std,
            ls.contribution,
            ls.regressor_rms,
            ls.variance_inflation,
            strict=True,
        )
    )


def _refine(
    params: ModelParameters,
    ls: EquationErrorFit,
    settings: FitSettings,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    current: CurrentEstimate | None,
) -> RefinementResult:
    """Refine the EKF's estimate ``params`` by output error, the equation-error one beside it.

    The equation-error estimate carries the EKF's prior covariance (its own × the
    ``prior_inflation``²). With a current the logs are taken into the water frame first:
    the refinement sees a ship in still water.
    """
    equation_error = params.with_vector(ls.theta, ls.covariance * settings.prior_inflation**2)
    water_logs, water_tracks = list(logs), list(tracks)
    if current is not None:
        moved = [
            water_frame(g, t, c)
            for g, t, c in zip(logs, tracks, current.vectors(len(logs)), strict=True)
        ]
        water_logs, water_tracks = [m[0] for m in moved], [m[1] for m in moved]
    return refine_output_error(
        params, water_logs, tracks=water_tracks, alternatives={"equation-error": equation_error}
    )
