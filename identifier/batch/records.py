"""The client side of one vessel: its files in ``OUT/<vessel>/`` and whether it is up to date.

Per vessel, in ``OUT/<vessel>/``: ``params.json``, ``<vessel>.fmu`` and its OSP
sidecar (not with ``build_fmu=False``), and last ``done.json``, the completion record
(the inputs with their sha256, the settings, the fit-quality figures, the run time);
or ``error.txt``, one line, instead of ``done.json`` when the vessel failed. A vessel
whose ``done.json`` names the same inputs with the same sha256 and the same settings,
and whose outputs exist, is up to date (:func:`up_to_date`).
"""

from __future__ import annotations

import contextlib
import datetime as dt
import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from fmu_model import get_model, save_params
from fmu_model.atomic import write_atomic
from fmu_model.export_native import osp_sidecar_path
from fmu_model.variants import family_name
from identifier.batch.manifest import VesselSpec
from identifier.batch.summary import VesselResult
from identifier.batch.task import VesselJob, VesselOutcome

__all__ = [
    "DONE_FORMAT",
    "DONE_VERSION",
    "record_failure",
    "record_outcome",
    "result_from_done",
    "settings_record",
    "up_to_date",
]

DONE_FORMAT = "shipid-batch-done"
"""The ``format`` of ``done.json``."""
DONE_VERSION = 1
"""The ``version`` of ``done.json``; another version means the vessel runs again."""


def settings_record(
    model: str,
    method: str,
    length_m: float | None,
    build_fmu: bool,
    current: str | None = None,
    windage: tuple[str, str] | None = None,
) -> dict[str, Any]:
    """Return the ``settings`` of ``done.json``: model, method, current, length, FMU, windage.

    ``length_m`` [m]; ``build_fmu``: the FMU built. ``current`` None (JSON null): the mode
    the ship's size chose. ``windage``: its file's path and sha256 (a changed windage fits
    again), None without one.
    """
    return {
        "model": model,
        "method": method,
        "current": current,
        "length_m": length_m,
        "fmu": build_fmu,
        "windage": None if windage is None else {"path": windage[0], "sha256": windage[1]},
    }


def up_to_date(
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
            and done["settings"]["method"] == settings["method"]
            and done["settings"]["current"] == settings["current"]
            and done["settings"]["length_m"] == settings["length_m"]
            and done["settings"]["windage"] == settings["windage"]
            and (done["settings"]["fmu"] or not settings["fmu"])
            and (directory / "params.json").is_file()
            and (not settings["fmu"] or (directory / f"{name}.fmu").is_file())
        )
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return done if same else None


def result_from_done(directory: Path, done: Mapping[str, Any]) -> VesselResult:
    """Return the summary row (status ``skipped``) of a vessel up to date from ``done``."""
    figures = done["result"]
    return VesselResult(
        name=done["vessel"],
        status="skipped",
        n_logs=len(done["inputs"]),
        n_samples=int(figures["n_samples"]),
        model=figures.get("model", done["settings"]["model"]),  # fitted (asked before)
        position_rms_m=float(figures["position_rms_m"]),
        heading_rms_deg=float(figures["heading_rms_deg"]),
        not_identifiable=tuple(figures["not_identifiable"]),
        n_coefficients=int(figures["n_coefficients"]),
        seconds=float(figures["seconds"]),
        error=None,
        directory=directory,
    )


def record_failure(
    directory: Path, spec: VesselSpec, model: str, error: str, n_samples: int, seconds: float
) -> VesselResult:
    """Record a failed vessel: ``error.txt`` instead of ``done.json``; return its summary row.

    Parameters
    ----------
    directory : pathlib.Path
        ``OUT/<vessel>``.
    spec : VesselSpec
        The vessel.
    model : str
        Its model structure.
    error : str
        One-line reason.
    n_samples : int
        Samples in its logs (0 when unknown).
    seconds : float
        Wall time spent on it [s].

    Returns
    -------
    VesselResult
        Status ``failed``.

    """
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


def record_outcome(
    directory: Path, spec: VesselSpec, job: VesselJob, outcome: VesselOutcome
) -> VesselResult:
    """Write a finished task's outputs (done.json last) and return its summary row."""
    if outcome.params is not None:
        save_params(directory / "params.json", outcome.params)
    if outcome.error is not None:
        return record_failure(
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
    # The model fitted, which may be a fallback of the one asked for (a thrust refit).
    assert outcome.params is not None  # identified: no error
    fitted = get_model(outcome.params.model)
    model, n_coefficients = family_name(outcome.params.model), fitted.n_coefficients
    figures = {
        "model": model,
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
        "settings": settings_record(
            job.model, job.method, job.length_m, job.build_fmu, job.current, job.windage
        ),
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
        model=model,
        position_rms_m=outcome.position_rms_m,
        heading_rms_deg=outcome.heading_rms_deg,
        not_identifiable=outcome.not_identifiable,
        n_coefficients=n_coefficients,
        seconds=outcome.seconds,
        error=None,
        directory=directory,
    )
