"""What the reference ships of a published right-hand side share: the plant and the trim.

A reference ship given by its equations of motion ṡ = f(s, δ, n) in calm water
(``scenarios.mariner``, ``scenarios.tanker``) becomes a plant of ``trials.run`` through
:class:`RhsPlant` (the one integrator, ``fmu_model.integrate.rk4_into``), and its
straight run at the approach through :func:`straight_run_helm`: the rudder and sway that
hold it against a single screw's side force and yaw moment.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import root

from fmu_model.integrate import rk4_into
from trials.maneuvers import Helm
from trials.run import SingleShip

Rhs = Callable[[np.ndarray, float, float], np.ndarray]
"""ṡ of the state [u, v, r, x, y, psi] at the rudder [rad] and the propeller rate [rev/s]."""


def _derivative_into(
    state: np.ndarray, rhs: Rhs, inputs: tuple[float, float], out: np.ndarray
) -> None:
    """``fmu_model.integrate`` form of an :data:`Rhs`."""
    out[:] = rhs(state, *inputs)


class RhsPlant(SingleShip):
    """A ship given by its :data:`Rhs` as a plant of ``trials.run``, in calm water.

    RK4 with equal substeps of at most ``max_substep_s`` [s], the rudder and the
    propeller rate held over each communication step.
    """

    def __init__(self, rhs: Rhs, length_m: float, max_substep_s: float) -> None:
        self.rhs = rhs
        self.length_m = length_m
        self.max_substep_s = max_substep_s
        self._state = np.zeros(6)

    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state``."""
        self._state = np.array(initial_state, dtype=float)

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` [s] with the rudder [rad] and the propeller rate [rev/s] held."""
        if not (math.isfinite(dt_s) and dt_s > 0.0):
            raise ValueError(f"dt_s must be a positive finite number, got {dt_s!r}")
        n_sub = max(1, math.ceil(dt_s / self.max_substep_s - 1e-9))
        h = dt_s / n_sub
        work = np.empty((5, 6))
        inputs = (float(rudder_rad), float(n_rps))
        for _ in range(n_sub):
            rk4_into(_derivative_into, self._state, h, self.rhs, inputs, inputs, inputs, work)
        return self._state.copy()


def straight_run_helm(
    side_force_and_moment: Callable[[float, float], tuple[float, float]],
    speed_mps: float,
    name: str,
) -> Helm:
    """Return the rudder [rad] and sway velocity [m/s] of a ship's straight run.

    The trim Y = N = 0 at r = 0 of ``side_force_and_moment(v′, rudder_rad)`` (v′ = v/U
    at the approach ``speed_mps``): the helm a trial's approach is steadied on.

    Raises
    ------
    RuntimeError
        The trim does not converge (no straight run near the rudder amidships).

    """

    def residual(z: np.ndarray) -> list[float]:
        return list(side_force_and_moment(float(z[0]), float(z[1])))

    trim = root(residual, np.zeros(2), tol=1e-14)
    if not trim.success:
        raise RuntimeError(f"no straight run of the {name} at U0: {trim.message}")
    v_prime, rudder_rad = (float(x) for x in trim.x)
    return Helm(rudder_rad=rudder_rad, sway_mps=v_prime * speed_mps)
