"""Trajectory smoothing: per-axis constant-acceleration Kalman filter + RTS smoother.

This is the data pre-processing of Shi et al. (2009), section 4.1. Each measured axis
(North position x, East position y, unwrapped heading ψ) is smoothed on its own with the
state-space model of their eq. (6),

    X(k+1) = Φ X(k) + w(k),    Z(k) = H X(k) + n(k),    X = [s, ṡ, s̈]ᵀ,  H = [1 0 0],

filtered forwards with eq. (7) and smoothed backwards with the fixed-interval
Rauch-Tung-Striebel smoother of eq. (8). The body velocities then follow from eq. (9):
U = √(ẋ² + ẏ²), χ = atan2(ẏ, ẋ), β = χ − ψ, u = U cos β, v = U sin β, r = ψ̇.

Unlike the paper (fixed T = 2 s), the sampling may be irregular: Φ and Q are rebuilt for
every interval Δt_k = t_k − t_{k−1}.

Process noise (Singer 1970)
---------------------------
Singer models the target acceleration a as a first-order Markov process with
correlation time τ = 1/α and variance σ_m², i.e. ȧ = −α a + w with white w of spectral
density 2ασ_m². For αT ≪ 1 (Singer 1970, eq. 19 in the small-αT limit) the discrete
process-noise covariance reduces to that of the constant-acceleration model driven by
white jerk of spectral density q = 2ασ_m² = 2σ_m²/τ:

    Q(T) = q ∫₀ᵀ g(s) g(s)ᵀ ds,  g(s) = [s²/2, s, 1]ᵀ

         = 2ασ_m² ⎡T⁵/20  T⁴/8  T³/6⎤
                  ⎢T⁴/8   T³/3  T²/2⎥
                  ⎣T³/6   T²/2  T   ⎦ ,

which is exactly the Q of Shi et al. (2009), eq. (6), here evaluated with T = Δt_k.
The transition matrix is the constant-acceleration Φ of the same equation,
Φ(T) = [[1, T, T²/2], [0, 1, T], [0, 0, 1]].

Glitches (innovation gating)
----------------------------
A GNSS receiver now and then puts a fix tens to thousands of metres off for one or a
few samples (multipath), and a compass may spike. :func:`smooth_track` rejects such
samples before they reach the smoother (:func:`_gate_kernel`):

- **Gate.** The forward filter tests every sample's normalised innovation squared
  NIS = yᵀS⁻¹y against a χ² quantile of false-alarm probability
  :data:`GATE_FALSE_ALARM` = 10⁻⁹ (for Gaussian innovations): the position pair,
  whose two filters share one covariance, NIS = (y_x² + y_y²)/S against χ²₂ =
  :data:`GATE_NIS_POSITION` = 41.4 (6.4 σ); the heading y²/S against χ²₁ =
  :data:`GATE_NIS_HEADING` = 37.3 (6.1 σ). A rejected sample gets the prediction
  only (x(k|k) = x(k|k−1)), and the RTS pass runs over the same decisions.
- **Calibration.** Real logs have heavier-tailed innovations than the model says (a
  Singer filter lags a rudder reversal; model-test tracks are smoothed at the
  source). A first pass at 16 × the threshold (4 × on the innovation) rejects only
  gross glitches; the 99th percentile of the NIS of the samples it kept, over that of
  χ², is λ (floored at 1), and the gate runs at λ × the threshold. On a log that
  follows the model λ ≈ 1 (1.00 to 1.03 on the synthetic KVLCC2 logs); on the HSVA
  model tests, 20 Hz and sub-millimetre noise, λ is 3 to 12, and nothing is rejected.
  λ is at most :data:`TAIL_RATIO_MAX` (4) × the same ratio of the 90th percentiles:
  a heavy tail spreads the top tenth of the innovations (on HSVA the 99th
  percentile's ratio is 1.3 to 3.5 × the 90th's; a Student t of 3 degrees of freedom
  gives 2.5), while glitches the calibration pass kept, a percent of the samples or
  more, stack in the top percent alone (three excursions of 5 samples and 20 m in
  1064: 11.9 × the 90th percentile's λ, and the gate let them all in).
- **Excursions.** A run of rejections that ends when the data come back onto the
  predicted track is a glitch: all its samples stay rejected. While a run lasts, the
  prediction's variance grows and an offset the gate rejected at first may pass it a
  few samples on; a sample ends the run only if it is nearer the predicted track
  (NIS) than the rejected sample before it moved on by the predicted rate (its
  squared distance over 2R), so that an excursion of tens of metres is rejected to
  its end.
- **Re-acquisition.** So that the gate cannot lock out for good, a run of rejections
  lasting :data:`REACQUIRE_SAMPLES` samples and :data:`REACQUIRE_S` seconds since the
  last accepted sample is taken for a genuine change of the measurement (a receiver
  that re-acquires with a new offset, a track that restarts): the filter goes back to
  the first sample of the run, restarts the track there (:func:`_add_jump`: position
  and rate variances widened by the squared innovation), accepts it and gates on
  from it. If the data come back onto the track from before it within
  :data:`EXCURSION_S`, the run and everything after it up to the return is an
  excursion after all (rejected; the rates are undisturbed).
- **Start.** The prior is built from the first three samples that agree with each
  other (:func:`_consistent_prior`), so that a glitch at the very start cannot give
  the filter a wrong velocity.
- **Noise.** The noise levels are estimated robustly (:func:`estimate_noise` leaves
  outliers out), so that glitches do not widen R or the process noise, and with
  them the gate. When the gate has rejected or re-acquired anything, the levels it
  did not get as arguments are estimated again from the accepted samples alone, the
  pieces between re-acquisitions apart (:func:`_segment_noise`: a step, or a glitch
  of many samples, is no outlier of the local fits but would raise the acceleration
  level), and the gate runs again with them.

The rejected samples and re-acquisitions are reported in :class:`SmoothedTrack`
(``rejected_position_samples``, ``rejected_heading_samples``, ...), and
:meth:`SmoothedTrack.deglitched` replaces the rejected measurements by the smoothed
track for whatever uses the logged track afterwards.

Units: an axis carries its own units ([m, m/s, m/s²] for positions,
[rad, rad/s, rad/s²] for heading); arguments documented "[axis unit]" follow them.
"""

from __future__ import annotations

import itertools
import math
import statistics
from dataclasses import dataclass, field, replace
from typing import TypeVar

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

from trials.angles import unwrap_heading
from trials.logs import ManeuverLog
from trials.trajectory import trajectory_of

__all__ = [
    "DEFAULT_TAU_S",
    "EXCURSION_S",
    "GATE_FALSE_ALARM",
    "GATE_NIS_HEADING",
    "GATE_NIS_POSITION",
    "OUTLIER_SIGMAS",
    "REACQUIRE_S",
    "REACQUIRE_SAMPLES",
    "TAIL_RATIO_MAX",
    "AxisSmoothing",
    "NoiseEstimate",
    "SmoothedTrack",
    "constant_acceleration_model",
    "deglitched_log",
    "estimate_noise",
    "smooth_axis",
    "smooth_log",
    "smooth_track",
    "smoothed_trajectory",
    "wrap_angle",
]

FloatArray = NDArray[np.float64]
_Array = TypeVar("_Array", bound=np.ndarray)

#: Default Singer manoeuvre time constant τ = 1/α [s]. Singer (1970) suggests about 60 s
#: for a lazy turn and 20 s for an evasive manoeuvre; a ship answering hard rudder
#: (zig-zag, turning circle) is the latter.
DEFAULT_TAU_S = 20.0

#: Inflation κ of the two-point initial covariance (see :func:`smooth_axis`).
_PRIOR_INFLATION = 10.0

#: Samples in a window of the acceleration-level fit (see :func:`estimate_noise`).
_ACCEL_FIT_SAMPLES = 31

#: Clip level of the noise estimator, in robust standard deviations.
_CLIP_SIGMAS = 4.0

OUTLIER_SIGMAS = 8.0
"""Outlier level of the noise estimator, in robust standard deviations: samples whose
residual exceeds it are left out and the fits repeated (see :func:`estimate_noise`).
Real residuals reach 6.3 σ (the HSVA model tests: heavier tails than Gaussian, where
5 σ comes once in 1.7 million); a glitch worth leaving out is tens of σ."""

#: Passes of outlier removal in :func:`estimate_noise` at most.
_OUTLIER_PASSES = 5

#: Upper quartile of |e| for e ~ N(0, 1): Φ⁻¹(0.875).
_GAUSSIAN_Q75 = statistics.NormalDist().inv_cdf(0.875)

GATE_FALSE_ALARM = 1e-9
"""Probability that the innovation gate rejects a good sample if the innovations were
Gaussian as the filter's model says. Real innovations have heavier tails (the gate is
widened for them, see the module notes); the glitches it is for are tens of σ."""

GATE_NIS_POSITION = -2.0 * math.log(GATE_FALSE_ALARM)
"""Gate on the position pair's normalised innovation squared: the χ² quantile with 2
degrees of freedom of :data:`GATE_FALSE_ALARM` (41.45, i.e. 6.4 σ; χ²₂ has survival
exp(−c/2))."""

GATE_NIS_HEADING = statistics.NormalDist().inv_cdf(1.0 - 0.5 * GATE_FALSE_ALARM) ** 2
"""Gate on the heading's normalised innovation squared: the χ² quantile with 1 degree
of freedom of :data:`GATE_FALSE_ALARM` (37.32, i.e. |y| > 6.11 √S)."""

REACQUIRE_SAMPLES = 5
"""Consecutive rejected samples after which a jump is taken for a genuine step."""

REACQUIRE_S = 5.0
"""... and the least time since the last accepted sample for that [s] (at 1 Hz both say
five samples; at 10 Hz the time does: fifty)."""

EXCURSION_S = 30.0
"""Longest glitch taken as one [s]: a jump that is followed within this time by a jump
back onto the track predicted from before it is an excursion, all its samples rejected."""

#: 99th and 90th percentiles of χ² with 1 and 2 degrees of freedom (see :func:`_gate`).
_CHI2_99 = (statistics.NormalDist().inv_cdf(0.995) ** 2, -2.0 * math.log(0.01))
_CHI2_90 = (statistics.NormalDist().inv_cdf(0.95) ** 2, -2.0 * math.log(0.1))

TAIL_RATIO_MAX = 4.0
"""Heaviest tail the gate's calibration takes for the log's own: λ is at most this
many times the 90th percentile's ratio (see :func:`_gate`)."""

#: Widening of the gate's calibration pass, on the NIS (4 × on the innovation).
_CALIBRATION_GATE = 16.0

#: Fewest samples of a piece between re-acquisitions whose noise is re-estimated.
_MIN_NOISE_SAMPLES = 20

#: Samples searched for a consistent triple to start the gated filter from.
_PRIOR_SEARCH_SAMPLES = 50


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class AxisSmoothing:
    """Filtered and smoothed estimates of one axis (arrays are read-only).

    The state is [position, rate, acceleration] in the axis' own units
    ([m, m/s, m/s²] or [rad, rad/s, rad/s²]).

    Attributes
    ----------
    time_s : ndarray, shape (N,)
        Sample times [s].
    x_filtered : ndarray, shape (N, 3)
        Filtered state x(k|k).
    P_filtered : ndarray, shape (N, 3, 3)
        Filtered covariance P(k|k).
    x_smoothed : ndarray, shape (N, 3)
        RTS-smoothed state x(k|N).
    P_smoothed : ndarray, shape (N, 3, 3)
        RTS-smoothed covariance P(k|N).
    innovation : ndarray, shape (N,)
        Innovation y(k) = z(k) − H x(k|k−1) [axis unit]; at k = 0 it is taken against
        the prior (0 for the default prior, which is centred on z(0)).
    innovation_var : ndarray, shape (N,)
        Innovation variance S(k) = H P(k|k−1) Hᵀ + R [axis unit²].
    log_likelihood : float
        Σ_k −½ (ln 2πS(k) + y(k)²/S(k)) over the accepted samples k ≥ 1 (the prior's own
        sample excluded).
    meas_std : float
        Measurement noise standard deviation √R used [axis unit].
    accel_std : float
        Singer acceleration standard deviation σ_m used [axis unit/s²].
    tau_s : float
        Singer time constant τ = 1/α used [s].
    rejected : ndarray of bool, shape (N,)
        Samples the innovation gate rejected (all False without gating).
    reacquired : ndarray of int
        Samples at which the filter re-acquired after a step (see the module notes).

    """

    time_s: FloatArray
    x_filtered: FloatArray
    P_filtered: FloatArray
    x_smoothed: FloatArray
    P_smoothed: FloatArray
    innovation: FloatArray
    innovation_var: FloatArray
    log_likelihood: float
    meas_std: float
    accel_std: float
    tau_s: float
    rejected: NDArray[np.bool_]
    reacquired: NDArray[np.intp]

    @property
    def position(self) -> FloatArray:
        """Smoothed position [axis unit], shape (N,)."""
        return self.x_smoothed[:, 0]

    @property
    def rate(self) -> FloatArray:
        """Smoothed rate [axis unit/s], shape (N,)."""
        return self.x_smoothed[:, 1]

    @property
    def acceleration(self) -> FloatArray:
        """Smoothed acceleration [axis unit/s²], shape (N,)."""
        return self.x_smoothed[:, 2]

    @property
    def std_smoothed(self) -> FloatArray:
        """Smoothed standard deviations of [position, rate, acceleration], shape (N, 3)."""
        return np.sqrt(np.diagonal(self.P_smoothed, axis1=1, axis2=2))


@dataclass(frozen=True)
class NoiseEstimate:
    """Noise levels of one axis estimated from its data (see :func:`estimate_noise`).

    Attributes
    ----------
    meas_std : float
        Measurement noise standard deviation [axis unit].
    accel_std : float
        RMS acceleration of the signal, the Singer σ_m [axis unit/s²].

    """

    meas_std: float
    accel_std: float


@dataclass(frozen=True)
class SmoothedTrack:
    """Smoothed track and derived ship velocities, Shi et al. (2009), eq. (9).

    Earth frame x North, y East; heading ψ clockwise from North; body u forward,
    v to starboard, r positive turning to starboard. Standard deviations are
    first-order propagations of the smoother covariances, the three axes taken as
    independent (see :func:`smooth_track`).

    Only the smoothed states of the three axes and the variances of their positions
    and rates are stored (15 numbers a sample), and the indices of the samples the
    innovation gate rejected; every other array is derived from them when asked for
    (shape (N,), read-only), so that a long log costs no more memory than that.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s].
    states : ndarray, shape (3, N, 3)
        Smoothed [position, rate, acceleration] of x [m], y [m] and the continuous
        heading ψ [rad], in that order of axes.
    variances : ndarray, shape (3, N, 2)
        Smoothed variances of [position, rate] of the same axes.
    position_noise_m : float
        Position measurement noise standard deviation used [m].
    heading_noise_rad : float
        Heading measurement noise standard deviation used [rad].
    position_accel_std_mps2 : float
        Singer acceleration standard deviation used on x and y [m/s²].
    heading_accel_std_radps2 : float
        Singer angular acceleration standard deviation used on ψ [rad/s²].
    tau_s : float
        Singer time constant used [s].
    position_rejected : ndarray of int
        Samples whose position fix (x and y together) the innovation gate rejected
        (see the module notes); the smoothed track bridges them.
    heading_rejected : ndarray of int
        Samples whose heading the gate rejected.
    position_reacquired, heading_reacquired : ndarray of int
        Samples at which the filter took a persistent jump for a genuine step and
        re-acquired (the first sample of the jump).
    position_gate_scale, heading_gate_scale : float
        Factor λ ≥ 1 by which the gate was widened because the log's innovations
        are wider than the filter's model says (module notes); 1: not widened.

    Derived (properties): ``rejected_position_samples``, ``rejected_heading_samples``
    (the counts), ``x_m, y_m`` [m], ``heading_rad`` [rad], ``x_dot_mps, y_dot_mps``,
    ``speed_mps`` U = √(ẋ² + ẏ²), ``u_mps`` = U cos β, ``v_mps`` = U sin β [m/s],
    ``course_rad`` χ = atan2(ẏ, ẋ) and ``drift_rad`` β = χ − ψ, in (−π, π] [rad],
    ``r_radps`` = ψ̇ [rad/s], ``u_dot_mps2`` = ẍ cos ψ + ÿ sin ψ + r v and
    ``v_dot_mps2`` = −ẍ sin ψ + ÿ cos ψ − r u [m/s²], ``r_dot_radps2`` = ψ̈ [rad/s²];
    the standard deviations ``x_std_m, y_std_m, heading_std_rad, x_dot_std_mps,
    y_dot_std_mps, speed_std_mps, u_std_mps, v_std_mps, course_std_rad, drift_std_rad,
    r_std_radps`` (χ and β meaningless where U ≈ 0).

    """

    time_s: FloatArray
    states: FloatArray
    variances: FloatArray
    position_noise_m: float
    heading_noise_rad: float
    position_accel_std_mps2: float
    heading_accel_std_radps2: float
    tau_s: float
    position_rejected: NDArray[np.intp] = field(default_factory=lambda: _no_samples())
    heading_rejected: NDArray[np.intp] = field(default_factory=lambda: _no_samples())
    position_reacquired: NDArray[np.intp] = field(default_factory=lambda: _no_samples())
    heading_reacquired: NDArray[np.intp] = field(default_factory=lambda: _no_samples())
    position_gate_scale: float = 1.0
    heading_gate_scale: float = 1.0

    @property
    def n_samples(self) -> int:
        """Number of samples N."""
        return int(self.time_s.size)

    @property
    def rejected_position_samples(self) -> int:
        """Number of position fixes the innovation gate rejected."""
        return int(self.position_rejected.size)

    @property
    def rejected_heading_samples(self) -> int:
        """Number of headings the innovation gate rejected."""
        return int(self.heading_rejected.size)

    def deglitched(
        self, x_m: ArrayLike, y_m: ArrayLike, heading_rad: ArrayLike
    ) -> tuple[FloatArray, FloatArray, FloatArray]:
        """Return the measurements with the rejected samples replaced by the smoothed track.

        For whatever uses the logged track itself after smoothing (the EKF's track
        measurements, the output-error objective): a glitch replaced by the smoother's
        estimate there instead of the thousand metres it was.

        Parameters
        ----------
        x_m, y_m : array_like, shape (N,)
            The measured North and East positions this track was smoothed from [m].
        heading_rad : array_like, shape (N,)
            The measured heading [rad]; a replaced heading is put on the 2π branch of
            the last accepted one before it (the first after it at the start).

        Returns
        -------
        x_m, y_m, heading_rad : ndarray, shape (N,)
            New arrays; equal to the inputs where nothing was rejected.

        """
        x = np.array(x_m, dtype=float)
        y = np.array(y_m, dtype=float)
        psi = np.array(heading_rad, dtype=float)
        _check_same_length(self.time_s, x_m=x, y_m=y, heading_rad=psi)
        bad = self.position_rejected
        x[bad] = self.x_m[bad]
        y[bad] = self.y_m[bad]
        bad = self.heading_rejected
        if bad.size and bad.size < psi.size:
            accepted = np.ones(psi.size, dtype=bool)
            accepted[bad] = False
            index = np.arange(psi.size)
            last = np.maximum.accumulate(np.where(accepted, index, -1))
            last[last < 0] = int(np.argmax(accepted))
            smoothed = self.heading_rad[bad]
            turns = np.round((psi[last[bad]] - smoothed) / (2.0 * np.pi))
            psi[bad] = smoothed + 2.0 * np.pi * turns
        return x, y, psi

    # Smoothed states of the axes.
    @property
    def x_m(self) -> FloatArray:
        """Smoothed North position [m]."""
        return self.states[0, :, 0]

    @property
    def y_m(self) -> FloatArray:
        """Smoothed East position [m]."""
        return self.states[1, :, 0]

    @property
    def heading_rad(self) -> FloatArray:
        """Smoothed heading ψ, continuous [rad]."""
        return self.states[2, :, 0]

    @property
    def x_dot_mps(self) -> FloatArray:
        """North velocity over ground ẋ [m/s]."""
        return self.states[0, :, 1]

    @property
    def y_dot_mps(self) -> FloatArray:
        """East velocity over ground ẏ [m/s]."""
        return self.states[1, :, 1]

    @property
    def r_radps(self) -> FloatArray:
        """Yaw rate r = ψ̇ [rad/s]."""
        return self.states[2, :, 1]

    @property
    def r_dot_radps2(self) -> FloatArray:
        """Yaw acceleration ṙ = ψ̈ [rad/s²]."""
        return self.states[2, :, 2]

    # Shi et al. (2009), eq. (9), as u = ẋ cos ψ + ẏ sin ψ, v = −ẋ sin ψ + ẏ cos ψ.
    @property
    def speed_mps(self) -> FloatArray:
        """Speed over ground U = √(ẋ² + ẏ²) [m/s]."""
        return _readonly(np.hypot(self.x_dot_mps, self.y_dot_mps))

    @property
    def course_rad(self) -> FloatArray:
        """Course over ground χ = atan2(ẏ, ẋ) in (−π, π] [rad]."""
        return _readonly(wrap_angle(np.arctan2(self.y_dot_mps, self.x_dot_mps)))

    @property
    def drift_rad(self) -> FloatArray:
        """Drift angle β = χ − ψ in (−π, π] [rad]."""
        return _readonly(wrap_angle(self.course_rad - self.heading_rad))

    @property
    def u_mps(self) -> FloatArray:
        """Surge velocity u = U cos β [m/s]."""
        psi = self.heading_rad
        return _readonly(self.x_dot_mps * np.cos(psi) + self.y_dot_mps * np.sin(psi))

    @property
    def v_mps(self) -> FloatArray:
        """Sway velocity v = U sin β [m/s], positive to starboard."""
        psi = self.heading_rad
        return _readonly(-self.x_dot_mps * np.sin(psi) + self.y_dot_mps * np.cos(psi))

    @property
    def u_dot_mps2(self) -> FloatArray:
        """Body-axis u̇ = ẍ cos ψ + ÿ sin ψ + r v [m/s²]."""
        psi = self.heading_rad
        xdd, ydd = self.states[0, :, 2], self.states[1, :, 2]
        return _readonly(xdd * np.cos(psi) + ydd * np.sin(psi) + self.r_radps * self.v_mps)

    @property
    def v_dot_mps2(self) -> FloatArray:
        """Body-axis v̇ = −ẍ sin ψ + ÿ cos ψ − r u [m/s²]."""
        psi = self.heading_rad
        xdd, ydd = self.states[0, :, 2], self.states[1, :, 2]
        return _readonly(-xdd * np.sin(psi) + ydd * np.cos(psi) - self.r_radps * self.u_mps)

    # First-order propagation of the smoother variances (see smooth_track).
    @property
    def x_std_m(self) -> FloatArray:
        """Standard deviation of the smoothed x [m]."""
        return _readonly(np.sqrt(self.variances[0, :, 0]))

    @property
    def y_std_m(self) -> FloatArray:
        """Standard deviation of the smoothed y [m]."""
        return _readonly(np.sqrt(self.variances[1, :, 0]))

    @property
    def heading_std_rad(self) -> FloatArray:
        """Standard deviation of the smoothed ψ [rad]."""
        return _readonly(np.sqrt(self.variances[2, :, 0]))

    @property
    def x_dot_std_mps(self) -> FloatArray:
        """Standard deviation of ẋ [m/s]."""
        return _readonly(np.sqrt(self.variances[0, :, 1]))

    @property
    def y_dot_std_mps(self) -> FloatArray:
        """Standard deviation of ẏ [m/s]."""
        return _readonly(np.sqrt(self.variances[1, :, 1]))

    @property
    def r_std_radps(self) -> FloatArray:
        """Standard deviation of r [rad/s]."""
        return _readonly(np.sqrt(self.variances[2, :, 1]))

    @property
    def u_std_mps(self) -> FloatArray:
        """Standard deviation of u: √(cos²ψ Var ẋ + sin²ψ Var ẏ + v² Var ψ) [m/s]."""
        c2, s2 = np.cos(self.heading_rad) ** 2, np.sin(self.heading_rad) ** 2
        var_xd, var_yd = self.variances[0, :, 1], self.variances[1, :, 1]
        var = c2 * var_xd + s2 * var_yd + self.v_mps**2 * self.variances[2, :, 0]
        return _readonly(np.sqrt(var))

    @property
    def v_std_mps(self) -> FloatArray:
        """Standard deviation of v: √(sin²ψ Var ẋ + cos²ψ Var ẏ + u² Var ψ) [m/s]."""
        c2, s2 = np.cos(self.heading_rad) ** 2, np.sin(self.heading_rad) ** 2
        var_xd, var_yd = self.variances[0, :, 1], self.variances[1, :, 1]
        var = s2 * var_xd + c2 * var_yd + self.u_mps**2 * self.variances[2, :, 0]
        return _readonly(np.sqrt(var))

    @property
    def speed_std_mps(self) -> FloatArray:
        """Standard deviation of U: √((ẋ² Var ẋ + ẏ² Var ẏ) / U²) [m/s]."""
        xd, yd = self.x_dot_mps, self.y_dot_mps
        var_xd, var_yd = self.variances[0, :, 1], self.variances[1, :, 1]
        speed2 = xd**2 + yd**2
        moving = speed2 > 0.0
        weighted = (xd**2 * var_xd + yd**2 * var_yd) / np.where(moving, speed2, 1.0)
        var = np.where(moving, weighted, var_xd + var_yd)
        return _readonly(np.sqrt(var))

    @property
    def course_std_rad(self) -> FloatArray:
        """Standard deviation of χ: √((ẏ² Var ẋ + ẋ² Var ẏ) / U⁴) [rad] (inf where U = 0)."""
        return _readonly(np.sqrt(self._course_var()))

    @property
    def drift_std_rad(self) -> FloatArray:
        """Standard deviation of β: √(Var χ + Var ψ) [rad]."""
        return _readonly(np.sqrt(self._course_var() + self.variances[2, :, 0]))

    def _course_var(self) -> FloatArray:
        xd, yd = self.x_dot_mps, self.y_dot_mps
        var_xd, var_yd = self.variances[0, :, 1], self.variances[1, :, 1]
        speed2 = xd**2 + yd**2
        moving = speed2 > 0.0
        safe = np.where(moving, speed2, 1.0)
        return np.where(moving, (yd**2 * var_xd + xd**2 * var_yd) / safe**2, np.inf)


# --------------------------------------------------------------------------- helpers


def wrap_angle(angle_rad: ArrayLike) -> FloatArray:
    """Wrap angles to the interval (−π, π].

    Parameters
    ----------
    angle_rad : array_like
        Angles [rad].

    Returns
    -------
    ndarray
        The same angles in (−π, π] [rad].

    """
    a = np.asarray(angle_rad, dtype=float)
    return a - 2.0 * np.pi * np.ceil((a - np.pi) / (2.0 * np.pi))


def _readonly(a: _Array) -> _Array:
    a.setflags(write=False)
    return a


def _no_samples() -> NDArray[np.intp]:
    """Return an empty, read-only index array."""
    a = np.empty(0, dtype=np.intp)
    a.setflags(write=False)
    return a


def _as_series(values: ArrayLike, name: str) -> FloatArray:
    """Copy ``values`` to a finite 1-D float array or raise ValueError naming it."""
    try:
        a = np.array(values, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be numeric: {exc}") from None
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {a.shape}")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError(f"{name} contains a non-finite value at sample {bad[0]}: {a[bad[0]]}")
    return a


def _check_time(t_s: FloatArray, min_samples: int = 3) -> None:
    if t_s.size < min_samples:
        raise ValueError(f"at least {min_samples} samples are needed, got {t_s.size}")
    dt = np.diff(t_s)
    bad = np.flatnonzero(dt <= 0.0)
    if bad.size:
        k = bad[0] + 1
        raise ValueError(
            f"time_s must be strictly increasing: sample {k} is at {t_s[k]!r} s "
            f"after {t_s[k - 1]!r} s at sample {k - 1}"
        )


def _check_same_length(t_s: FloatArray, **series: FloatArray) -> None:
    for name, a in series.items():
        if a.size != t_s.size:
            raise ValueError(f"{name} has {a.size} samples but time_s has {t_s.size}")


def _check_positive(value: float, name: str) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0.0):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return v


# --------------------------------------------------------------------------- model


def constant_acceleration_model(
    dt_s: ArrayLike, accel_std: float, tau_s: float = DEFAULT_TAU_S
) -> tuple[FloatArray, FloatArray]:
    """Transition matrices Φ and Singer process noise Q for a set of intervals.

    Shi et al. (2009), eq. (6), with T = Δt per interval::

        Φ(T) = ⎡1  T  T²/2⎤        Q(T) = 2ασ_m² ⎡T⁵/20  T⁴/8  T³/6⎤
               ⎢0  1  T   ⎥                      ⎢T⁴/8   T³/3  T²/2⎥
               ⎣0  0  1   ⎦                      ⎣T³/6   T²/2  T   ⎦

    with α = 1/τ. Q is the exact discretisation of white jerk of spectral density
    q = 2σ_m²/τ (the small-αT limit of Singer 1970).

    Parameters
    ----------
    dt_s : array_like, shape (M,)
        Sampling intervals Δt [s].
    accel_std : float
        Singer acceleration standard deviation σ_m [axis unit/s²].
    tau_s : float, optional
        Singer manoeuvre time constant τ = 1/α [s].

    Returns
    -------
    F : ndarray, shape (M, 3, 3)
        Transition matrices Φ(Δt).
    Q : ndarray, shape (M, 3, 3)
        Process noise covariances Q(Δt) [axis units²].

    """
    T = np.asarray(dt_s, dtype=float)
    q = 2.0 * accel_std**2 / tau_s  # 2ασ_m² [axis unit²/s⁵]
    T2, T3 = T * T, T * T * T
    T4, T5 = T3 * T, T3 * T2
    F = np.zeros((*T.shape, 3, 3))
    F[..., 0, 0] = F[..., 1, 1] = F[..., 2, 2] = 1.0
    F[..., 0, 1] = F[..., 1, 2] = T
    F[..., 0, 2] = 0.5 * T2
    Q = np.empty((*T.shape, 3, 3))
    Q[..., 0, 0] = q * T5 / 20.0
    Q[..., 0, 1] = Q[..., 1, 0] = q * T4 / 8.0
    Q[..., 0, 2] = Q[..., 2, 0] = q * T3 / 6.0
    Q[..., 1, 1] = q * T3 / 3.0
    Q[..., 1, 2] = Q[..., 2, 1] = q * T2 / 2.0
    Q[..., 2, 2] = q * T
    return F, Q


# --------------------------------------------------------------------------- one axis


#: Symmetric 3x3 stored as (P00, P01, P02, P11, P12, P22): gather indices to the full matrix.
_SYM_TO_FULL = [0, 1, 2, 1, 3, 4, 2, 4, 5]

#: Index of entry (i, j) of a symmetric 3x3 in the six-entry storage.
_SYM_INDEX = np.array([[0, 1, 2], [1, 3, 4], [2, 4, 5]])

#: Samples per block of the checkpointed RTS pass (see :func:`_rts_kernel`).
RTS_BLOCK_SAMPLES = 4096


@numba.njit(cache=True)
def _predict(T: float, q: float, x: FloatArray, P: FloatArray) -> None:
    """Prediction of eq. (7) for Φ, Q of eq. (6), in place on x (3,) and the six-entry P.

    The products are written out for the structure of Φ(T) (upper triangular, with
    h = T²/2) on the six distinct entries of the symmetric P. With B = Φ P::

        B₀ = P₀ + T P₁ + h P₂,   B₁ = P₁ + T P₂          (rows)
        (Φ P Φᵀ)₀₀ = B₀₀ + T B₀₁ + h B₀₂,   (Φ P Φᵀ)₀₁ = B₀₁ + T B₀₂,   (Φ P Φᵀ)₀₂ = B₀₂,
        (Φ P Φᵀ)₁₁ = B₁₁ + T B₁₂,           (Φ P Φᵀ)₁₂ = B₁₂,           (Φ P Φᵀ)₂₂ = P₂₂,

    plus Q = q [[T⁵/20, T⁴/8, T³/6], [., T³/3, T²/2], [., ., T]].
    """
    h = 0.5 * T * T
    x[0] = x[0] + T * x[1] + h * x[2]  # x(k|k−1) = Φ x(k−1|k−1)
    x[1] = x[1] + T * x[2]
    p00, p01, p02, p11, p12, p22 = P[0], P[1], P[2], P[3], P[4], P[5]
    b00 = p00 + T * p01 + h * p02
    b01 = p01 + T * p11 + h * p12
    b02 = p02 + T * p12 + h * p22
    b11 = p11 + T * p12
    b12 = p12 + T * p22
    qT = q * T
    qT2 = qT * T
    qT3 = qT2 * T
    P[0] = b00 + T * b01 + h * b02 + qT3 * T * T / 20.0
    P[1] = b01 + T * b02 + qT3 * T / 8.0
    P[2] = b02 + qT3 / 6.0
    P[3] = b11 + T * b12 + qT3 / 3.0
    P[4] = b12 + qT2 / 2.0
    P[5] = p22 + qT


@numba.njit(cache=True)
def _update(z: float, R: float, x: FloatArray, P: FloatArray) -> tuple[float, float]:
    """Update of eq. (7) with H = [1 0 0], in place; returns the innovation y and its S.

    P(k|k) = P − P Hᵀ H P / S on each entry, Pᵢⱼ − Pᵢ₀ Pⱼ₀ / S (for the first row
    Pᵢ₀ R / S, the same number without cancellation).
    """
    S = P[0] + R  # S = H P Hᵀ + R
    y = z - x[0]  # y = z − H x
    k0, k1, k2 = P[0] / S, P[1] / S, P[2] / S  # K = P Hᵀ / S
    x[0] += k0 * y
    x[1] += k1 * y
    x[2] += k2 * y
    P[3], P[4], P[5] = P[3] - k1 * P[1], P[4] - k1 * P[2], P[5] - k2 * P[2]  # P − K H P
    P[0], P[1], P[2] = k0 * R, k1 * R, k2 * R
    return y, S


@numba.njit(cache=True)
def _add_jump(J: FloatArray, P: FloatArray) -> None:
    """Add a re-acquisition's variances J = (J_position, J_rate) to the six-entry P(k|k−1).

    P₀₀ += J_position, P₁₁ += J_rate, in place: a jump of the position (and, for a
    restart of the track, of the rate) of unknown size (see :func:`_gate_kernel`). In
    the RTS pass this is process noise Q + diag(J_position, J_rate, 0) over the
    interval into the sample.
    """
    P[0] += J[0]
    P[3] += J[1]


@numba.njit(cache=True)
def _rts_step(
    T: float,
    q: float,
    xf: FloatArray,
    Pf: FloatArray,
    xs: FloatArray,
    Ps: FloatArray,
    xp: FloatArray,
    Pp: FloatArray,
    work: FloatArray,
    jump: FloatArray,
) -> None:
    """One step of the RTS smoother, eq. (8), in place: (xs, Ps) from k+1|N to k|N.

    With x(k+1|k) = Φ x(k|k), P(k+1|k) = Φ P(k|k) Φᵀ + Q and the gain
    A = P(k|k) Φᵀ P(k+1|k)⁻¹ (= (P(k+1|k)⁻¹ Φ P(k|k))ᵀ, solved by Cholesky)::

        x(k|N) = x(k|k) + A [x(k+1|N) − x(k+1|k)]
        P(k|N) = P(k|k) + A [P(k+1|N) − P(k+1|k)] Aᵀ

    ``jump`` (2,) is what a re-acquisition added to P(k+1|k) (zeros: none), see
    :func:`_add_jump`. ``xp`` (3,), ``Pp`` (6,) and ``work`` (3, 3, 3) are scratch
    space.
    """
    h = 0.5 * T * T
    p00, p01, p02, p11, p12, p22 = Pf[0], Pf[1], Pf[2], Pf[3], Pf[4], Pf[5]
    B, A, D = work[0], work[1], work[2]
    xp[:] = xf
    Pp[:] = Pf
    _predict(T, q, xp, Pp)
    if jump[0] != 0.0:
        _add_jump(jump, Pp)
    # B = Φ P(k|k), full 3 × 3.
    B[0, 0] = p00 + T * p01 + h * p02
    B[0, 1] = p01 + T * p11 + h * p12
    B[0, 2] = p02 + T * p12 + h * p22
    B[1, 0], B[1, 1], B[1, 2] = p01 + T * p02, p11 + T * p12, p12 + T * p22
    B[2, 0], B[2, 1], B[2, 2] = p02, p12, p22
    # P(k+1|k) = L Lᵀ; Aᵀ = L⁻ᵀ L⁻¹ B column by column.
    l00 = np.sqrt(Pp[0])
    l10 = Pp[1] / l00
    l20 = Pp[2] / l00
    l11 = np.sqrt(Pp[3] - l10 * l10)
    l21 = (Pp[4] - l20 * l10) / l11
    l22 = np.sqrt(Pp[5] - l20 * l20 - l21 * l21)
    for c in range(3):
        w0 = B[0, c] / l00
        w1 = (B[1, c] - l10 * w0) / l11
        w2 = (B[2, c] - l20 * w0 - l21 * w1) / l22
        a2 = w2 / l22
        a1 = (w1 - l21 * a2) / l11
        A[c, 0] = (w0 - l10 * a1 - l20 * a2) / l00
        A[c, 1] = a1
        A[c, 2] = a2
    d0, d1, d2 = xs[0] - xp[0], xs[1] - xp[1], xs[2] - xp[2]
    for i in range(3):
        xs[i] = xf[i] + A[i, 0] * d0 + A[i, 1] * d1 + A[i, 2] * d2
    for i in range(3):
        for j in range(3):
            D[i, j] = Ps[_SYM_INDEX[i, j]] - Pp[_SYM_INDEX[i, j]]
    for i in range(3):  # B ← A D
        for j in range(3):
            B[i, j] = A[i, 0] * D[0, j] + A[i, 1] * D[1, j] + A[i, 2] * D[2, j]
    for i in range(3):
        for j in range(i, 3):
            Ps[_SYM_INDEX[i, j]] = Pf[_SYM_INDEX[i, j]] + (
                B[i, 0] * A[j, 0] + B[i, 1] * A[j, 1] + B[i, 2] * A[j, 2]
            )


@numba.njit(cache=True)
def _rts_kernel(
    dt: FloatArray,
    z: FloatArray,
    R: float,
    q: float,
    x0: FloatArray,
    P0: FloatArray,
    accept: NDArray[np.bool_],
    jump: FloatArray,
    block: int,
    x_s: FloatArray,
    var_s: FloatArray,
    P_s: FloatArray,
    x_f: FloatArray,
    P_f: FloatArray,
    yS: FloatArray,
) -> None:
    """Kalman filter, eq. (7), and RTS smoother, eq. (8), in memory of O(N/block + block).

    The forward pass keeps x(k|k), P(k|k) only at the first sample of every block of
    ``block`` samples (checkpoints). The backward pass, block by block from the end,
    runs the filter again over the block from its checkpoint (the same arithmetic, so
    the same numbers), keeps that block's filtered states and runs the RTS recursion
    through it. A sample with ``accept[k]`` False gets the prediction only; ``jump[k]``
    (N, 2) (a re-acquisition; zeros: none) is added to P(k|k−1) by :func:`_add_jump`,
    in both passes. Outputs: ``x_s`` (N, 3) x(k|N) and ``var_s`` (N, 2) the
    smoothed variances of position and rate; ``P_s`` (N, 6) P(k|N), ``x_f`` (N, 3)
    x(k|k), ``P_f`` (N, 6) P(k|k) and ``yS`` (N, 2) innovations and their variances
    only when they have N rows (zero rows: not kept). Covariances in six-entry storage.
    """
    n = z.size
    keep = x_f.shape[0] == n
    n_blocks = (n + block - 1) // block
    check_x = np.empty((n_blocks, 3))
    check_P = np.empty((n_blocks, 6))
    x = x0.copy()
    P = P0.copy()
    for k in range(n):
        if k:
            _predict(dt[k - 1], q, x, P)
        if jump[k, 0] != 0.0:
            _add_jump(jump[k], P)
        if accept[k]:
            y, S = _update(z[k], R, x, P)
        else:
            y, S = z[k] - x[0], P[0] + R
        if k % block == 0:
            check_x[k // block] = x
            check_P[k // block] = P
        if keep:
            x_f[k] = x
            P_f[k] = P
            yS[k, 0] = y
            yS[k, 1] = S
    keep_P = P_s.shape[0] == n
    bx = np.empty((block, 3))
    bP = np.empty((block, 6))
    xp = np.empty(3)
    Pp = np.empty(6)
    work = np.empty((3, 3, 3))
    xs = x.copy()  # x(N−1|N−1) = x(N−1|N), the smoother's start
    Ps = P.copy()
    for b in range(n_blocks - 1, -1, -1):
        start = b * block
        stop = min(n, start + block)
        x[:] = check_x[b]
        P[:] = check_P[b]
        bx[0] = x
        bP[0] = P
        for k in range(start + 1, stop):
            _predict(dt[k - 1], q, x, P)
            if jump[k, 0] != 0.0:
                _add_jump(jump[k], P)
            if accept[k]:
                _update(z[k], R, x, P)
            bx[k - start] = x
            bP[k - start] = P
        for k in range(stop - 1, start - 1, -1):
            if k < n - 1:
                _rts_step(dt[k], q, bx[k - start], bP[k - start], xs, Ps, xp, Pp, work, jump[k + 1])
            x_s[k] = xs
            var_s[k, 0] = Ps[0]
            var_s[k, 1] = Ps[3]
            if keep_P:
                P_s[k] = Ps


@numba.njit(cache=True)
def _predict_axes(T: float, q: float, x: FloatArray, P: FloatArray) -> None:
    """:func:`_predict` of m axes x (m, 3) that share one covariance P."""
    _predict(T, q, x[0], P)
    h = 0.5 * T * T
    for i in range(1, x.shape[0]):
        x[i, 0] = x[i, 0] + T * x[i, 1] + h * x[i, 2]
        x[i, 1] = x[i, 1] + T * x[i, 2]


@numba.njit(cache=True)
def _update_axes(y: FloatArray, R: float, x: FloatArray, P: FloatArray) -> None:
    """:func:`_update` of m axes x (m, 3) with innovations y (m,) and one covariance P."""
    S = P[0] + R
    k0, k1, k2 = P[0] / S, P[1] / S, P[2] / S
    for i in range(x.shape[0]):
        x[i, 0] += k0 * y[i]
        x[i, 1] += k1 * y[i]
        x[i, 2] += k2 * y[i]
    P[3], P[4], P[5] = P[3] - k1 * P[1], P[4] - k1 * P[2], P[5] - k2 * P[2]
    P[0], P[1], P[2] = k0 * R, k1 * R, k2 * R


@numba.njit(cache=True)
def _gate_kernel(
    t: FloatArray,
    z: FloatArray,
    R: float,
    q: float,
    x0: FloatArray,
    P0: FloatArray,
    threshold: float,
    reacquire_samples: int,
    reacquire_s: float,
    excursion_s: float,
    accept: NDArray[np.bool_],
    jump: FloatArray,
    nis: FloatArray,
) -> None:
    """Innovation gate: decide which samples the filter of eq. (7) uses (module notes).

    ``z`` (N, m) holds m axes that share Φ, Q, R and so one covariance P (six-entry,
    ``P0``); ``x0`` (m, 3) their prior means. Sample k is accepted when
    NIS = Σᵢ yᵢ(k)² / S(k) ≤ ``threshold``, S = P(k|k−1)₀₀ + R, and, if sample k−1 was
    rejected, NIS ≤ Σᵢ dᵢ² / (2R) with d = z(k) − z(k−1) − ṡ(k|k−1) Δt (nearer the
    track than the run of rejections); otherwise it gets the prediction only. When
    ``reacquire_samples`` consecutive samples have been rejected and ``reacquire_s``
    seconds have passed since the last accepted one, the filter returns to the first of
    them, b, and re-acquires there:

    1. If the last re-acquisition, at a, was at most ``excursion_s`` before and sample
       b agrees (NIS ≤ ``threshold``) with the state before a predicted to b, the data
       went out and came back: samples a … b−1 are rejected, the re-acquisition at a
       undone, and the filter goes on from that prediction, updated with b.
    2. Else, if the re-acquisition at a (within ``excursion_s``) was of the position
       alone, the filter returns to a and restarts the track there: J = y(a)ᵀy(a) is
       added to the predicted position variance and J/T² to the rate's (T the interval
       into a): the rate jumped too.
    3. Else the position jumps at b: J = y(b)ᵀy(b) added to its predicted variance,
       the rate kept (a receiver that re-acquires with a new offset).

    The re-acquired sample is accepted and the gate goes on from it. Outputs
    ``accept`` (N,), ``jump`` (N, 2) the variances (position, rate) added at each
    sample (zeros elsewhere) for :func:`_rts_kernel`, and ``nis`` (N,) the NIS of every
    sample against the final filter's prediction.
    """
    n, m = z.shape
    x = x0.copy()
    P = P0.copy()
    x_prev = x.copy()  # x(k−1|k−1), P(k−1|k−1): where a run of rejections started from
    P_prev = P.copy()
    x_run = x.copy()  # the same at the start of the current run of rejections
    P_run = P.copy()
    x_out = x.copy()  # the same before the last re-acquisition
    P_out = P.copy()
    run_start = -1
    out_start = -1  # the last re-acquisition, while an excursion may end
    out_restart = False  # ... was a restart of the track (position and rate)
    last_accepted_t = t[0]
    force = 0  # re-acquire at k: 1 the position, 2 the track
    y = np.empty(m)
    k = 0
    while k < n:
        x_prev[:] = x
        P_prev[:] = P
        if k:
            _predict_axes(t[k] - t[k - 1], q, x, P)
        squares = 0.0
        for i in range(m):
            y[i] = z[k, i] - x[i, 0]
            squares += y[i] * y[i]
        nis[k] = squares / (P[0] + R)
        if force:
            T = t[k] - t[k - 1] if k else t[1] - t[0]
            jump[k, 0] = squares
            jump[k, 1] = squares / (T * T) if force == 2 else 0.0
            _add_jump(jump[k], P)
            out_restart = force == 2
            force = 0
            ok = True
        else:
            ok = squares <= threshold * (P[0] + R)
            if ok and run_start >= 0:
                # Inside a run of rejections the prediction's variance has grown, and an
                # offset the gate rejected at first may pass it now: the sample ends the
                # run only if it is nearer the predicted track than the rejected sample
                # before it (moved on by the predicted rate), each by its own variance.
                T = t[k] - t[k - 1]
                step = 0.0
                for i in range(m):
                    d = z[k, i] - z[k - 1, i] - x[i, 1] * T
                    step += d * d
                ok = squares / (P[0] + R) <= step / (2.0 * R)
        if ok:
            _update_axes(y, R, x, P)
            accept[k] = True
            run_start = -1
            last_accepted_t = t[k]
            k += 1
            continue
        accept[k] = False
        if run_start < 0:
            run_start = k
            x_run[:] = x_prev
            P_run[:] = P_prev
        if k - run_start + 1 < reacquire_samples or t[k] - last_accepted_t < reacquire_s:
            k += 1
            continue
        b = run_start
        run_start = -1
        if out_start >= 0 and t[b] - t[out_start] <= excursion_s:
            # 1. Back from an excursion? The state before it, predicted to b.
            x[:] = x_out
            P[:] = P_out
            for j in range(out_start, b + 1):
                if j:
                    _predict_axes(t[j] - t[j - 1], q, x, P)
            squares = 0.0
            for i in range(m):
                y[i] = z[b, i] - x[i, 0]
                squares += y[i] * y[i]
            if squares <= threshold * (P[0] + R):
                nis[b] = squares / (P[0] + R)
                _update_axes(y, R, x, P)
                accept[out_start:b] = False
                accept[b] = True
                jump[out_start] = 0.0
                out_start = -1
                last_accepted_t = t[b]
                k = b + 1
                continue
            if not out_restart:  # 2. the position jump at a was not all: restart there
                x[:] = x_out
                P[:] = P_out
                k = out_start
                force = 2
                continue
        # 3. A jump of the position at b.
        x[:] = x_run
        P[:] = P_run
        x_out[:] = x_run
        P_out[:] = P_run
        out_start = b
        k = b
        force = 1


def _default_prior(
    t_s: FloatArray, z: FloatArray, R: float, accel_std: float
) -> tuple[FloatArray, FloatArray]:
    """Return the two-point prior x(0|−1), P(0|−1) of :func:`smooth_axis` (six-entry P)."""
    dt0 = t_s[1] - t_s[0]
    k2 = _PRIOR_INFLATION**2
    x = np.array([z[0], (z[1] - z[0]) / dt0, 0.0])
    P = np.array([k2 * R, 0.0, 0.0, 2.0 * k2 * R / dt0**2, 0.0, accel_std**2])
    return x, P


def _consistent_prior(
    t_s: FloatArray, z: FloatArray, R: float, accel_std: float, threshold: float
) -> tuple[FloatArray, FloatArray]:
    """Return the two-point prior from the first three samples that agree (gated filter).

    ``z`` is (N, m), m axes gated together. Samples k, k+1, k+2 agree when the third is
    where the line through the first two puts it: ρ = z₂ − z₁ − (z₁ − z₀) Δt₁/Δt₀ with
    Σᵢ ρᵢ² ≤ ``threshold`` · Var ρ, Var ρ = R (1 + (1 + c)² + c²) + (σ_m Δt₁ (Δt₀ + Δt₁)/2)²,
    c = Δt₁/Δt₀. With k the first such sample (searched among the first
    :data:`_PRIOR_SEARCH_SAMPLES`; none: k = 0) the prior at t₀ is the line through
    samples k and k + 1, x(0|−1) = [z_k − ż (t_k − t₀), ż, 0], ż = (z_{k+1} − z_k)/Δt_k,
    with P(0|−1) = diag(κ²R (1 + 2 ((t_k − t₀)/Δt_k)²), 2κ²R/Δt_k², σ_m²): the default
    prior of :func:`smooth_axis` when k = 0. Returns x (m, 3) and the six-entry P.
    """
    n = t_s.size
    dt = np.diff(t_s)
    start = 0
    for k in range(min(n - 2, _PRIOR_SEARCH_SAMPLES)):
        c = dt[k + 1] / dt[k]
        rho = z[k + 2] - z[k + 1] - (z[k + 1] - z[k]) * c
        var = (
            R * (1.0 + (1.0 + c) ** 2 + c * c)
            + (accel_std * dt[k + 1] * (dt[k] + dt[k + 1]) / 2.0) ** 2
        )
        if float(np.sum(rho * rho)) <= threshold * var:
            start = k
            break
    rate = (z[start + 1] - z[start]) / dt[start]
    lead = (t_s[start] - t_s[0]) / dt[start]
    k2 = _PRIOR_INFLATION**2
    x = np.zeros((z.shape[1], 3))
    x[:, 0] = z[start] - rate * (t_s[start] - t_s[0])
    x[:, 1] = rate
    P = np.array(
        [k2 * R * (1.0 + 2.0 * lead * lead), 0.0, 0.0, 2.0 * k2 * R / dt[start] ** 2, 0.0,
         accel_std**2]
    )  # fmt: skip
    return x, P


def _gate(
    t_s: FloatArray,
    z: FloatArray,
    R: float,
    accel_std: float,
    tau_s: float,
    threshold: float,
    prior: tuple[FloatArray, FloatArray] | None = None,
) -> tuple[NDArray[np.bool_], FloatArray, float, FloatArray, FloatArray]:
    """Run the innovation gate on the axes ``z`` (N, m) gated together.

    A first pass at :data:`_CALIBRATION_GATE` × ``threshold`` rejects only gross
    glitches; the 99th percentile of the NIS of the samples it accepted, over that of
    χ² with m degrees of freedom, is λ (floored at 1, and at most
    :data:`TAIL_RATIO_MAX` × the same ratio of the 90th percentiles), and the gate runs
    at λ · ``threshold`` (see the module notes). ``prior`` (x (m, 3), six-entry P)
    replaces :func:`_consistent_prior`. Returns the accepted samples (N,), the
    re-acquisition variances (N, 2), λ and the prior used.
    """
    x0, P0 = _consistent_prior(t_s, z, R, accel_std, threshold) if prior is None else prior
    n, m = z.shape
    q = 2.0 * accel_std**2 / tau_s

    def run(level: float) -> tuple[NDArray[np.bool_], FloatArray, FloatArray]:
        accept, jump, nis = np.ones(n, dtype=np.bool_), np.zeros((n, 2)), np.empty(n)
        _gate_kernel(
            t_s, z, R, q, x0, P0, level, REACQUIRE_SAMPLES, REACQUIRE_S, EXCURSION_S,
            accept, jump, nis,
        )  # fmt: skip
        return accept, jump, nis

    accept, _, nis = run(_CALIBRATION_GATE * threshold)
    kept = nis[accept]
    tail = float(np.quantile(kept, 0.99)) / _CHI2_99[m - 1]
    body = float(np.quantile(kept, 0.90)) / _CHI2_90[m - 1]
    scale = max(1.0, min(tail, TAIL_RATIO_MAX * body))
    accept, jump, _ = run(scale * threshold)
    return accept, jump, scale, x0, P0


def smooth_axis(
    t_s: ArrayLike,
    z: ArrayLike,
    meas_std: float,
    accel_std: float,
    tau_s: float = DEFAULT_TAU_S,
    *,
    x0: ArrayLike | None = None,
    P0: ArrayLike | None = None,
    gate: bool = False,
) -> AxisSmoothing:
    """Smooth one axis with a constant-acceleration Kalman filter and the RTS smoother.

    Forward pass, Shi et al. (2009), eq. (7), with H = [1 0 0], R = σ_z²,
    Φ_k = Φ(t_k − t_{k−1}), Q_k = Q(t_k − t_{k−1}) (:func:`constant_acceleration_model`)::

        x(k|k−1) = Φ_k x(k−1|k−1)
        P(k|k−1) = Φ_k P(k−1|k−1) Φ_kᵀ + Q_k
        y(k)     = z(k) − H x(k|k−1),       S(k) = H P(k|k−1) Hᵀ + R
        K(k)     = P(k|k−1) Hᵀ / S(k)
        x(k|k)   = x(k|k−1) + K(k) y(k)
        P(k|k)   = P(k|k−1) − P(k|k−1) Hᵀ H P(k|k−1) / S(k)

    (the last line is (I − KH)P written so that it stays exactly symmetric).
    Backward pass, fixed-interval RTS smoother, eq. (8), from x(N|N) = x(N)::

        A(k)     = P(k|k) Φ_{k+1}ᵀ P(k+1|k)⁻¹
        x(k|N)   = x(k|k) + A(k) [x(k+1|N) − x(k+1|k)]
        P(k|N)   = P(k|k) + A(k) [P(k+1|N) − P(k+1|k)] A(k)ᵀ

    Both passes are compiled (numba); the backward pass works block by block from
    checkpoints of the forward pass (:func:`_rts_kernel`), so that only the results
    grow with N.

    Initialisation. The paper starts at the second sample with the two-point estimate
    X(2) = [Z(2), (Z(2) − Z(1))/T, 0] and P(2) = [[σ², σ²/T, 0], [σ²/T, 2σ²/T², 0],
    [0, 0, 0]]. To get estimates at every sample, the default here is a broad prior at
    the *first* sample built from the same two points:
    x(0|−1) = [z₀, (z₁ − z₀)/Δt₀, 0] with P(0|−1) = diag(κ²σ², 2κ²σ²/Δt₀², σ_m²),
    κ = 10, and the first update (k = 0) applied to it like every other. Inflating the
    two-point variances by κ² gives the prior a weight of 1/κ² = 1 % against the data
    it was built from, so z₀ and z₁ are in effect counted once; the acceleration prior
    is Singer's stationary variance σ_m². A larger κ buys little and costs accuracy:
    the smoothed covariance at the first samples is a difference of terms of order
    κ²σ², so about 2 log₁₀ κ digits are lost there (with κ = 10 it agrees with an
    extended-precision reference to ~1e−12 relative).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, strictly increasing, spacing may be irregular [s].
    z : array_like, shape (N,)
        Measurements of the axis [axis unit].
    meas_std : float
        Measurement noise standard deviation σ_z [axis unit].
    accel_std : float
        Singer acceleration standard deviation σ_m [axis unit/s²].
    tau_s : float, optional
        Singer time constant τ = 1/α [s]; only q = 2σ_m²/τ enters Q.
    x0 : array_like, shape (3,), optional
        Prior mean x(0|−1) at the first sample, replacing the default above.
    P0 : array_like, shape (3, 3), optional
        Prior covariance P(0|−1), replacing the default above.
    gate : bool, optional
        Reject glitches by the innovation gate of the module notes, at
        :data:`GATE_NIS_HEADING` (χ²₁); the default prior then comes from the first
        three samples that agree with each other (the same as above when those are
        the first three). Default False: every sample is used.

    Returns
    -------
    AxisSmoothing
        Filtered and smoothed states and covariances, innovations, rejected samples.

    Raises
    ------
    ValueError
        Fewer than 3 samples, mismatched lengths, non-finite values, time not strictly
        increasing, non-positive noise levels or a malformed prior.

    """
    t = _as_series(t_s, "time_s")
    zs = _as_series(z, "z")
    _check_same_length(t, z=zs)
    _check_time(t)
    R = _check_positive(meas_std, "meas_std") ** 2
    accel_std = _check_positive(accel_std, "accel_std")
    tau_s = _check_positive(tau_s, "tau_s")
    dt = np.diff(t)
    x, P = _default_prior(t, zs, R, accel_std)
    if x0 is not None:
        x = np.array(x0, dtype=float)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise ValueError(f"x0 must be 3 finite numbers, got {x0!r}")
    if P0 is not None:
        P_full = np.array(P0, dtype=float)
        if (
            P_full.shape != (3, 3)
            or not np.all(np.isfinite(P_full))
            or not np.allclose(P_full, P_full.T)
        ):
            raise ValueError(f"P0 must be a finite symmetric 3x3 matrix, got {P0!r}")
        P = P_full[np.triu_indices(3)]

    n = t.size
    accept, jump = np.ones(n, dtype=np.bool_), np.zeros((n, 2))
    if gate:
        given = None if x0 is None else (x[None, :], P)
        if given is None and P0 is not None:
            given = (_consistent_prior(t, zs[:, None], R, accel_std, GATE_NIS_HEADING)[0], P)
        accept, jump, _, x_gated, P = _gate(
            t, zs[:, None], R, accel_std, tau_s, GATE_NIS_HEADING, given
        )
        x = x_gated[0]
    x_s, x_filt, yS = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 2))
    P_s6, P_f6 = np.empty((n, 6)), np.empty((n, 6))
    _rts_kernel(
        dt, zs, R, 2.0 * accel_std**2 / tau_s, x, P, accept, jump, RTS_BLOCK_SAMPLES,
        x_s, np.empty((n, 2)), P_s6, x_filt, P_f6, yS,
    )  # fmt: skip
    y_all, S_all = yS[:, 0].copy(), yS[:, 1].copy()
    used = accept[1:]
    S1, y1 = S_all[1:][used], y_all[1:][used]
    log_likelihood = -0.5 * float(np.sum(np.log(2.0 * np.pi * S1) + y1 * y1 / S1))
    return AxisSmoothing(
        time_s=_readonly(t),
        x_filtered=_readonly(x_filt),
        P_filtered=_readonly(P_f6[:, _SYM_TO_FULL].reshape(n, 3, 3)),
        x_smoothed=_readonly(x_s),
        P_smoothed=_readonly(P_s6[:, _SYM_TO_FULL].reshape(n, 3, 3)),
        innovation=_readonly(y_all),
        innovation_var=_readonly(S_all),
        log_likelihood=log_likelihood,
        meas_std=math.sqrt(R),
        accel_std=accel_std,
        tau_s=tau_s,
        rejected=_readonly(~accept),
        reacquired=_readonly(np.flatnonzero(jump[:, 0])),
    )


# --------------------------------------------------------------------------- noise


def _local_polynomial_weights(
    t_s: FloatArray, window: int, degree: int, derivative: int
) -> tuple[NDArray[np.intp], FloatArray]:
    """Least-squares local polynomial weights for one derivative, one window per sample.

    For sample i the window is the ``window`` consecutive samples centred on i (shifted
    inwards at the ends). A polynomial of ``degree`` in (t − t_i) is fitted by least
    squares, and its ``derivative``-th derivative at t_i is a linear combination
    w_i · z[start_i : start_i + window] of the window's data.

    Returns
    -------
    start : ndarray of int, shape (N,)
        Index of each window's first sample.
    w : ndarray, shape (N, window)
        The weights w_i [axis unit⁻¹ ... per s^derivative].

    """
    n = t_s.size
    start = np.clip(np.arange(n) - window // 2, 0, n - window)
    idx = start[:, None] + np.arange(window)
    # Each window's own time scale, so that τ ∈ [−1, 1] wherever the window lies: a gap
    # elsewhere in the log (irregular sampling) does not degrade the other windows.
    h = np.max(np.abs(t_s[idx] - t_s[:, None]), axis=1)  # (N,), > 0: times increase
    tau = (t_s[idx] - t_s[:, None]) / h[:, None]  # (N, window)
    powers = np.empty((2 * degree + 1, n, window))  # τ^m, m = 0 … 2·degree
    powers[0] = 1.0
    for m in range(1, 2 * degree + 1):
        powers[m] = powers[m - 1] * tau
    moments = powers.sum(axis=2).T  # Σ τ^m over the window, (N, 2·degree + 1)
    d = np.arange(degree + 1)
    VtV = moments[:, d[:, None] + d[None, :]]  # normal matrix (VᵀV)_ij = Σ τ^(i+j)
    e = np.zeros((n, degree + 1, 1))
    e[:, derivative, 0] = math.factorial(derivative) / h**derivative
    # w = e_dᵀ (VᵀV)⁻¹ Vᵀ, the factor d!/h^d turning the τ-coefficient into the derivative.
    try:
        g = np.linalg.solve(VtV, e)[..., 0]  # (N, degree + 1)
    except np.linalg.LinAlgError:
        # A window across a gap far longer than its other intervals has too few distinct
        # times for the polynomial: the least-norm fit there (its residual is an outlier,
        # which the estimator's clipping discards); the other windows are unchanged.
        g = (np.linalg.pinv(VtV) @ e)[..., 0]
    return start, np.einsum("nd,dnw->nw", g, powers[: degree + 1])


def _normalised_residuals(t_s: FloatArray, z: FloatArray, window: int, degree: int) -> FloatArray:
    """Residual of each sample from its local polynomial fit over its own noise gain.

    e_i = (e_c − w_i)·z / ‖e_c − w_i‖, w_i the fit's weights of :func:`_local_polynomial_weights`
    (see :func:`estimate_noise`): Var e_i = σ² where the signal is locally a polynomial.
    """
    n = t_s.size
    start, fit = _local_polynomial_weights(t_s, window, degree, 0)
    windows = np.lib.stride_tricks.sliding_window_view(z, window)[start]  # (N, w)
    gain = -fit  # e_c − w_i
    gain[np.arange(n), np.arange(n) - start] += 1.0
    return np.einsum("ij,ij->i", gain, windows) / np.sqrt(np.einsum("ij,ij->i", gain, gain))


def estimate_noise(
    t_s: ArrayLike,
    z: ArrayLike,
    *,
    window: int = 9,
    degree: int = 3,
    accel_window_s: float = 30.0,
) -> NoiseEstimate:
    """Estimate an axis' measurement noise and acceleration level from its data.

    Measurement noise. Around every sample i a polynomial of ``degree`` (cubic) is fitted
    by least squares to the ``window`` nearest samples (irregular times allowed) and the
    residual at the sample itself, e_i = z_i − ẑ_i = (e_c − w_i)·z, is normalised by its
    own noise gain ‖e_c − w_i‖ (= √(1 − h_ii), h the hat matrix), so that
    Var(e_i / ‖e_c − w_i‖) = σ² exactly whenever the signal is locally a cubic. A short
    window keeps the model error negligible for a ship (at 1 Hz a 9-s cubic misses a
    500-m-radius turn at 8 m/s by under 1 mm).

    Outliers (GNSS glitches of tens to thousands of metres, heading spikes) are left
    out first: a sample whose normalised residual exceeds :data:`OUTLIER_SIGMAS` (8)
    robust standard deviations (the upper quartile of |e| over its Gaussian value
    1.150, leaving out residuals that are zero to rounding: quantised positions often
    lie exactly on their local cubic) is dropped (a glitch drags the residuals of its
    neighbours, whose fits include it, out with it: they go too, which costs only a
    little data), and the residuals are fitted again on the samples left, irregularly
    spaced now, for up to five passes or until none exceeds that level (at most half
    the samples are dropped). On data without such outliers nothing is dropped, and the
    estimate is what it was without this step (bit for bit on the synthetic KVLCC2 logs
    and the HSVA model tests). σ is then the RMS of the normalised residuals after discarding
    those beyond 4 robust standard deviations (1.4826 × median |e|) and corrected for
    that truncation (a factor 1.0005 for Gaussian noise).

    Acceleration level (default process noise). A quadratic is fitted in the same way
    over a longer window of about ``accel_window_s`` (on every m-th sample, m chosen so
    that the window has about 31 samples: 1 at 1 Hz, 10 at 10 Hz); its second
    derivative â_i has noise variance σ² ‖g_i‖², g_i its weights. The Singer σ_m is the
    RMS acceleration of the signal: σ_m² = mean(â_i²) − σ² mean(‖g_i‖²), floored at
    σ² mean(‖g_i‖²) (an acceleration level below the fit's own noise cannot be
    resolved, and q must stay positive). This fit uses the samples left after the
    outlier passes: one glitch of 1000 m would otherwise multiply σ_m many times over.
    (A step that stays, or a plateau of many samples, is not an outlier of the local
    fits; :func:`smooth_track` estimates again without what its gate rejected.)

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, strictly increasing [s].
    z : array_like, shape (N,)
        Measurements of the axis [axis unit]. Angles must be unwrapped.
    window : int, optional
        Samples in each noise-fit window (needs at least ``degree + 2``).
    degree : int, optional
        Degree of the noise-fit polynomial.
    accel_window_s : float, optional
        Duration of the acceleration-fit window [s] (at least 5 samples).

    Returns
    -------
    NoiseEstimate
        ``meas_std`` [axis unit] and ``accel_std`` [axis unit/s²].

    Raises
    ------
    ValueError
        Bad time or data (as :func:`smooth_axis`), or fewer samples than ``degree + 2``.

    """
    t = _as_series(t_s, "time_s")
    zs = _as_series(z, "z")
    _check_same_length(t, z=zs)
    _check_time(t, min_samples=3)
    if degree < 0 or window < degree + 2:
        raise ValueError(f"window ({window}) must exceed degree ({degree}) by at least 2")
    n = t.size
    if n < degree + 2:
        raise ValueError(
            f"at least {degree + 2} samples are needed to estimate the noise, got {n}; "
            "give the noise levels explicitly"
        )
    w = min(window, n)

    # Measurement noise from the local-cubic residual at each sample; samples whose
    # residual is an outlier are left out and the residuals fitted again without them.
    floor = 1e-9 * (1.0 + float(np.max(np.abs(zs))))  # keeps R > 0 on noise-free data
    for passes in itertools.count():
        e = _normalised_residuals(t, zs, w, degree)
        scale = 1.482602218505602 * float(np.median(np.abs(e)))
        # The outlier level from the residuals that are not zero to rounding (samples
        # exactly on their local cubic: quantised or noise-free data), whose upper
        # quartile is σ × 1.150 for Gaussian noise.
        size = np.abs(e)
        inexact = size[size > floor]
        if passes == _OUTLIER_PASSES or inexact.size < w:
            break
        level = OUTLIER_SIGMAS * float(np.quantile(inexact, 0.75)) / _GAUSSIAN_Q75
        good = size <= level
        left = np.count_nonzero(good)
        if left == e.size or left < max(w, n // 2):
            break
        t, zs = t[good], zs[good]
    kept = e[np.abs(e) <= _CLIP_SIGMAS * scale] if scale > 0.0 else e
    c = _CLIP_SIGMAS
    phi_c = math.exp(-0.5 * c * c) / math.sqrt(2.0 * math.pi)
    truncation = 1.0 - 2.0 * c * phi_c / math.erf(c / math.sqrt(2.0)) if scale > 0.0 else 1.0
    meas_std = max(math.sqrt(float(np.mean(kept**2)) / truncation), floor)

    # Acceleration level from a longer local quadratic, on every step-th sample so that
    # a window has about _ACCEL_FIT_SAMPLES of them at any rate (the acceleration of a
    # manoeuvre is resolved by them; the cost stays O(N)).
    step = max(1, round((_accel_window(t, accel_window_s) - 1) / (_ACCEL_FIT_SAMPLES - 1)))
    t, zs = t[::step], zs[::step]
    wa = _accel_window(t, accel_window_s)
    start_a, g = _local_polynomial_weights(t, wa, 2, 2)  # â = g_i · z
    windows_a = np.lib.stride_tricks.sliding_window_view(zs, wa)[start_a]
    accel = np.einsum("ij,ij->i", g, windows_a)
    noise_var = meas_std**2 * float(np.mean(np.einsum("ij,ij->i", g, g)))
    accel_var = max(float(np.mean(accel**2)) - noise_var, noise_var)
    return NoiseEstimate(meas_std=meas_std, accel_std=math.sqrt(accel_var))


# --------------------------------------------------------------------------- track


NOISE_CHUNK_SAMPLES = 20_000
"""Noise is estimated in chunks of at most this many samples and pooled (bounded memory)."""

NOISE_MAX_SAMPLES = 200_000
"""A longer series is estimated on chunks of this many samples in all, spread evenly."""


def _accel_window(t_s: FloatArray, accel_window_s: float) -> int:
    """Return the samples of the acceleration-fit window of about ``accel_window_s`` [s] (≥ 5)."""
    dt_med = float(np.median(np.diff(t_s)))
    return min(max(5, round(accel_window_s / dt_med) + 1), t_s.size)


def _pooled_noise(t_s: FloatArray, z: FloatArray, accel_window_s: float = 30.0) -> NoiseEstimate:
    """Run :func:`estimate_noise` on chunks of a long series and pool the variances.

    ``estimate_noise`` needs memory proportional to samples × window; chunks of
    :data:`NOISE_CHUNK_SAMPLES` samples keep that within about 20 MB. Variances are
    averaged weighted by the chunk lengths (a trailing chunk shorter than half a chunk
    joins the previous one). Two noise levels are all that is estimated, so a series
    longer than :data:`NOISE_MAX_SAMPLES` is estimated on that many samples, in chunks
    spread evenly over it (the estimate's relative standard error is then about
    1/√(2 · 200,000) = 0.2 %).
    """
    n = t_s.size
    chunk = NOISE_CHUNK_SAMPLES
    if n <= chunk:
        return estimate_noise(t_s, z, accel_window_s=accel_window_s)
    if n > NOISE_MAX_SAMPLES:
        count = max(NOISE_MAX_SAMPLES // chunk, 1)
        starts = np.linspace(0, n - chunk, count).astype(int).tolist()
        spans = [(start, start + chunk) for start in starts]
    else:
        edges = [*range(0, n, chunk), n]
        if n - edges[-2] < chunk // 2:
            del edges[-2]
        spans = list(itertools.pairwise(edges))
    meas_var = accel_var = 0.0
    used = 0
    for start, stop in spans:
        part = estimate_noise(t_s[start:stop], z[start:stop], accel_window_s=accel_window_s)
        meas_var += part.meas_std**2 * (stop - start)
        accel_var += part.accel_std**2 * (stop - start)
        used += stop - start
    return NoiseEstimate(meas_std=math.sqrt(meas_var / used), accel_std=math.sqrt(accel_var / used))


def _segment_noise(
    t_s: FloatArray, axes: tuple[FloatArray, ...], keep: NDArray[np.bool_], cuts: NDArray[np.bool_]
) -> tuple[float, float]:
    """Noise levels of ``axes`` from the samples ``keep``, apart between the ``cuts``.

    The samples are split before every sample where ``cuts`` is True; each piece of at
    least :data:`_MIN_NOISE_SAMPLES` kept samples is estimated by :func:`_pooled_noise`,
    and the variances are pooled over the pieces (weighted by their kept samples) and
    the axes (RMS). Returns (measurement noise std, acceleration std) [axis units];
    (nan, nan) when no piece is long enough.
    """
    starts = np.flatnonzero(cuts)
    meas_var = accel_var = 0.0
    used = 0
    for piece in np.split(np.arange(t_s.size), starts[starts > 0]):
        index = piece[keep[piece]]
        if index.size < _MIN_NOISE_SAMPLES:
            continue
        for z in axes:
            part = _pooled_noise(t_s[index], z[index])
            meas_var += part.meas_std**2 * index.size
            accel_var += part.accel_std**2 * index.size
            used += index.size
    if not used:
        return math.nan, math.nan
    return math.sqrt(meas_var / used), math.sqrt(accel_var / used)


def _noise_levels(
    t_s: FloatArray,
    axes: tuple[FloatArray, ...],
    meas_std: float | None,
    accel_std: float | None,
    names: tuple[str, str],
) -> tuple[float, float]:
    """Return the (measurement, acceleration) noise levels of ``axes`` gated together.

    Those not given (None) are estimated by :func:`_pooled_noise` of each axis, pooled as
    the RMS over the axes (one isotropic level for x and y); both checked positive
    (``names``: the arguments' names, for the error).
    """
    if meas_std is None or accel_std is None:
        estimates = [_pooled_noise(t_s, z) for z in axes]
        rms = math.sqrt(len(axes))
        if meas_std is None:
            meas_std = math.hypot(*(e.meas_std for e in estimates)) / rms
        if accel_std is None:
            accel_std = math.hypot(*(e.accel_std for e in estimates)) / rms
    return _check_positive(meas_std, names[0]), _check_positive(accel_std, names[1])


def _gated(
    t_s: FloatArray,
    axes: tuple[FloatArray, ...],
    meas_std: float,
    accel_std: float,
    tau_s: float,
    threshold: float,
    given: tuple[float | None, float | None],
) -> tuple[NDArray[np.bool_], FloatArray, float, list[tuple[FloatArray, FloatArray]], float, float]:
    """Run the innovation gate (:func:`_gate`) on ``axes`` gated together.

    When it rejected or re-acquired anything, the levels not ``given`` (measurement,
    acceleration) are estimated again without the rejected samples and apart on either
    side of a re-acquisition (:func:`_segment_noise`: a step widens the acceleration
    level), and the gate runs again with them. Returns the accepted samples, the
    re-acquisition variances, λ, each axis' prior (x0, P0) and the levels used.
    """
    z = np.column_stack(axes)
    accept, jump, scale, x0, P0 = _gate(t_s, z, meas_std**2, accel_std, tau_s, threshold)
    if (None in given) and (not accept.all() or jump.any()):
        meas_again, accel_again = _segment_noise(t_s, axes, accept, jump[:, 0] != 0.0)
        if math.isfinite(meas_again):  # else no piece long enough: keep the first
            meas_std = meas_std if given[0] is not None else meas_again
            accel_std = accel_std if given[1] is not None else accel_again
            accept, jump, scale, x0, P0 = _gate(t_s, z, meas_std**2, accel_std, tau_s, threshold)
    priors = [(x0[i], P0) for i in range(len(axes))]
    return accept, jump, scale, priors, meas_std, accel_std


def smooth_track(
    t_s: ArrayLike,
    x_m: ArrayLike,
    y_m: ArrayLike,
    heading_rad: ArrayLike,
    *,
    position_noise_m: float | None = None,
    heading_noise_rad: float | None = None,
    position_accel_std_mps2: float | None = None,
    heading_accel_std_radps2: float | None = None,
    tau_s: float = DEFAULT_TAU_S,
    gate: bool = True,
) -> SmoothedTrack:
    """Smooth a ship track and derive U, χ, β, u, v, r, Shi et al. (2009), eqs. (6)–(9).

    x, y and the unwrapped heading are smoothed independently by :func:`smooth_axis`.
    Then, with ψ the smoothed heading, eq. (9)::

        U = √(ẋ² + ẏ²),  χ = atan2(ẏ, ẋ),  β = χ − ψ,  u = U cos β,  v = U sin β,  r = ψ̇,

    evaluated as u = ẋ cos ψ + ẏ sin ψ, v = −ẋ sin ψ + ẏ cos ψ (identical, and free of
    the atan2 branch). With x North and y East, v > 0 when the ship moves to starboard
    of its heading. First-order variances (axes independent)::

        Var u = cos²ψ Var ẋ + sin²ψ Var ẏ + v² Var ψ
        Var v = sin²ψ Var ẋ + cos²ψ Var ẏ + u² Var ψ
        Var U = (ẋ² Var ẋ + ẏ² Var ẏ) / U²,   Var χ = (ẏ² Var ẋ + ẋ² Var ẏ) / U⁴
        Var β = Var χ + Var ψ,                Var r = P_ψ(k|N)[1, 1]

    Noise levels not given are estimated by :func:`estimate_noise`: for the position,
    x and y are estimated separately and pooled as the RMS of the two (one isotropic
    level for both axes), for measurement noise and acceleration level alike.

    Glitches are rejected by the innovation gate of the module notes (``gate``): the
    position fix as a pair (x and y share one covariance, so their normalised
    innovation squared is χ²₂ under the model) at :data:`GATE_NIS_POSITION`, the
    heading at :data:`GATE_NIS_HEADING`, with re-acquisition after a persistent jump;
    the estimated noise levels are estimated again without what it rejected. On a log
    without glitches the gate rejects nothing (:data:`GATE_FALSE_ALARM` for Gaussian
    innovations; none on any synthetic or HSVA log tried), and the result is the
    ungated one bit for bit.

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, strictly increasing, spacing may be irregular [s].
    x_m, y_m : array_like, shape (N,)
        Measured North and East positions [m].
    heading_rad : array_like, shape (N,)
        Measured heading, wrapped (0..2π or ±π) or continuous [rad]; it is unwrapped
        before filtering (``trials.angles.unwrap_heading``, robust to compass spikes),
        so the smoothed heading is continuous.
    position_noise_m : float, optional
        Position measurement noise standard deviation [m]; estimated if None.
    heading_noise_rad : float, optional
        Heading measurement noise standard deviation [rad]; estimated if None.
    position_accel_std_mps2 : float, optional
        Singer acceleration standard deviation σ_m of x and y [m/s²]; estimated
        (RMS acceleration of the track) if None.
    heading_accel_std_radps2 : float, optional
        Singer σ_m of the heading [rad/s²]; estimated if None.
    tau_s : float, optional
        Singer manoeuvre time constant τ [s], default :data:`DEFAULT_TAU_S`.
    gate : bool, optional
        Reject glitches (default True); False uses every sample (the plain
        smoother of eqs. (6)–(8)).

    Returns
    -------
    SmoothedTrack
        Smoothed states and their variances (derived velocities and standard
        deviations as properties), the noise levels used, the rejected samples.

    Raises
    ------
    ValueError
        Fewer than 3 samples, mismatched lengths, non-finite values, time not strictly
        increasing, non-positive noise levels; fewer than 5 samples when a noise level
        has to be estimated.

    """
    t = _as_series(t_s, "time_s")
    xm = _as_series(x_m, "x_m")
    ym = _as_series(y_m, "y_m")
    psi_meas = _as_series(heading_rad, "heading_rad")
    _check_same_length(t, x_m=xm, y_m=ym, heading_rad=psi_meas)
    _check_time(t)
    psi_meas = unwrap_heading(psi_meas)
    given = {
        "position": (position_noise_m, position_accel_std_mps2),
        "heading": (heading_noise_rad, heading_accel_std_radps2),
    }
    position_levels = _noise_levels(
        t, (xm, ym), *given["position"], ("position_noise_m", "position_accel_std_mps2")
    )
    heading_levels = _noise_levels(
        t, (psi_meas,), *given["heading"], ("heading_noise_rad", "heading_accel_std_radps2")
    )
    tau_s = _check_positive(tau_s, "tau_s")
    groups = {
        "position": ((xm, ym), *position_levels, GATE_NIS_POSITION),
        "heading": ((psi_meas,), *heading_levels, GATE_NIS_HEADING),
    }

    n = t.size
    states = np.empty((3, n, 3))
    variances = np.empty((3, n, 2))
    dt = np.diff(t)
    none = np.empty((0, 6))
    levels: dict[str, tuple[float, float]] = {}
    rejected, reacquired, scales = [], [], []
    axis = 0
    for name, (axes, meas_std, accel_std, threshold) in groups.items():
        if gate:
            accept, jump, scale, priors, meas_std, accel_std = _gated(
                t, axes, meas_std, accel_std, tau_s, threshold, given[name]
            )
        else:
            accept, jump, scale = np.ones(n, dtype=np.bool_), np.zeros((n, 2)), 1.0
            priors = [_default_prior(t, z, meas_std**2, accel_std) for z in axes]
        levels[name] = (meas_std, accel_std)
        scales.append(scale)
        rejected.append(_readonly(np.flatnonzero(~accept)))
        reacquired.append(_readonly(np.flatnonzero(jump[:, 0])))
        R, q = meas_std**2, 2.0 * accel_std**2 / tau_s
        for z, (x0, P0) in zip(axes, priors, strict=True):
            _rts_kernel(
                dt, z, R, q, x0, P0, accept, jump, RTS_BLOCK_SAMPLES,
                states[axis], variances[axis], none, none[:, :3], none, none[:, :2],
            )  # fmt: skip
            axis += 1
    position_noise_m, position_accel_std_mps2 = levels["position"]
    heading_noise_rad, heading_accel_std_radps2 = levels["heading"]
    return SmoothedTrack(
        time_s=_readonly(t),
        states=_readonly(states),
        variances=_readonly(variances),
        position_noise_m=position_noise_m,
        heading_noise_rad=heading_noise_rad,
        position_accel_std_mps2=position_accel_std_mps2,
        heading_accel_std_radps2=heading_accel_std_radps2,
        tau_s=tau_s,
        position_rejected=rejected[0],
        heading_rejected=rejected[1],
        position_reacquired=reacquired[0],
        heading_reacquired=reacquired[1],
        position_gate_scale=scales[0],
        heading_gate_scale=scales[1],
    )


def smooth_log(log: ManeuverLog) -> SmoothedTrack:
    """Smooth a log's track with noise levels estimated from it (as ``identify`` does).

    Parameters
    ----------
    log : ManeuverLog
        The log: x, y [m], heading [rad] over time [s].

    Returns
    -------
    SmoothedTrack
        The RTS-smoothed track (:func:`smooth_track`).

    """
    return smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)


def smoothed_trajectory(log: ManeuverLog, track: SmoothedTrack) -> np.ndarray:
    """Return ``log`` as a trajectory of its smoothed ``track``, rudder and rpm as logged.

    What a logged manoeuvre's indices are read off (``trials.conditions.maneuver_indices``:
    the scenarios' ``--like``, ``identifier.crossval``): a zig-zag's heading peaks are flat,
    and the peak of a 1 Hz log's raw headings with 0.1° of noise put its time to check
    yaw 0.3–0.54 s off in four draws of four (``tests/test_scenarios_cli.py``).
    """
    states = np.column_stack(
        (track.u_mps, track.v_mps, track.r_radps, track.x_m, track.y_m, track.heading_rad)
    )
    return trajectory_of(log.time_s, states, log.rudder_rad, log.n_rps)


def deglitched_log(log: ManeuverLog, track: SmoothedTrack) -> ManeuverLog:
    """Return ``log`` with the fixes and headings ``track``'s gate rejected replaced.

    By the smoothed track there (:meth:`SmoothedTrack.deglitched`): what reads the logged
    track itself after smoothing (the EKF, output error, a logged manoeuvre's indices and
    condition) sees no GNSS jump or compass spike. ``log`` itself when nothing was
    rejected.
    """
    if not (track.rejected_position_samples or track.rejected_heading_samples):
        return log
    x_m, y_m, heading_rad = track.deglitched(log.x_m, log.y_m, log.heading_rad)
    return replace(log, x_m=x_m, y_m=y_m, heading_rad=heading_rad)
