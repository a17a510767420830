"""Running a batch: every vessel that is not up to date is one task on a Dask cluster.

Each vessel to run is one task (:func:`identifier.batch.task.identify_vessel`), the
vessels with the most log data first, on a
``dask.distributed`` ``LocalCluster`` of ``n_workers`` single-threaded worker
processes, or on the existing scheduler at ``scheduler``; there the workers must see
the log files at the paths the client resolved (a shared file system). The client
writes all outputs (:mod:`identifier.batch.records`). A vessel's failure (unreadable
log, diverging EKF, FMU compile error, even a crashed worker) is recorded and the
other vessels go on.

The worker processes of a LocalCluster end with the process that started them: on
SIGTERM or SIGHUP it kills them (and whatever they started) before it ends
(:func:`_children_end_with_us`), on SIGINT its KeyboardInterrupt closes the cluster;
when it is killed outright (SIGKILL) each worker exits as soon as it notices
(``distributed`` watches the parent from every worker process once the worker has
imported its modules, within seconds).
"""

from __future__ import annotations

import contextlib
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from types import FrameType

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
from identifier.current import CURRENT_MODES
from identifier.identify import METHODS
from trials.cluster import cluster_client

__all__ = ["run_batch"]


# Signals whose default action ends this process without a word to its children.
_ENDING_SIGNALS = tuple(
    getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name)
)


@contextlib.contextmanager
def _children_end_with_us() -> Iterator[None]:
    """Inside, SIGTERM and SIGHUP kill the child processes started inside, then this one.

    Left to their default action, these signals end this process at once, and a worker
    process still importing its modules outlives it by as long as that takes (it only
    then starts watching its parent), seconds on a busy machine. The handler kills every
    descendant process started since entering (the worker processes, the resource
    tracker, a worker's compiler) and then ends this process by the same signal, as the
    default action would. A signal someone else handles (or ignores) is left alone, and
    so is everything when not called from the main thread (only it may set signal
    handlers). SIGINT is left to Python: its KeyboardInterrupt closes the cluster on
    the way out (during the cluster's start, distributed's exit handler does).
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    import psutil

    me = psutil.Process()
    before = {child.pid for child in me.children(recursive=True)}
    ours = [signum for signum in _ENDING_SIGNALS if signal.getsignal(signum) == signal.SIG_DFL]

    def end(signum: int, frame: FrameType | None) -> None:
        for other in ours:  # a second signal must not interrupt the clean-up
            signal.signal(other, signal.SIG_IGN)
        children = []
        with contextlib.suppress(psutil.Error):
            children = me.children(recursive=True)
        # SIGKILL: the multiprocessing resource tracker ignores SIGTERM, and nothing a
        # worker holds needs a clean exit (the client writes every output). No waiting
        # before this process ends: other threads must not have time to start anything
        # new (e.g. relaunch the resource tracker).
        for child in children:
            if child.pid not in before:
                with contextlib.suppress(psutil.Error):
                    child.kill()
        signal.signal(signum, signal.SIG_DFL)
        signal.raise_signal(signum)

    for signum in ours:
        signal.signal(signum, end)
    try:
        yield
    finally:
        for signum in ours:
            if signal.getsignal(signum) is end:
                signal.signal(signum, signal.SIG_DFL)


def run_batch(
    manifest_or_dir: str | os.PathLike[str],
    out_dir: str | os.PathLike[str],
    *,
    scheduler: str | None = None,
    n_workers: int = 2,
    model: str | None = None,
    method: str = METHODS[0],
    build_fmu: bool = True,
    current: str | None = None,
    progress: Callable[[VesselResult, int, int], None] | None = None,
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
    method : str
        Identification procedure of every vessel (``identifier.identify.METHODS``).
    current : str, optional
        Current estimated with every vessel's coefficients (``identifier.current``):
        ``"constant"``, ``"drifting"``, ``"per-log"``, ``"none"`` or ``"auto"``; None (the
        default): by each ship's size (``identifier.current.default_current``).
    build_fmu : bool
        Build ``<vessel>.fmu`` as well as ``params.json``.
    progress : callable, optional
        Called as ``progress(result, done, total)`` with each vessel's
        :class:`VesselResult` as soon as it is known, the number of vessels known so far
        (this one included) and of all the vessels.

    Returns
    -------
    BatchSummary
        One row per vessel; also written to ``OUT/summary.csv`` and ``OUT/summary.md``.

    Raises
    ------
    ManifestError
        Invalid manifest or directory (nothing is run).
    ValueError
        Unknown ``model``, ``method`` or ``current``, or ``n_workers`` below 1.

    """
    start = time.perf_counter()
    default_model = model or DEFAULT_MODEL
    if default_model not in model_names():
        raise ValueError(f"unknown model {default_model!r} (known: {', '.join(model_names())})")
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r} (known: {', '.join(METHODS)})")
    if current is not None and current not in CURRENT_MODES:
        raise ValueError(f"unknown current {current!r} (known: {', '.join(CURRENT_MODES)})")
    if n_workers < 1:
        raise ValueError(f"n_workers must be at least 1, got {n_workers}")
    out = Path(out_dir)
    specs = read_vessels(manifest_or_dir, out)
    results: dict[str, VesselResult] = {}
    pending: list[tuple[VesselSpec, VesselJob]] = []

    def report(result: VesselResult) -> None:
        results[result.name] = result
        if progress is not None:
            progress(result, len(results), len(specs))

    for spec in specs:
        directory = out / spec.name
        vessel_model = spec.model or default_model
        if not spec.logs:
            report(record_failure(directory, spec, vessel_model, "no *.csv logs", 0, 0.0))
            continue
        try:
            inputs = [(str(p), sha256_of(p)) for p in spec.logs]
            windage = None if spec.windage is None else (str(spec.windage), sha256_of(spec.windage))
        except OSError as exc:
            report(record_failure(directory, spec, vessel_model, describe_error(exc), 0, 0.0))
            continue
        done = up_to_date(
            directory,
            spec.name,
            inputs,
            settings_record(vessel_model, method, spec.length_m, build_fmu, current, windage),
        )
        if done is not None:
            report(result_from_done(directory, done))
            continue
        with contextlib.suppress(FileNotFoundError):
            (directory / "done.json").unlink()
        job = VesselJob(
            spec.name,
            tuple(p for p, _ in inputs),
            spec.length_m,
            vessel_model,
            method,
            build_fmu,
            current,
            windage,
        )
        pending.append((spec, job))

    if pending:
        from distributed import as_completed

        # Longest first (by the bytes of its logs): the last task to start is a short
        # one, so the workers finish together (LPT scheduling).
        pending.sort(key=lambda item: -sum(Path(p).stat().st_size for p in item[1].logs))
        # A local cluster's worker processes end with this process (a scheduler's do not).
        local = contextlib.nullcontext() if scheduler else _children_end_with_us()
        with local, cluster_client(scheduler, n_workers) as client:
            futures = {}
            for rank, (spec, job) in enumerate(pending):
                future = client.submit(identify_vessel, job, pure=False, priority=-rank)
                futures[future] = (spec, job)
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
