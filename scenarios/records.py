"""Records the scenarios share: condition, runs, intervals, comparison rows, validation.

A :class:`Validation` holds the standard manoeuvres (``trials.maneuvers.standard_set``)
run on a reference ship and on a predicted model (an FMU) at the same approach
condition; its comparison rows (:func:`compare_runs`) follow Shi et al. (2009),
Table 2: quantity, reference, predicted, error %. The error of a quantity is
``100 (predicted − reference) / reference`` [%], for the overshoot angles too (a
relative error of a small angle is large: a 5° overshoot predicted as 5.5° is a 10 %
error), so angles also carry the plain difference [deg].

With :class:`UncertaintyBands` (``Validation.uncertainty``) every predicted quantity
also carries a 95 % interval (:class:`Interval`) from a Monte-Carlo run over the
identified coefficients' covariance (``scenarios.validation.uncertainty_bands``), and
a row says whether the reference value lies inside it.

At sea (``Validation.environment``) both ships sail the same current and wind, and
their 35° turns are continued to 720° so that each can be corrected for the drift it
shows (MSC/Circ.1053 3.4.2.5, ``trials.current_correction``; :class:`TurnCorrection`
of a run). A turn whose drift exceeds 1 % of its approach speed is judged on its
current-corrected indices (``scenarios.imo.turning_ability_in_current``), and a pair
of turns is compared on the corrected indices when either is judged so (the label of
the row says "current-corrected"); otherwise on the raw ones.

With the envelope of the identification's logs (``Validation.envelope``, from params.json;
``fmu_model.envelope``) every predicted manoeuvre is also judged for extrapolation: a
manoeuvre steered, turned or slowed beyond the logs (:attr:`Validation.extrapolation`)
is a prediction of the structure beyond its data, whose error no interval carries.

Written out by :mod:`scenarios.report`; produced by :mod:`scenarios.runs` and
:mod:`scenarios.validation`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fmu_model.envelope import Envelope, trajectory_envelope
from scenarios.imo import Criterion, TurningJudgement, turning_ability_in_current
from scenarios.sea import SeaEnvironment
from trials.current_correction import DRIFT_THRESHOLD_FRACTION, CurrentCorrection
from trials.maneuvers import Program
from trials.metrics import TurningMetrics, ZigzagMetrics

__all__ = [
    "ComparisonRow",
    "Condition",
    "Interval",
    "ManeuverRun",
    "TurnCorrection",
    "UncertaintyBands",
    "Validation",
    "beyond_logs",
    "compare_runs",
    "current_correction_record",
    "environment_record",
    "failing_rows",
    "interval_counts",
    "maneuver_label",
    "turn_side",
]

# The compared quantities: (metrics attribute, label, unit) per kind of manoeuvre.
_TURNING_QUANTITIES = (
    ("advance_m", "advance", "m"),
    ("transfer_m", "transfer", "m"),
    ("tactical_diameter_m", "tactical diameter", "m"),
)
_ZIGZAG_QUANTITIES = (
    ("first_overshoot_deg", "1st overshoot", "deg"),
    ("second_overshoot_deg", "2nd overshoot", "deg"),
)


@dataclass(frozen=True)
class Condition:
    """Approach condition and step of a simulated manoeuvre.

    Parameters
    ----------
    speed_mps : float
        Approach speed [m/s].
    n_rps : float
        Propeller speed [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    dt_s : float
        Communication step [s].

    """

    speed_mps: float
    n_rps: float
    rudder_rate_radps: float
    dt_s: float

    def as_dict(self) -> dict[str, float]:
        """JSON record in display units: ``speed_mps, rpm, rudder_rate_deg_s, dt_s``."""
        return {
            "speed_mps": self.speed_mps,
            "rpm": self.n_rps * 60.0,
            "rudder_rate_deg_s": math.degrees(self.rudder_rate_radps),
            "dt_s": self.dt_s,
        }


def environment_record(environment: SeaEnvironment) -> dict[str, float]:
    """JSON record of a steady current and wind, in degrees.

    ``current_mps``, ``current_to_deg`` (the direction it sets towards), ``wind_mps``,
    ``wind_from_deg`` (the direction it comes from), as the command-line options name
    them.
    """
    return {
        "current_mps": environment.current_speed_mps,
        "current_to_deg": math.degrees(environment.current_to_rad),
        "wind_mps": environment.wind_speed_mps,
        "wind_from_deg": math.degrees(environment.wind_from_rad),
    }


def current_correction_record(
    correction: CurrentCorrection, judgement: TurningJudgement, length_m: float
) -> dict[str, Any]:
    """JSON record of a turn's current correction and of the basis it is judged on.

    The corrected indices (the keys of the raw ones, ``TurningMetrics.as_dict``), the
    drift (``CurrentEstimate.as_dict``), ``threshold_fraction``, ``threshold_mps``,
    ``applied`` (whether the corrected indices count), ``imo_basis`` and
    ``imo_reason``.
    """
    return {
        **correction.corrected.as_dict(length_m),
        **correction.estimate.as_dict(),
        "threshold_fraction": DRIFT_THRESHOLD_FRACTION,
        "threshold_mps": correction.threshold_mps(),
        "applied": judgement.corrected,
        "imo_basis": judgement.basis,
        "imo_reason": judgement.reason,
    }


@dataclass(frozen=True)
class TurnCorrection:
    """A turning circle sailed at sea: its current correction, and whether it counts.

    Attributes
    ----------
    correction : CurrentCorrection or None
        MSC/Circ.1053 3.4.2.5 correction of the turn (``trials.current_correction``);
        None when the run does not allow one (less than 720° of heading change).
    enabled : bool
        False judges the raw indices whatever the drift (``--no-current-correction``).

    """

    correction: CurrentCorrection | None
    enabled: bool = True

    def judgement(self, raw: TurningMetrics, length_m: float) -> TurningJudgement:
        """IMO 5.3.1 on the raw or the corrected indices (``turning_ability_in_current``)."""
        return turning_ability_in_current(raw, self.correction, length_m, correct=self.enabled)

    @property
    def applied(self) -> bool:
        """Whether the corrected indices count: enabled, and the drift is above 1 % of U."""
        return self.enabled and self.correction is not None and self.correction.is_significant()


@dataclass(frozen=True)
class ManeuverRun:
    """One manoeuvre simulated: the program, its trajectory and its metrics.

    ``current`` is the current correction of a turning circle sailed at sea (None in
    calm water, and for the other manoeuvres).
    """

    program: Program
    trajectory: np.ndarray
    metrics: TurningMetrics | ZigzagMetrics
    current: TurnCorrection | None = None

    def judgement(self, length_m: float) -> TurningJudgement | None:
        """IMO 5.3.1 of a turn sailed at sea, raw or current-corrected; None otherwise."""
        if self.current is None or not isinstance(self.metrics, TurningMetrics):
            return None
        return self.current.judgement(self.metrics, length_m)

    @property
    def current_corrected(self) -> bool:
        """Whether the run's current-corrected indices count (:attr:`TurnCorrection.applied`)."""
        return self.current is not None and self.current.applied

    def envelope(self, length_m: float) -> Envelope:
        """Return how hard the run steers, turns and slows (``fmu_model.envelope``).

        The speed is through the water; ``length_m`` [m] makes r′.
        """
        return trajectory_envelope(self.trajectory, length_m)

    def metrics_dict(self, length_m: float) -> dict[str, Any]:
        """Return the metrics' JSON record (``as_dict``); ``length_m`` for the L keys [m].

        A turn sailed at sea adds ``current_corrected`` (:func:`current_correction_record`;
        only ``applied``, ``imo_basis`` and ``imo_reason`` when it allows no correction).
        """
        if not isinstance(self.metrics, TurningMetrics):
            return dict(self.metrics.as_dict())
        record: dict[str, Any] = dict(self.metrics.as_dict(length_m))
        judgement = self.judgement(length_m)
        if self.current is not None and judgement is not None:
            if self.current.correction is None:
                record["current_corrected"] = {
                    "applied": False,
                    "imo_basis": judgement.basis,
                    "imo_reason": judgement.reason,
                }
            else:
                record["current_corrected"] = current_correction_record(
                    self.current.correction, judgement, length_m
                )
        return record


@dataclass(frozen=True)
class Interval:
    """95 % interval of one predicted quantity: coefficient uncertainty and model form.

    Attributes
    ----------
    lo, hi : float
        Bounds in the quantity's unit (m or deg); NaN when no sample gave a value.
    mean : float
        Sample mean, moved by ``offset`` like the bounds; NaN when no sample gave one.
    offset : float
        Added to every Monte-Carlo value: predicted value minus the Monte-Carlo value at
        the identified coefficients (the step-size difference of the two runs); 0 when
        either is missing [unit].
    n_samples : int
        Coefficient sets drawn.
    n_failed : int
        Samples without a value (diverged, the run did not reach the event, or the turn
        fell back against its rudder).
    model_form : float
        Half-width of the model-form term in the bounds (the spread of the fit's
        alternative estimates, ``scenarios.uncertainty.model_form``) [unit]; 0 when the
        parameters carry none.

    """

    lo: float
    hi: float
    mean: float
    offset: float
    n_samples: int
    n_failed: int
    model_form: float = 0.0

    @property
    def is_finite(self) -> bool:
        """True when both bounds are finite numbers."""
        return math.isfinite(self.lo) and math.isfinite(self.hi)

    def contains(self, value: float) -> bool:
        """Whether ``value`` lies in [lo, hi] (False for an interval without bounds)."""
        return self.is_finite and self.lo <= value <= self.hi

    def as_dict(self) -> dict[str, Any]:
        """JSON record with the attribute names as keys (NaN left for the writer)."""
        return {
            "lo": self.lo,
            "hi": self.hi,
            "mean": self.mean,
            "offset": self.offset,
            "n_samples": self.n_samples,
            "n_failed": self.n_failed,
            "model_form": self.model_form,
        }


@dataclass(frozen=True)
class UncertaintyBands:
    """Monte-Carlo 95 % intervals of the compared quantities.

    Attributes
    ----------
    intervals : mapping
        ``(maneuver, quantity) → Interval``, keys as in :class:`ComparisonRow`.
    n_samples : int
        Coefficient sets drawn.
    seed : int
        Seed of the draw.
    dt_s : float
        Communication step of the Monte-Carlo runs [s].
    source : str
        Where the coefficients and their covariance come from (the params.json).

    """

    intervals: Mapping[tuple[str, str], Interval]
    n_samples: int
    seed: int
    dt_s: float
    source: str = ""


@dataclass(frozen=True)
class ComparisonRow:
    """One line of the comparison table.

    Attributes
    ----------
    maneuver : str
        Program name, e.g. ``"turning-35-stbd"``.
    quantity : str
        Metrics key, e.g. ``"advance_m"``, ``"first_overshoot_deg"``.
    label : str
        Human-readable, e.g. ``"35° starboard turn: advance"``.
    unit : str
        ``"m"`` or ``"deg"``.
    reference, predicted : float or None
        The two values in ``unit``; None when the run does not cover the quantity.
    error_pct : float or None
        ``100 (predicted − reference) / reference``; None when either value is
        missing or the reference is 0 [%].
    difference : float or None
        ``predicted − reference`` in ``unit``.
    interval : Interval or None
        95 % interval of the predicted value under coefficient uncertainty, when the
        validation ran the Monte Carlo.

    """

    maneuver: str
    quantity: str
    label: str
    unit: str
    reference: float | None
    predicted: float | None
    error_pct: float | None
    difference: float | None
    interval: Interval | None = None

    @property
    def in_interval(self) -> bool | None:
        """Whether the reference lies in the 95 % interval; None when either is missing."""
        if self.interval is None or self.reference is None or not self.interval.is_finite:
            return None
        return self.interval.contains(self.reference)

    def as_dict(self) -> dict[str, Any]:
        """JSON record with the attribute names as keys, and ``in_interval``."""
        return {
            "maneuver": self.maneuver,
            "quantity": self.quantity,
            "label": self.label,
            "unit": self.unit,
            "reference": self.reference,
            "predicted": self.predicted,
            "error_pct": self.error_pct,
            "difference": self.difference,
            "interval": None if self.interval is None else self.interval.as_dict(),
            "in_interval": self.in_interval,
        }


@dataclass(frozen=True)
class Validation:
    """A predicted model and a reference ship through the same manoeuvres.

    Parameters
    ----------
    fmu_path : str
        The FMU that played the predicted side.
    model_name : str
        Its model name (modelDescription ``modelName``).
    model_length_m : float
        Its ship length [m].
    reference_name : str
        E.g. ``"kvlcc2-full"``.
    reference_description : str
        Where the reference model comes from.
    reference_length_m : float
        Reference ship length [m].
    condition : Condition
        Approach condition of every run (the reference ship's), both sides.
    reference, predicted : tuple of ManeuverRun
        The runs, in the same order of programs.
    criteria : tuple of Criterion
        IMO MSC.137(76) verdicts of the predicted model.
    reference_criteria : tuple of Criterion
        The same for the reference ship.
    warnings : tuple of str
        Anything the reader must know (e.g. the two lengths differ).
    uncertainty : UncertaintyBands, optional
        95 % intervals of the predicted quantities (``rows`` carry them).
    environment : SeaEnvironment, optional
        The current and wind both ships sailed in; None in calm water (module
        docstring).
    envelope : Envelope, optional
        What the predicted model's identification logs held (params.json
        ``identification.envelope``); None when not known (no params given).

    Attributes
    ----------
    rows : tuple of ComparisonRow
        The comparison (:func:`compare_runs`), with the intervals.
    extrapolation : dict or None
        Per predicted manoeuvre, how it leaves the envelope (:func:`beyond_logs`; empty:
        it does not); None when the envelope is not known.

    """

    fmu_path: str
    model_name: str
    model_length_m: float
    reference_name: str
    reference_description: str
    reference_length_m: float
    condition: Condition
    reference: tuple[ManeuverRun, ...]
    predicted: tuple[ManeuverRun, ...]
    criteria: tuple[Criterion, ...]
    reference_criteria: tuple[Criterion, ...]
    warnings: tuple[str, ...] = ()
    uncertainty: UncertaintyBands | None = None
    environment: SeaEnvironment | None = None
    envelope: Envelope | None = None
    rows: tuple[ComparisonRow, ...] = field(init=False)
    extrapolation: dict[str, tuple[str, ...]] | None = field(init=False)

    def __post_init__(self) -> None:
        intervals = None if self.uncertainty is None else self.uncertainty.intervals
        rows = compare_runs(self.reference, self.predicted, intervals=intervals)
        object.__setattr__(self, "rows", tuple(rows))
        extrapolation = (
            None
            if self.envelope is None
            else beyond_logs(self.envelope, self.predicted, self.model_length_m)
        )
        object.__setattr__(self, "extrapolation", extrapolation)

    @property
    def max_abs_error_pct(self) -> float | None:
        """Largest |error| over the rows that have one [%]; None when none has."""
        errors = [abs(r.error_pct) for r in self.rows if r.error_pct is not None]
        return max(errors) if errors else None

    @property
    def imo_passed(self) -> bool:
        """True when the predicted model passes every evaluated IMO criterion."""
        return all(c.passed for c in self.criteria)


def beyond_logs(
    envelope: Envelope, runs: Sequence[ManeuverRun], length_m: float
) -> dict[str, tuple[str, ...]]:
    """Per run (program name), how it leaves ``envelope`` (``Envelope.beyond``; empty: not).

    ``length_m`` is the ship length of the runs [m] (for r′).
    """
    return {run.program.name: envelope.beyond(run.envelope(length_m)) for run in runs}


def turn_side(program: Program) -> str:
    """``"starboard"`` or ``"port"``: the side of the program's (first) rudder."""
    return "starboard" if program.rudder_rad >= 0.0 else "port"


def maneuver_label(program: Program) -> str:
    """Human-readable name, e.g. ``"35° starboard turn"``, ``"10/10 zig-zag (port first)"``."""
    delta = round(math.degrees(abs(program.rudder_rad)))
    if program.kind == "turning":
        return f"{delta}° {turn_side(program)} turn"
    psi = round(math.degrees(program.heading_rad))
    return f"{delta}/{psi} zig-zag ({turn_side(program)} first)"


def compare_runs(
    reference: Sequence[ManeuverRun],
    predicted: Sequence[ManeuverRun],
    *,
    intervals: Mapping[tuple[str, str], Interval] | None = None,
) -> list[ComparisonRow]:
    """Compare turning indices and zig-zag overshoots, reference vs predicted.

    Parameters
    ----------
    reference, predicted : sequence of ManeuverRun
        Runs of the same programs in the same order.
    intervals : mapping, optional
        ``(maneuver, quantity) → Interval`` of the predicted values; rows without an
        entry get none.

    Returns
    -------
    list of ComparisonRow
        Advance, transfer, tactical diameter [m] of every turning run; first and second
        overshoot [deg] of every zig-zag. A pair of turns sailed at sea is compared on
        its current-corrected indices when either run's correction counts
        (:attr:`ManeuverRun.current_corrected`) and both have one; the label then ends
        in "(current-corrected)".

    """
    if [r.program.name for r in reference] != [p.program.name for p in predicted]:
        raise ValueError("reference and predicted runs must be the same programs in order")
    rows: list[ComparisonRow] = []
    for ref, pred in zip(reference, predicted, strict=True):
        quantities = (
            _TURNING_QUANTITIES if isinstance(ref.metrics, TurningMetrics) else _ZIGZAG_QUANTITIES
        )
        ref_metrics, pred_metrics, note = ref.metrics, pred.metrics, ""
        if (
            (ref.current_corrected or pred.current_corrected)
            and ref.current is not None
            and ref.current.correction is not None
            and pred.current is not None
            and pred.current.correction is not None
        ):
            ref_metrics = ref.current.correction.corrected
            pred_metrics = pred.current.correction.corrected
            note = " (current-corrected)"
        for key, label, unit in quantities:
            a = getattr(ref_metrics, key)
            b = getattr(pred_metrics, key)
            a = None if a is None else float(a)
            b = None if b is None else float(b)
            difference = None if a is None or b is None else b - a
            error = None if difference is None or a == 0.0 or a is None else 100.0 * difference / a
            rows.append(
                ComparisonRow(
                    maneuver=ref.program.name,
                    quantity=key,
                    label=f"{maneuver_label(ref.program)}: {label}{note}",
                    unit=unit,
                    reference=a,
                    predicted=b,
                    error_pct=error,
                    difference=difference,
                    interval=None if intervals is None else intervals.get((ref.program.name, key)),
                )
            )
    return rows


def failing_rows(rows: Sequence[ComparisonRow], max_error_pct: float) -> list[ComparisonRow]:
    """Rows whose |error| exceeds ``max_error_pct``, or that have no error to judge [%]."""
    return [r for r in rows if r.error_pct is None or abs(r.error_pct) > max_error_pct]


def interval_counts(rows: Sequence[ComparisonRow]) -> tuple[int, int]:
    """Rows whose reference lies inside its interval, and rows with a verdict at all."""
    verdicts = [r.in_interval for r in rows if r.in_interval is not None]
    return sum(verdicts), len(verdicts)
