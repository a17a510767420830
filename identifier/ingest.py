"""Convert raw trial recordings (NMEA 0183, latitude/longitude CSV) into trial logs.

``python -m identifier convert INPUT... -o DIR|FILE`` (:func:`add_parser`,
:func:`main`, wired into :mod:`identifier.cli`) runs :func:`convert_file` on every
input and writes each resulting :class:`~identifier.logs.ManeuverLog` with
:func:`~identifier.logs.write_log`: ``DIR/<input stem>_<k>.csv``, or ``FILE`` when
there is a single log (see :func:`output_paths`).

What happens to a recording
---------------------------
1. Every sensor stream is read with its own sample times: position fixes (latitude,
   longitude), heading, rudder angle and propeller speed.
2. The fixes are projected into a local tangent plane whose origin is the first
   valid fix (:class:`TangentPlane`): x North [m], y East [m]. Headings are turned
   from true North to the plane's x axis (meridian convergence, below 0.1 deg within
   5 km of the origin at 60 deg latitude).
3. Time 0 is the time of the first valid fix; ``time_origin_utc`` in the metadata
   says when that was (when the input gives a date).
4. Each stream is cut where it has no sample for longer than ``max_gap_s``; the
   recording is split into pieces where all four streams are present without such
   a gap. These gaps are reported in :attr:`ConversionResult.gaps` and the notes.
5. Each piece is resampled onto a common time base, by default the times of the
   position fixes in it, or a grid of ``rate_hz`` aligned to multiples of
   ``1 / rate_hz`` after the first fix. Heading, rudder and propeller speed are
   interpolated linearly (heading on the unwrapped angle), positions too on a
   ``rate_hz`` grid. A piece spans the time all streams have samples, widened by at
   most one time-base sample at each end: a stream whose first sample comes after a
   fix (grid time), by no more than one of the stream's own sample intervals and half
   of ``max_gap_s``, is extrapolated back to it along the line through its first two
   samples; the same after its last sample (noted, with the largest extrapolation of
   each stream). So the first fix of an NMEA recording is kept although its heading,
   rudder and RPM sentences follow it and get times just after it, and the last fix
   although the sentences after it have no later time stamp and are dropped.
   Positions are never extrapolated.
6. Pieces with fewer than ``min_samples`` samples are dropped with a note; the rest
   become logs, numbered in time order.

NMEA 0183 input (:func:`convert_nmea`)
--------------------------------------
One sentence per line, ``$<talker><type>,<fields>*<checksum>`` (ASCII; LF or CRLF).
Sentences used:

===== ============================================================ ===============
type  fields used                                                  valid when
===== ============================================================ ===============
GGA   UTC time of day, latitude, longitude, fix quality            quality > 0
RMC   UTC time of day, status, latitude, longitude, date (ddmmyy)  status ``A`` [#]_
ZDA   UTC time of day, day, month, year (time and date only)       always
HDT   true heading [deg], ``T``                                    always
THS   true heading [deg], mode indicator                           mode ``A``
RSA   starboard (or single) rudder sensor [deg], its status        status ``A``
RPM   source ``S`` (shaft), shaft number, speed [rpm], status      status ``A``
===== ============================================================ ===============

.. [#] and a mode indicator (NMEA 2.3) other than ``N``.

- **Checksums.** A sentence whose checksum does not match is skipped and counted in
  :attr:`ConversionResult.checksum_failures`. A sentence without a checksum is
  skipped (a line cut short would otherwise give a wrong number) unless
  ``require_checksum=False``. Lines that are not NMEA sentences, sentences with a
  malformed field (``4807.0x8``, a minute of 61, a heading of 400 deg, ...) and
  non-ASCII lines are skipped and counted in :attr:`ConversionResult.skipped_lines`.
  Neither is fatal. Other sentence types (GSV, VTG, AIS ``!`` lines, proprietary
  ``$P...`` sentences) are ignored and only counted in the notes.
- **Time.** GGA, RMC and ZDA carry the UTC time of day; RMC and ZDA also the date.
  A GGA time takes its day from the time-stamped sentence before it (at the start
  of the file: after it), the day that puts it within 12 hours of that one; so a
  time of day more than 12 hours before the previous one means midnight has passed
  (rollover), and a GGA-only stretch across midnight stays continuous. Without any
  date the time origin is unknown and ``time_origin_utc`` is left out. Heading,
  rudder and RPM sentences have no time of their own: each gets a time interpolated
  linearly over the line number between the two time-stamped sentences around it
  (a serial multiplexer writes at a steady rate). Sentences before the first or
  after the last time-stamped sentence are dropped (noted). Time stamps must
  increase: the longest increasing sequence of them is used, so that a repeated
  time (the GGA and RMC of one fix) or a few wrong ones (a clock step, a bad time
  with a valid checksum) cost only those sentences (noted), not the rest of the
  file.
- **Several sources.** When fixes come from several talkers (e.g. ``GP`` and
  ``GN``), or heading, rudder or RPM from several talkers or sentence types, the one
  with the most valid samples is used and the others are noted. RPM: shaft
  sentences only (source ``S``; engine sentences are noted and ignored), and the
  single shaft present, or the one chosen with ``shaft``; NMEA numbers a single or
  centre-line shaft 0, odd numbers to starboard, even to port.
- **Rudder sign.** RSA is "negative = bow turns to port", so positive turns to
  starboard as in this project: the default ``rudder_positive="starboard"`` keeps the
  sign, ``"port"`` flips it (a sensor installed the other way round).

Latitude/longitude CSV input (:func:`convert_latlon_csv`)
--------------------------------------------------------
UTF-8 (byte-order mark allowed), ``,``-separated, one header line; ``#`` lines and
blank lines are ignored anywhere. Accepted column names (exactly one per
quantity, case-sensitive; other columns are ignored):

=========== ========================================= ================================
quantity    column                                    unit / form
=========== ========================================= ================================
time        ``time_s``                                seconds, any origin
            ``time``                                  ISO 8601, e.g.
                                                      ``2024-05-17T23:58:30.25Z``;
                                                      without an offset: UTC
latitude    ``lat_deg``, ``lat``, ``latitude``        degrees, positive North
longitude   ``lon_deg``, ``lon``, ``longitude``       degrees, positive East
heading     ``heading_deg``, ``heading_rad``,         true heading, clockwise from
            ``heading``                               North; ``heading``: unit from
                                                      ``heading_unit`` (default deg)
rudder      ``rudder_deg``, ``rudder_rad``            sign per ``rudder_positive``
propeller   ``rpm``                                   revolutions per minute
=========== ========================================= ================================

Every row needs a time, strictly increasing; any other cell may be empty (that
sensor has no sample at that time), so streams at different rates can share one
file. A heading may be wrapped or continuous, within ±36000 deg (100 turns); a
rudder angle is within ±90 deg. Latitude and longitude are given together or not at
all. Unlike NMEA, a malformed CSV cell is an error (a CSV file comes from a program,
not a noisy line): :class:`~identifier.errors.LogFormatError` with file, line and
column.

Local tangent plane
-------------------
See :class:`TangentPlane`: an azimuthal equidistant projection (``+proj=aeqd``) on
the WGS84 ellipsoid centred on the first fix; exact geodesic distance and azimuth
from the origin, other distances to 5e-8 within 5 km.

Metadata of the logs
--------------------
``vessel`` and ``length_m`` (when given), ``source`` (input file name and format,
which piece and its time span, the origin, the conventions applied, the counts of
skipped lines and checksum failures), ``origin_lat_deg``, ``origin_lon_deg``
(WGS84, full precision), ``time_origin_utc`` (ISO 8601 UTC time of time 0, when
known) and ``projection`` (the PROJ string of the plane, to map x/y back to
latitude/longitude).
"""

from __future__ import annotations

import argparse
import bisect
import csv
import datetime as dt
import math
import os
import re
import sys
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Final, Literal

import numpy as np
import numpy.typing as npt
import pynmea2
import pyproj

from fmu_model import argtypes
from identifier.errors import LogFormatError
from identifier.logs import MIN_SAMPLES, ManeuverLog, write_log

__all__ = [
    "DEFAULT_MAX_GAP_S",
    "ConversionResult",
    "TangentPlane",
    "add_parser",
    "convert_file",
    "convert_latlon_csv",
    "convert_nmea",
    "detect_format",
    "main",
    "output_paths",
]

RudderPositive = Literal["starboard", "port"]
HeadingUnit = Literal["deg", "rad"]
InputFormat = Literal["auto", "nmea", "csv"]

DEFAULT_MAX_GAP_S: Final = 5.0
"""Longest time without a sample of a stream that is bridged by interpolation [s]."""

_FloatArray = npt.NDArray[np.float64]

_SECONDS_PER_DAY: Final = 86400.0
_HALF_DAY_S: Final = 43200.0
_SECONDS_PER_MINUTE: Final = 60.0
_NORTH_STEP_DEG: Final = 1e-5  # ~1 m: central difference for the direction of North
_SNIFF_LINES: Final = 50
_MAX_HEADING_RAD: Final = math.radians(36000.0)  # a continuous heading of up to 100 turns
_MAX_RUDDER_RAD: Final = math.pi / 2.0
_MAX_SHOWN_CHARS: Final = 40
_SAME_TIME_S: Final = 1e-9  # closer time stamps are one instant (round-off of sensor times)

_DECIMAL: Final = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)", re.ASCII)
_NUMBER: Final = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_TIME_OF_DAY: Final = re.compile(r"(\d{2})(\d{2})(\d{2}(?:\.\d*)?)", re.ASCII)
_LATITUDE: Final = re.compile(r"(\d{2})(\d{2}(?:\.\d*)?)", re.ASCII)
_LONGITUDE: Final = re.compile(r"(\d{3})(\d{2}(?:\.\d*)?)", re.ASCII)
_DATE: Final = re.compile(r"(\d{2})(\d{2})(\d{2})", re.ASCII)
_CHECKSUM_TAIL: Final = re.compile(r"\*[0-9A-Fa-f]{2}\Z", re.ASCII)

_TIME_COLUMNS: Final = ("time_s", "time")
_LAT_COLUMNS: Final = ("lat_deg", "lat", "latitude")
_LON_COLUMNS: Final = ("lon_deg", "lon", "longitude")
_HEADING_COLUMNS: Final = ("heading_deg", "heading_rad", "heading")
_RUDDER_COLUMNS: Final = ("rudder_deg", "rudder_rad")
_RPM_COLUMNS: Final = ("rpm",)

_HEADING: Final = "heading"
_RUDDER: Final = "rudder angle"
_RPM: Final = "propeller speed"
_FIXES: Final = "position fixes"


# --------------------------------------------------------------------------- results


@dataclass(frozen=True, eq=False)
class ConversionResult:
    """The trial logs made from one recording, and what was skipped on the way.

    Parameters
    ----------
    logs : tuple of ManeuverLog
        One log per piece between gaps, in time order; empty when every piece was
        shorter than ``min_samples`` (see ``notes``). All pieces share one time base
        and one tangent plane: time [s] after the first valid fix, x North and y
        East [m] of it.
    skipped_lines : int
        Lines that could not be used: not an NMEA sentence, no checksum (when one is
        required), a malformed field, not ASCII. Checksum failures are not included.
        Always 0 for CSV input, where such a line is an error.
    checksum_failures : int
        NMEA sentences whose checksum did not match (skipped).
    gaps : tuple of (float, float)
        Intervals (start, end) [s, same time base as the logs] in which a stream had
        no sample for longer than ``max_gap_s``; the recording is split there.
        Overlapping gaps of different streams are merged.
    notes : tuple of str
        Human-readable, one-line remarks: gaps per stream, dropped pieces, ignored
        sentence types, invalid readings, extrapolation at the ends of pieces,
        conventions applied.
    origin_lat_deg, origin_lon_deg : float
        Latitude and longitude of the first valid fix, the tangent-plane origin [deg].
    time_origin_utc : str or None
        ISO 8601 UTC time of the first valid fix (time 0), or None when the input
        has no date (NMEA without RMC/ZDA dates, CSV with ``time_s``).
    path : str
        The input file.

    """

    logs: tuple[ManeuverLog, ...]
    skipped_lines: int
    checksum_failures: int
    gaps: tuple[tuple[float, float], ...]
    notes: tuple[str, ...]
    origin_lat_deg: float
    origin_lon_deg: float
    time_origin_utc: str | None
    path: str


@dataclass(frozen=True)
class TangentPlane:
    """Local tangent plane about an origin on the WGS84 ellipsoid: x North, y East [m].

    The plane is PROJ's azimuthal equidistant projection, ``+proj=aeqd +lat_0=...
    +lon_0=... +datum=WGS84``, whose ellipsoidal form is computed with geodesics
    (Karney's algorithm): for every point, ``hypot(x, y)`` is the geodesic distance
    from the origin and ``atan2(y, x)`` the geodesic azimuth at the origin, both
    exact to round-off (PROJ puts points within 1e-10 rad, 0.6 mm, of the origin
    onto it, and an origin within 1e-10 rad of the equator or the prime meridian onto
    that line). Distances between two points that are not the origin are
    stretched across the radial direction by up to ``(s / R)**2 / 6`` at distance
    ``s`` from the origin (``R`` ~ 6371 km); measured between two points at 90 deg
    azimuth apart: 2e-9 (3 µm) at 1 km, 5e-8 (0.4 mm) at 5 km, 8e-7 (2 cm) at
    20 km from the origin, far below GNSS noise over a trial area of a few km.
    The plane's x axis is true North only at the origin: elsewhere the meridian
    makes a small angle with it (:meth:`north_azimuth_rad`; 0.08 deg at 5 km East at
    60 deg latitude), which the conversion adds to true headings so that heading and
    track agree.

    Parameters
    ----------
    origin_lat_deg : float
        Latitude of the origin [deg], positive North, within [-90, 90].
    origin_lon_deg : float
        Longitude of the origin [deg], positive East, within [-180, 180].

    Raises
    ------
    ValueError
        If the origin is not finite or out of range.

    """

    origin_lat_deg: float
    origin_lon_deg: float
    _transformer: pyproj.Transformer = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        lat, lon = float(self.origin_lat_deg), float(self.origin_lon_deg)
        if not (math.isfinite(lat) and math.isfinite(lon) and abs(lat) <= 90 and abs(lon) <= 180):
            raise ValueError(f"tangent-plane origin out of range: lat {lat!r}, lon {lon!r} deg")
        crs = pyproj.CRS.from_proj4(self.proj_string)
        transformer = pyproj.Transformer.from_crs("EPSG:4326", crs, always_xy=True)
        object.__setattr__(self, "_transformer", transformer)

    @property
    def proj_string(self) -> str:
        """The PROJ definition of the plane, e.g. ``+proj=aeqd +lat_0=63.43 ...``."""
        return (
            f"+proj=aeqd +lat_0={float(self.origin_lat_deg)!r} "
            f"+lon_0={float(self.origin_lon_deg)!r} +datum=WGS84 +units=m +no_defs"
        )

    def to_local(
        self, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike
    ) -> tuple[_FloatArray, _FloatArray]:
        """Project geodetic coordinates into the plane.

        Parameters
        ----------
        lat_deg, lon_deg : array_like
            Latitude and longitude on WGS84 [deg].

        Returns
        -------
        x_m, y_m : numpy.ndarray
            Position North and East of the origin in the plane [m].

        """
        lat = np.asarray(lat_deg, dtype=np.float64)
        lon = np.asarray(lon_deg, dtype=np.float64)
        east, north = self._transformer.transform(lon, lat)
        return np.asarray(north, dtype=np.float64), np.asarray(east, dtype=np.float64)

    def north_azimuth_rad(self, lat_deg: npt.ArrayLike, lon_deg: npt.ArrayLike) -> _FloatArray:
        """Direction of true North in the plane, clockwise from the x axis [rad].

        A true heading ψ at this point is the plane heading ``ψ + north_azimuth``.
        Zero on the origin's meridian; computed by a central difference of ±1e-5 deg
        of latitude (error ~1e-10 rad).

        Parameters
        ----------
        lat_deg, lon_deg : array_like
            Latitude and longitude on WGS84 [deg].

        Returns
        -------
        numpy.ndarray
            The angle [rad], negative East of the origin's meridian in the northern
            hemisphere (meridians converge towards the pole).

        """
        lat = np.asarray(lat_deg, dtype=np.float64)
        lon = np.asarray(lon_deg, dtype=np.float64)
        x1, y1 = self.to_local(np.clip(lat - _NORTH_STEP_DEG, -90.0, 90.0), lon)
        x2, y2 = self.to_local(np.clip(lat + _NORTH_STEP_DEG, -90.0, 90.0), lon)
        return np.asarray(np.arctan2(y2 - y1, x2 - x1), dtype=np.float64)


# --------------------------------------------------------------------------- public API


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
    raw = _read_bytes(name)
    kind = detect_format(raw, name) if input_format == "auto" else input_format
    options = _Options.make(rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m)
    if kind == "nmea":
        recording = _read_nmea(name, raw, options.rudder_sign, shaft, require_checksum)
        if heading_unit is not None:
            recording.notes.append(
                f"heading_unit={heading_unit!r} ignored: NMEA headings are in degrees"
            )
    elif kind == "csv":
        recording = _read_latlon_csv(name, raw, options.rudder_sign, heading_unit)
    else:
        raise ValueError(f"input_format must be 'auto', 'nmea' or 'csv', got {input_format!r}")
    return _assemble(recording, options)


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
) -> ConversionResult:
    """Convert an NMEA 0183 recording into trial logs (rules in the module docstring).

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
        :data:`~identifier.logs.MIN_SAMPLES`, the fewest a trial log may have.
    vessel : str or None
        Written as ``# vessel:`` when given (one line).
    length_m : float or None
        Ship length [m], written as ``# length_m:`` when given.
    shaft : int or None
        RPM shaft number to use; None: the only shaft present (an error when RPM
        sentences name several shafts).
    require_checksum : bool
        Skip sentences without a ``*hh`` checksum (default True).

    Returns
    -------
    ConversionResult
        Logs (metadata ``vessel``, ``length_m``, ``source``, ``origin_lat_deg``,
        ``origin_lon_deg``, ``time_origin_utc``, ``projection``), the counts of
        skipped lines and checksum failures, the gaps and notes.

    Raises
    ------
    LogFormatError
        If the file cannot be read, has no NMEA sentence with a valid checksum, no
        valid position fix, no valid heading, rudder or shaft RPM sentence, or RPM
        for several shafts and ``shaft`` is None.
    ValueError
        If an argument is out of range.

    """
    name = os.fspath(path)
    options = _Options.make(rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m)
    recording = _read_nmea(name, _read_bytes(name), options.rudder_sign, shaft, require_checksum)
    return _assemble(recording, options)


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
) -> ConversionResult:
    """Convert a CSV file with latitude/longitude columns into trial logs.

    Parameters
    ----------
    path : str or os.PathLike
        The CSV file (columns in the module docstring).
    rudder_positive : {"starboard", "port"}
        Which way a positive rudder value in the file turns the ship (default
        ``"starboard"``, this project's convention; ``"port"`` flips the sign).
    heading_unit : {"deg", "rad"} or None
        Unit of a ``heading`` column. None (default): degrees, and the unit of
        ``heading_deg`` / ``heading_rad`` from the name. A unit that contradicts the
        column name is an error.
    rate_hz, max_gap_s, min_samples, vessel, length_m
        As for :func:`convert_nmea`.

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
    options = _Options.make(rudder_positive, rate_hz, max_gap_s, min_samples, vessel, length_m)
    recording = _read_latlon_csv(name, _read_bytes(name), options.rudder_sign, heading_unit)
    return _assemble(recording, options)


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
    if names & set(_LAT_COLUMNS) and names & set(_LON_COLUMNS):
        return "csv"
    hint = ""
    if {"x_m", "y_m"} <= names:
        hint = " (it has x_m and y_m columns: it is already a trial log)"
    raise LogFormatError(
        "expected an NMEA 0183 recording ('$' sentences) or a CSV file with latitude and "
        f"longitude columns ({'/'.join(_LAT_COLUMNS)}, {'/'.join(_LON_COLUMNS)}), got "
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


# --------------------------------------------------------------------------- options


@dataclass(frozen=True)
class _Options:
    """Validated conversion settings shared by both input formats."""

    rudder_positive: RudderPositive
    rate_hz: float | None
    max_gap_s: float
    min_samples: int
    vessel: str | None
    length_m: float | None

    @property
    def rudder_sign(self) -> float:
        """+1 to keep the file's rudder sign, -1 to flip it."""
        return 1.0 if self.rudder_positive == "starboard" else -1.0

    @classmethod
    def make(
        cls,
        rudder_positive: RudderPositive,
        rate_hz: float | None,
        max_gap_s: float,
        min_samples: int,
        vessel: str | None,
        length_m: float | None,
    ) -> _Options:
        """Check the settings; raise ValueError naming the bad one."""
        if rudder_positive not in ("starboard", "port"):
            raise ValueError(
                f"rudder_positive must be 'starboard' or 'port', got {rudder_positive!r}"
            )
        if rate_hz is not None and not (math.isfinite(rate_hz) and rate_hz > 0.0):
            raise ValueError(f"rate_hz must be a positive number, got {rate_hz!r}")
        if not (math.isfinite(max_gap_s) and max_gap_s > 0.0):
            raise ValueError(f"max_gap_s must be a positive number of seconds, got {max_gap_s!r}")
        if isinstance(min_samples, bool) or not isinstance(min_samples, int) or min_samples < 2:
            raise ValueError(f"min_samples must be an integer of at least 2, got {min_samples!r}")
        if vessel is not None and (
            any(c in vessel for c in "\r\n\0") or not vessel.strip() or vessel != vessel.strip()
        ):
            raise ValueError(f"vessel must be one non-empty line without padding, got {vessel!r}")
        if length_m is not None and not (math.isfinite(length_m) and length_m > 0.0):
            raise ValueError(f"length_m must be a positive number of metres, got {length_m!r}")
        return cls(
            rudder_positive,
            None if rate_hz is None else float(rate_hz),
            float(max_gap_s),
            min_samples,
            vessel,
            None if length_m is None else float(length_m),
        )


# --------------------------------------------------------------------------- recordings


@dataclass
class _Recording:
    """What a reader found: each stream with its own times [s, any common origin]."""

    path: str
    kind: str
    fix_t: _FloatArray
    lat_deg: _FloatArray
    lon_deg: _FloatArray
    streams: dict[str, tuple[_FloatArray, _FloatArray]]  # name -> (times, SI values)
    sources: dict[str, str]  # name -> what would have provided it (for messages)
    epoch: dt.datetime | None  # UTC instant of time 0 of fix_t and the streams
    skipped_lines: int = 0
    checksum_failures: int = 0
    notes: list[str] = field(default_factory=list)


def _read_bytes(path: str) -> bytes:
    """Read a file's bytes, or raise LogFormatError as :func:`read_log` does."""
    try:
        with open(path, "rb") as file:
            return file.read()
    except FileNotFoundError:
        raise LogFormatError(
            "no such file; expected an existing recording", path=path, expected="an existing file"
        ) from None
    except IsADirectoryError:
        raise LogFormatError(
            "is a directory; expected a recording file", path=path, expected="a file"
        ) from None
    except OSError as error:
        reason = error.strerror or type(error).__name__
        raise LogFormatError(
            f"cannot read the file ({reason})", path=path, expected="a readable file"
        ) from None


def _show(text: str) -> str:
    """Quote a file excerpt for a message: repr, shortened if long."""
    if len(text) > _MAX_SHOWN_CHARS:
        return repr(text[: _MAX_SHOWN_CHARS - 3]) + "..."
    return repr(text)


def _one_line(text: str) -> str:
    """Make text fit a metadata value: printable characters only, stripped."""
    return "".join(c if c.isprintable() else "?" for c in text).strip()


# --------------------------------------------------------------------------- NMEA


class _MalformedError(Exception):
    """A field of an otherwise well-formed sentence cannot be read (line skipped)."""


@dataclass(frozen=True)
class _Timed:
    """A time-stamped sentence: GGA, RMC or ZDA."""

    line: int
    talker: str
    kind: str
    time_of_day_s: float
    date: dt.date | None
    fix: tuple[float, float] | None  # (lat_deg, lon_deg) of a valid fix


@dataclass(frozen=True)
class _Sample:
    """A sensor reading without its own time: heading, rudder or RPM."""

    line: int
    source: str  # talker + type (+ shaft), e.g. "HEHDT"
    value: float  # SI: rad or rev/s


def _time_of_day(text: str) -> float:
    """``hhmmss[.sss]`` → seconds after midnight."""
    match = _TIME_OF_DAY.fullmatch(text)
    if match is None:
        raise _MalformedError
    hours, minutes, seconds = int(match[1]), int(match[2]), float(match[3])
    if hours > 23 or minutes > 59 or seconds >= 61.0:  # 60.x: leap second
        raise _MalformedError
    return hours * 3600.0 + minutes * 60.0 + seconds


def _degrees_minutes(text: str, hemisphere: str, pattern: re.Pattern[str], limit: float) -> float:
    """``ddmm.mmmm`` / ``dddmm.mmmm`` with N/S or E/W → signed degrees."""
    match = pattern.fullmatch(text)
    if match is None or hemisphere not in ("N", "S", "E", "W"):
        raise _MalformedError
    minutes = float(match[2])
    value = int(match[1]) + minutes / 60.0
    if minutes >= 60.0 or value > limit:
        raise _MalformedError
    return -value if hemisphere in ("S", "W") else value


def _latitude(text: str, hemisphere: str) -> float:
    if hemisphere not in ("N", "S"):
        raise _MalformedError
    return _degrees_minutes(text, hemisphere, _LATITUDE, 90.0)


def _longitude(text: str, hemisphere: str) -> float:
    if hemisphere not in ("E", "W"):
        raise _MalformedError
    return _degrees_minutes(text, hemisphere, _LONGITUDE, 180.0)


def _decimal(text: str, low: float = -math.inf, high: float = math.inf) -> float:
    """Read a plain decimal number within [low, high]."""
    if _DECIMAL.fullmatch(text) is None:
        raise _MalformedError
    value = float(text)
    if not low <= value <= high:
        raise _MalformedError
    return value


def _rmc_date(text: str) -> dt.date | None:
    """``ddmmyy`` → date (years 2000-2099); empty → None."""
    if not text:
        return None
    match = _DATE.fullmatch(text)
    if match is None:
        raise _MalformedError
    try:
        return dt.date(2000 + int(match[3]), int(match[2]), int(match[1]))
    except ValueError:
        raise _MalformedError from None


def _zda_date(day: str, month: str, year: str) -> dt.date:
    if not (day.isdigit() and month.isdigit() and year.isdigit() and len(year) == 4):
        raise _MalformedError
    try:
        return dt.date(int(year), int(month), int(day))
    except ValueError:
        raise _MalformedError from None


class _NmeaReader:
    """Line-by-line collection of NMEA records (one instance per file)."""

    def __init__(self, rudder_sign: float, require_checksum: bool) -> None:
        self.rudder_sign = rudder_sign
        self.require_checksum = require_checksum
        self.skipped = 0
        self.checksum_failures = 0
        self.sentences = 0
        self.tally: Counter[str] = Counter()  # invalid readings, missing checksums, ...
        self.other: Counter[str] = Counter()  # ignored sentence types
        self.timed: list[_Timed] = []
        self.samples: dict[str, list[_Sample]] = {_HEADING: [], _RUDDER: [], _RPM: []}

    def feed(self, number: int, raw: bytes) -> None:
        """Consume line ``number`` (1-based)."""
        stripped = raw.strip()
        if not stripped:
            return
        try:
            line = stripped.decode("ascii")
        except UnicodeDecodeError:
            self.skipped += 1
            return
        if line.startswith("!"):  # AIS and other encapsulated sentences
            self.sentences += 1
            self.other[line[1:6] or "!"] += 1
            return
        if not line.startswith("$"):
            self.skipped += 1
            return
        if _CHECKSUM_TAIL.search(line) is None:
            if self.require_checksum:
                self.skipped += 1
                self.tally["sentences without a checksum (skipped)"] += 1
                return
        try:
            sentence = pynmea2.parse(line)
        except pynmea2.ChecksumError:
            self.checksum_failures += 1
            return
        except pynmea2.SentenceTypeError:
            self.sentences += 1
            body = line[1:].split("*", 1)[0].split(",")
            if body[0][2:] == "THS":
                self.dispatch(number, body[0][:2], "THS", body[1:], None)
            else:
                self.other[body[0][2:] or body[0]] += 1
            return
        except pynmea2.ParseError:
            self.skipped += 1
            return
        self.sentences += 1
        if not isinstance(sentence, pynmea2.TalkerSentence):
            self.other["proprietary"] += 1
            return
        self.dispatch(number, sentence.talker, sentence.sentence_type, sentence.data, sentence)

    def dispatch(self, number: int, talker: str, kind: str, data: list[str], sentence: Any) -> None:
        """Read the fields of one sentence of a used type; count a malformed one."""

        def get(name: str, index: int) -> str:
            # pynmea2's field table when there is one (THS has none in pynmea2).
            if sentence is not None:
                index = type(sentence).name_to_idx[name]
            return data[index].strip() if index < len(data) else ""

        handlers: dict[str, Callable[[int, str, Callable[[str, int], str]], None]] = {
            "GGA": self.gga,
            "RMC": self.rmc,
            "ZDA": self.zda,
            "HDT": self.hdt,
            "THS": self.ths,
            "RSA": self.rsa,
            "RPM": self.rpm,
        }
        handler = handlers.get(kind)
        if handler is None:
            self.other[kind] += 1
            return
        try:
            handler(number, talker, get)
        except _MalformedError:
            self.skipped += 1

    def gga(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--GGA,hhmmss.ss,llll.ll,a,yyyyy.yy,a,q,...``."""
        time_text, quality = get("timestamp", 0), get("gps_qual", 5)
        if not time_text:
            self.tally["GGA sentences without a time"] += 1
            return
        time_of_day = _time_of_day(time_text)
        if not (quality.isdigit() and len(quality) == 1):
            raise _MalformedError
        fix = None
        if quality != "0":
            fix = (
                _latitude(get("lat", 1), get("lat_dir", 2)),
                _longitude(get("lon", 3), get("lon_dir", 4)),
            )
        else:
            self.tally["GGA sentences without a fix (quality 0)"] += 1
        self.timed.append(_Timed(number, talker, "GGA", time_of_day, None, fix))

    def rmc(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--RMC,hhmmss.ss,A,llll.ll,a,yyyyy.yy,a,sog,cog,ddmmyy,...``."""
        time_text, status = get("timestamp", 0), get("status", 1)
        if not time_text:
            self.tally["RMC sentences without a time"] += 1
            return
        time_of_day = _time_of_day(time_text)
        if status not in ("A", "V"):
            raise _MalformedError
        date = _rmc_date(get("datestamp", 8))
        valid = status == "A" and get("mode_indicator", 11) != "N"
        fix = None
        if valid:
            fix = (
                _latitude(get("lat", 2), get("lat_dir", 3)),
                _longitude(get("lon", 4), get("lon_dir", 5)),
            )
        else:
            self.tally["RMC sentences without a fix (status V)"] += 1
        self.timed.append(_Timed(number, talker, "RMC", time_of_day, date, fix))

    def zda(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--ZDA,hhmmss.ss,dd,mm,yyyy,zh,zm``."""
        time_of_day = _time_of_day(get("timestamp", 0))
        date = _zda_date(get("day", 1), get("month", 2), get("year", 3))
        self.timed.append(_Timed(number, talker, "ZDA", time_of_day, date, None))

    def hdt(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--HDT,x.x,T``."""
        if get("hdg_true", 1) != "T":
            raise _MalformedError
        heading = _decimal(get("heading", 0), 0.0, 360.0)
        self.samples[_HEADING].append(_Sample(number, f"{talker}HDT", math.radians(heading)))

    def ths(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--THS,x.x,a`` (mode A autonomous, E estimated, M manual, S simulator, V)."""
        mode = get("mode", 1)
        if mode not in ("A", "E", "M", "S", "V"):
            raise _MalformedError
        heading = _decimal(get("heading", 0), 0.0, 360.0)
        if mode != "A":
            self.tally[f"THS headings with mode {mode}, not A (ignored)"] += 1
            return
        self.samples[_HEADING].append(_Sample(number, f"{talker}THS", math.radians(heading)))

    def rsa(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--RSA,x.x,A,x.x,A`` (starboard or single rudder, status; port, status)."""
        status = get("rsa_starboard_status", 1)
        if status not in ("A", "V"):
            raise _MalformedError
        if status != "A":
            self.tally["RSA rudder angles with status V (ignored)"] += 1
            return
        angle = _decimal(get("rsa_starboard", 0), -90.0, 90.0)
        rudder = self.rudder_sign * math.radians(angle)
        self.samples[_RUDDER].append(_Sample(number, f"{talker}RSA", rudder))

    def rpm(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--RPM,a,x,x.x,x.x,A`` (source S/E, number, rpm, pitch %, status)."""
        source, shaft, status = get("source", 0), get("engine_no", 1), get("status", 4)
        if source not in ("S", "E") or not shaft.isdigit() or status not in ("A", "V"):
            raise _MalformedError
        speed = _decimal(get("speed", 2))
        if status != "A":
            self.tally["RPM sentences with status V (ignored)"] += 1
        elif source == "E":
            self.tally["engine RPM sentences, source E (ignored; shaft RPM used)"] += 1
        else:
            n_rps = speed / _SECONDS_PER_MINUTE
            self.samples[_RPM].append(_Sample(number, f"{talker}RPM shaft {int(shaft)}", n_rps))


def _read_nmea(
    path: str, raw: bytes, rudder_sign: float, shaft: int | None, require_checksum: bool
) -> _Recording:
    """Collect the NMEA records of a file and put every stream on one time axis."""
    reader = _NmeaReader(rudder_sign, require_checksum)
    for number, text in enumerate(raw.split(b"\n"), start=1):
        reader.feed(number, text)
    counts = f"{reader.skipped} lines skipped, {reader.checksum_failures} checksum failures"
    if reader.sentences == 0:
        raise LogFormatError(
            "no NMEA 0183 sentence with a valid checksum ('$...*hh'); expected an NMEA 0183 "
            f"recording ({counts})",
            path=path,
            expected="NMEA 0183 sentences",
        )
    notes: list[str] = []
    fixes_by_talker = Counter(record.talker for record in reader.timed if record.fix is not None)
    if not fixes_by_talker:
        raise LogFormatError(
            "no valid position fix; expected GGA sentences with a fix quality above 0 or RMC "
            f"sentences with status A ({counts})",
            path=path,
            expected="valid GGA or RMC position fixes",
        )
    talker = _most_common(fixes_by_talker, "position fixes", notes)
    timed = [r for r in reader.timed if r.talker == talker or r.kind == "ZDA"]
    times, epoch = _resolve_times(timed, notes)

    # Time stamps must increase. A few wrong ones (a receiver's clock step, a bad time
    # with a valid checksum) must not discard the rest of the file, so the longest
    # increasing sequence is kept, separately for timing and for the fixes.
    anchors = _increasing(times)
    anchor_lines = [timed[i].line for i in anchors]
    anchor_times = [times[i] for i in anchors]
    with_fix = [i for i, r in enumerate(timed) if r.fix is not None and r.talker == talker]
    kept = [with_fix[k] for k in _increasing([times[i] for i in with_fix])]
    fix_t = [times[i] for i in kept]
    fixes = [fix for fix in (timed[i].fix for i in kept) if fix is not None]
    kept_times = set(fix_t)
    repeated = sum(times[i] in kept_times for i in set(with_fix) - set(kept))
    if repeated:
        notes.append(f"fixes at the time of another fix, e.g. GGA and RMC (unused): {repeated}")
    if len(with_fix) - len(kept) - repeated:
        notes.append(
            f"fixes with a time out of order (dropped): {len(with_fix) - len(kept) - repeated}"
        )
    if len(anchors) < len(timed):
        notes.append(
            "time stamps repeated or out of order, not used for timing: "
            f"{len(timed) - len(anchors)}"
        )

    lines = np.array(anchor_lines, dtype=np.float64)
    clock = np.array(anchor_times, dtype=np.float64)
    streams: dict[str, tuple[_FloatArray, _FloatArray]] = {}
    for name, samples in reader.samples.items():
        chosen = _choose_samples(name, samples, shaft, path, notes)
        line = np.array([s.line for s in chosen], dtype=np.float64)
        inside = (line > lines[0]) & (line < lines[-1])
        if np.count_nonzero(~inside):
            notes.append(
                f"{name} sentences before the first or after the last time-stamped sentence "
                f"(dropped): {np.count_nonzero(~inside)}"
            )
        values = np.array([s.value for s in chosen], dtype=np.float64)
        streams[name] = (np.interp(line[inside], lines, clock), values[inside])

    for what, count in sorted(reader.tally.items()):
        notes.append(f"{what}: {count}")
    if reader.other:
        shown = ", ".join(f"{kind} {count}" for kind, count in sorted(reader.other.items()))
        notes.append(f"other sentences ignored: {shown}")
    lat, lon = (np.array(values, dtype=np.float64) for values in zip(*fixes, strict=True))
    return _Recording(
        path=path,
        kind="NMEA 0183",
        fix_t=np.array(fix_t, dtype=np.float64),
        lat_deg=lat,
        lon_deg=lon,
        streams=streams,
        sources={
            _HEADING: "HDT or THS (mode A) sentences",
            _RUDDER: "RSA sentences with status A",
            _RPM: "RPM sentences of a shaft (source S) with status A",
        },
        epoch=epoch,
        skipped_lines=reader.skipped,
        checksum_failures=reader.checksum_failures,
        notes=notes,
    )


def _most_common(counts: Counter[str], what: str, notes: list[str]) -> str:
    """Return the source with the most samples; note the others."""
    ranked = counts.most_common()
    if len(ranked) > 1:
        others = ", ".join(f"{source} ({count})" for source, count in ranked[1:])
        notes.append(f"{what} from {ranked[0][0]} ({ranked[0][1]}) used; ignored {others}")
    return ranked[0][0]


def _choose_samples(
    name: str, samples: list[_Sample], shaft: int | None, path: str, notes: list[str]
) -> list[_Sample]:
    """Keep the samples of one source (and shaft) of a stream."""
    if name == _RPM:
        shafts = sorted({int(s.source.rsplit(" ", 1)[1]) for s in samples})
        if shaft is not None:
            samples = [s for s in samples if s.source.endswith(f" shaft {shaft}")]
            if not samples and shafts:
                raise LogFormatError(
                    f"no RPM sentences for shaft {shaft}; expected one of the shafts in the "
                    f"file: {', '.join(map(str, shafts))}",
                    path=path,
                    expected=f"RPM sentences for shaft {shaft}",
                )
        elif len(shafts) > 1:
            raise LogFormatError(
                f"RPM sentences for several shafts ({', '.join(map(str, shafts))}); expected "
                "one: choose it with shaft= (--shaft)",
                path=path,
                expected="RPM sentences of a single shaft",
            )
    if not samples:
        return []
    source = _most_common(Counter(s.source for s in samples), name, notes)
    return [s for s in samples if s.source == source]


def _resolve_times(timed: list[_Timed], notes: list[str]) -> tuple[list[float], dt.datetime | None]:
    """Seconds after midnight of the first date in the file, for every timed record.

    Records with a date use it; the others take the day that puts them within 12 h
    of the neighbouring record (the previous one, or the next for those before the
    first dated record), which unwraps midnight rollovers.
    """
    dates = [record.date for record in timed if record.date is not None]
    reference = dates[0] if dates else None
    if reference is None:
        notes.append("no date (RMC or ZDA) in the file: time_origin_utc unknown")
    times: list[float | None] = [None] * len(timed)
    previous: float | None = None
    for i, record in enumerate(timed):
        if record.date is not None and reference is not None:
            time = (record.date - reference).days * _SECONDS_PER_DAY + record.time_of_day_s
        elif previous is not None:
            time = _nearest_day(record.time_of_day_s, previous)
        elif reference is None:
            time = record.time_of_day_s  # no date anywhere: day 0
        else:
            continue  # before the first dated record: resolved backwards below
        times[i] = previous = time
    first = next(i for i, time in enumerate(times) if time is not None)
    for i in range(first - 1, -1, -1):
        later = times[i + 1]
        assert later is not None  # filled from ``first`` downwards
        times[i] = _nearest_day(timed[i].time_of_day_s, later)
    epoch = None
    if reference is not None:
        epoch = dt.datetime.combine(reference, dt.time(), tzinfo=dt.UTC)
    return [float(time) for time in times if time is not None], epoch


def _increasing(values: Sequence[float]) -> list[int]:
    """Return the indices of a longest strictly increasing subsequence of ``values``.

    Patience sorting, O(n log n).
    """
    tails: list[float] = []  # smallest last value of an increasing run of each length
    tail_index: list[int] = []
    previous = [-1] * len(values)
    for i, value in enumerate(values):
        k = bisect.bisect_left(tails, value)
        if k == len(tails):
            tails.append(value)
            tail_index.append(i)
        else:
            tails[k] = value
            tail_index[k] = i
        previous[i] = tail_index[k - 1] if k > 0 else -1
    result: list[int] = []
    i = tail_index[-1] if tail_index else -1
    while i >= 0:
        result.append(i)
        i = previous[i]
    return result[::-1]


def _nearest_day(time_of_day_s: float, near: float) -> float:
    """Return the time ``day * 86400 + time_of_day_s`` closest to ``near`` [s]."""
    time = math.floor(near / _SECONDS_PER_DAY) * _SECONDS_PER_DAY + time_of_day_s
    if time - near > _HALF_DAY_S:
        time -= _SECONDS_PER_DAY
    elif near - time > _HALF_DAY_S:
        time += _SECONDS_PER_DAY
    return time


# --------------------------------------------------------------------------- CSV


def _decode_utf8(raw: bytes, path: str) -> str:
    """Decode UTF-8 (optional byte-order mark) or raise LogFormatError with the line."""
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise LogFormatError(
            f"not a text file: invalid UTF-8 byte 0x{raw[error.start]:02x} at offset "
            f"{error.start}; expected UTF-8 text",
            path=path,
            line=raw.count(b"\n", 0, error.start) + 1,
            expected="UTF-8 text",
        ) from None


@dataclass(frozen=True)
class _Columns:
    """Field positions of the used CSV columns, and how to read them."""

    time: int
    iso_time: bool
    lat: int
    lon: int
    heading: int
    heading_scale: float  # file unit → rad
    rudder: int
    rudder_scale: float
    rpm: int
    n_fields: int


def _csv_columns(
    names: list[str], line: int, path: str, heading_unit: HeadingUnit | None
) -> _Columns:
    """Map the header to the accepted column names (module docstring)."""

    def one(accepted: tuple[str, ...], what: str) -> tuple[int, str]:
        present = [name for name in accepted if name in names]
        if not present:
            raise LogFormatError(
                f"missing {what} column; expected one of {', '.join(accepted)} in the header",
                path=path,
                line=line,
                expected=f"a {what} column",
            )
        if len(present) > 1 or names.count(present[0]) > 1:
            raise LogFormatError(
                f"expected one {what} column, got {', '.join(present)}"
                + (" more than once" if len(present) == 1 else ""),
                path=path,
                line=line,
                expected=f"one {what} column",
            )
        return names.index(present[0]), present[0]

    time, time_name = one(_TIME_COLUMNS, "time")
    heading, heading_name = one(_HEADING_COLUMNS, "heading")
    rudder, rudder_name = one(_RUDDER_COLUMNS, "rudder")
    unit = heading_name.removeprefix("heading").removeprefix("_") or heading_unit or "deg"
    if heading_unit is not None and unit != heading_unit:
        raise LogFormatError(
            f"its name says {unit}, but heading_unit={heading_unit!r} was given; expected a "
            f"column 'heading_{heading_unit}', or 'heading' (unit from heading_unit)",
            path=path,
            line=line,
            column=heading_name,
            expected=f"heading in {heading_unit}",
        )
    return _Columns(
        time=time,
        iso_time=time_name == "time",
        lat=one(_LAT_COLUMNS, "latitude")[0],
        lon=one(_LON_COLUMNS, "longitude")[0],
        heading=heading,
        heading_scale=1.0 if unit == "rad" else math.pi / 180.0,
        rudder=rudder,
        rudder_scale=1.0 if rudder_name == "rudder_rad" else math.pi / 180.0,
        rpm=one(_RPM_COLUMNS, "propeller speed")[0],
        n_fields=len(names),
    )


def _split_csv(line: str, number: int, path: str) -> list[str]:
    if '"' not in line:
        return line.split(",")
    try:
        return next(csv.reader([line], strict=True))
    except csv.Error:
        raise LogFormatError(
            f"expected comma-separated fields, got malformed quoting in {_show(line)}",
            path=path,
            line=number,
            expected="comma-separated fields",
        ) from None


class _CsvReader:
    """Line-by-line reading of a latitude/longitude CSV file (one instance per file)."""

    def __init__(self, path: str, rudder_sign: float, heading_unit: HeadingUnit | None) -> None:
        self.path = path
        self.rudder_sign = rudder_sign
        self.heading_unit = heading_unit
        self.columns: _Columns | None = None
        self.names: list[str] = []
        self.header_line = 0
        self.previous_line = 0
        self.times: list[float] = []
        self.first_iso: dt.datetime | None = None
        self.rows: dict[str, tuple[list[float], list[float]]] = {
            name: ([], []) for name in (_FIXES, "lon", _HEADING, _RUDDER, _RPM)
        }

    def error(
        self, message: str, line: int, expected: str, index: int | None = None
    ) -> LogFormatError:
        """Build a LogFormatError for this file (the caller raises it)."""
        column = None if index is None else self.names[index]
        return LogFormatError(message, self.path, line=line, column=column, expected=expected)

    def feed(self, number: int, line: str) -> None:
        """Consume line ``number`` (1-based), its LF already removed."""
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            return
        fields = _split_csv(line.removesuffix("\r"), number, self.path)
        if self.columns is None:
            self.names = [name.strip() for name in fields]
            if len(self.names) == 1 and ";" in line:
                raise self.error(
                    "expected ',' as the field separator, got ';'",
                    number,
                    expected="',' as the field separator",
                )
            self.columns = _csv_columns(self.names, number, self.path, self.heading_unit)
            self.header_line = number
            return
        self.row(number, fields, self.columns)

    def number(
        self,
        fields: list[str],
        index: int,
        line: int,
        low: float = -math.inf,
        high: float = math.inf,
    ) -> float | None:
        """Return the number in one cell, None when the cell is empty."""
        text = fields[index].strip()
        if not text:
            return None
        value = float(text) if _NUMBER.fullmatch(text) else math.nan
        if not (math.isfinite(value) and low <= value <= high):
            limits = "" if math.isinf(low) else f" within [{low:g}, {high:g}]"
            raise self.error(
                f"expected a finite number{limits}, got {_show(text)}",
                line,
                expected=f"a finite number{limits}",
                index=index,
            )
        return value

    def row(self, number: int, fields: list[str], columns: _Columns) -> None:
        """Read one data row into the streams."""
        if len(fields) != columns.n_fields:
            raise self.error(
                f"expected {columns.n_fields} fields separated by ',' as in the header on line "
                f"{self.header_line}, got {len(fields)}",
                number,
                expected=f"{columns.n_fields} fields",
            )
        time_text = fields[columns.time].strip()
        if columns.iso_time:
            stamp = _iso_time(time_text, self.path, number, self.names[columns.time])
            if self.first_iso is None:
                self.first_iso = stamp
            time = (stamp - self.first_iso).total_seconds()
        else:
            value = self.number(fields, columns.time, number)
            if value is None:
                raise self.error(
                    "expected a time, got an empty field",
                    number,
                    expected="a time",
                    index=columns.time,
                )
            time = value
        if self.times and time <= self.times[-1]:
            raise self.error(
                f"expected strictly increasing time, got {_show(time_text)} after the time on "
                f"line {self.previous_line}",
                number,
                expected="strictly increasing time",
                index=columns.time,
            )
        self.times.append(time)
        self.previous_line = number

        lat = self.number(fields, columns.lat, number, -90.0, 90.0)
        lon = self.number(fields, columns.lon, number, -180.0, 180.0)
        if (lat is None) != (lon is None):
            raise self.error(
                "expected latitude and longitude together or neither, got only one",
                number,
                expected="latitude and longitude together",
                index=columns.lat if lat is None else columns.lon,
            )
        heading_limit = _MAX_HEADING_RAD / columns.heading_scale  # in the file's unit
        rudder_limit = _MAX_RUDDER_RAD / columns.rudder_scale
        heading = self.number(fields, columns.heading, number, -heading_limit, heading_limit)
        rudder = self.number(fields, columns.rudder, number, -rudder_limit, rudder_limit)
        samples = (
            (_FIXES, lat, 1.0),
            ("lon", lon, 1.0),
            (_HEADING, heading, columns.heading_scale),
            (_RUDDER, rudder, self.rudder_sign * columns.rudder_scale),
            (_RPM, self.number(fields, columns.rpm, number), 1.0 / _SECONDS_PER_MINUTE),
        )
        for name, sample, scale in samples:
            if sample is not None:
                self.rows[name][0].append(time)
                self.rows[name][1].append(sample * scale)

    def finish(self) -> _Recording:
        """Check that there was a header; return the streams."""
        if self.columns is None:
            raise LogFormatError(
                "no header line; expected a CSV header with time, latitude, longitude, "
                "heading, rudder and rpm columns",
                path=self.path,
                expected="a header line",
            )
        arrays = {
            name: (np.array(t, dtype=np.float64), np.array(v, dtype=np.float64))
            for name, (t, v) in self.rows.items()
        }
        return _Recording(
            path=self.path,
            kind="latitude/longitude CSV",
            fix_t=arrays[_FIXES][0],
            lat_deg=arrays[_FIXES][1],
            lon_deg=arrays["lon"][1],
            streams={name: arrays[name] for name in (_HEADING, _RUDDER, _RPM)},
            sources={
                _HEADING: "rows with a heading",
                _RUDDER: "rows with a rudder angle",
                _RPM: "rows with an rpm",
            },
            epoch=self.first_iso,
            notes=[] if self.first_iso else ["time_s column: time_origin_utc unknown"],
        )


def _read_latlon_csv(
    path: str, raw: bytes, rudder_sign: float, heading_unit: HeadingUnit | None
) -> _Recording:
    """Read a latitude/longitude CSV file into streams (module docstring)."""
    if heading_unit not in (None, "deg", "rad"):
        raise ValueError(f"heading_unit must be 'deg', 'rad' or None, got {heading_unit!r}")
    reader = _CsvReader(path, rudder_sign, heading_unit)
    for number, line in enumerate(_decode_utf8(raw, path).split("\n"), start=1):
        reader.feed(number, line)
    return reader.finish()


def _iso_time(text: str, path: str, line: int, column: str) -> dt.datetime:
    """Parse an ISO 8601 date and time into an aware UTC datetime (no offset: UTC)."""
    try:
        stamp = dt.datetime.fromisoformat(text)
    except ValueError:
        raise LogFormatError(
            f"expected an ISO 8601 date and time like '2024-05-17T23:58:30.25Z', got "
            f"{_show(text) if text else 'an empty field'}",
            path=path,
            line=line,
            column=column,
            expected="an ISO 8601 date and time",
        ) from None
    if stamp.tzinfo is None:
        return stamp.replace(tzinfo=dt.UTC)
    return stamp.astimezone(dt.UTC)


# --------------------------------------------------------------------------- assembly


def _coverage(
    times: _FloatArray, max_gap_s: float
) -> tuple[list[tuple[float, float]], list[tuple[float, float]]]:
    """Intervals a stream covers without a gap longer than ``max_gap_s``, and the gaps."""
    breaks = np.flatnonzero(np.diff(times) > max_gap_s)
    starts = [float(times[0]), *(float(times[i + 1]) for i in breaks)]
    ends = [*(float(times[i]) for i in breaks), float(times[-1])]
    gaps = [(float(times[i]), float(times[i + 1])) for i in breaks]
    return list(zip(starts, ends, strict=True)), gaps


def _intersect(
    a: list[tuple[float, float]], b: list[tuple[float, float]]
) -> list[tuple[float, float]]:
    """Intersection of two sorted lists of disjoint closed intervals."""
    result: list[tuple[float, float]] = []
    i = j = 0
    while i < len(a) and j < len(b):
        low, high = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if low <= high:
            result.append((low, high))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return result


def _merge(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Union of intervals, as sorted disjoint intervals."""
    merged: list[tuple[float, float]] = []
    for low, high in sorted(intervals):
        if merged and low <= merged[-1][1]:
            merged[-1] = (merged[-1][0], max(merged[-1][1], high))
        else:
            merged.append((low, high))
    return merged


def _time_base(start: float, end: float, fix_t: _FloatArray, rate_hz: float | None) -> _FloatArray:
    """Sample times of one piece: the fixes in it, or the ``rate_hz`` grid in it."""
    if rate_hz is None:
        return fix_t[(fix_t >= start) & (fix_t <= end)]
    first = math.ceil(start * rate_hz - 1e-9)
    last = math.floor(end * rate_hz + 1e-9)
    return np.arange(first, last + 1, dtype=np.float64) / rate_hz


def _base_before(time: float, fix_t: _FloatArray, rate_hz: float | None) -> float | None:
    """Return the last time-base sample (fix or grid time) at or before ``time`` [s]."""
    if rate_hz is not None:
        return math.floor(time * rate_hz + 1e-9) / rate_hz
    k = int(np.searchsorted(fix_t, time + _SAME_TIME_S, side="right")) - 1
    return float(fix_t[k]) if k >= 0 else None


def _base_after(time: float, fix_t: _FloatArray, rate_hz: float | None) -> float | None:
    """Return the first time-base sample (fix or grid time) at or after ``time`` [s]."""
    if rate_hz is not None:
        return math.ceil(time * rate_hz - 1e-9) / rate_hz
    k = int(np.searchsorted(fix_t, time - _SAME_TIME_S, side="left"))
    return float(fix_t[k]) if k < fix_t.size else None


def _stretch(
    covered: list[tuple[float, float]],
    times: _FloatArray,
    fix_t: _FloatArray,
    options: _Options,
) -> list[tuple[float, float]]:
    """Widen a stream's covered intervals by one time-base sample at each end, if near.

    An interval that starts at the stream's sample ``t0`` (next sample ``t1``) is
    widened to the time-base sample ``b <= t0`` just before it when
    ``t0 - b <= min(t1 - t0, max_gap_s / 2)``: within one of the stream's own sample
    intervals, and never so far that the intervals on the two sides of a gap (longer
    than ``max_gap_s``) could meet. The same at the end. An interval of one sample is
    not widened. :func:`_resample` then continues the stream's edge line there.
    """
    widened = []
    for start, end in covered:
        i = int(np.searchsorted(times, start))  # covered ends are sample times
        j = int(np.searchsorted(times, end))
        if j > i:
            reach = min(float(times[i + 1] - times[i]), options.max_gap_s / 2.0)
            before = _base_before(start, fix_t, options.rate_hz)
            if before is not None and start - before <= reach + _SAME_TIME_S:
                start = min(start, before)
            reach = min(float(times[j] - times[j - 1]), options.max_gap_s / 2.0)
            after = _base_after(end, fix_t, options.rate_hz)
            if after is not None and after - end <= reach + _SAME_TIME_S:
                end = max(end, after)
        widened.append((start, end))
    return widened


def _resample(
    time: _FloatArray, times: _FloatArray, values: _FloatArray, max_gap_s: float
) -> tuple[_FloatArray, float]:
    """Values of one stream at ``time``, and how far any of them was extrapolated [s].

    Linear interpolation between the stream's samples; a time before the first (after
    the last) sample of a stretch without a gap longer than ``max_gap_s`` gets the
    line through the stretch's first (last) two samples, continued (a stretch of one
    sample: its value). Only the times :func:`_stretch` admits are asked for, at most
    one sample interval of the stream away from a sample.
    """
    result = np.interp(time, times, values)
    n = times.size
    # split[k]: times[k - 1] and times[k] are not joined (a gap; k = 0 and n: the ends)
    split = np.ones(n + 1, dtype=bool)
    split[1:-1] = np.diff(times) > max_gap_s
    index = np.searchsorted(times, time)  # times[k - 1] < time <= times[k]
    farthest = 0.0
    for i in np.flatnonzero(split[index]):
        k = int(index[i])
        if k < n and time[i] == times[k]:
            continue
        if k == n or (k > 0 and time[i] - times[k - 1] < times[k] - time[i]):
            a, b = k - 2, k - 1  # after the stretch that ends at times[k - 1]
            single = a < 0 or bool(split[b])
            edge = b
        else:
            a, b = k, k + 1  # before the stretch that starts at times[k]
            single = b >= n or bool(split[b])
            edge = a
        if single:
            result[i] = values[edge]
        else:
            slope = (values[b] - values[a]) / (times[b] - times[a])
            result[i] = values[edge] + slope * (time[i] - times[edge])
        farthest = max(farthest, abs(float(time[i] - times[edge])))
    return result, farthest


def _assemble(recording: _Recording, options: _Options) -> ConversionResult:
    """Project, split at gaps, resample and build the logs of one recording."""
    path, notes = recording.path, list(recording.notes)
    if recording.fix_t.size == 0:
        raise LogFormatError(
            "no valid position fix; expected rows with latitude and longitude",
            path=path,
            expected="position fixes",
        )
    for name, (times, _) in recording.streams.items():
        if times.size == 0:
            raise LogFormatError(
                f"no {name} samples; expected {recording.sources[name]}",
                path=path,
                expected=f"{name} samples",
            )
    plane = TangentPlane(float(recording.lat_deg[0]), float(recording.lon_deg[0]))
    x_m, y_m = plane.to_local(recording.lat_deg, recording.lon_deg)
    north = plane.north_azimuth_rad(recording.lat_deg, recording.lon_deg)
    t0 = float(recording.fix_t[0])
    fix_t = recording.fix_t - t0
    streams = {name: (t - t0, v) for name, (t, v) in recording.streams.items()}
    heading_t, heading = streams[_HEADING]
    streams[_HEADING] = (heading_t, np.unwrap(heading))

    pieces, gaps = _coverage(fix_t, options.max_gap_s)
    all_gaps = list(gaps)
    _note_gaps(_FIXES, gaps, options.max_gap_s, notes)
    for name, (times, _) in streams.items():
        covered, gaps = _coverage(times, options.max_gap_s)
        _note_gaps(name, gaps, options.max_gap_s, notes)
        all_gaps += gaps
        pieces = _intersect(pieces, _stretch(covered, times, fix_t, options))
        late, early = float(times[0]), float(fix_t[-1] - times[-1])
        if late > options.max_gap_s:
            notes.append(f"{name} starts {late:.1f} s after the first fix")
        if early > options.max_gap_s:
            notes.append(f"{name} ends {early:.1f} s before the last fix")

    kept: list[_FloatArray] = []
    for start, end in pieces:
        time = _time_base(start, end, fix_t, options.rate_hz)
        if time.size < options.min_samples:
            notes.append(
                f"dropped t = {start:.1f} to {end:.1f} s: {time.size} samples, fewer than "
                f"min_samples = {options.min_samples}"
            )
        else:
            kept.append(time)

    time_origin = None
    if recording.epoch is not None:
        instant = recording.epoch + dt.timedelta(seconds=t0)
        time_origin = instant.isoformat(timespec="milliseconds").replace("+00:00", "Z")
    logs = []
    extrapolated = dict.fromkeys(streams, 0.0)
    for k, time in enumerate(kept, start=1):
        sampled = {}
        for name, (times, values) in streams.items():
            sampled[name], farthest = _resample(time, times, values, options.max_gap_s)
            extrapolated[name] = max(extrapolated[name], farthest)
        heading = sampled[_HEADING] + np.interp(time, fix_t, north)
        heading -= 2.0 * np.pi * np.floor(heading[0] / (2.0 * np.pi))  # start in [0, 2π)
        piece = f"piece {k} of {len(kept)}"
        metadata = _metadata(
            recording, options, plane, time_origin, piece, float(time[0]), float(time[-1])
        )
        logs.append(
            ManeuverLog(
                time_s=time,
                x_m=np.interp(time, fix_t, x_m),
                y_m=np.interp(time, fix_t, y_m),
                heading_rad=heading,
                rudder_rad=sampled[_RUDDER],
                n_rps=sampled[_RPM],
                metadata=metadata,
            )
        )
    if any(extrapolated.values()):
        base = "fix" if options.rate_hz is None else "grid time"
        amounts = ", ".join(
            f"{name} by up to {farthest:.3g} s"
            for name, farthest in extrapolated.items()
            if farthest
        )
        notes.append(
            f"extrapolated linearly to the {base} just before a stream's first or after its "
            f"last sample (within one of its sample intervals): {amounts}"
        )
    return ConversionResult(
        logs=tuple(logs),
        skipped_lines=recording.skipped_lines,
        checksum_failures=recording.checksum_failures,
        gaps=tuple(_merge(all_gaps)),
        notes=tuple(notes),
        origin_lat_deg=plane.origin_lat_deg,
        origin_lon_deg=plane.origin_lon_deg,
        time_origin_utc=time_origin,
        path=path,
    )


def _note_gaps(
    name: str, gaps: Sequence[tuple[float, float]], max_gap_s: float, notes: list[str]
) -> None:
    for start, end in gaps:
        notes.append(
            f"gap: no {name} for {end - start:.1f} s (t = {start:.1f} to {end:.1f} s, "
            f"more than max_gap_s = {max_gap_s:g} s): split there"
        )


def _metadata(
    recording: _Recording,
    options: _Options,
    plane: TangentPlane,
    time_origin: str | None,
    piece: str,
    start: float,
    end: float,
) -> dict[str, str]:
    """Return the ``# key: value`` lines of one converted log."""
    skipped = ""
    if recording.kind.startswith("NMEA"):
        skipped = (
            f"; {recording.skipped_lines} unparsable lines and "
            f"{recording.checksum_failures} checksum failures skipped"
        )
    source = (
        f"{_one_line(os.path.basename(recording.path))} ({recording.kind}), {piece}, "
        f"t = {start:.3f} to {end:.3f} s after the first fix; origin = first fix "
        f"{plane.origin_lat_deg:.7f} deg, {plane.origin_lon_deg:.7f} deg, x North y East "
        f"in an azimuthal equidistant plane on WGS84; heading from true North to the plane's "
        f"x axis; rudder positive to {options.rudder_positive} in the input{skipped}"
    )
    metadata: dict[str, str] = {}
    if options.vessel is not None:
        metadata["vessel"] = options.vessel
    if options.length_m is not None:
        metadata["length_m"] = repr(options.length_m)
    metadata["source"] = source
    metadata["origin_lat_deg"] = repr(plane.origin_lat_deg)
    metadata["origin_lon_deg"] = repr(plane.origin_lon_deg)
    if time_origin is not None:
        metadata["time_origin_utc"] = time_origin
    metadata["projection"] = plane.proj_string
    return metadata


# --------------------------------------------------------------------------- command line


def _vessel(text: str) -> str:
    if not text.strip() or text != text.strip() or any(c in text for c in "\r\n\0"):
        raise argparse.ArgumentTypeError(f"expected a one-line name, got {text!r}")
    return text


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
            "Convert NMEA 0183 (GGA/RMC/ZDA, HDT/THS, RSA, RPM) or latitude/longitude CSV "
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
    convert.add_argument("--length-m", type=argtypes.positive, help="ship length [m]")
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
        "--rate-hz", type=argtypes.positive, help="resample at this rate [Hz] (default: fix times)"
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
        "--shaft", type=argtypes.count(0), help="NMEA RPM shaft number (default: the only one)"
    )
    convert.add_argument(
        "--allow-missing-checksum",
        action="store_true",
        help="use NMEA sentences without a '*hh' checksum (default: skip them)",
    )
    convert.add_argument("--quiet", action="store_true", help="no notes, no 'wrote' lines")
    return convert


def main(args: argparse.Namespace) -> int:
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
        print(f"error: -o {output}: expected a directory for several inputs", file=sys.stderr)
        return 2
    if len(set(stems)) < len(stems):
        twice = sorted({stem for stem in stems if stems.count(stem) > 1})
        print(
            f"error: inputs share the name {twice[0]!r}: convert them separately", file=sys.stderr
        )
        return 2
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
                shaft=args.shaft,
                require_checksum=not args.allow_missing_checksum,
            )
            if not result.logs:
                raise LogFormatError(
                    f"no log written: every piece has fewer than {args.min_samples} samples "
                    "(see the notes; lower --min-samples or raise --max-gap-s)",
                    path=path,
                    expected=f"a piece of at least {args.min_samples} samples",
                )
            results.append(result)
    except LogFormatError as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
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
    except OSError as error:
        print(f"error: {error.filename or ''}: {error.strerror or error}", file=sys.stderr)
        return 1
    return 0
