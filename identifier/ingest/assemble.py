"""Assembly: a recording's streams → trial logs on one time base in the tangent plane.

:func:`assemble` projects the fixes into the plane about the first fix
(:class:`~identifier.ingest.geodesy.TangentPlane`), turns true headings to the plane's
x axis, cuts every stream at its gaps, keeps the pieces where all streams are present,
resamples each piece onto its time base (the fixes, or a ``rate_hz`` grid), widened by
at most one time-base sample at each end, and writes the metadata of every log (steps
2 to 6 of :mod:`identifier.ingest`).

The optional streams (apparent wind speed and angle, speed through the water) do not
cut the recording: a log gets their columns when the stream covers it without a gap
longer than ``max_gap_s`` (with the same one-sample widening at the ends), resampled
like the others (the wind angle on the unwrapped angle, then back into [0, 2π));
otherwise the log has no such column and a note says so.
"""

from __future__ import annotations

import datetime as dt
import math
import os
from collections.abc import Sequence
from dataclasses import replace
from typing import Final

import numpy as np

from identifier.ingest.geodesy import TangentPlane
from identifier.ingest.recording import (
    FIXES,
    HEADING,
    RPM,
    RUDDER,
    SECONDS_PER_MINUTE,
    STW,
    STW_TRANSVERSE,
    WIND_ANGLE,
    WIND_SPEED,
    ConversionResult,
    FloatArray,
    Options,
    Recording,
)
from trials.angles import unwrap_heading
from trials.errors import LogFormatError
from trials.logs import MAX_STW_MPS, MAX_WIND_SPEED_MPS, ManeuverLog

__all__ = ["assemble"]

_SAME_TIME_S: Final = 1e-9  # closer time stamps are one instant (round-off of sensor times)

# The optional streams: ManeuverLog field and the bounds of the log's column.
_OPTIONAL_FIELDS: Final = {
    WIND_SPEED: ("wind_speed_mps", 0.0, MAX_WIND_SPEED_MPS),
    WIND_ANGLE: ("wind_angle_rad", -math.inf, math.inf),
    STW: ("stw_mps", 0.0, MAX_STW_MPS),
    STW_TRANSVERSE: ("stw_transverse_mps", -MAX_STW_MPS, MAX_STW_MPS),
}


def _coverage(
    times: FloatArray, max_gap_s: float
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


def _time_base(start: float, end: float, fix_t: FloatArray, rate_hz: float | None) -> FloatArray:
    """Sample times of one piece: the fixes in it, or the ``rate_hz`` grid in it."""
    if rate_hz is None:
        return fix_t[(fix_t >= start) & (fix_t <= end)]
    first = math.ceil(start * rate_hz - 1e-9)
    last = math.floor(end * rate_hz + 1e-9)
    return np.arange(first, last + 1, dtype=np.float64) / rate_hz


def _base_before(time: float, fix_t: FloatArray, rate_hz: float | None) -> float | None:
    """Return the last time-base sample (fix or grid time) at or before ``time`` [s]."""
    if rate_hz is not None:
        return math.floor(time * rate_hz + 1e-9) / rate_hz
    k = int(np.searchsorted(fix_t, time + _SAME_TIME_S, side="right")) - 1
    return float(fix_t[k]) if k >= 0 else None


def _base_after(time: float, fix_t: FloatArray, rate_hz: float | None) -> float | None:
    """Return the first time-base sample (fix or grid time) at or after ``time`` [s]."""
    if rate_hz is not None:
        return math.ceil(time * rate_hz - 1e-9) / rate_hz
    k = int(np.searchsorted(fix_t, time - _SAME_TIME_S, side="left"))
    return float(fix_t[k]) if k < fix_t.size else None


def _stretch(
    covered: list[tuple[float, float]],
    times: FloatArray,
    fix_t: FloatArray,
    options: Options,
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
    time: FloatArray, times: FloatArray, values: FloatArray, max_gap_s: float
) -> tuple[FloatArray, float]:
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


def _with_constant_rpm(
    recording: Recording, constant_n_rps: float | None, notes: list[str]
) -> Recording:
    """Return ``recording`` with a propeller speed of ``constant_n_rps`` [rev/s] at every fix.

    For a recording that logs none (a bridge's NMEA often has no RPM sentence, and a
    trial runs at a set engine order); None: as it is. Noted in ``notes``.

    Raises
    ------
    LogFormatError
        A constant given for a recording that logs the propeller speed.

    """
    if constant_n_rps is None:
        return recording
    if recording.streams[RPM][0].size:
        raise LogFormatError(
            f"the recording logs the {RPM} ({recording.sources[RPM]}); expected --rpm only "
            "for one without",
            path=recording.path,
            expected=f"no {RPM} samples with a constant one",
        )
    rpm = constant_n_rps * SECONDS_PER_MINUTE
    notes.append(f"{RPM}: none in the recording; {rpm:g} rpm at every fix, as given (--rpm)")
    constant = np.full(recording.fix_t.size, constant_n_rps)
    return replace(recording, streams={**recording.streams, RPM: (recording.fix_t, constant)})


def assemble(recording: Recording, options: Options) -> ConversionResult:
    """Project, split at gaps, resample and build the logs of one recording.

    Parameters
    ----------
    recording : Recording
        What a reader found: fixes [deg] and streams (SI units) with their own times [s].
    options : Options
        The validated settings (``rate_hz`` [Hz], ``max_gap_s`` [s], ...).

    Returns
    -------
    ConversionResult
        The logs, gaps and notes; times [s] after the first fix, x North and y East [m]
        of it.

    Raises
    ------
    LogFormatError
        If the recording has no valid position fix or a stream has no sample.

    """
    path, notes = recording.path, list(recording.notes)
    if recording.fix_t.size == 0:
        raise LogFormatError(
            "no valid position fix; expected rows with latitude and longitude",
            path=path,
            expected="position fixes",
        )
    recording = _with_constant_rpm(recording, options.constant_n_rps, notes)
    for name, (times, _) in recording.streams.items():
        if times.size == 0:
            hint = " (or the trial's constant shaft speed: convert --rpm N)" if name == RPM else ""
            raise LogFormatError(
                f"no {name} samples; expected {recording.sources[name]}{hint}",
                path=path,
                expected=f"{name} samples",
            )
    plane = TangentPlane(float(recording.lat_deg[0]), float(recording.lon_deg[0]))
    x_m, y_m = plane.to_local(recording.lat_deg, recording.lon_deg)
    north = plane.north_azimuth_rad(recording.lat_deg, recording.lon_deg)
    t0 = float(recording.fix_t[0])
    fix_t = recording.fix_t - t0
    streams = {name: (t - t0, v) for name, (t, v) in recording.streams.items()}
    heading_t, heading = streams[HEADING]
    streams[HEADING] = (heading_t, unwrap_heading(heading))
    optional = {name: (t - t0, v) for name, (t, v) in recording.optional.items()}
    if WIND_ANGLE in optional:
        angle_t, angle = optional[WIND_ANGLE]
        optional[WIND_ANGLE] = (angle_t, np.unwrap(angle))
    reach = {
        name: _stretch(_coverage(times, options.max_gap_s)[0], times, fix_t, options)
        for name, (times, _) in optional.items()
    }

    pieces, gaps = _coverage(fix_t, options.max_gap_s)
    all_gaps = list(gaps)
    _note_gaps(FIXES, gaps, options.max_gap_s, notes)
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

    kept: list[FloatArray] = []
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
    extrapolated = dict.fromkeys([*streams, *optional], 0.0)
    for k, time in enumerate(kept, start=1):
        sampled = {}
        for name, (times, values) in streams.items():
            sampled[name], farthest = _resample(time, times, values, options.max_gap_s)
            extrapolated[name] = max(extrapolated[name], farthest)
        columns: dict[str, FloatArray] = {}
        for name, (times, values) in optional.items():
            start, end = float(time[0]), float(time[-1])
            if not any(low <= start and end <= high for low, high in reach[name]):
                notes.append(
                    f"{name} does not cover t = {start:.1f} to {end:.1f} s (log {k}) without "
                    f"a gap of more than max_gap_s = {options.max_gap_s:g} s: left out of it"
                )
                continue
            resampled, farthest = _resample(time, times, values, options.max_gap_s)
            extrapolated[name] = max(extrapolated[name], farthest)
            field, low, high = _OPTIONAL_FIELDS[name]
            if name == WIND_ANGLE:
                resampled = np.mod(resampled, 2.0 * np.pi)
            columns[field] = np.clip(resampled, low, high)  # an extrapolation stays in bounds
        heading = sampled[HEADING] + np.interp(time, fix_t, north)
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
                rudder_rad=sampled[RUDDER],
                n_rps=sampled[RPM],
                metadata=metadata,
                wind_speed_mps=columns.get("wind_speed_mps"),
                wind_angle_rad=columns.get("wind_angle_rad"),
                stw_mps=columns.get("stw_mps"),
                stw_transverse_mps=columns.get("stw_transverse_mps"),
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
    recording: Recording,
    options: Options,
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
        f"{_printable(os.path.basename(recording.path))} ({recording.kind}), {piece}, "
        f"t = {start:.3f} to {end:.3f} s after the first fix; origin = first fix "
        f"{plane.origin_lat_deg:.7f} deg, {plane.origin_lon_deg:.7f} deg, x North y East "
        f"in an azimuthal equidistant plane on WGS84; heading from true North to the plane's "
        f"x axis; rudder positive to {options.rudder_positive} in the input{skipped}"
    )
    if options.constant_n_rps is not None:
        source += (
            f"; propeller speed {options.constant_n_rps * SECONDS_PER_MINUTE:g} rpm as given, "
            "not logged"
        )
    metadata: dict[str, str] = {}
    if options.vessel is not None:
        metadata["vessel"] = options.vessel
    if options.length_m is not None:
        metadata["length_m"] = repr(options.length_m)
    metadata.update((key, repr(value)) for key, value in options.on_board.items())
    metadata["source"] = source
    metadata["origin_lat_deg"] = repr(plane.origin_lat_deg)
    metadata["origin_lon_deg"] = repr(plane.origin_lon_deg)
    if time_origin is not None:
        metadata["time_origin_utc"] = time_origin
    metadata["projection"] = plane.proj_string
    return metadata


def _printable(text: str) -> str:
    """Make text fit a metadata value: printable characters only, stripped."""
    return "".join(c if c.isprintable() else "?" for c in text).strip()
