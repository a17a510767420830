"""The model-form term of the prediction intervals: how far the fit's own estimates disagree.

The coefficient covariance says how well the logs pin the coefficients *of the chosen
structure*; it says nothing of how wrong the structure is, which is why intervals from
it alone contain the truth less often than they claim (issue 13: 6 of 10). The
identification computes three estimates of the same coefficients from the same logs,
each minimising a different error: the equation-error fit (one-step accelerations), the
EKF (filtered one-step prediction of the track) and the output-error refinement (the
whole simulated run). Were the structure exact, all three would converge to the same
coefficients and predict the same manoeuvres; under undermodelling each converges to its
own best approximation, weighted by its own error, and their predictions of a manoeuvre
they were not trained on part (Ljung 1999, *System Identification*, §8.4–8.5: the
limit of prediction- and simulation-error estimates when the true system is not in
the model set). The spread of those predictions is a model-form term measured on the
data, at no extra identification cost.

For each predicted quantity the term is the largest distance of an alternative
estimate's value from the kept estimate's (``params.identification["estimates"]``,
written by ``identifier.identify``); it is combined with the Monte-Carlo interval side
by side in quadrature (:func:`widen`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from scenarios.records import Condition
from scenarios.uncertainty.monte_carlo import RunSetup, monte_carlo_metrics, simulate_chunk
from scenarios.uncertainty.results import METRICS, STATUS_OK, UncertaintyResult
from trials.maneuvers import Program


def alternative_estimates(params: ModelParameters) -> dict[str, np.ndarray]:
    """Coefficient vectors of the estimates recorded besides the kept one (by method).

    Estimates equal to the kept coefficients, or naming other coefficients than the
    model's, are left out; an empty dict when the parameters carry none.
    """
    recorded = params.identification.get("estimates") or {}
    kept = params.to_vector()
    out = {}
    for method, coefficients in recorded.items():
        if not isinstance(coefficients, Mapping) or set(coefficients) != set(params.names):
            continue
        theta = np.array([float(coefficients[name]) for name in params.names])
        if np.all(np.isfinite(theta)) and not np.array_equal(theta, kept):
            out[method] = theta
    return out


def model_form_half_widths(
    params: ModelParameters,
    programs: Sequence[Program],
    condition: Condition,
    *,
    divergence_factor: float = 10.0,
) -> dict[tuple[str, str], float]:
    """Half-width of the model-form term per (program name, metric), in the metric's unit.

    Each estimate sails ``programs`` at ``condition`` (approach speed, propeller rate,
    rudder rate, step).

    The largest |m(θ_alt) − m(θ̂)| over the alternative estimates whose run reaches the
    metric (``scenarios.uncertainty.monte_carlo.METRICS`` names and units: metres and
    radians); 0 for a metric no alternative reaches, and an empty dict when the
    parameters carry no alternative estimates.
    """
    alternatives = alternative_estimates(params)
    if not alternatives:
        return {}
    setup = RunSetup(
        params=params,
        programs=tuple(programs),
        speed_mps=condition.speed_mps,
        n_rps=condition.n_rps,
        rudder_rate_radps=condition.rudder_rate_radps,
        dt_s=condition.dt_s,
        divergence_factor=divergence_factor,
    )
    theta = np.column_stack([params.to_vector(), *alternatives.values()])
    out = {}
    for program, (values, status) in zip(programs, simulate_chunk(theta, setup), strict=True):
        ok = status[1:] == STATUS_OK
        for j, metric in enumerate(METRICS[program.kind]):
            distances = np.abs(values[1:, j][ok] - values[0, j])
            distances = distances[np.isfinite(distances)]
            out[program.name, metric] = float(distances.max()) if distances.size else 0.0
    return out


def widen(predicted: float, lo: float, hi: float, half_width: float) -> tuple[float, float]:
    """Combine an interval [lo, hi] about ``predicted`` with a ± ``half_width`` term.

    Each side's distance from the prediction is added in quadrature to the
    model-form half-width (independent error sources); NaN bounds stay NaN.
    """
    below, above = predicted - lo, hi - predicted
    return predicted - math.hypot(below, half_width), predicted + math.hypot(above, half_width)


def interval_terms(
    params: ModelParameters,
    programs: Sequence[Program],
    condition: Condition,
    **monte_carlo_options: Any,
) -> tuple[UncertaintyResult, dict[tuple[str, str], float]]:
    """Both terms of the 95 % intervals of ``programs`` sailed at one ``condition``.

    The Monte-Carlo run of the coefficient covariance (``monte_carlo_metrics``, which
    gets ``monte_carlo_options``: samples, seed, cluster) and the model-form half-widths
    (:func:`model_form_half_widths`), from the same approach speed, propeller rate,
    rudder rate and step; combine them per metric with :func:`widen`.

    Raises
    ------
    scenarios.errors.UncertaintyError
        From ``monte_carlo_metrics``.

    """
    result = monte_carlo_metrics(
        params,
        programs,
        speed_mps=condition.speed_mps,
        n_rps=condition.n_rps,
        rudder_rate_radps=condition.rudder_rate_radps,
        dt_s=condition.dt_s,
        **monte_carlo_options,
    )
    return result, model_form_half_widths(params, programs, condition)
