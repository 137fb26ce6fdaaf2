r"""The sampled estimator's prediction (P): ω̂, the attitude increment ``ΔR̂`` and the aim ``Γ`` between samples.

Between two samples the sampled estimator (:mod:`omegahat.observer.sampled`, ``docs/theory/sampled.md``) carries its
state forward with no measurement: ω̂ by Euler's equations (E1) under the torque held or interpolated over the
interval, the attitude increment ``ΔR̂`` along ω̂ by RKMK4 (exact in one step for a constant ω̂), the predicted
directions and their filter errors rotated by ``ΔR̂`` and decayed exactly, and the aim ``Γ`` (A1) that maps a rate
error at the end of the interval to the attitude error it has caused. These are the compiled pieces
:func:`omegahat.observer.sampled.step_into` calls; each is also what :mod:`omegahat.observer.reference` writes in
NumPy as the oracle. Matrices are row-major 9-tuples or ``(3, 3)`` arrays as each function says.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from omegahat.kernels.dynamics import euler_rate
from omegahat.kernels.rotation import dexpinv, exp_matrix
from omegahat.kernels.vec3 import matmul, matvec, skew

__all__ = [
    "MAX_SUBSTEPS",
    "MAX_SUBSTEP_ANGLE",
    "advance_aim",
    "diag_plus",
    "isotropic_inertia",
    "predict_constant",
    "predict_directions",
    "predict_rate",
]

MAX_SUBSTEP_ANGLE = 0.05  #: rad: default bound on a prediction substep's angle h_sub (|ω̂| + h |J⁻¹τ|)
MAX_SUBSTEPS = 1_000_000  #: cap on substeps per interval (a gap of hours at a fast spin)


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def diag_plus(d, p, X, q, Y):
    """``d I + p X + q Y`` for 9-tuples."""
    return (
        d + p * X[0] + q * Y[0], p * X[1] + q * Y[1], p * X[2] + q * Y[2],
        p * X[3] + q * Y[3], d + p * X[4] + q * Y[4], p * X[5] + q * Y[5],
        p * X[6] + q * Y[6], p * X[7] + q * Y[7], d + p * X[8] + q * Y[8],
    )  # fmt: skip


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def advance_aim(Jm, Jinv, w0, w1, w2, hs, aim):
    """(A1) over one substep, in place: the aim ``Γ = Φ_θω Φ_ωω⁻¹`` maps a rate error at the end of the interval
    to the attitude error it has caused since the last valid sample (``δθ = Γ δω``). From the linearised error
    ``δθ̇ = −W δθ + δω``, ``δω̇ = A δω`` (``W = ω̂×``, ``A = J⁻¹((Jω̂)× − ω̂× J)``) it obeys
    ``Γ̇ = I − W Γ − Γ A``, ``Γ = 0`` at a valid sample; with W and A frozen at the substep's start, the
    second-order step ``Γ ← Γ + h_s F − (h_s²/2)(W F + F A)``, ``F = I − W Γ − Γ A``."""
    W = skew(w0, w1, w2)
    a0, a1, a2 = matvec(Jm, w0, w1, w2)
    X = skew(a0, a1, a2)
    WJ = matmul(W, Jm)
    A = matmul(Jinv, (X[0] - WJ[0], X[1] - WJ[1], X[2] - WJ[2], X[3] - WJ[3], X[4] - WJ[4], X[5] - WJ[5],
                      X[6] - WJ[6], X[7] - WJ[7], X[8] - WJ[8]))  # fmt: skip
    G = (aim[0], aim[1], aim[2], aim[3], aim[4], aim[5], aim[6], aim[7], aim[8])
    F = diag_plus(1.0, -1.0, matmul(W, G), -1.0, matmul(G, A))
    WF = matmul(W, F)
    FA = matmul(F, A)
    c = 0.5 * hs * hs
    for i in range(9):
        aim[i] = G[i] + hs * F[i] - c * (WF[i] + FA[i])


@numba.njit(cache=True, error_model="numpy")
def isotropic_inertia(Jm):
    """Whether the inertia (a 9-tuple) is ``j I``: then Euler's equations without torque keep ω constant."""
    return (
        Jm[1] == 0.0 and Jm[2] == 0.0 and Jm[3] == 0.0 and Jm[5] == 0.0 and Jm[6] == 0.0 and Jm[7] == 0.0
        and Jm[0] == Jm[4] and Jm[4] == Jm[8]
    )  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def predict_constant(w, h, D, aim):
    """(P) over ``h`` in one exact step for a constant ω̂ ≠ 0 (no torque, isotropic J: (E1) gives ω̂̇ = 0), for
    intervals of any length: ``ΔR̂ = exp(h ω̂×)``, ``∫|ω̂| dt = h|ω̂|`` and, with ``A = 0`` in (A1),
    ``Γ̇ = I − W Γ``, ``W = ω̂×``, solved exactly (``θ = h|ω̂|``, Rodrigues' form of ``exp(−W s)`` integrated)::

        Γ ← exp(−W h) Γ + h I − (1 − cos θ)/|ω̂|² W + (h − sin θ/|ω̂|)/|ω̂|² W²                  (A2)

    ``w`` is unchanged; returns ``∫|ω̂| dt``."""
    w0, w1, w2 = w[0], w[1], w[2]
    speed = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    theta = h * speed
    E = exp_matrix(h * w0, h * w1, h * w2)
    for a in range(3):
        for b in range(3):
            D[a, b] = E[3 * a + b]
    W = skew(w0, w1, w2)
    W2 = matmul(W, W)
    B = matmul(exp_matrix(-h * w0, -h * w1, -h * w2), (aim[0], aim[1], aim[2], aim[3], aim[4], aim[5], aim[6],
                                                         aim[7], aim[8]))  # fmt: skip
    c1 = (1.0 - math.cos(theta)) / (speed * speed)
    c2 = (h - math.sin(theta) / speed) / (speed * speed)
    for i in range(9):
        aim[i] = B[i] - c1 * W[i] + c2 * W2[i]
    for i in (0, 4, 8):
        aim[i] += h
    return theta


@numba.njit(cache=True, error_model="numpy")
def predict_rate(Jm, Jinv, max_angle, w, tau_a, tau_b, h, D, aim):
    """(P) for ω̂ and ΔR̂ over h with the torque ``τ(s) = τ_a + (τ_b − τ_a) s/h`` (``τ_b = τ_a``: held):
    ``w`` ← ω̂(t + h) in place, ``D`` ← ΔR̂ (3×3), ``aim`` ← Γ (A1) carried on; returns
    ``∫|ω̂| dt``. RKMK4 in substeps of angle ``h_sub (|ω̂| + h|J⁻¹τ|) ≤ max_angle``: classical RK4 for ω̂, for
    ``ΔR̂ = exp(u)`` the stages ``u̇ = dexp⁻¹(ω̂)`` (R5), and ``∫|ω̂|`` with the same weights. Exact (ΔR̂ = exp(h ω̂))
    for a constant ω̂. An interval that would need more than :data:`MAX_SUBSTEPS` substeps (a long gap, a huge
    torque or rate) is predicted exactly when ω̂ is constant (no torque, J = j I: :func:`predict_constant`) and
    otherwise refused: ``w`` ← NaN and NaN returned (the step's caller then restarts the estimator)."""
    fa = euler_rate(Jm, Jinv, 0.0, 0.0, 0.0, tau_a[0], tau_a[1], tau_a[2])  # J⁻¹τ at both ends
    fb = euler_rate(Jm, Jinv, 0.0, 0.0, 0.0, tau_b[0], tau_b[1], tau_b[2])
    f_max = max(math.sqrt(fa[0] * fa[0] + fa[1] * fa[1] + fa[2] * fa[2]),
                math.sqrt(fb[0] * fb[0] + fb[1] * fb[1] + fb[2] * fb[2]))  # fmt: skip
    w0, w1, w2 = w[0], w[1], w[2]
    angle = h * (math.sqrt(w0 * w0 + w1 * w1 + w2 * w2) + h * f_max)
    need = angle / max_angle
    if not need <= MAX_SUBSTEPS:  # too long for substeps (or not finite): exact if ω̂ is constant, else refused
        if f_max == 0.0 and isotropic_inertia(Jm):
            return predict_constant(w, h, D, aim)
        w[0] = w[1] = w[2] = np.nan  # the step cannot be taken: the caller restarts the estimator
        return np.nan
    n_sub = max(1, math.ceil(need))
    hs = h / n_sub
    d0, d1, d2 = tau_b[0] - tau_a[0], tau_b[1] - tau_a[1], tau_b[2] - tau_a[2]
    int_abs = 0.0
    d = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)
    for j in range(n_sub):
        s0, s_mid, s1 = j / n_sub, (j + 0.5) / n_sub, (j + 1.0) / n_sub  # stage times as fractions of h
        ta = (tau_a[0] + s0 * d0, tau_a[1] + s0 * d1, tau_a[2] + s0 * d2)
        tm = (tau_a[0] + s_mid * d0, tau_a[1] + s_mid * d1, tau_a[2] + s_mid * d2)
        tb = (tau_a[0] + s1 * d0, tau_a[1] + s1 * d1, tau_a[2] + s1 * d2)
        advance_aim(Jm, Jinv, w0, w1, w2, hs, aim)
        L1 = euler_rate(Jm, Jinv, w0, w1, w2, ta[0], ta[1], ta[2])
        K1 = (hs * w0, hs * w1, hs * w2)
        n1 = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        s0, s1, s2 = w0 + 0.5 * hs * L1[0], w1 + 0.5 * hs * L1[1], w2 + 0.5 * hs * L1[2]
        n2 = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K2 = dexpinv(0.5 * K1[0], 0.5 * K1[1], 0.5 * K1[2], s0, s1, s2, hs)
        L2 = euler_rate(Jm, Jinv, s0, s1, s2, tm[0], tm[1], tm[2])
        s0, s1, s2 = w0 + 0.5 * hs * L2[0], w1 + 0.5 * hs * L2[1], w2 + 0.5 * hs * L2[2]
        n3 = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K3 = dexpinv(0.5 * K2[0], 0.5 * K2[1], 0.5 * K2[2], s0, s1, s2, hs)
        L3 = euler_rate(Jm, Jinv, s0, s1, s2, tm[0], tm[1], tm[2])
        s0, s1, s2 = w0 + hs * L3[0], w1 + hs * L3[1], w2 + hs * L3[2]
        n4 = math.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K4 = dexpinv(K3[0], K3[1], K3[2], s0, s1, s2, hs)
        L4 = euler_rate(Jm, Jinv, s0, s1, s2, tb[0], tb[1], tb[2])
        int_abs += hs * (n1 + 2.0 * n2 + 2.0 * n3 + n4) / 6.0
        w0 += hs * (L1[0] + 2.0 * L2[0] + 2.0 * L3[0] + L4[0]) / 6.0
        w1 += hs * (L1[1] + 2.0 * L2[1] + 2.0 * L3[1] + L4[1]) / 6.0
        w2 += hs * (L1[2] + 2.0 * L2[2] + 2.0 * L3[2] + L4[2]) / 6.0
        E = exp_matrix(
            (K1[0] + 2.0 * K2[0] + 2.0 * K3[0] + K4[0]) / 6.0,
            (K1[1] + 2.0 * K2[1] + 2.0 * K3[1] + K4[1]) / 6.0,
            (K1[2] + 2.0 * K2[2] + 2.0 * K3[2] + K4[2]) / 6.0,
        )
        d = matmul(d, E)  # ΔR̂ ← ΔR̂ exp(u)
    w[0], w[1], w[2] = w0, w1, w2
    for a in range(3):
        for b in range(3):
            D[a, b] = d[3 * a + b]
    return int_abs


@numba.njit(cache=True, error_model="numpy")
def predict_directions(r, e, D, decay, i):
    """(P) for direction i: ``r ← ΔR̂ᵀ r`` and ``e ← decay ΔR̂ᵀ e`` (row form ``rᵀ ΔR̂``), in place."""
    p0 = r[i, 0] * D[0, 0] + r[i, 1] * D[1, 0] + r[i, 2] * D[2, 0]
    p1 = r[i, 0] * D[0, 1] + r[i, 1] * D[1, 1] + r[i, 2] * D[2, 1]
    p2 = r[i, 0] * D[0, 2] + r[i, 1] * D[1, 2] + r[i, 2] * D[2, 2]
    e0 = decay * (e[i, 0] * D[0, 0] + e[i, 1] * D[1, 0] + e[i, 2] * D[2, 0])
    e1 = decay * (e[i, 0] * D[0, 1] + e[i, 1] * D[1, 1] + e[i, 2] * D[2, 1])
    e2 = decay * (e[i, 0] * D[0, 2] + e[i, 1] * D[1, 2] + e[i, 2] * D[2, 2])
    r[i, 0], r[i, 1], r[i, 2] = p0, p1, p2
    e[i, 0], e[i, 1], e[i, 2] = e0, e1, e2
