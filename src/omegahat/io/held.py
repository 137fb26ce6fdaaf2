"""Attitudes held between a sensor's updates: rows that repeat the previous attitude exactly, read as missing.

A log written faster than its attitude updates (a topic republished at a higher rate, a table forward-filled onto
a common clock) repeats each attitude, bit for bit, until the next one comes. Read as samples, a repeat says that the
body did not turn over that step, and the next update says that it turned by the whole interval's angle in one: the
differences swing between zero and several times the rate (a 10 Hz attitude held at 100 Hz gave errors of three to
four times the rate, every row labelled ``corrected``). An exact repeat is no measurement.

**The rule.** Among the consecutive valid rows of the log's head (its first
:data:`~omegahat.observer.autogain.HEAD_SAMPLES`, what the identification reads), count the exact repeats and the
changes. When the repeats are at least as many as the changes and the attitude changes at least twice, every row
of the log that repeats the last valid attitude exactly is set missing (NaN: the estimators predict through it,
status ``predicted``) and counted, in the head and in every later chunk. A log whose attitude never changes (a body at
rest, written exactly) is left as it is, and so is one with fewer repeats than changes (a body resting for a while
in a log of few digits): there a repeat may be a measurement that the body did not move.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np

from omegahat.io.registry import LogChunk
from omegahat.observer.autogain import HEAD_SAMPLES

__all__ = ["HeldSamples"]


class HeldSamples:
    """The rule of the module docstring over a stream's chunks: :meth:`screen` decides on the head and sets the
    held rows missing; :attr:`count` rows were, the first at :attr:`first` (its label), and the head's attitude
    changed every :attr:`update_interval` s (median) while it did."""

    def __init__(self) -> None:
        self.active = False
        self.count = 0
        self.first: int | None = None
        self.update_interval = float("nan")
        self._last: np.ndarray | None = None  # the last valid row as read (a held row repeats it)

    def screen(self, chunks: Iterator[LogChunk]) -> Iterator[LogChunk]:
        """The same chunks, the held rows set missing (copies where any is) once the head has been judged."""
        head, rows = [], 0
        for chunk in chunks:
            head.append(chunk)
            rows += len(chunk)
            if rows >= HEAD_SAMPLES:
                break
        self._decide(head)
        for chunk in head:
            yield self._apply(chunk)
        head.clear()
        for chunk in chunks:
            yield self._apply(chunk)

    def _decide(self, head: list[LogChunk]) -> None:
        if not head:
            return
        t = np.concatenate([c.t for c in head])
        rows = np.concatenate([c.data.reshape(len(c), -1) for c in head])
        valid = np.flatnonzero(np.all(np.isfinite(rows), axis=1))
        if valid.size < 3:
            return
        same = np.all(rows[valid[1:]] == rows[valid[:-1]], axis=1)
        changes = int(np.count_nonzero(~same))
        self.active = changes >= 2 and int(same.sum()) >= changes
        if self.active:  # the times of the rows that bring a new attitude
            fresh = t[valid[1:][~same]]
            self.update_interval = float(np.median(np.diff(fresh)))

    def _apply(self, chunk: LogChunk) -> LogChunk:
        if not self.active:
            return chunk
        rows = chunk.data.reshape(len(chunk), -1)
        valid = np.flatnonzero(np.all(np.isfinite(rows), axis=1))
        if not valid.size:
            return chunk
        last = np.full(rows.shape[1], np.nan) if self._last is None else self._last  # NaN equals nothing
        held = valid[np.all(rows[valid] == np.vstack([last, rows[valid[:-1]]]), axis=1)]
        self._last = rows[valid[-1]].copy()
        if not held.size:
            return chunk
        if self.first is None:
            self.first = int(chunk.labels[held[0]])
        self.count += int(held.size)
        data = chunk.data.copy()
        data[held] = np.nan
        return replace(chunk, data=data)

    def closing(self, label: str) -> str:
        """The summary's line: how many rows were held and read as missing ("" when none)."""
        if not self.count:
            return ""
        every = (
            f"; the attitude changed every {self.update_interval:.4g} s in the head" if self.update_interval > 0 else ""
        )
        return (
            f"held: {self.count} samples repeat the previous attitude exactly (a value held between the sensor's "
            f"updates, as a republished topic or a table filled forward gives; the first at {label} {self.first}): "
            f"read as missing, predicted through (status 'predicted'){every}"
        )
