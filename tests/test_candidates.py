"""Candidate families of benchmarks/candidates.py (issue 13).

The hull-basis blend (``offset-hullmix``): each nonlinear modulus hull term is blended
with the cubic term of the same symmetry, (1 − b)·modulus + b·cubic: at b = 0 the family
is the default one term for term, at b = 1 its hull is the MMG cubic basis of
``prime-cubic``, and the coefficient count is the default's at every b. The rudder in the
hull's shadow (``offset-shadow``): the tanker's drift-rudder term in the family's units.
"""

from __future__ import annotations

import math
from pathlib import Path
from types import ModuleType

import pytest
import sympy as sp

from fmu_model.structure import L, ModelStructure, Term, delta, n, r, u, v
from fmu_model.variants import (
    PRIME_CUBIC,
    PRIME_RUDDER_OFFSET,
    RUDDER_INFLOW_SQUARED,
    ModelFamily,
)
from tests.module_files import load_module

CANDIDATES = Path(__file__).resolve().parents[1] / "benchmarks" / "candidates.py"


@pytest.fixture(scope="module")
def candidates() -> ModuleType:
    return load_module("benchmark_candidates", CANDIDATES)


@pytest.fixture(scope="module")
def blend(candidates: ModuleType) -> ModelFamily:
    family: ModelFamily = candidates.hull_mixed(PRIME_RUDDER_OFFSET, "test-hullmix")
    return family


def _at(family: ModelFamily, b: float) -> ModelStructure:
    return family.structure({**PRIME_RUDDER_OFFSET.default_shape, "b": b})


def _same(a: Term, b: Term) -> bool:
    return a.coefficient == b.coefficient and sp.simplify(a.regressor - b.regressor) == 0


def test_at_b_0_the_blend_is_the_default_family_term_for_term(blend: ModelFamily) -> None:
    default = PRIME_RUDDER_OFFSET.structure(PRIME_RUDDER_OFFSET.default_shape)
    blended = _at(blend, 0.0)
    assert len(blended.terms) == len(default.terms)
    assert all(_same(a, b) for a, b in zip(blended.terms, default.terms, strict=True))


def test_at_b_1_the_hull_is_the_mmg_cubic_basis(blend: ModelFamily, candidates: ModuleType) -> None:
    cubic_sway, cubic_yaw = candidates.sway_and_yaw_terms(PRIME_CUBIC, *candidates.CUBIC_HULL)
    blended = _at(blend, 1.0)
    pairs = candidates.HULL_PAIRS
    for terms, cubic in ((blended.sway, cubic_sway), (blended.yaw, cubic_yaw)):
        twin = {t.coefficient[2:]: t.regressor for t in cubic}
        mixed = [t for t in terms if t.coefficient[2:] in pairs]
        assert len(mixed) == len(pairs)
        for t in mixed:
            assert sp.simplify(t.regressor - twin[pairs[t.coefficient[2:]]]) == 0, t


@pytest.mark.parametrize("flip", [{v: -v}, {r: -r}])
def test_each_pair_has_one_symmetry(candidates: ModuleType, flip: dict[sp.Symbol, sp.Expr]) -> None:
    """A term and its cubic twin are both odd or both even in v, and in r: a blend of the
    two keeps the port/starboard symmetry of the term it replaces."""
    default = PRIME_RUDDER_OFFSET.structure(PRIME_RUDDER_OFFSET.default_shape)
    cubic_sway, _ = candidates.sway_and_yaw_terms(PRIME_CUBIC, *candidates.CUBIC_HULL)
    modulus = {t.coefficient[2:]: t.regressor for t in default.sway}
    cubic = {t.coefficient[2:]: t.regressor for t in cubic_sway}

    def parity(f: sp.Expr) -> int:
        return 1 if sp.simplify(f.subs(flip, simultaneous=True) - f) == 0 else -1

    for name, twin in candidates.HULL_PAIRS.items():
        assert parity(modulus[name]) == parity(cubic[twin]), (name, twin)


def test_the_rudder_shadow_is_van_berlekom_and_goddards_drift_rudder_term(
    candidates: ModuleType,
) -> None:
    """``offset-shadow``'s sway term is u_R²·v′|v′|·|sin δ|/L (the tanker's c²|β|β|δ| with
    β ≈ v′), odd under the port/starboard mirror, silent without drift or rudder."""
    family = next(f for f in candidates.candidate_families() if f.name == "offset-shadow")
    # dwake 0: a wake recovery of one side would make u_R² itself differ by side.
    shape = {**PRIME_RUDDER_OFFSET.default_shape, "k": 4e-4, "gamma": 0.5, "dwake": 0.0}
    (sway,) = (t for t in family.structure(shape).sway if t.coefficient == "Y_Rb")
    (yaw,) = (t for t in family.structure(shape).yaw if t.coefficient == "N_Rb")
    point = {u: 6.0, v: -1.5, r: 0.004, delta: math.radians(30.0), n: 1.2, L: 320.0}
    constants = {c.symbol: shape[c.name] for c in family.shape}
    inflow_squared = float(RUDDER_INFLOW_SQUARED.subs(constants).subs(point))
    v_prime = -1.5 / math.hypot(6.0, -1.5)
    expected = inflow_squared * v_prime * abs(v_prime) * math.sin(math.radians(30.0)) / 320.0
    assert float(sway.regressor.subs(point)) == pytest.approx(expected, rel=1e-12)
    assert float(yaw.regressor.subs(point)) == pytest.approx(expected / 320.0, rel=1e-12)
    mirrored = {**point, v: 1.5, r: -0.004, delta: -math.radians(30.0)}
    assert float(sway.regressor.subs(mirrored)) == pytest.approx(-expected, rel=1e-12)
    assert float(sway.regressor.subs({**point, v: 0.0})) == 0.0
    assert float(sway.regressor.subs({**point, delta: 0.0})) == 0.0
