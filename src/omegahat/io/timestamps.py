r"""Duplicated, out-of-order and irregular timestamps: the one policy every reader of recorded data applies.

Motion-capture systems deliver frames over a network, drivers re-publish the last frame when a new one is late,
and loggers record what arrived. A recording therefore carries, besides jitter, samples that share a timestamp
and samples that arrive out of order. omegahat treats them as follows (readers of ROS bags, Motive, Vicon and
C3D exports, and :func:`omegahat.estimate_frame`):

1. **Irregular spacing is kept.** Jittery intervals, dropped frames and gaps are passed to the estimator as
   recorded: it predicts the state over each interval, whatever its length (:mod:`omegahat.observer.estimator`),
   so nothing is resampled or interpolated. ``largest_interval`` on the estimator reports the longest gap.
2. **Exact duplicates are dropped.** Samples with the same timestamp whose attitudes agree are one sample: the
   first is kept and the count is reported. Attitudes are compared as rotation matrices, so a quaternion ``q``
   and its negative ``−q`` (the same rotation) agree; "agree" means ``‖R_a − R_b‖_F ≤`` :data:`DUPLICATE_TOL`
   (about ``1e-6`` rad: the same frame written twice, up to the rounding of a text export). A missing sample
   (NaN) at the time of a valid one is dropped as well: it carries nothing the valid one lacks.
3. **Conflicting duplicates are rejected.** Two samples at the same time with different attitudes cannot both be
   right, and guessing which one is would hide a broken time source: :class:`~omegahat.io.LogFormatError` names
   both samples, the time and the angle between the two attitudes.
4. **Order.** Exports written frame by frame (CSV, C3D) must have non-decreasing times; a time going backwards is
   an error naming the line. Message streams (ROS bags), where network delivery can reorder messages, are sorted
   by their timestamps (a stable sort, so exact duplicates stay in arrival order) and the number of messages that
   arrived out of order is reported.

The jitter tests (``tests/test_timestamps.py``) check that a log with irregular sampling, dropped frames and
duplicates gives the same rate as the clean log within the noise.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from omegahat.io.logs import LogFormatError

__all__ = ["DUPLICATE_TOL", "TidyResult", "tidy_samples"]

DUPLICATE_TOL = 1e-6  #: ‖R_a − R_b‖_F (≈ the angle in rad) below which two samples at one time are the same


@dataclass(frozen=True)
class TidyResult:
    """What :func:`tidy_samples` kept: ``keep`` indices into the input (in time order), and ``source_of``
    ``(T,)``: for every input sample the index into ``keep`` of the sample that stands for it (a dropped duplicate
    points at the sample kept in its place), so results can be spread back onto the input's rows."""

    keep: np.ndarray
    source_of: np.ndarray
    n_duplicates: int
    n_reordered: int  #: samples that came after one with a later time (late arrivals)

    def notes(self) -> list[str]:
        """Human-readable lines for what was changed (empty when nothing was)."""
        out = []
        if self.n_reordered:
            out.append(f"{self.n_reordered} sample(s) arrived after a later-stamped one: sorted by time")
        if self.n_duplicates:
            out.append(f"dropped {self.n_duplicates} duplicated sample(s) (same time, same attitude)")
        return out


def _comparable(kind: str, data: np.ndarray) -> np.ndarray:
    """Flat rows in which two equal attitudes are equal: matrices for quaternions (q ≡ −q), else the data."""
    T = data.shape[0]
    if kind == "quaternion":
        from omegahat import so3  # compiled kernels: imported only when duplicates need comparing

        with np.errstate(invalid="ignore", divide="ignore"):
            return so3.from_quat(data).reshape(T, 9)
    return np.asarray(data, dtype=float).reshape(T, -1)


def _time_text(x) -> str:
    """A time for messages: seconds as written, or integer nanoseconds as seconds with all 9 digits."""
    if isinstance(x, np.integer | int):
        sec, ns = divmod(int(x), 1_000_000_000)
        return f"{sec}.{ns:09d} s"
    return repr(float(x))


def _angle_text(kind: str, a: np.ndarray, b: np.ndarray) -> str:
    if kind in ("quaternion", "matrix"):
        Ra, Rb = a.reshape(3, 3), b.reshape(3, 3)
        cos = np.clip((np.trace(Ra.T @ Rb) - 1.0) / 2.0, -1.0, 1.0)
        return f"attitudes {np.degrees(np.arccos(cos)):.4g}° apart"
    return f"directions differing by up to {np.abs(a - b).max():.3g}"


def tidy_samples(
    times: np.ndarray,
    kind: str,
    data: np.ndarray,
    torque: np.ndarray | None = None,
    *,
    label: Callable[[int], str],
    sort: bool,
    tol: float = DUPLICATE_TOL,
) -> TidyResult:
    """Apply the policy of the module docstring to one recording.

    ``times (T,)`` (seconds as floats, or integer nanoseconds: equality is exact either way), ``kind`` and
    ``data`` as in :class:`~omegahat.io.AttitudeLog`, ``torque (T, 3)`` or None. ``label(i)`` names input sample
    ``i`` for messages (e.g. ``"line 17"`` or ``"message 4"``). ``sort``: sort by time (message streams) or
    reject a time going backwards (exports). Raises :class:`~omegahat.io.LogFormatError`.
    """
    times = np.asarray(times)
    T = times.shape[0]
    if T == 0:
        return TidyResult(np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), 0, 0)
    if np.issubdtype(times.dtype, np.floating):
        bad = np.flatnonzero(~np.isfinite(times))
        if bad.size:
            raise LogFormatError(f"{label(int(bad[0]))}: time {float(times[bad[0]])!r} is not finite")
    if sort:
        order = np.argsort(times, kind="stable")
        n_reordered = int(np.count_nonzero(times[1:] < np.maximum.accumulate(times)[:-1]))  # late arrivals
    else:
        back = np.flatnonzero(np.diff(times) < 0)
        if back.size:
            k = int(back[0]) + 1
            raise LogFormatError(
                f"{label(k)}: time {_time_text(times[k])} is before {_time_text(times[k - 1])} ({label(k - 1)}); "
                "the rows of an export must be in time order"
            )
        order = np.arange(T)
        n_reordered = 0
    t_sorted = times[order]
    same_as_previous = np.concatenate([[False], t_sorted[1:] == t_sorted[:-1]])
    keep_pos = []  # positions in the sorted order
    source_sorted = np.empty(T, dtype=np.int64)
    if same_as_previous.any():
        rows = _comparable(kind, np.asarray(data)[order])
        tau = None if torque is None else np.asarray(torque, dtype=float)[order]
        valid = np.all(np.isfinite(rows), axis=1)
    for pos in range(T):
        if not same_as_previous[pos]:
            keep_pos.append(pos)
            source_sorted[pos] = len(keep_pos) - 1
            continue
        kept = keep_pos[-1]
        source_sorted[pos] = len(keep_pos) - 1
        a, b = order[kept], order[pos]
        if not valid[pos]:
            continue  # a missing sample at the time of another: nothing to add
        if not valid[kept]:
            keep_pos[-1] = pos  # the valid sample stands for the missing one kept so far
            continue
        differs = np.sqrt(np.sum((rows[pos] - rows[kept]) ** 2)) > tol
        torque_differs = tau is not None and np.abs(tau[pos] - tau[kept]).max() > tol * (1 + np.abs(tau[kept]).max())
        if differs or torque_differs:
            what = _angle_text(kind, rows[kept], rows[pos]) if differs else "different torques"
            raise LogFormatError(
                f"{label(int(a))} and {label(int(b))}: two samples at the same time {_time_text(times[a])} "
                f"with {what}. "
                "Duplicated timestamps must carry the same attitude (omegahat drops those); conflicting ones "
                "mean a broken time source: fix the time column (for a ROS bag, try the receive time: "
                "--stamp receive)"
            )
    keep = order[np.asarray(keep_pos, dtype=np.int64)]
    source_of = np.empty(T, dtype=np.int64)
    source_of[order] = source_sorted
    return TidyResult(keep, source_of, T - len(keep_pos), n_reordered)


def spread(values: np.ndarray, result: TidyResult) -> np.ndarray:
    """Rows of ``values`` (one per kept sample) repeated onto every input sample (``values[source_of]``)."""
    return np.asarray(values)[result.source_of]


def describe_labels(prefix: str, numbers: Sequence[int] | np.ndarray, unit: str) -> Callable[[int], str]:
    """``label(i) = f"{prefix}, {unit} {numbers[i]}"`` for messages (``numbers``: line numbers, frames, ...)."""
    return lambda i: f"{prefix}, {unit} {numbers[i]}"
