"""The input of a batch: a manifest file or a directory of vessel folders.

A manifest, ``MANIFEST.toml``, has one ``[[vessel]]`` table per vessel::

    [[vessel]]
    name = "tanker-a"                         # required: letters, digits, '.', '_', '-'
    logs = ["tanker-a/zigzag-10.csv",         # required: trial logs (DESIGN.md CSV),
            "tanker-a/turning-35.csv"]        #   relative to the manifest's folder
    length_m = 320.0                          # optional: default the logs' '# length_m:'
    model = "shi2009"                         # optional: --model, else DEFAULT_MODEL
    windage = "tanker-a/windage.json"         # optional: fit's --windage, for logs with wind

Other keys are errors (a typo must not silently fall back to a default). Or a
directory ``DIR`` with one sub-directory per vessel, named after the vessel, holding
its ``*.csv`` logs (taken in name order) and, for logs with a measured wind, its
``windage.json`` (as ``scenarios synthesize`` writes it beside logs at sea); hidden
sub-directories, and ``OUT`` when it lies inside ``DIR``, are not vessels.
"""

from __future__ import annotations

import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path

from fmu_model import model_names
from trials.errors import one_line

__all__ = ["ManifestError", "VesselSpec", "read_vessels"]

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")
_RESERVED_NAMES = frozenset({"summary.csv", "summary.md"})
_VESSEL_KEYS = frozenset({"name", "logs", "length_m", "model", "windage"})
WINDAGE_FILE = "windage.json"
"""A vessel folder's windage (``identifier.wind.read_windage``), when it has one."""


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
        self.message = one_line(message)
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
    windage : pathlib.Path, optional
        Its windage file (absolute path; fit's ``--windage``); none when None.

    """

    name: str
    logs: tuple[Path, ...]
    length_m: float | None = None
    model: str | None = None
    windage: Path | None = None


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
        windage = table.get("windage")
        if windage is not None and (not isinstance(windage, str) or not windage):
            raise ManifestError(path, f"{where}: 'windage' must be a file name, got {windage!r}")
        vessels.append(
            VesselSpec(
                name=name,
                logs=tuple(base / p for p in logs),
                length_m=None if length is None else float(length),
                model=model,
                windage=None if windage is None else base / windage,
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
        windage = folder / WINDAGE_FILE
        vessels.append(
            VesselSpec(
                name=name,
                logs=tuple(sorted(folder.glob("*.csv"))),
                windage=windage if windage.is_file() else None,
            )
        )
    return tuple(vessels)
