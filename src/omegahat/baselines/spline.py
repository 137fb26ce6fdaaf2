r"""Angular velocity from SciPy's rotation spline (offline; a peer no one here wrote).

Reference: ``docs/baselines.md``, "SciPy's RotationSpline" and SciPy's ``scipy.spatial.transform.RotationSpline``: a
cubic spline of rotation vectors with continuous angular rate and acceleration, interpolating the samples.
``RotationSpline(times, rotations)(t, 1)`` is the body-frame rate (checked in ``tests/test_spline.py``
against a closed-form trajectory). This module only calls SciPy: it checks the log through the one input path
(:func:`omegahat.measurements.checked_log`), drops the skipped (non-finite) samples, fits the spline through the
others, and evaluates its first derivative at every sample time.

It needs the whole record (``causal = False``, no ``update``) and interpolates rather than smooths, so
attitude noise passes through to the rate, amplified like differencing.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation, RotationSpline

from omegahat import measurements as ms
from omegahat.interface import Measurements

__all__ = ["SplineEstimator", "spline_rate"]


def spline_rate(
    times: ArrayLike,
    attitudes: ArrayLike | Rotation,
    scalar_first: bool = False,
    rotation_tol: float = ms.ROTATION_TOL,
    quat_norm_tol: float = ms.QUAT_NORM_TOL,
) -> np.ndarray:
    """Body-frame ω̂ ``(T, 3)`` at ``times`` from ``RotationSpline`` through the finite samples.

    ``attitudes``: a ``Rotation``, matrices ``(T, 3, 3)`` or quaternions ``(T, 4)`` (scalar last unless
    ``scalar_first``), checked with the times by :func:`omegahat.measurements.checked_log`; non-finite samples are
    left out of the fit (the spline bridges them). Needs at least two finite samples. A ``Rotation`` is handed to
    SciPy untouched.
    """
    log = ms.checked_log(
        times, attitudes, scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
    )
    return _spline(log, attitudes)


def _spline(log: ms.CheckedLog, attitudes: Measurements) -> np.ndarray:
    if isinstance(attitudes, Rotation):
        return RotationSpline(log.times, attitudes)(log.times, 1)
    valid = log.valid
    if valid.sum() < 2:
        raise ValueError(f"the spline needs at least 2 finite attitude samples; got {int(valid.sum())}")
    spline = RotationSpline(log.times[valid], Rotation.from_matrix(log.values[valid]))
    return spline(log.times, 1)


class SplineEstimator(ms.AttitudeBatchEstimator):
    """SciPy's ``RotationSpline`` behind the estimator contract: offline only (``run``), ``causal = False``.

    A skipped (non-finite) sample is bridged by the spline (status ``predicted``). The spline interpolates the
    samples, so attitude noise passes through to the rate (module docstring).

    Parameters
    ----------
    references, scalar_first, rotation_tol, quat_norm_tol : optional
        Keyword-only: the inertial directions of direction input (the spline runs through each sample's
        least-squares attitude), and the input checks of :mod:`omegahat.measurements` (quaternion order,
        tolerances).

    Examples
    --------
    A body turning at a constant rate, sampled at 100 Hz, one sample missing:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import SplineEstimator, Status
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    >>> q[50] = np.nan
    >>> est = SplineEstimator().run(t, q)
    >>> print(" ".join(f"{x:.3f}" for x in est.omega[50]), Status(est.status[50]).name)
    0.300 -0.200 0.500 PREDICTED
    """

    def rates(self, log: ms.CheckedLog, data: Measurements) -> np.ndarray:
        """The spline's derivative at the log's times (module docstring)."""
        return _spline(log, data)
