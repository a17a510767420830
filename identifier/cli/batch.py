"""``python -m identifier batch MANIFEST.toml|DIR --out OUT``: identify many vessels.

Runs :func:`identifier.batch.run_batch`; prints one line per vessel as it finishes and
a bar of the vessels done (stderr), the failures on stderr, and exits 1 when any vessel
failed.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tqdm import tqdm

from fmu_model import DEFAULT_MODEL, argtypes, model_names
from identifier.batch import ManifestError, VesselResult, format_failures, run_batch
from identifier.batch.task import describe_error
from identifier.cli.common import error
from identifier.current import CURRENT_MODES
from identifier.identify import METHODS
from trials.conditions import MODEL_SCALE_MAX_LENGTH_M
from trials.errors import one_line

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``batch`` command to the subparsers ``sub`` of ``python -m identifier``."""
    batch = sub.add_parser(
        "batch",
        help="identify many vessels (manifest or directory), one FMU each, resumable",
        description="Identify every vessel of MANIFEST.toml or DIR on a Dask cluster.",
    )
    batch.add_argument("source", metavar="MANIFEST.toml|DIR", help="vessels and their logs")
    batch.add_argument("--out", required=True, metavar="DIR", help="output directory")
    batch.add_argument(
        "--scheduler", metavar="ADDRESS", help="existing dask scheduler (default: LocalCluster)"
    )
    batch.add_argument(
        "--workers", type=argtypes.count(1), default=2, metavar="N", help="LocalCluster workers"
    )
    batch.add_argument(
        "--model", choices=model_names(), help=f"default model (default: {DEFAULT_MODEL})"
    )
    batch.add_argument(
        "--method",
        choices=METHODS,
        default=METHODS[0],
        help="identification procedure (default: output-error; ekf: the seed paper)",
    )
    batch.add_argument(
        "--current",
        choices=CURRENT_MODES,
        help="uniform current estimated with each vessel's coefficients: constant (a ship's "
        "default; per-log where the logs show different currents), drifting, per-log (one "
        "per log), none (still water) or auto (constant where its fit predicts the "
        "vessel's logs twice as close as still water's, else none; the default below L = "
        f"{MODEL_SCALE_MAX_LENGTH_M:g} m, a model's size)",
    )
    batch.add_argument("--no-fmu", action="store_true", help="write params.json only")
    batch.add_argument("--quiet", action="store_true", help="no per-vessel lines on stdout")
    return batch


def run(args: argparse.Namespace) -> int:
    """Run ``python -m identifier batch`` for parsed ``args``; return the exit status."""
    bars: list[tqdm[Any]] = []  # opened with the first vessel: an error before prints alone

    def show(result: VesselResult, done: int, total: int) -> None:
        if not bars:
            bars.append(tqdm(total=total, unit="vessel", disable=args.quiet, file=sys.stderr))
        bar = bars[0]
        if result.ok and not args.quiet:
            bar.write(
                f"{result.name}: {result.status} ({result.n_logs} logs, "
                f"{result.n_samples} samples, {result.seconds:.1f} s)",
                file=sys.stdout,
            )
        bar.update(done - bar.n)

    try:
        summary = run_batch(
            args.source,
            args.out,
            scheduler=args.scheduler,
            n_workers=args.workers,
            model=args.model,
            method=args.method,
            current=args.current,
            build_fmu=not args.no_fmu,
            progress=show,
        )
    except (ManifestError, ValueError) as exc:
        return error(one_line(str(exc)))
    except OSError as exc:
        return error(describe_error(exc))
    finally:
        for bar in bars:
            bar.close()
    for line in format_failures(summary):
        print(f"error: {line}", file=sys.stderr)
    if not args.quiet:
        print(f"wrote {summary.out_dir / 'summary.md'}")
    return 0 if summary.ok else 1
