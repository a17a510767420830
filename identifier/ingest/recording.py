"""The data handed between the steps of a conversion.

:class:`Options` (validated settings) go in, a reader (:mod:`identifier.ingest.nmea`,
:mod:`identifier.ingest.latlon_csv`) turns a file into a :class:`Recording` (each
sensor stream with its own sample times), :mod:`identifier.ingest.assemble` turns that
into a :class:`ConversionResult` (the trial logs and what was skipped on the way).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Final, Literal

import numpy as np
import numpy.typing as npt

from fmu_model.interface import MAX_LENGTH_M, MIN_LENGTH_M
from fmu_model.params import text_problem
from trials.logs import MAX_ON_BOARD_M, MAX_RPM, ON_BOARD_KEYS, ManeuverLog

__all__ = [
    "DEFAULT_MAX_GAP_S",
    "FIXES",
    "HEADING",
    "MAX_RATE_HZ",
    "MIN_RATE_HZ",
    "RPM",
    "RUDDER",
    "SECONDS_PER_MINUTE",
    "STW",
    "STW_TRANSVERSE",
    "WIND_ANGLE",
    "WIND_SPEED",
    "ConversionResult",
    "FloatArray",
    "HeadingUnit",
    "InputFormat",
    "Options",
    "Recording",
    "RudderPositive",
]

RudderPositive = Literal["starboard", "port"]
HeadingUnit = Literal["deg", "rad"]
InputFormat = Literal["auto", "nmea", "csv"]

DEFAULT_MAX_GAP_S: Final = 5.0
MIN_RATE_HZ: Final = 0.01
MAX_RATE_HZ: Final = 100.0
"""Resampling rates accepted [Hz]: manoeuvring dynamics need no more than a few Hz, and
100 Hz over the longest input is already tens of millions of rows."""
"""Longest time without a sample of a stream that is bridged by interpolation [s]."""

FloatArray = npt.NDArray[np.float64]

SECONDS_PER_MINUTE: Final = 60.0
"""Converts a propeller speed in rpm (files) to rev/s (inside)."""

# Names of the streams: keys of Recording.streams and Recording.sources, and the words
# the notes and error messages use.
HEADING: Final = "heading"
RUDDER: Final = "rudder angle"
RPM: Final = "propeller speed"
FIXES: Final = "position fixes"
# Optional streams: a log gets their columns when they cover it (see assemble).
WIND_SPEED: Final = "wind speed"
WIND_ANGLE: Final = "wind angle"
STW: Final = "speed through the water"
STW_TRANSVERSE: Final = "transverse speed through the water"


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
class Options:
    """Validated conversion settings shared by both input formats.

    Made by :meth:`make`; the fields are the arguments of
    :func:`~identifier.ingest.convert_nmea` of the same names (``rate_hz`` [Hz],
    ``max_gap_s`` [s], ``length_m`` [m], ``on_board`` [m]: positions on board by their
    metadata key, ``trials.logs.ON_BOARD_KEYS``; ``constant_n_rps`` [rev/s]: the
    propeller speed of a recording that logs none).
    """

    rudder_positive: RudderPositive
    rate_hz: float | None
    max_gap_s: float
    min_samples: int
    vessel: str | None
    length_m: float | None
    on_board: Mapping[str, float] = field(default_factory=dict)
    constant_n_rps: float | None = None

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
        on_board: Mapping[str, float] | None = None,
        constant_n_rps: float | None = None,
    ) -> Options:
        """Check the settings; raise ValueError naming the bad one."""
        if rudder_positive not in ("starboard", "port"):
            raise ValueError(
                f"rudder_positive must be 'starboard' or 'port', got {rudder_positive!r}"
            )
        if rate_hz is not None and not MIN_RATE_HZ <= rate_hz <= MAX_RATE_HZ:
            raise ValueError(
                f"rate_hz must be from {MIN_RATE_HZ:g} to {MAX_RATE_HZ:g} Hz, got {rate_hz!r}"
            )
        if not (math.isfinite(max_gap_s) and max_gap_s > 0.0):
            raise ValueError(f"max_gap_s must be a positive number of seconds, got {max_gap_s!r}")
        if isinstance(min_samples, bool) or not isinstance(min_samples, int) or min_samples < 2:
            raise ValueError(f"min_samples must be an integer of at least 2, got {min_samples!r}")
        if vessel is not None and (
            any(c in vessel for c in "\r\n\0") or not vessel.strip() or vessel != vessel.strip()
        ):
            raise ValueError(f"vessel must be one non-empty line without padding, got {vessel!r}")
        problem = None if vessel is None else text_problem(vessel)
        if problem is not None:
            raise ValueError(f"vessel {problem}, got {vessel!r}")
        if length_m is not None and not MIN_LENGTH_M <= length_m <= MAX_LENGTH_M:
            raise ValueError(
                f"length_m must be a ship length from {MIN_LENGTH_M:g} to {MAX_LENGTH_M:g} m, "
                f"got {length_m!r}"
            )
        for key, value in (on_board or {}).items():
            if key not in ON_BOARD_KEYS or not abs(value) <= MAX_ON_BOARD_M:
                raise ValueError(
                    f"on_board: expected positions within ±{MAX_ON_BOARD_M:g} m of "
                    f"{', '.join(ON_BOARD_KEYS)}, got {key!r}: {value!r}"
                )
        if constant_n_rps is not None and not 0.0 < constant_n_rps <= MAX_RPM / SECONDS_PER_MINUTE:
            raise ValueError(
                f"constant_n_rps must be a propeller speed above 0 and at most "
                f"{MAX_RPM / SECONDS_PER_MINUTE:g} rev/s, got {constant_n_rps!r}"
            )
        return cls(
            rudder_positive,
            None if rate_hz is None else float(rate_hz),
            float(max_gap_s),
            min_samples,
            vessel,
            None if length_m is None else float(length_m),
            {key: float(value) for key, value in (on_board or {}).items()},
            None if constant_n_rps is None else float(constant_n_rps),
        )


# --------------------------------------------------------------------------- recordings


@dataclass
class Recording:
    """What a reader found: each stream with its own times [s, any common origin].

    Parameters
    ----------
    path : str
        The input file.
    kind : str
        The input format, for the notes and the ``# source:`` line
        (``"NMEA 0183"``, ``"latitude/longitude CSV"``).
    fix_t : numpy.ndarray
        Times of the valid position fixes [s], increasing.
    lat_deg, lon_deg : numpy.ndarray
        Latitude and longitude of the fixes on WGS84 [deg].
    streams : dict of str to (numpy.ndarray, numpy.ndarray)
        :data:`HEADING` (true, [rad]), :data:`RUDDER` ([rad], positive to starboard)
        and :data:`RPM` ([rev/s]): sample times [s] and values (SI units).
    sources : dict of str to str
        Per stream, what would have provided it (for the message when it is empty).
    optional : dict of str to (numpy.ndarray, numpy.ndarray)
        Streams a log may lack, each only when the input has samples of it:
        :data:`WIND_SPEED` (apparent, [m/s]), :data:`WIND_ANGLE` (apparent, from the
        bow, positive from starboard, [rad] in [0, 2π)), :data:`STW` ([m/s]) and
        :data:`STW_TRANSVERSE` (positive to starboard, [m/s]; only from the source of
        :data:`STW`): sample times [s] and values.
    epoch : datetime.datetime or None
        UTC instant of time 0 of ``fix_t`` and the streams; None when unknown.
    skipped_lines, checksum_failures : int
        As in :class:`ConversionResult`.
    notes : list of str
        The reader's remarks, one line each.

    """

    path: str
    kind: str
    fix_t: FloatArray
    lat_deg: FloatArray
    lon_deg: FloatArray
    streams: dict[str, tuple[FloatArray, FloatArray]]  # name -> (times, SI values)
    sources: dict[str, str]  # name -> what would have provided it (for messages)
    epoch: dt.datetime | None  # UTC instant of time 0 of fix_t and the streams
    skipped_lines: int = 0
    checksum_failures: int = 0
    notes: list[str] = field(default_factory=list)
    optional: dict[str, tuple[FloatArray, FloatArray]] = field(default_factory=dict)
