r"""Basilisk's sun-line switch-EKF: one measured direction and the two rate components perpendicular to it.

Source: the public repository ``AVSLab/basilisk``, ``src/fswAlgorithms/attDetermination/sunlineSEKF/`` (the
module's ``_Documentation/Sunline_SEKF.tex``, ``sunlineSEKF.c`` and its unit test ``_UnitTest/
test_SunLineSEKF.py``; T. Teil's switch filter). Written here from those equations, in omegahat's words;
``docs/baselines.md`` tells the story. A kinematic filter: no inertia, no torque (a torque given with a sample is
checked and ignored). ``d`` is the measured direction in body axes (the Sun's), fixed in inertial space, so
``ḋ = d × ω`` with ω the body rate; the rate about d cannot be seen and is not estimated.

**Frames (S1).** For the body axis ``e`` in use (e₁, or e₂ after a switch)::

    s₁ = d/|d|,   s₂ = d × e / |d × e|,   s₃ = d × s₂ / |d × s₂|,   C = [s₁ s₂ s₃]  (body ← S)
    (C = I when |d × e| < 1e-5, as the source)

State ``X = [d (3, body axes, not normalised); ω₂; ω₃]``, the components 2 and 3 in S of the rate of S relative to
the body, ``ω_SB``; the body rate the filter stands for is ``ω̂ = C (0, −ω₂, −ω₃)`` (its part along d is set to 0).
Error state ``x`` (5) and covariance P (5×5). One update over ``h``, at a sample, in the source's order::

    switch: if |e · d/|d|| > cos 30°, e ← the other axis, X ← W X, P ← W P Wᵀ,                       (S2)
            W = diag(I₃, [C_newᵀ C_old]₂₃,₂₃)
    A = [[−ω̂×, −(d×) C₂₃], [0, 0]]   (C₂₃: C's columns 2, 3; C held fixed)                         (S3)
    d⁺ = d − h ω̂ × d,   ω₂, ω₃ unchanged,   Φ = I + h A                  (one Euler step)           (S4)
    Γ = [s (h²/2)(d⁺×) C⁺₂₃; h I₂]    (at the propagated state; s = +1 in the source)                 (S5)
    x̄ = Φ x,   P⁻ = Φ P Φᵀ + q Γ Γᵀ                                                                  (S6)
    y_j = n_jᵀ d + noise,  H = [n_jᵀ, 0, 0] rows,  K = P⁻Hᵀ(H P⁻ Hᵀ + σ² I)⁻¹                        (S7)
    EKF (max|P| ≤ threshold, P the previous posterior):  x = K (y − H X),  X ← X + x                 (S8)
    CKF (otherwise):  x = x̄ + K (y − H X − H x̄)  (X not moved)
    P = (I − K H) P⁻ (I − K H)ᵀ + σ² K Kᵀ                        (Joseph form)                       (S9)

With no sample, ``x = x̄`` and ``P = P⁻``. An update whose result (X, x, P) is not finite restarts the filter from
that sample, as at its start (d from the sample, the rates from ``omega_hat0``, P₀): the estimate there is NaN with
the status ``RESTARTED`` (:mod:`omegahat.interface`), never a diverged value.

Measurements: the source reads coarse sun sensors, cosines ``y_j = n_j·d`` of sensors with normals ``n_j`` whose
reading exceeds a threshold; omegahat's interface gives the measured unit direction ``b`` itself, i.e. three sensors
``n_j = e_j`` always read (``H = [I, 0]``). :func:`sekf_step` takes either (``normals``); ``benchmarks/peers.py``
runs the source's unit test with its eight sensors.

**Settings of the source** (its unit test): h = 0.5 s, q = 0.01, σ² = 0.001 (noise std √0.001 per cosine),
P₀ = diag(0.4, 0.4, 0.4, 0.004, 0.004), EKF/CKF threshold (4/3)², X₀ = [0.7, 0.7, 0, 0, 0], a fixed Sun heading
with no sample for the first 21 updates, then a new heading after half the run with no sample for 21 updates again;
it passes when the final state is within 0.1 of the heading (rates 0) and the covariance has come down.

**Inconsistencies found in the source** (each one also in ``docs/baselines.md``):

* Γ (S5) has the opposite sign from Φ's block ``∂d⁺/∂(ω₂, ω₃) = −h (d×) C₂₃`` (S3): the documentation's derivation
  (its equation ``ApproxPhi2``) writes ``d_{k+1} = d_i − (t−τ)(d×) ω_BN`` where ``ḋ = d × ω_BN`` gives ``+``. The
  code and its unit test carry the same sign, so the process noise enters the direction–rate covariance with the
  wrong sign. Default here: ``s = −1`` (Γ = ∫Φ B to leading order); ``as_published=True``: ``s = +1``;
* A (S3) holds the frame C fixed although C turns with d: it is the Jacobian of ``−ω̂ × d`` at fixed C, not of the
  dynamics; the neglected term is of the same order (|ω||δd|). Kept as published;
* in CKF mode the error state x accumulates the updates but is never added to X (the output), and the EKF update
  that follows overwrites it: the CKF's corrections are lost when the filter changes mode; the switch (S2) does not
  rotate x either. Kept as published. In the source's own test the CKF takes the first sample after each gap of
  21 updates (P's largest entry has grown past the threshold), and the EKF update that follows, from the unmoved
  state and the now small covariance, throws the rate estimate to about 2 rad/s (the truth is 0) before it decays;
  the test checks only the final state. ``benchmarks/peers.py`` reports the CKF updates and that peak;
* the documentation lists a 6-state initial covariance and a process-noise map for 6 states, names the 2×2 block
  of its transition ``Φ₃`` twice, and its test section points at the sunlineEKF module's files.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines import sunline_kernel as kernel
from omegahat.observer.compiled import CompiledEstimator
from omegahat.validation import as_positive, as_vector3

__all__ = [
    "SWITCH_COS",
    "SunlineSEKF",
    "body_rate",
    "dynamics_matrix",
    "frame",
    "measurement_update",
    "noise_map",
    "sekf_step",
    "switch",
    "time_update",
]

SWITCH_COS = 0.866  #: (S2) the source's threshold: switch when d is within about 30° of the axis in use
_AXES = np.eye(3)
_NAN3 = np.full(3, np.nan)
_NAN3.flags.writeable = False


def frame(d: np.ndarray, axis: int) -> np.ndarray:
    """(S1): ``C = [s₁ s₂ s₃]`` (body ← S) built on ``d`` and the body axis ``e_axis`` (0: e₁, 1: e₂)."""
    c = np.cross(d, _AXES[axis])
    if np.linalg.norm(c) < 1e-5:
        return np.eye(3)
    s2 = c / np.linalg.norm(c)
    s3 = np.cross(d, s2)
    return np.column_stack([d / np.linalg.norm(d), s2, s3 / np.linalg.norm(s3)])


def body_rate(X: np.ndarray, axis: int) -> np.ndarray:
    """``ω̂ = C (0, −ω₂, −ω₃)``: the body rate the state stands for (none along d)."""
    return frame(X[:3], axis) @ np.array([0.0, -X[3], -X[4]])


def dynamics_matrix(X: np.ndarray, axis: int) -> np.ndarray:
    """(S3): ``A`` (5×5), the frame held fixed."""
    C = frame(X[:3], axis)
    A = np.zeros((5, 5))
    A[:3, :3] = -so3.hat(C @ np.array([0.0, -X[3], -X[4]]))
    A[:3, 3:] = -so3.hat(X[:3]) @ C[:, 1:]
    return A


def noise_map(X: np.ndarray, axis: int, h: float, as_published: bool) -> np.ndarray:
    """(S5): ``Γ`` (5×2) at the (propagated) state X; ``as_published`` selects the source's sign."""
    sign = 1.0 if as_published else -1.0
    G = np.zeros((5, 2))
    G[:3] = sign * 0.5 * h * h * so3.hat(X[:3]) @ frame(X[:3], axis)[:, 1:]
    G[3:] = h * np.eye(2)
    return G


def time_update(
    X: np.ndarray, x: np.ndarray, P: np.ndarray, axis: int, h: float, q: float, as_published: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(S3)–(S6): ``(X⁺, x̄, P⁻)``."""
    Phi = np.eye(5) + h * dynamics_matrix(X, axis)
    X_next = X.copy()
    X_next[:3] = X[:3] - h * np.cross(body_rate(X, axis), X[:3])
    G = noise_map(X_next, axis, h, as_published)
    return X_next, Phi @ x, Phi @ P @ Phi.T + q * G @ G.T


def switch(
    X: np.ndarray, P: np.ndarray, axis: int, switch_cos: float = SWITCH_COS
) -> tuple[np.ndarray, np.ndarray, int]:
    """(S2): ``(X, P, axis)``, switched to the other body axis when d is within ``acos(switch_cos)`` of this one."""
    d = X[:3] / np.linalg.norm(X[:3])
    if abs(d[axis]) <= switch_cos:
        return X, P, axis
    new = 1 - axis
    S = frame(d, new).T @ frame(d, axis)
    W = np.eye(5)
    W[3:, 3:] = S[1:, 1:]
    return W @ X, W @ P @ W.T, new


def measurement_update(
    X: np.ndarray, x_bar: np.ndarray, P_bar: np.ndarray, P_prev: np.ndarray, y: np.ndarray, normals: np.ndarray,
    meas_var: float, ekf_switch: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
    """(S7)–(S9): ``(X, x, P)``; the CKF form when ``max|P_prev| > ekf_switch``."""
    H = np.zeros((normals.shape[0], 5))
    H[:, :3] = normals
    S = H @ P_bar @ H.T + meas_var * np.eye(H.shape[0])
    K = np.linalg.solve(S, H @ P_bar).T  # P⁻Hᵀ S⁻¹ (S, P⁻ symmetric)
    innovation = y - normals @ X[:3]
    if np.max(np.abs(P_prev)) > ekf_switch:
        x = x_bar + K @ (innovation - H @ x_bar)
    else:
        x = K @ innovation
        X = X + x
    IKH = np.eye(5) - K @ H
    return X, x, IKH @ P_bar @ IKH.T + meas_var * K @ K.T


def sekf_step(
    X: np.ndarray, x: np.ndarray, P: np.ndarray, axis: int, h: float | None, y: np.ndarray | None,
    normals: np.ndarray, q: float, meas_var: float, ekf_switch: float, switch_cos: float = SWITCH_COS,
    as_published: bool = False,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:  # fmt: skip
    """One update of the source's ``Update``: switch (S2), time update over ``h`` (None: none, the first sample),
    then the sample ``y`` ``(m,)`` read by sensors of ``normals`` ``(m, 3)`` (None: no sample). ``(X, x, P, axis)``."""
    X, P, axis = switch(X, P, axis, switch_cos)
    P_prev = P
    if h is not None:
        X, x, P = time_update(X, x, P, axis, h, q, as_published)
    finite = np.all(np.isfinite(X)) and np.all(np.isfinite(x)) and np.all(np.isfinite(P))
    if y is not None and finite:  # a state already not finite is left to the caller's restart
        X, x, P = measurement_update(X, x, P, P_prev, y, normals, meas_var, ekf_switch)
    return X, x, 0.5 * (P + P.T), axis


class SunlineSEKF(CompiledEstimator):
    """The sun-line switch-EKF of the module docstring behind the estimator contract: samples are one measured unit
    direction ``(3,)`` (or ``(1, 3)``; a log ``(T, 3)`` or ``(T, 1, 3)``), in body axes; ω̂ is the body rate
    perpendicular to it.

    Parameters (keyword-only: the filter has no inertia)
    ----------------------------------------------------
    measurement_noise : the direction noise's standard deviation per component (σ; the source: √0.001).
    process_noise : q of (S6), (rad/s²)²: the rates' variance grows by h² q per update (the source: 0.01).
    sigma_direction0, sigma_rate0 : the initial standard deviations of d and of (ω₂, ω₃) (the source: √0.4, √0.004).
    direction0 : the initial d (``None``: the first valid sample); omega_hat0 : the initial body rate (its part
        along d is dropped; default 0, and then no estimate at the first valid sample).
    ekf_switch : the threshold on max|P| above which the update is the CKF's (the source's test: (4/3)²).
    as_published : True: Γ with the source's sign (module docstring).

    The state (``X``, ``x``, ``P``, ``axis``, the last time ``t``) is public; ``n_restarts`` counts the restarts.
    :meth:`update` runs :func:`sekf_step` (NumPy), :meth:`run` its compiled twin
    (:mod:`omegahat.baselines.sunline_kernel`); conversion (the one-direction input path of
    :mod:`omegahat.measurements`), refusal, counting and statuses are the compiled estimators' shared base.
    """

    def __init__(
        self,
        *,
        measurement_noise: float = float(np.sqrt(0.001)),
        process_noise: float = 0.01,
        sigma_direction0: float = float(np.sqrt(0.4)),
        sigma_rate0: float = float(np.sqrt(0.004)),
        direction0: ArrayLike | None = None,
        omega_hat0: ArrayLike | None = None,
        ekf_switch: float = (4.0 / 3.0) ** 2,
        as_published: bool = False,
    ) -> None:
        self.measurement_noise = float(as_positive(measurement_noise, "measurement_noise")[0])
        self.meas_var = self.measurement_noise**2
        self.q = float(as_positive(process_noise, "process_noise")[0])
        sd = float(as_positive(sigma_direction0, "sigma_direction0")[0])
        sr = float(as_positive(sigma_rate0, "sigma_rate0")[0])
        self.P0 = np.diag([sd**2] * 3 + [sr**2] * 2)
        self.direction0 = None if direction0 is None else as_vector3(direction0, "direction0")
        if self.direction0 is not None and not np.linalg.norm(self.direction0) > 0:
            raise ValueError("direction0 must be a non-zero vector")
        self.omega_hat0 = np.zeros(3) if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        self.ekf_switch = float(as_positive(ekf_switch, "ekf_switch")[0])
        self.as_published = bool(as_published)
        self._conversion = ms.conversion(1, False, ms.ROTATION_TOL, ms.QUAT_NORM_TOL, 0.0)
        self._configure_input(n_directions=1, rate_given=omega_hat0 is not None)
        self.reset()

    def _initial_state(self, d: np.ndarray) -> np.ndarray:
        """``X`` from a direction and ``omega_hat0`` (S1): ``(ω₂, ω₃) = −C₂₃ᵀ ω̂₀``."""
        return np.concatenate([d, -(frame(d, 0)[:, 1:].T @ self.omega_hat0)])

    def _reset_state(self) -> None:
        X = None if self.direction0 is None else self._initial_state(self.direction0)
        self._commit((X, np.zeros(5), self.P0.copy(), 0, None))

    def _commit(self, state: Any) -> None:
        self.X, self.x, self.P, self.axis, self.t = state

    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        """One update (:func:`sekf_step`): the NumPy path, the oracle of :meth:`run`."""
        value = np.full((1, 3), np.nan)
        code, info = self._check_one(t, m, kind, tau, value)
        if code >= ms.ERROR:
            return None, _NAN3, code, info
        b = value[0] if code == ms.OK else None
        X, x, P, axis, restarted = self.X, self.x, self.P, self.axis, False
        if X is None:
            if b is not None:
                X = self._initial_state(b)
        else:
            h = None if self.t is None else t - self.t
            with np.errstate(all="ignore"):  # an overflow is caught just below: the filter restarts
                X, x, P, axis = sekf_step(
                    X, x, P, axis, h, b, np.eye(3), self.q, self.meas_var, self.ekf_switch, SWITCH_COS,
                    self.as_published,
                )  # fmt: skip
            restarted = not (np.all(np.isfinite(X)) and np.all(np.isfinite(x)) and np.all(np.isfinite(P)))
            if restarted:  # from this sample, as at the start
                X, x, P, axis = None if b is None else self._initial_state(b), np.zeros(5), self.P0.copy(), 0
        state = (X, x, P, axis, float(t))
        if restarted:
            return state, _NAN3, ms.RESTARTED, 0.0
        return state, _NAN3 if X is None else body_rate(X, axis), int(code), float(info)

    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        """The log checked (compiled), then the compiled filter (:mod:`omegahat.baselines.sunline_kernel`)."""
        prev_t = np.nan if self.t is None else self.t
        values, codes, refusal = self._check_log(times, m, kind, taus)
        if refusal is not None:
            return refusal
        state = np.array([prev_t, self.t is not None, self.X is not None, self.axis])
        X = np.zeros(5) if self.X is None else self.X.copy()
        x, P = self.x.copy(), np.array(self.P, order="C")
        use = np.repeat((codes == ms.OK)[:, None], 3, axis=1)
        params = np.array([self.q, self.meas_var, self.ekf_switch, SWITCH_COS, 1.0 if self.as_published else 0.0])
        out, restarted = kernel.run_log(
            times, np.ascontiguousarray(values[:, 0]), use, np.eye(3), self.omega_hat0, params, state, X, x, P,
            self.P0,
        )  # fmt: skip
        new = (X if state[2] else None, x, P, int(state[3]), float(times[-1]))  # restarts: counted by the base
        return new, out, np.where(restarted, ms.RESTARTED, codes), -1, 0.0
