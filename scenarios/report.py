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

The error of a quantity is ``100 (predicted − reference) / reference`` [%], for the
overshoot angles too (a relative error of a small angle is large: a 5° overshoot
predicted as 5.5° is a 10 % error), so angles also carry the plain difference [deg].

``validation.json``::

    {"format": "ship-maneuvering-validation", "version": 1,
     "fmu": path, "reference": {"name", "description", "length_m"},
     "model": {"name", "length_m"},
     "condition": {"speed_mps", "rpm", "rudder_rate_deg_s", "dt_s"},
     "comparison": [{"maneuver", "quantity", "label", "unit", "reference",
                     "predicted", "error_pct", "difference"}, ...],
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
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from fmu_model.atomic import write_atomic
from scenarios.imo import Criterion
from scenarios.maneuvers import Program
from scenarios.metrics import TurningMetrics, ZigzagMetrics
from scenarios.plots import save_png, trajectory_figure, zigzag_figure

__all__ = [
    "VALIDATION_FORMAT",
    "VALIDATION_VERSION",
    "ComparisonRow",
    "Condition",
    "ManeuverRun",
    "Validation",
    "compare_runs",
    "comparison_table",
    "criteria_table",
    "failing_rows",
    "figure_names",
    "format_table",
    "render_markdown",
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

    """

    maneuver: str
    quantity: str
    label: str
    unit: str
    reference: float | None
    predicted: float | None
    error_pct: float | None
    difference: float | None

    def as_dict(self) -> dict[str, Any]:
        """JSON record with the attribute names as keys."""
        return {
            "maneuver": self.maneuver,
            "quantity": self.quantity,
            "label": self.label,
            "unit": self.unit,
            "reference": self.reference,
            "predicted": self.predicted,
            "error_pct": self.error_pct,
            "difference": self.difference,
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
    rows: tuple[ComparisonRow, ...] = field(init=False)

    def __post_init__(self) -> None:
        object.__setattr__(self, "rows", tuple(compare_runs(self.reference, self.predicted)))

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
    reference: Sequence[ManeuverRun], predicted: Sequence[ManeuverRun]
) -> list[ComparisonRow]:
    """Compare turning indices and zig-zag overshoots, reference vs predicted.

    Parameters
    ----------
    reference, predicted : sequence of ManeuverRun
        Runs of the same programs in the same order.

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
                )
            )
    return rows


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


def comparison_table(rows: Sequence[ComparisonRow]) -> tuple[list[str], list[list[str]]]:
    """Header and rows (quantity, unit, reference, predicted, error %, difference) as text."""
    header = ["quantity", "unit", "reference", "predicted", "error %", "difference"]
    out = []
    for r in rows:
        digits = 1 if r.unit == "m" else 2
        out.append(
            [
                r.label,
                r.unit,
                _number(r.reference, digits),
                _number(r.predicted, digits),
                "n/a" if r.error_pct is None else f"{r.error_pct:+.1f}",
                "n/a" if r.difference is None else f"{r.difference:+.{digits}f} {r.unit}",
            ]
        )
    return header, out


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


def figure_names(validation: Validation) -> list[str]:
    """File names of the report's PNGs, in the order the report shows them."""
    names = []
    if any(r.program.kind == "turning" for r in validation.reference):
        names.append("turning-circles.png")
    names.extend(
        f"{r.program.name}.png" for r in validation.reference if r.program.kind == "zigzag"
    )
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


def _finite_or_none(value: Any) -> Any:
    """Replace non-finite floats (not valid JSON) by None, recursively."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite_or_none(x) for k, x in value.items()}
    if isinstance(value, list | tuple):
        return [_finite_or_none(x) for x in value]
    return value


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
    write_json(out / "validation.json", validation_json(v, max_error_pct))
    written.append(out / "validation.json")
    write_atomic(out / "report.md", render_markdown(v, max_error_pct) + "\n")
    written.append(out / "report.md")
    return written
