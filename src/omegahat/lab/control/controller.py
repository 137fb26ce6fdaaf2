r"""A saturated PD law on SO(3) that tracks a reference attitude, fed any angular-velocity estimate.

Frames as in :mod:`omegahat.so3`: ``R`` maps body to inertial axes, rates are in body axes. The reference is an
attitude ``R_d(t)`` with its rate ``ω_d`` and acceleration ``ω̇_d`` in the *reference's* body axes
(``Ṙ_d = R_d ω_d×``). The errors (T. Lee, M. Leok, N. H. McClamroch, "Geometric tracking control of a quadrotor
UAV on SE(3)", IEEE CDC 2010, Section III-B; F. Bullo and A. D. Lewis, *Geometric Control of Mechanical Systems*,
Springer 2005, Ch. 11; N. A. Chaturvedi, A. K. Sanyal, N. H. McClamroch, "Rigid-body attitude control", IEEE
Control Systems Magazine 31(3), 2011)::

    e_R = ½ vee(R_dᵀ R − Rᵀ R_d)                                             (C1, attitude error)
    e_ω = ω̂ − Rᵀ R_d ω_d                                                     (C2, rate error, with the estimate ω̂)
    Ψ   = ½ tr(I − R_dᵀ R) = 1 − cos θ_e,   |e_R| = sin θ_e                   (C3, θ_e the error angle)

and the law, evaluated with the *measured* attitude and the rate estimate ω̂ in place of a gyro's ω::

    u = −k_R e_R − k_ω e_ω + ω̂ × J ω̂ − J (ω̂× Rᵀ R_d ω_d − Rᵀ R_d ω̇_d)        (C4, PD + feed-forward)
    τ_i = clip(u_i, −τ_max, τ_max),  i = 1, 2, 3                             (C5, per-axis saturation)

(the feed-forward terms vanish for a constant reference with ``feedforward=False``: then (C4) is the plain PD
``u = −k_R e_R − k_ω ω̂``). Scalar gains are those the proof below is written for; :func:`pd_gains` picks them from
a natural frequency and a damping ratio for the mean principal inertia ``J̄ = tr J / 3``: ``k_R = J̄ ω_n²``,
``k_ω = 2 ζ ω_n J̄``. About a principal axis with inertia ``J_a``, near the reference and with the true rate, (C4)
reduces to ``J_a θ̈ + k_ω θ̇ + k_R sin θ = 0``, a damped oscillator to first order (the closed form the tests
check).

**What is proven and what is not.** With the true rate and no saturation, the Lyapunov function
``V = ½ e_ωᵀ J e_ω + k_R Ψ + c e_Rᵀ J e_ω`` proves exponential stability of ``R = R_d`` for every start with
``Ψ < 2`` (error angle below 180°) and rate error small enough for the bound on ``V``: *almost* global, never
global. No continuous feedback on SO(3) stabilises an attitude globally (S. P. Bhat and D. S. Bernstein, "A
topological obstruction to continuous global stabilization of rotational motion and the unwinding phenomenon",
Systems & Control Letters 39(1), 2000): (C4) has the equilibria ``R_dᵀ R = exp(π a×)`` (rotation by 180° about
a principal axis), unstable, near which the motion starts slowly. The saturation (C5) and the rate *estimate* are
outside that proof: with them the basin is only measured (:mod:`omegahat.lab.control.basin`), as is the
interconnection with the observer, which the paper leaves open.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = [
    "AttitudePD",
    "Reference",
    "SlewReference",
    "attitude_error",
    "error_angle",
    "pd_gains",
]


def attitude_error(R: ArrayLike, R_d: ArrayLike) -> np.ndarray:
    """(C1) ``e_R = ½ vee(R_dᵀ R − Rᵀ R_d)`` ``(*B, 3)`` for ``R, R_d (*B, 3, 3)``; its norm is ``sin θ_e``."""
    R = np.asarray(R, dtype=float)
    R_d = np.asarray(R_d, dtype=float)
    E = np.swapaxes(R_d, -1, -2) @ R
    return 0.5 * so3.vee(E - np.swapaxes(E, -1, -2))


def error_angle(R: ArrayLike, R_d: ArrayLike) -> np.ndarray:
    """The angle θ_e ∈ [0, π] of ``R_dᵀ R`` (rad), ``(*B,)``: ``atan2(|e_R|, (tr(R_dᵀ R) − 1)/2)`` with (C1)'s
    ``|e_R| = sin θ_e``, accurate to rounding at every angle (the arccosine of the trace alone loses half the
    digits near 0 and near π)."""
    R = np.asarray(R, dtype=float)
    R_d = np.asarray(R_d, dtype=float)
    cos = 0.5 * (np.einsum("...ij,...ij->...", R_d, R) - 1.0)  # tr(R_dᵀ R) = Σ R_d,ij R_ij
    return np.arctan2(np.linalg.norm(attitude_error(R, R_d), axis=-1), cos)


def pd_gains(J: ArrayLike, natural_frequency: float, damping: float) -> tuple[float, float]:
    """``(k_R, k_ω) = (J̄ ω_n², 2 ζ ω_n J̄)`` with ``J̄ = tr J / 3`` (module docstring)."""
    Jm = as_inertia(J)
    wn = float(as_positive(natural_frequency, "natural_frequency")[0])
    zeta = float(as_positive(damping, "damping")[0])
    jbar = float(np.trace(Jm)) / 3.0
    return jbar * wn * wn, 2.0 * zeta * wn * jbar


@dataclass(frozen=True)
class Reference:
    """A reference sample: attitude ``R_d (3, 3)``, rate ``omega_d (3,)`` and acceleration ``omega_dot_d (3,)``
    in the reference's body axes."""

    R_d: np.ndarray
    omega_d: np.ndarray
    omega_dot_d: np.ndarray

    @classmethod
    def fixed(cls, R_d: ArrayLike | None = None) -> Reference:
        """A constant attitude (default the identity), at rest."""
        R = np.eye(3) if R_d is None else so3.as_matrix(R_d)
        if not bool(so3.is_rotation(R)):
            raise ValueError("R_d must be a rotation matrix")
        return cls(R, np.zeros(3), np.zeros(3))


class SlewReference:
    r"""A rest-to-rest rotation by ``angle`` about the fixed ``axis`` (reference frame = start frame ``R0``) in
    ``duration`` s from ``start``, with the cycloidal profile (s = (t − start)/duration ∈ [0, 1])::

        θ(s) = angle (s − sin(2πs)/(2π)),   θ̇ = angle (1 − cos 2πs)/duration,   θ̈ = 2π angle sin(2πs)/duration²

    ``R_d = R0 exp(θ a)``, ``ω_d = θ̇ a``, ``ω̇_d = θ̈ a``; the peak acceleration is ``2π angle / duration²``."""

    def __init__(
        self, axis: ArrayLike, angle: float, duration: float, start: float = 0.0, R0: ArrayLike | None = None
    ) -> None:
        a = as_vector3(axis, "axis")
        norm = float(np.linalg.norm(a))
        if norm == 0.0:
            raise ValueError("the slew axis must not be zero")
        self.axis = a / norm
        self.angle = float(angle)
        self.duration = float(as_positive(duration, "duration")[0])
        self.start = float(start)
        self.R0 = np.eye(3) if R0 is None else Reference.fixed(R0).R_d

    def __call__(self, t: float) -> Reference:
        s = min(max((t - self.start) / self.duration, 0.0), 1.0)
        th = self.angle * (s - np.sin(2.0 * np.pi * s) / (2.0 * np.pi))
        moving = 0.0 < s < 1.0
        dth = self.angle * (1.0 - np.cos(2.0 * np.pi * s)) / self.duration if moving else 0.0
        ddth = 2.0 * np.pi * self.angle * np.sin(2.0 * np.pi * s) / self.duration**2 if moving else 0.0
        return Reference(self.R0 @ so3.exp(th * self.axis), dth * self.axis, ddth * self.axis)

    @property
    def peak_acceleration(self) -> float:
        """``2π |angle| / duration²`` (rad/s²)."""
        return 2.0 * np.pi * abs(self.angle) / self.duration**2


class AttitudePD:
    """The saturated PD tracking law (C4)–(C5) (module docstring).

    Parameters
    ----------
    J : inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    k_R, k_omega : the attitude and rate gains (N m, N m s), positive.
    tau_max : the per-axis torque limit (N m), positive; ``inf`` for none.
    feedforward : include the gyroscopic and reference terms of (C4) (default True).
    """

    def __init__(
        self, J: ArrayLike, *, k_R: float, k_omega: float, tau_max: float = np.inf, feedforward: bool = True
    ) -> None:
        self.J = as_inertia(J)
        self.k_R = float(as_positive(k_R, "k_R")[0])
        self.k_omega = float(as_positive(k_omega, "k_omega")[0])
        if not (isinstance(tau_max, int | float) and tau_max > 0):
            raise ValueError(f"tau_max must be a positive number (inf for no limit); got {tau_max!r}")
        self.tau_max = float(tau_max)
        self.feedforward = bool(feedforward)

    def __repr__(self) -> str:
        return f"AttitudePD(k_R={self.k_R:g}, k_omega={self.k_omega:g}, tau_max={self.tau_max:g})"

    def unsaturated(self, R: ArrayLike, omega_hat: ArrayLike, ref: Reference) -> np.ndarray:
        """(C4): the command ``u (3,)`` before the saturation, from the attitude ``R``, the rate (estimate) and
        the reference sample."""
        R = np.asarray(R, dtype=float)
        w = as_vector3(omega_hat, "omega_hat")
        Rt_Rd = R.T @ ref.R_d
        wd_body = Rt_Rd @ ref.omega_d  # the reference rate in the body axes
        u = -self.k_R * attitude_error(R, ref.R_d) - self.k_omega * (w - wd_body)
        if self.feedforward:
            u = u + so3.cross(w, self.J @ w) - self.J @ (so3.cross(w, wd_body) - Rt_Rd @ ref.omega_dot_d)
        return u

    def __call__(self, R: ArrayLike, omega_hat: ArrayLike, ref: Reference) -> np.ndarray:
        """(C5): the torque ``τ (3,)``, each component clipped to ``±tau_max``."""
        return np.clip(self.unsaturated(R, omega_hat, ref), -self.tau_max, self.tau_max)
