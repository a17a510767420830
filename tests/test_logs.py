"""Trial-log reading, validation and writing (trials.logs, .errors, .atomic)."""

from __future__ import annotations

import os
import pickle
import re
import tempfile
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import fmu_model.atomic
from fmu_model.atomic import write_atomic
from trials.errors import IdentificationError, LogFormatError
from trials.logs import (
    LOG_COLUMNS,
    MAX_DROPOUT_S,
    MAX_POSITION_M,
    MIN_SAMPLES,
    OPTIONAL_COLUMNS,
    ManeuverLog,
    format_log,
    parse_log,
    read_log,
    write_log,
)

HEADER = ",".join(LOG_COLUMNS)
METADATA = ["# vessel: kvlcc2", "# length_m: 320.0", "# source: test fixture"]
HEADER_LINE = len(METADATA) + 1  # 1-based line number of the header in _valid_lines()
N_ROWS = 12


def _row_line(row: int) -> int:
    """1-based file line of data row ``row`` (0-based) in _valid_lines()."""
    return HEADER_LINE + 1 + row


def _valid_lines(n_rows: int = N_ROWS) -> list[str]:
    """A valid log: a port-to-starboard heading wrap (355 -> 6 deg), 0.5 s sampling."""
    rows = [f"{0.5 * i},{4.0 * i},{0.25 * i},{(355 + i) % 360},{5.0},{60.0}" for i in range(n_rows)]
    return [*METADATA, HEADER, *rows]


def _text(lines: list[str]) -> str:
    return "\n".join(lines) + "\n"


def _with_cell(row: int, column: str, value: str) -> str:
    lines = _valid_lines()
    fields = lines[_row_line(row) - 1].split(",")
    fields[LOG_COLUMNS.index(column)] = value
    lines[_row_line(row) - 1] = ",".join(fields)
    return _text(lines)


def _with_line(line: int, new: str | None) -> str:
    """Replace (or with None delete) 1-based ``line`` of the valid log."""
    lines = _valid_lines()
    if new is None:
        del lines[line - 1]
    else:
        lines[line - 1] = new
    return _text(lines)


def _inserted(line: int, new: str) -> str:
    """Insert ``new`` so that it becomes 1-based ``line``."""
    lines = _valid_lines()
    lines.insert(line - 1, new)
    return _text(lines)


def _without_columns(*columns: str) -> str:
    keep = [i for i, name in enumerate(LOG_COLUMNS) if name not in columns]
    lines = _valid_lines()
    for index in range(HEADER_LINE - 1, len(lines)):
        fields = lines[index].split(",")
        lines[index] = ",".join(fields[i] for i in keep)
    return _text(lines)


def _write(tmp_path: Path, content: str | bytes, name: str = "trial.csv") -> Path:
    path = tmp_path / name
    if isinstance(content, str):
        path.write_bytes(content.encode("utf-8"))
    else:
        path.write_bytes(content)
    return path


def _example_log(n: int = 15, **metadata: str) -> ManeuverLog:
    t = np.linspace(0.0, 7.0, n) ** 1.3  # irregular sampling
    return ManeuverLog(
        time_s=t,
        x_m=7.7 * t + 0.1,
        y_m=0.03 * t**2,
        heading_rad=0.9 * t - 1.0,  # passes through 0 and 2π: continuous, never wrapped
        rudder_rad=np.deg2rad(35.0) * np.sin(t),
        n_rps=np.full(n, 1.6),
        metadata=metadata or {"vessel": "kvlcc2", "length_m": "320.0", "source": "unit test"},
    )


def _with_optional_columns(n_rows: int = N_ROWS) -> list[str]:
    """_valid_lines() with the optional columns appended (wind, the two axes of a log)."""
    lines = _valid_lines(n_rows)
    lines[HEADER_LINE - 1] += "," + ",".join(OPTIONAL_COLUMNS)
    for row in range(n_rows):
        lines[_row_line(row) - 1] += (
            f",{10.0 + row},{350.0 + 2.0 * row},{7.5 - 0.25 * row},{-0.5 + 0.125 * row}"
        )
    return lines


def _with_optional_cell(row: int, column: str, value: str) -> str:
    lines = _with_optional_columns()
    fields = lines[_row_line(row) - 1].split(",")
    fields[(*LOG_COLUMNS, *OPTIONAL_COLUMNS).index(column)] = value
    lines[_row_line(row) - 1] = ",".join(fields)
    return _text(lines)


def _without_optional_cells(rows: range | list[int], column: str) -> str:
    """_with_optional_columns() with ``column`` empty in ``rows``: its sensor's dropout."""
    lines = _with_optional_columns()
    for row in rows:
        fields = lines[_row_line(row) - 1].split(",")
        fields[(*LOG_COLUMNS, *OPTIONAL_COLUMNS).index(column)] = ""
        lines[_row_line(row) - 1] = ",".join(fields)
    return _text(lines)


# --------------------------------------------------------------------------- reading


def test_read_valid_log_converts_units_and_unwraps_heading(tmp_path: Path) -> None:
    log = read_log(_write(tmp_path, _text(_valid_lines())))

    assert log.n_samples == N_ROWS
    assert log.path == str(tmp_path / "trial.csv")
    assert dict(log.metadata) == {"vessel": "kvlcc2", "length_m": "320.0", "source": "test fixture"}
    assert log.length_m == 320.0
    np.testing.assert_array_equal(log.time_s, 0.5 * np.arange(N_ROWS))
    np.testing.assert_array_equal(log.x_m, 4.0 * np.arange(N_ROWS))
    np.testing.assert_array_equal(log.y_m, 0.25 * np.arange(N_ROWS))
    # 355, 356, ..., 359, 0, 1, ... deg in the file -> 355 ... 366 deg, continuous
    np.testing.assert_allclose(log.heading_rad, np.deg2rad(355.0 + np.arange(N_ROWS)), rtol=1e-14)
    np.testing.assert_allclose(log.rudder_rad, np.deg2rad(5.0), rtol=1e-15)
    np.testing.assert_allclose(log.n_rps, 1.0, rtol=1e-15)  # 60 rpm = 1 rev/s
    for array in (log.time_s, log.x_m, log.heading_rad, log.rudder_rad, log.n_rps):
        assert array.dtype == np.float64


def test_heading_wrapping_to_port_and_continuous_headings() -> None:
    port = [2.0, 1.0, 0.0, 359.0, 358.0, 357.0, 356.0, 355.0, 354.0, 353.0]
    many_turns = [700.0 + 20.0 * i for i in range(10)]  # continuous, beyond 360
    for headings, expected in ((port, 2.0 - np.arange(10)), (many_turns, many_turns)):
        lines = [HEADER] + [f"{i},0,0,{h},0,0" for i, h in enumerate(headings)]
        log = parse_log(_text(lines))
        np.testing.assert_allclose(log.heading_rad, np.deg2rad(expected), rtol=1e-14, atol=1e-15)


def test_read_accepts_bom_crlf_and_blank_trailing_lines(tmp_path: Path) -> None:
    plain = read_log(_write(tmp_path, _text(_valid_lines()), "plain.csv"))
    windows = "\ufeff" + "\r\n".join(_valid_lines()) + "\r\n\r\n  \r\n\n"
    log = read_log(_write(tmp_path, windows, "windows.csv"))

    assert dict(log.metadata) == dict(plain.metadata)
    for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(plain, name))


def test_read_accepts_columns_in_any_order_extra_columns_and_spaces() -> None:
    plain = parse_log(_text(_valid_lines()))
    order = ["rpm", "comment", "heading_deg", "time_s", "rudder_deg", "y_m", "x_m", "speed_kn"]
    lines = [" " + " , ".join(order)]
    for row in _valid_lines()[HEADER_LINE:]:
        values = dict(zip(LOG_COLUMNS, row.split(","), strict=True))
        values.update(comment="nan or text: not checked", speed_kn="")
        lines.append(", ".join(values[name] for name in order))

    log = parse_log(_text(lines))

    for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(plain, name))
    assert dict(log.metadata) == {}
    assert log.length_m is None
    assert log.path is None


def test_metadata_lines_and_free_comments() -> None:
    lines = [
        "",
        "# Trial 7, calm water",  # free comment: no 'key:' form
        "#vessel:kvlcc2",
        "#   operator :  A. N. Other  ",
        "# 12:30 start",  # a key cannot start with a digit: free comment
        "# note: see http://example.org/a:b",
        "# source:",
        "",
        *_valid_lines()[HEADER_LINE - 1 :],
    ]
    log = parse_log(_text(lines))
    assert dict(log.metadata) == {
        "vessel": "kvlcc2",
        "operator": "A. N. Other",
        "note": "see http://example.org/a:b",
        "source": "",
    }


def test_quoted_header_and_cells_are_read() -> None:
    lines = ['"time_s","x_m",y_m,heading_deg,rudder_deg,"rpm"']
    lines += [f'{i},"{i}.5",0,0,0,60' for i in range(MIN_SAMPLES)]
    log = parse_log(_text(lines))
    np.testing.assert_array_equal(log.x_m, np.arange(MIN_SAMPLES) + 0.5)


def test_optional_columns_are_read_when_present_and_none_when_absent() -> None:
    plain = parse_log(_text(_valid_lines()))
    assert (plain.wind_speed_mps, plain.wind_angle_rad, plain.stw_mps) == (None, None, None)
    assert plain.stw_transverse_mps is None

    log = parse_log(_text(_with_optional_columns()))
    rows = np.arange(N_ROWS)
    for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(plain, name))
    assert log.wind_speed_mps is not None
    assert log.wind_angle_rad is not None
    assert log.stw_mps is not None
    np.testing.assert_array_equal(log.wind_speed_mps, 10.0 + rows)
    # 350, 352, ... 372 deg: read as it is, not wrapped nor unwrapped
    np.testing.assert_allclose(log.wind_angle_rad, np.deg2rad(350.0 + 2.0 * rows), rtol=1e-15)
    np.testing.assert_array_equal(log.stw_mps, 7.5 - 0.25 * rows)
    assert log.stw_transverse_mps is not None
    np.testing.assert_array_equal(log.stw_transverse_mps, -0.5 + 0.125 * rows)
    assert parse_log(format_log(log)).stw_transverse_mps is not None  # written back
    for array in (log.wind_speed_mps, log.wind_angle_rad, log.stw_mps, log.stw_transverse_mps):
        assert array.dtype == np.float64
        assert not array.flags.writeable


def test_a_sensors_dropout_in_an_optional_column_is_interpolated_and_counted() -> None:
    """Empty or NaN cells of an optional column (up to 5 s) are its sensor's dropout:
    filled linearly in time, the wind angle the shorter way round through North, the
    nearest value at the ends; the required columns and the other cells as logged."""
    full = parse_log(_text(_with_optional_columns()))
    assert dict(full.filled) == {}
    lines = _with_optional_columns()
    for row, column, cell in ((3, "stw_mps", " "), (4, "stw_mps", "NaN"),
                              (5, "wind_angle_deg", ""), (0, "wind_speed_mps", "nan"),
                              (N_ROWS - 1, "stw_transverse_mps", "")):  # fmt: skip
        fields = lines[_row_line(row) - 1].split(",")
        fields[(*LOG_COLUMNS, *OPTIONAL_COLUMNS).index(column)] = cell
        lines[_row_line(row) - 1] = ",".join(fields)
    after = lines[_row_line(6) - 1].split(",")
    after[(*LOG_COLUMNS, *OPTIONAL_COLUMNS).index("wind_angle_deg")] = "2.0"  # 362 deg wrapped
    lines[_row_line(6) - 1] = ",".join(after)
    log = parse_log(_text(lines))
    assert dict(log.filled) == {
        "wind_speed_mps": 1, "wind_angle_deg": 1, "stw_mps": 2, "stw_transverse_mps": 1
    }  # fmt: skip
    assert log.stw_mps is not None and full.stw_mps is not None
    np.testing.assert_allclose(log.stw_mps, full.stw_mps, rtol=1e-15)  # a straight line
    assert log.wind_angle_rad is not None and full.wind_angle_rad is not None
    # 358 and 2 deg around the gap: 0 deg, not 180 (halfway the long way round)
    assert np.degrees(log.wind_angle_rad[5]) == pytest.approx(0.0, abs=1e-12)
    np.testing.assert_array_equal(
        np.delete(log.wind_angle_rad, [5, 6]), np.delete(full.wind_angle_rad, [5, 6])
    )
    assert log.wind_speed_mps is not None and log.wind_speed_mps[0] == 11.0  # the nearest
    assert log.stw_transverse_mps is not None
    assert log.stw_transverse_mps[-1] == log.stw_transverse_mps[-2]
    for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_array_equal(getattr(log, name), getattr(full, name))
    # A required column's empty cell is still an error (BAD_LOGS' "empty cell").
    required = r"column 'x_m': expected a finite number, got an empty field$"
    with pytest.raises(LogFormatError, match=required):
        parse_log(_text(_with_optional_columns()).replace("\n0.5,4.0,", "\n0.5,,", 1))


def test_replace_shares_the_unchanged_columns_and_copies_what_a_caller_can_write() -> None:
    """A changed copy of a long log costs only its changed columns; nothing is aliased."""
    log = parse_log(_text(_valid_lines()))
    moved = replace(log, x_m=log.x_m + 1.0)
    assert moved.rudder_rad is log.rudder_rad  # read-only, shared
    assert moved.x_m is not log.x_m and not moved.x_m.flags.writeable
    np.testing.assert_array_equal(moved.x_m, log.x_m + 1.0)
    writable = np.array(log.y_m)
    again = replace(log, y_m=writable)
    writable[0] = 1e6  # the caller's array changes, the log does not
    assert again.y_m[0] == log.y_m[0]
    view = writable[:]
    view.setflags(write=False)  # read-only, but a view of a writable array: copied
    assert replace(log, y_m=view).y_m is not view


def test_one_optional_column_alone_in_any_place() -> None:
    lines = _valid_lines()
    lines[HEADER_LINE - 1] = "stw_mps," + lines[HEADER_LINE - 1]
    for row in range(N_ROWS):
        lines[_row_line(row) - 1] = f"{6.0 + row}," + lines[_row_line(row) - 1]
    log = parse_log(_text(lines))
    assert log.wind_speed_mps is None
    assert log.wind_angle_rad is None
    assert log.stw_mps is not None
    np.testing.assert_array_equal(log.stw_mps, 6.0 + np.arange(N_ROWS))
    assert format_log(log).split("\n")[len(METADATA)] == HEADER + ",stw_mps"


def test_exactly_min_samples_rows_is_enough() -> None:
    assert parse_log(_text(_valid_lines(MIN_SAMPLES))).n_samples == MIN_SAMPLES


# --------------------------------------------------------------------------- bad logs

BAD_LOGS: list[tuple[str, Callable[[], str], int | None, str | None, str]] = [
    (
        "text in a number column",
        lambda: _with_cell(3, "rudder_deg", "abc"),
        _row_line(3),
        "rudder_deg",
        r"column 'rudder_deg': expected a finite number, got 'abc'$",
    ),
    (
        "nan",
        lambda: _with_cell(2, "x_m", "nan"),
        _row_line(2),
        "x_m",
        r"column 'x_m': expected a finite number, got 'nan'$",
    ),
    (
        "NaN upper case",
        lambda: _with_cell(0, "y_m", "NaN"),
        _row_line(0),
        "y_m",
        r"column 'y_m': expected a finite number, got 'NaN'$",
    ),
    (
        "inf",
        lambda: _with_cell(5, "heading_deg", "-inf"),
        _row_line(5),
        "heading_deg",
        r"column 'heading_deg': expected a finite number, got '-inf'$",
    ),
    (
        "overflow",
        lambda: _with_cell(4, "rpm", "1e999"),
        _row_line(4),
        "rpm",
        r"column 'rpm': expected a finite number, got '1e999' \(beyond the floating-point range\)$",
    ),
    (
        "empty cell",
        lambda: _with_cell(6, "time_s", " "),
        _row_line(6),
        "time_s",
        r"column 'time_s': expected a finite number, got an empty field$",
    ),
    (
        "python-only number syntax",
        lambda: _with_cell(1, "x_m", "1_000"),
        _row_line(1),
        "x_m",
        r"column 'x_m': expected a finite number, got '1_000'$",
    ),
    (
        "decimal comma in a quoted cell",
        lambda: _with_cell(1, "x_m", '"4,5"'),
        _row_line(1),
        "x_m",
        r"column 'x_m': expected a finite number, got '4,5'$",
    ),
    (
        "duplicate time",
        lambda: _with_cell(5, "time_s", "2.0"),  # row 4 is at 2.0 s
        _row_line(5),
        "time_s",
        rf"column 'time_s': expected strictly increasing time, got the same time 2\.0 as "
        rf"line {_row_line(4)}$",
    ),
    (
        "decreasing time",
        lambda: _with_cell(7, "time_s", "1.25"),  # row 6 is at 3.0 s
        _row_line(7),
        "time_s",
        rf"column 'time_s': expected strictly increasing time, got 1\.25 after 3\.0 on "
        rf"line {_row_line(6)}$",
    ),
    (
        "too many fields",
        lambda: _with_line(_row_line(2), "1.0,8.0,0.5,357,5.0,60.0,9"),
        _row_line(2),
        None,
        rf"expected 6 fields separated by ',' as in the header on line {HEADER_LINE}, got 7$",
    ),
    (
        "too few fields",
        lambda: _with_line(_row_line(9), "4.5,36.0"),
        _row_line(9),
        None,
        rf"expected 6 fields separated by ',' as in the header on line {HEADER_LINE}, got 2$",
    ),
    (
        "semicolon row",
        lambda: _with_line(_row_line(1), "0.5;4.0;0.25;356;5.0;60.0"),
        _row_line(1),
        None,
        rf"expected 6 fields separated by ',' as in the header on line {HEADER_LINE}, got 1 "
        r"\(only ',' is accepted as the field separator\)$",
    ),
    (
        "unterminated quote",
        lambda: _with_line(_row_line(1), '0.5,"4.0,0.25,356,5.0,60.0'),
        _row_line(1),
        None,
        r"expected 6 fields separated by ',', got malformed quoting",
    ),
    (
        "missing column",
        lambda: _without_columns("rudder_deg"),
        HEADER_LINE,
        None,
        r"missing column 'rudder_deg'; expected a header with time_s, x_m, y_m, heading_deg, "
        r"rudder_deg, rpm \(in any order\), got 'time_s,x_m,y_m,heading_deg,rpm'$",
    ),
    (
        "missing columns",
        lambda: _without_columns("time_s", "rpm"),
        HEADER_LINE,
        None,
        r"missing columns 'time_s', 'rpm'; expected a header with",
    ),
    (
        "column with another unit",
        lambda: _with_line(HEADER_LINE, HEADER.replace("heading_deg", "heading_rad")),
        HEADER_LINE,
        None,
        r"missing column 'heading_deg'; .* got 'time_s,x_m,y_m,heading_rad,rudder_deg,rpm'$",
    ),
    (
        "semicolon separator",
        lambda: _text(METADATA + [line.replace(",", ";") for line in _valid_lines()[3:]]),
        HEADER_LINE,
        None,
        r"expected ',' as the field separator, got ';' \(header "
        r"'time_s;x_m;y_m;heading_deg;rudder_deg;rpm'; expected "
        r"'time_s,x_m,y_m,heading_deg,rudder_deg,rpm'\)$",
    ),
    (
        "tab separator",
        lambda: _with_line(HEADER_LINE, HEADER.replace(",", "\t")),
        HEADER_LINE,
        None,
        r"expected ',' as the field separator, got a tab",
    ),
    (
        "duplicate column",
        lambda: _with_line(HEADER_LINE, HEADER + ",x_m"),
        HEADER_LINE,
        "x_m",
        r"column 'x_m': expected each column once, got 'x_m' in fields 2, 7$",
    ),
    (
        "duplicate optional column",
        lambda: _with_line(HEADER_LINE, HEADER + ",stw_mps,stw_mps"),
        HEADER_LINE,
        "stw_mps",
        r"column 'stw_mps': expected each column once, got 'stw_mps' in fields 7, 8$",
    ),
    (
        "text in the wind speed column",
        lambda: _with_optional_cell(3, "wind_speed_mps", "calm"),
        _row_line(3),
        "wind_speed_mps",
        r"column 'wind_speed_mps': expected a finite number, got 'calm'$",
    ),
    (
        "wind angle's sensor out for the whole log",
        lambda: _without_optional_cells(range(N_ROWS), "wind_angle_deg"),
        _row_line(0),
        "wind_angle_deg",
        r"column 'wind_angle_deg': expected a finite number, got no value \(empty or NaN\): "
        r"wind_angle_deg's sensor drops out for the whole log \(lines 5 to 16\); a dropout "
        r"of at most 5 s is interpolated$",
    ),
    (
        "speed log out for longer than 5 s",
        lambda: _without_optional_cells(range(1, 11), "stw_mps"),
        _row_line(1),
        "stw_mps",
        r"column 'stw_mps': expected a finite number, got no value \(empty or NaN\): "
        r"stw_mps's sensor "
        r"drops out for 5\.5 s \(lines 6 to 15\); a dropout of at most 5 s is interpolated$",
    ),
    (
        "inf speed through the water",
        lambda: _with_optional_cell(11, "stw_mps", "inf"),
        _row_line(11),
        "stw_mps",
        r"column 'stw_mps': expected a finite number, got 'inf'$",
    ),
    (
        "negative wind speed",
        lambda: _with_optional_cell(2, "wind_speed_mps", "-0.5"),
        _row_line(2),
        "wind_speed_mps",
        r"column 'wind_speed_mps': expected a wind speed from 0 to 100 m/s, got '-0\.5'$",
    ),
    (
        "wind speed beyond the bound",
        lambda: _with_optional_cell(2, "wind_speed_mps", "100.5"),
        _row_line(2),
        "wind_speed_mps",
        r"column 'wind_speed_mps': expected a wind speed from 0 to 100 m/s, got '100\.5'$",
    ),
    (
        "wind angle beyond the bound",
        lambda: _with_optional_cell(5, "wind_angle_deg", "-36000.1"),
        _row_line(5),
        "wind_angle_deg",
        r"column 'wind_angle_deg': expected a wind angle within ±36000 deg \(100 turns\), "
        r"got '-36000\.1'$",
    ),
    (
        "negative speed through the water",
        lambda: _with_optional_cell(4, "stw_mps", "-1e-9"),
        _row_line(4),
        "stw_mps",
        r"column 'stw_mps': expected a speed through the water from 0 to 50 m/s, got '-1e-9'$",
    ),
    (
        "speed through the water beyond the bound",
        lambda: _with_optional_cell(4, "stw_mps", "51"),
        _row_line(4),
        "stw_mps",
        r"column 'stw_mps': expected a speed through the water from 0 to 50 m/s, got '51'$",
    ),
    (
        "transverse speed through the water beyond the bound",
        lambda: _with_optional_cell(4, "stw_transverse_mps", "-50.5"),
        _row_line(4),
        "stw_transverse_mps",
        r"column 'stw_transverse_mps': expected a transverse speed through the water within "
        r"±50 m/s, got '-50\.5'$",
    ),
    (
        "transverse speed through the water without the longitudinal",
        lambda: _with_line(HEADER_LINE, HEADER + ",stw_transverse_mps"),
        HEADER_LINE,
        "stw_transverse_mps",
        r"column 'stw_transverse_mps': expected 'stw_mps' beside it \(the two axes of one speed "
        r"log\), got no stw_mps column$",
    ),
    (
        "no header",
        lambda: _with_line(HEADER_LINE, None),
        HEADER_LINE,
        None,
        r"expected a header line like 'time_s,x_m,y_m,heading_deg,rudder_deg,rpm', got a data "
        r"row '0\.0,0\.0,0\.0,355,5\.0,60\.0'$",
    ),
    (
        "length_m not a number",
        lambda: _with_line(2, "# length_m: abc"),
        2,
        None,
        r"metadata 'length_m': expected a positive finite number of metres, got 'abc'$",
    ),
    (
        "speed_log_x_m not a number",
        lambda: _with_line(2, "# speed_log_x_m: bow"),
        2,
        None,
        r"metadata 'speed_log_x_m': expected the speed log's position forward of midship "
        r"within ±500 m, got 'bow'$",
    ),
    (
        "time_origin_utc not a time",
        lambda: _with_line(3, "# time_origin_utc: yesterday noon"),
        3,
        None,
        r"metadata 'time_origin_utc': expected an ISO 8601 UTC time such as "
        r"2024-05-17T23:58:30\.000Z, got 'yesterday noon'$",
    ),
    (
        "time_origin_utc without its offset",
        lambda: _with_line(3, "# time_origin_utc: 2024-05-17T23:58:30"),
        3,
        None,
        r"metadata 'time_origin_utc': expected an ISO 8601 UTC time such as "
        r"2024-05-17T23:58:30\.000Z, got '2024-05-17T23:58:30'$",
    ),
    (
        "length_m with a unit",
        lambda: _with_line(2, "# length_m: 320 m"),
        2,
        None,
        r"metadata 'length_m': expected a positive finite number of metres, got '320 m'$",
    ),
    (
        "length_m zero",
        lambda: _with_line(2, "# length_m: 0"),
        2,
        None,
        r"metadata 'length_m': expected a positive finite number of metres, got '0'$",
    ),
    (
        "length_m empty",
        lambda: _with_line(2, "# length_m:"),
        2,
        None,
        r"metadata 'length_m': expected a positive finite number of metres, got ''$",
    ),
    (
        "duplicate metadata key",
        lambda: _with_line(3, "# vessel: other"),
        3,
        None,
        r"expected each metadata key once, got 'vessel' again \(first on line 1\)$",
    ),
    (
        "comment after the header",
        lambda: _inserted(_row_line(4), "# a late comment"),
        _row_line(4),
        None,
        rf"expected a data row, got a comment line \(comments are allowed only before the "
        rf"header on line {HEADER_LINE}\)$",
    ),
    (
        "blank line inside the data",
        lambda: _inserted(_row_line(4), ""),
        _row_line(4),
        None,
        r"expected a data row, got a blank line \(blank lines are allowed only at the end of "
        r"the file\)$",
    ),
    (
        "old Mac line endings",
        lambda: "\r".join(_valid_lines()),
        1,
        None,
        r"expected LF or CRLF line endings, got a bare carriage return \(CR\)$",
    ),
    (
        "fewer than MIN_SAMPLES rows",
        lambda: _text(_valid_lines(MIN_SAMPLES - 1)),
        None,
        None,
        rf"expected at least {MIN_SAMPLES} data rows after the header on line {HEADER_LINE}, "
        rf"got {MIN_SAMPLES - 1}$",
    ),
    (
        "header only",
        lambda: _text(_valid_lines(0)),
        None,
        None,
        rf"expected at least {MIN_SAMPLES} data rows after the header on line {HEADER_LINE}, "
        r"got 0$",
    ),
    (
        "empty file",
        lambda: "",
        None,
        None,
        r"empty file; expected a header line like 'time_s,x_m,y_m,heading_deg,rudder_deg,rpm' "
        rf"and at least {MIN_SAMPLES} data rows$",
    ),
    (
        "blank lines only",
        lambda: "\n \r\n\t\n",
        None,
        None,
        r"empty file; expected a header line",
    ),
    (
        "comments only",
        lambda: _text(METADATA),
        None,
        None,
        r"no header line; expected a header line like",
    ),
]


@pytest.mark.parametrize(
    ("make_text", "line", "column", "message"),
    [pytest.param(*case[1:], id=case[0]) for case in BAD_LOGS],
)
def test_bad_log_is_rejected_with_file_line_and_column(
    tmp_path: Path,
    make_text: Callable[[], str],
    line: int | None,
    column: str | None,
    message: str,
) -> None:
    path = _write(tmp_path, make_text())
    location = re.escape(str(path)) + ("" if line is None else f":{line}")

    with pytest.raises(LogFormatError, match=f"^{location}: {message}") as info:
        read_log(path)

    error = info.value
    assert (error.path, error.line, error.column) == (str(path), line, column)
    assert error.expected
    assert "\n" not in str(error)


@pytest.mark.parametrize(
    ("content", "line", "message"),
    [
        pytest.param(
            _text(_valid_lines()).replace("0.5,4.0", "0.5,\x004.0").encode(),
            _row_line(1),
            r"not a text file: NUL byte at offset \d+; expected UTF-8 text$",
            id="NUL byte",
        ),
        pytest.param(
            _text(_valid_lines()).replace("test fixture", "Trøndelag").encode("latin-1"),
            3,
            r"not a text file: invalid UTF-8 byte 0xf8 at offset \d+; expected UTF-8 text$",
            id="latin-1",
        ),
        pytest.param(
            b"\x89PNG\r\n\x1a\n" + bytes(range(128, 256)),
            1,
            r"not a text file: invalid UTF-8 byte 0x89 at offset 0; expected UTF-8 text$",
            id="binary data",
        ),
        pytest.param(
            _text(_valid_lines()).encode("utf-16"),
            1,
            r"not a text file in UTF-8: it starts with a UTF-16 byte-order mark",
            id="UTF-16",
        ),
    ],
)
def test_binary_file_is_not_a_text_file(
    tmp_path: Path, content: bytes, line: int, message: str
) -> None:
    path = _write(tmp_path, content)
    with pytest.raises(LogFormatError, match=f"^{re.escape(str(path))}:{line}: {message}") as info:
        read_log(path)
    assert info.value.expected == "UTF-8 text"


def test_missing_file_and_directory(tmp_path: Path) -> None:
    missing = tmp_path / "no_such_log.csv"
    with pytest.raises(LogFormatError, match=r"no_such_log\.csv: no such file; expected") as info:
        read_log(missing)
    assert info.value.line is None
    assert info.value.path == str(missing)

    with pytest.raises(LogFormatError, match=r": is a directory; expected a trial-log file$"):
        read_log(tmp_path)


# --------------------------------------------------------------------------- writing


def test_write_then_read_round_trips(tmp_path: Path) -> None:
    log = _example_log()
    path = tmp_path / "out" / "trial.csv"

    write_log(path, log)
    back = read_log(path)

    np.testing.assert_array_equal(back.time_s, log.time_s)
    np.testing.assert_array_equal(back.x_m, log.x_m)
    np.testing.assert_array_equal(back.y_m, log.y_m)
    for name in ("heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_allclose(getattr(back, name), getattr(log, name), rtol=1e-12, atol=0)
    assert dict(back.metadata) == dict(log.metadata)
    assert list(back.metadata) == list(log.metadata)  # order kept
    assert back.path == str(path)
    assert os.listdir(path.parent) == ["trial.csv"]


def test_write_then_read_round_trips_the_optional_columns(tmp_path: Path) -> None:
    log = _example_log()
    n = log.n_samples
    full = ManeuverLog(
        log.time_s,
        log.x_m,
        log.y_m,
        log.heading_rad,
        log.rudder_rad,
        log.n_rps,
        log.metadata,
        wind_speed_mps=np.linspace(0.0, 31.7, n),
        wind_angle_rad=np.linspace(-np.pi, 3.0 * np.pi, n),
        stw_mps=np.linspace(8.1, 3.3, n),
    )
    path = tmp_path / "trial.csv"

    write_log(path, full)
    back = read_log(path)

    assert path.read_text().split("\n")[len(log.metadata)] == (
        HEADER + ",wind_speed_mps,wind_angle_deg,stw_mps"
    )
    assert back.wind_speed_mps is not None
    assert back.wind_angle_rad is not None
    assert back.stw_mps is not None
    assert full.wind_angle_rad is not None
    np.testing.assert_array_equal(back.wind_speed_mps, full.wind_speed_mps)
    np.testing.assert_array_equal(back.stw_mps, full.stw_mps)
    np.testing.assert_allclose(back.wind_angle_rad, full.wind_angle_rad, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(back.x_m, log.x_m)

    # absent fields are absent from the file
    only_stw = replace(full, metadata={}, wind_speed_mps=None, wind_angle_rad=None)
    assert format_log(only_stw).split("\n")[0] == HEADER + ",stw_mps"
    assert format_log(log).split("\n")[len(log.metadata)] == HEADER


def test_format_log_layout() -> None:
    log = ManeuverLog(
        time_s=np.array([0.0, 0.1]),
        x_m=np.array([1.0, 2.5]),
        y_m=np.array([-0.0, 1e-5]),
        heading_rad=np.array([0.0, np.pi]),
        rudder_rad=np.array([0.0, -np.pi / 2]),
        n_rps=np.array([1.5, 0.5]),
        metadata={"vessel": "test ship", "length_m": "10.0", "source": ""},
    )
    assert format_log(log) == (
        "# vessel: test ship\n"
        "# length_m: 10.0\n"
        "# source:\n"
        "time_s,x_m,y_m,heading_deg,rudder_deg,rpm\n"
        "0.0,1.0,-0.0,0.0,0.0,90.0\n"
        "0.1,2.5,1e-05,180.0,-90.0,30.0\n"
    )


def test_format_log_rejects_values_that_overflow_in_file_units(tmp_path: Path) -> None:
    log = _example_log()
    huge = ManeuverLog(
        log.time_s, log.x_m, log.y_m, log.heading_rad, log.rudder_rad, np.full(15, 1e308)
    )
    target = _write(tmp_path, "previous content")
    with pytest.raises(ValueError, match=r"column 'rpm' overflows"):
        write_log(target, huge)
    assert target.read_text() == "previous content"


# --------------------------------------------------------------------------- ManeuverLog


def test_maneuver_log_stores_read_only_float_copies() -> None:
    time_s = np.arange(12)  # integers are accepted and converted
    x_m = np.zeros(12)
    metadata = {"vessel": "a"}
    log = ManeuverLog(time_s, x_m, x_m, x_m, x_m, x_m, metadata)  # type: ignore[arg-type]

    x_m[0] = 99.0
    metadata["vessel"] = "b"
    assert log.x_m[0] == 0.0
    assert log.metadata["vessel"] == "a"
    assert log.time_s.dtype == np.float64
    assert log.n_samples == 12
    with pytest.raises(ValueError, match="read-only"):
        log.heading_rad[0] = 1.0
    with pytest.raises(TypeError):
        log.metadata["vessel"] = "c"  # type: ignore[index]

    stw = np.arange(12)
    with_stw = ManeuverLog(time_s, x_m, x_m, x_m, x_m, x_m, stw_mps=stw)  # type: ignore[arg-type]
    stw[0] = 99
    assert with_stw.stw_mps is not None
    assert with_stw.stw_mps[0] == 0.0
    assert with_stw.stw_mps.dtype == np.float64
    with pytest.raises(ValueError, match="read-only"):
        with_stw.stw_mps[0] = 1.0


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"x_m": np.zeros(11)}, r"arrays differ in length"),
        ({"y_m": np.zeros((12, 1))}, r"y_m must be one-dimensional"),
        ({"n_rps": np.array(["1"] * 12)}, r"n_rps must be real-valued"),
        ({"n_rps": np.zeros(12, dtype=complex)}, r"n_rps must be real-valued"),
        ({"rudder_rad": np.where(np.arange(12) == 3, np.nan, 0.0)}, r"rudder_rad\[3\] is not"),
        ({"time_s": np.r_[0.0, 1.0, 1.0, np.arange(3.0, 12.0)]}, r"sample 2 \(1\.0 s\) follows"),
        ({"metadata": {"bad key": "v"}}, r"metadata key 'bad key'"),
        ({"metadata": {"source": "two\nlines"}}, r"metadata 'source' must be one line"),
        ({"metadata": {"source": " padded"}}, r"metadata 'source' must be one line"),
        ({"metadata": {"length_m": 320.0}}, r"metadata 'length_m' must be a str"),
        ({"stw_mps": np.zeros(11)}, r"arrays differ in length: .*'stw_mps': 11"),
        ({"wind_speed_mps": np.r_[np.zeros(11), np.inf]}, r"wind_speed_mps\[11\] is not finite"),
        ({"wind_angle_rad": np.zeros((12, 2))}, r"wind_angle_rad must be one-dimensional"),
        ({"stw_mps": np.array(["1"] * 12)}, r"stw_mps must be real-valued"),
    ],
)
def test_maneuver_log_invariants(change: dict[str, object], message: str) -> None:
    arrays: dict[str, object] = {
        name: np.arange(12.0)
        for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps")
    }
    with pytest.raises(ValueError, match=message):
        ManeuverLog(**(arrays | change))  # type: ignore[arg-type]


def test_length_m_property() -> None:
    assert _example_log(vessel="x").length_m is None
    assert _example_log(length_m="1.75e2").length_m == 175.0
    bad = _example_log(length_m="-3")
    with pytest.raises(LogFormatError, match=r"^metadata 'length_m': expected a positive") as info:
        _ = bad.length_m
    assert info.value.line is None


def test_positions_on_board_from_the_metadata() -> None:
    assert _example_log(vessel="x").on_board_m("speed_log_x_m") is None
    assert _example_log(speed_log_x_m="-12.5").on_board_m("speed_log_x_m") == -12.5
    assert _example_log(gnss_y_m="1e1").on_board_m("gnss_y_m") == 10.0
    with pytest.raises(LogFormatError, match=r"^metadata 'speed_log_x_m': expected the speed"):
        _example_log(speed_log_x_m="501").on_board_m("speed_log_x_m")


# --------------------------------------------------------------------------- errors


def test_error_messages_are_one_line_with_optional_parts() -> None:
    full = LogFormatError("expected x, got y", path="a.csv", line=3, column="x_m", expected="x")
    assert str(full) == "a.csv:3: column 'x_m': expected x, got y"
    assert str(LogFormatError("m", path=Path("a.csv"), line=3)) == "a.csv:3: m"
    assert str(LogFormatError("m", path="a.csv")) == "a.csv: m"
    assert str(LogFormatError("m", line=3)) == "line 3: m"
    assert str(LogFormatError("bad\nthing", path="x\ny.csv")) == "x\\ny.csv: bad\\nthing"
    assert isinstance(full, ValueError)

    copy = pickle.loads(pickle.dumps(full))
    assert (copy.path, copy.line, copy.column, copy.expected) == ("a.csv", 3, "x_m", "x")
    assert str(copy) == str(full)

    ident = IdentificationError("covariance lost positive definiteness", log="z.csv", sample=12)
    assert str(ident) == "z.csv: sample 12: covariance lost positive definiteness"
    assert str(IdentificationError("diverged")) == "diverged"
    assert isinstance(ident, RuntimeError)
    assert str(pickle.loads(pickle.dumps(ident))) == str(ident)


# --------------------------------------------------------------------------- NMEA given to fit

_GGA = "$GPGGA,235830.00,6325.8300000,N,01023.7060000,E,1,09,0.9,12.0,M,41.0,M,,*5D"
_HINT = r" \(an NMEA recording\? convert it first: python -m identifier convert FILE -o DIR\)$"


@pytest.mark.parametrize(
    ("name", "content", "message"),
    [
        pytest.param("rec.nmea", f"{_GGA}\n$HEHDT,340.100,T*29\n", "missing columns", id="nmea"),
        pytest.param("rec.csv", f"\n{_GGA}\n", "missing columns", id="$ line in a csv"),
        pytest.param(
            "ais.txt", "!AIVDM,1,1,,A,13aEOK?P00PD2wVMdLDRhgvL289?,0*26\n", "missing", id="!"
        ),
        pytest.param(
            "rec.nmea", f"{_GGA}\n\xff\n".encode("latin-1"), "invalid UTF-8", id="binary nmea"
        ),
        pytest.param("REC.NMEA", "lat,lon\n1,2\n", "missing columns", id="named .nmea"),
    ],
)
def test_an_nmea_recording_read_as_a_log_says_to_convert_it(
    tmp_path: Path, name: str, content: str | bytes, message: str
) -> None:
    path = _write(tmp_path, content, name)
    with pytest.raises(LogFormatError, match=message + ".*" + _HINT):
        read_log(path)


def test_a_csv_with_a_missing_column_gets_no_nmea_hint(tmp_path: Path) -> None:
    path = _write(tmp_path, "time_s,x_m,y_m,heading_deg,rudder_deg\n0,0,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"missing column 'rpm'") as info:
        read_log(path)
    assert "NMEA" not in str(info.value)


# --------------------------------------------------------------------------- write_atomic


def test_write_atomic_writes_text_and_bytes_creating_parents(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b" / "params.json"
    write_atomic(target, "héllo\nworld\n")
    assert target.read_bytes() == "héllo\nworld\n".encode()
    write_atomic(str(target), b"\x00\x01")
    assert target.read_bytes() == b"\x00\x01"
    assert os.listdir(target.parent) == ["params.json"]


def test_write_atomic_rejects_other_types_before_touching_disk(tmp_path: Path) -> None:
    with pytest.raises(TypeError, match="bytes or str"):
        write_atomic(tmp_path / "x" / "out.txt", 3)  # type: ignore[arg-type]
    assert os.listdir(tmp_path) == []


@pytest.mark.skipif(os.name != "posix", reason="POSIX permission bits")
def test_write_atomic_keeps_permissions_of_existing_file(tmp_path: Path) -> None:
    target = _write(tmp_path, "old", "out.txt")
    target.chmod(0o640)
    write_atomic(target, "new")
    assert target.stat().st_mode & 0o777 == 0o640

    umask = os.umask(0o022)
    os.umask(umask)
    fresh = tmp_path / "fresh.txt"
    write_atomic(fresh, "new")
    assert fresh.stat().st_mode & 0o777 == 0o666 & ~umask


class _HalfWrite:
    """Stand-in for ``open``: writes half of the data, then fails like a full disk."""

    def __init__(self, path: str, mode: str) -> None:
        self.file = open(path, mode)

    def __enter__(self) -> _HalfWrite:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.file.close()

    def write(self, data: bytes) -> None:
        self.file.write(data[: len(data) // 2])
        raise OSError(28, "No space left on device")


@pytest.mark.parametrize(
    ("failing", "exception"),
    [
        ("write", OSError(28, "No space left on device")),
        ("fsync", OSError(5, "Input/output error")),
        ("fsync", KeyboardInterrupt()),
        ("replace", OSError(18, "Invalid cross-device link")),
        ("replace", KeyboardInterrupt()),
    ],
)
def test_write_atomic_failure_leaves_previous_file_and_no_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, failing: str, exception: BaseException
) -> None:
    target = _write(tmp_path, "previous content", "params.json")

    def fail(*args: object, **kwargs: object) -> None:
        raise exception

    if failing == "write":
        monkeypatch.setattr(fmu_model.atomic, "open", _HalfWrite, raising=False)
    else:
        monkeypatch.setattr(os, failing, fail)

    with pytest.raises(type(exception)):
        write_atomic(target, "new content " * 1000)

    monkeypatch.undo()
    assert target.read_text() == "previous content"
    assert os.listdir(tmp_path) == ["params.json"]


def _no_temporary_named(error: OSError) -> None:
    assert ".tmp" not in str(error) and ".tmp" not in (error.strerror or "")
    assert error.filename2 is None


def test_write_atomic_error_names_the_target_when_its_directory_is_a_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    _write(tmp_path, "a file", "taken")
    monkeypatch.chdir(tmp_path)
    for target in ("taken/out.json", "taken/sub/out.json"):
        with pytest.raises(NotADirectoryError) as info:
            write_atomic(target, "new")
        assert info.value.filename == target  # as given, not made absolute
        assert info.value.strerror == "cannot write: Not a directory"
        _no_temporary_named(info.value)
    assert sorted(os.listdir(tmp_path)) == ["taken"]


def test_write_atomic_error_names_the_target_not_the_temporary_file(tmp_path: Path) -> None:
    target = tmp_path / "a directory"
    (target / "inside").mkdir(parents=True)
    with pytest.raises(IsADirectoryError) as info:  # the rename of the temporary file fails
        write_atomic(target, "new")
    assert info.value.filename == str(target)
    assert info.value.strerror == "cannot write: Is a directory"
    assert isinstance(info.value.__cause__, IsADirectoryError)  # the original, for debugging
    _no_temporary_named(info.value)
    assert sorted(os.listdir(tmp_path)) == ["a directory"]  # the temporary file is gone
    assert os.listdir(target) == ["inside"]


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="needs Linux /proc")
def test_write_atomic_error_when_the_temporary_file_cannot_be_created() -> None:
    with pytest.raises(OSError) as info:  # no file can be created in /proc, even by root
        write_atomic("/proc/x.fmu", "new")
    assert info.value.filename == "/proc/x.fmu"
    assert info.value.strerror == "cannot write: No such file or directory"
    _no_temporary_named(info.value)


# --------------------------------------------------------------------------- properties


@st.composite
def maneuver_logs(draw: st.DrawFn) -> ManeuverLog:
    """Random valid logs: any positions within the bounds, heading steps below π/3 (survives
    the unwrap on reading: three of them stay within half a turn of the median of the five
    samples before, ``trials.angles``), no time step longer than the others together,
    rpm ahead.
    """
    n = draw(st.integers(MIN_SAMPLES, 30))

    def floats(low: float, high: float, size: int) -> np.ndarray:
        element = st.floats(low, high, allow_subnormal=False)
        return np.array(draw(st.lists(element, min_size=size, max_size=size)))

    t0 = draw(st.floats(-1e6, 1e6))
    steps = floats(1e-3, 100.0, n - 1)
    largest, second = np.argsort(steps)[[-1, -2]]
    steps[largest] = steps[second]  # the largest step twice: none is longer than the rest
    time_s = t0 + np.concatenate([[0.0], np.cumsum(steps)])
    anywhere = st.floats(-MAX_POSITION_M, MAX_POSITION_M)
    x_m, y_m = (np.array(draw(st.lists(anywhere, min_size=n, max_size=n))) for _ in "xy")
    heading_rad = draw(st.floats(-50.0, 50.0)) + np.cumsum(floats(-1.0, 1.0, n))
    keys = st.from_regex(r"\A[A-Za-z_][A-Za-z0-9_.\-]{0,12}\Z").filter(lambda k: k != "length_m")
    printable = st.characters(exclude_categories=("Cs", "Cc"), exclude_characters="\ufffe\uffff")
    values = st.text(printable, max_size=20).map(str.strip)
    metadata = draw(st.dictionaries(keys, values, max_size=4))
    if draw(st.booleans()):
        metadata["length_m"] = repr(draw(st.floats(1.0, 500.0)))
    return ManeuverLog(
        time_s=time_s,
        x_m=x_m,
        y_m=y_m,
        heading_rad=heading_rad,
        rudder_rad=floats(-0.7, 0.7, n),
        n_rps=floats(0.0, 5.0, n),
        metadata=metadata,
        wind_speed_mps=floats(0.0, 100.0, n) if draw(st.booleans()) else None,
        wind_angle_rad=floats(-600.0, 600.0, n) if draw(st.booleans()) else None,
        stw_mps=floats(0.0, 50.0, n) if draw(st.booleans()) else None,
    )


@settings(max_examples=60, deadline=None)
@given(log=maneuver_logs())
def test_random_logs_round_trip_through_a_file(log: ManeuverLog) -> None:
    with tempfile.TemporaryDirectory() as directory:
        path = os.path.join(directory, "trial.csv")
        write_log(path, log)
        back = read_log(path)

    np.testing.assert_array_equal(back.time_s, log.time_s)
    np.testing.assert_array_equal(back.x_m, log.x_m)
    np.testing.assert_array_equal(back.y_m, log.y_m)
    for name in ("heading_rad", "rudder_rad", "n_rps"):
        np.testing.assert_allclose(getattr(back, name), getattr(log, name), rtol=1e-12, atol=0)
    assert dict(back.metadata) == dict(log.metadata)
    for name in ("wind_speed_mps", "wind_angle_rad", "stw_mps"):
        if getattr(log, name) is None:
            assert getattr(back, name) is None
        else:
            np.testing.assert_allclose(getattr(back, name), getattr(log, name), rtol=1e-12, atol=0)


@settings(max_examples=100, deadline=None)
@given(
    log=maneuver_logs(),
    data=st.data(),
    bad=st.sampled_from(["nan", "inf", "-inf", "", "x", "1e999", "NaN"]),
)
def test_single_cell_corruption_names_line_and_column(
    log: ManeuverLog, data: st.DataObject, bad: str
) -> None:
    lines = format_log(log).split("\n")
    header_index = len(log.metadata)  # 0-based: the metadata lines come first
    header = lines[header_index].split(",")
    assert header[: len(LOG_COLUMNS)] == list(LOG_COLUMNS)
    row = data.draw(st.integers(0, log.n_samples - 1), label="row")
    column = data.draw(st.sampled_from(header), label="column")
    fields = lines[header_index + 1 + row].split(",")
    fields[header.index(column)] = bad
    lines[header_index + 1 + row] = ",".join(fields)
    line = header_index + 2 + row  # 1-based
    if column in OPTIONAL_COLUMNS and bad in ("", "nan", "NaN"):  # a sensor's dropout
        span_s = log.time_s[min(row + 1, log.n_samples - 1)] - log.time_s[max(row - 1, 0)]
        if span_s <= MAX_DROPOUT_S:  # filled from the values around it
            assert parse_log("\n".join(lines), path="corrupt.csv").filled[column] == 1
            return

    with pytest.raises(
        LogFormatError, match=rf"^corrupt\.csv:{line}: column '{column}': expected a finite number"
    ) as info:
        parse_log("\n".join(lines), path="corrupt.csv")
    assert (info.value.line, info.value.column) == (line, column)
