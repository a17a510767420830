"""Runs sailed at other times of the tide: a current per log (``--current per-log``), and a
drifting current that walks through the time between the runs.

The truth is the identified structure itself (the seed ship of ``tests.test_identify``),
each log moved by a uniform current of its own (exact for a uniform current), so that the
coefficients and every log's current have values to be recovered.
"""

from __future__ import annotations

import math
import re
from dataclasses import replace

import numpy as np
import pytest

from fmu_model import get_model
from identifier.cli.fit import _summary
from identifier.crossval import cross_validate, held_out_errors
from identifier.current import (
    CURRENT_DISAGREEMENT_MPS,
    CURRENT_MODES,
    PER_LOG,
    CurrentEstimate,
    current_disagreement,
    kept_current,
    water_segments,
    weighted_mean_current,
    with_approach_cross,
)
from identifier.ekf import ekf_identify
from identifier.identify import IdentificationResult, identify
from identifier.preparation import sailed_order
from identifier.smoothing import SmoothedTrack, smooth_track
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from tests.test_identify import SEED, TRAINING, _ship
from tests.test_identify_at_sea import _beyond_three_sigma, _with_current, _with_speed_log
from tests.test_streaming import _segment
from trials.conditions import execute_index
from trials.logs import ManeuverLog

# turning-35, zigzag-10, zigzag-20 (tests.test_identify.TRAINING), each in its own current:
# the flood, the ebb, and slack water turning (North, East) [m/s].
TIDES = np.array([[0.15, 0.26], [-0.20, -0.22], [0.05, -0.10]])


def _tracks(logs: list[ManeuverLog]) -> list[SmoothedTrack]:
    return [smooth_track(g.time_s, g.x_m, g.y_m, g.heading_rad) for g in logs]


def _given(name: str | None) -> int:
    """The place given of a log named by it ("log 2": 1)."""
    assert name is not None and name.startswith("log ")
    return int(name.split()[1]) - 1


@pytest.fixture(scope="module")
def calm_logs() -> list[ManeuverLog]:
    return [
        synthesize_log(_ship(), MANEUVERS[name](), seed=seed) for seed, name in enumerate(TRAINING)
    ]


@pytest.fixture(scope="module")
def tidal_logs(calm_logs: list[ManeuverLog]) -> list[ManeuverLog]:
    return [_with_current(g, c) for g, c in zip(calm_logs, TIDES, strict=True)]


@pytest.fixture(scope="module")
def per_log(tidal_logs: list[ManeuverLog]) -> IdentificationResult:
    return identify(tidal_logs, replace(SEED, current=PER_LOG))


@pytest.fixture(scope="module")
def one_current(tidal_logs: list[ManeuverLog]) -> IdentificationResult:
    return identify(tidal_logs, replace(SEED, current="constant"))


def test_per_log_is_a_mode_of_the_command_line() -> None:
    assert PER_LOG in CURRENT_MODES


def test_each_log_keeps_its_own_current(per_log: IdentificationResult) -> None:
    c = per_log.current
    assert c is not None and c.mode == PER_LOG and len(c.logs) == 3
    for own in c.logs:
        truth = TIDES[_given(own.log)]
        std = np.array(own.std_mps)
        assert np.all(np.abs(own.vector - truth) <= np.maximum(3.0 * std, 0.02)), (own, truth)
    assert sorted(_given(own.log) for own in c.logs) == [0, 1, 2]
    np.testing.assert_allclose(c.vectors(3), [e.vector for e in c.logs])
    env = per_log.params.identification["environment"]
    assert kept_current(per_log.params) == PER_LOG and [e["log"] for e in env["logs"]] == [
        e.log for e in c.logs
    ]
    assert env["logs"][0]["current_north_mps"] == c.logs[0].north_mps
    assert not any("different currents" in w for w in per_log.warnings)
    # Each current is told from its own log: the zig-zags' ±20° say little along the course.
    assert any(w.startswith("a log's headings span") for w in per_log.warnings)


def test_per_log_coefficients_are_the_ships_where_one_current_is_not(
    per_log: IdentificationResult, one_current: IdentificationResult
) -> None:
    assert _beyond_three_sigma(per_log) == []
    # One current for the three puts their difference into the hull (the test can fail).
    off = _beyond_three_sigma(one_current)
    assert off, "one current for logs in three should bias the hull"
    warning = [w for w in one_current.warnings if "different currents" in w]
    assert len(warning) == 1 and "--current per-log" in warning[0]
    assert not any("headings span" in w for w in one_current.warnings)  # the turn among them


def test_the_summary_lists_every_logs_current(per_log: IdentificationResult) -> None:
    lines = _summary(per_log).splitlines()
    mean = [line for line in lines if line.startswith("current (per-log, their mean)")]
    each = [line for line in lines if re.match(r"current \(per-log, [^)]+\): ", line)]
    assert len(mean) == 1 and len(each) == 4  # the mean's line matches the pattern too
    assert "the ± are the identification noise only" in mean[0]


def test_the_approaches_show_logs_in_other_currents(calm_logs: list[ManeuverLog]) -> None:
    """Every log's approach is on one heading: a current across it drifts the approach."""
    names = ["turn", "zz10", "zz20"]
    same = [_with_current(g, TIDES[0]) for g in calm_logs]
    assert current_disagreement(same, _tracks(same), names) == []
    ebb = [same[0], same[1], _with_current(calm_logs[2], TIDES[1])]
    found = current_disagreement(ebb, _tracks(ebb), names)
    assert any(f.startswith("zz20's approach drifts") for f in found), found
    drifts = [float(x) for x in re.findall(r"drifts ([+-]\d\.\d\d) m/s", "; ".join(found))]
    assert drifts and all(abs(d) > CURRENT_DISAGREEMENT_MPS for d in drifts)
    assert current_disagreement(ebb[:1], _tracks(ebb[:1]), names[:1]) == []  # one log


def test_a_ships_default_takes_a_current_per_log_where_the_logs_show_it(
    tidal_logs: list[ManeuverLog], per_log: IdentificationResult
) -> None:
    """No --current, a ship's logs in three currents: fitted per log, and a note says why;
    the same fit as per-log asked for."""
    default = identify(tidal_logs, replace(SEED, current=None))
    assert default.current is not None and default.current.mode == PER_LOG
    assert default.settings.current == PER_LOG
    note = [n for n in default.notes if n.startswith("the logs were sailed in different")]
    assert len(note) == 1 and "what the default and auto take where the logs show" in note[0]
    np.testing.assert_array_equal(default.params.coefficients, per_log.params.coefficients)
    assert not any("different currents" in w for w in default.warnings)


def test_the_speed_logs_show_a_current_along_the_approach(calm_logs: list[ManeuverLog]) -> None:
    """Currents that differ along the approach's heading alone: no drift across it, and
    only the speed logs show them."""
    heading = float(np.median(calm_logs[1].heading_rad[:20]))
    along = np.array([math.cos(heading), math.sin(heading)])
    names = ["zz10", "zz20"]
    zigzags = calm_logs[1:]
    flood = [_with_speed_log(_with_current(g, 0.3 * along), g, 0.0, i)
             for i, g in enumerate(zigzags)]  # fmt: skip
    assert current_disagreement(flood, _tracks(flood), names) == []
    ebb = [flood[0], _with_speed_log(_with_current(zigzags[1], -0.3 * along), zigzags[1], 0.0, 1)]
    without = [replace(g, stw_mps=None) for g in ebb]
    assert current_disagreement(without, _tracks(without), names) == []  # not across
    found = current_disagreement(ebb, _tracks(ebb), names)
    assert len(found) == 2 and all("speed log shows a current" in f for f in found), found
    off = re.findall(r"current (\d\.\d\d) m/s off the mean", "; ".join(found))
    # Each off the weighted mean (nearer the more precise log): apart by the 0.6 m/s.
    assert sum(float(x) for x in off) == pytest.approx(0.6, abs=0.05)


def test_each_logs_record_keeps_what_its_speed_log_showed(
    tidal_logs: list[ManeuverLog], calm_logs: list[ManeuverLog]
) -> None:
    """Per log with a speed log on one of them: that log's record holds the log alone and
    the EKF's view of it, the other's none."""
    logs = [_with_speed_log(tidal_logs[0], calm_logs[0]), tidal_logs[1]]
    result = identify(logs, replace(SEED, current=PER_LOG))
    assert result.current is not None
    records = {e["log"]: e for e in result.params.identification["environment"]["logs"]}
    with_log, without = records["log 1"], records["log 2"]
    assert with_log["speed_log"]["alone"]["samples"] == logs[0].n_samples
    assert with_log["speed_log"]["samples"] > 0  # the EKF measured it
    assert without["speed_log"] is None
    assert with_log["current_model_form_covariance_m2ps2"] != [[0.0, 0.0], [0.0, 0.0]]


def test_crossval_predicts_a_held_out_log_in_its_own_current(
    tidal_logs: list[ManeuverLog], calm_logs: list[ManeuverLog]
) -> None:
    """Trained per log, a held-out log with a speed log is taken in the current it shows;
    without one, in the training logs' mean (its note says which)."""
    held = _with_speed_log(tidal_logs[0], calm_logs[0])
    settings = replace(SEED, current=PER_LOG)
    fold = cross_validate(tidal_logs[1:], [held, tidal_logs[0]], settings)
    own, mean = fold.held_out
    match = re.fullmatch(
        r"predicted in its own current, as its speed log shows it, (\d\.\d+) m/s towards "
        r"(\d+) deg",
        own.notes[0],
    )
    assert match, own.notes
    assert float(match[1]) == pytest.approx(float(np.hypot(*TIDES[0])), abs=0.03)
    assert float(match[2]) == pytest.approx(60.0, abs=5.0)
    assert mean.notes[0].startswith(
        "predicted in the training logs' mean current, its component across the approach"
    )
    assert own.position_rms_m < 0.5 * mean.position_rms_m
    # The mean as it is, without what the approach shows across it: further off.
    fitted = identify(tidal_logs[1:], settings).current
    assert fitted is not None
    plain = replace(fitted, logs=())
    as_fitted = held_out_errors(fold.params, tidal_logs[0], current=plain)
    assert mean.position_rms_m < 0.75 * as_fitted.position_rms_m  # measured: 37 m against 70 m


def test_an_approach_shows_the_current_across_it(calm_logs: list[ManeuverLog]) -> None:
    log = _with_current(calm_logs[1], TIDES[0])
    (track,) = _tracks([log])
    guess = np.array([0.5, -0.5])
    shown = with_approach_cross(guess, log, track)
    end = execute_index(log)
    heading = math.atan2(
        float(np.mean(np.sin(track.heading_rad[:end]))),
        float(np.mean(np.cos(track.heading_rad[:end]))),
    )
    along = np.array([math.cos(heading), math.sin(heading)])
    across = np.array([-math.sin(heading), math.cos(heading)])
    assert shown @ along == pytest.approx(guess @ along, abs=1e-3)  # the guess's, kept
    assert shown @ across == pytest.approx(TIDES[0] @ across, abs=0.02)  # the approach's
    at_once = replace(log, metadata={**log.metadata, "execute_time_s": repr(float(log.time_s[0]))})
    np.testing.assert_array_equal(with_approach_cross(guess, at_once, track), guess)  # none


def test_the_weighted_mean_of_two_currents_by_hand() -> None:
    """Inverse-variance weights per component: σ² 1 and 3 weigh 3:1."""
    currents = np.array([[1.0, 0.0], [0.0, 2.0]])
    covariances = np.array([np.diag([1.0, 3.0]), np.diag([3.0, 1.0])])
    mean, covariance = weighted_mean_current(currents, covariances)
    np.testing.assert_allclose(mean, [0.75, 1.5])
    np.testing.assert_allclose(covariance, np.diag([0.75, 0.75]))


def test_vectors_and_water_segments_take_a_current_per_log(
    per_log: IdentificationResult, tidal_logs: list[ManeuverLog]
) -> None:
    c = per_log.current
    assert c is not None
    with pytest.raises(ValueError, match="a current for 3 logs, asked for 2"):
        c.vectors(2)
    one = CurrentEstimate(0.1, 0.2, np.eye(2), "constant", 1)
    np.testing.assert_array_equal(one.vectors(3), [[0.1, 0.2]] * 3)
    segments, tracks = [_segment(g) for g in tidal_logs], _tracks(tidal_logs)
    each = water_segments(segments, tracks, TIDES)
    for i, seg in enumerate(each):
        (alone,) = water_segments([segments[i]], [tracks[i]], TIDES[i])
        np.testing.assert_array_equal(seg.velocities, alone.velocities)
        assert not np.array_equal(seg.velocities, segments[i].velocities)


def test_the_ekf_takes_one_current_or_one_per_segment(
    per_log: IdentificationResult, tidal_logs: list[ManeuverLog]
) -> None:
    ekf = per_log.ekf
    assert ekf.current is not None and ekf.current_covariance is not None
    assert ekf.current.shape == (3, 2) and ekf.current_covariance.shape == (3, 2, 2)
    structure = get_model(per_log.params.model)
    segments = [_segment(g) for g in tidal_logs]
    ls = per_log.equation_error
    with pytest.raises(ValueError, match=r"current0 must have shape \(2,\) or \(3, 2\)"):
        ekf_identify(
            structure, segments, ls.theta, ls.covariance, per_log.params.length_m,
            current0=np.zeros((2, 2)), current_covariance0=np.eye(2),
        )  # fmt: skip


def _at(log: ManeuverLog, origin: str) -> ManeuverLog:
    return replace(log, metadata={**log.metadata, "time_origin_utc": origin})


def test_the_logs_sailed_order_and_the_time_between_them(calm_logs: list[ManeuverLog]) -> None:
    """By their time origins: the turn at 10:00, the zig-zags at 08:00 and 12:30."""
    turn, zz10, zz20 = calm_logs
    timed = [_at(turn, "2024-05-17T10:00:00Z"), _at(zz10, "2024-05-17T08:00:00Z"),
             _at(zz20, "2024-05-17T14:30:00+02:00")]  # fmt: skip
    order, gaps = sailed_order(timed)
    assert order == [1, 0, 2]
    end_zz10 = float(zz10.time_s[-1])  # its first sample is at 0 s
    assert gaps[0] == 0.0
    assert gaps[1] == pytest.approx(2 * 3600.0 + float(turn.time_s[0]) - end_zz10)
    assert gaps[2] == pytest.approx(2.5 * 3600.0 - float(turn.time_s[-1]))
    assert sailed_order([timed[0], zz10, timed[2]]) == ([0, 1, 2], [0.0, 0.0, 0.0])  # not all


def test_a_drifting_current_walks_through_the_hours_between_the_runs(
    calm_logs: list[ManeuverLog],
) -> None:
    """--current drifting, the last log sailed five and a half hours later in a current
    0.6 m/s stronger to the East: with their times the walk between the runs (σ 0.2 m/s in
    an hour, 0.47 over the gap) lets the current follow; without them the last log (6.5
    min) must pull it there alone, at 0.2 m/s an hour (measured: 0.07 against 0.28 m/s)."""
    later = TIDES[0] + np.array([0.0, 0.6])
    logs = [_with_current(g, TIDES[0]) for g in calm_logs[:2]]
    logs.append(_with_current(calm_logs[2], later))
    settings = replace(SEED, current="drifting")
    untimed = identify(logs, settings)
    origins = ["2024-05-17T08:00:00Z", "2024-05-17T08:30:00Z", "2024-05-17T14:00:00Z"]
    timed_logs = [_at(g, o) for g, o in zip(logs, origins, strict=True)]
    timed = identify(timed_logs, settings)
    assert untimed.current is not None and timed.current is not None
    assert np.linalg.norm(timed.current.vector - later) < 0.1
    assert np.linalg.norm(untimed.current.vector - later) > 0.2
    # Given in another order, run in the order sailed: the same estimate, and a note.
    shuffled = identify([timed_logs[2], timed_logs[0], timed_logs[1]], settings)
    assert shuffled.current is not None
    np.testing.assert_allclose(shuffled.current.vector, timed.current.vector, atol=1e-9)
    assert any(
        n.startswith("the EKF runs through the logs in the order sailed") for n in shuffled.notes
    )


def test_a_models_auto_takes_a_current_per_log_where_the_logs_show_it() -> None:
    """A 7 m model (or a small craft) at 5 Hz, its two zig-zags in 0.2 m/s setting to 045
    and to 225: auto (its default) fits per log, not one current nor still water, and
    finds each log's."""
    ship = reference_ship("kvlcc2", "model")
    tides = 0.2 * np.array([[1.0, 1.0], [-1.0, -1.0]]) / math.sqrt(2.0)
    logs = [
        _with_current(
            synthesize_log(ship, MANEUVERS[name](), rate_hz=5.0, position_noise_m=0.01,
                           heading_noise_deg=0.05, seed=seed),
            tide,
        )
        for seed, (name, tide) in enumerate(zip(("zigzag-10", "zigzag-20"), tides, strict=True))
    ]  # fmt: skip
    result = identify(logs, replace(SEED, model="prime-rudder-offset", current=None))
    assert result.settings.current == PER_LOG and result.current is not None
    assert result.current_choice is None  # no comparison with still water was needed
    for own in result.current.logs:
        np.testing.assert_allclose(own.vector, tides[_given(own.log)], atol=0.01)
