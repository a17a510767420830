"""The FMU interface shared by both backends (DESIGN.md "FMU interface").

Everything the native C FMU and the pythonfmu FMU must agree on is defined here, once:

* the variable table :func:`fmu_variables` (names, value references, causality,
  variability, start values, units, display units, min/max), from which the native
  exporter writes ``modelDescription.xml`` and its C table ``model_config.h`` and the
  pythonfmu slave declares and checks its variables;
* the value rule :meth:`FmuVariable.problem` (finite and within the declared min/max),
  which the C layer applies from the same table;
* the modelIdentifier rule :func:`model_identifier`;
* the divergence rule (:data:`MAX_SPEED_MPS`, :data:`MAX_YAW_RATE_RADPS`,
  :func:`state_diverged`, :data:`DIVERGENCE_FORMAT`), which the native exporter emits
  into ``model_config.h`` and the pythonfmu slave applies after every internal step;
* the rules of ``fmi2DoStep`` and of the start: the largest number of internal steps
  of one call (:data:`MAX_SUBSTEPS`), a step that must advance the time
  (:data:`TIME_STALL_FORMAT`), the least start speed of a model that divides by the
  speed (:func:`min_start_speed_mps`, :data:`START_SPEED_FORMAT`);
* the check of a restored FMU state (:func:`fmu_state_problem`: every value as
  :meth:`FmuVariable.problem`, with the messages :data:`STATE_RANGE_FORMAT` and
  :data:`STATE_NONFINITE_FORMAT`).

The messages are printf formats: the native exporter writes them into
``model_config.h`` for the C layer's logger, the pythonfmu slave formats them with
``%``, so both backends log the same text.

Units are SI; the rudder angle has the display unit deg.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cache

import numpy as np

from fmu_model.errors import FmuBuildError
from fmu_model.numeric import numeric_model
from fmu_model.params import ModelParameters, text_problem
from fmu_model.structure import ModelStructure, unit_string

# Rudder angles beyond this are outside every steering gear we model [rad] (45 deg).
RUDDER_LIMIT_RAD = math.radians(45.0)
# Default largest internal RK4 step inside fmi2DoStep [s].
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

# A state beyond these bounds has diverged: no ship moves like this. |u| and |v| [m/s].
MAX_SPEED_MPS = 1.0e3
# ... and |r| [rad/s].
MAX_YAW_RATE_RADPS = 1.0e3
# The message of a diverged fmi2DoStep, a printf format shared by both backends (the C
# layer passes it to its logger, the pythonfmu slave formats it with ``%``): the time of
# the failed internal step [s], u [m/s], v [m/s], r [rad/s] there, MAX_SPEED_MPS,
# MAX_YAW_RATE_RADPS, and the time the state stays at (the start of the step) [s].
DIVERGENCE_FORMAT = (
    "fmi2DoStep: the state diverged at t = %.9g s (u = %g m/s, v = %g m/s, r = %g rad/s; "
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
    "fmi2DoStep: the step h = %g s needs h / max_step = %.6g internal steps of "
    "max_step = %g s, more than the %.0f one call may take (about 1 s of CPU); take "
    "shorter communication steps or a larger max_step"
)
# The message of a step too small to advance the time: h [s], the time t [s].
TIME_STALL_FORMAT = (
    "fmi2DoStep: the step h = %g s does not advance the time t = %.17g s "
    "(t + h == t in double precision)"
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
    "fmi2ExitInitializationMode: the start speed sqrt(u0^2 + v0^2) = %g m/s is below "
    "%g m/s, the least this model starts from (its equations divide by the speed); "
    "set u0 or v0"
)

# The messages of a restored FMU state with a value fmi2SetReal would refuse: the
# function, the variable name, its value, and (out of range) its min and max (-inf and
# inf when not declared).
STATE_RANGE_FORMAT = "%s: the FMU state is not restored: %s = %.17g is outside [%.17g, %.17g]"
STATE_NONFINITE_FORMAT = "%s: the FMU state is not restored: %s must be finite, got %g"


@dataclass(frozen=True)
class FmuVariable:
    """One scalar Real variable of the FMU.

    ``unit`` is an SI unit name declared in ``UnitDefinitions`` (``None`` for
    dimensionless); ``display_unit`` is a display unit inside that unit. ``min`` and
    ``max`` bound the values ``fmi2SetReal`` accepts (inclusive, in ``unit``).
    """

    name: str
    value_reference: int
    causality: str  # "input" | "output" | "parameter"
    variability: str  # "continuous" | "fixed"
    start: float | None
    unit: str | None
    description: str
    display_unit: str | None = None
    min: float | None = None
    max: float | None = None

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


# (name, unit, description) of the outputs and of the initial state u0 ... psi0.
_STATES = (
    ("u", "m/s", "surge velocity, forward"),
    ("v", "m/s", "sway velocity, to starboard"),
    ("r", "rad/s", "yaw rate, positive turning to starboard"),
    ("x", "m", "position North of the origin"),
    ("y", "m", "position East of the origin"),
    ("psi", "rad", "heading, clockwise from North"),
)


# Bounds (min, max) of the initial state u0 ... psi0: a start beyond the divergence
# bounds would diverge at once, and see the bounds of position and heading above.
_INITIAL_BOUNDS = (
    (-MAX_SPEED_MPS, MAX_SPEED_MPS),
    (-MAX_SPEED_MPS, MAX_SPEED_MPS),
    (-MAX_YAW_RATE_RADPS, MAX_YAW_RATE_RADPS),
    (-MAX_POSITION_M, MAX_POSITION_M),
    (-MAX_POSITION_M, MAX_POSITION_M),
    (-MAX_HEADING_RAD, MAX_HEADING_RAD),
)


def _check_params(params: ModelParameters) -> None:
    """Raise FmuBuildError unless the coefficients and vessel data can start an FMU."""
    problem = text_problem(params.vessel_name)
    if problem is not None:
        # It would become an invalid modelDescription.xml or C source.
        raise FmuBuildError(f"vessel name {params.vessel_name!r}: {problem}")
    bad = [
        n
        for n, value in zip(params.names, params.coefficients, strict=True)
        if not math.isfinite(value)
    ]
    if bad:
        raise FmuBuildError(f"coefficients {bad} are not finite")
    for what, value in (
        ("length_m", params.length_m),
        ("nominal_speed_mps", params.nominal_speed_mps),
        ("nominal_n_rps", params.nominal_n_rps),
    ):
        if not math.isfinite(value):
            raise FmuBuildError(f"{what} must be finite, got {value!r}")
    if params.length_m <= 0.0:
        raise FmuBuildError(f"length_m must be positive, got {params.length_m!r}")


def fmu_variables(
    params: ModelParameters, max_step_s: float | None = None
) -> tuple[FmuVariable, ...]:
    """All variables of the FMU for ``params``, in value-reference order.

    Order: inputs (rudder_angle, propeller_rpm), outputs (u, v, r, x, y, psi),
    parameters (length, max_step, u0 ... psi0), then one fixed parameter per coefficient.

    Parameters
    ----------
    params : ModelParameters
        Model structure, coefficients (the start values of the coefficient parameters)
        and vessel data (length [m], nominal speed [m/s] and propeller speed [rev/s]).
    max_step_s : float, optional
        Start value of ``max_step``, the largest internal RK4 step [s]; default
        :data:`DEFAULT_MAX_STEP_S`.

    Returns
    -------
    tuple of FmuVariable
        Value references 0, 1, ... in order.

    Raises
    ------
    FmuBuildError
        Non-finite coefficients or vessel data, a non-positive length, a vessel name
        with a control character or a lone surrogate (:func:`fmu_model.params.text_problem`),
        a start value outside its variable's bounds (e.g. a nominal rpm beyond
        :data:`MAX_PROPELLER_RPM` or a length outside [:data:`MIN_LENGTH_M`,
        :data:`MAX_LENGTH_M`]), or a ``max_step_s`` that is not a finite number >=
        :data:`MIN_MAX_STEP_S`.

    """
    _check_params(params)
    max_step = DEFAULT_MAX_STEP_S if max_step_s is None else float(max_step_s)
    if not (math.isfinite(max_step) and max_step >= MIN_MAX_STEP_S):
        raise FmuBuildError(
            f"max_step_s must be a finite number >= {MIN_MAX_STEP_S}, got {max_step_s}"
        )
    structure = params.structure
    variables: list[FmuVariable] = [
        FmuVariable(
            "rudder_angle",
            0,
            "input",
            "continuous",
            0.0,
            "rad",
            "rudder angle, positive turns the ship to starboard",
            "deg",
            -RUDDER_LIMIT_RAD,
            RUDDER_LIMIT_RAD,
        ),
        FmuVariable(
            "propeller_rpm",
            1,
            "input",
            "continuous",
            params.nominal_n_rps * 60.0,
            "rpm",
            "propeller speed [rev/min], negative astern",
            min=-MAX_PROPELLER_RPM,
            max=MAX_PROPELLER_RPM,
        ),
    ]
    for name, unit, text in _STATES:
        variables.append(
            FmuVariable(name, len(variables), "output", "continuous", None, unit, text)
        )
    variables.append(
        FmuVariable(
            "length",
            len(variables),
            "parameter",
            "fixed",
            params.length_m,
            "m",
            "ship length between perpendiculars",
            min=MIN_LENGTH_M,
            max=MAX_LENGTH_M,
        )
    )
    variables.append(
        FmuVariable(
            "max_step",
            len(variables),
            "parameter",
            "fixed",
            max_step,
            "s",
            "largest internal RK4 step inside doStep",
            min=MIN_MAX_STEP_S,
        )
    )
    initial = (params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0)
    least_speed = min_start_speed_mps(structure)
    for (name, unit, text), start, (low, high) in zip(
        _STATES, initial, _INITIAL_BOUNDS, strict=True
    ):
        description = f"initial {text}"
        if name == "u" and least_speed > 0.0:
            description += f"; the start speed sqrt(u0^2 + v0^2) must be >= {least_speed:g} m/s"
        variables.append(
            FmuVariable(
                f"{name}0",
                len(variables),
                "parameter",
                "fixed",
                start,
                unit,
                description,
                min=low,
                max=high,
            )
        )
    units = structure.coefficient_units()
    for term, value in zip(structure.terms, params.coefficients, strict=True):
        unit = unit_string(units[term.coefficient])
        variables.append(
            FmuVariable(
                term.coefficient,
                len(variables),
                "parameter",
                "fixed",
                float(value),
                None if unit == "1" else unit,
                f"coefficient of {term.regressor} ({structure.name})",
            )
        )
    for variable in variables:
        problem = None if variable.start is None else variable.problem(variable.start)
        if problem is not None:  # e.g. a nominal rpm or length outside the bounds
            raise FmuBuildError(f"the start value of {problem}")
    return tuple(variables)


@cache
def min_start_speed_mps(structure: ModelStructure) -> float:
    """Return the least start speed sqrt(u0² + v0²) the FMU of ``structure`` accepts.

    :data:`MIN_START_SPEED_MPS` for a structure whose equations divide by the speed
    (a regressor is not finite at u = v = 0 for some yaw rate, rudder angle and
    propeller speed, e.g. v/U in the speed-scaled variants), else 0: a polynomial model
    such as ``shi2009`` starts from rest.

    Parameters
    ----------
    structure : ModelStructure
        The model structure.

    Returns
    -------
    float
        The least start speed [m/s].

    """
    grid = np.array(np.meshgrid([0.0, 0.01], [0.0, 0.1], [0.0, 2.0])).reshape(3, -1)
    rest = np.zeros(grid.shape[1])
    r, rudder, n = grid
    with np.errstate(all="ignore"):
        phi = numeric_model(structure).regressors(rest, rest, r, rudder, n, 100.0)
    return 0.0 if bool(np.all(np.isfinite(phi))) else MIN_START_SPEED_MPS


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


def divergence_message(time_s: float, state: np.ndarray, kept_time_s: float) -> str:
    """Return the message of a diverged step (:data:`DIVERGENCE_FORMAT`), as the C layer's.

    Parameters
    ----------
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
    return DIVERGENCE_FORMAT % (
        time_s,
        u,
        v,
        r,
        MAX_SPEED_MPS,
        MAX_YAW_RATE_RADPS,
        kept_time_s,
    )
