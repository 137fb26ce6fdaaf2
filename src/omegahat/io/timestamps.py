r"""Duplicated, out-of-order and irregular timestamps: the one policy applied to every input.

Motion-capture systems deliver frames over a network, drivers re-publish the last frame when a new one is late,
and loggers record what arrived. A recording therefore carries, besides jitter, samples that share a timestamp
and samples that arrive out of order. omegahat treats them the same way whatever the format (omegahat's CSV and
NPZ logs, ROS bags, Motive, Vicon and C3D exports, DataFrames):

1. **Irregular spacing is kept.** Jittery intervals, dropped frames and gaps are passed to the estimator as
   recorded: it predicts the state over each interval, whatever its length (:mod:`omegahat.observer.estimator`),
   so nothing is resampled or interpolated. ``omegahat estimate`` reports the gaps.
2. **Exact duplicates are dropped.** Samples with the same timestamp whose attitudes agree are one sample: the
   first is kept and the count is reported. Attitudes are compared as rotation matrices, so a quaternion ``q``
   and its negative ``−q`` (the same rotation) agree; "agree" means ``‖R_a − R_b‖_F ≤`` :data:`DUPLICATE_TOL`
   (about ``1e-6`` rad: the same frame written twice, up to the rounding of a text export); known torques must
   agree too. A missing sample (NaN) at the time of a valid one is dropped as well: it carries nothing the valid
   one lacks. A dropped sample has no row in a file output; :func:`omegahat.estimate_frame`, whose output follows
   the input's rows, gives it the estimate of the sample kept in its place.
3. **Conflicting duplicates are rejected by default.** Two samples at the same time with different attitudes
   cannot both be right, and guessing which one is would hide a broken time source:
   :class:`~omegahat.io.LogFormatError` names both samples, the time and the angle between the two attitudes, and
   the option that reads on. Real ground truth has them (TUM's ``fr2_desk`` ground truth, two poses 0.61° apart
   at one stamp; EuRoC's ``V1_02``), so a user who has looked may choose (:data:`DUPLICATE_CHOICES`,
   ``ReadOptions.duplicate_times``, ``--duplicate-times``) to keep the ``first`` or the ``last`` sample of each
   such time; the others are dropped, counted and reported with the largest difference and where it was — never
   silently.
4. **Order.** Files written sample by sample (CSV, NPZ, Motive, Vicon, C3D) must have non-decreasing times; a time
   going backwards is an error naming the line (array index, frame). Message streams (ROS bags) and DataFrames,
   where delivery or a join can reorder rows, are sorted by time by their readers (:func:`sort_by_time`, a stable
   sort, so exact duplicates stay in arrival order), and the number of samples that arrived late is reported.

**Where it runs.** Rules 2–4 are applied by :class:`TimePolicy` inside :func:`omegahat.io.registry.open_log`, on
the stream of chunks every format produces, after the time unit is applied and before anything else sees the
samples; so every reader, ``omegahat estimate`` and :func:`omegahat.estimate_frame` get it from one place. The
policy holds back the last kept sample of each chunk until the next one arrives, so a duplicate that straddles
two chunks is treated exactly as one inside a chunk.

5. **Absolute times keep their precision.** Times written as seconds since 1970 (TUM trajectories, ``1.7e9``),
   nanoseconds (EuRoC, ``1.4e18``) or any time of magnitude ``2**20`` or more are read as decimal text and made
   relative to the integer part of the first one *before* they become floats (:class:`ExactTimes`), which the
   stream keeps as ``t0``: as floats ``1.7e9`` s would be rounded to 0.24 µs and ``1.4e18`` ns to 256 ns.

6. **Dates are read as seconds since 1970.** A text time column of ISO 8601 dates and times (pandas' ``to_csv``
   of a ``DatetimeIndex``, ``2026-01-01T12:00:00.010Z``) is read as seconds since 1970-01-01 UTC, kept exact in the
   same way (:class:`ExactTimes`), and the output's times are written so. A time with a zone offset is converted to
   UTC; one without is read as if it were UTC, which the reader says in a note.

The jitter test (``tests/test_timestamps.py``) checks that a log with irregular sampling, dropped frames and
duplicates gives the same rate as the clean log within the noise.
"""

from __future__ import annotations

from collections.abc import Callable
from decimal import Decimal, InvalidOperation

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc

from omegahat import so3
from omegahat.io.columns import LogFormatError

__all__ = [
    "ARROW_ERRORS",
    "DUPLICATE_CHOICES",
    "DUPLICATE_TOL",
    "EXACT_FROM",
    "ExactTimes",
    "TimePolicy",
    "date_text",
    "first_failure",
    "late_rows",
    "sort_by_time",
    "text_dates",
]

DUPLICATE_TOL = 1e-6  #: ‖R_a − R_b‖_F (≈ √2 × the angle in rad) below which two samples at one time are the same
DUPLICATE_CHOICES = ("error", "first", "last")  #: (3) what to do with samples at one time that disagree
EXACT_FROM = float(2**20)  #: (5) times from this magnitude on are made relative before they become floats
ARROW_ERRORS = (pa.ArrowInvalid, pa.ArrowNotImplementedError)  #: what an Arrow cast raises for a value it refuses
_DECIMAL = pa.decimal128(38, 18)  # 20 integer digits (ns since 1970: 19) and 18 decimals
_DIFFERENCE = pa.decimal128(37, 18)  # one digit less, so that a difference still fits 38 digits


class ExactTimes:
    """(5): text times relative to ``base``, the integer part of the first time (in the file's unit), if its
    magnitude is :data:`EXACT_FROM` or more (else ``base`` is 0 and the times are read as they are).
    :meth:`convert` turns a chunk's time texts (blanks trimmed, a decimal comma read as a point) into floats
    ``time − base``; a text that is no decimal number (``nan``, a word) is read as a float, which the readers
    refuse, naming it.

    (6) **Dates.** A first time written as an ISO 8601 date and time (``2026-01-01 12:00:00.010``,
    ``2026-01-01T12:00:00.010Z``, ``…+02:00``: what pandas, spreadsheets and many loggers write) makes every time
    one: :attr:`dates` is the Arrow type they are read as, ``base`` the whole seconds since 1970-01-01 UTC of the
    first, and :meth:`convert` gives seconds since ``base``, from integer nanoseconds (exact to 1 ns over 104 days).
    A time with a zone offset is the instant it names (converted to UTC). One without is read as if it were UTC:
    only differences of times matter to the estimate, so the zone changes nothing but the times written back
    (seconds since 1970 "UTC" are then the local clock's). Either way every row must be like the first (all with a
    zone or none), else its line is named. A local clock's daylight-saving jump back is a time going backwards,
    refused by rule 4."""

    def __init__(self, first: str):
        text = first.strip()
        self.dates: pa.DataType | None = None
        try:
            value = Decimal(text.replace(",", "."))
        except InvalidOperation:
            value = Decimal(0)
            self.dates = _date_type(text)
        if self.dates is not None:
            self.base = self.nanoseconds(pa.array([text]))[0].as_py() // 10**9
            return
        self.base = int(value) if value.is_finite() and abs(value) >= Decimal(EXACT_FROM) else 0

    @property
    def exact(self) -> bool:
        """Whether the times are read as text (absolute times made relative, or dates), not as floats."""
        return self.base != 0 or self.dates is not None

    @property
    def zoned(self) -> bool:
        """Whether the dates name their time zone (then converted to UTC)."""
        return self.dates is not None and self.dates.tz is not None

    @property
    def expected(self) -> str:
        """What every time must be, for the message naming one that is not."""
        if self.dates is None:
            return "a number"
        zone = "with" if self.zoned else "without"
        return f"a date and time {zone} a time zone, as the first row's (ISO 8601: 2026-01-31 12:00:00.010)"

    @property
    def dates_note(self) -> str:
        """The note of a log whose times are dates (6)."""
        zone = "their time zone converted to UTC" if self.zoned else "no time zone given, so read as if UTC"
        return f"dates read as seconds since 1970-01-01 UTC ({zone}: only differences matter to the rates)"

    def nanoseconds(self, text: pa.Array) -> pa.Array:
        """int64 nanoseconds since 1970-01-01 UTC of a string array of dates (6); raises ``pa.ArrowInvalid`` for a
        text unlike the first."""
        return pc.cast(pc.cast(text, self.dates), pa.int64())

    def convert(self, text: pa.Array) -> pa.Array:
        """float64 ``time − base`` (nulls kept) of a string array; raises ``pa.ArrowInvalid`` for text that is no
        number (no date, for dates)."""
        if self.dates is not None:
            ns = self.nanoseconds(text)
            return pc.divide(pc.cast(pc.subtract(ns, pa.scalar(self.base * 10**9)), pa.float64()), 1e9)
        if not self.exact:
            return pc.cast(text, pa.float64())
        try:
            d = pc.cast(pc.cast(text, _DECIMAL), _DIFFERENCE)
        except ARROW_ERRORS:  # nan/inf, or more than 18 decimals: as floats
            return pc.subtract(pc.cast(text, pa.float64()), pa.scalar(float(self.base)))
        return pc.cast(pc.subtract(d, pa.scalar(Decimal(self.base), _DIFFERENCE)), pa.float64())


def _date_type(text: str) -> pa.DataType | None:
    """The Arrow type an ISO 8601 date and time ``text`` is read as (6): nanoseconds in UTC where it names a zone,
    without a zone where it does not; None where it is no date."""
    for kind in (pa.timestamp("ns"), pa.timestamp("ns", "UTC")):
        try:
            pc.cast(pa.array([text]), kind)
        except ARROW_ERRORS:
            continue
        return kind
    return None


def text_dates(texts: list, where: Callable[[int], str]) -> tuple[np.ndarray, str] | None:
    """Integer nanoseconds since 1970-01-01 UTC of a column of ISO 8601 date texts (a DataFrame's strings, a gyro
    log's column), read as a CSV's are (6), and the note that says so; None where the first is no date (the caller
    reads numbers). ``where(k)`` names row ``k`` in the error for a text unlike the first or a missing one."""
    times = ExactTimes(next((str(v) for v in texts if not _missing(v)), ""))
    if times.dates is None:
        return None
    text = pa.array([None if _missing(v) else str(v).strip() for v in texts], pa.string())
    try:
        ns = times.nanoseconds(text)
    except ARROW_ERRORS:
        k = first_failure(times.nanoseconds, text)
        raise LogFormatError(f"{where(k)}: {text[k].as_py()!r} is not {times.expected}") from None
    if ns.null_count:
        k = int(np.flatnonzero(ns.is_null().to_numpy(zero_copy_only=False))[0])
        raise LogFormatError(f"{where(k)}: missing time (every row needs one)")
    return ns.to_numpy().astype(np.int64), times.dates_note


def first_failure(convert: Callable[[pa.Array], object], values: pa.Array) -> int:
    """The index of the first of ``values`` that ``convert`` (an Arrow cast) refuses, found by bisection (the whole
    array is known to fail): the element a message names."""
    lo, hi = 0, len(values)
    while hi - lo > 1:
        mid = (lo + hi) // 2
        try:
            convert(values[lo:mid])
            lo = mid
        except ARROW_ERRORS:
            hi = mid
    return lo


def _missing(value) -> bool:
    """None, NaN or pandas' NA: a missing value in a DataFrame's column of texts."""
    return value is None or (isinstance(value, float) and value != value) or type(value).__name__ == "NAType"


def date_text(base: int, seconds: float) -> str:
    """A time of (6), ``seconds`` after ``base`` s since 1970-01-01 UTC, as an ISO 8601 text (for messages)."""
    return str(np.datetime64(base * 10**9 + round(seconds * 1e9), "ns"))


def sort_by_time(times: np.ndarray) -> tuple[np.ndarray, int]:
    """``(order, n_late)``: the stable sort of ``times`` (rule 4, message streams) and the number of samples that
    came after one with a later time (late arrivals), for the note the reader adds."""
    times = np.asarray(times)
    if times.size == 0:
        return np.zeros(0, dtype=np.int64), 0
    return np.argsort(times, kind="stable"), int(np.count_nonzero(late_rows(times)))


def late_rows(times: np.ndarray) -> np.ndarray:
    """``(N,)``: True for each sample that came after one with a later time (a late arrival, or a clock stepping
    back)."""
    times = np.asarray(times)
    late = np.zeros(times.size, dtype=bool)
    late[1:] = times[1:] < np.maximum.accumulate(times)[:-1]
    return late


def _matrix(q: np.ndarray) -> np.ndarray | None:
    """Rotation matrix of a quaternion ``(x, y, z, w)``, normalised; None for a zero quaternion."""
    n = float(np.linalg.norm(q))
    if n == 0.0:
        return None
    x, y, z, w = q / n
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def _comparable(kind: str, row: np.ndarray) -> np.ndarray:
    """One sample as compared by rule 2: a rotation matrix for quaternions (q ≡ −q) and matrices, else the
    values."""
    if kind == "quaternion":
        R = _matrix(row)
        if R is not None:
            return R
    if kind == "matrix":
        return np.asarray(row, dtype=float).reshape(3, 3)
    return np.asarray(row, dtype=float)


def _difference(kind: str, a: np.ndarray, b: np.ndarray) -> tuple[str, float] | None:
    """None if two samples at one time agree (rule 2), else what differs (for the messages of rule 3) and by how
    much (degrees between attitudes, else the largest difference of the values), to report the largest."""
    ca, cb = _comparable(kind, a), _comparable(kind, b)
    if ca.shape == cb.shape and np.sqrt(np.sum((ca - cb) ** 2)) <= DUPLICATE_TOL:
        return None
    if ca.shape == (3, 3) and cb.shape == (3, 3):
        angle = float(np.degrees(so3.angle(ca, cb)))
        return f"attitudes {angle:.4g}° apart", angle
    size = float(np.abs(ca - cb).max())
    return f"values differing by up to {size:.3g}", size


class TimePolicy:
    """Rules 2–4 on consecutive chunks of one stream (module docstring).

    ``where(label, column)`` names a sample for messages (:meth:`omegahat.io.registry.LogStream.where`),
    ``unit`` is the labels' word (``"line"``, ``"index"``, ``"message"`` ...), ``time_name`` the time column named
    in messages, ``duplicates`` one of :data:`DUPLICATE_CHOICES` (rule 3; checked by
    :class:`omegahat.io.ReadOptions`), ``time_base`` the integer :class:`ExactTimes` subtracted from the raw times
    (added back in messages; ``dates``: shown as dates, (6)), or a float one (a binary table's first time);
    ``time_scale`` the seconds per unit of ``time_base`` where the raw times are seconds (a unit a name states).
    :meth:`feed` takes arrays ``(t, raw_t, data, torque, labels, extra)`` of one chunk (``t`` in seconds, ``raw_t``
    as the file writes it, for messages) and returns the indices of the rows to hand on and the concatenated arrays
    they index; :meth:`finish` returns the last sample held back.
    """

    def __init__(
        self,
        kind: str,
        where: Callable[..., str],
        unit: str,
        time_name: str | None,
        duplicates: str = "error",
        time_base: int | float = 0,
        dates: bool = False,
        time_scale: float = 1.0,
    ):
        self.kind, self.where, self.unit, self.time_name = kind, where, unit, time_name
        self.time_base = time_base  # (5): raw times are relative to it; messages show the time the file writes
        self.dates = dates  # (6): raw times are seconds after time_base since 1970, shown as dates
        self.time_scale = time_scale  # seconds per unit of time_base, where the raw times are already seconds
        self.duplicates = duplicates
        self.n_dropped = 0  # exact duplicates (rule 2)
        self.n_conflicts = 0  # samples dropped from times whose samples disagree (rule 3, first or last)
        self.n_conflict_times = 0
        self._worst: tuple[float, str] | None = None  # the largest disagreement: (size, where and what)
        self._conflict_time: float | None = None  # the time last counted in n_conflict_times
        self._held: tuple | None = None  # the last kept sample so far, as a tuple of length-1 arrays

    def notes(self) -> list[str]:
        """What was changed, for the stream's notes (empty when nothing was)."""
        notes = []
        if self.n_dropped:
            notes.append(f"dropped {self.n_dropped} duplicated sample(s) (same time, same attitude)")
        if self.n_conflicts and self._worst is not None:
            notes.append(
                f"--duplicate-times {self.duplicates}: kept the {self.duplicates} sample at each of "
                f"{self.n_conflict_times} time(s) whose samples differ, dropped {self.n_conflicts}; the largest "
                f"difference: {self._worst[1]}"
            )
        return notes

    def feed(self, arrays: tuple) -> tuple[tuple, slice | np.ndarray]:
        """``(arrays with the held sample in front, the rows to hand on now: a slice or indices)``."""
        if self._held is not None:
            arrays = tuple(_concat(h, a) for h, a in zip(self._held, arrays, strict=True))
        t, raw, labels = arrays[0], arrays[1], arrays[4]
        n = t.size
        if n == 0:
            return arrays, slice(0, 0)
        d = np.diff(t)
        back = np.flatnonzero(d < 0)
        if back.size:
            k = int(back[0]) + 1
            raise LogFormatError(
                f"{self.where(int(labels[k]), self.time_name)}: time {self._num(raw[k])} is not after "
                f"{self._num(raw[k - 1])} ({self.unit} {int(labels[k - 1])}); times must increase (equal times only "
                "for duplicates of one sample)"
            )
        equal = np.flatnonzero(d == 0) + 1
        if not equal.size:  # the usual case: everything but the last sample, which waits for the next chunk
            self._held = tuple(None if a is None else _take(a, slice(n - 1, n)) for a in arrays)
            return arrays, slice(0, n - 1)
        keep = np.ones(n, dtype=bool)
        self._duplicates(equal, keep, arrays)
        kept = np.flatnonzero(keep)
        self._held = tuple(None if a is None else _take(a, kept[-1:]) for a in arrays)
        return arrays, kept[:-1]

    def finish(self) -> tuple | None:
        """The sample still held back (arrays of length 1), or None."""
        held, self._held = self._held, None
        return held

    def _num(self, x) -> str:
        """A raw time as the file writes it (its exact base added back as decimals: a float would round it)."""
        if self.dates:
            return date_text(int(self.time_base), float(x))
        # in the file's unit where the raw times are seconds, to 12 digits (the subtraction's rounding left out)
        raw = float(f"{float(x) / self.time_scale:.12g}")
        if not self.time_base:
            return repr(raw)
        if isinstance(self.time_base, float):  # a binary float's: the sum is the float the file holds
            return repr(self.time_base + raw)
        exact = Decimal(self.time_base) + Decimal(repr(raw))
        return str(exact.to_integral_value() if exact == exact.to_integral_value() else exact)

    def _rounding(self, t: np.ndarray, raw: np.ndarray, j: int) -> str:
        """For the message of a conflicting duplicate at row ``j`` of a chunk: where the file writes its times
        with a fixed number of significant digits (a ``%g`` export), they lose decimals as they grow (RepoIMU:
        0.001 s early on, 0.01 s from 100 s on, at rows 11 ms apart), and once their step is about the rows'
        spacing, rows share stamps by rounding, not because the clock is broken. Then the rows' mean rate in the
        chunk is given to read them as regular samples. Empty where the decimals do not explain it: the same
        decimals throughout (a fixed-point column of a regular clock), or exact times relative to a base (5)."""
        if self.time_base or j == 0 or raw[j] == raw[0] or raw[j] == 0:
            return ""
        decimals = [-int(Decimal(repr(float(x))).as_tuple().exponent) for x in raw[: j + 1]]
        with np.errstate(divide="ignore"):  # a stamp 0 has no order (-inf): never raw[j]'s
            order = np.floor(np.log10(np.abs(raw[max(0, j - 63) : j + 1])))  # the recent stamps of raw[j]'s order
        near = max(d for d, o in zip(decimals[-order.size :], order, strict=True) if o == order[-1])
        most = max(decimals)
        resolution = 10.0**-near * float((t[j] - t[0]) / (raw[j] - raw[0]))  # in s
        step = float(t[j] - t[0]) / j  # the rows' mean spacing
        if near >= most or not resolution >= 0.5 * step:
            return ""
        return (
            f"the file's times lose decimals as they grow ({most} early on, {near} at {self._num(raw[j])}: a step "
            f"of {resolution:.3g} s) while its rows are {step:.3g} s apart on average, so rows share stamps by "
            "rounding (the clock need not be broken). To read them as regular samples, name the attitude columns in "
            f"--columns without the time and pass --rate {1.0 / step:.6g} (the rows' mean rate in this part of the "
            "log)"
        )

    def _duplicates(self, equal: np.ndarray, keep: np.ndarray, arrays: tuple) -> None:
        t, raw, data, torque, labels, _ = arrays
        n = t.size
        flat = data.reshape(n, -1)
        valid = np.all(np.isfinite(flat), axis=1)
        current = -1  # the sample kept for the current run of equal times
        for j in equal:
            j = int(j)
            if current < 0 or t[current] != t[j]:
                current = j - 1
            if not valid[j]:
                keep[j] = False  # a missing sample at the time of another: nothing to add
                self.n_dropped += 1
            elif not valid[current]:
                keep[current] = False  # the valid sample stands for the missing one kept so far
                self.n_dropped += 1
                current = j
            else:
                what = _difference(self.kind, flat[current], flat[j])
                if what is None and torque is not None:
                    size = float(np.abs(torque[j] - torque[current]).max())
                    if size > DUPLICATE_TOL * (1.0 + np.abs(torque[current]).max()):
                        what = (f"different torques (by up to {size:.3g})", size)
                if what is None:
                    keep[j] = False
                    self.n_dropped += 1
                    continue
                place = f"{self.where(int(labels[current]))} and {self.unit} {int(labels[j])}"
                if self.duplicates == "error":
                    keep_one = (
                        "pass --duplicate-times first or last (duplicate_times= in Python) to keep one sample of each "
                        "such time (the others are dropped, counted and reported)"
                    )
                    rounded = self._rounding(t, raw, j)
                    raise LogFormatError(
                        f"{place}: two samples at the same time {self._num(raw[j])} with {what[0]}"
                        + (
                            f": {rounded}; or {keep_one}"
                            if rounded
                            else ". Duplicated timestamps must carry the same attitude (omegahat drops those); "
                            "conflicting ones mean a broken time source: fix the time column (for a ROS bag, try the "
                            f"receive time: --stamp receive), or {keep_one}"
                        )
                    )
                self.n_conflicts += 1
                if self._conflict_time != t[j]:  # by value: a time's samples may straddle two chunks
                    self.n_conflict_times += 1
                    self._conflict_time = float(t[j])
                if self._worst is None or what[1] > self._worst[0]:
                    self._worst = (what[1], f"{place}, time {self._num(raw[j])}, {what[0]}")
                if self.duplicates == "first":
                    keep[j] = False
                else:  # last: the later sample stands for the time
                    keep[current] = False
                    current = j


def _concat(a, b):
    if a is None:
        return None
    if isinstance(a, dict):
        return {k: np.concatenate([a[k], b[k]]) for k in a}
    return np.concatenate([a, b])


def _take(a, idx):
    if isinstance(a, dict):
        return {k: v[idx] for k, v in a.items()}
    return a[idx]
