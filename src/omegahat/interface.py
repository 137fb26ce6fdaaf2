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
from collections.abc import Sequence
from typing import TypeAlias, cast

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

__all__ = ["Estimator", "Measurement", "Measurements"]

#: One sample: a rotation matrix ``(3, 3)``, a quaternion ``(4,)``, a single ``Rotation``, or ``(n, 3)`` directions.
Measurement: TypeAlias = ArrayLike | Rotation
#: A log of T samples: ``(T, 3, 3)``, ``(T, 4)``, ``(T, n, 3)``, a ``Rotation`` of T or a sequence of T Rotations.
Measurements: TypeAlias = ArrayLike | Rotation | Sequence[Rotation]


class Estimator(abc.ABC):
    """Common interface: ``update`` one sample, ``run`` a whole log, ``reset`` to the initial state."""

    #: True when the estimate at a sample uses only that sample and earlier ones.
    causal: bool = True

    @abc.abstractmethod
    def update(self, t: float, measurement: Measurement, torque: ArrayLike | None = None) -> np.ndarray:
        """Take the sample at time ``t`` and return ω̂(t), shape ``(3,)``."""

    def run(self, times: ArrayLike, measurements: Measurements, torques: ArrayLike | None = None) -> np.ndarray:
        """ω̂ at every sample of a log, shape ``(T, 3)``; the default loops over :meth:`update`."""
        times = np.asarray(times, dtype=float)
        out = np.empty((times.size, 3))
        samples = cast("Sequence[Measurement]", measurements)  # indexable: an array, a Rotation or a sequence
        taus = cast("Sequence[ArrayLike] | None", torques)
        for j, t in enumerate(times):
            tau = None if taus is None else taus[j]
            out[j] = self.update(t, samples[j], tau)
        return out

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget every sample and return to the initial state."""
