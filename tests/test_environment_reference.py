"""The KVLCC2 reference ship at sea: current, wind and gusts (scenarios.kvlcc2, .sea),
the logs they synthesise and ``python -m scenarios synthesize``'s options for them.

Forces are checked against Blendermann's (1994) formulas written out by hand with the
windage of docs/kvlcc2_environment.md; the current against the kinematics it must
reduce to; the gusts against their stated standard deviation and correlation time.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

from fmu_model.environment import Windage, wind_accelerations
from scenarios import synthesize
from scenarios.cli import PROG, main
from scenarios.kvlcc2 import (
    FROUDE_SCALE_RATIO,
    ReferencePlant,
    environment_forces,
    kvlcc2,
    kvlcc2_windage,
    mmg_rhs,
)
from scenarios.sea import GustProcess, SeaEnvironment, default_gust_time_s
from scenarios.synthesize import default_logging, maneuver_seed, reference_ship, synthesize_log
from trials.logs import LOG_COLUMNS, format_log, read_log
from trials.maneuvers import Program, turning_circle, zigzag
from trials.run import run_program

RHO_AIR = 1.225  # ISO standard atmosphere, as fmu_model.environment
# Blendermann (1994), tanker loaded: C_Dt, C_Dl,AF(0), delta
CD_T, CD_L_BOW, DELTA = 0.70, 0.90, 0.40
# docs/kvlcc2_environment.md, full scale
A_F, A_L, L_OA = 1714.0, 3994.6, 330.0
S_L = (750.0 * -145.0 + 100.0 * -150.0) / A_L


def _run(plant: ReferencePlant, program: Program, dt_s: float = 0.1) -> np.ndarray:
    ship = plant.ship
    return run_program(
        plant,
        program,
        speed_mps=ship.approach_speed_mps,
        n_rps=ship.nominal_rps,
        rudder_rate_radps=ship.rudder_rate_radps,
        dt_s=dt_s,
    )


def _short_zigzag() -> Program:
    """A 10/10 zig-zag, two legs of at most 30 s each, after 10 s of approach."""
    program = zigzag(math.radians(10.0), math.radians(10.0), n_reversals=1, max_time_s=30.0)
    return replace(program, approach_s=10.0)


# --------------------------------------------------------------------------- windage


def test_windage_values_and_froude_scale() -> None:
    full, model = kvlcc2_windage("full"), kvlcc2_windage("model")
    ship = kvlcc2("full")
    assert full.frontal_area_m2 == pytest.approx(9.2 * 58.0 + 1000.0 + 50.4 + 80.0 + 50.0)
    assert full.lateral_area_m2 == pytest.approx(9.2 * 325.5 + 750.0 + 100.0 + 150.0)
    assert (full.frontal_area_m2, full.lateral_area_m2, full.length_overall_m) == pytest.approx(
        (A_F, A_L, L_OA)
    )
    assert full.lateral_centroid_m == pytest.approx(S_L) and -31.0 < S_L < -30.9
    lam = FROUDE_SCALE_RATIO
    assert model.frontal_area_m2 == pytest.approx(A_F / lam**2, rel=1e-14)
    assert model.lateral_area_m2 == pytest.approx(A_L / lam**2, rel=1e-14)
    assert model.length_overall_m == pytest.approx(L_OA / lam, rel=1e-14)
    assert model.lateral_centroid_m == pytest.approx(S_L / lam, rel=1e-14)
    # effective inertias about midship: m + m_x, m + m_y, I_zG + x_G^2 m + J_z
    q = 0.5 * 1025.0 * 320.0**2 * 20.8
    m = 1025.0 * 312_600.0
    assert full.surge_mass_kg == pytest.approx(m + 0.022 * q, rel=1e-14)
    assert full.sway_mass_kg == pytest.approx(m + 0.223 * q, rel=1e-14)
    assert full.yaw_inertia_kgm2 == pytest.approx(
        m * 80.0**2 + ship.x_g_m**2 * m + 0.011 * q * 320.0**2, rel=1e-14
    )


# --------------------------------------------------------------------------- forces by hand


def test_still_ship_in_a_beam_wind_from_starboard() -> None:
    """u = v = r = 0, n = 0, heading North, wind 20 m/s from East: gamma = +90 deg.

    Blendermann: den = 1 (sin 2 gamma = 0), C_X = 0, C_Y = -C_Dt, C_N = s_L/L_oa C_Y, so
    Y = -1/2 rho V^2 A_L C_Dt (to port) and N = Y s_L; with no motion there is no
    still-air load to take off, and no hull, propeller or rudder force.
    """
    ship = kvlcc2("full")
    env = SeaEnvironment(wind_speed_mps=20.0, wind_from_rad=math.pi / 2)
    state = np.zeros(6)
    forces = environment_forces(ship, state, env)
    q = 0.5 * RHO_AIR * 20.0**2
    Y = -q * A_L * CD_T
    assert forces.X_wind_N == pytest.approx(0.0, abs=1e-6)
    assert forces.Y_wind_N == pytest.approx(Y, rel=1e-12)
    assert forces.N_wind_Nm == pytest.approx(Y * S_L, rel=1e-12)
    assert forces.N_wind_Nm > 0.0  # pushed to port aft of midship: the bow turns to starboard
    assert (forces.X_current_N, forces.Y_current_N, forces.N_current_Nm) == (0.0, 0.0, 0.0)

    # the accelerations: Y&Y2015 eq. (4) with only the wind, solved by Cramer's rule
    windage = kvlcc2_windage("full")
    m, x_G = ship.mass_kg, ship.x_g_m
    a11, a12, a22 = windage.sway_mass_kg, x_G * m, windage.yaw_inertia_kgm2
    det = a11 * a22 - a12 * a12
    v_dot = (a22 * Y - a12 * Y * S_L) / det
    r_dot = (a11 * Y * S_L - a12 * Y) / det
    rhs = mmg_rhs(ship, state, 0.0, 0.0, environment=env)
    assert rhs[0] == pytest.approx(0.0, abs=1e-15)
    assert rhs[1] == pytest.approx(v_dot, rel=1e-12)
    assert rhs[2] == pytest.approx(r_dot, rel=1e-12)
    np.testing.assert_array_equal(rhs[3:], 0.0)


@pytest.mark.parametrize("from_deg", [30.0, 90.0, 135.0, -60.0])
def test_the_windage_accelerations_are_the_references(from_deg: float) -> None:
    """What the identification takes out (``wind_accelerations`` of ``kvlcc2_windage``) is
    what the wind does to the reference, coupling of sway and yaw included (a still ship
    heading North: the apparent wind is the true wind)."""
    ship = kvlcc2("full")
    env = SeaEnvironment(wind_speed_mps=15.0, wind_from_rad=math.radians(from_deg))
    rhs = mmg_rhs(ship, np.zeros(6), 0.0, 0.0, environment=env)
    du, dv, dr = wind_accelerations(15.0, math.radians(from_deg), kvlcc2_windage("full"))
    assert (du, dv, dr) == pytest.approx(tuple(rhs[:3]), rel=1e-12, abs=1e-18)


def test_head_wind_adds_what_the_wind_adds_to_the_still_air_drag() -> None:
    """Heading 30 deg at U0, wind 15 m/s from 30 deg: apparent V_r = W + U0 from ahead.

    X = -1/2 rho A_F C_Dl,AF(0) [(W + U0)^2 - U0^2] (the ITTC correction's form); Y = N = 0.
    """
    ship = kvlcc2("full")
    U0 = ship.approach_speed_mps
    psi = math.radians(30.0)
    env = SeaEnvironment(wind_speed_mps=15.0, wind_from_rad=psi)
    state = np.array([U0, 0.0, 0.0, 0.0, 0.0, psi])
    forces = environment_forces(ship, state, env)
    expected = -0.5 * RHO_AIR * A_F * CD_L_BOW * ((15.0 + U0) ** 2 - U0**2)
    assert forces.X_wind_N == pytest.approx(expected, rel=1e-12)
    assert (forces.Y_wind_N, forces.N_wind_Nm) == (0.0, 0.0)

    calm = mmg_rhs(ship, state, 0.0, ship.nominal_rps)
    windy = mmg_rhs(ship, state, 0.0, ship.nominal_rps, environment=env)
    assert windy[0] - calm[0] == pytest.approx(expected / kvlcc2_windage().surge_mass_kg, rel=1e-9)
    np.testing.assert_array_equal(windy[1:], calm[1:])


def test_quartering_wind_against_blendermann_by_hand() -> None:
    """Ship at rest, heading 0, wind 12 m/s from 30 deg: the whole formula, with den != 1."""
    ship = kvlcc2("full")
    gamma = math.radians(30.0)
    env = SeaEnvironment(wind_speed_mps=12.0, wind_from_rad=gamma)
    forces = environment_forces(ship, np.zeros(6), env)
    cd_l = CD_L_BOW * A_F / A_L
    den = 1.0 - 0.5 * DELTA * (1.0 - cd_l / CD_T) * math.sin(2.0 * gamma) ** 2
    q = 0.5 * RHO_AIR * 12.0**2
    cy = -CD_T * math.sin(gamma) / den
    assert forces.X_wind_N == pytest.approx(-q * A_F * CD_L_BOW * math.cos(gamma) / den, rel=1e-12)
    assert forces.Y_wind_N == pytest.approx(q * A_L * cy, rel=1e-12)
    lever = S_L / L_OA - 0.18 * (gamma - math.pi / 2)
    assert forces.N_wind_Nm == pytest.approx(q * A_L * L_OA * lever * cy, rel=1e-12)


def test_wind_load_is_froude_scaled_between_the_scales() -> None:
    full, model = kvlcc2("full"), kvlcc2("model")
    lam = FROUDE_SCALE_RATIO
    psi = 0.4
    env_full = SeaEnvironment(wind_speed_mps=14.0, wind_from_rad=1.1)
    env_model = replace(env_full, wind_speed_mps=14.0 / math.sqrt(lam))
    state = np.array([7.0, -0.4, 0.002, 0.0, 0.0, psi])
    state_model = state * np.array([lam**-0.5, lam**-0.5, lam**0.5, 1.0, 1.0, 1.0])
    f_full = environment_forces(full, state, env_full)
    f_model = environment_forces(model, state_model, env_model)
    assert f_model.X_wind_N == pytest.approx(f_full.X_wind_N / lam**3, rel=1e-12)
    assert f_model.Y_wind_N == pytest.approx(f_full.Y_wind_N / lam**3, rel=1e-12)
    assert f_model.N_wind_Nm == pytest.approx(f_full.N_wind_Nm / lam**4, rel=1e-12)


def test_a_changing_current_acts_on_the_ships_mass() -> None:
    """Current 1 m/s towards East, +0.5 m/s per hour, veering +20 deg per hour; heading 0.

    At t = 0: dc_N/dt = -c omega, dc_E/dt = c_dot; the force is -m R^T c_dot at the CG,
    so X = m c omega, Y = -m c_dot, N = -x_G m c_dot. A still ship then accelerates
    through the water at u_dot = X/(m + m_x).
    """
    ship = kvlcc2("full")
    c_dot = 0.5 / 3600.0
    omega = math.radians(20.0) / 3600.0
    env = SeaEnvironment(
        current_speed_mps=1.0,
        current_to_rad=math.pi / 2,
        current_change_mps2=c_dot,
        current_veer_radps=omega,
    )
    m = ship.mass_kg
    forces = environment_forces(ship, np.zeros(6), env)
    assert forces.X_current_N == pytest.approx(m * omega, rel=1e-12)
    assert forces.Y_current_N == pytest.approx(-m * c_dot, rel=1e-12)
    assert forces.N_current_Nm == pytest.approx(-ship.x_g_m * m * c_dot, rel=1e-12)
    assert forces.current_north_mps == pytest.approx(0.0, abs=1e-16)
    assert forces.current_east_mps == pytest.approx(1.0, rel=1e-15)
    rhs = mmg_rhs(ship, np.zeros(6), 0.0, 0.0, environment=env)
    assert rhs[0] == pytest.approx(m * omega / kvlcc2_windage().surge_mass_kg, rel=1e-12)
    assert rhs[3:5] == pytest.approx([0.0, 1.0], abs=1e-15)  # the track moves with it


def test_current_rate_is_the_derivative_of_the_current() -> None:
    env = SeaEnvironment(
        current_speed_mps=0.8,
        current_to_rad=2.0,
        current_change_mps2=-3e-4,
        current_veer_radps=4e-4,
    )
    for t in (0.0, 500.0, 3000.0):
        h = 1e-2
        ahead, behind = env.current_ne(t + h), env.current_ne(t - h)
        c_n, c_e, dc_n, dc_e = env.current_ne(t)
        assert dc_n == pytest.approx((ahead[0] - behind[0]) / (2 * h), rel=1e-6)
        assert dc_e == pytest.approx((ahead[1] - behind[1]) / (2 * h), rel=1e-6)
        speed = 0.8 - 3e-4 * t
        assert math.hypot(c_n, c_e) == pytest.approx(abs(speed), rel=1e-12)


# --------------------------------------------------------------------------- runs


def test_zero_environment_reproduces_the_calm_reference_bit_for_bit() -> None:
    ship = kvlcc2("full")
    calm = _run(ReferencePlant(ship), _short_zigzag())
    for env in (
        SeaEnvironment(),
        SeaEnvironment(current_to_rad=2.0, wind_from_rad=1.0, gust_time_s=5.0, gust_seed=3),
    ):
        at_sea = _run(ReferencePlant(ship, env), _short_zigzag())
        assert at_sea.tobytes() == calm.tobytes()
    # the calm-water plant and the module-level step are one path: reset repeats it
    plant = ReferencePlant(ship)
    assert _run(plant, _short_zigzag()).tobytes() == calm.tobytes()


def test_a_uniform_current_shifts_the_track_by_c_t() -> None:
    """Steady uniform current, no wind: through the water nothing changes (same bits);
    over ground the track moves by (c_N t, c_E t)."""
    ship = kvlcc2("model")
    c, to = 0.12, math.radians(130.0)
    calm = _run(ReferencePlant(ship), _short_zigzag(), dt_s=0.02)
    drift = _run(
        ReferencePlant(ship, SeaEnvironment(current_speed_mps=c, current_to_rad=to)),
        _short_zigzag(),
        dt_s=0.02,
    )
    for name in ("time_s", "u_mps", "v_mps", "r_radps", "psi_rad", "rudder_rad"):
        assert drift[name].tobytes() == calm[name].tobytes(), name
    t = calm["time_s"] - calm["time_s"][0]
    shift_x = drift["x_m"] - calm["x_m"]
    shift_y = drift["y_m"] - calm["y_m"]
    np.testing.assert_allclose(shift_x, c * math.cos(to) * t, rtol=0, atol=1e-9)
    np.testing.assert_allclose(shift_y, c * math.sin(to) * t, rtol=0, atol=1e-9)
    assert abs(shift_y[-1]) > 2.0  # a real shift, not a vanishing one


def test_a_beam_wind_makes_the_ship_drift_and_turn() -> None:
    """Signs over a run: a wind from starboard pushes the ship to port, and with the
    windage's centroid aft of midship the bow turns into the wind (to starboard)."""
    ship = kvlcc2("full")
    program = replace(turning_circle(0.0, max_time_s=60.0), approach_s=0.0)
    calm = _run(ReferencePlant(ship), program)
    windy = _run(
        ReferencePlant(ship, SeaEnvironment(wind_speed_mps=20.0, wind_from_rad=math.pi / 2)),
        program,
    )
    assert windy["y_m"][-1] < calm["y_m"][-1] - 0.5
    assert windy["v_mps"][-1] < 0.0
    assert windy["r_radps"][-1] > 0.0 and windy["psi_rad"][-1] > 0.0
    assert windy["u_mps"][-1] < calm["u_mps"][-1]  # the wind's drag, 20 m/s on the beam


# --------------------------------------------------------------------------- gusts


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_gust_process_has_the_stated_std_and_correlation_time(seed: int) -> None:
    """Stationary OU of std sigma and time constant T, over 10 000 T.

    The sample variance's relative standard error is sqrt(2 T / D) = 1.4 %, the sample
    std's 0.7 %: a 3 % tolerance is over 4 standard errors. The lag-T autocorrelation
    is exp(-1) = 0.368 (standard error about 0.01; tolerance 0.04).
    """
    sigma, T = 1.7, 12.0
    gust = GustProcess(sigma, T, seed)
    n = 10_000 * 20 + 1  # grid step T/20
    g = gust.nodes(n)
    assert abs(float(np.mean(g))) < 0.05 * sigma
    assert float(np.std(g)) == pytest.approx(sigma, rel=0.03)
    lag = 20
    rho = float(np.corrcoef(g[:-lag], g[lag:])[0, 1])
    assert rho == pytest.approx(math.exp(-1.0), abs=0.04)


def test_gust_path_is_reproducible_and_independent_of_where_it_is_evaluated() -> None:
    a, b = GustProcess(2.0, 30.0, 5), GustProcess(2.0, 30.0, 5)
    times = np.array([0.0, 0.7, 13.1, 250.0, 1000.3])
    late_first = [b.value(float(t)) for t in times[::-1]][::-1]
    np.testing.assert_array_equal(a.values(times), late_first)
    step = a.grid_step_s
    assert a.value(4 * step) == a.nodes(5)[4]
    assert a.value(4.5 * step) == pytest.approx(0.5 * (a.nodes(6)[4] + a.nodes(6)[5]))
    assert not np.array_equal(GustProcess(2.0, 30.0, 6).nodes(50), a.nodes(50))
    assert GustProcess(0.0, 30.0, 5).value(12.0) == 0.0


def test_the_plant_blows_the_gusts_of_its_seed() -> None:
    """A still ship's apparent wind is the true wind: W + g(t) from the mean direction."""
    ship = kvlcc2("model")
    env = SeaEnvironment(wind_speed_mps=3.0, wind_from_rad=0.5, gust_std_mps=0.4, gust_seed=9)
    plant = ReferencePlant(ship, env)
    assert plant.gust_time_s == pytest.approx(default_gust_time_s(7.0))
    assert default_gust_time_s(320.0) == 60.0
    t = np.linspace(0.0, 50.0, 201)
    zeros = np.zeros_like(t)
    speed, angle = plant.apparent_wind(t, zeros, zeros, zeros)
    expected = 3.0 + GustProcess(0.4, default_gust_time_s(7.0), 9).values(t)
    np.testing.assert_allclose(speed, expected, rtol=1e-14)
    np.testing.assert_allclose(angle, 0.5, rtol=1e-14)
    assert float(np.std(speed)) > 0.1


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"current_speed_mps": -0.1}, r"current_speed_mps must be >= 0"),
        ({"wind_speed_mps": math.nan}, r"wind_speed_mps must be finite"),
        ({"gust_std_mps": -1.0}, r"gust_std_mps must be >= 0"),
        ({"gust_time_s": 0.0}, r"gust_time_s must be > 0"),
        ({"gust_seed": -1}, r"gust_seed must be >= 0"),
        ({"current_to_rad": "north"}, r"current_to_rad must be a number"),
    ],
)
def test_sea_environment_rejects_bad_values(change: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SeaEnvironment(**change)  # type: ignore[arg-type]


# --------------------------------------------------------------------------- logs


def _quick_turn() -> Program:
    """A 20 s turn, so that the command line runs in seconds."""
    return turning_circle(math.radians(35.0), max_time_s=20.0)


def test_synthesized_log_at_sea_carries_the_sensor_columns() -> None:
    env = SeaEnvironment(
        current_speed_mps=0.1, current_to_rad=1.0, wind_speed_mps=2.0, wind_from_rad=1.0
    )
    calm = synthesize_log(reference_ship("kvlcc2", "model"), _quick_turn(), approach_s=5.0, seed=4)
    assert (calm.wind_speed_mps, calm.wind_angle_rad, calm.stw_mps) == (None, None, None)
    assert calm.metadata["source"] == (
        "synthetic turning-35-stbd: KVLCC2 MMG standard model (Yasukawa & Yoshimura 2015), "
        "model scale; 1 Hz, position noise 1 m, heading noise 0.1 deg, seed 4"
    )
    log = synthesize_log(
        reference_ship("kvlcc2", "model", env), _quick_turn(), approach_s=5.0, seed=4
    )
    assert log.stw_mps is not None and log.wind_speed_mps is not None
    assert log.wind_angle_rad is not None
    ship = kvlcc2("model")
    # stw: about the approach speed, within the speed log's noise (0.05 m/s)
    assert abs(log.stw_mps[0] - ship.approach_speed_mps) < 0.25
    assert np.all((log.wind_angle_rad >= 0.0) & (log.wind_angle_rad < 2.0 * math.pi))
    # wind 2 m/s from 57 deg on a ship heading North at 1.18 m/s in a 0.1 m/s current:
    # apparent 2.9 m/s from 37 deg during the approach (the first 5 samples)
    assert 2.2 < float(np.median(log.wind_speed_mps[:5])) < 3.6
    assert 30.0 < math.degrees(float(np.median(log.wind_angle_rad[:5]))) < 44.0
    source = log.metadata["source"]
    assert "model scale; at sea: current 0.1 m/s towards 57.2958 deg; wind 2 m/s from " in source
    assert source.endswith("seed 4; speed-log noise 0.05 m/s; anemometer noise 0.3 m/s, 2 deg")
    only_current = synthesize_log(
        reference_ship("kvlcc2", "model", replace(env, wind_speed_mps=0.0)),
        _quick_turn(),
        approach_s=5.0,
        seed=4,
    )
    assert only_current.stw_mps is not None and only_current.wind_speed_mps is None
    assert "; no wind;" in only_current.metadata["source"]
    # A sea of no current and no wind: the calm log to the bit, and a speed log
    # (benchmarks/environment.py --calm-speed-log).
    still = synthesize_log(
        reference_ship("kvlcc2", "model", SeaEnvironment()), _quick_turn(), approach_s=5.0, seed=4
    )
    assert still.stw_mps is not None and still.wind_speed_mps is None
    for column in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(getattr(still, column), getattr(calm, column))
    # A two-axis log: v through the water as well, the rest of the log unchanged.
    two = synthesize_log(
        reference_ship("kvlcc2", "model", SeaEnvironment()),
        _quick_turn(),
        approach_s=5.0,
        seed=4,
        speed_log_axes=2,
    )
    assert two.stw_transverse_mps is not None and still.stw_transverse_mps is None
    np.testing.assert_array_equal(two.stw_mps, still.stw_mps)
    # amidships on the straight approach (|v| within 4σ of the noise), then sliding to
    # port in the starboard turn (a drift of some 10° at 1 m/s: v ≈ −0.2 m/s)
    assert np.all(np.abs(two.stw_transverse_mps[:5]) < 0.2)
    assert float(np.median(two.stw_transverse_mps[-8:])) < -0.08
    assert two.metadata["speed_log_x_m"] == "0.0" and "speed_log_x_m" not in still.metadata
    # At 2 m forward of midship the log measures v + x r: the difference of the two logs
    # (same noise) is 2 m times the yaw rate, whose integral is the (noiseless) heading.
    exact = {"approach_s": 5.0, "seed": 4, "speed_log_axes": 2, "heading_noise_deg": 0.0}
    ship = reference_ship("kvlcc2", "model", SeaEnvironment())
    amidships = synthesize_log(ship, _quick_turn(), **exact)
    forward = synthesize_log(ship, _quick_turn(), speed_log_x_m=2.0, **exact)
    assert forward.on_board_m("speed_log_x_m") == 2.0
    assert forward.stw_transverse_mps is not None and amidships.stw_transverse_mps is not None
    rate = (forward.stw_transverse_mps - amidships.stw_transverse_mps) / 2.0
    turned = cumulative_trapezoid(rate, forward.time_s, initial=0.0)
    np.testing.assert_allclose(turned, forward.heading_rad - forward.heading_rad[0], atol=2e-3)
    assert abs(float(turned[-1])) > 0.2  # a turn, well above atol
    with pytest.raises(ValueError, match="speed_log_axes must be one of"):
        synthesize_log(reference_ship("kvlcc2", "model"), _quick_turn(), speed_log_axes=3)


def _noise(program: Program, *, per_channel: bool) -> np.ndarray:
    """(heading, x, y) noise of a synthesized log of seed 4: the log less its noise-free twin."""
    ship = reference_ship("kvlcc2", "model")
    noisy, clean = (
        synthesize_log(
            ship,
            program,
            approach_s=5.0,
            seed=4,
            position_noise_m=noise_m,
            heading_noise_deg=noise_m / 10.0,
            noise_per_channel=per_channel,
        )
        for noise_m in (1.0, 0.0)
    )
    return np.vstack(
        [noisy.heading_rad - clean.heading_rad, noisy.x_m - clean.x_m, noisy.y_m - clean.y_m]
    )


@pytest.mark.parametrize("per_channel", [True, False])
def test_noise_per_channel_does_not_depend_on_the_logs_length(per_channel: bool) -> None:
    """With a generator per channel, sample k's noise is the same in a shorter log of one seed.

    The default draws the channels one after the other from one generator: the x and y
    noise of a shorter log are other numbers (benchmarks/environment.md, "Same noise on
    both logs").
    """
    longer = _noise(turning_circle(math.radians(35.0), max_time_s=30.0), per_channel=per_channel)
    shorter = _noise(_quick_turn(), per_channel=per_channel)
    n = shorter.shape[1]
    assert longer.shape[1] > n
    np.testing.assert_allclose(np.std(shorter[1:]), 1.0, atol=0.35)  # the noise is drawn
    np.testing.assert_allclose(shorter[0], longer[0, :n], atol=1e-12)  # heading: drawn first
    assert np.allclose(shorter[1:], longer[1:, :n], atol=1e-12) == per_channel


@pytest.fixture
def quick_maneuvers(monkeypatch: pytest.MonkeyPatch) -> None:
    """``zigzag-10`` of the command line becomes a 20 s turn (a fast, real run)."""
    monkeypatch.setitem(synthesize.MANEUVERS, "zigzag-10", _quick_turn)


def test_synthesize_cli_at_sea_writes_the_columns_and_the_source(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], quick_maneuvers: None
) -> None:
    common = ["synthesize", "--maneuver", "zigzag-10", "--scale", "model", "--seed", "2"]
    common += ["--approach-s", "5", "--rate-hz", "1", "--quiet"]
    sea = [
        "--current-mps", "0.1", "--current-to-deg", "90",
        "--current-change-mps-per-h", "0.2", "--current-veer-deg-per-h", "-15",
        "--wind-mps", "2.5", "--wind-from-deg", "45", "--gust-std-mps", "0.3",
    ]  # fmt: skip
    assert main([*common, *sea, "-o", str(tmp_path / "sea")]) == 0
    path = tmp_path / "sea" / "zigzag-10.csv"
    windage = tmp_path / "sea" / "windage.json"  # for `identifier fit --windage`
    assert capsys.readouterr().out.split() == [str(path), str(windage)]
    assert Windage.from_dict(json.loads(windage.read_text())) == kvlcc2_windage("model")
    lines = path.read_text().splitlines()
    header = next(line for line in lines if not line.startswith("#"))
    assert header == ",".join((*LOG_COLUMNS, "wind_speed_mps", "wind_angle_deg", "stw_mps"))
    log = read_log(path)
    assert log.n_samples == 26  # 5 s approach + 20 s turn at 1 Hz
    seed = maneuver_seed(2, "zigzag-10")
    source = log.metadata["source"]
    assert (
        "model scale; at sea: current 0.1 m/s towards 90 deg, changing +0.2 m/s per hour and "
        "veering -15 deg per hour; wind 2.5 m/s from 45 deg, gusts Ornstein-Uhlenbeck std "
        f"0.3 m/s, time constant 8.874 s, seed {seed}; wind load Blendermann (1994) loaded "
        "tanker on the estimated windage of docs/kvlcc2_environment.md;"
    ) in source

    # without the options: the calm-water log, byte for byte as synthesize_log writes it
    assert main([*common, "-o", str(tmp_path / "calm")]) == 0
    calm_text = (tmp_path / "calm" / "zigzag-10.csv").read_text()
    assert "stw_mps" not in calm_text and "at sea" not in calm_text
    expected = synthesize_log(
        reference_ship("kvlcc2", "model"), _quick_turn(), seed=seed, approach_s=5.0,
        position_noise_m=default_logging("model").position_noise_m,
    )  # fmt: skip
    assert calm_text == format_log(expected)
    # current only: a speed log, no anemometer
    assert main([*common, *sea[:4], "-o", str(tmp_path / "current")]) == 0
    current = read_log(tmp_path / "current" / "zigzag-10.csv")
    assert current.stw_mps is not None and current.wind_speed_mps is None
    assert current.stw_transverse_mps is None  # a single-axis log by default
    calm = read_log(tmp_path / "calm" / "zigzag-10.csv")
    np.testing.assert_array_equal(current.rudder_rad, calm.rudder_rad)
    # a two-axis log: the transverse axis drawn last, so the rest of the log is the same
    assert main([*common, *sea[:4], "--speed-log-axes", "2", "-o", str(tmp_path / "two")]) == 0
    two = read_log(tmp_path / "two" / "zigzag-10.csv")
    assert "two-axis speed log" in two.metadata["source"]
    assert two.stw_transverse_mps is not None and two.stw_mps is not None
    np.testing.assert_array_equal(two.stw_mps, current.stw_mps)
    np.testing.assert_array_equal(two.x_m, current.x_m)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--current-mps", "-0.5", "--current-to-deg", "0"], "argument --current-mps: expected"),
        (["--current-mps", "nan", "--current-to-deg", "0"], "argument --current-mps: expected"),
        (["--current-mps", "6", "--current-to-deg", "0"], "a number from 0 to 5 m/s, got '6'"),
        (["--current-mps", "1", "--current-to-deg", "400"], "argument --current-to-deg"),
        (["--current-mps", "1", "--current-to-deg", "0", "--current-veer-deg-per-h", "inf"],
         "argument --current-veer-deg-per-h"),
        (["--wind-mps", "abc", "--wind-from-deg", "0"], "argument --wind-mps: expected"),
        (["--wind-mps", "41", "--wind-from-deg", "0"], "a number from 0 to 40 m/s, got '41'"),
        (["--wind-mps", "10", "--wind-from-deg", "0", "--gust-std-mps", "6"],
         "argument --gust-std-mps"),
        (["--wind-mps", "10", "--wind-from-deg", "0", "--gust-std-mps", "1", "--gust-time-s",
          "0"], "argument --gust-time-s"),
        (["--current-mps", "1"], "--current-mps needs --current-to-deg"),
        (["--wind-mps", "10"], "--wind-mps needs --wind-from-deg"),
        (["--current-to-deg", "10"], "--current-to-deg needs --current-mps"),
        (["--current-change-mps-per-h", "0.1"], "--current-change-mps-per-h needs --current-mps"),
        (["--wind-from-deg", "10"], "--wind-from-deg needs --wind-mps"),
        (["--gust-std-mps", "1"], "--gust-std-mps needs --wind-mps"),
        (["--wind-mps", "10", "--wind-from-deg", "0", "--gust-time-s", "30"],
         "--gust-time-s needs --gust-std-mps"),
        (["--speed-log-axes", "2"], "--speed-log-axes needs --current-mps or --wind-mps"),
        (["--current-mps", "1", "--current-to-deg", "0", "--speed-log-x-m", "100"],
         "--speed-log-x-m needs --speed-log-axes 2"),
        (["--current-mps", "1", "--current-to-deg", "0", "--speed-log-axes", "2",
          "--speed-log-x-m", "600"], "argument --speed-log-x-m"),
        (["--current-mps", "1", "--current-to-deg", "0", "--speed-log-axes", "3"],
         "argument --speed-log-axes: invalid choice: 3"),
    ],
)  # fmt: skip
def test_synthesize_rejects_bad_environment_options(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], options: list[str], message: str
) -> None:
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as excinfo:
        main(["synthesize", "--maneuver", "zigzag-10", *options, "-o", str(out)])
    assert excinfo.value.code == 2
    err = capsys.readouterr().err
    last = err.splitlines()[-1]
    assert last.startswith(f"{PROG} synthesize: error: ")
    assert message in last
    assert not out.exists()
