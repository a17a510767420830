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
  radians under ``heading_deg`` 1/57.3.
  :func:`heading_course_problem` rejects a slope outside
  [:data:`MIN_HEADING_PER_COURSE`, :data:`MAX_HEADING_PER_COURSE`], judged when the
  course spreads over :data:`MIN_COURSE_SPREAD_RAD` or more.
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

Each check returns a one-line message (what is wrong and what was expected) or None.
"""

from __future__ import annotations

import math

import numpy as np

from identifier.smoothing import SmoothedTrack, wrap_angle
from trials.conditions import execute_index
from trials.logs import ManeuverLog

__all__ = [
    "MAX_HEADING_PER_COURSE",
    "MAX_MEDIAN_DRIFT_RAD",
    "MIN_COMMAND_RAD",
    "MIN_COURSE_SPREAD_RAD",
    "MIN_HEADING_PER_COURSE",
    "MIN_TURN_RAD",
    "heading_course_problem",
    "rudder_side_problem",
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

MAX_MEDIAN_DRIFT_RAD = math.radians(45.0)
"""Largest median angle between the course over ground and the heading [rad]."""

MIN_COMMAND_RAD = math.radians(5.0)
"""Least rudder command whose side the turn is judged by [rad]."""

MIN_TURN_RAD = math.radians(5.0)
"""Least heading change against the rudder that rejects a log [rad]."""

_EXPECTED_FRAME = "expected x_m North, y_m East and heading_deg clockwise from North"


def _under_way(track: SmoothedTrack) -> np.ndarray:
    """Return the samples at half the median speed over ground or more (a course to speak of)."""
    speed = np.asarray(track.speed_mps)
    return speed >= 0.5 * float(np.median(speed))


def heading_course_problem(track: SmoothedTrack) -> str | None:
    """Return what is wrong with the heading against the course over ground, or None.

    The slope of the heading on the course, and the median angle between them (module
    notes), over the samples under way of the smoothed ``track``.
    """
    moving = _under_way(track)
    course = np.unwrap(np.asarray(track.course_rad))[moving]
    heading = np.asarray(track.heading_rad)[moving]
    if float(np.std(course)) >= MIN_COURSE_SPREAD_RAD:
        dc = course - course.mean()
        slope = float(np.dot(heading - heading.mean(), dc) / np.dot(dc, dc))
        if slope < 0.0:
            return (
                f"the heading turns against the course over ground (slope {slope:.2f}): "
                f"a heading counter-clockwise, or x_m and y_m swapped? {_EXPECTED_FRAME}"
            )
        if not MIN_HEADING_PER_COURSE <= slope <= MAX_HEADING_PER_COURSE:
            return (
                f"the heading turns {slope:.3g} times as far as the course over ground, "
                f"expected about once: is heading_deg in degrees?"
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


def rudder_side_problem(log: ManeuverLog, track: SmoothedTrack) -> tuple[str, int] | None:
    """Return what is wrong with the rudder's sign and the sample its command began, or None.

    The heading change of the smoothed ``track`` under the first rudder command of
    :data:`MIN_COMMAND_RAD` or more after execute, from the sample it began (the rudder
    leaving its approach angle to that side) to its first return past that angle,
    against the command's side (module notes). Smaller movements before it (an
    autopilot's) are not commands.
    """
    k = execute_index(log)
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
