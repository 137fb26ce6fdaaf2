r"""Simulated sensors: body-frame directions and noisy attitudes along a trajectory.

* Directions: a known inertial direction ``v_i`` seen in the body is ``r_i = Rᵀ v_i`` (``R`` body→inertial),
  so with ``v_i = e_i`` the ``r_i`` are the rows of R. These obey ``ṙ_i = r_i × ω``.
* Noisy attitude: ``R_meas = R exp(ν)``, ``ν ~ N(0, diag(σ_x², σ_y², σ_z²))`` drawn independently per sample,
  i.e. a small random rotation about body axes with standard deviation σ (rad) per axis, so that
  ``log(Rᵀ R_meas) = ν`` exactly (for |ν| < π).
* Noisy directions: ``r_i,meas = Rᵀ v_i + n_i``, ``n_i ~ N(0, σ² I)`` independently per direction and sample
  (the model of an accelerometer or magnetometer; not renormalised).

Randomness comes only from the ``numpy.random.Generator`` the caller passes (no global state).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3
from omegahat.validation import as_directions

__all__ = ["directions", "noisy_attitudes", "noisy_directions"]


def _as_rotations(R, name="R") -> np.ndarray:
    R = np.asarray(R, dtype=float)
    if R.ndim < 2 or R.shape[-2:] != (3, 3):
        raise ValueError(f"{name} must be rotation matrices of shape (..., 3, 3); got shape {R.shape}")
    return R


def _as_sigma(sigma, shape, name="sigma") -> np.ndarray:
    s = np.asarray(sigma, dtype=float)
    if s.shape not in ((), shape):
        raise ValueError(f"{name} must be one number or {shape[0]} numbers (per axis); got shape {s.shape}")
    if not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"{name} must be non-negative and finite; got {s.tolist()}")
    return np.broadcast_to(s, shape)


def _as_generator(rng) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(
            f"rng must be a numpy.random.Generator (e.g. numpy.random.default_rng(seed)); got {type(rng).__name__}"
        )
    return rng


def directions(R: ArrayLike, references: ArrayLike) -> np.ndarray:
    """``r_i = Rᵀ v_i`` for the unit inertial ``references (n, 3)``. ``R (*B, 3, 3) -> (*B, n, 3)``."""
    R = _as_rotations(R)
    v = as_directions(references, min_angle_deg=0.0)
    # (Rᵀ v_i)_a = Σ_b R_ba v_ib
    return np.einsum("...ba,ib->...ia", R, v)


def noisy_attitudes(R: ArrayLike, sigma: ArrayLike, rng: np.random.Generator) -> np.ndarray:
    """``R exp(ν)`` with ``ν ~ N(0, diag σ²)`` per sample (σ in rad, one number or per body axis).

    ``R (*B, 3, 3) -> (*B, 3, 3)``.
    """
    R = _as_rotations(R)
    s = _as_sigma(sigma, (3,))
    nu = _as_generator(rng).standard_normal((*R.shape[:-2], 3)) * s
    return R @ so3.exp(nu)


def noisy_directions(R: ArrayLike, references: ArrayLike, sigma: ArrayLike, rng: np.random.Generator) -> np.ndarray:
    """``Rᵀ v_i + n_i`` with ``n_i ~ N(0, σ² I)``; ``sigma`` one number or one per direction ``(n,)``.

    ``R (*B, 3, 3) -> (*B, n, 3)``.
    """
    r = directions(R, references)
    n = r.shape[-2]
    s = _as_sigma(sigma, (n,))
    return r + _as_generator(rng).standard_normal(r.shape) * s[:, None]
