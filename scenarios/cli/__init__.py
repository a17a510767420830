"""Command line of the scenarios: ``python -m scenarios <command>`` (DESIGN.md contract).

Commands::

    synthesize      reference-ship trial logs, DIR/<manoeuvre>.csv
    turning-circle  turning circle on an FMU: advance, transfer, tactical diameter
    zigzag          zig-zag δ/ψ on an FMU: overshoots and times
    spiral          Dieudonné spiral on an FMU: r(δ) and the loop width
    pullout         pull-out on an FMU: residual yaw rate, decay time constant
    imo             IMO MSC.137(76) criteria of an FMU (--strict: gate)
    validate        standard set on an FMU and a reference ship, report (--max-error-pct: gate;
                    --params: 95 % intervals from the identified covariance)
    uncertainty     Monte-Carlo 95 % intervals of the standard manoeuvres from params.json
    demo            logs -> identification -> native FMU -> validation report with intervals
    warm-up         compile a model family's numba code once, before its first fit

Speed and propeller speed default to the FMU's start values (``u0``, ``propeller_rpm``);
the steering-gear rate to 2.34 deg/s (KVLCC2 full scale, a typical large ship's). The
commands that sail an FMU (and ``validate`` the reference ship with it) take a steady
current and wind, ``--current-mps C --current-to-deg D``, ``--wind-mps W
--wind-from-deg D`` (:mod:`~scenarios.cli.sea`); without them they sail in calm water.

Exit status: 0 success; 1 data error (missing or foreign FMU, rudder beyond the FMU's
limit, a run that does not give its metrics, unreadable files); 2 usage error
(argparse); 3 a gate failed (``imo --strict``, ``validate --max-error-pct``). Errors and
gate verdicts are one line on stderr, never a traceback. Progress goes to stderr

Modules, one command group each: :mod:`~scenarios.cli.synthesize`,
:mod:`~scenarios.cli.fmu_runs` (turning-circle, zigzag, spiral, pullout, imo),
:mod:`~scenarios.cli.validation` (validate, demo), :mod:`~scenarios.cli.uncertainty`,
:mod:`~scenarios.cli.warm_up`;
:mod:`~scenarios.cli.common` holds what they share.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable, Sequence

from fmu_model import ParamsFormatError
from fmu_model.errors import FmuBuildError
from scenarios.cli.common import EXIT_DATA_ERROR, EXIT_GATE_FAILED, PROG, fail
from scenarios.cli.fmu_runs import (
    add_fmu_commands,
    run_imo_command,
    run_pullout_command,
    run_spiral_command,
    run_turning_circle_command,
    run_zigzag_command,
)
from scenarios.cli.sea import check_sea_usage
from scenarios.cli.synthesize import (
    add_synthesize_command,
    check_synthesize_usage,
    run_synthesize_command,
)
from scenarios.cli.uncertainty import add_uncertainty_command, run_uncertainty_command
from scenarios.cli.validation import (
    add_demo_command,
    add_validate_command,
    check_validate_usage,
    run_demo_command,
    run_validate_command,
)
from scenarios.cli.warm_up import add_warm_up_command, run_warm_up_command
from scenarios.errors import ScenarioError
from trials.errors import IdentificationError, LogFormatError
from trials.metrics import MetricsError

__all__ = ["EXIT_DATA_ERROR", "EXIT_GATE_FAILED", "PROG", "build_parser", "main"]

_COMMANDS: dict[str, Callable[[argparse.Namespace], int]] = {
    "synthesize": run_synthesize_command,
    "turning-circle": run_turning_circle_command,
    "zigzag": run_zigzag_command,
    "spiral": run_spiral_command,
    "pullout": run_pullout_command,
    "imo": run_imo_command,
    "validate": run_validate_command,
    "demo": run_demo_command,
    "uncertainty": run_uncertainty_command,
    "warm-up": run_warm_up_command,
}


# The commands with the at-sea options of scenarios.cli.sea.
_AT_SEA = ("turning-circle", "zigzag", "spiral", "pullout", "imo", "validate")


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of ``python -m scenarios``."""
    return _build_parsers()[0]


def _build_parsers() -> tuple[argparse.ArgumentParser, dict[str, argparse.ArgumentParser]]:
    """Return the parser of ``python -m scenarios`` and its subcommands' parsers by name."""
    parser = argparse.ArgumentParser(
        prog=PROG,
        description="Manoeuvres, IMO criteria and validation reports for ship FMUs.",
        epilog="Exit status: 0 ok, 1 data error, 2 usage error, 3 gate failed.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    common = argparse.ArgumentParser(add_help=False)
    common.add_argument("--quiet", action="store_true", help="no progress on stderr")

    add_synthesize_command(sub, common)
    add_fmu_commands(sub, common)
    add_validate_command(sub, common)
    add_uncertainty_command(sub)
    add_demo_command(sub, common)
    add_warm_up_command(sub, common)
    return parser, dict(sub.choices)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (0, 1 data error, 3 gate failed).

    Usage errors exit through argparse with status 2.
    """
    parser, commands = _build_parsers()
    args = parser.parse_args(argv)
    if args.command == "validate":
        check_validate_usage(commands["validate"], args)
    if args.command == "synthesize":
        check_synthesize_usage(commands["synthesize"], args)
    elif args.command in _AT_SEA:
        check_sea_usage(commands[args.command], args)
    try:
        return _COMMANDS[args.command](args)
    except (
        ScenarioError,
        MetricsError,
        ParamsFormatError,
        LogFormatError,
        IdentificationError,
        FmuBuildError,
        OSError,
    ) as exc:
        return fail(args.command, exc)
