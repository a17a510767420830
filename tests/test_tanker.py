"""The large tanker of Van Berlekom & Goddard (``scenarios.tanker``): its equations against
the source's as MSS prints them, its design speed, its single-screw asymmetry, and its
place among the reference ships."""

from __future__ import annotations

import math

import numpy as np
import pytest

from scenarios.synthesize import MANEUVERS, REFERENCE_VESSELS, reference_ship, synthesize_log
from scenarios.tanker import (
    LENGTH_M,
    NOMINAL_RPS,
    RUDDER_RATE_RADPS,
    TankerPlant,
    approach_speed,
    neutral_helm,
    tanker,
    tanker_forces,
    tanker_rhs,
)
from trials.maneuvers import turning_circle, zigzag
from trials.metrics import turning_metrics, zigzag_metrics
from trials.run import run_program


def test_forces_and_accelerations_by_the_source_formulas():
    """u = 8 m/s, v = −0.4 m/s, r = 0.003 rad/s, rudder 0.2 rad to starboard (the source's
    δ = −0.2), 80 rpm. MSS ``tanker.m``, deep water (z = 0), evaluated term by term:
    β = atan(−0.05) = −0.0499584, g_T = 0.0110028 m/s², c = √(0.605·8·4/3 + 38.2·(4/3)²)
    = 8.62348; g_X = −2.13744e-3, g_Y = −1.35835e-2, g_LN = 1.00859; u̇ = g_X/1.05 =
    −2.03565e-3 m/s², v̇ = g_Y/2.02 = −6.72453e-3 m/s², ṙ = g_LN/(L²·0.1232) =
    8.81201e-5 rad/s²: the rudder pushes the stern to port and yaws the bow to starboard.
    """
    ship = tanker()
    x, y, ln = tanker_forces(ship, 8.0, -0.4, 0.003, 0.2, NOMINAL_RPS)
    assert (x, y, ln) == pytest.approx((-2.137435e-3, -1.3583549e-2, 1.0085923), rel=1e-6)
    state = np.array([8.0, -0.4, 0.003, 0.0, 0.0, math.radians(90.0)])
    rhs = tanker_rhs(ship, state, 0.2, NOMINAL_RPS)
    assert rhs[:3] == pytest.approx([-2.0356527e-3, -6.724529e-3, 8.812010e-5], rel=1e-6)
    # kinematics: heading East, the sway to port moves the track North
    assert rhs[3:] == pytest.approx([0.4, 8.0, 0.003])


def test_the_design_speed_at_80_rpm():
    """The source gives u = 8.23 m/s at the nominal 80 rpm: X = 0 there."""
    speed = approach_speed(tanker())
    assert speed == pytest.approx(8.23, abs=0.005)
    assert tanker_forces(tanker(), speed, 0.0, 0.0, 0.0, NOMINAL_RPS)[0] == pytest.approx(
        0.0, abs=1e-15
    )
    assert approach_speed(tanker(), 0.5 * NOMINAL_RPS) < 0.6 * speed  # less rpm, less speed


def test_the_single_screw_needs_a_helm_and_turns_tighter_to_port():
    """Y_T, N_T: the thrust's side force and yaw moment. Held on the neutral helm (0.5° to
    starboard) the ship runs straight; amidships it turns; and its 35° turn is tighter
    to port than to starboard."""
    ship = tanker()
    helm = neutral_helm(ship)
    assert math.degrees(helm.rudder_rad) == pytest.approx(0.50, abs=0.01)
    speed = approach_speed(ship)
    plant = TankerPlant(ship)
    headings = []
    for rudder in (helm.rudder_rad, 0.0):
        plant.reset(np.array([speed, helm.sway_mps, 0.0, 0.0, 0.0, 0.0]))
        for _ in range(60):
            state = plant.step(rudder, NOMINAL_RPS, 5.0)
        headings.append(abs(math.degrees(state[5])))
    assert headings[0] < 1e-3 < 1.0 < headings[1]  # degrees after 300 s
    diameters = []
    for side in (1.0, -1.0):
        run = run_program(
            plant, turning_circle(side * math.radians(35.0)), speed_mps=speed,
            n_rps=NOMINAL_RPS, rudder_rate_radps=RUDDER_RATE_RADPS, dt_s=0.5,
        )  # fmt: skip
        diameters.append(turning_metrics(run).tactical_diameter_m / LENGTH_M)
    starboard, port = diameters
    assert 2.5 < port < starboard < 4.0  # a large tanker's: 3.13 and 3.04 L


def test_a_zig_zag_overshoots_as_a_large_tanker_does():
    """10°/10°: first and second overshoot 6.2° and 14.7°, the second the larger, as for
    the KVLCC2 (5.0° / 13.9°): a full hull of small yaw stability."""
    ship = tanker()
    run = run_program(
        TankerPlant(ship), zigzag(math.radians(10.0), math.radians(10.0)),
        speed_mps=approach_speed(ship), n_rps=NOMINAL_RPS,
        rudder_rate_radps=RUDDER_RATE_RADPS, dt_s=0.5,
    )  # fmt: skip
    metrics = zigzag_metrics(run, math.radians(10.0), math.radians(10.0))
    first, second = (math.degrees(metrics.first_overshoot_rad),
                     math.degrees(metrics.second_overshoot_rad))  # fmt: skip
    assert 3.0 < first < second < 20.0


def test_a_reference_ship_of_synthesize():
    assert "tanker" in REFERENCE_VESSELS
    ship = reference_ship("tanker")
    assert ship.name == "tanker-full" and ship.length_m == LENGTH_M
    assert ship.neutral_helm == neutral_helm(tanker())
    log = synthesize_log(ship, MANEUVERS["zigzag-10"](), seed=1)
    assert log.metadata["vessel"] == "tanker-full"
    assert "Van Berlekom & Goddard 1972" in log.metadata["source"]
    with pytest.raises(ValueError, match="the tanker reference is given at full scale only"):
        reference_ship("tanker", "model")
