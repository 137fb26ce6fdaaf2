"""Compiled primitives (Numba), each written once: the kernels of omegahat are built from these.

========================================  =====================================================================
:mod:`omegahat.kernels.vec3`              3-vectors and 3×3 matrices as scalars: cross, dot, norm, M x, M⁻¹ y
:mod:`omegahat.kernels.rotation`          exp/log on SO(3), quaternions, nearest rotation, dexp⁻¹, Wahba
:mod:`omegahat.kernels.expfn`             the exponential in plain arithmetic, the φ-functions, small sin/cos
:mod:`omegahat.kernels.dynamics`          Euler's equations, their error form, the CF4 Lie-group step
:mod:`omegahat.kernels.observer`          the observer's own terms: innovation, filter decay, stiffness, output map
:mod:`omegahat.kernels.ekf`               the gyro-less multiplicative EKF's step: propagation, the two fixes
:mod:`omegahat.kernels.cache`             the on-disk cache: invalidated by any change to compiled code, private
:mod:`omegahat.kernels.compiling`         the time spent compiling, measured, and the notice when it starts
========================================  =====================================================================

Names are public within the package; the kernels that use them (the simulation engine, the sampled estimator, the
MEKF, the rigid-body integrator) import them from here. ``cache`` is imported first: it must see every cached
function defined.
"""

from omegahat.kernels import cache as cache  # first: registers the cache locator
from omegahat.kernels import compiling as compiling  # then: times every compilation from the start
