r"""Input formats, recognised from the file, read as a stream of chunks through one checked path.

A format is a :class:`Format`: a name, the file extensions it claims (a directory's is :data:`DIRECTORY`), an
``opener(path, options) -> LogStream``, optionally a ``sniff(path) -> bool`` that recognises it from the file's
content (several formats share ``.csv``: omegahat's columns, Motive and Vicon exports), and the reading options it
accepts. :mod:`omegahat.io` registers csv, npz, motive, vicon, c3d, rosbag1 and rosbag2; another format plugs in
the same way with :func:`register_format`.

**Detection** (:func:`detect_format`): among the formats claiming the path's extension, those with a sniffer are
asked first, in registration order, and the first that recognises the file wins; else the one without a sniffer
(for ``.csv``: omegahat's own columns, whose reader names what it expects).

**The one path** (:func:`open_log`): detect, refuse options the format does not take (``--topic`` for a CSV,
``--time-unit`` for a bag: loud rather than ignored), open, and wrap the stream (:func:`checked_stream`, which
:func:`omegahat.estimate_frame` uses for DataFrames too) so that every format gets, from one place:

* **time unit** (``ReadOptions.time_unit``, ``s | ms | us | ns``, for formats whose times carry no unit):
  times are scaled to seconds;
* **rotation convention** (``ReadOptions.rotation``): ``body-to-inertial`` (default: ``v_inertial = R v_body``,
  the convention of :mod:`omegahat.so3`, of ROS and of motion-capture exports) or ``inertial-to-body`` (``R`` maps
  inertial to body, as much spacecraft software stores it): then every matrix is transposed and every quaternion
  conjugated, so that the chunks handed on are always body → inertial and the rate comes out in body axes.
  Direction input is body-frame by definition and takes no rotation convention;
* **attitudes**: the precision policy of :mod:`omegahat.io.precision` (rounded and interpolated rotations
  normalised within the tolerance the file's digits allow, and counted; columns that hold no rotation named);
* **times**: finite, and the timestamp policy of :mod:`omegahat.io.timestamps` (in order; exact duplicates
  dropped; conflicting ones refused unless ``duplicate_times`` keeps the first or last), across chunk boundaries,
  every message naming the line (array index, message, frame or row) of both samples.

**Column maps** (``ReadOptions.columns``, ``header_rows``: :mod:`omegahat.io.colmap`) are read by the formats that
take them (omegahat's CSV); when one is given for a file that another format recognises (a Motive export read
column by column), the extension's plain format reads it, as the map asks.

A :class:`LogChunk` carries ``t`` (s, relative to the stream's ``t0``), the attitude in storage order (quaternions
scalar last, SciPy's order), the torque, ``labels`` (the line number, index, message or frame of each row, so that
every later message can name the place in the file) and ``extra`` per-row columns a writer needs (a bag's stamps).
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, fields, replace
from typing import Any, Self, cast

import numpy as np
from numpy.typing import ArrayLike

from omegahat.io.colmap import ColumnMap, parse_columns
from omegahat.io.columns import LogFormatError
from omegahat.io.euler import as_matrices, check_conventions
from omegahat.io.precision import Normaliser
from omegahat.io.rotvec import vectors_as_matrices
from omegahat.io.time_units import TIME_UNITS
from omegahat.io.timestamps import DUPLICATE_CHOICES, TimePolicy

__all__ = [
    "CHUNK_ROWS",
    "COLUMN_OPTIONS",
    "DIRECTORY",
    "MAP_OPTIONS",
    "OPTION_FLAGS",
    "ROTATIONS",
    "STAMPS",
    "TIME_UNITS",
    "Format",
    "LogChunk",
    "LogStream",
    "ReadOptions",
    "checked_stream",
    "detect_format",
    "get_format",
    "open_log",
    "prefetch",
    "register_format",
    "registered_extensions",
    "unregister_format",
    "with_options",
]

ROTATIONS = ("body-to-inertial", "inertial-to-body")
STAMPS = ("header", "receive")
DIRECTORY = "/"  #: the "extension" of a directory (a ROS 2 bag)
CHUNK_ROWS = 1 << 17  #: rows per chunk of formats read whole (NPZ, bags, exports, DataFrames)
#: options for logs whose columns are named by omegahat's rules (CSV, NPZ): the default of register_format
COLUMN_OPTIONS = ("time_unit", "scalar_first", "time_column", "euler", "angle_unit")
#: options of the formats read column by column through a column map (omegahat.io.colmap): text logs
MAP_OPTIONS = ("columns", "header_rows")
#: option -> its name on the command line (messages say both where it matters)
OPTION_FLAGS = {
    "time_unit": "--time-unit",
    "scalar_first": "--scalar-first",
    "time_column": "--time-column",
    "body": "--body",
    "topic": "--topic",
    "parent_frame": "--parent-frame",
    "child_frame": "--child-frame",
    "stamp": "--stamp",
    "columns": "--columns",
    "header_rows": "--header-rows",
    "rate": "--rate",
    "times": "--times",
    "euler": "--euler",
    "angle_unit": "--angle-unit",
}


@dataclass(frozen=True)
class ReadOptions:
    """How to read a log: conventions the file itself may not state, and which body or topic to read.

    ``time_unit``, ``scalar_first`` (the quaternion order, as SciPy names it: True ``w, x, y, z``, False
    ``x, y, z, w``), ``time_column``, ``euler``, ``angle_unit`` (:mod:`omegahat.io.euler`): CSV, NPZ and Parquet logs;
    ``columns`` (a column map: ``"t=1,qw=2,..."`` or ``{"t": "Time", "qw": 2}``) and ``header_rows`` (rows the
    header spans; 0: none): text logs (:mod:`omegahat.io.colmap`); ``rotation``: every attitude format; ``body``:
    the rigid body of a Motive, Vicon, Qualisys or C3D file, an AEM's spacecraft frame; ``topic``, ``parent_frame``,
    ``child_frame``, ``stamp`` (``header`` or ``receive`` time): ROS bags; ``rate`` (Hz) or ``times`` (a file of
    one time per line): the times of pose lists that have none (KITTI); ``duplicate_times``: every format, what to
    do with samples at one time whose attitudes differ (:data:`omegahat.io.timestamps.DUPLICATE_CHOICES`:
    ``error``, the default, or keep the ``first`` or the ``last``, counted and reported). A format refuses the
    selection options it does not take when they differ from their defaults."""

    time_unit: str = "s"
    scalar_first: bool | None = None  # None: the names say it (qw..), else the format's documented default
    rotation: str = "body-to-inertial"
    time_column: str = "t"
    body: str | None = None
    topic: str | None = None
    parent_frame: str | None = None
    child_frame: str | None = None
    stamp: str = "header"
    columns: ColumnMap | str | dict | None = None  # parsed into a ColumnMap (tuple of pairs) on construction
    header_rows: int | None = None  # None: the format's own (one header row for a CSV)
    rate: float | None = None
    times: str | None = None
    duplicate_times: str = "error"
    euler: str | None = None
    angle_unit: str | None = None
    chunk_bytes: int = 1 << 21  # CSV: bytes per chunk (memory stays proportional to this, not to the log)

    def __post_init__(self):
        object.__setattr__(self, "columns", parse_columns(self.columns))
        if self.header_rows is not None and (
            isinstance(self.header_rows, bool) or not isinstance(self.header_rows, int) or not 0 <= self.header_rows
        ):
            raise ValueError(f"header rows must be a whole number >= 0; got {self.header_rows!r}")
        if self.rate is not None and not (isinstance(self.rate, int | float) and 0 < self.rate < float("inf")):
            raise ValueError(f"rate must be a positive number of Hz; got {self.rate!r}")
        if self.time_unit not in TIME_UNITS:
            raise ValueError(f"time unit must be one of {', '.join(TIME_UNITS)}; got {self.time_unit!r}")
        if self.scalar_first not in (None, True, False):
            raise ValueError(f"scalar_first must be True, False or None; got {self.scalar_first!r}")
        if self.rotation not in ROTATIONS:
            raise ValueError(f"rotation must be {' or '.join(ROTATIONS)}; got {self.rotation!r}")
        if self.duplicate_times not in DUPLICATE_CHOICES:
            raise ValueError(
                f"duplicate times must be one of {', '.join(DUPLICATE_CHOICES)}; got {self.duplicate_times!r}"
            )
        check_conventions(self.euler, self.angle_unit)
        if self.stamp not in STAMPS:
            raise ValueError(f"stamp must be {' or '.join(STAMPS)}; got {self.stamp!r}")

    @property
    def column_map(self) -> ColumnMap | None:
        """``columns`` as parsed (:func:`omegahat.io.colmap.parse_columns` ran on construction)."""
        return cast("ColumnMap | None", self.columns)

    def given(self) -> list[str]:
        """The selection options (:data:`OPTION_FLAGS`) set to something other than their defaults."""
        defaults = ReadOptions()
        return [
            f.name
            for f in fields(self)
            if f.name in OPTION_FLAGS and getattr(self, f.name) != getattr(defaults, f.name)
        ]


@dataclass
class LogChunk:
    """Consecutive rows of a log: ``t (m,)`` s, ``data`` ``(m, 4)`` / ``(m, 3, 3)`` / ``(m, n, 3)`` (NaN rows are
    missing samples), ``torque (m, 3)`` or None, ``labels (m,)`` line numbers or indices, ``extra`` per-row
    arrays for the writer (or None)."""

    t: np.ndarray
    data: np.ndarray
    torque: np.ndarray | None
    labels: np.ndarray
    extra: dict[str, np.ndarray] | None = None

    def __len__(self) -> int:
        return self.t.size


@dataclass
class LogStream:
    """An open log: what it holds, and its rows chunk by chunk (:meth:`chunks`, once).

    ``label`` is the word for a row's place: ``"line"`` (text formats), ``"index"`` (NPZ arrays), ``"message"``
    (bags), ``"frame"`` (C3D) or ``"row"`` (DataFrames); ``notes`` are conventions the reader had to assume and
    what the timestamp policy changed (printed by the CLI so that nothing is silent); ``description`` says what
    was recognised (empty for omegahat's own logs); ``size`` and ``done`` measure progress (bytes for text
    formats, else rows); ``n_rows_hint`` the number of rows if known in advance (else None); ``t0`` the time
    (s) the chunks' times count from (a bag's first stamp: seconds since 1970 would lose precision as floats);
    ``context`` follows the source in messages (``", topic /pose"``); ``meta`` holds what a writer needs (a
    bag's topic, frames and ROS version); ``options`` the :class:`ReadOptions` it was opened with.
    """

    source: str
    kind: str
    n_directions: int
    has_torque: bool
    label: str
    _chunks: Callable[[], Iterator[LogChunk]]
    size: int = 0
    n_rows_hint: int | None = None
    notes: list[str] = field(default_factory=list)
    done: int = 0
    attitude_name: str = ""  # the columns or array holding the attitude, for messages ("qw,qx,qy,qz", "q", ...)
    time_name: str | None = "t"  # the time column or array, for messages (None: not named)
    description: str = ""
    t0: float = 0.0
    context: str = ""
    meta: dict = field(default_factory=dict)
    format: str = ""
    options: ReadOptions | None = None
    digits: int | None = None  # significant digits of the attitude's text (precision policy); None: binary/unknown
    columns: str = ""  # the --columns line that reads this stream as it was read (for messages; "" if none applies)

    def where(self, label: int, column: str | None = None) -> str:
        """``"path, line 17, column qx"``, ``"path, array q, index 17"``, ``"bag, topic /p, message 17"``: the
        place of a row (and column) in messages."""
        head = f"{self.source}{self.context}"
        if self.label == "index":
            return f"{head}, " + (f"array {column}, " if column else "") + f"index {label}"
        word = "columns" if column and ("," in column or ".." in column) else "column"
        return f"{head}, {self.label} {label}" + (f", {word} {column}" if column else "")

    def chunks(self) -> Iterator[LogChunk]:
        return self._chunks()

    def convert(self, step: Callable[[Iterator[LogChunk]], Iterator[LogChunk]]) -> None:
        """From now on, hand the rows on through ``step``, a generator over the chunks as they were (Euler angles,
        :func:`open_log`'s checks, a torque log)."""
        raw = self._chunks
        self._chunks = lambda: step(raw())

    @classmethod
    def from_arrays(
        cls,
        source: str,
        kind: str,
        t: np.ndarray,
        data: np.ndarray,
        torque: np.ndarray | None = None,
        labels: ArrayLike | None = None,
        extra: dict[str, np.ndarray] | None = None,
        **fields_: Any,
    ) -> Self:
        """A stream over whole arrays (formats read at once), handed on in chunks of :data:`CHUNK_ROWS` rows;
        ``labels`` default to the indices, ``fields_`` set the other attributes (``label``, ``description`` ...)."""
        T = len(t)
        row_labels = np.arange(T) if labels is None else np.asarray(labels)

        def chunks() -> Iterator[LogChunk]:
            for a in range(0, T, CHUNK_ROWS):
                b = min(T, a + CHUNK_ROWS)
                part = None if extra is None else {k: v[a:b] for k, v in extra.items()}
                yield LogChunk(t[a:b], data[a:b], None if torque is None else torque[a:b], row_labels[a:b], part)
                if by_rows:
                    stream.done = b

        n_dir = data.shape[1] if kind == "directions" else 0
        by_rows = "size" not in fields_  # progress in rows, unless the format measures it otherwise (bytes)
        fields_.setdefault("label", "index")
        fields_.setdefault("size", T)
        fields_.setdefault("n_rows_hint", T)
        stream = cls(source, kind, n_dir, torque is not None, _chunks=chunks, **fields_)
        return stream


@dataclass(frozen=True)
class Format:
    """A readable format (module docstring): ``title`` names it in messages ("an OptiTrack Motive CSV export")."""

    name: str
    title: str
    extensions: tuple[str, ...]
    opener: Callable[[str, ReadOptions], LogStream]
    sniff: Callable[[str], bool] | None = None
    options: tuple[str, ...] = COLUMN_OPTIONS


_FORMATS: list[Format] = []


def register_format(
    extensions: str | Iterable[str],
    opener: Callable[[str, ReadOptions], LogStream],
    *,
    name: str | None = None,
    title: str | None = None,
    sniff: Callable[[str], bool] | None = None,
    options: tuple[str, ...] = COLUMN_OPTIONS,
) -> Format:
    """Register ``opener(path, options) -> LogStream`` for file extensions such as ``".csv"`` (case-insensitive;
    :data:`DIRECTORY` for directories). ``sniff(path)``: recognise the format from the file's content (asked
    before the extension's plain format); ``options``: the :class:`ReadOptions` selection fields it takes. A
    format of the same name is replaced."""
    exts = tuple(e.lower() for e in ([extensions] if isinstance(extensions, str) else extensions))
    name = name or exts[0].lstrip(".")
    fmt = Format(name, title or f"a {name} file", exts, opener, sniff, tuple(options))
    _FORMATS[:] = [f for f in _FORMATS if f.name != name]
    _FORMATS.append(fmt)
    return fmt


def unregister_format(name: str) -> None:
    """Remove the format registered under ``name`` (a plug-in's, or to replace a built-in one)."""
    get_format(name)
    _FORMATS[:] = [f for f in _FORMATS if f.name != name]


def registered_extensions() -> list[str]:
    return sorted({e for f in _FORMATS for e in f.extensions if e != DIRECTORY})


def get_format(name: str) -> Format:
    """The format registered under ``name``."""
    for f in _FORMATS:
        if f.name == name:
            return f
    raise ValueError(f"no format named {name!r}; known: {', '.join(f.name for f in _FORMATS)}")


def _unknown(path: str, ext: str) -> LogFormatError:
    listing = "; ".join(f"{', '.join(e for e in f.extensions if e != DIRECTORY)} {f.title}" for f in _FORMATS)
    if ext == DIRECTORY:
        return LogFormatError(f"{path} is a directory, and no format reads it ({listing})")
    known = " or ".join(registered_extensions())
    return LogFormatError(f"{path}: unknown log format {ext or '(no extension)'!r}; use {known} ({listing})")


def detect_format(path: str | os.PathLike[str], fmt: str | None = None) -> Format:
    """The :class:`Format` of ``path`` (module docstring), or of ``fmt``: a format's name (``"motive"``) or an
    extension (``".csv"``: that extension's plain format, whatever the file's name)."""
    path = os.fspath(path)
    if fmt is not None and not fmt.startswith("."):
        return get_format(fmt)
    ext = (fmt or (DIRECTORY if os.path.isdir(path) else os.path.splitext(path)[1])).lower()
    candidates = [f for f in _FORMATS if ext in f.extensions]
    if fmt is None:
        for f in candidates:
            if f.sniff is not None and f.sniff(path):
                return f
    plain = [f for f in candidates if f.sniff is None]
    if plain:
        return plain[0]
    if len(candidates) == 1:  # the extension's only format: its reader says what is wrong with the file
        return candidates[0]
    raise _unknown(path, ext)


def _refuse_options(path: str, fmt: Format, options: ReadOptions) -> None:
    wrong = [o for o in options.given() if o not in fmt.options]
    if not wrong:
        return
    takers = [f.title for f in _FORMATS if all(o in f.options for o in wrong)]
    flags = ", ".join(OPTION_FLAGS[o] for o in wrong)
    raise ValueError(
        f"{path} is {fmt.title}: {flags} appl{'ies' if len(wrong) == 1 else 'y'} only to "
        + (", ".join(takers[:-1]) + " and " * (len(takers) > 1) + takers[-1] if takers else "other formats")
    )


_CONJUGATE = np.array([-1.0, -1.0, -1.0, 1.0])  # scalar last: (−x, −y, −z, w) is the inverse rotation


def _checked(stream: LogStream, raw: Iterator[LogChunk], options: ReadOptions) -> Iterator[LogChunk]:
    scale = TIME_UNITS[options.time_unit]
    invert = options.rotation == "inertial-to-body"
    if invert and stream.kind == "directions":
        raise LogFormatError(
            f"{stream.source}: --rotation applies to attitude input; body-frame directions (b1x, ...) are already "
            "in body axes (leave --rotation out)"
        )
    meta = stream.meta
    policy = TimePolicy(stream.kind, stream.where, stream.label, stream.time_name, options.duplicate_times,
                        meta.get("time_base", 0), bool(meta.get("time_dates", False)),
                        float(meta.get("time_scale", 1.0)))  # fmt: skip
    precise = Normaliser(stream.kind, stream.digits, stream.where, stream.attitude_name, stream.columns, stream.label)
    for chunk in raw:
        t = chunk.t * scale if scale != 1.0 else np.asarray(chunk.t, dtype=float)
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            k = int(bad[0])
            raise LogFormatError(
                f"{stream.where(int(chunk.labels[k]), stream.time_name)}: time {float(chunk.t[k])!r} is not finite"
            )
        data = precise.feed(chunk.data, chunk.labels)
        if invert:
            data = data * _CONJUGATE if stream.kind == "quaternion" else np.swapaxes(data, 1, 2).copy()
        arrays, keep = policy.feed((t, chunk.t, data, chunk.torque, chunk.labels, chunk.extra))
        part = _chunk(arrays, keep)
        if len(part):
            yield part
    precise.check_head()
    held = policy.finish()
    if held is not None:
        yield _chunk(held, slice(None))
    stream.notes.extend(precise.notes() + policy.notes())


def _chunk(arrays: tuple, sel) -> LogChunk:
    """The rows ``sel`` (a slice or indices) of ``arrays`` = (t, raw t, data, torque, labels, extra)."""
    t, _, data, torque, labels, extra = arrays
    return LogChunk(
        t[sel],
        data[sel],
        None if torque is None else torque[sel],
        labels[sel],
        None if extra is None else {k: v[sel] for k, v in extra.items()},
    )


def checked_stream(stream: LogStream, options: ReadOptions) -> LogStream:
    """Wrap a format's raw stream in the conversions and checks of the module docstring (done by
    :func:`open_log`; formats not read from a path, e.g. DataFrames, call it themselves)."""
    as_matrices(stream, options.euler, options.angle_unit)  # Euler angles (a no-op for other attitudes)
    vectors_as_matrices(stream)  # rotation vectors (likewise)
    stream.convert(lambda raw: _checked(stream, raw, options))
    stream.options = options
    if options.rotation == "inertial-to-body" and stream.kind != "directions":
        stream.notes.append("rotation: inertial-to-body (inverted to body-to-inertial; rates in body axes)")
    if options.time_unit != "s":
        stream.notes.append(f"time unit: {options.time_unit} (converted to s)")
    return stream


def open_log(path: str | os.PathLike[str], options: ReadOptions | None = None, fmt: str | None = None) -> LogStream:
    """Open a log in the format :func:`detect_format` finds (or ``fmt``: a format's name or an extension such as
    ``".csv"``); the stream's chunks are converted and checked (module docstring)."""
    options = ReadOptions() if options is None else options
    path = os.fspath(path)
    form = detect_format(path, fmt)
    recognised = form
    mapped = [o for o in MAP_OPTIONS if o in options.given() and o not in form.options]
    if mapped and fmt is None:  # a column map reads the file column by column, whatever else recognises it
        ext = os.path.splitext(path)[1].lower()
        plain = [f for f in _FORMATS if ext in f.extensions and f.sniff is None]
        form = plain[0] if plain and all(o in plain[0].options for o in mapped) else form
    _refuse_options(path, form, options)
    stream = form.opener(path, options)
    stream.format = form.name
    if form is not recognised:
        stream.notes.append(f"read column by column as the column map says, not as {recognised.title}")
    return checked_stream(stream, options)


def with_options(options: ReadOptions | None, **changes: Any) -> ReadOptions:
    """``options`` (default :class:`ReadOptions`) with ``changes`` applied (keyword conveniences of the readers)."""
    base = ReadOptions() if options is None else options
    return replace(base, **changes) if changes else base


def prefetch(chunks: Iterator[LogChunk], depth: int = 2) -> Iterator[LogChunk]:
    """The same chunks, produced by a background thread up to ``depth`` ahead (PyArrow parses without the
    GIL, so reading overlaps estimating); an exception in the reader is raised here, in order."""
    q: queue.Queue = queue.Queue(maxsize=depth)
    done = object()
    stop = threading.Event()

    def work():
        try:
            for c in chunks:
                if stop.is_set():
                    return
                q.put(c)
            q.put(done)
        except BaseException as exc:
            q.put(exc)

    thread = threading.Thread(target=work, name="omegahat-reader", daemon=True)
    thread.start()
    try:
        while True:
            item = q.get()
            if item is done:
                return
            if isinstance(item, BaseException):
                raise item
            yield item
    finally:
        stop.set()
        while thread.is_alive():  # let a reader blocked on a full queue finish
            try:
                q.get_nowait()
            except queue.Empty:
                thread.join(0.01)
