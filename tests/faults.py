"""Fault injection for the writers' tests: a disk that fills up after a given number of writes, and the chaos
suite's runs of ``omegahat estimate`` with a fault at every write, chunk or rename (:func:`disk_full_cases`,
:func:`signal_cases`, :func:`kill_cases`), shared by ``tests/test_chaos_writer.py`` and ``benchmarks/chaos.py``.

:func:`full_disk` replaces ``os.fdopen`` (through which :class:`omegahat.io.output.PartFile` hands a writer its
temporary file) by one whose file objects fail with ``ENOSPC``, as a full disk does, from their
``fail_at``-th ``write`` or ``flush`` call on (0: the first), counting the calls of every file opened while it is
active. It patches the public ``os`` function rather than a private name of omegahat: the writer only sees what a
real full disk would give it.
"""

from __future__ import annotations

import contextlib
import errno
import io
import os
from collections.abc import Iterator
from pathlib import Path


class FullDiskFile:
    """A binary file whose writes fail with ENOSPC once the shared counter reaches ``fail_at``."""

    def __init__(self, f, counter: list[int], fail_at: int):
        self._f, self._counter, self._fail_at = f, counter, fail_at

    def _fault(self) -> None:
        k = self._counter[0]
        self._counter[0] += 1
        if k >= self._fail_at:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def write(self, data) -> int:
        self._fault()
        return self._f.write(data)

    def flush(self) -> None:  # the buffered bytes reach the disk here: it can be full then too
        self._fault()
        self._f.flush()

    def __getattr__(self, name):  # flush, fileno, close, closed, ... of the real file
        return getattr(self._f, name)


@contextlib.contextmanager
def full_disk(fail_at: int) -> Iterator[list[int]]:
    """While active, files opened with ``os.fdopen(fd, "wb")`` fail their ``fail_at``-th write and every later
    one; yields the counter of write calls (``[n]``), so a caller can learn how many writes a run makes."""
    real = os.fdopen
    counter = [0]

    def fdopen(fd, mode="r", *args, **kwargs):
        f = real(fd, mode, *args, **kwargs)
        return FullDiskFile(f, counter, fail_at) if "w" in mode else f

    os.fdopen = fdopen
    try:
        yield counter
    finally:
        os.fdopen = real


# ------------------------------------------------------------------------- the writer's faults, case by case


PREVIOUS = "the previous complete result\n"


@contextlib.contextmanager
def patched(owner, name: str, value) -> Iterator[None]:
    """``owner.name = value`` while active (a monkeypatch usable outside a test: the benchmark runs these too)."""
    real = getattr(owner, name)
    setattr(owner, name, value)
    try:
        yield
    finally:
        setattr(owner, name, real)


@contextlib.contextmanager
def many_chunks(chunk_bytes: int = 1 << 12) -> Iterator[None]:
    """``omegahat estimate`` reading its input in chunks of ``chunk_bytes`` (many chunks for a small log; the
    default is the CSV reader's least chunk, so that a short log, quick to identify, has many)."""
    import omegahat.cli.estimate as cli_estimate
    from omegahat.io import ReadOptions

    with patched(cli_estimate, "ReadOptions", lambda **kw: ReadOptions(chunk_bytes=chunk_bytes, **kw)):
        yield


def short_log(folder: Path) -> Path:
    """``folder/log.csv``: 500 samples of a constant rate at 100 Hz (0.1 mrad of noise), 13 chunks under
    :func:`many_chunks`: the runs with a fault, one per write or chunk, each identify their model on a short head."""
    import numpy as np

    from logmaker import constant_rate, write_csv

    t = np.arange(500) / 100.0
    return write_csv(folder / "log.csv", t, constant_rate(t, np.array([0.1, -0.2, 0.3]), 1e-4))


def _parts(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".part"))


def _estimate(log: Path, dst: Path) -> tuple[int, str, str]:
    """``(exit status, standard output, standard error)`` of ``omegahat estimate LOG -o DST`` run in this process."""
    from omegahat.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["estimate", str(log), "-o", str(dst), "--no-progress"])
    return code, out.getvalue(), err.getvalue()


def judge(code: int, err: str, dst: Path, expect_code: int, expect_last: str) -> str:
    """The outcome of a run that had to fail: ``message`` (the expected one line and exit status, the output as
    it was, no temporary file), else what went wrong."""
    if "Traceback" in err or code not in (expect_code,):
        return "traceback"
    if _parts(dst.parent):
        return "leftover"
    if not dst.exists() or dst.read_text() != PREVIOUS:
        return "partial"
    return "message" if err.strip().splitlines()[-1].startswith(expect_last) else "unnamed"


def count_writes(log: Path, dst: Path) -> tuple[int, int]:
    """``(write calls, chunks written)`` of a clean run (with :func:`many_chunks` active, if wanted)."""
    from omegahat.io.output import OmegaWriter

    chunks = [0]
    real = OmegaWriter.write

    def counting(self, *a):
        chunks[0] += 1
        return real(self, *a)

    with patched(OmegaWriter, "write", counting), full_disk(10**9) as counter:
        code, _, err = _estimate(log, dst)
    assert code == 0, err
    return counter[0], chunks[0]


def disk_full_cases(log: Path, dst: Path) -> list[tuple[str, str]]:
    """The disk full at each write call of a run in turn: ``[(case, outcome)]``."""
    n, _ = count_writes(log, dst)
    cases = []
    for k in range(n):
        dst.write_text(PREVIOUS)
        with full_disk(k):
            code, _, err = _estimate(log, dst)
        want = f"omegahat estimate: error: cannot write {dst}: [Errno {errno.ENOSPC}]"
        cases.append((f"disk full at write {k}", judge(code, err, dst, 2, want)))
    return cases


def signal_cases(log: Path, dst: Path, sig: int) -> list[tuple[str, str]]:
    """``sig`` (SIGINT, SIGTERM) at each chunk of a run in turn: ``[(case, outcome)]``."""
    import signal

    from omegahat.io.output import OmegaWriter

    _, chunks = count_writes(log, dst)
    real = OmegaWriter.write
    calls = {"n": 0, "at": -1}

    def write(self, *a):
        if calls["n"] == calls["at"]:
            os.kill(os.getpid(), sig)
        calls["n"] += 1
        return real(self, *a)

    cases = []
    name = signal.Signals(sig).name
    with patched(OmegaWriter, "write", write):
        for at in range(chunks):
            dst.write_text(PREVIOUS)
            calls.update(n=0, at=at)
            code, _, err = _estimate(log, dst)
            want = f"omegahat estimate: interrupted by {name} (outputs are whole or absent)"
            cases.append((f"{name} at chunk {at}", judge(code, err, dst, 128 + sig, want)))
    return cases


def kill_cases(log: Path, dst: Path) -> list[tuple[str, str]]:
    """SIGKILL (a forked copy of this process) at each chunk and just before the final rename, each followed by a
    run that must remove the killed run's temporary file and write the output whole: ``[(case, outcome)]`` with
    outcome ``cleaned`` when all of that holds."""
    _, chunks = count_writes(log, dst)
    whole = dst.read_bytes()
    cases = []
    for at in range(chunks + 1):
        dst.write_text(PREVIOUS)
        status = _killed_child(log, dst, at, chunks)
        if not (os.WIFSIGNALED(status) and os.WTERMSIG(status) == 9):
            outcome = "traceback"  # not killed where it should have been
        elif dst.read_text() != PREVIOUS:
            outcome = "partial"
        else:
            code, out, err = _estimate(log, dst)
            cleaned = "removed 1 temporary file left by a killed run" in out
            if code != 0 or "Traceback" in err:
                outcome = "traceback"
            elif _parts(dst.parent) or not cleaned:
                outcome = "leftover"
            else:
                outcome = "cleaned" if dst.read_bytes() == whole else "partial"
        cases.append((f"SIGKILL at chunk {at}" if at < chunks else "SIGKILL before the rename", outcome))
    return cases


def _killed_child(log: Path, dst: Path, at: int, chunks: int) -> int:
    """Fork; the child runs the command and kills itself with SIGKILL at chunk ``at`` (``at == chunks``: just
    before the final rename). Returns the child's wait status (a child still running after two minutes is
    killed: status SIGKILL is then not what the caller expects only if it hung before ``at``)."""
    import signal
    import time

    from omegahat.io.output import OmegaWriter

    pid = os.fork()
    if pid == 0:  # the child: never returns
        try:
            calls = {"n": 0}
            real_write, real_replace = OmegaWriter.write, os.replace

            def write(self, *a):
                if calls["n"] == at:
                    os.kill(os.getpid(), signal.SIGKILL)
                calls["n"] += 1
                return real_write(self, *a)

            def replace(src, target):
                if at == chunks:
                    os.kill(os.getpid(), signal.SIGKILL)
                return real_replace(src, target)

            OmegaWriter.write = write  # type: ignore[method-assign]
            os.replace = replace
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, 1)
            os.dup2(devnull, 2)
            _estimate(log, dst)
        finally:
            os._exit(3)
    deadline = time.monotonic() + 120
    while True:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            return status
        if time.monotonic() > deadline:  # pragma: no cover - a child stuck after fork
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
            return 0
        time.sleep(0.01)
