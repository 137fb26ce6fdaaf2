"""Small validators named after what they check; messages name the parameter and the bad value."""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = ["as_directions", "as_inertia", "as_positive", "as_vector3"]


def _fmt(x) -> str:
    return np.array2string(np.asarray(x), precision=6, threshold=12)


def as_inertia(J: ArrayLike, name: str = "J") -> np.ndarray:
    """Inertia of a rigid body as a symmetric positive-definite 3×3 matrix.

    Accepts a 3×3 matrix, 3 numbers (a diagonal) or 9 numbers (a full matrix, row-major). Besides positive
    definiteness, the principal moments ``J₁ ≤ J₂ ≤ J₃`` of any real body satisfy the triangle inequality
    ``J₁ + J₂ ≥ J₃`` (``J₁ + J₂ − J₃ = 2 ∫ z² dm ≥ 0`` about the third principal axis); a matrix that violates it
    (e.g. ``diag(1, 1, 5)``) is not an inertia, most often a typing error, and is refused. Relative slack of
    ``1e-9`` admits the limit of a flat plate (``J₁ + J₂ = J₃``) given with rounding.
    """
    a = np.asarray(J, dtype=float)
    if a.shape in ((3,), (1, 3), (3, 1)):
        a = np.diag(a.ravel())
    elif a.shape == (9,):
        a = a.reshape(3, 3)
    if a.shape != (3, 3):
        raise ValueError(f"{name} must be 3 numbers (diagonal), 9 numbers or a 3x3 matrix; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite; got {_fmt(a)}")
    if not np.allclose(a, a.T, rtol=1e-10, atol=1e-12 * np.abs(a).max()):
        raise ValueError(f"{name} must be symmetric; got {_fmt(a)}")
    eig = np.linalg.eigvalsh(a)
    if eig[0] <= 0:
        raise ValueError(f"{name} must be positive definite; its eigenvalues are {_fmt(eig)}")
    if eig[0] + eig[1] < eig[2] * (1 - 1e-9):
        raise ValueError(
            f"{name} is not the inertia of a rigid body: its principal moments {_fmt(eig)} violate the triangle "
            f"inequality J1 + J2 >= J3 ({eig[0]:.6g} + {eig[1]:.6g} < {eig[2]:.6g}); check the numbers and units"
        )
    return 0.5 * (a + a.T)


def as_vector3(v: ArrayLike, name: str) -> np.ndarray:
    """A finite 3-vector."""
    a = np.asarray(v, dtype=float)
    if a.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite; got {_fmt(a)}")
    return a


def as_positive(x: ArrayLike, name: str, n: int | None = None) -> np.ndarray:
    """Strictly positive finite numbers, broadcast to length ``n`` when given."""
    a = np.atleast_1d(np.asarray(x, dtype=float))
    if n is not None:
        if a.size == 1:
            a = np.full(n, a.item())
        elif a.shape != (n,):
            raise ValueError(f"{name} must be one number or {n} numbers (one per direction); got shape {a.shape}")
    if not np.all(np.isfinite(a)) or np.any(a <= 0):
        raise ValueError(f"{name} must be positive and finite; got {_fmt(a)}")
    return a


def as_directions(v: ArrayLike, name: str = "references", min_angle_deg: float = 1.0) -> np.ndarray:
    """``n ≥ 2`` inertial directions ``(n, 3)``, normalised, two of them at least ``min_angle_deg`` apart."""
    a = np.asarray(v, dtype=float)
    if a.shape == (1, 3):
        raise ValueError(
            f"{name} holds one direction: the rate about it cannot be observed from it alone; for one measured "
            "direction use omegahat.SingleDirectionEstimator (it needs the body to tumble)"
        )
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 2:
        raise ValueError(f"{name} must have shape (n, 3) with n >= 2; got shape {a.shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite; got {_fmt(a)}")
    norms = np.linalg.norm(a, axis=1)
    if np.any(norms == 0):
        raise ValueError(f"{name} must be non-zero vectors; row {int(np.argmin(norms))} is zero")
    u = a / norms[:, None]
    # Largest sine of the angle between any two directions.
    s = np.linalg.norm(np.cross(u[:, None, :], u[None, :, :]), axis=-1).max()
    if s < np.sin(np.radians(min_angle_deg)):
        raise ValueError(
            f"{name} are nearly collinear (largest angle between two of them "
            f"{np.degrees(np.arcsin(min(s, 1.0))):.3g} deg < {min_angle_deg} deg): the angular velocity "
            "about their common axis cannot be observed"
        )
    return u
