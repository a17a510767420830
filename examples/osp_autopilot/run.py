"""Ship FMU + PID heading autopilot FMU, closed loop, co-simulated in libcosim (OSP).

    python examples/osp_autopilot/run.py [--params build/demo/params.json]
        [--setpoint-deg 30] [--duration-s 600] [--settle-by-s 300] [--tolerance-deg 0.5]
        [--workdir build/osp_autopilot] [--csv heading.csv]

Builds the native ship FMU from a params.json (default: the 100 m demo ship of
``tests/conftest.py``) and the pythonfmu autopilot FMU (``autopilot.py``) into the work
folder, writes ``OspSystemStructure.xml`` there (this folder's file with the set-point,
propeller speed and gains filled in), loads it with libcosimpy, steps it at 0.1 s and
prints whether the heading settled: |ψ − ψ_set| < tolerance from some time on to the
end of the run, that time being no later than ``--settle-by-s``. Exit status 0 when it
settled, 1 when not, 2 on a usage error.

The work folder is a complete OSP case (FMUs, ``ship_OspModelDescription.xml``,
``OspSystemStructure.xml``). The autopilot is a pythonfmu FMU: its library takes the
Python C API from the process that loads it, which a Python process (libcosimpy, fmpy)
provides; a C/C++ host such as libcosim's ``cosim`` tool needs libpython preloaded
(see README.md).

Importable: :func:`run_autopilot` runs prepared FMUs and returns an :class:`AutopilotRun`.
"""

from __future__ import annotations

import argparse
import csv
import math
import shutil
import sys
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from fmpy import read_model_description
from libcosimpy._internal import get_last_error_message  # no public accessor
from libcosimpy.CosimEnums import CosimExecutionState
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimObserver import CosimObserver

from fmu_model import ModelParameters, load_params
from fmu_model.errors import FmuBuildError
from fmu_model.export_native import build_native_fmu, osp_sidecar_path

HERE = Path(__file__).resolve().parent
TEMPLATE = HERE / "OspSystemStructure.xml"
OSP_NAMESPACE = "http://opensimulationplatform.com/MSMI/OSPSystemStructure"
SHIP = "ship"  # simulator names in OspSystemStructure.xml; the FMUs are <name>.fmu
AUTOPILOT = "autopilot"
NANOSECONDS = 1_000_000_000  # libcosim counts time in integer nanoseconds

# The 100 m demo ship (tests/conftest.py, SEED_COEFFICIENTS): Shi et al. (2009) structure,
# 5 m/s at 2 rev/s, positive rudder turns to starboard.
DEMO_COEFFICIENTS = {
    "a1": -0.004,
    "a2": -0.002,
    "a3": -10.0,
    "a4": -0.05,
    "a5": 0.5,
    "a6": 0.0,
    "a7": 0.0,
    "a8": -0.005,
    "a9": 0.0375,
    "b1": -0.08,
    "b2": 0.0,
    "b3": -0.02,
    "b4": -0.5,
    "c1": -0.0003,
    "c2": -0.05,
    "c3": 0.0036,
}

# Autopilot gains in ship time units τ = L/U: Kp [-], Kd = KD_TAU τ [s], Ki = KI_TAU / τ
# [1/s]. Tuned on the demo ship (τ = 20 s: Kd = 60 s, Ki = 0.001 1/s), where a 30° course
# change settles to 0.5° in 82 s with 35° rudder; the KVLCC2 model of `make demo`
# (τ = 40 s) settles in about 220 s with the scaled gains.
KP = 3.0
KD_TAU = 3.0
KI_TAU = 0.02
RUDDER_LIMIT_RAD = math.radians(35.0)


class CosimRunError(RuntimeError):
    """libcosim could not load or step the system."""


@dataclass(frozen=True)
class AutopilotRun:
    """Time series of one co-simulation, sampled after every step.

    Attributes
    ----------
    time_s : numpy.ndarray
        Time t_k = k h, k = 1 ... n [s].
    heading_rad : numpy.ndarray
        Ship heading ψ(t_k) [rad] (continuous, not wrapped).
    yaw_rate_radps : numpy.ndarray
        Ship yaw rate r(t_k) [rad/s].
    rudder_rad : numpy.ndarray
        Autopilot output at t_k [rad], the rudder over the next step (0 when the rudder
        is not connected, see :func:`run_autopilot`).
    setpoint_rad : float
        Heading set-point [rad].

    """

    time_s: np.ndarray
    heading_rad: np.ndarray
    yaw_rate_radps: np.ndarray
    rudder_rad: np.ndarray
    setpoint_rad: float

    def heading_error_deg(self) -> np.ndarray:
        """ψ − ψ_set wrapped to [-180°, 180°) [deg]."""
        error = np.degrees(self.heading_rad - self.setpoint_rad)
        return (error + 180.0) % 360.0 - 180.0

    def settling_time_s(self, tolerance_deg: float) -> float | None:
        """Earliest sample time from which |ψ − ψ_set| < tolerance to the end [s].

        None when the last sample is outside the tolerance.
        """
        outside = np.flatnonzero(np.abs(self.heading_error_deg()) >= tolerance_deg)
        if outside.size == 0:
            return float(self.time_s[0])
        if outside[-1] == self.time_s.size - 1:
            return None
        return float(self.time_s[outside[-1] + 1])

    def settled(self, tolerance_deg: float, by_s: float) -> bool:
        """Whether the heading is within the tolerance from ``by_s`` (or earlier) to the end."""
        settle = self.settling_time_s(tolerance_deg)
        return settle is not None and settle <= by_s + 1e-9 and bool(self.time_s[-1] >= by_s)


def demo_params() -> ModelParameters:
    """Return the 100 m demo ship (the coefficients of ``tests/conftest.py``)."""
    return ModelParameters.from_vector(
        "shi2009",
        np.array(list(DEMO_COEFFICIENTS.values())),
        length_m=100.0,
        vessel_name="demo ship",
        nominal_speed_mps=5.0,
        nominal_n_rps=2.0,
    )


def scaled_gains(length_m: float, speed_mps: float) -> dict[str, float]:
    """Autopilot parameters (FMU variable names) for a ship of this length and speed.

    Parameters
    ----------
    length_m : float
        Ship length [m].
    speed_mps : float
        Service speed [m/s], > 0.

    Returns
    -------
    dict of str to float
        ``Kp`` [-], ``Ki`` [1/s], ``Kd`` [s], ``rudder_limit`` [rad].

    """
    if not (length_m > 0.0 and speed_mps > 0.0):
        raise ValueError(f"length and speed must be positive, got {length_m} m, {speed_mps} m/s")
    tau = length_m / speed_mps
    return {"Kp": KP, "Ki": KI_TAU / tau, "Kd": KD_TAU * tau, "rudder_limit": RUDDER_LIMIT_RAD}


def ship_start_values(ship_fmu: Path) -> dict[str, float]:
    """Start values of the ship FMU's real variables (``length``, ``u0``, ``propeller_rpm`` …)."""
    description = read_model_description(str(ship_fmu))
    return {v.name: float(v.start) for v in description.modelVariables if v.start is not None}


def _copy(source: Path, target: Path) -> None:
    if not (target.exists() and source.resolve() == target.resolve()):
        shutil.copyfile(source, target)


def write_system_structure(
    workdir: Path,
    *,
    setpoint_rad: float,
    propeller_rpm: float,
    gains: dict[str, float],
    connect_rudder: bool = True,
) -> Path:
    """Write ``workdir/OspSystemStructure.xml`` from this folder's file.

    The initial values of the template are replaced (or added): the ship's
    ``propeller_rpm`` and the autopilot's ``heading_setpoint`` and ``gains`` (any of its
    parameters by name, e.g. ``Kp`` or ``integral_band``). Without ``connect_rudder`` the connection
    autopilot.rudder_angle → ship.rudder_angle is removed (the ship keeps rudder 0).
    """
    ET.register_namespace("", OSP_NAMESPACE)
    tree = ET.parse(TEMPLATE)
    ns = {"osp": OSP_NAMESPACE}
    values = {
        SHIP: {"propeller_rpm": propeller_rpm},
        AUTOPILOT: {"heading_setpoint": setpoint_rad, **gains},
    }
    for simulator in tree.getroot().iterfind("osp:Simulators/osp:Simulator", ns):
        wanted = values[simulator.attrib["name"]]
        initials = simulator.find("osp:InitialValues", ns)
        if initials is None:
            initials = ET.SubElement(simulator, f"{{{OSP_NAMESPACE}}}InitialValues")
        reals = {
            initial.attrib["variable"]: initial.find("osp:Real", ns)
            for initial in initials.iterfind("osp:InitialValue", ns)
        }
        for name, value in wanted.items():
            real = reals.get(name)
            if real is None:  # a variable the template leaves at the FMU's start value
                initial = ET.SubElement(initials, f"{{{OSP_NAMESPACE}}}InitialValue", variable=name)
                real = ET.SubElement(initial, f"{{{OSP_NAMESPACE}}}Real")
            real.set("value", repr(float(value)))
    if not connect_rudder:
        connections = tree.getroot().find("osp:Connections", ns)
        assert connections is not None, "the template has connections"
        for connection in list(connections):
            targets = [(v.attrib["simulator"], v.attrib["name"]) for v in connection]
            if (SHIP, "rudder_angle") in targets:
                connections.remove(connection)
    root = tree.getroot()
    root.insert(
        0,
        ET.Comment(
            f" Written by examples/osp_autopilot/run.py from {TEMPLATE.name}: set-point "
            f"{math.degrees(setpoint_rad):g} deg, rudder "
            f"{'connected' if connect_rudder else 'NOT connected'} "
        ),
    )
    ET.indent(tree, space="    ")
    path = workdir / "OspSystemStructure.xml"
    tree.write(path, encoding="UTF-8", xml_declaration=True)
    return path


def run_autopilot(
    ship_fmu: Path,
    autopilot_fmu: Path,
    workdir: Path,
    duration_s: float,
    setpoint_deg: float,
    *,
    propeller_rpm: float | None = None,
    gains: dict[str, float] | None = None,
    connect_rudder: bool = True,
) -> AutopilotRun:
    """Run ship + autopilot in libcosim and return heading and rudder time series.

    The FMUs (and the ship's ``<stem>_OspModelDescription.xml``, when present) are
    copied into ``workdir`` as ``ship.fmu`` and ``autopilot.fmu`` next to the written
    ``OspSystemStructure.xml``; the system is stepped at its base step (0.1 s) from 0 to
    ``duration_s``. The ship starts at its own initial state (``u0`` … ``psi0``).

    Parameters
    ----------
    ship_fmu : pathlib.Path
        Ship FMU with this project's interface.
    autopilot_fmu : pathlib.Path
        The autopilot FMU (``build_autopilot.py``).
    workdir : pathlib.Path
        Folder for the OSP case; created if needed.
    duration_s : float
        Simulated time [s].
    setpoint_deg : float
        Heading set-point [deg].
    propeller_rpm : float, optional
        Propeller speed [rpm]; default the ship FMU's start value (its nominal speed).
    gains : dict of str to float, optional
        Autopilot parameters by name (``Kp``, ``Ki``, ``Kd``, ``rudder_limit``,
        ``integral_band``); default :func:`scaled_gains` of the ship FMU's ``length``
        and ``u0``.
    connect_rudder : bool
        False removes autopilot → ship rudder connection (open loop, rudder 0).

    Returns
    -------
    AutopilotRun
        Heading, yaw rate and rudder after every step.

    Raises
    ------
    ValueError
        ``duration_s`` is not positive.
    CosimRunError
        libcosim cannot load the system or a step fails (e.g. a bad autopilot
        parameter: the FMU logs the reason and discards the step).

    """
    ship_fmu, autopilot_fmu, workdir = Path(ship_fmu), Path(autopilot_fmu), Path(workdir)
    if not duration_s > 0.0:
        raise ValueError(f"duration_s must be positive, got {duration_s}")
    workdir.mkdir(parents=True, exist_ok=True)
    starts = ship_start_values(ship_fmu)
    rpm = starts["propeller_rpm"] if propeller_rpm is None else float(propeller_rpm)
    if gains is None:
        gains = scaled_gains(starts["length"], starts["u0"])
    _copy(ship_fmu, workdir / f"{SHIP}.fmu")
    sidecar = osp_sidecar_path(ship_fmu)
    if sidecar.is_file():
        _copy(sidecar, osp_sidecar_path(workdir / f"{SHIP}.fmu"))
    _copy(autopilot_fmu, workdir / f"{AUTOPILOT}.fmu")
    setpoint_rad = math.radians(setpoint_deg)
    structure = write_system_structure(
        workdir,
        setpoint_rad=setpoint_rad,
        propeller_rpm=rpm,
        gains=gains,
        connect_rudder=connect_rudder,
    )

    try:
        execution = CosimExecution.from_osp_config_file(str(structure))
    except AssertionError as exc:  # libcosimpy reports a failed load by assert
        raise CosimRunError(str(exc)) from None
    ship = execution.slave_index_from_instance_name(SHIP)
    autopilot = execution.slave_index_from_instance_name(AUTOPILOT)
    ship_vr = {v.name.decode(): v.reference for v in execution.slave_variables(ship)}
    autopilot_vr = {v.name.decode(): v.reference for v in execution.slave_variables(autopilot)}
    observer = CosimObserver.create_last_value()
    execution.add_observer(observer)

    base_step = ET.parse(structure).getroot().findtext(f"{{{OSP_NAMESPACE}}}BaseStepSize")
    step_ns = round(float(base_step or "nan") * NANOSECONDS)
    n_steps = max(1, round(duration_s * NANOSECONDS / step_ns))
    ship_refs = [ship_vr["psi"], ship_vr["r"]]
    rudder_ref = [autopilot_vr["rudder_angle"]]
    samples = np.empty((n_steps, 3))
    for k in range(n_steps):
        if not execution.step(1):
            state = CosimExecutionState(execution.status().state).name
            raise CosimRunError(
                f"step {k + 1} (t = {k * step_ns / NANOSECONDS:g} s) failed, execution {state}: "
                f"{get_last_error_message() or 'see the FMU log above'}"
            )
        samples[k, :2] = observer.last_real_values(ship, ship_refs)
        samples[k, 2] = observer.last_real_values(autopilot, rudder_ref)[0]
    return AutopilotRun(
        time_s=np.arange(1, n_steps + 1) * step_ns / NANOSECONDS,
        heading_rad=samples[:, 0],
        yaw_rate_radps=samples[:, 1],
        rudder_rad=samples[:, 2],
        setpoint_rad=setpoint_rad,
    )


def write_csv(path: Path, run: AutopilotRun) -> None:
    """Write ``time_s, heading_deg, yaw_rate_degps, rudder_deg`` rows."""
    with path.open("w", newline="", encoding="utf-8") as stream:
        writer = csv.writer(stream)
        writer.writerow(["time_s", "heading_deg", "yaw_rate_degps", "rudder_deg"])
        for row in zip(
            run.time_s,
            np.degrees(run.heading_rad),
            np.degrees(run.yaw_rate_radps),
            np.degrees(run.rudder_rad),
            strict=True,
        ):
            writer.writerow(f"{value:.6f}" for value in row)


def main(argv: list[str] | None = None) -> int:
    """Command line: build both FMUs, run the OSP case, report whether the heading settled."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--params", type=Path, help="params.json of the ship (default: demo ship)")
    parser.add_argument("--setpoint-deg", type=float, default=30.0, help="heading set-point")
    parser.add_argument("--duration-s", type=float, default=600.0, help="simulated time")
    parser.add_argument("--settle-by-s", type=float, default=300.0, help="settled no later than")
    parser.add_argument("--tolerance-deg", type=float, default=0.5, help="settling band ±")
    parser.add_argument("--workdir", type=Path, default=Path("build") / "osp_autopilot")
    parser.add_argument("--csv", type=Path, help="write the time series to this CSV file")
    args = parser.parse_args(argv)
    if not (args.tolerance_deg > 0.0 and 0.0 <= args.settle_by_s <= args.duration_s):
        parser.error("need --tolerance-deg > 0 and 0 <= --settle-by-s <= --duration-s")

    from build_autopilot import build_autopilot_fmu  # next to this script

    try:
        params = demo_params() if args.params is None else load_params(args.params)
        gains = scaled_gains(params.length_m, params.nominal_speed_mps)
        ship_fmu = build_native_fmu(params, args.workdir / f"{SHIP}.fmu")
    except (OSError, ValueError, FmuBuildError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    autopilot_fmu = build_autopilot_fmu(args.workdir / f"{AUTOPILOT}.fmu")
    log_output_level(CosimLogLevel.WARNING)  # libcosim logs every FMI call otherwise
    print(
        f"ship {params.vessel_name!r} (L = {params.length_m:g} m, "
        f"{params.nominal_speed_mps:g} m/s, {60.0 * params.nominal_n_rps:g} rpm); autopilot "
        + ", ".join(f"{name} = {value:.4g}" for name, value in gains.items())
    )
    try:
        run = run_autopilot(
            ship_fmu, autopilot_fmu, args.workdir, args.duration_s, args.setpoint_deg, gains=gains
        )
    except CosimRunError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    if args.csv is not None:
        write_csv(args.csv, run)

    error = run.heading_error_deg()
    final = run.time_s >= args.settle_by_s
    settle = run.settling_time_s(args.tolerance_deg)
    print(f"OSP case: {args.workdir / 'OspSystemStructure.xml'} ({run.time_s.size} steps)")
    print(
        f"set-point {args.setpoint_deg:g} deg; heading {np.degrees(run.heading_rad[-1]):.3f} deg "
        f"at {run.time_s[-1]:g} s; max rudder {np.degrees(np.abs(run.rudder_rad).max()):.1f} deg; "
        f"max |error| after {args.settle_by_s:g} s: {np.abs(error[final]).max():.3f} deg"
    )
    settled = run.settled(args.tolerance_deg, args.settle_by_s)
    when = "never" if settle is None else f"from {settle:.1f} s on"
    verdict = "settled" if settled else "NOT settled"
    print(
        f"heading {verdict}: |error| < {args.tolerance_deg:g} deg {when} "
        f"(required from {args.settle_by_s:g} s to {run.time_s[-1]:g} s)"
    )
    return 0 if settled else 1


if __name__ == "__main__":
    sys.exit(main())
