"""The cross-flow drag of ``prime-crossflow``'s yaw moment: its integrals against their closed
forms."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from fmu_model.numeric import numeric_model
from fmu_model.variants import PRIME_CROSSFLOW

LENGTH_M = 100.0
SPEED_MPS = 5.0
STRUCTURE = PRIME_CROSSFLOW.structure(PRIME_CROSSFLOW.default_shape)
INTEGRALS = {"N_cf1": (1, LENGTH_M), "N_cf2": (2, LENGTH_M)}  # name: (k of I_k, L^j)


def integrals(v_prime: float, r_prime: float) -> dict[str, float]:
    """I_k of the model's regressors: φ / (q/L^j), q = U²/L, at u = U cos β, v = U v′."""
    u = SPEED_MPS * np.sqrt(1.0 - v_prime**2)
    v = SPEED_MPS * v_prime
    r = r_prime * SPEED_MPS / LENGTH_M
    phi = numeric_model(STRUCTURE).regressors(u, v, r, 0.0, 1.0, LENGTH_M)
    names = STRUCTURE.coefficient_names
    q = SPEED_MPS**2 / LENGTH_M
    return {name: float(phi[names.index(name)]) * per / q for name, (_, per) in INTEGRALS.items()}


def closed_form(power: int, v_prime: float, r_prime: float) -> float:
    """∫ x^k |v′ + x r′|(v′ + x r′) dx over [−½, ½], piecewise exact (split at the pivot)."""
    edges = [-0.5, 0.5]
    if r_prime != 0.0 and abs(v_prime / r_prime) < 0.5:
        edges.insert(1, -v_prime / r_prime)
    total = 0.0
    for a, b in itertools.pairwise(edges):
        sign = np.sign(v_prime + 0.5 * (a + b) * r_prime)
        # sign · ∫ x^k (v + x r)² dx, the polynomial integrated term by term
        coefficients = (v_prime**2, 2.0 * v_prime * r_prime, r_prime**2)
        total += sign * sum(
            c * (b ** (power + j + 1) - a ** (power + j + 1)) / (power + j + 1)
            for j, c in enumerate(coefficients)
        )
    return total


def test_a_drift_and_a_pure_yaw_give_the_textbook_integrals() -> None:
    """r′ = 0: I₁ = 0, I₂ = |v′|v′/12; v′ = 0: I₁ = r′|r′|/32, I₂ = 0."""
    drift = integrals(-0.3, 0.0)
    assert drift["N_cf2"] == pytest.approx(-0.09 / 12.0, rel=1e-12)
    assert abs(drift["N_cf1"]) < 1e-15
    yaw = integrals(0.0, 0.6)
    assert yaw["N_cf1"] == pytest.approx(0.36 / 32.0, rel=3e-3)
    assert abs(yaw["N_cf2"]) < 1e-15


def test_the_sway_equation_keeps_the_modulus_terms() -> None:
    """Only the yaw moment is the cross flow's (the measured runs' choice, variants.py)."""
    names = STRUCTURE.coefficient_names
    assert {"Y_vav", "Y_rar", "Y_var", "Y_avr"} <= set(names)
    assert not {"N_vav", "N_rar", "N_var", "N_avr"} & set(names)
    assert len(names) == 19


@pytest.mark.parametrize(
    ("v_prime", "r_prime"),
    [(0.25, 0.3), (-0.4, 0.5), (0.05, -0.3), (-0.1, 0.35), (0.2, -1.1), (0.5, 0.9)],
)
def test_the_quadrature_is_the_integral_where_the_cross_flow_changes_sign(
    v_prime: float, r_prime: float
) -> None:
    """Within 3e-3 of v′² + r′²/12 (the docstring's bound); exact where no strip reverses."""
    got = integrals(v_prime, r_prime)
    scale = v_prime**2 + r_prime**2 / 12.0
    reverses = abs(v_prime) < 0.5 * abs(r_prime)
    for name, (power, _) in INTEGRALS.items():
        expected = closed_form(power, v_prime, r_prime)
        assert abs(got[name] - expected) <= (3e-3 * scale if reverses else 1e-14), name


def test_the_integrals_are_odd_in_the_cross_flow() -> None:
    """A port manoeuvre is the mirror image of a starboard one: I_k(−v′, −r′) = −I_k."""
    starboard, port = integrals(0.15, -0.4), integrals(-0.15, 0.4)
    for name in INTEGRALS:
        assert port[name] == pytest.approx(-starboard[name], rel=1e-13)
