"""Batch identification: Dask tasks per vessel, failures isolated, resumable, CLI."""

from __future__ import annotations

import csv
import hashlib
import json
import logging
import math
import signal
import subprocess
import sys
import time
import zipfile
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import psutil
import pytest

from fmu_model import ModelParameters, get_model, load_params
from identifier.batch import ManifestError, read_vessels, run_batch
from identifier.batch.manifest import VesselSpec
from identifier.batch.records import (
    DONE_FORMAT,
    DONE_VERSION,
    record_outcome,
    result_from_done,
    settings_record,
    up_to_date,
)
from identifier.batch.task import VesselJob, VesselOutcome
from identifier.cli import main
from scenarios.synthesize import MANEUVERS, TruthShip, model_ship, synthesize_log
from tests.conftest import SEED_COEFFICIENTS
from trials import cluster
from trials.logs import write_log

BAD_LOG = "time_s,x_m,y_m,heading_deg,rudder_deg,rpm\n0,0,0,0,0,abc\n"
ROOT = Path(__file__).resolve().parents[1]


def _ship() -> TruthShip:
    params = ModelParameters.from_vector(
        "shi2009",
        np.array(list(SEED_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="testship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )
    return model_ship(params, rudder_rate_radps=math.radians(5.0))


@pytest.fixture(scope="module")
def cluster_address() -> Iterator[str]:
    """A LocalCluster of 2 single-threaded worker processes, shared by the module."""
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        scheduler_kwargs={"dashboard_address": ":0"},  # no dashboard; any free port
        silence_logs=logging.ERROR,
    ) as cluster:
        yield cluster.scheduler_address


def _manifest(root: Path) -> Path:
    """Two good vessels from 1 Hz zig-zags of the seed ship, one with a corrupt log."""
    ship = _ship()
    for vessel, seed in (("alpha", 0), ("beta", 10)):
        for offset, maneuver in enumerate(("zigzag-10", "zigzag-20")):
            log = synthesize_log(ship, MANEUVERS[maneuver](), seed=seed + offset)
            write_log(root / vessel / f"{maneuver}.csv", log)
    (root / "gamma").mkdir()
    (root / "gamma" / "zigzag-10.csv").write_text(BAD_LOG)
    manifest = root / "fleet.toml"
    manifest.write_text(
        "[[vessel]]\n"
        'name = "alpha"\n'
        'logs = ["alpha/zigzag-10.csv", "alpha/zigzag-20.csv"]\n'
        "length_m = 100.0\n"
        "\n[[vessel]]\n"
        'name = "beta"\n'
        'logs = ["beta/zigzag-10.csv", "beta/zigzag-20.csv"]\n'
        'model = "shi2009"\n'
        "\n[[vessel]]\n"
        'name = "gamma"\n'
        'logs = ["gamma/zigzag-10.csv"]\n'
    )
    return manifest


def _mtimes(out: Path) -> dict[str, int]:
    return {p.relative_to(out).as_posix(): p.stat().st_mtime_ns for p in out.glob("*/*")}


def test_batch_runs_isolates_failures_and_resumes(
    tmp_path: Path, cluster_address: str, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = _manifest(tmp_path / "in")
    out = tmp_path / "out"
    seen: list[tuple[str, int, int]] = []

    # First run: two vessels identified with params.json and FMU, one failure recorded.
    summary = run_batch(
        manifest,
        out,
        scheduler=cluster_address,
        method="ekf",
        current="none",  # still-water logs (and half the EKF passes)
        progress=lambda v, done, total: seen.append((v.name, done, total)),
    )
    assert [(v.name, v.status) for v in summary.vessels] == [
        ("alpha", "ok"),
        ("beta", "ok"),
        ("gamma", "failed"),
    ]
    assert sorted(name for name, _, _ in seen) == ["alpha", "beta", "gamma"]
    assert [(done, total) for _, done, total in seen] == [(1, 3), (2, 3), (3, 3)]
    assert summary.n_identified == 2 and not summary.ok
    for name in ("alpha", "beta"):
        params = load_params(out / name / "params.json")
        assert params.vessel_name == name and params.length_m == 100.0
        # The fit follows the logged track to about the logger's 1 m noise.
        row = summary.vessels[0 if name == "alpha" else 1]
        assert 0.3 < row.position_rms_m < 2.0 and row.heading_rms_deg < 0.2
        assert row.n_logs == 2 and row.n_samples > 500
        with zipfile.ZipFile(out / name / f"{name}.fmu") as fmu:
            assert "modelDescription.xml" in fmu.namelist()
        done = json.loads((out / name / "done.json").read_text())
        assert done["settings"]["current"] == "none"
        assert params.identification["environment"] == {"current": "none"}
        assert [i["sha256"] for i in done["inputs"]] == [
            i["sha256"] for i in params.identification["logs"]
        ]
        assert not (out / name / "error.txt").exists()
    error = (out / "gamma" / "error.txt").read_text()
    assert error.count("\n") == 1 and "zigzag-10.csv:2: column 'rpm'" in error
    assert not (out / "gamma" / "done.json").exists()
    with open(out / "summary.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    assert [(r["vessel"], r["status"], r["n_logs"]) for r in rows] == [
        ("alpha", "ok", "2"),
        ("beta", "ok", "2"),
        ("gamma", "failed", "1"),
    ]
    assert int(rows[0]["not_identifiable"]) < int(rows[0]["n_coefficients"])
    assert "column 'rpm'" in rows[2]["error"]
    markdown = (out / "summary.md").read_text()
    assert "| alpha | ok | 2 |" in markdown and "**gamma**" in markdown

    # Re-run through the CLI: finished vessels are skipped (files untouched), the
    # failure is retried and reported as one line on stderr, exit status 1.
    before = _mtimes(out)
    argv = ["batch", str(manifest), "--out", str(out), "--scheduler", cluster_address]
    status = main([*argv, "--quiet", "--method", "ekf", "--current", "none"])
    assert status == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("error: gamma: ") and "column 'rpm'" in err[0]
    after = _mtimes(out)
    assert {k: v for k, v in after.items() if not k.startswith("gamma/")} == {
        k: v for k, v in before.items() if not k.startswith("gamma/")
    }
    with open(out / "summary.csv", newline="") as file:
        assert [r["status"] for r in csv.DictReader(file)] == ["skipped", "skipped", "failed"]

    # An interrupted batch (alpha's completion record missing) resumes alpha only.
    (out / "alpha" / "done.json").unlink()
    summary = run_batch(manifest, out, scheduler=cluster_address, method="ekf", current="none")
    assert [v.status for v in summary.vessels] == ["ok", "skipped", "failed"]
    assert summary.n_identified == 1
    assert (out / "beta" / "params.json").stat().st_mtime_ns == before["beta/params.json"]
    assert (out / "alpha" / "done.json").is_file()

    # A changed log re-runs its vessel; fixing the corrupt log lets gamma succeed.
    log = synthesize_log(_ship(), MANEUVERS["zigzag-10"](), seed=99)
    write_log(tmp_path / "in" / "beta" / "zigzag-10.csv", log)
    write_log(tmp_path / "in" / "gamma" / "zigzag-10.csv", log)
    summary = run_batch(
        manifest, out, scheduler=cluster_address, method="ekf", current="none", build_fmu=False
    )
    assert [v.status for v in summary.vessels] == ["skipped", "ok", "ok"]
    assert summary.ok
    assert not (out / "gamma" / "error.txt").exists()
    assert not (out / "gamma" / "gamma.fmu").exists()  # --no-fmu
    assert not (out / "beta" / "beta.fmu").exists()  # no stale FMU beside new params
    assert (out / "gamma" / "params.json").is_file()


def test_default_local_cluster_and_directory_input(tmp_path: Path) -> None:
    # Only failing vessels: the LocalCluster starts, the tasks fail fast, and every
    # failure is recorded; no identification (no numba compile) is needed.
    source = tmp_path / "fleet"
    for name in ("one", "two"):
        (source / name).mkdir(parents=True)
        (source / name / "a.csv").write_text(BAD_LOG)
    (source / "empty").mkdir()
    (source / ".hidden").mkdir()
    out = source / "out"  # inside the input directory: not a vessel
    summary = run_batch(source, out, n_workers=2, method="ekf", build_fmu=False)
    assert [(v.name, v.status) for v in summary.vessels] == [
        ("empty", "failed"),
        ("one", "failed"),
        ("two", "failed"),
    ]
    assert summary.vessels[0].error == "no *.csv logs"
    assert "a.csv:2: column 'rpm'" in str(summary.vessels[1].error)
    assert (out / "two" / "error.txt").is_file() and (out / "summary.md").is_file()


def test_directory_vessels_take_their_csv_logs_in_name_order(tmp_path: Path) -> None:
    for name in ("b.csv", "a.csv", "notes.txt"):
        (tmp_path / "ship-1" / name).parent.mkdir(exist_ok=True)
        (tmp_path / "ship-1" / name).write_text("")
    (tmp_path / "out").mkdir()
    vessels = read_vessels(tmp_path, tmp_path / "out")
    assert [v.name for v in vessels] == ["ship-1"]
    assert [p.name for p in vessels[0].logs] == ["a.csv", "b.csv"]
    assert vessels[0].logs[0].is_absolute()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[[vessel]]\nname = 'a'\nlogs = [\n", "invalid TOML"),
        ("[[vessel]]\nname = 'a b'\nlogs = ['x.csv']\n", "expected a vessel name"),
        ("[[vessel]]\nname = 'a'\nlogs = []\n", "'logs' must be a non-empty list"),
        ("[[vessel]]\nname = 'a'\nlogs = ['x.csv']\nlength = 3\n", r"unknown keys \['length'\]"),
        ("[[vessel]]\nname = 'a'\nlogs = ['x.csv']\nlength_m = -1\n", "'length_m' must be"),
        ("[[vessel]]\nname = 'a'\nlogs = ['x.csv']\nmodel = 'nope'\n", "unknown model 'nope'"),
        ("[[vessel]]\nname = 'a'\nlogs = ['x']\n[[vessel]]\nname = 'A'\nlogs = ['y']\n", "twice"),
        ("title = 'fleet'\n", "unknown top-level keys"),
        ("", "expected one or more"),
    ],
)
def test_bad_manifest_is_a_one_line_error(tmp_path: Path, text: str, message: str) -> None:
    manifest = tmp_path / "fleet.toml"
    manifest.write_text(text)
    with pytest.raises(ManifestError, match=message) as info:
        read_vessels(manifest)
    assert "\n" not in str(info.value) and str(info.value).startswith(str(manifest))


def test_cli_bad_manifest_exits_1_without_output(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    manifest = tmp_path / "fleet.toml"
    manifest.write_text("[[vessel]]\nname = 'a'\n")
    out = tmp_path / "out"
    assert main(["batch", str(manifest), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "fleet.toml: vessel 'a': 'logs' must be" in err
    assert not out.exists()


def test_cli_scheduler_that_does_not_answer_is_a_one_line_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """``--scheduler`` at an address where nothing listens: one line naming it, no output."""
    monkeypatch.setattr(cluster, "SCHEDULER_TIMEOUT_S", 0.5)
    root = tmp_path / "fleet"
    (root / "alpha").mkdir(parents=True)
    write_log(root / "alpha" / "zigzag-10.csv", synthesize_log(_ship(), MANEUVERS["zigzag-10"]()))
    manifest = root / "fleet.toml"
    manifest.write_text('[[vessel]]\nname = "alpha"\nlogs = ["alpha/zigzag-10.csv"]\n')
    out = tmp_path / "out"
    start = time.perf_counter()
    status = main(["batch", str(manifest), "--out", str(out), "--scheduler", "tcp://127.0.0.1:1"])
    assert status == 1 and time.perf_counter() - start < 30.0
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("error: ") and "tcp://127.0.0.1:1 after 0.5 s" in err
    assert not out.exists()


def test_cli_usage_errors_exit_2(tmp_path: Path) -> None:
    for argv in (
        ["batch", str(tmp_path)],
        ["batch", str(tmp_path), "--out", "o", "--workers", "0"],
    ):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2


# ------------------------------------------------ the workers end with the batch

# How long the worker processes may outlive a killed batch [s]. SIGTERM: none, the batch
# kills them first. SIGKILL: nothing runs in the batch; a worker exits as soon as it
# watches its parent, which it does once it has imported its modules (seconds on a busy
# machine: the time of `python -c "import identifier.cli, distributed"`).
OUTLIVE_S = {signal.SIGTERM: 2.0, signal.SIGKILL: 20.0}


def _alive(process: psutil.Process) -> bool:
    try:
        return bool(process.status() != psutil.STATUS_ZOMBIE)
    except psutil.NoSuchProcess:
        return False


def _children(parent: psutil.Process) -> list[psutil.Process]:
    """Descendants of ``parent`` whose command line is read (psutil keeps it)."""
    found = []
    for child in parent.children(recursive=True):
        try:
            child.cmdline()
        except psutil.Error:
            continue
        found.append(child)
    return found


@pytest.fixture(scope="module")
def fleet(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The manifest of :func:`_manifest`, written once for the module."""
    return _manifest(tmp_path_factory.mktemp("fleet"))


@pytest.mark.parametrize("phase", ["starting", "working"])
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGKILL], ids=["SIGTERM", "SIGKILL"])
def test_killed_batch_leaves_no_worker_process(
    fleet: Path, tmp_path: Path, signum: signal.Signals, phase: str
) -> None:
    """Kill ``python -m identifier batch`` as its workers start, or a few seconds later.

    Its child processes (the LocalCluster's workers, the resource tracker) must end with
    it: at once on SIGTERM, within the start-up of a worker process on SIGKILL.
    """
    argv = [
        "-m",
        "identifier",
        "batch",
        str(fleet),
        "--out",
        str(tmp_path / "out"),
        "--method",
        "ekf",
    ]
    stderr = tmp_path / "stderr.txt"
    with stderr.open("wb") as err:  # a file: the children share it and may outlive the batch
        batch = subprocess.Popen(
            [sys.executable, *argv, "--no-fmu", "--quiet"],
            cwd=ROOT,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
    try:
        parent = psutil.Process(batch.pid)
        deadline = time.monotonic() + 120.0
        while not any("spawn_main" in " ".join(c.cmdline()) for c in _children(parent)):
            assert batch.poll() is None, stderr.read_text()
            assert time.monotonic() < deadline, "no worker process started"
            time.sleep(0.02)
        if phase == "working":
            time.sleep(6.0)
        children = _children(parent)
        assert len(children) >= 2 and batch.poll() is None
        batch.send_signal(signum)
        assert batch.wait(timeout=60) == -signum
        killed = time.monotonic()
        while any(map(_alive, children)) and time.monotonic() - killed < OUTLIVE_S[signum]:
            time.sleep(0.02)
        left = [f"{c.pid} {' '.join(c.cmdline())[:80]}" for c in children if _alive(c)]
        assert left == [], f"alive {OUTLIVE_S[signum]} s after {signum.name}: {left}"
        if signum == signal.SIGTERM:
            assert stderr.read_text() == ""
    finally:
        if batch.poll() is None:
            batch.kill()
            batch.wait()


def test_a_vessel_done_with_another_current_runs_again(tmp_path: Path) -> None:
    (tmp_path / "params.json").write_text("{}")
    inputs = [("a.csv", "0" * 64)]
    done = {
        "format": DONE_FORMAT,
        "version": DONE_VERSION,
        "inputs": [{"path": "a.csv", "sha256": "0" * 64}],
        "settings": settings_record("shi2009", "ekf", 100.0, False, "none"),
    }
    (tmp_path / "done.json").write_text(json.dumps(done))
    same = settings_record("shi2009", "ekf", 100.0, False, "none")
    assert up_to_date(tmp_path, "v", inputs, same) == done
    other = settings_record("shi2009", "ekf", 100.0, False, "constant")
    assert up_to_date(tmp_path, "v", inputs, other) is None
    # A record from before the current was a setting: run again.
    del done["settings"]["current"]
    (tmp_path / "done.json").write_text(json.dumps(done))
    assert up_to_date(tmp_path, "v", inputs, other) is None


def test_the_summary_names_the_model_fitted_not_the_one_asked_for(tmp_path: Path) -> None:
    """A fit refitted with the thrust of fixed slope (``prime-rudder-offset-thrust``, 20
    coefficients) where ``prime-rudder-offset`` (21) was asked for: the summary row and
    done.json say what params.json holds (before: the family asked for, "3 of 21")."""
    fitted = get_model("prime-rudder-offset-thrust")
    params = ModelParameters.from_vector(
        fitted.name, np.zeros(fitted.n_coefficients), length_m=100.0, vessel_name="delta"
    )
    spec = VesselSpec(name="delta", logs=(tmp_path / "zz.csv",))
    job = VesselJob("delta", ("zz.csv",), None, "prime-rudder-offset", "output-error", False)
    outcome = VesselOutcome(
        "delta", (("zz.csv", "0" * 64),), 1000, 1.0, params=params, not_identifiable=("X_vv",)
    )
    row = record_outcome(tmp_path, spec, job, outcome)
    assert (row.model, row.n_coefficients) == ("prime-rudder-offset-thrust", 20)
    done = json.loads((tmp_path / "done.json").read_text())
    assert done["settings"]["model"] == "prime-rudder-offset"  # as asked: what resumes
    assert done["result"]["model"] == "prime-rudder-offset-thrust"
    assert result_from_done(tmp_path, done).model == "prime-rudder-offset-thrust"


def test_a_vessel_with_a_windage_is_fitted_with_it(tmp_path: Path, cluster_address: str) -> None:
    """A vessel folder's ``windage.json`` (as ``synthesize`` writes it beside logs at sea)
    is fit's ``--windage``: params.json carries it, done.json records its sha256, and a
    changed windage fits again; a manifest names it by ``windage``, and an unreadable one
    fails that vessel in one line."""
    from tests.test_identify_at_sea import WINDAGE

    source = tmp_path / "fleet"
    ship = _ship()
    for offset, maneuver in enumerate(("zigzag-10", "zigzag-20")):
        write_log(source / "windy" / f"{maneuver}.csv",
                  synthesize_log(ship, MANEUVERS[maneuver](), seed=offset))  # fmt: skip
    windage = source / "windy" / "windage.json"
    windage.write_text(json.dumps(WINDAGE.to_dict()))
    (spec,) = read_vessels(source)
    assert spec.windage == windage.resolve()
    out = tmp_path / "out"
    options = {"scheduler": cluster_address, "method": "ekf", "current": "none",
               "build_fmu": False}  # fmt: skip
    (row,) = run_batch(source, out, **options).vessels
    assert row.status == "ok", row.error
    assert load_params(out / "windy" / "params.json").windage == WINDAGE
    done = json.loads((out / "windy" / "done.json").read_text())
    assert done["settings"]["windage"]["sha256"] == hashlib.sha256(windage.read_bytes()).hexdigest()
    assert run_batch(source, out, **options).vessels[0].status == "skipped"
    windage.write_text(json.dumps({**WINDAGE.to_dict(), "lateral_area_m2": 1900.0}))
    (row,) = run_batch(source, out, **options).vessels
    assert row.status == "ok"
    assert load_params(out / "windy" / "params.json").windage.lateral_area_m2 == 1900.0

    manifest = tmp_path / "fleet.toml"
    manifest.write_text("[[vessel]]\nname = 'windy'\nlogs = ['fleet/windy/zigzag-10.csv']\n"
                        "windage = 'fleet/windy/nowhere.json'\n")  # fmt: skip
    (spec,) = read_vessels(manifest)
    assert spec.windage == tmp_path / "fleet" / "windy" / "nowhere.json"
    (row,) = run_batch(manifest, tmp_path / "out2", **options).vessels
    assert row.status == "failed" and row.error is not None
    assert "nowhere.json" in row.error and "\n" not in row.error
    manifest.write_text("[[vessel]]\nname = 'w'\nlogs = ['a.csv']\nwindage = 3\n")
    with pytest.raises(ManifestError, match="vessel 'w': 'windage' must be a file name, got 3"):
        read_vessels(manifest)
