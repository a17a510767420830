"""Identification at sea: a uniform current estimated with the coefficients, a measured wind
taken out (issue 14). The truth here is the identified structure itself (the seed ship), so
that the coefficients and the current have exact values to be recovered."""

from __future__ import annotations

import json
import math
import re
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fmu_model import simulate
from fmu_model.environment import Windage, apparent_wind
from identifier import identify as identify_module
from identifier.cli import main
from identifier.crossval import cross_validate, held_out_errors
from identifier.current import (
    CURRENT_TOLERANCE_MPS,
    CURRENT_TOLERANCE_SIGMAS,
    SHAPE_PASSES,
    CurrentEstimate,
    SpeedLogFit,
    approach_course,
    current_model_form,
    current_tolerance_mps,
    heading_span_rad,
    huber_loss,
    initial_current,
    speed_log_current,
    speed_log_noise_mps,
    water_frame,
    water_segments,
)
from identifier.ekf import body_current
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.smoothing import smooth_log, smooth_track
from identifier.wind import known_acceleration, mean_true_wind_ne, read_windage
from scenarios.kvlcc2 import kvlcc2_windage
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from tests.test_identify import RUDDER_RATE, SEED, TRAINING, _ship, _truth
from trials.conditions import execute_index, maneuver_kind
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, write_log
from trials.maneuvers import zigzag
from trials.run import ModelPlant, run_program

CURRENT_NE = np.array([0.15, 0.26])  # 0.3 m/s towards 60 deg
# A 100 m ship with a tall superstructure (areas of a car carrier of that length), so that a
# 20 m/s wind matters: X, Y, N of some 1 %, 5 %, 5 % of the hull's in a zig-zag.
WINDAGE = Windage(
    frontal_area_m2=400.0,
    lateral_area_m2=1800.0,
    length_overall_m=105.0,
    lateral_centroid_m=-5.0,
    surge_mass_kg=6.0e6,
    sway_mass_kg=1.0e7,
    yaw_inertia_kgm2=6.0e9,
)
WIND_SPEED_MPS = 20.0
WIND_FROM_RAD = math.radians(90.0)


def _with_current(log: ManeuverLog, current_ne: np.ndarray) -> ManeuverLog:
    """The log of the same run in a uniform current: the track moves by c·t (exact)."""
    elapsed = log.time_s - log.time_s[0]
    return replace(
        log, x_m=log.x_m + current_ne[0] * elapsed, y_m=log.y_m + current_ne[1] * elapsed
    )


@pytest.fixture(scope="module")
def calm_logs() -> list[ManeuverLog]:
    return [
        synthesize_log(_ship(), MANEUVERS[name](), seed=seed) for seed, name in enumerate(TRAINING)
    ]


@pytest.fixture(scope="module")
def in_current(calm_logs: list[ManeuverLog]) -> IdentificationResult:
    return identify([_with_current(log, CURRENT_NE) for log in calm_logs], SEED)


@pytest.fixture(scope="module")
def in_current_ignored(calm_logs: list[ManeuverLog]) -> IdentificationResult:
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs]
    return identify(logs, replace(SEED, current="none"))


def test_current_is_recovered_within_its_uncertainty(in_current: IdentificationResult) -> None:
    c = in_current.current
    assert c is not None and c.mode == "constant"
    std = np.array(c.std_mps)
    assert np.all(np.abs(c.vector - CURRENT_NE) <= np.maximum(3.0 * std, 0.01)), (c, std)
    assert abs(c.speed_mps - 0.3) < 0.02
    assert abs(math.degrees(c.to_rad) - 60.0) < 3.0
    assert not any("a model's size" in w for w in in_current.warnings)  # a ship at sea
    env = in_current.params.identification["environment"]
    assert env["current"] == "constant"
    assert env["current_north_mps"] == pytest.approx(c.north_mps)
    assert env["current_east_std_mps"] == pytest.approx(std[1])


def _beyond_three_sigma(result: IdentificationResult) -> list[str]:
    """The identifiable coefficients more than 3σ from the seed ship's (the truth)."""
    truth = dict(SEED_COEFFICIENTS)
    return [
        c.name
        for c in result.coefficients
        if c.identifiable and abs(c.value - truth[c.name]) > 3.0 * c.std
    ]


def test_coefficients_in_a_current_are_the_ships(
    in_current: IdentificationResult, in_current_ignored: IdentificationResult
) -> None:
    truth = dict(SEED_COEFFICIENTS)
    assert _beyond_three_sigma(in_current) == []
    # The same logs fitted as still water: the current goes into the hull (the test can fail).
    ignored = {c.name: c for c in in_current_ignored.coefficients}
    assert in_current_ignored.current is None
    assert in_current_ignored.params.identification["environment"] == {"current": "none"}
    biased = [
        name
        for name in ("b1", "c1", "c2", "c3")
        if abs(ignored[name].value - truth[name]) > 3.0 * ignored[name].std
    ]
    assert biased, "ignoring a 0.3 m/s current should bias the sway/yaw coefficients"


def test_auto_keeps_a_current_the_logs_show(
    calm_logs: list[ManeuverLog], in_current: IdentificationResult
) -> None:
    """--current auto: the fit with the current predicts the training tracks
    better than the still-water one, whose hull took the current in, and is kept as it is."""
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs]
    auto = identify(logs, replace(SEED, current="auto"))
    choice = auto.current_choice
    assert choice is not None and choice.kept == "constant"
    assert choice.track_rms_m["none"] > 2.0 * choice.track_rms_m["constant"], choice
    np.testing.assert_array_equal(auto.params.to_vector(), in_current.params.to_vector())
    assert auto.current is not None and auto.current.north_mps == in_current.current.north_mps
    env = auto.params.identification["environment"]
    assert env["current"] == "constant" and env["current_choice"]["kept"] == "constant"
    assert env["current_choice"]["track_rms_m"]["none"] == choice.track_rms_m["none"]
    assert auto.settings.current == "auto"


def test_auto_with_a_speed_log_fits_the_current_alone(
    calm_logs: list[ManeuverLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A speed log measures the current: auto fits with one, and no still-water fit; a
    speed log refused as broken does not decide."""
    logs = [
        _with_speed_log(_with_current(g, CURRENT_NE), g, 0.0, i) for i, g in enumerate(calm_logs)
    ]
    modes: list[str] = []
    fit = identify_module._fit_thrust_ruled

    def counted(data: Any, settings: FitSettings, *args: Any, **kwargs: Any) -> Any:
        modes.append(settings.current)
        return fit(data, settings, *args, **kwargs)

    monkeypatch.setattr(identify_module, "_fit_thrust_ruled", counted)
    auto = identify(logs, replace(SEED, current="auto"))
    assert modes == ["constant"]
    assert auto.current_choice is not None and auto.current_choice.track_rms_m == {}
    assert "speed log" in auto.current_choice.reason
    assert auto.current is not None and auto.current.speed_log_ekf is not None
    # A speed log refused as broken (twice the speed: a scale error of +100 %) measures
    # nothing: the two fits are compared as without one.
    broken = [
        _with_speed_log(_with_current(log, CURRENT_NE), log, 1.0, i)
        for i, log in enumerate(calm_logs)
    ]
    modes.clear()
    auto = identify(broken, replace(SEED, current="auto"))
    assert modes == ["constant", "none"]
    assert auto.current is not None and auto.current.speed_log_ignored is not None
    assert auto.current_choice is not None
    assert set(auto.current_choice.track_rms_m) == {"constant", "none"}


def test_a_drifting_current_follows_a_change(calm_logs: list[ManeuverLog]) -> None:
    """--current drifting: the last log is sailed in a current 0.2 m/s stronger to the East."""
    later = CURRENT_NE + np.array([0.0, 0.2])
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs[:2]]
    logs.append(_with_current(calm_logs[2], later))
    drifting = identify(logs, replace(SEED, current="drifting"))
    constant = identify(logs, SEED)
    assert drifting.current is not None and constant.current is not None
    assert drifting.current.mode == "drifting"
    # The drifting estimate (at the end of the last log) is nearer the later current.
    assert np.linalg.norm(drifting.current.vector - later) < np.linalg.norm(
        constant.current.vector - later
    )


def test_a_diverging_alternation_pass_keeps_the_last_settled_start(
    calm_logs: list[ManeuverLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A pass of the current's alternation that diverges stops it; the first one raises
    (when no start along the course settles either: every pass diverges here).

    (Seen on the batch benchmark's demo ship: from the current one pass moved to, the
    next pass diverged, and with it the whole default fit.) The estimate's pass then
    starts where the last pass that converged started.
    """
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs]
    starts: list[np.ndarray | None] = []
    run_ekf = identify_module._run_ekf

    def third_pass_diverges(*args: Any, **kwargs: Any) -> Any:
        prior = args[6] if len(args) > 6 else kwargs.get("current_prior")
        starts.append(None if prior is None else prior[0])  # the pass's starting current
        if len(starts) == 3:
            raise IdentificationError("state or covariance became non-finite", log="x")
        return run_ekf(*args, **kwargs)

    monkeypatch.setattr(identify_module, "_run_ekf", third_pass_diverges)
    result = identify(logs, SEED)
    assert result.current is not None and result.current.iterations == 2
    assert len(starts) == 4  # two settled passes, the diverged one, the last (estimate)
    np.testing.assert_array_equal(starts[3], starts[1])  # where the last converged one began
    np.testing.assert_allclose(result.current.vector, CURRENT_NE, atol=0.05)

    def first_pass_diverges(*args: Any, **kwargs: Any) -> Any:
        raise IdentificationError("state or covariance became non-finite", log="x")

    monkeypatch.setattr(identify_module, "_run_ekf", first_pass_diverges)
    with pytest.raises(IdentificationError, match="non-finite"):
        identify(logs, SEED)


def test_a_current_that_does_not_settle_keeps_the_last_pass_the_ekf_followed(
    calm_logs: list[ManeuverLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    """(A Mariner fit from one turning circle: the current wandered some 0.05 m/s at the
    level of its noise for all 30 passes, and the estimate's pass, started where the last
    pass had moved it, a start no pass had run from, diverged at sample 20: the fit
    failed.) With a tolerance no pass meets, the estimate's pass starts where the last
    alternation pass started, and a note says so."""
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs]
    starts: list[np.ndarray] = []
    run_ekf = identify_module._run_ekf

    def recorded(*args: Any, **kwargs: Any) -> Any:
        starts.append(np.array(args[6]))  # the pass's starting current
        return run_ekf(*args, **kwargs)

    monkeypatch.setattr(identify_module, "_run_ekf", recorded)
    monkeypatch.setattr(identify_module, "current_tolerance_mps", lambda covariance: 0.0)
    monkeypatch.setattr(identify_module, "MAX_CURRENT_ITERATIONS", 2)
    result = identify(logs, SEED)
    assert len(starts) == 2 * SHAPE_PASSES + 1  # the alternation's passes, the estimate's
    np.testing.assert_array_equal(starts[-1], starts[-2])
    assert not np.array_equal(starts[-2], starts[-3])  # each pass moved it
    assert any(
        re.fullmatch(
            rf"current: not settled after {2 * SHAPE_PASSES} EKF passes \(the last moved it "
            r"0\.\d{3} m/s, more than its tolerance\): the last pass's start is kept, which "
            r"the EKF followed; the logs barely determine the current",
            note,
        )
        for note in result.notes
    ), result.notes
    assert result.current is not None
    np.testing.assert_allclose(result.current.vector, CURRENT_NE, atol=0.05)


def test_alternation_tolerance_follows_the_estimate_uncertainty() -> None:
    assert current_tolerance_mps(np.diag([1e-8, 1e-8])) == CURRENT_TOLERANCE_MPS
    assert current_tolerance_mps(np.diag([0.04**2, 0.01**2])) == pytest.approx(
        CURRENT_TOLERANCE_SIGMAS * 0.04
    )


def test_calm_logs_give_no_current(calm_logs: list[ManeuverLog]) -> None:
    result = identify(calm_logs, SEED)
    assert result.current is not None
    assert result.current.speed_mps < max(3.0 * max(result.current.std_mps), 0.01)


def test_narrow_headings_warn_that_the_current_is_barely_separable(
    calm_logs: list[ManeuverLog],
) -> None:
    result = identify(calm_logs[1:], SEED)  # the zig-zags: headings within ±40 deg
    assert any("barely told apart" in w for w in result.warnings)
    assert not any("barely told apart" in w for w in identify(calm_logs, SEED).warnings)


def test_velocities_through_the_water_and_the_water_frame(calm_logs: list[ManeuverLog]) -> None:
    log = _with_current(calm_logs[0], CURRENT_NE)
    track = smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
    # Heading 90 deg (East): a current to the North is 1 m/s from port, c_v = -1.
    assert body_current(np.array([1.0, 0.0]), math.pi / 2) == pytest.approx([0.0, -1.0])
    moved, moved_track = water_frame(log, track, CURRENT_NE)
    calm = calm_logs[0]
    assert np.allclose(moved.x_m, calm.x_m, atol=1e-9)
    assert np.allclose(moved.y_m, calm.y_m, atol=1e-9)
    calm_track = smooth_track(calm.time_s, calm.x_m, calm.y_m, calm.heading_rad)
    # Smoothing is linear: the moved track is the calm one's to rounding.
    assert np.allclose(moved_track.u_mps, calm_track.u_mps, atol=1e-6)
    assert np.allclose(moved_track.v_mps, calm_track.v_mps, atol=1e-6)
    assert np.allclose(moved_track.x_m, calm_track.x_m, atol=1e-6)
    from identifier.ekf import EkfSegment

    segment = EkfSegment(
        name="s",
        time_s=log.time_s,
        velocities=np.column_stack([track.u_mps, track.v_mps, track.r_radps]),
        velocity_std=np.ones((log.n_samples, 3)),
        track=np.column_stack([log.x_m, log.y_m, log.heading_rad]),
        track_std=np.ones(3),
        initial_track=np.zeros(3),
        rudder_rad=log.rudder_rad,
        n_rps=log.n_rps,
    )
    (water,) = water_segments([segment], [track], CURRENT_NE)
    assert np.allclose(water.velocities[:, 0], calm_track.u_mps, atol=1e-6)
    assert np.allclose(water.velocities[:, 1], calm_track.v_mps, atol=1e-6)
    assert heading_span_rad([calm_track]) > math.radians(350.0)  # a turning circle


def test_a_start_the_ekf_cannot_follow_is_retried_along_the_course(
    calm_logs: list[ManeuverLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The approaches (heading North) show the current's East part, not its North part,
    and the alternation starts with none North. Where the EKF diverges from that start
    (here: made to, as it did on the Mariner in 1 m/s, ``test_mariner``), it starts again
    ∓ and ± 10 % of the approach speed along the course, keeps the start whose EKF
    follows the track closest, and says so; the current comes out as from the truth."""
    logs = [_with_current(log, CURRENT_NE) for log in calm_logs]
    run_ekf = identify_module._run_ekf
    starts: list[np.ndarray] = []

    def the_approaches_start_diverges(*args: Any, **kwargs: Any) -> Any:
        prior = np.asarray(args[6])
        starts.append(prior)
        if abs(prior[0]) < 0.01:  # (nearly) none along the course: the approaches' start
            raise IdentificationError("state or covariance became non-finite", log="x")
        return run_ekf(*args, **kwargs)

    monkeypatch.setattr(identify_module, "_run_ekf", the_approaches_start_diverges)
    result = identify(logs, SEED)
    assert result.current is not None
    np.testing.assert_allclose(result.current.vector, CURRENT_NE, atol=0.05)
    (note,) = [n for n in result.notes if n.startswith("current: the EKF diverged")]
    assert "started again 10% of the approach speed along it either way" in note
    # the approaches' start, then an alternation from each side of it along North
    assert abs(starts[0][0]) < 0.01 and starts[0][1] == pytest.approx(CURRENT_NE[1], abs=0.02)
    along = starts[1] - starts[0]
    assert along[0] < -0.1 and abs(along[1]) < 0.01 * abs(along[0])
    assert any(np.allclose(start, starts[0] - along, rtol=0, atol=1e-12) for start in starts[2:])


def test_the_approach_shows_the_cross_current(calm_logs: list[ManeuverLog]) -> None:
    """The alternation starts from the straight approaches: their drift is c's cross part."""
    log = _with_current(calm_logs[1], CURRENT_NE)  # a zig-zag, approach heading North
    track = smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
    start = initial_current([log], [track])
    # Heading North: the cross component is c_E; the along one is not seen (minimum norm).
    assert start[1] == pytest.approx(CURRENT_NE[1], abs=0.02)
    assert start[0] == pytest.approx(0.0, abs=1e-3)
    # ... which is the approach's course, North
    course = approach_course([log], [track])
    assert course is not None
    np.testing.assert_allclose(course, [1.0, 0.0], atol=1e-3)


def _with_speed_log(
    log: ManeuverLog,
    calm: ManeuverLog,
    scale_error: float = 0.0,
    seed: int = 3,
    two_axis: bool = False,
    log_x_m: float = 0.0,
) -> ManeuverLog:
    """``log`` with a speed log: (1 + k) times the calm run's surge speed, 0.05 m/s of noise.

    Smoothing is linear, so the calm log's smoothed surge speed is the current log's less
    the current's forward component: u_w of the model's equation, to rounding. ``two_axis``:
    its transverse axis too, (1 + k)(v_w + x_L r) at ``log_x_m`` forward of midship (its
    metadata ``speed_log_x_m``), with noise of its own.
    """
    calm_track = smooth_track(calm.time_s, calm.x_m, calm.y_m, calm.heading_rad)
    noise = np.random.default_rng(seed).normal(0.0, 0.05, (2, log.n_samples))
    stw = np.abs((1.0 + scale_error) * calm_track.u_mps + noise[0])
    if not two_axis:
        return replace(log, stw_mps=stw)
    at_log = calm_track.v_mps + log_x_m * calm_track.r_radps
    return replace(
        log,
        stw_mps=stw,
        stw_transverse_mps=(1.0 + scale_error) * at_log + noise[1],
        metadata={**log.metadata, "speed_log_x_m": repr(log_x_m)},
    )


def test_a_speed_log_shows_the_current_and_its_scale_error(calm_logs: list[ManeuverLog]) -> None:
    """stw = (1 + k)(u_g − c_u(ψ)): a zig-zag's heading and speed changes show c and k."""
    zigzags = calm_logs[1:]  # headings within ±40 deg of North, one rpm
    logs = [
        _with_speed_log(_with_current(g, CURRENT_NE), g, 0.015, i) for i, g in enumerate(zigzags)
    ]
    tracks = [smooth_track(g.time_s, g.x_m, g.y_m, g.heading_rad) for g in logs]
    assert speed_log_current(zigzags, tracks) is None  # no log carries stw_mps
    fit = speed_log_current(logs, tracks)
    assert fit is not None and fit.samples == sum(g.n_samples for g in logs)
    std = np.sqrt(np.diag(fit.covariance))
    assert np.all(np.abs(fit.current_ne - CURRENT_NE) <= 3.0 * std), (fit, std)
    assert abs(fit.scale_error - 0.015) <= 3.0 * fit.scale_error_std
    # The logs narrow the 1 % prior: the scale error's σ, and the along (North) component's
    # against the 0.05 m/s that 1 % of this ship's 5 m/s would leave it.
    assert std[0] < 0.7 * 0.05 and fit.scale_error_std < 0.7 * 0.01
    assert fit.noise_mps == pytest.approx(0.05, rel=0.3)
    # Spikes and drop-outs on 1 % of the samples (aerated water): one bad sample each.
    rng = np.random.default_rng(11)
    glitched = []
    for log in logs:
        assert log.stw_mps is not None
        bad = rng.choice(log.n_samples, size=max(1, log.n_samples // 100), replace=False)
        stw = log.stw_mps.copy()
        stw[bad] = np.where(np.arange(bad.size) % 2 == 0, 0.0, 2.0 * stw[bad])
        glitched.append(replace(log, stw_mps=stw))
    robust = speed_log_current(glitched, tracks)
    assert robust is not None
    assert np.all(np.abs(robust.current_ne - fit.current_ne) <= 0.5 * std), (robust, fit)
    assert robust.noise_mps == pytest.approx(fit.noise_mps, rel=0.1)
    assert fit.implausible() is None
    assert "scale error is +20 %" in str(replace(fit, scale_error=0.2).implausible())
    # A log taken as exact (prior σ 1e-6) puts its 1.5 % into the current along the course.
    exact = speed_log_current(logs, tracks, scale_std=1e-6)
    assert exact is not None and abs(exact.scale_error) < 1e-5
    assert CURRENT_NE[0] - exact.current_ne[0] > 0.05  # a log 1.5 % fast: c_u = u_g − stw


def test_a_two_axis_log_shows_the_current_across_the_course_too(
    calm_logs: list[ManeuverLog],
) -> None:
    """stw_t = (1 + k)(v_g − c_v(ψ)): the transverse axis measures the cross component."""
    zigzags = calm_logs[1:]  # headings near North: the cross component is East
    one, two = (
        [_with_speed_log(_with_current(g, CURRENT_NE), g, 0.015, i, axes == 2)
         for i, g in enumerate(zigzags)]
        for axes in (1, 2)
    )  # fmt: skip
    tracks = [smooth_track(g.time_s, g.x_m, g.y_m, g.heading_rad) for g in two]
    along, both = speed_log_current(one, tracks), speed_log_current(two, tracks)
    assert along is not None and both is not None
    assert (along.transverse_samples, along.transverse_noise_mps) == (0, None)
    assert both.transverse_samples == both.samples == sum(g.n_samples for g in two)
    assert both.transverse_noise_mps == pytest.approx(0.05, rel=0.3)
    std = np.sqrt(np.diag(both.covariance))
    assert np.all(np.abs(both.current_ne - CURRENT_NE) <= 3.0 * std), (both, std)
    assert abs(both.scale_error - 0.015) <= 3.0 * both.scale_error_std
    # The cross (East) component is measured sample by sample, not inferred from the
    # heading changes: its σ narrows to less than half the single axis'.
    assert std[1] < 0.5 * math.sqrt(along.covariance[1, 1])
    assert both.as_dict()["transverse_samples"] == both.samples
    # A log with the transverse axis and one without: each axis of the samples it has.
    mixed = speed_log_current([two[0], one[1]], tracks)
    assert mixed is not None and mixed.transverse_samples == two[0].n_samples


def test_a_two_axis_log_forward_measures_the_yaw_rate_there(calm_logs: list[ManeuverLog]) -> None:
    """At 0.4 L forward a zig-zag's yaw rate adds up to 1 m/s: modelled, not a current."""
    zigzags = calm_logs[1:]
    length_m = zigzags[0].length_m
    assert length_m is not None
    bow = 0.4 * length_m
    logs = [
        _with_speed_log(_with_current(g, CURRENT_NE), g, 0.0, i, True, bow)
        for i, g in enumerate(zigzags)
    ]
    tracks = [smooth_track(g.time_s, g.x_m, g.y_m, g.heading_rad) for g in logs]
    assert max(bow * float(np.max(np.abs(t.r_radps))) for t in tracks) > 0.5
    fit = speed_log_current(logs, tracks)
    assert fit is not None
    std = np.sqrt(np.diag(fit.covariance))
    assert np.all(np.abs(fit.current_ne - CURRENT_NE) <= 3.0 * std), (fit, std)
    # Taken as amidships, the yaw rate's share becomes the log's noise: ten times as much.
    amidships = [replace(g, metadata={**g.metadata, "speed_log_x_m": "0.0"}) for g in logs]
    wrong = speed_log_current(amidships, tracks)
    assert wrong is not None and wrong.transverse_noise_mps is not None
    assert fit.transverse_noise_mps is not None
    assert wrong.transverse_noise_mps > 5.0 * fit.transverse_noise_mps
    result = identify(logs, SEED)
    assert result.current is not None and result.current.speed_log_ekf is not None
    assert result.current.speed_log_ekf.transverse_rejected == 0
    std = np.array(result.current.std_mps)
    assert np.all(np.abs(result.current.vector - CURRENT_NE) <= np.maximum(3.0 * std, 0.01))
    # Without its position the transverse axis is not used, and the fit says so.
    unplaced = [
        replace(g, metadata={k: v for k, v in g.metadata.items() if k != "speed_log_x_m"})
        for g in logs
    ]
    with pytest.raises(ValueError, match="stw_transverse_mps without speed_log_x_m"):
        speed_log_current(unplaced, tracks)
    blind = identify(unplaced, SEED)
    assert blind.current is not None and blind.current.speed_log_ekf is not None
    assert blind.current.speed_log_ekf.transverse_samples == 0
    assert sum("transverse axis (stw_transverse_mps) was not used" in w
               for w in blind.warnings) == len(logs)  # fmt: skip


def test_still_water_says_the_speed_log_is_not_used(
    calm_logs: list[ManeuverLog], in_current_ignored: IdentificationResult
) -> None:
    zigzags = calm_logs[1:]
    logs = [_with_speed_log(g, g, 0.0, i) for i, g in enumerate(zigzags)]
    still = identify(logs, replace(SEED, current="none"))
    unused = "the speed log (stw_mps) is measured with a current only: not used here"
    assert f"{unused} (--current none)" in still.notes
    assert not any(unused in note for note in in_current_ignored.notes)  # no log, no note


def test_the_huber_loss_of_the_speed_log_fit_has_a_threshold_per_residual() -> None:
    """ρ(z) = z within t², 2t√z − t² beyond; ρ' and ρ'' its derivatives (finite differences)."""
    threshold = np.array([1.0, 0.5, 2.0, np.inf])
    z = np.array([0.25, 0.81, 9.0, 1e6])
    rho = huber_loss(threshold)(z)
    np.testing.assert_allclose(rho[0], [0.25, 2 * 0.5 * 0.9 - 0.25, 2 * 2.0 * 3.0 - 4.0, 1e6])
    step = 1e-6 * z
    slope = (huber_loss(threshold)(z + step)[0] - huber_loss(threshold)(z - step)[0]) / (2 * step)
    np.testing.assert_allclose(rho[1], slope, rtol=1e-6)
    curve = (huber_loss(threshold)(z + step)[1] - huber_loss(threshold)(z - step)[1]) / (2 * step)
    np.testing.assert_allclose(rho[2], curve, rtol=1e-4, atol=1e-9)


def test_the_ekf_measures_a_two_axis_log(calm_logs: list[ManeuverLog]) -> None:
    """Both axes measured, spikes on either gated out; the cross component narrows."""
    zigzags = calm_logs[1:]
    one, two = (
        [_with_speed_log(_with_current(g, CURRENT_NE), g, 0.0, i, axes == 2)
         for i, g in enumerate(zigzags)]
        for axes in (1, 2)
    )  # fmt: skip
    single, double = identify(one, SEED), identify(two, SEED)
    assert single.current is not None and double.current is not None
    in_ekf = double.current.speed_log_ekf
    assert in_ekf is not None and single.current.speed_log_ekf is not None
    assert single.current.speed_log_ekf.transverse_noise_mps is None
    measured = sum(g.n_samples - 1 for g in two)
    assert (in_ekf.samples, in_ekf.transverse_samples, in_ekf.transverse_rejected) == (
        measured,
        measured,
        0,
    )
    # the 0.05 m/s added, and the wobble of the smoothed sway speed it was added to
    assert in_ekf.transverse_noise_mps is not None
    assert 0.045 < in_ekf.transverse_noise_mps < 0.1
    std = np.array(double.current.std_mps)
    assert np.all(np.abs(double.current.vector - CURRENT_NE) <= np.maximum(3.0 * std, 0.01))
    assert double.current.covariance[1, 1] < 0.5 * single.current.covariance[1, 1]
    record = double.params.identification["environment"]["speed_log"]
    assert record["transverse_samples"] == measured and record["transverse_rejected_samples"] == 0
    # Spikes on 1 % of the transverse samples: gated out one by one.
    glitched, bad_samples = _spiked(
        two, "stw_transverse_mps", lambda z, odd: z + np.where(odd, -3.0, 3.0), 12
    )
    spiky = identify(glitched, SEED)
    assert spiky.current is not None and spiky.current.speed_log_ekf is not None
    assert spiky.current.speed_log_ekf.transverse_rejected == bad_samples > 0
    assert np.all(np.abs(spiky.current.vector - double.current.vector) <= 0.5 * std)


def test_the_ekf_measures_a_speed_log(calm_logs: list[ManeuverLog]) -> None:
    """From zig-zags alone, a speed log pins the current along the course the track barely shows."""
    zigzags = calm_logs[1:]
    logs = [_with_speed_log(_with_current(g, CURRENT_NE), g, 0.0, i) for i, g in enumerate(zigzags)]
    track_only = identify([_with_current(g, CURRENT_NE) for g in zigzags], SEED)
    with_log = identify(logs, SEED)
    assert track_only.current is not None and with_log.current is not None
    assert track_only.current.speed_log is None and with_log.current.speed_log is not None
    # the identification σ: the log's own (the model-form term below is its distance to the EKF)
    assert with_log.current.covariance[0, 0] < 0.75**2 * track_only.current.covariance[0, 0]
    assert not np.any(track_only.current.model_form)  # no second estimate without a log
    alone = with_log.current.speed_log
    assert alone is not None
    d = with_log.current.vector - alone.current_ne
    np.testing.assert_allclose(with_log.current.model_form, np.outer(d, d), rtol=1e-12)
    std = np.array(with_log.current.std_mps)
    assert np.all(np.abs(with_log.current.vector - CURRENT_NE) <= np.maximum(3.0 * std, 0.01))
    assert not any("barely told apart" in w for w in with_log.warnings)
    in_ekf = with_log.current.speed_log_ekf
    assert in_ekf is not None
    # Every sample but each log's first (the filter's start) measured, none gated out.
    assert (in_ekf.samples, in_ekf.rejected) == (sum(g.n_samples - 1 for g in logs), 0)
    assert abs(in_ekf.scale_error) <= 3.0 * in_ekf.scale_error_std < 3.0 * 0.01
    # The log's own noise, from the log: the 0.05 m/s added (to a smoothed speed).
    assert in_ekf.noise_mps == pytest.approx(0.05, rel=0.2)
    record = with_log.params.identification["environment"]["speed_log"]
    assert record["samples"] == in_ekf.samples and record["rejected_samples"] == 0
    assert record["scale_error"] == in_ekf.scale_error
    assert record["alone"]["samples"] == sum(g.n_samples for g in logs)
    assert track_only.params.identification["environment"]["speed_log"] is None
    # Spikes and drop-outs (0 or twice the speed) on 1 % of the samples: gated out one by
    # one, and the current stays where the clean log put it.
    glitched, bad_samples = _spiked(logs, "stw_mps", lambda z, odd: np.where(odd, 2.0 * z, 0.0), 11)
    spiky = identify(glitched, SEED)
    assert spiky.current is not None and spiky.current.speed_log_ekf is not None
    assert spiky.current.speed_log_ekf.rejected == bad_samples > 0
    assert np.all(np.abs(spiky.current.vector - with_log.current.vector) <= 0.5 * std)
    # A log stuck at 0 would "show" a current of the ship's own speed: not used, warned.
    stuck = identify([replace(g, stw_mps=np.zeros(g.n_samples)) for g in logs], SEED)
    assert stuck.current is not None and stuck.current.speed_log is None
    assert stuck.current.speed_log_ekf is None
    np.testing.assert_array_equal(stuck.current.vector, track_only.current.vector)
    (warning,) = [w for w in stuck.warnings if "was not used" in w]
    assert any("barely told apart" in w for w in stuck.warnings)  # the track alone again
    assert re.fullmatch(
        r"the speed log \(stw_mps\) was not used: it implies a current of [\d.]+ m/s, more "
        r"than 3 m/s \(a log stuck or in other units\?\)",
        warning,
    ), warning
    assert stuck.params.identification["environment"]["speed_log_ignored"].startswith("it implies")


def test_current_model_form_is_the_outer_product_of_the_estimates_distance() -> None:
    alone = _speed_log_fit(np.array([0.28, 0.13]))
    term = current_model_form(np.array([0.30, 0.10]), alone)
    np.testing.assert_allclose(term, [[4e-4, -6e-4], [-6e-4, 9e-4]], atol=1e-15)
    estimate = CurrentEstimate(
        north_mps=0.30,
        east_mps=0.10,
        covariance=np.diag([1e-4, 4e-4]),
        mode="constant",
        iterations=3,
        model_form=term,
    )
    assert estimate.std_mps == pytest.approx((math.sqrt(5e-4), math.sqrt(13e-4)), rel=1e-12)
    record = estimate.as_dict()
    assert record["current_east_std_mps"] == pytest.approx(math.sqrt(13e-4), rel=1e-12)
    assert record["current_covariance_m2ps2"] == pytest.approx(
        np.array([[5e-4, -6e-4], [-6e-4, 13e-4]])
    )
    assert record["current_identification_covariance_m2ps2"] == [[1e-4, 0.0], [0.0, 4e-4]]
    assert record["current_model_form_covariance_m2ps2"] == term.tolist()
    assert not np.any(replace(estimate, model_form=np.zeros((2, 2))).as_dict()[
        "current_model_form_covariance_m2ps2"])  # fmt: skip


def _speed_log_fit(current_ne: np.ndarray) -> SpeedLogFit:
    """What a speed log alone showed: ``current_ne``, the rest of no concern here."""
    return SpeedLogFit(
        current_ne=current_ne, covariance=np.eye(2) * 1e-4, scale_error=0.0,
        scale_error_std=0.01, samples=100, noise_mps=0.05,
    )  # fmt: skip


def test_the_current_model_form_term_holds_the_structure_error_of_the_reference() -> None:
    """KVLCC2 (MMG, cubic hull) fitted by the modulus family: its current is further off than
    the EKF's σ says; with the distance to the speed log's own estimate it is inside its
    95 % ellipse (the benchmark's draw 0, 0.5 m/s towards 45° in a 10 m/s beam wind:
    eᵀC⁻¹e 4.7 and 1.6 since the shape polish's two whole sweeps, 11.9 and 1.9 with the
    cap of 300 evaluations before; over draws 0–4 the EKF's own 4.7 / 3.8 / 0.4 / 1.2 /
    10.5, a mean of 4.1 where χ²₂'s is 2)."""
    truth = 0.5 * np.array([math.cos(math.radians(45.0)), math.sin(math.radians(45.0))])
    sea = SeaEnvironment(
        current_speed_mps=0.5,
        current_to_rad=math.radians(45.0),
        wind_speed_mps=10.0,
        wind_from_rad=math.radians(90.0),
    )
    ship = reference_ship("kvlcc2", "full", sea)
    logs = [
        synthesize_log(ship, MANEUVERS[name](), seed=seed, noise_per_channel=True)
        for seed, name in ((1, "zigzag-10"), (2, "zigzag-20"))
    ]
    result = identify(logs, FitSettings(method="ekf", windage=kvlcc2_windage("full")))
    current = result.current
    assert current is not None and current.speed_log is not None
    error = current.vector - truth
    assert np.max(np.abs(error)) < 0.05  # issue 14's bar
    chi2_2_95, chi2_2_5 = 5.99, 0.103
    ekf_only = error @ np.linalg.solve(current.covariance, error)
    total = error @ np.linalg.solve(current.total_covariance, error)
    assert total < 0.5 * ekf_only  # the model-form term takes the larger part
    # within the 95 % ellipse, and not so wide that the error sits in its innermost 5 %
    assert chi2_2_5 < total < chi2_2_95


def test_the_ekf_tells_a_speed_logs_scale_error_from_the_current(
    calm_logs: list[ManeuverLog],
) -> None:
    """A log 1.5 % fast: the EKF's k is the 1.5 % (within 3σ), not a current along the course."""
    zigzags = calm_logs[1:]
    logs = [
        _with_speed_log(_with_current(g, CURRENT_NE), g, 0.015, i) for i, g in enumerate(zigzags)
    ]
    result = identify(logs, SEED)
    assert result.current is not None and result.current.speed_log_ekf is not None
    in_ekf = result.current.speed_log_ekf
    assert abs(in_ekf.scale_error - 0.015) <= 3.0 * in_ekf.scale_error_std
    assert in_ekf.scale_error_std < 0.7 * 0.01  # the logs narrow the 1 % prior
    std = np.array(result.current.std_mps)
    assert np.all(np.abs(result.current.vector - CURRENT_NE) <= np.maximum(3.0 * std, 0.01))
    # One log with a speed log, one without: the one measured, the other the track alone.
    mixed = identify([logs[0], replace(logs[1], stw_mps=None)], SEED)
    assert mixed.current is not None and mixed.current.speed_log_ekf is not None
    assert mixed.current.speed_log_ekf.samples == logs[0].n_samples - 1


def test_speed_log_noise_from_the_log_itself() -> None:
    """σ and the lag-one correlation from second differences: white, correlated, spiky, none."""
    n = 4000
    t = np.arange(n, dtype=float)
    speed = 7.0 - 4.0 * np.sin(2.0 * np.pi * t / 600.0)  # a turn's speed loss, 0.04 m/s/s

    def ar1(rho: float, seed: int) -> np.ndarray:  # stationary σ = 0.05 m/s
        white = np.random.default_rng(seed).normal(0.0, 0.05, n)
        noise = np.empty(n)
        noise[0] = white[0]
        for k in range(1, n):
            noise[k] = rho * noise[k - 1] + math.sqrt(1.0 - rho**2) * white[k]
        return noise

    def noise(stw: np.ndarray) -> float | None:
        return speed_log_noise_mps([_ship_log_with_speed(stw)])

    assert noise(speed) is not None and noise(speed) < 0.04  # its own speed: below a log's
    for seed in range(3):
        assert noise(speed + ar1(0.0, seed)) == pytest.approx(0.05, rel=0.1)
        # Correlated: σ·√((1 + ρ)/(1 − ρ)), as many independent samples as it holds.
        assert noise(speed + ar1(0.5, seed)) == pytest.approx(0.05 * math.sqrt(3.0), rel=0.15)
        assert noise(speed + ar1(0.8, seed)) == pytest.approx(0.15, rel=0.3)
        assert noise(speed + ar1(0.9, seed)) == pytest.approx(0.05 * math.sqrt(19.0), rel=0.3)
    # Spikes and drop-outs on 1 % of the samples do not count.
    spiky = speed + ar1(0.0, 0)
    spiky[np.random.default_rng(9).choice(n, size=n // 100, replace=False)] = 0.0
    assert noise(spiky) == pytest.approx(0.05, rel=0.15)
    # A log that never changes is no measurement to the millimetre.
    assert noise(np.full(n, 7.0)) == 0.005
    # Logs too short for the longer lags: lag 1 alone, the noise taken as white.
    short = noise(speed[:10] + ar1(0.0, 0)[:10])
    assert short is not None and 0.02 < short < 0.1
    assert speed_log_noise_mps([replace(_ship_log_with_speed(speed), stw_mps=None)]) is None
    # A two-axis log's transverse axis, of its own column.
    across = replace(_ship_log_with_speed(speed), stw_transverse_mps=ar1(0.0, 5))
    assert speed_log_noise_mps([across], "stw_transverse_mps") == pytest.approx(0.05, rel=0.1)
    assert speed_log_noise_mps([_ship_log_with_speed(speed)], "stw_transverse_mps") is None
    with pytest.raises(ValueError, match="column must be stw_mps or stw_transverse_mps"):
        speed_log_noise_mps([across], "wind_speed_mps")


def _spiked(
    logs: list[ManeuverLog],
    column: str,
    spoil: Callable[[np.ndarray, np.ndarray], np.ndarray],
    seed: int,
) -> tuple[list[ManeuverLog], int]:
    """``logs`` with 1 % of the samples of ``column`` (never the first) spoilt; their count.

    ``spoil(values, odd)`` gives the bad samples' values, ``odd`` alternating False, True.
    """
    rng = np.random.default_rng(seed)
    spoilt, count = [], 0
    for log in logs:
        values = np.array(getattr(log, column))
        bad = rng.choice(np.arange(1, log.n_samples), size=log.n_samples // 100, replace=False)
        values[bad] = spoil(values[bad], np.arange(bad.size) % 2 == 1)
        spoilt.append(replace(log, **{column: values}))
        count += bad.size
    return spoilt, count


def _ship_log_with_speed(stw_mps: np.ndarray) -> ManeuverLog:
    """A straight-ahead log of ``stw_mps.size`` samples at 1 Hz carrying the speed log given."""
    n = stw_mps.size
    zeros = np.zeros(n)
    return ManeuverLog(
        time_s=np.arange(n, dtype=float),
        x_m=np.cumsum(stw_mps),
        y_m=zeros,
        heading_rad=zeros,
        rudder_rad=zeros,
        n_rps=np.ones(n),
        stw_mps=stw_mps,
    )


def test_a_noisy_compass_does_not_show_an_along_current(calm_logs: list[ManeuverLog]) -> None:
    """0.5° of heading noise is no heading spread: the along component stays unseen."""
    log = _with_current(calm_logs[1], CURRENT_NE)
    noise = np.random.default_rng(5).normal(0.0, math.radians(0.5), log.n_samples)
    noisy = replace(log, heading_rad=log.heading_rad + noise)
    track = smooth_track(noisy.time_s, noisy.x_m, noisy.y_m, noisy.heading_rad)
    start = initial_current([noisy], [track])
    assert start[1] == pytest.approx(CURRENT_NE[1], abs=0.02)
    assert start[0] == pytest.approx(0.0, abs=1e-3)
    # The threshold is the heading spread: it is not just any rcond (the same approach
    # with a cut below that noise's spread resolves an along current that is not there).
    rows = np.column_stack([-np.sin(track.heading_rad), np.cos(track.heading_rad)])
    end = execute_index(noisy)
    loose = np.linalg.lstsq(rows[:end], track.v_mps[:end], rcond=1e-3)[0]
    assert abs(loose[0] - CURRENT_NE[0]) > 0.5


# --------------------------------------------------------------------------- wind


def _in_wind(log: ManeuverLog, wind_speed_mps: float = WIND_SPEED_MPS) -> ManeuverLog:
    """The seed ship re-sailed through the log's inputs in a beam wind, logged with wind.

    The truth's own equations with the Blendermann load (``fmu_model.simulate``), the
    logger noise of ``synthesize_log`` (1 m, 0.1 deg), and the anemometer's apparent wind
    computed from the states.
    """
    truth = replace(_truth(), windage=WINDAGE)
    start = np.array([5.0, 0.0, 0.0, 0.0, 0.0, float(log.heading_rad[0])])
    # Sailed at 10 Hz with the rudder moving continuously (as the logged 1 Hz samples of a
    # moving rudder mean), recorded at the log's samples.
    fine_s = np.linspace(log.time_s[0], log.time_s[-1], 10 * (log.n_samples - 1) + 1)
    states = simulate(
        truth,
        fine_s,
        np.interp(fine_s, log.time_s, log.rudder_rad),
        np.interp(fine_s, log.time_s, log.n_rps),
        start,
        wind_speed_mps=wind_speed_mps,
        wind_direction_rad=WIND_FROM_RAD,
        windage=WINDAGE,
    )[::10]
    speed, angle = apparent_wind(
        wind_speed_mps, WIND_FROM_RAD, states[:, 5], states[:, 0], states[:, 1]
    )
    rng = np.random.default_rng(7)
    return replace(
        log,
        x_m=states[:, 3] + rng.normal(0.0, 1.0, log.n_samples),
        y_m=states[:, 4] + rng.normal(0.0, 1.0, log.n_samples),
        heading_rad=states[:, 5] + rng.normal(0.0, math.radians(0.1), log.n_samples),
        wind_speed_mps=np.asarray(speed),
        wind_angle_rad=np.asarray(angle) % (2.0 * math.pi),
    )


@pytest.fixture(scope="module")
def wind_logs(calm_logs: list[ManeuverLog]) -> list[ManeuverLog]:
    return [_in_wind(log) for log in calm_logs]


def test_known_acceleration_is_the_blendermann_load(wind_logs: list[ManeuverLog]) -> None:
    log = wind_logs[0]
    assert known_acceleration(log, None) is None
    assert (
        known_acceleration(replace(log, wind_speed_mps=None, wind_angle_rad=None), WINDAGE) is None
    )
    acc = known_acceleration(log, WINDAGE)
    assert acc is not None and acc.shape == (log.n_samples, 3)
    # By hand at sample 0, Blendermann (1994), tanker loaded: C_Y = -C_Dt sin(g) / den.
    v_r, g = float(log.wind_speed_mps[0]), float(log.wind_angle_rad[0])
    g = (g + math.pi) % (2.0 * math.pi) - math.pi
    cd_t, cd_l = 0.70, 0.90 if math.cos(g) >= 0.0 else 0.55
    ratio = cd_l * WINDAGE.frontal_area_m2 / (cd_t * WINDAGE.lateral_area_m2)
    den = 1.0 - 0.5 * 0.40 * (1.0 - ratio) * math.sin(2.0 * g) ** 2
    q = 0.5 * 1.225 * v_r**2
    y_n = q * WINDAGE.lateral_area_m2 * (-cd_t * math.sin(g) / den)
    assert acc[0, 1] == pytest.approx(y_n / WINDAGE.sway_mass_kg, rel=1e-9)


def test_measured_wind_is_taken_out_of_the_coefficients(wind_logs: list[ManeuverLog]) -> None:
    truth = dict(SEED_COEFFICIENTS)
    settings = replace(SEED, current="none")
    taken_out = identify(wind_logs, replace(settings, windage=WINDAGE))
    left_in = identify(wind_logs, settings)
    assert any("no windage was given" in w for w in left_in.warnings)
    assert taken_out.params.windage == WINDAGE  # the FMU gets it (vessel.windage)

    def worst(result: IdentificationResult) -> float:
        """Largest |error| of the sway and yaw coefficients, in the estimate's σ."""
        return max(
            abs(c.value - truth[c.name]) / c.std
            for c in result.coefficients
            if c.name in ("b1", "b3", "b4", "c1", "c2", "c3")
        )

    assert worst(taken_out) < 3.0, worst(taken_out)
    assert worst(left_in) > 3.0 * worst(taken_out), worst(left_in)


# --------------------------------------------------------------------------- CLI


def test_windage_file_errors_are_one_line(tmp_path: Path) -> None:
    bad = tmp_path / "windage.json"
    bad.write_text('{"frontal_area_m2": 1.0}', encoding="utf-8")
    with pytest.raises(ValueError, match=r"windage\.json: expected a windage .*lacks"):
        read_windage(str(bad))
    bad.write_text("{", encoding="utf-8")
    with pytest.raises(ValueError, match=r"windage\.json:1: invalid JSON"):
        read_windage(str(bad))
    good = tmp_path / "good.json"
    good.write_text(json.dumps(WINDAGE.to_dict()), encoding="utf-8")
    assert read_windage(str(good)) == WINDAGE


def test_fit_cli_current_and_windage(
    tmp_path: Path, calm_logs: list[ManeuverLog], capsys: pytest.CaptureFixture[str]
) -> None:
    paths = []
    for i, log in enumerate(calm_logs):
        paths.append(str(tmp_path / f"{i}.csv"))
        write_log(paths[-1], _with_current(log, CURRENT_NE))
    out = str(tmp_path / "p.json")
    status = main(["fit", *paths, "--model", "shi2009", "--method", "ekf", "--current", "auto",
                   "-o", out])  # fmt: skip
    assert status == 0
    summary = capsys.readouterr().out
    shown = re.search(r"current \(auto → constant\): ([\d.]+) m/s towards ([\d.]+) deg", summary)
    assert shown is not None
    assert re.search(
        r"current choice \(auto\): constant, as predicted open loop from execute, the training "
        r"logs stay [\d.]+ m \(RMS\) from their tracks with a current of 0\.[23]\d\d m/s towards "
        r"(59|60|61) deg, [\d.]+ m in still water \(a current is kept where it divides the "
        r"distance by 2\)\n",
        summary,
    )
    assert float(shown.group(1)) == pytest.approx(0.3, abs=0.02)
    assert float(shown.group(2)) == pytest.approx(60.0, abs=3.0)
    assert "speed log:" not in summary  # no stw_mps in these logs
    assert re.search(
        r"current \(auto → constant\): .* m/s\); the ± are the identification noise only, no "
        r"speed "
        r"log measures the hull's share\n",
        summary,
    )
    for i, log in enumerate(calm_logs):
        write_log(paths[i], _with_speed_log(_with_current(log, CURRENT_NE), log, 0.0, i))
    status = main(["fit", *paths, "--model", "shi2009", "--method", "ekf", "-o", out])
    assert status == 0
    summary = capsys.readouterr().out
    shown = re.search(
        r"speed log: ([\d,]+) samples measured \((\d+) rejected\), noise ([\d.]+) m/s, "
        r"scale error ([-+][\d.]+) ± ([\d.]+) %; alone it shows North [-+][\d.]+ ± [\d.]+, "
        r"East [-+][\d.]+ ± [\d.]+ m/s; the current's ± include the two estimates' "
        r"distance \(model form\)",
        summary,
    )
    assert shown is not None, "the summary says what the speed log showed"
    assert "identification noise only" not in summary
    assert int(shown.group(1).replace(",", "")) == sum(g.n_samples - 1 for g in calm_logs)
    assert int(shown.group(2)) == 0
    assert float(shown.group(3)) == pytest.approx(0.05, rel=0.2)
    assert abs(float(shown.group(4))) <= 3.0 * float(shown.group(5))
    for i, log in enumerate(calm_logs):  # a two-axis log: written, read, measured, reported
        write_log(paths[i], _with_speed_log(_with_current(log, CURRENT_NE), log, 0.0, i, True))
    assert main(["fit", *paths, "--model", "shi2009", "--method", "ekf", "-o", out]) == 0
    shown = re.search(
        r"speed log: [\d,]+ samples measured \(0 rejected\), noise [\d.]+ m/s; transverse "
        r"axis ([\d,]+) \((\d+) rejected\), noise ([\d.]+) m/s, scale error",
        capsys.readouterr().out,
    )
    assert shown is not None, "the summary says what the transverse axis showed"
    assert int(shown.group(1).replace(",", "")) == sum(g.n_samples - 1 for g in calm_logs)
    assert int(shown.group(2)) == 0 and 0.045 < float(shown.group(3)) < 0.1
    with pytest.raises(SystemExit):
        main(["fit", *paths, "--speed-log-scale-std-pct", "0", "-o", out])
    assert "--speed-log-scale-std-pct: expected a number from 0.0001 to 50 %" in (
        capsys.readouterr().err
    )
    status = main(["fit", *paths, "--measurements", "velocities", "--current", "constant",
                   "-o", out])  # fmt: skip
    assert status == 2
    assert "--current constant needs --measurements track" in capsys.readouterr().err
    missing = str(tmp_path / "nowhere.json")
    assert main(["fit", *paths, "--windage", missing, "-o", str(tmp_path / "q.json")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nowhere.json: file not found" in err
    assert not (tmp_path / "q.json").exists()


def test_a_held_out_log_in_a_current_is_predicted_in_it(calm_logs: list[ManeuverLog]) -> None:
    """crossval at sea: the true model, told the true current, predicts the turning log
    sailed in it exactly as well as the calm log (the water frame of the one is the other,
    the smoother linear), and its indices over the ground; without the current the
    prediction runs off by the drift, 0.3 m/s for the log's minutes."""
    calm, at_sea = calm_logs[0], _with_current(calm_logs[0], CURRENT_NE)
    assert maneuver_kind(calm) == "turning"
    still = held_out_errors(_truth(), calm)
    true_current = CurrentEstimate(
        *CURRENT_NE, covariance=np.zeros((2, 2)), mode="constant", iterations=0
    )
    carried = held_out_errors(_truth(), at_sea, current=true_current)
    ignored = held_out_errors(_truth(), at_sea)
    assert carried.position_rms_m == pytest.approx(still.position_rms_m, rel=1e-6)
    assert carried.position_rms_m < 2.0 and ignored.position_rms_m > 20.0 * carried.position_rms_m
    assert carried.notes == ("predicted in the training fit's current, 0.300 m/s towards 60 deg",)
    for m in carried.metrics:  # the logged ones over the ground, the drift in both
        assert m.logged is not None and m.predicted is not None
        assert abs(m.predicted - m.logged) < 1.0, m
    drifted = {m.name: m.logged for m in carried.metrics}
    calm_indices = {m.name: m.logged for m in still.metrics}
    assert drifted["tactical_diameter_m"] > calm_indices["tactical_diameter_m"] + 10.0


def test_crossval_predicts_the_held_out_logs_in_the_training_fits_current(
    calm_logs: list[ManeuverLog],
) -> None:
    """The fold's fit from the zig-zags in the current finds it, and the turning log held
    out is predicted in it: several times closer than the same model in still water."""
    at_sea = [_with_current(log, CURRENT_NE) for log in calm_logs]
    fold = cross_validate(at_sea[1:], at_sea[:1], SEED)
    (held,) = fold.held_out
    assert len(held.notes) == 1
    assert re.fullmatch(
        r"predicted in the training fit's current, 0\.[23]\d\d m/s towards (5\d|6\d) deg",
        held.notes[0],
    )
    ignored = held_out_errors(fold.params, at_sea[0])
    assert held.position_rms_m < 0.4 * ignored.position_rms_m


def test_a_held_out_zigzag_in_a_wind_is_sailed_again_in_it() -> None:
    """crossval at sea: a 10/10 zig-zag sailed closed loop in a 20 m/s head wind by the true
    model with its windage (after five minutes of approach, slowed by the wind to 4.5 m/s),
    logged at 1 Hz with 1 m / 0.1 deg of noise and the anemometer's apparent wind. The
    log's mean true wind comes back from the apparent wind and the smoothed track; held
    out, the true model sails the zig-zag again in it and repeats the overshoots as it does
    a calm log's (within 0.4 deg at 1 Hz). The log without its wind columns is sailed in
    still air, where the ship keeps more speed: its overshoots 4-5 deg short."""
    truth = replace(_truth(), windage=WINDAGE)
    head_wind = (0.0, 0.0, WIND_SPEED_MPS, 0.0)
    program = replace(zigzag(math.radians(10.0), math.radians(10.0), max_time_s=900.0),
                      approach_s=300.0)  # fmt: skip
    run = run_program(ModelPlant(truth, environment=head_wind), program, speed_mps=5.0,
                      n_rps=2.0, rudder_rate_radps=RUDDER_RATE, dt_s=0.1)[::10]  # fmt: skip
    rng = np.random.default_rng(3)
    noise = [rng.normal(0.0, s, run.size) for s in (1.0, 1.0, math.radians(0.1))]
    speed, angle = apparent_wind(WIND_SPEED_MPS, 0.0, run["psi_rad"], run["u_mps"], run["v_mps"])
    log = ManeuverLog(
        run["time_s"] - run["time_s"][0],
        run["x_m"] + noise[0],
        run["y_m"] + noise[1],
        run["psi_rad"] + noise[2],
        run["rudder_rad"],
        run["n_rps"],
        wind_speed_mps=np.asarray(speed),
        wind_angle_rad=np.asarray(angle) % (2.0 * math.pi),
        metadata={"length_m": "100.0"},
    )  # no current: the velocities through the water are those over the ground
    found = mean_true_wind_ne(log, smooth_log(log))
    assert found is not None  # blowing towards South
    np.testing.assert_allclose(found, [-WIND_SPEED_MPS, 0.0], atol=0.05)
    held = held_out_errors(truth, log)
    assert held.notes == ("sailed again in the log's mean true wind, 20.0 m/s from 0 deg",)
    without = held_out_errors(truth, replace(log, wind_speed_mps=None, wind_angle_rad=None))
    assert without.notes == ()
    overshoots = [m for m in zip(held.metrics, without.metrics, strict=True)
                  if m[0].name.endswith("overshoot_deg")]  # fmt: skip
    assert len(overshoots) == 2
    for sailed, still_air in overshoots:
        assert sailed.error is not None and still_air.error is not None
        assert abs(sailed.error) < 0.5, sailed
        assert still_air.error < -3.0, still_air


def test_crossval_cli_takes_the_wind_out_with_a_windage(
    tmp_path: Path, wind_logs: list[ManeuverLog], capsys: pytest.CaptureFixture[str]
) -> None:
    """``crossval --windage``: the training fit takes the logged wind's load out, the
    held-out zig-zag is sailed again in its mean wind and the table's notes say so;
    without it, the fit's warning; a missing file is one line."""
    paths = []
    for i, log in enumerate(wind_logs):
        paths.append(str(tmp_path / f"{i}.csv"))
        write_log(paths[-1], log)
    windage = tmp_path / "windage.json"
    windage.write_text(json.dumps(WINDAGE.to_dict()), encoding="utf-8")
    args = ["crossval", *paths, "--train", *paths[:-1], "--model", "shi2009", "--method", "ekf",
            "--current", "none"]  # fmt: skip
    assert main([*args, "--windage", str(windage)]) == 0
    out, err = capsys.readouterr()
    assert "no windage was given" not in err
    assert re.search(
        rf"^note: {Path(paths[-1]).name} \(trained on 0\.csv, 1\.csv\): sailed again in the "
        r"log's mean true wind, 2\d\.\d m/s from (8\d|9\d) deg$",
        out,
        re.MULTILINE,
    ), out
    assert main(args) == 0
    out, err = capsys.readouterr()
    assert "no windage was given" in err and "mean true wind" not in out
    assert main([*args, "--windage", str(tmp_path / "nowhere.json")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "nowhere.json: file not found" in err
