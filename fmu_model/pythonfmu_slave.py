"""The pythonfmu slave of the ship model: a thin FMI adapter over generated equations.

This file is the script of the FMU built by :func:`fmu_model.export_pythonfmu.build_pythonfmu_fmu`.
The class only holds the values of the FMU variables (the table of
:func:`fmu_model.interface.fmu_variables`, carried as ``fmu_interface.json``) and the
6-state (u, v, r, x, y, ψ); ``do_step`` advances the state with ``n_substeps`` classical
RK4 steps of :func:`fmu_model.integrate.rk4_into` over the generated right-hand side,
inputs held over the communication step, exactly as ``fmu_model.simulate(method="rk4")``
and the native C FMU do. The rules (value, step, start, divergence, restored states)
are those of :mod:`fmu_model.fmi_rules`, with the native FMU's messages.

What the slave imports at run time is the FMU's own ``resources/``: ``fmu_model``'s
``fmi_rules``, ``integrate`` and ``envelope`` (standard library and numpy) and the
generated ``model_equations.py`` (standard library ``math`` only, from
:func:`fmu_model.codegen.generate_model_py`): the host Python needs **numpy** and nothing
else of this project's dependencies (no sympy). Resources read at instantiation:
``fmu_interface.json`` (the variable table, the modelIdentifier, the least start speed,
the envelope of the logs or null) and ``model_equations.py``.

Status mapping. pythonfmu 0.7's wrapper turns every Python exception into ``fmi2Fatal``
and a ``False`` from ``do_step`` into ``fmi2Discard``; it has no way to return
``fmi2Error`` from a setter, from ``fmi2ExitInitializationMode`` or from
``fmi2SetFMUstate``. So where the native FMU returns ``fmi2Error`` and leaves the
instance unchanged, this slave logs the native message with status ``fmi2Error``, keeps
the refused call from taking effect on the simulation, and every following
``fmi2DoStep`` returns ``fmi2Discard`` (with the message again) until the cause is
corrected; nothing here raises:

* a value :meth:`fmu_model.fmi_rules.FmuVariable.problem` rejects (non-finite or
  outside the declared min/max) is stored but blocks every step until a valid value is
  set; setting an output, a local or the time, or a fixed parameter after
  initialisation, is ignored, and so is a call with an unknown value reference
  (``fmi2GetReal`` then gives NaN; pythonfmu's own lookup would raise: ``fmi2Fatal``);
* a start below the model's least start speed (the native FMU stays in initialization
  mode): the instance is initialised but never steps;
* ``fmi2SetFMUstate`` with a state :func:`fmu_model.fmi_rules.fmu_state_problem`
  rejects, an initialised one whose windage :func:`fmu_model.fmi_rules.windage_problem`
  rejects, or one that is not a state of this FMU: the instance keeps its values, but steps
  are refused until a valid state is restored (``fmi2DeSerializeFMUstate`` cannot
  refuse here; a corrupt serialised state is refused at ``fmi2SetFMUstate``).

A step the native FMU refuses (:func:`fmu_model.fmi_rules.step_problem`: not positive
and finite, not at the FMU's time, not advancing the time, more than
:data:`~fmu_model.fmi_rules.MAX_SUBSTEPS` internal steps) is ``fmi2Discard`` with the
native message; a diverging state (:func:`fmu_model.fmi_rules.state_diverged`) ends the
step with ``fmi2Discard`` and the native message, the state stays at the start of the
step and, as in the native state "step failed", every further ``fmi2DoStep`` is refused
until ``fmi2SetFMUstate`` restores a state. The status queries are answered by
pythonfmu's wrapper: ``fmi2GetStatus`` gives ``fmi2Error`` where the native FMU gives
``fmi2Discard``.

Beyond the logs: with the envelope of the identification's logs in
``fmu_interface.json``, every completed step is judged by
:class:`fmu_model.envelope.ExtrapolationWatch` and each axis and side gone beyond for the
first time is logged with status warning, the native FMU's text; the step is still
``fmi2OK``. (pythonfmu 0.7 passes messages on only when logging is on.)
"""

from __future__ import annotations

import importlib.util
import json
import math
from collections.abc import Sequence
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

from fmu_model.envelope import Envelope, ExtrapolationWatch, instant_envelope
from fmu_model.fmi_rules import (
    FmuVariable,
    divergence_message,
    fmu_state_problem,
    start_speed_problem,
    state_diverged,
    step_problem,
    windage_problem,
)
from fmu_model.integrate import n_substeps, rk4_into

INTERFACE_RESOURCE = "fmu_interface.json"
EQUATIONS_RESOURCE = "model_equations.py"
STATE_NAMES = ("u", "v", "r", "x", "y", "psi")
# Of fmu_model.interface (which the FMU does not carry: it needs sympy).
ENVIRONMENT_NAMES = ("current_speed", "current_direction", "wind_speed", "wind_direction")
GROUND_NAMES = ("sog", "cog")
WINDAGE_NAMES = (
    "frontal_area",
    "lateral_area",
    "length_overall",
    "lateral_centroid",
    "surge_mass",
    "sway_mass",
    "yaw_inertia",
    "sway_yaw_coupling",
)

# pythonfmu 0.7 has no causality "independent": the time is registered as a local (the
# completed modelDescription.xml declares it independent).
PYTHONFMU_CAUSALITY = {
    "input": Fmi2Causality.input,
    "output": Fmi2Causality.output,
    "parameter": Fmi2Causality.parameter,
    "local": Fmi2Causality.local,
    "independent": Fmi2Causality.local,
}
_VARIABILITY = {"continuous": Fmi2Variability.continuous, "fixed": Fmi2Variability.fixed}
# Keys of self._problems that are not variable names: they block steps until cleared.
_START_SPEED = "(start speed)"
_WINDAGE = "(windage)"
_RESTORED_STATE = "(restored FMU state)"
# Key of a serialised state that could not be read (see _fmu_state_from_bytes).
_UNREADABLE = "unreadable"


def load_equations(path: Path) -> ModuleType:
    """Load the generated equations module of one FMU under a name of its own.

    Two FMUs of different models in one process each keep their own equations.
    """
    spec = importlib.util.spec_from_file_location(f"_ship_equations_{id(path)}", path)
    assert spec is not None and spec.loader is not None  # a .py file always has a loader
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _derivative(state: np.ndarray, context: Any, inputs: Any, out: np.ndarray) -> None:
    """ṡ of the generated equations into ``out`` (the derivative of ``rk4_into``).

    The model's right-hand side, then what the environment adds (as the native FMU).
    """
    equations, theta, length, windage = context
    rudder, n_rps, environment = inputs
    equations.rhs(out, theta, length, state, rudder, n_rps)
    equations.environment_rhs(out, state, environment, windage)


class ShipManoeuvringSlave(Fmi2Slave):
    """FMI 2.0 co-simulation slave of one identified ship model (see the module docstring)."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        resources = Path(self.resources)
        interface = json.loads((resources / INTERFACE_RESOURCE).read_text(encoding="utf-8"))
        self._variables = tuple(FmuVariable.from_json(v) for v in interface["variables"])
        self._min_start_speed = float(interface["min_start_speed_mps"])
        logged = interface.get("envelope")
        envelope = None if logged is None else Envelope.from_dict(logged)
        self._watch = None if envelope is None else ExtrapolationWatch(envelope)
        self._equations = load_equations(resources / EQUATIONS_RESOURCE)
        self.modelName = interface["model_identifier"]  # names the binary

        vr = {v.name: v.value_reference for v in self._variables}
        self._vr_rudder = vr["rudder_angle"]
        self._vr_rpm = vr["propeller_rpm"]
        self._vr_length = vr["length"]
        self._vr_max_step = vr["max_step"]
        self._vr_initial = [vr[f"{name}0"] for name in STATE_NAMES]
        self._vr_theta = [vr[name] for name in self._equations.COEFFICIENT_NAMES]
        self._state_index = {vr[name]: i for i, name in enumerate(STATE_NAMES)}
        self._derivative_index = {
            v.value_reference: STATE_NAMES.index(v.derivative_of)
            for v in self._variables
            if v.derivative_of is not None
        }
        self._vr_time = vr["time"]
        self._vr_environment = [vr[name] for name in ENVIRONMENT_NAMES]
        self._ground_index = {vr[name]: i for i, name in enumerate(GROUND_NAMES)}
        self._vr_windage = [vr[name] for name in WINDAGE_NAMES]

        self._values = [math.nan if v.start is None else float(v.start) for v in self._variables]
        self._state = np.array([self._values[k] for k in self._vr_initial])
        self._problems: dict[str, str] = {}
        self._initialised = False
        self._step_failed = False
        self._time = 0.0
        self._theta = [self._values[k] for k in self._vr_theta]
        self._windage = [self._values[k] for k in self._vr_windage]
        self._work = np.empty((5, len(STATE_NAMES)))

        for variable in self._variables:
            k = variable.value_reference
            self.register_variable(
                Real(
                    variable.name,
                    causality=PYTHONFMU_CAUSALITY[variable.causality],
                    variability=_VARIABILITY[variable.variability],
                    description=variable.description,
                    getter=lambda k=k: self._get(k),
                    setter=lambda value, k=k: self._set(k, value),
                ),
                nested=False,
            )

    # -- variable access ------------------------------------------------------------------

    def _unknown(self, function: str, vrs: list[int]) -> bool:
        """Log the first value reference the FMU does not have, as the native FMU does.

        pythonfmu's own ``get_real``/``set_real`` raise ``KeyError`` for it, which its
        wrapper turns into ``fmi2Fatal``.
        """
        unknown = next((vr for vr in vrs if vr not in self.vars), None)
        if unknown is None:
            return False
        self.log(f"{function}: unknown value reference {unknown}", Fmi2Status.error)
        return True

    def get_real(self, vrs: list[int]) -> list[float]:
        """Values of ``vrs``; NaN for all when a value reference is unknown (logged)."""
        if self._unknown("fmi2GetReal", vrs):
            return [math.nan] * len(vrs)
        return super().get_real(vrs)

    def set_real(self, vrs: list[int], values: list[float]) -> None:
        """Set ``vrs`` to ``values``; nothing when a value reference is unknown (logged)."""
        if not self._unknown("fmi2SetReal", vrs):
            super().set_real(vrs, values)

    def _get(self, k: int) -> float:
        if k in self._state_index:
            return float(self._state[self._state_index[k]])
        if k in self._derivative_index:
            dx = np.zeros(len(STATE_NAMES))
            _derivative(self._state, self._context(), self._inputs(), dx)
            return float(dx[self._derivative_index[k]])
        if k in self._ground_index:
            ground = [0.0] * len(GROUND_NAMES)
            self._equations.ground(ground, self._state, self._environment())
            return float(ground[self._ground_index[k]])
        if k == self._vr_time:
            return self._time
        return self._values[k]

    def _environment(self) -> list[float]:
        return [self._values[k] for k in self._vr_environment]

    def _inputs(self) -> tuple[float, float, list[float]]:
        """Rudder [rad], propeller speed [rev/s] and environment, as ``_derivative`` takes them."""
        rpm = self._values[self._vr_rpm]
        return self._values[self._vr_rudder], rpm / 60.0, self._environment()

    def _context(self) -> tuple[Any, list[float], float, list[float]]:
        return self._equations, self._theta, self._values[self._vr_length], self._windage

    def _set(self, k: int, value: float) -> None:
        variable = self._variables[k]
        if variable.causality not in ("input", "parameter"):
            self.log(f"fmi2SetReal: '{variable.name}' (vr {k}) cannot be set", Fmi2Status.error)
            return
        if variable.causality == "parameter" and self._initialised:
            self.log(
                f"fmi2SetReal: '{variable.name}' (vr {k}) is a fixed parameter; it can only "
                "be set before ExitInitializationMode",
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

    def setup_experiment(
        self, start_time: float, stop_time: float | None = None, tolerance: float | None = None
    ) -> None:
        """Start the time at ``start_time`` [s] (the stop time and tolerance are not used)."""
        self._time = float(start_time)

    def exit_initialization_mode(self) -> None:
        """Fix the parameters and start the state from u0 ... psi0.

        A start speed below the model's least or a windage whose sway-yaw mass matrix is
        singular (the native FMU's fmi2Error) is logged and blocks every step.
        """
        self._theta = [self._values[k] for k in self._vr_theta]
        self._windage = [self._values[k] for k in self._vr_windage]
        self._state = np.array([self._values[k] for k in self._vr_initial])
        self._initialised = True
        if self._watch is not None:
            self._watch.warned.clear()
        for key, message in self._start_problems().items():
            self._problems[key] = message
            self.log(message, Fmi2Status.error)

    def _start_problems(self) -> dict[str, str]:
        """Return the start speed's and the windage's problems, by key of ``self._problems``."""
        function = "fmi2ExitInitializationMode"
        u0, v0 = (self._values[k] for k in self._vr_initial[:2])
        found = {
            _START_SPEED: start_speed_problem(function, u0, v0, self._min_start_speed),
            _WINDAGE: _windage_problem(function, self._windage),
        }
        return {key: message for key, message in found.items() if message is not None}

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Advance the state over one communication step; ``False`` means fmi2Discard.

        Parameters
        ----------
        current_time : float
            Start of the communication step [s], the FMU's time.
        step_size : float
            Length of the communication step [s], > 0.

        Returns
        -------
        bool
            ``True`` when the state advanced, ``False`` (fmi2Discard, with a logged
            message) when the step was refused or the state diverged.

        """
        if not self._initialised:
            self.log("fmi2DoStep must not be called in state 'instantiated'", Fmi2Status.error)
            return False
        if self._step_failed:
            self.log("fmi2DoStep must not be called in state 'step failed'", Fmi2Status.error)
            return False
        if self._problems:
            self.log("; ".join(self._problems.values()), Fmi2Status.error)
            return False
        max_step = self._values[self._vr_max_step]
        message = step_problem("fmi2DoStep", self._time, current_time, step_size, max_step)
        if message is not None:
            self.log(message, Fmi2Status.error)
            return False
        inputs = self._inputs()
        context = self._context()
        m = n_substeps(step_size, max_step)
        h = step_size / m
        state = np.array(self._state)
        with np.errstate(all="ignore"):  # divergence is detected below, not warned about
            for i in range(m):
                try:
                    rk4_into(_derivative, state, h, context, inputs, inputs, inputs, self._work)
                except (OverflowError, ValueError, ZeroDivisionError):  # math's domain errors
                    state[:] = math.nan
                if state_diverged(state):
                    self._step_failed = True
                    message = divergence_message(
                        "fmi2DoStep", current_time + (i + 1) * h, state, current_time
                    )
                    self.log(message, Fmi2Status.discard)
                    return False
        self._state = state
        self._time = current_time + step_size
        self._warn_beyond_logs()
        return True

    def _warn_beyond_logs(self) -> None:
        """Log the axes the step went beyond the logs on for the first time (as warnings)."""
        if self._watch is None:
            return
        rudder, n_rps, _ = self._inputs()
        u0, v0 = (self._values[k] for k in self._vr_initial[:2])
        start_speed = math.sqrt(u0 * u0 + v0 * v0)
        length = self._values[self._vr_length]
        instant = instant_envelope(rudder, n_rps, self._state, start_speed, length)
        for message in self._watch.news("fmi2DoStep", self._time, instant):
            self.log(message, Fmi2Status.warning)

    # -- FMU state (fmi2Get/SetFMUstate, serialisation as JSON by pythonfmu) --------------

    def _get_fmu_state(self) -> dict[str, Any]:
        return {
            "values": list(self._values),
            "state": [float(s) for s in self._state],
            "time": self._time,
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
        values, vector, time, initialised, step_failed = restored
        self._values = values
        self._state = vector
        self._time = time
        self._theta = [values[k] for k in self._vr_theta]
        self._windage = [values[k] for k in self._vr_windage]
        self._initialised = initialised
        self._step_failed = step_failed
        self._problems = self._start_problems() if initialised else {}

    def _read_fmu_state(
        self, state: Any
    ) -> str | tuple[list[float], np.ndarray, float, bool, bool]:
        """Return the parts of a saved state, or the message refusing its values.

        Raises KeyError, TypeError, ValueError or OverflowError for a malformed state.
        """
        if not isinstance(state, dict) or _UNREADABLE in state:
            raise ValueError(state.get(_UNREADABLE) if isinstance(state, dict) else "no object")
        values = [_number(v) for v in state["values"]]
        vector = np.array([_number(v) for v in state["state"]])
        time = _number(state["time"])
        initialised, step_failed = state["initialised"], state["step_failed"]
        if len(values) != len(self._variables) or vector.shape != (len(STATE_NAMES),):
            raise ValueError("wrong number of values")
        if not (isinstance(initialised, bool) and isinstance(step_failed, bool)):
            raise TypeError("malformed flags")
        if not math.isfinite(time):
            return f"fmi2SetFMUstate: the FMU state is not restored: its time {time} must be finite"
        seen = list(values)  # the outputs are the state vector, as in the native FMU
        for k, i in self._state_index.items():
            seen[k] = vector[i]
        # Not stored: always valid.
        computed = set(self._derivative_index) | set(self._ground_index) | {self._vr_time}
        checked = [
            (v, x)
            for v, x in zip(self._variables, seen, strict=True)
            if v.value_reference not in computed
        ]
        problem = fmu_state_problem(
            [v for v, _ in checked], [x for _, x in checked], "fmi2SetFMUstate"
        )
        if problem is None and initialised:  # past initialisation: the windage is fixed
            problem = _windage_problem(
                "fmi2SetFMUstate: the FMU state is not restored",
                [values[k] for k in self._vr_windage],
            )
        if problem is not None:
            return problem
        return values, vector, time, initialised, step_failed

    @staticmethod
    def _fmu_state_from_bytes(state: bytes) -> dict[str, Any]:
        """Parse a serialised state; never raises (pythonfmu would make that fmi2Fatal)."""
        try:
            parsed = json.loads(state.decode("utf-8"))
        except (UnicodeDecodeError, ValueError, RecursionError) as exc:
            return {_UNREADABLE: f"not JSON: {type(exc).__name__}"}
        return parsed if isinstance(parsed, dict) else {_UNREADABLE: "not a JSON object"}


def _windage_problem(function: str, windage: Sequence[float]) -> str | None:
    """Return :func:`~fmu_model.fmi_rules.windage_problem` of values in ``WINDAGE_NAMES`` order."""
    named = dict(zip(WINDAGE_NAMES, windage, strict=True))
    return windage_problem(
        function, named["sway_mass"], named["yaw_inertia"], named["sway_yaw_coupling"]
    )


def _number(value: Any) -> float:
    """Return a JSON number as float; TypeError for anything else (bool, text, ...)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise TypeError(f"{value!r} is not a number")
    return float(value)
