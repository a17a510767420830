"""PID heading autopilot: the control law and its pythonfmu slave.

The control law is the pure function :func:`pid_step`; :class:`HeadingAutopilot` is the
thin FMI 2.0 co-simulation adapter that pythonfmu packs into ``autopilot.fmu`` (built by
``build_autopilot.py``). The slave needs only the Python standard library and
pythonfmu's own sources, which travel inside the FMU.

Control law (sampled at the communication step h, heading error wrapped to (-π, π])::

    e_k   = wrap(ψ_set,k − ψ_k)
    I_k+1 = I_k + e_k h          if |e_k| < e_I, else I_k       (see anti-windup below)
    δ_c   = Kp e_k + Ki I_k+1 − Kd r_k
    δ_k+1 = clip(δ_c, −δ_max, +δ_max)

Positive rudder turns the ship to starboard (r > 0, ψ increasing), so a positive error
asks for positive rudder and the yaw-rate term damps the turn. Anti-windup by
conditional integration: the error is integrated only within the band |e| < e_I
(``integral_band``, default 5°), so a large course change does not charge the integral
(it would overshoot and settle slowly), and not while the command is saturated with the
error pushing it further into the limit. The rudder computed in ``fmi2DoStep`` from
the inputs at t_k is the output over [t_k+1, t_k+2): one communication step of delay,
as a sampled controller with zero-order hold has.

FMU interface (SI units, radians):

========================  ==========  ===================================================
variable                  causality   meaning
========================  ==========  ===================================================
``heading_setpoint``      input       commanded heading ψ_set [rad]
``psi``                   input       ship heading ψ [rad] (continuous or wrapped)
``r``                     input       ship yaw rate r [rad/s]
``rudder_angle``          output      rudder command δ [rad], within ±``rudder_limit``
``Kp``                    parameter   rudder per heading error [rad/rad]
``Ki``                    parameter   rudder per integrated heading error [1/s]
``Kd``                    parameter   rudder per yaw rate [s]
``rudder_limit``          parameter   δ_max [rad], 0 < δ_max ≤ 35°
``integral_band``         parameter   e_I [rad], > 0: integrate the error only within it
========================  ==========  ===================================================

Status mapping: pythonfmu turns a Python exception into ``fmi2Fatal`` and ``False`` from
``do_step`` into ``fmi2Discard``; nothing here raises. A non-finite input or a bad
parameter is logged with status ``fmi2Error`` and the step returns ``fmi2Discard`` with
the output and the integral unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pythonfmu import Fmi2Causality, Fmi2Slave, Fmi2Variability, Real
from pythonfmu.enums import Fmi2Status

# The largest rudder angle the autopilot may command [rad] (35°, the usual hard-over).
RUDDER_LIMIT_MAX_RAD = math.radians(35.0)
# Default band of heading error within which the error is integrated [rad] (5°).
INTEGRAL_BAND_RAD = math.radians(5.0)


@dataclass(frozen=True)
class PidGains:
    """Gains and rudder limit of the heading autopilot.

    Attributes
    ----------
    kp : float
        Proportional gain: rudder per heading error [rad/rad].
    ki : float
        Integral gain: rudder per integrated heading error [1/s].
    kd : float
        Derivative gain on the measured yaw rate: rudder per yaw rate [s].
    rudder_limit_rad : float
        Largest commanded rudder angle δ_max [rad], 0 < δ_max ≤ 35°.
    integral_band_rad : float
        The heading error is integrated only while |e| < e_I [rad], e_I > 0.

    """

    kp: float = 3.0
    ki: float = 0.001
    kd: float = 60.0
    rudder_limit_rad: float = RUDDER_LIMIT_MAX_RAD
    integral_band_rad: float = INTEGRAL_BAND_RAD

    def problems(self) -> list[str]:
        """Human-readable problems of these values (empty when they are usable)."""
        found = [
            f"{name} must be a finite number >= 0, got {value}"
            for name, value in (("Kp", self.kp), ("Ki", self.ki), ("Kd", self.kd))
            if not (math.isfinite(value) and value >= 0.0)
        ]
        limit = self.rudder_limit_rad
        if not (math.isfinite(limit) and 0.0 < limit <= RUDDER_LIMIT_MAX_RAD + 1e-12):
            found.append(
                f"rudder_limit must be in (0, {RUDDER_LIMIT_MAX_RAD:.6f}] rad, got {limit}"
            )
        band = self.integral_band_rad
        if not (band > 0.0):  # also catches NaN; +inf integrates always
            found.append(f"integral_band must be > 0 rad, got {band}")
        return found


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to (-π, π] [rad]."""
    wrapped = math.remainder(angle_rad, 2.0 * math.pi)
    return math.pi if wrapped == -math.pi else wrapped


def pid_step(
    gains: PidGains,
    integral: float,
    setpoint_rad: float,
    psi_rad: float,
    r_radps: float,
    dt_s: float,
) -> tuple[float, float]:
    """Advance the autopilot by one sample (equations in the module docstring).

    Parameters
    ----------
    gains : PidGains
        Gains and rudder limit.
    integral : float
        Integrated heading error at the start of the sample [rad s].
    setpoint_rad : float
        Commanded heading ψ_set [rad].
    psi_rad : float
        Measured heading ψ [rad].
    r_radps : float
        Measured yaw rate r [rad/s].
    dt_s : float
        Sample time h [s], >= 0.

    Returns
    -------
    tuple of float
        The integral at the end of the sample [rad s] and the rudder command δ [rad],
        within ±``gains.rudder_limit_rad``.

    """
    error = wrap_angle(setpoint_rad - psi_rad)
    damping = gains.kd * r_radps
    updated = integral + error * dt_s if abs(error) < gains.integral_band_rad else integral
    command = gains.kp * error + gains.ki * updated - damping
    limit = gains.rudder_limit_rad
    if updated != integral and abs(command) > limit and error * command > 0.0:
        # Saturated and the error drives further into the limit: hold the integral.
        updated = integral
        command = gains.kp * error + gains.ki * updated - damping
    return updated, min(limit, max(-limit, command))


class HeadingAutopilot(Fmi2Slave):
    """FMI 2.0 co-simulation slave of the PID heading autopilot (see the module docstring)."""

    author = "shipid examples"
    description = "PID heading autopilot: heading set-point, psi, r -> rudder_angle"

    def __init__(self, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        defaults = PidGains()
        self.heading_setpoint = 0.0
        self.psi = 0.0
        self.r = 0.0
        self.rudder_angle = 0.0
        self.Kp = defaults.kp
        self.Ki = defaults.ki
        self.Kd = defaults.kd
        self.rudder_limit = defaults.rudder_limit_rad
        self.integral_band = defaults.integral_band_rad
        self._integral = 0.0
        continuous = Fmi2Variability.continuous
        fixed = Fmi2Variability.fixed
        for name, causality, variability, text in (
            ("heading_setpoint", Fmi2Causality.input, continuous, "commanded heading [rad]"),
            ("psi", Fmi2Causality.input, continuous, "ship heading [rad]"),
            ("r", Fmi2Causality.input, continuous, "ship yaw rate [rad/s]"),
            (
                "rudder_angle",
                Fmi2Causality.output,
                Fmi2Variability.discrete,
                "rudder command [rad], within +-rudder_limit",
            ),
            ("Kp", Fmi2Causality.parameter, fixed, "rudder per heading error [rad/rad]"),
            ("Ki", Fmi2Causality.parameter, fixed, "rudder per integrated heading error [1/s]"),
            ("Kd", Fmi2Causality.parameter, fixed, "rudder per yaw rate [s]"),
            ("rudder_limit", Fmi2Causality.parameter, fixed, "largest rudder command [rad]"),
            (
                "integral_band",
                Fmi2Causality.parameter,
                fixed,
                "heading error is integrated only while |error| < integral_band [rad]",
            ),
        ):
            self.register_variable(
                Real(name, causality=causality, variability=variability, description=text)
            )

    def _gains(self) -> PidGains:
        return PidGains(
            kp=float(self.Kp),
            ki=float(self.Ki),
            kd=float(self.Kd),
            rudder_limit_rad=float(self.rudder_limit),
            integral_band_rad=float(self.integral_band),
        )

    def do_step(self, current_time: float, step_size: float) -> bool:
        """Compute the rudder for the next step; ``False`` means fmi2Discard."""
        gains = self._gains()
        problems = gains.problems()
        inputs = (self.heading_setpoint, self.psi, self.r)
        if not all(math.isfinite(float(value)) for value in inputs):
            problems.append(f"non-finite input (heading_setpoint, psi, r) = {inputs}")
        if not (math.isfinite(step_size) and step_size >= 0.0):
            problems.append(f"communication step must be >= 0, got {step_size}")
        if problems:
            self.log(f"t = {current_time} s: " + "; ".join(problems), Fmi2Status.error)
            return False
        self._integral, self.rudder_angle = pid_step(
            gains,
            self._integral,
            float(self.heading_setpoint),
            float(self.psi),
            float(self.r),
            step_size,
        )
        return True

    def _get_fmu_state(self) -> dict[str, Any]:
        state = super()._get_fmu_state()
        state["_integral"] = self._integral
        return state
