"""The time this process spends compiling kernels, measured, and a notice when it starts: the wait said whole.

A listener on Numba's ``numba:compile`` events (fired for compilations only: a kernel loaded from the cache fires
none) adds up the wall time of the outermost compilations (a kernel compiling the kernels it calls counts once) in
:func:`seconds`, and calls the notice set by :func:`announce_with` once, when a compilation has gone on for
:data:`NOTICE_DELAY` seconds (a brief one, such as the discarded first attempt of a kernel that asks for literal
arguments before it loads from the cache, says nothing). The
commands report both with :func:`process_seconds`, the time since the process started (imports included): the
user reads how long the run took in all and how much of it was compiling, not a part of the wait.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Callable, Iterator

from numba.core import event

__all__ = ["NOTICE", "announce_with", "announced", "process_seconds", "seconds", "wait_note"]

NOTICE = "compiling kernels, once (later runs load them from the cache) ..."  #: what the notice says by default
_T_IMPORT = time.perf_counter()
clock = time.perf_counter  #: the compilations' clock (a test may stand another in)
NOTICE_DELAY = 0.5  #: seconds a compilation must last before the notice is said (0: at once)


class _Listener(event.Listener):
    """Times the outermost ``numba:compile`` events; announces the first."""

    def __init__(self) -> None:
        self.depth = 0
        self.t0 = 0.0
        self.total = 0.0
        self.notice: Callable[[str], None] | None = None
        self.timer: threading.Timer | None = None

    def _say(self) -> None:
        notice, self.notice = self.notice, None
        if notice is not None:
            notice(NOTICE)

    def on_start(self, ev: event.Event) -> None:
        self.depth += 1
        if self.depth == 1:
            self.t0 = clock()
            if self.notice is not None and NOTICE_DELAY <= 0.0:
                self._say()
            elif self.notice is not None:
                self.timer = threading.Timer(NOTICE_DELAY, self._say)
                self.timer.daemon = True
                self.timer.start()

    def on_end(self, ev: event.Event) -> None:
        self.depth -= 1
        if self.depth == 0:
            self.total += clock() - self.t0
            if self.timer is not None:
                self.timer.cancel()  # not said yet if it was brief: the next compilation may say it
                self.timer = None


_LISTENER = _Listener()
event.register("numba:compile", _LISTENER)


def seconds() -> float:
    """Wall seconds this process has spent compiling kernels so far (0 when everything came from the cache)."""
    return _LISTENER.total


def announce_with(notice: Callable[[str], None] | None) -> None:
    """Call ``notice(NOTICE)`` when the next compilation starts, once (None: no notice)."""
    _LISTENER.notice = notice


def _on_stderr(notice: str) -> None:
    print(notice, file=sys.stderr, flush=True)


@contextlib.contextmanager
def announced(notice: Callable[[str], None] | None = None) -> Iterator[None]:
    """While active, the notice of :func:`announce_with` is said once when a compilation starts, by ``notice``
    (None: printed on standard error), and no longer after: a command's work, with the wait said whole."""
    announce_with(notice or _on_stderr)
    try:
        yield
    finally:
        announce_with(None)


def process_seconds() -> float:
    """Wall seconds since this process started (Linux: from ``/proc``; elsewhere since omegahat's kernels were
    imported, which misses the interpreter's start-up)."""
    try:
        with open("/proc/self/stat") as f:
            start_ticks = int(f.read().rsplit(")", 1)[1].split()[19])
        with open("/proc/uptime") as f:
            uptime = float(f.read().split()[0])
        return max(0.0, uptime - start_ticks / os.sysconf("SC_CLK_TCK"))
    except (OSError, ValueError, IndexError):
        return time.perf_counter() - _T_IMPORT


def wait_note(compiled_before: float) -> str:
    """``"; T s in all, C s of it compiling the kernels (once: …)"`` when this process compiled for more than half a
    second since :func:`seconds` was ``compiled_before`` (T: :func:`process_seconds`, C: the compilation since),
    else ``""``: the closing words of a command's report."""
    c = seconds() - compiled_before
    if c <= 0.5:
        return ""
    return (
        f"; {process_seconds():.1f} s in all, {c:.1f} s of it compiling the kernels (once: later runs load them from "
        "the cache)"
    )
