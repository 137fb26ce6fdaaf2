r"""Running the files of a batch (:mod:`omegahat.cli.many`): here, on this machine's cores, or on a Dask cluster.

Each file is one call of the one-file function (:func:`run_job` around :func:`omegahat.cli.estimate.estimate_file`)
with a copy of the command's options whose input and output are the file's; what it reports is kept for the
summary, and an error becomes the file's row (its first line in the table, all of it in the report), so one bad
file never stops the others.

* ``--jobs 1``: in this process, one file after another.
* ``--jobs N`` (default: the cores this process may use, :func:`cores`): a pool of N processes
  (:func:`start_method`), larger files first, so that a long one does not finish alone at the end. Each process
  loads the compiled kernels from the cache once.
* ``--dask ADDRESS``: one task per file on the cluster's workers (``local``: a ``LocalCluster`` on this machine,
  one single-threaded process per core), as ``omegahat montecarlo --dask`` does. The workers read the inputs and
  write the outputs at the paths of this machine, so those must be on a file system they share.

**Stopping.** Ctrl-C or SIGTERM (the command's handlers raise ``KeyboardInterrupt``) sets a stop flag that every
file checks before it starts and after every chunk it writes: a file not started is not run (``not run``), one
running stops at its next chunk (``interrupted``) or finishes (``ok``); either way its output is whole or absent,
as the one-file command guarantees. The pool's processes ignore both signals themselves (Ctrl-C reaches the whole
process group), so that the flag alone decides; the flag is a ``multiprocessing`` event for the pool and a
``distributed.Event`` on a cluster. In ``--jobs 1`` the signal interrupts the file running (its output absent).
The interrupt is handed back (:func:`run_jobs`) to be raised once the summary is written.
"""

from __future__ import annotations

import argparse
import copy
import multiprocessing
import os
import re
import signal
import sys
import threading
import time
import uuid
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_completed
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Protocol

from tqdm import tqdm

from omegahat.cli import interrupted_by, pending_interrupt
from omegahat.io.registry import LogStream

__all__ = [
    "STATUSES",
    "SUMMARY_CSV",
    "SUMMARY_TXT",
    "Job",
    "OneFile",
    "Outcome",
    "Stopped",
    "Summary",
    "cores",
    "dask_jobs",
    "expected_error",
    "run_job",
    "run_jobs",
    "start_method",
]

STATUSES = ("ok", "failed", "kept", "interrupted", "not run")  #: an :class:`Outcome`'s status, in the tally's order
SUMMARY_CSV = "omegahat-summary.csv"  #: the batch's table, one row per input, beside the outputs
SUMMARY_TXT = "omegahat-summary.txt"  #: the table, the files skipped, and every file's report
_ABSENT = "stopped while running; no output written"
_EXPECTED = re.compile(r"expected RMS error ([0-9.eE+-]+) rad/s")
#: the identification's line (omegahat.identification.Identification.explain): both expected errors and which runs
_IDENTIFIED = re.compile(
    r"expected RMS error of the model's filter ([0-9.eE+-]+) rad/s, of backward differencing ([0-9.eE+-]+) rad/s: "
    r"(the model's filter|backward differencing) runs"
)
#: differencing's own expectation where it runs through the log's causal filter ((C2) of identification.causal)
_BY_SPECTRUM = re.compile(r"expected RMS error ([0-9.eE+-]+) rad/s by the log's spectrum")
#: the smoothers' closing line (omegahat.io.choice): the two expectations where both ran, or the Wiener smoother's
_SMOOTHED = re.compile(
    r"expected RMS error: the model's smoother ([0-9.eE+-]+) rad/s, the Wiener smoother ([0-9.eE+-]+) rad/s"
    r"|expected RMS error ([0-9.eE+-]+) rad/s (?:\(the model's account\)|by its spectrum's account)"
)


class Summary(Protocol):
    """What the table takes from a run's :class:`omegahat.io.pipeline.RunSummary` (the loop's own module is
    imported by the two shells over it only): the rows written, the gains' text, the closing lines."""

    rows: int
    gains_text: str
    lines: list[str]


class OneFile(Protocol):
    """The one-file function (:func:`omegahat.cli.estimate.estimate_file`)."""

    def __call__(
        self,
        args: argparse.Namespace,
        report: Callable[[str], None] = ...,
        on_chunk: Callable[[int], None] | None = ...,
        announce: Callable[[str], None] | None = ...,
    ) -> tuple[LogStream, Summary]: ...


@dataclass(frozen=True)
class Job:
    """A file to run: its place ``index`` in the batch, ``input`` and ``output`` paths (made absolute for a
    cluster, whose workers do not share this working directory), and both as the table shows them."""

    index: int
    input: str
    output: str
    shown: str
    name: str


@dataclass
class Outcome:
    """What came of one file: ``status`` ``ok``, ``failed`` (``message``: the error's first line), ``kept`` (its
    output existed), ``interrupted`` (stopped while running: no output) or ``not run`` (stopped before it began);
    the ``format`` read, ``rows`` written, the ``estimator`` and the ``expected`` RMS error (rad/s) when the run
    states one; ``notes`` (every note and warning), the full ``report`` and the ``seconds`` it took."""

    index: int
    shown: str
    output: str
    status: str
    message: str = ""
    format: str = ""
    rows: int | None = None
    estimator: str = ""
    expected: float | None = None
    notes: list[str] = field(default_factory=list)
    report: list[str] = field(default_factory=list)
    seconds: float = 0.0


class _Stop:
    """The stop flag as a file sees it: the pool's event (set in each process by :func:`_init_process`), a Dask
    event by name (made on the worker, where it reaches the scheduler), or none (in this process, Ctrl-C itself
    interrupts)."""

    process_event: Any = None

    def __init__(self, dask_name: str | None = None):
        self.dask_name = dask_name
        self._event: Any = None

    def is_set(self) -> bool:
        if self.dask_name is not None:
            if self._event is None:
                import distributed

                self._event = distributed.Event(self.dask_name)
            return bool(self._event.is_set())
        return _Stop.process_event is not None and _Stop.process_event.is_set()


def _init_process(event: Any) -> None:
    """In each pool process: Ctrl-C reaches it with the command (and SIGTERM may), but only the flag stops its
    file (cleanly)."""
    for s in (signal.SIGINT, signal.SIGTERM):  # the command's handlers, inherited by a forked process
        signal.signal(s, signal.SIG_IGN)
    _Stop.process_event = event


def _estimator(args: argparse.Namespace, stream: LogStream, summary: Summary) -> str:
    """The estimator and model of a run, for the table, from the options and the run's closing line."""
    model = "J given" if args.inertia is not None else "J = I"
    if args.preset is not None:
        return f"--preset {args.preset}" + (" --smooth" if args.smooth else "")
    if stream.kind == "directions" and stream.n_directions == 1:
        return f"one-direction observer, {model}"
    used = next((line for line in summary.lines if line.startswith(("estimator used: ", "gains used: "))), "")
    smooth = " --smooth" if args.smooth else ""
    if used.startswith("estimator used: omegahat"):
        return f"omegahat{smooth}, {model}"
    if used.startswith("estimator used: backward differencing"):
        return "backward differencing" + (", causal filter" if "causal filter" in used else "")
    if used.startswith("estimator used: the identified model's smoother"):
        return f"omegahat{smooth}, {model}"
    if used.startswith("estimator used: the log's own Wiener smoother"):
        return f"Wiener smoother{smooth}"
    if used.startswith("estimator used: the rotation spline"):
        return f"rotation spline{smooth}"
    return f"sarras, {model}"


def expected_error(estimator: str, summary: Summary, report: list[str]) -> float | None:
    """The expected RMS error the run stated for the estimator that ran: the fixed-gain observer's (its gains' line),
    the identification's for its model's filter or for backward differencing (the log's spectrum's account (C2) where
    the log has a spectrum, else differencing's (D1)), or (``--smooth``) the smoother's it
    kept (its closing line; None for the rotation spline, which states none)."""
    if estimator.startswith("sarras"):
        found = _EXPECTED.search(summary.gains_text)
        return float(found.group(1)) if found else None
    if " --smooth" in estimator:  # the smoother kept: its own expectation (the lower of the two where both ran)
        used = next((line for line in summary.lines if line.startswith("estimator used: ")), "")
        found = _SMOOTHED.search(used)
        values = [float(x) for x in found.groups() if x is not None] if found else []
        return min(values) if values else None
    found = next((m for line in report for m in [_IDENTIFIED.search(line)] if m), None)
    if found is None:
        return None
    if found.group(3) == "the model's filter":
        return float(found.group(1))
    spectrum = next((m for line in report for m in [_BY_SPECTRUM.search(line)] if m), None)
    return float(spectrum.group(1) if spectrum else found.group(2))  # (C2)'s account where the log has a spectrum


class Stopped(KeyboardInterrupt):
    """A file stopped by the batch's stop flag (not by a signal to the process running it)."""


def run_job(one: OneFile, args: argparse.Namespace, job: Job, stop: _Stop | None = None) -> Outcome:
    """Run one file as ``omegahat estimate`` does (module docstring). The file's own errors become its outcome;
    an interrupt of the process running it (Ctrl-C in ``--jobs 1``) is raised, the file's output being absent."""
    stop = _Stop() if stop is None else stop
    out = Outcome(job.index, job.shown, job.name, "not run")
    if stop.is_set():
        return out
    mine = copy.copy(args)
    mine.input, mine.output, mine.progress = Path(job.input), Path(job.output), False
    lines: list[str] = []

    def on_chunk(rows: int) -> None:
        if stop.is_set():
            raise Stopped("stopped")

    t0 = time.perf_counter()
    try:
        stream, summary = one(mine, report=lines.append, on_chunk=on_chunk, announce=lines.append)
    except (ValueError, OSError) as exc:  # the file's own error, as the one-file command prints it
        out.status, out.message = "failed", str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        lines.append(f"error: {exc}")
    except BaseException as exc:
        cause = interrupted_by(exc)  # an interrupt inside compiled code comes out wrapped in a SystemError
        if isinstance(cause, Stopped):
            out.status, out.message = "interrupted", _ABSENT
        elif cause is not None or not isinstance(exc, Exception):
            raise
        else:  # a bug: this file's row says so, the others go on
            out.status = "failed"
            out.message = f"internal error ({type(exc).__name__}: {exc}); please report it".splitlines()[0]
            lines.append(f"error: {out.message}")
    else:
        out.status, out.format, out.rows = "ok", stream.format, summary.rows
        out.estimator = _estimator(args, stream, summary)
        out.expected = expected_error(out.estimator, summary, lines)
    out.seconds = time.perf_counter() - t0
    out.report = lines
    out.notes = [line for line in lines if line.startswith(("note: ", "warning: "))]
    return out


def _bar(args: argparse.Namespace, total: int) -> tqdm:
    show = args.progress if args.progress is not None else sys.stderr.isatty()
    return tqdm(total=total, unit="file", desc="estimating", disable=not show, file=sys.stderr)


Ran = tuple[list[Outcome], KeyboardInterrupt | None, str]  #: outcomes, the interrupt that stopped the batch, where


def run_jobs(jobs: list[Job], args: argparse.Namespace, one: OneFile) -> Ran:
    """``(outcomes, interrupt, where it ran)`` of every job, in any order; ``interrupt``: the SIGINT or SIGTERM
    (a ``KeyboardInterrupt``) that stopped the batch, for the caller to raise once the summary is written."""
    if not jobs:
        return [], None, "(nothing to run)"
    if args.dask is not None:
        return _on_dask(jobs, args, one)
    n = min(args.jobs or cores(), len(jobs))
    if n == 1:
        return _here(jobs, args, one)
    return _in_pool(jobs, args, one, n)


def cores() -> int:
    """The cores this process may run on (its affinity, where the system has one), the default of ``--jobs``."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _here(jobs: list[Job], args: argparse.Namespace, one: OneFile) -> Ran:
    outcomes: list[Outcome] = []
    interrupt = None
    current: Job | None = None
    t0 = time.perf_counter()
    with _bar(args, len(jobs)) as bar:
        try:
            for job in jobs:
                current = job
                outcomes.append(run_job(one, args, job))
                bar.update()
                if (swallowed := pending_interrupt()) is not None:  # its raise was lost in a finalizer
                    raise swallowed
        except BaseException as exc:
            interrupt = interrupted_by(exc)
            if interrupt is None:
                raise
            _stopping()
            if current is not None and all(o.index != current.index for o in outcomes):
                outcomes.append(Outcome(current.index, current.shown, current.name, "interrupted", _ABSENT))
    done = {o.index for o in outcomes}
    outcomes += [Outcome(j.index, j.shown, j.name, "not run") for j in jobs if j.index not in done]
    return outcomes, interrupt, f"in {time.perf_counter() - t0:.1f} s in this process"


def _largest_first(jobs: list[Job]) -> list[Job]:
    def size(job: Job) -> int:
        try:
            return os.path.getsize(job.input)
        except OSError:
            return 0

    return sorted(jobs, key=size, reverse=True)


def _in_pool(jobs: list[Job], args: argparse.Namespace, one: OneFile, n: int) -> Ran:
    ctx = multiprocessing.get_context(start_method())
    event = ctx.Event()
    t0 = time.perf_counter()
    sys.stdout.flush()  # a forked process would print again what is still buffered
    sys.stderr.flush()
    with ProcessPoolExecutor(n, mp_context=ctx, initializer=_init_process, initargs=(event,)) as pool:
        # submitting starts the processes (all at once, with fork): before any thread (the bar's) exists here
        futures = [pool.submit(run_job, one, args, job) for job in _largest_first(jobs)]
        with _bar(args, len(jobs)) as bar:
            outcomes, interrupt = _collect(futures, futures_completed, lambda fs: [f.result() for f in fs], event, bar)
    return outcomes, interrupt, f"in {time.perf_counter() - t0:.1f} s on {n} processes"


def _collect(
    futures: list[Any],
    completed: Callable[[list[Any]], Any],
    results: Callable[[list[Any]], list[Outcome]],
    event: Any,
    bar: Any,
) -> tuple[list[Outcome], KeyboardInterrupt | None]:
    """The jobs' outcomes as they complete (``completed``: the pool's or Dask's iterator), the bar moved on each; an
    interrupt sets ``event`` (the jobs stop at their next chunk) and waits for every outcome (``results``) without
    being interrupted again: ``(outcomes, the interrupt or None)``."""
    outcomes: list[Outcome] = []
    interrupt = None
    try:
        for f in completed(futures):
            outcomes.append(f.result())
            bar.update()
            if (swallowed := pending_interrupt()) is not None:  # its raise was lost in a finalizer
                raise swallowed
    except KeyboardInterrupt as exc:
        interrupt = exc
        event.set()
        with _deaf():
            got = {o.index for o in outcomes}
            outcomes += [o for o in results(futures) if o.index not in got]
    return outcomes, interrupt


@contextmanager
def _deaf() -> Iterator[None]:
    """While the files stop: said once, and a second Ctrl-C (or SIGTERM) waits for them instead of abandoning them."""
    _stopping()
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)


def start_method() -> str:
    """How the pool's processes start: forked on Linux when this process runs no other thread (they begin with the
    command's modules imported: a second of CPU each saved), else spawned (a thread holding a lock while the
    process forks would leave that lock held in the child)."""
    return "fork" if sys.platform.startswith("linux") and threading.active_count() == 1 else "spawn"


def _stopping() -> None:
    print(
        "stopping: the files running stop at their next chunk or finish (whole or absent); the others are not started",
        file=sys.stderr,
    )


def _on_dask(jobs: list[Job], args: argparse.Namespace, one: OneFile) -> Ran:
    try:
        import distributed
    except ModuleNotFoundError as exc:  # pragma: no cover - exercised only without the extra
        raise ModuleNotFoundError("--dask needs the 'dask' extra: pip install \"omegahat[dask]\"") from exc
    t0 = time.perf_counter()
    jobs = [replace(j, input=os.path.abspath(j.input), output=os.path.abspath(j.output)) for j in jobs]
    if args.dask == "local":
        with distributed.LocalCluster(threads_per_worker=1, dashboard_address=None) as cluster:
            with distributed.Client(cluster) as client:
                outcomes, interrupt = dask_jobs(client, jobs, args, one)
    else:
        with distributed.Client(args.dask) as client:
            outcomes, interrupt = dask_jobs(client, jobs, args, one)
    return outcomes, interrupt, f"in {time.perf_counter() - t0:.1f} s on the Dask cluster {args.dask}"


def dask_jobs(
    client: Any, jobs: list[Job], args: argparse.Namespace, one: OneFile
) -> tuple[list[Outcome], KeyboardInterrupt | None]:
    """Every job as a task on ``client``'s cluster: ``(outcomes, the interrupt that stopped them or None)``."""
    import distributed

    name = f"omegahat-stop-{uuid.uuid4().hex}"
    event = distributed.Event(name, client=client)
    stop = _Stop(name)
    futures = [client.submit(run_job, one, args, job, stop, pure=False) for job in _largest_first(jobs)]
    with _bar(args, len(jobs)) as bar:
        return _collect(futures, distributed.as_completed, client.gather, event, bar)
