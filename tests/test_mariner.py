"""The Mariner reference ship (``scenarios.mariner``): its expansion against hand
computations of the printed coefficients, its single-screw asymmetry, and its place
among the reference ships of ``synthesize`` and ``validate``."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pytest

from fmu_model import DEFAULT_MODEL, load_params
from fmu_model.export_native import build_native_fmu
from fmu_model.variants import NEUTRAL_RUDDER_OFFSET, parse_family
from identifier.identify import FitSettings, identify
from scenarios.cli import PROG, main
from scenarios.mariner import (
    APPROACH_SPEED_MPS,
    NOMINAL_RPS,
    AbkowitzPlant,
    abkowitz_forces,
    abkowitz_rhs,
    mariner,
    neutral_helm,
)
from scenarios.runs import reference_runs
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from tests.test_scenarios_cli import _one_line
from trials.logs import read_log
from trials.maneuvers import Helm, turning_circle
from trials.metrics import turning_metrics
from trials.run import ModelPlant, run_program

ROOT = Path(__file__).resolve().parents[1]
RUDDER_RATE_RADPS = math.radians(2.32)


def test_forces_and_accelerations_of_a_rudder_step_by_hand():
    """At U₀, straight, rudder 0.1 rad to starboard (the source's δ = −0.1).

    By hand from the printed coefficients (× 1e-5): X′ = X_δδ δ² = −95·0.01 = −9.5e-6;
    Y′ = Y_δ δ + Y_δδδ δ³ + Y₀ = −278e-6 + 0.9e-6 − 40e-6 = −3.171e-4;
    N′ = N_δ δ + N_δδδ δ³ + N₀ = 139e-6 − 0.45e-6 + 30e-6 = 1.6855e-4: the rudder pulls
    the stern to port and the bow to starboard. With U₀²/L = 0.370097 m/s², m₁₁ = 840e-5,
    m₂₂ = 1546e-5, m₂₃ = −9.0e-5, m₃₂ = −23.0e-5, m₃₃ = 83.0e-5, det = 1.28111e-5:
    u̇ = X′ U₀²/L / m₁₁ = −4.1856e-4 m/s², v̇ = (m₃₃Y′ − m₂₃N′) U₀²/L / det = −7.1651e-3 m/s²,
    ṙ = (m₂₂N′ − m₃₂Y′) U₀²/L² / det = 4.5468e-4 rad/s².
    """
    ship = mariner()
    x, y, n = abkowitz_forces(ship, APPROACH_SPEED_MPS, 0.0, 0.0, 0.1)
    assert (x, y, n) == pytest.approx((-9.5e-6, -3.171e-4, 1.6855e-4), rel=1e-9)
    state = np.array([APPROACH_SPEED_MPS, 0.0, 0.0, 10.0, -5.0, math.radians(30.0)])
    rhs = abkowitz_rhs(ship, state, 0.1)
    assert rhs[:3] == pytest.approx([-4.1856e-4, -7.1651e-3, 4.5468e-4], rel=1e-4)
    # kinematics: the track moves along the heading, 30° East of North
    assert rhs[3:] == pytest.approx([APPROACH_SPEED_MPS * math.sqrt(3) / 2, 3.85875, 0.0])


def test_neutral_helm_by_hand_holds_the_ship_straight():
    """The single screw's constant force and moment (Y₀, N₀) are balanced by a helm.

    Straight (r = 0) at U₀, by hand from the linear terms: Y_v v′ + Y_δ δ = −Y₀,
    N_v v′ + N_δ δ = −N₀ gives δ = 4536/234632 = 0.019332 rad (the source's δ, to port:
    rudder −1.1077°) and v′ = 278/234632 = 0.0011848; the cubic terms (Y_δδδ δ³ ≈ 7e-9
    beside Y₀ = 4e-5) move the trim of ``neutral_helm`` by about 1e-4 of that. Held
    from that state for ten minutes the ship keeps its heading within 0.05° (the hand
    helm is rounded to 5 digits; the trim's within 1e-3°); with the rudder amidships it
    turns to starboard by tens of degrees.
    """
    ship = mariner()
    helm = neutral_helm(ship)
    assert helm.rudder_rad == pytest.approx(-0.019332, rel=3e-4)
    assert helm.sway_mps == pytest.approx(0.0011848 * APPROACH_SPEED_MPS, rel=3e-4)
    _, y, n = abkowitz_forces(ship, APPROACH_SPEED_MPS, helm.sway_mps, 0.0, helm.rudder_rad)
    assert abs(y) < 1e-15 and abs(n) < 1e-15
    plant = AbkowitzPlant(ship)
    headings_deg = []
    for rudder_rad, v, tolerance_deg in (
        (-0.019332, 0.0011848 * APPROACH_SPEED_MPS, 0.05),
        (helm.rudder_rad, helm.sway_mps, 1e-3),
        (0.0, 0.0, math.inf),
    ):
        plant.reset(np.array([APPROACH_SPEED_MPS, v, 0.0, 0.0, 0.0, 0.0]))
        state = plant.step(rudder_rad, NOMINAL_RPS, 600.0)
        headings_deg.append(math.degrees(state[5]))
        assert abs(headings_deg[-1]) < tolerance_deg
    assert headings_deg[-1] > 20.0


def test_logs_approach_at_the_neutral_helm_as_a_trial_does():
    """The Mariner's logs are steadied on their neutral helm before execute: rudder and
    heading constant on the approach, the source says so; from a midship approach the
    ship swings several degrees first. KVLCC2's helm is amidships (its logs as before)."""
    ship = reference_ship("mariner")
    assert ship.neutral_helm == neutral_helm(mariner())
    program = MANEUVERS["zigzag-10"]()
    quiet = {"position_noise_m": 0.0, "heading_noise_deg": 0.0, "approach_s": 60.0}
    steady = synthesize_log(ship, program, **quiet)
    swinging = synthesize_log(ship, program, approach_helm=Helm(), **quiet)
    execute = 60  # 1 Hz
    assert np.all(steady.rudder_rad[:execute] == ship.neutral_helm.rudder_rad)
    assert np.max(np.abs(np.degrees(steady.heading_rad[: execute + 1]))) < 1e-3
    assert "approach at rudder -1.108 deg (neutral helm)" in steady.metadata["source"]
    assert np.all(swinging.rudder_rad[:execute] == 0.0)
    assert math.degrees(swinging.heading_rad[execute]) > 3.0
    assert "neutral helm" not in swinging.metadata["source"]
    assert reference_ship("kvlcc2").neutral_helm == Helm()


def test_a_fit_without_the_offset_notes_the_neutral_helm():
    """A family with no neutral-rudder offset is told of the logs' neutral helm and of the
    family that models it; the default family has the offset and is not."""
    log = synthesize_log(reference_ship("mariner"), MANEUVERS["zigzag-10"]())
    plain = FitSettings(model="prime-rudder", method="ekf", current="none")
    note = (
        "log 1 approaches at a helm of -1.11 deg (mean rudder before execute): a single "
        "screw's neutral helm, which prime-rudder has no term for; --model "
        "prime-rudder-slipstream has one"
    )
    assert note in identify([log], plain).notes
    default = parse_family(DEFAULT_MODEL)
    assert default is not None and default[0].has(NEUTRAL_RUDDER_OFFSET)
    offset = identify([log], replace(plain, model=DEFAULT_MODEL)).notes
    assert not any("neutral helm" in n for n in offset)


def _tactical_diameters_L(ship) -> tuple[float, float]:
    plant = AbkowitzPlant(ship)
    out = []
    for rudder_deg in (35.0, -35.0):
        run = run_program(
            plant,
            turning_circle(math.radians(rudder_deg)),
            speed_mps=APPROACH_SPEED_MPS,
            n_rps=NOMINAL_RPS,
            rudder_rate_radps=RUDDER_RATE_RADPS,
            dt_s=1.0,
        )
        out.append(turning_metrics(run).tactical_diameter_m / ship.length_m)
    return out[0], out[1]


@pytest.mark.order("first")  # long: started first (conftest.py)
def test_zig_zags_in_two_knots_across_the_approach_fit_and_find_the_current():
    """The Mariner's zig-zags (noise draw 1 of benchmarks/fidelity.py) in a current of
    1 m/s setting to 135°, the approaches heading North: they show the current's East
    part, and the alternation starts with none North, where its EKF diverged and with it
    the default fit ("innovation covariance is not positive definite", log 1, sample
    309). Started again along the course, it fits: the current within 0.06 m/s, and the
    calm-water 35° turn as from the same logs in still water (measured: 0.050 m/s; the
    tactical diameters 0.2 and 0.1 % from the still-water fit's)."""
    ship = reference_ship("mariner")
    seeds = {"zigzag-10": 11, "zigzag-20": 12}
    calm = [synthesize_log(ship, MANEUVERS[name](), seed=seed) for name, seed in seeds.items()]
    current_ne = np.array([-1.0, 1.0]) / math.sqrt(2.0)
    sea = [
        replace(
            log, x_m=log.x_m + current_ne[0] * log.time_s, y_m=log.y_m + current_ne[1] * log.time_s
        )
        for log in calm
    ]
    result = identify(sea, FitSettings())
    assert result.current is not None
    np.testing.assert_allclose(result.current.vector, current_ne, atol=0.06)
    assert any(note.startswith("current: the EKF diverged") for note in result.notes)
    still = identify(calm, FitSettings())
    turn = turning_circle(math.radians(35.0))
    diameters = [
        turning_metrics(
            run_program(
                ModelPlant(params),
                turn,
                speed_mps=ship.speed_mps,
                n_rps=ship.n_rps,
                rudder_rate_radps=ship.rudder_rate_radps,
                dt_s=0.2,
            )
        ).tactical_diameter_m
        for params in (result.params, still.params)
    ]
    assert diameters[0] == pytest.approx(diameters[1], rel=0.01)


def test_turns_mirror_without_the_constant_terms_and_not_with_them():
    """Every other term of (2)-(3) is odd in (v, r, δ) and of (1) even: without Y₀…, N₀…
    the port turn is the starboard turn mirrored; with them (N₀ > 0 yaws to starboard)
    the starboard turn is the tighter one."""
    ship = mariner()
    symmetric = dict(ship.coefficients)
    for name in ("Y0", "Y0u", "Y0uu", "N0", "N0u", "N0uu"):
        symmetric[name] = 0.0
    stbd, port = _tactical_diameters_L(replace(ship, coefficients=MappingProxyType(symmetric)))
    assert stbd == pytest.approx(port, rel=1e-12)
    stbd, port = _tactical_diameters_L(ship)
    assert 5.0 < stbd < port < 8.0
    assert port / stbd - 1.0 > 0.02  # a single-screw asymmetry worth modelling


def test_plant_sails_at_its_nominal_rpm_only():
    plant = AbkowitzPlant(mariner())
    plant.reset(np.array([APPROACH_SPEED_MPS, 0.0, 0.0, 0.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match="no propeller term: it sails at its nominal 100 rpm"):
        plant.step(0.0, 2.0, 1.0)


def test_reference_ship_and_synthesize_command(tmp_path, capsys):
    ship = reference_ship("mariner")
    assert ship.name == "mariner-full" and ship.length_m == 160.93
    assert ship.n_rps == NOMINAL_RPS and "Chislett" in ship.source
    argv = ["synthesize", "--vessel", "mariner", "--maneuver", "zigzag-10", "--quiet"]
    assert main([*argv, "--approach-s", "10", "-o", str(tmp_path / "logs")]) == 0
    log = read_log(tmp_path / "logs" / "zigzag-10.csv")
    assert log.metadata["vessel"] == "mariner-full" and log.length_m == 160.93
    assert np.all(log.n_rps == NOMINAL_RPS)
    capsys.readouterr()


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (["--scale", "model"], "the mariner reference is given at full scale only, not 'model'"),
        (
            ["--current-mps", "0.5", "--current-to-deg", "45"],
            "the mariner reference sails in calm water only (no windage)",
        ),
    ],
)
def test_synthesize_refuses_what_the_mariner_is_not_given_in(options, message, tmp_path, capsys):
    out = tmp_path / "logs"
    argv = ["synthesize", "--vessel", "mariner", "--maneuver", "zigzag-10", "--quiet"]
    assert main([*argv, *options, "-o", str(out)]) == 1
    captured = capsys.readouterr()
    assert _one_line(captured.err) == f"{PROG} synthesize: error: {message}"
    assert captured.out == "" and not out.exists()


def test_validate_reference_side_sails_the_standard_set():
    """What ``validate --reference mariner`` compares with: both 35° turns and both
    zig-zags complete, the turns as the plant's own (above), the zig-zags with the
    single screw's asymmetry in the overshoots of a starboard-first run (to starboard
    the ship swings further: N₀ > 0)."""
    name, description, length, condition, runs = reference_runs("mariner", "full", 0.5)
    assert name == "mariner-full" and length == 160.93 and "Abkowitz" in description
    assert condition.n_rps == NOMINAL_RPS and condition.speed_mps == APPROACH_SPEED_MPS
    metrics = {run.program.name: run.metrics for run in runs}
    assert set(metrics) == {
        "turning-35-stbd",
        "turning-35-port",
        "zigzag-10-10-stbd",
        "zigzag-20-20-stbd",
    }
    assert metrics["turning-35-stbd"].tactical_diameter_m < (
        metrics["turning-35-port"].tactical_diameter_m
    )
    zigzag = metrics["zigzag-10-10-stbd"]
    assert zigzag.first_overshoot_deg > zigzag.second_overshoot_deg > 0.0


def test_a_ship_of_another_structure_goes_through_the_whole_pipeline(tmp_path, capsys):
    """Mariner logs → fit → native FMU → validate against the Mariner: every command
    succeeds and every compared quantity is predicted; the starboard turn, trained on,
    within 20 % (the default family does not fit this ship's turn closely,
    benchmarks/fidelity.md); the estimate kept sails the virtual 20/20 zig-zags. The
    default family has the neutral-rudder offset: the logs' neutral helm (1.1° to port)
    comes out as d0 > 0 (no rudder force at δ = −d0, a helm to port), and the fit has
    nothing to note about it."""
    logs = tmp_path / "logs"
    argv = ["synthesize", "--vessel", "mariner", "--quiet", "-o", str(logs)]
    for name in ("zigzag-10", "zigzag-20", "turning-35"):
        argv += ["--maneuver", name]
    assert main(argv) == 0
    params_path = tmp_path / "params.json"
    fit = [sys.executable, "-m", "identifier", "fit", *sorted(map(str, logs.glob("*.csv")))]
    done = subprocess.run(
        [*fit, "-o", str(params_path)], check=True, cwd=ROOT, capture_output=True, text=True
    )
    assert "neutral helm" not in done.stderr
    params = load_params(params_path)
    family = parse_family(params.model)
    assert family is not None
    assert 0.0 < family[1][str(NEUTRAL_RUDDER_OFFSET)] < 0.1
    refinement = params.identification["refinement"]
    assert refinement[refinement["kept"]]["virtual_zigzags_complete"] is True
    fmu = build_native_fmu(params, tmp_path / "mariner.fmu")
    report = tmp_path / "report"
    argv = ["validate", "--fmu", str(fmu), "--reference", "mariner", "--report", str(report)]
    assert main([*argv, "--dt-s", "0.5", "--quiet"]) == 0
    capsys.readouterr()
    document = json.loads((report / "validation.json").read_text())
    assert document["reference"]["name"] == "mariner-full"
    rows = document["comparison"]
    assert len(rows) == 10 and all(row["predicted"] is not None for row in rows)
    trained = [row for row in rows if row["maneuver"] == "turning-35-stbd"]
    assert len(trained) == 3
    assert all(abs(row["predicted"] / row["reference"] - 1.0) < 0.20 for row in trained), trained
