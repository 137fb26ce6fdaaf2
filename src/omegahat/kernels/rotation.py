r"""Rotations for the compiled kernels: exp and log on SO(3), quaternions, the nearest rotation, Wahba's problem.

Conventions (the project's, :mod:`omegahat.so3`): ``R`` maps body to inertial; a quaternion is Hamilton's, stored
**scalar last** ``(x, y, z, w)`` as SciPy stores it, and passed as four floats; a 3×3 matrix is returned as a
row-major 9-tuple (:func:`omegahat.kernels.vec3.mat3`) and written into an array with :func:`store`.

Formulas, with ``θ = |φ|`` and ``â = φ/θ``::

    exp:     q(φ) = (sin(θ/2) â, cos(θ/2)),  R(q) = I + 2w [q_v]× + 2 [q_v]×²                         (R1)
    log:     φ = 2 atan2(|q_v|, w) q_v / |q_v|  for w ≥ 0                                            (R2)
    R → q:   Shepperd's method: the largest of tr R and the diagonal picks the pivot (stable at every angle) (R3)
    nearest rotation to D:  U diag(1, 1, det U Vᵀ) Vᵀ  from the SVD D = U S Vᵀ                        (R4)
    dexp⁻¹:  u̇ = dexp⁻¹_{−u}(ω) ≈ ω + ½ u × ω + (1/12) u × (u × ω)   (order 4, RKMK4)                   (R5)
    Wahba:   A = argmin Σ w_i |t_i − A s_i|² = U diag(1, 1, det U det V) Vᵀ,  Σ w_i t_i s_iᵀ = U S Vᵀ   (R6)

Below ``θ = 1e-4`` the sines of (R1) are Taylor series (their truncation error O(θ⁶) is far below rounding);
(R2) uses ``2 q_v / w`` below ``|q_v| = 1e-12``, its error O(θ³) then below rounding.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from omegahat.kernels.vec3 import mat3, polished

__all__ = [
    "det",
    "dexpinv",
    "exp_matrix",
    "hat",
    "matrix_from_quat",
    "nearest_rotation",
    "orthogonality_error",
    "quat_from_matrix",
    "quat_from_rotvec",
    "quat_multiply",
    "rotvec_from_matrix",
    "rotvec_from_quat",
    "store",
    "wahba",
]

SMALL_ANGLE = 1e-4  #: below this angle (rad) the coefficients of (R1) are Taylor series


@numba.njit(cache=True, error_model="numpy")
def store(M, out):
    """Write the 9-tuple ``M`` into the 3×3 array ``out``."""
    out[0, 0], out[0, 1], out[0, 2] = M[0], M[1], M[2]
    out[1, 0], out[1, 1], out[1, 2] = M[3], M[4], M[5]
    out[2, 0], out[2, 1], out[2, 2] = M[6], M[7], M[8]


@numba.njit(cache=True, inline="always", error_model="numpy")
def quat_from_rotvec(x, y, z):
    """Unit quaternion ``(x, y, z, w)`` of the rotation vector φ = (x, y, z): (R1)."""
    t2 = x * x + y * y + z * z
    theta = math.sqrt(t2)
    if theta < SMALL_ANGLE:
        s = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0  # sin(θ/2)/θ
        c = 1.0 - t2 / 8.0 + t2 * t2 / 384.0  # cos(θ/2)
    else:
        s = math.sin(0.5 * theta) / theta
        c = math.cos(0.5 * theta)
    return s * x, s * y, s * z, c


@numba.njit(cache=True, error_model="numpy")
def quat_multiply(px, py, pz, pw, qx, qy, qz, qw):
    """Hamilton product ``p ⊗ q`` (the rotation ``R(p) R(q)``)."""
    return (
        pw * qx + px * qw + py * qz - pz * qy,
        pw * qy - px * qz + py * qw + pz * qx,
        pw * qz + px * qy - py * qx + pz * qw,
        pw * qw - px * qx - py * qy - pz * qz,
    )


@numba.njit(cache=True, inline="always", error_model="numpy")
def matrix_from_quat(x, y, z, w):
    """Rotation matrix (9-tuple) of the unit quaternion ``(x, y, z, w)``: (R1). Quadratic in q, so q ≡ −q."""
    return (
        1.0 - 2.0 * (y * y + z * z),
        2.0 * (x * y - z * w),
        2.0 * (x * z + y * w),
        2.0 * (x * y + z * w),
        1.0 - 2.0 * (x * x + z * z),
        2.0 * (y * z - x * w),
        2.0 * (x * z - y * w),
        2.0 * (y * z + x * w),
        1.0 - 2.0 * (x * x + y * y),
    )


@numba.njit(cache=True, inline="always", error_model="numpy")
def exp_matrix(x, y, z):
    """``exp(φ×)`` (9-tuple) of the rotation vector φ = (x, y, z), through its quaternion: (R1)."""
    qx, qy, qz, qw = quat_from_rotvec(x, y, z)
    return matrix_from_quat(qx, qy, qz, qw)


@numba.njit(cache=True)
def nearest_rotation(D):
    """The rotation nearest to ``D`` in the Frobenius norm (R4): ``U diag(1, 1, det(U Vᵀ)) Vᵀ`` from the SVD
    ``D = U S Vᵀ`` (a new 3×3 array; a reflection or any matrix is mapped to a rotation). A proper matrix within
    1e-3 of orthogonal (largest entry of ``DᵀD − I``; rotations written in single precision, as QTM, Vicon and C3D
    write them, are 1e-7 off) has (R4) as its polar factor, reached without the SVD by three Newton–Schulz steps
    ``D (3I − DᵀD)/2``, each turning that deviation ε into about ``3ε²/4``."""
    dev = 0.0
    for i in range(3):
        for j in range(3):
            g = D[0, i] * D[0, j] + D[1, i] * D[1, j] + D[2, i] * D[2, j]
            dev = max(dev, abs(g - (1.0 if i == j else 0.0)))
    if dev <= 1e-3 and det(D) > 0.0:
        M = mat3(D)
        for _ in range(3):
            M = polished(M)
        A = np.empty((3, 3))
        for a in range(9):
            A[a // 3, a % 3] = M[a]
        return A
    U, _, Vt = np.linalg.svd(D)
    d = 1.0 if np.linalg.det(U) * np.linalg.det(Vt) >= 0.0 else -1.0
    A = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            A[a, b] = U[a, 0] * Vt[0, b] + U[a, 1] * Vt[1, b] + d * U[a, 2] * Vt[2, b]
    return A


@numba.njit(cache=True, error_model="numpy")
def orthogonality_error(R):
    """``‖RᵀR − I‖_F`` of a 3×3 array (0 for a rotation)."""
    err2 = 0.0
    for a in range(3):
        for b in range(3):
            s = R[0, a] * R[0, b] + R[1, a] * R[1, b] + R[2, a] * R[2, b] - (1.0 if a == b else 0.0)
            err2 += s * s
    return math.sqrt(err2)


@numba.njit(cache=True, error_model="numpy")
def det(R):
    """The determinant of a 3×3 array."""
    return (
        R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
        - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
        + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0])
    )


@numba.njit(cache=True)
def quat_from_matrix(D):
    """Unit quaternion ``(x, y, z, w)`` of a rotation matrix, ``w ≥ 0``: Shepperd's method (R3) with SciPy's pivot
    and sign rules (``Rotation.from_matrix(D).as_quat(canonical=True)``). Like SciPy, a matrix whose ``D Dᵀ``
    differs from I by more than 1e-12 is first replaced by the nearest rotation (R4)."""
    dev = 0.0
    for i in range(3):
        for j in range(3):
            g = D[i, 0] * D[j, 0] + D[i, 1] * D[j, 1] + D[i, 2] * D[j, 2]
            dev = max(dev, abs(g - (1.0 if i == j else 0.0)))
    if dev > 1e-12:
        D = nearest_rotation(D)
    tr = D[0, 0] + D[1, 1] + D[2, 2]
    q = np.empty(4)
    i = 0
    if D[1, 1] > D[i, i]:
        i = 1
    if D[2, 2] > D[i, i]:
        i = 2
    if tr > D[i, i]:  # ties go to the diagonal, as in SciPy (argmax of [D₀₀, D₁₁, D₂₂, tr])
        q[0] = D[2, 1] - D[1, 2]
        q[1] = D[0, 2] - D[2, 0]
        q[2] = D[1, 0] - D[0, 1]
        q[3] = 1.0 + tr
    else:
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1.0 - tr + 2.0 * D[i, i]
        q[j] = D[j, i] + D[i, j]
        q[k] = D[k, i] + D[i, k]
        q[3] = D[k, j] - D[j, k]
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    sign = -1.0 if q[3] < 0.0 else 1.0
    return sign * q[0] / n, sign * q[1] / n, sign * q[2] / n, sign * q[3] / n


@numba.njit(cache=True, error_model="numpy")
def rotvec_from_quat(x, y, z, w):
    """Rotation vector (|φ| ≤ π) of the unit quaternion ``(x, y, z, w)`` with ``w ≥ 0``: (R2)."""
    s = math.sqrt(x * x + y * y + z * z)
    g = 2.0 / w if s < 1e-12 else 2.0 * math.atan2(s, w) / s  # θ = 2 atan2(s, w); 2 q_v / w to O(θ³)
    return g * x, g * y, g * z


@numba.njit(cache=True)
def rotvec_from_matrix(R):
    """Rotation vector (|φ| ≤ π) of a rotation matrix: (R3) then (R2), accurate at every angle."""
    x, y, z, w = quat_from_matrix(R)
    return rotvec_from_quat(x, y, z, w)


@numba.njit(cache=True, inline="always", error_model="numpy")
def dexpinv(u0, u1, u2, w0, w1, w2, hs):
    """``hs (w + ½ u × w + (1/12) u × (u × w))``: a stage of RKMK4, (R5)."""
    c0 = u1 * w2 - u2 * w1
    c1 = u2 * w0 - u0 * w2
    c2 = u0 * w1 - u1 * w0
    d0 = u1 * c2 - u2 * c1
    d1 = u2 * c0 - u0 * c2
    d2 = u0 * c1 - u1 * c0
    return hs * (w0 + 0.5 * c0 + d0 / 12.0), hs * (w1 + 0.5 * c1 + d1 / 12.0), hs * (w2 + 0.5 * c2 + d2 / 12.0)


@numba.njit(cache=True)
def hat(v):
    """The skew matrix ``v×`` (a new 3×3 array): ``hat(v) @ x == v × x``."""
    S = np.zeros((3, 3))
    S[0, 1], S[0, 2], S[1, 2] = -v[2], v[1], -v[0]
    S[1, 0], S[2, 0], S[2, 1] = v[2], -v[1], v[0]
    return S


@numba.njit(cache=True)
def wahba(weights, targets, sources):
    """The rotation ``A`` minimising ``Σ w_i |t_i − A s_i|²`` over directions ``targets``, ``sources`` ``(n, 3)``:
    (R6), Markley's SVD solution, which is the rotation nearest to ``Σ w_i t_i s_iᵀ`` (a new 3×3 array)."""
    B = np.zeros((3, 3))  # Σ w_i t_i s_iᵀ
    for i in range(targets.shape[0]):
        for a in range(3):
            for b in range(3):
                B[a, b] += weights[i] * targets[i, a] * sources[i, b]
    return nearest_rotation(B)
