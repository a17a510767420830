"""A heading made continuous, robust to compass spikes (trials.angles.unwrap_heading)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from trials.angles import UNWRAP_WINDOW, unwrap_heading
from trials.logs import parse_log


def _turning_heading(n: int = 400, rate_rad_per_sample: float = 0.05) -> np.ndarray:
    """A ship turning steadily through several turns, with a wobble (continuous) [rad]."""
    k = np.arange(n, dtype=float)
    return rate_rad_per_sample * k + 0.2 * np.sin(k / 7.0)


def test_a_continuous_heading_is_kept_to_the_bit() -> None:
    heading = _turning_heading()
    np.testing.assert_array_equal(unwrap_heading(heading), heading)


@pytest.mark.parametrize("offset", [0.0, -math.pi])
def test_a_wrapped_heading_is_numpy_unwrap_and_the_truth(offset: float) -> None:
    heading = _turning_heading()  # 3.2 turns: it wraps three times either way
    wrapped = np.mod(heading - offset, 2.0 * math.pi) + offset
    unwrapped = unwrap_heading(wrapped)
    np.testing.assert_allclose(unwrapped, np.unwrap(wrapped), rtol=0.0, atol=1e-12)
    turns = (unwrapped - heading) / (2.0 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns[0]), rtol=0.0, atol=1e-12)


def test_spikes_stay_spikes_where_numpy_unwrap_leaves_a_turn_behind() -> None:
    heading = _turning_heading(rate_rad_per_sample=-0.05)  # turning to port
    spiked = heading.copy()
    spiked[100] += math.radians(167.9)  # two in a row, about half a turn each way
    spiked[101] -= math.radians(178.1)
    spiked[250] += math.radians(179.0)  # one alone
    wrapped = np.mod(spiked, 2.0 * math.pi)
    unwrapped = unwrap_heading(wrapped)
    good = np.setdiff1d(np.arange(heading.size), [100, 101, 250])
    np.testing.assert_allclose(unwrapped[good], heading[good], rtol=0.0, atol=1e-12)
    # the spikes themselves: their own angle, on the turn nearest the heading before them
    spikes = [100, 101, 250]
    turns = (unwrapped[spikes] - spiked[spikes]) / (2.0 * math.pi)
    np.testing.assert_allclose(turns, np.round(turns), rtol=0.0, atol=1e-12)
    assert np.all(np.abs(unwrapped[spikes] - heading[spikes]) < math.pi + 0.2)
    # numpy.unwrap agrees before the pair and takes everything after it a turn further on
    shift = np.unwrap(wrapped) - heading
    np.testing.assert_allclose(shift[:100], 0.0, atol=1e-12)
    np.testing.assert_allclose(np.abs(shift[102:250]), 2.0 * math.pi, atol=1e-12)


def test_the_window_out_votes_two_bad_samples_not_three() -> None:
    """The rule's limit: after three samples in a row at 179°, the median of the five
    before the next is one of them, and a heading of −179° goes onto their turn (181°)."""
    assert UNWRAP_WINDOW == 5
    heading = np.zeros(20)
    heading[8:11] = math.radians(179.0)
    heading[11:] = math.radians(-179.0)
    unwrapped = unwrap_heading(heading)
    np.testing.assert_allclose(unwrapped[:11], heading[:11], atol=1e-12)
    assert unwrapped[11] == pytest.approx(math.radians(181.0))


def test_the_reader_unwraps_a_logged_spike_pair_without_a_step() -> None:
    rows = ["time_s,x_m,y_m,heading_deg,rudder_deg,rpm"]
    heading_deg = [350.0, 352.0, 354.0, 356.0, 358.0, 0.0 + 168.0, 2.0 - 178.0, 4.0, 6.0, 8.0]
    for k, psi in enumerate(heading_deg):
        rows.append(f"{k},{8.0 * k},0,{psi % 360.0},0,60")
    log = parse_log("\n".join(rows) + "\n", "spiky.csv")
    expected = np.radians([350, 352, 354, 356, 358, 528, 184, 364, 366, 368])
    np.testing.assert_allclose(log.heading_rad, expected, atol=1e-12)
