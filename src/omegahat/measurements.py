r"""The one input path: every estimator's samples, times and torques are checked here, the same way.

The Sarras estimator, the MEKF, differencing and the spline all validate their input through this module, so a log
rejected by one is rejected by all, with the same message (``tests/test_input_path.py``).

**Measurements.** The observer (``observer.md``) works with ``n ≥ 2`` known inertial directions ``v_i`` seen in the
body, ``r_i = Rᵀ v_i`` (``R`` maps body to inertial). With ``V`` the ``(n, 3)`` matrix whose rows are the ``v_i``,
the rows of ``r = V R`` are the ``r_i``; for ``V = I`` they are the rows of R (R itself). A measurement is one of

* a rotation matrix ``(3, 3)``: accepted when ``‖RᵀR − I‖_F ≤ rotation_tol`` and ``det R > 0``  (M1)
  (used as given, not re-projected: within the tolerance the rows are unit to the same accuracy);
* a quaternion ``(4,)`` in SciPy's order, scalar last ``(x, y, z, w)`` unless ``scalar_first=True``: accepted
  when ``|‖q‖ − 1| ≤ quat_norm_tol`` (M2), then normalised. ``q`` and ``−q`` give the same matrix (every entry
  of the matrix is quadratic in q), so a log that mixes both signs needs no unwrapping;
* a :class:`scipy.spatial.transform.Rotation` (converted with ``as_matrix``);
* body-frame measurements ``b_i ≈ Rᵀ v_i`` of the known directions, ``(n, 3)`` (an accelerometer and a
  magnetometer, say): each row is normalised (a zero row is an error). If the largest angle between two measured
  directions is below ``min_angle_deg`` (M3) the sample is **flagged and skipped** (status :data:`COLLINEAR`),
  not an error: the references are checked non-collinear when an estimator is built, so collinear measurements
  mean a disturbed sensor at that instant, and a stream rides through such a sample as through a missing one;
* one measured direction (``n = 1``: only where the caller says so, by giving one reference — the one-direction
  estimators; the others refuse one reference when built): a sample ``(3,)`` or ``(1, 3)``, a log ``(T, 3)`` or
  ``(T, 1, 3)``, normalised (a zero direction is an error); (M3) does not apply (there is no pair).

Any non-finite number in a sample (NaN, ±inf) marks it **missing** (status :data:`MISSING`), never an error: the
estimators skip it. Everything else that is wrong raises :class:`MeasurementError` (a ``ValueError``) naming the
sample, its time, the quantity and its value; wrong shapes raise ``ValueError`` naming the shape.

**Times and torques (T).** A sample's time must be finite and strictly after the previous sample's (the previous
one in the log, or the estimator's last time for the first sample of a log fed in chunks); a torque given with a
sample must be finite. The checks of one sample run in the order time finite, time order, torque, measurement,
and a log is checked sample by sample, so the error names the first sample with anything wrong, whatever it is.

**Tolerance policy (P)**, the tolerances named here and nowhere else:

* measured attitudes: :data:`ROTATION_TOL` and :data:`QUAT_NORM_TOL` (1e-3) by default; every estimator takes
  ``rotation_tol``, ``quat_norm_tol`` and ``scalar_first`` with these defaults. Matrices read from text with ~6
  significant digits are orthogonal to ~1e-6, and a quaternion written with 4 digits has ``|‖q‖ − 1|`` up to ~1e-4:
  the defaults accept honest rounding and reject what is not a rotation at all;
* problem definitions (a simulation's ``R0``, the rigid-body integrator's ``R0``): :func:`as_rotation` with
  :data:`PROBLEM_ROTATION_TOL` (1e-9): an exact problem must start on SO(3) to rounding, since the integrators
  carry the attitude without re-projecting it.

The per-sample checks are compiled (Numba, :mod:`omegahat.kernels.checks`, re-exported here with their status
codes): :func:`check_sample` (:func:`check_time`, :func:`check_torque`, :func:`convert_sample`) is what an
estimator's compiled step calls; :func:`checked_log` and :func:`checked_sample` are the Python faces for whole logs
and for one sample; :func:`describe_rejection` (defined in :mod:`omegahat.rejections`, re-exported here) turns any
rejection status into its message.
"""

from __future__ import annotations

import abc
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.conversion import (
    as_references,
    log_array,
    min_angle,
    read_only,
    real_array,
    sample_array,
    sample_time,
    times_array,
    tolerances,
    torque_vector,
    torques_array,
)
from omegahat.interface import Estimate, Estimator, Measurement, Measurements, batch_status
from omegahat.kernels.checks import (
    COLLINEAR,
    ERROR,
    HELD,
    KIND_DIRECTIONS,
    KIND_MATRIX,
    KIND_QUAT,
    MISSING,
    NOT_ORTHOGONAL,
    NOT_PROPER,
    OK,
    QUAT_NORM,
    RESTARTED,
    TIME_NOT_FINITE,
    TIME_ORDER,
    TORQUE_NOT_FINITE,
    ZERO_DIRECTION,
    check_batch,
    check_sample,
    check_time,
    check_times,
    check_torque,
    convert_sample,
    status_batch,
)
from omegahat.rejections import (
    MeasurementError,
    describe_rejection,
    python_option,
    rejection_error,
    suggested_tolerance,
)
from omegahat.validation import as_directions

__all__ = [
    "COLLINEAR",
    "ERROR",
    "HELD",
    "KIND_DIRECTIONS",
    "KIND_MATRIX",
    "KIND_QUAT",
    "MIN_ANGLE_DEG",
    "MISSING",
    "NOT_ORTHOGONAL",
    "NOT_PROPER",
    "OK",
    "PROBLEM_ROTATION_TOL",
    "QUAT_NORM",
    "QUAT_NORM_TOL",
    "RESTARTED",
    "ROTATION_TOL",
    "TIME_NOT_FINITE",
    "TIME_ORDER",
    "TORQUE_NOT_FINITE",
    "ZERO_DIRECTION",
    "AttitudeBatchEstimator",
    "CheckedLog",
    "CheckedSample",
    "Directions",
    "MeasurementError",
    "as_references",
    "as_rotation",
    "attitude_directions",
    "attitude_matrices",
    "body_directions",
    "check_batch",
    "check_sample",
    "check_time",
    "check_times",
    "check_torque",
    "checked_log",
    "checked_sample",
    "checked_times",
    "conversion",
    "convert_sample",
    "describe_rejection",
    "log_array",
    "min_angle",
    "python_option",
    "real_array",
    "rejection_error",
    "sample_array",
    "sample_status",
    "sample_time",
    "suggested_tolerance",
    "times_array",
    "tolerances",
    "torque_vector",
    "torques_array",
]

ROTATION_TOL = 1e-3  #: (P) default bound on ‖RᵀR − I‖_F of a measured rotation matrix (M1)
QUAT_NORM_TOL = 1e-3  #: (P) default bound on |‖q‖ − 1| of a measured quaternion (M2)
MIN_ANGLE_DEG = 1.0  #: (M3) default: measured directions closer to collinear than this are skipped
PROBLEM_ROTATION_TOL = 1e-9  #: (P) bound for problem definitions (initial attitudes of simulations), matrix and quat


class Directions(NamedTuple):
    """Measured body-frame directions ``r (*B, n, 3)`` (NaN where skipped) and a status per sample ``(*B,)``."""

    r: np.ndarray
    status: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """True where the sample is usable (status :data:`OK`)."""
        return self.status == OK


class CheckedLog(NamedTuple):
    """A checked log: ``times (T,)``; ``values`` the rotation matrices ``(T, 3, 3)`` (attitude input) or the unit
    directions ``(T, n, 3)`` (direction input), NaN where a sample is skipped; ``torques (T, 3)``; ``status (T,)``
    (:data:`OK`, :data:`MISSING` or :data:`COLLINEAR`)."""

    times: np.ndarray
    values: np.ndarray
    torques: np.ndarray
    status: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """True where the sample is usable (status :data:`OK`)."""
        return self.status == OK


class CheckedSample(NamedTuple):
    """One checked sample: its time, ``value`` (a rotation matrix or the unit directions; NaN when skipped), the
    torque ``(3,)`` and the status."""

    t: float
    value: np.ndarray
    torque: np.ndarray
    status: int


def _where(index: int, batch_shape: tuple[int, ...]) -> str:
    if batch_shape == ():
        return "the sample"
    idx = np.unravel_index(index, batch_shape)
    return f"sample {idx[0] if len(idx) == 1 else tuple(int(i) for i in idx)}"


def _raise_first(first_bad, status, info, batch):
    if first_bad >= 0:
        raise rejection_error(int(status[first_bad]), float(info), _where(first_bad, batch))


# ------------------------------------------------------------------------------------------------ the checks


def _previous(t_prev: float | None) -> float:
    return np.nan if t_prev is None else float(t_prev)


def conversion(
    n: int | None, scalar_first: bool, rotation_tol: float, quat_norm_tol: float, min_angle_deg: float
) -> tuple[np.ndarray, bool, float, float, float]:
    """The converter's ``(V, scalar_first, rotation_tol, quat_norm_tol, min_sin)`` for attitudes (``n`` None;
    ``V = I``: the directions are the rows of R, R itself) or ``n`` directions (V is then only a shape). One
    direction (``n = 1``: the one-direction estimators, whose caller says so by giving one reference) has no pair
    to be collinear: (M3) does not apply (``min_sin = 0``), and its samples may also be ``(3,)`` (a log ``(T, 3)``)."""
    V = read_only(np.eye(3) if n is None else np.zeros((n, 3)))
    min_sin = 0.0 if n == 1 else float(np.sin(np.radians(min_angle_deg)))
    return V, bool(scalar_first), float(rotation_tol), float(quat_norm_tol), min_sin


def checked_times(times: ArrayLike, *, t_prev: float | None = None, where: str = "sample {j}") -> np.ndarray:
    """Sample times ``(T,)`` through (T) alone, each after the one before (the first after ``t_prev``, None: no
    previous time); a rejected time raises :class:`MeasurementError` naming it as ``where.format(j=j)``."""
    t = times_array(times)
    first_bad, status, info = check_times(t, _previous(t_prev))
    if first_bad >= 0:
        raise rejection_error(status, info, where.format(j=first_bad), float(t[first_bad]))
    return t


def checked_log(
    times: ArrayLike,
    measurements: Measurements,
    torques: ArrayLike | None = None,
    *,
    references: ArrayLike | None = None,
    t_prev: float | None = None,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
    min_angle_deg: float = MIN_ANGLE_DEG,
) -> CheckedLog:
    """A whole log through (M1)–(M3) and (T): the estimators' batch input path.

    ``measurements``: attitudes (references None) as in :func:`log_array`, giving rotation matrices, or the body
    directions ``(T, n, 3)`` of the ``references`` ``(n, 3)``, giving unit directions (one reference: ``(T, 3)``
    too, and no collinearity test). ``t_prev`` is the time of
    the sample before ``times[0]`` (None: there is none). Raises :class:`MeasurementError` at the first rejected
    sample, named ``"sample j (t = ...)"`` (j its index in this call), and ``ValueError`` for wrong shapes.
    """
    t = times_array(times)
    n = None if references is None else np.atleast_2d(references).shape[0]  # only the count matters here
    m, kind = log_array(measurements, t.size, n)
    taus = torques_array(torques, t.size)
    conv = conversion(n, scalar_first, rotation_tol, quat_norm_tol, min_angle_deg)
    r, status, first_bad, info = check_batch(t, _previous(t_prev), taus, True, m, kind, *conv)
    if first_bad >= 0:
        raise rejection_error(int(status[first_bad]), float(info), f"sample {first_bad}", float(t[first_bad]))
    return CheckedLog(t, r, taus, status)


def checked_sample(
    t: float,
    measurement: Measurement,
    torque: ArrayLike | None = None,
    *,
    references: ArrayLike | None = None,
    t_prev: float | None = None,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
    min_angle_deg: float = MIN_ANGLE_DEG,
) -> CheckedSample:
    """One sample through (M1)–(M3) and (T) against the previous time ``t_prev``: the estimators' streaming input
    path (:func:`checked_log` for one sample, named ``"the sample"``)."""
    n = None if references is None else np.atleast_2d(references).shape[0]  # only the count matters here
    t = sample_time(t)
    m, kind = sample_array(measurement, n)
    tau = torque_vector(torque)
    r = np.full((3 if n is None else n, 3), np.nan)
    conv = conversion(n, scalar_first, rotation_tol, quat_norm_tol, min_angle_deg)
    status, info = check_sample(t, _previous(t_prev), tau, m, kind, *conv, r, np.empty((3, 3)))
    if status >= ERROR:
        raise rejection_error(status, info, "the sample", t)
    if status != OK:
        r[:] = np.nan
    return CheckedSample(t, r, tau, int(status))


def as_rotation(
    attitude: ArrayLike | Rotation,
    name: str = "R0",
    *,
    scalar_first: bool = False,
    rotation_tol: float = PROBLEM_ROTATION_TOL,
    quat_norm_tol: float = PROBLEM_ROTATION_TOL,
) -> np.ndarray:
    """One attitude given as a setting, not a sample (a matrix, a quaternion or a Rotation), as a rotation matrix
    ``(3, 3)``, checked by the same (M1)/(M2). Defaults :data:`PROBLEM_ROTATION_TOL`: a problem definition's
    attitude (a simulation's ``R0``) must be a rotation to rounding; an estimator's initial attitude is checked
    with the estimator's own tolerances."""
    m = np.ascontiguousarray(attitude.as_matrix() if isinstance(attitude, Rotation) else attitude, dtype=float)
    if m.shape not in ((3, 3), (4,)):
        raise ValueError(
            f"{name} must be a rotation matrix (3, 3), a quaternion (4,) or a Rotation; got shape {m.shape}"
        )
    kind = KIND_MATRIX if m.shape == (3, 3) else KIND_QUAT
    R = np.empty((3, 3))
    status, info = convert_sample(
        m.reshape(-1, m.shape[-1]), kind, np.eye(3), scalar_first, rotation_tol, quat_norm_tol, 0.0, R, R.copy()
    )
    if status == MISSING:
        raise ValueError(f"{name} must be finite; got {m.tolist()}")
    if status == NOT_ORTHOGONAL:
        raise ValueError(f"{name} is not a rotation matrix: ‖RᵀR − I‖_F = {info:.3g} exceeds {rotation_tol:g}")
    if status == QUAT_NORM:
        raise ValueError(f"{name} is not a unit quaternion: ‖q‖ = {info:.6g}, |‖q‖ − 1| exceeds {quat_norm_tol:g}")
    if status != OK:
        raise rejection_error(status, info, name)
    return m.copy() if kind == KIND_MATRIX else R


# ------------------------------------------------------------------------------------------ arrays, no times


def _attitude_array(attitudes) -> tuple[np.ndarray, int, tuple[int, ...]]:
    """``(m (T, a, b), kind, batch_shape)`` for matrices, quaternions or a Rotation; shape errors named."""
    if isinstance(attitudes, Rotation):
        a = np.asarray(attitudes.as_matrix(), dtype=float)
        return np.ascontiguousarray(a.reshape(-1, 3, 3)), KIND_MATRIX, a.shape[:-2]
    a = np.asarray(attitudes, dtype=float)
    if a.ndim >= 2 and a.shape[-2:] == (3, 3):
        return np.ascontiguousarray(a.reshape(-1, 3, 3)), KIND_MATRIX, a.shape[:-2]
    if a.ndim >= 1 and a.shape[-1] == 4:
        return np.ascontiguousarray(a.reshape(-1, 1, 4)), KIND_QUAT, a.shape[:-1]
    raise ValueError(
        "an attitude must be a rotation matrix (..., 3, 3), a quaternion (..., 4) or a scipy Rotation; "
        f"got shape {a.shape}"
    )


def _convert(m, kind, V, scalar_first=False, rotation_tol=0.0, quat_norm_tol=0.0, min_sin=0.0):
    empty = np.empty(0)
    return check_batch(
        empty,
        np.nan,
        read_only(np.empty((0, 3))),
        False,
        m,
        kind,
        V,
        scalar_first,
        rotation_tol,
        quat_norm_tol,
        min_sin,
    )


def sample_status(
    samples: ArrayLike,
    *,
    directions: bool = False,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
    min_angle_deg: float = MIN_ANGLE_DEG,
) -> tuple[np.ndarray, np.ndarray]:
    """The status of every sample of a batch, never raising on a bad one: ``(status (T,), info (T,))``, so that a
    caller can drop or report bad samples before estimating. ``samples``: attitudes ``(T, 3, 3)`` or ``(T, 4)``,
    or body-frame directions ``(T, n, 3)`` (``directions=True``); the statuses of (M1)–(M3)."""
    a = np.asarray(samples, dtype=float)
    if directions:
        if a.ndim != 3 or a.shape[-1] != 3 or a.shape[1] < 2:
            raise ValueError(f"direction samples must have shape (T, n, 3) with n >= 2; got shape {a.shape}")
        m, kind = np.ascontiguousarray(a), KIND_DIRECTIONS
    else:
        m, kind, batch = _attitude_array(a)
        if len(batch) != 1:
            raise ValueError(f"attitude samples must have shape (T, 3, 3) or (T, 4); got shape {a.shape}")
    conv = conversion(a.shape[1] if directions else None, scalar_first, rotation_tol, quat_norm_tol, min_angle_deg)
    return status_batch(m, kind, *conv)


def attitude_directions(
    attitudes: ArrayLike | Rotation,
    references: ArrayLike | None = None,
    *,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
) -> Directions:
    """Checked body-frame directions ``r_i = Rᵀ v_i`` from attitudes with leading batch axes (no times).

    ``attitudes``: matrices ``(*B, 3, 3)``, quaternions ``(*B, 4)`` or a ``Rotation``; ``references`` the inertial
    ``v_i`` ``(n, 3)`` (default the three axes, so ``r`` holds the rows of R). Returns :class:`Directions`
    ``r (*B, n, 3)`` and ``status (*B,)`` (:data:`MISSING` where a sample has a non-finite entry). Raises
    :class:`MeasurementError` at the first sample that is not a rotation or not a unit quaternion.
    """
    V = as_references(references)
    m, kind, batch = _attitude_array(attitudes)
    r, status, first_bad, info = _convert(m, kind, V, bool(scalar_first), float(rotation_tol), float(quat_norm_tol))
    _raise_first(first_bad, status, info, batch)
    return Directions(r.reshape(batch + V.shape), status.reshape(batch))


def attitude_matrices(
    attitudes: ArrayLike | Rotation,
    *,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
) -> np.ndarray:
    """Checked rotation matrices ``(*B, 3, 3)`` from matrices, quaternions or a Rotation; NaN where missing."""
    r, _ = attitude_directions(
        attitudes, np.eye(3), scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
    )
    return r  # with V = I the directions are the rows of R, i.e. R itself


def body_directions(measured: ArrayLike, n: int | None = None, *, min_angle_deg: float = MIN_ANGLE_DEG) -> Directions:
    """Checked, normalised body-frame direction measurements ``(*B, n, 3)`` (``n ≥ 2``), no times.

    Status :data:`MISSING` where a sample has a non-finite entry, :data:`COLLINEAR` where its directions are
    within ``min_angle_deg`` of collinear (both skipped by the estimators); a zero row raises.
    """
    a = np.asarray(measured, dtype=float)
    if a.ndim < 2 or a.shape[-1] != 3 or a.shape[-2] < 2 or (n is not None and a.shape[-2] != n):
        want = "(..., n, 3) with n >= 2" if n is None else f"(..., {n}, 3)"
        raise ValueError(f"direction measurements must have shape {want}; got shape {a.shape}")
    batch = a.shape[:-2]
    V = read_only(np.zeros((a.shape[-2], 3)))  # only its shape is used
    m = np.ascontiguousarray(a.reshape((-1, *a.shape[-2:])))
    r, status, first_bad, info = _convert(m, KIND_DIRECTIONS, V, min_sin=float(np.sin(np.radians(min_angle_deg))))
    _raise_first(first_bad, status, info, batch)
    return Directions(r.reshape(a.shape), status.reshape(batch))


class AttitudeBatchEstimator(Estimator):
    """A batch estimator of attitudes (the spline, Savitzky–Golay, the log's own Wiener smoother): ``run`` checks the
    log through :func:`checked_log`, hands it to :meth:`rates`, counts the skipped samples and gives the statuses of
    :func:`omegahat.interface.batch_status`. Keyword-only: the quaternion order and the tolerances, and
    ``references`` ``(n, 3)`` (n ≥ 2) for body-frame directions of known inertial ones: each sample's directions are
    checked as every estimator checks them, then turned into its least-squares attitude (Wahba's problem,
    :func:`omegahat.so3.wahba`), which the estimator takes as measured."""

    causal = False

    def __init__(
        self,
        *,
        references: ArrayLike | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ROTATION_TOL,
        quat_norm_tol: float = QUAT_NORM_TOL,
    ) -> None:
        self.references = None if references is None else as_directions(references)
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = tolerances(rotation_tol, quat_norm_tol)

    @abc.abstractmethod
    def rates(self, log: CheckedLog, data: Measurements) -> np.ndarray:
        """ω̂ ``(T, 3)`` at the log's times from the checked log of attitudes (``data``: the attitudes as given)."""

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """ω̂ at every sample time, ``(T, 3)``, and the statuses (``torque`` is not used)."""
        tols = {"rotation_tol": self.rotation_tol, "quat_norm_tol": self.quat_norm_tol}
        log = checked_log(t, data, references=self.references, scalar_first=self.scalar_first, **tols)
        if self.references is not None:  # directions: each sample's least-squares attitude
            attitudes = np.where(log.valid[:, None, None], so3.wahba(log.values, self.references), np.nan)
            log = log._replace(values=attitudes)
            data = attitudes
        omega = self.rates(log, data)
        self.n_skipped = int(np.count_nonzero(~log.valid))
        return Estimate(omega, batch_status(log.valid, omega))
