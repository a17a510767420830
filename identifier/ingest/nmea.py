"""The NMEA 0183 reader: sentences in, each sensor stream with its own times out.

:func:`read_nmea` makes the :class:`~identifier.ingest.recording.Recording` that
:func:`~identifier.ingest.convert_nmea` (and :func:`~identifier.ingest.convert_file`)
assembles into trial logs.

One sentence per line, ``$<talker><type>,<fields>*<checksum>`` (ASCII; LF or CRLF).
Sentences used:

===== ============================================================ ===============
type  fields used                                                  valid when
===== ============================================================ ===============
GGA   UTC time of day, latitude, longitude, fix quality            quality > 0
RMC   UTC time of day, status, latitude, longitude, date (ddmmyy)  status ``A`` [#]_
GNS   UTC time of day, latitude, longitude, a mode per system      a mode not ``N``
ZDA   UTC time of day, day, month, year (time and date only)       always
HDT   true heading [deg], ``T``                                    always
THS   true heading [deg], mode indicator                           mode ``A``
HDG   magnetic heading, deviation, variation [deg] (each E or W)   a variation
RSA   starboard (or single) rudder sensor [deg], its status        status ``A``
RPM   source ``S`` (shaft), shaft number, speed [rpm], status      status ``A``
MWV   wind angle [deg], reference ``R``, wind speed, unit, status  status ``A``,
                                                                   reference ``R``
VHW   speed through the water [kn], ``N`` (else [km/h], ``K``)     always
VBW   longitudinal and transverse water speeds [kn], their status  status ``A``
===== ============================================================ ===============

.. [#] and a mode indicator (NMEA 2.3) other than ``N``.

HDG is a magnetic compass's: its heading plus the deviation and the variation (east
positive) is the true heading. It is used only in a recording without HDT and THS
headings (noted); an HDG without a variation cannot be made true and is skipped (noted).

GNS is the multi-constellation fix (NMEA 2.3, talker ``GN`` when it combines systems):
one mode character per satellite system (GPS, GLONASS, Galileo, BeiDou, ...), ``N``
for no fix in that system; the fix is valid when any system has one, as RMC's mode
indicator says. Its time has no date, as GGA's.

MWV, VHW and VBW are optional: a log gets the columns ``wind_speed_mps``,
``wind_angle_deg`` (MWV), ``stw_mps`` (VHW or VBW) and ``stw_transverse_mps`` (VBW) when
the recording has such
sentences and they cover the log (see :mod:`identifier.ingest.assemble`).

- **Wind.** Only the relative (apparent) wind goes into the log, as the anemometer
  measures it: MWV with reference ``R``. Its angle is from the bow, clockwise, the
  direction the wind comes *from*: 0 from ahead, 90 from the starboard beam, 270 from
  the port beam, so positive from starboard as the log's ``wind_angle_deg``; it is
  kept in [0, 360). The speed unit is ``N`` (knots, 1852 m per hour), ``M`` (m/s),
  ``K`` (km/h) or ``S`` (statute miles per hour), at most 100 m/s. MWV with reference
  ``T`` (a "true" or theoretical wind, computed by the instrument from the ship's
  motion) is ignored and counted in the notes, as is status ``V``.
- **Speed through the water.** VHW's speed in knots, or in km/h when the knots field
  is empty (its headings are not used: HDT/THS give the heading); VBW's longitudinal
  water speed in knots with status ``A`` (astern, a negative one, is ignored and
  noted; the ground speeds are not used), and its transverse water speed (NMEA: "−"
  to port, so positive to starboard as the log's ``stw_transverse_mps``; empty in a
  single-axis log's VBW) when the longitudinal one is taken. At most 50 m/s either.
  When both sentence types (or several talkers) are present, the one with the most
  valid samples is used, as for the other streams; the transverse speed only from that
  same VBW source (a VHW log chosen: none, noted).

- **Checksums.** A sentence whose checksum does not match is skipped and counted in
  :attr:`~identifier.ingest.ConversionResult.checksum_failures`. A sentence without
  a checksum is skipped (a line cut short would otherwise give a wrong number) unless
  ``require_checksum=False``. Lines that are not NMEA sentences, sentences with a
  malformed field (``4807.0x8``, a minute of 61, a heading of 400 deg, a propeller
  speed beyond ±6000 rpm, a wind speed beyond 100 m/s, a water speed beyond 50 m/s,
  a number beyond the floating-point range, ...) and non-ASCII lines are skipped and
  counted in :attr:`~identifier.ingest.ConversionResult.skipped_lines`.
  Neither is fatal. Other sentence types (GSV, VTG, AIS ``!`` lines, proprietary
  ``$P...`` sentences) are ignored and only counted in the notes.
- **Time.** GGA, RMC, GNS and ZDA carry the UTC time of day; RMC and ZDA also the
  date. A GGA (or GNS) time takes its day from the time-stamped sentence before it
  (at the start of the file: after it), the day that puts it within 12 hours of that
  one; so a time of day more than 12 hours before the previous one means midnight has
  passed (rollover), and a GGA-only stretch across midnight stays continuous. Without any
  date the time origin is unknown and ``time_origin_utc`` is left out. Heading,
  rudder, RPM, wind and water-speed sentences have no time of their own: each gets a
  time interpolated linearly over the line number between the two time-stamped
  sentences around it (a serial multiplexer writes at a steady rate). Sentences
  before the first or after the last time-stamped sentence are dropped (noted).
  Time stamps must increase: the longest increasing sequence of them is used, so
  that a repeated time (the GGA and RMC of one fix) or a few wrong ones (a clock
  step, a bad time with a valid checksum) cost only those sentences (noted), not the
  rest of the file.
- **Dates.** An RMC date has a two-digit year: its century is the one nearest to the
  previous date in the file (RMC, else ZDA), so that a recording goes on from 2099 into
  2100; the first without a previous date is in 2000-2099. Where RMC dates are present
  they win: a ZDA date off the nearest RMC date by a multiple of 1024 weeks (a GPS
  week-number rollover, 19.6 years) is corrected by it, one off by another amount of
  more than a day is dropped (both noted).
- **Leap seconds.** 23:59:60 (only then may the seconds reach 60) is the second after
  23:59:59, and the times count elapsed seconds: from there on one more than the
  difference of the UTC clock times (noted); ``time_origin_utc`` stays the UTC time of
  the first fix.
- **Several sources.** When fixes come from several talkers (e.g. ``GP`` and
  ``GN``), or heading, rudder, RPM, wind or water speed from several talkers or
  sentence types, the one with the most valid samples is used and the others are
  noted. RPM: shaft sentences only (source ``S``; engine sentences are noted and
  ignored), and the single shaft present, or the one chosen with ``shaft``; NMEA
  numbers a single or centre-line shaft 0, odd numbers to starboard, even to port.
- **Rudder sign.** RSA is "negative = bow turns to port", so positive turns to
  starboard as in this project: the default ``rudder_positive="starboard"`` keeps the
  sign, ``"port"`` flips it (a sensor installed the other way round).
"""

from __future__ import annotations

import bisect
import datetime as dt
import math
import re
from collections import Counter
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from typing import Any, Final

import numpy as np
import pynmea2

from fmu_model.interface import MAX_PROPELLER_RPM
from identifier.ingest.recording import (
    HEADING,
    RPM,
    RUDDER,
    SECONDS_PER_MINUTE,
    STW,
    STW_TRANSVERSE,
    WIND_ANGLE,
    WIND_SPEED,
    FloatArray,
    Recording,
)
from trials.errors import LogFormatError
from trials.logs import MAX_STW_MPS, MAX_WIND_SPEED_MPS

__all__ = ["read_nmea"]

_SECONDS_PER_DAY: Final = 86400.0
_GPS_ROLLOVER_DAYS: Final = 1024 * 7  # GPS week numbers count modulo 1024
_HALF_DAY_S: Final = 43200.0

_DECIMAL: Final = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)", re.ASCII)
_TIME_OF_DAY: Final = re.compile(r"(\d{2})(\d{2})(\d{2}(?:\.\d*)?)", re.ASCII)
_LATITUDE: Final = re.compile(r"(\d{2})(\d{2}(?:\.\d*)?)", re.ASCII)
_LONGITUDE: Final = re.compile(r"(\d{3})(\d{2}(?:\.\d*)?)", re.ASCII)
_DATE: Final = re.compile(r"(\d{2})(\d{2})(\d{2})", re.ASCII)
_CHECKSUM_TAIL: Final = re.compile(r"\*[0-9A-Fa-f]{2}\Z", re.ASCII)

_KNOT_MPS: Final = 1852.0 / 3600.0
_KMH_MPS: Final = 1.0 / 3.6
_MPH_MPS: Final = 0.44704  # statute mile (1609.344 m) per hour
_WIND_UNITS: Final = {"N": _KNOT_MPS, "M": 1.0, "K": _KMH_MPS, "S": _MPH_MPS}
"""MWV wind speed units → m/s."""
_OPTIONAL: Final = (WIND_SPEED, WIND_ANGLE, STW, STW_TRANSVERSE)
_GNS_MODES: Final = frozenset("ADEFMNPRS")
"""GNS modes (NMEA 4.1): autonomous, differential, estimated, float RTK, manual, no fix,
precise, RTK, simulator."""


class _MalformedError(Exception):
    """A field of an otherwise well-formed sentence cannot be read (line skipped)."""


@dataclass(frozen=True)
class _Timed:
    """A time-stamped sentence: GGA, RMC, GNS or ZDA."""

    line: int
    talker: str
    kind: str
    time_of_day_s: float
    date: dt.date | None
    fix: tuple[float, float] | None  # (lat_deg, lon_deg) of a valid fix


@dataclass(frozen=True)
class _Sample:
    """A sensor reading without its own time: heading, rudder, RPM, wind, water speed."""

    line: int
    source: str  # talker + type (+ shaft), e.g. "HEHDT"
    value: float  # SI: rad or rev/s


def _time_of_day(text: str) -> float:
    """``hhmmss[.sss]`` → seconds after midnight."""
    match = _TIME_OF_DAY.fullmatch(text)
    if match is None:
        raise _MalformedError
    hours, minutes, seconds = int(match[1]), int(match[2]), float(match[3])
    if hours > 23 or minutes > 59 or seconds >= 61.0:
        raise _MalformedError
    if seconds >= 60.0 and (hours, minutes) != (23, 59):  # a leap second ends a UTC day
        raise _MalformedError
    return hours * 3600.0 + minutes * 60.0 + seconds  # 23:59:60.x: 86400 + x


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
    value = float(text)  # inf for a number beyond the floating-point range
    if not (math.isfinite(value) and low <= value <= high):
        raise _MalformedError
    return value


def _east_positive(text: str, direction: str) -> float | None:
    """Return an HDG angle [deg] east positive (``E`` or ``W`` after it), None when empty."""
    if not text and not direction:
        return None
    if direction not in ("E", "W"):
        raise _MalformedError
    angle = _decimal(text, 0.0, 180.0)
    return angle if direction == "E" else -angle


def _rmc_date(text: str, near: dt.date | None) -> dt.date | None:
    """``ddmmyy`` → date; empty → None.

    The century is the one that puts the year nearest to ``near`` (the previous date of
    the file), so that a recording across 31 Dec 2099 goes on into 2100; without a
    previous date, the years 2000-2099.
    """
    if not text:
        return None
    match = _DATE.fullmatch(text)
    if match is None:
        raise _MalformedError
    two_digits = int(match[3])
    year = 2000 + two_digits
    if near is not None:
        century = near.year // 100 * 100
        year = min(
            (century + offset + two_digits for offset in (-100, 0, 100)),
            key=lambda candidate: abs(candidate - near.year),
        )
    try:
        return dt.date(year, int(match[2]), int(match[1]))
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
        self.last_date: dt.date | None = None  # of the last RMC (or ZDA) with a date
        self.last_rmc_date: dt.date | None = None
        self.magnetic: list[_Sample] = []  # true headings of HDG, for want of HDT and THS
        self.samples: dict[str, list[_Sample]] = {
            HEADING: [],
            RUDDER: [],
            RPM: [],
            WIND_SPEED: [],
            WIND_ANGLE: [],
            STW: [],
            STW_TRANSVERSE: [],  # after STW: taken from STW's chosen source only
        }

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
            "GNS": self.gns,
            "ZDA": self.zda,
            "HDT": self.hdt,
            "THS": self.ths,
            "HDG": self.hdg,
            "RSA": self.rsa,
            "RPM": self.rpm,
            "MWV": self.mwv,
            "VHW": self.vhw,
            "VBW": self.vbw,
        }
        handler = handlers.get(kind)
        if handler is None:
            self.other[kind] += 1
            return
        try:
            handler(number, talker, get)
        except _MalformedError:
            self.skipped += 1

    def _undated_fix(
        self,
        number: int,
        talker: str,
        get: Callable[[str, int], str],
        kind: str,
        has_fix: Callable[[], bool],
        without: str,
    ) -> None:
        """Read a fix with the time of day and position in fields 0 to 4 and no date.

        GGA and GNS: ``has_fix`` reads the sentence's own validity field (raising
        :class:`_MalformedError` for a malformed one); ``without`` names the value that
        means no fix, for the tally.
        """
        time_text = get("timestamp", 0)
        if not time_text:
            self.tally[f"{kind} sentences without a time"] += 1
            return
        time_of_day = _time_of_day(time_text)
        fix = None
        if has_fix():
            fix = (
                _latitude(get("lat", 1), get("lat_dir", 2)),
                _longitude(get("lon", 3), get("lon_dir", 4)),
            )
        else:
            self.tally[f"{kind} sentences without a fix ({without})"] += 1
        self.timed.append(_Timed(number, talker, kind, time_of_day, None, fix))

    def gga(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--GGA,hhmmss.ss,llll.ll,a,yyyyy.yy,a,q,...`` (a fix when q > 0)."""

        def has_fix() -> bool:
            quality = get("gps_qual", 5)
            if not (quality.isdigit() and len(quality) == 1):
                raise _MalformedError
            return quality != "0"

        self._undated_fix(number, talker, get, "GGA", has_fix, "quality 0")

    def rmc(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--RMC,hhmmss.ss,A,llll.ll,a,yyyyy.yy,a,sog,cog,ddmmyy,...``."""
        time_text, status = get("timestamp", 0), get("status", 1)
        if not time_text:
            self.tally["RMC sentences without a time"] += 1
            return
        time_of_day = _time_of_day(time_text)
        if status not in ("A", "V"):
            raise _MalformedError
        date = _rmc_date(get("datestamp", 8), self.last_rmc_date or self.last_date)
        if date is not None:
            self.last_date = self.last_rmc_date = date
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

    def gns(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--GNS,hhmmss.ss,llll.ll,a,yyyyy.yy,a,c--c,...`` (c--c: a mode per system)."""

        def has_fix() -> bool:
            modes = get("mode_indicator", 5)
            if not modes or not set(modes) <= _GNS_MODES:
                raise _MalformedError
            return set(modes) != {"N"}

        self._undated_fix(number, talker, get, "GNS", has_fix, "mode N")

    def zda(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--ZDA,hhmmss.ss,dd,mm,yyyy,zh,zm``."""
        time_of_day = _time_of_day(get("timestamp", 0))
        date = _zda_date(get("day", 1), get("month", 2), get("year", 3))
        self.last_date = date
        self.timed.append(_Timed(number, talker, "ZDA", time_of_day, date, None))

    def hdt(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--HDT,x.x,T``."""
        if get("hdg_true", 1) != "T":
            raise _MalformedError
        heading = _decimal(get("heading", 0), 0.0, 360.0)
        self.samples[HEADING].append(_Sample(number, f"{talker}HDT", math.radians(heading)))

    def ths(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--THS,x.x,a`` (mode A autonomous, E estimated, M manual, S simulator, V)."""
        mode = get("mode", 1)
        if mode not in ("A", "E", "M", "S", "V"):
            raise _MalformedError
        heading = _decimal(get("heading", 0), 0.0, 360.0)
        if mode != "A":
            self.tally[f"THS headings with mode {mode}, not A (ignored)"] += 1
            return
        self.samples[HEADING].append(_Sample(number, f"{talker}THS", math.radians(heading)))

    def hdg(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--HDG,x.x,x.x,a,x.x,a`` (magnetic heading, deviation, variation)."""
        heading = _decimal(get("heading", 0), 0.0, 360.0)
        deviation = _east_positive(get("deviation", 1), get("dev_dir", 2))
        variation = _east_positive(get("variation", 3), get("var_dir", 4))
        if variation is None:
            self.tally["HDG headings without a magnetic variation (not made true)"] += 1
            return
        true_deg = (heading + (deviation or 0.0) + variation) % 360.0
        self.magnetic.append(_Sample(number, f"{talker}HDG", math.radians(true_deg)))

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
        self.samples[RUDDER].append(_Sample(number, f"{talker}RSA", rudder))

    def rpm(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--RPM,a,x,x.x,x.x,A`` (source S/E, number, rpm, pitch %, status)."""
        source, shaft, status = get("source", 0), get("engine_no", 1), get("status", 4)
        if source not in ("S", "E") or not shaft.isdigit() or status not in ("A", "V"):
            raise _MalformedError
        speed = _decimal(get("speed", 2), -MAX_PROPELLER_RPM, MAX_PROPELLER_RPM)
        if status != "A":
            self.tally["RPM sentences with status V (ignored)"] += 1
        elif source == "E":
            self.tally["engine RPM sentences, source E (ignored; shaft RPM used)"] += 1
        else:
            n_rps = speed / SECONDS_PER_MINUTE
            self.samples[RPM].append(_Sample(number, f"{talker}RPM shaft {int(shaft)}", n_rps))

    def mwv(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--MWV,x.x,a,x.x,a,A`` (angle [deg], reference R/T, speed, unit, status)."""
        reference, unit, status = get("reference", 1), get("wind_speed_units", 3), get("status", 4)
        if reference not in ("R", "T") or status not in ("A", "V"):
            raise _MalformedError
        if status != "A":
            self.tally["MWV wind readings with status V (ignored)"] += 1
            return
        if reference != "R":
            self.tally["MWV true (theoretical) wind readings, reference T (ignored)"] += 1
            return
        if unit not in _WIND_UNITS:
            raise _MalformedError
        angle = _decimal(get("wind_angle", 0), 0.0, 360.0)
        speed = _decimal(get("wind_speed", 2), 0.0, MAX_WIND_SPEED_MPS / _WIND_UNITS[unit])
        source = f"{talker}MWV"
        self.samples[WIND_SPEED].append(_Sample(number, source, speed * _WIND_UNITS[unit]))
        self.samples[WIND_ANGLE].append(_Sample(number, source, math.radians(angle % 360.0)))

    def vhw(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--VHW,x.x,T,x.x,M,x.x,N,x.x,K`` (headings; water speed [kn], [km/h])."""
        knots, kmh = get("water_speed_knots", 4), get("water_speed_km", 6)
        if knots:
            if get("knots", 5) != "N":
                raise _MalformedError
            speed = _decimal(knots, 0.0, MAX_STW_MPS / _KNOT_MPS) * _KNOT_MPS
        elif kmh:
            if get("kilometers", 7) != "K":
                raise _MalformedError
            speed = _decimal(kmh, 0.0, MAX_STW_MPS / _KMH_MPS) * _KMH_MPS
        else:
            self.tally["VHW sentences without a water speed"] += 1
            return
        self.samples[STW].append(_Sample(number, f"{talker}VHW", speed))

    def vbw(self, number: int, talker: str, get: Callable[[str, int], str]) -> None:
        """Read ``$--VBW,x.x,x.x,A,x.x,x.x,A`` (water speeds [kn], status; ground speeds).

        The transverse water speed, when the field is there, only with a longitudinal one
        taken (the two are one log's axes).
        """
        status = get("data_validity_water_spd", 2)
        if status not in ("A", "V"):
            raise _MalformedError
        if status != "A":
            self.tally["VBW water speeds with status V (ignored)"] += 1
            return
        limit = MAX_STW_MPS / _KNOT_MPS
        speed = _decimal(get("lon_water_spd", 0), -limit, limit) * _KNOT_MPS
        if speed < 0.0:
            self.tally["VBW water speeds astern, negative (ignored)"] += 1
            return
        transverse = get("trans_water_spd", 1)
        source = f"{talker}VBW"
        if transverse:
            value = _decimal(transverse, -limit, limit) * _KNOT_MPS
            self.samples[STW_TRANSVERSE].append(_Sample(number, source, value))
        self.samples[STW].append(_Sample(number, source, speed))


def read_nmea(
    path: str, raw: bytes, rudder_sign: float, shaft: int | None, require_checksum: bool
) -> Recording:
    """Collect the NMEA records of a file and put every stream on one time axis.

    Parameters
    ----------
    path : str
        The file, for messages and the recording.
    raw : bytes
        Its content.
    rudder_sign : float
        +1 to keep the RSA sign, -1 to flip it.
    shaft : int or None
        RPM shaft to use; None: the only one present.
    require_checksum : bool
        Skip sentences without a ``*hh`` checksum.

    Returns
    -------
    Recording
        The fixes [deg] and the heading [rad], rudder [rad] and rpm [rev/s] streams,
        times [s] after midnight UTC of the first date (or of day 0 without a date).

    Raises
    ------
    LogFormatError
        If there is no valid sentence or fix, or RPM for several shafts and ``shaft``
        is None, or none for ``shaft``.

    """
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
            "no valid position fix; expected GGA sentences with a fix quality above 0, RMC "
            f"sentences with status A or GNS sentences with a mode other than N ({counts})",
            path=path,
            expected="valid GGA, RMC or GNS position fixes",
        )
    talker = _most_common(fixes_by_talker, "position fixes", notes)
    timed = _prefer_rmc_dates(
        [r for r in reader.timed if r.talker == talker or r.kind == "ZDA"], notes
    )
    times, epoch, leaps = _resolve_times(timed, notes)

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

    if epoch is not None and leaps:
        # Times count elapsed seconds; a leap second before the first fix would put its
        # clock time (epoch + time, where datetime has no leap seconds) 1 s late.
        epoch -= dt.timedelta(seconds=sum(leap <= fix_t[0] for leap in leaps))
    lines = np.array(anchor_lines, dtype=np.float64)
    clock = np.array(anchor_times, dtype=np.float64)
    if reader.magnetic and reader.samples[HEADING]:
        notes.append(f"HDG headings ignored (HDT or THS used): {len(reader.magnetic)}")
    elif reader.magnetic:
        reader.samples[HEADING] = reader.magnetic
        notes.append(
            "heading from HDG, a magnetic compass's corrected by its deviation and variation "
            "(no HDT or THS in the recording)"
        )
    streams: dict[str, tuple[FloatArray, FloatArray]] = {}
    optional: dict[str, tuple[FloatArray, FloatArray]] = {}
    used: dict[str, str] = {}  # stream -> the source chosen
    for name, samples in reader.samples.items():
        if name in _OPTIONAL and not samples:
            continue
        if name == STW_TRANSVERSE:  # the transverse axis of the log chosen for STW
            kept_samples = [s for s in samples if s.source == used.get(STW)]
            if len(kept_samples) < len(samples):
                notes.append(
                    f"{name} of another source than the {STW}'s (ignored): "
                    f"{len(samples) - len(kept_samples)}"
                )
            if not kept_samples:
                continue
            samples = kept_samples
        chosen = _choose_samples(name, samples, shaft, path, notes)
        used[name] = chosen[0].source if chosen else ""
        line = np.array([s.line for s in chosen], dtype=np.float64)
        inside = (line > lines[0]) & (line < lines[-1])
        if np.count_nonzero(~inside):
            notes.append(
                f"{name} sentences before the first or after the last time-stamped sentence "
                f"(dropped): {np.count_nonzero(~inside)}"
            )
        values = np.array([s.value for s in chosen], dtype=np.float64)
        stream = (np.interp(line[inside], lines, clock), values[inside])
        if name not in _OPTIONAL:
            streams[name] = stream
        elif stream[0].size:
            optional[name] = stream

    for what, count in sorted(reader.tally.items()):
        notes.append(f"{what}: {count}")
    if reader.other:
        shown = ", ".join(f"{kind} {count}" for kind, count in sorted(reader.other.items()))
        notes.append(f"other sentences ignored: {shown}")
    lat, lon = (np.array(values, dtype=np.float64) for values in zip(*fixes, strict=True))
    return Recording(
        path=path,
        kind="NMEA 0183",
        fix_t=np.array(fix_t, dtype=np.float64),
        lat_deg=lat,
        lon_deg=lon,
        streams=streams,
        sources={
            HEADING: "HDT or THS (mode A) sentences, or HDG sentences with a variation",
            RUDDER: "RSA sentences with status A",
            RPM: "RPM sentences of a shaft (source S) with status A",
            WIND_SPEED: "MWV sentences with reference R and status A",
            WIND_ANGLE: "MWV sentences with reference R and status A",
            STW: "VHW sentences, or VBW sentences with status A",
            STW_TRANSVERSE: "VBW sentences with status A and a transverse water speed",
        },
        epoch=epoch,
        skipped_lines=reader.skipped,
        checksum_failures=reader.checksum_failures,
        notes=notes,
        optional=optional,
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
    if name == RPM:
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


def _prefer_rmc_dates(timed: list[_Timed], notes: list[str]) -> list[_Timed]:
    """Check the ZDA dates against the RMC dates beside them; the RMC dates win.

    A receiver whose week number has rolled over (GPS counts weeks modulo 1024) puts its
    ZDA date 1024 weeks (19.6 years) early, or a multiple of that, while its RMC date is
    right (or the other way round in older firmware). A ZDA date that differs from the
    nearest RMC date (in line order) by a multiple of 1024 weeks, within a day (around
    midnight the two sentences may straddle it), is corrected by that multiple; one that
    differs otherwise by more than a day is dropped. Both are noted.
    """
    rmc_lines = [i for i, r in enumerate(timed) if r.kind == "RMC" and r.date is not None]
    if not rmc_lines:
        return timed
    kept: list[_Timed] = []
    corrected = dropped = 0
    for i, record in enumerate(timed):
        if record.kind != "ZDA" or record.date is None:
            kept.append(record)
            continue
        k = bisect.bisect_left(rmc_lines, i)
        nearest = min(rmc_lines[max(k - 1, 0) : k + 1], key=lambda j: abs(j - i))
        rmc_date = timed[nearest].date
        assert rmc_date is not None  # by the choice of rmc_lines
        days = (rmc_date - record.date).days
        rollovers = round(days / _GPS_ROLLOVER_DAYS)
        if abs(days - rollovers * _GPS_ROLLOVER_DAYS) > 1:
            dropped += 1
        elif rollovers:
            corrected += 1
            shift = dt.timedelta(days=rollovers * _GPS_ROLLOVER_DAYS)
            kept.append(replace(record, date=record.date + shift))
        else:
            kept.append(record)
    if corrected:
        notes.append(
            "ZDA dates off the RMC dates by a multiple of 1024 weeks (GPS week-number "
            f"rollover), corrected to the RMC dates: {corrected}"
        )
    if dropped:
        notes.append(f"ZDA dates that disagree with the RMC dates (dropped): {dropped}")
    return kept


def _resolve_times(
    timed: list[_Timed], notes: list[str]
) -> tuple[list[float], dt.datetime | None, list[float]]:
    """Seconds after midnight of the first date in the file, for every timed record.

    Records with a date use it; the others take the day that puts them within 12 h
    of the neighbouring record (the previous one, or the next for those before the
    first dated record), which unwraps midnight rollovers.

    A leap second, 23:59:60, is the second after 23:59:59: the times count elapsed
    seconds, so every later time is one second more than the difference of the clock
    times (noted). Also returned: the times at which the leap seconds ended (midnight
    after them, on the returned scale).
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
    resolved = [float(time) for time in times if time is not None]
    # Midnights that follow a leap second (23:59:60 on the clock, 86400 s of its day).
    boundaries = sorted(
        {
            time - (record.time_of_day_s - _SECONDS_PER_DAY)
            for time, record in zip(resolved, timed, strict=True)
            if record.time_of_day_s >= _SECONDS_PER_DAY
        }
    )
    if boundaries:
        # A time at or after a boundary is one second later per leap second before it;
        # a leap second itself only after the earlier ones.
        leap = [record.time_of_day_s >= _SECONDS_PER_DAY for record in timed]
        resolved = [
            time
            + (
                bisect.bisect_left(boundaries, time - (record.time_of_day_s - _SECONDS_PER_DAY))
                if is_leap
                else bisect.bisect_right(boundaries, time)
            )
            for time, record, is_leap in zip(resolved, timed, leap, strict=True)
        ]
        first = leap.index(True)
        notes.append(
            f"leap second (23:59:60) on line {timed[first].line}: later times count elapsed "
            "seconds, one more than the difference of the UTC clock times"
        )
    epoch = None
    if reference is not None:
        epoch = dt.datetime.combine(reference, dt.time(), tzinfo=dt.UTC)
    leaps = [b + k + 1 for k, b in enumerate(boundaries)]  # on the shifted scale
    return resolved, epoch, leaps


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
