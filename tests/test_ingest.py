"""Ingestion of NMEA 0183 and latitude/longitude CSV recordings (identifier.ingest).

The recordings in ``tests/data`` are made by :func:`nmea_trial` and :func:`latlon_trial`
below from a known track (run ``python -m tests.test_ingest`` to rewrite them;
a test checks that they are up to date). Expected positions come from geodesics
(``pyproj.Geod``), not from the projection under test.
"""

from __future__ import annotations

import datetime as dt
import functools
import math
import operator
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pyproj
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identifier.cli import main
from identifier.ingest import (
    ConversionResult,
    TangentPlane,
    convert_file,
    convert_latlon_csv,
    convert_nmea,
    detect_format,
    output_paths,
)
from trials.errors import LogFormatError
from trials.logs import ManeuverLog, read_log, write_log

DATA = Path(__file__).parent / "data"
REPO = Path(__file__).parent.parent
GEOD = pyproj.Geod(ellps="WGS84")

ORIGIN_LAT, ORIGIN_LON = 63.4305, 10.3951  # Trondheimsfjorden
START = dt.datetime(2024, 5, 17, 23, 58, 30, tzinfo=dt.UTC)  # midnight at t = 90 s
DURATION_S = 160
LINES_PER_SECOND = 5  # slots: fix, HDT, RSA, HDT, RPM -> slot j is at t = k + j / 5
GAP_SECONDS = range(41, 50)  # GGA without a fix: no position from t = 40 to 50 s
RMC_SECONDS = (*range(5, 80, 10), 155)  # dated fixes; GGA only across midnight
SPEED_MPS, COURSE_DEG = 5.0, 30.0


def heading_true_deg(t: np.ndarray | float) -> np.ndarray | float:
    return 340.0 + 0.5 * np.asarray(t)  # crosses North at t = 40 s


def rudder_deg(t: np.ndarray | float) -> np.ndarray | float:
    return -8.0 + 0.1 * np.asarray(t)


def rpm(t: np.ndarray | float) -> np.ndarray | float:
    return 60.0 + 0.05 * np.asarray(t)


# --------------------------------------------------------------------------- generators


def _sentence(body: str) -> str:
    checksum = functools.reduce(operator.xor, map(ord, body), 0)
    return f"${body}*{checksum:02X}"


def _dm(value: float, degree_digits: int) -> tuple[str, float]:
    """Degrees → NMEA ``(d)ddmm.mmmmmmm`` and the value that text stands for [deg]."""
    degrees = int(abs(value))
    minutes = round((abs(value) - degrees) * 60.0, 7)
    text = f"{degrees:0{degree_digits}d}{minutes:010.7f}"
    return text, math.copysign(degrees + float(f"{minutes:.7f}") / 60.0, value)


def _track(t: float) -> tuple[float, float]:
    lon, lat, _ = GEOD.fwd(ORIGIN_LON, ORIGIN_LAT, COURSE_DEG, SPEED_MPS * t)
    return float(lat), float(lon)


def nmea_trial(corrupt: bool) -> tuple[list[str], dict[int, tuple[float, float]]]:
    """Lines of an NMEA recording and the (lat, lon) it states for each fix second.

    With ``corrupt``, some lines are replaced (never inserted, so that every line
    keeps its time slot): 3 checksum failures, 4 unusable lines, 1 other sentence.
    """
    lines: list[str] = []
    fixes: dict[int, tuple[float, float]] = {}
    for k in range(DURATION_S):
        stamp = START + dt.timedelta(seconds=k)
        hhmmss = stamp.strftime("%H%M%S.00")
        lat, lon = _track(k)
        lat_text, lat_value = _dm(lat, 2)
        lon_text, lon_value = _dm(lon, 3)
        if k in GAP_SECONDS:
            fix = _sentence(f"GPGGA,{hhmmss},,,,,0,00,99.9,,M,,M,,")
        elif k in RMC_SECONDS:
            date = stamp.strftime("%d%m%y")
            fix = _sentence(f"GPRMC,{hhmmss},A,{lat_text},N,{lon_text},E,9.7,30.0,{date},,,A")
            fixes[k] = (lat_value, lon_value)
        else:
            fix = _sentence(f"GPGGA,{hhmmss},{lat_text},N,{lon_text},E,1,09,0.9,12.0,M,41.0,M,,")
            fixes[k] = (lat_value, lon_value)
        times = [k + j / LINES_PER_SECOND for j in range(LINES_PER_SECOND)]
        lines += [
            fix,
            _sentence(f"HEHDT,{heading_true_deg(times[1]) % 360.0:.3f},T"),
            _sentence(f"IIRSA,{rudder_deg(times[2]):.3f},A,,V"),
            _sentence(f"HEHDT,{heading_true_deg(times[3]) % 360.0:.3f},T"),
            _sentence(f"IIRPM,S,1,{rpm(times[4]):.3f},80.0,A"),
        ]
    if corrupt:
        for second, slot in ((12, 1), (63, 0), (100, 2)):  # checksum failures
            index = LINES_PER_SECOND * second + slot
            lines[index] = lines[index][:-2] + ("00" if lines[index][-2:] != "00" else "11")
        del fixes[63]
        unusable = {
            (20, 3): "garbage from a serial line",
            (30, 4): "$IIRPM,S,1,6",  # cut short: no checksum
            (70, 1): _sentence("HEHDT,1x3.0,T"),  # valid checksum, malformed field
            (110, 3): "\xff\xfe" + _sentence("HEHDT,10.0,T"),  # not ASCII
        }
        for (second, slot), text in unusable.items():
            lines[LINES_PER_SECOND * second + slot] = text
        lines[LINES_PER_SECOND * 120 + 3] = _sentence("GPVTG,30.0,T,,M,9.7,N,18.0,K,A")
    return lines, fixes


def latlon_trial() -> str:
    """A 30 s CSV recording at 2 Hz: rudder at 1 Hz, rpm at 0.5 Hz (empty cells)."""
    rows = ["# exported by a data logger", "time,lat_deg,lon_deg,heading_deg,rudder_deg,rpm"]
    for i in range(60):
        t = 0.5 * i
        stamp = (START + dt.timedelta(seconds=t)).isoformat().replace("+00:00", "Z")
        lat, lon = _track(t)
        rudder = f"{rudder_deg(t):.3f}" if i % 2 == 0 else ""
        speed = f"{rpm(t):.3f}" if i % 4 == 0 else ""
        rows.append(
            f"{stamp},{lat:.9f},{lon:.9f},{heading_true_deg(t) % 360.0:.3f},{rudder},{speed}"
        )
    return "\n".join(rows) + "\n"


def _write_nmea(path: Path, corrupt: bool) -> Path:
    lines, _ = nmea_trial(corrupt)
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("latin-1"))
    return path


def write_data_files(directory: Path = DATA) -> None:
    directory.mkdir(exist_ok=True)
    _write_nmea(directory / "trial.nmea", corrupt=True)
    (directory / "trial_latlon.csv").write_text(latlon_trial(), encoding="utf-8")


# --------------------------------------------------------------------------- helpers


def _expected_xy(lat: np.ndarray, lon: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """x North, y East [m] from geodesic distance and azimuth at the origin."""
    n = np.size(lat)
    azimuth, _, distance = GEOD.inv(
        np.full(n, ORIGIN_LON), np.full(n, ORIGIN_LAT), np.asarray(lon), np.asarray(lat)
    )
    azimuth = np.radians(azimuth)
    return distance * np.cos(azimuth), distance * np.sin(azimuth)


def _north_azimuth_deg(lat: np.ndarray, lon: np.ndarray) -> np.ndarray:
    """True North in the plane, clockwise from x, via PROJ's meridian convergence."""
    plane = pyproj.Proj(TangentPlane(ORIGIN_LAT, ORIGIN_LON).proj_string)
    return -np.asarray(plane.get_factors(lon, lat).meridian_convergence)


def _wrapped(angle_rad: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * angle_rad))


def _write_csv(tmp_path: Path, rows: list[str], name: str = "rec.csv") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(rows) + "\n", encoding="utf-8")
    return path


def _csv_rows(n: int = 20, heading: str = "heading_deg", rudder: str = "rudder_deg") -> list[str]:
    rows = [f"time_s,lat_deg,lon_deg,{heading},{rudder},rpm"]
    for i in range(n):
        lat, lon = _track(float(i))
        rows.append(f"{i}.0,{lat:.9f},{lon:.9f},{0.1 * i},{0.02 + 0.005 * i},{60 + i}")
    return rows


# --------------------------------------------------------------------------- data files


def test_committed_data_files_are_made_by_the_generators(tmp_path: Path) -> None:
    write_data_files(tmp_path)
    for name in ("trial.nmea", "trial_latlon.csv"):
        committed = (DATA / name).read_bytes().replace(b"\r\n", b"\n")  # git may convert EOL
        assert committed == (tmp_path / name).read_bytes().replace(b"\r\n", b"\n"), (
            f"tests/data/{name} is stale: run python -m tests.test_ingest"
        )
        assert (DATA / name).stat().st_size < 50_000


# --------------------------------------------------------------------------- tangent plane


def test_a_fix_0_001_deg_north_of_the_origin_is_110_6_m_north() -> None:
    plane = TangentPlane(ORIGIN_LAT, ORIGIN_LON)
    x, y = plane.to_local(ORIGIN_LAT + 0.001, ORIGIN_LON)
    _, _, distance = GEOD.inv(ORIGIN_LON, ORIGIN_LAT, ORIGIN_LON, ORIGIN_LAT + 0.001)
    assert x == pytest.approx(111.4, abs=0.1)  # 0.001 deg of latitude at 63.4 deg N
    assert abs(x - distance) < 1e-6
    assert abs(y) < 1e-9
    equator = TangentPlane(0.0, 0.0)
    x0, _ = equator.to_local(0.001, 0.0)
    assert x0 == pytest.approx(110.574, abs=0.001)  # the textbook 110.6 m at the equator
    x_origin, y_origin = plane.to_local(ORIGIN_LAT, ORIGIN_LON)
    assert (x_origin, y_origin) == (0.0, 0.0)


@settings(max_examples=50, deadline=None)
@given(
    lat0=st.floats(-80.0, 80.0),
    lon0=st.floats(-179.0, 179.0),
    azimuth=st.floats(-180.0, 180.0),
    distance=st.floats(0.0, 5000.0),
)
def test_tangent_plane_is_geodesic_polar_coordinates_about_the_origin(
    lat0: float, lon0: float, azimuth: float, distance: float
) -> None:
    lon, lat, _ = GEOD.fwd(lon0, lat0, azimuth, distance)
    x, y = TangentPlane(lat0, lon0).to_local(lat, lon)
    # To 10 µm beyond 10 m; closer in, PROJ works to about 1e-10 rad (0.6 mm) near the
    # origin, and it moves an origin within about 2e-10 rad of the equator or the prime
    # meridian onto it, that angle times the earth's radius off: up to 1.3 mm (found by
    # hypothesis: 0.4 mm at 1e-10 rad, 0.7 mm at 1.09e-10; by hand 0.95 mm at 1.5e-10,
    # none at 2e-10). Judged with 2 mm within 1e-8 rad (6 cm) of either.
    near_axis = min(abs(math.radians(lat0)), abs(math.radians(lon0))) < 1e-8
    tolerance = 2e-3 if near_axis else 1e-5 if distance > 10.0 else 1e-3
    assert float(x) == pytest.approx(distance * math.cos(math.radians(azimuth)), abs=tolerance)
    assert float(y) == pytest.approx(distance * math.sin(math.radians(azimuth)), abs=tolerance)


def test_distances_between_points_within_5_km_are_kept_to_a_millimetre() -> None:
    plane = TangentPlane(ORIGIN_LAT, ORIGIN_LON)
    lon_a, lat_a, _ = GEOD.fwd(ORIGIN_LON, ORIGIN_LAT, 10.0, 5000.0)
    lon_b, lat_b, _ = GEOD.fwd(ORIGIN_LON, ORIGIN_LAT, 100.0, 5000.0)
    xa, ya = plane.to_local(lat_a, lon_a)
    xb, yb = plane.to_local(lat_b, lon_b)
    _, _, distance = GEOD.inv(lon_a, lat_a, lon_b, lat_b)
    assert abs(math.hypot(xa - xb, ya - yb) - distance) < 1e-3


def test_north_azimuth_matches_proj_meridian_convergence() -> None:
    plane = TangentPlane(60.0, 10.0)
    lon, lat, _ = GEOD.fwd(10.0, 60.0, 90.0, 5000.0)
    north = plane.north_azimuth_rad(lat, lon)
    expected = math.radians(
        float(-pyproj.Proj(plane.proj_string).get_factors(lon, lat).meridian_convergence)
    )
    assert float(north) == pytest.approx(expected, abs=1e-9)
    assert math.degrees(float(north)) == pytest.approx(-0.0776, abs=1e-4)
    assert float(plane.north_azimuth_rad(61.0, 10.0)) == pytest.approx(0.0, abs=1e-12)


def test_tangent_plane_rejects_an_origin_out_of_range() -> None:
    with pytest.raises(ValueError, match="out of range"):
        TangentPlane(91.0, 0.0)
    with pytest.raises(ValueError, match="out of range"):
        TangentPlane(0.0, math.nan)


# --------------------------------------------------------------------------- NMEA


@pytest.fixture(scope="module")
def clean_nmea(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _write_nmea(tmp_path_factory.mktemp("nmea") / "clean.nmea", corrupt=False)


def test_clean_nmea_positions_are_the_geodesic_positions_of_the_fixes(clean_nmea: Path) -> None:
    result = convert_nmea(clean_nmea)
    _, fixes = nmea_trial(corrupt=False)
    for log in result.logs:
        seconds = np.rint(log.time_s).astype(int)
        np.testing.assert_array_equal(log.time_s, seconds)  # the fix times
        lat = np.array([fixes[k][0] for k in seconds])
        lon = np.array([fixes[k][1] for k in seconds])
        x, y = _expected_xy(lat, lon)
        np.testing.assert_allclose(log.x_m, x, rtol=0, atol=1e-6)
        np.testing.assert_allclose(log.y_m, y, rtol=0, atol=1e-6)
        # and the track is the generated one: 5 m/s on 030 deg, to the 0.2 mm of the text
        np.testing.assert_allclose(np.hypot(log.x_m, log.y_m), SPEED_MPS * log.time_s, atol=3e-4)
    assert result.origin_lat_deg == pytest.approx(ORIGIN_LAT, abs=1e-9)
    assert result.origin_lon_deg == pytest.approx(ORIGIN_LON, abs=1e-9)


def test_clean_nmea_interpolation_is_exact_for_linear_signals(clean_nmea: Path) -> None:
    result = convert_nmea(clean_nmea)
    assert (result.skipped_lines, result.checksum_failures) == (0, 0)
    assert len(result.logs) == 2
    _, fixes = nmea_trial(corrupt=False)
    plane = TangentPlane(ORIGIN_LAT, ORIGIN_LON)
    for log in result.logs:
        t = log.time_s
        lat = np.array([fixes[int(k)][0] for k in t])
        lon = np.array([fixes[int(k)][1] for k in t])
        north = plane.north_azimuth_rad(lat, lon)
        # the meridian convergence is applied (~0.01 deg at 800 m) and agrees with PROJ's
        np.testing.assert_allclose(north, np.radians(_north_azimuth_deg(lat, lon)), atol=1e-9)
        heading = np.radians(heading_true_deg(t)) + north
        # continuous across North (340 -> 360 -> 20 deg), starting within [0, 2π)
        assert 0.0 <= log.heading_rad[0] < 2 * np.pi
        np.testing.assert_allclose(
            log.heading_rad - log.heading_rad[0], heading - heading[0], rtol=0, atol=1e-12
        )
        np.testing.assert_allclose(_wrapped(log.heading_rad - heading), 0.0, atol=1e-12)
        np.testing.assert_allclose(log.rudder_rad, np.radians(rudder_deg(t)), rtol=0, atol=1e-12)
        np.testing.assert_allclose(log.n_rps, rpm(t) / 60.0, rtol=0, atol=1e-12)
    assert np.max(np.abs(np.degrees(north))) > 5e-3


def test_the_first_and_last_fixes_are_kept(clean_nmea: Path) -> None:
    # Each second: the fix, then HDT (+0.2 s), RSA (+0.4 s), HDT (+0.6 s), RPM (+0.8 s).
    # The sensor lines of the first fix get times after it; those after the last fix
    # have no time stamp after them and are dropped. Both fixes are kept, the sensors
    # extrapolated along their edge lines (exact for these linear signals).
    result = convert_nmea(clean_nmea)
    first, second = result.logs
    assert first.time_s[0] == 0.0 and second.time_s[-1] == DURATION_S - 1
    assert (first.x_m[0], first.y_m[0]) == (0.0, 0.0)  # the first fix is the origin
    for log, i in ((first, 0), (second, -1)):
        t = log.time_s[i]
        assert log.rudder_rad[i] == pytest.approx(math.radians(rudder_deg(t)), abs=1e-12)
        assert log.n_rps[i] == pytest.approx(rpm(t) / 60.0, abs=1e-12)
    assert (
        "extrapolated linearly to the fix just before a stream's first or after its last "
        "sample (within one of its sample intervals): heading by up to 0.4 s, rudder angle "
        "by up to 0.6 s, propeller speed by up to 0.8 s"
    ) in result.notes


def _sparse_csv(tmp_path: Path, fix_times: list[float], heading_times: list[float]) -> Path:
    """Fixes (with rudder and rpm) and headings (0.5 deg/s) at their own times."""
    rows = ["time_s,lat_deg,lon_deg,heading_deg,rudder_deg,rpm"]
    for t in sorted(set(fix_times) | set(heading_times)):
        lat, lon = _track(t) if t in fix_times else ("", "")
        heading = f"{0.5 * t!r}" if t in heading_times else ""
        sensors = f"{0.1 * t!r},{60 + t!r}" if t in fix_times else ","
        rows.append(f"{t!r},{lat},{lon},{heading},{sensors}")
    return _write_csv(tmp_path, rows)


@pytest.mark.parametrize(
    ("first_heading_s", "interval_s", "start_s"),
    [
        pytest.param(2.5, 1.0, 2.0, id="0.5 s after a fix, 1 s interval: back to it"),
        pytest.param(2.25, 0.25, 2.0, id="0.25 s after a fix, 0.25 s interval: back to it"),
        pytest.param(1.6, 0.5, 2.0, id="0.6 s after a fix, 0.5 s interval: not"),
        pytest.param(2.0, 1.0, 2.0, id="at a fix: no extrapolation needed"),
    ],
)
def test_a_stream_is_extrapolated_to_the_fix_before_it_within_one_interval(
    tmp_path: Path, first_heading_s: float, interval_s: float, start_s: float
) -> None:
    fixes = [float(t) for t in range(20)]
    headings = [first_heading_s + interval_s * k for k in range(round(16 / interval_s))]
    (log,) = convert_latlon_csv(_sparse_csv(tmp_path, fixes, headings)).logs
    assert log.time_s[0] == start_s  # never further back than one fix
    heading = np.degrees(log.heading_rad - _north_azimuth_deg_rad(log))
    np.testing.assert_allclose(heading, 0.5 * log.time_s, atol=1e-9)


def test_extrapolation_does_not_bridge_a_gap(tmp_path: Path) -> None:
    # Headings every 4.5 s with a 7 s gap (> max_gap_s = 5 s) between 16.5 and 23.5 s;
    # fixes every 4 s. Each side may reach at most max_gap_s / 2 = 2.5 s towards the
    # other, so neither reaches the fix at 20 s and the split stays.
    fixes = [4.0 * k for k in range(11)]
    headings = [3.0, 7.5, 12.0, 16.5, 23.5, 28.0, 32.5, 37.0]
    result = convert_latlon_csv(_sparse_csv(tmp_path, fixes, headings), min_samples=2)
    assert [list(log.time_s) for log in result.logs] == [
        [4.0, 8.0, 12.0, 16.0],
        [24.0, 28.0, 32.0, 36.0],
    ]
    assert result.gaps == ((16.5, 23.5),)


def test_rate_hz_resamples_on_an_aligned_grid(clean_nmea: Path) -> None:
    result = convert_nmea(clean_nmea, rate_hz=4.0)
    by_fix = convert_nmea(clean_nmea)
    first, second = result.logs
    # first rpm at 0.8 s: extrapolated back to the grid time before it (0.75 s), not
    # further; the last sensor lines time-stamped are those before the last fix (159 s):
    # the rudder at 158.4 s, extrapolated to 158.5 s, ends the second piece
    assert first.time_s[0] == 0.75 and first.time_s[-1] == 40.0
    assert second.time_s[0] == 50.0 and second.time_s[-1] == 158.5
    for log, fixed in zip(result.logs, by_fix.logs, strict=True):
        np.testing.assert_allclose(np.diff(log.time_s), 0.25, rtol=0, atol=1e-12)
        np.testing.assert_allclose(log.n_rps, rpm(log.time_s) / 60.0, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            log.rudder_rad, np.radians(rudder_deg(log.time_s)), rtol=0, atol=1e-12
        )
        # positions: linear between the fixes
        inside = log.time_s <= fixed.time_s[-1]
        np.testing.assert_allclose(
            log.x_m[inside], np.interp(log.time_s[inside], fixed.time_s, fixed.x_m), atol=1e-9
        )


def test_corrupt_nmea_counts_skips_and_splits_at_the_gap() -> None:
    result = convert_nmea(DATA / "trial.nmea", vessel="test ship", length_m=12.5)

    assert isinstance(result, ConversionResult)
    assert result.checksum_failures == 3
    assert result.skipped_lines == 4
    assert result.gaps == ((40.0, 50.0),)
    assert result.time_origin_utc == "2024-05-17T23:58:30.000Z"
    # from the first fix (0 s; its sensor lines follow it, at 0.2 to 0.8 s) to the last
    # (159 s; the sensor lines after it are not time-stamped); the fix at 63 s failed its
    # checksum
    assert [log.n_samples for log in result.logs] == [41, 109]
    first, second = result.logs
    np.testing.assert_array_equal(first.time_s, np.arange(0.0, 41.0))
    np.testing.assert_array_equal(second.time_s, np.setdiff1d(np.arange(50.0, 160.0), [63.0]))
    # across midnight (t = 90 s, GGA only until the RMC at 155 s) time stays continuous
    assert np.all(np.diff(second.time_s) <= 2.0)
    notes = " | ".join(result.notes)
    assert "gap: no position fixes for 10.0 s (t = 40.0 to 50.0 s" in notes
    assert "sentences without a checksum (skipped): 1" in notes
    assert "GGA sentences without a fix (quality 0): 9" in notes
    assert "other sentences ignored: VTG 1" in notes
    # the skipped heading lines do not disturb linear signals
    for log in result.logs:
        np.testing.assert_allclose(log.rudder_rad, np.radians(rudder_deg(log.time_s)), atol=1e-12)
    metadata = dict(first.metadata)
    assert metadata["vessel"] == "test ship"
    assert metadata["length_m"] == "12.5"
    assert float(metadata["origin_lat_deg"]) == result.origin_lat_deg
    assert float(metadata["origin_lon_deg"]) == result.origin_lon_deg
    assert metadata["time_origin_utc"] == "2024-05-17T23:58:30.000Z"
    assert metadata["projection"].startswith("+proj=aeqd +lat_0=63.4305")
    assert metadata["source"].startswith("trial.nmea (NMEA 0183), piece 1 of 2")
    assert "4 unparsable lines and 3 checksum failures skipped" in metadata["source"]


def test_converted_logs_read_back(tmp_path: Path) -> None:
    result = convert_nmea(DATA / "trial.nmea", vessel="test ship")
    for k, log in enumerate(result.logs, start=1):
        path = tmp_path / f"trial_{k}.csv"
        write_log(path, log)
        back = read_log(path)
        np.testing.assert_array_equal(back.time_s, log.time_s)
        np.testing.assert_array_equal(back.x_m, log.x_m)
        np.testing.assert_allclose(back.heading_rad, log.heading_rad, rtol=1e-12)
        np.testing.assert_allclose(back.rudder_rad, log.rudder_rad, rtol=1e-12, atol=1e-15)
        assert dict(back.metadata) == dict(log.metadata)


def test_rudder_positive_port_flips_the_sign(clean_nmea: Path) -> None:
    starboard = convert_nmea(clean_nmea)
    port = convert_nmea(clean_nmea, rudder_positive="port")
    for a, b in zip(starboard.logs, port.logs, strict=True):
        np.testing.assert_array_equal(b.rudder_rad, -a.rudder_rad)
        np.testing.assert_array_equal(b.heading_rad, a.heading_rad)
    assert "rudder positive to port in the input" in port.logs[0].metadata["source"]


def test_max_gap_s_longer_than_the_gap_gives_one_log(clean_nmea: Path) -> None:
    result = convert_nmea(clean_nmea, max_gap_s=20.0)
    assert len(result.logs) == 1
    assert result.gaps == ()
    assert 40.0 in result.logs[0].time_s and 50.0 in result.logs[0].time_s


def test_too_short_pieces_are_dropped_with_a_note(clean_nmea: Path) -> None:
    result = convert_nmea(clean_nmea, min_samples=50)
    assert [log.n_samples for log in result.logs] == [110]
    assert any(
        "dropped t = 0.0 to 40.0 s: 41 samples, fewer than min_samples = 50" in note
        for note in result.notes
    )
    assert "piece 1 of 1" in result.logs[0].metadata["source"]


def _nmea_file(tmp_path: Path, lines: list[str], name: str = "rec.nmea") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n", encoding="ascii")
    return path


def _simple_nmea(n: int = 20, *, date: bool = True, start: str = "120000") -> list[str]:
    """A 1 Hz recording with one line of each sensor per second."""
    base = dt.datetime.strptime(start, "%H%M%S")
    lines = []
    for k in range(n):
        hhmmss = (base + dt.timedelta(seconds=k)).strftime("%H%M%S")
        lat_text, _ = _dm(_track(k)[0], 2)
        lon_text, _ = _dm(_track(k)[1], 3)
        if date and k == 0:
            lines.append(_sentence(f"GPRMC,{hhmmss},A,{lat_text},N,{lon_text},E,9,30,170524,,"))
        else:
            lines.append(_sentence(f"GPGGA,{hhmmss},{lat_text},N,{lon_text},E,1,9,1,0,M,0,M,,"))
        lines += [
            _sentence(f"HEHDT,{10.0 + k},T"),
            _sentence(f"IIRSA,{k * 0.5},A,,"),
            _sentence(f"IIRPM,S,0,{60 + k},,A"),
        ]
    return lines


def test_a_recording_without_rpm_takes_the_trials_constant(tmp_path: Path) -> None:
    """A bridge's NMEA with no RPM sentence: an error that names ``--rpm``; with it the
    constant at every fix, noted and in the source line; beside logged RPM an error."""
    logged = _simple_nmea()
    without = _nmea_file(tmp_path, [line for line in logged if "RPM" not in line])
    with pytest.raises(LogFormatError) as excinfo:
        convert_nmea(without)
    assert str(excinfo.value) == (
        f"{without}: no propeller speed samples; expected RPM sentences of a shaft (source S) "
        "with status A (or the trial's constant shaft speed: convert --rpm N)"
    )
    result = convert_nmea(without, constant_n_rps=1.75)
    (log,) = result.logs
    np.testing.assert_array_equal(log.n_rps, np.full(20, 1.75))
    assert "propeller speed: none in the recording; 105 rpm at every fix, as given (--rpm)" in (
        result.notes
    )
    assert log.metadata["source"].endswith("; propeller speed 105 rpm as given, not logged")
    with pytest.raises(LogFormatError, match=r"the recording logs the propeller speed \(RPM "):
        convert_nmea(_nmea_file(tmp_path, logged, "logged.nmea"), constant_n_rps=1.75)
    with pytest.raises(ValueError, match="constant_n_rps must be a propeller speed above 0"):
        convert_nmea(without, constant_n_rps=0.0)


def test_a_latlon_csv_without_an_rpm_column_takes_the_trials_constant(tmp_path: Path) -> None:
    rows = [row.rsplit(",", 1)[0] for row in _csv_rows()]
    path = _write_csv(tmp_path, rows)
    with pytest.raises(LogFormatError, match=r"expected an rpm column \(or the trial's constant"):
        convert_latlon_csv(path)
    (log,) = convert_latlon_csv(path, constant_n_rps=0.5).logs
    np.testing.assert_array_equal(log.n_rps, np.full(20, 0.5))


def test_cli_convert_rpm(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    without = _nmea_file(tmp_path, [line for line in _simple_nmea() if "RPM" not in line])
    out = tmp_path / "log.csv"
    assert main(["convert", str(without), "--rpm", "84", "--quiet", "-o", str(out)]) == 0
    np.testing.assert_allclose(read_log(out).n_rps, 1.4, rtol=1e-15)
    capsys.readouterr()
    with pytest.raises(SystemExit) as excinfo:
        main(["convert", str(without), "--rpm", "0", "-o", str(tmp_path / "x.csv")])
    assert excinfo.value.code == 2
    assert "argument --rpm: expected a number above 0 and at most 6000 rpm, got '0'" in (
        capsys.readouterr().err
    )
    assert not (tmp_path / "x.csv").exists()


def _as_gns(line: str, modes: str) -> str:
    """A GGA sentence's fix as a GNS sentence with the mode per system ``modes``."""
    fields = line[1 : line.index("*")].split(",")
    talker = fields[0][:2]
    return _sentence(f"{talker}GNS,{','.join(fields[1:6])},{modes},09,0.9,12.0,41.0,,")


def test_gns_fixes_convert_as_the_gga_ones(tmp_path: Path, clean_nmea: Path) -> None:
    """A multi-constellation receiver's GNS in place of every GGA: the same logs; a fix
    is valid when any system has one (``DN``: differential GPS, no GLONASS)."""
    lines, _ = nmea_trial(corrupt=False)
    gns = [
        _as_gns(line, "NN" if ",,,,,0," in line else "DN") if "GGA," in line else line
        for line in lines
    ]
    result = convert_nmea(_nmea_file(tmp_path, gns))
    expected = convert_nmea(clean_nmea)
    assert len(result.logs) == len(expected.logs) == 2
    for log, reference in zip(result.logs, expected.logs, strict=True):
        for name in ("time_s", "x_m", "y_m", "heading_rad", "rudder_rad", "n_rps"):
            np.testing.assert_array_equal(getattr(log, name), getattr(reference, name))
    assert result.time_origin_utc == expected.time_origin_utc
    assert "GNS sentences without a fix (mode N): 9" in " | ".join(result.notes)


def test_a_gns_mode_that_is_none_of_nmea_s_is_a_malformed_sentence(tmp_path: Path) -> None:
    lines = [_as_gns(line, "AN") if "GGA," in line else line for line in _simple_nmea(20)]
    lines[4 * 7] = _as_gns(_simple_nmea(20)[4 * 7], "A?")
    result = convert_nmea(_nmea_file(tmp_path, lines))
    assert result.skipped_lines == 1
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.setdiff1d(np.arange(20.0), [7.0]))


def _as_hdg(line: str, deviation: str, variation: str) -> str:
    """An HDT sentence's true heading as the magnetic one of an HDG sentence.

    ``deviation`` and ``variation`` as HDG writes them (``1.5,E``, ``12.6,W``, or ``,``).
    """
    true_deg = float(line[line.index("HDT,") + 4 : line.index(",T")])
    east = sum(
        float(value) * (1.0 if side == "E" else -1.0)
        for value, side in (deviation.split(","), variation.split(","))
        if value
    )
    return _sentence(f"HCHDG,{(true_deg - east) % 360.0:.3f},{deviation},{variation}")


def test_hdg_magnetic_headings_made_true_when_there_is_no_hdt(
    tmp_path: Path, clean_nmea: Path
) -> None:
    """A magnetic compass's HDG in place of every HDT: its heading plus the deviation and
    the variation, east positive, is the true heading (to the text's 0.001 deg)."""
    lines, _ = nmea_trial(corrupt=False)
    magnetic = [_as_hdg(line, "1.5,E", "12.6,W") if "HDT," in line else line for line in lines]
    result = convert_nmea(_nmea_file(tmp_path, magnetic))
    expected = convert_nmea(clean_nmea)
    for log, reference in zip(result.logs, expected.logs, strict=True):
        np.testing.assert_allclose(
            log.heading_rad, reference.heading_rad, rtol=0, atol=math.radians(0.002)
        )
    assert any(note.startswith("heading from HDG") for note in result.notes)
    # beside HDT it is not used; without a variation it cannot be made true
    both = [_as_hdg(line, ",", "3.0,E") for line in lines if "HDT," in line] + lines
    result = convert_nmea(_nmea_file(tmp_path, both, "both.nmea"))
    assert "HDG headings ignored (HDT or THS used): 320" in result.notes
    unvaried = [_as_hdg(line, "1.5,E", ",") if "HDT," in line else line for line in lines]
    with pytest.raises(LogFormatError, match=r"no heading samples; expected HDT or THS .*HDG"):
        convert_nmea(_nmea_file(tmp_path, unvaried, "unvaried.nmea"))


def test_gga_only_time_rolls_over_midnight_without_a_date(tmp_path: Path) -> None:
    path = _nmea_file(tmp_path, _simple_nmea(30, date=False, start="235950"))
    result = convert_nmea(path)
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.arange(0.0, 30.0))
    assert result.time_origin_utc is None
    assert "time_origin_utc" not in log.metadata
    assert any("no date" in note for note in result.notes)


def test_sensor_time_is_interpolated_over_the_line_number(tmp_path: Path) -> None:
    # per second: fix, HDT, RSA, RPM -> HDT at +0.25 s, RSA at +0.5 s, RPM at +0.75 s
    result = convert_nmea(_nmea_file(tmp_path, _simple_nmea(20)))
    (log,) = result.logs
    t = log.time_s
    np.testing.assert_allclose(np.degrees(log.rudder_rad), 0.5 * (t - 0.5), atol=1e-12)
    np.testing.assert_allclose(log.n_rps * 60.0, 60.0 + (t - 0.75), atol=1e-12)
    # the RPM line of second 19 is after the last fix: extrapolated from 17.75 and 18.75 s
    assert (log.time_s[0], log.time_s[-1]) == (0.0, 19.0)


def test_a_wrong_time_costs_only_its_own_sentence(tmp_path: Path) -> None:
    lines = _simple_nmea(20)
    lines[4 * 10] = lines[4 * 10].replace("GPGGA,120010", "GPGGA,180010")[:-3]  # 6 h ahead
    lines[4 * 10] = _sentence(lines[4 * 10][1:])
    lines.insert(4 * 5 + 1, lines[4 * 5])  # the fix of second 5 twice
    result = convert_nmea(_nmea_file(tmp_path, lines))
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.setdiff1d(np.arange(0.0, 20.0), [10.0]))
    assert "fixes with a time out of order (dropped): 1" in result.notes
    assert "fixes at the time of another fix, e.g. GGA and RMC (unused): 1" in result.notes
    assert "time stamps repeated or out of order, not used for timing: 2" in result.notes


def test_several_shafts_need_a_choice(tmp_path: Path) -> None:
    lines = _simple_nmea(20)
    lines += [_sentence(f"IIRPM,S,2,{70 + k},,A") for k in range(3)]
    path = _nmea_file(tmp_path, lines)
    with pytest.raises(LogFormatError, match=r"RPM sentences for several shafts \(0, 2\)"):
        convert_nmea(path)
    # at the first fix (0 s): 60 rpm at 0.75 s, 61 rpm at 1.75 s, extrapolated
    assert convert_nmea(path, shaft=0).logs[0].n_rps[0] == pytest.approx(59.25 / 60.0)
    with pytest.raises(LogFormatError, match=r"no RPM sentences for shaft 3; expected one of"):
        convert_nmea(path, shaft=3)


def test_sentences_without_checksum_are_skipped_unless_allowed(tmp_path: Path) -> None:
    lines = [line.rsplit("*", 1)[0] if "HDT" in line else line for line in _simple_nmea(20)]
    path = _nmea_file(tmp_path, lines)
    with pytest.raises(LogFormatError, match=r"no heading samples; expected HDT or THS"):
        convert_nmea(path)
    assert convert_nmea(path, require_checksum=False).logs[0].n_samples == 20


def test_ths_heading_and_invalid_readings(tmp_path: Path) -> None:
    lines = [
        _sentence(f"HETHS,{line.split(',')[1]},A") if "HDT" in line else line
        for line in _simple_nmea(20)
    ]
    lines[1] = _sentence("HETHS,99.0,V")  # invalid mode: ignored
    lines[2] = _sentence("IIRSA,5.0,V,,")  # invalid status: ignored
    result = convert_nmea(_nmea_file(tmp_path, lines))
    (log,) = result.logs
    assert result.skipped_lines == 0
    notes = " | ".join(result.notes)
    assert "THS headings with mode V, not A (ignored): 1" in notes
    assert "RSA rudder angles with status V (ignored): 1" in notes
    heading = np.degrees(log.heading_rad - _north_azimuth_deg_rad(log))
    np.testing.assert_allclose(heading, 10.0 + (log.time_s - 0.25), atol=1e-9)


def test_an_rpm_beyond_the_floating_point_range_is_a_malformed_sentence(tmp_path: Path) -> None:
    lines = _simple_nmea(20)
    lines[4 * 5 + 3] = _sentence("IIRPM,S,0," + "9" * 400 + ".0,,A")  # float() gives inf
    lines[4 * 6 + 3] = _sentence("IIRPM,S,0,7000.0,,A")  # beyond the FMU's ±6000 rpm
    result = convert_nmea(_nmea_file(tmp_path, lines))
    (log,) = result.logs
    assert result.skipped_lines == 2  # counted and skipped like any malformed field
    np.testing.assert_allclose(log.n_rps * 60.0, 60.0 + (log.time_s - 0.75), atol=1e-12)


def _dated_nmea(
    start: dt.datetime, n: int = 20, *, leap_at: int | None = None, zda_shift_days: int = 0
) -> list[str]:
    """A 1 Hz RMC recording from ``start``; ``leap_at``: that second is 23:59:60.

    With ``zda_shift_days``, each fix is followed by a ZDA whose date is that many days
    early (a GPS week-number rollover: 7168).
    """
    lines = []
    for k in range(n):
        stamp = start + dt.timedelta(seconds=k - (leap_at is not None and k > leap_at))
        hhmmss = stamp.strftime("%H%M%S")
        if k == leap_at:
            stamp -= dt.timedelta(seconds=1)  # 23:59:60 belongs to the day it ends
            hhmmss = "235960"
        lat_text, _ = _dm(_track(k)[0], 2)
        lon_text, _ = _dm(_track(k)[1], 3)
        date = stamp.strftime("%d%m%y")
        lines.append(_sentence(f"GPRMC,{hhmmss},A,{lat_text},N,{lon_text},E,9,30,{date},,"))
        if zda_shift_days:
            zda = stamp.date() - dt.timedelta(days=zda_shift_days)
            lines.append(
                _sentence(f"GPZDA,{hhmmss}.00,{zda.day:02d},{zda.month:02d},{zda.year},00,00")
            )
        lines += [
            _sentence(f"HEHDT,{10.0 + k},T"),
            _sentence(f"IIRSA,{k * 0.5},A,,"),
            _sentence(f"IIRPM,S,0,{60 + k},,A"),
        ]
    return lines


@pytest.mark.parametrize(
    ("start", "leap_at", "origin"),
    [
        (dt.datetime(2016, 12, 31, 23, 59, 50), 10, "2016-12-31T23:59:50.000Z"),
        (dt.datetime(2016, 12, 31, 23, 59, 59), 1, "2016-12-31T23:59:59.000Z"),
    ],
)
def test_a_leap_second_is_one_second_after_23_59_59(
    tmp_path: Path, start: dt.datetime, leap_at: int, origin: str
) -> None:
    result = convert_nmea(_nmea_file(tmp_path, _dated_nmea(start, leap_at=leap_at)))
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.arange(20.0))  # no fix lost, none 1 s short
    assert result.time_origin_utc == origin
    assert any(note.startswith("leap second (23:59:60) on line ") for note in result.notes)


def test_the_time_origin_after_a_leap_second_is_its_utc_time(tmp_path: Path) -> None:
    # A ZDA at 23:59:59 and 23:59:60 dates the file; the fixes start after the leap second.
    lines = [
        _sentence("GPZDA,235959.00,31,12,2016,00,00"),
        _sentence("GPZDA,235960.00,31,12,2016,00,00"),
        *_dated_nmea(dt.datetime(2017, 1, 1, 0, 0, 1)),
    ]
    result = convert_nmea(_nmea_file(tmp_path, lines))
    assert result.time_origin_utc == "2017-01-01T00:00:01.000Z"
    np.testing.assert_array_equal(result.logs[0].time_s, np.arange(20.0))


def test_a_second_of_60_outside_23_59_is_malformed(tmp_path: Path) -> None:
    lines = _simple_nmea(20)
    lines[4 * 5] = _sentence(lines[4 * 5][1:-3].replace("GPGGA,120005", "GPGGA,120060"))
    result = convert_nmea(_nmea_file(tmp_path, lines))
    assert result.skipped_lines == 1
    assert 5.0 not in result.logs[0].time_s


def test_rmc_dates_go_on_from_2099_into_2100(tmp_path: Path) -> None:
    lines = _dated_nmea(dt.datetime(2099, 12, 31, 23, 59, 50))
    result = convert_nmea(_nmea_file(tmp_path, lines))
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.arange(20.0))
    assert result.time_origin_utc == "2099-12-31T23:59:50.000Z"


@pytest.mark.parametrize("rollovers", [1, 2])
def test_zda_dates_off_by_gps_week_rollovers_yield_to_the_rmc_dates(
    tmp_path: Path, rollovers: int
) -> None:
    start = dt.datetime(2024, 5, 17, 23, 59, 50)  # across midnight
    lines = _dated_nmea(start, zda_shift_days=1024 * 7 * rollovers)
    result = convert_nmea(_nmea_file(tmp_path, lines))
    (log,) = result.logs
    np.testing.assert_array_equal(log.time_s, np.arange(20.0))
    assert result.time_origin_utc == "2024-05-17T23:59:50.000Z"
    assert (
        "ZDA dates off the RMC dates by a multiple of 1024 weeks (GPS week-number rollover), "
        "corrected to the RMC dates: 20"
    ) in result.notes


def test_zda_dates_that_disagree_with_the_rmc_dates_otherwise_are_dropped(tmp_path: Path) -> None:
    lines = _dated_nmea(dt.datetime(2024, 5, 17, 12, 0, 0), zda_shift_days=3)
    result = convert_nmea(_nmea_file(tmp_path, lines))
    np.testing.assert_array_equal(result.logs[0].time_s, np.arange(20.0))
    assert "ZDA dates that disagree with the RMC dates (dropped): 20" in result.notes


def _north_azimuth_deg_rad(log: ManeuverLog) -> np.ndarray:
    """North azimuth [rad] at a log's positions (inverse projection)."""
    plane = TangentPlane(ORIGIN_LAT, ORIGIN_LON)
    inverse = pyproj.Transformer.from_crs(plane.proj_string, "EPSG:4326", always_xy=True)
    lon, lat = inverse.transform(log.y_m, log.x_m)
    return np.radians(_north_azimuth_deg(np.asarray(lat), np.asarray(lon)))


@pytest.mark.parametrize(
    ("lines", "message"),
    [
        pytest.param(["hello", "world"], r"no NMEA 0183 sentence with a valid checksum", id="text"),
        pytest.param(
            [_sentence("HEHDT,10.0,T"), _sentence("GPGGA,120000,,,,,0,0,,,,,,,")],
            r"no valid position fix; expected GGA sentences with a fix quality above 0",
            id="no fix",
        ),
        pytest.param(
            [_sentence("HEHDT,10.0,T"), _sentence("GNGNS,120000,,,,,NNN,00,,,,,")],
            r"no valid position fix; expected .* or GNS sentences with a mode other than N",
            id="no GNS fix",
        ),
        pytest.param(
            [line for line in _simple_nmea(20) if "RSA" not in line],
            r"no rudder angle samples; expected RSA sentences with status A$",
            id="no rudder",
        ),
    ],
)
def test_unusable_nmea_is_an_error(tmp_path: Path, lines: list[str], message: str) -> None:
    path = _nmea_file(tmp_path, lines)
    with pytest.raises(LogFormatError, match=message) as info:
        convert_nmea(path)
    assert info.value.path == str(path)
    assert "\n" not in str(info.value)


@settings(max_examples=30, deadline=None)
@given(
    junk=st.lists(
        st.tuples(
            st.integers(0, 79), st.binary(max_size=40) | st.text(max_size=40).map(str.encode)
        ),
        max_size=10,
    )
)
def test_junk_lines_are_skipped_never_fatal(junk: list[tuple[int, bytes]]) -> None:
    lines = [line.encode() for line in _simple_nmea(20)]
    for index, text in junk:
        lines[index] = text.replace(b"\n", b" ")
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "junk.nmea"
        path.write_bytes(b"\n".join(lines))
        try:
            result = convert_nmea(path, min_samples=2)
        except LogFormatError as error:
            assert "\n" not in str(error)
        else:
            assert result.skipped_lines + result.checksum_failures <= len(junk)
            for log in result.logs:
                assert np.all(np.isfinite(log.x_m))


# --------------------------------------------------------------------------- CSV


def test_latlon_csv_file_converts_with_iso_times_and_sparse_columns() -> None:
    result = convert_latlon_csv(DATA / "trial_latlon.csv", vessel="test ship")
    (log,) = result.logs
    assert result.time_origin_utc == "2024-05-17T23:58:30.000Z"
    assert (result.skipped_lines, result.checksum_failures, result.gaps) == (0, 0, ())
    # rpm is logged every 2 s, from 0 to 28 s: the log covers the fixes in between
    np.testing.assert_array_equal(log.time_s, np.arange(0.0, 28.5, 0.5))
    np.testing.assert_allclose(log.n_rps, rpm(log.time_s) / 60.0, atol=1e-12)
    np.testing.assert_allclose(log.rudder_rad, np.radians(rudder_deg(log.time_s)), atol=1e-12)
    lat = np.array([_track(t)[0] for t in log.time_s])
    lon = np.array([_track(t)[1] for t in log.time_s])
    x, y = _expected_xy(np.round(lat, 9), np.round(lon, 9))
    np.testing.assert_allclose(log.x_m, x, atol=1e-6)
    np.testing.assert_allclose(log.y_m, y, atol=1e-6)
    heading = np.radians(heading_true_deg(log.time_s) + _north_azimuth_deg(lat, lon))
    np.testing.assert_allclose(_wrapped(log.heading_rad - heading), 0.0, atol=1e-8)


@pytest.mark.parametrize(
    ("column", "unit", "scale"),
    [
        ("heading_deg", None, 1.0),
        ("heading_rad", None, 180.0 / math.pi),
        ("heading", None, 1.0),
        ("heading", "deg", 1.0),
        ("heading", "rad", 180.0 / math.pi),
        ("heading_rad", "rad", 180.0 / math.pi),
    ],
)
def test_heading_unit(tmp_path: Path, column: str, unit: str | None, scale: float) -> None:
    path = _write_csv(tmp_path, _csv_rows(heading=column))
    (log,) = convert_latlon_csv(path, heading_unit=unit).logs  # type: ignore[arg-type]
    heading = log.heading_rad - _north_azimuth_deg_rad(log)
    expected = np.radians(scale * 0.1 * log.time_s)
    np.testing.assert_allclose(_wrapped(heading - expected), 0.0, atol=1e-9)


def test_heading_unit_contradicting_the_column_name_is_an_error(tmp_path: Path) -> None:
    path = _write_csv(tmp_path, _csv_rows(heading="heading_deg"))
    with pytest.raises(LogFormatError) as info:
        convert_latlon_csv(path, heading_unit="rad")
    assert str(info.value) == (
        f"{path}:1: column 'heading_deg': its name says deg, but heading_unit='rad' was "
        "given; expected a column 'heading_rad', or 'heading' (unit from heading_unit)"
    )
    assert info.value.column == "heading_deg"


def test_csv_rudder_sign_and_radians(tmp_path: Path) -> None:
    path = _write_csv(tmp_path, _csv_rows(rudder="rudder_rad"))
    starboard = convert_latlon_csv(path).logs[0]
    port = convert_latlon_csv(path, rudder_positive="port").logs[0]
    np.testing.assert_allclose(starboard.rudder_rad, 0.02 + 0.005 * starboard.time_s, atol=1e-12)
    np.testing.assert_array_equal(port.rudder_rad, -starboard.rudder_rad)


def test_a_meridian_run_off_the_origin_has_heading_along_the_track(tmp_path: Path) -> None:
    # the first fix (origin) and then a run due true North 5 km East of it at 60 deg N
    lon_east, lat_east, _ = GEOD.fwd(10.0, 60.0, 90.0, 5000.0)
    rows = ["time_s,lat,lon,heading,rudder_deg,rpm", "0,60.0,10.0,0.0,0,60"]
    for i in range(1, 15):
        lat = lat_east + 1e-4 * i
        rows.append(f"{i},{lat!r},{lon_east!r},0.0,0,60")
    (log,) = convert_latlon_csv(_write_csv(tmp_path, rows), max_gap_s=2.0).logs
    track = np.arctan2(np.diff(log.y_m[1:]), np.diff(log.x_m[1:]))
    np.testing.assert_allclose(_wrapped(log.heading_rad[2:] - track), 0.0, atol=1e-6)
    assert math.degrees(float(track[0])) == pytest.approx(-0.0776, abs=2e-4)


@pytest.mark.parametrize(
    ("rows", "line", "column", "message"),
    [
        pytest.param(
            ["time_s,lat_deg,lon_deg,heading_deg,rpm", "0,1,1,1,1"],
            1,
            None,
            r"missing rudder column; expected one of rudder_deg, rudder_rad in the header",
            id="missing column",
        ),
        pytest.param(
            ["time_s,lat,lat_deg,lon,heading,rudder_deg,rpm"],
            1,
            None,
            r"expected one latitude column, got lat_deg, lat",
            id="two latitude columns",
        ),
        pytest.param(
            [*_csv_rows(3), "3.0,63.5,10.4,1,x,60"],
            5,
            "rudder_deg",
            r"expected a finite number within \[-90, 90\], got 'x'",
            id="text cell",
        ),
        pytest.param(
            [*_csv_rows(3), "3.0,95.0,10.4,1,1,60"],
            5,
            "lat_deg",
            r"expected a finite number within \[-90, 90\], got '95\.0'",
            id="latitude out of range",
        ),
        pytest.param(
            [*_csv_rows(3), "3.0,63.5,10.4,1,95,60"],
            5,
            "rudder_deg",
            r"expected a finite number within \[-90, 90\], got '95'",
            id="rudder beyond 90 deg",
        ),
        pytest.param(
            [*_csv_rows(3, heading="heading_rad"), "3.0,63.5,10.4,1e300,1,60"],
            5,
            "heading_rad",
            r"expected a finite number within \[-628\.319, 628\.319\], got '1e300'",
            id="heading of more than 100 turns",
        ),
        pytest.param(
            [*_csv_rows(3), "2.0,63.5,10.4,1,1,60"],
            5,
            "time_s",
            r"expected strictly increasing time, got '2\.0' after the time on line 4",
            id="time not increasing",
        ),
        pytest.param(
            [*_csv_rows(3), "3.0,63.5,,1,1,60"],
            5,
            "lon_deg",
            r"expected latitude and longitude together or neither, got only one",
            id="latitude without longitude",
        ),
        pytest.param(
            [*_csv_rows(3), "3.0,63.5,10.4,1,1"],
            5,
            None,
            r"expected 6 fields separated by ',' as in the header on line 1, got 5",
            id="short row",
        ),
        pytest.param(
            ["time,lat,lon,heading,rudder_deg,rpm", "17 May 2024,63.5,10.4,1,1,60"],
            2,
            "time",
            r"expected an ISO 8601 date and time like",
            id="not ISO time",
        ),
        pytest.param(
            ["time;lat;lon;heading;rudder_deg;rpm"],
            1,
            None,
            r"expected ',' as the field separator, got ';'",
            id="semicolons",
        ),
        pytest.param(
            ["time_s,lat,lon,heading,rudder_deg,rpm", "0,,,1,1,1", "1,,,1,1,1"],
            None,
            None,
            r"no valid position fix; expected rows with latitude and longitude",
            id="no fix",
        ),
    ],
)
def test_bad_csv_is_an_error_with_line_and_column(
    tmp_path: Path, rows: list[str], line: int | None, column: str | None, message: str
) -> None:
    path = _write_csv(tmp_path, rows)
    with pytest.raises(LogFormatError, match=message) as info:
        convert_latlon_csv(path)
    assert (info.value.path, info.value.line, info.value.column) == (str(path), line, column)
    assert "\n" not in str(info.value)


def test_iso_times_with_offsets_and_without(tmp_path: Path) -> None:
    rows = ["time,lat,lon,heading,rudder_deg,rpm"]
    for i in range(12):
        lat, lon = _track(float(i))
        stamp = dt.datetime(2024, 5, 18, 1, 58, 30) + dt.timedelta(seconds=i)  # +02:00
        text = stamp.isoformat() + ("+02:00" if i % 2 else "")  # naive = UTC, so no offset
        if not i % 2:
            text = (stamp - dt.timedelta(hours=2)).isoformat()
        rows.append(f"{text},{lat},{lon},1,1,60")
    result = convert_latlon_csv(_write_csv(tmp_path, rows))
    np.testing.assert_array_equal(result.logs[0].time_s, np.arange(12.0))
    assert result.time_origin_utc == "2024-05-17T23:58:30.000Z"


STRANGE = ["", "nan", "inf", "1e308", "-1e400", "x", "١٢", "1,5", '"', "95", "-200", "\t"]


@settings(max_examples=40, deadline=None)
@given(
    cells=st.lists(
        st.tuples(st.integers(1, 15), st.integers(0, 5), st.sampled_from(STRANGE)), max_size=4
    )
)
def test_odd_csv_cells_are_an_error_or_convert(cells: list[tuple[int, int, str]]) -> None:
    rows = _csv_rows(15)
    for row, column, text in cells:
        fields = rows[row].split(",")
        fields[column] = text
        rows[row] = ",".join(fields)
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "odd.csv"
        path.write_text("\n".join(rows) + "\n", encoding="utf-8")
        try:
            result = convert_latlon_csv(path, min_samples=2)
        except LogFormatError as error:
            assert "\n" not in str(error)
            assert error.line is None or 2 <= error.line <= 16
            return
    for log in result.logs:
        for values in (log.x_m, log.y_m, log.heading_rad, log.rudder_rad, log.n_rps):
            assert np.all(np.isfinite(values))
        assert np.all(np.abs(log.rudder_rad) <= np.pi / 2)


# --------------------------------------------------------------------------- detection, CLI


def test_detect_format() -> None:
    assert detect_format((DATA / "trial.nmea").read_bytes()) == "nmea"
    assert detect_format((DATA / "trial_latlon.csv").read_bytes()) == "csv"
    with pytest.raises(LogFormatError, match=r"got neither \(it has x_m and y_m columns: it is"):
        detect_format(b"time_s,x_m,y_m,heading_deg,rudder_deg,rpm\n", "log.csv")
    with pytest.raises(LogFormatError, match=r"^x\.bin: expected an NMEA 0183 recording"):
        detect_format(bytes(range(256)), "x.bin")
    result = convert_file(DATA / "trial_latlon.csv", heading_unit="deg")
    assert len(result.logs) == 1
    nmea = convert_file(DATA / "trial.nmea", heading_unit="rad")
    assert "heading_unit='rad' ignored: NMEA headings are in degrees" in nmea.notes


def test_output_paths(tmp_path: Path) -> None:
    assert output_paths(tmp_path / "out.csv", "trial", 1) == [tmp_path / "out.csv"]
    assert output_paths(tmp_path / "out.csv", "trial", 2) == [
        tmp_path / "out_1.csv",
        tmp_path / "out_2.csv",
    ]
    assert output_paths(tmp_path / "dir", "trial", 1) == [tmp_path / "dir" / "trial_1.csv"]
    (tmp_path / "odd.csv").mkdir()
    assert output_paths(tmp_path / "odd.csv", "t", 1) == [tmp_path / "odd.csv" / "t_1.csv"]


def test_cli_convert_writes_one_log_per_piece(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "logs"
    status = main(
        [
            "convert",
            str(DATA / "trial.nmea"),
            "-o",
            str(out),
            "--vessel",
            "test ship",
            "--length-m",
            "12.5",
        ]
    )
    captured = capsys.readouterr()
    assert status == 0, captured.err
    assert sorted(p.name for p in out.iterdir()) == ["trial_1.csv", "trial_2.csv"]
    warnings = [line for line in captured.err.splitlines() if line.startswith("warning:")]
    assert warnings == [
        f"warning: {DATA / 'trial.nmea'}: skipped 4 unparsable lines and 3 checksum failures"
    ]
    for k, n in ((1, 41), (2, 109)):
        log = read_log(out / f"trial_{k}.csv")
        assert log.n_samples == n
        assert log.metadata["vessel"] == "test ship"
        assert log.length_m == 12.5
        assert str(out / f"trial_{k}.csv") in captured.out


def test_cli_convert_single_log_to_a_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "run.csv"
    assert main(["convert", str(DATA / "trial_latlon.csv"), "-o", str(target), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert (captured.out, captured.err) == ("", "")
    assert read_log(target).n_samples == 57


def test_cli_convert_bad_input_is_one_line_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    junk = tmp_path / "junk.txt"
    junk.write_text("this is not a recording\n")
    out = tmp_path / "out"
    status = main(["convert", str(DATA / "trial.nmea"), str(junk), "-o", str(out)])
    captured = capsys.readouterr()
    assert status == 1
    assert captured.err.splitlines() == [
        f"error: {junk}: expected an NMEA 0183 recording ('$' sentences) or a CSV file with "
        "latitude and longitude columns (lat_deg/lat/latitude, lon_deg/lon/longitude), got neither"
    ]
    assert not out.exists()


def test_cli_convert_every_piece_too_short_is_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status = main(
        ["convert", str(DATA / "trial.nmea"), "-o", str(tmp_path / "o"), "--min-samples", "500"]
    )
    captured = capsys.readouterr()
    assert status == 1
    assert captured.err.splitlines()[-1].startswith(f"error: {DATA / 'trial.nmea'}: no log")
    assert not (tmp_path / "o").exists()


def test_cli_convert_usage_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    both = [str(DATA / "trial.nmea"), str(DATA / "trial_latlon.csv")]
    assert main(["convert", *both, "-o", str(tmp_path / "x.csv")]) == 2
    assert capsys.readouterr().err == (
        f"error: -o {tmp_path / 'x.csv'}: expected a directory for several inputs\n"
    )
    for argv in (
        ["convert", both[0], "-o", str(tmp_path), "--rate-hz", "0"],
        ["convert", both[0], "-o", str(tmp_path), "--rudder-positive", "up"],
        ["convert", both[0], "-o", str(tmp_path), "--min-samples", "1"],
        ["convert", both[0], "-o", str(tmp_path), "--vessel", "two\nlines"],
    ):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2
    capsys.readouterr()
    assert list(tmp_path.iterdir()) == []


def test_python_m_identifier_convert(tmp_path: Path) -> None:
    process = subprocess.run(
        [
            sys.executable,
            "-m",
            "identifier",
            "convert",
            str(DATA / "trial_latlon.csv"),
            "-o",
            str(tmp_path / "one.csv"),
            "--vessel",
            "x",
        ],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=False,
    )
    assert process.returncode == 0, process.stderr
    assert read_log(tmp_path / "one.csv").metadata["vessel"] == "x"


if __name__ == "__main__":
    write_data_files()
