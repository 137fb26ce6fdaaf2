r"""Plant and continuous-time observer simulated together: fast (Numba) and reference (SciPy).

The coupled system is the rigid body (``ṙ_i = r_i × ω``, ``J ω̇ = (Jω) × ω + τ``) and the observer of
:mod:`omegahat.observer.continuous` driven by the true directions ``r_i = Rᵀ v_i``.

**Coordinates.** The fast simulator integrates ``(r_i, ω, z, e_i)`` with ``z = ω̂ − ω`` and ``e_i = r̂_i − r_i``,
a change of variables of the observer's own ``(ξ, r̂_i)`` (``ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i``, observer.md). Two
reasons:

* in ``(ω̂, r̂)`` the stiff terms ``l_i k_i J⁻¹ r_i × (r̂_i − r_i)`` of ξ̇ and ``−l_i J⁻¹ k_i r_i × (r̂_i − r_i)`` of
  ``d/dt β`` cancel exactly, so the stiffness sits only in the linear decay ``−l_i e_i``;
* every term of ``(ż, ė)`` is proportional to the error, so the local truncation error is relative to the error
  itself and ``|ω̂ − ω|`` is resolved accurately even when it is 1e-9 of |ω|.

The equations integrated are the error dynamics of observer.md, with the gyroscopic difference expanded without
cancellation, ``(Jω̂) × ω̂ − (Jω) × ω = (Jz) × ω + (Jω) × z + (Jz) × z``::

    ż   = J⁻¹ Σ k_i (r_i + e_i) × (r_i × z) + J⁻¹ ((Jz) × ω + (Jω) × z + (Jz) × z)
    ė_i = r_i × z + e_i × (ω + z) − l_i(ω + z) e_i

They are checked against the observer's own equations integrated by ``scipy.integrate.solve_ivp``
(:func:`simulate_reference`) in ``tests/test_simulate.py``.

**Integrator.** An exponential Runge–Kutta method of order 4 (ETDRK4, Cox & Matthews, J. Comput. Phys. 176, 2002)
whose linear part is the scalar decay ``−l_i(ω̂_n)`` of each ``e_i`` frozen at the start of the step (the rest,
including ``−(l_i(ω̂) − l_i(ω̂_n)) e_i``, is the explicit part); on the other components it reduces to the classical
RK4. The stiff decay is therefore integrated exactly whatever ``l_i h``. The step size is controlled by an embedded
estimate (the ETD34 construction of Whalen, Brio & Moloney, J. Comput. Phys. 280, 2015): the nonlinear part at the
new point, which the next step needs anyway (first same as last), replaces the last stage in ETDRK4's final
combination, giving a third-order solution; ``δ = b₄ (N(c) − N(y_{n+1}))`` is its difference from the fourth-order
solution, which is the one propagated. The test is a mixed relative/absolute tolerance per block ``(r_i, ω, z,
e_i)``: ``max_b |δ_b| / √(atol² + rtol² |y_b|²) ≤ 1``, and the next step is ``0.9 (ratio)^(−1/4)`` times this one,
clipped to [0.2, 4]. Four evaluations of the right-hand side per step (step doubling, used before, took 11). On the
stiff ``e_i`` the estimate is close to the true local error of ETDRK4, which there scales like ``h³`` (the last
stage sees ``z`` at a second-order stage: the method's stiff order reduction); the step-doubling estimate ``(y_half
− y_full)/15`` assumed ``h⁵`` and underestimated it up to tenfold, so the new control takes more, cheaper steps and
its results are closer to the reference at the same ``rtol``. On ``(r, ω, z)`` the estimate is of third order, hence
conservative. Steps are not forced onto the output times: those are filled by the step's continuous extension of
order 3 (ETDRK4's combination with θ-dependent φ-weights, exact on the stiff decay; the classical RK4 dense output
on the other blocks); only the last step ends on the last output time.

**Many runs at once.** :mod:`omegahat.simulation.engine` steps many runs in lockstep (SIMD over runs) and gives each
run the very bits of :func:`integrate_coupled`; the two share their small pieces (``_sin_cos_small``, the
φ-functions, ``_step_factor``).

**Torques.** The kernel evaluates the torque itself, so it must be given as data:
:class:`SinusoidalTorque` ``τ(t) = c + Σ_j a_j ∘ sin(ν_j t + φ_j)`` (a constant is the case with no terms).
The observer knows it exactly (observer.md assumes a known torque).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba
import numpy as np
from scipy.integrate import solve_ivp

from omegahat import measurements as ms
from omegahat.kernels.expfn import exp_kernel
from omegahat.observer import continuous as sarras
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.validation import as_directions, as_inertia, as_vector3

__all__ = [
    "CoupledProblem",
    "CoupledTrajectory",
    "SinusoidalTorque",
    "first_step",
    "paper_problem",
    "simulate",
    "simulate_reference",
]


# --------------------------------------------------------------------------------------------------------------
# Problem definition
# --------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SinusoidalTorque:
    """Known torque ``τ(t) = constant + Σ_j amplitudes[j] ∘ sin(frequencies[j] t + phases[j])`` (N·m, rad/s, rad).

    ``amplitudes`` and ``phases`` have shape ``(m, 3)``, ``frequencies`` ``(m,)``; ``m = 0`` is a constant torque.
    """

    constant: np.ndarray = field(default_factory=lambda: np.zeros(3))
    amplitudes: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    frequencies: np.ndarray = field(default_factory=lambda: np.zeros(0))
    phases: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def __post_init__(self):
        c = as_vector3(self.constant, "torque constant")
        a = np.asarray(self.amplitudes, dtype=float).reshape(-1, 3)
        m = a.shape[0]
        f = np.asarray(self.frequencies, dtype=float).reshape(m)
        p = np.broadcast_to(np.asarray(self.phases, dtype=float), (m, 3)).copy()
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(f)) and np.all(np.isfinite(p))):
            raise ValueError("torque amplitudes, frequencies and phases must be finite")
        object.__setattr__(self, "constant", c)
        object.__setattr__(self, "amplitudes", a)
        object.__setattr__(self, "frequencies", f)
        object.__setattr__(self, "phases", p)

    def __call__(self, t):
        """τ at time(s) ``t``: ``(3,)`` for a scalar, ``(T, 3)`` for an array."""
        t = np.asarray(t, dtype=float)
        tt = t[..., None, None]  # (..., 1, 1)
        terms = self.amplitudes * np.sin(self.frequencies[:, None] * tt + self.phases)  # (..., m, 3)
        return self.constant + terms.sum(axis=-2)

    @property
    def bound(self) -> float:
        """An upper bound of ``|τ(t)|`` over all t."""
        return float(np.linalg.norm(np.abs(self.constant) + np.abs(self.amplitudes).sum(axis=0)))


def _as_torque(torque) -> SinusoidalTorque:
    if torque is None:
        return SinusoidalTorque()
    if isinstance(torque, SinusoidalTorque):
        return torque
    if callable(torque):
        raise TypeError(
            "simulate() evaluates the torque inside a compiled kernel: pass a SinusoidalTorque (or a constant "
            "3-vector), not a Python function; omegahat.simulation.rigid_body.integrate accepts arbitrary functions"
        )
    return SinusoidalTorque(constant=torque)


@dataclass(frozen=True)
class CoupledProblem:
    """A rigid body, its measured directions and the observer, with initial conditions.

    * ``J`` inertia (3×3 SPD, or 3 numbers for a diagonal); ``gains`` an
      :class:`~omegahat.observer.gains.ObserverGains`;
    * ``references`` the known inertial directions ``v_i`` ``(n, 3)`` (default: the first two rows of R);
    * ``R0`` initial attitude (body → inertial; matrix, quaternion or ``Rotation``), ``omega0`` initial rate;
    * ``r_hat0`` initial filter states ``(n, 3)`` (default: the true directions), ``omega_hat0`` initial estimate;
    * ``torque`` the known torque (None, a constant 3-vector or a :class:`SinusoidalTorque`).
    """

    J: np.ndarray
    gains: ObserverGains
    omega0: np.ndarray
    R0: np.ndarray = field(default_factory=lambda: np.eye(3))
    references: np.ndarray | None = None
    r_hat0: np.ndarray | None = None
    omega_hat0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: SinusoidalTorque | None = None

    def __post_init__(self):
        J = as_inertia(self.J)
        refs = as_directions(np.eye(3)[: self.gains.n] if self.references is None else self.references)
        if refs.shape[0] != self.gains.n:
            raise ValueError(f"{self.gains.n} gains were given for {refs.shape[0]} reference directions")
        R0 = ms.as_rotation(self.R0, "R0")  # a problem definition: a rotation to rounding (measurements, policy P)
        r0 = refs @ R0  # r_i = R0ᵀ v_i, stacked as rows
        r_hat0 = r0.copy() if self.r_hat0 is None else np.asarray(self.r_hat0, dtype=float)
        if r_hat0.shape != r0.shape or not np.all(np.isfinite(r_hat0)):
            raise ValueError(f"r_hat0 must be finite with shape {r0.shape}; got {self.r_hat0!r}")
        object.__setattr__(self, "J", J)
        object.__setattr__(self, "references", refs)
        object.__setattr__(self, "R0", R0)
        object.__setattr__(self, "r_hat0", r_hat0)
        object.__setattr__(self, "omega0", as_vector3(self.omega0, "omega0"))
        object.__setattr__(self, "omega_hat0", as_vector3(self.omega_hat0, "omega_hat0"))
        object.__setattr__(self, "torque", _as_torque(self.torque))

    @property
    def r0(self) -> np.ndarray:
        """Initial true directions ``r_i0 = R0ᵀ v_i``, ``(n, 3)``."""
        return self.references @ self.R0

    @property
    def xi0(self) -> np.ndarray:
        """The observer's ξ₀ that gives ω̂₀ (the paper's ``ξ₀ = Σ k_i J⁻¹ (r̂_i0 × r_i0)`` when ω̂₀ = 0)."""
        return sarras.xi_for_omega_hat(self.omega_hat0, self.r0, self.r_hat0, self.gains.k, np.linalg.inv(self.J))


def paper_problem(torque=None) -> CoupledProblem:
    """Section 4 of the paper, typos fixed (observer.md): J = diag(3, 2, 1), ω₀ = (2, −1, 0.6), ω_M = 3,
    R(0) = I, two rows measured, r̂_10 = (0, −1, 0), r̂_20 = (0, 0, −1), ω̂₀ = 0, the theorem's gains
    (k = 14.5, l_i0 = 1); torque-free unless a torque is given."""
    J = np.diag([3.0, 2.0, 1.0])
    return CoupledProblem(
        J=J,
        gains=theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0),
        omega0=np.array([2.0, -1.0, 0.6]),
        r_hat0=np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        torque=torque,
    )


PAPER_OMEGA_MAX = 3.0  #: the bound ω_M of the paper's scenario (rad/s)


@dataclass(frozen=True)
class CoupledTrajectory:
    """Samples of the coupled simulation at the output times (time-first arrays)."""

    t: np.ndarray  #: (T,)
    omega: np.ndarray  #: (T, 3) true rate
    omega_hat: np.ndarray  #: (T, 3) estimate
    r: np.ndarray  #: (T, n, 3) true directions
    r_hat: np.ndarray  #: (T, n, 3) filter states
    xi: np.ndarray  #: (T, 3) the observer's ξ
    z: np.ndarray  #: (T, 3) ω̂ − ω as integrated (not rounded by the subtraction of two O(|ω|) numbers)
    e: np.ndarray  #: (T, n, 3) r̂_i − r_i as integrated
    steps: int  #: accepted steps of the integrator
    rejected: int  #: rejected steps

    @property
    def error(self) -> np.ndarray:
        """``|ω̂ − ω|``, (T,)."""
        return np.linalg.norm(self.z, axis=-1)

    @property
    def filter_error(self) -> np.ndarray:
        """``|r̂_i − r_i|``, (T, n)."""
        return np.linalg.norm(self.e, axis=-1)


# --------------------------------------------------------------------------------------------------------------
# Fast kernel (Numba). State layout y = [r_1..r_n (3n), ω (3), z (3), e_1..e_n (3n)].
#
# Cost per accepted step (the unit of omegahat.campaigns.runner's throughput): one trial = one ETDRK4 step, 4
# evaluations of the nonlinear part (three stages and the new point, which is the next step's first stage; a
# rejected trial costs the same 4), torque at 3 times from sin and cos of ν_j h/2 per term (a polynomial for
# small angles; sin and cos at the step's start are carried from the previous step by angle addition), one
# exponential per distinct rate, no heap allocation inside the loop. Each output time inside a step adds
# φ-functions at 1 argument.
# _nonlinear and _etdrk4_step are inlined by Numba (inline="always": measured 12% less time per step).
# --------------------------------------------------------------------------------------------------------------


@numba.njit(cache=True, fastmath=False)
def _cross_into(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


_SINCOS_SMALL = 0.25  # |x| up to which _sin_cos_small is used: first omitted terms x^13/13!, x^14/14! < 3e-18


@numba.njit(cache=True, inline="always")
def _sin_cos_small(x):
    """sin x and cos x by their Taylor polynomials (degree 11 and 12, Horner in x²), accurate to rounding for
    |x| ≤ 1/4. Plain arithmetic, so the lockstep kernel (:mod:`omegahat.simulation.engine`) computes it for many
    runs at once and gets the very same bits."""
    x2 = x * x
    s = x * (
        1.0
        + x2
        * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362880.0 + x2 * (-1.0 / 39916800.0)))))
    )
    c = 1.0 + x2 * (
        -0.5
        + x2
        * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (-1.0 / 3628800.0 + x2 * (1.0 / 479001600.0)))))
    )
    return s, c


@numba.njit(cache=True)
def _torque_stages(h, c, a_cos, a_sin, freq, sn, cs, out, sn_end, cs_end):
    """τ at t, t + h/2 and t + h into ``out (3, 3)``: τ(t) = c + Σ_j a_j sin(ν_j t + φ_j), written
    (a_j cos φ_j) sin ν_j t + (a_j sin φ_j) cos ν_j t, from ``sn[j] = sin ν_j t`` and ``cs[j] = cos ν_j t``; the
    later times by the angle-addition rotation by ν_j h/2 (:func:`_sin_cos_small` when |ν_j h/2| ≤ 1/4), which
    also gives sin and cos at t + h into ``sn_end``, ``cs_end`` (the next step's ``sn``, ``cs``)."""
    for s in range(3):
        out[s, 0] = c[0]
        out[s, 1] = c[1]
        out[s, 2] = c[2]
    for j in range(freq.shape[0]):
        a = sn[j]
        b = cs[j]
        x = 0.5 * freq[j] * h
        sd, cd = _sin_cos_small(x)
        if abs(x) > _SINCOS_SMALL:
            sd = np.sin(x)
            cd = np.cos(x)
        for s in range(3):
            for d in range(3):
                out[s, d] += a_cos[j, d] * a + a_sin[j, d] * b
            if s < 2:
                a, b = a * cd + b * sd, b * cd - a * sd
        sn_end[j] = a
        cs_end[j] = b


@numba.njit(cache=True)
def _frozen_rates(y, n, l_off, l_slope, out):
    """l_i(ω̂) at the state y (the linear part L = −l_i frozen for a step)."""
    iw = 3 * n
    wh0 = y[iw] + y[iw + 3]
    wh1 = y[iw + 1] + y[iw + 4]
    wh2 = y[iw + 2] + y[iw + 5]
    norm_wh = np.sqrt(wh0 * wh0 + wh1 * wh1 + wh2 * wh2)
    for i in range(n):
        out[i] = l_off[i] + l_slope[i] * norm_wh


@numba.njit(cache=True, inline="always")
def _nonlinear(y, n, J, Jinv, k, l_off, l_slope, l_frozen, tau, dy):
    """dy = f(y) − L y, with L = −l_frozen on the e-blocks and 0 elsewhere; ``tau`` the torque at this time."""
    iw = 3 * n
    iz = iw + 3
    ie = iz + 3
    w0, w1, w2 = y[iw], y[iw + 1], y[iw + 2]
    z0, z1, z2 = y[iz], y[iz + 1], y[iz + 2]
    wh0, wh1, wh2 = w0 + z0, w1 + z1, w2 + z2
    norm_wh = np.sqrt(wh0 * wh0 + wh1 * wh1 + wh2 * wh2)
    # J ω and J z
    Jw0 = J[0, 0] * w0 + J[0, 1] * w1 + J[0, 2] * w2
    Jw1 = J[1, 0] * w0 + J[1, 1] * w1 + J[1, 2] * w2
    Jw2 = J[2, 0] * w0 + J[2, 1] * w1 + J[2, 2] * w2
    Jz0 = J[0, 0] * z0 + J[0, 1] * z1 + J[0, 2] * z2
    Jz1 = J[1, 0] * z0 + J[1, 1] * z1 + J[1, 2] * z2
    Jz2 = J[2, 0] * z0 + J[2, 1] * z1 + J[2, 2] * z2
    # plant: J ω̇ = (Jω) × ω + τ
    g0, g1, g2 = _cross_into(Jw0, Jw1, Jw2, w0, w1, w2)
    g0 += tau[0]
    g1 += tau[1]
    g2 += tau[2]
    for a in range(3):
        dy[iw + a] = Jinv[a, 0] * g0 + Jinv[a, 1] * g1 + Jinv[a, 2] * g2
    # error: J ż = Σ k_i r̂_i × (r_i × z) + (Jz) × ω + (Jω) × z + (Jz) × z
    s0, s1, s2 = _cross_into(Jz0, Jz1, Jz2, w0, w1, w2)
    p0, p1, p2 = _cross_into(Jw0, Jw1, Jw2, z0, z1, z2)
    q0, q1, q2 = _cross_into(Jz0, Jz1, Jz2, z0, z1, z2)
    s0 += p0 + q0
    s1 += p1 + q1
    s2 += p2 + q2
    for i in range(n):
        r0, r1, r2 = y[3 * i], y[3 * i + 1], y[3 * i + 2]
        e0, e1, e2 = y[ie + 3 * i], y[ie + 3 * i + 1], y[ie + 3 * i + 2]
        # ṙ_i = r_i × ω
        a0, a1, a2 = _cross_into(r0, r1, r2, w0, w1, w2)
        dy[3 * i] = a0
        dy[3 * i + 1] = a1
        dy[3 * i + 2] = a2
        # r_i × z, then r̂_i × (r_i × z)
        c0, c1, c2 = _cross_into(r0, r1, r2, z0, z1, z2)
        d0, d1, d2 = _cross_into(r0 + e0, r1 + e1, r2 + e2, c0, c1, c2)
        s0 += k[i] * d0
        s1 += k[i] * d1
        s2 += k[i] * d2
        # ė_i = r_i × z + e_i × ω̂ − l_i(ω̂) e_i, minus the frozen linear part −l_frozen e_i
        f0, f1, f2 = _cross_into(e0, e1, e2, wh0, wh1, wh2)
        dl = l_off[i] + l_slope[i] * norm_wh - l_frozen[i]
        dy[ie + 3 * i] = c0 + f0 - dl * e0
        dy[ie + 3 * i + 1] = c1 + f1 - dl * e1
        dy[ie + 3 * i + 2] = c2 + f2 - dl * e2
    for a in range(3):
        dy[iz + a] = Jinv[a, 0] * s0 + Jinv[a, 1] * s1 + Jinv[a, 2] * s2


# Taylor coefficients 1/(j + k)! of φ_k(x) = Σ_j x^j/(j + k)!, k = 1, 2, 3, j = 0..16: for |x| < 1/2 the first
# omitted term is below 2^-17/18! < 1.2e-21, far under the rounding of the sum.
_PHI_DEGREE = 16
_PHI1_TAYLOR = np.array([1.0 / math.factorial(j + 1) for j in range(_PHI_DEGREE + 1)])
_PHI2_TAYLOR = np.array([1.0 / math.factorial(j + 2) for j in range(_PHI_DEGREE + 1)])
_PHI3_TAYLOR = np.array([1.0 / math.factorial(j + 3) for j in range(_PHI_DEGREE + 1)])


@numba.njit(cache=True, inline="always")
def _phi123_taylor(x):
    """φ₁, φ₂, φ₃ and exp of x by the Taylor series (Horner), for |x| < 1/2 where the closed forms cancel."""
    t1 = _PHI1_TAYLOR[_PHI_DEGREE]
    t2 = _PHI2_TAYLOR[_PHI_DEGREE]
    t3 = _PHI3_TAYLOR[_PHI_DEGREE]
    for j in range(_PHI_DEGREE - 1, -1, -1):
        t1 = t1 * x + _PHI1_TAYLOR[j]
        t2 = t2 * x + _PHI2_TAYLOR[j]
        t3 = t3 * x + _PHI3_TAYLOR[j]
    return t1, t2, t3, 1.0 + x * t1


@numba.njit(cache=True, inline="always", error_model="numpy")
def _phi123_closed(x, ex):
    """φ₁, φ₂, φ₃ and exp of x by the closed forms, given ``ex = exp(x)`` (|x| ≥ 1/2); one division (1/x), the
    powers of 1/x by multiplication (a division costs several multiplications' time, and divisions and square
    roots share one unit)."""
    inv = 1.0 / x
    e1 = ex - 1.0
    return e1 * inv, (e1 - x) * (inv * inv), (e1 - x - 0.5 * x * x) * (inv * inv * inv), ex


@numba.njit(cache=True, inline="always", error_model="numpy")
def _phi1_half_closed(x, ex2):
    """φ₁(x/2) = (e^{x/2} − 1)·(2/x) given ``ex2 = e^{x/2}`` (|x/2| ≥ 1/2), through the 1/x of
    :func:`_phi123_closed` (LLVM computes the shared division once when both are inlined)."""
    return (ex2 - 1.0) * (2.0 * (1.0 / x))


@numba.njit(cache=True, inline="always")
def _phi1_taylor(x):
    """φ₁ and exp of x by the Taylor series, as :func:`_phi123_taylor`."""
    t1 = _PHI1_TAYLOR[_PHI_DEGREE]
    for j in range(_PHI_DEGREE - 1, -1, -1):
        t1 = t1 * x + _PHI1_TAYLOR[j]
    return t1, 1.0 + x * t1


@numba.njit(cache=True)
def _phi123(x):
    """φ₁, φ₂, φ₃ and exp of x ≤ 0 (φ_k(x) = Σ_j x^j/(j+k)!): :func:`_phi123_taylor` for |x| < 1/2,
    :func:`_phi123_closed` beyond. The lockstep kernel (:mod:`omegahat.simulation.engine`) computes both for a row
    of lanes and selects, which gives the same bits."""
    if abs(x) < 0.5:
        return _phi123_taylor(x)
    return _phi123_closed(x, exp_kernel(x))


@numba.njit(cache=True, inline="always", error_model="numpy")
def _step_factor(err):
    """Next step over this one from the error ratio: ``0.9 err^(−1/4)`` (the embedded estimate is of order 3),
    clipped to [0.2, 4]; written with two square roots (vectorisable, and cheaper than ``pow``)."""
    factor = 0.9 / np.sqrt(np.sqrt(err)) if err > 0 else 4.0
    return min(4.0, max(0.2, factor))


@numba.njit(cache=True, inline="always")
def _etdrk4_step(y, Nu, l_frozen, h, n, J, Jinv, k, l_off, l_slope, tau_mid, tau_end, work, out):
    """One ETDRK4 step (Cox–Matthews) of size h from y; result in out.

    ``Nu`` is the nonlinear part at (t, y) with the frozen rates ``l_frozen = l_i(ω̂(y))``; ``tau_mid``,
    ``tau_end`` the torque at t + h/2 and t + h. ``work``: (7, len(y)) scratch.
    """
    ie = 3 * n + 6
    Na = work[0]
    Nb = work[1]
    Nc = work[2]
    ya = work[3]
    yb = work[4]
    yc = work[5]
    coef = work[6]  # E, E2, Q, f1, f2, f3 for each direction: 6n ≤ len(y) = 6n + 6
    for i in range(n):
        if i > 0 and l_frozen[i] == l_frozen[i - 1]:  # equal rates (the usual case): same coefficients
            for c in range(6):
                coef[6 * i + c] = coef[6 * i - 6 + c]
            continue
        x = -l_frozen[i] * h
        x2 = 0.5 * x
        if abs(x2) < 0.5:
            q1, ex2 = _phi1_taylor(x2)
        else:
            ex2 = exp_kernel(x2)
            q1 = _phi1_half_closed(x, ex2)
        if abs(x) < 0.5:
            p1, p2, p3, ex = _phi123_taylor(x)
        else:  # one exponential a step: e^x = (e^{x/2})², within 2 units in the last place
            p1, p2, p3, ex = _phi123_closed(x, ex2 * ex2)
        coef[6 * i] = ex
        coef[6 * i + 1] = ex2
        coef[6 * i + 2] = 0.5 * h * q1
        coef[6 * i + 3] = h * (p1 - 3.0 * p2 + 4.0 * p3)
        coef[6 * i + 4] = h * (2.0 * p2 - 4.0 * p3)
        coef[6 * i + 5] = h * (4.0 * p3 - p2)
    hh = 0.5 * h
    for j in range(ie):
        ya[j] = y[j] + hh * Nu[j]
    for i in range(n):
        E2, Q = coef[6 * i + 1], coef[6 * i + 2]
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            ya[j] = E2 * y[j] + Q * Nu[j]
    _nonlinear(ya, n, J, Jinv, k, l_off, l_slope, l_frozen, tau_mid, Na)
    for j in range(ie):
        yb[j] = y[j] + hh * Na[j]
    for i in range(n):
        E2, Q = coef[6 * i + 1], coef[6 * i + 2]
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            yb[j] = E2 * y[j] + Q * Na[j]
    _nonlinear(yb, n, J, Jinv, k, l_off, l_slope, l_frozen, tau_mid, Nb)
    for j in range(ie):
        yc[j] = y[j] + h * Nb[j]
    for i in range(n):
        E2, Q = coef[6 * i + 1], coef[6 * i + 2]
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            yc[j] = E2 * ya[j] + Q * (2.0 * Nb[j] - Nu[j])
    _nonlinear(yc, n, J, Jinv, k, l_off, l_slope, l_frozen, tau_end, Nc)
    h6 = h / 6.0
    for j in range(ie):
        out[j] = y[j] + h6 * (Nu[j] + 2.0 * Na[j] + 2.0 * Nb[j] + Nc[j])
    for i in range(n):
        E, f1, f2, f3 = coef[6 * i], coef[6 * i + 3], coef[6 * i + 4], coef[6 * i + 5]
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            out[j] = E * y[j] + f1 * Nu[j] + f2 * (Na[j] + Nb[j]) + f3 * Nc[j]


@numba.njit(cache=True, inline="always")
def _larger_ratio(num, den, worst_num, worst_den):
    """The larger of ``num/den`` and ``worst_num/worst_den`` (denominators > 0) as a (numerator, denominator)
    pair, compared by cross-multiplication so that the error test divides once. A NaN numerator (non-finite
    state) is kept: the step is then rejected."""
    if num * worst_den > worst_num * den or num != num:
        return num, den
    return worst_num, worst_den


@numba.njit(cache=True)
def _embedded_error(Nc, N_new, y_new, coef, lf0, lf1, h, n, rtol, atol):
    """max over blocks (r_i, ω, z, e_i) of |δ| / √(atol² + rtol² |y_new|²), δ = b₄ (N(c) − N(y_new)): the ETDRK4
    solution minus the third-order one that uses the nonlinear part at the new point in place of the last stage
    (b₄ = h/6 on (r, ω, z), h(4φ₃ − φ₂)(−l_i h) on e_i; N(y_new) taken with the step's frozen rates ``lf0``:
    ``N_new`` was evaluated with the new point's rates ``lf1``, and N(y; l) = f(y) + l e). The squared ratios
    are compared as fractions (:func:`_larger_ratio`), and one division and one square root taken at the end
    (divisions and square roots cost as much as the rest of the test)."""
    ie = 3 * n + 6
    a2 = atol * atol
    r2 = rtol * rtol
    worst_num = 0.0
    worst_den = 1.0
    for b in range(2 * n + 2):
        if 3 * b < ie:
            w = h / 6.0
            shift = 0.0
        else:
            i = b - n - 2
            w = coef[6 * i + 5]
            shift = lf0[i] - lf1[i]
        d2 = 0.0
        y2 = 0.0
        for a in range(3):
            j = 3 * b + a
            d = w * (Nc[j] - N_new[j] - shift * y_new[j])
            d2 += d * d
            y2 += y_new[j] * y_new[j]
        worst_num, worst_den = _larger_ratio(d2, a2 + r2 * y2, worst_num, worst_den)
    return np.sqrt(worst_num / worst_den)


@numba.njit(cache=True, inline="always")
def _dense_weights(h, A, B, C):
    """The continuous extension's weights ``b₁ = h(A − 3B + 4C)``, ``b₂ = b₃ = h(2B − 4C)``, ``b₄ = h(4C − B)``."""
    return h * (A - 3.0 * B + 4.0 * C), h * (2.0 * B - 4.0 * C), h * (4.0 * C - B)


@numba.njit(cache=True)
def _dense_output(y, Nu, Na, Nb, Nc, l_frozen, h, theta, n, out):
    """The step's continuous extension at t + θh (0 < θ < 1): ETDRK4's final combination with the weights of
    order 3 at θ, ``b₁ = h(A − 3B + 4C)``, ``b₂ = b₃ = h(2B − 4C)``, ``b₄ = h(4C − B)`` with ``A = θφ₁(θz)``,
    ``B = θ²φ₂(θz)``, ``C = θ³φ₃(θz)`` and ``e^{θz}`` on the state (z = −l_i h on e_i, 0 elsewhere: classical RK4's
    cubic dense output). At θ = 1 they are the step's own weights."""
    ie = 3 * n + 6
    b1, b2, b4 = _dense_weights(h, theta, 0.5 * theta * theta, 0.5 * theta * theta * theta / 3.0)
    for j in range(ie):
        out[j] = y[j] + b1 * Nu[j] + b2 * (Na[j] + Nb[j]) + b4 * Nc[j]
    ex = 1.0
    for i in range(n):
        if i == 0 or l_frozen[i] != l_frozen[i - 1]:  # equal rates (the usual case): same weights
            p1, p2, p3, ex = _phi123(-l_frozen[i] * h * theta)
            b1, b2, b4 = _dense_weights(h, theta * p1, theta * theta * p2, theta * theta * theta * p3)
        for j in range(ie + 3 * i, ie + 3 * i + 3):
            out[j] = ex * y[j] + b1 * Nu[j] + b2 * (Na[j] + Nb[j]) + b4 * Nc[j]


@numba.njit(cache=True)
def integrate_coupled(y0, t_out, n, J, Jinv, k, l_off, l_slope, tc, ta, tf, tp, rtol, atol, h0, h_max, max_steps):
    """Integrate the coupled system from t_out[0] and return y at every t_out ``(T, len(y0))``.

    Steps are taken freely (the last one ends on ``t_out[-1]``); the other output times are filled from the
    accepted step that contains them by :func:`_dense_output`. Returns ``(Y, accepted, rejected, ok)``; ``ok`` is
    False when ``max_steps`` was exceeded or the state became non-finite (the remaining rows are then NaN).
    """
    m = y0.shape[0]
    T = t_out.shape[0]
    Y = np.full((T, m), np.nan)
    y = y0.copy()
    Y[0] = y
    t = t_out[0]
    t_end = t_out[T - 1]
    h = h0
    # torque terms a_j sin(ν_j t + φ_j) = (a_j cos φ_j) sin ν_j t + (a_j sin φ_j) cos ν_j t
    a_cos = ta * np.cos(tp)
    a_sin = ta * np.sin(tp)
    work = np.zeros((7, m))
    y_new = np.empty(m)
    Nu = np.empty(m)  # nonlinear part at (t, y) with the rates lf frozen at y
    N_new = np.empty(m)  # at (t + h, y_new) with the rates lf_new frozen at y_new: the next step's Nu (FSAL)
    lf = np.empty(n)
    lf_new = np.empty(n)
    taus = np.empty((3, 3))  # τ at t, t + h/2, t + h
    # sin ν_j t and cos ν_j t, carried from step to step by the rotations of _torque_stages (|drift| ~ 1e-16 a step)
    sn = np.sin(tf * t)
    cs = np.cos(tf * t)
    sn_new = np.empty_like(sn)
    cs_new = np.empty_like(cs)
    _torque_stages(0.0, tc, a_cos, a_sin, tf, sn, cs, taus, sn_new, cs_new)
    _frozen_rates(y, n, l_off, l_slope, lf)
    _nonlinear(y, n, J, Jinv, k, l_off, l_slope, lf, taus[0], Nu)
    accepted = 0
    rejected = 0
    idx = 1
    while idx < T:
        if accepted + rejected >= max_steps:
            return Y, accepted, rejected, False
        hh = min(h, h_max)
        last = False
        if t + 1.01 * hh >= t_end:
            hh = t_end - t
            last = True
        _torque_stages(hh, tc, a_cos, a_sin, tf, sn, cs, taus, sn_new, cs_new)
        _etdrk4_step(y, Nu, lf, hh, n, J, Jinv, k, l_off, l_slope, taus[1], taus[2], work, y_new)
        _frozen_rates(y_new, n, l_off, l_slope, lf_new)
        _nonlinear(y_new, n, J, Jinv, k, l_off, l_slope, lf_new, taus[2], N_new)
        err = _embedded_error(work[2], N_new, y_new, work[6], lf, lf_new, hh, n, rtol, atol)
        if not np.isfinite(err):
            if hh < 1e-14:
                return Y, accepted, rejected, False
            h = 0.25 * hh
            rejected += 1
            continue
        factor = _step_factor(err)
        if err <= 1.0:
            t_new = t_end if last else t + hh
            while idx < T and t_out[idx] < t_new:
                _dense_output(y, Nu, work[0], work[1], work[2], lf, hh, (t_out[idx] - t) / hh, n, Y[idx])
                idx += 1
            if idx < T and t_out[idx] == t_new:
                Y[idx] = y_new
                idx += 1
            t = t_new
            y, y_new = y_new, y
            Nu, N_new = N_new, Nu
            lf, lf_new = lf_new, lf
            sn, sn_new = sn_new, sn
            cs, cs_new = cs_new, cs
            accepted += 1
        else:
            rejected += 1
        h = hh * factor
    return Y, accepted, rejected, True


@numba.njit(cache=True, parallel=True)
def integrate_coupled_batch(
    Y0, t_out, n, J, Jinv, k, l_off, l_slope, tc, ta, tf, tp, rtol, atol, h0, h_max, max_steps, n_workers
):
    """:func:`integrate_coupled` for ``N`` independent runs: ``Y0 (N, m)``, per-run torques ``tc (N, 3)``,
    ``ta (N, M, 3)``, ``tf (N, M)``, ``tp (N, M, 3)`` and first steps ``h0 (N,)``; J and the gains shared.

    Returns ``(Y (N, T, m), accepted (N,), rejected (N,), ok (N,))``. Each run is the very same call as the
    single-run kernel, so it is bit-for-bit what :func:`integrate_coupled` gives, whatever the batch. Runs are
    dealt cyclically to ``n_workers`` parallel workers (run i to worker i mod n_workers), which balances runs of
    unequal cost without any dependence of the results on the split.
    """
    N = Y0.shape[0]
    m = Y0.shape[1]
    T = t_out.shape[0]
    Y = np.empty((N, T, m))
    accepted = np.zeros(N, dtype=np.int64)
    rejected = np.zeros(N, dtype=np.int64)
    ok = np.zeros(N, dtype=np.bool_)
    for w in numba.prange(n_workers):
        for i in range(w, N, n_workers):
            Yi, acc, rej, good = integrate_coupled(
                Y0[i],
                t_out,
                n,
                J,
                Jinv,
                k,
                l_off,
                l_slope,
                tc[i],
                ta[i],
                tf[i],
                tp[i],
                rtol,
                atol,
                h0[i],
                h_max,
                max_steps,
            )
            Y[i] = Yi
            accepted[i] = acc
            rejected[i] = rej
            ok[i] = good
    return Y, accepted, rejected, ok


# --------------------------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------------------------


def _kernel_args(problem: CoupledProblem):
    g = problem.gains
    tq = problem.torque
    return (
        g.n,
        problem.J,
        np.linalg.inv(problem.J),
        g.k,
        g.l_offset,
        g.l_slope,
        tq.constant,
        tq.amplitudes,
        tq.frequencies,
        tq.phases,
    )


def initial_state(problem: CoupledProblem) -> np.ndarray:
    """The kernel's state ``[r (3n), ω, z, e (3n)]`` at t = 0."""
    r0 = problem.r0
    return np.concatenate(
        [r0.ravel(), problem.omega0, problem.omega_hat0 - problem.omega0, (problem.r_hat0 - r0).ravel()]
    )


def first_step(gains: ObserverGains, omega_hat0, h_max: float):
    """The kernels' first step for runs starting at ω̂₀ ``(..., 3)``: ``0.1 / max(1, max_i l_i(ω̂₀))``, at most
    ``h_max`` (a tenth of the fastest decay's time constant). |ω̂₀| is summed element-wise, left to right, so the
    single-run and the batch paths, on any machine, start with the same step."""
    w = np.asarray(omega_hat0, dtype=float)
    speed = np.sqrt((w[..., 0] * w[..., 0] + w[..., 1] * w[..., 1]) + w[..., 2] * w[..., 2])
    rates = gains.l_offset + gains.l_slope * speed[..., None]
    return np.minimum(h_max, 0.1 / np.maximum(1.0, np.max(rates, axis=-1)))


def trajectory_from_states(problem: CoupledProblem, t, Y, accepted=0, rejected=0) -> CoupledTrajectory:
    """Unpack kernel states ``(T, 6n + 6)`` into a :class:`CoupledTrajectory`."""
    n = problem.gains.n
    r = Y[:, : 3 * n].reshape(-1, n, 3)
    omega = Y[:, 3 * n : 3 * n + 3]
    z = Y[:, 3 * n + 3 : 3 * n + 6]
    e = Y[:, 3 * n + 6 :].reshape(-1, n, 3)
    omega_hat = omega + z
    r_hat = r + e
    Jinv = np.linalg.inv(problem.J)
    beta = np.einsum("ij,tj->ti", Jinv, np.einsum("i,tia->ta", problem.gains.k, np.cross(r, r_hat)))
    return CoupledTrajectory(
        t=np.asarray(t, dtype=float),
        omega=omega,
        omega_hat=omega_hat,
        r=r,
        r_hat=r_hat,
        xi=omega_hat - beta,
        z=z,
        e=e,
        steps=int(accepted),
        rejected=int(rejected),
    )


def simulate(
    problem: CoupledProblem,
    horizon: float = 10.0,
    dt_out: float = 1e-3,
    t_out=None,
    rtol: float = 1e-9,
    atol: float = 1e-15,
    h_max: float = 0.05,
    max_steps: int = 10_000_000,
) -> CoupledTrajectory:
    """Simulate plant and observer from t = 0 and sample them at ``t_out`` (default every ``dt_out`` to horizon).

    ``rtol``/``atol`` bound the local error of each block ``(r_i, ω, z, e_i)`` relative to its size; the
    default reproduces ``|ω̂ − ω|`` of the paper's run at 0.5, 1 and 2 s to better than 1e-8 relative of a
    DOP853 reference at rtol 1e-13
    (``tests/test_simulate.py``). Output times inside a step are filled by its continuous extension (order 3), so
    a dense ``t_out`` costs no extra steps.
    """
    if t_out is None:
        if not (np.isfinite(horizon) and horizon > 0):
            raise ValueError(f"horizon must be positive and finite; got {horizon!r}")
        if not (np.isfinite(dt_out) and dt_out > 0):
            raise ValueError(f"dt_out must be positive and finite; got {dt_out!r}")
        count = round(horizon / dt_out)
        t_out = np.linspace(0.0, count * dt_out, count + 1)
        if t_out[-1] < horizon:
            t_out = np.append(t_out, horizon)
    t_out = np.asarray(t_out, dtype=float)
    if t_out.ndim != 1 or t_out.size < 1 or t_out[0] != 0.0 or np.any(np.diff(t_out) <= 0):
        raise ValueError("t_out must start at 0 and increase strictly")
    y0 = initial_state(problem)
    args = _kernel_args(problem)
    h0 = float(first_step(problem.gains, problem.omega_hat0, h_max))
    Y, acc, rej, ok = integrate_coupled(y0, t_out, *args, rtol, atol, h0, h_max, max_steps)
    if not ok:
        raise RuntimeError(
            f"simulation stopped at t = {t_out[np.argmax(np.isnan(Y[:, 0]))]:.6g} s after {acc + rej} steps "
            "(max_steps reached or the state became non-finite)"
        )
    return trajectory_from_states(problem, t_out, Y, acc, rej)


def simulate_reference(
    problem: CoupledProblem,
    t_eval,
    method: str = "Radau",
    rtol: float = 1e-10,
    atol: float = 1e-14,
    output_sign: float = sarras.OUTPUT_SIGN_CORRECTED,
) -> CoupledTrajectory:
    """The same coupled system in the observer's own coordinates ``(r_i, ω, ξ, r̂_i)``, right-hand side
    :func:`omegahat.observer.continuous.observer_rhs` term by term, integrated by ``scipy.integrate.solve_ivp``.

    Slow; it is the independent reference for :func:`simulate`, and with ``output_sign=OUTPUT_SIGN_PRINTED``
    it simulates the paper's printed (wrong) output map. ξ₀ is chosen for ω̂₀ under the chosen output map.
    """
    n = problem.gains.n
    J = problem.J
    Jinv = np.linalg.inv(J)
    g = problem.gains
    tq = problem.torque
    r0 = problem.r0
    xi0 = sarras.xi_for_omega_hat(problem.omega_hat0, r0, problem.r_hat0, g.k, Jinv, output_sign)

    def rhs(t, y):
        r = y[: 3 * n].reshape(n, 3)
        w = y[3 * n : 3 * n + 3]
        xi = y[3 * n + 3 : 3 * n + 6]
        r_hat = y[3 * n + 6 :].reshape(n, 3)
        tau = tq(t)
        r_dot = np.cross(r, w)
        w_dot = Jinv @ (np.cross(J @ w, w) + tau)
        xi_dot, r_hat_dot = sarras.observer_rhs(
            xi, r_hat, r, tau, J, Jinv, g.k, g.l_offset, g.l_slope, sign=output_sign
        )
        return np.concatenate([r_dot.ravel(), w_dot, xi_dot, r_hat_dot.ravel()])

    t_eval = np.asarray(t_eval, dtype=float)
    y0 = np.concatenate([r0.ravel(), problem.omega0, xi0, problem.r_hat0.ravel()])
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"solve_ivp({method}) failed: {sol.message}")
    Y = sol.y.T
    r = Y[:, : 3 * n].reshape(-1, n, 3)
    omega = Y[:, 3 * n : 3 * n + 3]
    xi = Y[:, 3 * n + 3 : 3 * n + 6]
    r_hat = Y[:, 3 * n + 6 :].reshape(-1, n, 3)
    omega_hat = xi + output_sign * np.einsum("ij,tj->ti", Jinv, np.einsum("i,tia->ta", g.k, np.cross(r, r_hat)))
    return CoupledTrajectory(
        t=sol.t,
        omega=omega,
        omega_hat=omega_hat,
        r=r,
        r_hat=r_hat,
        xi=xi,
        z=omega_hat - omega,
        e=r_hat - r,
        steps=int(sol.nfev),
        rejected=0,
    )
