"""``--current auto``: a constant current or still water, whichever predicts the training
logs' tracks better (``identifier.current.choose_current``). The fits of logs sailed in a
current are in test_identify_at_sea.py; here the rule itself, a basin's runs, and the
warning on a model fitted with a current."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from identifier.current import DEFAULT_CURRENT, CurrentChoice, choose_current
from identifier.identify import FitSettings, IdentificationResult, identify
from identifier.output_error import track_distance_m
from trials.logs import ManeuverLog, read_log

HSVA = Path(__file__).resolve().parents[2] / "shared" / "data" / "hsva_kvlcc2"


@pytest.mark.parametrize(
    ("constant_m", "none_m", "kept"),
    [
        (1.36, 6.44, "constant"),  # a current the logs show: still water drifts off
        (0.57, 0.35, "none"),  # a current the estimator invents in a basin
        (0.5, 0.5, "constant"),  # a tie keeps the current
        (math.inf, 0.35, "none"),  # the fit with a current diverges
        (0.35, math.inf, "constant"),
        (math.inf, math.inf, "constant"),
    ],
)
def test_the_better_prediction_of_the_training_tracks_is_kept(
    constant_m: float, none_m: float, kept: str
) -> None:
    assert choose_current({"constant": constant_m, "none": none_m}) == kept


def test_the_choice_is_recorded_as_json() -> None:
    choice = CurrentChoice("none", {"constant": math.inf, "none": 0.35}, "why")
    record = json.loads(json.dumps(choice.as_dict(), allow_nan=False))
    assert record == {
        "requested": "auto",
        "kept": "none",
        "track_rms_m": {"constant": None, "none": 0.35},
        "reason": "why",
    }
    assert FitSettings().current == DEFAULT_CURRENT == "constant"  # auto is asked for


@dataclass(frozen=True)
class Basin:
    """The HSVA 10/10 pair fitted with --current auto (its stages and samples counted) and
    with --current none."""

    logs: list[ManeuverLog]
    auto: IdentificationResult
    still: IdentificationResult
    stages: list[str]
    counted: list[int]


@pytest.fixture(scope="module")
def basin() -> Basin:
    logs = [read_log(HSVA / f"hsva_zz10_{side}.csv") for side in ("stbd", "port")]
    settings = FitSettings(method="ekf", current="auto")
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
    """The default (a constant current) on a 7 m model's runs says what the current found in
    a basin is; still water says nothing (nor a ship at sea: test_identify_at_sea.py)."""
    constant = identify(basin.logs, FitSettings(method="ekf"))
    assert constant.current is not None
    warned = [w for w in constant.warnings if "a model's size" in w]
    assert warned == [
        f"L = 7 m, a model's size: in a basin's still water the current found here "
        f"({constant.current.speed_mps:.3f} m/s) is the structure's error, and it trades "
        "against the hull's coefficients; fit tank tests with --current none"
    ]
    assert not any("a model's size" in w for w in basin.still.warnings)
