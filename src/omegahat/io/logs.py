"""Attitude logs in and angular-velocity estimates out: whole-log readers over the chunked streams.

Input columns (CSV header, or NPZ array names), by name, in any order, names compared ignoring case
(:mod:`omegahat.io.columns`):

* ``t``: sample times (seconds unless ``ReadOptions.time_unit`` says otherwise), strictly increasing;
* the attitude, exactly one of
  - a quaternion ``qw, qx, qy, qz`` (the names say which is the scalar part),
  - a rotation matrix ``r11, r12, …, r33`` (``rij`` = row i, column j of R, body → inertial unless
    ``ReadOptions.rotation`` says inertial-to-body),
  - body-frame directions ``b1x, b1y, b1z, b2x, …`` of n ≥ 1 known inertial directions (their inertial
    coordinates are given separately, e.g. ``omegahat estimate --references``);
* optionally the known torque ``tau_x, tau_y, tau_z`` (body axes, N·m).

Other columns are ignored. An **empty field** (or NaN) in the attitude columns is a missing sample: the whole
sample becomes NaN (the estimator skips it and predicts through). A quaternion need not be normalised here; the
estimator checks it. The formats themselves: :mod:`omegahat.io.csvlog` (CSV: encodings, delimiters, how it is
parsed fast) and :mod:`omegahat.io.npzlog` (NPZ: ``q``/``R``/``b`` arrays, the quaternion order of ``q``).

Every error names where the problem is: for a CSV the line number (1 = the first line) and the column, e.g.
``line 17, column qx: 'abc' is not a number``; for an NPZ the array.

This module reads a whole log, in any registered format (ROS bags, Motive, Vicon and C3D exports too), into an
:class:`AttitudeLog` (the streams of :mod:`omegahat.io.registry` read it chunk by chunk, which is what
``omegahat estimate`` does; both go through
:func:`omegahat.io.registry.open_log`). Output: :func:`write_omega_csv` writes
``t,wx,wy,wz`` (rad/s, body axes); :mod:`omegahat.io.output` writes the CLI's chunked, atomic output.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from omegahat.io.columns import MATRIX_COLUMNS, QUATERNION_COLUMNS, TORQUE_COLUMNS, LogFormatError
from omegahat.io.registry import ReadOptions, open_log, with_options

__all__ = [
    "MATRIX_COLUMNS",
    "QUATERNION_COLUMNS",
    "TORQUE_COLUMNS",
    "AttitudeLog",
    "LogFormatError",
    "read_csv",
    "read_log",
    "read_npz",
    "write_omega_csv",
]


@dataclass(frozen=True)
class AttitudeLog:
    """A log read from a file, whole (the samples the timestamp policy kept, in time order).

    ``t (T,)`` in seconds since ``t0`` (0 unless the format counts from its first stamp, as bags do);
    ``kind`` is ``"quaternion"`` (``data (T, 4)``, scalar **last**, SciPy's order), ``"matrix"``
    (``data (T, 3, 3)``) or ``"directions"`` (``data (T, n, 3)``); ``torque (T, 3)`` or None; ``labels (T,)`` the
    line number (CSV), index (NPZ), message (bag), frame (C3D) of each sample. Missing samples are rows of NaN.
    ``format``, ``description``, ``notes``, ``meta`` and ``extra`` are the stream's
    (:class:`~omegahat.io.registry.LogStream`): what was recognised and changed, and a bag's stamps and frames.
    """

    t: np.ndarray
    kind: str
    data: np.ndarray
    torque: np.ndarray | None = None
    source: str = ""
    labels: np.ndarray | None = None
    format: str = ""
    description: str = ""
    notes: tuple[str, ...] = ()
    t0: float = 0.0
    meta: dict = field(default_factory=dict)
    extra: dict[str, np.ndarray] | None = None

    @property
    def absolute_times(self) -> np.ndarray:
        """``t0 + t``: the times as the file states them (seconds)."""
        return self.t0 + self.t

    @property
    def missing(self) -> np.ndarray:
        """Boolean ``(T,)``: samples with a non-finite attitude (skipped by the estimator)."""
        return ~np.all(np.isfinite(self.data.reshape(self.t.size, -1)), axis=1)

    def __len__(self) -> int:
        return self.t.size


def read_log(
    path: str | os.PathLike[str],
    progress: Callable[[int, int], object] | None = None,
    options: ReadOptions | None = None,
    fmt: str | None = None,
    **option_values: Any,
) -> AttitudeLog:
    """Read a whole log into an :class:`AttitudeLog`, in any registered format.

    The format is recognised from the file (:func:`omegahat.io.registry.detect_format`) or given by ``fmt``. The
    columns of omegahat's own CSV and NPZ logs are in the module docstring.

    Parameters
    ----------
    path : str or os.PathLike
        The log file.
    progress : callable, optional
        ``progress(done, total)``, called after each chunk with the bytes (CSV) or rows read so far and the total.
    options : ReadOptions, optional
        How to read the log (default: :class:`ReadOptions`'s defaults).
    fmt : str, optional
        A format's name such as ``"motive"``, or an extension such as ``".csv"`` (default: recognised).
    **option_values
        Fields of :class:`ReadOptions` set on ``options`` (``read_log("run.bag", topic="/pose")``).

    Returns
    -------
    AttitudeLog
        The samples the timestamp policy kept, in time order; missing samples are rows of NaN.

    Raises
    ------
    LogFormatError
        Naming the line and column (or array, message, frame) of the problem; also when the log has no samples.

    Examples
    --------
    A CSV log of quaternions (scalar last, as the column names say), then backward differencing on it:

    >>> import os, tempfile
    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import DifferencingEstimator, read_log
    >>> t = np.arange(0.0, 1.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()  # 0.3, -0.2, 0.5 rad/s, body axes
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     path = os.path.join(folder, "run.csv")
    ...     np.savetxt(path, np.column_stack([t, q]), delimiter=",", header="t,qx,qy,qz,qw", comments="")
    ...     log = read_log(path)
    >>> log.kind, len(log), log.data.shape
    ('quaternion', 100, (100, 4))
    >>> omega = DifferencingEstimator().run(log.t, log.data).omega
    >>> print(" ".join(f"{x:.3f}" for x in omega[-1]))
    0.300 -0.200 0.500
    """
    stream = open_log(path, with_options(options, **option_values), fmt)
    parts = []
    for chunk in stream.chunks():
        parts.append(chunk)
        if progress is not None:
            progress(min(stream.done, stream.size), stream.size)
    if progress is not None:
        progress(stream.size, stream.size)
    if not parts:
        raise LogFormatError(f"{stream.source}: no samples")
    t = np.concatenate([c.t for c in parts])
    data = np.concatenate([c.data for c in parts])
    torque = np.concatenate([c.torque for c in parts]) if stream.has_torque else None
    labels = np.concatenate([c.labels for c in parts])
    extras = [c.extra for c in parts if c.extra is not None]  # a stream's chunks all carry extra columns, or none
    extra = {k: np.concatenate([e[k] for e in extras]) for k in extras[0]} if extras else None
    return AttitudeLog(
        t,
        stream.kind,
        data,
        torque,
        stream.source,
        labels,
        stream.format,
        stream.description,
        tuple(stream.notes),
        stream.t0,
        dict(stream.meta),
        extra,
    )


def read_csv(
    path: str | os.PathLike[str],
    progress: Callable[[int, int], object] | None = None,
    options: ReadOptions | None = None,
) -> AttitudeLog:
    """Read a CSV log whatever its extension (:mod:`omegahat.io.csvlog`)."""
    return read_log(path, progress, options, ".csv")


def read_npz(path: str | os.PathLike[str], options: ReadOptions | None = None) -> AttitudeLog:
    """Read an NPZ log whatever its extension (:mod:`omegahat.io.npzlog`)."""
    return read_log(path, None, options, ".npz")


def write_omega_csv(path: str | os.PathLike[str], t: ArrayLike, omega: ArrayLike) -> None:
    """Write ``t,wx,wy,wz`` (rad/s), one row per sample; ``t (T,)``, ``omega (T, 3)``; NaN as ``nan``."""
    times = np.asarray(t, dtype=float)
    rates = np.asarray(omega, dtype=float)
    if times.ndim != 1 or rates.shape != (times.size, 3):
        raise ValueError(f"write_omega_csv needs t (T,) and omega (T, 3); got {times.shape} and {rates.shape}")
    table = np.column_stack([times, rates])
    np.savetxt(path, table, delimiter=",", header="t,wx,wy,wz", comments="", fmt="%.17g")
