"""Cost of one co-simulation step and of a 1-hour manoeuvre, per FMU backend and kind.

    python benchmarks/fmu_step.py [--params build/params.json] [--steps 20000]

For every backend in :func:`backends` (a list of (label, FMU path); adding a backend is
one line there: native C FMI 2.0, native C FMI 3.0, pythonfmu) it reports

* µs per step in an fmpy loop (set inputs, DoStep, get outputs, h = 0.1 s; the best of
  :data:`LOOP_REPEATS` loops, as ``timeit`` advises: the pythonfmu loops vary by ±30 %
  from one run to the next on a busy machine),
* µs per step in the C host ``tests/c_host/host.c`` (FMI 2.0 only; same loop without
  Python; a pythonfmu FMU runs there with libpython preloaded,
  :func:`python_host_environment`),
* seconds for a 1-hour run at 0.1 s with ``fmpy.simulate_fmu`` in co-simulation, and,
  for an FMU with model exchange, with fmpy's CVode (relative tolerance 1e-6),

and the fmpy-loop cost of every backend relative to the first one (native C, FMI 2.0).

Without ``--params`` (or when the file does not exist) a built-in demo ship is used.
"""

from __future__ import annotations

import argparse
import os
import shutil
import site
import subprocess
import sys
import sysconfig
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave

from fmu_model import ModelParameters, load_params
from fmu_model.envelope import Envelope, Sides, Span
from fmu_model.export_native import build_native_fmu, fmi_headers_dir
from fmu_model.export_pythonfmu import build_pythonfmu_fmu

ROOT = Path(__file__).resolve().parents[1]
HOST_SOURCE = ROOT / "tests" / "c_host" / "host.c"
STEP_S = 0.1
HOUR_S = 3600.0
LOOP_REPEATS = 3
VR_INPUTS = [0, 1]  # rudder_angle [rad], propeller_rpm [rpm]
VR_OUTPUTS = [2, 3, 4, 5, 6, 7]  # u, v, r, x, y, psi

# A stable ~100 m ship in equilibrium at 5 m/s and 2 rev/s (as in tests/test_fmu_native.py).
DEMO_COEFFICIENTS = (
    *(-0.01, -0.005, -2.0, -0.05, 0.1, 0.0, 0.0, 0.0, 0.0625),
    *(-0.5, 0.0, 0.05, -0.2),
    *(0.001, -0.5, 0.02),
)


def demo_params() -> ModelParameters:
    """Parameters of the built-in demo ship, with an envelope of logs the loop stays in."""
    logs = Envelope(Sides(0.5, 0.5), Sides(2.0, 2.0), 0.0, Span(0.0, 10.0), Span(0.0, 4.0))
    return ModelParameters(
        model="shi2009",
        coefficients=np.array(DEMO_COEFFICIENTS),
        length_m=100.0,
        vessel_name="Benchmark Ship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
        identification={"envelope": logs.as_dict()},
    )


def without_envelope(params: ModelParameters) -> ModelParameters:
    """``params`` without the envelope of their logs: an FMU that judges nothing."""
    kept = {k: v for k, v in params.identification.items() if k != "envelope"}
    return replace(params, identification=kept)


def backends(params: ModelParameters, workdir: Path) -> list[tuple[str, Path]]:
    """(label, FMU path) of every backend to compare; one line per backend.

    The ``no envelope`` rows are the same FMUs built without the envelope of the logs:
    what the check beyond the logs (``fmu_model.envelope``) costs per step.
    """
    bare = without_envelope(params)
    return [
        ("native C", build_native_fmu(params, workdir / "native" / "ship.fmu")),
        ("C, no envelope", build_native_fmu(bare, workdir / "bare" / "ship.fmu")),
        ("native FMI3", build_native_fmu(params, workdir / "fmi3" / "ship.fmu", fmi_version="3")),
        ("pythonfmu", build_pythonfmu_fmu(params, workdir / "pythonfmu" / "ship.fmu")),
        ("py, no envelope", build_pythonfmu_fmu(bare, workdir / "pybare" / "ship.fmu")),
    ]


def fmpy_loop_us(fmu_path: Path, steps: int) -> float:
    """µs per step of set inputs / doStep / get outputs driven from Python by fmpy."""
    unzipped = extract(fmu_path)
    try:
        md = read_model_description(unzipped)
        identifier = md.coSimulation.modelIdentifier
        rudder = np.radians(20.0) * np.sin(2.0 * np.pi * np.arange(steps) * STEP_S / 200.0)
        if md.fmiVersion == "2.0":
            fmu = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=identifier)
            fmu.instantiate()
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            set_values, get_values = fmu.setReal, fmu.getReal
        else:
            fmu = FMU3Slave(
                guid=md.instantiationToken, unzipDirectory=unzipped, modelIdentifier=identifier
            )
            fmu.instantiate()
            fmu.enterInitializationMode(startTime=0.0)
            set_values, get_values = fmu.setFloat64, fmu.getFloat64
        fmu.exitInitializationMode()
        start = time.perf_counter()
        for k in range(steps):
            set_values(VR_INPUTS, [float(rudder[k]), 120.0])
            fmu.doStep(k * STEP_S, STEP_S)
            get_values(VR_OUTPUTS)
        elapsed = time.perf_counter() - start
        fmu.terminate()
        fmu.freeInstance()
    finally:
        shutil.rmtree(unzipped, ignore_errors=True)
    return 1e6 * elapsed / steps


def compile_host(workdir: Path) -> Path | None:
    """Compile the C host; None when there is no C compiler."""
    compiler = shutil.which("gcc") or shutil.which("cc")
    if compiler is None:
        return None
    exe = workdir / "host"
    command = [compiler, "-std=c99", "-O2", "-I", str(fmi_headers_dir()), str(HOST_SOURCE)]
    subprocess.run([*command, "-o", str(exe), "-ldl", "-lm"], check=True)
    return exe


def host_us(host: Path | None, fmu_path: Path, steps: int, workdir: Path) -> float | None:
    """µs per step in the C host, or None when it cannot run this FMU."""
    if host is None:
        return None
    unzipped = Path(extract(fmu_path, unzipdir=tempfile.mkdtemp(dir=workdir)))
    md = read_model_description(unzipped)
    identifier = md.coSimulation.modelIdentifier
    libraries = list((unzipped / "binaries").glob(f"*/{identifier}.*"))
    if not libraries or md.fmiVersion != "2.0":  # the C host speaks FMI 2.0
        return None
    result = subprocess.run(
        [str(host), str(libraries[0]), str(steps), "--bench"],
        capture_output=True,
        text=True,
        env=python_host_environment() if "pythonfmu" in (md.generationTool or "").lower() else None,
    )
    if result.returncode != 0:
        return None
    for line in result.stdout.splitlines():
        if line.startswith("us_per_step "):
            return float(line.split()[1])
    return None


def python_host_environment() -> dict[str, str]:
    """Environment in which a C host can load a pythonfmu FMU.

    A pythonfmu binary does not link libpython: it expects the host process to have
    Python loaded (as fmpy has). A plain C host needs libpython preloaded and the
    packages the slave imports (pythonfmu, fmu_model) on PYTHONPATH.
    """
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    paths = [*site.getsitepackages(), str(ROOT)]
    return {**os.environ, "LD_PRELOAD": str(libpython), "PYTHONPATH": os.pathsep.join(paths)}


def hour_s(fmu_path: Path, fmi_type: str = "CoSimulation") -> float | None:
    """Seconds for a 1-hour turning run, output every 0.1 s, with fmpy.simulate_fmu.

    Co-simulation steps at 0.1 s; model exchange integrates with CVode (relative
    tolerance 1e-6). None when the FMU has no such kind.
    """
    md = read_model_description(str(fmu_path))
    if (md.modelExchange if fmi_type == "ModelExchange" else md.coSimulation) is None:
        return None
    options = {"solver": "CVode", "relative_tolerance": 1e-6} if fmi_type == "ModelExchange" else {}
    start = time.perf_counter()
    simulate_fmu(
        str(fmu_path),
        fmi_type=fmi_type,
        stop_time=HOUR_S,
        output_interval=STEP_S,
        start_values={"rudder_angle": np.radians(10.0)},
        **options,
    )
    return time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--params", type=Path, default=Path("build") / "params.json")
    parser.add_argument("--steps", type=int, default=20000, help="steps per timing loop")
    args = parser.parse_args()
    params = load_params(args.params) if args.params.is_file() else demo_params()
    print(f"vessel {params.vessel_name!r}, model {params.model}, h = {STEP_S} s")
    with tempfile.TemporaryDirectory(prefix="fmu-bench-") as tmp:
        workdir = Path(tmp)
        host = compile_host(workdir)
        rows = []
        for label, path in backends(params, workdir):
            in_host = host_us(host, path, 10 * args.steps, workdir)
            cs_hour, me_hour = hour_s(path), hour_s(path, "ModelExchange")
            assert cs_hour is not None  # every backend has co-simulation
            loop_us = min(fmpy_loop_us(path, args.steps) for _ in range(LOOP_REPEATS))
            rows.append((label, loop_us, in_host, cs_hour, me_hour))
    base_label, base_us = rows[0][0], rows[0][1]
    print(
        f"{'backend':<16} {'fmpy µs/step':>13} {f'x {base_label}':>12} {'C host µs/step':>15} "
        f"{'1 h CS s':>9} {'1 h ME CVode s':>15}"
    )
    for label, fmpy_us, c_us, cs_hour, me_hour in rows:
        c_text = "n/a" if c_us is None else f"{c_us:.3f}"
        me_text = "n/a" if me_hour is None else f"{me_hour:.2f}"
        print(
            f"{label:<16} {fmpy_us:>13.2f} {fmpy_us / base_us:>12.2f} {c_text:>15} "
            f"{cs_hour:>9.2f} {me_text:>15}"
        )
    print(
        "fmpy loop, µs per doStep: "
        + ", ".join(f"{row[0]} {row[1]:.2f}" for row in rows)
        + "".join(f"; {row[0]}/{base_label} = {row[1] / base_us:.2f}" for row in rows[1:])
    )
    print(
        "1 h manoeuvre, model exchange (CVode) / co-simulation: "
        + ", ".join(f"{row[0]} {me / row[3]:.2f}" for row in rows if (me := row[4]) is not None)
    )
    base_host = rows[0][2]
    if base_host is not None:
        print(
            "C host, µs per doStep: "
            + ", ".join(f"{row[0]} {row[2]:.3f}" for row in rows if row[2] is not None)
            + "".join(
                f"; {row[0]}/{base_label} = {row[2] / base_host:.0f}"
                for row in rows[1:]
                if row[2] is not None
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
