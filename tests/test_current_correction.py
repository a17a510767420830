"""The current correction of turning circles, IMO MSC/Circ.1053 3.4.2.5.

A uniform current adds c t to the track over ground and changes nothing else, so a
turning circle in current is built exactly as the still-water track plus c t: the
estimate must find c, and the corrected track must give the still-water indices.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from scenarios.cli import main
from scenarios.imo import turning_ability_in_current
from trials.current_correction import (
    DRIFT_THRESHOLD_FRACTION,
    correct_turning_circle,
    estimate_current,
    remove_drift,
)
from trials.logs import ManeuverLog, write_log
from trials.maneuvers import turning_circle
from trials.metrics import MetricsError, turning_metrics
from trials.run import ModelPlant, run_program
from trials.trajectory import empty_trajectory

DEG = math.pi / 180.0
RADIUS_M = 400.0
SPEED_MPS = 5.0
INDICES = ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m")


def _trajectory(
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    psi: np.ndarray,
    drift: tuple[float, float],
    water_velocity: tuple[np.ndarray, np.ndarray],
) -> np.ndarray:
    """A trajectory over ground: still-water track plus c t; u, v over ground (a log's)."""
    traj = empty_trajectory(t.size)
    traj["time_s"] = t
    traj["x_m"] = x + drift[0] * t
    traj["y_m"] = y + drift[1] * t
    traj["psi_rad"] = psi
    ground_n = water_velocity[0] + drift[0]
    ground_e = water_velocity[1] + drift[1]
    traj["u_mps"] = np.cos(psi) * ground_n + np.sin(psi) * ground_e
    traj["v_mps"] = -np.sin(psi) * ground_n + np.cos(psi) * ground_e
    traj["rudder_rad"] = np.where(t >= 0.0, 35.0 * DEG, 0.0)
    return traj


def steady_circle(
    t: np.ndarray,
    *,
    drift: tuple[float, float] = (0.0, 0.0),
    side: int = 1,
    psi0_rad: float = 0.3,
) -> np.ndarray:
    """A straight approach (t < 0), then from t = 0 a circle of radius R at speed U.

    Exact at any sample time: heading ψ0 + side U t / R, position on the circle,
    drift ``(c_N, c_E)`` [m/s] added as c t.
    """
    rate = SPEED_MPS / RADIUS_M
    theta = np.where(t >= 0.0, rate * t, 0.0)
    ahead = np.where(t >= 0.0, RADIUS_M * np.sin(theta), SPEED_MPS * t)
    lateral = side * RADIUS_M * (1.0 - np.cos(theta))
    psi = psi0_rad + side * theta
    x = ahead * math.cos(psi0_rad) - lateral * math.sin(psi0_rad)
    y = ahead * math.sin(psi0_rad) + lateral * math.cos(psi0_rad)
    velocity = (SPEED_MPS * np.cos(psi), SPEED_MPS * np.sin(psi))
    return _trajectory(t, x, y, psi, drift, velocity)


def settling_spiral(
    every: int, *, drift: tuple[float, float] = (0.0, 0.0), end_s: float = 1800.0
) -> np.ndarray:
    """A ship slowing from 8 to 5 m/s (time constant 60 s) while its yaw rate builds
    up to U∞/R (30 s) after execute: a spiral in to the 400 m circle.

    Integrated by the trapezoidal rule at 0.05 s, sampled every ``every`` steps; the
    drift is added to the integrated track, so the track with and without it differ by
    exactly c t.
    """
    t = np.arange(-60.0, end_s, 0.05)
    after = np.clip(t, 0.0, None)
    speed = np.where(t < 0.0, 8.0, SPEED_MPS + 3.0 * np.exp(-after / 60.0))
    rate = np.where(t < 0.0, 0.0, SPEED_MPS / RADIUS_M * (1.0 - np.exp(-after / 30.0)))

    def integral(f: np.ndarray) -> np.ndarray:
        out = np.concatenate(([0.0], np.cumsum(0.5 * (f[1:] + f[:-1]) * np.diff(t))))
        return out - np.interp(0.0, t, out)

    psi = 0.3 + integral(rate)
    north, east = speed * np.cos(psi), speed * np.sin(psi)
    traj = _trajectory(t, integral(north), integral(east), psi, drift, (north, east))
    return traj[::every]


def _still(traj: np.ndarray, drift: tuple[float, float]) -> np.ndarray:
    """The same samples without the drift (u, v through the water)."""
    return remove_drift(traj, drift[0], drift[1], 0.0)


# ----------------------------------------------------------------- the estimate


@pytest.mark.parametrize("side", [1, -1], ids=["starboard", "port"])
@pytest.mark.parametrize("towards_deg", [0.0, 135.0, 250.0])
def test_drifting_circle_gives_its_drift_and_the_still_water_indices(side, towards_deg):
    drift = (0.5 * math.cos(towards_deg * DEG), 0.5 * math.sin(towards_deg * DEG))
    t = np.arange(-60.0, 1600.0, 1.0)  # 3 turns of 503 s after a 60 s approach
    traj = steady_circle(t, drift=drift, side=side)
    still = turning_metrics(steady_circle(t, side=side))

    got = correct_turning_circle(traj)
    e = got.estimate
    assert e.drift_north_mps == pytest.approx(drift[0], abs=2e-5)
    assert e.drift_east_mps == pytest.approx(drift[1], abs=2e-5)
    assert e.speed_mps == pytest.approx(0.5, abs=2e-5)
    off_deg = (math.degrees(e.direction_rad) - towards_deg + 180.0) % 360.0 - 180.0
    assert 0.0 <= math.degrees(e.direction_rad) < 360.0 and abs(off_deg) < 0.01
    assert max(e.spread_north_mps, e.spread_east_mps) < 1e-4  # a steady turn
    # Reference headings from 180 deg to (1080 - 360) deg in 1 deg steps.
    turned = SPEED_MPS / RADIUS_M * t[-1] / DEG
    assert e.n_pairs == math.floor(turned - 360.0 - 180.0) + 1
    assert e.first_heading_change_rad == pytest.approx(math.pi)
    assert e.mean_period_s == pytest.approx(2.0 * math.pi * RADIUS_M / SPEED_MPS, rel=1e-9)

    for key in INDICES:
        assert getattr(got.corrected, key) == pytest.approx(getattr(still, key), abs=0.05), key
    # The drift moved the raw indices by tens of metres: the test can fail.
    assert max(abs(getattr(got.raw, k) - getattr(still, k)) for k in INDICES) > 40.0
    # Velocities over ground corrected too: the approach speed through the water.
    assert got.corrected.approach_speed_mps == pytest.approx(SPEED_MPS, abs=1e-6)
    assert got.corrected.steady_speed_ratio == pytest.approx(1.0, abs=1e-4)
    assert got.is_significant()


def test_still_water_circle_gives_no_drift():
    # Sampled at whole degrees of heading: both ends of every pair are samples.
    t = np.arange(0.0, 1081.0) * DEG * RADIUS_M / SPEED_MPS
    exact = correct_turning_circle(steady_circle(t))
    assert exact.estimate.speed_mps < 1e-12
    assert not exact.is_significant()
    for key in INDICES:
        assert getattr(exact.corrected, key) == pytest.approx(getattr(exact.raw, key), abs=1e-9)
    # Sampled every 1 s (0.72 deg): pairs interpolated on chords, 8 mm sagitta.
    sampled = estimate_current(steady_circle(np.arange(0.0, 1600.0, 1.0)))
    assert sampled.speed_mps < 2e-5


@pytest.mark.parametrize("turned_deg", [300.0, 600.0, 719.0])
def test_a_turn_short_of_720_deg_is_refused(turned_deg):
    t = np.arange(0.0, turned_deg * DEG * RADIUS_M / SPEED_MPS, 1.0)
    traj = steady_circle(t, drift=(0.3, 0.0))
    reached_deg = math.degrees(SPEED_MPS / RADIUS_M * t[-1])  # at the last sample
    with pytest.raises(
        MetricsError,
        match=(
            rf"^the heading changes by at most {reached_deg:.1f} deg after execute; the current "
            r"correction \(IMO MSC/Circ.1053 3.4.2.5\) needs 720 deg: positions one full turn "
            r"apart from 180 deg of heading change on$"
        ),
    ):
        estimate_current(traj)


def test_a_shorter_turn_may_be_asked_for_but_needs_two_pairs():
    t = np.arange(0.0, 600.0 * DEG * RADIUS_M / SPEED_MPS, 1.0)  # 600 deg
    drift = (0.3, -0.1)
    e = estimate_current(steady_circle(t, drift=drift), min_heading_change_rad=540.0 * DEG)
    assert e.n_pairs == 60  # 180 .. 239 deg, the last sample short of 600 deg
    assert (e.drift_north_mps, e.drift_east_mps) == pytest.approx(drift, abs=2e-5)
    with pytest.raises(MetricsError, match=r"fewer than two pairs of positions 360 deg apart"):
        estimate_current(
            steady_circle(t[t < 540.9 * DEG * RADIUS_M / SPEED_MPS]),
            min_heading_change_rad=540.0 * DEG,
        )


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"min_heading_change_rad": 500.0 * DEG}, r"must be at least start_heading_change_rad"),
        ({"heading_step_rad": 0.0}, r"heading_step_rad must be a positive number"),
        ({"start_heading_change_rad": -1.0}, r"start_heading_change_rad must be a non-negative"),
    ],
)
def test_bad_options_are_refused(options, message):
    t = np.arange(0.0, 1600.0, 1.0)
    with pytest.raises(MetricsError, match=message):
        estimate_current(steady_circle(t), **options)


def test_a_straight_run_is_not_a_turning_circle():
    traj = steady_circle(np.arange(-100.0, 0.0, 1.0))
    with pytest.raises(MetricsError, match="the heading never changes after execute"):
        estimate_current(traj, execute_time_s=-50.0)


def test_irregular_sampling():
    rng = np.random.default_rng(7)
    t = np.concatenate(([-60.0], -60.0 + np.cumsum(rng.uniform(0.2, 4.0, 900))))
    t = t[t < 1600.0]
    drift = (-0.25, 0.4)
    got = correct_turning_circle(steady_circle(t, drift=drift))
    # Steps of up to 4 s are 2.9 deg of heading: chords 0.12 m inside the arc.
    assert got.estimate.drift_north_mps == pytest.approx(drift[0], abs=1e-4)
    assert got.estimate.drift_east_mps == pytest.approx(drift[1], abs=1e-4)
    still = turning_metrics(steady_circle(t))
    for key in INDICES:
        assert getattr(got.corrected, key) == pytest.approx(getattr(still, key), abs=0.2), key


def test_a_settling_spiral_is_measured_after_its_transient():
    """The turn spirals in while the ship slows: positions one turn apart then differ by
    the shrinking radius as well as by the drift. From 180 deg on (IMO) the transient
    has decayed; counting the first 180 deg too would err a hundred times more."""
    drift = (0.2, 0.35)
    traj = settling_spiral(20, drift=drift)  # 1 s samples, 1267 deg
    got = correct_turning_circle(traj)
    error = math.hypot(
        got.estimate.drift_north_mps - drift[0], got.estimate.drift_east_mps - drift[1]
    )
    assert error < 3e-4
    from_execute = estimate_current(traj, start_heading_change_rad=0.0)
    early = math.hypot(
        from_execute.drift_north_mps - drift[0], from_execute.drift_east_mps - drift[1]
    )
    assert early > 30.0 * error and early > 5e-3
    # The spread says how unsteady the pairs were.
    assert from_execute.spread_east_mps > 10.0 * got.estimate.spread_east_mps

    still = turning_metrics(_still(traj, drift))
    for key in INDICES:
        assert getattr(got.corrected, key) == pytest.approx(getattr(still, key), abs=0.5), key
    assert got.corrected.approach_speed_mps == pytest.approx(8.0, abs=1e-3)


def test_remove_drift_shifts_a_copy():
    t = np.arange(-10.0, 20.0, 1.0)
    traj = steady_circle(t)
    before = traj.copy()
    out = remove_drift(traj, 0.5, -0.25, 5.0, velocities="water")
    np.testing.assert_array_equal(traj, before)
    np.testing.assert_allclose(out["x_m"], traj["x_m"] - 0.5 * (t - 5.0), rtol=0, atol=1e-12)
    np.testing.assert_allclose(out["y_m"], traj["y_m"] + 0.25 * (t - 5.0), rtol=0, atol=1e-12)
    for name in ("u_mps", "v_mps", "psi_rad", "time_s", "rudder_rad"):
        np.testing.assert_array_equal(out[name], traj[name])
    ground = remove_drift(traj, 0.5, -0.25, 5.0)
    assert not np.array_equal(ground["u_mps"], traj["u_mps"])
    with pytest.raises(ValueError, match="velocities must be 'ground' or 'water'"):
        remove_drift(traj, 0.5, 0.0, 0.0, velocities="air")  # type: ignore[arg-type]


def test_estimate_record():
    t = np.arange(-60.0, 1600.0, 1.0)
    e = estimate_current(steady_circle(t, drift=(0.0, -0.3)))
    record = e.as_dict()
    assert record["procedure"] == "IMO MSC/Circ.1053 3.4.2.5"
    assert record["drift_direction_deg"] == pytest.approx(270.0, abs=0.01)
    assert record["drift_speed_mps"] == pytest.approx(0.3, abs=2e-5)
    assert record["first_heading_change_deg"] == pytest.approx(180.0)
    assert record["last_heading_change_deg"] == pytest.approx(180.0 + record["n_pairs"] - 1)


# ------------------------------------------------------------------ IMO judgement


def test_imo_judges_the_corrected_indices_when_the_drift_counts():
    t = np.arange(-60.0, 1600.0, 1.0)
    length = 100.0
    drifting = correct_turning_circle(steady_circle(t, drift=(0.3, 0.3)))
    judged = turning_ability_in_current(drifting.raw, drifting, length)
    assert judged.corrected and judged.basis == "current-corrected"
    assert judged.criteria[0].name == "turning ability: advance (starboard, current-corrected)"
    assert judged.criteria[0].value == drifting.corrected.advance_m
    assert judged.criteria[1].value == drifting.corrected.tactical_diameter_m
    assert judged.reason.endswith(
        f"against {DRIFT_THRESHOLD_FRACTION * SPEED_MPS:.3f} m/s = 1 % of the approach speed: above"
    )

    off = turning_ability_in_current(drifting.raw, drifting, length, correct=False)
    assert not off.corrected and off.criteria[0].value == drifting.raw.advance_m
    assert off.criteria[0].name == "turning ability: advance (starboard)"
    assert off.reason.startswith("current correction switched off")

    # A drift of 0.5 % of U is below the 1 % threshold.
    weak = correct_turning_circle(steady_circle(t, drift=(0.025, 0.0)))
    below = turning_ability_in_current(weak.raw, weak, length)
    assert below.basis == "raw" and below.reason.endswith("not above")
    assert below.criteria[0].value == weak.raw.advance_m

    short = turning_metrics(steady_circle(np.arange(0.0, 300.0, 1.0)))
    none = turning_ability_in_current(short, None, length)
    assert none.basis == "raw" and "less than 720 deg" in none.reason
    assert none.as_dict()["criteria"][0]["name"] == "turning ability: advance (starboard)"


# ------------------------------------------------------------------ command line


@pytest.fixture(scope="module")
def fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from fmu_model.export_native import build_native_fmu
    from tests.test_scenarios_cli import _params

    return build_native_fmu(_params(), tmp_path_factory.mktemp("fmu") / "testship.fmu")


def test_cli_still_water_turn_reports_no_current(fmu, tmp_path, capsys):
    out = tmp_path / "turn.json"
    args = ["turning-circle", "--fmu", str(fmu), "--quiet", "--json", str(out)]
    assert main(args) == 0  # the default 540 deg: no estimate, outputs as before
    default = capsys.readouterr().out
    assert "current" not in default
    assert "current_corrected" not in json.loads(out.read_text())

    assert main([*args, "--heading-change-deg", "720"]) == 0
    printed = capsys.readouterr().out
    record = json.loads(out.read_text())
    current = record["current_corrected"]
    # The test ship is still settling after 180 deg (32 % speed loss): 1 cm/s of
    # apparent drift, 0.2 % of U, well below the 1 % threshold.
    assert current["drift_speed_mps"] < 0.02
    assert current["threshold_mps"] == pytest.approx(0.05)
    assert current["applied"] is False and current["imo_basis"] == "raw"
    assert current["n_pairs"] == 181
    assert [c["name"] for c in current["imo_criteria"]] == [
        "turning ability: advance (starboard)",
        "turning ability: tactical diameter (starboard)",
    ]
    assert record["advance_m"] == pytest.approx(current["advance_m"], abs=1.0)
    assert printed.startswith(default.split("\n")[0])
    assert "IMO MSC.137(76) 5.3.1 judged on the raw values" in printed


def test_cli_like_a_log_in_current_compares_corrected(fmu, tmp_path, capsys):
    """A 35 deg turn of the ship the FMU holds, logged at 1 Hz to 800 deg in a 0.36 m/s
    current: corrected, the log agrees with the FMU sailed in still water at the log's
    speed through the water; raw, it does not."""
    from tests.test_scenarios_cli import RUDDER_RATE_RADPS, _params

    program = turning_circle(35.0 * DEG, heading_change_rad=800.0 * DEG, max_time_s=3000.0)
    truth = run_program(
        ModelPlant(_params()),
        replace(program, approach_s=60.0),
        speed_mps=5.0,
        n_rps=2.0,
        rudder_rate_radps=RUDDER_RATE_RADPS,
        dt_s=1.0,
    )
    drift = (0.3, -0.2)
    t = truth["time_s"]
    log = tmp_path / "in-current.csv"
    write_log(
        log,
        ManeuverLog(
            t - t[0],
            truth["x_m"] + drift[0] * t,
            truth["y_m"] + drift[1] * t,
            truth["psi_rad"],
            truth["rudder_rad"],
            truth["n_rps"],
            metadata={"vessel": "testship", "length_m": "100.0"},
        ),
    )
    out, png = tmp_path / "like.json", tmp_path / "like.png"
    args = ["turning-circle", "--fmu", str(fmu), "--like", str(log), "--quiet"]
    assert main([*args, "--json", str(out), "--plot", str(png)]) == 0  # the corrected log drawn
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    record = json.loads(out.read_text())
    logged = record["logged"]
    current = logged["current_corrected"]
    assert current["applied"] is True and current["imo_basis"] == "current-corrected"
    assert current["drift_north_mps"] == pytest.approx(drift[0], abs=0.01)
    assert current["drift_east_mps"] == pytest.approx(drift[1], abs=0.01)
    assert record["run"]["speed_mps"] == pytest.approx(5.0, abs=0.01)  # through the water
    for key in ("advance_m", "transfer_m", "tactical_diameter_m"):
        assert current[key] == pytest.approx(record[key], rel=0.01), key
    assert abs(logged["tactical_diameter_m"] - record["tactical_diameter_m"]) > 15.0
    assert "as logged in" in printed and ", current-corrected:" in printed
    assert "judged on the current-corrected values" in printed

    assert main([*args, "--json", str(out), "--no-current-correction"]) == 0
    raw = json.loads(out.read_text())
    assert raw["logged"]["current_corrected"]["applied"] is False
    assert raw["run"]["speed_mps"] > 5.25  # over ground, with the current along the approach
    assert "judged on the raw values (current correction switched off" in capsys.readouterr().out
