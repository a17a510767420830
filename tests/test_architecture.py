"""The floors of the house (DESIGN.md, "Packages"), checked from every module's imports.

Data flows downhill: ``fmu_model`` (the model) ← ``trials`` (what identification and
validation share) ← ``identifier`` (logs in, params out) ← ``scenarios`` (manoeuvres,
validation, reports). A module may import its own package and the floors below it,
never one above; imports inside functions count too.
Command-line code (argparse, printing, exiting) lives only in command-line modules.
"""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
PROJECT = ("fmu_model", "trials", "identifier", "scenarios", "build_fmu")
ALLOWED: dict[str, set[str]] = {
    "fmu_model": {"fmu_model"},
    "trials": {"fmu_model", "trials"},
    "identifier": {"fmu_model", "trials", "identifier"},
    "scenarios": {"fmu_model", "trials", "identifier", "scenarios"},
    "build_fmu": {"fmu_model", "build_fmu"},
}
# Modules whose job is the command line (and the shared argparse types of every CLI).
CLI_MODULES = ("build_fmu", "fmu_model.argtypes")


def _modules() -> Iterator[tuple[str, Path]]:
    for package in PROJECT[:-1]:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = path.relative_to(ROOT).with_suffix("").parts
            yield ".".join(p for p in parts if p != "__init__"), path
    yield "build_fmu", ROOT / "build_fmu.py"


def _imported(tree: ast.AST, module: str) -> Iterator[tuple[int, str]]:
    """(line, top-level package) of every import in ``tree``, relative ones resolved."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name.split(".")[0]
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: within the importing package
                yield node.lineno, module.split(".")[0]
            elif node.module:
                yield node.lineno, node.module.split(".")[0]


def _is_cli(module: str) -> bool:
    parts = module.split(".")
    return module in CLI_MODULES or "cli" in parts or parts[-1] == "__main__"


MODULES = dict(_modules())


def test_every_package_is_seen() -> None:
    seen = {m.split(".")[0] for m in MODULES}
    assert seen == set(PROJECT)
    assert len(MODULES) > 40  # the walk found the tree, not an empty folder


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_only_downhill(module: str) -> None:
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    floor = module.split(".")[0]
    wrong = [
        f"{MODULES[module].relative_to(ROOT)}:{line} imports {package}"
        for line, package in _imported(tree, module)
        if package in PROJECT and package not in ALLOWED[floor]
    ]
    assert not wrong, "; ".join(wrong)


@pytest.mark.parametrize("module", sorted(m for m in MODULES if not _is_cli(m)))
def test_library_modules_hold_no_command_line(module: str) -> None:
    tree = ast.parse(MODULES[module].read_text(encoding="utf-8"))
    found = [
        f"line {line}: imports {package}"
        for line, package in _imported(tree, module)
        if package == "argparse"
    ]
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            name = ast.unparse(node.func)
            if name in ("print", "sys.exit", "exit"):
                found.append(f"line {node.lineno}: calls {name}")
    assert not found, f"{MODULES[module].relative_to(ROOT)}: " + "; ".join(found)


def test_the_rules_catch_an_upward_import() -> None:
    # The checker itself: an identifier module importing scenarios, inside a function.
    source = "def f():\n    from scenarios.metrics import turning_metrics\n"
    found = list(_imported(ast.parse(source), "identifier.refine"))
    assert found == [(2, "scenarios")]
    assert "scenarios" not in ALLOWED["identifier"]
