r"""Gyro-less multiplicative extended Kalman filter (MEKF) with the angular velocity in the state.

References: E. J. Lefferts, F. L. Markley, M. D. Shuster, "Kalman Filtering for Spacecraft Attitude
Estimation", JGCD 5(5), 1982; F. L. Markley, J. L. Crassidis, *Fundamentals of Spacecraft Attitude
Determination and Control*, Springer, 2014. Equations as in ``docs/baselines.md``, "The gyro-less multiplicative
EKF", written here on rotation matrices (``R`` body → inertial, ω in body axes)::

    nominal state   R̂, ω̂;  error state x = [δθ; δω] with R = R̂ Exp(δθ), ω = ω̂ + δω               (E1)
    process         dynamic:   J ω̇ = (Jω) × ω + τ + w_τ,  w_τ white with PSD q I  (N²·m²·s)
                    kinematic: ω̇ = w,                     w white with PSD q I  (rad²/s³)           (E2)
    linearised      δθ̇ = −ω̂× δθ + δω                                                              (E3)
                    δω̇ = J⁻¹((Jω̂)× − ω̂× J) δω + J⁻¹ w_τ   (dynamic)      δω̇ = w   (kinematic)
                    F = [[−ω̂×, I], [0, A]],  G = [[0], [J⁻¹]] (dynamic) or [[0], [I]] (kinematic),
                    A = J⁻¹((Jω̂)× − ω̂× J) (dynamic) or 0 (kinematic)
    propagate h     the nominal state in substeps turning at most ``max_angle`` (and at most ``max_step``
                    long): CF4, RK4 for ω̂ with the matching fourth-order Lie-group step for R̂ (dynamic),
                    R̂ ← R̂ Exp(ω̂ h) (kinematic); the torque held or interpolated (``torque_hold``);
                    P ← Φ P Φᵀ + Q_d in substeps of at most 0.2 rad, Φ and Q_d by the truncated series
                    (K2), (K3) of :mod:`omegahat.kernels.ekf`, with W = ω̂× and A frozen per substep  (E4)
    attitude fix    R_m = R Exp(ν), ν ~ N(0, σ² I); dq = q̂ᶜ ⊗ q_m (the quaternion of R̂ᵀ R_m, scalar ≥ 0);
                    z = 2 dq_vec / dq_w;  H = [I, 0];  R_meas = σ² I                                 (E5)
    vector fix      b_i = Rᵀ v_i + ν_i, ν_i ~ N(0, σ² I); b̂_i = R̂ᵀ v_i; z_i = b_i − b̂_i;
                    H_i = [b̂_i×, 0];  R_meas = σ² I                                                  (E6)
    update          S = H P Hᵀ + R_meas; K = P Hᵀ S⁻¹; δx̂ = K z;
                    P ← (I − K H) P (I − K H)ᵀ + K R_meas Kᵀ (Joseph form)                           (E7)
    reset           R̂ ← R̂ Exp(δθ̂);  ω̂ ← ω̂ + δω̂                                                    (E8)
                    then R̂ ← R̂ (3I − R̂ᵀR̂)/2: one Newton–Schulz step, R̂ kept a rotation to rounding

(E6) follows from ``Rᵀ v = Exp(−δθ) R̂ᵀ v ≈ b̂ + b̂ × δθ``. The filter converges only locally: started far from
the truth with a small covariance it can lock on a wrong solution or diverge. The known torque passed with a
sample is held over the interval that follows it (``torque_hold="zero"``, the default, as the sampled Sarras
estimator) or interpolated from it to the next sample's (``"linear"``).

Initial state: ``R0`` if given, else the first valid measurement (the attitude itself, or the least-squares
attitude from the directions by SVD — Wahba's problem), with ``P_θθ = sigma_theta0² I``; ``omega0`` with
``P_ωω = sigma_omega0² I``.

The NumPy functions below are the filter, written to be read, in NumPy and SciPy only (SciPy's ``Rotation``
for Exp and the quaternion of (E5) and Wahba's problem; ``cf4_step``, the NumPy step of
:mod:`omegahat.simulation.rigid_body`, for the dynamic nominal state): they are the oracle. :class:`MEKF` is a thin
stateful shell: :meth:`MEKF.update` (one sample) runs on these functions, :meth:`MEKF.run` (a whole log) on their
compiled twin, :mod:`omegahat.kernels.ekf` (the same step omegahat's default estimator runs), tested against them.
``python benchmarks/mekf_speed.py`` measures both.

Input: through :mod:`omegahat.measurements`, like every estimator (the same checks, tolerances and messages):
attitudes as matrices, quaternions (``scalar_first``) or ``Rotation``; direction samples are normalised and
skipped when nearly collinear (``min_angle_deg``); a non-finite sample is skipped (propagation only).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Literal, TypeAlias, get_args

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat.baselines import mekf_kernel as kernel
from omegahat.conversion import as_references, read_only
from omegahat.interface import Measurement, TorqueHold, one_of
from omegahat.kernels.ekf import COVARIANCE_SUBSTEP_ANGLE, MAX_SUBSTEPS, NOMINAL_SUBSTEP_ANGLE
from omegahat.observer.compiled import CompiledEstimator
from omegahat.simulation.rigid_body import RigidBody, Torque, cf4_step
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = [
    "MEKF",
    "MODELS",
    "FilterStep",
    "Model",
    "attitude_innovation",
    "discretize",
    "initial_attitude",
    "process_jacobian",
    "propagate_with_transition",
    "substeps",
    "update",
    "vector_innovation",
]

#: the process model (E2): Euler's equations with J and τ known, or a rate driven by white noise
Model: TypeAlias = Literal["dynamic", "kinematic"]
MODELS: tuple[str, ...] = get_args(Model)
_NO_RATE = np.full(3, np.nan)


def _exp(v) -> np.ndarray:
    """``Exp(v)``, the rotation matrix of the rotation vector v (SciPy)."""
    return Rotation.from_rotvec(v).as_matrix()


def _hat(v) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def process_jacobian(
    omega_hat: np.ndarray, J: np.ndarray, J_inv: np.ndarray, model: str
) -> tuple[np.ndarray, np.ndarray]:
    """F and G of (E3), shapes ``(6, 6)`` and ``(6, 3)``."""
    F = np.zeros((6, 6))
    G = np.zeros((6, 3))
    F[:3, :3] = -_hat(omega_hat)
    F[:3, 3:] = np.eye(3)
    if model == "dynamic":
        F[3:, 3:] = J_inv @ (_hat(J @ omega_hat) - _hat(omega_hat) @ J)
        G[3:] = J_inv
    else:
        G[3:] = np.eye(3)
    return F, G


def discretize(
    omega_hat: np.ndarray, J: np.ndarray, J_inv: np.ndarray, model: str, q: float, dt: float, q_a: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(E4) over one substep at ``omega_hat``: the transition Φ (Φ_θθ exact, the other blocks to third order) and
    the process covariance Q_d (its leading two orders), as (K2), (K3) of :mod:`omegahat.kernels.ekf`; with
    ``q_a`` (the unknown angular acceleration's random-walk PSD) the 9×9 forms of (K5)."""
    F, G = process_jacobian(omega_hat, J, J_inv, model)
    W, A = _hat(omega_hat), F[3:, 3:]
    U2 = A - W
    U3 = -W @ U2 + A @ A
    Phi = np.zeros((6, 6))
    Phi[:3, :3] = _exp(-dt * np.asarray(omega_hat))
    Phi[:3, 3:] = dt * np.eye(3) + dt**2 / 2 * U2 + dt**3 / 6 * U3
    Phi[3:, 3:] = np.eye(3) + dt * A + dt**2 / 2 * A @ A + dt**3 / 6 * A @ A @ A
    Qw = q * G[3:] @ G[3:].T
    Qd = np.zeros((6, 6))
    Qd[:3, :3] = dt**3 / 3 * Qw + dt**4 / 8 * (U2 @ Qw + Qw @ U2.T)
    Qd[:3, 3:] = dt**2 / 2 * Qw + dt**3 / 6 * U2 @ Qw + dt**3 / 3 * Qw @ A.T
    Qd[3:, :3] = Qd[:3, 3:].T
    Qd[3:, 3:] = dt * Qw + dt**2 / 2 * (A @ Qw + Qw @ A.T)
    if q_a is None:
        return Phi, Qd
    I3 = np.eye(3)
    Phi9, Qd9 = np.eye(9), np.zeros((9, 9))
    Phi9[:6, :6], Qd9[:6, :6] = Phi, Qd
    Phi9[:3, 6:] = dt**2 / 2 * I3 + dt**3 / 6 * U2 + dt**4 / 24 * U3
    Phi9[3:6, 6:] = dt * I3 + dt**2 / 2 * A + dt**3 / 6 * A @ A
    coeff = np.array(
        [[dt**5 / 20, dt**4 / 8, dt**3 / 6], [dt**4 / 8, dt**3 / 3, dt**2 / 2], [dt**3 / 6, dt**2 / 2, dt]]
    )
    return Phi9, Qd9 + q_a * np.kron(coeff, I3)


def _turn(h: float, omega_hat: np.ndarray, J_inv: np.ndarray, tau0: ArrayLike, tau1: ArrayLike) -> float:
    """``h(|ω̂| + h max|J⁻¹τ|)``: how far the body may turn over the interval (the kernel's rule)."""
    accel = max(np.linalg.norm(J_inv @ np.asarray(tau0)), np.linalg.norm(J_inv @ np.asarray(tau1)))
    return float(h * (np.linalg.norm(omega_hat) + h * accel))


def substeps(
    h: float, omega_hat: np.ndarray, J_inv: np.ndarray, tau0: ArrayLike, tau1: ArrayLike, max_step: float,
    max_angle: float,
) -> int:  # fmt: skip
    """``max(1, ⌈h/max_step⌉, ⌈h(|ω̂| + h max|J⁻¹τ|)/max_angle⌉)``, at most ``MAX_SUBSTEPS``: the rule of
    :func:`omegahat.kernels.ekf.ekf_substeps`."""
    angle = _turn(h, omega_hat, J_inv, tau0, tau1)
    n = 1
    if np.isfinite(max_step):
        n = max(n, int(np.ceil(h / max_step - 1e-12)))
    if np.isfinite(max_angle):
        n = max(n, int(np.ceil(angle / max_angle)) if angle < MAX_SUBSTEPS * max_angle else MAX_SUBSTEPS)
    return min(n, MAX_SUBSTEPS)


def propagate_with_transition(
    R: np.ndarray,
    omega: np.ndarray,
    P: np.ndarray,
    h: float,
    tau: ArrayLike,
    body: RigidBody,
    q: float,
    model: str,
    max_step: float = np.inf,
    max_angle: float = NOMINAL_SUBSTEP_ANGLE,
    tau_end: ArrayLike | None = None,
    q_a: float | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(E4) over ``h`` seconds, the torque ``tau`` at the start and ``tau_end`` (default ``tau``: held) at the end;
    returns ``(R, omega, P, Φ)``, ``Φ`` the interval's error-state transition (the product of the covariance
    substeps' transitions, ``P ← Φ P Φᵀ + Q``: what a fixed-interval smoother needs). The covariance in substeps of
    at most ``COVARIANCE_SUBSTEP_ANGLE``, each spanning a whole number of the nominal state's
    (:func:`omegahat.kernels.ekf.ekf_propagate`; an interval too far to integrate fails, ω̂ NaN, as there). With
    ``q_a`` (K5), ``omega`` is ``[ω̂, â]`` (6) and P is 9×9; the torque ``J â`` is added to the known one."""
    omega = np.asarray(omega, dtype=float)
    accel = omega[3:] if q_a is not None else np.zeros(3)
    omega = omega[:3]
    tau0 = np.asarray(tau, dtype=float) + body.J @ accel
    tau1 = tau0 if tau_end is None else np.asarray(tau_end, dtype=float) + body.J @ accel
    if not _turn(h, omega, body.J_inv, tau0, tau1) < MAX_SUBSTEPS * COVARIANCE_SUBSTEP_ANGLE:  # too far: it fails
        nan = np.full(3, np.nan)
        return R, (nan if q_a is None else np.concatenate([nan, accel])), P, np.eye(P.shape[0])
    n_cov = substeps(h, omega, body.J_inv, tau0, tau1, max_step, COVARIANCE_SUBSTEP_ANGLE)
    per_cov = -(-substeps(h, omega, body.J_inv, tau0, tau1, max_step, max_angle) // n_cov)
    n = n_cov * per_cov
    dt = h / n
    torque = Torque.of_time(lambda s: tau0 + (tau1 - tau0) * (s / h))
    Phi_total = np.eye(P.shape[0])
    for jc in range(n_cov):
        Phi, Qd = discretize(omega, body.J, body.J_inv, model, q, h / n_cov, q_a)
        P = Phi @ P @ Phi.T + Qd
        Phi_total = Phi @ Phi_total
        for j in range(jc * per_cov, (jc + 1) * per_cov):
            if model == "dynamic":
                R, omega = cf4_step(body, R, omega, j * dt, dt, torque)
            else:
                R = R @ _exp(dt * omega)
    return R, (omega if q_a is None else np.concatenate([omega, accel])), 0.5 * (P + P.T), Phi_total


def attitude_innovation(R_hat: np.ndarray, R_meas: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(E5): ``z = 2 dq_vec / dq_w`` of ``dq`` = quaternion of ``R̂ᵀ R_m`` (scalar ≥ 0), and ``H = [I, 0]``."""
    dq = Rotation.from_matrix(R_hat.T @ R_meas).as_quat(canonical=True)  # scalar last, w ≥ 0
    z = 2.0 * dq[:3] / dq[3]
    H = np.hstack([np.eye(3), np.zeros((3, 3))])
    return z, H


def vector_innovation(R_hat: np.ndarray, b_meas: np.ndarray, references: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(E6): ``z = b − R̂ᵀ v`` stacked ``(3n,)`` and ``H`` ``(3n, 6)``."""
    b_hat = references @ R_hat  # rows: R̂ᵀ v_i
    z = (b_meas - b_hat).ravel()
    H = np.zeros((3 * len(references), 6))
    for i, bh in enumerate(b_hat):
        H[3 * i : 3 * i + 3, :3] = _hat(bh)
    return z, H


def update(
    R: np.ndarray, omega: np.ndarray, P: np.ndarray, z: np.ndarray, H: np.ndarray, meas_var: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(E7) then the reset (E8); returns ``(R, omega, P)``. With a 9×9 P (K5) ``omega`` is ``[ω̂, â]`` and H is
    padded with zeros."""
    n = P.shape[0]
    H = np.hstack([H, np.zeros((H.shape[0], n - H.shape[1]))])
    S = H @ P @ H.T + meas_var * np.eye(H.shape[0])
    K = np.linalg.solve(S, H @ P).T  # P Hᵀ S⁻¹ (S and P symmetric)
    dx = K @ z
    IKH = np.eye(n) - K @ H
    P = IKH @ P @ IKH.T + meas_var * (K @ K.T)
    R = R @ _exp(dx[:3])
    R = R @ (1.5 * np.eye(3) - 0.5 * R.T @ R)  # one Newton–Schulz step: R̂ kept a rotation to rounding (E8)
    return R, omega + dx[3:], 0.5 * (P + P.T)


def initial_attitude(b: ArrayLike, references: ArrayLike) -> np.ndarray:
    """The first fix from directions: Wahba's least-squares attitude ``argmin_R Σ |v_i − R b_i|²`` (SciPy's
    ``align_vectors``, unit weights) for unit body directions ``b`` and references ``v`` ``(n, 3)``."""
    return Rotation.align_vectors(references, b)[0].as_matrix()


@dataclass(frozen=True)
class FilterStep:
    """One step of the filter: the prior ``(R_prior, x_prior, P_prior)`` after propagation (None attitude before the
    first fix), the interval's transition ``Phi`` (None at the first sample), and the posterior. ``x`` is ``ω̂``
    ``(3,)``, or ``[ω̂, â]`` ``(6,)`` with the unknown-acceleration state; ``P`` matches (6×6 or 9×9)."""

    R_prior: np.ndarray | None
    x_prior: np.ndarray
    P_prior: np.ndarray
    Phi: np.ndarray | None
    R: np.ndarray | None
    x: np.ndarray
    P: np.ndarray


def _finite(R: np.ndarray | None, x: np.ndarray, P: np.ndarray) -> bool:
    """Whether the filter's state is finite (R̂ when there is one, the rate part x, P): the guard."""
    return bool(np.all(np.isfinite(x)) and np.all(np.isfinite(P)) and (R is None or np.all(np.isfinite(R))))


class MEKF(CompiledEstimator):
    """The gyro-less MEKF of the module docstring behind the estimator contract.

    :meth:`update` runs the NumPy functions above (the oracle), :meth:`run` their compiled twin
    (:mod:`omegahat.baselines.mekf_kernel`); conversion, refusal, counting and statuses are the compiled
    estimators' shared base (:class:`omegahat.observer.compiled.CompiledEstimator`).

    Parameters
    ----------
    J : array_like, optional
        Inertia (3 numbers, 9 numbers or 3×3); needed by the dynamic model, ignored by the kinematic one; the one
        positional argument (the others are keyword-only).
    model : {"dynamic", "kinematic"}, optional
        ``"dynamic"`` (J and τ known; q is the torque-noise PSD, N²·m²·s) or ``"kinematic"`` (ω̇ white noise; q in
        rad²/s³).
    q : float, optional
        Process-noise PSD (the filter's one tuning knob).
    measurement_noise : float, optional
        The attitude noise (rad, one standard deviation per axis), or that of each direction component.
    references : array_like, optional
        ``None`` for attitude measurements, else the known inertial directions ``(n, 3)``; samples are then
        body-frame measurements ``(n, 3)``.
    omega_hat0, sigma_omega0 : optional
        Initial rate estimate (rad/s; default 0, and then no estimate at the first fix) and its standard deviation.
    R0, sigma_theta0 : optional
        Initial attitude (``None``: the first valid measurement) and its standard deviation (rad; default
        ``measurement_noise`` for attitude fixes, 0.1 rad for directions).
    max_step, max_angle : float, optional
        Bounds on a propagation substep, s (default: none) and rad (the body's turn).
    torque_hold : {"zero", "linear"}, optional
        ``"zero"`` (default: a sample's torque held until the next) or ``"linear"`` (interpolated to the next
        sample's torque; causal, as the next torque arrives with the next sample).
    disturbance_noise, sigma_accel0 : optional
        None (default) or σ_d (rad/s^2.5): the state then carries an unknown angular acceleration ``a`` (the torque
        ``J a`` the model lacks: a disturbance, or an inertia error's effect), a random walk of PSD ``σ_d²`` started
        at 0 with standard deviation ``sigma_accel0`` (rad/s²): (K5) of :mod:`omegahat.kernels.ekf`. ``accel``
        holds its estimate.
    scalar_first, rotation_tol, quat_norm_tol, min_angle_deg : optional
        The input checks of :mod:`omegahat.measurements` (the same for every estimator; ``R0`` is checked with the
        same tolerances).

    Examples
    --------
    Noisy attitudes (1 mrad per axis) of a body turning at a constant rate, 100 Hz, no inertia known:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import MEKF
    >>> w, t = np.array([0.3, -0.2, 0.5]), np.arange(0.0, 2.0, 0.01)  # rad/s (body axes), s
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    >>> q = (Rotation.from_rotvec(np.outer(t, w)) * noise).as_quat()
    >>> est = MEKF(model="kinematic", measurement_noise=1e-3).run(t, q)
    >>> print(" ".join(f"{x:.2f}" for x in est.omega[-1]))
    0.30 -0.20 0.50
    """

    def __init__(
        self,
        J: ArrayLike | None = None,
        *,
        model: Model = "dynamic",
        q: float = 1e-4,
        measurement_noise: float = 1e-3,
        references: ArrayLike | None = None,
        omega_hat0: ArrayLike | None = None,
        sigma_omega0: float = 1.0,
        R0: ArrayLike | Rotation | None = None,
        sigma_theta0: float | None = None,
        max_step: float = np.inf,
        max_angle: float = NOMINAL_SUBSTEP_ANGLE,
        torque_hold: TorqueHold = "zero",
        disturbance_noise: float | None = None,
        sigma_accel0: float = 1.0,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
    ) -> None:
        self.model: Model = one_of("model", model, Model)
        if model == "dynamic" and J is None:
            raise ValueError("J must be given for the dynamic model (use model='kinematic' when it is unknown)")
        self.body = RigidBody(as_inertia(np.eye(3) if J is None else J))
        self.q = float(as_positive(q, "q")[0])
        self.measurement_noise = float(as_positive(measurement_noise, "measurement_noise")[0])
        self.references = None if references is None else as_references(references)
        self.omega_hat0 = np.zeros(3) if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        self.sigma_omega0 = float(as_positive(sigma_omega0, "sigma_omega0")[0])
        self.q_a = (
            None if disturbance_noise is None else float(as_positive(disturbance_noise, "disturbance_noise")[0]) ** 2
        )
        self.sigma_accel0 = float(as_positive(sigma_accel0, "sigma_accel0")[0])
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        self.min_angle_deg = ms.min_angle(min_angle_deg)
        self.R0: np.ndarray | None = None
        if R0 is not None:
            tols = {"rotation_tol": self.rotation_tol, "quat_norm_tol": self.quat_norm_tol}
            self.R0 = ms.as_rotation(R0, "R0", scalar_first=self.scalar_first, **tols)
        if sigma_theta0 is None:
            sigma_theta0 = self.measurement_noise if self.references is None else 0.1
        self.sigma_theta0 = float(as_positive(sigma_theta0, "sigma_theta0")[0])
        if not max_step > 0:  # inf (no bound) is allowed
            raise ValueError(f"max_step must be positive (inf: no bound); got {max_step!r}")
        self.max_step = float(max_step)
        self.max_angle = float(as_positive(max_angle, "max_angle")[0])
        self.torque_hold: TorqueHold = one_of("torque_hold", torque_hold, TorqueHold)
        n = None if self.references is None else self.references.shape[0]
        self._conversion = ms.conversion(n, self.scalar_first, self.rotation_tol, self.quat_norm_tol, min_angle_deg)
        self._configure_input(n_directions=n, rate_given=omega_hat0 is not None)
        self.reset()

    def prior_covariance(self) -> np.ndarray:
        """``P₀ = diag(σ_θ0² I, σ_ω0² I[, σ_a0² I])``: the start's, and a restart's (the guard)."""
        prior = [self.sigma_theta0**2] * 3 + [self.sigma_omega0**2] * 3
        return np.diag(prior if self.q_a is None else prior + [self.sigma_accel0**2] * 3)

    def _reset_state(self) -> None:
        self.R: np.ndarray | None = None if self.R0 is None else self.R0.copy()
        self.omega = self.omega_hat0.copy()
        self.accel = np.zeros(3)
        self.P = self.prior_covariance()
        self.t: float | None = None
        self._tau = np.zeros(3)
        self.last_step: FilterStep | None = None

    def step(self, t: float, measurement: Measurement, torque: ArrayLike | None = None) -> FilterStep:
        """:meth:`update`, returning the step's prior, transition and posterior (:class:`FilterStep`): the record a
        fixed-interval smoother (:mod:`omegahat.baselines.rts`) runs backwards over."""
        self.update(t, measurement, torque)
        return self.last_step  # type: ignore[return-value]  # set by every accepted update

    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        """Propagate to ``t`` (with the previous sample's torque held, or the line to this one's), fuse the sample:
        the NumPy path, the oracle of :meth:`run`. A skipped sample is propagated through only."""
        value = np.full((3 if self.references is None else self.references.shape[0], 3), np.nan)
        code, info = self._check_one(t, m, kind, tau, value)
        if code >= ms.ERROR:
            return None, _NO_RATE, code, info
        R, P = self.R, self.P
        omega = self.omega if self.q_a is None else np.concatenate([self.omega, self.accel])
        Phi = None
        if self.t is not None and R is not None:
            R, omega, P, Phi = propagate_with_transition(
                R, omega, P, t - self.t, self._tau, self.body, self.q, self.model, self.max_step, self.max_angle,
                tau if self.torque_hold == "linear" else None, self.q_a,
            )  # fmt: skip
        prior = (R, omega, P)
        propagated = _finite(R, omega, P)  # the guard: no fix on a state that is not finite
        if propagated and code == ms.OK:  # else skipped: propagated through only
            if R is None:  # the first fix initialises the attitude
                R = value if self.references is None else initial_attitude(value, self.references)
            else:
                if self.references is None:
                    z, H = attitude_innovation(R, value)
                else:
                    z, H = vector_innovation(R, value, self.references)
                R, omega, P = update(R, omega, P, z, H, self.measurement_noise**2)
        record = FilterStep(prior[0], prior[1], prior[2], Phi, R, omega, P)
        if not (propagated and _finite(R, omega, P)):  # the guard (mekf_kernel's docstring): restart from the sample
            R = None
            if code == ms.OK:
                R = value if self.references is None else initial_attitude(value, self.references)
            omega = self.omega_hat0.copy() if self.q_a is None else np.concatenate([self.omega_hat0, np.zeros(3)])
            return (R, omega, self.prior_covariance(), t, tau.copy(), record), _NO_RATE, ms.RESTARTED, 0.0
        return (R, omega, P, t, tau.copy(), record), omega[:3], int(code), float(info)

    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        """The log checked (compiled), then the compiled filter (:mod:`omegahat.baselines.mekf_kernel`)."""
        values, codes, refusal = self._check_log(times, m, kind, taus)
        if refusal is not None:
            return refusal
        directions = self.references is not None
        state = np.array(
            [np.nan if self.t is None else self.t, self.t is not None, self.R is not None, *self.omega, *self.accel]
        )
        out, R, P, _, n_restarts = kernel.run_log(
            times,
            np.ascontiguousarray(values),
            codes == ms.OK,
            taus,
            self.references if directions else read_only(np.zeros((0, 3))),
            directions,
            self.model == "dynamic",
            read_only(np.ascontiguousarray(self.body.J)),  # read-only as the supervised filter's: one compilation
            read_only(np.ascontiguousarray(self.body.J_inv)),
            self.q,
            self.measurement_noise**2,
            self.max_step,
            self.max_angle,
            self.torque_hold == "linear",
            0.0 if self.q_a is None else self.q_a,
            state,
            np.zeros((3, 3)) if self.R is None else np.array(self.R, dtype=float, order="C"),
            np.ascontiguousarray(self.P, dtype=float),
            np.ascontiguousarray(self._tau, dtype=float),
            np.ascontiguousarray(self.omega_hat0, dtype=float),
            self.prior_covariance(),
            np.zeros(4),  # the innovations' likelihood, not kept here (omegahat.identification reads it)
            np.zeros((0, 3, 3)),  # nor the rate covariances
        )
        if n_restarts:  # the kernel writes NaN only where it restarted
            codes[~np.all(np.isfinite(out), axis=1)] = ms.RESTARTED
        omega = state[3:6] if self.q_a is None else state[3:9]
        return (R if state[2] else None, omega.copy(), P, float(times[-1]), taus[-1].copy(), None), out, codes, -1, 0.0

    def _commit(self, state: Any) -> None:
        self.R, omega, self.P, self.t, self._tau, self.last_step = state
        self.omega = omega[:3].copy()
        if self.q_a is not None:
            self.accel = omega[3:6].copy()
