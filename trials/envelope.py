"""The envelope of the logged manoeuvres: how hard the ship was steered, turned and slowed.

An identified model is a fit of the manoeuvres in its logs. Beyond them (a larger rudder
angle, a faster turn, more speed lost) it extrapolates its structure, and that is where
its predictions fail: trained on 10°/10° zig-zags, the measured HSVA 20°/10° second
overshoots come out 4–4.5° too large; trained on zig-zags, the KVLCC2 reference's 35°
turns 7–12 % too tight (benchmarks/hsva.md, fidelity.md). Neither the coefficient
covariance nor the spread of the fit's own estimates measures that error, so a
prediction outside the envelope is said to be one (``scenarios.validation``). Five
axes, each a force the structure has to extrapolate:

* the largest rudder angle |δ| to each side [rad]: the rudder's normal force (lift, stall);
* the largest non-dimensional yaw rate r′ = |r|·L/U to each side: the hull's nonlinear
  damping;
* the lowest speed ratio U/U₀ (U₀ the approach speed): the propeller's loading and its
  slipstream share of the rudder inflow;
* the range of the approach speeds U₀ [m/s]: the Froude number, and the point at which
  the speed-scaled coefficients were fitted;
* the range of the propeller rates n [rev/s; said in rpm]: the thrust and slipstream
  terms, which logs at one rpm fix at that rpm only (a fit of constant-rpm zig-zags
  driven at another rpm through the FMU's input extrapolates its thrust split).

The sides count apart because a single-screw ship is not symmetric: a hard turn to port
predicted from logs that turned hard only to starboard extrapolates the model's
port/starboard difference (the KVLCC2 reference's port turn, trained on a starboard one).
A run is beyond the envelope on an axis by more than :data:`MARGIN` of its value
(:data:`SPEED_RATIO_MARGIN` for the speed ratio; either end of a range): noise in the
smoothed logs should not make a repeat of a logged manoeuvre an extrapolation. Speeds
are through the water (the identification's estimate of them when it estimates a
current).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

MARGIN = 0.05
"""Relative margin of the rudder angle, yaw rate and ranges before a run counts as beyond."""
SPEED_RATIO_MARGIN = 0.05
"""Margin of the speed ratio U/U₀ (absolute) before a run counts as beyond."""
RPM_PER_RPS = 60.0
"""Propeller rates are said in rpm, as the logs and the FMU's input give them."""
MIN_SPEED_RATIO_FOR_YAW_RATE = 0.2
"""r′ = r·L/U is taken where U ≥ this fraction of U₀ (a ship almost stopped has no r′)."""


class Sides(NamedTuple):
    """One magnitude per side: port (δ < 0, r < 0) and starboard (the trajectory's signs)."""

    port: float
    starboard: float

    @classmethod
    def of(cls, values: np.ndarray) -> Sides:
        """Return the largest magnitude of the negative and the positive ``values`` (0: none)."""
        return cls(float(np.max(-values, initial=0.0)), float(np.max(values, initial=0.0)))

    @classmethod
    def widest(cls, items: Iterable[Sides]) -> Sides:
        """Return the largest per side of ``items``."""
        listed = list(items)
        return cls(max(s.port for s in listed), max(s.starboard for s in listed))


class Span(NamedTuple):
    """The lowest and the highest of some values."""

    low: float
    high: float

    @classmethod
    def of(cls, values: np.ndarray) -> Span:
        """Return the span of ``values``."""
        return cls(float(np.min(values)), float(np.max(values)))

    def said(self, scale: float, unit: str) -> str:
        """Say the span ×``scale`` in ``unit``, three significant digits: ``"5-6.4 m/s"``.

        One value when both ends read the same (``"614 rpm"``).
        """
        low, high = f"{scale * self.low:.3g}", f"{scale * self.high:.3g}"
        return f"{low} {unit}" if low == high else f"{low}-{high} {unit}"

    @classmethod
    def widest(cls, items: Iterable[Span]) -> Span:
        """Return the span of all ``items``."""
        listed = list(items)
        return cls(min(s.low for s in listed), max(s.high for s in listed))


def _number(value: object) -> float | None:
    """Return ``value`` as a float when it is a finite number, else None."""
    if isinstance(value, int | float) and math.isfinite(value):
        return float(value)
    return None


def _pair(record: object, names: tuple[str, str]) -> tuple[float, float] | None:
    """Read a JSON object of two finite numbers named ``names``; None when it is not one."""
    if not isinstance(record, Mapping):
        return None
    first, second = (_number(record.get(name)) for name in names)
    return None if first is None or second is None else (first, second)


def _past_sides(label: str, logged: Sides, sailed: Sides, *, angle: bool) -> list[str]:
    """Phrases for the sides on which ``sailed`` exceeds ``logged`` by more than the margin.

    An ``angle`` [rad] is said in degrees with one decimal; anything else with two.
    """
    scale, digits, unit = (math.degrees(1.0), 1, " deg") if angle else (1.0, 2, "")
    return [
        f"{label} {scale * s:.{digits}f}{unit} to {side} (logs: {scale * known:.{digits}f}{unit})"
        for side, known, s in zip(Sides._fields, logged, sailed, strict=True)
        if s > (1.0 + MARGIN) * known
    ]


def _past_span(label: str, logged: Span, sailed: Span, *, scale: float, unit: str) -> list[str]:
    """Say it when ``sailed`` reaches below or above ``logged`` by more than the margin.

    Values are said ×``scale`` in ``unit`` (:meth:`Span.said`).
    """
    if (1.0 - MARGIN) * logged.low <= sailed.low and sailed.high <= (1.0 + MARGIN) * logged.high:
        return []
    return [f"{label} {sailed.said(scale, unit)} (logs: {logged.said(scale, unit)})"]


@dataclass(frozen=True)
class Envelope:
    """What some manoeuvres reached: the axes of the module docstring.

    Largest rudder angle [rad] and yaw rate r′ [-] to each side, lowest speed ratio U/U₀
    [-], the span of the approach speeds U₀ [m/s] and of the propeller rates [rev/s].
    """

    rudder_max_rad: Sides
    yaw_rate_max: Sides
    speed_ratio_min: float
    approach_speed_mps: Span
    propeller_rate_rps: Span

    def as_dict(self) -> dict[str, object]:
        """Return the JSON record (params.json ``identification.envelope``)."""
        return {
            "rudder_max_rad": self.rudder_max_rad._asdict(),
            "yaw_rate_max": self.yaw_rate_max._asdict(),
            "speed_ratio_min": self.speed_ratio_min,
            "approach_speed_mps": self.approach_speed_mps._asdict(),
            "propeller_rate_rps": self.propeller_rate_rps._asdict(),
        }

    @classmethod
    def from_dict(cls, record: Mapping[str, object]) -> Envelope | None:
        """Read :meth:`as_dict`'s record; None when a value is missing or not a finite number."""
        rudder = _pair(record.get("rudder_max_rad"), Sides._fields)
        yaw_rate = _pair(record.get("yaw_rate_max"), Sides._fields)
        ratio = _number(record.get("speed_ratio_min"))
        approach = _pair(record.get("approach_speed_mps"), Span._fields)
        propeller = _pair(record.get("propeller_rate_rps"), Span._fields)
        if rudder is None or yaw_rate is None or ratio is None:
            return None
        if approach is None or propeller is None:
            return None
        return cls(Sides(*rudder), Sides(*yaw_rate), ratio, Span(*approach), Span(*propeller))

    def describe(self) -> str:
        """Say what the envelope holds, one line of text.

        E.g. ``"rudder 20.0 deg to port, 35.0 deg to starboard; r' 0.50 to port, 0.89 to
        starboard; speed down to 0.37 U0 from approach speeds of 7.96-7.97 m/s; propeller
        at 80.7 rpm"``.
        """
        rudder, yaw_rate = self.rudder_max_rad, self.yaw_rate_max
        return (
            f"rudder {math.degrees(rudder.port):.1f} deg to port, "
            f"{math.degrees(rudder.starboard):.1f} deg to starboard; r' {yaw_rate.port:.2f} to "
            f"port, {yaw_rate.starboard:.2f} to starboard; speed down to "
            f"{self.speed_ratio_min:.2f} U0 from approach speeds of "
            f"{self.approach_speed_mps.said(1.0, 'm/s')}; propeller at "
            f"{self.propeller_rate_rps.said(RPM_PER_RPS, 'rpm')}"
        )

    def beyond(self, run: Envelope) -> tuple[str, ...]:
        """Say on which axes ``run`` leaves this envelope (by more than the margins).

        One phrase per axis and side, e.g. ``"rudder 35.0 deg to port (logs: 20.1 deg)"``;
        empty when the run stays inside.
        """
        out = [
            *_past_sides("rudder", self.rudder_max_rad, run.rudder_max_rad, angle=True),
            *_past_sides("yaw rate r'", self.yaw_rate_max, run.yaw_rate_max, angle=False),
        ]
        if run.speed_ratio_min < self.speed_ratio_min - SPEED_RATIO_MARGIN:
            out.append(
                f"speed down to {run.speed_ratio_min:.2f} U0 (logs: {self.speed_ratio_min:.2f} U0)"
            )
        out += _past_span(
            "approach speed",
            self.approach_speed_mps,
            run.approach_speed_mps,
            scale=1.0,
            unit="m/s",
        )
        out += _past_span(
            "propeller",
            self.propeller_rate_rps,
            run.propeller_rate_rps,
            scale=RPM_PER_RPS,
            unit="rpm",
        )
        return tuple(out)


def envelope_of(
    rudder_rad: np.ndarray,
    r_radps: np.ndarray,
    speed_mps: np.ndarray,
    n_rps: np.ndarray,
    length_m: float,
    approach_samples: int = 1,
) -> Envelope:
    """Return the envelope of one manoeuvre's samples.

    Parameters
    ----------
    rudder_rad, r_radps, speed_mps, n_rps : numpy.ndarray
        Rudder angle [rad], yaw rate [rad/s], speed [m/s] and propeller rate [rev/s] per
        sample, the approach first (positive to starboard).
    length_m : float
        Ship length [m].
    approach_samples : int
        How many samples the approach takes: U₀ is their mean speed (a log's smoothed
        speed is noisy; a simulated run's first sample is its approach).

    """
    approach = float(np.mean(speed_mps[: max(approach_samples, 1)]))
    ratio = speed_mps / approach
    moving = ratio >= MIN_SPEED_RATIO_FOR_YAW_RATE
    return Envelope(
        rudder_max_rad=Sides.of(rudder_rad),
        yaw_rate_max=Sides.of(r_radps[moving] * length_m / speed_mps[moving]),
        speed_ratio_min=float(np.min(ratio)),
        approach_speed_mps=Span(approach, approach),
        propeller_rate_rps=Span.of(n_rps),
    )


def trajectory_envelope(trajectory: np.ndarray, length_m: float) -> Envelope:
    """Return the envelope of a run (``trials.trajectory``; speed through the water)."""
    speed_mps = np.hypot(trajectory["u_mps"], trajectory["v_mps"])
    return envelope_of(
        trajectory["rudder_rad"], trajectory["r_radps"], speed_mps, trajectory["n_rps"], length_m
    )


def union(envelopes: Iterable[Envelope]) -> Envelope:
    """Return the envelope of several manoeuvres together (the widest on every axis)."""
    items = list(envelopes)
    return Envelope(
        rudder_max_rad=Sides.widest(e.rudder_max_rad for e in items),
        yaw_rate_max=Sides.widest(e.yaw_rate_max for e in items),
        speed_ratio_min=min(e.speed_ratio_min for e in items),
        approach_speed_mps=Span.widest(e.approach_speed_mps for e in items),
        propeller_rate_rps=Span.widest(e.propeller_rate_rps for e in items),
    )
