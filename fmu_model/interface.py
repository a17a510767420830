"""The FMU interface of a model structure, shared by both backends (DESIGN.md "FMU interface").

Everything the native C FMU and the pythonfmu FMU must agree on is defined once: the
run-time rules in :mod:`fmu_model.fmi_rules` (bounds, value rule, divergence rule, step
and start rules, restored states, modelIdentifier; re-exported here), and here what
follows from a model structure and its parameters:

* the variable table :func:`fmu_variables` (names, value references, causality,
  variability, start values, units, display units, min/max), from which the native
  exporter writes ``modelDescription.xml`` (FMI 2.0 and 3.0) and its C table
  ``model_config.h``, and the pythonfmu exporter the table the slave declares and
  checks its variables from;
* the least start speed of a structure (:func:`min_start_speed_mps`);
* which states and inputs each state derivative depends on
  (:func:`derivative_dependencies`, the ``ModelStructure`` of model exchange), and which
  the outputs over ground do (:func:`ground_dependencies`).

Units are SI; angles have the display unit deg.

The environment (DESIGN.md "FMU interface"): optional inputs ``current_speed`` [m/s],
``current_direction`` [rad, the direction it sets towards], ``wind_speed`` [m/s],
``wind_direction`` [rad, the direction it comes from], default 0; the windage parameters
(``frontal_area`` ... ``yaw_inertia``, :class:`fmu_model.environment.Windage`), default
the params' ``windage`` or none (zero areas: no wind load); outputs ``sog`` and ``cog``,
speed and course over ground. With zero current and no windage the FMU computes what it
computed without them, bit for bit.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from functools import cache

import numpy as np

from fmu_model.envelope import Envelope
from fmu_model.environment import WINDAGE_FIELDS, Windage
from fmu_model.errors import FmuBuildError
from fmu_model.fmi_rules import (
    DEFAULT_MAX_STEP_S,
    DIVERGENCE_FORMAT,
    MAX_CURRENT_SPEED_MPS,
    MAX_DIRECTION_RAD,
    MAX_HEADING_RAD,
    MAX_LENGTH_M,
    MAX_POSITION_M,
    MAX_PROPELLER_RPM,
    MAX_SPEED_MPS,
    MAX_SUBSTEPS,
    MAX_WIND_SPEED_MPS,
    MAX_WINDAGE_AREA_M2,
    MAX_YAW_RATE_RADPS,
    MIN_LENGTH_M,
    MIN_MAX_STEP_S,
    MIN_START_SPEED_MPS,
    MIN_WINDAGE_INERTIA,
    RUDDER_LIMIT_RAD,
    START_SPEED_FORMAT,
    STATE_NONFINITE_FORMAT,
    STATE_RANGE_FORMAT,
    STEP_SIZE_FORMAT,
    STEP_TIME_FORMAT,
    STEP_TIME_TOLERANCE,
    SUBSTEP_LIMIT_FORMAT,
    TIME_STALL_FORMAT,
    FmuVariable,
    divergence_message,
    fmu_state_problem,
    model_identifier,
    state_diverged,
    step_problem,
)
from fmu_model.numeric import numeric_model
from fmu_model.params import ModelParameters, text_problem
from fmu_model.structure import (
    ENVIRONMENT_SYMBOLS,
    INPUT_SYMBOLS,
    KINEMATICS,
    STATE_NAMES,
    STATE_SYMBOLS,
    ModelStructure,
    apparent_wind_terms,
    current_terms,
    ground_terms,
    unit_string,
)

__all__ = [
    "DEFAULT_MAX_STEP_S",
    "DIVERGENCE_FORMAT",
    "ENVIRONMENT_NAMES",
    "GROUND_NAMES",
    "INPUT_NAMES",
    "MAX_HEADING_RAD",
    "MAX_LENGTH_M",
    "MAX_POSITION_M",
    "MAX_PROPELLER_RPM",
    "MAX_SPEED_MPS",
    "MAX_SUBSTEPS",
    "MAX_YAW_RATE_RADPS",
    "MIN_LENGTH_M",
    "MIN_MAX_STEP_S",
    "MIN_START_SPEED_MPS",
    "RUDDER_LIMIT_RAD",
    "START_SPEED_FORMAT",
    "STATE_NONFINITE_FORMAT",
    "STATE_RANGE_FORMAT",
    "STEP_SIZE_FORMAT",
    "STEP_TIME_FORMAT",
    "STEP_TIME_TOLERANCE",
    "SUBSTEP_LIMIT_FORMAT",
    "TIME_STALL_FORMAT",
    "WINDAGE_NAMES",
    "FmuVariable",
    "derivative_dependencies",
    "derivative_name",
    "divergence_message",
    "fmu_state_problem",
    "fmu_variables",
    "ground_dependencies",
    "min_start_speed_mps",
    "model_identifier",
    "state_diverged",
    "step_problem",
]

# The FMU's inputs in the order of the model's INPUT_SYMBOLS (rudder angle [rad],
# propeller speed [rpm], which enters the equations as rpm / 60 rev/s).
INPUT_NAMES = ("rudder_angle", "propeller_rpm")

# The environment inputs in the order of ENVIRONMENT_SYMBOLS: (name, unit, description,
# display unit, min, max); every one starts at 0.
_ENVIRONMENT = (
    ("current_speed", "m/s", "speed of the current over ground", None, 0.0,
     MAX_CURRENT_SPEED_MPS),
    ("current_direction", "rad", "direction the current sets towards, clockwise from North",
     "deg", -MAX_DIRECTION_RAD, MAX_DIRECTION_RAD),
    ("wind_speed", "m/s", "true wind speed over ground", None, 0.0, MAX_WIND_SPEED_MPS),
    ("wind_direction", "rad", "direction the true wind comes from, clockwise from North",
     "deg", -MAX_DIRECTION_RAD, MAX_DIRECTION_RAD),
)  # fmt: skip
ENVIRONMENT_NAMES = tuple(item[0] for item in _ENVIRONMENT)

# The outputs over ground: (name, unit, description, display unit).
_GROUND = (
    ("sog", "m/s", "speed over ground", None),
    ("cog", "rad", "course over ground, clockwise from North, in [-pi, pi]", "deg"),
)
GROUND_NAMES = tuple(item[0] for item in _GROUND)

# The windage parameters in the order of fmu_model.environment.Windage: (name, unit,
# description, min, max).
_WINDAGE = (
    ("frontal_area", "m2", "frontal projected area above the waterline A_F [m2] "
     "(Blendermann 1994 wind load; 0: none)", 0.0, MAX_WINDAGE_AREA_M2),
    ("lateral_area", "m2", "lateral projected area above the waterline A_L [m2] "
     "(0: no wind load)", 0.0, MAX_WINDAGE_AREA_M2),
    ("length_overall", "m", "length overall L_oa [m], of the wind load", MIN_LENGTH_M,
     MAX_LENGTH_M),
    ("lateral_centroid", "m", "centroid of A_L forward of midship s_L [m]", -MAX_LENGTH_M,
     MAX_LENGTH_M),
    ("surge_mass", "kg", "mass plus surge added mass m + m_x [kg], divides the wind's "
     "surge force", MIN_WINDAGE_INERTIA, None),
    ("sway_mass", "kg", "mass plus sway added mass m + m_y [kg], divides the wind's "
     "sway force", MIN_WINDAGE_INERTIA, None),
    ("yaw_inertia", "kg.m2", "yaw inertia plus added inertia about midship I_z + J_z "
     "[kg m2], divides the wind's yaw moment", MIN_WINDAGE_INERTIA, None),
    ("sway_yaw_coupling", "kg.m", "x_G m, centre of gravity forward of midship times the "
     "mass [kg m]: couples the wind's sway force and yaw moment (0: none; its square below "
     "sway_mass * yaw_inertia)", None, None),
)  # fmt: skip
WINDAGE_NAMES = tuple(item[0] for item in _WINDAGE)
assert len(WINDAGE_NAMES) == len(WINDAGE_FIELDS)  # the same order as Windage's fields

# The FMU variables a derivative or an output may depend on, by their symbols.
_KNOWNS = dict(
    zip(
        (*STATE_SYMBOLS, *INPUT_SYMBOLS, *ENVIRONMENT_SYMBOLS),
        (*STATE_NAMES, *INPUT_NAMES, *ENVIRONMENT_NAMES),
        strict=True,
    )
)

# (name, unit, description, unit of the time derivative) of the outputs, which are the
# continuous states of model exchange, and of the initial state u0 ... psi0.
_STATES = (
    ("u", "m/s", "surge velocity, forward", "m/s2"),
    ("v", "m/s", "sway velocity, to starboard", "m/s2"),
    ("r", "rad/s", "yaw rate, positive turning to starboard", "rad/s2"),
    ("x", "m", "position North of the origin", "m/s"),
    ("y", "m", "position East of the origin", "m/s"),
    ("psi", "rad", "heading, clockwise from North", "rad/s"),
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

    Order: inputs (rudder_angle, propeller_rpm), outputs (u, v, r, x, y, psi: the
    continuous states of model exchange), parameters (length, max_step, u0 ... psi0),
    one fixed parameter per coefficient, the state derivatives der(u) ... der(psi)
    (locals), the time (independent), then the environment: inputs current_speed,
    current_direction, wind_speed, wind_direction (start 0), outputs sog, cog, and the
    windage parameters frontal_area ... yaw_inertia (start: ``params.windage``, else
    zero areas, ``length_overall`` the ship's length and unit inertias: no wind load).
    New variables go at the end, so that the value references of a ship's FMU stay what
    hosts and OSP configurations know.

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
    for name, unit, text, _ in _STATES:
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
    for (name, unit, text, _), start, (low, high) in zip(
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
    for name, _, text, unit in _STATES:
        variables.append(
            FmuVariable(
                derivative_name(name),
                len(variables),
                "local",
                "continuous",
                None,
                unit,
                f"time derivative of the {text.split(',')[0]}",
                derivative_of=name,
            )
        )
    variables.append(
        FmuVariable("time", len(variables), "independent", "continuous", None, "s", "time")
    )
    for name, unit, text, display, low, high in _ENVIRONMENT:
        variables.append(
            FmuVariable(
                name, len(variables), "input", "continuous", 0.0, unit, text, display, low, high
            )
        )
    for name, unit, text, display in _GROUND:
        variables.append(
            FmuVariable(name, len(variables), "output", "continuous", None, unit, text, display)
        )
    windage = params.windage if params.windage is not None else Windage.none(params.length_m)
    for (name, unit, text, least, most), field in zip(_WINDAGE, WINDAGE_FIELDS, strict=True):
        variables.append(
            FmuVariable(
                name,
                len(variables),
                "parameter",
                "fixed",
                getattr(windage, field),
                unit,
                text,
                min=least,
                max=most,
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


def derivative_name(state: str) -> str:
    """Return the name of the FMU variable of a state's time derivative, ``der(<state>)``."""
    return f"der({state})"


@cache
def derivative_dependencies(structure: ModelStructure) -> tuple[tuple[str, ...], ...]:
    """Names of the states and inputs each state derivative depends on.

    One tuple per state (u, v, r, x, y, ψ) of the FMU variables (states in
    ``STATE_NAMES`` order, then the inputs, then the environment inputs) that occur in
    the right-hand side of its equation, the environment's terms included (the wind on
    the accelerations, whatever the windage: it is a parameter; the current on x', y'):
    the ``dependencies`` of ``ModelStructure/Derivatives`` (FMI 2.0 section 2.2.8) and
    ``ContinuousStateDerivative`` (FMI 3.0 section 2.4.8), and the sparsity of the
    Jacobian the directional derivatives come from.

    Parameters
    ----------
    structure : ModelStructure
        The model structure.

    Returns
    -------
    tuple of tuple of str
        Six tuples of variable names.

    """
    wind = set().union(*(e.free_symbols for e in apparent_wind_terms()))
    current = set().union(*(e.free_symbols for e in current_terms()))
    used = [e.free_symbols | wind for e in structure.accelerations()]
    used += [e.free_symbols | current for e in KINEMATICS[:2]] + [KINEMATICS[2].free_symbols]
    return tuple(
        tuple(name for symbol, name in _KNOWNS.items() if symbol in symbols) for symbols in used
    )


def ground_dependencies() -> tuple[str, ...]:
    """Names of the states and inputs the outputs sog and cog depend on (both the same).

    The velocity over ground: u, v, ψ and the current (a direct feed-through from the
    inputs current_speed and current_direction).
    """
    symbols = set().union(*(e.free_symbols for e in ground_terms()))
    return tuple(name for symbol, name in _KNOWNS.items() if symbol in symbols)


def logged_envelope(params: ModelParameters) -> Envelope | None:
    """Return the envelope of the logs ``params`` were identified from; None if not recorded.

    (params.json ``identification.envelope``; the FMU warns when it goes beyond it.)
    """
    record = params.identification.get("envelope")
    return Envelope.from_dict(record) if isinstance(record, Mapping) else None
