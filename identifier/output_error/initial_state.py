"""Where a replay starts: a log's execute sample and the model's state there.

The first smoothed state of a log is poor (the smoother sees one side only: 0.1–0.2 m/s
on u and v at 1 Hz, 1 m noise), and a replay from it drifts by several metres where the
true model, from the true state, stays within the noise. So each log's state at execute
is the start model's, fitted to the approach alone (:func:`fit_initial_state`) and
replayed to execute (:func:`execute_state`), and is then held: fitted over the whole
log it would absorb model error, and a replay that included the approach would let a
course-unstable model tune itself to a tiny initial error.
"""

from __future__ import annotations

import math

import numpy as np

from fmu_model import ModelParameters
from fmu_model.replay import replay
from identifier.output_error.objective import Objective, prepare_log
from identifier.output_error.records import RefineSettings
from identifier.smoothing import SmoothedTrack, smooth_log
from identifier.wind import known_acceleration
from trials.conditions import execute_index
from trials.logs import ManeuverLog


def fit_initial_state(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack | None = None,
    *,
    end_index: int | None = None,
    settings: RefineSettings | None = None,
) -> np.ndarray:
    """Fit a log's initial state to its track with the coefficients held.

    The first smoothed state is poor at the log's edge (the smoother sees one side
    only); replaying the model over the first ``end_index`` samples (the approach,
    say) and fitting the six initial states to the logged track, with the smoothed
    state as a weak prior, gives the state the model needs.

    Parameters
    ----------
    params : ModelParameters
        The model (held).
    log : ManeuverLog
        The log.
    track : SmoothedTrack, optional
        Its smoothed track; smoothed here when omitted.
    end_index : int, optional
        Fit to samples ``[0, end_index)``; the whole log when omitted. Fewer than 10
        samples: the first smoothed state is returned unchanged.
    settings : RefineSettings, optional
        Weights, replay step and input mode.

    Returns
    -------
    numpy.ndarray
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]) at ``log.time_s[0]``.

    """
    track = track or smooth_log(log)
    settings = _resolved(settings, params, track)
    d = prepare_log(log, track, log.path or "log", settings, windage=params.windage)
    end = log.n_samples if end_index is None else min(int(end_index), log.n_samples)
    if end < 10:
        return d.x0
    objective = Objective(
        structure=params.structure,
        length_m=params.length_m,
        data=(d.head(end),),
        settings=settings,
        theta0=params.to_vector(),
        whiten=np.eye(params.to_vector().size),
        free_theta=False,
        free_x0=True,
    )
    z0 = np.zeros(6)
    if not math.isfinite(objective.cost(z0)):
        return d.x0
    opt = objective.solve(z0, settings.max_nfev)
    return objective.initial_states(opt.x)[0]


def execute_state(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack | None = None,
    *,
    settings: RefineSettings | None = None,
) -> tuple[int, np.ndarray]:
    """Return the execute sample of a log and the model's state there, from the approach.

    The initial state is fitted to the approach (samples up to :func:`execute_index`)
    with the coefficients held (:func:`fit_initial_state`) and replayed to the execute
    sample. Only the approach is used, so a prediction from there is honest; and a
    replay that starts at execute cannot exploit a small initial error that grows
    over the approach (a course-unstable model amplifies it). With fewer than 10
    approach samples the smoothed state at execute is used; when the rudder never
    moves the whole log is the "manoeuvre" (index 0).

    Parameters
    ----------
    params : ModelParameters
        The model (held).
    log : ManeuverLog
        The log.
    track : SmoothedTrack, optional
        Its smoothed track; smoothed here when omitted.
    settings : RefineSettings, optional
        Weights, replay step [s] and input mode.

    Returns
    -------
    tuple of (int, numpy.ndarray)
        The execute index k and (u, v, r, x, y, ψ) at ``log.time_s[k]``, SI units.

    """
    track = track or smooth_log(log)
    k = execute_index(log)
    if k >= log.n_samples - 10:
        k = 0
    if k < 9:
        return k, prepare_log(log, track, "", settings or RefineSettings(), start=k).x0
    settings = _resolved(settings, params, track)
    x0 = fit_initial_state(params, log, track, end_index=k + 1, settings=settings)
    states = replay(
        params.structure,
        params.to_vector(),
        params.length_m,
        log.time_s[: k + 1],
        log.rudder_rad[: k + 1],
        log.n_rps[: k + 1],
        x0,
        inputs=settings.inputs,
        max_step_s=settings.max_step_s,
        extra_acceleration=_head(known_acceleration(log, params.windage), k + 1),
    )
    return k, states[-1]


def _head(values: np.ndarray | None, end: int) -> np.ndarray | None:
    """Return the first ``end`` rows of ``values`` (None stays None)."""
    return None if values is None else values[:end]


def _resolved(
    settings: RefineSettings | None, params: ModelParameters, track: SmoothedTrack
) -> RefineSettings:
    """Return the settings (default ones when None) with the replay step resolved.

    Default step 0.05 L / U0, U0 the nominal speed or else the log's first smoothed u.
    """
    speed = params.nominal_speed_mps or float(track.u_mps[0])
    return (settings or RefineSettings()).with_step(params.length_m, speed)
