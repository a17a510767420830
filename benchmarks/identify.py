"""Throughput of smoothing and of the EKF; end-to-end identification at 1 and 10 Hz.

    python benchmarks/identify.py [--rates-hz 10,1] [--samples 1000000]
        [--large-rates-hz 1,10] [--no-large] [--method ekf|output-error] [--timeout-s S]
        [--current-modes-only] [--shape-search-only]

The data are KVLCC2 full-scale trial logs (MMG reference ship, ``scenarios.synthesize``):
turning circle 35°, zig-zag 10/10 and 20/20, about 3,200 samples at 1 Hz and 32,000 at
10 Hz. Reported, in one run so that the figures are side by side:

* per logging rate, smoothing (``identifier.smoothing.smooth_track``: x, y and heading,
  noise levels estimated) in samples per second and the augmented-state EKF
  (``identifier.ekf.ekf_identify``) in measurement updates per second, on the seed
  model ``shi2009`` (22-state filter), for the paper's variant (smoothed u, v, r
  measured, one Euler step per sample) and for the default (the logged x, y, ψ
  measured, Euler substeps of at most 0.1 s, so 10 per update at 1 Hz); target
  ≥ 20,000 updates/s; then the default with a current estimated (two more states) and
  with a speed log measured as well (its scale error one more state, a scalar update
  after the track's; the smoothed surge speed stands in for the log), and the ratio of
  the two; then with a two-axis log (the smoothed sway speed for its transverse axis,
  a second scalar update), and its ratio to one axis. The numba compilation (first
  call, with a new kernel cache) is excluded and reported separately;
* ``identifier.identify.identify`` of the three logs with the default model
  (``fmu_model.DEFAULT_MODEL``, shape search included) at 1 and at 10 Hz, end to end in a fresh
  process (numba compilation included), and the 10 Hz / 1 Hz ratio;
* ``identify`` of one log of ``--samples`` samples at each of ``--large-rates-hz``, in a
  fresh process: seconds and peak resident memory (VmHWM, reset to the current RSS once
  the log is built) above the RSS before the identification. The long log is the three
  manoeuvres repeated end to end, each copy turned and moved to continue from the
  previous copy's last pose.

Every end-to-end run is made twice, each in a fresh process: once with empty caches
(numba's, ``NUMBA_CACHE_DIR``, and the kernel cache of ``fmu_model.kernels``), so that it
compiles the smoother and the model family's EKF and replay, as the first fit on a fresh
machine does; once with the caches one ``python -m scenarios warm-up`` filled (what
``make`` does after installing; timed and reported once), as every later fit.

The shape search of the default family (``identifier.shape.select_shape``) on the three
KVLCC2 logs at 1 Hz, its grid's shapes in batches (``SHAPE_BATCH_VALUES``, the default)
against one at a time, side by side in this process: seconds, the ratio, and that both
choose the same shape (``--shape-search-only`` runs this part alone).

Last, the cost of the current modes: ``identify`` with ``current`` "none", "constant",
"per-log" and "auto" (two fits unless a speed log decides) side by side in this process
(its caches warm from a first, untimed fit), on the three KVLCC2 logs at 1 Hz and on the
HSVA 10/10 pair (model scale, 20 Hz), and the ratios auto / constant, auto / none and
per-log / constant (``--current-modes-only`` runs this part alone).

``--method`` picks the procedure of the end-to-end runs (default: the ``FitSettings``
default); a run not finished after ``--timeout-s`` is stopped and reported as such.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from hsva import DATA, RUNS

import identifier.shape
from fmu_model import DEFAULT_MODEL, get_model
from fmu_model.kernels import CACHE_ENV
from fmu_model.variants import parse_family
from identifier.current import PER_LOG, kept_current
from identifier.ekf import EkfSegment, EkfSettings, SpeedLogMeasurement, ekf_identify
from identifier.equation_error import equation_error_fit
from identifier.identify import FitSettings, identify
from identifier.preparation import ekf_segment
from identifier.smoothing import smooth_track
from scenarios.synthesize import MANEUVERS, reference_ship, synthesize_log
from trials.logs import ManeuverLog, read_log

MODEL = "shi2009"
MANEUVER_NAMES = ("turning-35", "zigzag-10", "zigzag-20")
TARGET_UPDATES_PER_S = 20_000.0


def reference_logs(rate_hz: float) -> list[ManeuverLog]:
    """KVLCC2 full-scale logs of the three manoeuvres at ``rate_hz`` [Hz]."""
    ship = reference_ship("kvlcc2", "full")
    return [
        synthesize_log(ship, MANEUVERS[name](), rate_hz=rate_hz, seed=seed)
        for seed, name in enumerate(MANEUVER_NAMES)
    ]


def long_log(logs: Sequence[ManeuverLog], n_samples: int) -> ManeuverLog:
    """Repeat ``logs`` end to end up to ``n_samples``, each copy continuing the track.

    Every copy is rotated about its first position so that its first heading equals
    the previous copy's last heading, moved so that it starts where the previous one
    ended, and shifted in time by one sampling interval past the previous end.
    """
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("t", "x", "y", "psi", "d", "n")}
    count, t_end, x_end, y_end, psi_end = 0, 0.0, 0.0, 0.0, 0.0
    while count < n_samples:
        for log in logs:
            take = min(log.n_samples, n_samples - count)
            if take <= 0:
                break
            dt = float(log.time_s[1] - log.time_s[0])
            turn = psi_end - float(log.heading_rad[0]) if count else 0.0
            c, s = math.cos(turn), math.sin(turn)
            dx = log.x_m[:take] - log.x_m[0]
            dy = log.y_m[:take] - log.y_m[0]
            start = t_end + dt if count else 0.0
            parts["t"].append(start + log.time_s[:take] - log.time_s[0])
            parts["x"].append(x_end + c * dx - s * dy)
            parts["y"].append(y_end + s * dx + c * dy)
            parts["psi"].append(log.heading_rad[:take] + turn)
            parts["d"].append(log.rudder_rad[:take])
            parts["n"].append(log.n_rps[:take])
            t_end, x_end = float(parts["t"][-1][-1]), float(parts["x"][-1][-1])
            y_end, psi_end = float(parts["y"][-1][-1]), float(parts["psi"][-1][-1])
            count += take
    first = logs[0]
    return ManeuverLog(
        time_s=np.concatenate(parts["t"]),
        x_m=np.concatenate(parts["x"]),
        y_m=np.concatenate(parts["y"]),
        heading_rad=np.concatenate(parts["psi"]),
        rudder_rad=np.concatenate(parts["d"]),
        n_rps=np.concatenate(parts["n"]),
        metadata={"vessel": first.metadata["vessel"], "length_m": first.metadata["length_m"]},
    )


def smoothing_rate(logs: Sequence[ManeuverLog], repeats: int = 2) -> tuple[float, float]:
    """(first-call seconds, samples per second of later calls) of ``smooth_track``."""
    start = time.perf_counter()
    smooth_track(logs[0].time_s, logs[0].x_m, logs[0].y_m, logs[0].heading_rad)
    first = time.perf_counter() - start
    n = sum(log.n_samples for log in logs) * repeats
    start = time.perf_counter()
    for _ in range(repeats):
        for log in logs:
            smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
    return first, n / (time.perf_counter() - start)


def segments(logs: Sequence[ManeuverLog]) -> list[EkfSegment]:
    """Smoothed segments as ``identifier.identify.identify`` prepares them."""
    result = []
    for i, log in enumerate(logs):
        track = smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)
        result.append(
            replace(
                ekf_segment(log, track, f"log {i + 1}", measurements="velocities"),
                speed_log_mps=track.u_mps,  # measured only by the speed-log rows
                speed_log_transverse_mps=track.v_mps,  # only by the two-axis row
            )
        )
    return result


def ekf_rate(
    segs: Sequence[EkfSegment],
    length_m: float,
    measurements: str,
    max_substep_s: float,
    *,
    current: bool = False,
    speed_log_axes: int = 0,
) -> tuple[float, float]:
    """(first-call seconds, updates per second of a later call) of ``ekf_identify``.

    ``current``: a current estimated (from 0, σ 1 m/s); ``speed_log_axes``: and that many
    axes of the segments' speed logs measured (noise 0.05 m/s, scale error σ 1 %).
    """
    if speed_log_axes < 2:
        segs = [replace(seg, speed_log_transverse_mps=None) for seg in segs]
    ls = equation_error_fit(get_model(MODEL), segs, length_m)
    settings = EkfSettings(
        state_process_std=(
            float(ls.residual_std[0]),
            float(ls.residual_std[1]),
            float(ls.residual_std[2]),
        ),
        measurements=measurements,
        max_substep_s=max_substep_s,
    )
    cov0 = ls.covariance * 100.0

    def run() -> float:
        start = time.perf_counter()
        ekf_identify(
            get_model(MODEL),
            segs,
            ls.theta,
            cov0,
            length_m,
            settings,
            current0=np.zeros(2) if current else None,
            current_covariance0=np.eye(2) if current else None,
            speed_log=SpeedLogMeasurement(0.05, 0.01, 0.05 if speed_log_axes == 2 else None)
            if speed_log_axes
            else None,
        )
        return time.perf_counter() - start

    first = run()
    best = min(run() for _ in range(2))
    return first, sum(seg.time_s.size for seg in segs) / best


def _status_mib(field: str) -> float | None:
    """Return VmRSS, VmHWM, ... of /proc/self/status [MiB]; None where there is none."""
    try:
        with open("/proc/self/status") as file:
            for line in file:
                if line.startswith(f"{field}:"):
                    return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


def _reset_peak_rss() -> bool:
    """Reset the peak RSS to the current RSS (Linux ≥ 4.0); False where not possible."""
    try:
        with open("/proc/self/clear_refs", "w") as file:
            file.write("5")
    except OSError:
        return False
    return True


def _max_rss_mib() -> float:
    # ru_maxrss is in KiB on Linux (bytes on macOS).
    scale = 1.0 if sys.platform.startswith("linux") else 1.0 / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 1024.0


def large_identification(
    rate_hz: float, n_samples: int, method: str | None
) -> dict[str, float | str]:
    """Identify one ``n_samples`` log (0: the three logs) here; RSS before, peak, seconds.

    The log is built first and everything else freed; then the peak RSS is reset to the
    current RSS (``/proc/self/clear_refs``), so that the peak is that of ``identify``.
    Where that is not possible, the peak is the process's (``ru_maxrss``).
    """
    logs = reference_logs(rate_hz)
    if n_samples > 0:
        logs = [long_log(logs, n_samples)]
    settings = FitSettings() if method is None else FitSettings(method=method)
    gc.collect()
    before = _status_mib("VmRSS") if _reset_peak_rss() else None
    start = time.perf_counter()
    result = identify(logs, settings)
    seconds = time.perf_counter() - start
    peak = _status_mib("VmHWM") if before is not None else None
    shape = result.params.identification.get("shape", {})
    return {
        "samples": sum(log.n_samples for log in logs),
        "hours": sum(float(log.time_s[-1] - log.time_s[0]) for log in logs) / 3600.0,
        "rss_before_mib": before if before is not None else math.nan,
        "rss_peak_mib": peak if peak is not None else _max_rss_mib(),
        "seconds": seconds,
        "not_identifiable": len(result.not_identifiable),
        "method": settings.method,
        "shape_rows": shape.get("rows", 0),
        "regression_interval_s": result.equation_error.sample_interval_s,
    }


def _cache_env(directory: str) -> dict[str, str]:
    """Return the environment whose numba and kernel caches are under ``directory``."""
    return {
        **os.environ,
        "NUMBA_CACHE_DIR": os.path.join(directory, "numba"),
        CACHE_ENV: os.path.join(directory, "kernels"),
    }


def warm_up(directory: str) -> float:
    """Fill the caches under ``directory`` with ``python -m scenarios warm-up``; seconds."""
    start = time.perf_counter()
    command = [sys.executable, "-m", "scenarios", "warm-up", "--quiet"]
    subprocess.run(command, check=True, capture_output=True, env=_cache_env(directory))
    return time.perf_counter() - start


def _child(
    rate_hz: float, n_samples: int, method: str | None, timeout_s: float, caches: str
) -> dict[str, float | str] | None:
    """Run :func:`large_identification` in a fresh interpreter; None when it timed out.

    ``caches`` is the directory of the child's numba and kernel caches.
    """
    command = [sys.executable, __file__, "--child", "--rate-hz", str(rate_hz)]
    command += ["--samples", str(n_samples)] + ([] if method is None else ["--method", method])
    env = _cache_env(caches)
    try:
        child = subprocess.run(command, capture_output=True, text=True, timeout=timeout_s, env=env)
    except subprocess.TimeoutExpired:
        return None
    if child.returncode != 0:
        lines = child.stderr.strip().splitlines() or ["no output"]
        raise RuntimeError(f"identification of {n_samples} samples failed: {lines[-1]}")
    return json.loads(child.stdout.strip().splitlines()[-1])


def _describe(run: dict[str, float | str]) -> str:
    before, peak = float(run["rss_before_mib"]), float(run["rss_peak_mib"])
    return (
        f"{float(run['seconds']):.1f} s, peak RSS {peak - before:,.0f} MiB above the "
        f"{before:,.0f} MiB before identify (method {run['method']}; shape search on "
        f"{int(run['shape_rows']):,} rows, regression at {float(run['regression_interval_s']):g} s)"
    )


def end_to_end(
    rates_hz: Sequence[float], n_samples: int, method: str | None, timeout_s: float, warm: str
) -> None:
    """Print end-to-end identification of ``n_samples`` (0: the three logs) per rate.

    Each twice (module docstring): with empty caches, and with those of ``warm``, the
    directory a warm-up filled.
    """
    seconds: dict[tuple[float, str], float] = {}
    for rate_hz in rates_hz:
        for label in ("compiling", "after warm-up"):
            with tempfile.TemporaryDirectory(prefix="caches-") as empty:
                caches = empty if label == "compiling" else warm
                run = _child(rate_hz, n_samples, method, timeout_s, caches)
            if run is None:
                print(f"  {rate_hz:g} Hz ({label}): NOT FINISHED after {timeout_s:g} s")
                continue
            seconds[rate_hz, label] = float(run["seconds"])
            samples, hours = int(run["samples"]), float(run["hours"])
            print(
                f"  {rate_hz:g} Hz, {samples:,} samples ({hours:.1f} h), {label}: {_describe(run)}"
            )
    for label in ("compiling", "after warm-up"):
        if (1.0, label) in seconds and (10.0, label) in seconds:
            ratio = seconds[10.0, label] / seconds[1.0, label]
            print(f"  10 Hz / 1 Hz time, {label}: {ratio:.2f}")


def throughput(rate_hz: float) -> float | None:
    """Print smoothing and EKF rates on the logs at ``rate_hz``; return the compile time.

    The compile time is the first EKF call's excess over a warm call: the numba
    compilation when this is the first identification in the process, else about 0.
    """
    logs = reference_logs(rate_hz)
    n = sum(log.n_samples for log in logs)
    length_m = float(logs[0].metadata["length_m"])
    print(f"KVLCC2 full scale, {len(logs)} logs at {rate_hz:g} Hz, {n:,} samples; {MODEL}")
    first, rate = smoothing_rate(logs)
    print(f"  smoothing (smooth_track)       {rate:>10,.0f} samples/s")
    segs = segments(logs)
    compile_s = None
    rates = {}
    for label, measurements, substep, current, axes in (
        ("EKF velocities, 1 step/sample", "velocities", math.inf, False, 0),
        ("EKF track, substeps <= 0.1 s", "track", 0.1, False, 0),
        ("  + a current", "track", 0.1, True, 0),
        ("  + a current and a speed log", "track", 0.1, True, 1),
        ("  + ... a two-axis speed log", "track", 0.1, True, 2),
    ):
        first, rate = ekf_rate(
            segs, length_m, measurements, substep, current=current, speed_log_axes=axes
        )
        rates[label] = rate
        if compile_s is None:
            compile_s = first - n / rate
        verdict = "meets" if rate >= TARGET_UPDATES_PER_S else "BELOW"
        print(
            f"  {label:<31}{rate:>10,.0f} updates/s ({verdict} the "
            f"{TARGET_UPDATES_PER_S:,.0f}/s target)"
        )
    ratio = rates["  + a current"] / rates["  + a current and a speed log"]
    print(f"  time with the speed log / without (a current in both): {ratio:.2f}")
    ratio = rates["  + a current and a speed log"] / rates["  + ... a two-axis speed log"]
    print(f"  time with two axes of the speed log / one: {ratio:.2f}")
    return compile_s


def shape_search() -> None:
    """Print the default family's shape search, batched and one shape at a time, side by side."""
    logs = reference_logs(1.0)
    family = parse_family(DEFAULT_MODEL)
    assert family is not None
    ship = reference_ship("kvlcc2", "full")
    data = segments(logs)
    batched = identifier.shape.SHAPE_BATCH_VALUES
    seconds, chosen = {}, {}
    for label, values in (("in batches", batched), ("one at a time", 1)):
        identifier.shape.SHAPE_BATCH_VALUES = values
        start = time.perf_counter()
        try:
            selection = identifier.shape.select_shape(
                family[0], data, ship.length_m, ship.speed_mps, ship.n_rps
            )
        finally:
            identifier.shape.SHAPE_BATCH_VALUES = batched
        seconds[label] = time.perf_counter() - start
        chosen[label] = selection.shape
        print(
            f"  {label}: {seconds[label]:.2f} s, {selection.evaluations} shapes "
            f"({1e3 * seconds[label] / selection.evaluations:.2f} ms a shape, "
            f"{selection.rows} rows)"
        )
    same = (
        "the same shape" if chosen["in batches"] == chosen["one at a time"] else "DIFFERENT shapes"
    )
    ratio = seconds["one at a time"] / seconds["in batches"]
    print(f"  one at a time / in batches: {ratio:.2f} ({same})")


def current_modes(method: str | None) -> None:
    """Print ``identify``'s seconds per current mode side by side, and their ratios."""
    hsva = [read_log(DATA / f"{run}.csv") for run in RUNS[:2]]
    for label, logs in (("KVLCC2, three logs at 1 Hz", reference_logs(1.0)),
                        ("HSVA 10/10 pair, model scale, 20 Hz", hsva)):  # fmt: skip
        settings = FitSettings() if method is None else FitSettings(method=method)
        identify(logs, replace(settings, current="none"))  # caches warm, untimed
        seconds = {}
        for current in ("none", "constant", PER_LOG, "auto"):
            start = time.perf_counter()
            result = identify(logs, replace(settings, current=current))
            seconds[current] = time.perf_counter() - start
            kept = kept_current(result.params)
            print(f"  {label}, --current {current}: {seconds[current]:.1f} s (kept {kept})")
        print(
            f"  {label}: auto / constant {seconds['auto'] / seconds['constant']:.2f}, "
            f"auto / none {seconds['auto'] / seconds['none']:.2f}, "
            f"per-log / constant {seconds[PER_LOG] / seconds['constant']:.2f}"
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rates-hz", default="10,1", help="logging rates of the throughput runs [Hz]"
    )
    parser.add_argument("--samples", type=int, default=1_000_000, help="size of the long log")
    parser.add_argument(
        "--large-rates-hz", default="1,10", help="logging rates of the long-log runs [Hz]"
    )
    parser.add_argument("--no-large", action="store_true", help="skip the long-log runs")
    parser.add_argument(
        "--method", choices=("ekf", "output-error"), help="procedure (default: FitSettings')"
    )
    parser.add_argument(
        "--timeout-s", type=float, default=900.0, help="stop an end-to-end run after this"
    )
    parser.add_argument(
        "--current-modes-only",
        action="store_true",
        help="only the side-by-side of the current modes",
    )
    parser.add_argument(
        "--shape-search-only",
        action="store_true",
        help="only the side-by-side of the shape search in batches and one at a time",
    )
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--rate-hz", type=float, default=10.0, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(large_identification(args.rate_hz, args.samples, args.method)))
        return 0
    if args.current_modes_only:
        print("identify() by --current mode, this process, caches warm")
        current_modes(args.method)
        return 0
    print("shape search of the default family, three KVLCC2 logs at 1 Hz")
    shape_search()
    if args.shape_search_only:
        return 0

    compile_s = None
    with tempfile.TemporaryDirectory(prefix="kernels-") as cache:
        os.environ[CACHE_ENV] = cache  # the first EKF call compiles
        for rate_hz in map(float, args.rates_hz.split(",")):
            compiled = throughput(rate_hz)
            compile_s = compiled if compile_s is None else compile_s
        del os.environ[CACHE_ENV]
    if compile_s is not None:
        print(f"numba compile of the EKF (first call, new kernel cache): {compile_s:.1f} s")
    with tempfile.TemporaryDirectory(prefix="caches-") as warm:
        print(f"python -m scenarios warm-up with empty caches: {warm_up(warm):.1f} s")
        print("identify() of the three KVLCC2 logs, default model, fresh process")
        end_to_end((1.0, 10.0), 0, args.method, args.timeout_s, warm)
        if not args.no_large:
            print(f"identify() of one {args.samples:,}-sample log, default model, fresh process")
            rates = tuple(map(float, args.large_rates_hz.split(",")))
            end_to_end(rates, args.samples, args.method, args.timeout_s, warm)
    print("identify() by --current mode, this process, caches warm")
    current_modes(args.method)
    if hasattr(os, "getloadavg"):
        load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
        print(f"load average {load} on {os.cpu_count()} CPUs")
    return 0


if __name__ == "__main__":
    sys.exit(main())
