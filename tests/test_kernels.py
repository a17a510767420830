"""Compiled kernels cached on disk (fmu_model.kernels): reused, never stale, same numbers."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from fmu_model import get_model, kernels, numeric_model
from fmu_model.kernels import (
    CACHE_ENV,
    Binding,
    cache_directory,
    kernel_constants,
    kernel_module,
    kernel_source,
)
from fmu_model.replay import _REPLAY_BINDINGS
from fmu_model.variants import parse_family
from identifier.ekf import _EKF_PASS

# One EKF identification and one replay in a fresh interpreter: its numbers, and whether
# numba compiled the bound loops or loaded them from the cache directory.
_CHILD = """
import json
from fmu_model import get_model
from fmu_model.kernels import kernel_module
from fmu_model.replay import _REPLAY_BINDINGS
from identifier.ekf import _EKF_PASS
from identifier.identify import FitSettings, identify
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log

log = synthesize_log(reference_ship("kvlcc2", "full"), MANEUVERS["zigzag-10"](), seed=0)
result = identify([log], FitSettings(model="shi2009", current="none"))
structure = get_model("shi2009")
ekf = kernel_module(structure, (_EKF_PASS,)).ekf_pass.stats
batch = kernel_module(structure, _REPLAY_BINDINGS).replay_batch.stats
print(json.dumps({
    "ekf": result.ekf.theta.tolist(),
    "kept": result.params.coefficients.tolist(),
    "hits": sum(ekf.cache_hits.values()) + sum(batch.cache_hits.values()),
    "misses": sum(ekf.cache_misses.values()) + sum(batch.cache_misses.values()),
}))
"""


def _run_child(cache: Path) -> dict[str, object]:
    env = {**os.environ, CACHE_ENV: str(cache)}
    child = subprocess.run(
        [sys.executable, "-c", _CHILD],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
        check=True,
    )
    return json.loads(child.stdout.strip().splitlines()[-1])


def test_second_process_loads_the_compiled_loops_and_gets_the_same_numbers(
    tmp_path: Path,
) -> None:
    """The EKF and the replay of an identification: compiled once, then loaded."""
    first = _run_child(tmp_path)
    second = _run_child(tmp_path)
    assert first["misses"] == 2 and first["hits"] == 0  # compiled, EKF and replay
    assert second["hits"] == 2 and second["misses"] == 0  # both loaded from the cache
    assert first["ekf"] == second["ekf"]  # bit for bit: the same machine code
    assert first["kept"] == second["kept"]
    written = sorted(p.name for p in tmp_path.glob("shipid_kernels_*.py"))
    assert len(written) == 2  # one module per structure and set of bindings


def test_module_name_follows_its_text(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """Another structure or other bindings are another module; the same are the same one."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    # Not the module an earlier test of this process imported from another directory.
    monkeypatch.setattr(kernels, "_LOADED", {})
    for name in [n for n in sys.modules if n.startswith("shipid_kernels_")]:
        monkeypatch.delitem(sys.modules, name)
    seed, other = get_model("shi2009"), get_model("prime-cubic")
    text = kernel_source(seed, (_EKF_PASS,))
    assert text == kernel_source(seed, (_EKF_PASS,))
    assert text != kernel_source(other, (_EKF_PASS,))
    assert text != kernel_source(seed, _REPLAY_BINDINGS)
    module = kernel_module(seed, (_EKF_PASS,))
    assert kernel_module(seed, (_EKF_PASS,)) is module
    assert Path(module.__file__ or "").read_text(encoding="utf-8") == text
    assert Path(module.__file__ or "").parent == tmp_path
    # The template's own body, its kernel parameters bound to the module's kernels.
    assert "def ekf_pass(eq_index, constants, max_substep, q_interval, offset," in text
    assert "phi_fn = phi\ngrad_fn = grad\nkin_fn = kin\nkin_grad_fn = kin_grad\n" in text
    assert (
        "from identifier.ekf import SPEED_LOG_GATE_NIS, _EXPLODED, _NONFINITE, _NOT_PD, _OK,"
        in text
    )


def test_kernels_fill_the_symbolic_regressors(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """``phi`` of the generated module equals the symbolic structure's regressors."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    structure = get_model("prime-cubic")
    module = kernel_module(structure)
    out = np.empty(structure.n_coefficients)
    module.phi(5.0, -0.3, 0.01, 0.2, 1.5, kernel_constants(structure, 100.0), out)
    expected = numeric_model(structure).regressors(5.0, -0.3, 0.01, 0.2, 1.5, 100.0)
    np.testing.assert_allclose(out, expected, rtol=1e-14, atol=1e-300)


def test_structures_of_a_family_share_one_module_with_their_shape_at_run_time(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """Two shapes of prime-rudder: one module; each shape's φ and ∂φ/∂s are its own."""
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    family = parse_family("prime-rudder")
    assert family is not None
    shapes = [
        {**family[0].default_shape},
        {"k": 0.002, "gamma": 0.9, "dgamma": -0.2, "l": -0.6, "wake": 0.3, "dwake": 0.25},
    ]
    first, second = (family[0].structure(s) for s in shapes)
    assert first != second
    assert kernel_source(first, (_EKF_PASS,)) == kernel_source(second, (_EKF_PASS,))
    module = kernel_module(first)
    assert kernel_module(second) is module
    state = (7.0, -0.4, -0.02, 0.3, 2.0)  # u, v, r, δ, n: a turn with drift
    length_m = 320.0
    for structure, shape in zip((first, second), shapes, strict=True):
        constants = kernel_constants(structure, length_m)
        assert constants.tolist() == [length_m, *(shape[c.name] for c in family[0].shape)]
        phi = np.empty(structure.n_coefficients)
        grad = np.empty(3 * structure.n_coefficients)
        module.phi(*state, constants, phi)
        module.grad(*state, constants, grad)
        model = numeric_model(structure)
        np.testing.assert_allclose(phi, model.regressors(*state, length_m), rtol=1e-13)
        expected_grad = np.array(model._regressor_gradients(*state, length_m), dtype=float)
        np.testing.assert_allclose(grad, expected_grad.ravel(), rtol=1e-12, atol=1e-15)


def test_binding_needs_the_bound_parameters_bound_once() -> None:
    structure = get_model("shi2009")
    too_many = Binding("too_many", _EKF_PASS.template, tuple(f"k{i}" for i in range(40)))
    with pytest.raises(ValueError, match="not a function of at least 40 parameters"):
        kernel_source(structure, (too_many,))
    twice = Binding("again", _EKF_PASS.template, ("kin", "grad", "phi", "kin_grad"))
    with pytest.raises(ValueError, match="parameter 'phi_fn' is bound to two names"):
        kernel_source(structure, (_EKF_PASS, twice))
    # A binding named as a global its template uses would shadow it.
    shadowing = Binding("_add_track_residual", _EKF_PASS.template, _EKF_PASS.bound)
    with pytest.raises(ValueError, match=r"globals named as .*\['_add_track_residual'\]"):
        kernel_source(structure, (shadowing,))


def test_cache_directory_falls_back_when_the_user_cache_is_not_writable(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("not a directory")
    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(blocked))  # mkdir below a file fails
    monkeypatch.setenv("TMPDIR", str(tmp_path / "tmp"))
    (tmp_path / "tmp").mkdir()
    monkeypatch.setattr(tempfile, "tempdir", None)  # re-read TMPDIR
    directory = cache_directory()
    assert directory.parent == tmp_path / "tmp"
    assert directory.name.startswith("shipid-kernels-")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert cache_directory() == tmp_path / "cache" / "shipid" / "kernels"


def test_configured_directory_that_cannot_be_made_is_an_error(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    blocked = tmp_path / "file"
    blocked.write_text("not a directory")
    monkeypatch.setenv(CACHE_ENV, str(blocked / "kernels"))
    with pytest.raises(OSError, match="no writable kernel cache directory"):
        cache_directory()


def test_binding_keeps_the_source_of_its_import_when_the_file_changes(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    """An upgrade that rewrites a template's file while a process runs changes nothing."""
    package = tmp_path / "templatepkg"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "loops.py").write_text(
        "def loop(phi_fn, x, out):\n    phi_fn(x, 0.0, 0.0, 0.0, 0.0, 1.0, out)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    from templatepkg import loops  # type: ignore[import-not-found]

    binding = Binding("bound_loop", loops.loop, ("phi",))
    (package / "loops.py").write_text('"""Moved down."""\n\n\n' + "x = 1\n" * 5)
    import linecache

    linecache.clearcache()
    text = kernel_source(get_model("shi2009"), (binding,))
    assert "def bound_loop(x, out):\n    phi_fn(x, 0.0, 0.0, 0.0, 0.0, 1.0, out)" in text
    for name in ("templatepkg", "templatepkg.loops"):
        monkeypatch.delitem(sys.modules, name)
