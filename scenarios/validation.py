"""Validation: an FMU against a reference ship through the standard set, with intervals.

:func:`validate` runs the standard set on the FMU and on the reference ship at the
reference's approach condition and returns the :class:`scenarios.records.Validation`;
:func:`with_uncertainty` adds the 95 % intervals of the predicted quantities from a
Monte-Carlo run over the identified coefficients' covariance
(``scenarios.uncertainty.monte_carlo``), located at the predicted values by
:func:`uncertainty_bands`. Problems are :class:`scenarios.errors.ScenarioError`.

At sea (``environment``) both ships sail the same current and wind: the FMU through
its environment inputs (``scenarios.fmu_plant``), the reference through its own
equations and windage (``scenarios.kvlcc2.ReferencePlant``); their turns are
continued to 720° and compared and judged on the current-corrected indices where the
drift counts (``scenarios.runs``, ``scenarios.records``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING

from fmu_model.interface import logged_envelope
from scenarios.errors import ScenarioError, UncertaintyError
from scenarios.fmu_checks import (
    check_environment,
    check_params_match,
    check_rudder,
    open_fmu,
    read_fmu_info,
)
from scenarios.records import (
    ComparisonRow,
    Interval,
    UncertaintyBands,
    Validation,
)
from scenarios.runs import imo_criteria, reference_runs, run_standard_set
from scenarios.uncertainty.model_form import interval_terms, widen

if TYPE_CHECKING:
    from distributed import Client

    from fmu_model import ModelParameters
    from scenarios.sea import SeaEnvironment
    from scenarios.uncertainty.results import UncertaintyResult

__all__ = ["uncertainty_bands", "validate", "with_uncertainty"]


def validate(
    fmu_path: str | os.PathLike[str],
    *,
    reference: str = "kvlcc2",
    scale: str = "full",
    dt_s: float = 0.1,
    on_run: Callable[[str], object] | None = None,
    params: ModelParameters | None = None,
    uncertainty_samples: int = 0,
    uncertainty_dt_s: float = 0.5,
    seed: int = 0,
    scheduler: str | None = None,
    n_workers: int = 2,
    params_source: str = "",
    environment: SeaEnvironment | None = None,
    current_correction: bool = True,
) -> Validation:
    """Run the standard set on an FMU and on a reference ship, same approach condition.

    Both ships start at the reference ship's approach speed and propeller speed and use
    its steering-gear rate (an identified model of that ship is meant to reproduce it
    there). With ``params`` and ``uncertainty_samples`` > 0 the predicted quantities
    also get their 95 % intervals (:func:`with_uncertainty`).

    Parameters
    ----------
    fmu_path : path-like
        The predicted model.
    reference : str
        Reference vessel (``scenarios.synthesize.reference_ship``).
    scale : str
        ``"full"`` or ``"model"``.
    dt_s : float
        Communication step of both [s].
    on_run : callable, optional
        Called with a label after each of the eight runs.
    params : ModelParameters, optional
        The parameters the FMU was built from, with their covariance; checked against
        the FMU (:func:`check_params_match`) before anything runs. The envelope of
        their logs (``identification.envelope``) says which predictions extrapolate
        (``Validation.extrapolation``).
    uncertainty_samples : int
        Monte-Carlo samples for the intervals; 0 for none.
    uncertainty_dt_s : float
        Step of the Monte-Carlo runs [s].
    seed : int
        Seed of the draw.
    scheduler : str, optional
        Address of a dask scheduler for the Monte Carlo; default a local cluster.
    n_workers : int
        Workers of that local cluster.
    params_source : str, optional
        Where ``params`` come from (e.g. the params.json path), for the report.
    environment : SeaEnvironment, optional
        Current and wind both ships sail in (module docstring); calm water when None.
    current_correction : bool
        At sea, False compares and judges the turns' raw indices whatever their drift.

    Raises
    ------
    ScenarioError
        Bad FMU, parameters that do not match it or have no covariance, a run that does
        not give its metrics, an FMU error, an FMU without environment inputs at sea.

    """
    info = read_fmu_info(fmu_path)
    check_rudder(info, math.radians(35.0))
    if environment is not None:
        check_environment(info)
    if params is not None:
        check_params_match(info, params, params_source)
    if params is not None and uncertainty_samples > 0 and params.covariance is None:
        raise ScenarioError(
            f"{params_source or 'the parameters'}: no covariance, so no uncertainty to "
            "sample; identify with a covariance or leave out the uncertainty"
        )
    ref_name, description, ref_length, condition, ref = reference_runs(
        reference, scale, dt_s, environment=environment, current_correction=current_correction
    )
    if on_run is not None:
        for run in ref:
            on_run(f"reference {run.program.name}")
    with open_fmu(fmu_path, environment) as plant:
        predicted = run_standard_set(
            plant,
            condition,
            ref_length,
            on_run=None if on_run is None else lambda name: on_run(f"predicted {name}"),
            at_sea=environment is not None,
            current_correction=current_correction,
        )
    warnings = []
    if abs(info.length_m - ref_length) > 1e-9 * ref_length:
        warnings.append(
            f"the FMU's ship length ({info.length_m:g} m) differs from the reference's "
            f"({ref_length:g} m); the errors compare metres"
        )
    if info.speed_mps > 0.0 and abs(info.speed_mps / condition.speed_mps - 1.0) > 0.01:
        warnings.append(
            f"the FMU's start speed u0 = {info.speed_mps:.4g} m/s differs from the approach "
            f"speed {condition.speed_mps:.4g} m/s used for both ships"
        )
    if environment is not None and environment.has_wind and not info.has_windage:
        warnings.append(
            "the FMU has no windage (frontal_area = lateral_area = 0): the wind acts on the "
            "reference ship only"
        )
    if environment is not None and params is not None and uncertainty_samples > 0:
        warnings.append(
            "the 95 % intervals come from Monte-Carlo runs in calm water, moved to the "
            "predicted values at sea"
        )
    validation = Validation(
        fmu_path=info.path,
        model_name=info.model_name,
        model_length_m=info.length_m,
        reference_name=ref_name,
        reference_description=description,
        reference_length_m=ref_length,
        condition=condition,
        reference=ref,
        predicted=predicted,
        criteria=tuple(imo_criteria(predicted, info.length_m, condition.speed_mps)),
        reference_criteria=tuple(imo_criteria(ref, ref_length, condition.speed_mps)),
        warnings=tuple(warnings),
        environment=environment,
        envelope=None if params is None else logged_envelope(params),
    )
    if params is None or uncertainty_samples <= 0:
        return validation
    return with_uncertainty(
        validation,
        params,
        n_samples=uncertainty_samples,
        dt_s=uncertainty_dt_s,
        seed=seed,
        scheduler=scheduler,
        n_workers=n_workers,
        source=params_source,
    )


def with_uncertainty(
    validation: Validation,
    params: ModelParameters,
    *,
    n_samples: int = 100,
    dt_s: float = 0.5,
    seed: int = 0,
    scheduler: str | None = None,
    client: Client | None = None,
    n_workers: int = 2,
    processes: bool = True,
    chunk_size: int | None = None,
    source: str = "",
) -> Validation:
    """Return ``validation`` with the 95 % intervals of its predicted quantities.

    Runs the Monte-Carlo sampling (``scenarios.uncertainty.model_form.interval_terms``) on
    the validation's programs at its approach condition (the reference ship's speed,
    propeller speed and rudder rate) and locates each interval at the predicted value
    (:func:`uncertainty_bands`). When the parameters carry the fit's alternative
    estimates (``identification["estimates"]``), each interval is widened by the
    model-form term, the spread of their predictions
    (``scenarios.uncertainty.model_form``).

    Parameters
    ----------
    validation : Validation
        From :func:`validate`.
    params : ModelParameters
        The parameters the validated FMU was built from, with their covariance.
    n_samples : int
        Coefficient sets to draw.
    dt_s : float
        Communication step of the Monte-Carlo runs [s].
    seed : int
        Seed of the draw.
    scheduler : str, optional
        Address of a running dask scheduler (``"tcp://host:8786"``).
    client : distributed.Client, optional
        An existing client (not closed here).
    n_workers : int
        Workers of the local cluster made when neither of the two is given.
    processes : bool
        Whether that local cluster's workers are processes (else threads of this one).
    chunk_size : int, optional
        Samples per task. Default on a local cluster: one task per worker process, or
        a single task for thread workers (they share the GIL); the cost of a task is
        set by its number of steps much more than by its number of ships. Default on
        a given scheduler or client: ``monte_carlo_metrics``'s.
    source : str, optional
        Where ``params`` come from, for the report.

    Raises
    ------
    ScenarioError
        The parameters do not match the FMU, have no usable covariance, or the
        settings are invalid.

    """
    check_params_match(read_fmu_info(validation.fmu_path), params, source)
    if chunk_size is None and scheduler is None and client is None:
        chunk_size = max(1, math.ceil(n_samples / max(1, n_workers)) if processes else n_samples)
    try:
        result, model_form = interval_terms(
            params,
            [run.program for run in validation.predicted],
            replace(validation.condition, dt_s=dt_s),
            n_samples=n_samples,
            seed=seed,
            scheduler=scheduler,
            client=client,
            n_workers=n_workers,
            processes=processes,
            chunk_size=chunk_size,
        )
    except UncertaintyError as exc:
        raise ScenarioError(f"{source or 'uncertainty'}: {exc}") from None
    bands = uncertainty_bands(result, validation.rows, source=source, model_form=model_form)
    return replace(validation, uncertainty=bands)


def uncertainty_bands(
    result: UncertaintyResult,
    rows: Sequence[ComparisonRow],
    *,
    source: str = "",
    model_form: Mapping[tuple[str, str], float] | None = None,
) -> UncertaintyBands:
    """95 % intervals of the rows' predicted values from a Monte-Carlo run.

    For each row the samples of its metric (``result.summary``; overshoots converted
    from radians to degrees) are moved by ``offset = predicted − m(θ̂)``, the
    difference between the validation run and the Monte-Carlo run at the identified
    coefficients, so that the interval sits where the validation put the prediction:
    ``lo = q₀.₀₂₅ + offset``, ``hi = q₀.₉₇₅ + offset``, ``mean = mean + offset``. When
    either value is missing the offset is 0. A ``model_form`` half-width of the row's
    (manoeuvre, metric) widens both sides in quadrature (``model_form.widen``).

    Parameters
    ----------
    result : scenarios.uncertainty.results.UncertaintyResult
        Monte-Carlo run of the rows' programs (same names).
    rows : sequence of ComparisonRow
        The comparison (``compare_runs``) whose predicted values locate the intervals.
    source : str, optional
        Where the coefficients come from, for the report.
    model_form : mapping, optional
        Model-form half-width per (manoeuvre, Monte-Carlo metric), in the metric's
        unit (``model_form.model_form_half_widths``).

    Raises
    ------
    KeyError
        A row's manoeuvre is not among the result's programs.

    """
    intervals: dict[tuple[str, str], Interval] = {}
    for row in rows:
        if row.unit == "deg":
            metric, scale = row.quantity[: -len("_deg")] + "_rad", math.degrees(1.0)
        else:
            metric, scale = row.quantity, 1.0
        s = result.summary(row.maneuver, metric)
        nominal = scale * s.nominal
        offset = (
            row.predicted - nominal if row.predicted is not None and math.isfinite(nominal) else 0.0
        )
        lo, hi = scale * s.q025 + offset, scale * s.q975 + offset
        half_width = scale * (model_form or {}).get((row.maneuver, metric), 0.0)
        if half_width > 0.0 and math.isfinite(nominal):
            lo, hi = widen(nominal + offset, lo, hi, half_width)
        intervals[row.maneuver, row.quantity] = Interval(
            lo=lo,
            hi=hi,
            mean=scale * s.mean + offset,
            offset=offset,
            n_samples=s.n_samples,
            n_failed=s.n_failed,
            model_form=half_width,
        )
    return UncertaintyBands(
        intervals=intervals,
        n_samples=result.n_samples,
        seed=result.seed,
        dt_s=result.dt_s,
        source=source,
    )
