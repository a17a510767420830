"""Numerical evaluation of a model structure: right-hand side and analytic Jacobians.

Everything here is generated from the symbolic structure (``fmu_model.structure``) with
``sympy.lambdify``; nothing is written twice. With θ the coefficient vector and
s = (u, v, r) the velocities, every variant has the form

    ṡ = f(s, δ, n; θ) = M (θ ⊙ φ(s, δ, n)),

where φ are the p regressors and M (3 × p) assigns each coefficient to its equation.
Hence ∂f/∂θ = M diag(φ) and ∂f/∂s = M diag(θ) ∂φ/∂s, both exact.
All functions broadcast over trailing sample dimensions.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache
from typing import Any

import numpy as np
import sympy as sp

from fmu_model.structure import (
    INPUT_SYMBOLS,
    KINEMATICS,
    STATE_SYMBOLS,
    VELOCITY_SYMBOLS,
    L,
    ModelStructure,
)
from fmu_model.variants import ModelFamily

_ARGS = (*VELOCITY_SYMBOLS, *INPUT_SYMBOLS, L)


def _stack(values: list[Any], shape: tuple[int, ...]) -> np.ndarray:
    """Stack lambdify's list output, broadcasting constant entries to ``shape``."""
    if not shape:
        return np.array(values, dtype=float)
    out = np.empty((len(values), *shape))
    for i, value in enumerate(values):
        out[i] = value  # broadcasts the constant entries
    return out


@dataclass(frozen=True)
class NumericModel:
    """Numpy functions of one model structure (build with :func:`numeric_model`)."""

    structure: ModelStructure
    mask: np.ndarray  # (3, p): 1 where coefficient i enters equation j
    _regressors: Callable[..., list[Any]]
    _regressor_gradients: Callable[..., list[Any]]
    _rhs: Callable[..., list[Any]]

    @property
    def n_coefficients(self) -> int:
        """Number of coefficients p."""
        return self.structure.n_coefficients

    def regressors(
        self, u: Any, v: Any, r: Any, rudder_rad: Any, n_rps: Any, length_m: float
    ) -> np.ndarray:
        """Regressors φ, shape (p,) + broadcast shape of the arguments."""
        shape = np.broadcast_shapes(*(np.shape(a) for a in (u, v, r, rudder_rad, n_rps)))
        return _stack(self._regressors(u, v, r, rudder_rad, n_rps, length_m), shape)

    def accelerations(
        self,
        theta: np.ndarray,
        u: Any,
        v: Any,
        r: Any,
        rudder_rad: Any,
        n_rps: Any,
        length_m: float,
    ) -> np.ndarray:
        """Body accelerations (u', v', r') [m/s², m/s², rad/s²], shape (3,) + broadcast."""
        phi = self.regressors(u, v, r, rudder_rad, n_rps, length_m)
        return np.tensordot(self.mask, _weight(theta, phi), axes=1)

    def linearise(
        self,
        theta: np.ndarray,
        u: float,
        v: float,
        r: float,
        rudder_rad: float,
        n_rps: float,
        length_m: float,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return f (3,), ∂f/∂(u, v, r) (3, 3) and ∂f/∂θ (3, p) at one point (scalars)."""
        phi = np.asarray(self._regressors(u, v, r, rudder_rad, n_rps, length_m), dtype=float)
        grad = np.array(
            self._regressor_gradients(u, v, r, rudder_rad, n_rps, length_m), dtype=float
        )  # (p, 3)
        d_theta = self.mask * phi  # (3, p)
        f = d_theta @ theta
        d_state = (self.mask * theta) @ grad
        return f, d_state, d_theta

    def rhs(
        self,
        state: np.ndarray,
        rudder_rad: Any,
        n_rps: Any,
        theta: np.ndarray,
        length_m: float,
    ) -> np.ndarray:
        """Time derivative of the 6-state (u, v, r, x, y, ψ); state shape (6,) + batch.

        The accelerations of the structure followed by the kinematics of
        ``fmu_model.structure.KINEMATICS``; θ may carry the same batch dimensions.
        """
        shape = np.broadcast_shapes(
            np.shape(state)[1:], np.shape(theta)[1:], np.shape(rudder_rad), np.shape(n_rps)
        )
        return _stack(self._rhs(*state, rudder_rad, n_rps, length_m, theta), shape)


def _weight(theta: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """θ ⊙ φ with θ (p,) or (p, batch…) broadcast against φ (p, …)."""
    theta = np.asarray(theta, dtype=float)
    return theta.reshape(theta.shape + (1,) * (phi.ndim - theta.ndim)) * phi


def numeric_model(structure: ModelStructure) -> NumericModel:
    """Compile a model structure into numpy functions (cached by the structure's name)."""
    compiled = _COMPILED.get(structure.name)
    if compiled is None or compiled.structure != structure:
        compiled = _COMPILED[structure.name] = _compile(structure)
    return compiled


_COMPILED: dict[str, NumericModel] = {}


def _compile(structure: ModelStructure) -> NumericModel:
    regressors = [t.regressor for t in structure.terms]
    gradients = [[sp.diff(expr, s) for s in VELOCITY_SYMBOLS] for expr in regressors]
    mask = np.zeros((3, structure.n_coefficients))
    mask[structure.equation_index, np.arange(structure.n_coefficients)] = 1.0
    return NumericModel(
        structure=structure,
        mask=mask,
        _regressors=sp.lambdify(_ARGS, regressors, modules="numpy", cse=True),
        _regressor_gradients=sp.lambdify(_ARGS, gradients, modules="numpy", cse=True),
        _rhs=sp.lambdify(
            (*STATE_SYMBOLS, *INPUT_SYMBOLS, L, structure.coefficient_symbols),
            [*structure.accelerations(), *KINEMATICS],
            modules="numpy",
            cse=True,
        ),
    )


@cache
def family_regressors(
    family: ModelFamily, columns: tuple[int, ...] | None = None
) -> Callable[..., np.ndarray]:
    """Regressors of ``family`` with its shape constants as trailing arguments.

    Returns ``phi(u, v, r, rudder_rad, n_rps, length_m, *shape) -> (p, …)``, shape in the
    order of ``ModelFamily.shape``: one compiled function for a search over shapes,
    from the same symbolic terms as the structures the family instantiates. With
    ``columns``, only those regressors (indices in coefficient-vector order), in that order.
    Every argument broadcasts: samples (1, M) and shape constants (G, 1) give the
    regressors of G shapes at once, (p, G, M).
    """
    terms = family.terms if columns is None else tuple(family.terms[i] for i in columns)
    shape_symbols = tuple(c.symbol for c in family.shape)
    fn = sp.lambdify(
        (*_ARGS, *shape_symbols), [t.regressor for t in terms], modules="numpy", cse=True
    )

    def phi(*args: Any) -> np.ndarray:
        shape = np.broadcast_shapes(*(np.shape(a) for a in args))
        return _stack(fn(*args), shape)

    return phi
