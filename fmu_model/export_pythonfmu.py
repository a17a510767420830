"""The pythonfmu backend: an FMI 2.0 co-simulation FMU that runs ``fmu_model`` in Python.

This is the second FMU backend (``build_fmu.py --backend pythonfmu``); the native C FMU
is the default and needs no Python. The FMU built here has the same interface
(``fmu_model.interface.fmu_variables``: names, value references, causality, variability,
start values, units, display units, min/max) and the same numerics (RK4 with
``n_substeps``, inputs held over the step) as the native FMU and as
``fmu_model.simulate(..., method="rk4", max_step_s=...)``.

What travels inside the FMU (``resources/``): the slave script
(``fmu_model/pythonfmu_slave.py``), ``params.json``, ``fmu_settings.json`` (the
``max_step`` start value), the ``fmu_model`` package sources and pythonfmu's own Python
sources; ``binaries/`` holds pythonfmu's generic wrapper library (linux64 and win64 in
pythonfmu 0.7; no macOS binary).

Run-time requirements: the importing tool must load a Python 3 interpreter into its
process through pythonfmu's wrapper (``needsExecutionTool="true"``), and that Python
needs **numpy and sympy** installed (``fmu_model`` compiles the model equations with
``sympy.lambdify`` at instantiation), and any other third-party package that the
shipped ``fmu_model`` modules import at module level. The shipped ``fmu_model`` copy is
found first (pythonfmu puts ``resources/`` at the front of ``sys.path``), unless the
host process has already imported another ``fmu_model``.

pythonfmu 0.7 declares neither units, display units nor min/max, writes start values with
16 significant digits and lists no ``InitialUnknowns``. Its modelDescription.xml is
therefore replaced by the one the native exporter also writes
(:func:`fmu_model.model_description.model_description_xml`, with pythonfmu's model
identifier and GUID and ``needsExecutionTool="true"``), after checking that pythonfmu
declared exactly the variables of ``fmu_variables``. For the status mapping of bad input
see ``fmu_model.pythonfmu_slave``.
"""

from __future__ import annotations

import io
import json
import shutil
import sys
import tempfile
import xml.etree.ElementTree as ET
import zipfile
from collections.abc import Sequence
from pathlib import Path

from fmu_model.atomic import write_atomic
from fmu_model.errors import FmuBuildError
from fmu_model.interface import FmuVariable, fmu_variables
from fmu_model.model_description import generation_tool, model_description_xml
from fmu_model.params import ModelParameters, save_params
from fmu_model.pythonfmu_slave import PARAMS_RESOURCE, SETTINGS_RESOURCE

_PACKAGE_DIR = Path(__file__).resolve().parent
_SLAVE_SCRIPT = _PACKAGE_DIR / "pythonfmu_slave.py"


def build_pythonfmu_fmu(
    params: ModelParameters, output: str | Path, *, max_step_s: float | None = None
) -> Path:
    """Build the FMI 2.0 co-simulation FMU of ``params`` with pythonfmu.

    Parameters
    ----------
    params : ModelParameters
        Model variant, coefficients and vessel data; saved inside the FMU as params.json.
    output : str or pathlib.Path
        The .fmu file to write (atomically; parent directories are created).
    max_step_s : float, optional
        Start value of the ``max_step`` parameter, the largest internal RK4 step [s];
        default ``fmu_model.interface.DEFAULT_MAX_STEP_S``.

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    FmuBuildError
        Non-finite coefficients or vessel data, a bad ``max_step_s`` (the checks of
        :func:`fmu_model.interface.fmu_variables`), pythonfmu fails, or its
        modelDescription.xml does not match ``fmu_variables``. Nothing is written then.

    """
    output = Path(output)
    variables = fmu_variables(params, max_step_s)
    max_step = next(v.start for v in variables if v.name == "max_step")
    with tempfile.TemporaryDirectory(prefix="shipfmu_pythonfmu_") as tmp:
        stage = Path(tmp, "stage")
        stage.mkdir()
        script = stage / _SLAVE_SCRIPT.name
        shutil.copyfile(_SLAVE_SCRIPT, script)
        save_params(stage / PARAMS_RESOURCE, params)
        settings = stage / SETTINGS_RESOURCE
        settings.write_text(json.dumps({"max_step_s": max_step}) + "\n", encoding="utf-8")
        package = stage / _PACKAGE_DIR.name
        package.mkdir()
        for source in sorted(_PACKAGE_DIR.glob("*.py")):
            shutil.copyfile(source, package / source.name)
        raw = _run_pythonfmu(
            script, Path(tmp, "pythonfmu.fmu"), [stage / PARAMS_RESOURCE, settings, package]
        )
        data = _complete_fmu(raw, params, variables)
    write_atomic(output, data)
    return output


def _run_pythonfmu(script: Path, dest: Path, project_files: Sequence[Path]) -> Path:
    """Run pythonfmu's builder, undoing its changes to ``sys.path`` and ``sys.modules``."""
    from pythonfmu.builder import FmuBuilder

    saved_path = list(sys.path)
    module = script.stem
    had_module = module in sys.modules
    try:
        built = FmuBuilder.build_FMU(
            script,
            dest=dest,
            project_files=project_files,
            canGetAndSetFMUstate=True,
            canSerializeFMUstate=True,
        )
    except Exception as exc:
        raise FmuBuildError(f"pythonfmu could not build the FMU: {exc}") from exc
    finally:
        sys.path[:] = saved_path
        if not had_module:
            sys.modules.pop(module, None)
    return Path(built)


def _complete_fmu(raw: Path, params: ModelParameters, variables: Sequence[FmuVariable]) -> bytes:
    """Return the FMU archive with a completed modelDescription.xml, deflate-compressed."""
    buffer = io.BytesIO()
    with (
        zipfile.ZipFile(raw) as source,
        zipfile.ZipFile(buffer, "w", zipfile.ZIP_DEFLATED) as target,
    ):
        for info in source.infolist():
            data = source.read(info)
            if info.filename == "modelDescription.xml":
                data = complete_model_description(data, params, variables)
            target.writestr(info.filename, data)
    return buffer.getvalue()


def complete_model_description(
    xml: bytes, params: ModelParameters, variables: Sequence[FmuVariable]
) -> bytes:
    """Replace pythonfmu's modelDescription.xml by the shared rendering of the interface.

    ``xml`` is pythonfmu's document; its ScalarVariables must be ``variables`` (same
    order, names, value references, causality and variability), since the slave serves
    value references in that order. The result is
    :func:`fmu_model.model_description.model_description_xml` with pythonfmu's model
    identifier and GUID and ``needsExecutionTool="true"``.
    """
    root = ET.fromstring(xml)
    declared = [
        (s.get("name"), s.get("valueReference"), s.get("causality"), s.get("variability"))
        for s in root.findall("ModelVariables/ScalarVariable")
    ]
    expected = [(v.name, str(v.value_reference), v.causality, v.variability) for v in variables]
    if declared != expected:
        raise FmuBuildError(
            "pythonfmu declared variables that differ from fmu_model.interface: "
            f"{declared} != {expected}"
        )
    cosimulation = root.find("CoSimulation")
    identifier = None if cosimulation is None else cosimulation.get("modelIdentifier")
    guid = root.get("guid")
    if not identifier or not guid:
        raise FmuBuildError("pythonfmu wrote no modelIdentifier or GUID")
    try:
        text = model_description_xml(
            params,
            variables,
            model_identifier=identifier,
            guid=guid,
            needs_execution_tool=True,
            tool=f"{generation_tool()} with {root.get('generationTool')}",
        )
    except ValueError as exc:
        raise FmuBuildError(f"cannot describe the FMU: {exc}") from exc
    return text.encode("utf-8")
