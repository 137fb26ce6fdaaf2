r"""The column map: which column of a file holds what, when its names are not omegahat's.

``--columns t=NAME,qw=NAME,qx=NAME,qy=NAME,qz=NAME`` (``columns=`` in :func:`omegahat.io.read_log` and
:func:`omegahat.estimate_frame`) names, for each of omegahat's quantities (the keys of :mod:`omegahat.io.columns`:
``t``, ``qw qx qy qz``, ``r11 … r33``, ``b1x b1y b1z …``, ``roll pitch yaw``, ``tau_x tau_y tau_z``), the column
holding it:

* by **name**, compared as :func:`omegahat.io.columns.normalise_name` compares names (case and surrounding blanks
  ignored), after the header rows are joined (below);
* or by **position**, 1-based: ``--columns t=1,qw=2,qx=3,qy=4,qz=5``. On the command line a value made of digits
  only is a position; in Python an ``int`` is a position and a ``str`` a name.

The mapped columns are read under their keys; every other column keeps its own name, except that a column whose
own name is one of the keys of a group the map assigns (a ``t`` column when ``t=`` is mapped; ``qw`` when the
attitude is mapped) is ignored, so that the map decides. A key not in the map is found by its name as usual (a file
with a ``t`` column needs only the attitude mapped).

**Headers that span rows** (``--header-rows N``, ``header_rows=``): the N rows are joined per column, the upper
rows' cells carried to the right over empty cells (spreadsheet programs write a group title once over the columns it
spans, as merged cells), the parts joined with a space. ``Time (s);Vicon Orientation;;;`` over ``;W;X;Y;Z`` gives
``Time (s)``, ``Vicon Orientation W``, ``Vicon Orientation X`` ... ``--header-rows 0``: no header; the columns are
named ``1``, ``2``, ... and read by position.

Errors list the columns found and print the ``--columns`` line that would read the file
(:func:`suggest_columns`), or a template to fill in.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

from omegahat.io.columns import (
    EULER_COLUMNS,
    MATRIX_COLUMNS,
    QUATERNION_COLUMNS,
    ROTVEC_COLUMNS,
    TORQUE_COLUMNS,
    LogFormatError,
    attitude_groups,
    found_names,
    normalise_name,
    time_column_by_name,
)

__all__ = [
    "COLUMNS_TEMPLATE",
    "ColumnMap",
    "apply_columns",
    "columns_line",
    "frame_names",
    "join_header_rows",
    "named_quaternion",
    "named_quaternion_note",
    "parse_columns",
    "suggest_columns",
]

ColumnMap = tuple[tuple[str, "str | int"], ...]  #: parsed map: (key, column name or 1-based position), in order
_DIRECTION_KEY = re.compile(r"b[1-9]\d*[xyz]")
_GROUPS = {
    "time": ("t",),
    "quaternion": QUATERNION_COLUMNS,
    "matrix": MATRIX_COLUMNS,
    "euler": EULER_COLUMNS,
    "rotvec": ROTVEC_COLUMNS,
    "torque": TORQUE_COLUMNS,
}
#: what :func:`suggest_columns` prints where the names suggest no reading
COLUMNS_TEMPLATE = "--columns t=NAME,qw=NAME,qx=NAME,qy=NAME,qz=NAME (or by position: t=1,qw=2,qx=3,qy=4,qz=5)"


def _group(key: str) -> str:
    for g, keys in _GROUPS.items():
        if key in keys:
            return "attitude" if g in ("quaternion", "matrix", "euler", "rotvec") else g
    return "attitude" if _DIRECTION_KEY.fullmatch(key) else ""


def parse_columns(spec: str | Mapping[str, str | int] | Sequence | None) -> ColumnMap | None:
    """The column map of ``spec``: ``"t=Time,qw=2,..."`` (the command line's form: digits are a position), a mapping
    ``{"t": "Time", "qw": 2}`` (an ``int`` is a position) or an already parsed map; None for None. Raises
    ``ValueError`` for an unknown key, a key given twice, a position below 1 or a part without ``=``."""
    if spec is None:
        return None
    pairs: list[tuple[str, str | int]] = []
    if isinstance(spec, str):
        for part in spec.split(","):
            if not part.strip():
                continue
            name, eq, text = part.partition("=")
            if not eq:
                raise ValueError(f'--columns: {part.strip()!r} is not KEY=COLUMN (e.g. qw=2 or qw="Orientation W")')
            text = text.strip().strip('"').strip("'")
            pairs.append((name, int(text) if text.isdigit() else text))
    else:
        items: Sequence = list(spec.items()) if isinstance(spec, Mapping) else spec
        for name, given in items:
            if isinstance(given, bool) or not isinstance(given, int | str):
                raise ValueError(
                    f"columns: {name}= takes a column name (str) or a 1-based position (int); got {given!r}"
                )
            pairs.append((str(name), given))
    out: dict[str, str | int] = {}
    for key, value in pairs:
        k = normalise_name(key)
        if not _group(k):
            raise ValueError(
                f"columns: unknown key {key!r}; the keys are t, qw, qx, qy, qz, r11..r33, b1x, b1y, b1z, b2x, ..., "
                "roll, pitch, yaw, tau_x, tau_y, tau_z"
            )
        if k in out:
            raise ValueError(f"columns: {k} given twice")
        if isinstance(value, int) and value < 1:
            raise ValueError(f"columns: {k}={value}: positions count from 1")
        if isinstance(value, str) and not value.strip():
            raise ValueError(f"columns: {k}= names no column")
        out[k] = value
    if not out:
        raise ValueError("columns: empty map; give KEY=COLUMN pairs, e.g. t=1,qw=2,qx=3,qy=4,qz=5")
    return tuple(out.items())


def join_header_rows(rows: Sequence[Sequence[str]]) -> list[str]:
    """One name per column from header rows (module docstring): upper rows carried right over empty cells."""
    width = max((len(r) for r in rows), default=0)
    parts: list[list[str]] = [[] for _ in range(width)]
    for i, row in enumerate(rows):
        carry = ""
        for j in range(width):
            cell = row[j].strip() if j < len(row) else ""
            if i < len(rows) - 1:  # a group title spans the empty cells to its right
                carry = cell or carry
                cell = carry
            if cell:
                parts[j].append(cell)
    return [" ".join(p) for p in parts]


def frame_names(labels: Sequence, header_rows: int | None) -> list[str]:
    """A DataFrame's column labels as names: a pandas ``MultiIndex`` (tuples) has its levels joined per column as
    header rows are (``header_rows``, if given, must be its number of levels)."""
    tuples = [c for c in labels if isinstance(c, tuple)]
    if not tuples:
        if header_rows not in (None, 1):
            raise LogFormatError(f"DataFrame: header_rows={header_rows}, but its columns have one level")
        return [str(c) for c in labels]
    levels = len(tuples[0])
    if header_rows is not None and header_rows != levels:
        raise LogFormatError(f"DataFrame: header_rows={header_rows}, but its columns have {levels} levels")
    rows = [
        [str(c[i]) if isinstance(c, tuple) and "Unnamed" not in str(c[i]) else "" for c in labels]
        for i in range(levels)
    ]
    return join_header_rows(rows)


def _resolve(value: str | int, names: list[str], labels: Sequence[str], key: str, where: str) -> int:
    if isinstance(value, int):
        if value > len(names):
            raise LogFormatError(f"{where}: --columns {key}={value}, but the file has {len(names)} columns")
        return value - 1
    want = normalise_name(value)
    hits = [j for j, n in enumerate(names) if n == want]
    if len(hits) == 1:
        return hits[0]
    if hits:
        at = ", ".join(str(j + 1) for j in hits)
        raise LogFormatError(f"{where}: --columns {key}={value!r} matches columns {at}; give the position instead")
    raise LogFormatError(
        f"{where}: --columns {key}={value!r}: no such column (found: {found_names(labels, numbered=True)})"
    )


def apply_columns(names: Sequence[str], columns: ColumnMap | None, where: str, time_column: str = "t") -> list[str]:
    """The names the reader uses (normalised) once ``columns`` is applied to the header ``names`` (module
    docstring); without a map, the normalised names. An ignored column gets the empty name."""
    normal = [normalise_name(n) for n in names]
    if not columns:
        return normal
    keys = dict(columns)
    if "t" in keys and normalise_name(time_column) != "t":
        raise LogFormatError(f"{where}: the time column is given twice (--columns t= and --time-column); keep one")
    out = list(normal)
    assigned = {_group(k) for k in keys}
    for j, n in enumerate(normal):
        if _group(n) in assigned or ("attitude" in assigned and re.fullmatch(r"q[0-4]", n)):
            out[j] = ""  # the map decides this group
    used: dict[int, str] = {}
    for key, value in columns:
        j = _resolve(value, normal, names, key, where)
        if j in used:
            raise LogFormatError(f"{where}: --columns gives column {j + 1} ({names[j]!r}) to both {used[j]} and {key}")
        used[j] = key
        out[j] = key
    return out


def columns_line(pairs: Sequence[tuple[str, str | int]]) -> str:
    """``--columns k=v,...`` for the command line (names quoted where the shell needs it)."""
    text = ",".join(f"{k}={v}" for k, v in pairs)
    return f"--columns {text}" if re.fullmatch(r"[\w.,=\-\[\]/]+", text) else f"--columns '{text}'"


def _unit_free(name: str) -> str:
    return re.sub(r"\s*[\[(][^\])]*[\])]\s*$", "", name).strip()  # "q_RS_w []" -> "q_RS_w"


_ORIENTATION = r"orient|quat|rot|att|^q"  # the prefixes that name an attitude (orientation_w, quat.x, Rotation Z, q_w)


def _references(names: Sequence[str]) -> dict[int, str | int]:
    """How ``--columns`` names each column: its name where a command line can carry it, else its position."""
    return {
        j: (names[j] if names[j].strip() and not re.search(r"[,=]", names[j]) else j + 1) for j in range(len(names))
    }


def named_quaternion(names: Sequence[str], time_column: str = "t", timed: bool = False) -> ColumnMap | None:
    """The column map (``qw, qx, qy, qz``) of the one quaternion a header names by its parts, four columns of one
    attitude-like prefix ending in w, x, y, z (``quat_w``, ``orientation.x``, ``Rotation Z``, ``q_w``), where the
    header has no attitude columns of omegahat's own names and its time is known (``time_column``, or the one column
    named as a time, or ``timed``: times given otherwise); None where it has them, or no such group, or several
    (which one is the body's is then the user's choice), or no time (the error then suggests a line for both)."""
    normal = [normalise_name(n) for n in names]
    known = timed or normalise_name(time_column) in normal or time_column_by_name(normal, time_column)[1]
    if attitude_groups(normal) or not known:
        return None
    base = [_unit_free(n) for n in normal]
    unique = {b for b in base if base.count(b) == 1}
    groups = [g for p, g in _four(base, unique, r"[wxyz]", ({"w", "x", "y", "z"},)) if re.search(_ORIENTATION, p)]
    if len(groups) != 1:
        return None
    refs = _references(names)
    return tuple((f"q{a}", refs[groups[0][a]]) for a in "wxyz")


def named_quaternion_note(columns: ColumnMap) -> str:
    """The note of a map found by :func:`named_quaternion`."""
    return f"attitude: the one quaternion named so, {columns_line(columns)}"


def suggest_columns(names: Sequence[str]) -> str:
    """The ``--columns`` line that reads a file with these header names, guessed from them (a time-like column; four
    columns ending in w, x, y, z with a common prefix, preferring orientation-like prefixes), or the template. Four
    columns numbered 0–3 or 1–4 instead (``QUATERNION_0`` … ``QUATERNION_3``) do not say which is the scalar part:
    then both lines, each with the column it takes for the scalar. Columns roll, pitch and yaw: their line, with
    ``--euler`` and ``--angle-unit`` to complete."""
    base = [_unit_free(normalise_name(n)) for n in names]
    pos = _references(names)
    unique = {b for b in base if base.count(b) == 1}
    time = next((j for j, b in enumerate(base) if re.search(r"time|stamp|^t$|sec", b)), None)
    if time is None:
        return COLUMNS_TEMPLATE
    rank = lambda item: (not re.search(_ORIENTATION, item[0]), min(item[1].values()))  # noqa: E731
    named = _four(base, unique, r"[wxyz]", ({"w", "x", "y", "z"},))
    if named:
        g = min(named, key=rank)[1]
        return columns_line([("t", pos[time]), *((f"q{a}", pos[g[a]]) for a in "wxyz")])
    numbered = _four(base, unique, r"[0-4]", ({"0", "1", "2", "3"}, {"1", "2", "3", "4"}))
    if not numbered:
        return _euler_line(names, base, unique, pos, time)
    g = min(numbered, key=rank)[1]
    cols = [g[d] for d in sorted(g)]
    first = columns_line([("t", pos[time]), *zip(("qw", "qx", "qy", "qz"), (pos[j] for j in cols), strict=True)])
    last = columns_line([("t", pos[time]), *zip(("qx", "qy", "qz", "qw"), (pos[j] for j in cols), strict=True)])
    return f"{first} if {names[cols[0]]} is the quaternion's scalar part, {last} if {names[cols[3]]} is"


def _euler_line(names: Sequence[str], base: list[str], unique: set[str], pos: dict, time: int) -> str:
    """The ``--columns`` line for columns named roll, pitch and yaw (once each, units aside), with the Euler options
    to fill in (the unit given when every name states the same one: ``Roll (deg)``), or the template."""
    found = {a: base.index(a) for a in EULER_COLUMNS if a in unique}
    if len(found) < 3:
        return _rx_ry_rz_lines(base, unique, pos, time)
    units = {u for j in found.values() for u in ("deg", "rad") if re.search(rf"[\[(]\s*{u}", names[j].lower())}
    unit = units.pop() if len(units) == 1 else "deg|rad"
    line = columns_line([("t", pos[time]), *((a, pos[j]) for a, j in found.items())])
    return f"{line} --euler SEQ --angle-unit {unit} (SEQ the angles' sequence, e.g. ZYX: yaw, pitch, then roll)"


def _rx_ry_rz_lines(base: list[str], unique: set[str], pos: dict, time: int) -> str:
    """For columns ``rx, ry, rz`` (a Universal Robots or Vicon rotation vector, or Euler angles elsewhere: the names
    cannot say) the line for either reading, or the template."""
    if not {"rx", "ry", "rz"} <= unique:
        return COLUMNS_TEMPLATE
    cols = [pos[base.index(f"r{a}")] for a in "xyz"]
    rotvec = columns_line([("t", pos[time]), *zip(ROTVEC_COLUMNS, cols, strict=True)])
    angles = columns_line([("t", pos[time]), *zip(EULER_COLUMNS, cols, strict=True)])
    return (
        f"{rotvec} if rx, ry, rz are a rotation vector in radians (Universal Robots, Vicon), or {angles} --euler SEQ "
        "--angle-unit deg|rad if they are Euler angles"
    )


def _four(base: list[str], unique: set[str], suffix: str, sets: tuple[set[str], ...]) -> list[tuple[str, dict]]:
    """The groups of four columns sharing a prefix whose suffixes (``suffix``, a character class) make one of
    ``sets``: ``[(prefix, {suffix: column index})]``."""
    groups: dict[str, dict[str, int]] = {}
    for j, b in enumerate(base):
        m = re.fullmatch(rf"(.*?)[\s_.:/-]*({suffix})", b)
        if m and b in unique:
            groups.setdefault(m.group(1), {}).setdefault(m.group(2), j)
    return [(p, g) for p, g in groups.items() if set(g) in sets]
