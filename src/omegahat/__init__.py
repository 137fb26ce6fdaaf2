"""omegahat: the angular velocity of a rigid body without gyroscopes, from attitude measurements.

The core is the continuous, globally exponential observer of I. Sarras, with the sign of its output map corrected
(``docs/theory/observer.md``), realised for sampled, noisy data by :class:`SarrasEstimator`; the default estimator,
:class:`SupervisedKalmanEstimator`, lets it supervise a gyro-less EKF (``docs/theory/supervised.md``). The names
below are the public API; they are imported on first use, so that ``import omegahat`` (and the command line) stays
light.

Every estimator implements one contract, :mod:`omegahat.interface` (``run``, ``update``, ``reset``, an
:class:`~omegahat.interface.Estimate` with a :class:`~omegahat.interface.Status` per sample).

Packages: :mod:`omegahat.kernels` (compiled primitives), :mod:`omegahat.observer`, :mod:`omegahat.simulation`,
:mod:`omegahat.lab.campaigns`, :mod:`omegahat.baselines`, :mod:`omegahat.lab.evaluation`, :mod:`omegahat.io`,
:mod:`omegahat.cli`; modules :mod:`omegahat.so3`, :mod:`omegahat.measurements`.
"""

from __future__ import annotations

import importlib

__version__ = "0.1.0"

#: public name -> the module that defines it
_PUBLIC = {
    "Estimate": "omegahat.interface",
    "Estimator": "omegahat.interface",
    "Status": "omegahat.interface",
    "StreamingEstimator": "omegahat.interface",
    "SarrasEstimator": "omegahat.observer.estimator",
    "SupervisedKalmanEstimator": "omegahat.observer.kalman",
    "SingleDirectionEstimator": "omegahat.observer.single_direction",
    "LostExcitationWarning": "omegahat.observer.single_direction",
    "ObserverGains": "omegahat.observer.gains",
    "check_gains": "omegahat.observer.gains",
    "theorem_gains": "omegahat.observer.gains",
    "bandwidth_gains": "omegahat.observer.tuning",
    "sensor_gains": "omegahat.observer.tuning",
    "predicted_noise_std": "omegahat.observer.tuning",
    "isotropic_noise_std": "omegahat.observer.tuning",
    "CoupledProblem": "omegahat.simulation.problem",
    "paper_problem": "omegahat.simulation.problem",
    "simulate": "omegahat.simulation.coupled",
    "simulate_batch": "omegahat.simulation.coupled",
    "Torque": "omegahat.simulation.torque",
    "RigidBody": "omegahat.simulation.rigid_body",
    "MEKF": "omegahat.baselines.mekf",
    "DifferencingEstimator": "omegahat.baselines.differencing",
    "SplineEstimator": "omegahat.baselines.spline",
    "SpectralSmoother": "omegahat.identification.spectral",
    "SavitzkyGolayEstimator": "omegahat.baselines.savgol",
    "RTSSmoother": "omegahat.baselines.rts",
    "mocap_estimator": "omegahat.observer.presets",
    "smooth": "omegahat.observer.presets",
    "MocapSmoother": "omegahat.observer.presets",
    "MeasurementError": "omegahat.rejections",
    "read_log": "omegahat.io",
    "estimate_frame": "omegahat.io.frames",
}

__all__ = ["__version__", *sorted(_PUBLIC)]


def __getattr__(name: str):
    module = _PUBLIC.get(name)
    if module is None:
        raise AttributeError(f"module 'omegahat' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted([*globals(), *_PUBLIC])
