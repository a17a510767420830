"""The FMU interface shared by both exporters (DESIGN.md "FMU interface").

One list of variables, in value-reference order, from which the native exporter writes
``modelDescription.xml`` and its C value-reference table and the pythonfmu slave
declares its variables. Units are SI; the rudder angle has the display unit deg.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from fmu_model.params import ModelParameters
from fmu_model.structure import unit_string
from fmu_model.variants import get_model

# Rudder angles beyond this are outside every steering gear we model [rad] (45 deg).
RUDDER_LIMIT_RAD = math.radians(45.0)
# Default largest internal RK4 step inside fmi2DoStep [s].
DEFAULT_MAX_STEP_S = 0.05


@dataclass(frozen=True)
class FmuVariable:
    """One scalar Real variable of the FMU.

    ``unit`` is an SI unit name declared in ``UnitDefinitions`` (``None`` for
    dimensionless); ``display_unit`` is a display unit inside that unit.
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


# (name, unit, description) of the outputs and of the initial state u0 ... psi0.
_STATES = (
    ("u", "m/s", "surge velocity, forward"),
    ("v", "m/s", "sway velocity, to starboard"),
    ("r", "rad/s", "yaw rate, positive turning to starboard"),
    ("x", "m", "position North of the origin"),
    ("y", "m", "position East of the origin"),
    ("psi", "rad", "heading, clockwise from North"),
)


def fmu_variables(params: ModelParameters) -> tuple[FmuVariable, ...]:
    """All variables of the FMU for ``params``, in value-reference order.

    Order: inputs (rudder_angle, propeller_rpm), outputs (u, v, r, x, y, psi),
    parameters (length, max_step, u0 ... psi0), then one fixed parameter per coefficient.
    """
    structure = get_model(params.model)
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
            "propeller speed [rev/min]",
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
        )
    )
    variables.append(
        FmuVariable(
            "max_step",
            len(variables),
            "parameter",
            "fixed",
            DEFAULT_MAX_STEP_S,
            "s",
            "largest internal RK4 step inside doStep",
            min=1e-6,
        )
    )
    initial = (params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0)
    for (name, unit, text), start in zip(_STATES, initial, strict=True):
        variables.append(
            FmuVariable(
                f"{name}0", len(variables), "parameter", "fixed", start, unit, f"initial {text}"
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
    return tuple(variables)
