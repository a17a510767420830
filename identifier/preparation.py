"""The logs made ready for a fit: checked, reduced to midship, smoothed, deglitched, ordered.

Every fit starts from the same :class:`SmoothedLogs` (``identifier.identify``): the logs
checked for what no fit can mend (sampling, a ship that does not move or moves faster
than a ship, a heading, track or rudder in another convention, no straight approach
(``identifier.conventions``, which also warns of a rudder or propeller speed in another
unit), no rudder excitation; the vessel's length and name agreed), the GNSS
antenna's track reduced to midship, each log smoothed by ``identifier.smoothing`` (the
seed paper's Kalman filter and RTS smoother, with its innovation gate against GNSS
glitches) and the glitches it rejected replaced by its estimates, the spikes of the rudder
angle and the propeller speed interpolated (``trials.spikes``), and the logs ordered
for the EKF: by their largest rudder angle (:func:`ekf_order`), or as sailed for a
drifting current (:func:`sailed_order`).
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import scipy.constants

from fmu_model.environment import Windage
from fmu_model.interface import MAX_LENGTH_M, MIN_LENGTH_M, MIN_START_SPEED_MPS
from fmu_model.params import text_problem
from identifier.conventions import (
    MAX_APPROACH_YAW_RATE,
    log_problem,
    turning_yaw_rate,
    unit_warnings,
)
from identifier.current import placed_speed_log
from identifier.ekf import EkfSegment
from identifier.smoothing import SmoothedTrack, deglitched_log, smooth_track
from identifier.wind import has_wind, known_acceleration
from trials.conditions import EXECUTE_RUDDER_RAD
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, at_midship
from trials.spikes import despiked_inputs

# Sampling intervals outside this range cannot resolve ship manoeuvring dynamics [s].
MAX_SAMPLE_INTERVAL_S = 5.0
# A median interval of 10 to 1000 times that is a logger's times in milliseconds.
MILLISECONDS_PER_SECOND = 1000.0
# A sample interval below this fraction of the median one is a wrong time stamp (the
# constant-acceleration model's T² and T⁵ underflow or dwarf everything else).
MIN_SAMPLE_INTERVAL_FRACTION = 1e-6
# An interval this many times the median one is a gap in the log (dropped samples),
# noted: the smoother's motion model and the EKF's ship model bridge it.
GAP_INTERVALS = 5.0
# Plausibility of the track. No ship sails faster than this over ground [m/s] (about 97
# kn; the fastest high-speed craft make 30-40 m/s): a faster track has wrong units of
# time or position.
MAX_SPEED_OVER_GROUND_MPS = 50.0
# A log whose median smoothed speed over ground is within this many of its standard
# deviations of zero (or below the FMU's least start speed) shows a ship that does not
# move; the speed-scaled models divide by the speed.
STILL_SPEED_SIGMAS = 3.0
# Below this median Froude number U/√(gL) over ground no ship is on a manoeuvring trial
# (KVLCC2's 15.5 kn: 0.142; a VLCC at 2 kn: 0.018): the positions, times or length are
# in other units (positions in km: 0.00014).
MIN_FROUDE_NUMBER = 0.01
# Above these estimated noise levels the logger is suspect (warning) [m], [rad].
MAX_POSITION_NOISE_M = 20.0
MAX_HEADING_NOISE_RAD = math.radians(3.0)


def _log_name(log: ManeuverLog, index: int) -> str:
    return log.path or f"log {index + 1}"


def _check_sampling(log: ManeuverLog, name: str) -> str | None:
    """Reject a log sampled too coarsely or with a wrong time stamp.

    Returns the note of its gaps (:func:`_gap_note`), or None.
    """
    steps = np.diff(log.time_s)
    interval = float(np.median(steps))
    # Time stamps summed in floating point (0.1 + 0.1 + …) land a few ulps beyond a
    # round interval: a logger of exactly the limit's interval is within it.
    if interval > MAX_SAMPLE_INTERVAL_S * (1.0 + 1e-9):
        # A logger of 0.2 to 20 Hz with its times in milliseconds reads 50 to 5000 "s"; one
        # sample in 10 s is only a slow logger.
        per_ms = (
            10.0 * MAX_SAMPLE_INTERVAL_S
            <= interval
            <= MAX_SAMPLE_INTERVAL_S * MILLISECONDS_PER_SECOND * (1.0 + 1e-9)
        )
        raise IdentificationError(
            f"median sampling interval {interval:g} s is too coarse to resolve manoeuvring "
            f"(expected at most {MAX_SAMPLE_INTERVAL_S:g} s)"
            + (": is time_s in seconds, not milliseconds?" if per_ms else ""),
            log=name,
        )
    k = int(np.argmin(steps))
    if steps[k] < MIN_SAMPLE_INTERVAL_FRACTION * interval:
        raise IdentificationError(
            f"samples {k} and {k + 1} are {float(steps[k]):.3g} s apart, expected at least "
            f"{MIN_SAMPLE_INTERVAL_FRACTION:g} of the median interval ({interval:g} s): a "
            "wrong time stamp (the smoother's motion model cannot span it)",
            log=name,
            sample=k + 1,
        )
    return _gap_note(log, name, steps, interval)


def _gap_note(log: ManeuverLog, name: str, steps: np.ndarray, interval: float) -> str | None:
    """Return a note of the gaps in ``log``'s samples, or None.

    ``steps`` its sampling intervals and ``interval`` their median [s]. A gap is an
    interval of :data:`GAP_INTERVALS` median ones or more; the note names the longest.
    """
    gaps = np.flatnonzero(steps >= GAP_INTERVALS * interval * (1.0 - 1e-9))  # summed times
    if not gaps.size:
        return None
    k = int(gaps[np.argmax(steps[gaps])])
    count = "1 gap" if gaps.size == 1 else f"{gaps.size} gaps"
    longest = ":" if gaps.size == 1 else ", the longest"
    return (
        f"{name}: {count} in the samples{longest} {float(steps[k]):.3g} s from t = "
        f"{float(log.time_s[k]):.6g} s (sample {k}; the median interval {interval:.3g} s): "
        "bridged by the smoother's motion model and the EKF's ship model"
    )


def vessel_length(logs: Sequence[ManeuverLog], length_m: float | None) -> float:
    """Return the ship length: given, or from the logs' ``# length_m:`` (which must agree).

    A given length must be within the FMU's bounds, :data:`MIN_LENGTH_M` to
    :data:`MAX_LENGTH_M` [m] (the logs' are checked on reading).
    """
    if length_m is not None:
        if not MIN_LENGTH_M <= length_m <= MAX_LENGTH_M:
            raise IdentificationError(
                f"ship length must be from {MIN_LENGTH_M:g} to {MAX_LENGTH_M:g} m, got {length_m!r}"
            )
        return float(length_m)
    lengths = {log.length_m for log in logs if log.length_m is not None}
    if not lengths:
        raise IdentificationError(
            "no ship length: pass --length-m or add '# length_m:' to the logs"
        )
    if len(lengths) > 1:
        raise IdentificationError(f"the logs disagree on the ship length: {sorted(lengths)} m")
    return lengths.pop()


def vessel_name(logs: Sequence[ManeuverLog]) -> str:
    """Return the vessel of the logs' ``# vessel:`` lines (``"ship"`` when none has one).

    Raises
    ------
    IdentificationError
        If two logs name different vessels (exact text), or a name is not printable text
        (it becomes the FMU's model name).

    """
    first: dict[str, str] = {}  # vessel name → the first log naming it
    for i, log in enumerate(logs):
        name = log.metadata.get("vessel")
        if name is None:
            continue
        problem = text_problem(name)
        if problem is not None:
            raise IdentificationError(f"vessel name {name!r} {problem}", log=_log_name(log, i))
        first.setdefault(name, _log_name(log, i))
    if len(first) > 1:
        (a, log_a), (b, log_b) = list(first.items())[:2]
        raise IdentificationError(
            f"the logs are of different vessels: {a!r} ({log_a}) and {b!r} ({log_b}); "
            "identify one vessel at a time"
        )
    return next(iter(first), "ship")


def _check_track(track: SmoothedTrack, name: str, length_m: float) -> None:
    """Reject a track too fast for a ship, of a ship that does not move, or too slow for one.

    Raises
    ------
    IdentificationError
        If the smoothed speed over ground exceeds :data:`MAX_SPEED_OVER_GROUND_MPS`
        (wrong units of time or position), or its median is within
        :data:`STILL_SPEED_SIGMAS` standard deviations of zero (or below the FMU's least
        start speed, :data:`~fmu_model.interface.MIN_START_SPEED_MPS`), or its median
        Froude number for a ship of ``length_m`` [m] is below :data:`MIN_FROUDE_NUMBER`.

    """
    derived = (track.u_mps, track.v_mps, track.r_radps, track.u_std_mps, track.v_std_mps)
    if not all(np.all(np.isfinite(a)) for a in derived):
        raise IdentificationError(
            "the smoothed track is not finite (the times or positions overflow the smoother)",
            log=name,
        )
    k = int(np.argmax(track.speed_mps))
    fastest = float(track.speed_mps[k])
    if fastest > MAX_SPEED_OVER_GROUND_MPS:
        raise IdentificationError(
            f"the track implies a speed over ground of {fastest:.3g} m/s, expected at most "
            f"{MAX_SPEED_OVER_GROUND_MPS:g} m/s: check the units of time_s, x_m and y_m",
            log=name,
            sample=k,
        )
    speed = float(np.median(track.speed_mps))
    threshold = max(STILL_SPEED_SIGMAS * float(np.median(track.speed_std_mps)), MIN_START_SPEED_MPS)
    if not speed > threshold:
        raise IdentificationError(
            f"the ship does not move: its median speed over ground, {speed:.3g} m/s, is not "
            f"above {threshold:.3g} m/s ({STILL_SPEED_SIGMAS:g} standard deviations of the "
            f"smoothed speed, at least {MIN_START_SPEED_MPS:g} m/s); expected a ship under way "
            "(the models need headway)",
            log=name,
        )
    froude = speed / math.sqrt(scipy.constants.g * length_m)
    if froude < MIN_FROUDE_NUMBER:
        raise IdentificationError(
            f"the ship sails at {speed:.3g} m/s over ground in the median, a Froude number "
            f"U/sqrt(gL) of {froude:.2g} for L = {length_m:g} m, expected at least "
            f"{MIN_FROUDE_NUMBER:g} on a trial: check the units of x_m and y_m (metres), "
            "time_s (seconds) and the ship's length",
            log=name,
        )


def _velocity_std(track: SmoothedTrack, measurements: str) -> np.ndarray:
    """Return the σ of the smoothed (u, v, r) [m/s, m/s, rad/s] for the EKF, (N, 3).

    Per sample when the EKF measures the velocities. When it measures the track it
    needs them only for the velocities' initial covariance at a log's (or window's)
    start: the first sample's then stand for every sample, a read-only broadcast of one
    row (a log of a million samples is spared 24 MB).
    """
    if measurements == "velocities":
        return np.column_stack([track.u_std_mps, track.v_std_mps, track.r_std_radps])
    first = np.array([track.u_std_mps[0], track.v_std_mps[0], track.r_std_radps[0]])
    return np.broadcast_to(first, (track.n_samples, 3))


def ekf_segment(
    log: ManeuverLog,
    track: SmoothedTrack,
    name: str,
    *,
    measurements: str,
    windage: Windage | None = None,
) -> EkfSegment:
    """Return a log and its smoothed track as the EKF's segment.

    The smoothed (u, v, r) and their σ (:func:`_velocity_std`: per sample when the EKF
    measures them, ``measurements="velocities"``), the logged track as the measurement
    with the smoother's noise levels, the track's first smoothed sample as the start, the
    rudder and propeller speed, and a measured wind's known acceleration with the
    vessel's ``windage`` (``identifier.wind.known_acceleration``; None without either).
    """
    return EkfSegment(
        name=name,
        time_s=log.time_s,
        velocities=np.column_stack([track.u_mps, track.v_mps, track.r_radps]),
        velocity_std=_velocity_std(track, measurements),
        track=np.column_stack([log.x_m, log.y_m, log.heading_rad]),
        track_std=np.array(
            [track.position_noise_m, track.position_noise_m, track.heading_noise_rad]
        ),
        initial_track=np.array([track.x_m[0], track.y_m[0], track.heading_rad[0]]),
        rudder_rad=log.rudder_rad,
        n_rps=log.n_rps,
        known_acceleration=known_acceleration(log, windage),
    )


def _deglitched(
    log: ManeuverLog, track: SmoothedTrack, name: str, notes: list[str], warnings: list[str]
) -> ManeuverLog:
    """Return the log with the samples the smoother's gate rejected replaced by its track.

    The EKF and the output error measure the logged track itself: a GNSS jump the
    smoother rejected (``identifier.smoothing``, innovation gate) must not reach them.
    Adds a note of the counts, and a warning for every re-acquisition (a step in the
    fixes the smoother believed).
    """
    if track.rejected_position_samples or track.rejected_heading_samples:
        notes.append(
            f"{name}: {track.rejected_position_samples} position fixes and "
            f"{track.rejected_heading_samples} headings rejected as glitches (innovation gate)"
        )
    for what, samples in (
        ("position", track.position_reacquired),
        ("heading", track.heading_reacquired),
    ):
        for k in samples:
            warnings.append(
                f"{name}: {what} re-acquired after a jump at t = {float(log.time_s[k]):.1f} s "
                "(a step in the fixes; split the log there if it is not a receiver offset)"
            )
    return deglitched_log(log, track)


def _despiked_inputs(log: ManeuverLog, name: str, length_m: float, notes: list[str]) -> ManeuverLog:
    """Return the log with the spikes of its rudder angle and propeller speed interpolated.

    (``trials.spikes.despiked_inputs``: out and back faster than a ship of ``length_m``
    [m] moves them.) Adds a note of the counts. The log's ``length_m`` becomes the fit's,
    so that the fit's own readings of it (``trials.conditions``) judge its inputs as here,
    not by a header's length that ``--length-m`` overrides.
    """
    log, rudder, propeller = despiked_inputs(log, length_m)
    log = replace(log, metadata={**log.metadata, "length_m": repr(length_m)})
    if rudder or propeller:
        notes.append(
            f"{name}: {rudder} rudder angles and {propeller} propeller speeds taken for "
            "spikes (out and straight back faster than a ship's steering gear or engine) "
            "and interpolated"
        )
    return log


def ekf_order(logs: Sequence[ManeuverLog]) -> list[int]:
    """Return the order in which the EKF runs through ``logs`` (unless the current drifts).

    By the largest rudder angle of each log, smallest first: the EKF's coefficients are a
    random walk, so its estimate weighs the log it ends on most, and the log of the
    largest rudder angles is the nearest to the hard-over turns a model is asked to predict
    (``benchmarks/environment.md``, "The same logs in the other order": that log last
    predicted the KVLCC2 35° turn 1.6–2.8 points better in six fits of six). Logs of one
    largest angle in the order of their content (SHA-256 of the channels), so that the
    estimate is the same for the logs given in any order.
    """

    def content(log: ManeuverLog) -> str:
        channels = (log.time_s, log.x_m, log.y_m, log.heading_rad, log.rudder_rad, log.n_rps)
        digest = hashlib.sha256()
        for channel in channels:
            digest.update(np.ascontiguousarray(channel, dtype=np.float64).tobytes())
        return digest.hexdigest()

    keys = [(float(np.max(np.abs(log.rudder_rad))), content(log)) for log in logs]
    return sorted(range(len(logs)), key=keys.__getitem__)


def sailed_order(logs: Sequence[ManeuverLog]) -> tuple[list[int], list[float]]:
    """Return the order the logs were sailed in, and each one's time since the one before [s].

    By their ``time_origin_utc`` (``identifier convert`` writes it) when every log has one,
    the gaps between one's last sample and the next one's first (the first log's 0, an
    overlap's 0); else the order given, no gaps known (all 0). A drifting current walks
    through the runs and the time between them (``identifier.ekf.EkfSegment.current_gap_s``).
    """
    origins = [log.time_origin_utc for log in logs]
    if any(origin is None for origin in origins):
        return list(range(len(logs))), [0.0] * len(logs)
    first = min(o for o in origins if o is not None)
    spans = [
        ((o - first).total_seconds() + float(log.time_s[0]),
         (o - first).total_seconds() + float(log.time_s[-1]))
        for o, log in zip(origins, logs, strict=True) if o is not None
    ]  # fmt: skip
    order = sorted(range(len(logs)), key=lambda i: spans[i][0])
    gaps = [0.0] + [max(spans[b][0] - spans[a][1], 0.0) for a, b in itertools.pairwise(order)]
    return order, gaps


def _check_conventions(log: ManeuverLog, track: SmoothedTrack, name: str, length_m: float) -> None:
    """Reject a log in another convention, or without a straight approach.

    Raises
    ------
    IdentificationError
        Of :func:`identifier.conventions.log_problem` (the heading against the course
        over ground, a ship that turns against its rudder, an approach that turns; a
        ship of ``length_m`` [m]), at its sample.

    """
    found = log_problem(log, length_m, track)
    if found is not None:
        raise IdentificationError(found[0], log=name, sample=found[1])


def _check_rudder(
    logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack], length_m: float
) -> None:
    """Reject logs in which the rudder never leaves midship (nothing to identify).

    When the ship turns all the same (``identifier.conventions.turning_yaw_rate`` of the
    smoothed ``tracks``, a ship of ``length_m`` [m]), the message asks for the rudder's
    unit and sensor.
    """
    if any(np.max(np.abs(log.rudder_rad)) > EXECUTE_RUDDER_RAD for log in logs):
        return
    limit = math.degrees(EXECUTE_RUDDER_RAD)
    where = "the log" if len(logs) == 1 else "every log"
    turning = turning_yaw_rate(tracks, length_m)
    unit = (
        f"; the ship turns at r' up to {turning:.2f} all the same: is rudder_deg in degrees, "
        "and its sensor alive?"
        if turning > MAX_APPROACH_YAW_RATE
        else ""
    )
    raise IdentificationError(
        f"no rudder excitation: nothing to identify (the rudder stays within ±{limit:g} deg "
        f"in {where}); expected a manoeuvre: a zig-zag or a turning circle{unit}",
        log=_log_name(logs[0], 0) if len(logs) == 1 else None,
    )


@dataclass(frozen=True)
class SmoothedLogs:
    """The logs as given, deglitched, smoothed and as EKF segments: what every fit starts from.

    Every tuple is in the order the EKF runs through the logs (:func:`ekf_order`, or the
    order sailed with a drifting current); ``names`` keep the places given ("log 2").

    Smoothing depends on the logs and the noise settings only, not on the model, so a
    refit (``identify``'s thrust rule) starts from the same.
    """

    given: tuple[ManeuverLog, ...]
    logs: tuple[ManeuverLog, ...]  # the glitches replaced by the smoother's estimates
    tracks: tuple[SmoothedTrack, ...]
    segments: tuple[EkfSegment, ...]
    warnings: tuple[str, ...]
    notes: tuple[str, ...]

    @property
    def names(self) -> tuple[str, ...]:
        """The logs' names (paths, or "log k" by the place given), in the EKF's order."""
        return tuple(segment.name for segment in self.segments)


def smooth_logs(
    logs: Sequence[ManeuverLog],
    *,
    length_m: float,
    position_noise_m: float | None,
    heading_noise_rad: float | None,
    measurements: str,
    windage: Windage | None,
    drifting: bool,
    progress: Callable[[int], None] | None,
    stage: Callable[[str], None],
) -> SmoothedLogs:
    """Check, smooth and deglitch every log; warn of what the fits cannot fix.

    ``length_m``: the ship's [m], which sets how fast its inputs can change
    (``trials.spikes``); ``position_noise_m``, ``heading_noise_rad``: the logger's
    noise (None: estimated from the logs, ``identifier.smoothing.smooth_track``);
    ``measurements``: what the EKF measures ("track" or "velocities"); ``windage``: the
    vessel's, to take a measured wind's load out; ``drifting``: order the logs as sailed
    (a drifting current's random walk runs through them in time), else by
    :func:`ekf_order`. ``progress`` is called with each log's samples, ``stage`` with
    "smoothing <log>".
    """
    warnings: list[str] = []
    notes: list[str] = []
    tracks: list[SmoothedTrack] = []
    segments: list[EkfSegment] = []
    cleaned = []
    for i, given in enumerate(logs):
        name = _log_name(given, i)
        log = at_midship(given)  # the GNSS antenna's track reduced to the model's origin
        if log is not given:
            along, across = (given.on_board_m(key) or 0.0 for key in ("gnss_x_m", "gnss_y_m"))
            notes.append(
                f"{name}: positions reduced to midship from the GNSS antenna's, "
                f"{abs(along):g} m {'aft' if along < 0.0 else 'forward'} and "
                f"{abs(across):g} m to {'port' if across < 0.0 else 'starboard'}"
            )
        if log.filled:
            cells = ", ".join(f"{count} of {column}" for column, count in log.filled.items())
            notes.append(
                f"{name}: cells without a value ({cells}), a sensor's dropout, interpolated"
            )
        if (gaps_note := _check_sampling(log, name)) is not None:
            notes.append(gaps_note)
        stage(f"smoothing {Path(name).name}")
        track = smooth_track(
            log.time_s,
            log.x_m,
            log.y_m,
            log.heading_rad,
            position_noise_m=position_noise_m,
            heading_noise_rad=heading_noise_rad,
        )
        _check_track(track, name, length_m)
        log = _deglitched(log, track, name, notes, warnings)
        log = _despiked_inputs(log, name, length_m, notes)
        _check_conventions(log, track, name, length_m)
        if (placed := placed_speed_log(log)) is not log:
            warnings.append(
                f"{name}: the speed log's transverse axis (stw_transverse_mps) was not used: "
                "its position is not given (metadata speed_log_x_m, metres forward of "
                "midship: there the sway speed is v + x·r)"
            )
            log = placed
        cleaned.append(log)
        if track.position_noise_m > MAX_POSITION_NOISE_M:
            warnings.append(
                f"{name}: position noise {track.position_noise_m:.1f} m is unusually high"
            )
        if track.heading_noise_rad > MAX_HEADING_NOISE_RAD:
            warnings.append(
                f"{name}: heading noise {math.degrees(track.heading_noise_rad):.2f} deg "
                "is unusually high"
            )
        tracks.append(track)
        segments.append(ekf_segment(log, track, name, measurements=measurements, windage=windage))
        if progress is not None:
            progress(log.n_samples)

    _check_rudder(cleaned, tracks, length_m)
    warnings.extend(unit_warnings(cleaned, tracks, [s.name for s in segments], length_m))
    with_wind = [_log_name(log, i) for i, log in enumerate(cleaned) if has_wind(log)]
    if with_wind and windage is None:
        warnings.append(
            f"{len(with_wind)} of {len(cleaned)} logs carry a measured wind, but no windage was "
            "given: its load stays in the coefficients (give --windage FILE.json)"
        )
    # A drifting current's random walk runs through the logs in the order they were sailed.
    if drifting:
        order, gaps = sailed_order(cleaned)
        for i, gap in zip(order, gaps, strict=True):
            segments[i] = replace(segments[i], current_gap_s=gap)
    else:
        order = ekf_order(cleaned)
    names = ", ".join(Path(segments[i].name).name for i in order)
    if drifting and order != sorted(order):
        notes.append(f"the EKF runs through the logs in the order sailed (their times): {names}")
    elif order != sorted(order):
        notes.append(
            f"the EKF runs through the logs by their largest rudder angle, smallest first "
            f"(its estimate weighs the last most): {names}"
        )
    return SmoothedLogs(
        given=tuple(logs[i] for i in order),
        logs=tuple(cleaned[i] for i in order),
        tracks=tuple(tracks[i] for i in order),
        segments=tuple(segments[i] for i in order),
        warnings=tuple(warnings),
        notes=tuple(notes),
    )
