"""The hull-basis blend of benchmarks/candidates.py (``offset-hullmix``, issue 13).

Each nonlinear modulus hull term is blended with the cubic term of the same symmetry,
(1 − b)·modulus + b·cubic: at b = 0 the family is the default one term for term, at b = 1
its hull is the MMG cubic basis of ``prime-cubic``, and the coefficient count is the
default's at every b.
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest
import sympy as sp

from fmu_model.structure import ModelStructure, Term, r, v
from fmu_model.variants import PRIME_CUBIC, PRIME_RUDDER_OFFSET, ModelFamily
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
