"""What the scenarios check of an FMU before they drive it: interface, start values, limits.

:func:`read_fmu_info` reads the start values and limits the scenarios use from an FMU's
modelDescription.xml and rejects a file that is not a ship FMU of this project's
interface (DESIGN.md "FMU interface"); :func:`open_fmu` opens one as a plant of the
programme runner; :func:`check_params_match` and :func:`check_rudder` hold parameters
and rudder angles against it. Problems are :class:`scenarios.errors.ScenarioError`.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from fmu_model import get_model
from scenarios.errors import ScenarioError
from scenarios.fmu_plant import ENVIRONMENT_INPUTS, REQUIRED_VARIABLES, FmuPlant

if TYPE_CHECKING:
    from fmu_model import ModelParameters
    from scenarios.sea import SeaEnvironment

__all__ = [
    "FmuInfo",
    "check_environment",
    "check_params_match",
    "check_rudder",
    "open_fmu",
    "read_fmu_info",
]

# The windage parameters that make a wind load (fmu_model.interface): 0 means none.
_WINDAGE_AREAS = ("frontal_area", "lateral_area")


@dataclass(frozen=True)
class FmuInfo:
    """What the scenarios need from an FMU's modelDescription.xml.

    Attributes
    ----------
    path : str
        The FMU file.
    model_name : str
        ``modelName``.
    length_m : float
        Start value of ``length`` [m].
    speed_mps : float
        Start value of ``u0``, the default approach speed [m/s].
    rpm : float
        Start value of ``propeller_rpm``, the default propeller speed [rpm].
    rudder_limit_rad : float
        Largest |rudder_angle| the FMU accepts (its declared max; π when none) [rad].
    max_step_s : float or None
        Start value of ``max_step``, the FMU's largest internal step, if declared [s].
    parameters : mapping of str to float
        Start values of every variable of causality ``parameter`` that has one (the
        model's coefficients among them) [SI].
    structure_name : str or None
        The model structure the FMU was built from (``fmu_model.get_model`` name, e.g.
        ``prime-rudder[k=0.0004,…]``), as its coefficient parameters' descriptions
        name it (``coefficient of … (<structure>)``, ``fmu_model.interface``); None
        when they name none.
    has_environment_inputs : bool
        Whether the FMU has the environment inputs ``current_speed``,
        ``current_direction``, ``wind_speed``, ``wind_direction`` (DESIGN.md "FMU
        interface"), so that it can sail at sea.

    """

    path: str
    model_name: str
    length_m: float
    speed_mps: float
    rpm: float
    rudder_limit_rad: float
    max_step_s: float | None
    parameters: Mapping[str, float] = field(default_factory=dict)
    structure_name: str | None = None
    has_environment_inputs: bool = False

    @property
    def has_windage(self) -> bool:
        """Whether a wind acts on the FMU: its ``frontal_area`` or ``lateral_area`` is > 0."""
        return any(self.parameters.get(name, 0.0) > 0.0 for name in _WINDAGE_AREAS)


def _float_or_none(value: object) -> float | None:
    if value is None or value == "":
        return None
    try:
        return float(str(value))
    except ValueError:
        return None


# The description of a coefficient parameter (fmu_model.interface.fmu_variables):
# "coefficient of <regressor> (<structure name>)"; a structure name has no parentheses.
_COEFFICIENT_DESCRIPTION = re.compile(r"coefficient of .* \((?P<structure>[^()]+)\)", re.DOTALL)


def _structure_name(name: str, descriptions: Iterable[str | None]) -> str | None:
    """Return the structure the coefficient descriptions name; None when none names one."""
    found = {
        match["structure"]
        for text in descriptions
        if text and (match := _COEFFICIENT_DESCRIPTION.fullmatch(text))
    }
    if len(found) > 1:
        raise ScenarioError(
            f"{name}: the FMU's coefficients name different model structures "
            f"({', '.join(sorted(found))})"
        )
    return found.pop() if found else None


def read_fmu_info(path: str | os.PathLike[str]) -> FmuInfo:
    """Read the start values and limits the scenarios use from an FMU.

    Raises
    ------
    ScenarioError
        The file is missing, not an FMU, lacks a variable of the project's FMU
        interface (DESIGN.md "FMU interface"), or its coefficients name different
        model structures.

    """
    name = os.fspath(path)
    if not os.path.exists(name):
        raise ScenarioError(f"{name}: no such FMU file")
    if not os.path.isfile(name):
        raise ScenarioError(f"{name}: is not a file; expected an .fmu")
    from fmpy import read_model_description

    try:
        md = read_model_description(name)
    except Exception as exc:  # fmpy raises plain Exception for invalid files
        raise ScenarioError(f"{name}: not a readable FMU ({exc})") from None
    variables = {v.name: v for v in md.modelVariables}
    missing = [k for k in REQUIRED_VARIABLES if k not in variables]
    if missing:
        raise ScenarioError(
            f"{name}: not a ship FMU of this project's interface; missing {', '.join(missing)}"
        )
    length = _float_or_none(variables["length"].start)
    if length is None or not (math.isfinite(length) and length > 0.0):
        raise ScenarioError(f"{name}: the FMU's 'length' has no positive start value")
    limits = [
        abs(x)
        for x in (
            _float_or_none(variables["rudder_angle"].min),
            _float_or_none(variables["rudder_angle"].max),
        )
        if x is not None
    ]
    max_step = variables.get("max_step")
    parameters = {
        v.name: start
        for v in md.modelVariables
        if v.causality == "parameter" and (start := _float_or_none(v.start)) is not None
    }
    return FmuInfo(
        path=name,
        model_name=str(md.modelName),
        length_m=length,
        speed_mps=_float_or_none(variables["u0"].start) or 0.0,
        rpm=_float_or_none(variables["propeller_rpm"].start) or 0.0,
        rudder_limit_rad=min(limits) if limits else math.pi,
        max_step_s=None if max_step is None else _float_or_none(max_step.start),
        parameters=parameters,
        structure_name=_structure_name(
            name, (v.description for v in md.modelVariables if v.causality == "parameter")
        ),
        has_environment_inputs=all(
            k in variables and variables[k].causality == "input" for k in ENVIRONMENT_INPUTS
        ),
    )


@contextmanager
def open_fmu(
    path: str | os.PathLike[str], environment: SeaEnvironment | None = None
) -> Iterator[FmuPlant]:
    """Open an FMU as a plant (:class:`scenarios.fmu_plant.FmuPlant`); close it on exit.

    Parameters
    ----------
    path : path-like
        The FMU.
    environment : SeaEnvironment, optional
        Current and wind the plant sails in (:func:`check_environment`); calm water
        when None.

    Raises
    ------
    ScenarioError
        The FMU cannot be loaded or instantiated on this platform, or it cannot sail in
        ``environment``.

    """
    info = read_fmu_info(path)  # clear errors for a missing or foreign file first
    if environment is not None:
        check_environment(info)
    try:
        plant = FmuPlant(path, environment=environment)
    except Exception as exc:  # fmpy: OSError, plain Exception, FMICallException
        raise ScenarioError(f"{os.fspath(path)}: cannot load the FMU ({exc})") from None
    try:
        yield plant
    finally:
        plant.close()


def _resolved(name: str) -> str:
    """Canonical name of the structure ``name`` resolves to (``fmu_model.get_model``)."""
    try:
        return get_model(name).name
    except (KeyError, ValueError):
        return name  # not a structure known here: it can only equal itself


def check_params_match(info: FmuInfo, params: ModelParameters, source: str = "") -> None:
    """Raise :class:`ScenarioError` unless ``params`` are the ones the FMU was built from.

    The FMU's model structure (:attr:`FmuInfo.structure_name`) must be the parameters'
    structure: both names are resolved (``fmu_model.get_model``) and compared, so a
    family's shape counts, whether written in full, in part or not at all. The FMU's
    model name must be the vessel name, its ``length`` the ship length, and every
    coefficient of the parameters' structure a parameter of the FMU whose start value
    equals the coefficient (to 1e-12 relative; the exporters write the shortest text
    that parses back to the same double). An FMU whose coefficients name no structure
    (not built by this project's exporters) is held to its coefficients only.

    Parameters
    ----------
    info : FmuInfo
        From :func:`read_fmu_info`.
    params : ModelParameters
        E.g. the params.json the FMU is said to come from.
    source : str, optional
        Where ``params`` come from (a path), to begin the message with.

    """
    what = f"the parameters ({params.model}, vessel {params.vessel_name!r})"
    if source:
        what = f"{source}: {what}"
    problems = []
    structure = params.structure.name
    if info.structure_name is not None and _resolved(info.structure_name) != structure:
        # A different structure: its coefficients would not say more.
        raise ScenarioError(
            f"{what} do not match the FMU {info.path}: their model structure is {structure} "
            f"but the FMU's is {_resolved(info.structure_name)}"
        )
    if info.model_name != params.vessel_name:
        problems.append(f"the FMU's model is {info.model_name!r}")
    if not math.isclose(info.length_m, params.length_m, rel_tol=1e-12):
        problems.append(f"L = {params.length_m:g} m but the FMU's is {info.length_m:g} m")
    missing = [name for name in params.names if name not in info.parameters]
    if missing:
        problems.append(f"the FMU has no parameter {', '.join(missing)}")
    else:
        differ = [
            f"{name} = {value:.6g} but {info.parameters[name]:.6g} in the FMU"
            for name, value in params.as_dict().items()
            if not math.isclose(info.parameters[name], value, rel_tol=1e-12)
        ]
        if differ:
            more = f" (and {len(differ) - 3} more)" if len(differ) > 3 else ""
            problems.append(", ".join(differ[:3]) + more)
    if problems:
        raise ScenarioError(f"{what} do not match the FMU {info.path}: {'; '.join(problems)}")


def check_environment(info: FmuInfo) -> None:
    """Raise :class:`ScenarioError` when the FMU has no environment inputs to sail at sea."""
    if not info.has_environment_inputs:
        raise ScenarioError(
            f"{info.path}: the FMU has no environment inputs ({', '.join(ENVIRONMENT_INPUTS)}) "
            "to sail it in a current or a wind; build it again with build_fmu.py"
        )


def check_rudder(info: FmuInfo, rudder_rad: float) -> None:
    """Raise :class:`ScenarioError` when |``rudder_rad``| exceeds the FMU's limit."""
    if abs(rudder_rad) > info.rudder_limit_rad * (1.0 + 1e-12):
        raise ScenarioError(
            f"rudder angle {math.degrees(rudder_rad):g} deg is beyond the FMU's limit of "
            f"±{math.degrees(info.rudder_limit_rad):g} deg ({info.path})"
        )
