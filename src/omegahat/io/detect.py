"""Which reader a file needs, decided from the file itself, and where the estimates go.

:func:`detect_format` names the format of an input path:

* ``"rosbag1"``: a ``.bag`` file; ``"rosbag2"``: a directory with ``metadata.yaml`` (or its ``.db3``/``.mcap``);
* ``"c3d"``: a ``.c3d`` file;
* for ``.csv`` files, from the first lines (:func:`omegahat.io.mocap.sniff_csv`): ``"motive"`` (first field
  ``Format Version``), ``"vicon"`` (a section title, a rate, then ``Frame,Sub Frame``), or ``"log"``;
* ``"log"`` for anything else (omegahat's own CSV or NPZ, :mod:`omegahat.io.logs`, which names what it expects).

:func:`read_recording` reads any of them into a :class:`~omegahat.io.Recording` whose ``description`` says what
was detected. :func:`write_estimates` writes the rates: a ``.csv`` path gets ``t,wx,wy,wz`` with the file's own
times (absolute seconds for a bag), a ``.bag`` path a ROS 1 bag and, for a bag input, any other path a ROS 2 bag
(:func:`omegahat.io.rosbag.write_twist_bag`).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from omegahat.io.logs import LogFormatError, read_log, write_omega_csv
from omegahat.io.recording import Recording

__all__ = ["RECORDING_FORMATS", "detect_format", "output_kind", "read_recording", "write_estimates"]

RECORDING_FORMATS = ("rosbag1", "rosbag2", "motive", "vicon", "c3d")


def detect_format(path) -> str:
    """``"rosbag1"``, ``"rosbag2"``, ``"c3d"``, ``"motive"``, ``"vicon"`` or ``"log"`` (module docstring)."""
    from omegahat.io.mocap import sniff_csv
    from omegahat.io.rosbag import bag_path

    p = Path(path)
    bag = bag_path(p)
    if bag is not None:
        return "rosbag2" if bag.is_dir() else "rosbag1"
    suffix = p.suffix.lower()
    if suffix == ".c3d":
        return "c3d"
    if suffix == ".csv":
        return sniff_csv(p)
    return "log"


def read_recording(
    path,
    *,
    topic: str | None = None,
    parent_frame: str | None = None,
    child_frame: str | None = None,
    stamp: str = "header",
    body: str | None = None,
    progress=None,
) -> Recording:
    """Read any supported input (module docstring); selection options apply to the formats that have them
    (``topic``, frames and ``stamp`` to bags, ``body`` to Motive, Vicon and C3D) and are refused elsewhere."""
    fmt = detect_format(path)
    bag_options = {"topic": topic, "parent_frame": parent_frame, "child_frame": child_frame}
    given_bag = [k for k, v in bag_options.items() if v is not None] + (["stamp"] if stamp != "header" else [])
    if fmt not in ("rosbag1", "rosbag2") and given_bag:
        raise ValueError(f"{os.fspath(path)} is not a ROS bag ({fmt}): {', '.join(given_bag)} apply to bags only")
    if fmt not in ("motive", "vicon", "c3d") and body is not None:
        raise ValueError(f"{os.fspath(path)} is {fmt}: body selects a rigid body in Motive, Vicon or C3D files only")
    if fmt in ("rosbag1", "rosbag2"):
        from omegahat.io.rosbag import read_bag

        return read_bag(path, topic, parent_frame=parent_frame, child_frame=child_frame, stamp=stamp)
    if fmt == "motive":
        from omegahat.io.mocap import read_motive_csv

        return read_motive_csv(path, body)
    if fmt == "vicon":
        from omegahat.io.mocap import read_vicon_csv

        return read_vicon_csv(path, body)
    if fmt == "c3d":
        from omegahat.io.c3d import read_c3d

        return read_c3d(path, body)
    log = read_log(path, progress=progress)
    return Recording(log, f"omegahat log {os.fspath(path)}: {log.kind} columns, {len(log)} samples", format="log")


def output_kind(path, recording: Recording | None = None) -> str:
    """``"csv"``, ``"rosbag1"`` or ``"rosbag2"`` for an output path (module docstring); raises if none fits."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".csv":
        return "csv"
    if suffix == ".bag":
        if recording is None or recording.bag is None:
            raise ValueError(f"{p}: a bag output needs a bag input (its stamps and frames); write a .csv instead")
        return "rosbag1"
    if recording is not None and recording.bag is not None and suffix == "":
        return "rosbag2"
    raise ValueError(
        f"{p}: unknown output type {suffix or '(no extension)'!r}; use .csv"
        + (", .bag (ROS 1) or a name without extension (ROS 2 bag directory)" if recording and recording.bag else "")
    )


def write_estimates(path, recording: Recording, omega, *, frame_id: str | None = None, topic: str | None = None) -> str:
    """Write ``omega (T, 3)`` (one row per sample of ``recording.log``) to ``path``; returns a line saying what
    was written. ``frame_id`` and ``topic`` apply to bag outputs (defaults: the body frame the input names, or
    ``"body"``; :data:`omegahat.io.rosbag.DEFAULT_TWIST_TOPIC`)."""
    kind = output_kind(path, recording)
    omega = np.asarray(omega, dtype=float)
    if kind == "csv":
        if frame_id is not None or topic is not None:
            raise ValueError("--frame-id and --output-topic apply to bag outputs only")
        write_omega_csv(path, recording.absolute_times, omega)
        return f"wrote {omega.shape[0]} estimates to {path} (t,wx,wy,wz; rad/s in the body frame)"
    from omegahat.io.rosbag import DEFAULT_TWIST_TOPIC, write_twist_bag

    bag = recording.bag
    if frame_id is None:
        frame_id = bag.child or "body"
    topic = topic or DEFAULT_TWIST_TOPIC
    if os.path.abspath(path) == os.path.abspath(recording.log.source):
        raise LogFormatError(f"{path} is the input bag; choose another output")
    write_twist_bag(path, bag.header_ns, bag.receive_ns, omega, frame_id=frame_id, topic=topic)
    version = 1 if kind == "rosbag1" else 2
    return (
        f"wrote {omega.shape[0]} geometry_msgs/TwistStamped to ROS {version} bag {path}, topic {topic}, "
        f"frame_id {frame_id!r} (body frame), header stamps copied from {bag.topic}"
    )
