"""Manoeuvre metrics on trajectories whose answers are known analytically."""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from trials.metrics import (
    MetricsError,
    distance_at_heading_change,
    pullout_metrics,
    spiral_metrics,
    steady_yaw_rate,
    turned_back_rad,
    turning_metrics,
    zigzag_metrics,
)
from trials.trajectory import STATE_FIELDS, empty_trajectory, trajectory_of

DEG = math.pi / 180.0


# --------------------------------------------------------------------------------------
# Turning circle
# --------------------------------------------------------------------------------------


def circle_run(
    *,
    radius_m: float = 400.0,
    speed_mps: float = 5.0,
    step_rad: float = 1.0 * DEG,
    turned_rad: float = 2.0 * math.pi + 2.0 * math.pi,
    side: int = 1,
    psi0_rad: float = 0.0,
    origin_m: tuple[float, float] = (0.0, 0.0),
    approach_s: float = 0.0,
    approach_speed_mps: float | None = None,
) -> np.ndarray:
    """Exact circle: execute at t = 0 at ``origin_m`` on course ``psi0_rad``.

    In the approach frame (ahead, starboard) the ship is at R (sin θ, side (1 − cos θ))
    after a heading change θ = U t / R; optionally a straight approach before t = 0.
    Samples fall every ``step_rad`` of heading from θ = 0.
    """
    theta = np.arange(round(turned_rad / step_rad) + 1) * step_rad
    t = theta * radius_m / speed_mps
    ahead = radius_m * np.sin(theta)
    lateral = side * radius_m * (1.0 - np.cos(theta))
    u = np.full_like(t, speed_mps)
    r = np.full_like(t, side * speed_mps / radius_m)
    if approach_s > 0.0:
        u_app = speed_mps if approach_speed_mps is None else approach_speed_mps
        t_app = np.linspace(-approach_s, 0.0, 11)[:-1]
        t = np.concatenate((t_app, t))
        ahead = np.concatenate((u_app * t_app, ahead))
        lateral = np.concatenate((np.zeros_like(t_app), lateral))
        theta = np.concatenate((np.zeros_like(t_app), theta))
        u = np.concatenate((np.full_like(t_app, u_app), u))
        r = np.concatenate((np.zeros_like(t_app), r))
    traj = empty_trajectory(t.size)
    traj["time_s"] = t
    traj["x_m"] = origin_m[0] + ahead * math.cos(psi0_rad) - lateral * math.sin(psi0_rad)
    traj["y_m"] = origin_m[1] + ahead * math.sin(psi0_rad) + lateral * math.cos(psi0_rad)
    traj["psi_rad"] = psi0_rad + side * theta
    traj["u_mps"] = u
    traj["r_radps"] = r
    traj["rudder_rad"] = side * 35.0 * DEG * (t >= 0.0)
    return traj


@pytest.mark.parametrize("side", [1, -1])
def test_exact_circle_gives_radius_based_metrics(side: int) -> None:
    radius, speed = 400.0, 5.0
    m = turning_metrics(circle_run(radius_m=radius, speed_mps=speed, side=side))
    assert m.direction == side
    assert m.advance_m == pytest.approx(radius, rel=1e-9)
    assert m.transfer_m == pytest.approx(radius, rel=1e-9)
    assert m.tactical_diameter_m == pytest.approx(2.0 * radius, rel=1e-9)
    assert m.max_advance_m == pytest.approx(radius, rel=1e-9)
    assert m.max_transfer_m == pytest.approx(2.0 * radius, rel=1e-9)
    assert m.steady_diameter_m == pytest.approx(2.0 * radius, rel=1e-9)
    assert m.steady_yaw_rate_radps == pytest.approx(side * speed / radius, rel=1e-9)
    assert m.time_to_90_s == pytest.approx(0.5 * math.pi * radius / speed, rel=1e-12)
    assert m.time_to_180_s == pytest.approx(math.pi * radius / speed, rel=1e-12)
    assert m.steady_speed_ratio == pytest.approx(1.0, abs=1e-12)


def test_rotated_and_shifted_approach_course_gives_the_same_numbers() -> None:
    reference = turning_metrics(circle_run())
    rotated = turning_metrics(
        circle_run(psi0_rad=30.0 * DEG, origin_m=(1234.5, -678.9), approach_s=120.0)
    )
    for name in ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"):
        assert getattr(rotated, name) == pytest.approx(getattr(reference, name), rel=1e-9)
    assert rotated.approach_heading_rad == pytest.approx(30.0 * DEG)


def test_execute_between_samples_is_interpolated() -> None:
    # Execute 0.37 samples into the circle: the ship is then already 0.37° into the turn,
    # so 90° after execute is 90.37° on the circle, and the approach course is 0.37°.
    step = 1.0 * DEG
    radius, speed = 400.0, 5.0
    traj = circle_run(radius_m=radius, speed_mps=speed, step_rad=step)
    t_exec = 0.37 * step * radius / speed
    m = turning_metrics(traj, execute_time_s=t_exec)
    assert m.execute_time_s == pytest.approx(t_exec)
    assert m.approach_heading_rad == pytest.approx(0.37 * step, rel=1e-12)
    # A rotation of the whole circle about its centre is again the exact circle,
    # up to the chord error of the interpolated execute point (≤ R (1 − cos(Δθ/2))).
    chord_error = radius * (1.0 - math.cos(0.5 * step))
    assert m.advance_m == pytest.approx(radius, abs=2.0 * chord_error)
    assert m.tactical_diameter_m == pytest.approx(2.0 * radius, abs=2.0 * chord_error)


def test_coarse_off_grid_sampling_stays_within_the_chord_error() -> None:
    """7° of heading per sample: 90° and 180° fall between samples.

    With heading linear in time the crossing times are exact; the interpolated position
    lies on the chord, at most the sagitta R (1 − cos(Δθ/2)) from the arc.
    """
    radius, speed, step = 400.0, 5.0, 7.0 * DEG
    m = turning_metrics(circle_run(radius_m=radius, speed_mps=speed, step_rad=step))
    sagitta = radius * (1.0 - math.cos(0.5 * step))
    assert m.time_to_90_s == pytest.approx(0.5 * math.pi * radius / speed, rel=1e-12)
    assert m.time_to_180_s == pytest.approx(math.pi * radius / speed, rel=1e-12)
    assert abs(m.advance_m - radius) <= sagitta
    assert abs(m.transfer_m - radius) <= sagitta
    assert abs(m.tactical_diameter_m - 2.0 * radius) <= sagitta
    # the error is real (not an accidental grid hit), so the bound is what is tested
    assert abs(m.advance_m - radius) > 0.1 * sagitta
    # the circle fit uses the samples themselves, which are on the circle
    assert m.steady_diameter_m == pytest.approx(2.0 * radius, rel=1e-9)


@settings(max_examples=25, deadline=None)
@given(
    radius=st.floats(50.0, 5000.0),
    psi0_deg=st.floats(-720.0, 720.0),
    x0=st.floats(-1e4, 1e4),
    y0=st.floats(-1e4, 1e4),
    side=st.sampled_from([1, -1]),
)
def test_circle_metrics_are_invariant_to_course_origin_and_side(
    radius: float, psi0_deg: float, x0: float, y0: float, side: int
) -> None:
    m = turning_metrics(
        circle_run(radius_m=radius, psi0_rad=psi0_deg * DEG, origin_m=(x0, y0), side=side)
    )
    assert m.direction == side
    assert m.advance_m == pytest.approx(radius, rel=1e-9)
    assert m.transfer_m == pytest.approx(radius, rel=1e-9)
    assert m.tactical_diameter_m == pytest.approx(2.0 * radius, rel=1e-9)
    assert m.steady_diameter_m == pytest.approx(2.0 * radius, rel=1e-9)


def test_speed_loss_is_measured_against_the_speed_at_execute() -> None:
    traj = circle_run(speed_mps=3.0, approach_s=100.0, approach_speed_mps=7.5)
    traj["u_mps"][traj["time_s"] == 0.0] = 7.5  # still at approach speed at execute
    m = turning_metrics(traj)
    assert m.approach_speed_mps == pytest.approx(7.5)
    assert m.steady_speed_ratio == pytest.approx(3.0 / 7.5, rel=1e-12)
    assert m.speed_loss_pct == pytest.approx(60.0, rel=1e-12)


def test_steady_diameter_needs_a_full_revolution_after_180_degrees() -> None:
    short = turning_metrics(circle_run(turned_rad=530.0 * DEG))
    assert short.steady_diameter_m is None
    assert short.steady_yaw_rate_radps is None
    assert "steady_diameter_m" not in short.as_dict(100.0)
    enough = turning_metrics(circle_run(turned_rad=540.0 * DEG))
    assert enough.steady_diameter_m == pytest.approx(800.0, rel=1e-9)


def test_turning_as_dict_keys_and_ship_lengths() -> None:
    d = turning_metrics(circle_run(radius_m=400.0)).as_dict(200.0)
    assert d["direction"] == "starboard"
    assert d["advance_L"] == pytest.approx(2.0)
    assert d["transfer_L"] == pytest.approx(2.0)
    assert d["tactical_diameter_L"] == pytest.approx(4.0)
    assert d["steady_diameter_L"] == pytest.approx(4.0)
    for key in ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"):
        assert key in d
    for key in ("time_to_90_s", "time_to_180_s", "speed_loss_pct", "max_advance_m"):
        assert key in d
    with pytest.raises(ValueError, match="length_m"):
        turning_metrics(circle_run()).as_dict(0.0)


@pytest.mark.parametrize(
    ("turned_deg", "needed"),
    [(80.0, "need 90 deg"), (170.0, "need 180 deg")],
)
def test_turn_that_does_not_reach_90_or_180_degrees_is_an_error(
    turned_deg: float, needed: str
) -> None:
    with pytest.raises(MetricsError, match=needed):
        turning_metrics(circle_run(turned_rad=turned_deg * DEG))


def test_straight_run_is_not_a_turning_circle() -> None:
    traj = circle_run(turned_rad=0.0, approach_s=100.0)
    with pytest.raises(MetricsError, match="never changes"):
        turning_metrics(traj, execute_time_s=-50.0)


@pytest.mark.parametrize("side", [1, -1])
def test_a_turn_that_keeps_its_direction_never_turns_back(side: int) -> None:
    assert turned_back_rad(circle_run(side=side, approach_s=100.0)) == 0.0


@pytest.mark.parametrize("side", [1, -1])
def test_a_turn_that_loops_back_falls_back_by_the_loop(side: int) -> None:
    # Heading 0 → 150° → 115° (35° back against the rudder) → 150° → 600°, then a
    # smaller wobble (10° back) later: the largest fall counts, not the sum.
    legs = (0.0, 150.0, 115.0, 400.0, 390.0, 600.0)
    change_deg = np.concatenate(
        [np.linspace(a, b, 200, endpoint=False) for a, b in itertools.pairwise(legs)]
    )
    traj = empty_trajectory(change_deg.size)
    traj["time_s"] = np.arange(change_deg.size, dtype=float)
    traj["psi_rad"] = 0.3 + side * change_deg * DEG
    assert turned_back_rad(traj) == pytest.approx(35.0 * DEG, abs=1e-12)
    # From execute after the loop only the later wobble is left.
    assert turned_back_rad(traj, execute_time_s=500.0) == pytest.approx(10.0 * DEG, abs=1e-12)


def test_turning_back_needs_a_turn() -> None:
    with pytest.raises(MetricsError, match="never changes"):
        turned_back_rad(circle_run(turned_rad=0.0, approach_s=100.0), execute_time_s=-50.0)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda tr: tr["time_s"].__setitem__(5, tr["time_s"][4]), "strictly increasing"),
        (lambda tr: tr["x_m"].__setitem__(7, np.nan), "x_m is not finite at row 7"),
    ],
)
def test_malformed_trajectory_is_rejected(
    mutate: Callable[[np.ndarray], None], message: str
) -> None:
    traj = circle_run()
    mutate(traj)
    with pytest.raises(MetricsError, match=message):
        turning_metrics(traj)


def test_execute_time_outside_the_run_is_rejected() -> None:
    with pytest.raises(MetricsError, match="not inside the trajectory"):
        turning_metrics(circle_run(), execute_time_s=-1.0)


def test_trajectory_of_puts_each_state_column_in_its_field() -> None:
    time_s = np.array([0.0, 1.0])
    states = np.arange(12.0).reshape(2, 6)
    traj = trajectory_of(time_s, states, np.array([0.1, 0.2]), np.array([1.5, 1.6]))
    assert [list(traj[name]) for name in STATE_FIELDS] == [list(c) for c in states.T]
    assert list(traj["x_m"]) == [3.0, 9.0] and list(traj["psi_rad"]) == [5.0, 11.0]
    assert list(traj["time_s"]) == [0.0, 1.0] and list(traj["n_rps"]) == [1.5, 1.6]
    assert list(traj["rudder_rad"]) == [0.1, 0.2]


def test_plain_array_is_rejected() -> None:
    with pytest.raises(MetricsError, match="structured"):
        turning_metrics(np.zeros((10, 9)))


# --------------------------------------------------------------------------------------
# Distance at heading change (IMO initial turning ability)
# --------------------------------------------------------------------------------------


def test_distance_at_heading_change_is_the_track_length() -> None:
    radius, step = 400.0, 1.0 * DEG
    traj = circle_run(radius_m=radius, step_rad=step, approach_s=60.0)
    chord = 2.0 * radius * math.sin(0.5 * step)
    # on a sample: ten chords; between samples: the crossing is half-way in time
    assert distance_at_heading_change(traj, 10.0 * DEG) == pytest.approx(10.0 * chord, 1e-12)
    assert distance_at_heading_change(traj, 10.5 * DEG) == pytest.approx(10.5 * chord, 1e-12)
    # port turn: the same (either side counts)
    port = circle_run(radius_m=radius, step_rad=step, side=-1)
    assert distance_at_heading_change(port, 10.0 * DEG) == pytest.approx(10.0 * chord, 1e-12)
    # execute earlier: the approach distance is included
    from_earlier = distance_at_heading_change(traj, 10.0 * DEG, execute_time_s=-30.0)
    assert from_earlier == pytest.approx(30.0 * 5.0 + 10.0 * chord, rel=1e-12)


def test_distance_at_heading_change_never_reached() -> None:
    with pytest.raises(MetricsError, match=r"never reaches 10\.00 deg"):
        distance_at_heading_change(circle_run(turned_rad=5.0 * DEG), 10.0 * DEG)


# --------------------------------------------------------------------------------------
# Zig-zag
# --------------------------------------------------------------------------------------


class CappedZigzag:
    """Heading change h(t): straight ramps of slope ±a joined by parabolic caps (C¹).

    h = 0 for t ≤ 0, then rises at slope a. Peak i is the parabola
    P_i − sign(P_i) k (t − tp_i)² with k = a² / (4 d), entered and left at slope ±a,
    d below the peak. With the ±Z crossings on the ramps and every peak's three nearest
    samples inside its cap, linear crossing interpolation and the three-point parabola
    are exact, so every metric is known to rounding error.
    """

    def __init__(self, slope: float, drop: float, peaks: list[float]) -> None:
        self.slope = slope
        self.k = slope * slope / (4.0 * drop)
        half_width = 2.0 * drop / slope
        self.ramps: list[tuple[float, float, float]] = []  # (t_start, h_start, slope)
        self.caps: list[tuple[float, float, float]] = []  # (t_peak, peak, half_width)
        t_now, level = 0.0, 0.0
        for peak in peaks:
            sign = math.copysign(1.0, peak)
            entry = peak - sign * drop
            self.ramps.append((t_now, level, sign * slope))
            t_peak = t_now + abs(entry - level) / slope + half_width
            self.caps.append((t_peak, peak, half_width))
            t_now, level = t_peak + half_width, entry
        self.ramps.append((t_now, level, -math.copysign(1.0, peaks[-1]) * slope))

    def __call__(self, t: np.ndarray) -> np.ndarray:
        h = np.zeros_like(t)
        for t0, h0, slope in self.ramps:
            on = t >= t0
            h[on] = h0 + slope * (t[on] - t0)
        for t_peak, peak, half in self.caps:
            on = np.abs(t - t_peak) <= half
            h[on] = peak - math.copysign(1.0, peak) * self.k * (t[on] - t_peak) ** 2
        return h

    def crossing(self, ramp: int, level: float) -> float:
        t0, h0, slope = self.ramps[ramp]
        return t0 + (level - h0) / slope


def zigzag_run(t: np.ndarray, heading_change_rad: np.ndarray, psi0_rad: float) -> np.ndarray:
    traj = empty_trajectory(t.size)
    traj["time_s"] = t
    traj["psi_rad"] = psi0_rad + heading_change_rad
    traj["u_mps"] = 7.0
    traj["v_mps"] = -0.5
    return traj


def irregular_times(t_end: float, step: float, seed: int = 3) -> np.ndarray:
    """Sample times with ±30 % jitter, one of them exactly 0 (the execute)."""
    rng = np.random.default_rng(seed)
    steps = step * (1.0 + 0.6 * (rng.random(int(t_end / step) + 10) - 0.5))
    after = np.cumsum(steps)
    before = -np.cumsum(steps[:20])[::-1]
    t = np.concatenate((before, [0.0], after))
    return t[t <= t_end]


ZIG = CappedZigzag(
    slope=0.5 * DEG, drop=2.0 * DEG, peaks=[15 * DEG, -22 * DEG, 18 * DEG, -17 * DEG]
)
Z10 = 10.0 * DEG


@pytest.mark.parametrize("side", [1, -1])
def test_capped_zigzag_metrics_are_exact(side: int) -> None:
    t = irregular_times(ZIG.caps[-1][0] + 40.0, 0.3)
    m = zigzag_metrics(zigzag_run(t, side * ZIG(t), psi0_rad=1.2), side * 10.0 * DEG, Z10)
    expected_reversals = (
        ZIG.crossing(0, Z10),
        ZIG.crossing(1, -Z10),
        ZIG.crossing(2, Z10),
        ZIG.crossing(3, -Z10),
    )
    assert m.reversal_times_s == pytest.approx(expected_reversals, abs=1e-9)
    assert m.initial_turning_time_s == pytest.approx(Z10 / ZIG.slope, abs=1e-9)
    assert m.first_overshoot_deg == pytest.approx(5.0, abs=1e-9)
    assert m.second_overshoot_deg == pytest.approx(12.0, abs=1e-9)
    assert m.third_overshoot_deg == pytest.approx(8.0, abs=1e-9)
    assert m.peak_times_s == pytest.approx([c[0] for c in ZIG.caps[:3]], abs=1e-9)
    assert m.time_to_check_yaw_s == pytest.approx(ZIG.caps[0][0] - expected_reversals[0], 1e-9)
    assert m.period_s == pytest.approx(expected_reversals[2] - expected_reversals[0], abs=1e-9)
    assert m.initial_heading_rad == pytest.approx(1.2)
    assert m.approach_speed_mps == pytest.approx(math.hypot(7.0, 0.5))


def test_port_first_mirrors_starboard_first() -> None:
    t = irregular_times(ZIG.caps[-1][0] + 40.0, 0.3)
    stbd = zigzag_metrics(zigzag_run(t, ZIG(t), 0.0), 10.0 * DEG, Z10).as_dict()
    port = zigzag_metrics(zigzag_run(t, -ZIG(t), 0.0), -10.0 * DEG, Z10).as_dict()
    assert port.pop("rudder_deg") == pytest.approx(-10.0)
    assert stbd.pop("rudder_deg") == pytest.approx(10.0)
    assert port == stbd


def test_wrong_side_sees_no_reversal() -> None:
    # a starboard-first history up to its first peak, analysed as port-first: the heading
    # never reaches the check heading on the port side
    t = irregular_times(ZIG.caps[0][0], 0.3)
    with pytest.raises(MetricsError, match="no rudder reversal"):
        zigzag_metrics(zigzag_run(t, ZIG(t), 0.0), -10.0 * DEG, Z10)


def test_sinusoidal_zigzag_peak_to_1e6_degree() -> None:
    """h = A sin(ωt): overshoots A − Z, peaks at T/4 and 3T/4, crossings at asin(Z/A)/ω.

    Linear crossing interpolation errs by at most h''Δt²/8 / h' = A ω Δt² / (8 √(1 − (Z/A)²)).
    """
    amp, period, dt = 17.3 * DEG, 97.3, 0.1
    omega = 2.0 * math.pi / period
    t = np.arange(-200, 3200) * dt
    m = zigzag_metrics(zigzag_run(t, amp * np.sin(omega * np.clip(t, 0.0, None)), 0.0), Z10, Z10)
    assert m.first_overshoot_deg == pytest.approx((amp - Z10) / DEG, abs=1e-6)
    assert m.second_overshoot_deg == pytest.approx((amp - Z10) / DEG, abs=1e-6)
    assert m.third_overshoot_deg == pytest.approx((amp - Z10) / DEG, abs=1e-6)
    assert m.peak_times_s[:2] == pytest.approx([period / 4.0, 3.0 * period / 4.0], abs=1e-6)
    t_cross = math.asin(Z10 / amp) / omega
    bound = amp * omega * dt**2 / (8.0 * math.sqrt(1.0 - (Z10 / amp) ** 2)) / amp
    assert m.reversal_times_s[0] == pytest.approx(t_cross, abs=bound)
    assert m.reversal_times_s[1] == pytest.approx(period / 2.0 + t_cross, abs=bound)
    assert m.period_s == pytest.approx(period, abs=2.0 * bound)


def test_zigzag_as_dict_keys() -> None:
    t = irregular_times(ZIG.caps[1][0] + 10.0, 0.3)  # covers two overshoots, 2 reversals
    d = zigzag_metrics(zigzag_run(t, ZIG(t), 0.0), Z10, Z10).as_dict()
    assert d["first_overshoot_deg"] == pytest.approx(5.0)
    assert d["second_overshoot_deg"] == pytest.approx(12.0)
    assert "third_overshoot_deg" not in d
    assert "period_s" not in d
    assert d["heading_deg"] == pytest.approx(10.0)
    assert d["first_reversal_time_s"] == pytest.approx(20.0)
    assert set(d) >= {"initial_turning_time_s", "time_to_check_yaw_s", "reversal_times_s"}


def test_zigzag_without_reversal_is_an_error() -> None:
    t = np.linspace(0.0, 100.0, 201)
    with pytest.raises(MetricsError, match="no rudder reversal"):
        zigzag_metrics(zigzag_run(t, 0.05 * DEG * t, 0.0), Z10, Z10)


def test_zigzag_ending_before_the_first_peak_is_an_error() -> None:
    t = irregular_times(ZIG.caps[0][0] - 1.0, 0.3)
    with pytest.raises(MetricsError, match="first overshoot is not covered"):
        zigzag_metrics(zigzag_run(t, ZIG(t), 0.0), Z10, Z10)


def test_zigzag_rejects_zero_rudder() -> None:
    t = np.linspace(0.0, 100.0, 201)
    with pytest.raises(MetricsError, match="rudder_rad"):
        zigzag_metrics(zigzag_run(t, 0.0 * t, 0.0), 0.0, Z10)


# --------------------------------------------------------------------------------------
# Spiral
# --------------------------------------------------------------------------------------

SPIRAL_DELTA = np.concatenate(
    (np.arange(25.0, -25.1, -2.5), np.arange(-22.5, 25.1, 2.5))
)  # +25 → −25 → +25 deg in steps of 2.5 deg


def test_stable_spiral_has_no_loop() -> None:
    delta = SPIRAL_DELTA * DEG
    r = 0.02 * np.tanh(3.0 * (delta - 0.5 * DEG))  # single-valued, slight asymmetry
    m = spiral_metrics(delta, r)
    assert m.loop_width_rad == 0.0
    assert m.is_stable
    assert m.loop_low_rad is None
    assert list(m.curve_rudder_rad) == sorted(m.curve_rudder_rad)
    assert np.all(np.diff(m.curve_yaw_rate_radps) >= 0.0)
    assert m.rudder_rad[0] == pytest.approx(25.0 * DEG)


def test_unstable_spiral_loop_width_is_the_constructed_one() -> None:
    """Descending: starboard turn persists down to −5°; ascending: port turn up to +5°."""
    delta_deg = SPIRAL_DELTA
    descending = np.arange(delta_deg.size) <= np.argmin(delta_deg)
    r = np.where(
        descending,
        np.where(delta_deg >= -5.0, 1.0, -1.0),
        np.where(delta_deg <= 5.0, -1.0, 1.0),
    ) * (0.01 + 0.001 * np.abs(delta_deg))
    m = spiral_metrics(delta_deg * DEG, r)
    assert m.loop_width_deg == pytest.approx(10.0, abs=1e-12)
    assert m.loop_low_rad == pytest.approx(-5.0 * DEG)
    assert m.loop_high_rad == pytest.approx(5.0 * DEG)
    assert not m.is_stable


def test_spiral_tolerance_ignores_near_zero_yaw_rates() -> None:
    delta = np.array([5.0, 0.0, -5.0, 0.0, 5.0]) * DEG
    r = np.array([0.01, 1e-9, -0.01, -1e-9, 0.01])
    assert spiral_metrics(delta, r).loop_width_rad == 0.0  # both at δ = 0
    r_noisy = np.array([0.01, -1e-9, -0.01, 1e-9, 0.01])
    shifted = np.array([5.0, 0.1, -5.0, -0.1, 5.0]) * DEG
    assert spiral_metrics(shifted, r_noisy).loop_width_deg == pytest.approx(0.2)
    assert spiral_metrics(shifted, r_noisy, yaw_rate_tol_radps=1e-6).loop_width_rad == 0.0


def test_spiral_rejects_mismatched_input() -> None:
    with pytest.raises(MetricsError, match="equal length"):
        spiral_metrics([0.1, 0.2], [0.01])


def test_steady_yaw_rate_is_the_window_mean() -> None:
    t = np.linspace(0.0, 100.0, 101)
    traj = empty_trajectory(t.size)
    traj["time_s"] = t
    traj["r_radps"] = 0.001 * t  # linear: the mean over [a, b] is 0.001 (a + b) / 2
    assert steady_yaw_rate(traj, 10.25, 60.5) == pytest.approx(0.001 * 35.375, rel=1e-12)
    with pytest.raises(MetricsError, match="inside the trajectory"):
        steady_yaw_rate(traj, 50.0, 120.0)


# --------------------------------------------------------------------------------------
# Pull-out
# --------------------------------------------------------------------------------------


def pullout_run(r_inf: float, r0: float = 0.01, time_constant_s: float = 23.4) -> np.ndarray:
    t = np.arange(0.0, 400.0, 0.5)
    traj = empty_trajectory(t.size)
    traj["time_s"] = t
    decay = r_inf + (r0 - r_inf) * np.exp(-(t - 50.0) / time_constant_s)
    traj["r_radps"] = np.where(t < 50.0, r0, decay)
    return traj


def test_pullout_recovers_the_time_constant_of_a_stable_ship() -> None:
    m = pullout_metrics(pullout_run(0.0), 50.0)
    assert m.time_constant_s == pytest.approx(23.4, rel=1e-6)
    assert m.initial_yaw_rate_radps == pytest.approx(0.01)
    assert abs(m.residual_yaw_rate_radps) < 1e-6
    assert m.fitted_residual_yaw_rate_radps == pytest.approx(0.0, abs=1e-9)


@pytest.mark.parametrize("r_inf", [0.003, -0.002])
def test_pullout_of_an_unstable_ship_keeps_a_residual_yaw_rate(r_inf: float) -> None:
    m = pullout_metrics(pullout_run(r_inf), 50.0)
    assert m.time_constant_s == pytest.approx(23.4, rel=1e-6)
    assert m.fitted_residual_yaw_rate_radps == pytest.approx(r_inf, rel=1e-6)
    assert m.residual_yaw_rate_radps == pytest.approx(r_inf, rel=1e-3)


def test_pullout_without_change_has_no_time_constant() -> None:
    traj = pullout_run(0.0)
    traj["r_radps"] = 0.0
    m = pullout_metrics(traj, 50.0)
    assert m.time_constant_s is None
    assert m.residual_yaw_rate_radps == 0.0


def test_pullout_release_outside_the_run_is_rejected() -> None:
    with pytest.raises(MetricsError, match="not inside the trajectory"):
        pullout_metrics(pullout_run(0.0), 500.0)
