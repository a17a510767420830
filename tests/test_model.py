"""The model definition: structure, numeric evaluation, Jacobians, simulation, params.json."""

from __future__ import annotations

import json

import numpy as np
import pytest
import sympy as sp

from fmu_model import (
    ModelParameters,
    ModelStructure,
    ParamsFormatError,
    Term,
    get_model,
    load_params,
    model_names,
    n_substeps,
    numeric_model,
    save_params,
    simulate,
)
from fmu_model.structure import coefficient_unit, r, u, unit_string, v
from fmu_model.variants import SHI2009

RNG = np.random.default_rng(7)


def test_seed_structure_has_the_papers_16_coefficients() -> None:
    model = get_model("shi2009")
    assert model.coefficient_names == tuple(
        "a1 a2 a3 a4 a5 a6 a7 a8 a9 b1 b2 b3 b4 c1 c2 c3".split()
    )
    assert "shi2009" in model_names()


def test_coefficient_units_follow_from_the_regressors() -> None:
    units = {k: unit_string(d) for k, d in get_model("shi2009").coefficient_units().items()}
    # u' = a1 u^2 -> a1 [1/m]; a8 u n -> dimensionless; a9 n^2 -> m; v' = b3 delta -> m/s2;
    # r' = c1 v -> 1/(m.s); c3 delta -> 1/s2.
    assert units["a1"] == "1/m"
    assert units["a8"] == "1"
    assert units["a9"] == "m"
    assert units["b3"] == "m/s2"
    assert units["c1"] == "1/(m.s)"
    assert units["c3"] == "1/s2"


def test_inhomogeneous_regressor_is_rejected() -> None:
    with pytest.raises(ValueError, match="not dimensionally homogeneous"):
        coefficient_unit(u + r, "sway")


def test_structure_rejects_duplicate_names_and_unknown_symbols() -> None:
    with pytest.raises(ValueError, match="duplicate"):
        ModelStructure("bad", "", "", (Term("a", u),), (Term("a", v),), ())
    with pytest.raises(ValueError, match="unknown symbols"):
        ModelStructure("bad", "", "", (Term("a", sp.Symbol("w")),), (), ())


def test_straight_run_is_an_equilibrium(seed_params: ModelParameters) -> None:
    t = np.arange(0.0, 300.0, 1.0)
    states = simulate(seed_params, t, np.zeros_like(t), np.full_like(t, 2.0), [5, 0, 0, 0, 0, 0])
    assert np.allclose(states[:, 0], 5.0, atol=1e-12)
    assert np.allclose(states[:, 1:3], 0.0, atol=1e-15)
    assert np.allclose(states[:, 3], 5.0 * t, rtol=1e-12)
    assert np.allclose(states[:, 4:], 0.0, atol=1e-12)


def test_mirrored_rudder_gives_a_mirrored_trajectory(seed_params: ModelParameters) -> None:
    t = np.arange(0.0, 200.0, 0.5)
    rudder = np.radians(20.0) * np.sin(t / 15.0)
    n = np.full_like(t, 2.0)
    stbd = simulate(seed_params, t, rudder, n, [5, 0, 0, 0, 0, 0])
    port = simulate(seed_params, t, -rudder, n, [5, 0, 0, 0, 0, 0])
    mirror = np.array([1, -1, -1, 1, -1, -1])
    np.testing.assert_allclose(port, stbd * mirror, rtol=1e-12, atol=1e-9)
    assert np.max(np.abs(stbd[:, 5])) > np.radians(5.0)  # the test is not trivial


def test_positive_rudder_turns_to_starboard(seed_params: ModelParameters) -> None:
    t = np.arange(0.0, 60.0, 0.5)
    states = simulate(
        seed_params, t, np.full_like(t, 0.3), np.full_like(t, 2.0), [5, 0, 0, 0, 0, 0]
    )
    assert states[-1, 2] > 0.0 and states[-1, 5] > 0.0 and states[-1, 4] > 0.0


def test_rk4_is_fourth_order(seed_params: ModelParameters) -> None:
    def end_state(step: float) -> np.ndarray:
        t = np.arange(0.0, 60.0 + step / 2, step)
        rudder = np.full_like(t, 0.35)
        return simulate(seed_params, t, rudder, np.full_like(t, 2.0), [5, 0, 0, 0, 0, 0])[-1]

    reference = end_state(0.0625)
    errors = [np.linalg.norm(end_state(h) - reference) for h in (2.0, 1.0, 0.5)]
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all(orders > 3.8), orders
    assert np.all(orders < 4.3), orders


def test_euler_is_first_order_and_uses_averaged_inputs(seed_params: ModelParameters) -> None:
    t = np.array([0.0, 1.0])
    rudder = np.array([0.0, 0.2])
    states = simulate(seed_params, t, rudder, np.full(2, 2.0), [5, 0, 0, 0, 0, 0], method="euler")
    model = numeric_model(SHI2009)
    expected = np.array([5, 0, 0, 0, 0, 0]) + model.rhs(
        np.array([5.0, 0, 0, 0, 0, 0]), 0.1, 2.0, seed_params.to_vector(), 100.0
    )
    np.testing.assert_allclose(states[1], expected, rtol=1e-15)


def test_substeps_rule() -> None:
    assert n_substeps(0.3, 0.1) == 3
    assert n_substeps(0.31, 0.1) == 4
    assert n_substeps(0.05, 0.1) == 1
    assert n_substeps(1.0, None) == 1


def test_max_step_splits_each_interval(seed_params: ModelParameters) -> None:
    t = np.array([0.0, 2.0])
    one = simulate(
        seed_params, t, np.full(2, 0.3), np.full(2, 2.0), [5, 0, 0, 0, 0, 0], max_step_s=0.5
    )
    fine_t = np.arange(0.0, 2.01, 0.5)
    four = simulate(seed_params, fine_t, np.full(5, 0.3), np.full(5, 2.0), [5, 0, 0, 0, 0, 0])
    np.testing.assert_allclose(one[-1], four[-1], rtol=1e-14)


@pytest.mark.parametrize("point", range(5))
def test_analytic_jacobians_match_finite_differences(point: int) -> None:
    model = numeric_model(SHI2009)
    theta = RNG.normal(size=16)
    u0, v0, r0 = 3.0 + RNG.normal(), RNG.normal(), 0.05 * RNG.normal()
    rudder, n = 0.3 * RNG.normal(), 2.0 + RNG.normal()
    f, d_state, d_theta = model.linearise(theta, u0, v0, r0, rudder, n, 100.0)
    np.testing.assert_allclose(f, model.accelerations(theta, u0, v0, r0, rudder, n, 100.0))
    eps = 1e-6
    for j in range(3):
        dx = np.zeros(3)
        dx[j] = eps
        plus = model.accelerations(theta, *(np.array([u0, v0, r0]) + dx), rudder, n, 100.0)
        minus = model.accelerations(theta, *(np.array([u0, v0, r0]) - dx), rudder, n, 100.0)
        np.testing.assert_allclose(d_state[:, j], (plus - minus) / (2 * eps), rtol=1e-6, atol=1e-8)
    for i in range(16):
        dth = np.zeros(16)
        dth[i] = eps
        plus = model.accelerations(theta + dth, u0, v0, r0, rudder, n, 100.0)
        minus = model.accelerations(theta - dth, u0, v0, r0, rudder, n, 100.0)
        np.testing.assert_allclose(d_theta[:, i], (plus - minus) / (2 * eps), rtol=1e-6, atol=1e-8)


def test_rhs_broadcasts_over_a_batch(seed_params: ModelParameters) -> None:
    model = numeric_model(SHI2009)
    states = RNG.normal(size=(6, 4))
    batch = model.rhs(states, 0.1, 2.0, seed_params.to_vector(), 100.0)
    for k in range(4):
        np.testing.assert_array_equal(
            batch[:, k], model.rhs(states[:, k], 0.1, 2.0, seed_params.to_vector(), 100.0)
        )


def test_params_round_trip(tmp_path, seed_params: ModelParameters) -> None:
    cov = np.diag(np.arange(1.0, 17.0)) * 1e-6
    params = seed_params.with_vector(seed_params.to_vector(), cov)
    path = tmp_path / "params.json"
    save_params(path, params)
    back = load_params(path)
    np.testing.assert_array_equal(back.to_vector(), params.to_vector())
    np.testing.assert_array_equal(back.covariance, cov)
    assert back.length_m == 100.0 and back.nominal_n_rps == pytest.approx(2.0)
    doc = json.loads(path.read_text())
    assert doc["format"] == "ship-maneuvering-params" and doc["version"] == 1
    assert doc["std"]["a3"] == pytest.approx(np.sqrt(3e-6))
    assert doc["units"]["a1"] == "1/m"


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.update(version=2), "unsupported version 2"),
        (lambda d: d.update(format="other"), "not a params file"),
        (lambda d: d.update(model="nope"), "unknown model 'nope'"),
        (lambda d: d["coefficients"].pop("b2"), r"missing \['b2'\]"),
        (lambda d: d["coefficients"].update(zz=1.0), r"unexpected \['zz'\]"),
        (lambda d: d["coefficients"].update(a1="x"), "coefficient a1 must be a finite number"),
        (lambda d: d["vessel"].update(length_m=-1.0), "length_m must be positive"),
        (lambda d: d["covariance"][0].__setitem__(1, 1.0), "not symmetric"),
        (lambda d: d["covariance"].pop(), "covariance must be 16x16"),
    ],
)
def test_bad_params_are_rejected(tmp_path, seed_params: ModelParameters, edit, message) -> None:
    doc = seed_params.with_vector(seed_params.to_vector(), np.eye(16) * 1e-6).to_json_dict()
    edit(doc)
    path = tmp_path / "params.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ParamsFormatError, match=message) as info:
        load_params(path)
    assert "\n" not in str(info.value) and str(path) in str(info.value)


def test_nan_in_params_json_is_rejected(tmp_path, seed_params: ModelParameters) -> None:
    text = json.dumps(seed_params.to_json_dict()).replace('"a1": -0.004', '"a1": NaN')
    path = tmp_path / "params.json"
    path.write_text(text)
    with pytest.raises(ParamsFormatError, match="coefficient a1 must be a finite number"):
        load_params(path)


def test_invalid_json_names_the_line(tmp_path) -> None:
    path = tmp_path / "params.json"
    path.write_text('{\n "format": \n')
    with pytest.raises(ParamsFormatError, match=r"params.json:3: invalid JSON"):
        load_params(path)
