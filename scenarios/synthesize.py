"""Synthetic trial logs: a ship plays the manoeuvre, a noisy logger records it.

The truth is simulated with the step driver (``trials.run``) at a fine step, then
sampled at the logger's rate with Gaussian measurement noise on position and heading
(reproducible from a seed). Rudder angle and rpm are logged without noise, as the
steering-gear feedback and shaft counter are far more precise than GNSS. The heading
is written wrapped to [0, 360) like a gyro compass.

At sea (a reference ship given a :class:`~scenarios.sea.SeaEnvironment`) the log also
carries what the ship's own sensors measure, drawn after the noise above so that the
required columns are those of the same seed in calm water: ``stw_mps`` from a
single-axis speed log, the speed through the water along the ship u (exactly calibrated)
with Gaussian noise of :data:`STW_NOISE_MPS` (folded at 0); when there is a wind,
``wind_speed_mps`` and ``wind_angle_deg`` from an anemometer, the apparent wind at
midship (``fmu_model.environment.apparent_wind``: true wind, gusts included, minus the
velocity over ground; no yaw-rate lever arm, no flow distortion by the superstructure)
with Gaussian noise of :data:`WIND_SPEED_NOISE_MPS` (folded at 0) and
:data:`WIND_ANGLE_NOISE_DEG`, the angle written wrapped to [0, 360) like an MWV
sentence's; and with ``speed_log_axes=2`` (a two-axis Doppler log), drawn last,
``stw_transverse_mps``, the speed through the water across the ship at the log's
position x_L forward of midship, v + x_L r, with the same noise (x_L in the metadata
``speed_log_x_m``).
"""

from __future__ import annotations

import json
import math
import os
import zlib
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from fmu_model import ModelParameters
from fmu_model.atomic import write_atomic
from scenarios import tanker
from scenarios.errors import ScenarioError
from scenarios.kvlcc2 import FROUDE_SCALE_RATIO, ReferencePlant, kvlcc2, kvlcc2_windage
from scenarios.mariner import (
    NOMINAL_RPS,
    RUDDER_RATE_RADPS,
    AbkowitzPlant,
    mariner,
    neutral_helm,
)
from scenarios.sea import SeaEnvironment
from trials.logs import ManeuverLog, on_board_offset, write_log
from trials.maneuvers import Helm, Program, trial_day, turning_circle, zigzag
from trials.run import ModelPlant, Plant, run_program

STW_NOISE_MPS = 0.05
"""Standard deviation of the speed-log noise [m/s] (about 0.1 kn, a Doppler log's)."""
WIND_SPEED_NOISE_MPS = 0.3
"""Standard deviation of the anemometer's speed noise [m/s]."""
WIND_ANGLE_NOISE_DEG = 2.0
"""Standard deviation of the anemometer's angle noise [deg]."""
_NOISE_CHANNELS = 7
"""Noisy channels of a log: heading, x, y, speed log, wind speed, wind angle, the speed
log's transverse axis."""

SPEED_LOG_AXES = (1, 2)
"""A speed log's axes: along the ship only, or along and across (``synthesize_log``)."""

MANEUVERS: dict[str, Callable[[], Program]] = {
    "turning-35": lambda: turning_circle(math.radians(35.0)),
    "turning-35-port": lambda: turning_circle(-math.radians(35.0)),
    "zigzag-10": lambda: zigzag(math.radians(10.0), math.radians(10.0)),
    "zigzag-20": lambda: zigzag(math.radians(20.0), math.radians(20.0)),
    "zigzag-10-port": lambda: zigzag(-math.radians(10.0), math.radians(10.0)),
    "zigzag-20-port": lambda: zigzag(-math.radians(20.0), math.radians(20.0)),
    "trial-day": trial_day,
}


@dataclass(frozen=True)
class TruthShip:
    """A ship to synthesise logs from: a plant plus its approach condition.

    ``neutral_helm`` is the rudder that holds it on a straight course at the approach
    and its sway there (none for a symmetric ship; a single screw's rudder is off the
    centre line).
    """

    name: str
    plant: Plant
    length_m: float
    speed_mps: float
    n_rps: float
    rudder_rate_radps: float
    source: str
    neutral_helm: Helm = field(default_factory=Helm)


REFERENCE_VESSELS = ("kvlcc2", "mariner", "tanker")
"""The reference ships: KVLCC2 (MMG, ``scenarios.kvlcc2``), the Mariner (Abkowitz,
``scenarios.mariner``) and a large tanker (Van Berlekom & Goddard, ``scenarios.tanker``);
the last two at full scale in calm water."""


@dataclass(frozen=True)
class Logging:
    """A trial logger: its rate [Hz], position and heading noise [m, deg], approach [s]."""

    rate_hz: float
    position_noise_m: float
    heading_noise_deg: float
    approach_s: float


FULL_SCALE_LOGGING = Logging(
    rate_hz=1.0, position_noise_m=1.0, heading_noise_deg=0.1, approach_s=60.0
)
"""A sea trial's: a GNSS fix a second at 1 m, a gyro compass at 0.1°, a minute's approach."""


def default_logging(scale: str) -> Logging:
    """Return the logger of a trial at ``scale``, ``"full"`` or ``"model"``.

    :data:`FULL_SCALE_LOGGING`, Froude-scaled for the model (λ =
    ``scenarios.kvlcc2.FROUDE_SCALE_RATIO``, 45.7: lengths / λ, times / √λ, angles as
    they are: 6.8 Hz, 2.2 cm, 8.9 s), so that a model's log is not one of 1 m noise on
    a 7 m hull.

    Raises
    ------
    ValueError
        An unknown scale.

    """
    if scale == "full":
        return FULL_SCALE_LOGGING
    if scale != "model":
        raise ValueError(f"unknown scale {scale!r}: expected 'full' or 'model'")
    root = math.sqrt(FROUDE_SCALE_RATIO)
    return replace(
        FULL_SCALE_LOGGING,
        rate_hz=FULL_SCALE_LOGGING.rate_hz * root,
        position_noise_m=FULL_SCALE_LOGGING.position_noise_m / FROUDE_SCALE_RATIO,
        approach_s=FULL_SCALE_LOGGING.approach_s / root,
    )


def reference_ship(
    name: str = "kvlcc2", scale: str = "full", environment: SeaEnvironment | None = None
) -> TruthShip:
    """Return a reference vessel of :data:`REFERENCE_VESSELS` at ``scale`` full or model.

    With an ``environment`` KVLCC2 sails in that current and wind (``scenarios.kvlcc2``,
    windage of ``docs/kvlcc2_environment.md``), all values at the ship's scale; its
    ``source`` says so. Without, it is the calm-water ship. The Mariner and the tanker
    are given at full scale in calm water only.

    Raises
    ------
    ValueError
        An unknown vessel, or a scale or environment the vessel is not given in.

    """
    if name in ("mariner", "tanker"):
        if scale != "full":
            raise ValueError(f"the {name} reference is given at full scale only, not {scale!r}")
        if environment is not None:
            raise ValueError(f"the {name} reference sails in calm water only (no windage)")
    if name == "tanker":
        vessel = tanker.tanker()
        return TruthShip(
            name="tanker-full",
            plant=tanker.TankerPlant(vessel),
            length_m=vessel.length_m,
            speed_mps=tanker.approach_speed(vessel),
            n_rps=tanker.NOMINAL_RPS,
            rudder_rate_radps=tanker.RUDDER_RATE_RADPS,
            source="large tanker (Van Berlekom & Goddard 1972), full scale, deep water",
            neutral_helm=tanker.neutral_helm(vessel),
        )
    if name == "mariner":
        ship = mariner()
        return TruthShip(
            name="mariner-full",
            plant=AbkowitzPlant(ship),
            length_m=ship.length_m,
            speed_mps=ship.approach_speed_mps,
            n_rps=NOMINAL_RPS,
            rudder_rate_radps=RUDDER_RATE_RADPS,
            source="Mariner-class Abkowitz model (Chislett & Stroem-Tejsen 1965), full scale",
            neutral_helm=neutral_helm(ship),
        )
    if name != "kvlcc2":
        raise ValueError(
            f"unknown reference vessel {name!r} (known: {', '.join(REFERENCE_VESSELS)})"
        )
    reference = kvlcc2(scale)
    plant = ReferencePlant(reference, environment)
    source = f"KVLCC2 MMG standard model (Yasukawa & Yoshimura 2015), {scale} scale"
    if environment is not None:
        source += f"; at sea: {environment.describe(plant.gust_time_s)}"
        if environment.has_wind:
            source += (
                "; wind load Blendermann (1994) loaded tanker on the estimated windage of "
                "docs/kvlcc2_environment.md"
            )
    return TruthShip(
        name=f"kvlcc2-{scale}",
        plant=plant,
        length_m=reference.length_m,
        speed_mps=reference.approach_speed_mps,
        n_rps=reference.nominal_rps,
        rudder_rate_radps=reference.rudder_rate_radps,
        source=source,
    )


def model_ship(params: ModelParameters, rudder_rate_radps: float = math.radians(2.34)) -> TruthShip:
    """Return a ship that is itself an identified model (for recovery tests)."""
    return TruthShip(
        name=params.vessel_name,
        plant=ModelPlant(params),
        length_m=params.length_m,
        speed_mps=params.nominal_speed_mps,
        n_rps=params.nominal_n_rps,
        rudder_rate_radps=rudder_rate_radps,
        source=f"model {params.model} of {params.vessel_name}",
    )


def synthesize_log(
    ship: TruthShip,
    program: Program,
    *,
    rate_hz: float = FULL_SCALE_LOGGING.rate_hz,
    position_noise_m: float = FULL_SCALE_LOGGING.position_noise_m,
    heading_noise_deg: float = FULL_SCALE_LOGGING.heading_noise_deg,
    seed: int = 0,
    approach_s: float = FULL_SCALE_LOGGING.approach_s,
    approach_helm: Helm | None = None,
    truth_dt_s: float | None = None,
    noise_per_channel: bool = False,
    speed_log_axes: int = 1,
    speed_log_x_m: float = 0.0,
    gnss_x_m: float = 0.0,
    gnss_y_m: float = 0.0,
) -> ManeuverLog:
    """Simulate ``program`` on ``ship`` and return a noisy trial log.

    Parameters
    ----------
    ship : TruthShip
        The vessel playing the trial.
    program : Program
        The manoeuvre; a straight approach of ``approach_s`` is prepended.
    rate_hz : float
        Logger sampling rate [Hz].
    position_noise_m : float
        Standard deviation of the North and East position noise [m].
    heading_noise_deg : float
        Standard deviation of the heading noise [deg].
    seed : int
        Seed of the noise generator (same seed, same log).
    approach_s : float
        Straight approach before execute [s]; the log starts there.
    approach_helm : Helm, optional
        Rudder and sway of the approach; the ship's neutral helm by default, as a trial
        steadies its approach (the Mariner's rudder 1.1° to port, KVLCC2's amidships).
    truth_dt_s : float, optional
        Simulation step [s]; defaults to the largest divisor of the logging interval
        not above 0.1 s · √(L / 320 m) (0.1 s at full scale KVLCC2).
    noise_per_channel : bool
        One generator per channel (``numpy.random.SeedSequence(seed).spawn``): sample k of
        a channel has the same noise whatever the log's length and its other channels, so
        that logs of one seed sailed in different conditions (a wind ends a zig-zag a few
        samples earlier) carry the same noise. False (the default, every figure measured
        before 2026-12-05): heading, x, y and the sensors' noise drawn one after the other
        from one generator, so the position noise depends on the log's length.
    speed_log_axes : int
        At sea, the speed log's axes (:data:`SPEED_LOG_AXES`): 1, along the ship
        (``stw_mps``), or 2, across it too (``stw_transverse_mps``).
    speed_log_x_m : float
        With two axes, the log's position forward of midship [m] (the transverse axis
        measures v + x_L r there).
    gnss_x_m, gnss_y_m : float
        The GNSS antenna's position forward of midship and to starboard [m]: the logged
        positions are its (the metadata ``gnss_x_m``, ``gnss_y_m`` say so when not 0).

    Returns
    -------
    ManeuverLog
        The log; at sea (a :class:`~scenarios.kvlcc2.ReferencePlant` with an
        environment) with ``stw_mps`` and, when there is a wind, ``wind_speed_mps`` and
        ``wind_angle_rad`` (module docstring).

    """
    if rate_hz <= 0.0 or position_noise_m < 0.0 or heading_noise_deg < 0.0:
        raise ValueError("rate_hz must be positive and noise levels non-negative")
    if speed_log_axes not in SPEED_LOG_AXES:
        raise ValueError(f"speed_log_axes must be one of {SPEED_LOG_AXES}, got {speed_log_axes}")
    log_dt = 1.0 / rate_hz
    helm = ship.neutral_helm if approach_helm is None else approach_helm
    target = truth_dt_s or 0.1 * math.sqrt(ship.length_m / 320.0)
    every = max(1, math.ceil(log_dt / target - 1e-9))
    run = run_program(
        ship.plant,
        replace(program, approach_s=approach_s, approach_helm=helm),
        speed_mps=ship.speed_mps,
        n_rps=ship.n_rps,
        rudder_rate_radps=ship.rudder_rate_radps,
        dt_s=log_dt / every,
    )[::every]
    size = run.size
    noise = _noise_streams(seed, size, noise_per_channel)
    time_s = run["time_s"] - run["time_s"][0]
    heading = run["psi_rad"] + math.radians(heading_noise_deg) * next(noise)
    north_m, east_m = on_board_offset(gnss_x_m, gnss_y_m, run["psi_rad"])  # the antenna's place
    x_m = run["x_m"] + north_m + position_noise_m * next(noise)
    y_m = run["y_m"] + east_m + position_noise_m * next(noise)
    source = (
        f"synthetic {program.name}: {ship.source}; {rate_hz:g} Hz, position noise "
        f"{position_noise_m:g} m, heading noise {heading_noise_deg:g} deg, seed {seed}"
        + (" (one generator per channel)" if noise_per_channel else "")
    )
    if helm.rudder_rad != 0.0:
        source += f"; approach at rudder {math.degrees(helm.rudder_rad):+.4g} deg (neutral helm)"
    sensors: dict[str, np.ndarray] = {}
    plant = ship.plant
    if isinstance(plant, ReferencePlant) and plant.environment is not None:
        # drawn after the required columns' noise: those stay as in calm water
        stw = run["u_mps"] + STW_NOISE_MPS * next(noise)
        sensors["stw_mps"] = np.abs(stw)
        source += f"; speed-log noise {STW_NOISE_MPS:g} m/s"
        if plant.environment.has_wind:
            speed, angle = plant.apparent_wind(time_s, run["u_mps"], run["v_mps"], run["psi_rad"])
            speed = speed + WIND_SPEED_NOISE_MPS * next(noise)
            angle = angle + math.radians(WIND_ANGLE_NOISE_DEG) * next(noise)
            sensors["wind_speed_mps"] = np.abs(speed)
            sensors["wind_angle_rad"] = np.mod(angle, 2.0 * math.pi)
            source += (
                f"; anemometer noise {WIND_SPEED_NOISE_MPS:g} m/s, {WIND_ANGLE_NOISE_DEG:g} deg"
            )
        if speed_log_axes == 2:
            at_log = run["v_mps"] + speed_log_x_m * run["r_radps"]
            sensors["stw_transverse_mps"] = at_log + STW_NOISE_MPS * next(noise)
            source += "; two-axis speed log"
    return ManeuverLog(
        time_s=time_s,
        x_m=x_m,
        y_m=y_m,
        heading_rad=heading,
        rudder_rad=run["rudder_rad"],
        n_rps=run["n_rps"],
        metadata={
            "vessel": ship.name,
            "length_m": repr(ship.length_m),
            "source": source,
            "execute_time_s": repr(approach_s),
            **({"speed_log_x_m": repr(speed_log_x_m)} if "stw_transverse_mps" in sensors else {}),
            **(
                {"gnss_x_m": repr(gnss_x_m), "gnss_y_m": repr(gnss_y_m)}
                if gnss_x_m or gnss_y_m
                else {}
            ),
        },
        wind_speed_mps=sensors.get("wind_speed_mps"),
        wind_angle_rad=sensors.get("wind_angle_rad"),
        stw_mps=sensors.get("stw_mps"),
        stw_transverse_mps=sensors.get("stw_transverse_mps"),
    )


GNSS_JUMP_M = (50.0, 1000.0)
"""Range of the GNSS jumps of :func:`with_gnss_jumps` [m] (issue 14: a receiver's
single-sample jumps of tens to thousands of metres)."""
COMPASS_SPIKE_DEG = (5.0, 180.0)
"""Range of the compass spikes of :func:`with_compass_spikes` [deg]."""


def _glitch_samples(log: ManeuverLog, fraction: float, rng: np.random.Generator) -> np.ndarray:
    """Sorted distinct sample indices, ``round(fraction · n)`` of them, or raise ValueError."""
    if not 0.0 <= fraction <= 1.0:
        raise ValueError(f"the glitched fraction must be from 0 to 1, got {fraction!r}")
    count = round(fraction * log.n_samples)
    return np.sort(rng.choice(log.n_samples, count, replace=False))


def with_gnss_jumps(log: ManeuverLog, fraction: float, seed: int) -> tuple[ManeuverLog, np.ndarray]:
    """Replace ``fraction`` of the fixes by jumps of :data:`GNSS_JUMP_M` in any direction.

    Each chosen sample's position moves by a distance uniform in :data:`GNSS_JUMP_M`
    towards a uniform direction, the samples around it keep theirs: what a receiver's
    multipath or a lost-and-found fix writes. The ``source`` metadata says so.

    Parameters
    ----------
    log : ManeuverLog
        The clean log.
    fraction : float
        Share of the samples to glitch, 0 to 1 (0.01: 1 %).
    seed : int
        Seed of the glitches' generator (same seed, same samples and jumps).

    Returns
    -------
    tuple of ManeuverLog and numpy.ndarray
        The log and the indices of the jumped samples.

    """
    rng = np.random.default_rng(seed)
    index = _glitch_samples(log, fraction, rng)
    distance = rng.uniform(*GNSS_JUMP_M, index.size)
    direction = rng.uniform(0.0, 2.0 * math.pi, index.size)
    x, y = log.x_m.copy(), log.y_m.copy()
    x[index] += distance * np.cos(direction)
    y[index] += distance * np.sin(direction)
    low, high = GNSS_JUMP_M
    note = f"GNSS jumps of {low:g}-{high:g} m on {index.size} samples (seed {seed})"
    return replace(log, x_m=x, y_m=y, metadata=_noted(log, note)), index


def with_compass_spikes(
    log: ManeuverLog, fraction: float, seed: int
) -> tuple[ManeuverLog, np.ndarray]:
    """Add spikes of :data:`COMPASS_SPIKE_DEG`, either way, to ``fraction`` of the headings.

    As :func:`with_gnss_jumps`, for the heading: what a gyro's serial line garbles.

    Returns
    -------
    tuple of ManeuverLog and numpy.ndarray
        The log and the indices of the spiked samples.

    """
    rng = np.random.default_rng(seed)
    index = _glitch_samples(log, fraction, rng)
    spike = np.radians(rng.uniform(*COMPASS_SPIKE_DEG, index.size))
    heading = log.heading_rad.copy()
    heading[index] += spike * rng.choice([-1.0, 1.0], index.size)
    low, high = COMPASS_SPIKE_DEG
    note = f"compass spikes of {low:g}-{high:g} deg on {index.size} samples (seed {seed})"
    return replace(log, heading_rad=heading, metadata=_noted(log, note)), index


def _noted(log: ManeuverLog, note: str) -> dict[str, str]:
    """Return the metadata of ``log`` with ``note`` appended to its ``source``."""
    source = log.metadata.get("source")
    return {**log.metadata, "source": note if source is None else f"{source}; {note}"}


def _noise_streams(seed: int, size: int, per_channel: bool) -> Iterator[np.ndarray]:
    """Yield standard normal noise of ``size`` samples for each channel in turn.

    From one generator of ``seed``, or from one generator per channel spawned from it
    (``synthesize_log``'s ``noise_per_channel``).
    """
    if per_channel:
        for child in np.random.SeedSequence(seed).spawn(_NOISE_CHANNELS):
            yield np.random.default_rng(child).standard_normal(size)
        return
    rng = np.random.default_rng(seed)
    while True:
        yield rng.standard_normal(size)


def with_glitches(
    log: ManeuverLog,
    seed: int,
    *,
    gnss_jump_fraction: float = 0.0,
    compass_spike_fraction: float = 0.0,
    tag: str = "",
) -> ManeuverLog:
    """Return ``log`` with GNSS jumps and compass spikes on those shares of its samples.

    :func:`with_gnss_jumps` and :func:`with_compass_spikes`, each seeded by
    :func:`maneuver_seed` of ``seed`` and ``f"{tag}gnss-jumps"`` or
    ``f"{tag}compass-spikes"``, so that the clean channels and either kind of glitch stay
    the same whatever the other; a share of 0 leaves that channel as it is.
    """
    if gnss_jump_fraction > 0.0:
        jumps_seed = maneuver_seed(seed, f"{tag}gnss-jumps")
        log = with_gnss_jumps(log, gnss_jump_fraction, jumps_seed)[0]
    if compass_spike_fraction > 0.0:
        spikes_seed = maneuver_seed(seed, f"{tag}compass-spikes")
        log = with_compass_spikes(log, compass_spike_fraction, spikes_seed)[0]
    return log


def maneuver_seed(seed: int, maneuver: str) -> int:
    """Noise seed of one manoeuvre's log, derived from a run seed and the manoeuvre name.

    ``SeedSequence([seed, crc32(name)])``: each manoeuvre gets its own noise, and the
    same manoeuvre the same noise whatever else is synthesised with it.
    """
    if seed < 0:
        raise ScenarioError(f"seed must be non-negative, got {seed}")
    sequence = np.random.SeedSequence([seed, zlib.crc32(maneuver.encode("utf-8"))])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def synthesize_logs(
    directory: str | os.PathLike[str],
    maneuvers: Sequence[str],
    *,
    vessel: str = "kvlcc2",
    scale: str = "full",
    rate_hz: float = FULL_SCALE_LOGGING.rate_hz,
    position_noise_m: float = FULL_SCALE_LOGGING.position_noise_m,
    heading_noise_deg: float = FULL_SCALE_LOGGING.heading_noise_deg,
    seed: int = 0,
    approach_s: float = FULL_SCALE_LOGGING.approach_s,
    environment: SeaEnvironment | None = None,
    speed_log_axes: int = 1,
    speed_log_x_m: float = 0.0,
    gnss_x_m: float = 0.0,
    gnss_y_m: float = 0.0,
    gnss_jump_fraction: float = 0.0,
    compass_spike_fraction: float = 0.0,
    on_log: Callable[[Path], object] | None = None,
) -> list[Path]:
    """Write one synthetic trial log per manoeuvre, ``directory/<manoeuvre>.csv``.

    Parameters
    ----------
    directory : path-like
        Output folder (created).
    maneuvers : sequence of str
        Names from ``scenarios.synthesize.MANEUVERS``.
    vessel, scale : str
        Reference ship and scale (``reference_ship``).
    rate_hz, position_noise_m, heading_noise_deg, approach_s
        As ``synthesize_log`` [Hz, m, deg, s].
    seed : int
        Run seed; each manoeuvre's noise seed is :func:`maneuver_seed` of it.
    environment : SeaEnvironment, optional
        Current and wind the ship sails in (values at the ship's scale); calm water
        when None. Its ``gust_seed`` is replaced by each manoeuvre's noise seed, so the
        gusts too are reproducible from ``seed``.
    speed_log_axes, speed_log_x_m
        At sea, the speed log's axes and, with two, its position [m] (``synthesize_log``).
    gnss_x_m, gnss_y_m
        The GNSS antenna's position [m] (``synthesize_log``).
    gnss_jump_fraction, compass_spike_fraction : float
        Share of the samples with a GNSS jump (:func:`with_gnss_jumps`) and with a
        compass spike (:func:`with_compass_spikes`), 0 to 1; seeded by
        :func:`maneuver_seed` of ``seed`` and ``<manoeuvre>:gnss-jumps`` or
        ``<manoeuvre>:compass-spikes``, so the clean channels stay those of ``seed``.
    on_log : callable, optional
        Called with each path written.

    Returns
    -------
    list of pathlib.Path
        The logs, in the order of ``maneuvers``.

    """
    unknown = [m for m in maneuvers if m not in MANEUVERS]
    if unknown:
        raise ScenarioError(
            f"unknown manoeuvre(s) {', '.join(unknown)} (known: {', '.join(MANEUVERS)})"
        )
    written = []
    for name in dict.fromkeys(maneuvers):  # once each, in order
        noise_seed = maneuver_seed(seed, name)
        sea = None if environment is None else replace(environment, gust_seed=noise_seed)
        try:
            ship = reference_ship(vessel, scale, sea)
        except ValueError as exc:
            raise ScenarioError(str(exc)) from None
        log = synthesize_log(
            ship,
            MANEUVERS[name](),
            rate_hz=rate_hz,
            position_noise_m=position_noise_m,
            heading_noise_deg=heading_noise_deg,
            seed=noise_seed,
            approach_s=approach_s,
            speed_log_axes=speed_log_axes,
            speed_log_x_m=speed_log_x_m,
            gnss_x_m=gnss_x_m,
            gnss_y_m=gnss_y_m,
        )
        log = with_glitches(
            log,
            seed,
            gnss_jump_fraction=gnss_jump_fraction,
            compass_spike_fraction=compass_spike_fraction,
            tag=f"{name}:",
        )
        path = Path(directory) / f"{name}.csv"
        write_log(path, log)
        written.append(path)
        if on_log is not None:
            on_log(path)
    return written


def write_windage(
    directory: str | os.PathLike[str], vessel: str = "kvlcc2", scale: str = "full"
) -> Path:
    """Write the reference ship's windage, ``directory/windage.json`` (``fit --windage``).

    The areas, lateral centroid and effective inertias its wind load was synthesised with
    (``docs/kvlcc2_environment.md``), at ``scale``: what a trials engineer takes from the
    ship's general arrangement and loading condition.
    """
    if vessel != "kvlcc2":
        raise ScenarioError(f"reference vessel {vessel!r} has no windage (known: kvlcc2)")
    path = Path(directory) / "windage.json"
    write_atomic(path, json.dumps(kvlcc2_windage(scale).to_dict(), indent=2) + "\n")
    return path
