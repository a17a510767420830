"""A logged manoeuvre's condition, read from the log, and the manoeuvre sailed again in it."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import DEFAULT_MODEL, ModelParameters
from identifier import identify as identify_module
from identifier import preparation
from identifier.identify import FitSettings, IdentificationResult, fixed_thrust_model, identify
from identifier.output_error import VirtualTurn
from identifier.output_error.guards import virtual_turns
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from trials.conditions import (
    SailedAgain,
    execute_index,
    log_trajectory,
    logged_condition,
    maneuver_indices,
    maneuver_kind,
    sail_again,
)
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, read_log
from trials.maneuvers import Leg, Until, turning_circle, zigzag
from trials.run import ModelPlant

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"
HSVA_RUNS = ("hsva_zz10_stbd", "hsva_zz10_port", "hsva_zz20_10_stbd", "hsva_zz20_10_port")


@pytest.fixture(scope="module")
def truth() -> dict[str, dict[str, object]]:
    """The HSVA data set's own metrics (computed by its converter, not by this project)."""
    return json.loads((HSVA / "truth.json").read_text(encoding="utf-8"))


@pytest.fixture(scope="module")
def hsva() -> dict[str, ManeuverLog]:
    """The four measured zig-zags, read with the project's reader."""
    return {run: read_log(HSVA / f"{run}.csv") for run in HSVA_RUNS}


@pytest.mark.parametrize("run", HSVA_RUNS)
def test_the_measured_runs_condition_agrees_with_the_data_sets_own_metrics(
    run: str, hsva: dict[str, ManeuverLog], truth: dict[str, dict[str, object]]
) -> None:
    t = truth[run]
    c = logged_condition(hsva[run])
    sign = 1.0 if t["first_side"] == "starboard" else -1.0
    assert c.program.kind == "zigzag"
    assert math.copysign(1.0, c.program.rudder_rad) == sign
    assert math.degrees(c.program.heading_rad) == pytest.approx(10.0)  # 10.6-11.3 deg: nominal 10
    assert math.degrees(abs(c.program.rudder_rad)) == pytest.approx(
        t["rudder_amplitude_measured_deg"], abs=0.02
    )
    assert c.speed_mps == pytest.approx(t["approach_speed_mps"], abs=2e-3)
    assert c.n_rps * 60.0 == pytest.approx(t["approach_rpm"])
    assert math.degrees(c.rudder_rate_radps) == pytest.approx(t["rudder_rate_degps"], abs=0.01)
    # truth.json reads the heading when the rudder is 1 deg off its plateau; the switch
    # heading is where it started to move, 1 deg / rate (0.07 s) earlier at 2-3 deg/s.
    at_one_degree = np.abs(t["heading_rel_psi0_at_reversal_executes_deg"])
    earlier = at_one_degree - np.degrees(c.switch_headings_rad)
    assert np.all((earlier > 0.05) & (earlier < 0.3))
    # The legs reverse at the logged headings, alternating sides.
    first, second = c.program.legs[:2]
    assert first.rudder_rad * sign > 0.0 and second.rudder_rad * sign < 0.0
    crossing = first.until.heading_above_rad if sign > 0 else -(first.until.heading_below_rad or 0)
    assert crossing == pytest.approx(c.switch_headings_rad[0])


@pytest.mark.parametrize("run", HSVA_RUNS)
def test_the_logged_overshoots_are_the_data_sets_own(
    run: str, hsva: dict[str, ManeuverLog], truth: dict[str, dict[str, object]]
) -> None:
    log = hsva[run]
    c = logged_condition(log)
    got = maneuver_indices(
        "zigzag", log_trajectory(log), c.execute_time_s, (c.program.rudder_rad, math.radians(10.0))
    )
    t = truth[run]
    assert got["first_overshoot_deg"] == pytest.approx(t["first_overshoot_deg"], abs=0.03)
    assert got["second_overshoot_deg"] == pytest.approx(t["second_overshoot_deg"], abs=0.03)


@pytest.fixture(scope="module")
def reference_zigzag() -> ManeuverLog:
    """A noise-free 10 Hz zig-zag 10/10 of the KVLCC2 reference, port first."""
    ship = reference_ship("kvlcc2", "full")
    return synthesize_log(
        ship,
        zigzag(-math.radians(10.0), math.radians(10.0)),
        rate_hz=10.0,
        position_noise_m=0.0,
        heading_noise_deg=0.0,
    )


def test_a_synthetic_logs_condition_is_the_one_it_was_sailed_in(
    reference_zigzag: ManeuverLog,
) -> None:
    ship = reference_ship("kvlcc2", "full")
    c = logged_condition(reference_zigzag)
    assert c.speed_mps == pytest.approx(ship.speed_mps, rel=1e-4)
    assert c.n_rps == pytest.approx(ship.n_rps)
    assert c.rudder_rate_radps == pytest.approx(ship.rudder_rate_radps, rel=0.01)
    assert math.degrees(c.program.rudder_rad) == pytest.approx(-10.0, abs=1e-6)
    # The runner reverses at the first step past 10 deg: within one step's heading change.
    assert np.degrees(c.switch_headings_rad) == pytest.approx(10.0, abs=0.05)
    assert c.execute_time_s == pytest.approx(60.0)


def test_a_zigzag_that_ends_back_at_midship_is_read_as_its_zigzag(
    reference_zigzag: ManeuverLog,
) -> None:
    """A log ending with the rudder returned to midship and a straight run (a zig-zag cut
    from a trial day, ``identifier split``): the return is no reversal. Before, it counted
    as one to a plateau of 0 deg, and the amplitude came out 8 deg (``zigzag-8-10``)."""
    log = reference_zigzag
    tail_s = np.arange(1, 1001) * 0.1  # 100 s at the log's 10 Hz
    rate = reference_ship("kvlcc2", "full").rudder_rate_radps
    last = float(log.rudder_rad[-1])
    back = np.sign(last) * np.maximum(abs(last) - rate * tail_s, 0.0)
    ended = ManeuverLog(
        np.concatenate((log.time_s, log.time_s[-1] + tail_s)),
        np.concatenate((log.x_m, np.full(tail_s.size, log.x_m[-1]) + 8.0 * tail_s)),
        np.concatenate((log.y_m, np.full(tail_s.size, log.y_m[-1]))),
        np.concatenate((log.heading_rad, np.full(tail_s.size, log.heading_rad[-1]))),
        np.concatenate((log.rudder_rad, back)),
        np.concatenate((log.n_rps, np.full(tail_s.size, log.n_rps[-1]))),
    )
    assert back[-1] == 0.0 and maneuver_kind(ended) == "zigzag"
    whole, cut = logged_condition(log), logged_condition(ended)
    assert cut.program.name == whole.program.name == "zigzag-10-10-port"
    assert cut.program.rudder_rad == pytest.approx(whole.program.rudder_rad, abs=1e-12)
    assert cut.switch_headings_rad == pytest.approx(whole.switch_headings_rad, abs=1e-12)
    assert cut.rudder_rate_radps == pytest.approx(whole.rudder_rate_radps, rel=1e-9)


@pytest.mark.parametrize("first", ["zigzag", "turning"])
def test_a_manoeuvre_steadied_by_the_helm_after_it_is_read_as_itself(first: str) -> None:
    """A zig-zag or a turning circle, then 400 s on the autopilot, which checks the swing
    with rudder to the other side: a zig-zag's steadying is no reversal but its first,
    at the check angle where the zig-zag's last leg ended (before, every move was read as
    one, the tanker's 10/10 as ``zigzag-9-12``), a turn's counter-rudder no zig-zag (a 35°
    turn read as ``zigzag-22-595``)."""
    ship = reference_ship("kvlcc2", "full")
    alone = (
        zigzag(math.radians(10.0), math.radians(10.0))
        if first == "zigzag"
        else turning_circle(-math.radians(35.0))
    )
    steady = Leg(0.0, Until(time_s=400.0), label="steady", steer=True)
    steadied = replace(alone, legs=(*alone.legs, steady))
    logs = [synthesize_log(ship, p, rate_hz=10.0, position_noise_m=0.0, heading_noise_deg=0.0)
            for p in (alone, steadied)]  # fmt: skip
    assert np.ptp(logs[1].rudder_rad[-4000:]) > math.radians(2.0)  # the helm at work
    whole, then = (logged_condition(log) for log in logs)
    assert then.program.name == whole.program.name == alone.name
    assert then.program.rudder_rad == pytest.approx(whole.program.rudder_rad, abs=1e-9)
    logged = len(whole.switch_headings_rad)
    assert then.switch_headings_rad[:logged] == pytest.approx(whole.switch_headings_rad, abs=1e-12)
    if first == "zigzag":  # the helm's first check, at the check angle
        (extra,) = then.switch_headings_rad[logged:]
        assert math.degrees(extra) == pytest.approx(10.0, abs=1.5)


def test_the_ship_that_sailed_a_log_sails_it_again_to_the_same_overshoots(
    reference_zigzag: ManeuverLog,
) -> None:
    ship = reference_ship("kvlcc2", "full")
    again = sail_again(ship.plant, reference_zigzag)
    assert not again.diverged
    for key in ("first_overshoot_deg", "second_overshoot_deg"):
        assert again.predicted[key] == pytest.approx(again.logged[key], abs=0.05)
    for key in ("initial_turning_time_s", "time_to_check_yaw_s", "period_s"):
        # within a 0.1 s step, or 0.3 % of the period (each reversal up to a step late)
        assert again.predicted[key] == pytest.approx(again.logged[key], abs=0.2, rel=3e-3)
    # ... and a different condition gives different overshoots: the test can fail.
    assert again.logged["first_overshoot_deg"] > 1.0
    assert again.logged["period_s"] > 2.0 * again.logged["initial_turning_time_s"] > 20.0


def test_logs_are_classified_by_their_rudder() -> None:
    ship = reference_ship("kvlcc2", "full")
    turn = synthesize_log(ship, MANEUVERS["turning-35"](), position_noise_m=0.0)
    assert maneuver_kind(turn) == "turning"
    c = logged_condition(turn)
    assert c.program.kind == "turning" and c.switch_headings_rad == ()
    assert math.degrees(c.program.rudder_rad) == pytest.approx(35.0, abs=0.01)
    still = ManeuverLog(
        turn.time_s, turn.x_m, turn.y_m, turn.heading_rad, turn.rudder_rad * 0.0, turn.n_rps
    )
    assert maneuver_kind(still) is None
    assert execute_index(still) == still.n_samples - 1
    with pytest.raises(IdentificationError, match="never leaves midship"):
        logged_condition(still)


# --------------------------------------------------------------------------------------
# Measured data in the loop: the default fit on the HSVA 10/10 pair (benchmarks/hsva.py)
# --------------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def result_on_the_10_10_pair(hsva: dict[str, ManeuverLog]) -> IdentificationResult:
    """The default fit of the two 10/10 runs."""
    # A towing tank: still water (README "Identification at sea": --current none for tanks).
    still_water = FitSettings(current="none")
    return identify([hsva["hsva_zz10_stbd"], hsva["hsva_zz10_port"]], still_water, length_m=7.0)


@pytest.fixture(scope="module")
def fit_on_the_10_10_pair(
    hsva: dict[str, ManeuverLog], result_on_the_10_10_pair: IdentificationResult
) -> dict[str, SailedAgain]:
    """The default fit of the two 10/10 runs, every run sailed again in its condition."""
    params = result_on_the_10_10_pair.params
    return {run: sail_again(ModelPlant(params), log) for run, log in hsva.items()}


def _hard_turns(params: ModelParameters) -> tuple[VirtualTurn, VirtualTurn]:
    """35° turns to both sides from the fit's approach, at the runs' rudder rate."""
    return virtual_turns(
        params,
        speed_mps=params.nominal_speed_mps,
        n_rps=params.nominal_n_rps,
        rudder_rate_radps=math.radians(15.0),
    )


def test_a_fit_at_one_rpm_refits_a_thrust_that_is_not_a_propellers(
    result_on_the_10_10_pair: IdentificationResult,
) -> None:
    """Both runs at 10.23 rev/s: the free thrust split is the logs' to get wrong, and they
    do (benchmarks/hsva.md, "The propeller thrust is why"); the default fit says so and
    refits with a thrust of fixed slope, whose 35° turns complete (KVLCC2: 3.1 L)."""
    result = result_on_the_10_10_pair
    refit = fixed_thrust_model(DEFAULT_MODEL)
    assert refit is not None and result.params.model.startswith(f"{refit}[")
    assert "X_un = " in result.params.identification["thrust"]
    assert any(f"refitted as {refit}," in note for note in result.notes)
    assert not any("not a propeller's" in w for w in result.warnings)
    # the runs approach within 0.02 deg of amidships: no neutral-helm note
    assert not any("neutral helm" in note for note in result.notes)
    turns = _hard_turns(result.params)
    assert all(t.sane and t.tactical_diameter_m is not None for t in turns)
    assert all(2.0 < (t.tactical_diameter_m or 0.0) / 7.0 < 4.5 for t in turns)


def test_a_failed_refit_keeps_the_free_split_warned_about(
    hsva: dict[str, ManeuverLog], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A refit that fails (a diverging EKF, say) does not lose the fit that worked; the
    three fits (free, refit, free again) start from one smoothing of each log."""
    first_pass = identify_module._fit
    smooth = preparation.smooth_track
    smoothed = []

    def counted(*args, **kwargs):  # type: ignore[no-untyped-def]
        smoothed.append(args[0].size)
        return smooth(*args, **kwargs)

    refit = fixed_thrust_model(DEFAULT_MODEL)
    assert refit is not None

    def refit_fails(data, settings, *args):  # type: ignore[no-untyped-def]
        if settings.model.startswith(refit):
            raise IdentificationError("the EKF diverged (test)")
        return first_pass(data, settings, *args)

    monkeypatch.setattr(identify_module, "_fit", refit_fails)
    monkeypatch.setattr(preparation, "smooth_track", counted)
    runs = [hsva["hsva_zz10_stbd"], hsva["hsva_zz10_port"]]
    result = identify(runs, FitSettings(current="none"), length_m=7.0)
    assert smoothed == [run.n_samples for run in runs]
    assert result.params.model.startswith(f"{DEFAULT_MODEL}[")
    assert any("not a propeller's" in w for w in result.warnings)
    failed = f"the refit as {refit} failed (the EKF diverged"
    assert any(failed in note for note in result.notes)


def test_other_families_keep_the_free_split_and_are_warned(
    hsva: dict[str, ManeuverLog],
) -> None:
    """prime-rudder-lift has no fixed-slope twin: its free split stays, it is warned about,
    and its hard turns stop (the hard-turn column of benchmarks/hsva.md)."""
    runs = [hsva["hsva_zz10_stbd"], hsva["hsva_zz10_port"]]
    settings = FitSettings(model="prime-rudder-lift", current="none")
    result = identify(runs, settings, length_m=7.0)
    assert result.params.model.startswith("prime-rudder-lift[")
    assert any("not a propeller's" in w for w in result.warnings)
    assert not all(t.sane for t in _hard_turns(result.params))


def test_measured_training_runs_are_reproduced_within_1_degree(
    fit_on_the_10_10_pair: dict[str, SailedAgain],
) -> None:
    for run in ("hsva_zz10_stbd", "hsva_zz10_port"):
        sailed = fit_on_the_10_10_pair[run]
        assert not sailed.diverged
        for key in ("first_overshoot_deg", "second_overshoot_deg"):
            assert sailed.predicted[key] == pytest.approx(sailed.logged[key], abs=1.0), (run, key)


def test_the_measured_port_starboard_difference_is_predicted_with_its_sign(
    fit_on_the_10_10_pair: dict[str, SailedAgain],
) -> None:
    """Second overshoot, port-first run minus starboard-first run: −2.7° measured (10/10)."""
    stbd, port = (fit_on_the_10_10_pair[r] for r in ("hsva_zz10_stbd", "hsva_zz10_port"))
    key = "second_overshoot_deg"
    measured = port.logged[key] - stbd.logged[key]
    predicted = port.predicted[key] - stbd.predicted[key]
    assert measured < -2.0
    assert predicted < 0.0 and predicted == pytest.approx(measured, abs=1.5)


def test_held_out_20_10_runs_first_overshoots_within_1_5_degrees(
    fit_on_the_10_10_pair: dict[str, SailedAgain],
) -> None:
    """The issue's bar for the first overshoots; the second ones are 4-4.5 deg too large
    (README, Status): guarded here against getting worse only."""
    for run in ("hsva_zz20_10_stbd", "hsva_zz20_10_port"):
        sailed = fit_on_the_10_10_pair[run]
        first, second = "first_overshoot_deg", "second_overshoot_deg"
        assert sailed.predicted[first] == pytest.approx(sailed.logged[first], abs=1.5), run
        assert sailed.predicted[second] == pytest.approx(sailed.logged[second], abs=5.0), run
