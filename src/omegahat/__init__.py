"""omegahat: gyro-free rigid-body angular velocity estimation from attitude measurements.

The core is the continuous, globally exponential observer of I. Sarras, with the sign of its output map corrected
(see :mod:`omegahat.observer.continuous`).
"""

from omegahat.io.frames import estimate_frame
from omegahat.observer.gains import ObserverGains, check_gains, theorem_gains

__version__ = "0.1.0"

__all__ = ["ObserverGains", "__version__", "check_gains", "estimate_frame", "theorem_gains"]
