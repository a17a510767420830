"""OSP example (examples/osp_autopilot): the ship and a PID autopilot FMU in libcosim.

* the native ship FMU alone in libcosim, rudder prescribed step by step through an
  override manipulator, equals an fmpy run of the same FMU with the same inputs: to
  1e-9 with a plain 0.1 s step, and bit for bit on libcosim's own time grid;
* the pythonfmu autopilot loads in libcosim (inside this Python process) and the closed
  loop equals, bit for bit, the documented sampled loop (fmpy ship + ``pid_step`` with
  one step of delay); the heading settles to 0.5 deg of a 30 deg set-point by 300 s and stays there;
* negative controls: with the rudder connection removed the heading stays at 0 and does
  not settle; a bad autopilot parameter stops the run with an error.
"""

from __future__ import annotations

import math
import shutil
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver

from fmu_model import ModelParameters
from fmu_model.export_native import build_native_fmu
from scenarios.fmu_plant import FmuPlant
from tests.conftest import SEED_COEFFICIENTS
from tests.module_files import load_module

EXAMPLE_DIR = Path(__file__).resolve().parents[1] / "examples" / "osp_autopilot"
STEP_S = 0.1
STEP_NS = 100_000_000
RPM = 120.0
VR_RUDDER = 0
VR_OUTPUTS = [2, 3, 4, 5, 6, 7]  # u, v, r, x, y, psi
OSP_NS = {"osp": "http://opensimulationplatform.com/MSMI/OSPSystemStructure"}


# Not under the name "autopilot": the FMU's slave must come from the FMU's resources.
law = load_module("osp_autopilot_law", EXAMPLE_DIR / "autopilot.py")
builder = load_module("osp_autopilot_build", EXAMPLE_DIR / "build_autopilot.py")
osp_run = load_module("osp_autopilot_run", EXAMPLE_DIR / "run.py")


def libcosim_steps(n: int) -> np.ndarray:
    """Step sizes libcosim passes to fmi2DoStep: t_k+1 - t_k with t_k = k h_ns / 1e9."""
    t = np.arange(n + 1) * STEP_NS / 1e9
    return np.diff(t)


@pytest.fixture(scope="module", autouse=True)
def quiet_libcosim() -> Iterator[None]:
    log_output_level(CosimLogLevel.WARNING)  # libcosim logs every FMI call otherwise
    yield


@pytest.fixture(scope="module")
def ship_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=RPM / 60.0,
    )
    return build_native_fmu(params, tmp_path_factory.mktemp("ship") / "testship.fmu")


@pytest.fixture(scope="module")
def autopilot_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path: Path = builder.build_autopilot_fmu(tmp_path_factory.mktemp("ap") / "autopilot.fmu")
    return path


# -- the control law alone ------------------------------------------------------------


def test_pid_law_signs_limit_and_wrap() -> None:
    gains = law.PidGains(kp=2.0, ki=0.0, kd=10.0)
    assert law.pid_step(gains, 0.0, 0.3, 0.3, 0.0, STEP_S) == (0.0, 0.0)
    # positive error -> positive (starboard) rudder; yaw rate to starboard reduces it
    _, rudder = law.pid_step(gains, 0.0, 0.1, 0.0, 0.0, STEP_S)
    _, damped = law.pid_step(gains, 0.0, 0.1, 0.0, 0.005, STEP_S)
    assert rudder == pytest.approx(0.2) and damped == pytest.approx(0.15)
    # a large error saturates at the limit
    assert law.pid_step(gains, 0.0, 1.0, 0.0, 0.0, STEP_S)[1] == gains.rudder_limit_rad
    # set-point 350 deg from heading 10 deg: turn 20 deg to port, not 340 to starboard
    unit = law.PidGains(kp=1.0, ki=0.0, kd=0.0)
    _, rudder = law.pid_step(unit, 0.0, math.radians(350.0), math.radians(10.0), 0.0, STEP_S)
    assert rudder == pytest.approx(math.radians(-20.0))


def test_pid_law_anti_windup() -> None:
    gains = law.PidGains(kp=1.0, ki=0.5, kd=0.0, integral_band_rad=math.radians(5.0))
    small = math.radians(2.0)
    integral, _ = law.pid_step(gains, 0.0, small, 0.0, 0.0, STEP_S)
    assert integral == pytest.approx(small * STEP_S)
    # outside the band the error is not integrated
    assert law.pid_step(gains, 0.0, math.radians(6.0), 0.0, 0.0, STEP_S)[0] == 0.0
    # inside the band but saturated in the error's direction: integral held
    charged = 2.0 * gains.rudder_limit_rad / gains.ki
    integral, rudder = law.pid_step(gains, charged, small, 0.0, 0.0, STEP_S)
    assert (integral, rudder) == (charged, gains.rudder_limit_rad)


def test_pid_gains_problems() -> None:
    assert law.PidGains().problems() == []
    bad = law.PidGains(kp=-1.0, ki=math.nan, rudder_limit_rad=math.radians(40.0))
    problems = " ".join(bad.problems())
    assert "Kp" in problems and "Ki" in problems and "rudder_limit" in problems


# -- the ship FMU alone in libcosim ---------------------------------------------------


def test_ship_fmu_in_libcosim_matches_fmpy(ship_fmu: Path, tmp_path: Path) -> None:
    (tmp_path / "ship.fmu").write_bytes(ship_fmu.read_bytes())
    structure = tmp_path / "OspSystemStructure.xml"
    structure.write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<OspSystemStructure xmlns="{OSP_NS["osp"]}" version="0.1">\n'
        "  <BaseStepSize>0.1</BaseStepSize><Algorithm>fixedStep</Algorithm>\n"
        '  <Simulators><Simulator name="ship" source="ship.fmu"><InitialValues>\n'
        f'    <InitialValue variable="propeller_rpm"><Real value="{RPM}"/></InitialValue>\n'
        "  </InitialValues></Simulator></Simulators>\n"
        "</OspSystemStructure>\n",
        encoding="utf-8",
    )
    n = 1200
    rudder = np.radians(20.0) * np.sin(2.0 * np.pi * np.arange(n) * STEP_S / 60.0)

    execution = CosimExecution.from_osp_config_file(str(structure))
    ship = execution.slave_index_from_instance_name("ship")
    observer = CosimObserver.create_last_value()
    override = CosimManipulator.create_override()
    assert execution.add_observer(observer) and execution.add_manipulator(override)
    cosim = np.empty((n, 6))
    for k in range(n):
        assert override.slave_real_values(ship, [VR_RUDDER], [float(rudder[k])])
        assert execution.step(1)
        cosim[k] = observer.last_real_values(ship, VR_OUTPUTS)
    assert execution.status().current_time == n * STEP_NS

    with FmuPlant(ship_fmu) as plant:
        plant.reset(np.array([5.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
        fixed_step = np.array([plant.step(float(d), RPM / 60.0, STEP_S) for d in rudder])
    assert np.abs(cosim - fixed_step).max() <= 1e-9
    assert abs(cosim[-1, 5]) > 0.1  # the rudder did turn the ship

    # libcosim steps by differences of its nanosecond clock; with those step sizes the
    # same binary gives the same bits.
    unzipped = extract(str(ship_fmu))
    md = read_model_description(unzipped)
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="ship",
    )
    slave.instantiate()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.setReal([1], [RPM])
    grid = np.empty((n, 6))
    t = 0.0
    for k, h in enumerate(libcosim_steps(n)):
        slave.setReal([VR_RUDDER], [float(rudder[k])])
        slave.doStep(t, h)
        t = (k + 1) * STEP_NS / 1e9
        grid[k] = slave.getReal(VR_OUTPUTS)
    slave.terminate()
    slave.freeInstance()
    shutil.rmtree(unzipped, ignore_errors=True)
    np.testing.assert_array_equal(cosim, grid)


# -- ship + autopilot -----------------------------------------------------------------


def test_system_structure_file() -> None:
    root = ET.parse(EXAMPLE_DIR / "OspSystemStructure.xml").getroot()
    assert root.findtext("osp:BaseStepSize", namespaces=OSP_NS) == "0.1"
    connections = {
        tuple(f"{v.get('simulator')}.{v.get('name')}" for v in c)
        for c in root.iterfind("osp:Connections/osp:VariableConnection", OSP_NS)
    }
    assert connections == {
        ("ship.psi", "autopilot.psi"),
        ("ship.r", "autopilot.r"),
        ("autopilot.rudder_angle", "ship.rudder_angle"),
    }
    initial = {
        (s.get("name"), i.get("variable")): float(i.findall("osp:Real", OSP_NS)[0].get("value", ""))
        for s in root.iterfind("osp:Simulators/osp:Simulator", OSP_NS)
        for i in s.iterfind("osp:InitialValues/osp:InitialValue", OSP_NS)
    }
    assert initial[("autopilot", "heading_setpoint")] == pytest.approx(math.radians(30.0))
    assert initial[("ship", "propeller_rpm")] == RPM
    assert initial[("autopilot", "rudder_limit")] == pytest.approx(math.radians(35.0))
    assert osp_run.DEMO_COEFFICIENTS == SEED_COEFFICIENTS


def test_autopilot_settles_and_equals_sampled_loop(
    ship_fmu: Path, autopilot_fmu: Path, tmp_path: Path
) -> None:
    duration_s, setpoint_deg = 600.0, 30.0
    run = osp_run.run_autopilot(ship_fmu, autopilot_fmu, tmp_path, duration_s, setpoint_deg)
    assert run.time_s.size == 6000 and run.time_s[-1] == pytest.approx(duration_s)
    assert run.settled(tolerance_deg=0.5, by_s=300.0)
    settle = run.settling_time_s(0.5)
    assert settle is not None and 60.0 < settle < 120.0  # 82 s when this was written
    assert np.abs(run.heading_error_deg()[run.time_s >= 300.0]).max() < 0.1
    assert np.abs(run.rudder_rad).max() == pytest.approx(math.radians(35.0))  # saturates

    # The same loop without libcosim: the ship through fmpy, the autopilot's own
    # pid_step, both on libcosim's step sizes; the autopilot sees the ship's outputs at
    # t_k and its rudder acts over [t_k+1, t_k+2).
    gains = osp_run.scaled_gains(100.0, 5.0)
    pid = law.PidGains(kp=gains["Kp"], ki=gains["Ki"], kd=gains["Kd"])
    setpoint = math.radians(setpoint_deg)
    psi = r = integral = rudder = 0.0
    heading = np.empty(run.time_s.size)
    with FmuPlant(ship_fmu) as plant:
        plant.reset(np.array([5.0, 0.0, 0.0, 0.0, 0.0, 0.0]))
        for k, h in enumerate(libcosim_steps(run.time_s.size)):
            state = plant.step(rudder, RPM / 60.0, float(h))
            integral, rudder = law.pid_step(pid, integral, setpoint, psi, r, float(h))
            psi, r = float(state[5]), float(state[2])
            heading[k] = psi
    np.testing.assert_array_equal(run.heading_rad, heading)  # hence also within 1e-9


def test_without_rudder_connection_heading_does_not_settle(
    ship_fmu: Path, autopilot_fmu: Path, tmp_path: Path
) -> None:
    run = osp_run.run_autopilot(
        ship_fmu, autopilot_fmu, tmp_path, 100.0, 30.0, connect_rudder=False
    )
    assert np.abs(run.heading_rad).max() < 1e-12  # zero rudder: the ship runs straight
    assert not run.settled(tolerance_deg=0.5, by_s=60.0)
    assert run.settling_time_s(0.5) is None
    # the autopilot itself runs and asks for hard-over starboard rudder
    assert run.rudder_rad[-1] == pytest.approx(math.radians(35.0))


@pytest.mark.parametrize(
    ("name", "value"),
    [("rudder_limit", math.radians(40.0)), ("integral_band", 0.0)],  # in / not in template
)
def test_bad_autopilot_parameter_stops_the_run(
    ship_fmu: Path, autopilot_fmu: Path, tmp_path: Path, name: str, value: float
) -> None:
    gains = {**osp_run.scaled_gains(100.0, 5.0), name: value}
    with pytest.raises(osp_run.CosimRunError, match=r"step 1 .* failed"):
        osp_run.run_autopilot(ship_fmu, autopilot_fmu, tmp_path, 10.0, 30.0, gains=gains)


def test_settling_time_helper() -> None:
    t = np.arange(1, 6) * 1.0
    heading = np.radians([0.0, 29.0, 30.2, 29.9, 30.1])
    run = osp_run.AutopilotRun(t, heading, np.zeros(5), np.zeros(5), math.radians(30.0))
    assert run.settling_time_s(0.5) == 3.0
    assert run.settled(0.5, by_s=3.0) and not run.settled(0.5, by_s=2.0)
    assert not run.settled(0.5, by_s=10.0)  # the run is shorter than the required time
    left = osp_run.AutopilotRun(t, heading[::-1], np.zeros(5), np.zeros(5), math.radians(30.0))
    assert left.settling_time_s(0.5) is None
