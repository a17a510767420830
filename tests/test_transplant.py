"""benchmarks/transplant.py: a fit sailed with one equation of the reference's (issue 13).

The transplant takes exactly the rows asked from the reference and nothing else; with no
row taken it sails as the Python model does; the references' right-hand sides are the
reference ships' own.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from types import ModuleType

import numpy as np
import pytest

from fmu_model import ModelParameters, numeric_model
from scenarios.kvlcc2 import kvlcc2, mmg_rhs
from scenarios.tanker import tanker, tanker_rhs
from tests.module_files import benchmark_module
from trials.maneuvers import zigzag
from trials.run import ModelPlant, run_program

STATE = np.array([4.6, -0.4, 0.012, 10.0, -5.0, 0.3])  # u, v [m/s], r [rad/s], x, y [m], ψ
RUDDER_RAD = math.radians(20.0)
N_RPS = 2.0


@pytest.fixture(scope="module")
def transplant() -> Iterator[ModuleType]:
    with benchmark_module("transplant.py") as module:
        yield module


def _other(params: ModelParameters) -> ModelParameters:
    """The seed ship with another surge drag, sway damping and rudder: a 'reference'."""
    coefficients = dict(zip(params.names, params.coefficients, strict=True))
    coefficients.update(
        a1=1.5 * coefficients["a1"], b1=1.5 * coefficients["b1"], c3=2.0 * coefficients["c3"]
    )
    return replace(params, coefficients=np.array(list(coefficients.values())))


@pytest.mark.parametrize("rows", [(), (0,), (1,), (2,), (1, 2), (0, 1, 2)])
def test_a_transplant_takes_the_rows_asked_from_the_reference_and_no_other(
    transplant: ModuleType, seed_params: ModelParameters, rows: tuple[int, ...]
) -> None:
    other = _other(seed_params)
    model, reference = (numeric_model(p.structure) for p in (seed_params, other))

    def reference_rhs(state: np.ndarray, rudder_rad: float, n_rps: float) -> np.ndarray:
        return np.asarray(reference.rhs(state, rudder_rad, n_rps, other.coefficients, 100.0))

    plant = transplant.transplanted(seed_params, reference_rhs, rows)
    fitted = np.asarray(model.rhs(STATE, RUDDER_RAD, N_RPS, seed_params.coefficients, 100.0))
    theirs = reference_rhs(STATE, RUDDER_RAD, N_RPS)
    assert np.all(np.abs(fitted[:3] - theirs[:3]) > 1e-6)  # they differ in each equation
    expected = np.where(np.isin(np.arange(6), rows), theirs, fitted)
    np.testing.assert_array_equal(plant.rhs(STATE, RUDDER_RAD, N_RPS), expected)


def test_a_state_the_reference_has_no_forces_at_ends_the_run_as_a_divergence(
    transplant: ModuleType, seed_params: ModelParameters
) -> None:
    """The tanker's model has no slipstream astern (the square root of a negative): the
    transplanted run ends there as a diverging one does, which the indices call n/a."""

    def astern(state: np.ndarray, rudder_rad: float, n_rps: float) -> np.ndarray:
        return np.full(6, math.sqrt(-1.0))  # ValueError, as tanker_rhs's at u < 0

    plant = transplant.transplanted(seed_params, astern, (2,))
    with pytest.raises(FloatingPointError, match="the reference has no forces at"):
        plant.rhs(STATE, RUDDER_RAD, N_RPS)


def test_with_no_row_taken_the_fit_sails_as_the_python_model(
    transplant: ModuleType, seed_params: ModelParameters
) -> None:
    def unused(state: np.ndarray, rudder_rad: float, n_rps: float) -> np.ndarray:
        raise AssertionError("no row is taken from the reference")

    program = zigzag(math.radians(10.0), math.radians(10.0))
    kwargs = {"speed_mps": 5.0, "n_rps": N_RPS, "rudder_rate_radps": 0.04, "dt_s": 1.0}
    ours = run_program(transplant.transplanted(seed_params, unused, ()), program, **kwargs)
    python = run_program(
        ModelPlant(seed_params, max_step_s=transplant.MAX_SUBSTEP_S), program, **kwargs
    )
    for name in ("x_m", "y_m", "psi_rad", "u_mps", "v_mps", "r_radps"):
        np.testing.assert_allclose(ours[name], python[name], rtol=1e-9, atol=1e-9)


def test_the_references_right_hand_sides_are_the_reference_ships_own(
    transplant: ModuleType,
) -> None:
    state = np.array([7.5, -0.6, 0.004, 0.0, 0.0, 0.2])
    np.testing.assert_array_equal(
        transplant.reference_rhs("kvlcc2")(state, RUDDER_RAD, 1.3),
        mmg_rhs(kvlcc2("full"), state, RUDDER_RAD, 1.3),
    )
    np.testing.assert_array_equal(
        transplant.reference_rhs("tanker")(state, RUDDER_RAD, 1.3),
        tanker_rhs(tanker(), state, RUDDER_RAD, 1.3),
    )
