"""Source code of a model structure's equations, generated from its symbolic definition.

The native FMU is one hand-written, reviewed FMI layer (``fmu_model/c/``) over a small
generated model part, after the Modelica Reference-FMUs pattern (``config.h`` +
``model.c``); the pythonfmu FMU is a thin slave over generated numpy-free Python. This
module emits both model parts from the same sympy expressions: the right-hand side of
the 6-state (u, v, r, x, y, ψ) and its exact Jacobians with respect to the state and the
two inputs (rudder angle [rad], propeller speed [rev/s]), which the FMUs' directional
derivatives are made of. Common subexpressions are shared (``sympy.cse``); C uses C99
``math.h`` calls (``sympy.ccode``), Python the ``math`` module. Nothing of the equations
is typed twice.

The environment (current and wind, ``fmu_model.structure.current_terms`` ...
``ground_outputs``) is generated as separate functions that *add* its terms to the
structure's right-hand side and Jacobian, and compute the outputs over ground: with
zero current and no windage areas they add nothing, so the structure's numbers are bit
for bit those of an FMU without environment. The wind load is a function of the
apparent wind's body-frame vector (a, b); the generated code evaluates it, by the chain
rule its derivatives, only where a² + b² > 0 (it and they are 0 at a = b = 0), so that
no branch divides by zero. The ground outputs' derivatives are taken as 0 at rest over
ground, where the speed over ground has none.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cache

import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from fmu_model.structure import (
    ENVIRONMENT_SYMBOLS,
    INPUT_SYMBOLS,
    KINEMATICS,
    STATE_SYMBOLS,
    WINDAGE_SYMBOLS,
    L,
    ModelStructure,
    apparent_wind_terms,
    current_terms,
    ground_east,
    ground_north,
    ground_outputs,
    ground_terms,
    wind_ahead,
    wind_starboard,
    wind_terms,
)

RHS_SIGNATURE = (
    "static void model_rhs(const double *theta, double length, const double *x,"
    " double rudder, double n_rps, double *dx)"
)
JACOBIAN_SIGNATURE = (
    "static void model_jacobian(const double *theta, double length, const double *x,"
    " double rudder, double n_rps, double *dfdx, double *dfdu)"
)
ENVIRONMENT_SIGNATURE = (
    "static void model_environment(const double *x, const double *env, const double *windage,"
    " double *dx)"
)
ENVIRONMENT_JACOBIAN_SIGNATURE = (
    "static void model_environment_jacobian(const double *x, const double *env,"
    " const double *windage, double *dfdx, double *dfde)"
)
GROUND_SIGNATURE = "static void model_ground(const double *x, const double *env, double *g)"
GROUND_JACOBIAN_SIGNATURE = (
    "static void model_ground_jacobian(const double *x, const double *env, double *dgdx,"
    " double *dgde)"
)
# Arguments of the generated Python functions (after the output arrays' names).
_PY_ARGUMENTS = "theta, length, x, rudder, n_rps"


@dataclass(frozen=True)
class _Equations:
    """The structure's equations in the generated code's argument names."""

    rhs: list[sp.Expr]  # d/dt (u, v, r, x, y, psi)
    dfdx: list[sp.Expr]  # row-major 6 x 6: d rhs_i / d x_j
    dfdu: list[sp.Expr]  # row-major 6 x 2: d rhs_i / d (rudder, n_rps)


def _equations(structure: ModelStructure) -> _Equations:
    """Differentiate the equations, then rename the symbols to the code's arguments."""
    exprs = [*structure.accelerations(), *KINEMATICS]
    theta = sp.IndexedBase("theta", shape=(structure.n_coefficients,))
    state = sp.IndexedBase("x", shape=(len(STATE_SYMBOLS),))
    subs: dict[sp.Symbol, sp.Expr] = {
        s: theta[i] for i, s in enumerate(structure.coefficient_symbols)
    }
    subs.update({s: state[i] for i, s in enumerate(STATE_SYMBOLS)})
    rudder_sym, n_sym = INPUT_SYMBOLS
    subs.update(
        {rudder_sym: sp.Symbol("rudder"), n_sym: sp.Symbol("n_rps"), L: sp.Symbol("length")}
    )

    def rename(items: list[sp.Expr]) -> list[sp.Expr]:
        return [e.xreplace(subs) for e in items]

    return _Equations(
        rhs=rename(exprs),
        dfdx=rename([sp.diff(e, s) for e in exprs for s in STATE_SYMBOLS]),
        dfdu=rename([sp.diff(e, s) for e in exprs for s in INPUT_SYMBOLS]),
    )


def _body(
    outputs: list[tuple[str, list[sp.Expr]]],
    print_expr: Callable[[sp.Expr], str],
    temporary: str,
    assignment: str,
) -> list[str]:
    """Statements computing every ``name[i] = expr`` of ``outputs`` with shared CSE."""
    flat = [e for _, exprs in outputs for e in exprs]
    temporaries, reduced = sp.cse(flat, symbols=sp.numbered_symbols("t"))
    lines = [temporary.format(sym, print_expr(expr)) for sym, expr in temporaries]
    position = 0
    for name, exprs in outputs:
        for i in range(len(exprs)):
            lines.append(assignment.format(name, i, print_expr(reduced[position])))
            position += 1
    return lines


@dataclass(frozen=True)
class _Language:
    """How a generated language declares, assigns, adds and guards."""

    print_expr: Callable[[sp.Expr], str]
    declare: str  # "{name} {expr}"
    assign: str  # "{target} {expr}"
    add: str  # "{target} {target} {expr}"
    open_if: str  # "{condition}"
    close_if: str | None
    either: str  # "{} or {}"
    indent: str = "    "


_C = _Language(
    sp.ccode,
    "const double {} = {};",
    "{} = {};",
    "{0} = {0} + {1};",
    "if ({}) {{",
    "}",
    "{} || {}",
)


class _ExactPythonPrinter(PythonCodePrinter):
    """Python code with every float as the shortest text of its double (not 15 digits)."""

    def _print_Float(self, expr: sp.Float) -> str:
        return repr(float(expr))


_PY = _Language(
    _ExactPythonPrinter({"fully_qualified_modules": True}).doprint,
    "{} = {}",
    "{} = {}",
    "{0} = {0} + {1}",
    "if {}:",
    None,
    "{} or {}",
)


def _block(
    lang: _Language, items: list[tuple[str, str, sp.Expr]], prefix: str, depth: int = 1
) -> list[str]:
    """Statements of ``items`` (kind, target, expr) sharing common subexpressions.

    kind ``"let"`` declares a local named target, ``"set"`` assigns, ``"add"`` adds to
    the target; temporaries are named ``<prefix>0, <prefix>1, ...``.
    """
    temporaries, reduced = sp.cse([e for _, _, e in items], symbols=sp.numbered_symbols(prefix))
    pad = lang.indent * depth
    lines = [pad + lang.declare.format(sym, lang.print_expr(e)) for sym, e in temporaries]
    templates = {"let": lang.declare, "set": lang.assign, "add": lang.add}
    for (kind, target, _), expr in zip(items, reduced, strict=True):
        lines.append(pad + templates[kind].format(target, lang.print_expr(expr)))
    return lines


def _guarded(lang: _Language, condition: str, body: list[str], depth: int = 1) -> list[str]:
    """``body`` (already indented one level deeper) under ``if condition``."""
    pad = lang.indent * depth
    lines = [pad + lang.open_if.format(condition), *body]
    if lang.close_if is not None:
        lines.append(pad + lang.close_if)
    return lines


@dataclass(frozen=True)
class _EnvironmentCode:
    """The environment's symbols renamed to the generated code's arguments."""

    subs: dict[sp.Symbol, sp.Expr]
    state: list[sp.Expr]  # x[0] ... x[5]
    env: list[sp.Expr]  # env[0] ... env[3]


def _environment_code() -> _EnvironmentCode:
    x = sp.IndexedBase("x", shape=(len(STATE_SYMBOLS),))
    env = sp.IndexedBase("env", shape=(len(ENVIRONMENT_SYMBOLS),))
    windage = sp.IndexedBase("windage", shape=(len(WINDAGE_SYMBOLS.as_tuple()),))
    subs: dict[sp.Symbol, sp.Expr] = {s: x[i] for i, s in enumerate(STATE_SYMBOLS)}
    subs.update({s: env[i] for i, s in enumerate(ENVIRONMENT_SYMBOLS)})
    subs.update({s: windage[i] for i, s in enumerate(WINDAGE_SYMBOLS.as_tuple())})
    subs.update({wind_ahead: sp.Symbol("wa"), wind_starboard: sp.Symbol("wb")})
    subs.update({ground_north: sp.Symbol("gn"), ground_east: sp.Symbol("ge")})
    return _EnvironmentCode(
        subs,
        [x[i] for i in range(len(STATE_SYMBOLS))],
        [env[i] for i in range(len(ENVIRONMENT_SYMBOLS))],
    )


def _rename(expr: sp.Expr, code: _EnvironmentCode) -> sp.Expr:
    return sp.sympify(expr).xreplace(code.subs)


def _chain(
    lang: _Language,
    code: _EnvironmentCode,
    inner: tuple[sp.Symbol, sp.Symbol],
    inner_exprs: tuple[sp.Expr, sp.Expr],
    outer: tuple[sp.Expr, ...],
    rows: list[int],
    outputs: tuple[str, str],
    width: tuple[int, int],
) -> list[str]:
    """Jacobian lines of outer(inner(x, env)) by the chain rule, guarded at inner = 0.

    Row ``rows[i]`` of ``outputs[0]`` (by the state, ``width[0]`` columns, added to) and of
    ``outputs[1]`` (by the environment, ``width[1]`` columns, assigned, 0 at inner = 0).
    """
    p, q = (code.subs[s] for s in inner)
    knowns = [*zip(STATE_SYMBOLS, code.state, strict=True)]
    knowns += [*zip(ENVIRONMENT_SYMBOLS, code.env, strict=True)]
    # Partials of the inner functions: smooth (trigonometric), evaluated everywhere.
    first: list[tuple[str, str, sp.Expr]] = [
        ("let", str(p), _rename(inner_exprs[0], code)),
        ("let", str(q), _rename(inner_exprs[1], code)),
    ]
    partial_names: list[tuple[sp.Expr, sp.Expr]] = []
    for j, (symbol, _) in enumerate(knowns):
        names = []
        for name, expr in ((f"{p}_d{j}", inner_exprs[0]), (f"{q}_d{j}", inner_exprs[1])):
            d = _rename(sp.diff(expr, symbol), code)
            if d == 0:
                names.append(sp.Integer(0))
            else:
                first.append(("let", name, d))
                names.append(sp.Symbol(name))
        partial_names.append((names[0], names[1]))
    lines = _block(lang, first, "t")
    # Outer derivatives and the products, only where p^2 + q^2 > 0.
    guarded: list[tuple[str, str, sp.Expr]] = []
    for row, f in zip(rows, outer, strict=True):
        f_p, f_q = (_rename(sp.diff(f, s), code) for s in inner)
        for j, (d_p, d_q) in enumerate(partial_names):
            value = f_p * d_p + f_q * d_q
            if value == 0:
                continue
            if j < width[0]:
                guarded.append(("add", f"{outputs[0]}[{width[0] * row + j}]", value))
            else:
                k = j - width[0]
                guarded.append(("set", f"{outputs[1]}[{width[1] * row + k}]", value))
    body = _block(lang, guarded, "s", depth=2)
    return lines + _guarded(lang, f"{p} * {p} + {q} * {q} > 0.0", body)


@cache
def _environment_functions(lang: _Language) -> dict[str, list[str]]:
    """Bodies of model_environment, model_environment_jacobian, model_ground(_jacobian)."""
    code = _environment_code()
    c_north, c_east = current_terms()
    a, b = apparent_wind_terms()
    wind = wind_terms()
    n_env = len(ENVIRONMENT_SYMBOLS)
    n_state = len(STATE_SYMBOLS)
    wa, wb = (code.subs[s] for s in (wind_ahead, wind_starboard))

    # d/dt (u, v, r, x, y, psi) += (wind u', v', r', c_N, c_E, 0). Nothing is added
    # without current (its terms are 0) or without windage areas (the loads are
    # proportional to them): a calm FMU costs two comparisons more than the model alone.
    current = [("add", "dx[3]", _rename(c_north, code)), ("add", "dx[4]", _rename(c_east, code))]
    rhs = _guarded(lang, "env[0] != 0.0", _block(lang, current, "t", 2))
    apparent = [("let", str(wa), _rename(a, code)), ("let", str(wb), _rename(b, code))]
    loads = [("add", f"dx[{i}]", _rename(w, code)) for i, w in enumerate(wind)]
    wind_body = _block(lang, apparent, "t", 2) + _guarded(
        lang, f"{wa} * {wa} + {wb} * {wb} > 0.0", _block(lang, loads, "s", 3), 2
    )
    areas = lang.either.format("windage[0] > 0.0", "windage[1] > 0.0")
    rhs += _guarded(lang, areas, wind_body)

    # Jacobian: dfde is assigned in full (0 where nothing depends), dfdx added to.
    jacobian = _block(
        lang,
        [("set", f"dfde[{k}]", sp.Integer(0)) for k in range(n_state * n_env)]
        + [
            ("set", f"dfde[{n_env * row + k}]", _rename(sp.diff(c, s), code))
            for row, c in ((3, c_north), (4, c_east))
            for k, s in enumerate(ENVIRONMENT_SYMBOLS)
            if sp.diff(c, s) != 0
        ],
        "r",
    )
    jacobian += _chain(
        lang, code, (wind_ahead, wind_starboard), (a, b), wind, [0, 1, 2], ("dfdx", "dfde"),
        (n_state, n_env),
    )  # fmt: skip

    # Ground outputs and their Jacobian (0 at rest over ground).
    north, east = ground_terms()
    sog, cog = ground_outputs()
    gn, ge = (code.subs[s] for s in (ground_north, ground_east))
    ground = _block(
        lang,
        [
            ("let", str(gn), _rename(north, code)),
            ("let", str(ge), _rename(east, code)),
            ("set", "g[0]", _rename(sog, code)),
            ("set", "g[1]", _rename(cog, code)),
        ],
        "t",
    )
    ground_jacobian = _block(
        lang,
        [("set", f"dgdx[{k}]", sp.Integer(0)) for k in range(2 * n_state)]
        + [("set", f"dgde[{k}]", sp.Integer(0)) for k in range(2 * n_env)],
        "r",
    )
    ground_jacobian += _chain(
        lang, code, (ground_north, ground_east), (north, east), (sog, cog), [0, 1],
        ("dgdx", "dgde"), (n_state, n_env),
    )  # fmt: skip
    return {
        "environment": rhs,
        "environment_jacobian": jacobian,
        "ground": ground,
        "ground_jacobian": ground_jacobian,
    }


def generate_model_c(structure: ModelStructure) -> str:
    """Return the C translation unit of ``structure``'s equations.

    The file defines ``MODEL_STRUCTURE_NAME``, ``MODEL_N_COEFFICIENTS``,
    ``MODEL_COEFFICIENT_NAMES``, ``model_rhs`` with the signature :data:`RHS_SIGNATURE`
    (``theta`` the coefficients in structure order, ``length`` [m], ``x`` the state
    (u, v, r, x, y, ψ), ``rudder`` [rad], ``n_rps`` [rev/s], ``dx`` the derivative, out)
    and ``model_jacobian`` with :data:`JACOBIAN_SIGNATURE` (same inputs; out ``dfdx``
    6 × 6 and ``dfdu`` 6 × 2 row-major, the partial derivatives of ``dx`` with respect
    to the state and to (rudder, n_rps)).
    """
    eq = _equations(structure)
    names = ", ".join(f'"{name}"' for name in structure.coefficient_names)
    unused = "    (void)theta; (void)length; (void)x; (void)rudder; (void)n_rps;"
    lines = [
        f"/* Generated by fmu_model.codegen from model '{structure.name}'. Do not edit. */",
        f"/* {structure.description} */",
        f"/* Equations: {structure.reference} */",
        "#include <math.h>",
        "",
        f'#define MODEL_STRUCTURE_NAME "{structure.name}"',
        f"#define MODEL_N_COEFFICIENTS {structure.n_coefficients}",
        f"static const char *const MODEL_COEFFICIENT_NAMES[MODEL_N_COEFFICIENTS] = {{{names}}};",
        "",
        "/* d/dt (u, v, r, x, y, psi): accelerations of the structure, then kinematics. */",
        RHS_SIGNATURE,
        "{",
        unused,
        *_body([("dx", eq.rhs)], sp.ccode, "    const double {} = {};", "    {}[{}] = {};"),
        "}",
        "",
        "/* The exact partial derivatives of model_rhs (row i: dx[i]): dfdx[6 * i + j] with",
        "   respect to x[j], dfdu[2 * i + k] with respect to (rudder [rad], n_rps [rev/s])[k]. */",
        JACOBIAN_SIGNATURE,
        "{",
        unused,
        *_body(
            [("dfdx", eq.dfdx), ("dfdu", eq.dfdu)],
            sp.ccode,
            "    const double {} = {};",
            "    {}[{}] = {};",
        ),
        "}",
        "",
        *_environment_c(),
    ]
    return "\n".join(lines)


def _environment_c() -> list[str]:
    """Return the C functions of the environment (see the module docstring)."""
    body = _environment_functions(_C)
    n_env = len(ENVIRONMENT_SYMBOLS)
    return [
        "/* The environment, env = (current_speed [m/s], current_direction [rad, towards],",
        "   wind_speed [m/s], wind_direction [rad, from]), and the windage = (frontal_area_m2,",
        "   lateral_area_m2, length_overall_m, lateral_centroid_m, surge_mass_kg, sway_mass_kg,",
        "   yaw_inertia_kgm2, sway_yaw_coupling_kgm): dx (d/dt of x) += the wind's",
        "   accelerations and the current. */",
        ENVIRONMENT_SIGNATURE,
        "{",
        "    (void)windage;",
        *body["environment"],
        "}",
        "",
        "/* Their partial derivatives: dfdx (6 x 6, by x) += those of the environment's terms,",
        f"   dfde (6 x {n_env}, by env) = theirs. */",
        ENVIRONMENT_JACOBIAN_SIGNATURE,
        "{",
        "    (void)windage;",
        *body["environment_jacobian"],
        "}",
        "",
        "/* g = (speed over ground [m/s], course over ground [rad], atan2(East, North)). */",
        GROUND_SIGNATURE,
        "{",
        *body["ground"],
        "}",
        "",
        f"/* Their partial derivatives: dgdx (2 x 6, by x), dgde (2 x {n_env}, by env); 0 at",
        "   rest over ground. */",
        GROUND_JACOBIAN_SIGNATURE,
        "{",
        *body["ground_jacobian"],
        "}",
        "",
    ]


def generate_model_py(structure: ModelStructure) -> str:
    """Return a Python module of ``structure``'s equations that imports only ``math``.

    The module the pythonfmu FMU evaluates (so that its host needs neither sympy nor
    this package's symbolic part): ``STRUCTURE_NAME``, ``COEFFICIENT_NAMES``, and
    ``rhs(dx, theta, length, x, rudder, n_rps)`` and
    ``jacobian(dfdx, dfdu, theta, length, x, rudder, n_rps)``, the twins of the C
    functions of :func:`generate_model_c` (same arguments and units; the outputs are
    filled in place, item by item, so any mutable sequence of floats works).
    """
    eq = _equations(structure)
    printer = PythonCodePrinter({"fully_qualified_modules": True})
    names = ", ".join(repr(name) for name in structure.coefficient_names)
    lines = [
        f'"""Equations of model {structure.name!r}, generated by fmu_model.codegen. Do not edit.',
        "",
        f"{structure.description}. Equations: {structure.reference}.",
        '"""',
        "",
        "import math",
        "",
        f"STRUCTURE_NAME = {structure.name!r}",
        f"COEFFICIENT_NAMES = ({names},)",
        "",
        "",
        f"def rhs(dx, {_PY_ARGUMENTS}):",
        '    """Fill dx with d/dt (u, v, r, x, y, psi)."""',
        *_body([("dx", eq.rhs)], printer.doprint, "    {} = {}", "    {}[{}] = {}"),
        "",
        "",
        f"def jacobian(dfdx, dfdu, {_PY_ARGUMENTS}):",
        '    """Fill dfdx (6 x 6) and dfdu (6 x 2, rudder and n_rps) row-major."""',
        *_body(
            [("dfdx", eq.dfdx), ("dfdu", eq.dfdu)],
            printer.doprint,
            "    {} = {}",
            "    {}[{}] = {}",
        ),
        "",
        *_environment_py(),
    ]
    return "\n".join(lines)


def _environment_py() -> list[str]:
    """Return the Python twins of the functions of :func:`_environment_c`."""
    body = _environment_functions(_PY)
    return [
        "",
        "def environment_rhs(dx, x, env, windage):",
        '    """Add the wind\'s accelerations and the current to dx (d/dt of x)."""',
        *body["environment"],
        "",
        "",
        "def environment_jacobian(dfdx, dfde, x, env, windage):",
        '    """Add the environment\'s partials by x to dfdx (6 x 6); fill dfde (6 x 4)."""',
        *body["environment_jacobian"],
        "",
        "",
        "def ground(g, x, env):",
        '    """Fill g with (speed over ground [m/s], course over ground [rad])."""',
        *body["ground"],
        "",
        "",
        "def ground_jacobian(dgdx, dgde, x, env):",
        '    """Fill dgdx (2 x 6) and dgde (2 x 4) with the partials of ground()."""',
        *body["ground_jacobian"],
        "",
    ]
