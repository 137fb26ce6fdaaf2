r"""The innovations' log-likelihood of a motion model on a log: one pass of the gyro-less EKF per evaluation.

For a model ``m`` (:data:`MODELS`) with process noise ``q`` and white measurement noise ``σ`` (rad per axis, or per
direction component), the EKF of :mod:`omegahat.kernels.ekf` run over the log gives innovations ``ν_k`` with
covariances ``S_k``; their Gaussian log-likelihood (the prediction-error criterion of system identification) is ::

    ℓ(q, σ) = −½ Σ_k ( log det 2π S_k + ν_kᵀ S_k⁻¹ ν_k )                                             (L1)

**σ is concentrated out.** The filter's gains depend on ``q`` and ``σ`` only through the tracking index ::

    Λ = √q h^{p + 1/2} / σ,      q = Λ² σ² / h^{2p+1}                                                 (L2)

(``p`` = 1 for a random-walk rate, 2 for a random-walk acceleration; ``h`` the median spacing): scaling ``σ`` and
``√q`` together scales every covariance by ``σ²`` and leaves the state, the gains and the innovations unchanged. One
pass at ``σ = 1`` with ``q = Λ²/h^{2p+1}`` gives ``D = Σ log det S̃_k``, ``N = Σ ν_kᵀ S̃_k⁻¹ ν_k`` and the degrees
of freedom ``d``; then for any ``σ`` ::

    ℓ(Λ, σ) = −½ ( D + d log σ² + N/σ² + d log 2π ),    maximised by  σ̂² = N/d                         (L3)

so that the search runs over ``Λ`` alone. The first fixes (a diffuse prior's, :data:`BURN_IN`) are left out.

**A long dropout restarts a kinematic model's pass.** Across an interval of more than :data:`RESTART_GAP` spacings
(more samples missing than a restart leaves out, half a spacing spared for jitter) the pass of ``rate`` or
``acceleration`` starts again from the diffuse prior at the next fix, its first :data:`BURN_IN` fixes left out
again: a gap is where such a model's extrapolation is least right (a smooth motion's rate changes over a gap by far
more than a random walk fitted to steps of ``h`` predicts), and its one mismatch, a fix many times its predicted
spread and the filter's ringing after it, would otherwise decide ``Λ``. The default's filter starts over there too
((S5) of :mod:`omegahat.observer.supervised`). Euler's equations with J and τ bridge a gap as physics does. Where
the restarted pass follows the samples after the gap past half a turn per step (a glitch there, which a settled
filter weighs as one: a held-out phone recording had every ``Λ`` fail so), that gap is bridged instead.
Measured (``tests/test_identification.py``): on a closed-form smooth turn at 240 Hz with 0.25 mrad of noise, a 2 s
dropout had turned the rate model's ``Λ`` from 0.36 into 224, which sent the default to differencing at 3.7 times
the model's error elsewhere in the log.

Models (:data:`MODELS`), each an EKF the default estimator can run: ``rate`` — the rate a random walk (white
angular acceleration, ``p = 1``; kinematic, J and τ not used); ``acceleration`` — the angular acceleration a
random walk (white jerk, ``p = 2``); ``dynamic`` — Euler's equations with J and τ and a white torque noise
(``p = 1``, the noise on ``J⁻¹τ``); ``dynamic+disturbance`` — the same with an unknown torque whose angular
acceleration is a random walk (``p = 2``). The torque between samples is held over each step or interpolated
(``linear_hold``); :func:`omegahat.identification.identify` lets the likelihood choose (H1).
:func:`steady_rate_error` is the rate error a model's steady-state filter expects, :func:`coupled_rate_error` the
one its EKF's own covariance gives (for Euler's equations, which couple the axes).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Literal, NamedTuple, TypeAlias, get_args

import numpy as np
from scipy.linalg import solve_discrete_are

from omegahat.baselines.mekf_kernel import run_log
from omegahat.conversion import read_only, torques_array
from omegahat.kernels.ekf import NOMINAL_SUBSTEP_ANGLE
from omegahat.observer.kalman import NYQUIST_RATE

__all__ = [
    "BURN_IN",
    "DYNAMIC",
    "GRID",
    "MODELS",
    "REFINE_STEPS",
    "RESTART_GAP",
    "Model",
    "Pass",
    "Sums",
    "coupled_rate_error",
    "filter_pass",
    "innovation_sums",
    "log_likelihood",
    "maximise",
    "noise_intensity",
    "rate_response",
    "steady_filter",
    "steady_rate_error",
]

Model: TypeAlias = Literal["rate", "acceleration", "dynamic", "dynamic+disturbance"]
MODELS: tuple[str, ...] = get_args(Model)
DYNAMIC = ("dynamic", "dynamic+disturbance")  #: the models of Euler's equations (J and τ used)
ORDER = {"rate": 1, "acceleration": 2, "dynamic": 1, "dynamic+disturbance": 2}  #: p of (L2)
GRID = tuple(10.0**p for p in range(-8, 5))  #: Λ candidates (decades) before the refinement (down to a constant rate)
REFINE_STEPS = 8  #: golden-section steps in log Λ around the best grid point
_GOLD = (math.sqrt(5.0) - 1.0) / 2.0
BURN_IN = 3  #: fixes left out of (L1): the diffuse prior's (the filter has no rate before the second)
RESTART_GAP = BURN_IN + 1.5  #: an interval above this many spacings (more than BURN_IN missing) restarts a pass
_QUIET = 1e-12  # the relative torque noise of the disturbance model's known dynamics (the disturbance carries it)


class Sums(NamedTuple):
    """``D``, ``N`` and ``d`` of (L3) for one model and tracking index, at ``σ = 1``."""

    logdet: float
    nis: float
    dof: float


def noise_intensity(model: str, tracking_index: float, sigma: float, h: float) -> float:
    """``q`` of (L2): the process noise's power spectral density for ``model`` at ``tracking_index``."""
    return (tracking_index * sigma) ** 2 / h ** (2 * ORDER[model] + 1)


class Pass(NamedTuple):
    """One pass of the EKF over a log: the rate ``omega (T, 3)`` after each sample, the rate block of its covariance
    ``P (T, 3, 3)`` (empty unless asked), and the innovations' :class:`Sums`."""

    omega: np.ndarray
    P: np.ndarray
    sums: Sums


def filter_pass(
    t: np.ndarray,
    data: np.ndarray,
    valid: np.ndarray,
    model: str,
    tracking_index: float,
    *,
    sigma: float = 1.0,
    h: float,
    J: np.ndarray | None = None,
    torque: np.ndarray | None = None,
    references: np.ndarray | None = None,
    linear_hold: bool = False,
    covariances: bool = False,
    max_rate: float = np.inf,
) -> Pass:
    """One pass of the EKF of ``model`` with measurement noise ``sigma`` and the process noise of (L2) at
    ``tracking_index``, over the log ``t (T,)``, ``data`` (rotation matrices ``(T, 3, 3)``, or unit directions
    ``(T, n, 3)`` with ``references (n, 3)``), ``valid (T,)`` the usable samples, ``torque (T, 3)`` or None (used by
    the dynamic models only), from a diffuse prior whose first :data:`BURN_IN` fixes are left out of the sums."""
    dynamic = model in DYNAMIC
    J = np.eye(3) if J is None or not dynamic else np.asarray(J, dtype=float)
    q_rate = noise_intensity(model, tracking_index, sigma, h)
    q = _QUIET * q_rate if model == "dynamic+disturbance" else q_rate
    if dynamic:  # the EKF's torque noise PSD q acts on ω̇ through J⁻¹ (K1): the same Λ on ω̇ for any J
        q = q * (float(np.trace(J)) / 3.0) ** 2
    q_a = q_rate if ORDER[model] == 2 else 0.0
    n_states = 9 if q_a > 0.0 else 6
    # a diffuse prior: the attitude from the first fix, the rate (and acceleration) unknown at the scale of what a few
    # samples reveal; its fixes are left out of (L1)
    s2 = sigma**2
    P0 = np.diag([s2] * 3 + [1e4 * s2 / h**2] * 3 + ([1e4 * s2 / h**4] * 3 if n_states == 9 else []))
    directions = references is not None
    T = t.size
    t, data = np.ascontiguousarray(t, dtype=float), np.ascontiguousarray(data, dtype=float)
    valid = np.ascontiguousarray(valid, dtype=np.bool_)
    taus = torques_array(None if torque is None or not dynamic else torque, T)
    refs = read_only(np.ascontiguousarray(references, dtype=float) if directions else np.zeros((0, 3)))
    J_, J_inv = read_only(np.ascontiguousarray(J)), read_only(np.ascontiguousarray(np.linalg.inv(J)))  # one compilation
    omega, P_rates = np.full((T, 3), np.nan), np.full((T if covariances else 0, 3, 3), np.nan)
    iv = np.flatnonzero(valid)
    long = np.diff(t[iv]) > RESTART_GAP * h if not dynamic else np.zeros(max(iv.size - 1, 0), bool)
    starts = [0, *iv[1:][long].tolist(), T]  # a long dropout restarts a kinematic model's pass
    done: list[np.ndarray] = []  # the sums of the stretches run so far
    while len(done) < len(starts) - 1:
        a, b = starts[len(done)], starts[len(done) + 1]
        sums = np.array([float(BURN_IN), 0.0, 0.0, 0.0])
        covs = P_rates[a:b] if covariances else P_rates
        omega[a:b], *_ = run_log(
            t[a:b], data[a:b], valid[a:b], taus[a:b], refs, directions, dynamic, J_, J_inv, q, s2, np.inf,
            NOMINAL_SUBSTEP_ANGLE, linear_hold, q_a, np.array([np.nan, *[0.0] * 8]), np.zeros((3, 3)), P0.copy(),
            np.zeros(3), np.zeros(3), P0, sums, covs, max_rate,
        )  # fmt: skip
        if not np.isfinite(sums[2]) and done:  # restarted, it followed the samples after the gap past half a turn
            del starts[len(done)]  # per step (a glitch a settled filter weighs as one): the gap is bridged instead
            done.pop()
            continue
        done.append(sums)
        if not np.isfinite(sums[2]):  # the rate passed half a turn per step (max_rate): no model of the log
            break
    total = np.sum(done, axis=0) if done else np.zeros(4)
    return Pass(omega, P_rates, Sums(float(total[1]), float(total[2]), float(total[3])))


def innovation_sums(
    t: np.ndarray,
    data: np.ndarray,
    valid: np.ndarray,
    model: str,
    tracking_index: float,
    *,
    h: float,
    J: np.ndarray | None = None,
    torque: np.ndarray | None = None,
    references: np.ndarray | None = None,
    linear_hold: bool = False,
) -> Sums:
    """``(D, N, d)`` of (L3): :func:`filter_pass` at ``σ = 1``; for a kinematic model the pass ends, its ``N``
    infinite, where the filter's rate passes half a turn per step (:data:`~omegahat.observer.kalman.NYQUIST_RATE`
    over ``h``: an alias of the rate, as a spike or a reset of the attitude source throws a fast filter onto)."""
    max_rate = np.inf if model in DYNAMIC else NYQUIST_RATE / h
    return filter_pass(
        t, data, valid, model, tracking_index, h=h, J=J, torque=torque, references=references,
        linear_hold=linear_hold, max_rate=max_rate,
    ).sums  # fmt: skip


def log_likelihood(sums: Sums, sigma: float | None = None) -> tuple[float, float]:
    """``(ℓ, σ)`` of (L3): at ``sigma`` if given, else at its maximum ``σ̂ = √(N/d)``."""
    if sums.dof <= 0 or not np.isfinite(sums.nis) or not np.isfinite(sums.logdet):
        return -np.inf, np.nan
    s2 = sums.nis / sums.dof if sigma is None else sigma**2
    if not s2 > 0.0:
        return -np.inf, 0.0
    ll = -0.5 * (sums.logdet + sums.dof * np.log(s2) + sums.nis / s2 + sums.dof * np.log(2.0 * np.pi))
    return float(ll), float(np.sqrt(s2))


def steady_filter(
    model: str, tracking_index: float, sigma: float, h: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """The steady-state filter of ``model``'s per-axis linear dynamics (a random-walk rate, or a random-walk
    acceleration; state ``[θ, ω(, α)]``) sampled every ``h`` with attitude noise ``sigma``: its transition ``F`` and
    the gain ``K`` of the discrete algebraic Riccati equation, with the filtered covariance ``P``; None where the
    equation has no solution."""
    p = ORDER[model]
    q = noise_intensity(model, tracking_index, sigma, h)
    if p == 1:
        F = np.array([[1.0, h], [0.0, 1.0]])
        Q = q * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
    else:
        F = np.array([[1.0, h, h**2 / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
        Q = q * np.array([[h**5 / 20, h**4 / 8, h**3 / 6], [h**4 / 8, h**3 / 3, h**2 / 2], [h**3 / 6, h**2 / 2, h]])
    H = np.zeros((1, p + 1))
    H[0, 0] = 1.0
    Rv = np.array([[sigma**2]])
    try:
        P_pred = solve_discrete_are(F.T, H.T, Q + 1e-30 * np.eye(p + 1), Rv)
    except (np.linalg.LinAlgError, ValueError):
        return None
    K = P_pred @ H.T / (H @ P_pred @ H.T + Rv)
    return F, K, P_pred - K @ H @ P_pred


def steady_rate_error(model: str, tracking_index: float, sigma: float, h: float) -> float:
    """``√(tr P_ωω)`` (rad/s) of :func:`steady_filter`: the filtered error covariance of the model's per-axis
    steady-state filter."""
    found = steady_filter(model, tracking_index, sigma, h)
    return float("nan") if found is None else float(np.sqrt(3.0 * max(found[2][1, 1], 0.0)))


def rate_response(model: str, tracking_index: float, sigma: float, h: float, freq: np.ndarray) -> np.ndarray:
    """``H_b (F,)``, complex: the response of :func:`steady_filter`'s rate to the differenced rates ``b_k =
    (θ_k − θ_{k−1})/h`` at the frequencies ``freq`` (cycles per step), ``ω̂ = H_b b`` ::

        x̂_k = (I − K C) F x̂_{k−1} + K θ_k   ⇒   H_b(z) = e_ωᵀ (I − (I − K C) F z⁻¹)⁻¹ K · h / (1 − z⁻¹)      (K1)

    (``C = e_θᵀ``, ``z = e^{2πif}``); at ``f = 0`` it is 1 (the model follows a constant rate without error). NaN
    where :func:`steady_filter` has no solution."""
    found = steady_filter(model, tracking_index, sigma, h)
    freq = np.asarray(freq, dtype=float)
    if found is None:
        return np.full(freq.shape, np.nan + 0j)
    F, K, _ = found
    n = F.shape[0]
    loop = (np.eye(n) - K @ np.eye(n)[:1]) @ F
    response = np.ones(freq.shape, dtype=complex)
    for i, f in enumerate(freq):
        if f > 0:
            z_inv = np.exp(-2j * np.pi * f)
            state = np.linalg.solve(np.eye(n) - loop * z_inv, K[:, 0])
            response[i] = state[1] * h / (1.0 - z_inv)
    return response


def coupled_rate_error(t: np.ndarray, data: np.ndarray, valid: np.ndarray, model: str, tracking_index: float,
                       sigma: float, **options: object) -> float:  # fmt: skip
    """``√(mean tr P_ωω)`` (rad/s) of the EKF of ``model`` over the second half of the log, one :func:`filter_pass`
    (``options`` as there) with its covariances. Euler's equations couple the axes (``J⁻¹([Jω]× − [ω]× J)`` in the
    error's dynamics, and about the intermediate axis they amplify it), which :func:`steady_rate_error`'s per-axis
    model leaves out; the filter's own covariance has them, at the log's own rates. The first half is left to the
    diffuse prior's transient, and the samples where the filter restarted (NaN) are left out; NaN if none is left."""
    P = filter_pass(t, data, valid, model, tracking_index, sigma=sigma, covariances=True, **options).P  # type: ignore[arg-type]
    spread = np.trace(P[P.shape[0] // 2 :], axis1=1, axis2=2)
    spread = spread[np.isfinite(spread)]
    return float(np.sqrt(np.mean(spread))) if spread.size else math.nan


def maximise(
    evaluate: Callable[[float], tuple[float, float]], grid: tuple[float, ...] = GRID
) -> tuple[float, float, float]:
    """``(Λ, ℓ, σ)`` maximising ``evaluate(Λ) -> (ℓ, σ)`` on ``grid`` then by golden section in log Λ."""
    values = [evaluate(lam) for lam in grid]
    i = int(np.argmax([v[0] for v in values]))
    if i == len(grid) - 1:  # the fast limit: nothing above to refine towards
        return grid[i], values[i][0], values[i][1]
    lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, len(grid) - 1)])
    best = (grid[i], values[i][0], values[i][1])
    a, b = hi - _GOLD * (hi - lo), lo + _GOLD * (hi - lo)
    fa, fb = evaluate(math.exp(a)), evaluate(math.exp(b))
    for _ in range(REFINE_STEPS):
        if fa[0] > fb[0]:
            hi, b, fb = b, a, fa
            a = hi - _GOLD * (hi - lo)
            fa = evaluate(math.exp(a))
        else:
            lo, a, fa = a, b, fb
            b = lo + _GOLD * (hi - lo)
            fb = evaluate(math.exp(b))
    for lam, f in ((math.exp(a), fa), (math.exp(b), fb)):
        if f[0] > best[1]:
            best = (lam, f[0], f[1])
    return best
