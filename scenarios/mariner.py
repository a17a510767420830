"""Mariner-class cargo ship: the Abkowitz model of Chislett & Strøm-Tejsen (1965).

A second reference ship, of another model structure than the KVLCC2 MMG one
(``scenarios.kvlcc2``) and than every identified family (``fmu_model.variants``): hull,
rudder and propeller forces together as one third-order Taylor expansion (Abkowitz
1964) about the straight run at the approach speed, its coefficients from
planar-motion-mechanism tests of a Mariner-class single-screw cargo ship model. It
answers "does what the toolkit identifies from one ship's zig-zags predict a ship it
was not designed around?", and it is not symmetric: the constant side force and yaw
moment of its single screw (Y₀, N₀) turn it to starboard with the rudder amidships.

Source: M. S. Chislett and J. Strøm-Tejsen, *Planar motion mechanism tests and
full-scale steering and manoeuvring predictions for a Mariner class vessel*, Hydro- og
Aerodynamisk Laboratorium, Lyngby, Report Hy-5 (1965); coefficients and equations as
transcribed in the MSS toolbox of T. I. Fossen (``VESSELS/mariner.m``, T. Lauvdal 1994,
revised 2001–2021). Only the ship is taken from there: its steering-gear model (a
first-order lag, 5 °/s) is not, the rudder angle is this plant's input as for every
plant of ``trials.run``, moved by the programme at :data:`RUDDER_RATE_RADPS`.

Non-dimensional quantities (prime system II, on the *instantaneous* speed
U = √(u² + v²) and L): Δu′ = (u − U₀)/U, v′ = v/U, r′ = r L/U; forces over ½ρL²U²,
the yaw moment over ½ρL³U², masses over ½ρL³ and the moment of inertia over ½ρL⁵.
The expansion (the source's rudder angle δ is positive to *port*: δ = −rudder):

    X′ = X_u Δu′ + X_uu Δu′² + X_uuu Δu′³ + X_vv v′² + X_rr r′² + X_rv r′v′
         + X_δδ δ² + X_uδδ Δu′δ² + X_vδ v′δ + X_uvδ Δu′v′δ                          (1)
    Y′ = Y_v v′ + Y_r r′ + Y_vvv v′³ + Y_vvr v′²r′ + Y_vu v′Δu′ + Y_ru r′Δu′ + Y_δ δ
         + Y_δδδ δ³ + Y_uδ Δu′δ + Y_uuδ Δu′²δ + Y_vδδ v′δ² + Y_vvδ v′²δ
         + Y₀ + Y₀u Δu′ + Y₀uu Δu′²                                                 (2)
    N′ = the same terms with N                                                     (3)

    (m′ − X_u̇) u̇ L/U² = X′                                                          (4)
    [m′ − Y_v̇, m′x_G′ − Y_ṙ; m′x_G′ − N_v̇, I_z′ − N_ṙ] [v̇ L/U²; ṙ L²/U²] = [Y′; N′]     (5)

The rigid-body velocity terms are inside the derivatives, as the source gives them
(X_rv = m′, and Y_r, N_r hold −m′ and −m′x_G′ with u ≈ U₀). The body frame's origin is
midship (x_G′ from there), as in ``scenarios.kvlcc2``; the state is
``[u, v, r, x, y, psi]`` (u the whole surge speed, not its change), x North, y East,
r and the rudder positive to starboard.

The model has no propeller rate: its thrust is that of the one rate of the tests,
inside X_u …. The logs record :data:`NOMINAL_RPS` as a constant shaft speed (any
constant would do: it is a label, not a property of the ship), and the plant refuses
any other.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np

from scenarios.calm_plants import RhsPlant, straight_run_helm
from trials.maneuvers import Helm

LENGTH_M = 160.93
"""Length between perpendiculars L [m] (source)."""
APPROACH_SPEED_MPS = 7.7175
"""Approach speed U₀ [m/s], 15 kn (source)."""
NOMINAL_RPS = 100.0 / 60.0
"""Propeller rate the logs record [rev/s] (module docstring: a label)."""
RUDDER_RATE_RADPS = math.radians(2.32)
"""Steering-gear rate [rad/s]: SOLAS II-1/29.3.2's 35° one side to 30° the other in 28 s."""
MAX_SUBSTEP_S = 0.1
"""Longest RK4 substep [s], L/U₀ / 200: against 0.025 s the 35° turn's tactical diameter
moves by 4e-13 relative and the 10/10 second overshoot by 2e-10°."""

MARINER_COEFFICIENTS: Mapping[str, float] = MappingProxyType(
    {
        name: value * 1e-5
        for name, value in {
            # masses, inertia and centre of gravity (× 1e-5; x_G′ below)
            "m": 798.0,
            "Iz": 39.2,
            # added masses
            "Xudot": -42.0,
            "Yvdot": -748.0,
            "Yrdot": -9.354,
            "Nvdot": 4.646,
            "Nrdot": -43.8,
            # surge, eq. (1)
            "Xu": -184.0,
            "Xuu": -110.0,
            "Xuuu": -215.0,
            "Xvv": -899.0,
            "Xrr": 18.0,
            "Xrv": 798.0,
            "Xdd": -95.0,
            "Xudd": -190.0,
            "Xvd": 93.0,
            "Xuvd": 93.0,
            # sway, eq. (2)
            "Yv": -1160.0,
            "Yr": -499.0,
            "Yvvv": -8078.0,
            "Yvvr": 15356.0,
            "Yvu": -1160.0,
            "Yru": -499.0,
            "Yd": 278.0,
            "Yddd": -90.0,
            "Yud": 556.0,
            "Yuud": 278.0,
            "Yvdd": -4.0,
            "Yvvd": 1190.0,
            "Y0": -4.0,
            "Y0u": -8.0,
            "Y0uu": -4.0,
            # yaw, eq. (3)
            "Nv": -264.0,
            "Nr": -166.0,
            "Nvvv": 1636.0,
            "Nvvr": -5483.0,
            "Nvu": -264.0,
            "Nru": -166.0,
            "Nd": -139.0,
            "Nddd": 45.0,
            "Nud": -278.0,
            "Nuud": -139.0,
            "Nvdd": 13.0,
            "Nvvd": -489.0,
            "N0": 3.0,
            "N0u": 6.0,
            "N0uu": 3.0,
        }.items()
    }
    | {"xG": -0.023}
)
"""Chislett & Strøm-Tejsen's non-dimensional coefficients (module docstring), as printed."""


@dataclass(frozen=True)
class AbkowitzShip:
    """A ship given by the expansion (1)-(5) of the module docstring.

    Attributes
    ----------
    name : str
        Vessel name.
    length_m, approach_speed_mps : float
        L [m] and the speed U₀ the expansion is about [m/s].
    coefficients : Mapping[str, float]
        The non-dimensional coefficients, keys as :data:`MARINER_COEFFICIENTS`.

    """

    name: str
    length_m: float
    approach_speed_mps: float
    coefficients: Mapping[str, float]


def mariner() -> AbkowitzShip:
    """Return the Mariner-class ship of Chislett & Strøm-Tejsen (1965), full scale."""
    return AbkowitzShip("mariner", LENGTH_M, APPROACH_SPEED_MPS, MARINER_COEFFICIENTS)


def abkowitz_forces(
    ship: AbkowitzShip, u: float, v: float, r: float, rudder_rad: float
) -> tuple[float, float, float]:
    """Return X′, Y′, N′ of eqs. (1)-(3) at the state (u [m/s], v [m/s], r [rad/s]).

    ``rudder_rad`` is positive to starboard (the source's δ is its negative).
    """
    k = ship.coefficients
    speed = math.hypot(u, v)
    du = (u - ship.approach_speed_mps) / speed
    vp = v / speed
    rp = r * ship.length_m / speed
    d = -rudder_rad
    x = (
        k["Xu"] * du
        + k["Xuu"] * du**2
        + k["Xuuu"] * du**3
        + k["Xvv"] * vp**2
        + k["Xrr"] * rp**2
        + k["Xrv"] * rp * vp
        + k["Xdd"] * d**2
        + k["Xudd"] * du * d**2
        + k["Xvd"] * vp * d
        + k["Xuvd"] * du * vp * d
    )
    y, n = (
        k[f"{f}v"] * vp
        + k[f"{f}r"] * rp
        + k[f"{f}vvv"] * vp**3
        + k[f"{f}vvr"] * vp**2 * rp
        + k[f"{f}vu"] * vp * du
        + k[f"{f}ru"] * rp * du
        + k[f"{f}d"] * d
        + k[f"{f}ddd"] * d**3
        + k[f"{f}ud"] * du * d
        + k[f"{f}uud"] * du**2 * d
        + k[f"{f}vdd"] * vp * d**2
        + k[f"{f}vvd"] * vp**2 * d
        + k[f"{f}0"]
        + k[f"{f}0u"] * du
        + k[f"{f}0uu"] * du**2
        for f in ("Y", "N")
    )
    return x, y, n


def abkowitz_rhs(ship: AbkowitzShip, state: np.ndarray, rudder_rad: float) -> np.ndarray:
    """Return ṡ of ``state`` = [u, v, r, x, y, psi] (eqs. (4)-(5) and the kinematics)."""
    u, v, r, _, _, psi = (float(s) for s in state)
    k = ship.coefficients
    x, y, n = abkowitz_forces(ship, u, v, r, rudder_rad)
    m22 = k["m"] - k["Yvdot"]
    m23 = k["m"] * k["xG"] - k["Yrdot"]
    m32 = k["m"] * k["xG"] - k["Nvdot"]
    m33 = k["Iz"] - k["Nrdot"]
    det = m22 * m33 - m23 * m32
    speed_sq_over_length = (u * u + v * v) / ship.length_m
    u_dot = x * speed_sq_over_length / (k["m"] - k["Xudot"])  # (4)
    v_dot = (m33 * y - m23 * n) * speed_sq_over_length / det  # (5), by Cramer's rule
    r_dot = (m22 * n - m32 * y) * speed_sq_over_length / (ship.length_m * det)
    cos_psi, sin_psi = math.cos(psi), math.sin(psi)
    return np.array([u_dot, v_dot, r_dot, u * cos_psi - v * sin_psi, u * sin_psi + v * cos_psi, r])


def neutral_helm(ship: AbkowitzShip) -> Helm:
    """Return the rudder [rad] and sway velocity [m/s] of the straight run at U₀.

    The trim Y′ = N′ = 0 of (2)-(3) at u = U₀, r = 0 (``scenarios.calm_plants``): the
    helm a trial's approach is steadied on, against the single screw's Y₀ and N₀ (the
    Mariner: 1.1° to port).

    Raises
    ------
    RuntimeError
        The trim does not converge (no straight run near the rudder amidships).

    """
    speed = ship.approach_speed_mps

    def side_force_and_moment(v_prime: float, rudder_rad: float) -> tuple[float, float]:
        _, y, n = abkowitz_forces(ship, speed, v_prime * speed, 0.0, rudder_rad)
        return y, n

    return straight_run_helm(side_force_and_moment, speed, ship.name)


class AbkowitzPlant(RhsPlant):
    """An :class:`AbkowitzShip` as a plant of ``trials.run``, in calm water.

    RK4 with equal substeps of at most :data:`MAX_SUBSTEP_S`, the rudder held over each
    communication step. The propeller rate must be ``nominal_rps`` (module docstring).
    """

    def __init__(self, ship: AbkowitzShip, nominal_rps: float = NOMINAL_RPS) -> None:
        super().__init__(
            lambda state, rudder_rad, _: abkowitz_rhs(ship, state, rudder_rad),
            ship.length_m,
            MAX_SUBSTEP_S,
        )
        self.ship = ship
        self.nominal_rps = nominal_rps

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` [s] with the rudder [rad] held; ``n_rps`` must be the nominal."""
        if not math.isclose(n_rps, self.nominal_rps, rel_tol=1e-9):
            raise ValueError(
                f"the {self.ship.name} model has no propeller term: it sails at its nominal "
                f"{60.0 * self.nominal_rps:g} rpm only, not {60.0 * n_rps:g} rpm"
            )
        return super().step(rudder_rad, n_rps, dt_s)
