"""Logs of several manoeuvres for the tests: one log after another, as one recording.

It lives with the tests because only they need it (``identifier split`` cuts such logs).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from trials.logs import ManeuverLog


def joined(first: ManeuverLog, then: ManeuverLog, path: str = "day.csv") -> ManeuverLog:
    """``then`` logged after ``first``, one sample later, its track turned and moved on.

    So that its approach continues ``first``'s last heading from its last position, a
    step as long as ``first``'s last one further on (the yaw rate jumps at the join; no
    manoeuvre is sailed across it). The metadata and optional columns are ``first``'s
    (the optional ones left out).
    """
    step_s = float(first.time_s[-1] - first.time_s[-2])
    step_m = math.hypot(first.x_m[-1] - first.x_m[-2], first.y_m[-1] - first.y_m[-2])
    turn = float(first.heading_rad[-1] - then.heading_rad[0])
    north, east = then.x_m - then.x_m[0], then.y_m - then.y_m[0]
    x0 = first.x_m[-1] + step_m * math.cos(first.heading_rad[-1])
    y0 = first.y_m[-1] + step_m * math.sin(first.heading_rad[-1])

    def both(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.concatenate((a, b))

    return replace(
        first,
        time_s=both(first.time_s, first.time_s[-1] + step_s + then.time_s - then.time_s[0]),
        x_m=both(first.x_m, x0 + math.cos(turn) * north - math.sin(turn) * east),
        y_m=both(first.y_m, y0 + math.sin(turn) * north + math.cos(turn) * east),
        heading_rad=both(first.heading_rad, then.heading_rad + turn),
        rudder_rad=both(first.rudder_rad, then.rudder_rad),
        n_rps=both(first.n_rps, then.n_rps),
        wind_speed_mps=None,
        wind_angle_rad=None,
        stw_mps=None,
        stw_transverse_mps=None,
        path=path,
    )
