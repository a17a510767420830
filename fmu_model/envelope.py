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

Two users: the scenarios judge whole runs (``Envelope.beyond`` of a run's
:func:`trajectory_envelope`), and every FMU built from parameters that record the
envelope judges itself while it runs (:class:`ExtrapolationWatch`, one warning per axis
and side in the host's log), so that a co-simulation in any tool learns where the model
extrapolates. This module is on the FMU's floor for that reason: it imports only the
standard library and numpy, and the pythonfmu FMU carries it; the native FMU's C layer
follows the same rule with the numbers and formats written into its ``model_config.h``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
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
DEG_PER_RAD = math.degrees(1.0)
"""Rudder angles are said in degrees."""

# What :meth:`Envelope.beyond` says, as printf formats: the native FMU's C layer says the
# same (``model_config.h``), so both backends log the same text.
RUDDER_FORMAT = "rudder %.1f deg to %s (logs: %.1f deg)"
"""A rudder angle past the logs': the angle [deg], the side, the logs' largest [deg]."""
YAW_RATE_FORMAT = "yaw rate r' %.2f to %s (logs: %.2f)"
"""A yaw rate past the logs': r′, the side, the logs' largest r′."""
SPEED_RATIO_FORMAT = "speed down to %.2f U0 (logs: %.2f U0)"
"""A speed below the logs': U/U₀, the logs' lowest U/U₀."""
SPAN_VALUE_FORMAT = "%.3g"
"""One end of a span (:meth:`Span.said`)."""
SPAN_FORMAT = "%s %s (logs: %s)"
"""A value outside the logs' span: the axis, the value said, the logs' span said."""
AXES = (
    "rudder to port",
    "rudder to starboard",
    "yaw rate to port",
    "yaw rate to starboard",
    "speed",
    "approach speed",
    "propeller",
)
"""The axes and sides :meth:`Envelope.beyond` judges, in its order (bit k of the native
FMU's record of the axes it has warned about)."""
EXTRAPOLATION_FORMAT = "%s: t = %.9g s: beyond the identification logs, the model extrapolates: %s"
"""The warning an FMU logs (status warning, category ``logStatusWarning``) the first time
one of its steps goes beyond the envelope of its logs on an axis and side
(:class:`ExtrapolationWatch`): the FMI function, the time at the end of the step [s] and
:meth:`Envelope.beyond`'s phrase."""


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
        low, high = (SPAN_VALUE_FORMAT % (scale * end) for end in self)
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


def _past_sides(
    axis: str, logged: Sides, sailed: Sides, *, phrase: str, scale: float
) -> list[tuple[str, str]]:
    """(axis and side, phrase) for the sides on which ``sailed`` exceeds ``logged``.

    By more than the margin; values said ×``scale`` with the printf format ``phrase``.
    """
    return [
        (f"{axis} to {side}", phrase % (scale * s, side, scale * known))
        for side, known, s in zip(Sides._fields, logged, sailed, strict=True)
        if s > (1.0 + MARGIN) * known
    ]


def _past_span(
    axis: str, logged: Span, sailed: Span, *, scale: float, unit: str
) -> list[tuple[str, str]]:
    """(axis, phrase) when ``sailed`` reaches below or above ``logged`` by more than the margin.

    Values are said ×``scale`` in ``unit`` (:meth:`Span.said`).
    """
    if (1.0 - MARGIN) * logged.low <= sailed.low and sailed.high <= (1.0 + MARGIN) * logged.high:
        return []
    return [(axis, SPAN_FORMAT % (axis, sailed.said(scale, unit), logged.said(scale, unit)))]


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
            f"rudder {DEG_PER_RAD * rudder.port:.1f} deg to port, "
            f"{DEG_PER_RAD * rudder.starboard:.1f} deg to starboard; r' {yaw_rate.port:.2f} to "
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
        return tuple(phrase for _, phrase in self.beyond_by_axis(run))

    def beyond_by_axis(self, run: Envelope) -> list[tuple[str, str]]:
        """:meth:`beyond`'s phrases, each with its axis and side (one of :data:`AXES`)."""
        out = [
            *_past_sides(
                "rudder",
                self.rudder_max_rad,
                run.rudder_max_rad,
                phrase=RUDDER_FORMAT,
                scale=DEG_PER_RAD,
            ),
            *_past_sides(
                "yaw rate", self.yaw_rate_max, run.yaw_rate_max, phrase=YAW_RATE_FORMAT, scale=1.0
            ),
        ]
        if run.speed_ratio_min < self.speed_ratio_min - SPEED_RATIO_MARGIN:
            out.append(("speed", SPEED_RATIO_FORMAT % (run.speed_ratio_min, self.speed_ratio_min)))
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
        return out


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


def instant_envelope(
    rudder_rad: float,
    n_rps: float,
    state: Sequence[float] | np.ndarray,
    start_speed_mps: float,
    length_m: float,
) -> Envelope:
    """Return the envelope of one instant of a run that started at ``start_speed_mps``.

    ``state`` begins with u [m/s], v [m/s], r [rad/s]; U₀ = ``start_speed_mps``. What
    :func:`trajectory_envelope` makes of that sample in a run whose first sample moves at
    U₀; a run from rest (U₀ = 0) has no speed ratio (1 here) and no r′ (0).
    """
    u, v, r = (float(x) for x in state[:3])
    speed = math.sqrt(u * u + v * v)  # as the C layer computes it
    ratio, yaw_rate = 1.0, 0.0
    if start_speed_mps > 0.0:
        ratio = speed / start_speed_mps
        if ratio >= MIN_SPEED_RATIO_FOR_YAW_RATE:
            yaw_rate = r * length_m / speed
    return Envelope(
        rudder_max_rad=Sides(max(-rudder_rad, 0.0), max(rudder_rad, 0.0)),
        yaw_rate_max=Sides(max(-yaw_rate, 0.0), max(yaw_rate, 0.0)),
        speed_ratio_min=ratio,
        approach_speed_mps=Span(start_speed_mps, start_speed_mps),
        propeller_rate_rps=Span(n_rps, n_rps),
    )


@dataclass
class ExtrapolationWatch:
    """The run-time rule of both FMU backends: warn once per axis beyond the logs.

    After every co-simulation step the step's inputs (rudder angle, propeller rate) and
    the state at its end make an :func:`instant_envelope`, with U₀ the start speed
    √(u0² + v0²); each axis and side of :data:`AXES` on which it leaves the envelope of
    the identification's logs for the first time since the start is one warning
    (:data:`EXTRAPOLATION_FORMAT`). ``warned`` holds those axes; a new start clears it.
    """

    envelope: Envelope
    warned: set[str] = field(default_factory=set)

    def news(self, function: str, time_s: float, instant: Envelope) -> list[str]:
        """Return the warnings of the axes ``instant`` leaves for the first time.

        ``function`` is the FMI function and ``time_s`` the end of its step [s], for the
        message.
        """
        out = []
        for axis, phrase in self.envelope.beyond_by_axis(instant):
            if axis not in self.warned:
                self.warned.add(axis)
                out.append(EXTRAPOLATION_FORMAT % (function, time_s, phrase))
        return out
