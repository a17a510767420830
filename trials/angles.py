"""A heading made continuous, robust to compass spikes.

``numpy.unwrap`` takes each sample to the turn nearest the sample before it. A compass
that garbles two headings in a row by about half a turn (a spike of +168° followed by
one of −178°, as a gyro's serial line does) then leaves a whole turn behind: the first
spike is taken as it is, the second as +182°, and the good heading after them as a turn
further on, for the rest of the log. The smoother's gate (``identifier.smoothing``)
rejects spikes, not a step of 360° that lasts: it re-acquires there, and the EKF
downstream diverges (found with 1 % compass spikes through the default fit,
benchmarks/environment.md, "The glitch bar again, and compass spikes").

:func:`unwrap_heading` is ``numpy.unwrap`` where the heading steps less than
:data:`SPIKE_STEP_RAD` (a third of a turn) between samples, which a ship's heading logged
at 1 Hz or faster always does: there it is the same to the bit. After a larger step (a
spike, or its end) it takes each of the next :data:`UNWRAP_WINDOW` + 1 samples onto the
turn nearest the median of the :data:`UNWRAP_WINDOW` samples before it, and everything
after by the same whole turns: up to two bad samples in a row leave the median a good
heading, and the spikes stay spikes for the gate.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

UNWRAP_WINDOW = 5
"""Samples whose median is the reference after a large step: robust to two bad in a row."""

SPIKE_STEP_RAD = math.pi / 3.0
"""A step between samples from which on the next ones are checked against the median [rad].

Below it three steps stay within half a turn of the median of the five samples before
(the median is one of the three latest or lies between them), so the rule cannot differ
from ``numpy.unwrap`` there."""


def unwrap_heading(heading_rad: ArrayLike) -> NDArray[np.float64]:
    """Return ``heading_rad`` continuous, spikes left as spikes (module docstring).

    Parameters
    ----------
    heading_rad : array_like
        Headings [rad], wrapped (0..2π or ±π) or continuous, finite, (N,).

    Returns
    -------
    numpy.ndarray
        The headings plus whole turns, (N,) [rad].

    """
    unwrapped = np.unwrap(np.asarray(heading_rad, dtype=np.float64))
    if unwrapped.ndim != 1:
        raise ValueError(f"expected headings of shape (N,), got {unwrapped.shape}")
    turn = 2.0 * math.pi
    checked = 0  # samples before this one are final
    steps = np.flatnonzero(np.abs(np.diff(unwrapped)) >= SPIKE_STEP_RAD) + 1
    for start in steps.tolist():
        end = min(start + UNWRAP_WINDOW + 1, unwrapped.size)
        for k in range(max(start, checked), end):
            reference = float(np.median(unwrapped[max(0, k - UNWRAP_WINDOW) : k]))
            turns = round((reference - float(unwrapped[k])) / turn)
            if turns:
                unwrapped[k:] += turn * turns
        checked = max(checked, end)
    return unwrapped
