"""Equation-error least squares: the EKF's initial guess and the identifiability check.

Because every structure is linear in its coefficients, the model written for the
smoothed data with central-difference accelerations (second-order accurate, unlike the
forward difference of the paper's eq. (4), whose O(T) bias at T = 1 s reaches several
per cent on the yaw coefficients),

    (s_j(k+1) − s_j(k−1)) / (t(k+1) − t(k−1)) = Σ_i θ_i φ_i(s(k), δ(k), n(k)) + e_j(k),

j ∈ {u, v, r}, is an ordinary linear regression per equation. Each equation is solved separately
(its coefficients enter no other equation) with columns scaled to unit RMS and a tiny
ridge term so that an unexcited regressor (e.g. rudder terms in a straight run) gets a
zero estimate with a huge standard deviation instead of a singular matrix. The
covariance is σ²_e (XᵀX + λI)⁻¹ with σ_e the residual standard deviation.

Rate-aware. The regression is written on the smoothed data decimated to a sampling
interval of about :data:`REGRESSION_INTERVAL_L_OVER_U` × L/U, the time the ship takes to
sail 1/40 of its length (every m-th sample, m = ⌊that / median interval⌋, at least 1;
U the segment's 95th-percentile smoothed speed, about its approach speed: the fastest
part of the run sets the rate): the RTS smoother is the anti-aliasing filter
(its smoothed states carry nothing faster than the manoeuvre), a ship's manoeuvring
dynamics scale with L/U (Froude similarity: time constants of 0.25–2.5 L/U, the rudder
put over in about 0.3 L/U), and the central difference over 2/40 L/U keeps the
smoother's velocity noise out of the accelerations. That is 1 s for KVLCC2 at full
scale (L/U = 40 s), where 0.1 s at 10 Hz would give ten times the noise, and 0.15 s for
its 7 m model (L/U = 6 s), where 1 s would smear a rudder step of 1.3 s. The EKF still
measures every sample.

Bounded memory. The fit needs only the normal equations: ΦΦᵀ, Φ aᵀ and a aᵀ are summed
over chunks of :data:`CHUNK_ROWS` rows (:class:`NormalEquations`), so a log of any length
costs no more than one chunk of regressors.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np
from threadpoolctl import threadpool_limits

from fmu_model import ModelStructure, numeric_model
from identifier.ekf import EkfSegment

# Ridge weight relative to the number of samples, in unit-RMS column scaling.
_RIDGE = 1e-9

#: Sampling interval the regression is decimated to, in units of L/U [-] (module docstring).
REGRESSION_INTERVAL_L_OVER_U = 1.0 / 40.0

#: Rows of regressors held at once when summing the normal equations.
CHUNK_ROWS = 50_000


@dataclass(frozen=True)
class EquationErrorFit:
    """Least-squares estimate of θ.

    Attributes
    ----------
    theta : numpy.ndarray
        Coefficients (p,).
    covariance : numpy.ndarray
        Their covariance (p, p), block-diagonal by equation.
    residual_std : numpy.ndarray
        Residual standard deviation of (u̇, v̇, ṙ) [m/s², m/s², rad/s²].
    regressor_rms : numpy.ndarray
        RMS of every regressor over the data (p,); 0 means not excited at all.
    contribution : numpy.ndarray
        RMS(θ_i φ_i) / RMS(fitted acceleration of its equation) (p,).
    variance_inflation : numpy.ndarray
        Uncentred variance inflation factor of every regressor (p,).
    rows : int
        Regression rows (decimated samples) the fit used.
    sample_interval_s : float
        Their median sampling interval [s] after decimation (0 when not known).

    """

    theta: np.ndarray
    covariance: np.ndarray
    residual_std: np.ndarray
    regressor_rms: np.ndarray
    contribution: np.ndarray
    variance_inflation: np.ndarray
    rows: int = 0
    sample_interval_s: float = 0.0


def decimation(segment: EkfSegment, length_m: float) -> int:
    """Return m, the step of the decimation to about 1/40 L/U (≥ 1; module docstring)."""
    speed = np.hypot(segment.velocities[:, 0], segment.velocities[:, 1])
    return decimation_step(segment.time_s, speed, length_m)


def decimation_step(time_s: np.ndarray, speed_mps: np.ndarray, length_m: float) -> int:
    """Return m, the step of samples at ``time_s`` [s] to about 1/40 L/U (≥ 1).

    U is the 95th percentile of ``speed_mps`` [m/s] (the approach, not the slowed turn).
    """
    interval = float(np.median(np.diff(time_s)))
    speed = float(np.percentile(speed_mps, 95))
    target_s = REGRESSION_INTERVAL_L_OVER_U * length_m / speed if speed > 0.0 else interval
    return max(1, math.floor(target_s / interval * (1.0 + 1e-9)))


def regression_rows(segments: Sequence[EkfSegment], length_m: float) -> int:
    """Return the number of rows of the decimated regression of ``segments``."""
    return sum(
        max(len(range(0, seg.time_s.size, decimation(seg, length_m))) - 2, 0) for seg in segments
    )


def regression_chunks(
    segments: Sequence[EkfSegment],
    length_m: float,
    chunk_rows: int | None = None,
    row_step: int = 1,
) -> Iterator[tuple[np.ndarray, np.ndarray]]:
    """Yield the decimated samples (u, v, r, δ, n) (5, m) and their accelerations (3, m).

    Each segment is decimated by :func:`decimation` (ship length ``length_m`` [m]); the
    accelerations are central differences over the decimated samples. SI units: m/s, m/s,
    rad/s, rad, rev/s; accelerations m/s², m/s², rad/s², less the segment's known ones (a
    measured wind's load) when it has them. The first and last decimated sample
    of every segment have no central difference and are left out. At most ``chunk_rows``
    rows (default :data:`CHUNK_ROWS`) a chunk; a chunk never spans two segments. With
    ``row_step`` > 1 only every ``row_step``-th row of each chunk is kept (a subset spread
    evenly over the data).
    """
    per_chunk = CHUNK_ROWS if chunk_rows is None else chunk_rows
    for seg in segments:
        m = decimation(seg, length_m)
        t = seg.time_s[::m]
        for start in range(1, t.size - 1, per_chunk):
            stop = min(start + per_chunk, t.size - 1)  # rows start … stop − 1
            rows = slice(start * m, stop * m, m)
            s = seg.velocities[rows].T
            ahead = seg.velocities[(start + 1) * m : (stop + 1) * m : m].T
            behind = seg.velocities[(start - 1) * m : (stop - 1) * m : m].T
            span = t[start + 1 : stop + 1] - t[start - 1 : stop - 1]
            acc = (ahead - behind) / span
            if seg.known_acceleration is not None:  # the ship's own part of it
                acc = acc - seg.known_acceleration[rows].T
            yield (
                np.vstack([s, seg.rudder_rad[rows], seg.n_rps[rows]])[:, ::row_step],
                acc[:, ::row_step],
            )


def regression_samples(
    segments: Sequence[EkfSegment], length_m: float, max_rows: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Return the decimated samples (5, M) and accelerations (3, M) of :func:`regression_chunks`.

    With ``max_rows``, every k-th row only, k the least that keeps at most about that
    many rows (a chunk's first row is always kept).
    """
    step = 1 if max_rows is None else max(1, -(-regression_rows(segments, length_m) // max_rows))
    chunks = list(regression_chunks(segments, length_m, row_step=step))
    return (
        np.concatenate([c[0] for c in chunks], axis=1),
        np.concatenate([c[1] for c in chunks], axis=1),
    )


def regression_interval_s(segments: Sequence[EkfSegment], length_m: float) -> float:
    """Return the median sampling interval of the decimated regression [s]."""
    return float(
        np.median(
            [np.median(np.diff(seg.time_s[:: decimation(seg, length_m)])) for seg in segments]
        )
    )


class NormalEquations:
    """Running sums of the regression of every equation (bounded memory).

    ``add(phi, acc)`` adds rows: regressors φ (p, m) and accelerations (3, m); the sums
    ΦΦᵀ (p, p), Φ aᵀ (p, 3) and Σ a² (3,) are all :meth:`solve` needs. The sums of
    :meth:`of_sums` may carry leading axes, one regression each (G of them, (G, p, p) and
    (G, p, 3): the shapes of a family, ``identifier.shape``); :meth:`residual_std` answers
    for all of them at once.
    """

    def __init__(self, n_coefficients: int) -> None:
        self.rows = 0
        self.gram = np.zeros((n_coefficients, n_coefficients))
        self.cross = np.zeros((n_coefficients, 3))
        self.acc_squares = np.zeros(3)

    @classmethod
    def of_sums(
        cls, rows: int, gram: np.ndarray, cross: np.ndarray, acc_squares: np.ndarray
    ) -> NormalEquations:
        """Return the normal equations of sums made elsewhere: ΦΦᵀ, Φ aᵀ and Σ a² of ``rows``."""
        sums = cls(gram.shape[0])
        sums.rows, sums.gram, sums.cross, sums.acc_squares = rows, gram, cross, acc_squares
        return sums

    def add(self, phi: np.ndarray, acc: np.ndarray) -> None:
        """Add the rows of φ (p, m) and of the accelerations (3, m)."""
        self.rows += phi.shape[1]
        self.gram += phi @ phi.T
        self.cross += phi @ acc.T
        self.acc_squares += np.einsum("jm,jm->j", acc, acc)

    def solve(
        self,
        equation_index: Sequence[int],
        prior_std: Sequence[float | None] | None = None,
        prior_inflation: float = 1.0,
    ) -> EquationErrorFit:
        """Solve acc_j ≈ Σ_{i in equation j} θ_i φ_i for every equation j (module docstring).

        With X = Φ_jᵀ D⁻¹ (columns scaled to unit RMS by D), A = XᵀX + λ m I + R::

            β = A⁻¹ Xᵀ a_j,   θ_j = D⁻¹ β,
            ‖a_j − X β‖² = aᵀa − 2 βᵀ Xᵀ a + βᵀ XᵀX β,   σ² = that / (m − p_j),
            Cov θ_j = σ² D⁻¹ A⁻¹ D⁻¹,   VIF = diag((A / m)⁻¹).

        R is the zero-mean prior θ_i ~ N(0, s_i²) of the coefficients with a ``prior_std``
        s_i (None: none), R_ii = c²σ₀²/(s_i D_i)², σ₀ the residual standard deviation
        without it and c = ``prior_inflation``: the rows are serially correlated, so the
        data carry about 1/c² of the information σ₀⁻²XᵀX says (the EKF's prior is this
        covariance × c², ``identifier.identify``), and a coefficient the data do not
        determine keeps its prior, c²·Cov θ_i → s_i².
        """
        m = self.rows
        p = self.gram.shape[0]
        theta = np.zeros(p)
        cov = np.zeros((p, p))
        residual_std = np.zeros(3)
        rms = self._rms()
        eq_index = np.asarray(equation_index)
        fitted_squares = np.zeros(3)
        vif = np.ones(p)
        prior = np.array(
            [np.inf if std is None else std for std in (prior_std or [None] * p)], dtype=float
        )
        for j in range(3):
            cols, scale, A, beta, fit_squares, sigma2 = self._equation(j, eq_index, rms)
            if np.isfinite(prior[cols]).any():
                ridge = prior_inflation**2 * sigma2 / (prior[cols] * scale) ** 2
                cols, scale, A, beta, fit_squares, sigma2 = self._equation(j, eq_index, rms, ridge)
            theta[cols] = beta / scale
            cov[np.ix_(cols, cols)] = sigma2 * np.linalg.inv(A) / np.outer(scale, scale)
            residual_std[j] = np.sqrt(sigma2)
            vif[cols] = np.diag(np.linalg.inv(A / m))
            fitted_squares[j] = fit_squares
        signal = np.sqrt(fitted_squares / max(m, 1))
        term_rms = np.abs(theta) * rms
        contribution = term_rms / np.where(signal[eq_index] > 0.0, signal[eq_index], 1.0)
        return EquationErrorFit(theta, cov, residual_std, rms, contribution, vif, rows=m)

    def residual_std(self, equation_index: Sequence[int]) -> np.ndarray:
        """Residual standard deviations σ_j of :meth:`solve` alone (…, 3), without the rest."""
        rms = self._rms()
        eq_index = np.asarray(equation_index)
        return np.sqrt(np.stack([self._equation(j, eq_index, rms)[5] for j in range(3)], -1))

    def _rms(self) -> np.ndarray:
        diagonal = np.diagonal(self.gram, axis1=-2, axis2=-1)
        return np.sqrt(np.maximum(diagonal, 0.0) / max(self.rows, 1))

    def _equation(
        self, j: int, eq_index: np.ndarray, rms: np.ndarray, ridge: np.ndarray | float = 0.0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Columns, scale D, A, β, ‖Xβ‖² and σ² of equation j (:meth:`solve`; R = ``ridge``).

        Of every regression of the sums' leading axes: every array with those axes in
        front (‖Xβ‖² and σ² 0-d for one regression).
        """
        m = self.rows
        cols = np.flatnonzero(eq_index == j)
        scale = np.where(rms[..., cols] > 0.0, rms[..., cols], 1.0)
        xtx = self.gram[..., cols[:, None], cols] / (scale[..., :, None] * scale[..., None, :])
        xta = self.cross[..., cols, j] / scale
        A = xtx + np.diag(_RIDGE * m + np.broadcast_to(ridge, cols.shape))
        beta = np.linalg.solve(A, xta[..., None])[..., 0]
        fit_squares = (beta[..., None, :] @ xtx @ beta[..., :, None])[..., 0, 0]
        explained = (beta[..., None, :] @ xta[..., :, None])[..., 0, 0]
        residual = np.maximum(self.acc_squares[..., j] - 2.0 * explained + fit_squares, 0.0)
        return cols, scale, A, beta, fit_squares, residual / max(m - cols.size, 1)


def equation_error_fit(
    structure: ModelStructure,
    segments: Sequence[EkfSegment],
    length_m: float,
    prior_inflation: float = 1.0,
) -> EquationErrorFit:
    """Fit θ by equation-error least squares on the smoothed segments (module docstring).

    Terms with a ``prior_std`` get their prior (:meth:`NormalEquations.solve`, with
    ``prior_inflation``).
    """
    model = numeric_model(structure)
    sums = NormalEquations(model.n_coefficients)
    with threadpool_limits(limits=1, user_api="blas"):  # p ≤ 28 columns: threads only cost
        for (u, v, r, rudder_rad, n_rps), acc in regression_chunks(segments, length_m):
            sums.add(model.regressors(u, v, r, rudder_rad, n_rps, length_m), acc)
        fit = sums.solve(
            structure.equation_index, [t.prior_std for t in structure.terms], prior_inflation
        )
    return replace(fit, sample_interval_s=regression_interval_s(segments, length_m))
