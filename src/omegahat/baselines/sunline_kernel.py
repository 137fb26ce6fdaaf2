r"""The sun-line switch-EKF over a whole log in one Numba call: :meth:`omegahat.baselines.sunline_sekf.SunlineSEKF.run`.

(S1)–(S9) of :mod:`omegahat.baselines.sunline_sekf`, whose NumPy functions are the oracle
(``tests/test_sunline_sekf.py`` checks :func:`run_log` against a loop of
:func:`omegahat.baselines.sunline_sekf.sekf_step` to 1e-10, with the interface's three unit sensors and with the
source's eight coarse sun sensors). One compiled entry point; no
fast-math; all arrays C-contiguous float64.
"""

from __future__ import annotations

import numba
import numpy as np

__all__ = ["run_log"]


@numba.njit(cache=True)
def _frame(d, axis):
    """(S1): ``C`` (body ← S) on ``d`` and the body axis ``axis`` (0: e₁, 1: e₂)."""
    e = np.zeros(3)
    e[axis] = 1.0
    c = np.array([d[1] * e[2] - d[2] * e[1], d[2] * e[0] - d[0] * e[2], d[0] * e[1] - d[1] * e[0]])
    C = np.eye(3)
    if np.linalg.norm(c) < 1e-5:
        return C
    s2 = c / np.linalg.norm(c)
    s3 = np.array([d[1] * s2[2] - d[2] * s2[1], d[2] * s2[0] - d[0] * s2[2], d[0] * s2[1] - d[1] * s2[0]])
    C[:, 0] = d / np.linalg.norm(d)
    C[:, 1] = s2
    C[:, 2] = s3 / np.linalg.norm(s3)
    return C


@numba.njit(cache=True)
def _hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@numba.njit(cache=True)
def _finite(X, x, P):
    for v in P.flat:
        if not np.isfinite(v):
            return False
    return np.all(np.isfinite(X)) and np.all(np.isfinite(x))


@numba.njit(cache=True)
def _step(X, x, P, axis, has_h, h, y, normals, q, meas_var, ekf_switch, switch_cos, as_published):
    """:func:`omegahat.baselines.sunline_sekf.sekf_step` in place on ``X``, ``x``, ``P``; returns the axis. ``y``
    holds the readings of ``normals`` (no rows: no sample)."""
    d_unit = X[:3] / np.linalg.norm(X[:3])
    if abs(d_unit[axis]) > switch_cos:  # (S2)
        new = 1 - axis
        S = _frame(d_unit, new).T @ _frame(d_unit, axis)
        W = np.eye(5)
        W[3:, 3:] = S[1:, 1:]
        X[:] = W @ X
        P[:, :] = W @ P @ W.T
        axis = new
    P_prev = P.copy()
    if has_h:  # (S3)-(S6)
        C = _frame(X[:3], axis)
        w = C @ np.array([0.0, -X[3], -X[4]])
        A = np.zeros((5, 5))
        A[:3, :3] = -_hat(w)
        A[:3, 3:] = -_hat(X[:3]) @ np.ascontiguousarray(C[:, 1:])
        Phi = np.eye(5) + h * A
        d = X[:3].copy()
        X[:3] = d - h * np.array([w[1] * d[2] - w[2] * d[1], w[2] * d[0] - w[0] * d[2], w[0] * d[1] - w[1] * d[0]])
        G = np.zeros((5, 2))
        sign = 1.0 if as_published else -1.0
        G[:3] = sign * 0.5 * h * h * _hat(X[:3]) @ np.ascontiguousarray(_frame(X[:3], axis)[:, 1:])
        G[3:] = h * np.eye(2)
        x[:] = Phi @ x
        P[:, :] = Phi @ P @ Phi.T + q * G @ G.T
    m = y.size
    if m > 0 and _finite(X, x, P):  # (S7)-(S9); a state already not finite is left to the caller's restart
        H = np.zeros((m, 5))
        H[:, :3] = normals
        S = H @ P @ H.T + meas_var * np.eye(m)
        K = np.linalg.solve(S, H @ P).T
        innovation = y - normals @ X[:3]
        if np.max(np.abs(P_prev)) > ekf_switch:
            x[:] = x + K @ (innovation - H @ x)
        else:
            x[:] = K @ innovation
            X[:] = X + x
        IKH = np.eye(5) - K @ H
        P[:, :] = IKH @ P @ IKH.T + meas_var * K @ K.T
    P[:, :] = 0.5 * (P + P.T)
    return axis


@numba.njit(cache=True)
def _start(X, d, omega0):
    """``X`` from the direction ``d`` and the body rate ``omega0``: ``(ω₂, ω₃) = −C₂₃ᵀ ω₀`` (axis e₁)."""
    X[:3] = d
    C = _frame(X[:3], 0)
    X[3] = -(C[0, 1] * omega0[0] + C[1, 1] * omega0[1] + C[2, 1] * omega0[2])
    X[4] = -(C[0, 2] * omega0[0] + C[1, 2] * omega0[1] + C[2, 2] * omega0[2])


@numba.njit(cache=True)
def run_log(times, values, use, normals, omega0, params, state, X, x, P, P0):
    """:meth:`SunlineSEKF.update` over a log. ``values (T, m)``: the readings of the sensors ``normals (m, 3)``
    (omegahat's interface: the unit direction, ``normals = I``); ``use (T, m)``: the readings to take (a sample with
    none is no sample). ``params = [q, σ², ekf_switch, switch_cos, as_published]``. In place: ``state = [t_prev,
    has_t, initialised, axis]``, ``X``, ``x``, ``P``. Not initialised: the first sample with three readings of
    ``normals = I`` starts X at that direction with (ω₂, ω₃) = −C₂₃ᵀ ``omega0``. An update whose result is not
    finite restarts the filter (x = 0, P = ``P0``, axis e₁, X from the sample as at the start): ω̂ is NaN there.
    Returns ``(ω̂ (T, 3), restarted (T,))``."""
    T = times.size
    out = np.empty((T, 3))
    restarted = np.zeros(T, dtype=np.bool_)
    t_prev, has_t, ready, axis = state[0], state[1] != 0.0, state[2] != 0.0, int(state[3])
    three = values.shape[1] == 3  # the interface's unit direction (normals = I): a sample can start X
    for j in range(T):
        rows = np.flatnonzero(use[j])
        if ready:
            y = np.empty(rows.size)
            N = np.empty((rows.size, 3))
            for k in range(rows.size):
                y[k] = values[j, rows[k]]
                N[k] = normals[rows[k]]
            axis = _step(
                X, x, P, axis, has_t, times[j] - t_prev, y, N, params[0], params[1], params[2], params[3],
                params[4] != 0.0,
            )  # fmt: skip
            if not _finite(X, x, P):  # restart from this sample
                restarted[j] = True
                x[:] = 0.0
                P[:, :] = P0
                axis = 0
                ready = False
        if not ready and three and rows.size == 3:
            _start(X, values[j], omega0)
            ready = True
            axis = 0
        t_prev = times[j]
        has_t = True
        if restarted[j]:
            out[j] = np.nan
        elif ready:
            C = _frame(X[:3], axis)
            out[j] = C @ np.array([0.0, -X[3], -X[4]])
        else:
            out[j] = np.nan  # no direction yet: no estimate
    state[0], state[1], state[2], state[3] = t_prev, 1.0, 1.0 if ready else 0.0, float(axis)
    return out, restarted
