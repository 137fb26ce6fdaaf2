r"""One step of the exponential Runge–Kutta method ETDRK4 with its embedded error estimate, for every lane.

The method (Cox & Matthews, J. Comput. Phys. 176, 2002) integrates ``ẏ = L y + N(y)`` with the linear part
``L = −l_i`` (the decay of each ``e_i``, frozen at the start of the step; 0 on the other components) exactly. With
``x = −l_i h`` and the φ-functions of :mod:`omegahat.kernels.expfn`::

    a   = e^{x/2} y + (h/2) φ₁(x/2) N(y)                      (E2 = e^{x/2}, Q = (h/2) φ₁(x/2))
    b   = e^{x/2} y + (h/2) φ₁(x/2) N(a)
    c   = e^{x/2} a + (h/2) φ₁(x/2) (2 N(b) − N(y))
    y⁺  = eˣ y + f₁ N(y) + f₂ (N(a) + N(b)) + f₃ N(c)          (E4)
          f₁ = h(φ₁ − 3φ₂ + 4φ₃),  f₂ = h(2φ₂ − 4φ₃),  f₃ = h(4φ₃ − φ₂)

On the components without decay (x = 0) it is the classical RK4. **Error estimate** (the ETD34 construction of
Whalen, Brio & Moloney, J. Comput. Phys. 280, 2015): N at the new point, which the next step needs anyway (first
same as last), replaces N(c) in (E4), giving a third-order solution; their difference ``δ = f₃ (N(c) − N(y⁺))``
(``h/6`` on the decay-free blocks) is tested block by block ``(r_i, ω, z, e_i)`` against
``√(atol² + rtol² |y⁺_b|²)``; the next step is ``0.9 ratio^(−1/4)`` times this one, clipped to [0.2, 4]. N(y⁺) is
re-taken with the step's frozen rate: ``N(y; l) = f(y) + l e``. **Continuous extension** at ``t + θh``: (E4)
with the weights of order 3 at θ (``A = θφ₁(θx)``, ``B = θ²φ₂(θx)``, ``C = θ³φ₃(θx)``, ``b₁ = h(A − 3B + 4C)``,
``b₂ = b₃ = h(2B − 4C)``, ``b₄ = h(4C − B)``, and ``e^{θx}`` on the state), exact on the decay.

Every function works on the engine's workspace (one flat array: the quantity in row ``r`` of lane ``w`` is
``S[r * lanes + w]``, row offsets from :func:`omegahat.simulation.layout.workspace_rows`), lanes outermost and the
components inside.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels.expfn import (
    PHI_TAYLOR_BELOW,
    exp_kernel,
    phi1_half_closed,
    phi1_taylor,
    phi123,
    phi123_closed,
    phi123_taylor,
)
from omegahat.simulation.layout import workspace_rows

__all__ = [
    "combine",
    "dense_output",
    "error_ratios",
    "half_stage",
    "larger_ratio",
    "last_stage",
    "phi_weights",
    "step_factor",
]


@numba.njit(cache=True, inline="always", error_model="numpy")
def step_factor(err):
    """Next step over this one from the error ratio: ``0.9 err^(−1/4)`` (the embedded estimate is of order 3),
    clipped to [0.2, 4]; written with two square roots (vectorisable, and cheaper than ``pow``)."""
    factor = 0.9 / np.sqrt(np.sqrt(err)) if err > 0 else 4.0
    return min(4.0, max(0.2, factor))


@numba.njit(cache=True, inline="always", error_model="numpy")
def larger_ratio(num, den, worst_num, worst_den):
    """The larger of ``num/den`` and ``worst_num/worst_den`` (denominators > 0) as a (numerator, denominator)
    pair, compared by cross-multiplication so that the error test divides once. A NaN numerator (non-finite
    state) is kept: the step is then rejected."""
    if num * worst_den > worst_num * den or num != num:
        return num, den
    return worst_num, worst_den


@numba.njit(cache=True, inline="always", error_model="numpy")
def _store_weights(S, lanes, c, w, h, ex, ex2, q1, p1, p2, p3):
    """Rows ``c .. c + 6`` of lane w: E, E₂, Q, f₁, f₂, f₃."""
    S[(c) * lanes + w] = ex
    S[(c + 1) * lanes + w] = ex2
    S[(c + 2) * lanes + w] = 0.5 * h * q1
    S[(c + 3) * lanes + w] = h * (p1 - 3.0 * p2 + 4.0 * p3)
    S[(c + 4) * lanes + w] = h * (2.0 * p2 - 4.0 * p3)
    S[(c + 5) * lanes + w] = h * (4.0 * p3 - p2)


@numba.njit(cache=True, inline="always", error_model="numpy")
def phi_weights(S, lanes, n, M):
    """The step's weights E, E₂, Q, f₁, f₂, f₃ for direction i into rows ``rows.coef + 6i ..`` (one exponential,
    e^{x/2}, per lane, and ``eˣ = (e^{x/2})²``). A direction whose rates equal the previous one's in every lane
    (equal gains, the usual case) copies its weights."""
    rows = workspace_rows(n, M)
    for i in range(n):
        c = rows.coef + 6 * i
        if i > 0:
            same = True
            for w in range(lanes):
                same = same and S[(rows.lf + i) * lanes + w] == S[(rows.lf + i - 1) * lanes + w]
            if same:
                for a in range(6):
                    for w in range(lanes):
                        S[(c + a) * lanes + w] = S[(c - 6 + a) * lanes + w]
                continue
        any_small = False
        for w in range(lanes):
            any_small = (
                any_small or abs(S[(rows.lf + i) * lanes + w] * S[(rows.hh) * lanes + w]) < 2.0 * PHI_TAYLOR_BELOW
            )
        # Two loops, so that LLVM vectorises each without the other's work (in one loop it computed the Taylor
        # series for every lane in every step and selected)
        if not any_small:
            for w in range(lanes):
                h = S[(rows.hh) * lanes + w]
                x = -S[(rows.lf + i) * lanes + w] * h
                ex2 = exp_kernel(0.5 * x)
                p1, p2, p3, ex = phi123_closed(x, ex2 * ex2)
                _store_weights(S, lanes, c, w, h, ex, ex2, phi1_half_closed(x, ex2), p1, p2, p3)
        else:  # the Taylor branches (|x| < 1/2, |x/2| < 1/2) too: both computed, one selected
            for w in range(lanes):
                h = S[(rows.hh) * lanes + w]
                x = -S[(rows.lf + i) * lanes + w] * h
                x2 = 0.5 * x
                small = abs(x) < PHI_TAYLOR_BELOW
                small2 = abs(x2) < PHI_TAYLOR_BELOW
                t1, t2, t3, tex = phi123_taylor(x)
                u1, uex = phi1_taylor(x2)
                ex2 = uex if small2 else exp_kernel(x2)
                q1 = u1 if small2 else phi1_half_closed(x, ex2)
                c1, c2, c3, cex = phi123_closed(x, ex2 * ex2)
                p1 = t1 if small else c1
                p2 = t2 if small else c2
                p3 = t3 if small else c3
                ex = tex if small else cex
                _store_weights(S, lanes, c, w, h, ex, ex2, q1, p1, p2, p3)


@numba.njit(cache=True, inline="always", error_model="numpy")
def half_stage(S, lanes, n, M, rN, rout):
    """Stages a and b: ``y + (h/2) N`` on (r, ω, z) and ``E₂ e + Q N_e`` on each e_i, N from rows ``rN``, into
    rows ``rout``."""
    rows = workspace_rows(n, M)
    ie = 3 * n + 6
    for w in range(lanes):
        for j in range(ie):
            S[(rout + j) * lanes + w] = (
                S[(rows.y + j) * lanes + w] + S[(rows.half) * lanes + w] * S[(rN + j) * lanes + w]
            )
        for i in range(n):
            c = rows.coef + 6 * i
            for j in range(ie + 3 * i, ie + 3 * i + 3):
                S[(rout + j) * lanes + w] = (
                    S[(c + 1) * lanes + w] * S[(rows.y + j) * lanes + w]
                    + S[(c + 2) * lanes + w] * S[(rN + j) * lanes + w]
                )


@numba.njit(cache=True, inline="always", error_model="numpy")
def last_stage(S, lanes, n, M):
    """Stage c: ``y + h N(b)`` on (r, ω, z) and ``E₂ a + Q (2 N(b) − N(y))`` on each e_i."""
    rows = workspace_rows(n, M)
    ie = 3 * n + 6
    for w in range(lanes):
        for j in range(ie):
            S[(rows.yc + j) * lanes + w] = (
                S[(rows.y + j) * lanes + w] + S[(rows.hh) * lanes + w] * S[(rows.Nb + j) * lanes + w]
            )
        for i in range(n):
            c = rows.coef + 6 * i
            for j in range(ie + 3 * i, ie + 3 * i + 3):
                S[(rows.yc + j) * lanes + w] = S[(c + 1) * lanes + w] * S[(rows.ya + j) * lanes + w] + S[
                    (c + 2) * lanes + w
                ] * (2.0 * S[(rows.Nb + j) * lanes + w] - S[(rows.Nu + j) * lanes + w])


@numba.njit(cache=True, inline="always", error_model="numpy")
def combine(S, lanes, n, M):
    """The new point (E4): RK4's combination on (r, ω, z), the φ-weights' on each e_i."""
    rows = workspace_rows(n, M)
    ie = 3 * n + 6
    for w in range(lanes):
        for j in range(ie):
            S[(rows.y_new + j) * lanes + w] = S[(rows.y + j) * lanes + w] + S[(rows.h6) * lanes + w] * (
                S[(rows.Nu + j) * lanes + w]
                + 2.0 * S[(rows.Na + j) * lanes + w]
                + 2.0 * S[(rows.Nb + j) * lanes + w]
                + S[(rows.Nc + j) * lanes + w]
            )
        for i in range(n):
            c = rows.coef + 6 * i
            for j in range(ie + 3 * i, ie + 3 * i + 3):
                S[(rows.y_new + j) * lanes + w] = (
                    S[(c) * lanes + w] * S[(rows.y + j) * lanes + w]
                    + S[(c + 3) * lanes + w] * S[(rows.Nu + j) * lanes + w]
                    + S[(c + 4) * lanes + w] * (S[(rows.Na + j) * lanes + w] + S[(rows.Nb + j) * lanes + w])
                    + S[(c + 5) * lanes + w] * S[(rows.Nc + j) * lanes + w]
                )


@numba.njit(cache=True, inline="always", error_model="numpy")
def error_ratios(S, lanes, n, M, rtol, atol):
    """Row ``rows.err``: the largest block ratio ``|δ_b| / √(atol² + rtol² |y⁺_b|²)`` of the embedded estimate;
    row ``rows.factor``: the next step over this one. The squared ratios are compared as fractions
    (:func:`larger_ratio`), one division and one square root taken at the end."""
    rows = workspace_rows(n, M)
    ie = 3 * n + 6
    a2 = atol * atol
    r2 = rtol * rtol
    for w in range(lanes):
        worst_num = 0.0
        worst_den = 1.0
        for b in range(2 * n + 2):
            j0 = 3 * b
            if j0 >= ie:  # e_i: weight h(4φ₃ − φ₂), N(y⁺) re-taken with the step's frozen rates
                i = b - n - 2
                wt = S[(rows.coef + 6 * i + 5) * lanes + w]
                shift = S[(rows.lf + i) * lanes + w] - S[(rows.lf_new + i) * lanes + w]
            else:
                wt = S[(rows.h6) * lanes + w]
                shift = 0.0
            d0 = wt * (
                S[(rows.Nc + j0) * lanes + w]
                - S[(rows.N_new + j0) * lanes + w]
                - shift * S[(rows.y_new + j0) * lanes + w]
            )
            d1 = wt * (
                S[(rows.Nc + j0 + 1) * lanes + w]
                - S[(rows.N_new + j0 + 1) * lanes + w]
                - shift * S[(rows.y_new + j0 + 1) * lanes + w]
            )
            d2 = wt * (
                S[(rows.Nc + j0 + 2) * lanes + w]
                - S[(rows.N_new + j0 + 2) * lanes + w]
                - shift * S[(rows.y_new + j0 + 2) * lanes + w]
            )
            v0 = S[(rows.y_new + j0) * lanes + w]
            v1 = S[(rows.y_new + j0 + 1) * lanes + w]
            v2 = S[(rows.y_new + j0 + 2) * lanes + w]
            worst_num, worst_den = larger_ratio(
                d0 * d0 + d1 * d1 + d2 * d2, a2 + r2 * (v0 * v0 + v1 * v1 + v2 * v2), worst_num, worst_den
            )
        S[(rows.err) * lanes + w] = worst_num / worst_den
    for w in range(lanes):
        S[(rows.err) * lanes + w] = np.sqrt(S[(rows.err) * lanes + w])
        S[(rows.factor) * lanes + w] = step_factor(S[(rows.err) * lanes + w])


@numba.njit(cache=True, inline="always", error_model="numpy")
def _dense_weights(h, A, B, C):
    """``b₁ = h(A − 3B + 4C)``, ``b₂ = b₃ = h(2B − 4C)``, ``b₄ = h(4C − B)``."""
    return h * (A - 3.0 * B + 4.0 * C), h * (2.0 * B - 4.0 * C), h * (4.0 * C - B)


@numba.njit(cache=True, inline="always", error_model="numpy")
def dense_output(S, lanes, n, M, h, theta, w, out):
    """The continuous extension of lane w's step at ``t + θh`` into ``out (m,)`` (scalar code: output times are
    rare beside steps). At θ = 1 its weights are the step's own."""
    rows = workspace_rows(n, M)
    ie = 3 * n + 6
    b1, b2, b4 = _dense_weights(h, theta, 0.5 * theta * theta, 0.5 * theta * theta * theta / 3.0)
    for j in range(ie):
        out[j] = (
            S[(rows.y + j) * lanes + w]
            + b1 * S[(rows.Nu + j) * lanes + w]
            + b2 * (S[(rows.Na + j) * lanes + w] + S[(rows.Nb + j) * lanes + w])
            + b4 * S[(rows.Nc + j) * lanes + w]
        )
    ex = 1.0
    for i in range(n):
        if (
            i == 0 or S[(rows.lf + i) * lanes + w] != S[(rows.lf + i - 1) * lanes + w]
        ):  # equal rates (the usual case): same weights
            p1, p2, p3, ex = phi123(-S[(rows.lf + i) * lanes + w] * h * theta)
            b1, b2, b4 = _dense_weights(h, theta * p1, theta * theta * p2, theta * theta * theta * p3)
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            out[j] = (
                ex * S[(rows.y + j) * lanes + w]
                + b1 * S[(rows.Nu + j) * lanes + w]
                + b2 * (S[(rows.Na + j) * lanes + w] + S[(rows.Nb + j) * lanes + w])
                + b4 * S[(rows.Nc + j) * lanes + w]
            )
