"""The pythonfmu slave of the ship model: a thin FMI adapter over ``fmu_model``.

This file is the script of the FMU built by :func:`fmu_model.export_pythonfmu.build_pythonfmu_fmu`.
The class only holds the values of the FMU variables (:func:`fmu_model.interface.fmu_variables`
in value-reference order) and the 6-state (u, v, r, x, y, ψ); ``do_step`` advances the
state with ``n_substeps`` classical RK4 steps of :func:`fmu_model.simulate.rk4_step`, inputs
held over the communication step, exactly as ``fmu_model.simulate(method="rk4")`` and the
native C FMU do. The equations, the variable table, the value rule, the modelIdentifier
and the divergence rule live in ``fmu_model``, which travels inside the FMU.

Resources read at instantiation (next to this script in ``resources/``):
``params.json`` (the parameter set, :func:`fmu_model.params.load_params`) and
``fmu_settings.json`` (``{"max_step_s": ...}``, the start value of ``max_step``).

Status mapping. pythonfmu turns every Python exception into ``fmi2Fatal`` and a ``False``
from ``do_step`` into ``fmi2Discard``, so where the native FMU returns ``fmi2Error`` this
slave logs the error and, if it concerns a step, returns ``fmi2Discard``; nothing here
raises. A value that :meth:`fmu_model.interface.FmuVariable.problem` rejects (non-finite
or outside the declared min/max) is stored, reported through the logger with status
``fmi2Error`` at once, and every following ``fmi2DoStep`` returns ``fmi2Discard`` until a
valid value is set. A non-positive or non-finite communication step, a step that does not
advance the time (t + h == t) and a step of more than
:data:`fmu_model.interface.MAX_SUBSTEPS` internal steps are refused as by the native FMU,
with its message. A state that diverges in an internal step
(:func:`fmu_model.interface.state_diverged`) ends the step with ``fmi2Discard`` and the
native FMU's message; the state stays at the start of the step and, as in the native
FMU's state "step failed", every further ``fmi2DoStep`` is refused until
``fmi2SetFMUstate`` restores a state.

Where the native FMU refuses a call that pythonfmu cannot let fail without
``fmi2Fatal``, the refusal is logged (status ``fmi2Error``, the native message) and
every following ``fmi2DoStep`` returns ``fmi2Discard`` with that message:

* ``fmi2ExitInitializationMode`` below the model's least start speed
  (:func:`fmu_model.interface.min_start_speed_mps`): the native FMU stays in
  initialization mode; here the instance is initialised but never steps (the native
  FMU's message, then ``fmi2Discard`` from every step).
* ``fmi2SetFMUstate`` with a state that :func:`fmu_model.interface.fmu_state_problem`
  rejects (a value ``fmi2SetReal`` would refuse), or that is not a state of this FMU:
  the instance keeps its values and state, as in the native FMU, but steps are refused
  until a valid state is restored. ``fmi2DeSerializeFMUstate`` cannot refuse here (the
  native FMU checks there already); a corrupt serialised state is refused at
  ``fmi2SetFMUstate``. A state saved while a refused ``fmi2SetReal`` value was pending
  holds that value and is refused too (the native FMU never stores such a value).

The status queries (``fmi2GetStatus``, ``fmi2GetRealStatus``, ...) are answered by
pythonfmu's compiled wrapper, not here: pythonfmu 0.7 gives ``fmi2Error`` for
``fmi2GetStatus`` where the native FMU gives ``fmi2Discard``, and ``fmi2Discard`` for the
other statuses it cannot give, as the native FMU does.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

from fmu_model.integrate import n_substeps
from fmu_model.interface import (
    MAX_SUBSTEPS,
    START_SPEED_FORMAT,
    SUBSTEP_LIMIT_FORMAT,
    TIME_STALL_FORMAT,
    divergence_message,
    fmu_state_problem,
    fmu_variables,
    min_start_speed_mps,
    model_identifier,
    state_diverged,
)
from fmu_model.numeric import numeric_model
from fmu_model.params import load_params
from fmu_model.simulate import rk4_step
from fmu_model.structure import STATE_NAMES

PARAMS_RESOURCE = "params.json"
SETTINGS_RESOURCE = "fmu_settings.json"

_CAUSALITY = {
    "input": Fmi2Causality.input,
    "output": Fmi2Causality.output,
    "parameter": Fmi2Causality.parameter,
}
_VARIABILITY = {"continuous": Fmi2Variability.continuous, "fixed": Fmi2Variability.fixed}
# Keys of self._problems that are not variable names: they block steps until cleared.
_START_SPEED = "(start speed)"
_RESTORED_STATE = "(restored FMU state)"
# Key of a serialised state that could not be read (see _fmu_state_from_bytes).
_UNREADABLE = "unreadable"


class ShipManoeuvringSlave(Fmi2Slave):
    """FMI 2.0 co-simulation slave of one identified ship model (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        resources = Path(self.resources)
        params = load_params(resources / PARAMS_RESOURCE)
        settings = json.loads((resources / SETTINGS_RESOURCE).read_text(encoding="utf-8"))
        self._variables = fmu_variables(params, float(settings["max_step_s"]))
        self._model = numeric_model(params.structure)
        self._min_start_speed = min_start_speed_mps(params.structure)
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
        self._step_failed = False
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
        problem = variable.problem(value)
        if problem is None:
            self._problems.pop(variable.name, None)
        else:
            self._problems[variable.name] = problem
            self.log(problem, Fmi2Status.error)
        if k in self._vr_initial:
            self._state[self._vr_initial.index(k)] = value

    # -- FMI life cycle -------------------------------------------------------------------

    def exit_initialization_mode(self) -> None:
        """Fix the parameters and start the state from u0 ... psi0.

        A start speed below the model's least (the native FMU's fmi2Error) is logged
        and blocks every step.
        """
        self._theta = np.array([self._values[k] for k in self._vr_theta])
        self._state = np.array([self._values[k] for k in self._vr_initial])
        self._initialised = True
        message = self._start_speed_problem()
        if message is not None:
            self._problems[_START_SPEED] = message
            self.log(message, Fmi2Status.error)

    def _start_speed_problem(self) -> str | None:
        """Return the message refusing the start speed sqrt(u0² + v0²), or None."""
        u0, v0 = (self._values[k] for k in self._vr_initial[:2])
        speed = math.sqrt(u0 * u0 + v0 * v0)
        if self._min_start_speed > 0.0 and not speed >= self._min_start_speed:
            return START_SPEED_FORMAT % (speed, self._min_start_speed)
        return None

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Advance the state over one communication step; ``False`` means fmi2Discard.

        Parameters
        ----------
        current_time : float
            Start of the communication step [s].
        step_size : float
            Length of the communication step [s], > 0.

        Returns
        -------
        bool
            ``True`` when the state advanced, ``False`` (fmi2Discard, with a logged
            message) when the step was refused or the state diverged.

        """
        if not self._initialised:
            self.log("fmi2DoStep called before initialisation", Fmi2Status.error)
            return False
        if self._step_failed:
            self.log("fmi2DoStep must not be called in state 'step failed'", Fmi2Status.error)
            return False
        if self._problems:
            self.log("; ".join(self._problems.values()), Fmi2Status.error)
            return False
        if not (step_size > 0.0 and math.isfinite(step_size)):
            self.log(
                f"fmi2DoStep: communicationStepSize must be positive and finite, got {step_size}",
                Fmi2Status.error,
            )
            return False
        if not current_time + step_size > current_time:
            self.log(TIME_STALL_FORMAT % (step_size, current_time), Fmi2Status.error)
            return False
        max_step = self._values[self._vr_max_step]
        if step_size > max_step and not step_size / max_step * (1.0 - 1e-12) <= MAX_SUBSTEPS:
            ratio = step_size / max_step
            message = SUBSTEP_LIMIT_FORMAT % (step_size, ratio, max_step, MAX_SUBSTEPS)
            self.log(message, Fmi2Status.error)
            return False
        rudder = np.float64(self._values[self._vr_rudder])
        n_rps = np.float64(self._values[self._vr_rpm]) / 60.0
        length = self._values[self._vr_length]
        m = n_substeps(step_size, max_step)
        h = step_size / m
        state = self._state
        with np.errstate(all="ignore"):  # divergence is detected below, not warned about
            for i in range(m):
                state = rk4_step(self._model, self._theta, length, state, rudder, n_rps, h)
                if state_diverged(state):
                    self._step_failed = True
                    message = divergence_message(current_time + (i + 1) * h, state, current_time)
                    self.log(message, Fmi2Status.discard)
                    return False
        self._state = state
        return True

    # -- FMU state (fmi2Get/SetFMUstate, serialisation as JSON by pythonfmu) --------------

    def _get_fmu_state(self) -> dict[str, Any]:
        return {
            "values": list(self._values),
            "state": [float(s) for s in self._state],
            "initialised": self._initialised,
            "step_failed": self._step_failed,
        }

    def _set_fmu_state(self, state: dict[str, Any]) -> None:
        """Restore ``state``, or refuse it as the native FMU does (see the module docstring).

        Every value is checked as ``fmi2SetReal`` would check it. What follows from the
        values is derived, not read: the coefficients in use (fixed at initialisation)
        and, for an initialised state, the refusal of a start below the least speed.
        """
        try:
            restored = self._read_fmu_state(state)
        except (KeyError, TypeError, ValueError, OverflowError) as exc:
            reason = str(exc.args[0]) if exc.args else type(exc).__name__
            restored = f"fmi2SetFMUstate: not an FMU state of this FMU ({reason})"
        if isinstance(restored, str):
            self._problems[_RESTORED_STATE] = restored
            self.log(restored, Fmi2Status.error)
            return
        values, vector, initialised, step_failed = restored
        self._values = values
        self._state = vector
        self._theta = np.array([values[k] for k in self._vr_theta])
        self._initialised = initialised
        self._step_failed = step_failed
        self._problems = {}
        message = self._start_speed_problem() if initialised else None
        if message is not None:
            self._problems[_START_SPEED] = message

    def _read_fmu_state(self, state: Any) -> str | tuple[list[float], np.ndarray, bool, bool]:
        """Return the parts of a saved state, or the message refusing its values.

        Raises KeyError, TypeError, ValueError or OverflowError for a malformed state.
        """
        if not isinstance(state, dict) or _UNREADABLE in state:
            raise ValueError(state.get(_UNREADABLE) if isinstance(state, dict) else "no object")
        values = [_number(v) for v in state["values"]]
        vector = np.array([_number(v) for v in state["state"]])
        initialised, step_failed = state["initialised"], state["step_failed"]
        if len(values) != len(self._variables) or vector.shape != (len(STATE_NAMES),):
            raise ValueError("wrong number of values")
        if not (isinstance(initialised, bool) and isinstance(step_failed, bool)):
            raise TypeError("malformed flags")
        seen = list(values)  # the outputs are the state vector, as in the native FMU
        for k, i in self._state_index.items():
            seen[k] = vector[i]
        problem = fmu_state_problem(self._variables, seen, "fmi2SetFMUstate")
        if problem is not None:
            return problem
        return values, vector, initialised, step_failed

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        """Parse a serialised state; never raises (pythonfmu would make that fmi2Fatal)."""
        try:
            parsed = json.loads(state.decode("utf-8"))
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            return {_UNREADABLE: f"not JSON: {type(exc).__name__}"}
        return parsed if isinstance(parsed, dict) else {_UNREADABLE: "not a JSON object"}


def _number(value: Any) -> float:
    """Return a JSON number as float; TypeError for anything else (bool, text, ...)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{value!r} is not a number")
    return float(value)
