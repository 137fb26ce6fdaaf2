r"""The continuous-time observer of I. Sarras, with the sign of its output map corrected.

Reference: I. Sarras, "Continuous globally exponential rigid-body angular velocity estimation from attitude
measurements" (IFAC). The equations below are those of ``docs/theory/observer.md``, which corrects the paper.

Measured directions ``r_i = Rᵀ v_i`` (i = 1..n, n ≥ 2, two of them not collinear; the rows of R are the case
``v_i = e_i``) obey ``ṙ_i = r_i × ω``. With gains ``k_i > 0`` and ``l_i(ω̂) > 0`` the observer is::

    ω̂    = ξ + J⁻¹ Σ k_i r_i × r̂_i                                            (β, output map)
    ξ̇    = −J⁻¹ Σ k_i (r_i × r̂_i) × ω̂ + J⁻¹ Σ l_i k_i r_i × (r̂_i − r_i) + J⁻¹((Jω̂) × ω̂ + τ)
    r̂̇_i = r̂_i × ω̂ − l_i (r̂_i − r_i)

**Erratum.** The paper prints ``ω̂ = ξ + J⁻¹ Σ k_i r̂_i × r_i`` (``OUTPUT_SIGN_PRINTED = -1`` here). Its own ξ̇
and its initialisation ``ξ₀ = Σ k_i J⁻¹ (r̂_i0 × r_i0)`` (chosen so that ω̂₀ = 0) agree with the sign above; with
constant ``l_i = 1`` the printed map diverges while the corrected one converges (``tests/test_observer.py``).

Error dynamics, with ``z = ω̂ − ω`` and ``e_i = r̂_i − r_i`` (the test oracle)::

    ż   = J⁻¹ Σ k_i r̂_i × (r_i × z) + J⁻¹((Jω̂) × ω̂ − (Jω) × ω)
    ė_i = r_i × z + e_i × ω̂ − l_i e_i

and the proof's Lyapunov function ``V = |J z| + ½ Σ |e_i|²``.

The gain ``l_i`` may depend on ω̂ (the theorem's ``l_i(ω̂) = l_i0 + (|ω̂| + ω_M)(1 + k_i/J_m (1 + 2 k_i/J_m))``).
It is represented everywhere as the affine function ``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|``: see
:class:`omegahat.observer.gains.ObserverGains`.

Arrays: directions ``(n, 3)``, vectors ``(3,)``; these plain functions are the readable oracle that the fast
simulator (:mod:`omegahat.simulation.coupled`) and the sampled estimator are tested against.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3

__all__ = [
    "OUTPUT_SIGN_CORRECTED",
    "OUTPUT_SIGN_PRINTED",
    "error_dynamics",
    "gain_l",
    "lyapunov",
    "observer_rhs",
    "output_map",
    "xi_for_omega_hat",
]

OUTPUT_SIGN_CORRECTED = 1.0  #: ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i (observer.md)
OUTPUT_SIGN_PRINTED = -1.0  #: ω̂ = ξ + J⁻¹ Σ k_i r̂_i × r_i (the paper's theorem: wrong)


def gain_l(omega_hat: ArrayLike, l_offset: ArrayLike, l_slope: ArrayLike) -> np.ndarray:
    """``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|``, shape ``(n,)``."""
    return np.asarray(l_offset, float) + np.asarray(l_slope, float) * np.linalg.norm(omega_hat)


def output_map(
    xi: np.ndarray,
    r: np.ndarray,
    r_hat: np.ndarray,
    k: ArrayLike,
    J_inv: np.ndarray,
    sign: float = OUTPUT_SIGN_CORRECTED,
) -> np.ndarray:
    """ω̂ = ξ + sign · J⁻¹ Σ k_i r_i × r̂_i (β of the paper, corrected for ``sign = +1``)."""
    return xi + sign * (J_inv @ np.sum(np.asarray(k)[:, None] * so3.cross(r, r_hat), axis=0))


def xi_for_omega_hat(
    omega_hat: ArrayLike,
    r: np.ndarray,
    r_hat: np.ndarray,
    k: ArrayLike,
    J_inv: np.ndarray,
    sign: float = OUTPUT_SIGN_CORRECTED,
) -> np.ndarray:
    """The ξ that makes the output map give ``omega_hat`` (the paper's initialisation uses ω̂₀ = 0)."""
    return np.asarray(omega_hat, float) - output_map(np.zeros(3), r, r_hat, k, J_inv, sign)


def observer_rhs(
    xi: np.ndarray,
    r_hat: np.ndarray,
    r: np.ndarray,
    tau: ArrayLike,
    J: np.ndarray,
    J_inv: np.ndarray,
    k: ArrayLike,
    l_offset: ArrayLike,
    l_slope: ArrayLike,
    sign: float = OUTPUT_SIGN_CORRECTED,
) -> tuple[np.ndarray, np.ndarray]:
    """Right-hand side ``(ξ̇, r̂̇)`` of the observer, term by term as in observer.md.

    ``sign`` selects the output map (the ξ̇ and r̂̇ equations are the same for both).
    """
    k = np.asarray(k, float)
    omega_hat = output_map(xi, r, r_hat, k, J_inv, sign)
    l = gain_l(omega_hat, l_offset, l_slope)
    r_cross_rhat = so3.cross(r, r_hat)  # (n, 3)
    xi_dot = (
        -J_inv @ np.sum(k[:, None] * so3.cross(r_cross_rhat, omega_hat), axis=0)
        + J_inv @ np.sum((l * k)[:, None] * so3.cross(r, r_hat - r), axis=0)
        + J_inv @ (so3.cross(J @ omega_hat, omega_hat) + tau)
    )
    r_hat_dot = so3.cross(r_hat, omega_hat) - l[:, None] * (r_hat - r)
    return xi_dot, r_hat_dot


def error_dynamics(
    z: np.ndarray,
    e: np.ndarray,
    r: np.ndarray,
    omega: np.ndarray,
    J: np.ndarray,
    J_inv: np.ndarray,
    k: ArrayLike,
    l_offset: ArrayLike,
    l_slope: ArrayLike,
) -> tuple[np.ndarray, np.ndarray]:
    """``(ż, ė)`` of observer.md at error ``z = ω̂ − ω``, ``e_i = r̂_i − r_i`` and true ``r``, ``ω``."""
    k = np.asarray(k, float)
    omega_hat = omega + z
    r_hat = r + e
    l = gain_l(omega_hat, l_offset, l_slope)
    z_dot = J_inv @ (
        np.sum(k[:, None] * so3.cross(r_hat, so3.cross(r, z)), axis=0)
        + so3.cross(J @ omega_hat, omega_hat)
        - so3.cross(J @ omega, omega)
    )
    e_dot = so3.cross(r, z) + so3.cross(e, omega_hat) - l[:, None] * e
    return z_dot, e_dot


def lyapunov(z: ArrayLike, e: ArrayLike, J: ArrayLike) -> np.ndarray:
    """The proof's ``V = |J z| + ½ Σ |e_i|²``; broadcasts over leading axes (``z (*B,3)``, ``e (*B,n,3)``)."""
    z = np.asarray(z, float)
    e = np.asarray(e, float)
    return np.linalg.norm(z @ np.asarray(J).T, axis=-1) + 0.5 * np.sum(e * e, axis=(-2, -1))
