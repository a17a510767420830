"""A trial log's conventions checked against its own motion, before any fit.

DESIGN.md's conventions: x North, y East, the heading clockwise from North, a positive
rudder angle turning the ship to starboard. Logs in other conventions are to be converted
at reading (``identifier convert``'s options), but a log written by another tool may come
in any of them, and a fit on it either fails deep inside (a traceback from a virtual turn
that never gets under way) or, worse, writes a model (a rudder of the wrong sign turns
it the wrong way; a heading counter-clockwise gives a phantom current of 0.6 m/s on the
KVLCC2 zig-zags). The log's motion tells each of these apart from a real ship's:

- **The course over ground turns with the heading.** Over a manoeuvre the heading ψ and
  the course χ change together, χ = ψ + β with the drift angle β small and, in a zig-zag,
  out of phase with ψ; in a current of speed c the crab angle adds at most a share c/U
  either way. The least-squares slope of ψ on χ is then about 1/(1 ± c/U), about 1 but
  where the current is as fast as the ship. A heading counter-clockwise, or x and y
  swapped (one frame mirrored against the other), makes it −1; a heading logged in
  radians under ``heading_deg`` 1/57.3, a frozen sensor's 0.
  :func:`heading_course_problem` rejects a slope whose size is outside
  [:data:`MIN_HEADING_PER_COURSE`, :data:`MAX_HEADING_PER_COURSE`] (a frozen sensor's
  −0.001 is no mirror), then a negative one, judged when the course spreads over
  :data:`MIN_COURSE_SPREAD_RAD` or more on the samples under way (their speed at least
  :data:`UNDER_WAY_SPEED_SIGMAS` of its σ: a ship at her berth has a course of noise).
- **The heading points along the track.** The median of |χ − ψ| over the samples under
  way is a ship's drift angle or crab, tens of degrees at the very most; a heading
  measured from East, or a heading sensor mounted across the ship without its offset,
  makes it about 90°. Rejected above :data:`MAX_MEDIAN_DRIFT_RAD`.
- **The ship turns to the side of its rudder.** Under the first rudder command of
  :data:`MIN_COMMAND_RAD` or more after execute (smaller ones, an autopilot's, are not
  judged: below it a directionally unstable ship may turn against its rudder), from the
  sample the rudder left its approach angle to that side to its first return past
  that angle (a zig-zag's first reversal: the heading has then reached the switch angle
  on the rudder's side; a turning circle's end), the heading changes to the command's
  side. :func:`rudder_side_problem` rejects a change of at least :data:`MIN_TURN_RAD`
  to the other side.
- **A manoeuvre starts from a straight approach** (ITTC, IMO: the execute point ends a
  steady straight run). The nominal speed, the current's start and the approach's helm
  come from the samples before execute; a log cut after it (a turn from its first
  sample, whose rudder then never moves and whose "approach" is the whole log) gave the
  KVLCC2 a phantom current of 0.95 m/s. :func:`approach_problem` rejects an approach whose
  median non-dimensional yaw rate r′ = |r| L / U exceeds :data:`MAX_APPROACH_YAW_RATE`
  (every reference log's and HSVA run's is below 0.004, a 35° turn's about 0.9).

Each check returns a one-line message (what is wrong and what was expected) or None;
:func:`log_problem` the first of them and its sample (``identifier fit`` and the
scenarios' ``--like`` raise it).
Two units are judged but only warned of (:func:`unit_warnings`), for a real ship may
come near: a rudder of at most :data:`RUDDER_UNIT_MAX_RAD` in every log while the ship
turns at r′ above :data:`HARD_TURN_YAW_RATE` (radians under ``rudder_deg``: a 35° turn's
rudder reads 0.6°; a directionally unstable ship in a spiral test turns at small
angles), and a ship that advances more than :data:`MAX_ADVANCE_PER_REVOLUTION_L` of its
length per propeller revolution in the median (rev/s under ``rpm``: 0.34 L in the
KVLCC2's turn, 0.78 L in its zig-zag, whose own 0.006–0.013 L, the Mariner's
0.022–0.028 L and the HSVA model's 0.012–0.016 L are a propeller's pitch, about its
diameter; a fast craft's a few times the Mariner's). A model fitted in either unit is
consistent in it, but the scenarios and the FMU read degrees and rpm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import scipy.constants

from identifier.smoothing import SmoothedTrack, smooth_log, wrap_angle
from trials.conditions import execute_index
from trials.logs import ManeuverLog

__all__ = [
    "HARD_TURN_YAW_RATE",
    "MAX_ADVANCE_PER_REVOLUTION_L",
    "MAX_APPROACH_YAW_RATE",
    "MAX_HEADING_PER_COURSE",
    "MAX_MEDIAN_DRIFT_RAD",
    "MIN_COMMAND_RAD",
    "MIN_COURSE_SPREAD_RAD",
    "MIN_HEADING_PER_COURSE",
    "MIN_TURN_RAD",
    "RUDDER_UNIT_MAX_RAD",
    "UNDER_WAY_SPEED_SIGMAS",
    "approach_problem",
    "heading_course_problem",
    "log_problem",
    "rudder_side_problem",
    "turning_yaw_rate",
    "unit_warnings",
    "yaw_rate_prime",
]

MIN_COURSE_SPREAD_RAD = math.radians(3.0)
"""Standard deviation of the course over ground below which the heading's turning is not
judged (a straight run's course is noise)."""

MIN_HEADING_PER_COURSE = 0.1
"""Least slope of the heading on the course over ground of a log in the conventions:
0.87–1.18 on the KVLCC2's zig-zags and turns in 1 m/s of current, 0.45–3.1 on its 7 m
model's in 0.6 m/s, half its approach speed (in the turn it slows to about the current's
speed); a heading in radians under ``heading_deg`` gives 0.017."""

MAX_HEADING_PER_COURSE = 10.0
"""Largest such slope (a heading in degrees read as radians: 57)."""

UNDER_WAY_SPEED_SIGMAS = 3.0
"""Least speed over ground, in standard deviations of the smoothed speed, of a sample whose
course is judged."""

MAX_MEDIAN_DRIFT_RAD = math.radians(45.0)
"""Largest median angle between the course over ground and the heading [rad]."""

MIN_COMMAND_RAD = math.radians(5.0)
"""Least rudder command whose side the turn is judged by [rad]."""

MIN_TURN_RAD = math.radians(5.0)
"""Least heading change against the rudder that rejects a log [rad]."""

MAX_APPROACH_YAW_RATE = 0.05
"""Largest median r′ = |r| L / U of the approach before execute (a circle of 40 L)."""

RUDDER_UNIT_MAX_RAD = math.radians(2.0)
"""Largest rudder angle [rad] of logs with a hard turn that is warned of (radians read as
degrees?)."""

HARD_TURN_YAW_RATE = 0.3
"""r′ of a hard turn, which such a rudder does not give."""

MAX_ADVANCE_PER_REVOLUTION_L = 0.1
"""Largest median speed over ground per propeller revolution, in ship lengths, not warned
of (rev/s read as rpm?)."""

_EXPECTED_FRAME = "expected x_m North, y_m East and heading_deg clockwise from North"


def yaw_rate_prime(track: SmoothedTrack, length_m: float) -> np.ndarray:
    """Return r′ = |r| L / U over ground of every sample of ``track``."""
    speed = np.maximum(np.asarray(track.speed_mps), np.finfo(float).tiny)
    return np.abs(np.asarray(track.r_radps)) * length_m / speed


def _under_way(track: SmoothedTrack) -> np.ndarray:
    """Return the samples with a course to speak of.

    At half the median speed over ground or more, and :data:`UNDER_WAY_SPEED_SIGMAS`
    standard deviations of the smoothed speed (a ship at her berth has a course of noise).
    """
    speed = np.asarray(track.speed_mps)
    known = speed >= UNDER_WAY_SPEED_SIGMAS * np.asarray(track.speed_std_mps)
    return known & (speed >= 0.5 * float(np.median(speed)))


def heading_course_problem(track: SmoothedTrack) -> str | None:
    """Return what is wrong with the heading against the course over ground, or None.

    The slope of the heading on the course, and the median angle between them (module
    notes), over the samples under way of the smoothed ``track``.
    """
    moving = _under_way(track)
    if np.count_nonzero(moving) < 2:
        return None  # no course to speak of
    course = np.unwrap(np.asarray(track.course_rad))[moving]
    heading = np.asarray(track.heading_rad)[moving]
    if float(np.std(course)) >= MIN_COURSE_SPREAD_RAD:
        dc = course - course.mean()
        slope = float(np.dot(heading - heading.mean(), dc) / np.dot(dc, dc))
        if not MIN_HEADING_PER_COURSE <= abs(slope) <= MAX_HEADING_PER_COURSE:
            return (
                f"the heading turns {slope:.3g} times as far as the course over ground, "
                f"expected about once: is heading_deg in degrees, and its sensor not frozen?"
            )
        if slope < 0.0:
            return (
                f"the heading turns against the course over ground (slope {slope:.2f}): "
                f"a heading counter-clockwise, or x_m and y_m swapped? {_EXPECTED_FRAME}"
            )
    drift = float(np.median(np.abs(wrap_angle(np.asarray(track.drift_rad)[moving]))))
    if drift > MAX_MEDIAN_DRIFT_RAD:
        return (
            f"the heading is {math.degrees(drift):.0f} deg off the course over ground in the "
            f"median, expected at most {math.degrees(MAX_MEDIAN_DRIFT_RAD):.0f} deg (a drift "
            f"angle or crab): a heading from East, or a heading sensor's mounting offset? "
            f"{_EXPECTED_FRAME}"
        )
    return None


def rudder_side_problem(
    log: ManeuverLog, track: SmoothedTrack, execute: int
) -> tuple[str, int] | None:
    """Return what is wrong with the rudder's sign and the sample its command began, or None.

    The heading change of the smoothed ``track`` under the first rudder command of
    :data:`MIN_COMMAND_RAD` or more after the ``execute`` sample
    (:func:`trials.conditions.execute_index`), from the sample it began (the rudder
    leaving its approach angle to that side) to its first return past that angle,
    against the command's side (module notes). Smaller movements before it (an
    autopilot's) are not commands.
    """
    k = execute
    helm = np.asarray(log.rudder_rad) - log.rudder_rad[max(k - 1, 0)]  # from the approach's
    commands = np.flatnonzero(np.abs(helm[k:]) >= MIN_COMMAND_RAD)
    if not commands.size:
        return None
    first = k + int(commands[0])
    side = math.copysign(1.0, helm[first])
    other_side = np.flatnonzero(side * helm[k:first] <= 0.0)
    start = k + int(other_side[-1]) + 1 if other_side.size else k
    back = np.flatnonzero(side * helm[first:] < 0.0)
    end = first + int(back[0]) if back.size else helm.size - 1
    heading = np.asarray(track.heading_rad)
    turn = float(heading[end] - heading[start])
    if side * turn > -MIN_TURN_RAD:
        return None
    command = float(np.max(side * helm[first : end + 1]))
    to, against = ("starboard", "port") if side > 0.0 else ("port", "starboard")
    return (
        f"the ship turns {math.degrees(abs(turn)):.0f} deg to {against} under its first "
        f"rudder command, {math.degrees(command):.0f} deg to {to}: expected a positive "
        "rudder_deg to turn it to starboard (identifier convert --rudder-positive port "
        "flips a log's sign)",
        start,
    )


def approach_problem(
    log: ManeuverLog, track: SmoothedTrack, length_m: float, execute: int
) -> tuple[str, int] | None:
    """Return what is wrong with the approach before execute and the execute sample, or None.

    The median r′ of the smoothed ``track`` before the ``execute`` sample
    (:func:`trials.conditions.execute_index`) against :data:`MAX_APPROACH_YAW_RATE`
    (module notes); ``length_m`` the ship's [m].
    """
    k = execute
    if k < 1:
        return None
    turning = float(np.median(yaw_rate_prime(track, length_m)[:k]))
    if turning <= MAX_APPROACH_YAW_RATE:
        return None
    never = " (its rudder never moves)" if k == log.n_samples - 1 else ""
    return (
        f"the approach before execute turns at r' {turning:.2f} in the median (|r| L/U), "
        f"expected a straight run (at most {MAX_APPROACH_YAW_RATE:g}): a log that starts "
        f"after execute{never}? The nominal speed and the current's start come from the "
        "approach",
        k,
    )


def log_problem(
    log: ManeuverLog, length_m: float | None, track: SmoothedTrack | None = None
) -> tuple[str, int | None] | None:
    """Return the first problem of ``log`` and its sample (None: of the whole log), or None.

    The heading against the course, the rudder's side and, for a ship of ``length_m``
    [m] (None: not judged, as for a recording's pieces, which need not be manoeuvres),
    the approach, in that order; ``track`` the log's smoothed track (default: smoothed
    here, with the noise estimated).
    """
    if track is None:
        track = smooth_log(log)
    heading = heading_course_problem(track)
    if heading is not None:
        return heading, None
    execute = execute_index(log)
    rudder = rudder_side_problem(log, track, execute)
    if rudder is not None or length_m is None:
        return rudder
    return approach_problem(log, track, length_m, execute)


def turning_yaw_rate(tracks: Sequence[SmoothedTrack], length_m: float) -> float:
    """Return the largest r′ = |r| L / U of the smoothed ``tracks`` under way (L = ``length_m``)."""
    return max(
        float(np.max(yaw_rate_prime(track, length_m)[_under_way(track)])) for track in tracks
    )


def unit_warnings(
    logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack], names: Sequence[str],
    length_m: float,
) -> list[str]:  # fmt: skip
    """Return warnings of a rudder angle in radians or a propeller speed in rev/s.

    Judged on the logs together (the rudder) and on each (the propeller) as the module
    notes say; ``names`` the logs' for the messages, ``length_m`` the ship's [m].
    """
    warnings = []
    rudder_rad = max(float(np.max(np.abs(log.rudder_rad))) for log in logs)
    yaw_rate = turning_yaw_rate(tracks, length_m)
    if rudder_rad < RUDDER_UNIT_MAX_RAD and yaw_rate > HARD_TURN_YAW_RATE:
        warnings.append(
            f"the rudder reaches at most {math.degrees(rudder_rad):.2f} deg while the ship "
            f"turns at r' up to {yaw_rate:.2f}: is rudder_deg in degrees? (radians read as "
            "degrees are 57 times too small; the scenarios and the FMU read degrees)"
        )
    for log, track, name in zip(logs, tracks, names, strict=True):
        n_rps = float(np.median(log.n_rps))
        if n_rps <= 0.0:
            continue
        advance = float(np.median(track.speed_mps)) / (n_rps * length_m)
        if advance > MAX_ADVANCE_PER_REVOLUTION_L:
            rpm = n_rps * scipy.constants.minute
            warnings.append(
                f"{name}: the ship advances {advance:.2f} L per propeller revolution at "
                f"{rpm:.3g} rpm, expected at most {MAX_ADVANCE_PER_REVOLUTION_L:g} L "
                "(about a propeller's diameter): is rpm in revolutions per minute? (the "
                "scenarios and the FMU's propeller_rpm then take the logs' unit)"
            )
    return warnings
