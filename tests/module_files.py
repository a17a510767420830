"""Importing a Python file of a folder that is no package (benchmarks/, examples/)."""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import ModuleType

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def load_module(name: str, path: Path) -> ModuleType:
    """Import ``path`` under the private module name ``name`` (registered in sys.modules)."""
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


@contextmanager
def benchmark_module(filename: str) -> Iterator[ModuleType]:
    """Import ``benchmarks/<filename>`` with its folder on sys.path for its siblings.

    The benchmarks import each other (``fidelity``, ``report``) as top-level modules;
    sys.path is restored on leaving.
    """
    saved = list(sys.path)
    sys.path.insert(0, str(BENCHMARKS))
    try:
        yield load_module(f"benchmark_{Path(filename).stem}", BENCHMARKS / filename)
    finally:
        sys.path[:] = saved
