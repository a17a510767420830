"""A uniform current in identification: through the water, not over the ground.

A trial at sea is logged over the ground, but the hull forces act on the velocities
through the water. With a uniform current c = (c_N, c_E) [m/s] (the direction it sets
towards) the kinematics are

    ẋ = u cos ψ − v sin ψ + c_N,   ẏ = u sin ψ + v cos ψ + c_E,

with u, v through the water, and the smoothed velocities over the ground are those
plus the current's body components (:func:`identifier.ekf.body_current`). Fitted as if
the water were still, the current goes into the hull coefficients: 0.5 m/s setting
across a KVLCC2's zig-zags turns the predicted 35° turn's tactical diameter by +22 %.

The current is estimated with the coefficients (``identifier.identify``): c enters the
augmented EKF as two more states (:func:`identifier.ekf.ekf_identify`), and the
equation-error fit that starts the EKF is written on the velocities through the water
for the current so far, starting from what the straight approaches show
(:func:`initial_current`). The two alternate until the current settles
(:func:`current_tolerance_mps`): the equation-error start, fitted on ground velocities,
would otherwise hold the EKF's coefficients, and with them the current, near the
still-water answer. On long logs the alternation's EKF passes run on windows of the
data (:data:`ALTERNATION_MAX_SAMPLES`); the last pass sees every sample. The model
family's shape is chosen again once for the settled current (:data:`SHAPE_PASSES`).
Once the current is known, the logs and their smoothed tracks are moved into the water
frame (:func:`water_frame`), and everything downstream (the output-error refinement,
its guards) sees a ship in still water.

What separates a current from the hull: a turn of 360° or more shows it as the drift of
the circle; a straight approach shows its cross component as a drift angle the
symmetric hull does not have; its along-course component looks like the ship's own
speed and is told apart only by the heading changes of the manoeuvres and by how the
hull's response scales with the speed through the water. Zig-zags alone (heading
±35°) separate it less well (:data:`MIN_HEADING_SPAN_RAD`, warned about), unless the
logs carry a speed log (``stw_mps``): that measures the speed through the water, so the
current along the course directly, up to the log's scale error, which the manoeuvres'
speed changes tell apart. The EKF then measures the log sample by sample, its scale
error one more state (``identifier.ekf.SpeedLogMeasurement``; noise from the log itself,
:func:`speed_log_noise_mps`); what the log shows alone (:func:`speed_log_current`)
starts the alternation, says whether the log is plausible at all, and is reported.

Whether to estimate a current at all: ``--current auto`` fits both and lets the training
logs decide (:func:`choose_current`); a speed log decides for a current. A fit that names
no mode takes one by the ship's size (:func:`default_current`): a ship's logs a constant
current, a model's auto.

One current for every log, or one each: runs sailed hours apart meet another tide.
``--current per-log`` (:data:`PER_LOG`) gives every log a constant current of its own,
its own start (its speed log's, else its approach's) and its own states in the EKF,
restarted at each log (``identifier.ekf.ekf_identify``); the water frame then moves each
log by its own. :func:`current_disagreement` says when the logs' approaches or speed logs
show different currents; a ship's default then takes one per log (a note), a current
asked for as one warns. A drifting current walks through the time between the runs too,
where the logs carry their time origins (``identifier.preparation.sailed_order``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import median_abs_deviation

from fmu_model import ModelParameters
from identifier.ekf import EkfSegment, body_current
from identifier.smoothing import SmoothedTrack
from trials.conditions import MODEL_SCALE_MAX_LENGTH_M, execute_index
from trials.logs import ManeuverLog

CURRENT_MODES = ("constant", "none", "drifting", "per-log", "auto")
"""``--current``: a constant current (a ship's default, :data:`DEFAULT_CURRENT`), none
(still water), a drifting one (random walk), one constant current per log (:data:`PER_LOG`),
or auto (a constant one where the training logs show it, else none:
:func:`choose_current`; a model's default, :data:`MODEL_SCALE_CURRENT`)."""

PER_LOG = "per-log"
"""``--current per-log``: each log has a constant current of its own, independent of the
others': runs sailed hours apart, at another time of the tide. One current for all of
them takes their difference into the hull: two KVLCC2 zig-zags in 0.5 m/s setting to 45°
and to 225° put the calm-water 35° turn 10–18 points off the calm logs' fit with a speed
log, 47–68 without; per log 0.6–3.8 and 0.2–4.9 (benchmarks/environment.md, "Runs in
another tide"). What it costs: each current is told from its own log's manoeuvres only,
and in calm water each log's phantom current (the structure's error) is its own
(benchmarks/fidelity.md, "A current per log for every fit"): a ship's default takes it
only where the logs show different currents (``identifier.identify``)."""

DEFAULT_CURRENT = "constant"
"""The default ``--current`` of a ship (:func:`default_current`). Not "auto", which keeps
still water in calm logs: the Mariner's zig-zag-trained turns then come out 21 points
worse in sum over ten draws (the phantom current of its constant fits takes up part of
its structure's error), for 5.5 points better on the KVLCC2 reference
(benchmarks/fidelity.md, "A current must halve the distance")."""

MODEL_SCALE_CURRENT = "auto"
"""The default ``--current`` of a ship shorter than ``MODEL_SCALE_MAX_LENGTH_M`` (20 m):
mostly a model in a basin's still water, where a current estimated is the structure's error
(the HSVA runs: 0.03–0.04 m/s, and their held-out overshoots 17.4° off in sum over six
folds against 15.9° with auto, which keeps still water in every fold, benchmarks/hsva.md);
auto rather than none for a small craft logged at sea, whose current the logs then show
(:func:`choose_current`)."""


def kept_current(params: ModelParameters) -> str:
    """Return the current mode a fit kept, as its params.json records it ("none", "per-log", …)."""
    return str(params.identification["environment"]["current"])


def default_current(length_m: float, measurements: str = "track") -> str:
    """Return the ``--current`` of a fit that names none, by the ship's length [m].

    :data:`MODEL_SCALE_CURRENT` below ``MODEL_SCALE_MAX_LENGTH_M``, else
    :data:`DEFAULT_CURRENT`; "none" when the EKF measures smoothed velocities (a current
    needs ``measurements="track"``).
    """
    if measurements != "track":
        return "none"
    return MODEL_SCALE_CURRENT if length_m < MODEL_SCALE_MAX_LENGTH_M else DEFAULT_CURRENT


CURRENT_EVIDENCE_RATIO = 2.0
"""How many times closer to their tracks a fit with a current must predict the training
logs than the still-water fit, for ``--current auto`` to keep the current
(:func:`choose_current`). A current the logs show makes the still-water fit drift off:
the KVLCC2 zig-zags in 0.25–1.0 m/s, 3.5–6 times the distance of the fit with it
(benchmarks/environment.md, "Without a speed log, and `--current auto`"). A current the
estimator invents in still water (the structure's error) does not halve it: the
HSVA 10/10 pair 0.57 m against 0.35 m in still water (benchmarks/hsva.md), its
three-run folds within 1 %, calm KVLCC2 and Mariner zig-zags 0.58–1.52 times, with 1 %
GNSS jumps 0.95–1.24 (benchmarks/fidelity.md, "A current only where the logs show one").
Between the two, a ratio of 2 tells them apart where a ratio of 1 flips with the noise."""

CURRENT_PRIOR_STD_MPS = 1.0
"""Prior standard deviation of each current component [m/s]: 2 kn, an open-sea current
beyond the ordinary."""

DRIFTING_RANDOM_WALK_MPS = 0.2
"""Random walk of each component of a drifting current in an hour [m/s] (a tidal current
turns by about 1 kn in a few hours)."""

SPEED_LOG_SCALE_STD = 0.01
"""Prior standard deviation of a speed log's scale error k (stw = (1 + k) u_w), a fraction
of the speed: IMO MSC.96(72) allows a speed log 2 % of the ship's speed (or 0.2 kn,
whichever is more), taken here as two standard deviations (:func:`speed_log_current`
and the EKF, ``identifier.ekf.SpeedLogMeasurement``). At 15 kn, 1 % is 0.08 m/s of
current along the course: the manoeuvres' speed changes, not this prior, must tell the
two apart."""

MAX_SPEED_LOG_CURRENT_MPS = 3.0
"""A speed log that implies a current above this [m/s] (6 kn: beyond the open sea's, a
tidal race's) is not used (:meth:`SpeedLogFit.implausible`)."""

MAX_SPEED_LOG_SCALE_ERROR = 0.1
"""... nor one whose scale error is above this fraction (ten times IMO MSC.96(72)'s 2 %)."""

MAX_SPEED_LOG_CORRELATION = 0.95
"""Largest lag-one correlation of a speed log's noise taken (:func:`speed_log_noise_mps`):
its noise then counts as a 39th of a white noise's samples."""

SPEED_LOG_NOISE_LAGS = (1, 2, 4, 8)
"""The lags of :func:`speed_log_noise_mps`'s second differences [samples]."""

MIN_SPEED_LOG_DIFFERENCES = 8
"""Fewest second differences of a lag :func:`speed_log_noise_mps` takes a variance of."""

MIN_SPEED_LOG_NOISE_MPS = 0.005
"""Least noise σ a speed log is taken to have [m/s] (0.01 kn: a log's resolution at
best); a log whose samples never change is no measurement to the millimetre."""

SPEED_LOG_HUBER_SIGMAS = 3.0
"""Speed-log residuals beyond this many σ count linearly, not squared (Huber loss,
:func:`speed_log_current`): a spike or a drop-out is one bad sample, not a current."""

CURRENT_TOLERANCE_MPS = 1e-3
"""The alternation stops when no component changes by more than this [m/s] or by more
than :data:`CURRENT_TOLERANCE_SIGMAS` of the estimate's own standard deviation."""

CURRENT_TOLERANCE_SIGMAS = 0.1
"""... a change far inside the estimate's uncertainty is noise of the passes, not a
current still moving (:func:`current_tolerance_mps`)."""

MAX_CURRENT_ITERATIONS = 15
"""Most EKF passes of one alternation (each a fraction of a second for a few logs)."""

ALTERNATION_MAX_SAMPLES = 50_000
"""The alternation's EKF passes see at most about this many samples, in
:data:`ALTERNATION_WINDOWS` windows spread over the logs (``identifier.ekf.sample_windows``):
they only settle the start; the last pass, the estimate, sees every sample. A day-long
log at 10 Hz has 864,000; the manoeuvres of a trial at 1 Hz, a few thousand."""

MIN_APPROACH_SPREAD_RAD = math.radians(5.0)
"""Spread of the approaches' headings (RMS about their mean) below which they do not show
the current's along component (:func:`initial_current`). The
least-squares solution resolves a component when its singular value exceeds this
fraction (sin) of the largest, and for approaches on one heading that fraction is the
RMS heading spread: a compass's noise (0.5° is ordinary for a GNSS compass) would
otherwise "resolve" the along component as v_g divided by noise (7 m/s on the KVLCC2
logs at 0.5°, benchmarks/sensitivity.md)."""

ALONG_COURSE_STARTS = (0.1, 0.2)
"""Along-course components of the current's start, as shares of the approach speed [-],
that the alternation tries either way when the start the approaches show (none along
their common heading) makes the EKF diverge (``identifier.identify``): a current of 0.7
to 1.5 m/s along a 7.7 m/s Mariner's course is 10 to 20 % of its speed; the first share
with a start that settles is kept."""

ALTERNATION_WINDOWS = 4
"""Windows of the alternation's samples on long logs (:data:`ALTERNATION_MAX_SAMPLES`):
few and long (12,500 samples: 21 min at 10 Hz, a KVLCC2 zig-zag or turn), as short
windows of a log of zig-zags alone do not separate the current from the hull."""

SHAPE_PASSES = 2
"""Shape choices: for the starting current, then once more for the settled one."""

_CHUNK_SAMPLES = 65_536
"""Samples per block of the per-sample arithmetic on whole logs (bounded temporaries)."""

CURRENT_DISAGREEMENT_MPS = 0.1
"""Logs whose currents, as their approaches or speed logs show them, differ by more than
this [m/s] (0.2 kn) were sailed in different currents (:func:`current_disagreement`)."""

CURRENT_DISAGREEMENT_SIGMAS = 4.0
"""... and, for a speed log's current, by more than this many of its σ."""

MIN_HEADING_SPAN_RAD = math.radians(90.0)
"""Below this range of headings over all logs the along-course current is barely told
apart from the ship's own speed (warning)."""


def current_tolerance_mps(covariance: np.ndarray) -> float:
    """Return the change of the current [m/s] below which the alternation has settled.

    :data:`CURRENT_TOLERANCE_MPS`, or :data:`CURRENT_TOLERANCE_SIGMAS` of the largest
    standard deviation of the estimate (``covariance``, (2, 2) [m²/s²], or (logs, 2, 2)
    with a current per log) when that is more.
    """
    std = float(np.sqrt(np.max(np.diagonal(covariance, axis1=-2, axis2=-1))))
    return max(CURRENT_TOLERANCE_MPS, CURRENT_TOLERANCE_SIGMAS * std)


@dataclass(frozen=True)
class CurrentEstimate:
    """The estimated uniform current.

    Attributes
    ----------
    north_mps, east_mps : float
        Current velocity (it sets towards) [m/s]; for a drifting current, at the end of
        the last log; with a current per log, their mean weighted by their covariances
        (each log's own in ``logs``).
    covariance : numpy.ndarray
        Its covariance (2, 2) [m²/s²] from the EKF: identification noise only.
    mode : str
        ``"constant"``, ``"drifting"`` or ``"per-log"``.
    iterations : int
        EKF passes of the alternation.
    speed_log : SpeedLogFit, optional
        What the logs' speed log showed alone (the alternation's start); None without.
    speed_log_ignored : str, optional
        Why the logs' speed log was not used (:meth:`SpeedLogFit.implausible`); None.
    speed_log_ekf : SpeedLogInEkf, optional
        What the EKF, which measured the speed log, made of it; None without.
    model_form : numpy.ndarray
        The model-form term of the covariance (2, 2) [m²/s²] (:func:`current_model_form`);
        zeros when the logs carry no speed log the EKF measured.
    logs : tuple of CurrentEstimate
        With ``mode`` "per-log", each log's current in the order fitted (its ``log`` the
        log's name, its ``speed_log`` what that log's speed log shows alone); else empty.
    log : str, optional
        The log this current is of, in ``logs``; None for the current of every log.

    """

    north_mps: float
    east_mps: float
    covariance: np.ndarray
    mode: str
    iterations: int
    speed_log: SpeedLogFit | None = None
    speed_log_ignored: str | None = None
    speed_log_ekf: SpeedLogInEkf | None = None
    model_form: np.ndarray = field(default_factory=lambda: np.zeros((2, 2)))
    logs: tuple[CurrentEstimate, ...] = ()
    log: str | None = None

    @classmethod
    def of(
        cls,
        current_ne: np.ndarray,
        covariance: np.ndarray,
        mode: str,
        iterations: int = 0,
        **rest: Any,
    ) -> CurrentEstimate:
        """Return the estimate of a current (North, East) [m/s] and its covariance (2, 2).

        ``rest``: the other fields by name.
        """
        return cls(
            north_mps=float(current_ne[0]),
            east_mps=float(current_ne[1]),
            covariance=np.asarray(covariance, dtype=float),
            mode=mode,
            iterations=iterations,
            **rest,
        )

    def vectors(self, count: int) -> np.ndarray:
        """Return the current (c_N, c_E) of each of ``count`` logs (count, 2) [m/s].

        Each log's own with a current per log (``count`` must be their number), else
        :attr:`vector` for every one.
        """
        if self.logs:
            if count != len(self.logs):
                raise ValueError(f"a current for {len(self.logs)} logs, asked for {count}")
            return np.array([c.vector for c in self.logs])
        return np.tile(self.vector, (count, 1))

    @property
    def measured(self) -> bool:
        """Whether a speed log measured the current (with a current per log, every log's)."""
        return all(c.speed_log is not None for c in self.logs or (self,))

    @property
    def total_covariance(self) -> np.ndarray:
        """Covariance (2, 2) [m²/s²] with the model-form term: identification and structure."""
        return self.covariance + self.model_form

    @property
    def vector(self) -> np.ndarray:
        """(c_N, c_E) [m/s]."""
        return np.array([self.north_mps, self.east_mps])

    @property
    def speed_mps(self) -> float:
        """Current speed [m/s]."""
        return math.hypot(self.north_mps, self.east_mps)

    @property
    def to_rad(self) -> float:
        """Direction it sets towards, clockwise from North, in [0, 2π) [rad]."""
        return math.atan2(self.east_mps, self.north_mps) % (2.0 * math.pi)

    @property
    def std_mps(self) -> tuple[float, float]:
        """Standard deviations of (c_N, c_E) [m/s], the model-form term included."""
        total = self.total_covariance
        return (math.sqrt(total[0, 0]), math.sqrt(total[1, 1]))

    def as_dict(self) -> dict[str, object]:
        """Return the ``identification.environment`` record of params.json (units in keys)."""
        std_n, std_e = self.std_mps
        return {
            "current": self.mode,
            "current_north_mps": self.north_mps,
            "current_east_mps": self.east_mps,
            "current_north_std_mps": std_n,
            "current_east_std_mps": std_e,
            "current_speed_mps": self.speed_mps,
            "current_to_deg": math.degrees(self.to_rad),
            "current_covariance_m2ps2": self.total_covariance.tolist(),
            "current_identification_covariance_m2ps2": self.covariance.tolist(),
            "current_model_form_covariance_m2ps2": self.model_form.tolist(),
            "iterations": self.iterations,
            "speed_log": None
            if self.speed_log is None or self.speed_log_ekf is None
            else {**self.speed_log_ekf.as_dict(), "alone": self.speed_log.as_dict()},
            "speed_log_ignored": self.speed_log_ignored,
            **({"log": self.log} if self.log is not None else {}),
            **({"logs": [c.as_dict() for c in self.logs]} if self.logs else {}),
        }


@dataclass(frozen=True)
class CurrentChoice:
    """What ``--current auto`` kept, and why (:func:`choose_current`).

    Attributes
    ----------
    kept : str
        ``"constant"`` or ``"none"``.
    track_rms_m : dict of str to float
        Per mode fitted, the RMS distance of the training logs' predictions (open loop
        from execute, every sample after it) from their smoothed tracks over the ground
        [m]; ``math.inf`` where a prediction diverges. Empty when a speed log decided, or
        when one of the two fits failed.
    reason : str
        One sentence for the fit summary.

    """

    kept: str
    track_rms_m: dict[str, float]
    reason: str

    def as_dict(self) -> dict[str, object]:
        """Return the record of params.json's ``environment.current_choice`` (JSON numbers)."""
        return {
            "requested": "auto",
            "kept": self.kept,
            "track_rms_m": {
                mode: value if math.isfinite(value) else None
                for mode, value in self.track_rms_m.items()
            },
            "reason": self.reason,
        }


def choose_current(track_rms_m: Mapping[str, float]) -> str:
    """Return the mode of ``--current auto``: "constant" where the logs show a current.

    ``track_rms_m`` holds, for "none" and "constant", how far the fit's open-loop
    predictions of its own training logs stay from the smoothed tracks over the ground
    [m] (a fit with a current predicts the track through the water and adds the current).
    A current is kept where its fit's distance is at most 1 / :data:`CURRENT_EVIDENCE_RATIO`
    of the still-water fit's, and finite; otherwise still water, ties and two diverging
    predictions included: a current is one more hypothesis, and it must earn its place.
    """
    constant, none = track_rms_m["constant"], track_rms_m["none"]
    shown = math.isfinite(constant) and CURRENT_EVIDENCE_RATIO * constant <= none
    return "constant" if shown else "none"


@dataclass(frozen=True)
class SpeedLogInEkf:
    """The speed log as the EKF measured it (``identifier.ekf.SpeedLogMeasurement``).

    Attributes
    ----------
    scale_error, scale_error_std : float
        The log's scale error k (stw = (1 + k) u_w) and its standard deviation, estimated
        with the current and the coefficients [-].
    noise_mps : float
        The noise σ per sample the EKF took for it (:func:`speed_log_noise_mps`) [m/s].
    samples, rejected : int
        Samples measured, and samples the EKF's gate rejected (spikes, drop-outs).
    transverse_noise_mps : float, optional
        As ``noise_mps``, of a two-axis log's transverse axis; None without one.
    transverse_samples, transverse_rejected : int
        As ``samples`` and ``rejected``, of the transverse axis.

    """

    scale_error: float
    scale_error_std: float
    noise_mps: float
    samples: int
    rejected: int
    transverse_noise_mps: float | None = None
    transverse_samples: int = 0
    transverse_rejected: int = 0

    def as_dict(self) -> dict[str, object]:
        """Return the record of params.json's ``environment.speed_log`` (units in keys)."""
        return {
            "samples": self.samples,
            "rejected_samples": self.rejected,
            "noise_mps": self.noise_mps,
            "scale_error": self.scale_error,
            "scale_error_std": self.scale_error_std,
            "transverse_samples": self.transverse_samples,
            "transverse_rejected_samples": self.transverse_rejected,
            "transverse_noise_mps": self.transverse_noise_mps,
        }


def initial_current(logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack]) -> np.ndarray:
    """Return the current (North, East) the logs' approaches show [m/s]: the alternation's start.

    On a straight approach with the rudder amidships a (nearly) symmetric hull sails
    without drift, v ≈ 0 through the water, so the smoothed sway velocity over the ground
    is the current's cross component there: −c_N sin ψ + c_E cos ψ = v_g. Least squares
    over the approach samples of every log (before execute); with all approaches on one
    heading (within :data:`MIN_APPROACH_SPREAD_RAD`) the along component is not seen, and
    the minimum-norm solution leaves it 0 for the EKF to find. Without an approach:
    (0, 0). (A speed log shows the along component too: :func:`speed_log_current`.)
    """
    parts = [_approach_rows(log, track) for log, track in zip(logs, tracks, strict=True)]
    a, b = np.concatenate([a for a, _ in parts]), np.concatenate([b for _, b in parts])
    if b.size < 2:
        return np.zeros(2)
    return np.linalg.lstsq(a, b, rcond=math.sin(MIN_APPROACH_SPREAD_RAD))[0]


def approach_course(
    logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack]
) -> np.ndarray | None:
    """Return the unit vector (North, East) of the logs' approach heading, or None.

    The mean heading (cos ψ, sin ψ) of every log's approach (before execute): the
    direction along which :func:`initial_current` cannot see the current when the
    approaches share a heading; None as :func:`_unit_mean` (the across direction of the
    same samples, turned a quarter back).
    """
    rows = [_approach_rows(log, track)[0] for log, track in zip(logs, tracks, strict=True)]
    across = _unit_mean(np.concatenate(rows))
    return None if across is None else np.array([across[1], -across[0]])


def _unit_mean(directions: np.ndarray) -> np.ndarray | None:
    """Return the mean of unit vectors ``directions`` (M, 2), normalised.

    None for fewer than two, or when they point every way (the mean shorter than a half):
    no approach, or not a straight one.
    """
    if directions.shape[0] < 2:
        return None
    mean = directions.mean(axis=0)
    length = float(np.hypot(*mean))
    return mean / length if length >= 0.5 else None


def _approach_rows(log: ManeuverLog, track: SmoothedTrack) -> tuple[np.ndarray, np.ndarray]:
    """Return A, v_g of the approach (before execute): A c is the current's cross component."""
    end = execute_index(log)
    heading = np.asarray(track.heading_rad)[:end]
    return np.column_stack([-np.sin(heading), np.cos(heading)]), np.asarray(track.v_mps)[:end]


def with_approach_cross(
    current_ne: np.ndarray, log: ManeuverLog, track: SmoothedTrack
) -> np.ndarray:
    """Return ``current_ne`` [m/s] with its component across the log's approach as shown there.

    The straight approach (before execute) drifts across its heading with the current's
    cross component (:func:`initial_current`); along it, a log without a speed log shows
    nothing without a hull model, so that component stays ``current_ne``'s. Without an
    approach, ``current_ne`` itself.
    """
    a, v_g = _approach_rows(log, track)
    across = _unit_mean(a)
    if across is None:
        return np.asarray(current_ne, dtype=float)
    return current_ne + across * (float(np.mean(v_g)) - float(across @ current_ne))


def current_disagreement(
    logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack], names: Sequence[str]
) -> list[str]:
    """Say which logs show a current :data:`CURRENT_DISAGREEMENT_MPS` off the others'.

    Two views need no hull model: a straight approach drifts across its heading with the
    current's cross component (:func:`initial_current`), and a log's speed log shows its
    current whole (:func:`speed_log_current`, each log alone). A log whose approach drifts
    that much off what all the approaches show together, or whose speed log's current is
    that far (and :data:`CURRENT_DISAGREEMENT_SIGMAS` of its σ) from the logs' weighted
    mean, was sailed in another current: a run at another time of the tide, for
    ``--current per-log``. On the KVLCC2 reference's logs in one current the approaches
    agree within 0.008 m/s and the speed logs within 2σ; in currents of 0.5 m/s setting
    to 45° and to 225° the approaches are 0.35 m/s off (benchmarks/environment.md, "Runs
    in another tide"). A strong wind's leeway also drifts approaches that differ in
    heading. One phrase per finding ("<name>'s approach drifts +0.35 m/s across its
    heading"); none when the logs agree, or for one log.
    """
    if len(logs) < 2:
        return []
    common = initial_current(logs, tracks)
    found = []
    for log, track, name in zip(logs, tracks, names, strict=True):
        a, v_g = _approach_rows(log, track)
        if v_g.size >= 2:
            drift = float(np.mean(v_g - a @ common))
            if abs(drift) > CURRENT_DISAGREEMENT_MPS:
                found.append(f"{name}'s approach drifts {drift:+.2f} m/s across its heading")
    alone = [
        (name, fit)
        for log, track, name in zip(logs, tracks, names, strict=True)
        if (fit := speed_log_current([log], [track])) is not None and fit.implausible() is None
    ]
    if len(alone) >= 2:
        mean, _ = weighted_mean_current(
            np.array([f.current_ne for _, f in alone]), np.array([f.covariance for _, f in alone])
        )
        for name, fit in alone:
            d = fit.current_ne - mean
            sigma = math.sqrt(float(d @ fit.covariance @ d) / float(d @ d)) if d.any() else 0.0
            distance = float(np.hypot(*d))
            if distance > max(CURRENT_DISAGREEMENT_MPS, CURRENT_DISAGREEMENT_SIGMAS * sigma):
                found.append(f"{name}'s speed log shows a current {distance:.2f} m/s off the mean")
    return found


def weighted_mean_current(
    currents: np.ndarray, covariances: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return the covariance-weighted mean (2,) of currents (logs, 2) [m/s], and its covariance.

    c̄ = C̄ Σ C_i⁻¹ c_i with C̄ = (Σ C_i⁻¹)⁻¹ (covariances (logs, 2, 2) [m²/s²]): the one
    current that all the logs' estimates show together, were it one.
    """
    information = np.linalg.inv(covariances)
    covariance = np.linalg.inv(information.sum(axis=0))
    return covariance @ np.einsum("kij,kj->i", information, currents), covariance


@dataclass(frozen=True)
class SpeedLogFit:
    """The current a speed log shows, with the log's scale error (:func:`speed_log_current`).

    Attributes
    ----------
    current_ne : numpy.ndarray
        Current (North, East) [m/s].
    covariance : numpy.ndarray
        Its covariance (2, 2) [m²/s²], the scale error's uncertainty included.
    scale_error, scale_error_std : float
        k of stw = (1 + k) u_w and its standard deviation [-].
    samples : int
        Speed-log samples fitted.
    noise_mps : float
        Standard deviation of the residual (the log's noise and the smoothed
        velocities'), robust (from the median absolute residual) [m/s].
    transverse_samples : int
        Samples of a two-axis log's transverse axis fitted (0: none).
    transverse_noise_mps : float, optional
        As ``noise_mps``, of the transverse axis; None without one.

    """

    current_ne: np.ndarray
    covariance: np.ndarray
    scale_error: float
    scale_error_std: float
    samples: int
    noise_mps: float
    transverse_samples: int = 0
    transverse_noise_mps: float | None = None

    def implausible(self) -> str | None:
        """Return why this fit is no measurement of a current, or None when it may be.

        A current above :data:`MAX_SPEED_LOG_CURRENT_MPS` or a scale error above
        :data:`MAX_SPEED_LOG_SCALE_ERROR` says the log is broken (stuck at 0, another
        unit, a fouled sensor), not that the sea is so.
        """
        speed = math.hypot(*self.current_ne)
        if speed > MAX_SPEED_LOG_CURRENT_MPS:
            return (
                f"it implies a current of {speed:.2f} m/s, more than "
                f"{MAX_SPEED_LOG_CURRENT_MPS:g} m/s (a log stuck or in other units?)"
            )
        if abs(self.scale_error) > MAX_SPEED_LOG_SCALE_ERROR:
            return (
                f"its scale error is {100.0 * self.scale_error:+.0f} %, beyond "
                f"±{100.0 * MAX_SPEED_LOG_SCALE_ERROR:g} %"
            )
        return None

    def as_dict(self) -> dict[str, object]:
        """Return the record of ``environment.speed_log.alone`` (units in keys)."""
        return {
            "samples": self.samples,
            "scale_error": self.scale_error,
            "scale_error_std": self.scale_error_std,
            "noise_mps": self.noise_mps,
            "transverse_samples": self.transverse_samples,
            "transverse_noise_mps": self.transverse_noise_mps,
            "current_north_mps": float(self.current_ne[0]),
            "current_east_mps": float(self.current_ne[1]),
            "current_covariance_m2ps2": self.covariance.tolist(),
        }


def placed_speed_log(log: ManeuverLog) -> ManeuverLog:
    """Return ``log`` without its speed log's transverse axis where its position is unknown.

    A two-axis log's transverse axis measures the sway speed v + x·r at its position x
    forward of midship (metadata ``speed_log_x_m``); without x it cannot be used
    (:func:`speed_log_current` refuses it), the along axis still can. ``log`` itself
    otherwise.
    """
    if log.stw_transverse_mps is None or log.on_board_m("speed_log_x_m") is not None:
        return log
    return replace(log, stw_transverse_mps=None)


def speed_log_current(
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    scale_std: float = SPEED_LOG_SCALE_STD,
) -> SpeedLogFit | None:
    """Return the current and the speed log's scale error that every speed-log sample shows.

    A speed log measures the speed through the water along the ship, stw = (1 + k) u_w,
    and u_w = u_g − c_u(ψ) with u_g the smoothed surge velocity over the ground and
    c_u = c_N cos ψ + c_E sin ψ the current's forward component
    (:func:`identifier.ekf.body_current`), so that

        stw = (1 + k)(u_g − c_N cos ψ − c_E sin ψ) + ε;

    a two-axis log's transverse axis (``stw_transverse_mps``) as well, at the log's
    position x_L forward of midship (metadata ``speed_log_x_m``), with the same k,

        stw_t = (1 + k)(v_g + x_L r + c_N sin ψ − c_E cos ψ) + ε'.

    The heading changes of the manoeuvres show both components of c; the speed changes
    (a zig-zag loses some of it at every swing) tell the scale error k apart from the
    current along the course. Least squares (``scipy.optimize.least_squares``) with the
    priors c ~ N(0, :data:`CURRENT_PRIOR_STD_MPS`²) and k ~ N(0, ``scale_std``²), and a
    Huber loss beyond :data:`SPEED_LOG_HUBER_SIGMAS` σ, so that a speed log's spikes and
    drop-outs (aerated water, a fouled sensor) weigh as little as they deserve. Each
    axis's noise σ (from the median absolute residual) and lag-one correlation ρ (the
    smoothed velocities are correlated from sample to sample; from the samples within
    :data:`SPEED_LOG_HUBER_SIGMAS` σ) come from the residuals of a first fit with k = 0;
    every sample then counts as (1 − ρ)/(1 + ρ) of an independent one (an AR(1) residual's
    effective sample size). The covariance is (JᵀJ)⁻¹ at the solution (the loss's
    Gauss-Newton J), its (c_N, c_E) block the current's. None when no log carries
    ``stw_mps``; ValueError when one carries ``stw_transverse_mps`` without its position.
    """
    if scale_std <= 0.0:
        raise ValueError("scale_std must be positive")
    pairs = zip(logs, tracks, strict=True)
    parts = [(log, track) for log, track in pairs if log.stw_mps is not None]
    if not parts:
        return None
    axes = [_SpeedLogAxis.along(parts)]
    if any(log.stw_transverse_mps is not None for log, _ in parts):
        axes.append(_SpeedLogAxis.across(parts))
    a = np.concatenate([axis.current_rows for axis in axes])
    first = np.linalg.lstsq(
        a, np.concatenate([axis.over_ground - axis.measured for axis in axes]), rcond=None
    )[0]
    noise = [axis.noise(first) for axis in axes]  # (σ, σ per effective sample) of each axis
    threshold = np.concatenate(  # the Huber threshold of each residual, in its own units
        [np.full(axis.measured.size, SPEED_LOG_HUBER_SIGMAS * sigma / effective)
         for axis, (sigma, effective) in zip(axes, noise, strict=True)] + [np.full(3, np.inf)]
    )  # fmt: skip

    def weighted_residuals(p: np.ndarray) -> np.ndarray:
        return np.concatenate(
            [(axis.measured - (1.0 + p[2]) * (axis.over_ground - axis.current_rows @ p[:2]))
             / effective for axis, (_, effective) in zip(axes, noise, strict=True)]
            + [p[:2] / CURRENT_PRIOR_STD_MPS, [p[2] / scale_std]]
        )  # fmt: skip

    solution = least_squares(weighted_residuals, np.append(first, 0.0), loss=huber_loss(threshold))
    covariance = np.linalg.inv(solution.jac.T @ solution.jac)
    return SpeedLogFit(
        current_ne=solution.x[:2].copy(),
        covariance=covariance[:2, :2].copy(),
        scale_error=float(solution.x[2]),
        scale_error_std=math.sqrt(covariance[2, 2]),
        samples=int(axes[0].measured.size),
        noise_mps=noise[0][0],
        transverse_samples=int(axes[1].measured.size) if len(axes) > 1 else 0,
        transverse_noise_mps=noise[1][0] if len(axes) > 1 else None,
    )


@dataclass(frozen=True)
class _SpeedLogAxis:
    """One axis of the speed logs for :func:`speed_log_current`: stw = (1 + k)(g − A c) + ε.

    ``measured`` the logged speeds, ``over_ground`` the smoothed body velocity g over the
    ground along the axis, ``current_rows`` A (the current's body component along the
    axis per (c_N, c_E)), ``ends`` where each log's samples end (all concatenated).
    """

    measured: np.ndarray
    over_ground: np.ndarray
    current_rows: np.ndarray
    ends: np.ndarray

    @classmethod
    def along(cls, parts: Sequence[tuple[ManeuverLog, SmoothedTrack]]) -> _SpeedLogAxis:
        """Return the longitudinal axis (``stw_mps``, u_g; c_u = c_N cos ψ + c_E sin ψ)."""
        return cls._of(
            [(log.stw_mps, track.u_mps, track.heading_rad) for log, track in parts],
            lambda h: np.column_stack([np.cos(h), np.sin(h)]),
        )

    @classmethod
    def across(cls, parts: Sequence[tuple[ManeuverLog, SmoothedTrack]]) -> _SpeedLogAxis:
        """Return the transverse axis (``stw_transverse_mps``, v_g + x_L r; c_v(ψ))."""
        columns = []
        for log, track in parts:
            if log.stw_transverse_mps is None:
                continue
            x_m = log.on_board_m("speed_log_x_m")
            if x_m is None:
                raise ValueError(f"{log.path or 'a log'}: stw_transverse_mps without speed_log_x_m")
            over_ground = np.asarray(track.v_mps) + x_m * np.asarray(track.r_radps)
            columns.append((log.stw_transverse_mps, over_ground, track.heading_rad))
        return cls._of(columns, lambda h: np.column_stack([-np.sin(h), np.cos(h)]))

    @classmethod
    def _of(
        cls,
        columns: Sequence[tuple[Any, Any, Any]],
        rows: Callable[[np.ndarray], np.ndarray],
    ) -> _SpeedLogAxis:
        """Concatenate (measured, over ground, heading) per log; ``rows`` gives A of ψ."""
        measured = [np.asarray(m, dtype=float) for m, _, _ in columns]
        return cls(
            measured=np.concatenate(measured),
            over_ground=np.concatenate([np.asarray(g, dtype=float) for _, g, _ in columns]),
            current_rows=np.concatenate([rows(np.asarray(h, dtype=float)) for _, _, h in columns]),
            ends=np.cumsum([m.size for m in measured])[:-1],
        )

    def noise(self, current_ne: np.ndarray) -> tuple[float, float]:
        """Return the residual's σ and its σ per effective sample at k = 0 [m/s]."""
        residual = self.over_ground - self.measured - self.current_rows @ current_ne
        sigma = float(median_abs_deviation(residual, scale="normal")) or 1e-6
        calm = np.abs(residual) <= SPEED_LOG_HUBER_SIGMAS * sigma
        lagged = lag_pairs = 0.0
        for e, ok in zip(np.split(residual, self.ends), np.split(calm, self.ends), strict=True):
            both = ok[:-1] & ok[1:]
            lagged += float(np.dot(e[:-1][both], e[1:][both]))
            lag_pairs += float(np.count_nonzero(both))
        rho = min(max(lagged / max(lag_pairs, 1.0) / sigma**2, 0.0), 0.99)
        return sigma, sigma * math.sqrt((1.0 + rho) / (1.0 - rho))


def huber_loss(threshold: np.ndarray) -> Callable[[np.ndarray], np.ndarray]:
    """Return a Huber loss for ``least_squares`` with a threshold per residual.

    ρ(z) of the squared residual z: z within threshold², 2t√z − t² beyond; with its first
    and second derivatives, as ``scipy.optimize.least_squares`` takes a callable loss.
    """
    square = threshold**2

    def loss(z: np.ndarray) -> np.ndarray:
        out = np.empty((3, z.size))
        beyond = z > square
        root = np.sqrt(np.where(beyond, z, 1.0))
        t = np.where(beyond, threshold, 0.0)
        out[0] = np.where(beyond, 2.0 * t * root - square, z)
        out[1] = np.where(beyond, t / root, 1.0)
        out[2] = np.where(beyond, -0.5 * t / root**3, 0.0)
        return out

    return loss


def current_model_form(current_ne: np.ndarray, alone: SpeedLogFit) -> np.ndarray:
    """Return the model-form term (2, 2) [m²/s²] of the EKF's current: ddᵀ, d = ĉ − ĉ_log.

    The EKF's covariance of the current holds the identification noise of the chosen
    structure only. Where the structure is not the ship's, the filter puts part of what
    the hull does not explain into the current, the same way in every noise draw: on the
    KVLCC2 reference (zig-zags in 0.5 and 1.0 m/s and a 10 m/s wind, five draws each) the
    error across the track is a steady 2–6 mm/s against a σ of 1.6 mm/s, and the error's
    eᵀC⁻¹e (χ²₂: 2 on average) is 2.2–15.8. What the speed log
    shows alone (:func:`speed_log_current`: the smoothed track and the log, no hull model)
    is an estimate of the same current that this error does not reach. Their distance d
    is taken as the model-form term, as the spread of the fit's alternative estimates is
    for the predictions (``scenarios.uncertainty.model_form``): a term measured on the
    data, added to the EKF's covariance (independent sources). With it the same runs
    give eᵀC⁻¹e 0.2–2.4 in eight of ten, 9.2 and 9.7 in the draw whose two estimates are
    wrong alike (``benchmarks/environment.md``, "The wind's sway-yaw coupling"; before
    that fix the same eight of ten, "The current's model-form term").
    """
    d = np.asarray(current_ne, dtype=float) - alone.current_ne
    return np.outer(d, d)


def speed_log_noise_mps(logs: Sequence[ManeuverLog], column: str = "stw_mps") -> float | None:
    """Return the σ per sample [m/s] of the speed logs' noise, as the EKF is to take it.

    Of the log's axis ``column`` (``stw_mps``, or a two-axis log's ``stw_transverse_mps``):
    from the logs themselves (every log with that column), by their second differences at
    the lags L of :data:`SPEED_LOG_NOISE_LAGS`, D_L = z(k + L) − 2z(k) + z(k − L): the
    ship's own speed hardly curves over a few samples (a 35° turn's speed loss is a few
    cm/s per second, its change of slope far less), a log's noise does. For a noise of
    variance σ² correlated as an AR(1) process of lag-one correlation ρ (a log that
    smooths its output), var(D_L) = 2σ²(1 − ρᴸ)(3 − ρᴸ): σ² and ρ are fitted to the logs'
    var(D_L) in logarithms (``scipy.optimize.least_squares``), ρ within [0,
    :data:`MAX_SPEED_LOG_CORRELATION`] (beyond, σ² again with ρ at the bound: noise that
    wanders that slowly is not told from the ship's own speed). The variances are robust
    ones (the median absolute deviation; the plain variance where a log's resolution makes
    most differences 0): spikes do not count. A lag of fewer than
    :data:`MIN_SPEED_LOG_DIFFERENCES` differences is not taken; with lag 1 alone the noise
    is taken as white. Returned is σ·√((1 + ρ)/(1 − ρ)), at least
    :data:`MIN_SPEED_LOG_NOISE_MPS`: correlated noise counts as fewer independent samples
    to a filter that takes it as white. (Checked on AR(1) noise of σ = 0.05 m/s over a
    turn's speed loss, 4,000 samples, eight seeds: ρ = 0 within 8 %, 0.5 within 10 %, 0.8
    and 0.9 within 30 % but for one seed each, 43 % and 2× too wide;
    ``tests/test_identify_at_sea.py``.) None when no log carries ``column``.
    """
    if column not in ("stw_mps", "stw_transverse_mps"):
        raise ValueError(f"column must be stw_mps or stw_transverse_mps, got {column!r}")
    usable = [getattr(log, column) for log in logs if getattr(log, column) is not None]
    if not usable:
        return None
    differences = {
        lag: np.concatenate([z[2 * lag :] - 2.0 * z[lag:-lag] + z[: -2 * lag] for z in usable])
        for lag in SPEED_LOG_NOISE_LAGS
    }
    # The lags the logs are long enough for (a short log: the white-noise σ of lag 1).
    taken = [lag for lag, d in differences.items() if d.size >= MIN_SPEED_LOG_DIFFERENCES]
    variances = np.array([_robust_variance(differences[lag]) for lag in taken])
    if not taken or not np.all(variances > 0.0):
        return MIN_SPEED_LOG_NOISE_MPS
    if len(taken) == 1:
        return max(math.sqrt(variances[0] / 6.0), MIN_SPEED_LOG_NOISE_MPS)
    lags = np.array(taken, dtype=float)

    def shape(rho: float) -> np.ndarray:  # var(D_L)/σ² of AR(1) noise
        return 2.0 * (1.0 - rho**lags) * (3.0 - rho**lags)

    def residuals(p: np.ndarray) -> np.ndarray:  # p = (ln σ², ρ)
        return p[0] + np.log(shape(float(p[1]))) - np.log(variances)

    high = MAX_SPEED_LOG_CORRELATION
    start = np.array([math.log(variances[0] / 6.0), 0.5 * high])
    rho = float(least_squares(residuals, start, bounds=([-np.inf, 0.0], [np.inf, high])).x[1])
    sigma2 = math.exp(float(np.mean(np.log(variances) - np.log(shape(rho)))))
    return max(math.sqrt(sigma2 * (1.0 + rho) / (1.0 - rho)), MIN_SPEED_LOG_NOISE_MPS)


def _robust_variance(values: np.ndarray) -> float:
    """Variance from the median absolute deviation, or the plain one where that is 0."""
    spread = float(median_abs_deviation(values, scale="normal"))
    return spread**2 if spread > 0.0 else float(np.var(values))


def water_segments(
    segments: Sequence[EkfSegment],
    tracks: Sequence[SmoothedTrack],
    current_ne: np.ndarray,
) -> list[EkfSegment]:
    """Return the segments with their smoothed (u, v) through the water.

    u_w = u − c_u(ψ), v_w = v − c_v(ψ) with the current's body components at the smoothed
    heading ψ of every sample; r, the logged track and the inputs are unchanged.
    ``current_ne`` (North, East) [m/s] is (2,) for every segment or (segments, 2), one each.
    """
    currents = np.broadcast_to(current_ne, (len(segments), 2))
    out = []
    for seg, track, current in zip(segments, tracks, currents, strict=True):
        heading = np.asarray(track.heading_rad)
        velocities = seg.velocities.copy()
        for start in range(0, heading.size, _CHUNK_SAMPLES):  # bounded temporaries
            part = slice(start, start + _CHUNK_SAMPLES)
            c_u, c_v = body_current(current, heading[part])
            velocities[part, 0] -= c_u
            velocities[part, 1] -= c_v
        out.append(replace(seg, velocities=velocities))
    return out


def water_frame(
    log: ManeuverLog, track: SmoothedTrack, current_ne: np.ndarray
) -> tuple[ManeuverLog, SmoothedTrack]:
    """Return a log and its smoothed track as seen from the water moving at ``current_ne``.

    Positions become x − c_N (t − t₀), y − c_E (t − t₀) (t₀ the first sample), the
    smoothed North and East rates lose c_N, c_E; heading, rudder, rpm, noise levels and
    variances are unchanged (the current is taken as known).
    """
    elapsed = log.time_s - log.time_s[0]
    c_n, c_e = float(current_ne[0]), float(current_ne[1])
    states = track.states.copy()
    states[0, :, 0] -= c_n * elapsed
    states[0, :, 1] -= c_n
    states[1, :, 0] -= c_e * elapsed
    states[1, :, 1] -= c_e
    moved = replace(log, x_m=log.x_m - c_n * elapsed, y_m=log.y_m - c_e * elapsed)
    return moved, replace(track, states=states)


def heading_span_rad(tracks: Sequence[SmoothedTrack]) -> float:
    """Range of the smoothed headings of all logs about their circular mean [rad] (< 2π)."""
    sin_sum = sum(float(np.sum(np.sin(t.heading_rad))) for t in tracks)
    cos_sum = sum(float(np.sum(np.cos(t.heading_rad))) for t in tracks)
    mean = math.atan2(sin_sum, cos_sum)
    low, high = math.inf, -math.inf
    for track in tracks:  # one log at a time: a long log's temporaries stay few
        deviation = np.remainder(np.asarray(track.heading_rad) - mean + math.pi, 2.0 * math.pi)
        low, high = min(low, float(np.min(deviation))), max(high, float(np.max(deviation)))
    return high - low
