"""Spikes of the logged rudder angle and propeller speed (trials.spikes).

Hand-built channels: a rudder that holds and turns at 2.3 °/s (the KVLCC2's steering
gear) sampled at 1 Hz, a ship of 320 m (the bound √(g/L) = 0.175 rad/s, 10 °/s); then
the synthetic and the measured logs, on which nothing may be taken for a spike, and
the preparation of a fit, which interpolates the spikes and says so.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.constants

from identifier.preparation import smooth_logs
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from trials.conditions import (
    approach_helm_rad,
    execute_index,
    logged_condition,
    maneuver_kind,
)
from trials.logs import ManeuverLog, read_log
from trials.spikes import (
    FROUDE_RATE,
    MAX_SPIKE_SAMPLES,
    despiked,
    input_rate_bound,
    out_and_back,
)

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"
LENGTH_M = 320.0
RATE = input_rate_bound(LENGTH_M)
T = np.arange(60.0)


def _rudder() -> np.ndarray:
    """0 for 10 s, then to 35° at 2.3 °/s, held, back to −35° from t = 40 s [rad]."""
    slope = math.radians(2.3)
    up = np.clip(slope * (T - 10.0), 0.0, math.radians(35.0))
    down = np.clip(slope * (T - 40.0), 0.0, math.radians(70.0))
    return up - down


def test_the_bound_is_froude_scaled() -> None:
    assert FROUDE_RATE * math.sqrt(scipy.constants.g / LENGTH_M) == RATE
    assert input_rate_bound(7.0) == pytest.approx(RATE * math.sqrt(LENGTH_M / 7.0))
    assert math.degrees(RATE) == pytest.approx(10.03, abs=0.01)


def test_a_steering_gear_at_its_rate_has_no_spike() -> None:
    assert out_and_back(T, _rudder(), RATE).size == 0


@pytest.mark.parametrize(
    ("where", "by_deg"),
    [([5], [35.0]), ([28], [-30.0]), ([44], [20.0]), ([20, 21], [25.0, 25.0]),
     ([20, 21], [15.0, 30.0]), ([3, 30], [-20.0, -20.0])],
)  # fmt: skip
def test_spikes_of_one_and_two_samples_are_found_and_interpolated(
    where: list[int], by_deg: list[float]
) -> None:
    """Samples 5 (on the hold at 0), 28 (on the hold at 35°), 44 (on the ramp back), a
    run of two (20, 21; also a staircase up and straight back), two apart: found, and
    the ramp or hold put back exactly."""
    clean = _rudder()
    spiked = clean.copy()
    spiked[where] += np.radians(by_deg)
    found = out_and_back(T, spiked, RATE)
    np.testing.assert_array_equal(found, where)
    np.testing.assert_allclose(despiked(T, spiked, found), clean, atol=1e-15)


def test_what_is_no_spike() -> None:
    rudder = _rudder()
    step = np.where(T < 30.0, 0.0, math.radians(20.0))  # fast, but it stays
    assert out_and_back(T, step, RATE).size == 0
    slow = rudder.copy()
    slow[25] += math.radians(9.0)  # out and back, 9° in a second: a steering gear could
    assert out_and_back(T, slow, RATE).size == 0
    long = rudder.copy()
    long[20 : 21 + MAX_SPIKE_SAMPLES] += math.radians(30.0)  # longer than a spike
    assert out_and_back(T, long, RATE).size == 0
    elsewhere = rudder.copy()
    elsewhere[22:] += math.radians(20.0)  # up fast and down fast, but not back: a shift
    elsewhere[21] += math.radians(45.0)
    assert out_and_back(T, elsewhere, RATE).size == 0
    ends = rudder.copy()
    ends[[0, -1]] += math.radians(30.0)  # no neighbour on one side
    assert out_and_back(T, ends, RATE).size == 0


def test_irregular_sampling_is_judged_by_each_interval() -> None:
    """A sample 20° off that came 5 s after the one before: 4 °/s in, a steering gear's
    rate; the same 20° 1 s later: a spike."""
    t = np.array([0.0, 1.0, 2.0, 7.0, 8.0, 9.0])
    z = np.radians([0.0, 0.0, 0.0, 20.0, 0.0, 0.0])
    assert out_and_back(t, z, RATE).size == 0
    t[3] = 3.0
    t[4:] = [4.0, 5.0]
    np.testing.assert_array_equal(out_and_back(t, z, RATE), [3])


@pytest.mark.parametrize(
    ("vessel", "maneuver", "rate_hz"),
    [("kvlcc2", "zigzag-10", 1.0), ("kvlcc2", "turning-35", 10.0), ("mariner", "zigzag-20", 1.0)],
)
def test_synthetic_logs_have_no_spike(vessel: str, maneuver: str, rate_hz: float) -> None:
    ship = reference_ship(vessel)
    log = synthesize_log(ship, MANEUVERS[maneuver](), seed=3, rate_hz=rate_hz)
    rate = input_rate_bound(ship.length_m)
    assert out_and_back(log.time_s, log.rudder_rad, rate).size == 0
    typical = float(np.median(np.abs(log.n_rps)))
    assert out_and_back(log.time_s, log.n_rps, rate * typical).size == 0


@pytest.mark.skipif(not HSVA.is_dir(), reason="HSVA model-test data not present")
@pytest.mark.parametrize("run", ["hsva_zz10_stbd", "hsva_zz10_port", "hsva_zz20_10_stbd",
                                 "hsva_zz20_10_port"])  # fmt: skip
def test_measured_model_tests_have_no_spike(run: str) -> None:
    """20 Hz, L = 7 m: the rudder turns at up to 17 °/s, the bound is 68 °/s."""
    log = read_log(HSVA / f"{run}.csv")
    rate = input_rate_bound(7.0)
    assert out_and_back(log.time_s, log.rudder_rad, rate).size == 0
    typical = float(np.median(np.abs(log.n_rps)))
    assert out_and_back(log.time_s, log.n_rps, rate * typical).size == 0


def _prepared(log: ManeuverLog, length_m: float = LENGTH_M) -> tuple[ManeuverLog, tuple[str, ...]]:
    data = smooth_logs(
        [log], length_m=length_m, position_noise_m=None, heading_noise_rad=None,
        measurements="track", windage=None, drifting=False, progress=None,
        stage=lambda _: None,
    )  # fmt: skip
    return data.logs[0], data.notes


def test_a_fit_takes_the_spikes_out_and_says_so() -> None:
    """1 % of the rudder samples of a 10/10 zig-zag spiked to ±35°, 1 % of the propeller
    speeds dropped to 0: every spike found, each channel put back where it was (the
    holds and ramps exactly, a spike beside a corner of the rudder within its rate)."""
    clean = synthesize_log(reference_ship("kvlcc2"), MANEUVERS["zigzag-10"](), seed=1)
    rng = np.random.default_rng(4)
    inner = np.arange(2, clean.n_samples - 2, 4)  # apart: 0, n, n, 0 would be four spikes
    rudder_at = np.sort(rng.choice(inner, 11, replace=False))
    rps_at = np.sort(rng.choice(inner, 11, replace=False))
    rudder = clean.rudder_rad.copy()
    rudder[rudder_at] = np.radians(35.0) * rng.choice([-1.0, 1.0], rudder_at.size)
    n_rps = clean.n_rps.copy()
    n_rps[rps_at] = 0.0
    log, notes = _prepared(replace(clean, rudder_rad=rudder, n_rps=n_rps))
    assert any("11 rudder angles and 11 propeller speeds taken for spikes" in n for n in notes)
    gear = math.radians(2.32)  # the reference's steering rate [rad/s]
    np.testing.assert_allclose(log.rudder_rad, clean.rudder_rad, atol=gear / 2.0)
    np.testing.assert_allclose(log.n_rps, clean.n_rps, rtol=1e-12)
    _, clean_notes = _prepared(clean)
    assert not any("spikes" in n for n in clean_notes)


def test_a_logged_condition_is_read_through_the_spikes() -> None:
    """A 10/10 zig-zag without its ``# execute_time_s:`` line, one rudder sample spiked to
    +20° during the approach and one to +35° on the first plateau: the execute point, the
    rudder amplitude and rate, the kind and the angles read as from the clean log (the
    spike before execute would be taken for it, 40 s early; the one on the plateau for a
    35° zig-zag)."""
    clean = synthesize_log(reference_ship("kvlcc2"), MANEUVERS["zigzag-10"](), seed=1)
    metadata = {k: v for k, v in clean.metadata.items() if k != "execute_time_s"}
    clean = replace(clean, metadata=metadata)
    k = execute_index(clean)
    rudder = clean.rudder_rad.copy()
    rudder[k - 40] = math.radians(20.0)
    rudder[k + 20] = math.radians(35.0)
    spiked = replace(clean, rudder_rad=rudder)
    assert execute_index(spiked) == k
    assert maneuver_kind(spiked) == maneuver_kind(clean) == "zigzag"
    assert approach_helm_rad(spiked) == approach_helm_rad(clean)
    assert logged_condition(spiked) == logged_condition(clean)


def test_the_fit_reads_its_logs_at_the_length_it_was_given() -> None:
    """A 15° rudder pulse of one sample (1 Hz) 40 s before execute: a spike of a 320 m
    ship (bound 10 °/s), a real movement of a 100 m one (18 °/s). The log's header says
    320 m, the fit is given 100 m: the cleaned log keeps the pulse, and the fit's own
    reading of its execute point takes it there, not at the header's length."""
    clean = synthesize_log(reference_ship("kvlcc2"), MANEUVERS["zigzag-10"](), seed=1)
    metadata = {k: v for k, v in clean.metadata.items() if k != "execute_time_s"}
    k = execute_index(replace(clean, metadata=metadata))
    rudder = clean.rudder_rad.copy()
    rudder[k - 40] = math.radians(15.0)
    pulsed = replace(clean, rudder_rad=rudder, metadata=metadata)
    assert pulsed.length_m == LENGTH_M
    assert execute_index(pulsed) == k
    log, _ = _prepared(pulsed, length_m=100.0)
    assert log.length_m == 100.0
    assert log.rudder_rad[k - 40] == rudder[k - 40]
    assert execute_index(log) == k - 40
