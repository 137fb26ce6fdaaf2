r"""The second-order minimum-energy filter on TSO(3): attitude and rate from two (or more) directions, J and τ known.

Source: the public repository ``NikolasKubis/attitude_estimation_TSO3``, ``min_energy_filter/
second_order_minimum_symplectic.m`` with its helpers ``alpha_integration.m``, ``e_integration.m``,
``jacobian_e_integration.m`` (the filter after Saccon, Trumpf, Mahony and Aguiar's second-order-optimal
minimum-energy filters on Lie groups). Written here from the equations, in omegahat's frames (:mod:`omegahat.
baselines.tso3_common`: model (C1), directions (C2), timing (C3)). ``docs/baselines.md`` tells the story.

State: ``R̂``, ``ω̂`` and the symmetric gain ``K`` (6×6, blocks ``K₁₁ K₁₂; K₂₁ K₂₂`` over ``[attitude; rate]``). One
step over ``h``, from the sample ``a_i`` (unit directions, body axes) at its start and the torque τ held::

    b̂_i = R̂ᵀ v_i,      r = Σ_i g_i a_i × b̂_i                    (gradient of the output cost)      (M1)
    δ_R = K₁₁ r,       δ_ω = K₂₁ r                                (the correction K [r; 0])         (M2)
    R̂⁺ = R̂ Exp(h (ω̂ + δ_R))                                                                        (M3)
    N(x) = I − ½ x× + (1/12) (x×)²    (dexp⁻¹ to second order)
    N(−h ω̂⁺) J ω̂⁺ = N(h ω̂) J ω̂ + h (τ + J δ_ω)             (implicit, Newton (C4))               (M4)
    K⁺ = K + h (−α K + A K + K Aᵀ − K E K + B Bᵀ/ρ − W K − K Wᵀ)                                     (M5)
    A = [[−ω̂×, I], [0, J⁻¹((J ω̂)× − ω̂× J)]],   B Bᵀ = [[0, 0], [0, I]],   W = [[½ δ_R×, 0], [0, 0]]
    E = [[E₁₁, 0], [0, 0]],   E₁₁ = Σ_i (q_i/2) (2 (a_i·b̂_i) I − a_i b̂_iᵀ − b̂_i a_iᵀ)   (Hessian of the cost)

(M4) is a symmetric discretisation of Euler's equations (expand N: ``J(ω̂⁺ − ω̂)/h + ½(ω̂⁺ × Jω̂⁺ + ω̂ × Jω̂) = τ +
J δ_ω + O(h)``), second order; (M3) and (M5) are explicit Euler steps of the continuous filter
``Ṙ̂ = R̂ (ω̂ + K₁₁ r)×``, ``ω̂̇ = J⁻¹((Jω̂) × ω̂ + τ) + K₂₁ r``, ``K̇`` as in (M5). The Newton iteration uses the exact
Jacobian of (M4)'s left side (:func:`rate_jacobian`)::

    D(ω) = J + (h/2)(ω× J − (Jω)×) + (h²/12)((ωᵀJω) I + 2 ω ωᵀ J − 2 J ω ωᵀ − |ω|² J)             (M6)

A missing sample drops r and E₁₁ from its step. K is symmetrised after each step (rounding only).

**Settings of the source** (its script): J = diag(6, 7, 9) kg·m², τ(t) = (sin(2πt/3), cos(2πt), sin(2πt/5)) N·m,
ω(0) = (0.3, 0.2, 0.1) rad/s, R(0) = Exp(1.8 rad about (1, 1, 1)/√3), v₁ = e₃, v₂ = e₂, direction noise 0.01 per
component, h = 0.01 s, 100 s; the filter from R̂ = I, ω̂ = 0, K = I₆, α = 0.01 s⁻¹, q₁ = q₂ = 0.1, ρ = 1.
``benchmarks/peers.py`` reproduces it.

**Inconsistencies found in the source** (each one also in ``docs/baselines.md``):

* the gradient (M1) carries no weights (``g_i = 1``) while the Hessian (M5) carries ``q_i = 0.1``: the two are
  the first and second derivatives of one output cost and should share its weights. Default here: ``g_i = q_i``;
  ``as_published=True`` reproduces the source (``g_i = 1``);
* its Newton Jacobian for (M4) is not the derivative of (M4): it has ``(h/4)(ωᵀJω) I + (h/2) ω ωᵀ J`` where (M6) has
  the ``h²/12`` terms. Newton still converges to the same root at its step sizes, so only the iteration count is
  affected; (M6) is used here (checked against finite differences in the tests);
* (M5) carries ``−αK``; a cost discounted by ``e^{−α(t−s)}`` gives ``+αK`` (scalar case: the information
  ``H = e^{−αt}/K₀ + ∫ e^{−α(t−s)} ds/ρ_y`` gives ``K̇ = αK − K²/ρ_y``). Kept as published (``alpha``; a negative
  value gives the discounted form); at α = 0.01 s⁻¹ beside the process weight it changes the gain little;
* in the source's simulation the second sensor's noise is centred with the first sensor's sample mean (``mean46``
  is the mean of rows 1–3), and ``alpha2`` is set but ``alpha`` is used (same value): no effect on the filter;
* the README's figures start from an attitude error of about 68° (the scripts start from 1.8 rad = 103°).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines import tso3_kernel as kernel
from omegahat.baselines.tso3_common import TSO3Filter, exp_so3, newton
from omegahat.validation import as_positive

__all__ = [
    "MinimumEnergyFilter",
    "gradient",
    "hessian",
    "min_energy_step",
    "rate_jacobian",
    "rate_residual",
    "riccati_rate",
]


def gradient(R: np.ndarray, a: np.ndarray, references: np.ndarray, g: np.ndarray) -> np.ndarray:
    """(M1): ``r = Σ_i g_i a_i × (R̂ᵀ v_i)``."""
    return np.sum(g[:, None] * np.cross(a, references @ R), axis=0)


def hessian(R: np.ndarray, a: np.ndarray, references: np.ndarray, q: np.ndarray) -> np.ndarray:
    """(M5)'s ``E₁₁ = Σ_i (q_i/2)(2 (a_i·b̂_i) I − a_i b̂_iᵀ − b̂_i a_iᵀ)``, ``b̂_i = R̂ᵀ v_i``."""
    E = np.zeros((3, 3))
    for qi, ai, bi in zip(q, a, references @ R, strict=True):
        E += 0.5 * qi * (2.0 * np.dot(ai, bi) * np.eye(3) - np.outer(ai, bi) - np.outer(bi, ai))
    return E


def _N(x: np.ndarray) -> np.ndarray:
    X = so3.hat(x)
    return np.eye(3) - 0.5 * X + X @ X / 12.0


def rate_residual(omega: np.ndarray, c: np.ndarray, J: np.ndarray, h: float) -> np.ndarray:
    """(M4) as a residual: ``N(−h ω) J ω − c``."""
    return _N(-h * omega) @ J @ omega - c


def rate_jacobian(omega: np.ndarray, J: np.ndarray, h: float) -> np.ndarray:
    """(M6): the derivative of :func:`rate_residual` in ω."""
    Jw = J @ omega
    w = omega
    second = np.dot(w, Jw) * np.eye(3) + 2.0 * np.outer(w, Jw) - 2.0 * np.outer(Jw, w) - np.dot(w, w) * J
    return J + 0.5 * h * (so3.hat(w) @ J - so3.hat(Jw)) + h * h / 12.0 * second


def riccati_rate(
    K: np.ndarray, omega: np.ndarray, J: np.ndarray, J_inv: np.ndarray, E11: np.ndarray, delta_R: np.ndarray,
    alpha: float, process_weight: float,
) -> np.ndarray:  # fmt: skip
    """(M5)'s right side ``K̇`` (``process_weight`` is ``1/ρ``)."""
    A = np.zeros((6, 6))
    A[:3, :3] = -so3.hat(omega)
    A[:3, 3:] = np.eye(3)
    A[3:, 3:] = J_inv @ (so3.hat(J @ omega) - so3.hat(omega) @ J)
    E = np.zeros((6, 6))
    E[:3, :3] = E11
    BB = np.zeros((6, 6))
    BB[3:, 3:] = process_weight * np.eye(3)
    W = np.zeros((6, 6))
    W[:3, :3] = 0.5 * so3.hat(delta_R)
    return -alpha * K + A @ K + K @ A.T - K @ E @ K + BB - W @ K - K @ W.T


def min_energy_step(
    R: np.ndarray, omega: np.ndarray, K: np.ndarray, a: np.ndarray | None, references: np.ndarray, tau: np.ndarray,
    h: float, J: np.ndarray, J_inv: np.ndarray, q: np.ndarray, g: np.ndarray, alpha: float, process_weight: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:  # fmt: skip
    """(M1)–(M5) over ``h`` from the sample ``a`` ``(n, 3)`` (None: missing); ``(R̂⁺, ω̂⁺, K⁺)``, None when (M4)'s
    Newton iteration fails."""
    if a is None:
        r, E11 = np.zeros(3), np.zeros((3, 3))
    else:
        r, E11 = gradient(R, a, references, g), hessian(R, a, references, q)
    delta_R, delta_w = K[:3, :3] @ r, K[3:, :3] @ r
    R_next = R @ exp_so3(h * (omega + delta_R))
    c = _N(h * omega) @ J @ omega + h * (tau + J @ delta_w)
    w_next = newton(lambda w: rate_residual(w, c, J, h), lambda w: rate_jacobian(w, J, h), omega)
    if w_next is None:
        return None
    K_next = K + h * riccati_rate(K, omega, J, J_inv, E11, delta_R, alpha, process_weight)
    return R_next, w_next, 0.5 * (K_next + K_next.T)


class MinimumEnergyFilter(TSO3Filter):
    """The second-order minimum-energy filter of the module docstring behind the estimator contract.

    ``gain`` holds K. :meth:`update` runs :func:`min_energy_step` (NumPy), :meth:`run` its compiled twin
    (:mod:`omegahat.baselines.tso3_kernel`); a step that cannot be taken restarts the filter ((C5) of
    :mod:`omegahat.baselines.tso3_common`).

    Parameters
    ----------
    J : inertia (3 numbers, 9 numbers or 3×3), kg·m²; the one positional argument.
    references : ``None`` for attitude samples (their three directions), else the inertial directions ``(n, 3)``.
    weights : the output cost's weights ``q_i`` (one number or one per direction; the source: 0.1).
    process_weight : ``1/ρ``, the weight of the rate's model error in (M5) (the source: 1).
    alpha : the ``−αK`` term's α, 1/s (the source: 0.01).
    K0 : the initial gain (6×6, or one number times I₆; the source: I₆).
    omega_hat0, R0 : the initial rate (rad/s; default 0, and then no estimate at the first valid sample) and
        attitude (``None``: the first valid sample's least-squares attitude; the source starts from the identity).
    as_published : True: the gradient (M1) without the weights, as in the source script.
    scalar_first, rotation_tol, quat_norm_tol, min_angle_deg : the input checks of :mod:`omegahat.measurements`.
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        references: ArrayLike | None = None,
        weights: ArrayLike = 0.1,
        process_weight: float = 1.0,
        alpha: float = 0.01,
        K0: ArrayLike = 1.0,
        omega_hat0: ArrayLike | None = None,
        R0: ArrayLike | Rotation | None = None,
        as_published: bool = False,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
    ) -> None:
        n = 3 if references is None else np.atleast_2d(np.asarray(references)).shape[0]
        self.weights = as_positive(weights, "weights", n)
        self.as_published = bool(as_published)
        self.gradient_weights = np.ones(n) if self.as_published else self.weights.copy()
        self.process_weight = float(as_positive(process_weight, "process_weight")[0])
        if not np.isfinite(alpha):
            raise ValueError(f"alpha must be finite; got {alpha!r}")
        self.alpha = float(alpha)
        K = np.asarray(K0, dtype=float)
        K = K * np.eye(6) if K.ndim == 0 else K
        if K.shape != (6, 6) or not np.all(np.isfinite(K)) or not np.allclose(K, K.T):
            raise ValueError(f"K0 must be one number or a symmetric finite 6x6 matrix; got shape {K.shape}")
        if np.linalg.eigvalsh(K)[0] <= 0:
            raise ValueError("K0 must be positive definite")
        self.K0 = K
        super().__init__(
            J, references=references, omega_hat0=omega_hat0, R0=R0, scalar_first=scalar_first,
            rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol, min_angle_deg=min_angle_deg,
        )  # fmt: skip

    def _initial_gain(self) -> np.ndarray:
        return self.K0.copy()

    def _numpy_step(self, R, omega, gain, a, tau, h):
        return min_energy_step(
            R, omega, gain, a, self.directions, tau, h, self.J, self.J_inv, self.weights, self.gradient_weights,
            self.alpha, self.process_weight,
        )  # fmt: skip

    def _run_compiled(self, times, values, valid, taus, state, R, gain, prev):
        params = np.array([self.alpha, self.process_weight, 0.0, 0.0])
        return kernel.run_log(
            kernel.MIN_ENERGY, times, values, valid, taus, np.ascontiguousarray(self.directions), self.J, self.J_inv,
            self.weights, self.gradient_weights, params, state, R, gain, prev, self.omega_hat0, self.K0,
        )  # fmt: skip
