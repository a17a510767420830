"""Batch identification: many vessels, one Dask task each, resumable.

    python -m identifier batch MANIFEST.toml|DIR --out OUT [--scheduler ADDRESS]
        [--workers N] [--model NAME] [--no-fmu]

Input
-----
A manifest, ``MANIFEST.toml``, with one ``[[vessel]]`` table per vessel::

    [[vessel]]
    name = "tanker-a"                         # required: letters, digits, '.', '_', '-'
    logs = ["tanker-a/zigzag-10.csv",         # required: trial logs (DESIGN.md CSV),
            "tanker-a/turning-35.csv"]        #   relative to the manifest's folder
    length_m = 320.0                          # optional: default the logs' '# length_m:'
    model = "shi2009"                         # optional: --model, else DEFAULT_MODEL

Other keys are errors (a typo must not silently fall back to a default). Or a
directory ``DIR`` with one sub-directory per vessel, named after the vessel, holding
its ``*.csv`` logs (taken in name order); hidden sub-directories, and ``OUT`` when it
lies inside ``DIR``, are not vessels.

Output
------
Per vessel, in ``OUT/<vessel>/``:

* ``params.json`` — the identified model (vessel name = the batch's vessel name);
* ``<vessel>.fmu`` and its OSP sidecar — the native FMI 2.0 FMU (not with ``--no-fmu``);
* ``done.json`` — the completion record, written last: the inputs with their sha256,
  the settings (model, length, FMU), the fit-quality figures and the run time;
* ``error.txt`` — one line, instead of ``done.json``, when the vessel failed.

and ``OUT/summary.csv`` + ``OUT/summary.md``: vessel, status (``ok`` identified in
this run, ``skipped`` up to date from an earlier run, ``failed``), number of logs and
samples, model, RMS of the EKF's filtered track against the logged one (position [m],
heading [deg]), number of coefficients the logs do not identify (of all), seconds.
Every file is written atomically (``fmu_model.atomic.write_atomic``); a file that
cannot be written is reported by its own name (``<file>: cannot write: <reason>``),
never by the name of its temporary file.

Resuming
--------
A vessel whose ``done.json`` names the same inputs with the same sha256 and the same
settings, and whose outputs exist, is skipped; anything else (a changed or added log,
another model, a missing ``done.json`` after an interrupted run, an earlier failure)
runs again. So an interrupted batch is resumed by running the same command again.

Execution
---------
Each vessel to run is one task (read logs → :func:`identifier.identify.identify` →
FMU) on a ``dask.distributed`` ``LocalCluster`` of ``n_workers`` single-threaded
worker processes, or on the existing scheduler at ``scheduler``; there the workers
must see the log files at the paths the client resolved (a shared file system). The
client writes all outputs. A vessel's failure (unreadable log, diverging EKF, FMU
compile error, even a crashed worker) is recorded and the other vessels go on.

The FMU is built by ``fmu_model.export_native.build_native_fmu``, one function call:
this module holds no FMI knowledge.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import datetime as dt
import hashlib
import io
import json
import logging
import math
import os
import re
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from fmu_model import (
    ModelParameters,
    ParamsFormatError,
    argtypes,
    get_model,
    model_names,
    save_params,
)
from fmu_model.atomic import write_atomic
from fmu_model.errors import FmuBuildError
from fmu_model.export_native import build_native_fmu, osp_sidecar_path
from identifier.errors import IdentificationError, LogFormatError
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.logs import read_log

__all__ = [
    "BatchSummary",
    "ManifestError",
    "VesselResult",
    "VesselSpec",
    "read_vessels",
    "run_batch",
]

DEFAULT_MODEL = FitSettings().model
DONE_FORMAT = "shipid-batch-done"
DONE_VERSION = 1
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
_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_RESERVED_NAMES = frozenset({"summary.csv", "summary.md"})
_VESSEL_KEYS = frozenset({"name", "logs", "length_m", "model"})


class ManifestError(ValueError):
    """A batch input (manifest or directory) that cannot be used; ``str()`` is one line.

    Parameters
    ----------
    path : str or os.PathLike
        The manifest file or vessel directory.
    message : str
        What is wrong.

    """

    def __init__(self, path: str | os.PathLike[str], message: str) -> None:
        self.path = os.fspath(path)
        self.message = message.replace("\r", "\\r").replace("\n", "\\n")
        super().__init__(self.path, self.message)

    def __str__(self) -> str:
        return f"{self.path}: {self.message}"


@dataclass(frozen=True)
class VesselSpec:
    """One vessel of a batch.

    Parameters
    ----------
    name : str
        Vessel name: output folder, FMU file and params.json vessel name.
    logs : tuple of pathlib.Path
        Its trial logs (absolute paths), processed in this order.
    length_m : float, optional
        Ship length [m]; from the logs' metadata when None.
    model : str, optional
        Model structure; the batch default when None.

    """

    name: str
    logs: tuple[Path, ...]
    length_m: float | None = None
    model: str | None = None


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
        Model structure.
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
    """Outcome of :func:`run_batch`: one :class:`VesselResult` per vessel, input order."""

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


# --------------------------------------------------------------------------- input


def read_vessels(
    source: str | os.PathLike[str], out_dir: str | os.PathLike[str] | None = None
) -> tuple[VesselSpec, ...]:
    """Return the vessels of a manifest (``*.toml`` file) or a directory of vessel folders.

    Parameters
    ----------
    source : str or os.PathLike
        ``MANIFEST.toml`` or a directory (module docstring).
    out_dir : str or os.PathLike, optional
        The batch's output directory, excluded from a directory's vessels.

    Raises
    ------
    ManifestError
        Unreadable or invalid manifest, an empty directory, bad or duplicate names.

    """
    path = Path(source)
    if path.is_dir():
        vessels = _vessels_from_directory(path, None if out_dir is None else Path(out_dir))
    elif path.is_file():
        vessels = _vessels_from_manifest(path)
    else:
        raise ManifestError(path, "no such manifest file or vessel directory")
    seen: set[str] = set()
    for vessel in vessels:
        if vessel.name.casefold() in seen:
            raise ManifestError(path, f"vessel {vessel.name!r} appears twice")
        seen.add(vessel.name.casefold())
    if not vessels:
        raise ManifestError(path, "no vessels")
    return vessels


def _check_name(path: Path, name: object, where: str) -> str:
    if not isinstance(name, str) or not _NAME.fullmatch(name) or name in _RESERVED_NAMES:
        raise ManifestError(
            path,
            f"{where}: expected a vessel name of letters, digits, '.', '_', '-' "
            f"(a folder name), got {name!r}",
        )
    return name


def _vessels_from_manifest(path: Path) -> tuple[VesselSpec, ...]:
    try:
        doc = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as exc:
        raise ManifestError(path, f"invalid TOML: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ManifestError(path, f"cannot read: {exc}") from None
    extra = sorted(set(doc) - {"vessel"})
    if extra:
        raise ManifestError(path, f"unknown top-level keys {extra} (expected [[vessel]] tables)")
    tables = doc.get("vessel")
    if not isinstance(tables, list) or not all(isinstance(t, dict) for t in tables):
        raise ManifestError(path, "expected one or more [[vessel]] tables")
    base = path.resolve().parent
    vessels = []
    for index, table in enumerate(tables, start=1):
        where = f"vessel {index}"
        unknown = sorted(set(table) - _VESSEL_KEYS)
        if unknown:
            raise ManifestError(
                path, f"{where}: unknown keys {unknown} (expected {sorted(_VESSEL_KEYS)})"
            )
        name = _check_name(path, table.get("name"), where)
        where = f"vessel {name!r}"
        logs = table.get("logs")
        if (
            not isinstance(logs, list)
            or not logs
            or not all(isinstance(p, str) and p for p in logs)
        ):
            raise ManifestError(path, f"{where}: 'logs' must be a non-empty list of file names")
        length = table.get("length_m")
        if length is not None and (
            isinstance(length, bool)
            or not isinstance(length, int | float)
            or not (math.isfinite(length) and length > 0.0)
        ):
            raise ManifestError(
                path, f"{where}: 'length_m' must be a positive number, got {length!r}"
            )
        model = table.get("model")
        if model is not None and model not in model_names():
            raise ManifestError(
                path, f"{where}: unknown model {model!r} (known: {', '.join(model_names())})"
            )
        vessels.append(
            VesselSpec(
                name=name,
                logs=tuple(base / p for p in logs),
                length_m=None if length is None else float(length),
                model=model,
            )
        )
    return tuple(vessels)


def _vessels_from_directory(path: Path, out_dir: Path | None) -> tuple[VesselSpec, ...]:
    skip = None if out_dir is None else out_dir.resolve()
    vessels = []
    for folder in sorted(path.resolve().iterdir()):
        if not folder.is_dir() or folder.name.startswith(".") or folder == skip:
            continue
        name = _check_name(path, folder.name, f"folder {folder.name!r}")
        vessels.append(VesselSpec(name=name, logs=tuple(sorted(folder.glob("*.csv")))))
    return tuple(vessels)


# --------------------------------------------------------------------------- worker task


@dataclass(frozen=True)
class _Job:
    """What a worker needs to identify one vessel (picklable)."""

    name: str
    logs: tuple[str, ...]
    length_m: float | None
    model: str
    build_fmu: bool


@dataclass(frozen=True)
class _Outcome:
    """What a worker returns; the client writes the files."""

    name: str
    inputs: tuple[tuple[str, str], ...]
    n_samples: int
    seconds: float
    params: ModelParameters | None = None  # once identified
    fmu: bytes | None = None
    sidecar: bytes | None = None
    position_rms_m: float = math.nan
    heading_rms_deg: float = math.nan
    not_identifiable: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    error: str | None = None


def _one_line(text: str) -> str:
    return text.replace("\r", "\\r").replace("\n", "\\n")


def _describe(exc: BaseException) -> str:
    """One-line message of an exception, as the CLI prints it."""
    if isinstance(exc, LogFormatError | IdentificationError | FmuBuildError | ParamsFormatError):
        return _one_line(str(exc))
    if isinstance(exc, OSError) and exc.strerror:
        return _one_line(f"{exc.filename or ''}: {exc.strerror}".lstrip(": "))
    return _one_line(f"{type(exc).__name__}: {exc}")


def _fit_quality(result: IdentificationResult) -> tuple[float, float]:
    """RMS filtered-minus-logged position [m] and heading [deg] over all logs."""
    position_sq, heading_sq, count = 0.0, 0.0, 0
    for log, states in zip(result.logs, result.ekf.filtered, strict=True):
        dx = states[:, 3] - log.x_m
        dy = states[:, 4] - log.y_m
        dpsi = np.angle(np.exp(1j * (states[:, 5] - log.heading_rad)))
        position_sq += float(np.sum(dx**2 + dy**2))
        heading_sq += float(np.sum(dpsi**2))
        count += log.n_samples
    return math.sqrt(position_sq / count), math.degrees(math.sqrt(heading_sq / count))


def _identify_vessel(job: _Job) -> _Outcome:
    """Identify one vessel and build its FMU; never raises for bad data (Dask task)."""
    start = time.perf_counter()
    inputs: list[tuple[str, str]] = []
    n_samples = 0
    params = None
    try:
        logs = []
        for path in job.logs:
            logs.append(read_log(path))
            inputs.append((path, _sha256(Path(path))))
        n_samples = sum(log.n_samples for log in logs)
        result = identify(logs, FitSettings(model=job.model), length_m=job.length_m)
        identification = dict(result.params.identification)
        identification["logs"] = [{"path": p, "sha256": h} for p, h in inputs]
        params = replace(result.params, vessel_name=job.name, identification=identification)
        position_rms, heading_rms = _fit_quality(result)
        fmu = sidecar = None
        if job.build_fmu:
            with tempfile.TemporaryDirectory(prefix="shipid-batch-") as tmp:
                built = build_native_fmu(params, Path(tmp) / f"{job.name}.fmu")
                fmu = built.read_bytes()
                sidecar = osp_sidecar_path(built).read_bytes()
    except Exception as exc:  # one vessel's failure must not stop the batch
        return _Outcome(
            name=job.name,
            inputs=tuple(inputs),
            n_samples=n_samples,
            seconds=time.perf_counter() - start,
            params=params,
            error=_describe(exc),
        )
    return _Outcome(
        name=job.name,
        inputs=tuple(inputs),
        n_samples=n_samples,
        seconds=time.perf_counter() - start,
        params=params,
        fmu=fmu,
        sidecar=sidecar,
        position_rms_m=position_rms,
        heading_rms_deg=heading_rms,
        not_identifiable=result.not_identifiable,
        warnings=result.warnings,
    )


# --------------------------------------------------------------------------- client side


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for chunk in iter(lambda: file.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def _settings(model: str, length_m: float | None, build_fmu: bool) -> dict[str, Any]:
    return {"model": model, "length_m": length_m, "fmu": build_fmu}


def _up_to_date(
    directory: Path, name: str, inputs: list[tuple[str, str]], settings: dict[str, Any]
) -> dict[str, Any] | None:
    """Return the vessel's done.json when it matches inputs, settings and outputs, else None."""
    try:
        done = json.loads((directory / "done.json").read_text(encoding="utf-8"))
        same = (
            done["format"] == DONE_FORMAT
            and done["version"] == DONE_VERSION
            and [(i["path"], i["sha256"]) for i in done["inputs"]] == inputs
            and done["settings"]["model"] == settings["model"]
            and done["settings"]["length_m"] == settings["length_m"]
            and (done["settings"]["fmu"] or not settings["fmu"])
            and (directory / "params.json").is_file()
            and (not settings["fmu"] or (directory / f"{name}.fmu").is_file())
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return done if same else None


def _result_from_done(directory: Path, done: Mapping[str, Any]) -> VesselResult:
    figures = done["result"]
    return VesselResult(
        name=done["vessel"],
        status="skipped",
        n_logs=len(done["inputs"]),
        n_samples=int(figures["n_samples"]),
        model=done["settings"]["model"],
        position_rms_m=float(figures["position_rms_m"]),
        heading_rms_deg=float(figures["heading_rms_deg"]),
        not_identifiable=tuple(figures["not_identifiable"]),
        n_coefficients=int(figures["n_coefficients"]),
        seconds=float(figures["seconds"]),
        error=None,
        directory=directory,
    )


def _failed(
    directory: Path, spec: VesselSpec, model: str, error: str, n_samples: int, seconds: float
) -> VesselResult:
    with contextlib.suppress(FileNotFoundError):
        (directory / "done.json").unlink()
    write_atomic(directory / "error.txt", error + "\n")
    return VesselResult(
        name=spec.name,
        status="failed",
        n_logs=len(spec.logs),
        n_samples=n_samples,
        model=model,
        position_rms_m=math.nan,
        heading_rms_deg=math.nan,
        not_identifiable=(),
        n_coefficients=get_model(model).n_coefficients,
        seconds=seconds,
        error=error,
        directory=directory,
    )


def _finish(directory: Path, spec: VesselSpec, job: _Job, outcome: _Outcome) -> VesselResult:
    """Write a finished task's outputs (done.json last) and return its summary row."""
    if outcome.params is not None:
        save_params(directory / "params.json", outcome.params)
    if outcome.error is not None:
        return _failed(
            directory, spec, job.model, outcome.error, outcome.n_samples, outcome.seconds
        )
    fmu_path = directory / f"{spec.name}.fmu"
    if outcome.fmu is not None and outcome.sidecar is not None:
        write_atomic(fmu_path, outcome.fmu)
        write_atomic(osp_sidecar_path(fmu_path), outcome.sidecar)
    else:  # an FMU of an earlier run no longer matches params.json
        for stale in (fmu_path, osp_sidecar_path(fmu_path)):
            with contextlib.suppress(FileNotFoundError):
                stale.unlink()
    n_coefficients = get_model(job.model).n_coefficients
    figures = {
        "n_samples": outcome.n_samples,
        "position_rms_m": outcome.position_rms_m,
        "heading_rms_deg": outcome.heading_rms_deg,
        "not_identifiable": list(outcome.not_identifiable),
        "n_coefficients": n_coefficients,
        "seconds": outcome.seconds,
        "warnings": list(outcome.warnings),
    }
    done = {
        "format": DONE_FORMAT,
        "version": DONE_VERSION,
        "vessel": spec.name,
        "inputs": [{"path": p, "sha256": h} for p, h in outcome.inputs],
        "settings": _settings(job.model, job.length_m, job.build_fmu),
        "outputs": {
            "params": "params.json",
            "fmu": f"{spec.name}.fmu" if job.build_fmu else None,
        },
        "result": figures,
        "finished": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
    }
    write_atomic(directory / "done.json", json.dumps(done, indent=2) + "\n")
    with contextlib.suppress(FileNotFoundError):
        (directory / "error.txt").unlink()
    return VesselResult(
        name=spec.name,
        status="ok",
        n_logs=len(spec.logs),
        n_samples=outcome.n_samples,
        model=job.model,
        position_rms_m=outcome.position_rms_m,
        heading_rms_deg=outcome.heading_rms_deg,
        not_identifiable=outcome.not_identifiable,
        n_coefficients=n_coefficients,
        seconds=outcome.seconds,
        error=None,
        directory=directory,
    )


@contextlib.contextmanager
def _client(scheduler: str | None, n_workers: int) -> Iterator[Any]:
    """Yield a ``distributed.Client`` on ``scheduler`` or on a new LocalCluster of processes."""
    from distributed import Client, LocalCluster

    if scheduler is not None:
        with Client(scheduler) as client:
            yield client
        return
    with (
        LocalCluster(
            n_workers=n_workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": ":0"},  # no dashboard; any free port
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


def run_batch(
    manifest_or_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    n_workers: int = 2,
    model: str | None = None,
    build_fmu: bool = True,
    progress: Callable[[VesselResult], None] | None = None,
) -> BatchSummary:
    """Identify every vessel of a manifest or directory, one Dask task per vessel.

    Parameters
    ----------
    manifest_or_dir : str or os.PathLike
        ``MANIFEST.toml`` or a directory of vessel folders (module docstring).
    out_dir : str or os.PathLike
        Output directory; created when missing.
    scheduler : str, optional
        Address of a running ``dask.distributed`` scheduler (``tcp://host:8786``);
        a ``LocalCluster`` of ``n_workers`` processes is started when None (and only
        when some vessel has to run).
    n_workers : int
        Worker processes of the LocalCluster (one thread each).
    model : str, optional
        Model structure of the vessels whose manifest entry names none
        (default ``shi2009``).
    build_fmu : bool
        Build ``<vessel>.fmu`` as well as ``params.json``.
    progress : callable, optional
        Called with each vessel's :class:`VesselResult` as soon as it is known.

    Returns
    -------
    BatchSummary
        One row per vessel; also written to ``OUT/summary.csv`` and ``OUT/summary.md``.

    Raises
    ------
    ManifestError
        Invalid manifest or directory (nothing is run).
    ValueError
        Unknown ``model`` or ``n_workers`` below 1.

    """
    start = time.perf_counter()
    default_model = model or DEFAULT_MODEL
    if default_model not in model_names():
        raise ValueError(f"unknown model {default_model!r} (known: {', '.join(model_names())})")
    if n_workers < 1:
        raise ValueError(f"n_workers must be at least 1, got {n_workers}")
    out = Path(out_dir)
    specs = read_vessels(manifest_or_dir, out)
    results: dict[str, VesselResult] = {}
    pending: list[tuple[VesselSpec, _Job]] = []

    def report(result: VesselResult) -> None:
        results[result.name] = result
        if progress is not None:
            progress(result)

    for spec in specs:
        directory = out / spec.name
        vessel_model = spec.model or default_model
        if not spec.logs:
            report(_failed(directory, spec, vessel_model, "no *.csv logs", 0, 0.0))
            continue
        try:
            inputs = [(str(p), _sha256(p)) for p in spec.logs]
        except OSError as exc:
            report(_failed(directory, spec, vessel_model, _describe(exc), 0, 0.0))
            continue
        done = _up_to_date(
            directory, spec.name, inputs, _settings(vessel_model, spec.length_m, build_fmu)
        )
        if done is not None:
            report(_result_from_done(directory, done))
            continue
        with contextlib.suppress(FileNotFoundError):
            (directory / "done.json").unlink()
        job = _Job(spec.name, tuple(p for p, _ in inputs), spec.length_m, vessel_model, build_fmu)
        pending.append((spec, job))

    if pending:
        from distributed import as_completed

        with _client(scheduler, n_workers) as client:
            futures = {
                client.submit(_identify_vessel, job, pure=False): (spec, job)
                for spec, job in pending
            }
            for future in as_completed(futures):
                spec, job = futures[future]
                directory = out / spec.name
                try:
                    outcome = future.result()
                except Exception as exc:  # a crashed worker, a lost connection
                    report(_failed(directory, spec, job.model, _describe(exc), 0, 0.0))
                else:
                    report(_finish(directory, spec, job, outcome))

    summary = BatchSummary(
        vessels=tuple(results[spec.name] for spec in specs),
        out_dir=out,
        seconds=time.perf_counter() - start,
    )
    write_summary(summary)
    return summary


# --------------------------------------------------------------------------- summary


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


# --------------------------------------------------------------------------- command line


def add_parser(sub: Any) -> argparse.ArgumentParser:
    """Add the ``batch`` command to the subparsers ``sub`` of ``python -m identifier``."""
    batch = sub.add_parser(
        "batch",
        help="identify many vessels (manifest or directory), one FMU each, resumable",
        description="Identify every vessel of MANIFEST.toml or DIR on a Dask cluster.",
    )
    batch.add_argument("source", metavar="MANIFEST.toml|DIR", help="vessels and their logs")
    batch.add_argument("--out", required=True, metavar="DIR", help="output directory")
    batch.add_argument(
        "--scheduler", metavar="ADDRESS", help="existing dask scheduler (default: LocalCluster)"
    )
    batch.add_argument(
        "--workers", type=argtypes.count(1), default=2, metavar="N", help="LocalCluster workers"
    )
    batch.add_argument(
        "--model", choices=model_names(), help=f"default model (default: {DEFAULT_MODEL})"
    )
    batch.add_argument("--no-fmu", action="store_true", help="write params.json only")
    batch.add_argument("--quiet", action="store_true", help="no per-vessel lines on stdout")
    return batch


def main(args: argparse.Namespace) -> int:
    """Run ``python -m identifier batch`` for parsed ``args``; return the exit status."""

    def show(result: VesselResult) -> None:
        if result.ok and not args.quiet:
            print(
                f"{result.name}: {result.status} ({result.n_logs} logs, "
                f"{result.n_samples} samples, {result.seconds:.1f} s)",
                flush=True,
            )

    try:
        summary = run_batch(
            args.source,
            args.out,
            scheduler=args.scheduler,
            n_workers=args.workers,
            model=args.model,
            build_fmu=not args.no_fmu,
            progress=show,
        )
    except (ManifestError, ValueError) as exc:
        print(f"error: {_one_line(str(exc))}", file=sys.stderr)
        return 1
    except OSError as exc:
        print(f"error: {_describe(exc)}", file=sys.stderr)
        return 1
    for line in format_failures(summary):
        print(f"error: {line}", file=sys.stderr)
    if not args.quiet:
        print(f"wrote {summary.out_dir / 'summary.md'}")
    return 0 if summary.ok else 1
