"""Cross-validation: identify on some manoeuvres, predict the ones held out.

Zig-zag overshoots do not tell a model that extrapolates well from one that does not
(reference/model_structures.md, §8); only held-out manoeuvres do. For each held-out
log the identified model is replayed with the log's own rudder and propeller speed
(``fmu_model.replay.replay``, RK4, inputs interpolated between samples) from the
execute point on, from the state the model itself gives there when fitted to the
approach (``identifier.output_error.execute_state``; nothing after execute is used). Then

* the RMS position error from execute to the end of the log, in ship lengths, and
* the manoeuvre's own indices computed the same way on both the logged (smoothed)
  track and the prediction (``trials.conditions.maneuver_indices``): advance, transfer,
  tactical and steady diameter of a turning circle, from the replay (its rudder is held);
  first and second overshoot, initial turning time, time to check yaw and period of a
  zig-zag, whose rudder follows its heading, from the model sailing the log's condition
  closed loop (``trials.conditions.sail_again``: approach speed, rpm, rudder amplitude
  and rate, reversing at the logged switch headings, as the scenarios' ``--like``; in
  a current, the log's condition through the water; where the log carries a measured
  wind and the model a windage, in the log's mean true wind). A replay reverses the rudder when
  the log did, whatever the model's heading: trained on three of HSVA's four runs it put
  the held-out 10/10 starboard-first second overshoot at 7.2° (closed loop 15.7°,
  measured 20.5°).

Where the training fit estimated a uniform current, the held-out logs are taken as sailed
in the same one: the model sails through the water, and the current's drift is added to
its predicted track before it is compared with the logged one over the ground. With a
current per training log (``--current per-log``), a held-out log is taken in its own, as
its speed log shows it, or without one in the training logs' mean with the component
across its approach as the approach shows it.

The metric definitions (pure functions of a trajectory) exist once, in
``trials.metrics``. Nothing here knows about FMI, and nothing here prints: the
command line is ``python -m identifier crossval`` (:mod:`identifier.cli.crossval`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from identifier.current import (
    CurrentEstimate,
    speed_log_current,
    water_frame,
    with_approach_cross,
)
from identifier.identify import FitSettings, identify
from identifier.output_error import predict_log
from identifier.smoothing import (
    SmoothedTrack,
    deglitched_log,
    smooth_log,
    smoothed_trajectory,
)
from identifier.split import several_manoeuvres
from identifier.wind import mean_true_wind_ne, speed_and_source
from trials.conditions import (
    BEYOND_STANDARD_INDICES,
    KINDS,
    maneuver_indices,
    maneuver_kind,
    sail_again,
)
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, at_midship
from trials.run import ModelPlant
from trials.spikes import despiked_inputs
from trials.trajectory import trajectory_of

# --------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class MetricError:
    """One manoeuvre index, logged vs predicted.

    Attributes
    ----------
    name : str
        One of ``trials.conditions.TURNING_INDICES`` or ``ZIGZAG_INDICES``, such as
        ``tactical_diameter_m`` or ``time_to_check_yaw_s`` (the unit is in the name).
    logged, predicted : float or None
        From the logged (smoothed) track and from the prediction; None when the
        track does not cover the index (e.g. a turn that never reaches 180°).
    error : float or None
        predicted − logged, in the unit of the name.
    relative_error : float or None
        predicted / logged − 1.

    """

    name: str
    logged: float | None
    predicted: float | None

    @property
    def error(self) -> float | None:
        """Return predicted − logged (None when one is missing)."""
        if self.logged is None or self.predicted is None:
            return None
        return self.predicted - self.logged

    @property
    def relative_error(self) -> float | None:
        """Return predicted / logged − 1 (None when missing or logged is 0)."""
        if self.logged is None or self.predicted is None or self.logged == 0.0:
            return None
        return self.predicted / self.logged - 1.0


@dataclass(frozen=True)
class HeldOut:
    """Prediction of one held-out log.

    Attributes
    ----------
    name : str
        The log's path (or "log N").
    kind : str or None
        ``turning``, ``zigzag`` or None (unknown: no indices).
    position_rms_m : float
        RMS distance between predicted and logged positions from execute to the end
        of the log [m]; inf when the prediction diverged.
    position_rms_L : float
        The same in ship lengths.
    metrics : tuple of MetricError
        The manoeuvre's indices.
    notes : tuple of str
        Why an index is missing.
    logged, predicted : numpy.ndarray or None
        The trajectories the indices were read off (``TRAJECTORY_DTYPE``, time from the
        execute point; not in the JSON): the log's smoothed track, and the replay (a
        turn: from execute, where it stays finite, in the log's frame) or the closed-loop
        run (a zig-zag: from the origin); None for a log of unknown kind.

    """

    name: str
    kind: str | None
    position_rms_m: float
    position_rms_L: float
    metrics: tuple[MetricError, ...]
    notes: tuple[str, ...] = ()
    logged: np.ndarray | None = field(default=None, repr=False, compare=False)
    predicted: np.ndarray | None = field(default=None, repr=False, compare=False)

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-ready dict (non-finite numbers as null)."""
        return {
            "log": self.name,
            "kind": self.kind,
            "position_rms_m": _json_number(self.position_rms_m),
            "position_rms_L": _json_number(self.position_rms_L),
            "metrics": {
                m.name: {
                    "logged": _json_number(m.logged),
                    "predicted": _json_number(m.predicted),
                    "error": _json_number(m.error),
                    "relative_error": _json_number(m.relative_error),
                }
                for m in self.metrics
            },
            "notes": list(self.notes),
        }


@dataclass(frozen=True)
class Fold:
    """One identification and the logs it predicts.

    Attributes
    ----------
    train : tuple of str
        Names of the training logs.
    params : ModelParameters
        The identified model (refined when refinement ran and was kept).
    held_out : tuple of HeldOut
        The predictions.
    warnings : tuple of str
        The identification's warnings.

    """

    train: tuple[str, ...]
    params: ModelParameters
    held_out: tuple[HeldOut, ...]
    warnings: tuple[str, ...]

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-ready dict."""
        refinement = self.params.identification.get("refinement")
        return {
            "train": list(self.train),
            "coefficients": self.params.as_dict(),
            "refinement": None
            if refinement is None
            else {k: refinement[k] for k in ("kept", "reason", "cost_before", "cost_after")},
            "test": [h.to_json_dict() for h in self.held_out],
            "warnings": list(self.warnings),
        }


@dataclass(frozen=True)
class CrossValidation:
    """All folds of a cross-validation."""

    model: str
    method: str
    folds: tuple[Fold, ...]

    def to_json_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``{"model", "method", "folds": [...]}``."""
        return {
            "model": self.model,
            "method": self.method,
            "folds": [f.to_json_dict() for f in self.folds],
        }


def _json_number(value: float | None) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


SAIL_STEP_L = 0.0025
"""Step of a held-out zig-zag sailed again, in L/U (0.1 s for KVLCC2 at full scale, 0.015 s
for its 7 m model): the runner reverses the rudder at the first step past a switch
heading, so a step of the log's own interval (1 s) would put an overshoot a step's yaw
too far."""


# --------------------------------------------------------------------------------------
# Classifying logs
# --------------------------------------------------------------------------------------


def _name(log: ManeuverLog, index: int) -> str:
    return log.path or f"log {index + 1}"


# --------------------------------------------------------------------------------------
# Prediction of one log
# --------------------------------------------------------------------------------------


def _held_out_current(
    current: CurrentEstimate, log: ManeuverLog, track: SmoothedTrack, name: str
) -> tuple[CurrentEstimate, str]:
    """Return the current a held-out log is predicted in, and whose it is (for its note).

    The training fit's; with a current per training log, the log's own as its speed log
    shows it, or their mean with the component across its approach as that shows it.
    """
    if not current.logs:
        return current, "the training fit's current"
    own = speed_log_current([log], [track])
    if own is not None and own.implausible() is None:
        mine = CurrentEstimate.of(
            own.current_ne, own.covariance, current.mode, speed_log=own, log=name
        )
        return mine, "its own current, as its speed log shows it"
    north, east = with_approach_cross(current.vector, log, track)
    return (
        replace(current, north_mps=float(north), east_mps=float(east), log=name, logs=()),
        "the training logs' mean current, its component across the approach as the "
        "approach shows it (no speed log shows its own)",
    )


def held_out_errors(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack | None = None,
    *,
    name: str | None = None,
    current: CurrentEstimate | None = None,
) -> HeldOut:
    """Predict a log and compare: position RMS and the manoeuvre's indices.

    Parameters
    ----------
    params : ModelParameters
        The identified model.
    log : ManeuverLog
        The held-out log; its fixes and headings the track's gate rejected, and the
        spikes of its rudder and propeller speed, are mended as the fit's are
        (``identifier.preparation``).
    track : SmoothedTrack, optional
        Its smoothed track; smoothed here when omitted.
    name : str, optional
        Name in the result; the log's path by default.
    current : CurrentEstimate, optional
        A uniform current the log was sailed in (the training fit's,
        :func:`cross_validate`): the model sails through the water from the state fitted
        to the approach in the water frame (``identifier.current.water_frame``), and the
        current's drift is added to its track, which is then compared with the logged
        one over the ground. A current per training log (``current.logs``): the log's
        own as its speed log shows it (``identifier.current.speed_log_current``), else
        their mean with its component across the log's approach as the approach shows it
        (``identifier.current.with_approach_cross``). None: still water.

    Returns
    -------
    HeldOut
        Errors of the prediction.

    """
    log = at_midship(log)
    track = track or smooth_log(log)
    # As the fit's logs (identifier.preparation): a glitch or spike is no part of the run.
    log = despiked_inputs(deglitched_log(log, track), params.length_m)[0]
    name = name or log.path or "log"
    notes: list[str] = []
    if (several := several_manoeuvres(log, params.length_m, track)) is not None:
        notes.append(several)
    if current is None:
        k, states = predict_log(params, log, track)
    else:
        current, whose = _held_out_current(current, log, track, name)
        k, states = predict_log(params, *water_frame(log, track, current.vector))
        elapsed = log.time_s[k:] - log.time_s[0]
        states[:, 3] += current.north_mps * elapsed
        states[:, 4] += current.east_mps * elapsed
        notes.append(
            f"predicted in {whose}, {current.speed_mps:.3f} m/s towards "
            f"{math.degrees(current.to_rad):.0f} deg"
        )
    finite = np.all(np.isfinite(states), axis=1)
    if finite.all():
        sq = np.square(states[:, 3] - log.x_m[k:]) + np.square(states[:, 4] - log.y_m[k:])
        rms = math.sqrt(float(np.mean(sq)))
    else:
        rms = math.inf
        notes.append(f"the prediction diverges at t = {log.time_s[k + int(np.argmin(finite))]:g} s")
    kind = maneuver_kind(log)
    metrics: list[MetricError] = []
    smoothed = smoothed_trajectory(log, track)
    run: np.ndarray | None = None
    execute_s = float(log.time_s[k])
    if kind == "zigzag":  # its rudder follows its heading: sailed again, closed loop
        sailed = log if current is None else water_frame(log, track, current.vector)[0]
        wind = _sailing_wind(params, log, track, current)
        if wind is not None:
            notes.append(
                f"sailed again in the log's mean true wind, {wind[2]:.1f} m/s from "
                f"{round(math.degrees(wind[3])) % 360} deg"
                + ("" if current is None else " (in the water)")
            )
        step_s = SAIL_STEP_L * params.length_m / float(np.median(track.speed_mps))
        again = sail_again(ModelPlant(params, environment=wind), sailed, dt_s=step_s)
        program = again.condition.program
        execute_s = again.condition.execute_time_s
        angles = (program.rudder_rad, program.heading_rad)
        logged = maneuver_indices(kind, smoothed, execute_s, angles)
        predicted, run = again.predicted, again.trajectory
    elif kind == "turning":  # its rudder is held: the replay is the manoeuvre
        logged = maneuver_indices(kind, smoothed, execute_s)
        good = int(np.argmin(finite)) if not finite.all() else states.shape[0]
        end = k + good
        run = trajectory_of(
            log.time_s[k:end], states[:good], log.rudder_rad[k:end], log.n_rps[k:end]
        )
        predicted = maneuver_indices(kind, run, execute_s) if good > 2 else {}
        run["time_s"] -= execute_s
    else:
        logged = predicted = {}
        notes.append("manoeuvre kind unknown (the rudder never leaves midship)")
    for key, value in logged.items():
        if value is None and key in BEYOND_STANDARD_INDICES:
            continue
        metrics.append(MetricError(key, value, predicted.get(key)))
        if value is None:
            notes.append(f"{key}: not covered by the logged track")
        elif predicted.get(key) is None:
            notes.append(f"{key}: not reached by the prediction")
    return HeldOut(
        name=name,
        kind=kind,
        position_rms_m=rms,
        position_rms_L=rms / params.length_m,
        metrics=tuple(metrics),
        notes=tuple(notes),
        logged=None if kind is None else _from_execute(smoothed, execute_s),
        predicted=run,
    )


def _sailing_wind(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack,
    current: CurrentEstimate | None,
) -> tuple[float, float, float, float] | None:
    """Return the environment a held-out zig-zag is sailed again in, or None (still air).

    The log's mean true wind (``identifier.wind.mean_true_wind_ne``) when it carries one
    and the model its load (a windage); sailed through the water in a ``current``, the
    wind as seen from the water, the wind's velocity less the current's.
    """
    wind = None if params.windage is None else mean_true_wind_ne(log, track)
    if wind is None:
        return None
    if current is not None:
        wind = wind - current.vector
    return 0.0, 0.0, *speed_and_source(wind)


def _from_execute(traj: np.ndarray, execute_s: float) -> np.ndarray:
    """Return ``traj`` with its time counted from the execute point at ``execute_s`` [s]."""
    moved = traj.copy()
    moved["time_s"] -= execute_s
    return moved


# --------------------------------------------------------------------------------------
# Folds
# --------------------------------------------------------------------------------------


def select_logs(logs: Sequence[ManeuverLog], spec: Sequence[str]) -> list[int]:
    """Return the indices of the logs a ``--train``/``--test`` spec names.

    Each item is a kind (``turning``, ``zigzag``) or a log path; a path matches a log
    whose path is the same file.

    Raises
    ------
    IdentificationError
        An item that is neither a kind nor one of the logs.

    """
    chosen: list[int] = []
    for item in spec:
        if item in KINDS:
            hits = [i for i, log in enumerate(logs) if maneuver_kind(log) == item]
        else:
            target = Path(item).resolve()
            hits = [
                i for i, log in enumerate(logs) if log.path and Path(log.path).resolve() == target
            ]
            if not hits:
                raise IdentificationError(
                    f"{item!r} is neither a manoeuvre kind ({', '.join(KINDS)}) nor one of the logs"
                )
        chosen.extend(i for i in hits if i not in chosen)
    return chosen


def cross_validate(
    train: Sequence[ManeuverLog],
    test: Sequence[ManeuverLog],
    settings: FitSettings | None = None,
    *,
    length_m: float | None = None,
) -> Fold:
    """Identify on ``train`` and predict every log of ``test``.

    The held-out logs are predicted in the current the training fit found, if any
    (:func:`held_out_errors`).

    Parameters
    ----------
    train, test : sequence of ManeuverLog
        Training and held-out logs.
    settings : FitSettings, optional
        Identification settings.
    length_m : float, optional
        Ship length [m]; from the logs when omitted.

    Raises
    ------
    IdentificationError
        No training or no test log, or a failed identification.

    """
    if not train:
        raise IdentificationError("no training logs")
    if not test:
        raise IdentificationError("no held-out logs to predict")
    result = identify(list(train), settings or FitSettings(), length_m=length_m)
    held = tuple(
        held_out_errors(result.params, log, name=_name(log, i), current=result.current)
        for i, log in enumerate(test)
    )
    return Fold(
        train=tuple(_name(log, i) for i, log in enumerate(train)),
        params=result.params,
        held_out=held,
        warnings=result.warnings,
    )


def leave_one_out(
    logs: Sequence[ManeuverLog],
    settings: FitSettings | None = None,
    *,
    length_m: float | None = None,
) -> tuple[Fold, ...]:
    """One fold per log: identify on all the others, predict it.

    Raises
    ------
    IdentificationError
        Fewer than two logs, or a failed identification.

    """
    if len(logs) < 2:
        raise IdentificationError("leave-one-out needs at least two logs")
    return tuple(
        cross_validate(
            [log for j, log in enumerate(logs) if j != i], [logs[i]], settings, length_m=length_m
        )
        for i in range(len(logs))
    )


def format_table(cv: CrossValidation) -> str:
    """Markdown table of all held-out predictions, one row per index; then their notes.

    A note says what a held-out log was predicted in (current, wind) or why an index is
    missing, one line each: ``note: <log> (trained on <logs>): <note>``.
    """
    lines = [
        f"model {cv.model}, method {cv.method}",
        "",
        "| trained on | held out | pos. RMS [L] | index | logged | predicted | error |",
        "|---|---|---|---|---|---|---|",
    ]

    def fmt(value: float | None, digits: str = ".4g") -> str:
        return "—" if value is None or not math.isfinite(value) else format(value, digits)

    for fold in cv.folds:
        train = ", ".join(Path(t).name for t in fold.train)
        for h in fold.held_out:
            rows = h.metrics or (MetricError("—", None, None),)
            for m in rows:
                rel = m.relative_error
                error = "—" if rel is None else f"{rel:+.1%}"
                unit = m.name.rsplit("_", 1)[-1]
                if unit in ("deg", "s") and m.error is not None:  # angles and times: absolute
                    error = f"{m.error:+.2f} {unit} ({error})"
                lines.append(
                    f"| {train} | {Path(h.name).name} | {fmt(h.position_rms_L, '.3f')} | "
                    f"{m.name} | {fmt(m.logged)} | {fmt(m.predicted)} | {error} |"
                )
    notes = [
        f"note: {Path(h.name).name} (trained on {', '.join(Path(t).name for t in fold.train)}): "
        f"{note}"
        for fold in cv.folds
        for h in fold.held_out
        for note in h.notes
    ]
    return "\n".join(lines + (["", *notes] if notes else []))


def run_cross_validation(
    logs: Sequence[ManeuverLog],
    settings: FitSettings,
    *,
    train: Sequence[str] = (),
    test: Sequence[str] = (),
    leave_one_out_: bool = False,
    length_m: float | None = None,
) -> CrossValidation:
    """Select the folds from specs (kinds or paths) and run them.

    Without ``test`` every log not in training is held out.
    """
    if leave_one_out_:
        folds = leave_one_out(logs, settings, length_m=length_m)
    else:
        if not train:
            raise IdentificationError("name the training logs (--train) or use --leave-one-out")
        train_idx = select_logs(logs, train)
        test_idx = (
            select_logs(logs, test) if test else [i for i in range(len(logs)) if i not in train_idx]
        )
        overlap = sorted(set(train_idx) & set(test_idx))
        if overlap:
            names = ", ".join(_name(logs[i], i) for i in overlap)
            raise IdentificationError(f"logs both trained on and held out: {names}")
        folds = (
            cross_validate(
                [logs[i] for i in train_idx],
                [logs[i] for i in test_idx],
                settings,
                length_m=length_m,
            ),
        )
    return CrossValidation(model=settings.model, method=settings.method, folds=folds)
