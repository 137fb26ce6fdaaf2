"""Which columns (or arrays) of a log hold what: one place for the naming rules every reader follows.

Names are compared after :func:`normalise_name`: surrounding whitespace, quotes and a UTF-8 byte-order mark
removed, lower case (spreadsheet programs write ``\\ufeffT`` or ``QW``). Groups, each by name and in any order:

* time: ``t`` (or the name given as ``time_column``); a log without ``t`` whose one time column is named as a time
  (``time``, ``timestamp``, ``Time (s)``: :func:`time_named_columns`) has that one read, said in a note;
* quaternion: ``qw, qx, qy, qz`` (the names say which is the scalar part), or the ambiguous ``q0, q1, q2, q3`` /
  ``q1, q2, q3, q4``, whose scalar part only the ``scalar_first`` option can say (SciPy's name);
* rotation matrix ``r11 … r33`` (``rij`` = row i, column j);
* body-frame directions ``b1x, b1y, b1z, b2x, …`` (numbered without gaps; one direction alone goes to
  :mod:`omegahat.io.single_direction`);
* Euler angles ``roll, pitch, yaw`` (about x, y, z; the sequence and unit are options: :mod:`omegahat.io.euler`);
* a rotation vector ``rotvec_x, rotvec_y, rotvec_z`` (radians, axis times angle: :mod:`omegahat.io.rotvec`);
* torque ``tau_x, tau_y, tau_z``.

Exactly one attitude group may be present. A reader (CSV, NPZ, or a format registered in
:mod:`omegahat.io.registry`) calls :func:`layout` on its names and gets a :class:`Layout`: the time column, the
attitude kind and its columns in storage order (quaternions scalar **last**, SciPy's order), the torque columns.
"""

from __future__ import annotations

import re
import shlex
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = [
    "EULER_COLUMNS",
    "MATRIX_COLUMNS",
    "MAX_COLUMNS",
    "QUATERNION_COLUMNS",
    "QUATERNION_ORDERS",
    "ROTVEC_COLUMNS",
    "TIME_COLUMN_NAMES",
    "TORQUE_COLUMNS",
    "Layout",
    "LogFormatError",
    "attitude_groups",
    "direction_columns",
    "found_names",
    "layout",
    "normalise_name",
    "shown_value",
    "time_column_by_name",
    "time_named_columns",
    "time_or_capital_t",
    "time_unit_in_name",
]

QUATERNION_COLUMNS = ("qx", "qy", "qz", "qw")  # stored in this order: SciPy's scalar-last
MATRIX_COLUMNS = tuple(f"r{i}{j}" for i in range(1, 4) for j in range(1, 4))
TORQUE_COLUMNS = ("tau_x", "tau_y", "tau_z")
EULER_COLUMNS = ("roll", "pitch", "yaw")  # the angles about x, y, z (omegahat.io.euler)
ROTVEC_COLUMNS = ("rotvec_x", "rotvec_y", "rotvec_z")  # axis times angle, radians (omegahat.io.rotvec)
QUATERNION_ORDERS = ("wxyz", "xyzw")
MAX_COLUMNS = 200_000  #: a header naming more columns is refused before its names are split (issue 23: size limits)
_AXES = ("x", "y", "z")
# Numbered quaternion columns whose scalar part the header does not say: storage order (x, y, z, w) per option.
_NUMBERED: dict[tuple[str, ...], dict[str, tuple[str, ...]]] = {
    ("q0", "q1", "q2", "q3"): {"wxyz": ("q1", "q2", "q3", "q0"), "xyzw": ("q0", "q1", "q2", "q3")},
    ("q1", "q2", "q3", "q4"): {"wxyz": ("q2", "q3", "q4", "q1"), "xyzw": ("q1", "q2", "q3", "q4")},
}


_KEYS = frozenset(
    (
        "t",
        *QUATERNION_COLUMNS,
        *MATRIX_COLUMNS,
        *EULER_COLUMNS,
        *ROTVEC_COLUMNS,
        *TORQUE_COLUMNS,
        *(f"q{i}" for i in range(5)),
    )
)


class LogFormatError(ValueError):
    """A log that cannot be read as documented in :mod:`omegahat.io`; the message says where and what to do."""


@dataclass(frozen=True)
class Layout:
    """Where a log's quantities are: names as found (normalised), attitude columns in storage order."""

    time: str
    kind: str  # "quaternion", "matrix", "directions", "euler" (angles about x, y, z) or "rotvec"
    attitude: tuple[str, ...]
    torque: tuple[str, ...] | None
    quaternion_named: bool = True  # False for q0..q3 / q1..q4 (order from the option)

    @property
    def n_directions(self) -> int:
        return len(self.attitude) // 3 if self.kind == "directions" else 0

    @property
    def columns(self) -> tuple[str, ...]:
        """Every column read, time first (when it is a column)."""
        return (*((self.time,) if self.time else ()), *self.attitude, *(self.torque or ()))


def found_names(names: Iterable[str], numbered: bool = False, most: int = 24, width: int = 40) -> str:
    """The names a file has, for a message: at most ``most`` of them, each cut to ``width`` characters (a header
    that is one long comment, or a file of thousands of columns, would otherwise fill the screen), with their 1-based
    positions when ``numbered``."""
    shown, count = [], 0
    for j, name in enumerate(names):
        count = j + 1
        if j < most:
            text = name if len(name) <= width else name[: width - 3] + "..."
            shown.append(f"{j + 1}:{text or '(empty)'}" if numbered else text)
    more = f", ... ({count} in all)" if count > most else ""
    return (", ".join(shown) or "none") + more


def shown_value(value: object, width: int = 60) -> str:
    """A field's value for a message, quoted as Python does, cut to about ``width`` characters with its length
    said (a 100 kB field is named, not echoed)."""
    shown = repr(value)
    if len(shown) <= width:
        return shown
    text = str(value)
    return f"{text[: width - 3]!r}... ({len(text)} characters)"


def normalise_name(name: str) -> str:
    """Column name as compared: BOM, quotes and surrounding whitespace removed, lower case."""
    return name.replace("\ufeff", "").strip().strip('"').strip("'").strip().lower()


#: the words a time column's name may end in to state its unit (``timestamp_ns``, ``Time (s)``, ``t [ms]``)
_TIME_UNIT_WORDS = {
    **dict.fromkeys(("s", "sec", "secs", "second", "seconds"), "s"),
    **dict.fromkeys(("ms", "msec", "millisecond", "milliseconds"), "ms"),
    **dict.fromkeys(("us", "µs", "usec", "microsecond", "microseconds"), "us"),
    **dict.fromkeys(("ns", "nsec", "nanosecond", "nanoseconds"), "ns"),
}


def time_unit_in_name(name: str) -> str | None:
    """The unit (``s``, ``ms``, ``us`` or ``ns``) a time column's name states in its last word, after ``_``, ``-``,
    ``.`` or a blank, or in brackets (``timestamp_ns``, ``Time (s)``, ``#timestamp [ns]``); None when it states
    none (``t``, ``time``, ``SampleTimeFine``)."""
    m = _last_word(normalise_name(name))
    return _TIME_UNIT_WORDS.get(m.group(1)) if m else None


def _last_word(name: str) -> re.Match | None:
    """The last word of a (normalised) name, after a separator or in brackets, with the separator in its span."""
    return re.search(r"(?:^|[\s_.\-\[(]+)([a-zµ]+)\s*[\])]?$", name)


#: the names (less a unit they state: ``time_s``, ``Timestamp [ns]``) that name a log's time column where it has no
#: column ``t`` (``%time`` and ``field.header.stamp``, rostopic's two times, are left to the user to choose)
TIME_COLUMN_NAMES = frozenset(
    ("time", "times", "timestamp", "timestamps", "time_stamp", "stamp", "sec", "secs", "seconds", "datetime")
)


_ROSTOPIC_RECEIVED, _ROSTOPIC_STAMP = "%time", "field.header.stamp"  # the two times of `rostopic echo -p`'s CSV


def time_named_columns(names: list[str]) -> list[str]:
    """The ``names`` (normalised, in order) that name a time column: one of :data:`TIME_COLUMN_NAMES`, alone or
    followed by the unit it states (``time``, ``Time (s)``, ``timestamp_ns``)."""
    found = []
    for name in names:
        stem = normalise_name(name)
        unit = _last_word(stem)
        if unit and unit.group(1) in _TIME_UNIT_WORDS and stem not in TIME_COLUMN_NAMES:
            stem = stem[: unit.start()]  # less its unit word
        if stem in TIME_COLUMN_NAMES:
            found.append(normalise_name(name))
    return found


def time_column_by_name(names: list[str], time_column: str) -> tuple[str, str | None]:
    """The time column to read and the note that says why: ``time_column`` unless it is ``t``, the log has no
    column ``t`` and exactly one column is named as a time (:func:`time_named_columns`), which is then read (a log
    with several leaves the choice to ``--time-column``; the error names them). A CSV of ``rostopic echo -p``, with
    its receive time ``%time`` and the messages' ``field.header.stamp``, has the header stamp read, as a bag has."""
    if normalise_name(time_column) != "t":
        return time_column, None
    normalised = [normalise_name(n) for n in names]
    if "t" in normalised:
        return time_column, None
    if {_ROSTOPIC_RECEIVED, _ROSTOPIC_STAMP} <= set(normalised):  # rostopic echo -p: the header stamp, as for a bag
        return _ROSTOPIC_STAMP, (
            f"time column: {_ROSTOPIC_STAMP!r}, the messages' header stamps, as for a ROS bag (rostopic's "
            f"{_ROSTOPIC_RECEIVED!r} is when it received them: --time-column {_ROSTOPIC_RECEIVED})"
        )
    found = time_named_columns(normalised)
    if len(found) != 1:
        return time_column, None
    return found[0], f"time column: {found[0]!r}, the one named as a time (the log has no column 't')"


def time_or_capital_t(names: Sequence[str], time_column: str, flag: str | None = "--time-column") -> str | None:
    """Where the time is read from the default column ``t``, the header (as written) spells it ``T`` and another
    column is named as a time (``Time,T,qw,...``: ``T`` a temperature or a tension): the message that asks which
    is the time, with the ``flag`` that chooses (None: no option does; the caller says how); the caller adds the
    place; else None. Read as the time, such a ``T`` gave rates ten times off."""
    if time_column != "t":  # the default, or a time column the user named (--time-column T chooses it)
        return None
    capital = [n for n in names if normalise_name(n) == "t" and "T" in n]
    others = [n for n in names if normalise_name(n) in time_named_columns([normalise_name(n)])]
    if not capital or not others:
        return None
    a, b = capital[0].strip(), others[0].strip()
    choose = f": pass {flag} {shlex.quote(a)} or {flag} {shlex.quote(b)}" if flag else ""
    said = f"columns {a!r} and {b!r} could each be the time (names are compared ignoring case, so {a!r} reads as t)"
    return said + choose


def direction_columns(names: Iterable[str]) -> list[str]:
    """``b1x, b1y, b1z, b2x, …`` for every i such that some ``bi?`` column is present (checked by :func:`layout`)."""
    idx = sorted(
        {int(nm[1:-1]) for nm in names if len(nm) >= 3 and nm[0] == "b" and nm[1:-1].isdigit() and nm[-1] in _AXES}
    )
    return [f"b{i}{a}" for i in idx for a in _AXES]


def _read(name: str, time_column: str) -> bool:
    """Whether a column of this name may be read (two columns of a name that is not are both ignored)."""
    return bool(name) and (
        name == time_column
        or name in _KEYS
        or (len(name) >= 3 and name[0] == "b" and name[1:-1].isdigit() and name[-1] in _AXES)
    )


def _numbered_quaternion(present: set[str]) -> tuple[str, ...] | None:
    for cols in _NUMBERED:
        if set(cols) <= present:
            return cols
    return None


def attitude_groups(names: list[str]) -> dict[str, list[str]]:
    """The attitude groups (quaternion, matrix, directions, euler, rotvec) of which some column is among ``names``
    (normalised), each with its columns."""
    present = set(names)
    numbered = _numbered_quaternion(present) if not present & set(QUATERNION_COLUMNS) else None
    groups = {
        "quaternion": list(numbered or QUATERNION_COLUMNS),
        "matrix": list(MATRIX_COLUMNS),
        "directions": direction_columns(names),
        "euler": list(EULER_COLUMNS),
        "rotvec": list(ROTVEC_COLUMNS),
    }
    return {kind: cols for kind, cols in groups.items() if cols and present & set(cols)}


def layout(names: Iterable[str], where: str, time_column: str | None = "t", scalar_first: bool | None = None) -> Layout:
    """The :class:`Layout` of a log whose columns are ``names`` (normalised); ``where`` prefixes every message.
    ``time_column`` None: the time is not among the columns (a DataFrame's index); ``Layout.time`` is then ``""``.

    Raises :class:`LogFormatError` for a missing time column, no or several attitude groups, incomplete groups,
    and numbered quaternion columns without ``scalar_first`` (True: the first is the scalar; False: the last).
    """
    normalised = [normalise_name(n) for n in names]
    present = set(normalised)
    time_column = "" if time_column is None else normalise_name(time_column)
    dup = sorted(n for n, c in Counter(normalised).items() if c > 1 and _read(n, time_column))  # linear in columns
    if dup:
        raise LogFormatError(f"{where}: duplicate column(s) {', '.join(dup)} (names are compared ignoring case)")
    if time_column and time_column not in present:
        hint = time_named_columns(normalised)
        tip = "; name it t or pass --time-column NAME"
        if len(hint) == 1:
            tip = f"; pass --time-column {hint[0]}"
        elif hint:
            tip = f"; several columns are named as a time ({', '.join(hint)}): pass --time-column with the one to read"
        raise LogFormatError(f"{where}: no time column {time_column!r} (found: {found_names(normalised)}){tip}")
    touched = attitude_groups(normalised)
    numbered = _numbered_quaternion(present) if not present & set(QUATERNION_COLUMNS) else None
    if len(touched) > 1:  # Euler angles beside an exact attitude (exports often write both): the exact one is read
        touched.pop("euler", None)
    if not touched:
        raise LogFormatError(
            f"{where}: no attitude columns; expected qw,qx,qy,qz or r11..r33 or b1x,b1y,b1z,b2x,... or roll,pitch,yaw "
            f"or rotvec_x,rotvec_y,rotvec_z (found: {found_names(normalised)})"
        )
    if len(touched) > 1:
        raise LogFormatError(f"{where}: attitude given more than one way ({' and '.join(touched)}); keep one")
    kind, cols = next(iter(touched.items()))
    missing = [c for c in cols if c not in present]
    if kind == "directions":
        n = len(cols) // 3
        if missing:
            raise LogFormatError(f"{where}: missing direction column(s) {', '.join(missing)}")
        if [int(c[1:-1]) for c in cols[::3]] != list(range(1, n + 1)):
            raise LogFormatError(
                f"{where}: directions must be numbered b1, b2, ... without gaps; got "
                f"{', '.join(sorted({c[:-1] for c in cols}))}"
            )
    elif missing:
        raise LogFormatError(f"{where}: missing {kind} column(s) {', '.join(missing)}")
    if numbered is not None:
        if scalar_first is None:
            raise LogFormatError(
                f"{where}: columns {', '.join(numbered)} do not say which is the scalar part of the quaternion; "
                f"pass --scalar-first ({numbered[0]} is the scalar) or --scalar-last ({numbered[3]} is the scalar)"
            )
        cols = list(_NUMBERED[numbered][QUATERNION_ORDERS[0] if scalar_first else QUATERNION_ORDERS[1]])
    if time_column and time_column in cols:
        raise LogFormatError(
            f"{where}: the time column {time_column!r} is one of the attitude columns ({', '.join(cols)}); name the "
            "column that holds the time (--time-column NAME)"
        )
    torque = [c for c in TORQUE_COLUMNS if c in present]
    if time_column and time_column in torque:
        raise LogFormatError(f"{where}: the time column {time_column!r} is a torque column; name the time column")
    if torque and len(torque) != 3:
        lacking = [c for c in TORQUE_COLUMNS if c not in present]
        raise LogFormatError(f"{where}: torque needs tau_x, tau_y and tau_z; missing {', '.join(lacking)}")
    return Layout(time_column, kind, tuple(cols), tuple(torque) if torque else None, numbered is None)
