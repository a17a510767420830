"""Sensitivity to log quality: what trial instrumentation the identification needs (issue 8).

    python benchmarks/sensitivity.py [--model NAME] [--method ekf|output-error] [--quick]
        [--factor rate_hz ...] [--seeds 10] [--out benchmarks/sensitivity.md] [--dt-s 0.2]

Data: KVLCC2 full-scale trial logs from the MMG reference ship (``scenarios.synthesize``):
the 35° starboard turning circle, zig-zag 10/10 and zig-zag 20/20, all three used for
training. One factor at a time is varied around the baseline of ``benchmarks/fidelity.py``
(1 m position noise, 0.1° heading noise, 1 Hz):

- position noise σ 0.5, 1, 2, 5 m (North and East);
- heading noise σ 0.05, 0.1, 0.2, 0.5°;
- logging rate 0.5, 1, 2, 5, 10 Hz.

A last row sets all three to their best (0.5 m, 0.05°, 10 Hz): what remains there is
the error of the model structure, not of the logs. ``--quick`` runs only the two
extremes of each factor (and that row); ``--factor`` only the factors named (without
it). Every condition is repeated with ``--seeds`` noise realisations; realisation k
uses the same seeds in every condition (common random numbers), so a difference between
rows is the factor's, not the draw's. The measurement noise is estimated from the logs,
as for a user's own trial.

Each identified model (``identifier.identify.identify`` with ``--model``, default
``fmu_model.DEFAULT_MODEL``; the EKF estimate unless ``--method output-error``) sails the
standard manoeuvres from the reference approach through the driver of ``benchmarks/fidelity.py``
(``indices``), and its indices are compared with the reference ship's own run through
the same driver: advance, transfer and tactical diameter of the 35° turn
(predicted/true − 1 [%]) and first and second overshoot of both zig-zags
(predicted − true [°]). Cells are mean ± standard deviation over the realisations; the
worst columns are the largest magnitude over all realisations (the turning one also
over the tactical diameter of the held-out port turn). The identification wall
time is the mean per realisation, after a warm-up fit (numba compilation not timed).

Prints a markdown table and writes it into its block of ``--out`` (``report.py``: the notes
around it stay); progress goes to stderr.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path

from fidelity import SEEDS, Indices, index_errors, indices, worst_turning_error
from report import write_block
from tqdm import tqdm

from fmu_model import DEFAULT_MODEL, model_names
from identifier.identify import METHODS, FitSettings, identify
from scenarios.synthesize import MANEUVERS, TruthShip, reference_ship, synthesize_log
from trials.errors import IdentificationError
from trials.logs import ManeuverLog
from trials.run import ModelPlant

TURNING = ("adv", "trf", "TD")
OVERSHOOTS = ("10/10 OS1", "10/10 OS2", "20/20 OS1", "20/20 OS2")
REPORTED = TURNING + OVERSHOOTS


@dataclass(frozen=True)
class LogQuality:
    """Instrumentation of one set of trial logs.

    Parameters
    ----------
    position_noise_m : float
        Standard deviation of the North and East position noise [m].
    heading_noise_deg : float
        Standard deviation of the heading noise [deg].
    rate_hz : float
        Logging rate [Hz].

    """

    position_noise_m: float
    heading_noise_deg: float
    rate_hz: float


BASELINE = LogQuality(position_noise_m=1.0, heading_noise_deg=0.1, rate_hz=1.0)
SWEEPS: dict[str, tuple[float, ...]] = {
    "position_noise_m": (0.5, 1.0, 2.0, 5.0),
    "heading_noise_deg": (0.05, 0.1, 0.2, 0.5),
    "rate_hz": (0.5, 1.0, 2.0, 5.0, 10.0),
}
# All three at their best together: the error left is the model structure's.
BEST = LogQuality(position_noise_m=0.5, heading_noise_deg=0.05, rate_hz=10.0)


@dataclass(frozen=True)
class Outcome:
    """Results of one log quality over all noise realisations.

    Parameters
    ----------
    errors : tuple of dict
        Per identified realisation, the error of each ``REPORTED`` index: [%] for the
        turning distances, [deg] for the overshoots; None = the index was not reached.
    worst_turning : tuple of float
        Per identified realisation, the largest |relative error| of advance, transfer and
        tactical diameter [-] (inf: one was not reached).
    seconds : tuple of float
        Identification wall time of each realisation [s].
    failures : tuple of str
        Messages of the realisations whose identification failed.

    """

    errors: tuple[dict[str, float | None], ...]
    worst_turning: tuple[float, ...]
    seconds: tuple[float, ...]
    failures: tuple[str, ...]


def sweep(quick: bool = False, factors: Sequence[str] = ()) -> list[tuple[str, LogQuality]]:
    """Return the one-factor-at-a-time conditions as (varied field, quality), in table order.

    The last row, varied field ``"all"``, is ``BEST``: every factor at its best.

    Parameters
    ----------
    quick : bool
        Only the smallest and largest value of each factor.
    factors : sequence of str
        Only these factors (``SWEEPS`` keys), without the ``BEST`` row; all when empty.

    """
    rows = []
    for field, values in SWEEPS.items():
        if factors and field not in factors:
            continue
        for value in (values[0], values[-1]) if quick else values:
            rows.append((field, replace(BASELINE, **{field: value})))
    return rows if factors else [*rows, ("all", BEST)]


def trial_logs(ship: TruthShip, quality: LogQuality, realisation: int) -> list[ManeuverLog]:
    """Synthesise the three training logs of one noise realisation.

    Parameters
    ----------
    ship : TruthShip
        The reference ship.
    quality : LogQuality
        Noise levels and logging rate.
    realisation : int
        Index of the noise realisation; realisation 0 uses the seeds of
        ``benchmarks/fidelity.py``.

    """
    return [
        synthesize_log(
            ship,
            MANEUVERS[name](),
            rate_hz=quality.rate_hz,
            position_noise_m=quality.position_noise_m,
            heading_noise_deg=quality.heading_noise_deg,
            seed=seed + len(SEEDS) * realisation,
        )
        for name, seed in SEEDS.items()
    ]


def evaluate(
    ship: TruthShip,
    truth: Indices,
    quality: LogQuality,
    settings: FitSettings,
    seeds: int,
    dt_s: float,
    bar: tqdm,
) -> Outcome:
    """Identify and sail every noise realisation of one log quality.

    Parameters
    ----------
    ship : TruthShip
        The reference ship.
    truth : Indices
        Its indices through the same driver.
    quality : LogQuality
        Noise levels and logging rate of the training logs.
    settings : FitSettings
        Identification settings.
    seeds : int
        Number of noise realisations.
    dt_s : float
        Driver step of the manoeuvre runs [s].
    bar : tqdm
        Progress bar, advanced once per realisation.

    """
    errors: list[dict[str, float | None]] = []
    worst: list[float] = []
    seconds: list[float] = []
    failures: list[str] = []
    for k in range(seeds):
        logs = trial_logs(ship, quality, k)
        start = time.perf_counter()
        try:
            result = identify(logs, settings)
        except IdentificationError as exc:
            failures.append(str(exc))
            continue
        finally:
            seconds.append(time.perf_counter() - start)
            bar.update()
        predicted = indices(ModelPlant(result.params), ship, dt_s)
        errors.append(index_errors(predicted, truth, REPORTED))
        worst.append(worst_turning_error(predicted, truth))
    return Outcome(tuple(errors), tuple(worst), tuple(seconds), tuple(failures))


def mean_std(values: Sequence[float | None], digits: int, seeds: int) -> str:
    """Format the reached values as ``mean ± std`` and count those not reached.

    Parameters
    ----------
    values : sequence of float or None
        One error per identified realisation; None = not reached.
    digits : int
        Decimals shown.
    seeds : int
        Number of realisations run (the failed identifications count as not reached).

    """
    reached = [v for v in values if v is not None]
    missing = seeds - len(reached)
    if not reached:
        return "n/a"
    cell = f"{statistics.fmean(reached):+.{digits}f}"
    if len(reached) > 1:
        cell += f" ± {statistics.stdev(reached):.{digits}f}"
    return cell + (f" ({missing} n/a)" if missing else "")


def table_row(field: str, quality: LogQuality, outcome: Outcome, seeds: int) -> str:
    """Return one markdown row; the varied setting is in bold.

    Parameters
    ----------
    field : str
        Name of the varied ``LogQuality`` field, or ``"all"``.
    quality : LogQuality
        The condition.
    outcome : Outcome
        Its results.
    seeds : int
        Number of realisations run.

    """
    values = {name: getattr(quality, name) for name in SWEEPS}
    settings = [f"**{v:g}**" if field in (n, "all") else f"{v:g}" for n, v in values.items()]
    cells = [
        mean_std([e[key] for e in outcome.errors], 1 if key in TURNING else 2, seeds)
        for key in REPORTED
    ]
    worst_turn = max(outcome.worst_turning, default=math.inf)
    overshoots = [abs(v) for e in outcome.errors for k in OVERSHOOTS if (v := e[k]) is not None]
    complete = len(outcome.errors) == seeds and len(overshoots) == seeds * len(OVERSHOOTS)
    cells += [
        f"{100.0 * worst_turn:.1f}" if math.isfinite(worst_turn) else "n/a",
        f"{max(overshoots):.2f}" if complete else "n/a",
        f"{statistics.fmean(outcome.seconds):.1f}",
    ]
    return "| " + " | ".join(settings + cells) + " |"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; print and write the table.

    Parameters
    ----------
    argv : sequence of str, optional
        Command-line arguments (``sys.argv[1:]`` when None).

    Returns
    -------
    int
        Exit status.

    """
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--model", default=DEFAULT_MODEL, choices=model_names())
    parser.add_argument("--method", choices=METHODS, default="ekf", help="identification procedure")
    parser.add_argument("--quick", action="store_true", help="only the extremes of each factor")
    parser.add_argument(
        "--factor",
        action="append",
        dest="factors",
        choices=list(SWEEPS),
        help="only this factor (repeat; default: all, and the row of all at their best)",
    )
    parser.add_argument("--seeds", type=int, default=10, help="noise realisations per row")
    parser.add_argument("--out", default=str(Path(__file__).with_name("sensitivity.md")))
    parser.add_argument("--dt-s", type=float, default=0.2, help="driver step [s]")
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error("--seeds must be at least 1")

    began = time.perf_counter()
    ship = reference_ship("kvlcc2", "full")
    settings = FitSettings(model=args.model, method=args.method)
    truth = indices(ship.plant, ship, args.dt_s)
    identify(trial_logs(ship, BASELINE, 0), settings)  # warm-up: compile before timing
    rows = sweep(args.quick, args.factors or ())
    conditions = list(dict.fromkeys(quality for _, quality in rows))  # baseline once
    outcomes: dict[LogQuality, Outcome] = {}
    with tqdm(
        total=len(conditions) * args.seeds, unit="fit", file=sys.stderr, dynamic_ncols=True
    ) as bar:
        for quality in conditions:
            bar.set_description(
                f"{quality.position_noise_m:g} m, {quality.heading_noise_deg:g}°, "
                f"{quality.rate_hz:g} Hz"
            )
            outcomes[quality] = evaluate(ship, truth, quality, settings, args.seeds, args.dt_s, bar)
    minutes = (time.perf_counter() - began) / 60.0

    columns = [
        "position σ [m]",
        "heading σ [°]",
        "rate [Hz]",
        *(f"{key} [%]" for key in TURNING),
        *(f"{key} [°]" for key in OVERSHOOTS),
        "worst adv/trf/TD, both turns [%]",
        "worst OS [°]",
        "identification [s]",
    ]
    lines = [
        "# Sensitivity to log quality on KVLCC2 (benchmarks/sensitivity.py)",
        "",
        f"Model `{args.model}`, method {args.method}, "
        "trained on the 35° turning circle and the 10/10 and 20/20 zig-zags; "
        f"{args.seeds} noise realisation(s) per row; baseline {BASELINE.position_noise_m:g} m, "
        f"{BASELINE.heading_noise_deg:g}°, {BASELINE.rate_hz:g} Hz; "
        f"{'extremes only (--quick); ' if args.quick else ''}"
        f"driver step {args.dt_s:g} s; total run time {minutes:.1f} min.",
        "",
        "Reference (MMG, same driver): "
        + ", ".join(
            f"{k} {v:.2f}°" if k in OVERSHOOTS else f"{k} {v:.1f} m"
            for k in REPORTED
            if (v := truth.values[k]) is not None
        ),
        "",
        "Errors: distances predicted/true − 1 [%], overshoots predicted − true [°], "
        "mean ± standard deviation over the realisations; worst = largest magnitude over "
        "all realisations and indices of the group, the turning one including the held-out "
        "35° port turn; n/a = the run diverged, never reached "
        "the index, or the identification failed. The varied setting is in bold. "
        "Identification = mean wall time of one fit of the three logs.",
        "",
        "| " + " | ".join(columns) + " |",
        "|" + "---|" * len(columns),
    ]
    lines += [table_row(field, q, outcomes[q], args.seeds) for field, q in rows]
    failures = sorted({m for outcome in outcomes.values() for m in outcome.failures})
    if failures:
        lines += ["", "Failed identifications:", *(f"- {m}" for m in failures)]
    write_block(args.out, "sensitivity.py", lines)
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
