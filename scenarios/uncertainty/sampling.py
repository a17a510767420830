"""Coefficient sets drawn from the identified coefficients' covariance, θ ~ N(θ̂, Σ)."""

from __future__ import annotations

import numpy as np

from fmu_model import ModelParameters
from scenarios.errors import UncertaintyError

__all__ = ["draw_coefficients"]

_JITTER_START = 1e-12  # first diagonal jitter on the correlation matrix [-]
_JITTER_MAX = 1e-6  # largest jitter tried before the covariance is rejected [-]
_SYMMETRY_RTOL = 1e-9


def draw_coefficients(
    params: ModelParameters, n_samples: int, seed: int
) -> tuple[np.ndarray, float]:
    """Draw coefficient sets θ ~ N(θ̂, Σ) from the parameters' covariance.

    With d the standard deviations of the coefficients whose variance is positive and
    C = Σ / (d dᵀ) their correlation matrix, θ = θ̂ + d ⊙ (chol(C + εI) z) with
    z ~ N(0, I); ε = 0 when C is positive definite, else the smallest of 1e-12, 1e-11,
    … 1e-6 that makes the factorisation succeed. Coefficients with zero variance stay
    exactly at θ̂.

    Parameters
    ----------
    params : ModelParameters
        θ̂ and Σ (``covariance`` must not be None).
    n_samples : int
        Number of coefficient sets N ≥ 1.
    seed : int
        Seed of ``numpy.random.default_rng``; the same seed gives the same draw.

    Returns
    -------
    samples : numpy.ndarray
        (N, p) coefficient sets in the structure's order [SI].
    jitter : float
        ε used [-].

    Raises
    ------
    UncertaintyError
        No covariance, or one that is not finite, not symmetric, has a negative
        variance, or is not positive semi-definite (Cholesky fails with ε = 1e-6).

    """
    if n_samples < 1:
        raise UncertaintyError(f"n_samples must be at least 1, got {n_samples}")
    theta = params.to_vector()
    if params.covariance is None:
        raise UncertaintyError(
            f"the parameters of {params.vessel_name!r} have no covariance; nothing to sample"
        )
    cov = np.asarray(params.covariance, dtype=float)
    if not np.all(np.isfinite(cov)):
        raise UncertaintyError("the covariance contains NaN or infinite values")
    scale = max(float(np.max(np.abs(cov))), np.finfo(float).tiny)
    if np.max(np.abs(cov - cov.T)) > _SYMMETRY_RTOL * scale:
        raise UncertaintyError("the covariance is not symmetric")
    variance = np.diag(cov)
    if np.any(variance < 0.0):
        raise UncertaintyError("the covariance has a negative variance on its diagonal")
    free = np.flatnonzero(variance > 0.0)
    rng = np.random.default_rng(seed)
    samples = np.tile(theta, (n_samples, 1))
    if free.size == 0:
        return samples, 0.0
    d = np.sqrt(variance[free])
    correlation = cov[np.ix_(free, free)] / np.outer(d, d)
    jitter = 0.0
    while True:
        try:
            factor = np.linalg.cholesky(correlation + jitter * np.eye(free.size))
            break
        except np.linalg.LinAlgError:
            jitter = _JITTER_START if jitter == 0.0 else 10.0 * jitter
            if jitter > _JITTER_MAX * (1.0 + 1e-9):
                raise UncertaintyError(
                    "the covariance is not positive semi-definite (Cholesky fails with a "
                    f"jitter of {_JITTER_MAX:g} on the correlation matrix)"
                ) from None
    z = rng.standard_normal((n_samples, free.size))
    samples[:, free] += (z @ factor.T) * d
    return samples, jitter
