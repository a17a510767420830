"""Build an FMI 2.0 co-simulation FMU from params.json (DESIGN.md, command-line contract).

    python build_fmu.py [--params params.json] [-o build/NAME.fmu]
                        [--backend native|pythonfmu] [--max-step-s S]

Prints the path of the FMU written. Exit status 0 on success, 1 on a data or build
error (one line on stderr, nothing written), 2 on a usage error. The native backend
compiles with ``$CC`` when it is set.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from fmu_model import argtypes
from fmu_model.errors import FmuBuildError
from fmu_model.params import ParamsFormatError, load_params

DEFAULT_PARAMS = Path("build") / "params.json"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="build_fmu.py", description="Build an FMI 2.0 co-simulation FMU from params.json."
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
    args = _parser().parse_args(argv)
    try:
        params = load_params(args.params)
        if args.backend == "native":
            from fmu_model.export_native import build_native_fmu, model_identifier

            output = args.output or Path("build") / f"{model_identifier(params.vessel_name)}.fmu"
            written = build_native_fmu(params, output, max_step_s=args.max_step_s)
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
    return 0


if __name__ == "__main__":
    sys.exit(main())
