r"""The gyro-less multiplicative EKF's compiled step: propagation and the two fixes, in place, allocation-free.

The filter of :mod:`omegahat.baselines.mekf` (``docs/baselines.md``): nominal state ``R̂`` (body → inertial) and
``ω̂`` (body), error state ``x = [δθ; δω]`` with ``R = R̂ Exp(δθ)``, ``ω = ω̂ + δω``, covariance ``P`` (6×6)::

    F = [[−W, I], [0, A]],  W = ω̂×,  A = J⁻¹((Jω̂)× − ω̂× J) (dynamic) or 0 (kinematic)                (K1)
    process noise on δω̇ with PSD Q_ω = q J⁻¹J⁻ᵀ (dynamic: torque noise) or q I (kinematic)

**Propagation** over an interval ``h`` in ``n`` equal substeps, ``n = max(1, ⌈h/max_step⌉,
⌈h(|ω̂| + h|J⁻¹τ|)/max_angle⌉)`` for the nominal state; the covariance in substeps of at most
:data:`COVARIANCE_SUBSTEP_ANGLE`, each spanning a whole number of the nominal state's. The torque is
``τ(s) = τ₀ + (τ₁ − τ₀) s/h`` (``τ₁ = τ₀``: held; with the unknown acceleration of (K5), ``J â`` added to it, in
the substep count too). Per substep
``dt``, with ``W`` and ``A`` frozen at its start, the transition ``Φ = exp(F dt) = [[Φ_θθ, Φ_θω], [0, Φ_ωω]]`` is::

    Φ_θθ = Exp(−ω̂ dt)                     (exact, Rodrigues)                                        (K2)
    Φ_θω = Σ_{k=1..3} dt^k/k! U_k,   U₁ = I, U_{k+1} = −W U_k + A^k   (the upper-right blocks of F^k)
    Φ_ωω = Σ_{k=0..3} dt^k/k! A^k

(truncation ``(|F| dt)⁴/24``: 7e-5 relative at the covariance's substeps of at most 0.2 rad, below: P models a
gain, it does not carry the estimate) and the process covariance
``Q_d = ∫₀^dt Φ(s) [0; I] Q_ω [0, I] Φ(s)ᵀ ds`` to its leading two orders::

    Q_θθ = dt³/3 Q_ω + dt⁴/8 (U₂ Q_ω + Q_ω U₂ᵀ)                                                     (K3)
    Q_θω = dt²/2 Q_ω + dt³/6 U₂ Q_ω + dt³/3 Q_ω Aᵀ
    Q_ωω = dt Q_ω + dt²/2 (A Q_ω + Q_ω Aᵀ)

**Unknown torque (K5).** With a 9×9 ``P`` the state carries a third block, the unknown angular acceleration
``a`` (rad/s², body axes; the torque ``J a`` added to the known one), a random walk of PSD ``q_a``::

    δω̇ = A δω + δa,  δȧ = w_a:   F = [[−W, I, 0], [0, A, I], [0, 0, 0]]
    Φ_θa = dt²/2 I + dt³/6 U₂ + dt⁴/24 U₃,  Φ_ωa = dt I + dt²/2 A + dt³/6 A²,  Φ_aa = I
    Q_d += q_a [[dt⁵/20, dt⁴/8, dt³/6], [dt⁴/8, dt³/3, dt²/2], [dt³/6, dt²/2, dt]] ⊗ I  (leading orders)

``P ← Φ P Φᵀ + Q_d`` written in 3×3 blocks (Φ is block upper-triangular). **An interval too far to integrate**
— the body would turn ``h(|ω̂| + h|J⁻¹τ|) ≥`` :data:`MAX_SUBSTEPS` · :data:`COVARIANCE_SUBSTEP_ANGLE` = 2000 rad in
it, or that turn is not finite — is not integrated: the step fails (ω̂ set to NaN, so the caller's guard restarts
the filter, as for any step whose result is not finite), instead of taking ten thousand substeps per interval of
a diverged filter. The nominal state: CF4
(:func:`omegahat.kernels.dynamics.cf4_increment`) with the torque at the substep's start, middle and end (dynamic),
or ``R̂ ← R̂ Exp(ω̂ dt)`` (kinematic).

**Fixes**, both with the update in Joseph form written in blocks for ``H = [C, 0]``, gain ``K = [K₁; K₂]``::

    (I − KH) P (I − KH)ᵀ + σ² K Kᵀ,   I − KH = [[I − K₁C, 0], [−K₂C, I]]                          (K4)

* attitude (E5): ``z = 2 dq_vec/dq_w``, ``dq`` the quaternion of ``R̂ᵀ R_m`` (``dq_w ≥ 0``), ``C = I``;
* directions (E6): ``z_i = b_i − R̂ᵀ v_i``, ``C_i = (R̂ᵀ v_i)×``, processed one direction after the other at the
  same linearisation point (equal to the stacked update for independent noise);

then the reset ``R̂ ← R̂ Exp(δθ̂)``, ``ω̂ ← ω̂ + δω̂`` (and ``â ← â + δâ``). Each fix returns the normalised
innovation squared ``ν = Σ r_iᵀ S_i⁻¹ r_i`` (``r_i`` the sequential innovations, ``S_i`` their covariances):
the supervisor of :mod:`omegahat.observer.supervised` watches it; and it leaves ``Σ log det S_i`` in
``scratch[LOGDET_SLOT]``: with ν, the fix's share of the innovations' log-likelihood
``−½ (Σ log det 2π S_i + ν)`` that :mod:`omegahat.identification` maximises.

3×3 blocks are 9-tuples (:mod:`omegahat.kernels.vec3`); ``R`` (3, 3), ``w`` and ``a`` (3,), ``P`` (6, 6 or 9, 9) are
the caller's C-contiguous float64 arrays, updated in place; ``scratch`` holds at least :data:`EKF_SCRATCH` floats.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from omegahat.kernels.dynamics import cf4_increment
from omegahat.kernels.rotation import exp_matrix, matrix_from_quat, quat_from_matrix, quat_from_rotvec
from omegahat.kernels.vec3 import (
    det,
    inverse,
    lincomb,
    mat3,
    matmul,
    matvec,
    matvec_transposed,
    polished,
    skew,
    transposed,
)

__all__ = [
    "COVARIANCE_SUBSTEP_ANGLE",
    "EKF_SCRATCH",
    "LOGDET_SLOT",
    "MAX_SUBSTEPS",
    "NOMINAL_SUBSTEP_ANGLE",
    "ekf_attitude_update",
    "ekf_finite",
    "ekf_propagate",
    "ekf_substeps",
    "ekf_vector_update",
]

EKF_SCRATCH = 46  #: floats of scratch space the fixes need
LOGDET_SLOT = 45  #: where a fix leaves Σ log det S_i of its innovations (module docstring)
COVARIANCE_SUBSTEP_ANGLE = 0.2  #: rad: the covariance's substeps turn at most this far
NOMINAL_SUBSTEP_ANGLE = 0.2  #: rad: the default bound on the nominal state's substeps (CF4, fourth order)
MAX_SUBSTEPS = 10_000  #: cap per interval: a diverged filter (|ω̂| huge or not finite) must not stall the run

_I3 = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _block(P, i, j):
    return (
        P[i, j], P[i, j + 1], P[i, j + 2], P[i + 1, j], P[i + 1, j + 1], P[i + 1, j + 2],
        P[i + 2, j], P[i + 2, j + 1], P[i + 2, j + 2],
    )  # fmt: skip


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _put(P, i, j, B):
    for a in range(3):
        for b in range(3):
            P[i + a, j + b] = B[3 * a + b]


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _add(A, B, C):
    """``A + B + C`` for 9-tuples."""
    return lincomb(1.0, lincomb(1.0, A, 1.0, B), 1.0, C)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _sym(A):
    return lincomb(0.5, A, 0.5, transposed(A))


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _torque_at(tau0, tau1, s):
    """The first-order hold at the fraction ``s`` of the interval."""
    return (tau0[0] + s * (tau1[0] - tau0[0]), tau0[1] + s * (tau1[1] - tau0[1]), tau0[2] + s * (tau1[2] - tau0[2]))


@numba.njit(cache=True, error_model="numpy")
def ekf_finite(R, w, a, P):
    """Whether the filter's whole state (R̂, ω̂, â, P) is finite: the guard every caller applies after a step."""
    # x − x is 0 for a finite x and NaN for ±inf or NaN: one test at the end instead of a branch per entry (the
    # guard runs twice per sample)
    s = 0.0
    for i in range(3):
        s += (w[i] - w[i]) + (a[i] - a[i])
        for j in range(3):
            s += R[i, j] - R[i, j]
    for i in range(P.shape[0]):
        for j in range(P.shape[1]):
            s += P[i, j] - P[i, j]
    return s == 0.0


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _turn(h, w, Jinv, tau0, tau1):
    """``h(|ω̂| + h max|J⁻¹τ|)``: how far the body may turn over the interval (module docstring)."""
    f0 = matvec(mat3(Jinv), tau0[0], tau0[1], tau0[2])
    f1 = matvec(mat3(Jinv), tau1[0], tau1[1], tau1[2])
    accel = max(math.sqrt(f0[0] ** 2 + f0[1] ** 2 + f0[2] ** 2), math.sqrt(f1[0] ** 2 + f1[1] ** 2 + f1[2] ** 2))
    return h * (math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]) + h * accel)


@numba.njit(cache=True, error_model="numpy")
def ekf_substeps(h, w, Jinv, tau0, tau1, max_step, max_angle):
    """The number of substeps of an interval ``h`` (module docstring)."""
    return _substeps(h, _turn(h, w, Jinv, tau0, tau1), max_step, max_angle)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _substeps(h, angle, max_step, max_angle):
    """:func:`ekf_substeps` for an interval in which the body may turn ``angle`` (:func:`_turn`)."""
    n = 1.0
    if max_step < np.inf:
        n = max(n, math.ceil(h / max_step - 1e-12))
    if max_angle < np.inf and angle < MAX_SUBSTEPS * max_angle:  # False for NaN: capped below
        n = max(n, math.ceil(angle / max_angle))
    elif max_angle < np.inf:
        n = MAX_SUBSTEPS
    return int(min(n, MAX_SUBSTEPS))


@numba.njit(cache=True, error_model="numpy")
def ekf_propagate(R, w, a, P, h, tau0, tau1, J, Jinv, q, q_a, dynamic, max_step, max_angle):
    """(K1)–(K3) over ``h`` in place; returns the number of the nominal state's substeps. ``a`` is the estimated
    unknown angular acceleration (used when ``P`` is 9×9: (K5)); the covariance takes substeps of at most
    :data:`COVARIANCE_SUBSTEP_ANGLE` (and ``max_step``), each spanning a whole number of the nominal state's."""
    aug = P.shape[0] == 9
    Jm, Ji = mat3(J), mat3(Jinv)
    d0, d1, d2 = matvec(Jm, a[0], a[1], a[2]) if aug else (0.0, 0.0, 0.0)  # J â: the disturbance torque
    t0 = (tau0[0] + d0, tau0[1] + d1, tau0[2] + d2)  # the torque the nominal state integrates
    t1 = (tau1[0] + d0, tau1[1] + d1, tau1[2] + d2)
    angle = _turn(h, w, Jinv, t0, t1)
    if not angle < MAX_SUBSTEPS * COVARIANCE_SUBSTEP_ANGLE:  # NaN too: too far to integrate
        w[0] = w[1] = w[2] = np.nan
        return 0
    n_cov = _substeps(h, angle, max_step, COVARIANCE_SUBSTEP_ANGLE)
    per_cov = -(-_substeps(h, angle, max_step, max_angle) // n_cov)  # ceiling division
    n = n_cov * per_cov
    dt_cov = h / n_cov
    Qw = matmul(Ji, transposed(Ji)) if dynamic else _I3
    Qw = lincomb(q, Qw, 0.0, Qw)
    for jc in range(n_cov):
        _propagate_covariance(P, w, dt_cov, Jm, Ji, Qw, q_a, dynamic, aug)
        for j in range(jc * per_cov, (jc + 1) * per_cov):
            _nominal_step(R, w, h / n, j / n, (j + 0.5) / n, (j + 1.0) / n, t0, t1, Jm, Ji, dynamic)
    for i in range(P.shape[0]):
        for k in range(i):
            P[i, k] = P[k, i] = 0.5 * (P[i, k] + P[k, i])
    return n


@numba.njit(cache=True, error_model="numpy")
def _nominal_step(R, w, dt, sa, sm, sb, tau0, tau1, Jm, Ji, dynamic):
    """The nominal state over one substep, the torque at the fractions ``sa``, ``sm``, ``sb`` of the interval."""
    w0, w1, w2 = w[0], w[1], w[2]
    if dynamic:
        p, w_next = cf4_increment(
            Jm, Ji, w0, w1, w2, dt, _torque_at(tau0, tau1, sa), _torque_at(tau0, tau1, sm), _torque_at(tau0, tau1, sb)
        )
        w[0], w[1], w[2] = w_next
    else:
        p = quat_from_rotvec(dt * w0, dt * w1, dt * w2)
    _put(R, 0, 0, matmul(mat3(R), matrix_from_quat(p[0], p[1], p[2], p[3])))


@numba.njit(cache=True, error_model="numpy")
def _propagate_covariance(P, w, dt, Jm, Ji, Qw, q_a, dynamic, aug):
    """``P ← Φ P Φᵀ + Q_d`` over ``dt`` with (K2), (K3) (and (K5) when ``aug``) at the current ω̂, in place."""
    w0, w1, w2 = w[0], w[1], w[2]
    W = skew(w0, w1, w2)
    if dynamic:
        a0, a1, a2 = matvec(Jm, w0, w1, w2)
        A = matmul(Ji, lincomb(1.0, skew(a0, a1, a2), -1.0, matmul(W, Jm)))
    else:
        A = lincomb(0.0, _I3, 0.0, _I3)
    A2 = matmul(A, A)
    U2 = lincomb(1.0, A, -1.0, W)
    U3 = lincomb(-1.0, matmul(W, U2), 1.0, A2)
    c2, c3, c4 = dt * dt / 2.0, dt**3 / 6.0, dt**4 / 24.0
    T = exp_matrix(-dt * w0, -dt * w1, -dt * w2)  # (K2)
    B = lincomb(1.0, lincomb(dt, _I3, c2, U2), c3, U3)
    D = lincomb(1.0, lincomb(1.0, _I3, dt, A), 1.0, lincomb(c2, A2, c3, matmul(A, A2)))
    QA = matmul(Qw, transposed(A))
    Q00 = lincomb(dt**3 / 3.0, Qw, dt**4 / 8.0, _sym(lincomb(2.0, matmul(U2, Qw), 0.0, Qw)))  # (K3)
    Q01 = lincomb(1.0, lincomb(c2, Qw, c3, matmul(U2, Qw)), dt**3 / 3.0, QA)
    Q11 = lincomb(dt, Qw, c2, lincomb(1.0, QA, 1.0, transposed(QA)))
    P00, P01, P11 = _block(P, 0, 0), _block(P, 0, 3), _block(P, 3, 3)
    X00 = lincomb(1.0, matmul(T, P00), 1.0, matmul(B, transposed(P01)))  # X = Φ P, block by block
    X01 = lincomb(1.0, matmul(T, P01), 1.0, matmul(B, P11))
    X11 = matmul(D, P11)
    if aug:  # (K5): the disturbance's blocks of Φ, its share of Q_d, its rows and columns of P
        E = lincomb(1.0, lincomb(c2, _I3, c3, U2), c4, U3)
        G = lincomb(1.0, lincomb(dt, _I3, c2, A), c3, A2)
        P02, P12, P22 = _block(P, 0, 6), _block(P, 3, 6), _block(P, 6, 6)
        X00 = lincomb(1.0, X00, 1.0, matmul(E, transposed(P02)))
        X01 = lincomb(1.0, X01, 1.0, matmul(E, transposed(P12)))
        X02 = _add(matmul(T, P02), matmul(B, P12), matmul(E, P22))
        X11 = lincomb(1.0, X11, 1.0, matmul(G, transposed(P12)))
        X12 = lincomb(1.0, matmul(D, P12), 1.0, matmul(G, P22))
        Q00 = lincomb(1.0, Q00, q_a * dt**5 / 20.0, _I3)
        Q01 = lincomb(1.0, Q01, q_a * dt**4 / 8.0, _I3)
        Q11 = lincomb(1.0, Q11, q_a * dt**3 / 3.0, _I3)
        N00 = _add(matmul(X00, transposed(T)), matmul(X01, transposed(B)), matmul(X02, transposed(E)))
        N01 = lincomb(1.0, matmul(X01, transposed(D)), 1.0, matmul(X02, transposed(G)))
        N11 = lincomb(1.0, matmul(X11, transposed(D)), 1.0, matmul(X12, transposed(G)))
        N02 = lincomb(1.0, X02, q_a * dt**3 / 6.0, _I3)
        N12 = lincomb(1.0, X12, q_a * dt * dt / 2.0, _I3)
        _put(P, 0, 6, N02)
        _put(P, 6, 0, transposed(N02))
        _put(P, 3, 6, N12)
        _put(P, 6, 3, transposed(N12))
        _put(P, 6, 6, lincomb(1.0, P22, q_a * dt, _I3))
    else:
        N00 = lincomb(1.0, matmul(X00, transposed(T)), 1.0, matmul(X01, transposed(B)))
        N01 = matmul(X01, transposed(D))
        N11 = matmul(X11, transposed(D))
    N01 = lincomb(1.0, N01, 1.0, Q01)
    _put(P, 0, 0, lincomb(1.0, N00, 1.0, Q00))
    _put(P, 0, 3, N01)
    _put(P, 3, 0, transposed(N01))
    _put(P, 3, 3, lincomb(1.0, N11, 1.0, Q11))


@numba.njit(cache=True, error_model="numpy")
def _joseph(P, Ks, C, var):
    """(K4) in blocks, in place, for ``H = [C, 0 …]`` and the gain blocks ``Ks[i]`` (9 floats each):
    ``M = (I − KH) P``, ``M_ij = P_ij − K_i C P_0j``; ``N_ij = M_ij − M_i0 (K_j C)ᵀ + σ² K_i K_jᵀ``."""
    nb = P.shape[0] // 3
    K0 = (Ks[0, 0], Ks[0, 1], Ks[0, 2], Ks[0, 3], Ks[0, 4], Ks[0, 5], Ks[0, 6], Ks[0, 7], Ks[0, 8])
    K1 = (Ks[1, 0], Ks[1, 1], Ks[1, 2], Ks[1, 3], Ks[1, 4], Ks[1, 5], Ks[1, 6], Ks[1, 7], Ks[1, 8])
    KC0, KC1 = matmul(K0, C), matmul(K1, C)
    P00, P01, P11 = _block(P, 0, 0), _block(P, 0, 3), _block(P, 3, 3)
    M00 = lincomb(1.0, P00, -1.0, matmul(KC0, P00))
    M01 = lincomb(1.0, P01, -1.0, matmul(KC0, P01))
    M10 = lincomb(1.0, transposed(P01), -1.0, matmul(KC1, P00))
    M11 = lincomb(1.0, P11, -1.0, matmul(KC1, P01))
    N00 = lincomb(1.0, lincomb(1.0, M00, -1.0, matmul(M00, transposed(KC0))), var, matmul(K0, transposed(K0)))
    N01 = lincomb(1.0, lincomb(1.0, M01, -1.0, matmul(M00, transposed(KC1))), var, matmul(K0, transposed(K1)))
    N11 = lincomb(1.0, lincomb(1.0, M11, -1.0, matmul(M10, transposed(KC1))), var, matmul(K1, transposed(K1)))
    if nb == 3:
        K2 = (Ks[2, 0], Ks[2, 1], Ks[2, 2], Ks[2, 3], Ks[2, 4], Ks[2, 5], Ks[2, 6], Ks[2, 7], Ks[2, 8])
        KC2 = matmul(K2, C)
        P02, P12, P22 = _block(P, 0, 6), _block(P, 3, 6), _block(P, 6, 6)
        M02 = lincomb(1.0, P02, -1.0, matmul(KC0, P02))
        M12 = lincomb(1.0, P12, -1.0, matmul(KC1, P02))
        M20 = lincomb(1.0, transposed(P02), -1.0, matmul(KC2, P00))
        M22 = lincomb(1.0, P22, -1.0, matmul(KC2, P02))
        N02 = lincomb(1.0, lincomb(1.0, M02, -1.0, matmul(M00, transposed(KC2))), var, matmul(K0, transposed(K2)))
        N12 = lincomb(1.0, lincomb(1.0, M12, -1.0, matmul(M10, transposed(KC2))), var, matmul(K1, transposed(K2)))
        N22 = lincomb(1.0, lincomb(1.0, M22, -1.0, matmul(M20, transposed(KC2))), var, matmul(K2, transposed(K2)))
        _put(P, 0, 6, N02)
        _put(P, 6, 0, transposed(N02))
        _put(P, 3, 6, N12)
        _put(P, 6, 3, transposed(N12))
        _put(P, 6, 6, _sym(N22))
    _put(P, 0, 0, _sym(N00))
    _put(P, 0, 3, N01)
    _put(P, 3, 0, transposed(N01))
    _put(P, 3, 3, _sym(N11))


@numba.njit(cache=True, error_model="numpy")
def _gains(P, C, Si, Ks):
    """``K_i = P_i0 Cᵀ S⁻¹`` for every block row of P, into ``Ks`` (one row of 9 per block)."""
    Ct = transposed(C)
    for i in range(P.shape[0] // 3):
        K = matmul(matmul(_block(P, 3 * i, 0), Ct), Si)
        for k in range(9):
            Ks[i, k] = K[k]


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _apply(Ks, dx, r0, r1, r2):
    """``δx += K r``: ``dx`` holds the correction, 3 per block."""
    for i in range(Ks.shape[0]):
        for c in range(3):
            dx[3 * i + c] += Ks[i, 3 * c] * r0 + Ks[i, 3 * c + 1] * r1 + Ks[i, 3 * c + 2] * r2


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _reset(R, w, a, dx, aug):
    """(E8): ``R̂ ← R̂ Exp(δθ̂)``, ``ω̂ ← ω̂ + δω̂`` (and ``â ← â + δâ``); then ``R̂ ← R̂ (3I − R̂ᵀR̂)/2`` (one
    Newton–Schulz step of the polar factor: a deviation ε of ``R̂ᵀR̂`` from I becomes O(ε²)). Without it a product
    of millions of rotations drifts from orthogonality by rounding, and once past 1e-12 every attitude fix takes the
    nearest-rotation path of :func:`~omegahat.kernels.rotation.quat_from_matrix`."""
    _put(R, 0, 0, polished(matmul(mat3(R), exp_matrix(dx[0], dx[1], dx[2]))))
    for c in range(3):
        w[c] += dx[3 + c]
        if aug:
            a[c] += dx[6 + c]


@numba.njit(cache=True, error_model="numpy")
def ekf_attitude_update(R, w, a, P, R_meas, meas_var, scratch):
    """The attitude fix (E5) with (K4) and the reset, in place; returns ν (3 degrees of freedom). ``scratch``:
    at least :data:`EKF_SCRATCH` floats."""
    nb = P.shape[0] // 3
    Dm = scratch[:9].reshape(3, 3)
    Ks = scratch[9:36].reshape(3, 9)[:nb]
    dx = scratch[36:45]
    dx[:] = 0.0
    _put(Dm, 0, 0, matmul(transposed(mat3(R)), mat3(R_meas)))
    dq = quat_from_matrix(Dm)
    z0, z1, z2 = 2.0 * dq[0] / dq[3], 2.0 * dq[1] / dq[3], 2.0 * dq[2] / dq[3]
    S = lincomb(1.0, _block(P, 0, 0), meas_var, _I3)
    scratch[LOGDET_SLOT] = math.log(det(S))
    Si = inverse(S)
    _gains(P, _I3, Si, Ks)
    s0, s1, s2 = matvec(Si, z0, z1, z2)
    _apply(Ks, dx, z0, z1, z2)
    _joseph(P, Ks, _I3, meas_var)
    _reset(R, w, a, dx, nb == 3)
    return z0 * s0 + z1 * s1 + z2 * s2


@numba.njit(cache=True, error_model="numpy")
def ekf_vector_update(R, w, a, P, b, references, meas_var, scratch):
    """The direction fix (E6), one direction after the other, with (K4) and the reset, in place; returns ν."""
    nb = P.shape[0] // 3
    Ks = scratch[9:36].reshape(3, 9)[:nb]
    dx = scratch[36:45]
    dx[:] = 0.0
    Rt = mat3(R)
    nis = 0.0
    scratch[LOGDET_SLOT] = 0.0
    for i in range(references.shape[0]):
        bh = matvec_transposed(Rt, references[i, 0], references[i, 1], references[i, 2])  # R̂ᵀ v_i
        C = skew(bh[0], bh[1], bh[2])
        Cd = matvec(C, dx[0], dx[1], dx[2])
        r0, r1, r2 = b[i, 0] - bh[0] - Cd[0], b[i, 1] - bh[1] - Cd[1], b[i, 2] - bh[2] - Cd[2]
        S = lincomb(1.0, matmul(matmul(C, _block(P, 0, 0)), transposed(C)), meas_var, _I3)
        scratch[LOGDET_SLOT] += math.log(det(S))
        Si = inverse(S)
        _gains(P, C, Si, Ks)
        s = matvec(Si, r0, r1, r2)
        nis += r0 * s[0] + r1 * s[1] + r2 * s[2]
        _apply(Ks, dx, r0, r1, r2)
        _joseph(P, Ks, C, meas_var)
    _reset(R, w, a, dx, nb == 3)
    return nis
