r"""The attitude controller in closed loop with a sampled star tracker, a rate source and a rigid-body plant.

One sample period ``h = 1/rate_hz``; at each sample time ``t_k = k h``:

1. the star tracker measures ``R̃_k = R(t_k) exp(ν_k)``, ``ν_k ~ N(0, σ² I)``
   (:func:`omegahat.simulation.sensors.noisy_attitudes`);
2. the rate source gives ``ω̂_k`` (:class:`RateFeed`): the true rate (a perfect gyro, :class:`GyroFeed`), an
   estimator fed ``R̃_k`` (:class:`EstimatorFeed`: omegahat's default estimator, the fixed-gain observer or
   log-map differencing) or the observer with its correction's sign reversed (:class:`WrongSignFeed`);
3. the controller (:class:`omegahat.lab.control.controller.AttitudePD`) computes ``τ_k`` from ``(R̃_k, ω̂_k)`` and
   the reference at ``t_k``;
4. the torque is held over ``[t_k, t_{k+1})`` (zero-order hold) while the plant moves; the estimator is told
   that ``τ_k`` is the torque held from ``t_k`` on (its prediction to ``t_{k+1}`` uses it exactly).

(The estimators take, with a sample, the torque "known from t on", which would need ``τ_k`` before ``ω̂_k``;
with a zero-order hold that torque is only used for the next interval, so :class:`EstimatorFeed` writes ``τ_k``
into the observer's held-torque slot after the controller has run: the same estimate, the right torque.)

The plant is :class:`RigidBodyPlant` (Euler's equations with the CF4 integrator of
:mod:`omegahat.simulation.rigid_body`) or, as an independent check, MuJoCo
(:mod:`omegahat.lab.control.mujoco_plant`). A run stops early as *diverged* when the rate source's output leaves
``|ω̂| ≤ divergence_bound`` or stops being finite after having been finite.

Scoring (:func:`settling_time`, with :func:`omegahat.lab.evaluation.metrics.convergence_time`)::

    settled at t_s = min { t_k : θ_e(t_j) ≤ θ_tol and |ω(t_j) − R(t_j)ᵀ R_d ω_d| ≤ ω_tol for all j ≥ k }   (M1)

with the *true* attitude and rate, ``θ_e`` the error angle of ``R_dᵀ R``; the pointing error is the RMS of θ_e
over the last ``tail`` seconds (M2); the torque used is ``Σ_k Σ_i |τ_k,i| h`` in N m s (M3).
"""

from __future__ import annotations

import abc
import math
from collections.abc import Callable
from typing import NamedTuple, Protocol

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3
from omegahat.conversion import read_only
from omegahat.interface import Estimator, Status, StreamingEstimator
from omegahat.lab.control.controller import AttitudePD, Reference, error_angle
from omegahat.lab.evaluation.metrics import convergence_time, steady_rms
from omegahat.measurements import sample_array
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.sampled import STATE, step
from omegahat.simulation.rigid_body import RigidBody, integrate
from omegahat.simulation.sensors import noisy_attitudes
from omegahat.validation import as_positive, as_vector3

__all__ = [
    "ClosedLoopRun",
    "EstimatorFeed",
    "GyroFeed",
    "Plant",
    "RateFeed",
    "RigidBodyPlant",
    "WrongSignFeed",
    "pointing_error",
    "settling_time",
    "simulate_closed_loop",
    "torque_used",
]

_OMEGA = slice(STATE.omega_hat, STATE.omega_hat + 3)
_TORQUE = slice(STATE.torque, STATE.torque + 3)


# ------------------------------------------------------------------------------------------------ plants


class Plant(Protocol):
    """A simulated body: set its state, read it, move it under a torque held for ``h`` s (body axes)."""

    def reset(self, R0: np.ndarray, omega0: np.ndarray) -> None: ...

    def state(self) -> tuple[np.ndarray, np.ndarray]: ...

    def advance(self, tau: np.ndarray, h: float) -> None: ...


class RigidBodyPlant:
    """Euler's equations integrated by :func:`omegahat.simulation.rigid_body.integrate` (CF4, steps of at most
    ``max_step`` s) under a torque held constant over each call of :meth:`advance`."""

    def __init__(self, J: ArrayLike, max_step: float = 0.01) -> None:
        self.body = RigidBody(J)
        self.max_step = float(as_positive(max_step, "max_step")[0])
        self.reset(np.eye(3), np.zeros(3))

    def reset(self, R0: np.ndarray, omega0: np.ndarray) -> None:
        self._t = 0.0
        self._R = np.array(R0, dtype=float)
        self._w = np.array(omega0, dtype=float)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        return self._R.copy(), self._w.copy()

    def advance(self, tau: np.ndarray, h: float) -> None:
        traj = integrate(self.body, self._R, self._w, [self._t, self._t + h], torque=tau, max_step=self.max_step)
        self._t += h
        self._R, self._w = traj.R[-1], traj.omega[-1]


# ------------------------------------------------------------------------------------------------ rate feeds


class RateFeed(abc.ABC):
    """Where the controller's rate comes from (module docstring, step 2)."""

    name: str = "feed"

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget every sample."""

    @abc.abstractmethod
    def rate(self, t: float, R_meas: np.ndarray, omega_true: np.ndarray) -> np.ndarray:
        """The rate at sample time ``t`` from the measured attitude (or, for a gyro, the true rate)."""

    def hold(self, tau: np.ndarray) -> None:  # noqa: B027 - a feed without a model has nothing to do
        """Take note that ``tau`` is held from the last sample on (for a model-based estimator's prediction)."""


class GyroFeed(RateFeed):
    """The true rate: the controller with a perfect gyroscope."""

    name = "gyro"

    def reset(self) -> None:
        pass

    def rate(self, t: float, R_meas: np.ndarray, omega_true: np.ndarray) -> np.ndarray:
        return np.array(omega_true, dtype=float)


def _observer_of(estimator: Estimator) -> SarrasEstimator | None:
    """The Sarras observer whose held-torque slot an estimator predicts with (None for a model-free one)."""
    if isinstance(estimator, SupervisedKalmanEstimator):
        return estimator.observer
    if isinstance(estimator, SarrasEstimator):
        return estimator
    return None


class EstimatorFeed(RateFeed):
    """Any streaming :class:`omegahat.interface.StreamingEstimator` fed the measured attitudes; the torque reaches a
    model-based one (the Sarras observer or the default estimator, built with ``torque_hold="zero"``) through
    :meth:`hold`."""

    def __init__(self, estimator: StreamingEstimator, name: str = "estimator") -> None:
        if not isinstance(estimator, StreamingEstimator):
            raise TypeError(
                f"estimator must be an omegahat Estimator fed one sample at a time (a StreamingEstimator); got "
                f"{type(estimator).__name__}"
            )
        self.estimator = estimator
        self.name = name
        self._observer = _observer_of(estimator)
        if self._observer is not None and self._observer.torque_hold != "zero":
            raise ValueError("in a sampled loop the torque is held: build the estimator with torque_hold='zero'")

    def reset(self) -> None:
        self.estimator.reset()

    def rate(self, t: float, R_meas: np.ndarray, omega_true: np.ndarray) -> np.ndarray:
        """The estimate at ``t``; before a model-based estimator has one (its first sample), its state's rate (its
        initial ω̂₀) stands in, so that the controller acts from the first sample (NaN: no command)."""
        omega, status = self.estimator.update(t, R_meas)
        if status == Status.UNAVAILABLE and self._observer is not None:
            return self.estimator.omega_hat  # type: ignore[attr-defined]  # Sarras or the default estimator
        return np.asarray(omega, dtype=float)

    def hold(self, tau: np.ndarray) -> None:
        if self._observer is not None:
            x = self._observer.state_vector
            x[_TORQUE] = tau
            self._observer.state_vector = x


class WrongSignFeed(EstimatorFeed):
    r"""The fixed-gain observer with its correction applied with the wrong sign, the sampled counterpart of the
    paper's printed output map (``docs/theory/observer.md``, Erratum): where the estimator moves ω̂ from its
    prediction ``ω̂⁻`` to ``ω̂⁻ + c``, this feed moves it to ``ω̂⁻ − c``. Its linearised error map is
    ``z ← (2I − (I + h J⁻¹M)⁻¹) z``, expanding: a closed loop fed by it must fail."""

    def __init__(self, estimator: SarrasEstimator) -> None:
        if not isinstance(estimator, SarrasEstimator):
            raise TypeError(f"WrongSignFeed wraps a SarrasEstimator; got {type(estimator).__name__}")
        super().__init__(estimator, name="wrong sign")
        self._sarras = estimator

    def rate(self, t: float, R_meas: np.ndarray, omega_true: np.ndarray) -> np.ndarray:
        est = self._sarras
        if not est.state.initialised:  # the first sample: nothing to predict from yet
            return super().rate(t, R_meas, omega_true)
        x = est.state_vector
        m, kind = sample_array(np.full((3, 3), np.nan), None)  # a missing sample: the prediction alone
        predicted, _, _ = step(x, est.params, float(t), m, kind, read_only(x[_TORQUE]))
        corrected = super().rate(t, R_meas, omega_true)
        wrong = 2.0 * predicted[_OMEGA] - corrected
        x = est.state_vector
        x[_OMEGA] = wrong
        est.state_vector = x
        return wrong


# ------------------------------------------------------------------------------------------------ the loop


class ClosedLoopRun(NamedTuple):
    """A closed-loop run sampled at the star tracker's times ``t (T,)``: true ``R (T, 3, 3)``, ``omega (T, 3)``,
    the rate fed to the controller ``omega_hat (T, 3)``, the torque ``tau (T, 3)`` held from each sample, the
    error angle ``angle (T,)`` (rad) and the true rate error ``rate_error (T,)`` (rad/s); ``diverged``: the run
    stopped at ``t[-1]`` because the rate source diverged."""

    t: np.ndarray
    R: np.ndarray
    omega: np.ndarray
    omega_hat: np.ndarray
    tau: np.ndarray
    angle: np.ndarray
    rate_error: np.ndarray
    diverged: bool


def simulate_closed_loop(
    plant: Plant,
    controller: AttitudePD,
    feed: RateFeed,
    reference: Callable[[float], Reference],
    R0: ArrayLike,
    omega0: ArrayLike,
    *,
    horizon: float,
    rate_hz: float,
    sigma: float,
    rng: np.random.Generator,
    divergence_bound: float = 100.0,
) -> ClosedLoopRun:
    """Run the loop of the module docstring from ``(R0, omega0)`` at t = 0 for ``horizon`` s at ``rate_hz``, with
    star-tracker noise ``sigma`` rad per axis (0 for none) drawn from ``rng``."""
    R0 = so3.as_matrix(R0)
    w0 = as_vector3(omega0, "omega0")
    horizon = float(as_positive(horizon, "horizon")[0])
    h = 1.0 / float(as_positive(rate_hz, "rate_hz")[0])
    if not (math.isfinite(sigma) and sigma >= 0.0):
        raise ValueError(f"sigma must be a finite number >= 0 (rad); got {sigma!r}")
    n = math.floor(horizon / h + 1e-9) + 1
    plant.reset(R0, w0)
    feed.reset()
    out = {key: np.full((n, 3), np.nan) for key in ("omega", "omega_hat", "tau")}
    R_out = np.full((n, 3, 3), np.nan)
    angle, rate_err = np.full(n, np.nan), np.full(n, np.nan)
    diverged, had_rate = False, False
    k = 0
    for k in range(n):
        t = k * h
        R, w = plant.state()
        ref = reference(t)
        R_meas = noisy_attitudes(R, sigma, rng) if sigma > 0.0 else R
        w_hat = feed.rate(t, R_meas, w)
        finite = bool(np.all(np.isfinite(w_hat)))
        if (had_rate and not finite) or (finite and float(np.linalg.norm(w_hat)) > divergence_bound):
            diverged = True
        had_rate = had_rate or finite
        tau = controller(R_meas, w_hat, ref) if finite else np.zeros(3)  # no rate yet: no command
        R_out[k], out["omega"][k], out["omega_hat"][k], out["tau"][k] = R, w, w_hat, tau
        angle[k] = error_angle(R, ref.R_d)
        rate_err[k] = np.linalg.norm(w - R.T @ ref.R_d @ ref.omega_d)
        if diverged:
            break
        feed.hold(tau)
        if k < n - 1:
            plant.advance(tau, h)
    m = k + 1
    return ClosedLoopRun(
        np.arange(m) * h, R_out[:m], out["omega"][:m], out["omega_hat"][:m], out["tau"][:m], angle[:m],
        rate_err[:m], diverged,
    )  # fmt: skip


def settling_time(run: ClosedLoopRun, angle_tol: float, rate_tol: float) -> float:
    """(M1): the time from which the error angle stays ≤ ``angle_tol`` (rad) and the rate error ≤ ``rate_tol``
    (rad/s); ``inf`` if never, or if the run diverged."""
    if run.diverged:
        return math.inf
    score = np.maximum(run.angle / float(angle_tol), run.rate_error / float(rate_tol))
    return convergence_time(run.t, score, 1.0)


def pointing_error(run: ClosedLoopRun, tail: float) -> float:
    """(M2): the RMS error angle (rad) over the last ``tail`` s; ``inf`` if the run diverged."""
    if run.diverged:
        return math.inf
    return steady_rms(run.t, run.angle, float(run.t[-1]) - float(tail))


def torque_used(run: ClosedLoopRun) -> float:
    """(M3): ``Σ_k Σ_i |τ_k,i| h`` (N m s), the torque impulse the actuators delivered."""
    h = float(run.t[1] - run.t[0]) if run.t.size > 1 else 0.0
    return float(np.abs(run.tau[:-1]).sum() * h)
