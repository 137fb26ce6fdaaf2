r"""Qualisys Track Manager (QTM) 6DOF exports: the ``_6d.tsv`` file, recognised from its header.

The file is tab separated: a header of ``NAME<tab>value`` lines (``NO_OF_FRAMES``, ``NO_OF_CAMERAS``,
``NO_OF_BODIES``, ``FREQUENCY``, ``TIME_STAMP``, ``DATA_INCLUDED 6D``, ``BODY_NAMES<tab>name<tab>name...``, ...),
then (with QTM's "time and frame columns" option) a row of column labels, ``Frame  Time`` followed, for each body
in the order of ``BODY_NAMES``, by ``X Y Z`` (the position, mm), three Euler angles (``Roll Pitch Yaw`` by default),
``Residual`` and ``Rot[0]`` … ``Rot[8]``, then one row per frame.

**The rotation** is the matrix ``R`` of QTM's 6DOF output, which takes a point from the body's local coordinates
to the global (or reference) coordinates, ``P_global = R · P_local + P_origin`` (QTM manual, "Rotation angle
calculations in QTM"): body → inertial, omegahat's ``R``. QTM lays its nine elements out **column by column**::

    R = | Rot[0]  Rot[3]  Rot[6] |
        | Rot[1]  Rot[4]  Rot[7] |          R[i, j] = Rot[i + 3 j]
        | Rot[2]  Rot[5]  Rot[8] |

as QTM's real-time protocol sends them and its SDKs read them (the 6DOF rotation matrix, column-major). The reader
checks this on the file itself when the angles are QTM's default ones (``Roll Pitch Yaw``: rotations about the
local X, then Y, then Z axes, ``R = Rx(roll) Ry(pitch) Rz(yaw)``): on the first tracked frames the matrix must agree
with the angles, else the file is refused with a message rather than read in an order it contradicts. A frame where
the body is not tracked (QTM writes empty fields, NaN, or an all-zero matrix) is a missing sample.

**Time**: the ``Time`` column; without one, ``Frame / FREQUENCY`` (or the row's index / ``FREQUENCY``).
**Selection**: ``--body`` names the body (optional when there is one); the error lists ``BODY_NAMES``.
"""

from __future__ import annotations

import os

import numpy as np

from omegahat.io.columns import LogFormatError, shown_value
from omegahat.io.euler import matrices as euler_matrices
from omegahat.io.mocap import choose_body
from omegahat.io.precision import significant_digits
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.textlines import head_lines

__all__ = ["check_order", "is_qtm_6d", "open_qtm_6d"]

_ROT = [f"Rot[{k}]" for k in range(9)]
_CHECK_FRAMES = 20  # tracked frames on which the element order is checked against the angles
_ORDER_TOL = 1e-3  # agreement of the matrix with the angles: the file's rounding (3+ decimals) is below this


def is_qtm_6d(path: str | os.PathLike[str]) -> bool:
    """Whether a file is a QTM 6D TSV export: a ``DATA_INCLUDED<tab>6D`` line among the first lines."""
    return any(line.split("\t")[:2] == ["DATA_INCLUDED", "6D"] for line in head_lines(os.fspath(path), 40))


def _rows(path: str) -> list[list[str]]:
    try:
        with open(path, encoding="utf-8-sig") as f:
            text = f.read()
    except UnicodeDecodeError as exc:
        raise LogFormatError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    return [line.rstrip("\r").split("\t") for line in text.split("\n")]


def _rot_blocks(labels: list[str]) -> list[int]:
    """The column of ``Rot[0]`` of each body, in order (each followed by ``Rot[1]`` … ``Rot[8]``)."""
    starts = [j for j, a in enumerate(labels) if a.strip().endswith("Rot[0]")]
    return [j for j in starts if [a.strip()[-6:] for a in labels[j : j + 9]] == _ROT]


def _from_angles(roll, pitch, yaw) -> np.ndarray:
    """``Rx(roll) Ry(pitch) Rz(yaw)`` (degrees): QTM's default angles, written out from the manual's definition."""
    return euler_matrices(np.column_stack([roll, pitch, yaw]), "XYZ", degrees=True)


def check_order(R: np.ndarray, angles: np.ndarray | None, path: str, name: str) -> str:
    """Compare the first tracked frames with their angles (module docstring); returns what was checked."""
    ok = np.flatnonzero(np.all(np.isfinite(R.reshape(len(R), -1)), axis=1))[:_CHECK_FRAMES]
    if angles is None or not ok.size:
        return "element order as documented (no Roll, Pitch, Yaw columns to check it on)"
    A = _from_angles(*angles[ok].T)
    as_read = np.abs(R[ok] - A).max()
    transposed = np.abs(np.swapaxes(R[ok], 1, 2) - A).max()
    if as_read <= _ORDER_TOL:
        return f"element order checked against Roll, Pitch, Yaw (agree to {as_read:.1g})"
    if transposed <= _ORDER_TOL:
        raise LogFormatError(
            f"{path}: the Rot[0..8] of body {name!r} agree with its Roll, Pitch, Yaw only when read row by row, not "
            "column by column as QTM documents them; read the file with a column map naming r11..r33 "
            "(--columns) if its order is known"
        )
    return "element order as documented (the angles follow a custom Euler definition: not checked)"


def open_qtm_6d(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One body's attitude from a QTM 6D TSV export (module docstring)."""
    path = os.fspath(path)
    rows = _rows(path)
    meta: dict[str, list[str]] = {}
    i = 0
    while i < len(rows) and rows[i][0].isupper() and not rows[i][0][:1].isdigit() and rows[i][0] != "":
        meta.setdefault(rows[i][0], rows[i][1:])
        i += 1
    if meta.get("DATA_INCLUDED", [""])[0] != "6D":
        raise LogFormatError(f"{path}: not a QTM 6D export (no 'DATA_INCLUDED<tab>6D' header line)")
    bodies = [b for b in meta.get("BODY_NAMES", []) if b.strip()]
    try:
        rate = float(meta.get("FREQUENCY", ["nan"])[0])
    except ValueError:
        rate = float("nan")
    while i < len(rows) and not any(f.strip() for f in rows[i]):
        i += 1
    labels = rows[i] if i < len(rows) else []
    blocks = _rot_blocks(labels)
    if blocks:
        i += 1
    else:  # no label row: 16 columns a body (X Y Z, 3 angles, Residual, Rot[0..8]), after Frame and Time if any
        width = len(labels)
        lead = width - 16 * len(bodies)
        labels = ["Frame", "Time"] if lead == 2 else []
        blocks = [lead + 7 + 16 * k for k in range(len(bodies))] if lead in (0, 2) and bodies else []
    if not bodies or len(blocks) != len(bodies) or i >= len(rows):
        raise LogFormatError(
            f"{path}: BODY_NAMES lists {len(bodies)} bodies but the columns hold {len(blocks)} Rot[0..8] blocks; "
            "export the 6D TSV with its header and the time and frame columns"
        )
    name = choose_body(bodies, options.body, path, "body", "bodies")
    start = blocks[bodies.index(name)]
    stripped = [a.strip() for a in labels]
    time_col = stripped.index("Time") if "Time" in stripped else None
    frame_col = stripped.index("Frame") if "Frame" in stripped else None
    if time_col is None and not rate > 0:
        raise LogFormatError(f"{path}: no Time column and no FREQUENCY in the header: the frames have no times")
    angle_cols = (
        list(range(start - 4, start - 1)) if stripped[start - 4 : start - 1] == ["Roll", "Pitch", "Yaw"] else None
    )
    times, mats, angles, lines = [], [], [], []
    texts: list[str] = []
    for k in range(i, len(rows)):
        row = rows[k]
        if not any(f.strip() for f in row):
            continue
        line = k + 1
        fields = [row[j].strip() if j < len(row) else "" for j in range(start, start + 9)]
        values = [_value(f, path, line, f"{name} {_ROT[c]}") for c, f in enumerate(fields)]
        if time_col is not None:
            times.append(_value(row[time_col] if time_col < len(row) else "", path, line, "Time", required=True))
        elif frame_col is not None:
            frame = row[frame_col] if frame_col < len(row) else ""
            times.append(_value(frame, path, line, "Frame", required=True) / rate)
        else:
            times.append(len(times) / rate)
        m = np.array(values).reshape(3, 3).T  # R[i, j] = Rot[i + 3 j]
        if not np.all(np.isfinite(m)) or not np.any(m):
            m = np.full((3, 3), np.nan)
        elif len(texts) < 1800:
            texts += fields
        mats.append(m)
        if angle_cols is not None:
            angles.append([_value(row[j] if j < len(row) else "", path, line, stripped[j]) for j in angle_cols])
        lines.append(line)
    if not times:
        raise LogFormatError(f"{path}: no frames after the header")
    R = np.array(mats)
    checked = check_order(R, np.array(angles) if angle_cols else None, path, name)
    how = "column 'Time'" if time_col is not None else f"Frame / {rate:g} Hz"
    stream = LogStream.from_arrays(
        path,
        "matrix",
        np.array(times),
        R,
        labels=np.array(lines),
        label="line",
        size=os.path.getsize(path),
        done=os.path.getsize(path),
        description=f"Qualisys QTM 6D TSV: body {name!r}, rotation Rot[0..8] column by column (body -> global; "
        f"{checked}), time from {how}, {R.shape[0]} frames" + (f" at {rate:g} Hz" if rate > 0 else ""),
        notes=[f"other bodies in the file: {', '.join(b for b in bodies if b != name)}"] if len(bodies) > 1 else [],
        time_name="Time" if time_col is not None else None,
        attitude_name=f"{name} Rot[0..8]",
    )
    stream.digits = significant_digits(texts)
    return stream


def _value(text: str, path: str, line: int, column: str, required: bool = False) -> float:
    text = text.strip()
    if not text:
        if required:
            raise LogFormatError(f"{path}, line {line}, column {column}: empty (every frame needs one)")
        return float("nan")
    try:
        return float(text)
    except ValueError:
        raise LogFormatError(f"{path}, line {line}, column {column}: {shown_value(text)} is not a number") from None
