r"""Presets a user can type: ``mocap`` — motion capture of a body whose inertia and torques are unknown.

``omegahat estimate LOG --preset mocap`` (causal) and ``--preset mocap --smooth`` (offline, zero lag), and
:func:`mocap_estimator`, :func:`smooth` from Python. ``docs/theory/mocap.md`` has the measurements behind every
number below; they were chosen on BROAD trials 01, 06 and 10 (native 285.7 Hz and decimated to 143, 95, 57, 29
and 9.5 Hz), nothing else.

**Model.** With ``J`` and ``τ`` unknown the estimator is omegahat's default one
(:class:`omegahat.observer.kalman.SupervisedKalmanEstimator`: the Sarras observer supervising the gyro-less EKF)
with ``J = I``, ``τ = 0``, so that the EKF's model is kinematic, in one of two forms chosen by the sample rate
``f = 1/h``::

    f ≥ 80 Hz:  constant acceleration:  ω̇ = a,  ȧ = w_a,  w_a white, σ_d = 1500 rad/s^2.5,
                σ_m = max(1e-3, 10 σ̂) rad                                                          (P1)
    f < 80 Hz:  constant rate:           ω̇ = w_ω,  w_ω white, σ_a = Λ σ_m / h^1.5, Λ = 10,
                σ_m = 1e-3 rad                                                                      (P2)

with ``σ̂`` the log's attitude noise as ``omegahat estimate`` measures it (:func:`attitude_noise`: second
differences of the increments over the log's first samples; BROAD's optical attitude: 2–5e-5 rad at 286 Hz,
1–2e-4 rad at 95 Hz).

(P1) is a physical statement — the hand's angular jerk level — so the filter's discretisation scales it with the
rate by itself: its best σ_d, measured at 286, 143 and 95 Hz, is 1300–2700 rad/s^2.5 whatever the rate. Below
about 80 Hz a moving hand has power near the Nyquist frequency and extrapolating an acceleration amplifies it:
(P1) loses to backward differencing by 2.5–2.7× at 29 Hz. (P2) is the constant-rate filter at a fixed tracking index
``Λ = σ_a h^1.5 / σ_m`` (a property of the sampled filter: its gain is the same at every rate). Only the ratios
``σ_d/σ_m`` and ``σ_a/σ_m`` shape the estimate; ``σ_m`` sets the covariance's scale (its innovation statistics are
not meaningful on a hand). In (P1) ``σ_m`` grows with a noisier log's measured noise, so that an attitude
filter's output at 1 mrad is smoothed (at 100 Hz: 0.21 rad/s RMS against raw differencing's 0.26); below 80 Hz
the second differences measure the motion more than the noise (0.005–0.018 rad on BROAD at 10 Hz), so (P2)
keeps its fixed ``σ_m``.

**Supervision.** The supervisor's innovation test is switched off (threshold 1e6): a hand is not the model, its
innovations are never white, and the test would restart the EKF every few samples (measured: 3–5× the error at
29 Hz). Its divergence test (S2) stays, measured in the motion's scale as the identified default's
(:mod:`omegahat.identification`): given backward differencing's expected error ``e_d`` on the log (D1,
:func:`log_differencing_error`), σ_m, σ_a and σ_d are multiplied by one factor ``s``, which leaves the filter's
gains as they are (they depend on the ratios) and puts the observer's noise, the test's yardstick, in the motion's
scale; the EKF is restarted (with its acceleration at zero) when it leaves the observer by
:data:`~omegahat.observer.kalman.DIVERGENCE_FACTOR` times that noise for three samples, at once when its rate
is above the rotation's Nyquist bound ``π / h`` (:data:`~omegahat.observer.kalman.NYQUIST_RATE`) or its own rate
spread above the same yardstick (after a gap: (S5) of :mod:`omegahat.observer.supervised`)::

    s = max(1, e_d h / (√6 σ_m))                                                                        (P5)

Without it, an EKF that diverged after an optical gap stayed diverged (up to 1e7 rad/s written as corrected on
BROAD trials 28 and 29 at 286 Hz, 100–700 times differencing's error on trials 08 and 28 at 29 Hz); with it the
same logs score 0.64–1.05 times differencing's error, and the logs it never fired on are unchanged
(``docs/theory/mocap.md``). Without ``differencing_rms`` (sample by sample, the log not known ahead) only a state
that stops being finite restarts the EKF.

**Smoothing** (:func:`smooth`): the same estimator run forward, and again on the log reversed in time (where the
body rate is ``−ω``); each pass is moved by the filter's own lag ``d`` (:func:`filter_lag`: the steady delay of
its rate on a constant-acceleration turn, 0 for (P1), 0.33 samples for (P2)), and the two are averaged::

    ω̂_s(t_k) = ½ (ω̂_f(t_k + d) − ω̂_b(t_k − d))                                                   (P3)

(``ω̂_b`` the backward pass's rate at the same instant, in reversed time; the shifts by cubic-spline interpolation of
each pass). The forward pass lags and the backward one leads by the same amount, so the average has no lag. Near
the ends, and after a gap that restarted a pass, one pass has only just started: the average is weighted by each
pass's settling, the inverse of its rate variance that many samples after its (re)start
(:func:`rate_variance_after_start`, (P4)); elsewhere the weights are equal.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Literal, TypeAlias, get_args

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.interface import (
    Estimate,
    Estimator,
    Measurement,
    Measurements,
    StreamingEstimator,
    batch_status,
    one_of,
)
from omegahat.observer import autogain
from omegahat.observer.estimator import SkippedSamplesWarning
from omegahat.observer.kalman import DIVERGENCE_FACTOR, NYQUIST_RATE, SupervisedKalmanEstimator
from omegahat.observer.tuning import differencing_error
from omegahat.validation import as_positive

__all__ = [
    "MOCAP_SWITCH_HZ",
    "MOCAP_TUNED_NOISE",
    "PRESETS",
    "MocapModel",
    "MocapPreset",
    "MocapSmoother",
    "Preset",
    "attitude_noise",
    "estimator_for",
    "filter_lag",
    "log_differencing_error",
    "mocap_estimator",
    "mocap_model",
    "rate_variance_after_start",
    "smooth",
]

#: the presets a user can type
Preset: TypeAlias = Literal["mocap"]
PRESETS: tuple[str, ...] = get_args(Preset)
MOCAP_SWITCH_HZ = 80.0  #: (P1) at and above this sample rate, (P2) below
MOCAP_MEASUREMENT_NOISE = 1e-3  #: σ_m, rad per axis
MOCAP_JERK_NOISE = 1500.0  #: σ_d of (P1), rad/s^2.5
MOCAP_TRACKING_INDEX = 10.0  #: Λ of (P2)
MOCAP_NOISE_FACTOR = 10.0  #: (P1): σ_m = max(σ_m, this × the log's measured noise)
MOCAP_TUNED_NOISE = 2.5e-4  #: rad: the largest σ̂ of the BROAD logs at 80 Hz and above (the preset's regime)
_RATE_NOISE_FLOOR = 1e-6  # (P1): the rate itself is driven by the acceleration state, not by noise of its own
_NO_CONSISTENCY_TEST = 1e6  # supervisor thresholds that never fire on finite numbers (module docstring)


@dataclass(frozen=True)
class MocapModel:
    """What the preset runs at one sample rate: ``kind`` ``"constant-acceleration"`` (P1) or ``"constant-rate"``
    (P2), the EKF's ``rate_noise`` σ_a (rad/s^1.5), ``disturbance_noise`` σ_d (rad/s^2.5, or None) and
    ``measurement_noise`` σ_m (rad)."""

    kind: str
    rate_hz: float
    measurement_noise: float
    rate_noise: float
    disturbance_noise: float | None

    def describe(self) -> str:
        if self.disturbance_noise is not None:
            return (
                f"{self.kind} model (rate {self.rate_hz:.4g} Hz >= {MOCAP_SWITCH_HZ:g} Hz): angular jerk noise "
                f"{self.disturbance_noise:g} rad/s^2.5, attitude noise {self.measurement_noise:g} rad"
            )
        return (
            f"{self.kind} model (rate {self.rate_hz:.4g} Hz < {MOCAP_SWITCH_HZ:g} Hz): rate noise "
            f"{self.rate_noise:.4g} rad/s^1.5, attitude noise {self.measurement_noise:g} rad"
        )


def attitude_noise(times: ArrayLike, attitudes: Measurements) -> float:
    """σ̂ of (P1): the attitude noise (rad) that ``omegahat estimate`` measures on a log's first
    :data:`omegahat.observer.autogain.HEAD_SAMPLES` valid samples (:func:`omegahat.observer.autogain.measure_motion`).
    """
    log = ms.checked_log(times, attitudes)
    ok = np.flatnonzero(log.valid)[: autogain.HEAD_SAMPLES]
    if ok.size < 3:
        return autogain.SIGMA_FLOOR
    return autogain.measure_motion(log.times[ok], Rotation.from_matrix(log.values[ok])).sigma


def mocap_model(rate_hz: float, measurement_noise: float | None = None) -> MocapModel:
    """(P1) or (P2) at ``rate_hz``; ``measurement_noise`` the log's attitude noise σ̂ (rad per axis; None:
    motion-capture grade, 1e-4 rad or less). The model's own ``measurement_noise`` is σ_m of (P1), (P2)."""
    f = float(as_positive(rate_hz, "rate_hz")[0])
    sm = MOCAP_MEASUREMENT_NOISE
    if f >= MOCAP_SWITCH_HZ:
        if measurement_noise is not None:
            sm = max(sm, MOCAP_NOISE_FACTOR * float(as_positive(measurement_noise, "measurement_noise")[0]))
        return MocapModel("constant-acceleration", f, sm, _RATE_NOISE_FLOOR, MOCAP_JERK_NOISE)
    h = 1.0 / f
    return MocapModel("constant-rate", f, sm, MOCAP_TRACKING_INDEX * sm / h**1.5, None)


def mocap_estimator(
    rate_hz: float, measurement_noise: float | None = None, *, differencing_rms: float | None = None, **options: object
) -> SupervisedKalmanEstimator:
    """The preset's estimator for a log sampled at ``rate_hz`` with attitude noise ``measurement_noise``.

    (P1) at and above 80 Hz, (P2) below (module docstring), run by
    :class:`~omegahat.observer.kalman.SupervisedKalmanEstimator` with J = I, τ = 0 and the supervisor's consistency
    tests off. It is causal; :func:`smooth` is the offline, zero-lag estimate.

    Parameters
    ----------
    rate_hz : float
        The log's sample rate (Hz).
    measurement_noise : float, optional
        The log's attitude noise σ̂ (rad per axis; None: motion-capture grade, 1e-4 rad or less).
    differencing_rms : float, optional
        Backward differencing's expected RMS error on the log (rad/s, (D1) of
        :func:`~omegahat.observer.tuning.differencing_error`; :func:`log_differencing_error` measures it): given,
        the supervisor restarts a diverged EKF (module docstring, **Supervision**); None: no divergence test, the
        EKF is restarted only when its state stops being finite.
    **options
        Go to :class:`~omegahat.observer.kalman.SupervisedKalmanEstimator` (the start, input tolerances, ...).

    Returns
    -------
    SupervisedKalmanEstimator
        A new estimator (``run`` a log, or ``update`` sample by sample).

    Examples
    --------
    A turn at a constant angular acceleration (an unknown torque), sampled at 100 Hz: ``ω(t) = t · axis``.

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import mocap_estimator
    >>> axis = np.array([0.48, 0.6, 0.64])
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(0.5 * t**2, axis)).as_quat()
    >>> est = mocap_estimator(100.0)
    >>> omega = est.run(t, q).omega
    >>> print(" ".join(f"{x:.3f}" for x in omega[-1]), "| true:", " ".join(f"{x:.3f}" for x in t[-1] * axis))
    0.955 1.194 1.274 | true: 0.955 1.194 1.274
    """
    return estimator_for(mocap_model(rate_hz, measurement_noise), differencing_rms, **options)


def estimator_for(
    model: MocapModel, differencing_rms: float | None = None, **options: object
) -> SupervisedKalmanEstimator:
    """The estimator that runs ``model``: J = I, τ = 0, the supervisor's innovation test off, its divergence test
    in the motion's scale when ``differencing_rms`` is given, else off (module docstring, **Supervision**).
    ``benchmarks/mocap_tuning.py`` builds its candidates with it."""
    scale, divergence = 1.0, dict[str, object](disagreement_factor=_NO_CONSISTENCY_TEST)
    if differencing_rms is not None:
        # (P5): σ_m, σ_a, σ_d scaled together leave the filter's gains as they are and put the supervisor's
        # yardstick (the observer's noise, proportional to σ_m) in the motion's scale
        scale = max(1.0, differencing_rms / (math.sqrt(6.0) * model.rate_hz * model.measurement_noise))
        divergence = {
            "disagreement_factor": DIVERGENCE_FACTOR,
            "disagreement_yardstick": "observer",
            "max_rate": NYQUIST_RATE * model.rate_hz,
        }
    return SupervisedKalmanEstimator(
        np.eye(3),
        rate_hz=model.rate_hz,
        measurement_noise=scale * model.measurement_noise,
        rate_noise=scale * model.rate_noise,
        disturbance_noise=None if model.disturbance_noise is None else scale * model.disturbance_noise,
        nis_max=_NO_CONSISTENCY_TEST,
        **(divergence | options),  # type: ignore[arg-type]
    )


def log_differencing_error(
    times: ArrayLike, attitudes: Measurements, measurement_noise: float, **checks: object
) -> float:
    """(D1) of :func:`~omegahat.observer.tuning.differencing_error` on a log (``times (T,)``, ``attitudes`` as
    :func:`smooth` takes them, missing samples skipped; ``checks``: ``scalar_first``, ``rotation_tol``,
    ``quat_norm_tol``) with attitude noise ``measurement_noise``: the motion scale the preset's supervisor is
    measured in. Steps that are not one sample spacing (across a gap) are left out."""
    log = ms.checked_log(times, attitudes, **checks)  # type: ignore[arg-type]
    t, R = log.times[log.valid], log.values[log.valid]
    if t.size < 3:
        return 0.0
    dt = np.diff(t)
    h = float(np.median(dt))
    steps = so3.increments(R)
    steps[np.abs(dt / h - 1.0) > 0.05] = np.nan
    return differencing_error(steps, h, measurement_noise)


def smooth(
    times: ArrayLike,
    attitudes: Measurements,
    rate_hz: float | None = None,
    preset: Preset = "mocap",
    measurement_noise: float | None = None,
    **options: object,
) -> np.ndarray:
    """Zero-lag ω̂ ``(T, 3)`` (rad/s, body axes) at every sample of a whole log, by (P3).

    The preset's estimator (:func:`mocap_estimator`) runs forward and backward in time; the two passes, shifted by
    the filter's lag, are averaged with the weights (P4) (module docstring). The log is checked once, as every
    estimator checks it (:func:`omegahat.measurements.checked_log`); missing samples are bridged.

    Parameters
    ----------
    times : array_like
        The sample times ``(T,)`` (s), increasing; at least 3 samples.
    attitudes : array_like or scipy.spatial.transform.Rotation
        Matrices, quaternions (``scalar_first`` in ``options``) or a ``Rotation``, body → inertial.
    rate_hz : float, optional
        The sample rate (default: from the median spacing).
    preset : {"mocap"}, optional
        The preset (the only one: ``"mocap"``).
    measurement_noise : float, optional
        The log's attitude noise σ̂ (rad per axis; default: measured, :func:`attitude_noise`).
    **options
        ``scalar_first``, ``rotation_tol``, ``quat_norm_tol`` for the input checks; the rest go to
        :func:`mocap_estimator`.

    Returns
    -------
    numpy.ndarray
        ``(T, 3)``: ω̂ at every sample (rad/s, body axes; NaN where neither pass has an estimate).

    Raises
    ------
    ValueError
        If the log has fewer than 3 samples, or the preset is unknown.

    Examples
    --------
    At 50 Hz the causal filter (P2) lags a turn at constant angular acceleration (``ω(t) = t · axis``); the
    smoothed estimate does not:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import mocap_estimator, smooth
    >>> axis = np.array([0.48, 0.6, 0.64])
    >>> t = np.arange(0.0, 2.0, 0.02)
    >>> q = Rotation.from_rotvec(np.outer(0.5 * t**2, axis)).as_quat()
    >>> causal = mocap_estimator(50.0).run(t, q).omega
    >>> smoothed = smooth(t, q)
    >>> for name, omega in (("causal", causal), ("smoothed", smoothed), ("true", t[:, None] * axis)):
    ...     print(f"{name:8} at t = {t[50]:.1f} s:", " ".join(f"{x:.3f}" for x in omega[50]))
    causal   at t = 1.0 s: 0.477 0.596 0.636
    smoothed at t = 1.0 s: 0.480 0.600 0.640
    true     at t = 1.0 s: 0.480 0.600 0.640
    """
    one_of("preset", preset, Preset)
    checks = {k: options.pop(k) for k in ("scalar_first", "rotation_tol", "quat_norm_tol") if k in options}
    log = ms.checked_log(times, attitudes, **checks)  # type: ignore[arg-type]
    t, R = log.times, np.where(log.valid[:, None, None], log.values, np.nan)
    if t.size < 3:
        raise ValueError(f"smoothing needs at least 3 samples; got {t.size}")
    rate_hz = 1.0 / float(np.median(np.diff(t))) if rate_hz is None else rate_hz
    if measurement_noise is None:
        measurement_noise = attitude_noise(t, R)
    if "differencing_rms" not in options:
        options["differencing_rms"] = log_differencing_error(t, R, measurement_noise)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)  # missing samples: the caller counts them
        passes = [mocap_estimator(rate_hz, measurement_noise, **options) for _ in "fb"]  # type: ignore[arg-type]
        forward = passes[0].run(t, R).omega
        backward = -passes[1].run(t[-1] - t[::-1], R[::-1]).omega[::-1]
    d = filter_lag(rate_hz, measurement_noise)
    if d > 0:
        forward, backward = _shifted(t, forward, d), _shifted(t, backward, -d)
    variance = rate_variance_after_start(mocap_model(rate_hz, measurement_noise), 1.0 / rate_hz, t.size)
    variance[0] = np.inf  # at its (re)start a pass carries the observer's rate: weight 0 (the other has settled)
    fix = log.valid
    ages = [_since_restart(passes[0].last_source, fix), _since_restart(passes[1].last_source, fix[::-1])[::-1]]
    weights = np.stack([1.0 / variance[a] for a in ages])[:, :, None] * np.ones((1, 1, 3))  # (P4)
    both = np.stack([forward, backward])
    weights = np.where(np.isfinite(both), weights, 0.0)
    weights = np.where(weights.sum(axis=0) > 0, weights, np.isfinite(both))  # both just (re)started: the plain mean
    total = (weights * np.where(np.isfinite(both), both, 0.0)).sum(axis=0)
    norm = weights.sum(axis=0)
    return np.where(norm > 0, total / np.where(norm > 0, norm, 1.0), np.nan)


def _since_restart(source: np.ndarray | None, fix: np.ndarray) -> np.ndarray:
    """(P4)'s ``n`` per sample of a pass: samples since a fix last gave the observer's rate (its start, a restart)."""
    index = np.arange(fix.size)
    restart = fix & (np.zeros(fix.size) if source is None else np.asarray(source).ravel() == 0.0)
    return index - np.maximum.accumulate(np.where(restart, index, 0))


def rate_variance_after_start(model: MocapModel, h: float, n: int) -> np.ndarray:
    """(P4): the variance of one axis of the filter's rate estimate ``n`` samples into a pass, ``(n,)``, by the
    Kalman recursion of the model's linear kinematic chain (``[θ, ω]`` or ``[θ, ω, a]`` per axis, spacing ``h``,
    the attitude measured with variance σ_m², the prior 1 rad/s on the rate and 1 rad/s² on the acceleration).
    Weighting the two passes of (P3) by its inverse lets each end of the log, and each gap's, rely on the pass that
    has settled there. Run until it settles (relative change below 1e-9), then held."""
    if model.disturbance_noise is not None:
        Phi = np.array([[1.0, h, h * h / 2], [0.0, 1.0, h], [0.0, 0.0, 1.0]])
        c = np.array([[h**5 / 20, h**4 / 8, h**3 / 6], [h**4 / 8, h**3 / 3, h**2 / 2], [h**3 / 6, h**2 / 2, h]])
        Q, P = model.disturbance_noise**2 * c, np.diag([model.measurement_noise**2, 1.0, 1.0])
    else:
        Phi = np.array([[1.0, h], [0.0, 1.0]])
        Q = model.rate_noise**2 * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
        P = np.diag([model.measurement_noise**2, 1.0])
    out = np.empty(n)
    for k in range(n):
        P = Phi @ P @ Phi.T + Q if k else P
        gain = P[:, 0] / (P[0, 0] + model.measurement_noise**2)
        P = P - np.outer(gain, P[0, :])
        out[k] = P[1, 1]
        if k > 10 and abs(out[k] - out[k - 1]) <= 1e-9 * out[k]:
            out[k:] = out[k]
            break
    return out


def filter_lag(rate_hz: float, measurement_noise: float | None = None) -> float:
    """The preset filter's lag ``d`` (s) of (P3): its steady rate error on a noise-free turn at constant angular
    acceleration ``α`` is ``−α d`` (a filter that tracks ramps, (P1), has none)."""
    if mocap_model(rate_hz, measurement_noise).disturbance_noise is not None:
        return 0.0
    alpha, axis = 0.05, np.array([0.6, 0.0, 0.8])
    t = np.arange(0.0, 400.0 / rate_hz, 1.0 / rate_hz)  # the filter settles within ~20 samples
    R = so3.exp(np.outer(0.5 * alpha * t**2, axis))
    omega = mocap_estimator(rate_hz, measurement_noise, omega_hat0=np.zeros(3)).run(t, R).omega
    error = (omega - np.outer(alpha * t, axis))[t.size // 2 :] @ axis
    return float(-np.mean(error) / alpha)


def _shifted(t, w, d):
    """``w`` at ``t + d`` by cubic-spline interpolation of its finite rows, where it has them (a pass with no rate
    before its first fix gets none by extrapolation: a cubic over a missing stretch ran to 90 rad/s)."""
    ok = np.all(np.isfinite(w), axis=1)
    return w if ok.sum() < 4 else np.where(ok[:, None], CubicSpline(t[ok], w[ok], axis=0)(t + d), np.nan)


class MocapPreset(StreamingEstimator):
    """``--preset mocap`` behind the estimator contract (causal). ``measurement_noise``: the log's σ̂; None: :meth:`run`
    on a fresh estimator measures it on the log's head (:func:`attitude_noise`), :meth:`update` takes motion-capture
    grade noise. ``options`` go to :func:`mocap_estimator`. The torque is not used (the preset is for unknown ones)."""

    estimator: SupervisedKalmanEstimator  # the one that runs: :func:`mocap_estimator`'s (set by reset and run)

    def __init__(self, *, rate_hz: float, measurement_noise: float | None = None, **options: object) -> None:
        self.rate_hz, self.measurement_noise, self.options = rate_hz, measurement_noise, options
        self.reset()

    @property
    def n_skipped(self) -> int:  # type: ignore[override]  # the estimator's own count
        return self.estimator.n_skipped

    def update(self, t: float, sample: Measurement, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at ``t`` (``torque`` not used); a refused sample leaves the estimator as it was."""
        out, self._fresh = self.estimator.update(t, sample), False  # after it: a refused one changes nothing
        return out

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at every sample; from a fresh state without ``measurement_noise``, an estimator for the log's
        measured noise (``torque`` not used)."""
        if self._fresh and (self.measurement_noise is None or "differencing_rms" not in self.options):
            sigma = attitude_noise(t, data) if self.measurement_noise is None else self.measurement_noise
            options = dict(self.options)
            if "differencing_rms" not in options:
                checks = {k: v for k, v in options.items() if k in ("scalar_first", "rotation_tol", "quat_norm_tol")}
                options["differencing_rms"] = log_differencing_error(t, data, sigma, **checks)
            self.estimator = mocap_estimator(self.rate_hz, sigma, **options)  # type: ignore[arg-type]
        self._fresh = False
        return self.estimator.run(t, data)

    def reset(self) -> None:
        """Back to a new estimator (nothing seen)."""
        self.estimator, self._fresh = mocap_estimator(self.rate_hz, self.measurement_noise, **self.options), True  # type: ignore[arg-type]


class MocapSmoother(Estimator):
    """:func:`smooth` behind the estimator contract: offline only (``run``), ``causal = False``.

    ``run(t, data)`` returns an :class:`~omegahat.interface.Estimate`: the zero-lag ω̂ of :func:`smooth` and a
    status per sample; a missing sample is bridged by both passes (status ``predicted``) and counted in
    ``n_skipped``. The torque is not used: the preset is for unknown ones.

    Parameters
    ----------
    rate_hz, measurement_noise : float, optional
        The sample rate (Hz) and the log's attitude noise σ̂ (rad per axis): as :func:`smooth` (None: from the log).
    scalar_first, rotation_tol, quat_norm_tol : optional
        The input checks of :mod:`omegahat.measurements` (quaternions scalar last by default, as SciPy's).

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import MocapSmoother
    >>> from omegahat.interface import Status
    >>> axis = np.array([0.48, 0.6, 0.64])
    >>> t = np.arange(0.0, 2.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(0.5 * t**2, axis)).as_quat()  # ω(t) = t · axis
    >>> q[100] = np.nan  # a missing sample
    >>> smoother = MocapSmoother()
    >>> est = smoother.run(t, q)
    >>> print(" ".join(f"{x:.3f}" for x in est.omega[100]), Status(est.status[100]).name, smoother.n_skipped)
    0.480 0.600 0.640 PREDICTED 1
    """

    causal = False

    def __init__(
        self,
        *,
        rate_hz: float | None = None,
        measurement_noise: float | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
    ) -> None:
        self.rate_hz, self.measurement_noise, self.scalar_first = rate_hz, measurement_noise, bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """Zero-lag ω̂ at every sample ``(T, 3)`` and the statuses (``torque`` not used: the preset is for unknown
        ones)."""
        tols = {"rotation_tol": self.rotation_tol, "quat_norm_tol": self.quat_norm_tol}
        log = ms.checked_log(t, data, scalar_first=self.scalar_first, **tols)
        R = np.where(log.valid[:, None, None], log.values, np.nan)  # the checked log, NaN where skipped
        omega = smooth(
            log.times, R, self.rate_hz, measurement_noise=self.measurement_noise
        )  # R is checked: no second verdict
        self.n_skipped = int(np.count_nonzero(~log.valid))
        return Estimate(omega, batch_status(log.valid, omega))
