"""The interface every angular-velocity estimator in omegahat shares.

An estimator is fed samples one at a time with :meth:`Estimator.update` (online, causal) or whole arrays with
:meth:`Estimator.run` (the same computation over a log). Both return body-frame angular velocity estimates in
rad/s: ``update`` a ``(3,)`` array for the sample's time, ``run`` a ``(T, 3)`` array, one row per sample.

Measurements are whatever the estimator was built for: attitudes (rotation matrices ``(3, 3)``, quaternions
``(4,)`` in SciPy's scalar-last order unless ``scalar_first=True``, or ``scipy.spatial.transform.Rotation``) or
body-frame measurements of known inertial directions ``(n, 3)``.
"""

from __future__ import annotations

import abc

import numpy as np

__all__ = ["Estimator"]


class Estimator(abc.ABC):
    """Common interface: ``update`` one sample, ``run`` a whole log, ``reset`` to the initial state."""

    #: True when the estimate at a sample uses only that sample and earlier ones.
    causal: bool = True

    @abc.abstractmethod
    def update(self, t: float, measurement, torque=None) -> np.ndarray:
        """Take the sample at time ``t`` and return ω̂(t), shape ``(3,)``."""

    def run(self, times, measurements, torques=None) -> np.ndarray:
        """ω̂ at every sample of a log, shape ``(T, 3)``; the default loops over :meth:`update`."""
        times = np.asarray(times, dtype=float)
        out = np.empty((times.size, 3))
        for j, t in enumerate(times):
            tau = None if torques is None else torques[j]
            out[j] = self.update(t, measurements[j], tau)
        return out

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget every sample and return to the initial state."""
