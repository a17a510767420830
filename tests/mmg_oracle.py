"""A test oracle for the MMG reference ship: adaptive, event-located manoeuvres.

The reference ship is stepped in the project by the one integrator (``scenarios.kvlcc2.step``,
RK4 at fixed steps, driven by ``trials.run``). The tests check it against this
independent simulation: DOP853 at rtol 1e-10 with the rudder's kinks as breakpoints and
the zig-zag reversals located as events on the heading (ref. §10 of
``shared/reference/kvlcc2_mmg.md``). It lives with the tests because only they need it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from scipy.integrate import solve_ivp

from scenarios.kvlcc2 import MmgShip, _derivatives
from trials.trajectory import TRAJECTORY_DTYPE

_RTOL = 1e-10
_ATOL_REL = 1e-10
_FULL_SCALE_SAMPLE_DT_S = 0.1
_FULL_LENGTH_M = 320.0


@dataclass(frozen=True)
class TurningProgram:
    """Turning-circle rudder program (ref. §10).

    Attributes
    ----------
    rudder_rad : float
        Commanded rudder angle from t = 0 on [rad]; positive is a starboard turn.

    """

    rudder_rad: float


@dataclass(frozen=True)
class ZigzagProgram:
    """Zig-zag rudder program Z/Z (ref. §10).

    The rudder is commanded to ``rudder_rad`` at t = 0; each time the heading reaches
    ``sign(rudder_rad) * heading_rad`` (then its negative, alternately) the command is
    reversed. A positive ``rudder_rad`` is starboard first.

    Attributes
    ----------
    rudder_rad : float
        First rudder command, non-zero [rad].
    heading_rad : float
        Check heading, > 0 [rad].

    """

    rudder_rad: float
    heading_rad: float


def default_sample_dt_s(ship: MmgShip) -> float:
    """Return the default sampling interval: 0.1 s full-scale equivalent [s]."""
    return _FULL_SCALE_SAMPLE_DT_S * math.sqrt(ship.length_m / _FULL_LENGTH_M)


class _Segment(NamedTuple):
    """One integration piece with an affine rudder angle delta0 + rate (t - t0)."""

    t0: float
    t1: float
    solution: Callable[[np.ndarray], np.ndarray]
    delta0: float
    delta_rate: float


@dataclass(frozen=True)
class _HeadingCrossing:
    """Terminal ``solve_ivp`` event: the heading reaches ``target_rad`` (ref. §10)."""

    target_rad: float
    direction: float  # +1: psi increasing through the target, -1: decreasing
    terminal: bool = True

    def __call__(self, t: float, y: np.ndarray) -> float:
        return float(y[5] - self.target_rad)


def _integrate_segment(
    ship: MmgShip,
    t0: float,
    t1: float,
    y0: np.ndarray,
    delta0: float,
    delta_rate: float,
    n: float,
    heading_target: float | None,
    heading_direction: float,
) -> tuple[_Segment, float, np.ndarray, bool]:
    """Integrate from t0 to t1 (or to a heading crossing); return segment and end point."""
    U0 = ship.approach_speed_mps
    L = ship.length_m
    atol = _ATOL_REL * np.array([U0, U0, U0 / L, L, L, 1.0])

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        delta = delta0 + delta_rate * (t - t0)
        return np.array(_derivatives(ship, y[0], y[1], y[2], y[5], delta, n))

    events = None
    if heading_target is not None:
        events = [_HeadingCrossing(heading_target, heading_direction)]

    sol = solve_ivp(
        rhs,
        (t0, t1),
        y0,
        method="DOP853",
        rtol=_RTOL,
        atol=atol,
        dense_output=True,
        events=events,
    )
    if not sol.success:
        raise RuntimeError(f"MMG integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    hit = heading_target is not None and sol.status == 1 and sol.t_events[0].size > 0
    if hit:
        t_end = float(sol.t_events[0][0])
        y_end = np.array(sol.y_events[0][0], dtype=float)
    else:
        t_end = float(sol.t[-1])
        y_end = np.array(sol.y[:, -1], dtype=float)
    return _Segment(t0, t_end, sol.sol, delta0, delta_rate), t_end, y_end, hit


def simulate_maneuver(
    ship: MmgShip,
    program: TurningProgram | ZigzagProgram,
    duration_s: float,
    *,
    n_rps: float | None = None,
    sample_dt_s: float | None = None,
) -> np.ndarray:
    """Simulate a turning or zig-zag manoeuvre accurately (ref. §10).

    The ship starts at t = 0 (execute) from a straight run in equilibrium: u = U0,
    v_m = r = 0, rudder 0, heading 0, at the origin. The steering gear moves the rudder
    from its current angle to the commanded one at the constant rate
    ``ship.rudder_rate_radps``, without dead time. Integration is adaptive DOP853 with
    rtol 1e-10; the rudder angle is an exact piecewise-linear function of time (its kinks
    are integration breakpoints) and zig-zag reversals are located as events at the
    heading crossings.

    Parameters
    ----------
    ship : MmgShip
        The ship.
    program : TurningProgram or ZigzagProgram
        Rudder program.
    duration_s : float
        Simulated time after execute, > 0 [s].
    n_rps : float, optional
        Constant propeller speed [rev/s]; ``ship.nominal_rps`` by default.
    sample_dt_s : float, optional
        Sampling interval of the returned trajectory [s]; 0.1 s full-scale equivalent by
        default (`default_sample_dt_s`).

    Returns
    -------
    numpy.ndarray
        Trajectory of dtype ``TRAJECTORY_DTYPE`` sampled at t = 0, dt, 2 dt, ... up to
        ``duration_s``, with the actual rudder angle and the propeller speed.

    Raises
    ------
    ValueError
        If the program, duration, sampling interval or propeller speed is invalid.

    """
    if not (math.isfinite(duration_s) and duration_s > 0.0):
        raise ValueError(f"duration_s must be a positive finite number, got {duration_s!r}")
    dt = default_sample_dt_s(ship) if sample_dt_s is None else float(sample_dt_s)
    if not (math.isfinite(dt) and dt > 0.0):
        raise ValueError(f"sample_dt_s must be a positive finite number, got {sample_dt_s!r}")
    n = ship.nominal_rps if n_rps is None else float(n_rps)
    if not (math.isfinite(n) and n >= 0.0):
        raise ValueError(f"n_rps must be a finite number >= 0, got {n_rps!r}")

    command = float(program.rudder_rad)
    heading_target: float | None
    if isinstance(program, ZigzagProgram):
        if not (command != 0.0 and math.isfinite(command)):
            raise ValueError("ZigzagProgram.rudder_rad must be finite and non-zero")
        if not (math.isfinite(program.heading_rad) and program.heading_rad > 0.0):
            raise ValueError("ZigzagProgram.heading_rad must be finite and positive")
        heading_target = math.copysign(float(program.heading_rad), command)
    elif isinstance(program, TurningProgram):
        if not math.isfinite(command):
            raise ValueError("TurningProgram.rudder_rad must be finite")
        heading_target = None
    else:
        raise ValueError(f"unknown manoeuvre program {program!r}")

    rate = ship.rudder_rate_radps
    t = 0.0
    y = np.array([ship.approach_speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0])
    delta = 0.0
    segments: list[_Segment] = []
    while t < duration_s:
        if delta != command:
            # steering gear moving: reaches the command at t_reach
            t_reach = t + abs(command - delta) / rate
            t_stop = min(t_reach, duration_s)
            delta_rate = math.copysign(rate, command - delta)
        else:
            t_reach = math.inf
            t_stop = duration_s
            delta_rate = 0.0
        direction = 0.0 if heading_target is None else math.copysign(1.0, heading_target)
        segment, t, y, hit = _integrate_segment(
            ship, t, t_stop, y, delta, delta_rate, n, heading_target, direction
        )
        segments.append(segment)
        delta = command if (not hit and t >= t_reach) else delta + delta_rate * (t - segment.t0)
        if hit:
            # Zig-zag reversal at the check heading (ref. §10)
            assert heading_target is not None
            command = -command
            heading_target = -heading_target

    n_samples = math.floor(duration_s / dt * (1.0 + 1e-12)) + 1
    times = np.arange(n_samples) * dt
    out = np.zeros(n_samples, dtype=TRAJECTORY_DTYPE)
    out["time_s"] = times
    out["n_rps"] = n
    for seg in segments:
        mask = (times >= seg.t0) & (times <= seg.t1)
        if not np.any(mask):
            continue
        ts = np.clip(times[mask], seg.t0, seg.t1)
        ys = seg.solution(ts)
        out["u_mps"][mask] = ys[0]
        out["v_mps"][mask] = ys[1]
        out["r_radps"][mask] = ys[2]
        out["x_m"][mask] = ys[3]
        out["y_m"][mask] = ys[4]
        out["psi_rad"][mask] = ys[5]
        out["rudder_rad"][mask] = seg.delta0 + seg.delta_rate * (ts - seg.t0)
    # the last sample may lie a rounding error beyond the end of the last segment
    last = segments[-1]
    beyond = times > last.t1
    if np.any(beyond):
        ys = last.solution(np.full(int(beyond.sum()), last.t1))
        for i, name in enumerate(("u_mps", "v_mps", "r_radps", "x_m", "y_m", "psi_rad")):
            out[name][beyond] = ys[i]
        out["rudder_rad"][beyond] = last.delta0 + last.delta_rate * (last.t1 - last.t0)
    return out
