"""Build an FMU from params.json (DESIGN.md, command-line contract).

    python build_fmu.py [--params params.json] [-o build/NAME.fmu]
                        [--backend native|pythonfmu] [--fmi-version 2|3]
                        [--kind cs|me|both] [--max-step-s S]

The native backend builds FMI 2.0 (default) or 3.0, co-simulation, model exchange or
both in one FMU (default); the pythonfmu backend builds FMI 2.0 co-simulation only.
Prints the path of the FMU written (on stderr, a note of what its logs reached when the
params record it: the FMU warns beyond that, ``fmu_model.envelope``). Exit status 0 on
success, 1 on a data or build error (one line on stderr, nothing written), 2 on a usage
error. The native backend compiles with ``$CC`` when it is set.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from fmu_model import argtypes
from fmu_model.errors import FmuBuildError
from fmu_model.interface import logged_envelope
from fmu_model.params import ParamsFormatError, load_params

DEFAULT_PARAMS = Path("build") / "params.json"
# --kind: the kinds of FMU in one file.
_KINDS = {"cs": ("cs",), "me": ("me",), "both": ("cs", "me")}


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="build_fmu.py", description="Build an FMU from params.json."
    )
    parser.add_argument(
        "--params",
        type=Path,
        default=DEFAULT_PARAMS,
        help=f"parameter file (default {DEFAULT_PARAMS})",
    )
    parser.add_argument(
        "-o", "--output", type=Path, default=None, help="FMU to write (default build/<vessel>.fmu)"
    )
    parser.add_argument(
        "--backend",
        choices=("native", "pythonfmu"),
        default="native",
        help="native C (default) or pythonfmu",
    )
    parser.add_argument(
        "--fmi-version",
        choices=("2", "3"),
        default="2",
        help="FMI 2.0 (default) or FMI 3.0 (native backend only)",
    )
    parser.add_argument(
        "--kind",
        choices=tuple(_KINDS),
        default=None,
        help="co-simulation, model exchange or both in one FMU (default: both for the "
        "native backend, cs for pythonfmu, which has no model exchange)",
    )
    parser.add_argument(
        "--max-step-s",
        type=argtypes.positive,
        default=None,
        metavar="S",
        help="largest internal RK4 step inside doStep [s] (default 0.05)",
    )
    return parser


def _fail(message: str) -> int:
    """Print one line on stderr; return exit status 1."""
    text = message.replace("\r", "\\r").replace("\n", "\\n")
    print(f"build_fmu.py: error: {text}", file=sys.stderr)
    return 1


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status."""
    parser = _parser()
    args = parser.parse_args(argv)
    if args.backend == "pythonfmu" and (args.fmi_version != "2" or args.kind not in (None, "cs")):
        parser.error("the pythonfmu backend builds FMI 2.0 co-simulation only")
    try:
        params = load_params(args.params)
        if args.backend == "native":
            from fmu_model.export_native import build_native_fmu, model_identifier

            output = args.output or Path("build") / f"{model_identifier(params.vessel_name)}.fmu"
            kinds = _KINDS[args.kind or "both"]
            written = build_native_fmu(
                params,
                output,
                max_step_s=args.max_step_s,
                fmi_version=args.fmi_version,
                kinds=kinds,
            )
        else:
            from fmu_model.export_native import model_identifier
            from fmu_model.export_pythonfmu import build_pythonfmu_fmu

            output = args.output or Path("build") / f"{model_identifier(params.vessel_name)}.fmu"
            written = build_pythonfmu_fmu(params, output, max_step_s=args.max_step_s)
    except (ParamsFormatError, FmuBuildError) as exc:
        return _fail(str(exc))
    except OSError as exc:
        return _fail(f"{exc.filename}: {exc.strerror}" if exc.filename else str(exc))
    print(written)
    envelope = logged_envelope(params)
    if envelope is not None:
        print(
            "build_fmu.py: note: the FMU warns in its host's log when a step goes beyond what "
            f"its logs reached: {envelope.describe()}",
            file=sys.stderr,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
