"""Current and wind: the environment functions, and the FMU with environment inputs.

* ``fmu_model.environment`` against hand computations: Blendermann's (1994) wind-load
  coefficients at 0, 90, 180 and 30 deg from starboard, the signs of the loads, the
  apparent wind of a ship heading North in an East wind, true wind back from apparent
  wind, the kinematics with current; the numpy and sympy forms of the formulas agree;
* ``Windage`` and ``vessel.windage`` in params.json;
* the FMU (native FMI 2.0 and 3.0, pythonfmu) with zero environment computes bit for bit
  what the model alone computes; with current and wind it equals ``fmu_model.simulate``
  to 1e-12, also with a time-varying current fed by fmpy and by another FMU connected
  in libcosim; its directional derivatives by the new inputs and of sog and cog equal
  finite differences; a negative speed or a non-finite environment input is an error
  that changes nothing.
"""

from __future__ import annotations

import ctypes
import json
import math
import sys
from collections.abc import Iterator
from ctypes import c_double, c_uint
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import sympy as sp
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

import fmu_model.export_native as export_native
from fmu_model import (
    ModelParameters,
    ParamsFormatError,
    numeric_model,
    params_from_json_dict,
    simulate,
)
from fmu_model.codegen import ENVIRONMENT_SIGNATURE, generate_model_c
from fmu_model.environment import (
    AIR_DENSITY_KGPM3,
    TANKER_LOADED,
    Windage,
    WindageSymbols,
    apparent_wind,
    blendermann_coefficients,
    course_over_ground,
    current_velocity_ne,
    environment_accelerations,
    ground_velocity_body,
    ground_velocity_ne,
    speed_over_ground,
    true_wind,
    wind_accelerations,
    wind_loads,
)
from fmu_model.export_native import build_native_fmu
from fmu_model.export_pythonfmu import build_pythonfmu_fmu
from fmu_model.interface import ENVIRONMENT_NAMES, GROUND_NAMES, WINDAGE_NAMES, fmu_variables
from fmu_model.pythonfmu_slave import ENVIRONMENT_NAMES as SLAVE_ENVIRONMENT_NAMES
from fmu_model.pythonfmu_slave import GROUND_NAMES as SLAVE_GROUND_NAMES
from fmu_model.pythonfmu_slave import WINDAGE_NAMES as SLAVE_WINDAGE_NAMES
from fmu_model.simulate import rk4_step
from fmu_model.structure import apparent_wind_terms, wind_ahead, wind_starboard, wind_terms
from tests.fmi_logging import LogRecorder
from tests.test_fmu_kinds import model_exchange_instance
from tests.test_fmu_native import make_params

STATES = ("u", "v", "r", "x", "y", "psi")
FMI_OK, FMI_DISCARD, FMI_ERROR = 0, 2, 3
MAX_STEP_S = 0.05
# A windage for the 100 m test ship of make_params (about 12 000 t): a tanker-like
# superstructure, centroid 5 m forward of midship.
WINDAGE = Windage(
    frontal_area_m2=300.0,
    lateral_area_m2=1200.0,
    length_overall_m=105.0,
    lateral_centroid_m=5.0,
    surge_mass_kg=1.3e7,
    sway_mass_kg=2.0e7,
    yaw_inertia_kgm2=1.0e10,
    sway_yaw_coupling_kgm=1.0e8,  # centre of gravity 8 m forward of midship
)
# Current 1 m/s setting towards 60 deg, wind 20 m/s from 120 deg.
ENVIRONMENT = {
    "current_speed": 1.0,
    "current_direction": math.radians(60.0),
    "wind_speed": 20.0,
    "wind_direction": math.radians(120.0),
}
RUDDER_RAD = 0.3


# --- the formulas against hand computations ------------------------------------------

# Windage of the hand computations: A_F = 1000 m2, A_L = 5000 m2, L_oa = 320 m, s_L = 10 m.
HAND = Windage(1000.0, 5000.0, 320.0, 10.0, 3.0e8, 4.0e8, 2.0e12)
# Tanker, loaded (Blendermann 1994; MSS blendermann94.m): C_Dt = 0.70, C_Dl,AF(0) = 0.90,
# C_Dl,AF(pi) = 0.55, delta = 0.40.
# At 30 deg: C_Dl = 0.90 A_F / A_L = 0.18, sin^2(2 gamma) = 0.75.
DEN_30 = 1.0 - 0.5 * 0.40 * (1.0 - 0.18 / 0.70) * 0.75
HAND_COEFFICIENTS = {
    # gamma [deg]: (C_X, C_Y, C_N)
    0.0: (-0.90, 0.0, 0.0),  # head wind: drag aft, no side force
    90.0: (0.0, -0.70, (10.0 / 320.0) * -0.70),  # beam wind from starboard: pushed to port
    180.0: (0.55, 0.0, 0.0),  # wind from astern: pushed ahead
    30.0: (
        -0.90 * math.cos(math.radians(30.0)) / DEN_30,
        -0.70 * 0.5 / DEN_30,
        (10.0 / 320.0 - 0.18 * (math.radians(30.0) - math.pi / 2.0)) * (-0.70 * 0.5 / DEN_30),
    ),
}


@pytest.mark.parametrize("angle_deg", list(HAND_COEFFICIENTS))
def test_blendermann_coefficients_equal_the_formula_by_hand(angle_deg: float) -> None:
    got = blendermann_coefficients(math.radians(angle_deg), HAND)
    np.testing.assert_allclose(got, HAND_COEFFICIENTS[angle_deg], rtol=1e-14, atol=1e-15)
    assert TANKER_LOADED.cd_t == 0.70 and TANKER_LOADED.delta == 0.40
    # 30 deg: C_Dl = 0.18, den = 1 - 0.2 * (1 - 0.18 / 0.7) * 0.75 = 0.888571...
    assert DEN_30 == pytest.approx(0.8885714285714286, rel=1e-15)


def test_wind_loads_have_the_signs_of_the_conventions() -> None:
    def loads(angle_deg: float) -> np.ndarray:
        return np.array(wind_loads(15.0, math.radians(angle_deg), HAND))

    ahead, astern = loads(0.0), loads(180.0)
    assert ahead[0] < 0.0 < astern[0]  # a head wind brakes, a following wind pushes
    starboard, port = loads(90.0), loads(-90.0)
    assert starboard[1] < 0.0 < port[1]  # wind from starboard pushes to port
    # Centroid forward of midship: a beam wind from starboard turns the bow to port.
    assert starboard[2] < 0.0 < port[2]
    # On the bow the wind pushes the bow away (N < 0 from starboard), on the quarter the
    # stern (the bow turns into the wind, N > 0 from starboard).
    assert loads(30.0)[2] < 0.0 < loads(150.0)[2]
    # Port-starboard symmetry: X even, Y and N odd in gamma.
    for angle in (10.0, 45.0, 100.0, 170.0):
        np.testing.assert_allclose(loads(-angle), loads(angle) * [1.0, -1.0, -1.0], rtol=1e-14)
    # X = 1/2 rho V^2 A_F C_X ... and the accelerations divide by the inertias.
    q = 0.5 * AIR_DENSITY_KGPM3 * 15.0**2
    cx, cy, cn = blendermann_coefficients(math.radians(30.0), HAND)
    np.testing.assert_allclose(
        loads(30.0), [q * 1000.0 * cx, q * 5000.0 * cy, q * 5000.0 * 320.0 * cn], rtol=1e-15
    )
    np.testing.assert_allclose(
        wind_accelerations(15.0, math.radians(30.0), HAND),
        loads(30.0) / [3.0e8, 4.0e8, 2.0e12],
        rtol=1e-15,
    )


def test_no_windage_and_no_apparent_wind_give_no_load() -> None:
    assert np.all(np.array(wind_loads(20.0, 0.7, Windage.none(100.0))) == 0.0)
    assert np.all(np.array(wind_loads(0.0, 0.0, HAND)) == 0.0)
    calm = environment_accelerations(0.0, 0.0, 0.3, 0.0, 0.0, 0.0, 0.0, HAND)
    assert np.all(np.array(calm) == 0.0)  # ship at rest in calm air: 0, not nan


def test_apparent_wind_of_a_ship_heading_north_in_an_east_wind() -> None:
    # 5 m/s North, wind 10 m/s from East: 11.18 m/s from 63.4 deg to starboard.
    speed, angle = apparent_wind(10.0, math.radians(90.0), 0.0, 5.0, 0.0)
    assert speed == pytest.approx(math.sqrt(125.0), rel=1e-15)
    assert math.degrees(angle) == pytest.approx(63.43494882292201, rel=1e-14)
    # Heading East in a wind from North: the same wind from port.
    speed, angle = apparent_wind(10.0, 0.0, math.radians(90.0), 5.0, 0.0)
    assert (speed, math.degrees(angle)) == pytest.approx((math.sqrt(125.0), -63.434948822922))
    # Stopped in the water, carried North by a 1 m/s current, no wind: the anemometer
    # sees 1 m/s from ahead.
    u_g, v_g = ground_velocity_body(0.0, 0.0, 0.0, *current_velocity_ne(1.0, 0.0))
    assert apparent_wind(0.0, 0.0, 0.0, u_g, v_g) == pytest.approx((1.0, 0.0))


def test_true_wind_inverts_apparent_wind() -> None:
    rng = np.random.default_rng(3)
    speed = rng.uniform(0.5, 30.0, 50)
    direction = rng.uniform(0.0, 2.0 * np.pi, 50)
    psi = rng.uniform(-10.0, 10.0, 50)
    u_g, v_g = rng.uniform(-2.0, 8.0, 50), rng.uniform(-1.0, 1.0, 50)
    apparent = apparent_wind(speed, direction, psi, u_g, v_g)
    back_speed, back_direction = true_wind(*apparent, psi, u_g, v_g)
    np.testing.assert_allclose(back_speed, speed, rtol=1e-12)
    np.testing.assert_allclose(np.cos(back_direction - direction), 1.0, rtol=1e-12)
    assert np.all((back_direction >= 0.0) & (back_direction < 2.0 * np.pi))


def test_current_and_ground_velocity() -> None:
    north, east = current_velocity_ne(1.0, math.radians(90.0))  # setting East
    assert (north, east) == pytest.approx((0.0, 1.0), abs=1e-16)
    # Heading East at 5 m/s through the water, in a current setting North at 1 m/s.
    x_dot, y_dot = ground_velocity_ne(5.0, 0.0, math.radians(90.0), 1.0, 0.0)
    assert (x_dot, y_dot) == pytest.approx((1.0, 5.0))
    assert speed_over_ground(x_dot, y_dot) == pytest.approx(math.sqrt(26.0))
    assert course_over_ground(x_dot, y_dot) == pytest.approx(math.atan2(5.0, 1.0))
    # The same velocity, seen aboard: 5 m/s ahead, 1 m/s to port.
    assert ground_velocity_body(5.0, 0.0, math.radians(90.0), 1.0, 0.0) == pytest.approx((5, -1))
    # Without current the kinematics are those of the model, bit for bit.
    u, v, psi = 4.3, -0.7, 2.1
    assert ground_velocity_ne(u, v, psi, 0.0, 0.0) == (
        u * math.cos(psi) - v * math.sin(psi),
        u * math.sin(psi) + v * math.cos(psi),
    )


def test_numpy_and_sympy_forms_of_the_formulas_agree() -> None:
    """One definition: the sympy expressions (C and pythonfmu code) evaluate as numpy."""
    rng = np.random.default_rng(11)
    n = 200
    u, v, psi = rng.uniform(-2, 8, n), rng.uniform(-2, 2, n), rng.uniform(-7, 7, n)
    cs, cd = rng.uniform(0, 2, n), rng.uniform(-7, 7, n)
    ws, wd = rng.uniform(0, 30, n), rng.uniform(-7, 7, n)
    want = environment_accelerations(u, v, psi, *current_velocity_ne(cs, cd), ws, wd, HAND)

    symbols = WindageSymbols.make()
    args = sp.symbols("u v psi cn ce ws wd", real=True)
    exprs = environment_accelerations(*args, symbols, xp=sp)
    lambdified = sp.lambdify((*args, *symbols.as_tuple()), exprs, modules="numpy")
    with np.errstate(invalid="ignore", divide="ignore"):  # numpy evaluates both branches
        got = lambdified(u, v, psi, *current_velocity_ne(cs, cd), ws, wd, *HAND.to_dict().values())
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-20)

    # The structure's split: wind_terms(a, b) after apparent_wind_terms(state, env).
    from fmu_model import structure as s

    names = (s.u, s.v, s.psi, s.current_speed, s.current_direction, s.wind_speed, s.wind_direction)
    ab = sp.lambdify(names, apparent_wind_terms(), modules="numpy")(u, v, psi, cs, cd, ws, wd)
    split = sp.lambdify(
        (wind_ahead, wind_starboard, *s.WINDAGE_SYMBOLS.as_tuple()), wind_terms(), "numpy"
    )(*ab, *HAND.to_dict().values())
    np.testing.assert_allclose(split, want, rtol=1e-12, atol=1e-20)


# --- Windage and params.json ------------------------------------------------------------


@pytest.mark.parametrize(
    ("changes", "message"),
    [
        ({"frontal_area_m2": -1.0}, "frontal_area_m2 must be >= 0"),
        ({"lateral_area_m2": math.nan}, "lateral_area_m2 must be finite"),
        ({"surge_mass_kg": 0.0}, "surge_mass_kg must be > 0"),
        ({"yaw_inertia_kgm2": 10**400}, "yaw_inertia_kgm2 must be finite"),
        ({"length_overall_m": True}, "length_overall_m must be a number"),
        ({"lateral_area_m2": 0.0}, "lateral_area_m2 must be > 0 when frontal_area_m2 is"),
        ({"sway_yaw_coupling_kgm": -5.0e8}, r"sway_yaw_coupling_kgm must be below"),
    ],
)
def test_windage_refuses_bad_values(changes: dict[str, Any], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Windage(**{**WINDAGE.to_dict(), **changes})


def test_wind_accelerations_solve_the_sway_yaw_mass_matrix() -> None:
    """M·(v̇, ṙ) = (Y, N) with M = [[m + m_y, x_G m], [x_G m, I_z + J_z]] (Y&Y2015 eq. (4))."""
    angle = math.radians(70.0)
    x_n, y_n, n_nm = wind_loads(15.0, angle, WINDAGE)
    du, dv, dr = wind_accelerations(15.0, angle, WINDAGE)
    assert du == pytest.approx(x_n / 1.3e7, rel=1e-15)
    assert 2.0e7 * dv + 1.0e8 * dr == pytest.approx(y_n, rel=1e-12)
    assert 1.0e8 * dv + 1.0e10 * dr == pytest.approx(n_nm, rel=1e-12)
    # Cramer's rule by hand, and the coupling's share: at 70° off the bow it moves the yaw
    # acceleration by 40 % of N/(I_z + J_z) here
    det = 2.0e7 * 1.0e10 - 1.0e8**2
    assert (dv, dr) == pytest.approx(
        ((1.0e10 * y_n - 1.0e8 * n_nm) / det, (2.0e7 * n_nm - 1.0e8 * y_n) / det), rel=1e-12
    )
    _, dv0, dr0 = wind_accelerations(15.0, angle, replace(WINDAGE, sway_yaw_coupling_kgm=0.0))
    assert (dv0, dr0) == (y_n / 2.0e7, n_nm / 1.0e10)
    assert abs(dr - dr0) > 0.1 * abs(dr0)


def test_windage_round_trips_through_params_json() -> None:
    assert Windage.from_dict(WINDAGE.to_dict()) == WINDAGE
    # a windage written before the coupling (its key absent): a centre of gravity at midship
    older = {k: v for k, v in WINDAGE.to_dict().items() if k != "sway_yaw_coupling_kgm"}
    assert Windage.from_dict(older) == replace(WINDAGE, sway_yaw_coupling_kgm=0.0)
    params = make_params(windage=WINDAGE)
    doc = json.loads(json.dumps(params.to_json_dict()))
    assert doc["vessel"]["windage"]["frontal_area_m2"] == 300.0
    assert doc["version"] == 1
    assert params_from_json_dict(doc).windage == WINDAGE
    del doc["vessel"]["windage"]  # optional: absent means no wind load
    assert params_from_json_dict(doc).windage is None
    assert "windage" not in make_params().to_json_dict()["vessel"]
    doc["vessel"]["windage"] = {**WINDAGE.to_dict(), "draught_m": 10.0}
    with pytest.raises(ParamsFormatError, match=r"vessel\.windage has unknown keys draught_m"):
        params_from_json_dict(doc, "p.json")
    doc["vessel"]["windage"] = {**WINDAGE.to_dict(), "sway_mass_kg": -1.0}
    with pytest.raises(ParamsFormatError, match=r"p\.json: vessel\.windage sway_mass_kg"):
        params_from_json_dict(doc, "p.json")


# --- the FMU -------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def params() -> ModelParameters:
    return make_params(windage=WINDAGE)


@pytest.fixture(scope="module")
def fmus(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> dict[str, Path]:
    """The FMUs of ``params``: native FMI 2.0 and 3.0 (CS + ME), pythonfmu; by name."""
    folder = tmp_path_factory.mktemp("environment")
    return {
        "native2": build_native_fmu(params, folder / "fmi2" / "Test_Ship.fmu"),
        "native3": build_native_fmu(params, folder / "fmi3" / "Test_Ship.fmu", fmi_version="3"),
        "pythonfmu": build_pythonfmu_fmu(
            params, folder / "pythonfmu" / "Test_Ship.fmu", max_step_s=MAX_STEP_S
        ),
    }


def _reference(params: ModelParameters, t: np.ndarray, **environment: Any) -> np.ndarray:
    """The Python model's run (RK4, max step 0.05 s), rudder 0.3 rad: (N, 6)."""
    names = {
        "current_speed": "current_speed_mps",
        "current_direction": "current_direction_rad",
        "wind_speed": "wind_speed_mps",
        "wind_direction": "wind_direction_rad",
    }
    return simulate(
        params,
        t,
        np.full(t.size, RUDDER_RAD),
        np.full(t.size, params.nominal_n_rps),
        [params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0],
        max_step_s=MAX_STEP_S,
        **{names[k]: v for k, v in environment.items()},
    )


def _assert_equal_to_1e12(got: np.ndarray, want: np.ndarray) -> None:
    """Each column to 1e-12 of its own largest value (at least 1)."""
    scale = np.maximum(np.max(np.abs(want), axis=0), 1.0)
    excess = np.abs(got - want) / (1e-12 * scale)
    assert np.all(excess <= 1.0), f"error up to {np.max(excess):.3g} x 1e-12"


def _ground(states: np.ndarray, current_speed: Any, current_direction: Any) -> np.ndarray:
    """Speed and course over ground of the states (N, 6) in the current: (N, 2)."""
    current = current_velocity_ne(current_speed, current_direction)
    north, east = ground_velocity_ne(states[:, 0], states[:, 1], states[:, 5], *current)
    return np.column_stack([speed_over_ground(north, east), course_over_ground(north, east)])


def test_interface_lists_the_environment_in_both_backends(
    params: ModelParameters, fmus: dict[str, Path]
) -> None:
    variables = {v.name: v for v in fmu_variables(params)}
    names = list(variables)
    assert names.index("time") + 1 == names.index("current_speed")  # appended: old VRs stay
    assert names[-14:] == [*ENVIRONMENT_NAMES, *GROUND_NAMES, *WINDAGE_NAMES]
    assert (SLAVE_ENVIRONMENT_NAMES, SLAVE_GROUND_NAMES, SLAVE_WINDAGE_NAMES) == (
        ENVIRONMENT_NAMES,
        GROUND_NAMES,
        WINDAGE_NAMES,
    )
    assert [variables[n].start for n in WINDAGE_NAMES] == list(WINDAGE.to_dict().values())
    bare = {v.name: v for v in fmu_variables(make_params())}
    assert [bare[n].start for n in WINDAGE_NAMES] == [0.0, 0.0, 100.0, 0.0, 1.0, 1.0, 1.0, 0.0]
    for key in fmus:
        md = read_model_description(str(fmus[key]))
        declared = {v.name: v for v in md.modelVariables}
        speed, direction = declared["current_speed"], declared["current_direction"]
        assert (speed.causality, speed.unit, float(speed.min), speed.start) == (
            "input",
            "m/s",
            0.0,
            "0.0",
        )
        assert (direction.unit, direction.displayUnit) == ("rad", "deg")
        assert float(declared["wind_speed"].min) == 0.0
        assert (declared["cog"].causality, declared["cog"].unit) == ("output", "rad")
        assert (declared["yaw_inertia"].unit, declared["lateral_area"].unit) == ("kg.m2", "m2")
        assert declared["sway_yaw_coupling"].unit == "kg.m"
        assert "Blendermann (1994)" in md.description
    assert "no windage" not in read_model_description(str(fmus["native2"])).description


def _without_environment(text: str) -> str:
    """The generated C with an empty model_environment: the model alone."""
    start = text.index("{", text.index(ENVIRONMENT_SIGNATURE))
    end = text.index("\n}\n", start)
    return text[:start] + "{\n    (void)x; (void)env; (void)windage; (void)dx;" + text[end:]


@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_zero_environment_is_bit_identical_to_the_model_alone(
    fmi_type: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    params = make_params()  # no windage: zero areas
    with_environment = build_native_fmu(params, tmp_path / "a" / "Test_Ship.fmu")
    monkeypatch.setattr(
        export_native, "generate_model_c", lambda s: _without_environment(generate_model_c(s))
    )
    alone = build_native_fmu(params, tmp_path / "b" / "Test_Ship.fmu")
    options = {
        "fmi_type": fmi_type,
        "stop_time": 400.0,
        "output_interval": 0.37,
        "start_values": {"rudder_angle": RUDDER_RAD, "v0": 0.2, "psi0": 1.0},
        "output": list(STATES),
    }
    got, want = simulate_fmu(str(with_environment), **options), simulate_fmu(str(alone), **options)
    for name in STATES:
        np.testing.assert_array_equal(got[name], want[name])
    assert got["psi"][-1] - got["psi"][0] > np.pi  # it turned

    # The Python model: a zero environment and no windage add exact zeros.
    state = np.array([5.0, 0.2, 0.01, 10.0, -3.0, 1.0])
    model = numeric_model(params.structure)
    plain = rk4_step(model, params.to_vector(), 100.0, state, 0.2, 2.0, 0.1)
    zero = (0.0, 0.0, 0.0, 0.0)
    theta = params.to_vector()
    calm = rk4_step(model, theta, 100.0, state, 0.2, 2.0, 0.1, environment=zero, windage=None)
    no_area = rk4_step(
        model, theta, 100.0, state, 0.2, 2.0, 0.1, environment=zero, windage=Windage.none(100.0)
    )
    np.testing.assert_array_equal(plain, no_area)
    np.testing.assert_array_equal(plain, calm)


@pytest.mark.parametrize("key", ["native2", "native3", "pythonfmu"])
def test_fmu_in_current_and_wind_equals_the_python_model(
    key: str, params: ModelParameters, fmus: dict[str, Path]
) -> None:
    stop = 60.0 if key == "pythonfmu" else 300.0
    result = simulate_fmu(
        str(fmus[key]),
        stop_time=stop,
        output_interval=0.1,
        start_values={"rudder_angle": RUDDER_RAD, **ENVIRONMENT},
        output=[*STATES, *GROUND_NAMES],
    )
    got = np.column_stack([result[name] for name in STATES])
    want = _reference(params, result["time"], **ENVIRONMENT)
    _assert_equal_to_1e12(got, want)
    ground = np.column_stack([result[name] for name in GROUND_NAMES])
    _assert_equal_to_1e12(
        ground, _ground(want, ENVIRONMENT["current_speed"], ENVIRONMENT["current_direction"])
    )
    # The environment mattered: without it the ship is elsewhere.
    calm = _reference(replace(params, windage=None), result["time"])
    assert np.max(np.abs(calm[:, 3:5] - want[:, 3:5])) > 30.0


def _varying(t: np.ndarray) -> dict[str, np.ndarray]:
    """A tidal current veering and strengthening, a gusting wind backing."""
    return {
        "current_speed": 0.6 + 0.4 * np.sin(2.0 * np.pi * t / 150.0),
        "current_direction": np.radians(30.0 + 0.5 * t),
        "wind_speed": 15.0 + 5.0 * np.sin(2.0 * np.pi * t / 37.0),
        "wind_direction": np.radians(200.0 - 0.2 * t),
    }


@pytest.mark.parametrize("key", ["native2", "pythonfmu"])
def test_time_varying_environment_fed_by_fmpy_equals_the_python_model(
    key: str, params: ModelParameters, fmus: dict[str, Path]
) -> None:
    stop = 60.0 if key == "pythonfmu" else 300.0
    samples = np.arange(0.0, stop + 1e-9, 0.1)
    signals = np.array(
        list(zip(samples, *_varying(samples).values(), strict=True)),
        dtype=[("time", float)] + [(name, float) for name in ENVIRONMENT_NAMES],
    )
    result = simulate_fmu(
        str(fmus[key]),
        stop_time=stop,
        output_interval=0.1,
        start_values={"rudder_angle": RUDDER_RAD},
        input=signals,
        output=[*STATES, *GROUND_NAMES],
    )
    # fmpy sets the inputs at each communication point t (its sum of steps, which may
    # differ from the samples by rounding): held over the step, as here.
    t = result["time"]
    np.testing.assert_allclose(t, samples, rtol=1e-13)
    series = _varying(t)
    want = _reference(params, t, **series)
    _assert_equal_to_1e12(np.column_stack([result[name] for name in STATES]), want)
    # fmpy reads the outputs after a step, before it sets the next inputs: sog and cog
    # at t_k+1 are those of the current of the step just taken, that of t_k.
    held = {name: np.concatenate([series[name][:1], series[name][:-1]]) for name in series}
    ground = np.column_stack([result[name] for name in GROUND_NAMES])
    _assert_equal_to_1e12(ground, _ground(want, held["current_speed"], held["current_direction"]))


_CURRENT_SOURCE = '''
import math

from pythonfmu import Fmi2Causality, Fmi2Slave, Real


def current(t):
    """Tidal current at t [s]: speed [m/s], direction it sets towards [rad]."""
    return 0.6 + 0.4 * math.sin(2.0 * math.pi * t / 150.0), math.radians(30.0 + 0.5 * t)


class CurrentSource(Fmi2Slave):
    """Outputs the current at the end of each step."""

    def __init__(self, **kwargs):
        super().__init__(**kwargs)
        self.speed, self.direction = current(0.0)
        self.register_variable(Real("speed", causality=Fmi2Causality.output))
        self.register_variable(Real("direction", causality=Fmi2Causality.output))

    def do_step(self, current_time, step_size):
        self.speed, self.direction = current(current_time + step_size)
        return True
'''


@pytest.fixture(scope="module")
def current_source_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A pythonfmu FMU whose outputs are a time-varying current."""
    from pythonfmu.builder import FmuBuilder

    folder = tmp_path_factory.mktemp("source")
    script = folder / "current_source_slave.py"
    script.write_text(_CURRENT_SOURCE, encoding="utf-8")
    saved = list(sys.path)
    try:
        built = FmuBuilder.build_FMU(script, dest=folder / "source.fmu")
    finally:
        sys.path[:] = saved
        sys.modules.pop(script.stem, None)
    return Path(built)


def test_current_from_another_fmu_in_libcosim_equals_the_python_model(
    params: ModelParameters, fmus: dict[str, Path], current_source_fmu: Path, tmp_path: Path
) -> None:
    from libcosimpy.CosimExecution import CosimExecution
    from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
    from libcosimpy.CosimObserver import CosimObserver

    log_output_level(CosimLogLevel.WARNING)
    (tmp_path / "ship.fmu").write_bytes(fmus["native2"].read_bytes())
    (tmp_path / "source.fmu").write_bytes(current_source_fmu.read_bytes())
    namespace = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
    (tmp_path / "OspSystemStructure.xml").write_text(
        '<?xml version="1.0" encoding="UTF-8"?>\n'
        f'<OspSystemStructure xmlns="{namespace}" version="0.1">\n'
        "  <BaseStepSize>0.1</BaseStepSize><Algorithm>fixedStep</Algorithm>\n"
        "  <Simulators>\n"
        '    <Simulator name="ship" source="ship.fmu"><InitialValues>\n'
        f'      <InitialValue variable="rudder_angle"><Real value="{RUDDER_RAD}"/>'
        "</InitialValue>\n"
        "    </InitialValues></Simulator>\n"
        '    <Simulator name="source" source="source.fmu"/>\n'
        "  </Simulators>\n"
        "  <Connections>\n"
        '    <VariableConnection><Variable simulator="source" name="speed"/>'
        '<Variable simulator="ship" name="current_speed"/></VariableConnection>\n'
        '    <VariableConnection><Variable simulator="source" name="direction"/>'
        '<Variable simulator="ship" name="current_direction"/></VariableConnection>\n'
        "  </Connections>\n"
        "</OspSystemStructure>\n",
        encoding="utf-8",
    )
    execution = CosimExecution.from_osp_config_file(str(tmp_path / "OspSystemStructure.xml"))
    ship = execution.slave_index_from_instance_name("ship")
    source = execution.slave_index_from_instance_name("source")
    vr = {v.name.decode(): v.reference for v in execution.slave_variables(ship)}
    source_vr = {v.name.decode(): v.reference for v in execution.slave_variables(source)}
    observer = CosimObserver.create_last_value()
    assert execution.add_observer(observer)
    n = 1500
    states = np.empty((n + 1, 6))
    current = np.empty((n + 1, 2))
    states[0] = [params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0]
    current[0] = [0.6, math.radians(30.0)]  # the source's output at t = 0
    for k in range(1, n + 1):
        assert execution.step(1)
        states[k] = observer.last_real_values(ship, [vr[name] for name in STATES])
        current[k] = observer.last_real_values(source, [source_vr["speed"], source_vr["direction"]])
    seen = observer.last_real_values(ship, [vr["current_speed"], vr["current_direction"]])
    # libcosim passes the source's output at t_k to the ship for the step from t_k.
    np.testing.assert_array_equal(seen, current[n - 1])
    t = np.arange(n + 1) * 100_000_000 / 1e9  # libcosim's clock: integer nanoseconds
    want = _reference(params, t, current_speed=current[:, 0], current_direction=current[:, 1])
    _assert_equal_to_1e12(states, want)
    assert np.ptp(current[:, 1]) > math.radians(70.0)  # the current did veer


@pytest.mark.parametrize("version", ["2", "3"])
def test_directional_derivatives_by_the_environment_equal_finite_differences(
    params: ModelParameters, fmus: dict[str, Path], version: str, tmp_path: Path
) -> None:
    vr = {v.name: v.value_reference for v in fmu_variables(params)}
    states = [vr[n] for n in STATES]
    inputs = [vr[n] for n in ("rudder_angle", "propeller_rpm", *ENVIRONMENT_NAMES)]
    derivatives = [vr[f"der({n})"] for n in STATES]
    ground = [vr[n] for n in GROUND_NAMES]
    unknowns, knowns = derivatives + states + ground, states + inputs
    model = model_exchange_instance(fmus[f"native{version}"], version, tmp_path)
    set_inputs = model.setReal if version == "2" else model.setFloat64
    get = model.getReal if version == "2" else model.getFloat64
    point = [4.0, 0.4, -0.02, 100.0, -50.0, 0.7]
    base = [*point, 0.3, 100.0, *ENVIRONMENT.values()]

    def at(x: list[float]) -> None:
        model.setContinuousStates((ctypes.c_double * 6)(*x[:6]), 6)
        set_inputs(inputs, x[6:])

    try:
        at(base)
        jacobian = np.column_stack(
            [
                model.getDirectionalDerivative(unknowns, knowns, list(np.eye(len(knowns))[j]))
                for j in range(len(knowns))
            ]
        )
        finite = np.empty_like(jacobian)
        for j in range(len(knowns)):
            h = 1e-6 * max(1.0, abs(base[j]))
            columns = []
            for sign in (1.0, -1.0):
                x = list(base)
                x[j] += sign * h
                at(x)
                columns.append(np.concatenate([get(derivatives), x[:6], get(ground)]))
            finite[:, j] = (columns[0] - columns[1]) / (2.0 * h)
        np.testing.assert_allclose(jacobian, finite, rtol=1e-6, atol=1e-9)
        environment = jacobian[:, 8:]
        assert np.all(environment[:3] != 0.0)  # the wind on u', v', r'
        assert np.all(environment[3:5, :2] != 0.0) and np.all(environment[3:5, 2:] == 0.0)
        assert np.all(environment[12:, :2] != 0.0)  # sog and cog: the current, directly
        assert np.all(jacobian[12:, 6:8] == 0.0)  # ... not the rudder or propeller
    finally:
        model.terminate()
        model.freeInstance()


# --- bad input -----------------------------------------------------------------------------

BAD_INPUTS = [
    ("current_speed", -0.1),
    ("wind_speed", -1.0),
    ("current_direction", math.nan),
    ("wind_direction", math.inf),
    ("wind_speed", math.nan),
]


def _slave(fmu: Path, version: str, logger: LogRecorder | None = None) -> Any:
    unzipped = extract(str(fmu))
    md = read_model_description(unzipped)
    if version == "2":
        slave: Any = FMU2Slave(
            guid=md.guid,
            unzipDirectory=unzipped,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="ship",
        )
        slave.instantiate(callbacks=logger.callbacks if logger else None, loggingOn=True)
        slave.setupExperiment(startTime=0.0)
    else:
        slave = FMU3Slave(
            guid=md.instantiationToken,
            unzipDirectory=unzipped,
            modelIdentifier=md.coSimulation.modelIdentifier,
            instanceName="ship",
        )
        slave.instantiate()
        slave.enterInitializationMode(startTime=0.0)
        slave.exitInitializationMode()
        return slave
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    return slave


@pytest.fixture
def slave_of(fmus: dict[str, Path]) -> Iterator[Any]:
    made: list[Any] = []

    def make(key: str, logger: LogRecorder | None = None) -> Any:
        made.append(_slave(fmus[key], "3" if key == "native3" else "2", logger))
        return made[-1]

    yield make
    for slave in made:
        slave.terminate()
        slave.freeInstance()


def _code(call: Any, *args: Any) -> int:
    """Status of a low-level fmpy call (fmpy raises for an error or a discard)."""
    try:
        return int(call(*args))
    except FMICallException as exc:
        return int(exc.status)


@pytest.mark.parametrize(("name", "value"), BAD_INPUTS)
@pytest.mark.parametrize("key", ["native2", "native3"])
def test_a_bad_environment_input_is_an_error_and_changes_nothing(
    slave_of: Any, params: ModelParameters, key: str, name: str, value: float
) -> None:
    vr = {v.name: v.value_reference for v in fmu_variables(params)}
    good, control = slave_of(key), slave_of(key)
    fmi2 = key == "native2"
    names = list(ENVIRONMENT)
    refs = [vr[n] for n in names]
    for fmu in (good, control):
        (fmu.setReal if fmi2 else fmu.setFloat64)(refs, list(ENVIRONMENT.values()))
    bad = [value if n == name else ENVIRONMENT[n] * 2.0 for n in names]  # all or nothing
    vrs, values = (c_uint * 4)(*refs), (c_double * 4)(*bad)
    if fmi2:
        code = _code(good.fmi2SetReal, good.component, vrs, 4, values)
    else:
        code = _code(good.fmi3SetFloat64, good.component, vrs, 4, values, 4)
    assert code == FMI_ERROR
    outputs = [vr[n] for n in (*STATES, *GROUND_NAMES, *ENVIRONMENT_NAMES)]
    for fmu in (good, control):
        fmu.doStep(0.0, 10.0)
    get = (lambda f: f.getReal(outputs)) if fmi2 else (lambda f: f.getFloat64(outputs))
    np.testing.assert_array_equal(get(good), get(control))


@pytest.mark.parametrize(("name", "value"), BAD_INPUTS[:3])
def test_pythonfmu_refuses_a_bad_environment_input_with_the_native_rule(
    slave_of: Any, params: ModelParameters, name: str, value: float
) -> None:
    log = LogRecorder()
    vr = {v.name: v.value_reference for v in fmu_variables(params)}
    fmu = slave_of("pythonfmu", log)
    before = fmu.getReal([vr[n] for n in STATES])
    fmu.setReal([vr[name]], [value])
    assert [status for status, _, _ in log.messages] == [FMI_ERROR]
    assert name in log.messages[0][2]
    code = _code(fmu.fmi2DoStep, fmu.component, 0.0, 1.0, 1)
    assert code == FMI_DISCARD  # refused until corrected, the state unchanged
    assert fmu.getReal([vr[n] for n in STATES]) == before
    fmu.setReal([vr[name]], [0.5])
    fmu.doStep(0.0, 1.0)
    assert fmu.getReal([vr["x"]])[0] > 4.0


def test_windage_set_before_initialisation_is_used(fmus: dict[str, Path], tmp_path: Path) -> None:
    bare = build_native_fmu(make_params(), tmp_path / "Test_Ship.fmu")  # no windage
    assert "no windage" in read_model_description(str(bare)).description
    start = dict(zip(WINDAGE_NAMES, WINDAGE.to_dict().values(), strict=True))
    options = {
        "stop_time": 200.0,
        "output_interval": 0.1,
        "output": list(STATES),
    }
    windy = {"rudder_angle": RUDDER_RAD, **ENVIRONMENT}
    set_later = simulate_fmu(str(bare), start_values={**windy, **start}, **options)
    built_in = simulate_fmu(str(fmus["native2"]), start_values=windy, **options)
    for name in STATES:
        np.testing.assert_array_equal(set_later[name], built_in[name])
    without = simulate_fmu(str(bare), start_values=windy, **options)
    assert abs(without["y"][-1] - set_later["y"][-1]) > 3.0  # the windage acted
