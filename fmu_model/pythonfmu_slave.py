"""The pythonfmu slave of the ship model: a thin FMI adapter over ``fmu_model``.

This file is the script of the FMU built by :func:`fmu_model.export_pythonfmu.build_pythonfmu_fmu`.
The class only holds the values of the FMU variables (``fmu_model.interface.fmu_variables``
in value-reference order) and the 6-state (u, v, r, x, y, ψ); ``do_step`` advances the
state with ``n_substeps`` classical RK4 steps of :func:`fmu_model.simulate.rk4_step`, inputs
held over the communication step, exactly as ``fmu_model.simulate(method="rk4")`` and the
native C FMU do. The equations live in ``fmu_model``, which travels inside the FMU.

Resources read at instantiation (next to this script in ``resources/``):
``params.json`` (the parameter set, :func:`fmu_model.params.load_params`) and
``fmu_settings.json`` (``{"max_step_s": ...}``, the start value of ``max_step``).

Status mapping. pythonfmu turns every Python exception into ``fmi2Fatal`` and a ``False``
from ``do_step`` into ``fmi2Discard``; nothing here raises. A non-finite input or parameter
(or a non-positive ``length``/``max_step``) is stored, reported through the logger with
status ``fmi2Error`` at once, and every following ``fmi2DoStep`` returns ``fmi2Discard``
until a valid value is set. A step that would make the state non-finite returns
``fmi2Discard`` and leaves the state at the start of the step.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

from fmu_model.interface import FmuVariable, fmu_variables
from fmu_model.numeric import numeric_model
from fmu_model.params import ModelParameters, load_params
from fmu_model.simulate import n_substeps, rk4_step
from fmu_model.structure import STATE_NAMES

PARAMS_RESOURCE = "params.json"
SETTINGS_RESOURCE = "fmu_settings.json"

_CAUSALITY = {
    "input": Fmi2Causality.input,
    "output": Fmi2Causality.output,
    "parameter": Fmi2Causality.parameter,
}
_VARIABILITY = {"continuous": Fmi2Variability.continuous, "fixed": Fmi2Variability.fixed}


def slave_variables(params: ModelParameters, max_step_s: float) -> tuple[FmuVariable, ...]:
    """Return the FMU variables of ``params`` with ``max_step`` starting at ``max_step_s`` [s]."""
    return tuple(
        replace(v, start=max_step_s) if v.name == "max_step" else v for v in fmu_variables(params)
    )


def model_identifier(vessel_name: str) -> str:
    """Make a C identifier from the vessel name (the FMU's modelIdentifier)."""
    text = re.sub(r"\W", "_", vessel_name, flags=re.ASCII).strip("_") or "ship"
    return f"_{text}" if text[0].isdigit() else text


class ShipManoeuvringSlave(Fmi2Slave):
    """FMI 2.0 co-simulation slave of one identified ship model (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        resources = Path(self.resources)
        params = load_params(resources / PARAMS_RESOURCE)
        settings = json.loads((resources / SETTINGS_RESOURCE).read_text(encoding="utf-8"))
        self._variables = slave_variables(params, float(settings["max_step_s"]))
        self._model = numeric_model(params.model)
        self.modelName = model_identifier(params.vessel_name)  # names the binary

        vr = {v.name: v.value_reference for v in self._variables}
        self._vr_rudder = vr["rudder_angle"]
        self._vr_rpm = vr["propeller_rpm"]
        self._vr_length = vr["length"]
        self._vr_max_step = vr["max_step"]
        self._vr_initial = [vr[f"{name}0"] for name in STATE_NAMES]
        self._vr_theta = [vr[name] for name in params.names]
        self._state_index = {vr[name]: i for i, name in enumerate(STATE_NAMES)}

        self._values = [math.nan if v.start is None else float(v.start) for v in self._variables]
        self._state = np.array([self._values[k] for k in self._vr_initial])
        self._problems: dict[str, str] = {}
        self._initialised = False
        self._theta = np.array([self._values[k] for k in self._vr_theta])

        for variable in self._variables:
            k = variable.value_reference
            self.register_variable(
                Real(
                    variable.name,
                    causality=_CAUSALITY[variable.causality],
                    variability=_VARIABILITY[variable.variability],
                    description=variable.description,
                    getter=lambda k=k: self._get(k),
                    setter=lambda value, k=k: self._set(k, value),
                )
            )

    # -- variable access ------------------------------------------------------------------

    def _get(self, k: int) -> float:
        i = self._state_index.get(k)
        return float(self._state[i]) if i is not None else self._values[k]

    def _set(self, k: int, value: float) -> None:
        variable = self._variables[k]
        if variable.causality == "output":
            self.log(f"{variable.name} is an output and cannot be set", Fmi2Status.error)
            return
        if variable.causality == "parameter" and self._initialised:
            self.log(
                f"{variable.name} is a fixed parameter and cannot be changed after "
                "initialisation; value ignored",
                Fmi2Status.error,
            )
            return
        value = float(value)
        self._values[k] = value
        problem = self._check(variable, value)
        if problem is None:
            self._problems.pop(variable.name, None)
        else:
            self._problems[variable.name] = problem
            self.log(problem, Fmi2Status.error)
        if k in self._vr_initial:
            self._state[self._vr_initial.index(k)] = value

    def _check(self, variable: FmuVariable, value: float) -> str | None:
        if not math.isfinite(value):
            return f"{variable.name} must be finite, got {value}"
        if variable.name in ("length", "max_step") and value <= 0.0:
            return f"{variable.name} must be positive, got {value}"
        return None

    # -- FMI life cycle -------------------------------------------------------------------

    def exit_initialization_mode(self) -> None:
        """Fix the parameters and start the state from u0 ... psi0."""
        self._theta = np.array([self._values[k] for k in self._vr_theta])
        self._state = np.array([self._values[k] for k in self._vr_initial])
        self._initialised = True

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Advance the state over one communication step; ``False`` means fmi2Discard."""
        if not self._initialised:
            self.log("fmi2DoStep called before initialisation", Fmi2Status.error)
            return False
        if self._problems:
            self.log("; ".join(self._problems.values()), Fmi2Status.error)
            return False
        if not (math.isfinite(step_size) and step_size >= 0.0):
            self.log(f"communication step must be >= 0, got {step_size}", Fmi2Status.error)
            return False
        rudder = np.float64(self._values[self._vr_rudder])
        n_rps = np.float64(self._values[self._vr_rpm]) / 60.0
        length = self._values[self._vr_length]
        m = n_substeps(step_size, self._values[self._vr_max_step])
        h = step_size / m
        state = self._state
        with np.errstate(all="ignore"):  # divergence is detected below, not warned about
            for _ in range(m):
                state = rk4_step(self._model, self._theta, length, state, rudder, n_rps, h)
        if not np.all(np.isfinite(state)):
            self.log(
                f"state diverged in the step from t = {current_time} s by {step_size} s; "
                "state kept at the start of the step",
                Fmi2Status.discard,
            )
            return False
        self._state = state
        return True

    # -- FMU state (fmi2Get/SetFMUstate, serialisation as JSON by pythonfmu) --------------

    def _get_fmu_state(self) -> dict[str, Any]:
        return {
            "values": list(self._values),
            "state": [float(s) for s in self._state],
            "theta": [float(t) for t in self._theta],
            "problems": dict(self._problems),
            "initialised": self._initialised,
        }

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        self._values = [float(v) for v in state["values"]]
        self._state = np.array(state["state"], dtype=float)
        self._theta = np.array(state["theta"], dtype=float)
        self._problems = dict(state["problems"])
        self._initialised = bool(state["initialised"])
