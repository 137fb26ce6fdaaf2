r"""The error envelope of one coupled run, from its states on the output grid (a campaign's per-run diagnostics).

For the states ``(T, 6n + 6)`` of one run (layout ``[r (3n), ω, z, e (3n)]``) on the grid ``t_k``::

    E(t) = |z| + Σ_i |e_i|,   ρ = E/E(0),   V = |J z| + ½ Σ_i |e_i|²    (the proof's Lyapunov function)

the largest |ω|, the last output time ``t_f`` with ``ρ ≥ rho_floor``, the run's rate ``λ_run = −ln ρ(t_f)/t_f``,
its constant ``c_run = max_{t_k ≤ t_f} ρ e^{λ_run t_k}`` and the largest relative increase of V between
consecutive output times up to ``t_f`` (:mod:`omegahat.lab.campaigns` says what they test). :func:`diagnose_run` is
compiled so that the engine can take them as a run ends, from its states still in cache
(:func:`omegahat.simulation.engine.integrate_envelopes`). It performs the floating-point operations of the NumPy
reference :func:`omegahat.lab.campaigns.diagnostics.diagnose_reference` in its order (norms as ((x0² + x1²) + x2²),
sums over i from the first term, J z row by row as ((z0 J_i0 + z1 J_i1) + z2 J_i2)); only exp, log and BLAS's
J z (a non-diagonal J) may differ from NumPy's in the last bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["diagnose_run"]


@numba.njit(cache=True, error_model="numpy")
def diagnose_run(Yj, j, n, J, t, rho_floor, integrated, rho, out, ok, V):
    """Diagnostics of one run from its states ``Yj (T, 6n + 6)`` on the grid ``t``; ``integrated``: the kernel
    integrated it without failure. Writes ``rho[j]``, ``ok[j]`` and ``out[:, j]`` = (E0, omega_peak, lam, c_run,
    t_f, v_increase). ``V (T,)`` is scratch space (for V along the run)."""
    T = Yj.shape[0]
    finite = True
    peak = np.nan  # nanmax: the largest non-NaN |ω|, NaN if there is none
    E0 = np.nan
    for k in range(T):
        o = 3 * n
        z0, z1, z2 = Yj[k, o + 3], Yj[k, o + 4], Yj[k, o + 5]
        e_sum = 0.0
        e_sq = 0.0
        for i in range(n):
            a, b, c = Yj[k, o + 6 + 3 * i], Yj[k, o + 7 + 3 * i], Yj[k, o + 8 + 3 * i]
            e_norm = math.sqrt(a * a + b * b + c * c)
            e_sum += e_norm
            e_sq += e_norm * e_norm
        E = math.sqrt(z0 * z0 + z1 * z1 + z2 * z2) + e_sum
        if k == 0:
            E0 = E
        rho[j, k] = E / E0
        finite = finite and math.isfinite(rho[j, k])
        q0 = z0 * J[0, 0] + z1 * J[0, 1] + z2 * J[0, 2]
        q1 = z0 * J[1, 0] + z1 * J[1, 1] + z2 * J[1, 2]
        q2 = z0 * J[2, 0] + z1 * J[2, 1] + z2 * J[2, 2]
        V[k] = math.sqrt(q0 * q0 + q1 * q1 + q2 * q2) + 0.5 * e_sq
        w0, w1, w2 = Yj[k, o], Yj[k, o + 1], Yj[k, o + 2]
        w = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        if not math.isnan(w) and (math.isnan(peak) or w > peak):
            peak = w
    good = integrated and finite
    ok[j] = good
    out[0, j] = E0
    out[1, j] = peak if good else np.nan
    # envelope_fit on ρ (1 everywhere for a failed run): t_f the last output time with ρ ≥ floor (the last one
    # if none is), λ_run = −ln ρ(t_f) / t_f if t_f > 0, c_run = max_{k ≤ i_f} ρ e^{λ_run t_k} (NaN propagates)
    i_f = T - 1
    if good:
        while i_f > 0 and not rho[j, i_f] >= rho_floor:
            i_f -= 1
        if i_f == 0 and not rho[j, 0] >= rho_floor:
            i_f = T - 1
    out[4, j] = t[i_f]
    lam = np.nan
    c_run = np.nan
    v_increase = -np.inf
    if good:
        if t[i_f] > 0:
            lam = -math.log(rho[j, i_f]) / t[i_f]
        if math.isfinite(lam):
            c_run = rho[j, 0] * math.exp(lam * t[0])
            for k in range(1, i_f + 1):
                x = rho[j, k] * math.exp(lam * t[k])
                if not math.isnan(c_run) and (math.isnan(x) or x > c_run):
                    c_run = x
        # the largest relative increase of V between consecutive output times up to t_f (NaN propagates)
        for k in range(1, i_f + 1):
            x = (V[k] - V[k - 1]) / V[k - 1]
            if not math.isnan(v_increase) and (math.isnan(x) or x > v_increase):
                v_increase = x
    out[2, j] = lam
    out[3, j] = c_run
    out[5, j] = v_increase
