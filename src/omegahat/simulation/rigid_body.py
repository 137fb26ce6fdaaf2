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

Torque: a :class:`Torque` says explicitly what it depends on (nothing, a constant, time, or time and state).
When it does not depend on the state the whole integration runs in a compiled kernel (Numba), with the torque
tabulated beforehand at every stage time; :func:`cf4_step` is the plain NumPy step, the readable oracle the
kernel is tested against and the path used for state-dependent torques.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numba
import numpy as np

from omegahat import measurements as ms
from omegahat import so3
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = ["RigidBody", "Torque", "Trajectory", "as_torque", "cf4_step", "integrate"]


class RigidBody:
    """A rigid body with inertia ``J`` (symmetric positive definite; 3 numbers = diagonal, 9 = full)."""

    def __init__(self, J):
        self.J = as_inertia(J)
        self.J_inv = np.linalg.inv(self.J)

    def __repr__(self) -> str:
        return f"RigidBody(J={self.J.tolist()})"

    def omega_dot(self, omega, torque=None):
        """ω̇ = J⁻¹((Jω) × ω + τ). ``omega (*B, 3)``, ``torque`` broadcastable to it (None = 0)."""
        omega = np.asarray(omega, dtype=float)
        Jw = omega @ self.J.T
        rhs = np.cross(Jw, omega)
        if torque is not None:
            rhs = rhs + np.asarray(torque, dtype=float)
        return rhs @ self.J_inv.T

    def kinetic_energy(self, omega):
        """½ ωᵀ J ω. ``(*B, 3) -> (*B,)``."""
        omega = np.asarray(omega, dtype=float)
        return 0.5 * np.einsum("...i,ij,...j->...", omega, self.J, omega)

    def momentum_norm(self, omega):
        """|J ω|, the norm of the angular momentum (same in body and inertial axes). ``(*B, 3) -> (*B,)``."""
        return np.linalg.norm(np.asarray(omega, dtype=float) @ self.J.T, axis=-1)

    def inertial_momentum(self, R, omega):
        """L = R J ω, the angular momentum in inertial axes. ``(*B, 3, 3), (*B, 3) -> (*B, 3)``."""
        Jw = np.asarray(omega, dtype=float) @ self.J.T
        return np.einsum("...ij,...j->...i", np.asarray(R, dtype=float), Jw)


class Torque:
    """A known torque in body axes, N·m, with what it depends on stated explicitly.

    Build one with :meth:`none`, :meth:`constant`, :meth:`of_time` (``f(t) -> (3,)``) or :meth:`of_state`
    (``f(t, R, omega) -> (3,)``). Calling it always takes ``(t, R, omega)`` and returns a checked ``(3,)``
    array.
    """

    NONE, CONSTANT, TIME, STATE = "none", "constant", "time", "state"

    def __init__(self, kind: str, value=None, func: Callable | None = None):
        if kind not in (self.NONE, self.CONSTANT, self.TIME, self.STATE):
            raise ValueError(f"torque kind must be 'none', 'constant', 'time' or 'state'; got {kind!r}")
        self.kind = kind
        self.value = np.zeros(3) if kind == self.NONE else value
        self.func = func

    @classmethod
    def none(cls) -> Torque:
        """τ = 0 (torque-free motion)."""
        return cls(cls.NONE)

    @classmethod
    def constant(cls, tau) -> Torque:
        """A constant body-frame torque."""
        return cls(cls.CONSTANT, value=as_vector3(tau, "torque"))

    @classmethod
    def of_time(cls, func: Callable) -> Torque:
        """τ = func(t)."""
        if not callable(func):
            raise TypeError(f"Torque.of_time needs a callable f(t); got {func!r}")
        return cls(cls.TIME, func=func)

    @classmethod
    def of_state(cls, func: Callable) -> Torque:
        """τ = func(t, R, omega) (R body→inertial ``(3, 3)``, omega body rate ``(3,)``)."""
        if not callable(func):
            raise TypeError(f"Torque.of_state needs a callable f(t, R, omega); got {func!r}")
        return cls(cls.STATE, func=func)

    @property
    def depends_on_state(self) -> bool:
        return self.kind == self.STATE

    def __call__(self, t, R=None, omega=None) -> np.ndarray:
        if self.kind in (self.NONE, self.CONSTANT):
            return self.value
        raw = self.func(t) if self.kind == self.TIME else self.func(t, R, omega)
        tau = np.asarray(raw, dtype=float)
        if tau.shape != (3,) or not np.all(np.isfinite(tau)):
            raise ValueError(f"the torque function must return 3 finite numbers; at t = {float(t)} it returned {raw!r}")
        return tau

    def __repr__(self) -> str:
        detail = self.value.tolist() if self.kind == self.CONSTANT else self.func
        return f"Torque.{'none' if self.kind == self.NONE else self.kind}({'' if detail is None else detail})"


def as_torque(torque) -> Torque:
    """None → no torque, a 3-vector → constant, a :class:`Torque` → itself. A bare function is refused."""
    if torque is None:
        return Torque.none()
    if isinstance(torque, Torque):
        return torque
    if callable(torque):
        raise TypeError(
            "a torque function must say what it depends on: wrap it as Torque.of_time(f) for f(t) "
            "or Torque.of_state(f) for f(t, R, omega)"
        )
    return Torque.constant(torque)


class Trajectory(NamedTuple):
    """Samples of a motion: ``t (T,)``, ``R (T, 3, 3)``, ``omega (T, 3)``, ``torque (T, 3)``."""

    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    torque: np.ndarray


# ------------------------------------------------------------------------------------------------------------
# Plain NumPy step (the oracle)


def cf4_step(body: RigidBody, R, omega, t: float, h: float, torque: Torque):
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
def _quat_exp(x, y, z):
    """Unit quaternion (w, x, y, z) of the rotation vector (x, y, z): (cos θ/2, sin(θ/2)/θ · φ)."""
    t2 = x * x + y * y + z * z
    theta = np.sqrt(t2)
    if theta < 1e-4:
        s = 0.5 - t2 / 48.0 + t2 * t2 / 3840.0  # sin(θ/2)/θ, Taylor, error O(θ⁶)
        c = 1.0 - t2 / 8.0 + t2 * t2 / 384.0
    else:
        s = np.sin(0.5 * theta) / theta
        c = np.cos(0.5 * theta)
    q = np.empty(4)
    q[0] = c
    q[1] = s * x
    q[2] = s * y
    q[3] = s * z
    return q


@numba.njit(cache=True)
def _quat_mul(p, q):
    """Hamilton product p ⊗ q, scalar first (matches the matrix product R(p) R(q))."""
    r = np.empty(4)
    r[0] = p[0] * q[0] - p[1] * q[1] - p[2] * q[2] - p[3] * q[3]
    r[1] = p[0] * q[1] + p[1] * q[0] + p[2] * q[3] - p[3] * q[2]
    r[2] = p[0] * q[2] - p[1] * q[3] + p[2] * q[0] + p[3] * q[1]
    r[3] = p[0] * q[3] + p[1] * q[2] - p[2] * q[1] + p[3] * q[0]
    return r


@numba.njit(cache=True)
def _quat_to_matrix(q):
    w, x, y, z = q[0], q[1], q[2], q[3]
    R = np.empty((3, 3))
    R[0, 0] = 1 - 2 * (y * y + z * z)
    R[0, 1] = 2 * (x * y - z * w)
    R[0, 2] = 2 * (x * z + y * w)
    R[1, 0] = 2 * (x * y + z * w)
    R[1, 1] = 1 - 2 * (x * x + z * z)
    R[1, 2] = 2 * (y * z - x * w)
    R[2, 0] = 2 * (x * z - y * w)
    R[2, 1] = 2 * (y * z + x * w)
    R[2, 2] = 1 - 2 * (x * x + y * y)
    return R


@numba.njit(cache=True)
def _polar(D):
    """The rotation nearest to a nearly orthogonal 3 × 3 ``D`` (its polar factor ``U Vᵀ``) by Newton's iteration
    ``X ← (X + X⁻ᵀ)/2``, quadratically convergent: a few steps from ‖DᵀD − I‖ ~ 1e-4."""
    X = D.copy()
    for _ in range(30):
        C = np.empty((3, 3))  # cofactors: X⁻ᵀ = C / det X
        for i in range(3):
            for j in range(3):
                i1, i2, j1, j2 = (i + 1) % 3, (i + 2) % 3, (j + 1) % 3, (j + 2) % 3
                C[i, j] = X[i1, j1] * X[i2, j2] - X[i1, j2] * X[i2, j1]
        det = X[0, 0] * C[0, 0] + X[0, 1] * C[0, 1] + X[0, 2] * C[0, 2]
        Y = 0.5 * (X + C / det)
        change = np.abs(Y - X).max()
        X = Y
        if change < 1e-15:
            break
    return X


@numba.njit(cache=True)
def _quat_of_matrix(D):
    """Unit quaternion (x, y, z, w) of a rotation matrix by Shepperd's method (the largest of the trace and the
    diagonal chooses the pivot), normalised, with w ≥ 0: SciPy's ``from_matrix(...).as_quat(canonical=True)``.
    Like SciPy, a matrix whose ``D Dᵀ`` differs from I by more than 1e-12 is first replaced by the nearest
    rotation (:func:`_polar`; SciPy uses the SVD, the same matrix)."""
    dev = 0.0
    for i in range(3):
        for j in range(3):
            g = D[i, 0] * D[j, 0] + D[i, 1] * D[j, 1] + D[i, 2] * D[j, 2]
            dev = max(dev, abs(g - (1.0 if i == j else 0.0)))
    if dev > 1e-12:
        D = _polar(D)
    tr = D[0, 0] + D[1, 1] + D[2, 2]
    q = np.empty(4)
    i = 0
    if D[1, 1] > D[i, i]:
        i = 1
    if D[2, 2] > D[i, i]:
        i = 2
    if tr > D[i, i]:  # ties go to the diagonal, as in SciPy (argmax of [D₀₀, D₁₁, D₂₂, tr])
        q[0] = D[2, 1] - D[1, 2]
        q[1] = D[0, 2] - D[2, 0]
        q[2] = D[1, 0] - D[0, 1]
        q[3] = 1.0 + tr
    else:
        j = (i + 1) % 3
        k = (j + 1) % 3
        q[i] = 1.0 - tr + 2.0 * D[i, i]
        q[j] = D[j, i] + D[i, j]
        q[k] = D[k, i] + D[i, k]
        q[3] = D[k, j] - D[j, k]
    q /= np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[3] < 0.0:
        q = -q
    return q


@numba.njit(cache=True)
def _omega_dot(J, J_inv, w, tau):
    Jw = J @ w
    c = np.empty(3)
    c[0] = Jw[1] * w[2] - Jw[2] * w[1] + tau[0]
    c[1] = Jw[2] * w[0] - Jw[0] * w[2] + tau[1]
    c[2] = Jw[0] * w[1] - Jw[1] * w[0] + tau[2]
    return J_inv @ c


@numba.njit(cache=True)
def _cf4_increment(J, J_inv, w1, hs, tau0, tau_mid, tau1):
    """One CF4 step of size ``hs`` from ω = ``w1`` with the torque ``tau0, tau_mid, tau1`` at t, t + h/2, t + h.

    Returns ``(p, ω⁺)``: ``p`` is the unit quaternion (scalar first) of the attitude increment
    ``exp(h(Ω₁/4 + Ω₂/6 + Ω₃/6 − Ω₄/12)) exp(h(−Ω₁/12 + Ω₂/6 + Ω₃/6 + Ω₄/4))``, so that ``R⁺ = R R(p)``
    (``q⁺ = q ⊗ p``), and ω⁺ is the classical RK4 update. Shared by :func:`_cf4_kernel` and the MEKF kernel.
    """
    a1 = _omega_dot(J, J_inv, w1, tau0)
    w2 = w1 + 0.5 * hs * a1
    a2 = _omega_dot(J, J_inv, w2, tau_mid)
    w3 = w1 + 0.5 * hs * a2
    a3 = _omega_dot(J, J_inv, w3, tau_mid)
    w4 = w1 + hs * a3
    a4 = _omega_dot(J, J_inv, w4, tau1)
    first = hs * (w1 / 4.0 + w2 / 6.0 + w3 / 6.0 - w4 / 12.0)
    second = hs * (-w1 / 12.0 + w2 / 6.0 + w3 / 6.0 + w4 / 4.0)
    step = _quat_mul(_quat_exp(first[0], first[1], first[2]), _quat_exp(second[0], second[1], second[2]))
    return step, w1 + hs * (a1 + 2.0 * a2 + 2.0 * a3 + a4) / 6.0


@numba.njit(cache=True)
def _cf4_kernel(q0, w0, J, J_inv, h, tau_stages, record):
    """CF4 steps of sizes ``h (S,)``; torque ``tau_stages (S, 3, 3)`` at t, t + h/2, t + h of each step.

    The attitude is carried as a unit quaternion ``q0`` (scalar first): ``R exp(A) exp(B)`` is
    ``q ⊗ q(A) ⊗ q(B)``, renormalised (a rescaling that leaves the rotation unchanged) so that R(q) stays
    orthogonal to rounding over millions of steps, where a product of matrices drifts by ~1e-17 per step.
    Returns the state after the steps flagged in ``record (S,)`` (in order), plus the initial state first.
    """
    n_out = 1
    for s in range(h.size):
        if record[s]:
            n_out += 1
    R_out = np.empty((n_out, 3, 3))
    w_out = np.empty((n_out, 3))
    q = q0.copy()
    w1 = w0.copy()
    R_out[0] = _quat_to_matrix(q)
    w_out[0] = w1
    k = 1
    for s in range(h.size):
        step, w1 = _cf4_increment(J, J_inv, w1, h[s], tau_stages[s, 0], tau_stages[s, 1], tau_stages[s, 2])
        q = _quat_mul(q, step)
        q = q / np.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        if record[s]:
            R_out[k] = _quat_to_matrix(q)
            w_out[k] = w1
            k += 1
    return R_out, w_out


# ------------------------------------------------------------------------------------------------------------


def integrate(body: RigidBody, R0, omega0, times, torque=None, max_step: float = 1e-3) -> Trajectory:
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
        if tq.kind == Torque.TIME:
            for s in range(h.size):
                tau_stages[s, 0] = tq(start[s])
                tau_stages[s, 1] = tq(start[s] + 0.5 * h[s])
                tau_stages[s, 2] = tq(start[s] + h[s])
        else:
            tau_stages[:] = tq.value
        q0 = so3.to_quat(R, scalar_first=True)
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
