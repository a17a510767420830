"""The logs' order: with a constant current (or none) ``fit`` runs the EKF through the logs
by their largest rudder angle (``identifier.preparation.ekf_order``), so the logs given in any
order give the same model; a drifting current keeps the order they were sailed in."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from fmu_model import load_params
from identifier.cli import main
from identifier.identify import FitSettings, identify
from identifier.preparation import ekf_order
from scenarios.synthesize import MANEUVERS, synthesize_log
from tests.test_identify import _ship
from trials.logs import ManeuverLog, write_log

ORDER_NOTE = "the EKF runs through the logs by their largest rudder angle, smallest first"


def _seed_logs() -> list[ManeuverLog]:
    """A 20/20 and a 10/10 zig-zag of the seed paper's ship (1 Hz), the larger one first."""
    return [
        synthesize_log(_ship(), MANEUVERS[name](), seed=seed)
        for seed, name in enumerate(("zigzag-20", "zigzag-10"))
    ]


def test_the_order_is_by_largest_rudder_angle_and_ties_by_content() -> None:
    big, small = _seed_logs()
    assert ekf_order([big, small]) == [1, 0]
    assert ekf_order([small, big]) == [0, 1]
    # Two logs of one largest angle: one order, whichever is given first.
    twin = replace(small, x_m=small.x_m + 1.0)
    first = ekf_order([small, twin])
    assert ekf_order([twin, small]) == first[::-1]
    # The angle is the largest magnitude, to either side.
    port = replace(small, rudder_rad=-2.5 * small.rudder_rad)
    assert ekf_order([port, big]) == [1, 0]


def test_fit_gives_the_same_model_for_the_logs_in_either_order() -> None:
    logs = _seed_logs()
    settings = FitSettings(model="shi2009", method="ekf")
    given, reversed_ = identify(logs, settings), identify(logs[::-1], settings)
    np.testing.assert_array_equal(given.params.coefficients, reversed_.params.coefficients)
    assert given.current is not None and reversed_.current is not None
    np.testing.assert_array_equal(given.current.vector, reversed_.current.vector)
    # The larger zig-zag given first was moved last, and the note says so by name.
    assert [log.n_samples for log in given.logs] == [logs[1].n_samples, logs[0].n_samples]
    assert f"{ORDER_NOTE} (its estimate weighs the last most): log 2, log 1" in given.notes
    assert not any(ORDER_NOTE in note for note in reversed_.notes)  # given in that order
    assert [entry["path"] for entry in given.params.identification["logs"]] == ["log 2", "log 1"]


def test_a_drifting_current_runs_through_the_logs_as_they_were_sailed() -> None:
    logs = _seed_logs()
    settings = FitSettings(model="shi2009", method="ekf", current="drifting")
    given, reversed_ = identify(logs, settings), identify(logs[::-1], settings)
    assert [log.n_samples for log in given.logs] == [log.n_samples for log in logs]
    assert not any(ORDER_NOTE in note for note in given.notes)
    moved = np.abs(given.params.coefficients - reversed_.params.coefficients)
    assert given.params.std is not None
    assert np.max(moved / given.params.std) > 0.05  # the order given is the order filtered


def test_the_order_holds_without_a_current_too() -> None:
    logs = _seed_logs()
    settings = FitSettings(model="shi2009", method="ekf", current="none")
    np.testing.assert_array_equal(
        identify(logs, settings).params.coefficients,
        identify(logs[::-1], settings).params.coefficients,
    )


def test_fit_on_the_command_line_writes_one_model_and_says_when_it_reordered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    paths = []
    for log, name in zip(_seed_logs(), ("zz20.csv", "zz10.csv"), strict=True):
        paths.append(tmp_path / name)
        write_log(paths[-1], log)
    coefficients, stderr = [], []
    for order, out in ((paths, "given.json"), (paths[::-1], "reversed.json")):
        args = ["fit", *map(str, order), "--model", "shi2009", "--method", "ekf"]
        assert main([*args, "-o", str(tmp_path / out)]) == 0
        coefficients.append(load_params(tmp_path / out).coefficients)
        stderr.append(capsys.readouterr().err)
    np.testing.assert_array_equal(*coefficients)
    note = f"note: {ORDER_NOTE} (its estimate weighs the last most): zz10.csv, zz20.csv"
    assert note in stderr[0]
    assert ORDER_NOTE not in stderr[1]
