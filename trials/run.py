"""The one programme runner: drive ships through a manoeuvre programme, step by step.

One driver for every "plant": an FMU through fmpy (``scenarios.fmu_plant``), the MMG
reference ship (``scenarios.kvlcc2``) and the identified model itself (:class:`ModelPlant`,
the same equations as the FMU, RK4 of ``fmu_model.integrate``), which may hold a batch
of K coefficient sets stepped together (Monte-Carlo draws, virtual turns of several
candidates). The driver owns the steering gear (the rudder moves toward the leg's
command at the rudder rate) and evaluates the legs' end conditions on the heading the
plant returns after each communication step, per ship, so the zig-zag is closed-loop
and every ship ends (and reverses its rudder) at its own time; a switch takes effect at
the next communication step (≤ 0.5 % on overshoots at 0.1 s full scale, reference §10).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from fmu_model import ModelParameters, n_substeps, numeric_model, rk4_step
from trials.maneuvers import (
    AUTOPILOT_DERIVATIVE_L,
    AUTOPILOT_GAIN,
    AUTOPILOT_LIMIT_RAD,
    Program,
)
from trials.trajectory import trajectory_of


class Plant(Protocol):
    """Ships that can be stepped together: state (u, v, r, x, y, ψ) in SI units, (6, K)."""

    length_m: float
    n_ships: int

    def reset(self, initial_state: np.ndarray) -> None:
        """Start every ship again from ``initial_state`` (6,)."""

    def step_ships(
        self, ships: np.ndarray, rudder_rad: np.ndarray, n_rps: np.ndarray, dt_s: float
    ) -> np.ndarray:
        """Advance the ships ``ships`` (indices) by ``dt_s`` with the inputs held.

        Returns their new states, (6, len(ships)).
        """
        ...


class SingleShip(ABC):
    """Base of a plant of one ship: implement ``reset`` and ``step``; this adds the batch API."""

    length_m: float
    n_ships = 1

    @abstractmethod
    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state`` (6,)."""

    @abstractmethod
    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` with the inputs held; return the new state (6,)."""

    def step_ships(
        self, ships: np.ndarray, rudder_rad: np.ndarray, n_rps: np.ndarray, dt_s: float
    ) -> np.ndarray:
        """:meth:`step` for the one ship (``ships`` is ``[0]``); (6, 1)."""
        return np.asarray(self.step(float(rudder_rad[0]), float(n_rps[0]), dt_s))[:, None]


@dataclass
class ModelPlant:
    """The ``fmu_model`` Python model, RK4 with the FMU's substep rule.

    In still air and water unless ``environment`` says otherwise, as the FMU with its
    environment inputs at 0: a ship with a windage (``params.windage``) feels the air load
    of its own motion, as the FMU does.

    Parameters
    ----------
    params : ModelParameters
        Model, vessel and (unless ``thetas`` is given) the coefficients.
    max_step_s : float, optional
        Largest internal RK4 step [s] (the FMU's ``max_step``); one step per
        communication step when None.
    thetas : numpy.ndarray, optional
        (p, K) coefficient sets, one ship each; ``params``' coefficients when None.
    environment : tuple of float, optional
        A steady current and true wind, as the FMU's environment inputs: (current speed
        [m/s], direction it sets towards [rad], wind speed [m/s], direction it comes
        from [rad]); the wind loads the ship through ``params.windage`` only.

    """

    params: ModelParameters
    max_step_s: float | None = None
    thetas: np.ndarray | None = None
    environment: tuple[float, float, float, float] | None = None
    _state: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self.length_m = self.params.length_m
        self._model = numeric_model(self.params.structure)
        theta = self.params.to_vector()[:, None] if self.thetas is None else self.thetas
        self._thetas = np.asarray(theta, dtype=float)
        self.n_ships = self._thetas.shape[1]
        self._state = np.zeros((6, self.n_ships))

    def reset(self, initial_state: np.ndarray) -> None:
        """Start every ship again from ``initial_state`` (6,)."""
        self._state = np.repeat(np.asarray(initial_state, dtype=float)[:, None], self.n_ships, 1)

    def step_ships(
        self, ships: np.ndarray, rudder_rad: np.ndarray, n_rps: np.ndarray, dt_s: float
    ) -> np.ndarray:
        """Advance the ships ``ships`` by ``dt_s`` in RK4 substeps; their states (6, k)."""
        state = self._state[:, ships]
        theta = self._thetas[:, ships]
        if ships.size == 1:  # scalar rows: the same arithmetic, far less numpy overhead
            state, theta = state[:, 0], theta[:, 0]
            rudder_rad, n_rps = rudder_rad[0], n_rps[0]
        m = n_substeps(dt_s, self.max_step_s)
        with np.errstate(all="ignore"):  # a diverging draw is the runner's to judge
            for _ in range(m):
                state = rk4_step(
                    self._model,
                    theta,
                    self.length_m,
                    state,
                    rudder_rad,
                    n_rps,
                    dt_s / m,
                    environment=self.environment,
                    windage=self.params.windage,
                )
        state = state.reshape(6, ships.size)
        self._state[:, ships] = state
        return state


@dataclass(frozen=True)
class BatchRun:
    """What :func:`run_batch` returns.

    Attributes
    ----------
    trajectories : tuple of numpy.ndarray
        Per ship its trajectory (``TRAJECTORY_DTYPE``, time 0 at execute); for a ship
        that diverged, up to its last finite state.
    diverged : numpy.ndarray
        (K,) bool.
    diverged_at_s : numpy.ndarray
        (K,) time of the step that diverged [s]; NaN for the others.

    """

    trajectories: tuple[np.ndarray, ...]
    diverged: np.ndarray
    diverged_at_s: np.ndarray


def run_batch(
    plant: Plant,
    program: Program,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float,
    dt_s: float,
    divergence_factor: float = math.inf,
    progress: Callable[[float], None] | None = None,
) -> BatchRun:
    """Run ``program`` on every ship of ``plant``; each follows its own legs.

    Every ship has its own leg index, leg start time, heading at execute and rudder
    angle; all advance together by one communication step until each has finished its
    last leg (or the step limit: the approach, the legs' time limits and one step per
    leg), or diverged.

    Parameters
    ----------
    plant : Plant
        The ships to drive.
    program : Program
        Approach + legs (``trials.maneuvers``).
    speed_mps : float
        Approach speed U [m/s]; every ship starts at u = U, r = 0 at the origin,
        heading North, with the rudder and sway of the programme's ``approach_helm``.
    n_rps : float
        Propeller speed [rev/s] unless a leg sets its own.
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    dt_s : float
        Communication step [s].
    divergence_factor : float
        A ship diverges when its state turns non-finite, or its speed exceeds this × U
        or its |r| this × U/L [-] (inf: non-finite only).
    progress : callable, optional
        Called with the simulated time [s] every 100 steps.

    Returns
    -------
    BatchRun
        Trajectories (rows at every communication point, the approach at negative
        times) and which ships diverged.

    """
    if not dt_s > 0.0:
        raise ValueError("dt_s must be positive")
    n_ships = plant.n_ships
    legs = program.legs
    n_legs = len(legs)

    # Per leg, and a last entry for "all legs done" (index n_legs).
    rudder_cmd = np.array([leg.rudder_rad for leg in legs] + [0.0])
    steer = np.array([leg.steer for leg in legs] + [False])
    n_cmd = np.array([n_rps if leg.n_rps is None else leg.n_rps for leg in legs] + [n_rps])
    time_limit = _per_leg([leg.until.time_s for leg in legs], math.inf)
    above = _per_leg([leg.until.heading_above_rad for leg in legs], math.inf)
    below = _per_leg([leg.until.heading_below_rad for leg in legs], -math.inf)

    approach_steps = round(program.approach_s / dt_s)
    max_steps = approach_steps + int(
        sum((leg.until.time_s or 0.0) for leg in legs) / dt_s + n_legs + 1
    )
    history = np.empty((max_steps + 1, 8, n_ships))  # per step: u v r x y ψ | rudder n
    time_s = np.empty(max_steps + 1)

    state = np.zeros((6, n_ships))
    state[0] = speed_mps
    state[1] = program.approach_helm.sway_mps
    plant.reset(state[:, 0].copy())
    rudder = np.full(n_ships, program.approach_helm.rudder_rad)
    n_now = np.full(n_ships, float(n_rps))
    t = -approach_steps * dt_s
    executed = approach_steps == 0
    leg = np.zeros(n_ships, dtype=int)
    leg_start = np.full(n_ships, t)
    heading0 = np.zeros(n_ships)
    course = np.zeros(n_ships)  # a steering leg's: the heading at its start
    active = np.ones(n_ships, dtype=bool)
    diverged = np.zeros(n_ships, dtype=bool)
    diverged_at = np.full(n_ships, math.nan)
    rows = np.zeros(n_ships, dtype=int)
    max_move = rudder_rate_radps * dt_s
    time_unit_s = plant.length_m / speed_mps if steer.any() else 0.0  # L/U₀
    envelope = math.isfinite(divergence_factor)
    max_speed = divergence_factor * speed_mps
    max_yaw_rate = divergence_factor * speed_mps / plant.length_m
    k = 0
    while True:
        if not executed and t >= -1e-9:  # execute: the approach is over
            executed = True
            leg_start[:] = t
            heading0 = state[5].copy()
            course = heading0.copy()
        going = active
        if executed:
            change = state[5] - heading0
            for _ in range(n_legs):  # several legs may end at the same step
                done = active & (
                    (t - leg_start >= time_limit[leg] - 1e-9)
                    | (change >= above[leg])
                    | (change <= below[leg])
                )
                if not done.any():
                    break
                leg = leg + done
                leg_start = np.where(done, t, leg_start)
                course = np.where(done, state[5], course)
            finished = active & ((leg >= n_legs) | (k >= max_steps))
            rows[finished] = k + 1
            going = active & ~finished
            n_now = np.where(going, n_cmd[leg], n_now)
            command = rudder_cmd[leg]
            if steer.any():  # the autopilot of a steering leg (trials.maneuvers.Leg)
                off_course = state[5] - course + AUTOPILOT_DERIVATIVE_L * state[2] * time_unit_s
                correction = np.clip(
                    AUTOPILOT_GAIN * off_course, -AUTOPILOT_LIMIT_RAD, AUTOPILOT_LIMIT_RAD
                )
                command = np.where(steer[leg], command - correction, command)
            # Steering gear: constant-rate move toward the command within one step.
            move = np.minimum(np.maximum(command - rudder, -max_move), max_move)
            rudder = np.where(going, rudder + move, rudder)
        # The inputs are held over [t, t + dt).
        time_s[k] = t
        history[k, :6] = state
        history[k, 6] = rudder
        history[k, 7] = n_now
        active = going
        if not active.any():
            break
        idx = np.flatnonzero(active)
        new = plant.step_ships(idx, rudder[idx], n_now[idx], dt_s)
        bad = ~np.isfinite(new).all(axis=0)
        if envelope:
            with np.errstate(invalid="ignore"):
                bad |= (np.hypot(new[0], new[1]) > max_speed) | (np.abs(new[2]) > max_yaw_rate)
        state[:, idx] = new
        if bad.any():
            lost = idx[bad]
            diverged[lost] = True
            diverged_at[lost] = t
            rows[lost] = k + 1
            active[lost] = False
        t += dt_s
        k += 1
        if progress is not None and k % 100 == 0:
            progress(t)

    trajectories = []
    for j in range(n_ships):
        ship = history[: rows[j], :, j]
        trajectories.append(trajectory_of(time_s[: rows[j]], ship[:, :6], ship[:, 6], ship[:, 7]))
    return BatchRun(tuple(trajectories), diverged, diverged_at)


def _per_leg(values: list[float | None], missing: float) -> np.ndarray:
    """One entry per leg (``missing`` for None) and ``missing`` for "all legs done"."""
    return np.array([missing if x is None else x for x in values] + [missing], dtype=float)


def run_program(
    plant: Plant,
    program: Program,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float,
    dt_s: float,
    progress: Callable[[float], None] | None = None,
) -> np.ndarray:
    """Run ``program`` on a plant of one ship; its trajectory (``TRAJECTORY_DTYPE``).

    :func:`run_batch` for one ship, which diverges only when its state turns
    non-finite.

    Raises
    ------
    FloatingPointError
        The simulation diverged.

    """
    if plant.n_ships != 1:
        raise ValueError(f"run_program drives one ship; this plant has {plant.n_ships}")
    run = run_batch(
        plant,
        program,
        speed_mps=speed_mps,
        n_rps=n_rps,
        rudder_rate_radps=rudder_rate_radps,
        dt_s=dt_s,
        progress=progress,
    )
    if run.diverged[0]:
        raise FloatingPointError(
            f"{program.name}: the simulation diverged at t = {run.diverged_at_s[0]:.1f} s"
        )
    return run.trajectories[0]
