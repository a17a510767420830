"""Monte-Carlo uncertainty of manoeuvre metrics from the identified coefficient covariance.

An identification returns θ̂ and its covariance Σ (params.json). This module draws
coefficient sets θ ~ N(θ̂, Σ), drives every sample through the manoeuvre programs
(turning circles, zig-zags) and summarises each metric by its value at θ̂, the mean,
the standard deviation and the 2.5 % and 97.5 % quantiles of the samples:

    θ_i = θ̂ + S z_i,   z_i ~ N(0, I),   S Sᵀ = Σ   (i = 1 … N),

with S from a Cholesky factorisation of the correlation matrix of the coefficients that
have a positive variance (a small jitter on its diagonal when it is only
semi-definite); coefficients with zero variance stay exactly at θ̂.

The samples are simulated in chunks: each chunk is one task on a ``dask.distributed``
cluster (a ``LocalCluster`` made for the call by default), and inside a task the
chunk's ships advance together, one vectorised RK4 step for all of them
(``fmu_model.simulate.rk4_step`` broadcasts over a trailing sample dimension). The
step driver follows ``scenarios.run.run_program`` line by line: steering gear at a
constant rate, legs ended by time or by the heading change since execute evaluated
after each communication step, so every zig-zag sample reverses its rudder at its own
times. The trajectories go to the usual ``scenarios.metrics`` functions.

A sample *fails* for a program when its ship diverges (non-finite state, speed over
ground above ``divergence_factor`` × U or yaw rate above ``divergence_factor`` × U/L)
or when the metrics cannot be computed (the heading does not reach 90°/180° or the
check heading, or the ship turns against its rudder). Failed samples are counted and
reported, never raised; the statistics are over the remaining samples.
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from fmu_model import ModelParameters, argtypes, numeric_model, rk4_step
from scenarios.maneuvers import DEFAULT_RUDDER_RATE_DEG_S, Program, standard_set
from scenarios.metrics import MetricsError, turning_metrics, zigzag_metrics
from scenarios.trajectory import empty_trajectory

if TYPE_CHECKING:
    from distributed import Client

__all__ = [
    "DEFAULT_RUDDER_RATE_RADPS",
    "METRICS",
    "STATUS_DIVERGED",
    "STATUS_INCOMPLETE",
    "STATUS_OK",
    "MetricSummary",
    "ProgramUncertainty",
    "UncertaintyError",
    "UncertaintyResult",
    "add_uncertainty_command",
    "draw_coefficients",
    "monte_carlo_metrics",
    "run_uncertainty_command",
    "simulate_batch",
]

DEFAULT_RUDDER_RATE_RADPS = math.radians(DEFAULT_RUDDER_RATE_DEG_S)
"""Default steering-gear rate [rad/s] (``scenarios.maneuvers.DEFAULT_RUDDER_RATE_DEG_S``)."""

STATUS_OK = 0
"""Sample simulated and all of its program's mandatory metrics computed."""
STATUS_DIVERGED = 1
"""The ship diverged (non-finite state or outside the physical envelope)."""
STATUS_INCOMPLETE = 2
"""The run did not cover the metric's event (90°/180°, check heading, turn side)."""

METRICS: Mapping[str, tuple[str, ...]] = {
    "turning": ("advance_m", "transfer_m", "tactical_diameter_m", "steady_diameter_m"),
    "zigzag": ("first_overshoot_rad", "second_overshoot_rad"),
}
"""Metrics per program kind, SI names; ``steady_diameter_m`` needs 540° of turn."""

_JITTER_START = 1e-12  # first diagonal jitter on the correlation matrix [-]
_JITTER_MAX = 1e-6  # largest jitter tried before the covariance is rejected [-]
_SYMMETRY_RTOL = 1e-9
_MAX_DEFAULT_CHUNK = 100
_STATE_FIELDS = ("u_mps", "v_mps", "r_radps", "x_m", "y_m", "psi_rad")


class UncertaintyError(ValueError):
    """Input that a Monte-Carlo run cannot use; ``str()`` is one line."""


# --------------------------------------------------------------------------------------
# Results
# --------------------------------------------------------------------------------------


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
    """Outcome of :func:`monte_carlo_metrics`.

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
            "condition": {
                "speed_mps": self.speed_mps,
                "rpm": self.n_rps * 60.0,
                "rudder_rate_deg_s": math.degrees(self.rudder_rate_radps),
                "dt_s": self.dt_s,
            },
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


# --------------------------------------------------------------------------------------
# Sampling
# --------------------------------------------------------------------------------------


def draw_coefficients(
    params: ModelParameters, n_samples: int, seed: int
) -> tuple[np.ndarray, float]:
    """Draw coefficient sets θ ~ N(θ̂, Σ) from the parameters' covariance.

    With d the standard deviations of the coefficients whose variance is positive and
    C = Σ / (d dᵀ) their correlation matrix, θ = θ̂ + d ⊙ (chol(C + εI) z) with
    z ~ N(0, I); ε = 0 when C is positive definite, else the smallest of 1e-12, 1e-11,
    … 1e-6 that makes the factorisation succeed. Coefficients with zero variance stay
    exactly at θ̂.

    Parameters
    ----------
    params : ModelParameters
        θ̂ and Σ (``covariance`` must not be None).
    n_samples : int
        Number of coefficient sets N ≥ 1.
    seed : int
        Seed of ``numpy.random.default_rng``; the same seed gives the same draw.

    Returns
    -------
    samples : numpy.ndarray
        (N, p) coefficient sets in the structure's order [SI].
    jitter : float
        ε used [-].

    Raises
    ------
    UncertaintyError
        No covariance, or one that is not finite, not symmetric, has a negative
        variance, or is not positive semi-definite (Cholesky fails with ε = 1e-6).

    """
    if n_samples < 1:
        raise UncertaintyError(f"n_samples must be at least 1, got {n_samples}")
    theta = params.to_vector()
    if params.covariance is None:
        raise UncertaintyError(
            f"the parameters of {params.vessel_name!r} have no covariance; nothing to sample"
        )
    cov = np.asarray(params.covariance, dtype=float)
    if not np.all(np.isfinite(cov)):
        raise UncertaintyError("the covariance contains NaN or infinite values")
    scale = max(float(np.max(np.abs(cov))), np.finfo(float).tiny)
    if np.max(np.abs(cov - cov.T)) > _SYMMETRY_RTOL * scale:
        raise UncertaintyError("the covariance is not symmetric")
    variance = np.diag(cov)
    if np.any(variance < 0.0):
        raise UncertaintyError("the covariance has a negative variance on its diagonal")
    free = np.flatnonzero(variance > 0.0)
    rng = np.random.default_rng(seed)
    samples = np.tile(theta, (n_samples, 1))
    if free.size == 0:
        return samples, 0.0
    d = np.sqrt(variance[free])
    correlation = cov[np.ix_(free, free)] / np.outer(d, d)
    jitter = 0.0
    while True:
        try:
            factor = np.linalg.cholesky(correlation + jitter * np.eye(free.size))
            break
        except np.linalg.LinAlgError:
            jitter = _JITTER_START if jitter == 0.0 else 10.0 * jitter
            if jitter > _JITTER_MAX * (1.0 + 1e-9):
                raise UncertaintyError(
                    "the covariance is not positive semi-definite (Cholesky fails with a "
                    f"jitter of {_JITTER_MAX:g} on the correlation matrix)"
                ) from None
    z = rng.standard_normal((n_samples, free.size))
    samples[:, free] += (z @ factor.T) * d
    return samples, jitter


# --------------------------------------------------------------------------------------
# Vectorised step driver
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Setup:
    """Everything a task needs besides its coefficient chunk (picklable, hashable)."""

    model: str
    length_m: float
    programs: tuple[Program, ...]
    speed_mps: float
    n_rps: float
    rudder_rate_radps: float
    dt_s: float
    divergence_factor: float


def simulate_batch(
    model: str,
    theta: np.ndarray,
    length_m: float,
    program: Program,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float,
    dt_s: float,
    divergence_factor: float = 10.0,
) -> tuple[list[np.ndarray | None], np.ndarray]:
    """Run ``program`` for K coefficient sets at once, as ``run_program`` runs one.

    Every sample has its own leg index, leg start time, heading at execute and rudder
    angle; all advance together by one RK4 step per communication step until each has
    finished its last leg (or the step limit of ``run_program``), or diverged.

    Parameters
    ----------
    model : str
        Registered model structure.
    theta : numpy.ndarray
        (p, K) coefficient sets, one per column [SI].
    length_m : float
        Ship length [m].
    program : Program
        The manoeuvre.
    speed_mps : float
        Approach speed U [m/s]; every ship starts at u = U, v = r = 0 at the origin.
    n_rps : float
        Propeller speed [rev/s] unless a leg sets its own.
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    dt_s : float
        Communication step (one RK4 step) [s].
    divergence_factor : float
        A ship diverges when its speed exceeds this × U or |r| this × U/L [-].

    Returns
    -------
    trajectories : list
        Per sample its trajectory (``TRAJECTORY_DTYPE``, time 0 at execute), or None
        when it diverged.
    diverged : numpy.ndarray
        (K,) bool.

    """
    numeric = numeric_model(model)
    theta = np.asarray(theta, dtype=float)
    n_ships = theta.shape[1]
    legs = program.legs
    n_legs = len(legs)

    def per_leg(values: list[float | None], missing: float, after: float) -> np.ndarray:
        # One entry per leg and a last one for "all legs done" (index n_legs).
        return np.array([missing if x is None else x for x in values] + [after], dtype=float)

    rudder_cmd = per_leg([leg.rudder_rad for leg in legs], 0.0, 0.0)
    n_cmd = per_leg([leg.n_rps for leg in legs], math.nan, 0.0)
    time_limit = per_leg([leg.until.time_s for leg in legs], math.inf, math.inf)
    above = per_leg([leg.until.heading_above_rad for leg in legs], math.inf, math.inf)
    below = per_leg([leg.until.heading_below_rad for leg in legs], -math.inf, -math.inf)

    approach_steps = round(program.approach_s / dt_s)
    max_steps = approach_steps + int(
        sum((leg.until.time_s or 0.0) for leg in legs) / dt_s + n_legs + 1
    )
    record: list[np.ndarray] = []  # per step (8, K): u v r x y ψ | rudder n
    times: list[float] = []

    state = np.zeros((6, n_ships))
    state[0] = speed_mps
    rudder = np.zeros(n_ships)
    n_now = np.full(n_ships, float(n_rps))
    t = -approach_steps * dt_s
    executed = approach_steps == 0
    leg = np.zeros(n_ships, dtype=int)
    leg_start = np.full(n_ships, t)
    heading0 = np.zeros(n_ships)
    active = np.ones(n_ships, dtype=bool)
    diverged = np.zeros(n_ships, dtype=bool)
    rows = np.zeros(n_ships, dtype=int)
    max_move = rudder_rate_radps * dt_s
    max_speed = divergence_factor * speed_mps
    max_yaw_rate = divergence_factor * speed_mps / length_m
    k = 0
    while True:
        finished = np.zeros(n_ships, dtype=bool)
        command = np.zeros(n_ships)
        if not executed and t >= -1e-9:  # execute: the approach is over
            executed = True
            leg_start[:] = t
            heading0 = state[5].copy()
        if executed:
            change = state[5] - heading0
            for _ in range(n_legs):  # several legs may end at the same step
                i = leg
                done = (
                    active
                    & (leg < n_legs)
                    & (
                        (t - leg_start >= time_limit[i] - 1e-9)
                        | (change >= above[i])
                        | (change <= below[i])
                    )
                )
                if not done.any():
                    break
                leg = leg + done
                leg_start = np.where(done, t, leg_start)
            finished = active & ((leg >= n_legs) | (k >= max_steps))
            going = active & ~finished
            command = np.where(going, rudder_cmd[leg], 0.0)
            leg_n = n_cmd[leg]
            n_now = np.where(going, np.where(np.isnan(leg_n), n_rps, leg_n), n_now)
        going = active & ~finished
        rudder = np.where(going, rudder + np.clip(command - rudder, -max_move, max_move), rudder)
        times.append(t)
        record.append(np.concatenate((state, rudder[None], n_now[None])))
        rows[finished] = k + 1
        active = going
        if not active.any():
            break
        idx = np.flatnonzero(active)
        with np.errstate(all="ignore"):
            # rk4_step is annotated for scalar inputs but broadcasts (NumericModel.rhs).
            new = rk4_step(
                numeric,
                theta[:, idx],
                length_m,
                state[:, idx],
                cast(float, rudder[idx]),
                cast(float, n_now[idx]),
                dt_s,
            )
            bad = ~np.all(np.isfinite(new), axis=0)
            bad |= np.hypot(new[0], new[1]) > max_speed
            bad |= np.abs(new[2]) > max_yaw_rate
        state[:, idx] = new
        lost = idx[bad]
        diverged[lost] = True
        active[lost] = False
        t += dt_s
        k += 1

    history = np.stack(record)  # (steps, 8, K)
    time_s = np.array(times)
    trajectories: list[np.ndarray | None] = []
    for j in range(n_ships):
        if diverged[j]:
            trajectories.append(None)
            continue
        traj = empty_trajectory(int(rows[j]))
        traj["time_s"] = time_s[: rows[j]]
        for f, name in enumerate((*_STATE_FIELDS, "rudder_rad", "n_rps")):
            traj[name] = history[: rows[j], f, j]
        trajectories.append(traj)
    return trajectories, diverged


def _program_metrics(program: Program, traj: np.ndarray) -> tuple[np.ndarray, int]:
    """Metric values (``METRICS[program.kind]`` order, NaN where missing) and the status."""
    names = METRICS[program.kind]
    values = np.full(len(names), math.nan)
    try:
        if program.kind == "turning":
            m = turning_metrics(traj)
            side = 1 if program.rudder_rad >= 0.0 else -1
            if m.direction != side:
                return values, STATUS_INCOMPLETE  # turned against its rudder
            found: tuple[float | None, ...] = (
                m.advance_m,
                m.transfer_m,
                m.tactical_diameter_m,
                m.steady_diameter_m,
            )
        else:
            z = zigzag_metrics(traj, program.rudder_rad, program.heading_rad)
            before = traj["time_s"] <= z.reversal_times_s[0]
            if np.any(np.sign(program.rudder_rad) * traj["rudder_rad"][before] < 0.0):
                # The check heading was reached only after the first leg timed out.
                return values, STATUS_INCOMPLETE
            found = (z.first_overshoot_rad, z.second_overshoot_rad)
    except MetricsError:
        return values, STATUS_INCOMPLETE
    values[:] = [math.nan if v is None else v for v in found]
    return values, STATUS_OK


def _simulate_chunk(theta: np.ndarray, setup: _Setup) -> list[tuple[np.ndarray, np.ndarray]]:
    """One task: every program for the coefficient sets ``theta`` (p, K).

    Returns per program the (K, n_metrics) values and the (K,) status.
    """
    out = []
    for program in setup.programs:
        trajectories, _ = simulate_batch(
            setup.model,
            theta,
            setup.length_m,
            program,
            speed_mps=setup.speed_mps,
            n_rps=setup.n_rps,
            rudder_rate_radps=setup.rudder_rate_radps,
            dt_s=setup.dt_s,
            divergence_factor=setup.divergence_factor,
        )
        values = np.full((len(trajectories), len(METRICS[program.kind])), math.nan)
        status = np.full(len(trajectories), STATUS_DIVERGED, dtype=np.int8)
        for j, traj in enumerate(trajectories):
            if traj is not None:
                values[j], status[j] = _program_metrics(program, traj)
        out.append((values, status))
    return out


# --------------------------------------------------------------------------------------
# Monte Carlo on a dask cluster
# --------------------------------------------------------------------------------------


@contextmanager
def _dask_client(
    scheduler: str | None, client: Client | None, n_workers: int, processes: bool
) -> Iterator[Client]:
    """Yield ``client``, a client of ``scheduler``, or one of a new ``LocalCluster``."""
    if client is not None:
        yield client
        return
    import logging

    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler, timeout="10s") as remote:
            yield remote
        return
    with (
        LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=processes,
            dashboard_address=None,  # no dashboard; its HTTP server on a free port:
            scheduler_kwargs={"dashboard_address": ":0"},
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as local,
    ):
        yield local


def monte_carlo_metrics(
    params: ModelParameters,
    programs: Sequence[Program] | None = None,
    *,
    n_samples: int = 200,
    seed: int = 0,
    dt_s: float = 0.5,
    rudder_rate_radps: float = DEFAULT_RUDDER_RATE_RADPS,
    speed_mps: float | None = None,
    n_rps: float | None = None,
    scheduler: str | None = None,
    client: Client | None = None,
    n_workers: int = 2,
    processes: bool = True,
    chunk_size: int | None = None,
    divergence_factor: float = 10.0,
) -> UncertaintyResult:
    """Monte-Carlo distribution of manoeuvre metrics under coefficient uncertainty.

    Draws N coefficient sets θ ~ N(θ̂, Σ) (:func:`draw_coefficients`), simulates every
    program for each and for θ̂ itself, and summarises each metric (turning: advance,
    transfer, tactical and steady diameter; zig-zag: first and second overshoot).
    Chunks of ``chunk_size`` samples are tasks on a ``dask.distributed`` cluster.

    Parameters
    ----------
    params : ModelParameters
        Identified model with its covariance.
    programs : sequence of Program, optional
        Turning circles and zig-zags (``scenarios.maneuvers``); default the standard
        set (35° turning both ways, 10/10 and 20/20 zig-zag).
    n_samples : int
        Number of coefficient sets N.
    seed : int
        Seed of the draw; the same seed gives the same result whatever the cluster or
        chunk size.
    dt_s : float
        Communication step, one RK4 step [s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    speed_mps : float, optional
        Approach speed [m/s]; default ``params.nominal_speed_mps``.
    n_rps : float, optional
        Propeller speed [rev/s]; default ``params.nominal_n_rps``.
    scheduler : str, optional
        Address of a running dask scheduler (``"tcp://host:8786"``).
    client : distributed.Client, optional
        An existing client to use (not closed here).
    n_workers : int
        Workers of the ``LocalCluster`` created when neither ``scheduler`` nor
        ``client`` is given (one thread each); closed before returning.
    processes : bool
        Whether that ``LocalCluster`` uses worker processes (else threads).
    chunk_size : int, optional
        Samples per task; default N / (2 × cluster threads), at most 100.
    divergence_factor : float
        A ship counts as diverged when its speed exceeds this × U or its yaw rate
        this × U/L [-].

    Returns
    -------
    UncertaintyResult
        Nominal values, statistics, failure counts and the samples themselves.

    Raises
    ------
    UncertaintyError
        No usable covariance, no approach speed, an unsupported program kind,
        duplicate program names, or invalid settings.

    """
    if scheduler is not None and client is not None:
        raise UncertaintyError("give either scheduler or client, not both")
    speed = params.nominal_speed_mps if speed_mps is None else float(speed_mps)
    n = params.nominal_n_rps if n_rps is None else float(n_rps)
    if not (math.isfinite(speed) and speed > 0.0):
        raise UncertaintyError(f"the approach speed must be positive, got {speed!r} m/s")
    if not math.isfinite(n):
        raise UncertaintyError(f"the propeller speed must be finite, got {n!r} rev/s")
    for name, value in (
        ("dt_s", dt_s),
        ("rudder_rate_radps", rudder_rate_radps),
        ("divergence_factor", divergence_factor),
    ):
        if not (math.isfinite(value) and value > 0.0):
            raise UncertaintyError(f"{name} must be a positive number, got {value!r}")
    if chunk_size is not None and chunk_size < 1:
        raise UncertaintyError(f"chunk_size must be at least 1, got {chunk_size}")
    if n_workers < 1:
        raise UncertaintyError(f"n_workers must be at least 1, got {n_workers}")
    chosen = tuple(standard_set(params.length_m, speed) if programs is None else programs)
    if not chosen:
        raise UncertaintyError("no programs given")
    unsupported = sorted({p.kind for p in chosen} - set(METRICS))
    if unsupported:
        raise UncertaintyError(
            f"unsupported program kind(s) {', '.join(unsupported)} (supported: turning, zigzag)"
        )
    names = [p.name for p in chosen]
    if len(set(names)) != len(names):
        raise UncertaintyError(f"program names must be unique, got {names}")

    samples, jitter = draw_coefficients(params, n_samples, seed)
    setup = _Setup(
        model=params.model,
        length_m=params.length_m,
        programs=chosen,
        speed_mps=speed,
        n_rps=n,
        rudder_rate_radps=float(rudder_rate_radps),
        dt_s=float(dt_s),
        divergence_factor=float(divergence_factor),
    )
    with _dask_client(scheduler, client, n_workers, processes) as dask_client:
        if chunk_size is None:
            threads = max(1, sum(dask_client.nthreads().values()))
            chunk_size = min(_MAX_DEFAULT_CHUNK, max(1, math.ceil(n_samples / (2 * threads))))
        # θ̂ rides as an extra first column of the first chunk: a task of its own would
        # cost almost as much as a whole chunk (the step loop, not the width, dominates).
        columns = np.vstack((params.to_vector(), samples)).T
        bounds = [0, *range(chunk_size + 1, n_samples + 1, chunk_size), n_samples + 1]
        chunks = [np.ascontiguousarray(columns[:, a:b]) for a, b in itertools.pairwise(bounds)]
        futures = dask_client.map(_simulate_chunk, chunks, setup=setup)
        parts = dask_client.gather(futures)

    results = []
    for i, program in enumerate(chosen):
        values = np.concatenate([part[i][0] for part in parts])
        status = np.concatenate([part[i][1] for part in parts])
        results.append(
            ProgramUncertainty(
                program=program,
                metrics=METRICS[program.kind],
                values=values[1:],
                status=status[1:],
                nominal=values[0],
                nominal_status=int(status[0]),
            )
        )
    return UncertaintyResult(
        params=params,
        programs=tuple(results),
        coefficient_samples=samples,
        seed=seed,
        jitter=jitter,
        speed_mps=speed,
        n_rps=n,
        rudder_rate_radps=float(rudder_rate_radps),
        dt_s=float(dt_s),
        chunk_size=int(chunk_size),
    )


# --------------------------------------------------------------------------------------
# Command line: python -m scenarios uncertainty
# --------------------------------------------------------------------------------------

_PROG = "python -m scenarios uncertainty"


def add_cluster_arguments(parser: Any) -> None:
    """Add ``--scheduler`` and ``--workers`` (where the Monte-Carlo samples run)."""
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask scheduler address, e.g. tcp://host:8786 (default: a local cluster)",
    )
    parser.add_argument(
        "--workers",
        type=argtypes.count(1),
        default=2,
        metavar="K",
        help="workers of the local cluster (default 2)",
    )


def add_uncertainty_command(subparsers: Any) -> None:
    """Add ``uncertainty`` to the subparsers of ``python -m scenarios``.

    Parameters
    ----------
    subparsers : argparse._SubParsersAction
        From ``parser.add_subparsers()``; the command's handler is
        :func:`run_uncertainty_command`.

    """
    p = subparsers.add_parser(
        "uncertainty",
        help="Monte-Carlo 95 %% intervals of the standard manoeuvres from params.json",
        description="Draw coefficient sets from the covariance in params.json, run the "
        "standard manoeuvres for each on a dask cluster and print the metrics' "
        "nominal value, mean and 95 % interval.",
    )
    p.add_argument("--params", required=True, metavar="FILE", help="params.json with covariance")
    p.add_argument(
        "--samples", type=argtypes.count(1), default=200, metavar="N", help="samples (default 200)"
    )
    p.add_argument("--seed", type=argtypes.count(0), default=0, metavar="S", help="draw seed")
    add_cluster_arguments(p)
    p.add_argument("--chunk-size", type=argtypes.count(1), metavar="M", help="samples per task")
    p.add_argument(
        "--speed-mps", type=argtypes.positive, metavar="U", help="approach speed (default nominal)"
    )
    p.add_argument(
        "--rpm", type=argtypes.non_negative, metavar="N", help="propeller speed (default nominal)"
    )
    p.add_argument(
        "--rudder-rate-deg-s",
        type=argtypes.positive,
        default=math.degrees(DEFAULT_RUDDER_RATE_RADPS),
        metavar="R",
        help="steering-gear rate [deg/s] (default 2.34)",
    )
    p.add_argument(
        "--dt-s", type=argtypes.positive, default=0.5, metavar="S", help="step [s] (default 0.5)"
    )
    p.add_argument("--json", metavar="OUT", help="write the statistics as JSON")
    p.add_argument(
        "--include-samples", action="store_true", help="also write every sample to the JSON"
    )
    p.add_argument("--quiet", action="store_true", help="no progress on stderr")


def run_uncertainty_command(args: argparse.Namespace) -> int:
    """Run ``python -m scenarios uncertainty``; return the exit status.

    Prints the summary table on stdout; an error is one line on stderr and exit 1.
    """
    import json

    from fmu_model import ParamsFormatError, load_params
    from fmu_model.atomic import write_atomic

    try:
        params = load_params(args.params)
        if not args.quiet:
            print(
                f"{_PROG}: {args.samples} samples of {params.vessel_name} "
                f"({params.model}) on {args.scheduler or f'{args.workers} local workers'}",
                file=sys.stderr,
            )
        result = monte_carlo_metrics(
            params,
            n_samples=args.samples,
            seed=args.seed,
            dt_s=args.dt_s,
            rudder_rate_radps=math.radians(args.rudder_rate_deg_s),
            speed_mps=args.speed_mps,
            n_rps=None if args.rpm is None else args.rpm / 60.0,
            scheduler=args.scheduler,
            n_workers=args.workers,
            chunk_size=args.chunk_size,
        )
        if args.json:
            document = result.as_dict(include_samples=args.include_samples)
            write_atomic(args.json, json.dumps(document, indent=2, allow_nan=False) + "\n")
    except (ParamsFormatError, UncertaintyError, OSError, TimeoutError) as exc:
        text = str(exc).replace("\r", "\\r").replace("\n", "\\n")
        if isinstance(exc, OSError) and exc.filename:
            text = f"{exc.filename}: {exc.strerror or exc}"
        print(f"{_PROG}: error: {text}", file=sys.stderr)
        return 1
    print(result.summary_table(), end="")
    failed = [
        f"{p.program.name}: {p.n_diverged} diverged, {p.n_incomplete} incomplete"
        for p in result.programs
        if p.n_diverged or p.n_incomplete
    ]
    if failed:
        print("failed samples (excluded from the statistics): " + "; ".join(failed))
    return 0
