"""Throughput of batch identification, 1 worker against 2, on the same vessels.

    python benchmarks/batch.py [--vessels 4] [--rate-hz 1] [--no-fmu] [--cold]

Each vessel has three trial logs (turning circle 35°, zig-zag 10/10 and 20/20) at
``--rate-hz``, synthesised once into a temporary directory from the KVLCC2 reference
ship (full and model scale) and the fmu_step demo ship, in turn, each with its own
noise seed. The kernel cache (``fmu_model.kernels``) is a new temporary directory,
filled first by one untimed batch of all the vessels, so that no timed run compiles a
model's EKF or replay. For 1 and then 2 single-threaded worker processes, a
``LocalCluster`` is started and warmed up (each worker identifies one log: imports,
numba's own start), then :func:`identifier.batch.run_batch` identifies all vessels on it
(and builds their FMUs unless ``--no-fmu``). Reported: manoeuvre logs identified per
minute and the 2-worker / 1-worker ratio. ``--cold`` also times a run on a fresh
cluster started by ``run_batch`` itself (process start included).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from fmu_step import demo_params

from fmu_model.kernels import CACHE_ENV
from identifier.batch import BatchSummary, run_batch
from scenarios.synthesize import MANEUVERS, TruthShip, model_ship, reference_ship, synthesize_log
from trials.cluster import local_client
from trials.logs import write_log

MANEUVER_NAMES = ("turning-35", "zigzag-10", "zigzag-20")


def ships() -> list[TruthShip]:
    """Return the truth ships the vessels cycle through."""
    return [
        reference_ship("kvlcc2", "full"),
        reference_ship("kvlcc2", "model"),
        model_ship(demo_params()),
    ]


def make_fleet(root: Path, n_vessels: int, rate_hz: float) -> int:
    """Write ``n_vessels`` folders of three logs each under ``root``; return the log count."""
    truth = ships()
    count = 0
    for i in range(n_vessels):
        ship = truth[i % len(truth)]
        for j, name in enumerate(MANEUVER_NAMES):
            log = synthesize_log(ship, MANEUVERS[name](), rate_hz=rate_hz, seed=10 * i + j)
            write_log(root / f"vessel-{i + 1}" / f"{name}.csv", log)
            count += 1
    return count


def _warm_up(path: str) -> float:
    """Identify one log in this worker process (numba compilation); return seconds."""
    from identifier.identify import identify
    from trials.logs import read_log

    start = time.perf_counter()
    identify([read_log(path)])
    return time.perf_counter() - start


def timed_batch(
    fleet: Path, out: Path, n_workers: int, build_fmu: bool, warm: bool
) -> tuple[BatchSummary, float]:
    """Run the batch with ``n_workers``; return its summary and wall time [s]."""
    if not warm:
        start = time.perf_counter()
        summary = run_batch(fleet, out, n_workers=n_workers, build_fmu=build_fmu)
        return summary, time.perf_counter() - start
    with local_client(n_workers) as client:
        first_log = next(fleet.glob("*/*.csv"))
        client.run(_warm_up, str(first_log))
        address = client.scheduler_info()["address"]  # a round trip: not timed
        start = time.perf_counter()
        summary = run_batch(fleet, out, scheduler=address, build_fmu=build_fmu)
        return summary, time.perf_counter() - start


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--vessels", type=int, default=4, help="number of vessels")
    parser.add_argument("--rate-hz", type=float, default=1.0, help="logging rate [Hz]")
    parser.add_argument("--no-fmu", action="store_true", help="params.json only, no FMU")
    parser.add_argument("--cold", action="store_true", help="also time fresh clusters")
    args = parser.parse_args()
    build_fmu = not args.no_fmu
    with tempfile.TemporaryDirectory(prefix="batch-bench-") as tmp:
        root = Path(tmp)
        os.environ[CACHE_ENV] = str(root / "kernels")  # the workers inherit it
        fleet = root / "fleet"
        n_logs = make_fleet(fleet, args.vessels, args.rate_hz)
        filled = time.perf_counter()
        run_batch(fleet, root / "out-fill", build_fmu=False)
        print(f"kernel cache filled by an untimed batch in {time.perf_counter() - filled:.1f} s")
        print(
            f"{args.vessels} vessels x {len(MANEUVER_NAMES)} logs at {args.rate_hz:g} Hz, "
            f"{'params.json + FMU' if build_fmu else 'params.json'}"
        )
        print(f"{'cluster':<22}{'workers':>8}{'seconds':>9}{'logs/min':>10}")
        rates: dict[tuple[bool, int], float] = {}
        n_samples = 0
        for warm in (True, False) if args.cold else (True,):
            for n_workers in (1, 2):
                out = root / f"out-{'warm' if warm else 'cold'}-{n_workers}"
                summary, seconds = timed_batch(fleet, out, n_workers, build_fmu, warm)
                if not summary.ok:
                    failure = summary.failed[0]
                    print(f"batch failed: {failure.name}: {failure.error}")
                    return 1
                rates[warm, n_workers] = n_logs / seconds * 60.0
                n_samples = sum(v.n_samples for v in summary.vessels)
                label = "warm (compiled)" if warm else "cold (new cluster)"
                print(f"{label:<22}{n_workers:>8}{seconds:>9.1f}{rates[warm, n_workers]:>10.1f}")
        for warm in (True, False) if args.cold else (True,):
            ratio = rates[warm, 2] / rates[warm, 1]
            print(f"2 / 1 workers, {'warm' if warm else 'cold'}: {ratio:.2f}x")
        print(f"({n_logs} logs, {n_samples:,} samples in all)")
    if hasattr(os, "getloadavg"):
        load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
        print(f"load average {load} on {os.cpu_count()} CPUs (a busy machine cannot scale)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
