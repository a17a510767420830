"""Augmented-state extended Kalman filter identification (Shi et al. 2009, section 3).

The motion state s = (u, v, r, x, y, ψ) is augmented with the model coefficients θ,
which follow a random walk. The model is discretised by forward Euler (eq. (4)) with
the inputs averaged over each step, s̄ = (s(k) + s(k+1))/2, optionally split into
shorter substeps:

    s(k+1) = s(k) + T f(s(k), s̄(k); θ(k)) + w_s,     θ(k+1) = θ(k) + w_θ,

and the EKF of eq. (5):

    x⁻ = f*(x),  P⁻ = Φ P Φᵀ + Q,  Φ = ∂f*/∂x = [[∂s⁺/∂s, ∂s⁺/∂θ], [0, I]]
    K = P⁻ Hᵀ (H P⁻ Hᵀ + R)⁻¹,  x = x⁻ + K (y − H x⁻),  P = P⁻ − K H P⁻.

Two measurement choices, both with H selecting three states:

* ``"velocities"`` — the paper's: y = smoothed (u, v, r), H = [I₃ 0 0];
* ``"track"`` — y = the logged (x, y, ψ) themselves, H = [0 I₃ 0], R from the logger's
  noise. The model then does the smoothing: no lag of a kinematic smoother enters the
  coefficients, and the measurement noise really is white, so the covariance is honest.

∂f/∂s and ∂f/∂θ are the analytic Jacobians generated from ``fmu_model``'s structure
(``fmu_model.kernels``, compiled once per structure and cached on disk). Only the six
motion rows of Φ differ from the identity, so the prediction updates only those rows and
columns of P, and the update needs only a 3 × 3 innovation covariance (explicit
Cholesky).

With a current estimated, a speed log (``EkfSegment.speed_log_mps``) is a fourth,
scalar measurement: stw = (1 + k) u + ε, u through the water, with the log's scale error k
one more augmented state (:class:`SpeedLogMeasurement`), updated after the track's
(sequential updates: the two noises are independent); a two-axis log's transverse axis
(``EkfSegment.speed_log_transverse_mps``) a fifth, (1 + k)(v + x_L r) + ε' at the log's
position x_L forward of midship, with the same k (one log, one calibration: a Doppler
log's is the speed of sound in the water). An innovation beyond
:data:`SPEED_LOG_GATE_NIS` is a spike or a drop-out, not taken.

Several logs are processed in one identification: the motion states restart at each
log's first (smoothed) sample, θ and its covariance carry over.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numba
import numpy as np

from fmu_model import ModelStructure, numeric_model
from fmu_model.kernels import Binding, kernel_constants, kernel_module
from identifier.smoothing import GATE_NIS_HEADING
from trials.errors import IdentificationError

MEASUREMENTS = ("track", "velocities")

SPEED_LOG_GATE_NIS = GATE_NIS_HEADING
"""A speed-log sample whose innovation squared exceeds this many times its variance
(χ²₁ at the smoother's false-alarm probability, ``identifier.smoothing``: 6.1 σ) is not
taken: a log's spike or drop-out, not the ship's speed."""

#: Samples of a log the compiled pass runs at a time (rounded up to a whole number of
#: history strides), so that ``progress`` hears from a long log while it runs.
EKF_CHUNK_SAMPLES = 50_000


@dataclass(frozen=True)
class EkfSegment:
    """One manoeuvre prepared for the EKF.

    Parameters
    ----------
    name : str
        Log name for messages and provenance.
    time_s : numpy.ndarray
        Sample times [s], strictly increasing, shape (N,).
    velocities : numpy.ndarray
        Smoothed (u [m/s], v [m/s], r [rad/s]), shape (N, 3).
    velocity_std : numpy.ndarray
        Their standard deviations, shape (N, 3); with ``measurements="track"`` only
        those at the start are used (the velocities' initial covariance).
    track : numpy.ndarray
        Logged (x [m], y [m], ψ [rad], continuous), shape (N, 3).
    track_std : numpy.ndarray
        Logger noise of (x, y, ψ), shape (3,).
    initial_track : numpy.ndarray
        Smoothed (x, y, ψ) at the first sample, shape (3,).
    rudder_rad : numpy.ndarray
        Rudder angle [rad], shape (N,).
    n_rps : numpy.ndarray
        Propeller speed [rev/s], shape (N,).
    known_acceleration : numpy.ndarray, optional
        Accelerations (u̇ [m/s²], v̇ [m/s²], ṙ [rad/s²]) of known external loads (a
        measured wind's, ``identifier.wind``), shape (N, 3), added to the model's, so
        that the coefficients are the ship's alone; None: none.
    speed_log_mps : numpy.ndarray, optional
        Logged speed through the water along the ship [m/s], shape (N,) (a measurement
        when :func:`ekf_identify` is given a :class:`SpeedLogMeasurement`); None: none.
    speed_log_transverse_mps : numpy.ndarray, optional
        The same log's speed through the water across the ship, positive to starboard
        [m/s], shape (N,) (a two-axis log; measured with ``speed_log_mps``); None: none.
    speed_log_x_m : float
        The log's position forward of midship [m], where it measures v + x_L r.
    current_gap_s : float
        Time since the previous segment's last sample [s], over which a drifting current
        walks before this one (``EkfSettings.current_random_walk_mps``); 0: none known.

    """

    name: str
    time_s: np.ndarray
    velocities: np.ndarray
    velocity_std: np.ndarray
    track: np.ndarray
    track_std: np.ndarray
    initial_track: np.ndarray
    rudder_rad: np.ndarray
    n_rps: np.ndarray
    known_acceleration: np.ndarray | None = None
    speed_log_mps: np.ndarray | None = None
    speed_log_transverse_mps: np.ndarray | None = None
    speed_log_x_m: float = 0.0
    current_gap_s: float = 0.0

    def known_acceleration_or_zero(self) -> np.ndarray:
        """Return the known accelerations (N, 3), or one row of zeros (1, 3) for none.

        (The EKF pass reads its last row for every later sample, as it does ``r_var``'s.)
        """
        if self.known_acceleration is None:
            return np.zeros((1, 3))
        return np.ascontiguousarray(self.known_acceleration, dtype=float)

    def window(self, start: int, stop: int) -> EkfSegment:
        """Return samples ``start`` to ``stop`` (exclusive) as a segment of their own.

        Its first (x, y, ψ) is the logged one at ``start`` (the smoothed one only at 0).
        """
        if not 0 <= start < stop <= self.time_s.size:
            raise ValueError(f"window {start}:{stop} outside the segment's {self.time_s.size}")
        part = slice(start, stop)
        return EkfSegment(
            name=self.name,
            time_s=self.time_s[part],
            velocities=self.velocities[part],
            velocity_std=self.velocity_std[part],
            track=self.track[part],
            track_std=self.track_std,
            initial_track=self.initial_track if start == 0 else self.track[start].copy(),
            rudder_rad=self.rudder_rad[part],
            n_rps=self.n_rps[part],
            known_acceleration=None
            if self.known_acceleration is None
            else self.known_acceleration[part],
            speed_log_mps=None if self.speed_log_mps is None else self.speed_log_mps[part],
            speed_log_transverse_mps=None
            if self.speed_log_transverse_mps is None
            else self.speed_log_transverse_mps[part],
            speed_log_x_m=self.speed_log_x_m,
        )

    def speed_log_or_none(self) -> np.ndarray:
        """Return the speed log's axes (N, 2) [m/s], NaN for an axis it has not.

        One row of NaN (1, 2) without a speed log: the EKF pass measures none.
        """
        if self.speed_log_mps is None:
            return np.full((1, 2), np.nan)
        transverse = self.speed_log_transverse_mps
        return np.column_stack(
            [self.speed_log_mps, np.full_like(self.speed_log_mps, np.nan)
             if transverse is None else transverse]
        )  # fmt: skip


def sample_windows(
    segments: Sequence[EkfSegment], max_samples: int, windows: int
) -> list[tuple[int, EkfSegment]]:
    """Return at most about ``max_samples`` samples of ``segments`` in evenly spread windows.

    The segments as they are when they hold no more; else ``windows`` windows of equal
    length, their starts spread evenly over all the samples (each within one segment),
    so that a long log's every part has its say. Each with the index of the segment it
    is of. For work that only has to settle a start (``identifier.identify``: the
    current's alternation), not for the estimate.
    """
    sizes = [seg.time_s.size for seg in segments]
    total = sum(sizes)
    if total <= max_samples:
        return list(enumerate(segments))
    length = max(max_samples // windows, 2)
    ends = np.cumsum(sizes)
    result = []
    for start in np.linspace(0, total - length, windows).astype(int):
        i = int(np.searchsorted(ends, start, side="right"))
        local = int(start - (ends[i] - sizes[i]))
        local = min(local, max(sizes[i] - length, 0))
        result.append((i, segments[i].window(local, min(local + length, sizes[i]))))
    return result


@dataclass(frozen=True)
class EkfSettings:
    """Tuning of the augmented-state EKF.

    Parameters
    ----------
    state_process_std : tuple of float
        Model-error standard deviation of (u̇, v̇, ṙ) [m/s², m/s², rad/s²], as an
        average over ``process_noise_interval_s``; the process noise of the motion
        states over a step of T seconds is std² · T · max(T, that interval).
    process_noise_interval_s : float
        Δ, the interval over which ``state_process_std`` was measured (the equation-error
        residual's, ``EquationErrorFit.sample_interval_s``) [s]. Over steps shorter than Δ
        the model error is a white noise of intensity std² · Δ, so that the filter allows
        the same model error per second at any logging rate (with (T · std)² per step,
        10 Hz logs would allow a tenth of what 1 Hz logs do, and the estimate drifts
        with the rate: benchmarks/sensitivity.md, "The EKF per second"). 0: (T · std)²
        for every step, and ``param_random_walk`` per step.
    param_random_walk : float
        ρ, the relative random walk of θ over a step of ``process_noise_interval_s``
        (or over any longer step): Q_θ = diag((ρ σ_θ0)²) · T / max(T, that interval)
        over a step of T, σ_θ0 the initial standard deviations, so that the filter
        forgets as fast per second at any logging rate. 0 gives constant parameters.
    divergence_factor : float
        Divergence is declared when a parameter variance grows above this factor
        times its initial value.
    measurements : {"track", "velocities"}
        What the filter measures (module docstring); "velocities" is the paper's.
    max_substep_s : float
        Largest forward-Euler substep [s]; each sample interval is split into equal
        substeps no longer than this. ``math.inf`` gives one step per interval, the
        paper's discretisation, eq. (4), whose O(T) bias at T = 1 s and yaw time
        constants of 10–20 s reaches several per cent on the coefficients.
    max_history_rows : int
        Most rows of the histories kept in ``EkfResult`` (see there).
    current_random_walk_mps : float
        Random walk of each current component in an hour [m/s] (a drifting current,
        Q_c = σ² T / 3600 s per step of T seconds); 0 keeps an estimated current constant.
        Used only when :func:`ekf_identify` estimates a current.

    """

    state_process_std: tuple[float, float, float] = (1e-3, 1e-3, 1e-5)
    process_noise_interval_s: float = 0.0
    param_random_walk: float = 1e-4
    divergence_factor: float = 1e6
    measurements: str = "track"
    max_substep_s: float = 0.1
    max_history_rows: int = 10_000
    current_random_walk_mps: float = 0.0


@dataclass(frozen=True)
class SpeedLogMeasurement:
    """A speed log as a measurement of the EKF: stw = (1 + k) u + ε (and (1 + k) v + ε').

    Parameters
    ----------
    noise_std_mps : float
        Standard deviation of ε per sample [m/s] (a white noise's; a log whose noise is
        correlated from sample to sample inflated to count as fewer samples,
        ``identifier.current.speed_log_noise_mps``).
    scale_error_std : float
        Prior standard deviation of the scale error k (mean 0) [-].
    transverse_noise_std_mps : float, optional
        Standard deviation of ε' per sample [m/s], of a two-axis log's transverse axis (as
        ``noise_std_mps``); None: the segments' logs have no transverse axis.

    """

    noise_std_mps: float
    scale_error_std: float
    transverse_noise_std_mps: float | None = None


@dataclass(frozen=True)
class EkfResult:
    """Output of :func:`ekf_identify`.

    The histories are kept at every ``history_stride``-th sample of each segment
    (samples 0, s, 2s, … of it), the stride the smallest that keeps them within
    ``EkfSettings.max_history_rows`` rows in all: every sample for logs of up to that
    many samples, and bounded memory however long the logs are. ``theta_history`` and
    ``std_history`` hold θ and its standard deviations after those updates, all segments
    concatenated (shape (M, p)); ``segment_ends`` are the indices in those arrays where
    each segment ends. ``filtered`` are the filtered motion states (u, v, r, x, y, ψ) at
    the same samples, one (M_i, 6) array per segment. ``track_rms`` is, per segment and
    over every sample, the RMS of the filtered minus the logged position [m] and heading
    (wrapped) [rad]. With a speed log: its scale error k and standard deviation [-], and
    the samples taken and rejected by the gate (:data:`SPEED_LOG_GATE_NIS`), of its
    longitudinal axis and of its transverse axis.
    """

    theta: np.ndarray
    covariance: np.ndarray
    theta_history: np.ndarray
    std_history: np.ndarray
    segment_ends: tuple[int, ...]
    filtered: tuple[np.ndarray, ...]
    history_stride: int
    track_rms: tuple[tuple[float, float], ...]
    current: np.ndarray | None = None  # (2,), or (segments, 2) with a current per segment
    current_covariance: np.ndarray | None = None  # (2, 2), or (segments, 2, 2)
    speed_log_scale_error: float | None = None
    speed_log_scale_error_std: float | None = None
    speed_log_samples: tuple[int, int] = (0, 0)  # (taken, rejected)
    speed_log_transverse_samples: tuple[int, int] = (0, 0)


def ekf_identify(
    structure: ModelStructure,
    segments: Sequence[EkfSegment],
    theta0: np.ndarray,
    covariance0: np.ndarray,
    length_m: float,
    settings: EkfSettings | None = None,
    progress: Callable[[int], None] | None = None,
    current0: np.ndarray | None = None,
    current_covariance0: np.ndarray | None = None,
    speed_log: SpeedLogMeasurement | None = None,
) -> EkfResult:
    """Identify the coefficients θ of ``structure`` with the augmented-state EKF.

    With ``current0`` the state is augmented further by a uniform current c = (c_N, c_E)
    [m/s] that moves the ship over the ground (ẋ = u cos ψ − v sin ψ + c_N, ẏ = u sin ψ +
    v cos ψ + c_E), constant or a random walk (``settings.current_random_walk_mps``); u, v
    and the coefficients are then through the water. Given as one (2,), it carries over
    between the logs like θ (one sea area, one current); given one row per segment
    ((segments, 2)), each segment has a current of its own, independent of the others
    (runs sailed at other times of the tide): c restarts at each segment from its row and
    ``current_covariance0``, uncorrelated with θ, and its estimate is kept at the
    segment's end. Only with ``measurements="track"``: the smoothed velocities of
    ``"velocities"`` are over the ground.

    Parameters
    ----------
    structure : ModelStructure
        The model structure.
    segments : sequence of EkfSegment
        The manoeuvres, processed in order.
    theta0 : numpy.ndarray
        Initial coefficients (p,).
    covariance0 : numpy.ndarray
        Initial coefficient covariance (p, p).
    length_m : float
        Ship length [m] (used by structures in non-dimensional form).
    settings : EkfSettings, optional
        Tuning; defaults when omitted.
    progress : callable, optional
        Called with the number of samples processed since the last call.
    current0 : numpy.ndarray, optional
        Initial current (North, East) [m/s], (2,) for all segments or (segments, 2) one
        per segment; None estimates no current.
    current_covariance0 : numpy.ndarray, optional
        Its covariance (2, 2) [m²/s²] (of each segment's); required with ``current0``.
    speed_log : SpeedLogMeasurement, optional
        Measure the segments' ``speed_log_mps`` (those that have one; and their
        ``speed_log_transverse_mps``) with the scale error k as one more state after the
        current (module docstring); only with ``current0``.

    Raises
    ------
    IdentificationError
        On a non-finite state or covariance, a covariance that loses positive
        definiteness, or one that grows beyond ``divergence_factor``; the error names the
        segment and the sample.

    """
    settings = settings or EkfSettings()
    if settings.measurements not in MEASUREMENTS:
        raise ValueError(f"measurements must be one of {MEASUREMENTS}")
    model = numeric_model(structure)
    ekf_pass = kernel_module(structure, (_EKF_PASS,)).ekf_pass
    constants = kernel_constants(structure, length_m)
    eq_index = np.asarray(model.structure.equation_index, dtype=np.int64)
    p = model.n_coefficients
    theta = np.array(theta0, dtype=float)
    P_theta = np.array(covariance0, dtype=float)
    if theta.shape != (p,) or P_theta.shape != (p, p):
        raise ValueError(f"theta0/covariance0 must have shapes ({p},) and ({p}, {p})")
    with np.errstate(over="ignore"):  # an infinite Q or limit: the pass reports divergence
        q_theta = (settings.param_random_walk * np.sqrt(np.diag(P_theta))) ** 2
        variance_limit = settings.divergence_factor * np.maximum(np.diag(P_theta), 1e-300)
    block, current_rows, speed_log_var = _augment(
        _Augmented(theta, P_theta, q_theta, variance_limit),
        segments, settings, current0, current_covariance0, speed_log,
    )  # fmt: skip
    estimated_current = current_rows is not None
    # One current per segment: its rows, else None.
    per_segment = current_rows if current_rows is not None and current_rows.ndim == 2 else None
    theta, P_theta, q_theta, variance_limit = block
    n_total = sum(seg.time_s.size for seg in segments)
    stride = max(1, -(-n_total // max(settings.max_history_rows, 1)))
    rows = [-(-seg.time_s.size // stride) for seg in segments]
    theta_hist = np.empty((sum(rows), p))
    std_hist = np.empty((sum(rows), p))
    # Model error enters the accelerations; the kinematics are exact.
    q_state = np.concatenate(
        [np.asarray(settings.state_process_std, dtype=float) ** 2, np.zeros(3)]
    )
    ekf = _Pass(
        ekf_pass, eq_index, constants, settings, 3 if settings.measurements == "track" else 0,
        speed_log_var, q_state, q_theta, variance_limit, stride,
    )  # fmt: skip
    speed_log_counts = np.zeros(4, dtype=np.int64)  # taken, rejected of each axis
    ends: list[int] = []
    filtered: list[np.ndarray] = []
    track_rms: list[tuple[float, float]] = []
    segment_currents: list[tuple[np.ndarray, np.ndarray]] = []  # per segment: c, its P
    row = 0
    for index, seg in enumerate(segments):
        n = seg.time_s.size
        if per_segment is not None:
            # this run's own current, from its prior, uncorrelated with θ and k
            P_theta[p : p + 2, :] = 0.0
            P_theta[:, p : p + 2] = 0.0
            P_theta[p : p + 2, p : p + 2] = current_covariance0
            theta[p : p + 2] = per_segment[index]
        elif estimated_current:  # a drifting current walks between the runs too
            walk = settings.current_random_walk_mps**2 * seg.current_gap_s / 3600.0
            P_theta[p : p + 2, p : p + 2] += walk * np.eye(2)
        x, P = _segment_start(seg, theta, P_theta, p if estimated_current else None)
        states = np.empty((rows[index], 6))
        histories = (states, theta_hist[row : row + states.shape[0]],
                     std_hist[row : row + states.shape[0]])  # fmt: skip
        square_sums = ekf.run(
            seg, x, P, histories, speed_log is not None, speed_log_counts, progress
        )
        theta = x[6:].copy()
        P_theta = 0.5 * (P[6:, 6:] + P[6:, 6:].T)
        try:
            np.linalg.cholesky(P_theta)
        except np.linalg.LinAlgError:
            raise IdentificationError(
                "parameter covariance is not positive definite at the end of the log",
                log=seg.name,
                sample=n - 1,
            ) from None
        if estimated_current:
            segment_currents.append((theta[p : p + 2].copy(), P_theta[p : p + 2, p : p + 2].copy()))
        row += states.shape[0]
        ends.append(row)
        filtered.append(states)
        track_rms.append((float(np.sqrt(square_sums[0] / n)), float(np.sqrt(square_sums[1] / n))))
    scale = p + 2  # k's index in θ's augmented block, with a speed log
    current = current_covariance = None
    if per_segment is not None:
        current = np.array([c for c, _ in segment_currents])
        current_covariance = np.array([cov for _, cov in segment_currents])
    elif estimated_current:
        current, current_covariance = theta[p : p + 2], P_theta[p : p + 2, p : p + 2]
    return EkfResult(
        theta=theta[:p],
        covariance=P_theta[:p, :p],
        theta_history=theta_hist,
        std_history=std_hist,
        segment_ends=tuple(ends),
        filtered=tuple(filtered),
        history_stride=stride,
        track_rms=tuple(track_rms),
        current=current,
        current_covariance=current_covariance,
        speed_log_scale_error=None if speed_log is None else float(theta[scale]),
        speed_log_scale_error_std=None
        if speed_log is None
        else math.sqrt(float(P_theta[scale, scale])),
        speed_log_samples=(int(speed_log_counts[0]), int(speed_log_counts[1])),
        speed_log_transverse_samples=(int(speed_log_counts[2]), int(speed_log_counts[3])),
    )


def _augment(
    block: _Augmented,
    segments: Sequence[EkfSegment],
    settings: EkfSettings,
    current0: np.ndarray | None,
    current_covariance0: np.ndarray | None,
    speed_log: SpeedLogMeasurement | None,
) -> tuple[_Augmented, np.ndarray | None, np.ndarray]:
    """Return θ's block augmented by the current and the speed log's scale error.

    (:func:`ekf_identify`'s arguments, checked.) Also returns the current's rows
    (``current0`` as an array; None without a current) and the variances of the speed
    log's two axes (zeros without one).
    """
    current_rows = None
    if current0 is not None:
        if settings.measurements != "track":
            raise ValueError('a current is estimated only with measurements="track"')
        if current_covariance0 is None or np.shape(current_covariance0) != (2, 2):
            raise ValueError("current_covariance0 must have shape (2, 2)")
        current_rows = np.asarray(current0, dtype=float)
        if current_rows.shape not in ((2,), (len(segments), 2)):
            raise ValueError(f"current0 must have shape (2,) or ({len(segments)}, 2)")
        # θ and c are one augmented block: they carry over together, correlations too.
        interval_s = float(np.median(np.concatenate([np.diff(s.time_s) for s in segments])))
        block = block.augmented(
            current_rows[0] if current_rows.ndim == 2 else current_rows,
            np.asarray(current_covariance0),
            settings.current_random_walk_mps**2 * interval_s / 3600.0,
            settings.divergence_factor,
        )
    speed_log_var = np.zeros(2)  # of the two axes
    if speed_log is not None:
        if current_rows is None:
            raise ValueError("a speed log is measured only with a current estimated")
        # k follows c in the augmented block, constant, from its prior N(0, σ_k²).
        k_var = speed_log.scale_error_std**2
        block = block.augmented(np.zeros(1), np.array([[k_var]]), 0.0, settings.divergence_factor)
        transverse_std = speed_log.transverse_noise_std_mps
        if transverse_std is None and any(
            seg.speed_log_transverse_mps is not None for seg in segments
        ):
            raise ValueError("a transverse speed-log axis needs transverse_noise_std_mps")
        speed_log_var[:] = speed_log.noise_std_mps**2, (transverse_std or 0.0) ** 2
    return block, current_rows, speed_log_var


class _Pass(NamedTuple):
    """What every segment's pass of the compiled EKF shares: kernel, settings, noise."""

    kernel: Callable[..., tuple[int, int]]
    eq_index: np.ndarray
    constants: np.ndarray
    settings: EkfSettings
    offset: int  # the measured states: 3 (x, y, ψ) or 0 (u, v, r)
    speed_log_var: np.ndarray
    q_state: np.ndarray
    q_theta: np.ndarray
    variance_limit: np.ndarray
    stride: int

    def run(
        self,
        seg: EkfSegment,
        x: np.ndarray,
        P: np.ndarray,
        histories: tuple[np.ndarray, np.ndarray, np.ndarray],
        with_speed_log: bool,
        speed_log_counts: np.ndarray,
        progress: Callable[[int], None] | None,
    ) -> np.ndarray:
        """Filter ``seg`` in place on x, P and ``histories``; return its track's square sums.

        In chunks [a, b] of whole strides, each starting at the previous one's last
        sample: the pass carries x and P on, so the filter is the same as in one pass;
        the history row of a chunk's first sample is written again with the same values,
        and its track residual, added again, is taken back out. An input of one row
        stands for every sample (R with track measurements, no known loads, no speed
        log): not cut.
        """
        n = seg.time_s.size
        track = np.ascontiguousarray(seg.track, dtype=float)
        inputs = _pass_inputs(seg, track, self.offset, with_speed_log)
        square_sums = np.zeros(2)
        stride = self.stride
        chunk = -(-EKF_CHUNK_SAMPLES // stride) * stride
        for a in range(0, max(n - 1, 1), chunk):
            b = min(a + chunk, n - 1)
            repeated = np.zeros(2)
            if a > 0:
                _add_track_residual(x, track, a, repeated)
            part, rows_part = slice(a, b + 1), slice(a // stride, b // stride + 1)
            status, sample = _run_pass(
                self.kernel, seg.name, self.eq_index, self.constants,
                self.settings.max_substep_s, self.settings.process_noise_interval_s,
                self.offset, *(v if v.shape[0] == 1 else v[part] for v in inputs),
                self.speed_log_var, seg.speed_log_x_m, x, P, self.q_state, self.q_theta,
                self.variance_limit, stride, track[part], *(h[rows_part] for h in histories),
                square_sums, speed_log_counts,
            )  # fmt: skip
            if status != _OK:
                raise IdentificationError(
                    _STATUS_MESSAGES[status], log=seg.name, sample=a + int(sample)
                )
            square_sums -= repeated
            if progress is not None:
                progress(b - a + int(a == 0))  # every sample once
        return square_sums


def _segment_start(
    seg: EkfSegment, theta: np.ndarray, P_theta: np.ndarray, current_at: int | None
) -> tuple[np.ndarray, np.ndarray]:
    """Return the filter's state and covariance at a segment's first sample.

    The motion states restart at the segment's first smoothed sample (through the water:
    less the current's body components, the current at ``current_at`` in θ's augmented
    block, None without one); θ (and c, k) carry over with ``P_theta``.
    """
    velocities0 = seg.velocities[0].copy()
    velocity_var0 = seg.velocity_std[0] ** 2
    if current_at is not None:
        c = slice(current_at, current_at + 2)
        velocities0[:2] -= body_current(theta[c], seg.initial_track[2])
        velocity_var0[:2] += np.trace(P_theta[c, c])
    x = np.concatenate([velocities0, seg.initial_track, theta])
    P = np.zeros((6 + theta.size, 6 + theta.size))
    P[:3, :3] = np.diag(velocity_var0)
    P[3:6, 3:6] = np.diag(seg.track_std**2)
    P[6:, 6:] = P_theta
    return x, P


def _pass_inputs(
    seg: EkfSegment, track: np.ndarray, offset: int, with_speed_log: bool
) -> tuple[np.ndarray, ...]:
    """Return the pass's per-sample arguments: t, y, R, δ, n, known loads, speed log.

    ``offset`` 3: the filter measures the track (``track``, one row of R for every
    sample); 0: the smoothed velocities with their variances. An input of one row stands
    for every sample (R of the track, no known loads, no speed log: one row of NaN).
    """
    if offset == 3:
        y, r_var = track, (seg.track_std**2)[None, :]
    else:
        y, r_var = seg.velocities, seg.velocity_std**2
    measured_speed = (
        np.ascontiguousarray(seg.speed_log_or_none(), dtype=float)
        if with_speed_log
        else np.full((1, 2), np.nan)
    )
    return (
        np.ascontiguousarray(seg.time_s, dtype=float),
        np.ascontiguousarray(y, dtype=float),
        np.ascontiguousarray(r_var, dtype=float),
        np.ascontiguousarray(seg.rudder_rad, dtype=float),
        np.ascontiguousarray(seg.n_rps, dtype=float),
        seg.known_acceleration_or_zero(),
        measured_speed,
    )


class _Augmented(NamedTuple):
    """The EKF's augmented parameter block: θ and what follows it (a current, a scale error).

    Its mean, covariance, random-walk variance per step and divergence limits of the
    variances, each over the whole block.
    """

    mean: np.ndarray
    covariance: np.ndarray
    walk_variance: np.ndarray
    variance_limit: np.ndarray

    def augmented(
        self, mean: np.ndarray, covariance: np.ndarray, walk_variance: float, factor: float
    ) -> _Augmented:
        """Append states of prior ``mean`` and ``covariance`` (uncorrelated with the block).

        Each walks by ``walk_variance`` per step; its variance may grow ``factor`` times.
        """
        n, m = self.mean.size, mean.size
        return _Augmented(
            np.concatenate([self.mean, mean]),
            np.block([[self.covariance, np.zeros((n, m))], [np.zeros((m, n)), covariance]]),
            np.concatenate([self.walk_variance, np.full(m, walk_variance)]),
            np.concatenate([self.variance_limit, factor * np.diag(covariance)]),
        )


def body_current(current_ne: np.ndarray, heading_rad: np.ndarray | float) -> np.ndarray:
    """Body-frame components (forward, starboard) of a current (North, East) [m/s].

    c_u = c_N cos ψ + c_E sin ψ,  c_v = −c_N sin ψ + c_E cos ψ, so that the velocities
    through the water are (u − c_u, v − c_v) of those over the ground.
    """
    c_n, c_e = current_ne[0], current_ne[1]
    cos_psi, sin_psi = np.cos(heading_rad), np.sin(heading_rad)
    return np.array([c_n * cos_psi + c_e * sin_psi, -c_n * sin_psi + c_e * cos_psi])


def _run_pass(ekf_pass: Callable[..., tuple[int, int]], name: str, *args: Any) -> tuple[int, int]:
    """Call the compiled ``ekf_pass``; a division by zero is a data error of the log ``name``."""
    try:
        return ekf_pass(*args)
    except ZeroDivisionError:  # numba's scalar division, e.g. by a speed of exactly 0
        raise IdentificationError(
            "the model divides by zero: the ship's speed through the water reached 0 "
            "(the speed-scaled models need headway throughout the log)",
            log=name,
        ) from None


_OK, _NONFINITE, _NOT_PD, _EXPLODED = 0, 1, 2, 3
_STATUS_MESSAGES = {
    _NONFINITE: "state or covariance became non-finite (EKF diverged)",
    _NOT_PD: "innovation covariance is not positive definite (EKF diverged)",
    _EXPLODED: (
        "parameter covariance lost positive definiteness or exploded "
        "(EKF diverged; try a smaller --param-random-walk or better logs)"
    ),
}


# A template in numba's subset: compiled, and cached on disk, per structure with its
# kernels bound (_EKF_PASS, fmu_model.kernels).
def _ekf_pass(
    phi_fn, grad_fn, kin_fn, kin_grad_fn, eq_index, constants, max_substep, q_interval,
    offset, t, y, r_var, rudder, n_rps, known, speed_log, speed_log_var, speed_log_x, x, P,
    q_state, q_theta, variance_limit, stride, track, states, theta_hist, std_hist,
    square_sums, speed_log_counts,
):  # fmt: skip
    """One segment of the EKF, eq. (4)-(5), in place on x and P; returns (status, sample).

    x = (u, v, r, x, y, ψ, θ, c, k): c the current (North, East) [m/s] when ``q_theta``
    is longer than θ by two or more (it moves the ship over the ground: ẋ += c_N,
    ẏ += c_E), else none; k a speed log's scale error when longer by three; the
    measurement is states offset … offset+2, with the
    variances of row k of ``r_var`` (its only row when it has one), then with k the
    speed log ``speed_log`` (N, 2: its longitudinal and transverse axes, NaN where it has
    none; one row: none) of variances ``speed_log_var`` (2,), the transverse one at
    ``speed_log_x`` [m] forward of midship, gated by :data:`SPEED_LOG_GATE_NIS`
    (``speed_log_counts`` += taken, rejected of each axis); the motion states' process
    noise over a step of T is ``q_state`` · T · max(T, ``q_interval``), θ's
    ``q_theta`` · T / max(T, ``q_interval``) (a current's ``q_theta`` per step). The
    motion states and θ with its standard deviations after the updates at samples 0,
    stride, … go to ``states``, ``theta_hist`` and ``std_hist``; ``known`` (N, 3) are
    accelerations of known loads added to the model's (one row: the same for every sample);
    ``square_sums`` accumulates the squared filtered-minus-logged position [m²] and
    wrapped heading [rad²] over every sample.
    """
    p = eq_index.size
    m = 6 + q_theta.size
    current = q_theta.size > p
    scale = 6 + p + 2 if q_theta.size > p + 2 else -1  # k's index in x, or none
    last_speed = speed_log.shape[0] - 1
    phi = np.empty(p)
    grad = np.empty(3 * p)
    kin = np.empty(3)
    kin_grad = np.empty(3 * 6)
    F = np.zeros((6, m))  # motion rows of Φ; θ rows are [0 I]
    A = np.empty((6, 6))  # I + h ∂f/∂s of one substep
    f = np.empty(6)
    G = np.empty((6, m))  # motion rows of Φ P
    K = np.empty((m, 3))
    PH = np.empty((m, 3))
    o = offset
    states[0, :] = x[:6]
    for i in range(p):
        theta_hist[0, i] = x[6 + i]
        std_hist[0, i] = np.sqrt(P[6 + i, 6 + i])
    _add_track_residual(x, track, 0, square_sums)
    last_row = r_var.shape[0] - 1
    last_known = known.shape[0] - 1
    for k in range(t.size - 1):
        T = t[k + 1] - t[k]
        substeps = max(1, int(np.ceil(T / max_substep * (1.0 - 1e-12))))
        h = T / substeps
        # Φ motion rows start as [I 0] and accumulate the Euler substeps:
        # F ← (I + h ∂f/∂s) F + [0, h ∂f/∂θ].
        F[:, :] = 0.0
        for c in range(6):
            F[c, c] = 1.0
        for j in range(substeps):
            # Inputs averaged over the substep (linear between samples); with one
            # substep this is the paper's s̄(k) = (s(k) + s(k+1)) / 2, eq. (4).
            w = (j + 0.5) / substeps
            d_mean = (1.0 - w) * rudder[k] + w * rudder[k + 1]
            n_mean = (1.0 - w) * n_rps[k] + w * n_rps[k + 1]
            phi_fn(x[0], x[1], x[2], d_mean, n_mean, constants, phi)
            grad_fn(x[0], x[1], x[2], d_mean, n_mean, constants, grad)
            kin_fn(x[0], x[1], x[2], x[5], kin)
            kin_grad_fn(x[0], x[1], x[2], x[5], kin_grad)
            A[:, :] = 0.0
            f[:] = 0.0
            for c in range(3):  # known loads (a measured wind's), averaged as the inputs
                f[c] = (1.0 - w) * known[min(k, last_known), c] + w * known[
                    min(k + 1, last_known), c
                ]
            for i in range(p):
                e = eq_index[i]
                th = x[6 + i]
                f[e] += th * phi[i]
                for c in range(3):
                    A[e, c] += h * th * grad[3 * i + c]
            for c in range(3):
                f[3 + c] = kin[c]
                for d in range(6):
                    A[3 + c, d] += h * kin_grad[6 * c + d]
            if current:
                f[3] += x[6 + p]
                f[4] += x[7 + p]
            for c in range(6):
                A[c, c] += 1.0
            for b in range(m):
                for c in range(6):
                    G[c, b] = F[c, b]
                for c in range(6):
                    acc = 0.0
                    for d in range(6):
                        acc += A[c, d] * G[d, b]
                    F[c, b] = acc
            for i in range(p):
                F[eq_index[i], 6 + i] += h * phi[i]
            if current:
                F[3, 6 + p] += h
                F[4, 7 + p] += h
            for c in range(6):
                x[c] += h * f[c]
        # P⁻ = Φ P Φᵀ + Q: only the motion rows and columns change.
        for c in range(6):
            for b in range(m):
                acc = 0.0
                for a in range(m):
                    acc += F[c, a] * P[a, b]
                G[c, b] = acc
        for c in range(6):
            for b in range(m):
                P[c, b] = G[c, b]
                P[b, c] = G[c, b]
        for c in range(6):
            for d in range(6):
                acc = 0.0
                for a in range(m):
                    acc += G[c, a] * F[d, a]
                P[c, d] = acc
            P[c, c] += q_state[c] * T * max(T, q_interval)  # EkfSettings
        theta_share = T / max(T, q_interval)  # the random walk is per interval (EkfSettings)
        for i in range(q_theta.size):
            P[6 + i, 6 + i] += q_theta[i] * (theta_share if i < p else 1.0)
        # Update: S = H P⁻ Hᵀ + R = L Lᵀ (Cholesky, 3 × 3).
        rk = min(k + 1, last_row)
        s00 = P[o, o] + r_var[rk, 0]
        s11 = P[o + 1, o + 1] + r_var[rk, 1]
        s22 = P[o + 2, o + 2] + r_var[rk, 2]
        if not s00 > 0.0:
            return _NOT_PD, k + 1
        l00 = np.sqrt(s00)
        l10 = P[o + 1, o] / l00
        l20 = P[o + 2, o] / l00
        d11 = s11 - l10 * l10
        if not d11 > 0.0:
            return _NOT_PD, k + 1
        l11 = np.sqrt(d11)
        l21 = (P[o + 2, o + 1] - l20 * l10) / l11
        d22 = s22 - l20 * l20 - l21 * l21
        if not d22 > 0.0:
            return _NOT_PD, k + 1
        l22 = np.sqrt(d22)
        # K = P Hᵀ S⁻¹: forward and back substitution for every row of P Hᵀ.
        for a in range(m):
            PH[a, 0] = P[a, o]
            PH[a, 1] = P[a, o + 1]
            PH[a, 2] = P[a, o + 2]
            w0 = PH[a, 0] / l00
            w1 = (PH[a, 1] - l10 * w0) / l11
            w2 = (PH[a, 2] - l20 * w0 - l21 * w1) / l22
            k2 = w2 / l22
            k1 = (w1 - l21 * k2) / l11
            K[a, 0] = (w0 - l10 * k1 - l20 * k2) / l00
            K[a, 1] = k1
            K[a, 2] = k2
        e0 = y[k + 1, 0] - x[o]
        e1 = y[k + 1, 1] - x[o + 1]
        e2 = y[k + 1, 2] - x[o + 2]
        for a in range(m):
            x[a] += K[a, 0] * e0 + K[a, 1] * e1 + K[a, 2] * e2
        # P = P⁻ − K H P⁻, kept symmetric.
        for a in range(m):
            for b in range(a, m):
                value = P[a, b] - (K[a, 0] * PH[b, 0] + K[a, 1] * PH[b, 1] + K[a, 2] * PH[b, 2])
                P[a, b] = value
                P[b, a] = value
        # The speed log, stw = (1 + k) u + ε (and a two-axis log's transverse axis at x_L,
        # (1 + k)(v + x_L r) + ε'): H has 1 + k at u (v; and (1 + k) x_L at r) and the
        # speed measured at k; scalar updates after the track's (independent noises), each
        # unless gated out.
        for axis in range(2):
            stw = speed_log[min(k + 1, last_speed), axis]
            if scale < 0 or not np.isfinite(stw):
                continue
            gain = 1.0 + x[scale]
            lever = speed_log_x if axis == 1 else 0.0
            speed = x[axis] + lever * x[2]
            for a in range(m):
                PH[a, 0] = gain * (P[a, axis] + lever * P[a, 2]) + speed * P[a, scale]
            s_log = (
                gain * (PH[axis, 0] + lever * PH[2, 0]) + speed * PH[scale, 0] + speed_log_var[axis]
            )
            if not s_log > 0.0:
                return _NOT_PD, k + 1
            innovation = stw - gain * speed
            if innovation * innovation <= SPEED_LOG_GATE_NIS * s_log:
                for a in range(m):
                    x[a] += PH[a, 0] / s_log * innovation
                for a in range(m):
                    for b in range(a, m):
                        value = P[a, b] - PH[a, 0] * PH[b, 0] / s_log
                        P[a, b] = value
                        P[b, a] = value
                speed_log_counts[2 * axis] += 1
            else:
                speed_log_counts[2 * axis + 1] += 1
        for a in range(m):
            if not (np.isfinite(x[a]) and np.isfinite(P[a, a])):
                return _NONFINITE, k + 1
            if P[a, a] <= 0.0:
                return _EXPLODED, k + 1
        for i in range(q_theta.size):
            if P[6 + i, 6 + i] > variance_limit[i]:
                return _EXPLODED, k + 1
        _add_track_residual(x, track, k + 1, square_sums)
        if (k + 1) % stride == 0:
            r = (k + 1) // stride
            for i in range(p):
                theta_hist[r, i] = x[6 + i]
                std_hist[r, i] = np.sqrt(P[6 + i, 6 + i])
            for c in range(6):
                states[r, c] = x[c]
    return _OK, 0


_EKF_PASS = Binding("ekf_pass", _ekf_pass, ("phi", "grad", "kin", "kin_grad"))
""":func:`_ekf_pass` bound to a structure's kernels (``fmu_model.kernels``)."""


@numba.njit(cache=True)
def _add_track_residual(x, track, k, square_sums):  # fmt: skip
    """Add the squared filtered-minus-logged position and wrapped heading at sample k."""
    dx = x[3] - track[k, 0]
    dy = x[4] - track[k, 1]
    dpsi = (x[5] - track[k, 2] + np.pi) % (2.0 * np.pi) - np.pi
    square_sums[0] += dx * dx + dy * dy
    square_sums[1] += dpsi * dpsi
