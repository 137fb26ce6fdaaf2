r"""Known torques from a log of their own (``omegahat estimate LOG --torque FILE --inertia ...``).

A spacecraft's commanded torques come from its controller, on its own schedule, while the attitude comes from the
star tracker (or an attitude ephemeris, :mod:`omegahat.io.aem`); a bench's actuator log is apart from the motion
capture. This module puts such a torque log beside any attitude log, as if its torque columns had been written in
the attitude log (``tau_x, tau_y, tau_z``).

**The file** is text with a header: a time column (``t``, else the one column named as a time, or ISO 8601 dates,
as for attitude logs) and three torque columns, N·m in body axes: ``tau_x, tau_y, tau_z`` (or ``torque_x ...``, or
the one triple of names ending in x, y, z whose stem says torque), else ``--torque-columns X,Y,Z``
(:func:`omegahat.io.gyrolog.read_vectors`: the gyroscope log's reader, with a torque's names). Numeric times are in
the attitude log's unit (``--time-unit``) unless the time column's name states one (``time_ms``), on **the
attitude log's clock**; dates are seconds since 1970 UTC.

**Between its rows** a torque holds its value until the next row: the controller's command, held (zero order),

.. math::

   \tau(t) = \tau_j, \qquad t_j \le t < t_{j+1},  \tag{T1}

and the last row holds for one step of the log (its median spacing) after its time.

**Onto the attitude's samples.** The estimators hold the torque of sample :math:`k` over
:math:`[t_k, t_{k+1}]`, so sample :math:`k` gets the mean of (T1) over that interval, exactly (the integral of
(T1) is piecewise linear):

.. math::

   \bar\tau_k = \frac{I(t_{k+1}) - I(t_k)}{t_{k+1} - t_k}, \qquad I(t) = \int_{t_0}^{t} \tau(s)\,ds,  \tag{T2}

and the last sample gets :math:`\tau(t_K)`. A torque that changes within an interval is thus felt by its impulse,
not by whichever value happened to stand at the sample time.

**Refused**, with the spans or rows named: times that do not increase; an attitude sample before the torque log's
first time or after its last time's hold (the clocks do not match, or the log is short: no torque is made up);
an attitude log that has torque columns of its own.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator

import numpy as np

from omegahat.io.columns import TORQUE_COLUMNS, LogFormatError
from omegahat.io.gyrolog import GyroLog, VectorRole, read_vectors
from omegahat.io.registry import LogChunk, LogStream
from omegahat.io.time_units import TIME_UNITS, implausible_spacing, unit_stated

__all__ = ["TORQUE", "TorqueLog", "attach_torque", "read_torque_log"]

TORQUE = VectorRole(
    "torque", "--torque", (TORQUE_COLUMNS, ("torque_x", "torque_y", "torque_z")), r"tau|torq|moment", "torque", False
)


class TorqueLog:
    """A torque log (module docstring): ``t (M,)`` in seconds on the attitude log's clock, strictly increasing,
    ``tau (M, 3)`` N·m, its ``source`` and ``names`` (time, x, y, z); :meth:`interval_means` is (T2)."""

    def __init__(self, source: str, t: np.ndarray, tau: np.ndarray, names: tuple[str, ...], note: str = ""):
        back = np.flatnonzero(np.diff(t) <= 0)
        if back.size:
            k = int(back[0]) + 1
            raise LogFormatError(
                f"{source}: the torque log's times do not increase at its row {k + 1} ({t[k]:.9g} s after "
                f"{t[k - 1]:.9g} s)"
            )
        if t.size < 1 or not np.all(np.isfinite(tau)):
            raise LogFormatError(f"{source}: a torque log needs rows of finite torques")
        self.source, self.t, self.tau, self.names, self.note = source, t, tau, names, note
        self.hold = float(np.median(np.diff(t))) if t.size > 1 else 0.0
        # I(t_j), the integral of (T1) from t_0 to each row's time
        self._integral = np.vstack([np.zeros(3), np.cumsum(tau[:-1] * np.diff(t)[:, None], axis=0)])

    def covers(self, first: float, last: float) -> str | None:
        """None if ``[first, last]`` (s) lies within the log's span and hold, else what is wrong."""
        end = self.t[-1] + self.hold
        if first >= self.t[0] and last <= end:
            return None
        return (
            f"the attitude log runs from {first:.9g} s to {last:.9g} s, the torque log from {self.t[0]:.9g} s to "
            f"{end:.9g} s (its last row held one step): they must share one clock and the torque log must cover the "
            "attitude's"
        )

    def integral(self, times: np.ndarray) -> np.ndarray:
        """:math:`I(t)` of (T2) at ``times`` (none before the first row's time)."""
        j = np.searchsorted(self.t, times, side="right") - 1
        return self._integral[j] + self.tau[j] * (times - self.t[j])[:, None]

    def interval_means(self, times: np.ndarray, following: float | None) -> np.ndarray:
        """(T2) for the samples at ``times``; ``following`` is the next sample's time (None: the last is the log's
        last sample, which gets (T1) at its time)."""
        ends = np.append(times[1:], np.nan if following is None else following)
        out = np.empty((times.size, 3))
        inner = np.isfinite(ends)
        lo, hi = times[inner], ends[inner]
        out[inner] = (self.integral(hi) - self.integral(lo)) / (hi - lo)[:, None]
        if not inner.all():
            out[~inner] = self.tau[np.searchsorted(self.t, times[~inner], side="right") - 1]
        return out


def read_torque_log(
    path: str | os.PathLike[str],
    time_unit: str = "s",
    columns: tuple[str, str, str] | None = None,
) -> TorqueLog:
    """The torque log at ``path`` (module docstring), its numeric times in ``time_unit`` unless the time column's
    name or size states another (:func:`omegahat.io.time_units.unit_stated`, as for attitude logs)."""
    path = os.fspath(path)
    raw: GyroLog = read_vectors(path, TORQUE, columns)
    if raw.own_unit:
        return TorqueLog(path, raw.t, raw.g, raw.names, raw.own_unit)
    stated, note = unit_stated(raw.names[0], time_unit, raw.t[:64])
    unit = stated or time_unit
    t = raw.t * TIME_UNITS[unit]
    h = float(np.median(np.diff(t))) if t.size > 1 else math.nan
    if not stated and h > 0:  # a torque log in ms read as s: rows 1000 s apart; no option sets its unit alone
        remedy = lambda u: f"name its time column time_{u}, which states its unit"  # noqa: E731
        note = implausible_spacing(h, float(t[0]), unit, f"in {unit}, as --time-unit says", remedy, "its rows") or note
    return TorqueLog(path, t, raw.g, raw.names, note or "")


def attach_torque(stream: LogStream, log: TorqueLog) -> LogStream:
    """``stream`` with each chunk's torque from ``log`` by (T2); the chunks are handed on one behind, since the last
    sample of a chunk needs the next chunk's first time."""
    if stream.has_torque:
        raise LogFormatError(
            f"{stream.source}: the log has torque columns of its own; --torque adds them to a log without"
        )
    if stream.kind == "directions":
        raise LogFormatError(f"{stream.source}: --torque goes with attitude logs (quaternions, matrices)")
    t0 = stream.t0

    def chunks(raw: Iterator[LogChunk]) -> Iterator[LogChunk]:
        first: float | None = None
        pending: LogChunk | None = None
        for chunk in raw:
            if not len(chunk):
                continue
            if first is None:
                first = float(t0 + chunk.t[0])
                _check(log, first, first, stream.source)
            if pending is not None:
                yield _with_torque(pending, log, t0, float(t0 + chunk.t[0]))
            pending = chunk
        if pending is not None:
            assert first is not None
            _check(log, first, float(t0 + pending.t[-1]), stream.source)
            yield _with_torque(pending, log, t0, None)

    stream.has_torque = True
    stream.convert(chunks)
    stream.notes.append(
        f"torque: {log.source}, {log.t.size} rows ({', '.join(log.names[1:])}, N m), each held until the next and "
        "averaged over each interval between attitude samples" + (f"; {log.note}" if log.note else "")
    )
    return stream


def _check(log: TorqueLog, first: float, last: float, source: str) -> None:
    wrong = log.covers(first, last)
    if wrong:
        raise LogFormatError(f"{source} and {log.source}: {wrong}")


def _with_torque(chunk: LogChunk, log: TorqueLog, t0: float, following: float | None) -> LogChunk:
    times = t0 + chunk.t
    _check(log, float(times[0]), float(times[-1]), "the attitude log")
    return LogChunk(chunk.t, chunk.data, log.interval_means(times, following), chunk.labels, chunk.extra)
