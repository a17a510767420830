"""``python -m identifier split LOG.csv ... -o DIR``: one log per manoeuvre.

Runs :func:`identifier.split.split_log` on every input and writes each manoeuvre with
:func:`trials.logs.write_log` as ``DIR/<input stem>_<k>_<manoeuvre>.csv``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from identifier.cli.common import DATA_ERRORS, add_length_argument, error, os_error_text
from identifier.preparation import vessel_length
from identifier.split import MAX_APPROACH_L, MIN_APPROACH_L, manoeuvre_name, piece_logs, split_log
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, read_log, write_log

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``split`` command to the subparsers ``sub`` of ``python -m identifier``."""
    split = sub.add_parser(
        "split",
        help="split trial logs of several manoeuvres into one log per manoeuvre",
        description=(
            "Split a recording of several manoeuvres (a trial day) into one trial log per "
            "manoeuvre, as crossval and the scenarios' --like read them. A manoeuvre begins "
            f"with a rudder command of 5 deg or more after {MIN_APPROACH_L:g} ship length of "
            f"straight running; its log keeps up to {MAX_APPROACH_L:g} ship lengths of that "
            "approach and of the straight run after it, its execute as '# execute_time_s:' "
            "and the recording's times. Writes DIR/<input stem>_<k>_<manoeuvre>.csv. Exit 0 "
            "on success, 1 on unusable input (nothing written), 2 on a usage error."
        ),
    )
    split.add_argument("inputs", nargs="+", metavar="LOG.csv", help="trial logs to split")
    split.add_argument("-o", "--output", required=True, metavar="DIR")
    add_length_argument(split, " (default: from the log), written as '# length_m:'")
    split.add_argument("--quiet", action="store_true", help="no notes, no 'wrote' lines")
    return split


def _named(stem: str, k: int, log: ManeuverLog) -> str:
    name = manoeuvre_name(log)
    return f"{stem}_{k}.csv" if name is None else f"{stem}_{k}_{name}.csv"


def run(args: argparse.Namespace) -> int:
    """Run ``python -m identifier split`` for parsed ``args``; return the exit status.

    Every input is split before anything is written, so that an unusable input (exit 1,
    one line on stderr) leaves no partial output.
    """
    inputs = [Path(name) for name in args.inputs]
    output = Path(args.output)
    stems = [path.stem for path in inputs]
    if output.suffix.lower() == ".csv" and not output.is_dir():
        return error(f"-o {output}: expected a directory", status=2)
    if len(set(stems)) < len(stems):
        twice = sorted({stem for stem in stems if stems.count(stem) > 1})
        return error(f"inputs share the name {twice[0]!r}: split them separately", status=2)
    written: list[tuple[Path, ManeuverLog]] = []
    notes: list[str] = []
    try:
        for path in inputs:
            log = read_log(path)
            try:
                length_m = vessel_length([log], args.length_m)
            except IdentificationError as exc:  # the one message of fit's, naming the file
                raise IdentificationError(exc.message, log=path) from None
            found = split_log(log, length_m)
            notes += [f"{path}: {note}" for note in found.notes]
            for k, piece in enumerate(piece_logs(log, found, length_m), start=1):
                written.append((output / _named(path.stem, k, piece), piece))
    except DATA_ERRORS as exc:
        return error(str(exc))
    except OSError as exc:
        return error(os_error_text(exc))
    if not args.quiet:
        for note in notes:
            print(f"note: {note}", file=sys.stderr)
    try:
        output.mkdir(parents=True, exist_ok=True)
        for target, piece in written:
            write_log(target, piece)
            if not args.quiet:
                execute_s = float(piece.metadata["execute_time_s"])
                print(
                    f"wrote {target} (t = {piece.time_s[0]:.2f} to {piece.time_s[-1]:.2f} s, "
                    f"execute at {execute_s:.2f} s)"
                )
    except OSError as exc:
        return error(os_error_text(exc))
    return 0
