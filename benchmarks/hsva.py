"""Cross-predictions on measured data: the four HSVA free-running zig-zags of KVLCC2 (issue 13).

    python benchmarks/hsva.py [--model NAME ...] [--fold NAME ...] [--current none|constant|auto]
        [--out benchmarks/hsva.md]

Data: ``../shared/data/hsva_kvlcc2`` (model scale, L = 7 m, 20 Hz), read with the
project's own reader. Folds:

* ``10/10 → 20/10``: trained on both 10°/10° runs, predicts both 20°/10° runs;
* ``stbd → port``: trained on the two starboard-first runs, predicts the port-first ones;
* ``leave one out``: trained on three runs, predicts the fourth (four folds);
* ``all four`` (only with ``--fold 'all four'``): trained on every run, nothing held out:
  what the family can fit at all.

Every run of every fold, trained on or held out, is sailed again closed-loop by the
identified model in the run's own condition (``trials.conditions.sail_again``: approach
speed, rpm, rudder amplitude and rate, the logged switch headings), and its first and
second overshoot are compared with the run's, measured with the same definitions.
Two estimates of each fit: ``ekf`` (the seed paper's algorithm, ``--method ekf``) and
``default`` (what ``identifier fit`` keeps). Errors predicted − measured [deg]. The fits
take the basin's water as still (``--current none``, the README's advice for tank tests);
``--current constant`` fits as ``identifier fit`` does a ship's logs unless told so,
``--current auto`` chooses between the two as ``fit`` does a model's (L < 20 m) unless
told so (the fold's cell says which it kept).

The asymmetry row: the predicted second-overshoot difference port-first − starboard-first
run of each pair, against the measured one (10/10: 17.83 − 20.54 = −2.71°).

The hard-turn column: none of the runs is a turn, but an FMU built from them will be
sailed through one. Each estimate sails virtual 35° turns to both sides from the approach
its fit found, at the runs' rudder rate (``identifier.output_error.guards.virtual_turns``);
tactical diameter and advance in ship lengths, n/a when the turn diverges or does not pass
360°. A yardstick, not a measurement of these runs: the KVLCC2 MMG reference at the same
Froude number turns with a tactical diameter of 3.11 L and an advance of 3.08 L, and the
hull in free-running tests turns about 8 % tighter to port (``README.md`` of the data).

The coverage column (issue 13, item 4; default estimate only): how many of the held-out
runs' measured overshoots lie in the 95 % intervals of the prediction in the run's own
condition, identification noise only / with the model-form term (``intervals.py``, the
intervals of ``validate``), of those the intervals reach; then the same with the
model-form term for the runs sailed within the envelope of the training runs
(``fmu_model.envelope``: rudder angle and yaw rate to each side, speed lost), where the
model does not extrapolate.

Candidates studied for issue 13: ``benchmarks/candidates.py`` (``--model NAME``). The table
goes into its block of ``--out`` (``report.py``: the notes around it stay).
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
from fmu_model.envelope import trajectory_envelope
from fmu_model.interface import logged_envelope
from identifier.current import kept_current
from identifier.identify import FitSettings, identify
from identifier.output_error.guards import virtual_turns
from scenarios.records import Condition
from trials.conditions import LoggedCondition, sail_again
from trials.logs import ManeuverLog, read_log
from trials.run import ModelPlant

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"
RUNS = ("hsva_zz10_stbd", "hsva_zz10_port", "hsva_zz20_10_stbd", "hsva_zz20_10_port")
PAIRS = {"10/10": ("hsva_zz10_port", "hsva_zz10_stbd"), "20/10": RUNS[3:1:-1]}
FOLDS: dict[str, tuple[str, ...]] = {
    "10/10 → 20/10": RUNS[:2],
    "stbd → port": (RUNS[0], RUNS[2]),
    **{f"leave out {held}": tuple(r for r in RUNS if r != held) for held in RUNS},
}
EXTRA_FOLDS = {"all four": RUNS}  # run only when named
ALL_FOLDS = {**FOLDS, **EXTRA_FOLDS}
LENGTH_M = 7.0
RUDDER_RATE_RADPS = math.radians(15.0)  # the runs' steering gear, 14–16 °/s (README.md there)
MODELS = (DEFAULT_MODEL,)
INDICES = ("first_overshoot_deg", "second_overshoot_deg")


@dataclass(frozen=True)
class RunError:
    """Overshoots of one run sailed again by one estimate."""

    run: str
    trained: bool
    logged: tuple[float | None, ...]
    predicted: tuple[float | None, ...]
    condition: LoggedCondition  # what was sailed
    beyond: bool  # sailed beyond the envelope of the identification logs

    @property
    def errors(self) -> tuple[float | None, ...]:
        """Return predicted − logged [deg] per overshoot; None where either is missing."""
        return tuple(
            None if p is None or m is None else p - m
            for p, m in zip(self.predicted, self.logged, strict=True)
        )


def read_runs(directory: Path = DATA) -> dict[str, ManeuverLog]:
    """Read the four HSVA runs."""
    return {run: read_log(directory / f"{run}.csv") for run in RUNS}


def sail_all(
    params: ModelParameters, logs: dict[str, ManeuverLog], train: Sequence[str]
) -> list[RunError]:
    """Sail every run again with ``params``; its overshoots against the logged ones."""
    envelope = logged_envelope(params)
    assert envelope is not None
    out = []
    for run, log in logs.items():
        sailed = sail_again(ModelPlant(params), log)
        sailed_envelope = trajectory_envelope(sailed.trajectory, params.length_m)
        out.append(
            RunError(
                run,
                run in train,
                tuple(sailed.logged[k] for k in INDICES),
                tuple(sailed.predicted[k] for k in INDICES),
                sailed.condition,
                bool(envelope.beyond(sailed_envelope)),
            )
        )
    return out


def estimates(
    logs: dict[str, ManeuverLog], model: str, train: Sequence[str], current: str = "none"
) -> dict[str, ModelParameters]:
    """Identify ``model`` on the ``train`` runs; the EKF's estimate and the default kept one.

    ``current``: ``FitSettings.current`` (a basin's water is still: "none").
    """
    settings = FitSettings(model=model, current=current)
    result = identify([logs[r] for r in train], settings, length_m=LENGTH_M)
    refinement = result.refinement
    assert refinement is not None
    ekf = refinement.initial.params.with_vector(result.ekf.theta)
    return {"ekf": ekf, "default": result.params}


def worst(errors: Sequence[RunError], trained: bool) -> float:
    """Largest |error| [deg] of the runs trained on (or held out); inf when one is missing."""
    values = [e for r in errors if r.trained == trained for e in r.errors]
    if not values:
        return math.nan
    return (
        math.inf if any(v is None for v in values) else max(abs(v) for v in values if v is not None)
    )


def asymmetry(
    errors: Sequence[RunError], pair: tuple[str, str]
) -> tuple[float | None, float | None]:
    """(predicted, measured) second-overshoot difference port-first − starboard-first [deg]."""
    by_run = {r.run: r for r in errors}
    port, stbd = by_run[pair[0]], by_run[pair[1]]

    def diff(a: float | None, b: float | None) -> float | None:
        return None if a is None or b is None else a - b

    return diff(port.predicted[1], stbd.predicted[1]), diff(port.logged[1], stbd.logged[1])


def held_out_coverage(
    params: ModelParameters, logs: dict[str, ManeuverLog], errors: Sequence[RunError]
) -> str:
    """Held-out measured overshoots in the 95 % intervals: "id only / with model form of n".

    Then those of the runs sailed within the envelope of the identification logs.
    """
    inside, judged = [0, 0], 0
    within = [0, 0]
    for run_error in errors:
        if run_error.trained:
            continue
        condition = run_error.condition
        program = condition.program
        dt_s = float(np.median(np.diff(logs[run_error.run].time_s)))
        intervals = prediction_intervals(
            params,
            [program],
            Condition(condition.speed_mps, condition.n_rps, condition.rudder_rate_radps, dt_s),
        )
        for index, measured in zip(INDICES, run_error.logged, strict=True):
            interval = intervals.get((program.name, index.replace("_deg", "_rad")))
            if measured is None or interval is None:
                continue
            judged += 1
            for i, (lo, hi) in enumerate((interval.identification, interval.with_model_form)):
                inside[i] += math.degrees(lo) <= measured <= math.degrees(hi)
            if not run_error.beyond:
                lo, hi = interval.with_model_form
                within[0] += math.degrees(lo) <= measured <= math.degrees(hi)
                within[1] += 1
    if not judged:
        return "—"
    return f"{inside[0]} / {inside[1]} of {judged}; within: {within[0]} of {within[1]}"


def hard_turns(params: ModelParameters) -> str:
    """Tactical diameter / advance [L] of virtual 35° turns to starboard and port; n/a: diverged.

    From the approach the fit found, at the runs' rudder rate: none of the runs is a turn,
    so this is how far the model can be trusted beyond zig-zags (module docstring).
    """
    cells = []
    for turn in virtual_turns(
        params,
        speed_mps=params.nominal_speed_mps,
        n_rps=params.nominal_n_rps,
        rudder_rate_radps=RUDDER_RATE_RADPS,
    ):
        diameter, advance = turn.tactical_diameter_m, turn.advance_m
        if not turn.bounded or diameter is None or advance is None:
            cells.append("n/a")
        else:
            cells.append(f"{diameter / LENGTH_M:.2f} / {advance / LENGTH_M:.2f}")
    return ", ".join(cells)


def _deg(value: float | None) -> str:
    return "n/a" if value is None or not math.isfinite(value) else f"{value:+.2f}"


def main(argv: Sequence[str] | None = None) -> int:
    """Run the cross-predictions; print and write the tables."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    candidates = register_candidates()
    parser.add_argument(
        "--model",
        action="append",
        dest="models",
        help=f"model (repeat; default {MODELS[0]}; candidates: {', '.join(candidates)})",
    )
    parser.add_argument(
        "--fold",
        action="append",
        dest="folds",
        choices=list(ALL_FOLDS),
        help="fold name (repeat; default: all but 'all four')",
    )
    parser.add_argument("--data", type=Path, default=DATA, help="directory of the runs")
    parser.add_argument(
        "--current",
        choices=("none", "constant", "auto"),
        default="none",
        help="the fits' current: none (a basin's still water, the default), constant "
        "(identifier fit's default for a ship) or auto (its default for a model, as here)",
    )
    parser.add_argument("--out", default=str(Path(__file__).with_name("hsva.md")))
    args = parser.parse_args(argv)
    logs = read_runs(args.data)
    lines = [
        "# Cross-predictions on the HSVA KVLCC2 zig-zags (benchmarks/hsva.py)",
        "",
        "Overshoot errors predicted − measured [deg], closed-loop in each run's own condition. "
        "`T` = trained on, `H` = held out. Asymmetry: predicted (measured) second-overshoot "
        "difference port-first − starboard-first.",
        "",
        "| model | fold | estimate | "
        + " | ".join(f"{r.removeprefix('hsva_')} OS1 | OS2" for r in RUNS)
        + " | worst T | worst H | asym 10/10 | asym 20/10 | 35° TD / adv stbd, port [L] | s "
        "| held out in 95 % (id only / with model form; within the logs' envelope: with model "
        "form) |",
        "|" + "---|" * (3 + 2 * len(RUNS) + 7),
    ]
    for model in args.models or MODELS:
        for fold in args.folds or FOLDS:
            train = ALL_FOLDS[fold]
            start = time.perf_counter()
            fits = estimates(logs, model, train, args.current)
            seconds = time.perf_counter() - start
            kept = kept_current(fits["default"])
            label = fold if args.current != "auto" else f"{fold} (auto → {kept})"
            for name, params in fits.items():
                errors = sail_all(params, logs, train)
                cells = []
                for run_error in errors:
                    tag = "T" if run_error.trained else "H"
                    cells += [f"{_deg(e)} {tag}" for e in run_error.errors]
                asym = [asymmetry(errors, PAIRS[p]) for p in PAIRS]
                row = [
                    fitted_label(model, params.model),
                    label,
                    name,
                    *cells,
                    _deg(worst(errors, True)),
                    _deg(worst(errors, False)),
                    *(f"{_deg(p)} ({_deg(m)})" for p, m in asym),
                    hard_turns(params),
                    f"{seconds:.0f}" if name == "ekf" else "",
                    held_out_coverage(params, logs, errors) if name == "default" else "",
                ]
                lines.append("| " + " | ".join(row) + " |")
                print(lines[-1], flush=True)
    write_block(args.out, "hsva.py", lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
