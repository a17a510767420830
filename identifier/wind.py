"""A measured wind in identification: its load taken out, so the coefficients are the ship's.

A log may carry the apparent wind of an anemometer (``wind_speed_mps``, ``wind_angle_deg``
off the bow, positive from starboard; ``trials.logs``). With the vessel's windage (its
projected areas and effective inertias, ``fmu_model.environment.Windage``, from
``--windage``) the wind's load follows from the published shape of Blendermann (1994)
(``fmu_model.environment.wind_accelerations``), the same the FMU applies to its wind
inputs. Its accelerations are known inputs of the identification: subtracted from the
equation-error targets, added to the EKF's and the output-error replay's model
(``EkfSegment.known_acceleration``, ``fmu_model.replay``'s ``extra_acceleration``).
The load is that of the whole apparent wind, including the ship's own motion through
still air, as in the FMU: the hull's resistance is then without its air drag, and the
FMU with the same windage adds it back.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np

from fmu_model.environment import Windage, true_wind, wind_accelerations
from fmu_model.params import ParamsFormatError, read_json
from identifier.smoothing import SmoothedTrack
from trials.logs import ManeuverLog

WINDAGE_KEYS = "{" + ", ".join(f.name for f in fields(Windage)) + "}"
"""The keys of a windage file, for messages."""


def has_wind(log: ManeuverLog) -> bool:
    """Whether the log carries the apparent wind (speed and angle)."""
    return log.wind_speed_mps is not None and log.wind_angle_rad is not None


def known_acceleration(log: ManeuverLog, windage: Windage | None) -> np.ndarray | None:
    """Return the accelerations of the logged wind's load (N, 3), or None.

    (X/(m+m_x) [m/s²], Y/(m+m_y) [m/s²], N/(I_z+J_z) [rad/s²]) at every sample; None when
    the log carries no wind or no windage is given (nothing is taken out then).
    """
    if windage is None or log.wind_speed_mps is None or log.wind_angle_rad is None:
        return None
    du, dv, dr = wind_accelerations(log.wind_speed_mps, log.wind_angle_rad, windage)
    return np.column_stack([du, dv, dr])


def mean_true_wind_ne(log: ManeuverLog, track: SmoothedTrack) -> np.ndarray | None:
    """Return a log's mean true wind, the velocity it blows with (North, East) [m/s].

    Each sample's true wind from its apparent wind and the ship's smoothed heading and
    velocity over ground (``fmu_model.environment.true_wind``), averaged as vectors (a
    gust and a veer average out); None when the log carries no wind. What a held-out
    run is sailed again in (``identifier.crossval``).
    """
    if log.wind_speed_mps is None or log.wind_angle_rad is None:
        return None
    speed, from_rad = true_wind(
        log.wind_speed_mps, log.wind_angle_rad, track.heading_rad, track.u_mps, track.v_mps
    )
    towards = np.asarray(from_rad) + np.pi
    return np.array([np.mean(speed * np.cos(towards)), np.mean(speed * np.sin(towards))])


def speed_and_source(wind_ne: np.ndarray) -> tuple[float, float]:
    """Return a wind velocity's speed [m/s] and the direction it comes from [rad, 0 to 2π).

    ``wind_ne``: the velocity it blows with, (North, East) [m/s], as
    :func:`mean_true_wind_ne` returns it; the pair the FMU's wind inputs take.
    """
    north, east = float(wind_ne[0]), float(wind_ne[1])
    return math.hypot(north, east), math.atan2(-east, -north) % (2.0 * math.pi)


def read_windage(path: str) -> Windage:
    """Read a windage file: a JSON object with the fields of ``Windage.to_dict``.

    Raises
    ------
    ParamsFormatError
        One line naming the file (and the JSON line) and what is wrong.

    """
    doc = read_json(path)
    try:
        return Windage.from_dict(doc)
    except (TypeError, ValueError) as exc:
        raise ParamsFormatError(path, f"expected a windage {WINDAGE_KEYS}: {exc}") from None
