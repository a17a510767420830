"""The native FMU from two plain C masters: FMI 2.0 (``tests/c_host/host.c``) and FMI 3.0
(``tests/c_host/host3.c``).

Both dlopen the FMU's binary and read what they need from its modelDescription.xml
(GUID or instantiationToken, value references by name), compiled here against the FMI
headers the FMU itself is built with (fmpy's). The FMI 3.0 host's self-test (two
instances, state round trips, bad calls, divergence, reset) runs alone and under
valgrind; then both hosts sail the same manoeuvres of ``tests/c_host/manoeuvre.h`` (a 35°
turn, 10°/10° zig-zags, one in a current) and print them: the FMI 2.0 and FMI 3.0 runs
must be identical to the last bit, and equal ``fmu_model.simulate`` on the inputs they
printed to 1e-12 (relative to each output's range). The FMI 2.0 host's self-test is in
``tests/test_fmu_native.py``.
"""

from __future__ import annotations

import io
import math
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract

from fmu_model import ModelParameters, simulate
from fmu_model.envelope import Envelope, Sides, Span
from fmu_model.environment import (
    course_over_ground,
    current_velocity_ne,
    ground_velocity_ne,
    speed_over_ground,
)
from fmu_model.export_native import build_native_fmu, fmi_headers_dir
from tests.test_fmu_native import assert_matches_model, make_params

C_HOST = Path(__file__).resolve().parent / "c_host"
HOSTS = {"2": "host.c", "3": "host3.c"}
LIBRARIES = {"2": "binaries/linux64/Test_Ship.so", "3": "binaries/x86_64-linux/Test_Ship.so"}
MANOEUVRES = ("turn-35", "zigzag-10", "zigzag-10-current")
RUN_STEP_S, RUN_RPM, MAX_STEP_S = 0.1, 120.0, 0.05  # of manoeuvre.h; the FMU's max_step
STATES = ["u", "v", "r", "x", "y", "psi"]


@pytest.fixture(scope="module")
def params() -> ModelParameters:
    return make_params()


@pytest.fixture(scope="module")
def hosts(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Both hosts, compiled as strictly as the FMU's own sources."""
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        pytest.skip("no C compiler")
    folder = tmp_path_factory.mktemp("hosts")
    built = {}
    for version, source in HOSTS.items():
        exe = folder / Path(source).stem
        command = [compiler, "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror", "-O2"]
        command += ["-I", str(fmi_headers_dir()), str(C_HOST / source), "-o", str(exe)]
        subprocess.run([*command, "-ldl", "-lm"], check=True, capture_output=True, text=True)
        built[version] = exe
    return built


@pytest.fixture(scope="module")
def libraries(tmp_path_factory: pytest.TempPathFactory, params: ModelParameters) -> dict[str, Path]:
    """The shared library of the unpacked co-simulation FMU, FMI 2.0 and 3.0."""
    folder = tmp_path_factory.mktemp("fmus")
    found = {}
    for version, library in LIBRARIES.items():
        fmu = build_native_fmu(
            params, folder / f"fmi{version}" / "Test_Ship.fmu", fmi_version=version, kinds=("cs",)
        )
        found[version] = Path(extract(str(fmu), str(folder / f"x{version}"))) / library
    return found


def test_fmi3_host_self_test(hosts: dict[str, Path], libraries: dict[str, Path]) -> None:
    done = subprocess.run(
        [str(hosts["3"]), str(libraries["3"]), "3000"], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("ok: FMI 3.0, 2 instances x 3000 steps"), done.stdout
    assert done.stderr == ""  # every message it provoked was one it expected


def test_fmi3_host_under_valgrind(hosts: dict[str, Path], libraries: dict[str, Path]) -> None:
    valgrind = shutil.which("valgrind")
    if valgrind is None:
        pytest.skip("valgrind not installed")
    done = subprocess.run(
        [
            *(valgrind, "--leak-check=full", "--error-exitcode=3", "-q"),
            *(str(hosts["3"]), str(libraries["3"]), "1000"),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr


def _sail(host: Path, library: Path, manoeuvre: str) -> str:
    done = subprocess.run(
        [str(host), str(library), "--run", manoeuvre], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("manoeuvre", MANOEUVRES)
def test_both_hosts_sail_the_python_model(
    hosts: dict[str, Path], libraries: dict[str, Path], params: ModelParameters, manoeuvre: str
) -> None:
    fmi2, fmi3 = (_sail(hosts[v], libraries[v], manoeuvre) for v in ("2", "3"))
    assert fmi3 == fmi2  # FMI 3.0 and 2.0: the same numbers to the last bit
    run = np.genfromtxt(io.StringIO(fmi3), delimiter=",", names=True)
    t = run["time"]
    assert t.size == 3001 and np.all(np.diff(t) > 0.0)
    assert np.all(run["propeller_rpm"] == RUN_RPM)
    start = [run[name][0] for name in STATES]
    assert start == [params.nominal_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0]  # the start values
    # The printed inputs were held over the step after their row (the last row's unused).
    want = simulate(
        params,
        t,
        run["rudder_angle"],
        run["propeller_rpm"] / 60.0,
        start,
        method="rk4",
        max_step_s=MAX_STEP_S,
        current_speed_mps=run["current_speed"],
        current_direction_rad=run["current_direction"],
    )
    assert_matches_model(np.column_stack([run[name] for name in STATES]), want)
    # sog and cog at a row: of its state and of the current set before the step to it
    # (the start value 0 at the first row).
    speed = np.concatenate([[0.0], run["current_speed"][:-1]])
    direction = np.concatenate([[0.0], run["current_direction"][:-1]])
    ground = ground_velocity_ne(
        want[:, 0], want[:, 1], want[:, 5], *current_velocity_ne(speed, direction)
    )
    assert_matches_model(
        np.column_stack([run["sog"], run["cog"]]),
        np.column_stack([speed_over_ground(*ground), course_over_ground(*ground)]),
    )
    # The manoeuvre was sailed: the rudder moved at the steering-gear rate, the ship turned.
    rudder_deg = np.degrees(run["rudder_angle"])
    assert np.max(np.abs(np.diff(rudder_deg))) == pytest.approx(0.234)
    if manoeuvre == "turn-35":
        assert rudder_deg.max() == pytest.approx(35.0) and want[-1, 5] > 2.0 * np.pi
    else:
        reversals = np.count_nonzero(np.diff(np.sign(np.diff(rudder_deg))) != 0)
        assert reversals >= 4 and np.max(np.abs(want[:, 5])) > np.radians(10.0)
    if manoeuvre.endswith("current"):
        assert np.all(run["current_speed"] == 0.5) and want[-1, 4] > 150.0  # set East


def test_hosts_refuse_an_unknown_manoeuvre(
    hosts: dict[str, Path], libraries: dict[str, Path]
) -> None:
    for version, host in hosts.items():
        done = subprocess.run(
            [str(host), str(libraries[version]), "--run", "spiral"], capture_output=True, text=True
        )
        assert (done.returncode, done.stderr) == (2, "unknown manoeuvre spiral\n")


def test_both_hosts_hear_the_warnings_beyond_the_logs(
    hosts: dict[str, Path], params: ModelParameters, tmp_path: Path
) -> None:
    """An FMU of logs steered to 20° and turned to r' 0.2: in the 35° turn the C layer
    formats one warning per axis, in FMI 2.0 and 3.0 the same; under valgrind where it is
    installed, without a memory error (without it, the warnings are still checked)."""
    valgrind = shutil.which("valgrind")
    memcheck = (
        () if valgrind is None else (valgrind, "--leak-check=full", "--error-exitcode=3", "-q")
    )
    logs = Envelope(
        Sides(math.radians(20.0), math.radians(20.0)),
        Sides(0.2, 0.2),
        0.0,
        Span(params.nominal_speed_mps, params.nominal_speed_mps),
        Span(RUN_RPM / 60.0, RUN_RPM / 60.0),
    )
    identified = replace(params, identification={"envelope": logs.as_dict()})
    heard = {}
    for version, library in LIBRARIES.items():
        fmu = build_native_fmu(
            identified, tmp_path / f"fmi{version}" / "Test_Ship.fmu", fmi_version=version
        )
        unpacked = Path(extract(str(fmu), str(tmp_path / f"x{version}"))) / library
        done = subprocess.run(
            [*memcheck, str(hosts[version]), str(unpacked), "--run", "turn-35"],
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert done.returncode == 0, done.stderr
        heard[version] = [
            line.split("logStatusWarning (1): ", 1)[1].replace(f"fmi{version}DoStep", "DoStep")
            for line in done.stderr.splitlines()
        ]
    assert heard["3"] == heard["2"]
    said = sorted(line.split(", the model extrapolates: ", 1)[1] for line in heard["2"])
    assert len(said) == 2  # once each (r' passes 0.21 before the rudder, at 2.3°/s, 21°)
    assert said[0].startswith("rudder ") and said[0].endswith(" to starboard (logs: 20.0 deg)")
    assert said[1].startswith("yaw rate r' ") and said[1].endswith(" to starboard (logs: 0.20)")
