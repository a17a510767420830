"""IMO MSC.137(76) criteria: each one at, just below and just above its limit."""

from __future__ import annotations

import math

import pytest

from scenarios.imo import (
    Criterion,
    evaluate,
    first_overshoot_limit_10_rad,
    initial_turning_ability,
    second_overshoot_limit_10_rad,
    stopping_ability,
    turning_ability,
    yaw_checking_10,
    yaw_checking_20,
)
from trials.metrics import TurningMetrics, ZigzagMetrics

DEG = math.pi / 180.0
L = 320.0
EPS = 1e-9  # relative nudge above / below a limit


def turning(advance_m: float, tactical_m: float, direction: int = 1) -> TurningMetrics:
    return TurningMetrics(
        direction=direction,
        execute_time_s=0.0,
        approach_heading_rad=0.0,
        approach_speed_mps=7.97,
        advance_m=advance_m,
        transfer_m=0.4 * advance_m,
        tactical_diameter_m=tactical_m,
        time_to_90_s=170.0,
        time_to_180_s=330.0,
        max_advance_m=advance_m,
        max_transfer_m=tactical_m,
        steady_speed_ratio=0.4,
    )


def zigzag(angle_deg: float, first_deg: float, second_deg: float | None) -> ZigzagMetrics:
    return ZigzagMetrics(
        rudder_rad=angle_deg * DEG,
        heading_rad=angle_deg * DEG,
        execute_time_s=0.0,
        initial_heading_rad=0.0,
        approach_speed_mps=16.0,  # L/V = 20 s
        reversal_times_s=(70.0, 160.0),
        peak_times_s=(90.0, 190.0),
        first_overshoot_rad=first_deg * DEG,
        second_overshoot_rad=None if second_deg is None else second_deg * DEG,
        third_overshoot_rad=None,
        initial_turning_time_s=70.0,
        time_to_check_yaw_s=20.0,
        period_s=None,
    )


def verdicts(criteria: tuple[Criterion, ...] | list[Criterion]) -> list[bool]:
    return [c.passed for c in criteria]


@pytest.mark.parametrize(("scale", "passed"), [(1.0 - EPS, True), (1.0, True), (1.0 + EPS, False)])
def test_turning_ability_at_its_limits(scale: float, passed: bool) -> None:
    advance, tactical = turning_ability(turning(4.5 * L * scale, 2.0 * L), L)
    assert advance.passed is passed
    assert advance.limit == pytest.approx(4.5 * L)
    assert advance.margin == pytest.approx(4.5 * L * (1.0 - scale), abs=1e-9)
    assert tactical.passed
    advance, tactical = turning_ability(turning(3.0 * L, 5.0 * L * scale), L)
    assert advance.passed
    assert tactical.passed is passed
    assert tactical.limit == pytest.approx(5.0 * L)


def test_turning_criterion_names_the_side() -> None:
    advance, _ = turning_ability(turning(3.0 * L, 3.1 * L, direction=-1), L)
    assert "port" in advance.name
    assert "5.3.1" in advance.reference


@pytest.mark.parametrize(("scale", "passed"), [(1.0 - EPS, True), (1.0, True), (1.0 + EPS, False)])
def test_initial_turning_ability_at_its_limit(scale: float, passed: bool) -> None:
    c = initial_turning_ability(2.5 * L * scale, L)
    assert c.passed is passed
    assert c.limit == pytest.approx(2.5 * L)
    assert c.unit == "m"


@pytest.mark.parametrize(
    ("l_over_v_s", "first_deg", "second_deg"),
    [
        (5.0, 10.0, 25.0),
        (9.999, 10.0, 25.0),
        (10.0, 10.0, 25.0),  # continuous at 10 s: 5 + 5 = 10, 17.5 + 7.5 = 25
        (20.0, 15.0, 32.5),
        (29.999, 5.0 + 0.5 * 29.999, 17.5 + 0.75 * 29.999),
        (30.0, 20.0, 40.0),
        (45.0, 20.0, 40.0),
    ],
)
def test_10_10_overshoot_limits_follow_l_over_v(
    l_over_v_s: float, first_deg: float, second_deg: float
) -> None:
    speed = L / l_over_v_s
    assert first_overshoot_limit_10_rad(L, speed) == pytest.approx(first_deg * DEG, rel=1e-12)
    assert second_overshoot_limit_10_rad(L, speed) == pytest.approx(second_deg * DEG, rel=1e-12)


@pytest.mark.parametrize(("scale", "passed"), [(1.0 - EPS, True), (1.0, True), (1.0 + EPS, False)])
def test_yaw_checking_10_at_l_over_v_20(scale: float, passed: bool) -> None:
    # L / V = 200 m / 10 m/s = 20 s: first overshoot ≤ 15°, second ≤ 32.5°
    first, second = yaw_checking_10(15.0 * DEG * scale, 32.5 * DEG * scale, 200.0, 10.0)
    assert (first.passed, second.passed) == (passed, passed)
    assert first.limit == pytest.approx(15.0 * DEG, rel=1e-12)
    assert second.limit == pytest.approx(32.5 * DEG, rel=1e-12)
    assert first.unit == second.unit == "rad"
    assert "5.3.3.1" in first.reference
    assert "5.3.3.2" in second.reference


def test_yaw_checking_10_without_second_overshoot() -> None:
    (first,) = yaw_checking_10(5.0 * DEG, None, L, 8.0)
    assert first.passed
    assert first.margin == pytest.approx((20.0 - 5.0) * DEG)  # L/V = 40 s


@pytest.mark.parametrize(("scale", "passed"), [(1.0 - EPS, True), (1.0, True), (1.0 + EPS, False)])
def test_yaw_checking_20_at_its_limit(scale: float, passed: bool) -> None:
    c = yaw_checking_20(25.0 * DEG * scale)
    assert c.passed is passed
    assert c.limit == pytest.approx(25.0 * DEG)


@pytest.mark.parametrize(("scale", "passed"), [(1.0 - EPS, True), (1.0, True), (1.0 + EPS, False)])
def test_stopping_ability_at_its_limit(scale: float, passed: bool) -> None:
    assert stopping_ability(15.0 * L * scale, L).passed is passed
    assert stopping_ability(20.0 * L * scale, L, limit_L=20.0).passed is passed


def test_stopping_limit_may_not_exceed_20_lengths() -> None:
    with pytest.raises(ValueError, match="exceeds 20"):
        stopping_ability(10.0 * L, L, limit_L=20.5)


def test_margin_is_positive_when_passing_and_negative_when_failing() -> None:
    good = yaw_checking_20(20.0 * DEG)
    bad = yaw_checking_20(30.0 * DEG)
    assert good.margin == pytest.approx(5.0 * DEG)
    assert bad.margin == pytest.approx(-5.0 * DEG)
    assert not bad.passed


def test_report_text_and_dict_use_degrees_and_ship_lengths() -> None:
    first, _ = yaw_checking_10(12.0 * DEG, 20.0 * DEG, 200.0, 10.0)
    text = first.describe()
    assert "12.00 deg" in text
    assert "15.00 deg" in text
    assert "pass" in text
    assert first.as_dict()["limit_deg"] == pytest.approx(15.0)
    stop = stopping_ability(16.0 * L, L)
    assert "FAIL" in stop.describe()
    assert "16.000 L" in stop.describe()
    d = stop.as_dict()
    assert d["value_L"] == pytest.approx(16.0)
    assert d["margin_m"] == pytest.approx(-L)
    assert d["passed"] is False


def test_evaluate_assembles_what_is_given() -> None:
    criteria = evaluate(
        L,
        turning=[turning(3.08 * L, 3.11 * L), turning(3.09 * L, 3.10 * L, direction=-1)],
        initial_turning_distance_m=1.9 * L,
        zigzag_10=zigzag(10.0, 5.0, 13.9),
        zigzag_20=zigzag(20.0, 10.6, 15.8),
        stopping_track_reach_m=12.0 * L,
    )
    assert [c.reference.split()[-1] for c in criteria] == [
        "5.3.1",
        "5.3.1",
        "5.3.1",
        "5.3.1",
        "5.3.2",
        "5.3.3.1",
        "5.3.3.2",
        "5.3.3.3",
        "5.3.4",
    ]
    assert all(verdicts(criteria))
    # the 10/10 limits used the run's approach speed: L/V = 320 / 16 = 20 s
    assert criteria[5].limit == pytest.approx(15.0 * DEG)
    # an explicit speed overrides it: L/V = 40 s
    (first, _) = evaluate(L, zigzag_10=zigzag(10.0, 5.0, 13.9), speed_mps=8.0)
    assert first.limit == pytest.approx(20.0 * DEG)
    assert evaluate(L) == []


def test_evaluate_fails_the_overshoot_above_the_interpolated_limit() -> None:
    criteria = evaluate(L, zigzag_10=zigzag(10.0, 15.5, 33.0))  # L/V = 20 s: 15°, 32.5°
    assert verdicts(criteria) == [False, False]


def test_evaluate_rejects_the_wrong_zigzag() -> None:
    with pytest.raises(ValueError, match="expected a 10/10 zig-zag, got 20/20"):
        evaluate(L, zigzag_10=zigzag(20.0, 5.0, 10.0))


@pytest.mark.parametrize(("length_m", "speed_mps"), [(0.0, 5.0), (L, 0.0), (math.nan, 5.0)])
def test_bad_length_or_speed_is_rejected(length_m: float, speed_mps: float) -> None:
    with pytest.raises(ValueError, match="must be a positive number"):
        yaw_checking_10(5.0 * DEG, None, length_m, speed_mps)


def test_non_finite_value_is_rejected() -> None:
    with pytest.raises(ValueError, match="value must be finite"):
        yaw_checking_20(math.nan)
