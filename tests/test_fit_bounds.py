"""``identifier fit`` on implausible logs and settings: one line, exit 1 or 2, nothing written.

Each case once crashed with a traceback (ZeroDivisionError, OverflowError,
LinAlgError), printed RuntimeWarnings before its error, ran for ever, or wrote absurd
coefficients with exit 0. Now a data error is one ``error:`` line on stderr and exit 1,
a setting out of its stated range a usage error (exit 2), and nothing is written
(README, "Errors you may see" and "Plausibility bounds").
"""

from __future__ import annotations

import math
import re
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import identifier.cli.fit as fit_command
from fmu_model import ModelParameters
from identifier.cli import main
from identifier.identify import FitSettings, identify
from identifier.smoothing import smooth_track
from scenarios.synthesize import MANEUVERS, model_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, format_log, parse_log, read_log

RUDDER_RATE = math.radians(5.0)
HEADER = "time_s,x_m,y_m,heading_deg,rudder_deg,rpm"


@pytest.fixture(scope="module")
def zigzag_text() -> str:
    """A 1 Hz zig-zag 10/10 of the test ship (L = 100 m, 5 m/s), as file text."""
    truth = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    ship = model_ship(truth, rudder_rate_radps=RUDDER_RATE)
    return format_log(synthesize_log(ship, MANEUVERS["zigzag-10"](), seed=1))


def _header_index(lines: list[str]) -> int:
    return lines.index(HEADER)


def _rows(change: Callable[[list[str], int], list[str]]) -> Callable[[str], str]:
    """Apply ``change(cells, k)`` to every data row k (0-based) of a log's text."""

    def edit(text: str) -> str:
        lines = text.split("\n")
        first = _header_index(lines) + 1
        for i in range(first, len(lines)):
            if lines[i]:
                lines[i] = ",".join(change(lines[i].split(","), i - first))
        return "\n".join(lines)

    return edit


def _cell(row: int, column: str, value: str) -> Callable[[str], str]:
    index = HEADER.split(",").index(column)

    def change(cells: list[str], k: int) -> list[str]:
        if k == row:
            cells[index] = value
        return cells

    return _rows(change)


def _metadata(key: str, value: str) -> Callable[[str], str]:
    def edit(text: str) -> str:
        lines = [line for line in text.split("\n") if not line.startswith(f"# {key}:")]
        return "\n".join([f"# {key}: {value}", *lines])

    return edit


def _time(change: Callable[[float, int], float]) -> Callable[[str], str]:
    return _rows(lambda cells, k: [repr(change(float(cells[0]), k)), *cells[1:]])


def _line_of_row(text: str, row: int) -> int:
    """1-based line number of data row ``row`` (0-based)."""
    return _header_index(text.split("\n")) + 2 + row


def _fit(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], logs: list[Path], *options: str
) -> tuple[int, str, Path]:
    out = tmp_path / "params.json"
    capsys.readouterr()
    status = main(["fit", *map(str, logs), "-o", str(out), "--quiet", "--method", "ekf", *options])
    return status, capsys.readouterr().err, out


def _assert_one_data_error(status: int, err: str, out: Path, where: object, pattern: str) -> None:
    """Exit 1, one line ``error: <where><pattern>`` (``where``: a path or ""), no output."""
    assert status == 1, err
    assert err.count("\n") == 1, err
    prefix = f"error: {where}"
    assert err.startswith(prefix), err
    assert re.match(pattern, err.removeprefix(prefix).rstrip("\n")), err
    assert not out.exists()


def _write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


# --------------------------------------------------------------------------- data errors

ZERO_ROW = ["0", "0", "0", "0", "0"]


@pytest.mark.parametrize(
    "edit",
    [
        pytest.param(_rows(lambda cells, k: [cells[0], *ZERO_ROW]), id="all zero"),
        pytest.param(
            _rows(lambda cells, k: [cells[0], "10", "20", "30", "0", "0"]), id="stationary rpm 0"
        ),
    ],
)
def test_a_ship_that_does_not_move_is_a_data_error(
    zigzag_text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    edit: Callable[[str], str],
) -> None:
    log = _write(tmp_path, "still.csv", edit(zigzag_text))
    status, err, out = _fit(tmp_path, capsys, [log])  # the default, speed-scaled model
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        r": the ship does not move: its median speed over ground",
    )


def test_positions_in_kilometres_are_a_data_error_of_units(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """x_m and y_m in km: a ship of 100 m sailing 5 mm/s, a Froude number of 1.6e-4 (it
    used to pass as an approach that turns at r' 1.7, or as a model of that)."""
    km = _rows(lambda cells, k: [cells[0], *(repr(float(c) / 1000.0) for c in cells[1:3]),
                                 *cells[3:]])(zigzag_text)  # fmt: skip
    log = _write(tmp_path, "km.csv", km)
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        r": the ship sails at 0\.00[45]\d* m/s over ground in the median, a Froude number "
        r"U/sqrt\(gL\) of 0\.0001[56] for L = 100 m, expected at least 0\.01 on a trial: check "
        r"the units of x_m and y_m \(metres\), time_s \(seconds\) and the ship's length$",
    )


@pytest.mark.parametrize(
    ("column", "value", "expected"),
    [
        ("x_m", "1e308", r"a position within ±1e\+08 m"),
        ("y_m", "-2e8", r"a position within ±1e\+08 m"),
        ("heading_deg", "1e308", r"a heading within ±36000 deg \(100 turns\)"),
        ("time_s", "1e308", r"a time within ±1e\+10 s"),
        ("rudder_deg", "1e6", r"a rudder angle within ±90 deg"),
        ("rpm", "1e308", r"a propeller speed from 0 to 6000 rpm"),
        ("rpm", "-50", r"a propeller speed from 0 to 6000 rpm, got '-50' \(astern: .*\)"),
    ],
)
def test_an_implausible_cell_names_file_line_and_column(
    zigzag_text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    column: str,
    value: str,
    expected: str,
) -> None:
    row = 372 if column == "time_s" else 50  # the last row keeps time increasing
    log = _write(tmp_path, "trial.csv", _cell(row, column, value)(zigzag_text))
    line = _line_of_row(zigzag_text, row)
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        rf":{line}: column '{column}': expected {expected}",
    )


@pytest.mark.parametrize("value", ["1e308", "1e-300", "0.05", "1001"])
def test_a_ship_length_beyond_the_fmu_bounds_in_the_log_is_a_data_error(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], value: str
) -> None:
    log = _write(tmp_path, "trial.csv", _metadata("length_m", value)(zigzag_text))
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        rf":1: metadata 'length_m': expected a ship length from 0.1 to 1000 m, "
        rf"got '{value}'$",
    )


def test_a_log_without_a_ship_length_is_one_line_even_with_progress(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Found by a user's log without metadata: the progress bar printed its empty line
    twice before the error, which is found before any work."""
    text = "\n".join(line for line in zigzag_text.split("\n") if not line.startswith("#"))
    log = _write(tmp_path, "trial.csv", text)
    out = tmp_path / "params.json"
    capsys.readouterr()
    assert main(["fit", str(log), "-o", str(out), "--method", "ekf"]) == 1
    assert capsys.readouterr().err == (
        "error: no ship length: pass --length-m or add '# length_m:' to the logs\n"
    )
    assert not out.exists()


def test_an_error_after_the_progress_bar_starts_on_a_line_of_its_own(
    zigzag_text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A data error found during the fit (an EKF that diverges, say) follows the bar on
    the next line: with the bar shown late (tqdm's ``delay``) it came on the bar's line."""

    def failing(*_: object, progress: Callable[[int], None], stage: Callable[[str], None],
                **__: object) -> None:  # fmt: skip
        progress(100)
        stage("EKF on every sample")
        raise IdentificationError("sample 20: the EKF diverged", log="trial.csv")

    monkeypatch.setattr(fit_command, "identify", failing)
    log = _write(tmp_path, "trial.csv", zigzag_text)
    assert main(["fit", str(log), "-o", str(tmp_path / "params.json")]) == 1
    err = capsys.readouterr().err
    assert err.endswith("\nerror: trial.csv: sample 20: the EKF diverged\n"), err[-200:]


@pytest.mark.parametrize("length_m", [1e308, 1e-300, math.inf, math.nan, 0.0])
def test_identify_rejects_a_ship_length_beyond_the_fmu_bounds(
    zigzag_text: str, length_m: float
) -> None:
    with pytest.raises(IdentificationError, match=r"ship length must be from 0.1 to 1000 m"):
        identify([parse_log(zigzag_text)], length_m=length_m)


@pytest.mark.parametrize(
    ("jump_s", "expected"),
    [
        (1e7, r"expected no gap in time longer than the rest of the log \(.* s\), got 1e\+07 s "
         r"after .* s on line \d+: far longer than the manoeuvre; split the log there$"),
        (1e5, r"expected no gap .*, got 100001 s after .*; split the log there$"),
        (1e12, r"expected a time within ±1e\+10 s, got '1000000000100\.0'$"),
    ],
)  # fmt: skip
def test_a_time_jump_far_longer_than_the_manoeuvre_names_its_line(
    zigzag_text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    jump_s: float,
    expected: str,
) -> None:
    text = _time(lambda t, k: t + (jump_s if k >= 100 else 0.0))(zigzag_text)
    log = _write(tmp_path, "jump.csv", text)
    line = _line_of_row(zigzag_text, 100)
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(status, err, out, log, rf":{line}: column 'time_s': {expected}")


def test_the_smoother_bridges_gaps_shorter_than_the_rest_of_the_log() -> None:
    # Three 1-s bursts at 100 Hz, 10 000 s apart: the reader accepts it (no gap is longer
    # than the rest), and the local fits of the noise estimator across a gap have too
    # few distinct times; they once raised LinAlgError (singular matrix).
    rng = np.random.default_rng(0)
    burst = np.arange(100) * 0.01
    t = np.concatenate([burst, 1.0 + 1e4 + burst, 2.0 + 2e4 + burst])
    x = 5.0 * t + rng.normal(0.0, 1.0, t.size)
    y = rng.normal(0.0, 1.0, t.size)
    heading = 1e-3 * t + rng.normal(0.0, 2e-3, t.size)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        track = smooth_track(t, x, y, heading)
    assert track.position_noise_m == pytest.approx(1.0, rel=0.1)
    assert np.all(np.isfinite(track.speed_mps))


def test_a_track_faster_than_any_ship_is_a_data_error(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write(tmp_path, "ns.csv", _time(lambda t, k: t * 1e-9)(zigzag_text))
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        r": sample \d+: the track implies a speed over ground of .* m/s, expected "
        r"at most 50 m/s: check the units of time_s, x_m and y_m$",
    )


def test_a_track_without_rudder_is_refused(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    straight = _rows(lambda cells, k: [*cells[:4], "0", cells[5]])(zigzag_text)
    log = _write(tmp_path, "straight.csv", straight)
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        r": no rudder excitation: nothing to identify \(the rudder stays within "
        r"±0.5 deg in the log\); expected a manoeuvre: a zig-zag or a turning circle; the "
        r"ship turns at r' up to 0\.\d\d all the same: is rudder_deg in degrees, and its "
        r"sensor alive\?$",
    )


def test_logs_of_different_vessels_are_refused_naming_both(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _write(tmp_path, "a.csv", zigzag_text)
    second = _write(tmp_path, "b.csv", _metadata("vessel", "other ship")(zigzag_text))
    status, err, out = _fit(tmp_path, capsys, [first, second])
    _assert_one_data_error(
        status,
        err,
        out,
        "",
        rf"the logs are of different vessels: 'testship' \({re.escape(str(first))}\) and "
        rf"'other ship' \({re.escape(str(second))}\); identify one vessel at a time$",
    )


@pytest.mark.parametrize(
    ("name", "code"), [("red\x1b[31mship", "U+001B"), ("tab\tship", "U+0009"), ("a\x85b", "U+0085")]
)
def test_a_vessel_name_with_a_control_character_is_a_data_error(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, code: str
) -> None:
    log = _write(tmp_path, "trial.csv", _metadata("vessel", name)(zigzag_text))
    status, err, out = _fit(tmp_path, capsys, [log])
    _assert_one_data_error(
        status,
        err,
        out,
        log,
        rf":1: metadata 'vessel': contains a control character {re.escape(code)} at "
        r"character \d+; expected printable text$",
    )


@pytest.mark.parametrize("name", ["a\x1bb", "del\x7f", "\ufffe"])
def test_identify_rejects_an_unprintable_vessel_name_of_a_log_in_memory(
    zigzag_text: str, name: str
) -> None:
    log = parse_log(zigzag_text)
    named = ManeuverLog(
        log.time_s,
        log.x_m,
        log.y_m,
        log.heading_rad,
        log.rudder_rad,
        log.n_rps,
        metadata={**log.metadata, "vessel": name},
    )
    with pytest.raises(IdentificationError, match=r"vessel name .* contains (a|the) "):
        identify([named])


# --------------------------------------------------------------------------- settings

FIT_OPTIONS = [
    ("--length-m", "1e308", "expected a number from 0.1 to 1000 m"),
    ("--length-m", "1e-300", "expected a number from 0.1 to 1000 m"),
    ("--position-noise-m", "1e308", "expected a number from 1e-06 to 1000 m"),
    ("--position-noise-m", "0", "expected a number from 1e-06 to 1000 m"),
    ("--heading-noise-deg", "1e-300", "expected a number from 1e-06 to 90 deg"),
    ("--heading-noise-deg", "360", "expected a number from 1e-06 to 90 deg"),
    ("--param-random-walk", "1e300", "expected a number from 0 to 1"),
    ("--param-random-walk", "-1", "expected a number from 0 to 1"),
    ("--param-random-walk", "nan", "expected a number from 0 to 1"),
    ("--alpha", "1e308", "expected a number from 1e-12 to 1e\\+12"),
    ("--alpha", "0", "expected a number from 1e-12 to 1e\\+12"),
    ("--max-substep-s", "1e-9", "expected a number >= 0.001 s or inf"),
    ("--max-substep-s", "-inf", "expected a number >= 0.001 s or inf"),
]


@pytest.mark.parametrize(("option", "value", "expected"), FIT_OPTIONS)
def test_fit_options_out_of_their_range_are_usage_errors(
    zigzag_text: str,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    option: str,
    value: str,
    expected: str,
) -> None:
    log = _write(tmp_path, "trial.csv", zigzag_text)
    out = tmp_path / "params.json"
    capsys.readouterr()
    with pytest.raises(SystemExit) as info:
        main(["fit", str(log), "-o", str(out), "--quiet", "--initial", "zero", f"{option}={value}"])
    assert info.value.code == 2
    err = capsys.readouterr().err
    errors = [line for line in err.splitlines() if "error:" in line]
    assert errors == [err.splitlines()[-1]], err
    assert re.fullmatch(
        rf"python -m identifier fit: error: argument {option}: {expected}, got '{value}'", errors[0]
    ), errors[0]
    assert not out.exists()


@pytest.mark.parametrize("command", ["crossval", "convert"])
def test_other_commands_bound_the_ship_length_too(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str
) -> None:
    extra = ["--leave-one-out"] if command == "crossval" else ["-o", str(tmp_path / "out")]
    with pytest.raises(SystemExit) as info:
        main([command, "x.csv", *extra, "--length-m", "1e308"])
    assert info.value.code == 2
    assert "argument --length-m: expected a number from 0.1 to 1000 m, got '1e308'" in (
        capsys.readouterr().err
    )


@pytest.mark.parametrize(
    ("name", "shown"),
    [("red\x1b[31mship", r"contains a control character U\+001B at character 4"),
     ("bad\udcffbyte", r"contains a lone surrogate U\+DCFF at character 4")],
)  # fmt: skip
def test_convert_vessel_with_a_control_character_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str, shown: str
) -> None:
    with pytest.raises(SystemExit) as info:
        main(["convert", "rec.nmea", "-o", str(tmp_path / "out"), "--vessel", name])
    assert info.value.code == 2
    last = capsys.readouterr().err.splitlines()[-1]
    assert re.fullmatch(
        rf".*error: argument --vessel: {shown}; expected printable text, got .*", last
    )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "settings",
    [
        pytest.param(FitSettings(model="shi2009", param_random_walk=1e300), id="rho 1e300"),
        pytest.param(FitSettings(model="shi2009", initial="zero", alpha=1e308), id="alpha 1e308"),
    ],
)
def test_a_diverging_fit_raises_without_runtime_warnings(
    zigzag_text: str, settings: FitSettings
) -> None:
    # Settings the command line refuses, through the library: the EKF's divergence is
    # the error, and numpy's overflow warnings no longer come first.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(IdentificationError, match="EKF diverged"):
            identify([parse_log(zigzag_text, path="trial.csv")], settings)


def test_a_valid_fit_prints_nothing_but_its_result(
    zigzag_text: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    log = _write(tmp_path, "trial.csv", zigzag_text)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        # A tank test: still water (one zig-zag would warn that a current is barely told apart).
        status, err, out = _fit(tmp_path, capsys, [log], "--model", "shi2009", "--current", "none")
    assert status == 0
    assert read_log(log).n_samples == 373
    # What one zig-zag leaves open, and nothing else: its coefficients and a turn.
    left_open = ("warning: not identifiable", "warning: no log turns through 180 deg")
    assert [line.startswith(left_open) for line in err.splitlines()] == [True, True], err
    assert out.exists()


def test_a_time_stamp_a_hair_after_the_previous_is_a_data_error(zigzag_text: str) -> None:
    """1e-308 s between two samples (found by the property test): one line, no traceback."""
    log = parse_log(zigzag_text)
    time_s = log.time_s.copy()
    time_s[1] = time_s[0] + 1e-308
    bad = ManeuverLog(time_s, log.x_m, log.y_m, log.heading_rad, log.rudder_rad, log.n_rps)
    with pytest.raises(IdentificationError, match=r"samples 0 and 1 are 1e-308 s apart"):
        identify([bad], FitSettings(model="shi2009", method="ekf", current="none"), length_m=100.0)
