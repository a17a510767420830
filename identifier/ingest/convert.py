"""The public conversion functions: one recording file in, trial logs out.

:func:`convert_file` (format detected by :func:`detect_format`), :func:`convert_nmea`
and :func:`convert_latlon_csv` read a file with its reader
(:mod:`identifier.ingest.nmea`, :mod:`identifier.ingest.latlon_csv`) and assemble the
logs (:mod:`identifier.ingest.assemble`); :func:`output_paths` names the files the
logs are written to.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Final, Literal

from identifier.ingest.assemble import assemble
from identifier.ingest.latlon_csv import LAT_COLUMNS, LON_COLUMNS, read_latlon_csv
from identifier.ingest.nmea import read_nmea
from identifier.ingest.recording import (
    DEFAULT_MAX_GAP_S,
    ConversionResult,
    HeadingUnit,
    InputFormat,
    Options,
    RudderPositive,
)
from trials.errors import LogFormatError
from trials.logs import MIN_SAMPLES
from trials.text_input import read_bytes

__all__ = [
    "convert_file",
    "convert_latlon_csv",
    "convert_nmea",
    "detect_format",
    "output_paths",
]

_SNIFF_LINES: Final = 50


def convert_file(
    path: str | os.PathLike[str],
    *,
    input_format: InputFormat = "auto",
    rudder_positive: RudderPositive = "starboard",
    heading_unit: HeadingUnit | None = None,
    rate_hz: float | None = None,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    min_samples: int = MIN_SAMPLES,
    vessel: str | None = None,
    length_m: float | None = None,
    shaft: int | None = None,
    require_checksum: bool = True,
    on_board: Mapping[str, float] | None = None,
    constant_n_rps: float | None = None,
) -> ConversionResult:
    """Convert an NMEA 0183 or latitude/longitude CSV file (detected from its content).

    Parameters
    ----------
    path : str or os.PathLike
        The recording.
    input_format : {"auto", "nmea", "csv"}
        ``"auto"`` (default) uses :func:`detect_format`.
    rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m
        As for :func:`convert_nmea`.
    heading_unit : {"deg", "rad"} or None
        CSV only, as for :func:`convert_latlon_csv`; noted and ignored for NMEA,
        whose headings are degrees.
    shaft, require_checksum
        NMEA only, as for :func:`convert_nmea`.
    on_board, constant_n_rps
        As for :func:`convert_nmea`.

    Returns
    -------
    ConversionResult
        The logs and the conversion report.

    Raises
    ------
    LogFormatError
        If the file cannot be read, is neither format, or is unusable (see the
        converters).
    ValueError
        If an argument is out of range.

    """
    name = os.fspath(path)
    raw = read_bytes(name, "recording")
    kind = detect_format(raw, name) if input_format == "auto" else input_format
    options = Options.make(
        rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m, on_board,
        constant_n_rps,
    )  # fmt: skip
    if kind == "nmea":
        recording = read_nmea(name, raw, options.rudder_sign, shaft, require_checksum)
        if heading_unit is not None:
            recording.notes.append(
                f"heading_unit={heading_unit!r} ignored: NMEA headings are in degrees"
            )
    elif kind == "csv":
        recording = read_latlon_csv(name, raw, options.rudder_sign, heading_unit)
    else:
        raise ValueError(f"input_format must be 'auto', 'nmea' or 'csv', got {input_format!r}")
    return assemble(recording, options)


def convert_nmea(
    path: str | os.PathLike[str],
    *,
    rudder_positive: RudderPositive = "starboard",
    rate_hz: float | None = None,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    min_samples: int = MIN_SAMPLES,
    vessel: str | None = None,
    length_m: float | None = None,
    shaft: int | None = None,
    require_checksum: bool = True,
    on_board: Mapping[str, float] | None = None,
    constant_n_rps: float | None = None,
) -> ConversionResult:
    """Convert an NMEA 0183 recording into trial logs (rules: :mod:`identifier.ingest.nmea`).

    Parameters
    ----------
    path : str or os.PathLike
        The NMEA 0183 text file.
    rudder_positive : {"starboard", "port"}
        Which way a positive RSA angle turns the ship. Default ``"starboard"``, the
        NMEA convention and this project's; ``"port"`` flips the sign.
    rate_hz : float or None
        Resample onto a grid of this rate [Hz]; None (default): onto the times of
        the position fixes.
    max_gap_s : float
        Longest time without a sample of any stream that is still interpolated
        across [s]; longer gaps split the recording. Default 5 s.
    min_samples : int
        Pieces with fewer samples are dropped (noted). Default
        :data:`~trials.logs.MIN_SAMPLES`, the fewest a trial log may have.
    vessel : str or None
        Written as ``# vessel:`` when given (one line).
    length_m : float or None
        Ship length [m], written as ``# length_m:`` when given.
    shaft : int or None
        RPM shaft number to use; None: the only shaft present (an error when RPM
        sentences name several shafts).
    require_checksum : bool
        Skip sentences without a ``*hh`` checksum (default True).
    on_board : mapping of str to float, optional
        Positions on board [m] by their metadata key (``trials.logs.ON_BOARD_KEYS``: the
        GNSS antenna's, ``gnss_x_m`` and ``gnss_y_m``, where the fixes are; a two-axis
        speed log's, ``speed_log_x_m``, where VBW's transverse water speed is), written
        as ``# key:`` lines.
    constant_n_rps : float or None
        The propeller speed [rev/s] of a recording that logs none (no RPM sentence; a
        trial at a set engine order), written at every fix and noted; None (default):
        the recording's own. Given for a recording that logs it: an error.

    Returns
    -------
    ConversionResult
        Logs (metadata ``vessel``, ``length_m``, ``on_board``'s, ``source``, ``origin_lat_deg``,
        ``origin_lon_deg``, ``time_origin_utc``, ``projection``), the counts of
        skipped lines and checksum failures, the gaps and notes.

    Raises
    ------
    LogFormatError
        If the file cannot be read, has no NMEA sentence with a valid checksum, no
        valid position fix, no valid heading, rudder or shaft RPM sentence (unless
        ``constant_n_rps`` is given, which is an error beside one), or RPM for several
        shafts and ``shaft`` is None.
    ValueError
        If an argument is out of range.

    """
    name = os.fspath(path)
    options = Options.make(
        rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m, on_board,
        constant_n_rps,
    )  # fmt: skip
    recording = read_nmea(
        name, read_bytes(name, "recording"), options.rudder_sign, shaft, require_checksum
    )
    return assemble(recording, options)


def convert_latlon_csv(
    path: str | os.PathLike[str],
    *,
    rudder_positive: RudderPositive = "starboard",
    heading_unit: HeadingUnit | None = None,
    rate_hz: float | None = None,
    max_gap_s: float = DEFAULT_MAX_GAP_S,
    min_samples: int = MIN_SAMPLES,
    vessel: str | None = None,
    length_m: float | None = None,
    on_board: Mapping[str, float] | None = None,
    constant_n_rps: float | None = None,
) -> ConversionResult:
    """Convert a CSV file with latitude/longitude columns into trial logs.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file (columns: :mod:`identifier.ingest.latlon_csv`).
    rudder_positive : {"starboard", "port"}
        Which way a positive rudder value in the file turns the ship (default
        ``"starboard"``, this project's convention; ``"port"`` flips the sign).
    heading_unit : {"deg", "rad"} or None
        Unit of a ``heading`` column. None (default): degrees, and the unit of
        ``heading_deg`` / ``heading_rad`` from the name. A unit that contradicts the
        column name is an error.
    rate_hz, max_gap_s, min_samples, vessel, length_m, on_board, constant_n_rps
        As for :func:`convert_nmea` (a file without an rpm column needs
        ``constant_n_rps``).

    Returns
    -------
    ConversionResult
        As for :func:`convert_nmea`; ``skipped_lines`` and ``checksum_failures``
        are 0.

    Raises
    ------
    LogFormatError
        If the file cannot be read, is not UTF-8, lacks a column, has a malformed
        cell, a latitude or longitude out of range, a time that does not increase,
        or no valid position fix or no sample of a stream.
    ValueError
        If an argument is out of range.

    """
    name = os.fspath(path)
    options = Options.make(
        rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m, on_board,
        constant_n_rps,
    )  # fmt: skip
    recording = read_latlon_csv(
        name, read_bytes(name, "recording"), options.rudder_sign, heading_unit
    )
    return assemble(recording, options)


def detect_format(raw: bytes, path: str | None = None) -> Literal["nmea", "csv"]:
    """Tell an NMEA 0183 recording from a latitude/longitude CSV by the content.

    NMEA if one of the first 50 non-blank lines starts with ``$`` or ``!``; CSV if
    the first line that is neither blank nor a ``#`` comment names a latitude and a
    longitude column.

    Parameters
    ----------
    raw : bytes
        The file content.
    path : str or None
        File name for the error message.

    Returns
    -------
    {"nmea", "csv"}
        The format.

    Raises
    ------
    LogFormatError
        If it is neither (the message says what was expected, and that a file with
        ``x_m``/``y_m`` columns is already a trial log).

    """
    lines = [line.strip() for line in raw.split(b"\n")]
    lines = [line for line in lines if line][:_SNIFF_LINES]
    if any(line.startswith((b"$", b"!")) for line in lines):
        return "nmea"
    header = next((line for line in lines if not line.startswith(b"#")), b"")
    header = header.removeprefix(b"\xef\xbb\xbf")
    names = {name.strip().strip(b'"').decode("utf-8", "replace") for name in header.split(b",")}
    if names & set(LAT_COLUMNS) and names & set(LON_COLUMNS):
        return "csv"
    hint = ""
    if {"x_m", "y_m"} <= names:
        hint = " (it has x_m and y_m columns: it is already a trial log)"
    raise LogFormatError(
        "expected an NMEA 0183 recording ('$' sentences) or a CSV file with latitude and "
        f"longitude columns ({'/'.join(LAT_COLUMNS)}, {'/'.join(LON_COLUMNS)}), got "
        f"neither{hint}",
        path=path,
        expected="NMEA 0183 or a latitude/longitude CSV",
    )


def output_paths(output: str | os.PathLike[str], stem: str, count: int) -> list[Path]:
    """Names of the CSV files for ``count`` logs converted from an input named ``stem``.

    Parameters
    ----------
    output : str or os.PathLike
        A file ending in ``.csv`` (and not an existing directory), or a directory.
    stem : str
        Name of the input without its suffix.
    count : int
        Number of logs.

    Returns
    -------
    list of pathlib.Path
        For a file ``F.csv``: ``[F.csv]`` for one log, ``F_1.csv``, ``F_2.csv``, ...
        beside it for several. For a directory ``D``: ``D/<stem>_1.csv``, ...
        (numbered even for one log, so that names do not depend on gaps).

    """
    target = Path(output)
    if target.suffix.lower() == ".csv" and not target.is_dir():
        if count == 1:
            return [target]
        return [target.with_name(f"{target.stem}_{k}{target.suffix}") for k in range(1, count + 1)]
    return [target / f"{stem}_{k}.csv" for k in range(1, count + 1)]
