"""``identifier batch --scheduler`` on a real cluster: ``dask scheduler`` + two ``dask worker``.

The test starts the three processes itself on free ports, runs the batch CLI against
the scheduler, kills (SIGKILL) the worker running the first vessel while it works, and
checks that the batch still completes every vessel, that the killed vessel's task was
retried on the surviving worker, and that nothing is left running.
"""

from __future__ import annotations

import json
import math
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fmu_model import ModelParameters
from scenarios.synthesize import MANEUVERS, model_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials.logs import write_log

ROOT = Path(__file__).resolve().parents[1]
VESSELS = ("alpha", "beta", "gamma")
START_TIMEOUT_S = 30.0


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _fleet(root: Path) -> Path:
    """Three vessels of one 1 Hz zig-zag each, of the seed-model ship."""
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    ship = model_ship(params, rudder_rate_radps=math.radians(5.0))
    for seed, name in enumerate(VESSELS):
        log = synthesize_log(ship, MANEUVERS["zigzag-20"](), seed=seed)
        write_log(root / name / "zigzag-20.csv", log)
    return root


def _dask(*args: str, log: Path) -> subprocess.Popen[bytes]:
    with log.open("wb") as out:
        return subprocess.Popen(
            [sys.executable, "-m", "dask", *args], cwd=ROOT, stdout=out, stderr=subprocess.STDOUT
        )


def _worker(address: str, name: str, log: Path) -> subprocess.Popen[bytes]:
    """A single-threaded ``dask worker`` without a nanny: killing it kills the worker."""
    options = ("--nthreads", "1", "--no-nanny", "--no-dashboard", "--host", "127.0.0.1")
    return _dask("worker", address, "--name", name, *options, log=log)


def _stop(process: subprocess.Popen[bytes]) -> None:
    if process.poll() is None:
        process.kill()
    process.wait(timeout=30)


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[tuple[str, dict[str, subprocess.Popen[bytes]]]]:
    """A ``dask scheduler`` and two single-threaded ``dask worker`` processes (no nanny)."""
    from distributed import Client

    address = f"tcp://127.0.0.1:{_free_port()}"
    port = address.rsplit(":", 1)[1]
    scheduler = _dask(
        "scheduler", "--host", "127.0.0.1", "--port", port, "--no-dashboard",
        log=tmp_path / "scheduler.log",
    )  # fmt: skip
    workers = {name: _worker(address, name, tmp_path / f"{name}.log") for name in ("w1", "w2")}
    try:
        with Client(address, timeout=START_TIMEOUT_S) as client:
            client.wait_for_workers(2, timeout=START_TIMEOUT_S)
        yield address, workers
    finally:
        for process in (*workers.values(), scheduler):
            _stop(process)


def _worker_story(key: str, dask_worker: Any = None) -> list[str]:
    """Return the states a worker's task ``key`` went through (run on the worker)."""
    return [str(entry[2]) for entry in dask_worker.state.story(key) if len(entry) > 2]


def test_batch_survives_a_killed_worker_and_retries_its_vessel(
    tmp_path: Path, cluster: tuple[str, dict[str, subprocess.Popen[bytes]]]
) -> None:
    from distributed import Client

    address, workers = cluster
    fleet = _fleet(tmp_path / "fleet")
    out = tmp_path / "out"
    batch = subprocess.Popen(
        [sys.executable, "-m", "identifier", "batch", str(fleet), "--out", str(out),
         "--scheduler", address, "--model", "shi2009", "--method", "ekf", "--no-fmu"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
    )  # fmt: skip
    started = time.monotonic()
    try:
        with Client(address, timeout=START_TIMEOUT_S) as monitor:
            names = {a: w["name"] for a, w in monitor.scheduler_info()["workers"].items()}
            # Wait until a worker runs a vessel, then kill that worker outright.
            deadline = time.monotonic() + START_TIMEOUT_S
            busy: dict[str, tuple[str, ...]] = {}
            while not any(busy.values()):
                assert batch.poll() is None, batch.communicate()
                assert time.monotonic() < deadline, "no vessel started"
                busy = monitor.processing()
                time.sleep(0.05)
            victim_address, keys = next((a, k) for a, k in busy.items() if k)
            key = str(keys[0])
            time.sleep(0.5)  # the task is running, not just assigned
            workers[names[victim_address]].kill()
            survivor = next(a for a in names if a != victim_address)
            stdout, stderr = batch.communicate(timeout=120)
            assert batch.returncode == 0, stderr.decode()
            print(f"batch: {time.monotonic() - started:.1f} s, killed {names[victim_address]}")
            story = monitor.run(_worker_story, key, workers=[survivor])[survivor]
        assert "memory" in story, story  # the killed vessel ran again, to the end
    finally:
        _stop(batch)
    assert workers[names[victim_address]].wait(timeout=10) == -9
    lines = stdout.decode().splitlines()
    assert sorted(line.split(":")[0] for line in lines if ": ok (" in line) == sorted(VESSELS)
    # The bar of vessels done (stderr) reached all of them.
    n = len(VESSELS)
    assert f"{n}/{n} [" in stderr.decode().replace("\r", "\n").splitlines()[-1]
    for name in VESSELS:
        done = json.loads((out / name / "done.json").read_text())
        assert done["inputs"] and (out / name / "params.json").is_file()
