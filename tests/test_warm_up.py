"""``python -m scenarios warm-up``: after it, a fit of other logs compiles nothing."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from fmu_model import DEFAULT_MODEL
from fmu_model.kernels import CACHE_ENV
from identifier.identify import fixed_thrust_model

# A fit of two other logs (other manoeuvres, rate and noise than the warm-up's zig-zag)
# under the default and the still-water settings, in a fresh interpreter: what numba
# compiled and what it loaded from the caches.
_FIT = """
import json
from fmu_model.kernels import numba_compilations
from identifier.identify import FitSettings, identify
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log

ship = reference_ship("kvlcc2", "full")
logs = [
    synthesize_log(ship, MANEUVERS[name](), rate_hz=2.0, seed=3)
    for name in ("turning-35", "zigzag-20")
]
for current in ("constant", "none"):
    identify(logs, FitSettings(current=current))
compiled, loaded = numba_compilations()
print(json.dumps({"compiled": compiled, "loaded": loaded}))
"""


@pytest.mark.order("first")  # long: started first (conftest.py)
def test_after_warm_up_a_fit_loads_every_compiled_function(tmp_path: Path) -> None:
    # Both caches empty, as on a fresh machine: numba's own (the smoother's) and the
    # generated kernel modules'.
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "numba"),
        CACHE_ENV: str(tmp_path / "kernels"),
    }
    warm = subprocess.run(
        [sys.executable, "-m", "scenarios", "warm-up", "--quiet"],
        capture_output=True,
        text=True,
        env=env,
        timeout=900,
    )
    assert warm.returncode == 0, warm.stderr
    match = re.search(r"(\d+) numba functions compiled, (\d+) loaded", warm.stdout)
    assert match, warm.stdout
    assert int(match[1]) > 0  # it compiled (the count is not always 0) ...
    assert list((tmp_path / "kernels").glob("shipid_kernels_*.py"))  # ... into the caches
    # ... of the default family and of what a default fit may be refitted as
    assert f"warm-up of {DEFAULT_MODEL}:" in warm.stdout
    assert f"warm-up of {fixed_thrust_model(DEFAULT_MODEL)}:" in warm.stdout
    fit = subprocess.run(
        [sys.executable, "-c", _FIT], capture_output=True, text=True, env=env, timeout=900
    )
    assert fit.returncode == 0, fit.stderr
    counts = json.loads(fit.stdout.strip().splitlines()[-1])
    assert counts["compiled"] == 0
    assert counts["loaded"] > 0
