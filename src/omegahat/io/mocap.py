r"""Motion-capture CSV exports: OptiTrack Motive and Vicon Nexus / Tracker, recognised from their headers.

**OptiTrack Motive** (CSV export; every layout in use). The file starts with a line of ``key,value`` pairs
(``Format Version,1.23,Take Name,...,Rotation Type,Quaternion,...``) and a blank line; then rows of each column's
kind (``Rigid Body``, ``Rigid Body Marker``, ``Marker``, ``Bone``), name and ID — labelled ``,Type,``, ``,Name,``,
``,ID,`` from format 1.23 on (Motive 2 and 3), without labels (``,,Rigid Body,...``) in format 1.21 and earlier —,
a row of components (``Rotation``, ``Position``, ``Mean Marker Error``), and the row of axis labels that starts
``Frame,Time`` (``Time (Seconds)`` from 1.23 on). With ``Rotation Type`` ``Quaternion`` a rigid body's rotation is
``X, Y, Z, W`` (scalar **last**); with an Euler order (``XYZ``, ``XZY``, ``YXZ``, ``YZX``, ``ZXY``, ``ZYX``) it is
the angles ``X, Y, Z`` in degrees, composed in the stated order about the rotating axes (``XYZ``:
``R = Rx(X) Ry(Y) Rz(Z)``, as NaturalPoint's NatNet samples compose them), each column the angle about its axis.
Either rotates the rigid body's local axes into Motive's global axes (body → inertial, as omegahat's ``R``), so the
rate comes out in the rigid body's own axes whatever Motive's up axis is. Time is the ``Time`` column; an empty
rotation (body not tracked in that frame) is a missing sample.

**Vicon** (Nexus "Segments" export and Tracker's object export). Sections start with a title line
(``Segments``, ``Objects``, ``Trajectories``, ``Model Outputs``, ...), the rate in Hz, a row of object names
(``Subject:Segment``; Tracker may write ``Global Angle Name``), a row of labels ``Frame,Sub Frame,RX,RY,RZ,TX,
TY,TZ,...`` and a row of units (``deg`` or ``rad``, ``mm``); a blank line ends the section. ``RX, RY, RZ`` are
Vicon's *helical* angles: the rotation vector (axis times angle) of the segment's rotation into the global frame,
converted with the exponential map ((V1) of :mod:`omegahat.io.rotvec`); its wrap-around at 180° changes the vector,
not the rotation, so it causes no spike. Time is ``Frame / rate`` (frame numbers may skip: dropped frames). A file
with marker trajectories only is refused with a message saying which export holds rotations.

**Selection.** ``ReadOptions.body`` (``--body``) names the rigid body (Motive) or object/segment (Vicon); with a
single one it may be omitted, with several the error lists them. Detection looks only at the first lines
(:func:`is_motive`, :func:`is_vicon`, the sniffers registered for ``.csv`` in :mod:`omegahat.io`): ``Format
Version`` first → Motive (whatever the layout below it); a one-word title line, a number, then a ``Frame,Sub Frame``
row → Vicon; anything else is omegahat's own CSV (:mod:`omegahat.io.csvlog`) or another ``.csv`` format. Every error
names the file, the line and the column. The openers return a :class:`~omegahat.io.registry.LogStream` labelled by
line, so the timestamp policy (:mod:`omegahat.io.timestamps`: rows in time order; exact duplicates dropped;
conflicts refused) names lines too. These exports are read whole with Python's :mod:`csv` (a take of minutes at a
few hundred Hz is a few MB).
"""

from __future__ import annotations

import csv
import os

import numpy as np

from omegahat.io.columns import LogFormatError, shown_value
from omegahat.io.euler import matrices as euler_matrices
from omegahat.io.precision import significant_digits
from omegahat.io.registry import LogStream, ReadOptions
from omegahat.io.rotvec import matrices as rotvec_matrices
from omegahat.io.textlines import is_number

__all__ = ["choose_body", "is_motive", "is_vicon", "open_motive_csv", "open_vicon_csv"]

_SNIFF_LINES = 12


def _rows(path: str) -> list[list[str]]:
    """Every line's fields (row ``i`` is line ``i + 1``), each line parsed on its own: a stray quote cannot fold the
    lines after it into one field (:mod:`omegahat.io.csvparse`)."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            text = f.read()
    except UnicodeDecodeError as exc:
        raise LogFormatError(f"{path}: not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    rows = []
    for i, line in enumerate(text.replace("\r\n", "\n").replace("\r", "\n").split("\n")):
        if line.count('"') % 2:  # a quote that opens a field and never closes it would swallow the line's rest
            raise LogFormatError(
                f"{path}, line {i + 1}: an unbalanced quote ('\"'); the fields after it cannot be read"
            )
        try:
            rows.append([field.strip() for field in next(csv.reader([line]), [])])
        except csv.Error as exc:  # a field beyond csv.field_size_limit()
            raise LogFormatError(f"{path}, line {i + 1}: {exc} (the limit for one field)") from None
    while rows and not rows[-1]:
        rows.pop()
    return rows


def _head(path: str) -> list[list[str]]:
    head: list[list[str]] = []
    try:
        with open(path, newline="", encoding="utf-8-sig", errors="replace") as f:
            for row in csv.reader(f):
                head.append([x.strip() for x in row])
                if len(head) >= _SNIFF_LINES:
                    break
    except (OSError, csv.Error):
        return []  # the plain CSV reader reports the problem
    return head


def is_motive(path: str | os.PathLike[str]) -> bool:
    """Whether a CSV file is a Motive export: its first field is ``Format Version``."""
    head = _head(os.fspath(path))
    return bool(head and head[0] and head[0][0] == "Format Version")


def _vicon_title(rows: list[list[str]], i: int) -> bool:
    """Whether a Vicon section starts at row ``i``: a one-word title, a rate, names, then ``Frame,Sub Frame``."""
    title = [x for x in rows[i] if x]
    return (
        len(title) == 1
        and not is_number(title[0], decimal_comma=False)
        and bool(rows[i + 1][:1])
        and is_number(rows[i + 1][0], decimal_comma=False)
        and rows[i + 3][:2] == ["Frame", "Sub Frame"]
    )


def is_vicon(path: str | os.PathLike[str]) -> bool:
    """Whether a CSV file is a Vicon export: a section title, a rate, names, then ``Frame,Sub Frame``."""
    head = _head(os.fspath(path))
    return any(_vicon_title(head, i) for i in range(len(head) - 3))


def _number(field: str, path: str, line: int, column: str) -> float:
    try:
        return float(field)
    except ValueError:
        raise LogFormatError(f"{path}, line {line}, column {column}: {shown_value(field)} is not a number") from None


def choose_body(names: list[str], body: str | None, path: str, what: str, plural: str) -> str:
    """The name in ``names`` that ``body`` selects (exact, else ignoring case; optional when there is one name);
    the errors list the names."""
    if not names:
        raise LogFormatError(f"{path}: no {what} with a rotation found")
    if body is None:
        if len(names) > 1:
            raise LogFormatError(
                f"{path}: {len(names)} {plural} with rotations ({', '.join(names)}); choose one with --body NAME "
                "(body= in Python)"
            )
        return names[0]
    if body in names:
        return body
    folded = [n for n in names if n.casefold() == body.casefold()]
    if len(folded) == 1:
        return folded[0]
    raise LogFormatError(f"{path}: no {what} named {body!r}; the file has {', '.join(names)}")


# ---------------------------------------------------------------------------------------------------- Motive


_EULER_ORDERS = ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX")
_HEADER_KEYS = ("Type", "Name", "ID")


def _motive_header(rows: list[list[str]], i_axes: int, path: str) -> dict[str, list[str]]:
    """The kinds, names and IDs rows above the component row: labelled (``,Type,...``: Motive 1.23 and later) or,
    without labels (Motive 1.21 and earlier), the non-blank rows between the metadata and the component row, in
    that order."""
    labelled = {r[1]: r for r in rows[1 : i_axes - 1] if len(r) > 1 and r[1] in _HEADER_KEYS}
    if labelled:
        found = labelled
    else:
        block = [r for r in rows[1 : i_axes - 1] if any(r)]
        found = dict(zip(_HEADER_KEYS, block[-3:] if len(block) >= 3 else block, strict=False))
    for key in ("Type", "Name"):
        if key not in found:
            raise LogFormatError(
                f"{path}: no row of {'kinds (Rigid Body, Marker, ...)' if key == 'Type' else 'names'} above line "
                f"{i_axes} (a Motive export has rows of kinds, names and IDs above the X,Y,Z labels)"
            )
    return found


def _rotation_columns(rows, header, i_axes, axes_wanted) -> tuple[dict[str, dict[str, int]], list[str]]:
    types, names = header["Type"], header["Name"]
    comp, axes = rows[i_axes - 1], rows[i_axes]

    def cell(row, j):
        return row[j] if j < len(row) else ""

    bodies: dict[str, dict[str, int]] = {}
    for j in range(len(axes)):
        if cell(types, j) in ("Rigid Body", "Bone") and cell(comp, j) == "Rotation" and cell(axes, j) in axes_wanted:
            bodies.setdefault(cell(names, j), {})[cell(axes, j)] = j
    kinds = sorted({cell(types, j) for j in range(2, len(axes))} - {""})
    return {n: c for n, c in bodies.items() if set(c) == set(axes_wanted)}, kinds


def open_motive_csv(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One rigid body's attitude from an OptiTrack Motive CSV export (module docstring)."""
    path = os.fspath(path)
    rows = _rows(path)
    meta_row = rows[0] if rows else []
    if not meta_row or meta_row[0] != "Format Version":
        raise LogFormatError(f"{path}, line 1: not a Motive export (it starts {','.join(meta_row[:2])!r})")
    meta = {meta_row[i]: meta_row[i + 1] for i in range(0, len(meta_row) - 1, 2) if meta_row[i]}
    version = meta.get("Format Version", "?")
    rotation_type = meta.get("Rotation Type", "Quaternion").strip()
    euler = rotation_type.upper() if rotation_type.upper() in _EULER_ORDERS else None
    if euler is None and rotation_type.casefold() != "quaternion":
        raise LogFormatError(
            f"{path}, line 1: Rotation Type {rotation_type!r} is neither Quaternion nor an Euler order "
            f"({', '.join(_EULER_ORDERS)}); export the take again with Rotation Type = Quaternion"
        )
    try:
        i_axes = next(i for i, r in enumerate(rows) if r[:1] == ["Frame"])
    except StopIteration:
        raise LogFormatError(f"{path}: no header row starting 'Frame' (the row of X,Y,Z,W labels)") from None
    header = _motive_header(rows, i_axes, path)
    axes = rows[i_axes]
    time_col = next((j for j, a in enumerate(axes) if a.startswith("Time")), None)
    if time_col is None:
        raise LogFormatError(f"{path}, line {i_axes + 1}: no 'Time' column")
    wanted = "XYZ" if euler else "XYZW"
    complete, kinds = _rotation_columns(rows, header, i_axes, wanted)
    if not complete:
        raise LogFormatError(
            f"{path}: no rigid body with {'Euler angle' if euler else 'quaternion'} columns {','.join(wanted)} "
            f"(column types found: {', '.join(kinds) or 'none'}); omegahat needs rigid-body rotations: define a "
            "rigid body in Motive and export it"
        )
    name = choose_body(list(complete), options.body, path, "rigid body", "rigid bodies")
    if euler and _rotation_columns(rows, header, i_axes, "XYZW")[0].get(name):
        raise LogFormatError(
            f"{path}, line {i_axes + 1}: Rotation Type is {rotation_type!r} (Euler angles X,Y,Z) but rigid body "
            f"{name!r} has rotation columns X,Y,Z,W (a quaternion): the file contradicts itself; export it again"
        )
    cols = [complete[name][a] for a in wanted]
    ids = header.get("ID", [])
    body_id = ids[cols[0]] if cols[0] < len(ids) else ""
    times, values, lines = [], [], []
    texts: list[str] = []
    for i in range(i_axes + 1, len(rows)):
        row = rows[i]
        if not any(row):
            continue
        line = i + 1
        t_field = row[time_col] if time_col < len(row) else ""
        if not t_field:
            raise LogFormatError(f"{path}, line {line}, column {axes[time_col]}: empty time")
        times.append(_number(t_field, path, line, axes[time_col]))
        fields = [row[j] if j < len(row) else "" for j in cols]
        if any(not f for f in fields):
            values.append([np.nan] * len(wanted))
        else:
            values.append([_number(f, path, line, f"{name} Rotation {a}") for f, a in zip(fields, wanted, strict=True)])
            if len(texts) < 800:
                texts += fields
        lines.append(line)
    if not times:
        raise LogFormatError(f"{path}: no data rows after the header (line {i_axes + 1})")
    if euler:
        data = euler_matrices(np.array(values), euler, degrees=True)  # values: the angles about X, Y, Z
        kind = "matrix"
        product = "·".join("R" + a.lower() for a in euler)
        what = f"Euler angles X,Y,Z in degrees, order {euler} about the rotating axes (R = {product})"
    else:
        data, kind, what = np.array(values), "quaternion", "quaternions X,Y,Z,W (scalar last)"
    layout_note = "" if "Type" in {r[1] for r in rows[1:i_axes] if len(r) > 1} else ", header rows without labels"
    description = (
        f"OptiTrack Motive CSV (format {version}{layout_note}): rigid body {name!r}"
        + (f" (ID {body_id})" if body_id else "")
        + f", {what}, time from column {axes[time_col]!r}, {len(times)} frames"
        + (
            f" at {float(meta['Export Frame Rate']):g} Hz"
            if is_number(meta.get("Export Frame Rate", ""), decimal_comma=False)
            else ""
        )
    )
    notes = (
        [f"other rigid bodies in the file: {', '.join(n for n in complete if n != name)}"] if len(complete) > 1 else []
    )
    stream = _stream(path, kind, times, data, lines, description, notes, axes[time_col], f"{name} Rotation")
    stream.digits = None if euler else significant_digits(texts)
    return stream


def _stream(path, kind, times, data, lines, description, notes, time_name, attitude_name) -> LogStream:
    size = os.path.getsize(path)
    return LogStream.from_arrays(
        path,
        kind,
        np.asarray(times, dtype=float),
        np.asarray(data, dtype=float),
        labels=np.asarray(lines),
        label="line",
        size=size,
        done=size,
        description=description,
        notes=notes,
        time_name=time_name,
        attitude_name=attitude_name,
    )


# ---------------------------------------------------------------------------------------------------- Vicon


def _vicon_sections(rows: list[list[str]], path: str) -> list[dict]:
    """Every section: title, rate, its header rows' indices and its data rows' range."""
    sections = []
    i = 0
    while i < len(rows) - 4:
        if _vicon_title(rows, i):
            title = [x for x in rows[i] if x]
            start = i + 5
            end = start
            while end < len(rows) and any(rows[end]):
                end += 1
            sections.append(
                {
                    "title": title[0],
                    "rate": float(rows[i + 1][0]),
                    "names": i + 2,
                    "labels": i + 3,
                    "data": (start, end),
                }
            )
            i = end
        else:
            i += 1
    return sections


def _vicon_objects(rows, sec) -> dict[str, dict[str, int]]:
    names, labels = rows[sec["names"]], rows[sec["labels"]]
    objects: dict[str, dict[str, int]] = {}
    current = None
    for j in range(2, len(labels)):
        if j < len(names) and names[j]:
            current = names[j].removeprefix("Global Angle ").strip()
        if current is not None and labels[j]:
            objects.setdefault(current, {})[labels[j]] = j
    return objects


def open_vicon_csv(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """One object's or segment's attitude from a Vicon Nexus or Tracker CSV export (module docstring)."""
    path = os.fspath(path)
    body = options.body
    rows = _rows(path)
    sections = _vicon_sections(rows, path)
    if not sections:
        raise LogFormatError(f"{path}: not a Vicon CSV export (no section title, rate and 'Frame,Sub Frame' rows)")
    candidates = []  # (section, object name, columns)
    for sec in sections:
        for obj, cols in _vicon_objects(rows, sec).items():
            if {"RX", "RY", "RZ"} <= set(cols):
                candidates.append((sec, obj, cols))
    if not candidates:
        titles = ", ".join(s["title"] for s in sections)
        raise LogFormatError(
            f"{path}: this Vicon export has no rotations (sections: {titles}); omegahat needs each body's "
            "rotation: export the 'Segments' section from Nexus (a subject with segments), or the objects' "
            "rotations from Tracker"
        )
    name = choose_body([c[1] for c in candidates], body, path, "object/segment", "objects/segments")
    sec, _, cols = next(c for c in candidates if c[1] == name)
    units_row = rows[sec["labels"] + 1]
    unit = units_row[cols["RX"]] if cols["RX"] < len(units_row) else ""
    scale = {"deg": np.pi / 180.0, "rad": 1.0}.get(unit.casefold())
    if scale is None:
        raise LogFormatError(
            f"{path}, line {sec['labels'] + 2}, column {name} RX: unit {unit!r}; expected 'deg' or 'rad'"
        )
    rate = sec["rate"]
    if not rate > 0:
        raise LogFormatError(f"{path}, line {sec['labels'] - 1}: rate {rate!r} Hz is not positive")
    frames, vecs, lines = [], [], []
    start, end = sec["data"]
    for i in range(start, end):
        row = rows[i]
        line = i + 1
        frame = _number(row[0] if row else "", path, line, "Frame")
        sub = _number(row[1], path, line, "Sub Frame") if len(row) > 1 and row[1] else 0.0
        if sub != 0:
            raise LogFormatError(
                f"{path}, line {line}, column Sub Frame: {row[1]!r}; a {sec['title']} section has one row per frame"
            )
        fields = [row[cols[a]] if cols[a] < len(row) else "" for a in ("RX", "RY", "RZ")]
        if any(not f for f in fields):
            vecs.append([np.nan] * 3)
        else:
            vecs.append(
                [_number(f, path, line, f"{name} {a}") for f, a in zip(fields, ("RX", "RY", "RZ"), strict=True)]
            )
        frames.append(frame)
        lines.append(line)
    if not frames:
        raise LogFormatError(f"{path}, line {start}: the {sec['title']} section has no data rows")
    frame_numbers = np.array(frames)
    R = rotvec_matrices(np.array(vecs).reshape(-1, 3) * scale)  # (V1); a missing sample stays NaN
    description = (
        f"Vicon CSV, section {sec['title']!r} at {rate:g} Hz: {name!r}, helical angles RX,RY,RZ in {unit} "
        f"(rotation vector into the global frame), time = Frame / {rate:g}, {frame_numbers.size} frames"
    )
    return _stream(path, "matrix", frame_numbers / rate, R, lines, description, [], None, f"{name} RX,RY,RZ")
