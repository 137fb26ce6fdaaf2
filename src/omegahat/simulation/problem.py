r"""What a simulation of plant + observer is given, and what it returns.

A :class:`CoupledProblem` is a rigid body (inertia J, initial attitude and rate, a known torque), the inertial
directions it measures and the observer's gains and initial state. The coupled system is the body
(``ṙ_i = r_i × ω``, ``J ω̇ = (Jω) × ω + τ``) and the observer driven by the true directions ``r_i = Rᵀ v_i``.
The engine (:mod:`omegahat.simulation.engine`) integrates it in error coordinates ``(r_i, ω, z, e_i)`` with
``z = ω̂ − ω`` and ``e_i = r̂_i − r_i`` — a change of variables of the observer's own ``(ξ, r̂_i)``, related by the
output map ``ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i`` (O5 of :mod:`omegahat.kernels.observer`) — for two reasons:

* in ``(ω̂, r̂)`` the stiff terms ``l_i k_i J⁻¹ r_i × (r̂_i − r_i)`` of ξ̇ and of the output map's derivative cancel
  exactly, so the stiffness sits only in the linear decay ``−l_i e_i``, which the integrator treats exactly;
* every term of ``(ż, ė)`` is proportional to the error, so the local error is relative to the error itself and
  ``|ω̂ − ω|`` is resolved accurately even when it is 1e-9 of |ω|.

:class:`CoupledTrajectory` holds the samples at the output times, with ξ and r̂ recovered from the states.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field

import numba
import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.kernels.observer import output_map
from omegahat.kernels.vec3 import mat3
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation.engine import Model, RunSet
from omegahat.simulation.torque import Torque, as_torque
from omegahat.validation import as_directions, as_inertia, as_vector3

__all__ = [
    "PAPER_OMEGA_MAX",
    "CoupledProblem",
    "CoupledTrajectory",
    "batch_inputs",
    "first_step",
    "initial_state",
    "initial_states",
    "model_of",
    "paper_problem",
    "trajectory_from_states",
]

PAPER_OMEGA_MAX = 3.0  #: the bound ω_M of the paper's scenario (rad/s)


@dataclass(frozen=True)
class CoupledProblem:
    """A rigid body, its measured directions and the observer, with initial conditions.

    The input of :func:`~omegahat.simulation.coupled.simulate` (module docstring). A frozen dataclass: the
    inputs are checked and converted on construction (arrays, a rotation matrix, a :class:`Torque`); the
    properties ``r0`` (the initial true directions ``r_i0 = R0ᵀ v_i``, ``(n, 3)``) and ``xi0`` (the observer's ξ₀
    that gives ω̂₀) follow from them.

    Parameters
    ----------
    J : array_like
        Inertia (3×3 SPD, or 3 numbers for a diagonal).
    gains : ObserverGains
        The observer's gains, an :class:`~omegahat.observer.ObserverGains` (one ``k_i`` per direction).
    omega0 : array_like
        Initial rate ω(0) (rad/s, body axes), 3 numbers.
    R0 : array_like or scipy.spatial.transform.Rotation, optional
        Initial attitude (body → inertial; matrix, quaternion or ``Rotation``); default the identity.
    references : array_like, optional
        The known inertial directions ``v_i`` ``(n, 3)`` (default: the first rows of R, one per gain).
    r_hat0 : array_like, optional
        Initial filter states ``(n, 3)``, finite (default: the true directions).
    omega_hat0 : array_like, optional
        Initial estimate ω̂(0), 3 numbers (default zero).
    torque : Torque or array_like, optional
        The known torque: None, a constant 3-vector or a :class:`~omegahat.simulation.torque.Torque` given as data
        (none, constant, sinusoidal).

    Raises
    ------
    ValueError
        If the number of gains is not the number of references, ``r_hat0`` is not finite of shape ``(n, 3)``, or
        another input is invalid (not SPD, not a rotation, not finite).
    TypeError
        If the torque is a Python function (the engine needs a torque given as data).

    Examples
    --------
    A body spinning about its middle axis, measuring two inertial directions, the observer starting at ω̂ = 0:

    >>> import numpy as np
    >>> from omegahat import CoupledProblem, simulate, theorem_gains
    >>> J = np.diag([3.0, 2.0, 1.0])
    >>> problem = CoupledProblem(J=J, gains=theorem_gains(J, omega_max=2.0), omega0=[0.0, 1.0, 0.1])
    >>> print(problem.references.shape, problem.r0.shape, problem.torque)
    (2, 3) (2, 3) Torque.none()
    >>> trajectory = simulate(problem, horizon=2.0, dt_out=1.0)
    >>> print(" ".join(f"{e:.1e}" for e in trajectory.error))  # |ω̂ − ω| at t = 0, 1, 2 s
    1.0e+00 3.2e-03 1.1e-05
    """

    J: np.ndarray
    gains: ObserverGains
    omega0: np.ndarray
    R0: np.ndarray = field(default_factory=lambda: np.eye(3))
    # None (the defaults) and the other accepted inputs are replaced by arrays and a Torque in __post_init__
    references: np.ndarray = None  # type: ignore[assignment]
    r_hat0: np.ndarray = None  # type: ignore[assignment]
    omega_hat0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    torque: Torque = None  # type: ignore[assignment]

    def __post_init__(self):
        J = as_inertia(self.J)
        refs = as_directions(np.eye(3)[: self.gains.n] if self.references is None else self.references)
        if refs.shape[0] != self.gains.n:
            raise ValueError(f"{self.gains.n} gains were given for {refs.shape[0]} reference directions")
        R0 = ms.as_rotation(self.R0, "R0")  # a problem definition: a rotation to rounding (the measurements' policy)
        r0 = refs @ R0  # r_i = R0ᵀ v_i, stacked as rows
        r_hat0 = r0.copy() if self.r_hat0 is None else np.asarray(self.r_hat0, dtype=float)
        if r_hat0.shape != r0.shape or not np.all(np.isfinite(r_hat0)):
            raise ValueError(f"r_hat0 must be finite with shape {r0.shape}; got {self.r_hat0!r}")
        torque = as_torque(self.torque)
        torque.sinusoid()  # the engine evaluates it: it must be data, said now rather than at simulate()
        object.__setattr__(self, "J", J)
        object.__setattr__(self, "references", refs)
        object.__setattr__(self, "R0", R0)
        object.__setattr__(self, "r_hat0", r_hat0)
        object.__setattr__(self, "omega0", as_vector3(self.omega0, "omega0"))
        object.__setattr__(self, "omega_hat0", as_vector3(self.omega_hat0, "omega_hat0"))
        object.__setattr__(self, "torque", torque)

    @property
    def r0(self) -> np.ndarray:
        """Initial true directions ``r_i0 = R0ᵀ v_i``, ``(n, 3)``."""
        return _seen_in_body(self.references, self.R0[None])[0]

    @property
    def xi0(self) -> np.ndarray:
        """The observer's ξ₀ that gives ω̂₀ (the paper's ``ξ₀ = Σ k_i J⁻¹ (r̂_i0 × r_i0)`` when ω̂₀ = 0)."""
        beta = output_map(mat3(np.linalg.inv(self.J)), self.gains.k, self.r0, self.r_hat0)
        return self.omega_hat0 - np.array(beta)


def paper_problem(torque: Torque | ArrayLike | None = None) -> CoupledProblem:
    """The scenario of Section 4 of the paper, typos fixed.

    J = diag(3, 2, 1), ω₀ = (2, −1, 0.6), ω_M = 3, R(0) = I, two rows measured, r̂_10 = (0, −1, 0),
    r̂_20 = (0, 0, −1), ω̂₀ = 0, the theorem's gains (k = 14.5, l_i0 = 1); torque-free unless a torque is given.

    Parameters
    ----------
    torque : Torque or array_like, optional
        The known torque: None (torque-free), a constant 3-vector or a
        :class:`~omegahat.simulation.torque.Torque` given as data.

    Returns
    -------
    CoupledProblem
        The paper's problem, ready for :func:`~omegahat.simulation.coupled.simulate`.

    Examples
    --------
    >>> import numpy as np
    >>> from omegahat import Torque, paper_problem
    >>> problem = paper_problem()
    >>> print(problem.J.diagonal().tolist(), problem.omega0.tolist(), problem.gains.k.tolist())
    [3.0, 2.0, 1.0] [2.0, -1.0, 0.6] [14.5, 14.5]
    >>> print(problem.r_hat0.tolist())
    [[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]
    >>> print(paper_problem(Torque.constant([0.1, 0.0, 0.0])).torque)
    Torque.constant([0.1, 0.0, 0.0])
    """
    J = np.diag([3.0, 2.0, 1.0])
    return CoupledProblem(
        J=J,
        gains=theorem_gains(J, omega_max=PAPER_OMEGA_MAX, margin=1.0, l0=1.0),
        omega0=np.array([2.0, -1.0, 0.6]),
        r_hat0=np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]),
        torque=as_torque(torque),
    )


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


def _seen_in_body(references, R):
    """``r_i = Rᵀ v_i`` for stacked ``R (N, 3, 3)``: ``(N, n, 3)``, summed element-wise, left to right."""
    V = np.asarray(references, dtype=float)
    r = V[None, :, 0, None] * R[:, None, 0, :]
    r = r + V[None, :, 1, None] * R[:, None, 1, :]
    return r + V[None, :, 2, None] * R[:, None, 2, :]


def initial_states(
    references: ArrayLike, R0: ArrayLike, omega0: np.ndarray, omega_hat0: np.ndarray, r_hat0: ArrayLike
) -> np.ndarray:
    """The engine's states ``[r (3n), ω, z, e (3n)]`` at t = 0 for runs stacked on the first axis: ``R0 (N, 3, 3)``,
    ``omega0``, ``omega_hat0 (N, 3)``, ``r_hat0 (N, n, 3)``. ``r_i = R0ᵀ v_i`` is summed element-wise, left to right
    (no BLAS, whose order depends on the CPU), so that a run starts from the same bits alone or in any batch."""
    R0 = np.asarray(R0, dtype=float)
    r0 = _seen_in_body(references, R0)
    N = R0.shape[0]
    return np.concatenate(
        [r0.reshape(N, -1), omega0, omega_hat0 - omega0, (np.asarray(r_hat0, dtype=float) - r0).reshape(N, -1)],
        axis=1,
    )


def initial_state(problem: CoupledProblem) -> np.ndarray:
    """The engine's state ``[r (3n), ω, z, e (3n)]`` at t = 0 (:func:`initial_states` for one run)."""
    p = problem
    return initial_states(p.references, p.R0[None], p.omega0[None], p.omega_hat0[None], p.r_hat0[None])[0]


def first_step(gains: ObserverGains, omega_hat0: ArrayLike, h_max: float) -> np.ndarray:
    """The engine's first step for runs starting at ω̂₀ ``(..., 3)``: ``0.1 / max(1, max_i l_i(ω̂₀))``, at most
    ``h_max`` (a tenth of the fastest decay's time constant). |ω̂₀| is summed element-wise, left to right, so that
    a run starts with the same step alone or in a batch, on any machine."""
    w = np.asarray(omega_hat0, dtype=float)
    speed = np.sqrt((w[..., 0] * w[..., 0] + w[..., 1] * w[..., 1]) + w[..., 2] * w[..., 2])
    rates = gains.l_offset + gains.l_slope * speed[..., None]
    return np.minimum(h_max, 0.1 / np.maximum(1.0, np.max(rates, axis=-1)))


def model_of(J: np.ndarray, gains: ObserverGains) -> Model:
    """The engine's :class:`~omegahat.simulation.engine.Model` for inertia J and the gains."""
    return Model(J, np.linalg.inv(J), gains.k, gains.l_offset, gains.l_slope)


def batch_inputs(problems: Iterable[CoupledProblem], h_max: float) -> tuple[Model, RunSet]:
    """The engine's inputs for ``problems`` (all with the same J, gains and references; each its own initial
    state and torque, padded with zero-amplitude terms to a common number, which adds exactly 0.0)."""
    problems = list(problems)
    if not problems:
        raise ValueError("a batch needs at least one problem")
    p0 = problems[0]
    for j, p in enumerate(problems):
        same = (
            np.array_equal(p.J, p0.J)
            and np.array_equal(p.references, p0.references)
            and all(np.array_equal(getattr(p.gains, a), getattr(p0.gains, a)) for a in ("k", "l_offset", "l_slope"))
        )
        if not same:
            raise ValueError(f"problem {j} has another J, gains or references than problem 0; batch them apart")
    N = len(problems)
    M = max(p.torque.frequencies.size for p in problems)
    amplitudes, frequencies, phases = np.zeros((N, M, 3)), np.zeros((N, M)), np.zeros((N, M, 3))
    for j, p in enumerate(problems):
        _, a, f, ph = p.torque.sinusoid()
        amplitudes[j, : f.size], frequencies[j, : f.size], phases[j, : f.size] = a, f, ph
    runs = RunSet(
        y0=initial_states(
            p0.references,
            np.stack([p.R0 for p in problems]),
            np.stack([p.omega0 for p in problems]),
            np.stack([p.omega_hat0 for p in problems]),
            np.stack([p.r_hat0 for p in problems]),
        ),
        h0=first_step(p0.gains, np.stack([p.omega_hat0 for p in problems]), h_max),
        torque_constant=np.stack([p.torque.constant_term for p in problems]),
        torque_amplitudes=amplitudes,
        torque_frequencies=frequencies,
        torque_phases=phases,
    )
    return model_of(p0.J, p0.gains), runs


@numba.njit(cache=True)
def _output_map_rows(Jinv, k, r, r_hat, out):
    for t in range(r.shape[0]):
        out[t, 0], out[t, 1], out[t, 2] = output_map(Jinv, k, r[t], r_hat[t])


def trajectory_from_states(
    problem: CoupledProblem, t: ArrayLike, Y: np.ndarray, accepted: int = 0, rejected: int = 0
) -> CoupledTrajectory:
    """Unpack engine states ``(T, 6n + 6)`` into a :class:`CoupledTrajectory` (ξ by the output map)."""
    n = problem.gains.n
    r = Y[:, : 3 * n].reshape(-1, n, 3)
    omega = Y[:, 3 * n : 3 * n + 3]
    z = Y[:, 3 * n + 3 : 3 * n + 6]
    e = Y[:, 3 * n + 6 :].reshape(-1, n, 3)
    omega_hat = omega + z
    r_hat = r + e
    beta = np.empty((Y.shape[0], 3))
    _output_map_rows(mat3(np.linalg.inv(problem.J)), problem.gains.k, np.ascontiguousarray(r), r_hat, beta)
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
