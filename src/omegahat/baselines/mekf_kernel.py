r"""The gyro-less MEKF compiled: the equations of :mod:`omegahat.baselines.mekf` for a whole log in one Numba call.

:meth:`omegahat.baselines.mekf.MEKF.run` checks the log (:func:`omegahat.measurements.checked_log`) and hands it to
:func:`run_log`, which applies, sample by sample, the same equations (E3)–(E8) as the readable NumPy functions of
:mod:`omegahat.baselines.mekf` (the oracle these are tested against), built from the compiled primitives of
:mod:`omegahat.kernels`:

* (E3) :func:`process_model`, with ``hat`` of :mod:`omegahat.kernels.rotation`;
* (E4) :func:`van_loan`: the 12 × 12 Van Loan matrix exponentiated by ``expm_block_upper`` of
  :mod:`omegahat.kernels.linalg` (the degree-12 Taylor polynomial and the scaling of ``mekf.expm_small``, with the
  products skipping the zero lower-left block); the nominal state by :func:`nominal_step`: the CF4 step
  ``cf4_increment`` of :mod:`omegahat.kernels.dynamics` (dynamic model, torque held) or ``R̂ Exp(ω̂ h)``
  (kinematic); R̂ is carried as a matrix and multiplied by exact rotations, as in NumPy;
* (E5) :func:`attitude_fix`: the quaternion of ``R̂ᵀ R_m`` by ``quat_from_matrix`` (Shepperd's method with SciPy's
  pivot and sign rules); (E6) :func:`vector_fix`;
* (E7) in Joseph form with ``S⁻¹`` by Cholesky (``solve_spd``) and the reset (E8): :func:`update`;
* the first valid fix initialises R̂: the sample itself, or Wahba's least-squares attitude from the directions
  (``wahba`` of :mod:`omegahat.kernels.rotation`, unit weights).

The sub-step rule is NumPy's, ``n_sub = max(1, ⌈h/max_step − 1e-12⌉)``. ``tests/test_mekf.py`` checks that ``run``
equals a loop of ``MEKF.update`` (the NumPy path) to 1e-10 relative, with torques, directions, skipped samples and
gaps of several sub-steps. All arrays are C-contiguous float64.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels.dynamics import cf4_increment
from omegahat.kernels.linalg import expm_block_upper, mm, solve_spd, transpose
from omegahat.kernels.rotation import (
    exp_matrix,
    hat,
    matrix_from_quat,
    quat_from_matrix,
    quat_from_rotvec,
    store,
    wahba,
)
from omegahat.kernels.vec3 import mat3, matvec, matvec_transposed

__all__ = ["attitude_fix", "nominal_step", "process_model", "propagate", "run_log", "update", "van_loan", "vector_fix"]


@numba.njit(cache=True)
def process_model(w, J, J_inv, dynamic, F, G):
    """(E3) at ω̂ = ``w`` into ``F (6, 6)``, ``G (6, 3)``: ``F = [[−ω̂×, I], [0, A]]``, ``A = J⁻¹((Jω̂)× − ω̂× J)``
    (dynamic) or 0, ``G = [[0], [J⁻¹]]`` (dynamic) or ``[[0], [I]]`` (kinematic)."""
    F[:, :] = 0.0
    G[:, :] = 0.0
    W = hat(w)
    for i in range(3):
        F[i, 3 + i] = 1.0
        for j in range(3):
            F[i, j] = -W[i, j]
    if dynamic:
        X = hat(np.array(matvec(mat3(J), w[0], w[1], w[2])))
        WJ = mm(W, J)
        for i in range(3):
            for j in range(3):
                X[i, j] -= WJ[i, j]
        A = mm(J_inv, X)
        for i in range(3):
            for j in range(3):
                F[3 + i, 3 + j] = A[i, j]
                G[3 + i, j] = J_inv[i, j]
    else:
        for i in range(3):
            G[3 + i, i] = 1.0


@numba.njit(cache=True)
def van_loan(F, G, q, dt):
    """(E4): ``B = expm([[−F, q G Gᵀ], [0, Fᵀ]] dt)``, ``Φ = B₂₂ᵀ``, ``Q_d = Φ B₁₂``; returns ``(Φ, Q_d)``."""
    Qc = mm(G, transpose(G))
    M = np.zeros((12, 12))
    for i in range(6):
        for j in range(6):
            M[i, j] = -F[i, j] * dt
            M[i, 6 + j] = q * Qc[i, j] * dt
            M[6 + i, 6 + j] = F[j, i] * dt
    B = expm_block_upper(M, 6)
    Phi = np.empty((6, 6))
    B12 = np.empty((6, 6))
    for i in range(6):
        for j in range(6):
            Phi[i, j] = B[6 + j, 6 + i]
            B12[i, j] = B[i, 6 + j]
    return Phi, mm(Phi, B12)


@numba.njit(cache=True)
def nominal_step(R, w, dt, tau, J, J_inv, dynamic, E):
    """The nominal state over ``dt``: CF4 with the torque held (dynamic) or ``R̂ Exp(ω̂ dt)`` (kinematic, ω̂
    constant). ``w`` is updated in place; returns the new R̂. ``E`` is 3×3 scratch space."""
    if dynamic:
        p, w_next = cf4_increment(mat3(J), mat3(J_inv), w[0], w[1], w[2], dt, tau, tau, tau)
        w[0], w[1], w[2] = w_next
    else:
        p = quat_from_rotvec(dt * w[0], dt * w[1], dt * w[2])
    store(matrix_from_quat(p[0], p[1], p[2], p[3]), E)
    return mm(R, E)


@numba.njit(cache=True)
def propagate(R, omega, P, h, tau, J, J_inv, q, dynamic, max_step):
    """(E4) over ``h`` with ``tau`` held, in NumPy's sub-steps; returns ``(R, ω, P)`` (new arrays)."""
    n_sub = max(1, int(np.ceil(h / max_step - 1e-12)))
    dt = h / n_sub
    F = np.empty((6, 6))
    G = np.empty((6, 3))
    E = np.empty((3, 3))
    w = omega.copy()
    for _ in range(n_sub):
        process_model(w, J, J_inv, dynamic, F, G)  # at the sub-step's start, as the NumPy path
        Phi, Qd = van_loan(F, G, q, dt)
        R = nominal_step(R, w, dt, tau, J, J_inv, dynamic, E)
        P = mm(mm(Phi, P), transpose(Phi))  # P ← Φ P Φᵀ + Q_d (Q_d symmetrised as in mekf.discretize)
        for i in range(6):
            for j in range(6):
                P[i, j] += 0.5 * (Qd[i, j] + Qd[j, i])
    for i in range(6):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])
    return R, w, P


@numba.njit(cache=True)
def attitude_fix(R, R_meas):
    """(E5): ``z = 2 dq_vec / dq_w`` with dq the quaternion of ``R̂ᵀ R_m`` (w ≥ 0), and ``H = [I, 0]``."""
    dq = quat_from_matrix(mm(transpose(R), R_meas))
    z = np.empty(3)
    H = np.zeros((3, 6))
    for c in range(3):
        z[c] = 2.0 * dq[c] / dq[3]
        H[c, c] = 1.0
    return z, H


@numba.njit(cache=True)
def vector_fix(R, b, references):
    """(E6): ``z_i = b_i − R̂ᵀ v_i`` stacked ``(3n,)`` and ``H_i = [b̂_i×, 0]``, ``(3n, 6)``."""
    n = references.shape[0]
    z = np.empty(3 * n)
    H = np.zeros((3 * n, 6))
    M = mat3(R)
    bh = np.empty(3)
    for r in range(n):
        bh[0], bh[1], bh[2] = matvec_transposed(M, references[r, 0], references[r, 1], references[r, 2])  # R̂ᵀ v_r
        for c in range(3):
            z[3 * r + c] = b[r, c] - bh[c]
        B = hat(bh)
        for c in range(3):
            for d in range(3):
                H[3 * r + c, d] = B[c, d]
    return z, H


@numba.njit(cache=True)
def update(R, omega, P, z, H, meas_var):
    """(E7) in Joseph form, then the reset (E8); returns ``(R, ω, P)`` (new arrays)."""
    m = z.size
    HP = mm(H, P)
    S = mm(HP, transpose(H))
    for i in range(m):
        S[i, i] += meas_var
    K = transpose(solve_spd(S, HP))  # P Hᵀ S⁻¹ (S and P symmetric)
    dx = np.zeros(6)
    for i in range(6):
        for j in range(m):
            dx[i] += K[i, j] * z[j]
    IKH = mm(K, H)
    for i in range(6):
        for j in range(6):
            IKH[i, j] = (1.0 if i == j else 0.0) - IKH[i, j]
    P = mm(mm(IKH, P), transpose(IKH))
    KKt = mm(K, transpose(K))
    for i in range(6):
        for j in range(6):
            P[i, j] += meas_var * KKt[i, j]
    for i in range(6):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])
    w = np.empty(3)
    for i in range(3):
        w[i] = omega[i] + dx[3 + i]
    E = np.empty((3, 3))
    store(exp_matrix(dx[0], dx[1], dx[2]), E)
    return mm(R, E), w, P


@numba.njit(cache=True)
def run_log(
    times, meas, valid, torques, references, directions, dynamic, J, J_inv, q, meas_var, max_step, state, R, P, tau
):
    """``MEKF.update`` over a checked log. ``meas``: rotation matrices ``(T, 3, 3)`` or unit directions
    ``(T, n, 3)``; ``valid`` the usable samples. The filter's state goes in and comes out: ``state = [t_prev,
    has_t, has_R, ω̂ (3)]`` (updated in place), ``R`` (ignored while ``has_R`` is 0), ``P``, ``tau`` the torque
    held from ``t_prev``. Returns ``(ω̂ (T, 3), R, P, n_skipped)``."""
    T = times.size
    out = np.empty((T, 3))
    R, P, tau = R.copy(), P.copy(), tau.copy()
    omega = state[3:6].copy()
    t_prev, has_t, has_R = state[0], state[1] != 0.0, state[2] != 0.0
    n_skipped = 0
    weights = np.ones(references.shape[0])
    for j in range(T):
        if has_t and has_R:  # (E4) with the previous sample's torque held
            R, omega, P = propagate(R, omega, P, times[j] - t_prev, tau, J, J_inv, q, dynamic, max_step)
        if not valid[j]:
            n_skipped += 1
        elif not has_R:  # the first fix initialises the attitude
            R = wahba(weights, references, meas[j]) if directions else meas[j].copy()
            has_R = True
        else:
            if directions:
                z, H = vector_fix(R, meas[j], references)
            else:
                z, H = attitude_fix(R, meas[j])
            R, omega, P = update(R, omega, P, z, H, meas_var)
        t_prev = times[j]
        has_t = True
        tau = torques[j].copy()
        for c in range(3):
            out[j, c] = omega[c]
    state[0], state[1], state[2] = t_prev, 1.0 if has_t else 0.0, 1.0 if has_R else 0.0
    state[3:6] = omega
    return out, R, P, n_skipped
