"""The current correction of a turning circle (IMO MSC/Circ.1053, 3.4.2.5).

A uniform, steady current c carries the ship and the water together: it does not
change the ship's motion through the water, only adds c t to its track over ground.
A turning circle sailed in current is therefore a circle that drifts; the positions at
which the ship reaches the same heading on two successive turns differ by c times the
time between them. The procedure of the IMO Explanatory Notes to the Standards for
Ship Manoeuvrability, MSC/Circ.1053 (2002), Annex 3.4.2.5, which this module
implements:

1. record the track, heading and time until the heading has changed by at least
   720° (:data:`IMO_MIN_HEADING_CHANGE_RAD`);
2. use only the data after the first 180° of heading change
   (:data:`IMO_START_HEADING_CHANGE_RAD`), when the turn has settled;
3. pair the positions (x₁ᵢ, y₁ᵢ, t₁ᵢ) and (x₂ᵢ, y₂ᵢ, t₂ᵢ) at which the heading change is
   θᵢ and θᵢ + 360°; each pair gives a local current velocity
   cᵢ = (x₂ᵢ − x₁ᵢ, y₂ᵢ − y₁ᵢ) / (t₂ᵢ − t₁ᵢ);
4. the current is the mean of the local velocities over the pairs;
5. the corrected track is x(t) − c_N (t − t₀), y(t) − c_E (t − t₀), t₀ the execute,
   and its turning indices are measured as in still water
   (``trials.metrics.turning_metrics``).

Choices this module makes where the circular leaves them open:

- the reference headings θᵢ run from 180° to (heading change reached − 360°) in even
  steps of heading (default 1°), so every part of the circle weighs the same whatever
  the sampling; each event is located by linear interpolation of the heading in time
  and of the position in time between the two samples that bracket it, never the
  nearest sample (DESIGN.md conventions);
- the mean is taken of the velocity vectors (north, east components), not of speeds
  and directions separately: the two agree when the local velocities do, and the
  vector mean stays defined for a weak current whose local directions scatter around
  the compass;
- the spread of the estimate is the sample standard deviation of the local velocities
  over the pairs. The pairs of neighbouring headings are not independent, so this is
  a measure of how steady the turn was, not a standard error.

ITTC Recommended Procedure 7.5-04-02-01 (Full Scale Manoeuvring Trials) lists a
"Correction due to environment" (its 5.1.1); its text could not be consulted for this
module, so the procedure above is MSC/Circ.1053's alone.

Linear interpolation of a position on a curved track errs by at most the sagitta
R (1 − cos(Δθ/2)) for Δθ of heading per sample; for R = 500 m and 1° per sample that is
2 cm at each end of a pair, 10⁻⁴ m/s of drift over a 400 s turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

# The trajectory checks and the cut at the execute point are those of the turning
# metrics, so that both read a trajectory the same way and reject it with the same words.
from trials.metrics import MetricsError, TurningMetrics, _checked, _run_from, turning_metrics

__all__ = [
    "DRIFT_THRESHOLD_FRACTION",
    "IMO_MIN_HEADING_CHANGE_RAD",
    "IMO_START_HEADING_CHANGE_RAD",
    "REFERENCE",
    "CurrentCorrection",
    "CurrentEstimate",
    "correct_turning_circle",
    "estimate_current",
    "remove_drift",
]

REFERENCE = "IMO MSC/Circ.1053 3.4.2.5"
"""Where the procedure is stated."""
IMO_MIN_HEADING_CHANGE_RAD = 4.0 * math.pi
"""Heading change the run must reach: at least 720° (MSC/Circ.1053 3.4.2.5) [rad]."""
IMO_START_HEADING_CHANGE_RAD = math.pi
"""Only the data after 180° of heading change estimate the current (3.4.2.5) [rad]."""
DEFAULT_HEADING_STEP_RAD = math.radians(1.0)
"""Spacing of the reference headings θᵢ of the pairs [rad]."""
DRIFT_THRESHOLD_FRACTION = 0.01
"""A drift faster than this fraction of the approach speed through the water counts as
a current worth correcting (1 %: over the 180° to the tactical diameter the track then
moves by about 1.5 % of the turning diameter) [-]."""


@dataclass(frozen=True)
class CurrentEstimate:
    """The drift of a turning circle over ground, from positions one turn apart.

    Attributes
    ----------
    drift_north_mps, drift_east_mps : float
        Mean local current velocity over the pairs, North and East components [m/s].
    spread_north_mps, spread_east_mps : float
        Sample standard deviation of the local velocities over the pairs [m/s]; 0 for
        a steady turn in a uniform current.
    n_pairs : int
        Number of pairs of positions 360° of heading apart.
    first_heading_change_rad, last_heading_change_rad : float
        Range of the reference headings θᵢ (heading change from execute, towards the
        turn) of the first position of each pair; the second is 360° later [rad].
    mean_period_s : float
        Mean time between the two positions of a pair, one turn's period [s].
    execute_time_s : float
        Time of the execute point, t₀ of the corrected track [s].

    """

    drift_north_mps: float
    drift_east_mps: float
    spread_north_mps: float
    spread_east_mps: float
    n_pairs: int
    first_heading_change_rad: float
    last_heading_change_rad: float
    mean_period_s: float
    execute_time_s: float

    @property
    def speed_mps(self) -> float:
        """Drift speed |c| [m/s]."""
        return math.hypot(self.drift_north_mps, self.drift_east_mps)

    @property
    def direction_rad(self) -> float:
        """Direction the current sets towards, clockwise from North, in [0, 2π) [rad]."""
        return math.atan2(self.drift_east_mps, self.drift_north_mps) % (2.0 * math.pi)

    def as_dict(self) -> dict[str, float | int | str]:
        """JSON record, angles in degrees: the attributes, drift speed and direction."""
        return {
            "procedure": REFERENCE,
            "drift_north_mps": self.drift_north_mps,
            "drift_east_mps": self.drift_east_mps,
            "drift_speed_mps": self.speed_mps,
            "drift_direction_deg": math.degrees(self.direction_rad),
            "spread_north_mps": self.spread_north_mps,
            "spread_east_mps": self.spread_east_mps,
            "n_pairs": self.n_pairs,
            "first_heading_change_deg": math.degrees(self.first_heading_change_rad),
            "last_heading_change_deg": math.degrees(self.last_heading_change_rad),
            "mean_period_s": self.mean_period_s,
        }


@dataclass(frozen=True)
class CurrentCorrection:
    """A turning circle measured raw and corrected for the current.

    Attributes
    ----------
    estimate : CurrentEstimate
        The drift removed.
    trajectory : numpy.ndarray
        The corrected trajectory (:func:`remove_drift`).
    raw : TurningMetrics
        Turning indices of the trajectory as given.
    corrected : TurningMetrics
        Turning indices of the corrected trajectory.

    """

    estimate: CurrentEstimate
    trajectory: np.ndarray
    raw: TurningMetrics
    corrected: TurningMetrics

    def threshold_mps(self, fraction: float = DRIFT_THRESHOLD_FRACTION) -> float:
        """Drift speed above which the current counts: ``fraction`` × approach speed [m/s].

        The approach speed is the corrected run's, i.e. through the water.
        """
        if not (math.isfinite(fraction) and fraction >= 0.0):
            raise ValueError(f"fraction must be a non-negative number, got {fraction!r}")
        return fraction * self.corrected.approach_speed_mps

    def is_significant(self, fraction: float = DRIFT_THRESHOLD_FRACTION) -> bool:
        """Whether the drift speed exceeds :meth:`threshold_mps`."""
        return self.estimate.speed_mps > self.threshold_mps(fraction)


def estimate_current(
    traj: np.ndarray,
    execute_time_s: float = 0.0,
    *,
    start_heading_change_rad: float = IMO_START_HEADING_CHANGE_RAD,
    min_heading_change_rad: float = IMO_MIN_HEADING_CHANGE_RAD,
    heading_step_rad: float = DEFAULT_HEADING_STEP_RAD,
) -> CurrentEstimate:
    """Estimate the drift of a continued turn from positions one turn apart.

    MSC/Circ.1053 3.4.2.5: for every reference heading change θᵢ from
    ``start_heading_change_rad`` to (the largest heading change reached − 360°) in
    steps of ``heading_step_rad``, the positions and times at which the heading change
    first reaches θᵢ and θᵢ + 360° give a local current velocity
    cᵢ = Δpᵢ / Δtᵢ; the estimate is their mean.

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields (``time_s``, ``x_m``, ``y_m``,
        ``psi_rad`` are used), positions over ground, heading continuous.
    execute_time_s : float, optional
        Time of the execute point; heading changes are measured from the heading there
        [s].
    start_heading_change_rad : float, optional
        First reference heading change; the turn before it is transient (IMO: 180°)
        [rad].
    min_heading_change_rad : float, optional
        Heading change the run must reach (IMO: 720°); at least
        ``start_heading_change_rad`` + 360° [rad].
    heading_step_rad : float, optional
        Spacing of the reference headings [rad].

    Returns
    -------
    CurrentEstimate
        Drift velocity (north, east) and its spread over the pairs.

    Raises
    ------
    MetricsError
        When the trajectory is malformed, the execute time lies outside it, the heading
        never changes, or it changes by less than ``min_heading_change_rad`` or too
        little for two pairs.

    """
    for name, value in (
        ("start_heading_change_rad", start_heading_change_rad),
        ("min_heading_change_rad", min_heading_change_rad),
    ):
        if not (math.isfinite(value) and value >= 0.0):
            raise MetricsError(f"{name} must be a non-negative number, got {value!r}")
    if not (math.isfinite(heading_step_rad) and heading_step_rad > 0.0):
        raise MetricsError(f"heading_step_rad must be a positive number, got {heading_step_rad!r}")
    turn = 2.0 * math.pi
    if min_heading_change_rad < start_heading_change_rad + turn:
        raise MetricsError(
            f"min_heading_change_rad ({math.degrees(min_heading_change_rad):.1f} deg) must be "
            f"at least start_heading_change_rad + 360 deg "
            f"({math.degrees(start_heading_change_rad) + 360.0:.1f} deg)"
        )

    run = _run_from(_checked(traj, ("time_s", "x_m", "y_m", "psi_rad")), execute_time_s)
    t = run["time_s"]
    dpsi = run["psi_rad"] - run["psi_rad"][0]
    k_max = int(np.argmax(np.abs(dpsi)))
    if dpsi[k_max] == 0.0:
        raise MetricsError("the heading never changes after execute; not a turning circle")
    turned = math.copysign(1.0, float(dpsi[k_max])) * dpsi  # towards the turn [rad]
    reached = np.maximum.accumulate(turned)
    most = float(reached[-1])
    if most < min_heading_change_rad:
        raise MetricsError(
            f"the heading changes by at most {math.degrees(most):.1f} deg after execute; the "
            f"current correction ({REFERENCE}) needs {math.degrees(min_heading_change_rad):.0f}"
            f" deg: positions one full turn apart from "
            f"{math.degrees(start_heading_change_rad):.0f} deg of heading change on"
        )
    n_levels = math.floor((most - turn - start_heading_change_rad) / heading_step_rad) + 1
    if n_levels < 2:
        raise MetricsError(
            f"the heading changes by {math.degrees(most):.1f} deg after execute: fewer than two "
            f"pairs of positions 360 deg apart from {math.degrees(start_heading_change_rad):.0f}"
            f" deg on in steps of {math.degrees(heading_step_rad):g} deg"
        )
    levels = start_heading_change_rad + heading_step_rad * np.arange(n_levels)
    t1, x1, y1 = _first_reaching(t, run["x_m"], run["y_m"], turned, reached, levels)
    t2, x2, y2 = _first_reaching(t, run["x_m"], run["y_m"], turned, reached, levels + turn)
    period = t2 - t1
    north = (x2 - x1) / period
    east = (y2 - y1) / period
    return CurrentEstimate(
        drift_north_mps=float(np.mean(north)),
        drift_east_mps=float(np.mean(east)),
        spread_north_mps=float(np.std(north, ddof=1)),
        spread_east_mps=float(np.std(east, ddof=1)),
        n_pairs=n_levels,
        first_heading_change_rad=float(levels[0]),
        last_heading_change_rad=float(levels[-1]),
        mean_period_s=float(np.mean(period)),
        execute_time_s=float(t[0]),
    )


def remove_drift(
    traj: np.ndarray,
    drift_north_mps: float,
    drift_east_mps: float,
    t0_s: float,
    *,
    velocities: Literal["ground", "water"] = "ground",
) -> np.ndarray:
    """Return the track with a uniform drift taken out: x − c_N (t − t₀), y − c_E (t − t₀).

    Every row is shifted (before t₀ too, where the shift is the other way), so a
    straight approach stays straight.

    Parameters
    ----------
    traj : numpy.ndarray
        Trajectory with ``TRAJECTORY_DTYPE`` fields.
    drift_north_mps, drift_east_mps : float
        Drift velocity c, North and East [m/s].
    t0_s : float
        Time at which the corrected and the given track coincide (the execute) [s].
    velocities : {"ground", "water"}, optional
        What ``u_mps``, ``v_mps`` of ``traj`` are: over ground (a trial log's,
        differentiated from positions: the drift's body-axis components are taken out
        too, u − (c_N cos ψ + c_E sin ψ), v − (−c_N sin ψ + c_E cos ψ)) or through the
        water (a simulator's: left as they are).

    Returns
    -------
    numpy.ndarray
        A corrected copy; ``traj`` is not changed.

    """
    if velocities not in ("ground", "water"):
        raise ValueError(f"velocities must be 'ground' or 'water', got {velocities!r}")
    for name, value in (("drift_north_mps", drift_north_mps), ("drift_east_mps", drift_east_mps)):
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")
    out = np.array(traj, copy=True)
    elapsed = out["time_s"] - t0_s
    out["x_m"] = out["x_m"] - drift_north_mps * elapsed
    out["y_m"] = out["y_m"] - drift_east_mps * elapsed
    if velocities == "ground":
        cos_psi, sin_psi = np.cos(out["psi_rad"]), np.sin(out["psi_rad"])
        out["u_mps"] = out["u_mps"] - (drift_north_mps * cos_psi + drift_east_mps * sin_psi)
        out["v_mps"] = out["v_mps"] - (-drift_north_mps * sin_psi + drift_east_mps * cos_psi)
    return out


def correct_turning_circle(
    traj: np.ndarray,
    execute_time_s: float = 0.0,
    *,
    velocities: Literal["ground", "water"] = "ground",
    start_heading_change_rad: float = IMO_START_HEADING_CHANGE_RAD,
    min_heading_change_rad: float = IMO_MIN_HEADING_CHANGE_RAD,
    heading_step_rad: float = DEFAULT_HEADING_STEP_RAD,
) -> CurrentCorrection:
    """Estimate the current of a continued turn, take it out, measure both tracks.

    :func:`estimate_current`, then :func:`remove_drift` from the execute point, then
    ``trials.metrics.turning_metrics`` of the given and of the corrected trajectory.
    The options are those of the two functions.

    Raises
    ------
    MetricsError
        As :func:`estimate_current` and ``turning_metrics``.

    """
    estimate = estimate_current(
        traj,
        execute_time_s,
        start_heading_change_rad=start_heading_change_rad,
        min_heading_change_rad=min_heading_change_rad,
        heading_step_rad=heading_step_rad,
    )
    corrected = remove_drift(
        traj,
        estimate.drift_north_mps,
        estimate.drift_east_mps,
        estimate.execute_time_s,
        velocities=velocities,
    )
    return CurrentCorrection(
        estimate=estimate,
        trajectory=corrected,
        raw=turning_metrics(traj, execute_time_s),
        corrected=turning_metrics(corrected, execute_time_s),
    )


def _first_reaching(
    t: np.ndarray,
    x: np.ndarray,
    y: np.ndarray,
    turned: np.ndarray,
    reached: np.ndarray,
    levels: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Time and position at which the heading change first reaches each level.

    ``reached`` is the running maximum of ``turned``; a level 0 < L ≤ reached[-1] is
    first reached between samples i − 1 and i, i the first index with reached ≥ L
    (then turned[i − 1] < L ≤ turned[i]). Time by linear interpolation of the heading,
    positions linear in time in the same interval.
    """
    # Clipped at both ends: a level 0 is reached at the first sample; one a rounding
    # error above the last reach, at the last.
    i = np.clip(np.searchsorted(reached, levels, side="left"), 1, t.size - 1)
    lo = turned[i - 1]
    rise = turned[i] - lo  # > 0 but for a level 0 reached at the execute point itself
    frac = np.zeros_like(levels)
    np.divide(levels - lo, rise, out=frac, where=rise > 0.0)
    frac = np.clip(frac, 0.0, 1.0)
    return (
        t[i - 1] + frac * (t[i] - t[i - 1]),
        x[i - 1] + frac * (x[i] - x[i - 1]),
        y[i - 1] + frac * (y[i] - y[i - 1]),
    )
