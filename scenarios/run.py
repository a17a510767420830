"""Drive a ship through a manoeuvre program, step by step, and record the trajectory.

One driver for every "plant": an FMU through fmpy (the normal case), the Python model of
``fmu_model`` (the same equations, for cross-checks) and the KVLCC2 reference ship. The
driver owns the steering gear (the rudder moves toward the leg's command at the rudder
rate) and evaluates the legs' end conditions on the heading the plant returns after each
communication step, so the zig-zag is closed-loop; a switch takes effect at the next
communication step (≤ 0.5 % on overshoots at 0.1 s full scale, reference §10).
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from types import TracebackType
from typing import Protocol

import numpy as np

from fmu_model import ModelParameters, n_substeps, numeric_model, rk4_step
from scenarios.kvlcc2 import MmgShip
from scenarios.kvlcc2 import step as mmg_step
from scenarios.maneuvers import Program, Until
from scenarios.trajectory import empty_trajectory


class Plant(Protocol):
    """A ship that can be stepped: state (u, v, r, x, y, ψ) in SI units."""

    length_m: float

    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state``."""

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` with the inputs held; return the new state."""
        ...


@dataclass
class ModelPlant:
    """The ``fmu_model`` Python model, RK4 with the FMU's substep rule."""

    params: ModelParameters
    max_step_s: float | None = None

    def __post_init__(self) -> None:
        self.length_m = self.params.length_m
        self._model = numeric_model(self.params.model)
        self._theta = self.params.to_vector()
        self._state = np.zeros(6)

    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state``."""
        self._state = np.array(initial_state, dtype=float)

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` with RK4 substeps."""
        m = n_substeps(dt_s, self.max_step_s)
        for _ in range(m):
            self._state = rk4_step(
                self._model, self._theta, self.length_m, self._state, rudder_rad, n_rps, dt_s / m
            )
        return self._state


@dataclass
class ReferencePlant:
    """The MMG reference ship (``scenarios.kvlcc2``), rudder held over each step."""

    ship: MmgShip

    def __post_init__(self) -> None:
        self.length_m = self.ship.length_m
        self._state = np.zeros(6)

    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state``."""
        self._state = np.array(initial_state, dtype=float)

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` (the MMG model's own RK4 substeps)."""
        self._state = mmg_step(self.ship, self._state, rudder_rad, n_rps, dt_s)
        return self._state


class FmuPlant:
    """An FMU with this project's interface, through fmpy's ``FMU2Slave``.

    Use as a context manager, or call :meth:`close`. The FMU is unpacked once and
    instantiated once; :meth:`reset` uses ``fmi2Reset`` and sets the initial state
    parameters ``u0 … psi0`` before initialisation.
    """

    def __init__(self, fmu_path: str | os.PathLike[str], instance_name: str = "ship") -> None:
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Slave

        self._dir = tempfile.mkdtemp(prefix="shipfmu-")
        from fmpy import extract

        extract(str(fmu_path), unzipdir=self._dir)
        md = read_model_description(self._dir)
        self._vr = {v.name: v.valueReference for v in md.modelVariables}
        starts = {v.name: v.start for v in md.modelVariables}
        self.length_m = float(starts["length"])
        self._slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._dir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self._slave.instantiate()
        self._instantiated = True
        self._initialised = False
        self._time = 0.0
        self._outputs = [self._vr[k] for k in ("u", "v", "r", "x", "y", "psi")]
        self._inputs = [self._vr["rudder_angle"], self._vr["propeller_rpm"]]

    def reset(self, initial_state: np.ndarray) -> None:
        """Reset the FMU and initialise it at ``initial_state``."""
        if self._initialised:
            self._slave.reset()
        names = ("u0", "v0", "r0", "x0", "y0", "psi0")
        self._slave.setReal([self._vr[k] for k in names], [float(s) for s in initial_state])
        self._slave.setupExperiment(startTime=0.0)
        self._slave.enterInitializationMode()
        self._slave.exitInitializationMode()
        self._initialised = True
        self._time = 0.0

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Set the inputs, ``fmi2DoStep`` over ``dt_s`` and return the outputs."""
        self._slave.setReal(self._inputs, [rudder_rad, n_rps * 60.0])
        self._slave.doStep(currentCommunicationPoint=self._time, communicationStepSize=dt_s)
        self._time += dt_s
        return np.array(self._slave.getReal(self._outputs))

    def close(self) -> None:
        """Terminate, free the instance and remove the unpacked files."""
        if self._instantiated:
            if self._initialised:
                self._slave.terminate()
            self._slave.freeInstance()
            self._instantiated = False
        shutil.rmtree(self._dir, ignore_errors=True)

    def __enter__(self) -> FmuPlant:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _leg_done(until: Until, time_in_leg_s: float, heading_change_rad: float) -> bool:
    if until.time_s is not None and time_in_leg_s >= until.time_s - 1e-9:
        return True
    if until.heading_above_rad is not None and heading_change_rad >= until.heading_above_rad:
        return True
    return until.heading_below_rad is not None and heading_change_rad <= until.heading_below_rad


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
    """Run ``program`` on ``plant`` and return the trajectory (``TRAJECTORY_DTYPE``).

    Parameters
    ----------
    plant : Plant
        The ship to drive.
    program : Program
        Approach + legs (``scenarios.maneuvers``).
    speed_mps : float
        Approach speed [m/s]; the run starts at u = speed, v = r = 0 at the origin,
        heading North.
    n_rps : float
        Propeller speed [rev/s] unless a leg sets its own.
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    dt_s : float
        Communication step [s].
    progress : callable, optional
        Called with the simulated time [s] every 100 steps.

    Returns
    -------
    numpy.ndarray
        Rows at every communication point; time 0 is the execute point (the approach
        has negative times).

    """
    if dt_s <= 0.0:
        raise ValueError("dt_s must be positive")
    state = np.array([speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0])
    plant.reset(state)
    legs = program.legs
    approach_steps = round(program.approach_s / dt_s)
    max_steps = approach_steps + int(
        sum((leg.until.time_s or 0.0) for leg in legs) / dt_s + len(legs) + 1
    )
    traj = empty_trajectory(max_steps + 1)
    rudder = 0.0
    n_now = n_rps
    t = -approach_steps * dt_s
    leg_index = -1 if approach_steps > 0 else 0
    leg_start = t
    heading0 = 0.0
    k = 0
    while True:
        finished = False
        if leg_index < 0 and t >= -1e-9:  # execute: the approach is over
            leg_index, leg_start, heading0 = 0, t, state[5]
        command = 0.0
        if leg_index >= 0:
            change = state[5] - heading0
            while leg_index < len(legs) and _leg_done(legs[leg_index].until, t - leg_start, change):
                leg_index, leg_start = leg_index + 1, t
            finished = leg_index >= len(legs) or k >= max_steps
            if not finished:
                command = legs[leg_index].rudder_rad
                n_leg = legs[leg_index].n_rps
                n_now = n_rps if n_leg is None else n_leg
        if not finished:
            # Steering gear: constant-rate move toward the command within one step.
            max_move = rudder_rate_radps * dt_s
            rudder += float(np.clip(command - rudder, -max_move, max_move))
        row = traj[k]
        row["time_s"] = t
        row["u_mps"], row["v_mps"], row["r_radps"], row["x_m"], row["y_m"], row["psi_rad"] = state
        row["rudder_rad"], row["n_rps"] = rudder, n_now  # inputs held over [t, t + dt)
        if finished:
            return traj[: k + 1]
        state = plant.step(rudder, n_now, dt_s)
        if not np.all(np.isfinite(state)):
            raise FloatingPointError(f"{program.name}: the simulation diverged at t = {t:.1f} s")
        t += dt_s
        k += 1
        if progress is not None and k % 100 == 0:
            progress(t)
