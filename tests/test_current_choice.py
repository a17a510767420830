"""``--current auto``: a constant current where the logs show one (its fit predicts the
training logs' tracks twice as close as still water's, ``identifier.current.choose_current``),
and the default of a ship shorter than 20 m (``identifier.current.default_current``). The
fits of logs sailed in a current are in test_identify_at_sea.py; here the rules, a basin's
runs, and the warning on a model fitted with a current."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from identifier import identify as identify_module
from identifier.cli import main
from identifier.current import (
    CURRENT_EVIDENCE_RATIO,
    CurrentChoice,
    choose_current,
    default_current,
)
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.output_error import track_distance_m
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from tests.test_identify_at_sea import _with_current
from trials.errors import IdentificationError
from trials.logs import ManeuverLog, read_log

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"


@pytest.mark.parametrize(
    ("constant_m", "none_m", "kept"),
    [
        (1.36, 6.44, "constant"),  # a current the logs show: still water drifts off
        (0.57, 0.35, "none"),  # a current the estimator invents in a basin
        (42.0, 64.0, "none"),  # better, but not twice: a calm Mariner draw's phantom drift
        (1.0, 2.0, "constant"),  # halved: shown
        (0.5, 0.5, "none"),  # a tie: still water
        (math.inf, 0.35, "none"),  # the fit with a current diverges
        (0.35, math.inf, "constant"),
        (math.inf, math.inf, "none"),
    ],
)
def test_a_current_is_kept_where_it_halves_the_training_tracks_distance(
    constant_m: float, none_m: float, kept: str
) -> None:
    assert CURRENT_EVIDENCE_RATIO == 2.0
    assert choose_current({"constant": constant_m, "none": none_m}) == kept


@pytest.mark.parametrize(
    ("length_m", "measurements", "mode"),
    [
        (320.0, "track", "constant"),  # a ship
        (20.0, "track", "constant"),
        (19.99, "track", "auto"),  # a model (or a small craft): still water unless shown
        (7.0, "track", "auto"),
        (7.0, "velocities", "none"),  # a current needs the track
        (320.0, "velocities", "none"),
    ],
)
def test_a_fit_that_names_no_current_takes_one_by_the_ships_size(
    length_m: float, measurements: str, mode: str
) -> None:
    assert FitSettings().current is None
    assert default_current(length_m, measurements) == mode


def test_a_diverging_prediction_is_said_as_such_in_the_reason() -> None:
    """Not "inf m (RMS)" (the default fit of a 7 m model's zig-zags, whose fit with a
    current of 0.25 m/s did not sail its logs)."""
    assert identify_module._distance_text(2.671, " (RMS)") == "2.67 m (RMS)"
    assert identify_module._distance_text(0.348) == "0.348 m"
    assert identify_module._distance_text(math.inf) == "no distance (a prediction diverges)"


def test_the_choice_is_recorded_as_json() -> None:
    choice = CurrentChoice("none", {"constant": math.inf, "none": 0.35}, "why")
    record = json.loads(json.dumps(choice.as_dict(), allow_nan=False))
    assert record == {
        "requested": "auto",
        "kept": "none",
        "track_rms_m": {"constant": None, "none": 0.35},
        "reason": "why",
    }


@dataclass(frozen=True)
class Basin:
    """The HSVA 10/10 pair fitted with the default current, a model's auto (its stages and
    samples counted), and with --current none."""

    logs: list[ManeuverLog]
    auto: IdentificationResult
    still: IdentificationResult
    stages: list[str]
    counted: list[int]


@pytest.fixture(scope="module")
def basin() -> Basin:
    logs = [read_log(HSVA / f"hsva_zz10_{side}.csv") for side in ("stbd", "port")]
    settings = FitSettings(method="ekf")  # no current named: a 7 m model's is auto
    stages: list[str] = []
    counted: list[int] = []
    auto = identify(logs, settings, progress=counted.append, stage=stages.append)
    still = identify(logs, replace(settings, current="none"))
    return Basin(logs, auto, still, stages, counted)


def test_a_basins_runs_keep_still_water(basin: Basin) -> None:
    """The HSVA 10/10 pair: the estimator finds a current of some 0.03 m/s in the basin's
    still water (the structure's error); with it the fit predicts its own runs worse."""
    auto, still = basin.auto, basin.still
    choice = auto.current_choice
    assert choice is not None and choice.kept == "none"
    assert auto.current is None
    assert choice.track_rms_m["none"] < 0.8 * choice.track_rms_m["constant"]
    np.testing.assert_array_equal(auto.params.to_vector(), still.params.to_vector())
    env = auto.params.identification["environment"]
    assert env["current"] == "none" and env["current_choice"]["kept"] == "none"
    settings = auto.params.identification["settings"]
    assert settings["current"] == "auto"  # as asked; the rest the kept fit's (a thrust refit)
    assert {**settings, "current": "none"} == still.params.identification["settings"]
    assert auto.settings == replace(still.settings, current="auto")
    assert "in still water" in choice.reason


def test_the_kept_fits_distance_is_its_prediction_of_the_tracks(basin: Basin) -> None:
    """The recorded RMS is the still-water fit's predictions against the smoothed tracks,
    every sample after each run's execute alike."""
    auto, still = basin.auto, basin.still
    assert auto.current_choice is not None
    distances = np.concatenate(
        [
            track_distance_m(still.params, log, track)
            for log, track in zip(still.logs, still.tracks, strict=True)
        ]
    )
    assert auto.current_choice.track_rms_m["none"] == pytest.approx(
        math.sqrt(float(np.mean(distances**2))), rel=1e-12
    )


def test_the_two_fits_are_named_in_the_stages_and_the_samples_counted_once(basin: Basin) -> None:
    """What the fit's bar shows: smoothing, then every stage of the fit with a current, then
    of the one in still water, each by name; smoothing and the first EKF count the samples."""
    names = [f"smoothing {name}" for name in ("hsva_zz10_stbd.csv", "hsva_zz10_port.csv")]
    assert basin.stages[:2] == names
    with_current = [s for s in basin.stages if s.startswith("with a current: ")]
    still = [s for s in basin.stages if s.startswith("in still water: ")]
    assert basin.stages == [*names, *with_current, *still]
    assert with_current[:2] == [
        "with a current: equation-error start",
        "with a current: current: EKF pass 1",
    ]
    assert still[:2] == [
        "in still water: equation-error start",
        "in still water: EKF on every sample",
    ]
    assert sum(basin.counted) == 2 * sum(log.n_samples for log in basin.logs)


def test_a_models_fit_with_a_current_is_warned_about(basin: Basin) -> None:
    """A constant current asked for on a 7 m model's runs: the fit says what the current
    found in a basin is; still water and auto (the default) say nothing, nor a ship at sea
    (test_identify_at_sea.py)."""
    constant = identify(basin.logs, FitSettings(method="ekf", current="constant"))
    assert constant.current is not None
    warned = [w for w in constant.warnings if "a model's size" in w]
    assert warned == [
        f"L = 7 m, a model's size: in a basin's still water the current found here "
        f"({constant.current.speed_mps:.3f} m/s) is the structure's error, and it trades "
        "against the hull's coefficients; fit tank tests with --current none (or auto, the "
        "default at this size)"
    ]
    for quiet in (basin.still, basin.auto):
        assert not any("a model's size" in w for w in quiet.warnings)


def test_fit_says_the_models_size_chose_auto(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`fit` on a 7 m model's runs without --current: auto, said so, still water kept."""
    logs = [str(HSVA / f"hsva_zz10_{side}.csv") for side in ("stbd", "port")]
    out = tmp_path / "p.json"
    assert main(["fit", *logs, "--method", "ekf", "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert "current (auto → none): still water\n" in captured.out
    assert (
        "current choice (auto, a model's default: L < 20 m): none, as "
        "predicted open loop from execute" in captured.out
    )
    assert "a model's size: in a basin's still water" not in captured.err
    identification = json.loads(out.read_text(encoding="utf-8"))["identification"]
    assert identification["settings"]["current"] == "auto"
    assert identification["environment"]["current"] == "none"


@pytest.fixture(scope="module")
def model_zigzags() -> list[ManeuverLog]:
    """The KVLCC2 reference's 7 m model: zig-zags 10/10 and 20/20 at 5 Hz, 1 cm, 0.05°."""
    ship = reference_ship("kvlcc2", "model")
    return [
        synthesize_log(
            ship, MANEUVERS[name](), rate_hz=5.0, position_noise_m=0.01, heading_noise_deg=0.05,
            seed=seed,
        )
        for seed, name in enumerate(("zigzag-10", "zigzag-20"))
    ]  # fmt: skip


def test_a_models_default_keeps_a_current_its_logs_show(model_zigzags: list[ManeuverLog]) -> None:
    """A 7 m model, or a small craft, in 0.03 m/s towards 045 (2.5 % of its 1.18 m/s; the
    track moved by c·t, exactly what a uniform current does) without a speed log: the
    default (auto at this size) keeps the current, the still-water fit predicting its
    tracks many times worse; the same runs in still water keep still water."""
    current_ne = np.full(2, 0.03 / math.sqrt(2.0))
    drifted = [_with_current(log, current_ne) for log in model_zigzags]
    still, at_sea = (identify(logs, FitSettings(method="ekf")) for logs in (model_zigzags, drifted))
    assert still.settings.current == at_sea.settings.current == "auto"
    assert still.current_choice is not None and still.current_choice.kept == "none"
    assert at_sea.current_choice is not None and at_sea.current_choice.kept == "constant"
    rms = at_sea.current_choice.track_rms_m
    assert rms["none"] > 5.0 * CURRENT_EVIDENCE_RATIO * rms["constant"], rms
    assert at_sea.current is not None
    np.testing.assert_allclose(at_sea.current.vector, current_ne, atol=0.005)
    assert not any("a model's size" in w for w in at_sea.warnings)


@pytest.mark.parametrize("failing", ["constant", "none"])
def test_auto_keeps_the_fit_that_did_not_fail(
    model_zigzags: list[ManeuverLog], monkeypatch: pytest.MonkeyPatch, failing: str
) -> None:
    """A model's default fits twice; where one fit fails (here made to), the other is
    kept, and the choice says why, where a ship's default would have failed outright."""
    fit_as_given = identify_module._fit_thrust_ruled

    def fit_or_fail(data: Any, settings: FitSettings, *args: Any, **kwargs: Any) -> Any:
        if settings.current == failing:
            raise IdentificationError("the EKF diverges (made to, for this test)")
        return fit_as_given(data, settings, *args, **kwargs)

    monkeypatch.setattr(identify_module, "_fit_thrust_ruled", fit_or_fail)
    result = identify(model_zigzags, FitSettings(method="ekf"))
    kept = "none" if failing == "constant" else "constant"
    choice = result.current_choice
    assert choice is not None and choice.kept == kept and choice.track_rms_m == {}
    what = "the fit with a current" if failing == "constant" else "the still-water fit"
    assert choice.reason == f"{what} failed (the EKF diverges (made to, for this test))"
    assert (result.current is None) == (kept == "none")
    assert result.params.identification["environment"]["current"] == kept
