"""The records of the output-error refinement: its settings, fits, virtual turns, result.

Frozen dataclasses only; the numerics that fill them live beside them in
``identifier.output_error`` (``objective``, ``initial_state``, ``guards``,
``covariance``, composed by ``refine``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from fmu_model import ModelParameters
from trials.metrics import TURN_BACK_TOLERANCE_RAD


@dataclass(frozen=True)
class RefineSettings:
    """Tuning of the output-error refinement.

    Parameters
    ----------
    position_weight : float
        w_p, multiplies the position residuals (x, y) / σ_p.
    heading_weight : float
        w_ψ, multiplies the heading residuals ψ / σ_ψ.
    velocity_weight : float
        w_v, multiplies the residuals against the smoothed u, v, r (0: not used).
    prior_weight : float
        w_prior of the Tikhonov prior at the start estimate (0: no prior).
    max_nfev : int
        Largest number of objective evaluations of ``least_squares``.
    ftol : float
        Relative cost reduction below which ``least_squares`` stops.
    max_step_s : float, optional
        Largest RK4 step of the replay [s]; default 0.05 L / U0 (the ship's time scale
        L / U0 is 40 s for a 320 m ship at 8 m/s, so one step per 1 Hz sample).
    inputs : {"linear", "hold"}
        Rudder and propeller speed between log samples: interpolated (default; a log
        samples a continuously moving rudder) or held as by ``fmu_model.simulate``.
    turn_tolerance : float
        Largest relative change of the virtual turns' tactical diameter accepted
        when the training logs contain no turn. 0, the default: without a turning log
        output error is a check on turns, not an estimate of them, and the start is kept
        whenever the refinement moves its turn (model_structures.md §6 suggests ~5 %;
        a threshold lets a beam wind or a noise draw flip the estimate kept,
        benchmarks/environment.md, "The turn check without a tolerance").
    disagreement_tolerance : float
        Largest relative spread of the candidate starts' virtual tactical diameters
        that the fit does not warn about.
    check_turns : bool, optional
        Apply that check: None decides from the data (no log turns through 180°).
    rudder_rate_radps : float, optional
        Steering-gear rate of the virtual turns [rad/s]; default from the logs.
    turn_duration_factor : float
        Length of the virtual turns in units of L / U0.
    preferred_start : str, optional
        The candidate estimate the refinement starts from whenever its replay of the
        training logs does not diverge: the equation-error estimate, fitted on samples
        decimated to about L/U/40, predicts held-out manoeuvres better
        (benchmarks/fidelity.md, "The start of the refinement: the equation-error
        estimate"; chosen when the EKF's estimate still drifted with the logging rate,
        before its process noise was set per second). None, or a name not among the
        candidates: whichever candidate replays the logs best.
    verbose : int
        ``least_squares`` verbosity (0 silent).

    """

    position_weight: float = 1.0
    heading_weight: float = 1.0
    velocity_weight: float = 0.0
    prior_weight: float = 1.0
    max_nfev: int = 100
    ftol: float = 1e-6
    max_step_s: float | None = None
    inputs: str = "linear"
    turn_tolerance: float = 0.0
    disagreement_tolerance: float = 0.05
    check_turns: bool | None = None
    rudder_rate_radps: float | None = None
    turn_duration_factor: float = 60.0
    preferred_start: str | None = "equation-error"
    verbose: int = 0

    def with_step(self, length_m: float, speed_mps: float) -> RefineSettings:
        """Return the settings with ``max_step_s`` resolved.

        Parameters
        ----------
        length_m : float
            Ship length L [m].
        speed_mps : float
            Approach speed U0 [m/s] (at least 1 mm/s is used).

        Returns
        -------
        RefineSettings
            These settings when ``max_step_s`` is given, else with 0.05 L / U0 [s].

        """
        if self.max_step_s is not None:
            return self
        return replace(self, max_step_s=0.05 * length_m / max(speed_mps, 1e-3))


@dataclass(frozen=True)
class VirtualTurn:
    """A simulated hard-over turn from the training approach state.

    Attributes
    ----------
    rudder_rad : float
        Rudder angle, + starboard [rad].
    advance_m, transfer_m, tactical_diameter_m : float or None
        ITTC turning indices [m]; None when the heading change does not reach 90°/180°.
    heading_change_rad : float
        Largest heading change reached towards the turn [rad].
    bounded : bool
        The run stayed finite with its speed below five times the approach speed.
    passed_360 : bool
        The heading changed by at least 360°.
    turned_back_rad : float
        How far the heading fell back against the rudder (``trials.metrics.
        turned_back_rad``) [rad].
    lost_headway : bool
        The forward speed u fell to zero or below: the ship under its ahead propeller
        stopped or went astern in the turn, which no ship does (the speed a hard turn
        costs is a surge equation extrapolated far below the logs' speeds).

    """

    rudder_rad: float
    advance_m: float | None
    transfer_m: float | None
    tactical_diameter_m: float | None
    heading_change_rad: float
    bounded: bool
    passed_360: bool
    turned_back_rad: float = 0.0
    lost_headway: bool = False

    @property
    def sane(self) -> bool:
        """Bounded, through 360° (model_structures.md §7), never turning back nor astern."""
        return (
            self.bounded
            and self.passed_360
            and self.turned_back_rad <= TURN_BACK_TOLERANCE_RAD
            and not self.lost_headway
        )


SANITY_FAILURE = (
    "a virtual hard-over turn diverges, turns back, loses its headway or does not pass 360 deg"
)
"""What an estimate that fails the sanity guard (:attr:`VirtualTurn.sane`) does, for messages."""


@dataclass(frozen=True)
class FitSummary:
    """How well one coefficient set replays the training logs.

    Attributes
    ----------
    params : ModelParameters
        The coefficients (and covariance) judged.
    cost : float
        The refinement objective J(θ) (``identifier.output_error.objective``); inf when
        a replay diverged.
    residual_rms : float
        RMS of the weighted data residuals (dimensionless, 1 = logger noise).
    position_rms_L : float
        RMS position error of the replays over all samples from execute on [ship
        lengths].
    heading_rms_deg : float
        RMS heading error of the replays [deg].
    log_position_rms_L : tuple of float
        The RMS position error per log, from execute to the end [ship lengths].
    initial_states : tuple of numpy.ndarray
        The state (u, v, r, x, y, ψ) each replay starts from (at the log's execute
        sample), SI units.
    diverged : tuple of str
        Names of the logs whose replay diverged.
    turns : tuple of VirtualTurn
        Virtual hard-over turns to starboard and to port.
    zigzags_complete : bool
        Whether virtual 20°/20° zig-zags to both sides reach their second overshoot
        (``identifier.output_error.guards.virtual_zigzags``).

    """

    params: ModelParameters
    cost: float
    residual_rms: float
    position_rms_L: float
    heading_rms_deg: float
    log_position_rms_L: tuple[float, ...]
    initial_states: tuple[np.ndarray, ...]
    diverged: tuple[str, ...]
    turns: tuple[VirtualTurn, VirtualTurn]
    zigzags_complete: bool

    @property
    def sane(self) -> bool:
        """Every log replays and both turns are sane (:attr:`VirtualTurn.sane`)."""
        return not self.diverged and all(t.sane for t in self.turns)


@dataclass(frozen=True)
class RefinementResult:
    """Output of :func:`identifier.output_error.refine_output_error`.

    Attributes
    ----------
    params : ModelParameters
        The estimate kept (refined or initial), with the refinement summary in
        ``identification["refinement"]`` once :meth:`recorded`.
    initial_method : str
        Which candidate start replayed the training logs best: "ekf" or, when offered,
        "equation-error".
    kept : {"refined", "initial"}
        Which estimate ``params`` is.
    reason : str
        Why.
    initial, refined : FitSummary
        The start estimate and the output-error optimum (kept or not).
    turn_check : bool
        Whether the virtual-turn check of §6 applied (no turning log in training).
    turn_spread : float
        Largest relative change of the virtual tactical diameter, refined vs initial
        (inf when one of them does not turn through 180°).
    nfev : int
        Objective evaluations of the optimiser.
    status : str
        The optimiser's message.
    warnings : tuple of str
        Human-readable problems (guards that fired, diverging replays).
    settings : RefineSettings
        The settings used.

    """

    params: ModelParameters
    initial_method: str
    kept: str
    reason: str
    initial: FitSummary
    refined: FitSummary
    turn_check: bool
    turn_spread: float
    nfev: int
    status: str
    warnings: tuple[str, ...]
    settings: RefineSettings

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary for ``params.json`` ``identification["refinement"]``."""

        def fit(s: FitSummary) -> dict[str, Any]:
            return {
                "cost": _finite_or_none(s.cost),
                "residual_rms": _finite_or_none(s.residual_rms),
                "position_rms_L": _finite_or_none(s.position_rms_L),
                "heading_rms_deg": _finite_or_none(s.heading_rms_deg),
                "diverged": list(s.diverged),
                "virtual_tactical_diameter_m": [
                    _finite_or_none(t.tactical_diameter_m) for t in s.turns
                ],
                "virtual_zigzags_complete": s.zigzags_complete,
            }

        return {
            "method": (
                "output error: RK4 replay of every log from its execute state (the start "
                "model fitted to the approach), scipy.optimize.least_squares (trf), "
                "Tikhonov prior at the start estimate"
            ),
            "initial_method": self.initial_method,
            "kept": self.kept,
            "reason": self.reason,
            "cost_before": _finite_or_none(self.initial.cost),
            "cost_after": _finite_or_none(self.refined.cost),
            "initial": fit(self.initial),
            "refined": fit(self.refined),
            "refined_coefficients": self.refined.params.as_dict(),
            "turn_check": self.turn_check,
            "turn_spread": _finite_or_none(self.turn_spread),
            "nfev": self.nfev,
            "status": self.status,
            "settings": asdict(self.settings),
        }

    def recorded(self) -> RefinementResult:
        """Return the result with :meth:`summary` in ``params.identification``.

        The kept estimate's provenance gains the key ``"refinement"``; everything else
        in ``params.identification`` stays as it was.
        """
        identification: Mapping[str, Any] = {
            **dict(self.params.identification),
            "refinement": self.summary(),
        }
        return replace(self, params=replace(self.params, identification=identification))


def _finite_or_none(value: float | None) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None
