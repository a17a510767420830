"""The model-form term: the spread of the fit's alternative estimates, and how it widens.

On the first-order-yaw ship of ``test_uncertainty`` the steady turning diameter is
D = K / c3 exactly, so an alternative estimate with c3 → 1.1 c3 differs from the kept
one by |K/(1.1 c3) − K/c3|: the model-form half-width is known by hand.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from fmu_model import ModelParameters
from scenarios.records import ComparisonRow, Condition
from scenarios.report import uncertainty_scope
from scenarios.uncertainty.model_form import (
    alternative_estimates,
    model_form_half_widths,
    widen,
)
from scenarios.uncertainty.monte_carlo import monte_carlo_metrics
from scenarios.validation import uncertainty_bands
from tests.test_uncertainty import C3, K_DIAMETER, NAMES, SPEED_MPS, TURN, linear_ship
from trials.maneuvers import Program, zigzag


def with_estimates(params: ModelParameters, **estimates: np.ndarray) -> ModelParameters:
    """``params`` carrying ``identification["estimates"]`` as ``identify`` writes them."""
    recorded = {
        method.replace("_", "-"): dict(zip(NAMES, map(float, theta), strict=True))
        for method, theta in estimates.items()
    }
    return replace(params, identification={"estimates": recorded})


def scaled_c3(params: ModelParameters, factor: float) -> np.ndarray:
    theta = params.to_vector().copy()
    theta[NAMES.index("c3")] *= factor
    return theta


def test_the_half_width_is_the_alternative_estimates_distance_by_hand() -> None:
    ship = linear_ship()
    params = with_estimates(
        ship,
        ekf=scaled_c3(ship, 1.1),
        equation_error=scaled_c3(ship, 0.95),
        output_error=ship.to_vector(),
    )
    assert set(alternative_estimates(params)) == {"ekf", "equation-error"}  # kept one left out
    half = model_form_half_widths(params, [TURN], Condition(SPEED_MPS, 0.0, math.radians(5.0), 0.5))
    expected = max(abs(K_DIAMETER / (f * C3) - K_DIAMETER / C3) for f in (1.1, 0.95))
    assert half[TURN.name, "steady_diameter_m"] == pytest.approx(expected, rel=1e-6)


def test_without_alternative_estimates_there_is_no_term() -> None:
    ship = linear_ship()
    assert alternative_estimates(ship) == {}
    wrong_names = replace(ship, identification={"estimates": {"ekf": {"a1": 1.0}}})
    assert alternative_estimates(wrong_names) == {}
    assert model_form_half_widths(ship, [TURN], Condition(SPEED_MPS, 0.0, 0.1, 0.5)) == {}


def test_widen_adds_each_side_in_quadrature() -> None:
    lo, hi = widen(10.0, 8.0, 13.0, 3.0)
    assert lo == pytest.approx(10.0 - math.sqrt(2.0**2 + 3.0**2))
    assert hi == pytest.approx(10.0 + math.sqrt(3.0**2 + 3.0**2))
    assert widen(10.0, 8.0, 13.0, 0.0) == pytest.approx((8.0, 13.0))


ZIGZAG = zigzag(math.radians(20.0), math.radians(20.0), max_time_s=900.0)


@pytest.mark.parametrize(
    ("program", "quantity", "metric", "unit", "to_row_unit"),
    [
        (TURN, "steady_diameter_m", "steady_diameter_m", "m", 1.0),
        (ZIGZAG, "first_overshoot_deg", "first_overshoot_rad", "deg", math.degrees(1.0)),
    ],
    ids=["metres", "degrees"],
)
def test_bands_carry_the_model_form_term(
    program: Program, quantity: str, metric: str, unit: str, to_row_unit: float
) -> None:
    ship = linear_ship(c3_std=0.02 * C3)
    result = monte_carlo_metrics(
        ship, [program], n_samples=50, seed=3, n_workers=1, processes=False
    )
    predicted = to_row_unit * result.summary(program.name, metric).nominal
    row = ComparisonRow(
        maneuver=program.name,
        quantity=quantity,
        label=quantity,
        unit=unit,
        reference=predicted,
        predicted=predicted,
        error_pct=0.0,
        difference=0.0,
    )
    half_width = 0.05 * predicted / to_row_unit  # in the Monte-Carlo metric's unit
    plain_bands = uncertainty_bands(result, [row])
    wide_bands = uncertainty_bands(result, [row], model_form={(program.name, metric): half_width})
    assert "not model-structure error" in uncertainty_scope(plain_bands)
    assert "and model form" in uncertainty_scope(wide_bands)
    plain = plain_bands.intervals[program.name, quantity]
    widened = wide_bands.intervals[program.name, quantity]
    h = 0.05 * predicted  # in the row's unit
    assert plain.model_form == 0.0 and widened.model_form == pytest.approx(h)
    assert plain.lo < predicted < plain.hi
    assert widened.lo == pytest.approx(predicted - math.hypot(predicted - plain.lo, h))
    assert widened.hi == pytest.approx(predicted + math.hypot(plain.hi - predicted, h))
