r"""The lockstep engine: the one integrator of plant + observer, for one run or for many runs at once.

Every simulation of the coupled system goes through this engine: :func:`omegahat.simulation.coupled.simulate`
(one run, one lane), :func:`omegahat.simulation.coupled.simulate_batch` and the Monte-Carlo campaigns
(:mod:`omegahat.lab.campaigns`, many runs, :data:`LANES` lanes per thread). The integrator is ETDRK4 with its embedded
error estimate, free steps and a continuous extension at the output times (:mod:`omegahat.simulation.etd`); the
right-hand side is :mod:`omegahat.simulation.rates`, built from :mod:`omegahat.kernels`.

**Layout.** Every per-lane quantity is a row of lanes of one flat workspace: row ``r`` of lane ``w`` is
``S[r * lanes + w]``, the rows named by :func:`omegahat.simulation.layout.workspace_rows` from the number of
directions n and of torque terms M. With the number of lanes, n and M compile-time constants every offset is a
constant, each line of the right-hand side is a loop over lanes without branches, and LLVM turns it into SIMD
instructions (AVX-512 here: 8 doubles at once). Each lane carries its own run, time, step, output index and
counters as rows too, so that step sizes, acceptance and counters are decided for all lanes at once; only what is
rare stays per lane in scalar code: output times (the continuous extension), failures, loading a new run into a
lane whose run has ended (a lane without a run steps on with h = 0 and its results are discarded).

**A step, phase by phase** (:func:`_lockstep`, each phase a screen of its own): load runs into empty lanes;
choose each lane's step; one ETDRK4 trial for all lanes (torque at the stage times, φ-weights, three stages, the
new point's rates); the error ratios; acceptance and counters; output times and failures lane by lane; accepted
lanes move to the new point (bitwise selects); runs that ended leave their lanes.

**Same numbers in every lane.** A lane performs, for its run, the same operations in the same order whatever the
number of lanes, the lane, the worker, the batch or the chunk: no fast-math (no reassociation, no fused
multiply-adds: the bits do not depend on whether the CPU has them), the exponential and the small-angle sine and
cosine in plain arithmetic (:mod:`omegahat.kernels.expfn`). One run simulated alone (one lane) and in a campaign
(24 lanes) gives the very same bits (``tests/test_engine.py``), on any machine as long as libm's ``sin`` and
``cos`` agree (the torque's phases and large angles call them).

**What is kept of a run** is the caller's choice of mode: every state at the output times
(:func:`integrate_states`), or, for a campaign, each run's envelope diagnostics taken as the run ends from its
states still in the worker's own rows (:func:`integrate_envelopes`, :mod:`omegahat.simulation.envelope`), so that
a campaign never holds more than the runs in flight. The many-lane entries are compiled once per (lanes, n, M)
and cached on disk; the one-lane entry once per n.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numba import literally
from numpy.typing import ArrayLike

from omegahat.simulation.envelope import diagnose_run
from omegahat.simulation.etd import combine, dense_output, error_ratios, half_stage, last_stage, phi_weights
from omegahat.simulation.layout import (
    ENVELOPES,
    STATES,
    Model,
    RunOutputs,
    RunSet,
    StepControl,
    check_inputs,
    workspace_rows,
)
from omegahat.simulation.rates import coupled_rates, frozen_decay_rates, torque_stages

__all__ = [
    "LANES",
    "Model",
    "RunOutputs",
    "RunSet",
    "StepControl",
    "check_inputs",
    "integrate_envelopes",
    "integrate_states",
]

#: Lanes per worker of the many-lane entries, a compile-time constant: 3 AVX-512 vectors per row. 24 lanes beat 32
#: (whose workspace no longer fits the 32 KB level-1 cache) and 16 (too little work per lane loop).
LANES = 24


# ------------------------------------------------------------------------------------------------ the phases
# Each phase is a compiled function of its own (LLVM inlines the small ones); the number of lanes, n and M arrive as
# literal (compile-time) arguments in the many-lane entries, and each phase derives its row offsets from them.


@numba.njit(cache=True, inline="always")
def _idle(S, lanes, rows, w):
    """A lane without a run steps by h = 0 from t = −∞ and has no output due."""
    S[(rows.t) * lanes + w] = -np.inf
    S[(rows.h) * lanes + w] = 0.0
    S[(rows.next) * lanes + w] = np.inf


@numba.njit(cache=True, inline="always")
def _output_rows(outputs, stage, mode, w, i):
    """Where run i (in lane w) writes its states: straight into ``Y`` in mode STATES, else the worker's own rows
    (in cache until the run ends)."""
    return outputs.Y[i] if mode == STATES else stage[w]


@numba.njit(cache=True, inline="always", error_model="numpy")
def _load_runs(S, lanes, n, M, model, runs, t_out, queue, q, run, idx, fresh, outputs, stage, mode):
    """Empty lanes take the next runs of the queue (from ``q``); their first rates are evaluated for all lanes at
    once and kept for the new lanes only. Returns the new ``q`` and the number of runs loaded."""
    rows = workspace_rows(n, M)
    m = 6 * n + 6
    loaded = 0
    for w in range(lanes):
        fresh[w] = False
        if run[w] >= 0 or q >= queue.shape[0]:
            continue
        i = queue[q]
        q += 1
        out = _output_rows(outputs, stage, mode, w, i)
        for j in range(m):
            S[(rows.y + j) * lanes + w] = runs.y0[i, j]
            out[0, j] = runs.y0[i, j]
        run[w] = i
        idx[w] = 1
        S[(rows.t) * lanes + w] = t_out[0]
        S[(rows.h) * lanes + w] = runs.h0[i]
        S[(rows.acc) * lanes + w] = 0.0
        S[(rows.rej) * lanes + w] = 0.0
        S[(rows.next) * lanes + w] = t_out[1]
        # torque terms a_j sin(ν_j t + φ_j) = (a_j cos φ_j) sin ν_j t + (a_j sin φ_j) cos ν_j t
        for d in range(3):
            S[(rows.tc + d) * lanes + w] = runs.torque_constant[i, d]
            S[(rows.tau_fresh + d) * lanes + w] = runs.torque_constant[i, d]
        for j in range(M):
            s0 = np.sin(runs.torque_frequencies[i, j] * t_out[0])
            c0 = np.cos(runs.torque_frequencies[i, j] * t_out[0])
            S[(rows.freq + j) * lanes + w] = runs.torque_frequencies[i, j]
            S[(rows.sn + j) * lanes + w] = s0
            S[(rows.cs + j) * lanes + w] = c0
            for d in range(3):
                a_cos = runs.torque_amplitudes[i, j, d] * np.cos(runs.torque_phases[i, j, d])
                a_sin = runs.torque_amplitudes[i, j, d] * np.sin(runs.torque_phases[i, j, d])
                S[(rows.acos + 3 * j + d) * lanes + w] = a_cos
                S[(rows.asin + 3 * j + d) * lanes + w] = a_sin
                S[(rows.tau_fresh + d) * lanes + w] += a_cos * s0 + a_sin * c0
        fresh[w] = True
        loaded += 1
    if loaded > 0:
        frozen_decay_rates(S, lanes, n, model, rows.y, rows.lf_fresh)
        coupled_rates(S, lanes, n, model, rows.y, rows.lf_fresh, rows.tau_fresh, rows.N_fresh)
        for w in range(lanes):
            if fresh[w]:
                for j in range(m):
                    S[(rows.Nu + j) * lanes + w] = S[(rows.N_fresh + j) * lanes + w]
                for i in range(n):
                    S[(rows.lf + i) * lanes + w] = S[(rows.lf_fresh + i) * lanes + w]
    return q, loaded


@numba.njit(cache=True, inline="always", error_model="numpy")
def _choose_steps(S, lanes, n, M, h_max, t_end):
    """Each lane's trial step: its next step, at most ``h_max``, stretched to end on the last output time when
    within 1 % of it."""
    rows = workspace_rows(n, M)
    for w in range(lanes):
        hw = min(S[(rows.h) * lanes + w], h_max)
        last = S[(rows.t) * lanes + w] + 1.01 * hw >= t_end
        hw = t_end - S[(rows.t) * lanes + w] if last else hw
        S[(rows.last) * lanes + w] = 1.0 if last else 0.0
        S[(rows.hh) * lanes + w] = hw
        S[(rows.half) * lanes + w] = 0.5 * hw
        S[(rows.h6) * lanes + w] = hw / 6.0


@numba.njit(cache=True, inline="always", error_model="numpy")
def _trial(S, lanes, n, M, model):
    """One ETDRK4 trial for all lanes (:mod:`omegahat.simulation.etd`), then the rates at the new point."""
    rows = workspace_rows(n, M)
    torque_stages(S, lanes, n, M)
    phi_weights(S, lanes, n, M)
    half_stage(S, lanes, n, M, rows.Nu, rows.ya)
    coupled_rates(S, lanes, n, model, rows.ya, rows.lf, rows.tau + 3, rows.Na)
    half_stage(S, lanes, n, M, rows.Na, rows.yb)
    coupled_rates(S, lanes, n, model, rows.yb, rows.lf, rows.tau + 3, rows.Nb)
    last_stage(S, lanes, n, M)
    coupled_rates(S, lanes, n, model, rows.yc, rows.lf, rows.tau + 6, rows.Nc)
    combine(S, lanes, n, M)
    frozen_decay_rates(S, lanes, n, model, rows.y_new, rows.lf_new)
    coupled_rates(S, lanes, n, model, rows.y_new, rows.lf_new, rows.tau + 6, rows.N_new)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _accept(S, lanes, n, M, t_end, all_bits):
    """Acceptance, counters and the next step for all lanes; returns how many lanes need the per-lane code (an
    output time reached, or a non-finite error)."""
    rows = workspace_rows(n, M)
    flagged = 0
    for w in range(lanes):
        e = S[(rows.err) * lanes + w]
        hw = S[(rows.hh) * lanes + w]
        finite = e < np.inf  # False for inf and NaN
        accept = e <= 1.0
        t_new = t_end if S[(rows.last) * lanes + w] != 0.0 else S[(rows.t) * lanes + w] + hw
        S[(rows.t_new) * lanes + w] = t_new
        S[(rows.mask) * lanes + w] = all_bits if accept else 0.0
        S[(rows.acc) * lanes + w] += 1.0 if accept else 0.0
        S[(rows.rej) * lanes + w] += 0.0 if accept else 1.0
        S[(rows.h) * lanes + w] = hw * S[(rows.factor) * lanes + w] if finite else 0.25 * hw
        flag = (accept and S[(rows.next) * lanes + w] <= t_new) or not finite
        S[(rows.flag) * lanes + w] = 1.0 if flag else 0.0
        flagged += flag
    return flagged


@numba.njit(cache=True, inline="always", error_model="numpy")
def _outputs_and_failures(S, lanes, n, M, run, idx, failed, t_out, outputs, stage, mode):
    """Lane by lane where flagged: the output times inside the accepted step (continuous extension; the last one
    exactly), or, for a non-finite error at a step below 1e-14, the run's failure (that trial not counted)."""
    rows = workspace_rows(n, M)
    T = t_out.shape[0]
    m = 6 * n + 6
    for w in range(lanes):
        i = run[w]
        if S[(rows.flag) * lanes + w] == 0.0 or i < 0:
            continue
        hw = S[(rows.hh) * lanes + w]
        if not S[(rows.err) * lanes + w] < np.inf:
            if hw < 1e-14:
                S[(rows.rej) * lanes + w] -= 1.0
                failed[w] = True
            continue
        t_new = S[(rows.t_new) * lanes + w]
        out = _output_rows(outputs, stage, mode, w, i)
        while idx[w] < T and t_out[idx[w]] < t_new:
            dense_output(S, lanes, n, M, hw, (t_out[idx[w]] - S[(rows.t) * lanes + w]) / hw, w, out[idx[w]])
            idx[w] += 1
        if idx[w] < T and t_out[idx[w]] == t_new:
            for j in range(m):
                out[idx[w], j] = S[(rows.y_new + j) * lanes + w]
            idx[w] += 1
        S[(rows.next) * lanes + w] = t_out[idx[w]] if idx[w] < T else np.inf


@numba.njit(cache=True, inline="always", error_model="numpy")
def _select_rows(Si, lanes, rmask, rdst, rsrc, count):
    """Rows ``rdst ..`` take rows ``rsrc ..`` where the mask is all ones: a bitwise select, exact, vectorised."""
    for w in range(lanes):
        mk = Si[(rmask) * lanes + w]
        for j in range(count):
            Si[(rdst + j) * lanes + w] = (Si[(rsrc + j) * lanes + w] & mk) | (Si[(rdst + j) * lanes + w] & ~mk)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _advance(Si, lanes, n, M):
    """Accepted lanes move to the new point; its rates become the next step's first (first same as last)."""
    rows = workspace_rows(n, M)
    m = 6 * n + 6
    _select_rows(Si, lanes, rows.mask, rows.y, rows.y_new, m)
    _select_rows(Si, lanes, rows.mask, rows.Nu, rows.N_new, m)
    _select_rows(Si, lanes, rows.mask, rows.lf, rows.lf_new, n)
    _select_rows(Si, lanes, rows.mask, rows.sn, rows.sn_new, M)
    _select_rows(Si, lanes, rows.mask, rows.cs, rows.cs_new, M)
    _select_rows(Si, lanes, rows.mask, rows.t, rows.t_new, 1)


@numba.njit(cache=True, inline="always", error_model="numpy")
def _release_ended(S, lanes, n, M, run, idx, failed, max_steps, t_out, outputs, stage, mode, scratch):
    """Runs that reached the last output time, failed, or spent their budget of trials leave their lanes: a failed
    run's unreached rows become NaN, its counters go out, and in mode ENVELOPES its states are reduced to their
    diagnostics. Returns how many left."""
    rows = workspace_rows(n, M)
    T = t_out.shape[0]
    left = 0
    for w in range(lanes):
        i = run[w]
        if i < 0:
            continue
        good = idx[w] >= T
        if not (good or failed[w] or S[(rows.acc) * lanes + w] + S[(rows.rej) * lanes + w] >= max_steps):
            continue
        out = _output_rows(outputs, stage, mode, w, i)
        if not good:
            out[idx[w] :] = np.nan
        outputs.accepted[i] = np.int64(S[(rows.acc) * lanes + w])
        outputs.rejected[i] = np.int64(S[(rows.rej) * lanes + w])
        if mode == STATES:
            outputs.ok[i] = good
        else:
            diagnose_run(out, i, n, outputs.J, t_out, outputs.rho_floor, good, outputs.rho, outputs.diagnostics,
                         outputs.ok, scratch)  # fmt: skip
        run[w] = -1
        failed[w] = False
        _idle(S, lanes, rows, w)
        left += 1
    return left


class Buffers(NamedTuple):
    """A worker's own memory, allocated by the entry point: the workspace ``S (rows, lanes)``, each lane's
    states while the run is in flight ``stage`` (mode ENVELOPES), the lanes' run, output index and flags, and a
    scratch row for the diagnostics."""

    S: np.ndarray
    stage: np.ndarray
    run: np.ndarray
    idx: np.ndarray
    failed: np.ndarray
    fresh: np.ndarray
    scratch: np.ndarray


@numba.njit(cache=True, inline="always")
def _buffers(lanes, n, M, T, mode):
    rows = workspace_rows(n, M)
    return Buffers(
        np.zeros(rows.count * lanes), np.empty((lanes if mode == ENVELOPES else 0, T, 6 * n + 6)),
        np.full(lanes, -1, dtype=np.int64), np.zeros(lanes, dtype=np.int64), np.zeros(lanes, dtype=np.bool_),
        np.zeros(lanes, dtype=np.bool_), np.empty(T),
    )  # fmt: skip


# Compiled without Numba's reference counting (_nrt=False): every array here is owned by the entry point that
# allocated it, and the phases' array arguments would otherwise cost atomic increments and decrements at every
# call (a fifth of a single run's time). Nothing below allocates.
@numba.njit(cache=True, _nrt=False, error_model="numpy")  # type: ignore[call-overload]  # _nrt: not in the stubs
def _lockstep(queue, t_out, model, runs, control, outputs, mode, buffers, all_bits, lanes, n, M):
    """Integrate the runs ``queue`` (indices into ``runs``) on ``lanes`` lanes (module docstring), from
    ``t_out[0]`` to ``t_out[-1]`` (at least two output times), keeping what ``mode`` says in ``outputs``."""
    T = t_out.shape[0]
    t_end = t_out[T - 1]
    rows = workspace_rows(n, M)
    S = buffers.S
    Si = S.view(np.int64)
    stage, run, idx, failed, fresh = buffers.stage, buffers.run, buffers.idx, buffers.failed, buffers.fresh
    for w in range(lanes):
        _idle(S, lanes, rows, w)
        for j in range(M):
            S[(rows.cs + j) * lanes + w] = 1.0
            S[(rows.cs_new + j) * lanes + w] = 1.0
    q = 0
    active = 0
    while True:
        q, loaded = _load_runs(S, lanes, n, M, model, runs, t_out, queue, q, run, idx, fresh, outputs, stage, mode)
        active += loaded
        if active == 0:
            break
        _choose_steps(S, lanes, n, M, control.h_max, t_end)
        _trial(S, lanes, n, M, model)
        error_ratios(S, lanes, n, M, control.rtol, control.atol)
        if _accept(S, lanes, n, M, t_end, all_bits) > 0:
            _outputs_and_failures(S, lanes, n, M, run, idx, failed, t_out, outputs, stage, mode)
        _advance(Si, lanes, n, M)
        active -= _release_ended(
            S, lanes, n, M, run, idx, failed, control.max_steps, t_out, outputs, stage, mode, buffers.scratch
        )


# ----------------------------------------------------------------------------------------------- entry points


_ALL_BITS = np.array([-1], dtype=np.int64).view(np.float64)[0]  # the accepted-lane mask as a float64 (a NaN)


@numba.njit(cache=True, parallel=True, error_model="numpy")
def _parallel(t_out, model, runs, control, outputs, mode, n_workers, lanes, n, M):
    for wk in numba.prange(n_workers):
        queue = np.arange(wk, runs.y0.shape[0], n_workers)  # run i to worker i mod n_workers
        buffers = _buffers(literally(lanes), literally(n), literally(M), t_out.shape[0], mode)
        _lockstep(queue, t_out, model, runs, control, outputs, mode, buffers, _ALL_BITS, literally(lanes),
                  literally(n), literally(M))  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def _serial(t_out, model, runs, control, outputs, mode, n_workers, lanes, n, M):
    buffers = _buffers(literally(lanes), literally(n), literally(M), t_out.shape[0], mode)
    _lockstep(np.arange(runs.y0.shape[0]), t_out, model, runs, control, outputs, mode, buffers, _ALL_BITS,
              literally(lanes), literally(n), literally(M))  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def _one_lane(t_out, model, runs, control, outputs, mode, n_workers, lanes, n, M):
    # one lane: the torque's number of terms at run time (its loops are short and not vectorised anyway)
    buffers = _buffers(literally(lanes), literally(n), M, t_out.shape[0], mode)
    _lockstep(np.arange(runs.y0.shape[0]), t_out, model, runs, control, outputs, mode, buffers, _ALL_BITS,
              literally(lanes), literally(n), M)  # fmt: skip


_ENTRIES: dict = {}  # (entry, lanes, n, M) -> the compiled entry point


def _call(kernel, args: tuple, lanes: int, n: int, M: int) -> None:
    """Call a compiled entry whose last three arguments are ``(lanes, n, M)``: Numba's dispatch of literal
    arguments costs milliseconds a call, so after the first call (which compiles, or loads the on-disk cache) the
    compiled entry point is called directly."""
    literal_M = kernel is not _one_lane
    key = (kernel, lanes, n, M if literal_M else -1)
    entry = _ENTRIES.get(key)
    if entry is not None:
        entry(*args, lanes, n, M)
        return
    kernel(*args, lanes, n, M)
    lit = numba.types.literal
    for sig, cres in kernel.overloads.items():
        if sig[-3] == lit(lanes) and sig[-2] == lit(n) and (not literal_M or sig[-1] == lit(M)):
            _ENTRIES[key] = cres.entry_point


def _integrate(model, runs, t_out, control, mode, rho_floor, n_workers, lanes, parallel) -> RunOutputs:
    model, runs, t_out, n, M = check_inputs(model, runs, t_out)
    N, T, m = runs.y0.shape[0], t_out.size, 6 * n + 6
    states = mode == STATES
    outputs = RunOutputs(
        np.zeros(N, np.int64), np.zeros(N, np.int64), np.ones(N, np.bool_),
        np.empty((N, T, m) if states else (0, 0, 0)), np.empty((0, 0) if states else (N, T)),
        np.empty((6, 0) if states else (6, N)), model.J, float(rho_floor),
    )  # fmt: skip
    if T == 1:  # nothing to integrate (the engine needs a second output time): the initial states
        for i in range(N):
            if states:
                outputs.Y[i, 0] = runs.y0[i]
            else:
                diagnose_run(runs.y0[i : i + 1], i, n, model.J, t_out, outputs.rho_floor, True, outputs.rho,
                             outputs.diagnostics, outputs.ok, np.empty(1))  # fmt: skip
        return outputs
    control = StepControl(float(control.rtol), float(control.atol), float(control.h_max), int(control.max_steps))
    args = (t_out, model, runs, control, outputs, mode, int(n_workers))
    if lanes == 1:
        _call(_one_lane, args, 1, n, M)
    else:
        _call(_parallel if parallel else _serial, args, int(lanes), n, M)
    return outputs


def integrate_states(
    model: Model,
    runs: RunSet,
    t_out: ArrayLike,
    control: StepControl,
    n_workers: int = 1,
    lanes: int = LANES,
    parallel: bool = True,
) -> RunOutputs:
    """Integrate every run of ``runs``; return :class:`RunOutputs` with the states ``Y (N, T, 6n + 6)`` at
    ``t_out`` (a failed run's rows from its failure on are NaN and its ``ok`` is False) and the counters.

    ``lanes=1`` is the single-run path (:func:`omegahat.simulation.coupled.simulate`); otherwise ``lanes``
    lanes per worker, run i on worker ``i mod n_workers`` (``parallel``: Numba's threads; ``parallel=False``: all
    on the calling thread, for callers that run several batches in threads, e.g. Dask). Every run gets the same
    bits whatever ``lanes``, ``n_workers`` and ``parallel``.
    """
    return _integrate(model, runs, t_out, control, STATES, 0.0, n_workers, lanes, parallel)


def integrate_envelopes(
    model: Model,
    runs: RunSet,
    t_out: ArrayLike,
    control: StepControl,
    rho_floor: float,
    n_workers: int = 1,
    lanes: int = LANES,
    parallel: bool = True,
) -> RunOutputs:
    """:func:`integrate_states` keeping of each run only its envelope diagnostics
    (:func:`omegahat.simulation.envelope.diagnose_run` with ``rho_floor``, J the body's inertia): ``rho (N, T)`` and
    ``diagnostics (6, N)``, taken as the run ends from its states in the worker's own rows, so that no more than
    the runs in flight are ever held (a campaign's chunk of 1024 runs of 401 output times would need 59 MB)."""
    return _integrate(model, runs, t_out, control, ENVELOPES, rho_floor, n_workers, lanes, parallel)
