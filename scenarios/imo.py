"""IMO Standards for Ship Manoeuvrability, resolution MSC.137(76) (2002), Annex §5.3.

The criteria (the explanatory notes are MSC/Circ.1053, 2002), L = length between
perpendiculars [m], V = test speed [m/s]:

- §5.3.1 Turning ability: advance ≤ 4.5 L and tactical diameter ≤ 5 L in the turning
  circle manoeuvre (35° or the maximum rudder angle, port and starboard).
- §5.3.2 Initial turning ability: with 10° rudder the ship should not have travelled
  more than 2.5 L by the time the heading has changed by 10° from the original heading.
- §5.3.3.1 10°/10° zig-zag, first overshoot ≤ 10° if L/V < 10 s; ≤ 20° if L/V ≥ 30 s;
  ≤ (5 + ½ L/V)° if 10 s ≤ L/V < 30 s.
- §5.3.3.2 10°/10° zig-zag, second overshoot ≤ 25° if L/V < 10 s; ≤ 40° if L/V ≥ 30 s;
  ≤ (17.5 + 0.75 L/V)° if 10 s ≤ L/V < 30 s.
- §5.3.3.3 20°/20° zig-zag, first overshoot ≤ 25°.
- §5.3.4 Stopping ability: track reach in the full-astern stopping test ≤ 15 L; the
  Administration may raise this for ships of large displacement, never above 20 L.

"Should not exceed": a value equal to its limit passes. Angles are radians in this
API; the human-readable text (``Criterion.describe``) and ``as_dict`` use degrees.

A turning circle sailed in current drifts; MSC/Circ.1053 3.4.2.5 corrects it from a
turn continued to 720° (``trials.current_correction``).
:func:`turning_ability_in_current` judges §5.3.1 on the current-corrected indices when
the estimated drift exceeds a stated threshold (1 % of the approach speed by default),
else on the raw ones, and says which.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

from trials.current_correction import DRIFT_THRESHOLD_FRACTION, CurrentCorrection
from trials.metrics import TurningMetrics, ZigzagMetrics

__all__ = [
    "ADVANCE_LIMIT_L",
    "INITIAL_TURNING_DISTANCE_LIMIT_L",
    "STOPPING_TRACK_REACH_LIMIT_L",
    "STOPPING_TRACK_REACH_MAX_LIMIT_L",
    "TACTICAL_DIAMETER_LIMIT_L",
    "ZIGZAG_20_FIRST_OVERSHOOT_LIMIT_RAD",
    "Criterion",
    "TurningJudgement",
    "evaluate",
    "first_overshoot_limit_10_rad",
    "initial_turning_ability",
    "second_overshoot_limit_10_rad",
    "stopping_ability",
    "turning_ability",
    "turning_ability_in_current",
    "yaw_checking_10",
    "yaw_checking_20",
]

_SOURCE = "IMO MSC.137(76) Annex"

ADVANCE_LIMIT_L = 4.5
"""Turning ability: largest advance in ship lengths, §5.3.1."""
TACTICAL_DIAMETER_LIMIT_L = 5.0
"""Turning ability: largest tactical diameter in ship lengths, §5.3.1."""
INITIAL_TURNING_DISTANCE_LIMIT_L = 2.5
"""Initial turning ability: largest track distance to 10° heading change [L], §5.3.2."""
ZIGZAG_20_FIRST_OVERSHOOT_LIMIT_RAD = math.radians(25.0)
"""20°/20° zig-zag: largest first overshoot [rad], §5.3.3.3."""
STOPPING_TRACK_REACH_LIMIT_L = 15.0
"""Stopping ability: largest track reach in ship lengths, §5.3.4."""
STOPPING_TRACK_REACH_MAX_LIMIT_L = 20.0
"""Stopping ability: the Administration's modified limit may not exceed this [L], §5.3.4."""

_ZIGZAG_TOLERANCE_RAD = 1e-6


@dataclass(frozen=True)
class Criterion:
    """One IMO criterion evaluated: the value, its limit and the verdict.

    Attributes
    ----------
    name : str
        What is judged, e.g. ``"turning ability: advance (starboard)"``.
    value : float
        The ship's value, in ``unit``.
    limit : float
        The largest value that passes, in ``unit``.
    unit : str
        ``"m"`` or ``"rad"``.
    reference : str
        Where the criterion is stated (resolution and paragraph).
    length_m : float or None
        Ship length, to express lengths in L in the text [m].
    passed : bool
        ``value <= limit`` (computed).
    margin : float
        ``limit - value`` in ``unit``; ≥ 0 when passing (computed).

    """

    name: str
    value: float
    limit: float
    unit: str
    reference: str
    length_m: float | None = None
    passed: bool = field(init=False)
    margin: float = field(init=False)

    def __post_init__(self) -> None:
        if self.unit not in ("m", "rad"):
            raise ValueError(f"unit must be 'm' or 'rad', got {self.unit!r}")
        _require_finite(self.value, "value")
        _require_finite(self.limit, "limit")
        object.__setattr__(self, "passed", bool(self.value <= self.limit))
        object.__setattr__(self, "margin", float(self.limit - self.value))

    def describe(self) -> str:
        """One line for a report, angles in degrees, lengths in m and L."""
        verdict = "pass" if self.passed else "FAIL"
        relation = "<=" if self.passed else ">"
        return (
            f"{self.name}: {self._show(self.value)} {relation} {self._show(self.limit)} "
            f"-> {verdict} (margin {self._show(self.margin)}; {self.reference})"
        )

    def as_dict(self) -> dict[str, float | str | bool]:
        """JSON record: ``name``, ``reference``, ``passed`` and value/limit/margin.

        The numbers carry their display unit in the key: ``value_deg``,
        ``limit_deg``, ``margin_deg`` for angles; ``value_m``, ``limit_m``,
        ``margin_m`` (and ``value_L``, ``limit_L``, ``margin_L`` when the length is
        known) for distances.
        """
        out: dict[str, float | str | bool] = {
            "name": self.name,
            "reference": self.reference,
            "passed": self.passed,
        }
        numbers = {"value": self.value, "limit": self.limit, "margin": self.margin}
        for key, number in numbers.items():
            if self.unit == "rad":
                out[f"{key}_deg"] = math.degrees(number)
            else:
                out[f"{key}_m"] = number
                if self.length_m is not None:
                    out[f"{key}_L"] = number / self.length_m
        return out

    def _show(self, number: float) -> str:
        if self.unit == "rad":
            return f"{math.degrees(number):.2f} deg"
        if self.length_m is not None:
            return f"{number:.1f} m ({number / self.length_m:.3f} L)"
        return f"{number:.1f} m"


def first_overshoot_limit_10_rad(length_m: float, speed_mps: float) -> float:
    """Limit of the first overshoot in the 10°/10° zig-zag, §5.3.3.1.

    Parameters
    ----------
    length_m : float
        Ship length L [m].
    speed_mps : float
        Test (approach) speed V [m/s].

    Returns
    -------
    float
        10° if L/V < 10 s, 20° if L/V ≥ 30 s, (5 + L/(2V))° in between [rad].

    """
    return _zigzag_10_limit_rad(length_m, speed_mps, 10.0, 20.0, 5.0, 0.5)


def second_overshoot_limit_10_rad(length_m: float, speed_mps: float) -> float:
    """Limit of the second overshoot in the 10°/10° zig-zag, §5.3.3.2.

    Parameters
    ----------
    length_m : float
        Ship length L [m].
    speed_mps : float
        Test (approach) speed V [m/s].

    Returns
    -------
    float
        25° if L/V < 10 s, 40° if L/V ≥ 30 s, (17.5 + 0.75 L/V)° in between [rad].

    """
    return _zigzag_10_limit_rad(length_m, speed_mps, 25.0, 40.0, 17.5, 0.75)


def turning_ability(
    metrics: TurningMetrics, length_m: float, *, note: str | None = None
) -> tuple[Criterion, Criterion]:
    """Judge turning ability, §5.3.1: advance ≤ 4.5 L, tactical diameter ≤ 5 L.

    Parameters
    ----------
    metrics : TurningMetrics
        A turning circle at 35° (or the maximum) rudder angle.
    length_m : float
        Ship length L [m].
    note : str, optional
        Added to the side in the criteria's names, e.g. ``"current-corrected"`` gives
        ``"turning ability: advance (starboard, current-corrected)"``.

    Returns
    -------
    tuple of Criterion
        (advance, tactical diameter), unit m.

    """
    _require_positive(length_m, "length_m")
    side = "starboard" if metrics.direction > 0 else "port"
    if note:
        side = f"{side}, {note}"
    return (
        Criterion(
            name=f"turning ability: advance ({side})",
            value=metrics.advance_m,
            limit=ADVANCE_LIMIT_L * length_m,
            unit="m",
            reference=f"{_SOURCE} 5.3.1",
            length_m=length_m,
        ),
        Criterion(
            name=f"turning ability: tactical diameter ({side})",
            value=metrics.tactical_diameter_m,
            limit=TACTICAL_DIAMETER_LIMIT_L * length_m,
            unit="m",
            reference=f"{_SOURCE} 5.3.1",
            length_m=length_m,
        ),
    )


@dataclass(frozen=True)
class TurningJudgement:
    """Turning ability judged on the raw or on the current-corrected indices.

    Attributes
    ----------
    criteria : tuple of Criterion
        (advance, tactical diameter), §5.3.1.
    corrected : bool
        True when the criteria judge the current-corrected indices.
    basis : str
        ``"current-corrected"`` or ``"raw"``.
    reason : str
        Why, in words: the drift against its threshold, or why there is no estimate.

    """

    criteria: tuple[Criterion, Criterion]
    corrected: bool
    basis: str
    reason: str

    def as_dict(self) -> dict[str, object]:
        """JSON record: ``basis``, ``reason``, ``criteria`` (``Criterion.as_dict`` each)."""
        return {
            "basis": self.basis,
            "reason": self.reason,
            "criteria": [c.as_dict() for c in self.criteria],
        }


def turning_ability_in_current(
    raw: TurningMetrics,
    correction: CurrentCorrection | None,
    length_m: float,
    *,
    correct: bool = True,
    threshold_fraction: float = DRIFT_THRESHOLD_FRACTION,
) -> TurningJudgement:
    """Judge §5.3.1 on the current-corrected indices when the run shows a drift, else raw.

    Parameters
    ----------
    raw : TurningMetrics
        The turning circle as measured.
    correction : CurrentCorrection or None
        Its current correction (``trials.current_correction.correct_turning_circle``,
        MSC/Circ.1053 3.4.2.5); None when the run does not allow one (it covers less
        than 720° of heading change).
    length_m : float
        Ship length L [m].
    correct : bool, optional
        False judges the raw indices whatever the drift.
    threshold_fraction : float, optional
        The corrected indices are judged when the drift speed exceeds this fraction of
        the approach speed through the water (default 1 %) [-].

    Returns
    -------
    TurningJudgement
        The criteria and which indices they judge, with the reason.

    """
    if correction is None:
        reason = "no current estimate: the run covers less than 720 deg of heading change"
        return TurningJudgement(turning_ability(raw, length_m), False, "raw", reason)
    estimate = correction.estimate
    threshold = correction.threshold_mps(threshold_fraction)
    drift = (
        f"drift {estimate.speed_mps:.3f} m/s (MSC/Circ.1053 3.4.2.5) against "
        f"{threshold:.3f} m/s = {100.0 * threshold_fraction:g} % of the approach speed"
    )
    if not correct:
        reason = f"current correction switched off; {drift}"
        return TurningJudgement(turning_ability(raw, length_m), False, "raw", reason)
    if correction.is_significant(threshold_fraction):
        criteria = turning_ability(correction.corrected, length_m, note="current-corrected")
        return TurningJudgement(criteria, True, "current-corrected", f"{drift}: above")
    return TurningJudgement(turning_ability(raw, length_m), False, "raw", f"{drift}: not above")


def initial_turning_ability(distance_m: float, length_m: float) -> Criterion:
    """Judge initial turning ability, §5.3.2: distance to 10° heading change ≤ 2.5 L.

    Parameters
    ----------
    distance_m : float
        Distance travelled from execute (10° rudder) until the heading has changed
        by 10°, e.g. from ``metrics.distance_at_heading_change`` [m].
    length_m : float
        Ship length L [m].

    """
    _require_positive(length_m, "length_m")
    return Criterion(
        name="initial turning ability: distance to 10 deg heading change (10 deg rudder)",
        value=distance_m,
        limit=INITIAL_TURNING_DISTANCE_LIMIT_L * length_m,
        unit="m",
        reference=f"{_SOURCE} 5.3.2",
        length_m=length_m,
    )


def yaw_checking_10(
    first_overshoot_rad: float,
    second_overshoot_rad: float | None,
    length_m: float,
    speed_mps: float,
) -> tuple[Criterion, ...]:
    """Judge yaw-checking and course-keeping, 10°/10° zig-zag, §5.3.3.1 and §5.3.3.2.

    Parameters
    ----------
    first_overshoot_rad : float
        First overshoot angle [rad].
    second_overshoot_rad : float or None
        Second overshoot angle, None when not measured [rad].
    length_m : float
        Ship length L [m].
    speed_mps : float
        Test (approach) speed V [m/s].

    Returns
    -------
    tuple of Criterion
        (first overshoot,) or (first overshoot, second overshoot), unit rad.

    """
    lv_s = _length_over_speed_s(length_m, speed_mps)
    out = [
        Criterion(
            name=f"10/10 zig-zag: first overshoot (L/V = {lv_s:.1f} s)",
            value=first_overshoot_rad,
            limit=first_overshoot_limit_10_rad(length_m, speed_mps),
            unit="rad",
            reference=f"{_SOURCE} 5.3.3.1",
        )
    ]
    if second_overshoot_rad is not None:
        out.append(
            Criterion(
                name=f"10/10 zig-zag: second overshoot (L/V = {lv_s:.1f} s)",
                value=second_overshoot_rad,
                limit=second_overshoot_limit_10_rad(length_m, speed_mps),
                unit="rad",
                reference=f"{_SOURCE} 5.3.3.2",
            )
        )
    return tuple(out)


def yaw_checking_20(first_overshoot_rad: float) -> Criterion:
    """Judge yaw-checking, 20°/20° zig-zag, §5.3.3.3: first overshoot ≤ 25°.

    Parameters
    ----------
    first_overshoot_rad : float
        First overshoot angle [rad].

    """
    return Criterion(
        name="20/20 zig-zag: first overshoot",
        value=first_overshoot_rad,
        limit=ZIGZAG_20_FIRST_OVERSHOOT_LIMIT_RAD,
        unit="rad",
        reference=f"{_SOURCE} 5.3.3.3",
    )


def stopping_ability(
    track_reach_m: float,
    length_m: float,
    *,
    limit_L: float = STOPPING_TRACK_REACH_LIMIT_L,
) -> Criterion:
    """Judge stopping ability, §5.3.4: track reach in a full-astern stop ≤ 15 L.

    Parameters
    ----------
    track_reach_m : float
        Track reach of a full-astern (crash) stop from the test speed [m].
    length_m : float
        Ship length L [m].
    limit_L : float, optional
        Limit in ship lengths; 15 unless the Administration has raised it for a ship
        of large displacement, at most 20 [L].

    """
    _require_positive(length_m, "length_m")
    _require_positive(limit_L, "limit_L")
    if limit_L > STOPPING_TRACK_REACH_MAX_LIMIT_L:
        raise ValueError(
            f"limit_L = {limit_L} exceeds {STOPPING_TRACK_REACH_MAX_LIMIT_L} L, the most an "
            "Administration may allow (MSC.137(76) 5.3.4)"
        )
    return Criterion(
        name="stopping ability: track reach (full astern)",
        value=track_reach_m,
        limit=limit_L * length_m,
        unit="m",
        reference=f"{_SOURCE} 5.3.4",
        length_m=length_m,
    )


def evaluate(
    length_m: float,
    *,
    turning: Sequence[TurningMetrics] = (),
    initial_turning_distance_m: float | None = None,
    zigzag_10: ZigzagMetrics | None = None,
    zigzag_20: ZigzagMetrics | None = None,
    speed_mps: float | None = None,
    stopping_track_reach_m: float | None = None,
    stopping_limit_L: float = STOPPING_TRACK_REACH_LIMIT_L,
) -> list[Criterion]:
    """Evaluate every criterion for which results are given.

    Parameters
    ----------
    length_m : float
        Ship length L [m].
    turning : sequence of TurningMetrics, optional
        Turning circles at 35° (or maximum) rudder, e.g. starboard and port.
    initial_turning_distance_m : float, optional
        Track distance to 10° heading change with 10° rudder [m].
    zigzag_10 : ZigzagMetrics, optional
        A 10°/10° zig-zag (checked: |δ| = Z = 10°).
    zigzag_20 : ZigzagMetrics, optional
        A 20°/20° zig-zag (checked: |δ| = Z = 20°).
    speed_mps : float, optional
        Test speed V for L/V [m/s]; default the 10°/10° run's approach speed.
    stopping_track_reach_m : float, optional
        Track reach of a full-astern stopping test [m].
    stopping_limit_L : float, optional
        Stopping limit in ship lengths (15, at most 20) [L].

    Returns
    -------
    list of Criterion
        In the order of the resolution: turning, initial turning, 10°/10°, 20°/20°,
        stopping.

    """
    _require_positive(length_m, "length_m")
    out: list[Criterion] = []
    for metrics in turning:
        out.extend(turning_ability(metrics, length_m))
    if initial_turning_distance_m is not None:
        out.append(initial_turning_ability(initial_turning_distance_m, length_m))
    if zigzag_10 is not None:
        _require_zigzag(zigzag_10, 10.0)
        speed = zigzag_10.approach_speed_mps if speed_mps is None else speed_mps
        out.extend(
            yaw_checking_10(
                zigzag_10.first_overshoot_rad, zigzag_10.second_overshoot_rad, length_m, speed
            )
        )
    if zigzag_20 is not None:
        _require_zigzag(zigzag_20, 20.0)
        out.append(yaw_checking_20(zigzag_20.first_overshoot_rad))
    if stopping_track_reach_m is not None:
        out.append(stopping_ability(stopping_track_reach_m, length_m, limit_L=stopping_limit_L))
    return out


def _require_finite(value: float, name: str) -> None:
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")


def _require_positive(value: float, name: str) -> None:
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{name} must be a positive number, got {value!r}")


def _length_over_speed_s(length_m: float, speed_mps: float) -> float:
    _require_positive(length_m, "length_m")
    _require_positive(speed_mps, "speed_mps")
    return length_m / speed_mps


def _zigzag_10_limit_rad(
    length_m: float,
    speed_mps: float,
    short_deg: float,
    long_deg: float,
    offset_deg: float,
    slope_deg_per_s: float,
) -> float:
    """Apply the rule of the 10°/10° zig-zag limits, §5.3.3.1-2, with t = L/V [s].

    Returns ``short_deg`` if t < 10 s, ``long_deg`` if t ≥ 30 s, and
    ``offset_deg + slope_deg_per_s · t`` in between (continuous at both ends), in
    radians.
    """
    lv_s = _length_over_speed_s(length_m, speed_mps)
    if lv_s < 10.0:
        return math.radians(short_deg)
    if lv_s >= 30.0:
        return math.radians(long_deg)
    return math.radians(offset_deg + slope_deg_per_s * lv_s)


def _require_zigzag(metrics: ZigzagMetrics, angle_deg: float) -> None:
    target = math.radians(angle_deg)
    if (
        abs(abs(metrics.rudder_rad) - target) > _ZIGZAG_TOLERANCE_RAD
        or abs(metrics.heading_rad - target) > _ZIGZAG_TOLERANCE_RAD
    ):
        raise ValueError(
            f"expected a {angle_deg:g}/{angle_deg:g} zig-zag, got "
            f"{math.degrees(abs(metrics.rudder_rad)):g}/{math.degrees(metrics.heading_rad):g}"
        )
