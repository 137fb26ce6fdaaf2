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
taken before the attitude is known, and ``ω̂`` stays at ``omega0`` until then.

**The implicit rate step (C4).** Both filters advance ``ω̂`` by an implicit second-order step of (C1), solved by
Newton's method from the previous rate: :func:`newton` here (NumPy), the same loop compiled in
:mod:`omegahat.baselines.tso3_kernel`. It stops when ``max|Δω| ≤ NEWTON_TOL (1 + max|ω|)``, or fails after
``NEWTON_MAX`` iterations (both defined in the compiled module, so that its cache follows them); the shells then
raise :class:`StepFailure` (never a NaN written as an estimate).
"""

from __future__ import annotations

import abc
from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat.baselines.mekf import initial_attitude
from omegahat.baselines.tso3_kernel import NEWTON_MAX, NEWTON_TOL
from omegahat.interface import Estimator, Measurement, Measurements
from omegahat.validation import as_inertia, as_vector3

__all__ = ["NEWTON_MAX", "NEWTON_TOL", "StepFailure", "TSO3Filter", "exp_so3", "newton"]


class StepFailure(RuntimeError):
    """A filter's implicit rate step did not converge (the state diverged): no estimate is written."""


def exp_so3(phi: np.ndarray) -> np.ndarray:
    """``Exp(φ)``: the rotation matrix of the rotation vector φ (SciPy)."""
    return Rotation.from_rotvec(phi).as_matrix()


def newton(
    residual: Callable[[np.ndarray], np.ndarray], jacobian: Callable[[np.ndarray], np.ndarray], start: np.ndarray
) -> np.ndarray | None:
    """(C4): the root of ``residual`` by Newton's method from ``start``; None when it does not converge."""
    w = np.array(start, dtype=float)
    for _ in range(NEWTON_MAX):
        step = np.linalg.solve(jacobian(w), residual(w))
        w = w - step
        if not np.all(np.isfinite(w)):
            return None
        if np.max(np.abs(step)) <= NEWTON_TOL * (1.0 + np.max(np.abs(w))):
            return w
    return None


class TSO3Filter(Estimator):
    """The stateful shell of (C3) over a pure step function; subclasses give the step (NumPy) and its compiled twin.

    Keyword-only settings shared by both filters: ``J`` (inertia), ``references`` (``None``: attitude samples,
    else the inertial directions ``(n, 3)``, samples ``(n, 3)``), ``omega0`` (rad/s), ``R0`` (``None``: the first
    valid sample's least-squares attitude), and the input checks of :mod:`omegahat.measurements`.
    """

    def __init__(
        self,
        *,
        J: ArrayLike,
        references: ArrayLike | None,
        omega0: ArrayLike,
        R0: ArrayLike | Rotation | None,
        scalar_first: bool,
        rotation_tol: float,
        quat_norm_tol: float,
        min_angle_deg: float,
    ) -> None:
        self.J = as_inertia(J)
        self.J_inv = np.linalg.inv(self.J)
        self.references = None if references is None else ms.as_references(references)
        self.omega0 = as_vector3(omega0, "omega0")
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        if not 0 <= min_angle_deg < 90:
            raise ValueError(f"min_angle_deg must be in [0, 90); got {min_angle_deg!r}")
        self.min_angle_deg = float(min_angle_deg)
        self.R0: np.ndarray | None = None
        if R0 is not None:
            tols = {"rotation_tol": self.rotation_tol, "quat_norm_tol": self.quat_norm_tol}
            self.R0 = ms.as_rotation(R0, "R0", scalar_first=self.scalar_first, **tols)
        self.reset()

    @property
    def directions(self) -> np.ndarray:
        """The inertial directions ``v_i`` ``(n, 3)`` the samples are seen as (``I`` for attitude samples)."""
        return np.eye(3) if self.references is None else self.references

    # ---------------------------------------------------------------------------------------- subclass hooks

    @abc.abstractmethod
    def _initial_gain(self) -> np.ndarray:
        """The filter's extra state at the start (the minimum-energy gain; an empty array for none)."""

    @abc.abstractmethod
    def _step(
        self, R: np.ndarray, omega: np.ndarray, gain: np.ndarray, a: np.ndarray | None, tau: np.ndarray, h: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """One NumPy step from the sample ``a`` (None: none) over ``h``; None when it fails."""

    @abc.abstractmethod
    def _run_compiled(self, log: ms.CheckedLog, state: np.ndarray, R: np.ndarray, prev: np.ndarray) -> tuple:
        """The compiled loop over a checked log: ``(ω̂ (T, 3), R, gain, failed index or −1)``."""

    # ---------------------------------------------------------------------------------------- the shell

    def reset(self) -> None:
        self.R: np.ndarray | None = None if self.R0 is None else self.R0.copy()
        self.omega = self.omega0.copy()
        self.gain = self._initial_gain()
        self.t: float | None = None
        self._prev: np.ndarray | None = None  # the last sample's directions (None: skipped, or no sample yet)
        self._tau = np.zeros(3)

    def _checks(self) -> dict:
        return {
            "references": self.references,
            "t_prev": self.t,
            "scalar_first": self.scalar_first,
            "rotation_tol": self.rotation_tol,
            "quat_norm_tol": self.quat_norm_tol,
            "min_angle_deg": self.min_angle_deg,
        }

    def update(self, t: float, measurement: Measurement, torque: ArrayLike | None = None) -> np.ndarray:
        """Take the sample at ``t``: step from the previous sample's time with the previous sample (C3), keep this
        one for the next step, return ``ω̂(t)`` ``(3,)``. The NumPy path (the oracle of :meth:`run`)."""
        sample = ms.checked_sample(t, measurement, torque, **self._checks())
        R, omega, gain = self.R, self.omega, self.gain
        if self.t is not None and R is not None:
            stepped = self._step(R, omega, gain, self._prev, self._tau, sample.t - self.t)
            if stepped is None:
                raise StepFailure(f"the sample (t = {sample.t!r}): the implicit rate step did not converge")
            R, omega, gain = stepped
        valid = sample.status == ms.OK
        if valid and R is None:
            R = initial_attitude(sample.value, self.directions)
        self.R, self.omega, self.gain, self.t = R, omega, gain, sample.t
        self._prev = sample.value.copy() if valid else None
        self._tau = sample.torque.copy()
        return self.omega.copy()

    def run(self, times: ArrayLike, measurements: Measurements, torques: ArrayLike | None = None) -> np.ndarray:
        """``ω̂`` at every sample ``(T, 3)``: the same as :meth:`update` sample by sample (continuing from the current
        state), in one compiled call. The log is checked first; a failed step raises :class:`StepFailure` naming the
        sample, and the state is then left as it was before the call."""
        log = ms.checked_log(times, measurements, torques, **self._checks())
        if log.times.size == 0:
            return np.empty((0, 3))
        n = self.directions.shape[0]
        state = np.array(
            [
                np.nan if self.t is None else self.t,
                self.t is not None,
                self.R is not None,
                self._prev is not None,
                *self.omega,
                *self._tau,
            ]
        )
        R = np.zeros((3, 3)) if self.R is None else np.array(self.R, dtype=float, order="C")
        prev = np.zeros((n, 3)) if self._prev is None else np.array(self._prev, dtype=float, order="C")
        out, R, gain, failed = self._run_compiled(log, state, R, prev)
        if failed >= 0:
            raise StepFailure(
                f"sample {failed} (t = {float(log.times[failed])!r}): the implicit rate step did not converge"
            )
        self.R = R if state[2] else None
        self.omega, self._tau, self.gain = state[4:7].copy(), state[7:10].copy(), gain
        self.t = float(log.times[-1])
        self._prev = prev if state[3] else None
        return out
