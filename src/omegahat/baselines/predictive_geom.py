r"""The geometric predictive filter on TSO(3): attitude and rate from two (or more) directions, J and τ known.

Source: the public repository ``NikolasKubis/attitude_estimation_TSO3``, ``geom_filter/predictive_filter_geom.m``
(after a TU Delft thesis, ``resolver.tudelft.nl/uuid:23eac88f-a75a-4d8d-aaa5-dcfe32d7c909``), a predictive filter in
the manner of Crassidis and Markley's: each step finds the smallest unmodelled angular acceleration δ that makes the
directions predicted one step ahead agree with the measured ones, and feeds it to the rate. Written here from the
equations, in omegahat's frames (:mod:`omegahat.baselines.tso3_common`: (C1)–(C3)); ``docs/baselines.md`` tells the
story. One step over ``h`` from the sample ``y_i`` (unit directions, body axes) at its start, τ held::

    b̂_i = R̂ᵀ v_i,      ω̂̇ = J⁻¹((J ω̂) × ω̂ + τ)                                                      (G1)
    ζ_i = −h ω̂ × b̂_i + (h²/2)(b̂_i × ω̂̇ + ω̂ × (ω̂ × b̂_i))     (b over h to second order)             (G2)
    b_i(h) ≈ b̂_i + ζ_i + (h²/2) b̂_i × δ                      (δ: a constant unmodelled ω̇)            (G3)
    e(δ) = Σ_i y_i × (b̂_i + ζ_i + (h²/2) b̂_i × δ) = α + β δ,   β = (h²/2) Σ_i (y_i×)(b̂_i×)          (G4)
    δ = argmin eᵀQe + δᵀR_δ δ = −(βᵀQβ + R_δ)⁻¹ βᵀQ α,          Q = q I, R_δ = ρ I                    (G5)
    ω_½ = ω̂ + (h/2)(ω̂̇ + δ)                                                                          (G6)
    ω̂⁺ = ω_½ + (h/2)(J⁻¹((J ω̂⁺) × ω̂⁺ + τ) + δ)               (implicit, Newton (C4))                (G7)
    r = Σ_i y_i × b̂_i,     R̂⁺ = R̂ Exp(h (ω_½ + k_R r))                                               (G8)

(G6)–(G7) are the trapezoidal rule for ``ω̇ = J⁻¹((Jω) × ω + τ) + δ``, the same the source's simulation uses for
the plant (its model error enters both halves as an angular acceleration). Newton's Jacobian for (G7):
``−I + (h/2) J⁻¹((Jω)× − ω× J)``. A missing sample gives δ = 0 and r = 0.

**Settings of the source** (its script): J = diag(60, 70, 90) kg·m², τ(t) = (sin(2πt/3), cos(2πt), sin(2πt/5)) N·m,
ω(0) = (0.3, 0.2, 0.1) rad/s, R(0) = Exp(1.7 rad about (1, 1, 1)/√3), v₁ = e₂, v₂ = e₃, direction noise 0.001 per
component, h = 0.01 s, 100 s; the filter from R̂ = I, ω̂ = 0 with q = 10⁴, ρ = 4·10⁻³, k_R = 0.7 (and a
sensitivity scale σ_δ = 1). ``benchmarks/peers.py`` reproduces it.

**Inconsistencies found in the source** (each one also in ``docs/baselines.md``):

* its Newton loop for (G7) adds ``δ`` inside ``J⁻¹(…)`` — δ taken as a torque, ``J⁻¹δ`` — where its first half-step
  (G6) adds ``J δ`` inside ``J⁻¹(…)`` — δ as an angular acceleration, as (G3) models it. With J of 60–90 kg·m² the
  second half keeps about 1/75 of δ. Default here: δ in both halves; ``as_published=True`` reproduces the source;
* the prediction (G2)–(G3) reaches ``t_{k+1}`` but is compared with the sample at ``t_k`` (the script's index k on
  both): at the truth ``α ≈ −h Σ_i (I − b_i b_iᵀ) ω ≠ 0``, so the truth is not a fixed point and the filter settles
  with its predicted directions on the latest sample, its attitude about one sample behind. Kept (it is the
  recursion's structure); ``benchmarks/peers.py`` measures what it leaves on a noise-free run;
* the sensitivity scale σ_δ multiplies δ in (G3) but not in (G6)–(G7): the two agree only at σ_δ = 1, the source's
  value, which is why it is not a parameter here;
* the script reports ``ω − ω̂`` where the minimum-energy script reports ``ω̂ − ω`` (sign only); its Newton loop
  tests the residual before its last update, so it always takes one more step than its tolerance asks (harmless).
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

__all__ = ["PredictiveFilter", "disturbance", "predicted_change", "predictive_step"]


def predicted_change(b_hat: np.ndarray, omega: np.ndarray, omega_dot: np.ndarray, h: float) -> np.ndarray:
    """(G2): ``ζ_i``, the change of each ``b̂_i`` ``(n, 3)`` over ``h`` to second order."""
    w = np.broadcast_to(omega, b_hat.shape)
    wd = np.broadcast_to(omega_dot, b_hat.shape)
    return -h * np.cross(w, b_hat) + 0.5 * h * h * (np.cross(b_hat, wd) + np.cross(w, np.cross(w, b_hat)))


def disturbance(
    y: np.ndarray, b_hat: np.ndarray, zeta: np.ndarray, h: float, q: float, rho: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(G4)–(G5): ``(δ, α, β)``."""
    alpha = np.sum(np.cross(y, b_hat + zeta), axis=0)
    beta = 0.5 * h * h * sum(so3.hat(yi) @ so3.hat(bi) for yi, bi in zip(y, b_hat, strict=True))
    delta = -np.linalg.solve(q * beta.T @ beta + rho * np.eye(3), q * beta.T @ alpha)
    return delta, alpha, beta


def predictive_step(
    R: np.ndarray, omega: np.ndarray, y: np.ndarray | None, references: np.ndarray, tau: np.ndarray, h: float,
    J: np.ndarray, J_inv: np.ndarray, q: float, rho: float, k_R: float, as_published: bool = False,
) -> tuple[np.ndarray, np.ndarray] | None:  # fmt: skip
    """(G1)–(G8) over ``h`` from the sample ``y`` ``(n, 3)`` (None: missing); ``(R̂⁺, ω̂⁺)``, None when (G7)'s Newton
    iteration fails. ``as_published``: the source's second half-step (``J⁻¹δ``)."""
    b_hat = references @ R
    omega_dot = J_inv @ (np.cross(J @ omega, omega) + tau)
    if y is None:
        delta, r = np.zeros(3), np.zeros(3)
    else:
        delta = disturbance(y, b_hat, predicted_change(b_hat, omega, omega_dot, h), h, q, rho)[0]
        r = np.sum(np.cross(y, b_hat), axis=0)
    w_half = omega + 0.5 * h * (omega_dot + delta)
    second = J_inv @ delta if as_published else delta

    def residual(w):
        return -w + w_half + 0.5 * h * (J_inv @ (np.cross(J @ w, w) + tau) + second)

    def jacobian(w):
        return -np.eye(3) + 0.5 * h * J_inv @ (so3.hat(J @ w) - so3.hat(w) @ J)

    w_next = newton(residual, jacobian, w_half)
    if w_next is None:
        return None
    return R @ exp_so3(h * (w_half + k_R * r)), w_next


class PredictiveFilter(TSO3Filter):
    """The geometric predictive filter of the module docstring behind the estimator contract.

    :meth:`update` runs :func:`predictive_step` (NumPy), :meth:`run` its compiled twin
    (:mod:`omegahat.baselines.tso3_kernel`); a step that cannot be taken restarts the filter ((C5) of
    :mod:`omegahat.baselines.tso3_common`).

    Parameters
    ----------
    J : inertia (3 numbers, 9 numbers or 3×3), kg·m²; the one positional argument.
    references : ``None`` for attitude samples (their three directions), else the inertial directions ``(n, 3)``.
    residual_weight, disturbance_weight : q and ρ of (G5) (the source: 10⁴ and 4·10⁻³; only q/ρ matters).
    attitude_gain : k_R of (G8), 1/s (the source: 0.7).
    omega_hat0, R0 : the initial rate (rad/s; default 0, and then no estimate at the first valid sample) and
        attitude (``None``: the first valid sample's least-squares attitude; the source starts from the identity).
    as_published : True: the source's second half-step (``J⁻¹δ``, module docstring).
    scalar_first, rotation_tol, quat_norm_tol, min_angle_deg : the input checks of :mod:`omegahat.measurements`.
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        references: ArrayLike | None = None,
        residual_weight: float = 1e4,
        disturbance_weight: float = 4e-3,
        attitude_gain: float = 0.7,
        omega_hat0: ArrayLike | None = None,
        R0: ArrayLike | Rotation | None = None,
        as_published: bool = False,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
    ) -> None:
        self.residual_weight = float(as_positive(residual_weight, "residual_weight")[0])
        self.disturbance_weight = float(as_positive(disturbance_weight, "disturbance_weight")[0])
        self.attitude_gain = float(as_positive(attitude_gain, "attitude_gain")[0])
        self.as_published = bool(as_published)
        super().__init__(
            J, references=references, omega_hat0=omega_hat0, R0=R0, scalar_first=scalar_first,
            rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol, min_angle_deg=min_angle_deg,
        )  # fmt: skip

    def _initial_gain(self) -> np.ndarray:
        return np.zeros((6, 6))  # no gain state: the compiled loop's K slot, unused

    def _numpy_step(self, R, omega, gain, a, tau, h):
        stepped = predictive_step(
            R, omega, a, self.directions, tau, h, self.J, self.J_inv, self.residual_weight, self.disturbance_weight,
            self.attitude_gain, self.as_published,
        )  # fmt: skip
        return None if stepped is None else (*stepped, gain)

    def _run_compiled(self, times, values, valid, taus, state, R, gain, prev):
        n = self.directions.shape[0]
        params = np.array(
            [self.residual_weight, self.disturbance_weight, self.attitude_gain, 1.0 if self.as_published else 0.0]
        )
        return kernel.run_log(
            kernel.PREDICTIVE, times, values, valid, taus, np.ascontiguousarray(self.directions), self.J, self.J_inv,
            np.ones(n), np.ones(n), params, state, R, gain, prev, self.omega_hat0, gain.copy(),
        )  # fmt: skip
