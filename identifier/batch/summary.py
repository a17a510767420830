"""The results of a batch: one row per vessel, and the summary tables.

:class:`VesselResult` (a vessel's outcome) and :class:`BatchSummary` (all of them),
written as ``OUT/summary.csv`` and ``OUT/summary.md`` by :func:`write_summary`.
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from fmu_model.atomic import write_atomic

__all__ = [
    "SUMMARY_COLUMNS",
    "BatchSummary",
    "VesselResult",
    "format_failures",
    "summary_csv",
    "summary_markdown",
    "write_summary",
]

SUMMARY_COLUMNS = (
    "vessel",
    "status",
    "n_logs",
    "n_samples",
    "model",
    "position_rms_m",
    "heading_rms_deg",
    "not_identifiable",
    "n_coefficients",
    "seconds",
    "error",
)
"""Columns of ``summary.csv``, in order."""


@dataclass(frozen=True)
class VesselResult:
    """Outcome of one vessel (a row of the summary).

    Parameters
    ----------
    name : str
        Vessel name.
    status : {"ok", "skipped", "failed"}
        Identified in this run, up to date from an earlier run, or failed.
    n_logs, n_samples : int
        Number of trial logs and of samples in them (samples 0 when a log was unreadable).
    model : str
        Model structure or family fitted (a fallback of the one asked for, e.g. the
        thrust refit ``…-thrust``; the one asked for when failed).
    position_rms_m : float
        RMS distance between the EKF's filtered position and the logged one [m] (NaN
        when failed).
    heading_rms_deg : float
        RMS difference between the filtered and the logged heading [deg] (NaN when failed).
    not_identifiable : tuple of str
        Coefficients the logs do not determine.
    n_coefficients : int
        Number of coefficients of the model.
    seconds : float
        Wall time of the vessel's task (identification and FMU) [s]; for a skipped
        vessel, of the run that produced it.
    error : str, optional
        One-line reason of a failure.
    directory : pathlib.Path
        ``OUT/<vessel>``.

    """

    name: str
    status: str
    n_logs: int
    n_samples: int
    model: str
    position_rms_m: float
    heading_rms_deg: float
    not_identifiable: tuple[str, ...]
    n_coefficients: int
    seconds: float
    error: str | None
    directory: Path

    @property
    def ok(self) -> bool:
        """True unless the vessel failed."""
        return self.status != "failed"


@dataclass(frozen=True)
class BatchSummary:
    """Outcome of :func:`~identifier.batch.run_batch`: one :class:`VesselResult` a vessel.

    In the order of the input; ``seconds`` is the wall time of the whole batch [s].
    """

    vessels: tuple[VesselResult, ...]
    out_dir: Path
    seconds: float

    @property
    def failed(self) -> tuple[VesselResult, ...]:
        """The vessels that failed."""
        return tuple(v for v in self.vessels if v.status == "failed")

    @property
    def n_identified(self) -> int:
        """Number of vessels identified in this run (not skipped)."""
        return sum(v.status == "ok" for v in self.vessels)

    @property
    def ok(self) -> bool:
        """True when every vessel succeeded (in this run or an earlier one)."""
        return not self.failed


def _row(v: VesselResult) -> dict[str, str]:
    def number(value: float, digits: int) -> str:
        return "" if math.isnan(value) else f"{value:.{digits}f}"

    return {
        "vessel": v.name,
        "status": v.status,
        "n_logs": str(v.n_logs),
        "n_samples": str(v.n_samples),
        "model": v.model,
        "position_rms_m": number(v.position_rms_m, 3),
        "heading_rms_deg": number(v.heading_rms_deg, 4),
        "not_identifiable": "" if v.status == "failed" else str(len(v.not_identifiable)),
        "n_coefficients": str(v.n_coefficients),
        "seconds": number(v.seconds, 2),
        "error": v.error or "",
    }


def summary_csv(summary: BatchSummary) -> str:
    """Return the summary table as CSV text (columns :data:`SUMMARY_COLUMNS`)."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=SUMMARY_COLUMNS, lineterminator="\n")
    writer.writeheader()
    writer.writerows(_row(v) for v in summary.vessels)
    return buffer.getvalue()


def summary_markdown(summary: BatchSummary) -> str:
    """Return the summary as a markdown table with a one-line total and the failures."""
    headers = (
        "vessel",
        "status",
        "logs",
        "samples",
        "model",
        "position RMS [m]",
        "heading RMS [deg]",
        "not identifiable",
        "seconds",
    )
    lines = [
        "# Batch identification",
        "",
        "| " + " | ".join(headers) + " |",
        "|" + "|".join("---" for _ in headers) + "|",
    ]
    for v in summary.vessels:
        row = _row(v)
        weak = "" if v.status == "failed" else f"{row['not_identifiable']} of {v.n_coefficients}"
        cells = (
            v.name,
            v.status,
            row["n_logs"],
            row["n_samples"],
            v.model,
            row["position_rms_m"],
            row["heading_rms_deg"],
            weak,
            row["seconds"],
        )
        lines.append("| " + " | ".join(cells) + " |")
    n_ok = len(summary.vessels) - len(summary.failed)
    lines += [
        "",
        f"{n_ok} of {len(summary.vessels)} vessels succeeded "
        f"({summary.n_identified} identified in this run), {summary.seconds:.1f} s.",
    ]
    if summary.failed:
        lines += ["", "## Failures", ""]
        lines += [f"- **{v.name}**: {v.error}" for v in summary.failed]
    return "\n".join(lines) + "\n"


def write_summary(summary: BatchSummary) -> tuple[Path, Path]:
    """Write ``summary.csv`` and ``summary.md`` in the output directory (atomically)."""
    csv_path = summary.out_dir / "summary.csv"
    md_path = summary.out_dir / "summary.md"
    write_atomic(csv_path, summary_csv(summary))
    write_atomic(md_path, summary_markdown(summary))
    return csv_path, md_path


def format_failures(summary: BatchSummary) -> Sequence[str]:
    """One line per failed vessel, ``<vessel>: <reason>``, for the CLI's stderr."""
    return [f"{v.name}: {v.error}" for v in summary.failed]
