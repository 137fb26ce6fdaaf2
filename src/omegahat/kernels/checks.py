r"""The compiled input checks (Numba), written once: every estimator's samples, times and torques pass through them.

:mod:`omegahat.measurements` is their Python face and holds the tolerance policy and the messages; the equations
(M1)–(M3) and the time check (T) are stated there. Here, per sample::

    matrix R:        ‖RᵀR − I‖_F ≤ rotation_tol  and  det R > 0                                          (M1)
    quaternion q:    |‖q‖ − 1| ≤ quat_norm_tol, then R = R(q/‖q‖)  (R1 of :mod:`omegahat.kernels.rotation`)  (M2)
    directions b_i:  b_i ≠ 0, r_i = b_i/|b_i|; skipped when max_{i<j} |r_i × r_j| < sin(min_angle)          (M3)
    time t:          finite, and t > t_prev when there is a previous sample                               (T)
    torque τ:        finite                                                                               (T)

Every check returns ``(status, info)``: below :data:`ERROR` the sample is used (:data:`OK`) or skipped
(:data:`MISSING`: a NaN or inf in it; :data:`COLLINEAR`); from :data:`ERROR` on it is rejected and ``info`` is the
offending value (documented with each code). Two more codes below :data:`ERROR` are an estimator's, not a check's:
:data:`RESTARTED`, a sample at which the step could not be taken and the estimator started again from that sample,
and :data:`HELD`, a sample used for the attitude whose rate is the one held through the gap before it.
:func:`check_sample` runs the checks of one sample in the order time, time order, torque, measurement and reports
the first that fails.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels import rotation as rot
from omegahat.kernels.vec3 import cross, mat3, matvec_transposed, norm

__all__ = [
    "COLLINEAR",
    "ERROR",
    "HELD",
    "KIND_DIRECTIONS",
    "KIND_MATRIX",
    "KIND_QUAT",
    "MISSING",
    "NOT_ORTHOGONAL",
    "NOT_PROPER",
    "OK",
    "QUAT_NORM",
    "RESTARTED",
    "TIME_NOT_FINITE",
    "TIME_ORDER",
    "TORQUE_NOT_FINITE",
    "ZERO_DIRECTION",
    "all_finite",
    "check_batch",
    "check_sample",
    "check_time",
    "check_times",
    "check_torque",
    "convert_sample",
    "status_batch",
]

# Per-sample status codes. Below ERROR the sample is usable or skipped; from ERROR on it is rejected.
OK = 0  #: a valid sample
MISSING = 1  #: NaN or inf somewhere in the sample: skipped, the estimator keeps predicting
COLLINEAR = 2  #: measured directions nearly collinear: skipped like a missing sample, counted separately
RESTARTED = 3  #: the step to this sample could not be taken: the estimator restarted from the sample (no estimate)
HELD = 4  #: a sample used (the attitude), the rate the one held through the gap before it ((S5)): predicted
ERROR = 10
NOT_ORTHOGONAL = 10  #: info = ‖RᵀR − I‖_F
NOT_PROPER = 11  #: info = det R (a reflection)
QUAT_NORM = 12  #: info = ‖q‖
ZERO_DIRECTION = 13  #: info = index of the zero row
TIME_ORDER = 20  #: info = the previous time
TIME_NOT_FINITE = 21  #: info = the time
TORQUE_NOT_FINITE = 22  #: info = the first non-finite component

# Measurement kinds understood by the compiled converters.
KIND_MATRIX = 0
KIND_QUAT = 1
KIND_DIRECTIONS = 2


@numba.njit(cache=True, error_model="numpy")
def all_finite(a):
    """Whether every entry of the array ``a`` is finite (no NaN, no ±inf)."""
    for x in a.flat:
        if not np.isfinite(x):
            return False
    return True


@numba.njit(cache=True, error_model="numpy")
def _check_matrix(R, tol):
    """``(status, info)`` of one 3×3 matrix by (M1): MISSING, NOT_ORTHOGONAL, NOT_PROPER or OK."""
    if not all_finite(R):
        return MISSING, np.nan
    err = rot.orthogonality_error(R)
    if err > tol:
        return NOT_ORTHOGONAL, err
    d = rot.det(R)
    if d < 0.0:
        return NOT_PROPER, d
    return OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def _quat_matrix(q, scalar_first, tol, R):
    """Write the rotation matrix of quaternion ``q`` into ``R`` after (M2); return ``(status, info)``."""
    if not all_finite(q):
        return MISSING, np.nan
    if scalar_first:
        w, x, y, z = q[0], q[1], q[2], q[3]
    else:
        x, y, z, w = q[0], q[1], q[2], q[3]
    n = np.sqrt(x * x + y * y + z * z + w * w)
    if abs(n - 1.0) > tol:
        return QUAT_NORM, n
    rot.store(rot.matrix_from_quat(x / n, y / n, z / n, w / n), R)
    return OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def _rows_from_matrix(V, R, r):
    """``r = V R``: row i is ``Rᵀ v_i``."""
    M = mat3(R)
    for i in range(V.shape[0]):
        r[i, 0], r[i, 1], r[i, 2] = matvec_transposed(M, V[i, 0], V[i, 1], V[i, 2])


@numba.njit(cache=True, error_model="numpy")
def _normalise_directions(b, min_sin, r):
    """Normalise the rows of ``b`` into ``r``; ``(status, info)``: MISSING, ZERO_DIRECTION, COLLINEAR (M3) or OK."""
    if not all_finite(b):
        return MISSING, np.nan
    n = b.shape[0]
    for i in range(n):
        length = norm(b[i, 0], b[i, 1], b[i, 2])
        if length == 0.0:
            return ZERO_DIRECTION, float(i)
        for c in range(3):
            r[i, c] = b[i, c] / length
    best = 0.0  # the largest sine of the angle between two measured directions
    for i in range(n):
        for j in range(i + 1, n):
            cx, cy, cz = cross(r[i, 0], r[i, 1], r[i, 2], r[j, 0], r[j, 1], r[j, 2])
            best = max(best, norm(cx, cy, cz))
    if best < min_sin:
        return COLLINEAR, np.degrees(np.arcsin(min(best, 1.0)))
    return OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def convert_sample(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r, R_work):
    """One sample of any kind to directions ``r (n, 3)`` (written in place); returns ``(status, info)``.

    ``m`` is 2-D: a matrix ``(3, 3)``, a quaternion ``(1, 4)`` or directions ``(n, 3)``; ``min_sin`` is the sine of
    ``min_angle_deg``; ``R_work`` is 3×3 scratch space.
    """
    if kind == KIND_MATRIX:
        status, info = _check_matrix(m, rotation_tol)
        if status == OK:
            _rows_from_matrix(V, m, r)
        return status, info
    if kind == KIND_QUAT:
        status, info = _quat_matrix(m[0], scalar_first, quat_norm_tol, R_work)
        if status == OK:
            _rows_from_matrix(V, R_work, r)
        return status, info
    return _normalise_directions(m, min_sin, r)


@numba.njit(cache=True, error_model="numpy")
def check_time(t, t_prev):
    """(T) for a sample at ``t`` after one at ``t_prev`` (NaN: none yet): ``(status, info)``, TIME_NOT_FINITE
    (info t), TIME_ORDER (info t_prev) or OK."""
    if not np.isfinite(t):
        return TIME_NOT_FINITE, t
    if np.isfinite(t_prev) and not t > t_prev:
        return TIME_ORDER, t_prev
    return OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def check_times(times, t_prev):
    """:func:`check_time` along ``times`` (the first after ``t_prev``): ``(first_bad, status, info)``, first_bad −1
    when every time passes."""
    for j in range(times.size):
        status, info = check_time(times[j], t_prev)
        if status != OK:
            return j, status, info
        t_prev = times[j]
    return -1, OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def check_torque(tau):
    """(T) for a torque ``(3,)``: ``(TORQUE_NOT_FINITE, the first non-finite component)`` or ``(OK, 0)``."""
    for a in range(3):
        if not np.isfinite(tau[a]):
            return TORQUE_NOT_FINITE, tau[a]
    return OK, 0.0


@numba.njit(cache=True, error_model="numpy")
def check_sample(t, t_prev, tau, m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r, R_work):
    """Every check of one sample in order (time, time order, torque, then :func:`convert_sample`); returns
    ``(status, info)`` of the first that fails, or the converter's (OK, MISSING or COLLINEAR)."""
    status, info = check_time(t, t_prev)
    if status != OK:
        return status, info
    status, info = check_torque(tau)
    if status != OK:
        return status, info
    return convert_sample(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r, R_work)


@numba.njit(cache=True, error_model="numpy")
def check_batch(times, t_prev, taus, timed, m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin):
    """:func:`check_sample` (``timed``) or :func:`convert_sample` over ``m (T, a, b)``, stopping at the first
    rejected sample. Returns ``(r (T, n, 3), status (T,), first_bad, info)``; ``first_bad = −1`` when none."""
    T = m.shape[0]
    r = np.full((T, V.shape[0], 3), np.nan)
    status = np.zeros(T, dtype=np.int64)
    R_work = np.empty((3, 3))
    for j in range(T):
        if timed:
            s, info = check_sample(
                times[j],
                t_prev,
                taus[j],
                m[j],
                kind,
                V,
                scalar_first,
                rotation_tol,
                quat_norm_tol,
                min_sin,
                r[j],
                R_work,
            )
            t_prev = times[j]
        else:
            s, info = convert_sample(m[j], kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r[j], R_work)
        status[j] = s
        if s >= ERROR:
            return r, status, j, info
        if s != OK:
            r[j, :, :] = np.nan
    return r, status, -1, 0.0


@numba.njit(cache=True, error_model="numpy")
def status_batch(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin):
    """:func:`convert_sample`'s ``(status, info)`` for every sample of ``m (T, a, b)``, without stopping."""
    T = m.shape[0]
    status = np.zeros(T, dtype=np.int64)
    info = np.zeros(T)
    r = np.empty((V.shape[0], 3))
    R_work = np.empty((3, 3))
    for j in range(T):
        status[j], info[j] = convert_sample(
            m[j], kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r, R_work
        )
    return status, info
