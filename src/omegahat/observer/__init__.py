"""The observer: its continuous equations, the sampled estimator, and its gains.

* :mod:`~omegahat.observer.continuous` — the paper's observer, sign-corrected, in plain NumPy (the reference);
* :mod:`~omegahat.observer.estimator` — :class:`SarrasEstimator`, the sampled streaming estimator
  (:mod:`~omegahat.observer.sampled`: its compiled step; :mod:`~omegahat.observer.reference`: its NumPy oracle);
* :mod:`~omegahat.observer.kalman` — :class:`SupervisedKalmanEstimator`, the default estimator: the sampled
  observer supervising a gyro-less EKF (:mod:`~omegahat.observer.supervised`: its compiled step);
* :mod:`~omegahat.observer.single_direction` — :class:`SingleDirectionEstimator`: the rate from ONE measured
  direction (a Sarras-type observer and a gradient one, with a run-time excitation monitor);
* :mod:`~omegahat.observer.gains` — the theorem's gain conditions; :mod:`~omegahat.observer.tuning` — gains for
  sampled noisy sensors; :mod:`~omegahat.lab.gain_sweep` — the trade-off measured by simulation;
  :mod:`~omegahat.observer.autogain` — gains chosen from a log itself (what ``omegahat estimate`` does).
"""

from omegahat.observer.estimator import EstimatorState, SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.gains import GainCheck, GainConditionWarning, ObserverGains, check_gains, theorem_gains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.single_direction import LostExcitationWarning, SingleDirectionEstimator
from omegahat.observer.tuning import bandwidth_gains, isotropic_noise_std, predicted_noise_std, sensor_gains

__all__ = [
    "EstimatorState",
    "GainCheck",
    "GainConditionWarning",
    "LostExcitationWarning",
    "ObserverGains",
    "SarrasEstimator",
    "SingleDirectionEstimator",
    "SkippedSamplesWarning",
    "SupervisedKalmanEstimator",
    "bandwidth_gains",
    "check_gains",
    "isotropic_noise_std",
    "predicted_noise_std",
    "sensor_gains",
    "theorem_gains",
]
