"""Hardening: corrupted trial logs and hand-edited params.json (issue 9, item 3).

Complements tests/test_logs.py (one known defect per test) with property-based
corruption of whole files: whatever is done to a valid log, :func:`read_log` either
raises :class:`LogFormatError` (one line, a line number in the file or None) or
returns exactly what the file says, checked against an independent minimal reading
of the same bytes; any other exception fails. And every corrupt params.json gives a
one-line :class:`ParamsFormatError` naming the file, and ``build_fmu.py`` exits 1
with one line on stderr and writes no FMU.
"""

from __future__ import annotations

import copy
import csv
import json
import os
import re
import subprocess
import sys
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from fmu_model import ModelParameters, ParamsFormatError, load_params
from tests.conftest import SEED_COEFFICIENTS
from trials.angles import UNWRAP_WINDOW
from trials.errors import LogFormatError
from trials.logs import LOG_COLUMNS, MIN_SAMPLES, ManeuverLog, format_log, read_log

REPO = Path(__file__).parent.parent
HYPOTHESIS = settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])

# --------------------------------------------------------------------------- valid logs


@st.composite
def valid_log_texts(draw: st.DrawFn) -> str:
    """The text of a valid log: metadata, header and 10-16 rows of varied numbers."""
    n = draw(st.integers(MIN_SAMPLES, MIN_SAMPLES + 6))
    # No step longer than all the others together: the reader refuses such a gap.
    steps = draw(
        st.lists(st.floats(0.01, 5.0), min_size=n - 1, max_size=n - 1).filter(
            lambda s: max(s) <= 0.9 * (sum(s) - max(s))  # a margin for the rounding
        )
    )
    time_s = draw(st.floats(-100.0, 100.0)) + np.concatenate([[0.0], np.cumsum(steps)])
    value = st.floats(-1e4, 1e4, allow_subnormal=False)
    columns = [draw(st.lists(value, min_size=n, max_size=n)) for _ in range(2)]
    heading = draw(st.floats(-10.0, 10.0)) + np.cumsum(
        draw(st.lists(st.floats(-3.0, 3.0), min_size=n, max_size=n))
    )
    rudder = draw(st.lists(st.floats(-0.6, 0.6), min_size=n, max_size=n))
    n_rps = draw(st.lists(st.floats(0.0, 3.0), min_size=n, max_size=n))
    metadata = {"vessel": "kvlcc2", "length_m": "320.0", "source": "hardening test"}
    x_m, y_m, rudder_rad, rps = (np.array(v) for v in (*columns, rudder, n_rps))
    log = ManeuverLog(time_s, x_m, y_m, heading, rudder_rad, rps, metadata)
    return format_log(log)


# --------------------------------------------------------------------------- corruptions

STRANGE_CELLS = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "Infinity",
    "1e308",
    "-1e308",
    "1e400",
    "-1e400",
    "1e-400",
    "",
    " ",
    "0x10",
    "1_000",
    "1,5",
    "1.5.2",
    "+.5",
    "5.",
    ".5",
    "1e5",
    "1E+2",
    "--1",
    "\u22125",  # unicode minus sign
    "\u0661\u0662",  # Arabic-Indic digits: float() accepts them, a log must not
    "\uff11\uff12",  # full-width digits
    "\u00a012\u00a0",  # no-break spaces around a number
    "\t12\t",
    "True",
    "None",
    '"12"',
    '"1,5"',
    "'12'",
    "12 m",
    "💥",
    "\ufeff12",
]


def _cells(line: str) -> list[str]:
    return line.split(",")


def _apply(text: str, operation: tuple[Any, ...]) -> str:
    """Apply one corruption to a log's text; indices wrap around the sizes."""
    kind, *args = operation
    lines = text.split("\n")
    # after earlier corruptions there may be no header or no row left: then any line
    header = next((i for i, line in enumerate(lines) if line and line[0] != "#"), 0)
    rows = range(header + 1, len(lines) - 1) or range(len(lines))  # last: "" after "\n"
    if kind == "truncate line":
        i, k = args[0] % len(lines), args[1]
        lines[i] = lines[i][: k % (len(lines[i]) + 1)]
    elif kind == "truncate file":
        return text[: args[0] % (len(text) + 1)]
    elif kind == "swap header columns":
        names = _cells(lines[header])
        a, b = args[0] % len(names), args[1] % len(names)
        names[a], names[b] = names[b], names[a]
        lines[header] = ",".join(names)
    elif kind == "strange cell":
        i = rows[args[0] % len(rows)]
        cells = _cells(lines[i])
        cells[args[1] % len(cells)] = args[2]
        lines[i] = ",".join(cells)
    elif kind == "insert text":
        i = args[0] % len(lines)
        k = args[1] % (len(lines[i]) + 1)
        lines[i] = lines[i][:k] + args[2] + lines[i][k:]
    elif kind == "separator":
        separator, where = args
        targets = {"header": [header], "row": [rows[0]], "all": range(len(lines))}[where]
        for i in targets:
            lines[i] = lines[i].replace(",", separator)
    elif kind == "pad cells with tabs":
        i = rows[args[0] % len(rows)]
        lines[i] = ",".join(f"\t {cell}\t" for cell in _cells(lines[i]))
    elif kind == "delete line":
        del lines[args[0] % len(lines)]
    elif kind == "duplicate line":
        i = args[0] % len(lines)
        lines.insert(i, lines[i])
    elif kind == "blank line":
        lines.insert(args[0] % (len(lines) + 1), "")
    elif kind == "crlf":
        return "\r\n".join(lines)
    elif kind == "bom":
        return "\ufeff" + text
    else:  # pragma: no cover - the strategy below lists every kind
        raise AssertionError(kind)
    return "\n".join(lines)


index = st.integers(0, 200)
garbage = st.text(min_size=1, max_size=8)  # any unicode, control characters included
operations = st.one_of(
    st.tuples(st.just("truncate line"), index, index),
    st.tuples(st.just("truncate file"), st.integers(0, 2000)),
    st.tuples(st.just("swap header columns"), index, index),
    st.tuples(st.just("strange cell"), index, index, st.sampled_from(STRANGE_CELLS)),
    st.tuples(st.just("insert text"), index, index, garbage),
    st.tuples(
        st.just("separator"),
        st.sampled_from([";", "\t", " ", "|"]),
        st.sampled_from(["header", "row", "all"]),
    ),
    st.tuples(st.just("pad cells with tabs"), index),
    st.tuples(st.just("delete line"), index),
    st.tuples(st.just("duplicate line"), index),
    st.tuples(st.just("blank line"), index),
    st.tuples(st.just("crlf")),
    st.tuples(st.just("bom")),
)


# --------------------------------------------------------------------------- the oracle


def _fields(line: str) -> list[str]:
    return next(csv.reader([line])) if '"' in line else line.split(",")


def _what_the_file_says(raw: bytes) -> tuple[dict[str, str], dict[str, np.ndarray]]:
    """Metadata and required columns of a file, read as plainly as possible.

    Only called after :func:`read_log` accepted the file, so it may assume the file
    is well-formed; any disagreement with the reader is a wrong silent result.
    """
    lines = [line.removesuffix("\r") for line in raw.decode("utf-8-sig").split("\n")]
    header = next(i for i, line in enumerate(lines) if line.strip() and line.strip()[0] != "#")
    metadata = {}
    for line in lines[:header]:
        match = re.fullmatch(r"#\s*([A-Za-z_][A-Za-z0-9_.\-]*)\s*:(.*)", line.strip())
        if match:
            metadata[match[1]] = match[2].strip()
    names = [name.strip() for name in _fields(lines[header])]
    rows = [_fields(line) for line in lines[header + 1 :] if line.strip()]
    columns = {
        column: np.array([float(row[names.index(column)].strip()) for row in rows])
        for column in LOG_COLUMNS
    }
    return metadata, columns


def _check_read(raw: bytes) -> None:
    """Read ``raw`` as a log file: a clean error or exactly what the file says."""
    with tempfile.TemporaryDirectory() as directory:
        path = os.path.join(directory, "trial.csv")
        with open(path, "wb") as file:
            file.write(raw)
        try:
            log = read_log(path)
        except LogFormatError as error:
            message = str(error)
            assert "\n" not in message and "\r" not in message, message
            assert message.startswith(path), message
            n_lines = raw.count(b"\n") + 1
            assert error.line is None or 1 <= error.line <= n_lines, (error.line, n_lines)
            assert error.column is None or error.column in LOG_COLUMNS
            assert error.expected
            event("LogFormatError" if error.line is None else "LogFormatError with a line")
            return
    event("read")
    metadata, says = _what_the_file_says(raw)
    assert dict(log.metadata) == metadata
    assert log.n_samples == len(says["time_s"])
    np.testing.assert_array_equal(log.time_s, says["time_s"])
    np.testing.assert_array_equal(log.x_m, says["x_m"])
    np.testing.assert_array_equal(log.y_m, says["y_m"])
    np.testing.assert_allclose(log.rudder_rad, np.deg2rad(says["rudder_deg"]), rtol=1e-15)
    np.testing.assert_allclose(log.n_rps, says["rpm"] / 60.0, rtol=1e-15)
    heading = np.deg2rad(says["heading_deg"])
    assert np.all(np.isfinite(log.heading_rad))
    if np.max(np.abs(says["heading_deg"])) < 1e9:  # beyond, 2π is below the float spacing
        scale = 1e-12 * max(1.0, float(np.max(np.abs(heading))))
        wrapped = np.angle(np.exp(1j * (log.heading_rad - heading)))
        np.testing.assert_allclose(wrapped, 0.0, atol=scale)
        # continuous: each sample within half a turn of the median of those before it
        for k in range(1, log.n_samples):
            before = log.heading_rad[max(0, k - UNWRAP_WINDOW) : k]
            assert abs(log.heading_rad[k] - np.median(before)) <= np.pi + scale


# --------------------------------------------------------------------------- log properties


@HYPOTHESIS
@given(text=valid_log_texts(), corruptions=st.lists(operations, min_size=1, max_size=3))
def test_corrupted_log_is_an_error_with_its_line_or_reads_what_it_says(
    text: str, corruptions: list[tuple[Any, ...]]
) -> None:
    for operation in corruptions:
        text = _apply(text, operation)
    _check_read(text.encode("utf-8"))


@HYPOTHESIS
@given(
    text=valid_log_texts(),
    flips=st.lists(st.tuples(st.integers(0, 10**6), st.integers(1, 255)), min_size=1, max_size=4),
)
def test_random_byte_flips_are_an_error_or_read_what_the_file_says(
    text: str, flips: list[tuple[int, int]]
) -> None:
    raw = bytearray(text.encode("utf-8"))
    for position, mask in flips:
        raw[position % len(raw)] ^= mask
    _check_read(bytes(raw))


@HYPOTHESIS
@given(
    text=valid_log_texts(),
    row=index,
    corruption=st.one_of(
        st.tuples(st.just("truncate"), index),
        st.tuples(st.just("cell"), st.integers(0, 5), st.sampled_from(STRANGE_CELLS)),
        st.tuples(st.just("insert"), index, garbage),
    ),
)
def test_a_corrupted_row_is_reported_on_its_line(
    text: str, row: int, corruption: tuple[Any, ...]
) -> None:
    lines = text.split("\n")
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    n_rows = len(lines) - header - 2
    i = header + 1 + row % n_rows  # 0-based index of the corrupted line
    kind, *args = corruption
    if kind == "truncate":
        lines[i] = lines[i][: args[0] % len(lines[i])]
    elif kind == "cell":
        cells = lines[i].split(",")
        cells[args[0]] = args[1]
        lines[i] = ",".join(cells)
    else:
        k = args[0] % (len(lines[i]) + 1)
        lines[i] = lines[i][:k] + args[1] + lines[i][k:]
    try:
        read_log_bytes("\n".join(lines).encode("utf-8"))
    except LogFormatError as error:
        # the bad line itself, or the next one when a changed time breaks the order
        # (and None when cutting the last row leaves too few rows)
        assert error.line in (i + 1, i + 2, None), (error.line, i + 1, str(error))
        assert "\n" not in str(error)
        if error.line is None:
            assert "data rows" in str(error)
    else:
        _check_read("\n".join(lines).encode("utf-8"))


def test_benign_changes_read_identically() -> None:
    """CRLF, a BOM, tabs around cells and trailing blank lines change nothing."""
    rows = [
        f"{0.5 * i},{4.0 * i},{-0.25 * i},{(355 + 3 * i) % 360},{5.0},{60.0}" for i in range(12)
    ]
    text = "# vessel: kvlcc2\n" + ",".join(LOG_COLUMNS) + "\n" + "\n".join(rows) + "\n"
    plain = read_log_bytes(text.encode())
    variants = [
        _apply(text, ("crlf",)),
        _apply(text, ("bom",)),
        _apply(_apply(text, ("pad cells with tabs", 3)), ("pad cells with tabs", 7)),
        text + "\n\n \n",
    ]
    for variant in variants:
        log = read_log_bytes(variant.encode())
        for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
            np.testing.assert_array_equal(getattr(log, name), getattr(plain, name))


def read_log_bytes(raw: bytes) -> ManeuverLog:
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "trial.csv"
        path.write_bytes(raw)
        return read_log(path)


# --------------------------------------------------------------------------- params.json


def _valid_document() -> dict[str, Any]:
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
        covariance=np.diag(np.linspace(1e-6, 1e-4, len(SEED_COEFFICIENTS))),
    )
    return params.to_json_dict()


def _edit(change: Callable[[dict[str, Any]], None]) -> Callable[[], bytes]:
    """A case built by editing the valid document (json.dumps writes NaN as NaN)."""

    def make() -> bytes:
        document = copy.deepcopy(_valid_document())
        change(document)
        return json.dumps(document, indent=2).encode()

    return make


def _text(change: Callable[[str], str]) -> Callable[[], bytes]:
    """A case built by editing the valid file's text."""

    def make() -> bytes:
        return change(json.dumps(_valid_document(), indent=2)).encode("utf-8")

    return make


def _set(path: str, value: Any) -> Callable[[dict[str, Any]], None]:
    def change(document: dict[str, Any]) -> None:
        *parents, key = path.split(".")
        target = document
        for parent in parents:
            target = target[parent]
        target[key] = value

    return change


def _delete(path: str) -> Callable[[dict[str, Any]], None]:
    def change(document: dict[str, Any]) -> None:
        *parents, key = path.split(".")
        target = document
        for parent in parents:
            target = target[parent]
        del target[key]

    return change


def _covariance(change: Callable[[list[list[Any]]], None]) -> Callable[[dict[str, Any]], None]:
    def edit(document: dict[str, Any]) -> None:
        change(document["covariance"])

    return edit


def _unsymmetric(matrix: list[list[Any]]) -> None:
    matrix[0][1] = 1e-5


def _negative_variance(matrix: list[list[Any]]) -> None:
    matrix[3][3] = -1e-6


def _nan_covariance(matrix: list[list[Any]]) -> None:
    matrix[2][2] = float("nan")


def _text_in_covariance(matrix: list[list[Any]]) -> None:
    matrix[1][1] = "small"


def _ragged_covariance(matrix: list[list[Any]]) -> None:
    matrix[5].pop()


def _three_by_three(document: dict[str, Any]) -> None:
    document["covariance"] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]


def _huge_variance(matrix: list[list[Any]]) -> None:
    matrix[4][4] = 10**400  # JSON integers have no size limit; no float holds this


# Integers of 400 digits: json.loads reads them (its limit is 4300 digits) and float()
# of them raises OverflowError, not ValueError.
HUGE = 10**400


# (id, content, message) — content is built lazily; message is a regex after "<file>: "
PARAMS_CASES: list[tuple[str, Callable[[], bytes], str]] = [
    ("wrong version", _edit(_set("version", 2)), r"unsupported version 2 \(this tool reads 1\)"),
    ("version as text", _edit(_set("version", "1")), r"unsupported version '1'"),
    ("no version", _edit(_delete("version")), r"unsupported version None"),
    ("wrong format", _edit(_set("format", "params")), r"not a params file \(format must be"),
    (
        "missing coefficient",
        _edit(_delete("coefficients.a3")),
        r"coefficients for model 'shi2009': missing \['a3'\], unexpected \[\]",
    ),
    (
        "unknown coefficient",
        _edit(_set("coefficients.a10", 1.0)),
        r"missing \[\], unexpected \['a10'\]",
    ),
    (
        "NaN coefficient",
        _edit(_set("coefficients.b1", float("nan"))),
        r"coefficient b1 must be a finite number, got nan",
    ),
    (
        "Infinity coefficient",
        _edit(_set("coefficients.c3", float("inf"))),
        r"coefficient c3 must be a finite number, got inf",
    ),
    (
        "overflowing coefficient",
        _text(lambda text: text.replace('"a5": 0.5', '"a5": 1e400')),
        r"coefficient a5 must be a finite number, got inf",
    ),
    (
        "coefficient as text",
        _edit(_set("coefficients.a1", "-0.004")),
        r"coefficient a1 must be a finite number, got '-0.004'",
    ),
    (
        "coefficient as bool",
        _edit(_set("coefficients.a2", True)),
        r"coefficient a2 must be a finite number, got True",
    ),
    (
        "coefficient null",
        _edit(_set("coefficients.a4", None)),
        r"coefficient a4 must be a finite number, got None",
    ),
    (
        "coefficients as list",
        _edit(_set("coefficients", [1.0, 2.0])),
        r"'coefficients' has the wrong type \(list\)",
    ),
    ("non-symmetric covariance", _edit(_covariance(_unsymmetric)), r"covariance is not symmetric"),
    (
        "negative variance",
        _edit(_covariance(_negative_variance)),
        r"covariance has a negative variance",
    ),
    (
        "NaN in covariance",
        _edit(_covariance(_nan_covariance)),
        r"covariance contains NaN or infinite values",
    ),
    (
        "text in covariance",
        _edit(_covariance(_text_in_covariance)),
        r"covariance must be a matrix of numbers",
    ),
    (
        "ragged covariance",
        _edit(_covariance(_ragged_covariance)),
        r"covariance must be a matrix of numbers",
    ),
    ("covariance 3x3", _edit(_three_by_three), r"covariance must be 16x16, got shape \(3, 3\)"),
    (
        "coefficient of 401 digits",
        _edit(_set("coefficients.a5", HUGE)),
        r"coefficient a5 must be a finite number, got an integer of 401 digits \(beyond the "
        r"floating-point range\)$",
    ),
    (
        "negative coefficient of 401 digits",
        _edit(_set("coefficients.c1", -HUGE)),
        r"coefficient c1 must be a finite number, got an integer of 401 digits",
    ),
    (
        "length of 401 digits",
        _edit(_set("vessel.length_m", HUGE)),
        r"vessel\.length_m must be a finite number, got an integer of 401 digits",
    ),
    (
        "nominal rpm of 401 digits",
        _edit(_set("nominal.rpm", HUGE)),
        r"nominal\.rpm must be a finite number, got an integer of 401 digits",
    ),
    (
        "covariance entry of 401 digits",
        _edit(_covariance(_huge_variance)),
        r"covariance\[4\]\[4\] must be a finite number, got an integer of 401 digits",
    ),
    (
        "escape sequence in the vessel name",
        _edit(_set("vessel.name", "tanker\x1b[31m")),
        r"vessel\.name contains a control character U\+001B at character 7; expected printable",
    ),
    (
        "lone surrogate in the vessel name",
        _edit(_set("vessel.name", "\ud800x")),  # written as the JSON escape \ud800
        r"vessel\.name contains a lone surrogate U\+D800 at character 1",
    ),
    (
        "NUL in the vessel name",
        _edit(_set("vessel.name", "ship\x00")),
        r"vessel\.name contains a control character U\+0000 at character 5",
    ),
    (
        "C1 control in the vessel name",
        _edit(_set("vessel.name", "NEL\x85")),
        r"vessel\.name contains a control character U\+0085",
    ),
    (
        "tab in the vessel name",
        _edit(_set("vessel.name", "MV\tOne")),
        r"vessel\.name contains a control character U\+0009 at character 3",
    ),
    (
        "non-character in the vessel name",
        _edit(_set("vessel.name", "ship\uffff")),
        r"vessel\.name contains the non-character U\+FFFF",
    ),
    (
        "vessel name as number",
        _edit(_set("vessel.name", 7)),
        r"vessel\.name must be a string, got int",
    ),
    ("unknown model", _edit(_set("model", "no-such-model")), r"no-such-model"),
    ("model as number", _edit(_set("model", 7)), r"'model' has the wrong type \(int\)"),
    ("vessel as text", _edit(_set("vessel", "testship")), r"'vessel' has the wrong type \(str\)"),
    (
        "negative length",
        _edit(_set("vessel.length_m", -100.0)),
        r"vessel\.length_m must be positive, got -100\.0",
    ),
    (
        "length as text",
        _edit(_set("vessel.length_m", "100 m")),
        r"vessel\.length_m must be a finite number, got '100 m'",
    ),
    (
        "rpm as text",
        _edit(_set("nominal.rpm", "120")),
        r"nominal\.rpm must be a finite number, got '120'",
    ),
    (
        "identification as list",
        _edit(_set("identification", [1])),
        r"'identification' must be an object",
    ),
    ("top-level list", lambda: b"[1, 2, 3]\n", r"expected a JSON object"),
    (
        "trailing comma",
        _text(lambda text: text.replace('"model": "shi2009"', '"model": "shi2009",,')),
        r"invalid JSON: ",
    ),
    ("truncated file", _text(lambda text: text[: len(text) // 2]), r"invalid JSON: "),
    ("empty file", lambda: b"", r"invalid JSON: Expecting value"),
    ("single quotes", _text(lambda text: text.replace('"', "'")), r"invalid JSON: "),
    (
        "not UTF-8",
        lambda: json.dumps(_valid_document()).replace("testship", "Tr\xf8ndelag").encode("latin-1"),
        r"cannot read: ",
    ),
    ("binary", lambda: bytes(range(256)) * 4, r"cannot read: |invalid JSON: "),
]

# Pathological JSON: json.loads raises other exceptions than JSONDecodeError for these;
# load_params must still give a ParamsFormatError.
PARAMS_DEFECTS: list[tuple[str, Callable[[], bytes], str]] = [
    ("deeply nested", lambda: b"[" * 100_000 + b"]" * 100_000, r"invalid JSON"),
    (
        "integer of 5000 digits",
        _text(lambda text: text.replace('"a5": 0.5', '"a5": 1' + "0" * 5000)),
        r".",
    ),
    ("version true", _edit(_set("version", True)), r"unsupported version True"),
]

# build_fmu.py runs as a subprocess (~0.6 s each): one case per kind of defect.
BUILD_FMU_CASES = [
    "wrong version",
    "missing coefficient",
    "NaN coefficient",
    "non-symmetric covariance",
    "trailing comma",
    "truncated file",
    "coefficient as text",
    "coefficient of 401 digits",
    "escape sequence in the vessel name",
]


def _write_case(directory: Path, name: str, make: Callable[[], bytes]) -> Path:
    path = directory / (re.sub(r"\W+", "_", name) + ".json")
    path.write_bytes(make())
    return path


def test_the_valid_document_loads(tmp_path: Path) -> None:
    path = tmp_path / "params.json"
    path.write_text(json.dumps(_valid_document()))
    assert load_params(path).vessel_name == "testship"


@pytest.mark.parametrize(
    ("make", "message"), [pytest.param(*case[1:], id=case[0]) for case in PARAMS_CASES]
)
def test_corrupt_params_json_is_a_one_line_error_naming_the_file(
    tmp_path: Path, make: Callable[[], bytes], message: str
) -> None:
    path = tmp_path / "params.json"
    path.write_bytes(make())
    with pytest.raises(ParamsFormatError) as info:
        load_params(path)
    text = str(info.value)
    assert text.startswith(f"{path}:"), text
    assert re.search(message, text), text
    assert "\n" not in text and "\r" not in text


@pytest.mark.parametrize(
    ("make", "message"),
    [pytest.param(*case[1:], id=case[0]) for case in PARAMS_DEFECTS],
)
def test_pathological_params_json_is_an_error(
    tmp_path: Path, make: Callable[[], bytes], message: str
) -> None:
    path = tmp_path / "params.json"
    path.write_bytes(make())
    with pytest.raises(ParamsFormatError, match=message):
        load_params(path)


@pytest.fixture(scope="module")
def build_fmu_runs(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Any]]:
    """Run ``build_fmu.py`` on every BUILD_FMU_CASES file, all processes at once."""
    directory = tmp_path_factory.mktemp("params")
    cases = {name: make for name, make, _ in PARAMS_CASES}
    runs = {}
    for name in BUILD_FMU_CASES:
        params = _write_case(directory, name, cases[name])
        output = directory / f"out_{params.stem}" / "ship.fmu"
        process = subprocess.Popen(
            [sys.executable, "build_fmu.py", "--params", str(params), "-o", str(output)],
            cwd=REPO,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        runs[name] = (params, output, process)
    results = {}
    for name, (params, output, process) in runs.items():
        stdout, stderr = process.communicate(timeout=120)
        results[name] = (params, output, process.returncode, stdout, stderr)
    yield results


@pytest.mark.parametrize("name", BUILD_FMU_CASES)
def test_build_fmu_rejects_corrupt_params_with_one_line(
    build_fmu_runs: dict[str, Any], name: str
) -> None:
    params, output, status, stdout, stderr = build_fmu_runs[name]
    message = next(case[2] for case in PARAMS_CASES if case[0] == name)
    assert status == 1, stderr
    assert stdout == ""
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith(f"build_fmu.py: error: {params}:"), lines[0]
    assert re.search(message, lines[0]), lines[0]
    assert not output.exists()
    assert not output.parent.exists() or list(output.parent.iterdir()) == []


@pytest.mark.parametrize(
    ("output", "reason"),
    [
        pytest.param("taken/ship.fmu", "Not a directory", id="directory is a file"),
        pytest.param(
            "/proc/ship.fmu",
            "No such file or directory",
            id="temporary file cannot be created",
            marks=pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="Linux /proc"),
        ),
    ],
)
def test_build_fmu_write_error_names_the_output_not_a_temporary_file(
    tmp_path: Path, output: str, reason: str
) -> None:
    params = tmp_path / "params.json"
    params.write_text(json.dumps(_valid_document()))
    (tmp_path / "taken").write_text("a file")
    done = subprocess.run(
        [sys.executable, str(REPO / "build_fmu.py"), "--params", str(params), "-o", output],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 1
    assert done.stdout == ""
    assert done.stderr == f"build_fmu.py: error: {output}: cannot write: {reason}\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["params.json", "taken"]


VALID_NAMES = ["Ålesund ø", "東京丸", "ship 🚢", "KVLCC2 (1:45.7)", "Zero\u200dWidth Joiner"]


@pytest.mark.parametrize("name", VALID_NAMES)
def test_printable_unicode_vessel_names_load(tmp_path: Path, name: str) -> None:
    path = tmp_path / "params.json"
    document = _valid_document()
    document["vessel"]["name"] = name
    path.write_text(json.dumps(document))
    assert load_params(path).vessel_name == name
