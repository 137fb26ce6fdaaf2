"""The estimate's output: whole or absent, checked before any work, never a temporary file left behind.

**Checks before any work** (:func:`check_output_path`): the output's directory must exist and be writable, the
output must not be a directory, and it must not be the input (compared as files, so ``./log.csv``,
``../dir/log.csv`` and a symbolic link to it are all caught). Which writer a name asks for (``.csv``, ``.bag``, a
ROS 2 bag directory) is the writers' registry's business (:mod:`omegahat.io.writers`).

**Whole or absent.** Every writer writes into a temporary file (or folder) *in the target's directory*, named
``.NAME.TOKEN.part``, and renames it onto the target only when everything is written (``os.replace`` is atomic
within a directory): a run that fails, is interrupted (SIGINT, SIGTERM) or finds the disk full leaves the target
as it was (absent, or the previous complete file) and removes its temporary file, and an error says which output
could not be written. A run that is *killed* (SIGKILL, power loss) cannot clean up: the next run writing the same
output removes the temporary files of runs that are gone (:func:`remove_stale_parts`; a writer holds a lock on
its temporary file while it lives, so a run writing the same output at the same time is left alone).

**A symbolic link** as the output is written *through*: the link stays and its target gets the new content (as a
shell's ``>`` does), the temporary file beside the target so that the rename stays atomic (a dangling link too).

:class:`OmegaWriter` writes ``t,wx,wy,wz,status`` (s, rad/s in body axes, one word) chunk by chunk. ``status``
says what each row is:

* ``corrected``: the estimate after a measured sample;
* ``predicted``: no usable sample at that time (missing, skipped, held, nearly collinear directions): predicted;
* ``unavailable``: no estimate yet (before the first valid sample, and at it: one attitude gives no rate; with a
  warm start until the second); the rate columns are ``nan`` there, never 0;
* ``restarted``: the estimator could not take the step to this sample (its result was not finite: a gap too long
  for the model, a torque or gains too large) and started again from it; ``nan`` there, then ``unavailable`` until
  the restart's warm start gives an estimate again.

:func:`staged_folder` gives a folder of files the same guarantee, :func:`write_whole` a small file (a calibration).
"""

from __future__ import annotations

import contextlib
import os
import re
import secrets
import shutil
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any, BinaryIO, Self

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

from omegahat.interface import STATUS_WORDS, Status

try:  # POSIX: a writer's lock on its temporary file tells a later run that the file is still being written
    import fcntl
except ImportError:  # pragma: no cover - Windows: an open file cannot be deleted, which protects it as well
    fcntl = None  # type: ignore[assignment]

if TYPE_CHECKING:  # for annotations only (the registry is imported where it is used)
    from omegahat.io.registry import LogChunk

__all__ = [
    "CORRECTED",
    "PREDICTED",
    "RESTARTED",
    "STATUS_WORDS",
    "UNAVAILABLE",
    "AtomicOutput",
    "OmegaWriter",
    "PartFile",
    "WriteError",
    "check_output_folder",
    "check_output_path",
    "remove_stale_parts",
    "staged_folder",
    "target_of",
    "write_error",
    "write_whole",
]

# the estimators' statuses, one enum (omegahat.interface.Status; "restarted" too), written as their words
UNAVAILABLE, CORRECTED, PREDICTED, RESTARTED = Status.UNAVAILABLE, Status.CORRECTED, Status.PREDICTED, Status.RESTARTED
HEADER = "t,wx,wy,wz,status"
PART_SUFFIX = ".part"


def _same_file(a: Path, b: Path) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.normcase(os.path.realpath(a)) == os.path.normcase(os.path.realpath(b))


def _parent(path: Path) -> Path:
    return path.parent if str(path.parent) else Path(".")


def target_of(path: str | os.PathLike[str]) -> Path:
    """The file a name writes to: the name itself, or for a symbolic link the file it points to (module
    docstring)."""
    path = Path(path)
    return Path(os.path.realpath(path)) if path.is_symlink() else path


def check_output_path(
    output: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]] = (), what: str = "the estimate"
) -> Path:
    """Refuse, before any work, an output that cannot be written or that is one of ``inputs`` (every file the run
    reads; module docstring); ``what`` the output holds, for the message. Returns the output as given."""
    out = Path(output)
    for src in inputs:
        if _same_file(out, Path(src)):
            raise ValueError(f"the output {out} is the input {src}; write {what} to another file")
    target = target_of(out)
    shown = str(out) if target == out else f"{out} (a link to {target})"
    if target.is_dir():
        raise ValueError(f"the output {shown} is a directory; give a file name, e.g. {out / 'omega.csv'}")
    parent = _parent(target)
    if not parent.is_dir():
        raise ValueError(f"the output's directory {parent} does not exist; create it first (mkdir -p {parent})")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ValueError(f"the output's directory {parent} is not writable")
    if target.exists() and not os.access(target, os.W_OK):
        raise ValueError(f"the output {shown} exists and is not writable")
    return out


def check_output_folder(folder: str | os.PathLike[str], option: str = "--out") -> Path:
    """Refuse, before any work, an output folder that is a file or cannot be created or written (the
    laboratory's commands; ``option`` names it in the message)."""
    out = Path(folder)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{option} {out} is a file, not a folder; give a folder (created if absent)")
    probe = out
    while not probe.exists():  # the nearest existing ancestor must let us create the rest
        probe = _parent(probe) if probe != _parent(probe) else Path(".")
        if probe == Path(".") and not probe.exists():  # pragma: no cover - the working directory always exists
            break
    if not probe.is_dir():
        raise ValueError(f"{option} {out}: {probe} is a file, so the folder cannot be created")
    if not os.access(probe, os.W_OK | os.X_OK):
        raise ValueError(f"{option} {out}: {probe} is not writable")
    return out


class WriteError(OSError):
    """An output that could not be written (disk full, quota, I/O error), named, and left as it was."""

    def __str__(self) -> str:
        return self.strerror or super().__str__()


def write_error(exc: Exception, path: Path, left: str = "") -> WriteError:
    """``exc`` (a failed write) as a :class:`WriteError` naming the output and saying what was left (default:
    nothing written, the output as it was); an error that already is one is returned as it is."""
    if isinstance(exc, WriteError):
        return exc
    errno = getattr(exc, "errno", None)
    strerror = getattr(exc, "strerror", None)
    why = f"[Errno {errno}] {strerror}" if errno is not None and strerror else str(exc)
    left = left or f"nothing written; {path} is as it was before"
    return WriteError(errno, f"cannot write {path}: {why or type(exc).__name__} ({left})")


# ------------------------------------------------------------------------------------------- temporary files


def _part_pattern(name: str) -> re.Pattern[str]:
    return re.compile(rf"\.{re.escape(name)}\.[0-9a-f]{{16}}{re.escape(PART_SUFFIX)}")


def _lock(fd: int) -> bool:
    """Take the exclusive lock of an open temporary file or folder; False if a living writer holds it."""
    if fcntl is None:  # pragma: no cover - Windows
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


@contextlib.contextmanager
def _directory_lock(directory: Path) -> Iterator[None]:
    """Serialise creating and cleaning temporary files in ``directory`` (a new file is locked before a cleaner
    can see it unlocked)."""
    if fcntl is None:  # pragma: no cover - Windows
        yield
        return
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:  # not readable: no cleaning there, and creation reports its own error
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)


def remove_stale_parts(output: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files (and folders) of earlier runs writing ``output`` that are gone (killed: module
    docstring); returns what was removed. A temporary file another living run holds is left alone."""
    target = target_of(output)
    directory = _parent(target)
    pattern = _part_pattern(target.name)
    removed: list[Path] = []
    try:
        names = [n for n in os.listdir(directory) if pattern.fullmatch(n)]
    except OSError:
        return removed
    with _directory_lock(directory):
        for name in names:
            path = directory / name
            try:
                fd = os.open(path, os.O_RDONLY)
            except OSError:
                continue
            try:
                if not _lock(fd):
                    continue
                if path.is_dir():
                    shutil.rmtree(path)
                else:
                    path.unlink()
                removed.append(path)
            except OSError:  # Windows: an open file cannot be removed; elsewhere: not ours to remove
                pass
            finally:
                os.close(fd)
    return removed


def _remove_quietly(path: Path) -> None:
    """Remove a temporary file or folder, if it is there."""
    with contextlib.suppress(OSError):
        if path.is_dir():
            shutil.rmtree(path, ignore_errors=True)
        else:
            path.unlink(missing_ok=True)


class PartFile:
    """A locked temporary file (``folder=False``) or folder (``folder=True``) beside ``target``, named
    ``.NAME.TOKEN.part`` (module docstring): :attr:`path`; the lock is held until :meth:`release` (a folder) or
    until the file object of :meth:`open` is closed (a file)."""

    def __init__(self, target: Path, *, folder: bool = False):
        directory = _parent(target)
        with _directory_lock(directory):
            while True:
                path = directory / f".{target.name}.{secrets.token_hex(8)}{PART_SUFFIX}"
                try:
                    if folder:
                        os.mkdir(path, 0o700)
                        fd = os.open(path, os.O_RDONLY)
                    else:
                        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o600)
                except FileExistsError:  # pragma: no cover - 64 random bits
                    continue
                except BaseException:  # interrupted (Ctrl-C) once the name was taken: the name is ours (random)
                    _remove_quietly(path)
                    raise
                break
            try:
                _lock(fd)
            except BaseException:
                os.close(fd)
                _remove_quietly(path)
                raise
        self.path, self.fd, self.folder = path, fd, folder

    def open(self) -> BinaryIO:
        """The temporary file as a binary file object, which from now on owns the descriptor and its lock."""
        f = os.fdopen(self.fd, "wb")
        self.fd = -1
        return f

    def release(self) -> None:
        """Drop the lock of a folder (a file's goes with its file object)."""
        if self.fd >= 0:
            with contextlib.suppress(OSError):
                os.close(self.fd)
            self.fd = -1

    def discard(self) -> None:
        """Remove the temporary file or folder and release it."""
        _remove_quietly(self.path)
        self.release()

    def publish(self, f: BinaryIO, target: Path) -> None:
        """The file written through ``f`` (from :meth:`open`), on the disk, becomes ``target``, readable."""
        f.flush()
        os.fsync(f.fileno())  # the content is on the disk before the name says it is complete
        publish_mode(self.path)
        os.replace(self.path, target)  # while still locked: no cleaner can take it for stale


def write_whole(path: str | os.PathLike[str], write: Callable[[BinaryIO], object]) -> None:
    """A small output whole or absent: ``write(f)`` fills a locked temporary file, which then replaces ``path``."""
    part = PartFile(target_of(path))
    try:
        with part.open() as f:
            write(f)
            part.publish(f, target_of(path))
    except BaseException as exc:
        _remove_quietly(part.path)
        if isinstance(exc, OSError):
            raise write_error(exc, Path(path)) from exc
        raise


def publish_mode(path: Path) -> None:
    """Make a finished temporary file readable as the umask allows (``mkstemp``-like files are private)."""
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(path, 0o666 & ~umask)


# ------------------------------------------------------------------------------------------------- writers


class AtomicOutput:
    """A writer that is a context manager: :meth:`commit` on a clean exit (the output appears whole), :meth:`abort`
    on an exception (nothing appears). Subclasses implement ``write(chunk, omega, status)``, ``commit`` and
    ``abort``; a commit that fails must leave nothing behind (it aborts)."""

    #: temporary files of killed runs of the same output removed when this writer was opened
    removed_stale: list[Path]

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None:
        raise NotImplementedError

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

    def stale_note(self) -> str:
        """``"; removed 1 temporary file left by a killed run"`` for a closing line, or ``""``."""
        n = len(getattr(self, "removed_stale", ()))
        return f"; removed {n} temporary file{'s' if n > 1 else ''} left by a killed run" if n else ""


class OmegaWriter(AtomicOutput):
    """Chunked, atomic writer of ``t,wx,wy,wz,status`` (module docstring). Use as a context manager:
    the file appears on a clean exit, never on an exception. Each chunk is formatted and written by a
    background thread (PyArrow releases the GIL) while the caller computes the next; at most one chunk waits."""

    def __init__(self, path: str | os.PathLike[str], t0: float = 0.0):
        self.path = Path(path)
        self.target = target_of(self.path)
        self.t0 = t0
        self.removed_stale = remove_stale_parts(self.path)
        try:
            self._part = PartFile(self.target)
        except OSError as exc:
            raise write_error(exc, self.path) from exc
        self._f: BinaryIO | None = None
        self.rows = 0
        self._pool: ThreadPoolExecutor | None = None
        self._pending: Future[Any] | None = None  # the chunk being written
        try:  # until the writer is returned nobody else can abort it: an interrupt here (Ctrl-C) removes it too
            self._f = self._part.open()
            self._words = pa.array(STATUS_WORDS)
            self._begin()
            self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="omegahat-writer")
        except OSError as exc:
            self.abort()
            raise write_error(exc, self.path) from exc
        except BaseException:
            self.abort()
            raise

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None:
        """Append rows: the times of ``chunk`` (:class:`~omegahat.io.registry.LogChunk`, plus ``t0``),
        ``omega (m, 3)``, ``status (m,)`` codes UNAVAILABLE/CORRECTED/PREDICTED/RESTARTED."""
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
        assert self._pool is not None
        self._pending = self._pool.submit(self._put, table)
        self.rows += len(chunk)

    def _begin(self) -> None:
        """Start the file (the header); a subclass writing another format starts it here."""
        assert self._f is not None
        self._f.write((HEADER + "\n").encode())
        self._options = pacsv.WriteOptions(include_header=False, quoting_style="none")

    def _put(self, table: pa.Table) -> None:
        """Write one chunk's table (in the writer's thread)."""
        pacsv.write_csv(table, self._f, self._options)

    def _end(self) -> None:
        """Finish the file after its last chunk, before it is flushed and renamed (nothing to add to a CSV)."""

    def _wait(self) -> None:
        if self._pending is not None:
            pending, self._pending = self._pending, None
            try:
                pending.result()  # re-raises a failed write here
            except OSError as exc:
                raise write_error(exc, self.path) from exc

    def describe(self) -> str:
        """What was written, for the command's closing line."""
        link = "" if self.target == self.path else f" (a link: written to {self.target})"
        return f"{self.rows} estimates to {self.path}{link} (t,wx,wy,wz,status; rad/s in body axes){self.stale_note()}"

    def commit(self) -> None:
        """Write what is pending, flush to the disk, and move the temporary file onto the target (readable as the
        umask allows); on any failure nothing is left behind and the error names the output."""
        f = self._f
        assert f is not None  # set by __init__ or it raised
        try:
            self._wait()
            self._shutdown()
            self._end()
            self._part.publish(f, self.target)
        except OSError as exc:
            self.abort()
            raise write_error(exc, self.path) from exc
        except BaseException:
            self.abort()
            raise
        with contextlib.suppress(OSError):  # the content is on the disk and in place: closing cannot lose it
            f.close()

    def _shutdown(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def abort(self) -> None:
        """Close and remove the temporary file; the target is left as it was."""
        try:
            self._wait()
        except Exception:
            pass
        self._shutdown()
        if self._f is not None:
            with contextlib.suppress(OSError):  # a close that flushes onto a full disk fails too: nothing to keep
                self._f.close()
        self._part.discard()


@contextlib.contextmanager
def staged_folder(folder: str | os.PathLike[str]) -> Iterator[Path]:
    """A temporary folder beside ``folder`` to write a command's files into; on a clean exit each file is moved
    into ``folder`` (created if absent; files of the same names replaced, each atomically), on an exception
    nothing is moved and the temporary folder is removed (module docstring)."""
    out = Path(folder)
    try:
        _parent(out.absolute()).mkdir(parents=True, exist_ok=True)
        remove_stale_parts(out)
        part = PartFile(out.absolute(), folder=True)
    except OSError as exc:
        raise write_error(exc, out) from exc
    try:
        yield part.path
    except BaseException:
        part.discard()
        raise
    try:
        out.mkdir(parents=True, exist_ok=True)
        for entry in sorted(part.path.rglob("*")):
            if entry.is_dir():
                continue
            dest = out / entry.relative_to(part.path)
            dest.parent.mkdir(parents=True, exist_ok=True)
            publish_mode(entry)
            os.replace(entry, dest)
    except OSError as exc:
        part.discard()
        raise write_error(exc, out, "each file in it is whole: the new one, or as it was before") from exc
    except BaseException:
        part.discard()
        raise
    part.discard()
