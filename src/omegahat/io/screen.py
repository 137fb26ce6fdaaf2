r"""The turns between consecutive attitudes, judged as the rows are read, before an estimator reads them.

:func:`omegahat.io.pipeline.estimate_stream` hands every chunk of an attitude log through :class:`TurnScreen`:

* an **isolated spike** ((P1) of :mod:`omegahat.identification.spikes`: one sample far from both neighbours, which
  agree, as a marker swap or a misread frame gives) becomes a missing sample, so that it costs one predicted row
  instead of a restart or two wrong differences;
* a **reset** of the attitude source ((P2): one step far larger than both of its neighbours, the attitudes after it
  all turned by one rotation, as an orientation filter re-aligning its heading gives) is stitched ((P3)): every
  later attitude is turned back so that the step across the reset is the mean of its neighbours' increments, and
  the sample it reached becomes a missing sample (the body's motion over that step is not in the samples). An
  estimator then reads the body's increments on both sides, and none across the reset;
* **jumps**, consecutive attitudes more than :data:`JUMP_ANGLE` apart (a turn faster than the samples can follow,
  a quarter of the half-turn beyond which the sampled attitudes cannot tell the direction at all, or a reset that
  (P2) cannot judge, beside a missing sample), are counted.

A sample is judged once its two successors are read, so each chunk's last two rows are held back until the next
chunk comes. Every count and the largest of each (by its row's label) go into the run's summary.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Protocol

import numpy as np

from omegahat import measurements as ms
from omegahat import so3
from omegahat.identification.spikes import (
    across_gaps,
    judged_resets,
    judged_spikes,
    per_spacing,
    reset_turn,
    step_scales,
)
from omegahat.io.registry import LogChunk

if TYPE_CHECKING:
    from omegahat.io.settings import EstimateSettings

__all__ = ["JUMP_ANGLE", "Counts", "TurnScreen", "largest_of"]

JUMP_ANGLE = math.pi / 2  #: rad between consecutive attitudes beyond which the summary reports a jump


class Counts(Protocol):
    """What the screen counts into (the pipeline's ``RunSummary``): each kind and its largest ``(rad, label)``."""

    spikes: int
    largest_spike: tuple[float, int | None]
    resets: int
    largest_reset: tuple[float, int | None]
    jumps: int
    largest_jump: tuple[float, int | None]


class TurnScreen:
    """Spikes set missing, resets stitched and jumps counted, chunk by chunk (module docstring).

    :meth:`feed` returns the rows judged so far (the chunk's, a copy where spikes and resets are set to NaN and the
    attitudes after a reset turned back) and holds the last two back for the next chunk; :meth:`finish` returns
    those of the log's end, the last-but-one judged with the one successor it has (as the identification judges
    the whole log), the last never. A spike that is not a rotation at all is left for the pipeline's
    ``BadSamples`` to name, and so is one after a reset (turned, it has the same ``|q|``, ``|RᵀR − I|``, ``det R``)."""

    def __init__(
        self, settings: EstimateSettings, summary: Counts, head: list[np.ndarray], spacing: float | None = None
    ) -> None:
        self.settings, self.summary = settings, summary
        self.rows: LogChunk | None = None  # the last two rows handed on (as read), then the rows held back
        self.handed = 0  # how many of ``rows`` were handed on already (the next samples' neighbours)
        # the scales spikes and resets are judged against: the head's (the rows the identification reads), so that
        # every chunk is judged alike wherever the chunks are cut
        self.typical_step, self.fastest_step = step_scales(_turns(np.concatenate(head))) if head else (0.0, 0.0)
        self.spacing = np.inf if spacing is None else spacing  # the head's median spacing (None: no gap judged)
        self.last_missing = False  # the last row handed on was a spike or a reset's, set missing
        self.turn: np.ndarray | None = None  # (P3): the rotation every row read from now on is turned by

    def feed(self, chunk: LogChunk) -> LogChunk | None:
        """The rows judged once ``chunk`` is read (None if none yet)."""
        if self.turn is not None:  # after a reset: every row read from now on, turned back (a copy of the chunk)
            chunk = LogChunk(chunk.t, chunk.data.copy(), chunk.torque, chunk.labels, chunk.extra)
            self._turn(chunk.data, self.turn)
        rows = chunk if self.rows is None else _joined(self.rows, chunk)
        return self._hand_on(rows, max(len(rows) - 2, self.handed), hold=True)

    def finish(self) -> LogChunk | None:
        """The rows held back at the end of the log (once)."""
        if self.rows is None or len(self.rows) == self.handed:
            return None
        return self._hand_on(self.rows, len(self.rows), hold=False)

    def _hand_on(self, rows: LogChunk, ready: int, hold: bool) -> LogChunk | None:
        """The rows ``handed … ready − 1`` of ``rows`` judged (those with a successor): resets stitched, spikes set
        to NaN, jumps counted; ``hold``: keep the last two rows as the next chunk's neighbours."""
        done = self.handed
        step = _turns(rows.data)
        scaled = per_spacing(step, rows.t, self.spacing)  # a reset is judged per spacing, across a gap too
        resets = judged_resets(scaled, self.typical_step, self.fastest_step, done, ready - 1)
        if resets.samples.size:
            turned = step[resets.samples - 1]  # the reset's own angle (judged per spacing, said as it is)
            rows = self._stitched(rows, resets.samples)
            step = _turns(rows.data)
            self.summary.resets += resets.samples.size
            self.summary.largest_reset = largest_of(self.summary.largest_reset, resets.samples, turned, rows.labels)
        step = across_gaps(step, rows.t, self.spacing)  # no spike's neighbour and no jump across a gap
        data = rows.data
        found = judged_spikes(step, lambda k: so3.angle(data[k - 1], data[k + 1]), self.typical_step, done, ready - 1)
        status, _ = ms.sample_status(
            data[found.samples], rotation_tol=self.settings.rotation_tol, quat_norm_tol=self.settings.quat_norm_tol
        )
        spikes, detour = found.samples[status < ms.ERROR], found.detour[status < ms.ERROR]
        keep = max(ready - 2, 0) if hold else len(rows)
        self.rows, self.handed = _rows(rows, keep, len(rows)), ready - keep
        if ready == done:
            return None
        out = _rows(rows, done, ready)
        lo = max(done - 1, 0)
        turn = step[lo : ready - 1]  # the turns into the rows handed on now (from the last one handed on before)
        if spikes.size:
            out.data = out.data.copy()
            out.data[spikes - done] = np.nan
            turn = turn.copy()
            near = np.concatenate([spikes - 1, spikes]) - lo  # a missing sample turns nothing: no jump on either side
            turn[near[near < turn.size]] = np.nan
            self.summary.spikes += spikes.size
            self.summary.largest_spike = largest_of(self.summary.largest_spike, spikes, detour, rows.labels)
        self._jumps(turn, rows.labels[lo:ready], after_missing=done > 0 and self.last_missing)
        missing = np.concatenate([spikes, resets.samples])
        self.last_missing = bool(missing.size) and int(missing.max()) == ready - 1
        return out

    def _stitched(self, rows: LogChunk, reached: np.ndarray) -> LogChunk:
        """``rows`` with (P3) at each reset, the samples ``reached`` by them (ascending) set to NaN."""
        rows = LogChunk(rows.t, rows.data.copy(), rows.torque, rows.labels, rows.extra)
        for j in reached:  # set missing after all: a second reset's neighbour may be the first's sample
            R = _matrices(rows.data[j - 2 : j + 2])  # the increments beside the reset: a turn leaves them as they are
            phi = so3.increments(R)
            S = reset_turn(R[1], R[2], phi[0], phi[2], np.diff(rows.t[j - 2 : j + 2]))
            self._turn(rows.data[j:], S)
            self.turn = S if self.turn is None else S @ self.turn
        rows.data[reached] = np.nan
        return rows

    @staticmethod
    def _turn(data: np.ndarray, S: np.ndarray) -> None:
        """The attitudes ``data`` turned by ``S`` (``S R``), in place. A sample that is not a rotation keeps what its
        message says (``|q|``, ``|RᵀR − I|``, ``det R``: a turn changes none of them)."""
        if data.ndim == 2:  # quaternions x, y, z, w: s ⊗ q
            data[:] = so3.quat_product(so3.to_quat(S), data)
        else:
            data[:] = S @ data

    def _jumps(self, step: np.ndarray, labels: np.ndarray, after_missing: bool) -> None:
        """Count the jumps among the turns ``step`` between the rows labelled ``labels`` (``after_missing``: the
        first row was set missing, so the first turn is none)."""
        with np.errstate(invalid="ignore"):  # NaN (a missing sample on either side) is not a jump
            jump = np.flatnonzero(step > JUMP_ANGLE)
        jump = jump[jump > 0] if after_missing else jump
        self.summary.jumps += jump.size
        self.summary.largest_jump = largest_of(self.summary.largest_jump, jump + 1, step[jump], labels)


def largest_of(
    largest: tuple[float, int | None], rows: np.ndarray, size: np.ndarray, labels: np.ndarray
) -> tuple[float, int | None]:
    """A summary's largest gap, jump, spike or reset ``(size, label)``: ``largest``, or the largest ``size`` at the
    ``rows`` (labelled ``labels[rows]``) where that is larger."""
    if rows.size == 0:
        return largest
    j = int(np.argmax(size))
    return (float(size[j]), int(labels[rows[j]])) if size[j] > largest[0] else largest


def _matrices(data: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(n, 3, 3)`` of rows of quaternions (x, y, z, w) or of matrices."""
    return so3.from_quat(data) if data.ndim == 2 else data


def _rows(chunk: LogChunk, start: int, stop: int) -> LogChunk:
    """The rows ``start … stop − 1`` of ``chunk`` (views)."""
    cut = slice(start, stop)
    torque = None if chunk.torque is None else chunk.torque[cut]
    extra = None if chunk.extra is None else {k: v[cut] for k, v in chunk.extra.items()}
    return LogChunk(chunk.t[cut], chunk.data[cut], torque, chunk.labels[cut], extra)


def _joined(a: LogChunk, b: LogChunk) -> LogChunk:
    """The rows of ``a`` then those of ``b``."""
    torque = None if a.torque is None or b.torque is None else np.concatenate([a.torque, b.torque])
    extra = (
        None if a.extra is None or b.extra is None else {k: np.concatenate([a.extra[k], b.extra[k]]) for k in a.extra}
    )
    return LogChunk(
        np.concatenate([a.t, b.t]),
        np.concatenate([a.data, b.data]),
        torque,
        np.concatenate([a.labels, b.labels]),
        extra,
    )


def _turns(data: np.ndarray) -> np.ndarray:
    """The angle (rad) between each two consecutive attitudes of ``data`` (:func:`omegahat.so3.angle`)."""
    return so3.angle(data[:-1], data[1:])
