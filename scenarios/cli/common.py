"""What every command of ``python -m scenarios`` shares: its name, exit codes, progress, errors."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from tqdm import tqdm

from scenarios.demo import Bar, BarFactory
from trials.conditions import MODEL_SCALE_MAX_LENGTH_M
from trials.maneuvers import DEFAULT_RUDDER_RATE_DEG_S

__all__ = [
    "EXIT_DATA_ERROR",
    "EXIT_GATE_FAILED",
    "PROG",
    "STEERING_RATE_HELP",
    "fail",
    "make_bars",
    "progress",
    "sim_progress",
    "steering_rate_deg_s",
]

PROG = "python -m scenarios"
EXIT_DATA_ERROR = 1
EXIT_GATE_FAILED = 3


STEERING_RATE_HELP = (
    f"steering-gear rate [deg/s] (default {DEFAULT_RUDDER_RATE_DEG_S}, a full-scale ship's; "
    f"a warning on a ship shorter than {MODEL_SCALE_MAX_LENGTH_M:g} m)"
)
"""Help of ``--rudder-rate-deg-s`` (:func:`steering_rate_deg_s`)."""


def steering_rate_deg_s(given: float | None, length_m: float) -> tuple[float, str | None]:
    """Return a run's steering-gear rate [deg/s] and a warning for the default on a model.

    ``given`` is ``--rudder-rate-deg-s`` (None: not given, the default
    ``DEFAULT_RUDDER_RATE_DEG_S``, a full-scale ship's: SOLAS, 35° to 30° the other side in
    28 s). A model of scale λ steers √λ times faster (Froude scaling of time), so the
    default on a ship shorter than :data:`MODEL_SCALE_MAX_LENGTH_M` makes every overshoot
    too large: the warning says so.
    """
    if given is not None:
        return given, None
    warning = None
    if length_m < MODEL_SCALE_MAX_LENGTH_M:
        warning = (
            f"L = {length_m:g} m, a model? The default steering-gear rate "
            f"{DEFAULT_RUDDER_RATE_DEG_S} deg/s is a full-scale ship's; a model of scale "
            "lambda steers sqrt(lambda) times faster: pass --rudder-rate-deg-s (its logs' rate)"
        )
    return DEFAULT_RUDDER_RATE_DEG_S, warning


def progress(message: str, quiet: bool) -> None:
    """Print a progress line on stderr unless ``quiet``."""
    if not quiet:
        print(message, file=sys.stderr, flush=True)


def _tqdm(description: str, total: float | None, unit: str, quiet: bool) -> tqdm:
    return tqdm(
        desc=description,
        total=total,
        unit=unit,
        disable=True if quiet else None,  # None: only on a terminal
        file=sys.stderr,
        leave=False,
        dynamic_ncols=True,
    )


def make_bars(quiet: bool) -> BarFactory:
    """Return a factory of tqdm progress bars on stderr (none when ``quiet``)."""

    def make(description: str, total: float | None, unit: str) -> Bar:
        return _tqdm(description, total, unit, quiet)

    return make


@contextmanager
def sim_progress(label: str, quiet: bool) -> Iterator[Callable[[float], None]]:
    """Yield a ``run_program`` progress callback counting simulated seconds (tqdm)."""
    with _tqdm(label, None, "s", quiet) as bar:

        def update(t_s: float) -> None:
            bar.update(max(0, int(t_s) - bar.n))

        yield update


def fail(command: str, error: str | BaseException) -> int:
    """Print ``error`` as one line on stderr, ``PROG COMMAND: error: …``; return 1.

    An ``OSError`` that names a file reads ``FILE: STRERROR``.
    """
    message = str(error)
    if isinstance(error, OSError) and error.filename:
        message = f"{error.filename}: {error.strerror or error}"
    text = message.replace("\r", "\\r").replace("\n", "\\n")
    print(f"{PROG} {command}: error: {text}", file=sys.stderr)
    return EXIT_DATA_ERROR
