r"""The two TSO(3) filters over a whole log in one Numba call: :meth:`omegahat.baselines.tso3_common.TSO3Filter.run`.

One loop, :func:`run_log`, for both filters (one compiled function, not two: compile time): ``kind`` selects the
step, :data:`MIN_ENERGY` ((M1)–(M6) of :mod:`omegahat.baselines.tso3_min_energy`) or :data:`PREDICTIVE` ((G1)–(G8)
of :mod:`omegahat.baselines.predictive_geom`), with the timing (C3), the Newton iteration (C4) and the restart
(C5) of :mod:`omegahat.baselines.tso3_common`. The NumPy functions of those modules are the oracle:
``tests/test_tso3.py`` checks that :func:`run_log` equals a loop of their ``update`` to 1e-10. Written in the order
of the NumPy references' formulas (no fast-math, ``docs/DEVELOPING.md``); all arrays C-contiguous float64.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels.rotation import exp_matrix, store, wahba

__all__ = ["MIN_ENERGY", "NEWTON_MAX", "NEWTON_TOL", "PREDICTIVE", "run_log"]

MIN_ENERGY = 0  #: ``kind`` of :func:`run_log`: the minimum-energy filter
PREDICTIVE = 1  #: ``kind`` of :func:`run_log`: the predictive filter
NEWTON_TOL = 1e-13  #: (C4) Newton stops when max|Δω| ≤ NEWTON_TOL (1 + max|ω|)
NEWTON_MAX = 50  #: (C4) ... or fails after this many iterations


@numba.njit(cache=True)
def _cross(a, b):
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


@numba.njit(cache=True)
def _hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@numba.njit(cache=True)
def _newton(kind, start, c, J, J_inv, h, tau, second):
    """(C4) for (M4) (``kind`` MIN_ENERGY: ``N(−hω)Jω − c``, Jacobian (M6)) or (G7) (PREDICTIVE: ``c`` is ω_½);
    returns ``(ω, converged)``."""
    w = start.copy()
    for _ in range(NEWTON_MAX):
        Jw = J @ w
        if kind == MIN_ENERGY:
            x = -h * w
            wJw = _cross(x, Jw)
            e = Jw - 0.5 * wJw + _cross(x, wJw) / 12.0 - c
            W = _hat(w)
            second_order = np.dot(w, Jw) * np.eye(3) + 2.0 * np.outer(w, Jw) - 2.0 * np.outer(Jw, w) - np.dot(w, w) * J
            D = J + 0.5 * h * (W @ J - _hat(Jw)) + h * h / 12.0 * second_order
        else:
            e = -w + c + 0.5 * h * (J_inv @ (_cross(Jw, w) + tau) + second)
            D = -np.eye(3) + 0.5 * h * J_inv @ (_hat(Jw) - _hat(w) @ J)
        if not (np.all(np.isfinite(D)) and np.all(np.isfinite(e))):
            return w, False
        step = np.linalg.solve(D, e)
        w = w - step
        if not np.all(np.isfinite(w)):
            return w, False
        if np.max(np.abs(step)) <= NEWTON_TOL * (1.0 + np.max(np.abs(w))):
            return w, True
    return w, False


@numba.njit(cache=True)
def _rotate(R, phi):
    """``R ← R Exp(φ)`` in place."""
    E = np.empty((3, 3))
    store(exp_matrix(phi[0], phi[1], phi[2]), E)
    R[:, :] = R @ E


@numba.njit(cache=True)
def _min_energy_step(R, omega, K, a, has_a, refs, tau, h, J, J_inv, q, g, alpha, process_weight):
    """(M1)–(M5) in place on ``R``, ``omega``, ``K``; False when (M4)'s Newton iteration fails."""
    r = np.zeros(3)
    E11 = np.zeros((3, 3))
    if has_a:
        for i in range(refs.shape[0]):
            b = R.T @ refs[i]
            r += g[i] * _cross(a[i], b)
            E11 += 0.5 * q[i] * (2.0 * np.dot(a[i], b) * np.eye(3) - np.outer(a[i], b) - np.outer(b, a[i]))
    delta_R = np.ascontiguousarray(K[:3, :3]) @ r
    delta_w = np.ascontiguousarray(K[3:, :3]) @ r
    x = h * omega
    Jw = J @ omega
    xJw = _cross(x, Jw)
    c = Jw - 0.5 * xJw + _cross(x, xJw) / 12.0 + h * (tau + J @ delta_w)
    w_next, ok = _newton(MIN_ENERGY, omega, c, J, J_inv, h, tau, tau)
    if not ok:
        return False
    A = np.zeros((6, 6))
    A[:3, :3] = -_hat(omega)
    A[:3, 3:] = np.eye(3)
    A[3:, 3:] = J_inv @ (_hat(Jw) - _hat(omega) @ J)
    E = np.zeros((6, 6))
    E[:3, :3] = E11
    BB = np.zeros((6, 6))
    BB[3:, 3:] = process_weight * np.eye(3)
    W = np.zeros((6, 6))
    W[:3, :3] = 0.5 * _hat(delta_R)
    K_dot = -alpha * K + A @ K + K @ A.T - K @ E @ K + BB - W @ K - K @ W.T
    K_next = K + h * K_dot
    K[:, :] = 0.5 * (K_next + K_next.T)
    _rotate(R, h * (omega + delta_R))
    omega[:] = w_next
    return True


@numba.njit(cache=True)
def _predictive_step(R, omega, y, has_y, refs, tau, h, J, J_inv, q, rho, k_R, as_published):
    """(G1)–(G8) in place on ``R``, ``omega``; False when (G7)'s Newton iteration fails."""
    omega_dot = J_inv @ (_cross(J @ omega, omega) + tau)
    delta = np.zeros(3)
    r = np.zeros(3)
    if has_y:
        alpha = np.zeros(3)
        beta = np.zeros((3, 3))
        for i in range(refs.shape[0]):
            b = R.T @ refs[i]
            zeta = -h * _cross(omega, b) + 0.5 * h * h * (_cross(b, omega_dot) + _cross(omega, _cross(omega, b)))
            alpha += _cross(y[i], b + zeta)
            beta += _hat(y[i]) @ _hat(b)
            r += _cross(y[i], b)
        beta = 0.5 * h * h * beta
        delta = -np.linalg.solve(q * beta.T @ beta + rho * np.eye(3), q * beta.T @ alpha)
    w_half = omega + 0.5 * h * (omega_dot + delta)
    second = J_inv @ delta if as_published else delta
    w_next, ok = _newton(PREDICTIVE, w_half, w_half, J, J_inv, h, tau, second)
    if not ok:
        return False
    _rotate(R, h * (w_half + k_R * r))
    omega[:] = w_next
    return True


@numba.njit(cache=True)
def _finite(R, omega, K):
    for x in R.flat:
        if not np.isfinite(x):
            return False
    for x in K.flat:
        if not np.isfinite(x):
            return False
    return np.all(np.isfinite(omega))


@numba.njit(cache=True)
def run_log(kind, times, values, valid, torques, refs, J, J_inv, q, g, params, state, R, K, prev, omega0, K0):
    """The shell's ``update`` over a checked log; returns ``(ω̂ (T, 3), restarted (T,))``: ``restarted[j]`` when
    the step to sample j could not be taken ((C5) of :mod:`omegahat.baselines.tso3_common`: Newton failed or the
    result is not finite); the filter then restarts from sample j with ``omega0`` and the gain ``K0``, its attitude
    from the sample when valid, and ω̂ there is NaN. ``values``: directions ``(T, n, 3)`` (attitude samples: the
    rotation matrices, whose rows are the directions of ``refs = I``); ``params``: MIN_ENERGY ``[α, 1/ρ, 0, 0]``,
    PREDICTIVE ``[q, ρ, k_R, as_published]``. In place: ``state = [t_prev, has_t, has_R, has_prev, ω̂ (3),
    τ_prev (3)]``, ``R``, ``K`` (the minimum-energy gain) and ``prev`` (the last sample's directions)."""
    T = times.size
    out = np.empty((T, 3))
    restarted = np.zeros(T, dtype=np.bool_)
    omega = state[4:7].copy()
    tau = state[7:10].copy()
    t_prev, has_t, has_R, has_prev = state[0], state[1] != 0.0, state[2] != 0.0, state[3] != 0.0
    for j in range(T):
        if has_t and has_R:
            h = times[j] - t_prev
            if kind == MIN_ENERGY:
                ok = _min_energy_step(R, omega, K, prev, has_prev, refs, tau, h, J, J_inv, q, g, params[0], params[1])
            else:
                ok = _predictive_step(
                    R, omega, prev, has_prev, refs, tau, h, J, J_inv, params[0], params[1], params[2],
                    params[3] != 0.0,
                )  # fmt: skip
            if not (ok and _finite(R, omega, K)):  # (C5): restart from this sample
                restarted[j] = True
                omega[:] = omega0
                K[:, :] = K0
                has_R = False
        if valid[j] and not has_R:  # the first valid sample gives the attitude (Wahba, unit weights)
            R[:, :] = wahba(np.ones(refs.shape[0]), refs, values[j])
            has_R = True
        has_prev = valid[j]
        if has_prev:
            prev[:, :] = values[j]
        tau = torques[j].copy()
        t_prev = times[j]
        has_t = True
        if restarted[j]:
            out[j] = np.nan
        else:
            out[j] = omega
    state[0], state[1], state[2], state[3] = t_prev, 1.0, 1.0 if has_R else 0.0, 1.0 if has_prev else 0.0
    state[4:7] = omega
    state[7:10] = tau
    return out, restarted
