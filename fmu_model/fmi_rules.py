"""The run-time rules of the FMU, shared by every backend and every FMI version.

This module is what an FMU needs at run time besides its equations, and it imports
nothing but the standard library and numpy: the pythonfmu FMU carries it (with
``fmu_model.integrate`` and the generated numpy equations) so that the host needs numpy
only, and the native exporter writes its numbers and messages into ``model_config.h``
for the C layer. What is symbolic (the variable table of a model structure, its least
start speed) is in :mod:`fmu_model.interface`.

* the bounds of inputs, parameters and initial state, and :class:`FmuVariable` with its
  value rule :meth:`FmuVariable.problem` (finite and within the declared min/max);
* the divergence rule (:data:`MAX_SPEED_MPS`, :data:`MAX_YAW_RATE_RADPS`,
  :func:`state_diverged`, :data:`DIVERGENCE_FORMAT`);
* the rules of a co-simulation step (:func:`step_problem`: a positive finite step at the
  FMU's time that advances the time in at most :data:`MAX_SUBSTEPS` internal steps) and
  of the start (:data:`MIN_START_SPEED_MPS`, :func:`start_speed_problem`);
* the check of a restored FMU state (:func:`fmu_state_problem`);
* the modelIdentifier rule (:func:`model_identifier`).

The messages are printf formats: the C layer passes them to its logger, the pythonfmu
slave formats them with ``%``, so both backends log the same text. The formats of the
step and start rules are prefixed with the name of the FMI function and ``": "`` (e.g.
``fmi2DoStep: ``, ``fmi3DoStep: ``) where they are logged; those of restored states take
the function as their first argument.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

# Rudder angles beyond this are outside every steering gear we model [rad] (45 deg).
RUDDER_LIMIT_RAD = math.radians(45.0)
# Default largest internal RK4 step inside a co-simulation step (fmi2DoStep, fmi3DoStep) [s].
DEFAULT_MAX_STEP_S = 0.05
# Smallest largest internal RK4 step the FMU accepts [s] (the declared min of max_step).
MIN_MAX_STEP_S = 1e-6

# Bounds of the propeller speed input [rpm]: 100 rev/s either way. The fastest marine
# propellers (high-speed craft, outboard drives, small free-running models) turn at up
# to about 3000 rpm and a large merchant ship at 60-150 rpm, so this refuses no real
# propeller, astern included; a value beyond it is a unit mistake (rpm multiplied by 60
# once more, rev/h, ...) that the equations would turn into nonsense forces.
MAX_PROPELLER_RPM = 6000.0
# Bounds of the ship length [m]: from a 10 cm toy (free-running models are 1 m and
# more) to about twice the longest ship ever built (458 m); the equations divide by
# the length, so 0 must be out.
MIN_LENGTH_M = 0.1
MAX_LENGTH_M = 1000.0
# Bound of |x0| and |y0| [m]: 2.5 times the Earth's circumference. The North/East
# plane of the outputs means nothing that far out.
MAX_POSITION_M = 1.0e8
# Bound of |psi0| [rad]: the heading is continuous (not wrapped), so a run that starts
# where another ended may begin after many turns; 1e6 rad is 160 000 turns and keeps
# the heading to 1e-10 rad.
MAX_HEADING_RAD = 1.0e6

# Bounds of the environment inputs. The current over ground [m/s]: the fastest tidal
# races (Saltstraumen, Moskstraumen) run at about 10 m/s, so 20 m/s refuses no real
# current, but a speed in cm/s or a knots-to-m/s mistake squared would be refused.
MAX_CURRENT_SPEED_MPS = 20.0
# The true wind [m/s]: the highest gust measured is 113 m/s (Barrow Island, 1996).
MAX_WIND_SPEED_MPS = 150.0
# Bound of |current_direction| and |wind_direction| [rad], as of the heading: any angle
# works, but one beyond it has lost its precision.
MAX_DIRECTION_RAD = MAX_HEADING_RAD
# Bounds of the windage parameters: areas in [0, MAX_WINDAGE_AREA_M2] m² (a square
# kilometre), the lever of the lateral area within +-MAX_LENGTH_M, the effective masses
# [kg] and yaw inertia [kg m²] at least MIN_WINDAGE_INERTIA, since they divide.
MAX_WINDAGE_AREA_M2 = 1.0e6
MIN_WINDAGE_INERTIA = 1.0e-3

# A state beyond these bounds has diverged: no ship moves like this. |u| and |v| [m/s].
MAX_SPEED_MPS = 1.0e3
# ... and |r| [rad/s].
MAX_YAW_RATE_RADPS = 1.0e3
# The message of a diverged fmi2DoStep, a printf format shared by both backends (the C
# layer passes it to its logger, the pythonfmu slave formats it with ``%``): the time of
# the failed internal step [s], u [m/s], v [m/s], r [rad/s] there, MAX_SPEED_MPS,
# MAX_YAW_RATE_RADPS, and the time the state stays at (the start of the step) [s].
DIVERGENCE_FORMAT = (
    "the state diverged at t = %.9g s (u = %g m/s, v = %g m/s, r = %g rad/s; "
    "bounds %g m/s, %g rad/s); the state stays at t = %.9g s"
)

# Largest number of internal RK4 steps in one fmi2DoStep, so that one call returns
# within about a second. The native FMU takes 0.4 us (shi2009) to 1.0 us (prime-rudder,
# prime-modulus) per internal step on the 2-core machine of the measured figures
# (README), so the largest step takes 0.4-1.0 s (the old limit, 1e7, took 4-10 s). The
# pythonfmu FMU takes about 230 us per internal step, about 4 minutes for the largest
# step; the limit is shared so that both backends accept and refuse the same steps.
MAX_SUBSTEPS = 1_000_000
# The message of a step that needs more internal steps (refused before any work): h [s],
# h / max_step, max_step [s], MAX_SUBSTEPS.
SUBSTEP_LIMIT_FORMAT = (
    "the step h = %g s needs h / max_step = %.6g internal steps of "
    "max_step = %g s, more than the %.0f one call may take (about 1 s of CPU); take "
    "shorter communication steps or a larger max_step"
)
# The message of a step too small to advance the time: h [s], the time t [s].
TIME_STALL_FORMAT = (
    "the step h = %g s does not advance the time t = %.17g s (t + h == t in double precision)"
)

# The least start speed sqrt(u0^2 + v0^2) [m/s] of a model whose equations divide by the
# speed U = sqrt(u^2 + v^2) (speed-scaled variants such as prime-cubic, v'^3 U^2/L =
# v^3/(U L), and prime-rudder, its drift angle at the rudder -w/U): at U = 0 they are
# 0/0 and the first step would end as "diverged, u = nan". 1 mm/s is at rest for every
# practical purpose (a 4 m free-running model makes about 0.7 m/s, a tanker manoeuvres
# at 3-8 m/s), so no real start is refused, while v/U and rL/U are ordinary finite
# numbers there. A fraction of sqrt(gL) would scale with the ship, but would tie the
# limit to the parameter `length` and claim more than it is: the identified
# coefficients hold near the trial speed, not near rest, on any scale. Below it the
# start is refused; there is no low-speed blend.
MIN_START_SPEED_MPS = 1.0e-3
# The message of a refused start: the start speed [m/s], the least start speed [m/s].
START_SPEED_FORMAT = (
    "the start speed sqrt(u0^2 + v0^2) = %g m/s is below "
    "%g m/s, the least this model starts from (its equations divide by the speed); "
    "set u0 or v0"
)

# The message of a refused windage (at ExitInitializationMode, where its parameters are
# all set): the sway-yaw coupling x_G m [kg m] and the bound sqrt(sway_mass * yaw_inertia)
# [kg m] its size must stay below, or the sway-yaw mass matrix of the wind's
# accelerations is singular (fmu_model.environment.Windage refuses the same).
WINDAGE_COUPLING_FORMAT = (
    "the windage's sway_yaw_coupling %g kg.m makes the sway-yaw mass matrix singular: its "
    "size must stay below sqrt(sway_mass * yaw_inertia) = %g kg.m; set sway_yaw_coupling"
)

# The messages of a restored FMU state with a value fmi2SetReal would refuse: the
# function, the variable name, its value, and (out of range) its min and max (-inf and
# inf when not declared).
STATE_RANGE_FORMAT = "%s: the FMU state is not restored: %s = %.17g is outside [%.17g, %.17g]"
STATE_NONFINITE_FORMAT = "%s: the FMU state is not restored: %s must be finite, got %g"

# The messages of a refused co-simulation step (before any work): a step that is not
# positive and finite (h [s]), and a step that does not start at the FMU's time
# (currentCommunicationPoint [s], the FMU's time [s]), which it must equal within
# STEP_TIME_TOLERANCE relative to 1 + |time|.
STEP_SIZE_FORMAT = "communicationStepSize must be positive and finite, got %g"
STEP_TIME_FORMAT = "currentCommunicationPoint %.17g is not the FMU's time %.17g"
STEP_TIME_TOLERANCE = 1.0e-9
# The message of a model-exchange evaluation (the derivatives) at a diverged state: the
# time [s], u [m/s], v [m/s], r [rad/s] there, MAX_SPEED_MPS, MAX_YAW_RATE_RADPS.
DIVERGED_STATE_FORMAT = (
    "the state at t = %.9g s has diverged (u = %g m/s, v = %g m/s, r = %g rad/s; "
    "bounds %g m/s, %g rad/s)"
)


@dataclass(frozen=True)
class FmuVariable:
    """One scalar Real variable of the FMU.

    ``causality`` is ``"input"``, ``"output"``, ``"parameter"``, ``"local"`` (the time
    derivative of a state, ``derivative_of`` naming the state) or ``"independent"`` (the
    time). ``unit`` is an SI unit name declared in ``UnitDefinitions`` (``None`` for
    dimensionless); ``display_unit`` is a display unit inside that unit. ``min`` and
    ``max`` bound the values ``fmi2SetReal`` accepts (inclusive, in ``unit``).
    """

    name: str
    value_reference: int
    causality: str  # "input" | "output" | "parameter" | "local" | "independent"
    variability: str  # "continuous" | "fixed"
    start: float | None
    unit: str | None
    description: str
    display_unit: str | None = None
    min: float | None = None
    max: float | None = None
    derivative_of: str | None = None

    def problem(self, value: float) -> str | None:
        """Return why ``value`` cannot be set (``None`` when it can).

        A value must be finite and within the declared ``min`` and ``max``; both
        backends reject everything else (the C layer with the same rule, from
        ``model_config.h``).

        Parameters
        ----------
        value : float
            The value to set, in the variable's ``unit``.

        Returns
        -------
        str or None
            A one-line reason naming the variable, or ``None``.

        """
        if not math.isfinite(value):
            return f"{self.name} must be finite, got {value}"
        low = -math.inf if self.min is None else self.min
        high = math.inf if self.max is None else self.max
        if not low <= value <= high:
            return f"{self.name} = {value!r} is outside [{low!r}, {high!r}]"
        return None

    def to_json(self) -> dict[str, Any]:
        """Return the variable as a JSON object (the table the pythonfmu FMU carries)."""
        return asdict(self)

    @classmethod
    def from_json(cls, doc: Mapping[str, Any]) -> FmuVariable:
        """Return the variable of :meth:`to_json`'s object."""
        return cls(**doc)


def step_problem(
    function: str, fmu_time_s: float, time_s: float, step_s: float, max_step_s: float
) -> str | None:
    """Return why a co-simulation step is refused before any work (``None``: it is not).

    The rule of both backends' ``fmi2DoStep`` (and of ``fmi3DoStep``): the step ``h``
    must be positive and finite (:data:`STEP_SIZE_FORMAT`), start at the FMU's time
    (:data:`STEP_TIME_FORMAT`), advance the time (t + h > t in double precision,
    :data:`TIME_STALL_FORMAT`) and need at most :data:`MAX_SUBSTEPS` internal steps of
    ``max_step`` (:data:`SUBSTEP_LIMIT_FORMAT`).

    Parameters
    ----------
    function : str
        The FMI function, for the message (``"fmi2DoStep"``).
    fmu_time_s : float
        The FMU's time, the end of the last step [s].
    time_s : float
        currentCommunicationPoint [s].
    step_s : float
        communicationStepSize [s].
    max_step_s : float
        The largest internal RK4 step [s].

    Returns
    -------
    str or None
        The message the FMU logs with the error, or ``None``.

    """
    if not (step_s > 0.0 and math.isfinite(step_s)):
        return f"{function}: " + STEP_SIZE_FORMAT % step_s
    if not (
        math.isfinite(time_s)
        and abs(time_s - fmu_time_s) <= STEP_TIME_TOLERANCE * (1.0 + abs(fmu_time_s))
    ):
        return f"{function}: " + STEP_TIME_FORMAT % (time_s, fmu_time_s)
    if not time_s + step_s > time_s:
        return f"{function}: " + TIME_STALL_FORMAT % (step_s, time_s)
    if step_s > max_step_s and not step_s / max_step_s * (1.0 - 1e-12) <= MAX_SUBSTEPS:
        ratio = step_s / max_step_s
        return f"{function}: " + SUBSTEP_LIMIT_FORMAT % (step_s, ratio, max_step_s, MAX_SUBSTEPS)
    return None


def start_speed_problem(
    function: str, u0_mps: float, v0_mps: float, min_start_speed_mps: float
) -> str | None:
    """Return the message refusing a start speed sqrt(u0² + v0²), or ``None``.

    Parameters
    ----------
    function : str
        The FMI function, for the message (``"fmi2ExitInitializationMode"``).
    u0_mps, v0_mps : float
        Initial surge and sway velocity [m/s].
    min_start_speed_mps : float
        The model's least start speed [m/s] (0: it starts from rest).

    Returns
    -------
    str or None
        :data:`START_SPEED_FORMAT` filled in, or ``None``.

    """
    speed = math.sqrt(u0_mps * u0_mps + v0_mps * v0_mps)
    if min_start_speed_mps > 0.0 and not speed >= min_start_speed_mps:
        return f"{function}: " + START_SPEED_FORMAT % (speed, min_start_speed_mps)
    return None


def windage_problem(
    function: str, sway_mass_kg: float, yaw_inertia_kgm2: float, coupling_kgm: float
) -> str | None:
    """Return the message refusing a windage whose sway-yaw mass matrix is singular, or None.

    Parameters
    ----------
    function : str
        The FMI function, for the message (``"fmi2ExitInitializationMode"``).
    sway_mass_kg, yaw_inertia_kgm2 : float
        m + m_y [kg] and I_z + J_z [kg m²] (positive by their declared minimum).
    coupling_kgm : float
        x_G·m [kg m].

    Returns
    -------
    str or None
        :data:`WINDAGE_COUPLING_FORMAT` filled in, or ``None``.

    """
    if coupling_kgm * coupling_kgm < sway_mass_kg * yaw_inertia_kgm2:
        return None
    bound = math.sqrt(sway_mass_kg * yaw_inertia_kgm2)
    return f"{function}: " + WINDAGE_COUPLING_FORMAT % (coupling_kgm, bound)


def fmu_state_problem(
    variables: Sequence[FmuVariable], values: Sequence[float], function: str
) -> str | None:
    """Return why a restored FMU state cannot be used (``None`` when it can).

    The check of ``fmi2SetFMUstate`` and ``fmi2DeSerializeFMUstate`` in both backends:
    every value must be one that ``fmi2SetReal`` accepts, i.e. finite and within its
    variable's min and max; the first that is not is named, with
    :data:`STATE_NONFINITE_FORMAT` or :data:`STATE_RANGE_FORMAT` (the C layer's messages).

    Parameters
    ----------
    variables : sequence of FmuVariable
        The FMU's variables, in value-reference order.
    values : sequence of float
        The state's value of each variable (outputs included).
    function : str
        The FMI function that restores the state, for the message.

    Returns
    -------
    str or None
        A one-line message, or ``None``.

    """
    for variable, value in zip(variables, values, strict=True):
        if not math.isfinite(value):
            return STATE_NONFINITE_FORMAT % (function, variable.name, value)
        low = -math.inf if variable.min is None else variable.min
        high = math.inf if variable.max is None else variable.max
        if not low <= value <= high:
            return STATE_RANGE_FORMAT % (function, variable.name, value, low, high)
    return None


def model_identifier(vessel_name: str) -> str:
    """Return the FMU's modelIdentifier (and library name) for a vessel name.

    Every character other than an ASCII letter, digit or ``_`` becomes ``_`` (so
    non-ASCII letters are dropped, not transliterated); runs of ``_`` collapse to one
    and leading or trailing ``_`` go; a name that then starts with a digit gets the
    prefix ``ship_``, an empty one is ``ship``. The result always matches
    ``[A-Za-z][A-Za-z0-9_]*``: a C identifier that is not reserved (no leading ``_``),
    also as the prefix of the FMI function names. The rule is stable: it depends on
    nothing but the name, and applying it to its own result changes nothing.

    Parameters
    ----------
    vessel_name : str
        The vessel name of the parameter set (the FMU's modelName).

    Returns
    -------
    str
        E.g. ``"Test Ship 1"`` -> ``"Test_Ship_1"``, ``"2nd ship"`` -> ``"ship_2nd_ship"``,
        ``"Ålesund/ø"`` -> ``"lesund"``, ``"  "`` -> ``"ship"``.

    """
    identifier = re.sub(r"[^A-Za-z0-9_]+", "_", vessel_name)
    identifier = re.sub(r"_+", "_", identifier).strip("_")
    if not identifier:
        return "ship"
    if identifier[0].isdigit():
        return "ship_" + identifier
    return identifier


def state_diverged(state: np.ndarray) -> bool:
    """Return whether the state has diverged: the rule of both backends' fmi2DoStep.

    Parameters
    ----------
    state : numpy.ndarray
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]), shape (6,).

    Returns
    -------
    bool
        True when a component is non-finite, |u| or |v| > :data:`MAX_SPEED_MPS` or
        |r| > :data:`MAX_YAW_RATE_RADPS`.

    """
    u, v, r = (float(s) for s in state[:3])
    return not (
        bool(np.all(np.isfinite(state)))
        and abs(u) <= MAX_SPEED_MPS
        and abs(v) <= MAX_SPEED_MPS
        and abs(r) <= MAX_YAW_RATE_RADPS
    )


def divergence_message(function: str, time_s: float, state: np.ndarray, kept_time_s: float) -> str:
    """Return the message of a diverged step (:data:`DIVERGENCE_FORMAT`), as the C layer's.

    Parameters
    ----------
    function : str
        The FMI function, for the message (``"fmi2DoStep"``).
    time_s : float
        End of the internal step at which the state diverged [s].
    state : numpy.ndarray
        The diverged state (u [m/s], v [m/s], r [rad/s], ...).
    kept_time_s : float
        The time the FMU's state stays at, the start of the communication step [s].

    Returns
    -------
    str
        One line.

    """
    u, v, r = (float(s) for s in state[:3])
    return f"{function}: " + DIVERGENCE_FORMAT % (
        time_s,
        u,
        v,
        r,
        MAX_SPEED_MPS,
        MAX_YAW_RATE_RADPS,
        kept_time_s,
    )
