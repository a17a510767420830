"""Running a batch: every vessel that is not up to date is one task on a Dask cluster.

Each vessel to run is one task (:func:`identifier.batch.task.identify_vessel`) on a
``dask.distributed`` ``LocalCluster`` of ``n_workers`` single-threaded worker
processes, or on the existing scheduler at ``scheduler``; there the workers must see
the log files at the paths the client resolved (a shared file system). The client
writes all outputs (:mod:`identifier.batch.records`). A vessel's failure (unreadable
log, diverging EKF, FMU compile error, even a crashed worker) is recorded and the
other vessels go on.
"""

from __future__ import annotations

import contextlib
import logging
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

from fmu_model import DEFAULT_MODEL, model_names
from identifier.batch.manifest import VesselSpec, read_vessels
from identifier.batch.records import (
    record_failure,
    record_outcome,
    result_from_done,
    settings_record,
    up_to_date,
)
from identifier.batch.summary import BatchSummary, VesselResult, write_summary
from identifier.batch.task import VesselJob, describe_error, identify_vessel, sha256_of

__all__ = ["run_batch"]


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
        ``MANIFEST.toml`` or a directory of vessel folders
        (:mod:`identifier.batch.manifest`).
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
        (default :data:`fmu_model.DEFAULT_MODEL`).
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
    pending: list[tuple[VesselSpec, VesselJob]] = []

    def report(result: VesselResult) -> None:
        results[result.name] = result
        if progress is not None:
            progress(result)

    for spec in specs:
        directory = out / spec.name
        vessel_model = spec.model or default_model
        if not spec.logs:
            report(record_failure(directory, spec, vessel_model, "no *.csv logs", 0, 0.0))
            continue
        try:
            inputs = [(str(p), sha256_of(p)) for p in spec.logs]
        except OSError as exc:
            report(record_failure(directory, spec, vessel_model, describe_error(exc), 0, 0.0))
            continue
        done = up_to_date(
            directory, spec.name, inputs, settings_record(vessel_model, spec.length_m, build_fmu)
        )
        if done is not None:
            report(result_from_done(directory, done))
            continue
        with contextlib.suppress(FileNotFoundError):
            (directory / "done.json").unlink()
        job = VesselJob(
            spec.name, tuple(p for p, _ in inputs), spec.length_m, vessel_model, build_fmu
        )
        pending.append((spec, job))

    if pending:
        from distributed import as_completed

        with _client(scheduler, n_workers) as client:
            futures = {
                client.submit(identify_vessel, job, pure=False): (spec, job)
                for spec, job in pending
            }
            for future in as_completed(futures):
                spec, job = futures[future]
                directory = out / spec.name
                try:
                    outcome = future.result()
                except Exception as exc:  # a crashed worker, a lost connection
                    report(record_failure(directory, spec, job.model, describe_error(exc), 0, 0.0))
                else:
                    report(record_outcome(directory, spec, job, outcome))

    summary = BatchSummary(
        vessels=tuple(results[spec.name] for spec in specs),
        out_dir=out,
        seconds=time.perf_counter() - start,
    )
    write_summary(summary)
    return summary
