"""Compiled kernels of a model structure, generated once and cached on disk.

The identifier's hot loops (the augmented EKF, ``identifier.ekf``; the batched RK4
replay, ``fmu_model.replay``) are numba functions written once for every structure:
they take the structure's regressor kernels (``phi``, ``grad``, ``kin``, ``kin_grad``,
generated from its symbolic terms) as their leading arguments. numba cannot cache a
function whose signature holds other functions, so every new process compiled them
again: 5–9 s for the EKF alone, for every shape a model family tries, on every run.

Here the kernels of one structure and thin wrappers that bind them to those loops are
written as a Python module to a cache directory, and imported; every function in it is
``numba.njit(cache=True)``, so numba keeps the machine code beside it and the next
process loads it instead of compiling. The structures of one family
(``fmu_model.variants.ModelFamily``: the shapes the identifier tries) share one module:
its kernels take the shape constants at run time, beside the ship length, in the
``constants`` array of :func:`kernel_constants`; so a fit compiles one EKF for the
family, not one for every shape it tries. The module's name carries a hash of its text, of
numba's version and of the source of the packages it calls into, so a changed loop, a
changed structure or another numba never meets a stale file. The modules are written
atomically (another process may be writing the same one).

The directory is ``$SHIPID_KERNEL_CACHE``, else ``$XDG_CACHE_HOME/shipid/kernels``
(``~/.cache/shipid/kernels``), else a directory in the system's temporary directory
when that is not writable.
"""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import inspect
import os
import sys
import tempfile
import textwrap
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cache
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import sympy as sp
from sympy.printing.pycode import PythonCodePrinter

from fmu_model.structure import (
    INPUT_SYMBOLS,
    KINEMATICS,
    STATE_SYMBOLS,
    VELOCITY_SYMBOLS,
    L,
    ModelStructure,
    psi,
)
from fmu_model.variants import parse_family

CACHE_ENV = "SHIPID_KERNEL_CACHE"
"""Environment variable naming the kernel cache directory (module docstring)."""

_ARGS = (*VELOCITY_SYMBOLS, *INPUT_SYMBOLS)

KERNEL_NAMES = ("phi", "grad", "kin", "kin_grad")
"""The kernels of every generated module, in order (:func:`kernel_source`)."""


@dataclass(frozen=True)
class Binding:
    """A function of the generated module: ``name(*args) = template(*bound, *args)``.

    Attributes
    ----------
    name : str
        Name of the function in the generated module.
    template : Callable
        A plain Python function in numba's subset, defined at the top level of a module,
        whose leading parameters are functions: its source is compiled in the generated
        module with those parameters bound (``_binding_sources``).
    bound : tuple of str
        Names in the generated module the leading parameters are bound to: the kernels
        (``phi``, ``grad``, ``kin``, ``kin_grad``; :func:`kernel_source`) or an earlier
        binding's function.

    """

    name: str
    template: Callable[..., Any]
    bound: tuple[str, ...]
    source: str = field(init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        # Read when the binding is made, at the template module's import: the file may
        # change while a process runs (an upgrade), and ``inspect.getsource`` reads the
        # file as it is then, at the line numbers of the code as it was.
        object.__setattr__(self, "source", textwrap.dedent(inspect.getsource(self.template)))


@dataclass(frozen=True)
class _KernelSpec:
    """What a generated module's kernels compute: the regressors in the run-time constants.

    ``constants`` are the symbols read from the kernels' ``constants`` array, in order:
    the ship length L, then a family's shape constants.
    """

    name: str
    regressors: tuple[sp.Expr, ...]
    constants: tuple[sp.Symbol, ...]


@cache
def _kernel_spec(structure: ModelStructure) -> tuple[_KernelSpec, tuple[float, ...]]:
    """Return the kernels of ``structure`` and its shape constants' values (module docstring).

    A structure of a family (``family[c=v,…]``, as ``ModelFamily.structure`` builds it)
    has its family's kernels and its shape as values; any other structure has kernels of
    its own and no values.
    """
    try:
        shaped = parse_family(structure.name)
    except KeyError:  # a name of family form with a shape no family has
        shaped = None
    if shaped is not None:
        family, shape = shaped
        if len(shape) == len(family.shape) and family.structure(shape) == structure:
            spec = _KernelSpec(
                family.name,
                tuple(t.regressor for t in family.terms),
                (L, *(c.symbol for c in family.shape)),
            )
            return spec, tuple(float(shape[c.name]) for c in family.shape)
    return _KernelSpec(structure.name, tuple(t.regressor for t in structure.terms), (L,)), ()


def kernel_constants(structure: ModelStructure, length_m: float) -> np.ndarray:
    """Return the ``constants`` argument of the kernels of ``structure``: (L [m], shape…)."""
    return np.array([length_m, *_kernel_spec(structure)[1]], dtype=float)


def _filler(
    name: str, exprs: Sequence[sp.Expr], args: Sequence[sp.Symbol], constants: Sequence[sp.Symbol]
) -> str:
    """Return the source of ``def name(*args[, constants], out)`` filling ``out[i] = exprs[i]``.

    With ``constants``, the function reads those symbols from its ``constants`` array.
    """
    temporaries, reduced = sp.cse(list(exprs), symbols=sp.numbered_symbols("_t"))
    printer = PythonCodePrinter({"fully_qualified_modules": True})
    parameters = [str(a) for a in args] + (["constants"] if constants else []) + ["out"]
    lines = ["@numba.njit(cache=True)", f"def {name}({', '.join(parameters)}):"]
    lines += [f"    {sym} = constants[{i}]" for i, sym in enumerate(constants)]
    lines += [f"    {sym} = {printer.doprint(expr)}" for sym, expr in temporaries]
    lines += [f"    out[{i}] = {printer.doprint(expr)}" for i, expr in enumerate(reduced)]
    return "\n".join(lines)


def _kernel_sources(spec: _KernelSpec) -> list[str]:
    """Return the sources of the four kernels of ``spec`` (:func:`kernel_source`)."""
    gradients = [sp.diff(e, s) for e in spec.regressors for s in VELOCITY_SYMBOLS]
    kin_args = (*VELOCITY_SYMBOLS, psi)
    kin_grad = [sp.diff(e, s) for e in KINEMATICS for s in STATE_SYMBOLS]
    exprs = (spec.regressors, gradients, list(KINEMATICS), kin_grad)
    args = (_ARGS, _ARGS, kin_args, kin_args)
    constants = (spec.constants, spec.constants, (), ())
    return [_filler(*f) for f in zip(KERNEL_NAMES, exprs, args, constants, strict=True)]


def _binding_sources(bindings: Sequence[Binding]) -> list[str]:
    """Return the sources of the bound functions (and the imports and names they use).

    Each is its template's own definition (``Binding.source``) renamed, with the
    leading parameters removed: each removed parameter becomes a name of the generated
    module for what it is bound to, and the template module's globals the body uses are
    imported. numba then sees the kernels as globals (static calls) and can cache the
    function; passed as arguments they would be run-time values, which it cannot cache.
    """
    aliases: dict[str, str] = {}
    imports: dict[str, set[str]] = {}
    functions = []
    generated = {*KERNEL_NAMES, *(b.name for b in bindings)}
    for binding in bindings:
        template = binding.template
        tree = ast.parse(binding.source)
        node = tree.body[0]
        if not isinstance(node, ast.FunctionDef) or len(node.args.args) < len(binding.bound):
            raise ValueError(
                f"{template.__name__} is not a function of at least {len(binding.bound)} "
                "parameters (the bound names)"
            )
        leading = [a.arg for a in node.args.args[: len(binding.bound)]]
        for parameter, bound in zip(leading, binding.bound, strict=True):
            if aliases.setdefault(parameter, bound) != bound:
                raise ValueError(f"parameter {parameter!r} is bound to two names")
        node.args.args = node.args.args[len(binding.bound) :]
        node.name = binding.name
        node.decorator_list = []
        names = {n.id for n in ast.walk(node) if isinstance(n, ast.Name)}
        module = sys.modules[template.__module__]
        used = {n for n in names - set(leading) if n in vars(module)}
        if used & generated:
            raise ValueError(
                f"{template.__module__} has globals named as the generated module's "
                f"functions: {sorted(used & generated)}"
            )
        imports.setdefault(template.__module__, set()).update(used)
        functions.append("@numba.njit(cache=True)\n" + ast.unparse(node))
    lines = [f"from {m} import {', '.join(sorted(n))}" for m, n in imports.items() if n]
    # After the kernels in the module's text (kernel_source): an alias names a kernel, or
    # a function numba resolves when it compiles, at the first call.
    lines += [f"{p} = {b}" for p, b in aliases.items() if p != b]
    return ["\n".join(lines), *functions] if lines else functions


@cache
def _package_stamp(package: str) -> str:
    """sha256 of the text of every module of ``package`` (its source files, sorted)."""
    spec = importlib.util.find_spec(package)
    if spec is None or not spec.submodule_search_locations:
        raise ValueError(f"{package!r} is not a package")
    digest = hashlib.sha256()
    for root in spec.submodule_search_locations:
        for path in sorted(Path(root).rglob("*.py")):
            digest.update(path.relative_to(root).as_posix().encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def cache_directory() -> Path:
    """Return the directory of the generated kernel modules (module docstring), created."""
    configured = os.environ.get(CACHE_ENV)
    if configured:
        candidates = [Path(configured)]
    else:
        xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        user = os.environ.get("USER") or str(os.getuid() if hasattr(os, "getuid") else "user")
        candidates = [
            Path(xdg) / "shipid" / "kernels",
            Path(tempfile.gettempdir()) / f"shipid-kernels-{user}",
        ]
    for directory in candidates:
        try:
            directory.mkdir(parents=True, exist_ok=True)
        except OSError:
            continue
        if os.access(directory, os.W_OK):
            return directory
    raise OSError(f"no writable kernel cache directory among {[str(c) for c in candidates]}")


def kernel_source(structure: ModelStructure, bindings: Sequence[Binding]) -> str:
    """Text of the generated module of ``structure`` with ``bindings`` (module docstring).

    Its kernels, for the structure's regressors φ(u, v, r, δ, n; L, shape):
    ``phi(u, v, r, δ, n, constants, out)`` fills out (p,) with φ; ``grad(u, v, r, δ, n,
    constants, out)`` fills out (3p,) with ∂φ_i/∂(u, v, r) row-major, ``constants``
    being :func:`kernel_constants`; ``kin(u, v, r, ψ, out)`` fills (3,) with the
    kinematics (ẋ, ẏ, ψ̇); ``kin_grad(u, v, r, ψ, out)`` fills (18,) with
    ∂(ẋ, ẏ, ψ̇)/∂(u, v, r, x, y, ψ). The structures of a family have one text.
    """
    import numba  # only the identifier's hot loops need it, not the FMU runtime

    spec = _kernel_spec(structure)[0]
    packages = sorted({"fmu_model", *(b.template.__module__.split(".")[0] for b in bindings)})
    stamps = ", ".join(f"{p} {_package_stamp(p)[:16]}" for p in packages)
    constants = ", ".join(str(c) for c in spec.constants)
    header = [
        f'"""Compiled kernels of {spec.name}: generated by fmu_model.kernels, do not edit.',
        "",
        f"Run-time constants ({constants}); numba {numba.__version__}; sources {stamps}.",
        '"""',
        "",
        "import math  # noqa: F401 (the kernels' text may call it)",
        "",
        "import numba",
    ]
    return (
        "\n\n\n".join(["\n".join(header), *_kernel_sources(spec), *_binding_sources(bindings)])
        + "\n"
    )


def kernel_module(structure: ModelStructure, bindings: Sequence[Binding] = ()) -> ModuleType:
    """Import (writing it first if new) the generated kernel module of ``structure``.

    Parameters
    ----------
    structure : ModelStructure
        The model structure whose kernels the module holds (see :func:`kernel_source`);
        the structures of a family share their family's module.
    bindings : sequence of Binding
        Wrappers binding the kernels to compiled loops, in order (a binding may bind an
        earlier one).

    Returns
    -------
    ModuleType
        The module: attributes ``phi``, ``grad``, ``kin``, ``kin_grad`` and one per
        binding, numba dispatchers cached on disk; their ``constants`` argument is
        :func:`kernel_constants` of ``structure``.

    """
    spec = _kernel_spec(structure)[0]
    key = (spec.name, tuple(bindings))
    loaded = _LOADED.get(key)
    if loaded is not None and loaded[0] == spec:
        return loaded[1]
    text = kernel_source(structure, bindings)
    digest = hashlib.sha256(text.encode()).hexdigest()[:20]
    name = f"shipid_kernels_{digest}"
    module = sys.modules.get(name)
    if module is None:
        module = _import(name, text)
    _LOADED[key] = (spec, module)
    return module


_LOADED: dict[tuple[str, tuple[Binding, ...]], tuple[_KernelSpec, ModuleType]] = {}


def _import(name: str, text: str) -> ModuleType:
    """Import the module ``name`` of ``text`` from the cache directory (writing it first)."""
    directory = cache_directory()
    path = directory / f"{name}.py"
    if not path.is_file():
        # Written under a temporary name and renamed: another process may be writing
        # the same module, and no process may import half of it.
        handle, temporary = tempfile.mkstemp(dir=directory, suffix=".tmp")
        with os.fdopen(handle, "w", encoding="utf-8") as file:
            file.write(text)
        os.replace(temporary, path)
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None  # a .py file always has one
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def numba_compilations() -> tuple[int, int]:
    """Return (compiled, loaded): numba functions this process compiled, and loaded from caches.

    Counted per signature (numba's ``Dispatcher.stats``) over the dispatchers at the top
    level of every module imported so far (the generated kernel modules among them):
    after ``python -m scenarios warm-up`` (or any earlier fit with the same settings) a
    fit compiles nothing, and its process holds no compiler.
    """
    import numba

    dispatchers = {
        id(value): value
        for module in list(sys.modules.values())
        for value in list(getattr(module, "__dict__", {}).values())
        if isinstance(value, numba.core.dispatcher.Dispatcher)
    }
    compiled = sum(sum(d.stats.cache_misses.values()) for d in dispatchers.values())
    loaded = sum(sum(d.stats.cache_hits.values()) for d in dispatchers.values())
    return compiled, loaded
