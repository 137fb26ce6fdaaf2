r"""The coupled system's right-hand side, for every lane of the lockstep engine (:mod:`omegahat.simulation.engine`).

State of one run, ``y = [r_1..r_n (3n), ω (3), z (3), e_1..e_n (3n)]`` with ``z = ω̂ − ω`` and ``e_i = r̂_i − r_i``
(``m = 6n + 6`` components). Its rates are the plant and the observer of :mod:`omegahat.kernels`, nothing else::

    ṙ_i = r_i × ω                                                          (D2)
    ω̇   = J⁻¹((J ω) × ω + τ)                                               (D1)
    J ż  = (J z) × ω + (J ω) × z + (J z) × z  +  Σ_i k_i r̂_i × m_i,  m_i = r_i × z    (D3) + (O1)
    ė_i  = m_i + e_i × ω̂ − l_i(ω̂) e_i                                       (O2)

(equation labels of :mod:`omegahat.kernels.dynamics` and :mod:`omegahat.kernels.observer`; ``ż = ω̂̇ − ω̇`` is
(O1) minus (D1) with the gyroscopic difference written without cancellation). The integrator treats the decay
``−l_i e_i`` exactly with the rate frozen at the start of a step, so :func:`coupled_rates` returns the rest:
``ė_i + l_frozen_i e_i``.

Every function works on the engine's workspace ``S`` (rows of lanes, ``S[row, lane]``): the lane loop is
outermost and the components inside, which LLVM vectorises over lanes. ``n`` and ``M`` (torque terms) are
compile-time constants in the engine's many-lane variant.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels.dynamics import euler_rate, gyroscopic_difference
from omegahat.kernels.expfn import SINCOS_SMALL, sin_cos_small
from omegahat.kernels.observer import decay_rate, filter_rate, innovation
from omegahat.kernels.vec3 import cross, mat3, matvec, norm
from omegahat.simulation.layout import workspace_rows

__all__ = ["coupled_rates", "frozen_decay_rates", "torque_stages"]


@numba.njit(cache=True, inline="always", error_model="numpy")
def coupled_rates(S, lanes, n, model, ry, rlf, rtau, rdy):
    """Rows ``rdy .. rdy + m`` of S: the rates of the states in rows ``ry ..`` (module docstring), minus the frozen
    decay whose rates are in rows ``rlf + i``, with the torque in rows ``rtau .. rtau + 3``."""
    J, Jinv = mat3(model.J), mat3(model.Jinv)
    k, l_offset, l_slope = model.k, model.l_offset, model.l_slope
    yw = ry + 3 * n
    yz = yw + 3
    ye = yz + 3
    for w in range(lanes):  # n is a compile-time constant: the direction loop below unrolls, this one vectorises
        w0, w1, w2 = S[(yw) * lanes + w], S[(yw + 1) * lanes + w], S[(yw + 2) * lanes + w]
        z0, z1, z2 = S[(yz) * lanes + w], S[(yz + 1) * lanes + w], S[(yz + 2) * lanes + w]
        wh0, wh1, wh2 = w0 + z0, w1 + z1, w2 + z2
        speed = norm(wh0, wh1, wh2)
        # plant (D1)
        d0, d1, d2 = euler_rate(
            J, Jinv, w0, w1, w2, S[(rtau) * lanes + w], S[(rtau + 1) * lanes + w], S[(rtau + 2) * lanes + w]
        )
        S[(rdy + 3 * n) * lanes + w], S[(rdy + 3 * n + 1) * lanes + w], S[(rdy + 3 * n + 2) * lanes + w] = d0, d1, d2
        # observer: J ż = (D3) + Σ innovation (O1)
        s0, s1, s2 = gyroscopic_difference(J, w0, w1, w2, z0, z1, z2)
        for i in range(n):
            yr = ry + 3 * i
            yi = ye + 3 * i
            r0, r1, r2 = S[(yr) * lanes + w], S[(yr + 1) * lanes + w], S[(yr + 2) * lanes + w]
            e0, e1, e2 = S[(yi) * lanes + w], S[(yi + 1) * lanes + w], S[(yi + 2) * lanes + w]
            dr = rdy + 3 * i
            S[(dr) * lanes + w], S[(dr + 1) * lanes + w], S[(dr + 2) * lanes + w] = cross(
                r0, r1, r2, w0, w1, w2
            )  # (D2)
            m0, m1, m2 = cross(r0, r1, r2, z0, z1, z2)  # (O3)
            a0, a1, a2, b0, b1, b2 = innovation(k[i], r0 + e0, r1 + e1, r2 + e2, m0, m1, m2)
            s0 += a0
            s1 += a1
            s2 += a2
            dl = decay_rate(l_offset[i], l_slope[i], speed) - S[(rlf + i) * lanes + w]  # l_i(ω̂) minus the frozen rate
            de = rdy + 3 * n + 6 + 3 * i
            S[(de) * lanes + w], S[(de + 1) * lanes + w], S[(de + 2) * lanes + w] = filter_rate(
                b0, b1, b2, e0, e1, e2, wh0, wh1, wh2, dl
            )  # (O2)
        S[(rdy + 3 * n + 3) * lanes + w], S[(rdy + 3 * n + 4) * lanes + w], S[(rdy + 3 * n + 5) * lanes + w] = matvec(
            Jinv, s0, s1, s2
        )


@numba.njit(cache=True, inline="always", error_model="numpy")
def frozen_decay_rates(S, lanes, n, model, ry, rout):
    """Rows ``rout + i``: ``l_i(ω̂)`` (O4) at the states in rows ``ry ..``, the decay frozen for a step."""
    iw = ry + 3 * n
    l_offset, l_slope = model.l_offset, model.l_slope
    for w in range(lanes):
        speed = norm(
            S[(iw) * lanes + w] + S[(iw + 3) * lanes + w],
            S[(iw + 1) * lanes + w] + S[(iw + 4) * lanes + w],
            S[(iw + 2) * lanes + w] + S[(iw + 5) * lanes + w],
        )
        for i in range(n):
            S[(rout + i) * lanes + w] = decay_rate(l_offset[i], l_slope[i], speed)


@numba.njit(cache=True, inline="always", error_model="numpy")
def torque_stages(S, lanes, n, M):
    """The torque ``τ(t) = c + Σ_j a_j sin(ν_j t + φ_j)`` at t + h/2 and t + h into rows ``tau + 3s + d``
    (s = 1, 2), and sin, cos of ``ν_j (t + h)`` into rows ``sn_new + j``, ``cs_new + j``.

    Written ``(a_j cos φ_j) sin ν_j t + (a_j sin φ_j) cos ν_j t`` from the carried ``sin ν_j t``, ``cos ν_j t``
    (rows ``sn``, ``cs``); the later times by the angle-addition rotation by ``ν_j h/2``, whose sine and cosine
    (rows ``sd``, ``cd``) are polynomials for small angles (plain arithmetic, vectorised) and libm's otherwise
    (never in a campaign, whose steps keep ``ν_j h/2 ≤ 1/4``)."""
    rows = workspace_rows(n, M)
    large = 0
    for w in range(lanes):
        for j in range(M):
            x = 0.5 * S[(rows.freq + j) * lanes + w] * S[(rows.hh) * lanes + w]
            S[(rows.sd + j) * lanes + w], S[(rows.cd + j) * lanes + w] = sin_cos_small(x)
            large += abs(x) > SINCOS_SMALL
    if large > 0:
        for w in range(lanes):
            for j in range(M):
                x = 0.5 * S[(rows.freq + j) * lanes + w] * S[(rows.hh) * lanes + w]
                if abs(x) > SINCOS_SMALL:
                    S[(rows.sd + j) * lanes + w] = np.sin(x)
                    S[(rows.cd + j) * lanes + w] = np.cos(x)
    for w in range(lanes):
        for s in range(1, 3):
            for d in range(3):
                S[(rows.tau + 3 * s + d) * lanes + w] = S[(rows.tc + d) * lanes + w]
        for j in range(M):
            ac = rows.acos + 3 * j
            asn = rows.asin + 3 * j
            a = S[(rows.sn + j) * lanes + w]
            b = S[(rows.cs + j) * lanes + w]
            sdw = S[(rows.sd + j) * lanes + w]
            cdw = S[(rows.cd + j) * lanes + w]
            for s in range(3):
                if s > 0:
                    for d in range(3):
                        S[(rows.tau + 3 * s + d) * lanes + w] += (
                            S[(ac + d) * lanes + w] * a + S[(asn + d) * lanes + w] * b
                        )
                if s < 2:
                    a, b = a * cdw + b * sdw, b * cdw - a * sdw
            S[(rows.sn_new + j) * lanes + w] = a
            S[(rows.cs_new + j) * lanes + w] = b
