"""Native C FMU: model description, numerics against fmu_model.simulate, FMI behaviour, CLI.

The FMU is built once per module from a stable ~100 m ship in equilibrium at 5 m/s and
2 rev/s. Its outputs must equal ``fmu_model.simulate(..., method="rk4")`` with the
inputs held per step to 1e-12 (relative to each output's range); the state functions
must continue bit-identically; bad input must give the documented FMI status.
"""

from __future__ import annotations

import gc
import json
import math
import re
import shutil
import struct
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from ctypes import byref, c_char_p, c_double, c_int, c_uint, c_void_p
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2LastSuccessfulTime,
    fmi2Terminated,
)
from fmpy.validation import validate_fmu

import build_fmu
from fmu_model import ModelParameters, get_model, model_names, save_params, simulate
from fmu_model.errors import FmuBuildError
from fmu_model.export_native import (
    C_DIR,
    COMMON_SOURCE,
    LAYER_SOURCES,
    build_native_fmu,
    fmi_headers_dir,
    osp_sidecar_path,
    render_native_fmu,
)
from fmu_model.fmi_rules import WINDAGE_COUPLING_FORMAT
from fmu_model.interface import (
    MAX_PROPELLER_RPM,
    MAX_SPEED_MPS,
    MAX_SUBSTEPS,
    MAX_YAW_RATE_RADPS,
    MIN_LENGTH_M,
    RUDDER_LIMIT_RAD,
    fmu_variables,
    model_identifier,
)
from fmu_model.model_description import LOG_CATEGORIES, OSP_NAMESPACE
from tests.fmi_logging import LogRecorder
from tests.test_shape import COEFFICIENTS as PRIME_RUDDER_COEFFICIENTS

ROOT = Path(__file__).resolve().parents[1]
HOST_SOURCE = ROOT / "tests" / "c_host" / "host.c"

FMI_OK, FMI_DISCARD, FMI_ERROR = 0, 2, 3
VR_RUDDER, VR_RPM = 0, 1
VR_OUTPUTS = list(range(2, 8))  # u, v, r, x, y, psi
VR_MAX_STEP, VR_U0 = 9, 10
VR_COEFFICIENTS = 16
MAX_STEP_S = 0.05
LAYER_SOURCE = LAYER_SOURCES["2"]

# A stable ship, L = 100 m: at u = 5 m/s and n = 2 rev/s the surge balance
# a1 u^2 + a9 n^2 = 0 holds (a9 = 0.01 * 25 / 4); sway/yaw are a stable linear pair
# (b1 = c2 = -0.5 1/s) and positive rudder gives r > 0 (c3 > 0).
COEFFICIENTS = {
    "a1": -0.01,
    "a2": -0.005,
    "a3": -2.0,
    "a4": -0.05,
    "a5": 0.1,
    "a6": 0.0,
    "a7": 0.0,
    "a8": 0.0,
    "a9": 0.0625,
    "b1": -0.5,
    "b2": 0.0,
    "b3": 0.05,
    "b4": -0.2,
    "c1": 0.001,
    "c2": -0.5,
    "c3": 0.02,
}
SPEED_MPS, N_RPS = 5.0, 2.0


def make_params(**changes: Any) -> ModelParameters:
    params = ModelParameters(
        model="shi2009",
        coefficients=np.array(list(COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="Test Ship",
        nominal_speed_mps=SPEED_MPS,
        nominal_n_rps=N_RPS,
        covariance=np.diag(np.full(len(COEFFICIENTS), 1e-8)),
        identification={"method": "ekf", "created": "2024-05-01T12:00:00+00:00"},
    )
    return replace(params, **changes)


@pytest.fixture(scope="module")
def params() -> ModelParameters:
    return make_params()


@pytest.fixture(scope="module")
def fmu_path(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> Path:
    return build_native_fmu(params, tmp_path_factory.mktemp("fmu") / "Test_Ship.fmu")


@pytest.fixture(scope="module")
def unzipped(fmu_path: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    return Path(extract(fmu_path, unzipdir=tmp_path_factory.mktemp("unzipped")))


# --- FMI helpers -----------------------------------------------------------------------


@contextmanager
def slave(
    unzipped: Path,
    *,
    logger: LogRecorder | None = None,
    logging_on: bool = False,
    before_init: Callable[[FMU2Slave], None] | None = None,
    name: str = "ship",
) -> Iterator[FMU2Slave]:
    """An initialised FMU2Slave (start time 0), freed on exit."""
    md = read_model_description(unzipped)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(unzipped),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName=name,
    )
    fmu.instantiate(callbacks=logger.callbacks if logger else None, loggingOn=logging_on)
    try:
        fmu.setupExperiment(startTime=0.0)
        if before_init is not None:
            before_init(fmu)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        yield fmu
    finally:
        fmu.freeInstance()


def status(call: Callable[..., Any], *args: Any) -> int:
    """Return code of a low-level fmpy call (fmpy raises for codes above fmi2Warning)."""
    try:
        return int(call(*args))
    except FMICallException as exc:
        return int(exc.status)


def set_real(fmu: FMU2Slave, vrs: list[int], values: list[float]) -> int:
    vr = (c_uint * len(vrs))(*vrs)
    value = (c_double * len(values))(*values)
    return status(fmu.fmi2SetReal, fmu.component, vr, len(vrs), value)


def do_step(fmu: FMU2Slave, t: float, h: float) -> int:
    return status(fmu.fmi2DoStep, fmu.component, t, h, 1)


def run(fmu: FMU2Slave, time_s: np.ndarray, rudder: np.ndarray, rpm: np.ndarray) -> np.ndarray:
    """Outputs at the sample times; inputs at time_s[k] held over [t_k, t_k+1]."""
    out = np.empty((time_s.size, 6))
    out[0] = fmu.getReal(VR_OUTPUTS)
    for k in range(time_s.size - 1):
        fmu.setReal([VR_RUDDER, VR_RPM], [rudder[k], rpm[k]])
        fmu.doStep(time_s[k], time_s[k + 1] - time_s[k])
        out[k + 1] = fmu.getReal(VR_OUTPUTS)
    return out


def manoeuvre(time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rudder [rad] (sine up to 35 deg and steps) and propeller [rpm] histories."""
    rudder = np.radians(35.0 * np.sin(2.0 * np.pi * time_s / 90.0))
    rudder[(time_s > 100.0) & (time_s < 130.0)] = np.radians(-20.0)
    rpm = 60.0 * N_RPS + 12.0 * np.sin(2.0 * np.pi * time_s / 70.0)
    return rudder, rpm


def assert_matches_model(out: np.ndarray, ref: np.ndarray) -> None:
    """Equal to 1e-12 relative, each output against its own range (v and r cross zero)."""
    scale = np.max(np.abs(ref), axis=0)
    excess = np.abs(out - ref) / (1e-12 * np.maximum(np.abs(ref), scale))
    assert np.all(excess <= 1.0), f"error up to {np.max(excess):.3g} x 1e-12 relative"


# --- model description, sidecar, sources --------------------------------------------


def test_validate_fmu_reports_no_problems(fmu_path: Path) -> None:
    assert validate_fmu(str(fmu_path)) == []


def test_model_description_declares_capabilities_units_and_structure(
    unzipped: Path, params: ModelParameters
) -> None:
    md = read_model_description(unzipped)
    cs = md.coSimulation
    assert md.fmiVersion == "2.0"
    assert md.modelName == "Test Ship"
    assert cs.modelIdentifier == "Test_Ship"
    assert cs.canHandleVariableCommunicationStepSize
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert not cs.needsExecutionTool and not cs.canBeInstantiatedOnlyOncePerProcess
    assert md.generationDateAndTime == "2024-05-01T12:00:00Z"
    assert md.generationTool.startswith("shipid ")
    assert md.numberOfEventIndicators == 0
    assert [c.name for c in md.logCategories] == [name for name, _ in LOG_CATEGORIES]
    assert md.defaultExperiment.stepSize == "0.1"

    names = [v.name for v in md.modelVariables]
    assert names == [v.name for v in fmu_variables(params)]
    variables = {v.name: v for v in md.modelVariables}
    rudder = variables["rudder_angle"]
    assert (rudder.causality, rudder.unit, rudder.displayUnit) == ("input", "rad", "deg")
    assert float(rudder.max) == RUDDER_LIMIT_RAD == -float(rudder.min)
    assert variables["propeller_rpm"].start == "120.0"
    rpm, length = variables["propeller_rpm"], variables["length"]
    assert (
        (float(rpm.min), float(rpm.max)) == (-MAX_PROPELLER_RPM, MAX_PROPELLER_RPM) == (-6e3, 6e3)
    )
    assert float(length.min) == MIN_LENGTH_M > 0.0 and float(length.max) == 1000.0
    for name in ("u0", "v0", "r0", "x0", "y0", "psi0"):
        assert float(variables[name].min) == -float(variables[name].max) > -math.inf
    assert variables["a9"].start == "0.0625" and variables["a9"].variability == "fixed"
    assert variables["max_step"].start == "0.05"

    units = {u.name: u for u in md.unitDefinitions}
    deg = units["rad"].displayUnits[0]
    assert (deg.name, deg.factor) == ("deg", 57.29577951308232)
    assert units["rad"].baseUnit.rad == 1
    assert (units["rpm"].baseUnit.s, units["rpm"].baseUnit.factor) == (-1, 1.0 / 60.0)
    assert (units["1/(m.s)"].baseUnit.m, units["1/(m.s)"].baseUnit.s) == (-1, -1)
    assert (units["m/s2"].baseUnit.m, units["m/s2"].baseUnit.s) == (1, -2)

    outputs = [u.variable.name for u in md.outputs]
    assert outputs == ["u", "v", "r", "x", "y", "psi", "sog", "cog"]
    states = outputs[:6]
    # A state output depends on itself, never directly on an input; speed and course
    # over ground on the states and (directly) on the current.
    dependencies = {u.variable.name: [d.name for d in u.dependencies] for u in md.outputs}
    assert all(dependencies[name] == [name] for name in states)
    over_ground = ["u", "v", "psi", "current_speed", "current_direction"]
    assert dependencies["sog"] == dependencies["cog"] == over_ground
    derivatives = {u.variable.name: {d.name for d in u.dependencies} for u in md.derivatives}
    wind = {"u", "v", "psi", "current_speed", "current_direction", "wind_speed", "wind_direction"}
    assert derivatives == {
        "der(u)": {"u", "v", "r", "rudder_angle", "propeller_rpm"} | wind,  # a1 ... a9
        "der(v)": {"u", "v", "r", "rudder_angle"} | wind,  # b1 ... b4
        "der(r)": {"v", "r", "rudder_angle"} | wind,  # c1 ... c3
        "der(x)": {"u", "v", "psi", "current_speed", "current_direction"},
        "der(y)": {"u", "v", "psi", "current_speed", "current_direction"},
        "der(psi)": {"r"},
    }
    assert [v.derivative.name for v in md.modelVariables if v.derivative] == states
    initial = {u.variable.name: u.dependencies for u in md.initialUnknowns}
    assert {k: [d.name for d in initial[k]] for k in states} == {n: [f"{n}0"] for n in states}
    assert all(initial[f"der({n})"] is None for n in states)  # depends on everything
    at_start = ["u0", "v0", "psi0", "current_speed", "current_direction"]
    assert [d.name for d in initial["sog"]] == [d.name for d in initial["cog"]] == at_start
    assert md.buildConfigurations[0].sourceFileSets[0].sourceFiles == [LAYER_SOURCE]
    me = md.modelExchange
    assert me.modelIdentifier == cs.modelIdentifier
    assert me.providesDirectionalDerivative and cs.providesDirectionalDerivative
    assert "event-free" in md.description


def test_log_categories_match_the_c_layer() -> None:
    source = (C_DIR / COMMON_SOURCE).read_text()
    table = re.search(r"LOG_CATEGORY_NAMES\[N_LOG_CATEGORIES\] = \{(.*?)\};", source, re.S)
    assert table is not None
    assert re.findall(r'"(\w+)"', table.group(1)) == [name for name, _ in LOG_CATEGORIES]


def test_fmu_carries_its_sources_and_guid(fmu_path: Path, unzipped: Path) -> None:
    with zipfile.ZipFile(fmu_path) as archive:
        names = sorted(archive.namelist())
    assert names == [
        "binaries/linux64/Test_Ship.so",
        "modelDescription.xml",
        "sources/fmi2_functions.c",
        "sources/model_config.h",
        "sources/model_equations.h",
        "sources/ship_common.c",
        "sources/ship_fmu.h",
    ]
    guid = read_model_description(unzipped).guid
    assert f'#define MODEL_GUID "{guid}"' in (unzipped / "sources/model_config.h").read_text()
    for name in (LAYER_SOURCE, COMMON_SOURCE):
        assert (unzipped / "sources" / name).read_text() == (C_DIR / name).read_text()


def test_guid_follows_the_content(params: ModelParameters) -> None:
    first = render_native_fmu(params)
    assert render_native_fmu(params).guid == first.guid
    theta = params.coefficients.copy()
    theta[0] *= 1.001
    assert render_native_fmu(params.with_vector(theta)).guid != first.guid
    assert render_native_fmu(params, max_step_s=0.02).guid != first.guid


def test_osp_sidecar_groups_reference_model_variables(
    fmu_path: Path, params: ModelParameters
) -> None:
    sidecar = osp_sidecar_path(fmu_path)
    assert sidecar.name == "Test_Ship_OspModelDescription.xml"
    root = ET.parse(sidecar).getroot()
    ns = {"osp": OSP_NAMESPACE}
    assert root.tag == f"{{{OSP_NAMESPACE}}}OspModelDescription"
    groups = root.find("osp:VariableGroups", ns)
    assert groups is not None

    def refs(element: str, name: str) -> list[str]:
        group = groups.find(f"osp:{element}[@name='{name}']", ns)
        assert group is not None, (element, name)
        return [v.get("ref", "") for v in group.findall("osp:Variable", ns)]

    assert refs("LinearVelocity", "linear_velocity") == ["u", "v"]
    assert refs("AngularVelocity", "angular_velocity") == ["r"]
    assert refs("LinearDisplacement", "position") == ["x", "y"]
    assert refs("Generic", "heading") == ["psi"]
    assert refs("Generic", "rudder_angle") == ["rudder_angle"]
    assert refs("Generic", "propeller_speed") == ["propeller_rpm"]
    # The schema is a sequence: Generic groups first, typed groups in schema order.
    tags = [child.tag.split("}")[1] for child in groups]
    assert tags == ["Generic"] * 3 + ["LinearVelocity", "AngularVelocity", "LinearDisplacement"]
    defined = {u.get("name") for u in root.iterfind("osp:UnitDefinitions/osp:Unit", ns)}
    used = {v.get("unit") for v in root.iterfind(".//osp:Variable", ns)}
    assert used <= defined
    names = {v.name for v in fmu_variables(params)}
    assert {v.get("ref") for v in root.iterfind(".//osp:Variable", ns)} <= names


def test_model_identifier_is_c_safe() -> None:
    assert model_identifier("Test Ship 1") == "Test_Ship_1"
    assert model_identifier("KVLCC2 (model scale)") == "KVLCC2_model_scale"
    assert model_identifier("123") == "ship_123"
    assert model_identifier("2nd ship") == "ship_2nd_ship"
    assert model_identifier("_x__y_") == "x_y"
    assert model_identifier("Ålesund/ø") == "lesund"
    assert model_identifier("  ") == "ship"


def test_model_config_carries_the_divergence_rule_of_the_interface(
    params: ModelParameters,
) -> None:
    config = render_native_fmu(params).sources["model_config.h"]
    assert f"#define DIVERGENCE_MAX_SPEED {MAX_SPEED_MPS!r}\n" in config
    assert f"#define DIVERGENCE_MAX_YAW_RATE {MAX_YAW_RATE_RADPS!r}\n" in config
    assert '#define DIVERGENCE_FORMAT "the state diverged at t = %.9g s' in config
    layer = (C_DIR / COMMON_SOURCE).read_text()
    assert "DIVERGENCE_MAX_SPEED" in layer and "#define DIVERGENCE" not in layer  # one copy


def test_model_config_carries_the_step_and_start_rules_of_the_interface(
    params: ModelParameters,
) -> None:
    config = render_native_fmu(params).sources["model_config.h"]
    assert "#define MAX_SUBSTEPS 1000000.0\n" in config
    assert "#define MIN_START_SPEED 0.0\n" in config  # shi2009 starts from rest
    prime = replace(
        params,
        model="prime-rudder",
        coefficients=np.array(list(PRIME_RUDDER_COEFFICIENTS.values())),
        covariance=None,
    )
    assert "#define MIN_START_SPEED 0.001\n" in render_native_fmu(prime).sources["model_config.h"]
    layer = (C_DIR / COMMON_SOURCE).read_text()
    for macro in ("MAX_SUBSTEPS", "MIN_START_SPEED", "TIME_STALL_FORMAT", "STATE_RANGE_FORMAT"):
        assert macro in layer and f"#define {macro}" not in layer  # one copy, generated
    assert "10000000" not in layer  # the old limit of 1e7 internal steps (7-9 s) is gone


# --- numerics against fmu_model.simulate ----------------------------------------------


def _irregular(rng: np.random.Generator, n: int, low: float, high: float) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(rng.uniform(low, high, n - 1))])


SCHEDULES = {
    # step equal to two internal steps
    "regular 0.1 s": lambda rng: np.arange(1500) * 0.1,
    # steps below max_step: one internal step each
    "regular 0.02 s": lambda rng: np.arange(1500) * 0.02,
    # 1 s steps: 20 internal steps each
    "regular 1 s": lambda rng: np.arange(300) * 1.0,
    # irregular steps on both sides of max_step
    "irregular": lambda rng: _irregular(rng, 1500, 0.005, 0.37),
}


@pytest.mark.parametrize("schedule", SCHEDULES)
def test_outputs_equal_python_rk4(unzipped: Path, params: ModelParameters, schedule: str) -> None:
    time_s = SCHEDULES[schedule](np.random.default_rng(7))
    rudder, rpm = manoeuvre(time_s)
    with slave(unzipped) as fmu:
        out = run(fmu, time_s, rudder, rpm)
    initial = [SPEED_MPS, 0.0, 0.0, 0.0, 0.0, 0.0]
    ref = simulate(params, time_s, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    assert_matches_model(out, ref)
    assert np.ptp(ref[:, 5]) > 0.1  # the ship did manoeuvre


# Gains of the speed-dependent variants: the prime-rudder tanker of test_shape, with
# rudder terms for the free-rudder variants, a cubic lift of a third of the linear one
# (prime-rudder-lift), the same approach thrust of fixed slope (prime-rudder-thrust) and
# a cross-flow yaw moment of about the modulus terms' size (prime-crossflow);
# absent names are 0.
PRIME_GAINS = {
    **PRIME_RUDDER_COEFFICIENTS,
    "Y_uud": -0.03,
    "N_uud": 0.3,
    "N_nv": -1e-3,
    "Y_R3": -0.018,
    "N_R3": 0.17,
    "X_T": 9e-6,
    "N_cf1": -8.0,
    "N_cf2": -0.6,
}


@pytest.mark.parametrize(
    "model",
    # the neutral-rudder offset at a value that moves the rudder force (default 0)
    [m for m in model_names() if m != "shi2009"] + ["prime-rudder-offset[d0=0.02]"],
)
def test_every_variant_fmu_equals_python_rk4(model: str, tmp_path: Path) -> None:
    names = get_model(model).coefficient_names
    params = replace(
        make_params(),
        model=model,
        coefficients=np.array([PRIME_GAINS.get(name, 0.0) for name in names]),
        covariance=None,
    )
    unzipped = Path(extract(build_native_fmu(params, tmp_path / "v.fmu"), unzipdir=tmp_path / "x"))
    time_s = SCHEDULES["regular 0.1 s"](np.random.default_rng(7))
    rudder, rpm = manoeuvre(time_s)
    with slave(unzipped) as fmu:
        out = run(fmu, time_s, rudder, rpm)
    initial = [SPEED_MPS, 0.0, 0.0, 0.0, 0.0, 0.0]
    ref = simulate(params, time_s, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    assert np.all(np.isfinite(ref)) and np.ptp(ref[:, 5]) > 0.1
    assert_matches_model(out, ref)


def test_parameters_set_before_initialisation_are_used(
    unzipped: Path, params: ModelParameters
) -> None:
    """Every coefficient, max_step and the initial state go through the VR table."""
    theta = params.coefficients * np.linspace(0.9, 1.1, params.coefficients.size)
    initial = [4.0, 0.1, 0.01, 10.0, -5.0, 0.3]

    def configure(fmu: FMU2Slave) -> None:
        vrs = list(range(VR_COEFFICIENTS, VR_COEFFICIENTS + theta.size))
        fmu.setReal(vrs, list(theta))
        fmu.setReal([VR_MAX_STEP], [0.02])
        fmu.setReal(list(range(VR_U0, VR_U0 + 6)), initial)

    time_s = np.arange(400) * 0.1
    rudder, rpm = manoeuvre(time_s)
    with slave(unzipped, before_init=configure) as fmu:
        assert fmu.getReal(VR_OUTPUTS) == initial
        out = run(fmu, time_s, rudder, rpm)
    ref = simulate(params.with_vector(theta), time_s, rudder, rpm / 60.0, initial, max_step_s=0.02)
    assert_matches_model(out, ref)


def test_straight_run_stays_straight_and_turns_are_mirror_images(unzipped: Path) -> None:
    time_s = np.arange(3001) * 0.2  # 600 s
    rpm = np.full(time_s.size, 60.0 * N_RPS)
    with slave(unzipped) as fmu:
        straight = run(fmu, time_s, np.zeros(time_s.size), rpm)
    np.testing.assert_array_equal(straight[:, [1, 2, 4, 5]], 0.0)  # v, r, y, psi
    np.testing.assert_allclose(straight[:, 0], SPEED_MPS, rtol=1e-14)  # equilibrium
    with slave(unzipped) as fmu:
        starboard = run(fmu, time_s, np.full(time_s.size, np.radians(20.0)), rpm)
    with slave(unzipped) as fmu:
        port = run(fmu, time_s, np.full(time_s.size, np.radians(-20.0)), rpm)
    assert starboard[-1, 2] > 0.0 and starboard[-1, 5] > 2.0 * np.pi  # a full circle
    assert np.all((starboard[:, 0] > 3.0) & (starboard[:, 0] <= SPEED_MPS + 1e-12))
    assert np.max(np.abs(starboard[:, 1])) < 1.0
    mirror = np.array([1.0, -1.0, -1.0, 1.0, -1.0, -1.0])
    np.testing.assert_array_equal(port, starboard * mirror)


def test_simulate_fmu_runs_one_hour(fmu_path: Path) -> None:
    result = simulate_fmu(
        str(fmu_path),
        stop_time=3600.0,
        step_size=0.1,
        output_interval=1.0,
        start_values={"rudder_angle": np.radians(10.0)},
    )
    assert result["time"][-1] == pytest.approx(3600.0)
    assert np.all(np.isfinite(result["psi"])) and result["psi"][-1] > 2.0 * np.pi


# --- FMU state, reset ---------------------------------------------------------------


def test_fmu_state_round_trips_continue_bit_identically(unzipped: Path) -> None:
    time_s = np.arange(801) * 0.1
    rudder, rpm = manoeuvre(time_s)
    half = 400
    with slave(unzipped) as fmu, slave(unzipped, name="other") as other:
        run(fmu, time_s[: half + 1], rudder, rpm)
        state = fmu.getFMUstate()
        serialized = fmu.serializeFMUstate(state)
        first = run(fmu, time_s[half:], rudder[half:], rpm[half:])

        fmu.setFMUstate(state)
        again = run(fmu, time_s[half:], rudder[half:], rpm[half:])
        np.testing.assert_array_equal(again, first)

        restored = fmu.deSerializeFMUstate(serialized)
        fmu.setFMUstate(restored)
        np.testing.assert_array_equal(run(fmu, time_s[half:], rudder[half:], rpm[half:]), first)

        # A serialised state moves between instances of the same FMU.
        moved = other.deSerializeFMUstate(serialized)
        other.setFMUstate(moved)
        np.testing.assert_array_equal(run(other, time_s[half:], rudder[half:], rpm[half:]), first)
        fmu.freeFMUstate(state)
        fmu.freeFMUstate(restored)
        other.freeFMUstate(moved)


def test_fmu_state_functions_work_in_every_state_fmi_allows(unzipped: Path) -> None:
    """FMI 2.0: instantiated, initialization mode, step complete, step failed, terminated."""
    md = read_model_description(unzipped)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(unzipped),
        modelIdentifier=md.coSimulation.modelIdentifier,
    )
    fmu.instantiate()
    saved = []

    def save_and_round_trip() -> None:
        state = fmu.getFMUstate()
        copy = fmu.deSerializeFMUstate(fmu.serializeFMUstate(state))
        fmu.setFMUstate(copy)
        fmu.freeFMUstate(copy)
        saved.append(state)

    try:
        save_and_round_trip()  # instantiated
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([VR_COEFFICIENTS], [0.5])  # a1 > 0: diverges within 0.4 s
        save_and_round_trip()  # initialization mode
        fmu.exitInitializationMode()
        save_and_round_trip()  # step complete
        step_complete = saved[-1]
        assert do_step(fmu, 0.0, 2.0) == FMI_DISCARD
        save_and_round_trip()  # step failed
        assert do_step(fmu, 0.0, 0.1) == FMI_ERROR  # still failed after the round trip
        fmu.setFMUstate(step_complete)
        assert do_step(fmu, 0.0, 0.1) == FMI_OK
        fmu.terminate()
        save_and_round_trip()  # terminated
        fmu.setFMUstate(saved[0])  # back to instantiated: initialisation is allowed again
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        assert do_step(fmu, 0.0, 2.0) == FMI_OK  # a1 of the instantiated state: stable
        for state in saved:
            fmu.freeFMUstate(state)
    finally:
        fmu.freeInstance()


def test_corrupt_serialized_state_is_rejected(unzipped: Path) -> None:
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        serialized = bytearray(fmu.serializeFMUstate(fmu.getFMUstate()))
        serialized[20] ^= 0xFF  # inside the GUID
        with pytest.raises(FMICallException) as info:
            fmu.deSerializeFMUstate(bytes(serialized))
        assert info.value.status == FMI_ERROR
        assert "another FMU" in logger.last()[2]
        with pytest.raises(FMICallException):
            fmu.deSerializeFMUstate(bytes(serialized[:-1]))


def test_reset_returns_to_the_initial_state(unzipped: Path) -> None:
    time_s = np.arange(301) * 0.1
    rudder, rpm = manoeuvre(time_s)
    with slave(unzipped) as fmu:
        initial = fmu.getReal(VR_OUTPUTS)
        first = run(fmu, time_s, rudder, rpm)
        fmu.reset()
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        assert fmu.getReal(VR_OUTPUTS) == initial
        fmu.exitInitializationMode()
        np.testing.assert_array_equal(run(fmu, time_s, rudder, rpm), first)


def test_log_messages_reach_the_default_logger_after_a_recorder_is_gone(
    unzipped: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    # fmpy's C logging proxy has one process-wide target; a per-test callback left it
    # dangling and crashed the next FMU that logged through fmpy's defaults.
    recorder = LogRecorder()
    with slave(unzipped, logger=recorder) as fmu, pytest.raises(FMICallException):
        fmu.setReal([VR_RUDDER], [math.nan])
    assert "must be finite" in recorder.last()[2]
    del recorder, fmu
    gc.collect()
    with slave(unzipped) as fmu, pytest.raises(FMICallException):
        fmu.setReal([VR_RPM], [math.inf])
    assert "[ERROR] fmi2SetReal: 'propeller_rpm'" in capfd.readouterr().out


# --- bad input: the documented statuses ----------------------------------------------

BAD_SET_REAL = {
    "NaN rudder": ([VR_RUDDER], [math.nan], "must be finite"),
    "infinite rpm": ([VR_RPM], [math.inf], "must be finite"),
    "rpm beyond +6000": ([VR_RPM], [6000.5], "'propeller_rpm' (vr 1) = 6000.5 is outside"),
    "rpm -1e9": ([VR_RPM], [-1e9], "is outside [-6000, 6000]"),
    "rudder beyond +45 deg": ([VR_RUDDER], [np.radians(45.5)], "outside"),
    "rudder beyond -45 deg": ([VR_RUDDER], [-np.radians(46.0)], "outside"),
    "parameter after init": ([VR_COEFFICIENTS], [-0.02], "fixed parameter"),
    "max_step after init": ([VR_MAX_STEP], [0.01], "fixed parameter"),
    "output": ([2], [1.0], "is an output"),
    "unknown value reference": ([999], [0.0], "unknown value reference"),
    "one bad value in a batch": ([VR_RPM, VR_RUDDER], [100.0, math.nan], "must be finite"),
}


@pytest.mark.parametrize("case", BAD_SET_REAL)
def test_bad_set_real_is_an_error_and_changes_nothing(unzipped: Path, case: str) -> None:
    vrs, values, message = BAD_SET_REAL[case]
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        everything = list(range(32))
        before = fmu.getReal(everything)
        assert set_real(fmu, vrs, values) == FMI_ERROR
        code, category, text = logger.last()
        assert (code, category) == (FMI_ERROR, "logStatusError")
        assert message in text
        assert fmu.getReal(everything) == before  # all or nothing
        assert do_step(fmu, 0.0, 0.1) == FMI_OK  # the instance goes on


BAD_DO_STEP = {
    "negative step": (0.0, -0.1, "must be positive"),
    "zero step": (0.0, 0.0, "must be positive"),
    "NaN step": (0.0, math.nan, "must be positive"),
    "wrong communication point": (5.0, 0.1, "is not the FMU's time"),
    "too many internal steps": (0.0, 1e9, "internal steps"),
    "one internal step more than the limit": (
        0.0,
        (MAX_SUBSTEPS + 1) * MAX_STEP_S,
        "more than the 1000000 one call may take",
    ),
}


@pytest.mark.parametrize("case", BAD_DO_STEP)
def test_bad_do_step_is_an_error(unzipped: Path, case: str) -> None:
    t, h, message = BAD_DO_STEP[case]
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        before = fmu.getReal(VR_OUTPUTS)
        assert do_step(fmu, t, h) == FMI_ERROR
        assert message in logger.last()[2]
        assert fmu.getReal(VR_OUTPUTS) == before
        assert do_step(fmu, 0.0, 0.1) == FMI_OK


def test_the_largest_step_of_the_costliest_variant_takes_about_a_second(tmp_path: Path) -> None:
    """MAX_SUBSTEPS internal steps of prime-rudder (about 1.0 us each): well within 3 s."""
    names = get_model("prime-rudder").coefficient_names
    params = replace(
        make_params(),
        model="prime-rudder",
        coefficients=np.array([PRIME_GAINS.get(name, 0.0) for name in names]),
        covariance=None,
    )
    fmu_file = build_native_fmu(params, tmp_path / "prime.fmu")
    unzipped = Path(extract(fmu_file, unzipdir=tmp_path / "x"))
    with slave(unzipped) as fmu:
        fmu.setReal([VR_RUDDER], [0.1])
        started = time.perf_counter()
        assert do_step(fmu, 0.0, MAX_SUBSTEPS * MAX_STEP_S) == FMI_OK
        elapsed = time.perf_counter() - started
        assert all(math.isfinite(x) for x in fmu.getReal(VR_OUTPUTS))
        started = time.perf_counter()
        t = MAX_SUBSTEPS * MAX_STEP_S
        assert do_step(fmu, t, (MAX_SUBSTEPS + 1) * MAX_STEP_S) == FMI_ERROR
        refused = time.perf_counter() - started
    assert elapsed < 3.0, f"{elapsed:.2f} s for the largest step"  # measured 0.97 s
    assert refused < 0.1  # refused before any work


# Parameters outside their physical bounds, set before initialisation:
# (name, value, message).
BAD_PARAMETERS = {
    "negative length": ("length", -320.0, "'length' (vr 8) = -320 is outside [0.1"),
    "zero length": ("length", 0.0, "'length' (vr 8) = 0 is outside"),
    "length of 2 km": ("length", 2000.0, "= 2000 is outside [0.10000000000000001, 1000]"),
    "u0 beyond the divergence bound": ("u0", 1500.0, "= 1500 is outside [-1000, 1000]"),
    "r0 beyond the divergence bound": ("r0", -1001.0, "'r0' (vr 12) = -1001 is outside"),
    "x0 beyond the Earth": ("x0", 1e9, "'x0' (vr 13) = 1000000000 is outside"),
    "psi0 of 1e7 rad": ("psi0", 1e7, "'psi0' (vr 15) = 10000000 is outside"),
    "max_step zero": ("max_step", 0.0, "'max_step' (vr 9) = 0 is outside"),
}


@pytest.mark.parametrize("case", BAD_PARAMETERS)
def test_parameters_outside_their_bounds_are_refused_before_initialisation(
    unzipped: Path, params: ModelParameters, case: str
) -> None:
    name, value, message = BAD_PARAMETERS[case]
    variable = next(v for v in fmu_variables(params) if v.name == name)
    logger = LogRecorder()
    codes = []
    with slave(
        unzipped,
        logger=logger,
        before_init=lambda fmu: codes.append(set_real(fmu, [variable.value_reference], [value])),
    ) as fmu:
        assert codes == [FMI_ERROR]
        assert any(message in text for _, _, text in logger.messages), logger.messages
        assert fmu.getReal([variable.value_reference]) == [variable.start]  # unchanged
        assert do_step(fmu, 0.0, 0.1) == FMI_OK


# Byte offsets in the serialised state: magic (8), version (4), number of variables (4),
# GUID (64), FMI state (4), padding (4), then the doubles time, start_time,
# last_successful_time and the values by value reference.
SERIAL_TIME_OFFSET = 8 + 4 + 4 + 64 + 4 + 4
SERIAL_VALUES_OFFSET = SERIAL_TIME_OFFSET + 3 * 8
# What fmi2SetReal cannot set but a state carries: outputs and times. The values that
# fmi2SetReal refuses are checked in both backends (tests/test_fmu_parity.py).
BAD_SERIALISED_STATES = {
    "NaN surge velocity": (SERIAL_VALUES_OFFSET + 8 * 2, math.nan, "u must be finite, got nan"),
    "infinite heading": (SERIAL_VALUES_OFFSET + 8 * 7, -math.inf, "psi must be finite, got -inf"),
    "infinite time": (SERIAL_TIME_OFFSET, math.inf, "its times (inf, 0, 0.1 s) must be finite"),
    "NaN start time": (SERIAL_TIME_OFFSET + 8, math.nan, "its times (0.1, nan, 0.1 s)"),
    "rudder 1.5 rad": (SERIAL_VALUES_OFFSET, 1.5, "rudder_angle = 1.5 is outside [-0.785"),
}


@pytest.mark.parametrize("case", BAD_SERIALISED_STATES)
def test_a_serialised_state_with_a_value_no_fmu_could_have_is_refused(
    unzipped: Path, case: str
) -> None:
    offset, value, message = BAD_SERIALISED_STATES[case]
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        assert do_step(fmu, 0.0, 0.1) == FMI_OK
        everything = list(range(32))
        before = fmu.getReal(everything)
        serialized = bytearray(fmu.serializeFMUstate(fmu.getFMUstate()))
        struct.pack_into("=d", serialized, offset, value)
        with pytest.raises(FMICallException) as info:
            fmu.deSerializeFMUstate(bytes(serialized))
        assert info.value.status == FMI_ERROR
        code, category, text = logger.last()
        assert (code, category) == (FMI_ERROR, "logStatusError")
        assert text.startswith("fmi2DeSerializeFMUstate: the FMU state is not restored: ")
        assert message in text, text
        assert fmu.getReal(everything) == before
        assert do_step(fmu, 0.1, 0.1) == FMI_OK


def test_a_serialised_state_past_initialisation_with_a_singular_windage_is_refused(
    unzipped: Path, params: ModelParameters
) -> None:
    """(x_G m)^2 >= (m + m_y)(I_z + J_z) makes the wind's accelerations divide by zero:
    ExitInitializationMode refuses such a windage, and so does the restore of a state past
    it. In initialization mode the windage may still be corrected, so a state there is
    restored. The test ship has no windage: unit inertias, so the bound is 1 kg m."""
    vr = {v.name: v.value_reference for v in fmu_variables(params)}
    everything = list(range(len(vr)))
    offset = SERIAL_VALUES_OFFSET + 8 * vr["sway_yaw_coupling"]
    expected = (
        "fmi2DeSerializeFMUstate: the FMU state is not restored: "
        + WINDAGE_COUPLING_FORMAT % (1.0, 1.0)
    )
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        assert do_step(fmu, 0.0, 0.1) == FMI_OK
        for running in (True, False):  # step complete, then terminated
            if not running:
                fmu.terminate()
            before = fmu.getReal(everything)
            state = fmu.getFMUstate()
            serialized = bytearray(fmu.serializeFMUstate(state))
            fmu.freeFMUstate(state)
            assert struct.unpack_from("=d", serialized, offset)[0] == 0.0  # the layout
            struct.pack_into("=d", serialized, offset, 1.0)
            with pytest.raises(FMICallException) as info:
                fmu.deSerializeFMUstate(bytes(serialized))
            assert info.value.status == FMI_ERROR
            assert logger.last() == (FMI_ERROR, "logStatusError", expected)
            assert fmu.getReal(everything) == before  # the state is not restored
            if running:
                assert do_step(fmu, 0.1, 0.1) == FMI_OK  # it goes on

    md = read_model_description(unzipped)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(unzipped),
        modelIdentifier=md.coSimulation.modelIdentifier,
    )
    fmu.instantiate(callbacks=logger.callbacks)
    try:
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([vr["sway_yaw_coupling"]], [1.0])
        state = fmu.getFMUstate()
        restored = fmu.deSerializeFMUstate(fmu.serializeFMUstate(state))
        fmu.setFMUstate(restored)
        assert fmu.getReal([vr["sway_yaw_coupling"]]) == [1.0]
        assert status(fmu.exitInitializationMode) == FMI_ERROR  # refused here instead
        fmu.setReal([vr["sway_yaw_coupling"]], [0.5])
        fmu.exitInitializationMode()
        assert do_step(fmu, 0.0, 0.1) == FMI_OK
        fmu.freeFMUstate(state)
        fmu.freeFMUstate(restored)
    finally:
        fmu.freeInstance()


def test_diverging_state_discards_the_step(unzipped: Path, params: ModelParameters) -> None:
    """With a1 > 0, u' = a1 u^2 blows up within 1/(a1 u0) = 0.4 s."""
    logger = LogRecorder()

    def unstable(fmu: FMU2Slave) -> None:
        fmu.setReal([VR_COEFFICIENTS], [0.5])

    with slave(unzipped, logger=logger, before_init=unstable) as fmu:
        assert do_step(fmu, 0.0, 0.1) == FMI_OK
        before = fmu.getReal(VR_OUTPUTS)
        assert do_step(fmu, 0.1, 2.0) == FMI_DISCARD
        code, category, text = logger.last()
        assert (code, category) == (FMI_DISCARD, "logStatusDiscard")
        assert "diverged" in text
        assert fmu.getReal(VR_OUTPUTS) == before  # the state stays at the step's start
        last = c_double()
        fmu.fmi2GetRealStatus(fmu.component, fmi2LastSuccessfulTime, byref(last))
        assert last.value == pytest.approx(0.1)
        terminated = c_int()
        fmu.fmi2GetBooleanStatus(fmu.component, fmi2Terminated, byref(terminated))
        assert terminated.value == 1
        assert do_step(fmu, 0.1, 0.1) == FMI_ERROR  # not in state "step failed"
        assert "must not be called" in logger.last()[2]
        fmu.terminate()


UNSUPPORTED = {
    "fmi2CancelStep": lambda f: f.fmi2CancelStep(f.component),
    "fmi2SetRealInputDerivatives": lambda f: f.fmi2SetRealInputDerivatives(
        f.component, None, 0, None, None
    ),
    "fmi2GetRealOutputDerivatives": lambda f: f.fmi2GetRealOutputDerivatives(
        f.component, None, 0, None, None
    ),
}
# Model-exchange functions called on a co-simulation instance: not in its state machine.
NOT_IN_CO_SIMULATION = {
    "fmi2SetTime": lambda f: model_exchange(f, "fmi2SetTime", c_double(0.0)),
    "fmi2EnterEventMode": lambda f: model_exchange(f, "fmi2EnterEventMode"),
}


def model_exchange(fmu: FMU2Slave, function: str, *args: Any) -> int:
    """Call an exported model-exchange function, which FMU2Slave does not wrap."""
    exported = getattr(fmu.dll, function)
    exported.argtypes = [c_void_p, *(type(arg) for arg in args)]
    exported.restype = c_int
    return int(exported(fmu.component, *args))


@pytest.mark.parametrize("function", UNSUPPORTED)
def test_unsupported_functions_are_errors_with_a_message(unzipped: Path, function: str) -> None:
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        assert status(UNSUPPORTED[function], fmu) == FMI_ERROR
        assert logger.last()[2].startswith(f"{function} is not supported: ")


@pytest.mark.parametrize("function", NOT_IN_CO_SIMULATION)
def test_model_exchange_calls_on_a_co_simulation_instance_are_errors(
    unzipped: Path, function: str
) -> None:
    logger = LogRecorder()
    with slave(unzipped, logger=logger) as fmu:
        assert status(NOT_IN_CO_SIMULATION[function], fmu) == FMI_ERROR
        assert logger.last()[2] == f"{function} must not be called in state 'step complete'"


def test_instantiate_refuses_a_wrong_guid_and_an_unknown_type(unzipped: Path) -> None:
    md = read_model_description(unzipped)
    logger = LogRecorder()
    fmu = FMU2Slave(
        guid="{00000000-0000-0000-0000-000000000000}",
        unzipDirectory=str(unzipped),
        modelIdentifier=md.coSimulation.modelIdentifier,
    )
    with pytest.raises(Exception, match="Failed to instantiate"):
        fmu.instantiate(callbacks=logger.callbacks)
    assert "does not match" in logger.last()[2]
    component = fmu.fmi2Instantiate(b"x", 7, md.guid.encode(), b"", byref(logger.callbacks), 0, 0)
    assert component is None
    assert "unknown fmuType 7" in logger.last()[2]
    fmu.freeLibrary()


def test_logging_categories(unzipped: Path) -> None:
    logger = LogRecorder()
    with slave(unzipped, logger=logger, logging_on=True) as fmu:
        fmu.doStep(0.0, 0.1)
        assert (FMI_OK, "logAll") == logger.last()[:2]
        categories = (c_char_p * 1)(b"logStatusError")
        fmu.fmi2SetDebugLogging(fmu.component, 0, 1, categories)  # errors off
        count = len(logger.messages)
        assert set_real(fmu, [VR_RUDDER], [math.nan]) == FMI_ERROR
        assert len(logger.messages) == count
        fmu.doStep(0.1, 0.1)  # logAll is still on
        assert len(logger.messages) == count + 1 and logger.last()[1] == "logAll"
        fmu.fmi2SetDebugLogging(fmu.component, 1, 1, categories)  # errors on again
        bad = (c_char_p * 1)(b"logNoSuchThing")
        assert status(fmu.fmi2SetDebugLogging, fmu.component, 1, 1, bad) == FMI_ERROR
        assert "unknown log category 'logNoSuchThing'" in logger.last()[2]
        fmu.fmi2SetDebugLogging(fmu.component, 0, 0, None)  # everything off
        count = len(logger.messages)
        fmu.doStep(0.2, 0.1)
        assert set_real(fmu, [VR_RUDDER], [math.nan]) == FMI_ERROR
        assert len(logger.messages) == count


# --- a C host: two instances, state round trip, no leaks ------------------------------


@pytest.fixture(scope="module")
def host(tmp_path_factory: pytest.TempPathFactory) -> Path:
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler")
    exe = tmp_path_factory.mktemp("host") / "host"
    command = [compiler, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2"]
    command += ["-I", str(fmi_headers_dir()), str(HOST_SOURCE), "-o", str(exe), "-ldl", "-lm"]
    subprocess.run(command, check=True, capture_output=True, text=True)
    return exe


def _library(unzipped: Path) -> Path:
    return unzipped / "binaries" / "linux64" / "Test_Ship.so"


def test_c_host_two_instances_and_state_round_trip(host: Path, unzipped: Path) -> None:
    result = subprocess.run(
        [str(host), str(_library(unzipped)), "10000"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith("ok: 2 instances x 10000 steps")


def test_c_host_under_valgrind(host: Path, unzipped: Path) -> None:
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not installed")
    result = subprocess.run(
        [
            *(valgrind, "--leak-check=full", "--error-exitcode=3", "-q"),
            *(str(host), str(_library(unzipped)), "10000"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr


def test_fmi_layer_compiles_without_warnings(unzipped: Path, tmp_path: Path) -> None:
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler")
    sources = unzipped / "sources"
    for std in ("c99", "c11"):
        result = subprocess.run(
            [
                *(compiler, f"-std={std}", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2"),
                *("-shared", "-fPIC", "-I", str(fmi_headers_dir()), "-I", str(sources)),
                *(str(sources / LAYER_SOURCE), "-o", str(tmp_path / "x.so"), "-lm"),
            ],
            capture_output=True,
            text=True,
        )
        assert result.returncode == 0, result.stderr


# --- rebuild from sources/ with fmpy ------------------------------------------------


def test_fmpy_compile_rebuilds_the_binary_from_sources(fmu_path: Path, tmp_path: Path) -> None:
    fmpy_cli = Path(sys.executable).with_name("fmpy")
    if shutil.which("cmake") is None or not fmpy_cli.exists():
        pytest.skip("cmake or the fmpy command is not available")
    stripped = tmp_path / "Test_Ship.fmu"
    with zipfile.ZipFile(fmu_path) as source, zipfile.ZipFile(stripped, "w") as target:
        for item in source.infolist():
            if not item.filename.startswith("binaries/"):
                target.writestr(item, source.read(item))
    result = subprocess.run(
        [str(fmpy_cli), "compile", str(stripped)], capture_output=True, text=True, timeout=300
    )
    assert result.returncode == 0, result.stdout + result.stderr
    with zipfile.ZipFile(stripped) as archive:
        assert "binaries/linux64/Test_Ship.so" in archive.namelist()
    options = {"stop_time": 200.0, "step_size": 0.1, "start_values": {"rudder_angle": 0.3}}
    rebuilt = simulate_fmu(str(stripped), **options)
    original = simulate_fmu(str(fmu_path), **options)
    for name in ("u", "v", "r", "x", "y", "psi"):
        np.testing.assert_allclose(rebuilt[name], original[name], rtol=1e-12, atol=1e-12)


# --- build errors ---------------------------------------------------------------------


def test_build_errors_are_fmu_build_errors_and_write_nothing(tmp_path: Path) -> None:
    output = tmp_path / "out.fmu"
    theta = make_params().coefficients.copy()
    theta[3] = math.nan
    with pytest.raises(FmuBuildError, match=r"coefficients \['a4'\] are not finite"):
        build_native_fmu(make_params().with_vector(theta), output)
    with pytest.raises(FmuBuildError, match="max_step_s"):
        build_native_fmu(make_params(), output, max_step_s=0.0)
    with pytest.raises(FmuBuildError, match="C compiler '/nonexistent/cc' not found"):
        build_native_fmu(make_params(), output, cc="/nonexistent/cc")
    with pytest.raises(FmuBuildError, match=r"C compilation failed \(gcc\): .*nonexistent\.h"):
        build_native_fmu(make_params(), output, cc="gcc -include /nonexistent.h")
    assert list(tmp_path.iterdir()) == []


BAD_BUILDS: dict[str, tuple[dict[str, Any], str]] = {
    "escape sequence in the vessel name": (
        {"vessel_name": "tanker\x1b[31m"},
        r"vessel name 'tanker\\x1b\[31m': contains a control character U\+001B at character 7",
    ),
    "lone surrogate in the vessel name": (
        {"vessel_name": "\ud800x"},
        r"contains a lone surrogate U\+D800 at character 1; expected printable text",
    ),
    "newline in the vessel name": (
        {"vessel_name": "two\nlines"},
        r"contains a control character U\+000A at character 4",
    ),
    "bell in the identification method": (
        {"identification": {"method": "ekf\x07"}},
        r"fmiModelDescription description .* contains a control character U\+0007",
    ),
    "nominal propeller speed beyond the bound": (
        {"nominal_n_rps": 200.0},
        r"the start value of propeller_rpm = 12000\.0 is outside \[-6000\.0, 6000\.0\]",
    ),
    "length beyond the bound": (
        {"length_m": 2000.0},
        r"the start value of length = 2000\.0 is outside \[0\.1, 1000\.0\]",
    ),
    "nominal speed beyond the divergence bound": (
        {"nominal_speed_mps": 1500.0},
        r"the start value of u0 = 1500\.0 is outside \[-1000\.0, 1000\.0\]",
    ),
}


@pytest.mark.parametrize("case", BAD_BUILDS)
def test_an_fmu_that_could_not_be_used_is_never_written(tmp_path: Path, case: str) -> None:
    changes, message = BAD_BUILDS[case]
    spoilt = make_params(**changes)
    with pytest.raises(FmuBuildError, match=message) as info:
        build_native_fmu(spoilt, tmp_path / "ship.fmu")
    assert "\n" not in str(info.value)
    with pytest.raises(FmuBuildError, match=message):
        render_native_fmu(spoilt)
    assert list(tmp_path.iterdir()) == []


# --- build_fmu.py -----------------------------------------------------------------------


def test_cli_default_paths_build_a_reproducible_fmu(
    tmp_path: Path, params: ModelParameters, fmu_path: Path
) -> None:
    save_params(tmp_path / "build" / "params.json", params)
    result = subprocess.run(
        [sys.executable, str(ROOT / "build_fmu.py")],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    written = tmp_path / "build" / "Test_Ship.fmu"
    assert result.stdout.strip() == str(Path("build") / "Test_Ship.fmu")
    assert written.read_bytes() == fmu_path.read_bytes()  # same params: same bytes
    assert (tmp_path / "build" / "Test_Ship_OspModelDescription.xml").is_file()


def _params_doc(params: ModelParameters) -> dict[str, Any]:
    return params.to_json_dict()


def _wrong_version(doc: dict[str, Any]) -> None:
    doc["version"] = 99


def _missing_coefficient(doc: dict[str, Any]) -> None:
    del doc["coefficients"]["c3"]


def _nan_coefficient(doc: dict[str, Any]) -> None:
    doc["coefficients"]["b1"] = math.nan


def _asymmetric_covariance(doc: dict[str, Any]) -> None:
    doc["covariance"][0][1] = 1e-3


def _huge_coefficient(doc: dict[str, Any]) -> None:
    doc["coefficients"]["a1"] = -(10**400)


def _huge_covariance_entry(doc: dict[str, Any]) -> None:
    doc["covariance"][2][3] = 10**400


def _escape_in_vessel_name(doc: dict[str, Any]) -> None:
    doc["vessel"]["name"] = "tanker\x1b[31m"


def _lone_surrogate_in_vessel_name(doc: dict[str, Any]) -> None:
    doc["vessel"]["name"] = "\ud800x"  # json.dumps writes it as the escape \ud800


BAD_PARAMS = {
    "wrong version": (_wrong_version, "unsupported version 99"),
    "missing coefficient": (_missing_coefficient, "missing ['c3']"),
    "NaN coefficient": (_nan_coefficient, "coefficient b1 must be a finite number"),
    "non-symmetric covariance": (_asymmetric_covariance, "covariance is not symmetric"),
    "coefficient of 401 digits": (
        _huge_coefficient,
        "coefficient a1 must be a finite number, got an integer of 401 digits",
    ),
    "covariance entry of 401 digits": (
        _huge_covariance_entry,
        "covariance[2][3] must be a finite number, got an integer of 401 digits",
    ),
    "escape sequence in the vessel name": (
        _escape_in_vessel_name,
        "vessel.name contains a control character U+001B at character 7",
    ),
    "lone surrogate in the vessel name": (
        _lone_surrogate_in_vessel_name,
        "vessel.name contains a lone surrogate U+D800 at character 1",
    ),
}


@pytest.mark.parametrize("case", BAD_PARAMS)
def test_cli_bad_params_exit_1_with_one_line(
    case: str, tmp_path: Path, params: ModelParameters, capsys: pytest.CaptureFixture[str]
) -> None:
    spoil, message = BAD_PARAMS[case]
    doc = _params_doc(params)
    spoil(doc)
    path = tmp_path / "params.json"
    path.write_text(json.dumps(doc))  # NaN is written as the JSON extension token NaN
    output = tmp_path / "out" / "ship.fmu"
    code = build_fmu.main(["--params", str(path), "-o", str(output)])
    captured = capsys.readouterr()
    assert code == 1
    assert captured.out == ""
    assert captured.err.count("\n") == 1 and message in captured.err
    assert not output.exists() and not osp_sidecar_path(output).exists()


def test_cli_missing_compiler_exits_1(
    tmp_path: Path,
    params: ModelParameters,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    path = tmp_path / "params.json"
    save_params(path, params)
    monkeypatch.setenv("CC", "/nonexistent")
    output = tmp_path / "ship.fmu"
    assert build_fmu.main(["--params", str(path), "-o", str(output)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "C compiler '/nonexistent' not found ($CC)" in err
    assert not output.exists()


def test_cli_missing_params_file_and_usage_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert build_fmu.main(["--params", str(tmp_path / "none.json")]) == 1
    assert "file not found" in capsys.readouterr().err
    for argv in (["--backend", "fortran"], ["--max-step-s", "-1"], ["--no-such-option"]):
        with pytest.raises(SystemExit) as info:
            build_fmu.main(argv)
        assert info.value.code == 2


def test_host_program_interface_matches_fmu_variables(params: ModelParameters) -> None:
    """The C host hard-codes value references; they must be those of the interface."""
    names = [v.name for v in fmu_variables(params)]
    source = HOST_SOURCE.read_text()
    assert names[:16] == [
        "rudder_angle", "propeller_rpm", "u", "v", "r", "x", "y", "psi",
        "length", "max_step", "u0", "v0", "r0", "x0", "y0", "psi0",
    ]  # fmt: skip
    for macro, index in (("VR_RUDDER", 0), ("VR_RPM", 1), ("VR_MAX_STEP", 9), ("VR_U0", 10)):
        assert f"#define {macro} {index}u" in source
    assert VR_COEFFICIENTS == names.index("a1")
