r"""From an open log to written estimates: the one loop of ``omegahat estimate`` and :func:`omegahat.estimate_frame`.

:func:`estimate_stream` takes a :class:`~omegahat.io.registry.LogStream` (any format, already converted and
checked by :func:`~omegahat.io.registry.open_log`: time unit, rotation convention, timestamp policy) and a writer
(:func:`omegahat.io.output.open_output`, or the DataFrame collector of :mod:`omegahat.io.frames`), and does, in
order:

1. **What was read**: the stream's description (``detected OptiTrack Motive CSV ...``) and notes are reported;
   the settings' combinations are checked (:meth:`~omegahat.io.settings.EstimateSettings.check`).
2. **The head** (the first :data:`omegahat.observer.autogain.HEAD_SAMPLES` samples) of an attitude or
   multi-direction stream is checked by the estimator's own compiled checks on a throwaway estimator, which also
   compiles (or loads from the cache) the kernels the run needs, announced when it takes long.
3. **The estimator**, by one picker per kind of stream: :func:`omegahat.io.choice.attitude_choice` (from the head:
   gains, start, model) or :func:`omegahat.io.single_direction.single_direction_choice` (one direction).
4. **Estimation**, the same loop whatever the estimator (:class:`omegahat.interface.Estimator`): a streaming one
   chunk by chunk (memory does not grow with the log), a batch one (the smoother) over the whole stream read
   first; each chunk is written with the estimator's own per-row statuses (:class:`omegahat.interface.Status`). A
   sample that is not a rotation stops the run with a message naming its line and column and the options that
   would accept or skip it, unless ``skip_bad_samples`` (:class:`BadSamples`): then it is treated as missing,
   counted and reported. An isolated spike (:mod:`omegahat.identification.spikes`: one attitude far from both
   neighbours, a marker swap) is treated as missing before the estimator reads it, and a reset of the attitude
   source (one step far larger than those beside it; an iPhone's CoreMotion attitude jumped 130° in one 9 ms step)
   is stitched, the attitudes after it turned back (:class:`~omegahat.io.screen.TurnScreen`, which holds each
   chunk's last two rows back until their successors are read); both are counted. Gaps longer than twice the
   median spacing are counted, and so are jumps: consecutive attitudes more than :data:`JUMP_ANGLE` apart, a turn
   faster than the samples can follow or a reset beside a missing sample.
5. **Summary**: rows written, samples skipped and why, bad samples, gaps, jumps, spikes, resets, what ran.

The loop knows options by their keys only; messages name them through the caller's spelling (``spell``,
:mod:`omegahat.io.settings`: ``rotation_tol=0.02`` from Python, ``--rotation-tol 0.02`` from the command), and an
error that a setting would solve carries the ``(key, suggested value)`` pairs as its ``options``.
"""

from __future__ import annotations

import math
import re
import sys
import time
import warnings
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from omegahat import measurements as ms
from omegahat.identification.spikes import GAP
from omegahat.interface import Estimate, Status
from omegahat.io.choice import attitude_choice, references
from omegahat.io.columns import LogFormatError
from omegahat.io.held import HeldSamples
from omegahat.io.registry import LogChunk, LogStream, prefetch
from omegahat.io.screen import JUMP_ANGLE, TurnScreen, largest_of
from omegahat.io.settings import Choice, EstimateSettings, Spelling, naming
from omegahat.io.single_direction import single_direction_choice
from omegahat.kernels import compiling
from omegahat.observer import autogain
from omegahat.observer.compiled import SkippedSamplesWarning
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.single_direction import LostExcitationWarning

__all__ = ["BadSamples", "ChunkWriter", "EstimateSettings", "RunSummary", "estimate_stream"]


class ChunkWriter(Protocol):
    """What :func:`estimate_stream` writes through (inside a ``with`` block): :class:`omegahat.io.OmegaWriter`,
    :class:`omegahat.io.rosbag.TwistBagWriter`, or the DataFrame collector of :mod:`omegahat.io.frames`;
    a writer that has a ``describe()`` method says with it what it wrote."""

    def write(self, chunk: LogChunk, omega: np.ndarray, status: np.ndarray) -> None: ...


@dataclass
class RunSummary:
    """What :func:`estimate_stream` did: ``rows`` written, the ``gains`` and the ``gains_text`` saying why,
    ``n_skipped`` samples skipped by the estimator (of which ``n_collinear`` with nearly collinear directions),
    ``n_bad`` treated as missing (``skip_bad_samples``), ``gaps`` and the ``largest_gap`` ``(seconds, label after
    it)``, ``jumps`` (consecutive attitudes more than :data:`JUMP_ANGLE` apart) and the ``largest_jump`` ``(rad,
    label after it)``, isolated ``spikes`` (:mod:`omegahat.identification.spikes`) and the ``largest_spike`` ``(rad,
    its label)``, ``resets`` of the attitude source stitched and the ``largest_reset`` ``(rad, label after it)``,
    ``elapsed`` seconds estimating, ``compile_s`` seconds checking the head (compilation included), ``output``: what
    the writer says it wrote (its ``describe()``), and ``lines``: the report."""

    rows: int = 0
    output: str = ""
    gains: ObserverGains | None = None
    gains_text: str = ""
    n_skipped: int = 0
    n_collinear: int = 0
    n_bad: int = 0
    gaps: int = 0
    largest_gap: tuple[float, int | None] = (0.0, None)
    jumps: int = 0
    largest_jump: tuple[float, int | None] = (0.0, None)
    spikes: int = 0
    largest_spike: tuple[float, int | None] = (0.0, None)
    held: int = 0  # rows that repeat the attitude exactly, read as missing (io.held), and their line
    held_line: str = ""
    resets: int = 0
    largest_reset: tuple[float, int | None] = (0.0, None)
    elapsed: float = 0.0
    reference: list[float] = field(default_factory=lambda: [0.0, 0.0, 0.0])  # Σ|ω̂ − ω_ref|², Σ|ω_ref|², samples
    compile_s: float = 0.0
    lines: list[str] = field(default_factory=list)


class BadSamples:
    """Rejected samples: checked chunk by chunk, dropped (NaN) with ``skip_bad_samples``, else an error naming the
    line (index, message, frame, row), the attitude's columns and the options (:func:`ms.describe_rejection
    <omegahat.measurements.describe_rejection>`, the one table of messages)."""

    def __init__(self, settings: EstimateSettings, stream: LogStream, spell: Spelling = ms.python_option) -> None:
        self.settings, self.stream, self.spell, self.count = settings, stream, spell, 0
        self.first: list[tuple[int, str]] = []  # (label, why) of the first few bad samples, for the summary

    def _why(self, status: int, info: float, where: str) -> str:
        s = self.settings
        tolerances = (s.rotation_tol, s.quat_norm_tol)
        return ms.describe_rejection(status, info, where, option=self.spell, skip=True, tolerances=tolerances)

    def check(self, chunk: LogChunk) -> None:
        s, stream = self.settings, self.stream
        data = chunk.data
        if stream.kind == "directions" and stream.n_directions == 1:
            data = np.concatenate([data, data], axis=1)  # one direction: its own checks (twice: no pair to test)
        st, info = ms.sample_status(
            data, directions=stream.kind == "directions", rotation_tol=s.rotation_tol, quat_norm_tol=s.quat_norm_tol
        )
        bad = np.flatnonzero(st >= ms.ERROR)
        if not bad.size:
            return
        k = int(bad[0])
        if not s.skip_bad_samples:
            where = stream.where(int(chunk.labels[k]), stream.attitude_name)
            accept = ms.suggested_tolerance(int(st[k]), float(info[k]))
            options = (("skip_bad_samples", True),) + ((accept,) if accept else ())
            raise naming(LogFormatError(self._why(int(st[k]), float(info[k]), where)), *options)
        chunk.data[bad] = np.nan
        self.count += bad.size
        for j in bad[: max(0, 5 - len(self.first))]:
            label = int(chunk.labels[j])
            self.first.append((label, self._why(int(st[j]), float(info[j]), f"{stream.label} {label}")))


def _check_head(head: list[LogChunk], stream: LogStream, refs: np.ndarray, bad: BadSamples) -> None:
    """Validate the head with the estimator's own compiled checks (a throwaway estimator: this also compiles, or
    loads from the cache, the kernels the run needs); only if it rejects a sample are the samples checked one by one
    (:class:`BadSamples`)."""
    settings = bad.settings
    probe = SarrasEstimator(
        np.eye(3),
        gains=ObserverGains.constant(1.0, 1.0, n=refs.shape[0]),
        references=refs,
        measurement="directions" if stream.kind == "directions" else "attitude",
        warm_start=False,
        rotation_tol=settings.rotation_tol,
        quat_norm_tol=settings.quat_norm_tol,
    )
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)
        for c in head:
            try:
                probe.run(c.t, c.data, c.torque)
            except ms.MeasurementError:
                bad.check(c)  # raises naming the line, or (skip_bad_samples) turns bad samples into missing
                probe.run(c.t, c.data, c.torque)


class _Run:
    """One pass over the stream with any estimator: bad samples, estimation, gaps, output (state across chunks)."""

    def __init__(
        self,
        choice: Choice,
        stream: LogStream,
        writer: ChunkWriter,
        bad: BadSamples,
        summary: RunSummary,
        head: list[LogChunk],
    ) -> None:
        self.choice, self.est, self.stream, self.writer, self.bad = choice, choice.estimator, stream, writer, bad
        self.summary = summary
        self.gap_limit = np.inf if choice.spacing is None else GAP * choice.spacing
        self.t_prev: float | None = None
        turns = stream.kind in ("quaternion", "matrix")  # attitudes: the spikes, resets and jumps of the rows read
        self.screen = TurnScreen(bad.settings, summary, [c.data for c in head], choice.spacing) if turns else None

    def _estimate(self, t: np.ndarray, data: np.ndarray, torque: np.ndarray | None) -> Estimate:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkippedSamplesWarning)  # counted and reported once, at the end
            warnings.simplefilter("ignore", LostExcitationWarning)  # summarised once, at the end
            return self.est.run(t, data, torque)

    def _checked(self, chunks: list[LogChunk]) -> Estimate:
        """The estimate over ``chunks`` (one, or the whole stream for a batch estimator): a sample that is not a
        rotation is found (line, column) and skipped, or stops the run there."""
        t0, c0 = time.perf_counter(), compiling.seconds()
        join = (lambda xs: xs[0]) if len(chunks) == 1 else np.concatenate
        t, data = join([c.t for c in chunks]), join([c.data for c in chunks])
        torque = None if chunks[0].torque is None else join([c.torque for c in chunks])
        try:
            est = self._estimate(t, data, torque)
        except ms.MeasurementError:  # run() is atomic: the estimator is as before the call
            for chunk in chunks:
                self.bad.check(chunk)  # raises naming the line, or turns bad samples into missing (in place)
            est = self._estimate(t, join([c.data for c in chunks]), torque)
        except ValueError as exc:  # not expected after the reader's checks; name the line anyway
            labels = join([c.labels for c in chunks])
            raise ValueError(
                re.sub(r"sample (\d+)", lambda m: f"{self.stream.label} {labels[int(m.group(1))]}", str(exc))
            ) from None
        self.summary.elapsed += time.perf_counter() - t0 - (compiling.seconds() - c0)  # compiling is not estimating
        return est

    def write(self, chunk: LogChunk, est: Estimate) -> None:
        s = self.summary
        if self.choice.after_chunk is not None:
            self.choice.after_chunk(chunk, est)
        # an estimator's contract: NaN exactly where there is no estimate; a row without a finite estimate is never
        # labelled as one (belt and braces: the compiled steps' guard already ensures it)
        no_rate = ~np.all(np.isfinite(est.omega), axis=1) & np.isin(est.status, (Status.CORRECTED, Status.PREDICTED))
        if no_rate.any():
            est = Estimate(est.omega, np.where(no_rate, np.int8(Status.UNAVAILABLE), est.status))
        self.writer.write(chunk, est.omega, est.status)
        s.rows += len(chunk)
        if chunk.extra is not None and "reference_rate" in chunk.extra:  # the log's own rates, to compare with
            ref = chunk.extra["reference_rate"]
            both = np.all(np.isfinite(ref), axis=1) & np.all(np.isfinite(est.omega), axis=1)
            s.reference[0] += float(np.sum((est.omega[both] - ref[both]) ** 2))
            s.reference[1] += float(np.sum(ref[both] ** 2))
            s.reference[2] += int(both.sum())
        if self.t_prev is None and self.choice.spacing is None and len(chunk) > 1:
            self.gap_limit = GAP * float(np.median(np.diff(chunk.t)))
        dt = np.diff(chunk.t if self.t_prev is None else np.concatenate([[self.t_prev], chunk.t]))
        big = np.flatnonzero(dt > self.gap_limit)
        s.gaps += big.size
        after = big + (1 if self.t_prev is None else 0)  # the row after each gap (dt[0] is the carried one's)
        s.largest_gap = largest_of(s.largest_gap, after, dt[big], chunk.labels)
        self.t_prev = float(chunk.t[-1])

    def _screened(self, chunk: LogChunk | None) -> LogChunk | None:
        """The rows ready for the estimator once ``chunk`` is read (None: the end of the stream), if any."""
        if self.screen is None:
            return chunk
        return self.screen.feed(chunk) if chunk is not None else self.screen.finish()

    def feed(self, chunk: LogChunk | None) -> None:
        """A streaming estimator: one chunk (None: the end of the stream, the rows the spike screen held back)."""
        ready = self._screened(chunk)
        if ready is not None:
            self.write(ready, self._checked([ready]))

    def feed_all(self, chunks: list[LogChunk]) -> None:
        """A batch estimator: the whole stream at once, written chunk by chunk (``chunks`` emptied on the way)."""
        screened = [ready for chunk in [*chunks, None] if (ready := self._screened(chunk)) is not None]
        chunks.clear()
        est = self._checked(screened)
        start = 0
        while screened:
            chunk = screened.pop(0)
            stop = start + len(chunk)
            self.write(chunk, Estimate(est.omega[start:stop], est.status[start:stop]))
            start = stop


def _head(chunks) -> list[LogChunk]:
    """Chunks from the start until HEAD_SAMPLES rows (kept for the real pass)."""
    head, rows = [], 0
    for chunk in chunks:
        head.append(chunk)
        rows += len(chunk)
        if rows >= autogain.HEAD_SAMPLES:
            break
    return head


def estimate_stream(
    stream: LogStream,
    settings: EstimateSettings,
    open_writer: Callable[[LogStream], AbstractContextManager[ChunkWriter]],
    report: Callable[[str], None] = print,
    progress: Callable[[int], None] | None = None,
    announce: Callable[[str], None] | None = None,
    spell: Spelling = ms.python_option,
) -> RunSummary:
    """Estimate the rate of every sample of ``stream`` and write it (module docstring: the steps).

    ``open_writer(stream)`` makes the writer (a context manager with ``write(chunk, omega, status)``; the output
    is whole or absent); it is called only once the head has been checked and the estimator chosen. ``report`` gets
    what was read and chosen as it happens; the closing lines (what the timestamp policy changed, samples skipped,
    gaps, what ran) are in the returned ``RunSummary.lines``. ``progress(rows)`` is called after each chunk;
    ``announce`` (default: standard error) gets the notice that the kernels are being compiled; ``spell(key,
    value)`` names options in messages (default: as Python does). Raises :class:`~omegahat.io.LogFormatError` or
    ``ValueError`` naming the place and the option to use (and carrying it: ``exc.options``).
    """
    if stream.description:
        report(f"detected {stream.description}")
    for note in stream.notes:
        report(f"note: {note}")
    n_notes = len(stream.notes)
    settings.check(spell)
    summary = RunSummary()
    compiled_before = compiling.seconds()
    with compiling.announced(announce):  # said when a compilation starts (the head's check, a chunk)
        bad = BadSamples(settings, stream, spell)
        held = HeldSamples()
        source = held.screen(stream.chunks())  # rows that repeat an attitude exactly, set missing (io.held)
        head: list[LogChunk] = []
        if stream.kind == "directions" and stream.n_directions == 1:  # one direction: its own observer (no attitude)
            if settings.preset is not None:
                raise ValueError(f"{spell('preset', settings.preset)} needs attitudes or two directions or more")
            choice = single_direction_choice(stream, settings, report, spell)
            chunks = prefetch(source)
        else:
            head = _head(source)  # read here, not ahead: what was read so far is the head's (its share of the log)
            head_done = stream.done
            chunks = prefetch(source)  # the rest is read while the kernels compile
            refs = references(settings, stream, spell)
            _check_head(head, stream, refs, bad)
            choice = attitude_choice(stream, settings, head, report, spell, head_done)
        summary.gains, summary.gains_text = choice.gains, choice.gains_text
        est = choice.estimator
        with open_writer(stream) as writer:
            job = _Run(choice, stream, writer, bad, summary, head)
            if not est.streaming:  # the whole stream first (a smoother runs backwards too)
                job.feed_all([*head, *chunks])
                head.clear()
            while head:  # the head first (releasing it as it goes), then the rest of the stream
                job.feed(head.pop(0))
            for chunk in chunks:
                job.feed(chunk)
                if progress is not None:
                    progress(summary.rows)
            job.feed(None)  # the rows held back at the end
    summary.compile_s = compiling.seconds() - compiled_before
    describe = getattr(writer, "describe", None)
    summary.output = describe() if describe is not None else f"{summary.rows} estimates"
    summary.n_skipped, summary.n_collinear, summary.n_bad = est.n_skipped, getattr(est, "n_collinear", 0), bad.count
    summary.held, summary.held_line = held.count, held.closing(stream.label)
    summary.lines = _summary_lines(summary, choice, stream, bad, spell, stream.notes[n_notes:])
    return summary


def _summary_lines(s: RunSummary, choice: Choice, stream, bad: BadSamples, spell: Spelling, notes) -> list[str]:
    lines = [f"note: {note}" for note in notes]  # what the timestamp policy changed, known once the stream is read
    missing = s.n_skipped - s.n_collinear - s.spikes - s.resets - s.held  # set missing: said on their own lines
    if missing > 0 or s.n_collinear:
        lines.append(
            f"skipped {missing + s.n_collinear} of {s.rows} samples ({missing} missing, {s.n_collinear} with nearly "
            "collinear directions): predicted through (status 'predicted')"
            + (  # rows of other sensors in one table (PlotJuggler's export of several topics): say where they come from
                "; most rows have no attitude at all, as where a table interleaves other sensors' rows (an export of "
                "several topics): their estimates are predictions at those rows' times, and a table of the attitude "
                "alone has them at its own"
                if 2 * missing > s.rows
                else ""
            )
        )
    n_restarts = getattr(choice.estimator, "n_restarts", 0)
    if n_restarts:
        lines.append(
            f"restarted {n_restarts} times: a step's result was not finite (a gap too long for the model, a "
            "torque or gains too large); no estimate there until the next warm start (status 'restarted')"
        )
    if bad.count:
        first = "; ".join(f"{why.split(' (')[0]}" for _, why in bad.first)
        lines.append(f"{spell('skip_bad_samples', None)}: {bad.count} bad samples treated as missing (first: {first})")
    if s.gaps:
        lines.append(
            f"gaps: {s.gaps} intervals longer than twice the median spacing; the longest {s.largest_gap[0]:.4g} s "
            f"before {stream.label} {s.largest_gap[1]} (predicted through)"
        )
    if s.jumps:
        lines.append(
            f"jumps: {s.jumps} step{'s' if s.jumps > 1 else ''} between consecutive samples turn"
            f"{'' if s.jumps > 1 else 's'} the attitude more than {math.degrees(JUMP_ANGLE):.0f}°; the largest "
            f"{math.degrees(s.largest_jump[0]):.0f}° before {stream.label} {s.largest_jump[1]}: faster than the "
            "samples can follow, or a reset or glitch of the attitude source (the rates there are not the body's)"
        )
    if s.held:
        lines.append(s.held_line)
    if s.spikes:
        lines.append(
            f"spikes: {s.spikes} isolated sample{'s' if s.spikes > 1 else ''} far from both neighbours, which agree "
            f"with each other; the largest {math.degrees(s.largest_spike[0]):.3g}° off at {stream.label} "
            f"{s.largest_spike[1]}: a marker swap or a misread frame, treated as missing (predicted through, status "
            "'predicted')"
        )
    if s.resets:
        lines.append(
            f"resets: {s.resets} step{'s' if s.resets > 1 else ''} far larger than the steps beside "
            f"{'them' if s.resets > 1 else 'it'}; the largest {math.degrees(s.largest_reset[0]):.3g}° before "
            f"{stream.label} {s.largest_reset[1]}: the attitude source restarted from another reference; the "
            "attitudes after it turned back to continue the body's steps, the sample it reached treated as missing "
            "(status 'predicted')"
        )
    if s.reference[2]:
        diff, scale, n = s.reference
        against = stream.meta.get("reference_rate", "the log's own rates")
        lines.append(
            f"against {against}: RMS difference "
            f"{math.sqrt(diff / n):.3g} rad/s over {n:.0f} samples (their own RMS {math.sqrt(scale / n):.3g} rad/s)"
        )
    return [*lines, *choice.closing(), choice.used()]


def _stderr(text: str) -> None:
    print(text, file=sys.stderr)
