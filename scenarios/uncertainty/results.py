"""Result records of a Monte-Carlo run: per-metric statistics, per-program samples, the whole.

Metric values are SI (metres, radians) inside; the JSON record and the markdown table
show angles in degrees.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from scenarios.records import Condition
from trials.maneuvers import Program

__all__ = [
    "METRICS",
    "STATUS_DIVERGED",
    "STATUS_INCOMPLETE",
    "STATUS_OK",
    "MetricSummary",
    "ProgramUncertainty",
    "UncertaintyResult",
]

STATUS_OK = 0
"""Sample simulated and all of its program's mandatory metrics computed."""
STATUS_DIVERGED = 1
"""The ship diverged (non-finite state or outside the physical envelope)."""
STATUS_INCOMPLETE = 2
"""The run did not cover the metric's event (90°/180°, check heading, turn side), or the
turn fell back against its rudder (``trials.metrics.TURN_BACK_TOLERANCE_RAD``)."""

METRICS: Mapping[str, tuple[str, ...]] = {
    "turning": ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"),
    "zigzag": ("first_overshoot_rad", "second_overshoot_rad"),
}
"""Metrics per program kind, SI names; ``steady_diameter_m`` needs 540° of turn."""


def _display(metric: str) -> tuple[str, float, str]:
    """Display key, scale factor from SI and unit of a metric (radians shown in degrees)."""
    if metric.endswith("_rad"):
        return metric[: -len("_rad")] + "_deg", math.degrees(1.0), "deg"
    return metric, 1.0, metric.rsplit("_", 1)[-1]


def _finite_or_none(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


@dataclass(frozen=True)
class MetricSummary:
    """Monte-Carlo statistics of one metric of one program.

    Attributes
    ----------
    program : str
        Program name, e.g. ``"turning-35-stbd"``.
    metric : str
        Metric name with its SI unit, e.g. ``"advance_m"``, ``"first_overshoot_rad"``.
    nominal : float
        Value at the identified coefficients θ̂; NaN when that run failed [SI].
    mean, std : float
        Sample mean and standard deviation (ddof = 1) of the successful samples;
        NaN when fewer than one (two for ``std``) succeeded [SI].
    q025, q975 : float
        2.5 % and 97.5 % sample quantiles (linear interpolation), the 95 % interval;
        NaN when no sample succeeded [SI].
    n_samples : int
        Samples drawn.
    n_failed : int
        Samples without a value for this metric (diverged, incomplete, or the run
        did not cover this metric's event).

    """

    program: str
    metric: str
    nominal: float
    mean: float
    std: float
    q025: float
    q975: float
    n_samples: int
    n_failed: int

    @property
    def n_valid(self) -> int:
        """Samples with a value."""
        return self.n_samples - self.n_failed

    def contains(self, value: float) -> bool:
        """Whether ``value`` [SI] lies inside the 95 % interval [q025, q975]."""
        return bool(self.q025 <= value <= self.q975)

    def as_dict(self) -> dict[str, Any]:
        """JSON record in display units (degrees for angles); NaN becomes None."""
        _, scale, unit = _display(self.metric)
        return {
            "unit": unit,
            "nominal": _finite_or_none(scale * self.nominal),
            "mean": _finite_or_none(scale * self.mean),
            "std": _finite_or_none(scale * self.std),
            "q025": _finite_or_none(scale * self.q025),
            "q975": _finite_or_none(scale * self.q975),
            "n_valid": self.n_valid,
            "n_failed": self.n_failed,
        }


@dataclass(frozen=True, eq=False)
class ProgramUncertainty:
    """All samples of one program.

    Attributes
    ----------
    program : Program
        The manoeuvre.
    metrics : tuple of str
        Metric names (SI), the columns of ``values``.
    values : numpy.ndarray
        (n_samples, n_metrics) metric values, NaN where a sample has none [SI];
        read-only.
    status : numpy.ndarray
        (n_samples,) ``STATUS_OK``, ``STATUS_DIVERGED`` or ``STATUS_INCOMPLETE``.
    nominal : numpy.ndarray
        (n_metrics,) values at θ̂, NaN where missing [SI].
    nominal_status : int
        Status of the nominal run.

    """

    program: Program
    metrics: tuple[str, ...]
    values: np.ndarray
    status: np.ndarray
    nominal: np.ndarray
    nominal_status: int

    def __post_init__(self) -> None:
        for name in ("values", "status", "nominal"):
            array = np.array(getattr(self, name))
            array.setflags(write=False)
            object.__setattr__(self, name, array)

    @property
    def n_diverged(self) -> int:
        """Samples whose ship diverged."""
        return int(np.count_nonzero(self.status == STATUS_DIVERGED))

    @property
    def n_incomplete(self) -> int:
        """Samples whose run did not cover the program's mandatory metrics."""
        return int(np.count_nonzero(self.status == STATUS_INCOMPLETE))

    def summary(self, metric: str) -> MetricSummary:
        """Statistics of one metric (name as in ``metrics``)."""
        j = self.metrics.index(metric)
        column = self.values[:, j]
        valid = column[np.isfinite(column)]
        n = valid.size
        q025, q975 = np.quantile(valid, (0.025, 0.975)) if n else (math.nan, math.nan)
        return MetricSummary(
            program=self.program.name,
            metric=metric,
            nominal=float(self.nominal[j]),
            mean=float(valid.mean()) if n else math.nan,
            std=float(valid.std(ddof=1)) if n > 1 else math.nan,
            q025=float(q025),
            q975=float(q975),
            n_samples=int(column.size),
            n_failed=int(column.size - n),
        )

    def summaries(self) -> tuple[MetricSummary, ...]:
        """Statistics of every metric, in ``metrics`` order."""
        return tuple(self.summary(m) for m in self.metrics)


@dataclass(frozen=True, eq=False)
class UncertaintyResult:
    """Outcome of :func:`scenarios.uncertainty.monte_carlo.monte_carlo_metrics`.

    Attributes
    ----------
    params : ModelParameters
        The identified model (θ̂, Σ).
    programs : tuple of ProgramUncertainty
        One per program, in the order given.
    coefficient_samples : numpy.ndarray
        (n_samples, p) the drawn coefficient sets; read-only.
    seed : int
        Seed of the draw.
    jitter : float
        Diagonal jitter added to the correlation matrix before its Cholesky
        factorisation (0 when it was positive definite) [-].
    speed_mps : float
        Approach speed [m/s].
    n_rps : float
        Propeller speed [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    dt_s : float
        Communication step [s].
    chunk_size : int
        Samples per task.

    """

    params: ModelParameters
    programs: tuple[ProgramUncertainty, ...]
    coefficient_samples: np.ndarray
    seed: int
    jitter: float
    speed_mps: float
    n_rps: float
    rudder_rate_radps: float
    dt_s: float
    chunk_size: int

    def __post_init__(self) -> None:
        samples = np.array(self.coefficient_samples, dtype=float)
        samples.setflags(write=False)
        object.__setattr__(self, "coefficient_samples", samples)

    @property
    def n_samples(self) -> int:
        """Samples drawn."""
        return int(self.coefficient_samples.shape[0])

    @property
    def condition(self) -> Condition:
        """Approach condition and step of every run."""
        return Condition(self.speed_mps, self.n_rps, self.rudder_rate_radps, self.dt_s)

    def program(self, name: str) -> ProgramUncertainty:
        """Return the samples of the program called ``name``."""
        for entry in self.programs:
            if entry.program.name == name:
                return entry
        known = ", ".join(p.program.name for p in self.programs)
        raise KeyError(f"no program {name!r} (known: {known})")

    def summary(self, program: str, metric: str) -> MetricSummary:
        """Statistics of ``metric`` (SI name) in ``program``."""
        return self.program(program).summary(metric)

    def as_dict(self, *, include_samples: bool = False) -> dict[str, Any]:
        """Return a JSON-ready record (display units: m, deg, rpm; NaN as None).

        Parameters
        ----------
        include_samples : bool
            Also list every sample's metric values (``"samples"`` per program).

        """
        programs: dict[str, Any] = {}
        for entry in self.programs:
            record: dict[str, Any] = {
                "kind": entry.program.kind,
                "n_samples": int(entry.status.size),
                "n_diverged": entry.n_diverged,
                "n_incomplete": entry.n_incomplete,
                "metrics": {_display(s.metric)[0]: s.as_dict() for s in entry.summaries()},
            }
            if include_samples:
                scales = np.array([_display(m)[1] for m in entry.metrics])
                record["samples"] = [
                    [_finite_or_none(v) for v in row] for row in entry.values * scales
                ]
            programs[entry.program.name] = record
        return {
            "format": "ship-maneuvering-uncertainty",
            "version": 1,
            "vessel": {"name": self.params.vessel_name, "length_m": self.params.length_m},
            "model": self.params.model,
            "condition": self.condition.as_dict(),
            "sampling": {
                "n_samples": self.n_samples,
                "seed": self.seed,
                "jitter": self.jitter,
                "chunk_size": self.chunk_size,
                "distribution": "multivariate normal N(theta_hat, covariance)",
            },
            "programs": programs,
        }

    def summary_table(self) -> str:
        """Markdown table: metric, nominal, mean, std, 95 % interval, failed samples."""
        lines = [
            "| manoeuvre | metric | nominal | mean | std | 95 % interval | failed |",
            "|---|---|---:|---:|---:|---|---:|",
        ]

        def fmt(value: float) -> str:
            return "–" if not math.isfinite(value) else f"{value:.4g}"

        for entry in self.programs:
            for s in entry.summaries():
                key, scale, unit = _display(s.metric)
                label = key[: -len(unit) - 1].replace("_", " ")
                interval = (
                    "–"
                    if not math.isfinite(s.q025)
                    else f"{fmt(scale * s.q025)} … {fmt(scale * s.q975)}"
                )
                lines.append(
                    f"| {s.program} | {label} [{unit}] | {fmt(scale * s.nominal)} | "
                    f"{fmt(scale * s.mean)} | {fmt(scale * s.std)} | {interval} | "
                    f"{s.n_failed}/{s.n_samples} |"
                )
        return "\n".join(lines) + "\n"
