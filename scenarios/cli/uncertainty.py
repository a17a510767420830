"""``python -m scenarios uncertainty``: Monte-Carlo 95 % intervals from a params.json.

Also the cluster options (``--scheduler``, ``--workers``) that ``validate --params``
shares. The Monte Carlo itself is :mod:`scenarios.uncertainty`.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from typing import Any

from fmu_model import ParamsFormatError, argtypes, load_params
from fmu_model.atomic import write_atomic
from scenarios.cli.common import PROG, STEERING_RATE_HELP, fail, steering_rate_deg_s
from scenarios.errors import UncertaintyError
from scenarios.uncertainty.monte_carlo import monte_carlo_metrics

__all__ = ["add_cluster_arguments", "add_uncertainty_command", "run_uncertainty_command"]


def add_cluster_arguments(parser: Any) -> None:
    """Add ``--scheduler`` and ``--workers`` (where the Monte-Carlo samples run)."""
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask scheduler address, e.g. tcp://host:8786 (default: a local cluster)",
    )
    parser.add_argument(
        "--workers",
        type=argtypes.count(1),
        default=2,
        metavar="K",
        help="workers of the local cluster (default 2)",
    )


def add_uncertainty_command(subparsers: Any) -> None:
    """Add ``uncertainty`` to the subparsers of ``python -m scenarios``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        From ``parser.add_subparsers()``; the command's handler is
        :func:`run_uncertainty_command`.

    """
    p = subparsers.add_parser(
        "uncertainty",
        help="Monte-Carlo 95 %% intervals of the standard manoeuvres from params.json",
        description="Draw coefficient sets from the covariance in params.json, run the "
        "standard manoeuvres for each on a dask cluster and print the metrics' "
        "nominal value, mean and 95 % interval.",
    )
    p.add_argument("--params", required=True, metavar="FILE", help="params.json with covariance")
    p.add_argument(
        "--samples", type=argtypes.count(1), default=200, metavar="N", help="samples (default 200)"
    )
    p.add_argument("--seed", type=argtypes.count(0), default=0, metavar="S", help="draw seed")
    add_cluster_arguments(p)
    p.add_argument("--chunk-size", type=argtypes.count(1), metavar="M", help="samples per task")
    p.add_argument(
        "--speed-mps", type=argtypes.positive, metavar="U", help="approach speed (default nominal)"
    )
    p.add_argument(
        "--rpm", type=argtypes.non_negative, metavar="N", help="propeller speed (default nominal)"
    )
    p.add_argument(
        "--rudder-rate-deg-s",
        type=argtypes.positive,
        metavar="R",
        help=STEERING_RATE_HELP,
    )
    p.add_argument(
        "--dt-s", type=argtypes.positive, default=0.5, metavar="S", help="step [s] (default 0.5)"
    )
    p.add_argument("--json", metavar="OUT", help="write the statistics as JSON")
    p.add_argument(
        "--include-samples", action="store_true", help="also write every sample to the JSON"
    )
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def run_uncertainty_command(args: argparse.Namespace) -> int:
    """Run ``python -m scenarios uncertainty``; return the exit status.

    Prints the summary table on stdout; an error is one line on stderr and exit 1.
    """
    try:
        params = load_params(args.params)
        # its warning once the run has succeeded: an error stays the one line on stderr
        rate_deg_s, warning = steering_rate_deg_s(args.rudder_rate_deg_s, params.length_m)
        if not args.quiet:
            print(
                f"{PROG} uncertainty: {args.samples} samples of {params.vessel_name} "
                f"({params.model}) on {args.scheduler or f'{args.workers} local workers'}",
                file=sys.stderr,
            )
        result = monte_carlo_metrics(
            params,
            n_samples=args.samples,
            seed=args.seed,
            dt_s=args.dt_s,
            rudder_rate_radps=math.radians(rate_deg_s),
            speed_mps=args.speed_mps,
            n_rps=None if args.rpm is None else args.rpm / 60.0,
            scheduler=args.scheduler,
            n_workers=args.workers,
            chunk_size=args.chunk_size,
        )
        if args.json:
            document = result.as_dict(include_samples=args.include_samples)
            write_atomic(args.json, json.dumps(document, indent=2, allow_nan=False) + "\n")
    except (ParamsFormatError, UncertaintyError, OSError, TimeoutError) as exc:
        return fail("uncertainty", exc)
    if warning is not None:
        print(f"warning: {args.params}: {warning}", file=sys.stderr)
    print(result.summary_table(), end="")
    failed = [
        f"{p.program.name}: {p.n_diverged} diverged, {p.n_incomplete} incomplete"
        for p in result.programs
        if p.n_diverged or p.n_incomplete
    ]
    if failed:
        print(
            "failed samples (excluded from the statistics; incomplete: the run did not reach "
            "the event, or its turn fell back against the rudder): " + "; ".join(failed)
        )
    return 0
