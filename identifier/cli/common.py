"""What the identifier's commands share: how an error becomes one line on stderr."""

from __future__ import annotations

import argparse
import sys

from fmu_model import ParamsFormatError, argtypes
from fmu_model.interface import MAX_LENGTH_M, MIN_LENGTH_M
from trials.errors import IdentificationError, LogFormatError

__all__ = ["DATA_ERRORS", "add_length_argument", "add_windage_argument", "error", "os_error_text"]

DATA_ERRORS = (LogFormatError, IdentificationError, ParamsFormatError)
"""Exceptions that mean bad input data: ``error: <message>``, exit status 1."""


def error(message: str, status: int = 1) -> int:
    """Print ``error: <message>`` on stderr and return the exit status.

    Parameters
    ----------
    message : str
        One line.
    status : int
        Exit status to return: 1 for a data error (default), 2 for a usage error.

    Returns
    -------
    int
        ``status``.

    """
    print(f"error: {message}", file=sys.stderr)
    return status


def os_error_text(exc: OSError) -> str:
    """Return ``<file>: <reason>`` for a file that cannot be read or written."""
    return f"{exc.filename or ''}: {exc.strerror or exc}"


def add_windage_argument(parser: argparse.ArgumentParser, then: str) -> None:
    """Add ``--windage FILE.json`` (read by ``identifier.wind.read_windage``).

    ``then``: what else the command does with the windage, the end of its help.
    """
    parser.add_argument(
        "--windage",
        metavar="FILE.json",
        help="the vessel's windage (areas, centroid, effective inertias; README): the load of "
        f"the logs' measured wind is taken out of the coefficients, {then}",
    )


def add_length_argument(parser: argparse.ArgumentParser, then: str = "") -> None:
    """Add ``--length-m L``: the ship's length [m], within the FMU's bounds.

    ``then``: the end of its help, e.g. its default.
    """
    parser.add_argument(
        "--length-m",
        type=argtypes.within(MIN_LENGTH_M, MAX_LENGTH_M, "m"),
        help=f"ship length [m], {MIN_LENGTH_M:g} to {MAX_LENGTH_M:g}{then}",
    )
