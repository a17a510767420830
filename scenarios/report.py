"""Validation results and their report: comparison table, IMO verdicts, markdown, JSON, PNGs.

A :class:`Validation` holds the standard manoeuvres (``scenarios.maneuvers.standard_set``)
run on a reference ship and on a predicted model (an FMU) at the same approach
condition. From it this module derives the comparison table in the manner of Shi et al.
(2009), Table 2 (quantity, reference, predicted, error %), applies the error gate, and
writes the report directory::

    report.md            the tables, the IMO verdicts, the figures
    validation.json      the same numbers, for machines (format below)
    turning-circles.png  35° turns, starboard and port, reference vs predicted (in L)
    <zigzag>.png         heading, rudder and speed time histories per zig-zag
    uncertainty.png      reference vs predicted with the 95 % intervals (with uncertainty)

The error of a quantity is ``100 (predicted − reference) / reference`` [%], for the
overshoot angles too (a relative error of a small angle is large: a 5° overshoot
predicted as 5.5° is a 10 % error), so angles also carry the plain difference [deg].

With :class:`UncertaintyBands` (``Validation.uncertainty``) every predicted quantity
also carries a 95 % interval from a Monte-Carlo run over the identified coefficients'
covariance (``scenarios.uncertainty.monte_carlo_metrics``), and the table says whether
the reference value lies inside it. The Monte-Carlo runs step more coarsely than the
validation runs, so each interval is moved by the offset between the predicted value
and the Monte-Carlo value at θ̂ (:func:`uncertainty_bands`):

    [lo, hi] = predicted + [q₀.₀₂₅ − m(θ̂), q₀.₉₇₅ − m(θ̂)],

with m(θ̂) the metric of the Monte-Carlo run at the identified coefficients: the
location comes from the validation run, the spread from the samples.

``validation.json``::

    {"format": "ship-maneuvering-validation", "version": 1,
     "fmu": path, "reference": {"name", "description", "length_m"},
     "model": {"name", "length_m"},
     "condition": {"speed_mps", "rpm", "rudder_rate_deg_s", "dt_s"},
     "comparison": [{"maneuver", "quantity", "label", "unit", "reference",
                     "predicted", "error_pct", "difference",
                     "interval": {"lo", "hi", "mean", "offset", "n_samples",
                                  "n_failed"} | null,
                     "in_interval": bool | null}, ...],
     "uncertainty": {"n_samples", "seed", "dt_s", "source", "scope",
                     "n_in_interval", "n_with_interval"} | null,
     "max_abs_error_pct": float | null,
     "gate": {"max_error_pct", "passed", "failing": [label, ...]} | null,
     "imo": {"passed": bool, "criteria": [Criterion.as_dict(), ...]},
     "imo_reference": {...same for the reference ship...},
     "runs": {"reference": {maneuver: metrics}, "predicted": {maneuver: metrics}},
     "warnings": [str, ...]}
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from fmu_model.atomic import write_atomic
from scenarios.imo import Criterion
from scenarios.maneuvers import Program
from scenarios.metrics import TurningMetrics, ZigzagMetrics
from scenarios.plots import (
    IntervalBar,
    interval_figure,
    save_png,
    trajectory_figure,
    zigzag_figure,
)

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from scenarios.uncertainty import UncertaintyResult

__all__ = [
    "VALIDATION_FORMAT",
    "VALIDATION_VERSION",
    "ComparisonRow",
    "Condition",
    "Interval",
    "ManeuverRun",
    "UncertaintyBands",
    "Validation",
    "compare_runs",
    "comparison_table",
    "criteria_table",
    "failing_rows",
    "figure_names",
    "format_table",
    "interval_counts",
    "render_markdown",
    "uncertainty_bands",
    "uncertainty_figure",
    "validation_json",
    "write_json",
    "write_report",
]

VALIDATION_FORMAT = "ship-maneuvering-validation"
VALIDATION_VERSION = 1

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

UNCERTAINTY_SCOPE = (
    "coefficient uncertainty from identification only (the measurement noise of the "
    "trial logs), not model-structure error"
)
"""What the 95 % intervals cover, for the report and ``validation.json``."""


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


@dataclass(frozen=True)
class ManeuverRun:
    """One manoeuvre simulated: the program, its trajectory and its metrics."""

    program: Program
    trajectory: np.ndarray
    metrics: TurningMetrics | ZigzagMetrics

    def metrics_dict(self, length_m: float) -> dict[str, Any]:
        """Return the metrics' JSON record (``as_dict``); ``length_m`` for the L keys [m]."""
        if isinstance(self.metrics, TurningMetrics):
            return dict(self.metrics.as_dict(length_m))
        return dict(self.metrics.as_dict())


@dataclass(frozen=True)
class Interval:
    """95 % interval of one predicted quantity under coefficient uncertainty.

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
        Samples without a value (diverged or the run did not reach the event).

    """

    lo: float
    hi: float
    mean: float
    offset: float
    n_samples: int
    n_failed: int

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
    rows: tuple[ComparisonRow, ...] = field(init=False)

    def __post_init__(self) -> None:
        intervals = None if self.uncertainty is None else self.uncertainty.intervals
        rows = compare_runs(self.reference, self.predicted, intervals=intervals)
        object.__setattr__(self, "rows", tuple(rows))

    @property
    def max_abs_error_pct(self) -> float | None:
        """Largest |error| over the rows that have one [%]; None when none has."""
        errors = [abs(r.error_pct) for r in self.rows if r.error_pct is not None]
        return max(errors) if errors else None

    @property
    def imo_passed(self) -> bool:
        """True when the predicted model passes every evaluated IMO criterion."""
        return all(c.passed for c in self.criteria)


def _side(program: Program) -> str:
    return "starboard" if program.rudder_rad >= 0.0 else "port"


def _row_label(program: Program, label: str) -> str:
    delta = round(math.degrees(abs(program.rudder_rad)))
    if program.kind == "turning":
        return f"{delta}° {_side(program)} turn: {label}"
    psi = round(math.degrees(program.heading_rad))
    return f"{delta}/{psi} zig-zag ({_side(program)} first): {label}"


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
        overshoot [deg] of every zig-zag.

    """
    if [r.program.name for r in reference] != [p.program.name for p in predicted]:
        raise ValueError("reference and predicted runs must be the same programs in order")
    rows: list[ComparisonRow] = []
    for ref, pred in zip(reference, predicted, strict=True):
        quantities = (
            _TURNING_QUANTITIES if isinstance(ref.metrics, TurningMetrics) else _ZIGZAG_QUANTITIES
        )
        for key, label, unit in quantities:
            a = getattr(ref.metrics, key)
            b = getattr(pred.metrics, key)
            a = None if a is None else float(a)
            b = None if b is None else float(b)
            difference = None if a is None or b is None else b - a
            error = None if difference is None or a == 0.0 or a is None else 100.0 * difference / a
            rows.append(
                ComparisonRow(
                    maneuver=ref.program.name,
                    quantity=key,
                    label=_row_label(ref.program, label),
                    unit=unit,
                    reference=a,
                    predicted=b,
                    error_pct=error,
                    difference=difference,
                    interval=None if intervals is None else intervals.get((ref.program.name, key)),
                )
            )
    return rows


def uncertainty_bands(
    result: UncertaintyResult, rows: Sequence[ComparisonRow], *, source: str = ""
) -> UncertaintyBands:
    """95 % intervals of the rows' predicted values from a Monte-Carlo run.

    For each row the samples of its metric (``result.summary``; overshoots converted
    from radians to degrees) are moved by ``offset = predicted − m(θ̂)``, the
    difference between the validation run and the Monte-Carlo run at the identified
    coefficients, so that the interval sits where the validation put the prediction:
    ``lo = q₀.₀₂₅ + offset``, ``hi = q₀.₉₇₅ + offset``, ``mean = mean + offset``. When
    either value is missing the offset is 0.

    Parameters
    ----------
    result : scenarios.uncertainty.UncertaintyResult
        Monte-Carlo run of the rows' programs (same names).
    rows : sequence of ComparisonRow
        The comparison (``compare_runs``) whose predicted values locate the intervals.
    source : str, optional
        Where the coefficients come from, for the report.

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
        intervals[row.maneuver, row.quantity] = Interval(
            lo=scale * s.q025 + offset,
            hi=scale * s.q975 + offset,
            mean=scale * s.mean + offset,
            offset=offset,
            n_samples=s.n_samples,
            n_failed=s.n_failed,
        )
    return UncertaintyBands(
        intervals=intervals,
        n_samples=result.n_samples,
        seed=result.seed,
        dt_s=result.dt_s,
        source=source,
    )


def failing_rows(rows: Sequence[ComparisonRow], max_error_pct: float) -> list[ComparisonRow]:
    """Rows whose |error| exceeds ``max_error_pct``, or that have no error to judge [%]."""
    return [r for r in rows if r.error_pct is None or abs(r.error_pct) > max_error_pct]


# ----------------------------------------------------------------------------- text


def _number(value: float | None, digits: int) -> str:
    return "n/a" if value is None else f"{value:.{digits}f}"


def _criterion_cells(c: Criterion) -> tuple[str, str, str]:
    d = c.as_dict()
    if c.unit == "rad":
        return (
            f"{d['value_deg']:.2f} deg",
            f"{d['limit_deg']:.2f} deg",
            f"{d['margin_deg']:+.2f} deg",
        )
    if "value_L" in d:
        return (
            f"{d['value_m']:.1f} m ({d['value_L']:.2f} L)",
            f"{d['limit_m']:.1f} m ({d['limit_L']:.2f} L)",
            f"{d['margin_m']:+.1f} m ({d['margin_L']:+.2f} L)",
        )
    return f"{d['value_m']:.1f} m", f"{d['limit_m']:.1f} m", f"{d['margin_m']:+.1f} m"


def criteria_table(criteria: Sequence[Criterion]) -> tuple[list[str], list[list[str]]]:
    """Header and rows (criterion, value, limit, margin, pass/FAIL, reference) as text."""
    header = ["criterion", "value", "limit", "margin", "verdict", "ref."]
    rows = [
        [c.name, *_criterion_cells(c), "pass" if c.passed else "FAIL", c.reference]
        for c in criteria
    ]
    return header, rows


def _verdict(value: bool | None) -> str:
    return "n/a" if value is None else ("yes" if value else "no")


def comparison_table(rows: Sequence[ComparisonRow]) -> tuple[list[str], list[list[str]]]:
    """Header and rows (quantity, unit, reference, predicted, error %, difference) as text.

    When any row has an interval, two more columns: "95 % interval" (``lo … hi``) and
    "in interval" (``yes``/``no``: the reference inside it; ``n/a`` without one).
    """
    header = ["quantity", "unit", "reference", "predicted", "error %", "difference"]
    banded = any(r.interval is not None for r in rows)
    if banded:
        header += ["95 % interval", "in interval"]
    out = []
    for r in rows:
        digits = 1 if r.unit == "m" else 2
        cells = [
            r.label,
            r.unit,
            _number(r.reference, digits),
            _number(r.predicted, digits),
            "n/a" if r.error_pct is None else f"{r.error_pct:+.1f}",
            "n/a" if r.difference is None else f"{r.difference:+.{digits}f} {r.unit}",
        ]
        if banded:
            interval = r.interval
            cells += [
                f"{interval.lo:.{digits}f} … {interval.hi:.{digits}f}"
                if interval is not None and interval.is_finite
                else "n/a",
                _verdict(r.in_interval),
            ]
        out.append(cells)
    return header, out


def interval_counts(rows: Sequence[ComparisonRow]) -> tuple[int, int]:
    """Rows whose reference lies inside its interval, and rows with a verdict at all."""
    verdicts = [r.in_interval for r in rows if r.in_interval is not None]
    return sum(verdicts), len(verdicts)


def _is_numeric(cell: str) -> bool:
    return cell == "n/a" or (bool(cell) and (cell[0].isdigit() or cell[0] in "+-."))


def _right_aligned(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[bool]:
    """Right-align every column but the first whose cells all look numeric."""
    columns = list(zip(header, *rows, strict=True))
    return [
        i > 0 and bool(rows) and all(_is_numeric(x) for x in column[1:])
        for i, column in enumerate(columns)
    ]


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Plain-text table, columns padded to their widest cell, numbers right-aligned.

    The first column is left-aligned; any other column whose cells all look numeric
    (start with a digit, sign or point, or are "n/a") is right-aligned.
    """
    columns = list(zip(header, *rows, strict=True))
    widths = [max(len(x) for x in column) for column in columns]
    right = _right_aligned(header, rows)

    def line(cells: Sequence[str]) -> str:
        parts = [
            cell.rjust(width) if align else cell.ljust(width)
            for cell, width, align in zip(cells, widths, right, strict=True)
        ]
        return "  ".join(parts).rstrip()

    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, rows)])


def _markdown_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    def escape(cell: str) -> str:
        return cell.replace("|", "\\|")

    align = ["---:" if right else "---" for right in _right_aligned(header, rows)]
    lines = ["| " + " | ".join(map(escape, header)) + " |", "| " + " | ".join(align) + " |"]
    lines.extend("| " + " | ".join(map(escape, row)) + " |" for row in rows)
    return lines


def uncertainty_figure(validation: Validation) -> Figure:
    """Draw reference vs predicted with the 95 % intervals: lengths in L, overshoots in deg.

    Lengths are divided by the reference ship's length so that the turning indices of
    both ships share one axis; rows without an interval show the two points only.
    """
    v = validation
    length = v.reference_length_m

    def bar(r: ComparisonRow, scale: float) -> IntervalBar:
        lo = hi = None
        if r.interval is not None and r.interval.is_finite:
            lo, hi = r.interval.lo / scale, r.interval.hi / scale
        return (
            r.label,
            None if r.reference is None else r.reference / scale,
            None if r.predicted is None else r.predicted / scale,
            lo,
            hi,
        )

    panels = [
        (
            f"length / L [-] (L = {length:g} m, the reference's)",
            [bar(r, length) for r in v.rows if r.unit == "m"],
        ),
        ("overshoot [deg]", [bar(r, 1.0) for r in v.rows if r.unit == "deg"]),
    ]
    samples = "" if v.uncertainty is None else f" ({v.uncertainty.n_samples} samples)"
    return interval_figure(
        [panel for panel in panels if panel[1]],
        title=f"reference {v.reference_name} vs predicted {Path(v.fmu_path).name}\n"
        f"95 % intervals from the identified coefficients' covariance{samples}",
    )


def figure_names(validation: Validation) -> list[str]:
    """File names of the report's PNGs, in the order the report shows them."""
    names = []
    if any(r.program.kind == "turning" for r in validation.reference):
        names.append("turning-circles.png")
    names.extend(
        f"{r.program.name}.png" for r in validation.reference if r.program.kind == "zigzag"
    )
    if any(r.interval is not None for r in validation.rows):
        names.append("uncertainty.png")
    return names


def render_markdown(validation: Validation, max_error_pct: float | None = None) -> str:
    """Return the report.md text: condition, comparison, gate, IMO verdicts, figures."""
    v = validation
    c = v.condition
    lines = [
        f"# Validation of `{Path(v.fmu_path).name}` against {v.reference_name}",
        "",
        f"- predicted: FMU `{v.fmu_path}` (model `{v.model_name}`, L = {v.model_length_m:g} m)",
        f"- reference: {v.reference_description} (L = {v.reference_length_m:g} m)",
        f"- approach condition, both ships: U = {c.speed_mps:.4g} m/s, "
        f"n = {c.n_rps * 60.0:.4g} rpm, rudder rate {math.degrees(c.rudder_rate_radps):.3g} deg/s; "
        f"communication step {c.dt_s:g} s",
        "- metrics: ITTC/IMO definitions from the execute point (start of the rudder "
        "command), interpolated at the crossings",
        "",
    ]
    for warning in v.warnings:
        lines.append(f"> **Warning:** {warning}")
        lines.append("")
    lines += [
        "## Predicted vs reference",
        "",
        "Error = 100 (predicted − reference) / reference. For the overshoot angles the "
        "error is relative too (a small angle gives a large percentage), so their "
        "difference in degrees is given as well.",
        "",
    ]
    lines += _markdown_table(*comparison_table(v.rows))
    lines.append("")
    worst = v.max_abs_error_pct
    lines.append(f"Largest |error|: {_number(worst, 1)} %.")
    if max_error_pct is not None:
        failing = failing_rows(v.rows, max_error_pct)
        verdict = "PASS" if not failing else f"FAIL ({len(failing)} of {len(v.rows)} rows)"
        lines.append(f"Gate |error| ≤ {max_error_pct:g} %: **{verdict}**.")
    if v.uncertainty is not None:
        lines += ["", *_uncertainty_paragraph(v.uncertainty, v.rows)]
    lines += ["", "## IMO MSC.137(76) criteria, predicted model", ""]
    lines += _markdown_table(*criteria_table(v.criteria))
    lines += [
        "",
        f"Verdict: **{'all criteria pass' if v.imo_passed else 'FAIL'}** "
        f"({sum(c.passed for c in v.criteria)} of {len(v.criteria)} pass).",
        "",
        "The reference ship, for comparison:",
        "",
    ]
    lines += _markdown_table(*criteria_table(v.reference_criteria))
    lines += ["", "## Figures", ""]
    for name in figure_names(v):
        lines += [f"![{name[:-4]}]({name})", ""]
    return "\n".join(lines)


def _uncertainty_paragraph(bands: UncertaintyBands, rows: Sequence[ComparisonRow]) -> list[str]:
    """Markdown lines saying what the intervals are, what they cover and how they came out."""
    inside, judged = interval_counts(rows)
    source = f" in `{bands.source}`" if bands.source else ""
    lines = [
        f"The 95 % intervals are the 2.5 % and 97.5 % quantiles of {bands.n_samples} "
        f"Monte-Carlo samples of the identified coefficients, θ ~ N(θ̂, Σ) with the "
        f"covariance Σ{source} (seed {bands.seed}, step {bands.dt_s:g} s), each moved "
        "by the difference between the predicted value and the Monte-Carlo run at θ̂. "
        f"They cover the {UNCERTAINTY_SCOPE}: a reference value outside its interval "
        "is a difference the noise in the trials does not explain. "
        f"Reference inside the interval: {inside} of {judged} quantities.",
    ]
    failed = [r for r in rows if r.interval is not None and r.interval.n_failed]
    if failed:
        parts = [
            f"{r.label} ({r.interval.n_failed} of {r.interval.n_samples})"
            for r in failed
            if r.interval is not None
        ]
        lines += [
            "",
            "Samples without a value (diverged, or the run did not reach the event), "
            f"left out of the intervals: {'; '.join(parts)}.",
        ]
    return lines


def _finite_or_none(value: Any) -> Any:
    """Replace non-finite floats (not valid JSON) by None, recursively."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite_or_none(x) for k, x in value.items()}
    if isinstance(value, list | tuple):
        return [_finite_or_none(x) for x in value]
    return value


def _uncertainty_record(validation: Validation) -> dict[str, Any]:
    bands = validation.uncertainty
    assert bands is not None
    inside, judged = interval_counts(validation.rows)
    return {
        "n_samples": bands.n_samples,
        "seed": bands.seed,
        "dt_s": bands.dt_s,
        "source": bands.source,
        "scope": UNCERTAINTY_SCOPE,
        "n_in_interval": inside,
        "n_with_interval": judged,
    }


def validation_json(validation: Validation, max_error_pct: float | None = None) -> dict[str, Any]:
    """Return the ``validation.json`` document (format in the module docstring)."""
    v = validation
    gate = None
    if max_error_pct is not None:
        failing = failing_rows(v.rows, max_error_pct)
        gate = {
            "max_error_pct": max_error_pct,
            "passed": not failing,
            "failing": [r.label for r in failing],
        }
    doc = {
        "format": VALIDATION_FORMAT,
        "version": VALIDATION_VERSION,
        "fmu": v.fmu_path,
        "model": {"name": v.model_name, "length_m": v.model_length_m},
        "reference": {
            "name": v.reference_name,
            "description": v.reference_description,
            "length_m": v.reference_length_m,
        },
        "condition": v.condition.as_dict(),
        "comparison": [r.as_dict() for r in v.rows],
        "uncertainty": None if v.uncertainty is None else _uncertainty_record(v),
        "max_abs_error_pct": v.max_abs_error_pct,
        "gate": gate,
        "imo": {"passed": v.imo_passed, "criteria": [c.as_dict() for c in v.criteria]},
        "imo_reference": {
            "passed": all(c.passed for c in v.reference_criteria),
            "criteria": [c.as_dict() for c in v.reference_criteria],
        },
        "runs": {
            "reference": {
                r.program.name: r.metrics_dict(v.reference_length_m) for r in v.reference
            },
            "predicted": {r.program.name: r.metrics_dict(v.model_length_m) for r in v.predicted},
        },
        "warnings": list(v.warnings),
    }
    result: dict[str, Any] = _finite_or_none(doc)
    return result


def write_json(path: str | os.PathLike[str], document: Any) -> None:
    """Write ``document`` as indented JSON atomically (no NaN/Infinity)."""
    write_atomic(path, json.dumps(_finite_or_none(document), indent=2, allow_nan=False) + "\n")


def write_report(
    validation: Validation,
    directory: str | os.PathLike[str],
    *,
    max_error_pct: float | None = None,
) -> list[Path]:
    """Write the figures, ``validation.json`` and (last) ``report.md`` into ``directory``.

    Parameters
    ----------
    validation : Validation
        The runs to report.
    directory : path-like
        Report folder; created when missing. Every file is written atomically.
    max_error_pct : float, optional
        Error gate to state in the report and the JSON [%].

    Returns
    -------
    list of pathlib.Path
        The files written, ``report.md`` last.

    """
    v = validation
    out = Path(directory)
    fmu_name = Path(v.fmu_path).name
    written: list[Path] = []
    turns = [
        (_side(ref.program), [("reference", ref.trajectory), ("predicted", pred.trajectory)])
        for ref, pred in zip(v.reference, v.predicted, strict=True)
        if ref.program.kind == "turning"
    ]
    if turns:
        fig = trajectory_figure(
            turns,
            v.reference_length_m,
            title=f"35° turning circles: reference {v.reference_name} vs predicted {fmu_name}",
        )
        written.append(save_png(fig, out / "turning-circles.png"))
    for ref, pred in zip(v.reference, v.predicted, strict=True):
        if ref.program.kind != "zigzag":
            continue
        fig = zigzag_figure(
            [("reference", ref.trajectory), ("predicted", pred.trajectory)],
            title=f"{_row_label(ref.program, '')[:-2]}: reference {v.reference_name} vs "
            f"predicted {fmu_name}",
        )
        written.append(save_png(fig, out / f"{ref.program.name}.png"))
    if any(r.interval is not None for r in v.rows):
        written.append(save_png(uncertainty_figure(v), out / "uncertainty.png"))
    write_json(out / "validation.json", validation_json(v, max_error_pct))
    written.append(out / "validation.json")
    write_atomic(out / "report.md", render_markdown(v, max_error_pct) + "\n")
    written.append(out / "report.md")
    return written
