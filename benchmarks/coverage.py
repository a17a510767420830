"""Coverage of validate's 95 % intervals on the demo, at several noise seeds (issue 13, item 4).

    python benchmarks/coverage.py [--seeds 1,2,3,4,5] [--samples 100] [--out benchmarks/coverage.md]

For each seed, the demo's pipeline: KVLCC2 reference logs (35° starboard turn, 10/10 and
20/20 zig-zags, 1 Hz, 1 m / 0.1° noise, ``scenarios.synthesize``), the default fit, a
native FMU, ``validate`` against the reference with ``--params``. The intervals are made
twice from the same Monte-Carlo seed: from the identification noise only (the params
without their alternative estimates) and with the model-form term (as ``validate``
gives them). Per seed: the reference values inside, of those with an interval; the same
for the manoeuvres within the envelope of the logs (``fmu_model.envelope``) and beyond it;
the mean width ratio with / without the model-form term; and which manoeuvres went
beyond the logs. The table goes into its block of ``--out`` (``report.py``).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from report import write_block

from fmu_model.export_native import build_native_fmu
from identifier.identify import FitSettings, identify
from scenarios.demo import DemoConfig
from scenarios.records import ComparisonRow, Validation, interval_counts
from scenarios.report import within_envelope
from scenarios.synthesize import synthesize_logs
from scenarios.validation import validate, with_uncertainty
from trials.logs import read_log


def widths(validation: Validation) -> dict[tuple[str, str], float]:
    """Width of each finite interval, by (manoeuvre, quantity) [the row's unit]."""
    return {
        (r.maneuver, r.quantity): r.interval.hi - r.interval.lo
        for r in validation.rows
        if r.interval is not None and r.interval.is_finite
    }


def _count(rows: Sequence[ComparisonRow]) -> str:
    inside, judged = interval_counts(rows)
    return f"{inside} of {judged}"


def seed_row(seed: int, n_samples: int, directory: Path) -> list[str]:
    """Run the demo's pipeline at ``seed``; the table cells of its intervals."""
    config = DemoConfig(seed=seed)
    logs = synthesize_logs(directory / "logs", config.maneuvers, seed=seed)
    start = time.perf_counter()
    params = identify([read_log(p) for p in logs], FitSettings()).params
    seconds = time.perf_counter() - start
    fmu = build_native_fmu(params, directory / "ship.fmu")
    validation = validate(fmu, params=params, dt_s=config.validation_dt_s)
    identification_only = replace(
        params, identification={k: v for k, v in params.identification.items() if k != "estimates"}
    )
    bands = {
        name: with_uncertainty(
            validation, p, n_samples=n_samples, dt_s=config.uncertainty_dt_s, n_workers=2
        )
        for name, p in (("id", identification_only), ("full", params))
    }
    full = bands["full"]
    narrow, wide = widths(bands["id"]), widths(full)
    ratio = sum(wide[k] / narrow[k] for k in narrow) / len(narrow)
    extrapolated = [name for name, reasons in (full.extrapolation or {}).items() if reasons]
    beyond = [r for r in full.rows if r.maneuver in extrapolated]
    return [
        str(seed),
        params.model.split("[")[0],
        f"{seconds:.0f}",
        _count(bands["id"].rows),
        _count(full.rows),
        _count(within_envelope(full)),
        _count(beyond),
        f"{ratio:.2f}",
        ", ".join(extrapolated) or "—",
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Run every seed; print and write the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--seeds", default="1,2,3,4,5", help="noise seeds, comma-separated")
    parser.add_argument("--samples", type=int, default=100, help="Monte-Carlo samples")
    parser.add_argument("--out", default=str(Path(__file__).with_name("coverage.md")))
    args = parser.parse_args(argv)
    lines = [
        "| seed | fitted | fit s | in 95 %, id only | with model form | within the logs' "
        "envelope | beyond it | width × | beyond the logs |",
        "|" + "---|" * 9,
    ]
    for seed in (int(s) for s in args.seeds.split(",")):
        with tempfile.TemporaryDirectory() as directory:
            lines.append("| " + " | ".join(seed_row(seed, args.samples, Path(directory))) + " |")
        print(lines[-1], flush=True)
    write_block(args.out, "coverage.py", lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
