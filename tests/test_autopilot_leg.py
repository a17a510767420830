"""A steering leg (``trials.maneuvers.Leg(steer=True)``): the autopilot of a trial day's
straight runs, driven by ``trials.run``."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from scenarios.synthesize import reference_ship
from trials.maneuvers import AUTOPILOT_LIMIT_RAD, Leg, Until, zigzag
from trials.run import run_program


@pytest.mark.parametrize("steer", [True, False])
def test_a_steering_leg_holds_the_course_a_course_unstable_ship_leaves(steer: bool) -> None:
    """KVLCC2 after a 10/10 zig-zag, 600 s with the rudder amidships keeps turning (r′ 0.06:
    course-unstable); on the autopilot it holds the heading the leg began on."""
    ship = reference_ship("kvlcc2", "full")
    check = zigzag(math.radians(10.0), math.radians(10.0))
    after = Leg(0.0, Until(time_s=600.0), label="after", steer=steer)
    run = run_program(
        ship.plant,
        replace(check, legs=(*check.legs, after)),
        speed_mps=ship.speed_mps,
        n_rps=ship.n_rps,
        rudder_rate_radps=ship.rudder_rate_radps,
        dt_s=0.5,
    )
    start = int(np.argmax(run["time_s"] >= run["time_s"][-1] - 600.0))  # the leg's first row
    last = run[-100:]  # its last 50 s
    r_prime = np.abs(last["r_radps"]) * ship.length_m / ship.speed_mps
    if steer:
        assert r_prime.max() < 0.005
        assert abs(math.degrees(last["psi_rad"][-1] - run["psi_rad"][start])) < 1.0
        assert np.abs(run["rudder_rad"][start:]).max() <= AUTOPILOT_LIMIT_RAD + 1e-12
        assert np.abs(run["rudder_rad"][start:]).max() > math.radians(5.0)  # it checks the swing
    else:
        assert r_prime.min() > 0.03
