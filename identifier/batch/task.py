"""The work of one vessel, run as a Dask task on a worker: read logs, identify, build the FMU.

:func:`identify_vessel` takes a picklable :class:`VesselJob` and returns a
:class:`VesselOutcome`; it writes nothing (the client writes all outputs,
:mod:`identifier.batch.records`) and never raises for bad data. The FMU is built by
``fmu_model.export_native.build_native_fmu``, one function call: this module holds no
FMI knowledge.
"""

from __future__ import annotations

import hashlib
import math
import tempfile
import time
from dataclasses import dataclass, replace
from pathlib import Path

from fmu_model import ModelParameters, ParamsFormatError
from fmu_model.errors import FmuBuildError
from fmu_model.export_native import build_native_fmu, osp_sidecar_path
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.wind import read_windage
from trials.errors import IdentificationError, LogFormatError, one_line
from trials.logs import read_log

__all__ = ["VesselJob", "VesselOutcome", "describe_error", "identify_vessel", "sha256_of"]


@dataclass(frozen=True)
class VesselJob:
    """What a worker needs to identify one vessel (picklable).

    Parameters
    ----------
    name : str
        Vessel name.
    logs : tuple of str
        Its trial logs, resolved paths the worker can open.
    length_m : float or None
        Ship length [m]; from the logs' metadata when None.
    model : str
        Model structure.
    method : str
        Identification procedure (``identifier.identify.METHODS``).
    current : str, optional
        Current estimated with the coefficients (``identifier.current.CURRENT_MODES``);
        None: by the ship's size (``identifier.current.default_current``).
    build_fmu : bool
        Build the native FMU as well.
    windage : tuple of (str, str), optional
        Its windage file (fit's ``--windage``) and the file's sha256; None without one.

    """

    name: str
    logs: tuple[str, ...]
    length_m: float | None
    model: str
    method: str
    build_fmu: bool
    current: str | None = None
    windage: tuple[str, str] | None = None


@dataclass(frozen=True)
class VesselOutcome:
    """What a worker returns; the client writes the files.

    Parameters
    ----------
    name : str
        Vessel name.
    inputs : tuple of (str, str)
        The logs read, with their sha256.
    n_samples : int
        Samples in the logs (0 when a log could not be read).
    seconds : float
        Wall time of the task [s].
    params : ModelParameters or None
        The identified model (vessel name and input hashes filled in), once identified.
    fmu, sidecar : bytes or None
        The native FMU and its OSP sidecar, when built.
    position_rms_m, heading_rms_deg : float
        RMS filtered-minus-logged position [m] and heading [deg] (NaN when failed).
    not_identifiable, warnings : tuple of str
        From the identification.
    error : str or None
        One-line reason of a failure.

    """

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


def describe_error(exc: BaseException) -> str:
    """Return the one-line message of an exception, as the CLI prints it.

    The project's data errors by their message, a file error as ``<file>: <reason>``,
    anything else (a bug, a crashed worker) as ``<type>: <message>``; line breaks
    escaped.
    """
    if isinstance(exc, LogFormatError | IdentificationError | FmuBuildError | ParamsFormatError):
        return one_line(str(exc))
    if isinstance(exc, OSError) and exc.strerror:
        return one_line(f"{exc.filename or ''}: {exc.strerror}".lstrip(": "))
    return one_line(f"{type(exc).__name__}: {exc}")


def _fit_quality(result: IdentificationResult) -> tuple[float, float]:
    """RMS filtered-minus-logged position [m] and heading [deg] over all logs."""
    counts = [log.n_samples for log in result.logs]
    position_sq = sum(n * pos**2 for n, (pos, _) in zip(counts, result.ekf.track_rms, strict=True))
    heading_sq = sum(n * head**2 for n, (_, head) in zip(counts, result.ekf.track_rms, strict=True))
    total = sum(counts)
    return math.sqrt(position_sq / total), math.degrees(math.sqrt(heading_sq / total))


def identify_vessel(job: VesselJob) -> VesselOutcome:
    """Identify one vessel and build its FMU; never raises for bad data (Dask task).

    Parameters
    ----------
    job : VesselJob
        The vessel's logs and settings.

    Returns
    -------
    VesselOutcome
        The identified model, its FMU and fit-quality figures; on a failure, the
        one-line reason (``error``) and what was done before it (``params`` once
        identified, so that the client writes ``params.json`` when only the FMU failed).

    """
    start = time.perf_counter()
    inputs: list[tuple[str, str]] = []
    outcome = VesselOutcome(name=job.name, inputs=(), n_samples=0, seconds=0.0)
    try:
        logs = []
        for path in job.logs:
            logs.append(read_log(path))
            inputs.append((path, sha256_of(Path(path))))
        outcome = replace(outcome, n_samples=sum(log.n_samples for log in logs))
        windage = None if job.windage is None else read_windage(job.windage[0])
        settings = FitSettings(
            model=job.model, method=job.method, current=job.current, windage=windage
        )
        result = identify(logs, settings, length_m=job.length_m)
        identification = dict(result.params.identification)
        identification["logs"] = [{"path": p, "sha256": h} for p, h in inputs]
        params = replace(result.params, vessel_name=job.name, identification=identification)
        outcome = replace(outcome, params=params)
        position_rms, heading_rms = _fit_quality(result)
        fmu = sidecar = None
        if job.build_fmu:
            with tempfile.TemporaryDirectory(prefix="shipid-batch-") as tmp:
                built = build_native_fmu(params, Path(tmp) / f"{job.name}.fmu")
                fmu = built.read_bytes()
                sidecar = osp_sidecar_path(built).read_bytes()
        outcome = replace(
            outcome,
            fmu=fmu,
            sidecar=sidecar,
            position_rms_m=position_rms,
            heading_rms_deg=heading_rms,
            not_identifiable=result.not_identifiable,
            warnings=result.warnings,
        )
    except Exception as exc:  # one vessel's failure must not stop the batch
        outcome = replace(outcome, error=describe_error(exc))
    return replace(outcome, inputs=tuple(inputs), seconds=time.perf_counter() - start)


def sha256_of(path: Path) -> str:
    """Return the SHA-256 of a file's content, as hex digits (read in 1 MiB chunks)."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for chunk in iter(lambda: file.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()
