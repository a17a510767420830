"""Augmented-state extended Kalman filter identification (Shi et al. 2009, section 3).

The motion state s = (u, v, r) is augmented with the model coefficients θ, which follow
a random walk. With the forward-Euler discretisation of eq. (4) and the step's averaged
inputs s̄(k) = (δ(k) + δ(k+1))/2, (n(k) + n(k+1))/2:

    s(k+1) = s(k) + T f(s(k), s̄(k); θ(k)) + w_s,     θ(k+1) = θ(k) + w_θ,
    y(k)   = H x(k) + e(k),   H = [I₃ 0]          (measurements: smoothed u, v, r)

and the EKF of eq. (5):

    x⁻ = f*(x),  P⁻ = Φ P Φᵀ + Q,  Φ = ∂f*/∂x = [[I + T ∂f/∂s, T ∂f/∂θ], [0, I]]
    K = P⁻ Hᵀ (H P⁻ Hᵀ + R)⁻¹,  x = x⁻ + K (y − H x⁻),  P = P⁻ − K H P⁻.

∂f/∂s and ∂f/∂θ are the analytic Jacobians of ``fmu_model`` (``NumericModel.linearise``).
Because H selects the first three states, the update only needs the 3 × 3 innovation
covariance, and the prediction only changes the motion rows of P; both are exploited
below (no dense (3+p)³ products).

Several logs are processed in one identification: the motion states restart at each
log's first sample (with the measurement covariance), θ and its covariance carry over.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numba
import numpy as np

from fmu_model import numeric_model
from identifier.errors import IdentificationError


@dataclass(frozen=True)
class EkfSegment:
    """One manoeuvre prepared for the EKF (smoothed motion and measured inputs).

    Parameters
    ----------
    name : str
        Log name for messages and provenance.
    time_s : numpy.ndarray
        Sample times [s], strictly increasing, shape (N,).
    velocities : numpy.ndarray
        Smoothed (u [m/s], v [m/s], r [rad/s]) used as measurements, shape (N, 3).
    velocity_std : numpy.ndarray
        Their standard deviations, shape (N, 3) (the measurement noise R).
    rudder_rad : numpy.ndarray
        Rudder angle [rad], shape (N,).
    n_rps : numpy.ndarray
        Propeller speed [rev/s], shape (N,).
    """

    name: str
    time_s: np.ndarray
    velocities: np.ndarray
    velocity_std: np.ndarray
    rudder_rad: np.ndarray
    n_rps: np.ndarray

    def mean_inputs(self) -> tuple[np.ndarray, np.ndarray]:
        """Step-averaged inputs s̄(k) of Shi et al. (2009), eq. (4), shape (N−1,)."""
        return (
            0.5 * (self.rudder_rad[:-1] + self.rudder_rad[1:]),
            0.5 * (self.n_rps[:-1] + self.n_rps[1:]),
        )


@dataclass(frozen=True)
class EkfSettings:
    """Tuning of the augmented-state EKF.

    Parameters
    ----------
    state_process_std : tuple of float
        Model-error standard deviation of (u̇, v̇, ṙ) [m/s², m/s², rad/s²]; the
        per-step process noise of the motion states is (T · std)².
    param_random_walk : float
        Relative random walk of θ per step: Q_θ = diag((ρ σ_θ0)²) with σ_θ0 the
        initial standard deviations. 0 gives constant parameters.
    divergence_factor : float
        Divergence is declared when a parameter variance grows above this factor
        times its initial value.
    """

    state_process_std: tuple[float, float, float] = (1e-3, 1e-3, 1e-5)
    param_random_walk: float = 1e-4
    divergence_factor: float = 1e6


@dataclass(frozen=True)
class EkfResult:
    """Output of :func:`ekf_identify`.

    ``theta_history`` and ``std_history`` hold θ and its standard deviations after each
    update, all segments concatenated (shape (M, p)); ``segment_ends`` are the indices in
    those arrays where each segment ends. ``filtered`` are the filtered motion states.
    """

    theta: np.ndarray
    covariance: np.ndarray
    theta_history: np.ndarray
    std_history: np.ndarray
    segment_ends: tuple[int, ...]
    filtered: tuple[np.ndarray, ...]


def ekf_identify(
    model_name: str,
    segments: Sequence[EkfSegment],
    theta0: np.ndarray,
    covariance0: np.ndarray,
    length_m: float,
    settings: EkfSettings | None = None,
    progress: Callable[[int], None] | None = None,
) -> EkfResult:
    """Identify the coefficients θ of ``model_name`` with the augmented-state EKF.

    Parameters
    ----------
    model_name : str
        Registered model structure.
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

    Raises
    ------
    IdentificationError
        On a non-finite state or covariance, a covariance that loses positive
        definiteness, or one that grows beyond ``divergence_factor``; the error names the
        segment and the sample.
    """
    settings = settings or EkfSettings()
    model = numeric_model(model_name)
    phi_fn, grad_fn = model.kernels
    eq_index = np.asarray(model.structure.equation_index, dtype=np.int64)
    p = model.n_coefficients
    theta = np.array(theta0, dtype=float)
    P_theta = np.array(covariance0, dtype=float)
    if theta.shape != (p,) or P_theta.shape != (p, p):
        raise ValueError(f"theta0/covariance0 must have shapes ({p},) and ({p}, {p})")
    q_theta = (settings.param_random_walk * np.sqrt(np.diag(P_theta))) ** 2
    variance_limit = settings.divergence_factor * np.maximum(np.diag(P_theta), 1e-300)
    q_state = np.asarray(settings.state_process_std, dtype=float) ** 2
    n_total = sum(seg.time_s.size for seg in segments)
    theta_hist = np.empty((n_total, p))
    std_hist = np.empty((n_total, p))
    ends: list[int] = []
    filtered: list[np.ndarray] = []
    row = 0
    for seg in segments:
        # Motion states restart at the segment's first measurement; θ carries over.
        x = np.concatenate([seg.velocities[0], theta])
        P = np.zeros((3 + p, 3 + p))
        P[:3, :3] = np.diag(seg.velocity_std[0] ** 2)
        P[3:, 3:] = P_theta
        states = np.empty((seg.time_s.size, 3))
        status, sample = _ekf_pass(
            phi_fn, grad_fn, eq_index, length_m,
            np.ascontiguousarray(seg.time_s, dtype=float),
            np.ascontiguousarray(seg.velocities, dtype=float),
            np.ascontiguousarray(seg.velocity_std, dtype=float) ** 2,
            np.ascontiguousarray(seg.rudder_rad, dtype=float),
            np.ascontiguousarray(seg.n_rps, dtype=float),
            x, P, q_state, q_theta, variance_limit,
            states, theta_hist[row : row + seg.time_s.size], std_hist[row : row + seg.time_s.size],
        )  # fmt: skip
        if status != _OK:
            raise IdentificationError(_STATUS_MESSAGES[status], log=seg.name, sample=int(sample))
        theta = x[3:].copy()
        P_theta = 0.5 * (P[3:, 3:] + P[3:, 3:].T)
        try:
            np.linalg.cholesky(P_theta)
        except np.linalg.LinAlgError:
            raise IdentificationError(
                "parameter covariance is not positive definite at the end of the log",
                log=seg.name,
                sample=seg.time_s.size - 1,
            ) from None
        row += seg.time_s.size
        ends.append(row)
        filtered.append(states)
        if progress is not None:
            progress(seg.time_s.size)
    return EkfResult(
        theta=theta,
        covariance=P_theta,
        theta_history=theta_hist,
        std_history=std_hist,
        segment_ends=tuple(ends),
        filtered=tuple(filtered),
    )


_OK, _NONFINITE, _NOT_PD, _EXPLODED = 0, 1, 2, 3
_STATUS_MESSAGES = {
    _NONFINITE: "state or covariance became non-finite (EKF diverged)",
    _NOT_PD: "innovation covariance is not positive definite (EKF diverged)",
    _EXPLODED: (
        "parameter covariance lost positive definiteness or exploded "
        "(EKF diverged; try a smaller --param-random-walk or better logs)"
    ),
}


@numba.njit(cache=True)
def _ekf_pass(
    phi_fn, grad_fn, eq_index, length, t, z, r_var, rudder, n_rps,
    x, P, q_state, q_theta, variance_limit, states, theta_hist, std_hist,
):  # type: ignore[no-untyped-def]  # fmt: skip
    """One segment of the EKF, eq. (4)-(5), in place on x and P; returns (status, sample)."""
    p = q_theta.size
    m = 3 + p
    phi = np.empty(p)
    grad = np.empty(3 * p)
    F = np.zeros((3, m))  # motion rows of Φ; θ rows are [0 I]
    G = np.empty((3, m))  # motion rows of Φ P
    K = np.empty((m, 3))
    PH = np.empty((m, 3))
    states[0, :] = x[:3]
    for i in range(p):
        theta_hist[0, i] = x[3 + i]
        std_hist[0, i] = np.sqrt(P[3 + i, 3 + i])
    for k in range(t.size - 1):
        T = t[k + 1] - t[k]
        # Step-averaged inputs, eq. (4).
        d_mean = 0.5 * (rudder[k] + rudder[k + 1])
        n_mean = 0.5 * (n_rps[k] + n_rps[k + 1])
        phi_fn(x[0], x[1], x[2], d_mean, n_mean, length, phi)
        grad_fn(x[0], x[1], x[2], d_mean, n_mean, length, grad)
        # Φ motion rows: [I + T ∂f/∂s, T ∂f/∂θ]; f = Σ θ_i φ_i per equation.
        F[:, :] = 0.0
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        for i in range(p):
            j = eq_index[i]
            th = x[3 + i]
            if j == 0:
                f0 += th * phi[i]
            elif j == 1:
                f1 += th * phi[i]
            else:
                f2 += th * phi[i]
            F[j, 3 + i] = T * phi[i]
            for c in range(3):
                F[j, c] += T * th * grad[3 * i + c]
        for c in range(3):
            F[c, c] += 1.0
        x[0] += T * f0
        x[1] += T * f1
        x[2] += T * f2
        # P⁻ = Φ P Φᵀ + Q: only the motion rows and columns change.
        for c in range(3):
            for b in range(m):
                acc = 0.0
                for a in range(m):
                    acc += F[c, a] * P[a, b]
                G[c, b] = acc
        for c in range(3):
            for b in range(m):
                P[c, b] = G[c, b]
                P[b, c] = G[c, b]
        for c in range(3):
            for d in range(3):
                acc = 0.0
                for a in range(m):
                    acc += G[c, a] * F[d, a]
                P[c, d] = acc
            P[c, c] += q_state[c] * T * T
        for i in range(p):
            P[3 + i, 3 + i] += q_theta[i]
        # Update with y = (u, v, r) at k+1: S = H P⁻ Hᵀ + R = L Lᵀ (Cholesky, 3 × 3).
        s00 = P[0, 0] + r_var[k + 1, 0]
        s11 = P[1, 1] + r_var[k + 1, 1]
        s22 = P[2, 2] + r_var[k + 1, 2]
        if not s00 > 0.0:
            return _NOT_PD, k + 1
        l00 = np.sqrt(s00)
        l10 = P[1, 0] / l00
        l20 = P[2, 0] / l00
        d11 = s11 - l10 * l10
        if not d11 > 0.0:
            return _NOT_PD, k + 1
        l11 = np.sqrt(d11)
        l21 = (P[2, 1] - l20 * l10) / l11
        d22 = s22 - l20 * l20 - l21 * l21
        if not d22 > 0.0:
            return _NOT_PD, k + 1
        l22 = np.sqrt(d22)
        # K = P Hᵀ S⁻¹: solve L Lᵀ Kᵀ = H P for every column of P Hᵀ.
        for a in range(m):
            PH[a, 0] = P[a, 0]
            PH[a, 1] = P[a, 1]
            PH[a, 2] = P[a, 2]
            w0 = PH[a, 0] / l00
            w1 = (PH[a, 1] - l10 * w0) / l11
            w2 = (PH[a, 2] - l20 * w0 - l21 * w1) / l22
            k2 = w2 / l22
            k1 = (w1 - l21 * k2) / l11
            K[a, 0] = (w0 - l10 * k1 - l20 * k2) / l00
            K[a, 1] = k1
            K[a, 2] = k2
        e0 = z[k + 1, 0] - x[0]
        e1 = z[k + 1, 1] - x[1]
        e2 = z[k + 1, 2] - x[2]
        for a in range(m):
            x[a] += K[a, 0] * e0 + K[a, 1] * e1 + K[a, 2] * e2
        # P = P⁻ − K H P⁻, symmetrised.
        for a in range(m):
            for b in range(a, m):
                value = P[a, b] - (K[a, 0] * PH[b, 0] + K[a, 1] * PH[b, 1] + K[a, 2] * PH[b, 2])
                P[a, b] = value
                P[b, a] = value
        for a in range(m):
            if not (np.isfinite(x[a]) and np.isfinite(P[a, a])):
                return _NONFINITE, k + 1
            if P[a, a] <= 0.0:
                return _EXPLODED, k + 1
        for i in range(p):
            if P[3 + i, 3 + i] > variance_limit[i]:
                return _EXPLODED, k + 1
            theta_hist[k + 1, i] = x[3 + i]
            std_hist[k + 1, i] = np.sqrt(P[3 + i, 3 + i])
        states[k + 1, :] = x[:3]
    return _OK, 0
