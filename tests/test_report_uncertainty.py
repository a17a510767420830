"""95 % intervals in the validation report: verdicts, table, JSON, figure, CLI.

The row and interval logic is checked on fabricated metrics and Monte-Carlo samples
(no simulation); one small ``validate --params`` run on the seed-structure test ship
checks the whole path, with its Monte Carlo on an in-process dask cluster.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from distributed import LocalCluster

from fmu_model import ModelParameters, save_params
from fmu_model.envelope import Envelope, Sides, Span
from fmu_model.export_native import build_native_fmu
from scenarios.cli import main
from scenarios.errors import ScenarioError
from scenarios.fmu_checks import FmuInfo, check_params_match
from scenarios.records import (
    ComparisonRow,
    Condition,
    Interval,
    ManeuverRun,
    UncertaintyBands,
    Validation,
)
from scenarios.report import (
    comparison_table,
    figure_names,
    format_table,
    render_markdown,
    validation_json,
)
from scenarios.uncertainty.results import (
    METRICS,
    STATUS_DIVERGED,
    STATUS_OK,
    ProgramUncertainty,
    UncertaintyResult,
)
from scenarios.validation import uncertainty_bands
from tests.conftest import SEED_COEFFICIENTS
from trials.maneuvers import turning_circle, zigzag
from trials.metrics import TurningMetrics, ZigzagMetrics
from trials.trajectory import empty_trajectory

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TURN = turning_circle(math.radians(35.0))
ZIGZAG = zigzag(math.radians(10.0), math.radians(10.0))


def _turning(advance_m: float, transfer_m: float, tactical_m: float) -> TurningMetrics:
    return TurningMetrics(
        direction=1,
        execute_time_s=0.0,
        approach_heading_rad=0.0,
        approach_speed_mps=5.0,
        advance_m=advance_m,
        transfer_m=transfer_m,
        tactical_diameter_m=tactical_m,
        time_to_90_s=100.0,
        time_to_180_s=200.0,
        max_advance_m=advance_m,
        max_transfer_m=tactical_m,
        steady_speed_ratio=0.7,
    )


def _zigzag(first_deg: float, second_deg: float) -> ZigzagMetrics:
    return ZigzagMetrics(
        rudder_rad=math.radians(10.0),
        heading_rad=math.radians(10.0),
        execute_time_s=0.0,
        initial_heading_rad=0.0,
        approach_speed_mps=5.0,
        reversal_times_s=(20.0, 60.0, 100.0),
        peak_times_s=(25.0, 65.0),
        first_overshoot_rad=math.radians(first_deg),
        second_overshoot_rad=math.radians(second_deg),
        third_overshoot_rad=None,
        initial_turning_time_s=20.0,
        time_to_check_yaw_s=5.0,
        period_s=80.0,
    )


def _runs(turning: TurningMetrics, zz: ZigzagMetrics) -> tuple[ManeuverRun, ManeuverRun]:
    return (
        ManeuverRun(TURN, empty_trajectory(0), turning),
        ManeuverRun(ZIGZAG, empty_trajectory(0), zz),
    )


def _validation(uncertainty: UncertaintyBands | None) -> Validation:
    """Reference: advance 300, transfer 120, tactical 310 m; overshoots 5 and 8 deg."""
    return Validation(
        fmu_path="ship.fmu",
        model_name="ship",
        model_length_m=100.0,
        reference_name="refship",
        reference_description="fabricated",
        reference_length_m=100.0,
        condition=Condition(5.0, 2.0, math.radians(2.34), 0.1),
        reference=_runs(_turning(300.0, 120.0, 310.0), _zigzag(5.0, 8.0)),
        predicted=_runs(_turning(320.0, 125.0, 330.0), _zigzag(4.0, 9.0)),
        criteria=(),
        reference_criteria=(),
        uncertainty=uncertainty,
    )


def _interval(lo: float, hi: float, n_failed: int = 0) -> Interval:
    return Interval(lo=lo, hi=hi, mean=0.5 * (lo + hi), offset=0.0, n_samples=50, n_failed=n_failed)


# Verdicts by construction: inside, on the bound, above, below, no bounds, no interval.
BANDS = UncertaintyBands(
    intervals={
        ("turning-35-stbd", "advance_m"): _interval(290.0, 340.0),  # 300 inside
        ("turning-35-stbd", "transfer_m"): _interval(120.0, 130.0),  # 120 on the bound
        ("turning-35-stbd", "tactical_diameter_m"): _interval(315.0, 345.0),  # 310 below
        ("zigzag-10-10-stbd", "first_overshoot_deg"): _interval(3.5, 4.5),  # 5 above
        ("zigzag-10-10-stbd", "second_overshoot_deg"): _interval(math.nan, math.nan, 50),
    },
    n_samples=50,
    seed=7,
    dt_s=0.5,
    source="params.json",
)
VERDICTS = [True, True, False, False, None]


# ------------------------------------------------------------ rows and verdicts


@pytest.mark.parametrize(
    ("reference", "interval", "want"),
    [
        (1.0, _interval(0.5, 1.5), True),
        (0.5, _interval(0.5, 1.5), True),  # bounds belong to the interval
        (1.5, _interval(0.5, 1.5), True),
        (1.5000001, _interval(0.5, 1.5), False),
        (0.4999999, _interval(0.5, 1.5), False),
        (1.0, _interval(math.nan, math.nan), None),  # no sample gave a value
        (None, _interval(0.5, 1.5), None),  # the reference run lacks the quantity
        (1.0, None, None),  # no Monte Carlo
    ],
)
def test_in_interval_verdict(reference, interval, want):
    row = ComparisonRow("m", "advance_m", "advance", "m", reference, 1.0, None, None, interval)
    assert row.in_interval is want
    assert row.as_dict()["in_interval"] is want


def test_validation_rows_carry_their_intervals():
    v = _validation(BANDS)
    assert [r.in_interval for r in v.rows] == VERDICTS
    assert all(r.interval is BANDS.intervals[r.maneuver, r.quantity] for r in v.rows)
    assert all(r.interval is None and r.in_interval is None for r in _validation(None).rows)


def test_comparison_table_gets_the_interval_columns_only_with_bands():
    header, _ = comparison_table(_validation(None).rows)
    assert header[-1] == "difference" and len(header) == 6

    header, rows = comparison_table(_validation(BANDS).rows)
    assert header[-2:] == ["95 % interval", "in interval"]
    assert [row[-1] for row in rows] == ["yes", "yes", "no", "no", "n/a"]
    assert rows[0][-2] == "290.0 … 340.0"  # metres to 0.1
    assert rows[3][-2] == "3.50 … 4.50"  # degrees to 0.01
    assert rows[4][-2] == "n/a"
    lines = format_table(header, rows).splitlines()
    assert "95 % interval" in lines[0] and len(lines) == 2 + len(rows)


def test_json_markdown_and_figures_with_and_without_bands():
    doc = validation_json(_validation(BANDS))
    json.dumps(doc, allow_nan=False)  # the NaN bounds became null
    rows = doc["comparison"]
    assert [r["in_interval"] for r in rows] == VERDICTS
    assert rows[0]["interval"] == {
        "lo": 290.0,
        "hi": 340.0,
        "mean": 315.0,
        "offset": 0.0,
        "n_samples": 50,
        "n_failed": 0,
        "model_form": 0.0,
    }
    assert rows[4]["interval"]["lo"] is None and rows[4]["interval"]["n_failed"] == 50
    u = doc["uncertainty"]
    assert (u["n_samples"], u["seed"], u["dt_s"], u["source"]) == (50, 7, 0.5, "params.json")
    assert (u["n_in_interval"], u["n_with_interval"]) == (2, 4)
    assert "not model-structure error" in u["scope"]

    text = render_markdown(_validation(BANDS))
    assert "| 95 % interval | in interval |" in text
    assert "50 Monte-Carlo samples" in text and "not model-structure error" in text
    assert "2 of 4 quantities" in text
    assert "2nd overshoot (50 of 50)" in text  # the failed samples are named
    assert figure_names(_validation(BANDS))[-1] == "uncertainty.png"
    assert "](uncertainty.png)" in text

    plain = _validation(None)
    doc = validation_json(plain)
    assert doc["uncertainty"] is None
    assert all(r["interval"] is None and r["in_interval"] is None for r in doc["comparison"])
    assert "uncertainty.png" not in figure_names(plain)
    assert "95 % interval" not in render_markdown(plain)


# --------------------------------------------------- from Monte-Carlo samples


def test_uncertainty_bands_move_the_samples_to_the_predicted_value(seed_params):
    """Quantiles of the fabricated samples plus (predicted − value at θ̂), in row units."""
    rng = np.random.default_rng(3)
    n = 40
    turning = rng.normal([330.0, 126.0, 332.0, 250.0], [5.0, 2.0, 6.0, 9.0], (n, 4))
    turning[:3] = math.nan  # three diverged samples
    zz = np.radians(rng.normal([4.2, 9.1], [0.2, 0.4], (n, 2)))
    zz[:, 1][5] = math.nan  # one sample without a second overshoot
    status = np.full(n, STATUS_OK)
    status[:3] = STATUS_DIVERGED
    nominal_turning = np.array([328.0, 124.0, 331.0, 249.0])
    result = UncertaintyResult(
        params=seed_params,
        programs=(
            ProgramUncertainty(
                TURN, METRICS["turning"], turning, status, nominal_turning, STATUS_OK
            ),
            ProgramUncertainty(
                ZIGZAG,
                METRICS["zigzag"],
                zz,
                np.full(n, STATUS_OK),
                np.array([math.radians(4.1), math.nan]),  # θ̂ missed the 2nd overshoot
                STATUS_OK,
            ),
        ),
        coefficient_samples=np.zeros((n, seed_params.to_vector().size)),
        seed=11,
        jitter=0.0,
        speed_mps=5.0,
        n_rps=2.0,
        rudder_rate_radps=math.radians(2.34),
        dt_s=0.5,
        chunk_size=n,
    )
    rows = _validation(None).rows  # predicted: 320, 125, 330 m; 4, 9 deg
    bands = uncertainty_bands(result, rows, source="p.json")
    assert (bands.n_samples, bands.seed, bands.dt_s, bands.source) == (n, 11, 0.5, "p.json")

    advance = bands.intervals["turning-35-stbd", "advance_m"]
    valid = turning[3:, 0]
    assert advance.offset == pytest.approx(320.0 - 328.0)
    assert advance.lo == pytest.approx(np.quantile(valid, 0.025) - 8.0, rel=1e-12)
    assert advance.hi == pytest.approx(np.quantile(valid, 0.975) - 8.0, rel=1e-12)
    assert advance.mean == pytest.approx(valid.mean() - 8.0, rel=1e-12)
    assert (advance.n_samples, advance.n_failed) == (n, 3)

    first = bands.intervals["zigzag-10-10-stbd", "first_overshoot_deg"]
    degrees = np.degrees(zz[:, 0])
    assert first.offset == pytest.approx(4.0 - 4.1, rel=1e-9)
    assert first.lo == pytest.approx(np.quantile(degrees, 0.025) - 0.1, rel=1e-9)
    assert first.hi == pytest.approx(np.quantile(degrees, 0.975) - 0.1, rel=1e-9)
    assert first.n_failed == 0

    second = bands.intervals["zigzag-10-10-stbd", "second_overshoot_deg"]
    second_deg = np.degrees(zz[:, 1])
    assert second.offset == 0.0  # nothing to move by: the samples stay where they are
    assert second.lo == pytest.approx(np.nanquantile(second_deg, 0.025), rel=1e-12)
    assert second.n_failed == 1
    assert len(bands.intervals) == len(rows)  # steady diameter is not compared


# ------------------------------------------------------ params against the FMU


def _info(**changes: float) -> FmuInfo:
    parameters = {"length": 100.0, "u0": 5.0, **SEED_COEFFICIENTS, **changes}
    return FmuInfo("ship.fmu", "testship", 100.0, 5.0, 120.0, 0.6, 0.05, parameters)


def test_params_must_match_the_fmu(seed_params):
    check_params_match(_info(), seed_params)  # the same coefficients: no error
    with pytest.raises(ScenarioError, match=r"p\.json: .*c3 = 0\.0036 but 0\.0037 in the FMU"):
        check_params_match(_info(c3=0.0037), seed_params, "p.json")
    with pytest.raises(ScenarioError, match="the FMU's model is 'otherchip'"):
        check_params_match(
            FmuInfo("o.fmu", "otherchip", 100.0, 5.0, 120.0, 0.6, 0.05, _info().parameters),
            seed_params,
        )
    parameters = dict(_info().parameters)
    del parameters["b4"]
    with pytest.raises(ScenarioError, match="no parameter b4"):
        check_params_match(
            FmuInfo("o.fmu", "testship", 100.0, 5.0, 120.0, 0.6, 0.05, parameters), seed_params
        )


# -------------------------------------------------------------------- the CLI


def _uncertain(params: ModelParameters) -> ModelParameters:
    """The same ship with independent 1 % standard deviations on its coefficients."""
    theta = params.to_vector()
    return params.with_vector(theta, np.diag((0.01 * np.abs(theta)) ** 2))


@pytest.fixture(scope="module")
def ship(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A native FMU of the seed-structure test ship and its params.json with covariance."""
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    folder = tmp_path_factory.mktemp("uncertain")
    # Logs steered to 20° at most (turning and slowing as much as anything sailed here):
    # the 35° turns go beyond on the rudder, the zig-zags stay within.
    rudder = Sides(math.radians(20.0), math.radians(20.0))
    logs = Envelope(rudder, Sides(5.0, 5.0), 0.0, Span(0.1, 100.0), Span(0.0, 100.0))
    identified = replace(_uncertain(params), identification={"envelope": logs.as_dict()})
    save_params(folder / "params.json", identified)
    other = params.with_vector(params.to_vector() * 1.01)
    save_params(folder / "other.json", _uncertain(other))
    return build_native_fmu(params, folder / "testship.fmu"), folder


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    """Two thread workers in this process: no process start-up for a small run."""
    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=False,
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": ":0"},
    ) as cluster:
        yield cluster.scheduler_address


def test_validate_with_params_adds_intervals_and_figure(ship, scheduler, tmp_path, capsys):
    fmu, folder = ship
    report = tmp_path / "report"
    status = main(
        [
            "validate",
            "--fmu",
            str(fmu),
            "--reference",
            "kvlcc2",
            "--report",
            str(report),
            "--dt-s",
            "0.5",
            "--params",
            str(folder / "params.json"),
            "--uncertainty-samples",
            "8",
            "--scheduler",
            scheduler,
            "--quiet",
        ]
    )
    assert status == 0
    out = capsys.readouterr().out
    header = out.splitlines()[1]
    assert "95 % interval" in header and "in interval" in header
    assert "8 Monte-Carlo samples" in out
    assert header.endswith("beyond the logs")
    assert "- turning-35-port: rudder 35.0 deg to port (logs: 20.0 deg)" in out

    doc = json.loads((report / "validation.json").read_text())
    assert doc["uncertainty"]["n_samples"] == 8
    for row in doc["comparison"]:
        band = row["interval"]
        assert band["n_samples"] == 8 and band["n_failed"] == 0, row["label"]
        assert band["lo"] < band["hi"], row["label"]
        assert row["in_interval"] is (band["lo"] <= row["reference"] <= band["hi"])
    # A 100 m ship against the 320 m KVLCC2: no turning index can be inside.
    assert not any(r["in_interval"] for r in doc["comparison"] if r["unit"] == "m")
    beyond = doc["extrapolation"]["beyond"]
    assert beyond["zigzag-10-10-stbd"] == [] and beyond["turning-35-stbd"]
    assert (report / "uncertainty.png").read_bytes().startswith(PNG_MAGIC)
    text = (report / "report.md").read_text()
    assert "](uncertainty.png)" in text and "not model-structure error" in text

    # Parameters that are not the FMU's: one line, exit 1, before anything runs.
    status = main(
        [
            "validate",
            "--fmu",
            str(fmu),
            "--report",
            str(tmp_path / "other"),
            "--params",
            str(folder / "other.json"),
            "--quiet",
        ]
    )
    assert status == 1
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "do not match the FMU" in err and "other.json" in err
    assert not (tmp_path / "other").exists()


def test_uncertainty_options_need_params(capsys):
    with pytest.raises(SystemExit) as excinfo:
        main(["validate", "--fmu", "x.fmu", "--report", "r", "--uncertainty-samples", "5"])
    assert excinfo.value.code == 2
    assert "--uncertainty-samples needs --params" in capsys.readouterr().err
