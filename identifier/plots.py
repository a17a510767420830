"""Figures of an identification: smoothed track, derived velocities, convergence.

The equivalents of Shi et al. (2009), Fig. 2–6: raw vs smoothed data and the
convergence of every coefficient with its ±2σ band; and of a cross-validation, each
held-out log against its prediction. Matplotlib with the Agg backend;
each figure is written atomically as PNG.
"""

from __future__ import annotations

import io
import math
import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from fmu_model.atomic import write_atomic
from identifier.crossval import CrossValidation, HeldOut
from identifier.identify import IdentificationResult
from trials.logs import at_midship


def _save(fig: Figure, path: Path) -> Path:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    plt.close(fig)
    write_atomic(path, buffer.getvalue())
    return path


def track_figure(result: IdentificationResult) -> Figure:
    """Plot the raw and smoothed track (North up) and heading of every log.

    The raw track at midship, as the smoothed one (``trials.logs.at_midship``).
    """
    n = len(result.logs)
    fig, axes = plt.subplots(2, n, figsize=(4.5 * n, 8), squeeze=False)
    for i, (given, track) in enumerate(zip(result.logs, result.tracks, strict=True)):
        log = at_midship(given)
        ax = axes[0, i]
        ax.plot(log.y_m, log.x_m, ".", ms=2, color="0.6", label="logged")
        ax.plot(track.y_m, track.x_m, "-", lw=1.2, color="C0", label="smoothed")
        ax.set_xlabel("y East [m]")
        ax.set_ylabel("x North [m]")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(Path(log.path).name if log.path else f"log {i + 1}", fontsize=9)
        ax.legend(fontsize=8)
        ax = axes[1, i]
        ax.plot(log.time_s, np.degrees(log.heading_rad), ".", ms=2, color="0.6", label="logged")
        ax.plot(track.time_s, np.degrees(track.heading_rad), "-", color="C0", label="smoothed")
        ax.plot(log.time_s, np.degrees(log.rudder_rad), "-", color="C3", lw=0.8, label="rudder")
        ax.set_xlabel("time [s]")
        ax.set_ylabel("heading, rudder [deg]")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def velocity_figure(result: IdentificationResult) -> Figure:
    """Plot the derived u, v, r (smoothed, ±2σ) and the EKF's filtered motion states."""
    n = len(result.logs)
    fig, axes = plt.subplots(3, n, figsize=(4.5 * n, 8), squeeze=False, sharex="col")
    labels = ("u [m/s]", "v [m/s]", "r [deg/s]")
    for i, (track, states) in enumerate(zip(result.tracks, result.ekf.filtered, strict=True)):
        series = (
            (track.u_mps, track.u_std_mps, 1.0),
            (track.v_mps, track.v_std_mps, 1.0),
            (track.r_radps, track.r_std_radps, math.degrees(1.0)),
        )
        for j, (value, std, scale) in enumerate(series):
            ax = axes[j, i]
            ax.fill_between(
                track.time_s,
                (value - 2 * std) * scale,
                (value + 2 * std) * scale,
                color="C0",
                alpha=0.25,
                lw=0,
            )
            ax.plot(track.time_s, value * scale, color="C0", lw=1, label="smoothed ±2σ")
            ax.plot(
                track.time_s[:: result.ekf.history_stride],
                states[:, j] * scale,
                "--",
                color="C1",
                lw=1,
                label="EKF",
            )
            ax.set_ylabel(labels[j])
        axes[0, i].legend(fontsize=8)
        axes[-1, i].set_xlabel("time [s]")
    fig.tight_layout()
    return fig


def convergence_figure(result: IdentificationResult) -> Figure:
    """Plot every coefficient's EKF history with its ±2σ band (logs separated by lines)."""
    names = result.params.names
    cols = 4
    rows = math.ceil(len(names) / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(14, 2.4 * rows), squeeze=False)
    history, std = result.ekf.theta_history, result.ekf.std_history
    steps = np.arange(history.shape[0]) * result.ekf.history_stride
    for i, name in enumerate(names):
        ax = axes[i // cols, i % cols]
        ax.fill_between(
            steps,
            history[:, i] - 2 * std[:, i],
            history[:, i] + 2 * std[:, i],
            color="C0",
            alpha=0.25,
            lw=0,
        )
        ax.plot(steps, history[:, i], color="C0", lw=1)
        for end in result.ekf.segment_ends[:-1]:
            ax.axvline(end * result.ekf.history_stride, color="0.5", lw=0.6, ls=":")
        ident = next(c.identifiable for c in result.coefficients if c.name == name)
        ax.set_title(f"{name}" + ("" if ident else " (not identifiable)"), fontsize=9)
        ax.tick_params(labelsize=7)
    for j in range(len(names), rows * cols):
        axes[j // cols, j % cols].axis("off")
    fig.supxlabel("EKF step (all logs)")
    fig.tight_layout()
    return fig


def held_out_figure(held: HeldOut, length_m: float, title: str) -> Figure:
    """Plot a held-out log against its prediction (``identifier.crossval``).

    A turn: the smoothed track and the replay of its logged rudder and rpm, in ship
    lengths ``length_m``, North up. A zig-zag: heading change from the execute heading,
    and rudder angle, against the time from execute, as logged (smoothed) and as the model
    sails it closed loop in the log's condition.
    """
    fig, ax = plt.subplots(figsize=(8.0, 6.0) if held.kind == "zigzag" else (6.5, 6.0))
    how = "replayed" if held.kind == "turning" else "sailed closed loop"
    runs = (("logged", held.logged, "-"), (f"predicted, {how}", held.predicted, "--"))
    for label, traj, style in runs:
        if traj is None or traj.size == 0:
            continue
        if held.kind == "turning":
            ax.plot(traj["y_m"] / length_m, traj["x_m"] / length_m, style, color="C0", label=label)
            continue
        start = float(np.interp(0.0, traj["time_s"], traj["psi_rad"]))
        heading = np.degrees(traj["psi_rad"] - start)
        ax.plot(traj["time_s"], heading, style, color="C0", lw=1.3, label=f"heading, {label}")
        rudder = np.degrees(traj["rudder_rad"])
        ax.plot(traj["time_s"], rudder, style, color="C3", lw=1.0, label=f"rudder, {label}")
    if held.kind == "turning":
        ax.set_xlabel("y East / L [-]")
        ax.set_ylabel("x North / L [-]")
        ax.set_aspect("equal", adjustable="datalim")
    else:
        ax.axhline(0.0, color="0.5", lw=0.5)
        ax.set_xlabel("time from execute [s]")
        ax.set_ylabel("heading change, rudder [deg]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    return fig


def write_held_out_plots(cv: CrossValidation, directory: str | os.PathLike[str]) -> list[Path]:
    """Write ``fold<k>-<held-out log>.png`` into ``directory`` for every held-out log."""
    out = Path(directory)
    paths = []
    for k, fold in enumerate(cv.folds, start=1):
        trained = ", ".join(Path(t).name for t in fold.train)
        for held in fold.held_out:
            if held.kind is None:
                continue
            name = Path(held.name).stem
            title = f"{Path(held.name).name} held out (trained on {trained}): {cv.model}"
            figure = held_out_figure(held, fold.params.length_m, title)
            paths.append(_save(figure, out / f"fold{k}-{name}.png"))
    return paths


def write_plots(result: IdentificationResult, directory: str | os.PathLike[str]) -> list[Path]:
    """Write track.png, velocities.png and convergence.png into ``directory``."""
    out = Path(directory)
    return [
        _save(track_figure(result), out / "track.png"),
        _save(velocity_figure(result), out / "velocities.png"),
        _save(convergence_figure(result), out / "convergence.png"),
    ]
