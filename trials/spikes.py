"""Spikes of the logged inputs: a rudder angle or a propeller speed out and straight back.

The rudder angle and the propeller speed of a trial log are the model's inputs, used as
logged (Shi et al. 2009 smooth only the track, section 4.1). A rudder-angle transmitter or
a tachometer glitches now and then: one or two samples far off, the next back where the
channel was. Taken as logged, such samples are rudder the ship never had; on the KVLCC2
zig-zags at 1 Hz, 1 % of the rudder samples spiked to ±35° moved the predicted 35° turn's
transfer by 10 points and the 10/10 second overshoot by 0.65°, 1 % of the propeller
speeds dropped to 0 the tactical diameter by 4.6 points (`identifier fit`, by hand).
:func:`despiked_inputs` mends a log before every fit (``identifier.preparation``) and
before its manoeuvre's condition is read (``trials.conditions``: a spike before the
execute point would be taken for it, one on a plateau for the rudder amplitude).

A spike is a run of at most :data:`MAX_SPIKE_SAMPLES` samples that leaves the sample
before it and returns to the sample after it, both steps in opposite directions and
faster than the ship can move the input: the steering gear and the engine of a ship are
Froude-scaled with it, so their fastest rate is a multiple of √(g/L) per second. Measured:
the KVLCC2 rudder turns at 2.3 °/s (0.23 √(g/L) at L = 320 m), the HSVA model's at
17 °/s (0.25 √(g/L) at 7 m); the bound :data:`FROUDE_RATE` × √(g/L) is four times that,
for the rudder in radians per second and for the propeller speed relative to the log's
median. A genuine fast move that does not come straight back is never a spike; the first
and the last sample have no neighbour on one side and are never one either. Two spikes
two or three samples apart make the good samples between them look like one too: all
are interpolated from the samples either side, which puts them back where the channel
was.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import scipy.constants
from numpy.typing import ArrayLike, NDArray

from trials.logs import ManeuverLog

__all__ = [
    "FROUDE_RATE",
    "MAX_SPIKE_SAMPLES",
    "despiked",
    "despiked_inputs",
    "input_rate_bound",
    "out_and_back",
]

FloatArray = NDArray[np.float64]

FROUDE_RATE = 1.0
"""The fastest input rate a ship can have, in units of √(g/L) [1/s] (module notes)."""

MAX_SPIKE_SAMPLES = 2
"""Longest run of samples taken for one spike."""


def input_rate_bound(length_m: float) -> float:
    """Return the fastest rate of a ship's inputs, :data:`FROUDE_RATE` · √(g/L) [1/s].

    In rad/s for the rudder angle; for the propeller speed, a fraction of its median
    per second.
    """
    return FROUDE_RATE * math.sqrt(scipy.constants.g / length_m)


def out_and_back(t_s: ArrayLike, values: ArrayLike, max_rate: float) -> NDArray[np.intp]:
    """Return the samples of ``values`` that are spikes (module notes), in order.

    Samples k … k+w−1 (1 ≤ w ≤ :data:`MAX_SPIKE_SAMPLES`) are a spike when the steps
    into and out of the run, a = z_k − z_{k−1} and b = z_{k+w} − z_{k+w−1}, have
    opposite signs and each is larger than ``max_rate`` × its interval, and the samples
    on either side agree: |z_{k+w} − z_{k−1}| ≤ ``max_rate`` · (t_{k+w} − t_{k−1}) (the
    channel came straight back).

    Parameters
    ----------
    t_s : array_like, shape (N,)
        Sample times [s], strictly increasing.
    values : array_like, shape (N,)
        The input [its unit].
    max_rate : float
        The fastest rate the input can have [its unit per second], > 0.

    """
    t = np.asarray(t_s, dtype=float)
    z = np.asarray(values, dtype=float)
    step = np.diff(z)
    fast = np.abs(step) > max_rate * np.diff(t)
    spike = np.zeros(z.size, dtype=bool)
    for width in range(1, MAX_SPIKE_SAMPLES + 1):
        into, out = step[: step.size - width], step[width:]
        across = np.abs(z[width + 1 :] - z[: z.size - width - 1])  # z_{k+w} − z_{k−1}
        back = across <= max_rate * (t[width + 1 :] - t[: t.size - width - 1])
        runs = fast[: fast.size - width] & fast[width:] & (into * out < 0.0) & back
        for k in np.flatnonzero(runs):
            spike[k + 1 : k + 1 + width] = True
    return np.flatnonzero(spike)


def despiked(t_s: ArrayLike, values: ArrayLike, spikes: ArrayLike) -> FloatArray:
    """Return ``values`` with the samples ``spikes`` interpolated linearly in time.

    Between the nearest samples that are not spikes on either side (spikes are never
    the first or the last sample, :func:`out_and_back`).
    """
    t = np.asarray(t_s, dtype=float)
    z = np.array(values, dtype=float)
    bad = np.zeros(z.size, dtype=bool)
    bad[np.asarray(spikes, dtype=np.intp)] = True
    z[bad] = np.interp(t[bad], t[~bad], z[~bad])
    return z


def despiked_inputs(
    log: ManeuverLog, length_m: float | None = None
) -> tuple[ManeuverLog, int, int]:
    """Return ``log`` with the spikes of its rudder angle and propeller speed interpolated.

    Spikes as :func:`out_and_back` finds them at :func:`input_rate_bound` of the ship's
    length ``length_m`` [m] (default the log's ``# length_m:``; with neither, the log as
    it is), the propeller speed relative to its median (a log whose median is 0 is not
    looked at). Also returns how many rudder angles and propeller speeds were taken for
    spikes; the log itself when none was.
    """
    length = log.length_m if length_m is None else length_m
    if length is None:
        return log, 0, 0
    rate = input_rate_bound(length)
    rudder = out_and_back(log.time_s, log.rudder_rad, rate)
    typical_rps = float(np.median(np.abs(log.n_rps)))
    propeller = (
        out_and_back(log.time_s, log.n_rps, rate * typical_rps)
        if typical_rps > 0.0
        else np.empty(0, dtype=np.intp)
    )
    if not (rudder.size or propeller.size):
        return log, 0, 0
    despiked_log = replace(
        log,
        rudder_rad=despiked(log.time_s, log.rudder_rad, rudder),
        n_rps=despiked(log.time_s, log.n_rps, propeller),
    )
    return despiked_log, int(rudder.size), int(propeller.size)
