r"""Rotations: the group SO(3) and its Lie algebra, batched over leading axes.

Conventions (used everywhere in omegahat):

* ``R`` maps body to inertial: ``v_inertial = R @ v_body``; kinematics ``Ṙ = R ω×`` with ω in body axes.
* ``hat(v)`` is the skew matrix with ``hat(v) @ x == cross(v, x)``; ``vee`` is its inverse.
* ``exp(φ) = I + sin θ/θ φ× + (1 − cos θ)/θ² φ×²`` (Rodrigues), θ = |φ|; ``log`` is its inverse with
  ``|log R| ≤ π``.
* Quaternions follow SciPy: scalar **last** ``(x, y, z, w)`` unless ``scalar_first=True``. A quaternion and
  its negative are the same rotation.

Every function broadcasts over leading axes: a vector is ``(*B, 3)``, a matrix ``(*B, 3, 3)``, a quaternion
``(*B, 4)``. The formulas are the compiled kernels of :mod:`omegahat.kernels.rotation` (written once, there),
applied to every element: exp through the unit quaternion ``(sin(θ/2) â, cos(θ/2))`` with Taylor series near the
identity, log through the quaternion by Shepperd's method and ``2 atan2(|q_v|, w)`` (accurate at every angle,
near 0 and near π alike), the nearest rotation by the SVD. ``tests/test_so3.py`` checks them against SciPy's
``Rotation`` and the group laws.
"""

from __future__ import annotations

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat.kernels import rotation as rot

__all__ = [
    "angle",
    "as_matrix",
    "coning",
    "cross",
    "exp",
    "from_quat",
    "hat",
    "increments",
    "is_rotation",
    "log",
    "orthogonality_error",
    "project",
    "quat_product",
    "to_quat",
    "vee",
    "wahba",
]


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


def _rows(a: np.ndarray, width: tuple[int, ...]) -> np.ndarray:
    """``a`` as a C-contiguous stack ``(N, *width)`` of its leading axes."""
    return np.ascontiguousarray(a.reshape((-1, *width)))


# ------------------------------------------------------------------------- the kernels applied element by element


@numba.njit(cache=True)
def _exp_rows(phi, out):
    for j in range(phi.shape[0]):
        rot.store(rot.exp_matrix(phi[j, 0], phi[j, 1], phi[j, 2]), out[j])


@numba.njit(cache=True)
def _log_rows(R, out):
    for j in range(R.shape[0]):
        out[j, 0], out[j, 1], out[j, 2] = rot.rotvec_from_matrix(R[j])


@numba.njit(cache=True)
def _from_quat_rows(q, out):
    for j in range(q.shape[0]):
        n = np.sqrt(q[j, 0] * q[j, 0] + q[j, 1] * q[j, 1] + q[j, 2] * q[j, 2] + q[j, 3] * q[j, 3])
        rot.store(rot.matrix_from_quat(q[j, 0] / n, q[j, 1] / n, q[j, 2] / n, q[j, 3] / n), out[j])


@numba.njit(cache=True)
def _to_quat_rows(R, out):
    for j in range(R.shape[0]):
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = rot.quat_from_matrix(R[j])


@numba.njit(cache=True)
def _quat_product_rows(p, q, out):
    for j in range(q.shape[0]):
        out[j, 0], out[j, 1], out[j, 2], out[j, 3] = rot.quat_multiply(
            p[0], p[1], p[2], p[3], q[j, 0], q[j, 1], q[j, 2], q[j, 3]
        )


@numba.njit(cache=True)
def _orthogonality_rows(R, err, det):
    for j in range(R.shape[0]):
        err[j] = rot.orthogonality_error(R[j])
        det[j] = rot.det(R[j])


@numba.njit(cache=True)
def _project_rows(M, out):
    for j in range(M.shape[0]):
        out[j] = rot.nearest_rotation(M[j])


# --------------------------------------------------------------------------------------------------- public


def hat(v: ArrayLike) -> np.ndarray:
    """Skew-symmetric matrix of ``v``: ``hat(v) @ x == np.cross(v, x)``. ``(*B, 3) -> (*B, 3, 3)``."""
    v = _check_vectors(v, "hat")
    x, y, z = v[..., 0], v[..., 1], v[..., 2]
    o = np.zeros_like(x)
    return np.stack([np.stack([o, -z, y], -1), np.stack([z, o, -x], -1), np.stack([-y, x, o], -1)], axis=-2)


def cross(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """``a × b`` of 3-vectors or stacks of them, broadcast as ``np.cross`` does, in float: the same numbers as
    ``np.cross`` without its moving of axes on every call, which dominates on one vector. The observer's right-hand
    sides are called tens of thousands of times per integration, each with several cross products.
    ``(*A, 3), (*B, 3) -> (*broadcast(A, B), 3)``."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    if a.shape[-1:] != (3,) or b.shape[-1:] != (3,):
        raise ValueError(f"cross: 3-vectors expected, got shapes {a.shape} and {b.shape}")
    if a.ndim == 1 and b.ndim == 1:  # one pair (a streaming step): Python floats beat nine array operations
        a0, a1, a2 = a.tolist()
        b0, b1, b2 = b.tolist()
        return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a[..., 1] * b[..., 2] - a[..., 2] * b[..., 1]
    out[..., 1] = a[..., 2] * b[..., 0] - a[..., 0] * b[..., 2]
    out[..., 2] = a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
    return out


def vee(S: ArrayLike) -> np.ndarray:
    """Inverse of :func:`hat` (the antisymmetric part is read off; ``(*B, 3, 3) -> (*B, 3)``)."""
    S = _check_matrices(S, "vee")
    return 0.5 * np.stack([S[..., 2, 1] - S[..., 1, 2], S[..., 0, 2] - S[..., 2, 0], S[..., 1, 0] - S[..., 0, 1]], -1)


def exp(phi: ArrayLike) -> np.ndarray:
    """Rotation matrix ``exp(φ×)`` of a rotation vector ``φ``. ``(*B, 3) -> (*B, 3, 3)``."""
    phi = _check_vectors(phi, "exp")
    out = np.empty((*phi.shape[:-1], 3, 3))
    _exp_rows(_rows(phi, (3,)), out.reshape(-1, 3, 3))
    return out


def log(R: ArrayLike) -> np.ndarray:
    """Rotation vector ``φ`` with ``exp(φ) = R`` and ``|φ| ≤ π``. ``(*B, 3, 3) -> (*B, 3)``.

    At exactly θ = π both ``±π a`` are valid; the one returned is the one with a non-negative quaternion scalar
    part's sign convention of SciPy.
    """
    R = _check_matrices(R, "log")
    out = np.empty(R.shape[:-1])
    _log_rows(_rows(R, (3, 3)), out.reshape(-1, 3))
    return out


def increments(R: ArrayLike) -> np.ndarray:
    """The body-frame increments ``φ_k = log(R_kᵀ R_{k+1})`` of consecutive rotations. ``(T, 3, 3) -> (T − 1, 3)``;
    NaN where either rotation is NaN (a missing sample)."""
    R = np.asarray(R, dtype=float)
    return log(np.swapaxes(R[:-1], -1, -2) @ R[1:])


def angle(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    r"""The angle (rad, 0 … π) of the turn between the attitudes ``a`` and ``b``, row by row: quaternions ``(*B, 4)``
    (of any norm and sign, the scalar first or last alike: the angle depends on none of them) or rotation matrices
    ``(*B, 3, 3)``; NaN where either is missing. Both forms are of half-angles, accurate at every angle::

        θ = 4 atan2(|â − s b̂|, |â + s b̂|),   â = a/|a|, b̂ = b/|b|, s = ±1 the sign of â·b̂        (quaternions)
        θ = atan2(|vee(M)|, (tr M − 1) / 2),   M = aᵀ b  (vee reads the antisymmetric part)       (matrices)
    """
    x, y = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    with np.errstate(invalid="ignore", divide="ignore"):  # missing samples: NaN angles
        if x.shape[-1] == 4:
            dot = np.einsum("...i,...i->...", x, y)
            x = x / np.sqrt(np.einsum("...i,...i->...", x, x))[..., None]
            y = y * (np.copysign(1.0, dot) / np.sqrt(np.einsum("...i,...i->...", y, y)))[..., None]
            apart, together = x - y, x + y
            return 4.0 * np.arctan2(
                np.sqrt(np.einsum("...i,...i->...", apart, apart)),
                np.sqrt(np.einsum("...i,...i->...", together, together)),
            )
        M = np.swapaxes(x, -1, -2) @ y
        return np.arctan2(np.linalg.norm(vee(M), axis=-1), 0.5 * (np.trace(M, axis1=-2, axis2=-1) - 1.0))


def coning(omega_start: ArrayLike, omega_end: ArrayLike, h: ArrayLike) -> np.ndarray:
    r"""The second-order term of an increment's log: for a body rate ``ω(t)`` over a step ``h`` (``Ṙ = R ω×``), ::

        log(R_kᵀ R_{k+1}) / h = (1/h) ∫ ω dt + (h/12) ω_k × ω_{k+1} + O(h³)                              (M1)

    (Magnus: the increment's log is ``∫ω − ½ ∫∫_{s<u} ω(u) × ω(s)``; for ``ω = ω_k + s ω̇`` the double integral is
    ``(h³/6) ω̇ × ω_k``, and ``h ω_k × ω̇ = ω_k × ω_{k+1}`` to first order). A rate whose axis turns (coning) makes
    differenced attitudes depart from the interval's mean rate by this much; a rate of fixed axis does not.
    ``(*B, 3), (*B, 3), (*B,) or scalar -> (*B, 3)``: rad/s."""
    if isinstance(h, float):  # one step's (a streaming filter's): no broadcasting needed
        return (h / 12.0) * cross(omega_start, omega_end)
    a, b = np.asarray(omega_start, dtype=float), np.asarray(omega_end, dtype=float)
    return np.asarray(h, dtype=float)[..., None] / 12.0 * cross(a, b)


def orthogonality_error(R: ArrayLike) -> np.ndarray:
    """Frobenius norm of ``RᵀR − I`` (0 for an exact rotation). ``(*B, 3, 3) -> (*B,)``."""
    R = _check_matrices(R, "orthogonality_error")
    err, det = np.empty(R.shape[:-2]), np.empty(R.shape[:-2])
    _orthogonality_rows(_rows(R, (3, 3)), err.reshape(-1), det.reshape(-1))
    return err


def is_rotation(R: ArrayLike, tol: float = 1e-6) -> np.ndarray:
    """True where ``‖RᵀR − I‖_F ≤ tol`` and ``det R > 0``. ``(*B, 3, 3) -> (*B,)`` booleans."""
    R = _check_matrices(R, "is_rotation")
    err, det = np.empty(R.shape[:-2]), np.empty(R.shape[:-2])
    _orthogonality_rows(_rows(R, (3, 3)), err.reshape(-1), det.reshape(-1))
    return (err <= tol) & (det > 0)


def project(M: ArrayLike) -> np.ndarray:
    """Nearest rotation to ``M`` in the Frobenius norm (special orthogonal polar factor, by SVD)."""
    M = _check_matrices(M, "project")
    out = np.empty(M.shape)
    _project_rows(_rows(M, (3, 3)), out.reshape(-1, 3, 3))
    return out


def wahba(directions: ArrayLike, references: ArrayLike) -> np.ndarray:
    """The least-squares attitude of each sample of body-frame ``directions`` of the inertial ``references`` (Wahba's
    problem, equal weights; both sets of directions are normalised here)::

        R_k = argmin_R Σ_i |v_i − R b_ki|² = project(Σ_i v_i b_kiᵀ)                                      (W)

    ``(T, n, 3)`` and ``(n, 3)`` ``-> (T, 3, 3)``; NaN where a sample's directions are not finite. Unique where at
    least two of the sample's directions are not collinear (the callers check it)."""
    b = np.asarray(directions, dtype=float)
    V = np.asarray(references, dtype=float)
    if b.ndim != 3 or b.shape[2] != 3 or V.shape != (b.shape[1], 3):
        raise ValueError(f"wahba needs directions (T, n, 3) and references (n, 3); got {b.shape} and {V.shape}")
    out = np.full((b.shape[0], 3, 3), np.nan)
    ok = np.all(np.isfinite(b.reshape(b.shape[0], -1)), axis=1)
    unit = b[ok] / np.linalg.norm(b[ok], axis=2, keepdims=True)
    V = V / np.linalg.norm(V, axis=1, keepdims=True)
    out[ok] = project(np.einsum("ni,tnj->tij", V, unit))
    return out


def from_quat(q: ArrayLike, scalar_first: bool = False) -> np.ndarray:
    """Rotation matrix of quaternion(s) ``q`` (normalised here). ``(*B, 4) -> (*B, 3, 3)``."""
    q = np.asarray(q, dtype=float)
    if q.shape[-1:] != (4,):
        raise ValueError(f"quaternions must have shape (..., 4), got shape {q.shape}")
    if scalar_first:
        q = np.roll(q, -1, axis=-1)
    out = np.empty((*q.shape[:-1], 3, 3))
    _from_quat_rows(_rows(q, (4,)), out.reshape(-1, 3, 3))
    return out


def to_quat(R: ArrayLike, scalar_first: bool = False) -> np.ndarray:
    """Unit quaternion of rotation matrix ``R``, scalar part ≥ 0 (SciPy's rules). ``(*B,3,3) -> (*B,4)``."""
    R = _check_matrices(R, "to_quat")
    out = np.empty((*R.shape[:-2], 4))
    _to_quat_rows(_rows(R, (3, 3)), out.reshape(-1, 4))
    return np.roll(out, 1, axis=-1) if scalar_first else out


def quat_product(p: ArrayLike, q: ArrayLike) -> np.ndarray:
    """Hamilton product ``p ⊗ q`` of one quaternion ``p (4,)`` and quaternions ``q (*B, 4)``, scalar last: the
    rotation ``R(p) R(q)``. Neither is normalised (``|p ⊗ q| = |p| |q|``), so a sample's norm is kept as it came.
    ``-> (*B, 4)``."""
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    if p.shape != (4,) or q.shape[-1:] != (4,):
        raise ValueError(f"quat_product expects p of shape (4,) and q of shape (..., 4); got {p.shape} and {q.shape}")
    out = np.empty(q.shape)
    _quat_product_rows(p, _rows(q, (4,)), out.reshape(-1, 4))
    return out


def as_matrix(attitude: ArrayLike | Rotation, scalar_first: bool = False) -> np.ndarray:
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
