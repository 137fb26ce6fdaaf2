r"""Qualisys Track Manager (QTM) MAT exports: the ``.mat`` file QTM writes with "Export to MAT file".

The file is a MATLAB level 5 MAT-file holding one struct, named after the measurement, with the fields (QTM 2.x;
newer versions add others, which are ignored)::

    File, Timestamp, StartFrame, Frames, FrameRate        the capture: its first frame's number, frames, Hz
    Trajectories                                          the markers (not read)
    RigidBodies.Bodies                                    the number of rigid bodies n
    RigidBodies.Name                                      their names (1 × n cells)
    RigidBodies.Positions  (n, 3, F)                      mm (not read)
    RigidBodies.Rotations  (n, 9, F)                      the 6DOF rotation matrix, nine elements per frame
    RigidBodies.RPYs       (n, 3, F)                      roll, pitch, yaw in degrees
    RigidBodies.Residual   (n, 1, F)

**The rotation** is QTM's 6DOF matrix, body → global (omegahat's ``R``), its nine elements column by column
(``R[i, j] = Rotations[b, i + 3 j, k]``) as in the 6D TSV export (:mod:`omegahat.io.qualisys`, which explains
it), and checked the same way against ``RPYs`` when they are there: on the first tracked frames the matrix must
agree with QTM's default angles, else the file is refused rather than read in an order it contradicts. A frame
where the body is not tracked (QTM writes NaN, or an all-zero matrix) is a missing sample.

**Time**: frame ``StartFrame + k`` at ``(StartFrame + k − 1) / FrameRate`` s (frame 1 at 0, as in the TSV export's
``Time`` column). **Selection**: ``--body`` names the body (optional when there is one); the error lists them.

**What is refused, with a message naming the file**: a MAT-file of MATLAB 7.3 (HDF5; export from QTM, or save
with ``-v7``), a MAT-file holding no QTM struct (its variables are listed), a struct without rigid bodies or frame
rate, and a file whose arrays would take more than :data:`MAX_MAT_BYTES` of memory: the compressed elements are
measured by decompressing them in pieces, before SciPy reads the file (a few kilobytes can expand into
gigabytes). A damaged file is an error naming it, whatever SciPy's parser raised.
"""

from __future__ import annotations

import math
import os
import re
import struct
import zlib

import numpy as np

from omegahat.io.columns import LogFormatError
from omegahat.io.mocap import choose_body
from omegahat.io.npzlog import MAX_NPZ_BYTES
from omegahat.io.qualisys import check_order
from omegahat.io.registry import LogStream, ReadOptions

__all__ = ["MAX_MAT_BYTES", "open_qtm_mat"]

MAX_MAT_BYTES = MAX_NPZ_BYTES  #: bytes of arrays read from one MAT-file at most: it is read whole, as an NPZ log
_HEADER = 128  # a level 5 MAT-file's header: text, subsystem offset, version, endian indicator
_COMPRESSED = 15  # miCOMPRESSED: a zlib stream holding one element
_PIECE = 1 << 20  # bytes decompressed at a time while measuring


def _expanded_size(path: str) -> int:
    """The bytes the file's elements hold once decompressed (module docstring); stops past :data:`MAX_MAT_BYTES`.
    Raises for a file that is not a level 5 MAT-file."""
    with open(path, "rb") as f:
        header = f.read(_HEADER)
        if len(header) < _HEADER or header[126:128] not in (b"IM", b"MI"):
            raise LogFormatError(f"{path}: not a MATLAB level 5 MAT-file (no MAT-file header)")
        if header[124:126] in (b"\x00\x02", b"\x02\x00"):
            raise LogFormatError(
                f"{path}: a MATLAB 7.3 MAT-file (HDF5), which omegahat does not read; export the MAT file from QTM "
                "again, or save it in MATLAB with -v7"
            )
        order = "<" if header[126:128] == b"IM" else ">"
        total = 0
        while total <= MAX_MAT_BYTES:
            tag = f.read(8)
            if len(tag) < 8:
                return total
            kind, size = struct.unpack(order + "II", tag)
            if kind != _COMPRESSED:
                total += size
                f.seek(size, os.SEEK_CUR)
                continue
            inflate, left = zlib.decompressobj(), size
            try:
                while left > 0 and total <= MAX_MAT_BYTES:
                    data = f.read(min(left, _PIECE))
                    if not data:
                        break
                    left -= len(data)
                    total += len(inflate.decompress(data, _PIECE))
                    while inflate.unconsumed_tail and total <= MAX_MAT_BYTES:
                        total += len(inflate.decompress(inflate.unconsumed_tail, _PIECE))
            except zlib.error as exc:
                raise LogFormatError(f"{path}: not a readable MAT-file (damaged compressed data: {exc})") from None
        return total


def _load(path: str) -> dict:
    from scipy.io import loadmat  # here: SciPy's MAT reader loads in 0.1 s, for MAT files only

    expanded = _expanded_size(path)
    if expanded > MAX_MAT_BYTES:
        raise LogFormatError(
            f"{path}: its arrays take more than {MAX_MAT_BYTES >> 30} GiB once decompressed, more than omegahat reads "
            "from one MAT-file (it is read whole); export a shorter range or the 6D TSV, which is read in chunks"
        )
    try:
        return loadmat(path, struct_as_record=True, squeeze_me=False, verify_compressed_data_integrity=True)
    except Exception as exc:  # SciPy's parser raises many kinds on damaged bytes: all mean the same
        raise LogFormatError(f"{path}: not a readable MAT-file ({type(exc).__name__}: {exc})") from None


def _field(record: np.ndarray, name: str) -> np.ndarray | None:
    """A field of a 1 × 1 MATLAB struct (None if absent or empty)."""
    if record.dtype.names is None or name not in record.dtype.names or record.size != 1:
        return None
    value = record.flat[0][name]
    return value if getattr(value, "size", 0) else None


def _number(record: np.ndarray, name: str) -> float | None:
    value = _field(record, name)
    try:
        return float(np.asarray(value, dtype=float).flat[0]) if value is not None else None
    except (TypeError, ValueError):
        return None


def _names(cells: np.ndarray | None, n: int) -> list[str]:
    """The bodies' names from ``RigidBodies.Name`` (a cell array of strings); ``body k`` for a missing one."""
    flat = list(cells.flat) if cells is not None else []
    names = []
    for k in range(n):
        item = np.asarray(flat[k]) if k < len(flat) else np.array([])
        names.append(str(item.flat[0]).strip() if item.size and item.dtype.kind in "US" else f"body {k + 1}")
    return names


_COMPONENTS = ("1234", "0123", "wxyz")  # a quaternion's names end in these, one vector each (the scalar first)


def _quaternion_parts(arrays: dict) -> list[tuple[str, ...]]:
    """Quaternions stored one component per vector (``imu_q1`` … ``imu_q4``, ``q_w`` … ``q_z``): the names of each
    group of four same-length vectors (more than 4 samples) with one stem, in the scalar-first order of the suffixes."""
    vectors = {k.lower(): k for k, s in arrays.items() if max(s, default=0) > 4 and math.prod(s) == max(s)}
    groups = []
    for name in vectors:
        for order in _COMPONENTS:
            stem = name[:-1]
            if name[-1] == order[0] and all(stem + c in vectors for c in order):
                names = tuple(vectors[stem + c] for c in order)
                if len({arrays[k] for k in names}) == 1:
                    groups.append(names)
    return groups


def _recipe(path: str, variables: dict) -> str:
    """``, e.g. python -c "..."``: the line that writes this MAT file's arrays as an NPZ log, guessed from their names
    and shapes (a time vector or a rate, ``(T, 4)`` quaternions or ``(3, 3, T)`` matrices); empty when no attitude
    array is found."""
    arrays = {k: np.shape(v) for k, v in variables.items() if isinstance(v, np.ndarray) and v.dtype.kind in "fiu"}
    attitude = next(((k, s) for k, s in arrays.items() if len(s) == 2 and 4 in s and max(s) > 4), None)
    matrices = next(((k, s) for k, s in arrays.items() if len(s) == 3 and s.count(3) >= 2 and max(s) > 3), None)
    parts = _quaternion_parts(arrays)
    found = attitude if attitude is not None else matrices
    if found is None and not parts:
        return ""
    name, shape = found if found is not None else (parts[0][0], arrays[parts[0][0]])
    T = max(shape)
    clock = re.compile(r"time|stamp|^ts$|^t$", re.I)
    times = [k for k, s in arrays.items() if clock.search(k) and sorted(s)[-1] == T and math.prod(s) == T]
    rates = [k for k, s in arrays.items() if re.search(r"rate|freq|^fs$|hz", k, re.I) and math.prod(s) == 1]
    t = (
        f"m[{times[0]!r}].ravel()"
        if times
        else f"np.arange({T}) / m[{rates[0]!r}].item()"
        if rates
        else f"np.arange({T}) / RATE_HZ"
    )
    if found is None:  # four vectors, one per component
        what = f"q=np.column_stack([m[k].ravel() for k in {parts[0]!r}]), scalar_first=True"
        scalar = "its first name's" if parts[0][0][-1].lower() != "w" else "w"
        tail = f" (the scalar taken as {scalar} component: reorder the names if it is not)" + "".join(
            f"; another quaternion: {', '.join(other)}" for other in parts[1:]
        )
    elif found is attitude:
        what = f"q=m[{name!r}]" + (".T" if shape[0] == 4 else "") + ", scalar_first=True"
        tail = " (scalar_first=False if the quaternion's scalar is its last column)"
    else:
        what, tail = "R=" + (f"np.moveaxis(m[{name!r}], -1, 0)" if shape[-1] == T else f"m[{name!r}]"), ""
    stem = os.path.splitext(os.path.basename(path))[0]
    return (
        f', e.g. python -c "import numpy as np, scipy.io; m = scipy.io.loadmat({os.path.basename(path)!r}); '
        f'np.savez({stem + ".npz"!r}, t={t}, {what})"{tail}'
    )


def open_qtm_mat(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One body's attitude from a QTM MAT export (module docstring)."""
    path = os.fspath(path)
    variables = {k: v for k, v in _load(path).items() if not k.startswith("__")}
    captures = [k for k, v in variables.items() if isinstance(v, np.ndarray) and _field(v, "RigidBodies") is not None]
    if len(captures) != 1:
        found = ", ".join(f"{k} {'x'.join(map(str, np.shape(v)))}" for k, v in variables.items()) or "none"
        raise LogFormatError(
            f"{path}: " + ("no" if not captures else f"{len(captures)}") + " QTM measurement structs with "
            f"RigidBodies (variables: {found}); omegahat reads the MAT export of QTM with 6DOF data, one measurement "
            f"per file. Other MAT files: write the arrays as an NPZ log (t, and q or R){_recipe(path, variables)}"
        )
    capture = variables[captures[0]]
    bodies = _field(capture, "RigidBodies")
    assert bodies is not None
    rate = _number(capture, "FrameRate")
    if rate is None or not rate > 0 or not np.isfinite(rate):
        raise LogFormatError(f"{path}: {captures[0]}.FrameRate is {rate}: the frames have no times")
    rotations = _field(bodies, "Rotations")
    n = int(_number(bodies, "Bodies") or 0)
    if rotations is None or n < 1 or rotations.size % (9 * n) or rotations.dtype.kind not in "fiu":
        shape = "none" if rotations is None else "x".join(map(str, rotations.shape))
        raise LogFormatError(
            f"{path}: {captures[0]}.RigidBodies holds {n} bodies and Rotations of shape {shape}, not {n} x 9 x "
            "frames; export the MAT file with 6DOF data"
        )
    rotations = np.asarray(rotations, dtype=float).reshape(n, 9, -1)
    names = _names(_field(bodies, "Name"), n)
    name = choose_body(names, options.body, path, "rigid body", "rigid bodies")
    b = names.index(name)
    frames = rotations.shape[2]
    R = rotations[b].T.reshape(frames, 3, 3).transpose(0, 2, 1).copy()  # R[i, j] = Rotations[b, i + 3 j]
    untracked = ~np.all(np.isfinite(R.reshape(frames, 9)), axis=1) | ~np.any(R.reshape(frames, 9), axis=1)
    R[untracked] = np.nan
    angles = _field(bodies, "RPYs")
    rpy = None
    if angles is not None and angles.size == 3 * n * frames and angles.dtype.kind in "fiu":
        rpy = np.asarray(angles, dtype=float).reshape(n, 3, frames)[b].T
    checked = check_order(R, rpy, path, name)
    start = _number(capture, "StartFrame")
    first = int(start) if start is not None and np.isfinite(start) and start >= 1 else 1
    numbers = first + np.arange(frames)
    return LogStream.from_arrays(
        path,
        "matrix",
        (numbers - 1) / rate,
        R,
        labels=numbers,
        label="frame",
        size=os.path.getsize(path),
        done=os.path.getsize(path),
        description=f"Qualisys QTM MAT export ({captures[0]}): body {name!r}, RigidBodies.Rotations column by "
        f"column (body -> global; {checked}), time (frame - 1) / {rate:g} Hz, {frames} frames",
        notes=[f"other bodies in the file: {', '.join(x for x in names if x != name)}"] if n > 1 else [],
        time_name=None,
        attitude_name=f"{name} Rotations",
    )
