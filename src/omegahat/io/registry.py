r"""Log formats by extension, read as a stream of chunks with the conventions applied and the times checked.

A format is a function ``opener(path, options) -> LogStream`` registered for one or more file extensions with
:func:`register_format` (CSV and NPZ are registered by :mod:`omegahat.io`; other formats plug in the same way).
:func:`open_log` picks the opener by extension and wraps the stream so that every format gets, from one place:

* **time unit** (``ReadOptions.time_unit``, ``s | ms | us | ns``): times are scaled to seconds;
* **rotation convention** (``ReadOptions.rotation``): ``body-to-inertial`` (default: ``v_inertial = R v_body``,
  the convention of :mod:`omegahat.so3`) or ``inertial-to-body`` (``R`` maps inertial to body, as much spacecraft
  software stores it): then every matrix is transposed and every quaternion conjugated, so that the chunks
  handed on are always body → inertial and the rate comes out in body axes. Direction input is body-frame by
  definition and takes no rotation convention;
* **time checks**: finite and strictly increasing across chunk boundaries, every message naming the line (or
  array index) of both samples.

A :class:`LogChunk` carries ``t`` (s), the attitude in storage order (quaternions scalar last, SciPy's order),
the torque, and ``labels``: the line number (CSV) or the index (NPZ) of each row, so that every later message
(a rejected sample, a gap) can name the place in the file.
"""

from __future__ import annotations

import os
import queue
import threading
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field

import numpy as np

from omegahat.io.columns import QUATERNION_ORDERS, LogFormatError

__all__ = [
    "ROTATIONS",
    "TIME_UNITS",
    "LogChunk",
    "LogStream",
    "ReadOptions",
    "open_log",
    "prefetch",
    "register_format",
    "registered_extensions",
]

TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
ROTATIONS = ("body-to-inertial", "inertial-to-body")


@dataclass(frozen=True)
class ReadOptions:
    """How to read a log: conventions the file itself may not state (module docstring)."""

    time_unit: str = "s"
    quaternion_order: str | None = None  # None: the names say it (qw..), else the format's documented default
    rotation: str = "body-to-inertial"
    time_column: str = "t"
    chunk_bytes: int = 1 << 21  # CSV: bytes per chunk (memory stays proportional to this, not to the log)

    def __post_init__(self):
        if self.time_unit not in TIME_UNITS:
            raise ValueError(f"time unit must be one of {', '.join(TIME_UNITS)}; got {self.time_unit!r}")
        if self.quaternion_order not in (None, *QUATERNION_ORDERS):
            raise ValueError(f"quaternion order must be wxyz or xyzw; got {self.quaternion_order!r}")
        if self.rotation not in ROTATIONS:
            raise ValueError(f"rotation must be {' or '.join(ROTATIONS)}; got {self.rotation!r}")


@dataclass
class LogChunk:
    """Consecutive rows of a log: ``t (m,)`` s, ``data`` ``(m, 4)`` / ``(m, 3, 3)`` / ``(m, n, 3)`` (NaN rows are
    missing samples), ``torque (m, 3)`` or None, ``labels (m,)`` line numbers or indices."""

    t: np.ndarray
    data: np.ndarray
    torque: np.ndarray | None
    labels: np.ndarray

    def __len__(self) -> int:
        return self.t.size


@dataclass
class LogStream:
    """An open log: what it holds, and its rows chunk by chunk (:meth:`chunks`, once).

    ``label`` is ``"line"`` (text formats) or ``"index"``; ``notes`` are conventions the reader had to assume
    (printed by the CLI so that an assumption is never silent); ``size`` and ``done`` measure progress (bytes or
    rows); ``n_rows_hint`` the number of rows if known in advance (else None).
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

    def where(self, label: int, column: str | None = None) -> str:
        """``"path, line 17, column qx"`` (text) or ``"path, array q, index 17"``: the place of a row."""
        if self.label == "line":
            word = "columns" if column and ("," in column or ".." in column) else "column"
            return f"{self.source}, line {label}" + (f", {word} {column}" if column else "")
        return f"{self.source}, " + (f"array {column}, " if column else "") + f"index {label}"

    def chunks(self) -> Iterator[LogChunk]:
        return self._chunks()


_FORMATS: dict[str, Callable[[str, ReadOptions], LogStream]] = {}


def register_format(extensions, opener: Callable[[str, ReadOptions], LogStream]) -> None:
    """Register ``opener(path, options) -> LogStream`` for file extensions such as ``".csv"`` (case-insensitive)."""
    for ext in [extensions] if isinstance(extensions, str) else extensions:
        _FORMATS[ext.lower()] = opener


def registered_extensions() -> list[str]:
    return sorted(_FORMATS)


def _conjugate(q: np.ndarray) -> np.ndarray:
    out = q.copy()
    out[:, :3] *= -1.0  # scalar last: (−x, −y, −z, w) is the inverse rotation
    return out


def _checked(stream: LogStream, raw, options: ReadOptions) -> Iterator[LogChunk]:
    scale = TIME_UNITS[options.time_unit]
    invert = options.rotation == "inertial-to-body"
    if invert and stream.kind == "directions":
        raise LogFormatError(
            f"{stream.source}: --rotation applies to attitude input; body-frame directions (b1x, ...) are already "
            "in body axes (leave --rotation out)"
        )
    prev_t, prev_label = np.nan, None
    tcol = options.time_column if stream.label == "line" else "t"
    for chunk in raw():
        t = chunk.t * scale if scale != 1.0 else chunk.t
        bad = np.flatnonzero(~np.isfinite(t))
        if bad.size:
            k = int(bad[0])
            raise LogFormatError(
                f"{stream.where(int(chunk.labels[k]), tcol)}: time {float(chunk.t[k])!r} is not finite"
            )
        full = np.concatenate([[prev_t], t]) if prev_label is not None else t
        bad = np.flatnonzero(np.diff(full) <= 0)
        if bad.size:
            k = int(bad[0]) + (0 if prev_label is not None else 1)  # index in this chunk of the later sample
            before = chunk.labels[k - 1] if k > 0 else prev_label
            t_before = float(chunk.t[k - 1]) if k > 0 else prev_t / scale
            raise LogFormatError(
                f"{stream.where(int(chunk.labels[k]), tcol)}: time {float(chunk.t[k])!r} is not after "
                f"{t_before!r} ({stream.label} {before}); times must increase strictly"
            )
        data = chunk.data
        if invert:
            data = _conjugate(data) if stream.kind == "quaternion" else np.swapaxes(data, 1, 2).copy()
        if t.size:
            prev_t, prev_label = float(t[-1]), int(chunk.labels[-1])
        yield LogChunk(t, data, chunk.torque, chunk.labels)


def open_log(path, options: ReadOptions | None = None, fmt: str | None = None) -> LogStream:
    """Open a log by its extension, or as format ``fmt`` (an extension such as ``".csv"``); the stream's chunks
    are converted and checked (module docstring)."""
    options = ReadOptions() if options is None else options
    path = os.fspath(path)
    ext = (fmt or os.path.splitext(path)[1]).lower()
    opener = _FORMATS.get(ext)
    if opener is None:
        known = " or ".join(registered_extensions())
        raise LogFormatError(f"{path}: unknown log format {ext or '(no extension)'!r}; use {known}")
    stream = opener(path, options)
    raw = stream._chunks
    stream._chunks = lambda: _checked(stream, raw, options)
    if options.rotation == "inertial-to-body" and stream.kind != "directions":
        stream.notes.append("rotation: inertial-to-body (inverted to body-to-inertial; rates in body axes)")
    if options.time_unit != "s":
        stream.notes.append(f"time unit: {options.time_unit} (converted to s)")
    return stream


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
