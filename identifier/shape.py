"""Choosing the shape constants of a model family from the training data.

A family (``fmu_model.variants.ModelFamily``, e.g. ``prime-rudder``) is linear in its
coefficients once a few shape constants are fixed: for ``prime-rudder`` the slipstream
share k of the rudder inflow, the flow-straightening factor γ and its port/starboard
asymmetry Δγ, the rudder position l (in L) of reference/model_structures.md §4, and the
wake recovery in a drift and its asymmetry (wake, dwake; ``fmu_model.variants``). They
are chosen, inside their physical bounds, by the equation-error residual on the
training data, summed over the three equations relative to their signal,

    J(shape) = Σ_j ‖a_j − Φ_j(shape) θ̂_j(shape)‖² / ‖a_j‖²,   j ∈ {u, v, r},

first the smallest on the grid each constant declares (``ShapeConstant.grid``), then
polished from that grid point with a bounded Powell search (``scipy.optimize.minimize``)
of :data:`SHAPE_POLISH_SWEEPS` whole sweeps: a deliberate stop, short of J's minimum
along its flat valleys, at a point continuous in the data (see there). Nothing of a
held-out manoeuvre is used.
The slipstream share k is searched as κ = k (n₀L/U₀)², the (nL)² part of the rudder
inflow relative to U₀² at the nominal approach, so that one grid fits every ship.

Rate-aware. J is evaluated on the regression of ``identifier.equation_error``, decimated
to about L/U/40 (1 Hz for KVLCC2 at full scale; the smoother being the anti-aliasing
filter), and on at most :data:`SHAPE_MAX_ROWS` of its rows, spread evenly over the data:
a day-long log has hundreds of thousands of rows, and the several thousand shapes tried
need only J's minimum, which that many rows fix (the coefficients of the chosen shape
are then fitted on every row). The regressions are tiny (p ≤ 28 columns), so BLAS runs
on one thread here: its threads cost more than they give, a hundredfold on a busy
machine.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import minimize
from threadpoolctl import threadpool_limits

from fmu_model import ModelStructure
from fmu_model.numeric import family_regressors
from fmu_model.variants import ModelFamily, ShapeConstant
from identifier.ekf import EkfSegment
from identifier.equation_error import (
    NormalEquations,
    regression_interval_s,
    regression_samples,
)

#: Most regression rows J is evaluated on (module docstring).
SHAPE_MAX_ROWS = 10_000

#: Regressor values of one column computed at once (``_ShapeRegression``): the grid's
#: shapes go in batches of this many over the rows (2 MB an array).
SHAPE_BATCH_VALUES = 250_000

#: Whole sweeps of the Powell polish (each line search run to its tolerance). The polish
#: stops well before Powell converges, and that is measured to matter: converged, J falls
#: by up to 9 % on zig-zag training data while the held-out turns get worse (the Mariner
#: 131.8 against 77.4 points in sum over ten draws; benchmarks/fidelity.md, "The shape
#: search's polish, converged"): along J's flat valleys a short polish keeps the shape
#: near the best grid point, a regularisation the zig-zags need. Whole sweeps, not a cap
#: on evaluations (300 until 2026-12-07), because a cap ends inside a sweep at a point the
#: data's last digits decide: 1 % of GNSS jumps gated out moved a calm-water turn 1.3
#: points (issue 14's glitch bar), after two sweeps every draw is within 0.44. On the
#: references' held-out turns two sweeps against the cap, worst turning error per draw,
#: paired over twenty draws: KVLCC2 −1.03 ± 0.34 points a draw (closer in 16, further in
#: none), the tanker −0.64 ± 0.26, the Mariner +1.04 ± 0.55 (t 1.9); the HSVA folds 0.4°
#: worse in sum (benchmarks/fidelity.md, "Two whole sweeps of the shape polish").
SHAPE_POLISH_SWEEPS = 2


@dataclass(frozen=True)
class ShapeSelection:
    """The chosen shape of a family.

    Attributes
    ----------
    structure : ModelStructure
        The structure with that shape (named ``family[k=…,gamma=…,l=…]``).
    shape : dict
        The shape constants.
    residual : float
        J(shape) of the module docstring (dimensionless, 0 = perfect fit).
    default_residual : float
        J at the family's default shape, for comparison.
    evaluations : int
        Number of shapes tried.
    rows : int
        Regression rows J was evaluated on.
    sample_interval_s : float
        Their sampling interval after decimation (median) [s].

    """

    structure: ModelStructure
    shape: dict[str, float]
    residual: float
    default_residual: float
    evaluations: int
    rows: int
    sample_interval_s: float

    def as_dict(self) -> dict[str, Any]:
        """Return the record of params.json ``identification.shape`` (structure by name)."""
        return {
            "model": self.structure.name,
            "shape": dict(self.shape),
            "residual": self.residual,
            "default_residual": self.default_residual,
            "evaluations": self.evaluations,
            "rows": self.rows,
            "sample_interval_s": self.sample_interval_s,
        }


def _unit(constant: ShapeConstant, slipstream: float) -> float:
    """Value of one grid unit of ``constant`` (``ShapeConstant.grid_unit``)."""
    return (slipstream or 1.0) if constant.grid_unit == "slipstream" else 1.0


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
        Constants known beforehand (e.g. ``{"dgamma": 0.0}``); only the others are
        searched, and of them only those ``searched`` (the rest take their defaults).

    """
    fixed = family.settled(fixed or {})
    family.check(fixed)
    with threadpool_limits(limits=1, user_api="blas"):
        return _select_shape(family, segments, length_m, nominal_speed_mps, nominal_n_rps, fixed)


def _select_shape(
    family: ModelFamily,
    segments: Sequence[EkfSegment],
    length_m: float,
    nominal_speed_mps: float,
    nominal_n_rps: float,
    fixed: dict[str, float],
) -> ShapeSelection:
    """:func:`select_shape` after the check of ``fixed``."""
    samples, acc = regression_samples(segments, length_m, max_rows=SHAPE_MAX_ROWS)
    regression = _ShapeRegression(family, samples, acc, length_m)
    signal = np.sum(acc**2, axis=1)
    signal = np.where(signal > 0.0, signal, 1.0)
    names = [c.name for c in family.shape]
    free = [i for i, c in enumerate(family.shape) if c.name not in fixed]
    evaluations = 0

    def residuals(shapes: np.ndarray) -> np.ndarray:
        """J (G,) of the shapes (G, n) (inf where a regressor is not finite)."""
        nonlocal evaluations
        evaluations += shapes.shape[0]
        residual_std = regression.residual_std(shapes)
        return np.sum(residual_std**2 * acc.shape[1] / signal, axis=-1)

    def residual(values: Sequence[float]) -> float:
        return float(residuals(np.asarray([values], dtype=float))[0])

    def full(free_values: Sequence[float]) -> list[float]:
        values = [fixed.get(name, math.nan) for name in names]
        for i, value in zip(free, free_values, strict=True):
            values[i] = float(value)
        return values

    n_l = nominal_n_rps * length_m
    slipstream = (nominal_speed_mps / n_l) ** 2 if n_l > 0.0 else 0.0  # (U₀/(n₀L))²
    constants = [family.shape[i] for i in free]
    scale = np.array([_unit(c, slipstream) for c in constants])
    axes = [
        [min(max(g * s, c.lower), c.upper) for g in c.grid]
        for c, s in zip(constants, scale, strict=True)
    ]
    grid = list(itertools.product(*axes))
    shapes = np.array([full(values) for values in grid], dtype=float)
    batch = max(1, SHAPE_BATCH_VALUES // acc.shape[1])
    scores = np.concatenate([residuals(shapes[i : i + batch]) for i in range(0, len(grid), batch)])
    i_best = int(np.argmin(scores))
    best, best_score = np.asarray(grid[i_best], dtype=float), float(scores[i_best])
    if free:
        # Powell in grid units, where every constant is of order 1.
        polish = minimize(
            lambda z: residual(full(z * scale)),
            best / scale,
            method="Powell",
            bounds=[(c.lower / s, c.upper / s) for c, s in zip(constants, scale, strict=True)],
            options={"xtol": 1e-3, "ftol": 1e-6, "maxiter": SHAPE_POLISH_SWEEPS},
        )
        if polish.fun < best_score:
            best = polish.x * scale
    # The structure's constants are those of its name (6 significant digits).
    shape = {n: float(f"{v:.6g}") for n, v in zip(names, full(list(best)), strict=True)}
    return ShapeSelection(
        structure=family.structure(shape),
        shape=shape,
        residual=residual(list(shape.values())),
        default_residual=residual([c.default for c in family.shape]),
        evaluations=evaluations,
        rows=acc.shape[1],
        sample_interval_s=regression_interval_s(segments, length_m),
    )


class _ShapeRegression:
    """The regression of J for any shapes, with the sums of the shape-free columns made once.

    Only a few regressors of a family hold shape constants (``ModelFamily.shaped_columns``;
    prime-rudder: the rudder force, 3 of 21 columns). The products ΦΦᵀ and Φ aᵀ of the
    others are the same for every shape, so a shape costs only its own columns and their
    products with all (3 × 21 of the 21 × 21 products; 2.3 instead of 2.8 ms a shape on
    10,000 rows here, the shaped regressors' arithmetic being most of what is left). The
    shapes come in batches, G at a time (:data:`SHAPE_BATCH_VALUES` of the grid, one of
    the polish), as numpy arrays with the batch in front: the grid's 8,505 shapes of the
    default family in 0.32 instead of 0.86 ms a shape on 3,242 rows
    (``benchmarks/identify.py --shape-search-only``).
    """

    def __init__(
        self, family: ModelFamily, samples: np.ndarray, acc: np.ndarray, length_m: float
    ) -> None:
        p = len(family.terms)
        self._shaped = list(family.shaped_columns)
        self._fixed = [i for i in range(p) if i not in self._shaped]
        self._shaped_fn = family_regressors(family, tuple(self._shaped))
        self._samples, self._acc, self._length_m = samples, acc, length_m
        defaults = [c.default for c in family.shape]  # the shape-free columns ignore them
        self._fixed_phi = family_regressors(family, tuple(self._fixed))(
            *samples, length_m, *defaults
        )
        self._finite = bool(np.all(np.isfinite(self._fixed_phi)))
        # The sums with the shaped columns zero: their rows and columns are made per shape.
        base_phi = np.zeros((p, acc.shape[1]))
        base_phi[self._fixed] = self._fixed_phi
        self._base = NormalEquations(p)
        self._base.add(base_phi, acc)
        self._equation_index = family.structure(family.default_shape).equation_index

    def residual_std(self, shapes: np.ndarray) -> np.ndarray:
        """Residual σ_j (G, 3) of the equation-error fits of ``shapes`` (G, n); inf: not finite."""
        g = shapes.shape[0]
        constants = (shapes[:, i, None] for i in range(shapes.shape[1]))
        shaped = self._shaped_fn(*self._samples[:, None, :], self._length_m, *constants)
        shaped = np.moveaxis(shaped, 0, 1)  # (G, columns, rows)
        finite = self._finite & np.all(np.isfinite(shaped), axis=(1, 2))
        shaped[~finite] = 0.0
        p = self._base.gram.shape[0]
        gram = np.broadcast_to(self._base.gram, (g, p, p)).copy()
        cross = np.broadcast_to(self._base.cross, (g, p, 3)).copy()
        with_fixed = shaped @ self._fixed_phi.T
        shaped_rows, fixed_rows = np.array(self._shaped)[:, None], np.array(self._fixed)[:, None]
        gram[:, shaped_rows, self._fixed] = with_fixed
        gram[:, fixed_rows, self._shaped] = np.swapaxes(with_fixed, 1, 2)
        gram[:, shaped_rows, self._shaped] = shaped @ np.swapaxes(shaped, 1, 2)
        cross[:, self._shaped] = shaped @ self._acc.T
        sums = NormalEquations.of_sums(self._base.rows, gram, cross, self._base.acc_squares)
        return np.where(finite[:, None], sums.residual_std(self._equation_index), np.inf)
