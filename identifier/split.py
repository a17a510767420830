"""A recording of several manoeuvres split into one log each.

A trial day is often logged as one recording: an approach, a zig-zag, minutes of straight
running, a turning circle, and so on. ``identifier fit`` takes it as it is, but whatever
compares a logged manoeuvre with a prediction (``identifier crossval``, the scenarios'
``--like``, ``trials.conditions.logged_condition``) reads one manoeuvre a log: its
approach, its execute and its rudder program. :func:`split_log` finds the manoeuvres in
the log's own motion, with the conventions' rules (``identifier.conventions``):

- **A rudder command** is a rudder angle :data:`~identifier.conventions.MIN_COMMAND_RAD`
  (5°) or more off the ship's neutral helm, the median rudder angle within 5° of midship
  where she runs straight (an autopilot's smaller movements are no commands; the rudder's
  spikes interpolated, ``trials.spikes``), under which the heading swings by
  :data:`~identifier.conventions.MIN_TURN_RAD` (5°) or more before she is straight again
  (a correction in a gust is no manoeuvre).
- **She runs straight** where her rudder is not commanded and she turns at r′ = |r| L/U
  of at most :data:`~identifier.conventions.MAX_APPROACH_YAW_RATE` (on the smoothed
  track, its GNSS jumps and compass spikes gated out): what ``fit`` asks of an approach.
- **A command begins a manoeuvre** when she ran straight for :data:`MIN_APPROACH_L` ship
  lengths over ground before it, or from the log's first sample (at least
  ``trials.conditions.MIN_APPROACH_SAMPLES``: a basin's run starts a second before its
  execute). Every other command (a zig-zag's reversals, a pull-out's return to midship,
  a spiral's steps) belongs to the manoeuvre it follows. A first command without an
  approach (a recording started in a turn) leaves the samples up to the next manoeuvre
  out, with a note.
- **A manoeuvre's log** begins at most :data:`MAX_APPROACH_L` ship lengths before its
  execute (the first sample of the command's rudder movement,
  ``trials.conditions.movement_start``), where the straight run and a propeller speed
  within :data:`STEADY_RPM_FRACTION` of the execute's begin, and ends where the next
  manoeuvre's begins, or :data:`MAX_APPROACH_L` ship lengths into a longer straight run
  that follows (a steady run between trials is not a manoeuvre's: left out). Its execute
  is written as ``# execute_time_s:``, so that an approach's helm corrections are not
  taken for it; its times are the recording's (its ``# time_origin_utc:`` holds).

Nothing here prints or writes: the command line is ``python -m identifier split``
(:mod:`identifier.cli.split`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import cumulative_trapezoid

from identifier.conventions import (
    MAX_APPROACH_YAW_RATE,
    MIN_COMMAND_RAD,
    MIN_TURN_RAD,
    yaw_rate_prime,
)
from identifier.smoothing import SmoothedTrack, deglitched_log, smooth_log
from trials.conditions import MIN_APPROACH_SAMPLES, logged_condition, movement_start
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, at_midship, log_piece
from trials.spikes import despiked_inputs

__all__ = [
    "MAX_APPROACH_L",
    "MIN_APPROACH_L",
    "STEADY_RPM_FRACTION",
    "Piece",
    "Split",
    "manoeuvre_name",
    "piece_logs",
    "several_manoeuvres",
    "split_log",
]

MIN_APPROACH_L = 1.0
"""Straight running before a command that makes it a new manoeuvre [ship lengths]: a
zig-zag's reversal or a pull-out follows its turn at once."""
MAX_APPROACH_L = 5.0
"""Longest straight run kept before a manoeuvre's execute, and after its end [ship lengths]
(KVLCC2 at 15.5 kn: 200 s)."""
STEADY_RPM_FRACTION = 0.02
"""Largest change of the propeller speed within an approach, of its speed at execute."""


@dataclass(frozen=True)
class Piece:
    """One manoeuvre of a log: samples ``start`` to ``stop`` − 1, its execute at ``execute``."""

    start: int
    execute: int
    stop: int


@dataclass(frozen=True)
class Split:
    """The manoeuvres :func:`split_log` found, in time order, and its notes (one line each)."""

    pieces: tuple[Piece, ...]
    notes: tuple[str, ...]


def _run_start(ok: np.ndarray, end: int) -> int:
    """First sample of the run of True in ``ok`` that ends at sample ``end`` − 1."""
    broken = np.flatnonzero(~ok[:end])
    return int(broken[-1]) + 1 if broken.size else 0


def _turning(commanded: np.ndarray, heading_rad: np.ndarray, calm: np.ndarray) -> np.ndarray:
    """``commanded`` without the commands under which the heading swings less than 5°.

    Each run of commanded samples, from its first sample until the ship is calm again
    after it: a helmsman's or an autopilot's correction of more than 5° for a few
    seconds in a gust is no manoeuvre (:data:`~identifier.conventions.MIN_TURN_RAD`).
    """
    out = commanded.copy()
    edges = np.diff(np.concatenate(([0], commanded.astype(np.int8), [0])))
    for start, stop in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True):
        settled = np.flatnonzero(calm[stop:])
        end = stop + int(settled[0]) + 1 if settled.size else len(commanded)
        if np.max(np.abs(heading_rad[start:end] - heading_rad[start])) < MIN_TURN_RAD:
            out[start:stop] = False
    return out


def split_log(log: ManeuverLog, length_m: float, track: SmoothedTrack | None = None) -> Split:
    """Find the manoeuvres of ``log`` (module docstring).

    Parameters
    ----------
    log : ManeuverLog
        A recording of one or more manoeuvres.
    length_m : float
        The ship's length [m].
    track : SmoothedTrack, optional
        The log's smoothed track at midship (``identifier.smoothing.smooth_log`` of
        ``trials.logs.at_midship``); smoothed here when omitted.

    Returns
    -------
    Split
        The pieces, each a manoeuvre with its approach, and the notes.

    Raises
    ------
    IdentificationError
        When the log has no rudder command, or no command with an approach.

    """
    name = log.path or "log"
    inputs = despiked_inputs(log, length_m)[0]
    rudder, n_rps = inputs.rudder_rad, inputs.n_rps
    track = track or smooth_log(at_midship(log))
    calm = yaw_rate_prime(track, length_m) <= MAX_APPROACH_YAW_RATE
    held = calm & (np.abs(rudder) < MIN_COMMAND_RAD)  # not a zig-zag's heading peak
    helm = float(np.median(rudder[held])) if held.any() else 0.0
    commanded = _turning(np.abs(rudder - helm) >= MIN_COMMAND_RAD, track.heading_rad, calm)
    straight = calm & ~commanded
    onsets = np.flatnonzero(commanded & ~np.r_[False, commanded[:-1]])
    if not onsets.size:
        raise IdentificationError(
            f"no rudder command of {math.degrees(MIN_COMMAND_RAD):g} deg or more off the "
            f"neutral helm ({math.degrees(helm):.1f} deg): expected a recording of "
            "manoeuvres",
            log=name,
        )
    sailed_m = cumulative_trapezoid(track.speed_mps, log.time_s, initial=0.0)  # over ground
    reach_m = MAX_APPROACH_L * length_m

    pieces: list[Piece] = []
    notes: list[str] = []
    for c in onsets:
        run = _run_start(straight, int(c))
        if run == 0:
            new = int(c) >= MIN_APPROACH_SAMPLES
        else:
            new = sailed_m[c] - sailed_m[run] >= MIN_APPROACH_L * length_m
        if not new:
            continue  # a command within the manoeuvre before, or before any approach
        execute = movement_start(rudder, int(c), math.copysign(1.0, rudder[c] - helm), run)
        steady_rpm = np.abs(n_rps - n_rps[execute]) <= STEADY_RPM_FRACTION * abs(n_rps[execute])
        farthest = int(np.searchsorted(sailed_m, sailed_m[execute] - reach_m))
        start = max(run, farthest, _run_start(steady_rpm, execute))
        if execute - start < MIN_APPROACH_SAMPLES:
            start = max(run, farthest)
            notes.append(
                f"the manoeuvre executed at t = {log.time_s[execute]:.1f} s: its propeller "
                "speed changes in its approach"
            )
        if pieces:
            tail = int(np.searchsorted(sailed_m, sailed_m[run] + reach_m))
            pieces[-1] = replace(pieces[-1], stop=min(tail, start))
        elif onsets[0] < c:
            notes.append(
                f"samples 0 to {start - 1} (t = {log.time_s[0]:.1f} to "
                f"{log.time_s[start - 1]:.1f} s): rudder commands without a straight approach "
                "before them (a recording started in a manoeuvre?): left out"
            )
        pieces.append(Piece(start, execute, log.n_samples))
    if not pieces:
        raise IdentificationError(
            "no rudder command after a straight approach: expected a recording of "
            f"manoeuvres, each after a straight run of {MIN_APPROACH_L:g} ship length",
            log=name,
        )
    settled = _run_start(straight, log.n_samples)
    if settled < log.n_samples:  # the log ends in a straight run
        tail = int(np.searchsorted(sailed_m, sailed_m[settled] + reach_m))
        pieces[-1] = replace(pieces[-1], stop=min(tail, log.n_samples))
    return Split(tuple(pieces), tuple(notes))


def piece_logs(log: ManeuverLog, split: Split, length_m: float) -> list[ManeuverLog]:
    """Return the manoeuvres of ``split`` as logs of their own.

    Every column and the metadata of ``log``, the times as they are; the ship's
    ``length_m`` [m] as ``# length_m:``, the execute as ``# execute_time_s:`` and the
    samples taken in ``# source:``.
    """
    source = log.metadata.get("source")
    out = []
    for piece in split.pieces:
        where = f"samples {piece.start} to {piece.stop - 1} of {log.path or 'a log'}"
        metadata = {
            **log.metadata,
            "length_m": repr(float(length_m)),
            "source": where if source is None else f"{source} ({where})",
            "execute_time_s": repr(float(log.time_s[piece.execute])),
        }
        out.append(replace(log_piece(log, piece.start, piece.stop), metadata=metadata))
    return out


def manoeuvre_name(log: ManeuverLog) -> str | None:
    """Return what a piece is, e.g. ``zigzag-10-10-stbd``, ``turning-35-port``; None if neither.

    As ``trials.conditions.logged_condition`` reads it from the log at midship with its
    GNSS jumps and compass spikes taken out, as ``crossval`` and ``--like`` read it (a
    spike at a reversal put a 10/10's check angle at 12°, and ``crossval`` takes the
    check angle a file's name gives); a spiral's steps read as a zig-zag.
    """
    midship = at_midship(log)
    try:
        return logged_condition(deglitched_log(midship, smooth_log(midship))).program.name
    except IdentificationError:
        return None


def several_manoeuvres(log: ManeuverLog, length_m: float, track: SmoothedTrack) -> str | None:
    """Return what to do with a log of several manoeuvres where one is read; else None.

    For the commands that read a log as one manoeuvre (``identifier crossval``'s held-out
    logs, the scenarios' ``--like``): its indices and condition would be of the
    recording as a whole. ``track`` as :func:`split_log`'s.
    """
    try:
        pieces = split_log(log, length_m, track).pieces
    except IdentificationError:
        return None
    if len(pieces) < 2:
        return None
    times = ", ".join(f"{log.time_s[piece.execute]:.1f}" for piece in pieces)
    return (
        f"the log holds {len(pieces)} manoeuvres (executed at t = {times} s), read here as "
        "one: split it into one log each first (python -m identifier split)"
    )
