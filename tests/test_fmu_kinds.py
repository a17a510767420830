"""The native FMU in every kind: FMI 2.0 and 3.0, co-simulation and model exchange.

Each kind is checked against the Python model (``fmu_model.simulate``), its directional
derivatives against finite differences of its own derivatives, its description with
fmpy's validation and fmu-manipulation-toolbox's checker, and it is run by a second,
independent master (ecos, through ecospy). Model exchange, integrated by fmpy's CVode and
forward Euler, sails the 35° turn and the 10°/10° zig-zag through the programme runner
with the Python model's advance, transfer and tactical diameter within 0.1 % and its
overshoots within 0.05°.
"""

from __future__ import annotations

import ctypes
import os
import stat
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Model
from fmpy.fmi3 import FMU3Model
from fmpy.simulation import ForwardEuler
from fmpy.sundials import CVodeSolver
from fmpy.validation import validate_fmu

from fmu_model import ModelParameters, simulate
from fmu_model.export_native import build_native_fmu
from fmu_model.interface import fmu_variables
from tests.test_fmu_native import N_RPS, SPEED_MPS, make_params
from trials.maneuvers import DEFAULT_RUDDER_RATE_DEG_S, turning_circle, zigzag
from trials.metrics import TurningMetrics, ZigzagMetrics, turning_metrics, zigzag_metrics
from trials.run import ModelPlant, SingleShip, run_program

KINDS = {"cs": ("cs",), "me": ("me",), "both": ("cs", "me")}
STATES = ("u", "v", "r", "x", "y", "psi")
RUDDER_RAD = np.radians(35.0)
TURN_S = 300.0


@pytest.fixture(scope="module")
def params() -> ModelParameters:
    return make_params()


@pytest.fixture(scope="module")
def build(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> Any:
    """build(fmi_version, kind) -> the FMU, built once per module."""
    folder = tmp_path_factory.mktemp("kinds")
    built: dict[tuple[str, str], Path] = {}

    def get(version: str, kind: str) -> Path:
        if (version, kind) not in built:
            path = folder / f"fmi{version}_{kind}" / "Test_Ship.fmu"
            built[version, kind] = build_native_fmu(
                params, path, fmi_version=version, kinds=KINDS[kind]
            )
        return built[version, kind]

    return get


@pytest.mark.parametrize("version", ["2", "3"])
@pytest.mark.parametrize("kind", list(KINDS))
def test_every_kind_is_valid_for_fmpy_and_fmu_manipulation_toolbox(
    build: Any, version: str, kind: str
) -> None:
    fmu = build(version, kind)
    assert validate_fmu(str(fmu)) == []
    md = read_model_description(str(fmu))
    assert md.fmiVersion == f"{version}.0"
    assert (md.coSimulation is not None, md.modelExchange is not None) == (
        "cs" in KINDS[kind],
        "me" in KINDS[kind],
    )
    fmutool = Path(sys.executable).with_name("fmutool")
    done = subprocess.run(
        [str(fmutool), "-input", str(fmu), "-check"], capture_output=True, text=True, timeout=120
    )
    report = done.stdout + done.stderr
    assert done.returncode == 0, report
    assert f"compliant with FMI-{version}.0" in report, report
    assert f"No semantic error against the FMI-{version} standard" in report, report


# --- the 35 deg turn against the Python model -----------------------------------------


@pytest.fixture(scope="module")
def reference(params: ModelParameters) -> np.ndarray:
    """The Python model's turn, RK4 at 0.05 s, sampled every 0.1 s: (N, 6)."""
    t = np.arange(0.0, TURN_S + 1e-9, 0.1)
    n_rps = np.full(t.size, params.nominal_n_rps)
    start = [params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0]
    return simulate(params, t, np.full(t.size, RUDDER_RAD), n_rps, start, max_step_s=0.05)


def _turn(fmu: Path, fmi_type: str, interval_s: float = 0.1, **options: Any) -> np.ndarray:
    """The turn every 0.1 s, simulated with output (and Euler) steps of ``interval_s``."""
    result = simulate_fmu(
        str(fmu),
        fmi_type=fmi_type,
        stop_time=TURN_S,
        output_interval=interval_s,
        start_values={"rudder_angle": RUDDER_RAD},
        output=list(STATES),
        **options,
    )
    every = round(0.1 / interval_s)
    return np.column_stack([result[name] for name in STATES])[::every]


def _errors(got: np.ndarray, want: np.ndarray) -> tuple[float, float]:
    """Largest position error relative to the turn's extent, largest heading error [deg]."""
    extent = np.ptp(want[:, 3:5])
    position = float(np.max(np.abs(got[:, 3:5] - want[:, 3:5])) / extent)
    return position, float(np.degrees(np.max(np.abs(got[:, 5] - want[:, 5]))))


@pytest.mark.parametrize("version", ["2", "3"])
def test_co_simulation_equals_the_python_model(
    build: Any, reference: np.ndarray, version: str
) -> None:
    got = _turn(build(version, "both"), "CoSimulation")
    scale = np.max(np.abs(reference), axis=0)
    assert np.all(np.abs(got - reference) <= 1e-12 * np.maximum(scale, 1.0))


@pytest.mark.parametrize("version", ["2", "3"])
def test_model_exchange_with_cvode_follows_the_python_model(
    build: Any, reference: np.ndarray, version: str
) -> None:
    got = _turn(build(version, "both"), "ModelExchange", solver="CVode", relative_tolerance=1e-9)
    position, heading_deg = _errors(got, reference)
    assert position < 1e-3 and heading_deg < 0.05, (position, heading_deg)
    assert reference[-1, 5] > 2.0 * np.pi  # a full circle and more: the turn was sailed


@pytest.mark.parametrize("version", ["2", "3"])
def test_model_exchange_with_euler_converges_at_first_order(
    build: Any, reference: np.ndarray, version: str
) -> None:
    fmu = build(version, "me")  # fmpy's Euler steps from output point to output point
    coarse = _errors(_turn(fmu, "ModelExchange", 0.05, solver="Euler", step_size=0.05), reference)
    fine = _errors(_turn(fmu, "ModelExchange", 0.025, solver="Euler", step_size=0.025), reference)
    assert fine[0] < 1e-3 and fine[1] < 0.05, fine
    assert 1.7 < coarse[0] / fine[0] < 2.3  # halving the step halves the error
    assert 1.7 < coarse[1] / fine[1] < 2.3


# --- the IMO manoeuvres through model exchange: the Python model's metrics -------------

# The programme runner's settings (trials.run): approach at the nominal speed and rpm,
# steering gear at the KVLCC2 rate, communication step 0.1 s.
RUN = {
    "speed_mps": SPEED_MPS,
    "n_rps": N_RPS,
    "rudder_rate_radps": np.radians(DEFAULT_RUDDER_RATE_DEG_S),
    "dt_s": 0.1,
}
TURN_35 = turning_circle(np.radians(35.0), heading_change_rad=np.radians(225.0))  # to 180 deg
_ZIGZAG_ANGLES = (np.radians(10.0), np.radians(10.0))  # rudder, check heading
ZIGZAG_10 = zigzag(*_ZIGZAG_ANGLES)
# The "done when": 0.1 % on advance, transfer and tactical diameter, 0.05 deg on
# the overshoots.
LENGTH_RTOL, OVERSHOOT_DEG = 1e-3, 0.05


class _NoInput:
    """fmpy's solvers apply an input only at their root function: there is none here."""

    def apply(self, *args: Any, **kwargs: Any) -> None:
        pass


class ModelExchangePlant(SingleShip):
    """A model-exchange FMU as a plant of the programme runner, integrated by fmpy's solvers.

    Inputs are held over each communication step, as the co-simulation FMU and the
    Python model hold them. ``CVode`` (fmpy's CVodeSolver, BDF) is re-initialised at
    every step, the inputs being discontinuous there; ``Euler`` (fmpy's ForwardEuler)
    takes ``euler_step_s`` steps.
    """

    def __init__(
        self,
        fmu: Path,
        version: str,
        folder: Path,
        solver: str,
        euler_step_s: float = 0.0,
        relative_tolerance: float = 1e-9,
    ) -> None:
        unzipped = extract(str(fmu), str(folder))
        md = read_model_description(unzipped)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.length_m = float(next(v.start for v in md.modelVariables if v.name == "length"))
        cls = FMU2Model if version == "2" else FMU3Model
        token = md.guid if version == "2" else md.instantiationToken
        self.fmu = cls(
            guid=token, unzipDirectory=unzipped, modelIdentifier=md.modelExchange.modelIdentifier
        )
        self.fmu.instantiate()
        self.version, self.solver_name = version, solver
        self.euler_step_s, self.relative_tolerance = euler_step_s, relative_tolerance
        self.initialised = False
        self.time_s = 0.0
        self.solver: Any = None

    def reset(self, initial_state: np.ndarray) -> None:
        fmu = self.fmu
        if self.initialised:
            fmu.reset()
        names = ["u0", "v0", "r0", "x0", "y0", "psi0"]
        _set(fmu, self.version, [self.vr[n] for n in names], [float(x) for x in initial_state])
        if self.version == "2":
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            fmu.newDiscreteStates()
        else:
            fmu.enterInitializationMode(startTime=0.0)
            fmu.exitInitializationMode()
            fmu.updateDiscreteStates()
        fmu.enterContinuousTimeMode()
        self.initialised = True
        self.time_s = 0.0
        get_dx = fmu.getDerivatives if self.version == "2" else fmu.getContinuousStateDerivatives
        common = {
            "nx": len(STATES),
            "nz": 0,
            "get_x": fmu.getContinuousStates,
            "set_x": fmu.setContinuousStates,
            "get_dx": get_dx,
            "get_z": fmu.getEventIndicators,
            "input": _NoInput(),
        }
        if self.solver_name == "CVode":
            self.solver = CVodeSolver(
                get_nominals=fmu.getNominalsOfContinuousStates,
                set_time=fmu.setTime,
                startTime=0.0,
                relativeTolerance=self.relative_tolerance,
                **common,
            )
        else:
            self.solver = ForwardEuler(**common)

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        inputs = [self.vr["rudder_angle"], self.vr["propeller_rpm"]]
        _set(self.fmu, self.version, inputs, [rudder_rad, 60.0 * n_rps])
        if self.solver_name == "CVode":
            self.solver.reset(self.time_s)  # the inputs jumped: start the BDF afresh
            self.solver.step(self.time_s, self.time_s + dt_s)
        else:
            m = round(dt_s / self.euler_step_s)
            for i in range(m):
                self.fmu.setTime(self.time_s + i * dt_s / m)
                self.solver.step(self.time_s + i * dt_s / m, self.time_s + (i + 1) * dt_s / m)
        self.time_s += dt_s
        self.fmu.setTime(self.time_s)
        return _get(self.fmu, self.version, [self.vr[n] for n in STATES])

    def close(self) -> None:
        self.fmu.terminate()
        self.fmu.freeInstance()


@pytest.fixture(scope="module")
def python_metrics(params: ModelParameters) -> tuple[TurningMetrics, ZigzagMetrics]:
    """The Python model's 35 deg turn and 10/10 zig-zag: RK4, the FMU's 0.05 s max_step."""
    plant = ModelPlant(params, max_step_s=0.05)
    turn = turning_metrics(run_program(plant, TURN_35, **RUN))
    return turn, zigzag_metrics(run_program(plant, ZIGZAG_10, **RUN), *_ZIGZAG_ANGLES)


# Measured errors (of 0.1 % and 0.05 deg allowed): CVode at rtol 1e-8 1e-5 and 2e-6 deg;
# Euler at 0.02 s 3e-4 (its first-order error; tests above) and 0.002 deg.
SOLVERS = {
    "CVode": {"solver": "CVode", "relative_tolerance": 1e-8},
    "Euler 0.02 s": {"solver": "Euler", "euler_step_s": 0.02},
}


@pytest.mark.parametrize("version", ["2", "3"])
@pytest.mark.parametrize("solver", SOLVERS)
def test_model_exchange_sails_the_turn_and_zigzag_of_the_python_model(
    build: Any,
    python_metrics: tuple[TurningMetrics, ZigzagMetrics],
    version: str,
    solver: str,
    tmp_path: Path,
) -> None:
    """The same programmes through the same runner (closed loop: the zig-zag reverses the
    rudder where the plant's own heading says so), the plant integrated by the host."""
    plant = ModelExchangePlant(build(version, "me"), version, tmp_path, **SOLVERS[solver])
    try:
        turn = turning_metrics(run_program(plant, TURN_35, **RUN))
        zigzag_run = run_program(plant, ZIGZAG_10, **RUN)  # the same instance, reset
        zz = zigzag_metrics(zigzag_run, *_ZIGZAG_ANGLES)
    finally:
        plant.close()
    want_turn, want_zz = python_metrics
    for name in ("advance_m", "transfer_m", "tactical_diameter_m"):
        got, want = getattr(turn, name), getattr(want_turn, name)
        assert abs(got / want - 1.0) < LENGTH_RTOL, (name, got, want)
    overshoots = ("first_overshoot_rad", "second_overshoot_rad", "third_overshoot_rad")
    for name in overshoots:
        got, want = getattr(zz, name), getattr(want_zz, name)
        assert want is not None and got is not None, name
        assert abs(np.degrees(got - want)) < OVERSHOOT_DEG, (name, got, want)
    # Not a trivial agreement: a turn of a few ship lengths, overshoots of about 1.5 deg.
    assert want_turn.advance_m > 2.0 * plant.length_m < want_turn.tactical_diameter_m
    assert all(np.degrees(getattr(want_zz, name)) > 1.0 for name in overshoots)


# --- directional and adjoint derivatives against finite differences --------------------


def model_exchange_instance(fmu: Path, version: str, tmp_path: Path) -> Any:
    """An FMI 2 or 3 model-exchange instance of ``fmu`` in continuous-time mode."""
    folder = extract(str(fmu), str(tmp_path / "unzipped"))
    md = read_model_description(folder)
    cls = FMU2Model if version == "2" else FMU3Model
    token = {"guid": md.guid} if version == "2" else {"guid": md.instantiationToken}
    model = cls(unzipDirectory=folder, modelIdentifier=md.modelExchange.modelIdentifier, **token)
    model.instantiate()
    if version == "2":
        model.setupExperiment(startTime=0.0)
        model.enterInitializationMode()
    else:
        model.enterInitializationMode(startTime=0.0)
    model.exitInitializationMode()
    if version == "2":
        model.newDiscreteStates()
    else:
        model.updateDiscreteStates()
    model.enterContinuousTimeMode()
    return model


def _set(model: Any, version: str, vr: list[int], values: list[float]) -> None:
    (model.setReal if version == "2" else model.setFloat64)(vr, values)


def _get(model: Any, version: str, vr: list[int]) -> np.ndarray:
    return np.array((model.getReal if version == "2" else model.getFloat64)(vr))


@pytest.mark.parametrize("version", ["2", "3"])
def test_directional_derivatives_equal_finite_differences(
    build: Any, params: ModelParameters, version: str, tmp_path: Path
) -> None:
    vr = {v.name: v.value_reference for v in fmu_variables(params)}
    states = [vr[n] for n in STATES]
    inputs = [vr["rudder_angle"], vr["propeller_rpm"]]
    derivatives = [vr[f"der({n})"] for n in STATES]
    point = [4.0, 0.4, -0.02, 100.0, -50.0, 0.7]
    model = model_exchange_instance(build(version, "both"), version, tmp_path)
    try:
        model.setContinuousStates((ctypes.c_double * 6)(*point), 6)
        _set(model, version, inputs, [0.3, 100.0])
        unknowns, knowns = derivatives + states, states + inputs
        jacobian = np.column_stack(
            [
                model.getDirectionalDerivative(unknowns, knowns, list(np.eye(len(knowns))[j]))
                for j in range(len(knowns))
            ]
        )
        base = [*point, 0.3, 100.0]
        finite = np.empty_like(jacobian)
        for j in range(len(knowns)):
            h = 1e-6 * max(1.0, abs(base[j]))
            columns = []
            for sign in (1.0, -1.0):
                x = list(base)
                x[j] += sign * h
                model.setContinuousStates((ctypes.c_double * 6)(*x[:6]), 6)
                _set(model, version, inputs, x[6:])
                columns.append(np.concatenate([_get(model, version, derivatives), x[:6]]))
            finite[:, j] = (columns[0] - columns[1]) / (2.0 * h)
        np.testing.assert_allclose(jacobian, finite, rtol=1e-6, atol=1e-9)
        assert np.any(jacobian[:6, 6:] != 0.0)  # the inputs act on the accelerations
        np.testing.assert_array_equal(jacobian[6:], np.eye(6, 8))  # outputs: the states
        if version == "3":  # the adjoint is the transpose
            model.setContinuousStates((ctypes.c_double * 6)(*point), 6)
            _set(model, version, inputs, [0.3, 100.0])
            seed = [0.5, -1.0, 2.0, 0.0, 1.0, 3.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6]
            adjoint = model.getAdjointDerivative(unknowns, knowns, seed, len(knowns))
            np.testing.assert_allclose(adjoint, jacobian.T @ seed, rtol=1e-12, atol=1e-15)
    finally:
        model.terminate()
        model.freeInstance()


# --- a second master: ecos (ecospy) ------------------------------------------------------


@pytest.fixture(scope="module")
def ecospy() -> Any:
    """ecospy, made loadable: its library needs libtbb.so.12 (the tbb wheel puts it in
    the environment's lib/, which is not on the loader's path) and its proxyfmu binary
    ships without the run bit."""
    tbb = Path(sys.prefix) / "lib" / "libtbb.so.12"
    if not sys.platform.startswith("linux") or not tbb.is_file():
        pytest.skip("ecospy's Linux library and the tbb wheel are installed by make test")
    ctypes.CDLL(str(tbb), mode=ctypes.RTLD_GLOBAL)
    import ecospy

    proxy = Path(ecospy.__file__).parent / "binaries" / "proxyfmu"
    if proxy.is_file() and not os.access(proxy, os.X_OK):
        proxy.chmod(proxy.stat().st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)
    return ecospy


@pytest.mark.parametrize("version", ["2", "3"])
@pytest.mark.parametrize("proxy", [False, True], ids=["in-process", "proxyfmu"])
def test_ecos_runs_the_fmu_as_fmpy_does(
    build: Any,
    ecospy: Any,
    version: str,
    proxy: bool,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.chdir(tmp_path)  # proxyfmu writes logs/<instance>.txt into the working directory
    fmu = build(version, "both")
    structure = ecospy.EcosSimulationStructure()
    structure.add_model("ship", f"proxyfmu://localhost?file={fmu}" if proxy else str(fmu))
    structure.add_parameter_set("turn", {"ship::rudder_angle": 0.3})
    with ecospy.EcosSimulation(structure=structure, step_size=0.1) as sim:
        sim.init(parameter_set="turn")
        sim.step(600)
        end_s = sim.get_time()
        got = [sim.get_real(f"ship::{name}") for name in STATES]
        sim.terminate()
    want = simulate_fmu(
        str(fmu), stop_time=end_s, output_interval=0.1, start_values={"rudder_angle": 0.3}
    )
    assert end_s == pytest.approx(60.0) and want["time"][-1] == pytest.approx(end_s)
    np.testing.assert_allclose(got, [want[name][-1] for name in STATES], rtol=1e-12)
    assert got[5] > 0.5  # it turned to starboard
