"""Covariance of a least-squares estimate whose residuals are correlated in time.

The residuals of a replayed track are strongly correlated (a model error persists for
minutes), and s² (JᵀJ)⁻¹ would be optimistic by about their correlation time in
samples. The covariance of the refined coefficients is therefore the Newey–West
sandwich at the optimum (:func:`newey_west_covariance`), with Andrews' automatic
bandwidth (:func:`_bartlett_lags`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from statsmodels.stats.sandwich_covariance import S_hac_simple


def newey_west_covariance(
    blocks: Sequence[tuple[np.ndarray, np.ndarray, int]], prior_jacobian: np.ndarray
) -> np.ndarray:
    """Least-squares covariance robust to residuals correlated in time (Newey–West).

    A replayed track's residuals are far from white (a model error persists for
    minutes), so s² (JᵀJ)⁻¹ is optimistic by about the correlation time in samples.
    The sandwich A⁻¹ S A⁻¹, A = JᵀJ over all rows, sums per block (one log) the lagged
    products of the per-sample scores g_k = Σ_channels J_kᵀ r_k with Bartlett weights
    (``statsmodels`` ``S_hac_simple``) over Andrews' automatic bandwidth
    (:func:`_bartlett_lags`); the prior rows add J_pᵀ J_p (unit variance).

    Parameters
    ----------
    blocks : sequence of (J, r, channels)
        Per log: Jacobian rows (m, n) and residuals (m,), time-major with ``channels``
        residuals per sample.
    prior_jacobian : numpy.ndarray
        Jacobian rows of the prior (q, n), residuals of unit variance.

    Returns
    -------
    numpy.ndarray
        Covariance (n, n) of the estimate, in the units of the Jacobian's columns.

    """
    info = prior_jacobian.T @ prior_jacobian
    meat = info.copy()
    for J, r, channels in blocks:
        info += J.T @ J
        scores = (J * r[:, None]).reshape(-1, channels, J.shape[1]).sum(axis=1)
        meat += S_hac_simple(scores, nlags=_bartlett_lags(r.reshape(-1, channels)))
    try:
        bread = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        bread = np.linalg.pinv(info)
    return bread @ meat @ bread


def _bartlett_lags(residuals: np.ndarray) -> int:
    """Bandwidth of the Bartlett window for (N, C) residuals: Andrews (1991), AR(1) rule.

    L = 1.1447 (α N)^⅓ with α = 4ρ² / ((1 − ρ)² (1 + ρ)²) and ρ the channels' mean lag-1
    autocorrelation (Andrews, Econometrica 59(3), eq. (6.4) and Table I), at most N − 1.
    """
    centred = residuals - residuals.mean(axis=0)
    n = centred.shape[0]
    power = float(np.sum(centred**2))
    if n < 3 or power == 0.0:
        return 0
    rho = min(max(float(np.sum(centred[1:] * centred[:-1])) / power, 0.0), 0.999)
    # Andrews (1991), eq. (6.4): α(1) for an AR(1) approximation, Bartlett kernel.
    alpha = 4.0 * rho**2 / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    # Andrews (1991), Table I: S_T = 1.1447 (α(1) T)^(1/3) for the Bartlett kernel.
    return min(int(1.1447 * (alpha * n) ** (1.0 / 3.0)), n - 1)
