r"""Gyroscope logs for ``omegahat calibrate``: a time column and three rate columns, every error naming line and column.

**Text** (``.csv``, ``.txt``, ``.tsv``, any other name): the columns are separated by ``,`` ``;`` or tab (the most
frequent in the header), or by blanks where there is none of them (:func:`omegahat.io.textlines.delimiter`);
``header_rows`` lines name them (``2``: a group title over ``X, Y, Z``, names joined per column as for attitude
logs, :func:`omegahat.io.colmap.join_header_rows`; ``0``: no header, the columns named by their 1-based position).
A decimal comma is read where the delimiter is not ``,``. Blank lines are skipped, and so are comment lines above the
header (:func:`omegahat.io.textlines.comment_above_header`) and Excel's ``sep=,``; any other field that is not a
number is an error naming its line and column, and so is a row with more or fewer fields than the header names, or
with a carriage return inside it (a damaged row is never read in part).

**Columns**: ``time_column`` (default ``t``, or where the header has no ``t`` its one column named as a time,
:func:`omegahat.io.columns.time_column_by_name`; None: no times are read, ``t`` is the row's index from 0, for the
caller to scale by a rate) and the three rate columns ``columns`` by name (any case) or 1-based position; without
``columns``, the header's one group of :data:`GYRO_COLUMNS`, else its one triple of names ending in x, y, z whose
stem names a gyroscope (``IMU Gyroscope X``, ``gyr.x``...); the errors list what was found and suggest
``--gyro-columns``.

**NPZ**: arrays ``t`` and ``g (M, 3)``, or one array per rate column under the names above.

**PX4 ULog** (``.ulg``, recognised by its first bytes): a gyroscope topic, in seconds
(:func:`omegahat.io.px4.read_ulog_gyro`).

**Xsens exports** (MT Manager's and a DOT's, recognised by their header, :func:`omegahat.io.xsens.is_xsens`):
``Gyr_X..Z`` (rad/s in MT Manager's; a DOT's file states no unit, and a note says so) against the export's own
clock, ``SampleTimeFine`` or the packet counter at the stated rate, unwrapped (:func:`omegahat.io.xsens.export_clock`);
with ``--gyro-rate`` the packet counter at that rate.
"""

from __future__ import annotations

import os
import re
import shlex
import zipfile
from typing import NamedTuple

import numpy as np

from omegahat.io.colmap import join_header_rows
from omegahat.io.columns import LogFormatError, found_names, shown_value, time_column_by_name, time_or_capital_t
from omegahat.io.px4 import is_ulog, read_ulog_gyro
from omegahat.io.textlines import (
    comment_above_header,
    delimiter,
    excel_separator,
    is_number,
    refuse_inner_carriage_return,
    split_line,
    wrong_width,
)
from omegahat.io.timestamps import text_dates
from omegahat.io.xsens import export_clock, is_xsens

__all__ = [
    "GYROSCOPE",
    "GYRO_COLUMNS",
    "GyroLog",
    "VectorRole",
    "column_triple",
    "gyro_columns",
    "read_gyro",
    "read_vectors",
]

GYRO_COLUMNS = (
    ("gx", "gy", "gz"),
    ("g_x", "g_y", "g_z"),
    ("wx", "wy", "wz"),
    ("gyro_x", "gyro_y", "gyro_z"),
    ("gyr_x", "gyr_y", "gyr_z"),
    ("gyrox", "gyroy", "gyroz"),
    ("omega_x", "omega_y", "omega_z"),
    ("angular_velocity_x", "angular_velocity_y", "angular_velocity_z"),
)  #: the gyroscope's rate columns recognised by name (one group of them in a header; others: --gyro-columns)


class VectorRole(NamedTuple):
    """What a log of three columns holds, for the column search and the messages: ``noun`` ("gyroscope"),
    ``flag`` (the options' prefix, ``--gyro``), ``groups`` (column names recognised), ``stem`` (a regular expression
    the stem of the one triple ``stem·x, stem·y, stem·z`` must match to be taken without a group's names),
    ``what`` (the three columns' word in messages: "rate") and ``time_option`` (whether ``{flag}-time-column``
    exists; where not, a time column is named by its header)."""

    noun: str
    flag: str
    groups: tuple[tuple[str, str, str], ...]
    stem: str
    what: str
    time_option: bool = True


GYROSCOPE = VectorRole("gyroscope", "--gyro", GYRO_COLUMNS, "gyr", "rate")
#: the stems of x, y, z columns that are another sensor's (accelerations, fields, positions, velocities, angles)
OTHER_SENSORS = r"a|acc\w*|m|mag\w*|p|pos\w*|v|vel\w*|lin\w*|euler\w*|angle\w*|rot\w*|q|quat\w*"
#: where a log's time column is named by its header alone (no option names it)
TIME_NAMES_TIP = "; name its time column t, time or timestamp, with its unit where not s (time_ms, timestamp_ns)"


class GyroLog(NamedTuple):
    """What :func:`read_gyro` read: ``t (M,)`` as written, ``g (M, 3)``, and the columns' names as the file gives
    them (time, x, y, z); ``own_unit``: empty where ``t`` is as written (its unit the caller's), else what says how
    the reader turned the log's own times into seconds (ISO 8601 dates, :func:`omegahat.io.timestamps.text_dates`;
    a PX4 ULog's microseconds, :func:`omegahat.io.px4.read_ulog_gyro`); ``note``: what the file could not say and
    the caller must (an Xsens DOT's rate unit)."""

    t: np.ndarray
    g: np.ndarray
    names: tuple[str, str, str, str]
    own_unit: str = ""
    note: str = ""


def column_triple(text: str | None, role: VectorRole = GYROSCOPE) -> tuple[str, str, str] | None:
    """The three columns ``X,Y,Z`` (names or 1-based positions) an option such as ``--gyro-columns`` names (the
    role's flag), or None where it is not given; anything but three names is refused."""
    if text is None:
        return None
    names = [c.strip() for c in text.split(",")]
    if len(names) != 3 or not all(names):
        raise ValueError(f"{role.flag}-columns names 3 columns x,y,z; got {text!r}")
    return names[0], names[1], names[2]


def _triples(names: list[str]) -> list[tuple[str, str, str]]:
    """Every triple ``stem·x, stem·y, stem·z`` among ``names`` (the separator ``·`` empty, ``_ . - `` or a blank)."""
    stems = {m.group(1) for n in names if (m := re.fullmatch(r"(.+?)[_.\s-]?x", n))}
    return [
        (f"{p}{sep}x", f"{p}{sep}y", f"{p}{sep}z")
        for p in sorted(stems)
        for sep in ("", "_", ".", " ", "-")
        if all(f"{p}{sep}{a}" in names for a in "xyz")
    ]


def gyro_columns(names: list[str], where: str, role: VectorRole = GYROSCOPE) -> tuple[str, str, str]:
    """The ``role``'s three columns among ``names`` (lower case; module docstring), or an error that names what was
    found and suggests ``--gyro-columns`` (the role's flag) where three columns end in x, y, z."""
    found = [g for g in role.groups if all(c in names for c in g)]
    if len(found) == 1:
        return found[0]
    flag = f"{role.flag}-columns X,Y,Z"
    if found:
        groups = " and ".join(",".join(g) for g in found)
        raise LogFormatError(f"{where}: several {role.noun} columns ({groups}); name one with {flag}")
    triples = _triples(names)
    taken = [t for t in triples if re.search(role.stem, t[0])]
    if len(taken) == 1:
        return taken[0]
    others = [t for t in triples if re.fullmatch(OTHER_SENSORS, t[0][:-1].rstrip("_.- "))]  # ax,ay,az: no tip
    tip = (
        f" (perhaps {role.flag}-columns {shlex.quote(','.join(triples[0]))})"
        if len(triples) == 1 and not others
        else ""
    )
    raise LogFormatError(
        f"{where}: no {role.noun} columns (found: {found_names(names)}); expected one of "
        f"{'; '.join(','.join(g) for g in role.groups)}: name them with {flag}{tip}"
    )


def _index(name: str, names: list[str], path: str, what: str, role: VectorRole) -> int:
    """The column ``name`` (any case) or 1-based position among ``names``."""
    key = name.strip().lower()
    if key in names:
        return names.index(key)
    if key.isdigit() and 1 <= int(key) <= len(names):
        return int(key) - 1
    if what == "time" and not role.time_option:
        raise LogFormatError(f"{path}: no column {name!r} (found: {found_names(names)}){TIME_NAMES_TIP}")
    raise LogFormatError(
        f"{path}: no column {name!r} (found: {found_names(names)}); name the {role.noun} log's {what} with "
        + f"{role.flag}-{'time-column' if what == 'time' else 'columns'} (a name or a 1-based position)"
        + ("; a log without times: --gyro-rate HZ (row k at k / HZ)" if what == "time" and role is GYROSCOPE else "")
    )


def read_gyro(
    path: str | os.PathLike[str],
    columns: tuple[str, str, str] | None = None,
    time_column: str | None = "t",
    header_rows: int = 1,
    topic: str | None = None,
) -> GyroLog:
    """A gyroscope log (module docstring): ``t`` as written (its unit is the caller's, unless ``own_unit`` says
    otherwise) and ``g (M, 3)``; ``topic`` chooses a PX4 ULog's gyroscope topic."""
    path = os.fspath(path)
    if path.lower().endswith(".npz"):
        return _read_npz(path, time_column, columns)
    if is_ulog(path):
        return GyroLog(*read_ulog_gyro(path, topic))
    if is_xsens(path):
        return _read_xsens(path, columns, counted=time_column is None)
    return read_vectors(path, GYROSCOPE, columns, time_column, header_rows)


def _read_xsens(path: str, columns: tuple[str, str, str] | None, counted: bool) -> GyroLog:
    """An Xsens export as a gyroscope log: ``Gyr_X..Z`` (rad/s; or ``columns``) against the export's own
    clock (:func:`omegahat.io.xsens.export_clock`) in seconds; with ``counted`` (a rate given, ``--gyro-rate``) the
    packet counter unwrapped, for the caller to divide by the rate, so that dropped packets keep their places."""
    clock = export_clock(path, 1.0 if counted else None)  # rate 1: the counts themselves
    log = read_vectors(path, GYROSCOPE, columns, clock.column, skip_lines=clock.header_line - 1)
    unsure = "Gyr_X..Z in the unit --gyro-unit gives (a DOT's file does not state it)" if clock.dot else ""
    return log._replace(t=clock.seconds(log.t), own_unit="" if counted else f"s, from {clock.said}", note=unsure)


def read_vectors(
    path: str,
    role: VectorRole,
    columns: tuple[str, str, str] | None = None,
    time_column: str | None = "t",
    header_rows: int = 1,
    skip_lines: int = 0,
) -> GyroLog:
    """A text log of a time column and three columns (module docstring, **Text** and **Columns**, with ``role``'s
    names and flags): ``t`` as written, unless ``own_unit`` says otherwise, and the three columns ``(M, 3)``;
    the first ``skip_lines`` lines (an Xsens export's preamble) are left out, the others' numbers kept."""
    if header_rows < 0:
        raise ValueError(f"{role.flag}-header-rows is 0 or more; got {header_rows}")
    try:
        with open(path, encoding="utf-8-sig", newline="") as f:
            text = f.read()
    except UnicodeDecodeError as exc:
        raise LogFormatError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    lines = [(k + 1, line.rstrip("\r")) for k, line in enumerate(text.split("\n")) if line.strip() and k >= skip_lines]
    above = 0  # lines above the header that are not part of it: Excel's delimiter hint, then comments
    if header_rows and lines and excel_separator(lines[0][1]):
        above = 1
    while (
        header_rows
        and above < len(lines)
        and comment_above_header(lines[above][1], [x for _, x in lines[above + 1 : above + 9]])
    ):
        above += 1  # '# recorded with ...' above the header
    lines = lines[above:]  # one copy, whatever the number of comments
    if len(lines) <= header_rows:
        raise LogFormatError(f"{path}: {len(lines)} non-blank line(s), expected {header_rows} of header and rows")
    head, body = lines[:header_rows], lines[header_rows:]
    first = head[0] if head else body[0]
    delim = delimiter(first[1], f"{path}, line {first[0]}", allow_blanks=True)
    if head:
        rows = [split_line(h, delim, f"{path}, line {k}") for k, h in head]
        written = rows[0] if header_rows == 1 else join_header_rows(rows)
        flag = f"{role.flag}-time-column" if role.time_option else None
        if time_column is not None and (ask := time_or_capital_t(written, time_column, flag)):
            raise LogFormatError(f"{path}, line {head[0][0]}: {ask}{'' if flag else TIME_NAMES_TIP}")
        names = [n.strip().lower() for n in written]
    else:
        names = [str(j + 1) for j in range(len(split_line(first[1], delim, f"{path}, line {first[0]}")))]
    if head and all(is_number(n) for n in names):
        raise LogFormatError(
            f"{path}, line {head[0][0]}: numbers where the header should name the columns ({', '.join(names[:4])}"
            f"{', ...' if len(names) > 4 else ''}): a file without a header is read with {role.flag}-header-rows 0 "
            f"and the columns by position ({role.flag}-time-column 1 {role.flag}-columns 2,3,4"
            + (", or --gyro-rate HZ without times)" if role is GYROSCOPE else ")")
        )
    rate = gyro_columns(names, path, role) if columns is None else columns
    idx = [_index(c, names, path, role.what, role) for c in rate]
    if time_column is not None:
        named = time_column_by_name(names, time_column)[0] if head else time_column  # no column t: one named so
        idx.insert(0, _index(named, names, path, "time", role))  # (the caller prints the name read)
    comma = delim != ","  # a decimal comma: only where the comma does not separate the columns
    out = np.empty((len(body), 4))
    out[:, 0] = np.arange(len(body))  # the row's index, where no time column is read
    rows = []
    for line, row in body:  # every row as wide as the header: a row that is not is damaged, never read in part
        refuse_inner_carriage_return(row, f"{path}, line {line}")
        rows.append(split_line(row, delim, f"{path}, line {line}"))
        if len(rows[-1]) != len(names):
            raise wrong_width(f"{path}, line {line}", len(rows[-1]), len(names), delim, head[-1][0] if head else 0)
    dates = None
    if time_column is not None:  # ISO 8601 dates: seconds since 1970 (the attitude reader's rule)
        texts = [fields[idx[0]] if idx[0] < len(fields) else None for fields in rows]
        dates = text_dates(texts, lambda k: f"{path}, line {body[k][0]}, column {names[idx[0]]}")
        if dates is not None:
            out[:, 0] = dates[0] * 1e-9
    numbers = list(enumerate(idx, start=4 - len(idx)))[(dates is not None) :]  # (out's column, the file's)
    for r, (line, _) in enumerate(body):
        fields = rows[r]
        for c, i in numbers:
            field = fields[i].strip() if i < len(fields) else ""
            try:
                out[r, c] = float(field.replace(",", ".") if comma else field)
            except ValueError:
                shown = shown_value(field) if i < len(fields) else "nothing"
                raise LogFormatError(f"{path}, line {line}, column {names[i]}: {shown} is not a number") from None
    x, y, z = (names[i] for i in idx[-3:])
    time_name = names[idx[0]] if time_column is not None else "row"
    return GyroLog(out[:, 0], out[:, 1:], (time_name, x, y, z), "" if dates is None else dates[1])


def _read_npz(path: str, time_column: str | None, columns: tuple[str, str, str] | None) -> GyroLog:
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k.lower(): np.asarray(z[k], dtype=float) for k in z.files}
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as exc:
        raise LogFormatError(f"{path}: not a readable .npz file of numbers ({exc})") from None
    time_name = "row" if time_column is None else time_column.lower()
    if time_column is not None and time_name not in arrays:
        raise LogFormatError(f"{path}: no array {time_name!r} (found: {found_names(arrays)})")
    if columns is None and "g" in arrays:
        g, rate = arrays["g"], ("g[:, 0]", "g[:, 1]", "g[:, 2]")
    else:
        x, y, z = gyro_columns(list(arrays), path) if columns is None else columns
        rate = (x.lower(), y.lower(), z.lower())
        if not all(c in arrays for c in rate):
            raise LogFormatError(f"{path}: no arrays {', '.join(rate)} (found: {found_names(arrays)})")
        g = np.column_stack([arrays[c].ravel() for c in rate])
    t = np.arange(len(g), dtype=float) if time_column is None else arrays[time_name].ravel()
    if g.shape != (t.size, 3):
        raise LogFormatError(f"{path}: the gyro must be ({t.size}, 3), one row per time; got {g.shape}")
    return GyroLog(t, g, (time_name, rate[0], rate[1], rate[2]))
