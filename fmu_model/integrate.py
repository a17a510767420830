"""The one integrator: classical fourth-order Runge–Kutta with a substep rule.

Every simulation in the project steps through :func:`rk4_into`: the identified model in
numpy (``fmu_model.simulate``, the pythonfmu FMU, the programme runner of ``trials``,
one ship or a batch of them), the same model in numba (``fmu_model.replay``: the
function below compiled with ``numba.njit``, as the regressor kernels are generated
from the symbolic structure), and the MMG reference ship of ``scenarios``. The native
FMU's C (``fmu_model/c``) is the same scheme, tested against it to 1e-12.

The function is written in the subset of Python that numba compiles, in place and
without allocation: the state's rows are updated one by one, so a row may be a scalar
(one ship) or a vector (a batch of ships stepped together); the results are the same
bits either way (element-wise arithmetic in the same order).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

Derivative = Callable[[np.ndarray, Any, Any, np.ndarray], None]
"""``f(state, context, inputs, out)``: write ṡ at ``state`` into ``out`` (same shape)."""


def rk4_into(
    f: Derivative,
    state: np.ndarray,
    step_s: float,
    context: Any,
    at_start: Any,
    at_middle: Any,
    at_end: Any,
    work: np.ndarray,
) -> None:
    """Advance ``state`` in place by one classical Runge–Kutta step.

    With h the step and f the derivative,

        k₁ = f(s, i₀), k₂ = f(s + h/2 k₁, i½), k₃ = f(s + h/2 k₂, i½), k₄ = f(s + h k₃, i₁),
        s ← s + h/6 (k₁ + 2 k₂ + 2 k₃ + k₄),

    where i₀, i½, i₁ are the inputs at the start, middle and end of the step (equal for
    inputs held over the step, as an FMU holds them between communication points).

    Parameters
    ----------
    f : callable
        ``f(state, context, inputs, out)`` writes the time derivative into ``out``.
    state : numpy.ndarray
        State, shape (n,) or (n, K) for K systems stepped together; updated in place.
    step_s : float
        Step h [s].
    context : object
        Passed to ``f`` unchanged (coefficients, ship data, scratch arrays).
    at_start, at_middle, at_end : object
        Inputs passed to ``f`` at the four stages (start, middle twice, end).
    work : numpy.ndarray
        Scratch, shape (5,) + ``state.shape``: k₁ … k₄ and the stage state.

    """
    half = 0.5 * step_s
    k1, k2, k3, k4, stage = work[0], work[1], work[2], work[3], work[4]
    f(state, context, at_start, k1)
    for c in range(state.shape[0]):
        stage[c] = state[c] + half * k1[c]
    f(stage, context, at_middle, k2)
    for c in range(state.shape[0]):
        stage[c] = state[c] + half * k2[c]
    f(stage, context, at_middle, k3)
    for c in range(state.shape[0]):
        stage[c] = state[c] + step_s * k3[c]
    f(stage, context, at_end, k4)
    for c in range(state.shape[0]):
        state[c] = state[c] + (step_s / 6.0) * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c])


def n_substeps(step_s: float, max_step_s: float | None) -> int:
    """Return the number of equal internal steps of a communication step (as the C FMU).

    ``ceil(step / max_step)`` with a 1e-12 relative guard so that, e.g., 0.3 / 0.1
    gives 3 and not 4.
    """
    if max_step_s is None or step_s <= max_step_s:
        return 1
    return max(1, math.ceil(step_s / max_step_s * (1.0 - 1e-12)))
