"""``python -m identifier convert INPUT... -o DIR|FILE``: recordings → trial logs.

Runs :func:`identifier.ingest.convert_file` on every input and writes each log with
:func:`trials.logs.write_log` (names from :func:`identifier.ingest.output_paths`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

import scipy.constants

from fmu_model import argtypes
from fmu_model.params import text_problem
from identifier.cli.common import add_length_argument, error, os_error_text
from identifier.conventions import log_problem
from identifier.ingest import (
    DEFAULT_MAX_GAP_S,
    MAX_RATE_HZ,
    MIN_RATE_HZ,
    convert_file,
    output_paths,
)
from trials.errors import LogFormatError
from trials.logs import (
    MAX_ON_BOARD_M,
    MAX_RPM,
    MIN_SAMPLES,
    ON_BOARD_KEYS,
    ManeuverLog,
    at_midship,
    write_log,
)

__all__ = ["add_parser", "run"]


def _vessel(text: str) -> str:
    if not text.strip() or text != text.strip() or any(c in text for c in "\r\n\0"):
        raise argparse.ArgumentTypeError(f"expected a one-line name, got {text!r}")
    problem = text_problem(text)
    if problem is not None:  # an escape sequence, a tab, a lone surrogate from bad bytes
        raise argparse.ArgumentTypeError(f"{problem}, got {text!r}")
    return text


def _convention_problem(log: ManeuverLog) -> str | None:
    """Return the problem of a written log's heading or rudder convention, or None.

    What ``fit`` would refuse it for (``identifier.conventions.log_problem``, on the
    track reduced to midship as ``fit`` judges it: a bridge antenna's swings wide in a
    turn), the approach not judged (a piece of a recording need not be a manoeuvre);
    pieces shorter than ``fit`` reads are not judged.
    """
    if log.n_samples < MIN_SAMPLES:
        return None
    found = log_problem(at_midship(log), length_m=None)
    if found is None:
        return None
    message, sample = found
    where = "" if sample is None else f"sample {sample} (t = {log.time_s[sample]:.1f} s): "
    return f"{where}{message}; identifier fit refuses such a log"


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``convert`` command to the subparsers ``sub`` of ``python -m identifier``.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The subparsers of the identifier's parser.

    Returns
    -------
    argparse.ArgumentParser
        The ``convert`` parser.

    """
    convert = sub.add_parser(
        "convert",
        help="convert NMEA 0183 or lat/lon CSV recordings into trial logs",
        description=(
            "Convert NMEA 0183 (GGA/RMC/GNS/ZDA, HDT/THS/HDG, RSA, RPM) or latitude/longitude CSV "
            "recordings into trial logs: x North, y East [m] about the first fix, split at "
            "gaps. Heading, rudder and rpm are interpolated linearly at the fix times (or the "
            "--rate-hz grid); at the ends of a piece, a stream is extrapolated along its edge "
            "line to the one fix (grid time) just before its first or after its last sample "
            "when that is within one of its sample intervals, so that the first and last "
            "fixes are kept. Writes DIR/<input stem>_<k>.csv, or FILE when there is one log "
            "(FILE_<k>.csv for several). Exit 0 on success, 1 on unusable input (nothing "
            "written), 2 on a usage error."
        ),
    )
    convert.add_argument("inputs", nargs="+", metavar="INPUT", help="recordings to convert")
    convert.add_argument("-o", "--output", required=True, metavar="DIR|FILE.csv")
    convert.add_argument(
        "--format", choices=("auto", "nmea", "csv"), default="auto", help="default: from content"
    )
    convert.add_argument("--vessel", type=_vessel, help="written as '# vessel:'")
    add_length_argument(convert)
    on_board = argtypes.within(-MAX_ON_BOARD_M, MAX_ON_BOARD_M, "m")
    convert.add_argument(
        "--gnss-x-m",
        type=on_board,
        metavar="X",
        help="the GNSS antenna's position forward of midship [m] (the fixes are its), "
        "written as '# gnss_x_m:'; fit reduces the positions to midship",
    )
    convert.add_argument(
        "--gnss-y-m",
        type=on_board,
        metavar="Y",
        help="the GNSS antenna's position to starboard of the centre line [m], '# gnss_y_m:'",
    )
    convert.add_argument(
        "--speed-log-x-m",
        type=on_board,
        metavar="X",
        help="a two-axis speed log's position forward of midship [m] (NMEA VBW's transverse "
        "water speed is measured there), written as '# speed_log_x_m:'",
    )
    convert.add_argument(
        "--rudder-positive",
        choices=("starboard", "port"),
        default="starboard",
        help="side a positive rudder value in the input turns to (default starboard, as "
        "NMEA RSA); port flips the sign",
    )
    convert.add_argument(
        "--heading-unit",
        choices=("deg", "rad"),
        help="CSV 'heading' column unit (default deg; heading_deg/heading_rad: from the name)",
    )
    convert.add_argument(
        "--rate-hz",
        type=argtypes.within(MIN_RATE_HZ, MAX_RATE_HZ, "Hz"),
        help="resample at this rate [Hz] (default: fix times)",
    )
    convert.add_argument(
        "--max-gap-s",
        type=argtypes.positive,
        default=DEFAULT_MAX_GAP_S,
        help=f"split where a stream has no sample for longer [s] (default {DEFAULT_MAX_GAP_S:g})",
    )
    convert.add_argument(
        "--min-samples",
        type=argtypes.count(2),
        default=MIN_SAMPLES,
        help=f"drop shorter pieces (default {MIN_SAMPLES})",
    )
    convert.add_argument(
        "--rpm",
        type=argtypes.within(0.0, MAX_RPM, "rpm", low_open=True),
        metavar="N",
        help="propeller speed [rpm] of a recording that logs none (no RPM sentence or rpm "
        "column; a trial at a set engine order): written at every fix",
    )
    convert.add_argument(
        "--shaft", type=argtypes.count(0), help="NMEA RPM shaft number (default: the only one)"
    )
    convert.add_argument(
        "--allow-missing-checksum",
        action="store_true",
        help="use NMEA sentences without a '*hh' checksum (default: skip them)",
    )
    convert.add_argument("--quiet", action="store_true", help="no notes, no 'wrote' lines")
    return convert


def run(args: argparse.Namespace) -> int:
    """Run ``python -m identifier convert`` for parsed ``args``; return the exit status.

    Every input is converted before anything is written, so that an unusable input
    (exit 1, one line on stderr) leaves no partial output. Skipped lines and checksum
    failures are reported as one ``warning:`` line per input on stderr, notes as
    ``note:`` lines (not with ``--quiet``), written files on stdout.
    """
    inputs = [Path(name) for name in args.inputs]
    output = Path(args.output)
    to_file = output.suffix.lower() == ".csv" and not output.is_dir()
    stems = [path.stem for path in inputs]
    if len(inputs) > 1 and to_file:
        return error(f"-o {output}: expected a directory for several inputs", status=2)
    if len(set(stems)) < len(stems):
        twice = sorted({stem for stem in stems if stems.count(stem) > 1})
        return error(f"inputs share the name {twice[0]!r}: convert them separately", status=2)
    try:
        results = []
        for path in inputs:
            result = convert_file(
                path,
                input_format=args.format,
                rudder_positive=args.rudder_positive,
                heading_unit=args.heading_unit,
                rate_hz=args.rate_hz,
                max_gap_s=args.max_gap_s,
                min_samples=args.min_samples,
                vessel=args.vessel,
                length_m=args.length_m,
                on_board={
                    key: value for key in ON_BOARD_KEYS if (value := getattr(args, key)) is not None
                },
                shaft=args.shaft,
                require_checksum=not args.allow_missing_checksum,
                constant_n_rps=None if args.rpm is None else args.rpm / scipy.constants.minute,
            )
            if not result.logs:
                raise LogFormatError(
                    f"no log written: every piece has fewer than {args.min_samples} samples "
                    "(see the notes; lower --min-samples or raise --max-gap-s)",
                    path=path,
                    expected=f"a piece of at least {args.min_samples} samples",
                )
            results.append(result)
    except LogFormatError as exc:
        return error(str(exc))
    for path, result in zip(inputs, results, strict=True):
        if result.skipped_lines or result.checksum_failures:
            print(
                f"warning: {path}: skipped {result.skipped_lines} unparsable lines and "
                f"{result.checksum_failures} checksum failures",
                file=sys.stderr,
            )
        if not args.quiet:
            for note in result.notes:
                print(f"note: {path}: {note}", file=sys.stderr)
    try:
        for path, result in zip(inputs, results, strict=True):
            for target, log in zip(
                output_paths(output, path.stem, len(result.logs)), result.logs, strict=True
            ):
                write_log(target, log)
                if not args.quiet:
                    print(f"wrote {target}")
                if (problem := _convention_problem(log)) is not None:
                    print(f"warning: {target}: {problem}", file=sys.stderr)
    except OSError as exc:
        return error(os_error_text(exc))
    return 0
