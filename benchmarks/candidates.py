"""Candidate terms of issue 13, studied with benchmarks/hsva.py and fidelity.py.

Registered here, not in ``fmu_model``: none predicted the held-out measured runs better
than ``prime-rudder`` (``benchmarks/hsva.md``, the sections after the first table;
``benchmarks/fidelity.md``, "Issue 13's candidates on the reference" and after); the one that did,
a rudder normal force not linear in sin α_R, is ``fmu_model``'s ``prime-rudder-lift``,
the one whose every fit of the measured runs turns, a thrust of fixed open-water slope, is
``prime-rudder-thrust``, and the neutral-rudder offset that predicts the Mariner's turns
from logs approaching at its neutral helm is ``prime-rudder-offset`` (the candidate
``offset`` of earlier rounds, with ``prime-rudder-offset-thrust`` as its thrust fallback).
Each is
``prime-rudder`` plus terms with one gain each, or with another rudder force and its
shape constants. The ``offset-*`` candidates take the default's surge equation, since
the round of 2026-12-06 (tenth) with its prior on the surge drag of drift and yaw
(``fmu_model.variants.with_surge_drag_prior``); their tables measured before are of the
free one:

* ``asym-hull``: even yaw-rate terms of the hull, q·r′² in sway and yaw (r²L, r²), a
  side-dependent yaw damping: the propeller's swirl makes the stern flow asymmetric;
* ``asym-prop``: a constant propeller side force and yaw moment, n²L and n² (§5 of
  reference/model_structures.md: too small on its own);
* ``lift-thrust``: the thrust of fixed open-water slope of ``prime-rudder-thrust`` (the
  candidate ``thrust`` of earlier rounds, registered in ``fmu_model``: every fit of the
  measured HSVA runs turns) in ``prime-rudder-lift``;
* ``offset-lift``, ``offset-lift-thrust``: ``prime-rudder-lift``'s u_R² sin³α_R in sway
  and yaw on the default ``prime-rudder-offset`` (both angles of attack with δ₀), and the
  same with the thrust of fixed open-water slope (what a fit at one rpm whose free split
  is not a propeller's would be refitted as);
* ``offset-xflow``, ``offset-xflow-thrust``: a rudder normal force with a cross-flow
  drag part, u_R² sin α_R |sin α_R| beside u_R² sin α_R in sway and yaw on the default
  ``prime-rudder-offset`` (Hoerner's low-aspect-ratio wing, C_N = C_Lα sin α +
  C_Dc sin α |sin α|: a normal force that grows faster than sin α from small angles on,
  where ``prime-rudder-lift``'s sin³α is nearly silent at 10°), and the same with the
  thrust of fixed open-water slope;
* ``offset-asym-hull``, ``offset-asym-hull-thrust``: ``asym-hull``'s even yaw-rate terms on
  the default ``prime-rudder-offset``, and the same with the fixed thrust;
* ``offset-swirl-thrust``: ``swirl``'s angle beside the neutral-rudder offset δ₀, with the
  fixed thrust;
* ``offset-shadow``, ``offset-shadow-thrust``: the rudder in the hull's shadow at drift,
  u_R²·v′|v′|·|sin δ| in sway and yaw (one gain each, Y_Rb and N_Rb) on the default
  ``prime-rudder-offset``: Van Berlekom & Goddard's drift-rudder term c²|β|β|δ|, which
  cancels the tanker's rudder force in its hard turns (``scenarios/tanker.py``;
  ``benchmarks/fidelity.md``, "A third structure"); and the same with the fixed thrust.
  Its tables in ``fidelity.md`` ("The rudder in the hull's shadow") were measured with
  ``offset-shadow`` refitted as its thrust twin, as ``fit`` does the default (one more
  entry in ``identifier.identify``'s map of fixed-thrust families, in a worktree);
* ``slipstream-nvvr``, ``slipstream-nvvr-thrust``: the default ``prime-rudder-slipstream``
  with the MMG cubic basis' yaw term q·v′²r′/L beside the modulus ones (one gain, N_vvr),
  and the same with the fixed thrust: the yaw damping a hard turn's drift adds, which
  carries half of the KVLCC2 reference's yaw damping in its 35° turn and grows faster
  than the modulus terms from the zig-zags' yaw rates (``benchmarks/fidelity.md``, "How
  far a turn is extrapolated": the yaw equation carries the turn's error). The best
  zig-zag-trained KVLCC2 turns yet, but on the measured HSVA runs the 20°/10° overshoots
  twice as far off and turns 25–41 % too wide (``hsva.md``, "The yaw damping of a turn's
  drift"): not adopted;
* ``helm``: the neutral-rudder offset linearised, so that it is estimated with the other
  gains instead of gridded: u_R² sin(α_R + δ₀) ≈ u_R² sin α_R + δ₀·u_R² cos α_R, the
  second term with its own gain in sway and yaw (Y_R0, N_R0; Y_R0/Y_R ≈ δ₀): the
  single-screw ship's neutral helm, which a log approaching straight at a held rudder
  shows (``benchmarks/fidelity.md``, "A straight approach at the neutral helm");
* ``swirl``: the propeller-swirl angle of issue 13, α_R = δ + s·k(nL)²/u_R² + …, with s a
  shape constant (±0.3 rad, grid −0.15, 0, 0.15): it grows with the slipstream share,
  i.e. as the ship slows in a turn (reference/model_structures.md §9: equation error
  alone cannot choose s);
* ``slipstream``: the rudder inflow of the MMG standard method (Yasukawa & Yoshimura 2015,
  reference/kvlcc2_mmg.md §5) instead of u_P² + k(nL)²: u_R² = η(u_P + κ(S − u_P))² +
  (1 − η)u_P², S² = u_P² + c(nL)², with η = D_P/H_R = 0.7 and κ = 0.5 fixed (KVLCC2:
  0.626, 0.50) and c, which stands for 8K_T D_P²/(πL²) at a constant K_T, searched in
  place of k (KVLCC2 about 2e-3). Its cross term 2ηκ(1 − κ)·S·u_P, which
  u_P² + k(nL)² lacks, changes how the inflow falls with the speed in a turn. On the
  default's neutral-rudder offset and surge prior it is ``fmu_model``'s
  ``prime-rudder-slipstream``, the default since 2026-12-07;
* ``rudder-cubic``: the rudder force of ``prime-rudder`` with the MMG cubic hull basis
  {v′, r′, v′³, v′²r′, v′r′², r′³} (``prime-cubic``'s) in place of the modulus one: the
  KVLCC2 reference's own hull form;
* ``rudder-both``: the modulus basis and the cubic terms v′³, v′²r′, v′r′², r′³ together
  (25 coefficients);
* ``crossflow-lift``, ``crossflow-lift-thrust``: ``prime-rudder-lift``'s u_R² sin³α_R in
  sway and yaw on ``prime-crossflow`` (the hull's cross-flow drag, ``fmu_model``), and the
  same with the thrust of fixed open-water slope;
* ``offset-hullmix``, ``offset-hullmix-thrust``: the default ``prime-rudder-offset`` with
  each nonlinear hull term a blend of the modulus basis and the MMG cubic one paired by
  symmetry, (1 − b)·v′|v′| + b·v′³, (1 − b)·r′|r′| + b·r′³, (1 − b)·v′|r′| + b·v′r′²,
  (1 − b)·|v′|r′ + b·v′²r′, with the cubic share b a shape constant in [0, 1] (grid 0,
  0.5, 1): the hull's form chosen by the equation-error residual with the rudder's, the
  coefficient count that of the default (the reference is cubic, the measured runs
  prefer the modulus basis: ``rudder-cubic`` above and ``benchmarks/hsva.md``); and the
  same with the fixed thrust;
* ``offset-norar``, ``offset-norar-thrust``: the default ``prime-rudder-offset`` without
  N_rar (its HSVA fits have N_rar > 0, a yaw damping that falls with the rate): what a
  sign constraint N_rar ≤ 0 gives where it binds; and the same with the fixed thrust;
* ``offset-thrustprior``: ``prime-rudder-offset-thrust`` (the thrust of fixed open-water
  slope, X_T·(n²L − κ·u·n)) plus a free slope term X_un·u·n under a zero-mean prior of
  :data:`THRUST_SLOPE_DEVIATION_STD`: the propeller's slope where the logs leave the split
  open, theirs where they determine it — the thrust rule's switch made a prior
  (``fidelity.md``, "The surge drag prior in the default family", last paragraph);
* ``both-prior002``, ``both-prior010``: ``rudder-both`` with a zero-mean prior on the
  cubic terms (``Term.prior_std``) of 0.02 and 0.1 in the MMG's Y′ and N′ (per ½ρL²d,
  ½ρL³d; KVLCC2 |Y′_vvv| 1.6, |N′_vvr| 0.29): cubic terms that count only where the logs
  determine them.
"""

from __future__ import annotations

from dataclasses import replace

import sympy as sp

from fmu_model.structure import L, ModelStructure, Term, delta, n, r, u, v
from fmu_model.variants import (
    NEUTRAL_RUDDER_OFFSET,
    PRIME_CROSSFLOW,
    PRIME_CUBIC,
    PRIME_MODULUS,
    PRIME_RUDDER,
    PRIME_RUDDER_LIFT,
    PRIME_RUDDER_OFFSET,
    PRIME_RUDDER_OFFSET_THRUST,
    PRIME_RUDDER_SLIPSTREAM,
    RUDDER_INFLOW_SQUARED,
    SLIPSTREAM_SHARE,
    SWAY_MASS,
    YAW_INERTIA,
    ModelFamily,
    ShapeConstant,
    parse_family,
    register_family,
    rudder_angle_of_attack,
    rudder_gain_terms,
    rudder_lift_terms,
    rudder_normal_force,
    with_fixed_thrust,
    with_mmg_inflow,
    with_prior,
    with_rudder_force,
)

SWIRL_RAD = sp.Symbol("swirl", real=True)
CUBIC_SHARE = sp.Symbol("b", nonnegative=True)
_CUBIC_SHARE = ShapeConstant(CUBIC_SHARE, 0.0, 1.0, 0.0, (0.0, 0.5, 1.0))
#: The modulus basis' nonlinear terms and the cubic ones of the same symmetry.
HULL_PAIRS = {"vav": "vvv", "rar": "rrr", "var": "vrr", "avr": "vvr"}
_SWIRL = ShapeConstant(SWIRL_RAD, -0.3, 0.3, 0.0, (-0.15, 0.0, 0.15))
CUBIC_HULL = ("v", "r", "vvv", "vvr", "vrr", "rrr")  # the MMG hull basis, prime-cubic's
MODULUS_HULL = ("v", "r", "vav", "rar", "var", "avr")  # prime-rudder's (prime-modulus's)


def _with_terms(
    name: str,
    surge: tuple[Term, ...],
    sway: tuple[Term, ...],
    yaw: tuple[Term, ...],
    base: ModelFamily = PRIME_RUDDER,
) -> ModelFamily:
    """Return ``base`` with the surge terms ``surge`` and extra sway and yaw terms."""
    return replace(base, name=name, surge=surge, sway=base.sway + sway, yaw=base.yaw + yaw)


def _with_hull(name: str, sway: tuple[Term, ...], yaw: tuple[Term, ...]) -> ModelFamily:
    """``prime-rudder`` with the hull terms ``sway`` and ``yaw`` before its rudder's."""
    base = PRIME_RUDDER
    (rudder_sway,), (rudder_yaw,) = sway_and_yaw_terms(base, "R")
    return replace(base, name=name, sway=(*sway, rudder_sway), yaw=(*yaw, rudder_yaw))


def sway_and_yaw_terms(
    source: ModelStructure | ModelFamily, *bases: str
) -> tuple[tuple[Term, ...], tuple[Term, ...]]:
    """Sway and yaw terms Y_b, N_b of ``source`` for the basis functions named (``vvr``)."""
    sway = {t.coefficient: t for t in source.sway}
    yaw = {t.coefficient: t for t in source.yaw}
    return tuple(sway[f"Y_{b}"] for b in bases), tuple(yaw[f"N_{b}"] for b in bases)


def hull_mixed(base: ModelFamily, name: str) -> ModelFamily:
    """Return ``base`` with each modulus hull term blended with its cubic twin (``HULL_PAIRS``)."""

    def mixed(terms: tuple[Term, ...], cubic: tuple[Term, ...]) -> tuple[Term, ...]:
        twin = {t.coefficient[2:]: t.regressor for t in cubic}
        return tuple(
            replace(
                t,
                regressor=(1 - CUBIC_SHARE) * t.regressor
                + CUBIC_SHARE * twin[HULL_PAIRS[t.coefficient[2:]]],
            )
            if t.coefficient[2:] in HULL_PAIRS
            else t
            for t in terms
        )

    cubic_sway, cubic_yaw = sway_and_yaw_terms(PRIME_CUBIC, *CUBIC_HULL)
    return replace(
        base,
        name=name,
        sway=mixed(base.sway, cubic_sway),
        yaw=mixed(base.yaw, cubic_yaw),
        shape=(*base.shape, _CUBIC_SHARE),
    )


# X_un of a propeller's thrust is −κ·X_T (KVLCC2 X_T ≈ 2e-5, κ 20): a deviation of
# 10·X_T is a slope κ ± 10, single-screw ships' 12–40 within two standard deviations.
THRUST_SLOPE_DEVIATION_STD = 2e-4


_, _HELM_SWAY, _HELM_YAW = rudder_gain_terms(
    RUDDER_INFLOW_SQUARED * sp.cos(rudder_angle_of_attack()), suffix="0"
)


_OFFSET_SWAY3, _OFFSET_YAW3 = rudder_lift_terms(NEUTRAL_RUDDER_OFFSET)

_SIN_ALPHA = sp.sin(rudder_angle_of_attack(NEUTRAL_RUDDER_OFFSET))
# sin α |sin α| as a Piecewise: sympy's Abs of an expression it cannot prove real
# differentiates into re() and im(), which the code printers do not print.
_, _XFLOW_SWAY, _XFLOW_YAW = rudder_gain_terms(
    RUDDER_INFLOW_SQUARED
    * sp.Piecewise((_SIN_ALPHA**2, _SIN_ALPHA >= 0), (-(_SIN_ALPHA**2), True)),
    suffix="2",
)


# The rudder in the hull's shadow at drift (module docstring): u_R²·v′|v′|·|sin δ|, the
# cos δ of rudder_gain_terms divided out; v′ = v/U.
_V_PRIME = v / sp.sqrt(u**2 + v**2)
_, _SHADOW_SWAY, _SHADOW_YAW = rudder_gain_terms(
    RUDDER_INFLOW_SQUARED * _V_PRIME * sp.Abs(_V_PRIME) * sp.Abs(sp.sin(delta)) / sp.cos(delta),
    suffix="b",
)


def candidate_families() -> tuple[ModelFamily, ...]:
    """Return the candidate families of the module docstring."""
    base = PRIME_RUDDER
    modulus = sway_and_yaw_terms(PRIME_MODULUS, *MODULUS_HULL)
    cubic = sway_and_yaw_terms(PRIME_CUBIC, *CUBIC_HULL)
    extra = sway_and_yaw_terms(PRIME_CUBIC, *CUBIC_HULL[2:])
    offset_lift = _with_terms(
        "offset-lift",
        PRIME_RUDDER_OFFSET.surge,
        (_OFFSET_SWAY3,),
        (_OFFSET_YAW3,),
        PRIME_RUDDER_OFFSET,
    )
    offset_xflow = _with_terms(
        "offset-xflow",
        PRIME_RUDDER_OFFSET.surge,
        (_XFLOW_SWAY,),
        (_XFLOW_YAW,),
        PRIME_RUDDER_OFFSET,
    )
    offset_asym_hull = _with_terms(
        "offset-asym-hull",
        PRIME_RUDDER_OFFSET.surge,
        (Term("Y_rr", r**2 * L),),
        (Term("N_rr", r**2),),
        PRIME_RUDDER_OFFSET,
    )
    hullmix = hull_mixed(PRIME_RUDDER_OFFSET, "offset-hullmix")
    no_rar = replace(
        PRIME_RUDDER_OFFSET,
        name="offset-norar",
        yaw=tuple(t for t in PRIME_RUDDER_OFFSET.yaw if t.coefficient != "N_rar"),
    )
    thrust_prior = replace(
        PRIME_RUDDER_OFFSET_THRUST,
        name="offset-thrustprior",
        surge=(
            *PRIME_RUDDER_OFFSET_THRUST.surge,
            Term("X_un", u * n, prior_std=THRUST_SLOPE_DEVIATION_STD),
        ),
    )
    shadow = _with_terms(
        "offset-shadow",
        PRIME_RUDDER_OFFSET.surge,
        (_SHADOW_SWAY,),
        (_SHADOW_YAW,),
        PRIME_RUDDER_OFFSET,
    )
    crossflow_lift = _with_terms(
        "crossflow-lift", PRIME_CROSSFLOW.surge, (_OFFSET_SWAY3,), (_OFFSET_YAW3,), PRIME_CROSSFLOW
    )
    yaw_vvr = _with_terms(
        "slipstream-nvvr",
        PRIME_RUDDER_SLIPSTREAM.surge,
        (),
        sway_and_yaw_terms(PRIME_CUBIC, "vvr")[1],
        PRIME_RUDDER_SLIPSTREAM,
    )
    return (
        yaw_vvr,
        with_fixed_thrust(yaw_vvr, "slipstream-nvvr-thrust", "slipstream-nvvr, fixed thrust"),
        shadow,
        with_fixed_thrust(shadow, "offset-shadow-thrust", "offset-shadow, fixed thrust"),
        crossflow_lift,
        with_fixed_thrust(crossflow_lift, "crossflow-lift-thrust", "crossflow-lift, fixed thrust"),
        _with_hull("rudder-cubic", *cubic),
        _with_hull("rudder-both", modulus[0] + extra[0], modulus[1] + extra[1]),
        *(
            _with_hull(
                f"both-prior{round(100 * std):03d}",
                modulus[0] + with_prior(extra[0], std / SWAY_MASS),
                modulus[1] + with_prior(extra[1], std / YAW_INERTIA),
            )
            for std in (0.02, 0.1)
        ),
        _with_terms("asym-hull", base.surge, (Term("Y_rr", r**2 * L),), (Term("N_rr", r**2),)),
        _with_terms("asym-prop", base.surge, (Term("Y_nn", n**2 * L),), (Term("N_nn", n**2),)),
        with_fixed_thrust(PRIME_RUDDER_LIFT, "lift-thrust", "prime-rudder-lift, fixed thrust"),
        offset_lift,
        with_fixed_thrust(offset_lift, "offset-lift-thrust", "offset-lift, fixed thrust"),
        offset_xflow,
        with_fixed_thrust(offset_xflow, "offset-xflow-thrust", "offset-xflow, fixed thrust"),
        no_rar,
        thrust_prior,
        with_fixed_thrust(no_rar, "offset-norar-thrust", "offset-norar, fixed thrust"),
        hullmix,
        with_fixed_thrust(hullmix, "offset-hullmix-thrust", "offset-hullmix, fixed thrust"),
        offset_asym_hull,
        with_fixed_thrust(
            offset_asym_hull, "offset-asym-hull-thrust", "offset-asym-hull, fixed thrust"
        ),
        with_fixed_thrust(
            with_rudder_force(
                PRIME_RUDDER_OFFSET,
                "offset-swirl",
                rudder_normal_force(NEUTRAL_RUDDER_OFFSET + SWIRL_RAD * SLIPSTREAM_SHARE),
                (*PRIME_RUDDER_OFFSET.shape, _SWIRL),
            ),
            "offset-swirl-thrust",
            "offset with the swirl angle, fixed thrust",
        ),
        _with_terms(
            "helm",
            base.surge,
            (_HELM_SWAY,),
            (_HELM_YAW,),
        ),
        with_rudder_force(
            PRIME_RUDDER,
            "swirl",
            rudder_normal_force(SWIRL_RAD * SLIPSTREAM_SHARE),
            (*base.shape, _SWIRL),
        ),
        with_mmg_inflow(PRIME_RUDDER, "slipstream"),
    )


def register_candidates() -> tuple[str, ...]:
    """Register the candidate families (once); return their names."""
    names = []
    for family in candidate_families():
        if parse_family(family.name) is None:
            register_family(family)
        names.append(family.name)
    return tuple(names)
