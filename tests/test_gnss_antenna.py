"""Positions logged by a GNSS antenna away from midship, reduced to the midship point.

A tanker's antenna is on the bridge, some 0.4 L aft of midship: in a hard turn that point
moves sideways 1.5 m/s more than midship, and the IMO indices (and the models) are of the
midship point. The logs say where the antenna is (metadata ``gnss_x_m``, ``gnss_y_m``).
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import ModelParameters
from identifier.cli import main
from identifier.crossval import held_out_errors
from identifier.identify import FitSettings, identify
from scenarios.synthesize import MANEUVERS, TruthShip, reference_ship, synthesize_log
from trials.conditions import log_trajectory
from trials.errors import LogFormatError
from trials.logs import ManeuverLog, at_midship, read_log, write_log
from trials.maneuvers import turning_circle
from trials.metrics import turning_metrics
from trials.run import ModelPlant, run_program

AFT_M = -128.0  # 0.4 L aft of KVLCC2's midship: the bridge


def _log(heading_deg: float, **metadata: str) -> ManeuverLog:
    n = 12
    return ManeuverLog(
        time_s=np.arange(n, dtype=float),
        x_m=np.full(n, 100.0),
        y_m=np.full(n, 50.0),
        heading_rad=np.full(n, math.radians(heading_deg)),
        rudder_rad=np.zeros(n),
        n_rps=np.ones(n),
        metadata={"vessel": "x", **metadata},
    )


@pytest.mark.parametrize(
    ("heading_deg", "forward_m", "starboard_m", "midship_ne"),
    [
        (0.0, 10.0, 0.0, (90.0, 50.0)),  # heading North, antenna 10 m forward: 10 m South
        (90.0, 10.0, 0.0, (100.0, 40.0)),  # heading East: 10 m West
        (0.0, 0.0, 5.0, (100.0, 45.0)),  # heading North, 5 m to starboard: 5 m West
        (180.0, -20.0, 5.0, (80.0, 55.0)),  # heading South, 20 m aft, 5 m to starboard
    ],
)
def test_the_midship_point_by_hand(
    heading_deg: float, forward_m: float, starboard_m: float, midship_ne: tuple[float, float]
) -> None:
    log = _log(heading_deg, gnss_x_m=repr(forward_m), gnss_y_m=repr(starboard_m))
    midship = at_midship(log)
    np.testing.assert_allclose(midship.x_m, midship_ne[0], atol=1e-12)
    np.testing.assert_allclose(midship.y_m, midship_ne[1], atol=1e-12)
    assert "gnss_x_m" not in midship.metadata and "gnss_y_m" not in midship.metadata
    assert midship.metadata["vessel"] == "x"
    assert at_midship(midship) is midship  # reduced once: the keys are gone


def test_without_an_offset_the_log_itself() -> None:
    plain = _log(30.0)
    assert at_midship(plain) is plain
    zeros = _log(30.0, gnss_x_m="0", gnss_y_m="0.0")
    assert at_midship(zeros) is zeros


def test_an_offset_beyond_the_ship_is_a_one_line_error(tmp_path: Path) -> None:
    path = tmp_path / "antenna.csv"
    write_log(path, _log(0.0))
    lines = path.read_text().splitlines()
    path.write_text("\n".join(["# gnss_y_m: port", *lines]) + "\n")
    with pytest.raises(LogFormatError) as info:
        read_log(path)
    assert str(info.value) == (
        f"{path}:1: metadata 'gnss_y_m': expected the GNSS antenna's position to starboard "
        "of the centre line within ±500 m, got 'port'"
    )
    with pytest.raises(LogFormatError, match="metadata 'gnss_x_m': expected the GNSS antenna"):
        at_midship(_log(0.0, gnss_x_m="-600"))


def test_a_synthesized_antenna_track_reduces_to_the_midship_track() -> None:
    """The same run logged at the bridge (exact heading): at_midship gives midship's track."""
    ship = reference_ship("kvlcc2", "full")
    program = MANEUVERS["turning-35"]()
    kwargs = {"seed": 3, "heading_noise_deg": 0.0, "approach_s": 30.0}
    midship = synthesize_log(ship, program, **kwargs)
    bridge = synthesize_log(ship, program, gnss_x_m=AFT_M, gnss_y_m=2.0, **kwargs)
    assert bridge.on_board_m("gnss_x_m") == AFT_M and bridge.on_board_m("gnss_y_m") == 2.0
    # in the turn the antenna's circle is not midship's: up to 2 × 128 m apart
    assert float(np.max(np.hypot(bridge.x_m - midship.x_m, bridge.y_m - midship.y_m))) > 100.0
    reduced = at_midship(bridge)
    np.testing.assert_allclose(reduced.x_m, midship.x_m, atol=1e-8)
    np.testing.assert_allclose(reduced.y_m, midship.y_m, atol=1e-8)
    # The measured indices of a log are the midship point's, wherever the antenna is.
    np.testing.assert_allclose(log_trajectory(bridge)["y_m"], midship.y_m, atol=1e-8)


def test_identification_from_the_bridge_equals_the_midship_one() -> None:
    """Reduced, the bridge's zig-zags identify the midship model; ignored, another one."""
    ship = reference_ship("kvlcc2", "full")
    settings = FitSettings(method="ekf", current="none")
    names = ("zigzag-10", "zigzag-20")
    midship = [synthesize_log(ship, MANEUVERS[n](), seed=k) for k, n in enumerate(names)]
    bridge = [
        synthesize_log(ship, MANEUVERS[n](), seed=k, gnss_x_m=AFT_M) for k, n in enumerate(names)
    ]
    ignored = [
        replace(g, metadata={k: v for k, v in g.metadata.items() if k != "gnss_x_m"})
        for g in bridge
    ]
    fits = [identify(logs, settings) for logs in (midship, bridge, ignored)]
    assert any("positions reduced to midship from the GNSS antenna's, 128 m aft and 0 m" in n
               for n in fits[1].notes)  # fmt: skip
    # The 35° turn they predict: the reduced fit's within 1 % of the midship fit's (the
    # heading noise moves the reduced positions by 0.1° × 128 m = 0.2 m); taken as
    # midship's, the bridge's track puts the advance some 12 % further.
    advance, tactical = np.array([_turn(fit.params, ship) for fit in fits]).T
    np.testing.assert_allclose(advance[1], advance[0], rtol=0.01)
    np.testing.assert_allclose(tactical[1], tactical[0], rtol=0.01)
    assert advance[2] > 1.05 * advance[0]
    # The held-out replay compares the model with the midship track too.
    turn = synthesize_log(ship, MANEUVERS["turning-35"](), seed=5, gnss_x_m=AFT_M)
    plain = synthesize_log(ship, MANEUVERS["turning-35"](), seed=5)
    at_bridge = held_out_errors(fits[1].params, turn)
    at_midship_point = held_out_errors(fits[1].params, plain)
    assert at_bridge.position_rms_m == pytest.approx(at_midship_point.position_rms_m, rel=0.05)


def _turn(params: ModelParameters, ship: TruthShip) -> tuple[float, float]:
    """Advance and tactical diameter [m] of the model's 35° starboard turn from the approach."""
    run = run_program(
        ModelPlant(params),
        turning_circle(math.radians(35.0)),
        speed_mps=ship.speed_mps,
        n_rps=ship.n_rps,
        rudder_rate_radps=ship.rudder_rate_radps,
        dt_s=1.0,
    )
    metrics = turning_metrics(run)
    return metrics.advance_m, metrics.tactical_diameter_m


def test_convert_writes_where_the_antenna_is(tmp_path: Path) -> None:
    """``--gnss-x-m``/``--gnss-y-m`` become the log's metadata (lat/lon CSV here)."""
    lines = ["time_s,lat_deg,lon_deg,heading_deg,rudder_deg,rpm"]
    lines += [f"{k},{63.0 + 1e-5 * k:.7f},10.0,0.0,{5.0 * (k > 5)},60" for k in range(20)]
    source = tmp_path / "trial.csv"
    source.write_text("\n".join(lines) + "\n")
    out = tmp_path / "log.csv"
    options = ["--gnss-x-m", "-128", "--gnss-y-m", "1.5", "--vessel", "t", "--quiet"]
    assert main(["convert", str(source), "-o", str(out), *options]) == 0
    log = read_log(out)
    assert (log.on_board_m("gnss_x_m"), log.on_board_m("gnss_y_m")) == (-128.0, 1.5)
    assert log.on_board_m("speed_log_x_m") is None
    with pytest.raises(ValueError, match="key must be one of"):
        log.on_board_m("antenna_z_m")
