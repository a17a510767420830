"""The trajectory record shared by the driver, the reference ship and the metrics.

A trajectory is a structured numpy array, one row per communication point, SI units
and radians inside (DESIGN.md conventions); the field names carry the unit.
"""

from __future__ import annotations

import numpy as np

TRAJECTORY_DTYPE = np.dtype(
    [
        ("time_s", "f8"),
        ("x_m", "f8"),  # North of the origin
        ("y_m", "f8"),  # East of the origin
        ("psi_rad", "f8"),  # heading, clockwise from North, continuous (not wrapped)
        ("u_mps", "f8"),  # surge velocity
        ("v_mps", "f8"),  # sway velocity, positive to starboard
        ("r_radps", "f8"),  # yaw rate, positive turning to starboard
        ("rudder_rad", "f8"),  # actual rudder angle, positive turns to starboard
        ("n_rps", "f8"),  # propeller speed [rev/s]
    ]
)

STATE_FIELDS = ("u_mps", "v_mps", "r_radps", "x_m", "y_m", "psi_rad")
"""The fields of the 6-state (u, v, r, x, y, ψ), in the state-vector order of ``fmu_model``."""


def empty_trajectory(n_samples: int) -> np.ndarray:
    """Return a zero-filled trajectory with ``n_samples`` rows."""
    return np.zeros(n_samples, dtype=TRAJECTORY_DTYPE)


def trajectory_of(
    time_s: np.ndarray, states: np.ndarray, rudder_rad: np.ndarray, n_rps: np.ndarray
) -> np.ndarray:
    """Return the trajectory of ``states`` (N, 6) in :data:`STATE_FIELDS` order at ``time_s``."""
    traj = empty_trajectory(time_s.size)
    traj["time_s"] = time_s
    for column, name in enumerate(STATE_FIELDS):
        traj[name] = states[:, column]
    traj["rudder_rad"], traj["n_rps"] = rudder_rad, n_rps
    return traj
