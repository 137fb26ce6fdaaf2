r"""The observer's own terms, written once: every compiled realisation of the observer calls these.

The observer of Sarras (sign-corrected: ``docs/theory/observer.md``) for measured directions ``r_i`` (i = 1..n) and
its filter states ``r̂_i = r_i + e_i`` is, in the coordinates ``(ω̂, e_i)`` and for directions that move as
``ṙ_i = r_i × ω_r`` (ω_r = ω for the true directions)::

    J ω̂̇ = (J ω̂) × ω̂ + τ + Σ_i k_i r̂_i × m_i                                    (O1)
    ė_i  = m_i + e_i × ω̂ − l_i(ω̂) e_i                                          (O2)
    m_i  = r_i × (ω̂ − ω_r)              the mismatch of direction i               (O3)
    l_i(ω̂) = l_offset_i + l_slope_i |ω̂|                                         (O4)

(O1)–(O2) follow from the paper's ``(ξ, r̂_i)`` equations with the output map ``ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i``
(O5): differentiating (O5) along the observer, the stiff ``l_i`` terms cancel. The first two terms of (O1) are the
body's model, Euler's equations (:mod:`omegahat.kernels.dynamics`); the rest is the observer's response to the
mismatches, :func:`innovation`, the one place where that response is written. Its users:

* the continuous simulation (:mod:`omegahat.simulation.engine`), with ``m_i = r_i × z``, ``z = ω̂ − ω``;
* the sampled estimator (:mod:`omegahat.observer.sampled`): between samples the directions are predicted along ω̂,
  so every ``m_i`` is zero and (O1) is Euler's equations alone; at a sample the mismatch accumulated over the
  interval is ``−Δ_i`` (measured minus predicted direction), and the correction applies :func:`innovation` to it.

Linearised at ``e = 0``, the response to z is ``Σ k_i r_i × (r_i × z) = −M z`` with the stiffness
``M = Σ_i k_i (|r_i|² I − r_i r_iᵀ)`` (O6, :func:`stiffness`), which the sampled correction inverts implicitly.
"""

from __future__ import annotations

import numba

from omegahat.kernels.vec3 import cross, matvec

__all__ = ["decay_rate", "filter_rate", "innovation", "output_map", "stiffness"]


@numba.njit(cache=True, error_model="numpy")
def decay_rate(l_offset, l_slope, speed):
    """``l_i(ω̂) = l_offset_i + l_slope_i |ω̂|`` (O4), with ``speed = |ω̂|``."""
    return l_offset + l_slope * speed


@numba.njit(cache=True, error_model="numpy")
def innovation(k, rh0, rh1, rh2, m0, m1, m2):
    """The observer's response to the mismatch ``m`` of one direction (O3), filter state ``r̂`` and gain k:
    its term ``k r̂ × m`` of ``J ω̂̇`` (O1) and its term ``m`` of ``ė`` (O2). Returns six floats."""
    a0, a1, a2 = cross(rh0, rh1, rh2, m0, m1, m2)
    return k * a0, k * a1, k * a2, m0, m1, m2


@numba.njit(cache=True, error_model="numpy")
def filter_rate(d0, d1, d2, e0, e1, e2, wh0, wh1, wh2, l):
    """``ė = d + e × ω̂ − l e`` (O2) given the innovation's term ``d`` and the decay rate ``l`` (a kernel that
    integrates part of the decay exactly passes the rest)."""
    f0, f1, f2 = cross(e0, e1, e2, wh0, wh1, wh2)
    return d0 + f0 - l * e0, d1 + f1 - l * e1, d2 + f2 - l * e2


@numba.njit(cache=True, inline="always", error_model="numpy")
def stiffness(k, r0, r1, r2):
    """One direction's share of ``M = Σ k_i (|r_i|² I − r_i r_iᵀ)`` (O6), as the six entries
    ``(M00, M11, M22, M01, M02, M12)`` of the symmetric matrix."""
    q = r0 * r0 + r1 * r1 + r2 * r2
    return (
        k * (q - r0 * r0),
        k * (q - r1 * r1),
        k * (q - r2 * r2),
        -(k * r0 * r1),
        -(k * r0 * r2),
        -(k * r1 * r2),
    )


@numba.njit(cache=True)
def output_map(Jinv, k, r, r_hat):
    """``β = J⁻¹ Σ k_i r_i × r̂_i`` (O5; ``ω̂ = ξ + β``) for directions ``r``, ``r_hat`` ``(n, 3)``."""
    s0 = s1 = s2 = 0.0
    for i in range(r.shape[0]):
        c0, c1, c2 = cross(r[i, 0], r[i, 1], r[i, 2], r_hat[i, 0], r_hat[i, 1], r_hat[i, 2])
        s0 += k[i] * c0
        s1 += k[i] * c1
        s2 += k[i] * c2
    return matvec(Jinv, s0, s1, s2)
