"""Identification end to end: recovery of known coefficients, bad data, the CLI."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import ModelParameters, get_model, load_params, variants
from fmu_model.envelope import trajectory_envelope, union
from fmu_model.interface import logged_envelope
from fmu_model.variants import (
    PRIME_RUDDER_OFFSET,
    SURGE_DRAG_PRIOR_X,
    SURGE_DRAG_TERMS,
    SURGE_MASS,
    THRUST_SLOPE,
)
from identifier.cli import build_parser, main
from identifier.cli import fit as fit_cli
from identifier.diagnostics import (
    TURN_EXTRAPOLATION_EVIDENCE,
    centripetal_warning,
    logged_side,
    one_sided_model,
    reversal_warning,
    thrust_warning,
    turn_warning,
)
from identifier.identify import FitSettings, IdentificationResult, fixed_thrust_model, identify
from identifier.preparation import MAX_SAMPLE_INTERVAL_S, ekf_order, smooth_logs
from scenarios.kvlcc2 import kvlcc2
from scenarios.synthesize import MANEUVERS, TruthShip, model_ship, reference_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, format_log, parse_log, read_log, write_log
from trials.maneuvers import Leg, Program, Until, turning_circle, zigzag
from trials.metrics import turning_metrics, zigzag_metrics
from trials.run import ModelPlant, run_program

TRAINING = ("turning-35", "zigzag-10", "zigzag-20")
RUDDER_RATE = math.radians(5.0)
SEED = FitSettings(model="shi2009", method="ekf")  # the paper's EKF, the truth's structure


def _truth() -> ModelParameters:
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )


def _ship() -> TruthShip:
    return model_ship(_truth(), rudder_rate_radps=RUDDER_RATE)


@pytest.fixture(scope="module")
def log_files(tmp_path_factory: pytest.TempPathFactory) -> list[Path]:
    """Seed-model logs, 1 Hz, 1 m position and 0.1 deg heading noise, written to CSV."""
    directory = tmp_path_factory.mktemp("logs")
    paths = []
    for seed, name in enumerate(TRAINING):
        log = synthesize_log(_ship(), MANEUVERS[name](), seed=seed)
        paths.append(directory / f"{name}.csv")
        write_log(paths[-1], log)
    return paths


@pytest.fixture(scope="module")
def recovered(log_files: list[Path]) -> IdentificationResult:
    return identify([read_log(p) for p in log_files], SEED)


def test_noise_levels_are_estimated_from_the_logs(recovered: IdentificationResult) -> None:
    for track in recovered.tracks:
        assert track.position_noise_m == pytest.approx(1.0, rel=0.1)
        assert math.degrees(track.heading_noise_rad) == pytest.approx(0.1, rel=0.1)


def test_identifiable_coefficients_are_recovered_within_3_sigma(
    recovered: IdentificationResult,
) -> None:
    truth = dict(SEED_COEFFICIENTS)
    identifiable = [c for c in recovered.coefficients if c.identifiable]
    # The sway and yaw coefficients that shape the manoeuvres must be among them.
    assert {"b1", "b4", "c1", "c2", "c3"} <= {c.name for c in identifiable}
    for c in identifiable:
        assert abs(c.value - truth[c.name]) <= 3.0 * c.std, (c.name, c.value, c.std)
    # ... and the uncertainties are informative, not inflated to pass.
    by_name = {c.name: c for c in recovered.coefficients}
    assert by_name["c3"].relative_std < 0.02
    assert by_name["c2"].relative_std < 0.05


def _metrics(params: ModelParameters, program: Program) -> tuple[float, float]:
    run = run_program(
        ModelPlant(params), program, speed_mps=5.0, n_rps=2.0,
        rudder_rate_radps=RUDDER_RATE, dt_s=0.1,
    )  # fmt: skip
    if program.kind == "turning":
        m = turning_metrics(run)
        return m.advance_m, m.tactical_diameter_m
    z = zigzag_metrics(run, program.rudder_rad, program.heading_rad)
    assert z.second_overshoot_rad is not None
    return z.first_overshoot_deg, math.degrees(z.second_overshoot_rad)


def test_identified_model_reproduces_the_manoeuvres(recovered: IdentificationResult) -> None:
    truth = _truth()
    advance, tactical = _metrics(recovered.params, turning_circle(math.radians(35.0)))
    true_advance, true_tactical = _metrics(truth, turning_circle(math.radians(35.0)))
    assert advance == pytest.approx(true_advance, rel=0.01)
    assert tactical == pytest.approx(true_tactical, rel=0.01)
    for angle in (10.0, 20.0):
        program = zigzag(math.radians(angle), math.radians(angle))
        first, second = _metrics(recovered.params, program)
        true_first, true_second = _metrics(truth, program)
        assert first == pytest.approx(true_first, abs=0.5)
        assert second == pytest.approx(true_second, abs=0.5)


def test_nominal_condition_comes_from_the_approach(recovered: IdentificationResult) -> None:
    assert recovered.params.nominal_speed_mps == pytest.approx(5.0, rel=0.01)
    assert recovered.params.nominal_n_rps == pytest.approx(2.0)
    assert recovered.params.length_m == 100.0


def test_track_measurements_beat_the_papers_velocity_measurements(
    log_files: list[Path], recovered: IdentificationResult
) -> None:
    paper = identify(
        [read_log(p) for p in log_files],
        FitSettings(
            model="shi2009",
            method="ekf",
            measurements="velocities",
            max_substep_s=math.inf,
            current="none",  # the paper's: still water (and the velocities are over ground)
        ),
    )
    ours = {c.name: c for c in recovered.coefficients}
    theirs = {c.name: c.value for c in paper.coefficients}
    for name in ("b1", "b4", "c2", "c3"):
        truth = SEED_COEFFICIENTS[name]
        # The paper's variant (smoothed u, v, r, one Euler step per sample) finds the
        # dominant coefficients within 30 %, biased by the smoother's lag ...
        assert theirs[name] == pytest.approx(truth, rel=0.3), name
        # ... the EKF on the logged track within 2σ of the truth ...
        assert abs(ours[name].value - truth) < 2.0 * ours[name].std, name
    for name in ("b1", "c2"):  # ... and closer where the lag biases most (−27 %, −11 %)
        truth = SEED_COEFFICIENTS[name]
        assert abs(ours[name].value - truth) < 0.5 * abs(theirs[name] - truth), name


def _straight_log() -> ManeuverLog:
    program = Program("straight", "turning", (Leg(0.0, Until(time_s=300.0)),))
    return synthesize_log(_ship(), program, seed=3)


def test_straight_run_alone_is_refused_naming_the_missing_manoeuvre() -> None:
    # Nothing excites the rudder and turning terms: no coefficients to report, and the
    # reason is the log, not a setting.
    with pytest.raises(
        IdentificationError, match="no rudder excitation: nothing to identify"
    ) as err:
        identify([_straight_log()], SEED)
    assert err.value.message.endswith("a zig-zag or a turning circle")  # nor does it turn


def test_straight_run_beside_a_manoeuvre_reports_unidentifiable_coefficients(
    log_files: list[Path],
) -> None:
    zigzag = read_log(log_files[1])
    result = identify([_straight_log(), zigzag], SEED)
    assert result.params.length_m == 100.0
    assert any("not identifiable" in w for w in result.warnings)


def test_diverging_filter_raises_with_log_and_sample(log_files: list[Path]) -> None:
    log = read_log(log_files[1])
    with pytest.raises(IdentificationError, match=r"sample \d+: .*(diverged|exploded)") as info:
        identify([log], FitSettings(model="shi2009", param_random_walk=100.0))
    assert info.value.sample is not None and info.value.sample > 0


def test_too_coarse_sampling_is_an_error() -> None:
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), rate_hz=0.1, seed=1)
    with pytest.raises(IdentificationError, match=r"sampling interval 10 s is too coarse") as e:
        identify([log])
    assert str(e.value).endswith("(expected at most 5 s)")  # a slow logger: no unit hint


def test_a_time_in_milliseconds_is_named() -> None:
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), seed=1)
    with pytest.raises(IdentificationError) as excinfo:
        identify([replace(log, time_s=log.time_s * 1000.0)])
    assert str(excinfo.value).endswith(
        "median sampling interval 1000 s is too coarse to resolve manoeuvring (expected at "
        "most 5 s): is time_s in seconds, not milliseconds?"
    )


def test_a_log_at_the_coarsest_interval_is_smoothed() -> None:
    """0.2 Hz with times summed in floating point: 5.000000000005 s, a few ulps beyond
    the limit (rejected before: "interval 5 s is too coarse (expected at most 5 s)")."""
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), rate_hz=0.2, seed=1)
    log = replace(log, time_s=np.arange(log.time_s.size) * MAX_SAMPLE_INTERVAL_S * (1 + 1e-12))
    assert float(np.median(np.diff(log.time_s))) > MAX_SAMPLE_INTERVAL_S
    smoothed = smooth_logs(
        [log], length_m=320.0, position_noise_m=None, heading_noise_rad=None, measurements="track",
        windage=None, drifting=False, progress=None, stage=lambda _: None,
    )  # fmt: skip
    assert len(smoothed.tracks) == 1


def test_gaps_in_the_samples_are_noted() -> None:
    """Fifteen fixes lost from a 1 Hz zig-zag, and 3 s further on two more: the fit
    bridges them and says where (an interval of five median ones or more); none in
    the log as logged."""
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), seed=1)

    def notes(kept: np.ndarray) -> list[str]:
        cut = ManeuverLog(
            log.time_s[kept], log.x_m[kept], log.y_m[kept], log.heading_rad[kept],
            log.rudder_rad[kept], log.n_rps[kept], metadata=log.metadata,
        )  # fmt: skip
        data = smooth_logs(
            [cut], length_m=320.0, position_noise_m=None, heading_noise_rad=None,
            measurements="track", windage=None, drifting=False, progress=None,
            stage=lambda _: None,
        )  # fmt: skip
        return [n for n in data.notes if "gap" in n]

    everything = np.ones(log.n_samples, dtype=bool)
    assert notes(everything) == []
    lost = everything.copy()
    lost[300:315] = False
    assert notes(lost) == [
        "log 1: 1 gap in the samples: 16 s from t = 299 s (sample 299; the median interval "
        "1 s): bridged by the smoother's motion model and the EKF's ship model"
    ]
    lost[318:322] = False  # 5 s: a gap too; 4 s would not be
    (two,) = notes(lost)
    assert two.startswith("log 1: 2 gaps in the samples, the longest 16 s from t = 299 s")


def test_a_speed_logs_dropout_filled_on_reading_is_noted() -> None:
    """Three empty stw_mps cells of a 1 Hz zig-zag with a speed log: read, filled and
    named in the fit's notes (a data error before); none without them."""
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), seed=1)
    text = format_log(replace(log, stw_mps=np.full(log.n_samples, 8.0))).splitlines()
    header = next(i for i, line in enumerate(text) if line.startswith("time_s"))
    for i in range(header + 101, header + 104):
        text[i] = text[i].rsplit(",", 1)[0] + ","

    def notes(lines: list[str]) -> list[str]:
        data = smooth_logs(
            [parse_log("\n".join(lines) + "\n", "z.csv")], length_m=320.0,
            position_noise_m=None, heading_noise_rad=None, measurements="track",
            windage=None, drifting=False, progress=None, stage=lambda _: None,
        )  # fmt: skip
        return [n for n in data.notes if "without a value" in n]

    assert notes(text) == [
        "z.csv: cells without a value (3 of stw_mps), a sensor's dropout, interpolated"
    ]
    assert notes(format_log(replace(log, stw_mps=np.full(log.n_samples, 8.0))).splitlines()) == []


def test_missing_length_is_an_error() -> None:
    log = _straight_log()
    bare = ManeuverLog(
        log.time_s, log.x_m, log.y_m, log.heading_rad, log.rudder_rad, log.n_rps, metadata={}
    )
    with pytest.raises(IdentificationError, match="no ship length: pass --length-m"):
        identify([bare])


def test_cli_fit_writes_params_and_plots(log_files: list[Path], tmp_path: Path, capsys) -> None:
    out = tmp_path / "params.json"
    args = ["--model", "shi2009", "-o", str(out), "--plot", str(tmp_path), "--quiet"]
    status = main(["fit", *map(str, log_files), *args])
    assert status == 0
    params = load_params(out)
    assert params.model == "shi2009" and params.length_m == 100.0
    doc = json.loads(out.read_text())
    in_ekf_order = [log_files[i] for i in ekf_order([read_log(p) for p in log_files])]
    assert [entry["sha256"] for entry in doc["identification"]["logs"]] == [
        __import__("hashlib").sha256(p.read_bytes()).hexdigest() for p in in_ekf_order
    ]
    assert in_ekf_order[-1].name == "turning-35.csv"  # the largest rudder angle last
    assert np.allclose(np.array(doc["covariance"]), np.array(doc["covariance"]).T)
    for name in ("track.png", "velocities.png", "convergence.png"):
        assert (tmp_path / name).stat().st_size > 10_000


def test_cli_bad_log_is_one_line_and_writes_nothing(tmp_path: Path, capsys) -> None:
    bad = tmp_path / "bad.csv"
    bad.write_text("time_s,x_m,y_m,heading_deg,rudder_deg,rpm\n0,0,0,0,0,abc\n")
    out = tmp_path / "params.json"
    assert main(["fit", str(bad), "-o", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "bad.csv:2: column 'rpm'" in err
    assert not out.exists()


def test_cli_usage_error_exits_2(capsys) -> None:
    with pytest.raises(SystemExit) as info:
        main(["fit", "x.csv"])
    assert info.value.code == 2


def test_cli_max_substep_accepts_inf_and_rejects_zero_negative_nan(capsys) -> None:
    parser = build_parser()

    def parse(value: str) -> float:
        return parser.parse_args(
            ["fit", "x.csv", "-o", "p.json", f"--max-substep-s={value}"]
        ).max_substep_s

    assert parse("inf") == math.inf  # the paper's one Euler step per sample
    assert parse("0.05") == 0.05
    for bad in ("0", "-0.1", "-inf", "nan"):
        with pytest.raises(SystemExit) as info:
            parse(bad)
        assert info.value.code == 2
        err = capsys.readouterr().err
        assert f"--max-substep-s: expected a number >= 0.001 s or inf, got '{bad}'" in err
    with pytest.raises(SystemExit) as info:
        parse("abc")
    assert info.value.code == 2
    assert "expected a number >= 0.001 s or inf, got 'abc'" in capsys.readouterr().err


def test_cli_fit_with_max_substep_inf_writes_params(
    log_files: list[Path], tmp_path: Path, capsys
) -> None:
    out = tmp_path / "params.json"
    args = ["--model", "shi2009", "--method", "ekf", "--max-substep-s", "inf", "-o", str(out)]
    args.append("--quiet")
    assert main(["fit", str(log_files[0]), *args]) == 0
    params = load_params(out)
    assert params.model == "shi2009"
    assert params.identification["settings"]["max_substep_s"] == "inf"


def test_cli_fit_summary_prints_the_kept_estimate_and_the_rates(
    log_files: list[Path], tmp_path: Path, capsys
) -> None:
    """The table is what params.json holds (the refined estimate, not the EKF's)."""
    out = tmp_path / "params.json"
    assert main(["fit", *map(str, log_files), "--model", "shi2009", "-o", str(out)]) == 0
    printed = capsys.readouterr().out
    params = load_params(out)
    assert params.identification["estimates"]["ekf"] != params.as_dict()  # refined: differs
    rows = {line.split()[0]: line.split() for line in printed.splitlines() if line[:1] == " "}
    for name, value, std in zip(params.names, params.coefficients, params.std, strict=True):
        assert float(rows[name][1]) == pytest.approx(value, rel=1e-5)
        assert float(rows[name][2]) == pytest.approx(std, rel=1e-2)
    samples = sum(read_log(p).n_samples for p in log_files)
    rows_line = next(line for line in printed.splitlines() if line.startswith("regression on"))
    assert f"the EKF on all {samples:,} samples" in rows_line
    regression_rows = int(rows_line.split()[2].replace(",", ""))
    assert samples - 2 * len(log_files) - 10 < regression_rows <= samples  # 1 Hz: every sample
    assert " rows at 1 s (about L/U/40)" in rows_line
    assert "the logs reach: rudder 20.0 deg to port, 35.0 deg to starboard; r' " in printed


@pytest.mark.parametrize("compiled", [0, 7])
def test_cli_fit_says_when_it_compiled(
    compiled: int, log_files: list[Path], tmp_path: Path, capsys, monkeypatch
) -> None:
    """A fit that compiled says so and names the warm-up; one that did not, nothing."""
    counts = iter([(3, 0), (3 + compiled, 4)])  # before and after the identification
    monkeypatch.setattr(fit_cli, "numba_compilations", lambda: next(counts))
    out = tmp_path / "params.json"
    args = ["--model", "shi2009", "--method", "ekf", "-o", str(out)]
    assert main(["fit", *map(str, log_files), *args]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if "numba" in line]
    expected = (
        f"note: compiled {compiled} numba functions (cached now: the first fit of shi2009 "
        "with these settings on this machine); `python -m scenarios warm-up --model shi2009` "
        "does it ahead, in a process of its own"
    )
    assert notes == ([expected] if compiled else [])


def test_stages_are_named_as_they_begin_and_samples_counted_twice(log_files: list[Path]) -> None:
    """What the fit's bar shows: every stage, in order; smoothing and EKF count the samples."""
    logs = [read_log(p) for p in log_files]
    stages: list[str] = []
    counted: list[int] = []
    identify(logs, FitSettings(model="shi2009"), progress=counted.append, stage=stages.append)
    names = [f"smoothing {Path(p).name}" for p in log_files]
    assert stages[: len(logs)] == names
    rest = stages[len(logs) :]
    assert rest[0] == "equation-error start" and rest[1] == "current: EKF pass 1"
    passes = [int(s.rsplit(" ", 1)[1]) for s in rest if s.startswith("current: EKF pass")]
    assert passes == list(range(1, len(passes) + 1)) and len(passes) >= 2
    assert rest[-2:] == ["EKF on every sample", "output-error refinement"]
    assert set(rest[:-2]) == {"equation-error start", *(f"current: EKF pass {k}" for k in passes)}
    assert sum(counted) == 2 * sum(log.n_samples for log in logs)


def test_identification_records_the_envelope_of_its_logs(
    recovered: IdentificationResult,
) -> None:
    """From 1 m / 0.1° noisy logs: the truth's rudder and rpm exactly, its r′ within 5 %,
    its lowest speed ratio within 0.02 (the truth sailed noise-free through the same runs)."""
    envelope = logged_envelope(recovered.params)
    assert envelope is not None
    ship = _ship()
    truth = union(
        trajectory_envelope(
            run_program(
                ship.plant,
                MANEUVERS[name](),
                speed_mps=ship.speed_mps,
                n_rps=ship.n_rps,
                rudder_rate_radps=ship.rudder_rate_radps,
                dt_s=1.0,
            ),
            recovered.params.length_m,
        )
        for name in TRAINING
    )
    assert envelope.rudder_max_rad == pytest.approx(truth.rudder_max_rad, rel=1e-9)
    assert envelope.yaw_rate_max == pytest.approx(truth.yaw_rate_max, rel=0.05)
    assert envelope.speed_ratio_min == pytest.approx(truth.speed_ratio_min, abs=0.02)
    assert envelope.approach_speed_mps == pytest.approx(truth.approach_speed_mps, rel=0.01)
    assert envelope.propeller_rate_rps == (ship.n_rps, ship.n_rps)  # the logs' constant rpm


def test_cli_fit_on_an_nmea_recording_says_to_convert_it(tmp_path: Path, capsys) -> None:
    nmea = tmp_path / "zigzag-10.nmea"
    nmea.write_text("$HEHDT,340.100,T*29\n$IIRSA,-7.960,A,,V*5C\n")
    out = tmp_path / "params.json"
    assert main(["fit", str(nmea), "-o", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"error: {nmea}:1: missing columns")
    assert err.endswith(
        "(an NMEA recording? convert it first: python -m identifier convert FILE -o DIR)\n"
    )
    assert not out.exists()


@pytest.mark.parametrize(
    ("x_nn", "x_un", "warned"),
    [
        (2.3e-5, -1.2e-3, False),  # a propeller: thrust at bollard, falling with speed
        (-6.5e-5, 1.1e-2, True),  # the HSVA 10/10 pair's kept estimate (benchmarks/hsva.md)
        (2.0e-6, 2.4e-3, True),  # thrust rising with speed at one rpm
        (0.0, -1.2e-3, True),  # no thrust at bollard
    ],
)
def test_a_thrust_that_is_not_a_propellers_is_warned_about(
    x_nn: float, x_un: float, warned: bool
) -> None:
    model = get_model("prime-rudder")
    theta = np.ones(model.n_coefficients)
    names = list(model.coefficient_names)
    theta[names.index("X_nn")], theta[names.index("X_un")] = x_nn, x_un
    params = ModelParameters.from_vector(model.name, theta, length_m=320.0)
    warning = thrust_warning(params)
    assert (warning is not None) == warned
    if warning is not None:
        assert f"X_nn = {x_nn:.3g}" in warning and "another rpm" in warning


def test_families_without_the_thrust_pair_are_not_judged() -> None:
    model = get_model("shi2009")
    params = ModelParameters.from_vector(model.name, np.zeros(model.n_coefficients), length_m=320.0)
    assert thrust_warning(params) is None
    assert centripetal_warning(params) is None  # a5·v·r is no prime family's X_vr


@pytest.mark.parametrize(
    ("x_vr", "warned"),
    [
        (1.85, False),  # the KVLCC2 MMG model's (m + m_y + X'_vr)/(m + m_x)
        (0.95, False),  # the Mariner's
        (0.0, True),
        (-20.1, True),  # the HSVA 10/10 pair fitted with a current (benchmarks/hsva.md)
    ],
)
def test_a_centripetal_surge_term_of_no_ships_sign_is_warned_about(
    x_vr: float, warned: bool
) -> None:
    model = get_model("prime-rudder-offset")
    theta = np.ones(model.n_coefficients)
    theta[list(model.coefficient_names).index("X_vr")] = x_vr
    warning = centripetal_warning(ModelParameters.from_vector(model.name, theta, length_m=7.0))
    assert (warning is not None) == warned
    if warning is not None:
        assert f"X_vr = {x_vr:.3g}" in warning and "--current none" in warning


_TWENTY_DEG = math.radians(20.0)


@pytest.mark.parametrize(
    ("weak", "turn_logged", "named"),
    [
        (("X_vr", "X_vv", "X_rr", "Y_rar"), False, "X_vr, X_vv, X_rr"),
        (("X_un", "X_rr"), False, "X_rr"),
        (("X_vr", "X_vv", "X_rr"), True, None),  # a turning log fixes them
        (("X_un", "Y_rar"), False, ""),  # the turn's surge is determined: extrapolated still
        (("a5",), False, ""),  # not a prime family's
    ],
)
def test_turns_extrapolated_from_zigzags_are_warned_about_with_the_surge_left_open(
    weak: tuple[str, ...], turn_logged: bool, named: str | None
) -> None:
    warning = turn_warning(weak, turn_logged=turn_logged, largest_rudder_rad=_TWENTY_DEG)
    if named is None:
        assert warning is None
        return
    assert warning is not None
    assert warning.startswith(
        "no log turns through 180 deg: the model's turning circles are extrapolated from a "
        f"rudder of at most 20.0 deg ({TURN_EXTRAPOLATION_EVIDENCE})"
    )
    assert warning.endswith("add a turning circle to the logs")
    surge = f"; the surge force of a hard turn ({named}) is not determined by these logs"
    assert (surge in warning) == bool(named)
    assert ("surge force" in warning) == bool(named)


def test_the_open_surge_terms_a_prior_holds_are_named() -> None:
    weak = ("X_vv", "X_rr", "Y_rar")
    warning = turn_warning(
        weak, turn_logged=False, largest_rudder_rad=_TWENTY_DEG, held=("X_vv", "X_rr", "Y_vav")
    )
    assert warning is not None
    assert "(X_vv, X_rr) is not determined" in warning
    assert "; X_vv, X_rr keep the family's prior (near zero, a ship's size);" in warning
    one = turn_warning(
        ("X_vr", "X_rr"), turn_logged=False, largest_rudder_rad=_TWENTY_DEG, held=("X_vv", "X_rr")
    )
    assert one is not None and "; X_rr keeps the family's prior" in one
    free = turn_warning(
        ("X_vr",), turn_logged=False, largest_rudder_rad=_TWENTY_DEG, held=("X_vv", "X_rr")
    )
    assert free is not None and "prior" not in free


_SURGE_SETTINGS = FitSettings(method="ekf", current="none")


@pytest.fixture(scope="module")
def kvlcc2_zigzag_and_turn() -> tuple[ManeuverLog, ManeuverLog]:
    ship = reference_ship("kvlcc2")
    zigzag, turn = (synthesize_log(ship, MANEUVERS[m]()) for m in ("zigzag-10", "turning-35"))
    return zigzag, turn


@pytest.fixture(scope="module")
def kvlcc2_zigzag_fit(
    kvlcc2_zigzag_and_turn: tuple[ManeuverLog, ManeuverLog],
) -> IdentificationResult:
    return identify([kvlcc2_zigzag_and_turn[0]], _SURGE_SETTINGS)


def test_zigzags_alone_leave_the_turns_surge_open_and_a_turning_log_does_not(
    kvlcc2_zigzag_and_turn: tuple[ManeuverLog, ManeuverLog],
    kvlcc2_zigzag_fit: IdentificationResult,
) -> None:
    """The default family fitted on a zig-zag alone is warned that its turns extrapolate
    from its rudder of 10° and the surge; with a turning circle beside it, not."""
    alone = [w for w in kvlcc2_zigzag_fit.warnings if "no log turns through 180 deg" in w]
    assert len(alone) == 1 and "X_vv, X_rr keep the family's prior" in alone[0]
    assert "extrapolated from a rudder of at most 10.0 deg" in alone[0]
    both = identify(list(kvlcc2_zigzag_and_turn), _SURGE_SETTINGS).warnings
    assert not any("no log turns" in w or "surge force of a hard turn" in w for w in both)


def test_turning_circles_alone_leave_the_response_to_a_reversal_open_and_a_zigzag_does_not(
    kvlcc2_zigzag_and_turn: tuple[ManeuverLog, ManeuverLog],
    kvlcc2_zigzag_fit: IdentificationResult,
) -> None:
    """The mirror of the surge warning: a fit of turns alone (here one 35° turn) is warned
    that a zig-zag's overshoots are not determined; a zig-zag's fit is not."""
    zigzag, turn = kvlcc2_zigzag_and_turn
    port = replace(turn, rudder_rad=-turn.rudder_rad, y_m=-turn.y_m, heading_rad=-turn.heading_rad)
    assert reversal_warning([zigzag]) is None and reversal_warning([turn, zigzag]) is None
    warning = reversal_warning([turn, port])  # both sides, each held: no reversal
    assert warning is not None and warning.startswith("no log reverses its rudder")
    assert warning.endswith("add a zig-zag to the logs")
    assert "turn to" not in warning  # both sides logged
    for one_side, logged, other in (([turn], "starboard", "port"), ([port], "port", "starboard")):
        warning = reversal_warning(one_side)
        assert warning is not None and warning.startswith("no log reverses its rudder")
        assert f"they turn to {logged} only: the {other} turn is extrapolated too" in warning
        assert warning.endswith(f"add a zig-zag and a turn to {other}")
    alone = identify([turn], _SURGE_SETTINGS)
    assert sum(w.startswith("no log reverses its rudder") for w in alone.warnings) == 1
    # One side's turn holds the family's asymmetry at 0: the other side its mirror.
    assert all(
        re.search(rf"[\[,]{c}=0[,\]]", alone.params.model) for c in ("dgamma", "dwake", "d0")
    )
    assert any(n.startswith("the logs turn to starboard only: dgamma, dwake, d0 held at 0")
               for n in alone.notes)  # fmt: skip
    assert not any("reverses its rudder" in w for w in kvlcc2_zigzag_fit.warnings)


def test_logs_of_one_side_hold_the_familys_asymmetry_at_zero(
    kvlcc2_zigzag_and_turn: tuple[ManeuverLog, ManeuverLog],
) -> None:
    """Turns to one side only cannot determine Δγ, dwake and δ₀ (searched, they put the
    other side's tactical diameter 2-76 % off on the reference ships): held at 0 unless
    the model name fixes them; logs turning both ways, or a model without them, keep it."""
    zigzag, turn = kvlcc2_zigzag_and_turn
    port = replace(turn, rudder_rad=-turn.rudder_rad, y_m=-turn.y_m, heading_rad=-turn.heading_rad)
    assert (logged_side([turn]), logged_side([port])) == ("starboard", "port")
    assert logged_side([turn, port]) is None and logged_side([zigzag]) is None
    # A helmsman's 8° to port for 5 s on the approach, and a compass spike of 30° to port
    # in the turn, do not turn the ship to port: the logs still turn to starboard only.
    approach = np.flatnonzero(turn.time_s < turn.time_s[0] + 5.0)
    helmed = turn.rudder_rad.copy()
    helmed[approach] = -math.radians(8.0)
    spiked = turn.heading_rad.copy()
    spiked[turn.n_samples // 2] -= math.radians(30.0)
    assert logged_side([replace(turn, rudder_rad=helmed, heading_rad=spiked)]) == "starboard"
    held = one_sided_model([turn], "prime-rudder-offset")
    assert held is not None and held[0] == "prime-rudder-offset[dgamma=0,dwake=0,d0=0]"
    assert held[1].startswith("the logs turn to starboard only: dgamma, dwake, d0 held at 0")
    given = one_sided_model([port], "prime-rudder-offset[l=-0.7,d0=0.01]")
    assert given is not None
    assert given[0] == "prime-rudder-offset[dgamma=0,l=-0.7,dwake=0,d0=0.01]"
    assert "the logs turn to port only: dgamma, dwake held at 0" in given[1]
    assert get_model(
        given[0].replace("[", "[k=0.001,gamma=0.5,").replace("dwake", "wake=0.3,dwake")
    )
    assert one_sided_model([turn, port], "prime-rudder-offset") is None
    assert one_sided_model([turn], "shi2009") is None
    assert one_sided_model([turn], "prime-rudder-offset[dgamma=0.1,dwake=0,d0=0]") is None


def test_the_surge_drag_prior_leaves_the_centripetal_term_to_a_zigzag(
    kvlcc2_zigzag_and_turn: tuple[ManeuverLog, ManeuverLog],
    kvlcc2_zigzag_fit: IdentificationResult,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Held to a ship's size, X_vv and X_rr leave X_vr to the zig-zag: determined, within
    2σ of the reference's (m + m_y + ½ρL²d·X′_vr)/(m + m_x); without the prior not one of
    the three is determined."""
    ship = kvlcc2("full")
    half_rho_L2_d = 0.5 * ship.water_density_kgpm3 * ship.length_m**2 * ship.draught_m
    m = ship.mass_kg
    centripetal = (m + half_rho_L2_d * (ship.m_y + ship.X_vr)) / (m + half_rho_L2_d * ship.m_x)
    report = {c.name: c for c in kvlcc2_zigzag_fit.coefficients}
    assert report["X_vr"].identifiable
    assert abs(report["X_vr"].value - centripetal) < 2.0 * report["X_vr"].std
    for name in SURGE_DRAG_TERMS:
        assert report[name].std <= SURGE_DRAG_PRIOR_X / SURGE_MASS

    free = replace(
        PRIME_RUDDER_OFFSET,
        name="test-free-surge-drag",
        surge=tuple(replace(t, prior_std=None) for t in PRIME_RUDDER_OFFSET.surge),
    )
    monkeypatch.setitem(variants._FAMILIES, free.name, free)
    fit = identify([kvlcc2_zigzag_and_turn[0]], replace(_SURGE_SETTINGS, model=free.name))
    assert {"X_vr", *SURGE_DRAG_TERMS} <= set(fit.not_identifiable)


@pytest.mark.parametrize(
    ("model", "refit"),
    [
        ("prime-rudder", "prime-rudder-thrust"),
        ("prime-rudder[dgamma=0, l=-0.6]", "prime-rudder-thrust[dgamma=0.0,l=-0.6]"),
        ("prime-rudder-offset", "prime-rudder-offset-thrust"),
        ("prime-rudder-offset[d0=0.02]", "prime-rudder-offset-thrust[d0=0.02]"),
        ("prime-crossflow", "prime-crossflow-thrust"),
        ("prime-crossflow[d0=0.01]", "prime-crossflow-thrust[d0=0.01]"),
        ("prime-rudder-lift", None),
        ("prime-crossflow-thrust", None),
        ("prime-rudder-thrust", None),
        ("prime-rudder-offset-thrust", None),
        ("shi2009", None),
    ],
)
def test_only_the_rudder_families_are_refitted_with_a_fixed_thrust_slope(
    model: str, refit: str | None
) -> None:
    """The constants the user fixed stay fixed in the refit, κ at its default."""
    assert fixed_thrust_model(model) == refit
    if refit is not None:
        family = model.split("[")[0]
        assert get_model(refit).name == get_model(model).name.replace(
            f"{family}[", f"{family}-thrust["
        ).replace("]", f",kappa={THRUST_SLOPE:g}]")
