"""Tests for identifier.smoothing: CA Kalman filter + RTS smoother, noise estimate, eq. (9)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
from filterpy.kalman import KalmanFilter
from filterpy.kalman import rts_smoother as filterpy_rts_smoother

from identifier.smoothing import (
    DEFAULT_TAU_S,
    constant_acceleration_model,
    estimate_noise,
    smooth_axis,
    smooth_track,
    wrap_angle,
)

# --------------------------------------------------------------------------- helpers


def irregular_times(n: int, rng: np.random.Generator, t0_s: float = 0.0) -> np.ndarray:
    """Sample times with Δt uniform in [0.5, 1.5] s."""
    return t0_s + np.concatenate([[0.0], np.cumsum(rng.uniform(0.5, 1.5, n - 1))])


def simulate_ca(
    t_s: np.ndarray, accel_std: float, tau_s: float, rng: np.random.Generator
) -> np.ndarray:
    """Truth drawn from the filter's own model: x(k+1) = Φ x(k) + w, w ~ N(0, Q)."""
    F, Q = constant_acceleration_model(np.diff(t_s), accel_std, tau_s)
    L = np.linalg.cholesky(Q)
    w = (L @ rng.standard_normal((t_s.size - 1, 3, 1)))[..., 0]
    X = np.empty((t_s.size, 3))
    X[0] = [100.0, 5.0, rng.normal(0.0, accel_std)]
    for k in range(1, t_s.size):
        X[k] = F[k - 1] @ X[k - 1] + w[k - 1]
    return X


def default_prior(t_s: np.ndarray, z: np.ndarray, meas_std: float, accel_std: float):
    """The documented default prior of smooth_axis, rebuilt independently."""
    dt0 = t_s[1] - t_s[0]
    R = meas_std**2
    x0 = np.array([z[0], (z[1] - z[0]) / dt0, 0.0])
    kappa = 10.0
    P0 = np.diag([kappa**2 * R, 2.0 * kappa**2 * R / dt0**2, accel_std**2])
    return x0, P0


def zigzag_truth(duration_s: float = 400.0, dt_s: float = 0.05):
    """Kinematic 10/10 zig-zag: first-order Nomoto yaw, rate-limited rudder, drift ∝ r.

    Returns fine-grid arrays t, x, y, ψ, r, β, U (x North, y East, r > 0 to starboard).
    """
    speed_mps, gain_per_s, time_constant_s = 7.0, 0.05, 30.0
    rudder_max, check_heading, rudder_rate = np.radians(10.0), np.radians(10.0), np.radians(2.3)
    t = np.arange(0.0, duration_s + dt_s / 2, dt_s)
    r = np.zeros_like(t)
    psi = np.zeros_like(t)
    rudder, command = 0.0, rudder_max
    for i in range(1, t.size):
        if psi[i - 1] > check_heading:
            command = -rudder_max
        elif psi[i - 1] < -check_heading:
            command = rudder_max
        rudder += np.clip(command - rudder, -rudder_rate * dt_s, rudder_rate * dt_s)
        r[i] = r[i - 1] + dt_s * (gain_per_s * rudder - r[i - 1]) / time_constant_s
        psi[i] = psi[i - 1] + dt_s * r[i]
    beta = -8.0 * r  # drift to port in a starboard turn
    chi = psi + beta
    x_dot, y_dot = speed_mps * np.cos(chi), speed_mps * np.sin(chi)
    x = np.concatenate([[0.0], np.cumsum(0.5 * (x_dot[1:] + x_dot[:-1]) * dt_s)])
    y = np.concatenate([[0.0], np.cumsum(0.5 * (y_dot[1:] + y_dot[:-1]) * dt_s)])
    return t, x, y, psi, r, beta, speed_mps


@pytest.fixture(scope="module")
def zigzag_1hz():
    t, x, y, psi, r, beta, speed = zigzag_truth()
    idx = np.arange(0, t.size, 20)  # 1 Hz
    return t[idx], x[idx], y[idx], psi[idx], r[idx], beta[idx], speed


# --------------------------------------------------------------------------- model


def test_transition_and_process_noise_match_continuous_white_jerk_model():
    # Van Loan (1978): for ẋ = A x + G w, E[w wᵀ] = q δ, expm([[−A, GqGᵀ], [0, Aᵀ]] T)
    # holds Φ = expm(A T) and Q = Φ · (upper-right block).
    accel_std, tau_s = 0.3, 15.0
    q = 2.0 * accel_std**2 / tau_s
    A = np.diag([1.0, 1.0], k=1)
    G = np.array([[0.0], [0.0], [1.0]])
    dts = np.array([0.1, 0.7, 2.0, 5.0])
    F, Q = constant_acceleration_model(dts, accel_std, tau_s)
    for T, Fk, Qk in zip(dts, F, Q, strict=True):
        M = np.block([[-A, q * G @ G.T], [np.zeros((3, 3)), A.T]]) * T
        E = scipy.linalg.expm(M)
        Phi = E[3:, 3:].T
        np.testing.assert_allclose(Fk, Phi, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(Qk, Phi @ E[:3, 3:], rtol=1e-10, atol=1e-16)
    # and the paper's matrix, eq. (6), written out
    T = 2.0
    paper = (
        2.0
        / tau_s
        * accel_std**2
        * np.array(
            [
                [T**5 / 20, T**4 / 8, T**3 / 6],
                [T**4 / 8, T**3 / 3, T**2 / 2],
                [T**3 / 6, T**2 / 2, T],
            ]
        )
    )
    np.testing.assert_allclose(constant_acceleration_model([T], accel_std, tau_s)[1][0], paper)


# --------------------------------------------------------------------------- cross-check


def run_filterpy(t_s, z, meas_std, accel_std, tau_s, x0, P0):
    """Reference: filterpy's KalmanFilter with per-step F and Q, then both RTS smoothers."""
    F, Q = constant_acceleration_model(np.diff(t_s), accel_std, tau_s)
    kf = KalmanFilter(dim_x=3, dim_z=1)
    kf.x = x0.reshape(3, 1).copy()
    kf.P = P0.copy()
    kf.H = np.array([[1.0, 0.0, 0.0]])
    kf.R = np.array([[meas_std**2]])
    xs, covs, innov, S, loglik = [], [], [], [], 0.0
    for k, zk in enumerate(z):
        if k:
            kf.predict(F=F[k - 1], Q=Q[k - 1])
        kf.update(zk)
        xs.append(kf.x[:, 0].copy())
        covs.append(kf.P.copy())
        innov.append(kf.y[0, 0])
        S.append(kf.S[0, 0])
        if k:
            loglik += kf.log_likelihood
    Xs, Ps = np.array(xs), np.array(covs)
    eye, zero = np.eye(3)[None], np.zeros((1, 3, 3))
    # method: Fs[k] is the transition into k; module function: Fs[k] is the one out of k
    xs_m, Ps_m, _, _ = kf.rts_smoother(
        Xs[..., None], Ps, Fs=np.concatenate([eye, F]), Qs=np.concatenate([zero, Q])
    )
    xs_f, Ps_f, _, _ = filterpy_rts_smoother(
        Xs, Ps, Fs=np.concatenate([F, eye]), Qs=np.concatenate([Q, zero])
    )
    np.testing.assert_allclose(xs_m[..., 0], xs_f, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(Ps_m, Ps_f, rtol=1e-12, atol=1e-12)
    return Xs, Ps, xs_f, Ps_f, np.array(innov), np.array(S), loglik


@pytest.mark.parametrize("explicit_prior", [False, True])
def test_filter_and_smoother_match_filterpy_with_irregular_steps(explicit_prior):
    rng = np.random.default_rng(1)
    t = irregular_times(300, rng, t0_s=1234.5)
    truth = simulate_ca(t, accel_std=0.05, tau_s=DEFAULT_TAU_S, rng=rng)
    meas_std, accel_std, tau_s = 1.5, 0.08, 12.0
    z = truth[:, 0] + rng.normal(0.0, meas_std, t.size)
    if explicit_prior:
        x0, P0 = np.array([90.0, 3.0, 0.01]), np.array([[50.0, 1, 0], [1, 4.0, 0], [0, 0, 0.1]])
        ours = smooth_axis(t, z, meas_std, accel_std, tau_s, x0=x0, P0=P0)
    else:
        x0, P0 = default_prior(t, z, meas_std, accel_std)
        ours = smooth_axis(t, z, meas_std, accel_std, tau_s)
    Xf, Pf, Xs, Ps, innov, S, loglik = run_filterpy(t, z, meas_std, accel_std, tau_s, x0, P0)
    tol = 1e-10
    np.testing.assert_allclose(ours.x_filtered, Xf, rtol=tol, atol=tol)
    np.testing.assert_allclose(ours.P_filtered, Pf, rtol=tol, atol=tol)
    np.testing.assert_allclose(ours.x_smoothed, Xs, rtol=tol, atol=tol)
    np.testing.assert_allclose(ours.P_smoothed, Ps, rtol=tol, atol=tol)
    np.testing.assert_allclose(ours.innovation, innov, rtol=tol, atol=tol)
    np.testing.assert_allclose(ours.innovation_var, S, rtol=tol, atol=tol)
    assert ours.log_likelihood == pytest.approx(loglik, rel=1e-10)


def test_results_are_read_only_and_inputs_untouched():
    t = np.arange(10.0)
    z = t**2
    res = smooth_axis(t, z, 1.0, 0.1)
    assert z.flags.writeable and t.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        res.x_smoothed[0, 0] = 1.0


# --------------------------------------------------------------------------- statistics


@pytest.mark.parametrize("sampling", ["regular", "irregular"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_smoother_beats_filter_and_is_consistent(sampling, seed):
    rng = np.random.default_rng(seed)
    n, meas_std, accel_std = 3000, 2.0, 0.1
    t = np.arange(n, dtype=float) if sampling == "regular" else irregular_times(n, rng)
    truth = simulate_ca(t, accel_std, DEFAULT_TAU_S, rng)
    z = truth[:, 0] + rng.normal(0.0, meas_std, n)
    res = smooth_axis(t, z, meas_std, accel_std)
    for i in (0, 1):  # position, rate
        err_f = res.x_filtered[:, i] - truth[:, i]
        err_s = res.x_smoothed[:, i] - truth[:, i]
        assert np.sqrt(np.mean(err_s**2)) < 0.9 * np.sqrt(np.mean(err_f**2))
        inside = np.abs(err_s) <= 3.0 * res.std_smoothed[:, i]
        assert inside.mean() >= 0.99
        # not trivially consistent: the reported σ is not grossly inflated either
        assert np.sqrt(np.mean((err_s / res.std_smoothed[:, i]) ** 2)) > 0.8


def test_irregular_sampling_is_used_not_assumed_regular():
    # A constant-acceleration track sampled irregularly: the rate must follow the true
    # rate, which a filter assuming Δt = mean(Δt) would not.
    rng = np.random.default_rng(7)
    t = irregular_times(400, rng)
    a = 0.04
    x_true, xd_true = 3.0 * t + 0.5 * a * t**2, 3.0 + a * t
    z = x_true + rng.normal(0.0, 1.0, t.size)
    res = smooth_axis(t, z, 1.0, a)  # Singer σ_m: the RMS acceleration
    err = (res.rate - xd_true) / res.std_smoothed[:, 1]
    assert np.mean(np.abs(err) <= 3.0) >= 0.99
    assert np.mean(np.abs(res.acceleration - a) <= 3.0 * res.std_smoothed[:, 2]) >= 0.99
    regular = smooth_axis(np.arange(t.size) * np.mean(np.diff(t)), z, 1.0, a)
    rms_irregular = np.sqrt(np.mean((res.rate - xd_true) ** 2))
    assert np.sqrt(np.mean((regular.rate - xd_true) ** 2)) > 10 * rms_irregular


# --------------------------------------------------------------------------- noise


@pytest.mark.parametrize("meas_std_m", [0.5, 1.0, 2.0, 5.0])
def test_noise_estimate_within_20_percent_on_a_zigzag(zigzag_1hz, meas_std_m):
    t, x, y, *_ = zigzag_1hz
    assert 300 <= t.size <= 500
    for seed in range(5):
        rng = np.random.default_rng(seed)
        for track in (x, y):
            est = estimate_noise(t, track + rng.normal(0.0, meas_std_m, t.size))
            assert est.meas_std == pytest.approx(meas_std_m, rel=0.2)


def test_noise_estimate_irregular_sampling_and_outliers(zigzag_1hz):
    t_fine, x_fine, *_ = zigzag_truth()
    rng = np.random.default_rng(3)
    t = irregular_times(350, rng)
    x = np.interp(t, t_fine, x_fine)
    z = x + rng.normal(0.0, 2.0, t.size)
    assert estimate_noise(t, z).meas_std == pytest.approx(2.0, rel=0.2)
    z[[50, 120, 200]] += [60.0, -80.0, 100.0]  # GPS jumps
    assert estimate_noise(t, z).meas_std == pytest.approx(2.0, rel=0.2)


def test_accel_estimate_is_the_rms_acceleration():
    rng = np.random.default_rng(4)
    t = np.arange(600.0)
    a = 0.05
    z = 2.0 * t + 0.5 * a * t**2 + rng.normal(0.0, 1.0, t.size)
    est = estimate_noise(t, z)
    assert est.accel_std == pytest.approx(a, rel=0.2)
    still = estimate_noise(t, 2.0 * t + rng.normal(0.0, 1.0, t.size))
    assert 0.0 < still.accel_std < 0.01  # floored at the fit's own resolution


def test_noise_free_data_gives_a_tiny_but_positive_noise():
    t = np.arange(50.0)
    z = 0.01 * t**3  # exactly a cubic: the residuals are rounding only
    est = estimate_noise(t, z)
    assert 0.0 < est.meas_std <= 1e-8 * np.max(np.abs(z))
    smooth_track(t, 0.01 * t**3, t, np.zeros_like(t))  # must not fail


# --------------------------------------------------------------------------- track


def circle(t, speed_mps, radius_m, drift_rad):
    """Steady starboard turn: χ = ωt, ψ = χ − β, r = ω = U / R."""
    omega = speed_mps / radius_m
    chi = 0.3 + omega * t
    x = 1000.0 + radius_m * np.sin(chi)
    y = -500.0 - radius_m * np.cos(chi)
    return x, y, chi - drift_rad, omega


@pytest.mark.parametrize("sampling", ["regular", "irregular"])
def test_u_v_r_on_a_circle_with_drift(sampling):
    rng = np.random.default_rng(11)
    n = 900
    t = np.arange(n, dtype=float) if sampling == "regular" else irregular_times(n, rng)
    speed, radius, drift = 7.0, 600.0, np.radians(-6.0)
    x, y, psi, omega = circle(t, speed, radius, drift)
    pos_std, hdg_std = 1.5, np.radians(0.2)
    track = smooth_track(
        t,
        x + rng.normal(0.0, pos_std, n),
        y + rng.normal(0.0, pos_std, n),
        wrap_angle(psi + rng.normal(0.0, hdg_std, n)),
    )
    assert track.position_noise_m == pytest.approx(pos_std, rel=0.2)
    assert track.heading_noise_rad == pytest.approx(hdg_std, rel=0.2)
    truth = {
        "u_mps": speed * np.cos(drift),
        "v_mps": speed * np.sin(drift),
        "r_radps": omega,
        "speed_mps": speed,
        "drift_rad": drift,
    }
    for name, value in truth.items():
        est = getattr(track, name)
        std = getattr(track, name.replace("_", "_std_", 1))
        z = (est - value) / std
        assert np.mean(np.abs(z) <= 3.0) >= 0.99, name
        assert np.max(np.abs(z)) < 5.0, name
    assert track.v_mps.mean() < 0  # drift to port in a starboard turn
    for derivative in (track.u_dot_mps2, track.v_dot_mps2):  # steady turn: u̇ = v̇ = 0
        assert np.sqrt(np.mean(derivative**2)) < 0.02
    # eq. (9) in its polar form agrees with the rotation used
    np.testing.assert_allclose(track.u_mps, track.speed_mps * np.cos(track.drift_rad), atol=1e-12)
    np.testing.assert_allclose(track.v_mps, track.speed_mps * np.sin(track.drift_rad), atol=1e-12)


def test_zigzag_r_and_v_within_their_sigma(zigzag_1hz):
    t, x, y, psi, r, beta, speed = zigzag_1hz
    rng = np.random.default_rng(5)
    track = smooth_track(
        t,
        x + rng.normal(0.0, 2.0, t.size),
        y + rng.normal(0.0, 2.0, t.size),
        psi + rng.normal(0.0, 0.003, t.size),
    )
    for est, std, value in (
        (track.r_radps, track.r_std_radps, r),
        (track.v_mps, track.v_std_mps, speed * np.sin(beta)),
        (track.u_mps, track.u_std_mps, speed * np.cos(beta)),
    ):
        assert np.mean(np.abs(est - value) <= 3.0 * std) >= 0.98
    # the yaw rate is resolved to a few percent of its amplitude
    assert np.sqrt(np.mean((track.r_radps - r) ** 2)) < 0.05 * np.max(np.abs(r))


def test_sway_is_positive_when_moving_to_starboard_of_heading():
    # Heading North (ψ ≈ 0, noisy, so the wrapped log jumps between ≈0 and ≈2π),
    # moving North-East: the ship slides to starboard, v > 0, β = +45°.
    rng = np.random.default_rng(2)
    t = np.arange(200.0)
    speed = 5.0
    x, y = speed * np.cos(np.pi / 4) * t, speed * np.sin(np.pi / 4) * t
    heading = np.mod(rng.normal(0.0, 0.002, t.size), 2 * np.pi)
    track = smooth_track(t, x + rng.normal(0, 1, t.size), y + rng.normal(0, 1, t.size), heading)
    assert np.all(track.v_mps > 0.0)
    assert np.all(track.u_mps > 0.0)
    np.testing.assert_allclose(track.v_mps, speed * np.sin(np.pi / 4), atol=0.1)
    np.testing.assert_allclose(track.drift_rad, np.pi / 4, atol=0.02)
    np.testing.assert_allclose(track.course_rad, np.pi / 4, atol=0.02)
    assert np.max(np.abs(track.heading_rad)) < 0.01  # continuous, not 0 ↔ 2π


@pytest.mark.parametrize(
    "wrap", [wrap_angle, lambda a: np.mod(a, 2 * np.pi)], ids=["pm180", "0-360"]
)
def test_heading_wrap_creates_no_spike(wrap):
    rng = np.random.default_rng(8)
    t = np.arange(700.0)
    r_true = 0.02  # several full turns: many wraps at ±π and at 0/2π
    psi = 3.0 + r_true * t
    psi_meas = psi + rng.normal(0.0, 0.003, t.size)
    xy = np.zeros_like(t), np.zeros_like(t)
    continuous = smooth_track(t, *xy, psi_meas, position_noise_m=1.0)
    wrapped = smooth_track(t, *xy, wrap(psi_meas), position_noise_m=1.0)
    assert np.max(np.abs(np.diff(wrapped.heading_rad))) < 0.05
    np.testing.assert_allclose(wrapped.r_radps, continuous.r_radps, atol=1e-9)
    offset = wrapped.heading_rad - continuous.heading_rad
    np.testing.assert_allclose(offset, np.round(offset[0] / (2 * np.pi)) * 2 * np.pi, atol=1e-9)
    assert np.max(np.abs(wrapped.r_radps - r_true)) < 1e-3
    assert np.max(np.abs(wrapped.r_radps - r_true) / wrapped.r_std_radps) < 4.0


def test_given_noise_levels_are_used_and_reported():
    t = np.arange(20.0)
    track = smooth_track(
        t,
        t,
        0 * t,
        0 * t,
        position_noise_m=0.7,
        heading_noise_rad=0.01,
        position_accel_std_mps2=0.2,
        heading_accel_std_radps2=0.001,
        tau_s=15.0,
    )
    assert (track.position_noise_m, track.heading_noise_rad) == (0.7, 0.01)
    assert (track.position_accel_std_mps2, track.heading_accel_std_radps2) == (0.2, 0.001)
    assert track.tau_s == 15.0


# --------------------------------------------------------------------------- bad input


def test_bad_input_raises_clear_errors():
    t = np.arange(10.0)
    z = np.zeros(10)
    with pytest.raises(ValueError, match="strictly increasing: sample 5"):
        smooth_track(np.r_[t[:5], t[4], t[6:]], z, z, z)
    with pytest.raises(ValueError, match="strictly increasing"):
        smooth_axis(t[::-1], z, 1.0, 0.1)
    with pytest.raises(ValueError, match="y_m has 9 samples but time_s has 10"):
        smooth_track(t, z, z[:9], z)
    with pytest.raises(ValueError, match="at least 3 samples are needed, got 2"):
        smooth_track(t[:2], z[:2], z[:2], z[:2])
    with pytest.raises(ValueError, match="at least 3 samples"):
        smooth_axis(t[:2], z[:2], 1.0, 0.1)
    with pytest.raises(ValueError, match="heading_rad contains a non-finite value at sample 3"):
        smooth_track(t, z, z, np.r_[z[:3], np.nan, z[4:]])
    with pytest.raises(ValueError, match="meas_std must be positive"):
        smooth_axis(t, z, 0.0, 0.1)
    with pytest.raises(ValueError, match="position_noise_m must be positive"):
        smooth_track(t, z, z, z, position_noise_m=-1.0)
    with pytest.raises(ValueError, match="heading_accel_std_radps2 must be positive"):
        smooth_track(t, z, z, z, heading_accel_std_radps2=0.0)
    with pytest.raises(ValueError, match="tau_s must be positive"):
        smooth_axis(t, z, 1.0, 0.1, tau_s=float("inf"))
    with pytest.raises(ValueError, match="P0 must be a finite symmetric 3x3"):
        smooth_axis(t, z, 1.0, 0.1, P0=np.triu(np.ones((3, 3))))
    with pytest.raises(ValueError, match="one-dimensional"):
        smooth_axis(t, np.zeros((10, 2)), 1.0, 0.1)
    with pytest.raises(ValueError, match="give the noise levels explicitly"):
        smooth_track(t[:4], z[:4], z[:4], z[:4])
    # three samples are enough when the noise levels are given
    three = smooth_track(
        t[:3],
        z[:3],
        z[:3],
        z[:3],
        position_noise_m=1.0,
        heading_noise_rad=0.01,
        position_accel_std_mps2=0.1,
        heading_accel_std_radps2=0.001,
    )
    assert three.u_mps.shape == (3,)


def test_long_series_noise_is_estimated_in_pooled_chunks() -> None:
    from identifier.smoothing import NOISE_CHUNK_SAMPLES, _pooled_noise

    rng = np.random.default_rng(11)
    t = np.arange(2.6 * NOISE_CHUNK_SAMPLES) * 0.5
    z = 300.0 * np.sin(t / 200.0) + 1.5 * rng.standard_normal(t.size)
    pooled = _pooled_noise(t, z)
    assert pooled.meas_std == pytest.approx(1.5, rel=0.05)
    whole = estimate_noise(t, z)
    assert pooled.meas_std == pytest.approx(whole.meas_std, rel=0.02)
