"""Choosing the shape constants of a model family from the training data.

A family (``fmu_model.variants.ModelFamily``, e.g. ``prime-rudder``) is linear in its
coefficients once a few shape constants are fixed: for ``prime-rudder`` the slipstream
share k of the rudder inflow, the flow-straightening factor γ and its port/starboard
asymmetry Δγ, and the rudder position l (in L) of reference/model_structures.md §4
(``fmu_model.variants``). They are chosen, inside their physical
bounds, by the smallest equation-error residual on the training data, summed over the
three equations relative to their signal,

    J(shape) = Σ_j ‖a_j − Φ_j(shape) θ̂_j(shape)‖² / ‖a_j‖²,   j ∈ {u, v, r},

first on a grid, then polished from the best grid point with a bounded Powell search
(``scipy.optimize.minimize``). Nothing of a held-out manoeuvre is used. The slipstream
share is searched as κ = k (n₀L/U₀)², the (nL)² part of the rudder inflow relative
to U₀² at the nominal approach, so that one grid fits every ship.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize

from fmu_model import get_model
from fmu_model.numeric import family_regressors
from fmu_model.variants import ModelFamily
from identifier.ekf import EkfSegment
from identifier.equation_error import fit_regression, regression_samples

# Grid of the search (the polish then moves freely inside the bounds).
KAPPA_GRID = (0.0, 0.25, 0.5, 1.0, 2.0, 4.0, 8.0)
FRACTION_GRID = (0.0, 0.25, 0.5, 0.75, 1.0)  # for constants bounded in [0, 1]
OTHER_GRID = 3  # points across the bounds of any other constant


@dataclass(frozen=True)
class ShapeSelection:
    """The chosen shape of a family.

    Attributes
    ----------
    model : str
        Name of the structure with that shape (``family[k=…,gamma=…,l=…]``).
    shape : dict
        The shape constants.
    residual : float
        J(shape) of the module docstring (dimensionless, 0 = perfect fit).
    default_residual : float
        J at the family's default shape, for comparison.
    evaluations : int
        Number of shapes tried.

    """

    model: str
    shape: dict[str, float]
    residual: float
    default_residual: float
    evaluations: int


def _axis(family: ModelFamily, index: int, kappa_to_k: float) -> list[float]:
    c = family.shape[index]
    if c.name == "k":
        return [min(kappa * kappa_to_k, c.upper) for kappa in KAPPA_GRID]
    if (c.lower, c.upper) == (0.0, 1.0):
        return list(FRACTION_GRID)
    return list(np.linspace(c.lower, c.upper, OTHER_GRID))


def select_shape(
    family: ModelFamily,
    segments: Sequence[EkfSegment],
    length_m: float,
    nominal_speed_mps: float,
    nominal_n_rps: float,
    fixed: Mapping[str, float] | None = None,
) -> ShapeSelection:
    """Choose the shape constants of ``family`` by the equation-error residual.

    Parameters
    ----------
    family : ModelFamily
        The family to shape.
    segments : sequence of EkfSegment
        Smoothed training data (velocities, rudder [rad], propeller speed [rev/s]).
    length_m : float
        Ship length [m].
    nominal_speed_mps, nominal_n_rps : float
        Approach speed [m/s] and propeller speed [rev/s], to scale the slipstream grid.
    fixed : mapping of str to float, optional
        Constants known beforehand (e.g. ``{"dgamma": 0.0}``); only the others are searched.

    """
    fixed = dict(fixed or {})
    family.check(fixed)
    phi_fn = family_regressors(family.name)
    samples, acc = regression_samples(segments)
    equation_index = get_model(family.name).equation_index
    signal = np.sum(acc**2, axis=1)
    signal = np.where(signal > 0.0, signal, 1.0)
    names = [c.name for c in family.shape]
    free = [i for i, c in enumerate(family.shape) if c.name not in fixed]
    evaluations = 0

    def residual(values: Sequence[float]) -> float:
        nonlocal evaluations
        evaluations += 1
        phi = phi_fn(*samples, length_m, *values)
        if not np.all(np.isfinite(phi)):
            return math.inf
        fit = fit_regression(phi, acc, equation_index)
        return float(np.sum(fit.residual_std**2 * acc.shape[1] / signal))

    def full(free_values: Sequence[float]) -> list[float]:
        values = [fixed.get(name, math.nan) for name in names]
        for i, value in zip(free, free_values, strict=True):
            values[i] = float(value)
        return values

    n_l = nominal_n_rps * length_m
    kappa_to_k = (nominal_speed_mps / n_l) ** 2 if n_l > 0.0 else 0.0
    axes = [_axis(family, i, kappa_to_k) for i in free]
    scores = {values: residual(full(values)) for values in itertools.product(*axes)}
    best = np.asarray(min(scores, key=scores.__getitem__), dtype=float)
    best_score = min(scores.values())
    if free:
        # Powell on unit-scaled constants: k is of order (U₀/n₀L)², the others of order 1.
        constants = [family.shape[i] for i in free]
        scale = np.array([(kappa_to_k or 1.0) if c.name == "k" else 1.0 for c in constants])
        polish = minimize(
            lambda z: residual(full(z * scale)),
            best / scale,
            method="Powell",
            bounds=[(c.lower / s, c.upper / s) for c, s in zip(constants, scale, strict=True)],
            options={"xtol": 1e-3, "ftol": 1e-6, "maxfev": 300},
        )
        if polish.fun < best_score:
            best = polish.x * scale
    # The structure's constants are those of its name (6 significant digits).
    shape = {n: float(f"{v:.6g}") for n, v in zip(names, full(list(best)), strict=True)}
    return ShapeSelection(
        model=family.structure_name(shape),
        shape=shape,
        residual=residual(list(shape.values())),
        default_residual=residual([c.default for c in family.shape]),
        evaluations=evaluations,
    )
