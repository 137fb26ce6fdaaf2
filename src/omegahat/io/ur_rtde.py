r"""Universal Robots recordings: the RTDE data a UR arm streams, as its recorders write it, recognised by its header.

Universal Robots' own recorder (``record.py`` of the RTDE client library) writes one line of names, then one line
per controller cycle, separated by blanks; the ``ur_rtde`` library's ``startFileRecording`` writes the same names
separated by commas. A vector field has one column per component, ``name_0 … name_5``:

``timestamp actual_q_0 … actual_TCP_pose_0 actual_TCP_pose_1 … actual_TCP_pose_5 actual_TCP_speed_0 …``

* ``timestamp``: seconds since the controller started (read as they are; the first is ``t0``). A recording of
  one's own with ``actual_TCP_pose_0..5`` and another time column (``t``, or the one named as a time: ``time``,
  ``Time (s)``, ``time_ns``, read in the unit its name states) is read the same way; without one it is refused with
  the ``--columns`` lines that read it, with the time column or with ``--rate``;
* ``actual_TCP_pose``: the tool centre point's pose in the robot's base frame, ``x, y, z`` in metres and then the
  **rotation vector** ``rx, ry, rz`` in radians (components 3–5; :mod:`omegahat.io.rotvec`, (V1)). It maps the
  tool's axes into the base's (body → inertial, omegahat's ``R``), so the rate comes out in the **tool's axes**.
  The position columns, the joints and every other field are not read.

The commanded pose ``target_TCP_pose`` is not read: it is what the controller asked for, not what the arm did, and
a file holding only it is refused with the ``--columns`` line that reads it anyway. ``--rotation`` is refused, since
the format states the direction. The lines are read by the CSV reader (chunks of any size, every error naming its
line and column).
"""

from __future__ import annotations

import os

from omegahat.io.colmap import ColumnMap, columns_line
from omegahat.io.columns import Layout, LogFormatError, normalise_name, time_column_by_name
from omegahat.io.csvlog import TextFormat, open_text
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.textlines import delimiter, head_lines, split_line

__all__ = ["is_ur_rtde", "open_ur_rtde"]

_POSE = ("actual_tcp_pose", "target_tcp_pose")
_ROTATION = (3, 4, 5)  # the rotation vector's components in a pose [x, y, z, rx, ry, rz]


def _names(path: str) -> list[str]:
    """The first line's names (separated by blanks, or by the delimiter the line shows), normalised; empty where
    the file cannot be read or the line has no fields."""
    lines = head_lines(path, 1)
    if not lines or not lines[0].strip():
        return []
    try:
        return [normalise_name(n) for n in split_line(lines[0], delimiter(lines[0], path, True), path)]
    except LogFormatError:  # a header too wide to be a recording's
        return []


def _rotation_columns(names: list[str], pose: str) -> list[int] | None:
    """The positions (0-based) of ``pose``'s rotation vector among ``names``, or None where any is missing."""
    try:
        return [names.index(f"{pose}_{k}") for k in _ROTATION]
    except ValueError:
        return None


def is_ur_rtde(path: str | os.PathLike[str]) -> bool:
    """Whether a text file is a Universal Robots recording: a first line naming the rotation components (3–5) of
    ``actual_TCP_pose`` or ``target_TCP_pose``."""
    names = _names(os.fspath(path))
    return any(_rotation_columns(names, pose) is not None for pose in _POSE)


def _time_column(names: list[str]) -> str | None:
    """``timestamp``, or else ``t`` or the one column named as a time (the CSV reader's rule,
    :func:`omegahat.io.columns.time_column_by_name`), or None."""
    name = "timestamp" if "timestamp" in names else time_column_by_name(names, "t")[0]
    return name if name in names else None


def open_ur_rtde(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The tool's attitude in a Universal Robots recording (module docstring)."""
    path = os.fspath(path)
    names = _names(path)
    actual, target = (_rotation_columns(names, pose) for pose in _POSE)
    time = _time_column(names)
    pose = "actual_TCP_pose" if actual is not None else "target_TCP_pose"
    rotation = [(f"rotvec_{a}", f"{pose}_{k}") for a, k in zip("xyz", _ROTATION, strict=True)]
    line = columns_line([("t", time or "NAME"), *rotation])
    if actual is None and target is not None:
        raise LogFormatError(
            f"{path}, line 1: a Universal Robots recording without actual_TCP_pose: target_TCP_pose is the pose the "
            f"controller commanded, not the one the arm reached; to read it anyway: {line}"
        )
    if actual is None:
        raise LogFormatError(f"{path}, line 1: not a Universal Robots recording (no actual_TCP_pose_3..5)")
    if time is None:
        raise LogFormatError(
            f"{path}, line 1: a Universal Robots pose without a time column ('timestamp', or one named as a time); "
            f"name the column that holds the time: {line}, or where none does, give the rate it was recorded at: "
            f"{columns_line(rotation)} --rate HZ (record.py records at 125 Hz unless told otherwise)"
        )
    if options.rotation != "body-to-inertial":
        raise LogFormatError(
            f"{path}: a Universal Robots pose maps the tool's axes into the base's, as omegahat's R does; leave "
            "--rotation out"
        )
    cmap: ColumnMap = (
        ("t", names.index(time) + 1),
        *((f"rotvec_{a}", j + 1) for a, j in zip("xyz", actual, strict=True)),
    )

    def describe(stream: LogStream, lay: Layout, _names: list[str]) -> str:
        del stream, lay
        since = " in s since the controller started" if time == "timestamp" else ""  # else the unit its name says
        return (
            "Universal Robots RTDE recording: attitude from actual_TCP_pose_3..5 (the tool's rotation vector in the "
            f"base frame, radians), time from {time!r}{since}; rates in the tool's axes"
        )

    return open_text(path, options, TextFormat(columns=cmap, describe=describe))
