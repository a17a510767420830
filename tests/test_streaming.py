"""Bounded-memory identification: checkpointed smoother, chunked regression, strided EKF
histories, decimation; and the same coefficients as the in-memory path on a shared log."""

from __future__ import annotations

import dataclasses
import gzip
import json
import math
from pathlib import Path

import numpy as np
import pytest

from fmu_model import ModelParameters, get_model, numeric_model
from fmu_model.kernels import kernel_constants, kernel_module
from identifier import ekf as ekf_module
from identifier import equation_error, preparation, smoothing
from identifier import identify as identify_module
from identifier.ekf import (
    EkfSegment,
    EkfSettings,
    SpeedLogMeasurement,
    ekf_identify,
    sample_windows,
)
from identifier.equation_error import (
    NormalEquations,
    decimation,
    equation_error_fit,
    regression_chunks,
)
from identifier.identify import FitSettings, identify
from identifier.smoothing import smooth_axis, smooth_track
from scenarios.synthesize import MANEUVERS, model_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, read_log

DATA = Path(__file__).parent / "data"


def _segment(log: ManeuverLog) -> EkfSegment:
    track = smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
    return preparation.ekf_segment(log, track, "log", measurements="velocities")


def _seed_log(rate_hz: float = 1.0) -> ManeuverLog:
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    ship = model_ship(params, rudder_rate_radps=math.radians(5.0))
    return synthesize_log(ship, MANEUVERS["zigzag-20"](), rate_hz=rate_hz, seed=3)


def test_checkpointed_smoother_is_the_one_block_smoother_to_the_bit(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    rng = np.random.default_rng(5)
    t = np.cumsum(rng.uniform(0.5, 1.5, 2000))
    z = 50.0 * np.sin(t / 80.0) + rng.normal(0.0, 1.0, t.size)
    whole = smooth_axis(t, z, 1.0, 0.05)
    monkeypatch.setattr(smoothing, "RTS_BLOCK_SAMPLES", 37)  # 55 blocks, a ragged last one
    blocks = smooth_axis(t, z, 1.0, 0.05)
    for name in ("x_filtered", "P_filtered", "x_smoothed", "P_smoothed", "innovation"):
        np.testing.assert_array_equal(getattr(blocks, name), getattr(whole, name), err_msg=name)
    # smooth_track's lean path keeps the same smoothed states and variances.
    track = smooth_track(t, z, 0 * z, 0 * z, position_noise_m=1.0, position_accel_std_mps2=0.05,
                         heading_noise_rad=0.01, heading_accel_std_radps2=0.01)  # fmt: skip
    np.testing.assert_array_equal(track.x_m, whole.position)
    np.testing.assert_array_equal(track.x_dot_mps, whole.rate)
    np.testing.assert_array_equal(track.x_std_m, whole.std_smoothed[:, 0])
    np.testing.assert_array_equal(track.x_dot_std_mps, whole.std_smoothed[:, 1])


def test_chunked_normal_equations_equal_one_chunk() -> None:
    segment = _segment(_seed_log())
    structure = get_model("shi2009")
    model_fit = equation_error_fit(structure, [segment], 100.0)
    sums = NormalEquations(structure.n_coefficients)
    chunks = list(regression_chunks([segment], 100.0, chunk_rows=7))
    assert len(chunks) > 10
    for (u, v, r, rudder, n), acc in chunks:
        sums.add(numeric_model(structure).regressors(u, v, r, rudder, n, 100.0), acc)
    chunked = sums.solve(structure.equation_index)
    assert chunked.rows == model_fit.rows == sum(acc.shape[1] for _, acc in chunks)
    np.testing.assert_allclose(chunked.theta, model_fit.theta, rtol=1e-7)  # summation order
    np.testing.assert_allclose(chunked.residual_std, model_fit.residual_std, rtol=1e-9)
    # The residual from the sums is the residual of the rows themselves.
    (u, v, r, rudder, n), acc = next(iter(regression_chunks([segment], 100.0, chunk_rows=10**9)))
    phi = numeric_model(structure).regressors(u, v, r, rudder, n, 100.0)
    eq = np.asarray(structure.equation_index)
    fitted = np.stack([model_fit.theta[eq == j] @ phi[eq == j] for j in range(3)])
    dof = acc.shape[1] - np.bincount(eq, minlength=3)
    direct = np.sqrt(np.sum((acc - fitted) ** 2, axis=1) / dof)
    np.testing.assert_allclose(model_fit.residual_std, direct, rtol=1e-6)


@pytest.mark.parametrize("rate_hz", [0.5, 1.0, 2.0, 10.0])
def test_regression_is_decimated_to_about_a_40th_of_l_over_u(rate_hz: float) -> None:
    """L = 100 m at an approach speed of about 5 m/s: L/U/40 is about 0.5 s."""
    log = _seed_log(rate_hz)
    segment = _segment(log)
    speed = np.percentile(np.hypot(segment.velocities[:, 0], segment.velocities[:, 1]), 95)
    assert speed == pytest.approx(5.0, rel=0.05)
    step = decimation(segment, 100.0)
    interval = 1.0 / rate_hz
    # The largest whole number of samples not above L/U/40, at least one.
    for length_m in (100.0, 1000.0):
        expected = max(1, math.floor(length_m / speed / 40.0 / interval + 1e-9))
        assert decimation(segment, length_m) == expected
    assert (step == 1) == (rate_hz <= 2.0)
    fit = equation_error_fit(get_model("shi2009"), [segment], 100.0)
    assert fit.sample_interval_s == pytest.approx(step / rate_hz)
    assert fit.rows == len(range(0, log.n_samples, step)) - 2


def _process_noise_after(
    rate_hz: float, interval_s: float, q_motion: float, q_theta: float
) -> np.ndarray:
    """Variances of the EKF pass's (u, v, r) and θ after 10 s of data that say nothing.

    shi2009 with θ = 0 and next to no variance at the start (1e-15): no acceleration, so
    the prediction adds the process noise ``q_motion`` (u̇, v̇, ṙ) and ``q_theta`` (θ)
    alone (give one of them: θ's variance enters u through the thrust terms), and a
    track measured with a variance of 1e12 takes next to nothing out.
    """
    structure = get_model("shi2009")
    p = structure.n_coefficients
    n = round(10.0 * rate_hz) + 1
    t = np.arange(n) / rate_hz
    x = np.zeros(6 + p)
    x[0] = 5.0
    P = 1e-15 * np.eye(6 + p)
    track = np.column_stack([5.0 * t, 0.0 * t, 0.0 * t])
    ekf_pass = kernel_module(structure, (ekf_module._EKF_PASS,)).ekf_pass
    status, _ = ekf_pass(
        np.asarray(structure.equation_index, dtype=np.int64), kernel_constants(structure, 100.0),
        0.1, interval_s, 3, t, track, np.full((1, 3), 1e12), 0.0 * t, 0.0 * t + 2.0,
        np.zeros((1, 3)), np.full((1, 2), np.nan), np.zeros(2), 0.0, x, P,
        np.array([q_motion] * 3 + [0.0] * 3), np.full(p, q_theta), np.full(p, np.inf), 1,
        track, np.zeros((n, 6)), np.zeros((n, p)), np.zeros((n, p)), np.zeros(2),
        np.zeros(4, dtype=np.int64),
    )  # fmt: skip
    assert status == ekf_module._OK
    return np.concatenate([np.diag(P)[:3], np.diag(P)[6:]])


@pytest.mark.parametrize("rate_hz", [2.0, 10.0])
def test_ekf_process_noise_is_per_second_at_any_rate(rate_hz: float) -> None:
    """With the regression's interval Δ = 0.5 s, 10 s add the same noise at 2 Hz as at 10 Hz.

    Motion states std² · T · max(T, Δ) per step: 1e-4 · 10 s · 0.5 s; coefficients
    ρ²σ₀² · T / max(T, Δ): 1e-6 · 10 s / 0.5 s. Per step as before (Δ = 0): at 10 Hz
    1e-4 · 100 · 0.01 s² and 1e-6 · 100, a fifth and five times the 2 Hz figures, the
    drift with the logging rate of benchmarks/sensitivity.md.
    """
    motion = _process_noise_after(rate_hz, 0.5, q_motion=1e-4, q_theta=0.0)[:3]
    theta = _process_noise_after(rate_hz, 0.5, q_motion=0.0, q_theta=1e-6)[3:]
    np.testing.assert_allclose(motion, 1e-4 * 10.0 * 0.5, rtol=1e-6)
    np.testing.assert_allclose(theta, 1e-6 * 10.0 / 0.5, rtol=1e-6)
    per_step_motion = _process_noise_after(rate_hz, 0.0, q_motion=1e-4, q_theta=0.0)[:3]
    per_step_theta = _process_noise_after(rate_hz, 0.0, q_motion=0.0, q_theta=1e-6)[3:]
    np.testing.assert_allclose(per_step_motion, 1e-4 * 10.0 / rate_hz, rtol=1e-6)
    np.testing.assert_allclose(per_step_theta, 1e-6 * 10.0 * rate_hz, rtol=1e-6)


def test_ekf_histories_are_strided_and_the_fit_quality_uses_every_sample() -> None:
    segment = _segment(_seed_log())
    structure = get_model("shi2009")
    ls = equation_error_fit(structure, [segment], 100.0)
    run = {
        rows: ekf_identify(structure, [segment, segment], ls.theta, ls.covariance * 100.0, 100.0,
                           EkfSettings(max_history_rows=rows))
        for rows in (10**9, 100)
    }  # fmt: skip
    full, strided = run[10**9], run[100]
    n = segment.time_s.size
    assert full.history_stride == 1 and full.theta_history.shape[0] == 2 * n
    stride = strided.history_stride
    assert stride == math.ceil(2 * n / 100) and strided.theta_history.shape[0] <= 100
    np.testing.assert_array_equal(strided.theta, full.theta)
    np.testing.assert_array_equal(
        strided.theta_history[: -(-n // stride)], full.theta_history[:n:stride]
    )
    np.testing.assert_array_equal(strided.filtered[1], full.filtered[1][::stride])
    assert strided.segment_ends == (-(-n // stride), 2 * -(-n // stride))
    states = full.filtered[0]
    position = np.sqrt(
        np.mean(
            (states[:, 3] - segment.track[:, 0]) ** 2 + (states[:, 4] - segment.track[:, 1]) ** 2
        )
    )
    heading = np.sqrt(np.mean(np.angle(np.exp(1j * (states[:, 5] - segment.track[:, 2]))) ** 2))
    assert strided.track_rms[0] == pytest.approx((position, heading), rel=1e-12)
    assert 0.3 < position < 2.0  # the logger's 1 m noise


@pytest.mark.parametrize(
    ("measurements", "max_history_rows"), [("track", 10**9), ("velocities", 100)]
)
def test_ekf_in_chunks_is_the_ekf_in_one_pass_and_reports_progress_per_chunk(
    measurements: str, max_history_rows: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Chunks of 37 samples (rounded up to whole strides) against one pass per log."""
    segment = _segment(_seed_log())
    structure = get_model("shi2009")
    ls = equation_error_fit(structure, [segment], 100.0)
    settings = EkfSettings(measurements=measurements, max_history_rows=max_history_rows)
    runs, heard = {}, {}
    for chunk in (10**9, 37):
        monkeypatch.setattr(ekf_module, "EKF_CHUNK_SAMPLES", chunk)
        heard[chunk] = []
        runs[chunk] = ekf_identify(
            structure, [segment, segment], ls.theta, ls.covariance * 100.0, 100.0, settings,
            heard[chunk].append,
        )  # fmt: skip
    one, chunked = runs[10**9], runs[37]
    n = segment.time_s.size
    np.testing.assert_array_equal(chunked.theta, one.theta)
    np.testing.assert_array_equal(chunked.covariance, one.covariance)
    np.testing.assert_array_equal(chunked.theta_history, one.theta_history)
    np.testing.assert_array_equal(chunked.std_history, one.std_history)
    for a, b in zip(chunked.filtered, one.filtered, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(chunked.track_rms, one.track_rms, strict=True):
        assert a == pytest.approx(b, rel=1e-12)
    assert heard[10**9] == [n, n]
    stride = one.history_stride
    chunk = -(-37 // stride) * stride
    assert len(heard[37]) == 2 * -(-(n - 1) // chunk) and sum(heard[37]) == 2 * n


def test_a_failing_ekf_names_the_same_sample_in_chunks(monkeypatch: pytest.MonkeyPatch) -> None:
    """A rudder that turns NaN at sample 100 (in the third chunk of 37) stops both there."""
    segment = _segment(_seed_log())
    rudder = np.array(segment.rudder_rad)
    rudder[100:] = np.nan
    broken = dataclasses.replace(segment, rudder_rad=rudder)
    structure = get_model("shi2009")
    ls = equation_error_fit(structure, [segment], 100.0)
    samples = []
    for chunk in (10**9, 37):
        monkeypatch.setattr(ekf_module, "EKF_CHUNK_SAMPLES", chunk)
        with pytest.raises(IdentificationError, match="EKF diverged") as info:
            ekf_identify(structure, [broken], ls.theta, ls.covariance * 100.0, 100.0)
        samples.append(info.value.sample)
    assert samples == [100, 100]


def test_a_two_axis_speed_log_in_chunks_is_the_one_pass(monkeypatch: pytest.MonkeyPatch) -> None:
    """Both axes of a speed log cut with the chunks: θ, current and counts as in one pass."""
    segment = _segment(_seed_log())
    two_axis = dataclasses.replace(
        segment,
        speed_log_mps=segment.velocities[:, 0].copy(),
        speed_log_transverse_mps=segment.velocities[:, 1] + 0.5 * segment.velocities[:, 2],
        speed_log_x_m=0.5,
    )
    structure = get_model("shi2009")
    ls = equation_error_fit(structure, [segment], 100.0)
    runs = {}
    for chunk in (10**9, 37):
        monkeypatch.setattr(ekf_module, "EKF_CHUNK_SAMPLES", chunk)
        runs[chunk] = ekf_identify(
            structure, [two_axis], ls.theta, ls.covariance * 100.0, 100.0,
            current0=np.zeros(2), current_covariance0=np.eye(2),
            speed_log=SpeedLogMeasurement(0.05, 0.01, 0.05),
        )  # fmt: skip
    whole, chunked = runs[10**9], runs[37]
    np.testing.assert_array_equal(chunked.theta, whole.theta)
    assert chunked.current is not None and whole.current is not None
    np.testing.assert_array_equal(chunked.current, whole.current)
    n = two_axis.time_s.size - 1
    assert whole.speed_log_samples[0] + whole.speed_log_samples[1] == n
    assert chunked.speed_log_transverse_samples == whole.speed_log_transverse_samples
    assert sum(whole.speed_log_transverse_samples) == n
    with pytest.raises(ValueError, match="a transverse speed-log axis needs"):
        ekf_identify(
            structure, [two_axis], ls.theta, ls.covariance * 100.0, 100.0,
            current0=np.zeros(2), current_covariance0=np.eye(2),
            speed_log=SpeedLogMeasurement(0.05, 0.01),
        )  # fmt: skip


def test_same_coefficients_as_the_in_memory_path_within_a_tenth_sigma(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The shared test log: 6000 samples of KVLCC2 manoeuvres at 1 Hz (tests/data)."""
    path = tmp_path / "kvlcc2_stitched_1hz.csv"
    path.write_bytes(gzip.decompress((DATA / "kvlcc2_stitched_1hz.csv.gz").read_bytes()))
    reference = json.loads((DATA / "kvlcc2_stitched_1hz_reference.json").read_text())
    # Small blocks, chunks and histories: every bounded-memory path is exercised.
    monkeypatch.setattr(smoothing, "RTS_BLOCK_SAMPLES", 1000)
    monkeypatch.setattr(equation_error, "CHUNK_ROWS", 1000)
    settings = FitSettings(model="prime-rudder", method="ekf", current="none")  # as recorded
    result = identify([read_log(path)], settings)
    assert list(result.params.names) == reference["names"]
    std = np.array(reference["std"])
    deviation = np.abs(result.params.coefficients - np.array(reference["theta"])) / std
    assert np.max(deviation) <= 0.1, dict(zip(reference["names"], deviation.round(3), strict=True))
    assert result.ekf.theta_history.shape[0] <= EkfSettings().max_history_rows


def test_velocity_std_is_held_per_sample_only_when_the_ekf_measures_the_velocities() -> None:
    """Measuring the track, the EKF reads the σ of the first velocities only: one row held."""
    log = _seed_log()
    track = smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
    first = np.array([track.u_std_mps[0], track.v_std_mps[0], track.r_std_radps[0]])
    per_sample = preparation._velocity_std(track, "velocities")
    assert per_sample.shape == (log.n_samples, 3) and per_sample.strides[0] > 0
    np.testing.assert_array_equal(per_sample[:, 1], track.v_std_mps)
    assert np.ptp(per_sample[:, 1]) > 0.0  # a σ that changes along the log
    held = preparation._velocity_std(track, "track")
    assert held.shape == (log.n_samples, 3) and held.strides[0] == 0  # one row in memory
    np.testing.assert_array_equal(held[-1], first)


def test_sample_windows_are_spread_over_every_log_and_start_on_the_logged_track() -> None:
    whole = _segment(_seed_log())
    n = whole.time_s.size
    first, second = whole.window(0, n // 3), whole.window(n // 3, n)
    assert sample_windows([first, second], n, 4) == [(0, first), (1, second)]  # fits: as it is
    sourced = sample_windows([first, second], 100, 5)
    windows = [w for _, w in sourced]
    assert [w.time_s.size for w in windows] == [20] * 5
    for source, w in sourced:  # each window's segment named
        part = (first, second)[source]
        assert part.time_s[0] <= w.time_s[0] and w.time_s[-1] <= part.time_s[-1]
    starts = [float(w.time_s[0]) for w in windows]
    assert starts[0] == whole.time_s[0] and starts == sorted(starts)
    assert float(windows[-1].time_s[-1]) == whole.time_s[-1]  # the last one ends the data
    gaps = np.diff([np.searchsorted(whole.time_s, t) for t in starts])
    assert np.ptp(gaps) <= 1  # evenly spread over all the samples
    for w in windows:
        k = int(np.searchsorted(whole.time_s, w.time_s[0]))
        np.testing.assert_array_equal(w.velocities, whole.velocities[k : k + 20])
        np.testing.assert_array_equal(w.rudder_rad, whole.rudder_rad[k : k + 20])
        expected = whole.initial_track if k == 0 else whole.track[k]
        np.testing.assert_array_equal(w.initial_track, expected)
        assert (w.time_s[0] < second.time_s[0]) == (w.time_s[-1] < second.time_s[0])
    with pytest.raises(ValueError, match="outside the segment"):
        whole.window(5, n + 1)


def test_current_settled_on_windows_gives_the_estimate_of_every_sample(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The alternation on two windows of a third each: the last pass sees every sample."""
    log = _seed_log()
    drift = 0.3 * (log.time_s - log.time_s[0])  # 0.3 m/s north-east
    log = ManeuverLog(**{**log.__dict__, "x_m": log.x_m + drift, "y_m": log.y_m + drift})
    settings = FitSettings(model="shi2009", method="ekf")
    full = identify([log], settings)
    monkeypatch.setattr(identify_module, "ALTERNATION_MAX_SAMPLES", 2 * log.n_samples // 3)
    monkeypatch.setattr(identify_module, "ALTERNATION_WINDOWS", 2)
    windowed = identify([log], settings)
    assert full.current is not None and windowed.current is not None
    sigma = np.sqrt(np.diag(full.current.covariance))
    np.testing.assert_allclose(full.current.vector, [0.3, 0.3], atol=3 * sigma.max() + 0.01)
    assert np.all(np.abs(windowed.current.vector - full.current.vector) <= 0.5 * sigma)
    std = np.sqrt(np.diag(full.ekf.covariance))
    assert np.max(np.abs(windowed.ekf.theta - full.ekf.theta) / std) <= 0.5
