"""A large tanker of Van Berlekom & Goddard (1972): a third reference ship, a third structure.

A ship of another model structure than the KVLCC2 MMG one (``scenarios.kvlcc2``), the
Mariner's Abkowitz expansion (``scenarios.mariner``) and every identified family
(``fmu_model.variants``): modulus (second-order, |v|v) hull terms in dimensional form,
a rudder force linear in the angle and in the square of an effective inflow speed c
that mixes the ship's speed and the propeller's race, a drift-rudder interaction
|β|β|δ|, and a propeller thrust whose side force and yaw moment (Y_T, N_T) make the
single-screw ship turn to one side with the rudder amidships. It answers, with the
Mariner, "does what the toolkit identifies from one ship's zig-zags predict a ship it
was not designed around?"

Source: W. B. van Berlekom and T. A. Goddard, *Maneuvering of large tankers*, Trans.
SNAME 80 (1972) 264-298; coefficients and equations as transcribed in the MSS toolbox of
T. I. Fossen (``VESSELS/tanker.m``, T. Lauvdal 1994, revised 2001-2024), deep water
(h → ∞: every term in z = T/(h − T) is 0). Only the ship is taken from there: its
steering gear (rate 2.33 °/s, saturation at 10°) and its shaft lag are not; the rudder
angle and the propeller rate are this plant's inputs, as for every plant of
``trials.run``, the rudder moved by the programme at :data:`RUDDER_RATE_RADPS`. The
source's rudder angle δ is positive to *port* (Y_ccδ > 0, N_ccδ < 0): δ = −rudder. A 35°
turn is the source's form taken beyond MSS's 10°, as it is for a turning trial.

Dimensional, SI, with the propeller rate n [rev/s], L = 304.8 m, β = atan(v/u):

    g_T = T_uu u²/L + T_un u n + L T_nn |n| n,        c = √(c_un u n + c_nn n²)
    X = [X_uu u² + L d₁₁ v r + X_vv v² + X_ccδδ |c|c δ² + X_ccβδ |c|c β δ
         + L g_T (1 − t)] / L                                                       (1)
    Y = [Y_uv u v + Y_vv |v|v + Y_ccδ |c|c δ + L d₂₂ u r + Y_ccββδ |c|c |β|β |δ|
         + Y_T g_T L] / L                                                          (2)
    L N = N_uv u v + L N_vr |v| r + N_ccδ |c|c δ + L d₃₃ u r
          + N_ccββδ |c|c |β|β |δ| + L N_T g_T                                        (3)
    u̇ = X / m₁₁,  v̇ = Y / m₂₂,  ṙ = L N / (L² m₃₃)                                   (4)

with the masses as fractions of the ship's (m₁₁ = 1 − X_u̇ …) and the kinematics of
``fmu_model.structure``; the state is ``[u, v, r, x, y, psi]``, x North, y East, r and
the rudder positive to starboard.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
from scipy.optimize import brentq

from scenarios.calm_plants import RhsPlant, straight_run_helm
from trials.maneuvers import Helm

LENGTH_M = 304.8
"""Length between perpendiculars L [m] (source)."""
NOMINAL_RPS = 80.0 / 60.0
"""Propeller rate of the approach [rev/s]: 80 rpm, the source's nominal."""
RUDDER_RATE_RADPS = math.radians(2.33)
"""Steering-gear rate [rad/s] (source)."""
MAX_SUBSTEP_S = 0.2
"""Longest RK4 substep [s], L/U₀ / 190 (as the Mariner's L/U₀ / 200)."""

TANKER_COEFFICIENTS: Mapping[str, float] = MappingProxyType(
    {
        "t": 0.22,  # thrust deduction
        "cun": 0.605,
        "cnn": 38.2,
        "Tuu": -0.00695,
        "Tun": -0.00063,
        "Tnn": 0.0000354,
        "m11": 1.050,  # 1 − X_u̇
        "m22": 2.020,  # 1 − Y_v̇
        "m33": 0.1232,  # k_z² − N_ṙ
        "d11": 2.020,  # 1 + X_vr
        "d22": -0.752,  # Y_ur − 1
        "d33": -0.231,  # N_ur − x_G
        "YT": 0.04,
        "NT": -0.02,
        "Xuu": -0.0377,
        "Xvv": 0.3,
        "Xccdd": -0.093,
        "Xccbd": 0.152,
        "Yuv": -1.205,
        "Yvv": -2.400,
        "Yccd": 0.208,
        "Yccbbd": -2.16,
        "Nuv": -0.451,
        "Nvr": -0.300,
        "Nccd": -0.098,
        "Nccbbd": 0.688,
    }
)
"""Van Berlekom & Goddard's deep-water coefficients (module docstring), as printed."""


@dataclass(frozen=True)
class TankerShip:
    """A ship given by eqs. (1)-(4) of the module docstring.

    Attributes
    ----------
    name : str
        Vessel name.
    length_m : float
        L [m].
    coefficients : Mapping[str, float]
        Keys as :data:`TANKER_COEFFICIENTS`.

    """

    name: str
    length_m: float
    coefficients: Mapping[str, float]


def tanker() -> TankerShip:
    """Return the large tanker of Van Berlekom & Goddard (1972), full scale, deep water."""
    return TankerShip("tanker", LENGTH_M, TANKER_COEFFICIENTS)


def tanker_forces(
    ship: TankerShip, u: float, v: float, r: float, rudder_rad: float, n_rps: float
) -> tuple[float, float, float]:
    """Return X, Y [m/s²] and L·N [m²/s²] of eqs. (1)-(3) (before the masses of (4)).

    At the state u, v [m/s], r [rad/s], the rudder [rad, positive to starboard] and the
    propeller rate [rev/s].
    """
    k = ship.coefficients
    length = ship.length_m
    d = -rudder_rad
    beta = math.atan(v / u)
    thrust = (
        k["Tuu"] * u * u / length + k["Tun"] * u * n_rps + length * k["Tnn"] * abs(n_rps) * n_rps
    )
    c = math.sqrt(k["cun"] * u * n_rps + k["cnn"] * n_rps * n_rps)
    race = abs(c) * c
    x = (
        k["Xuu"] * u * u
        + length * k["d11"] * v * r
        + k["Xvv"] * v * v
        + k["Xccdd"] * race * d * d
        + k["Xccbd"] * race * beta * d
        + length * thrust * (1.0 - k["t"])
    ) / length  # (1)
    y = (
        k["Yuv"] * u * v
        + k["Yvv"] * abs(v) * v
        + k["Yccd"] * race * d
        + length * k["d22"] * u * r
        + k["Yccbbd"] * race * abs(beta) * beta * abs(d)
        + k["YT"] * thrust * length
    ) / length  # (2)
    ln = (
        k["Nuv"] * u * v
        + length * k["Nvr"] * abs(v) * r
        + k["Nccd"] * race * d
        + length * k["d33"] * u * r
        + k["Nccbbd"] * race * abs(beta) * beta * abs(d)
        + length * k["NT"] * thrust
    )  # (3)
    return x, y, ln


def tanker_rhs(ship: TankerShip, state: np.ndarray, rudder_rad: float, n_rps: float) -> np.ndarray:
    """Return ṡ of ``state`` = [u, v, r, x, y, psi] (eq. (4) and the kinematics)."""
    u, v, r, _, _, psi = (float(s) for s in state)
    k = ship.coefficients
    x, y, ln = tanker_forces(ship, u, v, r, rudder_rad, n_rps)
    cos_psi, sin_psi = math.cos(psi), math.sin(psi)
    return np.array(
        [  # (4), then the kinematics
            x / k["m11"],
            y / k["m22"],
            ln / (ship.length_m**2 * k["m33"]),
            u * cos_psi - v * sin_psi,
            u * sin_psi + v * cos_psi,
            r,
        ]
    )


def approach_speed(ship: TankerShip, n_rps: float = NOMINAL_RPS) -> float:
    """Return the speed [m/s] of the straight run at ``n_rps``, rudder amidships: X = 0.

    (The drift of the trimmed run, :func:`neutral_helm`, changes it by parts in 10⁵.)
    80 rpm: 8.23 m/s, the source's design speed.
    """
    return brentq(lambda u: tanker_forces(ship, u, 0.0, 0.0, 0.0, n_rps)[0], 0.1, 50.0, xtol=1e-14)


def neutral_helm(ship: TankerShip, n_rps: float = NOMINAL_RPS) -> Helm:
    """Return the rudder [rad] and sway [m/s] of the straight run at ``n_rps``.

    The trim Y = N = 0 at r = 0 and the approach speed (``scenarios.calm_plants``),
    against the propeller's Y_T and N_T.
    """
    speed = approach_speed(ship, n_rps)

    def side_force_and_moment(v_prime: float, rudder_rad: float) -> tuple[float, float]:
        _, y, ln = tanker_forces(ship, speed, v_prime * speed, 0.0, rudder_rad, n_rps)
        return y, ln / ship.length_m

    return straight_run_helm(side_force_and_moment, speed, ship.name)


class TankerPlant(RhsPlant):
    """A :class:`TankerShip` as a plant of ``trials.run``, in calm deep water."""

    def __init__(self, ship: TankerShip) -> None:
        super().__init__(
            lambda state, rudder_rad, n_rps: tanker_rhs(ship, state, rudder_rad, n_rps),
            ship.length_m,
            MAX_SUBSTEP_S,
        )
        self.ship = ship
