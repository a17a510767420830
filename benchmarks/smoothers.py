"""The ship's velocity smoothed in its own axes: a candidate against the paper's smoother.

    python benchmarks/smoothers.py [--vessel NAME ...] [--draws 5] [--no-fits]
                                   [--out benchmarks/smoothers.md]

The identification's smoother (``identifier.smoothing``, Shi et al. (2009) eq. (6))
smooths North and East positions as two independent constant-acceleration tracks. A
ship's velocity is steady in its own axes, not in the Earth's: in a turn at speed U and
yaw rate r the North and East velocities swing through ±U with the heading (a jerk of
U·r² the per-axis model must take as process noise), so the per-axis filter follows the
track loosely and lets more of the GNSS noise into the sway velocity v.

The candidate here (``body_frame_track``, not in ``identifier``: it loses on the held-out
turns, see ``smoothers.md``) smooths the positions once more, with the velocity over
ground in the ship's axes, w = (u, v), as the constant-acceleration state and the heading
ψ(t) the per-axis smoother gives (the compass: 0.1° against the positions' 1 m):

    p(k+1) = p(k) + R(ψ̄)(T w(k) + T²/2 ẇ(k)),  w(k+1) = w(k) + T ẇ(k),  ẇ(k+1) = ẇ(k),

R(ψ̄) the rotation at the interval's mean heading, white jerk of spectral density q on
both body axes (the Q of eq. (6) with its position rows rotated), q the maximum of the
position innovations' likelihood on a grid. The gate's decisions of the per-axis
smoother (rejected fixes) are kept. Filter and RTS smoother are filterpy's
(``KalmanFilter.batch_filter``, ``rts_smoother``) with a transition per step.

Two tables:

1. **States against the truth**: RMS errors of u, v [m/s] and u̇, v̇ [m/s²] of either
   smoother on noisy logs (``scenarios.synthesize``'s default noise, seeds 0–2) of each
   ship's 10/10 and 20/20 zig-zags and 35° turn, against the same log without noise
   (0.001 m, 0.0001°) through the paper's smoother, and the q chosen.
2. **Fits** (``--no-fits`` leaves them out): the zig-zag-trained fits of
   ``fidelity.py --draws`` (same seeds, default procedure) with either smoother, worst
   turning error of the estimate the default keeps [%] and largest overshoot error [°].
   The candidate enters the fits in place of ``identifier.preparation.smooth_track``
   for the run (restored after it).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import time
from collections.abc import Iterator, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from fidelity import COLUMNS, indices, training_logs, worst_turning_error
from filterpy.kalman import KalmanFilter
from report import write_block

import identifier.preparation
from identifier.identify import FitSettings, identify
from identifier.smoothing import (
    DEFAULT_TAU_S,
    SmoothedTrack,
    constant_acceleration_model,
    smooth_log,
    smooth_track,
)
from scenarios.synthesize import MANEUVERS, REFERENCE_VESSELS, reference_ship, synthesize_log
from trials.run import ModelPlant

STATE_MANEUVERS = ("zigzag-10", "zigzag-20", "turning-35")
STATE_SEEDS = (0, 1, 2)
Q_GRID_DECADES = np.arange(-4.0, 1.01, 0.5)
"""The body-frame jerk density searched, in decades of the per-axis smoother's 2σ_m²/τ."""
TWIN_POSITION_NOISE_M, TWIN_HEADING_NOISE_DEG = 0.001, 0.0001
"""The noise of the twin log whose track stands for the truth [m, deg]."""


def _rotation(psi_rad: np.ndarray) -> np.ndarray:
    """R(ψ) (…, 2, 2): body axes (forward, starboard) to (North, East)."""
    c, s = np.cos(psi_rad), np.sin(psi_rad)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


def body_frame_model(
    interval_s: np.ndarray, mean_heading_rad: np.ndarray, jerk_density: float
) -> tuple[np.ndarray, np.ndarray]:
    """Return F and Q (M, 6, 6) of the state (p_N, p_E, u, v, u̇, v̇) over M intervals.

    Eq. (6) of Shi et al. (2009) (``identifier.smoothing.constant_acceleration_model``,
    whose q = 2σ_m²/τ is the jerk density) on each body axis, the position rows turned
    into the Earth's axes by R(ψ̄); with the same density q on both body axes the
    position block of Q is isotropic and needs no turning.
    """
    accel_std = math.sqrt(jerk_density * DEFAULT_TAU_S / 2.0)
    F3, Q3 = constant_acceleration_model(interval_s, accel_std, DEFAULT_TAU_S)
    F, Q = (np.kron(m, np.eye(2)) for m in (F3, Q3))  # (p, w, ẇ) blocks of both axes
    rot = _rotation(np.asarray(mean_heading_rad, dtype=float))
    F[..., 0:2, 2:6] = rot @ F[..., 0:2, 2:6]
    Q[..., 0:2, 2:6] = rot @ Q[..., 0:2, 2:6]
    Q[..., 2:6, 0:2] = np.swapaxes(Q[..., 0:2, 2:6], -1, -2)
    return F, Q


def _filtered(
    track: SmoothedTrack,
    fixes: list[np.ndarray | None],
    Fs: list[np.ndarray],
    unit_Q: np.ndarray,
    jerk_density: float,
) -> tuple[float, Any, Any, list[np.ndarray], KalmanFilter]:
    """Filter the fixes at one q: log-likelihood, filterpy's means and covariances, Q.

    ``Fs``: the transitions into every sample (the first the identity); ``unit_Q`` the
    process noise of every interval at q = 1 (Q is linear in q).
    """
    t, psi = track.time_s, track.heading_rad
    Qs = [np.zeros((6, 6)), *(jerk_density * unit_Q)]
    body = _rotation(psi[0]).T
    kf = KalmanFilter(dim_x=6, dim_z=2)
    kf.x = np.concatenate(
        [track.states[:2, 0, 0], body @ track.states[:2, 0, 1], body @ track.states[:2, 0, 2]]
    )
    var_position, var_rate = track.variances[0, 0]
    kf.P = np.diag([var_position] * 2 + [var_rate] * 2 + [track.position_accel_std_mps2**2] * 2)
    kf.H = np.hstack([np.eye(2), np.zeros((2, 4))])
    kf.R = np.eye(2) * track.position_noise_m**2
    means, covariances, predicted, predicted_cov = kf.batch_filter(fixes, Fs=Fs, Qs=Qs)
    log_likelihood = 0.0
    for k in range(1, t.size):
        z = fixes[k]
        if z is None:
            continue
        innovation = z - predicted[k][:2]
        S = predicted_cov[k][:2, :2] + kf.R
        log_likelihood -= 0.5 * (
            innovation @ np.linalg.solve(S, innovation) + math.log(np.linalg.det(2 * np.pi * S))
        )
    return log_likelihood, means, covariances, Qs, kf


def body_frame_track(
    x_m: np.ndarray, y_m: np.ndarray, track: SmoothedTrack
) -> tuple[SmoothedTrack, float]:
    """Return ``track`` with its position axes smoothed in the ship's axes, and the q used.

    ``track`` is the paper's smoother's of the fixes ``x_m``, ``y_m`` [m] (its heading,
    noise level and gate decisions are kept); the North and East states and variances
    are replaced by those of the body-frame smoother of the module notes (first-order
    variances, the heading taken as known). Its prior is the paper smoother's state at
    the first sample with that track's variances.
    """
    rejected = set(track.position_rejected.tolist())
    fixes: list[np.ndarray | None] = [
        None if k in rejected else np.array([x_m[k], y_m[k]]) for k in range(len(x_m))
    ]
    psi = track.heading_rad
    F, unit_Q = body_frame_model(np.diff(track.time_s), 0.5 * (psi[1:] + psi[:-1]), 1.0)
    Fs = [np.eye(6), *F]
    per_axis = 2.0 * track.position_accel_std_mps2**2 / track.tau_s
    candidates = (_filtered(track, fixes, Fs, unit_Q, per_axis * 10.0**d) for d in Q_GRID_DECADES)
    best = max(zip(candidates, Q_GRID_DECADES, strict=True), key=lambda c: c[0][0])
    (_, means, covariances, Qs, kf), decade = best
    smoothed, smoothed_cov, _, _ = kf.rts_smoother(means, covariances, Fs, Qs)
    rot = _rotation(track.heading_rad)  # (N, 2, 2)
    ground = np.einsum("nij,nj->ni", rot, smoothed[:, 2:4])  # (ẋ, ẏ) = R(ψ) w
    # d/dt R(ψ)w = R(ψ)ẇ + r·(−ẏ, ẋ)
    turning = track.r_radps[:, None] * np.column_stack([-ground[:, 1], ground[:, 0]])
    ground_rate = np.einsum("nij,nj->ni", rot, smoothed[:, 4:6]) + turning
    rate_cov = rot @ smoothed_cov[:, 2:4, 2:4] @ np.swapaxes(rot, -1, -2)
    states, variances = np.array(track.states), np.array(track.variances)
    for axis in (0, 1):  # North, East
        states[axis] = np.column_stack([smoothed[:, axis], ground[:, axis], ground_rate[:, axis]])
        variances[axis] = np.column_stack([smoothed_cov[:, axis, axis], rate_cov[:, axis, axis]])
    return replace(track, states=states, variances=variances), per_axis * 10.0**decade


@contextlib.contextmanager
def body_frame_smoothing() -> Iterator[None]:
    """Within the block, the identification smooths its logs with :func:`body_frame_track`."""

    def smoothed(t_s: Any, x_m: Any, y_m: Any, heading_rad: Any, **kwargs: Any) -> SmoothedTrack:
        track = smooth_track(t_s, x_m, y_m, heading_rad, **kwargs)
        return body_frame_track(np.asarray(x_m, float), np.asarray(y_m, float), track)[0]

    paper = identifier.preparation.smooth_track
    identifier.preparation.smooth_track = smoothed
    try:
        yield
    finally:
        identifier.preparation.smooth_track = paper


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    edge = slice(20, -20)  # the first and last samples lean on the prior
    return float(np.sqrt(np.mean((a[edge] - b[edge]) ** 2)))


def state_rows(vessel: str) -> list[str]:
    """Table 1's rows of one ship: each manoeuvre, RMS errors over the seeds."""
    ship = reference_ship(vessel, "full")
    rows = []
    for name in STATE_MANEUVERS:
        errors: dict[str, list[float]] = {}
        jerk = []
        for seed in STATE_SEEDS:
            log = synthesize_log(ship, MANEUVERS[name](), seed=seed)
            twin = synthesize_log(
                ship,
                MANEUVERS[name](),
                seed=seed,
                position_noise_m=TWIN_POSITION_NOISE_M,
                heading_noise_deg=TWIN_HEADING_NOISE_DEG,
            )
            truth = smooth_log(twin)
            paper = smooth_log(log)
            body, q = body_frame_track(log.x_m, log.y_m, paper)
            jerk.append(q)
            for label, track in (("paper", paper), ("body", body)):
                for quantity in ("u_mps", "v_mps", "u_dot_mps2", "v_dot_mps2"):
                    errors.setdefault(f"{label} {quantity}", []).append(
                        _rms(getattr(track, quantity), getattr(truth, quantity))
                    )
        cells = []
        for quantity in ("u_mps", "v_mps", "u_dot_mps2", "v_dot_mps2"):
            paper_rms = float(np.mean(errors[f"paper {quantity}"]))
            body_rms = float(np.mean(errors[f"body {quantity}"]))
            cells.append(f"{paper_rms:.3g} / {body_rms:.3g} ({paper_rms / body_rms:.1f}×)")
        rows.append(f"| {vessel} | {name} | " + " | ".join(cells) + f" | {np.median(jerk):.2g} |")
    return rows


def fit_rows(vessel: str, n_draws: int, dt_s: float) -> list[str]:
    """Table 2's rows of one ship: per draw, either smoother's default estimate."""
    ship = reference_ship(vessel, "full")
    truth = indices(ship.plant, ship, dt_s)
    overshoots = [c for c in COLUMNS if "OS" in c]
    rows = []
    for draw in range(n_draws):
        logs = training_logs(ship, draw)
        cells = []
        for candidate in (contextlib.nullcontext(), body_frame_smoothing()):
            start = time.perf_counter()
            with candidate:
                params = identify(logs, FitSettings()).params
            seconds = time.perf_counter() - start
            predicted = indices(ModelPlant(params), ship, dt_s)
            pairs = [(predicted.values[c], truth.values[c]) for c in overshoots]
            worst_os = max(
                (abs(p - t) if p is not None and t is not None else math.inf for p, t in pairs)
            )
            cells += [
                f"{100.0 * worst_turning_error(predicted, truth):.1f}",
                f"{worst_os:.2f}",
                f"{seconds:.0f}",
            ]
        rows.append(f"| {vessel} | {draw} | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    return rows


def main(argv: Sequence[str] | None = None) -> int:
    """Run both tables; print and write them."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--vessel", action="append", choices=REFERENCE_VESSELS, dest="vessels")
    parser.add_argument("--draws", type=int, default=5, help="noise draws of the fits")
    parser.add_argument("--no-fits", action="store_true", help="the states' table only")
    parser.add_argument("--dt-s", type=float, default=0.2, help="driver step [s]")
    parser.add_argument("--out", default=str(Path(__file__).with_name("smoothers.md")))
    args = parser.parse_args(argv)
    vessels = args.vessels or list(REFERENCE_VESSELS)
    lines = [
        "# The ship's velocity smoothed in its own axes (benchmarks/smoothers.py)",
        "",
        "RMS error against the noise-free twin's track, the paper's per-axis smoother / "
        "the body-frame candidate (ratio), mean over noise seeds "
        f"{', '.join(map(str, STATE_SEEDS))} (1 m, 0.1°, 1 Hz); q the candidate's jerk "
        "density [m²/s⁵], median over the seeds:",
        "",
        "| ship | log | u [m/s] | v [m/s] | u̇ [m/s²] | v̇ [m/s²] | q |",
        "|---|---|---|---|---|---|---|",
    ]
    for vessel in vessels:
        lines += state_rows(vessel)
        print(lines[-1], flush=True)
    if not args.no_fits:
        lines += [
            "",
            "Zig-zag-trained fits (10/10 and 20/20, `fidelity.py --draws`' seeds), the "
            "default procedure: worst turning error of the kept estimate [%], largest "
            "overshoot error [°], fit time [s]:",
            "",
            "| ship | draw | paper: worst turn % | worst OS ° | s | candidate: worst turn % "
            "| worst OS ° | s |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for vessel in vessels:
            lines += fit_rows(vessel, args.draws, args.dt_s)
    write_block(args.out, "smoothers.py", lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
