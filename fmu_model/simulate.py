"""Fixed-step simulation of a model: RK4 (as inside the FMU) and the paper's forward Euler.

RK4 is the project's one integrator, ``fmu_model.integrate.rk4_into``.

Input convention: rudder angle and propeller speed are given at the sample times
``time_s``. RK4 holds each input constant over its step (zero-order hold), exactly as
an FMU does between communication points. Forward Euler uses the step's averaged
inputs, s̄(k) = (s(k) + s(k+1)) / 2 (Shi et al. 2009, eq. (4)).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from fmu_model.integrate import n_substeps, rk4_into
from fmu_model.numeric import NumericModel, numeric_model
from fmu_model.params import ModelParameters


def _model_derivative(
    state: np.ndarray, context: tuple[NumericModel, np.ndarray, float], inputs: Any, out: np.ndarray
) -> None:
    """ṡ of the model (``NumericModel.rhs``) into ``out``; inputs (rudder [rad], n [rev/s])."""
    model, theta, length_m = context
    rudder_rad, n_rps = inputs
    out[...] = model.rhs(state, rudder_rad, n_rps, theta, length_m)


def rk4_step(
    model: NumericModel,
    theta: np.ndarray,
    length_m: float,
    state: np.ndarray,
    rudder_rad: Any,
    n_rps: Any,
    step_s: float,
) -> np.ndarray:
    """Advance the 6-state by one classical Runge–Kutta step with inputs held constant.

    :func:`fmu_model.integrate.rk4_into` on the model's right-hand side; broadcasts over
    a trailing batch dimension (state (6, K), θ (p, K), inputs (K,)).

    Parameters
    ----------
    model : NumericModel
        Compiled model structure.
    theta : numpy.ndarray
        Coefficient vector (p,) or (p, K).
    length_m : float
        Ship length [m].
    state : numpy.ndarray
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]), shape (6,) or (6, K).
    rudder_rad : float or numpy.ndarray
        Rudder angle [rad], held over the step.
    n_rps : float or numpy.ndarray
        Propeller speed [rev/s], held over the step.
    step_s : float
        Step [s].

    Returns
    -------
    numpy.ndarray
        The state after the step (a new array).

    """
    new = np.array(state, dtype=float)
    inputs = (rudder_rad, n_rps)
    work = np.empty((5, *new.shape))
    rk4_into(_model_derivative, new, step_s, (model, theta, length_m), inputs, inputs, inputs, work)
    return new


def euler_step(
    model: NumericModel,
    theta: np.ndarray,
    length_m: float,
    state: np.ndarray,
    rudder_rad: float,
    n_rps: float,
    step_s: float,
) -> np.ndarray:
    """Advance the 6-state by one forward-Euler step (Shi et al. 2009, eq. (4))."""
    return state + step_s * model.rhs(state, rudder_rad, n_rps, theta, length_m)


def simulate(
    params: ModelParameters,
    time_s: Sequence[float] | np.ndarray,
    rudder_rad: Sequence[float] | np.ndarray,
    n_rps: Sequence[float] | np.ndarray,
    initial_state: Sequence[float] | np.ndarray,
    *,
    method: str = "rk4",
    max_step_s: float | None = None,
) -> np.ndarray:
    """Simulate the model for given rudder and propeller time histories.

    Parameters
    ----------
    params : ModelParameters
        Model variant and coefficients.
    time_s : array_like
        Strictly increasing sample times [s], shape (N,); steps may be irregular.
    rudder_rad : array_like
        Rudder angle at the sample times [rad], shape (N,).
    n_rps : array_like
        Propeller speed at the sample times [rev/s], shape (N,).
    initial_state : array_like
        (u, v, r, x, y, ψ) at ``time_s[0]`` in SI units.
    method : {"rk4", "euler"}
        RK4 with zero-order-hold inputs, or forward Euler with step-averaged inputs.
    max_step_s : float, optional
        Largest internal step [s]; each interval is split into ``n_substeps`` equal steps.

    Returns
    -------
    numpy.ndarray
        States at the sample times, shape (N, 6).

    """
    t = np.asarray(time_s, dtype=float)
    rudder = np.asarray(rudder_rad, dtype=float)
    n = np.asarray(n_rps, dtype=float)
    if t.ndim != 1 or rudder.shape != t.shape or n.shape != t.shape:
        raise ValueError("time_s, rudder_rad and n_rps must be 1-D arrays of equal length")
    if np.any(np.diff(t) <= 0.0):
        raise ValueError("time_s must be strictly increasing")
    if method not in ("rk4", "euler"):
        raise ValueError(f"unknown method {method!r} (use 'rk4' or 'euler')")
    model = numeric_model(params.structure)
    theta = params.to_vector()
    states = np.empty((t.size, 6))
    states[0] = np.asarray(initial_state, dtype=float)
    for k in range(t.size - 1):
        dt = t[k + 1] - t[k]
        m = n_substeps(dt, max_step_s)
        h = dt / m
        state = states[k]
        if method == "rk4":
            for _ in range(m):
                state = rk4_step(model, theta, params.length_m, state, rudder[k], n[k], h)
        else:
            mean_rudder = 0.5 * (rudder[k] + rudder[k + 1])
            mean_n = 0.5 * (n[k] + n[k + 1])
            for _ in range(m):
                state = euler_step(model, theta, params.length_m, state, mean_rudder, mean_n, h)
        states[k + 1] = state
    return states
