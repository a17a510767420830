"""KVLCC2 reference ship: the MMG standard model of Yasukawa & Yoshimura (2015).

The "truth" vessel of the project (DESIGN.md): it synthesises trial logs and supplies
the measured side of every validation table. Its equations, coefficients, the choices
where published copies disagree, the scaling and the expected results are given in
``shared/reference/kvlcc2_mmg.md`` (quoted as "ref. §n" below). The model itself is
H. Yasukawa and Y. Yoshimura, *Introduction of MMG standard method for ship maneuvering
predictions*, J Mar Sci Technol 20 (2015) 37-52, doi:10.1007/s00773-014-0293-y
("Y&Y2015").

The model structure deliberately differs from the identified models in ``fmu_model``
(identification is only honest when the truth is not the model being fitted), so the
equations live here and not in ``fmu_model``.

Conventions (ref. §1): earth frame x North, y East; body frame at **midship**, u forward,
v_m to starboard, r positive turning to starboard; positive rudder angle turns the ship to
starboard. The state vector is ``[u, v_m, r, x, y, psi]`` in m/s, m/s, rad/s, m, m, rad.
Drift angle beta = atan(-v_m/u). Primed (non-dimensional) quantities use L, d and a speed
U: forces over 1/2 rho L d U^2, yaw moments over 1/2 rho L^2 d U^2, v' = v_m/U,
r' = r L/U.

At sea (:class:`~scenarios.sea.SeaEnvironment`, ``docs/kvlcc2_environment.md``):

* u, v_m, r are velocities **through the water**; the hull, propeller and rudder forces
  see only them. The position moves over ground:
  x_dot = u cos psi - v_m sin psi + c_N, y_dot = u sin psi + v_m cos psi + c_E.
  For a uniform current that does not change in time the equations of motion in the
  water-relative velocities are exactly the calm-water ones (Fossen 2011, *Handbook of
  Marine Craft Hydrodynamics and Motion Control*, §8.3, Property 8.1: with
  nu = nu_r + nu_c and nu_c_dot = -S(r) nu_c, M_RB nu_dot + C_RB(nu) nu =
  M_RB nu_r_dot + C_RB(nu_r) nu_r), so a steady current only moves the track.
* A current that changes in time, c_dot = (dc_N/dt, dc_E/dt) over ground, adds
  M_RB R(psi)^T c_dot to the rigid-body side of that identity: in the MMG equations (which
  keep the added masses on the water-relative accelerations) it is a body-frame force
  -m R^T c_dot at the centre of gravity, i.e. at midship surge -m c_dot_u, sway
  -m c_dot_v and yaw -x_G m c_dot_v, with c_dot_u = dc_N/dt cos psi + dc_E/dt sin psi and
  c_dot_v = -dc_N/dt sin psi + dc_E/dt cos psi. On the ship's mass alone it is the
  "-dc/dt in the body frame" of the water-relative accelerations (the added masses
  move with the water). This treats the current as a prescribed velocity field
  without its own pressure gradient; a current driven by a horizontal pressure
  gradient (a tide) would add the Froude-Krylov force rho Vol c_dot = m c_dot, which
  cancels the term exactly for a floating ship. For the slow changes it is meant
  for (0.5 m/s per hour: 1.4e-4 m/s^2) either choice is far below any other force.
* The wind load of Blendermann (1994) (``fmu_model.environment``, loaded tanker) on
  the apparent wind, computed from the true wind and the ship's velocity **over
  ground**, enters as dimensional forces X, Y at midship and a yaw moment N about
  midship (the windage's lateral centroid is given from midship, see
  :func:`kvlcc2_windage`). Only what the true wind adds is applied: the load in the
  apparent wind minus the load the ship's own motion through still air gives, as the
  ITTC speed/power trial procedure (7.5-04-01-01.1, wind resistance correction:
  1/2 rho_A C_X(psi_WR) A_XV V_WR^2 - 1/2 rho_A C_X(0) A_XV V_G^2) corrects a trial
  for wind, here for all three components. The still-air part is taken to belong to
  the calm-water model (R_0' and the hull derivatives); so no wind means exactly the
  calm-water ship, and the load is continuous as the wind tends to 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.optimize import root

from fmu_model.environment import (
    AIR_DENSITY_KGPM3,
    TANKER_LOADED,
    Windage,
    apparent_wind,
    ground_velocity_body,
    wind_loads,
)
from fmu_model.integrate import rk4_into
from scenarios.sea import GustProcess, SeaEnvironment, default_gust_time_s
from trials.run import SingleShip

FROUDE_SCALE_RATIO = 320.0 / 7.0
"""Geometric scale ratio lambda between the full-scale ship and the L = 7 m model (ref. §9)."""

_KNOT_MPS = 1852.0 / 3600.0
_FULL_LENGTH_M = 320.0
# Reference accuracy of ref. §8/§11: adaptive DOP853, rtol 1e-10.
# Full-scale equivalents of the default sampling and of the `step` sub-step [s].
_FULL_SCALE_MAX_SUBSTEP_S = 0.05


class MmgConvergenceError(RuntimeError):
    """The steady-turn equations of the MMG model could not be solved."""


@dataclass(frozen=True)
class MmgShip:
    """Particulars and MMG coefficients of a ship at one scale (Y&Y2015, ref. §6).

    Fields whose name ends in a unit (``_m``, ``_m2``, ``_m3``, ``_mps``, ``_rps``,
    ``_radps``, ``_kgpm3``) are dimensional, for the chosen scale. All other numeric
    fields are the non-dimensional (primed) coefficients of Y&Y2015; their names are the
    paper's symbols without the prime (``X_vv`` is X'_vv, ``x_P`` is x'_P = x_P/L).

    Attributes
    ----------
    name : str
        Vessel name, ``"kvlcc2"``.
    scale : str
        ``"full"`` or ``"model"``.
    length_m : float
        Length between perpendiculars L [m].
    breadth_m : float
        Breadth B [m] (not used in the equations).
    draught_m : float
        Draught d [m].
    displacement_m3 : float
        Displacement volume [m^3].
    x_g_m : float
        Longitudinal centre of gravity, forward of midship [m].
    block_coefficient : float
        Block coefficient C_b [-] (not used in the equations).
    propeller_diameter_m : float
        Propeller diameter D_P [m].
    rudder_span_m : float
        Rudder span H_R [m].
    rudder_area_m2 : float
        Profile area of the movable rudder A_R [m^2].
    yaw_gyration_radius_m : float
        Radius of gyration in yaw k_zz [m] (0.25 L).
    water_density_kgpm3 : float
        Water density rho [kg/m^3]. It cancels from every acceleration; it only sets the
        dimensional forces.
    approach_speed_mps : float
        Approach speed U0 (ref. §8) [m/s].
    nominal_rps : float
        Canonical propeller speed n_P, the self-propulsion point at U0 (ref. §8) [rev/s].
    rudder_rate_radps : float
        Steering-gear rate (ref. §7, §8) [rad/s].
    m_x, m_y, J_z : float
        Added mass in surge and sway, added moment of inertia in yaw [-]
        (over 1/2 rho L^2 d and 1/2 rho L^4 d).
    R_0 : float
        Straight-ahead resistance coefficient [-].
    X_vv, X_vr, X_rr, X_vvvv : float
        Hull surge derivatives [-].
    Y_v, Y_r, Y_vvv, Y_vvr, Y_vrr, Y_rrr : float
        Hull sway derivatives [-].
    N_v, N_r, N_vvv, N_vvr, N_vrr, N_rrr : float
        Hull yaw-moment derivatives [-].
    t_P : float
        Thrust deduction factor [-].
    w_P0 : float
        Effective wake fraction in straight run [-].
    x_P : float
        Longitudinal propeller position over L [-] (used in beta_P).
    k_0, k_1, k_2 : float
        Coefficients of the thrust polynomial K_T(J_P) [-].
    C_1, C_2_plus, C_2_minus : float
        Wake-change coefficients; C_2 is ``C_2_plus`` when beta_P > 0, else ``C_2_minus``.
    t_R : float
        Steering resistance deduction factor [-].
    a_H : float
        Rudder force increase factor [-].
    x_H : float
        Position of the hull lateral force induced by the rudder, over L [-].
    x_R : float
        Rudder position over L [-].
    epsilon : float
        Wake ratio (1 - w_R)/(1 - w_P) [-].
    kappa : float
        Propeller-slipstream constant in u_R [-].
    l_R : float
        Effective longitudinal rudder position in beta_R, over L [-].
    gamma_R_plus, gamma_R_minus : float
        Flow-straightening coefficient for beta_R > 0 and beta_R <= 0 [-].
    f_alpha : float
        Rudder lift-gradient coefficient [-].

    """

    name: str
    scale: str
    length_m: float
    breadth_m: float
    draught_m: float
    displacement_m3: float
    x_g_m: float
    block_coefficient: float
    propeller_diameter_m: float
    rudder_span_m: float
    rudder_area_m2: float
    yaw_gyration_radius_m: float
    water_density_kgpm3: float
    approach_speed_mps: float
    nominal_rps: float
    rudder_rate_radps: float
    m_x: float
    m_y: float
    J_z: float
    R_0: float
    X_vv: float
    X_vr: float
    X_rr: float
    X_vvvv: float
    Y_v: float
    Y_r: float
    Y_vvv: float
    Y_vvr: float
    Y_vrr: float
    Y_rrr: float
    N_v: float
    N_r: float
    N_vvv: float
    N_vvr: float
    N_vrr: float
    N_rrr: float
    t_P: float
    w_P0: float
    x_P: float
    k_0: float
    k_1: float
    k_2: float
    C_1: float
    C_2_plus: float
    C_2_minus: float
    t_R: float
    a_H: float
    x_H: float
    x_R: float
    epsilon: float
    kappa: float
    l_R: float
    gamma_R_plus: float
    gamma_R_minus: float
    f_alpha: float

    @property
    def mass_kg(self) -> float:
        """Ship mass m = rho * displacement [kg]."""
        return self.water_density_kgpm3 * self.displacement_m3

    @property
    def time_unit_s(self) -> float:
        """Time unit L/U0 of the non-dimensional time t' = t U0/L [s]."""
        return self.length_m / self.approach_speed_mps


def kvlcc2(scale: str = "full") -> MmgShip:
    """Return the KVLCC2 tanker in the MMG standard model (Y&Y2015, ref. §6-§8).

    Full scale is primary; the model (L = 7 m) is its exact Froude scale with
    lambda = 320/7 (ref. §6.1, §9): lengths / lambda, areas / lambda^2, volumes /
    lambda^3, speeds / sqrt(lambda), rates and rps * sqrt(lambda). Non-dimensional
    coefficients are the same at both scales.

    Parameters
    ----------
    scale : str, optional
        ``"full"`` (L = 320 m, sea water 1025 kg/m^3) or ``"model"`` (L = 7 m, fresh
        water 1000 kg/m^3). The density only changes dimensional forces.

    Returns
    -------
    MmgShip
        Particulars, approach condition and coefficients at that scale.

    Raises
    ------
    ValueError
        If ``scale`` is neither ``"full"`` nor ``"model"``.

    """
    if scale == "full":
        lam = 1.0
        rho = 1025.0
    elif scale == "model":
        lam = FROUDE_SCALE_RATIO
        rho = 1000.0
    else:
        raise ValueError(f"unknown scale {scale!r}: expected 'full' or 'model'")
    sqrt_lam = math.sqrt(lam)
    length_m = _FULL_LENGTH_M / lam
    return MmgShip(
        name="kvlcc2",
        scale=scale,
        # ref. §6.1, full-scale column, Froude-scaled (ref. §9)
        length_m=length_m,
        breadth_m=58.0 / lam,
        draught_m=20.8 / lam,
        displacement_m3=312_600.0 / lam**3,
        x_g_m=11.2 / lam,
        block_coefficient=0.810,
        propeller_diameter_m=9.86 / lam,
        rudder_span_m=15.80 / lam,
        rudder_area_m2=112.5 / lam**2,
        yaw_gyration_radius_m=0.25 * length_m,
        water_density_kgpm3=rho,
        # ref. §8: U0 = 15.5 kn full scale; n_P = 1.75024 rps full (11.8338 rps model);
        # steering rate 2.34 deg/s full (15.82 deg/s model), ref. §7
        approach_speed_mps=15.5 * _KNOT_MPS / sqrt_lam,
        nominal_rps=1.75024 * sqrt_lam,
        rudder_rate_radps=math.radians(2.34) * sqrt_lam,
        # ref. §6.2 (Y&Y2015 Table 4/5 values)
        m_x=0.022,
        m_y=0.223,
        J_z=0.011,
        R_0=0.022,
        X_vv=-0.040,
        X_vr=0.002,
        X_rr=0.011,
        X_vvvv=0.771,
        Y_v=-0.315,
        Y_r=0.083,
        Y_vvv=-1.607,
        Y_vvr=0.379,
        Y_vrr=-0.391,
        Y_rrr=0.008,
        N_v=-0.137,
        N_r=-0.049,
        N_vvv=-0.030,
        N_vvr=-0.294,
        N_vrr=0.055,
        N_rrr=-0.013,
        t_P=0.220,
        w_P0=0.40,
        x_P=-0.48,  # ref. §7: -0.48, not -0.69 / -0.5
        k_0=0.2931,
        k_1=-0.2753,
        k_2=-0.1385,  # ref. §7: -0.1385, not -0.1359
        C_1=2.0,
        C_2_plus=1.6,
        C_2_minus=1.1,
        t_R=0.387,
        a_H=0.312,
        x_H=-0.464,
        x_R=-0.5,
        epsilon=1.09,
        kappa=0.50,
        l_R=-0.710,
        gamma_R_plus=0.640,
        gamma_R_minus=0.395,
        f_alpha=2.747,
    )


@dataclass(frozen=True)
class MmgForces:
    """Forces of the MMG model at one state, with the module breakdown of ref. §11.

    Attributes
    ----------
    X_N, Y_N, N_Nm : float
        Total surge force X_H + X_P + X_R [N], sway force Y_H + Y_R [N] and yaw moment
        about midship N_H + N_R [N m].
    reference_speed_mps : float
        Speed U_ref used for every ``*_nd`` field [m/s].
    X_nd, Y_nd, N_nd : float
        The totals over 1/2 rho L d U_ref^2 (moment over 1/2 rho L^2 d U_ref^2) [-].
    X_H_nd, Y_H_nd, N_H_nd : float
        Hull forces and moment, same normalisation [-].
    X_P_nd : float
        Propeller thrust force, same normalisation [-].
    X_R_nd, Y_R_nd, N_R_nd : float
        Rudder forces and moment (including hull interaction), same normalisation [-].
    J_P : float
        Propeller advance ratio [-] (``inf`` at n = 0).
    K_T : float
        Thrust coefficient at J_P [-] (``nan`` at n = 0).
    w_P : float
        Effective wake fraction at the propeller in manoeuvring [-].
    u_R_mps, v_R_mps : float
        Longitudinal and lateral inflow velocity at the rudder [m/s].
    alpha_R_rad : float
        Effective rudder inflow angle [rad].

    """

    X_N: float
    Y_N: float
    N_Nm: float
    reference_speed_mps: float
    X_nd: float
    Y_nd: float
    N_nd: float
    X_H_nd: float
    Y_H_nd: float
    N_H_nd: float
    X_P_nd: float
    X_R_nd: float
    Y_R_nd: float
    N_R_nd: float
    J_P: float
    K_T: float
    w_P: float
    u_R_mps: float
    v_R_mps: float
    alpha_R_rad: float


class _Modules(NamedTuple):
    """Dimensional module forces [N, N m] and intermediate flow quantities."""

    X_H: float
    Y_H: float
    N_H: float
    X_P: float
    X_R: float
    Y_R: float
    N_R: float
    u_P: float  # propeller inflow speed u (1 - w_P) [m/s]
    w_P: float
    u_R: float
    v_R: float
    alpha_R: float


def _modules(ship: MmgShip, u: float, v: float, r: float, delta: float, n: float) -> _Modules:
    """Evaluate hull, propeller and rudder modules in dimensional form (ref. §3-§5)."""
    rho = ship.water_density_kgpm3
    L = ship.length_m
    d = ship.draught_m
    D_P = ship.propeller_diameter_m
    U2 = u * u + v * v
    U = math.sqrt(U2)
    if U > 0.0:
        v_nd = v / U  # ref. §1: v' = v_m/U
        r_nd = r * L / U  # ref. §1: r' = r L/U
    else:
        v_nd = r_nd = 0.0
    beta = math.atan2(-v, u)  # ref. §1: drift angle atan(-v_m/u)
    q_force = 0.5 * rho * L * d * U2
    q_moment = q_force * L

    # Hull, Y&Y2015 eq. (7); ref. §3
    v2 = v_nd * v_nd
    r2 = r_nd * r_nd
    X_H = q_force * (
        -ship.R_0
        + ship.X_vv * v2
        + ship.X_vr * v_nd * r_nd
        + ship.X_rr * r2
        + ship.X_vvvv * v2 * v2
    )
    Y_H = q_force * (
        ship.Y_v * v_nd
        + ship.Y_r * r_nd
        + ship.Y_vvv * v2 * v_nd
        + ship.Y_vvr * v2 * r_nd
        + ship.Y_vrr * v_nd * r2
        + ship.Y_rrr * r2 * r_nd
    )
    N_H = q_moment * (
        ship.N_v * v_nd
        + ship.N_r * r_nd
        + ship.N_vvv * v2 * v_nd
        + ship.N_vvr * v2 * r_nd
        + ship.N_vrr * v_nd * r2
        + ship.N_rrr * r2 * r_nd
    )

    # Propeller, Y&Y2015 eqs. (10)-(16); ref. §4
    beta_P = beta - ship.x_P * r_nd
    C_2 = ship.C_2_plus if beta_P > 0.0 else ship.C_2_minus
    one_minus_w_P = (1.0 - ship.w_P0) * (
        1.0 + (1.0 - math.exp(-ship.C_1 * abs(beta_P))) * (C_2 - 1.0)
    )
    u_P = u * one_minus_w_P
    # n^2 D_P^2 K_T(J_P) with J_P = u_P/(n D_P), written so that it stays finite at n = 0
    nD = n * D_P
    thrust_n2D2KT = ship.k_0 * nD * nD + ship.k_1 * nD * u_P + ship.k_2 * u_P * u_P
    X_P = (1.0 - ship.t_P) * rho * D_P * D_P * thrust_n2D2KT  # (1 - t_P) rho n^2 D_P^4 K_T

    # Rudder, Y&Y2015 eqs. (17)-(24); ref. §5
    eta = D_P / ship.rudder_span_m
    # u_P sqrt(1 + 8 K_T/(pi J_P^2)) = sqrt(u_P^2 + 8 n^2 D_P^2 K_T/pi) for u_P >= 0
    slipstream = math.sqrt(max(u_P * u_P + 8.0 * thrust_n2D2KT / math.pi, 0.0))
    u_R = ship.epsilon * math.sqrt(
        eta * (u_P + ship.kappa * (slipstream - u_P)) ** 2 + (1.0 - eta) * u_P * u_P
    )
    beta_R = beta - ship.l_R * r_nd
    gamma_R = ship.gamma_R_plus if beta_R > 0.0 else ship.gamma_R_minus
    v_R = U * gamma_R * beta_R
    alpha_R = delta - math.atan2(v_R, u_R)  # atan(v_R/u_R), u_R >= 0
    F_N = (
        0.5 * rho * ship.rudder_area_m2 * (u_R * u_R + v_R * v_R) * ship.f_alpha * math.sin(alpha_R)
    )
    cos_delta = math.cos(delta)
    X_R = -(1.0 - ship.t_R) * F_N * math.sin(delta)
    Y_R = -(1.0 + ship.a_H) * F_N * cos_delta
    N_R = -(ship.x_R + ship.a_H * ship.x_H) * L * F_N * cos_delta
    return _Modules(X_H, Y_H, N_H, X_P, X_R, Y_R, N_R, u_P, 1.0 - one_minus_w_P, u_R, v_R, alpha_R)


def mmg_forces(
    ship: MmgShip,
    u_mps: float,
    v_mps: float,
    r_radps: float,
    rudder_rad: float,
    n_rps: float,
    *,
    reference_speed_mps: float | None = None,
) -> MmgForces:
    """Evaluate the MMG forces and their module breakdown at one state (ref. §3-§5).

    Parameters
    ----------
    ship : MmgShip
        The ship.
    u_mps : float
        Surge velocity [m/s].
    v_mps : float
        Sway velocity at midship, positive to starboard [m/s].
    r_radps : float
        Yaw rate, positive turning to starboard [rad/s].
    rudder_rad : float
        Actual rudder angle, positive turns to starboard [rad].
    n_rps : float
        Propeller speed, >= 0 [rev/s].
    reference_speed_mps : float, optional
        Speed used for the non-dimensional fields [m/s]; the approach speed U0 by default,
        as in the force check of ref. §11.

    Returns
    -------
    MmgForces
        Dimensional totals and the non-dimensional breakdown.

    """
    m = _modules(ship, float(u_mps), float(v_mps), float(r_radps), float(rudder_rad), float(n_rps))
    U_ref = ship.approach_speed_mps if reference_speed_mps is None else float(reference_speed_mps)
    q_force = 0.5 * ship.water_density_kgpm3 * ship.length_m * ship.draught_m * U_ref**2
    q_moment = q_force * ship.length_m
    X = m.X_H + m.X_P + m.X_R
    Y = m.Y_H + m.Y_R
    N = m.N_H + m.N_R
    nD = float(n_rps) * ship.propeller_diameter_m
    if nD > 0.0:
        J_P = m.u_P / nD
        K_T = ship.k_0 + ship.k_1 * J_P + ship.k_2 * J_P**2  # Y&Y2015 eq. (11)
    else:
        J_P = math.inf
        K_T = math.nan
    return MmgForces(
        X_N=X,
        Y_N=Y,
        N_Nm=N,
        reference_speed_mps=U_ref,
        X_nd=X / q_force,
        Y_nd=Y / q_force,
        N_nd=N / q_moment,
        X_H_nd=m.X_H / q_force,
        Y_H_nd=m.Y_H / q_force,
        N_H_nd=m.N_H / q_moment,
        X_P_nd=m.X_P / q_force,
        X_R_nd=m.X_R / q_force,
        Y_R_nd=m.Y_R / q_force,
        N_R_nd=m.N_R / q_moment,
        J_P=J_P,
        K_T=K_T,
        w_P=m.w_P,
        u_R_mps=m.u_R,
        v_R_mps=m.v_R,
        alpha_R_rad=m.alpha_R,
    )


def _derivatives(
    ship: MmgShip, u: float, v: float, r: float, psi: float, delta: float, n: float
) -> tuple[float, float, float, float, float, float]:
    """Right-hand side of the equations of motion about midship (ref. §2)."""
    f = _modules(ship, u, v, r, delta, n)
    u_dot, v_dot, r_dot = _accelerations(
        ship, u, v, r, f.X_H + f.X_P + f.X_R, f.Y_H + f.Y_R, f.N_H + f.N_R
    )
    cos_psi = math.cos(psi)
    sin_psi = math.sin(psi)
    x_dot = u * cos_psi - v * sin_psi
    y_dot = u * sin_psi + v * cos_psi
    return u_dot, v_dot, r_dot, x_dot, y_dot, r


def _accelerations(
    ship: MmgShip, u: float, v: float, r: float, X: float, Y: float, N: float
) -> tuple[float, float, float]:
    """u_dot, v_dot, r_dot of Y&Y2015 eq. (4) under the total forces X, Y [N], N [N m]."""
    rho = ship.water_density_kgpm3
    L = ship.length_m
    half_rho_L2_d = 0.5 * rho * L * L * ship.draught_m
    m = ship.mass_kg
    m_x = ship.m_x * half_rho_L2_d  # m_x' over 1/2 rho L^2 d
    m_y = ship.m_y * half_rho_L2_d
    J_z = ship.J_z * half_rho_L2_d * L * L  # J_z' over 1/2 rho L^4 d
    I_zG = m * ship.yaw_gyration_radius_m**2
    x_G = ship.x_g_m
    # Y&Y2015 eq. (4), ref. §2: surge explicit, sway and yaw as a 2x2 system
    u_dot = (X + (m + m_y) * v * r + x_G * m * r * r) / (m + m_x)
    a11 = m + m_y
    a12 = x_G * m
    a22 = I_zG + x_G * x_G * m + J_z
    b1 = Y - (m + m_x) * u * r
    b2 = N - x_G * m * u * r
    det = a11 * a22 - a12 * a12
    v_dot = (a22 * b1 - a12 * b2) / det
    r_dot = (a11 * b2 - a12 * b1) / det
    return u_dot, v_dot, r_dot


def mmg_rhs(
    ship: MmgShip,
    state: np.ndarray,
    rudder_rad: float,
    n_rps: float,
    *,
    environment: SeaEnvironment | None = None,
    windage: Windage | None = None,
    time_s: float = 0.0,
) -> np.ndarray:
    """Time derivative of the MMG state (Y&Y2015 eq. (4), ref. §2), at sea if asked.

    Parameters
    ----------
    ship : MmgShip
        The ship.
    state : numpy.ndarray
        ``[u, v_m, r, x, y, psi]``, shape (6,): surge velocity through the water [m/s],
        sway velocity at midship through the water [m/s], yaw rate [rad/s], North and
        East position of midship [m], heading [rad].
    rudder_rad : float
        Actual rudder angle [rad] (no steering gear here).
    n_rps : float
        Propeller speed [rev/s].
    environment : SeaEnvironment, optional
        Current and wind (module docstring); calm water when None.
    windage : Windage, optional
        The ship's windage; :func:`kvlcc2_windage` of the ship's scale when None.
    time_s : float
        Time from the start of the run [s] (the current's change and the gusts).

    Returns
    -------
    numpy.ndarray
        ``d state / dt``, shape (6,), in [m/s^2, m/s^2, rad/s^2, m/s, m/s, rad/s].

    """
    u, v, r, _, _, psi = (float(s) for s in state)
    if environment is None:
        return np.array(_derivatives(ship, u, v, r, psi, float(rudder_rad), float(n_rps)))
    sea = _SeaRun(ship, environment, windage)
    return np.array(
        _derivatives_at_sea(ship, sea, u, v, r, psi, float(rudder_rad), float(n_rps), time_s)
    )


# --------------------------------------------------------------------------- at sea

# KVLCC2's windage at full scale (docs/kvlcc2_environment.md): no published value was
# found; estimated from the published hull (L_pp 320 m, L_wl 325.5 m, B 58 m, D 30 m,
# T 20.8 m) and a stated aft superstructure. Freeboard f = D - T = 9.2 m.
_FREEBOARD_M = 30.0 - 20.8
_WINDAGE_FULL = {
    # length overall: not published for the hull form; a typical VLCC's (~330 m)
    "length_overall_m": 330.0,
    # hull f x B (533.6) + deckhouse 40 m x 25 m (1000) + bridge wings 18 m x 2.8 m
    # (50.4) + funnel above the deckhouse 8 m x 10 m (80) + fittings (50)
    "frontal_area_m2": _FREEBOARD_M * 58.0 + 1000.0 + 18.0 * 2.8 + 80.0 + 50.0,
    # hull f x L_wl (2994.6) + deckhouse 30 m x 25 m (750) + funnel 10 m x 10 m (100)
    # + forecastle, piping, cranes, masts (150)
    "lateral_area_m2": _FREEBOARD_M * 325.5 + 750.0 + 100.0 + 150.0,
}
# lateral centroid from midship: hull and fittings at 0, deckhouse at -145 m, funnel at
# -150 m (between x = -160 m, the aft perpendicular, and -130 m)
_WINDAGE_FULL["lateral_centroid_m"] = (750.0 * -145.0 + 100.0 * -150.0) / _WINDAGE_FULL[
    "lateral_area_m2"
]


def kvlcc2_windage(scale: str = "full") -> Windage:
    """KVLCC2's windage for the Blendermann (1994) wind load (``docs/kvlcc2_environment.md``).

    Estimated, not published: the hull above the full-load waterline (freeboard
    D - T = 9.2 m over L_wl = 325.5 m and B = 58 m) plus an aft deckhouse, bridge wings,
    funnel and deck fittings of a typical VLCC. Full scale: A_F = 1714.0 m^2,
    A_L = 3994.6 m^2, L_oa = 330 m, lateral centroid 30.98 m aft of midship. The model
    (L = 7 m) is its Froude scale (areas / lambda^2, lengths / lambda). The effective
    inertias are this ship's about midship: m + m_x, m + m_y, I_zG + x_G^2 m + J_z and the
    coupling x_G m of Y&Y2015 eq. (4) (the MMG equations use the forces; the inertias
    complete the :class:`Windage`, so that its accelerations are the reference's).

    Parameters
    ----------
    scale : str
        ``"full"`` or ``"model"``, as :func:`kvlcc2`.

    Returns
    -------
    Windage
        Areas [m^2], length overall [m], lateral centroid forward of midship [m]
        (negative: aft), inertias [kg, kg m^2].

    """
    ship = kvlcc2(scale)
    lam = _FULL_LENGTH_M / ship.length_m
    half_rho_L2_d = 0.5 * ship.water_density_kgpm3 * ship.length_m**2 * ship.draught_m
    m = ship.mass_kg
    return Windage(
        frontal_area_m2=_WINDAGE_FULL["frontal_area_m2"] / lam**2,
        lateral_area_m2=_WINDAGE_FULL["lateral_area_m2"] / lam**2,
        length_overall_m=_WINDAGE_FULL["length_overall_m"] / lam,
        lateral_centroid_m=_WINDAGE_FULL["lateral_centroid_m"] / lam,
        surge_mass_kg=m + ship.m_x * half_rho_L2_d,
        sway_mass_kg=m + ship.m_y * half_rho_L2_d,
        yaw_inertia_kgm2=m * ship.yaw_gyration_radius_m**2
        + ship.x_g_m**2 * m
        + ship.J_z * half_rho_L2_d * ship.length_m**2,
        sway_yaw_coupling_kgm=ship.x_g_m * m,
    )


@dataclass(frozen=True)
class EnvironmentForces:
    """What the environment adds to the MMG equations at one state (module docstring).

    Attributes
    ----------
    X_wind_N, Y_wind_N : float
        Wind force at midship, forward and to starboard [N]: Blendermann's load in the
        apparent wind minus the load of the ship's own motion through still air.
    N_wind_Nm : float
        Wind yaw moment about midship, positive turning to starboard [N m].
    X_current_N, Y_current_N : float
        Force of a changing current, -m R^T c_dot at midship [N].
    N_current_Nm : float
        Its moment about midship, -x_G m c_dot_v [N m].
    current_north_mps, current_east_mps : float
        The current's velocity over ground c_N, c_E [m/s].

    """

    X_wind_N: float
    Y_wind_N: float
    N_wind_Nm: float
    X_current_N: float
    Y_current_N: float
    N_current_Nm: float
    current_north_mps: float
    current_east_mps: float


def environment_forces(
    ship: MmgShip,
    state: np.ndarray,
    environment: SeaEnvironment,
    *,
    windage: Windage | None = None,
    time_s: float = 0.0,
) -> EnvironmentForces:
    """Return the forces the current and the wind add to the MMG equations at one state.

    Parameters
    ----------
    ship : MmgShip
        The ship.
    state : numpy.ndarray
        ``[u, v_m, r, x, y, psi]`` (velocities through the water), shape (6,).
    environment : SeaEnvironment
        Current and wind.
    windage : Windage, optional
        The ship's windage; :func:`kvlcc2_windage` of the ship's scale when None.
    time_s : float
        Time from the start of the run [s].

    Returns
    -------
    EnvironmentForces
        Wind and current forces [N] and moments [N m] at midship, and the current.

    """
    u, v, _, _, _, psi = (float(s) for s in state)
    sea = _SeaRun(ship, environment, windage)
    c_n, c_e, dc_n, dc_e = environment.current_ne(time_s)
    X_w, Y_w, N_w = sea.wind_forces(u, v, psi, c_n, c_e, time_s)
    X_c, Y_c, N_c = sea.current_forces(psi, dc_n, dc_e)
    return EnvironmentForces(X_w, Y_w, N_w, X_c, Y_c, N_c, c_n, c_e)


class _SeaRun:
    """One run's environment for one ship: the current, the wind with its gust path."""

    def __init__(self, ship: MmgShip, environment: SeaEnvironment, windage: Windage | None) -> None:
        self.ship = ship
        self.environment = environment
        if windage is None:
            if ship.name != "kvlcc2":
                raise ValueError(f"no windage known for {ship.name!r}: give one")
            windage = kvlcc2_windage(ship.scale)
        self.windage = windage
        self.gust_time_s = (
            default_gust_time_s(ship.length_m)
            if environment.gust_time_s is None
            else environment.gust_time_s
        )
        self.gust = GustProcess(environment.gust_std_mps, self.gust_time_s, environment.gust_seed)

    def wind_speed(self, time_s: float) -> float:
        """Return the true wind speed W = W_mean + g(t) along the mean direction [m/s]."""
        return self.environment.wind_speed_mps + self.gust.value(time_s)

    def wind_forces(
        self, u: float, v: float, psi: float, c_n: float, c_e: float, time_s: float
    ) -> tuple[float, float, float]:
        """X [N], Y [N], N [N m] at midship that the true wind adds (module docstring)."""
        if not self.environment.has_wind:
            return 0.0, 0.0, 0.0
        u_g, v_g = ground_velocity_body(u, v, psi, c_n, c_e)
        # [the true wind, still air]: the same ship motion, one evaluation
        speed, angle = apparent_wind(
            np.array([self.wind_speed(time_s), 0.0]),
            self.environment.wind_from_rad,
            psi,
            u_g,
            v_g,
        )
        X, Y, N = wind_loads(speed, angle, self.windage, AIR_DENSITY_KGPM3, TANKER_LOADED)
        return float(X[0] - X[1]), float(Y[0] - Y[1]), float(N[0] - N[1])

    def current_forces(self, psi: float, dc_n: float, dc_e: float) -> tuple[float, float, float]:
        """-m R^T c_dot at the CG as X, Y [N] at midship and N [N m] about it."""
        m = self.ship.mass_kg
        cos_psi = math.cos(psi)
        sin_psi = math.sin(psi)
        dc_u = dc_n * cos_psi + dc_e * sin_psi
        dc_v = -dc_n * sin_psi + dc_e * cos_psi
        return -m * dc_u, -m * dc_v, -self.ship.x_g_m * m * dc_v

    def apparent_wind(
        self, time_s: np.ndarray, u: np.ndarray, v: np.ndarray, psi: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Apparent wind speed [m/s] and angle off the bow [rad] at the given states."""
        current = np.array([self.environment.current_ne(float(t))[:2] for t in time_s])
        c_n = current[:, 0] if current.size else np.zeros(0)
        c_e = current[:, 1] if current.size else np.zeros(0)
        u_g, v_g = ground_velocity_body(u, v, psi, c_n, c_e)
        wind = self.environment.wind_speed_mps + self.gust.values(time_s)
        return apparent_wind(wind, self.environment.wind_from_rad, psi, u_g, v_g)


def _derivatives_at_sea(
    ship: MmgShip,
    sea: _SeaRun,
    u: float,
    v: float,
    r: float,
    psi: float,
    delta: float,
    n: float,
    time_s: float,
) -> tuple[float, float, float, float, float, float]:
    """:func:`_derivatives` with the current and the wind (module docstring).

    In calm conditions every added term is 0.0, so the result is the calm one bit for bit.
    """
    f = _modules(ship, u, v, r, delta, n)
    c_n, c_e, dc_n, dc_e = sea.environment.current_ne(time_s)
    X_w, Y_w, N_w = sea.wind_forces(u, v, psi, c_n, c_e, time_s)
    X_c, Y_c, N_c = sea.current_forces(psi, dc_n, dc_e)
    u_dot, v_dot, r_dot = _accelerations(
        ship,
        u,
        v,
        r,
        f.X_H + f.X_P + f.X_R + X_w + X_c,
        f.Y_H + f.Y_R + Y_w + Y_c,
        f.N_H + f.N_R + N_w + N_c,
    )
    cos_psi = math.cos(psi)
    sin_psi = math.sin(psi)
    x_dot = u * cos_psi - v * sin_psi + c_n  # the track moves over ground
    y_dot = u * sin_psi + v * cos_psi + c_e
    return u_dot, v_dot, r_dot, x_dot, y_dot, r


def step(
    ship: MmgShip, state: np.ndarray, rudder_rad: float, n_rps: float, dt_s: float
) -> np.ndarray:
    """Advance the state by one communication step with constant inputs.

    Classical fourth-order Runge-Kutta with equal internal sub-steps no longer than
    0.05 s full-scale equivalent (0.05 s * sqrt(L / 320 m)). This is the "plant"
    interface a fixed-step driver uses like an FMU's ``doStep``.

    Parameters
    ----------
    ship : MmgShip
        The ship.
    state : numpy.ndarray
        ``[u, v_m, r, x, y, psi]`` at the start of the step, shape (6,) (see `mmg_rhs`).
    rudder_rad : float
        Actual rudder angle held over the step [rad].
    n_rps : float
        Propeller speed held over the step [rev/s].
    dt_s : float
        Communication step, > 0 [s].

    Returns
    -------
    numpy.ndarray
        The state at the end of the step, shape (6,).

    Raises
    ------
    ValueError
        If ``dt_s`` is not a positive finite number.

    """
    if not (math.isfinite(dt_s) and dt_s > 0.0):
        raise ValueError(f"dt_s must be a positive finite number, got {dt_s!r}")
    h_max = _FULL_SCALE_MAX_SUBSTEP_S * math.sqrt(ship.length_m / _FULL_LENGTH_M)
    n_sub = max(1, math.ceil(dt_s / h_max - 1e-9))
    h = dt_s / n_sub
    inputs = (float(rudder_rad), float(n_rps))
    y = np.array(state, dtype=float)
    work = np.empty((5, 6))
    for _ in range(n_sub):
        rk4_into(_derivative_into, y, h, ship, inputs, inputs, inputs, work)
    return y


def _derivative_into(
    state: np.ndarray, ship: MmgShip, inputs: tuple[float, float], out: np.ndarray
) -> None:
    """``fmu_model.integrate`` form of :func:`mmg_rhs`: ṡ into ``out``."""
    u, v, r, _, _, psi = (float(s) for s in state)
    out[:] = _derivatives(ship, u, v, r, psi, *inputs)


def _derivative_at_sea_into(
    state: np.ndarray,
    context: tuple[MmgShip, _SeaRun],
    inputs: tuple[float, float, float],
    out: np.ndarray,
) -> None:
    """``fmu_model.integrate`` form of :func:`_derivatives_at_sea`; inputs (δ, n, t)."""
    u, v, r, _, _, psi = (float(s) for s in state)
    out[:] = _derivatives_at_sea(context[0], context[1], u, v, r, psi, *inputs)


class ReferencePlant(SingleShip):
    """The MMG reference ship as a plant of ``trials.run``, rudder held over each step.

    Parameters
    ----------
    ship : MmgShip
        The ship.
    environment : SeaEnvironment, optional
        Current and wind (module docstring); calm water when None (the calm-water
        equations, untouched). Its time runs from the last :meth:`reset`.
    windage : Windage, optional
        The ship's windage; :func:`kvlcc2_windage` of the ship's scale when None.

    """

    def __init__(
        self,
        ship: MmgShip,
        environment: SeaEnvironment | None = None,
        windage: Windage | None = None,
    ) -> None:
        self.ship = ship
        self.length_m = ship.length_m
        self.environment = environment
        self._windage = windage
        self._sea = None if environment is None else _SeaRun(ship, environment, windage)
        self._state = np.zeros(6)
        self._time_s = 0.0

    @property
    def gust_time_s(self) -> float | None:
        """Correlation time of the gusts in use [s]; None in calm water."""
        return None if self._sea is None else self._sea.gust_time_s

    def reset(self, initial_state: np.ndarray) -> None:
        """Start again from ``initial_state`` at time 0 (the same gusts again)."""
        self._state = np.array(initial_state, dtype=float)
        self._time_s = 0.0
        if self.environment is not None:
            self._sea = _SeaRun(self.ship, self.environment, self._windage)

    def step(self, rudder_rad: float, n_rps: float, dt_s: float) -> np.ndarray:
        """Advance ``dt_s`` (:func:`step`'s RK4 substeps)."""
        if self._sea is None:
            self._state = step(self.ship, self._state, rudder_rad, n_rps, dt_s)
            return self._state
        if not (math.isfinite(dt_s) and dt_s > 0.0):
            raise ValueError(f"dt_s must be a positive finite number, got {dt_s!r}")
        h_max = _FULL_SCALE_MAX_SUBSTEP_S * math.sqrt(self.ship.length_m / _FULL_LENGTH_M)
        n_sub = max(1, math.ceil(dt_s / h_max - 1e-9))
        h = dt_s / n_sub
        delta, n = float(rudder_rad), float(n_rps)
        work = np.empty((5, 6))
        context = (self.ship, self._sea)
        t0 = self._time_s
        for i in range(n_sub):
            t = t0 + i * h
            rk4_into(
                _derivative_at_sea_into,
                self._state,
                h,
                context,
                (delta, n, t),
                (delta, n, t + 0.5 * h),
                (delta, n, t + h),
                work,
            )
        self._time_s = t0 + dt_s
        return self._state

    def apparent_wind(
        self, time_s: np.ndarray, u: np.ndarray, v: np.ndarray, psi: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Return the apparent wind an anemometer at midship sees along a run of this plant.

        Parameters
        ----------
        time_s : numpy.ndarray
            Times from the start of the run (the last :meth:`reset`) [s].
        u, v : numpy.ndarray
            Surge and sway (midship) velocity through the water [m/s].
        psi : numpy.ndarray
            Heading [rad].

        Returns
        -------
        speed_mps, angle_rad : numpy.ndarray
            Apparent wind speed [m/s] and the angle it comes from off the bow, positive
            from starboard, in [-pi, pi] [rad]; ``fmu_model.environment.apparent_wind``.

        Raises
        ------
        ValueError
            In calm water (no environment).

        """
        if self._sea is None:
            raise ValueError("the plant sails in calm water: no apparent wind to give")
        sea = _SeaRun(self.ship, self._sea.environment, self._windage)  # the same gusts
        return sea.apparent_wind(
            np.asarray(time_s, dtype=float),
            np.asarray(u, dtype=float),
            np.asarray(v, dtype=float),
            np.asarray(psi, dtype=float),
        )


@dataclass(frozen=True)
class SteadyTurn:
    """Steady turning state of the MMG model (u_dot = v_dot = r_dot = 0).

    Attributes
    ----------
    rudder_rad : float
        Rudder angle [rad].
    n_rps : float
        Propeller speed [rev/s].
    u_mps, v_mps : float
        Surge and sway (midship) velocity [m/s].
    r_radps : float
        Yaw rate [rad/s], negative in a port turn.
    speed_mps : float
        Speed U = sqrt(u^2 + v_m^2) [m/s].
    speed_ratio : float
        U / U0 [-].
    yaw_rate_nd : float
        r' = r L / U [-], signed like r.
    drift_rad : float
        Drift angle beta = atan(-v_m/u) [rad], signed (positive in a starboard turn).
    diameter_m : float
        Diameter of the midship path 2 U / |r| [m] (``inf`` for a straight run).

    """

    rudder_rad: float
    n_rps: float
    u_mps: float
    v_mps: float
    r_radps: float
    speed_mps: float
    speed_ratio: float
    yaw_rate_nd: float
    drift_rad: float
    diameter_m: float


def equilibrium_turn(ship: MmgShip, rudder_rad: float, n_rps: float | None = None) -> SteadyTurn:
    """Solve the steady turn u_dot = v_dot = r_dot = 0 at a fixed rudder angle (ref. §10).

    Parameters
    ----------
    ship : MmgShip
        The ship.
    rudder_rad : float
        Rudder angle [rad].
    n_rps : float, optional
        Propeller speed [rev/s]; ``ship.nominal_rps`` by default.

    Returns
    -------
    SteadyTurn
        The steady state.

    Raises
    ------
    MmgConvergenceError
        If the non-linear solver does not converge.

    """
    n = ship.nominal_rps if n_rps is None else float(n_rps)
    delta = float(rudder_rad)
    U0 = ship.approach_speed_mps
    L = ship.length_m
    accel_unit = U0 * U0 / L

    def residual(z: np.ndarray) -> np.ndarray:
        # unknowns u/U0, v_m/U0, r L/U0; residuals in units of U0^2/L (and U0^2/L^2)
        u_dot, v_dot, r_dot, *_ = _derivatives(
            ship, z[0] * U0, z[1] * U0, z[2] * U0 / L, 0.0, delta, n
        )
        return np.array([u_dot / accel_unit, v_dot / accel_unit, r_dot * L / accel_unit])

    # start from a typical hard-over turn, scaled to the rudder angle
    side = math.copysign(1.0, delta) if delta != 0.0 else 0.0
    frac = min(abs(delta) / math.radians(35.0), 1.0)
    guesses = [
        np.array([1.0 - 0.6 * frac, -0.15 * frac * side, 0.33 * frac * side]),
        np.array([1.0, 0.0, 0.0]),
        np.array([0.4, -0.15 * side, 0.33 * side]),
    ]
    for z0 in guesses:
        sol = root(residual, z0, method="hybr", tol=1e-13)
        # judge by the residual: "hybr" may report "xtol too small" at the exact root
        if float(np.max(np.abs(residual(sol.x)))) < 1e-12 and sol.x[0] > 0.0:
            break
    else:
        raise MmgConvergenceError(
            f"no steady turn found for rudder {math.degrees(delta):.3f} deg, n = {n:.6g} rps"
        )
    u, v, r = float(sol.x[0]) * U0, float(sol.x[1]) * U0, float(sol.x[2]) * U0 / L
    U = math.hypot(u, v)
    return SteadyTurn(
        rudder_rad=delta,
        n_rps=n,
        u_mps=u,
        v_mps=v,
        r_radps=r,
        speed_mps=U,
        speed_ratio=U / U0,
        yaw_rate_nd=r * L / U,
        drift_rad=math.atan2(-v, u),
        diameter_m=2.0 * U / abs(r) if r != 0.0 else math.inf,
    )
