"""Monte-Carlo uncertainty on an identified KVLCC2 model: 1 vs 2 dask workers, containment.

    python benchmarks/uncertainty.py [--params P.json] [--save-params P.json]
        [--samples 200] [--seed 0] [--chunk-size 50] [--workers 1,2] [--dt-s 0.5]

Without ``--params`` the model is identified here: noisy trial logs of the KVLCC2
reference ship (35° turning both ways, 10/10 and 20/20 zig-zag, seeds 0–3) fitted with
the default structure with output-error refinement (``fmu_model.DEFAULT_MODEL``, about
30 s); ``--save-params`` keeps it for the next run.

For every worker count a ``LocalCluster`` (one thread per worker process) is started,
warmed up (each worker compiles the model once) and then timed on the Monte-Carlo run
of the standard set (``trials.maneuvers.standard_set``). Printed: the timings side
by side with their ratio, whether the runs agree, the statistics table, and whether
the 95 % intervals contain the KVLCC2 values — from ``reference/kvlcc2_mmg.md`` §11
(canonical, fine step) and from the reference ship driven at the same step here.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from fmu_model import DEFAULT_MODEL, ModelParameters, ModelStructure, load_params, save_params
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from scenarios.uncertainty.monte_carlo import monte_carlo_metrics
from scenarios.uncertainty.results import UncertaintyResult
from trials.cluster import local_client
from trials.maneuvers import standard_set
from trials.metrics import turning_metrics, zigzag_metrics
from trials.run import run_program

LOGS = ("turning-35", "turning-35-port", "zigzag-10", "zigzag-20")

# reference/kvlcc2_mmg.md §11, full scale (L = 320 m), n_P = 105.01 rpm.
L_KVLCC2_M = 320.0
REFERENCE_S11: dict[tuple[str, str], float] = {
    ("turning-35-stbd", "advance_m"): 985.3,
    ("turning-35-stbd", "transfer_m"): 424.1,
    ("turning-35-stbd", "tactical_diameter_m"): 995.4,
    ("turning-35-stbd", "steady_diameter_m"): 2.3148 * L_KVLCC2_M,
    ("turning-35-port", "advance_m"): 988.8,
    ("turning-35-port", "transfer_m"): 424.1,
    ("turning-35-port", "tactical_diameter_m"): 990.9,
    ("turning-35-port", "steady_diameter_m"): 2.2472 * L_KVLCC2_M,
    ("zigzag-10-10-stbd", "first_overshoot_rad"): math.radians(5.001),
    ("zigzag-10-10-stbd", "second_overshoot_rad"): math.radians(13.937),
    ("zigzag-20-20-stbd", "first_overshoot_rad"): math.radians(10.583),
    ("zigzag-20-20-stbd", "second_overshoot_rad"): math.radians(15.823),
}


def identified_kvlcc2(model: str = DEFAULT_MODEL) -> ModelParameters:
    """Identify ``model`` from synthetic KVLCC2 logs (full scale, 1 Hz, seeds 0–3)."""
    from identifier.identify import FitSettings, identify

    ship = reference_ship("kvlcc2", "full")
    logs = [synthesize_log(ship, MANEUVERS[name](), seed=i) for i, name in enumerate(LOGS)]
    return identify(logs, FitSettings(model=model)).params


def reference_at_step(dt_s: float) -> dict[tuple[str, str], float]:
    """Metrics of the KVLCC2 reference ship on the standard set at step ``dt_s`` [SI]."""
    ship = reference_ship("kvlcc2", "full")
    out: dict[tuple[str, str], float] = {}
    for program in standard_set(ship.length_m, ship.speed_mps):
        traj = run_program(
            ship.plant,
            program,
            speed_mps=ship.speed_mps,
            n_rps=ship.n_rps,
            rudder_rate_radps=ship.rudder_rate_radps,
            dt_s=dt_s,
        )
        if program.kind == "turning":
            m = turning_metrics(traj)
            values = {
                "advance_m": m.advance_m,
                "transfer_m": m.transfer_m,
                "tactical_diameter_m": m.tactical_diameter_m,
                "steady_diameter_m": m.steady_diameter_m,
            }
        else:
            z = zigzag_metrics(traj, program.rudder_rad, program.heading_rad)
            values = {
                "first_overshoot_rad": z.first_overshoot_rad,
                "second_overshoot_rad": z.second_overshoot_rad,
            }
        out.update({(program.name, k): v for k, v in values.items() if v is not None})
    return out


def _warm_up(structure: ModelStructure) -> None:
    """Import the Monte-Carlo module and compile ``structure`` in a worker."""
    import scenarios.uncertainty.monte_carlo  # noqa: F401
    from fmu_model import numeric_model

    numeric_model(structure)


def timed_run(
    params: ModelParameters, n_workers: int, *, samples: int, seed: int, chunk: int, dt_s: float
) -> tuple[UncertaintyResult, dict[str, float]]:
    """Monte Carlo on a fresh ``LocalCluster`` of ``n_workers`` processes; timings [s]."""
    t0 = time.perf_counter()
    with local_client(n_workers) as client:
        t1 = time.perf_counter()
        client.run(_warm_up, params.structure)
        t2 = time.perf_counter()
        result = monte_carlo_metrics(
            params, n_samples=samples, seed=seed, dt_s=dt_s, client=client, chunk_size=chunk
        )
        t3 = time.perf_counter()
    return result, {"start_s": t1 - t0, "warm_up_s": t2 - t1, "run_s": t3 - t2}


def _display(metric: str, value: float) -> str:
    if metric.endswith("_rad"):
        return f"{math.degrees(value):.3f}°"
    return f"{value:.1f} m"


def containment_table(
    result: UncertaintyResult,
    references: Sequence[tuple[str, dict[tuple[str, str], float]]],
) -> tuple[str, dict[str, tuple[int, int]]]:
    """Markdown table of reference values vs 95 % intervals, and (inside, total) per source."""
    head = " | ".join(f"{name} | in" for name, _ in references)
    lines = [f"| manoeuvre | metric | 95 % interval | {head} |"]
    lines.append("|---|---|---|" + "---:|---|" * len(references))
    counts = {name: (0, 0) for name, _ in references}
    for entry in result.programs:
        for s in entry.summaries():
            interval = (
                "–"
                if not math.isfinite(s.q025)
                else f"{_display(s.metric, s.q025)} … {_display(s.metric, s.q975)}"
            )
            cells = []
            for name, values in references:
                ref = values.get((s.program, s.metric))
                if ref is None or not math.isfinite(s.q025):
                    cells.append("– | –")
                    continue
                inside = s.contains(ref)
                hit, total = counts[name]
                counts[name] = (hit + inside, total + 1)
                cells.append(f"{_display(s.metric, ref)} | {'yes' if inside else 'NO'}")
            label = s.metric[: -len("_rad")] + "_deg" if s.metric.endswith("_rad") else s.metric
            lines.append(f"| {s.program} | {label} | {interval} | {' | '.join(cells)} |")
    return "\n".join(lines) + "\n", counts


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; print timings, statistics and containment."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--params", type=Path, help="identified params.json (with covariance)")
    parser.add_argument("--save-params", type=Path, help="write the identified model here")
    parser.add_argument("--samples", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--chunk-size", type=int, default=50)
    parser.add_argument("--workers", default="1,2", help="worker counts to compare")
    parser.add_argument("--dt-s", type=float, default=0.5)
    args = parser.parse_args(argv)

    if args.params is not None and args.params.exists():
        params = load_params(args.params)
        print(f"model: {args.params}")
    else:
        t0 = time.perf_counter()
        params = identified_kvlcc2()
        print(
            f"model: {params.model} identified from KVLCC2 logs in {time.perf_counter() - t0:.1f} s"
        )
        if args.save_params is not None:
            save_params(args.save_params, params)
    workers = [int(w) for w in args.workers.split(",")]

    results: dict[int, UncertaintyResult] = {}
    timings: dict[int, dict[str, float]] = {}
    for n in workers:
        results[n], timings[n] = timed_run(
            params,
            n,
            samples=args.samples,
            seed=args.seed,
            chunk=args.chunk_size,
            dt_s=args.dt_s,
        )
    base = workers[0]
    print(
        f"\n{args.samples} samples × 4 manoeuvres, step {args.dt_s} s, "
        f"chunks of {args.chunk_size}\n"
    )
    print("| workers | cluster start [s] | warm-up [s] | Monte Carlo [s] | speed-up |")
    print("|---:|---:|---:|---:|---:|")
    for n in workers:
        t = timings[n]
        print(
            f"| {n} | {t['start_s']:.2f} | {t['warm_up_s']:.2f} | {t['run_s']:.2f} | "
            f"{timings[base]['run_s'] / t['run_s']:.2f} |"
        )
    last = results[workers[-1]]
    same = all(
        np.allclose(a.values, b.values, rtol=1e-12, equal_nan=True)
        for r in results.values()
        for a, b in zip(r.programs, last.programs, strict=True)
    )
    print(f"\nsame samples and metrics for every worker count: {same}\n")
    print(last.summary_table())
    for entry in last.programs:
        if entry.n_diverged or entry.n_incomplete:
            name, diverged, incomplete = entry.program.name, entry.n_diverged, entry.n_incomplete
            print(f"{name}: {diverged} diverged, {incomplete} incomplete")

    references = [
        ("§11 reference", REFERENCE_S11),
        (f"reference ship, {args.dt_s} s step", reference_at_step(args.dt_s)),
    ]
    table, counts = containment_table(last, references)
    print("\nDo the 95 % intervals contain the KVLCC2 values?\n")
    print(table)
    for name, (hit, total) in counts.items():
        print(f"{name}: {hit} of {total} inside")
    return 0


if __name__ == "__main__":
    sys.exit(main())
