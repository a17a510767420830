"""Model families: shape constants in model names, and their choice from the data."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace

import numpy as np
import pytest

from fmu_model import ModelParameters, get_model, model_names, numeric_model, simulate
from fmu_model.numeric import family_regressors
from fmu_model.structure import unit_string
from fmu_model.variants import (
    PRIME_RUDDER,
    PRIME_RUDDER_OFFSET,
    PRIME_RUDDER_SLIPSTREAM,
    PRIME_RUDDER_THRUST,
    THRUST_SLOPE,
    ModelFamily,
    family_name,
    parse_family,
)
from identifier import shape as shape_module
from identifier.ekf import EkfSegment
from identifier.equation_error import NormalEquations, regression_rows
from identifier.identify import FitSettings, identify
from identifier.shape import select_shape
from scenarios.synthesize import MANEUVERS, model_ship, synthesize_log

# A 320 m tanker in prime-rudder form (equation-error fit to KVLCC2 logs, rounded).
COEFFICIENTS = {
    "X_nn": 2.293e-05, "X_un": -0.001159, "X_uu": -0.03238, "X_vr": 3.504, "X_vv": 1.91,
    "X_rr": 0.501, "X_R": -0.0776,
    "Y_v": -0.8297, "Y_r": -0.6655, "Y_vav": -1.876, "Y_rar": 0.4918, "Y_var": 1.04,
    "Y_avr": 0.5201, "Y_R": -0.05537,
    "N_v": -3.294, "N_r": -0.918, "N_vav": 11.57, "N_rar": -1.616, "N_var": -1.687,
    "N_avr": 1.906, "N_R": 0.511,
}  # fmt: skip
TRUE_SHAPE = {"k": 1.5e-4, "gamma": 0.52, "dgamma": 0.12, "l": -0.7, "wake": 0.35, "dwake": 0.25}
LENGTH_M, SPEED_MPS, N_RPS = 320.0, 8.0, 1.75


def _truth(
    family: ModelFamily = PRIME_RUDDER, base: Mapping[str, float] = TRUE_SHAPE, **shape: float
) -> ModelParameters:
    return ModelParameters.from_vector(
        family.structure_name({**base, **shape}),
        np.array(list(COEFFICIENTS.values())),
        length_m=LENGTH_M,
        vessel_name="tanker",
        nominal_speed_mps=SPEED_MPS,
        nominal_n_rps=N_RPS,
    )


def test_family_names_carry_their_shape() -> None:
    assert "prime-rudder" in model_names()
    default = get_model("prime-rudder")
    assert default.name == "prime-rudder[k=0.0004,gamma=0.5,dgamma=0,l=-1,wake=0,dwake=0]"
    assert default.n_coefficients == 21
    # Every gain is dimensionless: the regressors carry the units.
    assert set(map(unit_string, default.coefficient_units().values())) == {"1"}
    partial = get_model("prime-rudder[dgamma=0.1]")
    assert partial.name == "prime-rudder[k=0.0004,gamma=0.5,dgamma=0.1,l=-1,wake=0,dwake=0]"
    family, fixed = parse_family("prime-rudder[dgamma=0.1, l=-0.6]") or (None, None)
    assert family is PRIME_RUDDER and fixed == {"dgamma": 0.1, "l": -0.6}
    assert parse_family("prime-modulus") is None
    assert family_name(partial.name) == "prime-rudder" and family_name("shi2009") == "shi2009"


@pytest.mark.parametrize(
    ("name", "message"),
    [
        ("prime-rudder[k=0.1]", r"k=0.1 outside \[0.0, 0.05\]"),
        ("prime-rudder[gamma=nan]", "gamma=nan outside"),
        ("prime-rudder[beta=0.3]", "unknown shape constant 'beta'"),
        ("prime-rudder[k]", "expected name=value"),
        ("prime-rudder[k=small]", "'small' is not a number"),
        ("prime-ruder[k=0.1]", "unknown model"),
    ],
)
def test_malformed_family_names_are_rejected(name: str, message: str) -> None:
    with pytest.raises(KeyError, match=message):
        get_model(name)


def test_rudder_force_depends_on_the_side_of_the_flow_as_in_mmg() -> None:
    # w = v + l r L > 0 straightens with γ − Δγ, w < 0 with γ + Δγ; the wake recovers
    # with C₂ − 1 = wake ± dwake for β = −w/U ≷ 0, saturating as C₁|β|/(1 + C₁|β|).
    params = _truth()
    model = numeric_model(params.structure)
    i = params.names.index("Y_R")
    u, delta, c1 = 6.0, math.radians(10.0), 2.0
    for w in (0.3, -0.3):
        gamma = TRUE_SHAPE["gamma"] - math.copysign(TRUE_SHAPE["dgamma"], w)
        beta = -w / math.hypot(u, w)
        c2_minus_1 = TRUE_SHAPE["wake"] + math.copysign(TRUE_SHAPE["dwake"], beta)
        u_p = u * (1.0 + c2_minus_1 * c1 * abs(beta) / (1.0 + c1 * abs(beta)))
        u_r2 = u_p**2 + TRUE_SHAPE["k"] * (N_RPS * LENGTH_M) ** 2
        alpha = delta + math.atan(gamma * w / math.sqrt(u_r2))
        expected = u_r2 * math.sin(alpha) * math.cos(delta) / LENGTH_M
        got = model.regressors(u, w, 0.0, delta, N_RPS, LENGTH_M)[i]
        assert got == pytest.approx(expected, rel=1e-12)


def _segments(truth: ModelParameters | None = None) -> list[EkfSegment]:
    """Noise-free velocities of three sine-rudder runs at two propeller speeds, 0.5 s."""
    truth = truth or _truth()
    t = np.arange(0.0, 700.0, 0.5)
    segments = []
    for amplitude_deg, n_rps, period_s in (
        (20.0, 1.75, 200.0),
        (35.0, 1.2, 300.0),
        (12.0, 1.75, 120.0),
    ):
        rudder = np.radians(amplitude_deg) * np.sin(2.0 * np.pi * t / period_s)
        n = np.full(t.size, n_rps)
        states = simulate(truth, t, rudder, n, [SPEED_MPS * n_rps / N_RPS, 0, 0, 0, 0, 0],
                          max_step_s=0.1)  # fmt: skip
        segments.append(
            EkfSegment(
                name=f"sine {amplitude_deg:g} deg",
                time_s=t,
                velocities=states[:, :3],
                velocity_std=np.ones((t.size, 3)),
                track=states[:, 3:],
                track_std=np.ones(3),
                initial_track=states[0, 3:],
                rudder_rad=rudder,
                n_rps=n,
            )
        )
    return segments


def test_shape_search_finds_the_slipstream_share_and_fits_as_well_as_the_truth(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    segments = _segments()
    short = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS)
    at_truth = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed=TRUE_SHAPE)
    assert at_truth.shape == TRUE_SHAPE and at_truth.evaluations == 3  # nothing to search
    # The default polish stops after SHAPE_POLISH_SWEEPS (a regularisation): short of the
    # truth's residual on these noise-free logs, and far below the default shape's.
    assert at_truth.residual < short.residual < 0.01 * short.default_residual
    # With room to converge, the search does as well as the truth, whose residual is the
    # central difference's O(Δt²).
    monkeypatch.setattr(shape_module, "SHAPE_POLISH_SWEEPS", 30)
    found = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS)
    assert found.residual <= at_truth.residual * 1.001
    # (the 0.5 s samples are decimated to 1 s: the central difference spans 2 s)
    assert found.shape["k"] == pytest.approx(TRUE_SHAPE["k"], rel=0.07)
    assert found.shape["dgamma"] == pytest.approx(TRUE_SHAPE["dgamma"], abs=0.03)
    assert found.shape["wake"] == pytest.approx(TRUE_SHAPE["wake"], abs=0.05)
    assert found.shape["dwake"] == pytest.approx(TRUE_SHAPE["dwake"], abs=0.03)
    assert found.structure.name == PRIME_RUDDER.structure_name(found.shape)
    # γ and l trade off along a ridge (γ·(v + l r L)); with l known, γ is found.
    known_l = select_shape(
        PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed={"l": TRUE_SHAPE["l"]}
    )
    assert known_l.shape["l"] == TRUE_SHAPE["l"]
    assert known_l.shape["gamma"] == pytest.approx(TRUE_SHAPE["gamma"], abs=0.03)


def test_the_neutral_rudder_offset_holds_a_straight_course_and_is_found() -> None:
    """prime-rudder-offset: α_R gains d0, so the rudder gives no force at δ = −d0 on a
    straight course (the single screw's neutral helm), and the shape search finds d0
    from logs of a ship that has one (the other constants given)."""
    d0 = 0.02
    truth = _truth(PRIME_RUDDER_OFFSET, d0=d0)
    model = numeric_model(truth.structure)
    at_helm = model.regressors(6.0, 0.0, 0.0, -d0, N_RPS, LENGTH_M)
    amidships = model.regressors(6.0, 0.0, 0.0, 0.0, N_RPS, LENGTH_M)
    for name in ("X_R", "Y_R", "N_R"):
        assert at_helm[truth.names.index(name)] == pytest.approx(0.0, abs=1e-15)
    # Amidships on a straight course: u_R² = u² + k(nL)², α_R = d0 (X_R's sin δ is 0).
    u_r2 = 6.0**2 + TRUE_SHAPE["k"] * (N_RPS * LENGTH_M) ** 2
    assert amidships[truth.names.index("Y_R")] == pytest.approx(u_r2 * math.sin(d0) / LENGTH_M)
    assert amidships[truth.names.index("N_R")] == pytest.approx(u_r2 * math.sin(d0) / LENGTH_M**2)
    t = np.arange(0.0, 300.0, 1.0)
    straight = simulate(truth, t, np.full(t.size, -d0), np.full(t.size, N_RPS),
                        [SPEED_MPS, 0, 0, 0, 0, 0], max_step_s=0.1)  # fmt: skip
    midship = simulate(truth, t, np.zeros(t.size), np.full(t.size, N_RPS),
                       [SPEED_MPS, 0, 0, 0, 0, 0], max_step_s=0.1)  # fmt: skip
    assert np.max(np.abs(straight[:, 5])) < 1e-12
    assert math.degrees(midship[-1, 5]) > 5.0  # d0 > 0 acts as starboard rudder
    found = select_shape(
        PRIME_RUDDER_OFFSET, _segments(truth), LENGTH_M, SPEED_MPS, N_RPS, fixed=TRUE_SHAPE
    )
    assert found.shape["d0"] == pytest.approx(d0, abs=1e-3)


# The MMG slipstream constant c of prime-rudder-slipstream in place of k.
TRUE_MMG_SHAPE = {**{k: v for k, v in TRUE_SHAPE.items() if k != "k"}, "c": 2e-3, "d0": 0.01}


def test_the_default_rudder_inflow_is_the_mmg_standard_methods() -> None:
    """prime-rudder-slipstream: u_R² = η(u_P + κ(S − u_P))² + (1 − η)u_P², S² = u_P² +
    c(nL)² (Yasukawa & Yoshimura 2015, eqs. (21)-(23)), η 0.7, κ 0.5, by hand at a drift
    to each side; α_R as prime-rudder-offset's (δ₀ and the side-dependent straightening)."""
    params = _truth(PRIME_RUDDER_SLIPSTREAM, TRUE_MMG_SHAPE)
    model = numeric_model(params.structure)
    shape = TRUE_MMG_SHAPE
    u, delta, c1 = 6.0, math.radians(10.0), 2.0
    for w in (0.3, -0.3):
        beta = -w / math.hypot(u, w)
        c2_minus_1 = shape["wake"] + math.copysign(shape["dwake"], beta)
        u_p = u * (1.0 + c2_minus_1 * c1 * abs(beta) / (1.0 + c1 * abs(beta)))
        far = math.sqrt(u_p**2 + shape["c"] * (N_RPS * LENGTH_M) ** 2)
        u_r2 = 0.7 * (u_p + 0.5 * (far - u_p)) ** 2 + 0.3 * u_p**2
        gamma = shape["gamma"] - math.copysign(shape["dgamma"], w)
        alpha = delta + shape["d0"] + math.atan(gamma * w / math.sqrt(u_r2))
        regressors = model.regressors(u, w, 0.0, delta, N_RPS, LENGTH_M)
        for name, factor in (("X_R", math.sin(delta) / LENGTH_M),
                             ("Y_R", math.cos(delta) / LENGTH_M),
                             ("N_R", math.cos(delta) / LENGTH_M**2)):  # fmt: skip
            got = regressors[params.names.index(name)]
            assert got == pytest.approx(u_r2 * math.sin(alpha) * factor, rel=1e-12)


def test_without_a_slipstream_the_mmg_inflow_is_the_offset_familys() -> None:
    """At c = k = 0 both inflows are u_P²: the two families are one, term for term (the
    Mariner's fits, which find no slipstream, come out the same with either)."""
    shape = {**TRUE_MMG_SHAPE, "c": 0.0}
    mmg = numeric_model(PRIME_RUDDER_SLIPSTREAM.structure(shape))
    offset_shape = {**{k: v for k, v in shape.items() if k != "c"}, "k": 0.0}
    offset = numeric_model(PRIME_RUDDER_OFFSET.structure(offset_shape))
    for state in ((6.0, 0.3, 0.004, 0.2, 1.75), (4.0, -0.8, -0.01, -0.6, 1.2)):
        a = mmg.regressors(*state, LENGTH_M)
        b = offset.regressors(*state, LENGTH_M)
        np.testing.assert_allclose(a, b, rtol=1e-13, atol=0.0)
    with_slipstream = numeric_model(PRIME_RUDDER_SLIPSTREAM.structure(TRUE_MMG_SHAPE))
    assert not np.allclose(with_slipstream.regressors(6.0, 0.3, 0.004, 0.2, 1.75, LENGTH_M),
                           mmg.regressors(6.0, 0.3, 0.004, 0.2, 1.75, LENGTH_M))  # fmt: skip


def test_the_shape_search_finds_the_mmg_slipstream() -> None:
    """c is found from noise-free runs of a ship with that inflow (the rest given)."""
    truth = _truth(PRIME_RUDDER_SLIPSTREAM, TRUE_MMG_SHAPE)
    fixed = {k: v for k, v in TRUE_MMG_SHAPE.items() if k != "c"}
    found = select_shape(
        PRIME_RUDDER_SLIPSTREAM, _segments(truth), LENGTH_M, SPEED_MPS, N_RPS, fixed=fixed
    )
    assert found.shape["c"] == pytest.approx(TRUE_MMG_SHAPE["c"], rel=0.05)
    assert found.structure.name.startswith("prime-rudder-slipstream[c=")


def test_the_thrust_slope_is_not_searched_but_can_be_given() -> None:
    """κ of prime-rudder-thrust: the default unless the name gives it, never searched."""
    segments = _segments()
    default = select_shape(PRIME_RUDDER_THRUST, segments, LENGTH_M, SPEED_MPS, N_RPS)
    given = select_shape(
        PRIME_RUDDER_THRUST, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed={"kappa": 35.0}
    )
    assert default.shape["kappa"] == THRUST_SLOPE and given.shape["kappa"] == 35.0
    assert given.structure.name.endswith(",kappa=35]")
    assert default.shape["k"] != PRIME_RUDDER_THRUST.default_shape["k"]  # the rest searched
    rest = select_shape(PRIME_RUDDER_THRUST, segments, LENGTH_M, SPEED_MPS, N_RPS, TRUE_SHAPE)
    assert rest.evaluations == 3 and rest.shape == {**TRUE_SHAPE, "kappa": THRUST_SLOPE}
    u, n = np.array([6.0, 2.0]), np.array([1.5, 0.4])
    phi = numeric_model(given.structure).regressors(u, 0.0 * u, 0.0 * u, 0.0 * u, n, LENGTH_M)
    np.testing.assert_allclose(phi[0], n**2 * LENGTH_M - 35.0 * u * n)  # X_T's regressor


def test_what_is_searched_is_what_is_neither_given_nor_unsearched() -> None:
    family = PRIME_RUDDER_THRUST
    searched = tuple(c.name for c in family.shape if c.name != "kappa")
    assert family.settled({}) == {"kappa": THRUST_SLOPE}
    assert family.settled({"kappa": 35.0, "l": -0.5}) == {"kappa": 35.0, "l": -0.5}
    assert family.to_search({}) == searched
    assert family.to_search({"l": -0.5}) == tuple(n for n in searched if n != "l")
    assert family.to_search(TRUE_SHAPE) == ()


def test_identify_resolves_the_family_and_the_fmu_model_is_that_structure() -> None:
    ship = model_ship(_truth(), rudder_rate_radps=math.radians(2.3))
    logs = [
        synthesize_log(ship, MANEUVERS[name](), seed=seed)
        for seed, name in enumerate(("zigzag-10", "zigzag-20"))
    ]
    result = identify(logs, FitSettings(model="prime-rudder[l=-0.7]"))
    params = result.params
    shape = params.identification["shape"]
    assert params.model == shape["model"] and params.model.startswith("prime-rudder[k=")
    assert shape["shape"]["l"] == -0.7
    assert shape["shape"]["k"] == pytest.approx(TRUE_SHAPE["k"], rel=0.25)
    assert get_model(params.model).coefficient_names == tuple(COEFFICIENTS)


def _upsampled(seg: EkfSegment, factor: int) -> EkfSegment:
    """``seg`` logged ``factor`` times faster: every ``factor``-th sample is the original."""
    n = factor * (seg.time_s.size - 1) + 1
    t = np.interp(np.arange(n) / factor, np.arange(seg.time_s.size), seg.time_s)
    return replace(
        seg,
        time_s=t,
        velocities=np.column_stack([np.interp(t, seg.time_s, c) for c in seg.velocities.T]),
        rudder_rad=np.interp(t, seg.time_s, seg.rudder_rad),
        n_rps=np.interp(t, seg.time_s, seg.n_rps),
    )


def test_shape_search_is_rate_aware_and_bounded(monkeypatch: pytest.MonkeyPatch) -> None:
    """20 Hz data are searched at about L/U/40 (1 s) like 2 Hz data; a long log on
    SHAPE_MAX_ROWS rows."""
    slow = _segments()  # 2 Hz, decimated by 2
    fast = [_upsampled(seg, 10) for seg in slow]  # 20 Hz, decimated by 20
    free = {"k": TRUE_SHAPE["k"], "gamma": TRUE_SHAPE["gamma"], "dgamma": TRUE_SHAPE["dgamma"]}
    at_2hz = select_shape(PRIME_RUDDER, slow, LENGTH_M, SPEED_MPS, N_RPS, fixed=free)
    at_20hz = select_shape(PRIME_RUDDER, fast, LENGTH_M, SPEED_MPS, N_RPS, fixed=free)
    # L/U/40 at the approach speed is 1.0-1.1 s: every 2nd sample at 2 Hz, every 20th-22nd
    # at 20 Hz.
    assert at_2hz.sample_interval_s == pytest.approx(1.0, abs=0.1)
    assert at_20hz.sample_interval_s == pytest.approx(1.0, abs=0.1)
    assert at_2hz.rows == regression_rows(slow, LENGTH_M) == 3 * (700 - 2)
    assert at_20hz.rows == regression_rows(fast, LENGTH_M)
    assert at_20hz.rows == pytest.approx(at_2hz.rows, rel=0.15)
    assert at_20hz.as_dict()["rows"] == at_20hz.rows
    for name, value in at_2hz.shape.items():  # nearly the same samples: the same shape
        assert at_20hz.shape[name] == pytest.approx(value, rel=0.01, abs=1e-6), name
    monkeypatch.setattr(shape_module, "SHAPE_MAX_ROWS", 500)
    few = select_shape(PRIME_RUDDER, slow, LENGTH_M, SPEED_MPS, N_RPS, fixed=free)
    step = math.ceil(at_2hz.rows / 500)  # every step-th row of each log's
    assert few.rows == sum(math.ceil(regression_rows([seg], LENGTH_M) / step) for seg in slow)
    assert few.rows <= 500


def test_the_polish_stops_after_its_whole_sweeps(monkeypatch: pytest.MonkeyPatch) -> None:
    """The Powell polish runs SHAPE_POLISH_SWEEPS whole sweeps (a regularisation measured
    on the benchmarks, continuous in the data): one sweep fewer stops earlier, at a higher
    residual; more sweeps go on, to a lower one."""
    segments = _segments()
    fixed = {name: TRUE_SHAPE[name] for name in ("dgamma", "wake", "dwake")}
    default = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed=fixed)
    sweeps = shape_module.SHAPE_POLISH_SWEEPS
    monkeypatch.setattr(shape_module, "SHAPE_POLISH_SWEEPS", sweeps - 1)
    fewer = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed=fixed)
    monkeypatch.setattr(shape_module, "SHAPE_POLISH_SWEEPS", sweeps + 4)
    more = select_shape(PRIME_RUDDER, segments, LENGTH_M, SPEED_MPS, N_RPS, fixed=fixed)
    assert fewer.evaluations < default.evaluations < more.evaluations
    assert more.residual < default.residual < fewer.residual


def test_shape_regression_reuses_the_shape_free_sums_and_equals_the_whole_regression() -> None:
    """J's residuals from the shaped columns alone equal those of all 21 columns, for a
    batch of shapes as one at a time; a shape whose regressors are not finite gets inf."""
    assert PRIME_RUDDER.shaped_columns == tuple(
        PRIME_RUDDER.structure(TRUE_SHAPE).coefficient_names.index(n) for n in ("X_R", "Y_R", "N_R")
    )
    rng = np.random.default_rng(3)
    m = 400
    samples = np.vstack(
        [
            SPEED_MPS + rng.normal(0.0, 1.0, m),
            rng.normal(0.0, 0.4, m),
            rng.normal(0.0, 0.005, m),
            rng.uniform(-0.6, 0.6, m),
            np.full(m, N_RPS),
        ]
    )
    acc = rng.normal(0.0, 0.01, (3, m))
    regression = shape_module._ShapeRegression(PRIME_RUDDER, samples, acc, LENGTH_M)
    equation_index = PRIME_RUDDER.structure(TRUE_SHAPE).equation_index
    shapes = np.array(
        [
            [shape[c.name] for c in PRIME_RUDDER.shape]
            for shape in (TRUE_SHAPE, PRIME_RUDDER.default_shape)
        ]
    )
    batch = regression.residual_std(np.vstack([shapes, np.full(shapes.shape[1], np.nan)]))
    assert np.all(np.isinf(batch[2]))
    for values, got in zip(shapes, batch, strict=False):
        whole = NormalEquations(len(PRIME_RUDDER.terms))
        whole.add(family_regressors(PRIME_RUDDER)(*samples, LENGTH_M, *values), acc)
        expected = whole.residual_std(equation_index)
        np.testing.assert_allclose(got, expected, rtol=1e-10)
        np.testing.assert_allclose(regression.residual_std(values[None, :])[0], got, rtol=1e-12)
