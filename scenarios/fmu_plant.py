"""An FMU of this project's interface as a plant of the programme runner, through fmpy."""

from __future__ import annotations

import os
import shutil
import tempfile
from types import TracebackType

import numpy as np

from trials.run import SingleShip

INPUTS = ("rudder_angle", "propeller_rpm")
"""Input variables the plant sets every step (rudder [rad], propeller speed [rpm])."""
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
        self._outputs = [self._vr[k] for k in OUTPUTS]
        self._inputs = [self._vr[k] for k in INPUTS]

    def reset(self, initial_state: np.ndarray) -> None:
        """Reset the FMU and initialise it at ``initial_state``."""
        if self._initialised:
            self._slave.reset()
        self._slave.setReal([self._vr[k] for k in INITIAL_STATE], [float(s) for s in initial_state])
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
