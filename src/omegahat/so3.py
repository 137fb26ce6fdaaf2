r"""Rotations: the group SO(3) and its Lie algebra, batched over leading axes.

Conventions (used everywhere in omegahat):

* ``R`` maps body to inertial: ``v_inertial = R @ v_body``; kinematics ``Ṙ = R ω×`` with ω in body axes.
* ``hat(v)`` is the skew matrix with ``hat(v) @ x == cross(v, x)``; ``vee`` is its inverse.
* ``exp(φ) = I + sin θ/θ φ× + (1 − cos θ)/θ² φ×²`` (Rodrigues), θ = |φ|; ``log`` is its inverse with
  ``|log R| ≤ π``.
* Quaternions follow SciPy: scalar **last** ``(x, y, z, w)`` unless ``scalar_first=True``. A quaternion and
  its negative are the same rotation.

Every function broadcasts over leading axes: a vector is ``(*B, 3)``, a matrix ``(*B, 3, 3)``, a quaternion
``(*B, 4)``.

Numerical care:

* near the identity the coefficients of ``exp``/``log`` are evaluated by their Taylor series (the closed forms
  lose all digits as θ → 0);
* near θ = π the axis of ``log`` is read from the symmetric part ``(R + Rᵀ)/2 = cos θ I + (1 − cos θ) a aᵀ``,
  because the antisymmetric part ``sin θ a×`` vanishes there (used for θ > 2 rad).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "as_matrix",
    "exp",
    "from_quat",
    "hat",
    "is_rotation",
    "log",
    "orthogonality_error",
    "project",
    "to_quat",
    "vee",
]

# Below this angle the Taylor branches are used; their truncation error is O(θ⁶) ≈ 1e-24 there.
_SMALL_ANGLE = 1e-4
# Above this angle (rad) log reads the axis from the symmetric part. The generic branch θ/sin θ · vee(R) loses
# digits as ε/sin θ (1.4e-14 in exp(log R) at π − 1e-2); the symmetric part (1 − cos θ) a aᵀ is accurate once
# 1 − cos θ ≥ 1, so switch well before π: with 2.0 rad both branches stay within 1.3e-15 (tests/test_so3.py).
_NEAR_PI = 2.0


def _check_vectors(v, name: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    if v.shape[-1:] != (3,):
        raise ValueError(f"{name} expects vectors of shape (..., 3), got shape {v.shape}")
    return v


def _check_matrices(M, name: str) -> np.ndarray:
    M = np.asarray(M, dtype=float)
    if M.shape[-2:] != (3, 3):
        raise ValueError(f"{name} expects matrices of shape (..., 3, 3), got shape {M.shape}")
    return M


def hat(v):
    """Skew-symmetric matrix of ``v``: ``hat(v) @ x == np.cross(v, x)``. ``(*B, 3) -> (*B, 3, 3)``."""
    v = _check_vectors(v, "hat")
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack(
        [np.stack([o, -z, y], -1), np.stack([z, o, -x], -1), np.stack([-y, x, o], -1)],
        axis=-2,
    )


def vee(S):
    """Inverse of :func:`hat` (the antisymmetric part is read off; ``(*B, 3, 3) -> (*B, 3)``)."""
    S = _check_matrices(S, "vee")
    return 0.5 * np.stack(
        [S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]], axis=-1
    )


def _exp_coefficients(theta):
    """``a = sin θ / θ`` and ``b = (1 − cos θ) / θ²``, with Taylor series near 0."""
    small = theta < _SMALL_ANGLE
    t = np.where(small, 1.0, theta)  # avoid 0/0 in the branch that is discarded
    t2 = theta * theta
    a = np.where(small, 1.0 - t2 / 6.0 + t2 * t2 / 120.0, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24.0 + t2 * t2 / 720.0, (1.0 - np.cos(t)) / (t * t))
    return a, b


def exp(phi):
    """Rotation matrix ``exp(φ×)`` of a rotation vector ``φ``. ``(*B, 3) -> (*B, 3, 3)``."""
    phi = _check_vectors(phi, "exp")
    K = hat(phi)
    theta = np.linalg.norm(phi, axis=-1)
    a, b = _exp_coefficients(theta)
    eye = np.broadcast_to(np.eye(3), K.shape)
    return eye + a[..., None, None] * K + b[..., None, None] * (K @ K)


def log(R):
    """Rotation vector ``φ`` with ``exp(φ) = R`` and ``|φ| ≤ π``. ``(*B, 3, 3) -> (*B, 3)``.

    At exactly θ = π both ``±π a`` are valid; the sign is then whatever the rounding of ``R − Rᵀ`` gives.
    """
    R = _check_matrices(R, "log")
    w = vee(R)  # = sin θ · a
    s = np.linalg.norm(w, axis=-1)
    c = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)  # = cos θ
    theta = np.arctan2(s, c)

    # Generic and near-identity branch: φ = θ / sin θ · w.
    small = theta < _SMALL_ANGLE
    t2 = theta * theta
    safe_s = np.where(s > 0, s, 1.0)
    scale = np.where(small, 1.0 + t2 / 6.0 + 7.0 * t2 * t2 / 360.0, theta / safe_s)
    phi = scale[..., None] * w

    near_pi = theta > _NEAR_PI
    if np.any(near_pi):
        # (R + Rᵀ)/2 − cos θ I = (1 − cos θ) a aᵀ: take the column with the largest diagonal entry.
        Rs = R[near_pi]
        cs = c[near_pi]
        A = 0.5 * (Rs + np.swapaxes(Rs, -1, -2)) - cs[:, None, None] * np.eye(3)
        idx = np.argmax(np.diagonal(A, axis1=-2, axis2=-1), axis=-1)
        col = np.take_along_axis(A, idx[:, None, None], axis=-1)[..., 0]
        axis = col / np.linalg.norm(col, axis=-1, keepdims=True)
        sign = np.where(np.einsum("...i,...i", axis, w[near_pi]) < 0, -1.0, 1.0)
        phi[near_pi] = (sign * theta[near_pi])[:, None] * axis
    return phi


def orthogonality_error(R):
    """Frobenius norm of ``RᵀR − I`` (0 for an exact rotation). ``(*B, 3, 3) -> (*B,)``."""
    R = _check_matrices(R, "orthogonality_error")
    return np.linalg.norm(np.swapaxes(R, -1, -2) @ R - np.eye(3), axis=(-2, -1))


def is_rotation(R, tol=1e-6):
    """True where ``‖RᵀR − I‖_F ≤ tol`` and ``det R > 0``. ``(*B, 3, 3) -> (*B,)`` booleans."""
    R = _check_matrices(R, "is_rotation")
    return (orthogonality_error(R) <= tol) & (np.linalg.det(R) > 0)


def project(M):
    """Nearest rotation to ``M`` in the Frobenius norm (special orthogonal polar factor, by SVD)."""
    M = _check_matrices(M, "project")
    U, _, Vt = np.linalg.svd(M)
    d = np.sign(np.linalg.det(U @ Vt))
    d = np.where(d == 0, 1.0, d)
    D = np.ones(M.shape[:-1])
    D[..., -1] = d
    return (U * D[..., None, :]) @ Vt


def from_quat(q, scalar_first=False):
    """Rotation matrix of unit quaternion(s) ``q`` (normalised here). ``(*B, 4) -> (*B, 3, 3)``."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"quaternions must have shape (..., 4), got shape {q.shape}")
    if scalar_first:
        q = np.roll(q, -1, axis=-1)
    q = q / np.linalg.norm(q, axis=-1, keepdims=True)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack(
        [
            np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)], -1),
            np.stack([2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)], -1),
            np.stack([2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)], -1),
        ],
        axis=-2,
    )


def to_quat(R, scalar_first=False):
    """Unit quaternion of rotation matrix ``R``, scalar part ≥ 0 (SciPy's algorithm). ``(*B,3,3)->(*B,4)``."""
    R = _check_matrices(R, "to_quat")
    flat = R.reshape(-1, 3, 3)
    q = Rotation.from_matrix(flat).as_quat(canonical=True)
    if scalar_first:
        q = np.roll(q, 1, axis=-1)
    return q.reshape((*R.shape[:-2], 4))


def as_matrix(attitude, scalar_first=False):
    """Rotation matrices from a ``Rotation``, matrices ``(*B, 3, 3)`` or quaternions ``(*B, 4)``.

    No validation beyond the shape: see :mod:`omegahat.measurements` for checked conversion of user input.
    """
    if isinstance(attitude, Rotation):
        return attitude.as_matrix()
    a = np.asarray(attitude, dtype=float)
    if a.shape[-2:] == (3, 3):
        return a
    if a.shape[-1:] == (4,):
        return from_quat(a, scalar_first=scalar_first)
    raise ValueError(
        f"an attitude must be a scipy Rotation, matrices (..., 3, 3) or quaternions (..., 4); got shape {a.shape}"
    )
