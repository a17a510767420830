"""What a logged manoeuvre was, and the condition it was sailed in, read from the log.

A prediction compares like with like only when the model sails the manoeuvre the ship
sailed: the same approach speed and propeller speed, the same rudder amplitude and
steering-gear rate, and, in a zig-zag, the rudder reversed at the heading the helmsman
(or the autopilot) reversed it, which is not exactly the nominal check angle (HSVA's
KVLCC2 model reversed 0.13–0.22 s late, at 10.6–11.3° instead of 10°). This module
reads all of that from the log (:func:`logged_condition`), so that
``trials.run.run_program`` can sail it closed-loop, and the manoeuvre's indices are
then measured on both with the same definitions (``trials.metrics``).

Definitions (after the SIMMAN 2008 conversions in ``../shared/data/hsva_kvlcc2``):

* execute: the start of the first rudder movement (:func:`execute_index`);
* approach speed: the speed over ground at execute of a parabola in time fitted by
  least squares to the positions before execute (at least :data:`MIN_APPROACH_SAMPLES`
  samples; a straight line below :data:`MIN_PARABOLA_SAMPLES`);
* rudder rate: the mean over the rudder transitions of 0.8·|step| / (t₉₀ − t₁₀), the
  10 % and 90 % crossings interpolated linearly between samples;
* switch headings: |ψ − ψ₀| at each reversal, i.e. when the rudder is
  :data:`REVERSAL_RUDDER_RAD` away from its plateau towards the other side;
* nominal check angle Z: the whole multiple of 5° nearest the mean switch heading
  when within :data:`NOMINAL_SNAP_RAD` of it (standard zig-zags are 5°, 10°, 20°, …),
  else the nearest whole degree; a ``zigzag-δ-Z`` in the source or file name wins.
"""

from __future__ import annotations

import itertools
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.ndimage import median_filter

from trials.errors import IdentificationError
from trials.logs import ManeuverLog, at_midship
from trials.maneuvers import Leg, Program, Until, turning_circle
from trials.metrics import MetricsError, turning_metrics, zigzag_metrics
from trials.run import Plant, run_batch
from trials.spikes import despiked_inputs
from trials.trajectory import trajectory_of

KINDS = ("turning", "zigzag")
EXECUTE_RUDDER_RAD = math.radians(0.5)
"""Rudder movement from its first value that marks the execute point [rad]."""
RUDDER_STEP_RAD = math.radians(0.01)
"""A rudder change between two samples that counts as moving [rad]."""
REVERSAL_RUDDER_RAD = math.radians(1.0)
"""Rudder movement away from a plateau that marks a reversal [rad]."""
TURN_BEFORE_REVERSAL_RAD = math.radians(90.0)
"""Heading change under the first command beyond which a later counter-rudder steadies a
turning circle rather than reversing a zig-zag [rad] (zig-zags reverse at 5–20°, a
turning circle runs through 540°)."""
NOMINAL_SNAP_RAD = math.radians(1.5)
"""Largest distance of the mean switch heading from a multiple of 5° read as that angle."""
MIN_APPROACH_SAMPLES = 3
"""Fewest samples of the approach fit for the approach speed."""
MIN_PARABOLA_SAMPLES = 6
"""Fewest approach samples for a parabola rather than a straight line."""
DIVERGENCE_FACTOR = 5.0
"""A ship sailing a logged manoeuvre again diverges above 5 × the approach speed [-]."""
MODEL_SCALE_MAX_LENGTH_M = 20.0
"""Ships shorter than this [m] are taken for tank models (HSVA's KVLCC2 model: 7 m): warned
about where a full-scale default does not fit them (the steering-gear rate of the
scenarios, a current estimated in a basin's still water)."""

_ZIGZAG_ANGLES = re.compile(r"zig[-_ ]?zag[-_ ]?(\d+(?:\.\d+)?)[-_/](\d+(?:\.\d+)?)", re.I)
# ``identifier convert`` names its outputs <input stem>_<k>.csv (k = 1, 2, ...: the pieces
# between gaps), so a ``_<digits>`` just before ``.csv`` is a piece number, not an angle.
_PIECE_SUFFIX = re.compile(r"_\d+(?=\.csv\Z)", re.IGNORECASE)


@dataclass(frozen=True)
class LoggedCondition:
    """A logged manoeuvre as a program, and the condition to sail it in.

    Attributes
    ----------
    program : Program
        The manoeuvre from execute on; a zig-zag's legs reverse at the logged switch
        headings (later legs at their mean), its ``heading_rad`` is the nominal Z.
    speed_mps : float
        Approach speed over ground [m/s].
    n_rps : float
        Mean propeller speed of the approach [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    execute_time_s : float
        Log time of the execute point [s].
    switch_headings_rad : tuple of float
        |ψ − ψ₀| at each logged rudder reversal [rad] (empty for a turning circle).

    """

    program: Program
    speed_mps: float
    n_rps: float
    rudder_rate_radps: float
    execute_time_s: float
    switch_headings_rad: tuple[float, ...] = ()


def _name(log: ManeuverLog) -> str:
    return log.path or "log"


def execute_index(log: ManeuverLog) -> int:
    """Index of the execute sample: the start of the first rudder command.

    From the log's ``# execute_time_s:`` when given (the last sample not after it),
    else the first sample of the rudder movement that takes it more than
    :data:`EXECUTE_RUDDER_RAD` from its first value (its spikes interpolated,
    ``trials.spikes``); the last sample when it never moves.
    """
    return _execute_index(despiked_inputs(log)[0])


def _execute_index(log: ManeuverLog) -> int:
    """:func:`execute_index` of a log whose spikes are interpolated already."""
    text = log.metadata.get("execute_time_s")
    if text is not None:
        try:
            t_exec = float(text)
        except ValueError:
            t_exec = math.nan
        if math.isfinite(t_exec) and log.time_s[0] <= t_exec <= log.time_s[-1]:
            # 1 µs of slack: sample times are often sums of float steps.
            return int(np.searchsorted(log.time_s, t_exec + 1e-6, side="right")) - 1
    rudder = log.rudder_rad
    moved = np.flatnonzero(np.abs(rudder - rudder[0]) > EXECUTE_RUDDER_RAD)
    if not moved.size:
        return log.n_samples - 1
    k = int(moved[0])
    return movement_start(rudder, k, math.copysign(1.0, rudder[k] - rudder[0]))


def movement_start(rudder_rad: np.ndarray, k: int, sign: float, first: int = 0) -> int:
    """Return the first sample of the rudder movement that reaches sample ``k``.

    Back from ``k`` while the rudder was already moving to the side of ``sign`` (+1
    starboard, −1 port) by more than :data:`RUDDER_STEP_RAD` a sample, not before sample
    ``first`` + 1: the execute point of a command first seen at ``k``.
    """
    while k > first + 1 and sign * (rudder_rad[k - 1] - rudder_rad[k - 2]) > RUDDER_STEP_RAD:
        k -= 1
    return k


def _first_side(log: ManeuverLog, k: int) -> float:
    """+1 when the rudder first goes to starboard after execute, −1 to port."""
    after = log.rudder_rad[k:] - log.rudder_rad[0]
    moved = np.flatnonzero(np.abs(after) > EXECUTE_RUDDER_RAD)
    return 1.0 if not moved.size or after[moved[0]] > 0.0 else -1.0


def steady_heading(log: ManeuverLog) -> np.ndarray:
    """Return the log's heading [rad] through a five-sample median: a spike is no swing.

    How a manoeuvre's kind and reversals read the heading here, and which sides a log
    turns to (``identifier.diagnostics.logged_side``).
    """
    return np.asarray(median_filter(log.heading_rad, size=5, mode="nearest"))


def _reversals(log: ManeuverLog, k: int, sign: float, heading: np.ndarray) -> np.ndarray:
    """Return the samples (≥ k) at which the rudder has left a plateau for the other side.

    A plateau is the extreme rudder angle reached on one side; the rudder has left it
    when it is :data:`REVERSAL_RUDDER_RAD` back from it towards the other side, and it
    goes on past midship to that side by as much before it turns back, with the heading
    off its execute value to the side the rudder left by half the first reversal's switch
    heading or more (a zig-zag reverses at ±Z in turn). The reversals end at the first
    that is not one: a return to midship (a zig-zag ended, the log's straight run after
    it), or a helmsman steadying the ship about the heading where the zig-zag ended.
    ``heading``: :func:`steady_heading` of the log [rad].
    """
    out = []
    side = sign
    extreme = -math.inf
    for i in range(k, log.n_samples):
        toward = side * float(log.rudder_rad[i])
        if toward > extreme:
            extreme = toward
        elif extreme > REVERSAL_RUDDER_RAD and extreme - toward > REVERSAL_RUDDER_RAD:
            out.append(i)
            side = -side
            extreme = side * float(log.rudder_rad[i])
    heading = heading - heading[k]
    first_switch = sign * float(heading[out[0]]) if out else 0.0
    for j, i in enumerate(out):
        to_side = -sign if j % 2 == 0 else sign
        end = out[j + 1] if j + 1 < len(out) else log.n_samples
        past_midship = float(np.max(to_side * log.rudder_rad[i:end])) > REVERSAL_RUDDER_RAD
        at_check = -to_side * float(heading[i]) >= 0.5 * first_switch
        if not (past_midship and at_check):
            return np.array(out[:j], dtype=int)
    return np.array(out, dtype=int)


def maneuver_kind(log: ManeuverLog) -> str | None:
    """Return ``"turning"`` or ``"zigzag"`` from the rudder, None when it never moves.

    A log whose rudder goes to the other side (more than :data:`REVERSAL_RUDDER_RAD`
    past midship) after its first command is a zig-zag; one whose rudder is put over
    and held (or returned to midship, or sent to the other side only after the heading
    turned :data:`TURN_BEFORE_REVERSAL_RAD` or more: a turn steadied after it) is a
    turning circle. The data decide, not the file name or the ``# source:`` text (HSVA's
    source says "turns the ship to port" of a zig-zag). The rudder's spikes are
    interpolated first (``trials.spikes``), the heading taken through a five-sample
    median.
    """
    despiked = despiked_inputs(log)[0]
    return _maneuver_kind(despiked, steady_heading(despiked))


def _maneuver_kind(log: ManeuverLog, heading: np.ndarray) -> str | None:
    """:func:`maneuver_kind` of a log whose spikes are interpolated already.

    ``heading``: :func:`steady_heading` of the log [rad].
    """
    k = _execute_index(log)
    if k >= log.n_samples - 1:
        return None
    sign = _first_side(log, k)
    to_the_other_side = np.flatnonzero(sign * log.rudder_rad[k:] < -REVERSAL_RUDDER_RAD)
    if not to_the_other_side.size:
        return "turning"
    turned = sign * (heading[k : k + int(to_the_other_side[0]) + 1] - heading[k])
    return "turning" if float(np.max(turned)) >= TURN_BEFORE_REVERSAL_RAD else "zigzag"


def _nominal_check(switch_rad: float) -> float:
    """Return the standard check angle a switch heading stands for (module docstring)."""
    five = math.radians(5.0)
    snapped = five * round(switch_rad / five)
    if snapped > 0.0 and abs(switch_rad - snapped) <= NOMINAL_SNAP_RAD:
        return snapped
    return math.radians(max(round(math.degrees(switch_rad)), 1))


def _crossing_time(time_s: np.ndarray, signal: np.ndarray, level: float, start: int) -> float:
    """First time from sample ``start`` on that ``signal`` reaches ``level`` (interpolated).

    ``signal`` rises towards ``level``; NaN when it never reaches it.
    """
    above = np.flatnonzero(signal[start:] >= level)
    if not above.size:
        return math.nan
    j = start + int(above[0])
    if j == 0 or signal[j] == signal[j - 1]:
        return float(time_s[j])
    w = (level - signal[j - 1]) / (signal[j] - signal[j - 1])
    return float(time_s[j - 1] + w * (time_s[j] - time_s[j - 1]))


def _rudder_rate(log: ManeuverLog, starts: list[int], levels: list[float]) -> float:
    """Mean of 0.8·|step|/(t₉₀ − t₁₀) over the transitions from ``levels[i]`` to ``levels[i+1]``.

    ``starts[i]`` is the first sample of transition i.
    """
    rates = []
    for i, start in enumerate(starts):
        a, b = levels[i], levels[i + 1]
        progress = (log.rudder_rad - a) / (b - a)
        t10 = _crossing_time(log.time_s, progress, 0.1, start)
        t90 = _crossing_time(log.time_s, progress, 0.9, start)
        if math.isfinite(t10) and math.isfinite(t90) and t90 > t10:
            rates.append(0.8 * abs(b - a) / (t90 - t10))
    if not rates:
        raise IdentificationError(
            "the rudder transitions are not resolved: cannot read the steering-gear rate",
            log=_name(log),
        )
    return float(np.mean(rates))


def _approach_speed(log: ManeuverLog, k: int) -> float:
    """Speed over ground at execute [m/s], from a least-squares fit to the approach track.

    A parabola in time through the positions before execute (a straight line when
    there are fewer than :data:`MIN_PARABOLA_SAMPLES`), differentiated at execute:
    the speed the ship has when the manoeuvre starts, also when it was still
    accelerating or slowing down.
    """
    end = max(k, MIN_APPROACH_SAMPLES)
    t = log.time_s[:end] - log.time_s[k]
    degree = 2 if end >= MIN_PARABOLA_SAMPLES else 1
    vx = np.polynomial.Polynomial.fit(t, log.x_m[:end], degree).deriv()(0.0)
    vy = np.polynomial.Polynomial.fit(t, log.y_m[:end], degree).deriv()(0.0)
    return float(math.hypot(vx, vy))


def _switch_headings(log: ManeuverLog, rudder: _RudderReading) -> tuple[float, ...]:
    """|ψ − ψ₀| [rad] where the rudder started to move back at each reversal.

    ψ₀ is the heading at execute. The rudder is first seen moving back when
    it is :data:`REVERSAL_RUDDER_RAD` from its plateau (interpolated between samples);
    it started :data:`REVERSAL_RUDDER_RAD` / rate earlier, and the heading is
    interpolated to that moment: the heading at which a helmsman sailing the
    program again must start the reversal.
    """
    bounds = [rudder.k, *rudder.reversals.tolist()]
    lead_s = REVERSAL_RUDDER_RAD / rudder.rate_radps
    out = []
    for j, i in enumerate(rudder.reversals):
        side = rudder.sign if j % 2 == 0 else -rudder.sign
        toward = side * log.rudder_rad
        level = float(np.max(toward[bounds[j] : i])) - REVERSAL_RUDDER_RAD
        w = (toward[i - 1] - level) / (toward[i - 1] - toward[i])
        seen_s = (1.0 - w) * log.time_s[i - 1] + w * log.time_s[i]
        heading = np.interp(seen_s - lead_s, log.time_s, log.heading_rad)
        out.append(abs(float(heading - log.heading_rad[rudder.k])))
    return tuple(out)


def approach_helm_rad(log: ManeuverLog) -> float:
    """Mean rudder angle [rad] before execute: the helm the approach was sailed at.

    A single-screw ship needs one off the centre line to run straight (its neutral helm);
    the first sample when the log starts at execute; the rudder's spikes interpolated
    (``trials.spikes``).
    """
    log = despiked_inputs(log)[0]
    return _helm_before(log, _execute_index(log))


def _helm_before(log: ManeuverLog, k: int) -> float:
    """Mean rudder angle [rad] before sample ``k`` (the first sample when k is 0)."""
    return float(np.mean(log.rudder_rad[: max(k, 1)]))


@dataclass(frozen=True)
class _RudderReading:
    """What the rudder did after execute (see :func:`_read_rudder`)."""

    k: int
    sign: float
    reversals: np.ndarray
    plateaus: list[float]
    rate_radps: float


def _read_rudder(
    log: ManeuverLog, k: int, heading: np.ndarray, *, reversing: bool
) -> _RudderReading:
    """Read the rudder from execute sample k: first side, reversals, plateaus and rate.

    ``reversing``: a zig-zag (every return past a plateau is a reversal, judged with the
    log's :func:`steady_heading` ``heading``); else a turn (one plateau, held).
    """
    sign = _first_side(log, k)
    reversals = _reversals(log, k, sign, heading) if reversing else np.array([], dtype=int)
    bounds = [k, *reversals.tolist(), log.n_samples]
    plateaus = _plateaus(log, bounds, sign)
    rate = _rudder_rate(log, bounds[:-1], [_helm_before(log, k), *plateaus])
    return _RudderReading(k, sign, reversals, plateaus, rate)


def _plateaus(log: ManeuverLog, bounds: list[int], sign: float) -> list[float]:
    """Return the extreme rudder angle [rad] between consecutive ``bounds``, alternating sides."""
    out = []
    for i, (a, b) in enumerate(itertools.pairwise(bounds)):
        side = sign if i % 2 == 0 else -sign
        out.append(side * float(np.max(side * log.rudder_rad[a:b])))
    return out


def logged_condition(log: ManeuverLog, *, max_time_s: float = 3600.0) -> LoggedCondition:
    """Read a turning circle's or zig-zag's program and condition from its log.

    Parameters
    ----------
    log : ManeuverLog
        A turning circle or zig-zag (:func:`maneuver_kind`), with its approach.
    max_time_s : float
        Time limit of each leg of the program [s].

    Raises
    ------
    IdentificationError
        When the log is neither manoeuvre, its rudder never leaves midship, or its
        rudder transitions are not resolved.

    """
    log = at_midship(log)  # the approach speed of the midship point, as the model's
    log = despiked_inputs(log)[0]  # a spike is no rudder angle nor rpm (trials.spikes)
    heading = steady_heading(log)  # one median filter for the kind and the reversals
    kind = _maneuver_kind(log, heading)
    k = _execute_index(log)
    if kind is None or k >= log.n_samples - 1:
        raise IdentificationError(
            "the rudder never leaves midship: not a turning circle or a zig-zag", log=_name(log)
        )
    rudder = _read_rudder(log, k, heading, reversing=kind == "zigzag")
    sign, rate = rudder.sign, rudder.rate_radps
    amplitude = float(np.mean(np.abs(rudder.plateaus)))
    speed = _approach_speed(log, k)
    n_rps = float(np.mean(log.n_rps[: max(k, 1)]))
    execute_s = float(log.time_s[k])
    if kind == "turning":
        program = turning_circle(sign * amplitude, max_time_s=max_time_s)
        return LoggedCondition(program, speed, n_rps, rate, execute_s)

    switches = _switch_headings(log, rudder)
    mean_switch = float(np.mean(switches))
    named = _named_check(log)
    check = named if named is not None else _nominal_check(mean_switch)
    legs = []
    for i in range(max(len(switches) + 1, 5)):
        side = sign if i % 2 == 0 else -sign
        switch = switches[i] if i < len(switches) else mean_switch
        until = (
            Until(time_s=max_time_s, heading_above_rad=switch)
            if side > 0
            else Until(time_s=max_time_s, heading_below_rad=-switch)
        )
        legs.append(Leg(side * amplitude, until, label=f"leg {i + 1}"))
    deg = round(math.degrees(amplitude)), round(math.degrees(check))
    program = Program(
        name=f"zigzag-{deg[0]}-{deg[1]}-{'stbd' if sign > 0 else 'port'}",
        kind="zigzag",
        legs=tuple(legs),
        rudder_rad=sign * amplitude,
        heading_rad=check,
    )
    return LoggedCondition(program, speed, n_rps, rate, execute_s, switches)


def _named_check(log: ManeuverLog) -> float | None:
    """Z [rad] from ``zigzag-δ-Z`` in the source or file name; None if absent.

    A ``_<digits>`` before ``.csv`` is the piece number ``identifier convert`` appends,
    not an angle.
    """
    name = _PIECE_SUFFIX.sub("", Path(log.path or "").name)
    for text in (log.metadata.get("source", ""), name):
        match = _ZIGZAG_ANGLES.search(text)
        if match:
            return math.radians(float(match[2]))
    return None


# --------------------------------------------------------------------------------------
# Sailing a logged manoeuvre again, and its indices
# --------------------------------------------------------------------------------------

TURNING_INDICES = ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m")
"""A turning circle's indices (``trials.metrics.TurningMetrics``; the steady diameter
where the trajectory reaches 540° of heading change)."""
ZIGZAG_INDICES = (
    "first_overshoot_deg",
    "second_overshoot_deg",
    "initial_turning_time_s",
    "time_to_check_yaw_s",
    "period_s",
)
"""A zig-zag's indices (``trials.metrics.ZigzagMetrics``; the period from the first to
the third rudder reversal, where the trajectory has one)."""
BEYOND_STANDARD_INDICES = frozenset({"steady_diameter_m", "period_s"})
"""Indices a standard trial need not cover (a turn stopped at 540°, a zig-zag of two
reversals): compared where a log covers them, not missed where it does not."""


def maneuver_indices(
    kind: str,
    traj: np.ndarray,
    execute_time_s: float,
    zigzag: tuple[float, float] | None = None,
) -> dict[str, float | None]:
    """Return a manoeuvre's indices of one trajectory; None where it does not cover one.

    Parameters
    ----------
    kind : {"turning", "zigzag"}
        Turning circle: advance, transfer, tactical and steady diameter [m]; zig-zag:
        first and second overshoot [deg], initial turning time, time to check yaw and
        period [s] (:data:`TURNING_INDICES`, :data:`ZIGZAG_INDICES`; ``trials.metrics``
        definitions).
    traj : numpy.ndarray
        ``TRAJECTORY_DTYPE`` rows.
    execute_time_s : float
        Time of the execute point in ``traj`` [s].
    zigzag : tuple of float, optional
        A zig-zag's (δ signed, Z) [rad]; required for ``kind="zigzag"``.

    """
    if kind == "turning":
        try:
            m = turning_metrics(traj, execute_time_s)
        except MetricsError:
            return dict.fromkeys(TURNING_INDICES)
        return {
            "advance_m": m.advance_m,
            "transfer_m": m.transfer_m,
            "tactical_diameter_m": m.tactical_diameter_m,
            "steady_diameter_m": m.steady_diameter_m,
        }
    if zigzag is None:
        raise ValueError("a zig-zag's indices need its (rudder, check heading)")
    try:
        z = zigzag_metrics(traj, zigzag[0], zigzag[1], execute_time_s)
    except MetricsError:
        return dict.fromkeys(ZIGZAG_INDICES)
    return {
        "first_overshoot_deg": z.first_overshoot_deg,
        "second_overshoot_deg": z.second_overshoot_deg,
        "initial_turning_time_s": z.initial_turning_time_s,
        "time_to_check_yaw_s": z.time_to_check_yaw_s,
        "period_s": z.period_s,
    }


def log_trajectory(log: ManeuverLog) -> np.ndarray:
    """Return the log as a trajectory, velocities by central differences of the raw track.

    For the manoeuvre's indices (which use heading, position and the speed at
    execute), not for identification: nothing is smoothed. Positions of the midship
    point (:func:`~trials.logs.at_midship`), as the indices are defined.
    """
    log = at_midship(log)
    x_dot = np.gradient(log.x_m, log.time_s)
    y_dot = np.gradient(log.y_m, log.time_s)
    cos_psi, sin_psi = np.cos(log.heading_rad), np.sin(log.heading_rad)
    states = np.column_stack(
        (
            cos_psi * x_dot + sin_psi * y_dot,
            -sin_psi * x_dot + cos_psi * y_dot,
            np.gradient(log.heading_rad, log.time_s),
            log.x_m,
            log.y_m,
            log.heading_rad,
        )
    )
    return trajectory_of(log.time_s, states, log.rudder_rad, log.n_rps)


@dataclass(frozen=True)
class SailedAgain:
    """A logged manoeuvre and the same manoeuvre sailed by a plant in its condition.

    Attributes
    ----------
    kind : {"turning", "zigzag"}
        The manoeuvre.
    condition : LoggedCondition
        What was sailed.
    logged, predicted : dict
        Indices (:func:`maneuver_indices`) of the log and of the plant's run; a
        predicted index is None when the run diverged or never reached it.
    trajectory : numpy.ndarray
        The plant's run (execute at t = 0).
    diverged : bool
        Whether the plant's run diverged.

    """

    kind: str
    condition: LoggedCondition
    logged: dict[str, float | None]
    predicted: dict[str, float | None]
    trajectory: np.ndarray
    diverged: bool


def sail_again(plant: Plant, log: ManeuverLog, *, dt_s: float | None = None) -> SailedAgain:
    """Sail a logged turning circle or zig-zag with ``plant`` in the log's condition.

    The run is closed-loop, as the log's helmsman sailed it: approach speed, propeller
    speed, rudder amplitude and rate and (zig-zag) the logged switch headings from
    :func:`logged_condition`; its indices and the log's come from the same definitions.

    Parameters
    ----------
    plant : Plant
        One ship (``trials.run``).
    log : ManeuverLog
        The logged manoeuvre.
    dt_s : float, optional
        Communication step [s]; the log's median sampling interval when omitted.

    Raises
    ------
    IdentificationError
        When the log is neither a turning circle nor a zig-zag (:func:`logged_condition`).

    """
    duration_s = float(log.time_s[-1] - log.time_s[0])
    condition = logged_condition(log, max_time_s=duration_s)
    kind = condition.program.kind
    angles = (condition.program.rudder_rad, condition.program.heading_rad)
    step = float(np.median(np.diff(log.time_s))) if dt_s is None else dt_s
    with np.errstate(all="ignore"):  # a diverging plant is reported, not warned about
        run = run_batch(
            plant,
            condition.program,
            speed_mps=condition.speed_mps,
            n_rps=condition.n_rps,
            rudder_rate_radps=condition.rudder_rate_radps,
            dt_s=step,
            divergence_factor=DIVERGENCE_FACTOR,
        )
    traj = run.trajectories[0]
    logged = maneuver_indices(kind, log_trajectory(log), condition.execute_time_s, angles)
    predicted = (
        maneuver_indices(kind, traj, 0.0, angles) if traj.size > 2 else dict.fromkeys(logged)
    )
    return SailedAgain(kind, condition, logged, predicted, traj, bool(run.diverged[0]))
