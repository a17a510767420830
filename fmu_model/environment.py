r"""Environment of a ship at sea: current, wind and the wind load (pure functions, SI).

Conventions (DESIGN.md): earth frame x North, y East; heading ψ clockwise from North;
body frame u forward, v to starboard, r (and the yaw moment N) positive turning to
starboard, i.e. clockwise seen from above.

* **Current** sets *towards* ``current_to_rad`` (clockwise from North) with speed
  ``current_speed_mps`` over ground; the hydrodynamic model sees the velocity through
  the water (u, v), the position moves with the velocity over ground:

  .. math::

      \dot x = u\cos\psi - v\sin\psi + c_N, \qquad
      \dot y = u\sin\psi + v\cos\psi + c_E

  (Fossen 2021, ch. 10: the current as an irrotational velocity, constant in the earth
  frame).
* **True wind** blows *from* ``wind_from_rad`` (clockwise from North) with speed
  ``wind_speed_mps`` relative to the ground, as a weather report gives it.
* **Apparent (relative) wind** is what an anemometer on board measures: the true
  wind minus the ship's velocity over ground, given as a speed V_r and the angle γ it
  comes from relative to the bow, γ ∈ [-π, π]: γ = 0 wind from ahead, γ > 0 from
  starboard, |γ| = π from astern.
* **Wind load** of Blendermann (1994), "Parameter identification of wind loads on
  ships", J. Wind Eng. Ind. Aerodyn. 51, 339-351, in the form of Fossen (2021),
  Handbook of Marine Craft Hydrodynamics and Motion Control, 2nd ed., Wiley,
  ch. 10.1.2, and of the MSS toolbox's ``blendermann94.m`` (Fossen & Perez,
  github.com/cybergalactic/MSS, LIBRARY/environment). Fossen measures γ positive from
  *port* (γ_F = -atan2(v_rw, u_rw)); here γ = -γ_F, so the sway force and the yaw
  moment change sign with respect to those texts while the surge force does not.
  Blendermann's yaw-moment formula is written for 0 ≤ γ ≤ π; for the other side
  it is continued by the ship's port-starboard symmetry (|γ| in its lever arm).

The identified models have the masses absorbed into their coefficients, so the loads
enter the equations of motion as accelerations: X/(m+m_x), and the sway and yaw
accelerations of the mass matrix about midship (Yasukawa & Yoshimura 2015, eq. (4)),

.. math::

    \begin{pmatrix} m+m_y & x_G m \\ x_G m & I_z+J_z \end{pmatrix}
    \begin{pmatrix} \dot v \\ \dot r \end{pmatrix}
    = \begin{pmatrix} Y \\ N \end{pmatrix},

with I_z = I_zG + x_G² m about midship and x_G the centre of gravity forward of it: the
effective inertias are part of :class:`Windage`. A centre of gravity off midship couples
the two (KVLCC2, x_G = 0.035 L: a beam wind's yaw acceleration 12–18 % off without the
coupling, 67 % off at 45° off the bow).

The wind formulas are written once, over a small math namespace (``numpy`` or
``sympy``): the numpy functions evaluate them, the FMU's C code and its derivatives
are generated from the sympy expressions of the same functions.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import MISSING, dataclass, fields
from types import ModuleType
from typing import Any, Protocol

import numpy as np
import sympy as sp

AIR_DENSITY_KGPM3 = 1.225
"""Density of air [kg/m³]: the ISO 2533:1975 standard atmosphere at sea level (15 °C,
101 325 Pa). MSS ``blendermann94.m`` uses 1.224 (20 °C); the 0.1 % difference is
below the scatter of any wind coefficient."""


@dataclass(frozen=True)
class BlendermannCoefficients:
    """One ship type's row of Blendermann's (1994) wind-load parameters.

    Parameters
    ----------
    cd_t : float
        Transverse drag coefficient C_Dt (beam wind) [-].
    cd_l_af_bow : float
        Longitudinal drag coefficient C_Dl,AF(0), wind from ahead (|γ| ≤ π/2) [-].
    cd_l_af_stern : float
        Longitudinal drag coefficient C_Dl,AF(π), wind from astern (|γ| > π/2) [-].
    delta : float
        Cross-force parameter δ [-].
    kappa : float
        Rolling-moment factor κ [-] (roll is not modelled; kept for completeness).

    """

    cd_t: float
    cd_l_af_bow: float
    cd_l_af_stern: float
    delta: float
    kappa: float


TANKER_LOADED = BlendermannCoefficients(
    cd_t=0.70, cd_l_af_bow=0.90, cd_l_af_stern=0.55, delta=0.40, kappa=3.1
)
"""Blendermann (1994), Table "Tanker, loaded"; Fossen (2021) Table 10.3; MSS
``blendermann94.m`` row 15."""

TANKER_IN_BALLAST = BlendermannCoefficients(
    cd_t=0.70, cd_l_af_bow=0.75, cd_l_af_stern=0.55, delta=0.40, kappa=2.2
)
"""Blendermann (1994), "Tanker, in ballast"; MSS ``blendermann94.m`` row 16."""


class WindageLike(Protocol):
    """Anything with the eight windage fields (a :class:`Windage` or its symbols)."""

    @property
    def frontal_area_m2(self) -> Any:
        """Frontal projected area A_F [m²]."""

    @property
    def lateral_area_m2(self) -> Any:
        """Lateral projected area A_L [m²]."""

    @property
    def length_overall_m(self) -> Any:
        """Length overall L_oa [m]."""

    @property
    def lateral_centroid_m(self) -> Any:
        """Centroid of A_L forward of midship s_L [m]."""

    @property
    def surge_mass_kg(self) -> Any:
        """Mass plus surge added mass m + m_x [kg]."""

    @property
    def sway_mass_kg(self) -> Any:
        """Mass plus sway added mass m + m_y [kg]."""

    @property
    def yaw_inertia_kgm2(self) -> Any:
        """Yaw inertia plus added inertia about midship I_z + J_z [kg m²]."""

    @property
    def sway_yaw_coupling_kgm(self) -> Any:
        """x_G·m, the mass's moment about midship [kg m]: the sway-yaw coupling."""


@dataclass(frozen=True)
class Windage:
    """Above-water geometry and effective inertias that turn wind into accelerations.

    Parameters
    ----------
    frontal_area_m2 : float
        Frontal projected area above the waterline A_F [m²], ≥ 0.
    lateral_area_m2 : float
        Lateral projected area above the waterline A_L [m²], ≥ 0; must be positive
        when ``frontal_area_m2`` is.
    length_overall_m : float
        Length overall L_oa [m], > 0.
    lateral_centroid_m : float
        Horizontal distance of A_L's centroid forward of midship [m] (Blendermann's
        s_L; MSS ``blendermann94.m`` calls it ``sL`` in the formula, though its
        docstring swaps the descriptions of ``sH`` and ``sL``). Negative = aft.
    surge_mass_kg : float
        Mass plus surge added mass m + m_x [kg], > 0.
    sway_mass_kg : float
        Mass plus sway added mass m + m_y [kg], > 0.
    yaw_inertia_kgm2 : float
        Yaw moment of inertia plus added inertia about midship I_z + J_z [kg m²]
        (I_z = I_zG + x_G² m), > 0.
    sway_yaw_coupling_kgm : float
        x_G·m [kg m], the centre of gravity x_G forward of midship times the mass: the
        off-diagonal of the sway-yaw mass matrix (module docstring). Default 0 (centre of
        gravity at midship; windage files written before it have none). Its square must
        stay below ``sway_mass_kg·yaw_inertia_kgm2``.

    Raises
    ------
    ValueError
        A non-finite value, a negative area, a non-positive length, mass or inertia,
        a frontal area without a lateral area, or a coupling that makes the sway-yaw
        mass matrix singular.

    """

    frontal_area_m2: float
    lateral_area_m2: float
    length_overall_m: float
    lateral_centroid_m: float
    surge_mass_kg: float
    sway_mass_kg: float
    yaw_inertia_kgm2: float
    sway_yaw_coupling_kgm: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise ValueError(f"windage {f.name} must be a number, got {value!r}")
            try:
                number = float(value)
            except OverflowError:  # an integer beyond the floating-point range
                number = math.inf
            if not math.isfinite(number):
                raise ValueError(f"windage {f.name} must be finite, got {number}")
            object.__setattr__(self, f.name, number)
        for name in ("frontal_area_m2", "lateral_area_m2"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"windage {name} must be >= 0, got {getattr(self, name)}")
        for name in ("length_overall_m", "surge_mass_kg", "sway_mass_kg", "yaw_inertia_kgm2"):
            if getattr(self, name) <= 0.0:
                raise ValueError(f"windage {name} must be > 0, got {getattr(self, name)}")
        if self.frontal_area_m2 > 0.0 and self.lateral_area_m2 == 0.0:
            raise ValueError("windage lateral_area_m2 must be > 0 when frontal_area_m2 is")
        if self.sway_yaw_coupling_kgm**2 >= self.sway_mass_kg * self.yaw_inertia_kgm2:
            raise ValueError(
                "windage sway_yaw_coupling_kgm must be below √(sway_mass_kg·yaw_inertia_kgm2) "
                f"in size, got {self.sway_yaw_coupling_kgm}"
            )

    @classmethod
    def none(cls, length_overall_m: float = 1.0) -> Windage:
        """No windage: zero areas, hence no wind load (unit placeholder inertias)."""
        return cls(0.0, 0.0, length_overall_m, 0.0, 1.0, 1.0, 1.0)

    @property
    def has_wind_load(self) -> bool:
        """True when the ship has an area the wind can act on."""
        return self.frontal_area_m2 > 0.0 or self.lateral_area_m2 > 0.0

    def to_dict(self) -> dict[str, float]:
        """Return the fields by name (keys carry their units), for params.json."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any]) -> Windage:
        """Build from :meth:`to_dict`'s mapping; raises ValueError naming a bad key."""
        if not isinstance(doc, Mapping):
            raise ValueError(f"windage must be an object, got {type(doc).__name__}")
        names = [f.name for f in fields(cls)]
        required = [f.name for f in fields(cls) if f.default is MISSING]
        missing = [n for n in required if n not in doc]
        unknown = sorted(set(doc) - set(names))
        if missing:
            raise ValueError(f"windage lacks {', '.join(missing)}")
        if unknown:
            raise ValueError(f"windage has unknown keys {', '.join(map(str, unknown))}")
        return cls(**{n: doc[n] for n in names if n in doc})


@dataclass(frozen=True)
class WindageSymbols:
    """The windage fields as sympy symbols (FMU parameters; unvalidated)."""

    frontal_area_m2: sp.Symbol
    lateral_area_m2: sp.Symbol
    length_overall_m: sp.Symbol
    lateral_centroid_m: sp.Symbol
    surge_mass_kg: sp.Symbol
    sway_mass_kg: sp.Symbol
    yaw_inertia_kgm2: sp.Symbol
    sway_yaw_coupling_kgm: sp.Symbol

    @classmethod
    def make(cls) -> WindageSymbols:
        """One real symbol per field, named as the field."""
        return cls(*(sp.Symbol(f.name, real=True) for f in fields(cls)))

    def as_tuple(self) -> tuple[sp.Symbol, ...]:
        """Return the symbols in field order."""
        return tuple(getattr(self, f.name) for f in fields(self))


WINDAGE_FIELDS = tuple(f.name for f in fields(Windage))
"""Names of the windage fields, in order (units in the names)."""


# --- the math namespaces the formulas are written over --------------------------------


class _NumpyMath:
    pi = np.pi
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    sqrt = staticmethod(np.sqrt)
    atan2 = staticmethod(np.arctan2)
    fabs = staticmethod(np.abs)

    @staticmethod
    def if_nonneg(x: Any, a: Any, b: Any) -> Any:
        """Return ``a`` where x ≥ 0, else ``b``."""
        return np.where(np.asarray(x) >= 0.0, a, b)

    @staticmethod
    def if_positive(x: Any, a: Any, b: Any) -> Any:
        """Return ``a`` where x > 0, else ``b``."""
        return np.where(np.asarray(x) > 0.0, a, b)


class _SympyMath:
    pi = sp.Float(math.pi)  # the double, not the symbol: C99 has no M_PI
    sin = staticmethod(sp.sin)
    cos = staticmethod(sp.cos)
    sqrt = staticmethod(sp.sqrt)
    atan2 = staticmethod(sp.atan2)
    fabs = staticmethod(sp.Abs)

    @staticmethod
    def if_nonneg(x: Any, a: Any, b: Any) -> Any:
        return sp.Piecewise((a, x >= 0), (b, True))

    @staticmethod
    def if_positive(x: Any, a: Any, b: Any) -> Any:
        return sp.Piecewise((a, x > 0), (b, True))


_NUMPY = _NumpyMath()
_SYMPY = _SympyMath()


def _ns(xp: ModuleType | Any) -> Any:
    """Return the namespace for ``xp``: the ``numpy`` or ``sympy`` module (or a namespace)."""
    if xp is np:
        return _NUMPY
    if xp is sp:
        return _SYMPY
    if isinstance(xp, (_NumpyMath, _SympyMath)):
        return xp
    raise ValueError(f"xp must be numpy or sympy, got {xp!r}")


def _wrap_pi(angle: Any) -> Any:
    """Angle to [-π, π] (numpy); values already inside are returned bit for bit."""
    angle = np.asarray(angle, dtype=float)
    wrapped = np.arctan2(np.sin(angle), np.cos(angle))
    return np.where(np.abs(angle) <= np.pi, angle, wrapped)


# --- current and kinematics -------------------------------------------------------------


def current_velocity_ne(
    current_speed_mps: Any, current_to_rad: Any, xp: ModuleType = np
) -> tuple[Any, Any]:
    """Velocity of the current in the earth frame.

    Parameters
    ----------
    current_speed_mps : float or array
        Speed of the current over ground [m/s].
    current_to_rad : float or array
        Direction the current sets *towards*, clockwise from North [rad].
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    north, east : float or array
        Current velocity c_N, c_E [m/s].

    """
    m = _ns(xp)
    return current_speed_mps * m.cos(current_to_rad), current_speed_mps * m.sin(current_to_rad)


def ground_velocity_ne(
    u: Any, v: Any, psi_rad: Any, current_north_mps: Any, current_east_mps: Any,
    xp: ModuleType = np,
) -> tuple[Any, Any]:  # fmt: skip
    """Velocity over ground in the earth frame: the kinematics with current.

    ẋ = u cos ψ − v sin ψ + c_N,  ẏ = u sin ψ + v cos ψ + c_E  (Fossen 2021, ch. 10).
    With zero current the result is bit for bit the kinematics without current.

    Parameters
    ----------
    u, v : float or array
        Surge and sway velocity through the water [m/s].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    current_north_mps, current_east_mps : float or array
        Current velocity c_N, c_E [m/s] (:func:`current_velocity_ne`).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    x_dot, y_dot : float or array
        Velocity over ground, North and East [m/s].

    """
    m = _ns(xp)
    c, s = m.cos(psi_rad), m.sin(psi_rad)
    return u * c - v * s + current_north_mps, u * s + v * c + current_east_mps


def ground_velocity_body(
    u: Any, v: Any, psi_rad: Any, current_north_mps: Any, current_east_mps: Any,
    xp: ModuleType = np,
) -> tuple[Any, Any]:  # fmt: skip
    """Velocity over ground in the body frame: (u, v) plus the current rotated aboard.

    Parameters
    ----------
    u, v : float or array
        Surge and sway velocity through the water [m/s].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    current_north_mps, current_east_mps : float or array
        Current velocity c_N, c_E [m/s].
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    u_ground, v_ground : float or array
        Forward and starboard velocity over ground [m/s].

    """
    m = _ns(xp)
    c, s = m.cos(psi_rad), m.sin(psi_rad)
    return (
        u + current_north_mps * c + current_east_mps * s,
        v - current_north_mps * s + current_east_mps * c,
    )


def speed_over_ground(north_mps: Any, east_mps: Any, xp: ModuleType = np) -> Any:
    """Speed over ground SOG = √(ẋ² + ẏ²) [m/s] from the earth-frame velocity [m/s]."""
    m = _ns(xp)
    return m.sqrt(north_mps * north_mps + east_mps * east_mps)


def course_over_ground(north_mps: Any, east_mps: Any, xp: ModuleType = np) -> Any:
    """Course over ground COG = atan2(ẏ, ẋ) ∈ [-π, π], clockwise from North [rad].

    The direction of the velocity over ground (North, East) [m/s]; 0 at rest.
    """
    return _ns(xp).atan2(east_mps, north_mps)


# --- wind -------------------------------------------------------------------------------


def apparent_wind_components(
    wind_speed_mps: Any,
    wind_from_rad: Any,
    psi_rad: Any,
    u_ground_mps: Any,
    v_ground_mps: Any,
    xp: ModuleType = np,
) -> tuple[Any, Any]:
    """Apparent wind as the vector it comes from, in the body frame: (V_r cos γ, V_r sin γ).

    With β − ψ the true wind's angle off the bow (β the direction it comes from),

        a = V_w cos(β − ψ) + u_g,  b = V_w sin(β − ψ) + v_g,

    i.e. minus the air's velocity relative to the ship (the true wind blows towards
    β + π; the ship moves with (u_g, v_g) over ground).

    Parameters
    ----------
    wind_speed_mps : float or array
        True wind speed relative to the ground [m/s].
    wind_from_rad : float or array
        Direction the true wind comes *from*, clockwise from North [rad].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    u_ground_mps, v_ground_mps : float or array
        Ship's velocity over ground in the body frame [m/s]
        (:func:`ground_velocity_body`; u, v when there is no current).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    ahead_mps, starboard_mps : float or array
        a: the component from ahead, b: the component from starboard [m/s].

    """
    m = _ns(xp)
    off_bow = wind_from_rad - psi_rad
    return (
        wind_speed_mps * m.cos(off_bow) + u_ground_mps,
        wind_speed_mps * m.sin(off_bow) + v_ground_mps,
    )


def apparent_wind(
    wind_speed_mps: Any,
    wind_from_rad: Any,
    psi_rad: Any,
    u_ground_mps: Any,
    v_ground_mps: Any,
    xp: ModuleType = np,
) -> tuple[Any, Any]:
    """Apparent (relative) wind: what an anemometer on board measures.

    V_r = √(a² + b²), γ = atan2(b, a), with (a, b) of :func:`apparent_wind_components`.

    Example: ship at 5 m/s heading North, wind 10 m/s from East → V_r = 11.18 m/s,
    γ = 63.4° (from starboard, ahead of the beam).

    Parameters
    ----------
    wind_speed_mps : float or array
        True wind speed relative to the ground [m/s].
    wind_from_rad : float or array
        Direction the true wind comes *from*, clockwise from North [rad].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    u_ground_mps, v_ground_mps : float or array
        Ship's velocity over ground in the body frame [m/s]
        (:func:`ground_velocity_body`; u, v when there is no current).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    speed_mps : float or array
        Apparent wind speed V_r [m/s].
    angle_rad : float or array
        Apparent wind angle γ ∈ [-π, π] it comes from, relative to the bow, positive
        from starboard [rad].

    """
    m = _ns(xp)
    a, b = apparent_wind_components(
        wind_speed_mps, wind_from_rad, psi_rad, u_ground_mps, v_ground_mps, m
    )
    return m.sqrt(a * a + b * b), m.atan2(b, a)


def true_wind(
    apparent_speed_mps: Any,
    apparent_angle_rad: Any,
    psi_rad: Any,
    u_ground_mps: Any,
    v_ground_mps: Any,
) -> tuple[Any, Any]:
    """Return the true wind from the apparent wind (inverse of :func:`apparent_wind`).

    For logs that carry the relative wind: V_r (cos γ, sin γ) − (u_g, v_g) is the
    true wind's "from" vector in the body frame; rotated by ψ it gives the direction.

    Parameters
    ----------
    apparent_speed_mps : float or array
        Apparent wind speed V_r [m/s].
    apparent_angle_rad : float or array
        Apparent wind angle γ off the bow, positive from starboard [rad].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    u_ground_mps, v_ground_mps : float or array
        Ship's velocity over ground in the body frame [m/s].

    Returns
    -------
    speed_mps : float or array
        True wind speed over ground [m/s].
    from_rad : float or array
        Direction the true wind comes from, clockwise from North, in [0, 2π) [rad].

    """
    a = apparent_speed_mps * np.cos(apparent_angle_rad) - u_ground_mps
    b = apparent_speed_mps * np.sin(apparent_angle_rad) - v_ground_mps
    direction = np.mod(np.arctan2(b, a) + psi_rad, 2.0 * np.pi)
    direction = np.where(direction >= 2.0 * np.pi, 0.0, direction)
    speed = np.hypot(a, b)
    if np.ndim(speed) == 0:
        return float(speed), float(direction)
    return speed, direction


def blendermann_coefficients(
    angle_rad: Any,
    windage: WindageLike,
    coefficients: BlendermannCoefficients = TANKER_LOADED,
    xp: ModuleType = np,
) -> tuple[Any, Any, Any]:
    """Wind-load coefficients C_X, C_Y, C_N of Blendermann (1994).

    With γ the apparent wind angle (here positive from starboard, see the module
    docstring), C_Dl = C_Dl,AF(γ) A_F / A_L and (Blendermann 1994; Fossen 2021,
    §10.1.2; MSS ``blendermann94.m``; all with γ_F = -γ):

        den = 1 − δ/2 (1 − C_Dl/C_Dt) sin²(2γ)
        C_X = −C_Dl,AF(γ) cos γ / den
        C_Y = −C_Dt sin γ / den
        C_N = [s_L/L_oa − 0.18 (|γ| − π/2)] C_Y

    C_Dl,AF(γ) is C_Dl,AF(0) for |γ| ≤ π/2 (cos γ ≥ 0) and C_Dl,AF(π) otherwise
    (MSS ``blendermann94.m``). With A_L = 0 (no windage) A_L is taken as 1 m² in
    C_Dl, so that nothing divides by zero (the loads are 0 then).

    Parameters
    ----------
    angle_rad : float or array
        Apparent wind angle γ off the bow, positive from starboard [rad]; numpy
        wraps it to [-π, π], sympy expects it there (``atan2``).
    windage : Windage or WindageSymbols
        Areas, length overall and centroid (the inertias are not used).
    coefficients : BlendermannCoefficients
        The ship type's row (default: tanker, loaded).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    cx, cy, cn : float or array
        Coefficients of X = ½ρV_r²A_F C_X, Y = ½ρV_r²A_L C_Y, N = ½ρV_r²A_L L_oa C_N
        [-]: X forward, Y to starboard, N turning to starboard.

    """
    m = _ns(xp)
    gamma = _wrap_pi(angle_rad) if m is _NUMPY else angle_rad
    k = coefficients
    cos_g, sin_g = m.cos(gamma), m.sin(gamma)
    cd_l_af = m.if_nonneg(cos_g, k.cd_l_af_bow, k.cd_l_af_stern)
    # C_Dl / C_Dt; A_L = 0 is replaced by 1 m² in the quotient, which then is 0 (a
    # Windage has no A_F > 0 with A_L = 0), so that no branch divides by zero.
    a_l = m.if_positive(windage.lateral_area_m2, windage.lateral_area_m2, 1.0)
    ratio = cd_l_af * windage.frontal_area_m2 / (k.cd_t * a_l)
    sin_2g = 2.0 * sin_g * cos_g
    den = 1.0 - 0.5 * k.delta * (1.0 - ratio) * sin_2g * sin_2g  # Blendermann (1994)
    cx = -cd_l_af * cos_g / den  # Blendermann (1994); Fossen (2021) §10.1.2
    cy = -k.cd_t * sin_g / den  # ibid. with γ = -γ_F: wind from starboard pushes to port
    lever = windage.lateral_centroid_m / windage.length_overall_m - 0.18 * (
        m.fabs(gamma) - m.pi / 2
    )
    cn = lever * cy  # ibid., continued to γ < 0 by symmetry (|γ|)
    return cx, cy, cn


def wind_loads(
    apparent_speed_mps: Any,
    apparent_angle_rad: Any,
    windage: WindageLike,
    air_density_kgpm3: float = AIR_DENSITY_KGPM3,
    coefficients: BlendermannCoefficients = TANKER_LOADED,
    xp: ModuleType = np,
) -> tuple[Any, Any, Any]:
    """Wind force and moment of Blendermann (1994) in the body frame.

    X = ½ρ V_r² A_F C_X,  Y = ½ρ V_r² A_L C_Y,  N = ½ρ V_r² A_L L_oa C_N
    (Fossen 2021, §10.1; coefficients of :func:`blendermann_coefficients`).

    Parameters
    ----------
    apparent_speed_mps : float or array
        Apparent wind speed V_r [m/s].
    apparent_angle_rad : float or array
        Apparent wind angle γ off the bow, positive from starboard [rad].
    windage : Windage or WindageSymbols
        The ship's windage.
    air_density_kgpm3 : float
        ρ [kg/m³].
    coefficients : BlendermannCoefficients
        The ship type's row (default: tanker, loaded).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    x_n, y_n : float or array
        Surge force (forward) and sway force (to starboard) [N].
    n_nm : float or array
        Yaw moment, positive turning to starboard [N m].

    """
    cx, cy, cn = blendermann_coefficients(apparent_angle_rad, windage, coefficients, xp)
    q = 0.5 * air_density_kgpm3 * apparent_speed_mps * apparent_speed_mps  # dynamic pressure
    a_l = windage.lateral_area_m2
    return (
        q * windage.frontal_area_m2 * cx,
        q * a_l * cy,
        q * a_l * windage.length_overall_m * cn,
    )


def wind_accelerations(
    apparent_speed_mps: Any,
    apparent_angle_rad: Any,
    windage: WindageLike,
    air_density_kgpm3: float = AIR_DENSITY_KGPM3,
    coefficients: BlendermannCoefficients = TANKER_LOADED,
    xp: ModuleType = np,
) -> tuple[Any, Any, Any]:
    """Accelerations of the wind load: X/(m+m_x), and v̇, ṙ of the sway-yaw mass matrix.

    The 2×2 system of the module docstring solved by Cramer's rule (one expression for
    numpy and sympy): v̇ = ((I_z+J_z)Y − x_G m N)/Δ, ṙ = ((m+m_y)N − x_G m Y)/Δ,
    Δ = (m+m_y)(I_z+J_z) − (x_G m)²; with x_G m = 0, Y/(m+m_y) and N/(I_z+J_z).

    Parameters
    ----------
    apparent_speed_mps : float or array
        Apparent wind speed V_r [m/s].
    apparent_angle_rad : float or array
        Apparent wind angle γ off the bow, positive from starboard [rad].
    windage : Windage or WindageSymbols
        The ship's windage, with its effective inertias.
    air_density_kgpm3 : float
        ρ [kg/m³].
    coefficients : BlendermannCoefficients
        The ship type's row (default: tanker, loaded).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    du, dv : float or array
        Surge and sway accelerations [m/s²].
    dr : float or array
        Yaw acceleration [rad/s²].

    """
    x_n, y_n, n_nm = wind_loads(
        apparent_speed_mps, apparent_angle_rad, windage, air_density_kgpm3, coefficients, xp
    )
    sway, yaw, coupling = (
        windage.sway_mass_kg,
        windage.yaw_inertia_kgm2,
        windage.sway_yaw_coupling_kgm,
    )
    det = sway * yaw - coupling * coupling
    return (
        x_n / windage.surge_mass_kg,
        (yaw * y_n - coupling * n_nm) / det,
        (sway * n_nm - coupling * y_n) / det,
    )


def environment_accelerations(
    u: Any,
    v: Any,
    psi_rad: Any,
    current_north_mps: Any,
    current_east_mps: Any,
    wind_speed_mps: Any,
    wind_from_rad: Any,
    windage: WindageLike,
    air_density_kgpm3: float = AIR_DENSITY_KGPM3,
    coefficients: BlendermannCoefficients = TANKER_LOADED,
    xp: ModuleType = np,
) -> tuple[Any, Any, Any]:
    """Wind accelerations from the ship's motion, the current and the true wind.

    The chain :func:`ground_velocity_body` → :func:`apparent_wind` →
    :func:`wind_accelerations`, written so that its sympy form differentiates and
    compiles to C without a division by zero: at zero apparent wind the result is 0
    (the loads are O(V_r²), so are their derivatives' limits), taken by a guard.

    Parameters
    ----------
    u, v : float or array
        Surge and sway velocity through the water [m/s].
    psi_rad : float or array
        Heading, clockwise from North [rad].
    current_north_mps, current_east_mps : float or array
        Current velocity c_N, c_E [m/s].
    wind_speed_mps : float or array
        True wind speed over ground [m/s].
    wind_from_rad : float or array
        Direction the true wind comes from, clockwise from North [rad].
    windage : Windage or WindageSymbols
        The ship's windage.
    air_density_kgpm3 : float
        ρ [kg/m³].
    coefficients : BlendermannCoefficients
        The ship type's row (default: tanker, loaded).
    xp : module
        ``numpy`` (default) or ``sympy``.

    Returns
    -------
    du, dv : float or array
        Surge and sway accelerations [m/s²].
    dr : float or array
        Yaw acceleration [rad/s²].

    """
    m = _ns(xp)
    u_g, v_g = ground_velocity_body(u, v, psi_rad, current_north_mps, current_east_mps, m)
    a, b = apparent_wind_components(wind_speed_mps, wind_from_rad, psi_rad, u_g, v_g, m)
    speed_sq = a * a + b * b
    loads = wind_accelerations(
        m.sqrt(speed_sq), m.atan2(b, a), windage, air_density_kgpm3, coefficients, m
    )
    du, dv, dr = (m.if_positive(speed_sq, load, 0.0 * load) for load in loads)
    return du, dv, dr


def environment_derivative(
    state: Any,
    current_speed_mps: Any,
    current_to_rad: Any,
    wind_speed_mps: Any,
    wind_from_rad: Any,
    windage: Windage | None,
) -> np.ndarray:
    """Return what the environment adds to d/dt (u, v, r, x, y, ψ) of a model (numpy).

    (X/(m+m_x), Y/(m+m_y), N/(I_z+J_z), c_N, c_E, 0): the wind's accelerations of
    :func:`environment_accelerations` and the current's velocity of
    :func:`current_velocity_ne`, the terms the FMU adds to the model's right-hand side
    (``fmu_model.structure.current_terms`` ... ``wind_terms``, the same formulas).

    Parameters
    ----------
    state : array
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]), shape (6,) + batch.
    current_speed_mps, current_to_rad : float or array
        Current over ground [m/s] and the direction it sets towards [rad].
    wind_speed_mps, wind_from_rad : float or array
        True wind over ground [m/s] and the direction it comes from [rad].
    windage : Windage or None
        The ship's windage; ``None``: no wind load.

    Returns
    -------
    numpy.ndarray
        Shape (6,) + the broadcast batch shape.

    """
    u, v, psi = state[0], state[1], state[5]
    c_north, c_east = current_velocity_ne(current_speed_mps, current_to_rad)
    wind: tuple[Any, Any, Any] = (0.0, 0.0, 0.0)
    if windage is not None:
        wind = environment_accelerations(
            u, v, psi, c_north, c_east, wind_speed_mps, wind_from_rad, windage
        )
    rest = np.zeros(np.broadcast_shapes(np.shape(u), np.shape(wind_speed_mps)))
    return np.array(np.broadcast_arrays(*wind, c_north, c_east, rest), dtype=float)
