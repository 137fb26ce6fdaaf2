"""What users would pick instead (``docs/baselines.md``): differencing the attitude on SO(3), SciPy's rotation
spline, and the gyro-less multiplicative EKF. Each shares the :class:`omegahat.interface.Estimator` interface and
the input checks of :mod:`omegahat.measurements`."""

from omegahat.baselines.differencing import DifferencingEstimator, log_difference, lowpass
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.spline import SplineEstimator, spline_rate

__all__ = ["MEKF", "DifferencingEstimator", "SplineEstimator", "log_difference", "lowpass", "spline_rate"]
