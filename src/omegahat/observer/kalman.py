r"""omegahat's default estimator: a Kalman filter supervised by the globally convergent Sarras observer.

Two estimators run side by side on every sample (``docs/theory/supervised.md`` explains the design at length):

* **the observer**, :class:`omegahat.observer.estimator.SarrasEstimator` with the isotropic, aimed correction
  (every error mode decays at ``b`` rad/s; the correction aimed along the predicted motion): it converges from
  any initial rate, needs no prior and no covariance, but its noise is that of a first-order filter of bandwidth b;
* **the EKF**, the gyro-less multiplicative EKF with the dynamic model (:mod:`omegahat.kernels.ekf`, the same
  equations as :class:`omegahat.baselines.mekf.MEKF`): it weighs each fix with the right time-varying gain, so its
  steady-state error is the smallest a model-based filter gets, but it converges only from close enough.

A supervisor (:mod:`omegahat.observer.supervised`, (S1)–(S5)) starts the EKF from the observer, watches its
innovations and its agreement with the observer, and restarts it from the observer whenever it is inconsistent,
uncertain or persistently disagreeing. The output is the EKF's estimate while it is trusted, else the observer's.

**What is proven, what is measured.** The observer's convergence is the paper's theorem for the continuous
observer (sampled: measured, ``docs/theory/sampled.md``); it runs untouched by the EKF, so after any number of
restarts it is still converging. Once it is within the EKF's basin, a restart from it puts the EKF there too:
the EKF's local convergence (classical) then applies. That the supervisor restarts the EKF only finitely often and
that the EKF's basin contains the observer's noise ball are *measured* (the robustness campaign of
``omegahat compare``), not proven.
"""

from __future__ import annotations

import math
from typing import Any, Literal, TypeAlias

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.interface import MeasurementKind, TorqueHold, one_of
from omegahat.kernels.ekf import EKF_SCRATCH, NOMINAL_SUBSTEP_ANGLE
from omegahat.observer import supervised
from omegahat.observer.compiled import CompiledEstimator
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.prediction import MAX_SUBSTEP_ANGLE
from omegahat.observer.supervised import EKF_PARAMS, EKF_STATE
from omegahat.observer.tuning import isotropic_noise_std
from omegahat.validation import as_positive

__all__ = ["DIVERGENCE_FACTOR", "NYQUIST_RATE", "SupervisedKalmanEstimator", "Yardstick"]

#: what (S2) measures the disagreement against (``disagreement_yardstick``)
Yardstick: TypeAlias = Literal["either", "observer"]

#: (S2)'s factor κ where the motion is not the filter's model (a hand, or no J): the EKF is restarted only when it
#: leaves the observer by 50 times the observer's noise in the motion's scale, a divergence, never a model's misfit
#: (the identified default without J, :mod:`omegahat.identification`, and the mocap preset, :mod:`~.presets`)
DIVERGENCE_FACTOR = 50.0

#: the rotation's Nyquist bound per hertz of sampling (rad/s per Hz): no attitude log tells a turn of more than π
#: between samples from the shorter one the other way, so a kinematic filter's rate above it is not an estimate
NYQUIST_RATE = math.pi


class SupervisedKalmanEstimator(CompiledEstimator):
    """The Sarras observer supervising a gyro-less EKF: omegahat's default estimator (module docstring).

    ``update(t, sample, torque)`` takes one sample, ``run(t, data, torques)`` a log (atomic); both return an
    :class:`~omegahat.interface.Estimate`. The output is the EKF's rate while it is trusted, else the observer's
    (``last_source``: 1 where it was the EKF's); ``restarts`` counts the EKF's restarts (S4).

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    rate_hz : float
        The nominal sample rate (Hz); the observer's bandwidth is ``observer_bandwidth × rate_hz`` rad/s.
    measurement_noise : float
        The attitude noise (rad, one standard deviation per axis), or that of each direction component.
    rate_noise : float, optional
        The EKF's process noise σ_a (rad/s^1.5): the torque noise PSD is ``q = (tr(J)/3 · σ_a)²``; it models what
        the known torque leaves out.
    references, measurement : optional
        As :class:`omegahat.observer.estimator.SarrasEstimator`.
    omega_hat0 : array_like, optional
        The initial rate estimate (default 0); ``warm_start`` takes it from the first two samples instead.
    omega_hat0_noise : float, optional
        The RMS error of ``omega_hat0`` (rad/s, of the 3-vector): the EKF's rate prior at its first start
        (default: the observer's stationary noise, as at every restart). A rate fitted over a window of the log
        is known far better than the observer's noise: without it the EKF would start as if from scratch.
    r_hat0 : array_like, optional
        The observer's initial filtered directions (default: the first measurement); the EKF always starts from a
        measured attitude.
    warm_start : bool, optional
        Default: on unless ``omega_hat0`` or ``r_hat0`` is given (as the observer's).
    torque_hold : {"zero", "linear"}, optional
        ``"zero"`` (default) or ``"linear"``, for both parts (as the observer's).
    observer_bandwidth : float, optional
        The observer's isotropic rate per hertz of sample rate (default 1: the observer's error halves every
        sample).
    disturbance_noise, sigma_accel0 : float, optional
        For a body whose torque (or inertia) is not fully known: None (default) or σ_d (rad/s^2.5); the EKF then
        also estimates the unknown angular acceleration ``a`` (the torque ``J a`` the model lacks), a random walk
        of PSD ``σ_d²``, prior standard deviation ``sigma_accel0`` (rad/s², default 1), so that it predicts with
        it between samples instead of holding the modelled motion (``docs/theory/supervised.md``).
    scalar_first, rotation_tol, quat_norm_tol, min_angle_deg, max_substep_angle : optional
        As :class:`omegahat.observer.estimator.SarrasEstimator`.
    nis_window, nis_max, disagreement_factor, disagreement_samples : optional
        The supervisor's constants (S1)–(S3): the NIS average's window ``1/α`` (samples, at least 1), ``ν_max``,
        ``κ`` and ``c_max``.
    disagreement_yardstick : {"either", "observer"}, optional
        ``"either"`` (default): (S2) measures the disagreement against the larger of the EKF's own spread and the
        observer's noise; ``"observer"``: against the observer's noise alone, so that an EKF whose covariance
        grew with its own divergence (after a long gap in a fast turn) is still caught.
    max_rate : float, optional
        ``ω_max`` of (S3) (rad/s; default: no bound): an EKF rate above it is lost at once. Without a dynamic
        model a rate above ``π × rate_hz`` turns the body more than half a turn between samples, which the
        attitudes cannot tell from the shorter turn the other way (:data:`NYQUIST_RATE` per hertz).
    restart_after : float, optional
        (S5): an interval between fixes (s) above which both start over at the fix, the observer from its warm
        start at the next (default: none; ``omegahat estimate`` without a dynamic model: where its identification
        restarts, :data:`omegahat.identification.likelihood.RESTART_GAP` spacings).

    Raises
    ------
    ValueError
        If an argument is out of range (as the observer's, or ``nis_window`` below 1).

    Examples
    --------
    Noisy attitudes (1 mrad per axis) of a body turning at a constant rate (J = I), 100 Hz:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import SupervisedKalmanEstimator
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 5.0, 0.01)
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    >>> q = (Rotation.from_rotvec(np.outer(t, w)) * noise).as_quat()
    >>> est = SupervisedKalmanEstimator(np.eye(3), rate_hz=100.0, measurement_noise=1e-3)
    >>> omega = est.run(t, q).omega
    >>> print(" ".join(f"{x:.3f}" for x in omega[-1]))
    0.300 -0.200 0.500
    >>> est.restarts, bool(est.last_source[-1])  # never restarted; the output is the EKF's
    (0, True)
    >>> print(f"mean NIS {est.mean_nis:.1f}")  # about 1: the noise model fits
    mean NIS 1.0
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        rate_hz: float,
        measurement_noise: float,
        rate_noise: float = 1e-4,
        references: ArrayLike | None = None,
        measurement: MeasurementKind | None = None,
        omega_hat0: ArrayLike | None = None,
        omega_hat0_noise: float | None = None,
        r_hat0: ArrayLike | None = None,
        warm_start: bool | None = None,
        torque_hold: TorqueHold = "zero",
        observer_bandwidth: float = 1.0,
        disturbance_noise: float | None = None,
        sigma_accel0: float = 1.0,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
        max_substep_angle: float = MAX_SUBSTEP_ANGLE,
        nis_window: float = 5.0,
        nis_max: float = 4.0,
        disagreement_factor: float = 5.0,
        disagreement_samples: int = 3,
        disagreement_yardstick: Yardstick = "either",
        max_rate: float = math.inf,
        restart_after: float = math.inf,
    ) -> None:
        self.rate_hz = float(as_positive(rate_hz, "rate_hz")[0])
        self.measurement_noise = float(as_positive(measurement_noise, "measurement_noise")[0])
        self.rate_noise = float(as_positive(rate_noise, "rate_noise")[0])
        self.observer_rate = float(as_positive(observer_bandwidth, "observer_bandwidth")[0]) * self.rate_hz
        n = 3 if references is None else np.atleast_2d(np.asarray(references)).shape[0]
        self.observer = SarrasEstimator(
            J,
            gains=ObserverGains.constant(1.0, 10.0 * self.observer_rate, n=n),
            references=references,
            measurement=measurement,
            omega_hat0=omega_hat0,
            r_hat0=r_hat0,
            scalar_first=scalar_first,
            rotation_tol=rotation_tol,
            quat_norm_tol=quat_norm_tol,
            min_angle_deg=min_angle_deg,
            max_substep_angle=max_substep_angle,
            warm_start=warm_start,
            torque_hold=torque_hold,
            isotropic_rate=self.observer_rate,
        )
        self.J = self.observer.J
        #: the observer's stationary noise, total over the three axes (rad/s): the supervisor's yardstick
        self.observer_noise = float(
            np.sqrt(3.0) * isotropic_noise_std(self.rate_hz, self.measurement_noise, self.observer_rate)
        )
        jbar = float(np.trace(self.J)) / 3.0
        sigma_theta = self.measurement_noise if self.observer.measurement == "attitude" else 0.1
        if not nis_window >= 1.0:
            raise ValueError(f"nis_window must be at least 1 sample; got {nis_window!r}")
        values = {
            "q": (jbar * self.rate_noise) ** 2,
            "meas_var": self.measurement_noise**2,
            "sigma_theta": sigma_theta,
            "sigma_obs": self.observer_noise,
            "own_spread": float(one_of("disagreement_yardstick", disagreement_yardstick, Yardstick) == "either"),
            "max_rate": math.inf if max_rate == math.inf else float(as_positive(max_rate, "max_rate")[0]),
            "restart_after": math.inf
            if restart_after == math.inf
            else float(as_positive(restart_after, "restart_after")[0]),
            "sigma_start": 0.0
            if omega_hat0_noise is None or omega_hat0 is None
            else float(as_positive(omega_hat0_noise, "omega_hat0_noise")[0]),
            "alpha": 1.0 / float(nis_window),
            "nis_max": float(as_positive(nis_max, "nis_max")[0]),
            "kappa": float(as_positive(disagreement_factor, "disagreement_factor")[0]),
            "disagree_max": float(as_positive(disagreement_samples, "disagreement_samples")[0]),
            "dynamic": 1.0,
            "max_step": np.inf,
            "max_angle": NOMINAL_SUBSTEP_ANGLE,
            "q_a": 0.0
            if disturbance_noise is None
            else float(as_positive(disturbance_noise, "disturbance_noise")[0]) ** 2,
            "sigma_accel": float(as_positive(sigma_accel0, "sigma_accel0")[0]),
        }
        self._ekf_params = np.array([values[name] for name in EKF_PARAMS._fields if name != "size"])
        self._configure_input(
            n_directions=None if self.observer.measurement == "attitude" else n,
            rate_given=omega_hat0 is not None and not self.observer.warm_start,
        )
        self.reset()

    def _reset_state(self) -> None:
        self.observer.reset()
        self._xe = supervised.initial_ekf_state()
        # the step's outputs and scratch, kept: update calls the very compiled step that run loops over (the wheel
        # ships it, so a first update compiles nothing), with the same argument types
        self._xs_next = np.empty_like(self.observer.state_vector)
        self._xe_next = np.empty_like(self._xe)
        self._work = np.empty((self.observer.gains.n + 6, 3))
        self._ekf_work = np.empty(EKF_SCRATCH + 9)
        self._observer_params = self.observer.params
        #: per sample of the last ``update`` or ``run``: 1 where the output is the EKF's, 0 where the observer's
        self.last_source: np.ndarray | None = None

    @property
    def measurement(self) -> str:
        return self.observer.measurement

    @property
    def omega_hat(self) -> np.ndarray:
        """The last output (the EKF's rate when it was trusted at the last sample, else the observer's)."""
        if self._xe[EKF_STATE.source] == supervised.FROM_EKF:
            return self._xe[EKF_STATE.omega : EKF_STATE.omega + 3].copy()
        return self.observer.omega_hat

    @property
    def mean_nis(self) -> float:
        """The EKF's normalised innovation squared per degree of freedom, averaged over the fixes it was judged on
        (about 1 when its noise model fits the data; NaN before any)."""
        n = self._xe[EKF_STATE.nis_count]
        return float(self._xe[EKF_STATE.nis_sum] / n) if n > 0 else float("nan")

    @property
    def restarts(self) -> int:
        """How many times the supervisor restarted the EKF from the observer (S4)."""
        return int(self._xe[EKF_STATE.resets])

    @property
    def ekf_covariance(self) -> np.ndarray:
        """The EKF's error covariance ``P`` (6×6: attitude error, rate error; 9×9 with the unknown acceleration)."""
        n = 9 if self._ekf_params[EKF_PARAMS.q_a] > 0.0 else 6
        return self._xe[EKF_STATE.P : EKF_STATE.P + n * n].reshape(n, n).copy()

    @property
    def accel(self) -> np.ndarray:
        """The EKF's estimate of the unknown angular acceleration (rad/s², body axes; zero unless
        ``disturbance_noise`` is given)."""
        return self._xe[EKF_STATE.accel : EKF_STATE.accel + 3].copy()

    # -- the compiled step (the base converts, refuses, counts) -------------------------------------------------

    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        xs, xe = self._xs_next, self._xe_next  # pure all the same: written here, the state only once committed
        status, info, w = supervised.step_into(
            self.observer.state_vector, self._observer_params, self._xe, self._ekf_params, t, m, kind, tau, xs, xe,
            self._work, self._ekf_work,
        )  # fmt: skip
        return (xs, xe, np.array([xe[EKF_STATE.source]])), w, int(status), float(info)  # update copies w

    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        xs, xe, W, source, status, first_bad, info = supervised.run(
            self.observer.state_vector, self.observer.params, self._xe, self._ekf_params, times, m, kind, taus
        )
        return (xs, xe, source), W, status, int(first_bad), float(info)

    def _commit(self, state: Any) -> None:
        xs, xe, self.last_source = state
        if xe is self._xe_next:  # an update's: the old EKF state becomes the next output
            self._xe_next = self._xe
        self._xe = xe
        self.observer.state_vector = xs  # a copy: the kept output stays the step's
