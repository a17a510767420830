"""Open-loop replay of logged inputs, compiled: the one integrator in numba, batched.

Output-error identification and cross-validation simulate the model over the rudder and
propeller speed of a log thousands of times, for many coefficient vectors at once. Here
:func:`fmu_model.integrate.rk4_into` is compiled with numba and driven by the regressor
kernels generated from the symbolic structure (``fmu_model.kernels``, compiled once per
structure and cached on disk), so that a replay is the same RK4 as
``fmu_model.simulate`` (bit for bit with held inputs) at the speed of compiled code.
numba is imported here only: the FMU runtime never needs it.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from fmu_model.integrate import n_substeps, rk4_into
from fmu_model.kernels import Binding, kernel_constants, kernel_module
from fmu_model.structure import ModelStructure

# How the inputs behave between log samples (see ``replay``).
INPUT_MODES = ("linear", "hold")

# Inlined into the replay compiled per structure (_REPLAY_BINDINGS): the derivative it
# calls is then a static call, not a run-time value (which numba cannot cache).
_rk4 = numba.njit(cache=False, inline="always")(rk4_into)
_substeps = numba.njit(cache=False)(n_substeps)


# Templates in numba's subset: compiled, and cached on disk, per structure with its
# kernels bound (_REPLAY_BINDINGS, fmu_model.kernels).
def _derivative(phi_fn, kin_fn, s, context, inputs, out):  # fmt: skip
    """ṡ = (M (θ ⊙ φ(s, δ, n)) + a, kinematics) of the structure of ``phi_fn``, ``kin_fn``.

    Bound to a structure's kernels, this is ``f(state, context, inputs, out)`` of
    ``rk4_into``, with context (equation index, θ, the kernels' constants (L [m],
    shape…; ``fmu_model.kernels.kernel_constants``), φ scratch (p,), kinematics scratch
    (3,)) and inputs (δ [rad], n [rev/s], a_u [m/s²], a_v [m/s²], a_r [rad/s²]):
    a known acceleration a (of a measured wind load) is added to the model's.
    """
    eq_index, theta, constants, phi, kin = context
    rudder, n_rps, a_u, a_v, a_r = inputs
    phi_fn(s[0], s[1], s[2], rudder, n_rps, constants, phi)
    kin_fn(s[0], s[1], s[2], s[5], kin)
    out[0] = a_u
    out[1] = a_v
    out[2] = a_r
    for i in range(theta.size):
        out[eq_index[i]] += theta[i] * phi[i]
    out[3] = kin[0]
    out[4] = kin[1]
    out[5] = kin[2]


def _replay_batch(
    derivative, eq_index, constants, max_step, linear, t, rudder, n_rps, extra, x0s, thetas,
    speed_limit, out,
):  # fmt: skip
    """RK4 replay from every row of ``x0s`` (B, 6) with ``thetas`` (B, p) into ``out`` (B, N, 6).

    Inputs (rudder, rpm and the known accelerations ``extra`` (N, 3)) are held over each
    interval (zero-order hold) or, with ``linear``, interpolated linearly between the
    samples at every RK4 stage. Each interval has
    ``n_substeps(T, max_step)`` equal substeps. A run that turns non-finite or faster
    than ``speed_limit`` is NaN from there on.
    """
    n_batch, p = thetas.shape
    phi = np.empty(p)
    kin = np.empty(3)
    s = np.empty(6)
    work = np.empty((5, 6))
    for b in range(n_batch):
        context = (eq_index, thetas[b], constants, phi, kin)
        for c in range(6):
            s[c] = x0s[b, c]
            out[b, 0, c] = x0s[b, c]
        alive = True
        for k in range(t.size - 1):
            if not alive:
                for c in range(6):
                    out[b, k + 1, c] = np.nan
                continue
            m = _substeps(t[k + 1] - t[k], max_step)
            h = (t[k + 1] - t[k]) / m
            d0 = rudder[k]
            n0 = n_rps[k]
            e0, e1, e2 = extra[k, 0], extra[k, 1], extra[k, 2]
            dd = 0.0
            dn = 0.0
            de0 = 0.0
            de1 = 0.0
            de2 = 0.0
            if linear:
                dd = (rudder[k + 1] - d0) / m
                dn = (n_rps[k + 1] - n0) / m
                de0 = (extra[k + 1, 0] - e0) / m
                de1 = (extra[k + 1, 1] - e1) / m
                de2 = (extra[k + 1, 2] - e2) / m
            for j in range(m):
                # Inputs at the stage times: fraction 0, ½, 1 of the substep.
                a = float(j)
                at_start = (d0 + a * dd, n0 + a * dn, e0 + a * de0, e1 + a * de1, e2 + a * de2)
                a = j + 0.5
                at_middle = (d0 + a * dd, n0 + a * dn, e0 + a * de0, e1 + a * de1, e2 + a * de2)
                a = j + 1.0
                at_end = (d0 + a * dd, n0 + a * dn, e0 + a * de0, e1 + a * de1, e2 + a * de2)
                _rk4(derivative, s, h, context, at_start, at_middle, at_end, work)
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


_REPLAY_BINDINGS = (
    Binding("derivative", _derivative, ("phi", "kin")),
    Binding("replay_batch", _replay_batch, ("derivative",)),
)
"""The replay bound to a structure's kernels (``fmu_model.kernels``)."""


def replay(
    structure: ModelStructure,
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
    extra_acceleration: np.ndarray | None = None,
) -> np.ndarray:
    """Simulate a batch of coefficient vectors over given inputs with RK4.

    With ``inputs="hold"`` this is exactly ``fmu_model.simulate(method="rk4")`` (each
    input held over its interval, as an FMU between communication points); with
    ``"linear"`` the inputs are interpolated linearly between the samples at every RK4
    stage, which is what a log of a continuously moving rudder means.

    Parameters
    ----------
    structure : ModelStructure
        The model structure.
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
    extra_acceleration : numpy.ndarray, optional
        Known accelerations (u̇ [m/s²], v̇ [m/s²], ṙ [rad/s²]) at the sample times added
        to the model's (a measured wind's load), shape (N, 3); none when None.

    Returns
    -------
    numpy.ndarray
        States (u, v, r, x, y, ψ), shape (N, 6) for one θ or (B, N, 6).

    """
    if inputs not in INPUT_MODES:
        raise ValueError(f"inputs must be one of {INPUT_MODES}, got {inputs!r}")
    theta_arr = np.asarray(thetas, dtype=float)
    # Fresh writable C arrays: one numba signature whatever the callers pass.
    x0_arr = np.asarray(initial_state, dtype=float)
    n_batch = max(np.atleast_2d(theta_arr).shape[0], np.atleast_2d(x0_arr).shape[0])
    batch = np.array(np.broadcast_to(theta_arr, (n_batch, theta_arr.shape[-1])), order="C")
    x0s = np.array(np.broadcast_to(x0_arr, (n_batch, 6)), order="C")
    t = np.array(time_s, dtype=float, order="C")
    out = np.empty((batch.shape[0], t.size, 6))
    kernel_module(structure, _REPLAY_BINDINGS).replay_batch(
        np.array(structure.equation_index, dtype=np.int64),
        kernel_constants(structure, length_m),
        math.inf if max_step_s is None else float(max_step_s),
        inputs == "linear",
        t,
        np.array(rudder_rad, dtype=float, order="C"),
        np.array(n_rps, dtype=float, order="C"),
        np.zeros((t.size, 3))
        if extra_acceleration is None
        else np.array(extra_acceleration, dtype=float, order="C"),
        x0s,
        batch,
        float(speed_limit_mps),
        out,
    )
    return out[0] if theta_arr.ndim == 1 and x0_arr.ndim == 1 else out
