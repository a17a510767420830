"""Native FMU (FMI 2.0 or 3.0, co-simulation and/or model exchange) from one model part.

The FMU is the hand-written FMI layer of ``fmu_model/c/`` - one file per FMI API
version (``fmi2_functions.c``, ``fmi3_functions.c``), each including the shared helpers
``ship_common.c`` and the contract ``ship_fmu.h`` - compiled together with two
generated headers (after the Reference-FMUs layout: FMI layer, ``config.h``, ``model.c``):

* ``model_equations.h`` - the right-hand side and its exact Jacobians from
  :func:`fmu_model.codegen.generate_model_c`;
* ``model_config.h`` - GUID, value-reference layout, the variable table (start, min,
  max, causality) from :func:`fmu_model.interface.fmu_variables`, and the rules and
  messages of :mod:`fmu_model.fmi_rules` (divergence, step, least start speed,
  restored states).

The FMI API file, ``ship_common.c``, ``ship_fmu.h`` and the two headers go into the
FMU's ``sources/`` (the API file is the one file to compile: ``<SourceFiles>`` in FMI
2.0, ``sources/buildDescription.xml`` in FMI 3.0; the FMI headers come from the
importing tool, e.g. fmpy), so ``fmpy compile`` rebuilds the binary for another platform.
One binary serves every kind the model description declares.

Behaviour of the FMU: see the header comment of ``ship_common.c``; the statuses are
those of FMI 2.0 and 3.0 alike (error: nothing changed; discard: a diverged state or a
status the FMU cannot give; never fatal). Messages go to the logger callback.
"""

from __future__ import annotations

import io
import math
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from fmu_model.atomic import write_atomic
from fmu_model.codegen import generate_model_c
from fmu_model.envelope import (
    DEG_PER_RAD,
    EXTRAPOLATION_FORMAT,
    MARGIN,
    MIN_SPEED_RATIO_FOR_YAW_RATE,
    RPM_PER_RPS,
    RUDDER_FORMAT,
    SPAN_FORMAT,
    SPAN_VALUE_FORMAT,
    SPEED_RATIO_FORMAT,
    SPEED_RATIO_MARGIN,
    YAW_RATE_FORMAT,
    Envelope,
    Sides,
    Span,
)
from fmu_model.errors import FmuBuildError
from fmu_model.fmi_rules import (
    DIVERGED_STATE_FORMAT,
    DIVERGENCE_FORMAT,
    MAX_SPEED_MPS,
    MAX_SUBSTEPS,
    MAX_YAW_RATE_RADPS,
    START_SPEED_FORMAT,
    STATE_NONFINITE_FORMAT,
    STATE_RANGE_FORMAT,
    STEP_SIZE_FORMAT,
    STEP_TIME_FORMAT,
    STEP_TIME_TOLERANCE,
    SUBSTEP_LIMIT_FORMAT,
    TIME_STALL_FORMAT,
    WINDAGE_COUPLING_FORMAT,
    FmuVariable,
    model_identifier,
)
from fmu_model.interface import (
    ENVIRONMENT_NAMES,
    GROUND_NAMES,
    WINDAGE_NAMES,
    derivative_name,
    fmu_variables,
    logged_envelope,
    min_start_speed_mps,
)
from fmu_model.model_description import (
    GUID_PLACEHOLDER,
    KINDS,
    build_description_xml,
    content_guid,
    generation_time,
    model_description_fmi3_xml,
    model_description_xml,
    osp_model_description_xml,
)
from fmu_model.params import ModelParameters
from fmu_model.structure import STATE_NAMES, ModelStructure

__all__ = [
    "C_DIR",
    "FMI_VERSIONS",
    "KINDS",
    "NativeFmuText",
    "build_native_fmu",
    "fmi_headers_dir",
    "generate_sources",
    "model_identifier",  # of fmu_model.interface, for the callers that name the .fmu
    "osp_sidecar_path",
    "render_native_fmu",
]

C_DIR = Path(__file__).with_name("c")
# The FMI versions the native layer implements, and the file of each (the one to compile).
FMI_VERSIONS = ("2", "3")
LAYER_SOURCES = {"2": "fmi2_functions.c", "3": "fmi3_functions.c"}
COMMON_SOURCE = "ship_common.c"
LAYER_HEADER = "ship_fmu.h"
CONFIG_HEADER = "model_config.h"
EQUATIONS_HEADER = "model_equations.h"
BUILD_DESCRIPTION = "buildDescription.xml"
# -ffp-contract=off: no fused multiply-add, so the RK4 rounds as numpy does.
CFLAGS = ("-shared", "-fPIC", "-O2", "-std=c99", "-ffp-contract=off", "-fvisibility=hidden")
# Binary folder (FMI 2.0 section 2.3, FMI 3.0 section 2.5.1.4) and library suffix per
# sys.platform.
_PLATFORMS = {
    "linux": ({"2": "linux64", "3": "x86_64-linux"}, ".so"),
    "darwin": ({"2": "darwin64", "3": "x86_64-darwin"}, ".dylib"),
}


def osp_sidecar_path(fmu_path: str | os.PathLike[str]) -> Path:
    """``<stem>_OspModelDescription.xml`` next to the FMU (the OSP-IS convention)."""
    path = Path(fmu_path)
    return path.with_name(f"{path.stem}_OspModelDescription.xml")


def fmi_headers_dir() -> Path:
    """Directory of the FMI 2.0 and 3.0 headers shipped with fmpy (``fmi2Functions.h`` ...)."""
    import fmpy

    directory = Path(fmpy.__file__).parent / "c-code"
    for header in ("fmi2Functions.h", "fmi3Functions.h"):
        if not (directory / header).is_file():
            raise FmuBuildError(
                f"FMI header {header} not found in {directory} (is fmpy installed?)"
            )
    return directory


def _c_string(text: str) -> str:
    """C string literal of text (anything but printable ASCII escaped in octal UTF-8)."""
    out = []
    for char in text:
        code = ord(char)
        if char in '"\\':
            out.append("\\" + char)
        elif 32 <= code < 127:
            out.append(char)
        else:
            try:
                encoded = char.encode("utf-8")
            except UnicodeEncodeError:  # a lone surrogate: not Unicode text
                raise FmuBuildError(f"cannot write {text!r} as C: U+{code:04X}") from None
            out.extend(f"\\{byte:03o}" for byte in encoded)
    return '"' + "".join(out) + '"'


def _c_double(value: float) -> str:
    if not math.isfinite(value):
        raise FmuBuildError(f"non-finite value {value!r} in the FMU interface")
    return repr(float(value))


def _layout(variables: tuple[FmuVariable, ...], structure: ModelStructure) -> dict[str, int]:
    """Value references the C layer needs, checking the layout it relies on."""
    if [v.value_reference for v in variables] != list(range(len(variables))):
        raise FmuBuildError("FMU variables must have value references 0, 1, ... in order")
    position = {v.name: v.value_reference for v in variables}

    def block(names: tuple[str, ...], what: str) -> int:
        try:
            refs = [position[name] for name in names]
        except KeyError as exc:
            raise FmuBuildError(f"FMU interface lacks variable {exc.args[0]!r}") from None
        if refs != list(range(refs[0], refs[0] + len(refs))):
            raise FmuBuildError(f"FMU variables of the {what} must be consecutive in {names}")
        return refs[0]

    layout = {
        "VR_RUDDER_ANGLE": block(("rudder_angle",), "rudder angle"),
        "VR_PROPELLER_RPM": block(("propeller_rpm",), "propeller speed"),
        "VR_STATE": block(STATE_NAMES, "state"),
        "VR_LENGTH": block(("length",), "length"),
        "VR_MAX_STEP": block(("max_step",), "max step"),
        "VR_INITIAL_STATE": block(tuple(f"{name}0" for name in STATE_NAMES), "initial state"),
        "VR_COEFFICIENTS": block(structure.coefficient_names, "coefficients"),
        "VR_DERIVATIVES": block(tuple(derivative_name(n) for n in STATE_NAMES), "derivatives"),
        "VR_TIME": block(("time",), "time"),
        "VR_ENVIRONMENT": block(ENVIRONMENT_NAMES, "environment"),
        "VR_GROUND": block(GROUND_NAMES, "outputs over ground"),
        "VR_WINDAGE": block(WINDAGE_NAMES, "windage"),
    }
    expected = {
        "VR_RUDDER_ANGLE": ("input", 1),
        "VR_PROPELLER_RPM": ("input", 1),
        "VR_STATE": ("output", len(STATE_NAMES)),
        "VR_DERIVATIVES": ("local", len(STATE_NAMES)),
        "VR_TIME": ("independent", 1),
        "VR_ENVIRONMENT": ("input", len(ENVIRONMENT_NAMES)),
        "VR_GROUND": ("output", len(GROUND_NAMES)),
        "VR_WINDAGE": ("parameter", len(WINDAGE_NAMES)),
    }
    for key, (causality, count) in expected.items():
        block_variables = variables[layout[key] : layout[key] + count]
        if any(v.causality != causality for v in block_variables):
            raise FmuBuildError(f"{key}: variables must have causality {causality!r}")
    return layout


def _envelope_lines(envelope: Envelope | None) -> list[str]:
    """Return the envelope block of ``model_config.h`` (without one: zeros, not used)."""
    nothing, none = Sides(0.0, 0.0), Span(0.0, 0.0)
    known = envelope or Envelope(nothing, nothing, 0.0, none, none)
    values = {
        "RUDDER_PORT": known.rudder_max_rad.port,
        "RUDDER_STARBOARD": known.rudder_max_rad.starboard,
        "YAW_RATE_PORT": known.yaw_rate_max.port,
        "YAW_RATE_STARBOARD": known.yaw_rate_max.starboard,
        "SPEED_RATIO_MIN": known.speed_ratio_min,
        "APPROACH_LOW": known.approach_speed_mps.low,
        "APPROACH_HIGH": known.approach_speed_mps.high,
        "PROPELLER_LOW": known.propeller_rate_rps.low,
        "PROPELLER_HIGH": known.propeller_rate_rps.high,
        "MARGIN": MARGIN,
        "SPEED_RATIO_MARGIN": SPEED_RATIO_MARGIN,
        "MIN_SPEED_RATIO_FOR_YAW_RATE": MIN_SPEED_RATIO_FOR_YAW_RATE,
        "DEG_PER_RAD": DEG_PER_RAD,
        "RPM_PER_RPS": RPM_PER_RPS,
    }
    formats = {
        "ENVELOPE_RUDDER_FORMAT": RUDDER_FORMAT,
        "ENVELOPE_YAW_RATE_FORMAT": YAW_RATE_FORMAT,
        "ENVELOPE_SPEED_RATIO_FORMAT": SPEED_RATIO_FORMAT,
        "ENVELOPE_SPAN_VALUE_FORMAT": SPAN_VALUE_FORMAT,
        "ENVELOPE_SPAN_FORMAT": SPAN_FORMAT,
        "EXTRAPOLATION_FORMAT": EXTRAPOLATION_FORMAT,
    }
    return [
        "/* The envelope of the identification's logs (fmu_model.envelope, params.json",
        "   identification.envelope): rudder [rad] and r' to port and starboard, lowest U/U0,",
        "   approach speeds [m/s] and propeller speeds [rev/s]; DoStep warns once per axis",
        "   beyond it. MODEL_HAS_ENVELOPE 0: none recorded, no warnings. */",
        f"#define MODEL_HAS_ENVELOPE {0 if envelope is None else 1}",
        *(f"#define ENVELOPE_{key} {_c_double(value)}" for key, value in values.items()),
        *(f"#define {key} {_c_string(text)}" for key, text in formats.items()),
    ]


def _config_header(
    identifier: str,
    guid: str,
    variables: tuple[FmuVariable, ...],
    layout: dict[str, int],
    min_start_speed: float,
    envelope: Envelope | None,
) -> str:
    causality = {
        "input": "SHIP_INPUT",
        "output": "SHIP_OUTPUT",
        "parameter": "SHIP_PARAMETER",
        "local": "SHIP_LOCAL",
        "independent": "SHIP_INDEPENDENT",
    }
    lines = [
        "/* Generated by fmu_model.export_native from fmu_model.interface.fmu_variables. */",
        "/* Do not edit: rebuild the FMU with build_fmu.py. See ship_fmu.h for the contract. */",
        "#ifndef MODEL_CONFIG_H",
        "#define MODEL_CONFIG_H",
        "",
        f'#include "{LAYER_HEADER}"',
        "",
        f"#define MODEL_GUID {_c_string(guid)}",
        f"#define MODEL_IDENTIFIER_NAME {_c_string(identifier)}",
        f"#define MODEL_N_VARIABLES {len(variables)}",
        *(f"#define {key} {value}" for key, value in layout.items()),
        "",
        "/* Divergence rule (fmu_model.fmi_rules): a state that is non-finite or beyond these",
        "   bounds [m/s, rad/s] ends DoStep, or a derivative evaluation, with a discard. */",
        f"#define DIVERGENCE_MAX_SPEED {_c_double(MAX_SPEED_MPS)}",
        f"#define DIVERGENCE_MAX_YAW_RATE {_c_double(MAX_YAW_RATE_RADPS)}",
        f"#define DIVERGENCE_FORMAT {_c_string(DIVERGENCE_FORMAT)}",
        f"#define DIVERGED_STATE_FORMAT {_c_string(DIVERGED_STATE_FORMAT)}",
        "",
        "/* Rules of DoStep and of the start (fmu_model.fmi_rules): a positive finite step at",
        "   the FMU's time that advances it, the largest number of internal steps of one",
        "   call, the least start speed sqrt(u0^2 + v0^2) [m/s] (0: starts from rest). */",
        f"#define STEP_SIZE_FORMAT {_c_string(STEP_SIZE_FORMAT)}",
        f"#define STEP_TIME_FORMAT {_c_string(STEP_TIME_FORMAT)}",
        f"#define STEP_TIME_TOLERANCE {_c_double(STEP_TIME_TOLERANCE)}",
        f"#define MAX_SUBSTEPS {_c_double(float(MAX_SUBSTEPS))}",
        f"#define SUBSTEP_LIMIT_FORMAT {_c_string(SUBSTEP_LIMIT_FORMAT)}",
        f"#define TIME_STALL_FORMAT {_c_string(TIME_STALL_FORMAT)}",
        f"#define MIN_START_SPEED {_c_double(min_start_speed)}",
        f"#define START_SPEED_FORMAT {_c_string(START_SPEED_FORMAT)}",
        "",
        "/* The windage's sway-yaw mass matrix must not be singular: the offsets of m + m_y,",
        "   I_z + J_z and x_G m in the windage block, and the message of a refused one. */",
        *(
            f"#define WINDAGE_{name.upper()} {WINDAGE_NAMES.index(name)}"
            for name in ("sway_mass", "yaw_inertia", "sway_yaw_coupling")
        ),
        f"#define WINDAGE_COUPLING_FORMAT {_c_string(WINDAGE_COUPLING_FORMAT)}",
        "",
        "/* Messages of a restored FMU state with a value fmi2SetReal would refuse. */",
        f"#define STATE_RANGE_FORMAT {_c_string(STATE_RANGE_FORMAT)}",
        f"#define STATE_NONFINITE_FORMAT {_c_string(STATE_NONFINITE_FORMAT)}",
        "",
        *_envelope_lines(envelope),
        "",
        "/* name, causality, start, has_min, min, has_max, max; index = value reference */",
        "static const ShipVariable MODEL_VARIABLES[MODEL_N_VARIABLES] = {",
    ]
    for var in variables:
        if var.causality not in causality:
            raise FmuBuildError(f"variable {var.name!r}: unsupported causality {var.causality!r}")
        start = (
            0.0 if var.start is None or var.causality not in ("input", "parameter") else var.start
        )
        fields = [
            _c_string(var.name),
            causality[var.causality],
            _c_double(start),
            "1" if var.min is not None else "0",
            _c_double(var.min if var.min is not None else 0.0),
            "1" if var.max is not None else "0",
            _c_double(var.max if var.max is not None else 0.0),
        ]
        lines.append(f"    {{{', '.join(fields)}}}, /* vr {var.value_reference} */")
    lines += ["};", "", "#endif /* MODEL_CONFIG_H */", ""]
    return "\n".join(lines)


def _check_target(fmi_version: str, kinds: tuple[str, ...]) -> None:
    if fmi_version not in FMI_VERSIONS:
        raise FmuBuildError(f"FMI version must be one of {FMI_VERSIONS}, got {fmi_version!r}")
    if not kinds or set(kinds) - set(KINDS) or len(set(kinds)) != len(kinds):
        raise FmuBuildError(f"kinds must be one or both of {KINDS}, got {kinds}")


def generate_sources(
    params: ModelParameters,
    *,
    max_step_s: float | None = None,
    guid: str = GUID_PLACEHOLDER,
    fmi_version: str = "2",
) -> dict[str, str]:
    """Return the C files of the FMU's ``sources/`` folder, by name.

    Parameters
    ----------
    params : ModelParameters
        Identified model: structure, coefficients, vessel.
    max_step_s : float, optional
        Start value of ``max_step`` [s]; default ``fmu_model.interface.DEFAULT_MAX_STEP_S``.
    guid : str
        The FMU's GUID (instantiation token), written into ``model_config.h``.
    fmi_version : {"2", "3"}
        The FMI API version: which layer file (``fmi2_functions.c`` or
        ``fmi3_functions.c``) is the one to compile.

    Returns
    -------
    dict of str to str
        The layer file, ``ship_common.c``, ``ship_fmu.h``, ``model_config.h`` and
        ``model_equations.h``.

    Raises
    ------
    FmuBuildError
        For parameters :func:`fmu_model.interface.fmu_variables` rejects, an interface
        the C layer cannot serve, or an unknown FMI version.

    """
    _check_target(fmi_version, KINDS)
    structure = params.structure
    variables = fmu_variables(params, max_step_s)
    identifier = model_identifier(params.vessel_name)
    layout = _layout(variables, structure)
    layer = LAYER_SOURCES[fmi_version]
    return {
        layer: (C_DIR / layer).read_text(encoding="utf-8"),
        COMMON_SOURCE: (C_DIR / COMMON_SOURCE).read_text(encoding="utf-8"),
        LAYER_HEADER: (C_DIR / LAYER_HEADER).read_text(encoding="utf-8"),
        CONFIG_HEADER: _config_header(
            identifier,
            guid,
            variables,
            layout,
            min_start_speed_mps(structure),
            logged_envelope(params),
        ),
        EQUATIONS_HEADER: generate_model_c(structure),
    }


def _compiler(cc: str | None) -> list[str]:
    """Command of the C compiler: ``cc`` argument, else ``$CC``, else cc / gcc / clang."""
    spec = cc if cc is not None else os.environ.get("CC")
    if spec:
        argv = shlex.split(spec)
        if not argv or shutil.which(argv[0]) is None:
            origin = "cc argument" if cc is not None else "$CC"
            raise FmuBuildError(f"C compiler {spec!r} not found ({origin})")
        return argv
    for name in ("cc", "gcc", "clang"):
        if shutil.which(name):
            return [name]
    raise FmuBuildError("no C compiler found (install gcc or clang, or set $CC)")


def _first_error_line(output: str) -> str:
    lines = [line.strip() for line in output.splitlines() if line.strip()]
    for line in lines:
        if "error" in line.lower():
            return line
    return lines[0] if lines else "no compiler output"


def _compile(sources: Path, layer: str, library: Path, compiler: list[str]) -> None:
    command = [
        *compiler,
        *CFLAGS,
        "-I",
        str(fmi_headers_dir()),
        "-I",
        ".",
        layer,
        "-o",
        str(library),
        "-lm",
    ]
    try:
        result = subprocess.run(
            command, cwd=sources, capture_output=True, text=True, timeout=300, check=False
        )
    except OSError as exc:
        raise FmuBuildError(f"cannot run C compiler {compiler[0]!r}: {exc.strerror}") from None
    except subprocess.TimeoutExpired:
        raise FmuBuildError(f"C compiler {compiler[0]!r} timed out") from None
    if result.returncode != 0:
        line = _first_error_line(result.stderr or result.stdout)
        raise FmuBuildError(f"C compilation failed ({compiler[0]}): {line}")


def _zip(entries: list[tuple[str, bytes]], stamp: datetime) -> bytes:
    """Zip archive with fixed time stamps and permissions (reproducible bytes)."""
    stamp = max(stamp.astimezone(UTC), datetime(1980, 1, 1, tzinfo=UTC))
    date_time = stamp.timetuple()[:6]
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, "w") as archive:
        for name, data in entries:
            info = zipfile.ZipInfo(name, date_time=date_time)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.external_attr = (0o755 if name.startswith("binaries/") else 0o644) << 16
            archive.writestr(info, data)
    return buffer.getvalue()


@dataclass(frozen=True)
class NativeFmuText:
    """Everything of a native FMU except its binary (see :func:`render_native_fmu`).

    Attributes
    ----------
    model_identifier : str
        C-safe identifier; the library is ``binaries/<platform>/<model_identifier>.so``.
    guid : str
        Content-derived GUID (FMI 3.0: instantiation token), in ``model_description``
        and ``model_config.h``.
    fmi_version : str
        ``"2"`` or ``"3"``.
    kinds : tuple of str
        ``"cs"`` and/or ``"me"``.
    model_description : str
        ``modelDescription.xml``.
    osp_model_description : str
        The OSP-IS sidecar ``<stem>_OspModelDescription.xml``.
    sources : dict of str to str
        Files of ``sources/`` by name (FMI 3.0: with ``buildDescription.xml``).
    layer_source : str
        The one file of ``sources`` to compile.
    created : datetime
        ``generationDateAndTime``, also the time stamp of the zip entries.

    """

    model_identifier: str
    guid: str
    fmi_version: str
    kinds: tuple[str, ...]
    model_description: str
    osp_model_description: str
    sources: dict[str, str]
    layer_source: str
    created: datetime


def render_native_fmu(
    params: ModelParameters,
    *,
    max_step_s: float | None = None,
    fmi_version: str = "2",
    kinds: tuple[str, ...] = KINDS,
) -> NativeFmuText:
    """Generate the texts of the native FMU (no compiler needed).

    The GUID is a hash of the model description and the sources (rendered with a
    placeholder GUID), so any change of coefficients, interface, FMI version, kinds or
    C layer changes it.

    Parameters
    ----------
    params : ModelParameters
        Identified model: variant, coefficients, vessel.
    max_step_s : float, optional
        Start value of ``max_step`` [s].
    fmi_version : {"2", "3"}
        FMI 2.0 or FMI 3.0.
    kinds : tuple of {"cs", "me"}
        Co-simulation, model exchange, or both (default), served by one binary.

    Raises
    ------
    FmuBuildError
        Non-finite coefficients or vessel data, a bad ``max_step_s``, an unknown FMI
        version or kind.

    """
    _check_target(fmi_version, kinds)
    variables = fmu_variables(params, max_step_s)
    identifier = model_identifier(params.vessel_name)
    created = generation_time(params)
    sources = generate_sources(params, max_step_s=max_step_s, fmi_version=fmi_version)
    layer = LAYER_SOURCES[fmi_version]
    try:
        if fmi_version == "2":
            description = model_description_xml(
                params,
                variables,
                model_identifier=identifier,
                kinds=kinds,
                source_files=(layer,),
                created=created,
            )
        else:
            description = model_description_fmi3_xml(
                params, variables, model_identifier=identifier, kinds=kinds, created=created
            )
            sources[BUILD_DESCRIPTION] = build_description_xml(identifier, (layer,))
        sidecar = osp_model_description_xml(params, variables)
    except ValueError as exc:
        raise FmuBuildError(str(exc)) from None
    guid = content_guid(
        [("modelDescription.xml", description.encode("utf-8"))]
        + [(f"sources/{name}", sources[name].encode("utf-8")) for name in sorted(sources)]
    )
    sources[CONFIG_HEADER] = sources[CONFIG_HEADER].replace(GUID_PLACEHOLDER, guid)
    return NativeFmuText(
        model_identifier=identifier,
        guid=guid,
        fmi_version=fmi_version,
        kinds=tuple(kinds),
        model_description=description.replace(GUID_PLACEHOLDER, guid),
        osp_model_description=sidecar,
        sources=sources,
        layer_source=layer,
        created=created,
    )


def build_native_fmu(
    params: ModelParameters,
    output: str | os.PathLike[str],
    *,
    max_step_s: float | None = None,
    cc: str | None = None,
    fmi_version: str = "2",
    kinds: tuple[str, ...] = KINDS,
) -> Path:
    """Generate, compile and pack the native FMU.

    Writes ``output`` (atomically: a reader never sees half an FMU) and the OSP-IS
    sidecar ``<stem>_OspModelDescription.xml`` next to it. A rebuild from the same
    parameters with the same compiler gives the same bytes (time stamps come from the
    identification's ``created`` time when it is present).

    Parameters
    ----------
    params : ModelParameters
        Identified model: variant, coefficients, vessel.
    output : path-like
        The ``.fmu`` file to write; parent folders are created.
    max_step_s : float, optional
        Start value of the FMU's ``max_step`` parameter, the largest internal RK4 step
        [s]; default ``fmu_model.interface.DEFAULT_MAX_STEP_S``.
    cc : str, optional
        C compiler command (may include options); default ``$CC``, else cc, gcc, clang.
    fmi_version : {"2", "3"}
        FMI 2.0 (default) or FMI 3.0.
    kinds : tuple of {"cs", "me"}
        Co-simulation, model exchange, or both (default), served by one binary.

    Returns
    -------
    pathlib.Path
        ``output``.

    Raises
    ------
    FmuBuildError
        Non-finite coefficients or vessel data, a bad ``max_step_s``, an unknown FMI
        version or kind, no C compiler, a compile failure (with the compiler's first
        error line), an unsupported platform. Nothing is written then.

    """
    output = Path(output)
    platform = next((v for k, v in _PLATFORMS.items() if sys.platform.startswith(k)), None)
    if platform is None:
        raise FmuBuildError(f"native FMU build is not supported on {sys.platform!r}")
    binary_dirs, suffix = platform
    text = render_native_fmu(params, max_step_s=max_step_s, fmi_version=fmi_version, kinds=kinds)
    compiler = _compiler(cc)
    with tempfile.TemporaryDirectory(prefix="shipid-fmu-") as tmp:
        source_dir = Path(tmp) / "sources"
        source_dir.mkdir()
        for name, content in text.sources.items():
            (source_dir / name).write_text(content, encoding="utf-8")
        library = Path(tmp) / f"{text.model_identifier}{suffix}"
        _compile(source_dir, text.layer_source, library, compiler)
        binary = library.read_bytes()

    binary_dir = binary_dirs[fmi_version]
    entries = [
        ("modelDescription.xml", text.model_description.encode("utf-8")),
        (f"binaries/{binary_dir}/{text.model_identifier}{suffix}", binary),
        *((f"sources/{name}", text.sources[name].encode("utf-8")) for name in sorted(text.sources)),
    ]
    write_atomic(output, _zip(entries, text.created))
    write_atomic(osp_sidecar_path(output), text.osp_model_description)
    return output
