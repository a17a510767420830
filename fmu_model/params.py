"""Identified parameter sets and their file format, params.json (DESIGN.md).

``ModelParameters`` is the immutable value passed between the identifier, the FMU
exporters and the scenarios. Vectors follow the coefficient order of the structure
(surge, sway, yaw).
"""

from __future__ import annotations

import json
import math
import os
import unicodedata
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from fmu_model.atomic import write_atomic
from fmu_model.environment import Windage
from fmu_model.structure import ModelStructure
from fmu_model.variants import get_model

PARAMS_FORMAT = "ship-maneuvering-params"
PARAMS_VERSION = 1


class ParamsFormatError(ValueError):
    """A params.json that cannot be used; ``str()`` is one line naming the file."""

    def __init__(self, path: str | None, message: str) -> None:
        self.path = path
        self.message = message
        super().__init__(f"{path}: {message}" if path else message)


@dataclass(frozen=True, eq=False)
class ModelParameters:
    """Coefficients of one model variant for one vessel, with their uncertainty.

    Parameters
    ----------
    model : str
        Registered structure name (``fmu_model.variants``); resolved once, on
        construction, into :attr:`structure`.
    coefficients : numpy.ndarray
        Coefficient vector θ (p,), SI units (see ``units()``).
    length_m : float
        Ship length between perpendiculars [m].
    vessel_name : str
        Vessel name; also the FMU's model name.
    nominal_speed_mps : float
        Approach speed of the trials [m/s].
    nominal_n_rps : float
        Approach propeller speed [rev/s].
    covariance : numpy.ndarray, optional
        Covariance of θ (p, p).
    identification : mapping
        Provenance: method, logs with sha256, settings, creation time.
    windage : Windage, optional
        Above-water areas and effective inertias for the wind load
        (``vessel.windage`` in params.json); ``None``: no wind load.

    """

    model: str
    coefficients: np.ndarray
    length_m: float
    vessel_name: str = "ship"
    nominal_speed_mps: float = 0.0
    nominal_n_rps: float = 0.0
    covariance: np.ndarray | None = None
    identification: Mapping[str, Any] = field(default_factory=dict)
    windage: Windage | None = None
    structure: ModelStructure = field(init=False, repr=False)
    """The model structure named by ``model``."""

    def __post_init__(self) -> None:
        structure = get_model(self.model)
        object.__setattr__(self, "structure", structure)
        theta = np.array(self.coefficients, dtype=float)
        if theta.shape != (structure.n_coefficients,):
            raise ValueError(
                f"model {self.model!r} has {structure.n_coefficients} coefficients, "
                f"got shape {theta.shape}"
            )
        theta.setflags(write=False)
        object.__setattr__(self, "coefficients", theta)
        if self.windage is not None and not isinstance(self.windage, Windage):
            raise TypeError(f"windage must be a Windage, got {type(self.windage).__name__}")
        if self.covariance is not None:
            cov = np.array(self.covariance, dtype=float)
            if cov.shape != (theta.size, theta.size):
                raise ValueError(f"covariance must be {theta.size}x{theta.size}")
            cov.setflags(write=False)
            object.__setattr__(self, "covariance", cov)

    @property
    def names(self) -> tuple[str, ...]:
        """Coefficient names in vector order."""
        return self.structure.coefficient_names

    @property
    def std(self) -> np.ndarray | None:
        """Standard deviations of the coefficients (sqrt of the covariance diagonal)."""
        if self.covariance is None:
            return None
        return np.sqrt(np.clip(np.diag(self.covariance), 0.0, None))

    def to_vector(self) -> np.ndarray:
        """Coefficient vector θ (a read-only view)."""
        return self.coefficients

    def with_vector(
        self, theta: np.ndarray, covariance: np.ndarray | None = None
    ) -> ModelParameters:
        """Return the same vessel and model with new coefficients (and covariance)."""
        return replace(self, coefficients=theta, covariance=covariance)

    @classmethod
    def from_vector(
        cls, model: str, theta: Sequence[float] | np.ndarray, **kwargs: Any
    ) -> ModelParameters:
        """Build from a coefficient vector in the structure's order."""
        return cls(model=model, coefficients=np.asarray(theta, dtype=float), **kwargs)

    def as_dict(self) -> dict[str, float]:
        """Coefficients by name."""
        return dict(zip(self.names, map(float, self.coefficients), strict=True))

    def units(self) -> dict[str, str]:
        """SI unit of every coefficient, e.g. ``{"a1": "1/m", ...}``."""
        from fmu_model.structure import unit_string

        return {k: unit_string(d) for k, d in self.structure.coefficient_units().items()}

    def to_json_dict(self) -> dict[str, Any]:
        """Return the params.json document (DESIGN.md) as a dict."""
        std = self.std
        vessel: dict[str, Any] = {"name": self.vessel_name, "length_m": self.length_m}
        if self.windage is not None:
            vessel["windage"] = self.windage.to_dict()
        return {
            "format": PARAMS_FORMAT,
            "version": PARAMS_VERSION,
            "model": self.model,
            "vessel": vessel,
            "nominal": {"speed_mps": self.nominal_speed_mps, "rpm": self.nominal_n_rps * 60.0},
            "coefficients": self.as_dict(),
            "units": self.units(),
            "std": None if std is None else dict(zip(self.names, map(float, std), strict=True)),
            "covariance": None if self.covariance is None else self.covariance.tolist(),
            "identification": dict(self.identification),
        }


def _require(
    doc: Mapping[str, Any], key: str, kind: type | tuple[type, ...], path: str | None
) -> Any:
    if key not in doc:
        raise ParamsFormatError(path, f"missing key {key!r}")
    value = doc[key]
    if not isinstance(value, kind) or isinstance(value, bool):
        raise ParamsFormatError(path, f"{key!r} has the wrong type ({type(value).__name__})")
    return value


def _finite(value: Any, what: str, path: str | None) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool):
        raise ParamsFormatError(path, f"{what} must be a finite number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:  # an integer beyond the floating-point range (JSON allows it)
        raise ParamsFormatError(
            path, f"{what} must be a finite number, got {_huge(int(value))}"
        ) from None
    if not math.isfinite(number):
        raise ParamsFormatError(path, f"{what} must be a finite number, got {value!r}")
    return number


def _huge(value: int) -> str:
    """Describe an integer too large for a float without printing its digits."""
    try:
        digits = f"{len(str(abs(value)))} digits"
    except ValueError:  # beyond Python's int-to-text limit
        digits = "thousands of digits"
    return f"an integer of {digits} (beyond the floating-point range)"


def _covariance_matrix(covariance: Any, path: str | None) -> np.ndarray:
    """Return the covariance as floats, or raise a one-line ParamsFormatError."""
    try:
        return np.array(covariance, dtype=float)
    except OverflowError:
        message = _huge_entry(covariance)
    except (TypeError, ValueError):
        message = "covariance must be a matrix of numbers"
    raise ParamsFormatError(path, message)


def _huge_entry(matrix: Any) -> str:
    """Name the first integer entry of a nested list that no float can hold."""
    rows = matrix if isinstance(matrix, list) else []
    for i, row in enumerate(rows):
        for j, entry in enumerate(row if isinstance(row, list) else []):
            if isinstance(entry, int) and not isinstance(entry, bool):
                try:
                    float(entry)
                except OverflowError:
                    return f"covariance[{i}][{j}] must be a finite number, got {_huge(entry)}"
    return "covariance has a number beyond the floating-point range"


def text_problem(text: str) -> str | None:
    """Return why ``text`` cannot be a name in an FMU (``None`` when it can).

    A vessel name becomes the FMU's ``modelName`` (XML) and a string in its C source:
    it must be Unicode text (no lone surrogate, which UTF-8 cannot encode) without
    control characters (C0, DEL, C1: invalid in XML 1.0 or a terminal escape) and
    without the non-characters U+FFFE and U+FFFF (invalid in XML).

    Parameters
    ----------
    text : str
        The name.

    Returns
    -------
    str or None
        E.g. ``"contains a control character U+001B at character 7; expected printable
        text"``, or ``None``.

    """
    for position, char in enumerate(text, start=1):
        code = ord(char)
        if 0xD800 <= code <= 0xDFFF:
            what = "a lone surrogate"
        elif unicodedata.category(char) == "Cc":
            what = "a control character"
        elif code in (0xFFFE, 0xFFFF):
            what = "the non-character"
        else:
            continue
        return f"contains {what} U+{code:04X} at character {position}; expected printable text"
    return None


def _vessel_name(vessel: Mapping[str, Any], path: str | None) -> str:
    name = vessel.get("name")
    if name is None or name == "":
        return "ship"
    if not isinstance(name, str):
        raise ParamsFormatError(path, f"vessel.name must be a string, got {type(name).__name__}")
    problem = text_problem(name)
    if problem is not None:
        raise ParamsFormatError(path, f"vessel.name {problem}")
    return name


def params_from_json_dict(doc: Any, path: str | None = None) -> ModelParameters:
    """Validate a params.json document and build :class:`ModelParameters`.

    Raises
    ------
    ParamsFormatError
        Wrong format or version, unknown model, missing or extra coefficients, a
        non-finite number (also an integer beyond the floating-point range), a negative
        length, a vessel name that is not a string or has a control character or a lone
        surrogate (:func:`text_problem`), a covariance that is not a symmetric p × p
        matrix of finite numbers with a non-negative diagonal, a ``vessel.windage``
        (optional) that :meth:`fmu_model.environment.Windage.from_dict` refuses.

    """
    if not isinstance(doc, Mapping):
        raise ParamsFormatError(path, "expected a JSON object")
    if doc.get("format") != PARAMS_FORMAT:
        raise ParamsFormatError(path, f"not a params file (format must be {PARAMS_FORMAT!r})")
    version = doc.get("version")
    if not isinstance(version, int) or isinstance(version, bool) or version != PARAMS_VERSION:
        raise ParamsFormatError(
            path, f"unsupported version {doc.get('version')!r} (this tool reads {PARAMS_VERSION})"
        )
    model = _require(doc, "model", str, path)
    try:
        structure = get_model(model)
    except KeyError as exc:
        raise ParamsFormatError(path, str(exc.args[0])) from None
    vessel = _require(doc, "vessel", Mapping, path)
    length = _finite(vessel.get("length_m"), "vessel.length_m", path)
    if length <= 0.0:
        raise ParamsFormatError(path, f"vessel.length_m must be positive, got {length}")
    nominal = _require(doc, "nominal", Mapping, path)
    coefficients = _require(doc, "coefficients", Mapping, path)
    names = structure.coefficient_names
    missing = [k for k in names if k not in coefficients]
    extra = [k for k in coefficients if k not in names]
    if missing or extra:
        raise ParamsFormatError(
            path, f"coefficients for model {model!r}: missing {missing}, unexpected {extra}"
        )
    theta = np.array([_finite(coefficients[k], f"coefficient {k}", path) for k in names])
    covariance = doc.get("covariance")
    cov: np.ndarray | None = None
    if covariance is not None:
        cov = _covariance_matrix(covariance, path)
        p = len(names)
        if cov.shape != (p, p):
            raise ParamsFormatError(path, f"covariance must be {p}x{p}, got shape {cov.shape}")
        if not np.all(np.isfinite(cov)):
            raise ParamsFormatError(path, "covariance contains NaN or infinite values")
        scale = max(float(np.max(np.abs(cov))), np.finfo(float).tiny)
        if np.max(np.abs(cov - cov.T)) > 1e-9 * scale:
            raise ParamsFormatError(path, "covariance is not symmetric")
        if np.any(np.diag(cov) < 0.0):
            raise ParamsFormatError(path, "covariance has a negative variance on its diagonal")
    identification = doc.get("identification") or {}
    if not isinstance(identification, Mapping):
        raise ParamsFormatError(path, "'identification' must be an object")
    windage = None
    if vessel.get("windage") is not None:
        try:
            windage = Windage.from_dict(vessel["windage"])
        except ValueError as exc:
            raise ParamsFormatError(path, f"vessel.{exc}") from None
    return ModelParameters(
        model=model,
        coefficients=theta,
        length_m=length,
        vessel_name=_vessel_name(vessel, path),
        nominal_speed_mps=_finite(nominal.get("speed_mps", 0.0), "nominal.speed_mps", path),
        nominal_n_rps=_finite(nominal.get("rpm", 0.0), "nominal.rpm", path) / 60.0,
        covariance=cov,
        identification=identification,
        windage=windage,
    )


def load_params(path: str | os.PathLike[str]) -> ModelParameters:
    """Read and validate a params.json file (see :func:`params_from_json_dict`)."""
    return params_from_json_dict(read_json(path), str(path))


def read_json(path: str | os.PathLike[str]) -> Any:
    """Return the JSON document of a file; :class:`ParamsFormatError` (one line) if it is none.

    The message names the file (and the line of a JSON syntax error).
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ParamsFormatError(name, "file not found") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ParamsFormatError(name, f"cannot read: {exc}") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ParamsFormatError(f"{name}:{exc.lineno}", f"invalid JSON: {exc.msg}") from None
    except (ValueError, RecursionError) as exc:  # e.g. huge integers, absurd nesting
        raise ParamsFormatError(name, f"invalid JSON: {str(exc).splitlines()[0]}") from None
    return doc


def save_params(path: str | os.PathLike[str], params: ModelParameters) -> None:
    """Write params.json atomically (temporary file + rename)."""
    write_atomic(path, json.dumps(params.to_json_dict(), indent=2, allow_nan=False) + "\n")
