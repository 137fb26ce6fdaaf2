r"""The sampled estimator's compiled step: one sample in, the state advanced, in one Numba call.

The realisation is explained in :mod:`omegahat.observer.estimator` (``docs/theory/sampled.md``): between samples the
prediction (P) — ω̂ by Euler's equations, the attitude increment ``ΔR̂`` along ω̂ by RKMK4, the filter errors
rotated and decayed exactly — then, at a valid sample, the innovation ``Δ_i`` (I), the implicit correction (C)
and the reset (R); the warm start (W) at the second valid sample. Each step is a function of its own (the
prediction's in :mod:`omegahat.observer.prediction`, the others here), built from :mod:`omegahat.kernels`
(Euler's equations, the observer's innovation and stiffness, exp and dexp⁻¹ on SO(3), Wahba's problem) and the
input checks of :mod:`omegahat.kernels.checks`.

**The state** is one flat array (a ``SarrasEstimator`` hands it to the compiled code and back, and a flat array
crosses that boundary in a fraction of a microsecond where a named tuple of arrays costs more than the step). Its
layout is named: :data:`STATE` (offsets of the fixed part; ``r`` then ``e``, ``3n`` each, follow) and the stage
codes :data:`UNINITIALISED`, :data:`WARM_PENDING`, :data:`RUNNING`. The parameters likewise: :data:`PARAMS`, built by
:func:`pack_params`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

from omegahat.kernels import checks
from omegahat.kernels.dynamics import euler_rate
from omegahat.kernels.observer import innovation, stiffness
from omegahat.kernels.rotation import rotvec_from_matrix, wahba
from omegahat.kernels.vec3 import inverse, matmul, matvec, solve
from omegahat.observer.gains import ObserverGains
from omegahat.observer.prediction import (
    predict_directions,
    predict_rate,
)

__all__ = [
    "PARAMS",
    "RUNNING",
    "STATE",
    "UNINITIALISED",
    "WARM_PENDING",
    "EstimatorState",
    "ParamLayout",
    "StateLayout",
    "initial_state_vector",
    "pack_params",
    "run",
    "start_over",
    "step",
]


class StateLayout(NamedTuple):
    """Offsets in the flat state: time of the last sample, stage, time of the last valid sample, ω̂ (3), the torque
    given with the last sample (3), the aim ``Γ`` accumulated since the last valid sample (9, row-major; (A1));
    then the directions ``r`` (3n) and the filter errors ``e = r̂ − r`` (3n)."""

    t: int
    stage: int
    t_meas: int
    omega_hat: int
    torque: int
    aim: int
    r: int


STATE = StateLayout(t=0, stage=1, t_meas=2, omega_hat=3, torque=6, aim=9, r=18)
UNINITIALISED = 0.0  #: stage before the first valid sample
WARM_PENDING = 1.0  #: stage after it while a warm start waits for the second
RUNNING = 2.0  #: stage from then on


class ParamLayout(NamedTuple):
    """Offsets in the flat parameters; ``k``, ``l_offset``, ``l_slope`` (n each), the references ``V`` (3n) and
    the initial ``r̂`` (3n) follow from ``k`` on."""

    J: int
    Jinv: int
    rotation_tol: int
    quat_norm_tol: int
    min_sin: int
    max_angle: int
    scalar_first: int
    has_r_hat0: int
    n: int
    warm_start: int
    linear_hold: int
    isotropic_rate: int
    k: int


PARAMS = ParamLayout(
    J=0, Jinv=9, rotation_tol=18, quat_norm_tol=19, min_sin=20, max_angle=21, scalar_first=22, has_r_hat0=23, n=24,
    warm_start=25, linear_hold=26, isotropic_rate=27, k=28,
)  # fmt: skip
TORQUE_HOLDS = ("zero", "linear")  #: the torque between samples: held (zero order) or interpolated (first order)


def pack_params(
    J: np.ndarray, gains: ObserverGains, references: ArrayLike, r_hat0: ArrayLike | None, rotation_tol: float,
    quat_norm_tol: float, min_angle_deg: float, max_angle: float, scalar_first: bool, warm_start: bool,
    torque_hold: str = "zero", isotropic_rate: float | None = None,
) -> np.ndarray:  # fmt: skip
    """The flat parameters (:data:`PARAMS`) of an estimator. ``isotropic_rate`` (rad/s, None = off): the
    geometry-aware correction (C) with the matrix gain ``G = b M⁻¹``."""
    n = gains.n
    return np.concatenate([
        np.asarray(J, dtype=float).ravel(),
        np.linalg.inv(J).ravel(),
        [rotation_tol, quat_norm_tol, math.sin(math.radians(min_angle_deg)), max_angle, float(scalar_first),
         float(r_hat0 is not None), float(n), float(warm_start), float(torque_hold == "linear"),
         0.0 if isotropic_rate is None else float(isotropic_rate)],
        gains.k, gains.l_offset, gains.l_slope,
        np.asarray(references, dtype=float).ravel(),
        np.zeros(3 * n) if r_hat0 is None else np.asarray(r_hat0, dtype=float).ravel(),
    ])  # fmt: skip


@dataclass(frozen=True)
class EstimatorState:
    """A readable copy of the state (``n`` directions).

    ``t`` time of the last sample (NaN before any), ``initialised`` whether a valid sample has set ``r``,
    ``t_meas`` time of the last valid (not skipped) sample, ``omega_hat (3,)``, ``torque (3,)`` held since ``t``,
    ``r (n, 3)`` the directions at ``t`` (the last measurement or its prediction), ``e (n, 3) = r̂ − r``,
    ``warm_pending`` whether a warm start waits for the second valid sample (``r`` is then the first sample's
    measurement), ``aim`` ``(3, 3)`` the aim Γ (A1) accumulated since the last valid sample (0 right after one).
    """

    t: float
    initialised: bool
    t_meas: float
    omega_hat: np.ndarray
    torque: np.ndarray
    r: np.ndarray
    e: np.ndarray
    warm_pending: bool = False
    aim: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))

    @property
    def r_hat(self) -> np.ndarray:
        """The observer's filtered directions ``r̂ = r + e``, ``(n, 3)``."""
        return self.r + self.e

    @classmethod
    def from_vector(cls, x: np.ndarray) -> EstimatorState:
        n = (x.size - STATE.r) // 6
        return cls(
            t=float(x[STATE.t]),
            initialised=bool(x[STATE.stage] != UNINITIALISED),
            t_meas=float(x[STATE.t_meas]),
            omega_hat=x[STATE.omega_hat : STATE.omega_hat + 3].copy(),
            torque=x[STATE.torque : STATE.torque + 3].copy(),
            r=x[STATE.r : STATE.r + 3 * n].reshape(n, 3).copy(),
            e=x[STATE.r + 3 * n :].reshape(n, 3).copy(),
            warm_pending=bool(x[STATE.stage] == WARM_PENDING),
            aim=x[STATE.aim : STATE.aim + 9].reshape(3, 3).copy(),
        )

    def to_vector(self) -> np.ndarray:
        stage = UNINITIALISED if not self.initialised else WARM_PENDING if self.warm_pending else RUNNING
        return np.concatenate(
            [
                [self.t, stage, self.t_meas],
                self.omega_hat,
                self.torque,
                np.asarray(self.aim).ravel(),
                self.r.ravel(),
                self.e.ravel(),
            ]
        )


def initial_state_vector(n: int, omega_hat0: ArrayLike) -> np.ndarray:
    """The state before any sample: time NaN, uninitialised, ω̂ = ω̂₀."""
    x = np.zeros(STATE.r + 6 * n)
    x[STATE.t] = np.nan
    x[STATE.t_meas] = np.nan
    x[STATE.omega_hat : STATE.omega_hat + 3] = omega_hat0
    return x


# ------------------------------------------------------------------------------------------------ the steps


@numba.njit(cache=True, error_model="numpy")
def _correct(Jinv, k, iso_rate, w, r, e, r_meas, aim):
    """(I), (C) and (R) at a valid sample: ``Δ_i = r_i,meas − r_i,pred``; the innovation accumulated over the
    interval, ``y = Σ innovation(k_i, r̂_i, −Δ_i)`` (O1 with the mismatch ``−Δ_i``); the aimed, implicit
    correction (C) ``ω̂ += (I + G M_meas Γ)⁻¹ G y`` with the stiffness (O6) at the measured directions, the aim
    ``Γ`` (A1) and the rate gain ``G = J⁻¹`` (the observer's) or ``G = b M_meas⁻¹`` (isotropic,
    ``iso_rate = b > 0``); then ``e ← e − Δ``, ``r ← r_meas`` (r̂ continuous) and ``Γ ← 0``."""
    y0 = y1 = y2 = 0.0
    M00 = M11 = M22 = M01 = M02 = M12 = 0.0
    for i in range(r.shape[0]):
        m0, m1, m2 = r_meas[i, 0], r_meas[i, 1], r_meas[i, 2]
        d0, d1, d2 = m0 - r[i, 0], m1 - r[i, 1], m2 - r[i, 2]  # (I): Δ_i
        a0, a1, a2, b0, b1, b2 = innovation(
            k[i], r[i, 0] + e[i, 0], r[i, 1] + e[i, 1], r[i, 2] + e[i, 2], -d0, -d1, -d2
        )
        y0 += a0
        y1 += a1
        y2 += a2
        s = stiffness(k[i], m0, m1, m2)
        M00 += s[0]
        M11 += s[1]
        M22 += s[2]
        M01 += s[3]
        M02 += s[4]
        M12 += s[5]
        e[i, 0], e[i, 1], e[i, 2] = e[i, 0] + b0, e[i, 1] + b1, e[i, 2] + b2  # (R): e ← e − Δ
        r[i, 0], r[i, 1], r[i, 2] = m0, m1, m2
    M = (M00, M01, M02, M01, M11, M12, M02, M12, M22)
    Gamma = (aim[0], aim[1], aim[2], aim[3], aim[4], aim[5], aim[6], aim[7], aim[8])
    if iso_rate > 0.0:
        Mi = inverse(M)
        G = (iso_rate * Mi[0], iso_rate * Mi[1], iso_rate * Mi[2], iso_rate * Mi[3], iso_rate * Mi[4],
             iso_rate * Mi[5], iso_rate * Mi[6], iso_rate * Mi[7], iso_rate * Mi[8])  # fmt: skip
    else:
        G = Jinv
    GMG = matmul(matmul(G, M), Gamma)
    T = (1.0 + GMG[0], GMG[1], GMG[2], GMG[3], 1.0 + GMG[4], GMG[5], GMG[6], GMG[7], 1.0 + GMG[8])
    z0, z1, z2 = matvec(G, y0, y1, y2)
    dw0, dw1, dw2 = solve(T, z0, z1, z2)
    w[0] += dw0
    w[1] += dw1
    w[2] += dw2
    aim[:] = 0.0  # the attitude is known at a valid sample


@numba.njit(cache=True, error_model="numpy")
def _warm_start(Jm, Jinv, k, l_off, l_slope, tau, h, w, r, e, r_meas):
    """(W) at the second valid sample, ``h`` after the first: Wahba's rotation A carrying the first sample's
    directions onto the second's (R6), ω_avg = log(Aᵀ)/h, half a step of Euler's equations to the sample's time;
    r, e advanced like (P), (I) and (R) with ΔR̂ = Aᵀ."""
    A = wahba(k, r_meas, r)
    p0, p1, p2 = rotvec_from_matrix(A.T.copy())  # ΔR̂ = Aᵀ = exp(h ω_avg)
    u0, u1, u2 = p0 / h, p1 / h, p2 / h
    f0, f1, f2 = euler_rate(Jm, Jinv, u0, u1, u2, tau[0], tau[1], tau[2])
    int_abs = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2) * h  # ∫|ω̂| dt along the constant ω_avg
    D = A.T.copy()
    for i in range(r.shape[0]):
        predict_directions(r, e, D, math.exp(-(l_off[i] * h + l_slope[i] * int_abs)), i)
        for a in range(3):  # (R): r̂ continuous, r jumps to the measurement
            e[i, a] -= r_meas[i, a] - r[i, a]
            r[i, a] = r_meas[i, a]
    w[0], w[1], w[2] = u0 + 0.5 * h * f0, u1 + 0.5 * h * f1, u2 + 0.5 * h * f2  # midpoint rate → the sample's


@numba.njit(cache=True, error_model="numpy")
def _restart(out, t, r_meas, valid):
    """The guard's restart (status ``RESTARTED``): the step to ``t`` gave a non-finite state (a gap too long for
    the model, an overflowing torque, gains beyond floating point), so the state is discarded and the estimator
    starts again from this sample (:func:`start_over`); ω̂ is NaN (no estimate) until its warm start. Returns the
    code."""
    out[STATE.omega_hat : STATE.omega_hat + 3] = np.nan
    start_over(out, t, r_meas, valid)
    return checks.RESTARTED


@numba.njit(cache=True, error_model="numpy")
def start_over(out, t, r_meas, valid):
    """The state ``out`` started again from the sample at ``t``: ``r`` ← the measurement when it is valid (``e = 0``,
    a warm start (W) waiting for the next valid sample), else uninitialised; ω̂ is left as it is (the caller's)."""
    out[STATE.aim :] = 0.0  # Γ, r, e (the sample's torque stays: it is held from t)
    if valid:
        out[STATE.stage] = WARM_PENDING
        out[STATE.t_meas] = t
        for i in range(r_meas.shape[0]):
            for a in range(3):
                out[STATE.r + 3 * i + a] = r_meas[i, a]
    else:
        out[STATE.stage] = UNINITIALISED
        out[STATE.t_meas] = np.nan


@numba.njit(cache=True, error_model="numpy")
def step_into(x, p, t, m, kind, tau, out, wk):
    """Check one sample and advance the state ``x`` into ``out``; returns ``(status, info)`` (the codes of
    :mod:`omegahat.kernels.checks`). On a rejection ``out`` is unspecified and ``x`` untouched. ``wk``: scratch
    ``(n + 6, 3)``."""
    n = int(p[PARAMS.n])
    o, oi = PARAMS.J, PARAMS.Jinv
    Jm = (p[o], p[o + 1], p[o + 2], p[o + 3], p[o + 4], p[o + 5], p[o + 6], p[o + 7], p[o + 8])
    Jinv = (p[oi], p[oi + 1], p[oi + 2], p[oi + 3], p[oi + 4], p[oi + 5], p[oi + 6], p[oi + 7], p[oi + 8])
    k = p[PARAMS.k : PARAMS.k + n]
    l_off = p[PARAMS.k + n : PARAMS.k + 2 * n]
    l_slope = p[PARAMS.k + 2 * n : PARAMS.k + 3 * n]
    V = p[PARAMS.k + 3 * n : PARAMS.k + 6 * n].reshape(n, 3)
    r_meas, D, R_work = wk[:n], wk[n : n + 3], wk[n + 3 : n + 6]
    status, info = checks.check_sample(
        t, x[STATE.t], tau, m, kind, V, p[PARAMS.scalar_first] != 0.0, p[PARAMS.rotation_tol],
        p[PARAMS.quat_norm_tol], p[PARAMS.min_sin], r_meas, R_work,
    )  # fmt: skip
    if status >= checks.ERROR:
        return status, info
    for i in range(x.size):  # element loops, not slice assignments: those compile a shape check and its message
        out[i] = x[i]
    out[STATE.t] = t
    for a in range(3):
        out[STATE.torque + a] = tau[a]
    w = out[STATE.omega_hat : STATE.omega_hat + 3]
    r = out[STATE.r : STATE.r + 3 * n].reshape(n, 3)
    e = out[STATE.r + 3 * n : STATE.r + 6 * n].reshape(n, 3)
    valid = status == checks.OK
    stage = x[STATE.stage]
    if stage == UNINITIALISED:
        if valid:  # the first valid sample sets r; e from the given r̂₀ (default: r̂ = r)
            restarting = not math.isfinite(w[0])  # after a restart: always a warm start, never r̂₀
            out[STATE.stage] = WARM_PENDING if p[PARAMS.warm_start] != 0.0 or restarting else RUNNING
            out[STATE.t_meas] = t
            given = p[PARAMS.has_r_hat0] != 0.0 and not restarting
            for i in range(n):
                for a in range(3):
                    r[i, a] = r_meas[i, a]
                    e[i, a] = p[PARAMS.k + 6 * n + 3 * i + a] - r_meas[i, a] if given else 0.0
        return status, info
    held = x[STATE.torque : STATE.torque + 3]
    if stage == WARM_PENDING:
        if valid:
            _warm_start(Jm, Jinv, k, l_off, l_slope, held, t - x[STATE.t_meas], w, r, e, r_meas)
            out[STATE.aim : STATE.aim + 9] = 0.0
            out[STATE.stage] = RUNNING
            out[STATE.t_meas] = t
            if not checks.all_finite(out[STATE.omega_hat :]):
                return _restart(out, t, r_meas, valid), info
        return status, info
    h_pred = t - x[STATE.t]
    aim = out[STATE.aim : STATE.aim + 9]
    tau_end = tau if p[PARAMS.linear_hold] != 0.0 else held  # first-order hold: the new sample's torque is known
    int_abs = predict_rate(Jm, Jinv, p[PARAMS.max_angle], w, held, tau_end, h_pred, D, aim)
    for i in range(n):
        predict_directions(r, e, D, math.exp(-(l_off[i] * h_pred + l_slope[i] * int_abs)), i)
    if valid:  # the correction's interval: since the last valid sample (a skipped one only adds substeps)
        _correct(Jinv, k, p[PARAMS.isotropic_rate], w, r, e, r_meas, aim)
        out[STATE.t_meas] = t
    if not checks.all_finite(out[STATE.omega_hat :]):  # ω̂, τ, Γ, r, e: the guard of every step
        return _restart(out, t, r_meas, valid), info
    return status, info


@numba.njit(cache=True, error_model="numpy")
def step(x, p, t, m, kind, tau):
    """The pure step: ``(new state, status, info)``; ``x`` is not modified. ``m`` is 2-D (a matrix ``(3, 3)``, a
    quaternion ``(1, 4)`` or directions ``(n, 3)``), ``kind`` one of the ``KIND_*`` codes."""
    out = np.empty_like(x)
    status, info = step_into(x, p, t, m, kind, tau, out, np.empty((int(p[PARAMS.n]) + 6, 3)))
    return out, status, info


# without the GIL: the command reads the next chunk and writes the last in other threads meanwhile (test_gil.py)
@numba.njit(cache=True, error_model="numpy", nogil=True)
def run(x, p, times, m, kind, taus):
    """:func:`step_into` over a log: ``(final state, ω̂ (T, 3), status (T,), first_bad, info)``; at the first
    rejected sample it stops and returns the state it started from (``first_bad`` its index, else −1)."""
    T = times.size
    W = np.empty((T, 3))
    status = np.zeros(T, dtype=np.int64)
    cur = x.copy()
    nxt = np.empty_like(x)
    wk = np.empty((int(p[PARAMS.n]) + 6, 3))
    for j in range(T):
        s, info = step_into(cur, p, times[j], m[j], kind, taus[j], nxt, wk)
        status[j] = s
        if s >= checks.ERROR:
            return x, W, status, j, info
        cur, nxt = nxt, cur
        W[j, 0], W[j, 1], W[j, 2] = cur[STATE.omega_hat], cur[STATE.omega_hat + 1], cur[STATE.omega_hat + 2]
    return cur, W, status, -1, 0.0
