r"""Gyro-less multiplicative extended Kalman filter (MEKF) with the angular velocity in the state.

References: E. J. Lefferts, F. L. Markley, M. D. Shuster, "Kalman Filtering for Spacecraft Attitude
Estimation", JGCD 5(5), 1982; F. L. Markley, J. L. Crassidis, *Fundamentals of Spacecraft Attitude
Determination and Control*, Springer, 2014. Equations as in ``shared/design/baselines.md`` §3, written here on
rotation matrices (``R`` body → inertial, ω in body axes)::

    nominal state   R̂, ω̂;  error state x = [δθ; δω] with R = R̂ Exp(δθ), ω = ω̂ + δω               (E1)
    process         dynamic:   J ω̇ = (Jω) × ω + τ + w_τ,  w_τ white with PSD q I  (N²·m²·s)
                    kinematic: ω̇ = w,                     w white with PSD q I  (rad²/s³)           (E2)
    linearised      δθ̇ = −ω̂× δθ + δω                                                              (E3)
                    δω̇ = J⁻¹((Jω̂)× − ω̂× J) δω + J⁻¹ w_τ   (dynamic)      δω̇ = w   (kinematic)
                    F = [[−ω̂×, I], [0, A]],  G = [[0], [J⁻¹]] (dynamic) or [[0], [I]] (kinematic),
                    A = J⁻¹((Jω̂)× − ω̂× J) (dynamic) or 0 (kinematic)
    propagate h     sub-steps of at most ``max_step``: ω̂ by RK4 of the Euler equations and R̂ by the
                    matching fourth-order Lie-group step (dynamic); R̂ ← R̂ Exp(ω̂ h) (kinematic);
                    Van Loan: B = expm([[−F, G Q Gᵀ], [0, Fᵀ]] h), Φ = B₂₂ᵀ, Q_d = Φ B₁₂;
                    P ← Φ P Φᵀ + Q_d                                                                (E4)
    attitude fix    R_m = R Exp(ν), ν ~ N(0, σ² I); dq = q̂ᶜ ⊗ q_m (the quaternion of R̂ᵀ R_m, scalar ≥ 0);
                    z = 2 dq_vec / dq_w;  H = [I, 0];  R_meas = σ² I                                 (E5)
    vector fix      b_i = Rᵀ v_i + ν_i, ν_i ~ N(0, σ² I); b̂_i = R̂ᵀ v_i; z_i = b_i − b̂_i;
                    H_i = [b̂_i×, 0];  R_meas = σ² I                                                  (E6)
    update          S = H P Hᵀ + R_meas; K = P Hᵀ S⁻¹; δx̂ = K z;
                    P ← (I − K H) P (I − K H)ᵀ + K R_meas Kᵀ (Joseph form)                           (E7)
    reset           R̂ ← R̂ Exp(δθ̂);  ω̂ ← ω̂ + δω̂                                                    (E8)

(E6) follows from ``Rᵀ v = Exp(−δθ) R̂ᵀ v ≈ b̂ + b̂ × δθ``. The filter converges only locally: started far from
the truth with a small covariance it can lock on a wrong solution or diverge. The known torque passed with a
sample is held over the interval that follows it (the same convention as the sampled Sarras estimator).

Initial state: ``R0`` if given, else the first valid measurement (the attitude itself, or the least-squares
attitude from the directions by SVD — Wahba's problem), with ``P_θθ = sigma_theta0² I``; ``omega0`` with
``P_ωω = sigma_omega0² I``.

The pure NumPy functions below are the filter, written to be read; :class:`MEKF` is a thin stateful shell over
them, and :meth:`MEKF.update` (one sample) runs on them: they are the oracle.

Compiled path. :meth:`MEKF.run` checks the whole log first (times, torques, samples: a bad one is named with
its index and value and the state is left unchanged), then hands it to one Numba kernel (``_run_kernel``,
``cache=True``) that applies the same equations sample by sample and returns the state as ``update`` would
leave it (``R, omega, P, t, _tau, n_skipped``), so that ``update`` can continue after ``run``; like the
default ``Estimator.run`` it does not reset. The kernel keeps the NumPy path's choices: the same sub-step rule
``n_sub = max(1, ⌈h/max_step − 1e-12⌉)``; (E3) then the Van Loan exponential (E4) by the same degree-12 Taylor
scaling and squaring (``_expm_block_upper``, which skips the products with the zero lower-left block of the
12 × 12 matrix: 3 of 8 block products); the CF4 step of :mod:`omegahat.simulation.rigid_body` for the dynamic model's
nominal state (its compiled ``_cf4_increment``, shared with the integrator); R̂ carried as a matrix and
multiplied by exact rotations as in NumPy; (E5) from the quaternion of ``R̂ᵀ R_m`` by Shepperd's method with
SciPy's pivot and sign rules (``_quat_of_matrix``); (E7) in Joseph form (S⁻¹ by Cholesky) and the reset (E8).
The first valid sample's attitude (the sample, or :func:`_wahba`) is computed in Python before the call.
Agreement with a loop of ``update`` (``tests/test_mekf.py``): ω̂ and P within 1e-10 relative (measured ω̂
3e-15 to 2e-13, P below 1e-15) with torques, directions, NaN samples and gaps of several sub-steps.

Cost, ``python benchmarks/mekf_speed.py`` (300 s logs, one core of a shared 2-core machine): ``run`` takes
9–12 µs per sample at 285.7 Hz (one sub-step) and 29–38 µs at 5 Hz (four sub-steps of 0.05 s), dynamic or
kinematic, attitude fixes or three directions; the NumPy ``update`` loop takes 0.45–1.2 ms and 1.0–4.3 ms,
about 50 to 110 times more. Most of the kernel's time is the 12 × 12 exponential. First call in a fresh
environment: about 10 s of compilation, cached afterwards.
"""

from __future__ import annotations

import numba
import numpy as np
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.baselines.differencing import _check_times, as_attitude_matrices, as_attitude_sample
from omegahat.interface import Estimator
from omegahat.simulation.rigid_body import (
    RigidBody,
    Torque,
    _cf4_increment,
    _quat_exp,
    _quat_of_matrix,
    _quat_to_matrix,
    cf4_step,
)
from omegahat.validation import _fmt, as_directions, as_inertia, as_positive, as_vector3

__all__ = [
    "MEKF",
    "MODELS",
    "attitude_innovation",
    "discretize",
    "expm_small",
    "process_jacobian",
    "propagate",
    "update",
    "vector_innovation",
]

MODELS = ("dynamic", "kinematic")


def process_jacobian(omega_hat, J, J_inv, model):
    """F and G of (E3), shapes ``(6, 6)`` and ``(6, 3)``."""
    F = np.zeros((6, 6))
    G = np.zeros((6, 3))
    F[:3, :3] = -so3.hat(omega_hat)
    F[:3, 3:] = np.eye(3)
    if model == "dynamic":
        F[3:, 3:] = J_inv @ (so3.hat(J @ omega_hat) - so3.hat(omega_hat) @ J)
        G[3:] = J_inv
    else:
        G[3:] = np.eye(3)
    return F, G


def expm_small(M):
    """Matrix exponential by scaling and squaring with a degree-12 Taylor polynomial, in plain NumPy.

    Scaled so that ``‖M/2^s‖₁ ≤ 0.5``, where the truncation error is below ``0.5¹³/13! ≈ 2e-14`` relative.
    Used instead of ``scipy.linalg.expm`` because, on a machine whose cores are busy, SciPy's compiled Padé
    step for a 12 × 12 matrix was measured at 2 ms per call against 20 µs single-threaded; this takes about
    50 µs either way. Tested against ``scipy.linalg.expm``. The compiled twin used by :meth:`MEKF.run` is
    ``_expm_block_upper`` (the same polynomial, scaling and squarings).
    """
    norm = np.abs(M).sum(axis=0).max()
    s = max(0, int(np.ceil(np.log2(norm / 0.5)))) if norm > 0.5 else 0
    A = M / 2.0**s
    E = np.eye(M.shape[0])
    term = np.eye(M.shape[0])
    for k in range(1, 13):
        term = term @ A / k
        E = E + term
    for _ in range(s):
        E = E @ E
    return E


def discretize(F, G, q, h):
    """Van Loan (E4): transition Φ and process covariance Q_d over ``h`` for white noise of PSD ``q I``."""
    n = F.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -F
    M[:n, n:] = q * (G @ G.T)
    M[n:, n:] = F.T
    B = expm_small(M * h)
    Phi = B[n:, n:].T
    Qd = Phi @ B[:n, n:]
    return Phi, 0.5 * (Qd + Qd.T)


def propagate(R, omega, P, h, tau, body, q, model, max_step):
    """(E4) over ``h`` seconds with the torque ``tau`` held; returns ``(R, omega, P)``.

    The nominal state of the dynamic model is advanced by :func:`omegahat.simulation.rigid_body.cf4_step` (RK4 for ω and
    a fourth-order commutator-free step for R); the kinematic model's ω̂ is constant, so R̂ ← R̂ Exp(ω̂ h) is
    exact.
    """
    n_sub = max(1, int(np.ceil(h / max_step - 1e-12)))
    dt = h / n_sub
    torque = Torque.constant(tau)
    for _ in range(n_sub):
        F, G = process_jacobian(omega, body.J, body.J_inv, model)
        Phi, Qd = discretize(F, G, q, dt)
        if model == "dynamic":
            R, omega = cf4_step(body, R, omega, 0.0, dt, torque)
        else:
            R = R @ so3.exp(dt * omega)
        P = Phi @ P @ Phi.T + Qd
    return R, omega, 0.5 * (P + P.T)


def attitude_innovation(R_hat, R_meas):
    """(E5): ``z = 2 dq_vec / dq_w`` of ``dq`` = quaternion of ``R̂ᵀ R_m`` (scalar ≥ 0), and ``H = [I, 0]``."""
    dq = Rotation.from_matrix(R_hat.T @ R_meas).as_quat(canonical=True)  # scalar last, w ≥ 0
    z = 2.0 * dq[:3] / dq[3]
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    return z, H


def vector_innovation(R_hat, b_meas, references):
    """(E6): ``z = b − R̂ᵀ v`` stacked ``(3n,)`` and ``H`` ``(3n, 6)``."""
    b_hat = references @ R_hat  # rows: R̂ᵀ v_i
    z = (b_meas - b_hat).ravel()
    H = np.zeros((3 * len(references), 6))
    for i, bh in enumerate(b_hat):
        H[3 * i : 3 * i + 3, :3] = so3.hat(bh)
    return z, H


def update(R, omega, P, z, H, meas_var):
    """(E7) then the reset (E8); returns ``(R, omega, P)``."""
    S = H @ P @ H.T + meas_var * np.eye(H.shape[0])
    K = np.linalg.solve(S, H @ P).T  # P Hᵀ S⁻¹ (S and P symmetric)
    dx = K @ z
    IKH = np.eye(6) - K @ H
    P = IKH @ P @ IKH.T + meas_var * (K @ K.T)
    return R @ so3.exp(dx[:3]), omega + dx[3:], 0.5 * (P + P.T)


def _wahba(b, references):
    """Least-squares attitude from body directions: argmax_R Σ b_iᵀ Rᵀ v_i by SVD (Markley 1988)."""
    Bm = references.T @ (b / np.linalg.norm(b, axis=1, keepdims=True))  # Σ v_i b_iᵀ
    U, _, Vt = np.linalg.svd(Bm)
    d = np.linalg.det(U) * np.linalg.det(Vt)
    return U @ np.diag([1.0, 1.0, d]) @ Vt


# ------------------------------------------------------------------------------------------------------------
# Compiled kernel: the same equations, one call for a whole log (MEKF.run). Tested against the functions above.
# Small matrices are multiplied by explicit loops (no BLAS call overhead); all arrays are C-contiguous float64.


@numba.njit(cache=True)
def _mm(A, B):
    """A @ B by loops (summed over k in order, like the textbook product)."""
    n, m, p = A.shape[0], A.shape[1], B.shape[1]
    C = np.zeros((n, p))
    for i in range(n):
        for k in range(m):
            a = A[i, k]
            for j in range(p):
                C[i, j] += a * B[k, j]
    return C


@numba.njit(cache=True)
def _hat(v):
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 2] = -v[2], v[1], -v[0]
    S[1, 0], S[2, 0], S[2, 1] = v[2], -v[1], v[0]
    return S


@numba.njit(cache=True)
def _transpose(A):
    n, m = A.shape
    T = np.empty((m, n))
    for i in range(n):
        for j in range(m):
            T[j, i] = A[i, j]
    return T


@numba.njit(cache=True)
def _mm_block_upper(A, B, C, n):
    """C = A @ B for ``2n × 2n`` block upper-triangular A, B (lower-left blocks exactly 0), which the Van Loan
    matrix of (E4) and all its powers are: the products with the zero blocks are skipped (3 of the 8 block
    products are done); every other term is summed in the order of the textbook full product, to which the
    result is identical (the skipped terms are exact zeros)."""
    N = 2 * n
    for i in range(N):
        for j in range(N):
            C[i, j] = 0.0
    for i in range(n):
        for k in range(N):
            a = A[i, k]
            for j in range(0 if k < n else n, N):
                C[i, j] += a * B[k, j]
    for i in range(n, N):
        for k in range(n, N):
            a = A[i, k]
            for j in range(n, N):
                C[i, j] += a * B[k, j]


@numba.njit(cache=True)
def _expm_block_upper(M, n):
    """:func:`expm_small` (degree-12 Taylor, scaled to ‖M/2^s‖₁ ≤ 0.5, squared s times) of a ``2n × 2n`` block
    upper-triangular M, with :func:`_mm_block_upper` for the products."""
    N = M.shape[0]
    norm = 0.0
    for j in range(N):
        c = 0.0
        for i in range(N):
            c += abs(M[i, j])
        norm = max(norm, c)
    s = max(0, int(np.ceil(np.log2(norm / 0.5)))) if norm > 0.5 else 0
    A = M / 2.0**s
    E = np.eye(N)
    term = np.eye(N)
    prod = np.empty((N, N))
    for k in range(1, 13):
        _mm_block_upper(term, A, prod, n)
        term = prod / k
        E = E + term
    for _ in range(s):
        _mm_block_upper(E, E, prod, n)
        E = prod.copy()
    return E


@numba.njit(cache=True)
def _propagate_c(R, omega, P, h, tau, J, J_inv, q, dynamic, max_step):
    """:func:`propagate` (E4): same sub-steps, Jacobian (E3), Van Loan discretisation and nominal step."""
    n_sub = max(1, int(np.ceil(h / max_step - 1e-12)))
    dt = h / n_sub
    F = np.zeros((6, 6))
    G = np.zeros((6, 3))
    M = np.zeros((12, 12))
    w = omega.copy()
    for _ in range(n_sub):
        # (E3): F = [[−ω̂×, I], [0, A]], A = J⁻¹((Jω̂)× − ω̂× J) (dynamic) or 0; G = [[0], [J⁻¹ or I]]
        W = _hat(w)
        for i in range(3):
            F[i, 3 + i] = 1.0
            for j in range(3):
                F[i, j] = -W[i, j]
        if dynamic:
            Jw = np.zeros(3)
            for i in range(3):
                for j in range(3):
                    Jw[i] += J[i, j] * w[j]
            X = _hat(Jw)
            WJ = _mm(W, J)
            for i in range(3):
                for j in range(3):
                    X[i, j] -= WJ[i, j]
            A = _mm(J_inv, X)
            for i in range(3):
                for j in range(3):
                    F[3 + i, 3 + j] = A[i, j]
                    G[3 + i, j] = J_inv[i, j]
        else:
            for i in range(3):
                G[3 + i, i] = 1.0
        # Van Loan (E4): B = expm([[−F, q G Gᵀ], [0, Fᵀ]] h), Φ = B₂₂ᵀ, Q_d = Φ B₁₂
        Qc = _mm(G, _transpose(G))
        for i in range(6):
            for j in range(6):
                M[i, j] = -F[i, j] * dt
                M[i, 6 + j] = q * Qc[i, j] * dt
                M[6 + i, 6 + j] = F[j, i] * dt
        B = _expm_block_upper(M, 6)
        Phi = np.empty((6, 6))
        B12 = np.empty((6, 6))
        for i in range(6):
            for j in range(6):
                Phi[i, j] = B[6 + j, 6 + i]
                B12[i, j] = B[i, 6 + j]
        Qd = _mm(Phi, B12)
        # nominal state: CF4 with the torque held (dynamic) or R̂ Exp(ω̂ dt) (kinematic)
        if dynamic:
            p, w = _cf4_increment(J, J_inv, w, dt, tau, tau, tau)
        else:
            p = _quat_exp(dt * w[0], dt * w[1], dt * w[2])
        R = _mm(R, _quat_to_matrix(p))
        # P ← Φ P Φᵀ + Q_d (Q_d symmetrised as in discretize)
        P = _mm(_mm(Phi, P), _transpose(Phi))
        for i in range(6):
            for j in range(6):
                P[i, j] += 0.5 * (Qd[i, j] + Qd[j, i])
    for i in range(6):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])
    return R, w, P


@numba.njit(cache=True)
def _solve_spd(S, B):
    """S⁻¹ B for symmetric positive definite S, by Cholesky S = L Lᵀ and two triangular solves."""
    m, p = B.shape
    L = np.zeros((m, m))
    for j in range(m):
        d = S[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        L[j, j] = np.sqrt(d)
        for i in range(j + 1, m):
            v = S[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
    X = B.copy()
    for c in range(p):
        for i in range(m):  # L y = b
            v = X[i, c]
            for k in range(i):
                v -= L[i, k] * X[k, c]
            X[i, c] = v / L[i, i]
        for i in range(m - 1, -1, -1):  # Lᵀ x = y
            v = X[i, c]
            for k in range(i + 1, m):
                v -= L[k, i] * X[k, c]
            X[i, c] = v / L[i, i]
    return X


@numba.njit(cache=True)
def _update_c(R, omega, P, z, H, meas_var):
    """:func:`update`: (E7) in Joseph form, then the reset (E8)."""
    m = z.size
    HP = _mm(H, P)
    S = _mm(HP, _transpose(H))
    for i in range(m):
        S[i, i] += meas_var
    K = _transpose(_solve_spd(S, HP))  # P Hᵀ S⁻¹ (S and P symmetric)
    dx = np.zeros(6)
    for i in range(6):
        for j in range(m):
            dx[i] += K[i, j] * z[j]
    IKH = _mm(K, H)
    for i in range(6):
        for j in range(6):
            IKH[i, j] = (1.0 if i == j else 0.0) - IKH[i, j]
    P = _mm(_mm(IKH, P), _transpose(IKH))
    KKt = _mm(K, _transpose(K))
    for i in range(6):
        for j in range(6):
            P[i, j] += meas_var * KKt[i, j]
    for i in range(6):
        for j in range(i):
            P[i, j] = P[j, i] = 0.5 * (P[i, j] + P[j, i])
    w = np.empty(3)
    for i in range(3):
        w[i] = omega[i] + dx[3 + i]
    return _mm(R, _quat_to_matrix(_quat_exp(dx[0], dx[1], dx[2]))), w, P


@numba.njit(cache=True)
def _run_kernel(
    times,
    meas,
    valid,
    torques,
    references,
    directions,
    dynamic,
    J,
    J_inv,
    q,
    meas_var,
    max_step,
    R,
    j_init,
    omega,
    P,
    t_prev,
    has_t,
    tau,
):
    """:meth:`MEKF.update` over a checked log; the filter state goes in and comes out (``has_t`` says whether
    ``t_prev`` is set). ``meas`` is ``(T, 3, 3)`` attitudes or ``(T, n, 3)`` directions, ``valid`` marks the
    finite samples. ``R`` is the attitude, or, when it is not set yet, the first fix's attitude (computed by the
    caller: the sample itself or :func:`_wahba`) and ``j_init`` that sample's index (−1 when R is set).
    Returns ``(ω̂ (T, 3), R, ω, P, n_skipped)``."""
    T = times.size
    out = np.empty((T, 3))
    R, omega, P, tau = R.copy(), omega.copy(), P.copy(), tau.copy()
    n_skipped = 0
    H_att = np.zeros((3, 6))
    for i in range(3):
        H_att[i, i] = 1.0
    n_ref = references.shape[0]
    has_R = j_init < 0
    for j in range(T):
        if has_t and has_R:  # (E4) with the previous sample's torque held
            R, omega, P = _propagate_c(R, omega, P, times[j] - t_prev, tau, J, J_inv, q, dynamic, max_step)
        if not valid[j]:
            n_skipped += 1
        elif not has_R:  # the first fix initialises the attitude (R holds it already)
            has_R = True
        else:
            if directions:  # (E6): z_i = b_i − R̂ᵀ v_i, H_i = [b̂_i×, 0]
                z = np.empty(3 * n_ref)
                H = np.zeros((3 * n_ref, 6))
                for r in range(n_ref):
                    bh = np.empty(3)  # R̂ᵀ v_r
                    for c in range(3):
                        bh[c] = references[r, 0] * R[0, c] + references[r, 1] * R[1, c] + references[r, 2] * R[2, c]
                        z[3 * r + c] = meas[j, r, c] - bh[c]
                    B = _hat(bh)
                    for c in range(3):
                        for d in range(3):
                            H[3 * r + c, d] = B[c, d]
            else:  # (E5): z = 2 dq_vec / dq_w, dq the quaternion of R̂ᵀ R_m
                dq = _quat_of_matrix(_mm(_transpose(R), meas[j]))
                z = np.empty(3)
                for c in range(3):
                    z[c] = 2.0 * dq[c] / dq[3]
                H = H_att
            R, omega, P = _update_c(R, omega, P, z, H, meas_var)
        t_prev = times[j]
        has_t = True
        tau = torques[j].copy()
        for c in range(3):
            out[j, c] = omega[c]
    return out, R, omega, P, n_skipped


class MEKF(Estimator):
    """The gyro-less MEKF of the module docstring behind the estimator interface.

    Parameters
    ----------
    J : inertia (3 numbers, 9 numbers or 3×3); needed by the dynamic model, ignored by the kinematic one.
    model : ``"dynamic"`` (J and τ known; q is the torque-noise PSD, N²·m²·s) or ``"kinematic"`` (ω̇ white
        noise; q in rad²/s³).
    q : process-noise PSD (the filter's one tuning knob).
    measurement_sigma : standard deviation of the attitude noise (rad per axis) or of each direction
        component.
    references : ``None`` for attitude measurements, else the known inertial directions ``(n, 3)``; samples
        are then body-frame measurements ``(n, 3)``.
    omega0, sigma_omega0 : initial rate estimate (rad/s) and its standard deviation.
    R0, sigma_theta0 : initial attitude (``None``: the first valid measurement) and its standard deviation
        (rad; default ``measurement_sigma`` for attitude fixes, 0.1 rad for directions).
    max_step : longest propagation sub-step, s.
    scalar_first, tol : quaternion order and how far a measurement may be from a rotation.
    """

    def __init__(
        self,
        J=None,
        model="dynamic",
        q=1e-4,
        measurement_sigma=1e-3,
        references=None,
        omega0=(0.0, 0.0, 0.0),
        sigma_omega0=1.0,
        R0=None,
        sigma_theta0=None,
        max_step=0.05,
        scalar_first=False,
        tol=1e-4,
    ):
        if model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}; got {model!r}")
        self.model = model
        if model == "dynamic" and J is None:
            raise ValueError("J must be given for the dynamic model (use model='kinematic' when it is unknown)")
        self.body = RigidBody(as_inertia(np.eye(3) if J is None else J))
        self.q = float(as_positive(q, "q")[0])
        self.measurement_sigma = float(as_positive(measurement_sigma, "measurement_sigma")[0])
        self.references = None if references is None else as_directions(references, "references")
        self.omega0 = as_vector3(omega0, "omega0")
        self.sigma_omega0 = float(as_positive(sigma_omega0, "sigma_omega0")[0])
        self.R0 = None if R0 is None else as_attitude_matrices(np.asarray(R0, float)[None], name="R0")[0]
        if sigma_theta0 is None:
            sigma_theta0 = self.measurement_sigma if self.references is None else 0.1
        self.sigma_theta0 = float(as_positive(sigma_theta0, "sigma_theta0")[0])
        self.max_step = float(as_positive(max_step, "max_step")[0])
        self.scalar_first = bool(scalar_first)
        self.tol = float(tol)
        self.reset()

    def reset(self) -> None:
        self.R = None if self.R0 is None else self.R0.copy()
        self.omega = self.omega0.copy()
        self.P = np.diag([self.sigma_theta0**2] * 3 + [self.sigma_omega0**2] * 3)
        self.t = None
        self._tau = np.zeros(3)
        self.n_skipped = 0

    def _measurement(self, m):
        """Checked sample: a rotation matrix, body directions ``(n, 3)``, or None when not finite."""
        if self.references is None:
            return as_attitude_sample(m, self.scalar_first, self.tol)
        a = np.asarray(m, dtype=float)
        n = len(self.references)
        if a.shape != (n, 3):
            raise ValueError(f"measurement must be {n} body-frame directions, shape ({n}, 3); got {a.shape}")
        return a if np.all(np.isfinite(a)) else None

    def update(self, t, measurement, torque=None) -> np.ndarray:
        """Propagate to ``t`` (with the previous sample's torque held), fuse the sample, return ω̂(t) ``(3,)``.

        A non-finite sample is skipped (propagation only, counted in ``n_skipped``).
        """
        t = float(t)
        if not np.isfinite(t):
            raise ValueError(f"t must be finite; got {t!r}")
        if self.t is not None and t <= self.t:
            raise ValueError(f"t must increase strictly; got t = {t!r} after t = {self.t!r}")
        tau = np.zeros(3) if torque is None else np.asarray(torque, dtype=float)
        if tau.shape != (3,) or not np.all(np.isfinite(tau)):
            raise ValueError(f"torque must be 3 finite numbers; got {_fmt(tau)}")
        m = self._measurement(measurement)  # raises before any state changes
        R, omega, P = self.R, self.omega, self.P
        if self.t is not None and R is not None:
            R, omega, P = propagate(R, omega, P, t - self.t, self._tau, self.body, self.q, self.model, self.max_step)
        if m is None:
            self.n_skipped += 1
        elif R is None:  # first fix initialises the attitude
            R = m if self.references is None else _wahba(m, self.references)
        else:
            if self.references is None:
                z, H = attitude_innovation(R, m)
            else:
                z, H = vector_innovation(R, m, self.references)
            R, omega, P = update(R, omega, P, z, H, self.measurement_sigma**2)
        self.R, self.omega, self.P, self.t, self._tau = R, omega, P, t, tau
        return self.omega.copy()

    def _measurement_log(self, measurements):
        """Checked log: ``(T, 3, 3)`` rotation matrices or ``(T, n, 3)`` directions (float, C order) and the
        finite samples ``(T,)``; raises ``ValueError`` naming the first bad sample and its value."""
        if self.references is None:
            try:
                R = as_attitude_matrices(measurements, self.scalar_first, self.tol, name="measurements")
            except (TypeError, ValueError) as err:  # e.g. a list of Rotation objects or of mixed types
                if isinstance(err, ValueError) and "not a " in str(err):
                    raise
                T = len(measurements)
                R = np.empty((T, 3, 3))
                for j in range(T):
                    try:
                        m = as_attitude_sample(measurements[j], self.scalar_first, self.tol)
                    except ValueError as e:
                        raise ValueError(f"measurements[{j}]: {e}") from None
                    R[j] = np.nan if m is None else m
            valid = np.all(np.isfinite(R), axis=(1, 2))
            return np.ascontiguousarray(R, dtype=float), valid
        n = len(self.references)
        a = np.asarray(measurements, dtype=float)
        if a.ndim != 3 or a.shape[1:] != (n, 3):
            raise ValueError(
                f"measurements must be samples of {n} body-frame directions, shape (T, {n}, 3); got {a.shape}"
            )
        return np.ascontiguousarray(a), np.all(np.isfinite(a), axis=(1, 2))

    def run(self, times, measurements, torques=None) -> np.ndarray:
        """ω̂ at every sample of a log, ``(T, 3)``: the same as calling :meth:`update` sample by sample (it
        continues from the current state, does not reset, and leaves the state as ``update`` would), but in one
        compiled call (module docstring, *Cost*). The whole log is checked first: on a bad time, torque or
        sample, ``ValueError`` names it and the state is left unchanged."""
        meas, valid = self._measurement_log(measurements)
        T = meas.shape[0]
        bad = np.flatnonzero(~np.isfinite(np.asarray(times, dtype=float).ravel()))
        if bad.size:  # named here: _check_times prints the (summarised) array
            raise ValueError(f"times must be finite; got times[{bad[0]}] = {np.ravel(times)[bad[0]]}")
        t = _check_times(times, T)  # strictly increasing, one per sample
        if T and self.t is not None and t[0] <= self.t:
            raise ValueError(f"t must increase strictly; got times[0] = {float(t[0])!r} after t = {self.t!r}")
        if torques is None:
            tau = np.zeros((T, 3))
        else:
            tau = np.asarray(torques, dtype=float)
            if tau.shape != (T, 3):
                raise ValueError(f"torques must be 3 numbers per sample, shape ({T}, 3); got shape {tau.shape}")
            bad = np.flatnonzero(~np.all(np.isfinite(tau), axis=1))
            if bad.size:
                raise ValueError(f"torque must be 3 finite numbers; got torques[{bad[0]}] = {_fmt(tau[bad[0]])}")
        if T == 0:
            return np.empty((0, 3))
        refs = np.zeros((0, 3)) if self.references is None else np.ascontiguousarray(self.references, dtype=float)
        R, j_init = self.R, -1
        if R is None:  # the first valid sample initialises the attitude (no valid one: R stays unset)
            first = np.flatnonzero(valid)
            j_init = int(first[0]) if first.size else T
            if first.size:
                R = meas[j_init] if self.references is None else _wahba(meas[j_init], self.references)
        out, R, omega, P, n_skipped = _run_kernel(
            np.ascontiguousarray(t),
            meas,
            valid,
            np.ascontiguousarray(tau),
            refs,
            self.references is not None,
            self.model == "dynamic",
            np.ascontiguousarray(self.body.J),
            np.ascontiguousarray(self.body.J_inv),
            self.q,
            self.measurement_sigma**2,
            self.max_step,
            np.zeros((3, 3)) if R is None else np.array(R, dtype=float, order="C"),
            j_init,
            np.ascontiguousarray(self.omega, dtype=float),
            np.ascontiguousarray(self.P, dtype=float),
            0.0 if self.t is None else float(self.t),
            self.t is not None,
            np.ascontiguousarray(self._tau, dtype=float),
        )
        self.R = None if j_init >= T else R
        self.omega, self.P, self.t, self._tau = omega, P, float(t[-1]), tau[-1].copy()
        self.n_skipped += int(n_skipped)
        return out
