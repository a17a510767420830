"""Which equation carries a zig-zag-trained turn's error: the fit with one of the reference's.

    python benchmarks/transplant.py [--vessel kvlcc2|mariner|tanker] [--draws 2]
        [--position-noise-m 1] [--training zig-zags|10/10|20/20] [--out benchmarks/fidelity.md]

The default fit of ``fidelity.py --draws`` (the same logs: zig-zag 10/10 and 20/20 of
the reference ship, noise draw d, or one of them alone) sails the 35° turns to both sides
and the two zig-zags again with its surge, sway or yaw equation, or sway and yaw, replaced
by the reference ship's own at the same state (its calm-water right-hand side:
``scenarios.kvlcc2.mmg_rhs``, ``scenarios.mariner.abkowitz_rhs``,
``scenarios.tanker.tanker_rhs``); the kinematics and the other equations are the fit's.
An equation whose transplant brings the turns to the reference's is where the fit's
error lives (``fidelity.md``, "How far a turn is extrapolated": on KVLCC2 the yaw
equation). Errors as ``fidelity.py``'s: distances predicted/true − 1, overshoots
predicted − true; worst of advance, transfer and both tactical diameters.

Writes its table into the block ``transplant.py SHIP NOISE m [TRAINING only]`` of ``--out``.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from fidelity import (
    COLUMNS,
    DRAW_TRAINING,
    errors,
    indices,
    training_logs,
    worst_turning_error,
)
from report import write_block

from fmu_model import ModelParameters, numeric_model
from identifier.identify import FitSettings, identify
from scenarios.calm_plants import Rhs, RhsPlant
from scenarios.kvlcc2 import ReferencePlant, mmg_rhs
from scenarios.synthesize import FULL_SCALE_LOGGING, REFERENCE_VESSELS, reference_ship

EQUATIONS = {"surge": (0,), "sway": (1,), "yaw": (2,), "sway and yaw": (1, 2)}
"""The rows of the state derivative (u̇, v̇, ṙ) each transplant takes from the reference."""

MAX_SUBSTEP_S = 0.1
"""RK4 substep of every sailing here [s], fitted and transplanted alike (full scale)."""


def reference_rhs(vessel: str) -> Rhs:
    """Return the calm-water right-hand side of a reference ship (full scale)."""
    plant = reference_ship(vessel, "full").plant
    if isinstance(plant, RhsPlant):  # the Mariner and the tanker
        return plant.rhs
    assert isinstance(plant, ReferencePlant)  # KVLCC2's, in calm water
    ship = plant.ship
    return lambda state, rudder_rad, n_rps: mmg_rhs(ship, state, rudder_rad, n_rps)


def transplanted(params: ModelParameters, reference: Rhs, rows: tuple[int, ...]) -> RhsPlant:
    """Return the fitted model as a plant, rows ``rows`` of its derivative from ``reference``.

    A state where the reference has no forces (it raises ValueError: the tanker's model
    astern) ends the run as a divergence does, FloatingPointError, which ``indices``
    reports as n/a.
    """
    model = numeric_model(params.structure)

    def rhs(state: np.ndarray, rudder_rad: float, n_rps: float) -> np.ndarray:
        derivative = np.array(
            model.rhs(state, rudder_rad, n_rps, params.coefficients, params.length_m), dtype=float
        )
        if rows:
            try:
                theirs = reference(state, rudder_rad, n_rps)
            except ValueError as exc:  # e.g. the tanker's slipstream astern: sqrt of < 0
                raise FloatingPointError(f"the reference has no forces at {state}: {exc}") from exc
            derivative[list(rows)] = theirs[list(rows)]
        return derivative

    return RhsPlant(rhs, params.length_m, MAX_SUBSTEP_S)


def transplant_table(
    vessel: str, n_draws: int, dt_s: float, position_noise_m: float, training: str
) -> list[str]:
    """Rows per draw: the default fit as fitted and with each transplant of :data:`EQUATIONS`."""
    ship = reference_ship(vessel, "full")
    truth = indices(ship.plant, ship, dt_s)
    reference = reference_rhs(vessel)
    lines = [
        "| draw | equation from the reference | " + " | ".join(COLUMNS) + " | worst turn |",
        "|" + "---|" * (len(COLUMNS) + 3),
    ]
    for draw in range(n_draws):
        params = identify(
            training_logs(ship, draw, position_noise_m, training), FitSettings()
        ).params
        for label, rows in {"none (as fitted)": (), **EQUATIONS}.items():
            predicted = indices(transplanted(params, reference, rows), ship, dt_s)
            worst = worst_turning_error(predicted, truth)
            shown = f"{worst:.1%}" if np.isfinite(worst) else "n/a"
            lines.append(
                f"| {draw} | {label} | " + " | ".join(errors(predicted, truth)) + f" | {shown} |"
            )
            print(lines[-1], flush=True)
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark; print and write the table."""
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--vessel", choices=REFERENCE_VESSELS, default="kvlcc2")
    parser.add_argument("--draws", type=int, default=2, help="noise draws (fidelity.py's seeds)")
    default_noise = FULL_SCALE_LOGGING.position_noise_m
    parser.add_argument(
        "--position-noise-m",
        type=float,
        default=default_noise,
        help=f"the logs' GNSS noise [m] (default {default_noise:g})",
    )
    parser.add_argument("--training", choices=DRAW_TRAINING, default="zig-zags")
    parser.add_argument("--dt-s", type=float, default=0.2, help="driver step [s]")
    parser.add_argument("--out", default=str(Path(__file__).with_name("fidelity.md")))
    args = parser.parse_args(argv)
    lines = transplant_table(
        args.vessel, args.draws, args.dt_s, args.position_noise_m, args.training
    )
    block = f"transplant.py {args.vessel} {args.position_noise_m:g} m"
    block += "" if args.training == "zig-zags" else f" {args.training} only"
    write_block(args.out, block, lines)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
