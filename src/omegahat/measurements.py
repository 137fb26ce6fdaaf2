r"""Checked conversion of user input into the measured body-frame directions the observer works with.

The observer (``observer.md``) works with ``n ≥ 2`` known inertial directions ``v_i`` seen in the body,
``r_i = Rᵀ v_i`` (``R`` maps body to inertial). With ``V`` the ``(n, 3)`` matrix whose rows are the ``v_i``, the
rows of ``r = V R`` are the ``r_i``; for ``V = I`` they are the rows of R. A measurement is one of

* a rotation matrix ``(3, 3)``: accepted when ``‖RᵀR − I‖_F ≤ rotation_tol`` and ``det R > 0`` (used as given,
  not re-projected: within the tolerance the rows are unit to the same accuracy);
* a quaternion ``(4,)`` in SciPy's order, scalar last ``(x, y, z, w)`` unless ``scalar_first=True``: accepted
  when ``|‖q‖ − 1| ≤ quat_norm_tol``, then normalised. ``q`` and ``−q`` give the same matrix (every entry of
  the matrix is quadratic in q), so a log that mixes both signs needs no unwrapping;
* a :class:`scipy.spatial.transform.Rotation` (converted with ``as_matrix``);
* body-frame measurements ``b_i ≈ Rᵀ v_i`` of the known directions, ``(n, 3)`` (for example an accelerometer and a
  magnetometer): each row is normalised (a zero row is an error). If the largest angle between two measured
  directions is below ``min_angle_deg`` the sample is **flagged and skipped** (status :data:`COLLINEAR`), not an
  error: the references are checked non-collinear when the estimator is built, so collinear measurements mean a
  disturbed sensor at that instant (a magnetometer near iron, an accelerometer during a strong push), and a
  stream should ride through such a sample the way it rides through a missing one.

Any non-finite number in a sample (NaN, ±inf) marks it **missing** (status :data:`MISSING`), never an error: the
estimator skips it and keeps predicting. Everything else that is wrong raises :class:`MeasurementError`
(a ``ValueError``) naming the sample, the quantity and its value; wrong shapes raise naming the shape.

The per-sample checks are compiled (Numba) so that the estimator can validate and step in one compiled call;
:func:`attitude_directions` and :func:`body_directions` apply exactly the same checks to whole arrays with leading
batch axes.
"""

from __future__ import annotations

from typing import NamedTuple

import numba
import numpy as np
from scipy.spatial.transform import Rotation

__all__ = [
    "COLLINEAR",
    "MISSING",
    "OK",
    "Directions",
    "MeasurementError",
    "attitude_directions",
    "attitude_matrices",
    "body_directions",
    "sample_status",
]

# Default tolerances (documented in the estimator): rotation matrices read from text logs with ~6 significant
# digits are orthogonal to ~1e-6; a quaternion written with 4 digits has |‖q‖ − 1| up to ~1e-4.
ROTATION_TOL = 1e-3
QUAT_NORM_TOL = 1e-3
MIN_ANGLE_DEG = 1.0

# Per-sample status codes. Below ERROR the sample is usable or skipped; from ERROR on it is rejected.
OK = 0  #: a valid sample
MISSING = 1  #: NaN or inf somewhere in the sample: skipped, the estimator keeps predicting
COLLINEAR = 2  #: measured directions nearly collinear: skipped like a missing sample, counted separately
ERROR = 10
NOT_ORTHOGONAL = 10  #: info = ‖RᵀR − I‖_F
NOT_PROPER = 11  #: info = det R (a reflection)
QUAT_NORM = 12  #: info = ‖q‖
ZERO_DIRECTION = 13  #: info = index of the zero row

# Measurement kinds understood by the compiled converters.
KIND_MATRIX = 0
KIND_QUAT = 1
KIND_DIRECTIONS = 2


class MeasurementError(ValueError):
    """A measurement that is present but invalid (not a rotation, quaternion far from unit norm, ...)."""


class Directions(NamedTuple):
    """Measured body-frame directions ``r (*B, n, 3)`` (NaN where skipped) and a status per sample ``(*B,)``."""

    r: np.ndarray
    status: np.ndarray

    @property
    def valid(self) -> np.ndarray:
        """True where the sample is usable (status :data:`OK`)."""
        return self.status == OK


# ----------------------------------------------------------------------------------------------- compiled checks


@numba.njit(cache=True)
def _all_finite(a):
    for x in a.flat:
        if not np.isfinite(x):
            return False
    return True


@numba.njit(cache=True)
def _check_matrix(R, tol):
    """``(status, info)`` of one 3×3 matrix: MISSING, NOT_ORTHOGONAL (info ‖RᵀR−I‖_F), NOT_PROPER (det) or OK."""
    if not _all_finite(R):
        return MISSING, np.nan
    err2 = 0.0
    for a in range(3):
        for b in range(3):
            s = R[0, a] * R[0, b] + R[1, a] * R[1, b] + R[2, a] * R[2, b] - (1.0 if a == b else 0.0)
            err2 += s * s
    err = np.sqrt(err2)
    if err > tol:
        return NOT_ORTHOGONAL, err
    det = (
        R[0, 0] * (R[1, 1] * R[2, 2] - R[1, 2] * R[2, 1])
        - R[0, 1] * (R[1, 0] * R[2, 2] - R[1, 2] * R[2, 0])
        + R[0, 2] * (R[1, 0] * R[2, 1] - R[1, 1] * R[2, 0])
    )
    if det < 0.0:
        return NOT_PROPER, det
    return OK, 0.0


@numba.njit(cache=True)
def _quat_matrix(q, scalar_first, tol, R):
    """Write the rotation matrix of quaternion ``q`` into ``R``; return ``(status, info)`` (QUAT_NORM: info ‖q‖)."""
    if not _all_finite(q):
        return MISSING, np.nan
    if scalar_first:
        w, x, y, z = q[0], q[1], q[2], q[3]
    else:
        x, y, z, w = q[0], q[1], q[2], q[3]
    norm = np.sqrt(x * x + y * y + z * z + w * w)
    if abs(norm - 1.0) > tol:
        return QUAT_NORM, norm
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    # Hamilton unit quaternion to matrix (the same formula as so3.from_quat); quadratic in q, so q ≡ −q.
    R[0, 0] = 1.0 - 2.0 * (y * y + z * z)
    R[0, 1] = 2.0 * (x * y - z * w)
    R[0, 2] = 2.0 * (x * z + y * w)
    R[1, 0] = 2.0 * (x * y + z * w)
    R[1, 1] = 1.0 - 2.0 * (x * x + z * z)
    R[1, 2] = 2.0 * (y * z - x * w)
    R[2, 0] = 2.0 * (x * z - y * w)
    R[2, 1] = 2.0 * (y * z + x * w)
    R[2, 2] = 1.0 - 2.0 * (x * x + y * y)
    return OK, 0.0


@numba.njit(cache=True)
def _rows_from_matrix(V, R, r):
    """``r = V R``: row i is ``Rᵀ v_i``."""
    for i in range(V.shape[0]):
        for c in range(3):
            r[i, c] = V[i, 0] * R[0, c] + V[i, 1] * R[1, c] + V[i, 2] * R[2, c]


@numba.njit(cache=True)
def _normalise_directions(b, min_sin, r):
    """Normalise the rows of ``b`` into ``r``; ``(status, info)``: MISSING, ZERO_DIRECTION, COLLINEAR or OK."""
    if not _all_finite(b):
        return MISSING, np.nan
    n = b.shape[0]
    for i in range(n):
        norm = np.sqrt(b[i, 0] ** 2 + b[i, 1] ** 2 + b[i, 2] ** 2)
        if norm == 0.0:
            return ZERO_DIRECTION, float(i)
        for c in range(3):
            r[i, c] = b[i, c] / norm
    # Largest sine of the angle between two measured directions.
    best = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            cx = r[i, 1] * r[j, 2] - r[i, 2] * r[j, 1]
            cy = r[i, 2] * r[j, 0] - r[i, 0] * r[j, 2]
            cz = r[i, 0] * r[j, 1] - r[i, 1] * r[j, 0]
            best = max(best, np.sqrt(cx * cx + cy * cy + cz * cz))
    if best < min_sin:
        return COLLINEAR, np.degrees(np.arcsin(min(best, 1.0)))
    return OK, 0.0


@numba.njit(cache=True)
def convert_sample(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r, R_work):
    """One sample of any kind to directions ``r (n, 3)`` (written in place); returns ``(status, info)``.

    ``m`` is 2-D: a matrix ``(3, 3)``, a quaternion ``(1, 4)`` or directions ``(n, 3)``.
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


@numba.njit(cache=True)
def _convert_batch(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin):
    """:func:`convert_sample` over a flat batch ``m (T, a, b)``; stops at the first rejected sample.

    Returns ``(r (T, n, 3), status (T,), first_bad, info)``; ``first_bad = −1`` when nothing was rejected.
    """
    T = m.shape[0]
    n = V.shape[0]
    r = np.full((T, n, 3), np.nan)
    status = np.zeros(T, dtype=np.int64)
    R_work = np.empty((3, 3))
    for j in range(T):
        s, info = convert_sample(m[j], kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin, r[j], R_work)
        if s >= ERROR:
            status[j] = s
            return r, status, j, info
        if s != OK:
            r[j, :, :] = np.nan
        status[j] = s
    return r, status, -1, 0.0


@numba.njit(cache=True)
def _status_batch(m, kind, V, scalar_first, rotation_tol, quat_norm_tol, min_sin):
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


# ------------------------------------------------------------------------------------------------ Python layer


def describe_rejection(status: int, info: float, where: str) -> str:
    """The error message for a rejected sample (``where`` names it, e.g. ``"sample 3 (t = 0.01)"``)."""
    if status == NOT_ORTHOGONAL:
        return (
            f"{where} is not a rotation matrix: ‖RᵀR − I‖ = {info:.3g} exceeds rotation_tol "
            "(pass rotation_tol to accept it, or fix the data)"
        )
    if status == NOT_PROPER:
        return f"{where} is a reflection, not a rotation: det R = {info:.6g} < 0"
    if status == QUAT_NORM:
        return (
            f"{where} is a quaternion far from unit norm: ‖q‖ = {info:.6g} "
            "(|‖q‖ − 1| exceeds quat_norm_tol; is it a quaternion at all, and in which order?)"
        )
    if status == ZERO_DIRECTION:
        return f"{where}: measured direction {int(info)} has zero norm"
    return f"{where}: rejected (status {status})"


def _where(index: int, batch_shape: tuple[int, ...]) -> str:
    if batch_shape == ():
        return "the sample"
    idx = np.unravel_index(index, batch_shape)
    return f"sample {idx[0] if len(idx) == 1 else tuple(int(i) for i in idx)}"


def as_references(references, n_default: int = 3) -> np.ndarray:
    """Inertial reference directions ``(n, 3)``, normalised; default the first ``n_default`` axes (rows of R)."""
    from omegahat.validation import as_directions

    if references is None:
        return np.eye(3)[:n_default].copy()
    return np.ascontiguousarray(as_directions(references, name="references"))


def _attitude_array(attitudes, scalar_first: bool) -> tuple[np.ndarray, int, tuple[int, ...]]:
    """``(m (T, a, b), kind, batch_shape)`` for matrices, quaternions or a Rotation; shape errors named."""
    if isinstance(attitudes, Rotation):
        a = np.asarray(attitudes.as_matrix(), dtype=float)
        kind = KIND_MATRIX
        batch = a.shape[:-2]
        return np.ascontiguousarray(a.reshape(-1, 3, 3)), kind, batch
    a = np.asarray(attitudes, dtype=float)
    if a.ndim >= 2 and a.shape[-2:] == (3, 3):
        return np.ascontiguousarray(a.reshape(-1, 3, 3)), KIND_MATRIX, a.shape[:-2]
    if a.ndim >= 1 and a.shape[-1] == 4:
        return np.ascontiguousarray(a.reshape(-1, 1, 4)), KIND_QUAT, a.shape[:-1]
    raise ValueError(
        "an attitude must be a rotation matrix (..., 3, 3), a quaternion (..., 4) or a scipy Rotation; "
        f"got shape {a.shape}"
    )


def _raise_first(first_bad, status, info, batch):
    if first_bad >= 0:
        raise MeasurementError(describe_rejection(int(status[first_bad]), float(info), _where(first_bad, batch)))


def attitude_directions(
    attitudes,
    references=None,
    *,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
) -> Directions:
    """Checked body-frame directions ``r_i = Rᵀ v_i`` from attitudes with leading batch axes.

    ``attitudes``: matrices ``(*B, 3, 3)``, quaternions ``(*B, 4)`` or a ``Rotation``; ``references`` the inertial
    ``v_i`` ``(n, 3)`` (default the three axes, so ``r`` holds the rows of R). Returns :class:`Directions`
    ``r (*B, n, 3)`` and ``status (*B,)`` (:data:`MISSING` where a sample has a non-finite entry). Raises
    :class:`MeasurementError` at the first sample that is not a rotation or not a unit quaternion.
    """
    V = as_references(references)
    m, kind, batch = _attitude_array(attitudes, scalar_first)
    r, status, first_bad, info = _convert_batch(
        m, kind, V, bool(scalar_first), float(rotation_tol), float(quat_norm_tol), 0.0
    )
    _raise_first(first_bad, status, info, batch)
    return Directions(r.reshape(batch + V.shape), status.reshape(batch))


def attitude_matrices(
    attitudes, *, scalar_first: bool = False, rotation_tol: float = ROTATION_TOL, quat_norm_tol: float = QUAT_NORM_TOL
) -> np.ndarray:
    """Checked rotation matrices ``(*B, 3, 3)`` from matrices, quaternions or a Rotation; NaN where missing."""
    r, _ = attitude_directions(
        attitudes, np.eye(3), scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
    )
    return r  # with V = I the directions are the rows of R, i.e. R itself


def sample_status(
    samples,
    *,
    directions: bool = False,
    scalar_first: bool = False,
    rotation_tol: float = ROTATION_TOL,
    quat_norm_tol: float = QUAT_NORM_TOL,
    min_angle_deg: float = MIN_ANGLE_DEG,
) -> tuple[np.ndarray, np.ndarray]:
    """The status of every sample of a batch, never raising on a bad one: ``(status (T,), info (T,))``.

    ``samples``: matrices ``(T, 3, 3)`` or quaternions ``(T, 4)`` (``directions=False``), or body-frame directions
    ``(T, n, 3)`` (``directions=True``). Statuses and ``info`` are those of the compiled checks the estimator
    runs (:data:`OK`, :data:`MISSING`, :data:`COLLINEAR`, and from ``ERROR`` on a rejection, described by
    :func:`describe_rejection`), so a caller can drop or report bad samples before estimating.
    """
    a = np.asarray(samples, dtype=float)
    if directions:
        if a.ndim != 3 or a.shape[-1] != 3 or a.shape[1] < 2:
            raise ValueError(f"direction samples must have shape (T, n, 3) with n >= 2; got shape {a.shape}")
        m, kind, V = np.ascontiguousarray(a), KIND_DIRECTIONS, np.zeros((a.shape[1], 3))
    else:
        m, kind, _ = _attitude_array(a, scalar_first)
        if m.shape[0] != (a.shape[0] if a.ndim else 0):
            raise ValueError(f"attitude samples must have shape (T, 3, 3) or (T, 4); got shape {a.shape}")
        V = np.eye(3)
    return _status_batch(
        m,
        kind,
        V,
        bool(scalar_first),
        float(rotation_tol),
        float(quat_norm_tol),
        float(np.sin(np.radians(min_angle_deg))),
    )


def body_directions(measured, n: int | None = None, *, min_angle_deg: float = MIN_ANGLE_DEG) -> Directions:
    """Checked, normalised body-frame direction measurements ``(*B, n, 3)`` (``n ≥ 2``).

    Status :data:`MISSING` where a sample has a non-finite entry, :data:`COLLINEAR` where its directions are
    within ``min_angle_deg`` of collinear (both skipped by the estimator); a zero row raises.
    """
    a = np.asarray(measured, dtype=float)
    if a.ndim < 2 or a.shape[-1] != 3 or a.shape[-2] < 2 or (n is not None and a.shape[-2] != n):
        want = "(..., n, 3) with n >= 2" if n is None else f"(..., {n}, 3)"
        raise ValueError(f"direction measurements must have shape {want}; got shape {a.shape}")
    batch = a.shape[:-2]
    V = np.eye(3)[: a.shape[-2]] if a.shape[-2] <= 3 else np.zeros((a.shape[-2], 3))  # only its shape is used
    m = np.ascontiguousarray(a.reshape((-1, *a.shape[-2:])))
    r, status, first_bad, info = _convert_batch(
        m, KIND_DIRECTIONS, V, False, 0.0, 0.0, float(np.sin(np.radians(min_angle_deg)))
    )
    _raise_first(first_bad, status, info, batch)
    return Directions(r.reshape(a.shape), status.reshape(batch))
