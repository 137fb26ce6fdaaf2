r"""The rigid body's equations for the compiled kernels: Euler's equations, their error form, and the CF4 step.

With ``R`` body → inertial, ω in body axes, J the inertia and τ the body torque::

    J ω̇ = (J ω) × ω + τ                                                       (D1, Euler's equations)
    Ṙ   = R ω×,   ṙ_i = r_i × ω for r_i = Rᵀ v_i                               (D2, kinematics)

The observer copies (D1) as its model. Integrated in error coordinates ``z = ω̂ − ω``, the model's share of
``J ż`` is the difference of the gyroscopic terms at ω̂ and ω, expanded so that nothing of size |ω|² cancels::

    (J ω̂) × ω̂ − (J ω) × ω = (J z) × ω + (J ω) × z + (J z) × z                 (D3)

(every term is proportional to z, so ``|ω̂ − ω|`` is resolved to its own relative precision, not |ω|'s).

The ground-truth integrator (:mod:`omegahat.simulation.rigid_body`) and the MEKF's nominal state use the
fourth-order commutator-free Lie group method CF4 of Celledoni, Marthinsen & Owren (FGCS 19(3), 2003), built on
the classical RK4 tableau, stage velocities ``ω_s`` and step h::

    ω₂ = ω₁ + (h/2) ω̇₁,  ω₃ = ω₁ + (h/2) ω̇₂,  ω₄ = ω₁ + h ω̇₃                   (D4)
    R⁺ = R exp(h(ω₁/4 + ω₂/6 + ω₃/6 − ω₄/12)) exp(h(−ω₁/12 + ω₂/6 + ω₃/6 + ω₄/4)),
    ω⁺ = ω₁ + h (ω̇₁ + 2ω̇₂ + 2ω̇₃ + ω̇₄)/6

Matrices are 9-tuples (:func:`omegahat.kernels.vec3.mat3`); quaternions scalar last.
"""

from __future__ import annotations

import numba

from omegahat.kernels.rotation import quat_from_rotvec, quat_multiply
from omegahat.kernels.vec3 import cross, matvec

__all__ = ["cf4_increment", "euler_rate", "gyroscopic_difference"]


@numba.njit(cache=True, inline="always", error_model="numpy")
def euler_rate(J, Jinv, w0, w1, w2, t0, t1, t2):
    """``ω̇ = J⁻¹((J ω) × ω + τ)``: (D1)."""
    a0, a1, a2 = matvec(J, w0, w1, w2)
    g0, g1, g2 = cross(a0, a1, a2, w0, w1, w2)
    return matvec(Jinv, g0 + t0, g1 + t1, g2 + t2)


@numba.njit(cache=True, inline="always", error_model="numpy")
def gyroscopic_difference(J, w0, w1, w2, z0, z1, z2):
    """``(J z) × ω + (J ω) × z + (J z) × z``: (D3), the model's share of ``J ż`` without cancellation."""
    Jw0, Jw1, Jw2 = matvec(J, w0, w1, w2)
    Jz0, Jz1, Jz2 = matvec(J, z0, z1, z2)
    s0, s1, s2 = cross(Jz0, Jz1, Jz2, w0, w1, w2)
    p0, p1, p2 = cross(Jw0, Jw1, Jw2, z0, z1, z2)
    q0, q1, q2 = cross(Jz0, Jz1, Jz2, z0, z1, z2)
    return s0 + (p0 + q0), s1 + (p1 + q1), s2 + (p2 + q2)


@numba.njit(cache=True, error_model="numpy")
def cf4_increment(J, Jinv, w0, w1, w2, h, tau0, tau_mid, tau1):
    """One CF4 step (D4) of size ``h`` from ω with the torque at t, t + h/2 and t + h (3-sequences).

    Returns ``(p, ω⁺)``: ``p`` the unit quaternion (scalar last) of the attitude increment, so that
    ``R⁺ = R R(p)`` (``q⁺ = q ⊗ p``), and ω⁺ (three floats each).
    """
    a0, a1, a2 = euler_rate(J, Jinv, w0, w1, w2, tau0[0], tau0[1], tau0[2])
    u0, u1, u2 = w0 + 0.5 * h * a0, w1 + 0.5 * h * a1, w2 + 0.5 * h * a2  # ω₂
    b0, b1, b2 = euler_rate(J, Jinv, u0, u1, u2, tau_mid[0], tau_mid[1], tau_mid[2])
    v0, v1, v2 = w0 + 0.5 * h * b0, w1 + 0.5 * h * b1, w2 + 0.5 * h * b2  # ω₃
    c0, c1, c2 = euler_rate(J, Jinv, v0, v1, v2, tau_mid[0], tau_mid[1], tau_mid[2])
    x0, x1, x2 = w0 + h * c0, w1 + h * c1, w2 + h * c2  # ω₄
    d0, d1, d2 = euler_rate(J, Jinv, x0, x1, x2, tau1[0], tau1[1], tau1[2])
    f0 = h * (w0 / 4.0 + u0 / 6.0 + v0 / 6.0 - x0 / 12.0)
    f1 = h * (w1 / 4.0 + u1 / 6.0 + v1 / 6.0 - x1 / 12.0)
    f2 = h * (w2 / 4.0 + u2 / 6.0 + v2 / 6.0 - x2 / 12.0)
    s0 = h * (-w0 / 12.0 + u0 / 6.0 + v0 / 6.0 + x0 / 4.0)
    s1 = h * (-w1 / 12.0 + u1 / 6.0 + v1 / 6.0 + x1 / 4.0)
    s2 = h * (-w2 / 12.0 + u2 / 6.0 + v2 / 6.0 + x2 / 4.0)
    px, py, pz, pw = quat_from_rotvec(f0, f1, f2)
    qx, qy, qz, qw = quat_from_rotvec(s0, s1, s2)
    p = quat_multiply(px, py, pz, pw, qx, qy, qz, qw)
    return p, (
        w0 + h * (a0 + 2.0 * b0 + 2.0 * c0 + d0) / 6.0,
        w1 + h * (a1 + 2.0 * b1 + 2.0 * c1 + d1) / 6.0,
        w2 + h * (a2 + 2.0 * b2 + 2.0 * c2 + d2) / 6.0,
    )
