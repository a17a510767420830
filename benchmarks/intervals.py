"""95 % prediction intervals of a fit's manoeuvre metrics, for the coverage columns.

The intervals of ``validate`` (issue 13, item 4; ``scenarios.uncertainty.model_form.
interval_terms``): 100 Monte-Carlo samples of the identified coefficients, alone and
widened by the model-form term, the spread of the fit's own alternative estimates. Used
by ``fidelity.py`` (the reference) and ``hsva.py`` (the measured runs, each in its own
condition).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

from fmu_model import ModelParameters
from scenarios.records import Condition
from scenarios.uncertainty.model_form import interval_terms, widen
from scenarios.uncertainty.results import METRICS
from trials.maneuvers import Program

MONTE_CARLO_SAMPLES = 100


@dataclass(frozen=True)
class Interval:
    """One metric's prediction and its 95 % intervals [SI: m, rad]."""

    nominal: float
    identification: tuple[float, float]
    with_model_form: tuple[float, float]


def prediction_intervals(
    params: ModelParameters, programs: Sequence[Program], condition: Condition
) -> dict[tuple[str, str], Interval]:
    """Intervals per (program name, metric) of ``params`` sailing ``programs``.

    Metrics the nominal run or the samples do not reach are left out.
    """
    result, half = interval_terms(
        params,
        programs,
        condition,
        n_samples=MONTE_CARLO_SAMPLES,
        n_workers=1,
        processes=False,
    )
    out = {}
    for program in programs:
        for metric in METRICS[program.kind]:
            s = result.summary(program.name, metric)
            if not (math.isfinite(s.q025) and math.isfinite(s.nominal)):
                continue
            out[program.name, metric] = Interval(
                s.nominal,
                (s.q025, s.q975),
                widen(s.nominal, s.q025, s.q975, half.get((program.name, metric), 0.0)),
            )
    return out
