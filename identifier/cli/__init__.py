"""Command line of the identifier: ``python -m identifier fit|convert|batch|crossval|split ...``.

One module per command, each with ``add_parser(sub)`` and ``run(args)``:
:mod:`identifier.cli.fit` (``fit LOG.csv ... -o params.json``),
:mod:`identifier.cli.convert` (NMEA / lat-lon recordings → trial logs),
:mod:`identifier.cli.batch` (many vessels on Dask),
:mod:`identifier.cli.crossval` (identify on some logs, predict the others) and
:mod:`identifier.cli.split` (a recording of several manoeuvres → one log each). The
library they call never prints; only these modules do.

Exit status: 0 success, 1 data error (bad log, bad settings for the data, diverging
identification), 2 usage error. Errors are one line on stderr, never a traceback.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from identifier.cli import batch, convert, crossval, fit, split

__all__ = ["build_parser", "main"]

_COMMANDS = {
    "fit": fit.run,
    "batch": batch.run,
    "convert": convert.run,
    "crossval": crossval.run,
    "split": split.run,
}


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``python -m identifier``."""
    parser = argparse.ArgumentParser(
        prog="python -m identifier",
        description="Identify ship manoeuvring models from trial logs.",
    )
    sub = parser.add_subparsers(dest="command", required=True)
    fit.add_parser(sub)
    batch.add_parser(sub)
    convert.add_parser(sub)
    crossval.add_parser(sub)
    split.add_parser(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI; return the exit status."""
    args = build_parser().parse_args(argv)
    return _COMMANDS[args.command](args)
