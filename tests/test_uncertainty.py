"""Monte-Carlo uncertainty of manoeuvre metrics: analytic cases, reproducibility, failures.

The analytic ship is the seed structure (Shi et al. 2009) reduced to a first-order yaw
equation: every surge and sway coefficient is zero and n = 0, so u = U and v = 0 for
ever, and r' = c2 r + c3 δ. With the rudder held at δ the yaw rate settles at
r∞ = −c3 δ / c2 and the ship runs on a circle of diameter D = 2U / r∞ = 2U(−c2)/(δ c3).
With only c3 uncertain, c3 ~ N(μ, σ²), D = K / c3 is a monotone function of c3: its
quantiles are K / (μ + σ Φ⁻¹(1 − q)), and its mean and standard deviation follow by
quadrature over the normal density.
"""

from __future__ import annotations

import argparse
import json
import logging
import math
import re
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import distributed
import numpy as np
import pytest
from distributed import Client, LocalCluster
from scipy import integrate, stats

from fmu_model import ModelParameters, get_model, save_params
from scenarios.cli.uncertainty import add_uncertainty_command, run_uncertainty_command
from scenarios.errors import UncertaintyError
from scenarios.uncertainty.monte_carlo import monte_carlo_metrics, program_metrics
from scenarios.uncertainty.results import STATUS_DIVERGED, STATUS_INCOMPLETE, STATUS_OK
from scenarios.uncertainty.sampling import draw_coefficients
from trials.maneuvers import turning_circle, zigzag
from trials.metrics import TURN_BACK_TOLERANCE_RAD, turned_back_rad
from trials.run import ModelPlant, run_batch, run_program

NAMES = get_model("shi2009").coefficient_names
LENGTH_M = 100.0
SPEED_MPS = 5.0
C2 = -0.2  # yaw damping [1/s], time constant 5 s
C3 = 0.011  # rudder yaw effectiveness [1/s²]
RUDDER_RAD = math.radians(35.0)
K_DIAMETER = 2.0 * SPEED_MPS * (-C2) / RUDDER_RAD  # D = K / c3, K [m/s²]
TURN = turning_circle(RUDDER_RAD, max_time_s=900.0)
DEG = math.pi / 180.0


def linear_ship(*, c2_std: float = 0.0, c3_std: float = 0.0) -> ModelParameters:
    """First-order-yaw ship (module docstring) with independent c2 and c3 uncertainty."""
    theta = np.zeros(len(NAMES))
    theta[NAMES.index("c2")] = C2
    theta[NAMES.index("c3")] = C3
    variance = np.zeros(len(NAMES))
    variance[NAMES.index("c2")] = c2_std**2
    variance[NAMES.index("c3")] = c3_std**2
    return ModelParameters(
        model="shi2009",
        coefficients=theta,
        length_m=LENGTH_M,
        vessel_name="linear-yaw",
        nominal_speed_mps=SPEED_MPS,
        nominal_n_rps=0.0,
        covariance=np.diag(variance),
    )


@pytest.fixture(scope="module")
def client() -> Iterator[Client]:
    """Two single-thread workers in this process (fast to start; the tests are small)."""
    with (
        LocalCluster(
            n_workers=2,
            threads_per_worker=1,
            processes=False,
            dashboard_address=None,
            scheduler_kwargs={"dashboard_address": ":0"},
        ) as cluster,
        Client(cluster) as c,
    ):
        yield c


# --------------------------------------------------------------------------------------
# The vectorised driver is run_program, many ships at once
# --------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "program",
    [turning_circle(RUDDER_RAD, max_time_s=600.0), zigzag(10.0 * DEG, 10.0 * DEG)],
    ids=["turning", "zigzag"],
)
def test_batch_equals_run_program_per_sample(seed_params: ModelParameters, program: object) -> None:
    rng = np.random.default_rng(3)
    theta = seed_params.to_vector()[:, None] * (1.0 + 0.1 * rng.standard_normal((16, 4)))
    batch = run_batch(
        ModelPlant(seed_params, thetas=theta),
        program,  # type: ignore[arg-type]
        speed_mps=5.0,
        n_rps=2.0,
        rudder_rate_radps=2.34 * DEG,
        dt_s=0.5,
        divergence_factor=10.0,
    )
    assert not batch.diverged.any()
    ends = set()
    for j, traj in enumerate(batch.trajectories):
        ref = run_program(
            ModelPlant(seed_params.with_vector(theta[:, j])),
            program,  # type: ignore[arg-type]
            speed_mps=5.0,
            n_rps=2.0,
            rudder_rate_radps=2.34 * DEG,
            dt_s=0.5,
        )
        assert traj is not None
        assert traj.size == ref.size
        for name in ref.dtype.names or ():
            np.testing.assert_allclose(traj[name], ref[name], rtol=1e-12, atol=1e-9)
        ends.add(traj.size)
    # Each ship ends (and, in the zig-zag, reverses its rudder) at its own time.
    assert len(ends) > 1


# --------------------------------------------------------------------------------------
# Drawing coefficient sets
# --------------------------------------------------------------------------------------


def test_draw_reproducible_and_fixed_coefficients_stay_fixed() -> None:
    params = linear_ship(c3_std=0.001)
    a, jitter = draw_coefficients(params, 50, seed=7)
    b, _ = draw_coefficients(params, 50, seed=7)
    c, _ = draw_coefficients(params, 50, seed=8)
    assert jitter == 0.0
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    fixed = [i for i, name in enumerate(NAMES) if name != "c3"]
    np.testing.assert_array_equal(a[:, fixed], np.tile(params.to_vector()[fixed], (50, 1)))


def test_draw_has_the_covariance() -> None:
    cov = np.zeros((16, 16))
    block = np.array([[4.0, -1.2], [-1.2, 1.0]]) * 1e-6
    cov[14:, 14:] = block  # c2, c3 correlated (ρ = −0.6)
    params = linear_ship().with_vector(linear_ship().to_vector(), cov)
    samples, jitter = draw_coefficients(params, 20000, seed=1)
    assert jitter == 0.0
    np.testing.assert_allclose(samples.mean(axis=0), params.to_vector(), atol=7e-5)
    # Sample covariance: entries within ~5 standard errors (σ_ij √(2/N) at most).
    np.testing.assert_allclose(np.cov(samples[:, 14:].T), block, atol=5 * 4e-6 * 0.01)


def test_draw_singular_covariance_uses_jitter() -> None:
    cov = np.zeros((16, 16))
    cov[14:, 14:] = np.array([[1.0, 1.0], [1.0, 1.0]]) * 1e-6  # ρ = 1 exactly
    params = linear_ship().with_vector(linear_ship().to_vector(), cov)
    samples, jitter = draw_coefficients(params, 100, seed=0)
    assert 0.0 < jitter <= 1e-6
    deviation = samples[:, 14:] - params.to_vector()[14:]
    np.testing.assert_allclose(deviation[:, 0], deviation[:, 1], atol=1e-3 * 1e-3 * 5)


@pytest.mark.parametrize(
    ("covariance", "match"),
    [
        (None, "no covariance"),
        (np.diag(np.r_[np.zeros(15), -1.0]), "negative variance"),
        (np.eye(16) + np.diag(np.ones(15), 1) * 0.9, "not symmetric"),
        (
            np.eye(16) + 0.9 * (np.diag(np.ones(15), 1) + np.diag(np.ones(15), -1)),
            "not positive semi-definite",
        ),
    ],
    ids=["missing", "negative", "asymmetric", "indefinite"],
)
def test_draw_rejects_bad_covariance(covariance: np.ndarray | None, match: str) -> None:
    params = linear_ship().with_vector(linear_ship().to_vector(), covariance)
    with pytest.raises(UncertaintyError, match=match):
        draw_coefficients(params, 10, seed=0)


# --------------------------------------------------------------------------------------
# Monte Carlo against the closed form
# --------------------------------------------------------------------------------------


def test_steady_diameter_distribution_is_analytic(client: Client) -> None:
    mu, sigma, n = C3, 0.05 * C3, 1000
    result = monte_carlo_metrics(
        linear_ship(c3_std=sigma), [TURN], n_samples=n, seed=11, client=client, chunk_size=250
    )
    entry = result.program(TURN.name)
    assert entry.n_diverged == entry.n_incomplete == 0
    d = entry.values[:, entry.metrics.index("steady_diameter_m")]

    # Sample by sample: D = K / c3 (RK4 on a circle, yaw transient e^-16 at 180°).
    c3 = result.coefficient_samples[:, NAMES.index("c3")]
    np.testing.assert_allclose(d, K_DIAMETER / c3, rtol=1e-6)
    s = result.summary(TURN.name, "steady_diameter_m")
    assert s.nominal == pytest.approx(K_DIAMETER / mu, rel=1e-6)

    # Distribution: quantiles, mean and std of K / c3 within 4 sampling standard errors.
    for q, value in ((0.025, s.q025), (0.975, s.q975)):
        c3_q = mu + sigma * stats.norm.ppf(1.0 - q)
        se_c3 = math.sqrt(q * (1.0 - q) / n) / stats.norm.pdf(stats.norm.ppf(q)) * sigma
        assert value == pytest.approx(K_DIAMETER / c3_q, abs=4.0 * se_c3 * K_DIAMETER / c3_q**2)

    def moment(k: int) -> float:
        def integrand(x: float) -> float:
            return float((K_DIAMETER / x) ** k * stats.norm.pdf(x, mu, sigma))

        return float(integrate.quad(integrand, mu - 10 * sigma, mu + 10 * sigma)[0])

    mean, std = moment(1), math.sqrt(moment(2) - moment(1) ** 2)
    assert s.mean == pytest.approx(mean, abs=4.0 * std / math.sqrt(n))
    assert s.std == pytest.approx(std, abs=4.0 * std / math.sqrt(2.0 * (n - 1)))
    assert s.n_failed == 0


def test_zero_covariance_every_sample_is_nominal(client: Client) -> None:
    programs = [TURN, zigzag(10.0 * DEG, 10.0 * DEG, max_time_s=900.0)]
    result = monte_carlo_metrics(
        linear_ship(), programs, n_samples=6, seed=0, client=client, chunk_size=4
    )
    for entry in result.programs:
        assert np.all(entry.status == STATUS_OK)
        np.testing.assert_allclose(entry.values, np.tile(entry.nominal, (6, 1)), rtol=1e-12)
        for s in entry.summaries():
            if math.isfinite(s.nominal):
                assert s.q025 == pytest.approx(s.nominal, rel=1e-12)
                assert s.q975 == pytest.approx(s.nominal, rel=1e-12)
                assert s.std == pytest.approx(0.0, abs=1e-9 * abs(s.nominal))


def test_seed_reproducible_whatever_the_chunks(client: Client) -> None:
    params = linear_ship(c3_std=0.1 * C3)
    a = monte_carlo_metrics(params, [TURN], n_samples=10, seed=5, client=client, chunk_size=3)
    b = monte_carlo_metrics(params, [TURN], n_samples=10, seed=5, client=client, chunk_size=10)
    c = monte_carlo_metrics(params, [TURN], n_samples=10, seed=6, client=client, chunk_size=10)
    np.testing.assert_allclose(a.programs[0].values, b.programs[0].values, rtol=1e-12)
    assert a.summary_table() == b.summary_table()
    assert not np.allclose(a.programs[0].values, c.programs[0].values)


# --------------------------------------------------------------------------------------
# Failed samples are counted, not raised
# --------------------------------------------------------------------------------------


def test_diverging_ships_are_counted(client: Client) -> None:
    # σ(c2) = 0.3: a quarter of the ships are yaw-unstable (c2 > 0); r grows as e^{c2 t}
    # beyond 10 U/L before the heading reaches 540° when c2 is clearly positive.
    result = monte_carlo_metrics(
        linear_ship(c2_std=0.3), [TURN], n_samples=40, seed=2, client=client, chunk_size=20
    )
    entry = result.programs[0]
    c2 = result.coefficient_samples[:, NAMES.index("c2")]
    assert np.all(entry.status[c2 > 0.1] == STATUS_DIVERGED)
    assert np.all(entry.status[c2 < -0.02] == STATUS_OK)
    assert entry.n_diverged >= np.count_nonzero(c2 > 0.1) > 0
    advance = result.summary(TURN.name, "advance_m")
    assert advance.n_failed == entry.n_diverged + entry.n_incomplete
    # Heavily damped ships (c2 ≈ −0.9) turn too slowly to reach 540° in the time limit:
    # no steady diameter, although the run itself is fine.
    steady = entry.values[:, entry.metrics.index("steady_diameter_m")]
    s = result.summary(TURN.name, "steady_diameter_m")
    assert s.n_failed == np.count_nonzero(np.isnan(steady)) > advance.n_failed
    assert s.mean == pytest.approx(np.nanmean(steady), rel=1e-12)
    record = result.as_dict()["programs"][TURN.name]
    assert record["n_diverged"] == entry.n_diverged
    assert record["metrics"]["advance_m"]["n_failed"] == advance.n_failed
    json.dumps(result.as_dict(include_samples=True), allow_nan=False)


def test_ships_turning_the_wrong_way_are_incomplete(client: Client) -> None:
    # Time limits: enough for c3 > C3 / 2 to reach 180° (turning) or 10° (zig-zag).
    turn = turning_circle(RUDDER_RAD, max_time_s=400.0)
    zz = zigzag(10.0 * DEG, 10.0 * DEG, max_time_s=150.0)
    result = monte_carlo_metrics(
        linear_ship(c3_std=C3), [turn, zz], n_samples=30, seed=4, client=client, chunk_size=15
    )
    c3 = result.coefficient_samples[:, NAMES.index("c3")]
    assert np.count_nonzero(c3 < 0.0) > 0
    for entry in result.programs:
        assert np.all(entry.status[c3 < 0.0] == STATUS_INCOMPLETE)
        assert np.all(entry.status[c3 > 0.5 * C3] == STATUS_OK)
        assert entry.n_incomplete >= np.count_nonzero(c3 < 0.0)
        assert result.summary(entry.program.name, entry.metrics[0]).n_failed == (
            entry.n_incomplete + entry.n_diverged
        )
    assert "incomplete" not in result.summary_table()  # the table counts, the CLI explains
    assert f"/{result.n_samples} |" in result.summary_table()


@pytest.mark.parametrize(
    ("fall_deg", "status"),
    [(0.0, STATUS_OK), (1.5, STATUS_OK), (20.0, STATUS_INCOMPLETE)],
)
def test_a_turn_that_falls_back_against_its_rudder_is_incomplete(
    fall_deg: float, status: int
) -> None:
    # The linear ship's 35° turn (< 1° of heading a step) with its heading made to drop
    # by fall_deg in one step after 120° of turn and come round again (a sample that
    # loses its speed in the turn): falling back beyond TURN_BACK_TOLERANCE_RAD, its 180°
    # crossing is a loop's, and not a metric.
    traj = run_program(
        ModelPlant(linear_ship()),
        TURN,
        speed_mps=SPEED_MPS,
        n_rps=0.0,
        rudder_rate_radps=2.34 * DEG,
        dt_s=0.5,
    )
    turned = traj["psi_rad"] - traj["psi_rad"][0]
    start = int(np.argmax(turned > 120.0 * DEG))
    dip = np.interp(np.arange(turned.size), [start, start + 1, start + 81], [0.0, fall_deg, 0.0])
    traj["psi_rad"] -= dip * DEG
    fell = turned_back_rad(traj)
    assert (fell > 0.0) == (fall_deg > 0.0)
    assert (fell > TURN_BACK_TOLERANCE_RAD) == (status == STATUS_INCOMPLETE)
    values, found = program_metrics(TURN, traj)
    assert found == status
    assert np.isnan(values).all() == (status == STATUS_INCOMPLETE)


# --------------------------------------------------------------------------------------
# Clusters: a LocalCluster of its own, a scheduler address, bad settings
# --------------------------------------------------------------------------------------


def test_own_local_cluster_with_two_workers() -> None:
    params = linear_ship(c3_std=0.05 * C3)
    result = monte_carlo_metrics(
        params, [TURN], n_samples=8, seed=1, n_workers=2, processes=False, chunk_size=2
    )
    assert result.chunk_size == 2
    assert np.all(result.programs[0].status == STATUS_OK)


def test_scheduler_address(client: Client) -> None:
    params = linear_ship(c3_std=0.05 * C3)
    address = client.scheduler_info()["address"]
    via_address = monte_carlo_metrics(
        params, [TURN], n_samples=4, seed=1, scheduler=address, chunk_size=4
    )
    via_client = monte_carlo_metrics(
        params, [TURN], n_samples=4, seed=1, client=client, chunk_size=4
    )
    np.testing.assert_allclose(via_address.programs[0].values, via_client.programs[0].values)


# Loggers that spoke during a LocalCluster's teardown: the parent's and the workers'.
TEARDOWN_LOGGERS = (
    "distributed",
    "distributed.worker",
    "distributed.nanny",
    "distributed.batched",
    "distributed.core",
    "distributed.client",
    "distributed.scheduler",
    "tornado.application",
    "asyncio",
)


def _speaking(names: tuple[str, ...], level: int) -> list[str]:
    return [name for name in names if logging.getLogger(name).isEnabledFor(level)]


def test_own_local_cluster_is_silent_and_closes_quietly(monkeypatch: pytest.MonkeyPatch) -> None:
    """A --quiet run must not print distributed's shutdown noise (heartbeat errors).

    The cluster silences its and its workers' logs (``silence_logs`` at CRITICAL: a
    failed heartbeat is logged at ERROR), the client is closed before the cluster, and
    both close with distributed's loggers silenced, which are put back afterwards.
    """
    events: list[tuple[str, list[str]]] = []
    made: dict[str, Any] = {}

    class RecordingCluster(LocalCluster):
        def __init__(self, **kwargs: Any) -> None:
            made.update(kwargs)
            super().__init__(**kwargs)

        def close(self, *args: Any, **kwargs: Any) -> Any:
            events.append(("cluster", _speaking(TEARDOWN_LOGGERS, logging.CRITICAL)))
            return super().close(*args, **kwargs)

    class RecordingClient(Client):
        def close(self, *args: Any, **kwargs: Any) -> Any:
            if not any(what == "client" for what, _ in events):
                events.append(("client", _speaking(TEARDOWN_LOGGERS, logging.CRITICAL)))
            return super().close(*args, **kwargs)

    monkeypatch.setattr(distributed, "LocalCluster", RecordingCluster)
    monkeypatch.setattr(distributed, "Client", RecordingClient)
    levels = {name: logging.getLogger(name).level for name in TEARDOWN_LOGGERS}
    result = monte_carlo_metrics(
        linear_ship(c3_std=0.05 * C3), [TURN], n_samples=2, seed=1, n_workers=1, processes=False
    )
    assert np.all(result.programs[0].status == STATUS_OK)
    assert made["silence_logs"] >= logging.CRITICAL
    assert [what for what, _ in events[:2]] == ["client", "cluster"]
    assert all(speaking == [] for _, speaking in events), events
    assert {name: logging.getLogger(name).level for name in TEARDOWN_LOGGERS} == levels


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"n_samples": 0}, "at least 1"),
        ({"dt_s": 0.0}, "dt_s"),
        ({"dt_s": 1e-300}, r"turning-35-stbd: .* steps, more than 1e\+07"),
        ({"speed_mps": -1.0}, "approach speed"),
        ({"chunk_size": 0}, "chunk_size"),
        ({"scheduler": "tcp://x:1", "client": object()}, "either"),
    ],
)
def test_bad_settings(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(UncertaintyError, match=match):
        monte_carlo_metrics(linear_ship(c3_std=0.001), [TURN], **kwargs)  # type: ignore[arg-type]


# --------------------------------------------------------------------------------------
# Command line hook
# --------------------------------------------------------------------------------------


def _parse(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m scenarios")
    add_uncertainty_command(parser.add_subparsers(dest="command", required=True))
    return parser.parse_args(argv)


def test_cli_writes_json_and_table(
    client: Client, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "params.json"
    save_params(path, linear_ship(c3_std=0.05 * C3))
    out = tmp_path / "mc.json"
    argv = ["uncertainty", "--params", str(path), "--samples", "4", "--chunk-size", "4"]
    argv += ["--scheduler", client.scheduler_info()["address"], "--json", str(out), "--quiet"]
    args = _parse(argv)
    assert run_uncertainty_command(args) == 0
    captured = capsys.readouterr()
    assert "| turning-35-stbd | advance [m] |" in captured.out
    assert "| zigzag-20-20-stbd | first overshoot [deg] |" in captured.out
    assert captured.err == ""
    doc = json.loads(out.read_text())
    assert doc["sampling"]["n_samples"] == 4
    assert set(doc["programs"]["zigzag-10-10-stbd"]["metrics"]) == {
        "first_overshoot_deg",
        "second_overshoot_deg",
    }


def test_cli_says_which_samples_failed_and_why(
    client: Client, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # σ(c3) = C3: about one ship in six has a rudder that turns it the wrong way.
    path = tmp_path / "params.json"
    save_params(path, linear_ship(c3_std=C3))
    argv = ["uncertainty", "--params", str(path), "--samples", "12", "--seed", "4"]
    argv += ["--chunk-size", "12", "--scheduler", client.scheduler_info()["address"], "--quiet"]
    assert run_uncertainty_command(_parse(argv)) == 0
    lines = [x for x in capsys.readouterr().out.splitlines() if x.startswith("failed samples")]
    assert len(lines) == 1
    assert "incomplete: the run did not reach the event, or its turn fell back" in lines[0]
    assert re.search(r"turning-35-stbd: 0 diverged, [1-9]\d* incomplete", lines[0])


def test_cli_warns_of_a_ships_steering_rate_on_a_tank_model(
    client: Client, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A 7 m ship at the default 2.34 deg/s: one warning line; given its rate, none."""
    path = tmp_path / "model.json"
    save_params(path, replace(linear_ship(c3_std=0.05 * C3), length_m=7.0))
    argv = ["uncertainty", "--params", str(path), "--samples", "2", "--chunk-size", "2"]
    argv += ["--scheduler", client.scheduler_info()["address"], "--quiet"]
    for rate, expected in (([], 2.34), (["--rudder-rate-deg-s", "15.8"], 15.8)):
        out = tmp_path / f"mc{len(rate)}.json"
        assert run_uncertainty_command(_parse([*argv, *rate, "--json", str(out)])) == 0
        err = capsys.readouterr().err
        if rate:
            assert err == ""
        else:
            assert err.startswith(f"warning: {path}: L = 7 m, a model?") and err.count("\n") == 1
        condition = json.loads(out.read_text())["condition"]
        assert condition["rudder_rate_deg_s"] == pytest.approx(expected)


def test_cli_errors_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.json"
    args = _parse(["uncertainty", "--params", str(missing), "--quiet"])
    assert run_uncertainty_command(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "file not found" in err

    path = tmp_path / "nocov.json"
    save_params(path, linear_ship().with_vector(linear_ship().to_vector(), None))
    args = _parse(["uncertainty", "--params", str(path), "--quiet"])
    assert run_uncertainty_command(args) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no covariance" in err
    # A tank model's steering-rate warning does not come before a failing run's error.
    model = tmp_path / "nocov_model.json"
    save_params(
        model, replace(linear_ship(), length_m=7.0).with_vector(linear_ship().to_vector(), None)
    )
    assert run_uncertainty_command(_parse(["uncertainty", "--params", str(model), "--quiet"])) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "no covariance" in err and "warning" not in err


def test_cli_usage_error_exits_2() -> None:
    with pytest.raises(SystemExit) as exc:
        _parse(["uncertainty", "--params", "p.json", "--samples", "0"])
    assert exc.value.code == 2
