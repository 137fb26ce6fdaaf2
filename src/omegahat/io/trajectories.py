r"""The trajectory files of robotics: EuRoC / ASL CSV, TUM and KITTI pose lists, recognised from their first lines.

These are the files `evo <https://github.com/MichaelGrupp/evo>`_ (the field's trajectory evaluation tool) reads and
writes; each pose's rotation maps the body (sensor) frame into the world frame, omegahat's ``R`` (body → inertial),
so the rate comes out in body axes. Positions are not read.

**EuRoC / ASL** (``.csv``; the ground truth ``state_groundtruth_estimate0/data.csv`` and ``vicon0/data.csv`` of the
EuRoC MAV dataset, and the ASL layout other datasets reuse): a header ``#timestamp [ns],p_RS_R_x [m],...,q_RS_w [],
q_RS_x [],q_RS_y [],q_RS_z [],...``; time in **nanoseconds** (integers, kept exact: ``t0`` is the first stamp), the
quaternion **scalar first** in the ``q_RS_w, q_RS_x, q_RS_y, q_RS_z`` columns (any position), the ``p_`` and every
other column ignored. Recognised by a first column ``#timestamp`` and the four ``q_RS_`` columns.

**TUM** (``.txt``, ``.tum``; the TUM RGB-D benchmark's format): one pose per line, ``timestamp tx ty tz qx qy qz
qw``, separated by blanks, ``#`` starting a comment line; the timestamp in **seconds since 1970** (``1.7e9``), read
as decimal text and made relative to its integer part before it becomes a float
(:class:`omegahat.io.timestamps.ExactTimes`), so no precision is lost; the quaternion **scalar last**. Recognised by
a first pose line of exactly 8 numbers.

**KITTI** (``.txt``; the KITTI odometry benchmark's ``poses/NN.txt``): one pose per line, the 12 numbers of the
``3 × 4`` matrix ``[R | t]`` row by row; the rotation is its left ``3 × 3`` block (``r11 r12 r13 tx r21 ...``). The
file has no times: give them with ``--times FILE`` (one time in seconds per line, as KITTI's ``times.txt``) or
``--rate HZ`` (frame ``k`` at ``k / rate``); a line of **13** numbers is ``t`` followed by the 12. Recognised by a
first line of 12 or 13 numbers. Read whole (a sequence of minutes is a few MB).

Digits: the quaternions and matrices carry the digits they were written with, and the precision policy
(:mod:`omegahat.io.precision`) normalises them within the tolerance those digits allow.
"""

from __future__ import annotations

import os
import re

import numpy as np

from omegahat.io.colmap import ColumnMap
from omegahat.io.columns import Layout, LogFormatError, normalise_name, shown_value
from omegahat.io.csvlog import TextFormat, open_by_header, open_text
from omegahat.io.precision import significant_digits
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.textlines import head_lines, header_fields

__all__ = ["TUM_COLUMNS", "is_euroc", "is_kitti", "is_tum", "open_euroc", "open_kitti", "open_tum"]

TUM_COLUMNS = ("t", "tx", "ty", "tz", "qx", "qy", "qz", "qw")
_EUROC_Q = {"qw": "q_rs_w", "qx": "q_rs_x", "qy": "q_rs_y", "qz": "q_rs_z"}
_UNITS = re.compile(r"\s*\[[^\]]*\]\s*$")


def _numbers(line: str) -> int | None:
    """How many numbers a blank-separated line holds, or None if it holds anything else."""
    parts = line.split()
    try:
        [float(p) for p in parts]
    except ValueError:
        return None
    return len(parts)


def _first_data_line(path: str) -> str | None:
    return next((x for x in head_lines(path, 40) if x.strip() and not x.lstrip().startswith("#")), None)


# ---------------------------------------------------------------------------------------------------- EuRoC


def _euroc_map(names: list[str]) -> ColumnMap | None:
    base = [_UNITS.sub("", normalise_name(n)) for n in names]
    if not base or not base[0].startswith("#timestamp"):
        return None
    try:
        return (("t", 1), *((k, base.index(v) + 1) for k, v in _EUROC_Q.items()))
    except ValueError:
        return None


def is_euroc(path: str | os.PathLike[str]) -> bool:
    """Whether a CSV file is an EuRoC / ASL trajectory: ``#timestamp`` first, and ``q_RS_w .. q_RS_z`` columns."""
    return _euroc_map(header_fields(os.fspath(path))) is not None


def _since(stream: LogStream, unit: str) -> str:
    base = stream.meta.get("time_base", 0)
    return f", relative to {base} {unit} (exact)" if base else ""


def _describe_euroc(stream: LogStream, lay: Layout, names: list[str]) -> str:
    del lay
    q = ",".join(_UNITS.sub("", n.strip()) for n in names if "q_rs" in n.lower())
    return (
        f"EuRoC / ASL CSV: quaternion {q} (scalar first), time from column {names[0].strip()!r} in ns"
        f"{_since(stream, 'ns')}, position columns not read"
    )


def open_euroc(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The attitude of an EuRoC / ASL trajectory CSV (module docstring)."""
    refusal = "not an EuRoC trajectory (no '#timestamp' and q_RS_w..q_RS_z columns)"
    return open_by_header(path, options, _euroc_map, refusal, TextFormat(time_scale=1e-9, describe=_describe_euroc))


# ---------------------------------------------------------------------------------------------------- TUM


def is_tum(path: str | os.PathLike[str]) -> bool:
    """Whether a text file is a TUM trajectory: its first pose line holds exactly 8 numbers, blank-separated."""
    line = _first_data_line(os.fspath(path))
    return line is not None and "," not in line and _numbers(line) == len(TUM_COLUMNS)


def _describe_tum(stream: LogStream, lay: Layout, names: list[str]) -> str:
    del lay, names
    return (
        "TUM trajectory: 'timestamp tx ty tz qx qy qz qw', quaternion qx,qy,qz,qw (scalar last), time in s"
        f"{_since(stream, 's')}, position not read"
    )


def open_tum(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The attitude of a TUM trajectory file (module docstring)."""
    fmt = TextFormat(header_rows=0, names=TUM_COLUMNS, comment=True, blanks=True, describe=_describe_tum)
    return open_text(os.fspath(path), options, fmt)


# ---------------------------------------------------------------------------------------------------- KITTI


def is_kitti(path: str | os.PathLike[str]) -> bool:
    """Whether a text file is a KITTI pose list: its first line holds 12 (or 13, with a time) numbers."""
    line = _first_data_line(os.fspath(path))
    return line is not None and "," not in line and _numbers(line) in (12, 13)


def _read_numbers(path: str, what: str) -> tuple[list[list[str]], list[int]]:
    """The blank-separated fields of every non-blank, non-comment line, and the line numbers."""
    try:
        with open(path, encoding="utf-8-sig", errors="strict") as f:
            text = f.read()
    except UnicodeDecodeError as exc:
        raise LogFormatError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise LogFormatError(f"{path}: cannot read the {what} ({exc.strerror})") from None
    rows, lines = [], []
    for i, line in enumerate(text.replace("\r\n", "\n").replace("\r", "\n").split("\n")):
        if line.strip() and not line.lstrip().startswith("#"):
            rows.append(line.split())
            lines.append(i + 1)
    return rows, lines


def _floats(rows: list[list[str]], lines: list[int], width: int, path: str) -> np.ndarray:
    out = np.empty((len(rows), width))
    for k, (row, line) in enumerate(zip(rows, lines, strict=True)):
        if len(row) != width:
            raise LogFormatError(f"{path}, line {line}: {len(row)} numbers, but the first line has {width}")
        for j, field in enumerate(row):
            try:
                out[k, j] = float(field)
            except ValueError:
                raise LogFormatError(
                    f"{path}, line {line}, number {j + 1}: {shown_value(field)} is not a number"
                ) from None
    return out


def _sibling_times(path: str) -> str:
    stem, _ = os.path.splitext(path)
    folder = os.path.dirname(path)
    for cand in (f"{stem}_times.txt", os.path.join(folder, "times.txt")):
        if os.path.isfile(cand):
            return f" ({os.path.basename(cand)} is beside it: --times {cand})"
    return ""


def open_kitti(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The attitude of a KITTI pose list, with times from ``--times``, ``--rate`` or a 13th (first) column."""
    path = os.fspath(path)
    rows, lines = _read_numbers(path, "poses")
    if not rows:
        raise LogFormatError(f"{path}: no poses")
    width = len(rows[0])
    data = _floats(rows, lines, width, path)
    has_time = width == 13
    if has_time and (options.rate is not None or options.times is not None):
        raise LogFormatError(f"{path}: the poses carry their times (13 numbers a line); leave --rate and --times out")
    if has_time:
        t, how = data[:, 0], "from the first of 13 numbers"
    elif options.times is not None and options.rate is not None:
        raise LogFormatError(f"{path}: give the times once: --times FILE or --rate HZ")
    elif options.times is not None:
        t_rows, t_lines = _read_numbers(options.times, "times")
        t = _floats(t_rows, t_lines, 1, options.times)[:, 0]
        if t.size != data.shape[0]:
            raise LogFormatError(f"{options.times}: {t.size} times for the {data.shape[0]} poses of {path}")
        how = f"from {os.path.basename(options.times)}"
    elif options.rate is not None:
        t, how = np.arange(data.shape[0]) / float(options.rate), f"frame / {options.rate:g} Hz"
    else:
        raise LogFormatError(
            f"{path}: a KITTI pose list has no times; give them with --times FILE (one time in s per line) or "
            f"--rate HZ{_sibling_times(path)}"
        )
    block = data[:, 1:] if has_time else data
    R = block.reshape(-1, 3, 4)[:, :, :3].copy()
    stream = LogStream.from_arrays(
        path,
        "matrix",
        np.ascontiguousarray(t, dtype=float),
        R,
        labels=np.asarray(lines),
        label="line",
        size=os.path.getsize(path),
        done=os.path.getsize(path),
        description=f"KITTI pose list: rotation = left 3x3 of each 3x4 [R|t] (row-major), time {how}, "
        f"{R.shape[0]} poses",
        time_name=None if not has_time else "t",
        attitude_name="r11..r33",
    )
    cols = [j + (1 if has_time else 0) for j in (0, 1, 2, 4, 5, 6, 8, 9, 10)]
    stream.digits = significant_digits(r[j] for r in rows[:200] for j in cols)
    return stream
