r"""Gains chosen from the log itself: the bandwidth that minimises the expected error for *this* log.

``omegahat estimate`` uses :func:`choose_gains` unless ``--bandwidth`` or ``--k/--l`` are given. From the
log's valid samples (attitudes, or body-frame directions turned into attitudes by Wahba's problem against the
references) it measures three things and predicts the mean-square error of the estimate over the log for every
candidate bandwidth ``f`` (Hz, gains ``tuning.sensor_gains(J, rate, σ, bandwidth_hz=f)``: every linearised
mode decays at least at ``ω_b = 2π f``):

**Sample rate** ``1/h``, ``h`` the median spacing.

**Attitude noise σ** (rad per axis, white). With ``φ_k = log(R_kᵀ R_{k+1})`` (the body-frame increment, ``≈ h ω
+ δ_{k+1} − δ_k`` for ``R_meas = R exp(δ×)``), the second difference ``d_k = φ_{k+2} − 2φ_{k+1} + φ_k`` is the
third difference of the noise plus ``h³ ω̈``: each axis has variance ``20 σ²``, so ``|d|²`` is ``20 σ² χ²₃``
and, robustly against glitches and motion, ::

    σ̂² = median |d_k|² / (20 · 2.366)          (2.366: median of χ² with 3 degrees of freedom)       (S)

over regularly spaced runs of valid samples.

**Unmodelled motion.** The estimator predicts with Euler's equations (``J``, ``τ``; ``J = I``, ``τ = 0`` when
unknown, i.e. a constant rate); what they do not predict it follows like a first-order tracker of bandwidth
``ω_b``. With ``ω̄_w(t)`` the mean rate over a window ``w`` (``log(R(t)ᵀ R(t+w))/w``) and the structure function
``D(Δ) = E|ω̄_w(t+Δ) − ω̄_w(t) − Δ f(ω̄, τ)|²`` (``f`` the Euler right-hand side), the tracking error is taken as ::

    lag²(ω_b) = D(Δ) / 2,   Δ = √2 / ω_b,   w = Δ / 2                                                  (D)

exact for a constant acceleration ``a`` (lag ``a/ω_b``) and within 20 % for a random-walk rate; the noise's share
of ``D`` (``12 σ²/w²``; ``18 σ²/w²`` when ``Δ = w``) is subtracted.

**Expected error** (mean square of ``|ω̂ − ω|`` over a log of duration T) ::

    E²(f) = Σ_axes noise_std(f)²  +  lag²(ω_b)  +  e₀² (1 − e^{−2 ω_b T}) / (2 ω_b T)                   (E)

with ``noise_std`` from ``tuning.predicted_noise_std`` (exact for white noise) and ``e₀`` the start-up error of
the initial rate: ``√6 σ / h`` for the streaming warm start (the rate from the first two samples, ``start="warm"``),
``|ω(0)|`` from zero (``start="zero"``), and for ``start="fit"`` (:func:`initial_rate`: a least-squares fit of the
rate over the first ``L = Δ`` seconds, which an offline tool holding the log can afford) its noise
``√(36 σ² / (n L²))`` (n samples in the window) and its bias ``a L / 2`` (``D(L)/4``). A warm start's ``e₀`` is
large at a high sample rate (0.25 rad/s at 100 Hz and 1 mrad) and, decaying at ``ω_b``, it dominates (E) unless
the bandwidth is high; the fit removes that dilemma, so the bandwidth is then set by noise against lag alone.
The bandwidth of least ``E`` on a logarithmic grid below Nyquist is chosen. Everything is measured on the samples
given (the CLI passes the first ``HEAD_SAMPLES`` of the log and the duration of the whole log).

:func:`select_gains` is what ``omegahat estimate`` and :func:`omegahat.estimate_frame` call: gains given or a
bandwidth given (each checked against the log's rate, with its expected error said), else :func:`choose_gains`.

:func:`convention_check` fits Euler's equations with the given J and τ under both rotation conventions and says
whether the other one fits markedly better (a log written inertial → body read as body → inertial).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.tuning import predicted_noise_std, sensor_gains
from omegahat.validation import as_directions, as_inertia

__all__ = [
    "HEAD_SAMPLES",
    "GainChoice",
    "LogMotion",
    "choose_gains",
    "choose_rate_noise",
    "convention_check",
    "gains_for_bandwidth",
    "initial_rate",
    "log_rotations",
    "measure_motion",
    "select_gains",
    "structure_table",
]

HEAD_SAMPLES = 1 << 15  # samples analysed at most (the CLI passes the head of a longer log)
SIGMA_FLOOR = 1e-9  # rad: below any real sensor (float32 quaternions carry ~6e-8); keeps (E) well posed
CHI2_3_MEDIAN = 2.3660
MAX_PAIRS = 20_000  # window pairs per structure-function evaluation (subsampled beyond)
MAX_WINDOW_ANGLE = 1.0  # rad: windows are kept short enough that the body turns less than this within one


def log_rotations(
    t: ArrayLike, data: ArrayLike, kind: str, references: ArrayLike | None = None
) -> tuple[np.ndarray, Rotation]:
    """``(times, Rotation)`` of the valid samples: quaternions ``(T, 4)`` scalar last, matrices ``(T, 3, 3)``
    (body → inertial), or directions ``(T, n, 3)`` solved for the attitude by Wahba's problem
    (:func:`omegahat.so3.wahba`) against the inertial ``references (n, 3)``. Samples with a non-finite entry are
    left out."""
    t = np.asarray(t, dtype=float)
    data = np.asarray(data, dtype=float)
    ok = np.all(np.isfinite(data.reshape(t.size, -1)), axis=1)
    t, data = t[ok], data[ok]
    if kind == "quaternion":
        norm = np.linalg.norm(data, axis=1)
        keep = norm > 0
        return t[keep], Rotation.from_quat(data[keep])
    if kind == "matrix":
        return t, Rotation.from_matrix(data)
    V = as_directions(references)  # type: ignore[arg-type]  # None: as_directions says (n, 3) is needed
    return t, Rotation.from_matrix(so3.wahba(data, V))


@dataclass(frozen=True)
class LogMotion:
    """What :func:`measure_motion` found: ``rate_hz``, ``sigma`` (rad), ``first_rate (3,)`` (rad/s, from the
    first increment), the times and rotations used, and the model (J, torque at those times)."""

    rate_hz: float
    sigma: float
    first_rate: np.ndarray
    t: np.ndarray
    rot: Rotation
    J: np.ndarray
    torque: np.ndarray | None
    quat: np.ndarray | None = None  # rot as unit quaternions (N, 4), scalar last
    max_window: int = 1 << 30  # samples: longest window over which the body turns less than MAX_WINDOW_ANGLE
    torque_integral: np.ndarray | None = None  # (N, 3): ∫τ dt from the first sample, τ held from each sample
    torque_integral2: np.ndarray | None = None  # (N, 3): ∫∫τ dt² (for means of ∫τ over windows)

    @property
    def h(self) -> float:
        return 1.0 / self.rate_hz


def _rel_rotvec(q: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``log(R_aᵀ R_b)`` (rotation vectors, body frame of a) for unit quaternions ``q (N, 4)`` scalar last."""
    qa, qb = q[a], q[b]
    va, wa, vb, wb = qa[:, :3], qa[:, 3:], qb[:, :3], qb[:, 3:]
    v = wa * vb - wb * va - so3.cross(va, vb)  # vector part of conj(qa) ⊗ qb
    w = (wa * wb + np.sum(va * vb, axis=1, keepdims=True))[:, 0]
    sgn = np.where(w < 0, -1.0, 1.0)
    s = np.linalg.norm(v, axis=1)
    aw = np.abs(w)
    angle = 2.0 * np.arctan2(s, aw)
    scale = np.where(s > 1e-12, angle / np.maximum(s, 1e-300), 2.0 / np.maximum(aw, 1e-300))
    return v * (scale * sgn)[:, None]


def _euler_rhs(J, J_inv, w, tau):
    """``f(ω) = J⁻¹((Jω) × ω + τ)`` row-wise."""
    out = so3.cross(w @ J.T, w)
    if tau is not None:
        out = out + tau
    return out @ J_inv.T


def measure_motion(
    t: ArrayLike, rot: Rotation, J: ArrayLike | None = None, torque: ArrayLike | None = None
) -> LogMotion:
    """Sample rate and noise (S) of a rotation sequence; ``torque (T, 3)`` aligned with ``t`` or None."""
    t = np.asarray(t, dtype=float)
    if t.size < 2:
        raise ValueError(f"at least 2 valid samples are needed to choose gains; got {t.size}")
    h_all = np.diff(t)
    h = float(np.median(h_all))
    quat = rot.as_quat()
    idx = np.arange(t.size - 1)
    phi = _rel_rotvec(quat, idx, idx + 1)
    sigma = SIGMA_FLOOR
    if phi.shape[0] >= 3:
        regular = np.abs(h_all / h - 1.0) < 0.05
        ok = regular[:-2] & regular[1:-1] & regular[2:]
        d = phi[2:] - 2.0 * phi[1:-1] + phi[:-2]
        if ok.any():
            sigma = max(SIGMA_FLOOR, float(np.sqrt(np.median(np.sum(d[ok] ** 2, axis=1)) / (20 * CHI2_3_MEDIAN))))
    J = np.eye(3) if J is None else as_inertia(J)
    fast = float(np.percentile(np.linalg.norm(phi, axis=1) / h_all, 99)) if phi.shape[0] else 0.0
    max_window = max(1, int(MAX_WINDOW_ANGLE / max(fast * h, 1e-300))) if fast > 0 else 1 << 30
    tint = tint2 = None
    if torque is not None:
        torque = np.asarray(torque, dtype=float)
        tint = np.concatenate([np.zeros((1, 3)), np.cumsum(torque[:-1] * h_all[:, None], axis=0)])
        # exact for τ held: ∫ over [t_j, t_j+1] of C(t) = C_j h + τ_j h²/2
        step = tint[:-1] * h_all[:, None] + 0.5 * torque[:-1] * h_all[:, None] ** 2
        tint2 = np.concatenate([np.zeros((1, 3)), np.cumsum(step, axis=0)])
    return LogMotion(1.0 / h, sigma, phi[0] / h_all[0], t, rot, J, torque, quat, max_window, tint, tint2)


def _structure(motion: LogMotion, m_delta: int, m_w: int) -> float | None:
    """``D(Δ)`` of (D) with Δ, w in samples, noise share removed; None when the windows turn too far."""
    N = motion.t.size
    n_pos = N - m_delta - m_w
    if n_pos < 8:
        return None
    k = np.arange(0, n_pos, max(1, n_pos // MAX_PAIRS))
    q, t = motion.quat, motion.t
    va, vb = _rel_rotvec(q, k, k + m_w), _rel_rotvec(q, k + m_delta, k + m_delta + m_w)  # type: ignore[arg-type]
    wa = va / (t[k + m_w] - t[k])[:, None]
    wb = vb / (t[k + m_delta + m_w] - t[k + m_delta])[:, None]
    span = (t[k + m_delta] - t[k])[:, None]
    J_inv = np.linalg.inv(motion.J)
    u = wb - wa - span * _euler_rhs(motion.J, J_inv, 0.5 * (wa + wb), None)
    if motion.torque_integral2 is not None:  # the torque's share: difference of the windows' means of ∫τ
        c = motion.torque_integral2
        lead = c[k + m_delta + m_w] - c[k + m_delta] - c[k + m_w] + c[k]
        u -= (lead / (m_w * motion.h)) @ J_inv.T
    w = m_w * motion.h
    noise = (18.0 if m_delta == m_w else 12.0) * motion.sigma**2 / w**2
    # Only what stands out of the noise counts: minus two standard errors of the noise's share, with one
    # independent pair per window length (overlapping windows share their noise).
    n_eff = max(1.0, n_pos / max(m_w, m_delta / 2))
    return max(0.0, float(np.mean(np.sum(u**2, axis=1))) - noise * (1.0 + 2.0 * np.sqrt(2.0 / (3.0 * n_eff))))


def structure_table(motion: LogMotion) -> tuple[np.ndarray, np.ndarray]:
    """``(Δ (s), D*(Δ))``: (D) on half-octave separations from one sample to a third of the log, made
    non-decreasing (``D*(Δ) = max_{Δ' ≤ Δ} D(Δ')``) so that a periodic motion, whose ``D`` vanishes at multiples
    of its period, still counts with its full swing."""
    N = motion.t.size
    seps = np.unique(np.round(np.geomspace(1, max(1, N // 3), max(2, int(2 * np.log2(max(N // 3, 2))) + 1))))
    out_d, out_D = [], []
    for m_delta in seps.astype(int):
        m_w = max(1, min(round(m_delta / 2), motion.max_window))
        D = _structure(motion, m_delta, m_w)
        if D is not None:
            out_d.append(m_delta * motion.h)
            out_D.append(D)
    if not out_d:
        return np.array([motion.h]), np.array([0.0])
    return np.array(out_d), np.maximum.accumulate(np.array(out_D))


def _lag_structure(table: tuple[np.ndarray, np.ndarray], delta: float) -> float:
    """``D*(Δ)`` from the table, interpolated in log Δ (constant beyond its ends)."""
    d, D = table
    return float(np.interp(np.log(delta), np.log(d), D))


@dataclass(frozen=True)
class GainChoice:
    """The chosen gains and why: ``bandwidth_hz``; the expected RMS error (rad/s) and its parts (E); the
    measured ``rate_hz`` and ``sigma``; every candidate ``(bandwidth_hz, expected RMS)``."""

    gains: ObserverGains
    bandwidth_hz: float
    expected: float
    noise: float
    lag: float
    startup: float
    rate_hz: float
    sigma: float
    candidates: tuple

    def explain(self) -> str:
        return (
            f"bandwidth {self.bandwidth_hz:.3g} Hz ({2 * np.pi * self.bandwidth_hz:.3g} rad/s), chosen from the log: "
            f"{self.rate_hz:.4g} Hz samples, attitude noise {self.sigma:.2g} rad; expected RMS error "
            f"{self.expected:.2g} rad/s (noise {self.noise:.2g}, lag {self.lag:.2g}, start-up {self.startup:.2g})"
        )


def gains_for_bandwidth(
    J: ArrayLike, rate_hz: float, bandwidth_hz: float, references: ArrayLike | None = None, sigma: float = SIGMA_FLOOR
) -> ObserverGains:
    """``tuning.sensor_gains`` at ``bandwidth_hz`` (Hz, below Nyquist ``rate_hz/2``, else ValueError)."""
    return sensor_gains(J, rate_hz, max(sigma, SIGMA_FLOOR), bandwidth_hz=bandwidth_hz, references=references)


STARTS = ("fit", "warm", "zero")


def fit_window(omega_b: float, rate_hz: float) -> float:
    """Seconds of log the ``fit`` start uses for a bandwidth ``omega_b`` (rad/s): ``Δ = √2/ω_b`` of (D)."""
    return max(np.sqrt(2.0) / omega_b, 2.0 / rate_hz)


def initial_rate(
    t: ArrayLike, rot: Rotation, window: float, J: ArrayLike | None = None, torque: ArrayLike | None = None
) -> np.ndarray:
    """Initial rate (rad/s, body axes) from a least-squares fit of the attitude over ``[t₀, t₀ + window]``.

    The slope of a line fitted to the attitude relative to the first sample, written on the increments ``φ_j``
    (no unwrapping, any turn) is the mean rate over the window, which belongs to its centre; half a window of
    Euler's equations (``f`` of (D), with ``J`` and the mean ``torque`` of the window) moves it to ``t₀``::

        ω_c = Σ c_j φ_j / Σ c_j h_j,  c_j = Σ_{k>j} (t_k − t̄);   ω̂₀ = ω_c − (L/2) f(ω_c, τ̄)             (F)

    (the ordinary least-squares slope of the cumulated angle, rearranged onto the increments; for even spacing
    ``c_j`` is the parabola ``(j+1)(n−1−j) h/2``); exact for a constant rate. Needs at least two samples in the
    window (with two it is the first increment's rate)."""
    t = np.asarray(t, dtype=float)
    n = max(2, int(np.searchsorted(t, t[0] + window, side="right")))
    idx = np.arange(n - 1)
    phi = _rel_rotvec(rot[:n].as_quat(), idx, idx + 1)
    h = np.diff(t[:n])
    L = t[n - 1] - t[0]
    dev = t[:n] - np.mean(t[:n])
    w = np.cumsum(dev[::-1])[::-1][1:]  # c_j = Σ_{k>j} (t_k − t̄): the line fit's weight on increment j
    w_c = (w @ phi) / (w @ h)
    if J is None and torque is None:
        return w_c
    J = np.eye(3) if J is None else as_inertia(J)
    tau = None if torque is None else np.mean(np.asarray(torque, dtype=float)[: n - 1], axis=0)
    return w_c - 0.5 * L * _euler_rhs(J, np.linalg.inv(J), w_c[None, :], None if tau is None else tau[None, :])[0]


def expected_error(
    motion: LogMotion,
    gains: ObserverGains,
    omega_b: float,
    duration: float,
    start: str = "fit",
    references: ArrayLike | None = None,
    table: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[float, float, float]:
    """``(noise, lag, start-up)`` RMS parts of (E) for ``gains`` whose slowest mode decays at ``omega_b``
    (``table``: :func:`structure_table` of ``motion``, computed if not given)."""
    noise = float(np.linalg.norm(predicted_noise_std(motion.J, gains, motion.rate_hz, motion.sigma, references)))
    table = structure_table(motion) if table is None else table
    D = _lag_structure(table, np.sqrt(2.0) / omega_b)
    lag = float(np.sqrt(0.5 * D))
    if start == "warm":
        e0 = np.sqrt(6.0) * motion.sigma * motion.rate_hz
    elif start == "zero":
        e0 = float(np.linalg.norm(motion.first_rate))
    else:
        L = min(fit_window(omega_b, motion.rate_hz), float(motion.t[-1] - motion.t[0]))
        n = max(2.0, L * motion.rate_hz)
        e0 = float(np.sqrt(36.0 * motion.sigma**2 / (n * max(L, motion.h) ** 2) + 0.25 * _lag_structure(table, L)))
    x = 2.0 * omega_b * max(duration, motion.h)
    startup = float(e0 * np.sqrt(-np.expm1(-x) / x))
    return noise, lag, startup


def choose_gains(
    motion: LogMotion,
    duration: float | None = None,
    start: str = "fit",
    references: ArrayLike | None = None,
    n_grid: int = 40,
) -> GainChoice:
    """The bandwidth of least expected error (E) on a log grid up to 0.45 × the rate.

    The grid starts at ``1/(1000 T)`` Hz when ``motion`` covers the whole log (its slow motion has then been
    measured up to a third of the log: a bandwidth that slow just keeps the initial fit, right when nothing was
    found to follow), else at ``1/(2π T_a)`` with ``T_a`` the span analysed (no trust in constancy beyond it)."""
    T = float(motion.t[-1] - motion.t[0]) if duration is None else float(duration)
    f_hi = 0.45 * motion.rate_hz
    span = float(motion.t[-1] - motion.t[0])
    f_lo = 1.0 / (1000.0 * max(T, motion.h)) if T <= span * (1 + 1e-9) else 1.0 / (2 * np.pi * max(span, motion.h))
    f_lo = min(f_lo, f_hi / 1e3)
    best, rows, table = None, [], structure_table(motion)
    for f in np.geomspace(f_lo, f_hi, n_grid):
        g = gains_for_bandwidth(motion.J, motion.rate_hz, f, references, motion.sigma)
        parts = expected_error(motion, g, 2 * np.pi * f, T, start, references, table)
        total = float(np.sqrt(sum(p**2 for p in parts)))
        rows.append((float(f), total))
        if best is None or total < best[1]:
            best = (float(f), total, g, parts)
    f, total, g, (noise, lag, startup) = best  # type: ignore[misc]  # None if n_grid < 1 (fails here)
    return GainChoice(g, f, total, noise, lag, startup, motion.rate_hz, motion.sigma, tuple(rows))


def convention_check(motion: LogMotion) -> tuple[float, float]:
    """RMS residual of Euler's equations ``J ω̇ − (Jω) × ω − τ`` (N·m) with the attitudes as given and inverted
    (the other rotation convention), at the shortest time scale (doubling from one sample) where the noise's
    share (``√18 σ J_M / Δ²``) is below a fifth of the larger residual; ``τ`` is averaged over the same span."""
    N = motion.t.size
    J_M = float(np.linalg.eigvalsh(motion.J)[-1])
    q_given: np.ndarray = motion.quat  # type: ignore[assignment]  # measure_motion sets it (None fails here)
    q_other = q_given * np.array([-1.0, -1.0, -1.0, 1.0])
    m, last = 1, (np.inf, np.inf)
    while 2 * m + 1 < N:
        k = np.arange(0, N - 2 * m, max(1, (N - 2 * m) // MAX_PAIRS))
        span = (0.5 * (motion.t[k + 2 * m] - motion.t[k]))[:, None]
        if motion.torque_integral is None:
            tau = 0.0
        else:
            c = motion.torque_integral
            tau = (c[k + m + m // 2] - c[k + m // 2]) / span
        res = []
        for q in (q_given, q_other):
            a = _rel_rotvec(q, k, k + m) / (motion.t[k + m] - motion.t[k])[:, None]
            b = _rel_rotvec(q, k + m, k + 2 * m) / (motion.t[k + 2 * m] - motion.t[k + m])[:, None]
            w = 0.5 * (a + b)
            r = (b - a) / span @ motion.J.T - so3.cross(w @ motion.J.T, w) - tau
            res.append(float(np.sqrt(np.mean(np.sum(r**2, axis=1)))))
        last = (res[0], res[1])
        noise = float(np.sqrt(18.0) * motion.sigma * J_M / (m * motion.h) ** 2)
        if noise < 0.2 * max(res):
            return last
        m *= 2
    return last


def select_gains(
    motion: LogMotion,
    duration: float,
    start: str = "fit",
    references: ArrayLike | None = None,
    *,
    gains: ObserverGains | None = None,
    bandwidth_hz: float | None = None,
    flag: str = "--bandwidth",
) -> tuple[ObserverGains, str, float]:
    """``(gains, text, ω_b)``: the gains to run with, a line saying what they are and why, and the bandwidth
    (rad/s) that sets the fit start's window (:func:`fit_window`).

    ``gains`` given: used as they are; the text states their slowest mode (of the linearised error map
    ``J⁻¹ M``) and predicted noise, and warns when they act faster than the Nyquist frequency (then the estimate is
    close to raw differencing). ``bandwidth_hz`` given (``flag`` names it in messages): refused unless positive
    and below Nyquist; the text states its expected error (E). Neither: :func:`choose_gains`."""
    refs = np.eye(3) if references is None else as_directions(references)
    rate = motion.rate_hz
    if gains is not None and bandwidth_hz is not None:
        raise ValueError(f"give either {flag} or the gains, not both")
    if gains is not None:
        n = refs.shape[0]
        if gains.k.shape != (n,):
            raise ValueError(f"the gains have {gains.k.size} k_i, but the input has {n} directions")
        M = sum(gains.k[i] * (np.eye(3) - np.outer(refs[i], refs[i])) for i in range(n))
        lam = float(np.linalg.eigvals(np.linalg.solve(motion.J, M)).real.min())  # slowest continuous mode, rad/s
        omega_b = np.log1p(lam / rate) * rate  # what the implicit correction makes of it per sample
        noise = float(np.linalg.norm(predicted_noise_std(motion.J, gains, rate, motion.sigma, refs)))
        text = f"k, l given: slowest mode {lam / (2 * np.pi):.3g} Hz, predicted noise {noise:.2g} rad/s"
        if lam / (2 * np.pi) >= rate / 2:
            text += (
                f"\nwarning: these gains act faster than the Nyquist frequency {rate / 2:.4g} Hz of this log: the "
                "estimate is close to raw differencing of the attitude; the automatic gains would filter it"
            )
        return gains, text, omega_b
    if bandwidth_hz is not None:
        b = bandwidth_hz
        if not (np.isfinite(b) and b > 0):
            raise ValueError(f"{flag} must be a positive number of Hz; got {b!r}")
        if b >= rate / 2:
            raise ValueError(
                f"{flag} {b:g} Hz is not below the Nyquist frequency {rate / 2:.4g} Hz of this log ({rate:.4g} Hz "
                f"samples); choose a lower one, or leave {flag} out for gains chosen from the log"
            )
        g = gains_for_bandwidth(motion.J, rate, b, refs, motion.sigma)
        noise, lag, st = expected_error(motion, g, 2 * np.pi * b, duration, start, refs)
        text = (
            f"bandwidth {b:g} Hz given; expected RMS error {np.sqrt(noise**2 + lag**2 + st**2):.2g} rad/s "
            f"(noise {noise:.2g}, lag {lag:.2g}, start-up {st:.2g})"
        )
        return g, text, 2 * np.pi * b
    choice = choose_gains(motion, duration, start, refs)
    return choice.gains, "gains: " + choice.explain(), 2 * np.pi * choice.bandwidth_hz


RATE_NOISE_GRID = tuple(10.0**p for p in range(-8, 2))  #: σ_a candidates (rad/s^1.5) for :func:`choose_rate_noise`


def choose_rate_noise(motion: LogMotion) -> tuple[float, str]:
    """The default estimator's process noise σ_a for this log, and a line saying why.

    The EKF's noise model fits the data when its normalised innovation squared averages 1 per degree of freedom
    (the innovations are as large as the filter predicts). :class:`omegahat.observer.kalman.SupervisedKalmanEstimator`
    runs over the analysed samples (attitudes, the model J and torque) for every σ_a of :data:`RATE_NOISE_GRID`
    with the measured attitude noise; the σ_a whose mean ν/m is closest to 1 (in ratio) is chosen. Too small a
    σ_a makes the filter overconfident (ν/m ≫ 1), too large one underconfident (ν/m < 1)."""
    R = motion.rot.as_matrix()
    tau = motion.torque
    sigma = max(motion.sigma, 1e-6)
    best: tuple[float, float, float] | None = None
    for sigma_a in RATE_NOISE_GRID:
        est = SupervisedKalmanEstimator(motion.J, rate_hz=motion.rate_hz, measurement_noise=sigma, rate_noise=sigma_a)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            est.run(motion.t, R, tau)
        nis = est.mean_nis
        if not np.isfinite(nis):
            continue
        miss = abs(np.log(nis))
        if best is None or miss < best[0]:
            best = (miss, sigma_a, nis)
    if best is None:  # too few samples to judge: the middle of the grid
        return 1e-3, "rate noise 0.001 rad/s^1.5 (too few samples to fit it)"
    return best[1], (
        f"rate noise {best[1]:.3g} rad/s^1.5, chosen from the log: the EKF's innovations average "
        f"{best[2]:.2f} times their predicted size (1 is a fit), attitude noise {sigma:.2g} rad"
    )
