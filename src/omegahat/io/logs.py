"""Attitude logs in and angular-velocity estimates out: CSV and NPZ.

Input columns (CSV header, or NPZ array names), by name and in any order:

* ``t``: sample times in seconds, strictly increasing, never empty;
* the attitude, exactly one of
  - a quaternion ``qw, qx, qy, qz`` (any column order; the names say which is the scalar part),
  - a rotation matrix ``r11, r12, …, r33`` (``rij`` = row i, column j of R, body → inertial),
  - body-frame directions ``b1x, b1y, b1z, b2x, …`` of n ≥ 2 known inertial directions (their inertial
    coordinates are given separately, e.g. ``omegahat estimate --references``);
* optionally the known torque ``tau_x, tau_y, tau_z`` (body axes, N·m).

Other columns are ignored (a log may carry gyroscope columns, say). In a CSV an **empty field** in the
attitude columns is a missing sample: the whole sample becomes NaN (the estimator skips it and predicts
through). A quaternion need not be normalised here; the estimator checks it. An NPZ may instead hold
``q`` ``(T, 4)`` — **scalar last** ``(x, y, z, w)`` as SciPy, unless the file also holds a boolean
``scalar_first`` — or ``R`` ``(T, 3, 3)`` or ``b`` ``(T, n, 3)``, and ``tau`` ``(T, 3)``; NaN rows are missing
samples.

Every error names where the problem is: for a CSV the line number (1 = the header) and the column, e.g.
``line 17, column qx: 'abc' is not a number``; for an NPZ the array.

Output: :func:`write_omega_csv` writes ``t,wx,wy,wz`` (rad/s, body axes), one row per sample, ``nan`` where
there is no estimate.
"""

from __future__ import annotations

import csv
import os
from dataclasses import dataclass

import numpy as np

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

QUATERNION_COLUMNS = ("qx", "qy", "qz", "qw")  # stored in this order: SciPy's scalar-last
MATRIX_COLUMNS = tuple(f"r{i}{j}" for i in range(1, 4) for j in range(1, 4))
TORQUE_COLUMNS = ("tau_x", "tau_y", "tau_z")
_AXES = ("x", "y", "z")


class LogFormatError(ValueError):
    """A log file that cannot be read as documented in :mod:`omegahat.io`; the message says where."""


@dataclass(frozen=True)
class AttitudeLog:
    """A log read from a file.

    ``t (T,)``; ``kind`` is ``"quaternion"`` (``data (T, 4)``, scalar **last**, SciPy's order),
    ``"matrix"`` (``data (T, 3, 3)``) or ``"directions"`` (``data (T, n, 3)``); ``torque (T, 3)`` or None.
    Missing samples are rows of NaN.
    """

    t: np.ndarray
    kind: str
    data: np.ndarray
    torque: np.ndarray | None = None
    source: str = ""

    @property
    def missing(self) -> np.ndarray:
        """Boolean ``(T,)``: samples with a non-finite attitude (skipped by the estimator)."""
        return ~np.all(np.isfinite(self.data.reshape(self.t.size, -1)), axis=1)

    def __len__(self) -> int:
        return self.t.size


def _direction_columns(names) -> list[str]:
    """``b1x, b1y, b1z, b2x, …`` for every i such that some ``bi?`` column is present (checked later)."""
    idx = sorted(
        {int(nm[1:-1]) for nm in names if len(nm) >= 3 and nm[0] == "b" and nm[1:-1].isdigit() and nm[-1] in _AXES}
    )
    return [f"b{i}{a}" for i in idx for a in _AXES]


def _choose_attitude(names, where: str) -> tuple[str, list[str]]:
    """Which attitude group the names hold: ``(kind, columns in storage order)``."""
    present = set(names)
    groups = {
        "quaternion": list(QUATERNION_COLUMNS),
        "matrix": list(MATRIX_COLUMNS),
        "directions": _direction_columns(names),
    }
    touched = {kind: cols for kind, cols in groups.items() if cols and present & set(cols)}
    if not touched:
        raise LogFormatError(
            f"{where}: no attitude columns; expected qw,qx,qy,qz or r11..r33 or b1x,b1y,b1z,b2x,... "
            f"(found: {', '.join(names)})"
        )
    if len(touched) > 1:
        raise LogFormatError(f"{where}: attitude given more than one way ({' and '.join(touched)}); keep one")
    kind, cols = next(iter(touched.items()))
    missing = [c for c in cols if c not in present]
    if kind == "directions":
        n = len(cols) // 3
        if n < 2:
            raise LogFormatError(f"{where}: direction input needs at least 2 directions (b1*, b2*); got {n}")
        if missing:
            raise LogFormatError(f"{where}: missing direction column(s) {', '.join(missing)}")
        if [int(c[1:-1]) for c in cols[::3]] != list(range(1, n + 1)):
            raise LogFormatError(
                f"{where}: directions must be numbered b1, b2, ... without gaps; got "
                f"{', '.join(sorted({c[:-1] for c in cols}))}"
            )
    elif missing:
        raise LogFormatError(f"{where}: missing {kind} column(s) {', '.join(missing)}")
    return kind, cols


def _torque_columns(names, where: str) -> list[str] | None:
    present = [c for c in TORQUE_COLUMNS if c in names]
    if not present:
        return None
    if len(present) != 3:
        missing = [c for c in TORQUE_COLUMNS if c not in names]
        raise LogFormatError(f"{where}: torque needs tau_x, tau_y and tau_z; missing {', '.join(missing)}")
    return list(TORQUE_COLUMNS)


def _shape_attitude(kind: str, flat: np.ndarray) -> np.ndarray:
    T = flat.shape[0]
    if kind == "matrix":
        return flat.reshape(T, 3, 3)
    if kind == "directions":
        return flat.reshape(T, -1, 3)
    return flat


def _check_time_order(t, prefix: str, label: str, numbers, column: str = "") -> None:
    """Strictly increasing finite times; messages call sample k ``{prefix}, {label} {numbers[k]}{column}``."""
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        k = int(bad[0])
        raise LogFormatError(f"{prefix}, {label} {numbers[k]}{column}: time {float(t[k])!r} is not finite")
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size:
        k = int(bad[0]) + 1
        raise LogFormatError(
            f"{prefix}, {label} {numbers[k]}{column}: time {float(t[k])!r} is not after {float(t[k - 1])!r} "
            f"({label} {numbers[k - 1]}); times must increase strictly"
        )


# ------------------------------------------------------------------------------------------------------ CSV


def _counting_lines(text: str, counter: list):
    """Lines of ``text`` (ends kept), adding each line's length to ``counter[0]``."""
    for line in text.splitlines(keepends=True):
        counter[0] += len(line)
        yield line


def read_csv(path, progress=None) -> AttitudeLog:
    """Read a CSV log (columns: module docstring).

    ``progress``: a callable ``progress(done, total)``, called now and then with the characters parsed so far
    and the file's length in characters (for a progress bar).

    Raises :class:`LogFormatError` naming the line and column of the first problem.
    """
    path = os.fspath(path)
    with open(path, newline="", encoding="utf-8") as f:
        text = f.read()
    consumed = [0]
    reader = csv.reader(_counting_lines(text, consumed))
    header = None
    for header in reader:
        if any(field.strip() for field in header):
            break
    if header is None or not any(field.strip() for field in header):
        raise LogFormatError(f"{path}: empty file, expected a header line naming the columns")
    header_line = reader.line_num
    names = [h.strip() for h in header]
    where = f"{path}, line {header_line} (header)"
    dup = sorted({n for n in names if names.count(n) > 1 and n})
    if dup:
        raise LogFormatError(f"{where}: duplicate column(s) {', '.join(dup)}")
    if "t" not in names:
        raise LogFormatError(f"{where}: no time column 't' (found: {', '.join(names)})")
    kind, att_cols = _choose_attitude(names, where)
    tau_cols = _torque_columns(names, where)
    col_index = {n: i for i, n in enumerate(names)}
    i_t = col_index["t"]
    i_att = [col_index[c] for c in att_cols]
    i_tau = [col_index[c] for c in tau_cols] if tau_cols else []

    times, att, tau, lines = [], [], [], []
    n_fields = len(names)
    for row in reader:
        line = reader.line_num
        if not any(field.strip() for field in row):
            continue  # blank line
        if len(row) != n_fields:
            raise LogFormatError(
                f"{path}, line {line}: {len(row)} fields, but the header (line {header_line}) names {n_fields}"
            )
        t_field = row[i_t].strip()
        if not t_field:
            raise LogFormatError(f"{path}, line {line}, column t: empty time (every row needs one)")
        times.append(_number(t_field, path, line, "t"))
        values = [row[i].strip() for i in i_att]
        if any(not v for v in values):
            att.append([np.nan] * len(values))  # a missing sample
        else:
            att.append([_number(v, path, line, c) for v, c in zip(values, att_cols, strict=True)])
        if i_tau:
            tv = []
            for i, c in zip(i_tau, tau_cols, strict=True):
                field = row[i].strip()
                if not field:
                    raise LogFormatError(
                        f"{path}, line {line}, column {c}: empty torque (fill the torque on every row)"
                    )
                value = _number(field, path, line, c)
                if not np.isfinite(value):
                    raise LogFormatError(f"{path}, line {line}, column {c}: torque {field!r} is not finite")
                tv.append(value)
            tau.append(tv)
        lines.append(line)
        if progress is not None and len(lines) % 4096 == 0:
            progress(consumed[0], len(text))
    if progress is not None:
        progress(consumed[0], len(text))
    if not times:
        raise LogFormatError(f"{path}: no data rows after the header (line {header_line})")
    t = np.array(times)
    _check_time_order(t, path, "line", lines, ", column t")
    data = _shape_attitude(kind, np.array(att, dtype=float))
    torque = np.array(tau, dtype=float) if tau_cols else None
    return AttitudeLog(t, kind, data, torque, path)


def _number(field: str, path, line: int, column: str) -> float:
    try:
        return float(field)
    except ValueError:
        raise LogFormatError(f"{path}, line {line}, column {column}: {field!r} is not a number") from None


# ------------------------------------------------------------------------------------------------------ NPZ


def read_npz(path) -> AttitudeLog:
    """Read an NPZ log (array names: module docstring). Raises :class:`LogFormatError` naming the array."""
    path = os.fspath(path)
    try:
        z = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as exc:
        raise LogFormatError(f"{path}: not a readable .npz file ({exc})") from None
    with z:
        names = list(z.files)

        def get(name, ndim_shape: str, shape_ok):
            a = z[name]
            if not np.issubdtype(a.dtype, np.number):
                raise LogFormatError(f"{path}, array {name}: expected numbers, got dtype {a.dtype}")
            a = np.asarray(a, dtype=float)
            if not shape_ok(a.shape):
                raise LogFormatError(f"{path}, array {name}: expected shape {ndim_shape}, got {a.shape}")
            return a

        if "t" not in names:
            raise LogFormatError(f"{path}: no array 't' (found: {', '.join(names) or 'none'})")
        t = get("t", "(T,)", lambda s: len(s) == 1 and s[0] > 0)
        T = t.size
        _check_time_order(t, f"{path}, array t", "index", range(T))

        whole = [n for n in ("q", "R", "b") if n in names]
        columns = [n for n in names if n in QUATERNION_COLUMNS + MATRIX_COLUMNS or _direction_columns([n])]
        if len(whole) + bool(columns) > 1:
            raise LogFormatError(f"{path}: attitude given more than one way ({', '.join(whole + columns)}); keep one")
        if "q" in whole:
            q = get("q", f"({T}, 4)", lambda s: s == (T, 4))
            scalar_first = bool(z["scalar_first"]) if "scalar_first" in names else False
            data = np.roll(q, -1, axis=1) if scalar_first else q
            kind = "quaternion"
        elif "R" in whole:
            data, kind = get("R", f"({T}, 3, 3)", lambda s: s == (T, 3, 3)), "matrix"
        elif "b" in whole:
            ok = lambda s: len(s) == 3 and s[0] == T and s[1] >= 2 and s[2] == 3  # noqa: E731
            data = get("b", f"({T}, n, 3) with n >= 2", ok)
            kind = "directions"
        else:
            kind, cols = _choose_attitude(names, path)
            flat = np.column_stack([get(c, f"({T},)", lambda s: s == (T,)) for c in cols])
            data = _shape_attitude(kind, flat)
        # A row with any non-finite entry is a missing sample, all NaN as in a CSV.
        bad = ~np.all(np.isfinite(data.reshape(T, -1)), axis=1)
        data = data.copy()
        data[bad] = np.nan

        torque = None
        if "tau" in names:
            torque = get("tau", f"({T}, 3)", lambda s: s == (T, 3))
        elif _torque_columns(names, path):
            torque = np.column_stack([get(c, f"({T},)", lambda s: s == (T,)) for c in TORQUE_COLUMNS])
        if torque is not None and not np.all(np.isfinite(torque)):
            k = int(np.flatnonzero(~np.all(np.isfinite(torque), axis=1))[0])
            raise LogFormatError(f"{path}, torque at index {k}: not finite ({torque[k].tolist()})")
    return AttitudeLog(t, kind, data, torque, path)


def read_log(path, progress=None) -> AttitudeLog:
    """Read a ``.csv`` or ``.npz`` log, chosen by the file name's extension."""
    ext = os.path.splitext(os.fspath(path))[1].lower()
    if ext == ".csv":
        return read_csv(path, progress=progress)
    if ext == ".npz":
        return read_npz(path)
    raise LogFormatError(f"{os.fspath(path)}: unknown log format {ext or '(no extension)'!r}; use .csv or .npz")


# --------------------------------------------------------------------------------------------------- output


def write_omega_csv(path, t, omega) -> None:
    """Write ``t,wx,wy,wz`` (rad/s), one row per sample; ``t (T,)``, ``omega (T, 3)``; NaN as ``nan``."""
    t = np.asarray(t, dtype=float)
    omega = np.asarray(omega, dtype=float)
    if t.ndim != 1 or omega.shape != (t.size, 3):
        raise ValueError(f"write_omega_csv needs t (T,) and omega (T, 3); got {t.shape} and {omega.shape}")
    table = np.column_stack([t, omega])
    np.savetxt(path, table, delimiter=",", header="t,wx,wy,wz", comments="", fmt="%.17g")
