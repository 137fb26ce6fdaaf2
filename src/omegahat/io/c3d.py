"""C3D files with rigid-body rotations, read with ``ezc3d`` (``pip install "omegahat[c3d]"``).

C3D stores marker trajectories (``POINT``), analog channels and, in files written by Vicon Nexus, Qualisys and
others that solve rigid bodies, the bodies' rotations: the ``ROTATION`` parameter group (``USED``, ``LABELS``,
``RATE`` or ``RATIO``) and per frame a 4×4 homogeneous transform per body, whose 3×3 block rotates the body's
axes into the laboratory's (body → inertial, as omegahat's ``R``). A frame the system could not solve is stored
as invalid and read as a missing sample.

Time is ``(first_frame + i) / rate`` with the rotations' rate. A file with markers only (no ``ROTATION`` data)
is refused with a message saying what is needed: the rotations themselves; omegahat does not fit rigid bodies to
markers. Timestamps follow :mod:`omegahat.io.timestamps`.
"""

from __future__ import annotations

import os

import numpy as np

from omegahat.io.logs import LogFormatError
from omegahat.io.recording import Recording, build_recording

__all__ = ["read_c3d"]


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


def read_c3d(path, body: str | None = None) -> Recording:
    """Read one rigid body's rotations from a C3D file (module docstring); ``body`` names it (a label of the
    ``ROTATION`` group), optional when there is one."""
    path = os.fspath(path)
    ezc3d = _ezc3d()
    try:
        c = ezc3d.c3d(path)
    except Exception as exc:  # ezc3d raises plain RuntimeError/IOError for unreadable files
        raise LogFormatError(f"{path}: not a readable C3D file ({exc})") from None
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
    if body is None:
        if len(labels) > 1:
            raise LogFormatError(
                f"{path}: {len(labels)} rigid bodies with rotations ({', '.join(labels)}); choose one with --body NAME"
            )
        index = 0
    else:
        matches = [i for i, n in enumerate(labels) if n == body] or [
            i for i, n in enumerate(labels) if n.casefold() == body.casefold()
        ]
        if len(matches) != 1:
            raise LogFormatError(f"{path}: no rigid body named {body!r}; the file has {', '.join(labels)}")
        index = matches[0]
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
    rec, _ = build_recording(
        frames / rate,
        "matrix",
        R,
        source=path,
        description=description,
        label=lambda k: f"{path}, frame {frames[k]}",
        sort=False,
        format="c3d",
    )
    return rec
