"""What users would pick instead (``docs/baselines.md``): differencing the attitude on SO(3), SciPy's rotation
spline, the gyro-less multiplicative EKF, and three published gyro-free peers (the second-order minimum-energy filter
and the geometric predictive filter on TSO(3), Basilisk's sun-line switch-EKF). Each shares the
:class:`omegahat.interface.Estimator` interface and the input checks of :mod:`omegahat.measurements`."""

from omegahat.baselines.differencing import DifferencingEstimator, log_difference, lowpass
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.spline import SplineEstimator, spline_rate
from omegahat.baselines.sunline_sekf import SunlineSEKF
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter

__all__ = [
    "MEKF",
    "DifferencingEstimator",
    "MinimumEnergyFilter",
    "PredictiveFilter",
    "SplineEstimator",
    "SunlineSEKF",
    "log_difference",
    "lowpass",
    "spline_rate",
]
