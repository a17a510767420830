"""Cross-validation: classification, the known-answer case, the CLI."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import ModelParameters
from identifier.cli import main
from identifier.crossval import (
    SAIL_STEP_L,
    Fold,
    cross_validate,
    held_out_errors,
    select_logs,
)
from identifier.identify import FitSettings
from identifier.ingest import output_paths
from identifier.smoothing import smooth_log
from scenarios.synthesize import (
    MANEUVERS,
    model_ship,
    synthesize_log,
    with_compass_spikes,
    with_gnss_jumps,
)
from tests.conftest import SEED_COEFFICIENTS
from tests.trial_day import joined
from trials.conditions import logged_condition, maneuver_kind, sail_again
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, read_log, write_log
from trials.run import ModelPlant

RUDDER_RATE = math.radians(5.0)
NAMES = ("turning-35", "zigzag-10", "zigzag-20", "turning-35-port", "zigzag-10-port")


def _truth() -> ModelParameters:
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )


@pytest.fixture(scope="module")
def logs() -> dict[str, ManeuverLog]:
    """Seed-model logs, 1 Hz, 1 m / 0.1 deg noise (the model fitted to data from itself)."""
    ship = model_ship(_truth(), rudder_rate_radps=RUDDER_RATE)
    return {
        name: synthesize_log(ship, MANEUVERS[name](), seed=seed) for seed, name in enumerate(NAMES)
    }


@pytest.fixture(scope="module")
def log_files(logs: dict[str, ManeuverLog], tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    directory = tmp_path_factory.mktemp("cv")
    paths = []
    for name in NAMES[:3]:
        paths.append(directory / f"{name}.csv")
        write_log(paths[-1], logs[name])
    return paths


@pytest.fixture(scope="module")
def known_answer(logs: dict[str, ManeuverLog]) -> Fold:
    train = [logs[n] for n in ("turning-35", "zigzag-10", "zigzag-20")]
    test = [logs[n] for n in ("turning-35-port", "zigzag-10-port")]
    return cross_validate(train, test, FitSettings(model="shi2009"))


def test_logs_are_classified_by_their_rudder_not_their_names(
    logs: dict[str, ManeuverLog], log_files: list[Path]
) -> None:
    assert maneuver_kind(logs["turning-35-port"]) == "turning"
    assert maneuver_kind(logs["zigzag-20"]) == "zigzag"
    named = ManeuverLog(*(getattr(logs["zigzag-10"], k) for k in _ARRAYS), path="t/turn1.csv")
    assert maneuver_kind(named) == "zigzag"  # the rudder goes to both sides
    zz = logs["zigzag-10"]
    midship = ManeuverLog(*(getattr(zz, k) for k in _ARRAYS[:4]), zz.rudder_rad * 0.0, zz.n_rps)
    assert maneuver_kind(midship) is None
    files = [read_log(p) for p in log_files]
    assert select_logs(files, ["zigzag"]) == [1, 2]
    assert select_logs(files, [str(log_files[0]), "zigzag"]) == [0, 1, 2]
    with pytest.raises(IdentificationError, match="neither a manoeuvre kind"):
        select_logs(files, ["spiral"])


_ARRAYS = ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps")


def _angles_deg(log: ManeuverLog) -> tuple[float, float]:
    """The zig-zag's first rudder command and check heading as its condition reads them."""
    program = logged_condition(log).program
    return math.degrees(program.rudder_rad), math.degrees(program.heading_rad)


def test_zigzag_angles_from_the_source_or_from_the_data(logs: dict[str, ManeuverLog]) -> None:
    assert _angles_deg(logs["zigzag-10-port"]) == pytest.approx((-10.0, 10.0), abs=0.01)
    bare = ManeuverLog(*(getattr(logs["zigzag-20"], k) for k in _ARRAYS), metadata={})
    # the rudder's plateaus; the standard angle the logged switch headings stand for
    assert _angles_deg(bare) == pytest.approx((20.0, 20.0), abs=0.01)


def test_model_fitted_to_its_own_data_predicts_held_out_manoeuvres_within_1_percent(
    known_answer: Fold,
) -> None:
    assert known_answer.params.identification["refinement"]["kept"] == "refined"
    turning, zig = known_answer.held_out
    assert turning.kind == "turning" and zig.kind == "zigzag"
    for m in turning.metrics:
        assert m.relative_error is not None and abs(m.relative_error) < 0.01, m
    for m in zig.metrics:
        assert m.error is not None and m.logged is not None
        if m.name.endswith("_s"):  # peaks and crossings of a 1 Hz log: within half a sample
            assert abs(m.error) <= 0.5, m
        else:
            assert abs(m.error) <= max(0.01 * abs(m.logged), 0.1), m  # [deg]
    assert {m.name for m in zig.metrics} >= {"time_to_check_yaw_s", "period_s"}
    assert turning.position_rms_L < 0.05 and zig.position_rms_L < 0.05
    for held in (turning, zig):  # nothing uncovered, nothing diverged; a current of < 0.1 m/s
        (note,) = held.notes
        assert note.startswith("predicted in the training fit's current, 0.0"), note


def test_a_held_out_zigzag_is_sailed_again_closed_loop(
    known_answer: Fold, logs: dict[str, ManeuverLog]
) -> None:
    """A model whose rudder turns the ship a fifth harder, on the held-out 10/10: its
    indices are those of the zig-zag it sails itself, reversing at the logged switch
    headings (``trials.conditions.sail_again``, as the scenarios' --like sails it), not
    those of a replay of the logged rudder, which reverses when the log did (before:
    second overshoot 7.2 deg against 15.7 closed loop on HSVA's 10/10 starboard-first
    run, leaving it out of the four)."""
    params = known_answer.params
    theta = params.to_vector().copy()
    theta[[t.coefficient for t in params.structure.terms].index("c3")] *= 1.2
    harder = params.with_vector(theta)
    log = logs["zigzag-10-port"]
    metrics = {m.name: m for m in held_out_errors(harder, log).metrics}
    speed = float(np.median(smooth_log(log).speed_mps))
    again = sail_again(ModelPlant(harder), log, dt_s=SAIL_STEP_L * harder.length_m / speed)
    for key in ("first_overshoot_deg", "second_overshoot_deg", "time_to_check_yaw_s"):
        assert metrics[key].predicted == pytest.approx(again.predicted[key], rel=1e-12), key
    first = metrics["first_overshoot_deg"]
    assert first.predicted is not None and first.logged is not None
    assert first.predicted > first.logged + 0.3  # harder over: further past the check heading


def test_a_held_out_logs_trajectories_are_those_its_indices_were_read_off(
    known_answer: Fold,
) -> None:
    """What ``crossval --plot`` draws: the smoothed log and the prediction, their time
    from execute; the model of the logs' own structure lies on them (its indices within
    1 %), and the zig-zag's run reverses its rudder where its heading says."""
    turning, zig = known_answer.held_out
    for held in (turning, zig):
        assert held.logged is not None and held.predicted is not None
        assert held.logged["time_s"][0] < 0.0 < held.logged["time_s"][-1]
        assert held.predicted["time_s"][0] == pytest.approx(0.0)
    assert turning.logged is not None and turning.predicted is not None
    at = np.searchsorted(turning.logged["time_s"], turning.predicted["time_s"])
    apart = np.hypot(*(turning.logged[k][at] - turning.predicted[k] for k in ("x_m", "y_m")))
    assert float(np.max(apart)) < 0.05 * known_answer.params.length_m
    assert zig.predicted is not None
    heading = np.degrees(zig.predicted["psi_rad"] - zig.predicted["psi_rad"][0])
    rudder = np.abs(zig.predicted["rudder_rad"])  # port first: to 10 deg, then back
    held = int(np.argmax(rudder >= rudder.max() - 1e-9))
    reversal = held + int(np.argmax(rudder[held:] < rudder.max() - 1e-9))
    assert abs(heading[reversal]) == pytest.approx(10.0, abs=0.2)  # at the check heading


def test_a_held_out_log_of_several_manoeuvres_is_noted(logs: dict[str, ManeuverLog]) -> None:
    """A port zig-zag and then a starboard turn in one held-out log: predicted as one
    manoeuvre, with a note to split it; a log of one manoeuvre has no such note."""
    zig, turn = logs["zigzag-10-port"], logs["turning-35"]
    both = held_out_errors(_truth(), joined(zig, turn))
    executes = f"60.0, {zig.time_s[-1] + 61.0:.1f}"
    assert (
        f"the log holds 2 manoeuvres (executed at t = {executes} s), read here as one: split it "
        "into one log each first (python -m identifier split)"
    ) in both.notes
    assert not any("manoeuvres" in note for note in held_out_errors(_truth(), zig).notes)


def test_a_held_out_logs_glitches_are_taken_out_as_the_fits_are(
    known_answer: Fold, logs: dict[str, ManeuverLog]
) -> None:
    """The held-out 10/10 zig-zag with 2 % of its fixes jumped 50-1000 m, 1 % of its
    headings spiked and a rudder sample at 35°: predicted as the clean log (before, the
    jumps went into the position RMS, 0.85 L against 0.015)."""
    clean = logs["zigzag-10-port"]
    glitched, _ = with_gnss_jumps(clean, 0.02, seed=1)
    glitched, _ = with_compass_spikes(glitched, 0.01, seed=2)
    rudder = glitched.rudder_rad.copy()
    rudder[clean.n_samples // 2] = math.radians(35.0)
    glitched = replace(glitched, rudder_rad=rudder)
    want, got = (held_out_errors(known_answer.params, log) for log in (clean, glitched))
    assert got.position_rms_L == pytest.approx(want.position_rms_L, rel=0.05)
    for a, b in zip(want.metrics, got.metrics, strict=True):
        assert b.predicted == pytest.approx(a.predicted, abs=0.05), (a, b)  # [deg]
        assert b.logged == pytest.approx(a.logged, abs=0.05), (a, b)


def test_cli_crossval_writes_table_and_json(log_files: list[Path], tmp_path: Path, capsys) -> None:
    out = tmp_path / "cv.json"
    status = main(
        ["crossval", *map(str, log_files), "--train", "zigzag", "--test", "turning",
         "--model", "shi2009", "--json", str(out), "--plot", str(tmp_path / "plots")]
    )  # fmt: skip
    assert status == 0
    table = capsys.readouterr().out
    assert "| tactical_diameter_m |" in table and f"wrote {out}" in table
    assert f"wrote {tmp_path / 'plots' / 'fold1-turning-35.png'}" in table
    assert (tmp_path / "plots" / "fold1-turning-35.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    doc = json.loads(out.read_text())
    assert doc["model"] == "shi2009" and doc["method"] == "output-error"
    (fold,) = doc["folds"]
    assert fold["train"] == [str(p) for p in log_files[1:]]
    (held,) = fold["test"]
    assert held["log"] == str(log_files[0]) and held["kind"] == "turning"
    assert held["position_rms_L"] > 0.0
    # (and a steady diameter where the log turns through 540 deg: this one stops short)
    assert set(held["metrics"]) == {"advance_m", "transfer_m", "tactical_diameter_m"}
    td = held["metrics"]["tactical_diameter_m"]
    assert set(td) == {"logged", "predicted", "error", "relative_error"}
    assert td["error"] == pytest.approx(td["predicted"] - td["logged"])


def test_cli_leave_one_out_runs_one_fold_per_log(
    log_files: list[Path], tmp_path: Path, capsys
) -> None:
    out = tmp_path / "loo.json"
    # The logs' own structure, shi2009: the folds' plumbing, not the default family, is tested
    args = ["crossval", *map(str, log_files), "--leave-one-out", "--model", "shi2009"]
    assert main([*args, "--json", str(out)]) == 0
    folds = json.loads(out.read_text())["folds"]
    assert [f["test"][0]["log"] for f in folds] == [str(p) for p in log_files]
    for fold, held_out in zip(folds, log_files, strict=True):
        assert str(held_out) not in fold["train"] and len(fold["train"]) == 2
    table = capsys.readouterr().out  # angles and times with their absolute error
    assert re.search(r"\| first_overshoot_deg \| [^|]+ \| [^|]+ \| [+-]\d+\.\d\d deg \(", table)
    assert re.search(r"\| time_to_check_yaw_s \| [^|]+ \| [^|]+ \| [+-]\d+\.\d\d s \(", table)
    zig = folds[1]["test"][0]
    assert set(zig["metrics"]) == {
        "first_overshoot_deg", "second_overshoot_deg",
        "initial_turning_time_s", "time_to_check_yaw_s", "period_s",
    }  # fmt: skip
    times = zig["metrics"]["initial_turning_time_s"]
    assert times["logged"] > 0.0 and times["error"] == pytest.approx(
        times["predicted"] - times["logged"]
    )


def test_cli_crossval_exit_codes(log_files: list[Path], tmp_path: Path, capsys) -> None:
    files = list(map(str, log_files))
    # Usage errors: 2.
    assert main(["crossval", *files, "--leave-one-out", "--train", "zigzag"]) == 2
    assert main(["crossval", *files]) == 2
    for option, bad_value in (("--model", "nope"), ("--current", "sideways")):
        with pytest.raises(SystemExit) as info:
            main(["crossval", *files, "--train", "zigzag", option, bad_value])
        assert info.value.code == 2
        assert f"invalid choice: '{bad_value}'" in capsys.readouterr().err
    # Data errors: 1, one line, nothing written.
    out = tmp_path / "cv.json"
    assert main(["crossval", *files, "--train", "spiral", "--json", str(out)]) == 1
    assert "spiral" in capsys.readouterr().err  # neither a kind nor a readable log
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,x_m,y_m,heading_deg,rudder_deg,rpm\n0,0,0,0,0,abc\n")
    assert main(["crossval", str(bad), *files, "--train", "zigzag", "--json", str(out)]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.csv:2: column 'rpm'" in err
    assert main(["crossval", files[0], "--train", files[0], "--test", files[0]]) == 1
    assert "both trained on and held out" in capsys.readouterr().err
    assert not out.exists()


def test_a_converted_logs_segment_suffix_is_not_read_as_an_angle(
    logs: dict[str, ManeuverLog], tmp_path: Path
) -> None:
    # ``identifier convert`` numbers its outputs <stem>_1.csv, <stem>_2.csv, ...
    arrays = [getattr(logs["zigzag-10"], k) for k in _ARRAYS]
    first, _ = output_paths(tmp_path, "zigzag-10", 2)
    assert first.name == "zigzag-10_1.csv"
    converted = ManeuverLog(*arrays, metadata={}, path=str(first))
    assert maneuver_kind(converted) == "zigzag"
    assert _angles_deg(converted) == pytest.approx((10.0, 10.0), abs=0.01)  # not 10/1
    # angles in the name before the suffix are still read (5 deg: not what the data say)
    _, second = output_paths(tmp_path, "zigzag-10-5", 2)
    named = ManeuverLog(*arrays, metadata={}, path=str(second))
    assert Path(named.path or "").name == "zigzag-10-5_2.csv"
    assert _angles_deg(named) == pytest.approx((10.0, 5.0), abs=0.01)


@pytest.mark.parametrize("length", ["-5", "0", "nan", "inf", "abc"])
def test_cli_crossval_length_must_be_a_positive_number(
    log_files: list[Path], length: str, capsys
) -> None:
    files = list(map(str, log_files))
    with pytest.raises(SystemExit) as info:
        main(["crossval", *files, "--train", "zigzag", "--length-m", length])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "crossval: error: argument --length-m: expected" in err
