"""Read, validate and write trial logs (DESIGN.md, "Trial-log CSV").

A trial log is one manoeuvre in a UTF-8 text file::

    # vessel: kvlcc2
    # length_m: 320.0
    # source: scenarios.synthesize zigzag-10, seed 1
    time_s,x_m,y_m,heading_deg,rudder_deg,rpm
    0.0,0.0,0.0,0.0,0.0,46.2
    0.5,3.9,0.0,0.0,1.1,46.2
    ...

Rules, applied by :func:`read_log` and :func:`parse_log`:

- Before the header, blank lines and lines starting with ``#`` are allowed. A line
  ``# key: value`` (key: a letter or ``_`` followed by letters, digits, ``_``, ``.``
  or ``-``) becomes ``metadata[key] = value`` with surrounding whitespace removed;
  other ``#`` lines are free comments and are ignored. A key may appear only once.
  ``length_m``, if present, must be a ship length from 0.1 to 1000 m (the FMU's
  bounds), and ``vessel`` printable text (it becomes the FMU's name).
- The header names the columns; ``time_s, x_m, y_m, heading_deg, rudder_deg, rpm``
  must all be present, in any order. The optional columns (:data:`OPTIONAL_COLUMNS`)
  may be present, each once; other columns are ignored (their cells are not checked).
  Names are case-sensitive; whitespace around names is ignored.
- The separator is ``,`` only. A semicolon-, tab- or space-separated file (as some
  spreadsheets write with a decimal comma) is rejected with an error that names
  the expected ``','`` separator: guessing the separator would also mean guessing
  the decimal mark.
- Every data row has as many fields as the header. Each cell of a required column,
  and of an optional column that is present, is a plain decimal number (``12``,
  ``-0.5``, ``1.5e-3``; whitespace around it is ignored) and finite: ``nan``,
  ``inf``, empty cells, text and values that overflow (``1e999``) are rejected. One
  exception: an optional column's empty or ``nan`` cells (any case: what a logger writes
  for a missing value) are its sensor's dropout, filled by
  linear interpolation in time between the column's values around it (the wind angle
  on the shorter way round; at the log's ends the nearest value) when the dropout lasts
  at most :data:`MAX_DROPOUT_S`, and counted in :attr:`ManeuverLog.filled`.
- Plausibility bounds, so that no value overflows the arithmetic downstream:
  ``|time_s|`` ≤ :data:`MAX_TIME_S`, ``|x_m|`` and ``|y_m|`` ≤ :data:`MAX_POSITION_M`,
  ``|heading_deg|`` ≤ :data:`MAX_HEADING_DEG`, ``|rudder_deg|`` ≤
  :data:`MAX_RUDDER_DEG`, and ``rpm`` from 0 to :data:`MAX_RPM` (astern, a negative
  rpm, cannot be identified by these models); when present, ``wind_speed_mps`` from 0
  to :data:`MAX_WIND_SPEED_MPS`, ``|wind_angle_deg|`` ≤ :data:`MAX_WIND_ANGLE_DEG`,
  ``stw_mps`` from 0 to :data:`MAX_STW_MPS` and ``|stw_transverse_mps|`` ≤
  :data:`MAX_STW_MPS`; ``stw_transverse_mps`` only beside ``stw_mps``.
- ``time_s`` increases strictly (irregular sampling is fine), without a step longer
  than the rest of the log together (two runs in one file: split it there); at least
  :data:`MIN_SAMPLES` rows.
- Blank lines are allowed at the end only; ``#`` lines only before the header.
- UTF-8 with or without a byte-order mark, LF or CRLF line endings. Anything that
  is not UTF-8 text (NUL bytes, invalid UTF-8, UTF-16) is "not a text file".
- ``heading_deg`` may be wrapped (0..360) or continuous: it is unwrapped on reading
  (``trials.angles.unwrap_heading``: ``numpy.unwrap``, but after a step of a third of a
  turn the next samples on the turn nearest the median of the five before, so that
  compass spikes leave no whole turn behind), and a heading change of half a turn or
  more within three samples cannot be represented.

Optional columns, what the ship's own sensors measured (an NMEA recording gives them
from MWV and VHW/VBW sentences):

- ``wind_speed_mps``: the apparent (relative) wind speed, as an anemometer on board
  measures it: the air's velocity relative to the moving ship [m/s].
- ``wind_angle_deg``: the apparent wind's angle relative to the bow, the direction the
  wind comes **from**: 0 = from ahead, positive from starboard (90 = on the starboard
  beam, 180 = from astern, 270 or -90 = on the port beam) [deg]. Wrapped (0..360) or
  not; it is read as it is (converted to radians, not unwrapped).
- ``stw_mps``: speed through the water along the ship (forward) from a speed log [m/s].
- ``stw_transverse_mps``: speed through the water across the ship, positive to
  starboard, from a two-axis (Doppler or electromagnetic) log [m/s], as NMEA VBW's
  transverse water speed; only with ``stw_mps``, the same log's other axis. Measured
  where the log's transducer is: give its position in the metadata ``speed_log_x_m``
  (metres forward of midship, the models' origin; within ±:data:`MAX_ON_BOARD_M`), as
  a turn's yaw rate adds x·r to the sway speed there.

Positions on board (metadata, metres from midship, the models' origin; within
±:data:`MAX_ON_BOARD_M`): ``speed_log_x_m`` above, and ``gnss_x_m`` (forward), ``gnss_y_m``
(to starboard), the GNSS antenna's: ``x_m``, ``y_m`` are then the antenna's positions,
which :func:`at_midship` reduces to the midship point's (a bridge antenna 0.4 L aft of a
tanker's midship moves 1.5 m/s sideways more than midship in a hard turn).

Every violation raises :class:`~trials.errors.LogFormatError` with the file,
the 1-based line number (None for whole-file problems), the column where one
applies and what was expected. Inside the program all quantities are SI and
radians; degrees and rpm exist only in the file.
"""

from __future__ import annotations

import datetime as dt
import math
import os
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType
from typing import Final

import numpy as np
import numpy.typing as npt

from fmu_model.atomic import write_atomic
from fmu_model.interface import MAX_LENGTH_M, MAX_PROPELLER_RPM, MIN_LENGTH_M
from fmu_model.interface import MAX_POSITION_M as MAX_POSITION_M_FMU
from fmu_model.params import text_problem
from trials.angles import unwrap_heading
from trials.errors import LogFormatError
from trials.text_input import NUMBER, decode_utf8, read_bytes, show, split_fields

__all__ = [
    "LOG_COLUMNS",
    "MAX_DROPOUT_S",
    "MAX_HEADING_DEG",
    "MAX_ON_BOARD_M",
    "MAX_POSITION_M",
    "MAX_RPM",
    "MAX_RUDDER_DEG",
    "MAX_STW_MPS",
    "MAX_TIME_S",
    "MAX_WIND_ANGLE_DEG",
    "MAX_WIND_SPEED_MPS",
    "MIN_SAMPLES",
    "ON_BOARD_KEYS",
    "OPTIONAL_COLUMNS",
    "ManeuverLog",
    "at_midship",
    "format_log",
    "log_piece",
    "on_board_offset",
    "parse_log",
    "read_log",
    "write_log",
]

MIN_SAMPLES: Final = 10
"""Fewest data rows a log may have.

The smoother fits a constant-acceleration model (three states per axis) and the
EKF then estimates velocities and several model coefficients from its output: with
fewer than about ten samples there is no redundancy left to tell signal from noise,
and no room for an approach, a rudder execute and a response. A shorter file is
almost always a truncated or mis-exported one, so it is rejected at reading with a
clear message rather than failing obscurely later. Passing this floor does not mean
a log is informative enough; the identification judges that.
"""

LOG_COLUMNS: Final = ("time_s", "x_m", "y_m", "heading_deg", "rudder_deg", "rpm")
"""The required columns of a trial log, in the order :func:`format_log` writes them."""

OPTIONAL_COLUMNS: Final = ("wind_speed_mps", "wind_angle_deg", "stw_mps", "stw_transverse_mps")
"""The optional columns of a trial log, in the order :func:`format_log` writes them
(after :data:`LOG_COLUMNS`, each only when the log has it)."""

MAX_TIME_S: Final = 1.0e10
"""Largest ``|time_s|`` [s]: about 317 years, so that Unix or GPS time in seconds fits,
and milliseconds since 1970 (1.7e12) do not."""
MAX_POSITION_M: Final = MAX_POSITION_M_FMU
"""Largest ``|x_m|``, ``|y_m|`` [m]: 2.5 times the Earth's circumference (the FMU's bound
of x0, y0), so that UTM northings fit."""
MAX_HEADING_DEG: Final = 36000.0
"""Largest ``|heading_deg|``: a continuous heading of up to 100 turns."""
MAX_RUDDER_DEG: Final = 90.0
"""Largest ``|rudder_deg|``: no rudder turns further."""
MAX_RPM: Final = MAX_PROPELLER_RPM
"""Largest ``rpm``, the FMU's input bound (100 rev/s: no ship propeller turns faster).
The least is 0: the models have no astern-propeller terms, so astern running cannot be
identified or validated."""
MAX_WIND_SPEED_MPS: Final = 100.0
"""Largest ``wind_speed_mps`` [m/s]: above any recorded gust at sea (hurricane force
is 33 m/s); the least is 0."""
MAX_WIND_ANGLE_DEG: Final = 36000.0
"""Largest ``|wind_angle_deg|``, as for the heading: 100 turns."""
MAX_ON_BOARD_M: Final = MAX_LENGTH_M / 2.0
"""Largest position on board from midship (:data:`ON_BOARD_KEYS`) [m]: half the longest
ship a log may be of."""
ON_BOARD_KEYS: Final = MappingProxyType(
    {
        "speed_log_x_m": "the speed log's position forward of midship",
        "gnss_x_m": "the GNSS antenna's position forward of midship",
        "gnss_y_m": "the GNSS antenna's position to starboard of the centre line",
    }
)
"""Metadata keys of positions on board [m] from midship (forward, starboard)."""
MAX_STW_MPS: Final = 50.0
"""Largest ``stw_mps`` [m/s] (97 kn: no displacement ship is faster); the least is 0.
Also the bound of ``|stw_transverse_mps|``."""

MAX_DROPOUT_S: Final = 5.0
"""Longest dropout of an optional column's sensor (its empty or NaN cells) the reader fills [s],
from the last value before to the first after (or to the log's end): the longest gap of
a stream ``identifier convert`` resamples across by default (``--max-gap-s``)."""

_SEPARATOR: Final = ","
_OTHER_SEPARATORS: Final = ((";", "';'"), ("\t", "a tab"), ("|", "'|'"))
_METADATA_KEY: Final = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*", re.ASCII)
_METADATA_LINE: Final = re.compile(r"#\s*([A-Za-z_][A-Za-z0-9_.\-]*)\s*:(.*)", re.ASCII)
_MAX_SHOWN_HEADER_CHARS: Final = 160
_SECONDS_PER_MINUTE: Final = 60.0
_NMEA_HINT: Final = (
    " (an NMEA recording? convert it first: python -m identifier convert FILE -o DIR)"
)

# Plausibility bounds of the required columns: (least, largest, what the column holds).
_BOUNDS: Final = {
    "time_s": (-MAX_TIME_S, MAX_TIME_S, f"a time within ±{MAX_TIME_S:g} s"),
    "x_m": (-MAX_POSITION_M, MAX_POSITION_M, f"a position within ±{MAX_POSITION_M:g} m"),
    "y_m": (-MAX_POSITION_M, MAX_POSITION_M, f"a position within ±{MAX_POSITION_M:g} m"),
    "heading_deg": (
        -MAX_HEADING_DEG,
        MAX_HEADING_DEG,
        f"a heading within ±{MAX_HEADING_DEG:g} deg (100 turns)",
    ),
    "rudder_deg": (
        -MAX_RUDDER_DEG,
        MAX_RUDDER_DEG,
        f"a rudder angle within ±{MAX_RUDDER_DEG:g} deg",
    ),
    "rpm": (0.0, MAX_RPM, f"a propeller speed from 0 to {MAX_RPM:g} rpm"),
    "wind_speed_mps": (
        0.0,
        MAX_WIND_SPEED_MPS,
        f"a wind speed from 0 to {MAX_WIND_SPEED_MPS:g} m/s",
    ),
    "wind_angle_deg": (
        -MAX_WIND_ANGLE_DEG,
        MAX_WIND_ANGLE_DEG,
        f"a wind angle within ±{MAX_WIND_ANGLE_DEG:g} deg (100 turns)",
    ),
    "stw_mps": (0.0, MAX_STW_MPS, f"a speed through the water from 0 to {MAX_STW_MPS:g} m/s"),
    "stw_transverse_mps": (
        -MAX_STW_MPS,
        MAX_STW_MPS,
        f"a transverse speed through the water within ±{MAX_STW_MPS:g} m/s",
    ),
}
# ManeuverLog's arrays: the required ones, and the optional ones in the order of
# OPTIONAL_COLUMNS.
_REQUIRED_FIELDS: Final = ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps")
_OPTIONAL_FIELDS: Final = ("wind_speed_mps", "wind_angle_rad", "stw_mps", "stw_transverse_mps")
_ASTERN_HINT: Final = (
    " (astern: the models have no astern-propeller terms, so astern running cannot be "
    "identified; cut it out of the log)"
)

_FloatArray = npt.NDArray[np.float64]


def _empty_metadata() -> Mapping[str, str]:
    return MappingProxyType({})


@dataclass(frozen=True, eq=False)
class ManeuverLog:
    """One manoeuvre's trial log, in SI units and radians.

    The arrays are stored as read-only float64 copies; compare logs with numpy
    (``np.array_equal``), not ``==`` (which is identity).

    Parameters
    ----------
    time_s : numpy.ndarray
        Sample times [s], float64, finite and strictly increasing.
    x_m : numpy.ndarray
        Position North of the origin [m].
    y_m : numpy.ndarray
        Position East of the origin [m].
    heading_rad : numpy.ndarray
        Heading ψ, clockwise from North [rad], continuous (unwrapped on reading).
    rudder_rad : numpy.ndarray
        Actual rudder angle [rad], positive turns the ship to starboard.
    n_rps : numpy.ndarray
        Propeller speed [rev/s] (the file holds rpm).
    metadata : Mapping[str, str]
        The file's ``# key: value`` lines, in file order, e.g. ``{"vessel":
        "kvlcc2", "length_m": "320.0", "source": "..."}``. Stored as a read-only
        mapping. Keys as described in the module docstring; values single-line,
        without NUL and without leading or trailing whitespace, so that
        :func:`format_log` can write them back unchanged.
    path : str or None
        File the log was read from, used in error messages; None if built in memory.
    wind_speed_mps : numpy.ndarray or None
        Apparent wind speed measured on board [m/s] (column ``wind_speed_mps``); None
        when the log has no such column.
    wind_angle_rad : numpy.ndarray or None
        Apparent wind angle relative to the bow, the direction the wind comes from: 0
        from ahead, positive from starboard [rad] (column ``wind_angle_deg``, not
        unwrapped); None when absent.
    stw_mps : numpy.ndarray or None
        Speed through the water along the ship from a speed log [m/s] (column
        ``stw_mps``); None when absent.
    stw_transverse_mps : numpy.ndarray or None
        Speed through the water across the ship, positive to starboard, from the same
        log's transverse axis [m/s] (column ``stw_transverse_mps``); None when absent, and
        only with ``stw_mps``.
    filled : Mapping[str, int]
        How many empty or NaN cells of each optional column (by column name, e.g.
        ``"stw_mps"``) the reader filled: a sensor's dropout (module docstring).

    Raises
    ------
    ValueError
        If an array is not one-dimensional, not real-valued, not finite, the arrays
        (the optional ones too, when given) differ in length, time does not increase
        strictly, ``stw_transverse_mps`` comes without ``stw_mps``, or the metadata
        cannot be written back (internal invariant: a log read from a file always
        satisfies it).

    """

    time_s: _FloatArray
    x_m: _FloatArray
    y_m: _FloatArray
    heading_rad: _FloatArray
    rudder_rad: _FloatArray
    n_rps: _FloatArray
    metadata: Mapping[str, str] = field(default_factory=_empty_metadata)
    path: str | None = None
    wind_speed_mps: _FloatArray | None = None
    wind_angle_rad: _FloatArray | None = None
    stw_mps: _FloatArray | None = None
    stw_transverse_mps: _FloatArray | None = None
    filled: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.stw_transverse_mps is not None and self.stw_mps is None:
            raise ValueError("ManeuverLog stw_transverse_mps needs stw_mps (a two-axis log)")
        present = tuple(name for name in _OPTIONAL_FIELDS if getattr(self, name) is not None)
        names = _REQUIRED_FIELDS + present
        for name in names:
            object.__setattr__(self, name, _frozen_float_array(name, getattr(self, name)))
        lengths = {name: len(getattr(self, name)) for name in names}
        if len(set(lengths.values())) > 1:
            raise ValueError(f"ManeuverLog arrays differ in length: {lengths}")
        steps = np.diff(self.time_s)
        if np.any(steps <= 0.0):
            index = int(np.flatnonzero(steps <= 0.0)[0]) + 1
            raise ValueError(
                f"ManeuverLog time_s must increase strictly; sample {index} "
                f"({float(self.time_s[index])!r} s) follows {float(self.time_s[index - 1])!r} s"
            )
        object.__setattr__(self, "metadata", _frozen_metadata(self.metadata))
        object.__setattr__(self, "filled", MappingProxyType(dict(self.filled)))
        if self.path is not None:
            object.__setattr__(self, "path", os.fspath(self.path))

    @property
    def n_samples(self) -> int:
        """Number of samples (rows) in the log."""
        return len(self.time_s)

    @property
    def length_m(self) -> float | None:
        """Ship length from the ``length_m`` metadata [m], or None when absent.

        Raises
        ------
        LogFormatError
            If ``length_m`` is present but not a positive finite number.

        """
        text = self.metadata.get("length_m")
        if text is None:
            return None
        return _parse_length_m(text, path=self.path, line=None)

    @property
    def time_origin_utc(self) -> dt.datetime | None:
        """The UTC time of ``time_s`` = 0 from the ``time_origin_utc`` metadata, or None.

        ``identifier convert`` writes it (ISO 8601, e.g. ``2024-05-17T23:58:30.000Z``).

        Raises
        ------
        LogFormatError
            If it is present but not an ISO 8601 time with its UTC offset.

        """
        text = self.metadata.get("time_origin_utc")
        return None if text is None else _parse_time_origin(text, self.path, None)

    def on_board_m(self, key: str) -> float | None:
        """Return a position on board from the metadata [m] (:data:`ON_BOARD_KEYS`).

        ``speed_log_x_m``: where a two-axis log measures the transverse speed
        (``stw_transverse_mps``; there the sway speed is v + x·r); ``gnss_x_m``,
        ``gnss_y_m``: where the positions ``x_m``, ``y_m`` are measured (:func:`at_midship`).
        None when absent.

        Raises
        ------
        LogFormatError
            If the key is present but not a number within ±:data:`MAX_ON_BOARD_M`.

        """
        if key not in ON_BOARD_KEYS:
            raise ValueError(f"key must be one of {sorted(ON_BOARD_KEYS)}, got {key!r}")
        text = self.metadata.get(key)
        return None if text is None else _parse_on_board(key, text, self.path, None)


def read_log(path: str | os.PathLike[str]) -> ManeuverLog:
    """Read and validate a trial-log CSV file.

    Parameters
    ----------
    path : str or os.PathLike
        The trial log, in the format described in this module's docstring.

    Returns
    -------
    ManeuverLog
        Times [s], positions [m], unwrapped heading [rad], rudder angle [rad],
        propeller speed [rev/s], the ``# key: value`` metadata, and ``path``.

    Raises
    ------
    LogFormatError
        If the file cannot be read, is not UTF-8 text, or breaks any rule of the
        format; the message names the file, the line and, where one applies, the
        column.

    """
    name = os.fspath(path)
    raw = read_bytes(name, "trial log")
    return parse_log(decode_utf8(raw, name, _binary_hint(raw, name)), path=name)


def parse_log(text: str, path: str | os.PathLike[str] | None = None) -> ManeuverLog:
    """Parse and validate the text of a trial log.

    :func:`read_log` without the file access; the inverse of :func:`format_log`.

    Parameters
    ----------
    text : str
        The whole log (a leading byte-order mark, if any, already removed).
    path : str or os.PathLike or None
        Name used in error messages and stored in the result.

    Returns
    -------
    ManeuverLog
        As for :func:`read_log`.

    Raises
    ------
    LogFormatError
        If the text breaks any rule of the format.

    """
    name = None if path is None else os.fspath(path)
    parser = _Parser(name)
    for number, line in enumerate(text.split("\n"), start=1):
        parser.feed(number, line.removesuffix("\r"))
    return parser.finish()


def at_midship(log: ManeuverLog) -> ManeuverLog:
    """Return ``log`` with its positions at midship, where the models' are.

    A log whose metadata places the GNSS antenna at (``gnss_x_m`` forward, ``gnss_y_m`` to
    starboard) of midship holds the antenna's track; midship is

        x = x_A − (a_x cos ψ − a_y sin ψ),   y = y_A − (a_x sin ψ + a_y cos ψ)

    (x North, y East, ψ the logged heading: the antenna's offset turned from the ship's
    axes to North-East). A compass spike moves that sample's position with it (an offset
    of 130 m and a 5° spike: 11 m), which the smoother's gate then rejects as well. The
    keys leave the metadata, so that the result, written back, is read as the midship
    track it is. Without the keys (or with zeros) the log itself.
    """
    a_x, a_y = (log.on_board_m(key) or 0.0 for key in ("gnss_x_m", "gnss_y_m"))
    if a_x == 0.0 and a_y == 0.0:
        return log
    north_m, east_m = on_board_offset(a_x, a_y, log.heading_rad)
    return replace(
        log,
        x_m=log.x_m - north_m,
        y_m=log.y_m - east_m,
        metadata={k: v for k, v in log.metadata.items() if k not in ("gnss_x_m", "gnss_y_m")},
    )


def log_piece(log: ManeuverLog, start: int, stop: int) -> ManeuverLog:
    """Return samples ``start`` to ``stop`` − 1 of ``log`` (every column; the metadata kept).

    Times as they are in ``log`` (so that its ``time_origin_utc`` holds for the piece).

    Raises
    ------
    ValueError
        If the piece is not a non-empty range of the log's samples.

    """
    if not 0 <= start < stop <= log.n_samples:
        raise ValueError(f"a piece within samples 0 to {log.n_samples}, got {start} to {stop}")
    return replace(
        log,
        **{
            name: getattr(log, name)[start:stop]
            for name in (*_REQUIRED_FIELDS, *_OPTIONAL_FIELDS)
            if getattr(log, name) is not None
        },
    )


def on_board_offset(
    forward_m: float, starboard_m: float, heading_rad: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Return a point on board's offset from midship, North and East [m], at ``heading_rad``.

    (a_x cos ψ − a_y sin ψ, a_x sin ψ + a_y cos ψ): the body-axis offset (a_x forward,
    a_y to starboard) turned to North-East by the heading ψ. :func:`at_midship` takes it
    off a GNSS antenna's track; ``scenarios.synthesize`` puts it on.
    """
    cos_psi, sin_psi = np.cos(heading_rad), np.sin(heading_rad)
    return forward_m * cos_psi - starboard_m * sin_psi, forward_m * sin_psi + starboard_m * cos_psi


def format_log(log: ManeuverLog) -> str:
    """Return the CSV text of a trial log: metadata lines, header, one row per sample.

    Columns are written in the order of :data:`LOG_COLUMNS`, then those of
    :data:`OPTIONAL_COLUMNS` the log has (its field is not None), with degrees and rpm,
    and every value with Python's shortest round-trip ``repr``, so that
    ``parse_log(format_log(log))`` gives back time and positions exactly and
    heading, rudder and propeller speed to within a few units in the last place
    (the degree and rpm conversions round). Lines end with LF.

    Parameters
    ----------
    log : ManeuverLog
        The log to write. Its heading is written as is (continuous); a heading
        change of π or more between consecutive samples does not survive reading,
        which unwraps the heading.

    Returns
    -------
    str
        The file content, ending with a newline.

    Raises
    ------
    ValueError
        If a value overflows when converted to degrees or rpm (|value| ~ 1e306).

    """
    with np.errstate(over="ignore"):  # reported below as a ValueError
        columns = {
            "time_s": log.time_s,
            "x_m": log.x_m,
            "y_m": log.y_m,
            "heading_deg": np.rad2deg(log.heading_rad),
            "rudder_deg": np.rad2deg(log.rudder_rad),
            "rpm": log.n_rps * _SECONDS_PER_MINUTE,
        }
        angle = None if log.wind_angle_rad is None else np.rad2deg(log.wind_angle_rad)
    optional = (
        ("wind_speed_mps", log.wind_speed_mps),
        ("wind_angle_deg", angle),
        ("stw_mps", log.stw_mps),
        ("stw_transverse_mps", log.stw_transverse_mps),
    )
    columns.update((name, values) for name, values in optional if values is not None)
    for column, values in columns.items():
        if not np.all(np.isfinite(values)):
            raise ValueError(f"column {column!r} overflows when converted to file units")
    lines = [f"# {key}: {value}".rstrip() for key, value in log.metadata.items()]
    lines.append(_SEPARATOR.join(columns))
    rows = zip(*(values.tolist() for values in columns.values()), strict=True)
    lines.extend(_SEPARATOR.join(map(repr, row)) for row in rows)
    return "\n".join(lines) + "\n"


def write_log(path: str | os.PathLike[str], log: ManeuverLog) -> None:
    """Write a trial log atomically (:func:`format_log` + :func:`write_atomic`).

    Parameters
    ----------
    path : str or os.PathLike
        Target file; parent directories are created, a previous file is replaced
        only once the new one is completely on disk.
    log : ManeuverLog
        The log to write.

    Raises
    ------
    ValueError
        As for :func:`format_log`; nothing is written.
    OSError
        If the file cannot be written; a previous file is left untouched.

    """
    write_atomic(path, format_log(log))


# --------------------------------------------------------------------------- helpers


def _frozen_float_array(name: str, values: object) -> _FloatArray:
    """Validate one ManeuverLog array and return it as a read-only float64 array.

    A copy, unless ``values`` already is a read-only float64 array owning its data (a
    column of another log: ``dataclasses.replace`` of a log then shares the columns it
    does not change, which matters for a log of a million samples).
    """
    array = np.asarray(values)
    if array.ndim != 1:
        raise ValueError(f"ManeuverLog.{name} must be one-dimensional, got shape {array.shape}")
    if array.dtype.kind not in "iuf":
        raise ValueError(f"ManeuverLog.{name} must be real-valued, got dtype {array.dtype}")
    frozen = array.dtype == np.float64 and array.flags.owndata and not array.flags.writeable
    result = array if frozen else np.array(array, dtype=np.float64, copy=True)
    if not np.all(np.isfinite(result)):
        index = int(np.flatnonzero(~np.isfinite(result))[0])
        raise ValueError(f"ManeuverLog.{name}[{index}] is not finite: {result[index]!r}")
    result.setflags(write=False)
    return result


def _frozen_metadata(metadata: Mapping[str, str]) -> Mapping[str, str]:
    """Check that metadata can be written and read back unchanged; return it read-only."""
    copy = dict(metadata)
    for key, value in copy.items():
        if not isinstance(key, str) or not _METADATA_KEY.fullmatch(key):
            raise ValueError(
                f"ManeuverLog metadata key {key!r} must be a letter or '_' followed by "
                "letters, digits, '_', '.' or '-'"
            )
        if not isinstance(value, str):
            raise ValueError(f"ManeuverLog metadata {key!r} must be a str, got {value!r}")
        if any(c in value for c in "\n\r\0") or value != value.strip():
            raise ValueError(
                f"ManeuverLog metadata {key!r} must be one line without NUL and without "
                f"leading or trailing whitespace, got {value!r}"
            )
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            raise ValueError(
                f"ManeuverLog metadata {key!r} cannot be encoded as UTF-8: {value!r}"
            ) from None
    return MappingProxyType(copy)


def _looks_like_nmea(path: str | None, first_line: str) -> bool:
    """Whether a file is probably an NMEA 0183 recording given to the trial-log reader.

    True for a ``.nmea`` file name or a first line starting with ``$`` or ``!`` (an
    NMEA sentence; a trial log starts with ``#`` comments or its header).
    """
    named = path is not None and path.lower().endswith(".nmea")
    return named or first_line.lstrip().startswith(("$", "!"))


def _binary_hint(raw: bytes, path: str) -> str:
    """Return the NMEA hint for a file that is not UTF-8 text, if it looks like NMEA."""
    stripped = raw.removeprefix(b"\xef\xbb\xbf").lstrip()
    first_line = stripped.partition(b"\n")[0].decode("latin-1")
    return _NMEA_HINT if _looks_like_nmea(path, first_line) else ""


def _parse_length_m(text: str, path: str | None, line: int | None) -> float:
    """Return the ``length_m`` metadata value [m], or raise LogFormatError.

    A ship length is within the FMU's bounds, :data:`~fmu_model.interface.MIN_LENGTH_M`
    to :data:`~fmu_model.interface.MAX_LENGTH_M`.
    """
    value = float(text) if NUMBER.fullmatch(text) else math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise LogFormatError(
            f"metadata 'length_m': expected a positive finite number of metres, got {show(text)}",
            path=path,
            line=line,
            expected="a positive finite number",
        )
    if not MIN_LENGTH_M <= value <= MAX_LENGTH_M:
        what = f"a ship length from {MIN_LENGTH_M:g} to {MAX_LENGTH_M:g} m"
        raise LogFormatError(
            f"metadata 'length_m': expected {what}, got {show(text)}",
            path=path,
            line=line,
            expected=what,
        )
    return value


def _parse_time_origin(text: str, path: str | None, line: int | None) -> dt.datetime:
    """Return the ``time_origin_utc`` metadata value (aware, UTC), or raise LogFormatError."""
    try:
        value = dt.datetime.fromisoformat(text)
    except ValueError:
        value = None
    if value is None or value.utcoffset() is None:
        what = "an ISO 8601 UTC time such as 2024-05-17T23:58:30.000Z"
        raise LogFormatError(
            f"metadata 'time_origin_utc': expected {what}, got {show(text)}",
            path=path,
            line=line,
            expected=what,
        )
    return value.astimezone(dt.UTC)


def _parse_on_board(key: str, text: str, path: str | None, line: int | None) -> float:
    """Return a position-on-board metadata value [m] (:data:`ON_BOARD_KEYS`), or raise."""
    value = float(text) if NUMBER.fullmatch(text) else math.nan
    if not (math.isfinite(value) and abs(value) <= MAX_ON_BOARD_M):
        what = f"{ON_BOARD_KEYS[key]} within ±{MAX_ON_BOARD_M:g} m"
        raise LogFormatError(
            f"metadata {key!r}: expected {what}, got {show(text)}",
            path=path,
            line=line,
            expected=what,
        )
    return value


class _Parser:
    """Line-by-line state machine behind :func:`parse_log` (one instance per text)."""

    def __init__(self, path: str | None) -> None:
        self.path = path
        self.metadata: dict[str, str] = {}
        self.metadata_lines: dict[str, int] = {}
        self.header_line: int | None = None
        self.n_fields = 0
        self.columns: tuple[str, ...] = LOG_COLUMNS  # + the optional ones present
        self.column_index: list[int] = []
        self.first_blank_line: int | None = None
        self.seen_text = False
        self.row_lines: list[int] = []
        self.values: list[list[float]] = []

    def error(
        self, message: str, line: int | None, expected: str, column: str | None = None
    ) -> LogFormatError:
        """Build a LogFormatError for this file (the caller raises it)."""
        return LogFormatError(message, path=self.path, line=line, column=column, expected=expected)

    def feed(self, number: int, line: str) -> None:
        """Consume line ``number`` (1-based), its line ending already removed."""
        if "\r" in line:
            raise self.error(
                "expected LF or CRLF line endings, got a bare carriage return (CR)",
                number,
                expected="LF or CRLF line endings",
            )
        stripped = line.strip()
        if self.header_line is None:
            if not stripped:
                return
            self.seen_text = True
            if stripped.startswith("#"):
                self.comment(number, stripped)
            else:
                self.header(number, line)
            return
        if not stripped:
            if self.first_blank_line is None:
                self.first_blank_line = number
            return
        if stripped.startswith("#"):
            raise self.error(
                "expected a data row, got a comment line "
                f"(comments are allowed only before the header on line {self.header_line})",
                number,
                expected="a data row",
            )
        if self.first_blank_line is not None:
            raise self.error(
                "expected a data row, got a blank line (blank lines are allowed only at the "
                "end of the file)",
                self.first_blank_line,
                expected="a data row",
            )
        self.row(number, line)

    def comment(self, number: int, stripped: str) -> None:
        """Record a ``# key: value`` line; other comments are ignored."""
        match = _METADATA_LINE.fullmatch(stripped)
        if match is None:
            return
        key, value = match.group(1), match.group(2).strip()
        if key in self.metadata:
            raise self.error(
                f"expected each metadata key once, got {key!r} again "
                f"(first on line {self.metadata_lines[key]})",
                number,
                expected="unique metadata keys",
            )
        if key == "length_m":
            _parse_length_m(value, path=self.path, line=number)
        if key in ON_BOARD_KEYS:
            _parse_on_board(key, value, path=self.path, line=number)
        if key == "time_origin_utc":
            _parse_time_origin(value, path=self.path, line=number)
        problem = text_problem(value) if key == "vessel" else None
        if problem is not None:  # the name of the FMU: XML and a C string
            raise self.error(f"metadata 'vessel': {problem}", number, expected="printable text")
        self.metadata[key] = value
        self.metadata_lines[key] = number

    def header(self, number: int, line: str) -> None:
        """Check the header line and map the required columns to field positions."""
        fields = split_fields(line)
        expected_header = _SEPARATOR.join(LOG_COLUMNS)
        if fields is None:
            raise self.error(
                f"expected a header line like {expected_header!r}, got malformed quoting "
                f"in {show(line)}",
                number,
                expected="a header line",
            )
        names = [name.strip() for name in fields]
        if len(names) == 1:
            self.check_separator(number, line, expected_header)
        if all(NUMBER.fullmatch(name) for name in names):
            raise self.error(
                f"expected a header line like {expected_header!r}, got a data row {show(line)}",
                number,
                expected="a header line",
            )
        missing = [column for column in LOG_COLUMNS if column not in names]
        if missing:
            plural = "s" if len(missing) > 1 else ""
            shown = show(line.strip(), _MAX_SHOWN_HEADER_CHARS)
            hint = _NMEA_HINT if _looks_like_nmea(self.path, line) else ""
            raise self.error(
                f"missing column{plural} {', '.join(map(repr, missing))}; expected a header "
                f"with {', '.join(LOG_COLUMNS)} (in any order), got {shown}{hint}",
                number,
                expected=f"columns {', '.join(LOG_COLUMNS)}",
            )
        for column in LOG_COLUMNS + OPTIONAL_COLUMNS:
            positions = [i + 1 for i, name in enumerate(names) if name == column]
            if len(positions) > 1:
                raise self.error(
                    f"expected each column once, got {column!r} in fields "
                    f"{', '.join(map(str, positions))}",
                    number,
                    column=column,
                    expected="unique column names",
                )
        if "stw_transverse_mps" in names and "stw_mps" not in names:
            raise self.error(
                "expected 'stw_mps' beside it (the two axes of one speed log), got no "
                "stw_mps column",
                number,
                column="stw_transverse_mps",
                expected="stw_mps beside stw_transverse_mps",
            )
        self.header_line = number
        self.n_fields = len(names)
        self.columns = LOG_COLUMNS + tuple(c for c in OPTIONAL_COLUMNS if c in names)
        self.column_index = [names.index(column) for column in self.columns]
        self.values = [[] for _ in self.columns]

    def check_separator(self, number: int, line: str, expected_header: str) -> None:
        """Reject a header that uses another separator than ','."""
        candidates = [*_OTHER_SEPARATORS, (None, "spaces")]
        for separator, described in candidates:
            parts = line.split(separator)
            if len(parts) > 1 and set(LOG_COLUMNS) & {part.strip() for part in parts}:
                shown = show(line.strip(), _MAX_SHOWN_HEADER_CHARS)
                raise self.error(
                    f"expected ',' as the field separator, got {described} "
                    f"(header {shown}; expected {expected_header!r})",
                    number,
                    expected="',' as the field separator",
                )

    def row(self, number: int, line: str) -> None:
        """Parse one data row into the column value lists."""
        fields = split_fields(line)
        if fields is None:
            raise self.error(
                f"expected {self.n_fields} fields separated by ',', got malformed quoting "
                f"in {show(line)}",
                number,
                expected=f"{self.n_fields} fields",
            )
        if len(fields) != self.n_fields:
            hint = ""
            if len(fields) == 1 and any(sep in line for sep, _ in _OTHER_SEPARATORS):
                hint = " (only ',' is accepted as the field separator)"
            raise self.error(
                f"expected {self.n_fields} fields separated by ',' as in the header on line "
                f"{self.header_line}, got {len(fields)}{hint}",
                number,
                expected=f"{self.n_fields} fields",
            )
        for column, index, values in zip(self.columns, self.column_index, self.values, strict=True):
            cell = fields[index].strip()
            if column in OPTIONAL_COLUMNS and (not cell or cell.lower() == "nan"):
                values.append(math.nan)  # a sensor's dropout: filled by finish()
                continue
            value = float(cell) if NUMBER.fullmatch(cell) else math.nan
            if not math.isfinite(value):
                if not cell:
                    got = "an empty field"
                elif math.isinf(value):
                    got = f"{show(cell)} (beyond the floating-point range)"
                else:
                    got = show(cell)
                raise self.error(
                    f"expected a finite number, got {got}",
                    number,
                    column=column,
                    expected="a finite number",
                )
            low, high, what = _BOUNDS[column]
            if not low <= value <= high:
                hint = _ASTERN_HINT if column == "rpm" and value < 0.0 else ""
                raise self.error(
                    f"expected {what}, got {show(cell)}{hint}",
                    number,
                    column=column,
                    expected=what,
                )
            values.append(value)
        self.row_lines.append(number)

    def check_gap(self, time_s: _FloatArray, steps: _FloatArray) -> None:
        """Reject a time step longer than the rest of the log together.

        Such a gap is far longer than the manoeuvre: the log holds two runs (or a time
        stamp is wrong), and no smoother or model bridges it.
        """
        k = int(np.argmax(steps))
        gap = float(steps[k])
        rest = float(time_s[-1] - time_s[0]) - gap
        if gap > rest:
            raise self.error(
                f"expected no gap in time longer than the rest of the log ({rest:.6g} s), got "
                f"{gap:.6g} s after {float(time_s[k])!r} s on line {self.row_lines[k]}: far "
                "longer than the manoeuvre; split the log there",
                self.row_lines[k + 1],
                column="time_s",
                expected="no gap longer than the rest of the log",
            )

    def finish(self) -> ManeuverLog:
        """Check the whole-file rules and build the log."""
        expected_header = _SEPARATOR.join(LOG_COLUMNS)
        if self.header_line is None:
            what = "no header line" if self.seen_text else "empty file"
            raise self.error(
                f"{what}; expected a header line like {expected_header!r} and at least "
                f"{MIN_SAMPLES} data rows",
                None,
                expected="a header line",
            )
        n_rows = len(self.row_lines)
        if n_rows < MIN_SAMPLES:
            raise self.error(
                f"expected at least {MIN_SAMPLES} data rows after the header on line "
                f"{self.header_line}, got {n_rows}",
                None,
                expected=f"at least {MIN_SAMPLES} data rows",
            )
        arrays = {
            column: np.array(values, dtype=np.float64)
            for column, values in zip(self.columns, self.values, strict=True)
        }
        time_s, x_m, y_m, heading_deg, rudder_deg, rpm = (arrays[c] for c in LOG_COLUMNS)
        steps = np.diff(time_s)
        if np.any(steps <= 0.0):
            k = int(np.flatnonzero(steps <= 0.0)[0]) + 1
            previous = self.row_lines[k - 1]
            if steps[k - 1] == 0.0:
                got = f"the same time {float(time_s[k])!r} as line {previous}"
            else:
                got = f"{float(time_s[k])!r} after {float(time_s[k - 1])!r} on line {previous}"
            raise self.error(
                f"expected strictly increasing time, got {got}",
                self.row_lines[k],
                column="time_s",
                expected="strictly increasing time",
            )
        self.check_gap(time_s, steps)
        filled: dict[str, int] = {}
        for column in OPTIONAL_COLUMNS:
            if column in arrays and np.isnan(arrays[column]).any():
                arrays[column], filled[column] = self.fill_dropouts(column, time_s, arrays[column])
        wind_angle_deg = arrays.get("wind_angle_deg")
        return ManeuverLog(
            time_s=time_s,
            x_m=x_m,
            y_m=y_m,
            heading_rad=unwrap_heading(np.deg2rad(heading_deg)),
            rudder_rad=np.deg2rad(rudder_deg),
            n_rps=rpm / _SECONDS_PER_MINUTE,
            metadata=self.metadata,
            path=self.path,
            wind_speed_mps=arrays.get("wind_speed_mps"),
            wind_angle_rad=None if wind_angle_deg is None else np.deg2rad(wind_angle_deg),
            stw_mps=arrays.get("stw_mps"),
            stw_transverse_mps=arrays.get("stw_transverse_mps"),
            filled=filled,
        )

    def fill_dropouts(
        self, column: str, time_s: _FloatArray, values: _FloatArray
    ) -> tuple[_FloatArray, int]:
        """Return an optional column with its dropout (NaN) filled, and its cells' count.

        Linear in time between the values around each dropout (a wind angle on the
        shorter way round), the nearest value at the log's ends; a dropout longer than
        :data:`MAX_DROPOUT_S`, or a column without any value, is an error at its first
        empty cell.
        """
        empty = np.isnan(values)
        good = np.flatnonzero(~empty)
        starts = np.flatnonzero(empty & ~np.concatenate(([False], empty[:-1])))
        ends = np.flatnonzero(empty & ~np.concatenate((empty[1:], [False])))
        for first, last in zip(starts, ends, strict=True):
            before = time_s[first - 1] if first > 0 else time_s[first]
            after = time_s[last + 1] if last + 1 < time_s.size else time_s[last]
            if good.size == 0 or after - before > MAX_DROPOUT_S:
                lasting = "the whole log" if good.size == 0 else f"{after - before:.6g} s"
                raise self.error(
                    f"expected a finite number, got no value (empty or NaN): {column}'s "
                    f"sensor drops out for {lasting} (lines {self.row_lines[first]} to "
                    f"{self.row_lines[last]}); a dropout of at most {MAX_DROPOUT_S:g} s is "
                    "interpolated",
                    self.row_lines[first],
                    column=column,
                    expected="a finite number",
                )
        known = values[good]
        if column == "wind_angle_deg":  # the shorter way round between two bearings
            known = np.rad2deg(np.unwrap(np.deg2rad(known)))
        result = values.copy()
        result[empty] = np.interp(time_s[empty], time_s[good], known)
        if column == "wind_angle_deg":
            result[empty] = np.mod(result[empty], 360.0)
        return result, int(empty.sum())
