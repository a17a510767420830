"""Model fidelity: which structure predicts manoeuvres it was not trained on (issue 8).

    python benchmarks/fidelity.py [--model NAME ...] [--out benchmarks/fidelity.md]
        [--dt-s 0.2] [--vessel kvlcc2|mariner|tanker]
        [--draws N [--current MODE] [--position-noise-m M] [--training 10/10|20/20]]

Data: full-scale trial logs from a reference ship (``scenarios.synthesize``, ``--vessel``:
the KVLCC2 MMG model by default, or the Mariner's Abkowitz model or Van Berlekom &
Goddard's large tanker, ships of other structures; 1 Hz, 1 m position and 0.1° heading
noise): zig-zag 10/10, zig-zag 20/20 and the 35° starboard turning circle. For every
model structure and two training sets

(a) the two zig-zags only: the turning circle is held out;
(b) all three manoeuvres;

the coefficients are identified (equation-error least squares, then the EKF) and
refined by output error (``identifier.output_error``) from whichever of the two replays the
training logs better (the ``(start)`` row). The table shows all three estimates, the
refined one even when the guards of reference/model_structures.md §6–§7 reject it,
and says which one ``identify`` (default method) keeps. Each coefficient set then sails the standard
manoeuvres from the reference approach condition (``trials.run.run_program`` with
``ModelPlant``, closed-loop zig-zags, as the FMU validation does), and its indices are
compared with the reference ship's own run through the same driver:
35° starboard advance, transfer and tactical diameter (and the port tactical
diameter), first and second overshoot of both zig-zags. Errors are predicted/true − 1
for distances and predicted − true in degrees for overshoots.

Prints a markdown table and writes it into its block of ``--out`` (``report.py``: the
notes around it stay). The recommendation at the end is the structure whose kept
estimate predicts the held-out turning circle of (a) best (largest |error| of advance,
transfer and tactical diameter, both sides).
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from candidates import register_candidates
from intervals import prediction_intervals
from report import fitted_label, write_block

from fmu_model import DEFAULT_MODEL, ModelParameters
from fmu_model.envelope import Envelope, trajectory_envelope
from fmu_model.interface import logged_envelope
from identifier.current import CURRENT_MODES
from identifier.identify import FitSettings, identify
from scenarios.records import Condition
from scenarios.synthesize import (
    FULL_SCALE_LOGGING,
    MANEUVERS,
    REFERENCE_VESSELS,
    TruthShip,
    reference_ship,
    synthesize_log,
)
from trials.logs import ManeuverLog
from trials.maneuvers import Program, turning_circle, zigzag
from trials.metrics import MetricsError, turning_metrics, zigzag_metrics
from trials.run import ModelPlant, Plant, run_program

MODELS = (
    "shi2009",
    "prime-cubic",
    "prime-modulus",
    "prime-rudder[dgamma=0,dwake=0]",
    "prime-rudder",
    "prime-rudder-offset",
    DEFAULT_MODEL,
)
TRAINING = {
    "zig-zags": ("zigzag-10", "zigzag-20"),
    "all three": ("turning-35", "zigzag-10", "zigzag-20"),
}
# The draws' training sets (``--training``): both zig-zags, or one rudder amplitude alone
# (the same log as in the pair): how far a turn is extrapolated in rudder angle.
DRAW_TRAINING = {
    "zig-zags": TRAINING["zig-zags"],
    "10/10": ("zigzag-10",),
    "20/20": ("zigzag-20",),
}
SEEDS = {"turning-35": 0, "zigzag-10": 1, "zigzag-20": 2}
COLUMNS = ("adv", "trf", "TD", "TD port", "10/10 OS1", "10/10 OS2", "20/20 OS1", "20/20 OS2")


@dataclass(frozen=True)
class Indices:
    """Manoeuvre indices of one ship: turning [m] and overshoots [deg]; None = not reached.

    ``beyond``: the programs (``programs()`` keys) sailed beyond the envelope of the
    ship's identification logs (``fmu_model.envelope``); empty when not judged.
    """

    values: dict[str, float | None]
    beyond: frozenset[str] = frozenset()


def programs() -> dict[str, Program]:
    """Return the validation manoeuvres, starboard first."""
    return {
        "turning": turning_circle(math.radians(35.0)),
        "turning port": turning_circle(-math.radians(35.0)),
        "10/10": zigzag(math.radians(10.0), math.radians(10.0)),
        "20/20": zigzag(math.radians(20.0), math.radians(20.0)),
    }


def indices(
    plant: Plant, ship: TruthShip, dt_s: float, envelope: Envelope | None = None
) -> Indices:
    """Sail the validation manoeuvres with ``plant`` at the reference approach.

    With the ``envelope`` of the logs ``plant`` was identified from, say which runs
    leave it.
    """
    values: dict[str, float | None] = dict.fromkeys(COLUMNS)
    beyond = set()
    for name, program in programs().items():
        try:
            with np.errstate(all="ignore"):  # a diverging model is reported as n/a
                run = run_program(
                    plant,
                    program,
                    speed_mps=ship.speed_mps,
                    n_rps=ship.n_rps,
                    rudder_rate_radps=ship.rudder_rate_radps,
                    dt_s=dt_s,
                )
            if envelope is not None and envelope.beyond(trajectory_envelope(run, ship.length_m)):
                beyond.add(name)
            if program.kind == "turning":
                m = turning_metrics(run)
                if name == "turning":
                    values["adv"] = m.advance_m
                    values["trf"] = m.transfer_m
                    values["TD"] = m.tactical_diameter_m
                else:
                    values["TD port"] = m.tactical_diameter_m
            else:
                z = zigzag_metrics(run, program.rudder_rad, program.heading_rad)
                values[f"{name} OS1"] = z.first_overshoot_deg
                values[f"{name} OS2"] = z.second_overshoot_deg
        except (FloatingPointError, MetricsError):
            continue  # diverged or never reached the index: stays None
    return Indices(values, frozenset(beyond))


def index_errors(
    predicted: Indices, truth: Indices, keys: Sequence[str] = COLUMNS
) -> dict[str, float | None]:
    """Return the error of each index in ``keys``; None where either was not reached.

    Distances: predicted/true − 1 [%]; overshoots: predicted − true [deg].
    """
    out: dict[str, float | None] = {}
    for key in keys:
        p, t = predicted.values[key], truth.values[key]
        if p is None or t is None:
            out[key] = None
        else:
            out[key] = p - t if "OS" in key else 100.0 * (p / t - 1.0)
    return out


def errors(predicted: Indices, truth: Indices) -> list[str]:
    """Table cells of :func:`index_errors`."""
    return [
        "n/a" if e is None else f"{e:+.2f}°" if "OS" in key else f"{e:+.1f}%"
        for key, e in index_errors(predicted, truth).items()
    ]


def worst_turning_error(predicted: Indices, truth: Indices) -> float:
    """Largest |relative error| of advance, transfer and both tactical diameters (inf: n/a)."""
    worst = 0.0
    for key in ("adv", "trf", "TD", "TD port"):
        p, t = predicted.values[key], truth.values[key]
        if p is None or t is None:
            return math.inf
        worst = max(worst, abs(p / t - 1.0))
    return worst


# Columns as (program of ``programs()``, Monte-Carlo metric, degrees?).
_MC_COLUMNS = {
    "adv": ("turning", "advance_m"),
    "trf": ("turning", "transfer_m"),
    "TD": ("turning", "tactical_diameter_m"),
    "TD port": ("turning port", "tactical_diameter_m"),
    "10/10 OS1": ("10/10", "first_overshoot_rad"),
    "10/10 OS2": ("10/10", "second_overshoot_rad"),
    "20/20 OS1": ("20/20", "first_overshoot_rad"),
    "20/20 OS2": ("20/20", "second_overshoot_rad"),
}


@dataclass(frozen=True)
class Coverage:
    """How many reference values the 95 % intervals contain, without and with model form.

    ``within``: (inside with model form, judged) of the values whose manoeuvre stays
    within the envelope of the identification logs.
    """

    identification: int
    with_model_form: int
    judged: int
    width_ratio: float  # mean (with model form) / (identification only) width
    within: tuple[int, int]


def coverage(
    params: ModelParameters, ship: TruthShip, truth: Indices, predicted: Indices, dt_s: float
) -> Coverage:
    """Intervals of ``params``' predictions (100 Monte-Carlo samples, model form) vs the truth."""
    chosen = programs()
    intervals = prediction_intervals(
        params,
        list(chosen.values()),
        Condition(ship.speed_mps, ship.n_rps, ship.rudder_rate_radps, dt_s),
    )
    inside = [0, 0]
    judged = 0
    widths = [0.0, 0.0]
    within = [0, 0]
    for column, (key, metric) in _MC_COLUMNS.items():
        true = truth.values[column]
        interval = intervals.get((chosen[key].name, metric))
        if true is None or interval is None:
            continue
        judged += 1
        scale = math.degrees(1.0) if metric.endswith("_rad") else 1.0
        for i, (a, b) in enumerate((interval.identification, interval.with_model_form)):
            inside[i] += scale * a <= true <= scale * b
            widths[i] += scale * (b - a)
        if key not in predicted.beyond:
            lo, hi = interval.with_model_form
            within[0] += scale * lo <= true <= scale * hi
            within[1] += 1
    ratio = widths[1] / widths[0] if widths[0] else math.nan
    return Coverage(inside[0], inside[1], judged, ratio, (within[0], within[1]))


def training_logs(
    ship: TruthShip,
    draw: int,
    position_noise_m: float = FULL_SCALE_LOGGING.position_noise_m,
    training: str = "zig-zags",
) -> list[ManeuverLog]:
    """Return the zig-zag training logs of noise draw ``draw`` (seeds ``10·d + 1``, ``+ 2``).

    ``position_noise_m``: their GNSS noise [m] (the compass's and the rate as logged at
    full scale); ``training``: a key of :data:`DRAW_TRAINING`.
    """
    return [
        synthesize_log(
            ship, MANEUVERS[name](), seed=10 * draw + SEEDS[name], position_noise_m=position_noise_m
        )
        for name in DRAW_TRAINING[training]
    ]


def draws_table(
    models: Sequence[str],
    n_draws: int,
    dt_s: float,
    vessel: str,
    current: str | None = None,
    position_noise_m: float = FULL_SCALE_LOGGING.position_noise_m,
    training: str = "zig-zags",
) -> list[str]:
    """Zig-zag-trained fits at ``n_draws`` noise draws: errors of both estimates per draw.

    Training logs of the reference ship ``vessel``: zig-zag 10/10 and 20/20 with noise
    seeds ``10·d + 1`` and ``10·d + 2`` for draw d and GNSS noise ``position_noise_m``
    [m] (the default 1 m; a quieter logger no longer widens the turns, ``smoothers.md``),
    or one of them alone (``training``, a key of :data:`DRAW_TRAINING`); the turning
    circles are held out.
    Rows: the EKF estimate (``--method ekf``) and the one the default ``identify`` keeps,
    fitted with ``current`` (``FitSettings.current``; None: ``fit``'s default, a ship's
    constant current); the row's draw names the mode a fit with "auto" kept.
    """
    ship = reference_ship(vessel, "full")
    truth = indices(ship.plant, ship, dt_s)
    lines = [
        "| model | draw | estimate | " + " | ".join(COLUMNS) + " | worst turn | s | "
        "in 95 % (id only / with model form) | within the logs' envelope: in 95 % | "
        "width × |",
        "|" + "---|" * (len(COLUMNS) + 8),
    ]
    for model in models:
        for draw in range(n_draws):
            logs = training_logs(ship, draw, position_noise_m, training)
            start = time.perf_counter()
            result = identify(logs, FitSettings(model=model, current=current))
            seconds = time.perf_counter() - start
            choice = result.current_choice
            shown_draw = str(draw) if choice is None else f"{draw} (auto → {choice.kept})"
            r = result.refinement
            assert r is not None
            fits = {
                "EKF": r.initial.params.with_vector(result.ekf.theta),
                "default": result.params,
            }
            for estimate, params in fits.items():
                predicted = indices(ModelPlant(params), ship, dt_s, logged_envelope(params))
                worst = worst_turning_error(predicted, truth)
                shown = fitted_label(model, params.model)
                row = [shown, shown_draw, estimate, *errors(predicted, truth)]
                row += [f"{worst:.1%}" if math.isfinite(worst) else "n/a"]
                row += [f"{seconds:.0f}" if estimate == "EKF" else ""]
                if estimate == "default":
                    c = coverage(params, ship, truth, predicted, dt_s)
                    row += [
                        f"{c.identification} / {c.with_model_form} of {c.judged}",
                        f"{c.within[0]} of {c.within[1]}",
                        f"{c.width_ratio:.2f}",
                    ]
                else:
                    row += ["", "", ""]
                lines.append("| " + " | ".join(row) + " |")
                print(lines[-1], flush=True)
    return lines


def _block(name: str, vessel: str) -> str:
    """Name of the table's block in ``--out``: KVLCC2's as before, another ship's its own."""
    return name if vessel == "kvlcc2" else f"{name} {vessel}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; print and write the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument(
        "--model",
        action="append",
        dest="models",
        help=f"model to assess (repeat; default: {', '.join(MODELS)}; issue 13's "
        f"candidates: {', '.join(register_candidates())})",
    )
    parser.add_argument("--out", default=str(Path(__file__).with_name("fidelity.md")))
    parser.add_argument("--dt-s", type=float, default=0.2, help="driver step [s]")
    parser.add_argument(
        "--vessel",
        choices=REFERENCE_VESSELS,
        default="kvlcc2",
        help="reference ship the logs are synthesised from and the predictions judged by",
    )
    parser.add_argument(
        "--draws", type=int, default=0, help="instead of the table: N noise draws, zig-zag-trained"
    )
    parser.add_argument(
        "--current",
        choices=CURRENT_MODES,
        help="with --draws: the fits' current (default: fit's, a constant one at a ship's size)",
    )
    default_noise = FULL_SCALE_LOGGING.position_noise_m
    parser.add_argument(
        "--position-noise-m",
        type=float,
        default=default_noise,
        help=f"with --draws: the logs' GNSS noise [m] (default {default_noise:g}; "
        "another level writes a block of its own)",
    )
    parser.add_argument(
        "--training",
        choices=DRAW_TRAINING,
        default="zig-zags",
        help="with --draws: both zig-zags (default) or one rudder amplitude alone (a block "
        "of its own)",
    )
    args = parser.parse_args(argv)
    if args.draws:
        models = args.models or [MODELS[-1]]
        noise = args.position_noise_m
        lines = draws_table(
            models, args.draws, args.dt_s, args.vessel, args.current, noise, args.training
        )
        block = _block("fidelity.py draws", args.vessel)
        block += "" if noise == default_noise else f" {noise:g} m"
        block += "" if args.training == "zig-zags" else f" {args.training} only"
        write_block(args.out, block, lines)
        return 0

    ship = reference_ship(args.vessel, "full")
    logs: dict[str, ManeuverLog] = {
        name: synthesize_log(ship, MANEUVERS[name](), seed=seed) for name, seed in SEEDS.items()
    }
    truth = indices(ship.plant, ship, args.dt_s)
    lines = [
        f"# Model fidelity on {ship.name} (benchmarks/fidelity.py)",
        "",
        f"Reference ({ship.source}, same driver): "
        + ", ".join(
            f"{k} {v:.1f} m" if "OS" not in k else f"{k} {v:.2f}°"
            for k, v in truth.values.items()
            if v is not None
        ),
        "",
        "Errors: distances predicted/true − 1, overshoots predicted − true. "
        "(a) = trained on the zig-zags only, the turning circle is held out; "
        "(b) = trained on all three. `kept` = the estimate default `identify` keeps. "
        "n/a = the run diverged or never reached the index. Replay RMS = position error "
        "of the open-loop replays of the training logs from execute on.",
        "",
        "| model | training | estimate | kept | " + " | ".join(COLUMNS) + " | replay RMS [L] | s |",
        "|" + "---|" * (len(COLUMNS) + 6),
    ]
    held_out: dict[str, float] = {}
    for model in args.models or MODELS:
        for label, names in TRAINING.items():
            tag = "(a) zig-zags" if label == "zig-zags" else "(b) all three"
            start = time.perf_counter()
            result = identify([logs[n] for n in names], FitSettings(model=model))
            seconds = time.perf_counter() - start
            r = result.refinement
            assert r is not None
            start_params = r.initial.params
            fits: list[tuple[str, ModelParameters, float | None, bool]] = [
                ("EKF", start_params.with_vector(result.ekf.theta), None, False),
                (
                    "equation-error",
                    start_params.with_vector(result.equation_error.theta),
                    None,
                    False,
                ),
                ("refined", r.refined.params, r.refined.position_rms_L, r.kept == "refined"),
            ]
            start_row = 0 if r.initial_method == "ekf" else 1
            fits[start_row] = (
                f"{fits[start_row][0]} (start)",
                start_params,
                r.initial.position_rms_L,
                r.kept == "initial",
            )
            for estimate, params, rms, kept in fits:
                predicted = indices(ModelPlant(params), ship, args.dt_s)
                if kept and label == "zig-zags":
                    held_out[model] = worst_turning_error(predicted, truth)
                shown = fitted_label(model, params.model)
                row = [shown, tag, estimate, "yes" if kept else "", *errors(predicted, truth)]
                row += [
                    "" if rms is None else f"{rms:.3f}",
                    f"{seconds:.0f}" if estimate.startswith("EKF") else "",
                ]
                lines.append("| " + " | ".join(row) + " |")
                print(lines[-1], flush=True)
            if r.kept == "initial":
                lines.append(f"| | | | | guard: {r.reason} |" + " |" * (len(COLUMNS) + 1))
    best = min(held_out, key=lambda m: held_out[m])
    lines += [
        "",
        "Held-out turning circle, (a), estimate kept, worst |error| of advance, transfer, "
        "tactical diameter: "
        + ", ".join(
            f"{m} " + (f"{e:.1%}" if math.isfinite(e) else "n/a") for m, e in held_out.items()
        )
        + f". Best on this ship's held-out turn: **{best}** (the default, {DEFAULT_MODEL}, is "
        "chosen on every ship and on the measured runs: fmu_model.variants.DEFAULT_MODEL).",
    ]
    write_block(args.out, _block("fidelity.py", args.vessel), lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
