"""The two FMU backends follow one interface: the same modelIdentifier, divergence rule,
step rules, start rule, restored-state check and statuses.

Each case builds the native C FMU and the pythonfmu FMU from the same parameter set and
drives both through fmpy's low-level calls. Where pythonfmu cannot return a status the
native FMU gives (``fmi2Error`` from ``fmi2DoStep``, ``fmi2ExitInitializationMode`` or
``fmi2SetFMUstate``), it logs the same message with status ``fmi2Error`` and refuses the
following steps with ``fmi2Discard`` (DESIGN.md "FMU interface").
"""

from __future__ import annotations

import json
import math
import re
import struct
import zipfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from ctypes import byref, c_char_p, c_double, c_int
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave, fmi2FMUstate

from fmu_model import ModelParameters
from fmu_model.export_native import build_native_fmu, render_native_fmu
from fmu_model.export_pythonfmu import build_pythonfmu_fmu
from fmu_model.interface import (
    DIVERGENCE_FORMAT,
    MAX_SPEED_MPS,
    MAX_SUBSTEPS,
    MAX_YAW_RATE_RADPS,
    MIN_START_SPEED_MPS,
    START_SPEED_FORMAT,
    SUBSTEP_LIMIT_FORMAT,
    TIME_STALL_FORMAT,
    fmu_variables,
    min_start_speed_mps,
    model_identifier,
    state_diverged,
)
from tests.fmi_logging import LogRecorder
from tests.test_fmu_pythonfmu import MAX_STEP_S, OUTPUTS, PARAMS, VR
from tests.test_shape import COEFFICIENTS as PRIME_RUDDER_COEFFICIENTS

FMI_OK, FMI_DISCARD, FMI_ERROR = 0, 2, 3
BACKENDS = {"native": build_native_fmu, "pythonfmu": build_pythonfmu_fmu}
# The message of DIVERGENCE_FORMAT, numbers matched loosely.
DIVERGENCE_PATTERN = (
    re.escape("fmi2DoStep: " + DIVERGENCE_FORMAT).replace("%\\.9g", "%g").replace("%g", r"\S+")
)


@pytest.fixture(scope="module")
def unzipped(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Both backends' FMUs of PARAMS, extracted, by backend name."""
    folders = {}
    for backend, build in BACKENDS.items():
        tmp = tmp_path_factory.mktemp(backend)
        folders[backend] = Path(extract(str(build(PARAMS, tmp / "ship.fmu")), str(tmp / "x")))
    return folders


@contextmanager
def instantiated(
    unzipped: Path, start: dict[str, float], start_time: float = 0.0
) -> Iterator[tuple[FMU2Slave, LogRecorder]]:
    """An FMU instance in initialization mode, ``start`` values set, and its log."""
    md = read_model_description(str(unzipped))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=str(unzipped),
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="parity",
    )
    log = LogRecorder()
    fmu.instantiate(callbacks=log.callbacks, loggingOn=True)  # pythonfmu logs only then
    try:
        fmu.setupExperiment(startTime=start_time)
        for name, value in start.items():
            fmu.setReal([vr[name]], [value])
        fmu.enterInitializationMode()
        yield fmu, log
    finally:
        fmu.freeInstance()


@contextmanager
def initialised(
    unzipped: Path, start: dict[str, float], start_time: float = 0.0
) -> Iterator[tuple[FMU2Slave, LogRecorder]]:
    """An FMU instance with ``start`` values set before initialisation, and its log."""
    with instantiated(unzipped, start, start_time) as (fmu, log):
        fmu.exitInitializationMode()
        yield fmu, log


def status(call: Callable[[], object]) -> int:
    """The FMI status of a call (fmpy raises for statuses above fmi2Warning)."""
    try:
        call()
    except FMICallException as exc:
        return int(exc.status)
    return FMI_OK


# --- modelIdentifier ------------------------------------------------------------------

AWKWARD_NAMES = {
    "leading digit": ("2nd ship", "ship_2nd_ship"),
    "spaces and punctuation": ("  Test  Ship (model scale) ", "Test_Ship_model_scale"),
    "non-ASCII letters": ("Ålesund/ø Fjord", "lesund_Fjord"),
    "empty after sanitising": ("東京丸 --", "ship"),
}


@pytest.mark.parametrize("case", AWKWARD_NAMES)
def test_both_backends_derive_the_same_model_identifier(case: str, tmp_path: Path) -> None:
    name, expected = AWKWARD_NAMES[case]
    params = replace(PARAMS, vessel_name=name)
    native = render_native_fmu(params)
    built = build_pythonfmu_fmu(params, tmp_path / "ship.fmu")
    md = read_model_description(str(built))
    assert native.model_identifier == md.coSimulation.modelIdentifier == expected
    assert f'modelIdentifier="{expected}"' in native.model_description
    assert md.modelName == name  # the vessel name itself stays the modelName
    with zipfile.ZipFile(built) as archive:
        assert f"binaries/linux64/{expected}.so" in archive.namelist()
    assert re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", expected)
    assert model_identifier(expected) == expected  # stable under re-application


# --- divergence -----------------------------------------------------------------------

# With no coefficients the velocities u, v, r keep their start values; only x, y, psi move.
NO_FORCES = dict.fromkeys(PARAMS.names, 0.0)
DIVERGING = {
    # u' = a1 u^2 + ... with a1 > 0: u grows without bound within 1/(a1 u0) = 0.2 s.
    "unstable surge": ({"a1": 1.0}, 5.0),
    # Starting on the bound (the largest start allowed), with one linear term of rate
    # 100/s: finite, but beyond the bound after the first internal step (RK4 grows it by
    # a factor 65 over 0.05 s).
    "surge beyond the bound": ({**NO_FORCES, "a8": 50.0, "u0": MAX_SPEED_MPS}, 0.1),  # u n
    "sway beyond the bound": ({**NO_FORCES, "b1": 100.0, "v0": -MAX_SPEED_MPS}, 0.1),
    "yaw rate beyond the bound": ({**NO_FORCES, "c2": 100.0, "r0": MAX_YAW_RATE_RADPS}, 0.1),
}


def _problems(log: LogRecorder) -> list[str]:
    """The messages logged with a status other than fmi2OK (not the trace)."""
    return [text for code, _, text in log.messages if code != FMI_OK]


def _diverge(unzipped: Path, start: dict[str, float], step_s: float) -> tuple[int, str, int, str]:
    """(status, message) of the diverging step and of the step after it."""
    with initialised(unzipped, start) as (fmu, log):
        before = fmu.getReal(OUTPUTS)
        first = status(lambda: fmu.doStep(0.0, step_s))
        (first_message,) = _problems(log)
        assert fmu.getReal(OUTPUTS) == before  # the state stays at the start of the step
        second = status(lambda: fmu.doStep(0.0, step_s))
        return first, first_message, second, _problems(log)[-1]


@pytest.mark.parametrize("case", DIVERGING)
def test_both_backends_discard_a_diverging_step_with_the_same_message(
    case: str, unzipped: dict[str, Path]
) -> None:
    start, step_s = DIVERGING[case]
    native = _diverge(unzipped["native"], start, step_s)
    python = _diverge(unzipped["pythonfmu"], start, step_s)
    assert native[0] == python[0] == FMI_DISCARD
    assert native[1] == python[1]
    assert re.fullmatch(DIVERGENCE_PATTERN, native[1]), native[1]
    # Then the state "step failed": native fmi2Error, pythonfmu (which cannot) fmi2Discard.
    assert (native[2], python[2]) == (FMI_ERROR, FMI_DISCARD)
    assert native[3].endswith("must not be called in state 'step failed'")
    assert python[3].endswith("must not be called in state 'step failed'")


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_state_just_inside_the_bounds_steps_on(backend: str, unzipped: dict[str, Path]) -> None:
    start = {**NO_FORCES, "u0": MAX_SPEED_MPS, "v0": -MAX_SPEED_MPS, "r0": MAX_YAW_RATE_RADPS}
    with initialised(unzipped[backend], start) as (fmu, log):
        assert status(lambda: fmu.doStep(0.0, 0.1)) == FMI_OK, _problems(log)
        u, v, r = fmu.getReal(OUTPUTS[:3])
    assert (u, v, r) == (MAX_SPEED_MPS, -MAX_SPEED_MPS, MAX_YAW_RATE_RADPS)


def test_the_python_divergence_rule_is_the_documented_one() -> None:
    ship = np.array([5.0, 0.5, 0.01, 1e9, -1e9, 1e3])  # far away is no divergence
    assert not state_diverged(ship)
    for k, bound in ((0, MAX_SPEED_MPS), (1, MAX_SPEED_MPS), (2, MAX_YAW_RATE_RADPS)):
        for sign in (1.0, -1.0):
            state = ship.copy()
            state[k] = sign * bound
            assert not state_diverged(state)
            state[k] = sign * math.nextafter(bound, math.inf)
            assert state_diverged(state)
    for k in range(6):
        for bad in (math.nan, math.inf):
            state = ship.copy()
            state[k] = bad
            assert state_diverged(state)


# --- restored FMU states: checked like fmi2SetReal ------------------------------------

# Byte offset of the values in the native serialised state: magic (8), version (4),
# number of variables (4), GUID (64), FMI state (4), padding (4), three times (3 x 8).
NATIVE_VALUES_OFFSET = 8 + 4 + 4 + 64 + 4 + 4 + 3 * 8
# A value that fmi2SetReal refuses, put into a saved state: (variable, value, message).
BAD_STATES = {
    "rudder 1.5 rad": ("rudder_angle", 1.5, "rudder_angle = 1.5 is outside [-0.785398"),
    "rudder 1e300 rad": ("rudder_angle", 1e300, "rudder_angle = 1.0000000000000001e+300 is"),
    "max_step -1": ("max_step", -1.0, "max_step = -1 is outside [9.9999999999999995e-07, inf]"),
    "length 0": ("length", 0.0, "length = 0 is outside [0.10000000000000001, 1000]"),
    "propeller 1e9 rpm": ("propeller_rpm", 1e9, "propeller_rpm = 1000000000 is outside"),
    "NaN coefficient": ("a1", math.nan, "a1 must be finite, got nan"),
    "infinite initial heading": ("psi0", math.inf, "psi0 must be finite, got inf"),
}


def _spoil(backend: str, serialized: bytes, name: str, value: float) -> bytes:
    """The serialised state with the value of variable ``name`` replaced by ``value``."""
    if backend == "native":
        data = bytearray(serialized)
        offset = NATIVE_VALUES_OFFSET + 8 * VR[name]
        assert struct.unpack_from("=d", data, offset)[0] == PARAMS_START[name]  # the layout
        struct.pack_into("=d", data, offset, value)
        return bytes(data)
    document = json.loads(serialized)  # the pythonfmu slave serialises its state as JSON
    document["values"][VR[name]] = value
    return json.dumps(document).encode()


PARAMS_START = {v.name: v.start for v in fmu_variables(PARAMS)}
PARAMS_START["rudder_angle"] = 0.1  # set in the test before the state is saved


def _restore(backend: str, fmu: FMU2Slave, serialized: bytes) -> int:
    """Status of restoring a serialised state: de-serialise, then (if that passed) set."""
    state = fmi2FMUstate()
    code = status(lambda: fmu.deSerializeFMUstate(serialized, state))
    if code == FMI_OK:
        code = status(lambda: fmu.setFMUstate(state))
        fmu.freeFMUstate(state)
    return code


@pytest.mark.parametrize("case", BAD_STATES)
def test_both_backends_refuse_a_restored_state_with_a_value_set_real_refuses(
    case: str, unzipped: dict[str, Path]
) -> None:
    name, value, message = BAD_STATES[case]
    refusals = {}
    for backend, folder in unzipped.items():
        with initialised(folder, {}) as (fmu, log):
            fmu.setReal([VR["rudder_angle"]], [0.1])
            fmu.doStep(0.0, 0.5)
            everything = list(range(len(VR)))
            before = fmu.getReal(everything)
            saved = fmu.getFMUstate()
            spoilt = _spoil(backend, fmu.serializeFMUstate(saved), name, value)
            code = _restore(backend, fmu, spoilt)
            refusal = _problems(log)[-1]
            assert log.messages[-1][0] == FMI_ERROR
            assert fmu.getReal(everything) == before  # the state is not restored
            if backend == "native":
                assert code == FMI_ERROR
                assert refusal.startswith("fmi2DeSerializeFMUstate: the FMU state is not")
                assert status(lambda: fmu.doStep(0.5, 0.5)) == FMI_OK  # it goes on
            else:  # pythonfmu turns an exception into fmi2Fatal: it cannot refuse the call
                assert code == FMI_OK
                assert refusal.startswith("fmi2SetFMUstate: the FMU state is not restored: ")
                assert status(lambda: fmu.doStep(0.5, 0.5)) == FMI_DISCARD  # ... but steps
                assert _problems(log)[-1] == refusal
                fmu.setFMUstate(saved)  # a valid state lifts the refusal
                assert status(lambda: fmu.doStep(0.5, 0.5)) == FMI_OK
            fmu.freeFMUstate(saved)
        refusals[backend] = refusal.split(": the FMU state is not restored: ")[1]
    assert refusals["native"] == refusals["pythonfmu"]
    assert refusals["native"].startswith(message), refusals["native"]


def test_pythonfmu_refuses_an_unreadable_state_without_fmi2_fatal(
    unzipped: dict[str, Path],
) -> None:
    """pythonfmu makes an exception fmi2Fatal: the slave must not raise on bad bytes."""
    with initialised(unzipped["pythonfmu"], {}) as (fmu, log):
        before = fmu.getReal(OUTPUTS)
        for spoilt in (b"{not json", b"[1, 2]", b'{"values": "x"}', b"\xff\xfe"):
            assert _restore("pythonfmu", fmu, spoilt) == FMI_OK
            assert _problems(log)[-1].startswith("fmi2SetFMUstate: not an FMU state of this FMU")
            assert fmu.getReal(OUTPUTS) == before
            assert status(lambda: fmu.doStep(0.0, 0.1)) == FMI_DISCARD


# --- the least start speed of a model that divides by the speed ----------------------

PRIME = ModelParameters.from_vector(
    "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7,wake=0.35,dwake=0.25]",
    list(PRIME_RUDDER_COEFFICIENTS.values()),
    length_m=100.0,
    vessel_name="prime ship",
    nominal_speed_mps=5.0,
    nominal_n_rps=2.0,
)


@pytest.fixture(scope="module")
def prime_unzipped(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Both backends' FMUs of PRIME (speed-scaled: v/U, rL/U), extracted."""
    folders = {}
    for backend, build in BACKENDS.items():
        tmp = tmp_path_factory.mktemp(f"prime-{backend}")
        folders[backend] = Path(extract(str(build(PRIME, tmp / "prime.fmu")), str(tmp / "x")))
    return folders


def test_the_least_start_speed_belongs_to_models_that_divide_by_the_speed() -> None:
    assert min_start_speed_mps(PRIME.structure) == MIN_START_SPEED_MPS == 1e-3
    assert min_start_speed_mps(PARAMS.structure) == 0.0  # shi2009 is a polynomial
    u0 = next(v for v in fmu_variables(PRIME) if v.name == "u0")
    assert "sqrt(u0^2 + v0^2) must be >= 0.001 m/s" in u0.description


REFUSED_STARTS = {"at rest": (0.0, 0.0), "just below": (0.999e-3, 0.0), "drifting": (0.0, -5e-4)}


@pytest.mark.parametrize("case", REFUSED_STARTS)
def test_both_backends_refuse_a_start_below_the_least_speed(
    case: str, prime_unzipped: dict[str, Path]
) -> None:
    u0, v0 = REFUSED_STARTS[case]
    expected = "fmi2ExitInitializationMode: " + START_SPEED_FORMAT % (
        math.hypot(u0, v0),
        MIN_START_SPEED_MPS,
    )
    with instantiated(prime_unzipped["native"], {"u0": u0, "v0": v0}) as (fmu, log):
        assert status(fmu.exitInitializationMode) == FMI_ERROR
        assert _problems(log) == [expected]
        fmu.setReal([VR["u0"]], [5.0])  # still in initialization mode: correct and go on
        fmu.exitInitializationMode()
        assert status(lambda: fmu.doStep(0.0, 0.1)) == FMI_OK
    with instantiated(prime_unzipped["pythonfmu"], {"u0": u0, "v0": v0}) as (fmu, log):
        assert status(fmu.exitInitializationMode) == FMI_OK  # an exception would be fatal
        assert _problems(log) == [expected]
        assert log.messages[-1][0] == FMI_ERROR
        assert status(lambda: fmu.doStep(0.0, 0.1)) == FMI_DISCARD
        assert _problems(log)[-1] == expected


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("start", [(1e-3, 0.0), (0.0, 2e-3), (5.0, 0.0)])
def test_both_backends_start_at_or_above_the_least_speed(
    backend: str, start: tuple[float, float], prime_unzipped: dict[str, Path]
) -> None:
    with initialised(prime_unzipped[backend], {"u0": start[0], "v0": start[1]}) as (fmu, log):
        assert status(lambda: fmu.doStep(0.0, 1.0)) == FMI_OK, _problems(log)
        assert all(math.isfinite(x) for x in fmu.getReal(OUTPUTS))
        assert _problems(log) == []


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_polynomial_model_starts_from_rest(backend: str, unzipped: dict[str, Path]) -> None:
    with initialised(unzipped[backend], {"u0": 0.0}) as (fmu, log):
        assert status(lambda: fmu.doStep(0.0, 10.0)) == FMI_OK, _problems(log)
        assert 0.0 < fmu.getReal([VR["u"]])[0] < 5.0  # the propeller speeds it up


# --- steps the FMU refuses: too many internal steps, no advance of time ---------------

REFUSED_STEPS: dict[str, tuple[float, float, str]] = {
    # (start time [s], step h [s], message)
    "one internal step more than the limit": (
        0.0,
        (MAX_SUBSTEPS + 1) * MAX_STEP_S,
        "fmi2DoStep: "
        + SUBSTEP_LIMIT_FORMAT
        % ((MAX_SUBSTEPS + 1) * MAX_STEP_S, MAX_SUBSTEPS + 1, MAX_STEP_S, MAX_SUBSTEPS),
    ),
    "a day in one step": (
        0.0,
        86400.0,
        "fmi2DoStep: " + SUBSTEP_LIMIT_FORMAT % (86400, 1.728e6, 0.05, 1e6),
    ),
    "1e9 s": (
        0.0,
        1e9,
        "fmi2DoStep: " + SUBSTEP_LIMIT_FORMAT % (1e9, 2e10, MAX_STEP_S, MAX_SUBSTEPS),
    ),
    "start time 1e300": (1e300, 0.1, "fmi2DoStep: " + TIME_STALL_FORMAT % (0.1, 1e300)),
    "start time 1e17, step 1 s": (
        1e17,
        1.0,
        "fmi2DoStep: " + TIME_STALL_FORMAT % (1.0, 1e17),
    ),
}


@pytest.mark.parametrize("case", REFUSED_STEPS)
def test_both_backends_refuse_the_same_steps_with_the_same_message(
    case: str, unzipped: dict[str, Path]
) -> None:
    start_time, step_s, message = REFUSED_STEPS[case]
    codes = {}
    for backend, folder in unzipped.items():
        with initialised(folder, {}, start_time) as (fmu, log):
            before = fmu.getReal(OUTPUTS)
            codes[backend] = status(lambda: fmu.doStep(start_time, step_s))
            assert _problems(log) == [message]
            assert log.messages[-1][0] == FMI_ERROR
            assert fmu.getReal(OUTPUTS) == before
            if start_time < 1e300:  # a step that does advance goes on (and 32 s does at 1e17)
                assert status(lambda: fmu.doStep(start_time, 32.0)) == FMI_OK
    # pythonfmu cannot return fmi2Error from fmi2DoStep: fmi2Discard, same message.
    assert codes == {"native": FMI_ERROR, "pythonfmu": FMI_DISCARD}


def test_the_largest_step_is_accepted(unzipped: dict[str, Path]) -> None:
    """Exactly MAX_SUBSTEPS internal steps: native only (pythonfmu would take minutes)."""
    with initialised(unzipped["native"], {}) as (fmu, log):
        assert status(lambda: fmu.doStep(0.0, MAX_SUBSTEPS * MAX_STEP_S)) == FMI_OK
        assert _problems(log) == []


# --- statuses the FMU cannot give: fmi2Discard (FMI 2.0 section 2.1.3) ---------------

# fmi2StatusKind: fmi2DoStepStatus 0, fmi2PendingStatus 1, fmi2LastSuccessfulTime 2,
# fmi2Terminated 3.
STATUS_QUERIES: dict[str, Callable[[FMU2Slave], Any]] = {
    "fmi2GetStatus": lambda f: f.fmi2GetStatus(f.component, 0, byref(c_int())),
    "fmi2GetIntegerStatus": lambda f: f.fmi2GetIntegerStatus(f.component, 1, byref(c_int())),
    "fmi2GetStringStatus": lambda f: f.fmi2GetStringStatus(f.component, 1, byref(c_char_p())),
    "fmi2GetRealStatus of fmi2DoStepStatus": lambda f: f.fmi2GetRealStatus(
        f.component, 0, byref(c_double())
    ),
    "fmi2GetRealStatus of fmi2Terminated": lambda f: f.fmi2GetRealStatus(
        f.component, 3, byref(c_double())
    ),
    "fmi2GetBooleanStatus of fmi2DoStepStatus": lambda f: f.fmi2GetBooleanStatus(
        f.component, 0, byref(c_int())
    ),
    "fmi2GetBooleanStatus of fmi2LastSuccessfulTime": lambda f: f.fmi2GetBooleanStatus(
        f.component, 2, byref(c_int())
    ),
}


# pythonfmu's wrapper logs these queries with a NULL category, which the recorder of
# tests/fmi_logging.py cannot decode (a warning in the ctypes callback, nothing else).
_NULL_CATEGORY = pytest.mark.filterwarnings(
    "ignore:Exception ignored on calling ctypes callback:pytest.PytestUnraisableExceptionWarning"
)


@pytest.mark.parametrize("backend", ["native", pytest.param("pythonfmu", marks=_NULL_CATEGORY)])
@pytest.mark.parametrize("query", STATUS_QUERIES)
def test_a_status_the_fmu_cannot_give_is_discard(
    backend: str, query: str, unzipped: dict[str, Path]
) -> None:
    with initialised(unzipped[backend], {}) as (fmu, log):
        fmu.doStep(0.0, 0.1)
        code = status(lambda: STATUS_QUERIES[query](fmu))
        if backend == "pythonfmu" and query == "fmi2GetStatus":
            # pythonfmu 0.7's compiled wrapper answers fmi2GetStatus itself, with fmi2Error
            # and no message; the slave cannot change it.
            assert code == FMI_ERROR
            return
        assert code == FMI_DISCARD
        if backend == "native":
            assert log.messages[-1][:2] == (FMI_DISCARD, "logStatusDiscard")
            assert log.messages[-1][2].startswith(query.split()[0] + ": ")
        # The statuses it can give still work, and the instance goes on.
        assert fmu.getRealStatus(kind=2) == pytest.approx(0.1)  # fmi2LastSuccessfulTime
        assert fmu.getBooleanStatus(kind=3) is False  # fmi2Terminated
        assert status(lambda: fmu.doStep(0.1, 0.1)) == FMI_OK
