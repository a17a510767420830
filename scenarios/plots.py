"""Figures of manoeuvres: track overlays, heading/rudder time histories, spiral, pull-out.

Matplotlib's object API with the Agg canvas (no pyplot, so no global figure state and
no display needed). Every figure compares any number of labelled runs, e.g. the
reference ship against the identified model, in the conventions of DESIGN.md: tracks
in ship lengths with x North up and y East to the right at equal aspect; angles in
degrees and times in seconds on the axes. :func:`save_png` writes a figure atomically.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from fmu_model.atomic import write_atomic

__all__ = [
    "IntervalBar",
    "Run",
    "interval_figure",
    "pullout_figure",
    "save_png",
    "spiral_figure",
    "trajectory_figure",
    "zigzag_figure",
]

Run = tuple[str, np.ndarray]
"""A labelled trajectory (``TRAJECTORY_DTYPE``): ``("reference", traj)``."""

IntervalBar = tuple[str, float | None, float | None, float | None, float | None]
"""``(label, reference, predicted, lo, hi)``: one quantity and its interval; None: missing."""

# Line styles by position in the list of runs: the first (the reference) solid.
_STYLES = ("-", "--", ":", "-.")
_DPI = 110


def _figure(width_in: float, height_in: float) -> Figure:
    fig = Figure(figsize=(width_in, height_in))
    FigureCanvasAgg(fig)
    return fig


def _style(index: int) -> str:
    return _STYLES[index % len(_STYLES)]


def trajectory_figure(
    groups: Sequence[tuple[str, Sequence[Run]]], length_m: float, title: str = ""
) -> Figure:
    """Tracks of one or more manoeuvres, each compared across runs, in ship lengths.

    Parameters
    ----------
    groups : sequence of (str, sequence of Run)
        One entry per manoeuvre (e.g. starboard and port turns), each a name and the
        runs to overlay (e.g. reference and predicted); one colour per manoeuvre, one
        line style per run (first solid).
    length_m : float
        Ship length L the axes are scaled by [m].
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        y East / L to the right, x North / L up, equal aspect, the execute point marked.

    """
    if not (math.isfinite(length_m) and length_m > 0.0):
        raise ValueError(f"length_m must be a positive number, got {length_m!r}")
    fig = _figure(6.5, 6.0)
    ax = fig.add_subplot()
    for g, (name, runs) in enumerate(groups):
        for i, (label, traj) in enumerate(runs):
            ax.plot(
                traj["y_m"] / length_m,
                traj["x_m"] / length_m,
                _style(i),
                color=f"C{g}",
                lw=1.3,
                label=f"{name}: {label}" if name else label,
            )
    ax.plot([0.0], [0.0], "k+", ms=10, label="execute")
    ax.set_xlabel("y East / L [-]")
    ax.set_ylabel("x North / L [-]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="best")
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def zigzag_figure(runs: Sequence[Run], title: str = "") -> Figure:
    """Heading change and rudder angle, and speed over ground, against time.

    Parameters
    ----------
    runs : sequence of Run
        Zig-zag trajectories to overlay (first solid); heading relative to the heading
        at the first sample.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        Top: heading change ψ − ψ₀ and rudder δ [deg]; bottom: U = √(u² + v²) [m/s].

    """
    fig = _figure(8.0, 6.0)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (2, 1)})
    for i, (label, traj) in enumerate(runs):
        t = traj["time_s"]
        heading = np.degrees(traj["psi_rad"] - traj["psi_rad"][0])
        top.plot(t, heading, _style(i), color="C0", lw=1.3, label=f"heading, {label}")
        rudder = np.degrees(traj["rudder_rad"])
        top.plot(t, rudder, _style(i), color="C3", lw=1.0, label=f"rudder, {label}")
        speed = np.hypot(traj["u_mps"], traj["v_mps"])
        bottom.plot(t, speed, _style(i), color="C2", lw=1.2, label=label)
    top.axhline(0.0, color="0.5", lw=0.5)
    top.set_ylabel("heading change, rudder [deg]")
    top.grid(True, lw=0.4, alpha=0.6)
    top.legend(fontsize=8, ncol=2, loc="upper right")
    bottom.set_xlabel("time from execute [s]")
    bottom.set_ylabel("speed U [m/s]")
    bottom.grid(True, lw=0.4, alpha=0.6)
    bottom.legend(fontsize=8, loc="best")
    if title:
        top.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def spiral_figure(
    curves: Sequence[tuple[str, Sequence[float], Sequence[float]]], title: str = ""
) -> Figure:
    """Dieudonné spiral: steady yaw rate against rudder angle, in the order applied.

    Parameters
    ----------
    curves : sequence of (label, rudder_rad, yaw_rate_radps)
        Rudder angles in the order applied [rad] and the steady yaw rates [rad/s].
    title : str, optional
        Figure title.

    """
    fig = _figure(6.5, 5.0)
    ax = fig.add_subplot()
    for i, (label, rudder, rate) in enumerate(curves):
        ax.plot(
            np.degrees(np.asarray(rudder)),
            np.degrees(np.asarray(rate)),
            _style(i) + "o",
            color=f"C{i}",
            ms=3,
            lw=1.0,
            label=label,
        )
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax.axvline(0.0, color="0.5", lw=0.5)
    ax.set_xlabel("rudder angle [deg]")
    ax.set_ylabel("steady yaw rate [deg/s]")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def pullout_figure(runs: Sequence[Run], title: str = "") -> Figure:
    """Pull-out: yaw rate and rudder angle against time.

    Parameters
    ----------
    runs : sequence of Run
        Pull-out trajectories to overlay (first solid).
    title : str, optional
        Figure title.

    """
    fig = _figure(8.0, 4.5)
    ax = fig.add_subplot()
    rudder_ax = ax.twinx()
    for i, (label, traj) in enumerate(runs):
        t = traj["time_s"]
        ax.plot(t, np.degrees(traj["r_radps"]), _style(i), color="C0", lw=1.3, label=label)
        rudder_ax.plot(t, np.degrees(traj["rudder_rad"]), _style(i), color="C3", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.5)
    ax.set_xlabel("time from execute [s]")
    ax.set_ylabel("yaw rate [deg/s]", color="C0")
    rudder_ax.set_ylabel("rudder [deg]", color="C3")
    ax.grid(True, lw=0.4, alpha=0.6)
    ax.legend(fontsize=8, loc="upper right")
    if title:
        ax.set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def interval_figure(panels: Sequence[tuple[str, Sequence[IntervalBar]]], title: str = "") -> Figure:
    """Draw reference and predicted values of quantities, the prediction's interval as a bar.

    Parameters
    ----------
    panels : sequence of (str, sequence of IntervalBar)
        One panel per unit, each its axis label and its quantities, listed top down:
        the reference as a black diamond, the predicted value as a dot and its
        interval [lo, hi] as a horizontal bar with end caps.
    title : str, optional
        Figure title.

    Returns
    -------
    matplotlib.figure.Figure
        The panels stacked, heights in proportion to their number of quantities.

    """
    if not panels:
        raise ValueError("no panels to draw")
    counts = [max(1, len(bars)) for _, bars in panels]
    fig = _figure(9.0, 1.2 + 0.45 * sum(counts) + 0.6 * len(panels))
    axes = fig.subplots(len(panels), 1, squeeze=False, gridspec_kw={"height_ratios": counts})
    for ax, (axis_label, bars) in zip(axes[:, 0], panels, strict=True):
        y = -np.arange(len(bars), dtype=float)  # first quantity on top
        shown: set[str] = set()

        def once(name: str, shown: set[str] = shown) -> str:
            if name in shown:
                return "_nolegend_"
            shown.add(name)
            return name

        for yi, (_, reference, predicted, lo, hi) in zip(y, bars, strict=True):
            if lo is not None and hi is not None:
                ax.hlines(yi, lo, hi, color="C0", lw=2.0, label=once("95 % interval"))
                ax.plot([lo, hi], [yi, yi], "|", color="C0", ms=12, mew=2.0)
            if predicted is not None:
                ax.plot([predicted], [yi], "o", color="C0", ms=6, label=once("predicted"))
            if reference is not None:
                ax.plot([reference], [yi], "D", color="k", ms=6, label=once("reference"))
        ax.set_yticks(y, [label for label, *_ in bars], fontsize=8)
        ax.set_ylim(y[-1] - 0.6 if len(y) else -0.6, 0.6)
        ax.set_xlabel(axis_label)
        ax.grid(True, axis="x", lw=0.4, alpha=0.6)
        ax.legend(fontsize=8, loc="best")
    if title:
        axes[0, 0].set_title(title, fontsize=10)
    fig.tight_layout()
    return fig


def save_png(fig: Figure, path: str | os.PathLike[str]) -> Path:
    """Render ``fig`` as PNG and write it atomically to ``path``; return the path."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=_DPI)
    write_atomic(path, buffer.getvalue())
    return Path(path)
