"""Output-error refinement: fit the coefficients to whole simulated manoeuvres.

The EKF (``identifier.ekf``) fits the coefficients one sample ahead. Output error asks
more of them: replayed open loop with the logged rudder and propeller speed from each
log's execute point on, the model must reproduce the whole track. With θ the
coefficients, ŝ_k(θ) the simulated state at the log's sample k and (x_k, y_k, ψ_k) the
logged track, the objective is

    J(θ) = ½ Σ_logs Σ_k>k_e [ w_p² ((x̂_k − x_k)² + (ŷ_k − y_k)²) / σ_p²
                            + w_ψ² (ψ̂_k − ψ_k)² / σ_ψ²
                            + w_v² Σ_{u,v,r} (ŝ_k − s̃_k)² / σ_s² ]
           + ½ w_prior (θ − θ₀)ᵀ Σ₀⁻¹ (θ − θ₀),

with σ_p, σ_ψ the logger noise estimated by the smoother, s̃ the smoothed velocities
(optional, ``velocity_weight``), k_e the execute sample and the last term a Tikhonov
prior at the start estimate θ₀ weighted by its covariance Σ₀. The start is the EKF
estimate or, when it replays the training logs worse (larger J(θ₀)), the
equation-error estimate. J is minimised with ``scipy.optimize.least_squares``
(trust-region reflective, lsmr sub-problems) in whitened coordinates z,
θ = θ₀ + C z with C Cᵀ = Σ₀, so that the prior is ½ w_prior |z|² and a unit step in
z is one prior standard deviation.

Initial states. The first smoothed state of a log is poor (the smoother sees one side
only: 0.1–0.2 m/s on u and v at 1 Hz, 1 m noise), and a replay from it drifts by
several metres where the true model, from the true state, stays within the noise.
So each log's state at execute is the start model's, fitted to the approach alone and
replayed to execute (:func:`execute_state`), and is then held: fitted over the whole
log it would absorb model error, and a replay that included the approach would let a
course-unstable model tune itself to a tiny initial error.

Simulation. Classical RK4, each sample interval split into equal steps no longer than
``max_step_s`` (as ``fmu_model.simulate``), with the inputs interpolated linearly
between the samples (``inputs="linear"``, default: a 1 Hz log of a rudder moving at
2–5°/s is a ramp, and holding it lags the truth by half a sample: the true seed ship
replays its 10/10 zig-zag to 0.1° heading RMS with it, 0.45° without) or held
(``"hold"``: bit-for-bit ``fmu_model.simulate(method="rk4")``). It runs in numba on
the regressor kernels generated from the model structure (``NumericModel.kernels``),
batched over coefficient vectors; the Jacobian is a batched forward difference in z.
The covariance of the refined coefficients is the Newey–West sandwich at the optimum
(:func:`_sandwich_covariance`): the residuals of a replayed track are strongly
correlated in time, and s² (JᵀJ)⁻¹ would be optimistic by about their correlation time.

Guards (reference/model_structures.md, §6 and §7): output error on zig-zags alone is
unreliable for turns. After refining, hard-over (35°) turns both ways are simulated
from the training approach state with the start and the refined coefficients. When no
training log turns through 180° and the refined tactical diameter differs from the
start's by more than ``turn_tolerance``, the start estimate is kept and the spread
reported (unless the start does not even turn through 180°). Independently, a refined
estimate is only kept when it lowers the cost, every training log replays without
divergence and both virtual turns stay bounded and pass 360°.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, replace
from functools import partial
from typing import Any

import numba
import numpy as np
from scipy.optimize import least_squares
from statsmodels.stats.sandwich_covariance import S_hac_simple

from fmu_model import ModelParameters, numeric_model
from identifier.errors import IdentificationError
from identifier.logs import ManeuverLog
from identifier.smoothing import SmoothedTrack, smooth_track

# Hard-over rudder of the virtual turns [rad] (IMO MSC.137(76) turning test).
HARD_OVER_RAD = math.radians(35.0)
# A logged rudder slower than this never moved [rad/s].
_RUDDER_STILL_RADPS = math.radians(0.01)
# Rudder movement that marks the execute point [rad].
_EXECUTE_RUDDER_RAD = math.radians(0.5)
# ... and a rudder change between two samples that counts as moving [rad].
_RUDDER_STEP_RAD = math.radians(0.01)
# Steering-gear rate used when the logs never move the rudder [rad/s] (IMO minimum).
_DEFAULT_RUDDER_RATE_RADPS = math.radians(2.32)
# A replay whose speed exceeds this multiple of the logged maximum has diverged.
_DIVERGENCE_SPEED_FACTOR = 5.0
# How the inputs behave between log samples (see ``replay``).
INPUT_MODES = ("linear", "hold")
# Relative forward-difference step in whitened coordinates (EKF standard deviations).
_FD_STEP = 1e-4
# Smallest eigenvalue kept in the prior covariance, relative to the largest.
_EIGEN_FLOOR = 1e-14


# --------------------------------------------------------------------------------------
# Settings and results
# --------------------------------------------------------------------------------------


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
        when the training logs contain no turn (model_structures.md §6).
    check_turns : bool, optional
        Apply that check: None decides from the data (no log turns through 180°).
    rudder_rate_radps : float, optional
        Steering-gear rate of the virtual turns [rad/s]; default from the logs.
    turn_duration_factor : float
        Length of the virtual turns in units of L / U0.
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
    turn_tolerance: float = 0.05
    check_turns: bool | None = None
    rudder_rate_radps: float | None = None
    turn_duration_factor: float = 60.0
    verbose: int = 0


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

    """

    rudder_rad: float
    advance_m: float | None
    transfer_m: float | None
    tactical_diameter_m: float | None
    heading_change_rad: float
    bounded: bool
    passed_360: bool

    @property
    def sane(self) -> bool:
        """Bounded and through 360° (model_structures.md §7)."""
        return self.bounded and self.passed_360


@dataclass(frozen=True)
class FitSummary:
    """How well one coefficient set replays the training logs.

    Attributes
    ----------
    params : ModelParameters
        The coefficients (and covariance) judged.
    cost : float
        The refinement objective J(θ) (module docstring); inf when a replay diverged.
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

    @property
    def sane(self) -> bool:
        """Every log replays and both turns are bounded and pass 360° (§7)."""
        return not self.diverged and all(t.sane for t in self.turns)


@dataclass(frozen=True)
class RefinementResult:
    """Output of :func:`refine_output_error`.

    Attributes
    ----------
    params : ModelParameters
        The estimate kept (refined or initial), with the refinement summary in
        ``identification["refinement"]``.
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


def _finite_or_none(value: float | None) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


# --------------------------------------------------------------------------------------
# Replay: RK4 of the model over logged inputs, batched over coefficient vectors
# --------------------------------------------------------------------------------------


@numba.njit(cache=False)
def _derivative(phi_fn, kin_fn, eq_index, theta, length, s, rudder, n_rps, phi, kin, out):
    """ṡ = (M (θ ⊙ φ(s, δ, n)), kinematics) into ``out`` (6,)."""
    phi_fn(s[0], s[1], s[2], rudder, n_rps, length, phi)
    kin_fn(s[0], s[1], s[2], s[5], kin)
    out[0] = 0.0
    out[1] = 0.0
    out[2] = 0.0
    for i in range(theta.size):
        out[eq_index[i]] += theta[i] * phi[i]
    out[3] = kin[0]
    out[4] = kin[1]
    out[5] = kin[2]


@numba.njit(cache=False)
def _replay_batch(
    phi_fn, kin_fn, eq_index, length, max_step, linear, t, rudder, n_rps, x0s, thetas,
    speed_limit, out,
):  # fmt: skip
    """RK4 replay from every row of ``x0s`` (B, 6) with ``thetas`` (B, p) into ``out`` (B, N, 6).

    Inputs are held over each interval (zero-order hold) or, with ``linear``,
    interpolated linearly between the samples at every RK4 stage. Each interval has
    ceil(T / max_step) equal substeps (``fmu_model.simulate.n_substeps``). A run that
    turns non-finite or faster than ``speed_limit`` is NaN from there on.
    """
    n_batch, p = thetas.shape
    phi = np.empty(p)
    kin = np.empty(3)
    s = np.empty(6)
    w = np.empty(6)
    k1 = np.empty(6)
    k2 = np.empty(6)
    k3 = np.empty(6)
    k4 = np.empty(6)
    for b in range(n_batch):
        theta = thetas[b]
        for c in range(6):
            s[c] = x0s[b, c]
            out[b, 0, c] = x0s[b, c]
        alive = True
        for k in range(t.size - 1):
            if not alive:
                for c in range(6):
                    out[b, k + 1, c] = np.nan
                continue
            T = t[k + 1] - t[k]
            m = 1
            if T > max_step:
                m = max(1, int(np.ceil(T / max_step * (1.0 - 1e-12))))
            h = T / m
            d0 = rudder[k]
            n0 = n_rps[k]
            dd = 0.0
            dn = 0.0
            if linear:
                dd = (rudder[k + 1] - d0) / m
                dn = (n_rps[k + 1] - n0) / m
            for j in range(m):
                # Inputs at the stage times: fraction 0, ½, ½, 1 of the substep.
                da, db, dc = d0 + j * dd, d0 + (j + 0.5) * dd, d0 + (j + 1.0) * dd
                na, nb, nc = n0 + j * dn, n0 + (j + 0.5) * dn, n0 + (j + 1.0) * dn
                _derivative(phi_fn, kin_fn, eq_index, theta, length, s, da, na, phi, kin, k1)
                for c in range(6):
                    w[c] = s[c] + 0.5 * h * k1[c]
                _derivative(phi_fn, kin_fn, eq_index, theta, length, w, db, nb, phi, kin, k2)
                for c in range(6):
                    w[c] = s[c] + 0.5 * h * k2[c]
                _derivative(phi_fn, kin_fn, eq_index, theta, length, w, db, nb, phi, kin, k3)
                for c in range(6):
                    w[c] = s[c] + h * k3[c]
                _derivative(phi_fn, kin_fn, eq_index, theta, length, w, dc, nc, phi, kin, k4)
                for c in range(6):
                    s[c] += (h / 6.0) * (k1[c] + 2.0 * k2[c] + 2.0 * k3[c] + k4[c])
            finite = True
            for c in range(6):
                if not np.isfinite(s[c]):
                    finite = False
            if not finite or np.sqrt(s[0] * s[0] + s[1] * s[1]) > speed_limit:
                alive = False
                for c in range(6):
                    out[b, k + 1, c] = np.nan
            else:
                for c in range(6):
                    out[b, k + 1, c] = s[c]


def replay(
    model: str,
    thetas: np.ndarray,
    length_m: float,
    time_s: np.ndarray,
    rudder_rad: np.ndarray,
    n_rps: np.ndarray,
    initial_state: np.ndarray,
    *,
    inputs: str = "linear",
    max_step_s: float | None = None,
    speed_limit_mps: float = math.inf,
) -> np.ndarray:
    """Simulate a batch of coefficient vectors over given inputs with RK4.

    With ``inputs="hold"`` this is exactly ``fmu_model.simulate(method="rk4")`` (each
    input held over its interval, as an FMU between communication points); with
    ``"linear"`` the inputs are interpolated linearly between the samples at every RK4
    stage, which is what a log of a continuously moving rudder means. Compiled with
    numba and batched over coefficient vectors.

    Parameters
    ----------
    model : str
        Registered model structure.
    thetas : numpy.ndarray
        Coefficient vectors, shape (p,) or (B, p).
    length_m : float
        Ship length [m].
    time_s : numpy.ndarray
        Strictly increasing sample times [s], shape (N,).
    rudder_rad : numpy.ndarray
        Rudder angle at the sample times [rad], shape (N,).
    n_rps : numpy.ndarray
        Propeller speed at the sample times [rev/s], shape (N,).
    initial_state : numpy.ndarray
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]) at ``time_s[0]``, shape
        (6,) or (B, 6).
    inputs : {"linear", "hold"}
        Inputs between the samples.
    max_step_s : float, optional
        Largest RK4 step [s]; one step per sample interval when None.
    speed_limit_mps : float
        A run faster than this [m/s] (or non-finite) has diverged: NaN from there on.

    Returns
    -------
    numpy.ndarray
        States (u, v, r, x, y, ψ), shape (N, 6) for one θ or (B, N, 6).

    """
    if inputs not in INPUT_MODES:
        raise ValueError(f"inputs must be one of {INPUT_MODES}, got {inputs!r}")
    numeric = numeric_model(model)
    phi_fn, _, kin_fn, _ = numeric.kernels
    theta_arr = np.asarray(thetas, dtype=float)
    # Fresh writable C arrays: one numba signature whatever the callers pass.
    x0_arr = np.asarray(initial_state, dtype=float)
    n_batch = max(np.atleast_2d(theta_arr).shape[0], np.atleast_2d(x0_arr).shape[0])
    batch = np.array(np.broadcast_to(theta_arr, (n_batch, theta_arr.shape[-1])), order="C")
    x0s = np.array(np.broadcast_to(x0_arr, (n_batch, 6)), order="C")
    t = np.array(time_s, dtype=float, order="C")
    out = np.empty((batch.shape[0], t.size, 6))
    _replay_batch(
        phi_fn,
        kin_fn,
        np.array(numeric.structure.equation_index, dtype=np.int64),
        float(length_m),
        math.inf if max_step_s is None else float(max_step_s),
        inputs == "linear",
        t,
        np.array(rudder_rad, dtype=float, order="C"),
        np.array(n_rps, dtype=float, order="C"),
        x0s,
        batch,
        float(speed_limit_mps),
        out,
    )
    return out[0] if theta_arr.ndim == 1 and x0_arr.ndim == 1 else out


def smooth_log(log: ManeuverLog) -> SmoothedTrack:
    """Smooth a log's track with noise levels estimated from it (as ``identify`` does)."""
    return smooth_track(log.time_s, log.x_m, log.y_m, log.heading_rad)


# --------------------------------------------------------------------------------------
# Virtual hard-over turns (the guards)
# --------------------------------------------------------------------------------------


def virtual_turns(
    params: ModelParameters,
    *,
    speed_mps: float,
    n_rps: float,
    rudder_rate_radps: float = _DEFAULT_RUDDER_RATE_RADPS,
    rudder_rad: float = HARD_OVER_RAD,
    duration_factor: float = 60.0,
    step_s: float = 1.0,
    max_step_s: float | None = None,
) -> tuple[VirtualTurn, VirtualTurn]:
    """Simulate hard-over turns to starboard and to port from a straight approach.

    The ship starts at (u, v, r) = (``speed_mps``, 0, 0) with the rudder amidships,
    the rudder moves at ``rudder_rate_radps`` to ±``rudder_rad`` and stays there for
    ``duration_factor`` · L / U0 seconds at constant ``n_rps``.

    Parameters
    ----------
    params : ModelParameters
        The model.
    speed_mps : float
        Approach speed [m/s].
    n_rps : float
        Propeller speed [rev/s].
    rudder_rate_radps : float
        Steering-gear rate [rad/s].
    rudder_rad : float
        Hard-over rudder angle [rad].
    duration_factor : float
        Run length in units of L / U0.
    step_s : float
        Output sampling [s].
    max_step_s : float, optional
        Largest RK4 step [s]; default 0.05 L / U0.

    Returns
    -------
    tuple of VirtualTurn
        Starboard, port.

    """
    from scenarios.metrics import MetricsError, turning_metrics
    from scenarios.trajectory import empty_trajectory

    if not (speed_mps > 0.0 and rudder_rate_radps > 0.0):
        raise ValueError("speed_mps and rudder_rate_radps must be positive")
    duration = duration_factor * params.length_m / speed_mps
    if max_step_s is None:
        max_step_s = 0.05 * params.length_m / speed_mps
    t = np.arange(0.0, duration + step_s, step_s)
    turns = []
    for sign in (1.0, -1.0):
        rudder = sign * np.minimum(rudder_rad, rudder_rate_radps * t)
        states = replay(
            params.model,
            params.to_vector(),
            params.length_m,
            t,
            rudder,
            np.full(t.size, n_rps),
            np.array([speed_mps, 0.0, 0.0, 0.0, 0.0, 0.0]),
            inputs="linear",
            max_step_s=max_step_s,
            speed_limit_mps=_DIVERGENCE_SPEED_FACTOR * speed_mps,
        )
        finite = np.all(np.isfinite(states), axis=1)
        bounded = bool(np.all(finite))
        good = states[: int(np.argmin(finite)) if not bounded else t.size]
        turned = sign * (good[:, 5] - good[0, 5])
        change = float(np.max(turned)) if good.size else 0.0
        traj = empty_trajectory(good.shape[0])
        traj["time_s"] = t[: good.shape[0]]
        traj["u_mps"], traj["v_mps"], traj["r_radps"] = good[:, 0], good[:, 1], good[:, 2]
        traj["x_m"], traj["y_m"], traj["psi_rad"] = good[:, 3], good[:, 4], good[:, 5]
        advance = transfer = tactical = None
        if change >= math.pi:
            try:
                metrics = turning_metrics(traj)
            except MetricsError:
                pass
            else:
                advance = metrics.advance_m
                transfer = metrics.transfer_m
                tactical = metrics.tactical_diameter_m
        turns.append(
            VirtualTurn(
                rudder_rad=sign * rudder_rad,
                advance_m=advance,
                transfer_m=transfer,
                tactical_diameter_m=tactical,
                heading_change_rad=change,
                bounded=bounded,
                passed_360=change >= 2.0 * math.pi,
            )
        )
    return turns[0], turns[1]


def turn_spread(reference: Sequence[VirtualTurn], candidate: Sequence[VirtualTurn]) -> float:
    """Largest relative change of the tactical diameter, candidate vs reference turns.

    inf when a turn of either set does not reach 180° of heading change.
    """
    spread = 0.0
    for ref, cand in zip(reference, candidate, strict=True):
        if ref.tactical_diameter_m is None or cand.tactical_diameter_m is None:
            return math.inf
        spread = max(spread, abs(cand.tactical_diameter_m / ref.tactical_diameter_m - 1.0))
    return spread


# --------------------------------------------------------------------------------------
# The objective
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Data:
    """One log prepared for the replay residuals."""

    name: str
    time_s: np.ndarray
    rudder_rad: np.ndarray
    n_rps: np.ndarray
    x0: np.ndarray  # first smoothed state (6,)
    x0_std: np.ndarray  # its standard deviations (6,), the scale of its prior
    target: np.ndarray  # (N - 1, k) observed quantities after the first sample
    scale: np.ndarray  # (k,) weight / σ of each quantity
    speed_limit_mps: float

    def head(self, end: int) -> _Data:
        """Return the log's first ``end`` samples."""
        return replace(
            self,
            time_s=self.time_s[:end],
            rudder_rad=self.rudder_rad[:end],
            n_rps=self.n_rps[:end],
            target=self.target[: end - 1],
        )


def _prepare(
    log: ManeuverLog,
    track: SmoothedTrack,
    name: str,
    settings: RefineSettings,
    start: int = 0,
) -> _Data:
    """Residual data of a log from sample ``start`` on (initial state: smoothed there)."""
    k = start
    columns = [log.x_m[k + 1 :], log.y_m[k + 1 :], log.heading_rad[k + 1 :]]
    sigma_p = max(track.position_noise_m, 1e-3)
    sigma_h = max(track.heading_noise_rad, 1e-5)
    scale = [
        settings.position_weight / sigma_p,
        settings.position_weight / sigma_p,
        settings.heading_weight / sigma_h,
    ]
    if settings.velocity_weight > 0.0:
        for values, std in (
            (track.u_mps, track.u_std_mps),
            (track.v_mps, track.v_std_mps),
            (track.r_radps, track.r_std_radps),
        ):
            columns.append(values[k + 1 :])
            scale.append(settings.velocity_weight / max(float(np.median(std)), 1e-9))
    x0_std = np.array(
        [
            track.u_std_mps[k],
            track.v_std_mps[k],
            track.r_std_radps[k],
            track.x_std_m[k],
            track.y_std_m[k],
            track.heading_std_rad[k],
        ]
    )
    floor = np.array([1e-3, 1e-3, 1e-5, 1e-2, 1e-2, 1e-5])
    speed = float(np.max(np.hypot(track.u_mps, track.v_mps)))
    return _Data(
        name=name,
        time_s=np.array(log.time_s[k:]),
        rudder_rad=np.array(log.rudder_rad[k:]),
        n_rps=np.array(log.n_rps[k:]),
        x0=np.array(
            [
                track.u_mps[k],
                track.v_mps[k],
                track.r_radps[k],
                track.x_m[k],
                track.y_m[k],
                track.heading_rad[k],
            ]
        ),
        x0_std=np.maximum(np.nan_to_num(x0_std, nan=1.0), floor),
        target=np.column_stack(columns),
        scale=np.asarray(scale),
        speed_limit_mps=_DIVERGENCE_SPEED_FACTOR * max(speed, 0.1),
    )


def _log_residuals(
    model: str,
    thetas: np.ndarray,
    x0s: np.ndarray,
    length_m: float,
    d: _Data,
    settings: RefineSettings,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted residuals (B, m) of a log for every (θ, x0) row, and the states (B, N, 6)."""
    sim = replay(
        model,
        np.atleast_2d(thetas),
        length_m,
        d.time_s,
        d.rudder_rad,
        d.n_rps,
        np.atleast_2d(x0s),
        inputs=settings.inputs,
        max_step_s=settings.max_step_s,
        speed_limit_mps=d.speed_limit_mps,
    )
    observed = [sim[:, 1:, 3], sim[:, 1:, 4], sim[:, 1:, 5]]
    if d.target.shape[1] > 3:
        observed += [sim[:, 1:, 0], sim[:, 1:, 1], sim[:, 1:, 2]]
    res = (np.stack(observed, axis=-1) - d.target) * d.scale
    return res.reshape(res.shape[0], -1), sim


def _forward_difference(
    base: np.ndarray, perturbed: np.ndarray, backward: Callable[[np.ndarray], np.ndarray]
) -> np.ndarray:
    """Columns (k, m) of forward differences; those not finite are taken backwards."""
    columns = (perturbed - base) / _FD_STEP
    bad = np.flatnonzero(~np.all(np.isfinite(columns), axis=1))
    if bad.size:
        columns[bad] = (base - backward(bad)) / _FD_STEP
    return np.nan_to_num(columns, nan=0.0, posinf=0.0, neginf=0.0)


@dataclass(frozen=True)
class _Objective:
    """The least-squares problem in whitened coordinates.

    z = (z_θ, z_x0 of log 1, z_x0 of log 2, …): θ = θ₀ + C z_θ and
    x0_i = x̂0_i + diag(σ̂0_i) z_x0_i, with x̂0 the log's initial state and σ̂0 the
    smoothed state's standard deviation; either part may be held (``free_theta``,
    ``free_x0``). Residuals: the weighted replay errors, √w_prior z_θ, and z_x0 (x̂0 as
    a measurement of the initial state).
    """

    model: str
    length_m: float
    data: tuple[_Data, ...]
    settings: RefineSettings
    theta0: np.ndarray
    whiten: np.ndarray
    free_theta: bool = True
    free_x0: bool = False

    @property
    def p(self) -> int:
        """Number of coefficients."""
        return self.theta0.size

    @property
    def n_theta(self) -> int:
        """Free coefficient coordinates (0 when θ is held)."""
        return self.p if self.free_theta else 0

    @property
    def size(self) -> int:
        """Length of z."""
        return self.n_theta + self.n_x0 * len(self.data)

    @property
    def n_x0(self) -> int:
        """Free initial-state coordinates per log (0 when held)."""
        return 6 if self.free_x0 else 0

    def theta(self, z: np.ndarray) -> np.ndarray:
        """Return the coefficients of z."""
        return self.theta0 + self.whiten @ z[: self.p] if self.free_theta else self.theta0

    def initial_states(self, z: np.ndarray) -> list[np.ndarray]:
        """Return the initial state of every log for z."""
        if not self.free_x0:
            return [d.x0 for d in self.data]
        o = self.n_theta
        return [d.x0 + d.x0_std * z[o + 6 * i : o + 6 * i + 6] for i, d in enumerate(self.data)]

    def _prior(self, z: np.ndarray) -> np.ndarray:
        w = math.sqrt(max(self.settings.prior_weight, 0.0))
        return np.concatenate([w * z[: self.n_theta], z[self.n_theta :]])

    def replays(self, z: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """Return the data residuals (m,) and the states (N, 6) of every log."""
        theta = self.theta(z)
        blocks, states = [], []
        for d, x0 in zip(self.data, self.initial_states(z), strict=True):
            res, sim = _log_residuals(self.model, theta, x0, self.length_m, d, self.settings)
            blocks.append(res[0])
            states.append(sim[0])
        return np.concatenate(blocks), states

    def residuals(self, z: np.ndarray) -> np.ndarray:
        """All residuals: data, then prior."""
        return np.concatenate([self.replays(z)[0], self._prior(z)])

    def cost(self, z: np.ndarray) -> float:
        """½ Σ r², inf when a replay diverged."""
        value = 0.5 * float(np.sum(np.square(self.residuals(z))))
        return value if math.isfinite(value) else math.inf

    def jacobian(self, z: np.ndarray) -> np.ndarray:
        """Forward-difference Jacobian, each log's columns in one batched replay."""
        theta = self.theta(z)
        x0s = self.initial_states(z)
        nt, nx = self.n_theta, self.n_x0
        blocks = []
        for i, (d, x0) in enumerate(zip(self.data, x0s, strict=True)):
            # Rows: base, the n_theta coefficient steps, the n_x0 initial-state steps.
            thetas = np.repeat(theta[None, :], 1 + nt + nx, axis=0)
            starts = np.repeat(x0[None, :], 1 + nt + nx, axis=0)
            if nt:
                thetas[1 : 1 + nt] += _FD_STEP * self.whiten.T
            if nx:
                starts[1 + nt :] += _FD_STEP * np.diag(d.x0_std)
            res, _ = _log_residuals(self.model, thetas, starts, self.length_m, d, self.settings)
            backward = partial(self._backward, d, thetas, starts)
            columns = _forward_difference(res[0], res[1:], backward)
            block = np.zeros((res.shape[1], self.size))
            block[:, :nt] = columns[:nt].T
            block[:, nt + nx * i : nt + nx * i + nx] = columns[nt:].T
            blocks.append(block)
        w = math.sqrt(max(self.settings.prior_weight, 0.0))
        prior = np.diag(np.concatenate([np.full(nt, w), np.ones(nx * len(self.data))]))
        return np.vstack([*blocks, prior])

    def _backward(
        self, d: _Data, thetas: np.ndarray, starts: np.ndarray, bad: np.ndarray
    ) -> np.ndarray:
        """Residuals of the steps ``bad`` taken backwards (rows 1… of the batch)."""
        th = 2.0 * thetas[0] - thetas[1 + bad]
        st = 2.0 * starts[0] - starts[1 + bad]
        return _log_residuals(self.model, th, st, self.length_m, d, self.settings)[0]

    def solve(self, z0: np.ndarray, max_nfev: int) -> Any:
        """Minimise from z0 with ``scipy.optimize.least_squares``."""
        # trf with the iterative (lsmr) trust-region solver and Jacobian scaling: no
        # dense SVD of the tall Jacobian per iteration (slow with threaded BLAS on a
        # busy machine), and robust to replays that diverge at a trial point.
        return least_squares(
            self.residuals,
            z0,
            jac=self.jacobian,
            method="trf",
            tr_solver="lsmr",
            x_scale="jac",
            max_nfev=max_nfev,
            ftol=self.settings.ftol,
            verbose=self.settings.verbose,
        )


def _summarise(
    objective: _Objective,
    z: np.ndarray,
    params: ModelParameters,
    approach: tuple[float, float, float],
) -> FitSummary:
    res, states = objective.replays(z)
    cost = objective.cost(z)
    diverged = tuple(
        d.name for d, s in zip(objective.data, states, strict=True) if np.isnan(s).any()
    )
    pos_sq, head_sq, counts, per_log = 0.0, 0.0, 0, []
    for d, s in zip(objective.data, states, strict=True):
        e = s[1:, 3:6] - d.target[:, :3]
        p2 = np.square(e[:, 0]) + np.square(e[:, 1])
        pos_sq += float(np.sum(p2))
        head_sq += float(np.sum(np.square(e[:, 2])))
        counts += e.shape[0]
        per_log.append(math.sqrt(float(np.mean(p2))) / params.length_m)
    speed, n, rate = approach
    settings = objective.settings
    return FitSummary(
        params=params,
        cost=cost,
        residual_rms=math.sqrt(float(np.mean(np.square(res)))),
        position_rms_L=math.sqrt(pos_sq / counts) / params.length_m,
        heading_rms_deg=math.degrees(math.sqrt(head_sq / counts)),
        log_position_rms_L=tuple(per_log),
        initial_states=tuple(objective.initial_states(z)),
        diverged=diverged,
        turns=virtual_turns(
            params,
            speed_mps=speed,
            n_rps=n,
            rudder_rate_radps=rate,
            duration_factor=settings.turn_duration_factor,
            max_step_s=settings.max_step_s,
        ),
    )


def _whitening(params: ModelParameters) -> np.ndarray:
    """C with C Cᵀ = Σ₀ (eigenvalues floored), or a diagonal scale without Σ."""
    theta = params.to_vector()
    if params.covariance is None:
        return np.diag(np.where(theta != 0.0, 0.1 * np.abs(theta), 1e-6))
    cov = 0.5 * (params.covariance + params.covariance.T)
    values, vectors = np.linalg.eigh(cov)
    floor = _EIGEN_FLOOR * max(float(values.max()), np.finfo(float).tiny)
    return vectors * np.sqrt(np.maximum(values, floor))


def _approach(
    params: ModelParameters, logs: Sequence[ManeuverLog], tracks: Sequence[SmoothedTrack]
) -> tuple[float, float, float]:
    """Approach speed [m/s], propeller speed [rev/s] and rudder rate [rad/s] of training."""
    speed = params.nominal_speed_mps or float(np.mean([t.u_mps[0] for t in tracks]))
    n = params.nominal_n_rps or float(np.mean([log.n_rps[0] for log in logs]))
    rates = [float(np.max(np.abs(np.diff(log.rudder_rad)) / np.diff(log.time_s))) for log in logs]
    rate = max(rates)
    return speed, n, rate if rate > _RUDDER_STILL_RADPS else _DEFAULT_RUDDER_RATE_RADPS


def _with_step(settings: RefineSettings, length_m: float, speed_mps: float) -> RefineSettings:
    """Return the settings with ``max_step_s`` resolved (0.05 L / U0 when not given)."""
    if settings.max_step_s is not None:
        return settings
    return replace(settings, max_step_s=0.05 * length_m / max(speed_mps, 1e-3))


def covers_turn(tracks: Sequence[SmoothedTrack]) -> bool:
    """Whether any track turns through 180° of heading (a turning-circle log)."""
    return any(float(np.ptp(t.heading_rad)) >= math.pi for t in tracks)


def fit_initial_state(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack | None = None,
    *,
    end_index: int | None = None,
    settings: RefineSettings | None = None,
) -> np.ndarray:
    """Fit a log's initial state to its track with the coefficients held.

    The first smoothed state is poor at the log's edge (the smoother sees one side
    only); replaying the model over the first ``end_index`` samples (the approach,
    say) and fitting the six initial states to the logged track, with the smoothed
    state as a weak prior, gives the state the model needs.

    Parameters
    ----------
    params : ModelParameters
        The model (held).
    log : ManeuverLog
        The log.
    track : SmoothedTrack, optional
        Its smoothed track; smoothed here when omitted.
    end_index : int, optional
        Fit to samples ``[0, end_index)``; the whole log when omitted. Fewer than 10
        samples: the first smoothed state is returned unchanged.
    settings : RefineSettings, optional
        Weights, replay step and input mode.

    Returns
    -------
    numpy.ndarray
        (u [m/s], v [m/s], r [rad/s], x [m], y [m], ψ [rad]) at ``log.time_s[0]``.

    """
    track = track or smooth_log(log)
    speed = params.nominal_speed_mps or float(track.u_mps[0])
    settings = _with_step(settings or RefineSettings(), params.length_m, speed)
    d = _prepare(log, track, log.path or "log", settings)
    end = log.n_samples if end_index is None else min(int(end_index), log.n_samples)
    if end < 10:
        return d.x0
    objective = _Objective(
        model=params.model,
        length_m=params.length_m,
        data=(d.head(end),),
        settings=settings,
        theta0=params.to_vector(),
        whiten=np.eye(params.to_vector().size),
        free_theta=False,
        free_x0=True,
    )
    z0 = np.zeros(6)
    if not math.isfinite(objective.cost(z0)):
        return d.x0
    opt = objective.solve(z0, settings.max_nfev)
    return objective.initial_states(opt.x)[0]


def execute_index(log: ManeuverLog) -> int:
    """Index of the execute sample: the start of the first rudder command.

    From the log's ``# execute_time_s:`` when given (the last sample not after it),
    else the first sample of the rudder movement that takes it more than 0.5° from
    its first value; the last sample when it never moves.
    """
    text = log.metadata.get("execute_time_s")
    if text is not None:
        try:
            t_exec = float(text)
        except ValueError:
            t_exec = math.nan
        if math.isfinite(t_exec) and log.time_s[0] <= t_exec <= log.time_s[-1]:
            # 1 µs of slack: sample times are often sums of float steps.
            return int(np.searchsorted(log.time_s, t_exec + 1e-6, side="right")) - 1
    rudder = log.rudder_rad
    moved = np.flatnonzero(np.abs(rudder - rudder[0]) > _EXECUTE_RUDDER_RAD)
    if not moved.size:
        return log.n_samples - 1
    # Back to the first sample of that movement (the rudder already moving that way).
    k = int(moved[0])
    sign = math.copysign(1.0, rudder[k] - rudder[0])
    while k > 1 and sign * (rudder[k - 1] - rudder[k - 2]) > _RUDDER_STEP_RAD:
        k -= 1
    return k


def execute_state(
    params: ModelParameters,
    log: ManeuverLog,
    track: SmoothedTrack | None = None,
    *,
    settings: RefineSettings | None = None,
) -> tuple[int, np.ndarray]:
    """Return the execute sample of a log and the model's state there, from the approach.

    The initial state is fitted to the approach (samples up to :func:`execute_index`)
    with the coefficients held (:func:`fit_initial_state`) and replayed to the execute
    sample. Only the approach is used, so a prediction from there is honest; and a
    replay that starts at execute cannot exploit a small initial error that grows
    over the approach (a course-unstable model amplifies it). With fewer than 10
    approach samples the smoothed state at execute is used; when the rudder never
    moves the whole log is the "manoeuvre" (index 0).

    Returns
    -------
    tuple of (int, numpy.ndarray)
        The execute index k and (u, v, r, x, y, ψ) at ``log.time_s[k]``, SI units.

    """
    track = track or smooth_log(log)
    k = execute_index(log)
    if k >= log.n_samples - 10:
        k = 0
    if k < 9:
        return k, _prepare(log, track, "", settings or RefineSettings(), start=k).x0
    x0 = fit_initial_state(params, log, track, end_index=k + 1, settings=settings)
    speed = params.nominal_speed_mps or float(track.u_mps[0])
    step = (settings.max_step_s if settings else None) or 0.05 * params.length_m / speed
    states = replay(
        params.model,
        params.to_vector(),
        params.length_m,
        log.time_s[: k + 1],
        log.rudder_rad[: k + 1],
        log.n_rps[: k + 1],
        x0,
        inputs=settings.inputs if settings else "linear",
        max_step_s=step,
    )
    return k, states[-1]


def refine_output_error(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    *,
    tracks: Sequence[SmoothedTrack] | None = None,
    settings: RefineSettings | None = None,
    method: str = "ekf",
    alternatives: Mapping[str, ModelParameters] | None = None,
    **overrides: Any,
) -> RefinementResult:
    """Refine identified coefficients by output error on whole manoeuvres.

    With ``alternatives`` (e.g. the equation-error estimate beside the EKF's), the
    start is the candidate whose open-loop replay of the training logs fits best
    (smallest J at its own estimate, the prior term then being zero): only training
    data decide, and the paper's one-step-ahead EKF fit is not always the estimate
    that simulates whole manoeuvres best.

    Every log is replayed from its execute sample on, from the state there that the
    start model gives when fitted to the approach (:func:`execute_state`). That state is
    held: fitted to the whole log, it would absorb model error. The coefficients are
    fitted to the logs from execute to the end.

    Parameters
    ----------
    params : ModelParameters
        The estimate of ``method``: start point, and with its covariance the prior.
    logs : sequence of ManeuverLog
        The training logs.
    tracks : sequence of SmoothedTrack, optional
        Their smoothed tracks (initial states, noise levels); smoothed here if omitted.
    settings : RefineSettings, optional
        Tuning; the defaults when omitted.
    method : str
        How ``params`` was estimated (named in the result and its messages).
    alternatives : mapping of str to ModelParameters, optional
        Other candidate starts by method name, with their covariances (the prior).
    **overrides
        Fields of :class:`RefineSettings` to override, e.g. ``prior_weight=0.1``.

    Returns
    -------
    RefinementResult
        Both fits, the estimate kept and why.

    Raises
    ------
    IdentificationError
        No logs, or logs and tracks that do not match.

    """
    settings = replace(settings or RefineSettings(), **overrides)
    if settings.inputs not in INPUT_MODES:
        raise ValueError(f"inputs must be one of {INPUT_MODES}, got {settings.inputs!r}")
    if not logs:
        raise IdentificationError("no logs to refine on")
    tracks = tuple(tracks) if tracks is not None else tuple(smooth_log(log) for log in logs)
    if len(tracks) != len(logs):
        raise IdentificationError(f"{len(logs)} logs but {len(tracks)} smoothed tracks")
    candidates = {method: params, **(alternatives or {})}
    approach = _approach(params, logs, tracks)
    if settings.rudder_rate_radps is not None:
        approach = (approach[0], approach[1], settings.rudder_rate_radps)
    settings = _with_step(settings, params.length_m, approach[0])
    objectives = {
        name: _objective(candidate, logs, tracks, settings)
        for name, candidate in candidates.items()
    }
    start_costs = {name: o.cost(np.zeros(o.size)) for name, o in objectives.items()}
    method = min(start_costs, key=start_costs.__getitem__)  # a diverging replay costs inf
    params, objective = candidates[method], objectives[method]
    p = params.to_vector().size
    warnings: list[str] = []
    z0 = np.zeros(objective.size)
    label = _label(method)
    if not math.isfinite(start_costs[method]):
        initial = _summarise(objective, z0, params, approach)
        reason = (
            f"the {label} estimate diverges replaying "
            + ", ".join(initial.diverged)
            + "; output-error refinement skipped"
        )
        return _result(
            params, method, "initial", reason, initial, initial, False, math.nan, 0,
            "not run", [reason], settings,
        )  # fmt: skip
    initial = _summarise(objective, z0, params, approach)
    others = {name: p for name, p in candidates.items() if name != method}
    warnings.extend(_candidate_disagreement(method, initial.turns, others, approach, settings))
    if not all(t.sane for t in initial.turns):
        warnings.append(
            f"the {label} estimate fails the sanity guard: a virtual hard-over turn "
            "diverges or does not pass 360 deg"
        )
    opt = objective.solve(z0, settings.max_nfev)
    cov_z = _sandwich_covariance(objective, opt.jac, objective.replays(opt.x)[0])
    C = objective.whiten
    cov = C @ cov_z[:p, :p] @ C.T
    refined_params = params.with_vector(objective.theta(opt.x), 0.5 * (cov + cov.T))
    refined = _summarise(objective, opt.x, refined_params, approach)
    turn_check = not covers_turn(tracks) if settings.check_turns is None else settings.check_turns
    spread = turn_spread(initial.turns, refined.turns)
    kept, reason = _decide(initial, refined, turn_check, spread, settings.turn_tolerance, label)
    if kept == "initial" or "although" in reason:
        warnings.append(reason)
    return _result(
        params, method, kept, reason, initial, refined, turn_check, spread, int(opt.nfev),
        str(opt.message), warnings, settings,
    )  # fmt: skip


def _objective(
    params: ModelParameters,
    logs: Sequence[ManeuverLog],
    tracks: Sequence[SmoothedTrack],
    settings: RefineSettings,
) -> _Objective:
    """Build the output-error objective around ``params`` (its execute states, prior)."""
    data = []
    for i, (log, track) in enumerate(zip(logs, tracks, strict=True)):
        k, state = execute_state(params, log, track, settings=settings)
        name = log.path or f"log {i + 1}"
        data.append(replace(_prepare(log, track, name, settings, start=k), x0=state))
    return _Objective(
        model=params.model,
        length_m=params.length_m,
        data=tuple(data),
        settings=settings,
        theta0=params.to_vector().copy(),
        whiten=_whitening(params),
    )


def _sandwich_covariance(objective: _Objective, J: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Covariance of z at the optimum from the objective's Jacobian and data residuals."""
    blocks, row = [], 0
    for d in objective.data:
        channels = d.target.shape[1]
        rows = d.target.shape[0] * channels
        blocks.append((J[row : row + rows], r[row : row + rows], channels))
        row += rows
    return newey_west_covariance(blocks, J[row:])


def newey_west_covariance(
    blocks: Sequence[tuple[np.ndarray, np.ndarray, int]], prior_jacobian: np.ndarray
) -> np.ndarray:
    """Least-squares covariance robust to residuals correlated in time (Newey–West).

    A replayed track's residuals are far from white (a model error persists for
    minutes), so s² (JᵀJ)⁻¹ is optimistic by about the correlation time in samples.
    The sandwich A⁻¹ S A⁻¹, A = JᵀJ over all rows, sums per block (one log) the lagged
    products of the per-sample scores g_k = Σ_channels J_kᵀ r_k with Bartlett weights
    (``statsmodels`` ``S_hac_simple``) over Andrews' automatic bandwidth
    (:func:`_bartlett_lags`); the prior rows add J_pᵀ J_p (unit variance).

    Parameters
    ----------
    blocks : sequence of (J, r, channels)
        Per log: Jacobian rows (m, n) and residuals (m,), time-major with ``channels``
        residuals per sample.
    prior_jacobian : numpy.ndarray
        Jacobian rows of the prior (q, n), residuals of unit variance.

    """
    info = prior_jacobian.T @ prior_jacobian
    meat = info.copy()
    for J, r, channels in blocks:
        info += J.T @ J
        scores = (J * r[:, None]).reshape(-1, channels, J.shape[1]).sum(axis=1)
        meat += S_hac_simple(scores, nlags=_bartlett_lags(r.reshape(-1, channels)))
    try:
        bread = np.linalg.inv(info)
    except np.linalg.LinAlgError:
        bread = np.linalg.pinv(info)
    return bread @ meat @ bread


def _bartlett_lags(residuals: np.ndarray) -> int:
    """Bandwidth of the Bartlett window for (N, C) residuals: Andrews (1991), AR(1) rule.

    L = 1.1447 (α N)^⅓ with α = 4ρ² / ((1 − ρ)² (1 + ρ)²) and ρ the channels' mean lag-1
    autocorrelation (Andrews, Econometrica 59(3), eq. (6.4) and Table I), at most N − 1.
    """
    centred = residuals - residuals.mean(axis=0)
    n = centred.shape[0]
    power = float(np.sum(centred**2))
    if n < 3 or power == 0.0:
        return 0
    rho = min(max(float(np.sum(centred[1:] * centred[:-1])) / power, 0.0), 0.999)
    alpha = 4.0 * rho**2 / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    return min(int(1.1447 * (alpha * n) ** (1.0 / 3.0)), n - 1)


def _candidate_disagreement(
    start: str,
    start_turns: Sequence[VirtualTurn],
    others: Mapping[str, ModelParameters],
    approach: tuple[float, float, float],
    settings: RefineSettings,
) -> list[str]:
    """Warn when another candidate start predicts a different hard-over turn.

    Estimates from the same logs that turn differently mean that the logs do not
    determine the turn (reference/model_structures.md §8): only a turning log, or
    cross-validation, can tell which is right.
    """
    speed, n, rate = approach
    spreads = {
        name: turn_spread(
            start_turns,
            virtual_turns(
                p,
                speed_mps=speed,
                n_rps=n,
                rudder_rate_radps=rate,
                duration_factor=settings.turn_duration_factor,
                max_step_s=settings.max_step_s,
            ),
        )
        for name, p in others.items()
    }
    worst = max(spreads, key=spreads.__getitem__, default=None)
    if worst is None or spreads[worst] <= settings.turn_tolerance:
        return []
    amount = "through 180 deg" if math.isinf(spreads[worst]) else f"by {spreads[worst]:.0%}"
    return [
        f"the {_label(start)} and {_label(worst)} estimates from these logs predict virtual "
        f"35 deg turns that differ {amount}: the logs do not determine the turning circle; "
        "add a turning log or check with 'identifier crossval'"
    ]


def _label(method: str) -> str:
    return "EKF" if method == "ekf" else method


def _decide(
    initial: FitSummary,
    refined: FitSummary,
    turn_check: bool,
    spread: float,
    tolerance: float,
    label: str,
) -> tuple[str, str]:
    """Which estimate to keep, "initial" or "refined", and why (model_structures.md §6, §7)."""
    keep = f"kept the {label} estimate"
    if refined.diverged:
        return "initial", (
            "output-error estimate rejected: replaying "
            + ", ".join(refined.diverged)
            + f" diverges; {keep}"
        )
    if not all(t.sane for t in refined.turns):
        return "initial", (
            "output-error estimate rejected: a virtual hard-over turn diverges or does not "
            f"pass 360 deg; {keep}"
        )
    if not refined.cost < initial.cost:
        return "initial", f"output error did not lower the cost; {keep}"
    if turn_check and not spread <= tolerance:
        text = _spread_text(initial, refined, spread)
        if any(t.tactical_diameter_m is None for t in initial.turns):
            return "refined", (
                f"{text}; kept the output-error estimate although no turning log verifies "
                f"it, because the {label} estimate does not turn through 180 deg"
            )
        return "initial", (
            f"{text}, beyond the {tolerance:.0%} tolerance of the turn check (output error "
            f"is not trusted on turns without a turning log); {keep}"
        )
    return "refined", "output-error estimate accepted"


def _spread_text(initial: FitSummary, refined: FitSummary, spread: float) -> str:
    def td(turn: VirtualTurn) -> str:
        d = turn.tactical_diameter_m
        return "none" if d is None else f"{d:.0f} m"

    sides = ", ".join(
        f"{side} {td(a)} -> {td(b)}"
        for side, a, b in zip(("stbd", "port"), initial.turns, refined.turns, strict=True)
    )
    amount = "beyond 180 deg" if math.isinf(spread) else f"by {spread:.1%}"
    return f"output error moves the virtual 35 deg tactical diameter {amount} ({sides})"


def _result(
    params: ModelParameters,
    method: str,
    kept: str,
    reason: str,
    initial: FitSummary,
    refined: FitSummary,
    turn_check: bool,
    spread: float,
    nfev: int,
    status: str,
    warnings: Sequence[str],
    settings: RefineSettings,
) -> RefinementResult:
    chosen = refined.params if kept == "refined" else params
    result = RefinementResult(
        params=chosen,
        initial_method=method,
        kept=kept,
        reason=reason,
        initial=initial,
        refined=refined,
        turn_check=turn_check,
        turn_spread=spread,
        nfev=nfev,
        status=status,
        warnings=tuple(warnings),
        settings=settings,
    )
    identification: Mapping[str, Any] = {
        **dict(params.identification),
        "refinement": result.summary(),
    }
    return replace(result, params=replace(chosen, identification=identification))
