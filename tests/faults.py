"""Fault injection for the writers' tests: a disk that fills up after a given number of writes.

:func:`full_disk` replaces ``os.fdopen`` (through which :class:`omegahat.io.output.PartFile` hands a writer its
temporary file) by one whose file objects fail with ``ENOSPC``, as a full disk does, from their
``fail_at``-th ``write`` or ``flush`` call on (0: the first), counting the calls of every file opened while it is
active. It patches the public ``os`` function rather than a private name of omegahat: the writer only sees what a
real full disk would give it.
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator


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
