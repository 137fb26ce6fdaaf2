"""The estimate's output file: its kind said by its name, checked before any work, written in chunks, whole or absent.

:func:`output_kind` says what a name asks for: ``.csv`` a CSV (below); for a ROS bag input also ``.bag`` (a ROS 1
bag) or a name without extension (a ROS 2 bag directory) of ``geometry_msgs/TwistStamped``
(:class:`omegahat.io.rosbag.TwistBagWriter`, which needs the input messages' stamps). Anything else is refused
rather than guessed. :func:`check_output_path` runs before the input is read: the output's directory must exist
and be writable, the output must not be a directory, and it must not be the input (compared as files, so
``./log.csv``, ``../dir/log.csv`` and a symbolic link to it are all caught). :func:`open_output` makes the writer.

:class:`OmegaWriter` writes ``t,wx,wy,wz,status`` (s, rad/s in body axes, one word) chunk by chunk into a
temporary file *in the target directory* and renames it over the target only when every row is written
(``os.replace`` is atomic within a directory): a run that fails or is interrupted leaves the target as it was
(absent, or the previous complete file) and removes its temporary file. ``status`` says what each row is:

* ``corrected``: the estimate after a measured sample;
* ``predicted``: no usable sample at that time (missing, skipped, nearly collinear directions): the estimate was
  predicted through;
* ``unavailable``: no estimate yet (before the first valid sample, and at it: one attitude gives no rate; with a
  warm start until the second); the rate columns are ``nan`` there, never 0.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, Self

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from omegahat.interface import STATUS_WORDS, Status

if TYPE_CHECKING:  # for annotations only (rosbag imports this module; the registry is imported where it is used)
    from omegahat.io.registry import LogChunk, LogStream
    from omegahat.io.rosbag import TwistBagWriter

__all__ = [
    "CORRECTED",
    "PREDICTED",
    "STATUS_WORDS",
    "UNAVAILABLE",
    "AtomicOutput",
    "OmegaWriter",
    "check_output",
    "check_output_path",
    "open_output",
    "output_kind",
]

# the estimators' statuses, one enum (omegahat.interface.Status; "restarted" too), written as their words
UNAVAILABLE, CORRECTED, PREDICTED = Status.UNAVAILABLE, Status.CORRECTED, Status.PREDICTED
HEADER = "t,wx,wy,wz,status"


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.normcase(os.path.realpath(a)) == os.path.normcase(os.path.realpath(b))


BAG_FORMATS = ("rosbag1", "rosbag2")


def output_kind(output: str | os.PathLike[str], input_format: str = "") -> str:
    """``"csv"``, ``"rosbag1"`` or ``"rosbag2"`` for an output name, given the input's format name (module
    docstring); raises ValueError for a name that says neither."""
    out = Path(output)
    suffix = out.suffix.lower()
    bag_input = input_format in BAG_FORMATS
    if suffix == ".csv":
        return "csv"
    if suffix == ".bag" or (suffix == "" and bag_input):
        if not bag_input:
            raise ValueError(f"{out}: a bag output needs a bag input (its stamps and frames); write a .csv instead")
        return "rosbag1" if suffix == ".bag" else "rosbag2"
    raise ValueError(
        f"{out}: unknown output type {suffix or '(no extension)'!r}; use .csv"
        + (", .bag (ROS 1) or a name without extension (ROS 2 bag directory)" if bag_input else "")
    )


def open_output(
    output: str | os.PathLike[str],
    kind: str,
    stream: LogStream,
    *,
    frame_id: str | None = None,
    topic: str | None = None,
) -> OmegaWriter | TwistBagWriter:
    """The writer for an output of ``kind`` (:func:`output_kind`) of ``stream``'s estimates: an
    :class:`OmegaWriter` (times ``stream.t0 + t``: as the file states them) or a
    :class:`~omegahat.io.rosbag.TwistBagWriter` (``frame_id`` default: the body frame the input names, else
    ``"body"``; ``topic`` default ``/omegahat/twist``). Both are context managers with ``write(chunk, omega,
    status)``: whole or absent."""
    if kind == "csv":
        return OmegaWriter(output, t0=stream.t0)
    from omegahat.io.rosbag import DEFAULT_TWIST_TOPIC, TwistBagWriter

    frame = frame_id or stream.meta.get("child") or "body"
    return TwistBagWriter(output, frame_id=frame, topic=topic or DEFAULT_TWIST_TOPIC, source=stream.meta.get("topic"))


def check_output(
    output: str | os.PathLike[str],
    input_path: str | os.PathLike[str],
    *,
    frame_id: str | None = None,
    topic: str | None = None,
) -> tuple[Path, str]:
    """``(path, kind)`` of an output for the input at ``input_path``, checked before any work: its kind from its
    name and the input's format (:func:`output_kind`), the path (:func:`check_output_path`), and that bag-only
    settings (``frame_id``, ``topic``: ``--frame-id``, ``--output-topic``) come with a bag output."""
    from omegahat.io.registry import detect_format

    kind = output_kind(output, detect_format(input_path).name)
    if kind == "csv" and (frame_id is not None or topic is not None):
        raise ValueError("--frame-id and --output-topic apply to bag outputs only")
    if kind != "csv" and Path(output).exists():
        raise FileExistsError(f"{output} exists; omegahat does not overwrite a bag (choose another output)")
    return check_output_path(output, [input_path]), kind


def check_output_path(output: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """Refuse, before any work, an output that cannot be written or that is one of ``inputs`` (module docstring)."""
    out = Path(output)
    for src in inputs:
        if _same_file(out, Path(src)):
            raise ValueError(f"the output {out} is the input log {src}; write the estimate to another file")
    if out.is_dir():
        raise ValueError(f"the output {out} is a directory; give a file name, e.g. {out / 'omega.csv'}")
    parent = out.parent if str(out.parent) else Path(".")
    if not parent.is_dir():
        raise ValueError(f"the output's directory {parent} does not exist; create it first (mkdir -p {parent})")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"the output's directory {parent} is not writable")
    if out.exists() and not os.access(out, os.W_OK):
        raise ValueError(f"the output {out} exists and is not writable")
    return out


class AtomicOutput:
    """A writer that is a context manager: :meth:`commit` on a clean exit (the output appears whole), :meth:`abort`
    on an exception (nothing appears). Subclasses implement ``write(chunk, omega, status)``, ``commit`` and
    ``abort``."""

    def commit(self) -> None:
        raise NotImplementedError

    def abort(self) -> None:
        raise NotImplementedError

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        if exc_type is None:
            self.commit()
        else:
            self.abort()


class OmegaWriter(AtomicOutput):
    """Chunked, atomic writer of ``t,wx,wy,wz,status`` (module docstring). Use as a context manager:
    the file appears on a clean exit, never on an exception. Each chunk is formatted and written by a
    background thread (PyArrow releases the GIL) while the caller computes the next; at most one chunk waits."""

    def __init__(self, path: str | os.PathLike[str], t0: float = 0.0):
        self.path = Path(path)
        self.t0 = t0
        parent = self.path.parent if str(self.path.parent) else Path(".")
        fd, tmp = tempfile.mkstemp(prefix=f".{self.path.name}.", suffix=".part", dir=parent)
        self._tmp = Path(tmp)
        self._f = os.fdopen(fd, "wb")
        self._f.write((HEADER + "\n").encode())
        self.rows = 0
        self._words = pa.array(STATUS_WORDS)
        self._options = pacsv.WriteOptions(include_header=False, quoting_style="none")
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="omegahat-writer")
        self._pending: Future[Any] | None = None  # the chunk being written

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None:
        """Append rows: the times of ``chunk`` (:class:`~omegahat.io.registry.LogChunk`, plus ``t0``),
        ``omega (m, 3)``, ``status (m,)`` codes UNAVAILABLE/CORRECTED/PREDICTED."""
        codes = pa.array(np.asarray(status, dtype=np.int8))
        t = chunk.t + self.t0 if self.t0 else chunk.t
        table = pa.table(
            {
                "t": np.ascontiguousarray(t, dtype=float),
                "wx": np.ascontiguousarray(omega[:, 0]),
                "wy": np.ascontiguousarray(omega[:, 1]),
                "wz": np.ascontiguousarray(omega[:, 2]),
                "status": pa.DictionaryArray.from_arrays(codes, self._words),
            }
        )
        self._wait()
        self._pending = self._pool.submit(pacsv.write_csv, table, self._f, self._options)
        self.rows += len(chunk)

    def _wait(self) -> None:
        if self._pending is not None:
            pending, self._pending = self._pending, None
            pending.result()  # re-raises a failed write here

    def describe(self) -> str:
        """What was written, for the command's closing line."""
        return f"{self.rows} estimates to {self.path} (t,wx,wy,wz,status; rad/s in body axes)"

    def commit(self) -> None:
        """Close the temporary file and move it onto the target (readable as the umask allows)."""
        try:
            self._wait()
        finally:
            self._pool.shutdown()
        self._f.close()
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(self._tmp, 0o666 & ~umask)
        os.replace(self._tmp, self.path)

    def abort(self) -> None:
        """Close and remove the temporary file; the target is left as it was."""
        try:
            self._wait()
        except Exception:
            pass
        self._pool.shutdown()
        if not self._f.closed:
            self._f.close()
        self._tmp.unlink(missing_ok=True)
