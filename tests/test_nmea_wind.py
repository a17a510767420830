"""NMEA wind (MWV) and speed through the water (VHW, VBW) into the trial log.

Every recording here is written line by line in the test: a fix a second (GGA, no
date), then heading, rudder and RPM, then the sentences under test, whose values are
chosen so that the expected column can be written down exactly.
"""

from __future__ import annotations

import functools
import operator
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from identifier.cli import main
from identifier.ingest import convert_file, convert_nmea
from trials.errors import LogFormatError
from trials.logs import read_log

KNOT = 1852.0 / 3600.0
SECONDS = 20


def sentence(body: str) -> str:
    """``$body*hh`` with its checksum."""
    return f"${body}*{functools.reduce(operator.xor, map(ord, body), 0):02X}"


def recording(tmp_path: Path, extra: Callable[[int], list[str]], seconds: int = SECONDS) -> Path:
    """One fix a second at 12:00:00 + k s, heading, rudder, RPM, then ``extra(k)``."""
    lines = []
    for k in range(seconds):
        lines += [
            sentence(
                f"GPGGA,12{k // 60:02d}{k % 60:02d}.00,6325.{8300 + 10 * k:04d},N,"
                "01023.7060,E,1,09,0.9,12.0,M,41.0,M,,"
            ),
            sentence(f"HEHDT,{10.0 + 0.1 * k:.1f},T"),
            sentence("IIRSA,5.0,A,,V"),
            sentence("IIRPM,S,0,60.0,80.0,A"),
            *extra(k),
        ]
    path = tmp_path / "trial.nmea"
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path


def at_fixes(values: list[float], line: int = 5, lines: int = 5) -> np.ndarray:
    """Values of the sentence on ``line`` of each second's ``lines``, at the fixes.

    A sentence without a time of its own is placed by its line number between the fixes
    around it: line ``line`` (1 = the fix) of second k is at k + (line − 1)/``lines``
    s. So the value at fix k is interpolated between seconds k − 1 and k, and the first
    fix gets the line through the first two continued back.
    """
    v = np.asarray(values, dtype=float)
    fraction = (line - 1) / lines
    inside = v[:-1] + (1.0 - fraction) * (v[1:] - v[:-1])
    first = v[0] - fraction * (v[1] - v[0])
    return np.concatenate([[first], inside])


# --------------------------------------------------------------------------- wind


@pytest.mark.parametrize(
    ("unit", "to_mps"), [("N", KNOT), ("M", 1.0), ("K", 1.0 / 3.6), ("S", 0.44704)]
)
def test_relative_wind_in_any_unit(tmp_path: Path, unit: str, to_mps: float) -> None:
    speed = [10.0 + k for k in range(SECONDS)]
    path = recording(
        tmp_path, lambda k: [sentence(f"WIMWV,{90.0 + k:.1f},R,{speed[k]:.1f},{unit},A")]
    )
    log = convert_nmea(path).logs[0]
    assert log.stw_mps is None
    assert log.wind_speed_mps is not None and log.wind_angle_rad is not None
    np.testing.assert_allclose(log.wind_speed_mps, at_fixes(speed)[: log.n_samples] * to_mps)
    # 90 deg = from the starboard beam, kept as the log's positive-from-starboard angle
    angle = [90.0 + k for k in range(SECONDS)]
    np.testing.assert_allclose(np.degrees(log.wind_angle_rad), at_fixes(angle)[: log.n_samples])


def test_wind_angle_is_interpolated_across_north_and_kept_in_0_360(tmp_path: Path) -> None:
    angle = [(350.0 + 2.0 * k) % 360.0 for k in range(SECONDS)]  # 350, 352, ... 358, 0, 2 ...
    path = recording(tmp_path, lambda k: [sentence(f"WIMWV,{angle[k]:.1f},R,12.0,M,A")])
    log = convert_nmea(path).logs[0]
    assert log.wind_angle_rad is not None
    degrees = np.degrees(log.wind_angle_rad)
    assert np.all((degrees >= 0.0) & (degrees < 360.0))
    expected = np.mod(at_fixes(list(np.unwrap(angle, period=360.0))), 360.0)[: log.n_samples]
    np.testing.assert_allclose(degrees, expected, atol=1e-9)
    np.testing.assert_allclose(np.mod(np.diff(degrees), 360.0), 2.0)  # never through 180


def test_only_relative_valid_wind_is_used(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        return [
            sentence("WIMWV,45.0,T,20.0,M,A"),  # "true" wind: computed, not measured
            sentence("WIMWV,,R,,M,V"),  # invalid reading, empty fields
            sentence(f"WIMWV,{30.0 + k:.1f},R,8.0,M,A"),
        ]

    result = convert_nmea(recording(tmp_path, extra))
    log = result.logs[0]
    assert log.wind_speed_mps is not None
    np.testing.assert_allclose(log.wind_speed_mps, 8.0)
    assert f"MWV true (theoretical) wind readings, reference T (ignored): {SECONDS}" in result.notes
    assert f"MWV wind readings with status V (ignored): {SECONDS}" in result.notes
    assert result.skipped_lines == 0


def test_true_wind_alone_gives_no_wind_columns(tmp_path: Path) -> None:
    result = convert_nmea(recording(tmp_path, lambda k: [sentence("WIMWV,45.0,T,20.0,M,A")]))
    log = result.logs[0]
    assert log.wind_speed_mps is None and log.wind_angle_rad is None and log.stw_mps is None


@pytest.mark.parametrize(
    "body",
    [
        "WIMWV,400.0,R,8.0,M,A",  # angle beyond 360
        "WIMWV,30.0,R,-1.0,M,A",  # negative speed
        "WIMWV,30.0,R,101.0,M,A",  # beyond 100 m/s
        "WIMWV,30.0,R,1" + "0" * 400 + ",M,A",  # beyond the floating-point range
        "WIMWV,30.0,R,1e3,M,A",  # not a plain decimal
        "WIMWV,30.0,R,8.0,X,A",  # no such unit
        "WIMWV,30.0,X,8.0,M,A",  # no such reference
        "WIMWV,30.0,R,8.0,M,Q",  # no such status
        "WIMWV,,R,8.0,M,A",  # valid, but no angle
        "VWVHW,,T,,M,9" + "9" * 400 + ",N,,K",
        "VWVHW,,T,,M,98.0,N,,K",  # beyond 50 m/s
        "VWVHW,,T,,M,8.0,X,,K",
        "VDVBW,1e308,0.1,A,8.0,0.1,A",
        "VDVBW,8.0,0.1,X,8.0,0.1,A",
        "VDVBW,8.0,-98.0,A,8.0,0.1,A",  # transverse beyond 50 m/s
        "VDVBW,8.0,0.1x,A,8.0,0.1,A",
    ],
)
def test_a_malformed_field_skips_its_sentence_only(tmp_path: Path, body: str) -> None:
    good = {
        "MWV": "WIMWV,30.0,R,8.0,M,A",
        "VHW": "VWVHW,,T,,M,8.0,N,,K",
        "VBW": "VDVBW,8.0,0.1,A,8.0,0.1,A",
    }[body[2:5]]

    def extra(k: int) -> list[str]:
        return [sentence(body if k == 7 else good)]

    result = convert_nmea(recording(tmp_path, extra))
    assert result.skipped_lines == 1
    log = result.logs[0]
    column = log.wind_speed_mps if body[2:5] == "MWV" else log.stw_mps
    assert column is not None
    np.testing.assert_allclose(column, 8.0 if body[2:5] == "MWV" else 8.0 * KNOT)


def test_a_checksum_failure_skips_its_sentence(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        line = sentence(f"WIMWV,30.0,R,{8.0 + k:.1f},M,A")
        return [line[:-2] + "00" if k == 7 else line]

    result = convert_nmea(recording(tmp_path, extra))
    assert result.checksum_failures == 1
    log = result.logs[0]
    assert log.wind_speed_mps is not None
    # sample 7 is missing: fixes 7 and 8 interpolate between its neighbours
    speeds = [8.0 + k for k in range(SECONDS)]
    np.testing.assert_allclose(log.wind_speed_mps[10:], at_fixes(speeds)[10 : log.n_samples])


# --------------------------------------------------------------------------- water speed


def test_vhw_in_knots_or_else_kilometres_per_hour(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        if k % 2:
            return [sentence(f"VWVHW,10.0,T,12.0,M,,N,{14.4:.1f},K")]  # 4 m/s
        return [sentence(f"VWVHW,10.0,T,12.0,M,{4.0 / KNOT:.6f},N,15.0,K")]  # knots win

    log = convert_nmea(recording(tmp_path, extra)).logs[0]
    assert log.stw_mps is not None and log.wind_speed_mps is None
    np.testing.assert_allclose(log.stw_mps, 4.0, rtol=1e-6)


def test_vbw_longitudinal_water_speed_with_status_a(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        if k == 5:
            return [sentence("VDVBW,-0.5,0.1,A,7.0,0.1,A")]  # astern: ignored
        if k == 6:
            return [sentence("VDVBW,,,V,7.0,0.1,A")]  # invalid water speed
        return [sentence(f"VDVBW,{6.0 + 0.1 * k:.1f},0.3,A,7.0,0.1,A")]

    result = convert_nmea(recording(tmp_path, extra))
    assert "VBW water speeds astern, negative (ignored): 1" in result.notes
    assert "VBW water speeds with status V (ignored): 1" in result.notes
    log = result.logs[0]
    assert log.stw_mps is not None
    knots = [6.0 + 0.1 * k for k in range(SECONDS)]
    np.testing.assert_allclose(log.stw_mps[8:] / KNOT, at_fixes(knots)[8 : log.n_samples])


def test_vbw_transverse_water_speed_is_positive_to_starboard(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        if k == 6:
            return [sentence("VDVBW,7.0,,A,7.0,0.1,A")]  # a single-axis sample
        return [sentence(f"VDVBW,7.0,{-0.5 + 0.05 * k:.2f},A,7.0,0.1,A")]  # "-": to port

    result = convert_nmea(recording(tmp_path, extra))
    log = result.logs[0]
    assert log.stw_mps is not None and log.stw_transverse_mps is not None
    knots = [-0.5 + 0.05 * k for k in range(SECONDS)]
    np.testing.assert_allclose(
        log.stw_transverse_mps[8:] / KNOT, at_fixes(knots)[8 : log.n_samples], atol=1e-12
    )
    assert log.stw_transverse_mps[1] < 0.0  # to port, as the sentence says


def test_the_water_speed_source_with_most_samples_is_used(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        lines = [sentence("VWVHW,,T,,M,8.0,N,,K")]
        if k % 4 == 0:
            lines.append(sentence("VDVBW,9.0,0.1,A,8.0,0.1,A"))
        return lines

    result = convert_nmea(recording(tmp_path, extra))
    log = result.logs[0]
    assert log.stw_mps is not None
    np.testing.assert_allclose(log.stw_mps, 8.0 * KNOT)
    assert f"speed through the water from VWVHW ({SECONDS}) used; ignored VDVBW (5)" in (
        result.notes
    )
    # VBW's transverse axis belongs to VBW's log, not to the VHW log chosen: none.
    assert log.stw_transverse_mps is None
    assert (
        "transverse speed through the water of another source than the speed through the "
        "water's (ignored): 5"
    ) in result.notes


# --------------------------------------------------------------------------- coverage, CLI


def test_an_optional_stream_with_a_gap_does_not_split_the_log(tmp_path: Path) -> None:
    """The wind stops after 8 s: the log keeps all its fixes and has no wind columns;
    the water speed covers it and is there."""

    def extra(k: int) -> list[str]:
        lines = [sentence("VWVHW,,T,,M,8.0,N,,K")]
        if k < 8:
            lines.append(sentence("WIMWV,30.0,R,8.0,M,A"))
        return lines

    result = convert_nmea(recording(tmp_path, extra))
    assert len(result.logs) == 1 and result.gaps == ()
    log = result.logs[0]
    assert log.n_samples == SECONDS
    assert log.wind_speed_mps is None and log.wind_angle_rad is None
    assert log.stw_mps is not None
    assert any(
        note.startswith("wind speed does not cover t = 0.0 to 19.0 s (log 1)")
        for note in result.notes
    )


def test_recordings_without_the_sentences_convert_as_before() -> None:
    data = Path(__file__).parent / "data"
    for name in ("trial.nmea", "trial_latlon.csv"):
        for log in convert_file(data / name).logs:
            assert log.wind_speed_mps is None and log.wind_angle_rad is None
            assert log.stw_mps is None


def test_cli_convert_writes_the_columns_and_the_log_reads_back(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def extra(k: int) -> list[str]:
        return [
            sentence(f"WIMWV,{270.0 + k:.1f},R,{10.0 + k:.1f},N,A"),
            sentence(f"VWVHW,,T,,M,{8.0 + 0.1 * k:.1f},N,,K"),
        ]

    path = recording(tmp_path, extra)
    out = tmp_path / "log.csv"
    assert main(["convert", str(path), "-o", str(out), "--quiet"]) == 0
    header = next(line for line in out.read_text().splitlines() if not line.startswith("#"))
    assert header.split(",")[-3:] == ["wind_speed_mps", "wind_angle_deg", "stw_mps"]
    back = read_log(out)
    converted = convert_nmea(path).logs[0]
    for name in ("wind_speed_mps", "wind_angle_rad", "stw_mps"):
        np.testing.assert_allclose(getattr(back, name), getattr(converted, name), rtol=1e-12)
    assert back.wind_angle_rad is not None
    wind = at_fixes([270.0 + k for k in range(SECONDS)], line=5, lines=6)
    np.testing.assert_allclose(np.degrees(back.wind_angle_rad), wind[: back.n_samples])


def test_cli_convert_a_two_axis_log_with_its_position(tmp_path: Path) -> None:
    def extra(k: int) -> list[str]:
        return [sentence(f"VDVBW,{8.0 + 0.1 * k:.1f},{-0.2 + 0.02 * k:.2f},A,8.0,0.1,A")]

    path = recording(tmp_path, extra)
    out = tmp_path / "log.csv"
    assert main(["convert", str(path), "-o", str(out), "--speed-log-x-m", "-12.5", "--quiet"]) == 0
    back = read_log(out)
    assert back.on_board_m("speed_log_x_m") == -12.5 and back.metadata["speed_log_x_m"] == "-12.5"
    converted = convert_nmea(path).logs[0]
    assert back.stw_transverse_mps is not None and converted.stw_transverse_mps is not None
    np.testing.assert_allclose(back.stw_transverse_mps, converted.stw_transverse_mps, rtol=1e-12)
    assert converted.on_board_m("speed_log_x_m") is None  # not given: fit will not use it
    with pytest.raises(ValueError, match=r"on_board: expected positions within ±500 m"):
        convert_nmea(path, on_board={"speed_log_x_m": 600.0})
    with pytest.raises(ValueError, match=r"got 'mast_x_m': 1\.0"):
        convert_nmea(path, on_board={"mast_x_m": 1.0})


def test_cli_convert_an_nmea_file_whose_every_fix_is_huge_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    lines = [
        sentence(
            "GPGGA,1200" + f"{k:02d}" + ".00," + "9" * 400 + ",N,01023.7060,E,1,09,"
            "0.9,12.0,M,41.0,M,,"
        )
        for k in range(12)
    ]
    path = tmp_path / "huge.nmea"
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    assert main(["convert", str(path), "-o", str(out)]) == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {path}: no valid position fix")
    assert not out.exists()
    with pytest.raises(LogFormatError, match="12 lines skipped"):
        convert_nmea(path)
