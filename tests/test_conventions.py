"""A log in another convention is a one-line data error, and no ship's own log is one.

Before ``identifier.conventions``, ``identifier fit`` on the KVLCC2 zig-zags with the
heading as the mathematical angle (90° − ψ) or x and y swapped ended in a traceback
(``ValueError: speed_mps and rudder_rate_radps must be positive``), with the rudder's sign
flipped or the heading counter-clockwise it wrote a model (the latter with a phantom
current of 0.59 m/s).
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import NamedTuple

import numpy as np
import pytest

from identifier.cli import main
from identifier.conventions import (
    approach_problem,
    heading_course_problem,
    rudder_side_problem,
    unit_warnings,
)
from identifier.smoothing import smooth_log
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from trials.conditions import execute_index
from trials.logs import ManeuverLog, format_log, read_log

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"
REPO = Path(__file__).resolve().parents[1]
FRAME = r"expected x_m North, y_m East and heading_deg clockwise from North"


class Found(NamedTuple):
    """What the checks find in a log: the heading's, the rudder's and the approach's
    problems, and the unit warnings."""

    heading: str | None
    rudder: tuple[str, int] | None
    approach: tuple[str, int] | None
    units: list[str]


IN_CONVENTIONS = Found(None, None, None, [])


def _found(log: ManeuverLog) -> Found:
    track = smooth_log(log)
    execute = execute_index(log)
    assert log.length_m is not None
    return Found(
        heading_course_problem(track),
        rudder_side_problem(log, track, execute),
        approach_problem(log, track, log.length_m, execute),
        unit_warnings([log], [track], ["log"], log.length_m),
    )


@pytest.fixture(scope="module")
def zigzag() -> ManeuverLog:
    return synthesize_log(reference_ship("kvlcc2"), MANEUVERS["zigzag-10"](), seed=1)


def _counter_clockwise(log: ManeuverLog) -> ManeuverLog:
    return replace(log, heading_rad=-log.heading_rad)


def _swapped(log: ManeuverLog) -> ManeuverLog:
    return replace(log, x_m=log.y_m, y_m=log.x_m)


def _from_east(log: ManeuverLog) -> ManeuverLog:
    return replace(log, heading_rad=log.heading_rad + math.pi / 2.0)


def _mathematical(log: ManeuverLog) -> ManeuverLog:
    return replace(log, heading_rad=math.pi / 2.0 - log.heading_rad)


def _radians_as_degrees(log: ManeuverLog) -> ManeuverLog:
    return replace(log, heading_rad=np.radians(log.heading_rad))


def _frozen(log: ManeuverLog) -> ManeuverLog:
    """The compass stuck at its first reading, with its noise: a slope of a few
    thousandths either way, which is no mirror."""
    noise = np.random.default_rng(3).normal(0.0, math.radians(0.1), log.n_samples)
    return replace(log, heading_rad=log.heading_rad[0] + noise)


@pytest.mark.parametrize(
    ("edit", "pattern"),
    [
        pytest.param(_counter_clockwise, r"the heading turns against the course over ground "
                     r"\(slope -1\.0\d\): a heading counter-clockwise, or x_m and y_m swapped\? "
                     + FRAME, id="counter-clockwise"),
        pytest.param(_swapped, r"the heading turns against the course over ground \(slope "
                     r"-1\.0\d\)", id="x and y swapped"),
        pytest.param(_mathematical, r"the heading turns against the course over ground",
                     id="from the x axis, anticlockwise"),
        pytest.param(_from_east, r"the heading is 90 deg off the course over ground in the "
                     r"median, expected at most 45 deg \(a drift angle or crab\): a heading "
                     r"from East, or a heading sensor's mounting offset\? " + FRAME,
                     id="from East"),
        pytest.param(_radians_as_degrees, r"the heading turns 0\.017\d times as far as the "
                     r"course over ground, expected about once: is heading_deg in degrees, "
                     r"and its sensor not frozen\?",
                     id="radians under heading_deg"),
        pytest.param(_frozen, r"the heading turns -0\.000\d+ times as far as the course over "
                     r"ground, expected about once: is heading_deg in degrees, and its sensor "
                     r"not frozen\?", id="frozen"),
    ],
)  # fmt: skip
def test_a_heading_in_another_frame_is_named(
    zigzag: ManeuverLog, edit: Callable[[ManeuverLog], ManeuverLog], pattern: str
) -> None:
    assert _found(zigzag) == IN_CONVENTIONS
    heading = _found(edit(zigzag)).heading
    assert heading is not None and re.fullmatch(pattern + ".*", heading), heading


@pytest.mark.parametrize(
    ("maneuver", "amplitude_deg"),
    [("zigzag-10", 10), ("zigzag-20-port", 20), ("turning-35", 35), ("turning-35-port", 35)],
)
def test_a_rudder_of_the_other_sign_is_named_at_execute(maneuver: str, amplitude_deg: int) -> None:
    log = synthesize_log(reference_ship("kvlcc2"), MANEUVERS[maneuver](), seed=2)
    flipped = replace(log, rudder_rad=-log.rudder_rad)
    heading, rudder, _, _ = _found(flipped)
    assert heading is None  # the frame is right: only the rudder is not
    assert rudder is not None
    message, sample = rudder
    assert sample == execute_index(log)
    to, against = ("port", "starboard") if maneuver.endswith("port") else ("starboard", "port")
    assert message.startswith(
        f"the ship turns {message.split()[3]} deg to {to} under its first rudder command, "
        f"{amplitude_deg} deg to {against}: expected a positive rudder_deg to turn it to starboard"
    ), message
    assert float(message.split()[3]) >= 5.0


def test_an_autopilots_movements_before_the_command_are_not_judged(zigzag: ManeuverLog) -> None:
    """±2° of helm every 10 s of the approach (logged, the motion as it was) and no
    ``# execute_time_s:``: the execute point reads at the first of them, and the first
    command of 5° or more, the zig-zag's, is judged from where it began."""
    metadata = {k: v for k, v in zigzag.metadata.items() if k != "execute_time_s"}
    k = execute_index(zigzag)
    rudder = zigzag.rudder_rad.copy()
    rudder[5:k:10] = np.radians(2.0)
    rudder[10:k:10] = np.radians(-2.0)
    steered = replace(zigzag, rudder_rad=rudder, metadata=metadata)
    assert execute_index(steered) == 5
    assert _found(steered) == IN_CONVENTIONS
    heading, rudder_problem, _, _ = _found(replace(steered, rudder_rad=-rudder))
    assert heading is None and rudder_problem is not None
    assert rudder_problem[1] == k
    assert rudder_problem[0].endswith("rudder command, 10 deg to port: expected a positive "
                                      "rudder_deg to turn it to starboard (identifier convert "
                                      "--rudder-positive port flips a log's sign)")  # fmt: skip


def _at_sea(scale: str, current_mps: float, to_deg: float, maneuver: str) -> ManeuverLog:
    environment = SeaEnvironment(current_speed_mps=current_mps,
                                 current_to_rad=math.radians(to_deg))  # fmt: skip
    ship = reference_ship("kvlcc2", scale, environment)
    return synthesize_log(ship, MANEUVERS[maneuver](), seed=3)


@pytest.mark.parametrize("vessel", ["kvlcc2", "mariner", "tanker"])
@pytest.mark.parametrize("maneuver", ["zigzag-10", "zigzag-20-port", "turning-35",
                                      "turning-35-port"])  # fmt: skip
def test_the_reference_ships_logs_are_in_the_conventions(vessel: str, maneuver: str) -> None:
    log = synthesize_log(reference_ship(vessel), MANEUVERS[maneuver](), seed=4)
    assert _found(log) == IN_CONVENTIONS


@pytest.mark.parametrize(
    ("scale", "current_mps", "to_deg"),
    [("full", 1.0, 180.0), ("full", 1.0, 90.0), ("model", 0.6, 0.0), ("model", 0.6, 90.0),
     ("model", 0.6, 180.0)],
)  # fmt: skip
@pytest.mark.parametrize("maneuver", ["zigzag-10", "turning-35"])
def test_logs_in_a_current_are_in_the_conventions(
    scale: str, current_mps: float, to_deg: float, maneuver: str
) -> None:
    """Up to a current of half the 7 m model's approach speed (1.18 m/s): in its turn the
    model slows to about the current's speed, and the course over ground follows the
    current more than the heading (slopes 0.45 to 3.1)."""
    assert _found(_at_sea(scale, current_mps, to_deg, maneuver)) == IN_CONVENTIONS


@pytest.mark.skipif(not HSVA.is_dir(), reason="HSVA model-test data not present")
@pytest.mark.parametrize("run", ["hsva_zz10_stbd", "hsva_zz10_port", "hsva_zz20_10_stbd",
                                 "hsva_zz20_10_port"])  # fmt: skip
def test_the_measured_runs_are_in_the_conventions(run: str) -> None:
    assert _found(read_log(HSVA / f"{run}.csv")) == IN_CONVENTIONS


def test_fit_rejects_a_rudder_of_the_other_sign_in_one_line(
    zigzag: ManeuverLog, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = tmp_path / "zigzag.csv"
    log.write_text(format_log(replace(zigzag, rudder_rad=-zigzag.rudder_rad)))
    out = tmp_path / "params.json"
    status = main(["fit", str(log), "-o", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert status == 1, err
    assert err.count("\n") == 1, err
    expected = (
        rf"error: {re.escape(str(log))}: sample {execute_index(zigzag)}: the ship turns \d+ deg "
        r"to starboard under its first rudder command, 10 deg to port: .* \(identifier "
        r"convert --rudder-positive port flips a log's sign\)"
    )
    assert re.fullmatch(expected, err.rstrip("\n")), err
    assert not out.exists()


@pytest.fixture(scope="module")
def turn() -> ManeuverLog:
    return synthesize_log(reference_ship("kvlcc2"), MANEUVERS["turning-35"](), seed=1)


def test_a_log_cut_after_execute_has_no_approach(
    turn: ManeuverLog, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The 35° turn from t = 200 s on, without ``# execute_time_s:`` (the fit kept a
    current of 0.95 m/s and a nominal speed of 3.3 m/s from it): the message, and
    ``fit``'s one line."""
    metadata = {k: v for k, v in turn.metadata.items() if k != "execute_time_s"}
    assert approach_problem(turn, smooth_log(turn), 320.0, execute_index(turn)) is None
    cut = turn.time_s >= 200.0
    late = replace(turn, time_s=turn.time_s[cut], x_m=turn.x_m[cut], y_m=turn.y_m[cut],
                   heading_rad=turn.heading_rad[cut], rudder_rad=turn.rudder_rad[cut],
                   n_rps=turn.n_rps[cut], metadata=metadata)  # fmt: skip
    found = approach_problem(late, smooth_log(late), 320.0, execute_index(late))
    assert found is not None
    message, sample = found
    assert sample == late.n_samples - 1  # the rudder never moves: the execute point
    assert re.fullmatch(
        r"the approach before execute turns at r' 0\.8\d in the median \(\|r\| L/U\), "
        r"expected a straight run \(at most 0\.05\): a log that starts after execute \(its "
        r"rudder never moves\)\? The nominal speed and the current's start come from the "
        r"approach",
        message,
    ), message
    path = tmp_path / "late.csv"
    path.write_text(format_log(late))
    out = tmp_path / "params.json"
    status = main(["fit", str(path), "-o", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert status == 1 and err == f"error: {path}: sample {sample}: {message}\n", err
    assert not out.exists()


def test_a_rudder_in_radians_and_a_propeller_in_revolutions_per_second_are_warned_of(
    zigzag: ManeuverLog, turn: ManeuverLog
) -> None:
    logs = [zigzag, turn]
    tracks = [smooth_log(log) for log in logs]
    assert unit_warnings(logs, tracks, ["zz", "turn"], 320.0) == []
    radians = [replace(log, rudder_rad=np.radians(log.rudder_rad)) for log in logs]
    (rudder,) = unit_warnings(radians, tracks, ["zz", "turn"], 320.0)
    assert re.fullmatch(
        r"the rudder reaches at most 0\.61 deg while the ship turns at r' up to 0\.[89]\d: is "
        r"rudder_deg in degrees\? \(radians read as degrees are 57 times too small; the "
        r"scenarios and the FMU read degrees\)",
        rudder,
    ), rudder
    per_second = [replace(log, n_rps=log.n_rps / 60.0) for log in logs]
    found = unit_warnings(per_second, tracks, ["zz", "turn"], 320.0)
    assert [w.split(":")[0] for w in found] == ["zz", "turn"]
    for warning in found:
        assert re.fullmatch(
            r"\w+: the ship advances 0\.\d\d L per propeller revolution at 1\.75 rpm, expected "
            r"at most 0\.1 L \(about a propeller's diameter\): is rpm in revolutions per "
            r"minute\? \(the scenarios and the FMU's propeller_rpm then take the logs' unit\)",
            warning,
        ), warning


def test_a_ship_at_her_berth_has_no_course_to_judge(zigzag: ManeuverLog) -> None:
    """Five minutes alongside, the fixes scattered by 2 m, the compass steady: the course
    over ground is noise (a recording's first piece). Before the under-way test's σ every
    draw of five was judged, four as a frozen compass and one as a heading that turns
    against the course ("slope -0.00")."""
    rng = np.random.default_rng(0)
    n = 300
    for _ in range(5):
        berth = ManeuverLog(
            time_s=zigzag.time_s[:n], x_m=rng.normal(0.0, 2.0, n), y_m=rng.normal(0.0, 2.0, n),
            heading_rad=np.full(n, 0.5) + rng.normal(0.0, 1e-3, n), rudder_rad=np.zeros(n),
            n_rps=np.zeros(n),
        )  # fmt: skip
        assert heading_course_problem(smooth_log(berth)) is None


def test_convert_warns_of_a_rudder_of_the_other_sign(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The README walkthrough's NMEA recording converted with the wrong
    ``--rudder-positive``: the log is written (the conversion is what was asked for), with
    ``fit``'s reason to refuse it on one line, also with ``--quiet``; converted right, no
    warning."""
    recording = tmp_path / "zz10.nmea"
    subprocess.run(
        [sys.executable, str(REPO / "examples/own_data/record_nmea.py"), "--maneuver",
         "zigzag-10", "-o", str(recording)],
        check=True, capture_output=True,
    )  # fmt: skip
    assert main(["convert", str(recording), "-o", str(tmp_path / "right.csv"), "--quiet"]) == 0
    assert "warning" not in capsys.readouterr().err
    wrong = tmp_path / "wrong.csv"
    code = main(
        ["convert", str(recording), "-o", str(wrong), "--rudder-positive", "port", "--quiet"]
    )
    out, err = capsys.readouterr()
    assert code == 0 and out == "" and wrong.is_file()
    log = read_log(wrong)
    k = execute_index(log)
    assert re.fullmatch(
        rf"warning: {re.escape(str(wrong))}: sample {k} \(t = {log.time_s[k]:.1f} s\): the ship "
        r"turns \d+ deg to starboard under its first rudder command, 10 deg to port: expected "
        r"a positive rudder_deg to turn it to starboard \(identifier convert --rudder-positive "
        r"port flips a log's sign\); identifier fit refuses such a log\n",
        err,
    ), err


def test_convert_judges_the_track_at_midship_as_fit_does(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 35° turn logged by an antenna 300 m aft of midship: its track swings wide, 49°
    off the heading in the median, which convert warned of as "a heading from East";
    reduced to midship, as ``fit`` judges it, nothing."""
    recording = tmp_path / "turn.nmea"
    subprocess.run(
        [sys.executable, str(REPO / "examples/own_data/record_nmea.py"), "--maneuver",
         "turning-35", "--gnss-x-m", "-300", "-o", str(recording)],
        check=True, capture_output=True,
    )  # fmt: skip
    out = tmp_path / "turn.csv"
    assert main(["convert", str(recording), "--gnss-x-m", "-300", "-o", str(out), "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    assert heading_course_problem(smooth_log(read_log(out))) is not None  # the antenna's own
