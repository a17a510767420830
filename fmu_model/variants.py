"""The registered manoeuvring-model variants.

Each variant is a :class:`~fmu_model.structure.ModelStructure`: the accelerations as
sums of coefficient × regressor. Register a new one with :func:`register_model`;
callers find it by name (``get_model``) and need no change.
"""

from __future__ import annotations

import sympy as sp

from fmu_model.structure import L, ModelStructure, Term, delta, n, r, u, v

_REGISTRY: dict[str, ModelStructure] = {}

DEFAULT_MODEL = "prime-modulus"
"""The default structure: the one that best predicts held-out manoeuvres
(benchmarks/fidelity.md: trained on KVLCC2 zig-zags only, it predicts the 35° turn
within 9 %, where shi2009 misses by 44 % and prime-cubic does not complete the turn)."""


def register_model(structure: ModelStructure) -> ModelStructure:
    """Add a structure to the registry under its name; returns it for chaining."""
    if structure.name in _REGISTRY:
        raise ValueError(f"model {structure.name!r} is already registered")
    _REGISTRY[structure.name] = structure
    return structure


def get_model(name: str) -> ModelStructure:
    """Return the registered structure called ``name``.

    Raises
    ------
    KeyError
        With the list of known names when ``name`` is not registered.

    """
    try:
        return _REGISTRY[name]
    except KeyError:
        known = ", ".join(sorted(_REGISTRY))
        raise KeyError(f"unknown model {name!r} (known: {known})") from None


def model_names() -> tuple[str, ...]:
    """Names of all registered structures, sorted."""
    return tuple(sorted(_REGISTRY))


SHI2009 = register_model(
    ModelStructure(
        name="shi2009",
        description="Shi et al. (2009) nonlinear 3-DOF model, 16 constant coefficients",
        reference=(
            "Shi, C., Zhao, D., Peng, J., Shen, C. (2009). Identification of ship "
            "maneuvering model using extended Kalman filters. TransNav 3(1), eq. (2)"
        ),
        # Shi et al. (2009), eq. (2), f_u: surge, second-order Taylor expansion with the
        # zero-, first- and second-order resistance terms in u merged into a1 u^2.
        surge=(
            Term("a1", u**2),
            Term("a2", v**2),
            Term("a3", r**2),
            Term("a4", delta**2),
            Term("a5", v * r),
            Term("a6", v * delta),
            Term("a7", r * delta),
            Term("a8", u * n),
            Term("a9", n**2),
        ),
        # Shi et al. (2009), eq. (2), f_v: sway.
        sway=(
            Term("b1", v),
            Term("b2", r),
            Term("b3", delta),
            Term("b4", u * r),
        ),
        # Shi et al. (2009), eq. (2), f_r: yaw.
        yaw=(
            Term("c1", v),
            Term("c2", r),
            Term("c3", delta),
        ),
    )
)


# --- Speed-dependent variants in the non-dimensional (prime) system -------------------
# Hull forces ½ρLdU²·Y'(v', r') divided by the (absorbed) mass give accelerations
# q·f(v', r') with q = U²/L, v' = v/U, r' = rL/U; yaw moments carry one more 1/L.
# Rudder normal force from an inflow mixing ship speed and propeller slipstream:
# u²·sinδ·cosδ and n²·L²·sinδ·cosδ (sway; /L in yaw), rudder-inflow damping n·v and
# n·r·L; surge from propeller and resistance: n²L, u·n, u²/L, v·r, q·v'², q·r'² and the
# rudder drag u²·sin²δ/L, n²L·sin²δ. Every coefficient is dimensionless.
# References: Yasukawa & Yoshimura (2015), MMG standard method (hull polynomials);
# Norrbin (1970) and Oltmann & Sharma (1984) for the modulus (cross-flow) form;
# reference/model_structures.md for the trials that led to these structures.
_U = sp.sqrt(u**2 + v**2)
_q = _U**2 / L
_vp = v / _U
_rp = r * L / _U
_SIN2D = sp.sin(delta) * sp.cos(delta)  # sin δ cos δ = ½ sin 2δ

_SURGE_PRIME = (
    Term("X_nn", n**2 * L),
    Term("X_un", u * n),
    Term("X_uu", u**2 / L),
    Term("X_vr", v * r),
    Term("X_vv", _q * _vp**2),
    Term("X_rr", _q * _rp**2),
    Term("X_uudd", u**2 * sp.sin(delta) ** 2 / L),
    Term("X_nndd", n**2 * L * sp.sin(delta) ** 2),
)
_RUDDER_SWAY = (
    Term("Y_uud", u**2 * _SIN2D / L),
    Term("Y_nnd", n**2 * L * _SIN2D),
    Term("Y_nv", n * v),
    Term("Y_nr", n * r * L),
)
_RUDDER_YAW = (
    Term("N_uud", u**2 * _SIN2D / L**2),
    Term("N_nnd", n**2 * _SIN2D),
    Term("N_nv", n * v / L),
    Term("N_nr", n * r),
)


def _hull(
    prefix: str, per_length: sp.Expr, basis: tuple[tuple[str, sp.Expr], ...]
) -> tuple[Term, ...]:
    return tuple(Term(f"{prefix}_{name}", _q * per_length * f) for name, f in basis)


_CUBIC = (
    ("v", _vp),
    ("r", _rp),
    ("vvv", _vp**3),
    ("vvr", _vp**2 * _rp),
    ("vrr", _vp * _rp**2),
    ("rrr", _rp**3),
)
_MODULUS = (
    ("v", _vp),
    ("r", _rp),
    ("vav", _vp * sp.Abs(_vp)),
    ("rar", _rp * sp.Abs(_rp)),
    ("var", _vp * sp.Abs(_rp)),
    ("avr", sp.Abs(_vp) * _rp),
)

PRIME_CUBIC = register_model(
    ModelStructure(
        name="prime-cubic",
        description="speed-dependent non-dimensional model, MMG cubic hull basis, 28 coefficients",
        reference="Yasukawa & Yoshimura (2015) hull polynomials; reference/model_structures.md",
        surge=_SURGE_PRIME,
        sway=_hull("Y", sp.Integer(1), _CUBIC) + _RUDDER_SWAY,
        yaw=_hull("N", 1 / L, _CUBIC) + _RUDDER_YAW,
    )
)

PRIME_MODULUS = register_model(
    ModelStructure(
        name="prime-modulus",
        description="speed-dependent non-dimensional model, modulus (cross-flow) hull basis, "
        "28 coefficients",
        reference="Norrbin (1970) modulus form; reference/model_structures.md",
        surge=_SURGE_PRIME,
        sway=_hull("Y", sp.Integer(1), _MODULUS) + _RUDDER_SWAY,
        yaw=_hull("N", 1 / L, _MODULUS) + _RUDDER_YAW,
    )
)
