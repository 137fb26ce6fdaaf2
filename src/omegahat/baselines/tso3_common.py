r"""What the two gyro-free filters on TSO(3) share: their model, their timing, their input and their stateful shell.

The second-order minimum-energy filter (:mod:`omegahat.baselines.tso3_min_energy`) and the geometric predictive
filter (:mod:`omegahat.baselines.predictive_geom`) come from the same public repository
(``NikolasKubis/attitude_estimation_TSO3``, ``min_energy_filter/`` and ``geom_filter/``) and share its set-up::

    J ω̇ = (J ω) × ω + τ,   Ṙ = R ω×          (R body → inertial, ω and τ in body axes)           (C1)
    a_i = Rᵀ v_i + noise,   i = 1..n         (n ≥ 2 known inertial directions v_i)                (C2)

State: the attitude ``R̂`` and the rate ``ω̂`` (and, for the minimum-energy filter, its gain ``K``). An attitude
sample is taken as the three directions it carries (the rows of R are ``Rᵀ e_i``: ``v_i = e_i``), as everywhere in
omegahat (:mod:`omegahat.measurements`).

**Timing (C3).** Both source scripts are explicit one-step recursions: the sample at ``t_k`` (with the torque given
with it, held) drives the step from ``t_k`` to ``t_{k+1}``, and the estimate reported at ``t_k`` is the state the
step from ``t_{k−1}`` reached. So ``ω̂(t_k)`` depends on the samples up to ``t_{k−1}`` only (one sample of lag
against a filter that fuses the sample at its own time); the shells keep that order (the step is taken when the
next sample's time is known, i.e. in :meth:`TSO3Filter.update` at ``t_{k+1}``).
A missing or skipped sample (:mod:`omegahat.measurements`) drives its step without any measurement term.

**Start.** ``R0`` when given (the sources start from ``R̂ = I``), else the least-squares attitude of the first valid
sample (Wahba's problem, as the MEKF's first fix, :func:`omegahat.baselines.mekf.initial_attitude`); no step is
taken before the attitude is known, and ``ω̂`` stays at ``omega_hat0`` until then.

**The implicit rate step (C4).** Both filters advance ``ω̂`` by an implicit second-order step of (C1), solved by
Newton's method from the previous rate: :func:`newton` here (NumPy), the same loop compiled in
:mod:`omegahat.baselines.tso3_kernel`. It stops when ``max|Δω| ≤ NEWTON_TOL (1 + max|ω|)``, or fails after
``NEWTON_MAX`` iterations (both defined in the compiled module, so that its cache follows them).

**A step that cannot be taken (C5)**: Newton's iteration failed, or the step's result (R̂, ω̂, the gain) is not
finite. The filter then restarts from that sample, as at its start: ``ω̂ = omega_hat0``, the initial gain, R̂ the
sample's least-squares attitude (none when the sample is missing: from the next valid one); the estimate there is
NaN with the status ``RESTARTED`` (:mod:`omegahat.interface`), never a diverged value; ``n_restarts`` counts them.

**The contract.** :class:`TSO3Filter` is a :class:`omegahat.observer.compiled.CompiledEstimator`: ``run`` and
``update`` return an :class:`omegahat.interface.Estimate`; conversion, refusal, counting and statuses are the base's.
A sample's status is its own (corrected when valid, predicted when skipped), although with (C3) the estimate at it
was computed from the sample before.
"""

from __future__ import annotations

import abc
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat.baselines.mekf import initial_attitude
from omegahat.baselines.tso3_kernel import NEWTON_MAX, NEWTON_TOL
from omegahat.observer.compiled import CompiledEstimator
from omegahat.validation import as_directions, as_inertia, as_vector3

__all__ = ["NEWTON_MAX", "NEWTON_TOL", "FilterState", "TSO3Filter", "exp_so3", "newton"]

_NAN3 = np.full(3, np.nan)
_NAN3.flags.writeable = False


def exp_so3(phi: np.ndarray) -> np.ndarray:
    """``Exp(φ)``: the rotation matrix of the rotation vector φ (SciPy)."""
    return Rotation.from_rotvec(phi).as_matrix()


def newton(
    residual: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray], start: np.ndarray
) -> np.ndarray | None:
    """(C4): the root of ``residual`` by Newton's method from ``start``; None when it does not converge."""
    w = np.array(start, dtype=float)
    for _ in range(NEWTON_MAX):
        D, e = jacobian(w), residual(w)
        if not (np.all(np.isfinite(D)) and np.all(np.isfinite(e))):
            return None
        step = np.linalg.solve(D, e)
        w = w - step
        if not np.all(np.isfinite(w)):
            return None
        if np.max(np.abs(step)) <= NEWTON_TOL * (1.0 + np.max(np.abs(w))):
            return w
    return None


class FilterState(NamedTuple):
    """A TSO(3) filter's state: ``R`` (None before the first valid sample), ``omega``, ``gain``, the time ``t`` of
    the last sample (None: none yet), ``prev`` its directions (None: skipped), ``tau`` its torque (the restarts are
    counted by :class:`~omegahat.observer.compiled.CompiledEstimator`)."""

    R: np.ndarray | None
    omega: np.ndarray
    gain: np.ndarray
    t: float | None
    prev: np.ndarray | None
    tau: np.ndarray


class TSO3Filter(CompiledEstimator):
    """The stateful shell of (C3)–(C5) over a pure step function; subclasses give the step (NumPy) and its compiled
    twin.

    Settings shared by both filters: ``J`` (inertia; the one positional argument), and keyword-only ``references``
    (``None``: attitude samples, else the inertial directions ``(n, 3)``, n ≥ 2, samples ``(n, 3)``),
    ``omega_hat0`` (rad/s; default 0, and then no estimate at the first valid sample), ``R0`` (``None``: the first
    valid sample's least-squares attitude), and the input checks of :mod:`omegahat.measurements`.
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        references: ArrayLike | None,
        omega_hat0: ArrayLike | None,
        R0: ArrayLike | Rotation | None,
        scalar_first: bool,
        rotation_tol: float,
        quat_norm_tol: float,
        min_angle_deg: float,
    ) -> None:
        self.J = as_inertia(J)
        self.J_inv = np.linalg.inv(self.J)
        self.references = None if references is None else as_directions(references, "references")
        self.omega_hat0 = np.zeros(3) if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        self.min_angle_deg = ms.min_angle(min_angle_deg)
        self.R0: np.ndarray | None = None
        if R0 is not None:
            tols = {"rotation_tol": self.rotation_tol, "quat_norm_tol": self.quat_norm_tol}
            self.R0 = ms.as_rotation(R0, "R0", scalar_first=self.scalar_first, **tols)
        n = None if self.references is None else self.references.shape[0]
        self._conversion = ms.conversion(n, self.scalar_first, self.rotation_tol, self.quat_norm_tol, min_angle_deg)
        self._configure_input(n_directions=n, rate_given=omega_hat0 is not None)
        self.reset()

    @property
    def directions(self) -> np.ndarray:
        """The inertial directions ``v_i`` ``(n, 3)`` the samples are seen as (``I`` for attitude samples)."""
        return np.eye(3) if self.references is None else self.references

    # ---------------------------------------------------------------------------------------- subclass hooks

    @abc.abstractmethod
    def _initial_gain(self) -> np.ndarray:
        """The filter's extra state at the start (the minimum-energy gain; zeros for none)."""

    @abc.abstractmethod
    def _numpy_step(
        self, R: np.ndarray, omega: np.ndarray, gain: np.ndarray, a: np.ndarray | None, tau: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """One NumPy step from the sample ``a`` (None: none) over ``h``; None when Newton's iteration fails."""

    @abc.abstractmethod
    def _run_compiled(
        self, times: np.ndarray, values: np.ndarray, valid: np.ndarray, taus: np.ndarray, state: np.ndarray,
        R: np.ndarray, gain: np.ndarray, prev: np.ndarray,
    ) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
        """The compiled loop over a checked log, in place on ``state``, ``R``, ``gain``, ``prev``: ``(ω̂ (T, 3),
        restarted (T,))``."""

    # ---------------------------------------------------------------------------------------- the shell

    def _reset_state(self) -> None:
        self._commit(
            FilterState(
                None if self.R0 is None else self.R0.copy(), self.omega_hat0.copy(), self._initial_gain(), None,
                None, np.zeros(3),
            )
        )  # fmt: skip

    def _commit(self, state: Any) -> None:
        self.R, self.omega, self.gain, self.t, self._prev, self._tau = state

    def _previous_time(self) -> float:
        return np.nan if self.t is None else self.t

    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        """Step from the previous sample's time with the previous sample (C3), keep this one for the next step: the
        NumPy path, the oracle of :meth:`run`; a step that cannot be taken restarts the filter (C5)."""
        value = np.full(self.directions.shape, np.nan)
        code, info = self._check_one(t, m, kind, tau, value)
        if code >= ms.ERROR:
            return None, _NAN3, code, info
        R, omega, gain = self.R, self.omega, self.gain
        restarted = False
        if self.t is not None and R is not None:
            with np.errstate(all="ignore"):  # an overflow is caught just below: the filter restarts
                stepped = self._numpy_step(R, omega, gain, self._prev, self._tau, t - self.t)
            restarted = stepped is None or not all(np.all(np.isfinite(x)) for x in stepped)
            if restarted:  # (C5)
                R, omega, gain = None, self.omega_hat0.copy(), self._initial_gain()
            else:
                R, omega, gain = stepped  # type: ignore[misc]  # not None here
        valid = code == ms.OK
        if valid and R is None:
            R = initial_attitude(value, self.directions)
        state = FilterState(R, omega, gain, float(t), value if valid else None, np.array(tau, dtype=float))
        if restarted:
            return state, _NAN3, ms.RESTARTED, 0.0
        return state, omega, int(code), float(info)

    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        """The log checked (compiled), then the compiled filter (:mod:`omegahat.baselines.tso3_kernel`)."""
        values, codes, refusal = self._check_log(times, m, kind, taus)
        if refusal is not None:
            return refusal
        n = self.directions.shape[0]
        state = np.array(
            [self._previous_time(), self.t is not None, self.R is not None, self._prev is not None, *self.omega,
             *self._tau]
        )  # fmt: skip
        R = np.zeros((3, 3)) if self.R is None else np.array(self.R, dtype=float, order="C")
        prev = np.zeros((n, 3)) if self._prev is None else np.array(self._prev, dtype=float, order="C")
        gain = np.array(self.gain, dtype=float, order="C")
        out, restarted = self._run_compiled(
            times, np.ascontiguousarray(values), codes == ms.OK, taus, state, R, gain, prev
        )
        codes = np.where(restarted, ms.RESTARTED, codes)  # counted and warned about by the base's run
        new = FilterState(
            R if state[2] else None, state[4:7].copy(), gain, float(times[-1]), prev if state[3] else None,
            state[7:10].copy(),
        )  # fmt: skip
        return new, out, codes, -1, 0.0
