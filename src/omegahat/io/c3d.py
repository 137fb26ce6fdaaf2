"""C3D files with rigid-body rotations, read with ``ezc3d`` (``pip install "omegahat[c3d]"``).

C3D stores marker trajectories (``POINT``), analog channels and, in files written by Vicon Nexus, Qualisys and
others that solve rigid bodies, the bodies' rotations: the ``ROTATION`` parameter group (``USED``, ``LABELS``,
``RATE`` or ``RATIO``) and per frame a 4×4 homogeneous transform per body, whose 3×3 block rotates the body's
axes into the laboratory's (body → inertial, as omegahat's ``R``). A frame the system could not solve is stored
as invalid and read as a missing sample.

Time is ``(first_frame + i) / rate`` with the rotations' rate. A file with markers only (no ``ROTATION`` data)
is refused with a message saying what is needed: the rotations themselves; omegahat does not fit rigid bodies to
markers. ``ReadOptions.body`` (``--body``) names the body, optional when there is one. The stream is labelled by
frame number, so the timestamp policy (:mod:`omegahat.io.timestamps`) names frames.
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np

from omegahat.io import c3d_child
from omegahat.io.columns import LogFormatError
from omegahat.io.mocap import choose_body
from omegahat.io.registry import LogStream, ReadOptions

__all__ = ["open_c3d"]


def _ezc3d():
    try:
        import ezc3d
    except ImportError:  # pragma: no cover - the test extra installs it
        raise ImportError('reading C3D files needs ezc3d: pip install "omegahat[c3d]"') from None
    return ezc3d


def _value(group: dict, name: str, default=None):
    entry = group.get(name)
    if entry is None:
        return default
    return entry["value"]


def _read(path: str) -> dict:
    """ezc3d's reading of ``path`` in a child process: on some damaged files (a truncated one) ezc3d does not raise
    but aborts the process (an uncaught C++ ``std::out_of_range``, SIGABRT), which would end the caller's without a
    word; the child's death becomes a message naming the file. The child is this interpreter running
    :func:`omegahat.io.c3d_child.load`; its answer comes back pickled on its standard output (our own code's
    output, not the file's)."""
    done = subprocess.run(
        [sys.executable, "-c", c3d_child.RUN, c3d_child.__file__, path], capture_output=True, check=False
    )
    if done.returncode != 0:
        raise LogFormatError(
            f"{path}: not a readable C3D file (the C3D reader stopped on it, exit status {done.returncode}: "
            "a truncated or damaged file?)"
        )
    out = pickle.loads(done.stdout)  # our own child's answer
    if "error" in out:  # ezc3d raised (plain RuntimeError/IOError for unreadable files)
        raise LogFormatError(f"{path}: not a readable C3D file ({out['error']})")
    return out


def open_c3d(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One rigid body's rotations from a C3D file (module docstring); ``options.body`` names it (a label of the
    ``ROTATION`` group), optional when there is one."""
    path = os.fspath(path)
    body = options.body
    _ezc3d()  # installed? (said here, before a child process is started)
    c = _read(path)
    params = c["parameters"]
    rot = np.asarray(c["data"].get("rotations", np.zeros((4, 4, 0, 0))))
    group = params.get("ROTATION", {})
    used = int(np.asarray(_value(group, "USED", [0])).ravel()[0]) if group else 0
    if used == 0 or rot.ndim != 4 or rot.shape[2] == 0 or rot.shape[3] == 0:
        labels = list(_value(params.get("POINT", {}), "LABELS", []) or [])
        shown = ", ".join(labels[:8]) + (", ..." if len(labels) > 8 else "")
        raise LogFormatError(
            f"{path}: this C3D file stores {len(labels)} marker trajectories ({shown or 'none'}) but no rigid-body "
            "rotations (no ROTATION data). omegahat needs each body's rotation: export the C3D with the solved "
            "rigid bodies / segments' rotations (the ROTATION group), or fit the body's rotation to three or more "
            "of its markers per frame (a Wahba/Kabsch fit) and give the rotations as a CSV (t, r11..r33)"
        )
    labels = [str(x) for x in (_value(group, "LABELS", []) or [])]
    if len(labels) != rot.shape[2]:
        labels = [f"rotation {i + 1}" for i in range(rot.shape[2])]
    index = labels.index(choose_body(labels, body, path, "rigid body", "rigid bodies"))
    header = c["header"]["rotations"]
    rate = float(header.get("frame_rate", 0.0))
    if not rate > 0:
        rate_param = _value(group, "RATE")
        rate = float(np.asarray(rate_param).ravel()[0]) if rate_param is not None else 0.0
    if not rate > 0:
        raise LogFormatError(f"{path}: the ROTATION group states no positive rate")
    first = int(header.get("first_frame", 0))
    R = np.ascontiguousarray(np.moveaxis(rot[:3, :3, index, :], -1, 0), dtype=float)  # (T, 3, 3)
    T = R.shape[0]
    frames = first + np.arange(T)
    description = (
        f"C3D file: rigid body {labels[index]!r} from the ROTATION group ({rot.shape[2]} bodies), "
        f"{T} frames at {rate:g} Hz, 3x3 rotation blocks (body to laboratory)"
    )
    return LogStream.from_arrays(
        path, "matrix", frames / rate, R, labels=frames, label="frame", description=description, time_name=None
    )
