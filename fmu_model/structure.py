r"""Symbolic definition of manoeuvring-model structures: the one place the equations live.

Every model variant in this project is *linear in its coefficients*: each body-frame
acceleration is a sum of coefficient × regressor,

.. math::

    \dot u = \sum_i a_i \, \phi^u_i(u, v, r, \delta, n), \quad
    \dot v = \sum_j b_j \, \phi^v_j(\ldots), \quad
    \dot r = \sum_k c_k \, \phi^r_k(\ldots),

with masses and inertias absorbed into the coefficients (Shi et al. 2009, eq. (2)).
A structure is therefore just three tuples of :class:`Term` (a coefficient name and its
regressor as a sympy expression). Everything numeric derives from it:

* the numpy right-hand side, the analytic Jacobians ∂f/∂x and ∂f/∂θ (``fmu_model.numeric``),
* the C source of the native FMU (``fmu_model.codegen``),
* the units of every coefficient (:func:`coefficient_unit`).

Symbols (SI inside): ``u, v`` [m/s], ``r`` [rad/s], ``delta`` rudder angle [rad],
``n`` propeller speed [rev/s], ``L`` ship length [m]; kinematics in ``x, y`` [m] (North,
East) and heading ``psi`` [rad] clockwise from North.

The environment (current and wind, :mod:`fmu_model.environment`) is not part of a
structure: it adds the same terms to every structure's equations,
:data:`ENVIRONMENT_TERMS`, in the environment symbols (:data:`ENVIRONMENT_SYMBOLS`) and
the windage parameters (:data:`WINDAGE_SYMBOLS`); the FMU and ``fmu_model.simulate``
add them to the right-hand side of the structure, which stays as it is.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cache, cached_property

import sympy as sp

from fmu_model import environment

# Motion state, inputs and the one vessel constant a structure may use.
u, v, r = sp.symbols("u v r", real=True)
x, y, psi = sp.symbols("x y psi", real=True)
delta = sp.Symbol("delta", real=True)
n = sp.Symbol("n", real=True)
L = sp.Symbol("L", positive=True)

VELOCITY_SYMBOLS = (u, v, r)
STATE_SYMBOLS = (u, v, r, x, y, psi)
INPUT_SYMBOLS = (delta, n)
STATE_NAMES = ("u", "v", "r", "x", "y", "psi")
EQUATIONS = ("surge", "sway", "yaw")

# Earth-fixed kinematics, x North, y East, psi clockwise from North (DESIGN.md
# conventions; Shi et al. 2009, Fig. 1):  x' = u cos psi - v sin psi,
# y' = u sin psi + v cos psi,  psi' = r.
KINEMATICS = (u * sp.cos(psi) - v * sp.sin(psi), u * sp.sin(psi) + v * sp.cos(psi), r)

# The environment: current over ground, speed [m/s] and the direction it sets towards
# [rad]; true wind over ground, speed [m/s] and the direction it comes from [rad]
# (both clockwise from North), and the ship's windage (fmu_model.environment.Windage).
current_speed, current_direction = sp.symbols("current_speed current_direction", real=True)
wind_speed, wind_direction = sp.symbols("wind_speed wind_direction", real=True)
ENVIRONMENT_SYMBOLS = (current_speed, current_direction, wind_speed, wind_direction)
WINDAGE_SYMBOLS = environment.WindageSymbols.make()
# The apparent wind's "from" vector in the body frame [m/s] (ahead, starboard): the
# intermediate through which the wind load depends on the state and the environment.
wind_ahead, wind_starboard = sp.symbols("wind_ahead wind_starboard", real=True)
# Velocity over ground, North and East [m/s]: the intermediate of the ground outputs.
ground_north, ground_east = sp.symbols("ground_north ground_east", real=True)


@cache
def current_terms() -> tuple[sp.Expr, sp.Expr]:
    """Velocity of the current (c_N, c_E) [m/s], added to x' and y' of :data:`KINEMATICS`.

    x' = (u cos ψ − v sin ψ) + c_N, y' = (u sin ψ + v cos ψ) + c_E (Fossen 2021,
    ch. 10; :func:`fmu_model.environment.ground_velocity_ne`).
    """
    return environment.current_velocity_ne(current_speed, current_direction, sp)


@cache
def apparent_wind_terms() -> tuple[sp.Expr, sp.Expr]:
    """Return (:data:`wind_ahead`, :data:`wind_starboard`) in the state and the environment.

    :func:`fmu_model.environment.apparent_wind_components` of the ship's velocity over
    ground (through the water plus the current).
    """
    c_north, c_east = current_terms()
    u_ground, v_ground = environment.ground_velocity_body(u, v, psi, c_north, c_east, sp)
    return environment.apparent_wind_components(
        wind_speed, wind_direction, psi, u_ground, v_ground, sp
    )


@cache
def wind_terms() -> tuple[sp.Expr, sp.Expr, sp.Expr]:
    """Return the wind's accelerations (u', v', r') in the apparent wind and the windage.

    :func:`fmu_model.environment.wind_accelerations` (Blendermann 1994, loaded tanker)
    of V_r = √(a² + b²), γ = atan2(b, a) with a = :data:`wind_ahead`,
    b = :data:`wind_starboard`, and :data:`WINDAGE_SYMBOLS`; added to the structure's
    accelerations. Defined for a² + b² > 0; the terms are O(a² + b²), so they and their
    derivatives are 0 at a = b = 0, where the generated code takes 0.
    """
    speed = sp.sqrt(wind_ahead**2 + wind_starboard**2)
    angle = sp.atan2(wind_starboard, wind_ahead)
    du, dv, dr = environment.wind_accelerations(speed, angle, WINDAGE_SYMBOLS, xp=sp)
    return du, dv, dr


def ground_terms() -> tuple[sp.Expr, sp.Expr]:
    """Return (:data:`ground_north`, :data:`ground_east`): the kinematics with current [m/s]."""
    c_north, c_east = current_terms()
    return KINEMATICS[0] + c_north, KINEMATICS[1] + c_east


def ground_outputs() -> tuple[sp.Expr, sp.Expr]:
    """Speed over ground [m/s] and course over ground [rad] of the velocity over ground.

    √(N² + E²) and atan2(E, N) in N = :data:`ground_north`, E = :data:`ground_east`
    (:func:`fmu_model.environment.speed_over_ground`, ``course_over_ground``).
    """
    return (
        environment.speed_over_ground(ground_north, ground_east, sp),
        environment.course_over_ground(ground_north, ground_east, sp),
    )


# SI dimensions as exponents of (metre, second). Angles and revolutions are
# dimensionless; r is rad/s and n is rev/s, both 1/s.
_DIMENSIONS: dict[sp.Symbol, tuple[int, int]] = {
    u: (1, -1),
    v: (1, -1),
    r: (0, -1),
    delta: (0, 0),
    n: (0, -1),
    L: (1, 0),
}
# Units of the accelerations u', v' [m/s^2] and r' [rad/s^2].
_ACCELERATION_DIMENSIONS = {"surge": (1, -2), "sway": (1, -2), "yaw": (0, -2)}


@dataclass(frozen=True)
class Term:
    """One coefficient × regressor term of an acceleration equation.

    Parameters
    ----------
    coefficient : str
        Coefficient name, unique within the structure (e.g. ``"a1"``).
    regressor : sympy.Expr
        Regressor in the module's symbols (e.g. ``u**2``).
    prior_std : float or None
        Standard deviation of a zero-mean Gaussian prior on the coefficient, for a term
        that should count only where the logs determine it (the identifier's equation-
        error fit, ``identifier.equation_error``); None: no prior.

    """

    coefficient: str
    regressor: sp.Expr
    prior_std: float | None = None


@dataclass(frozen=True)
class ModelStructure:
    """A manoeuvring-model variant: three linear-in-coefficient acceleration equations.

    Parameters
    ----------
    name : str
        Registry name (``--model NAME``).
    description : str
        One line for help texts and the FMU description.
    reference : str
        Where the equations come from.
    surge, sway, yaw : tuple of Term
        Terms of u', v' and r'.

    """

    name: str
    description: str
    reference: str
    surge: tuple[Term, ...]
    sway: tuple[Term, ...]
    yaw: tuple[Term, ...]

    def __post_init__(self) -> None:
        names = [t.coefficient for t in self.terms]
        if len(set(names)) != len(names):
            raise ValueError(f"model {self.name!r}: duplicate coefficient names in {names}")
        allowed = set(VELOCITY_SYMBOLS) | set(INPUT_SYMBOLS) | {L}
        for term in self.terms:
            extra = term.regressor.free_symbols - allowed
            if extra:
                raise ValueError(
                    f"model {self.name!r}: term {term.coefficient} uses unknown symbols {extra}"
                )

    @property
    def terms(self) -> tuple[Term, ...]:
        """All terms, surge first, then sway, then yaw (the coefficient-vector order)."""
        return self.surge + self.sway + self.yaw

    @property
    def coefficient_names(self) -> tuple[str, ...]:
        """Coefficient names in vector order."""
        return tuple(t.coefficient for t in self.terms)

    @property
    def n_coefficients(self) -> int:
        """Number of coefficients θ."""
        return len(self.terms)

    @property
    def equation_index(self) -> tuple[int, ...]:
        """For each coefficient, which acceleration it enters (0 surge, 1 sway, 2 yaw)."""
        return (0,) * len(self.surge) + (1,) * len(self.sway) + (2,) * len(self.yaw)

    @cached_property
    def coefficient_symbols(self) -> tuple[sp.Symbol, ...]:
        """One real sympy symbol per coefficient, named as the coefficient."""
        return tuple(sp.Symbol(name, real=True) for name in self.coefficient_names)

    def accelerations(self) -> tuple[sp.Expr, sp.Expr, sp.Expr]:
        """Symbolic (u', v', r') with the coefficients as symbols."""
        sums: list[sp.Expr] = [sp.Integer(0), sp.Integer(0), sp.Integer(0)]
        for theta, term, eq in zip(
            self.coefficient_symbols, self.terms, self.equation_index, strict=True
        ):
            sums[eq] = sums[eq] + theta * term.regressor
        return sums[0], sums[1], sums[2]

    def coefficient_units(self) -> dict[str, tuple[int, int]]:
        """SI dimension (metre, second exponents) of every coefficient."""
        return dict(self._coefficient_units)

    @cached_property
    def _coefficient_units(self) -> dict[str, tuple[int, int]]:
        # Derived once per structure: sympy's simplification of a rudder regressor takes
        # seconds, and params, FMU description and codegen all ask.
        return {
            term.coefficient: coefficient_unit(term.regressor, EQUATIONS[eq])
            for term, eq in zip(self.terms, self.equation_index, strict=True)
        }


def regressor_dimension(expr: sp.Expr) -> tuple[int, int]:
    """SI dimension of a regressor as exponents of (metre, second).

    Found by scaling every symbol by its unit, metres by 2 (``u -> 2u``, ``L -> 2L``)
    and then seconds by 2 (``u -> u/2``, ``r -> r/2``, ``n -> n/2``), and reading off
    the factors 2^dm and 2^ds by which the expression changes, at three points of
    the state space; raises ``ValueError`` when the expression is not dimensionally
    homogeneous (e.g. ``u + r``: the factor is not a power of 2, or not the same at
    every point). Numeric, because simplifying ``f(scaled)/f`` symbolically takes
    seconds for a rudder-force regressor.
    """
    symbols = sorted(expr.free_symbols, key=lambda s: s.name)
    unknown = [s for s in symbols if s not in _DIMENSIONS]
    if unknown:
        raise ValueError(f"regressor {expr} has symbols without a unit: {unknown}")
    f = sp.lambdify(symbols, expr, modules="math")
    points = ((0.7, 1.3, 0.9, 1.1, 0.8, 1.2), (1.21, 0.53, 1.37, 0.61, 1.05, 0.77),
              (0.45, 0.95, 0.55, 1.45, 1.15, 0.65))  # fmt: skip
    found: set[tuple[int, int]] = set()
    for point in points:
        values = dict(zip(symbols, point, strict=False))
        base = f(*values.values())
        exponents = []
        for axis in (0, 1):
            scaled = [v * 2.0 ** _DIMENSIONS[s][axis] for s, v in values.items()]
            ratio = f(*scaled) / base if base != 0.0 else math.nan
            exponent = math.log2(ratio) if ratio > 0.0 else math.nan
            if not abs(exponent - round(exponent)) < 1e-9:  # also for nan
                raise ValueError(f"regressor {expr} is not dimensionally homogeneous")
            exponents.append(round(exponent))
        found.add((exponents[0], exponents[1]))
    if len(found) != 1:
        raise ValueError(f"regressor {expr} is not dimensionally homogeneous")
    return found.pop()


def coefficient_unit(regressor: sp.Expr, equation: str) -> tuple[int, int]:
    """Dimension of the coefficient that multiplies ``regressor`` in ``equation``."""
    acc_m, acc_s = _ACCELERATION_DIMENSIONS[equation]
    reg_m, reg_s = regressor_dimension(regressor)
    return acc_m - reg_m, acc_s - reg_s


def unit_string(dimension: tuple[int, int]) -> str:
    """Readable SI unit of a (metre, second) exponent pair, e.g. (1, -2) -> ``"m/s2"``."""
    metre_exp, second_exp = dimension

    def part(symbol: str, exp: int) -> str:
        return symbol if exp == 1 else f"{symbol}{exp}"

    numerator = [part(s, e) for s, e in (("m", metre_exp), ("s", second_exp)) if e > 0]
    denominator = [part(s, -e) for s, e in (("m", metre_exp), ("s", second_exp)) if e < 0]
    text = ".".join(numerator) or "1"
    if len(denominator) == 1:
        text += "/" + denominator[0]
    elif denominator:
        text += "/(" + ".".join(denominator) + ")"
    return text
