"""Compile the identification's machine code once per machine, before the first fit.

The smoother (``identifier.smoothing``), the EKF and the replay of a model family
(``fmu_model.kernels``) are numba functions: compiled at their first call, cached on
disk, loaded by every later process. So the first fit on a machine pays the
compilation, about 20 s for the default family here, and keeps numba's compiler in its
process for as long as it runs (about 95 MiB: a long log's fit then needs that much
more memory, a Dask worker keeps it). :func:`warm_up` pays both in a process of its
own: it fits a short reference-ship zig-zag with the settings a fit uses, so that what
it compiles is what a fit calls, with the same argument types. ``make`` runs
``python -m scenarios warm-up`` once after installing: for the default family and for
its thrust twin (``prime-rudder-slipstream-thrust``), which a default fit of logs at one
rpm may be refitted as (``identifier.identify.fixed_thrust_model``); ``--model NAME``
warms up another family.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

from fmu_model.kernels import cache_directory, numba_compilations
from fmu_model.variants import DEFAULT_MODEL
from identifier.current import CURRENT_MODES
from identifier.identify import FitSettings, identify
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log

__all__ = ["WARM_UP_MANEUVER", "WarmUp", "warm_up"]

WARM_UP_MANEUVER = "zigzag-10"
"""The reference-ship log fitted (a full-scale 10/10 zig-zag at 1 Hz: 1,064 samples)."""


@dataclass(frozen=True)
class WarmUp:
    """What :func:`warm_up` did: numba functions compiled and loaded, seconds, cache."""

    compiled: int
    loaded: int
    seconds: float
    kernel_cache: str


def warm_up(model: str = DEFAULT_MODEL) -> WarmUp:
    """Fit :data:`WARM_UP_MANEUVER` of KVLCC2 with ``model`` under every current mode.

    Each current mode (``identifier.current.CURRENT_MODES``) takes its own path through
    the identification (the still-water EKF, the alternation with a current, a drifting
    one), so each is fitted once, with the default procedure (its output-error refinement
    compiles the replay): whatever a default fit calls is compiled. "auto" fits
    "constant" and "none" (the warm-up's log carries no speed log), so it stands for both.

    Raises
    ------
    trials.errors.IdentificationError
        ``model`` cannot be fitted to the zig-zag (a structure whose EKF diverges there).
    ValueError
        ``model`` is not a known structure or family.

    """
    start = time.perf_counter()
    log = synthesize_log(reference_ship("kvlcc2", "full"), MANEUVERS[WARM_UP_MANEUVER]())
    for current in CURRENT_MODES:
        if current not in ("constant", "none"):  # both of them inside "auto"
            identify([log], FitSettings(model=model, current=current))
    compiled, loaded = numba_compilations()
    return WarmUp(compiled, loaded, time.perf_counter() - start, str(cache_directory()))
