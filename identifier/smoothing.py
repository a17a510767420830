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

Units: an axis carries its own units ([m, m/s, m/s²] for positions,
[rad, rad/s, rad/s²] for heading); arguments documented "[axis unit]" follow them.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = [
    "DEFAULT_TAU_S",
    "AxisSmoothing",
    "NoiseEstimate",
    "SmoothedTrack",
    "constant_acceleration_model",
    "estimate_noise",
    "smooth_axis",
    "smooth_track",
    "wrap_angle",
]

FloatArray = NDArray[np.float64]

#: Default Singer manoeuvre time constant τ = 1/α [s]. Singer (1970) suggests about 60 s
#: for a lazy turn and 20 s for an evasive manoeuvre; a ship answering hard rudder
#: (zig-zag, turning circle) is the latter.
DEFAULT_TAU_S = 20.0

#: Inflation κ of the two-point initial covariance (see :func:`smooth_axis`).
_PRIOR_INFLATION = 10.0

#: Clip level of the noise estimator, in robust standard deviations.
_CLIP_SIGMAS = 4.0


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
        Σ_k −½ (ln 2πS(k) + y(k)²/S(k)) over k ≥ 1 (the prior's own sample excluded).
    meas_std : float
        Measurement noise standard deviation √R used [axis unit].
    accel_std : float
        Singer acceleration standard deviation σ_m used [axis unit/s²].
    tau_s : float
        Singer time constant τ = 1/α used [s].

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
    v to starboard, r positive turning to starboard. All arrays have shape (N,)
    and are read-only. Standard deviations are first-order propagations of the
    smoother covariances, the three axes taken as independent.

    Attributes
    ----------
    time_s : ndarray
        Sample times [s].
    x_m, y_m : ndarray
        Smoothed North and East positions [m].
    heading_rad : ndarray
        Smoothed heading ψ, continuous (unwrapped) [rad].
    x_dot_mps, y_dot_mps : ndarray
        Velocity over ground, North and East components [m/s].
    speed_mps : ndarray
        Speed over ground U = √(ẋ² + ẏ²) [m/s].
    course_rad : ndarray
        Course over ground χ = atan2(ẏ, ẋ), in (−π, π] [rad].
    drift_rad : ndarray
        Drift angle β = χ − ψ wrapped to (−π, π] [rad].
    u_mps, v_mps : ndarray
        Surge u = U cos β and sway v = U sin β velocities [m/s].
    r_radps : ndarray
        Yaw rate r = ψ̇ [rad/s].
    u_dot_mps2, v_dot_mps2 : ndarray
        Body-axis derivatives u̇ = ẍ cos ψ + ÿ sin ψ + r v and
        v̇ = −ẍ sin ψ + ÿ cos ψ − r u [m/s²].
    r_dot_radps2 : ndarray
        Yaw acceleration ṙ = ψ̈ [rad/s²].
    x_std_m, y_std_m, heading_std_rad : ndarray
        Standard deviations of the smoothed positions [m] and heading [rad].
    x_dot_std_mps, y_dot_std_mps, speed_std_mps, u_std_mps, v_std_mps : ndarray
        Standard deviations of ẋ, ẏ, U, u, v [m/s].
    course_std_rad, drift_std_rad : ndarray
        Standard deviations of χ and β [rad] (meaningless where U ≈ 0).
    r_std_radps : ndarray
        Standard deviation of r [rad/s].
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
    x_axis, y_axis, heading_axis : AxisSmoothing
        The per-axis filter and smoother results (innovations, full covariances).

    """

    time_s: FloatArray
    x_m: FloatArray
    y_m: FloatArray
    heading_rad: FloatArray
    x_dot_mps: FloatArray
    y_dot_mps: FloatArray
    speed_mps: FloatArray
    course_rad: FloatArray
    drift_rad: FloatArray
    u_mps: FloatArray
    v_mps: FloatArray
    r_radps: FloatArray
    u_dot_mps2: FloatArray
    v_dot_mps2: FloatArray
    r_dot_radps2: FloatArray
    x_std_m: FloatArray
    y_std_m: FloatArray
    heading_std_rad: FloatArray
    x_dot_std_mps: FloatArray
    y_dot_std_mps: FloatArray
    speed_std_mps: FloatArray
    course_std_rad: FloatArray
    drift_std_rad: FloatArray
    u_std_mps: FloatArray
    v_std_mps: FloatArray
    r_std_radps: FloatArray
    position_noise_m: float
    heading_noise_rad: float
    position_accel_std_mps2: float
    heading_accel_std_radps2: float
    tau_s: float
    x_axis: AxisSmoothing
    y_axis: AxisSmoothing
    heading_axis: AxisSmoothing


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


def _readonly(a: FloatArray) -> FloatArray:
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


def _forward(
    dt_s: FloatArray, z: FloatArray, R: float, q: float, x0: FloatArray, P0: FloatArray
) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray, FloatArray, FloatArray]:
    """Kalman filter of eq. (7) for Φ, Q of eq. (6) and H = [1 0 0], unrolled.

    The products are written out for the structure of Φ(T) (upper triangular, with
    h = T²/2) and of H, on the six distinct entries of the symmetric P, which makes a
    step about three times faster than general 3x3 numpy products. With B = Φ P::

        B₀ = P₀ + T P₁ + h P₂,   B₁ = P₁ + T P₂          (rows)
        (Φ P Φᵀ)₀₀ = B₀₀ + T B₀₁ + h B₀₂,   (Φ P Φᵀ)₀₁ = B₀₁ + T B₀₂,   (Φ P Φᵀ)₀₂ = B₀₂,
        (Φ P Φᵀ)₁₁ = B₁₁ + T B₁₂,           (Φ P Φᵀ)₁₂ = B₁₂,           (Φ P Φᵀ)₂₂ = P₂₂,

    and the update P(k|k) = P − P Hᵀ H P / S on each entry: Pᵢⱼ − Pᵢ₀ Pⱼ₀ / S (for the
    first row Pᵢ₀ R / S, the same number without cancellation).

    Returns
    -------
    x_pred, P_pred, x_filt, P_filt : ndarray
        x(k|k−1), P(k|k−1), x(k|k), P(k|k); shapes (N, 3), (N, 3, 3).
    y, S : ndarray, shape (N,)
        Innovations and their variances.

    """
    n = z.size
    x_pred = np.empty((n, 3))
    x_filt = np.empty((n, 3))
    P_pred6 = np.empty((n, 6))
    P_filt6 = np.empty((n, 6))
    yS = np.empty((n, 2))
    dts = [0.0, *dt_s.tolist()]
    zs = z.tolist()
    s, v, a = (float(c) for c in x0)  # position, rate, acceleration
    p00, p01, p02 = float(P0[0, 0]), float(P0[0, 1]), float(P0[0, 2])
    p11, p12, p22 = float(P0[1, 1]), float(P0[1, 2]), float(P0[2, 2])
    for k in range(n):
        if k:
            T = dts[k]
            h = 0.5 * T * T
            # x(k|k-1) = Φ x(k-1|k-1)
            s = s + T * v + h * a
            v = v + T * a
            # P(k|k-1) = Φ P Φᵀ + Q,  Q = q [[T⁵/20, T⁴/8, T³/6], [., T³/3, T²/2], [., ., T]]
            b00 = p00 + T * p01 + h * p02
            b01 = p01 + T * p11 + h * p12
            b02 = p02 + T * p12 + h * p22
            b11 = p11 + T * p12
            b12 = p12 + T * p22
            qT = q * T
            qT2 = qT * T
            qT3 = qT2 * T
            p00 = b00 + T * b01 + h * b02 + qT3 * T * T / 20.0
            p01 = b01 + T * b02 + qT3 * T / 8.0
            p02 = b02 + qT3 / 6.0
            p11 = b11 + T * b12 + qT3 / 3.0
            p12 = b12 + qT2 / 2.0
            p22 = p22 + qT
        x_pred[k] = (s, v, a)
        P_pred6[k] = (p00, p01, p02, p11, p12, p22)
        S = p00 + R  # S = H P Hᵀ + R
        y = zs[k] - s  # y = z − H x
        k0, k1, k2 = p00 / S, p01 / S, p02 / S  # K = P Hᵀ / S
        s, v, a = s + k0 * y, v + k1 * y, a + k2 * y  # x + K y
        p11, p12, p22 = p11 - k1 * p01, p12 - k1 * p02, p22 - k2 * p02  # P − K H P
        p00, p01, p02 = k0 * R, k1 * R, k2 * R
        x_filt[k] = (s, v, a)
        P_filt6[k] = (p00, p01, p02, p11, p12, p22)
        yS[k] = (y, S)
    P_pred = P_pred6[:, _SYM_TO_FULL].reshape(n, 3, 3)
    P_filt = P_filt6[:, _SYM_TO_FULL].reshape(n, 3, 3)
    return x_pred, P_pred, x_filt, P_filt, yS[:, 0].copy(), yS[:, 1].copy()


def _backward(
    F: FloatArray, x_pred: FloatArray, P_pred: FloatArray, x_filt: FloatArray, P_filt: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Fixed-interval RTS smoother, eq. (8), with everything but the recursion batched.

    With A(k) = P(k|k) Φ_{k+1}ᵀ P(k+1|k)⁻¹ (``F[k]`` is Φ_{k+1}, from k to k+1)::

        x(k|N) = c(k) + A(k) x(k+1|N),          c(k) = x(k|k) − A(k) x(k+1|k)
        P(k|N) = B(k) + A(k) P(k+1|N) A(k)ᵀ,    B(k) = P(k|k) − A(k) P(k+1|k) A(k)ᵀ

    A, c and B depend on the forward pass only and are computed for all k at once.
    """
    n = x_filt.shape[0]
    # A(k)ᵀ = P(k+1|k)⁻¹ Φ P(k|k), P(k+1|k) being symmetric.
    A = np.linalg.solve(P_pred[1:], F @ P_filt[:-1]).transpose(0, 2, 1)
    At = A.transpose(0, 2, 1)
    c = x_filt[:-1] - np.einsum("kij,kj->ki", A, x_pred[1:])
    B = P_filt[:-1] - A @ P_pred[1:] @ At
    x_s = np.empty((n, 3))
    P_s = np.empty((n, 3, 3))
    x_s[-1] = x_filt[-1]  # x(N|N) = x(N)
    P_s[-1] = P_filt[-1]
    for k in range(n - 2, -1, -1):
        x_s[k] = c[k] + A[k] @ x_s[k + 1]
        P_s[k] = B[k] + A[k] @ P_s[k + 1] @ At[k]
    return x_s, P_s


def smooth_axis(
    t_s: ArrayLike,
    z: ArrayLike,
    meas_std: float,
    accel_std: float,
    tau_s: float = DEFAULT_TAU_S,
    *,
    x0: ArrayLike | None = None,
    P0: ArrayLike | None = None,
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

    The gains A(k) do not depend on the backward recursion and are computed for all k
    at once; only the two recursions themselves loop over time.

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

    Returns
    -------
    AxisSmoothing
        Filtered and smoothed states and covariances, innovations.

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
    F, _ = constant_acceleration_model(dt, accel_std, tau_s)

    if x0 is None:
        x = np.array([zs[0], (zs[1] - zs[0]) / dt[0], 0.0])
    else:
        x = np.array(x0, dtype=float)
        if x.shape != (3,) or not np.all(np.isfinite(x)):
            raise ValueError(f"x0 must be 3 finite numbers, got {x0!r}")
    if P0 is None:
        k2 = _PRIOR_INFLATION**2
        P = np.diag([k2 * R, 2.0 * k2 * R / dt[0] ** 2, accel_std**2])
    else:
        P = np.array(P0, dtype=float)
        if P.shape != (3, 3) or not np.all(np.isfinite(P)) or not np.allclose(P, P.T):
            raise ValueError(f"P0 must be a finite symmetric 3x3 matrix, got {P0!r}")

    x_pred, P_pred, x_filt, P_filt, y_all, S_all = _forward(
        dt, zs, R, 2.0 * accel_std**2 / tau_s, x, P
    )
    x_s, P_s = _backward(F, x_pred, P_pred, x_filt, P_filt)

    S1, y1 = S_all[1:], y_all[1:]
    log_likelihood = -0.5 * float(np.sum(np.log(2.0 * np.pi * S1) + y1 * y1 / S1))
    return AxisSmoothing(
        time_s=_readonly(t),
        x_filtered=_readonly(x_filt),
        P_filtered=_readonly(P_filt),
        x_smoothed=_readonly(x_s),
        P_smoothed=_readonly(P_s),
        innovation=_readonly(y_all),
        innovation_var=_readonly(S_all),
        log_likelihood=log_likelihood,
        meas_std=math.sqrt(R),
        accel_std=accel_std,
        tau_s=tau_s,
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
    500-m-radius turn at 8 m/s by under 1 mm). σ is the RMS of these normalised residuals after
    discarding those beyond 4 robust standard deviations (1.4826 × median |e|), to
    tolerate outliers, and corrected for that truncation (a factor 1.0005 for Gaussian
    noise).

    Acceleration level (default process noise). A quadratic is fitted in the same way
    over a longer window of about ``accel_window_s``; its second derivative â_i has noise
    variance σ² ‖g_i‖², g_i its weights. The Singer σ_m is the RMS acceleration of the
    signal: σ_m² = mean(â_i²) − σ² mean(‖g_i‖²), floored at σ² mean(‖g_i‖²) (an
    acceleration level below the fit's own noise cannot be resolved, and q must stay
    positive).

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

    # Measurement noise from the local-cubic residual at each sample.
    start, fit = _local_polynomial_weights(t, w, degree, 0)
    windows = np.lib.stride_tricks.sliding_window_view(zs, w)[start]  # (N, w)
    gain = -fit  # e_c − w_i
    gain[np.arange(n), np.arange(n) - start] += 1.0
    e = np.einsum("ij,ij->i", gain, windows) / np.sqrt(np.einsum("ij,ij->i", gain, gain))
    scale = 1.482602218505602 * float(np.median(np.abs(e)))
    kept = e[np.abs(e) <= _CLIP_SIGMAS * scale] if scale > 0.0 else e
    c = _CLIP_SIGMAS
    phi_c = math.exp(-0.5 * c * c) / math.sqrt(2.0 * math.pi)
    truncation = 1.0 - 2.0 * c * phi_c / math.erf(c / math.sqrt(2.0)) if scale > 0.0 else 1.0
    floor = 1e-9 * (1.0 + float(np.max(np.abs(zs))))  # keeps R > 0 on noise-free data
    meas_std = max(math.sqrt(float(np.mean(kept**2)) / truncation), floor)

    # Acceleration level from a longer local quadratic.
    dt_med = float(np.median(np.diff(t)))
    wa = min(max(5, round(accel_window_s / dt_med) + 1), n)
    start_a, g = _local_polynomial_weights(t, wa, 2, 2)  # â = g_i · z
    windows_a = np.lib.stride_tricks.sliding_window_view(zs, wa)[start_a]
    accel = np.einsum("ij,ij->i", g, windows_a)
    noise_var = meas_std**2 * float(np.mean(np.einsum("ij,ij->i", g, g)))
    accel_var = max(float(np.mean(accel**2)) - noise_var, noise_var)
    return NoiseEstimate(meas_std=meas_std, accel_std=math.sqrt(accel_var))


# --------------------------------------------------------------------------- track


NOISE_CHUNK_SAMPLES = 20_000
"""Noise is estimated in chunks of this many samples and pooled (bounded memory)."""


def _pooled_noise(t_s: FloatArray, z: FloatArray) -> NoiseEstimate:
    """Run :func:`estimate_noise` on chunks of a long series and pool the variances.

    ``estimate_noise`` needs memory proportional to samples × window; chunking keeps a
    million-sample log within a few hundred MB. Variances are averaged weighted by the
    chunk lengths (a trailing chunk shorter than half a chunk joins the previous one).
    """
    n = t_s.size
    if n <= NOISE_CHUNK_SAMPLES:
        return estimate_noise(t_s, z)
    edges = [*range(0, n, NOISE_CHUNK_SAMPLES), n]
    if n - edges[-2] < NOISE_CHUNK_SAMPLES // 2:
        del edges[-2]
    meas_var = accel_var = 0.0
    for start, stop in itertools.pairwise(edges):
        part = estimate_noise(t_s[start:stop], z[start:stop])
        meas_var += part.meas_std**2 * (stop - start)
        accel_var += part.accel_std**2 * (stop - start)
    return NoiseEstimate(meas_std=math.sqrt(meas_var / n), accel_std=math.sqrt(accel_var / n))


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

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times, strictly increasing, spacing may be irregular [s].
    x_m, y_m : array_like, shape (N,)
        Measured North and East positions [m].
    heading_rad : array_like, shape (N,)
        Measured heading, wrapped (0..2π or ±π) or continuous [rad]; it is unwrapped
        before filtering, so the smoothed heading is continuous.
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

    Returns
    -------
    SmoothedTrack
        Smoothed states, derived velocities, their standard deviations, the noise levels
        used and the per-axis results.

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
    psi_meas = np.unwrap(psi_meas)

    if position_noise_m is None or position_accel_std_mps2 is None:
        ex, ey = _pooled_noise(t, xm), _pooled_noise(t, ym)
        if position_noise_m is None:
            position_noise_m = math.hypot(ex.meas_std, ey.meas_std) / math.sqrt(2.0)
        if position_accel_std_mps2 is None:
            position_accel_std_mps2 = math.hypot(ex.accel_std, ey.accel_std) / math.sqrt(2.0)
    if heading_noise_rad is None or heading_accel_std_radps2 is None:
        eh = _pooled_noise(t, psi_meas)
        if heading_noise_rad is None:
            heading_noise_rad = eh.meas_std
        if heading_accel_std_radps2 is None:
            heading_accel_std_radps2 = eh.accel_std
    position_noise_m = _check_positive(position_noise_m, "position_noise_m")
    heading_noise_rad = _check_positive(heading_noise_rad, "heading_noise_rad")
    position_accel_std_mps2 = _check_positive(position_accel_std_mps2, "position_accel_std_mps2")
    heading_accel_std_radps2 = _check_positive(heading_accel_std_radps2, "heading_accel_std_radps2")
    tau_s = _check_positive(tau_s, "tau_s")

    ax = smooth_axis(t, xm, position_noise_m, position_accel_std_mps2, tau_s)
    ay = smooth_axis(t, ym, position_noise_m, position_accel_std_mps2, tau_s)
    ah = smooth_axis(t, psi_meas, heading_noise_rad, heading_accel_std_radps2, tau_s)

    x, xd, xdd = ax.x_smoothed.T
    y, yd, ydd = ay.x_smoothed.T
    psi, r, rd = ah.x_smoothed.T
    var_x, var_xd = ax.P_smoothed[:, 0, 0], ax.P_smoothed[:, 1, 1]
    var_y, var_yd = ay.P_smoothed[:, 0, 0], ay.P_smoothed[:, 1, 1]
    var_psi, var_r = ah.P_smoothed[:, 0, 0], ah.P_smoothed[:, 1, 1]

    # Shi et al. (2009), eq. (9).
    speed = np.hypot(xd, yd)
    course = wrap_angle(np.arctan2(yd, xd))
    drift = wrap_angle(course - psi)
    c, s = np.cos(psi), np.sin(psi)
    u = xd * c + yd * s  # = U cos β
    v = -xd * s + yd * c  # = U sin β
    u_dot = xdd * c + ydd * s + r * v
    v_dot = -xdd * s + ydd * c - r * u

    # First-order propagation of the smoother variances.
    var_u = c**2 * var_xd + s**2 * var_yd + v**2 * var_psi
    var_v = s**2 * var_xd + c**2 * var_yd + u**2 * var_psi
    moving = speed > 0.0
    speed2 = np.where(moving, speed**2, 1.0)
    var_speed = np.where(moving, (xd**2 * var_xd + yd**2 * var_yd) / speed2, var_xd + var_yd)
    var_course = np.where(moving, (yd**2 * var_xd + xd**2 * var_yd) / speed2**2, np.inf)

    def ro(a: FloatArray) -> FloatArray:
        return _readonly(np.ascontiguousarray(a))

    return SmoothedTrack(
        time_s=ro(t.copy()),
        x_m=ro(x),
        y_m=ro(y),
        heading_rad=ro(psi),
        x_dot_mps=ro(xd),
        y_dot_mps=ro(yd),
        speed_mps=ro(speed),
        course_rad=ro(course),
        drift_rad=ro(drift),
        u_mps=ro(u),
        v_mps=ro(v),
        r_radps=ro(r),
        u_dot_mps2=ro(u_dot),
        v_dot_mps2=ro(v_dot),
        r_dot_radps2=ro(rd),
        x_std_m=ro(np.sqrt(var_x)),
        y_std_m=ro(np.sqrt(var_y)),
        heading_std_rad=ro(np.sqrt(var_psi)),
        x_dot_std_mps=ro(np.sqrt(var_xd)),
        y_dot_std_mps=ro(np.sqrt(var_yd)),
        speed_std_mps=ro(np.sqrt(var_speed)),
        course_std_rad=ro(np.sqrt(var_course)),
        drift_std_rad=ro(np.sqrt(var_course + var_psi)),
        u_std_mps=ro(np.sqrt(var_u)),
        v_std_mps=ro(np.sqrt(var_v)),
        r_std_radps=ro(np.sqrt(var_r)),
        position_noise_m=position_noise_m,
        heading_noise_rad=heading_noise_rad,
        position_accel_std_mps2=position_accel_std_mps2,
        heading_accel_std_radps2=heading_accel_std_radps2,
        tau_s=tau_s,
        x_axis=ax,
        y_axis=ay,
        heading_axis=ah,
    )
