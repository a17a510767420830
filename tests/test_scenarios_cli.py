"""``python -m scenarios``: FMU runs against the Python model, the KVLCC2 reference
against shared/reference/kvlcc2_mmg.md §11, JSON/CSV outputs, gates and bad input."""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import ModelParameters, get_model, save_params
from fmu_model.envelope import Envelope, Sides, Span
from fmu_model.export_native import build_native_fmu
from identifier.smoothing import smooth_log, smoothed_trajectory
from scenarios.cli import PROG, main
from scenarios.cli.fmu_runs import logged_run
from scenarios.errors import ScenarioError
from scenarios.fmu_checks import check_params_match, read_fmu_info
from scenarios.fmu_plant import FmuPlant
from scenarios.runs import reference_runs
from scenarios.synthesize import FULL_SCALE_LOGGING, default_logging, maneuver_seed
from tests.conftest import SEED_COEFFICIENTS
from tests.test_shape import COEFFICIENTS as PRIME_COEFFICIENTS
from tests.trial_day import joined
from trials.logs import ManeuverLog, on_board_offset, read_log, write_log
from trials.maneuvers import turning_circle, zigzag
from trials.metrics import turning_metrics, zigzag_metrics
from trials.run import ModelPlant, run_program

ROOT = Path(__file__).resolve().parents[1]
RUDDER_RATE_RADPS = math.radians(2.34)  # the CLI default
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
# A ship whose 35 deg turn is too wide for IMO MSC.137(76) 5.3.1 (tactical diameter
# about 7.2 L, advance 5.6 L) and whose initial turning is too slow (3.7 L to 10 deg).
WIDE_TURNING_C3 = 0.0008


def _params(c3: float | None = None, name: str = "testship") -> ModelParameters:
    coefficients = dict(SEED_COEFFICIENTS)
    if c3 is not None:
        coefficients["c3"] = c3
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(coefficients.values())),
        length_m=100.0,
        vessel_name=name,
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )


@pytest.fixture(scope="session")
def params() -> ModelParameters:
    return _params()


@pytest.fixture(scope="session")
def fmu(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> Path:
    """One native FMU of the seed-structure test ship for the whole session."""
    return build_native_fmu(params, tmp_path_factory.mktemp("fmu") / "testship.fmu")


@pytest.fixture(scope="session")
def wide_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    params = _params(WIDE_TURNING_C3, name="wideship")
    return build_native_fmu(params, tmp_path_factory.mktemp("wide") / "wideship.fmu")


def _one_line(text: str) -> str:
    lines = text.strip("\n").split("\n")
    assert len(lines) == 1, f"expected one line, got {text!r}"
    assert "Traceback" not in text
    return lines[0]


# ----------------------------------------------------------------- the plants agree


@pytest.mark.parametrize(
    "program",
    [
        turning_circle(math.radians(35.0), heading_change_rad=math.radians(400.0)),
        zigzag(math.radians(-20.0), math.radians(20.0)),
    ],
    ids=["turning", "zigzag-port"],
)
def test_fmu_run_equals_python_model_run(fmu, params, program):
    info = read_fmu_info(fmu)
    settings = {"speed_mps": 5.0, "n_rps": 2.0, "rudder_rate_radps": RUDDER_RATE_RADPS}
    with FmuPlant(fmu) as plant:
        got = run_program(plant, program, dt_s=0.1, **settings)
    want = run_program(
        ModelPlant(params, max_step_s=info.max_step_s), program, dt_s=0.1, **settings
    )
    assert got.shape == want.shape and got.size > 1000
    for name in ("time_s", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(got[name], want[name], err_msg=name)
    for name in ("x_m", "y_m", "psi_rad", "u_mps", "v_mps", "r_radps"):
        scale = max(1.0, float(np.max(np.abs(want[name]))))
        np.testing.assert_allclose(got[name], want[name], rtol=0.0, atol=1e-9 * scale, err_msg=name)


# ---------------------------------------------------------- the reference, ref. §11


def test_kvlcc2_reference_metrics_match_reference_page():
    """35 deg turns both ways and 10/10, 20/20 zig-zags at dt 0.1 s (ref. §10, §11)."""
    name, _, length, condition, runs = reference_runs("kvlcc2", "full", 0.1)
    assert name == "kvlcc2-full" and length == 320.0 and condition.dt_s == 0.1
    m = {run.program.name: run.metrics for run in runs}
    turning = {
        "turning-35-stbd": (3.0789, 1.3253, 3.1107, 174.23),
        "turning-35-port": (3.0901, 1.3255, 3.0964, 172.48),
    }
    for key, (advance_l, transfer_l, tactical_l, t90) in turning.items():
        t = m[key]
        assert t.advance_m / length == pytest.approx(advance_l, rel=0.01), key
        assert t.transfer_m / length == pytest.approx(transfer_l, rel=0.01), key
        assert t.tactical_diameter_m / length == pytest.approx(tactical_l, rel=0.01), key
        assert t.time_to_90_s == pytest.approx(t90, rel=0.01), key
    zigzags = {
        "zigzag-10-10-stbd": (5.001, 13.937, 71.63),
        "zigzag-20-20-stbd": (10.583, 15.823, 75.45),
    }
    for key, (first, second, reversal) in zigzags.items():
        z = m[key]
        assert z.first_overshoot_deg == pytest.approx(first, abs=max(0.01 * first, 0.1)), key
        assert z.second_overshoot_deg == pytest.approx(second, abs=max(0.01 * second, 0.1)), key
        assert z.reversal_times_s[0] == pytest.approx(reversal, rel=0.01), key


# --------------------------------------------------------------- JSON, CSV, figures


def test_turning_circle_json_csv_plot(fmu, tmp_path, capsys):
    out = {k: tmp_path / f"turn.{k}" for k in ("json", "csv", "png")}
    files = ["--json", str(out["json"]), "--csv", str(out["csv"]), "--plot", str(out["png"])]
    status = main(["turning-circle", "--fmu", str(fmu), "--rudder-deg", "35", "--quiet", *files])
    assert status == 0
    assert "tactical diameter" in capsys.readouterr().out
    record = json.loads(out["json"].read_text())
    for key in (
        "advance_m",
        "transfer_m",
        "tactical_diameter_m",
        "advance_L",
        "transfer_L",
        "tactical_diameter_L",
        "steady_diameter_m",  # the default run covers 540 deg
        "time_to_90_s",
    ):
        assert isinstance(record[key], float), key
    assert record["advance_L"] == pytest.approx(record["advance_m"] / 100.0, rel=1e-12)
    assert record["run"]["speed_mps"] == 5.0 and record["run"]["rpm"] == pytest.approx(120.0)

    # The same run, here: the CLI defaulted to the FMU's u0 and propeller_rpm starts.
    program = turning_circle(math.radians(35.0), max_time_s=60.0 * 100.0 / 5.0)
    with FmuPlant(fmu) as plant:
        traj = run_program(
            plant, program, speed_mps=5.0, n_rps=2.0, rudder_rate_radps=RUDDER_RATE_RADPS, dt_s=0.1
        )
    metrics = turning_metrics(traj)
    assert record["advance_m"] == metrics.advance_m
    assert record["tactical_diameter_m"] == metrics.tactical_diameter_m

    log = read_log(out["csv"])
    assert log.metadata["vessel"] == "testship" and log.length_m == 100.0
    assert "turning-35-stbd" in log.metadata["source"]
    np.testing.assert_array_equal(log.time_s, traj["time_s"])
    np.testing.assert_array_equal(log.x_m, traj["x_m"])
    np.testing.assert_array_equal(log.y_m, traj["y_m"])
    np.testing.assert_allclose(log.heading_rad, traj["psi_rad"], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(log.rudder_rad, traj["rudder_rad"], rtol=1e-14, atol=1e-15)
    np.testing.assert_allclose(log.n_rps, traj["n_rps"], rtol=1e-14)
    assert out["png"].read_bytes().startswith(PNG_MAGIC)


def test_zigzag_json_and_port_first_mirrors(fmu, tmp_path):
    """The test ship is mirror-symmetric: port first gives the same overshoots."""
    records = []
    for side in ([], ["--port-first"]):
        path = tmp_path / f"zz{len(side)}.json"
        args = ["zigzag", "--fmu", str(fmu), "--rudder-deg", "20", "--heading-deg", "20"]
        assert main([*args, *side, "--json", str(path), "--quiet"]) == 0
        records.append(json.loads(path.read_text()))
    stbd, port = records
    for key in ("first_overshoot_deg", "second_overshoot_deg", "initial_turning_time_s"):
        assert isinstance(stbd[key], float), key
        assert port[key] == pytest.approx(stbd[key], rel=1e-9, abs=1e-9), key
    assert stbd["rudder_deg"] == 20.0 and port["rudder_deg"] == -20.0
    assert len(stbd["reversal_times_s"]) >= 3
    with FmuPlant(fmu) as plant:
        traj = run_program(
            plant,
            zigzag(math.radians(20.0), math.radians(20.0), max_time_s=1200.0),
            speed_mps=5.0,
            n_rps=2.0,
            rudder_rate_radps=RUDDER_RATE_RADPS,
            dt_s=0.1,
        )
    z = zigzag_metrics(traj, math.radians(20.0), math.radians(20.0))
    assert stbd["first_overshoot_deg"] == z.first_overshoot_deg
    assert stbd["second_overshoot_deg"] == z.second_overshoot_deg


@pytest.fixture(scope="session")
def model_scale_fmu(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> Path:
    """The test ship as a 7 m tank model (its shi2009 coefficients do not use L)."""
    model = replace(params, length_m=7.0, vessel_name="tankmodel")
    return build_native_fmu(model, tmp_path_factory.mktemp("model") / "tankmodel.fmu")


def test_a_tank_model_sailed_at_a_ships_steering_rate_is_warned_about(
    model_scale_fmu, fmu, tmp_path, capsys
):
    """The default 2.34 deg/s on a 7 m FMU: one warning line, and the run uses it; the
    model's own rate (given) and a 100 m ship: no warning, and a faster rudder checks the
    swing sooner (a smaller first overshoot)."""
    zz = ["zigzag", "--rudder-deg", "20", "--heading-deg", "20", "--max-time-s", "1200"]
    records = {}
    for name, ship, rate in (
        ("default", model_scale_fmu, []),
        ("given", model_scale_fmu, ["--rudder-rate-deg-s", "15.8"]),
        ("ship", fmu, []),
    ):
        path = tmp_path / f"{name}.json"
        assert main([*zz, "--fmu", str(ship), *rate, "--quiet", "--json", str(path)]) == 0
        records[name] = (json.loads(path.read_text()), capsys.readouterr().err)
    default, warned = records["default"]
    line = _one_line(warned)
    assert line.startswith(f"warning: {model_scale_fmu}: L = 7 m, a model?"), line
    assert "--rudder-rate-deg-s" in line
    assert default["run"]["rudder_rate_deg_s"] == pytest.approx(2.34)
    given, quiet = records["given"]
    assert quiet == "" and given["run"]["rudder_rate_deg_s"] == pytest.approx(15.8)
    assert given["first_overshoot_deg"] < default["first_overshoot_deg"] - 0.1
    assert records["ship"][1] == ""


def test_spiral_and_pullout(fmu, tmp_path):
    spiral_json = tmp_path / "spiral.json"
    args = ["spiral", "--fmu", str(fmu), "--rudder-steps-deg", "10,0,-10,0,10"]
    assert main([*args, "--hold-s", "200", "--json", str(spiral_json), "--quiet"]) == 0
    spiral = json.loads(spiral_json.read_text())
    rates = spiral["steady_yaw_rate_degps"]
    assert spiral["rudder_deg"] == [10.0, 0.0, -10.0, 0.0, 10.0]
    assert rates[0] > 0.5 and rates[2] == pytest.approx(-rates[0], rel=1e-3)
    # Midship after a turn: the yaw rate decays (T about 28 s), symmetrically both ways.
    assert abs(rates[1]) < 0.01 * rates[0] and rates[3] == pytest.approx(-rates[1], rel=1e-3)
    assert spiral["stable"] is True and spiral["loop_width_deg"] == 0.0

    pullout_json = tmp_path / "pullout.json"
    args = ["pullout", "--fmu", str(fmu), "--rudder-deg", "20", "--turn-s", "300"]
    assert main([*args, "--release-s", "400", "--json", str(pullout_json), "--quiet"]) == 0
    pullout = json.loads(pullout_json.read_text())
    assert pullout["initial_yaw_rate_degps"] > 1.0
    assert abs(pullout["residual_yaw_rate_degps"]) < 0.01 * pullout["initial_yaw_rate_degps"]
    assert pullout["time_constant_s"] > 0.0


def test_synthesize_writes_logs_with_per_maneuver_seeds(tmp_path, capsys):
    both, alone = tmp_path / "both", tmp_path / "alone"
    common = ["--vessel", "kvlcc2", "--scale", "model", "--seed", "3", "--quiet"]
    args = ["synthesize", "--maneuver", "zigzag-10", "--maneuver", "zigzag-20", *common]
    assert main([*args, "-o", str(both)]) == 0
    printed = capsys.readouterr().out.split()
    assert printed == [str(both / "zigzag-10.csv"), str(both / "zigzag-20.csv")]
    logs = [read_log(both / f"zigzag-{a}.csv") for a in (10, 20)]
    for log, name in zip(logs, ("zigzag-10", "zigzag-20"), strict=True):
        assert log.metadata["vessel"] == "kvlcc2-model" and log.length_m == pytest.approx(7.0)
        assert log.metadata["source"].endswith(f"seed {maneuver_seed(3, name)}")
    assert maneuver_seed(3, "zigzag-10") != maneuver_seed(3, "zigzag-20")
    # A manoeuvre's noise does not depend on what else was synthesised with it.
    assert main(["synthesize", "--maneuver", "zigzag-10", *common, "-o", str(alone)]) == 0
    assert (alone / "zigzag-10.csv").read_bytes() == (both / "zigzag-10.csv").read_bytes()


def test_synthesize_at_model_scale_logs_as_a_basin_does(tmp_path, capsys):
    """The logger's defaults Froude-scaled to the 7 m model (λ = 320/7): 1 m of position
    noise on a 7 m hull, a fix a second and a minute's approach were a sea trial's."""
    lam = 320.0 / 7.0
    args = ["synthesize", "--maneuver", "zigzag-10", "--scale", "model", "--quiet"]
    assert main([*args, "-o", str(tmp_path)]) == 0
    log = read_log(tmp_path / "zigzag-10.csv")
    assert np.diff(log.time_s) == pytest.approx(1.0 / math.sqrt(lam))
    assert float(log.metadata["execute_time_s"]) == pytest.approx(60.0 / math.sqrt(lam), abs=0.15)
    assert (
        "; 6.76123 Hz, position noise 0.021875 m, heading noise 0.1 deg" in log.metadata["source"]
    )
    assert default_logging("full") == FULL_SCALE_LOGGING
    assert (FULL_SCALE_LOGGING.rate_hz, FULL_SCALE_LOGGING.position_noise_m) == (1.0, 1.0)
    with pytest.raises(ValueError, match="unknown scale 'tank': expected 'full' or 'model'"):
        default_logging("tank")


def test_synthesize_glitches_the_logs_it_is_asked_to(tmp_path, capsys):
    common = ["synthesize", "--maneuver", "zigzag-10", "--scale", "model", "--quiet"]
    assert main([*common, "-o", str(tmp_path / "clean")]) == 0
    glitches = ["--gnss-jump-pct", "2", "--compass-spike-pct", "1"]
    assert main([*common, *glitches, "-o", str(tmp_path / "glitched")]) == 0
    clean, glitched = (read_log(tmp_path / d / "zigzag-10.csv") for d in ("clean", "glitched"))
    jumped = np.hypot(glitched.x_m - clean.x_m, glitched.y_m - clean.y_m) > 1e-9
    spiked = np.abs(np.angle(np.exp(1j * (glitched.heading_rad - clean.heading_rad)))) > 1e-9
    assert np.count_nonzero(jumped) == round(0.02 * clean.n_samples)
    assert np.count_nonzero(spiked) == round(0.01 * clean.n_samples)
    source = glitched.metadata["source"]
    assert "GNSS jumps of 50-1000 m" in source and "compass spikes of 5-180 deg" in source
    capsys.readouterr()
    with pytest.raises(SystemExit) as excinfo:
        main([*common, "--gnss-jump-pct", "11", "-o", str(tmp_path / "x")])
    assert excinfo.value.code == 2 and "--gnss-jump-pct" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


# ------------------------------------------------------------------------- gates


def test_imo_strict_gate(fmu, wide_fmu, tmp_path, capsys):
    report = tmp_path / "imo.json"
    assert main(["imo", "--fmu", str(fmu), "--strict", "--quiet", "--json", str(report)]) == 0
    captured = capsys.readouterr()
    assert "verdict: PASS" in captured.out and captured.err == ""
    doc = json.loads(report.read_text())
    assert doc["passed"] is True and len(doc["criteria"]) == 8

    assert main(["imo", "--fmu", str(wide_fmu), "--quiet"]) == 0  # not strict: report only
    assert "verdict: FAIL" in capsys.readouterr().out
    assert main(["imo", "--fmu", str(wide_fmu), "--strict", "--quiet"]) == 3
    line = _one_line(capsys.readouterr().err)
    assert "FAIL" in line and "tactical diameter" in line and "initial turning" in line


def test_validate_report_and_error_gate(fmu, tmp_path, capsys):
    report = tmp_path / "report"
    args = ["validate", "--fmu", str(fmu), "--reference", "kvlcc2", "--report", str(report)]
    assert main([*args, "--max-error-pct", "10", "--quiet"]) == 3
    captured = capsys.readouterr()
    assert "FAIL" in _one_line(captured.err) and "advance" in captured.err
    assert f"report: {report / 'report.md'}" in captured.out
    doc = json.loads((report / "validation.json").read_text())
    assert doc["format"] == "ship-maneuvering-validation" and doc["gate"]["passed"] is False
    rows = doc["comparison"]
    assert len(rows) == 10  # advance, transfer, tactical x 2 turns; 2 overshoots x 2 zig-zags
    for row in rows:
        want = 100.0 * (row["predicted"] - row["reference"]) / row["reference"]
        assert row["error_pct"] == pytest.approx(want, rel=1e-12)
    assert {"turning-35-stbd", "zigzag-20-20-stbd"} <= set(doc["runs"]["predicted"])
    assert len(doc["imo"]["criteria"]) == 8
    assert any("length" in w for w in doc["warnings"])  # 100 m test ship vs 320 m KVLCC2
    text = (report / "report.md").read_text()
    assert "| 35° starboard turn: advance |" in text and "5.3.3.3" in text
    for png in ("turning-circles.png", "zigzag-10-10-stbd.png", "zigzag-20-20-stbd.png"):
        assert (report / png).read_bytes().startswith(PNG_MAGIC), png
        assert f"]({png})" in text

    limit = f"{doc['max_abs_error_pct'] + 1.0:.3f}"
    assert main([*args, "--max-error-pct", limit, "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    assert json.loads((report / "validation.json").read_text())["gate"]["passed"] is True


def test_quiet_validate_with_intervals_prints_nothing_on_stderr(fmu, params, tmp_path):
    """The Monte Carlo's local cluster (two worker processes) starts and ends in silence.

    Its teardown used to print distributed's heartbeat errors and a traceback about one
    run in ten; every one of several runs must leave stderr empty (fd 2: the worker
    processes write there too).
    """
    theta = params.to_vector()
    uncertain = params.with_vector(theta, np.diag((0.01 * theta) ** 2))
    save_params(tmp_path / "params.json", uncertain)
    argv = ["validate", "--fmu", str(fmu), "--params", str(tmp_path / "params.json")]
    argv += ["--dt-s", "1", "--uncertainty-samples", "4", "--uncertainty-dt-s", "2", "--quiet"]
    # Each run in a fresh interpreter, as a user runs it: inside this long-lived test
    # process (after hundreds of other tests, FMUs loaded in-process among them) the
    # cluster's worker processes twice failed to come up and gather waited for ever.
    for run in range(3):
        done = subprocess.run(
            [sys.executable, "-m", "scenarios", *argv, "--report", str(tmp_path / f"r{run}")],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
        assert done.stderr == "", f"run {run}: {done.stderr}"
        assert "95 % intervals: 4 Monte-Carlo samples" in done.stdout


# -------------------------------------------------------------------- bad input


def test_missing_fmu_is_one_line_exit_1(tmp_path):
    missing = tmp_path / "missing.fmu"
    result = subprocess.run(
        [sys.executable, "-m", "scenarios", "turning-circle", "--fmu", str(missing)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert result.returncode == 1
    assert "missing.fmu" in _one_line(result.stderr)
    assert result.stdout == ""


def test_rudder_beyond_the_fmus_limit(fmu, capsys):
    assert main(["turning-circle", "--fmu", str(fmu), "--rudder-deg", "60"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert "60 deg" in line and "45 deg" in line


def test_turn_that_never_reaches_90_degrees(fmu, capsys):
    assert main(["turning-circle", "--fmu", str(fmu), "--max-time-s", "20", "--quiet"]) == 1
    line = _one_line(capsys.readouterr().err)
    assert "turning-35-stbd" in line and "90 deg" in line


@pytest.mark.parametrize(
    "option",
    [["--speed-mps", "2.2e-16"], ["--dt-s", "1e-300"], ["--max-time-s", "1e308"]],
    ids=["creeping-approach", "tiny-step", "endless-limit"],
)
def test_runs_of_absurdly_many_steps_are_refused(fmu, tmp_path, capsys, option):
    """60 L/U at 2.2e-16 m/s used to be a traceback from numpy (too large an array)."""
    out = tmp_path / "turn.json"
    assert main(["turning-circle", "--fmu", str(fmu), "--quiet", "--json", str(out), *option]) == 1
    line = _one_line(capsys.readouterr().err)
    assert line.startswith(f"{PROG} turning-circle: error: turning-35-stbd: ")
    assert "steps, more than 1e+07; take a longer step or a shorter time limit" in line
    assert not out.exists()


def test_imo_and_runs_with_params_say_which_go_beyond_the_logs(fmu, params, tmp_path, capsys):
    """Logs steered to 20° at the FMU's 120 rpm (turning and slowing as much as anything
    here): the 35° turns are extrapolations, the zig-zags not, in imo and in a single
    run, unless driven at another rpm; params of another FMU are a one-line error."""
    rudder = Sides(math.radians(20.0), math.radians(20.0))
    logs = Envelope(rudder, Sides(5.0, 5.0), 0.0, Span(0.1, 100.0), Span(2.0, 2.0))
    path = tmp_path / "params.json"
    save_params(path, replace(params, identification={"envelope": logs.as_dict()}))
    report = tmp_path / "imo.json"
    argv = ["imo", "--fmu", str(fmu), "--params", str(path), "--quiet", "--json", str(report)]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert "- turning-35-stbd: rudder 35.0 deg to starboard (logs: 20.0 deg)" in out
    assert "- turning-35-port: rudder 35.0 deg to port (logs: 20.0 deg)" in out
    beyond = json.loads(report.read_text())["extrapolation"]["beyond"]
    assert beyond["zigzag-10-10-stbd"] == [] and beyond["zigzag-20-20-stbd"] == []
    assert main(["imo", "--fmu", str(fmu), "--quiet", "--json", str(report)]) == 0
    assert json.loads(report.read_text())["extrapolation"] is None  # no params: not judged
    capsys.readouterr()
    # The single-run commands say it of their run.
    turn = ["turning-circle", "--fmu", str(fmu), "--rudder-deg", "-35", "--params", str(path)]
    assert main([*turn, "--quiet", "--json", str(report)]) == 0
    assert "- turning-35-port: rudder 35.0 deg to port (logs: 20.0 deg)" in capsys.readouterr().out
    assert json.loads(report.read_text())["extrapolation"]["beyond"]["turning-35-port"]
    zz = ["zigzag", "--fmu", str(fmu), "--params", str(path), "--quiet", "--json", str(report)]
    assert main(zz) == 0
    assert "Every predicted manoeuvre stays within them." in capsys.readouterr().out
    assert json.loads(report.read_text())["extrapolation"]["beyond"] == {"zigzag-10-10-stbd": []}
    assert main([*zz, "--rpm", "150"]) == 0
    assert "- zigzag-10-10-stbd: propeller 150 rpm (logs: 120 rpm)" in capsys.readouterr().out
    other = tmp_path / "other.json"
    save_params(other, _params(c3=WIDE_TURNING_C3))
    assert main(["imo", "--fmu", str(fmu), "--params", str(other), "--quiet"]) == 1
    assert "other.json" in _one_line(capsys.readouterr().err)


def test_file_that_is_not_an_fmu(tmp_path, capsys):
    fake = tmp_path / "fake.fmu"
    fake.write_text("not a zip")
    assert main(["zigzag", "--fmu", str(fake)]) == 1
    assert "not a readable FMU" in _one_line(capsys.readouterr().err)
    foreign = tmp_path / "foreign.fmu"
    with zipfile.ZipFile(foreign, "w") as archive:
        archive.writestr("modelDescription.xml", "<fmiModelDescription/>")
    assert main(["imo", "--fmu", str(foreign)]) == 1
    assert "foreign.fmu" in _one_line(capsys.readouterr().err)


@pytest.mark.parametrize(
    "argv",
    [
        ["synthesize", "--maneuver", "loop-the-loop", "-o", "x"],
        ["turning-circle", "--fmu", "x.fmu", "--rudder-deg", "0"],
        ["zigzag", "--fmu", "x.fmu", "--heading-deg", "nan"],
        ["validate", "--fmu", "x.fmu"],  # --report missing
        ["zigzag", "--fmu", "x.fmu", "--reversals", "0"],
        ["zigzag", "--fmu", "x.fmu", "--reversals", "two"],
    ],
    ids=[
        "unknown-maneuver",
        "zero-rudder",
        "nan-heading",
        "missing-option",
        "no-reversals",
        "reversals-not-a-number",
    ],
)
def test_usage_errors_exit_2(argv, capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(argv)
    assert excinfo.value.code == 2
    assert "error:" in capsys.readouterr().err


@pytest.mark.parametrize(
    ("option", "value"), [("--uncertainty-samples", "5"), ("--scheduler", "tcp://h:8786")]
)
def test_validate_options_without_params_are_the_subcommands_usage_error(option, value, capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(["validate", "--fmu", "x.fmu", "--report", "r", option, value])
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    assert err.startswith(f"usage: {PROG} validate ")
    assert (
        err.splitlines()[-1]
        == f"{PROG} validate: error: {option} needs --params (the FMU's params.json)"
    )


def test_validate_help_shows_single_percent_signs(capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(["validate", "--help"])
    assert excinfo.value.code == 0
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps lines
    assert "%%" not in out
    assert "95 % intervals of the predicted quantities" in out
    assert "exceeds P % (overshoot angles" in out


# ------------------------------------------------- params of another model structure

# The family member the FMU is built from, and names of other members (or of none).
PRIME_MODEL = "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7,wake=0.35,dwake=0.25]"
OTHER_MODELS = {
    "another-shape": "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7,wake=0.35,dwake=0]",
    "partial-name": "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7]",
    "bare-family": "prime-rudder",
    "duplicated-key": (
        "prime-rudder[k=0.00015,gamma=0.52,dgamma=0.12,l=-0.7,wake=0.35,dwake=0.25,k=0.0004]"
    ),
}


def _prime(model: str) -> ModelParameters:
    """A 320 m tanker in ``model``, the same coefficients whatever the shape, 1 % std."""
    theta = np.array(list(PRIME_COEFFICIENTS.values()))
    return ModelParameters.from_vector(
        model,
        theta,
        length_m=320.0,
        vessel_name="tanker",
        nominal_speed_mps=8.0,
        nominal_n_rps=1.75,
        covariance=np.diag((0.01 * theta) ** 2),
    )


@pytest.fixture(scope="session")
def prime_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return build_native_fmu(_prime(PRIME_MODEL), tmp_path_factory.mktemp("prime") / "t.fmu")


def test_the_fmu_names_its_structure_and_an_equal_one_in_other_words_matches(prime_fmu):
    info = read_fmu_info(prime_fmu)
    assert info.structure_name == get_model(PRIME_MODEL).name
    # The same structure, its shape constants in another order: accepted.
    check_params_match(info, _prime(PRIME_MODEL))
    check_params_match(
        info, _prime("prime-rudder[dwake=0.25,wake=0.35,l=-0.7,dgamma=0.12,gamma=0.52,k=1.5e-4]")
    )


@pytest.mark.parametrize("case", OTHER_MODELS)
def test_validate_refuses_params_of_another_structure(case, prime_fmu, tmp_path, capsys):
    """Same coefficient names and values, another shape: exit 1 naming both, nothing run."""
    model = OTHER_MODELS[case]
    theirs = get_model(model).name
    params = tmp_path / "params.json"
    save_params(params, _prime(model))
    report = tmp_path / "report"
    argv = ["validate", "--fmu", str(prime_fmu), "--params", str(params)]
    argv += ["--report", str(report), "--uncertainty-samples", "2", "--quiet"]
    assert main(argv) == 1
    captured = capsys.readouterr()
    line = _one_line(captured.err)
    assert line.startswith(f"{PROG} validate: error: {params}: ")
    assert (
        f"their model structure is {theirs} but the FMU's is {get_model(PRIME_MODEL).name}" in line
    )
    assert captured.out == ""
    assert not report.exists()
    with pytest.raises(ScenarioError, match="model structure"):
        check_params_match(read_fmu_info(prime_fmu), _prime(model))


def test_params_of_an_unrelated_structure_are_refused_by_structure(prime_fmu):
    with pytest.raises(ScenarioError) as excinfo:
        check_params_match(read_fmu_info(prime_fmu), _params(), "p.json")
    message = str(excinfo.value)
    assert message.startswith("p.json: the parameters (shi2009, vessel 'testship') do not match")
    assert message.endswith(f"their model structure is shi2009 but the FMU's is {PRIME_MODEL}")


def test_a_log_is_laid_over_the_run_at_its_execute_point_and_heading(params) -> None:
    """A 20 deg turn logged 1 km North and 500 m West of the run's origin, on a course
    of 40 deg: the figure's log (its smoothed trajectory, as its indices are read) lies
    on the run of the same ship (the run at its origin heading North)."""
    run = run_program(
        ModelPlant(params),
        replace(turning_circle(math.radians(20.0), max_time_s=300.0), approach_s=30.0),
        speed_mps=5.0,
        n_rps=2.0,
        rudder_rate_radps=math.radians(3.0),
        dt_s=0.5,
    )
    turn = math.radians(40.0)
    north, east = run["x_m"] - run["x_m"][0], run["y_m"] - run["y_m"][0]
    log = ManeuverLog(
        run["time_s"] - run["time_s"][0] + 100.0,
        1000.0 + math.cos(turn) * north - math.sin(turn) * east,
        -500.0 + math.sin(turn) * north + math.cos(turn) * east,
        run["psi_rad"] + turn,
        run["rudder_rad"],
        run["n_rps"],
        metadata={"length_m": "100.0"},
    )
    smoothed = smoothed_trajectory(log, smooth_log(log))
    laid = logged_run(smoothed, 130.0, run[run["time_s"] >= -10.0])
    assert laid["time_s"][0] == pytest.approx(-10.0) and laid.size == np.sum(run["time_s"] >= -10.0)
    later = run[run["time_s"] >= -10.0]
    for key in ("x_m", "y_m"):
        np.testing.assert_allclose(laid[key], later[key], atol=1e-6)
    np.testing.assert_allclose(laid["psi_rad"], later["psi_rad"], atol=1e-9)  # the smoother
    np.testing.assert_array_equal(laid["u_mps"], smoothed["u_mps"][log.time_s >= 120.0])
    assert abs(later["x_m"][-1] - log.x_m[-1]) > 100.0  # where the log was: moved


def test_like_warns_of_a_log_of_several_manoeuvres(fmu, params, tmp_path, capsys):
    """Two 10/10 zig-zags in one log, each after 60 s (3 L) of straight running: ``--like``
    reads it as one manoeuvre, and says to split it first."""
    program = replace(
        zigzag(math.radians(10.0), math.radians(10.0), max_time_s=600.0), approach_s=60.0
    )
    truth = run_program(
        ModelPlant(params), program, speed_mps=5.0, n_rps=2.0,
        rudder_rate_radps=math.radians(5.0), dt_s=1.0,
    )  # fmt: skip
    one = ManeuverLog(
        truth["time_s"] - truth["time_s"][0], truth["x_m"], truth["y_m"], truth["psi_rad"],
        truth["rudder_rad"], truth["n_rps"], metadata={"length_m": "100.0"},
    )  # fmt: skip
    for log, warned in ((one, False), (joined(one, one), True)):
        write_log(tmp_path / "logged.csv", log)
        assert (
            main(["zigzag", "--fmu", str(fmu), "--like", str(tmp_path / "logged.csv"), "--quiet"])
            == 0
        )
        err = capsys.readouterr().err
        expected = (
            f"warning: {tmp_path / 'logged.csv'}: the log holds 2 manoeuvres (executed at t = "
            f"60.0, {one.time_s[-1] + 61.0:.1f} s), read here as one: split it into one log "
            "each first (python -m identifier split)\n"
        )
        assert err == (expected if warned else "")


def test_zigzag_like_a_log_sails_its_condition_and_prints_both(fmu, params, tmp_path, capsys):
    """A 15/12 port-first zig-zag, 3 deg/s, 10 Hz log of the ship the FMU holds, slowing
    from 4 m/s in its approach: ``--like`` reads all of it from the log, and the FMU
    repeats the log's overshoots."""
    program = zigzag(-math.radians(15.0), math.radians(12.0), max_time_s=1200.0)
    truth = run_program(
        ModelPlant(params),
        replace(program, approach_s=30.0),
        speed_mps=4.0,
        n_rps=1.5,
        rudder_rate_radps=math.radians(3.0),
        dt_s=0.1,
    )
    execute = int(np.argmin(np.abs(truth["time_s"])))
    log = tmp_path / "measured.csv"
    write_log(
        log,
        ManeuverLog(
            truth["time_s"] - truth["time_s"][0],
            truth["x_m"],
            truth["y_m"],
            truth["psi_rad"],
            truth["rudder_rad"],
            truth["n_rps"],
            metadata={"vessel": "testship", "length_m": "100.0"},
        ),
    )
    out, png = tmp_path / "like.json", tmp_path / "like.png"
    args = ["zigzag", "--fmu", str(fmu), "--like", str(log), "--json", str(out), "--quiet"]
    assert main([*args, "--plot", str(png)]) == 0  # the log laid over the run
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    record = json.loads(out.read_text())
    run = record["run"]
    speed = math.hypot(truth["u_mps"][execute], truth["v_mps"][execute])
    assert speed < 3.9  # slowed down in the approach
    assert run["speed_mps"] == pytest.approx(speed, rel=0.01)  # a parabola through the approach
    assert run["rpm"] == pytest.approx(90.0)
    assert run["rudder_rate_deg_s"] == pytest.approx(3.0, rel=0.02)
    assert record["rudder_deg"] == pytest.approx(-15.0, abs=0.01)
    assert record["heading_deg"] == pytest.approx(12.0)
    for key in ("first_overshoot_deg", "second_overshoot_deg"):
        # Each reversal is quantised to the 0.1 s step, in the log and again in the FMU run.
        assert record[key] == pytest.approx(record["logged"][key], abs=0.15)
    for key in ("initial_turning_time_s", "time_to_check_yaw_s", "period_s"):
        assert record["logged"][key] > 10.0  # the times of the zig-zag, logged and sailed
        assert record[key] == pytest.approx(record["logged"][key], abs=0.2, rel=3e-3)
    printed = capsys.readouterr().out
    assert f"as logged in {log}" in printed and "difference" in printed
    assert re.search(r"  period_s +logged +\d+\.\d\d s  predicted +\d+\.\d\d s", printed)
    # The same run logged at 1 Hz with 1 m and 0.1 deg of noise: its indices are read off
    # the smoothed track (off the raw headings' flat peaks the time to check yaw came out
    # 0.3-0.54 s off in four noise draws of four, one first overshoot 0.17 deg off).
    rng = np.random.default_rng(7)
    clean = read_log(log)
    every = slice(None, None, 10)
    noisy = tmp_path / "noisy.csv"
    write_log(noisy, ManeuverLog(
        clean.time_s[every],
        clean.x_m[every] + rng.normal(0.0, 1.0, clean.x_m[every].size),
        clean.y_m[every] + rng.normal(0.0, 1.0, clean.y_m[every].size),
        clean.heading_rad[every] + rng.normal(0.0, math.radians(0.1), clean.x_m[every].size),
        clean.rudder_rad[every], clean.n_rps[every], metadata=clean.metadata,
    ))  # fmt: skip
    out = tmp_path / "noisy.json"
    assert (
        main(["zigzag", "--fmu", str(fmu), "--like", str(noisy), "--json", str(out), "--quiet"])
        == 0
    )
    logged = json.loads(out.read_text())["logged"]
    for key in ("first_overshoot_deg", "second_overshoot_deg"):
        assert logged[key] == pytest.approx(record["logged"][key], abs=0.15), key
    for key in ("initial_turning_time_s", "time_to_check_yaw_s"):
        assert logged[key] == pytest.approx(record["logged"][key], abs=0.3), key
    # A compass spike of 60 deg at the first overshoot, a GNSS jump of 500 m in the
    # approach: glitches, not the manoeuvre (before, "logged" read the spike for the
    # overshoot).
    clean = read_log(log)
    heading, x_m = clean.heading_rad.copy(), clean.x_m.copy()
    peak = execute + int(np.argmax(np.abs(heading[execute:] - heading[execute])))
    heading[peak] += math.radians(60.0) * np.sign(heading[peak] - heading[execute])
    x_m[execute - 100] += 500.0
    glitched = tmp_path / "glitched.csv"
    write_log(glitched, replace(clean, heading_rad=heading, x_m=x_m))
    out = tmp_path / "glitched.json"
    args = ["zigzag", "--fmu", str(fmu), "--like", str(glitched), "--json", str(out), "--quiet"]
    assert main(args) == 0
    deglitched = json.loads(out.read_text())
    for key in ("first_overshoot_deg", "second_overshoot_deg"):
        assert deglitched["logged"][key] == pytest.approx(record["logged"][key], abs=0.01)
    assert deglitched["run"]["speed_mps"] == pytest.approx(run["speed_mps"], rel=1e-3)
    # The same run in a current of 0.3 m/s setting East, its speed log's water speed beside
    # the drifted track: the run sails in still water unless told, and says so.
    elapsed = clean.time_s - clean.time_s[0]
    drifted = tmp_path / "drifted.csv"
    write_log(drifted, replace(clean, y_m=clean.y_m + 0.3 * elapsed,
                               stw_mps=truth["u_mps"].copy(),
                               stw_transverse_mps=truth["v_mps"].copy()))  # fmt: skip
    # (a two-axis log without its position, speed_log_x_m: its transverse axis unused,
    # a traceback before)
    args = ["zigzag", "--fmu", str(fmu), "--like", str(drifted), "--quiet"]
    assert main(args) == 0
    (warning,) = capsys.readouterr().err.splitlines()
    assert re.fullmatch(
        rf"warning: {re.escape(str(drifted))}: its speed log shows a current of 0\.30 m/s "
        r"towards (89|90|91) deg, whose drift the logged indices carry; the run sails in still "
        r"water: give --current-mps 0\.30 --current-to-deg (89|90|91) to sail it in that current",
        warning,
    ), warning
    assert main([*args, "--current-mps", "0.3", "--current-to-deg", "90"]) == 0
    assert capsys.readouterr().err == ""
    # A turning circle is not a zig-zag.
    turn = tmp_path / "turn.csv"
    traj = run_program(
        ModelPlant(params),
        replace(turning_circle(math.radians(20.0), max_time_s=600.0), approach_s=30.0),
        speed_mps=5.0,
        n_rps=2.0,
        rudder_rate_radps=RUDDER_RATE_RADPS,
        dt_s=1.0,
    )
    write_log(
        turn,
        ManeuverLog(
            traj["time_s"] - traj["time_s"][0],
            traj["x_m"],
            traj["y_m"],
            traj["psi_rad"],
            traj["rudder_rad"],
            traj["n_rps"],
            metadata={"length_m": "100.0"},
        ),
    )
    assert main(["zigzag", "--fmu", str(fmu), "--like", str(turn), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is a turning manoeuvre, not a zigzag" in err
    # The same turn logged by an antenna 3 L aft of midship (its track swings wide of the
    # heading: judged at the antenna, a "heading from East" before): read at midship.
    midship = read_log(turn)
    north_m, east_m = on_board_offset(-300.0, 0.0, midship.heading_rad)
    aft = tmp_path / "aft.csv"
    write_log(aft, replace(midship, x_m=midship.x_m + north_m, y_m=midship.y_m + east_m,
                           metadata={**midship.metadata, "gnss_x_m": "-300.0"}))  # fmt: skip
    records = []
    for logged in (turn, aft):
        out, png = tmp_path / f"{logged.stem}.json", tmp_path / f"{logged.stem}.png"
        args = ["turning-circle", "--fmu", str(fmu), "--like", str(logged), "--json", str(out)]
        assert main([*args, "--quiet", "--plot", str(png)]) == 0, capsys.readouterr().err
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        records.append(json.loads(out.read_text())["logged"])
    for key in ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"):
        assert records[1][key] == pytest.approx(records[0][key], rel=1e-9)
    # A log whose rudder's sign is the other way round is not sailed again.
    flipped = tmp_path / "flipped.csv"
    write_log(flipped, replace(read_log(log), rudder_rad=-read_log(log).rudder_rad))
    assert main(["zigzag", "--fmu", str(fmu), "--like", str(flipped), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert re.fullmatch(
        rf"python -m scenarios zigzag: error: {re.escape(str(flipped))}: sample {execute}: the "
        r"ship turns \d+ deg to port under its first rudder command, 15 deg to starboard: "
        r"expected a positive rudder_deg to turn it to starboard .*",
        err.rstrip("\n"),
    ), err
