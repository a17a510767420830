"""The pythonfmu backend: interface, numerics against fmu_model.simulate, status, FMU state."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import zipfile
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (
    FMU2Slave,
    fmi2FMUstate,
)
from fmpy.validation import validate_fmu

from fmu_model import ModelParameters, simulate
from fmu_model.errors import FmuBuildError
from fmu_model.export_pythonfmu import build_pythonfmu_fmu
from fmu_model.interface import RUDDER_LIMIT_RAD, fmu_variables
from tests.fmi_logging import LogRecorder
from tests.test_shape import COEFFICIENTS as PRIME_RUDDER_COEFFICIENTS

MAX_STEP_S = 0.05
FMI_DISCARD, FMI_ERROR = 2, 3

# A 100 m ship at 5 m/s and 2 rev/s, in straight-run equilibrium: a1 u0^2 + a9 n0^2 = 0.
# Positive rudder turns to starboard (c3 > 0); sway and yaw are damped (b1, c2 < 0).
COEFFICIENTS = {
    "a1": -0.01,
    "a2": -0.02,
    "a3": -5.0,
    "a4": -0.1,
    "a5": 0.3,
    "a6": 0.0,
    "a7": 0.0,
    "a8": 0.0,
    "a9": 0.0625,
    "b1": -0.5,
    "b2": 0.0,
    "b3": -0.05,
    "b4": -0.3,
    "c1": -0.001,
    "c2": -0.5,
    "c3": 0.01,
}
PARAMS = ModelParameters.from_vector(
    "shi2009",
    list(COEFFICIENTS.values()),
    length_m=100.0,
    vessel_name="test ship",
    nominal_speed_mps=5.0,
    nominal_n_rps=2.0,
)
VR = {v.name: v.value_reference for v in fmu_variables(PARAMS)}
OUTPUTS = [VR[name] for name in ("u", "v", "r", "x", "y", "psi")]


@pytest.fixture(scope="module")
def fmu_path(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_pythonfmu_fmu(
        PARAMS, tmp_path_factory.mktemp("fmu") / "ship.fmu", max_step_s=MAX_STEP_S
    )


@pytest.fixture(scope="module")
def unzipdir(fmu_path: Path) -> str:
    return str(extract(str(fmu_path)))


class Instance:
    """An fmpy FMU2Slave that records the FMU's log messages as (status, text)."""

    def __init__(self, fmu_path: Path, unzipdir: str, start: dict[str, float] | None = None):
        self.log = LogRecorder()
        md = read_model_description(str(fmu_path))
        self.slave = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipdir,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="ship",
        )
        self.slave.instantiate(callbacks=self.log.callbacks, loggingOn=True)
        self.slave.setupExperiment(startTime=0.0)
        for name, value in (start or {}).items():
            self.slave.setReal([VR[name]], [value])
        self.slave.enterInitializationMode()
        self.slave.exitInitializationMode()

    @property
    def messages(self) -> list[tuple[int, str]]:
        return [(status, text) for status, _, text in self.log.messages]

    def outputs(self) -> np.ndarray:
        return np.array(self.slave.getReal(OUTPUTS))

    def run(self, t: np.ndarray, rudder: np.ndarray, rpm: np.ndarray) -> np.ndarray:
        """Step over t with zero-order-hold inputs; states at t (first row: current)."""
        states = [self.outputs()]
        for k in range(t.size - 1):
            self.slave.setReal([VR["rudder_angle"], VR["propeller_rpm"]], [rudder[k], rpm[k]])
            self.slave.doStep(t[k], t[k + 1] - t[k])
            states.append(self.outputs())
        return np.array(states)

    def close(self) -> None:
        self.slave.terminate()
        self.slave.freeInstance()


@pytest.fixture
def instance(fmu_path: Path, unzipdir: str) -> Iterator[Instance]:
    inst = Instance(fmu_path, unzipdir)
    yield inst
    inst.close()


def manoeuvre(n_steps: int, seed: int = 7) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Irregular steps (many longer than MAX_STEP_S), varying rudder [rad] and rpm."""
    rng = np.random.default_rng(seed)
    steps = rng.choice([0.01, 0.037, 0.05, 0.1, 0.13, 0.3, 0.5, 1.0], size=n_steps)
    t = np.concatenate([[0.0], np.cumsum(steps)])
    rudder = np.radians(25.0) * np.sin(2 * np.pi * t / 40.0) + np.radians(5.0) * (t > 20.0)
    rpm = 120.0 + 15.0 * np.sin(2 * np.pi * t / 55.0)
    return t, rudder, rpm


def assert_close(actual: np.ndarray, expected: np.ndarray, rtol: float = 1e-12) -> None:
    """|actual - expected| <= rtol x (largest |expected| of the same state component)."""
    scale = np.max(np.abs(expected), axis=0)
    assert np.all(np.abs(actual - expected) <= rtol * scale), np.max(
        np.abs(actual - expected) / scale
    )


def test_fmpy_validation_finds_no_problems(fmu_path: Path) -> None:
    assert validate_fmu(str(fmu_path)) == []


def test_model_description_declares_the_shared_interface(fmu_path: Path) -> None:
    md = read_model_description(str(fmu_path))
    expected = fmu_variables(PARAMS)
    assert [v.name for v in md.modelVariables] == [v.name for v in expected]
    for got, want in zip(md.modelVariables, expected, strict=True):
        assert (got.valueReference, got.causality, got.variability) == (
            want.value_reference,
            want.causality,
            want.variability,
        )
        assert got.unit == want.unit and got.displayUnit == want.display_unit
        assert got.description == want.description
        if want.start is not None and want.name != "max_step":
            assert float(got.start) == want.start  # exact, not 16 digits
    assert float(md.modelVariables[VR["max_step"]].start) == MAX_STEP_S
    units = {u.name: u for u in md.unitDefinitions}
    (deg,) = units["rad"].displayUnits
    assert deg.name == "deg" and deg.factor == pytest.approx(180.0 / math.pi, rel=1e-15)
    assert units["rpm"].baseUnit.s == -1 and units["rpm"].baseUnit.factor == 1.0 / 60.0
    assert units["1/(m.s)"].baseUnit.m == -1 and units["1/(m.s)"].baseUnit.s == -1
    outputs = {u.variable.name for u in md.outputs}
    states = set("uvrxy") | {"psi"}
    assert outputs == states | {"sog", "cog"}  # and speed and course over ground
    derivatives = {f"der({name})" for name in states}
    assert {u.variable.name for u in md.derivatives} == derivatives
    assert {u.variable.name for u in md.initialUnknowns} == outputs | derivatives
    assert md.modelExchange is None  # pythonfmu: co-simulation only
    cs = md.coSimulation
    assert not cs.providesDirectionalDerivative
    assert cs.canGetAndSetFMUstate and cs.canSerializeFMUstate
    assert cs.canHandleVariableCommunicationStepSize


def test_irregular_steps_equal_the_python_model(instance: Instance) -> None:
    t, rudder, rpm = manoeuvre(400)
    got = instance.run(t, rudder, rpm)
    initial = [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    want = simulate(PARAMS, t, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    assert np.degrees(np.ptp(want[:, 5])) > 10.0  # the ship really manoeuvres
    assert_close(got, want)
    assert instance.messages == []


def test_coefficient_and_initial_state_parameters_act_before_initialisation(
    fmu_path: Path, unzipdir: str
) -> None:
    theta = PARAMS.to_vector().copy()
    theta[PARAMS.names.index("c3")] *= 2.0  # twice the rudder yaw moment
    changed = PARAMS.with_vector(theta)
    initial = [4.5, 0.1, 0.0, -20.0, 30.0, 0.4]
    start = {"c3": 2.0 * COEFFICIENTS["c3"]}
    start.update(zip(("u0", "v0", "r0", "x0", "y0", "psi0"), initial, strict=True))
    t, rudder, rpm = manoeuvre(150, seed=3)
    inst = Instance(fmu_path, unzipdir, start)
    try:
        got = inst.run(t, rudder, rpm)
    finally:
        inst.close()
    want = simulate(changed, t, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    base = simulate(PARAMS, t, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    np.testing.assert_array_equal(got[0], initial)
    assert_close(got, want)
    assert np.max(np.abs(want[:, 2] - base[:, 2])) > 1e-3  # c3 matters: the test could fail


def test_fixed_parameter_change_after_initialisation_is_ignored(instance: Instance) -> None:
    t, rudder, rpm = manoeuvre(40)
    instance.slave.setReal([VR["c3"]], [1.0])
    got = instance.run(t, rudder, rpm)
    want = simulate(
        PARAMS, t, rudder, rpm / 60.0, [5.0, 0, 0, 0, 0, 0], method="rk4", max_step_s=MAX_STEP_S
    )
    assert_close(got, want)
    assert instance.messages[0][0] == FMI_ERROR
    assert f"'c3' (vr {VR['c3']}) is a fixed parameter" in instance.messages[0][1]


def test_nan_input_gives_an_error_and_no_step(instance: Instance) -> None:
    instance.slave.setReal([VR["rudder_angle"]], [0.1])
    instance.slave.doStep(0.0, 1.0)
    before = instance.outputs()
    instance.slave.setReal([VR["rudder_angle"]], [math.nan])
    assert instance.messages == [(FMI_ERROR, "rudder_angle must be finite, got nan")]
    with pytest.raises(FMICallException) as failure:
        instance.slave.doStep(1.0, 1.0)
    assert failure.value.status == FMI_DISCARD
    np.testing.assert_array_equal(instance.outputs(), before)
    instance.slave.setReal([VR["rudder_angle"]], [0.1])  # a finite value clears the fault
    instance.slave.doStep(1.0, 1.0)
    assert np.all(np.isfinite(instance.outputs())) and instance.outputs()[3] > before[3]


def test_out_of_range_input_gives_an_error_and_no_step(instance: Instance) -> None:
    instance.slave.setReal([VR["rudder_angle"]], [math.radians(46.0)])  # max is 45 deg
    ((status, text),) = instance.messages
    assert status == FMI_ERROR and text.startswith("rudder_angle = 0.80285")
    assert text.endswith(f"is outside [{-RUDDER_LIMIT_RAD!r}, {RUDDER_LIMIT_RAD!r}]")
    with pytest.raises(FMICallException) as failure:
        instance.slave.doStep(0.0, 1.0)
    assert failure.value.status == FMI_DISCARD
    np.testing.assert_array_equal(instance.outputs(), [5.0, 0, 0, 0, 0, 0])
    instance.slave.setReal([VR["rudder_angle"]], [RUDDER_LIMIT_RAD])  # the bound is allowed
    instance.slave.doStep(0.0, 1.0)
    assert instance.outputs()[2] > 0.0  # turning to starboard


@pytest.mark.parametrize("step_s", [0.0, -0.1, math.nan])
def test_a_non_positive_step_is_refused(instance: Instance, step_s: float) -> None:
    with pytest.raises(FMICallException) as failure:
        instance.slave.doStep(0.0, step_s)
    assert failure.value.status == FMI_DISCARD
    assert instance.messages[-1] == (
        FMI_ERROR,
        f"fmi2DoStep: communicationStepSize must be positive and finite, got {step_s:g}",
    )
    np.testing.assert_array_equal(instance.outputs(), [5.0, 0, 0, 0, 0, 0])


def test_divergence_is_discarded_and_keeps_the_last_state(fmu_path: Path, unzipdir: str) -> None:
    inst = Instance(fmu_path, unzipdir, {"a1": 1.0})  # u' = u^2 + ...: blows up in 0.2 s
    try:
        inst.slave.doStep(0.0, 0.1)
        before = inst.outputs()
        saved = inst.slave.getFMUstate()
        with pytest.raises(FMICallException) as failure:
            inst.slave.doStep(0.1, 5.0)
        assert failure.value.status == FMI_DISCARD
        np.testing.assert_array_equal(inst.outputs(), before)
        assert inst.messages[-1][0] == FMI_DISCARD and "diverged" in inst.messages[-1][1]
        # As the native FMU's state "step failed": no further step until a state is restored.
        with pytest.raises(FMICallException):
            inst.slave.doStep(0.1, 0.01)
        assert inst.messages[-1] == (
            FMI_ERROR,
            "fmi2DoStep must not be called in state 'step failed'",
        )
        inst.slave.setFMUstate(saved)
        inst.slave.doStep(0.1, 0.01)
        assert inst.outputs()[0] > before[0]
        inst.slave.freeFMUstate(saved)
    finally:
        inst.close()


def test_state_restore_and_deserialisation_continue_identically(
    fmu_path: Path, unzipdir: str
) -> None:
    t, rudder, rpm = manoeuvre(120, seed=11)
    first, second = slice(0, 61), slice(60, None)
    a = Instance(fmu_path, unzipdir, {"c3": 0.02})  # the parameters are part of the state
    b = Instance(fmu_path, unzipdir)
    try:
        a.run(t[first], rudder[first], rpm[first])
        saved = a.slave.getFMUstate()
        reference = a.run(t[second], rudder[second], rpm[second])
        a.slave.setFMUstate(saved)
        again = a.run(t[second], rudder[second], rpm[second])
        np.testing.assert_array_equal(again, reference)

        copy = b.slave.deSerializeFMUstate(a.slave.serializeFMUstate(saved))
        b.slave.setFMUstate(copy)
        np.testing.assert_array_equal(b.run(t[second], rudder[second], rpm[second]), reference)
        a.slave.freeFMUstate(saved)
        b.slave.freeFMUstate(copy)
    finally:
        a.close()
        b.close()


# This project's run-time dependencies other than numpy: a host without them must do.
NOT_ON_THE_HOST = (
    "sympy",
    "scipy",
    "numba",
    "statsmodels",
    "filterpy",
    "matplotlib",
    "dask",
    "pyproj",
    "pynmea2",
    "tqdm",
)


def test_shipped_sources_run_in_a_fresh_python_with_numpy_only(
    fmu_path: Path, tmp_path: Path
) -> None:
    """The FMU's Python needs numpy only: every other dependency is made unimportable."""
    script = f"""
import importlib.abc, json, sys

class NotOnTheHost(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {NOT_ON_THE_HOST!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}} (not on this host)")
        return None

sys.meta_path.insert(0, NotOnTheHost())
from fmpy import extract, simulate_fmu
directory = extract({str(fmu_path)!r}, {str(tmp_path / "unzipped")!r})
result = simulate_fmu(directory, stop_time=20.0, output_interval=0.5,
                      start_values={{"rudder_angle": 0.3, "propeller_rpm": 110.0}})
print(json.dumps({{"module": sys.modules["fmu_model"].__file__,
                   "blocked": sorted(set({NOT_ON_THE_HOST!r}) & set(sys.modules)),
                   "last": [float(result[k][-1]) for k in ("u", "v", "r", "x", "y", "psi")]}}))
"""
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=tmp_path, capture_output=True, text=True, check=True
    )
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert Path(report["module"]).is_relative_to(tmp_path / "unzipped" / "resources")
    assert report["blocked"] == []
    t = np.arange(41) * 0.5
    want = simulate(
        PARAMS,
        t,
        np.full(41, 0.3),
        np.full(41, 110.0 / 60.0),
        [5.0, 0, 0, 0, 0, 0],
        method="rk4",
        max_step_s=MAX_STEP_S,
    )
    assert_close(np.array([report["last"]]), want[-1:])


def test_build_writes_atomically_and_rejects_a_bad_max_step(tmp_path: Path) -> None:
    target = tmp_path / "out" / "ship.fmu"
    target.parent.mkdir()
    target.write_text("old")
    for bad in (0.0, -1.0, 1e-7, math.nan):
        with pytest.raises(FmuBuildError, match=r"max_step_s must be a finite number >= 1e-06"):
            build_pythonfmu_fmu(PARAMS, target, max_step_s=bad)
    theta = PARAMS.to_vector().copy()
    theta[PARAMS.names.index("b2")] = math.inf
    with pytest.raises(FmuBuildError, match=r"coefficients \['b2'\] are not finite"):
        build_pythonfmu_fmu(PARAMS.with_vector(theta), target)
    assert target.read_text() == "old"
    assert build_pythonfmu_fmu(PARAMS, target) == target
    assert list(target.parent.iterdir()) == [target]
    with zipfile.ZipFile(target) as archive:
        names = set(archive.namelist())
        interface = json.loads(archive.read("resources/fmu_interface.json"))
    carried = ("__init__.py", "fmi_rules.py", "integrate.py", "envelope.py")
    runtime = {f"resources/fmu_model/{n}" for n in carried}
    assert {"modelDescription.xml", "resources/model_equations.py"} | runtime <= names
    assert {n for n in names if n.startswith("resources/fmu_model/")} == runtime
    starts = {v["name"]: v["start"] for v in interface["variables"]}
    assert {name: starts[name] for name in COEFFICIENTS} == COEFFICIENTS
    assert interface["envelope"] is None  # PARAMS record no logs' envelope


def test_a_model_family_runs_in_the_pythonfmu_backend_as_in_python(tmp_path: Path) -> None:
    gains = PRIME_RUDDER_COEFFICIENTS
    params = ModelParameters.from_vector(
        "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7]",
        list(gains.values()),
        length_m=100.0,
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    shared = ("rudder_angle", "propeller_rpm", "u", "v", "r", "x", "y", "psi")
    assert {n: VR[n] for n in shared} == {
        v.name: v.value_reference for v in fmu_variables(params) if v.name in shared
    }
    path = build_pythonfmu_fmu(params, tmp_path / "family.fmu", max_step_s=MAX_STEP_S)
    instance = Instance(path, str(extract(str(path))))
    try:
        t, rudder, rpm = manoeuvre(200)
        got = instance.run(t, rudder, rpm)
    finally:
        instance.close()
    initial = [5.0, 0.0, 0.0, 0.0, 0.0, 0.0]
    want = simulate(params, t, rudder, rpm / 60.0, initial, method="rk4", max_step_s=MAX_STEP_S)
    assert np.degrees(np.ptp(want[:, 5])) > 5.0
    assert_close(got, want)


BAD_BUILDS: dict[str, tuple[dict[str, Any], str]] = {
    "escape sequence in the vessel name": (
        {"vessel_name": "tanker\x1b[31m"},
        r"contains a control character U\+001B at character 7",
    ),
    "lone surrogate in the vessel name": (
        {"vessel_name": "\ud800x"},
        r"contains a lone surrogate U\+D800 at character 1",
    ),
    "nominal propeller speed beyond the bound": (
        {"nominal_n_rps": 200.0},
        r"the start value of propeller_rpm = 12000\.0 is outside \[-6000\.0, 6000\.0\]",
    ),
}


@pytest.mark.parametrize("case", BAD_BUILDS)
def test_an_fmu_that_could_not_be_used_is_never_written(tmp_path: Path, case: str) -> None:
    changes, message = BAD_BUILDS[case]
    with pytest.raises(FmuBuildError, match=message):
        build_pythonfmu_fmu(replace(PARAMS, **changes), tmp_path / "ship.fmu")
    assert list(tmp_path.iterdir()) == []


def _spoilt_state(instance: Instance, change: str) -> bytes:
    document = json.loads(instance.slave.serializeFMUstate(instance.slave.getFMUstate()))
    if change == "NaN yaw rate":
        document["state"][2] = math.nan
    elif change == "state of 5 components":
        document["state"].pop()
    elif change == "step_failed as text":
        document["step_failed"] = "no"
    elif change == "value of 400 digits":
        return json.dumps(document).replace('"values": [0.0', '"values": [1' + "0" * 400).encode()
    return json.dumps(document).encode()


RESTORE_REFUSALS = {
    "NaN yaw rate": "fmi2SetFMUstate: the FMU state is not restored: r must be finite, got nan",
    "state of 5 components": "fmi2SetFMUstate: not an FMU state of this FMU (wrong number",
    "step_failed as text": "fmi2SetFMUstate: not an FMU state of this FMU (malformed flags)",
    "value of 400 digits": "fmi2SetFMUstate: not an FMU state of this FMU (",
}


@pytest.mark.parametrize("change", RESTORE_REFUSALS)
def test_a_restored_state_is_refused_without_fmi2_fatal(instance: Instance, change: str) -> None:
    instance.slave.doStep(0.0, 1.0)
    before = instance.outputs()
    spoilt = _spoilt_state(instance, change)
    state = instance.slave.deSerializeFMUstate(spoilt, fmi2FMUstate())
    instance.slave.setFMUstate(state)  # fmi2OK: pythonfmu cannot refuse it without fmi2Fatal
    status, text = instance.messages[-1]
    assert status == FMI_ERROR and text.startswith(RESTORE_REFUSALS[change]), text
    np.testing.assert_array_equal(instance.outputs(), before)  # not restored
    with pytest.raises(FMICallException) as failure:
        instance.slave.doStep(1.0, 1.0)
    assert failure.value.status == FMI_DISCARD
    assert instance.messages[-1] == (FMI_ERROR, text)
    instance.slave.freeFMUstate(state)
