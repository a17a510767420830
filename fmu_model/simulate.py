"""Fixed-step simulation of a model: RK4 (as inside the FMU) and the paper's forward Euler.

RK4 is the project's one integrator, ``fmu_model.integrate.rk4_into``.

Input convention: rudder angle and propeller speed are given at the sample times
``time_s``. RK4 holds each input constant over its step (zero-order hold), exactly as
an FMU does between communication points. Forward Euler uses the step's averaged
inputs, s̄(k) = (s(k) + s(k+1)) / 2 (Shi et al. 2009, eq. (4)).

The environment (current and wind, constant or sampled at ``time_s``, held over each
step in both methods) adds the terms of
:func:`fmu_model.environment.environment_derivative` to the model's right-hand side,
as the FMU does; without current and windage nothing is added.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from fmu_model.environment import Windage, environment_derivative
from fmu_model.integrate import n_substeps, rk4_into
from fmu_model.numeric import NumericModel, numeric_model
from fmu_model.params import ModelParameters

Environment = tuple[Any, Any, Any, Any]
"""(current speed [m/s], current direction [rad, towards], wind speed [m/s], wind
direction [rad, from]), each a float or an array over the batch."""


def _model_derivative(
    state: np.ndarray, context: tuple[NumericModel, np.ndarray, float], inputs: Any, out: np.ndarray
) -> None:
    """ṡ of the model (``NumericModel.rhs``) into ``out``; inputs (rudder [rad], n [rev/s])."""
    model, theta, length_m = context
    rudder_rad, n_rps = inputs
    out[...] = model.rhs(state, rudder_rad, n_rps, theta, length_m)


def _environment_model_derivative(
    state: np.ndarray,
    context: tuple[NumericModel, np.ndarray, float, Windage | None],
    inputs: Any,
    out: np.ndarray,
) -> None:
    """Write the model's ṡ plus the environment's terms into out (as the FMU's C does)."""
    model, theta, length_m, windage = context
    rudder_rad, n_rps, environment = inputs
    out[...] = model.rhs(state, rudder_rad, n_rps, theta, length_m)
    out += environment_derivative(state, *_four(environment), windage)


def rk4_step(
    model: NumericModel,
    theta: np.ndarray,
    length_m: float,
    state: np.ndarray,
    rudder_rad: Any,
    n_rps: Any,
    step_s: float,
    *,
    environment: Environment | None = None,
    windage: Windage | None = None,
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
    environment : tuple, optional
        (current speed [m/s], current direction [rad, towards], wind speed [m/s], wind
        direction [rad, from]), held over the step; ``None``: calm water, no current.
    windage : Windage, optional
        The ship's windage (``None``: no wind load).

    Returns
    -------
    numpy.ndarray
        The state after the step (a new array).

    """
    new = np.array(state, dtype=float)
    work = np.empty((5, *new.shape))
    if environment is None and windage is None:
        inputs: tuple[Any, ...] = (rudder_rad, n_rps)
        context: tuple[Any, ...] = (model, theta, length_m)
        rk4_into(_model_derivative, new, step_s, context, inputs, inputs, inputs, work)
        return new
    inputs = (rudder_rad, n_rps, (0.0, 0.0, 0.0, 0.0) if environment is None else environment)
    context = (model, theta, length_m, windage)
    rk4_into(_environment_model_derivative, new, step_s, context, inputs, inputs, inputs, work)
    return new


def euler_step(
    model: NumericModel,
    theta: np.ndarray,
    length_m: float,
    state: np.ndarray,
    rudder_rad: float,
    n_rps: float,
    step_s: float,
    *,
    environment: Environment | None = None,
    windage: Windage | None = None,
) -> np.ndarray:
    """Advance the 6-state by one forward-Euler step (Shi et al. 2009, eq. (4)).

    ``environment`` and ``windage`` as in :func:`rk4_step`.
    """
    derivative = model.rhs(state, rudder_rad, n_rps, theta, length_m)
    if environment is not None or windage is not None:
        environment = (0.0, 0.0, 0.0, 0.0) if environment is None else environment
        derivative = derivative + environment_derivative(state, *_four(environment), windage)
    return state + step_s * derivative


def simulate(
    params: ModelParameters,
    time_s: Sequence[float] | np.ndarray,
    rudder_rad: Sequence[float] | np.ndarray,
    n_rps: Sequence[float] | np.ndarray,
    initial_state: Sequence[float] | np.ndarray,
    *,
    method: str = "rk4",
    max_step_s: float | None = None,
    current_speed_mps: Any = 0.0,
    current_direction_rad: Any = 0.0,
    wind_speed_mps: Any = 0.0,
    wind_direction_rad: Any = 0.0,
    windage: Windage | None = None,
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
    current_speed_mps : float or array_like
        Speed of the current over ground [m/s], constant or at the sample times (N,).
    current_direction_rad : float or array_like
        Direction the current sets towards, clockwise from North [rad].
    wind_speed_mps : float or array_like
        True wind speed over ground [m/s].
    wind_direction_rad : float or array_like
        Direction the true wind comes from, clockwise from North [rad].
    windage : Windage, optional
        The ship's windage; default ``params.windage`` (``None``: no wind load). The
        environment is held over each step, as an FMU holds its inputs.

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
    environment = _environment_series(
        t.size, current_speed_mps, current_direction_rad, wind_speed_mps, wind_direction_rad
    )
    if windage is None:
        windage = params.windage
    if windage is not None and not windage.has_wind_load:
        windage = None
    calm = environment is None or not np.any(environment[0])  # no current
    if calm and windage is None:
        environment = None  # nothing to add: the model alone, bit for bit
    model = numeric_model(params.structure)
    theta = params.to_vector()
    states = np.empty((t.size, 6))
    states[0] = np.asarray(initial_state, dtype=float)
    for k in range(t.size - 1):
        dt = t[k + 1] - t[k]
        m = n_substeps(dt, max_step_s)
        h = dt / m
        state = states[k]
        options: dict[str, Any] = {}
        if environment is not None:
            options = {"environment": tuple(environment[:, k]), "windage": windage}
        if method == "rk4":
            for _ in range(m):
                state = rk4_step(
                    model, theta, params.length_m, state, rudder[k], n[k], h, **options
                )
        else:
            mean_rudder = 0.5 * (rudder[k] + rudder[k + 1])
            mean_n = 0.5 * (n[k] + n[k + 1])
            for _ in range(m):
                state = euler_step(
                    model, theta, params.length_m, state, mean_rudder, mean_n, h, **options
                )
        states[k + 1] = state
    return states


def _four(environment: Environment) -> Environment:
    """Return the four entries of ``environment`` (unpacked: the type checker sees four)."""
    current_speed, current_direction, wind_speed, wind_direction = environment
    return current_speed, current_direction, wind_speed, wind_direction


def _environment_series(size: int, *series: Any) -> np.ndarray | None:
    """Return the four environment inputs at the ``size`` sample times, shape (4, size).

    ``None`` when all are the scalar 0 (the default). Raises ValueError for a series
    of another length, a non-finite value, or a negative speed.
    """
    if all(np.ndim(s) == 0 and float(s) == 0.0 for s in series):
        return None
    out = np.empty((4, size))
    names = ("current_speed_mps", "current_direction_rad", "wind_speed_mps", "wind_direction_rad")
    for i, (name, values) in enumerate(zip(names, series, strict=True)):
        array = np.asarray(values, dtype=float)
        if array.ndim != 0 and array.shape != (size,):
            raise ValueError(f"{name} must be a number or an array like time_s, got {array.shape}")
        if not np.all(np.isfinite(array)):
            raise ValueError(f"{name} must be finite")
        if i in (0, 2) and np.any(array < 0.0):
            raise ValueError(f"{name} must be >= 0")
        out[i] = array
    return out
