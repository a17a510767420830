"""The end-to-end demo pipeline, DESIGN.md "The data flow" (:func:`run_demo`).

It prints nothing: progress goes to callbacks (``on_stage``, progress bars from a
:data:`BarFactory`), and a failing stage raises. The output folder::

    OUT/logs/<manoeuvre>.csv   synthetic KVLCC2 trial logs (noisy, seeds fixed)
    OUT/params.json            identified coefficients (identifier.identify)
    OUT/<vessel>.fmu           native FMI 2.0 co-simulation FMU (fmu_model.export_native)
    OUT/report/                validation against the reference ship (scenarios.report),
                               with the 95 % intervals from the identified covariance
                               (scenarios.uncertainty on a local dask cluster)
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Protocol

from fmu_model.variants import DEFAULT_MODEL, family_name
from scenarios.records import Validation, interval_counts
from scenarios.report import write_report
from scenarios.synthesize import synthesize_logs
from scenarios.validation import validate, with_uncertainty

__all__ = ["Bar", "BarFactory", "DemoConfig", "DemoResult", "run_demo"]


class Bar(Protocol):
    """A progress bar (``tqdm`` is one)."""

    def update(self, n: float = 1) -> object:
        """Advance by ``n``."""

    def close(self) -> None:
        """Finish the bar."""


BarFactory = Callable[[str, float | None, str], Bar]
"""``make_bar(description, total or None, unit)`` → a :class:`Bar`."""


class _NoBar:
    def update(self, n: float = 1) -> object:
        return None

    def close(self) -> None:
        return None


def _no_bar(description: str, total: float | None, unit: str) -> Bar:
    return _NoBar()


@dataclass(frozen=True)
class DemoConfig:
    """Settings of the demo pipeline.

    Attributes
    ----------
    vessel, scale : str
        Reference ship that plays the real ship.
    maneuvers : tuple of str
        Trial logs to synthesise and identify from.
    rate_hz, position_noise_m, heading_noise_deg : float
        Logger rate [Hz] and noise [m, deg].
    seed : int
        Run seed of the logs' noise (``scenarios.synthesize.maneuver_seed``).
    model : str
        Model structure to identify.
    validation_dt_s : float
        Communication step of the validation runs [s].
    method : {"output-error", "ekf"}
        Identification procedure (``identifier.identify.METHODS``).
    uncertainty_samples : int
        Monte-Carlo samples of the identified coefficients for the report's 95 %
        intervals; 0 for none.
    uncertainty_dt_s : float
        Communication step of the Monte-Carlo runs [s].
    uncertainty_workers : int
        Workers of the local dask cluster of the Monte Carlo.
    uncertainty_processes : bool
        Whether those workers are processes (else threads, which start at once).

    """

    vessel: str = "kvlcc2"
    scale: str = "full"
    maneuvers: tuple[str, ...] = ("turning-35", "zigzag-10", "zigzag-20")
    rate_hz: float = 1.0
    position_noise_m: float = 1.0
    heading_noise_deg: float = 0.1
    seed: int = 1
    model: str = DEFAULT_MODEL
    method: str = "output-error"
    validation_dt_s: float = 0.1
    uncertainty_samples: int = 100
    uncertainty_dt_s: float = 0.5
    uncertainty_workers: int = 2
    uncertainty_processes: bool = True

    @classmethod
    def quick(cls) -> DemoConfig:
        """Return the shorter configuration for tests: 0.5 s step, 20 samples on threads."""
        return cls(validation_dt_s=0.5, uncertainty_samples=20, uncertainty_processes=False)


@dataclass(frozen=True)
class DemoResult:
    """What the demo produced, and how long each stage took [s]."""

    logs: tuple[Path, ...]
    params_path: Path
    fmu_path: Path
    report_dir: Path
    report_files: tuple[Path, ...]
    validation: Validation
    identification_warnings: tuple[str, ...]
    identification_notes: tuple[str, ...] = ()
    stage_seconds: dict[str, float] = field(default_factory=dict)


def run_demo(
    out_dir: str | os.PathLike[str],
    config: DemoConfig | None = None,
    *,
    on_stage: Callable[[str, float, str], None] | None = None,
    make_bar: BarFactory | None = None,
) -> DemoResult:
    """Reference-ship logs → identification → native FMU → validation report.

    Parameters
    ----------
    out_dir : path-like
        Output folder; layout in the module docstring.
    config : DemoConfig, optional
        Default :class:`DemoConfig`.
    on_stage : callable, optional
        Called after each stage with its name, duration [s] and a one-line summary.
    make_bar : BarFactory, optional
        Progress bars for the long stages.

    Stages, each reported to ``on_stage``: ``synthesize``, ``identify``, ``build FMU``,
    ``validate``, ``uncertainty`` (when ``config.uncertainty_samples`` > 0) and
    ``report``.

    Raises
    ------
    ScenarioError, trials.errors.IdentificationError, fmu_model.errors.FmuBuildError
        A stage failed.

    """
    from fmu_model import save_params
    from fmu_model.export_native import build_native_fmu
    from fmu_model.interface import model_identifier
    from identifier.identify import FitSettings, identify
    from trials.logs import read_log

    config = config or DemoConfig()
    bar_factory = make_bar or _no_bar
    out = Path(out_dir)
    seconds: dict[str, float] = {}

    def stage_done(name: str, start: float, summary: str) -> None:
        seconds[name] = time.perf_counter() - start
        if on_stage is not None:
            on_stage(name, seconds[name], summary)

    start = time.perf_counter()
    bar = bar_factory("synthesize", len(config.maneuvers), "log")
    try:
        logs = synthesize_logs(
            out / "logs",
            config.maneuvers,
            vessel=config.vessel,
            scale=config.scale,
            rate_hz=config.rate_hz,
            position_noise_m=config.position_noise_m,
            heading_noise_deg=config.heading_noise_deg,
            seed=config.seed,
            on_log=lambda _path: bar.update(1),
        )
    finally:
        bar.close()
    stage_done("synthesize", start, f"{len(logs)} trial logs in {out / 'logs'}")

    start = time.perf_counter()
    trial_logs = [read_log(path) for path in logs]
    bar = bar_factory("identify", 2 * sum(log.n_samples for log in trial_logs), "sample")
    try:

        def advance(n: int) -> None:
            bar.update(n)

        settings = FitSettings(model=config.model, method=config.method)
        result = identify(trial_logs, settings, progress=advance)
    finally:
        bar.close()
    params_path = out / "params.json"
    save_params(params_path, result.params)
    family = family_name(result.params.model)  # prime-rudder-thrust when refitted
    stage_done("identify", start, f"{family} coefficients in {params_path}")

    start = time.perf_counter()
    fmu_path = out / f"{model_identifier(result.params.vessel_name)}.fmu"
    build_native_fmu(result.params, fmu_path)
    stage_done("build FMU", start, f"native FMI 2.0 co-simulation FMU {fmu_path}")

    start = time.perf_counter()
    bar = bar_factory("validate", 8, "run")
    try:
        validation = validate(
            fmu_path,
            reference=config.vessel,
            scale=config.scale,
            dt_s=config.validation_dt_s,
            on_run=lambda _name: bar.update(1),
            params=result.params,
            params_source=str(params_path),
        )
    finally:
        bar.close()
    trained = ", ".join(config.maneuvers)
    validation = replace(
        validation,
        warnings=(
            *validation.warnings,
            f"the model was identified from the logs {trained} only: every other "
            "manoeuvre in the comparison is a prediction of one it has not seen",
        ),
    )
    stage_done(
        "validate",
        start,
        f"{len(validation.rows)} quantities vs {validation.reference_name}, "
        f"step {config.validation_dt_s:g} s",
    )

    if config.uncertainty_samples > 0:
        start = time.perf_counter()
        validation = with_uncertainty(
            validation,
            result.params,
            n_samples=config.uncertainty_samples,
            dt_s=config.uncertainty_dt_s,
            n_workers=config.uncertainty_workers,
            processes=config.uncertainty_processes,
            source=str(params_path),
        )
        inside, judged = interval_counts(validation.rows)
        stage_done(
            "uncertainty",
            start,
            f"{config.uncertainty_samples} Monte-Carlo samples on "
            f"{config.uncertainty_workers} local "
            f"{'worker processes' if config.uncertainty_processes else 'worker threads'}; "
            "reference inside the 95 % "
            f"interval for {inside} of {judged} quantities",
        )

    start = time.perf_counter()
    report_dir = out / "report"
    files = write_report(validation, report_dir)
    stage_done("report", start, f"report in {report_dir / 'report.md'}")

    return DemoResult(
        logs=tuple(logs),
        params_path=params_path,
        fmu_path=fmu_path,
        report_dir=report_dir,
        report_files=tuple(files),
        validation=validation,
        identification_warnings=tuple(result.warnings),
        identification_notes=tuple(result.notes),
        stage_seconds=seconds,
    )
