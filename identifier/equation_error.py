"""Equation-error least squares: the EKF's initial guess and the identifiability check.

Because every structure is linear in its coefficients, the model written for the
smoothed data with central-difference accelerations (second-order accurate, unlike the
forward difference of the paper's eq. (4), whose O(T) bias at T = 1 s reaches several
per cent on the yaw coefficients),

    (s_j(k+1) − s_j(k−1)) / (t(k+1) − t(k−1)) = Σ_i θ_i φ_i(s(k), δ(k), n(k)) + e_j(k),

j ∈ {u, v, r}, is an ordinary linear regression per equation. Each equation is solved separately
(its coefficients enter no other equation) with columns scaled to unit RMS and a tiny
ridge term so that an unexcited regressor (e.g. rudder terms in a straight run) gets a
zero estimate with a huge standard deviation instead of a singular matrix. The
covariance is σ²_e (XᵀX + λI)⁻¹ with σ_e the residual standard deviation.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from fmu_model import ModelStructure, numeric_model
from identifier.ekf import EkfSegment

# Ridge weight relative to the number of samples, in unit-RMS column scaling.
_RIDGE = 1e-9


@dataclass(frozen=True)
class EquationErrorFit:
    """Least-squares estimate of θ.

    Attributes
    ----------
    theta : numpy.ndarray
        Coefficients (p,).
    covariance : numpy.ndarray
        Their covariance (p, p), block-diagonal by equation.
    residual_std : numpy.ndarray
        Residual standard deviation of (u̇, v̇, ṙ) [m/s², m/s², rad/s²].
    regressor_rms : numpy.ndarray
        RMS of every regressor over the data (p,); 0 means not excited at all.
    contribution : numpy.ndarray
        RMS(θ_i φ_i) / RMS(fitted acceleration of its equation) (p,).

    """

    theta: np.ndarray
    covariance: np.ndarray
    residual_std: np.ndarray
    regressor_rms: np.ndarray
    contribution: np.ndarray
    variance_inflation: np.ndarray


def regression_samples(segments: Sequence[EkfSegment]) -> tuple[np.ndarray, np.ndarray]:
    """Return the samples (u, v, r, δ, n) (5, M) and their central-difference accelerations (3, M).

    SI units: m/s, m/s, rad/s, rad, rev/s; accelerations m/s², m/s², rad/s². The first and
    last sample of every segment have no central difference and are left out.
    """
    samples, accs = [], []
    for seg in segments:
        s = seg.velocities
        samples.append(np.vstack([s[1:-1].T, seg.rudder_rad[1:-1], seg.n_rps[1:-1]]))
        span = (seg.time_s[2:] - seg.time_s[:-2])[:, None]
        accs.append(((s[2:] - s[:-2]) / span).T)
    return np.concatenate(samples, axis=1), np.concatenate(accs, axis=1)


def regression_data(
    structure: ModelStructure, segments: Sequence[EkfSegment], length_m: float
) -> tuple[np.ndarray, np.ndarray]:
    """Return the regressors Φ (p, M) and the central-difference accelerations (3, M)."""
    (u, v, r, rudder_rad, n_rps), acc = regression_samples(segments)
    return numeric_model(structure).regressors(u, v, r, rudder_rad, n_rps, length_m), acc


def equation_error_fit(
    structure: ModelStructure, segments: Sequence[EkfSegment], length_m: float
) -> EquationErrorFit:
    """Fit θ by equation-error least squares on the smoothed segments (module docstring)."""
    phi, acc = regression_data(structure, segments, length_m)
    return fit_regression(phi, acc, structure.equation_index)


def fit_regression(
    phi: np.ndarray, acc: np.ndarray, equation_index: Sequence[int]
) -> EquationErrorFit:
    """Solve acc_j ≈ Σ_{i in equation j} θ_i φ_i for every equation j (module docstring).

    Parameters
    ----------
    phi : numpy.ndarray
        Regressors (p, M).
    acc : numpy.ndarray
        Accelerations (3, M) [m/s², m/s², rad/s²].
    equation_index : sequence of int
        For each coefficient the equation it enters (0 surge, 1 sway, 2 yaw).

    """
    p, m = phi.shape
    theta = np.zeros(p)
    cov = np.zeros((p, p))
    residual_std = np.zeros(3)
    rms = np.sqrt(np.mean(phi**2, axis=1))
    eq_index = np.asarray(equation_index)
    fitted = np.zeros_like(acc)
    vif = np.ones(p)
    for j in range(3):
        cols = np.flatnonzero(eq_index == j)
        scale = np.where(rms[cols] > 0.0, rms[cols], 1.0)
        X = (phi[cols] / scale[:, None]).T  # (M, p_j), unit-RMS columns
        A = X.T @ X + _RIDGE * m * np.eye(cols.size)
        beta = np.linalg.solve(A, X.T @ acc[j])
        residual = acc[j] - X @ beta
        dof = max(m - cols.size, 1)
        sigma2 = float(residual @ residual) / dof
        theta[cols] = beta / scale
        cov[np.ix_(cols, cols)] = sigma2 * np.linalg.inv(A) / np.outer(scale, scale)
        residual_std[j] = np.sqrt(sigma2)
        # Uncentred VIF in unit-RMS scaling: diag((XᵀX/M)⁻¹).
        vif[cols] = np.diag(np.linalg.inv(A / m))
        fitted[j] = X @ beta
    signal = np.sqrt(np.mean(fitted**2, axis=1))
    term_rms = np.sqrt(np.mean((theta[:, None] * phi) ** 2, axis=1))
    contribution = term_rms / np.where(signal[eq_index] > 0.0, signal[eq_index], 1.0)
    return EquationErrorFit(theta, cov, residual_std, rms, contribution, vif)
