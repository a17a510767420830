"""Batch identification: many vessels, one Dask task each, resumable.

:func:`run_batch` is the library call behind

    python -m identifier batch MANIFEST.toml|DIR --out OUT [--scheduler ADDRESS]
        [--workers N] [--model NAME] [--no-fmu]

(:mod:`identifier.cli.batch`). One job per module:

==================================== ===============================================
:mod:`identifier.batch.manifest`     the input: manifest or directory → vessels
:mod:`identifier.batch.task`         one vessel's work on a Dask worker
:mod:`identifier.batch.records`      one vessel's files: done.json, error.txt, resume
:mod:`identifier.batch.run`          the Dask run over all vessels (:func:`run_batch`)
:mod:`identifier.batch.summary`      results and the summary tables
==================================== ===============================================

Input
-----
A manifest, ``MANIFEST.toml``, with one ``[[vessel]]`` table per vessel (``name``,
``logs``, optionally ``length_m`` and ``model``; other keys are errors), or a
directory ``DIR`` with one sub-directory of ``*.csv`` logs per vessel, named after the
vessel: :mod:`identifier.batch.manifest` has the rules.

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
this package holds no FMI knowledge.
"""

from __future__ import annotations

from identifier.batch.manifest import ManifestError, VesselSpec, read_vessels
from identifier.batch.run import run_batch
from identifier.batch.summary import (
    SUMMARY_COLUMNS,
    BatchSummary,
    VesselResult,
    format_failures,
    summary_csv,
    summary_markdown,
    write_summary,
)

__all__ = [
    "SUMMARY_COLUMNS",
    "BatchSummary",
    "ManifestError",
    "VesselResult",
    "VesselSpec",
    "format_failures",
    "read_vessels",
    "run_batch",
    "summary_csv",
    "summary_markdown",
    "write_summary",
]
