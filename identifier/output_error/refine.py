"""Output-error refinement: fit the coefficients to whole simulated manoeuvres.

The EKF (``identifier.ekf``) fits the coefficients one sample ahead. Output error asks
more of them: replayed open loop with the logged rudder and propeller speed from each
log's execute point on, the model must reproduce the whole track. This module composes
the steps, each of which has its own module in ``identifier.output_error``:

1. the start: the preferred candidate (``RefineSettings.preferred_start``, the
   equation-error estimate) unless its replay of the training logs diverges, else the
   candidate that replays them best (smallest J(θ₀)); when every candidate's replay
   diverges, the preferred one grown over a horizon: refined first on each log as far
   as it replays it, then on more (:func:`grown_start`);
2. each log's execute sample and the start model's state there, fitted to the
   approach and then held (``initial_state``);
3. the objective J(θ) with a Tikhonov prior at the start, minimised by
   ``scipy.optimize.least_squares`` in whitened coordinates (``objective``), on the
   samples decimated to about L/U/40 as the equation error's (a 10 Hz log replays as
   fast as a 1 Hz one);
4. the covariance of the optimum, the Newey–West sandwich (``covariance``);
5. virtual hard-over turns and the rules that keep the refined estimate or the
   start (``guards``); when the estimate kept fails the sanity guard and the other
   candidate start sails the virtual turns and zig-zags, the refinement runs again from
   that one;
6. the result record (``records``), its summary in ``params.identification``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from fmu_model.replay import INPUT_MODES
from identifier.equation_error import decimation_step
from identifier.output_error.covariance import newey_west_covariance
from identifier.output_error.guards import (
    POOR_REPLAY_L,
    Approach,
    candidate_disagreement,
    covers_both_sides,
    covers_turn,
    decide,
    kept_phrase,
    method_label,
    training_approach,
    turn_spread,
)
from identifier.output_error.initial_state import execute_state
from identifier.output_error.objective import Objective, prepare_log, whitening
from identifier.output_error.prediction import predict_log
from identifier.output_error.records import (
    SANITY_FAILURE,
    FitSummary,
    RefinementResult,
    RefineSettings,
    VirtualTurn,
)
from identifier.smoothing import SmoothedTrack, smooth_log
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, log_piece

HEAD_FRACTION = 0.75
"""A start whose replay of a log diverges is refined first on the log's head: this share
of the samples from execute over which its replay stays finite (:func:`grown_start`)."""
MIN_HEAD_TIME_UNITS = 3.0
"""The least head worth refining on: this many L/U₀ after execute [-] (120 s for KVLCC2)."""
MAX_GROWTH_STEPS = 4
"""Refinements on heads before a start that still diverges is given up."""


def refine_output_error(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    *,
    tracks: Sequence[SmoothedTrack] | None = None,
    settings: RefineSettings | None = None,
    method: str = "ekf",
    alternatives: Mapping[str, ModelParameters] | None = None,
    **overrides: Any,
) -> RefinementResult:
    """Refine identified coefficients by output error on whole manoeuvres.

    With ``alternatives`` (e.g. the equation-error estimate beside the EKF's), the
    start is ``settings.preferred_start`` (the equation-error estimate) unless its
    open-loop replay of the training logs diverges; else, or with no preferred start,
    the candidate whose replay fits best (smallest J at its own estimate, the prior term
    then being zero). The paper's one-step-ahead EKF fit is not always the estimate that
    simulates or predicts whole manoeuvres best.
    When the estimate kept (refined or start) fails the sanity guard (a virtual hard-over
    turn diverges, turns back, loses its headway or does not pass 360°) and another
    candidate sails the virtual turns and zig-zags, the refinement runs again from that
    candidate, and the result says why.

    Every log is replayed from its execute sample on, from the state there that the
    start model gives when fitted to the approach (:func:`execute_state`). That state is
    held: fitted to the whole log, it would absorb model error. The coefficients are
    fitted to the logs from execute to the end.

    Parameters
    ----------
    params : ModelParameters
        The estimate of ``method``: start point, and with its covariance the prior.
    logs : sequence of ManeuverLog
        The training logs.
    tracks : sequence of SmoothedTrack, optional
        Their smoothed tracks (initial states, noise levels); smoothed here if omitted.
    settings : RefineSettings, optional
        Tuning; the defaults when omitted.
    method : str
        How ``params`` was estimated (named in the result and its messages).
    alternatives : mapping of str to ModelParameters, optional
        Other candidate starts by method name, with their covariances (the prior).
    **overrides
        Fields of :class:`RefineSettings` to override, e.g. ``prior_weight=0.1``.

    Returns
    -------
    RefinementResult
        Both fits, the estimate kept and why.

    Raises
    ------
    IdentificationError
        No logs, or logs and tracks that do not match.

    """
    settings = replace(settings or RefineSettings(), **overrides)
    if settings.inputs not in INPUT_MODES:
        raise ValueError(f"inputs must be one of {INPUT_MODES}, got {settings.inputs!r}")
    if not logs:
        raise IdentificationError("no logs to refine on")
    tracks = tuple(tracks) if tracks is not None else tuple(smooth_log(log) for log in logs)
    if len(tracks) != len(logs):
        raise IdentificationError(f"{len(logs)} logs but {len(tracks)} smoothed tracks")
    candidates = {method: params, **(alternatives or {})}
    approach = training_approach(params, logs, tracks, rudder_rate_radps=settings.rudder_rate_radps)
    settings = settings.with_step(params.length_m, approach.speed_mps)
    objectives = {
        name: _coefficient_objective(candidate, logs, tracks, settings)
        for name, candidate in candidates.items()
    }
    start_costs = {name: o.cost(np.zeros(o.size)) for name, o in objectives.items()}
    method = _start(start_costs, settings.preferred_start)
    grown_note: str | None = None
    if not math.isfinite(start_costs[method]):  # every candidate diverges: grow one
        origin = settings.preferred_start if settings.preferred_start in candidates else method
        time_unit_s = params.length_m / approach.speed_mps
        grown = grown_start(candidates[origin], logs, tracks, settings, origin, time_unit_s)
        if grown is not None:
            candidates[origin], grown_note = grown
            objectives[origin] = _coefficient_objective(candidates[origin], logs, tracks, settings)
            start_costs[origin] = objectives[origin].cost(np.zeros(objectives[origin].size))
            method = _start(start_costs, origin)
    params, objective = candidates[method], objectives[method]
    label = method_label(method)
    initial = _summarise(objective, np.zeros(objective.size), params, approach)
    if not math.isfinite(start_costs[method]):
        reason = (
            f"the {label} estimate diverges replaying "
            + ", ".join(initial.diverged)
            + "; output-error refinement skipped"
        )
        return RefinementResult(
            params=params,
            initial_method=method,
            kept="initial",
            reason=reason,
            initial=initial,
            refined=initial,
            turn_check=False,
            turn_spread=math.nan,
            nfev=0,
            status="not run",
            warnings=(reason,),
            settings=settings,
        ).recorded()
    others = {name: p for name, p in candidates.items() if name != method}
    other_turns = {name: approach.turns(p, settings) for name, p in others.items()}
    warnings = candidate_disagreement(
        method, initial.turns, other_turns, settings.disagreement_tolerance
    )
    if grown_note is not None:
        warnings.insert(0, grown_note)
    insane_start = f"the {label} estimate fails the sanity guard: {SANITY_FAILURE}"
    if not all(t.sane for t in initial.turns):
        warnings.append(insane_start)
    opt = objective.solve(np.zeros(objective.size), settings.max_nfev)
    refined_params = params.with_vector(objective.theta(opt.x), _covariance(objective, opt))
    refined = _summarise(objective, opt.x, refined_params, approach)
    turn_check = not covers_turn(tracks) if settings.check_turns is None else settings.check_turns
    spread = turn_spread(initial.turns, refined.turns)
    kept, reason = decide(
        initial,
        refined,
        turn_check=turn_check,
        spread=spread,
        tolerance=settings.turn_tolerance,
        label=label,
        both_sides_logged=covers_both_sides([t.heading_rad for t in tracks]),
    )
    decided = reason
    if grown_note is not None:
        reason = f"{grown_note}; {reason}"
    kept_fit = refined if kept == "refined" else initial
    if not all(t.sane for t in kept_fit.turns):
        sane = _sane_candidate(others, other_turns, approach, settings)
        if sane is not None:  # start again from the one that sails the virtual manoeuvres
            again = refine_output_error(
                others[sane], logs, tracks=tracks, settings=settings, method=sane
            )
            # What the first decision kept is superseded, and `failing` says the start fails.
            failing = (
                f"the output-error estimate from the {label} start fails the sanity guard "
                f"({SANITY_FAILURE})"
                if kept == "refined"
                else f"the {label} start fails the sanity guard ({SANITY_FAILURE}) and its "
                f"refinement was not kept ({decided.removesuffix(f'; {kept_phrase(label)}')})"
            )
            why = (
                f"{failing}; refined again from the {method_label(sane)} estimate, which "
                "sails the virtual turns and zig-zags"
            )
            return replace(
                again,
                reason=f"{again.reason}; {why}",
                warnings=(
                    *(w for w in warnings if kept == "refined" or w != insane_start),
                    why,
                    *again.warnings,
                ),
            ).recorded()
    if kept == "initial":
        warnings.append(decided)
    if kept_fit.position_rms_L > POOR_REPLAY_L:  # of the estimate kept, not a rescued one
        warnings.append(_poor_replay_warning(kept_fit, refined, label))
    if not kept_fit.zigzags_complete:
        warnings.append(
            "the kept estimate's virtual 20/20 zig-zag diverges or does not reach its second "
            "overshoot: it is no model of that manoeuvre; add logs of larger rudder angles"
        )
    return RefinementResult(
        params=refined_params if kept == "refined" else params,
        initial_method=method,
        kept=kept,
        reason=reason,
        initial=initial,
        refined=refined,
        turn_check=turn_check,
        turn_spread=spread,
        nfev=int(opt.nfev),
        status=str(opt.message),
        warnings=tuple(warnings),
        settings=settings,
    ).recorded()


def grown_start(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    settings: RefineSettings,
    method: str,
    time_unit_s: float,
) -> tuple[ModelParameters, str] | None:
    """Grow a start whose replay diverges into one that replays every log; and a note.

    A growing horizon: output error on each log's head, :data:`HEAD_FRACTION` of the
    samples from execute over which the replay of ``params`` stays finite (a log it
    replays whole is taken whole), then the same from that refined estimate, until one
    replays the whole logs (at most :data:`MAX_GROWTH_STEPS` refinements). What a start
    from a single turning circle needs, whose turn loses its headway late in the log (on
    a KVLCC2 35° turn of 1,100 s both estimates did after 840 s; grown in one step, the
    start replays it to 0.12 L and its refinement to 0.021 L). None when a head would be
    shorter than
    :data:`MIN_HEAD_TIME_UNITS` L/U₀ (``time_unit_s`` [s]) or the steps run out.
    """
    current = params
    for step in range(MAX_GROWTH_STEPS + 1):
        heads: list[tuple[ManeuverLog, SmoothedTrack]] = []
        for log, track in zip(logs, tracks, strict=True):
            k, states = predict_log(current, log, track)
            finite = np.all(np.isfinite(states), axis=1)
            if finite.all():
                heads.append((log, track))
                continue
            end = k + int(HEAD_FRACTION * int(np.argmin(finite)))
            if end <= k or log.time_s[end - 1] - log.time_s[k] < MIN_HEAD_TIME_UNITS * time_unit_s:
                return None
            head = log_piece(log, 0, end)
            heads.append((head, smooth_log(head)))
        if all(head is log for (head, _), log in zip(heads, logs, strict=True)):
            if step == 0:
                return None  # it replays them: nothing to grow
            return current, (
                f"the {method_label(method)} estimate diverges replaying the training logs: "
                f"refined first on each log as far as it replays it, in {step} "
                f"step{'s' if step > 1 else ''} (growing horizon), and started from there"
            )
        if step == MAX_GROWTH_STEPS:
            return None
        head_logs, head_tracks = zip(*heads, strict=True)
        grown = refine_output_error(current, head_logs, tracks=head_tracks, settings=settings,
                                    method=method)  # fmt: skip
        current = grown.refined.params
    return None


def _poor_replay_warning(kept: FitSummary, refined: FitSummary, label: str) -> str:
    """Return the warning of an estimate kept that replays its logs :data:`POOR_REPLAY_L` off.

    ``kept`` is the fit kept (the ``label`` start or ``refined``), ``refined`` the
    output-error optimum, the best replay the structure gave.
    """
    kept_label = "output-error" if kept is refined else label
    return (
        f"the {kept_label} estimate kept replays its training logs {kept.position_rms_L:.2f} L "
        f"from their tracks (RMS, open loop from execute; the output-error optimum "
        f"{refined.position_rms_L:.3f} L): it is no sound model of these logs; check their "
        "noise and conventions, or add logs"
    )


def _start(start_costs: Mapping[str, float], preferred: str | None) -> str:
    """Return the candidate to start from (``RefineSettings.preferred_start``).

    ``preferred`` if its replay of the training logs is finite, else the candidate with
    the smallest J(θ₀) (a diverging replay costs inf).
    """
    if preferred is not None and math.isfinite(start_costs.get(preferred, math.inf)):
        return preferred
    return min(start_costs, key=start_costs.__getitem__)


def _sane_candidate(
    candidates: Mapping[str, ModelParameters],
    turns: Mapping[str, Sequence[VirtualTurn]],
    approach: Approach,
    settings: RefineSettings,
) -> str | None:
    """Return the first candidate whose virtual turns are sane and zig-zags complete.

    ``turns``: each candidate's virtual turns by name, sailed already. None when no
    candidate does.
    """
    for name, estimate in candidates.items():
        if all(t.sane for t in turns[name]) and approach.zigzags_complete(estimate, settings):
            return name
    return None


def _coefficient_objective(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    settings: RefineSettings,
) -> Objective:
    """Build the output-error objective around ``params`` (its execute states, prior)."""
    data = []
    for i, (log, track) in enumerate(zip(logs, tracks, strict=True)):
        k, state = execute_state(params, log, track, settings=settings)
        name = log.path or f"log {i + 1}"
        step = decimation_step(log.time_s, track.speed_mps, params.length_m)
        prepared = prepare_log(
            log, track, name, settings, start=k, windage=params.windage, step=step
        )
        data.append(replace(prepared, x0=state))
    return Objective(
        structure=params.structure,
        length_m=params.length_m,
        data=tuple(data),
        settings=settings,
        theta0=params.to_vector().copy(),
        whiten=whitening(params),
    )


def _covariance(objective: Objective, opt: Any) -> np.ndarray:
    """Covariance of the coefficients at the optimum ``opt`` of ``least_squares``.

    The Newey–West sandwich in z, cov_z, mapped back: Σ_θ = C cov_z Cᵀ (θ = θ₀ + C z),
    symmetrised.
    """
    blocks, prior_rows = objective.row_blocks(opt.jac, objective.replays(opt.x)[0])
    cov_z = newey_west_covariance(blocks, prior_rows)
    p, C = objective.p, objective.whiten
    cov = C @ cov_z[:p, :p] @ C.T
    return 0.5 * (cov + cov.T)


def _summarise(
    objective: Objective,
    z: np.ndarray,
    params: ModelParameters,
    approach: Approach,
) -> FitSummary:
    """How well ``params`` (z in ``objective``) replays the logs; its virtual manoeuvres."""
    res, states = objective.replays(z)
    cost = objective.cost(z)
    diverged = tuple(
        d.name for d, s in zip(objective.data, states, strict=True) if np.isnan(s).any()
    )
    pos_sq, head_sq, counts, per_log = 0.0, 0.0, 0, []
    for d, s in zip(objective.data, states, strict=True):
        e = s[1:, 3:6] - d.target[:, :3]
        p2 = np.square(e[:, 0]) + np.square(e[:, 1])
        pos_sq += float(np.sum(p2))
        head_sq += float(np.sum(np.square(e[:, 2])))
        counts += e.shape[0]
        per_log.append(math.sqrt(float(np.mean(p2))) / params.length_m)
    return FitSummary(
        params=params,
        cost=cost,
        residual_rms=math.sqrt(float(np.mean(np.square(res)))),
        position_rms_L=math.sqrt(pos_sq / counts) / params.length_m,
        heading_rms_deg=math.degrees(math.sqrt(head_sq / counts)),
        log_position_rms_L=tuple(per_log),
        initial_states=tuple(objective.initial_states(z)),
        diverged=diverged,
        turns=approach.turns(params, objective.settings),
        zigzags_complete=approach.zigzags_complete(params, objective.settings),
    )
