"""Soak: the native FMU over 24 simulated hours, bad inputs, and killed writers."""

from __future__ import annotations

import hashlib
import math
import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave

from fmu_model import ModelParameters
from fmu_model.atomic import STALE_TEMPORARY_AGE_S, write_atomic
from fmu_model.export_native import build_native_fmu
from tests.conftest import SEED_COEFFICIENTS

ROOT = Path(__file__).resolve().parents[1]
VR_RUDDER, VR_RPM = 0, 1
VR_STATES = [2, 3, 4, 5, 6, 7]  # u, v, r, x, y, psi
FMI2_ERROR = 3
STEP_S = 0.05
DAY_S = 24 * 3600.0
# Bounds of a sane state for the seed ship (L = 100 m, 5 m/s at 120 rpm) whatever the
# rudder within +-35 deg and 50-150 % rpm: it never stops or reverses (u > 0), nor
# drifts or spins faster than this.
MAX_U_MPS, MAX_V_MPS, MAX_R_RADPS = 10.0, 3.0, 0.1  # seen: 7.5, 2.1, 0.056


@pytest.fixture(scope="module")
def slave(seed_fmu: Path, tmp_path_factory: pytest.TempPathFactory) -> Iterator[FMU2Slave]:
    unzipped = extract(seed_fmu, unzipdir=tmp_path_factory.mktemp("unzipped"))
    md = read_model_description(unzipped)
    fmu = FMU2Slave(
        guid=md.guid,
        unzipDirectory=unzipped,
        modelIdentifier=md.coSimulation.modelIdentifier,
        instanceName="soak",
    )
    fmu.instantiate()
    yield fmu
    fmu.freeInstance()


@pytest.fixture(scope="module")
def seed_fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    return build_native_fmu(params, tmp_path_factory.mktemp("fmu") / "testship.fmu")


def _input_schedule(rng: np.random.Generator, n_steps: int) -> list[tuple[int, float, float]]:
    """(step, rudder [rad], rpm) changes every 30-120 s: rudder within +-35 deg, 60-180 rpm."""
    changes = []
    t = 0.0
    while t < n_steps * STEP_S:
        step = round(t / STEP_S)
        changes.append(
            (step, math.radians(rng.uniform(-35.0, 35.0)), 120.0 * rng.uniform(0.5, 1.5))
        )
        t += rng.uniform(30.0, 120.0)
    return changes


def test_native_fmu_survives_24_hours_at_50_ms_steps(slave: FMU2Slave) -> None:
    n_steps = round(DAY_S / STEP_S)
    assert n_steps == 1_728_000
    rng = np.random.default_rng(2024)
    changes = _input_schedule(rng, n_steps)
    assert 700 < len(changes) < 2900
    slave.reset()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    # The state is read every second (20 steps); the FMU itself rejects a non-finite or
    # diverging state in every step with fmi2Discard, which fmpy raises.
    every = 20
    samples = np.empty((n_steps // every, 6))
    do_step, get_real = slave.doStep, slave.getReal
    bounds = [c[0] for c in changes[1:]] + [n_steps]
    k = 0
    for (first, rudder, rpm), end in zip(changes, bounds, strict=True):
        slave.setReal([VR_RUDDER, VR_RPM], [rudder, rpm])
        while k < end:
            do_step(k * STEP_S, STEP_S)
            k += 1
            if k % every == 0:
                samples[k // every - 1] = get_real(VR_STATES)
        assert k == end >= first
    assert slave.getRealStatus(kind=2) == pytest.approx(DAY_S)  # fmi2LastSuccessfulTime
    u, v, r, x, y, psi = samples.T
    assert np.all(np.isfinite(samples))
    assert 0.0 < u.min() and u.max() < MAX_U_MPS
    assert np.abs(v).max() < MAX_V_MPS and np.abs(r).max() < MAX_R_RADPS
    distance = np.hypot(np.diff(x), np.diff(y))  # per second
    assert distance.max() < MAX_U_MPS + MAX_V_MPS
    # The rudder really was exercised: the ship turned hundreds of full circles.
    assert np.abs(np.diff(psi)).max() < MAX_R_RADPS
    assert np.abs(np.diff(psi)).sum() > 200 * 2.0 * math.pi


def test_native_fmu_rejects_inputs_outside_their_ranges(slave: FMU2Slave) -> None:
    slave.reset()
    slave.setupExperiment(startTime=0.0)
    slave.enterInitializationMode()
    slave.exitInitializationMode()
    slave.setReal([VR_RUDDER, VR_RPM], [math.radians(20.0), 120.0])
    slave.doStep(0.0, STEP_S)
    before = slave.getReal([VR_RUDDER, VR_RPM, *VR_STATES])
    bad = [
        ([VR_RUDDER], [math.radians(45.5)]),
        ([VR_RUDDER], [-math.radians(46.0)]),
        ([VR_RUDDER], [math.nan]),
        ([VR_RPM], [math.nan]),
        ([VR_RPM], [math.inf]),
        ([VR_RPM], [6000.5]),  # beyond the +-6000 rpm of any marine propeller
        ([VR_RPM], [-1e9]),
        ([VR_RUDDER, VR_RPM], [0.0, math.nan]),  # all or nothing: rudder not applied
    ]
    for vrs, values in bad:
        with pytest.raises(FMICallException) as info:
            slave.setReal(vrs, values)
        assert info.value.status == FMI2_ERROR, (vrs, values)
        assert slave.getReal([VR_RUDDER, VR_RPM, *VR_STATES]) == before
    # The documented limit itself is accepted, and the instance goes on stepping.
    slave.setReal([VR_RUDDER], [math.radians(45.0)])
    slave.doStep(STEP_S, STEP_S)
    assert all(math.isfinite(s) for s in slave.getReal(VR_STATES))


# --------------------------------------------------------------------------- killed writer

_WRITER = textwrap.dedent(
    """
    import hashlib, os, sys, time
    from fmu_model.atomic import write_atomic

    target, size, mode = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    real_fsync = os.fsync

    def slow_fsync(fd):
        # The temporary file holds all data, not yet renamed: be killed here.
        print("fsync", flush=True)
        time.sleep(60.0)
        real_fsync(fd)

    if mode == "slow":
        os.fsync = slow_fsync
    print("ready", flush=True)
    for n in range(1, 10**6):
        body = bytes([n % 251]) * size
        header = f"{n} {hashlib.sha256(body).hexdigest()}\\n".encode()
        write_atomic(target, header + body)
    """
)


def _check_complete(path: Path, size: int) -> int:
    """Return the sequence number of a complete payload at ``path`` (else fail)."""
    data = path.read_bytes()
    header, _, body = data.partition(b"\n")
    number, digest = header.decode().split()
    assert len(body) == size and hashlib.sha256(body).hexdigest() == digest
    return int(number)


def _spawn(target: Path, size: int, mode: str) -> subprocess.Popen[str]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.Popen(
        [sys.executable, "-c", _WRITER, str(target), str(size), mode],
        stdout=subprocess.PIPE,
        text=True,
        env=env,
    )


def _kill(process: subprocess.Popen[str]) -> None:
    process.send_signal(signal.SIGKILL)
    process.wait(timeout=10)
    assert process.returncode == -signal.SIGKILL
    assert process.stdout is not None
    process.stdout.close()


def test_a_killed_writer_never_leaves_a_half_written_file(tmp_path: Path) -> None:
    size = 8 << 20
    target = tmp_path / "params.json"
    body = b"\x00" * size
    write_atomic(target, f"0 {hashlib.sha256(body).hexdigest()}\n".encode() + body)

    # Deterministic: killed when the new data are all in the temporary file, but
    # before the rename. The previous file is intact; the new one never appears.
    writer = _spawn(target, size, "slow")
    assert writer.stdout is not None
    assert writer.stdout.readline() == "ready\n"
    assert writer.stdout.readline() == "fsync\n"
    _kill(writer)
    assert _check_complete(target, size) == 0
    leftovers = [p for p in tmp_path.iterdir() if p != target]
    assert len(leftovers) == 1 and leftovers[0].name.startswith(".params.json.")
    assert leftovers[0].stat().st_size == len(target.read_bytes())  # complete, unused
    leftovers[0].unlink()

    # At random moments of a writer replacing the file as fast as it can: whatever
    # was interrupted, the target is always one complete version.
    rng = np.random.default_rng(7)
    numbers = []
    for _ in range(4):
        writer = _spawn(target, size, "fast")
        assert writer.stdout is not None and writer.stdout.readline() == "ready\n"
        try:
            writer.wait(timeout=rng.uniform(0.2, 0.8))
        except subprocess.TimeoutExpired:
            pass
        _kill(writer)
        numbers.append(_check_complete(target, size))
    assert max(numbers) > 0  # the writer did replace the file before being killed


def test_the_next_write_removes_what_a_killed_writer_left_behind(tmp_path: Path) -> None:
    """kill -9 between the temporary file and the rename: cleaned once it is stale."""
    size = 1 << 20
    target = tmp_path / "params.json"
    body = b"\x00" * size
    write_atomic(target, f"0 {hashlib.sha256(body).hexdigest()}\n".encode() + body)
    writer = _spawn(target, size, "slow")
    assert writer.stdout is not None
    assert writer.stdout.readline() == "ready\n"
    assert writer.stdout.readline() == "fsync\n"
    _kill(writer)
    (leftover,) = (p for p in tmp_path.iterdir() if p != target)
    assert leftover.name.startswith(".params.json.") and leftover.name.endswith(".tmp")

    # At once, the file could still be a live writer's (on another host, say): kept.
    write_atomic(target, b"1\n")
    assert leftover.exists()
    # Once it has not changed for STALE_TEMPORARY_AGE_S, the next write removes it.
    then = time.time() - STALE_TEMPORARY_AGE_S - 1.0
    os.utime(leftover, (then, then))
    write_atomic(target, b"2\n")
    assert sorted(tmp_path.iterdir()) == [target] and target.read_bytes() == b"2\n"
