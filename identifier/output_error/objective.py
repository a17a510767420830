"""The output-error objective and its least-squares solve.

With θ the coefficients, ŝ_k(θ) the simulated state at the log's sample k and
(x_k, y_k, ψ_k) the logged track, the objective is

    J(θ) = ½ Σ_logs Σ_k>k_e [ w_p² ((x̂_k − x_k)² + (ŷ_k − y_k)²) / σ_p²
                            + w_ψ² (ψ̂_k − ψ_k)² / σ_ψ²
                            + w_v² Σ_{u,v,r} (ŝ_k − s̃_k)² / σ_s² ]
           + ½ w_prior (θ − θ₀)ᵀ Σ₀⁻¹ (θ − θ₀),

with σ_p, σ_ψ the logger noise estimated by the smoother, s̃ the smoothed velocities
(optional, ``velocity_weight``), k_e the execute sample and the last term a Tikhonov
prior at the start estimate θ₀ weighted by its covariance Σ₀. J is minimised with
``scipy.optimize.least_squares`` (trust-region reflective, lsmr sub-problems) in
whitened coordinates z, θ = θ₀ + C z with C Cᵀ = Σ₀ (:func:`whitening`), so that the
prior is ½ w_prior |z|² and a unit step in z is one prior standard deviation. The same
problem with θ held and the initial state free fits a log's initial state
(``identifier.output_error.initial_state``).

Simulation. Classical RK4 (``fmu_model.replay``), each sample interval split into equal
steps no longer than ``max_step_s`` (as ``fmu_model.simulate``), with the inputs
interpolated linearly between the samples (``inputs="linear"``, default: a 1 Hz log of
a rudder moving at 2–5°/s is a ramp, and holding it lags the truth by half a sample:
the true seed ship replays its 10/10 zig-zag to 0.1° heading RMS with it, 0.45°
without) or held (``"hold"``: bit-for-bit ``fmu_model.simulate(method="rk4")``). It
runs in numba on the regressor kernels generated from the model structure
(``fmu_model.kernels``), batched over coefficient vectors; the Jacobian is a batched
forward difference in z.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from typing import Any

import numpy as np
from scipy.optimize import least_squares

from fmu_model import ModelParameters, ModelStructure
from fmu_model.environment import Windage
from fmu_model.replay import replay
from identifier.output_error.records import RefineSettings
from identifier.smoothing import SmoothedTrack
from identifier.wind import known_acceleration
from trials.logs import ManeuverLog

# A replay whose speed exceeds this multiple of the logged maximum has diverged.
DIVERGENCE_SPEED_FACTOR = 5.0
# Relative forward-difference step in whitened coordinates (EKF standard deviations).
_FD_STEP = 1e-4
# Smallest eigenvalue kept in the prior covariance, relative to the largest.
_EIGEN_FLOOR = 1e-14


@dataclass(frozen=True)
class LogData:
    """One log prepared for the replay residuals.

    Attributes
    ----------
    name : str
        The log's name in messages.
    time_s : numpy.ndarray
        Sample times from the first replayed sample on (N,) [s].
    rudder_rad : numpy.ndarray
        Logged rudder angle (N,) [rad].
    n_rps : numpy.ndarray
        Logged propeller speed (N,) [rev/s].
    x0 : numpy.ndarray
        Initial state (u, v, r, x, y, ψ) (6,), SI units.
    x0_std : numpy.ndarray
        Its standard deviations (6,), SI units: the scale of its prior.
    target : numpy.ndarray
        Observed quantities after the first sample (N − 1, k): x, y [m], ψ [rad], then
        optionally the smoothed u, v [m/s], r [rad/s].
    scale : numpy.ndarray
        Weight / σ of each quantity (k,), in the inverse of its unit.
    speed_limit_mps : float
        Speed above which the replay has diverged [m/s].
    known_acceleration : numpy.ndarray or None
        Accelerations of known loads (a measured wind's) at the samples (N, 3) [m/s²,
        m/s², rad/s²], added to the model's in the replay; None: none.

    """

    name: str
    time_s: np.ndarray
    rudder_rad: np.ndarray
    n_rps: np.ndarray
    x0: np.ndarray
    x0_std: np.ndarray
    target: np.ndarray
    scale: np.ndarray
    speed_limit_mps: float
    known_acceleration: np.ndarray | None = None

    def head(self, end: int) -> LogData:
        """Return the log's first ``end`` samples."""
        return replace(
            self,
            time_s=self.time_s[:end],
            rudder_rad=self.rudder_rad[:end],
            n_rps=self.n_rps[:end],
            target=self.target[: end - 1],
            known_acceleration=(
                None if self.known_acceleration is None else self.known_acceleration[:end]
            ),
        )


def prepare_log(
    log: ManeuverLog,
    track: SmoothedTrack,
    name: str,
    settings: RefineSettings,
    start: int = 0,
    windage: Windage | None = None,
    step: int = 1,
) -> LogData:
    """Residual data of a log from sample ``start`` on (initial state: smoothed there).

    Parameters
    ----------
    log : ManeuverLog
        The log.
    track : SmoothedTrack
        Its smoothed track (initial state, its standard deviations, noise levels).
    name : str
        The log's name in messages.
    settings : RefineSettings
        The residual weights w_p, w_ψ, w_v.
    start : int
        Index of the first replayed sample.
    windage : Windage, optional
        The vessel's windage: the load of the log's measured wind enters the replay
        (``identifier.wind``); None: no wind load.
    step : int
        Every ``step``-th sample from ``start`` on is replayed and compared (the inputs
        linear between them): a log sampled much faster than the ship manoeuvres costs
        replay steps and gives no more information (``identifier.equation_error``'s
        L/U/40, :func:`identifier.equation_error.decimation_step`).

    Returns
    -------
    LogData
        The log from ``start`` on, its targets and their scales.

    """
    k = start
    rows = slice(k + step, None, step)  # the samples after the first replayed one
    columns = [log.x_m[rows], log.y_m[rows], log.heading_rad[rows]]
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
            columns.append(values[rows])
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
    known = known_acceleration(log, windage)
    return LogData(
        name=name,
        time_s=np.array(log.time_s[k::step]),
        rudder_rad=np.array(log.rudder_rad[k::step]),
        n_rps=np.array(log.n_rps[k::step]),
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
        speed_limit_mps=DIVERGENCE_SPEED_FACTOR * max(speed, 0.1),
        known_acceleration=None if known is None else known[k::step],
    )


def whitening(params: ModelParameters) -> np.ndarray:
    """C with C Cᵀ = Σ₀ (eigenvalues floored), or a diagonal scale without Σ.

    Parameters
    ----------
    params : ModelParameters
        The start estimate θ₀ with its covariance Σ₀ (optional).

    Returns
    -------
    numpy.ndarray
        C (p, p), in the coefficients' units; without Σ₀ a diagonal of 10 % of |θ₀|
        (1e-6 for a zero coefficient).

    """
    theta = params.to_vector()
    if params.covariance is None:
        return np.diag(np.where(theta != 0.0, 0.1 * np.abs(theta), 1e-6))
    cov = 0.5 * (params.covariance + params.covariance.T)
    values, vectors = np.linalg.eigh(cov)
    floor = _EIGEN_FLOOR * max(float(values.max()), np.finfo(float).tiny)
    return vectors * np.sqrt(np.maximum(values, floor))


def _log_residuals(
    structure: ModelStructure,
    thetas: np.ndarray,
    x0s: np.ndarray,
    length_m: float,
    d: LogData,
    settings: RefineSettings,
) -> tuple[np.ndarray, np.ndarray]:
    """Weighted residuals (B, m) of a log for every (θ, x0) row, and the states (B, N, 6)."""
    sim = replay(
        structure,
        np.atleast_2d(thetas),
        length_m,
        d.time_s,
        d.rudder_rad,
        d.n_rps,
        np.atleast_2d(x0s),
        inputs=settings.inputs,
        max_step_s=settings.max_step_s,
        speed_limit_mps=d.speed_limit_mps,
        extra_acceleration=d.known_acceleration,
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
class Objective:
    """The least-squares problem J in whitened coordinates.

    z = (z_θ, z_x0 of log 1, z_x0 of log 2, …): θ = θ₀ + C z_θ and
    x0_i = x̂0_i + diag(σ̂0_i) z_x0_i, with x̂0 the log's initial state and σ̂0 the
    smoothed state's standard deviation; either part may be held (``free_theta``,
    ``free_x0``). Residuals: the weighted replay errors, √w_prior z_θ, and z_x0 (x̂0 as
    a measurement of the initial state).

    Attributes
    ----------
    structure : ModelStructure
        The model structure replayed.
    length_m : float
        Ship length L [m].
    data : tuple of LogData
        The logs, prepared.
    settings : RefineSettings
        Weights, replay step and input mode, optimiser settings.
    theta0 : numpy.ndarray
        θ₀, the start coefficients (p,).
    whiten : numpy.ndarray
        C (p, p), C Cᵀ = Σ₀.
    free_theta, free_x0 : bool
        Whether the coefficients, the initial states are fitted.

    """

    structure: ModelStructure
    length_m: float
    data: tuple[LogData, ...]
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
            res, sim = _log_residuals(self.structure, theta, x0, self.length_m, d, self.settings)
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
            res, _ = _log_residuals(self.structure, thetas, starts, self.length_m, d, self.settings)
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
        self, d: LogData, thetas: np.ndarray, starts: np.ndarray, bad: np.ndarray
    ) -> np.ndarray:
        """Residuals of the steps ``bad`` taken backwards (rows 1… of the batch)."""
        th = 2.0 * thetas[0] - thetas[1 + bad]
        st = 2.0 * starts[0] - starts[1 + bad]
        return _log_residuals(self.structure, th, st, self.length_m, d, self.settings)[0]

    def row_blocks(
        self, jacobian: np.ndarray, residuals: np.ndarray
    ) -> tuple[list[tuple[np.ndarray, np.ndarray, int]], np.ndarray]:
        """Split the rows of a Jacobian and of the data residuals by log.

        Parameters
        ----------
        jacobian : numpy.ndarray
            The Jacobian of :meth:`residuals` (m + q, n): data rows, then prior rows.
        residuals : numpy.ndarray
            The data residuals (m,) of :meth:`replays`.

        Returns
        -------
        blocks : list of (J, r, channels)
            Per log its Jacobian rows, residuals (time-major) and residuals per sample,
            as :func:`identifier.output_error.covariance.newey_west_covariance` takes
            them.
        prior_jacobian : numpy.ndarray
            The remaining (prior) rows of the Jacobian (q, n).

        """
        blocks, row = [], 0
        for d in self.data:
            channels = d.target.shape[1]
            rows = d.target.shape[0] * channels
            blocks.append((jacobian[row : row + rows], residuals[row : row + rows], channels))
            row += rows
        return blocks, jacobian[row:]

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
