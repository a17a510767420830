"""A heading made continuous, robust to compass spikes.

``numpy.unwrap`` takes each sample to the turn nearest the sample before it. A compass
that garbles two headings in a row by half a turn (a spike of +168° followed by one of
−178°, as a gyro's serial line does) then leaves a whole turn behind: the first spike is
taken as it is, the second as +182°, and the good heading after them as a turn further
on, for the rest of the log. The smoother's gate (``identifier.smoothing``) rejects
spikes, not a step of 360° that lasts: it re-acquires there, and the EKF downstream
diverges (found with 1 % compass spikes through the default fit, benchmarks/
environment.md, "The glitch bar again, and compass spikes").

:func:`unwrap_heading` takes each sample to the turn nearest the median of the
:data:`UNWRAP_WINDOW` samples before it instead: up to two bad samples in a row leave
the median a good heading, and the spikes stay spikes for the gate. On a heading that
changes less than half a turn over the window's lag (three samples: a ship turning under
60°/s at 1 Hz) it is ``numpy.unwrap``, to the bit where no sample wraps.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import ArrayLike, NDArray

UNWRAP_WINDOW = 5
"""Samples whose median is the reference of the next one: robust to two bad in a row."""


def unwrap_heading(heading_rad: ArrayLike) -> NDArray[np.float64]:
    """Return ``heading_rad`` continuous: each sample on the turn nearest its predecessors.

    Parameters
    ----------
    heading_rad : array_like
        Headings [rad], wrapped (0..2π or ±π) or continuous, finite, (N,).

    Returns
    -------
    numpy.ndarray
        The headings plus whole turns, (N,) [rad]: sample k is on the turn nearest the
        median of the :data:`UNWRAP_WINDOW` samples before it (the first as given).

    """
    angles = np.asarray(heading_rad, dtype=np.float64)
    if angles.ndim != 1:
        raise ValueError(f"expected headings of shape (N,), got {angles.shape}")
    return _unwrap_kernel(np.ascontiguousarray(angles), UNWRAP_WINDOW)


@numba.njit(cache=True)
def _unwrap_kernel(angles: NDArray[np.float64], window: int) -> NDArray[np.float64]:
    """:func:`unwrap_heading` (N,) with the median of ``window`` samples as reference."""
    n = angles.size
    out = np.empty(n)
    turn = 2.0 * math.pi
    if n:
        out[0] = angles[0]
    for k in range(1, n):
        reference = np.median(out[max(0, k - window) : k])
        out[k] = angles[k] + turn * np.round((reference - angles[k]) / turn)
    return out
