r"""The one-direction observer's compiled step: samples through the observer and the excitation monitor in one call.

The equations are those of :mod:`omegahat.observer.single_direction` ((D1)–(D8), the monitor; theory in
``docs/theory/single_direction.md``), whose NumPy functions ``run_single_direction`` and ``excitation`` are the
oracle: ``tests/test_single_direction_step.py`` checks :func:`advance` against them to 1e-10 (both methods, gaps,
torques, chunked calls), and the monitor's flags for equality. The realisation is the same: between two samples,
classical RK4 in equal substeps (``rate · substep ≤ substep_rate``) on the state ``(x₁, x₂, b)``, with b moved along
the great circle (D8) toward the next sample, or along the estimate when that sample is missing.

**Built on the shared kernels.** The right-hand side is written with the observer's terms
(:mod:`omegahat.kernels.observer`) and Euler's equations (:mod:`omegahat.kernels.dynamics`). For the Sarras-type
observer, in the coordinates ``(ξ, r̂)`` of (D3)–(D4), with ``e = r̂ − b`` and w the rate that moves b (``ḃ = b × w``)::

    ω̂  = ξ + s J⁻¹ k b × r̂                      (D2; s = +1, or −1: the paper's misprint)              (C1)
    r̂̇ = filter_rate(b × ω̂, e, ω̂, l) = b × ω̂ + e × ω̂ − l e = r̂ × ω̂ − l (r̂ − b)              (D4)   (C2)
    ξ̇  = J⁻¹((J ω̂) × ω̂ + τ + k r̂ × m) − J⁻¹ k (ḃ × r̂ + b × r̂̇),    m = b × (ω̂ − w)                   (C3)

(C3) is (D3) written as (O1) — Euler's equations plus the innovation ``k r̂ × m`` for the mismatch m (O3) — minus
the rate of the output map's term ``J⁻¹ k b × r̂``; by Jacobi's identity the difference depends neither on w nor on
the sign s (it is (D3) for whatever ω̂ the output map gives). The gradient observer (D6): ``ω̂̇`` by Euler's equations
with the torque ``τ + k b × b̂``, ``b̂̇`` by (C2).

**Excitation monitor.** ``S``, ``W`` of the module docstring of :mod:`omegahat.observer.single_direction`, and per
sample ``λ_min(S/W)`` with its eigenvector by :func:`smallest_eigenpair` (closed form, no LAPACK call).

**Named flat arrays**, as the sampled estimator's (:mod:`omegahat.observer.sampled`): the parameters
(:data:`PARAMS`, :func:`pack_params`) and the state (:data:`STATE`, :func:`initial_state`; stage
:data:`UNINITIALISED` until the first valid sample, then :data:`RUNNING`). One compiled entry point,
``_advance``, with one specialisation: :func:`advance` hands it C-contiguous writable arrays (float64, the flags
bool) that it allocates or converts, so no caller's array type makes a second one (its first call compiles for about
3 s of CPU: ``benchmarks/RESULTS.md``).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike

from omegahat.kernels.checks import OK, ZERO_DIRECTION, check_time, check_torque
from omegahat.kernels.dynamics import euler_rate
from omegahat.kernels.observer import filter_rate, innovation
from omegahat.kernels.vec3 import cross, dot, matvec, norm
from omegahat.measurements import rejection_error

__all__ = [
    "PARAMS",
    "RUNNING",
    "STATE",
    "UNINITIALISED",
    "Advanced",
    "ParamLayout",
    "StateLayout",
    "advance",
    "initial_state",
    "pack_params",
    "smallest_eigenpair",
]


class ParamLayout(NamedTuple):
    """Offsets in the flat parameters: J (9, row-major), J⁻¹ (9), gains k and l, the smallest principal moment
    ``J_min``, the output map's sign, the method (0 Sarras-type, 1 gradient), ``substep_rate``, the monitor's
    window (s) and threshold, ``ω̂₀`` (3), the initial filtered direction ``r̂₀`` (3) and whether it is given."""

    J: int
    Jinv: int
    k: int
    l: int
    J_min: int
    sign: int
    gradient: int
    substep_rate: int
    window: int
    threshold: int
    omega_hat0: int
    r_hat0: int
    has_r_hat0: int


PARAMS = ParamLayout(
    J=0, Jinv=9, k=18, l=19, J_min=20, sign=21, gradient=22, substep_rate=23, window=24, threshold=25,
    omega_hat0=26, r_hat0=29, has_r_hat0=32,
)  # fmt: skip


class StateLayout(NamedTuple):
    """Offsets in the flat state: stage, time of the last sample (NaN before any), the direction b at that time
    (3), ``x₁`` (ξ or ω̂, 3), ``x₂`` (r̂ or b̂, 3), the torque held since the last valid sample (3); the monitor's
    ``S`` (6: entries 00, 11, 22, 01, 02, 12), ``W``, the time of the last valid sample and of the first (NaN:
    none yet)."""

    stage: int
    t: int
    b: int
    x1: int
    x2: int
    tau: int
    S: int
    W: int
    t_valid: int
    t_first: int


STATE = StateLayout(stage=0, t=1, b=2, x1=5, x2=8, tau=11, S=14, W=20, t_valid=21, t_first=22)
UNINITIALISED = 0.0  #: stage before the first valid sample
RUNNING = 1.0  #: stage from the first valid sample on


def pack_params(
    J: np.ndarray, *, gradient: bool, k: float, l: float, sign: float, substep_rate: float, window_s: float,
    threshold: float, omega_hat0: np.ndarray | None, r_hat0: np.ndarray | None,
) -> np.ndarray:  # fmt: skip
    """The flat parameters (:data:`PARAMS`) of an observer with inertia ``J (3, 3)`` (checked by the caller)."""
    J = np.asarray(J, dtype=float)
    return np.concatenate([
        J.ravel(), np.linalg.inv(J).ravel(),
        [k, l, float(np.linalg.eigvalsh(J)[0]), sign, float(gradient), substep_rate, window_s, threshold],
        np.zeros(3) if omega_hat0 is None else np.asarray(omega_hat0, dtype=float),
        np.zeros(3) if r_hat0 is None else np.asarray(r_hat0, dtype=float),
        [float(r_hat0 is not None)],
    ])  # fmt: skip


def initial_state() -> np.ndarray:
    """The flat state (:data:`STATE`) before any sample."""
    x = np.zeros(STATE.t_first + 1)
    x[STATE.stage] = UNINITIALISED
    x[[STATE.t, STATE.t_valid, STATE.t_first]] = np.nan
    return x


class Advanced(NamedTuple):
    """What :func:`advance` returns: ω̂ ``(T, 3)`` (NaN before the first valid sample), ``λ_min`` of the windowed
    Gramian ``(T,)`` (NaN before it) and its eigenvector ``(T, 3)`` (the weak axis, its largest component
    positive), the samples flagged unobservable ``(T,)`` and the state after the last sample."""

    omega: np.ndarray
    excitation: np.ndarray
    weak_axis: np.ndarray
    unobservable: np.ndarray
    state: np.ndarray


def _c64(a: ArrayLike) -> np.ndarray:
    """A C-contiguous writable float64 array (a read-only one would be another compiled specialisation)."""
    out = np.ascontiguousarray(a, dtype=float)
    return out if out.flags.writeable else out.copy()


def advance(params: np.ndarray, state: np.ndarray, t: ArrayLike, b: ArrayLike, torques: ArrayLike | None) -> Advanced:
    """The samples ``t (T,)``, ``b (T, 3)`` (any length; NaN or inf rows missing), ``torques (T, 3)`` or None (zero)
    through the observer and the monitor, from ``state`` (left unchanged: the new state is returned).

    Raises :class:`omegahat.measurements.MeasurementError` (the one input path's message) at the first sample whose
    time is not finite or not after the previous one, whose torque is not finite, or whose direction is zero.
    """
    times, dirs = _c64(t), _c64(b)
    if times.ndim != 1 or dirs.shape != (times.size, 3):
        raise ValueError(f"b must have shape (T, 3) with T = len(t) = {times.size}; got shape {dirs.shape}")
    taus = np.zeros((0, 3)) if torques is None else _c64(torques)
    if torques is not None and taus.shape != (times.size, 3):
        raise ValueError(f"torques must have shape ({times.size}, 3); got shape {taus.shape}")
    x = _c64(state).copy()
    T = times.size  # the outputs are allocated here: allocation inside compiled code would compile Numba's own
    omega, lam, axis, flags = np.empty((T, 3)), np.empty(T), np.empty((T, 3)), np.empty(T, dtype=bool)
    bad, status, info = _advance(_c64(params), x, times, dirs, taus, omega, lam, axis, flags)
    if bad >= 0:
        raise rejection_error(status, info, f"sample {bad}", float(times[bad]))
    return Advanced(omega, lam, axis, flags, x)


@numba.njit(cache=True, error_model="numpy")
def _null_vector(m00, m11, m22, m01, m02, m12):
    """A unit vector spanning the kernel of the symmetric rank-2 matrix M: the largest cross product of two of its
    rows ((1, 0, 0) if every one vanishes)."""
    best = -1.0
    v0 = v1 = v2 = 0.0
    for i in range(3):
        if i == 0:
            c0, c1, c2 = cross(m00, m01, m02, m01, m11, m12)
        elif i == 1:
            c0, c1, c2 = cross(m00, m01, m02, m02, m12, m22)
        else:
            c0, c1, c2 = cross(m01, m11, m12, m02, m12, m22)
        q = dot(c0, c1, c2, c0, c1, c2)
        if q > best:
            best, v0, v1, v2 = q, c0, c1, c2
    if not best > 0.0:
        return 1.0, 0.0, 0.0
    s = math.sqrt(best)
    return v0 / s, v1 / s, v2 / s


@numba.njit(cache=True, error_model="numpy")
def smallest_eigenpair(a00, a11, a22, a01, a02, a12):
    """``(λ_min, v0, v1, v2)`` of the symmetric 3×3 matrix A (entries 00, 11, 22, 01, 02, 12): the smallest
    eigenvalue, to rounding of ``|A|`` at any multiplicity, and a unit eigenvector, its largest component positive.

    The eigenvalues are ``q + 2p cos(φ + 2πi/3)`` (q the mean of the diagonal, ``p² = |A − qI|²_F / 6``,
    ``cos 3φ = det((A − qI)/p)/2``). The one of them separated from the other two (the smallest when
    ``cos 3φ < 0``, else the largest) is accurate by that formula, and its eigenvector is the kernel of
    ``A − λI``; when it is the largest, the smallest follows from the 2×2 problem in the plane orthogonal to it.
    """
    q = (a00 + a11 + a22) / 3.0
    d0, d1, d2 = a00 - q, a11 - q, a22 - q
    p2 = (d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6.0
    if not p2 > 0.0:  # A = qI: every axis is an eigenvector
        return q, 1.0, 0.0, 0.0
    p = math.sqrt(p2)
    b00, b11, b22, b01, b02, b12 = d0 / p, d1 / p, d2 / p, a01 / p, a02 / p, a12 / p
    r = 0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02))
    phi = math.acos(1.0 if r > 1.0 else -1.0 if r < -1.0 else r) / 3.0  # rounding may leave [−1, 1]
    if r < 0.0:
        lam = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
        v0, v1, v2 = _null_vector(a00 - lam, a11 - lam, a22 - lam, a01, a02, a12)
    else:
        top = q + 2.0 * p * math.cos(phi)
        n0, n1, n2 = _null_vector(a00 - top, a11 - top, a22 - top, a01, a02, a12)
        if abs(n0) > abs(n1):  # u ⟂ n, then w = n × u: an orthonormal basis of the plane
            s = math.sqrt(n0 * n0 + n2 * n2)
            u0, u1, u2 = -n2 / s, 0.0, n0 / s
        else:
            s = math.sqrt(n1 * n1 + n2 * n2)
            u0, u1, u2 = 0.0, n2 / s, -n1 / s
        w0, w1, w2 = cross(n0, n1, n2, u0, u1, u2)
        Au0, Au1, Au2 = a00 * u0 + a01 * u1 + a02 * u2, a01 * u0 + a11 * u1 + a12 * u2, a02 * u0 + a12 * u1 + a22 * u2
        Aw0, Aw1, Aw2 = a00 * w0 + a01 * w1 + a02 * w2, a01 * w0 + a11 * w1 + a12 * w2, a02 * w0 + a12 * w1 + a22 * w2
        a, c, d = dot(u0, u1, u2, Au0, Au1, Au2), dot(u0, u1, u2, Aw0, Aw1, Aw2), dot(w0, w1, w2, Aw0, Aw1, Aw2)
        lam = 0.5 * (a + d) - math.hypot(0.5 * (a - d), c)
        y0, y1 = c, lam - a  # (y0, y1): the 2×2 eigenvector, from whichever row of [[a, c], [c, d]] − λI is larger
        if abs(lam - d) + abs(c) > abs(c) + abs(lam - a):
            y0, y1 = lam - d, c
        if y0 == 0.0 and y1 == 0.0:
            y0 = 1.0
        v0, v1, v2 = y0 * u0 + y1 * w0, y0 * u1 + y1 * w1, y0 * u2 + y1 * w2
        s = norm(v0, v1, v2)
        v0, v1, v2 = v0 / s, v1 / s, v2 / s
    big = v0  # the sign: the largest component positive (the first of equal ones)
    if abs(v1) > abs(big):
        big = v1
    if abs(v2) > abs(big):
        big = v2
    if big < 0.0:
        return lam, -v0, -v1, -v2
    return lam, v0, v1, v2


@numba.njit(cache=True, error_model="numpy")
def _estimate(Jinv, k, sign, gradient, y):
    """ω̂ of the state ``y = (x₁, x₂, b)`` (9 floats): (C1), or x₁ itself for the gradient observer."""
    if gradient:
        return y[0], y[1], y[2]
    sk = sign * k
    c0, c1, c2 = cross(y[6], y[7], y[8], y[3], y[4], y[5])
    g0, g1, g2 = matvec(Jinv, sk * c0, sk * c1, sk * c2)
    return y[0] + g0, y[1] + g1, y[2] + g2


@numba.njit(cache=True, error_model="numpy")
def _rates(J, Jinv, k, l, sign, gradient, y, w_meas, use_meas, tau):
    """``(ẋ₁, ẋ₂, ḃ)`` (9 floats) at ``y``: (C1)–(C3) or (D6), b moving at ``w_meas`` or, if not ``use_meas``, ω̂."""
    h0, h1, h2 = _estimate(Jinv, k, sign, gradient, y)
    x0, x1, x2, b0, b1, b2 = y[3], y[4], y[5], y[6], y[7], y[8]
    w0, w1, w2 = w_meas if use_meas else (h0, h1, h2)
    db0, db1, db2 = cross(b0, b1, b2, w0, w1, w2)
    c0, c1, c2 = cross(b0, b1, b2, h0, h1, h2)
    r0, r1, r2 = filter_rate(c0, c1, c2, x0 - b0, x1 - b1, x2 - b2, h0, h1, h2, l)  # (C2)
    if gradient:
        g0, g1, g2 = cross(b0, b1, b2, x0, x1, x2)
        f0, f1, f2 = euler_rate(J, Jinv, h0, h1, h2, tau[0] + k * g0, tau[1] + k * g1, tau[2] + k * g2)
        return f0, f1, f2, r0, r1, r2, db0, db1, db2
    m0, m1, m2 = cross(b0, b1, b2, h0 - w0, h1 - w1, h2 - w2)  # (O3)
    i0, i1, i2, _, _, _ = innovation(k, x0, x1, x2, m0, m1, m2)
    f0, f1, f2 = euler_rate(J, Jinv, h0, h1, h2, tau[0] + i0, tau[1] + i1, tau[2] + i2)  # (O1)
    p0, p1, p2 = cross(db0, db1, db2, x0, x1, x2)
    q0, q1, q2 = cross(b0, b1, b2, r0, r1, r2)
    e0, e1, e2 = matvec(Jinv, k * (p0 + q0), k * (p1 + q1), k * (p2 + q2))  # the output map's term's rate
    return f0 - e0, f1 - e1, f2 - e2, r0, r1, r2, db0, db1, db2


@numba.njit(cache=True, error_model="numpy")
def _axpy(y, a, d):
    """``y + a d`` for 9-tuples."""
    return (
        y[0] + a * d[0], y[1] + a * d[1], y[2] + a * d[2], y[3] + a * d[3], y[4] + a * d[4], y[5] + a * d[5],
        y[6] + a * d[6], y[7] + a * d[7], y[8] + a * d[8],
    )  # fmt: skip


@numba.njit(cache=True, error_model="numpy")
def _interval(p, J, Jinv, y, h, valid, u, tau):
    """The state ``y`` carried over an interval h to the next sample (unit direction ``u`` if ``valid``): RK4
    substeps with b on the great circle (D8) toward u, or along ω̂ when the sample is missing. Returns the new y."""
    k, l, sign, gradient = p[PARAMS.k], p[PARAMS.l], p[PARAMS.sign], p[PARAMS.gradient] != 0.0
    b0, b1, b2 = y[6], y[7], y[8]
    n0, n1, n2 = u if valid else (b0, b1, b2)
    c0, c1, c2 = cross(b0, b1, b2, n0, n1, n2)
    s = norm(c0, c1, c2)
    theta = math.atan2(s, dot(b0, b1, b2, n0, n1, n2))
    scale = theta / s if s > 1e-12 else 1.0  # for s → 0 the axis is undefined but θ/s → 1
    w_meas = (-scale * c0 / h, -scale * c1 / h, -scale * c2 / h)  # (D8)
    e0, e1, e2 = _estimate(Jinv, k, sign, gradient, y)
    rate = l  # the largest of l, k/J_min and the turning rates (written out: Numba's max compiles a function)
    for r in (k / p[PARAMS.J_min], norm(e0, e1, e2), norm(w_meas[0], w_meas[1], w_meas[2])):
        if r > rate:
            rate = r
    n_sub = math.ceil(h * rate / p[PARAMS.substep_rate]) if math.isfinite(rate) else 1
    n_sub = n_sub if n_sub > 1 else 1
    dt = h / n_sub
    for _ in range(n_sub):  # classical RK4: stages at 0, h/2, h/2, h weighted 1, 2, 2, 1
        stage = y
        total = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        for i in range(4):
            a = _rates(J, Jinv, k, l, sign, gradient, stage, w_meas, valid, tau)
            total = _axpy(total, 1.0 if i == 0 or i == 3 else 2.0, a)
            stage = _axpy(y, 0.5 * dt if i < 2 else dt, a)
        y = _axpy(y, dt / 6.0, total)
    if valid:  # a measured sample replaces the moved direction (they agree to RK4 accuracy)
        return y[0], y[1], y[2], y[3], y[4], y[5], n0, n1, n2
    m = norm(y[6], y[7], y[8])  # a predicted one is renormalised
    return y[0], y[1], y[2], y[3], y[4], y[5], y[6] / m, y[7] / m, y[8] / m


# without the GIL: the command reads the next chunk and writes the last in other threads meanwhile (test_gil.py)
@numba.njit(cache=True, error_model="numpy", nogil=True)
def _advance(p, x, t, b, tau, omega, lam, axis, flags):
    """:func:`advance` in place on the state ``x`` and the outputs ``ω̂ (T, 3)``, ``λ_min (T,)``, the weak axis
    ``(T, 3)`` and the flags ``(T,)``; returns ``(first rejected sample or −1, its status, info)``."""
    T = t.size
    oj, oi = PARAMS.J, PARAMS.Jinv  # the 9-tuples of vec3.mat3, read here (one function fewer to compile)
    J = (p[oj], p[oj + 1], p[oj + 2], p[oj + 3], p[oj + 4], p[oj + 5], p[oj + 6], p[oj + 7], p[oj + 8])
    Jinv = (p[oi], p[oi + 1], p[oi + 2], p[oi + 3], p[oi + 4], p[oi + 5], p[oi + 6], p[oi + 7], p[oi + 8])
    k, sign, gradient = p[PARAMS.k], p[PARAMS.sign], p[PARAMS.gradient] != 0.0
    window, threshold = p[PARAMS.window], p[PARAMS.threshold]
    given = tau.shape[0] > 0
    for j in range(T):
        status, info = check_time(t[j], x[STATE.t])
        if status != OK:
            return j, status, info
        tq = (0.0, 0.0, 0.0)
        if given:
            status, info = check_torque(tau[j])
            if status != OK:
                return j, status, info
            tq = (tau[j, 0], tau[j, 1], tau[j, 2])
        valid = np.isfinite(b[j, 0]) and np.isfinite(b[j, 1]) and np.isfinite(b[j, 2])
        u = (0.0, 0.0, 0.0)
        if valid:
            length = norm(b[j, 0], b[j, 1], b[j, 2])
            if length == 0.0:
                return j, ZERO_DIRECTION, 0.0
            u = (b[j, 0] / length, b[j, 1] / length, b[j, 2] / length)
        y = (
            x[STATE.x1], x[STATE.x1 + 1], x[STATE.x1 + 2], x[STATE.x2], x[STATE.x2 + 1], x[STATE.x2 + 2],
            x[STATE.b], x[STATE.b + 1], x[STATE.b + 2],
        )  # fmt: skip
        if x[STATE.stage] == RUNNING:  # the observer
            held = (x[STATE.tau], x[STATE.tau + 1], x[STATE.tau + 2])
            y = _interval(p, J, Jinv, y, t[j] - x[STATE.t], valid, u, held)
        elif valid:  # the start: ξ₀ so that the output map (D2) gives ω̂₀ (the gradient observer: x₁ = ω̂₀)
            r = (p[PARAMS.r_hat0], p[PARAMS.r_hat0 + 1], p[PARAMS.r_hat0 + 2]) if p[PARAMS.has_r_hat0] != 0.0 else u
            w = (p[PARAMS.omega_hat0], p[PARAMS.omega_hat0 + 1], p[PARAMS.omega_hat0 + 2])
            g = _estimate(Jinv, k, sign, gradient, (0.0, 0.0, 0.0, r[0], r[1], r[2], u[0], u[1], u[2]))
            y = (w[0] - g[0], w[1] - g[1], w[2] - g[2], r[0], r[1], r[2], u[0], u[1], u[2])
            x[STATE.stage] = RUNNING
        if x[STATE.stage] == RUNNING:
            for i in range(3):
                x[STATE.x1 + i], x[STATE.x2 + i], x[STATE.b + i] = y[i], y[3 + i], y[6 + i]
            if valid:
                x[STATE.tau], x[STATE.tau + 1], x[STATE.tau + 2] = tq
            omega[j, 0], omega[j, 1], omega[j, 2] = _estimate(Jinv, k, sign, gradient, y)
        else:
            omega[j, 0] = omega[j, 1] = omega[j, 2] = np.nan
        x[STATE.t] = t[j]
        if valid:  # the monitor: S ← a S + (1 − a)(I − u uᵀ), W ← a W + (1 − a)
            a = 0.0 if np.isnan(x[STATE.t_valid]) else math.exp(-(t[j] - x[STATE.t_valid]) / window)
            f = 1.0 - a
            S = STATE.S
            x[S] = a * x[S] + f * (1.0 - u[0] * u[0])
            x[S + 1] = a * x[S + 1] + f * (1.0 - u[1] * u[1])
            x[S + 2] = a * x[S + 2] + f * (1.0 - u[2] * u[2])
            x[S + 3] = a * x[S + 3] + f * (0.0 - u[0] * u[1])
            x[S + 4] = a * x[S + 4] + f * (0.0 - u[0] * u[2])
            x[S + 5] = a * x[S + 5] + f * (0.0 - u[1] * u[2])
            x[STATE.W] = a * x[STATE.W] + f
            x[STATE.t_valid] = t[j]
            if np.isnan(x[STATE.t_first]):
                x[STATE.t_first] = t[j]
        W = x[STATE.W]
        if W > 0.0:
            S = STATE.S
            lam[j], axis[j, 0], axis[j, 1], axis[j, 2] = smallest_eigenpair(
                x[S] / W, x[S + 1] / W, x[S + 2] / W, x[S + 3] / W, x[S + 4] / W, x[S + 5] / W
            )
            flags[j] = t[j] - x[STATE.t_first] >= window and lam[j] < threshold
        else:
            lam[j] = axis[j, 0] = axis[j, 1] = axis[j, 2] = np.nan
            flags[j] = False
    return -1, OK, 0.0
