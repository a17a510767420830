"""Standard manoeuvres as data: a straight approach followed by a list of legs.

Each leg holds a rudder command (and optionally a propeller speed) until a condition on
time or heading is met; the driver (``trials.run``) evaluates the conditions on the
simulated heading, so the zig-zag is closed-loop as the standard prescribes. Angles in
radians, headings relative to the heading at execute (t = 0), positive to starboard.

Definitions follow ITTC 7.5-04-02-01 and IMO MSC.137(76): turning circle with the
rudder put over after a steady approach and held until at least 540° of heading change;
zig-zag δ/ψ with the rudder reversed each time the heading change reaches ±ψ; the
Dieudonné spiral with stepwise rudder held until the yaw rate is steady; the pull-out
with the rudder returned to midship after a steady turn.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

DEFAULT_RUDDER_RATE_DEG_S = 2.34
"""Default steering-gear rate [deg/s]: KVLCC2 full scale (reference §7), a typical large ship's."""


@dataclass(frozen=True)
class Until:
    """End condition of a leg; the leg ends when any given condition holds.

    Parameters
    ----------
    time_s : float, optional
        Time spent in this leg [s].
    heading_above_rad, heading_below_rad : float, optional
        Heading change since execute crosses above / below this value [rad].

    """

    time_s: float | None = None
    heading_above_rad: float | None = None
    heading_below_rad: float | None = None


@dataclass(frozen=True)
class Leg:
    """Hold ``rudder_rad`` (and ``n_rps`` when given) until ``until`` holds.

    With ``steer``, an autopilot steers the heading the ship has when the leg starts,
    about ``rudder_rad`` (its helm): δ = δ_helm − K (Δψ + T′ r′), Δψ the heading off that
    course, r′ = r L/U₀, K = :data:`AUTOPILOT_GAIN`, T′ = :data:`AUTOPILOT_DERIVATIVE_L`,
    within ±:data:`AUTOPILOT_LIMIT_RAD` of the helm: the straight run of a trial day
    between manoeuvres (a course-unstable ship at midship rudder keeps turning).
    """

    rudder_rad: float
    until: Until
    n_rps: float | None = None
    label: str = ""
    steer: bool = False


AUTOPILOT_GAIN = 1.5
"""Rudder per heading error of a steering leg's autopilot [rad/rad]."""
AUTOPILOT_DERIVATIVE_L = 2.0
"""Its derivative time, in ship lengths sailed at the approach speed [L/U₀]."""
AUTOPILOT_LIMIT_RAD = math.radians(10.0)
"""Most rudder it gives off the leg's helm [rad]."""


@dataclass(frozen=True)
class Helm:
    """A steady straight run: the rudder that holds it and the sway it has there.

    Parameters
    ----------
    rudder_rad : float
        Rudder angle [rad]; off the centre line for a single-screw ship, whose
        propeller pushes it to one side.
    sway_mps : float
        Sway velocity [m/s] of the straight run at that rudder.

    """

    rudder_rad: float = 0.0
    sway_mps: float = 0.0


@dataclass(frozen=True)
class Program:
    """A manoeuvre: straight approach, then legs from execute (t = 0).

    Parameters
    ----------
    name : str
        E.g. ``"turning-35-stbd"``, ``"zigzag-10-10-stbd"``.
    kind : str
        ``"turning"``, ``"zigzag"``, ``"spiral"`` or ``"pullout"`` (selects the metrics), or
        ``"trial-day"`` (several manoeuvres, :func:`trial_day`: no metrics of its own).
    legs : tuple of Leg
        Executed in order; the run ends after the last leg.
    approach_s : float
        Straight run before execute [s].
    approach_helm : Helm
        The steady straight run of the approach: rudder amidships and no sway, or a
        single-screw ship's neutral helm (a trial's approach is steadied on it).
    rudder_rad, heading_rad : float
        The nominal rudder (and zig-zag heading) angle, for the metrics.

    """

    name: str
    kind: str
    legs: tuple[Leg, ...]
    approach_s: float = 0.0
    approach_helm: Helm = field(default_factory=Helm)
    rudder_rad: float = 0.0
    heading_rad: float = 0.0


def _side(rudder_rad: float) -> str:
    return "stbd" if rudder_rad >= 0.0 else "port"


def turning_circle(
    rudder_rad: float,
    *,
    heading_change_rad: float = math.radians(540.0),
    max_time_s: float = 3600.0,
) -> Program:
    """Return a turning circle: rudder to ``rudder_rad`` (sign = side), held.

    The run ends when the heading changed by ``heading_change_rad`` or after
    ``max_time_s``.
    """
    sign = 1.0 if rudder_rad >= 0.0 else -1.0
    until = (
        Until(time_s=max_time_s, heading_above_rad=heading_change_rad)
        if sign > 0
        else Until(time_s=max_time_s, heading_below_rad=-heading_change_rad)
    )
    return Program(
        name=f"turning-{round(math.degrees(abs(rudder_rad)))}-{_side(rudder_rad)}",
        kind="turning",
        legs=(Leg(rudder_rad, until, label="rudder over"),),
        rudder_rad=rudder_rad,
    )


def zigzag(
    rudder_rad: float, heading_rad: float, *, n_reversals: int = 4, max_time_s: float = 3600.0
) -> Program:
    """Return a zig-zag δ/ψ, first to the side of ``rudder_rad``'s sign.

    ``n_reversals`` rudder reversals (the 4th completes the third overshoot), then the
    rudder is held until the heading passes the check angle once more.
    """
    sign = 1.0 if rudder_rad >= 0.0 else -1.0
    delta, psi = abs(rudder_rad), abs(heading_rad)
    legs = []
    for i in range(n_reversals + 1):
        s = sign if i % 2 == 0 else -sign
        until = (
            Until(time_s=max_time_s, heading_above_rad=psi)
            if s > 0
            else Until(time_s=max_time_s, heading_below_rad=-psi)
        )
        legs.append(Leg(s * delta, until, label=f"leg {i + 1}"))
    deg = round(math.degrees(delta)), round(math.degrees(psi))
    return Program(
        name=f"zigzag-{deg[0]}-{deg[1]}-{_side(rudder_rad)}",
        kind="zigzag",
        legs=tuple(legs),
        rudder_rad=sign * delta,
        heading_rad=psi,
    )


def spiral(rudder_steps_rad: tuple[float, ...], *, hold_s: float = 600.0) -> Program:
    """Return a Dieudonné spiral: each rudder angle held ``hold_s`` so the yaw rate settles."""
    legs = tuple(
        Leg(d, Until(time_s=hold_s), label=f"{math.degrees(d):+.1f} deg") for d in rudder_steps_rad
    )
    return Program(name="spiral", kind="spiral", legs=legs)


def pullout(rudder_rad: float, *, turn_s: float = 600.0, release_s: float = 600.0) -> Program:
    """Return a pull-out: steady turn with ``rudder_rad`` for ``turn_s``, then midship rudder."""
    legs = (
        Leg(rudder_rad, Until(time_s=turn_s), label="turn"),
        Leg(0.0, Until(time_s=release_s), label="released"),
    )
    return Program(
        name=f"pullout-{_side(rudder_rad)}", kind="pullout", legs=legs, rudder_rad=rudder_rad
    )


def trial_day(*, steady_s: float = 400.0) -> Program:
    """Return a trial day in one recording (``identifier split`` cuts it in two).

    A 10°/10° zig-zag to starboard, ``steady_s`` of straight running on the autopilot, a
    35° turning circle to port through 540° and more, and ``steady_s`` on the autopilot
    again. The end conditions' headings are relative to the zig-zag's execute.
    """
    steady = Leg(0.0, Until(time_s=steady_s), label="steady", steer=True)
    check = zigzag(math.radians(10.0), math.radians(10.0))
    turn = Leg(
        -math.radians(35.0),
        Until(time_s=3600.0, heading_below_rad=-math.radians(540.0 + 45.0)),
        label="turn to port",
    )
    return Program(name="trial-day", kind="trial-day", legs=(*check.legs, steady, turn, steady))


def standard_set(
    length_m: float, speed_mps: float, *, turn_heading_change_rad: float = math.radians(540.0)
) -> tuple[Program, ...]:
    """Return the validation set: 35° turning both ways, 10/10 and 20/20 zig-zags starboard first.

    ``length_m`` and ``speed_mps`` scale the time limits (about 60 L/U); the turns end
    at ``turn_heading_change_rad`` of heading change (540° by default; 720° for the
    current correction of MSC/Circ.1053 3.4.2.5).
    """
    limit_s = 60.0 * length_m / max(speed_mps, 1e-3)
    turn = turn_heading_change_rad
    return (
        turning_circle(math.radians(35.0), heading_change_rad=turn, max_time_s=limit_s),
        turning_circle(-math.radians(35.0), heading_change_rad=turn, max_time_s=limit_s),
        zigzag(math.radians(10.0), math.radians(10.0), max_time_s=limit_s),
        zigzag(math.radians(20.0), math.radians(20.0), max_time_s=limit_s),
    )
