r"""Attitude logged as Euler angles: columns ``roll``, ``pitch``, ``yaw``, the angles about the x, y and z axes.

Many loggers (IMU and flight-controller exports, phone apps, hand-written CSVs) store the attitude as three angles.
The names say which axis each angle turns about, but not the two conventions needed to build the rotation, and no
log can show them (any sequence and either unit turn any column of numbers into *some* rotation). So they are asked
for, never assumed:

* the **sequence** (``euler``, ``--euler``): three letters, each of x, y, z once, as SciPy writes them. Upper case
  turns about the body's own axes as they move (intrinsic), lower case about the fixed axes (extrinsic). For the
  sequence :math:`a_1 a_2 a_3`, with :math:`R_a(\theta)` the rotation by :math:`\theta` about axis :math:`a` and
  :math:`\theta_a` the angle of the column for :math:`a` (x: ``roll``, y: ``pitch``, z: ``yaw``),

  .. math::

     R = R_{a_1}(\theta_{a_1})\,R_{a_2}(\theta_{a_2})\,R_{a_3}(\theta_{a_3})   \quad\text{(upper case)}  \tag{E1}

  .. math::

     R = R_{a_3}(\theta_{a_3})\,R_{a_2}(\theta_{a_2})\,R_{a_1}(\theta_{a_1})   \quad\text{(lower case)}  \tag{E2}

  so ``ZYX`` and ``xyz`` are the same rotation, :math:`R = R_z(\text{yaw})\,R_y(\text{pitch})\,R_x(\text{roll})`:
  the aerospace convention (and ROS's roll-pitch-yaw, and most IMU vendors'). R maps body to inertial
  (:math:`v_\text{inertial} = R\,v_\text{body}`) unless ``--rotation inertial-to-body`` says otherwise;
* the **unit** (``angle_unit``, ``--angle-unit``): ``deg`` or ``rad``.

The angles are turned into rotation matrices (SciPy's :meth:`~scipy.spatial.transform.Rotation.from_euler`) as the
rows are read; from there the log is a log of rotation matrices. The conversion has no singularity (only the inverse,
matrix to angles, has one at pitch ±90° for ``ZYX``). A sample with an empty or non-finite angle is a missing sample,
as for every attitude. Sequences that repeat an axis (``ZXZ``) have no column per axis and are not read.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterator
from dataclasses import replace
from typing import Any

import numpy as np

from omegahat.io.columns import EULER_COLUMNS, LogFormatError

__all__ = ["ANGLE_UNITS", "as_matrices", "check_conventions", "matrices", "turned_into_matrices"]

ANGLE_UNITS = ("deg", "rad")
#: a unit an angle column's name states in its last word (``Roll (deg)``, ``yaw_rad``), said where it is not read
_NAMED_UNIT = {
    **dict.fromkeys(("deg", "degs", "degree", "degrees", "°"), "deg"),
    **dict.fromkeys(("rad", "rads", "radian", "radians"), "rad"),
}
_UNIT_WORD = re.compile(rf"(?:^|[\s_.\-\[(]+)({'|'.join(_NAMED_UNIT)})\s*[\])]?$")
_ASK = (
    "--euler SEQ (e.g. ZYX: yaw, then pitch, then roll about the body's rotating axes, the aerospace convention; "
    "lower case turns about the fixed axes) and --angle-unit deg or rad"
)


def check_conventions(euler: str | None, angle_unit: str | None) -> None:
    """Raise ``ValueError`` unless ``euler`` is None or three letters naming x, y and z once each, all upper or all
    lower case, and ``angle_unit`` is None, ``"deg"`` or ``"rad"``."""
    if euler is not None and not (
        isinstance(euler, str)
        and len(euler) == 3
        and (euler.isupper() or euler.islower())
        and set(euler.lower()) == set("xyz")
    ):
        raise ValueError(
            "Euler sequence must be three letters naming x, y and z once each, upper case (about the rotating axes) "
            f"or lower case (about the fixed axes), e.g. ZYX; got {euler!r}"
        )
    if angle_unit not in (None, *ANGLE_UNITS):
        raise ValueError(f"angle unit must be {' or '.join(ANGLE_UNITS)}; got {angle_unit!r}")


def matrices(angles: np.ndarray, euler: str, degrees: bool) -> np.ndarray:
    """(E1)/(E2): the rotation matrices ``(T, 3, 3)`` of ``angles (T, 3)`` about x, y, z (in that order, whatever the
    sequence) for the sequence ``euler``; a row with a non-finite angle gives a matrix of NaN (a missing sample)."""
    from scipy.spatial.transform import Rotation  # loaded only for Euler angles

    angles = np.asarray(angles, dtype=float)
    ok = np.all(np.isfinite(angles), axis=1)
    out = np.full((len(angles), 3, 3), np.nan)
    if ok.any():
        order = ["xyz".index(a) for a in euler.lower()]  # the columns in the order of the sequence
        out[ok] = Rotation.from_euler(euler, angles[ok][:, order], degrees=degrees).as_matrix()
    return out


def as_matrices(stream: Any, euler: str | None, angle_unit: str | None) -> None:
    """Make ``stream`` (a :class:`~omegahat.io.registry.LogStream`; that module imports this one) of kind
    ``"euler"`` (chunks of angles ``(m, 3)`` about x, y, z) a stream of rotation matrices by (E1)/(E2). Raises
    :class:`LogFormatError` asking for the conventions when either is missing; given for a log of another attitude,
    they are not used, and a note says so (a folder run gives every log the same options)."""
    if stream.kind != "euler":
        if euler is not None or angle_unit is not None:  # as --scalar-first for named quaternion columns: said
            stream.notes.append(
                f"--euler and --angle-unit not used: they read roll,pitch,yaw columns, and this log's attitude is "
                f"{stream.attitude_name or stream.kind}"
            )
        return
    missing = [flag for flag, value in (("--euler", euler), ("--angle-unit", angle_unit)) if value is None]
    if missing:
        raise LogFormatError(
            f"{stream.source}{stream.context}: the attitude is Euler angles ({stream.attitude_name}), whose sequence "
            f"and unit the log cannot show; pass {_ASK} (missing: {', '.join(missing)}; in Python euler= and "
            "angle_unit=)"
        )
    assert euler is not None and angle_unit is not None  # and checked (check_conventions) by ReadOptions
    degrees = angle_unit == "deg"
    names = ", ".join(EULER_COLUMNS)
    about = "rotating" if euler.isupper() else "fixed"
    written = [re.sub(r"\s*\((roll|pitch|yaw)\)$", "", n) for n in stream.attitude_name.split(",")]  # less the map's
    stated = {_NAMED_UNIT[m.group(1)] for n in written if (m := _UNIT_WORD.search(n.lower()))}
    against = (
        f"; their names say {stated.pop()} ({stream.attitude_name}): --angle-unit is what is read"
        if len(stated) == 1 and angle_unit not in stated
        else ""
    )
    stream.notes.append(
        f"attitude: Euler angles {names} in {'degrees' if degrees else 'radians'}, sequence {euler} (about the "
        f"{about} axes){against}"
    )
    turned_into_matrices(
        stream,
        lambda angles: matrices(angles, euler, degrees),
        np.abs,
        None
        if degrees
        else "angles up to {largest:.4g} read as radians (--angle-unit rad): more than a turn; if they are degrees, "
        "pass --angle-unit deg",
    )


def turned_into_matrices(
    stream: Any,
    to_matrices: Callable[[np.ndarray], np.ndarray],
    magnitude: Callable[[np.ndarray], np.ndarray],
    beyond_a_turn: str | None,
) -> None:
    """Make ``stream`` (a :class:`~omegahat.io.registry.LogStream` of three numbers per sample: Euler angles, a
    rotation vector) a stream of rotation matrices ``to_matrices(rows)`` as its chunks are read. Where
    ``beyond_a_turn`` is given and the ``magnitude`` of some finite row exceeds a turn (2π + 0.5), it is noted,
    formatted with the ``largest``: radians that may be degrees."""
    seen = {"largest": 0.0}

    def chunks(raw: Iterator) -> Iterator:
        for chunk in raw:
            rows = np.asarray(chunk.data, dtype=float)
            finite = rows[np.all(np.isfinite(rows), axis=1)]
            if finite.size:
                seen["largest"] = max(seen["largest"], float(np.max(magnitude(finite))))
            yield replace(chunk, data=to_matrices(rows))
        if beyond_a_turn is not None and seen["largest"] > 2 * np.pi + 0.5:
            stream.notes.append(beyond_a_turn.format(largest=seen["largest"]))

    stream.kind = "matrix"
    stream.digits = None  # the numbers' digits say nothing of the matrices' precision
    stream.convert(chunks)
