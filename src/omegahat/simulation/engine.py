r"""Lockstep batch kernel: many coupled runs stepped together, a row of lanes at a time.

The integrator is the one of :func:`omegahat.simulation.coupled.integrate_coupled` (ETDRK4 in error coordinates, the
embedded ETD3(4) error estimate, free steps, continuous extension of order 3 at the output times); only the
memory layout differs. Every state component is a row of ``LANES`` lanes (``y[j, w]``: component ``j`` of the run in
lane ``w``), so each line of the right-hand side becomes a loop over lanes without branches, which LLVM turns into
SIMD instructions (on this machine AVX-512: 8 doubles per instruction). Each lane carries its own run, time,
step size, output index and counters, as rows of the workspace too, so that step sizes, acceptance and
counters are decided for all lanes at once; a lane whose run has ended takes the next run of its worker's queue,
so the lanes stay full until the queue runs dry. Only what is rare or irregular stays per lane, in scalar code:
the output times (the continuous extension), sin and cos of large angles, failed runs and loading new ones. The
exponential is :func:`omegahat.kernels.expfn.exp_kernel`, plain arithmetic that vectorises. Lane loops are written with
the lanes outermost and the components inside (see ``docs/DEVELOPING.md``).

**Two outputs.** A lane writes its run's states at the output times into its own rows of the worker (``stage``,
in cache); when the run ends they are copied to the run's row of ``Y``
(:func:`integrate_coupled_lanes`), or a campaign's diagnostics are taken from them on the spot
(:func:`integrate_diagnosed_lanes`, :func:`omegahat.campaigns.diagnostics.diagnose_run`), so that a campaign never
holds more than the states of the runs in flight. Both are one compiled kernel (the choice is a run-time flag read
when a run ends).

**Same numbers as the single-run kernel.** For its run, a lane performs exactly the operations of
:func:`~omegahat.simulation.coupled.integrate_coupled`, in the same order: no fast-math (so no reassociation and no
fused multiply-adds), the small-angle sin and cos by the same polynomial
(:func:`omegahat.simulation.coupled._sin_cos_small`), the φ-functions by the same routines. A run's result is
therefore the same bits whichever lane, worker, batch or chunk it lands in (``tests/test_batch_kernel.py`` checks
equality with the single-run kernel). Two consequences of the layout: a lane whose run has ended and whose queue is
empty keeps stepping on its last state with ``h = 0`` (its results are discarded), and the initial right-hand side of a
new run is evaluated for all lanes at once and kept for the new lane only.

**Identical results everywhere.** No fused multiply-adds also means the bits do not depend on whether the CPU
has them, so a campaign split over a cluster of different machines gives the numbers of the local run (as long
as libm's ``sin`` and ``cos`` agree: the torque's phases and large angles call them; the exponential is the
project's own).

**Cost** (``benchmarks/montecarlo_throughput.py``, 10,000 runs, two threads, diagnosed as in a campaign): 0.89–1.12
s at best (2.1–2.7e7 accepted steps/s), medians 0.95–1.71 s on this drifting machine, against 4.6–5.4 s for a
``prange`` over runs of the single-run kernel. In one thread a step costs about 70 ns: the four right-hand sides
about 21 ns (≈ 230 floating-point operations each, at the rate of the floating-point pipes), the continuous
extension at output times 12 ns, stage combinations, error test and the accepted-lane select 20 ns (loads and
stores through the workspace), the φ-weights 4 ns, the run's diagnostics 3.5 ns, the torque 3 ns, the
bookkeeping 3 ns.
"""

from __future__ import annotations

import numba
import numpy as np
from numba import literally

from omegahat.campaigns.diagnostics import diagnose_run, diagnose_runs
from omegahat.kernels.expfn import exp_kernel
from omegahat.simulation.coupled import (
    _SINCOS_SMALL,
    _cross_into,
    _dense_weights,
    _larger_ratio,
    _phi1_half_closed,
    _phi1_taylor,
    _phi123,
    _phi123_closed,
    _phi123_taylor,
    _sin_cos_small,
    _step_factor,
)

__all__ = ["LANES", "integrate_coupled_lanes", "integrate_diagnosed_lanes"]

#: Lanes per worker, a compile-time constant (LLVM then knows every lane loop's trip count): 3 AVX-512 vectors per
#: row. The workspace is 230 rows of lanes (44 KB with two directions and two torque terms). Measured in one process,
#: alternating, 8 rounds (one thread, 2,048 theorem-gain runs): median 75.0 ns per step with 24 lanes, 81.9 with 32
#: (59 KB, further from the 32 KB level-1 cache), 82.5 with 16 (each lane loop then has too little work); two
#: threads, 10,000 runs: 73.7 against 80.2.
LANES = 24

# All per-lane arrays of a worker are rows of ONE workspace S (rows, LANES): every lane loop then reads and writes
# a single base pointer at row offsets, and LLVM vectorises it. With the same loops over separate arrays it
# gave up (too many run-time alias checks) and the direction loop of the right-hand side ran 4x slower.


@numba.njit(cache=True, inline="always", error_model="numpy")
def _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, ry, rlf, rtau, rdy):
    """:func:`omegahat.simulation.coupled._nonlinear` for every lane, the same operations in the same order: rows
    ``rdy..rdy+m`` of S from the state rows ``ry..``, frozen rates ``rlf..rlf+n`` and torque ``rtau..rtau+3``."""
    iw = 3 * n
    iz = iw + 3
    ie = iz + 3
    J00, J01, J02 = J[0, 0], J[0, 1], J[0, 2]
    J10, J11, J12 = J[1, 0], J[1, 1], J[1, 2]
    J20, J21, J22 = J[2, 0], J[2, 1], J[2, 2]
    K00, K01, K02 = Jinv[0, 0], Jinv[0, 1], Jinv[0, 2]
    K10, K11, K12 = Jinv[1, 0], Jinv[1, 1], Jinv[1, 2]
    K20, K21, K22 = Jinv[2, 0], Jinv[2, 1], Jinv[2, 2]
    yw = ry + iw
    yz = ry + iz
    for w in range(LANES):  # n is a compile-time constant: the direction loop below unrolls, this one vectorises
        w0, w1, w2 = S[yw, w], S[yw + 1, w], S[yw + 2, w]
        z0, z1, z2 = S[yz, w], S[yz + 1, w], S[yz + 2, w]
        wh0, wh1, wh2 = w0 + z0, w1 + z1, w2 + z2
        norm_wh = np.sqrt(wh0 * wh0 + wh1 * wh1 + wh2 * wh2)
        Jw0 = J00 * w0 + J01 * w1 + J02 * w2
        Jw1 = J10 * w0 + J11 * w1 + J12 * w2
        Jw2 = J20 * w0 + J21 * w1 + J22 * w2
        Jz0 = J00 * z0 + J01 * z1 + J02 * z2
        Jz1 = J10 * z0 + J11 * z1 + J12 * z2
        Jz2 = J20 * z0 + J21 * z1 + J22 * z2
        # plant: J ω̇ = (Jω) × ω + τ
        g0, g1, g2 = _cross_into(Jw0, Jw1, Jw2, w0, w1, w2)
        g0 += S[rtau, w]
        g1 += S[rtau + 1, w]
        g2 += S[rtau + 2, w]
        S[rdy + iw, w] = K00 * g0 + K01 * g1 + K02 * g2
        S[rdy + iw + 1, w] = K10 * g0 + K11 * g1 + K12 * g2
        S[rdy + iw + 2, w] = K20 * g0 + K21 * g1 + K22 * g2
        # error: J ż = (Jz) × ω + (Jω) × z + (Jz) × z + Σ k_i r̂_i × (r_i × z)
        s0, s1, s2 = _cross_into(Jz0, Jz1, Jz2, w0, w1, w2)
        p0, p1, p2 = _cross_into(Jw0, Jw1, Jw2, z0, z1, z2)
        q0, q1, q2 = _cross_into(Jz0, Jz1, Jz2, z0, z1, z2)
        s0 += p0 + q0
        s1 += p1 + q1
        s2 += p2 + q2
        for i in range(n):
            yr = ry + 3 * i
            ye = ry + ie + 3 * i
            dr = rdy + 3 * i
            de = rdy + ie + 3 * i
            r0, r1, r2 = S[yr, w], S[yr + 1, w], S[yr + 2, w]
            e0, e1, e2 = S[ye, w], S[ye + 1, w], S[ye + 2, w]
            # ṙ_i = r_i × ω
            a0, a1, a2 = _cross_into(r0, r1, r2, w0, w1, w2)
            S[dr, w] = a0
            S[dr + 1, w] = a1
            S[dr + 2, w] = a2
            # r_i × z, then r̂_i × (r_i × z)
            c0, c1, c2 = _cross_into(r0, r1, r2, z0, z1, z2)
            d0, d1, d2 = _cross_into(r0 + e0, r1 + e1, r2 + e2, c0, c1, c2)
            s0 += k[i] * d0
            s1 += k[i] * d1
            s2 += k[i] * d2
            # ė_i = r_i × z + e_i × ω̂ − (l_i(ω̂) − l_frozen) e_i
            f0, f1, f2 = _cross_into(e0, e1, e2, wh0, wh1, wh2)
            dl = l_off[i] + l_slope[i] * norm_wh - S[rlf + i, w]
            S[de, w] = c0 + f0 - dl * e0
            S[de + 1, w] = c1 + f1 - dl * e1
            S[de + 2, w] = c2 + f2 - dl * e2
        S[rdy + iz, w] = K00 * s0 + K01 * s1 + K02 * s2
        S[rdy + iz + 1, w] = K10 * s0 + K11 * s1 + K12 * s2
        S[rdy + iz + 2, w] = K20 * s0 + K21 * s1 + K22 * s2


@numba.njit(cache=True, inline="always", error_model="numpy")
def _frozen_rates_lanes(S, n, l_off, l_slope, ry, rout):
    """:func:`omegahat.simulation.coupled._frozen_rates` for every lane: row ``rout + i`` = l_i(ω̂) at the state rows
    ``ry..``."""
    iw = ry + 3 * n
    for w in range(LANES):
        wh0 = S[iw, w] + S[iw + 3, w]
        wh1 = S[iw + 1, w] + S[iw + 4, w]
        wh2 = S[iw + 2, w] + S[iw + 5, w]
        norm_wh = np.sqrt(wh0 * wh0 + wh1 * wh1 + wh2 * wh2)
        for i in range(n):
            S[rout + i, w] = l_off[i] + l_slope[i] * norm_wh


@numba.njit(cache=True, inline="always", error_model="numpy")
def _torque_stages_lanes(S, M, rhh, rtc, racos, rasin, rtf, rsn, rcs, rtau, rsn_end, rcs_end, rsd, rcd):
    """:func:`omegahat.simulation.coupled._torque_stages` for every lane: τ at t + h/2 and t + h into rows
    ``rtau + 3s + d`` (s = 1, 2; τ at t, s = 0, is not needed by a trial) and sin, cos of ν_j (t + h) into rows
    ``rsn_end + j``, ``rcs_end + j``; rows ``rsd + j``, ``rcd + j`` hold sin, cos of ν_j h/2."""
    large = 0
    for w in range(LANES):
        for j in range(M):
            x = 0.5 * S[rtf + j, w] * S[rhh, w]
            S[rsd + j, w], S[rcd + j, w] = _sin_cos_small(x)
            large += abs(x) > _SINCOS_SMALL
    if large > 0:  # large angles (not in a campaign with h_max ν ≤ 1/2): the library's sin and cos
        for w in range(LANES):
            for j in range(M):
                x = 0.5 * S[rtf + j, w] * S[rhh, w]
                if abs(x) > _SINCOS_SMALL:
                    S[rsd + j, w] = np.sin(x)
                    S[rcd + j, w] = np.cos(x)
    for w in range(LANES):
        for s in range(1, 3):
            for d in range(3):
                S[rtau + 3 * s + d, w] = S[rtc + d, w]
        for j in range(M):
            ac = racos + 3 * j
            asn = rasin + 3 * j
            a = S[rsn + j, w]
            b = S[rcs + j, w]
            sdw = S[rsd + j, w]
            cdw = S[rcd + j, w]
            for s in range(3):
                if s > 0:
                    for d in range(3):
                        S[rtau + 3 * s + d, w] += S[ac + d, w] * a + S[asn + d, w] * b
                if s < 2:
                    a, b = a * cdw + b * sdw, b * cdw - a * sdw
            S[rsn_end + j, w] = a
            S[rcs_end + j, w] = b


@numba.njit(cache=True, inline="always", error_model="numpy")
def _phi_coefficients_lanes(S, n, rlf, rhh, rcoef):
    """The step's φ-weights of :func:`omegahat.simulation.coupled._etdrk4_step` for every lane: rows
    ``rcoef + 6i .. rcoef + 6i + 6`` = E, E₂, Q, f₁, f₂, f₃ for direction i, on whole rows (one exponential,
    e^{x/2}, per lane: :func:`omegahat.kernels.expfn.exp_kernel`, which vectorises). A direction whose rates equal the
    previous one's in every lane (equal gains, the usual case) copies its weights."""
    for i in range(n):
        c = rcoef + 6 * i
        if i > 0:
            same = True
            for w in range(LANES):
                same = same and S[rlf + i, w] == S[rlf + i - 1, w]
            if same:
                for a in range(6):
                    for w in range(LANES):
                        S[c + a, w] = S[c - 6 + a, w]
                continue
        any_small = False
        for w in range(LANES):
            any_small = any_small or abs(S[rlf + i, w] * S[rhh, w]) < 1.0
        # simulate._etdrk4_step's weights. Two loops, so that LLVM vectorises each without the other's work (in
        # one loop it computed the Taylor series for every lane in every step and selected)
        if not any_small:
            for w in range(LANES):
                h = S[rhh, w]
                x = -S[rlf + i, w] * h
                ex2 = exp_kernel(0.5 * x)
                p1, p2, p3, ex = _phi123_closed(x, ex2 * ex2)
                _store_weights(S, c, w, h, ex, ex2, _phi1_half_closed(x, ex2), p1, p2, p3)
        else:  # the Taylor branches (|x| < 1/2, |x/2| < 1/2) too: both computed, one selected
            for w in range(LANES):
                h = S[rhh, w]
                x = -S[rlf + i, w] * h
                x2 = 0.5 * x
                small = abs(x) < 0.5
                small2 = abs(x2) < 0.5
                t1, t2, t3, tex = _phi123_taylor(x)
                u1, uex = _phi1_taylor(x2)
                ex2 = uex if small2 else exp_kernel(x2)
                q1 = u1 if small2 else _phi1_half_closed(x, ex2)
                c1, c2, c3, cex = _phi123_closed(x, ex2 * ex2)
                p1 = t1 if small else c1
                p2 = t2 if small else c2
                p3 = t3 if small else c3
                ex = tex if small else cex
                _store_weights(S, c, w, h, ex, ex2, q1, p1, p2, p3)


@numba.njit(cache=True, inline="always")
def _store_weights(S, c, w, h, ex, ex2, q1, p1, p2, p3):
    """Rows ``c .. c + 6`` of lane w: E, E₂, Q, f₁, f₂, f₃ of :func:`omegahat.simulation.coupled._etdrk4_step`."""
    S[c, w] = ex
    S[c + 1, w] = ex2
    S[c + 2, w] = 0.5 * h * q1
    S[c + 3, w] = h * (p1 - 3.0 * p2 + 4.0 * p3)
    S[c + 4, w] = h * (2.0 * p2 - 4.0 * p3)
    S[c + 5, w] = h * (4.0 * p3 - p2)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _half_stage_lanes(S, n, ry, rN, rhalf, rcoef, rout):
    """The first two stages of :func:`omegahat.simulation.coupled._etdrk4_step`: ``y + (h/2) N`` on (r, ω, z) and
    ``E₂ e + Q N_e`` on each e_i, into rows ``rout..``."""
    ie = 3 * n + 6
    for w in range(LANES):  # lanes outside, components inside: see _nonlinear_lanes
        for j in range(ie):
            S[rout + j, w] = S[ry + j, w] + S[rhalf, w] * S[rN + j, w]
        for i in range(n):
            c = rcoef + 6 * i
            for j in range(ie + 3 * i, ie + 3 * i + 3):
                S[rout + j, w] = S[c + 1, w] * S[ry + j, w] + S[c + 2, w] * S[rN + j, w]


@numba.njit(cache=True, inline="always", error_model="numpy")
def _select_rows(Si, rmask, rdst, rsrc, count):
    """Rows ``rdst .. rdst + count`` of the workspace take rows ``rsrc ..`` in the lanes whose mask (row
    ``rmask``) is all ones: a bitwise select, exact, which LLVM vectorises (``a if c else b`` on two rows of S
    became a select of addresses, lane by lane)."""
    for w in range(LANES):
        mk = Si[rmask, w]
        for j in range(count):
            Si[rdst + j, w] = (Si[rsrc + j, w] & mk) | (Si[rdst + j, w] & ~mk)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _dense_output_lane(S, n, ry, rNu, rNa, rNb, rNc, rlf, h, theta, w, Y, run, row):
    """:func:`omegahat.simulation.coupled._dense_output` for lane ``w`` (scalar: one output time of one run), into
    ``Y[run, row]``."""
    ie = 3 * n + 6
    b1, b2, b4 = _dense_weights(h, theta, 0.5 * theta * theta, 0.5 * theta * theta * theta / 3.0)
    for j in range(ie):
        Y[run, row, j] = S[ry + j, w] + b1 * S[rNu + j, w] + b2 * (S[rNa + j, w] + S[rNb + j, w]) + b4 * S[rNc + j, w]
    ex = 1.0
    for i in range(n):
        if i == 0 or S[rlf + i, w] != S[rlf + i - 1, w]:
            p1, p2, p3, ex = _phi123(-S[rlf + i, w] * h * theta)
            b1, b2, b4 = _dense_weights(h, theta * p1, theta * theta * p2, theta * theta * theta * p3)
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            Y[run, row, j] = (
                ex * S[ry + j, w] + b1 * S[rNu + j, w] + b2 * (S[rNa + j, w] + S[rNb + j, w]) + b4 * S[rNc + j, w]
            )


@numba.njit(cache=True)
def _release_lane(w, good, run, idx, S, Racc, Rrej, Rt, Rh, Rnext, stage, out):  # not inlined: rare, 3 call sites
    """Lane ``w``'s run ends (``good``: it reached the last output time): its counters (rows ``Racc``, ``Rrej``)
    go out, the rows a failed run did not reach become NaN, its states (``stage[w]``) go to ``Y`` or are
    diagnosed (``out``: the worker's outputs, :func:`_lanes_worker`), and the lane is free: it idles (its time
    −∞, its step 0, no output due; :func:`_idle_lane`) until a run is loaded into it."""
    Y, accepted, rejected, ok, diagnose, n, J, t_out, rho_floor, rho, dout = out
    i = run[w]
    accepted[i] = np.int64(S[Racc, w])
    rejected[i] = np.int64(S[Rrej, w])
    if not good:
        stage[w, idx[w] :] = np.nan
    if diagnose:
        diagnose_run(stage[w], i, n, J, t_out, rho_floor, good, rho, dout, ok)
    else:
        ok[i] = good
        Y[i] = stage[w]
    run[w] = -1
    _idle_lane(S, w, Rt, Rh, Rnext)


@numba.njit(cache=True, inline="always")
def _idle_lane(S, w, Rt, Rh, Rnext):
    """A lane without a run steps by h = 0 from t = −∞ and has no output due: its trials change nothing that
    matters, and no test in the vectorised bookkeeping singles it out."""
    S[Rt, w] = -np.inf
    S[Rh, w] = 0.0
    S[Rnext, w] = np.inf


@numba.njit(cache=True, error_model="numpy")
def _lanes_worker(
    runs,
    Y0,
    t_out,
    n,
    J,
    Jinv,
    k,
    l_off,
    l_slope,
    tc,
    ta,
    tf,
    tp,
    rtol,
    atol,
    h0,
    h_max,
    max_steps,
    Y,
    accepted,
    rejected,
    ok,
    diagnose,
    rho_floor,
    rho,
    dout,
    M,
):
    """Integrate the runs ``runs`` (indices into Y0, tc, …) in lockstep on ``LANES`` lanes. A lane writes its
    run's states into its own rows ``stage[w]`` (the worker's, in cache), and when the run ends they go to
    ``Y[run]`` (a failed run's rows from the failure on NaN), or, if ``diagnose``, only their diagnostics
    (:func:`omegahat.campaigns.diagnostics.diagnose_run`: ``rho[run]``, ``dout[:, run]``, ``ok[run]``, with
    ``rho_floor``); ``accepted[run]``, ``rejected[run]`` either way."""
    m = 6 * n + 6
    T = t_out.shape[0]
    ie = 3 * n + 6
    t_end = t_out[T - 1]
    a2 = atol * atol
    r2 = rtol * rtol
    # ---- the workspace: row offsets of each per-lane quantity -------------------------------------------------
    Ry = 0  # state y
    Ry_new = Ry + m  # trial point
    RNu = Ry_new + m  # nonlinear part at (t, y) with the rates frozen at y
    RN_new = RNu + m  # at the trial point with its own rates: the next step's RNu (FSAL)
    RNa = RN_new + m  # stages
    RNb = RNa + m
    RNc = RNb + m
    Rya = RNc + m
    Ryb = Rya + m  # also the third stage's point y_c: y_b is not needed once N_b is known
    Ryc = Ryb
    Rcoef = Ryb + m  # φ-weights, 6 per direction
    Rlf = Rcoef + 6 * n  # rates l_i frozen at y
    Rlf_new = Rlf + n
    Rtau = Rlf_new + n  # τ at t, t + h/2, t + h: row Rtau + 3 s + d
    # newly loaded runs: their first right-hand side, rates and torque go to rows a trial overwrites anyway
    RN_fresh = RNa
    Rlf_fresh = Rlf_new
    Rtau_fresh = Rtau
    Rtc = Rtau + 9  # the lane's torque: constant, a_j cos φ_j, a_j sin φ_j (row + 3 j + d), ν_j
    Racos = Rtc + 3
    Rasin = Racos + 3 * M
    Rtf = Rasin + 3 * M
    Rsn = Rtf + M  # sin ν_j t, cos ν_j t, and at t + h
    Rcs = Rsn + M
    Rsn_new = Rcs + M
    Rcs_new = Rsn_new + M
    Rsd = Rcs_new + M  # sin, cos of ν_j h/2
    Rcd = Rsd + M
    Rhh = Rcd + M  # the trial's step, h/2, h/6
    Rhalf = Rhh + 1
    Rh6 = Rhalf + 1
    Rerr = Rh6 + 1  # the trial's error ratio
    Rfactor = Rerr + 1  # the next step over this one
    Rmask = Rfactor + 1  # all bits set where the trial was accepted (read through the int64 view Si)
    # the lanes' bookkeeping, as rows too, so that the common case is decided for all lanes at once
    Rt = Rmask + 1  # the lane's time
    Rt_new = Rt + 1  # the trial's end
    Rh = Rt_new + 1  # the next trial's step, before h_max and the last step clip it
    Rlast = Rh + 1  # 1 where the trial ends on the last output time
    Racc = Rlast + 1  # accepted and rejected trials of the lane's run (exact in float64)
    Rrej = Racc + 1
    Rnext = Rrej + 1  # the lane's next output time (+∞: none)
    Rflag = Rnext + 1  # 1 where the trial needs the per-lane code: an output time reached, a non-finite error
    S = np.zeros((Rflag + 1, LANES))
    Si = S.view(np.int64)
    stage = np.empty((LANES, T, m))  # each lane's run's states, until the run ends
    out = (Y, accepted, rejected, ok, diagnose, n, J, t_out, rho_floor, rho, dout)
    for w in range(LANES):
        _idle_lane(S, w, Rt, Rh, Rnext)
        for j in range(M):
            S[Rcs + j, w] = 1.0
            S[Rcs_new + j, w] = 1.0
    all_bits = np.array([-1], dtype=np.int64).view(np.float64)[0]  # the accepted-lane mask as a float64
    # ---- per-lane run and output index -----------------------------------------------------------------------
    run = np.full(LANES, -1, dtype=np.int64)
    idx = np.zeros(LANES, dtype=np.int64)
    fresh = np.zeros(LANES, dtype=np.bool_)

    q = 0  # next run of the queue
    active = 0
    while True:
        # ---- load new runs into empty lanes (integrate_coupled's preamble) ------------------------------------
        any_fresh = False
        for w in range(LANES):
            fresh[w] = False
            if run[w] >= 0 or q >= runs.shape[0]:
                continue
            i = runs[q]
            q += 1
            for j in range(m):
                S[Ry + j, w] = Y0[i, j]
                stage[w, 0, j] = Y0[i, j]
            run[w] = i
            active += 1
            S[Rt, w] = t_out[0]
            S[Rh, w] = h0[i]
            S[Racc, w] = 0.0
            S[Rrej, w] = 0.0
            S[Rnext, w] = t_out[1]
            idx[w] = 1
            a_cos = ta[i] * np.cos(tp[i])
            a_sin = ta[i] * np.sin(tp[i])
            s0 = np.sin(tf[i] * t_out[0])
            c0 = np.cos(tf[i] * t_out[0])
            for d in range(3):
                S[Rtc + d, w] = tc[i, d]
                S[Rtau_fresh + d, w] = tc[i, d]
            for j in range(M):
                S[Rtf + j, w] = tf[i, j]
                S[Rsn + j, w] = s0[j]
                S[Rcs + j, w] = c0[j]
                for d in range(3):
                    S[Racos + 3 * j + d, w] = a_cos[j, d]
                    S[Rasin + 3 * j + d, w] = a_sin[j, d]
                    S[Rtau_fresh + d, w] += a_cos[j, d] * s0[j] + a_sin[j, d] * c0[j]
            fresh[w] = True
            any_fresh = True
        if any_fresh:
            _frozen_rates_lanes(S, n, l_off, l_slope, Ry, Rlf_fresh)
            _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, Ry, Rlf_fresh, Rtau_fresh, RN_fresh)
            for w in range(LANES):
                if fresh[w]:
                    for j in range(m):
                        S[RNu + j, w] = S[RN_fresh + j, w]
                    for i in range(n):
                        S[Rlf + i, w] = S[Rlf_fresh + i, w]
        if active == 0:
            break

        # ---- runs out of steps leave; step sizes for all lanes (an idle lane steps by 0) ------------------------
        spent = 0
        for w in range(LANES):
            spent += S[Racc, w] + S[Rrej, w] >= max_steps
        if spent > 0:
            for w in range(LANES):
                if run[w] >= 0 and S[Racc, w] + S[Rrej, w] >= max_steps:
                    _release_lane(w, False, run, idx, S, Racc, Rrej, Rt, Rh, Rnext, stage, out)
                    active -= 1
                elif run[w] < 0:  # an idle lane's counters grow without meaning: keep them from coming back here
                    S[Racc, w] = 0.0
                    S[Rrej, w] = 0.0
        for w in range(LANES):
            hw = min(S[Rh, w], h_max)
            last = S[Rt, w] + 1.01 * hw >= t_end
            hw = t_end - S[Rt, w] if last else hw
            S[Rlast, w] = 1.0 if last else 0.0
            S[Rhh, w] = hw
            S[Rhalf, w] = 0.5 * hw
            S[Rh6, w] = hw / 6.0

        # ---- one ETDRK4 trial for all lanes (simulate._etdrk4_step, then the new point's N) -------------------
        _torque_stages_lanes(S, M, Rhh, Rtc, Racos, Rasin, Rtf, Rsn, Rcs, Rtau, Rsn_new, Rcs_new, Rsd, Rcd)
        _phi_coefficients_lanes(S, n, Rlf, Rhh, Rcoef)
        _half_stage_lanes(S, n, Ry, RNu, Rhalf, Rcoef, Rya)
        _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, Rya, Rlf, Rtau + 3, RNa)
        _half_stage_lanes(S, n, Ry, RNa, Rhalf, Rcoef, Ryb)
        _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, Ryb, Rlf, Rtau + 3, RNb)
        for w in range(LANES):
            for j in range(ie):
                S[Ryc + j, w] = S[Ry + j, w] + S[Rhh, w] * S[RNb + j, w]
            for i in range(n):
                c = Rcoef + 6 * i
                for j in range(ie + 3 * i, ie + 3 * i + 3):
                    S[Ryc + j, w] = S[c + 1, w] * S[Rya + j, w] + S[c + 2, w] * (2.0 * S[RNb + j, w] - S[RNu + j, w])
        _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, Ryc, Rlf, Rtau + 6, RNc)
        for w in range(LANES):
            for j in range(ie):
                S[Ry_new + j, w] = S[Ry + j, w] + S[Rh6, w] * (
                    S[RNu + j, w] + 2.0 * S[RNa + j, w] + 2.0 * S[RNb + j, w] + S[RNc + j, w]
                )
            for i in range(n):
                c = Rcoef + 6 * i
                for j in range(ie + 3 * i, ie + 3 * i + 3):
                    S[Ry_new + j, w] = (
                        S[c, w] * S[Ry + j, w]
                        + S[c + 3, w] * S[RNu + j, w]
                        + S[c + 4, w] * (S[RNa + j, w] + S[RNb + j, w])
                        + S[c + 5, w] * S[RNc + j, w]
                    )
        _frozen_rates_lanes(S, n, l_off, l_slope, Ry_new, Rlf_new)
        _nonlinear_lanes(S, n, J, Jinv, k, l_off, l_slope, Ry_new, Rlf_new, Rtau + 6, RN_new)

        # ---- embedded error (simulate._embedded_error) -----------------------------------------------------------
        for w in range(LANES):
            worst_num = 0.0
            worst_den = 1.0
            for b in range(2 * n + 2):
                j0 = 3 * b
                if j0 >= ie:  # e_i: weight h(4φ₃ − φ₂), N(y_new) re-taken with the step's frozen rates
                    i = b - n - 2
                    wt = S[Rcoef + 6 * i + 5, w]
                    shift = S[Rlf + i, w] - S[Rlf_new + i, w]
                else:
                    wt = S[Rh6, w]
                    shift = 0.0
                d0 = wt * (S[RNc + j0, w] - S[RN_new + j0, w] - shift * S[Ry_new + j0, w])
                d1 = wt * (S[RNc + j0 + 1, w] - S[RN_new + j0 + 1, w] - shift * S[Ry_new + j0 + 1, w])
                d2 = wt * (S[RNc + j0 + 2, w] - S[RN_new + j0 + 2, w] - shift * S[Ry_new + j0 + 2, w])
                v0 = S[Ry_new + j0, w]
                v1 = S[Ry_new + j0 + 1, w]
                v2 = S[Ry_new + j0 + 2, w]
                worst_num, worst_den = _larger_ratio(
                    d0 * d0 + d1 * d1 + d2 * d2, a2 + r2 * (v0 * v0 + v1 * v1 + v2 * v2), worst_num, worst_den
                )
            S[Rerr, w] = worst_num / worst_den
        for w in range(LANES):
            S[Rerr, w] = np.sqrt(S[Rerr, w])
            S[Rfactor, w] = _step_factor(S[Rerr, w])

        # ---- acceptance and counters for all lanes; output times and failures lane by lane -------------------
        flagged = 0
        for w in range(LANES):
            e = S[Rerr, w]
            hw = S[Rhh, w]
            finite = e < np.inf  # False for inf and NaN
            accept = e <= 1.0
            t_new = t_end if S[Rlast, w] != 0.0 else S[Rt, w] + hw
            S[Rt_new, w] = t_new
            S[Rmask, w] = all_bits if accept else 0.0
            S[Racc, w] += 1.0 if accept else 0.0
            S[Rrej, w] += 0.0 if accept else 1.0
            S[Rh, w] = hw * S[Rfactor, w] if finite else 0.25 * hw
            flag = (accept and S[Rnext, w] <= t_new) or not finite
            S[Rflag, w] = 1.0 if flag else 0.0
            flagged += flag
        if flagged > 0:
            for w in range(LANES):
                i = run[w]
                if S[Rflag, w] == 0.0 or i < 0:
                    continue
                hw = S[Rhh, w]
                if not S[Rerr, w] < np.inf:  # rejected; below 1e-14 the run stops (this trial not counted)
                    if hw < 1e-14:
                        S[Rrej, w] -= 1.0
                        _release_lane(w, False, run, idx, S, Racc, Rrej, Rt, Rh, Rnext, stage, out)
                        active -= 1
                    continue
                t_new = S[Rt_new, w]
                while idx[w] < T and t_out[idx[w]] < t_new:
                    theta = (t_out[idx[w]] - S[Rt, w]) / hw
                    _dense_output_lane(S, n, Ry, RNu, RNa, RNb, RNc, Rlf, hw, theta, w, stage, w, idx[w])
                    idx[w] += 1
                if idx[w] < T and t_out[idx[w]] == t_new:
                    for j in range(m):
                        stage[w, idx[w], j] = S[Ry_new + j, w]
                    idx[w] += 1
                S[Rnext, w] = t_out[idx[w]] if idx[w] < T else np.inf

        # ---- accepted lanes move to the new point (FSAL: N_new becomes Nu) ------------------------------------
        _select_rows(Si, Rmask, Ry, Ry_new, m)
        _select_rows(Si, Rmask, RNu, RN_new, m)
        _select_rows(Si, Rmask, Rlf, Rlf_new, n)
        _select_rows(Si, Rmask, Rsn, Rsn_new, M)
        _select_rows(Si, Rmask, Rcs, Rcs_new, M)
        _select_rows(Si, Rmask, Rt, Rt_new, 1)

        # ---- finished runs leave their lanes ---------------------------------------------------------------------
        for w in range(LANES):
            if run[w] >= 0 and idx[w] >= T:
                _release_lane(w, True, run, idx, S, Racc, Rrej, Rt, Rh, Rnext, stage, out)
                active -= 1


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _integrate_lanes(
    Y0,
    t_out,
    n,
    J,
    Jinv,
    k,
    l_off,
    l_slope,
    tc,
    ta,
    tf,
    tp,
    rtol,
    atol,
    h0,
    h_max,
    max_steps,
    Y,
    accepted,
    rejected,
    ok,
    diagnose,
    rho_floor,
    rho,
    dout,
    n_workers,
    M,
):
    for wk in numba.prange(n_workers):
        _lanes_worker(
            np.arange(wk, Y0.shape[0], n_workers),
            Y0,
            t_out,
            literally(n),
            J,
            Jinv,
            k,
            l_off,
            l_slope,
            tc,
            ta,
            tf,
            tp,
            rtol,
            atol,
            h0,
            h_max,
            max_steps,
            Y,
            accepted,
            rejected,
            ok,
            diagnose,
            rho_floor,
            rho,
            dout,
            literally(M),
        )


@numba.njit(cache=True, error_model="numpy")
def _integrate_lanes_serial(
    Y0,
    t_out,
    n,
    J,
    Jinv,
    k,
    l_off,
    l_slope,
    tc,
    ta,
    tf,
    tp,
    rtol,
    atol,
    h0,
    h_max,
    max_steps,
    Y,
    accepted,
    rejected,
    ok,
    diagnose,
    rho_floor,
    rho,
    dout,
    n_workers,
    M,
):
    # the same on the calling thread (no Numba threading layer: callers that run several in threads, Dask)
    _lanes_worker(
        np.arange(Y0.shape[0]),
        Y0,
        t_out,
        literally(n),
        J,
        Jinv,
        k,
        l_off,
        l_slope,
        tc,
        ta,
        tf,
        tp,
        rtol,
        atol,
        h0,
        h_max,
        max_steps,
        Y,
        accepted,
        rejected,
        ok,
        diagnose,
        rho_floor,
        rho,
        dout,
        literally(M),
    )


_COMPILED = {}  # (parallel, n, number of torque terms) -> the compiled kernel's entry point


def _inputs(Y0, t_out, n, J, Jinv, k, l_off, l_slope, tc, ta, tf, tp, rtol, atol, h0, h_max, max_steps):
    """The kernel's inputs checked (the compiled kernel does not check bounds: every shape is checked here, by
    name) and converted to the types it is compiled for; with ``N`` runs, ``T`` output times, ``M`` torque terms."""
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    n = int(n)
    N = np.shape(Y0)[0] if np.ndim(Y0) == 2 else -1
    M = np.shape(tf)[1] if np.ndim(tf) == 2 else -1
    expected = {
        "Y0": (np.shape(Y0), (N, 6 * n + 6)),
        "J": (np.shape(J), (3, 3)),
        "Jinv": (np.shape(Jinv), (3, 3)),
        "k": (np.shape(k), (n,)),
        "l_off": (np.shape(l_off), (n,)),
        "l_slope": (np.shape(l_slope), (n,)),
        "tc": (np.shape(tc), (N, 3)),
        "ta": (np.shape(ta), (N, M, 3)),
        "tf": (np.shape(tf), (N, M)),
        "tp": (np.shape(tp), (N, M, 3)),
        "h0": (np.shape(h0), (N,)),
    }
    for name, (got, want) in expected.items():
        if N < 0 or M < 0 or got != want:
            raise ValueError(f"{name} must have shape {want} (N runs, n = {n} directions, M torque terms); got {got}")
    if np.ndim(t_out) != 1 or np.size(t_out) < 1:
        raise ValueError(f"t_out must be a non-empty 1-D array; got shape {np.shape(t_out)}")
    args = (
        f64(Y0),
        f64(t_out),
        n,
        f64(J),
        f64(Jinv),
        f64(k),
        f64(l_off),
        f64(l_slope),
        f64(tc),
        f64(ta),
        f64(tf),
        f64(tp),
        float(rtol),
        float(atol),
        f64(h0),
        float(h_max),
        int(max_steps),
    )
    return args, N, np.size(t_out), M


def _run(parallel, args):
    """Call the compiled kernel for ``args``' (n, M): Numba's dispatch of literal arguments costs about 14 ms a
    call, so after the first call (which compiles, or loads from the on-disk cache) its entry point is called
    directly."""
    kernel = _integrate_lanes if parallel else _integrate_lanes_serial
    key = (bool(parallel), args[2], args[-1])
    entry = _COMPILED.get(key)
    if entry is not None:
        entry(*args)
        return
    kernel(*args)
    for sig, cres in kernel.overloads.items():
        if sig[2] == numba.types.literal(key[1]) and sig[-1] == numba.types.literal(key[2]):
            _COMPILED[key] = cres.entry_point


def integrate_coupled_lanes(
    Y0,
    t_out,
    n,
    J,
    Jinv,
    k,
    l_off,
    l_slope,
    tc,
    ta,
    tf,
    tp,
    rtol,
    atol,
    h0,
    h_max,
    max_steps,
    n_workers,
    parallel=True,
):
    """:func:`omegahat.simulation.coupled.integrate_coupled_batch`'s contract (same arguments, same results bit for bit)
    computed in lockstep: run ``i`` goes to worker ``i mod n_workers``, each worker steps its runs ``LANES`` at a
    time (module docstring). Returns ``(Y (N, T, m), accepted (N,), rejected (N,), ok (N,))``.
    ``parallel=False``: all runs on the calling thread, without Numba's threading layer (``n_workers`` ignored).

    The number of directions ``n`` and of torque terms are compiled in as constants (one compiled kernel per
    pair, cached on disk): the workspace's row offsets are then constants and LLVM vectorises every lane loop.
    """
    head, N, T, M = _inputs(Y0, t_out, n, J, Jinv, k, l_off, l_slope, tc, ta, tf, tp, rtol, atol, h0, h_max, max_steps)
    Y = np.empty((N, T, head[0].shape[1]))
    accepted, rejected, ok = np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.int64), np.ones(N, dtype=bool)
    if T == 1:  # nothing to integrate (the kernel needs a second output time)
        Y[:, 0] = head[0]
    else:
        _run(
            parallel,
            (*head, Y, accepted, rejected, ok, False, 0.0, np.empty((0, T)), np.empty((6, 0)), int(n_workers), M),
        )
    return Y, accepted, rejected, ok


def integrate_diagnosed_lanes(
    Y0,
    t_out,
    n,
    J,
    Jinv,
    k,
    l_off,
    l_slope,
    tc,
    ta,
    tf,
    tp,
    rtol,
    atol,
    h0,
    h_max,
    max_steps,
    n_workers,
    rho_floor,
    parallel=True,
):
    """:func:`integrate_coupled_lanes` for a campaign: instead of the states, each run's diagnostics
    (:func:`omegahat.campaigns.diagnostics.diagnose_run` with ``rho_floor``, J the body's inertia), taken by the
    worker as soon as the run ends, from its states still in cache. Returns ``(rho (N, T), out (6, N), ok (N,),
    accepted (N,), rejected (N,))``, the numbers :func:`omegahat.campaigns.diagnostics.diagnose_runs` gives on
    :func:`integrate_coupled_lanes`' states, while only the states of the runs in flight are ever held (a chunk
    of 1024 runs of 401 output times would need 59 MB)."""
    head, N, T, M = _inputs(Y0, t_out, n, J, Jinv, k, l_off, l_slope, tc, ta, tf, tp, rtol, atol, h0, h_max, max_steps)
    rho, dout, ok = np.empty((N, T)), np.empty((6, N)), np.empty(N, dtype=bool)
    accepted, rejected = np.zeros(N, dtype=np.int64), np.zeros(N, dtype=np.int64)
    if T == 1:  # nothing to integrate: the initial states' diagnostics
        diagnose_runs(
            head[0][:, None, :], head[2], head[3], head[1], float(rho_floor), np.ones(N, dtype=bool), rho, dout, ok
        )
    else:
        _run(
            parallel,
            (
                *head,
                np.empty((0, T, head[0].shape[1])),
                accepted,
                rejected,
                ok,
                True,
                float(rho_floor),
                rho,
                dout,
                int(n_workers),
                M,
            ),
        )
    return rho, dout, ok, accepted, rejected
