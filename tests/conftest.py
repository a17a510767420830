"""Shared fixtures: a plausible, stable ship in the seed model structure."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import settings

from fmu_model import ModelParameters

# CI gates a change on these tests, so a property test draws the same examples on every
# run (seeded by the test itself): a run goes red for a change of the code, not for a
# new draw. `pytest --hypothesis-profile explore` draws anew, to look for what the fixed
# draws miss (three such runs of the property tests, seeds 11-13, passed when this was set).
settings.register_profile("ci", derandomize=True)
settings.register_profile("explore", derandomize=False)
settings.load_profile("ci")

# The suite runs on two workers (`make test`: pytest -n 2 --dist worksteal). Its few tests
# of a minute or more (the warm-up's from empty caches, the demo, the walkthroughs) are
# marked @pytest.mark.order("first") (pytest-order): started last, one of them kept a
# worker busy for minutes after the other had finished (16 min 18 s against 13 min 50 s of
# CPU time each); started first, the workers steal the short ones from each other around them.

# A 100 m single-screw ship at 5 m/s and 2 rev/s in the Shi et al. (2009) structure.
# Straight-run equilibrium: a1 u0^2 + a8 u0 n0 + a9 n0^2 = 0. Positive rudder turns to
# starboard (c3 > 0); 35 deg rudder gives a steady turn of about 1.3 L diameter with
# 20 deg drift and a 35 % speed loss, like a full-form ship.
SEED_COEFFICIENTS = {
    "a1": -0.004,
    "a2": -0.002,
    "a3": -10.0,
    "a4": -0.05,
    "a5": 0.5,
    "a6": 0.0,
    "a7": 0.0,
    "a8": -0.005,
    "a9": 0.0375,
    "b1": -0.08,
    "b2": 0.0,
    "b3": -0.02,
    "b4": -0.5,
    "c1": -0.0003,
    "c2": -0.05,
    "c3": 0.0036,
}


@pytest.fixture
def seed_params() -> ModelParameters:
    """The seed-structure test ship (L = 100 m, U0 = 5 m/s, n0 = 2 rev/s)."""
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
