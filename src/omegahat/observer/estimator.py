r"""The sampled, streaming Sarras estimator: one sample at a time (``update``) or whole logs (``run``).

Reference: I. Sarras, "Continuous globally exponential rigid-body angular velocity estimation from attitude
measurements", with the sign of the output map corrected (``shared/design/observer.md``,
:mod:`omegahat.observer.continuous`). This module realises that continuous-time observer for measurements that
arrive at sample times ``t_k`` (any, possibly irregular, spacing).

Coordinates. Instead of the paper's ``(ξ, r̂_i)`` the state is ``(ω̂, r_i, e_i)`` with ``e_i = r̂_i − r_i``;
``ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i`` makes the two equivalent. Differentiating that output map along the observer
with ``ṙ_i = r_i × ω̂`` (the direction moved along the estimate), the ``k_i`` and ``l_i`` terms cancel
(Jacobi identity) and::

    J ω̂̇ = (J ω̂) × ω̂ + τ                                                   (E1)
    ė_i  = e_i × ω̂ − l_i(ω̂) e_i                                           (E2)

while a jump ``Δ_i`` of ``r_i`` (with ξ and r̂ continuous) moves the output by ``J⁻¹ Σ k_i Δ_i × r̂_i``.

Between samples (``t_k → t_{k+1}``, ``h = t_{k+1} − t_k``, torque ``τ_k`` held from its sample):

1. **Predict.** ω̂ follows (E1) alone; the predicted directions move along the estimate,
   ``r_i^pred = ΔR̂ᵀ r_i,k`` with ``ΔR̂`` the attitude increment of ``Ṙ = R ω̂×`` over the interval; (E2) gives
   ``e_i = exp(−∫ l_i dt) ΔR̂ᵀ e_i,k``: the stiff decay is applied exactly, never with an explicit step.
   (E1) and ``ΔR̂`` are integrated together with the Runge–Kutta–Munthe-Kaas method of order 4 (RKMK4: classical
   RK4 for ω̂, and for ``ΔR̂ = exp(u)`` the stages ``u̇ = dexp⁻¹_{−u}(ω̂) ≈ ω̂ + ½ u × ω̂ + (1/12) u × (u × ω̂)``),
   in substeps of angle ``h_sub (|ω̂| + h|J⁻¹τ|) ≤ max_substep_angle``; ``∫|ω̂| dt`` (for ``l_i(ω̂)``) is
   integrated with the same RK4 weights. For a constant ω̂ every stage equals ``h ω̂`` and ``ΔR̂ = exp(h ω̂)``
   exactly, so a body at constant rate (J = I, or an axisymmetric body spinning about its axis) is predicted
   without error.
2. **Innovation** ``Δ_i = r_i,meas − r_i^pred``; ``r̂_i = r_i^pred + e_i`` is continuous across the sample.
3. **Correction (implicit).** The plain jump ``y = J⁻¹ Σ k_i Δ_i × r̂_i`` linearises to ``y ≈ −h J⁻¹ M z``
   (``z = ω̂ − ω``, ``M = Σ k_i (I − r_i r_iᵀ)``): explicit Euler of ``ż = −J⁻¹ M z``, which overshoots for
   ``k h / J ≈ 1`` and diverges beyond 2. The estimator applies instead::

       ω̂ ← ω̂ + (I + h J⁻¹ M_meas)⁻¹ y,      M_meas = Σ k_i (|r_i|² I − r_i r_iᵀ)   (measured r_i)    (C)

   whose linearised error map is ``z ← (I + h J⁻¹ M)⁻¹ z``, eigenvalues ``1/(1 + h λ)`` with ``λ > 0`` the
   eigenvalues of ``J⁻¹ M`` (similar to the SPD ``J^{-½} M J^{-½}``): a contraction for every k, h. It is zero when
   ``Δ = 0`` (exact equilibrium), and as ``h → 0`` it tends to the continuous observer at first order: on the
   paper's scenario the gap |ω̂_sampled − ω̂_continuous| at t = 1 s is 1.8e-3, 8.3e-4, 3.8e-4, 1.8e-4, 8.4e-5,
   4.1e-5 rad/s for h = 10, 5, 2.5, 1.25, 0.625, 0.3125 ms (fitted order 1.09; ``python
   benchmarks/sampled_convergence.py``). The exponential alternative ``ω̂ += (I − e^{−A}) A⁻¹ y``,
   ``A = h J⁻¹ M_meas``, has a smaller gap at these h (6.6e-5 at 1 s for h = 10 ms) but it does not shrink at a
   clean rate (4.5e-5 at h = 1.25 ms, fitted order 0.18; ``--compare-phi1``), and it needs a matrix exponential
   per sample: the implicit form is kept for its measured, monotone first-order convergence and its simplicity.
4. **Reset** ``e_i ← e_i − Δ_i`` and ``r_i ← r_i,meas`` (r̂ continuous, r jumps to the measurement).

Initialisation: the first valid sample sets ``r_i``; ``ω̂₀`` is given (default 0) and ``r̂_i0`` is given (default
the first measurement, ``e = 0``; the paper's scenario uses ``r̂_10 = (0, −1, 0)``, ``r̂_20 = (0, 0, −1)``). Until
that first valid sample the output is ``ω̂₀``.

**Warm start (W)**, optional (``warm_start=True``). The observer converges from any ω̂₀, but only at the rate its
gains allow, and gains tuned for a noisy sensor are slow (tens of seconds for the ``slew`` scenario of
:mod:`omegahat.simulation.scenarios`). Since ξ₀ is free, nothing in the theory forbids choosing it from the data: at the
second valid sample (interval ``h`` since the first), the estimator solves Wahba's problem for the rotation ``A``
that best carries the first sample's directions onto the second's, ``A = argmin Σ k_i |r_i,meas − A r_i|²``
(SVD, Markley 1988), takes the mean rate ``ω_avg = log(Aᵀ)/h`` (``ΔR̂ = Aᵀ``, exact for a constant rate while
``|ω| h < π``) and moves it from the interval's midpoint to its end with half a step of (E1),
``ω̂ = ω_avg + (h/2) J⁻¹((J ω_avg) × ω_avg + τ)``, so that its error is ``O(h²)`` plus the measurement noise
(about ``√2 σ / h``). ``r`` and ``e`` are advanced by steps 1, 2 and 4 with ``ΔR̂ = Aᵀ``; the gains take over from
there. Until the second valid sample the output is ``ω̂₀``.

Input (see :mod:`omegahat.measurements` for the checks). Attitudes (matrices, quaternions in SciPy's scalar-last
order unless ``scalar_first=True``, ``Rotation``) are turned into ``r_i = Rᵀ v_i``; the default ``v_i`` are the
first ``gains.n`` inertial axes, i.e. **all three rows of R for three gains**, the first two rows for two gains
(the paper). Direction input: ``references`` (the inertial ``v_i``, ``(n, 3)``) and per sample the measured
body-frame directions ``(n, 3)``.

Bad input, and what happens (the estimator's state is left exactly as it was whenever a sample is rejected):

* a NaN or inf anywhere in the measurement → the sample is **skipped**: the state is predicted to its time (the
  torque given with it starts being held), no correction, ``update`` returns the prediction; counted in
  ``n_missing`` and its time appended to ``skipped_times``. Gaps (long intervals) need nothing special: the
  prediction simply runs over the whole interval; ``largest_interval`` reports the longest one seen;
* direction measurements within ``min_angle_deg`` of collinear → skipped the same way, counted in ``n_collinear``;
* not a rotation (``‖RᵀR − I‖_F > rotation_tol`` or ``det R < 0``), a quaternion with ``|‖q‖ − 1| >
  quat_norm_tol``, a zero direction → :class:`omegahat.measurements.MeasurementError` naming the value;
* a time not strictly after the previous sample's, or not finite → ``ValueError`` naming both times;
* a torque that is not finite, wrong shapes → ``ValueError`` naming the value or shape.

``run`` issues one :class:`SkippedSamplesWarning` when it skipped samples, and is atomic: if it rejects a sample
it raises (naming the sample's index and time) and leaves the estimator as it was before the call.

Implementation: the state is one flat array (:class:`EstimatorState` is its readable view); the compiled
:func:`step` validates one sample and advances the state in a single Numba call, ``update`` is a thin shell over
it and ``run`` loops over the very same function in compiled code. :func:`reference_step` is the plain NumPy
version of steps 1–4 (the test oracle). Measured with ``python benchmarks/estimator_speed.py`` (paper's body at
1 kHz, three rows, on a shared 2-core machine, one core): ``update`` median 3.6 µs (matrix) / 3.9 µs (quaternion);
``run`` 1.2 (matrices) to 1.9 (quaternions) million samples/s; the NumPy oracle 1.5e3 samples/s, agreeing to 8e-15.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numba
import numpy as np
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.interface import Estimator
from omegahat.observer.gains import ObserverGains
from omegahat.simulation.rigid_body import _quat_of_matrix
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = [
    "EstimatorState",
    "SarrasEstimator",
    "SkippedSamplesWarning",
    "reference_predict",
    "reference_step",
    "step",
]

MAX_SUBSTEP_ANGLE = 0.05  # rad: default bound on h_sub (|ω̂| + h |J⁻¹τ|)
MAX_SUBSTEPS = 1_000_000  # cap on substeps per interval (a gap of hours at a fast spin)

# Statuses beyond those of omegahat.measurements (rejections, ≥ ms.ERROR).
TIME_ORDER = 20  #: info = previous time
TIME_NOT_FINITE = 21
TORQUE_NOT_FINITE = 22

# Layout of the flat state vector (n directions): [t, stage, t_meas, ω̂(3), τ(3), r(n·3), e(n·3)], stage 0 before
# the first valid sample, 1 after it while a warm start waits for the second, 2 running.
_T, _INIT, _TM, _W, _TAU, _R = 0, 1, 2, 3, 6, 9


class SkippedSamplesWarning(UserWarning):
    """``run`` skipped samples (missing or collinear); their times are in ``estimator.skipped_times``."""


@dataclass(frozen=True)
class EstimatorState:
    """Readable copy of the estimator's state (``n`` directions).

    ``t`` time of the last sample (NaN before any), ``initialised`` whether a valid sample has set ``r``,
    ``t_meas`` time of the last valid (not skipped) sample,
    ``omega_hat (3,)``, ``torque (3,)`` held since ``t``, ``r (n, 3)`` the directions at ``t`` (the last
    measurement or its prediction), ``e (n, 3) = r̂ − r``, ``warm_pending`` whether a warm start (W) is waiting
    for the second valid sample (``r`` is then the first sample's measurement).
    """

    t: float
    initialised: bool
    t_meas: float
    omega_hat: np.ndarray
    torque: np.ndarray
    r: np.ndarray
    e: np.ndarray
    warm_pending: bool = False

    @property
    def r_hat(self) -> np.ndarray:
        """The observer's filtered directions ``r̂ = r + e``, ``(n, 3)``."""
        return self.r + self.e

    @classmethod
    def from_vector(cls, x: np.ndarray) -> EstimatorState:
        n = (x.size - _R) // 6
        return cls(
            t=float(x[_T]),
            initialised=bool(x[_INIT] > 0.0),
            t_meas=float(x[_TM]),
            omega_hat=x[_W : _W + 3].copy(),
            torque=x[_TAU : _TAU + 3].copy(),
            r=x[_R : _R + 3 * n].reshape(n, 3).copy(),
            e=x[_R + 3 * n :].reshape(n, 3).copy(),
            warm_pending=bool(x[_INIT] == 1.0),
        )

    def to_vector(self) -> np.ndarray:
        return np.concatenate(
            [
                [self.t, 0.0 if not self.initialised else 1.0 if self.warm_pending else 2.0, self.t_meas],
                self.omega_hat,
                self.torque,
                self.r.ravel(),
                self.e.ravel(),
            ]
        )


# ------------------------------------------------------------------------------------- plain NumPy: the oracle


def _exp_so3(phi):
    """Rodrigues (Taylor near 0): ``exp(φ×)``."""
    th = np.linalg.norm(phi)
    K = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    if th < 1e-4:
        a, b = 1 - th**2 / 6 + th**4 / 120, 0.5 - th**2 / 24 + th**4 / 720
    else:
        a, b = np.sin(th) / th, (1 - np.cos(th)) / th**2
    return np.eye(3) + a * K + b * K @ K


def _substeps(h, omega_hat, J_inv, tau, max_angle):
    angle = h * (np.linalg.norm(omega_hat) + h * np.linalg.norm(J_inv @ tau))
    return int(min(MAX_SUBSTEPS, max(1, math.ceil(angle / max_angle))))


def reference_predict(omega_hat, r, e, tau, h, J, J_inv, gains: ObserverGains, max_angle=MAX_SUBSTEP_ANGLE):
    """Step 1 (predict over ``h``), plain NumPy: returns ``(ω̂, r_pred, e_pred)``."""
    f = lambda w: J_inv @ (np.cross(J @ w, w) + tau)  # (E1)  # noqa: E731
    dexpinv = lambda u, w: w + 0.5 * np.cross(u, w) + np.cross(u, np.cross(u, w)) / 12.0  # noqa: E731
    n_sub = _substeps(h, omega_hat, J_inv, tau, max_angle)
    hs = h / n_sub
    w = np.array(omega_hat, dtype=float)
    D = np.eye(3)  # ΔR̂
    int_abs_w = 0.0  # ∫ |ω̂| dt
    for _ in range(n_sub):  # RKMK4
        w1 = w
        K1, L1 = hs * w1, hs * f(w1)
        w2 = w + L1 / 2
        K2, L2 = hs * dexpinv(K1 / 2, w2), hs * f(w2)
        w3 = w + L2 / 2
        K3, L3 = hs * dexpinv(K2 / 2, w3), hs * f(w3)
        w4 = w + L3
        K4, L4 = hs * dexpinv(K3, w4), hs * f(w4)
        int_abs_w += (
            hs * (np.linalg.norm(w1) + 2 * np.linalg.norm(w2) + 2 * np.linalg.norm(w3) + np.linalg.norm(w4)) / 6
        )
        D = D @ _exp_so3((K1 + 2 * K2 + 2 * K3 + K4) / 6)
        w = w + (L1 + 2 * L2 + 2 * L3 + L4) / 6
    decay = np.exp(-(gains.l_offset * h + gains.l_slope * int_abs_w))  # exact solution of (E2)'s decay
    return w, r @ D, decay[:, None] * (e @ D)  # rows: (ΔR̂ᵀ r_i)ᵀ = r_iᵀ ΔR̂


def reference_step(
    state: EstimatorState,
    t,
    r_meas,
    tau,
    J,
    gains: ObserverGains,
    r_hat0=None,
    omega_hat0=None,
    max_angle=MAX_SUBSTEP_ANGLE,
    warm_start=False,
) -> EstimatorState:
    """Steps 1–4 (or the warm start W) for one sample of directions ``r_meas (n, 3)`` (None: a skipped sample),
    plain NumPy, no checks.

    ``tau`` is the torque given with this sample (held from ``t`` on); the interval uses ``state.torque``.
    """
    tau = np.zeros(3) if tau is None else np.asarray(tau, dtype=float)
    if not state.initialised:
        if r_meas is None:
            return EstimatorState(float(t), False, state.t_meas, state.omega_hat, tau, state.r, state.e)
        r_meas = np.asarray(r_meas, dtype=float)
        w0 = np.zeros(3) if omega_hat0 is None else np.asarray(omega_hat0, float)
        e0 = np.zeros_like(r_meas) if r_hat0 is None else np.asarray(r_hat0, float) - r_meas
        return EstimatorState(float(t), True, float(t), w0, tau, r_meas.copy(), e0, warm_start)
    J_inv = np.linalg.inv(J)
    if state.warm_pending:
        if r_meas is None:
            return EstimatorState(float(t), True, state.t_meas, state.omega_hat, tau, state.r, state.e, True)
        r_meas = np.asarray(r_meas, dtype=float)
        h = t - state.t_meas
        # (W): Wahba's rotation A = argmin Σ k_i |m_i − A r_i|² (SVD), ω_avg = log(Aᵀ)/h, then half a step of (E1)
        U, _, Vt = np.linalg.svd((gains.k[:, None, None] * r_meas[:, :, None] * state.r[:, None, :]).sum(axis=0))
        A = U @ np.diag([1.0, 1.0, np.linalg.det(U) * np.linalg.det(Vt)]) @ Vt
        w_avg = so3.log(A.T) / h
        w = w_avg + 0.5 * h * J_inv @ (np.cross(J @ w_avg, w_avg) + state.torque)
        decay = np.exp(-(gains.l_offset * h + gains.l_slope * np.linalg.norm(w_avg) * h))
        r_pred, e_pred = state.r @ A.T, decay[:, None] * (state.e @ A.T)
        return EstimatorState(float(t), True, float(t), w, tau, r_meas.copy(), e_pred - (r_meas - r_pred))
    w, r_pred, e_pred = reference_predict(
        state.omega_hat, state.r, state.e, state.torque, t - state.t, J, J_inv, gains, max_angle
    )
    if r_meas is None:
        return EstimatorState(float(t), True, state.t_meas, w, tau, r_pred, e_pred)
    r_meas = np.asarray(r_meas, dtype=float)
    delta = r_meas - r_pred  # step 2
    r_hat = r_pred + e_pred
    k = gains.k
    y = J_inv @ np.sum(k[:, None] * np.cross(delta, r_hat), axis=0)  # the plain jump
    M = sum(k[i] * (r_meas[i] @ r_meas[i] * np.eye(3) - np.outer(r_meas[i], r_meas[i])) for i in range(k.size))
    h = t - state.t_meas  # since the last valid sample
    w = w + np.linalg.solve(np.eye(3) + h * J_inv @ M, y)  # step 3, (C)
    return EstimatorState(float(t), True, float(t), w, tau, r_meas.copy(), e_pred - delta)  # step 4


# --------------------------------------------------------------------------------------------- compiled kernel

# Layout of the flat parameter vector: [J(9), J⁻¹(9), rotation_tol, quat_norm_tol, min_sin, max_angle,
# scalar_first, has_r_hat0, n, warm_start, k(n), l_offset(n), l_slope(n), V(3n), r̂0(3n)].
_P_J, _P_JI, _P_ROT, _P_QN, _P_SIN, _P_ANG, _P_SF, _P_HASR, _P_N, _P_WARM, _P_K = (
    0,
    9,
    18,
    19,
    20,
    21,
    22,
    23,
    24,
    25,
    26,
)


@numba.njit(cache=True, inline="always")
def _euler_rhs(J, J_inv, w0, w1, w2, t0, t1, t2):
    """``J⁻¹((J w) × w + τ)`` (E1), as a tuple."""
    a0 = J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2
    a1 = J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2
    a2 = J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2
    g0 = a1 * w2 - a2 * w1 + t0
    g1 = a2 * w0 - a0 * w2 + t1
    g2 = a0 * w1 - a1 * w0 + t2
    return (
        J_inv[0, 0] * g0 + J_inv[0, 1] * g1 + J_inv[0, 2] * g2,
        J_inv[1, 0] * g0 + J_inv[1, 1] * g1 + J_inv[1, 2] * g2,
        J_inv[2, 0] * g0 + J_inv[2, 1] * g1 + J_inv[2, 2] * g2,
    )


@numba.njit(cache=True, inline="always")
def _dexpinv(u0, u1, u2, w0, w1, w2, hs):
    """``hs (w + ½ u × w + (1/12) u × (u × w))``, as a tuple."""
    c0 = u1 * w2 - u2 * w1
    c1 = u2 * w0 - u0 * w2
    c2 = u0 * w1 - u1 * w0
    d0 = u1 * c2 - u2 * c1
    d1 = u2 * c0 - u0 * c2
    d2 = u0 * c1 - u1 * c0
    return hs * (w0 + 0.5 * c0 + d0 / 12.0), hs * (w1 + 0.5 * c1 + d1 / 12.0), hs * (w2 + 0.5 * c2 + d2 / 12.0)


@numba.njit(cache=True)
def _exp_into(x, y, z, E):
    """``E = exp(φ×)`` for ``φ = (x, y, z)`` (Rodrigues; Taylor below 1e-4 rad)."""
    th2 = x * x + y * y + z * z
    th = np.sqrt(th2)
    if th < 1e-4:
        a = 1.0 - th2 / 6.0 + th2 * th2 / 120.0
        b = 0.5 - th2 / 24.0 + th2 * th2 / 720.0
    else:
        a = np.sin(th) / th
        b = (1.0 - np.cos(th)) / th2
    # I + a K + b K², K = φ×, K² = φφᵀ − θ² I
    E[0, 0] = 1.0 + b * (x * x - th2)
    E[1, 1] = 1.0 + b * (y * y - th2)
    E[2, 2] = 1.0 + b * (z * z - th2)
    E[0, 1] = -a * z + b * x * y
    E[1, 0] = a * z + b * x * y
    E[0, 2] = a * y + b * x * z
    E[2, 0] = -a * y + b * x * z
    E[1, 2] = -a * x + b * y * z
    E[2, 1] = a * x + b * y * z


@numba.njit(cache=True)
def _predict(J, J_inv, max_angle, w, tau, h, D, E, T):
    """Step 1 in place (RKMK4, as :func:`reference_predict`): ``w`` ← ω̂(t+h), ``D`` ← ΔR̂; returns ∫|ω̂| dt.

    ``E``, ``T`` are 3×3 scratch matrices.
    """
    t0, t1, t2 = tau[0], tau[1], tau[2]
    f0, f1, f2 = _euler_rhs(J, J_inv, 0.0, 0.0, 0.0, t0, t1, t2)  # J⁻¹τ
    w0, w1, w2 = w[0], w[1], w[2]
    angle = h * (np.sqrt(w0 * w0 + w1 * w1 + w2 * w2) + h * np.sqrt(f0 * f0 + f1 * f1 + f2 * f2))
    n_sub = max(1, min(MAX_SUBSTEPS, math.ceil(angle / max_angle)))
    hs = h / n_sub
    int_abs = 0.0
    for j in range(n_sub):
        # stage 1
        L10, L11, L12 = _euler_rhs(J, J_inv, w0, w1, w2, t0, t1, t2)
        L10, L11, L12 = hs * L10, hs * L11, hs * L12
        K10, K11, K12 = hs * w0, hs * w1, hs * w2
        n1 = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
        # stage 2
        s0, s1, s2 = w0 + 0.5 * L10, w1 + 0.5 * L11, w2 + 0.5 * L12
        n2 = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K20, K21, K22 = _dexpinv(0.5 * K10, 0.5 * K11, 0.5 * K12, s0, s1, s2, hs)
        L20, L21, L22 = _euler_rhs(J, J_inv, s0, s1, s2, t0, t1, t2)
        L20, L21, L22 = hs * L20, hs * L21, hs * L22
        # stage 3
        s0, s1, s2 = w0 + 0.5 * L20, w1 + 0.5 * L21, w2 + 0.5 * L22
        n3 = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K30, K31, K32 = _dexpinv(0.5 * K20, 0.5 * K21, 0.5 * K22, s0, s1, s2, hs)
        L30, L31, L32 = _euler_rhs(J, J_inv, s0, s1, s2, t0, t1, t2)
        L30, L31, L32 = hs * L30, hs * L31, hs * L32
        # stage 4
        s0, s1, s2 = w0 + L30, w1 + L31, w2 + L32
        n4 = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        K40, K41, K42 = _dexpinv(K30, K31, K32, s0, s1, s2, hs)
        L40, L41, L42 = _euler_rhs(J, J_inv, s0, s1, s2, t0, t1, t2)
        L40, L41, L42 = hs * L40, hs * L41, hs * L42
        int_abs += hs * (n1 + 2.0 * n2 + 2.0 * n3 + n4) / 6.0
        w0 += (L10 + 2.0 * L20 + 2.0 * L30 + L40) / 6.0
        w1 += (L11 + 2.0 * L21 + 2.0 * L31 + L41) / 6.0
        w2 += (L12 + 2.0 * L22 + 2.0 * L32 + L42) / 6.0
        u0 = (K10 + 2.0 * K20 + 2.0 * K30 + K40) / 6.0
        u1 = (K11 + 2.0 * K21 + 2.0 * K31 + K41) / 6.0
        u2 = (K12 + 2.0 * K22 + 2.0 * K32 + K42) / 6.0
        if j == 0:
            _exp_into(u0, u1, u2, D)
        else:  # D ← D exp(u)
            _exp_into(u0, u1, u2, E)
            for a in range(3):
                for b in range(3):
                    T[a, b] = D[a, 0] * E[0, b] + D[a, 1] * E[1, b] + D[a, 2] * E[2, b]
            D[:, :] = T
    w[0], w[1], w[2] = w0, w1, w2
    return int_abs


@numba.njit(cache=True)
def _solve3(A, y0, y1, y2):
    """``A⁻¹ y`` by the adjugate (A = I + h J⁻¹ M has eigenvalues ≥ 1: well conditioned), as a tuple."""
    c00 = A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1]
    c01 = A[1, 2] * A[2, 0] - A[1, 0] * A[2, 2]
    c02 = A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]
    det = A[0, 0] * c00 + A[0, 1] * c01 + A[0, 2] * c02
    c10 = A[0, 2] * A[2, 1] - A[0, 1] * A[2, 2]
    c11 = A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
    c12 = A[0, 1] * A[2, 0] - A[0, 0] * A[2, 1]
    c20 = A[0, 1] * A[1, 2] - A[0, 2] * A[1, 1]
    c21 = A[0, 2] * A[1, 0] - A[0, 0] * A[1, 2]
    c22 = A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0]
    return (
        (c00 * y0 + c10 * y1 + c20 * y2) / det,
        (c01 * y0 + c11 * y1 + c21 * y2) / det,
        (c02 * y0 + c12 * y1 + c22 * y2) / det,
    )


@numba.njit(cache=True)
def _rotvec(R):
    """Rotation vector of ``R`` (|φ| ≤ π) from its quaternion (Shepperd's method, accurate at every angle)."""
    q = _quat_of_matrix(R)  # (x, y, z, w), w ≥ 0
    s = np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    g = 2.0 / q[3] if s < 1e-12 else 2.0 * math.atan2(s, q[3]) / s  # θ = 2 atan2(s, w); 2 q_vec / w to O(θ³)
    return g * q[0], g * q[1], g * q[2]


@numba.njit(cache=True)
def _warm_start(J, J_inv, k, l_off, l_slope, tau, h, r, e, r_meas, A):
    """Warm start (W) in place: ω̂ from the first two valid samples; returns ``ω̂ (3 floats)``.

    ``r`` (the directions measured at the first sample), ``e`` are advanced to the second sample like steps 1,
    2 and 4 with ``ΔR̂ = Aᵀ``; ``A`` (3×3) receives the Wahba rotation.
    """
    n = r.shape[0]
    B = np.zeros((3, 3))  # Σ k_i m_i r_iᵀ
    for i in range(n):
        for a in range(3):
            for b in range(3):
                B[a, b] += k[i] * r_meas[i, a] * r[i, b]
    U, _, Vt = np.linalg.svd(B)
    d = np.linalg.det(U) * np.linalg.det(Vt)
    for a in range(3):
        for b in range(3):
            A[a, b] = U[a, 0] * Vt[0, b] + U[a, 1] * Vt[1, b] + d * U[a, 2] * Vt[2, b]
    At = A.T.copy()
    p0, p1, p2 = _rotvec(At)  # ΔR̂ = Aᵀ = exp(h ω_avg)
    w0, w1, w2 = p0 / h, p1 / h, p2 / h
    f0, f1, f2 = _euler_rhs(J, J_inv, w0, w1, w2, tau[0], tau[1], tau[2])
    int_abs = np.sqrt(w0 * w0 + w1 * w1 + w2 * w2) * h  # ∫|ω̂| dt along the constant ω_avg
    for i in range(n):
        decay = np.exp(-(l_off[i] * h + l_slope[i] * int_abs))
        q0 = A[0, 0] * r[i, 0] + A[0, 1] * r[i, 1] + A[0, 2] * r[i, 2]  # r_pred = A r
        q1 = A[1, 0] * r[i, 0] + A[1, 1] * r[i, 1] + A[1, 2] * r[i, 2]
        q2 = A[2, 0] * r[i, 0] + A[2, 1] * r[i, 1] + A[2, 2] * r[i, 2]
        e0 = decay * (A[0, 0] * e[i, 0] + A[0, 1] * e[i, 1] + A[0, 2] * e[i, 2])
        e1 = decay * (A[1, 0] * e[i, 0] + A[1, 1] * e[i, 1] + A[1, 2] * e[i, 2])
        e2 = decay * (A[2, 0] * e[i, 0] + A[2, 1] * e[i, 1] + A[2, 2] * e[i, 2])
        # r̂ continuous: e ← e_pred − (r_meas − r_pred), r ← r_meas
        e[i, 0] = e0 - (r_meas[i, 0] - q0)
        e[i, 1] = e1 - (r_meas[i, 1] - q1)
        e[i, 2] = e2 - (r_meas[i, 2] - q2)
        r[i, 0], r[i, 1], r[i, 2] = r_meas[i, 0], r_meas[i, 1], r_meas[i, 2]
    return w0 + 0.5 * h * f0, w1 + 0.5 * h * f1, w2 + 0.5 * h * f2  # midpoint rate → rate at the sample


@numba.njit(cache=True)
def _step_into(x, p, t, m, kind, tau, out, wk):
    """Validate one sample and advance the flat state ``x`` into ``out``; returns ``(status, info)``.

    ``wk`` is scratch space ``(n + 12, 3)``. On a rejection (status ≥ ms.ERROR) ``out`` is left unspecified;
    ``x`` is never written.
    """
    n = int(p[_P_N])
    J = p[_P_J : _P_J + 9].reshape(3, 3)
    J_inv = p[_P_JI : _P_JI + 9].reshape(3, 3)
    k = p[_P_K : _P_K + n]
    l_off = p[_P_K + n : _P_K + 2 * n]
    l_slope = p[_P_K + 2 * n : _P_K + 3 * n]
    V = p[_P_K + 3 * n : _P_K + 6 * n].reshape(n, 3)
    r_meas = wk[:n]
    D = wk[n : n + 3]
    E = wk[n + 3 : n + 6]
    T = wk[n + 6 : n + 9]
    A = wk[n + 9 : n + 12]
    # --- checks that do not touch the state
    if not np.isfinite(t):
        return TIME_NOT_FINITE, t
    if np.isfinite(x[_T]) and not t > x[_T]:
        return TIME_ORDER, x[_T]
    for a in range(3):
        if not np.isfinite(tau[a]):
            return TORQUE_NOT_FINITE, tau[a]
    status, info = ms.convert_sample(m, kind, V, p[_P_SF] != 0.0, p[_P_ROT], p[_P_QN], p[_P_SIN], r_meas, E)
    if status >= ms.ERROR:
        return status, info
    # --- accepted: write the new state into out
    out[:] = x
    out[_T] = t
    w = out[_W : _W + 3]
    r = out[_R : _R + 3 * n].reshape(n, 3)
    e = out[_R + 3 * n : _R + 6 * n].reshape(n, 3)
    out[_TAU : _TAU + 3] = tau
    if x[_INIT] == 0.0:
        if status == ms.OK:  # initialisation by the first valid sample
            out[_INIT] = 1.0 if p[_P_WARM] != 0.0 else 2.0
            out[_TM] = t
            r[:, :] = r_meas
            if p[_P_HASR] != 0.0:
                e[:, :] = p[_P_K + 6 * n : _P_K + 9 * n].reshape(n, 3) - r_meas
            else:
                e[:, :] = 0.0
        return status, info
    if x[_INIT] == 1.0:  # warm start pending: ω̂ and r, e wait for the second valid sample
        if status == ms.OK:
            w[0], w[1], w[2] = _warm_start(J, J_inv, k, l_off, l_slope, x[_TAU : _TAU + 3], t - x[_TM], r, e, r_meas, A)
            out[_INIT] = 2.0
            out[_TM] = t
        return status, info
    int_abs = _predict(J, J_inv, p[_P_ANG], w, x[_TAU : _TAU + 3], t - x[_T], D, E, T)  # step 1
    h_pred = t - x[_T]
    skipped = status != ms.OK
    h = t - x[_TM]  # the correction's interval: since the last valid sample (see step 3)
    y0 = y1 = y2 = 0.0
    for a in range(3):
        for b in range(3):
            A[a, b] = 0.0
    for i in range(n):
        # r_pred = ΔR̂ᵀ r and e_pred = exp(−∫ l_i dt) ΔR̂ᵀ e, in row form rᵀ ΔR̂
        decay = np.exp(-(l_off[i] * h_pred + l_slope[i] * int_abs))
        p0 = r[i, 0] * D[0, 0] + r[i, 1] * D[1, 0] + r[i, 2] * D[2, 0]
        p1 = r[i, 0] * D[0, 1] + r[i, 1] * D[1, 1] + r[i, 2] * D[2, 1]
        p2 = r[i, 0] * D[0, 2] + r[i, 1] * D[1, 2] + r[i, 2] * D[2, 2]
        e0 = decay * (e[i, 0] * D[0, 0] + e[i, 1] * D[1, 0] + e[i, 2] * D[2, 0])
        e1 = decay * (e[i, 0] * D[0, 1] + e[i, 1] * D[1, 1] + e[i, 2] * D[2, 1])
        e2 = decay * (e[i, 0] * D[0, 2] + e[i, 1] * D[1, 2] + e[i, 2] * D[2, 2])
        if skipped:  # keep the prediction
            r[i, 0], r[i, 1], r[i, 2] = p0, p1, p2
            e[i, 0], e[i, 1], e[i, 2] = e0, e1, e2
            continue
        m0, m1, m2 = r_meas[i, 0], r_meas[i, 1], r_meas[i, 2]
        d0, d1, d2 = m0 - p0, m1 - p1, m2 - p2  # step 2: Δ_i
        h0, h1, h2 = p0 + e0, p1 + e1, p2 + e2  # r̂_i
        y0 += k[i] * (d1 * h2 - d2 * h1)  # Σ k_i Δ_i × r̂_i
        y1 += k[i] * (d2 * h0 - d0 * h2)
        y2 += k[i] * (d0 * h1 - d1 * h0)
        r2 = m0 * m0 + m1 * m1 + m2 * m2  # M_meas = Σ k_i (|r_i|² I − r_i r_iᵀ)
        A[0, 0] += k[i] * (r2 - m0 * m0)
        A[1, 1] += k[i] * (r2 - m1 * m1)
        A[2, 2] += k[i] * (r2 - m2 * m2)
        A[0, 1] -= k[i] * m0 * m1
        A[0, 2] -= k[i] * m0 * m2
        A[1, 2] -= k[i] * m1 * m2
        r[i, 0], r[i, 1], r[i, 2] = m0, m1, m2  # step 4: r jumps to the measurement, r̂ is continuous
        e[i, 0], e[i, 1], e[i, 2] = e0 - d0, e1 - d1, e2 - d2
    if skipped:
        return status, info
    A[1, 0], A[2, 0], A[2, 1] = A[0, 1], A[0, 2], A[1, 2]
    # step 3 (C): ω̂ += (I + h J⁻¹ M)⁻¹ J⁻¹ Σ k_i Δ_i × r̂_i, with h since the last valid sample (the span over
    # which the innovation accumulated, so a skipped sample changes nothing but the prediction's substeps)
    out[_TM] = t
    for a in range(3):
        for b in range(3):
            T[a, b] = (1.0 if a == b else 0.0) + h * (
                J_inv[a, 0] * A[0, b] + J_inv[a, 1] * A[1, b] + J_inv[a, 2] * A[2, b]
            )
    z0 = J_inv[0, 0] * y0 + J_inv[0, 1] * y1 + J_inv[0, 2] * y2
    z1 = J_inv[1, 0] * y0 + J_inv[1, 1] * y1 + J_inv[1, 2] * y2
    z2 = J_inv[2, 0] * y0 + J_inv[2, 1] * y1 + J_inv[2, 2] * y2
    dw0, dw1, dw2 = _solve3(T, z0, z1, z2)
    w[0] += dw0
    w[1] += dw1
    w[2] += dw2
    return status, info


@numba.njit(cache=True)
def step(x, p, t, m, kind, tau):
    """Pure step: ``(new_state, status, info)``; ``x`` is not modified. ``m`` is 2-D (matrix ``(3, 3)``,
    quaternion ``(1, 4)`` or directions ``(n, 3)``), ``kind`` one of ``measurements.KIND_*``."""
    out = np.empty_like(x)
    status, info = _step_into(x, p, t, m, kind, tau, out, np.empty((int(p[_P_N]) + 12, 3)))
    return out, status, info


@numba.njit(cache=True)
def _run(x, p, times, m, kind, taus):
    """:func:`_step_into` over a log: ``(final_state, ω̂ (T, 3), status (T,), first_bad, info)``."""
    T = times.size
    W = np.empty((T, 3))
    status = np.zeros(T, dtype=np.int64)
    cur = x.copy()
    nxt = np.empty_like(x)
    wk = np.empty((int(p[_P_N]) + 12, 3))
    for j in range(T):
        s, info = _step_into(cur, p, times[j], m[j], kind, taus[j], nxt, wk)
        status[j] = s
        if s >= ms.ERROR:
            return x, W, status, j, info
        cur, nxt = nxt, cur
        W[j, 0], W[j, 1], W[j, 2] = cur[_W], cur[_W + 1], cur[_W + 2]
    return cur, W, status, -1, 0.0


# ------------------------------------------------------------------------------------------------ the object

_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False


class SarrasEstimator(Estimator):
    """Sampled Sarras estimator (module docstring: equations, input, bad-input behaviour).

    Parameters
    ----------
    J : inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    gains : :class:`omegahat.observer.gains.ObserverGains` for ``n`` directions (required): ``theorem_gains``,
        :func:`omegahat.observer.tuning.sensor_gains` or your own.
    references : inertial directions ``v_i`` ``(n, 3)``. With ``measurement="attitude"`` (default when no
        references are given) they default to the first ``n`` inertial axes (rows of R); with
        ``measurement="directions"`` (default when references are given) they are required.
    omega_hat0 : initial estimate (default 0). ``r_hat0`` : initial ``r̂_i`` ``(n, 3)`` (default: first sample).
    scalar_first : quaternion order (default False: SciPy's ``(x, y, z, w)``).
    rotation_tol, quat_norm_tol, min_angle_deg : input checks (see :mod:`omegahat.measurements`).
    max_substep_angle : bound on the prediction's substep angle (rad).
    warm_start : if True, ω̂ is not taken from ``omega_hat0`` but computed from the first two valid samples (W,
        module docstring): the estimate is right from the second sample on instead of converging at the gains'
        rate. Default (None): True unless ``omega_hat0`` or ``r_hat0`` is given (an initial state given is used);
        False: the observer as published, started from ``omega_hat0``.
    """

    def __init__(
        self,
        J,
        *,
        gains: ObserverGains,
        references=None,
        measurement: str | None = None,
        omega_hat0=None,
        r_hat0=None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
        max_substep_angle: float = MAX_SUBSTEP_ANGLE,
        warm_start: bool | None = None,
    ):
        self.J = as_inertia(J)
        if not isinstance(gains, ObserverGains):
            raise TypeError(f"gains must be an omegahat.observer.gains.ObserverGains; got {type(gains).__name__}")
        self.gains = gains
        n = gains.n
        if measurement is None:
            measurement = "attitude" if references is None else "directions"
        if measurement not in ("attitude", "directions"):
            raise ValueError(f"measurement must be 'attitude' or 'directions'; got {measurement!r}")
        self.measurement = measurement
        if references is None:
            if measurement == "directions":
                raise ValueError("measurement='directions' needs the inertial references (n, 3)")
            if n not in (2, 3):
                raise ValueError(f"attitude input without references uses 2 or 3 rows of R; gains are for {n}")
        self.references = ms.as_references(references, n)
        if self.references.shape[0] != n:
            raise ValueError(f"{n} gains were given for {self.references.shape[0]} reference directions")
        self.omega_hat0 = np.zeros(3) if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        if r_hat0 is None:
            self.r_hat0 = None
        else:
            self.r_hat0 = np.asarray(r_hat0, dtype=float)
            if self.r_hat0.shape != (n, 3) or not np.all(np.isfinite(self.r_hat0)):
                raise ValueError(f"r_hat0 must be {n} finite directions, shape ({n}, 3); got {r_hat0!r}")
        self.scalar_first = bool(scalar_first)
        tols = [
            as_positive(v, name)[0]
            for v, name in (
                (rotation_tol, "rotation_tol"),
                (quat_norm_tol, "quat_norm_tol"),
                (max_substep_angle, "max_substep_angle"),
            )
        ]
        if not 0 <= min_angle_deg < 90:
            raise ValueError(f"min_angle_deg must be in [0, 90); got {min_angle_deg!r}")
        self.rotation_tol, self.quat_norm_tol, self.max_substep_angle = (float(v) for v in tols)
        self.min_angle_deg = float(min_angle_deg)
        self.warm_start = (omega_hat0 is None and r_hat0 is None) if warm_start is None else bool(warm_start)
        self._params = np.concatenate(
            [
                self.J.ravel(),
                np.linalg.inv(self.J).ravel(),
                [
                    self.rotation_tol,
                    self.quat_norm_tol,
                    np.sin(np.radians(self.min_angle_deg)),
                    self.max_substep_angle,
                    float(self.scalar_first),
                    float(self.r_hat0 is not None),
                    float(n),
                    float(self.warm_start),
                ],
                gains.k,
                gains.l_offset,
                gains.l_slope,
                self.references.ravel(),
                np.zeros(3 * n) if self.r_hat0 is None else self.r_hat0.ravel(),
            ]
        )
        self.reset()

    # -- state ------------------------------------------------------------------------------------------------

    def reset(self) -> None:
        """Forget every sample: back to ``ω̂₀``, uninitialised, counters cleared."""
        n = self.gains.n
        x = np.zeros(_R + 6 * n)
        x[_T] = np.nan
        x[_W : _W + 3] = self.omega_hat0
        self._x = x
        self.n_missing = 0
        self.n_collinear = 0
        self.skipped_times: list[float] = []
        self.largest_interval = 0.0
        self.last_status = None

    @property
    def state(self) -> EstimatorState:
        """A readable copy of the current state."""
        return EstimatorState.from_vector(self._x)

    @property
    def omega_hat(self) -> np.ndarray:
        return self._x[_W : _W + 3].copy()

    # -- input ------------------------------------------------------------------------------------------------

    def _sample(self, measurement):
        """``(m 2-D, kind)`` for one sample, shape checked (values are checked in the kernel)."""
        if isinstance(measurement, Rotation):
            if not measurement.single:
                raise ValueError(f"update takes one sample; got a Rotation holding {len(measurement)}")
            return measurement.as_matrix(), ms.KIND_MATRIX
        m = np.asarray(measurement, dtype=float)
        if self.measurement == "attitude":
            if m.shape == (3, 3):
                return m, ms.KIND_MATRIX
            if m.shape == (4,):
                return m.reshape(1, 4), ms.KIND_QUAT
            raise ValueError(
                f"an attitude sample must be a 3x3 matrix, a quaternion (4,) or a Rotation; got shape {m.shape}"
            )
        if m.shape != self.references.shape:
            raise ValueError(
                f"a direction sample must have shape {self.references.shape} (one row per reference); "
                f"got shape {m.shape}"
            )
        return m, ms.KIND_DIRECTIONS

    def _batch(self, measurements, T):
        if isinstance(measurements, Rotation):
            m = measurements.as_matrix()
            kind = ms.KIND_MATRIX
        else:
            m = np.asarray(measurements, dtype=float)
            if self.measurement == "attitude" and m.shape == (T, 3, 3):
                kind = ms.KIND_MATRIX
            elif self.measurement == "attitude" and m.shape == (T, 4):
                m, kind = m.reshape(T, 1, 4), ms.KIND_QUAT
            elif self.measurement == "directions" and m.shape == (T, *self.references.shape):
                kind = ms.KIND_DIRECTIONS
            else:
                want = (
                    "(T, 3, 3) or (T, 4)" if self.measurement == "attitude" else f"(T, {self.references.shape[0]}, 3)"
                )
                raise ValueError(f"measurements must have shape {want} with T = {T} samples; got shape {m.shape}")
        if m.shape[0] != T:
            raise ValueError(f"{m.shape[0]} measurements for {T} times")
        return np.ascontiguousarray(m), kind

    def _reject(self, status, info, t, where):
        t, info = float(t), float(info)
        if status == TIME_ORDER:
            return ValueError(
                f"{where}: time t = {t!r} is not after the previous sample's t = {info!r} "
                "(timestamps must increase strictly)"
            )
        if status == TIME_NOT_FINITE:
            return ValueError(f"{where}: time t = {t!r} is not finite")
        if status == TORQUE_NOT_FINITE:
            return ValueError(f"{where} (t = {t!r}): torque must be finite; got {info!r}")
        return ms.MeasurementError(ms.describe_rejection(status, info, f"{where} (t = {t!r})"))

    # -- estimation -------------------------------------------------------------------------------------------

    def update(self, t, measurement, torque=None) -> np.ndarray:
        """Take the sample at time ``t`` (``torque`` known from ``t`` on, None = 0) and return ω̂(t) ``(3,)``."""
        m, kind = self._sample(measurement)
        if not m.flags.c_contiguous:  # one compiled specialisation (C-contiguous) serves every call
            m = np.ascontiguousarray(m)
        if torque is None:
            tau = _ZERO3
        else:
            tau = np.asarray(torque, dtype=float)
            if tau.shape != (3,):
                raise ValueError(f"torque must be a 3-vector; got shape {tau.shape}")
        t_prev = self._x[_T]
        x, status, info = step(self._x, self._params, float(t), m, kind, tau)
        if status >= ms.ERROR:
            raise self._reject(status, info, t, "the sample")
        self._x = x
        self.last_status = status
        if status != ms.OK:
            self._note_skipped(status, t)
        if t - t_prev > self.largest_interval:  # NaN before the first sample: comparison False
            self.largest_interval = t - t_prev
        return x[_W : _W + 3].copy()

    def _note_skipped(self, status, t):
        if status == ms.MISSING:
            self.n_missing += 1
        else:
            self.n_collinear += 1
        self.skipped_times.append(float(t))

    def run(self, times, measurements, torques=None) -> np.ndarray:
        """ω̂ at every sample of a log ``(T, 3)``, continuing from the current state (:meth:`reset` first for
        a fresh start). Same compiled step as :meth:`update`; atomic on rejection (see the module docstring).

        ``times (T,)``; ``measurements`` ``(T, 3, 3)``, ``(T, 4)``, a ``Rotation`` of T, or ``(T, n, 3)``;
        ``torques (T, 3)`` or None. Per-sample statuses are left in ``last_status``.
        """
        times = np.asarray(times, dtype=float)
        if times.ndim != 1:
            raise ValueError(f"times must have shape (T,); got shape {times.shape}")
        T = times.size
        m, kind = self._batch(measurements, T)
        if torques is None:
            taus = np.zeros((T, 3))
        else:
            taus = np.ascontiguousarray(torques, dtype=float)
            if taus.shape != (T, 3):
                raise ValueError(f"torques must have shape ({T}, 3); got shape {taus.shape}")
        x, W, status, first_bad, info = _run(self._x, self._params, np.ascontiguousarray(times), m, kind, taus)
        if first_bad >= 0:
            raise self._reject(int(status[first_bad]), float(info), float(times[first_bad]), f"sample {first_bad}")
        t_prev = self._x[_T]
        self._x = x
        self.last_status = status
        skipped = status != ms.OK
        if T:
            gaps = np.diff(np.concatenate([[t_prev], times])) if np.isfinite(t_prev) else np.diff(times)
            if gaps.size:
                self.largest_interval = max(self.largest_interval, float(gaps.max()))
        if skipped.any():
            n_miss = int(np.count_nonzero(status == ms.MISSING))
            n_col = int(np.count_nonzero(status == ms.COLLINEAR))
            self.n_missing += n_miss
            self.n_collinear += n_col
            self.skipped_times.extend(times[skipped].tolist())
            warnings.warn(
                f"skipped {n_miss + n_col} of {T} samples ({n_miss} missing: NaN/inf, {n_col} with nearly "
                "collinear directions); the estimate was predicted through them (times in skipped_times)",
                SkippedSamplesWarning,
                stacklevel=2,
            )
        return W
