"""The validation report: comparison and criteria tables, markdown, JSON, PNGs.

From a :class:`scenarios.records.Validation` (the standard manoeuvres run on a
reference ship and on a predicted model at the same approach condition, with its
comparison rows in the manner of Shi et al. (2009), Table 2) this module makes the
text tables, states the error gate (``scenarios.records.failing_rows``), and writes the
report directory::

    report.md            the tables, the IMO verdicts, the figures
    validation.json      the same numbers, for machines (format below)
    turning-circles.png  35° turns, starboard and port, reference vs predicted (in L)
    <zigzag>.png         heading, rudder and speed time histories per zig-zag
    uncertainty.png      reference vs predicted with the 95 % intervals (with uncertainty)

The error of a quantity is ``100 (predicted − reference) / reference`` [%], for the
overshoot angles too, so angles also carry the plain difference [deg].

With uncertainty bands (``Validation.uncertainty``) every predicted quantity also
carries a 95 % interval from a Monte-Carlo run over the identified coefficients'
covariance (``scenarios.uncertainty.monte_carlo.monte_carlo_metrics``), located at the
predicted value by ``scenarios.validation.uncertainty_bands``:

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
                                  "n_failed", "model_form"} | null,
                     "in_interval": bool | null}, ...],
     "uncertainty": {"n_samples", "seed", "dt_s", "source", "scope",
                     "n_in_interval", "n_with_interval"} | null,
     "max_abs_error_pct": float | null,
     "gate": {"max_error_pct", "passed", "failing": [label, ...]} | null,
     "imo": {"passed": bool, "criteria": [Criterion.as_dict(), ...]},
     "imo_reference": {...same for the reference ship...},
     "runs": {"reference": {maneuver: metrics}, "predicted": {maneuver: metrics}},
     "warnings": [str, ...],
     "extrapolation": {"envelope": {"rudder_max_rad": {"port", "starboard"},
                                    "yaw_rate_max": {"port", "starboard"},
                                    "speed_ratio_min",
                                    "approach_speed_mps": {"low", "high"},
                                    "propeller_rate_rps": {"low", "high"}},
                       "beyond": {maneuver: [reason, ...]},
                       "n_in_interval_within", "n_with_interval_within"} | null,
     "environment": {"current_mps", "current_to_deg", "wind_mps", "wind_from_deg"}}

``extrapolation`` when the envelope of the identification's logs is known (params
given, ``fmu_model.envelope``): per predicted manoeuvre how it leaves that envelope (an
empty list: it stays inside), and the interval counts of the manoeuvres inside it
(null without intervals).

``environment`` only at sea; its turning runs then carry ``current_corrected``
(``scenarios.records.ManeuverRun.metrics_dict``: the corrected indices, the drift and
which indices IMO 5.3.1 judged, ``imo_basis``, ``imo_reason``), and a comparison row of
corrected turns says so in its label. Without an environment the document is the calm
water one, unchanged.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from fmu_model.atomic import write_atomic
from scenarios.imo import Criterion
from scenarios.plots import (
    IntervalBar,
    interval_figure,
    save_png,
    trajectory_figure,
    zigzag_figure,
)
from scenarios.records import (
    ComparisonRow,
    ManeuverRun,
    UncertaintyBands,
    Validation,
    environment_record,
    failing_rows,
    interval_counts,
    maneuver_label,
    turn_side,
)
from scenarios.sea import SeaEnvironment
from trials.current_correction import REFERENCE as CURRENT_CORRECTION_REFERENCE

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from fmu_model.envelope import Envelope

__all__ = [
    "VALIDATION_FORMAT",
    "VALIDATION_VERSION",
    "comparison_table",
    "criteria_table",
    "extrapolation_lines",
    "extrapolation_record",
    "figure_names",
    "format_table",
    "render_markdown",
    "sea_lines",
    "uncertainty_figure",
    "uncertainty_scope",
    "validation_json",
    "within_envelope",
    "write_json",
    "write_report",
]

VALIDATION_FORMAT = "ship-maneuvering-validation"
VALIDATION_VERSION = 1


def uncertainty_scope(bands: UncertaintyBands) -> str:
    """Say what the 95 % intervals cover, for the report and ``validation.json``."""
    identification = (
        "coefficient uncertainty from identification (the measurement noise of the trial logs)"
    )
    if any(i.model_form > 0.0 for i in bands.intervals.values()):
        return (
            f"{identification} and model form: the spread of the predictions of the fit's "
            "alternative estimates (equation error, EKF, output error), added in quadrature"
        )
    return f"{identification} only, not model-structure error"


# ----------------------------------------------------------------------------- text


def sea_lines(
    environment: SeaEnvironment, sides: Sequence[tuple[str, Sequence[ManeuverRun], float]]
) -> list[str]:
    """Say where the runs sailed and which values IMO judged (plain text, one item a line).

    Parameters
    ----------
    environment : SeaEnvironment
        The current and wind.
    sides : sequence of (str, sequence of ManeuverRun, float)
        Who sailed (``"reference"``, ``"predicted"``; ``""`` for a single ship), their
        runs and their ship length [m].

    Returns
    -------
    list of str
        The environment; per turning run sailed at sea the values IMO 5.3.1 judged
        (raw or current-corrected) and why; what the other criteria judged.

    """
    who = "both ships" if len(sides) > 1 else "the ship"
    lines = [
        f"at sea, {who}: {environment.describe()}",
        f"35 deg turns continued to 720 deg; {CURRENT_CORRECTION_REFERENCE} correction "
        "where the drift exceeds 1 % of the approach speed:",
    ]
    for name, runs, length_m in sides:
        for run in runs:
            judgement = run.judgement(length_m)
            if judgement is not None:
                label = f"{name} {run.program.name}".strip()
                lines.append(f"  {label}: {judgement.basis} values ({judgement.reason})")
    lines.append(
        "zig-zag overshoots and the initial turning distance (over ground): raw, as sailed"
    )
    return lines


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


def comparison_table(
    rows: Sequence[ComparisonRow], extrapolation: Mapping[str, Sequence[str]] | None = None
) -> tuple[list[str], list[list[str]]]:
    """Header and rows (quantity, unit, reference, predicted, error %, difference) as text.

    When any row has an interval, two more columns: "95 % interval" (``lo … hi``) and
    "in interval" (``yes``/``no``: the reference inside it; ``n/a`` without one). With
    ``extrapolation`` (``Validation.extrapolation``) a last column "beyond the logs":
    ``yes`` for the rows of a manoeuvre that leaves the logs' envelope.
    """
    header = ["quantity", "unit", "reference", "predicted", "error %", "difference"]
    banded = any(r.interval is not None for r in rows)
    if banded:
        header += ["95 % interval", "in interval"]
    if extrapolation is not None:
        header.append("beyond the logs")
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
        if extrapolation is not None:
            cells.append(_verdict(bool(extrapolation.get(r.maneuver))))
        out.append(cells)
    return header, out


def extrapolation_lines(
    envelope: Envelope | None, beyond: Mapping[str, Sequence[str]] | None
) -> list[str]:
    """Say what the identification's logs reached and which runs go beyond it.

    ``beyond``: per run, how it leaves the ``envelope`` (``records.beyond_logs``). Plain
    text, one item a line (the runs beyond as ``- name: reasons``); empty when either is
    not known.
    """
    if envelope is None or beyond is None:
        return []
    reached = f"The identification's logs reach: {envelope.describe()}."
    if not any(beyond.values()):
        return [f"{reached} Every predicted manoeuvre stays within them."]
    return [
        f"{reached} These predictions go beyond them: the model structure extrapolates "
        "there, and no interval carries the error of that:",
        *(f"- {name}: {'; '.join(reasons)}" for name, reasons in beyond.items() if reasons),
    ]


def within_envelope(validation: Validation) -> list[ComparisonRow]:
    """Return the comparison rows of the manoeuvres inside the logs' envelope (all if unknown)."""
    beyond = validation.extrapolation or {}
    return [r for r in validation.rows if not beyond.get(r.maneuver)]


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
    ]
    if v.environment is not None:
        sea = sea_lines(
            v.environment,
            [
                ("reference", v.reference, v.reference_length_m),
                ("predicted", v.predicted, v.model_length_m),
            ],
        )
        lines.append(
            f"- {sea[0]} (the FMU through its environment inputs, the reference through its "
            "own equations and windage)"
        )
        lines.append(f"- {sea[1]}")
        lines += [f"  - {line.strip()}" for line in sea[2:-1]]
        lines.append(f"- {sea[-1]}")
        lines.append(
            "- a turn is compared on the current-corrected indices when either ship's "
            "correction counts (its label says so), else on the raw ones"
        )
    lines.append("")
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
    lines += _markdown_table(*comparison_table(v.rows, v.extrapolation))
    lines.append("")
    worst = v.max_abs_error_pct
    lines.append(f"Largest |error|: {_number(worst, 1)} %.")
    if max_error_pct is not None:
        failing = failing_rows(v.rows, max_error_pct)
        verdict = "PASS" if not failing else f"FAIL ({len(failing)} of {len(v.rows)} rows)"
        lines.append(f"Gate |error| ≤ {max_error_pct:g} %: **{verdict}**.")
    extrapolation = extrapolation_lines(v.envelope, v.extrapolation)
    if extrapolation:
        lines += ["", *extrapolation]
    if v.uncertainty is not None:
        lines += ["", *_uncertainty_paragraph(v)]
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


def _uncertainty_paragraph(validation: Validation) -> list[str]:
    """Markdown lines saying what the intervals are, what they cover and how they came out."""
    bands, rows = validation.uncertainty, validation.rows
    assert bands is not None
    inside, judged = interval_counts(rows)
    source = f" in `{bands.source}`" if bands.source else ""
    lines = [
        f"The 95 % intervals are the 2.5 % and 97.5 % quantiles of {bands.n_samples} "
        f"Monte-Carlo samples of the identified coefficients, θ ~ N(θ̂, Σ) with the "
        f"covariance Σ{source} (seed {bands.seed}, step {bands.dt_s:g} s), each moved "
        "by the difference between the predicted value and the Monte-Carlo run at θ̂. "
        f"They cover the {uncertainty_scope(bands)}: a reference value outside its interval "
        "is a difference the noise in the trials does not explain. "
        f"Reference inside the interval: {inside} of {judged} quantities"
        + _within_counts(validation)
        + ".",
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
            "Samples without a value (diverged, the run did not reach the event, or the "
            "turn fell back against its rudder), "
            f"left out of the intervals: {'; '.join(parts)}.",
        ]
    return lines


def _within_counts(validation: Validation) -> str:
    """Return the interval count of the manoeuvres within the envelope, when some are not."""
    if not any((validation.extrapolation or {}).values()):
        return ""
    inside, judged = interval_counts(within_envelope(validation))
    return f"; of the manoeuvres within the logs' envelope: {inside} of {judged}"


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
        "scope": uncertainty_scope(bands),
        "n_in_interval": inside,
        "n_with_interval": judged,
    }


def extrapolation_record(
    envelope: Envelope | None, beyond: Mapping[str, Sequence[str]] | None
) -> dict[str, Any] | None:
    """Return the JSON record of :func:`extrapolation_lines`' content; None when unknown."""
    if envelope is None or beyond is None:
        return None
    return {
        "envelope": envelope.as_dict(),
        "beyond": {name: list(reasons) for name, reasons in beyond.items()},
    }


def _extrapolation_record(validation: Validation) -> dict[str, Any] | None:
    record = extrapolation_record(validation.envelope, validation.extrapolation)
    if record is None:
        return None
    inside, judged = interval_counts(within_envelope(validation))
    banded = validation.uncertainty is not None
    record["n_in_interval_within"] = inside if banded else None
    record["n_with_interval_within"] = judged if banded else None
    return record


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
        "extrapolation": _extrapolation_record(v),
    }
    if v.environment is not None:
        doc["environment"] = environment_record(v.environment)
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
        (turn_side(ref.program), [("reference", ref.trajectory), ("predicted", pred.trajectory)])
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
            title=f"{maneuver_label(ref.program)}: reference {v.reference_name} vs "
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
