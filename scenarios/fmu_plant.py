"""An FMU of this project's interface as a plant of the programme runner, through fmpy.

At sea (``environment``, a :class:`scenarios.sea.SeaEnvironment`) the plant also sets
the FMU's environment inputs before every communication step: ``current_speed`` and
``current_direction`` (towards) from the current over ground at the step's start,
``wind_speed`` and ``wind_direction`` (from) from the true wind there, gusts included
(the same Ornstein-Uhlenbeck path as the reference ship's of the same length and seed,
``scenarios.kvlcc2``). The FMU holds its inputs over the step, so a changing current or
a gust is seen as a staircase of the communication step; a steady environment is
exact. A current whose linear speed passes through zero, or a gust below the mean
wind's opposite, is given to the FMU as the opposite direction with the positive speed
(its inputs are speeds ≥ 0). Without an environment the plant sets only the rudder and
the propeller speed, as before the environment inputs existed.
"""

from __future__ import annotations

import math
import os
import shutil
import tempfile
from types import TracebackType

import numpy as np

from fmu_model.interface import ENVIRONMENT_NAMES
from scenarios.sea import GustProcess, SeaEnvironment, default_gust_time_s
from trials.run import SingleShip

INPUTS = ("rudder_angle", "propeller_rpm")
"""Input variables the plant sets every step (rudder [rad], propeller speed [rpm])."""
ENVIRONMENT_INPUTS = ENVIRONMENT_NAMES
"""Inputs it sets too at sea: current speed [m/s] and direction towards [rad], true wind
speed [m/s] and direction from [rad]."""
OUTPUTS = ("u", "v", "r", "x", "y", "psi")
"""Output variables it reads back: the 6-state in ``fmu_model``'s order."""
INITIAL_STATE = ("u0", "v0", "r0", "x0", "y0", "psi0")
"""Parameters it sets before initialisation."""
REQUIRED_VARIABLES = (*INPUTS, *OUTPUTS, "length", *INITIAL_STATE)
"""Every variable an FMU must have to be driven by :class:`FmuPlant`."""


class FmuPlant(SingleShip):
    """An FMU with this project's interface, through fmpy's ``FMU2Slave``.

    Use as a context manager, or call :meth:`close`. The FMU is unpacked once and
    instantiated once; :meth:`reset` uses ``fmi2Reset`` and sets the initial state
    parameters ``u0 … psi0`` before initialisation.

    Parameters
    ----------
    fmu_path : path-like
        The FMU.
    instance_name : str
        Its instance name.
    environment : SeaEnvironment, optional
        Current and wind to sail in (module docstring); its time runs from the last
        :meth:`reset`. None: the inputs ``current_*`` and ``wind_*`` are never set.

    Raises
    ------
    ValueError
        An environment is given but the FMU has no environment inputs.

    """

    def __init__(
        self,
        fmu_path: str | os.PathLike[str],
        instance_name: str = "ship",
        environment: SeaEnvironment | None = None,
    ) -> None:
        from fmpy import extract, read_model_description
        from fmpy.fmi2 import FMU2Slave

        self._instantiated = False
        self._dir = tempfile.mkdtemp(prefix="shipfmu-")
        try:
            extract(str(fmu_path), unzipdir=self._dir)
            md = read_model_description(self._dir)
            self._vr = {v.name: v.valueReference for v in md.modelVariables}
            missing = [k for k in ENVIRONMENT_INPUTS if k not in self._vr]
            if environment is not None and missing:
                raise ValueError(
                    f"{os.fspath(fmu_path)}: the FMU has no environment inputs "
                    f"({', '.join(missing)}) to sail it at sea"
                )
        except BaseException:
            shutil.rmtree(self._dir, ignore_errors=True)
            raise
        starts = {v.name: v.start for v in md.modelVariables}
        self.length_m = float(starts["length"])
        self.environment = environment
        self._gust_time_s: float | None = None
        if environment is not None:
            self._gust_time_s = (
                default_gust_time_s(self.length_m)
                if environment.gust_time_s is None
                else environment.gust_time_s
            )
        self._gust: GustProcess | None = None
        self._slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=self._dir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName=instance_name,
        )
        self._slave.instantiate()
        self._instantiated = True
        # An FMU built from identified parameters warns when a step goes beyond the
        # envelope of their logs (fmu_model.envelope), for hosts that know nothing else;
        # the scenarios judge whole runs against it themselves (--params).
        self._slave.setDebugLogging(False, ["logStatusWarning"])
        self._initialised = False
        self._time = 0.0
        self._outputs = [self._vr[k] for k in OUTPUTS]
        self._inputs = [self._vr[k] for k in INPUTS]
        if environment is not None:
            self._inputs += [self._vr[k] for k in ENVIRONMENT_INPUTS]

    @property
    def gust_time_s(self) -> float | None:
        """Correlation time of the gusts in use [s]; None without an environment."""
        return self._gust_time_s

    def reset(self, initial_state: np.ndarray) -> None:
        """Reset the FMU and initialise it at ``initial_state`` (time 0, the same gusts)."""
        if self._initialised:
            self._slave.reset()
        self._slave.setReal([self._vr[k] for k in INITIAL_STATE], [float(s) for s in initial_state])
        self._slave.setupExperiment(startTime=0.0)
        self._slave.enterInitializationMode()
        self._slave.exitInitializationMode()
        self._initialised = True
        self._time = 0.0
        env = self.environment
        if env is not None and self._gust_time_s is not None:
            self._gust = GustProcess(env.gust_std_mps, self._gust_time_s, env.gust_seed)

    def environment_inputs(self, time_s: float) -> tuple[float, float, float, float]:
        """Return the FMU's environment inputs at ``time_s`` from the last reset.

        Returns
        -------
        tuple of float
            Current speed [m/s] and the direction it sets towards [rad], true wind speed
            [m/s] and the direction it comes from [rad]; zeros without an environment.

        """
        env = self.environment
        if env is None:
            return 0.0, 0.0, 0.0, 0.0
        if env.current_is_steady:  # the values as given, bit for bit
            current, towards = env.current_speed_mps, env.current_to_rad
        else:
            current = env.current_speed_mps + env.current_change_mps2 * time_s
            towards = env.current_to_rad + env.current_veer_radps * time_s
            if current < 0.0:
                current, towards = -current, towards + math.pi
            towards = math.remainder(towards, 2.0 * math.pi)
        wind, wind_from = env.wind_speed_mps, env.wind_from_rad
        if self._gust is not None and env.gust_std_mps > 0.0:
            wind += self._gust.value(time_s)
            if wind < 0.0:
                wind, wind_from = -wind, math.remainder(wind_from + math.pi, 2.0 * math.pi)
        return current, towards, wind, wind_from

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Set the inputs, ``fmi2DoStep`` over ``dt_s`` and return the outputs."""
        if self.environment is None:
            self._slave.setReal(self._inputs, [rudder_rad, n_rps * 60.0])
        else:
            sea = self.environment_inputs(self._time)
            self._slave.setReal(self._inputs, [rudder_rad, n_rps * 60.0, *sea])
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
