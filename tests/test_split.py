"""A recording of several manoeuvres split into one log each (``identifier split``)."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from identifier.cli import main
from identifier.conventions import log_problem
from identifier.smoothing import smooth_log
from identifier.split import MAX_APPROACH_L, manoeuvre_name, piece_logs, split_log
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log, synthesize_logs
from tests.trial_day import joined
from trials.conditions import execute_index, logged_condition
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, log_piece, read_log, write_log
from trials.maneuvers import turning_circle, zigzag

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"
LENGTH_M = 320.0


@pytest.fixture(scope="module")
def zig() -> ManeuverLog:
    """KVLCC2's 10/10 zig-zag, a minute's approach (1 Hz, default noise)."""
    return synthesize_log(reference_ship(), zigzag(math.radians(10.0), math.radians(10.0)), seed=3)


@pytest.fixture(scope="module")
def turn() -> ManeuverLog:
    """KVLCC2's 35° port turn after ten minutes of straight running (15 ship lengths)."""
    return synthesize_log(
        reference_ship(), turning_circle(-math.radians(35.0)), seed=4, approach_s=600.0
    )


@pytest.fixture(scope="module")
def day(zig: ManeuverLog, turn: ManeuverLog) -> ManeuverLog:
    """A trial day: the zig-zag, then the turn after its straight run."""
    return joined(zig, turn)


def _sailed_l(log: ManeuverLog, start: int, stop: int) -> float:
    """Distance over ground from sample ``start`` to ``stop`` [ship lengths] (smoothed)."""
    speed = np.asarray(smooth_log(log).speed_mps)[start : stop + 1]
    return float(np.trapezoid(speed, log.time_s[start : stop + 1])) / LENGTH_M


def test_a_trial_day_splits_into_its_manoeuvres_each_with_its_approach(
    day: ManeuverLog, zig: ManeuverLog, turn: ManeuverLog
) -> None:
    found = split_log(day, LENGTH_M)
    assert found.notes == ()
    first, second = found.pieces
    assert (first.start, first.execute) == (0, execute_index(zig))
    assert second.execute == zig.n_samples + execute_index(turn)
    assert second.stop == day.n_samples  # the turn ends the log
    # Five ship lengths of the straight run kept before the turn, and after the zig-zag;
    # the rest of the ten minutes' run (15 L in all) is left out.
    step_l = 8.0 / LENGTH_M
    assert _sailed_l(day, second.start, second.execute) == pytest.approx(MAX_APPROACH_L, abs=step_l)
    assert first.stop < second.start
    straight_from = zig.n_samples  # the zig-zag log ends in its last swing
    assert first.stop > straight_from
    assert _sailed_l(day, straight_from, first.stop) == pytest.approx(MAX_APPROACH_L, abs=0.2)

    logs = piece_logs(day, found, LENGTH_M)
    assert [manoeuvre_name(log) for log in logs] == ["zigzag-10-10-stbd", "turning-35-port"]
    for piece, log, alone in zip(found.pieces, logs, (zig, turn), strict=True):
        np.testing.assert_array_equal(log.time_s, day.time_s[piece.start : piece.stop])
        np.testing.assert_array_equal(log.rudder_rad, day.rudder_rad[piece.start : piece.stop])
        assert float(log.metadata["execute_time_s"]) == day.time_s[piece.execute]
        assert log.metadata["length_m"] == "320.0"
        assert log.metadata["source"].endswith(
            f"(samples {piece.start} to {piece.stop - 1} of day.csv)"
        )
        assert log_problem(log, LENGTH_M) is None  # what fit asks of a log, the approach too
        got, want = logged_condition(log), logged_condition(alone)
        assert got.execute_time_s == day.time_s[piece.execute]
        assert got.speed_mps == pytest.approx(want.speed_mps, abs=0.02)
        assert got.n_rps == pytest.approx(want.n_rps, rel=1e-12)  # a mean of fewer samples
        assert got.rudder_rate_radps == pytest.approx(want.rudder_rate_radps, rel=1e-9)
        assert got.switch_headings_rad == pytest.approx(want.switch_headings_rad, abs=1e-12)


def test_an_autopilots_helm_is_no_command_and_a_new_engine_order_ends_the_approach(
    zig: ManeuverLog, turn: ManeuverLog
) -> None:
    """The turn's straight run steered by an autopilot (3° ± 3° of rudder: up to 6° off
    midship, 3° off its helm) with one correction of 8°, its propeller at 10 % fewer
    revolutions until 150 s (3.7 L) before execute."""
    k = execute_index(turn)
    t = turn.time_s - turn.time_s[0]
    rudder = turn.rudder_rad.copy()
    rudder[:k] = math.radians(3.0) + math.radians(3.0) * np.sin(2.0 * math.pi * t[:k] / 40.0)
    # A helmsman's correction of 8° for 5 s, 400 s before execute: no manoeuvre.
    rudder[k - 400 : k - 395] = math.radians(8.0)
    changed = k - 150
    n_rps = turn.n_rps.copy()
    n_rps[:changed] *= 0.9
    day = joined(zig, replace(turn, rudder_rad=rudder, n_rps=n_rps))
    _, second = split_log(day, LENGTH_M).pieces
    assert second.execute == zig.n_samples + k
    assert second.start == zig.n_samples + changed
    # Without the new engine order the approach is five ship lengths again.
    day = joined(zig, replace(turn, rudder_rad=rudder))
    _, second = split_log(day, LENGTH_M).pieces
    assert second.start < zig.n_samples + changed - 20
    # An order given two samples before execute leaves no approach at one propeller
    # speed: the straight run is kept, and a note says so.
    n_rps[: k - 2] = turn.n_rps[0] * 0.9
    n_rps[k - 2 :] = turn.n_rps[k - 2 :]
    day = joined(zig, replace(turn, n_rps=n_rps))
    found = split_log(day, LENGTH_M)
    assert found.pieces[1].start < zig.n_samples + changed - 20
    execute_s = day.time_s[found.pieces[1].execute]
    assert found.notes == (
        f"the manoeuvre executed at t = {execute_s:.1f} s: its propeller speed changes in "
        "its approach",
    )


def test_a_recording_started_in_a_turn_leaves_that_out_with_a_note(turn: ManeuverLog) -> None:
    k = execute_index(turn)
    started_in_it = joined(log_piece(turn, k + 100, k + 300), turn)
    found = split_log(started_in_it, LENGTH_M)
    (only,) = found.pieces
    assert only.execute == 200 + k
    (note,) = found.notes
    assert note.startswith(f"samples 0 to {only.start - 1} (t = ")
    assert "rudder commands without a straight approach before them" in note


def test_logs_without_a_manoeuvre_to_split_are_errors(turn: ManeuverLog) -> None:
    k = execute_index(turn)
    with pytest.raises(IdentificationError, match=r"^turn\.csv: no rudder command of 5 deg or"):
        split_log(replace(log_piece(turn, 0, k), path="turn.csv"), LENGTH_M)
    with pytest.raises(IdentificationError, match="no rudder command after a straight approach"):
        split_log(log_piece(turn, k + 50, turn.n_samples), LENGTH_M)


@pytest.mark.parametrize(
    "run", ["hsva_zz10_stbd", "hsva_zz10_port", "hsva_zz20_10_stbd", "hsva_zz20_10_port"]
)
def test_a_measured_run_is_one_manoeuvre_with_its_own_execute(run: str) -> None:
    """A basin's run starts a second before its execute (0.14 L): its first sample counts."""
    log = read_log(HSVA / f"{run}.csv")
    found = split_log(log, 7.0)
    assert found.notes == ()
    (only,) = found.pieces
    assert (only.start, only.execute, only.stop) == (0, execute_index(log), log.n_samples)


def test_split_writes_one_log_per_manoeuvre_named_by_what_it_is(
    day: ManeuverLog, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_log(tmp_path / "day.csv", replace(day, metadata={"vessel": "kvlcc2"}))
    assert main(["split", str(tmp_path / "day.csv"), "-o", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    no_length = "no ship length: pass --length-m or add '# length_m:' to the logs"
    assert err == f"error: {tmp_path / 'day.csv'}: {no_length}\n"
    assert not (tmp_path / "out").exists()

    assert main(["split", str(tmp_path / "day.csv"), "-o", str(tmp_path / "out"),
                 "--length-m", "320"]) == 0  # fmt: skip
    out = capsys.readouterr().out.splitlines()
    names = ["day_1_zigzag-10-10-stbd.csv", "day_2_turning-35-port.csv"]
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == names
    assert (
        out[0] == f"wrote {tmp_path / 'out' / names[0]} (t = 0.00 to 1271.00 s, execute at 60.00 s)"
    )
    pieces = split_log(day, LENGTH_M).pieces
    for name, piece in zip(names, pieces, strict=True):
        log = read_log(tmp_path / "out" / name)
        assert log.metadata["vessel"] == "kvlcc2" and log.length_m == LENGTH_M
        np.testing.assert_allclose(log.x_m, day.x_m[piece.start : piece.stop], atol=1e-3)
        assert execute_index(log) == piece.execute - piece.start


def test_split_writes_nothing_when_an_input_is_unusable(
    day: ManeuverLog, turn: ManeuverLog, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_log(tmp_path / "day.csv", day)
    write_log(tmp_path / "straight.csv", log_piece(turn, 0, execute_index(turn)))
    out = tmp_path / "out"
    assert main(["split", str(tmp_path / "day.csv"), str(tmp_path / "straight.csv"),
                 "-o", str(out)]) == 1  # fmt: skip
    err = capsys.readouterr().err
    assert err.startswith(f"error: {tmp_path / 'straight.csv'}: no rudder command of 5 deg")
    assert err.count("\n") == 1 and not out.exists()
    assert main(["split", str(tmp_path / "day.csv"), "-o", str(tmp_path / "day.csv")]) == 2
    assert "expected a directory" in capsys.readouterr().err


@pytest.mark.parametrize("vessel", ["kvlcc2", "mariner", "tanker"])
def test_a_synthesized_trial_day_splits_into_its_zigzag_and_its_turn(vessel: str) -> None:
    """``synthesize --maneuver trial-day``: a 10/10 zig-zag, 400 s on the autopilot, a 35°
    port turn, 400 s on the autopilot, in one log of each reference ship (the autopilot's
    steadying after each manoeuvre takes the rudder to the other side)."""
    ship = reference_ship(vessel)
    _the_trial_days_manoeuvres(
        synthesize_log(ship, MANEUVERS["trial-day"](), seed=3), ship.length_m
    )


def test_glitches_of_a_trial_day_are_no_manoeuvre_and_name_none(tmp_path: Path) -> None:
    """``synthesize --maneuver trial-day --gnss-jump-pct 1 --compass-spike-pct 1``: a
    compass spike at a reversal named the zig-zag ``zigzag-10-12`` (its condition read off
    the raw headings), and ``crossval`` takes the check angle a file's name gives."""
    (path,) = synthesize_logs(
        tmp_path, ["trial-day"], gnss_jump_fraction=0.01, compass_spike_fraction=0.01
    )
    _the_trial_days_manoeuvres(read_log(path), LENGTH_M)


def _the_trial_days_manoeuvres(day: ManeuverLog, length_m: float) -> None:
    found = split_log(day, length_m)
    assert found.notes == ()
    logs = piece_logs(day, found, length_m)
    assert [manoeuvre_name(log) for log in logs] == ["zigzag-10-10-stbd", "turning-35-port"]
    assert found.pieces[0].execute == execute_index(day)
    assert all(log_problem(log, length_m) is None for log in logs)
