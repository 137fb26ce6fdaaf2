r"""A rigid body and a ground-truth integrator that keeps its attitude on SO(3).

Model (frames as in ``so3``: R maps body to inertial, ω in body axes, τ in body axes)::

    J ω̇ = (J ω) × ω + τ(t, R, ω)          Euler's equations
    Ṙ   = R ω×                            attitude kinematics

Invariants of the torque-free motion: the kinetic energy ``½ ωᵀ J ω``, the body-frame momentum norm ``|J ω|``
and the inertial angular momentum ``L = R J ω`` (a constant vector).

Integrator: the fourth-order commutator-free Lie group method **CF4** of E. Celledoni, A. Marthinsen and
B. Owren, "Commutator-free Lie group methods", Future Generation Computer Systems 19(3), 2003 (Section 4).
It is built on the classical RK4 tableau; written for the right action ``Ṙ = R ω×`` with ``Ω_i = ω_i×`` the
stage velocities and step h::

    stage 1:  R₁ = R,                          ω₁ = ω                 Ω₁, ω̇₁ evaluated at (t,       R₁, ω₁)
    stage 2:  R₂ = R exp(h Ω₁/2),              ω₂ = ω + h ω̇₁/2        Ω₂, ω̇₂ at (t + h/2, R₂, ω₂)
    stage 3:  R₃ = R exp(h Ω₂/2),              ω₃ = ω + h ω̇₂/2        Ω₃, ω̇₃ at (t + h/2, R₃, ω₃)
    stage 4:  R₄ = R₂ exp(h (Ω₃ − Ω₁/2)),      ω₄ = ω + h ω̇₃          Ω₄, ω̇₄ at (t + h,   R₄, ω₄)
    update:   R⁺ = R exp(h(Ω₁/4 + Ω₂/6 + Ω₃/6 − Ω₄/12)) exp(h(−Ω₁/12 + Ω₂/6 + Ω₃/6 + Ω₄/4))
              ω⁺ = ω + h (ω̇₁ + 2 ω̇₂ + 2 ω̇₃ + ω̇₄)/6                  (classical RK4)

(The paper writes the left action ``y' = A(y) y``; ``X = Rᵀ`` obeys ``X' = −Ω X``, and transposing its
formulas gives the right-action ones above, with the factors in reverse order: the exponential weighted
towards the early stages acts first, so it sits next to R; swapping the two costs two orders of accuracy.)
The attitude is only ever multiplied by exact rotations (exponentials of rotation vectors), never projected.
The compiled kernel carries
it as a unit quaternion (``R exp(A) exp(B)`` is ``q ⊗ q(A) ⊗ q(B)``) and rescales q to unit norm each step,
which leaves the rotation unchanged: a product of matrices instead drifts from orthogonality by about 4e-17
per step (4e-12 after 1e5 steps, paper's body over 100 s), the quaternion form stays at 2e-15.

Torque: a :class:`~omegahat.simulation.torque.Torque` says explicitly what it depends on (nothing, a constant, a
sinusoid, time, or time and state).
When it does not depend on the state the whole integration runs in a compiled kernel (Numba), with the torque
tabulated beforehand at every stage time; :func:`cf4_step` is the plain NumPy step, the readable oracle the
kernel is tested against and the path used for state-dependent torques.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.kernels.dynamics import cf4_increment
from omegahat.kernels.rotation import matrix_from_quat, quat_multiply, store
from omegahat.kernels.vec3 import mat3
from omegahat.simulation.torque import Torque, as_torque
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = ["RigidBody", "Trajectory", "cf4_step", "integrate"]


class RigidBody:
    """A rigid body with inertia ``J``: Euler's equations and the invariants of torque-free motion.

    ``J ω̇ = (J ω) × ω + τ`` (module docstring; ω and τ in body axes). Methods, each on stacked ``(*B, 3)``
    rates: :meth:`omega_dot` (ω̇ = J⁻¹((Jω) × ω + τ)), :meth:`kinetic_energy` (½ ωᵀ J ω), :meth:`momentum_norm`
    (|J ω|) and :meth:`inertial_momentum` (L = R J ω). :func:`integrate` moves it in time. Attributes ``J`` and
    ``J_inv`` hold the inertia and its inverse as ``(3, 3)`` arrays.

    Parameters
    ----------
    J : array_like
        Inertia, symmetric positive definite (kg·m²): 3 numbers = diagonal, 9 = full.

    Raises
    ------
    ValueError
        If ``J`` is not a finite symmetric positive definite inertia.

    Examples
    --------
    >>> import numpy as np
    >>> from omegahat import RigidBody
    >>> from omegahat.simulation.rigid_body import integrate
    >>> body = RigidBody([3.0, 2.0, 1.0])
    >>> omega = np.array([2.0, -1.0, 0.6])
    >>> print(body.omega_dot(omega).round(3).tolist(), f"{body.kinetic_energy(omega):.3f}")
    [-0.2, -1.2, -2.0] 7.180
    >>> motion = integrate(body, np.eye(3), omega, np.linspace(0.0, 10.0, 11), max_step=1e-2)
    >>> energy = body.kinetic_energy(motion.omega)  # conserved without torque
    >>> L = body.inertial_momentum(motion.R, motion.omega)  # a constant vector without torque
    >>> print(np.allclose(energy, energy[0], rtol=1e-7), np.allclose(L, L[0], atol=1e-6))
    True True
    """

    def __init__(self, J: ArrayLike) -> None:
        self.J = as_inertia(J)
        self.J_inv = np.linalg.inv(self.J)

    def __repr__(self) -> str:
        return f"RigidBody(J={self.J.tolist()})"

    def omega_dot(self, omega: ArrayLike, torque: ArrayLike | None = None) -> np.ndarray:
        """ω̇ = J⁻¹((Jω) × ω + τ). ``omega (*B, 3)``, ``torque`` broadcastable to it (None = 0)."""
        omega = np.asarray(omega, dtype=float)
        Jw = omega @ self.J.T
        rhs = so3.cross(Jw, omega)
        if torque is not None:
            rhs = rhs + np.asarray(torque, dtype=float)
        return rhs @ self.J_inv.T

    def kinetic_energy(self, omega: ArrayLike) -> np.ndarray:
        """½ ωᵀ J ω. ``(*B, 3) -> (*B,)``."""
        omega = np.asarray(omega, dtype=float)
        return 0.5 * np.einsum("...i,ij,...j->...", omega, self.J, omega)

    def momentum_norm(self, omega: ArrayLike) -> np.ndarray:
        """|J ω|, the norm of the angular momentum (same in body and inertial axes). ``(*B, 3) -> (*B,)``."""
        return np.linalg.norm(np.asarray(omega, dtype=float) @ self.J.T, axis=-1)

    def inertial_momentum(self, R: ArrayLike, omega: ArrayLike) -> np.ndarray:
        """L = R J ω, the angular momentum in inertial axes. ``(*B, 3, 3), (*B, 3) -> (*B, 3)``."""
        Jw = np.asarray(omega, dtype=float) @ self.J.T
        return np.einsum("...ij,...j->...i", np.asarray(R, dtype=float), Jw)


class Trajectory(NamedTuple):
    """Samples of a motion: ``t (T,)``, ``R (T, 3, 3)``, ``omega (T, 3)``, ``torque (T, 3)``."""

    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    torque: np.ndarray


# ------------------------------------------------------------------------------------------------------------
# Plain NumPy step (the oracle)


def cf4_step(
    body: RigidBody, R: ArrayLike, omega: ArrayLike, t: float, h: float, torque: Torque
) -> tuple[np.ndarray, np.ndarray]:
    """One CF4 step of size h from ``(t, R, omega)`` (module docstring), returns ``(R⁺, ω⁺)``."""
    R = np.asarray(R, dtype=float)
    w1 = np.asarray(omega, dtype=float)
    # Stage 1
    a1 = body.omega_dot(w1, torque(t, R, w1))
    # Stage 2: R₂ = R exp(h Ω₁/2)
    R2 = R @ so3.exp(0.5 * h * w1)
    w2 = w1 + 0.5 * h * a1
    a2 = body.omega_dot(w2, torque(t + 0.5 * h, R2, w2))
    # Stage 3: R₃ = R exp(h Ω₂/2)
    R3 = R @ so3.exp(0.5 * h * w2)
    w3 = w1 + 0.5 * h * a2
    a3 = body.omega_dot(w3, torque(t + 0.5 * h, R3, w3))
    # Stage 4: R₄ = R₂ exp(h(Ω₃ − Ω₁/2))
    R4 = R2 @ so3.exp(h * (w3 - 0.5 * w1))
    w4 = w1 + h * a3
    a4 = body.omega_dot(w4, torque(t + h, R4, w4))
    # Update: two exponentials for R, classical RK4 for ω
    first = h * (w1 / 4 + w2 / 6 + w3 / 6 - w4 / 12)  # weighted to the early stages: acts first
    second = h * (-w1 / 12 + w2 / 6 + w3 / 6 + w4 / 4)
    R_next = R @ so3.exp(first) @ so3.exp(second)
    w_next = w1 + h * (a1 + 2 * a2 + 2 * a3 + a4) / 6
    return R_next, w_next


# ------------------------------------------------------------------------------------------------------------
# Compiled kernel for torques that do not depend on the state


@numba.njit(cache=True)
def _cf4_kernel(q0, w0, J, J_inv, h, tau_stages, record):
    """CF4 steps (:func:`omegahat.kernels.dynamics.cf4_increment`) of sizes ``h (S,)``; torque ``tau_stages
    (S, 3, 3)`` at t, t + h/2, t + h of each step.

    The attitude is carried as a unit quaternion ``q0`` (scalar last): ``R exp(A) exp(B)`` is ``q ⊗ q(A) ⊗ q(B)``,
    renormalised (a rescaling that leaves the rotation unchanged) so that R(q) stays orthogonal to rounding over
    millions of steps, where a product of matrices drifts by ~1e-17 per step. Returns the state after the steps
    flagged in ``record (S,)`` (in order), plus the initial state first.
    """
    n_out = 1
    for s in range(h.size):
        if record[s]:
            n_out += 1
    R_out = np.empty((n_out, 3, 3))
    w_out = np.empty((n_out, 3))
    Jm, Jinv = mat3(J), mat3(J_inv)
    qx, qy, qz, qw = q0[0], q0[1], q0[2], q0[3]
    w0_, w1_, w2_ = w0[0], w0[1], w0[2]
    store(matrix_from_quat(qx, qy, qz, qw), R_out[0])
    w_out[0, 0], w_out[0, 1], w_out[0, 2] = w0_, w1_, w2_
    k = 1
    for s in range(h.size):
        p, w = cf4_increment(Jm, Jinv, w0_, w1_, w2_, h[s], tau_stages[s, 0], tau_stages[s, 1], tau_stages[s, 2])
        w0_, w1_, w2_ = w
        qx, qy, qz, qw = quat_multiply(qx, qy, qz, qw, p[0], p[1], p[2], p[3])
        norm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
        qx, qy, qz, qw = qx / norm, qy / norm, qz / norm, qw / norm
        if record[s]:
            store(matrix_from_quat(qx, qy, qz, qw), R_out[k])
            w_out[k, 0], w_out[k, 1], w_out[k, 2] = w0_, w1_, w2_
            k += 1
    return R_out, w_out


# ------------------------------------------------------------------------------------------------------------


def integrate(
    body: RigidBody,
    R0: ArrayLike | Rotation,
    omega0: ArrayLike,
    times: ArrayLike,
    torque: Torque | ArrayLike | None = None,
    max_step: float = 1e-3,
) -> Trajectory:
    """Integrate the body from ``(R0, omega0)`` at ``times[0]``; sample it at every time in ``times``.

    Each interval between consecutive requested times is split into equal CF4 steps no longer than
    ``max_step`` (s). ``torque``: None, a constant 3-vector or a :class:`Torque`. Returns a
    :class:`Trajectory` with ``R (T, 3, 3)``, ``omega (T, 3)`` and the torque ``(T, 3)`` at the requested
    times.

    Accuracy: global error O(max_step⁴) (``tests/test_rigid_body.py`` fits the order).
    """
    if not isinstance(body, RigidBody):
        raise TypeError(f"body must be a RigidBody; got {type(body).__name__}")
    R = ms.as_rotation(R0, "R0")  # a problem definition: a rotation to rounding (measurements, policy P)
    w = as_vector3(omega0, "omega0")
    t = ms.checked_times(times, where="times[{j}]")
    if t.size < 1:
        raise ValueError("times must hold at least one time; got none")
    max_step = float(as_positive(max_step, "max_step")[0])
    tq = as_torque(torque)

    # Step grid: interval i of length Δ_i gets n_i = ceil(Δ_i / max_step) equal steps.
    dt = np.diff(t)
    n_sub = np.maximum(1, np.ceil(dt / max_step - 1e-12).astype(np.int64))
    h = np.repeat(dt / n_sub, n_sub)
    start = np.repeat(t[:-1], n_sub) + h * (np.arange(h.size) - np.repeat(np.cumsum(n_sub) - n_sub, n_sub))
    record = np.zeros(h.size, dtype=np.bool_)
    record[np.cumsum(n_sub) - 1] = True

    if not tq.depends_on_state:
        tau_stages = np.empty((h.size, 3, 3))
        if tq.kind == "time":
            for s in range(h.size):
                tau_stages[s, 0] = tq(start[s])
                tau_stages[s, 1] = tq(start[s] + 0.5 * h[s])
                tau_stages[s, 2] = tq(start[s] + h[s])
        else:  # data: evaluated for all stage times at once
            tau_stages[:, 0] = tq(start)
            tau_stages[:, 1] = tq(start + 0.5 * h)
            tau_stages[:, 2] = tq(start + h)
        q0 = so3.to_quat(R)
        R_out, w_out = _cf4_kernel(q0, w, body.J, body.J_inv, h, tau_stages, record)
        R_out[0] = R  # the initial attitude exactly as given
    else:
        R_out = np.empty((t.size, 3, 3))
        w_out = np.empty((t.size, 3))
        R_out[0], w_out[0] = R, w
        k = 1
        for s in range(h.size):
            R, w = cf4_step(body, R, w, start[s], h[s], tq)
            if record[s]:
                R_out[k], w_out[k] = R, w
                k += 1

    tau_out = np.array([tq(t[j], R_out[j], w_out[j]) for j in range(t.size)]).reshape(t.size, 3)
    return Trajectory(t, R_out, w_out, tau_out)
