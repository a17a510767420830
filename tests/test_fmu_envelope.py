"""An FMU warns when it is driven beyond the envelope of its identification's logs.

Both backends, built from parameters that record the envelope (params.json
``identification.envelope``), log one warning per axis and side the first time a step
goes beyond it (``fmu_model.envelope.ExtrapolationWatch``; the C layer's
``warn_beyond_logs``), with the same text; the step itself is OK. The expected warnings
are worked out here from the FMU's own outputs, by hand.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

import build_fmu
from fmu_model import save_params
from fmu_model.envelope import Envelope, Sides, Span
from fmu_model.export_native import build_native_fmu
from fmu_model.export_pythonfmu import build_pythonfmu_fmu
from scenarios.cli import main
from tests.fmi_logging import LogRecorder
from tests.test_fmu_pythonfmu import PARAMS

FMI_OK, FMI_WARNING = 0, 1
PREFIX = "fmi2DoStep: t = %.9g s: beyond the identification logs, the model extrapolates: "
# The test ship's logs: 20 deg of rudder and r' 0.2 to each side, speed down to 0.95 U0,
# approach speeds 4.9-5.1 m/s, 120 rpm.
LOGS = Envelope(
    rudder_max_rad=Sides(math.radians(20.0), math.radians(20.0)),
    yaw_rate_max=Sides(0.2, 0.2),
    speed_ratio_min=0.95,
    approach_speed_mps=Span(4.9, 5.1),
    propeller_rate_rps=Span(2.0, 2.0),
)
IDENTIFIED = replace(PARAMS, identification={"envelope": LOGS.as_dict()})
BUILDERS = {"native": build_native_fmu, "pythonfmu": build_pythonfmu_fmu}


@pytest.fixture(scope="module", params=sorted(BUILDERS))
def identified_fmu(request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory) -> str:
    """Each backend's FMU of the test ship with the envelope, unpacked."""
    path = tmp_path_factory.mktemp(request.param) / "ship.fmu"
    return str(extract(str(BUILDERS[request.param](IDENTIFIED, path))))


def _sail(
    unzipdir: str, rudder_deg: float, rpm: float, steps: int, *, u0_mps: float = 5.0
) -> tuple[list[tuple[int, str]], list[tuple[float, float, float, float]]]:
    """Drive the FMU at a constant rudder and rpm in 1 s steps from u0 (loggingOn).

    Returns the warnings (status, message) and, per step, (t [s], u, v, r) at its end.
    """
    md = read_model_description(unzipdir)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    recorder = LogRecorder()
    slave = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipdir,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="ship",
    )
    slave.instantiate(callbacks=recorder.callbacks, loggingOn=True)
    states = []
    try:
        slave.setReal([vr["u0"]], [u0_mps])
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        inputs = [vr["rudder_angle"], vr["propeller_rpm"]]
        for k in range(steps):
            slave.setReal(inputs, [math.radians(rudder_deg), rpm])
            status = slave.fmi2DoStep(slave.component, float(k), 1.0, True)
            assert status == FMI_OK  # a warning does not fail the step
            u, v, r = slave.getReal([vr["u"], vr["v"], vr["r"]])
            states.append((k + 1.0, u, v, r))
        slave.terminate()
    finally:
        slave.freeInstance()
    warnings = [(status, text) for status, _, text in recorder.messages if status == FMI_WARNING]
    return warnings, states


def test_each_axis_is_warned_once_when_first_beyond(identified_fmu: str) -> None:
    """35 deg to starboard at 130 rpm: the rudder and the propeller at the first step,
    r' when the turn first passes 0.2 × 1.05, never again; said as the FMU's own state."""
    warnings, states = _sail(identified_fmu, 35.0, 130.0, 120)
    yaw_rates = [(t, r * 100.0 / math.sqrt(u * u + v * v)) for t, u, v, r in states]
    t_yaw, r_yaw = next((t, q) for t, q in yaw_rates if q > 0.2 * 1.05)
    assert warnings == [
        (FMI_WARNING, PREFIX % 1.0 + "rudder 35.0 deg to starboard (logs: 20.0 deg)"),
        (FMI_WARNING, PREFIX % 1.0 + "propeller 130 rpm (logs: 120 rpm)"),
        (FMI_WARNING, PREFIX % t_yaw + f"yaw rate r' {r_yaw:.2f} to starboard (logs: 0.20)"),
    ]
    assert t_yaw > 1.0  # the turn builds up: a later step


def test_port_side_speed_and_approach_are_their_own_axes(identified_fmu: str) -> None:
    """From 6 m/s (beyond 5.1 × 1.05) at 120 rpm with 30 deg to port: the port rudder and
    the approach speed at once; the speed once the ship, slowing towards its 5 m/s at
    120 rpm, is below 0.95 − 0.05 U0."""
    warnings, states = _sail(identified_fmu, -30.0, 120.0, 60, u0_mps=6.0)
    texts = [text for _, text in warnings]
    assert texts[:2] == [
        PREFIX % 1.0 + "rudder 30.0 deg to port (logs: 20.0 deg)",
        PREFIX % 1.0 + "approach speed 6 m/s (logs: 4.9-5.1 m/s)",
    ]
    slow = [(t, math.sqrt(u * u + v * v) / 6.0) for t, u, v, _ in states]
    below = [(t, ratio) for t, ratio in slow if ratio < 0.95 - 0.05]
    t_slow, ratio = below[0]
    expected = PREFIX % t_slow + f"speed down to {ratio:.2f} U0 (logs: 0.95 U0)"
    assert [text for text in texts if "speed down" in text] == [expected]
    assert all("starboard" not in text and "propeller" not in text for text in texts)


def test_inside_the_envelope_nothing_is_said(identified_fmu: str) -> None:
    warnings, _ = _sail(identified_fmu, 10.0, 120.0, 20)
    assert warnings == []


def test_both_backends_say_the_same(tmp_path: Path) -> None:
    unpacked = {
        name: str(extract(str(build(IDENTIFIED, tmp_path / f"{name}.fmu"))))
        for name, build in BUILDERS.items()
    }
    said = {name: _sail(unzipdir, -35.0, 100.0, 90) for name, unzipdir in unpacked.items()}
    assert said["native"][0] == said["pythonfmu"][0]
    assert len(said["native"][0]) >= 3  # rudder, propeller, yaw rate to port at least


def test_fmi3_says_it_as_fmi2_does(tmp_path: Path) -> None:
    """The native FMI 3.0 FMU shares the C rule: the same warnings, from fmi3DoStep."""
    fmi2 = str(extract(str(build_native_fmu(IDENTIFIED, tmp_path / "fmi2.fmu"))))
    expected = [
        text.replace("fmi2DoStep", "fmi3DoStep") for _, text in _sail(fmi2, 35.0, 130.0, 30)[0]
    ]
    unzipdir = str(
        extract(str(build_native_fmu(IDENTIFIED, tmp_path / "fmi3.fmu", fmi_version="3")))
    )
    md = read_model_description(unzipdir)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    said: list[tuple[int, str]] = []

    def record(_env: object, status: int, _category: bytes, message: bytes) -> None:
        said.append((status, message.decode()))

    slave = FMU3Slave(
        guid=md.instantiationToken,
        unzipDirectory=unzipdir,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="ship",
    )
    slave.instantiate(loggingOn=False, logMessage=record)
    try:
        slave.setFloat64([vr["u0"]], [5.0])
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        for k in range(30):
            slave.setFloat64([vr["rudder_angle"], vr["propeller_rpm"]], [math.radians(35.0), 130.0])
            slave.doStep(float(k), 1.0)
        slave.terminate()
    finally:
        slave.freeInstance()
    assert [text for status, text in said if status == FMI_WARNING] == expected
    assert len(expected) == 3  # rudder, propeller, yaw rate


def test_without_a_recorded_envelope_nothing_is_judged(tmp_path: Path) -> None:
    assert "envelope" not in PARAMS.identification
    unzipdir = str(extract(str(build_native_fmu(PARAMS, tmp_path / "plain.fmu"))))
    warnings, _ = _sail(unzipdir, 35.0, 300.0, 30, u0_mps=9.0)
    assert warnings == []


def test_the_scenario_commands_print_none_of_it(tmp_path: Path, capfd) -> None:
    """fmpy's default logger would print the FMU's warnings; the scenarios judge the
    envelope themselves (--params), so the plant switches them off."""
    fmu = build_native_fmu(IDENTIFIED, tmp_path / "ship.fmu")
    assert main(["turning-circle", "--fmu", str(fmu), "--rudder-deg", "35", "--quiet"]) == 0
    out = capfd.readouterr().out
    assert "beyond the identification logs" not in out and "[WARNING]" not in out


def test_build_fmu_says_what_the_fmu_will_warn_beyond(tmp_path: Path, capsys) -> None:
    """stdout stays the FMU's path alone; the note goes to stderr; none without an envelope."""
    for params, name in ((IDENTIFIED, "identified"), (PARAMS, "plain")):
        save_params(tmp_path / f"{name}.json", params)
        argv = ["--params", str(tmp_path / f"{name}.json"), "-o", str(tmp_path / f"{name}.fmu")]
        assert build_fmu.main([*argv, "--kind", "cs"]) == 0
        out, err = capsys.readouterr()
        assert out == f"{tmp_path / f'{name}.fmu'}\n"
        if params is IDENTIFIED:
            assert err == (
                "build_fmu.py: note: the FMU warns in its host's log when a step goes beyond "
                f"what its logs reached: {LOGS.describe()}\n"
            )
        else:
            assert err == ""
