"""The latitude/longitude CSV reader: rows in, each sensor stream with its own times out.

:func:`read_latlon_csv` makes the :class:`~identifier.ingest.recording.Recording`
that :func:`~identifier.ingest.convert_latlon_csv` (and
:func:`~identifier.ingest.convert_file`) assembles into trial logs.

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

The rpm column may be left out where the recording has no propeller speed: the
conversion then needs the trial's constant one (``constant_n_rps``, ``identifier convert
--rpm``).

Every row needs a time, strictly increasing; any other cell may be empty (that
sensor has no sample at that time), so streams at different rates can share one
file. A heading may be wrapped or continuous, within ±36000 deg (100 turns); a
rudder angle is within ±90 deg. Latitude and longitude are given together or not at
all. Unlike NMEA, a malformed CSV cell is an error (a CSV file comes from a program,
not a noisy line): :class:`~trials.errors.LogFormatError` with file, line and
column.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass
from typing import Final

import numpy as np

from identifier.ingest.recording import (
    FIXES,
    HEADING,
    RPM,
    RUDDER,
    SECONDS_PER_MINUTE,
    HeadingUnit,
    Recording,
)
from trials.errors import LogFormatError
from trials.logs import MAX_HEADING_DEG, MAX_RPM, MAX_RUDDER_DEG, MAX_TIME_S
from trials.text_input import NUMBER, decode_utf8, show, split_fields

__all__ = ["LAT_COLUMNS", "LON_COLUMNS", "read_latlon_csv"]

LAT_COLUMNS: Final = ("lat_deg", "lat", "latitude")
"""Accepted names of the latitude column."""
LON_COLUMNS: Final = ("lon_deg", "lon", "longitude")
"""Accepted names of the longitude column."""

_TIME_COLUMNS: Final = ("time_s", "time")
_HEADING_COLUMNS: Final = ("heading_deg", "heading_rad", "heading")
_RUDDER_COLUMNS: Final = ("rudder_deg", "rudder_rad")
_RPM_COLUMNS: Final = ("rpm",)

_MAX_HEADING_RAD: Final = math.radians(MAX_HEADING_DEG)  # the trial log's bounds
_MAX_RUDDER_RAD: Final = math.radians(MAX_RUDDER_DEG)


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
    rpm: int | None  # None: no rpm column (identifier convert --rpm gives a constant)
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
        lat=one(LAT_COLUMNS, "latitude")[0],
        lon=one(LON_COLUMNS, "longitude")[0],
        heading=heading,
        heading_scale=1.0 if unit == "rad" else math.pi / 180.0,
        rudder=rudder,
        rudder_scale=1.0 if rudder_name == "rudder_rad" else math.pi / 180.0,
        rpm=one(_RPM_COLUMNS, "propeller speed")[0] if set(_RPM_COLUMNS) & set(names) else None,
        n_fields=len(names),
    )


def _split_csv(line: str, number: int, path: str) -> list[str]:
    fields = split_fields(line)
    if fields is None:
        raise LogFormatError(
            f"expected comma-separated fields, got malformed quoting in {show(line)}",
            path=path,
            line=number,
            expected="comma-separated fields",
        )
    return fields


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
            name: ([], []) for name in (FIXES, "lon", HEADING, RUDDER, RPM)
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
        value = float(text) if NUMBER.fullmatch(text) else math.nan
        if not (math.isfinite(value) and low <= value <= high):
            limits = "" if math.isinf(low) else f" within [{low:g}, {high:g}]"
            raise self.error(
                f"expected a finite number{limits}, got {show(text)}",
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
            value = self.number(fields, columns.time, number, -MAX_TIME_S, MAX_TIME_S)
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
                f"expected strictly increasing time, got {show(time_text)} after the time on "
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
        rpm = (
            None if columns.rpm is None else self.number(fields, columns.rpm, number, 0.0, MAX_RPM)
        )
        samples = (
            (FIXES, lat, 1.0),
            ("lon", lon, 1.0),
            (HEADING, heading, columns.heading_scale),
            (RUDDER, rudder, self.rudder_sign * columns.rudder_scale),
            (RPM, rpm, 1.0 / SECONDS_PER_MINUTE),
        )
        for name, sample, scale in samples:
            if sample is not None:
                self.rows[name][0].append(time)
                self.rows[name][1].append(sample * scale)

    def finish(self) -> Recording:
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
        return Recording(
            path=self.path,
            kind="latitude/longitude CSV",
            fix_t=arrays[FIXES][0],
            lat_deg=arrays[FIXES][1],
            lon_deg=arrays["lon"][1],
            streams={name: arrays[name] for name in (HEADING, RUDDER, RPM)},
            sources={
                HEADING: "rows with a heading",
                RUDDER: "rows with a rudder angle",
                RPM: "an rpm column" if self.columns.rpm is None else "rows with an rpm",
            },
            epoch=self.first_iso,
            notes=[] if self.first_iso else ["time_s column: time_origin_utc unknown"],
        )


def read_latlon_csv(
    path: str, raw: bytes, rudder_sign: float, heading_unit: HeadingUnit | None
) -> Recording:
    """Read a latitude/longitude CSV file into streams (rules in the module docstring).

    Parameters
    ----------
    path : str
        The file, for messages and the recording.
    raw : bytes
        Its content.
    rudder_sign : float
        +1 to keep the file's rudder sign, -1 to flip it.
    heading_unit : {"deg", "rad"} or None
        Unit of a ``heading`` column (None: degrees, or from the column name).

    Returns
    -------
    Recording
        The fixes [deg] and the heading [rad], rudder [rad] and rpm [rev/s] streams.

    Raises
    ------
    LogFormatError
        On the first malformed line or cell (file, line and column in it).
    ValueError
        If ``heading_unit`` is not one of the above.

    """
    if heading_unit not in (None, "deg", "rad"):
        raise ValueError(f"heading_unit must be 'deg', 'rad' or None, got {heading_unit!r}")
    reader = _CsvReader(path, rudder_sign, heading_unit)
    for number, line in enumerate(decode_utf8(raw, path).split("\n"), start=1):
        reader.feed(number, line)
    return reader.finish()


def _iso_time(text: str, path: str, line: int, column: str) -> dt.datetime:
    """Parse an ISO 8601 date and time into an aware UTC datetime (no offset: UTC)."""
    try:
        stamp = dt.datetime.fromisoformat(text)
    except ValueError:
        raise LogFormatError(
            f"expected an ISO 8601 date and time like '2024-05-17T23:58:30.25Z', got "
            f"{show(text) if text else 'an empty field'}",
            path=path,
            line=line,
            column=column,
            expected="an ISO 8601 date and time",
        ) from None
    if stamp.tzinfo is None:
        return stamp.replace(tzinfo=dt.UTC)
    return stamp.astimezone(dt.UTC)
