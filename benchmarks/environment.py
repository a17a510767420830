"""Identification at sea: calm-water predictions from logs sailed in current and wind (issue 14).

    python benchmarks/environment.py [--current-mps C ...] [--current-to-deg D ...]
        [--wind-mps W ...] [--wind-from-deg D] [--draws N] [--position-noise-m 1]
        [--heading-noise-deg 0.1] [--model NAME] [--method output-error|ekf]
        [--current constant|auto|per-log] [--tide-deg T] [--same-noise]
        [--calm-speed-log] [--speed-log-axes 1|2 [--speed-log-x-m X]] [--no-speed-log]
        [--gnss-jump-pct P] [--compass-spike-pct P]
        [--out benchmarks/environment.md]

For every condition (a uniform current of each speed towards each direction, crossed with
each true wind speed from ``--wind-from-deg``) and every noise draw d, the KVLCC2 reference
ship (``scenarios.synthesize``, full scale, 1 Hz, by default 1 m / 0.1° noise) sails zig-zag
10/10 and 20/20 in it (noise seeds 10·d + 1, 10·d + 2, as ``benchmarks/fidelity.py --draws``),
with its logger recording the relative wind and the speed through the water; the calm-water
logs have the same noise seeds (the same noise only where a log keeps its length:
``synthesize_log`` draws the x and y noise after the heading's from one generator, and a
wind ends the zig-zags a few samples earlier; ``environment.md``). With ``--same-noise``
every log draws each channel's noise from a generator of its own
(``synthesize_log(noise_per_channel=True)``), so the calm-water and the sea logs of a draw
carry the same noise sample by sample (other noise than the default's). With
``--calm-speed-log`` the calm-water logs carry the speed log too, as the logs at sea do; with
``--speed-log-axes 2`` the speed logs have a transverse axis too (a two-axis Doppler log's
``stw_transverse_mps``), at ``--speed-log-x-m`` forward of midship (default 0); with
``--no-speed-log`` the logs at sea carry none (the current from the track alone). With
``--position-noise-m 0.01 --heading-noise-deg 0.001`` what remains is the sea's own effect
on the identification, without the noise's. With ``--gnss-jump-pct P`` P % of the fixes of
the sea logs jump 50–1000 m (``scenarios.synthesize.with_gnss_jumps``), the calm logs'
not; with ``--current-mps 0 --wind-mps 0`` the condition is calm water itself, so the
rows compare the glitched logs with the clean ones (issue 14's glitch bar). With
``--compass-spike-pct P`` P % of the sea logs' headings spike 5–180° either way
(``with_compass_spikes``: a gyro's garbled serial line), alike. With
``--tide-deg T`` the 20/20 zig-zag is sailed in the current turned by T (a run at another
time of the tide: 180, the ebb after the flood), the 10/10 in the condition's. Two fits:

* ``default``: ``identify`` with the default settings (the current estimated, constant;
  with ``--current auto`` a constant one where the training logs show it, else none, a
  constant one with a speed log; ``--current per-log`` one of each log's own; the table
  says which each fit kept; the
  model family ``--model``, by default the default one; the procedure ``--method``, by
  default output error, ``ekf`` the seed paper's EKF estimate) and
  the ship's windage (``--windage``), so the measured wind's load is taken out;
* ``--current none``: the same, but the water taken as still (today's behaviour for a user
  who does not model the sea; the windage is still given).

Each fit predicts the calm-water standard manoeuvres (35° turn both sides, zig-zags 10/10 and
20/20) through the same driver as ``benchmarks/fidelity.py``; the table shows, per draw, the
largest difference of a turning index [percentage points] and of an overshoot [deg] from
what the default procedure gives from the calm-water logs of the same draw, and the error of
the current estimate (speed [m/s], direction [deg]; of the log whose estimate is the
farthest from its own current) with its eᵀC⁻¹e under the EKF's covariance
and under the covariance with the model-form term (``identifier.current.current_model_form``;
calibrated: χ²₂, mean 2). Issue 14's bar: within 1 point and
0.5°, and the current within 0.05 m/s and 5°, in every draw. The table goes into its block
of ``--out`` (``report.py``: the notes around it stay), row by row.
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from fidelity import SEEDS, Indices, index_errors, indices
from report import write_block
from sensitivity import BASELINE, LogQuality

from fmu_model import DEFAULT_MODEL, model_names
from identifier.current import DEFAULT_CURRENT, PER_LOG, CurrentEstimate, kept_current
from identifier.identify import FitSettings, IdentificationResult, identify
from scenarios.kvlcc2 import kvlcc2_windage
from scenarios.sea import SeaEnvironment
from scenarios.synthesize import (
    MANEUVERS,
    TruthShip,
    reference_ship,
    synthesize_log,
    with_glitches,
)
from trials.errors import IdentificationError
from trials.logs import ManeuverLog
from trials.run import ModelPlant

TRAINING = ("zigzag-10", "zigzag-20")
TURNING_KEYS = ("adv", "trf", "TD", "TD port")
OVERSHOOT_KEYS = ("10/10 OS1", "10/10 OS2", "20/20 OS1", "20/20 OS2")


@dataclass(frozen=True)
class Condition:
    """One sea state of the grid: current (towards) and true wind (from), SI units."""

    current_mps: float
    current_to_deg: float
    wind_mps: float
    wind_from_deg: float

    def environment(self) -> SeaEnvironment | None:
        """Return the reference ship's environment; None for calm water."""
        if self.current_mps == 0.0 and self.wind_mps == 0.0:
            return None
        return SeaEnvironment(
            current_speed_mps=self.current_mps,
            current_to_rad=math.radians(self.current_to_deg),
            wind_speed_mps=self.wind_mps,
            wind_from_rad=math.radians(self.wind_from_deg),
        )

    def label(self) -> str:
        """Table cell, e.g. ``0.5 m/s → 45°, wind 10 m/s``."""
        current = (
            f"{self.current_mps:g} m/s → {self.current_to_deg:g}°" if self.current_mps else "none"
        )
        wind = f"{self.wind_mps:g} m/s from {self.wind_from_deg:g}°" if self.wind_mps else "none"
        return f"current {current}, wind {wind}"


def training_logs(
    condition: Condition,
    draw: int,
    quality: LogQuality,
    *,
    same_noise: bool = False,
    speed_log: bool = False,
    speed_log_axes: int = 1,
    speed_log_x_m: float = 0.0,
    gnss_jump_fraction: float = 0.0,
    compass_spike_fraction: float = 0.0,
    tide_deg: float = 0.0,
) -> list[ManeuverLog]:
    """Sail the zig-zags of draw ``draw`` in ``condition``, logged at ``quality``.

    ``same_noise``: one noise generator per channel (module docstring). ``speed_log``:
    calm-water logs carry the speed log too (sailed in a sea of no current and no wind,
    which moves the ship exactly as calm water does); at sea they always do.
    ``speed_log_axes``, ``speed_log_x_m``: the speed log's axes and, with two, its
    position (``synthesize_log``). ``gnss_jump_fraction``: that share of the fixes jumps
    and ``compass_spike_fraction``: that share of the headings spikes
    (``scenarios.synthesize.with_glitches``, seeded by the log's noise seed).
    ``tide_deg``: the logs after the first are sailed in the current turned by that angle.
    """
    logs = []
    for i, name in enumerate(TRAINING):
        turned = replace(condition, current_to_deg=condition.current_to_deg + tide_deg * (i > 0))
        environment = turned.environment()
        if environment is None and speed_log:
            environment = SeaEnvironment()
        ship = reference_ship("kvlcc2", "full", environment)
        seed = 10 * draw + SEEDS[name]
        log = synthesize_log(
            ship,
            MANEUVERS[name](),
            seed=seed,
            rate_hz=quality.rate_hz,
            position_noise_m=quality.position_noise_m,
            heading_noise_deg=quality.heading_noise_deg,
            noise_per_channel=same_noise,
            speed_log_axes=speed_log_axes if environment is not None else 1,
            speed_log_x_m=speed_log_x_m,
        )
        logs.append(
            with_glitches(
                log,
                seed,
                gnss_jump_fraction=gnss_jump_fraction,
                compass_spike_fraction=compass_spike_fraction,
            )
        )
    return logs


def worst_differences(predicted: Indices, calm: Indices, truth: Indices) -> tuple[float, float]:
    """Largest |difference| from the calm-log prediction: turning [points], overshoots [deg]."""
    p = index_errors(predicted, truth)
    c = index_errors(calm, truth)
    both = {k: (pk, ck) for k in p if (pk := p[k]) is not None and (ck := c[k]) is not None}
    turning = [abs(a - b) for k, (a, b) in both.items() if k in TURNING_KEYS]
    overshoot = [abs(a - b) for k, (a, b) in both.items() if k in OVERSHOOT_KEYS]
    if len(turning) < len(TURNING_KEYS) or len(overshoot) < len(OVERSHOOT_KEYS):
        return math.inf, math.inf
    return max(turning), max(overshoot)


def current_vector(condition: Condition) -> np.ndarray:
    """Return the condition's current (North, East) [m/s]."""
    angle = math.radians(condition.current_to_deg)
    return condition.current_mps * np.array([math.cos(angle), math.sin(angle)])


def _log_currents(
    result: IdentificationResult, logs: Sequence[ManeuverLog], truths: Sequence[Condition]
) -> list[tuple[CurrentEstimate, Condition]]:
    """Pair the current each of ``logs`` was fitted in with the condition it was sailed in.

    ``truths[i]`` is the condition of ``logs[i]``; a fit with a current per log keeps each
    log's own (in its order, ``result.logs``), else one for all.
    """
    assert result.current is not None
    own = result.current.logs or (result.current,) * len(result.logs)
    return [(c, truths[logs.index(log)]) for c, log in zip(own, result.logs, strict=True)]


def current_error(
    result: IdentificationResult, logs: Sequence[ManeuverLog], truths: Sequence[Condition]
) -> tuple[float, float]:
    """Error of the current estimate: |ĉ − c| [m/s] and direction [deg] (nan without one).

    Of the log whose current is the farthest from the one it was sailed in (``truths``, one
    condition per log of ``logs``).
    """
    if result.current is None:
        return math.nan, math.nan
    speed, estimate, truth = max(
        ((float(np.hypot(*(c.vector - current_vector(t)))), c, t)
         for c, t in _log_currents(result, logs, truths)),
        key=lambda item: item[0],
    )  # fmt: skip
    if truth.current_mps == 0.0:
        return speed, math.nan
    angle = math.degrees(estimate.to_rad) - truth.current_to_deg
    return speed, (angle + 180.0) % 360.0 - 180.0


def current_consistency(
    result: IdentificationResult, logs: Sequence[ManeuverLog], truths: Sequence[Condition]
) -> tuple[float, float]:
    """eᵀC⁻¹e of the current's error e with the EKF's covariance and with the model form.

    χ²₂-distributed for a calibrated estimate (mean 2, 95 % below 5.99); the largest over
    the logs (as :func:`current_error`); nan without a current estimate.
    """
    if result.current is None:
        return math.nan, math.nan
    pairs = [(c, c.vector - current_vector(t)) for c, t in _log_currents(result, logs, truths)]
    return (
        max(float(e @ np.linalg.solve(c.covariance, e)) for c, e in pairs),
        max(float(e @ np.linalg.solve(c.total_covariance, e)) for c, e in pairs),
    )


def main(argv: Sequence[str] | None = None) -> int:
    """Run the grid; print and write the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--current-mps", type=float, action="append", dest="currents")
    parser.add_argument("--current-to-deg", type=float, action="append", dest="directions")
    parser.add_argument("--wind-mps", type=float, action="append", dest="winds")
    parser.add_argument("--wind-from-deg", type=float, default=90.0)
    parser.add_argument("--draws", type=int, default=5)
    parser.add_argument("--position-noise-m", type=float, default=BASELINE.position_noise_m)
    parser.add_argument("--heading-noise-deg", type=float, default=BASELINE.heading_noise_deg)
    parser.add_argument("--dt-s", type=float, default=0.2, help="driver step [s]")
    parser.add_argument(
        "--model", default=DEFAULT_MODEL, choices=model_names(), help="model family of every fit"
    )
    parser.add_argument(
        "--method",
        default="output-error",
        choices=("output-error", "ekf"),
        help="procedure of every fit (default: output-error, the default of fit)",
    )
    parser.add_argument(
        "--current",
        default=DEFAULT_CURRENT,
        choices=("constant", "auto", PER_LOG),
        help="the current of the default fits (default: constant, fit's default for a ship)",
    )
    parser.add_argument(
        "--tide-deg",
        type=float,
        default=0.0,
        help="the 20/20 zig-zag sailed in the current turned by this angle [deg]: a run at "
        "another time of the tide (default 0: one current for both)",
    )
    parser.add_argument(
        "--same-noise",
        action="store_true",
        help="one noise generator per channel: calm and sea logs of a draw share their noise",
    )
    parser.add_argument(
        "--calm-speed-log",
        action="store_true",
        help="the calm-water logs carry a speed log too, as the logs at sea do",
    )
    parser.add_argument(
        "--speed-log-axes",
        type=int,
        choices=(1, 2),
        default=1,
        help="the speed logs' axes: 1 along the ship, 2 across it too (a Doppler log)",
    )
    parser.add_argument(
        "--speed-log-x-m",
        type=float,
        default=0.0,
        help="a two-axis log's position forward of midship [m] (default 0)",
    )
    parser.add_argument(
        "--no-speed-log",
        action="store_true",
        help="the logs at sea carry no speed log (a trial without one: the current from the "
        "track alone)",
    )
    parser.add_argument(
        "--gnss-jump-pct",
        type=float,
        default=0.0,
        help="that share of the sea logs' fixes jumps 50-1000 m [%%]; with no current and "
        "no wind the calm logs themselves, glitched (issue 14's glitch bar)",
    )
    parser.add_argument(
        "--compass-spike-pct",
        type=float,
        default=0.0,
        help="that share of the sea logs' headings spikes 5-180 deg [%%]; with no current "
        "and no wind the calm logs themselves, spiked",
    )
    parser.add_argument("--out", default=str(Path(__file__).with_name("environment.md")))
    args = parser.parse_args(argv)
    if args.no_speed_log and (args.calm_speed_log or args.speed_log_axes == 2):
        parser.error("--no-speed-log excludes --calm-speed-log and --speed-log-axes 2")
    quality = replace(
        BASELINE, position_noise_m=args.position_noise_m, heading_noise_deg=args.heading_noise_deg
    )
    currents = args.currents or [0.0, 0.25, 0.5, 1.0]
    directions = args.directions or [0.0, 90.0, 180.0, 270.0]
    winds = args.winds or [0.0, 10.0, 15.0]
    conditions = [
        Condition(c, d, w, args.wind_from_deg)
        for c in currents
        for d in (directions if c else [0.0])
        for w in winds
        if c or w or args.gnss_jump_pct or args.compass_spike_pct
    ]
    settings = FitSettings(model=args.model, method=args.method, current=args.current)
    same = args.same_noise
    ship: TruthShip = reference_ship("kvlcc2", "full")
    truth = indices(ship.plant, ship, args.dt_s)
    windage = kvlcc2_windage("full")
    lines = [
        "# Identification at sea (benchmarks/environment.py)",
        "",
        "Zig-zag 10/10 + 20/20 of the KVLCC2 reference sailed in a uniform current and a "
        "true wind; calm-water predictions (35° turn both sides, both zig-zags) compared "
        "with what the same procedure gives from the calm-water logs of the same noise "
        f"draw (logger noise {quality.position_noise_m:g} m, {quality.heading_noise_deg:g}°"
        f"{', one noise generator per channel' if same else ''}"
        f"{'; the calm-water logs with a speed log too' if args.calm_speed_log else ''}"
        f"{'; two-axis speed logs' if args.speed_log_axes == 2 else ''}"
        f"{f' at {args.speed_log_x_m:g} m forward' if args.speed_log_x_m else ''}"
        f"{'; no speed log at sea' if args.no_speed_log else ''}"
        f"{f'; {args.gnss_jump_pct:g} % GNSS jumps' if args.gnss_jump_pct else ''}"
        f"{f'; {args.compass_spike_pct:g} % compass spikes' if args.compass_spike_pct else ''}"
        f"{f'; the 20/20 in the current turned by {args.tide_deg:g}°' if args.tide_deg else ''}; "
        f"model {args.model}, "
        f"method {args.method}, current {args.current}). "
        "Columns: largest difference of a turning index [points] and of an overshoot "
        "[deg]; error of the current estimate [m/s, deg] and its eᵀC⁻¹e with the EKF's "
        "covariance / with the model-form term (χ²₂: mean 2, 95 % below 5.99); fit time [s]; "
        "the current the calm and the sea fit kept (with ``--current auto``).",
        "",
        "| condition | draw | calm fit s | default: turn Δ | OS Δ | current err m/s | dir err ° "
        "| eᵀC⁻¹e | s | kept calm / sea | --current none: turn Δ | OS Δ |",
        "|" + "---|" * 12,
    ]
    print("\n".join(lines), flush=True)
    calm: dict[int, tuple[Indices, float, str]] = {}
    for draw in range(args.draws):
        start = time.perf_counter()
        calm_fit = identify(
            training_logs(
                Condition(0.0, 0.0, 0.0, 0.0),
                draw,
                quality,
                same_noise=same,
                speed_log=args.calm_speed_log,
                speed_log_axes=args.speed_log_axes,
                speed_log_x_m=args.speed_log_x_m,
            ),
            settings,
        )
        calm[draw] = (indices(ModelPlant(calm_fit.params), ship, args.dt_s),
                      time.perf_counter() - start, kept_current(calm_fit.params))  # fmt: skip
    for condition in conditions:
        for draw in range(args.draws):
            logs = training_logs(
                condition,
                draw,
                quality,
                same_noise=same,
                speed_log_axes=args.speed_log_axes,
                speed_log_x_m=args.speed_log_x_m,
                gnss_jump_fraction=args.gnss_jump_pct / 100.0,
                compass_spike_fraction=args.compass_spike_pct / 100.0,
                tide_deg=args.tide_deg,
            )
            if args.no_speed_log:
                logs = [replace(g, stw_mps=None, stw_transverse_mps=None) for g in logs]
            start = time.perf_counter()
            sea = identify(logs, replace(settings, windage=windage))
            seconds = time.perf_counter() - start
            sea_turn, sea_os = worst_differences(
                indices(ModelPlant(sea.params), ship, args.dt_s), calm[draw][0], truth
            )
            try:  # the still-water fit of logs in a current may fail: recorded as inf
                still = identify(logs, replace(settings, windage=windage, current="none"))
                still_turn, still_os = worst_differences(
                    indices(ModelPlant(still.params), ship, args.dt_s), calm[draw][0], truth
                )
            except IdentificationError:
                still_turn = still_os = math.inf
            turned = replace(condition, current_to_deg=condition.current_to_deg + args.tide_deg)
            truths = [condition] + [turned] * (len(logs) - 1)
            speed_err, angle_err = current_error(sea, logs, truths)
            identification_only, with_model_form = current_consistency(sea, logs, truths)
            row = [
                condition.label(),
                str(draw),
                f"{calm[draw][1]:.0f}",
                f"{sea_turn:.1f}",
                f"{sea_os:.2f}",
                f"{speed_err:.3f}",
                "" if math.isnan(angle_err) else f"{angle_err:+.1f}",
                f"{identification_only:.2f} / {with_model_form:.2f}",
                f"{seconds:.0f}",
                f"{calm[draw][2]} / {kept_current(sea.params)}",
                f"{still_turn:.1f}",
                f"{still_os:.2f}",
            ]
            lines.append("| " + " | ".join(row) + " |")
            print(lines[-1], flush=True)
            write_block(args.out, "environment.py", lines)
    write_block(args.out, "environment.py", lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
