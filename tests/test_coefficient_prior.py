"""A zero-mean prior on a coefficient (``Term.prior_std``) in the equation-error fit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from fmu_model.variants import PRIME_RUDDER
from identifier.equation_error import NormalEquations

# One regressor per equation (surge, sway, yaw): coefficient-vector order.
EQUATIONS = (0, 1, 2)


def _sums(phi: np.ndarray, acc: np.ndarray) -> NormalEquations:
    sums = NormalEquations(3)
    sums.add(phi, acc)
    return sums


def test_the_prior_shrinks_a_coefficient_as_the_posterior_mean_says() -> None:
    """θ = Σφa / (Σφ² + c²σ₀²/s²) by hand, σ₀² the residual variance without the prior;
    the equations without a prior are ordinary least squares."""
    rng = np.random.default_rng(3)
    m = 400
    phi = rng.normal(size=(3, m))
    acc = np.array([1.5, 2.0, -0.7])[:, None] * phi + 0.8 * rng.normal(size=(3, m))
    s, c = 0.05, 3.0
    fit = _sums(phi, acc).solve(EQUATIONS, prior_std=[None, s, None], prior_inflation=c)

    ff = phi @ phi.T
    fa = np.einsum("jm,jm->j", phi, acc)
    ols = fa / np.diag(ff)
    sigma0_sq = np.sum((acc[1] - ols[1] * phi[1]) ** 2) / (m - 1)
    shrunk = fa[1] / (ff[1, 1] + c**2 * sigma0_sq / s**2)
    sigma1_sq = np.sum((acc[1] - shrunk * phi[1]) ** 2) / (m - 1)
    np.testing.assert_allclose(fit.theta, [ols[0], shrunk, ols[2]], rtol=1e-6)
    assert abs(shrunk) < 0.5 * abs(ols[1])  # the prior matters here
    np.testing.assert_allclose(
        fit.covariance[1, 1], sigma1_sq / (ff[1, 1] + c**2 * sigma0_sq / s**2), rtol=1e-6
    )
    np.testing.assert_allclose(fit.residual_std[1], np.sqrt(sigma1_sq), rtol=1e-6)


def test_a_coefficient_the_logs_determine_keeps_its_least_squares_value() -> None:
    """σ₀ = 0.01, s = 1, c = 10, Σφ² ≈ 5000: shrunk by c²σ₀²/(s²Σφ²) ≈ 2e-6 only."""
    rng = np.random.default_rng(4)
    phi = rng.normal(size=(3, 5000))
    acc = np.array([1.5, 2.0, -0.7])[:, None] * phi + 0.01 * rng.normal(size=(3, 5000))
    sums = _sums(phi, acc)
    free = sums.solve(EQUATIONS)
    with_prior = sums.solve(EQUATIONS, prior_std=[1.0, 1.0, 1.0], prior_inflation=10.0)
    np.testing.assert_allclose(with_prior.theta, free.theta, rtol=1e-5)
    assert np.all(np.abs(with_prior.theta) < np.abs(free.theta))


def test_a_coefficient_the_logs_do_not_determine_keeps_its_prior() -> None:
    """Not excited: the estimate stays at 0 and c²·Cov θ (the EKF's prior) is s²."""
    rng = np.random.default_rng(5)
    phi = rng.normal(size=(3, 300))
    phi[2] = 0.0
    acc = rng.normal(size=(3, 300))
    s, c = 4.5, 10.0
    fit = _sums(phi, acc).solve(EQUATIONS, prior_std=[None, None, s], prior_inflation=c)
    assert fit.theta[2] == 0.0
    assert c**2 * fit.covariance[2, 2] == pytest.approx(s**2, rel=1e-6)
    free = _sums(phi, acc).solve(EQUATIONS)
    assert free.covariance[2, 2] > 1e6 * fit.covariance[2, 2]  # only the tiny ridge


def test_a_family_keeps_its_priors_when_its_shape_is_fixed() -> None:
    family = replace(
        PRIME_RUDDER,
        name="prior-test",
        sway=tuple(
            replace(t, prior_std=0.25) if t.coefficient == "Y_rar" else t for t in PRIME_RUDDER.sway
        ),
    )
    structure = family.structure(family.default_shape)
    priors = {t.coefficient: t.prior_std for t in structure.terms}
    assert priors["Y_rar"] == 0.25
    assert {name for name, std in priors.items() if std is not None} == {"Y_rar"}
