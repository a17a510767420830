"""The README's "Using your own trial data" walkthrough, command by command."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _run(*args: str, cwd: Path) -> subprocess.CompletedProcess[str]:
    done = subprocess.run(
        [sys.executable, *args], cwd=cwd, capture_output=True, text=True, check=False
    )
    assert done.returncode == 0, done.stderr
    return done


@pytest.mark.order("first")  # long: started first (conftest.py)
def test_nmea_recording_to_a_validated_fmu(tmp_path: Path) -> None:
    _run(
        str(ROOT / "examples/own_data/record_nmea.py"),
        "--maneuver", "zigzag-10", "-o", "recordings/zigzag-10.nmea",
        cwd=tmp_path,
    )  # fmt: skip
    _run(
        "-m", "identifier", "convert", "recordings/zigzag-10.nmea",
        "--vessel", "my-tanker", "--length-m", "320", "-o", "logs/", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    log = tmp_path / "logs/zigzag-10_1.csv"
    assert "# vessel: my-tanker" in log.read_text()
    _run("-m", "identifier", "fit", str(log), "-o", "build/params.json", "--quiet", cwd=tmp_path)
    built = _run(str(ROOT / "build_fmu.py"), "--params", "build/params.json", cwd=tmp_path)
    fmu = tmp_path / "build/my_tanker.fmu"  # the model identifier: a C name
    assert built.stdout.strip() == "build/my_tanker.fmu" and fmu.is_file()
    # What the FMU will warn beyond: the one zig-zag's 10 deg of rudder each way.
    assert built.stderr.startswith("build_fmu.py: note: the FMU warns in its host's log")
    assert "what its logs reached: rudder 10.0 deg to port, 10.0 deg to starboard;" in built.stderr
    _run(
        "-m", "scenarios", "zigzag", "--fmu", str(fmu), "--rudder-deg", "10",
        "--heading-deg", "10", "--json", "zz.json", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    result = json.loads((tmp_path / "zz.json").read_text())
    # Trained on this very manoeuvre of KVLCC2 (first overshoot 5.0 deg).
    assert 3.0 < result["first_overshoot_deg"] < 8.0
    _run(
        "-m", "scenarios", "imo", "--fmu", str(fmu), "--params", "build/params.json",
        "--json", "imo.json", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    beyond = json.loads((tmp_path / "imo.json").read_text())["extrapolation"]["beyond"]
    # From one 10/10 zig-zag: the 35° turns and the 20/20 zig-zag are extrapolations.
    assert {name for name, reasons in beyond.items() if reasons} == {
        "turning-35-stbd",
        "turning-35-port",
        "zigzag-20-20-stbd",
    }


@pytest.mark.order("first")  # long: started first (conftest.py)
def test_a_sea_trial_recording_with_a_bridge_antenna_and_a_doppler_log(tmp_path: Path) -> None:
    """NMEA at sea: fixes 128 m aft (the bridge), 1 % of them glitched, VBW from a two-axis
    log 128 m forward.

    Converted with both places, fitted: the glitches rejected, the current found, both
    log axes measured, the track reduced to midship; converted without the log's place,
    its transverse axis is left out and the fit says so.
    """
    for maneuver in ("zigzag-10", "zigzag-20"):
        _run(
            str(ROOT / "examples/own_data/record_nmea.py"), "--maneuver", maneuver,
            "--current-mps", "0.5", "--current-to-deg", "45", "--gnss-x-m", "-128",
            "--speed-log-x-m", "128", "--gnss-jump-pct", "1",
            "-o", f"recordings/{maneuver}.nmea",
            cwd=tmp_path,
        )  # fmt: skip
    recordings = ["recordings/zigzag-10.nmea", "recordings/zigzag-20.nmea"]
    _run(
        "-m", "identifier", "convert", *recordings, "--vessel", "my-tanker",
        "--length-m", "320", "--gnss-x-m", "-128", "--speed-log-x-m", "128", "-o", "logs/",
        "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    logs = ["logs/zigzag-10_1.csv", "logs/zigzag-20_1.csv"]
    fit = _run(
        "-m", "identifier", "fit", *logs, "--method", "ekf", "-o", "build/params.json",
        cwd=tmp_path,
    )  # fmt: skip
    assert "positions reduced to midship from the GNSS antenna's, 128 m aft" in fit.stderr
    for log, jumped in zip(logs, (11, 10), strict=True):  # 1 % of 1064 and 1016 fixes
        assert f"{log}: {jumped} position fixes and 0 headings rejected as glitches" in fit.stderr
    environment = json.loads((tmp_path / "build/params.json").read_text())["identification"][
        "environment"
    ]
    assert abs(environment["current_speed_mps"] - 0.5) < 0.02
    assert abs(environment["current_to_deg"] - 45.0) < 3.0
    assert environment["speed_log"]["transverse_samples"] > 2000
    _run(
        "-m", "identifier", "convert", *recordings, "--vessel", "my-tanker",
        "--length-m", "320", "--gnss-x-m", "-128", "-o", "unplaced/", "--quiet",
        cwd=tmp_path,
    )  # fmt: skip
    blind = _run(
        "-m", "identifier", "fit", "unplaced/zigzag-10_1.csv", "unplaced/zigzag-20_1.csv",
        "--method", "ekf", "-o", "build/blind.json",
        cwd=tmp_path,
    )  # fmt: skip
    assert blind.stderr.count("transverse axis (stw_transverse_mps) was not used") == 2
