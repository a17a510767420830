"""The body-frame smoother of benchmarks/smoothers.py (a candidate, issues 13 and 14).

Its transition is the exact discretisation of the body-axes constant-acceleration model at
a steady heading; on a steady turn, whose velocity is constant in the ship's axes and
swings in the Earth's, it reads u and v off noisy fixes closer than the paper's per-axis
smoother; and it enters a fit for a block only.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from types import ModuleType

import numpy as np
import pytest
import scipy.linalg

import identifier.preparation
from identifier.smoothing import smooth_track
from tests.module_files import benchmark_module


@pytest.fixture(scope="module")
def smoothers() -> Iterator[ModuleType]:
    with benchmark_module("smoothers.py") as module:
        yield module


def test_the_transition_is_the_exact_discretisation_at_a_steady_heading(
    smoothers: ModuleType,
) -> None:
    T, psi, q = 0.7, 1.1, 2e-3
    c, s = math.cos(psi), math.sin(psi)
    A = np.zeros((6, 6))
    A[0:2, 2:4] = [[c, -s], [s, c]]  # ṗ = R(ψ) w
    A[2:4, 4:6] = np.eye(2)  # ẇ = a, ȧ = white jerk of density q on both body axes
    G_Qc_Gt = np.zeros((6, 6))
    G_Qc_Gt[4:6, 4:6] = q * np.eye(2)
    # Van Loan (1978): expm([[−A, GQcGᵀ], [0, Aᵀ]]·T) = [[·, F⁻¹Q], [0, Fᵀ]]
    E = scipy.linalg.expm(np.block([[-A, G_Qc_Gt], [np.zeros((6, 6)), A.T]]) * T)
    F_exact = E[6:, 6:].T
    Q_exact = F_exact @ E[:6, 6:]
    F, Q = smoothers.body_frame_model(np.array([T]), np.array([psi]), q)
    np.testing.assert_allclose(F[0], F_exact, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(Q[0], Q_exact, rtol=1e-10, atol=1e-16)


def test_on_a_steady_turn_u_and_v_come_closer_than_the_paper_smoother(
    smoothers: ModuleType,
) -> None:
    # A turn at u = 7 m/s, v = −0.8 m/s, r = 0.01 rad/s: constant in the ship's axes.
    u, v, r = 7.0, -0.8, 0.01
    t = np.arange(600.0)
    psi = 0.3 + r * t
    x = (u * np.sin(psi) + v * np.cos(psi)) / r  # ẋ = u cos ψ − v sin ψ
    y = (-u * np.cos(psi) + v * np.sin(psi)) / r  # ẏ = u sin ψ + v cos ψ
    rng = np.random.default_rng(7)
    x_m, y_m = x + rng.normal(0.0, 1.0, t.size), y + rng.normal(0.0, 1.0, t.size)
    heading = psi + rng.normal(0.0, math.radians(0.1), t.size)
    paper = smooth_track(t, x_m, y_m, heading)
    body, _ = smoothers.body_frame_track(x_m, y_m, paper)
    inner = slice(20, -20)

    def rms(track: object, name: str, truth: float) -> float:
        return float(np.sqrt(np.mean((getattr(track, name)[inner] - truth) ** 2)))

    for name, truth in (("u_mps", u), ("v_mps", v)):
        assert rms(body, name, truth) < 0.01  # m/s
        assert rms(body, name, truth) < 0.5 * rms(paper, name, truth)
    # the body rates back through the Earth's axes (a turn's r·u, r·v are 0.07, 0.008 m/s²)
    for name in ("u_dot_mps2", "v_dot_mps2"):
        assert rms(body, name, 0.0) < 5e-4  # m/s²
        assert rms(body, name, 0.0) < 0.5 * rms(paper, name, 0.0)
    # the heading and the gate's decisions are the paper smoother's own
    np.testing.assert_array_equal(body.heading_rad, paper.heading_rad)
    np.testing.assert_array_equal(body.position_rejected, paper.position_rejected)


def test_the_candidate_enters_the_fits_for_its_block_only(smoothers: ModuleType) -> None:
    paper = identifier.preparation.smooth_track
    with pytest.raises(RuntimeError, match="inside"):
        with smoothers.body_frame_smoothing():
            assert identifier.preparation.smooth_track is not paper
            raise RuntimeError("inside")
    assert identifier.preparation.smooth_track is paper
