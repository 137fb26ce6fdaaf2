r"""The sampled estimator written plainly in NumPy and SciPy: the test oracle of the compiled step.

The same realisation as :mod:`omegahat.observer.sampled` (steps (P), (I), (C), (R) and the warm start (W) of
:mod:`omegahat.observer.estimator`), written from the equations with vectors and matrices, independent of the
compiled kernels: rotations by SciPy's ``Rotation`` (exp, log, and Wahba's problem by ``align_vectors``), the
observer's terms spelled out with cross products in NumPy (:func:`omegahat.so3.cross`). Slow (a thousand samples
a second); tests compare the compiled estimator with it sample by sample.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.observer.gains import ObserverGains
from omegahat.observer.prediction import MAX_SUBSTEP_ANGLE, MAX_SUBSTEPS
from omegahat.observer.sampled import EstimatorState

__all__ = ["reference_predict", "reference_step"]


def _substeps(h, omega_hat, J_inv, tau, tau_end, max_angle) -> int:
    accel = max(np.linalg.norm(J_inv @ tau), np.linalg.norm(J_inv @ tau_end))
    angle = h * (np.linalg.norm(omega_hat) + h * accel)
    return int(min(MAX_SUBSTEPS, max(1, math.ceil(angle / max_angle))))


def _hat(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def aim_step(aim: np.ndarray, omega_hat: np.ndarray, J: np.ndarray, J_inv: np.ndarray, hs: float) -> np.ndarray:
    """(A1) over one substep: ``Γ̇ = I − W Γ − Γ A`` by its second-order Taylor step with ``W = ω̂×`` and
    ``A = J⁻¹((Jω̂)× − ω̂× J)`` frozen at the substep's start."""
    W = _hat(omega_hat)
    A = J_inv @ (_hat(J @ omega_hat) - W @ J)
    F = np.eye(3) - W @ aim - aim @ A
    return aim + hs * F - hs**2 / 2.0 * (W @ F + F @ A)


def reference_predict(
    omega_hat: ArrayLike,
    r: np.ndarray,
    e: np.ndarray,
    tau: np.ndarray,
    h: float,
    J: np.ndarray,
    J_inv: np.ndarray,
    gains: ObserverGains,
    max_angle: float = MAX_SUBSTEP_ANGLE,
    tau_end: np.ndarray | None = None,
    aim: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(P) over ``h`` with the torque ``tau`` at the start and ``tau_end`` (default: ``tau``, held) at the end,
    linear in between; ``aim`` the aim Γ so far (default 0). Returns ``(ω̂, r_pred, e_pred, aim)``."""
    tau_end = tau if tau_end is None else tau_end
    torque = lambda s: tau + (tau_end - tau) * s  # s: the fraction of h  # noqa: E731
    f = lambda w, s: J_inv @ (so3.cross(J @ w, w) + torque(s))  # Euler's equations  # noqa: E731
    dexpinv = lambda u, w: w + 0.5 * so3.cross(u, w) + so3.cross(u, so3.cross(u, w)) / 12.0  # noqa: E731
    n_sub = _substeps(h, omega_hat, J_inv, tau, tau_end, max_angle)
    hs = h / n_sub
    w = np.array(omega_hat, dtype=float)
    aim = np.zeros((3, 3)) if aim is None else aim
    D = np.eye(3)  # ΔR̂
    int_abs_w: float | np.floating = 0.0  # ∫ |ω̂| dt
    for j in range(n_sub):  # RKMK4
        sa, sm, sb = j / n_sub, (j + 0.5) / n_sub, (j + 1.0) / n_sub
        aim = aim_step(aim, w, J, J_inv, hs)
        w1 = w
        K1, L1 = hs * w1, hs * f(w1, sa)
        w2 = w + L1 / 2
        K2, L2 = hs * dexpinv(K1 / 2, w2), hs * f(w2, sm)
        w3 = w + L2 / 2
        K3, L3 = hs * dexpinv(K2 / 2, w3), hs * f(w3, sm)
        w4 = w + L3
        K4, L4 = hs * dexpinv(K3, w4), hs * f(w4, sb)
        int_abs_w += (
            hs * (np.linalg.norm(w1) + 2 * np.linalg.norm(w2) + 2 * np.linalg.norm(w3) + np.linalg.norm(w4)) / 6
        )
        D = D @ Rotation.from_rotvec((K1 + 2 * K2 + 2 * K3 + K4) / 6).as_matrix()
        w = w + (L1 + 2 * L2 + 2 * L3 + L4) / 6
    decay = np.exp(-(gains.l_offset * h + gains.l_slope * int_abs_w))  # the exact decay of the filter errors
    return w, r @ D, decay[:, None] * (e @ D), aim  # rows: (ΔR̂ᵀ r_i)ᵀ = r_iᵀ ΔR̂


def reference_step(
    state: EstimatorState,
    t: float,
    r_meas: ArrayLike | None,
    tau: ArrayLike | None,
    J: np.ndarray,
    gains: ObserverGains,
    r_hat0: ArrayLike | None = None,
    omega_hat0: ArrayLike | None = None,
    max_angle: float = MAX_SUBSTEP_ANGLE,
    warm_start: bool = False,
    torque_hold: str = "zero",
    isotropic_rate: float | None = None,
) -> EstimatorState:
    """One sample of directions ``r_meas (n, 3)`` (None: a skipped sample), no checks. ``tau`` is the torque given
    with this sample; the interval uses ``state.torque`` held (``torque_hold="zero"``) or the line from it to
    ``tau`` (``"linear"``)."""
    tau = np.zeros(3) if tau is None else np.asarray(tau, dtype=float)
    if not state.initialised:
        if r_meas is None:
            return EstimatorState(float(t), False, state.t_meas, state.omega_hat, tau, state.r, state.e)
        r_meas = np.asarray(r_meas, dtype=float)
        w0 = np.zeros(3) if omega_hat0 is None else np.asarray(omega_hat0, float)
        e0 = np.zeros_like(r_meas) if r_hat0 is None else np.asarray(r_hat0, float) - r_meas
        return EstimatorState(float(t), True, float(t), w0, tau, r_meas.copy(), e0, warm_start)
    J_inv = np.linalg.inv(J)
    if state.warm_pending:
        if r_meas is None:
            return EstimatorState(float(t), True, state.t_meas, state.omega_hat, tau, state.r, state.e, True)
        r_meas = np.asarray(r_meas, dtype=float)
        h = t - state.t_meas
        # (W): A = argmin Σ k_i |m_i − A r_i|², ω_avg = log(Aᵀ)/h, then half a step of Euler's equations
        A = Rotation.align_vectors(r_meas, state.r, weights=gains.k)[0].as_matrix()
        w_avg = Rotation.from_matrix(A.T).as_rotvec() / h
        w = w_avg + 0.5 * h * J_inv @ (so3.cross(J @ w_avg, w_avg) + state.torque)
        decay = np.exp(-(gains.l_offset * h + gains.l_slope * np.linalg.norm(w_avg) * h))
        r_pred, e_pred = state.r @ A.T, decay[:, None] * (state.e @ A.T)
        return EstimatorState(float(t), True, float(t), w, tau, r_meas.copy(), e_pred - (r_meas - r_pred))
    tau_end = tau if torque_hold == "linear" else state.torque
    w, r_pred, e_pred, aim = reference_predict(
        state.omega_hat, state.r, state.e, state.torque, t - state.t, J, J_inv, gains, max_angle, tau_end, state.aim
    )
    if r_meas is None:
        return EstimatorState(float(t), True, state.t_meas, w, tau, r_pred, e_pred, aim=aim)
    r_meas = np.asarray(r_meas, dtype=float)
    delta = r_meas - r_pred  # (I)
    r_hat = r_pred + e_pred
    k = gains.k
    y = np.sum(k[:, None] * so3.cross(delta, r_hat), axis=0)  # the plain jump of the output map, times J
    M = sum(k[i] * (r_meas[i] @ r_meas[i] * np.eye(3) - np.outer(r_meas[i], r_meas[i])) for i in range(k.size))
    G = J_inv if isotropic_rate is None else isotropic_rate * np.linalg.inv(M)
    w = w + np.linalg.solve(np.eye(3) + G @ M @ aim, G @ y)  # (C)
    return EstimatorState(float(t), True, float(t), w, tau, r_meas.copy(), e_pred - delta)  # (R)
