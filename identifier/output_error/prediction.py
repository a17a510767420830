"""A log predicted open loop from the model's own state at execute.

The prediction of cross-validation (``identifier.crossval``) and of the choice between
a fit with a current and one without (``identifier.identify``, ``--current auto``): the
model starts from its state at execute, fitted to the approach alone
(:func:`identifier.output_error.initial_state.execute_state`), and runs on the logged
rudder and propeller speed from there, nothing after execute used.
"""

from __future__ import annotations

import numpy as np

from fmu_model import ModelParameters
from fmu_model.replay import replay
from identifier.output_error.initial_state import execute_state
from identifier.smoothing import SmoothedTrack, smooth_log
from identifier.wind import known_acceleration
from trials.logs import ManeuverLog, at_midship


def predict_log(
    params: ModelParameters, log: ManeuverLog, track: SmoothedTrack | None = None
) -> tuple[int, np.ndarray]:
    """Replay the model with a log's inputs from its state at execute.

    The state at execute comes from the approach alone (``execute_state``); from there on
    the model runs open loop on the logged rudder [rad] and propeller speed [rev/s].

    Parameters
    ----------
    params : ModelParameters
        The model.
    log : ManeuverLog
        The log whose inputs are replayed.
    track : SmoothedTrack, optional
        Its smoothed track; smoothed here when omitted.

    Returns
    -------
    tuple of (int, numpy.ndarray)
        The execute index k and the predicted (u, v, r, x, y, ψ) at the samples
        ``k, k+1, …`` (shape (N − k, 6), SI units; NaN from a divergence on).

    """
    log = at_midship(log)  # a GNSS antenna's track: the midship point's, as the model's
    track = track or smooth_log(log)
    k, state = execute_state(params, log, track)
    known = known_acceleration(log, params.windage)
    return k, replay(
        params.structure,
        params.to_vector(),
        params.length_m,
        log.time_s[k:],
        log.rudder_rad[k:],
        log.n_rps[k:],
        state,
        extra_acceleration=None if known is None else known[k:],
        max_step_s=0.05 * params.length_m / max(float(state[0]), 0.1),
        speed_limit_mps=5.0 * max(float(np.max(np.hypot(track.u_mps, track.v_mps))), 0.1),
    )


def track_distance_m(params: ModelParameters, log: ManeuverLog, track: SmoothedTrack) -> np.ndarray:
    """Distance of :func:`predict_log`'s positions from the smoothed track, from execute on [m].

    Against the smoothed positions, not the logged ones: a GNSS jump the smoother
    rejected does not count. NaN from a divergence of the prediction on.
    """
    k, states = predict_log(params, log, track)
    return np.hypot(states[:, 3] - track.x_m[k:], states[:, 4] - track.y_m[k:])
