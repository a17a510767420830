"""The guards of the refinement: virtual hard-over turns and the keep/reject rules.

Output error on zig-zags alone is unreliable for turns (reference/model_structures.md,
§6 and §7). After refining, hard-over (35°) turns both ways are simulated from the
training approach state (:class:`Approach`) with the start and the refined
coefficients (:func:`virtual_turns`). When no training log turns through 180°
(:func:`covers_turn`) and the refined tactical diameter differs from the start's by
more than ``turn_tolerance`` (:func:`turn_spread`; by default 0: at all), the start
estimate is kept and the spread reported, also when the start does not turn through
180° (it then fails the sanity guard, whose rescue judges it: whether a failing turn
stops short of 180° or just past it must not choose the estimate): without a turning
log, output error is a check on the turn, not an estimate of it. Independently, a
refined estimate is only kept when it lowers the cost, every training log replays
without divergence and both virtual turns stay bounded, never fall back against their
rudder and pass 360° (or, when the start's do not either, go at least as far as the
start's), its centripetal surge term keeps a ship's sign where the start's has it
(:func:`centripetal_is_a_ships`), and, when the start's do, its virtual 20°/20° zig-zags
to both sides reach their second overshoot without diverging (:func:`virtual_zigzags`;
:func:`decide`).
Unless the logs turn through 180° to both sides, a refined estimate whose two virtual
turns differ by more than :data:`MAX_SIDE_ASYMMETRY` (and more than the start's) is
rejected too: the side no log verifies is then the refinement's guess.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from identifier.output_error.objective import DIVERGENCE_SPEED_FACTOR
from identifier.output_error.records import (
    SANITY_FAILURE,
    FitSummary,
    RefineSettings,
    VirtualTurn,
)
from identifier.smoothing import SmoothedTrack
from trials.logs import ManeuverLog
from trials.maneuvers import Program, turning_circle, zigzag
from trials.metrics import MetricsError, turned_back_rad, turning_metrics, zigzag_metrics
from trials.run import BatchRun, ModelPlant, run_batch

MAX_SIDE_ASYMMETRY = 0.10
"""Largest port/starboard difference of the virtual 35° tactical diameters [-] a refined
estimate may bring in when no log verifies both sides. Single-screw ships turn tighter to
one side, by a few per cent: the Mariner reference 4 % (``scenarios.mariner``), the
KVLCC2 hull in free-running tests about 8 % (issue 13); refined fits of the Mariner with
its starboard turn in training put the unlogged port turn 16 % and 59 % tighter
(``benchmarks/fidelity.md``, "A ship of another structure")."""

POOR_REPLAY_L = 2.0
"""RMS distance [ship lengths] of the estimate kept's open-loop replays of its training logs
from their tracks beyond which it is warned of as no sound model of them. Kept starts
replay 0.36–0.49 L off where the turn check keeps them on KVLCC2 zig-zags (at sea, its
7 m model), 0.40–0.84 L on HSVA's runs (20°/10°: 30 L of track each), 1.41 L on the
Mariner's single port turn (a start that fails the sanity guard, warned of as such); 3.05
L on a turning circle and two zig-zags logged at 5 m and 1° (the refined estimate 0.03 L
off, rejected for a virtual turn that snaps back after two loops): that is no model of
its logs."""

# Hard-over rudder of the virtual turns [rad] (IMO MSC.137(76) turning test).
HARD_OVER_RAD = math.radians(35.0)
# Rudder and heading angle of the virtual zig-zags [rad] (MSC.137(76) 20°/20° test).
ZIGZAG_RAD = math.radians(20.0)
# A logged rudder slower than this never moved [rad/s].
_RUDDER_STILL_RADPS = math.radians(0.01)
# Steering-gear rate used when the logs never move the rudder [rad/s] (IMO minimum).
_DEFAULT_RUDDER_RATE_RADPS = math.radians(2.32)


@dataclass(frozen=True)
class Approach:
    """The training approach the virtual turns start from.

    Attributes
    ----------
    speed_mps : float
        Approach speed U0 [m/s].
    n_rps : float
        Propeller speed [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].

    """

    speed_mps: float
    n_rps: float
    rudder_rate_radps: float

    def turns(
        self, params: ModelParameters, settings: RefineSettings
    ) -> tuple[VirtualTurn, VirtualTurn]:
        """Virtual hard-over turns of ``params`` from this approach (:func:`virtual_turns`).

        Parameters
        ----------
        params : ModelParameters
            The model.
        settings : RefineSettings
            Run length (``turn_duration_factor``) and largest RK4 step [s].

        Returns
        -------
        tuple of VirtualTurn
            Starboard, port.

        """
        return virtual_turns(params, **self._sailing(settings))

    def zigzags_complete(self, params: ModelParameters, settings: RefineSettings) -> bool:
        """Whether ``params`` sails :func:`virtual_zigzags` from this approach."""
        return virtual_zigzags(params, **self._sailing(settings))

    def _sailing(self, settings: RefineSettings) -> dict[str, Any]:
        """Return the keyword arguments of the virtual manoeuvres from this approach."""
        return {
            "speed_mps": self.speed_mps,
            "n_rps": self.n_rps,
            "rudder_rate_radps": self.rudder_rate_radps,
            "duration_factor": settings.turn_duration_factor,
            "max_step_s": settings.max_step_s,
        }


def training_approach(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    *,
    rudder_rate_radps: float | None = None,
) -> Approach:
    """Approach speed, propeller speed and rudder rate of the training logs.

    Parameters
    ----------
    params : ModelParameters
        The estimate; its nominal speed [m/s] and propeller speed [rev/s] when given.
    logs : sequence of ManeuverLog
        The training logs (propeller speed, fastest rudder movement).
    tracks : sequence of SmoothedTrack
        Their smoothed tracks (first u [m/s]).
    rudder_rate_radps : float, optional
        Steering-gear rate to use [rad/s]; by default the fastest logged, or the IMO
        minimum 2.32°/s when no log moves the rudder.

    Returns
    -------
    Approach
        The conditions of the virtual turns.

    """
    speed = params.nominal_speed_mps or float(np.mean([t.u_mps[0] for t in tracks]))
    n = params.nominal_n_rps or float(np.mean([log.n_rps[0] for log in logs]))
    if rudder_rate_radps is None:
        rates = [
            float(np.max(np.abs(np.diff(log.rudder_rad)) / np.diff(log.time_s))) for log in logs
        ]
        rate = max(rates)
        rudder_rate_radps = rate if rate > _RUDDER_STILL_RADPS else _DEFAULT_RUDDER_RATE_RADPS
    return Approach(speed_mps=speed, n_rps=n, rudder_rate_radps=rudder_rate_radps)


def virtual_turns(
    params: ModelParameters,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float = _DEFAULT_RUDDER_RATE_RADPS,
    rudder_rad: float = HARD_OVER_RAD,
    duration_factor: float = 60.0,
    step_s: float = 1.0,
    max_step_s: float | None = None,
) -> tuple[VirtualTurn, VirtualTurn]:
    """Simulate hard-over turns to starboard and to port from a straight approach.

    The ship starts at (u, v, r) = (``speed_mps``, 0, 0) with the rudder amidships,
    the rudder moves at ``rudder_rate_radps`` to ±``rudder_rad`` and stays there for
    ``duration_factor`` · L / U0 seconds at constant ``n_rps`` (``trials.run``, the one
    programme runner).

    Parameters
    ----------
    params : ModelParameters
        The model.
    speed_mps : float
        Approach speed [m/s].
    n_rps : float
        Propeller speed [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    rudder_rad : float
        Hard-over rudder angle [rad].
    duration_factor : float
        Run length in units of L / U0.
    step_s : float
        Communication step of the run [s].
    max_step_s : float, optional
        Largest RK4 step [s]; default 0.05 L / U0.

    Returns
    -------
    tuple of VirtualTurn
        Starboard, port.

    """
    if not (speed_mps > 0.0 and rudder_rate_radps > 0.0):
        raise ValueError("speed_mps and rudder_rate_radps must be positive")
    turns = []
    for sign in (1.0, -1.0):
        program = turning_circle(
            sign * rudder_rad,
            heading_change_rad=math.inf,  # the whole run: a late divergence counts
            max_time_s=duration_factor * params.length_m / speed_mps,
        )
        run = _sail(params, program, speed_mps, n_rps, rudder_rate_radps, step_s, max_step_s)
        traj = run.trajectories[0]
        change = float(np.max(sign * (traj["psi_rad"] - traj["psi_rad"][0])))
        advance = transfer = tactical = None
        if change >= math.pi:
            try:
                metrics = turning_metrics(traj)
            except MetricsError:
                pass
            else:
                advance = metrics.advance_m
                transfer = metrics.transfer_m
                tactical = metrics.tactical_diameter_m
        turns.append(
            VirtualTurn(
                rudder_rad=sign * rudder_rad,
                advance_m=advance,
                transfer_m=transfer,
                tactical_diameter_m=tactical,
                heading_change_rad=change,
                bounded=not bool(run.diverged[0]),
                passed_360=change >= 2.0 * math.pi,
                turned_back_rad=turned_back_rad(traj) if change > 0.0 else 0.0,
                lost_headway=bool(np.any(traj["u_mps"] <= 0.0)),
            )
        )
    return turns[0], turns[1]


def virtual_zigzags(
    params: ModelParameters,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float = _DEFAULT_RUDDER_RATE_RADPS,
    duration_factor: float = 60.0,
    step_s: float = 1.0,
    max_step_s: float | None = None,
) -> bool:
    """Whether 20°/20° zig-zags to both sides reach their second overshoot.

    From the straight approach of :func:`virtual_turns`, closed loop (the rudder
    reverses when the heading passes ±20°); False when a run diverges (the speed or
    yaw-rate bound of the turns), or does not end its third leg, past the second
    overshoot, within ``duration_factor`` · L / U0 (a swing that 20° of counter-rudder
    does not check, a rudder too weak to turn the ship; a ship's 20/20 zig-zag gets
    there in a few L / U0, KVLCC2's in 6), or no second overshoot is measured.
    The refinement fitted the logs' replays with the logged rudder; this sails the
    standard manoeuvre the model will be asked for.
    """
    leg_limit_s = duration_factor * params.length_m / speed_mps
    for sign in (1.0, -1.0):
        program = zigzag(sign * ZIGZAG_RAD, ZIGZAG_RAD, n_reversals=2, max_time_s=leg_limit_s)
        run = _sail(params, program, speed_mps, n_rps, rudder_rate_radps, step_s, max_step_s)
        trajectory = run.trajectories[0]
        if run.diverged[0] or trajectory["time_s"][-1] >= leg_limit_s:
            return False
        try:
            zigzag_metrics(trajectory, program.rudder_rad, program.heading_rad)
        except MetricsError:
            return False
    return True


def _sail(
    params: ModelParameters,
    program: Program,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float,
    step_s: float,
    max_step_s: float | None,
) -> BatchRun:
    """Sail a virtual manoeuvre from the straight approach.

    RK4 steps of at most ``max_step_s`` (default 0.05 L / U0); a run diverges beyond the
    speed and yaw-rate bounds of the refinement's objective.
    """
    if max_step_s is None:
        max_step_s = 0.05 * params.length_m / speed_mps
    return run_batch(
        ModelPlant(params, max_step_s=max_step_s),
        program,
        speed_mps=speed_mps,
        n_rps=n_rps,
        rudder_rate_radps=rudder_rate_radps,
        dt_s=step_s,
        divergence_factor=DIVERGENCE_SPEED_FACTOR,
    )


def turn_spread(reference: Sequence[VirtualTurn], candidate: Sequence[VirtualTurn]) -> float:
    """Largest relative change of the tactical diameter, candidate vs reference turns.

    max over the turns of |D_T,candidate / D_T,reference − 1|; inf when a turn of
    either set does not reach 180° of heading change.

    Parameters
    ----------
    reference, candidate : sequence of VirtualTurn
        Turns in the same order (starboard, port).

    Returns
    -------
    float
        The spread (dimensionless), 0 for identical turns.

    """
    spread = 0.0
    for ref, cand in zip(reference, candidate, strict=True):
        if ref.tactical_diameter_m is None or cand.tactical_diameter_m is None:
            return math.inf
        spread = max(spread, abs(cand.tactical_diameter_m / ref.tactical_diameter_m - 1.0))
    return spread


def covers_turn(tracks: Sequence[SmoothedTrack]) -> bool:
    """Whether any track turns through 180° of heading (a turning-circle log)."""
    return any(float(np.ptp(t.heading_rad)) >= math.pi for t in tracks)


def covers_both_sides(headings_rad: Sequence[np.ndarray]) -> bool:
    """Whether continuous headings [rad] turn through 180° to starboard and to port.

    A side counts when some log's heading moves 180° from its first value that way.
    """
    to_stbd = to_port = False
    for heading in headings_rad:
        change = np.asarray(heading) - heading[0]
        to_stbd |= bool(change.max() >= math.pi)
        to_port |= bool(change.min() <= -math.pi)
    return to_stbd and to_port


def side_asymmetry(turns: Sequence[VirtualTurn]) -> float:
    """|D_T,port / D_T,stbd − 1| of virtual turns (starboard, port); inf without both."""
    stbd, port = (turn.tactical_diameter_m for turn in turns)
    if stbd is None or port is None:
        return math.inf
    return abs(port / stbd - 1.0)


def method_label(method: str) -> str:
    """Name of an estimation method in messages ("EKF" for "ekf")."""
    return "EKF" if method == "ekf" else method


def candidate_disagreement(
    start: str,
    start_turns: Sequence[VirtualTurn],
    other_turns: Mapping[str, Sequence[VirtualTurn]],
    tolerance: float,
) -> list[str]:
    """Warn when another candidate start predicts a different hard-over turn.

    Estimates from the same logs that turn differently mean that the logs do not
    determine the turn (reference/model_structures.md §8): only a turning log, or
    cross-validation, can tell which is right.

    Parameters
    ----------
    start : str
        The method of the start estimate.
    start_turns : sequence of VirtualTurn
        Its virtual turns.
    other_turns : mapping of str to sequence of VirtualTurn
        The other candidates' virtual turns (from the same approach) by method.
    tolerance : float
        Largest relative spread of the tactical diameters that is not reported
        (``RefineSettings.disagreement_tolerance``).

    Returns
    -------
    list of str
        One warning naming the candidate that differs most, or none.

    """
    spreads = {name: turn_spread(start_turns, turns) for name, turns in other_turns.items()}
    worst = max(spreads, key=spreads.__getitem__, default=None)
    if worst is None or spreads[worst] <= tolerance:
        return []
    amount = "through 180 deg" if math.isinf(spreads[worst]) else f"by {spreads[worst]:.0%}"
    return [
        f"the {method_label(start)} and {method_label(worst)} estimates from these logs "
        f"predict virtual 35 deg turns that differ {amount}: the logs do not determine the "
        "turning circle; add a turning log or check with 'identifier crossval'"
    ]


def decide(
    initial: FitSummary,
    refined: FitSummary,
    *,
    turn_check: bool,
    spread: float,
    tolerance: float,
    label: str,
    both_sides_logged: bool = False,
) -> tuple[str, str]:
    """Which estimate to keep, "initial" or "refined", and why (model_structures.md §6, §7).

    Parameters
    ----------
    initial, refined : FitSummary
        The start estimate and the output-error optimum.
    turn_check : bool
        Whether the turn check of §6 applies (no turning log in training).
    spread : float
        :func:`turn_spread` of the refined turns against the initial ones.
    tolerance : float
        Largest spread accepted under the turn check.
    label : str
        Name of the start's method in the reason.
    both_sides_logged : bool
        Whether the logs turn through 180° to both sides (:func:`covers_both_sides`):
        then they, not :data:`MAX_SIDE_ASYMMETRY`, judge the turns' asymmetry.

    Returns
    -------
    tuple of str
        "initial" or "refined", and the reason in one sentence.

    """
    keep = kept_phrase(label)
    if refined.diverged:
        return "initial", (
            "output-error estimate rejected: replaying "
            + ", ".join(refined.diverged)
            + f" diverges; {keep}"
        )
    if not all(_no_worse(a, b) for a, b in zip(initial.turns, refined.turns, strict=True)):
        return "initial", f"output-error estimate rejected: {SANITY_FAILURE}; {keep}"
    if centripetal_is_a_ships(initial.params) and not centripetal_is_a_ships(refined.params):
        x_vr = refined.params.as_dict()["X_vr"]
        return "initial", (
            f"output-error estimate rejected: its centripetal surge term X_vr = {x_vr:.3g} is "
            f"not positive, as a ship's is; {keep}"
        )
    if initial.zigzags_complete and not refined.zigzags_complete:
        return "initial", (
            "output-error estimate rejected: a virtual 20/20 zig-zag diverges or does not "
            f"reach its second overshoot; {keep}"
        )
    if not refined.cost < initial.cost:
        return "initial", f"output error did not lower the cost; {keep}"
    asymmetry, start_asymmetry = side_asymmetry(refined.turns), side_asymmetry(initial.turns)
    if not both_sides_logged and asymmetry > max(MAX_SIDE_ASYMMETRY, start_asymmetry):
        return "initial", (
            f"output-error estimate rejected: its virtual 35 deg turns differ by "
            f"{asymmetry:.0%} between the sides (the {label} estimate's by "
            f"{start_asymmetry:.0%}), beyond the {MAX_SIDE_ASYMMETRY:.0%} a single-screw "
            f"ship shows, and no turning log verifies both sides; {keep}"
        )
    if turn_check and not spread <= tolerance:
        return "initial", (
            f"{_spread_text(initial, refined, spread)}, more than the turn check allows "
            f"({tolerance:.0%}: output error is not trusted on turns without a turning log); "
            f"{keep}"
        )
    return "refined", "output-error estimate accepted"


def centripetal_is_a_ships(params: ModelParameters) -> bool:
    """Whether the estimate's surge v·r term has a ship's sign (or the family has none).

    In the prime families u̇ holds X_vr·v·r, the centripetal term of the surge equation,
    (m + m_y + X′_vr)/(m + m_x) for a ship: positive, about 1–2 (1.85 for the KVLCC2 MMG
    model, 0.95 for the Mariner's Abkowitz model). Zig-zags at one rpm leave the surge
    terms of a turn nearly collinear, and a fit can end with X_vr ≤ 0, whose speed in a
    hard turn is then no ship's.
    """
    x_vr = params.as_dict().get("X_vr")
    return x_vr is None or x_vr > 0.0


def kept_phrase(label: str) -> str:
    """Return how :func:`decide`'s reason ends when it keeps the ``label`` start."""
    return f"kept the {label} estimate"


def _no_worse(start: VirtualTurn, refined: VirtualTurn) -> bool:
    """Whether a refined virtual turn passes the sanity guard against the start's.

    Sane (bounded and through 360°), or, when the start's turn is not sane either, at
    least as far through the turn: the guard rejects what the refinement breaks, not
    what it inherits (the measured HSVA runs: every estimate from 10° zig-zags of a
    model-scale hull loses its speed in a 35° turn, benchmarks/hsva.md).
    """
    if refined.sane:
        return True
    return not start.sane and refined.heading_change_rad >= start.heading_change_rad


def _spread_text(initial: FitSummary, refined: FitSummary, spread: float) -> str:
    def td(turn: VirtualTurn) -> str:
        d = turn.tactical_diameter_m
        return "none" if d is None else f"{d:.0f} m"

    sides = ", ".join(
        f"{side} {td(a)} -> {td(b)}"
        for side, a, b in zip(("stbd", "port"), initial.turns, refined.turns, strict=True)
    )
    amount = "beyond 180 deg" if math.isinf(spread) else f"by {spread:.1%}"
    return f"output error moves the virtual 35 deg tactical diameter {amount} ({sides})"
