r"""The supervised Kalman step compiled: the Sarras observer and a gyro-less EKF advanced together, one sample in.

:class:`omegahat.observer.kalman.SupervisedKalmanEstimator` is the Python shell and explains the design
(``docs/theory/supervised.md``). Per sample, in one Numba call:

1. the sampled Sarras step (:func:`omegahat.observer.sampled.step_into`): it checks the sample (one input path for
   both parts: a rejected sample leaves both states untouched) and advances the globally convergent observer;
2. the EKF (:mod:`omegahat.kernels.ekf`): propagation over the interval with the same torque hold, then the
   attitude fix (E5) or the direction fix (E6), which returns the normalised innovation squared ν;
3. the supervisor (S1)–(S4) below decides whether the EKF is trusted, and re-initialises it from the observer
   when it is not.

With ``d = |ω̂_EKF − ω̂_obs|``, ``s = √tr P_ωω`` (the EKF's own rate uncertainty) and ``σ_obs`` the observer's
stationary noise level (rad/s, from the gain design)::

    ν̄ ← (1 − α) ν̄ + α ν / m                       (S1, the innovation consistency, m = the fix's dimension)
    c ← c + 1 if d > max(κ s, κ σ_obs) else 0       (S2, persistent disagreement with the observer)
    lost = ν̄ > ν_max  or  c ≥ c_max  or  |ω̂_EKF| > ω_max  or  the EKF's state (R̂, ω̂, â, P) not finite     (S3)
    lost ⇒  R̂ ← the measured attitude, ω̂_EKF ← ω̂_obs,  P ← diag(σ_θ² I, (σ_obs²/3) I),  ν̄ ← 1, c ← 0     (S4)
    lost by (S2), ω_max or not finite ⇒  also â ← 0 (an unknown acceleration the EKF carries; by ν̄ it is kept)
    uncertain = s > κ σ_obs before the fix, with the yardstick σ_obs alone (supervision in the motion's scale)  (S5)

(S5), after a gap: a skipped sample gives the observer's prediction instead of the EKF's where its spread is past
the yardstick. At a fix whose prediction is uncertain, or after an interval (missing samples or a jump of the
clock) longer than ``restart_after``, both start over from the fix: the observer waits for its warm start (W) at
the next fix (the rate from the two fixes), the EKF starts again from that warm start, and the fix's rate is the
EKF's update where its prediction's attitude spread is within a quarter turn (``3 √tr P_θθ < π/2``), the rate held
through the gap where it is not (code ``HELD``: status ``predicted``), and the observer's where (S5) found the
prediction uncertain. The observer's own correction, which read the whole innovation (past half a turn, maybe), is
not kept (``docs/theory/supervised.md``).

The output is the EKF's estimate unless it was lost (and restarted) at this sample, then the observer's. The EKF's
state is a flat array with the named offsets :data:`EKF_STATE`; its parameters :data:`EKF_PARAMS`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from omegahat.kernels import checks
from omegahat.kernels.ekf import EKF_SCRATCH, ekf_attitude_update, ekf_finite, ekf_propagate, ekf_vector_update
from omegahat.kernels.rotation import wahba
from omegahat.observer import sampled
from omegahat.observer.sampled import PARAMS, RUNNING, STATE, WARM_PENDING

__all__ = [
    "EKF_PARAMS",
    "EKF_STATE",
    "FROM_EKF",
    "FROM_OBSERVER",
    "EkfParamLayout",
    "EkfStateLayout",
    "initial_ekf_state",
    "run",
    "step",
    "step_into",
]

FROM_OBSERVER = 0.0  #: the output came from the Sarras observer
FROM_EKF = 1.0  #: the output came from the EKF


class EkfStateLayout(NamedTuple):
    """Offsets in the EKF's flat state: started (0/1), ν̄ (S1), c (S2), resets so far, the output's source
    (:data:`FROM_OBSERVER` / :data:`FROM_EKF`), R̂ (9, row-major), ω̂ (3), the unknown acceleration â (3; zero
    unless the filter carries it), P (36 or 81, row-major; room for 81), then the sum of ν/m over the fixes the
    EKF was judged on and their number (the mean tells whether its noise model fits the data)."""

    started: int
    nis_avg: int
    disagree: int
    resets: int
    source: int
    R: int
    omega: int
    accel: int
    P: int
    nis_sum: int
    nis_count: int
    size: int


EKF_STATE = EkfStateLayout(
    started=0, nis_avg=1, disagree=2, resets=3, source=4, R=5, omega=14, accel=17, P=20, nis_sum=101, nis_count=102,
    size=103,
)  # fmt: skip


class EkfParamLayout(NamedTuple):
    """Offsets in the EKF's flat parameters: process-noise PSD q, measurement variance, σ_θ of a reset, σ_obs,
    α, ν_max, κ, c_max, dynamic model (0/1), the substep bounds (s, rad), the unknown acceleration's PSD q_a
    (rad²/s⁵; 0: not carried) and its prior σ (rad/s²), and σ of the rate it starts from at the first fix (rad/s,
    the 3-vector's RMS; 0: σ_obs, the observer's), the yardstick of (S2) (1: max(s, σ_obs); 0: σ_obs alone), and
    the largest rate the EKF may give (rad/s; above it, lost (S3)), and the interval between fixes above which
    both start over ((S5); s)."""

    q: int
    meas_var: int
    sigma_theta: int
    sigma_obs: int
    alpha: int
    nis_max: int
    kappa: int
    disagree_max: int
    dynamic: int
    max_step: int
    max_angle: int
    q_a: int
    sigma_accel: int
    sigma_start: int
    own_spread: int
    max_rate: int
    restart_after: int
    size: int


EKF_PARAMS = EkfParamLayout(
    q=0, meas_var=1, sigma_theta=2, sigma_obs=3, alpha=4, nis_max=5, kappa=6, disagree_max=7, dynamic=8, max_step=9,
    max_angle=10, q_a=11, sigma_accel=12, sigma_start=13, own_spread=14, max_rate=15,
    restart_after=16, size=17,
)  # fmt: skip


def initial_ekf_state() -> np.ndarray:
    """The EKF before any sample: not started (it starts from the observer at the first valid sample)."""
    x = np.zeros(EKF_STATE.size)
    x[EKF_STATE.nis_avg] = 1.0
    return x


@numba.njit(cache=True, forceinline=True, error_model="numpy")
def _covariance(xe, pe):
    """The EKF's P inside its flat state: 6×6, or 9×9 when it carries the unknown acceleration."""
    n = 9 if pe[EKF_PARAMS.q_a] > 0.0 else 6
    return xe[EKF_STATE.P : EKF_STATE.P + n * n].reshape(n, n)


@numba.njit(cache=True, error_model="numpy")
def _reinitialise(xe, pe, w_obs, R_meas, sigma_w, keep_accel):
    """(S4): the EKF restarted from the observer's rate (its error's RMS ``sigma_w``) and the measured attitude. An
    unknown acceleration it carries keeps its estimate, with its prior variance again, when ``keep_accel`` (the
    filter was lost by its innovations: the torque it has learnt is still the best guess), and returns to its prior
    mean, zero, when not (the filter's rate left the observer's (S2): the acceleration that drove it away is as
    wrong as the rate, and kept it would drive the restarted filter away again)."""
    R = xe[EKF_STATE.R : EKF_STATE.R + 9].reshape(3, 3)
    for a in range(3):  # element loops, not slice assignments: those compile a shape check and its message
        xe[EKF_STATE.omega + a] = w_obs[a]
        for b in range(3):
            R[a, b] = R_meas[a, b]
    if not keep_accel or not checks.all_finite(xe[EKF_STATE.accel : EKF_STATE.accel + 3]):
        xe[EKF_STATE.accel : EKF_STATE.accel + 3] = 0.0
    P = _covariance(xe, pe)
    P[:, :] = 0.0
    var_w = sigma_w**2 / 3.0
    for i in range(3):
        P[i, i] = pe[EKF_PARAMS.sigma_theta] ** 2
        P[3 + i, 3 + i] = var_w
        if P.shape[0] == 9:
            P[6 + i, 6 + i] = pe[EKF_PARAMS.sigma_accel] ** 2
    xe[EKF_STATE.nis_avg] = 1.0
    xe[EKF_STATE.disagree] = 0.0


@numba.njit(cache=True, error_model="numpy")
def _measured_attitude(p, m, kind, r_meas, R_work, out):
    """The sample's attitude R (body → inertial) into ``out``: the matrix itself, the quaternion's matrix (the
    checks left it in ``R_work``) or Wahba's attitude from the directions (``R v_i ≈ …``: ``R r_i = v_i``)."""
    # element loops, not slice assignments: those compile a shape check and its message
    if kind == checks.KIND_MATRIX:
        for a in range(9):
            out[a // 3, a % 3] = m[a // 3, a % 3]
    elif kind == checks.KIND_QUAT:
        for a in range(9):
            out[a // 3, a % 3] = R_work[a // 3, a % 3]
    else:
        n = int(p[PARAMS.n])
        V = p[PARAMS.k + 3 * n : PARAMS.k + 6 * n].reshape(n, 3)
        R = wahba(p[PARAMS.k : PARAMS.k + n], V, r_meas)
        for a in range(9):
            out[a // 3, a % 3] = R[a // 3, a % 3]


@numba.njit(cache=True, error_model="numpy")
def _start_over(xs_out, xe_out, t, r_meas, w_now):
    """(S5): the observer (``xs_out``) starts over from the fix at ``t`` (its warm start (W) at the next one), its
    rate meanwhile ``w_now`` (its own correction, which read an innovation that may be past half a turn, is not
    kept), and the EKF (``xe_out``) starts again from that warm start. Returns the observer's rate (``w_now``)."""
    w_out = xs_out[STATE.omega_hat : STATE.omega_hat + 3]
    sampled.start_over(xs_out, t, r_meas, True)
    for c in range(3):
        w_out[c] = w_now[c]
    xe_out[EKF_STATE.started] = 0.0
    xe_out[EKF_STATE.resets] += 1.0
    return w_out


@numba.njit(cache=True, error_model="numpy")
def step_into(xs, p, xe, pe, t, m, kind, tau, xs_out, xe_out, wk, ek):
    """One sample: the observer (``xs`` → ``xs_out``), the EKF and the supervisor (``xe`` → ``xe_out``); returns
    ``(status, info, ω̂)``. On a rejection the outputs are unspecified and the inputs untouched. ``wk``: the
    observer's scratch ``(n + 6, 3)``; ``ek``: ``EKF_SCRATCH + 9`` floats."""
    status, info = sampled.step_into(xs, p, t, m, kind, tau, xs_out, wk)
    w_obs = xs_out[STATE.omega_hat : STATE.omega_hat + 3]
    if status >= checks.ERROR:
        return status, info, w_obs
    for i in range(xe.size):
        xe_out[i] = xe[i]
    xe_out[EKF_STATE.source] = FROM_OBSERVER
    if status == checks.RESTARTED:  # the observer restarted (no estimate): the EKF starts again after it
        xe_out[EKF_STATE.started] = 0.0
        return status, info, w_obs
    n = int(p[PARAMS.n])
    R = xe_out[EKF_STATE.R : EKF_STATE.R + 9].reshape(3, 3)
    w = xe_out[EKF_STATE.omega : EKF_STATE.omega + 3]
    a = xe_out[EKF_STATE.accel : EKF_STATE.accel + 3]
    P = _covariance(xe_out, pe)
    scratch = ek[:EKF_SCRATCH]
    R_meas = ek[EKF_SCRATCH : EKF_SCRATCH + 9].reshape(3, 3)
    Jm = p[PARAMS.J : PARAMS.J + 9].reshape(3, 3)
    Jinv = p[PARAMS.Jinv : PARAMS.Jinv + 9].reshape(3, 3)
    started = xe[EKF_STATE.started] != 0.0
    if started:  # propagate over the interval with the observer's torque hold
        held = xs[STATE.torque : STATE.torque + 3]
        tau_end = tau if p[PARAMS.linear_hold] != 0.0 else held
        ekf_propagate(
            R, w, a, P, t - xs[STATE.t], held, tau_end, Jm, Jinv, pe[EKF_PARAMS.q], pe[EKF_PARAMS.q_a],
            pe[EKF_PARAMS.dynamic] != 0.0, pe[EKF_PARAMS.max_step], pe[EKF_PARAMS.max_angle],
        )  # fmt: skip
    finite = started and ekf_finite(R, w, a, P)  # the EKF's guard
    sigma_obs = pe[EKF_PARAMS.sigma_obs]
    kappa = pe[EKF_PARAMS.kappa]
    in_motion_scale = pe[EKF_PARAMS.own_spread] == 0.0  # (S5) applies where σ_obs is in the motion's scale
    uncertain = in_motion_scale and not math.sqrt(P[3, 3] + P[4, 4] + P[5, 5]) <= kappa * sigma_obs  # (S5)
    if status != checks.OK:  # skipped: both parts predicted through it; the EKF is not judged without a fix
        if started and not finite:  # its step could not be taken: it starts again from the observer at a fix
            xe_out[EKF_STATE.started] = 0.0
            xe_out[EKF_STATE.resets] += 1.0
        elif started and xe[EKF_STATE.source] == FROM_EKF and not uncertain:
            xe_out[EKF_STATE.source] = FROM_EKF
            return status, info, w
        return status, info, w_obs
    r_meas, R_work = wk[:n], wk[n + 3 : n + 6]
    _measured_attitude(p, m, kind, r_meas, R_work, R_meas)
    warm_started = xs[STATE.stage] == WARM_PENDING and xs_out[STATE.stage] == RUNNING
    if not started or warm_started:  # the first fix, or the observer's warm start: the EKF starts from it
        if math.isfinite(w_obs[0]):  # not while the observer restarts (NaN until its warm start)
            first = xe[EKF_STATE.resets] == 0.0 and pe[EKF_PARAMS.sigma_start] > 0.0  # a given start's own σ
            sigma = pe[EKF_PARAMS.sigma_start if first else EKF_PARAMS.sigma_obs]
            _reinitialise(xe_out, pe, w_obs, R_meas, sigma, True)
            xe_out[EKF_STATE.started] = 1.0
        return status, info, w_obs
    gap = uncertain or t - xs[STATE.t_meas] > pe[EKF_PARAMS.restart_after]  # (S5): missing samples or a time jump
    if gap and (uncertain or not finite):  # (S5): no point to linearise at: the observer's rate at the fix
        return status, info, _start_over(xs_out, xe_out, t, r_meas, w_obs)
    if not finite:  # (S3) for a propagation that could not be taken: restarted (S4)
        _reinitialise(xe_out, pe, w_obs, R_meas, sigma_obs, False)
        xe_out[EKF_STATE.resets] += 1.0
        return status, info, w_obs
    if gap and not 3.0 * math.sqrt(P[0, 0] + P[1, 1] + P[2, 2]) < 0.5 * math.pi:  # (S5): its 3σ past a quarter turn
        held = w if xe[EKF_STATE.source] == FROM_EKF else xs[STATE.omega_hat : STATE.omega_hat + 3]  # as in the gap
        return checks.HELD, info, _start_over(xs_out, xe_out, t, r_meas, held)  # no update: the rate held, predicted
    if kind == checks.KIND_DIRECTIONS:
        V = p[PARAMS.k + 3 * n : PARAMS.k + 6 * n].reshape(n, 3)
        nis = ekf_vector_update(R, w, a, P, r_meas, V, pe[EKF_PARAMS.meas_var], scratch) / (3.0 * n)
    else:
        nis = ekf_attitude_update(R, w, a, P, R_meas, pe[EKF_PARAMS.meas_var], scratch) / 3.0
    if gap:  # (S5) after a long gap: the EKF's update (its linearisation holds) is this fix's rate; both start over
        return status, info, _start_over(xs_out, xe_out, t, r_meas, w)
    alpha = pe[EKF_PARAMS.alpha]
    nis_avg = (1.0 - alpha) * xe[EKF_STATE.nis_avg] + alpha * nis  # (S1)
    xe_out[EKF_STATE.nis_sum] += nis
    xe_out[EKF_STATE.nis_count] += 1.0
    d0, d1, d2 = w[0] - w_obs[0], w[1] - w_obs[1], w[2] - w_obs[2]
    d = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
    s = math.sqrt(P[3, 3] + P[4, 4] + P[5, 5])
    yardstick = max(s, sigma_obs) if pe[EKF_PARAMS.own_spread] != 0.0 else sigma_obs
    disagree = xe[EKF_STATE.disagree] + 1.0 if d > kappa * yardstick else 0.0  # (S2)
    speed = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    diverged = disagree >= pe[EKF_PARAMS.disagree_max] or not ekf_finite(R, w, a, P) or speed > pe[EKF_PARAMS.max_rate]
    lost = diverged or not nis_avg <= pe[EKF_PARAMS.nis_max]  # (S3); a NaN average counts as lost
    if lost:  # (S4)
        _reinitialise(xe_out, pe, w_obs, R_meas, pe[EKF_PARAMS.sigma_obs], not diverged)
        xe_out[EKF_STATE.resets] += 1.0
        return status, info, w_obs
    xe_out[EKF_STATE.nis_avg] = nis_avg
    xe_out[EKF_STATE.disagree] = disagree
    xe_out[EKF_STATE.source] = FROM_EKF  # trusted until lost: a lone spike of the observer's noise is not a verdict
    return status, info, w


@numba.njit(cache=True, error_model="numpy")
def step(xs, p, xe, pe, t, m, kind, tau):
    """The pure step: ``(observer state, EKF state, ω̂ (3,), status, info)``; the inputs are not modified."""
    xs_out = np.empty_like(xs)
    xe_out = np.empty_like(xe)
    wk = np.empty((int(p[PARAMS.n]) + 6, 3))
    ek = np.empty(EKF_SCRATCH + 9)
    status, info, w = step_into(xs, p, xe, pe, t, m, kind, tau, xs_out, xe_out, wk, ek)
    return xs_out, xe_out, w.copy(), status, info


# without the GIL: the command reads the next chunk and writes the last in other threads meanwhile (test_gil.py)
@numba.njit(cache=True, error_model="numpy", nogil=True)
def run(xs, p, xe, pe, times, m, kind, taus):
    """:func:`step_into` over a log: ``(observer state, EKF state, ω̂ (T, 3), source (T,), status (T,), first_bad,
    info)``; at the first rejected sample it stops and returns the states it started from."""
    T = times.size
    W = np.empty((T, 3))
    source = np.zeros(T)
    status = np.zeros(T, dtype=np.int64)
    cs, ns = xs.copy(), np.empty_like(xs)
    ce, ne = xe.copy(), np.empty_like(xe)
    wk = np.empty((int(p[PARAMS.n]) + 6, 3))
    ek = np.empty(EKF_SCRATCH + 9)
    for j in range(T):
        s, info, w = step_into(cs, p, ce, pe, times[j], m[j], kind, taus[j], ns, ne, wk, ek)
        status[j] = s
        if s >= checks.ERROR:
            return xs, xe, W, source, status, j, info
        W[j, 0], W[j, 1], W[j, 2] = w[0], w[1], w[2]
        source[j] = ne[EKF_STATE.source]
        cs, ns = ns, cs
        ce, ne = ne, ce
    return cs, ce, W, source, status, -1, 0.0
