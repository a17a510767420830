"""``modelDescription.xml`` (FMI 2.0 and 3.0) and the OSP-IS sidecar, from the shared interface.

Backend-neutral: everything is derived from :func:`fmu_model.interface.fmu_variables`
(the variables in value-reference order) and the model structure; the exporter only
adds what is specific to it (model identifier, GUID, source files, which kinds of FMU:
co-simulation ``"cs"``, model exchange ``"me"`` or both). Units are declared with FMI
``BaseUnit`` exponents derived from the (metre, second) dimension tuples of
``fmu_model.structure``; angles carry ``rad`` (display unit ``deg``), the propeller
speed ``rpm`` = 1/60 s⁻¹.

The outputs u ... ψ are the continuous states of model exchange, the locals
der(u) ... der(ψ) their derivatives (``derivative`` attribute), with the dependencies
of :func:`fmu_model.interface.derivative_dependencies` in ``ModelStructure``; such an
output depends on nothing but its own state (no direct feed-through from the inputs).
The outputs over ground, sog and cog, are calculated from the states u, v, ψ and the
current inputs (:func:`fmu_model.interface.ground_dependencies`: a direct
feed-through). Model exchange is event-free: no event indicators, no time events.
"""

from __future__ import annotations

import hashlib
import math
import uuid
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata

from fmu_model.interface import (
    GROUND_NAMES,
    FmuVariable,
    derivative_dependencies,
    ground_dependencies,
)
from fmu_model.params import ModelParameters, text_problem
from fmu_model.structure import STATE_NAMES, ModelStructure, unit_string

# Log categories of the native FMU, in the order of fmu_model/c/fmi2_cosimulation.c.
LOG_CATEGORIES: tuple[tuple[str, str], ...] = (
    ("logStatusWarning", "Warnings"),
    ("logStatusDiscard", "fmi2Discard: a diverged step, or a status this FMU cannot give"),
    (
        "logStatusError",
        "Errors: rejected values and FMU states, calls in the wrong state, unsupported calls",
    ),
    ("logStatusFatal", "Fatal errors (never raised by this FMU)"),
    ("logAll", "Trace of every FMI call"),
)

# The kinds of FMU: co-simulation and model exchange.
KINDS = ("cs", "me")

# CoSimulation flags of the native FMU, FMI 2.0 section 4.3.1 (the defaults of
# model_description_xml).
NATIVE_CAPABILITIES: Mapping[str, bool] = {
    "canHandleVariableCommunicationStepSize": True,
    "canInterpolateInputs": False,
    "canRunAsynchronuously": False,
    "canBeInstantiatedOnlyOncePerProcess": False,
    "canNotUseMemoryManagementFunctions": False,
    "canGetAndSetFMUstate": True,
    "canSerializeFMUstate": True,
    "providesDirectionalDerivative": True,
}
# ModelExchange flags of the native FMU, FMI 2.0 section 3.3.1: no events, so the FMU
# needs no fmi2CompletedIntegratorStep.
_FMI2_MODEL_EXCHANGE: Mapping[str, bool] = {
    "completedIntegratorStepNotNeeded": True,
    "canBeInstantiatedOnlyOncePerProcess": False,
    "canNotUseMemoryManagementFunctions": False,
    "canGetAndSetFMUstate": True,
    "canSerializeFMUstate": True,
    "providesDirectionalDerivative": True,
}
# Flags of FMI 3.0 sections 3.3 (ModelExchange) and 4.3 (CoSimulation); both share
# the first group.
_FMI3_COMMON: Mapping[str, bool] = {
    "needsExecutionTool": False,
    "canBeInstantiatedOnlyOncePerProcess": False,
    "canGetAndSetFMUState": True,
    "canSerializeFMUState": True,
    "providesDirectionalDerivatives": True,
    "providesAdjointDerivatives": True,
    "providesPerElementDependencies": False,
}
_FMI3_MODEL_EXCHANGE: Mapping[str, bool] = {
    "needsCompletedIntegratorStep": False,
    "providesEvaluateDiscreteStates": False,
}
_FMI3_CO_SIMULATION: Mapping[str, bool] = {
    "canHandleVariableCommunicationStepSize": True,
    "providesIntermediateUpdate": False,
    "mightReturnEarlyFromDoStep": False,
    "canReturnEarlyAfterIntermediateUpdate": False,
    "hasEventMode": False,
    "providesEvaluateDiscreteStates": False,
}

# Default experiment of the FMU [s].
DEFAULT_START_TIME_S = 0.0
DEFAULT_STOP_TIME_S = 1000.0
DEFAULT_STEP_SIZE_S = 0.1

_GUID_NAMESPACE = uuid.uuid5(uuid.NAMESPACE_URL, "https://shipid.invalid/fmu")
# GUID of a document rendered before its content GUID is known (see content_guid).
GUID_PLACEHOLDER = "{00000000-0000-0000-0000-000000000000}"
OSP_NAMESPACE = "https://open-simulation-platform.com/OspModelDescription/1.0.0"


@dataclass(frozen=True)
class FmiUnit:
    """An FMI 2.0 unit: SI base-unit exponents, factor, and display units.

    A value v in this unit is ``factor * v`` in the base units m^m s^s rad^rad.
    ``display_units`` are (name, factor) pairs with display value = factor * v.
    """

    name: str
    m: int = 0
    s: int = 0
    rad: int = 0
    factor: float = 1.0
    kg: int = 0
    display_units: tuple[tuple[str, float], ...] = ()


def _si_unit(dimension: tuple[int, int]) -> FmiUnit:
    """Return the unit of a (metre, second) dimension tuple, named by ``unit_string``."""
    return FmiUnit(unit_string(dimension), m=dimension[0], s=dimension[1])


# Angular units: angles and revolutions are dimensionless in ``fmu_model.structure``.
_DEG_PER_RAD = math.degrees(1.0)
_ANGULAR_UNITS = (
    FmiUnit("rad", rad=1, display_units=(("deg", _DEG_PER_RAD),)),
    FmiUnit("rad/s", rad=1, s=-1, display_units=(("deg/s", _DEG_PER_RAD),)),
    FmiUnit("rad/s2", rad=1, s=-2, display_units=(("deg/s2", _DEG_PER_RAD),)),
    FmiUnit("rpm", s=-1, factor=1.0 / 60.0),
)
# Units of the windage parameters (fmu_model.environment.Windage).
_WINDAGE_UNITS = (
    FmiUnit("m2", m=2),
    FmiUnit("kg", kg=1),
    FmiUnit("kg.m2", kg=1, m=2),
    FmiUnit("kg.m", kg=1, m=1),
)
# Dimensions of the state, derivative and parameter units: m, s, m/s, m/s2.
_STATE_DIMENSIONS = ((1, 0), (0, 1), (1, -1), (1, -2))


def unit_table(structure: ModelStructure) -> dict[str, FmiUnit]:
    """All units an FMU of ``structure`` may use, by name.

    The SI units come from the dimension tuples of the states and of the structure's
    coefficients (``ModelStructure.coefficient_units``); the angular ones are fixed.
    """
    table = {unit.name: unit for unit in (*_ANGULAR_UNITS, *_WINDAGE_UNITS)}
    dimensions = [*_STATE_DIMENSIONS, *structure.coefficient_units().values()]
    for dimension in dimensions:
        if dimension != (0, 0):
            unit = _si_unit(dimension)
            table.setdefault(unit.name, unit)
    return table


def units_of(variables: Iterable[FmuVariable], structure: ModelStructure) -> tuple[FmiUnit, ...]:
    """Return the units the variables use, in order of first use.

    Raises
    ------
    ValueError
        When a variable has a unit (or display unit) that :func:`unit_table` does not know.

    """
    table = unit_table(structure)
    used: dict[str, FmiUnit] = {}
    for var in variables:
        if var.unit is None:
            continue
        if var.unit not in table:
            raise ValueError(f"variable {var.name!r}: unknown unit {var.unit!r}")
        unit = table[var.unit]
        if var.display_unit is not None and var.display_unit not in dict(unit.display_units):
            raise ValueError(
                f"variable {var.name!r}: unit {var.unit!r} has no display unit {var.display_unit!r}"
            )
        used.setdefault(unit.name, unit)
    return tuple(used.values())


def generation_time(params: ModelParameters) -> datetime:
    """Time stamp of the FMU: the identification's ``created`` time, else now (UTC).

    Using the identification time makes a rebuild from the same params.json byte-identical.
    """
    created = params.identification.get("created") if params.identification else None
    if isinstance(created, str):
        try:
            stamp = datetime.fromisoformat(created)
        except ValueError:
            stamp = None
        if stamp is not None:
            if stamp.tzinfo is None:
                stamp = stamp.replace(tzinfo=UTC)
            return stamp.astimezone(UTC).replace(microsecond=0)
    return datetime.now(UTC).replace(microsecond=0)


def generation_tool() -> str:
    """``"shipid <version>"`` of the installed package."""
    try:
        version = metadata.version("shipid")
    except metadata.PackageNotFoundError:
        version = "unknown"
    return f"shipid {version}"


def content_guid(parts: Iterable[tuple[str, bytes]]) -> str:
    """GUID derived from named contents: the same contents give the same GUID.

    ``parts`` are (name, bytes) pairs, e.g. the model description rendered with
    :data:`GUID_PLACEHOLDER` and every source file.
    """
    digest = hashlib.sha256()
    for name, data in parts:
        digest.update(name.encode("utf-8") + b"\0")
        digest.update(len(data).to_bytes(8, "little"))
        digest.update(data)
    return "{" + str(uuid.uuid5(_GUID_NAMESPACE, digest.hexdigest())) + "}"


def _number(value: float) -> str:
    """Shortest text that parses back to the same double (XML and C)."""
    if not math.isfinite(value):
        raise ValueError(f"non-finite value {value!r} cannot be written")
    return repr(float(value))


def _base_unit_attributes(unit: FmiUnit, *, all_exponents: bool) -> dict[str, str]:
    exponents = {"kg": unit.kg, "m": unit.m, "s": unit.s, "A": 0, "K": 0, "mol": 0, "cd": 0}
    exponents["rad"] = unit.rad
    attributes = {
        key: str(value) for key, value in exponents.items() if all_exponents or value != 0
    }
    if all_exponents or unit.factor != 1.0:
        attributes["factor"] = _number(unit.factor)
    if all_exponents:
        attributes["offset"] = "0.0"
    return attributes


def _unit_definitions(parent: ET.Element, units: Sequence[FmiUnit], *, osp: bool) -> None:
    definitions = ET.SubElement(parent, "UnitDefinitions")
    for unit in units:
        element = ET.SubElement(definitions, "Unit", name=unit.name)
        ET.SubElement(element, "BaseUnit", _base_unit_attributes(unit, all_exponents=osp))
        for name, factor in unit.display_units:
            ET.SubElement(element, "DisplayUnit", name=name, factor=_number(factor))


def _to_text(root: ET.Element) -> str:
    """Serialise ``root``; ValueError for text that XML 1.0 cannot carry.

    ElementTree writes any string, also control characters and lone surrogates, which
    would make a document no XML parser reads (and no FMU importer loads).
    """
    for element in root.iter():
        for name, value in element.attrib.items():
            problem = text_problem(value)
            if problem is not None:
                raise ValueError(f"{element.tag} {name} {value!r} {problem}")
    ET.indent(root, space="  ")
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def _description(params: ModelParameters, kinds: Sequence[str]) -> str:
    """Return the ``description`` attribute: vessel, structure, method, notes of the kinds."""
    structure = params.structure
    method = params.identification.get("method") if params.identification else None
    description = f"{params.vessel_name}: {structure.description}"
    if method:
        description += f", identified by {method}"
    if params.windage is None or not params.windage.has_wind_load:
        description += (
            "; no windage (areas 0): the wind inputs act only after the windage parameters are set"
        )
    else:
        description += "; windage from params.json"
    description += (
        "; wind load of Blendermann (1994), loaded tanker, from the apparent wind; "
        "current over ground added to the kinematics"
    )
    if "me" in kinds:
        description += (
            "; model exchange is event-free (no event indicators, no time events, "
            "no discrete states)"
        )
    return description


def _check_kinds(kinds: Sequence[str]) -> None:
    if not kinds or set(kinds) - set(KINDS) or len(set(kinds)) != len(kinds):
        raise ValueError(f"kinds must be one or both of {KINDS}, got {tuple(kinds)}")


def _flags(values: Mapping[str, bool]) -> dict[str, str]:
    return {name: "true" if value else "false" for name, value in values.items()}


def _root(
    params: ModelParameters,
    version: str,
    token_attribute: str,
    token: str,
    kinds: Sequence[str],
    created: datetime | None,
    tool: str | None,
) -> ET.Element:
    stamp = created if created is not None else generation_time(params)
    return ET.Element(
        "fmiModelDescription",
        {
            "fmiVersion": version,
            "modelName": params.vessel_name,
            token_attribute: token,
            "description": _description(params, kinds),
            "generationTool": tool if tool is not None else generation_tool(),
            "generationDateAndTime": stamp.astimezone(UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "variableNamingConvention": "flat",
        },
    )


def _categories_and_experiment(root: ET.Element, log_categories: Sequence[tuple[str, str]]) -> None:
    categories = ET.SubElement(root, "LogCategories")
    for name, text in log_categories:
        ET.SubElement(categories, "Category", name=name, description=text)
    ET.SubElement(
        root,
        "DefaultExperiment",
        startTime=_number(DEFAULT_START_TIME_S),
        stopTime=_number(DEFAULT_STOP_TIME_S),
        stepSize=_number(DEFAULT_STEP_SIZE_S),
    )


def _real_attributes(var: FmuVariable) -> dict[str, str]:
    """Return unit, displayUnit, min, max and start (none for calculated variables)."""
    attributes: dict[str, str] = {}
    if var.unit is not None:
        attributes["unit"] = var.unit
    if var.display_unit is not None:
        attributes["displayUnit"] = var.display_unit
    if var.min is not None:
        attributes["min"] = _number(var.min)
    if var.max is not None:
        attributes["max"] = _number(var.max)
    if var.causality in ("input", "parameter") and var.start is not None:
        attributes["start"] = _number(var.start)
    return attributes


def _dependencies(
    params: ModelParameters, variables: Sequence[FmuVariable]
) -> list[tuple[FmuVariable, FmuVariable, list[FmuVariable]]]:
    """(state, its derivative, the states and inputs the derivative depends on)."""
    by_name = {v.name: v for v in variables}
    derivatives = [v for v in variables if v.derivative_of is not None]
    return [
        (by_name[str(d.derivative_of)], d, [by_name[name] for name in names])
        for d, names in zip(derivatives, derivative_dependencies(params.structure), strict=True)
    ]


def model_description_xml(
    params: ModelParameters,
    variables: Sequence[FmuVariable],
    *,
    model_identifier: str,
    guid: str = GUID_PLACEHOLDER,
    kinds: Sequence[str] = KINDS,
    source_files: Sequence[str] = (),
    needs_execution_tool: bool = False,
    created: datetime | None = None,
    tool: str | None = None,
    capabilities: Mapping[str, bool] | None = None,
    log_categories: Sequence[tuple[str, str]] = LOG_CATEGORIES,
) -> str:
    """Render the FMI 2.0 ``modelDescription.xml`` (co-simulation, model exchange or both).

    Parameters
    ----------
    params : ModelParameters
        Vessel, model variant and provenance (description, generation time).
    variables : sequence of FmuVariable
        The FMU's variables in value-reference order (``fmu_variables``).
    model_identifier : str
        C-safe identifier: the shared-library name.
    guid : str
        The FMU's GUID (see :func:`content_guid`).
    kinds : sequence of {"cs", "me"}
        Co-simulation, model exchange, or both (one binary serves both).
    source_files : sequence of str
        C files under ``sources/`` to compile (``<SourceFiles>``); empty for none.
    needs_execution_tool : bool
        False for a self-contained binary.
    created : datetime, optional
        ``generationDateAndTime``; default :func:`generation_time`.
    tool : str, optional
        ``generationTool``; default :func:`generation_tool`.
    capabilities : mapping of str to bool, optional
        Overrides of the ``CoSimulation`` flags (default :data:`NATIVE_CAPABILITIES`),
        e.g. ``{"providesDirectionalDerivative": False}`` for a backend without it.
    log_categories : sequence of (name, description)
        ``LogCategories``; default those of the native C layer.

    Returns
    -------
    str
        The XML document.

    Raises
    ------
    ValueError
        For unknown kinds or capabilities, a unit this module cannot declare, a
        non-finite start value, or text XML cannot carry (a control character or lone
        surrogate, e.g. in the vessel name or the identification method).

    """
    _check_kinds(kinds)
    flags = {**NATIVE_CAPABILITIES, **(capabilities or {})}
    unknown = set(flags) - set(NATIVE_CAPABILITIES)
    if unknown:
        raise ValueError(f"unknown CoSimulation capabilities {sorted(unknown)}")
    root = _root(params, "2.0", "guid", guid, kinds, created, tool)
    root.set("numberOfEventIndicators", "0")
    common = {
        "modelIdentifier": model_identifier,
        "needsExecutionTool": "true" if needs_execution_tool else "false",
    }
    elements = []
    if "me" in kinds:  # the schema's order: ModelExchange, then CoSimulation
        elements.append(ET.SubElement(root, "ModelExchange", common | _flags(_FMI2_MODEL_EXCHANGE)))
    if "cs" in kinds:
        cosim = common | _flags(flags) | {"maxOutputDerivativeOrder": "0"}
        elements.append(ET.SubElement(root, "CoSimulation", cosim))
    for element in elements:
        if source_files:
            files = ET.SubElement(element, "SourceFiles")
            for name in source_files:
                ET.SubElement(files, "File", name=name)
    _unit_definitions(root, units_of(variables, params.structure), osp=False)
    _categories_and_experiment(root, log_categories)

    model_variables = ET.SubElement(root, "ModelVariables")
    index = {var.name: position for position, var in enumerate(variables, start=1)}
    for var in variables:
        attributes = {
            "name": var.name,
            "valueReference": str(var.value_reference),
            "description": var.description,
            "causality": var.causality,
            "variability": var.variability,
        }
        if var.causality == "parameter":
            attributes["initial"] = "exact"
        scalar = ET.SubElement(model_variables, "ScalarVariable", attributes)
        real = _real_attributes(var)
        if var.derivative_of is not None:
            real["derivative"] = str(index[var.derivative_of])
        ET.SubElement(scalar, "Real", real)

    # FMI 2.0 section 2.2.8: dependencies are 1-based indices into ModelVariables.
    states = _dependencies(params, variables)
    structure_element = ET.SubElement(root, "ModelStructure")
    outputs_element = ET.SubElement(structure_element, "Outputs")
    for state, _, _ in states:
        # A state: it depends on itself only, never directly on an input.
        state_index = str(index[state.name])
        ET.SubElement(outputs_element, "Unknown", index=state_index, dependencies=state_index)
    for name in GROUND_NAMES:  # states and the current: a direct feed-through
        ground = sorted(index[known] for known in ground_dependencies())
        ET.SubElement(
            outputs_element,
            "Unknown",
            index=str(index[name]),
            dependencies=" ".join(map(str, ground)),
        )
    derivatives_element = ET.SubElement(structure_element, "Derivatives")
    for _, derivative, knowns in states:
        dependencies = " ".join(
            str(index[k.name]) for k in sorted(knowns, key=lambda v: index[v.name])
        )
        ET.SubElement(
            derivatives_element,
            "Unknown",
            index=str(index[derivative.name]),
            dependencies=dependencies,
        )
    initial_element = ET.SubElement(structure_element, "InitialUnknowns")
    for state, _, _ in states:
        # At initialisation the output x equals its parameter x0.
        ET.SubElement(
            initial_element,
            "Unknown",
            index=str(index[state.name]),
            dependencies=str(index[f"{state.name}0"]),
            dependenciesKind="dependent",
        )
    for _, derivative, _ in states:  # calculated from everything: no dependencies listed
        ET.SubElement(initial_element, "Unknown", index=str(index[derivative.name]))
    for name in GROUND_NAMES:  # from the initial state and the current
        initial = sorted(index[known] for known in _initial_ground_dependencies())
        ET.SubElement(
            initial_element,
            "Unknown",
            index=str(index[name]),
            dependencies=" ".join(map(str, initial)),
        )
    return _to_text(root)


def _initial_ground_dependencies() -> list[str]:
    """Return what sog and cog depend on at initialisation: u0, v0, psi0, the current."""
    return [name + "0" if name in STATE_NAMES else name for name in ground_dependencies()]


def model_description_fmi3_xml(
    params: ModelParameters,
    variables: Sequence[FmuVariable],
    *,
    model_identifier: str,
    instantiation_token: str = GUID_PLACEHOLDER,
    kinds: Sequence[str] = KINDS,
    created: datetime | None = None,
    tool: str | None = None,
    log_categories: Sequence[tuple[str, str]] = LOG_CATEGORIES,
) -> str:
    """Render the FMI 3.0 ``modelDescription.xml`` (co-simulation, model exchange or both).

    The same variables, units and structure as :func:`model_description_xml`, in the
    FMI 3.0 schema (section 2.4): ``Float64`` variables, ``ModelStructure`` by value
    reference, ``time`` the independent variable. The sources are listed in
    ``sources/buildDescription.xml`` (:func:`build_description_xml`), not here.

    Parameters
    ----------
    params : ModelParameters
        Vessel, model variant and provenance.
    variables : sequence of FmuVariable
        The FMU's variables in value-reference order (``fmu_variables``).
    model_identifier : str
        C-safe identifier: the shared-library name.
    instantiation_token : str
        The FMU's instantiation token (see :func:`content_guid`).
    kinds : sequence of {"cs", "me"}
        Co-simulation, model exchange, or both.
    created, tool, log_categories
        As in :func:`model_description_xml`.

    Returns
    -------
    str
        The XML document.

    Raises
    ------
    ValueError
        As :func:`model_description_xml`.

    """
    _check_kinds(kinds)
    root = _root(params, "3.0", "instantiationToken", instantiation_token, kinds, created, tool)
    identifier = {"modelIdentifier": model_identifier}
    if "me" in kinds:  # the schema's order: ModelExchange, then CoSimulation
        flags = _flags({**_FMI3_COMMON, **_FMI3_MODEL_EXCHANGE})
        ET.SubElement(root, "ModelExchange", identifier | flags)
    if "cs" in kinds:
        flags = _flags({**_FMI3_COMMON, **_FMI3_CO_SIMULATION})
        ET.SubElement(root, "CoSimulation", identifier | flags | {"maxOutputDerivativeOrder": "0"})
    _unit_definitions(root, units_of(variables, params.structure), osp=False)
    _categories_and_experiment(root, log_categories)

    model_variables = ET.SubElement(root, "ModelVariables")
    by_name = {v.name: v for v in variables}
    for var in variables:
        attributes = {
            "name": var.name,
            "valueReference": str(var.value_reference),
            "description": var.description,
            "causality": var.causality,
            "variability": var.variability,
        }
        if var.causality == "parameter":
            attributes["initial"] = "exact"
        attributes |= _real_attributes(var)
        if var.derivative_of is not None:
            attributes["derivative"] = str(by_name[var.derivative_of].value_reference)
        ET.SubElement(model_variables, "Float64", attributes)

    # FMI 3.0 section 2.4.8: dependencies are value references.
    states = _dependencies(params, variables)
    structure_element = ET.SubElement(root, "ModelStructure")
    for state, _, _ in states:
        reference = str(state.value_reference)  # a state: it depends on itself only
        ET.SubElement(structure_element, "Output", valueReference=reference, dependencies=reference)
    for name in GROUND_NAMES:  # states and the current: a direct feed-through
        references = sorted(by_name[known].value_reference for known in ground_dependencies())
        ET.SubElement(
            structure_element,
            "Output",
            valueReference=str(by_name[name].value_reference),
            dependencies=" ".join(map(str, references)),
        )
    for _, derivative, knowns in states:
        references = sorted(k.value_reference for k in knowns)
        ET.SubElement(
            structure_element,
            "ContinuousStateDerivative",
            valueReference=str(derivative.value_reference),
            dependencies=" ".join(str(vr) for vr in references),
        )
    for state, _, _ in states:
        ET.SubElement(
            structure_element,
            "InitialUnknown",
            valueReference=str(state.value_reference),
            dependencies=str(by_name[f"{state.name}0"].value_reference),
            dependenciesKind="dependent",
        )
    for _, derivative, _ in states:
        ET.SubElement(
            structure_element, "InitialUnknown", valueReference=str(derivative.value_reference)
        )
    for name in GROUND_NAMES:
        references = sorted(
            by_name[known].value_reference for known in _initial_ground_dependencies()
        )
        ET.SubElement(
            structure_element,
            "InitialUnknown",
            valueReference=str(by_name[name].value_reference),
            dependencies=" ".join(map(str, references)),
        )
    return _to_text(root)


def build_description_xml(model_identifier: str, source_files: Sequence[str]) -> str:
    """Render ``sources/buildDescription.xml`` of an FMI 3.0 FMU (section 2.5.1).

    Parameters
    ----------
    model_identifier : str
        The modelIdentifier the sources build.
    source_files : sequence of str
        The C files of ``sources/`` to compile, as one C99 source file set.

    Returns
    -------
    str
        The XML document.

    """
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    configuration = ET.SubElement(root, "BuildConfiguration", modelIdentifier=model_identifier)
    file_set = ET.SubElement(configuration, "SourceFileSet", language="C99")
    for name in source_files:
        ET.SubElement(file_set, "SourceFile", name=name)
    return _to_text(root)


# OSP-IS variable groups: (element, group name, variable names). The VariableGroups
# schema is a sequence, so Generic groups come first, then the typed groups in schema order.
_OSP_GROUPS: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("Generic", "rudder_angle", ("rudder_angle",)),
    ("Generic", "propeller_speed", ("propeller_rpm",)),
    ("Generic", "heading", ("psi",)),
    ("LinearVelocity", "linear_velocity", ("u", "v")),
    ("AngularVelocity", "angular_velocity", ("r",)),
    ("LinearDisplacement", "position", ("x", "y")),
)


def osp_model_description_xml(params: ModelParameters, variables: Sequence[FmuVariable]) -> str:
    """Render the OSP-IS ``<name>_OspModelDescription.xml`` sidecar (format 1.0.0).

    Groups: body velocities (u, v) as ``LinearVelocity``, yaw rate as
    ``AngularVelocity``, earth-fixed position (x, y) as ``LinearDisplacement``; heading,
    rudder angle and propeller speed as ``Generic`` groups.
    """
    by_name: Mapping[str, FmuVariable] = {v.name: v for v in variables}
    wanted = [by_name[name] for _, _, names in _OSP_GROUPS for name in names]
    # Default namespace (as in the OSP and libcosim examples); every element is in it.
    root = ET.Element("OspModelDescription", xmlns=OSP_NAMESPACE, version="1.0")
    _unit_definitions(root, units_of(wanted, params.structure), osp=True)
    groups = ET.SubElement(root, "VariableGroups")
    for element, group_name, names in _OSP_GROUPS:
        group = ET.SubElement(groups, element, name=group_name)
        for name in names:
            var = by_name[name]
            attributes = {"ref": var.name}
            if var.unit is not None:
                attributes["unit"] = var.unit
            ET.SubElement(group, "Variable", attributes)
    return _to_text(root)
