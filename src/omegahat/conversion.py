r"""Users' samples, logs, times and torques as the arrays the compiled checks take: types and shapes, once.

Every estimator converts its input here before anything runs (:class:`omegahat.observer.compiled.CompiledEstimator`
and the checked paths of :mod:`omegahat.measurements`, which re-exports these names): what is not real numbers is
refused (``TypeError``: a complex number, whose imaginary part a conversion would drop, a time given as text), and
so is a wrong shape (``ValueError`` naming the shape). The values themselves (finite, a rotation, in time order) are
the compiled checks' (:mod:`omegahat.kernels.checks`).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat.interface import Measurement, Measurements
from omegahat.kernels.checks import KIND_DIRECTIONS, KIND_MATRIX, KIND_QUAT
from omegahat.validation import as_directions, as_positive

__all__ = [
    "as_references",
    "log_array",
    "min_angle",
    "read_only",
    "real_array",
    "sample_array",
    "sample_time",
    "times_array",
    "tolerances",
    "torque_vector",
    "torques_array",
]


def read_only(a: np.ndarray) -> np.ndarray:
    """A read-only view of ``a`` (no copy). Every array a compiled kernel only reads is handed to it read-only:
    Numba compiles one specialisation per read-only flag, so a writeable torque from one caller and the shared
    read-only zero from another would compile the whole step twice (tens of seconds on a cold cache)."""
    view = a.view()
    view.flags.writeable = False
    return view


_ZERO3 = read_only(np.zeros(3))


def as_references(references: ArrayLike | None, n_default: int = 3) -> np.ndarray:
    """Inertial reference directions ``(n, 3)``, normalised; default the first ``n_default`` axes (rows of R)."""
    if references is None:
        return read_only(np.eye(3)[:n_default].copy())
    return read_only(np.ascontiguousarray(as_directions(references, name="references")))


def real_array(values: object, what: str) -> np.ndarray:
    """``values`` as a C-contiguous float array, refusing (``TypeError``) what is not real numbers: complex
    numbers (whose imaginary part a conversion would drop), text (``"1.0"``), objects that are neither."""
    if type(values) is np.ndarray and values.dtype == np.float64 and values.flags.c_contiguous:
        return values  # the common case, at once
    a = np.asarray(values)
    if a.dtype.kind == "O" and not any(isinstance(x, str | bytes | complex) for x in a.flat):
        a = np.asarray(a.tolist(), dtype=float) if a.size else a.astype(float)
    if a.dtype.kind not in "iuf":
        kind = "complex" if a.dtype.kind == "c" else "text" if a.dtype.kind in "USO" else str(a.dtype)
        raise TypeError(f"{what} must be real numbers; got {kind}: {np.asarray(values).ravel()[:3].tolist()!r}")
    return np.asarray(a, dtype=float, order="C")  # C-contiguous; a 0-d value stays 0-d


def sample_time(t: object) -> float:
    """A sample's time as a float, refused (``TypeError``) unless a real number, ``ValueError`` unless one."""
    if isinstance(t, float | int | np.integer) and not isinstance(t, bool):  # the common case, at once
        return float(t)
    a = real_array(t, "a sample's time")
    if a.shape != ():
        raise ValueError(f"a sample's time must be one number; got shape {a.shape}")
    return float(a)


def sample_array(measurement: Measurement, n: int | None = None) -> tuple[np.ndarray, int]:
    """One sample as ``(m 2-D, kind)`` for :func:`convert_sample`, shape checked (values are not): an attitude
    (``n`` None: a matrix, a quaternion or a single Rotation) or ``n`` body-frame directions ``(n, 3)``; one
    direction (``n = 1``, the caller's word: the one-direction estimators) also as ``(3,)``."""
    if isinstance(measurement, Rotation):
        if not measurement.single:
            raise ValueError(f"update takes one sample; got a Rotation holding {len(measurement)}")
        return measurement.as_matrix(), KIND_MATRIX
    m = real_array(measurement, "a sample")
    if n is None:
        if m.shape == (3, 3):
            return m, KIND_MATRIX
        if m.shape == (4,):
            return m.reshape(1, 4), KIND_QUAT
        raise ValueError(
            f"an attitude sample must be a 3x3 matrix, a quaternion (4,) or a Rotation; got shape {m.shape}"
        )
    if n == 1 and m.shape in ((3,), (1, 3)):
        return m.reshape(1, 3), KIND_DIRECTIONS
    if n == 1:
        raise ValueError(f"a one-direction sample must have shape (3,) or (1, 3); got shape {m.shape}")
    if m.shape != (n, 3):
        raise ValueError(f"a direction sample must have shape ({n}, 3) (one row per reference); got shape {m.shape}")
    return m, KIND_DIRECTIONS


def log_array(measurements: Measurements, T: int, n: int | None = None) -> tuple[np.ndarray, int]:
    """A log of ``T`` samples as ``(m (T, a, b), kind)``, shape checked: attitudes (``n`` None: matrices
    ``(T, 3, 3)``, quaternions ``(T, 4)``, a Rotation of T or a list of T Rotations) or directions ``(T, n, 3)``;
    one direction (``n = 1``) also as ``(T, 3)``."""
    if isinstance(measurements, list | tuple) and measurements and all(isinstance(x, Rotation) for x in measurements):
        measurements = Rotation.concatenate(measurements)
    if isinstance(measurements, Rotation):
        m = np.atleast_3d(measurements.as_matrix()).reshape(-1, 3, 3)
        if n is not None:
            raise ValueError(f"measurements must have shape (T, {n}, 3) with T = {T} samples; got a Rotation")
        if m.shape[0] != T:
            raise ValueError(f"{m.shape[0]} measurements for {T} times")
        return np.ascontiguousarray(m), KIND_MATRIX
    m = real_array(measurements, "measurements")
    if n is None and m.shape == (T, 3, 3):
        return np.ascontiguousarray(m), KIND_MATRIX
    if n is None and m.shape == (T, 4):
        return np.ascontiguousarray(m.reshape(T, 1, 4)), KIND_QUAT
    if n is not None and m.shape == (T, n, 3):
        return np.ascontiguousarray(m), KIND_DIRECTIONS
    if n == 1 and m.shape == (T, 3):
        return np.ascontiguousarray(m.reshape(T, 1, 3)), KIND_DIRECTIONS
    want = "(T, 3, 3) or (T, 4)" if n is None else "(T, 3) or (T, 1, 3)" if n == 1 else f"(T, {n}, 3)"
    raise ValueError(f"measurements must have shape {want} with T = {T} samples; got shape {m.shape}")


def tolerances(rotation_tol: float, quat_norm_tol: float) -> tuple[float, float]:
    """An estimator's ``(rotation_tol, quat_norm_tol)`` (P), checked positive and finite."""
    return float(as_positive(rotation_tol, "rotation_tol")[0]), float(as_positive(quat_norm_tol, "quat_norm_tol")[0])


def min_angle(min_angle_deg: float) -> float:
    """An estimator's ``min_angle_deg`` (the least angle between two measured directions, degrees), checked in
    ``[0, 90)``."""
    if not 0 <= min_angle_deg < 90:  # False for NaN too
        raise ValueError(f"min_angle_deg must be in [0, 90); got {min_angle_deg!r}")
    return float(min_angle_deg)


def times_array(times: ArrayLike) -> np.ndarray:
    """Sample times as a C-contiguous float array ``(T,)`` (shape checked; values by :func:`check_time`)."""
    t = real_array(times, "times")
    if t.ndim != 1:
        raise ValueError(f"times must have shape (T,); got shape {t.shape}")
    return t


def torque_vector(torque: ArrayLike | None) -> np.ndarray:
    """The torque of one sample ``(3,)`` (None: a shared read-only zero), shape checked (values by
    :func:`check_torque`)."""
    if torque is None:
        return _ZERO3
    tau = real_array(torque, "torque")
    if tau.shape != (3,):
        raise ValueError(f"torque must be a 3-vector; got shape {tau.shape}")
    return read_only(tau)


def torques_array(torques: ArrayLike | None, T: int) -> np.ndarray:
    """The torques of a log ``(T, 3)`` (None: zeros), shape checked (values by :func:`check_torque`)."""
    if torques is None:
        return read_only(np.zeros((T, 3)))
    taus = real_array(torques, "torques")
    if taus.shape != (T, 3):
        raise ValueError(f"torques must have shape ({T}, 3); got shape {taus.shape}")
    return read_only(taus)
