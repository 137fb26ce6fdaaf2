"""A recording read from a user's file: the attitude log plus what was detected and what was changed.

Every reader of recorded data (:mod:`omegahat.io.rosbag`, :mod:`omegahat.io.mocap`, :mod:`omegahat.io.c3d`)
returns a :class:`Recording`: the :class:`~omegahat.io.AttitudeLog` the estimator runs on (times strictly
increasing, after the policy of :mod:`omegahat.io.timestamps`), a one-line ``description`` of what was found
("OptiTrack Motive CSV (format 1.23), rigid body 'drone' ..."), ``notes`` on what was dropped or sorted, and, for
ROS bags, the stamps and frame names needed to write the result back as messages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from omegahat.io.logs import AttitudeLog
from omegahat.io.timestamps import TidyResult, tidy_samples

__all__ = ["BagStamps", "Recording", "build_recording"]


@dataclass(frozen=True)
class BagStamps:
    """Per kept sample: the message's header stamp and its receive (bag) time, integer nanoseconds; and the
    names of the frames (``parent`` the fixed frame, ``child`` the body frame, None where the message names none),
    the topic read, and the bag's ROS version (1 or 2)."""

    header_ns: np.ndarray
    receive_ns: np.ndarray
    parent: str | None
    child: str | None
    topic: str
    ros_version: int


@dataclass(frozen=True)
class Recording:
    """An attitude log read from a recording (module docstring).

    ``log.t`` are seconds since ``t0`` (``t0`` is 0 for files whose time column is used as written, the first
    stamp for ROS bags, whose stamps are nanoseconds since 1970 and would lose precision as floats); ``tidy``
    maps the file's samples onto ``log``'s rows (:class:`~omegahat.io.timestamps.TidyResult`).
    """

    log: AttitudeLog
    description: str
    notes: tuple[str, ...] = ()
    tidy: TidyResult | None = None
    t0: float = 0.0
    bag: BagStamps | None = None
    format: str = ""

    @property
    def absolute_times(self) -> np.ndarray:
        """``t0 + log.t``: the times as the file states them (seconds)."""
        return self.t0 + self.log.t

    def summary(self) -> str:
        """The description and the notes, one per line (what the CLI prints)."""
        return "\n".join([self.description, *self.notes])


def build_recording(
    times,
    kind: str,
    data: np.ndarray,
    *,
    source: str,
    description: str,
    label: Callable[[int], str],
    sort: bool,
    torque: np.ndarray | None = None,
    time_scale: float = 1e-9,
    format: str = "",
    notes: tuple[str, ...] = (),
) -> tuple[Recording, TidyResult]:
    """Apply the timestamp policy of :mod:`omegahat.io.timestamps` and wrap the result.

    ``times``: float seconds (used as written, ``t0 = 0``) or integers in units of ``time_scale`` seconds
    (nanoseconds by default), which become seconds since the first kept one (``t0`` = that one, in seconds).
    """
    result = tidy_samples(times, kind, data, torque, label=label, sort=sort)
    keep = result.keep
    t_kept = np.asarray(times)[keep]
    if np.issubdtype(t_kept.dtype, np.integer):
        base = int(t_kept[0]) if t_kept.size else 0
        t_sec = (t_kept - base).astype(np.float64) * time_scale
        t0 = base * time_scale
    else:
        t_sec = t_kept.astype(np.float64)
        t0 = 0.0
    data_kept = np.asarray(data, dtype=float)[keep]
    tau = None if torque is None else np.asarray(torque, dtype=float)[keep]
    log = AttitudeLog(t_sec, kind, data_kept, tau, source)
    missing = int(np.count_nonzero(log.missing))
    all_notes = list(notes) + result.notes()
    if missing:
        all_notes.append(f"{missing} of {len(log)} samples have no attitude (untracked): skipped and predicted through")
    rec = Recording(log, description, tuple(all_notes), result, t0, None, format)
    return rec, result
