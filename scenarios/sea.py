"""The sea a reference ship sails in: a uniform current and a wind with gusts.

What the environment is, independent of any ship: the current's velocity over ground
and its rate of change, the true wind's speed and direction, and the gust process.
How a ship responds to it (the wind load on its windage, the current in its equations
of motion) is the ship's own business: ``scenarios.kvlcc2`` for the MMG reference.

Conventions (DESIGN.md): earth frame x North, y East; directions clockwise from North.

* **Current**: uniform in space, over ground, setting *towards* ``current_to_rad``.
  It may change linearly in time over the run, in speed and in direction:
  c(t) = c₀ + ċ t, θ(t) = θ₀ + ω t, with t from the start of the run (the log's
  time 0). The speed may pass through zero (the current then sets the other way):
  the model is the linear one, not clipped.
* **Wind**: the true wind over ground, *from* ``wind_from_rad``, mean speed W̄. Gusts
  vary the speed along the mean direction only (longitudinal turbulence):
  W(t) = W̄ + g(t).
* **Gusts** g(t): a first-order Gauss-Markov (Ornstein-Uhlenbeck) process, stationary,
  zero mean, standard deviation σ and correlation time T,

      dg = −g/T dt + σ √(2/T) dB,   R(τ) = σ² exp(−|τ|/T),
      S(ω) = 2σ²T / (1 + ω²T²)  (two-sided),

  sampled exactly on a grid of step Δ = T/20 (g₀ ~ N(0, σ²), g_{k+1} = a g_k +
  σ √(1 − a²) ξ_k, a = exp(−Δ/T)) and linearly interpolated between the nodes, so
  that the integrator sees a continuous wind whatever its step, and the same seed gives
  the same gusts at any step. Why this and not the Davenport (1961) or Harris (1971)
  spectrum: its two parameters are the two numbers one states for a trial (gust
  standard deviation and duration), its variance is exact and its sampling is exact
  and step-independent; Davenport's spectrum has no energy at the lowest frequencies
  (which Harris's corrects), and both differ from this one mainly in their −5/3 rather
  than −2 roll-off above 1/T, frequencies a large ship's yaw (time constant L/U ≈ 40 s
  for KVLCC2) filters out. The default T is 60 s at full scale (Froude-scaled at model
  scale, see :func:`default_gust_time_s`), the order of the gust durations that move a
  large ship; state another one when a trial's wind record says otherwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "DEFAULT_GUST_TIME_FULL_SCALE_S",
    "GustProcess",
    "SeaEnvironment",
    "default_gust_time_s",
]

DEFAULT_GUST_TIME_FULL_SCALE_S = 60.0
"""Default correlation time T of the gusts at full scale (L = 320 m) [s]."""

_FULL_LENGTH_M = 320.0
_GRID_STEPS_PER_TIME_CONSTANT = 20
_CHUNK = 4096
_SECONDS_PER_HOUR = 3600.0


def default_gust_time_s(length_m: float) -> float:
    """Default gust correlation time for a ship of length ``length_m`` [s].

    60 s at the 320 m full-scale KVLCC2, Froude-scaled: 60 s · √(L / 320 m).
    """
    return DEFAULT_GUST_TIME_FULL_SCALE_S * math.sqrt(length_m / _FULL_LENGTH_M)


@dataclass(frozen=True)
class SeaEnvironment:
    """A uniform current and a wind with gusts, in SI units and radians.

    Parameters
    ----------
    current_speed_mps : float
        Current speed over ground at t = 0 [m/s], >= 0.
    current_to_rad : float
        Direction the current sets towards at t = 0, clockwise from North [rad].
    current_change_mps2 : float
        Rate of change of the current speed ċ [m/s per s] (linear in time).
    current_veer_radps : float
        Rate of change of the current direction ω [rad/s], positive clockwise.
    wind_speed_mps : float
        Mean true wind speed over ground W̄ [m/s], >= 0.
    wind_from_rad : float
        Direction the true wind comes from, clockwise from North [rad].
    gust_std_mps : float
        Standard deviation σ of the gust speed [m/s], >= 0 (0: a steady wind).
    gust_time_s : float or None
        Correlation time T of the gusts [s], > 0; None: :func:`default_gust_time_s` of
        the ship that sails in it.
    gust_seed : int
        Seed of the gust process, >= 0.

    Raises
    ------
    ValueError
        A value that is not a finite number, a negative speed or standard deviation, a
        non-positive gust time or a negative seed.

    """

    current_speed_mps: float = 0.0
    current_to_rad: float = 0.0
    current_change_mps2: float = 0.0
    current_veer_radps: float = 0.0
    wind_speed_mps: float = 0.0
    wind_from_rad: float = 0.0
    gust_std_mps: float = 0.0
    gust_time_s: float | None = None
    gust_seed: int = 0

    def __post_init__(self) -> None:
        for name in (
            "current_speed_mps",
            "current_to_rad",
            "current_change_mps2",
            "current_veer_radps",
            "wind_speed_mps",
            "wind_from_rad",
            "gust_std_mps",
        ):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)):
                raise ValueError(f"{name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"{name} must be finite, got {value!r}")
            object.__setattr__(self, name, float(value))
        for name in ("current_speed_mps", "wind_speed_mps", "gust_std_mps"):
            if getattr(self, name) < 0.0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)!r}")
        if self.gust_time_s is not None:
            if not (math.isfinite(self.gust_time_s) and self.gust_time_s > 0.0):
                raise ValueError(f"gust_time_s must be > 0, got {self.gust_time_s!r}")
            object.__setattr__(self, "gust_time_s", float(self.gust_time_s))
        if isinstance(self.gust_seed, bool) or not isinstance(self.gust_seed, int):
            raise ValueError(f"gust_seed must be an int, got {self.gust_seed!r}")
        if self.gust_seed < 0:
            raise ValueError(f"gust_seed must be >= 0, got {self.gust_seed}")

    @property
    def has_current(self) -> bool:
        """True when there is a current now or later (a speed or a rate of change)."""
        return self.current_speed_mps != 0.0 or self.current_change_mps2 != 0.0

    @property
    def current_is_steady(self) -> bool:
        """True when the current neither changes speed nor veers."""
        return self.current_change_mps2 == 0.0 and self.current_veer_radps == 0.0

    @property
    def has_wind(self) -> bool:
        """True when there is a true wind (a mean speed or gusts)."""
        return self.wind_speed_mps != 0.0 or self.gust_std_mps != 0.0

    def current_ne(self, time_s: float) -> tuple[float, float, float, float]:
        """Return the current velocity and its time derivative (earth frame) at ``time_s``.

        With c(t) = c₀ + ċ t and θ(t) = θ₀ + ω t:

            c_N = c cos θ,  c_E = c sin θ,
            ċ_N = ċ cos θ − c ω sin θ,  ċ_E = ċ sin θ + c ω cos θ.

        Parameters
        ----------
        time_s : float
            Time from the start of the run [s].

        Returns
        -------
        tuple of float
            c_N, c_E [m/s] and dc_N/dt, dc_E/dt [m/s²].

        """
        if self.current_is_steady:  # the same bits at every time
            speed, to = self.current_speed_mps, self.current_to_rad
        else:
            speed = self.current_speed_mps + self.current_change_mps2 * time_s
            to = self.current_to_rad + self.current_veer_radps * time_s
        cos_to, sin_to = math.cos(to), math.sin(to)
        # c_N, c_E as fmu_model.environment.current_velocity_ne (in math, for scalars)
        c_n, c_e = speed * cos_to, speed * sin_to
        if self.current_is_steady:
            return c_n, c_e, 0.0, 0.0
        turn = speed * self.current_veer_radps
        return (
            c_n,
            c_e,
            self.current_change_mps2 * cos_to - turn * sin_to,
            self.current_change_mps2 * sin_to + turn * cos_to,
        )

    def describe(self, gust_time_s: float | None = None) -> str:
        """One line for a log's ``# source:``: current, wind and gusts, in degrees.

        Parameters
        ----------
        gust_time_s : float, optional
            The gust time actually used [s], when :attr:`gust_time_s` is None.

        """
        parts = []
        if self.has_current or self.current_veer_radps != 0.0:
            text = (
                f"current {self.current_speed_mps:g} m/s towards "
                f"{math.degrees(self.current_to_rad):g} deg"
            )
            if not self.current_is_steady:
                text += (
                    f", changing {self.current_change_mps2 * _SECONDS_PER_HOUR:+g} m/s per hour"
                    f" and veering {math.degrees(self.current_veer_radps) * _SECONDS_PER_HOUR:+g}"
                    " deg per hour"
                )
            parts.append(text)
        else:
            parts.append("no current")
        if self.has_wind:
            text = f"wind {self.wind_speed_mps:g} m/s from {math.degrees(self.wind_from_rad):g} deg"
            if self.gust_std_mps > 0.0:
                time_s = self.gust_time_s if self.gust_time_s is not None else gust_time_s
                shown = "default" if time_s is None else f"{time_s:.4g} s"
                text += (
                    f", gusts Ornstein-Uhlenbeck std {self.gust_std_mps:g} m/s, time constant "
                    f"{shown}, seed {self.gust_seed}"
                )
            parts.append(text)
        else:
            parts.append("no wind")
        return "; ".join(parts)


class GustProcess:
    """One realisation of the Ornstein-Uhlenbeck gust g(t), t >= 0 (module docstring).

    Exact on the grid t_k = k Δ, Δ = T/20; linear between the nodes. Nodes are drawn in
    order from a generator seeded with ``SeedSequence([seed, 1])`` as far as asked for,
    so the path does not depend on the times it is evaluated at.

    Parameters
    ----------
    std_mps : float
        Standard deviation σ [m/s], >= 0 (0: g ≡ 0).
    time_constant_s : float
        Correlation time T [s], > 0.
    seed : int
        Seed, >= 0.

    """

    def __init__(self, std_mps: float, time_constant_s: float, seed: int) -> None:
        if not (math.isfinite(std_mps) and std_mps >= 0.0):
            raise ValueError(f"std_mps must be >= 0, got {std_mps!r}")
        if not (math.isfinite(time_constant_s) and time_constant_s > 0.0):
            raise ValueError(f"time_constant_s must be > 0, got {time_constant_s!r}")
        self.std_mps = float(std_mps)
        self.time_constant_s = float(time_constant_s)
        self.grid_step_s = self.time_constant_s / _GRID_STEPS_PER_TIME_CONSTANT
        self._decay = math.exp(-self.grid_step_s / self.time_constant_s)
        self._innovation = self.std_mps * math.sqrt(1.0 - self._decay * self._decay)
        self._rng = np.random.default_rng(np.random.SeedSequence([seed, 1]))
        self._nodes = np.array([self.std_mps * self._rng.standard_normal()])

    def _extend(self, n_nodes: int) -> None:
        """Draw nodes until there are at least ``n_nodes``."""
        while self._nodes.size < n_nodes:
            xi = self._rng.standard_normal(_CHUNK)
            new = np.empty(_CHUNK)
            g = float(self._nodes[-1])
            for k in range(_CHUNK):
                g = self._decay * g + self._innovation * float(xi[k])
                new[k] = g
            self._nodes = np.concatenate([self._nodes, new])

    def nodes(self, n_nodes: int) -> np.ndarray:
        """Return the first ``n_nodes`` grid values g(k Δ) [m/s] (a read-only view)."""
        self._extend(n_nodes)
        view = self._nodes[:n_nodes]
        view.flags.writeable = False
        return view

    def value(self, time_s: float) -> float:
        """Return g(``time_s``) [m/s], ``time_s`` >= 0 (negative times give g(0))."""
        if self.std_mps == 0.0:
            return 0.0
        position = max(time_s, 0.0) / self.grid_step_s
        k = int(position)
        self._extend(k + 2)
        a = position - k
        return float((1.0 - a) * self._nodes[k] + a * self._nodes[k + 1])

    def values(self, time_s: np.ndarray) -> np.ndarray:
        """Return g at each of ``time_s`` [m/s] (:meth:`value`, vectorised)."""
        times = np.maximum(np.asarray(time_s, dtype=float), 0.0)
        if self.std_mps == 0.0:
            return np.zeros_like(times)
        position = times / self.grid_step_s
        k = position.astype(np.int64)
        self._extend(int(k.max(initial=0)) + 2)
        a = position - k
        return (1.0 - a) * self._nodes[k] + a * self._nodes[k + 1]
