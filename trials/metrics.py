"""Manoeuvre metrics from a trajectory: turning circle, zig-zag, spiral, pull-out.

Pure functions on a trajectory (``trials.trajectory.TRAJECTORY_DTYPE``), SI units
and radians inside. Definitions follow ITTC (7.5-04-02-01) and IMO MSC.137(76) as
fixed in DESIGN.md "Conventions" and ``reference/kvlcc2_mmg.md`` §10:

- execute point = the state at ``execute_time_s`` (start of the rudder command),
  interpolated linearly in time when it falls between samples;
- every event (heading crosses 90°, 180°, ±Z, …) is located by linear interpolation
  of the heading in time between the two samples that bracket it, and the positions
  and speeds at the event are interpolated linearly in time in the same interval —
  never the nearest sample;
- extrema (zig-zag heading peaks, maximum advance and transfer) are located by the
  parabola through the largest sample and its two neighbours (exact for a quadratic,
  error O(Δt⁴) in the peak value for a smooth signal).

Linear interpolation of a position on a curved track is not exact: on a circle of
radius R sampled every Δθ of heading, the interpolated point lies on the chord, at
most the sagitta R (1 − cos(Δθ/2)) from the arc.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

__all__ = [
    "TURN_BACK_TOLERANCE_RAD",
    "MetricsError",
    "PulloutMetrics",
    "SpiralMetrics",
    "TurningMetrics",
    "ZigzagMetrics",
    "distance_at_heading_change",
    "pullout_metrics",
    "spiral_metrics",
    "steady_yaw_rate",
    "turned_back_rad",
    "turning_metrics",
    "zigzag_metrics",
]


TURN_BACK_TOLERANCE_RAD = math.radians(1.0)
"""Largest fall of a turn's heading against its rudder [rad] (:func:`turned_back_rad`)
that still counts as a turn keeping its direction: a ship holding its rudder hard over
does not fall back at all, and a model that does is not sailing a turning circle (the
Monte-Carlo samples of ``scenarios.uncertainty``, the refinement's virtual turns)."""


class MetricsError(ValueError):
    """A trajectory (or series) from which the requested metric cannot be computed."""


# --------------------------------------------------------------------------------------
# Result types
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TurningMetrics:
    """Turning-circle metrics (ITTC/IMO definitions).

    Attributes
    ----------
    direction : int
        +1 for a starboard turn (heading increasing), −1 for a port turn.
    execute_time_s : float
        Time of the execute point [s].
    approach_heading_rad : float
        Heading at execute, i.e. the approach course [rad].
    approach_speed_mps : float
        Speed over ground U = √(u² + v²) at execute [m/s].
    advance_m : float
        Distance travelled along the approach course from the execute position when
        the heading has changed by 90° [m].
    transfer_m : float
        Distance perpendicular to the approach course from the execute position when
        the heading has changed by 90° (magnitude) [m].
    tactical_diameter_m : float
        Distance perpendicular to the approach course from the execute position when
        the heading has changed by 180° (magnitude) [m].
    time_to_90_s : float
        Time from execute to 90° heading change [s].
    time_to_180_s : float
        Time from execute to 180° heading change [s].
    max_advance_m : float
        Largest distance along the approach course within the first 360° of heading
        change (the whole run if shorter) [m].
    max_transfer_m : float
        Largest distance perpendicular to the approach course, towards the turn,
        within the first 360° of heading change (the whole run if shorter) [m].
    steady_speed_ratio : float
        U / U at execute, U averaged over time over the last full 360° of heading when
        the run covers it (see ``steady_diameter_m``), else U at the end of the run [-].
    steady_diameter_m : float or None
        Diameter of the circle fitted by least squares (Kåsa algebraic fit) to the
        sampled positions within the last full 360° of heading change; available when
        the run reaches at least 540° of heading change (the first 180° are transient,
        then one full revolution), else None [m].
    steady_yaw_rate_radps : float or None
        Mean yaw rate over that last revolution, 2π / its duration, signed like
        ``direction``; None when the steady diameter is None [rad/s].

    """

    direction: int
    execute_time_s: float
    approach_heading_rad: float
    approach_speed_mps: float
    advance_m: float
    transfer_m: float
    tactical_diameter_m: float
    time_to_90_s: float
    time_to_180_s: float
    max_advance_m: float
    max_transfer_m: float
    steady_speed_ratio: float
    steady_diameter_m: float | None = None
    steady_yaw_rate_radps: float | None = None

    @property
    def speed_loss_pct(self) -> float:
        """Speed loss in the turn, 100 (1 − ``steady_speed_ratio``) [%]."""
        return 100.0 * (1.0 - self.steady_speed_ratio)

    def as_dict(self, length_m: float) -> dict[str, float | str]:
        """Return the JSON record of DESIGN.md (lengths also in ship lengths).

        Parameters
        ----------
        length_m : float
            Ship length L used for the ``_L`` keys [m].

        Returns
        -------
        dict
            ``direction`` ("starboard"/"port"), ``execute_time_s``,
            ``approach_speed_mps``, ``advance_m``, ``transfer_m``,
            ``tactical_diameter_m``, ``advance_L``, ``transfer_L``,
            ``tactical_diameter_L``, ``max_advance_m``, ``max_transfer_m``,
            ``max_advance_L``, ``max_transfer_L``, ``time_to_90_s``, ``time_to_180_s``,
            ``steady_speed_ratio``, ``speed_loss_pct``; and, when the run covers the
            last full revolution, ``steady_diameter_m``, ``steady_diameter_L`` and
            ``steady_yaw_rate_degps``.

        """
        if not (math.isfinite(length_m) and length_m > 0.0):
            raise ValueError(f"length_m must be a positive number, got {length_m!r}")
        out: dict[str, float | str] = {
            "direction": "starboard" if self.direction > 0 else "port",
            "execute_time_s": self.execute_time_s,
            "approach_speed_mps": self.approach_speed_mps,
            "advance_m": self.advance_m,
            "transfer_m": self.transfer_m,
            "tactical_diameter_m": self.tactical_diameter_m,
            "advance_L": self.advance_m / length_m,
            "transfer_L": self.transfer_m / length_m,
            "tactical_diameter_L": self.tactical_diameter_m / length_m,
            "max_advance_m": self.max_advance_m,
            "max_transfer_m": self.max_transfer_m,
            "max_advance_L": self.max_advance_m / length_m,
            "max_transfer_L": self.max_transfer_m / length_m,
            "time_to_90_s": self.time_to_90_s,
            "time_to_180_s": self.time_to_180_s,
            "steady_speed_ratio": self.steady_speed_ratio,
            "speed_loss_pct": self.speed_loss_pct,
        }
        if self.steady_diameter_m is not None:
            out["steady_diameter_m"] = self.steady_diameter_m
            out["steady_diameter_L"] = self.steady_diameter_m / length_m
        if self.steady_yaw_rate_radps is not None:
            out["steady_yaw_rate_degps"] = math.degrees(self.steady_yaw_rate_radps)
        return out


@dataclass(frozen=True)
class ZigzagMetrics:
    """Zig-zag (Kempf) metrics; angles are magnitudes, whichever side the test starts.

    Attributes
    ----------
    rudder_rad : float
        First rudder command δ (signed: + starboard first, − port first) [rad].
    heading_rad : float
        Check heading Z, the heading change at which the rudder is reversed [rad].
    execute_time_s : float
        Time of the execute point [s].
    initial_heading_rad : float
        Heading at execute; heading changes are measured from it [rad].
    approach_speed_mps : float
        Speed over ground U = √(u² + v²) at execute [m/s].
    reversal_times_s : tuple of float
        Times at which the heading change reaches +Z, −Z, +Z, … in turn (the rudder
        reversals), in the direction of the first rudder, interpolated [s].
    peak_times_s : tuple of float
        Times of the heading extremum after each of the first (up to) three reversals,
        where the yaw rate changes sign [s].
    first_overshoot_rad : float
        Largest heading excursion beyond +Z between the 1st and 2nd reversal [rad].
    second_overshoot_rad : float or None
        Largest excursion beyond −Z between the 2nd and 3rd reversal [rad].
    third_overshoot_rad : float or None
        Largest excursion beyond +Z between the 3rd and 4th reversal [rad].
    initial_turning_time_s : float
        Execute to 1st reversal (time to reach a heading change Z) [s].
    time_to_check_yaw_s : float
        1st reversal to the first heading peak [s].
    period_s : float or None
        1st to 3rd reversal: one full cycle [s].

    """

    rudder_rad: float
    heading_rad: float
    execute_time_s: float
    initial_heading_rad: float
    approach_speed_mps: float
    reversal_times_s: tuple[float, ...]
    peak_times_s: tuple[float, ...]
    first_overshoot_rad: float
    second_overshoot_rad: float | None
    third_overshoot_rad: float | None
    initial_turning_time_s: float
    time_to_check_yaw_s: float
    period_s: float | None

    @property
    def first_overshoot_deg(self) -> float:
        """First overshoot angle [deg]."""
        return math.degrees(self.first_overshoot_rad)

    @property
    def second_overshoot_deg(self) -> float | None:
        """Second overshoot angle [deg], None when the run does not cover it."""
        return _deg_or_none(self.second_overshoot_rad)

    @property
    def third_overshoot_deg(self) -> float | None:
        """Third overshoot angle [deg], None when the run does not cover it."""
        return _deg_or_none(self.third_overshoot_rad)

    def as_dict(self) -> dict[str, float | list[float]]:
        """Return the JSON record of DESIGN.md (angles in degrees, times in seconds).

        Returns
        -------
        dict
            ``rudder_deg``, ``heading_deg``, ``execute_time_s``, ``approach_speed_mps``,
            ``first_overshoot_deg``, ``initial_turning_time_s``,
            ``time_to_check_yaw_s``, ``first_reversal_time_s``, ``reversal_times_s``
            (list), ``peak_times_s`` (list); and, when covered by the run,
            ``second_overshoot_deg``, ``third_overshoot_deg`` and ``period_s``.

        """
        out: dict[str, float | list[float]] = {
            "rudder_deg": math.degrees(self.rudder_rad),
            "heading_deg": math.degrees(self.heading_rad),
            "execute_time_s": self.execute_time_s,
            "approach_speed_mps": self.approach_speed_mps,
            "first_overshoot_deg": self.first_overshoot_deg,
            "initial_turning_time_s": self.initial_turning_time_s,
            "time_to_check_yaw_s": self.time_to_check_yaw_s,
            "first_reversal_time_s": self.reversal_times_s[0],
            "reversal_times_s": list(self.reversal_times_s),
            "peak_times_s": list(self.peak_times_s),
        }
        if self.second_overshoot_deg is not None:
            out["second_overshoot_deg"] = self.second_overshoot_deg
        if self.third_overshoot_deg is not None:
            out["third_overshoot_deg"] = self.third_overshoot_deg
        if self.period_s is not None:
            out["period_s"] = self.period_s
        return out


@dataclass(frozen=True)
class SpiralMetrics:
    """Dieudonné spiral: steady yaw rate against rudder angle, and its hysteresis loop.

    Attributes
    ----------
    rudder_rad : tuple of float
        Rudder angles in the order they were applied [rad].
    yaw_rate_radps : tuple of float
        Steady yaw rate reached at each of them [rad/s].
    curve_rudder_rad : tuple of float
        The same rudder angles sorted ascending (stable sort) [rad].
    curve_yaw_rate_radps : tuple of float
        The yaw rates in the order of ``curve_rudder_rad`` [rad/s].
    loop_width_rad : float
        Width of the range of rudder angles over which both a starboard (r > 0) and a
        port (r < 0) steady turn were measured: max δ with r < 0 minus min δ with
        r > 0, or 0 when that is negative (a stable ship). Measured on the applied
        angles, so it is a lower bound of the true loop width, which is at most one
        rudder step wider at each end [rad].
    loop_low_rad, loop_high_rad : float or None
        Ends of that range (min δ with r > 0, max δ with r < 0); None when the width
        is 0 [rad].

    """

    rudder_rad: tuple[float, ...]
    yaw_rate_radps: tuple[float, ...]
    curve_rudder_rad: tuple[float, ...]
    curve_yaw_rate_radps: tuple[float, ...]
    loop_width_rad: float
    loop_low_rad: float | None
    loop_high_rad: float | None

    @property
    def loop_width_deg(self) -> float:
        """Hysteresis loop width [deg]."""
        return math.degrees(self.loop_width_rad)

    @property
    def is_stable(self) -> bool:
        """True when no hysteresis loop was measured (directionally stable ship)."""
        return self.loop_width_rad == 0.0


@dataclass(frozen=True)
class PulloutMetrics:
    """Pull-out manoeuvre: decay of the yaw rate after the rudder returns to midship.

    Attributes
    ----------
    release_time_s : float
        Time at which the rudder was ordered to midship [s].
    initial_yaw_rate_radps : float
        Yaw rate at release [rad/s].
    residual_yaw_rate_radps : float
        Time mean of the yaw rate over the last ``tail_fraction`` of the run after
        release [rad/s]; ≈ 0 for a directionally stable ship.
    fitted_residual_yaw_rate_radps : float or None
        r∞ of the fit r(t) = r∞ + (r₀ − r∞) exp(−(t − t_release) / T) [rad/s].
    time_constant_s : float or None
        T of that fit (least squares over the whole run after release); None when the
        yaw rate does not change or the fit does not converge to a finite T > 0 [s].

    """

    release_time_s: float
    initial_yaw_rate_radps: float
    residual_yaw_rate_radps: float
    fitted_residual_yaw_rate_radps: float | None
    time_constant_s: float | None


# --------------------------------------------------------------------------------------
# Public functions
# --------------------------------------------------------------------------------------


def turning_metrics(traj: np.ndarray, execute_time_s: float = 0.0) -> TurningMetrics:
    """Turning-circle metrics of a run, starboard or port.

    The turn direction is the sign of the largest heading change after execute. The
    advance is measured along the approach course (the heading at execute), the
    transfer and tactical diameter perpendicular to it, all from the execute position.

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields, time strictly increasing.
    execute_time_s : float, optional
        Time of the execute point, the start of the rudder command [s].

    Returns
    -------
    TurningMetrics
        See the class for the definitions.

    Raises
    ------
    MetricsError
        When the trajectory is malformed, the execute time lies outside it, or the
        heading change after execute does not reach 180°.

    """
    run = _run_from(
        _checked(traj, ("time_s", "x_m", "y_m", "psi_rad", "u_mps", "v_mps")), execute_time_s
    )
    t = run["time_s"]
    direction, turned = _turn(run)
    for needed_rad in (0.5 * math.pi, math.pi):
        if turned.max() < needed_rad:
            raise MetricsError(
                f"the heading changes by at most {math.degrees(turned.max()):.1f} deg after "
                f"execute; the turning metrics need {math.degrees(needed_rad):.0f} deg"
            )

    psi0 = float(run["psi_rad"][0])
    dx = run["x_m"] - run["x_m"][0]
    dy = run["y_m"] - run["y_m"][0]
    along = dx * math.cos(psi0) + dy * math.sin(psi0)
    towards_turn = direction * (-dx * math.sin(psi0) + dy * math.cos(psi0))

    t90, _ = _first_rising_crossing(t, turned - 0.5 * math.pi)
    t180, _ = _first_rising_crossing(t, turned - math.pi)
    advance_m = float(np.interp(t90, t, along))
    transfer_m = abs(float(np.interp(t90, t, towards_turn)))
    tactical_m = abs(float(np.interp(t180, t, towards_turn)))

    # Maxima within the first 360 deg of heading change (whole run if shorter).
    crossing_360 = _rising_crossings(t, turned - 2.0 * math.pi)
    stop = crossing_360[1][0] + 1 if crossing_360[1].size else t.size - 1
    max_advance_m = _refined_max(t, along, stop)
    max_transfer_m = _refined_max(t, towards_turn, stop)

    speed = np.hypot(run["u_mps"], run["v_mps"])
    u0 = float(speed[0])
    if u0 <= 0.0:
        raise MetricsError("the speed at execute is zero; the speed ratio is undefined")

    steady_diameter_m: float | None = None
    steady_r: float | None = None
    end_speed = float(speed[-1])
    if turned[-1] >= 3.0 * math.pi:
        times, _ = _rising_crossings(t, turned - (turned[-1] - 2.0 * math.pi))
        t_rev = float(times[-1])
        inside = t > t_rev
        if np.count_nonzero(inside) < 5:
            raise MetricsError(
                f"only {np.count_nonzero(inside)} samples in the last full revolution; "
                "too coarse to fit the steady turning circle (need 5)"
            )
        steady_diameter_m = _circle_fit_diameter(run["x_m"][inside], run["y_m"][inside])
        steady_r = direction * 2.0 * math.pi / (float(t[-1]) - t_rev)
        end_speed = _window_mean(t, speed, t_rev, float(t[-1]))

    return TurningMetrics(
        direction=direction,
        execute_time_s=float(t[0]),
        approach_heading_rad=psi0,
        approach_speed_mps=u0,
        advance_m=advance_m,
        transfer_m=transfer_m,
        tactical_diameter_m=tactical_m,
        time_to_90_s=t90 - float(t[0]),
        time_to_180_s=t180 - float(t[0]),
        max_advance_m=max_advance_m,
        max_transfer_m=max_transfer_m,
        steady_speed_ratio=end_speed / u0,
        steady_diameter_m=steady_diameter_m,
        steady_yaw_rate_radps=steady_r,
    )


def turned_back_rad(traj: np.ndarray, execute_time_s: float = 0.0) -> float:
    """How far the heading of a turn falls back against the turn's direction [rad].

    The largest distance of the heading below its running extreme towards the turn
    (the direction as in :func:`turning_metrics`), over the run after execute; 0 for a
    turn that keeps its direction. A ship holding its rudder hard over does not turn
    back; a model that does, at a speed its logs never reached, is not sailing a
    turning circle, and metrics taken at its 90° and 180° crossings would measure a
    loop of its own.

    Raises
    ------
    MetricsError
        When the trajectory is malformed, the execute time lies outside it, or the
        heading never changes after execute.

    """
    _, turned = _turn(_run_from(_checked(traj, ("time_s", "psi_rad")), execute_time_s))
    return float(np.max(np.maximum.accumulate(turned) - turned))


def distance_at_heading_change(
    traj: np.ndarray, angle_rad: float, execute_time_s: float = 0.0
) -> float:
    """Track distance travelled from execute until the heading has changed by an angle.

    Used for the IMO initial turning ability (10° rudder, distance at 10° heading
    change). The distance is the length of the sampled track (sum of the straight
    segments between positions, the last one cut at the interpolated crossing time),
    which is independent of the logged speeds; on a curved track it is shorter than the
    arc by the chord error, relative Δθ²/24 for Δθ of heading per sample.

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields.
    angle_rad : float
        Heading change, either side, measured from the heading at execute [rad].
    execute_time_s : float, optional
        Time of the execute point [s].

    Returns
    -------
    float
        Distance along the track [m].

    Raises
    ------
    MetricsError
        When the heading never changes by ``angle_rad``.

    """
    if not (math.isfinite(angle_rad) and angle_rad > 0.0):
        raise MetricsError(f"angle_rad must be a positive number, got {angle_rad!r}")
    run = _run_from(_checked(traj, ("time_s", "x_m", "y_m", "psi_rad")), execute_time_s)
    t = run["time_s"]
    turned = np.abs(run["psi_rad"] - run["psi_rad"][0])
    times, _ = _rising_crossings(t, turned - angle_rad)
    if times.size == 0:
        raise MetricsError(
            f"the heading changes by at most {math.degrees(turned.max()):.2f} deg after "
            f"execute; never reaches {math.degrees(angle_rad):.2f} deg"
        )
    step_m = np.hypot(np.diff(run["x_m"]), np.diff(run["y_m"]))
    travelled_m = np.concatenate(([0.0], np.cumsum(step_m)))
    return float(np.interp(times[0], t, travelled_m))


def zigzag_metrics(
    traj: np.ndarray, rudder_rad: float, heading_rad: float, execute_time_s: float = 0.0
) -> ZigzagMetrics:
    """Zig-zag metrics of a run, starboard first (``rudder_rad > 0``) or port first.

    Heading changes are measured from the heading at execute and counted positive in
    the direction of the first rudder. The rudder reversals are the interpolated times
    at which the heading change reaches +Z, then −Z, then +Z, … (whatever the logged
    rudder did). Each overshoot is the largest excursion beyond the check heading
    between one reversal and the next; its peak is the vertex of the parabola through
    the largest sample and its two neighbours (exact for a parabolic peak; for a
    sinusoid of angular frequency ω sampled at Δt the relative error is about
    (ωΔt)⁴/100).

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields.
    rudder_rad : float
        First rudder command δ, signed (+ starboard) [rad].
    heading_rad : float
        Check heading Z > 0 [rad].
    execute_time_s : float, optional
        Time of the execute point [s].

    Returns
    -------
    ZigzagMetrics
        At least the first reversal and the first overshoot; later ones when the run
        covers them.

    Raises
    ------
    MetricsError
        When the heading never reaches Z, or the run ends before the heading peaks
        after the first reversal.

    """
    if not (math.isfinite(rudder_rad) and rudder_rad != 0.0):
        raise MetricsError(f"rudder_rad must be a non-zero number, got {rudder_rad!r}")
    if not (math.isfinite(heading_rad) and heading_rad > 0.0):
        raise MetricsError(f"heading_rad must be a positive number, got {heading_rad!r}")
    run = _run_from(_checked(traj, ("time_s", "psi_rad", "u_mps", "v_mps")), execute_time_s)
    t = run["time_s"]
    side = 1.0 if rudder_rad > 0.0 else -1.0
    turned = side * (run["psi_rad"] - run["psi_rad"][0])

    reversals: list[float] = []
    start = 0
    while True:
        towards = 1.0 if len(reversals) % 2 == 0 else -1.0  # +Z, −Z, +Z, …
        times, segments = _rising_crossings(t[start:], towards * turned[start:] - heading_rad)
        if times.size == 0:
            break
        reversals.append(float(times[0]))
        start += int(segments[0]) + 1
    if not reversals:
        raise MetricsError(
            f"the heading change after execute reaches at most "
            f"{math.degrees(turned.max()):.2f} deg; no rudder reversal at the check heading "
            f"{math.degrees(heading_rad):.2f} deg"
        )

    peak_times: list[float] = []
    overshoots: list[float] = []
    for k in range(min(3, len(reversals))):
        towards = 1.0 if k % 2 == 0 else -1.0
        t_next = reversals[k + 1] if k + 1 < len(reversals) else math.inf
        inside = np.flatnonzero((t > reversals[k]) & (t < t_next))
        if inside.size == 0:
            break
        excursion = towards * turned
        i = int(inside[np.argmax(excursion[inside])])
        if i == t.size - 1:
            break  # still turning away at the end of the run: the peak is not covered
        t_peak, peak = _parabolic_peak(t[i - 1 : i + 2], excursion[i - 1 : i + 2])
        peak_times.append(t_peak)
        overshoots.append(peak - heading_rad)
    if not overshoots:
        raise MetricsError(
            "the run ends before the heading peaks after the first rudder reversal; "
            "the first overshoot is not covered"
        )

    def nth(values: list[float], n: int) -> float | None:
        return values[n] if len(values) > n else None

    return ZigzagMetrics(
        rudder_rad=float(rudder_rad),
        heading_rad=float(heading_rad),
        execute_time_s=float(t[0]),
        initial_heading_rad=float(run["psi_rad"][0]),
        approach_speed_mps=float(math.hypot(run["u_mps"][0], run["v_mps"][0])),
        reversal_times_s=tuple(reversals),
        peak_times_s=tuple(peak_times),
        first_overshoot_rad=overshoots[0],
        second_overshoot_rad=nth(overshoots, 1),
        third_overshoot_rad=nth(overshoots, 2),
        initial_turning_time_s=reversals[0] - float(t[0]),
        time_to_check_yaw_s=peak_times[0] - reversals[0],
        period_s=reversals[2] - reversals[0] if len(reversals) > 2 else None,
    )


def spiral_metrics(
    rudder_rad: Sequence[float] | np.ndarray,
    steady_r_radps: Sequence[float] | np.ndarray,
    *,
    yaw_rate_tol_radps: float = 0.0,
) -> SpiralMetrics:
    """Dieudonné spiral curve and the width of its hysteresis loop.

    Parameters
    ----------
    rudder_rad : array_like
        Rudder angles in the order they were applied, e.g. +25° … −25° … +25° [rad].
    steady_r_radps : array_like
        Steady yaw rate reached at each rudder angle [rad/s].
    yaw_rate_tol_radps : float, optional
        Yaw rates with |r| ≤ this count as neither starboard nor port turns [rad/s].

    Returns
    -------
    SpiralMetrics
        The r–δ curve (in applied order and sorted by δ) and the loop width.

    Raises
    ------
    MetricsError
        On arrays of different length, fewer than two points or non-finite values.

    """
    delta = np.asarray(rudder_rad, dtype=float)
    r = np.asarray(steady_r_radps, dtype=float)
    if delta.ndim != 1 or delta.shape != r.shape:
        raise MetricsError(
            f"rudder_rad and steady_r_radps must be 1-D of equal length, got shapes "
            f"{delta.shape} and {r.shape}"
        )
    if delta.size < 2:
        raise MetricsError("a spiral needs at least two rudder angles")
    if not (np.all(np.isfinite(delta)) and np.all(np.isfinite(r))):
        raise MetricsError("rudder_rad and steady_r_radps must be finite")
    if not (math.isfinite(yaw_rate_tol_radps) and yaw_rate_tol_radps >= 0.0):
        raise MetricsError(f"yaw_rate_tol_radps must be >= 0, got {yaw_rate_tol_radps!r}")

    order = np.argsort(delta, kind="stable")
    starboard = delta[r > yaw_rate_tol_radps]
    port = delta[r < -yaw_rate_tol_radps]
    width = 0.0
    low: float | None = None
    high: float | None = None
    if starboard.size and port.size and port.max() > starboard.min():
        low, high = float(starboard.min()), float(port.max())
        width = high - low
    return SpiralMetrics(
        rudder_rad=tuple(float(d) for d in delta),
        yaw_rate_radps=tuple(float(v) for v in r),
        curve_rudder_rad=tuple(float(d) for d in delta[order]),
        curve_yaw_rate_radps=tuple(float(v) for v in r[order]),
        loop_width_rad=width,
        loop_low_rad=low,
        loop_high_rad=high,
    )


def steady_yaw_rate(traj: np.ndarray, t_start_s: float, t_end_s: float) -> float:
    """Time mean of the yaw rate over a window (e.g. the steady part of a spiral step).

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields.
    t_start_s, t_end_s : float
        Window, inside the trajectory, ``t_start_s < t_end_s`` [s].

    Returns
    -------
    float
        (1 / (t_end − t_start)) ∫ r dt, trapezoidal on the linearly interpolated
        samples [rad/s].

    """
    traj = _checked(traj, ("time_s", "r_radps"))
    t = traj["time_s"]
    if not (t[0] <= t_start_s < t_end_s <= t[-1]):
        raise MetricsError(
            f"window [{t_start_s}, {t_end_s}] s must be non-empty and inside the "
            f"trajectory [{t[0]}, {t[-1]}] s"
        )
    return _window_mean(t, traj["r_radps"], t_start_s, t_end_s)


def pullout_metrics(
    traj: np.ndarray, release_time_s: float, *, tail_fraction: float = 0.2
) -> PulloutMetrics:
    """Pull-out test: residual yaw rate and decay time constant after release.

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields; the rudder returns to midship at
        ``release_time_s`` and the run continues until the yaw rate has settled.
    release_time_s : float
        Time at which the rudder is ordered to midship [s].
    tail_fraction : float, optional
        Fraction (0, 1] of the run after release, at its end, over which the residual
        yaw rate is averaged.

    Returns
    -------
    PulloutMetrics
        Residual yaw rate, and the time constant T of the least-squares fit
        r(t) = r∞ + (r₀ − r∞) exp(−(t − t_release) / T) over the run after release.

    """
    if not (math.isfinite(tail_fraction) and 0.0 < tail_fraction <= 1.0):
        raise MetricsError(f"tail_fraction must be in (0, 1], got {tail_fraction!r}")
    run = _run_from(_checked(traj, ("time_s", "r_radps")), release_time_s)
    t = run["time_s"]
    r = run["r_radps"]
    if t.size < 4:
        raise MetricsError(f"only {t.size} samples after release; need at least 4")
    tau = t - t[0]
    residual = _window_mean(t, r, float(t[-1] - tail_fraction * tau[-1]), float(t[-1]))

    fitted_inf: float | None = None
    time_constant: float | None = None
    r0 = float(r[0])
    span = float(np.max(np.abs(r - residual)))
    if span > 0.0:
        excess = np.abs(r - residual)
        below = np.flatnonzero(excess <= excess[0] / math.e)
        guess_t = float(tau[below[0]]) if below.size and below[0] > 0 else float(tau[-1] / 3.0)

        t_guess = max(guess_t, 1e-9 * float(tau[-1]))

        def residuals(p: np.ndarray) -> np.ndarray:
            # p = (r_inf, r_start, T)
            return p[0] + (p[1] - p[0]) * np.exp(-tau / p[2]) - r

        fit = least_squares(
            residuals,
            x0=np.array([residual, r0, t_guess]),
            bounds=([-np.inf, -np.inf, 0.0], [np.inf, np.inf, np.inf]),
            x_scale=np.array([span, span, t_guess]),
            ftol=1e-14,
            xtol=1e-14,
            gtol=1e-14,
            max_nfev=2000,
        )
        if fit.status > 0 and math.isfinite(fit.x[2]) and fit.x[2] > 0.0:
            fitted_inf = float(fit.x[0])
            time_constant = float(fit.x[2])

    return PulloutMetrics(
        release_time_s=float(t[0]),
        initial_yaw_rate_radps=r0,
        residual_yaw_rate_radps=residual,
        fitted_residual_yaw_rate_radps=fitted_inf,
        time_constant_s=time_constant,
    )


# --------------------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------------------


def _deg_or_none(value_rad: float | None) -> float | None:
    return None if value_rad is None else math.degrees(value_rad)


def _checked(traj: np.ndarray, fields: Sequence[str]) -> np.ndarray:
    """Validate a trajectory: structured 1-D, the fields present and finite, time increasing."""
    names = getattr(getattr(traj, "dtype", None), "names", None)
    if not isinstance(traj, np.ndarray) or names is None:
        raise MetricsError("trajectory must be a structured numpy array (TRAJECTORY_DTYPE)")
    missing = [name for name in fields if name not in names]
    if missing:
        raise MetricsError(f"trajectory lacks the field(s) {', '.join(missing)}")
    if traj.ndim != 1 or traj.shape[0] < 2:
        raise MetricsError(f"trajectory must be 1-D with at least 2 samples, got {traj.shape}")
    for name in fields:
        bad = np.flatnonzero(~np.isfinite(traj[name]))
        if bad.size:
            raise MetricsError(f"trajectory field {name} is not finite at row {bad[0]}")
    steps = np.diff(traj["time_s"])
    bad = np.flatnonzero(steps <= 0.0)
    if bad.size:
        raise MetricsError(f"time_s must be strictly increasing (row {bad[0] + 1})")
    return traj


def _run_from(traj: np.ndarray, t0_s: float) -> np.ndarray:
    """Return the run from ``t0_s`` on: a row interpolated at ``t0_s``, then later rows."""
    t = traj["time_s"]
    if not (math.isfinite(t0_s) and t[0] <= t0_s < t[-1]):
        raise MetricsError(f"time {t0_s!r} s is not inside the trajectory [{t[0]}, {t[-1]}) s")
    later = traj[t > t0_s]
    first = np.zeros(1, dtype=traj.dtype)
    for name in traj.dtype.names or ():
        if np.issubdtype(traj.dtype[name], np.floating):
            first[name] = np.interp(t0_s, t, traj[name])
    return np.concatenate((first, later))


def _turn(run: np.ndarray) -> tuple[int, np.ndarray]:
    """Direction of a turn (sign of the largest heading change) and the change towards it.

    ``run`` starts at execute; returns +1 (starboard) or −1 (port) and
    direction · (ψ − ψ₀) per sample [rad].
    """
    dpsi = run["psi_rad"] - run["psi_rad"][0]
    k_max = int(np.argmax(np.abs(dpsi)))
    if dpsi[k_max] == 0.0:
        raise MetricsError("the heading never changes after execute; not a turning circle")
    direction = 1 if dpsi[k_max] > 0.0 else -1
    return direction, direction * dpsi


def _rising_crossings(t: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return the times at which g(t) crosses zero upwards, linear between samples.

    A crossing lies in segment i when g[i] < 0 ≤ g[i+1]; returns the interpolated
    times and the segment indices.
    """
    segments = np.flatnonzero((g[:-1] < 0.0) & (g[1:] >= 0.0))
    g0 = g[segments]
    g1 = g[segments + 1]
    times = t[segments] + (-g0) / (g1 - g0) * (t[segments + 1] - t[segments])
    return times, segments


def _first_rising_crossing(t: np.ndarray, g: np.ndarray) -> tuple[float, int]:
    times, segments = _rising_crossings(t, g)
    return float(times[0]), int(segments[0])


def _parabolic_peak(t3: np.ndarray, f3: np.ndarray) -> tuple[float, float]:
    """Vertex (time, value) of the parabola through three samples, the middle one largest.

    Falls back to the middle sample when the three are not concave.
    """
    h1 = float(t3[0] - t3[1])
    h2 = float(t3[2] - t3[1])
    d1 = float(f3[0] - f3[1])
    d2 = float(f3[2] - f3[1])
    # f(t1 + h) = f1 + b h + c h²  through (h1, d1) and (h2, d2)
    det = h1 * h2 * (h2 - h1)
    c = (d2 * h1 - d1 * h2) / det
    b = (d1 * h2 * h2 - d2 * h1 * h1) / det
    if c >= 0.0:
        return float(t3[1]), float(f3[1])
    h = -b / (2.0 * c)
    return float(t3[1]) + h, float(f3[1]) - b * b / (4.0 * c)


def _refined_max(t: np.ndarray, f: np.ndarray, stop: int) -> float:
    """Largest value of f over samples 0..stop, refined by a parabola when interior."""
    i = int(np.argmax(f[: stop + 1]))
    if 0 < i < f.size - 1:
        return _parabolic_peak(t[i - 1 : i + 2], f[i - 1 : i + 2])[1]
    return float(f[i])


def _window_mean(t: np.ndarray, f: np.ndarray, t_a: float, t_b: float) -> float:
    """Time mean of the linear interpolant of f over [t_a, t_b] (trapezoidal, exact)."""
    inner = (t > t_a) & (t < t_b)
    tw = np.concatenate(([t_a], t[inner], [t_b]))
    fw = np.concatenate(([np.interp(t_a, t, f)], f[inner], [np.interp(t_b, t, f)]))
    return float(np.sum(0.5 * (fw[1:] + fw[:-1]) * np.diff(tw)) / (t_b - t_a))


def _circle_fit_diameter(x: np.ndarray, y: np.ndarray) -> float:
    """Diameter of the least-squares (Kåsa) circle through the points.

    Solves x² + y² = 2 a x + 2 b y + c in least squares on coordinates relative to the
    centroid; the radius is √(c + a² + b²). Exact for points on a circle.
    """
    xc = x - x.mean()
    yc = y - y.mean()
    design = np.column_stack((2.0 * xc, 2.0 * yc, np.ones_like(xc)))
    (a, b, c), *_ = np.linalg.lstsq(design, xc**2 + yc**2, rcond=None)
    return 2.0 * math.sqrt(c + a * a + b * b)
