"""Command lines under random numbers: an answer or one error line, never a traceback.

Every numeric input of the command lines gets random text: finite and non-finite
doubles (±1e±308, subnormals, nan, inf, -0.0), huge integers, empty and malformed
words. The trial-log columns and ``# length_m:`` given to ``python -m identifier fit``
and its numeric options; the columns of a lat/lon CSV and the numeric options of
``python -m identifier convert``; the trial-log columns and ``--length-m`` of ``python -m
identifier split``; the numbers of a params.json and ``--max-step-s`` of
``build_fmu.py``; ``--max-error-pct`` of ``python -m scenarios validate`` and
``--speed-mps``, ``--rpm`` of ``turning-circle`` (validate has neither). Whatever the
input, the command either exits 0 (3: a failed gate) and writes its output, or exits
1 (data error) or 2 (usage error) with one error line on stderr (after argparse's
usage for a usage error) and writes nothing; it never raises, and it answers within
:data:`ANSWER_S` seconds of CPU time and :data:`MEMORY_BYTES` more memory (an input that asks for
more, e.g. a resampling grid of 1e12 points, fails the test rather than the machine).

The commands run in this process (``main([...])``), with the stderr of the file
descriptor captured (the FMU and dask may write there too).
"""

from __future__ import annotations

import json
import math
import resource
import signal
import tempfile
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np
import psutil
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from hypothesis.control import currently_in_test_context

import build_fmu
from fmu_model import ModelParameters
from fmu_model.export_native import build_native_fmu
from identifier import cli as identifier_cli
from scenarios import cli as scenarios_cli
from scenarios.synthesize import MANEUVERS, model_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials.logs import ON_BOARD_KEYS, format_log

# Most CPU time a command may take on one example [s]: more is a hang (a loop), reported
# as a failure rather than stalling the suite. CPU, not wall-clock, time: a machine busy
# with other jobs slows a command down without making it hang.
ANSWER_S = 20.0
# Most address space a command may add on one example [bytes]: more raises MemoryError
# (a failure) instead of having the machine's OOM killer end the test process.
MEMORY_BYTES = 2 * 1024**3


def _examples(n: int) -> settings:
    return settings(
        max_examples=n,
        deadline=None,
        suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    )


# ------------------------------------------------------------------ random numbers

# Words that have broken number parsers before: non-finite and extreme doubles,
# integers beyond a double (and beyond Python's int-to-text limit), what float()
# accepts besides plain decimals (whitespace, underscores, other scripts' digits),
# and what it does not.
SPECIAL_WORDS = (
    "",
    " ",
    "nan",
    "-nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "-Infinity",
    "1e309",
    "-1e309",
    "0",
    "-0",
    "-0.0",
    "1e308",
    "-1e308",
    "1.7976931348623157e308",
    "1e-308",
    "-1e-308",
    "5e-324",
    "1e-400",
    "1" + "0" * 400,
    "-" + "9" * 400,
    "9" * 5000,
    " 7 ",
    "1_0",
    "\u0663",  # ARABIC-INDIC DIGIT THREE: float() reads 3.0
    "1e",
    "0x10",
    "1,5",
    "abc",
)


def numbers(low: float, high: float) -> st.SearchStrategy[str]:
    """Random number words: the special ones, any double, huge integers, plausible values.

    ``low`` and ``high`` bound the plausible values, so that valid inputs run too.
    """
    return st.one_of(
        st.sampled_from(SPECIAL_WORDS),
        st.floats().map(repr),
        st.integers(min_value=-(10**400), max_value=10**400).map(str),
        st.floats(low, high).map(repr),
        st.floats(low, high).map(repr),
    )


# ------------------------------------------------------------------ running a CLI


class Hang(Exception):
    """A command did not answer within ANSWER_S seconds of CPU time."""


@contextmanager
def _bounded(seconds: float, memory_bytes: int) -> Iterator[None]:
    """Raise Hang after ``seconds`` of CPU time (ITIMER_PROF: the process's user and
    system time), MemoryError beyond ``memory_bytes`` more (RLIMIT_AS)."""

    def expire(signum: int, frame: FrameType | None) -> None:
        raise Hang(f"no answer within {seconds:g} s of CPU time")

    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    limit = psutil.Process().memory_info().vms + memory_bytes
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    previous = signal.signal(signal.SIGPROF, expire)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    signal.setitimer(signal.ITIMER_PROF, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_PROF, 0.0)
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))
        signal.signal(signal.SIGPROF, previous)


def test_the_watchdog_counts_cpu_time_not_waiting() -> None:
    """A busy machine makes a command wait, not hang: only CPU time counts."""
    with _bounded(0.2, MEMORY_BYTES):
        time.sleep(0.5)  # waiting costs no CPU time
    with pytest.raises(Hang), _bounded(0.2, MEMORY_BYTES):
        while True:  # a loop does
            pass


def _run(
    main: Callable[[Sequence[str]], int], argv: list[str], capfd: pytest.CaptureFixture[str]
) -> tuple[int, str, str]:
    """Exit status, stdout and stderr of ``main(argv)``; any exception propagates."""
    capfd.readouterr()
    try:
        with _bounded(ANSWER_S, MEMORY_BYTES):
            status = main(argv)
    except SystemExit as exc:  # argparse: usage error, or --help
        status = exc.code if isinstance(exc.code, int) else 1
    out, err = capfd.readouterr()
    return status, out, err


def _files(directory: Path) -> set[Path]:
    return {p for p in directory.rglob("*") if p.is_file()}


def _check(
    status: int,
    err: str,
    *,
    inputs: set[Path],
    directory: Path,
    written: Callable[[], bool],
    ok: tuple[int, ...] = (0,),
) -> None:
    """The contract: ``ok`` and the output written, or 1/2, one error line, nothing written."""
    if currently_in_test_context():  # also called by the plain regression tests below
        event(f"exit {status}")
    assert "Traceback" not in err, err
    lines = err.strip("\n").splitlines()
    if status in ok:
        assert written(), f"exit {status} without its output"
        assert all(line.startswith(("warning:", "note:")) for line in lines), err
        return
    assert status in (1, 2), f"exit {status}: {err}"
    assert lines, f"exit {status} without a message"
    assert "error" in lines[-1], err
    if len(lines) > 1:  # argparse: usage first, then one error line
        assert status == 2 and lines[0].startswith("usage:"), err
        assert not any(": error:" in line for line in lines[:-1]), err
    assert _files(directory) == inputs, f"exit {status} but wrote {_files(directory) - inputs}"


@contextmanager
def _input_file(name: str, text: str) -> Iterator[tuple[Path, Path]]:
    """A temporary directory holding one input file ``name`` of ``text``: (directory, file)."""
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        path = directory / name
        path.write_text(text, encoding="utf-8")
        yield directory, path


# -------------------------------------------------------------- python -m identifier

LOG_COLUMNS = ("time_s", "x_m", "y_m", "heading_deg", "rudder_deg", "rpm")
# Plausible ranges of each column (and of # length_m), so that valid logs come up too.
LOG_RANGES = {
    "time_s": (0.0, 100.0),
    "x_m": (-100.0, 400.0),
    "y_m": (-100.0, 100.0),
    "heading_deg": (-30.0, 30.0),
    "rudder_deg": (-35.0, 35.0),
    "rpm": (0.0, 200.0),
    "length_m": (1.0, 400.0),
}
FIT_OPTIONS = {
    "--length-m": (0.5, 500.0),
    "--position-noise-m": (0.01, 10.0),
    "--heading-noise-deg": (0.01, 5.0),
    "--param-random-walk": (1e-6, 1e-2),
    "--alpha": (1e-3, 1e3),
    "--max-substep-s": (0.01, 2.0),
}
N_ROWS = 60  # 10 s approach, then the first rudder step of a 10/10 zig-zag, at 1 Hz


def _seed_params() -> ModelParameters:
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )


@pytest.fixture(scope="module")
def log_lines() -> list[str]:
    """A short trial log of the seed ship: metadata lines, header, N_ROWS rows."""
    ship = model_ship(_seed_params(), rudder_rate_radps=math.radians(5.0))
    text = format_log(synthesize_log(ship, MANEUVERS["zigzag-10"](), seed=0, approach_s=10.0))
    lines = text.splitlines()
    header = lines.index(",".join(LOG_COLUMNS))
    return lines[: header + 1 + N_ROWS]


@pytest.fixture(scope="module")
def warm(log_lines: list[str]) -> None:
    """One fit outside the time limit: numba compiles the EKF on first use (~10-40 s)."""
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "trial.csv"
        log.write_text("\n".join(log_lines) + "\n", encoding="utf-8")
        argv = ["fit", str(log), "--model", "shi2009", "--method", "ekf", "--quiet"]
        argv += ["-o", f"{tmp}/params.json"]
        assert identifier_cli.main(argv) == 0


@st.composite
def log_edits(draw: st.DrawFn) -> tuple[str, int, str]:
    """(field, row, word): a column and a row (or length_m, row -1) and its new text."""
    field = draw(st.sampled_from((*LOG_COLUMNS, "length_m")))
    row = -1 if field == "length_m" else draw(st.integers(0, N_ROWS - 1))
    return field, row, draw(numbers(*LOG_RANGES[field]))


def _edited_log(lines: list[str], field: str, row: int, word: str) -> str:
    lines = list(lines)
    if field == "length_m":
        index = next(i for i, line in enumerate(lines) if line.startswith("# length_m:"))
        lines[index] = f"# length_m: {word}"
    else:
        index = lines.index(",".join(LOG_COLUMNS)) + 1 + row
        cells = lines[index].split(",")
        cells[LOG_COLUMNS.index(field)] = word
        lines[index] = ",".join(cells)
    return "\n".join(lines) + "\n"


def _fit(
    log_text: str, options: list[str], capfd: pytest.CaptureFixture[str]
) -> tuple[int, str, str, Path, Path]:
    with _input_file("trial.csv", log_text) as (directory, log):
        output = directory / "out" / "params.json"
        argv = [
            "fit",
            str(log),
            "--model",
            "shi2009",
            "--method",
            "ekf",
            "--quiet",
            "-o",
            str(output),
        ]
        argv += options
        status, out, err = _run(identifier_cli.main, argv, capfd)
        _check(status, err, inputs={log}, directory=directory, written=output.is_file)
        if status == 0:
            json.loads(output.read_text(encoding="utf-8"))  # a whole document
    return status, out, err, log, output


@_examples(40)
@given(edit=log_edits())
def test_fit_any_number_in_the_log(
    edit: tuple[str, int, str], log_lines: list[str], warm: None, capfd: pytest.CaptureFixture[str]
) -> None:
    _fit(_edited_log(log_lines, *edit), [], capfd)


@_examples(12)
@given(key=st.sampled_from(sorted(ON_BOARD_KEYS)), data=st.data())
def test_fit_any_number_as_a_position_on_board(
    key: str,
    data: st.DataObject,
    log_lines: list[str],
    warm: None,
    capfd: pytest.CaptureFixture[str],
) -> None:
    """The GNSS antenna's (or a speed log's) place in the metadata: any number."""
    word = data.draw(numbers(-200.0, 200.0), label="value")
    _fit("\n".join([f"# {key}: {word}", *log_lines]) + "\n", [], capfd)


@_examples(30)
@given(option=st.sampled_from(sorted(FIT_OPTIONS)), data=st.data())
def test_fit_any_number_in_its_options(
    option: str,
    data: st.DataObject,
    log_lines: list[str],
    warm: None,
    capfd: pytest.CaptureFixture[str],
) -> None:
    word = data.draw(numbers(*FIT_OPTIONS[option]), label="value")
    extra = ["--initial", "zero"] if option == "--alpha" else []  # alpha is of the zero start
    _fit("\n".join(log_lines) + "\n", [f"{option}={word}", *extra], capfd)


def _split(log_text: str, options: list[str], capfd: pytest.CaptureFixture[str]) -> None:
    with _input_file("trial.csv", log_text) as (directory, log):
        out = directory / "out"
        argv = ["split", str(log), "--quiet", "-o", str(out), *options]
        status, _, err = _run(identifier_cli.main, argv, capfd)
        _check(status, err, inputs={log}, directory=directory, written=out.is_dir)


@_examples(30)
@given(edit=log_edits())
def test_split_any_number_in_the_log(
    edit: tuple[str, int, str], log_lines: list[str], capfd: pytest.CaptureFixture[str]
) -> None:
    _split(_edited_log(log_lines, *edit), [], capfd)


@_examples(12)
@given(word=numbers(0.5, 500.0))
def test_split_any_length(
    word: str, log_lines: list[str], capfd: pytest.CaptureFixture[str]
) -> None:
    _split("\n".join(log_lines) + "\n", [f"--length-m={word}"], capfd)


LATLON_COLUMNS = ("time_s", "lat_deg", "lon_deg", "heading_deg", "rudder_deg", "rpm")
LATLON_RANGES = {
    "time_s": (0.0, 40.0),
    "lat_deg": (-89.0, 89.0),
    "lon_deg": (-179.0, 179.0),
    "heading_deg": (0.0, 360.0),
    "rudder_deg": (-35.0, 35.0),
    "rpm": (0.0, 200.0),
}
CONVERT_OPTIONS = {
    "--rate-hz": (0.1, 20.0),
    "--length-m": (0.5, 500.0),
    "--gnss-x-m": (-200.0, 200.0),
    "--gnss-y-m": (-30.0, 30.0),
    "--speed-log-x-m": (-200.0, 200.0),
    "--rpm": (0.0, 200.0),  # beside the recording's rpm column: a data error
}
N_FIXES = 30


def _latlon_lines() -> list[str]:
    """A 1 Hz lat/lon recording off Trondheim, turning slowly to starboard."""
    lines = [",".join(LATLON_COLUMNS)]
    for i in range(N_FIXES):
        lat = 63.43 + 2e-5 * i
        lon = 10.3951 + 2e-5 * i * math.sin(i / 10.0)
        lines.append(
            f"{i:.1f},{lat:.9f},{lon:.9f},{340.0 + 0.5 * i:.3f},{-8.0 + 0.3 * i:.3f},"
            f"{60.0 + 0.1 * i:.2f}"
        )
    return lines


def _convert(csv_text: str, options: list[str], capfd: pytest.CaptureFixture[str]) -> None:
    with _input_file("recording.csv", csv_text) as (directory, recording):
        out = directory / "out"
        argv = ["convert", str(recording), "--quiet", "-o", str(out / "trial.csv"), *options]
        status, _, err = _run(identifier_cli.main, argv, capfd)
        _check(
            status,
            err,
            inputs={recording},
            directory=directory,
            written=lambda: any(out.glob("trial*.csv")),
        )


@_examples(30)
@given(
    column=st.sampled_from(LATLON_COLUMNS),
    row=st.integers(0, N_FIXES - 1),
    data=st.data(),
)
def test_convert_any_number_in_a_latlon_csv(
    column: str, row: int, data: st.DataObject, capfd: pytest.CaptureFixture[str]
) -> None:
    word = data.draw(numbers(*LATLON_RANGES[column]), label="value")
    lines = _latlon_lines()
    cells = lines[1 + row].split(",")
    cells[LATLON_COLUMNS.index(column)] = word
    lines[1 + row] = ",".join(cells)
    _convert("\n".join(lines) + "\n", [], capfd)


@_examples(25)
@given(option=st.sampled_from(sorted(CONVERT_OPTIONS)), data=st.data())
def test_convert_any_number_in_its_options(
    option: str, data: st.DataObject, capfd: pytest.CaptureFixture[str]
) -> None:
    word = data.draw(numbers(*CONVERT_OPTIONS[option]), label="value")
    _convert("\n".join(_latlon_lines()) + "\n", [f"{option}={word}"], capfd)


@pytest.mark.parametrize(
    ("cell", "options"),
    [
        (("time_s", 0, "-1e308"), []),  # every later time rounds to the same double
        (None, ["--rate-hz=1e308"]),
        (None, ["--rate-hz=1e300"]),
        (None, ["--rate-hz=1e9"]),
        (None, ["--rate-hz=1e5"]),  # 2.9 million rows: written, slowly
    ],
    ids=["time-1e308-first", "rate-1e308", "rate-1e300", "rate-1e9", "rate-1e5"],
)
def test_convert_inputs_found_by_the_properties(
    cell: tuple[str, int, str] | None, options: list[str], capfd: pytest.CaptureFixture[str]
) -> None:
    lines = _latlon_lines()
    if cell is not None:
        column, row, word = cell
        cells = lines[1 + row].split(",")
        cells[LATLON_COLUMNS.index(column)] = word
        lines[1 + row] = ",".join(cells)
    _convert("\n".join(lines) + "\n", options, capfd)


# --------------------------------------------------------------------- build_fmu.py

PLACEHOLDER = '"@NUMBER@"'


@st.composite
def params_edits(draw: st.DrawFn) -> tuple[tuple[Any, ...], bool, str]:
    """(where, both, word): a number of params.json, whether a covariance entry's
    mirror gets it too, and its new JSON text."""
    names = tuple(SEED_COEFFICIENTS)
    where = draw(
        st.one_of(
            st.sampled_from(names).map(lambda name: ("coefficients", name)),
            st.sampled_from((("vessel", "length_m"), ("nominal", "speed_mps"))),
            st.just(("nominal", "rpm")),
            st.tuples(st.just("covariance"), st.integers(0, len(names) - 1), st.integers(0, 15)),
        )
    )
    both = draw(st.booleans())
    ranges = {"length_m": (1.0, 900.0), "speed_mps": (0.1, 20.0), "rpm": (0.0, 300.0)}
    low, high = ranges.get(str(where[-1]), (-1.0, 1.0))
    return where, both, draw(numbers(low, high))


def _params_text(where: tuple[Any, ...], both: bool, word: str) -> str:
    params = _seed_params()
    theta = params.to_vector()
    doc = params.with_vector(theta, np.diag((0.01 * theta) ** 2 + 1e-12)).to_json_dict()
    if where[0] == "covariance":
        i, j = where[1], where[2]
        doc["covariance"][i][j] = PLACEHOLDER
        if both:
            doc["covariance"][j][i] = PLACEHOLDER
    else:
        doc[where[0]][where[1]] = PLACEHOLDER
    # The word goes in as JSON text: 1e309, NaN, Infinity, a 5000-digit integer, junk.
    return json.dumps(doc, indent=1).replace(json.dumps(PLACEHOLDER), word or '""')


def _build(params_text: str, options: list[str], capfd: pytest.CaptureFixture[str]) -> None:
    with _input_file("params.json", params_text) as (directory, params):
        fmu = directory / "out" / "ship.fmu"
        argv = ["--params", str(params), "-o", str(fmu), *options]
        status, _, err = _run(build_fmu.main, argv, capfd)
        _check(status, err, inputs={params}, directory=directory, written=fmu.is_file)


@_examples(25)
@given(edit=params_edits())
def test_build_fmu_any_number_in_params_json(
    edit: tuple[tuple[Any, ...], bool, str], capfd: pytest.CaptureFixture[str]
) -> None:
    _build(_params_text(*edit), [], capfd)


@_examples(10)
@given(word=numbers(1e-4, 1.0))
def test_build_fmu_any_max_step(word: str, capfd: pytest.CaptureFixture[str]) -> None:
    _build(_params_text(("nominal", "rpm"), False, "120.0"), [f"--max-step-s={word}"], capfd)


# -------------------------------------------------------------- python -m scenarios


@pytest.fixture(scope="module")
def fmu(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A native FMU of the seed ship (L = 100 m, 5 m/s, 120 rpm)."""
    return build_native_fmu(_seed_params(), tmp_path_factory.mktemp("fmu") / "testship.fmu")


@_examples(8)
@given(word=numbers(0.0, 200.0))
def test_validate_any_error_gate(word: str, fmu: Path, capfd: pytest.CaptureFixture[str]) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        report = directory / "report"
        argv = ["validate", "--fmu", str(fmu), "--report", str(report), "--quiet"]
        argv += ["--dt-s", "1", f"--max-error-pct={word}"]  # coarse steps: a cheap run
        status, _, err = _run(scenarios_cli.main, argv, capfd)
        if status == 3:  # the gate failed: its verdict is the one line
            assert len(err.strip("\n").splitlines()) == 1 and "FAIL" in err, err
            err = ""
        _check(
            status,
            err,
            inputs=set(),
            directory=directory,
            written=(report / "report.md").is_file,
            ok=(0, 3),
        )


@_examples(30)
@given(option=st.sampled_from(("--speed-mps", "--rpm")), data=st.data())
def test_turning_circle_any_speed_and_rpm(
    option: str, data: st.DataObject, fmu: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    low, high = (0.5, 15.0) if option == "--speed-mps" else (0.0, 300.0)
    word = data.draw(numbers(low, high), label="value")
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        out = directory / "turn.json"
        argv = ["turning-circle", "--fmu", str(fmu), "--quiet", "--dt-s", "0.5"]
        argv += ["--json", str(out), f"{option}={word}"]
        status, _, err = _run(scenarios_cli.main, argv, capfd)
        _check(status, err, inputs=set(), directory=directory, written=out.is_file)
