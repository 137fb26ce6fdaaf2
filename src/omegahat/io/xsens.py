r"""Xsens exports: the text files MT Manager writes for an MTi or MTw (Awinda), and an Xsens DOT's CSV files.

An export is a preamble of lines starting with ``//`` (``// Update Rate: 100.0Hz`` in older versions; device,
filter and coordinate-system lines in newer ones), then one line of names and one line per sample, separated by
tabs (the default), commas or semicolons::

    // Update Rate: 100.0Hz
    PacketCounter	SampleTimeFine	Acc_X	…	Gyr_X	Gyr_Y	Gyr_Z	Quat_q0	Quat_q1	Quat_q2	Quat_q3

* **Attitude**, the first of these the export holds: the quaternion ``Quat_q0..q3`` (scalar first); the rotation
  matrix ``Mat[i][j]``, the element of row i and column j of R, whatever order the columns come in; the Euler
  angles ``Roll, Pitch, Yaw`` in degrees, R = Rz(yaw) Ry(pitch) Rx(roll) (``ZYX``, :mod:`omegahat.io.euler`). Each
  is the sensor's orientation in the export's global frame (ENU unless the preamble says otherwise): it maps the
  sensor's axes into the global ones (body → inertial, omegahat's ``R``), so the rate comes out in the **sensor's
  axes**, those of ``Gyr_X..Z``. The three agree with each other in MT Manager's exports to their printed digits.
* **Time**, the first of these the export gives: ``SampleTimeFine``, the device's clock in ticks of 100 µs
  (:data:`TICK`), where the rows carry it; else ``PacketCounter`` at the rate of the ``// Update Rate`` line; else
  ``PacketCounter`` at ``--rate HZ`` (newer exports do not state their rate: the message asks for it; given, it
  counts the packets whatever else the export holds). ``SampleTimeFine`` whose steps are more than twice off the
  preamble's rate is refused (its ticks are not MT Manager's), with the ``--rate`` that counts the packets. Both
  counters wrap (``PacketCounter`` is 16 bits: every 11 minutes at 100 Hz; ``SampleTimeFine`` 32 bits) and are
  unwrapped (:func:`unwrapped`). A wireless MTw drops packets: the counter then skips, the times keep the missing
  samples' places, and a note counts them.
* **Gyroscope**: ``Gyr_X..Z`` (rad/s, sensor axes), where the export holds it, is compared with the estimate in the
  command's closing lines. The export's orientation was itself computed from these gyroscopes, so the comparison
  checks frames and conventions, not the estimate's accuracy.

**Xsens DOT** CSV files (as the DOT SDK's logger writes them: ``sep=,``, then ``Key:,value,,,`` lines with
``OutputRate:,60Hz``, a blank line, then ``PacketCounter,SampleTimeFine,Quat_W,Quat_X,Quat_Y,Quat_Z,…``) are read
the same way, told apart by their names: the quaternion ``Quat_W..Z`` (scalar first, the same direction),
``SampleTimeFine`` in microseconds (:data:`DOT_TICK`, checked against ``OutputRate`` as above). Their Euler angles
``Euler_X..Z`` are read as angles about x, y, z whose sequence and unit are asked for (``--euler``,
``--angle-unit``, :mod:`omegahat.io.euler`), and their gyroscope is not compared (the DOT's unit is not stated in
the file). The header of either is the first line naming ``PacketCounter`` or ``SampleTimeFine``; every line above
it is the preamble.

An export separated by single spaces is read only when no field is empty: there, two spaces cannot show an empty
field between them, and it is refused with how to export it otherwise. ``--rotation`` is refused, since the format
states the direction. The lines are read by the CSV reader (chunks of any size, every error naming its line and
column).
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import NamedTuple

import numpy as np

from omegahat.io.colmap import ColumnMap
from omegahat.io.columns import LogFormatError, normalise_name
from omegahat.io.csvlog import TextFormat, open_text
from omegahat.io.euler import matrices, turned_into_matrices
from omegahat.io.registry import LogChunk, LogStream, ReadOptions
from omegahat.io.textlines import WHITESPACE, delimiter, head_lines, split_line

__all__ = ["DOT_TICK", "TICK", "ExportClock", "export_clock", "is_xsens", "open_xsens", "unwrapped"]

TICK = 1e-4  #: SampleTimeFine's unit (s): MT Manager's exports count the device's clock in 10 kHz ticks
DOT_TICK = 1e-6  #: an Xsens DOT's SampleTimeFine counts microseconds
_WRAP = {"packetcounter": 2**16, "sampletimefine": 2**32}  # each counter's modulus
_QUATERNION = (("qw", "quat_q0"), ("qx", "quat_q1"), ("qy", "quat_q2"), ("qz", "quat_q3"))
_MATRIX = tuple((f"r{i}{j}", f"mat[{i}][{j}]") for i in (1, 2, 3) for j in (1, 2, 3))
_EULER = (("roll", "roll"), ("pitch", "pitch"), ("yaw", "yaw"))
_DOT_QUATERNION = (("qw", "quat_w"), ("qx", "quat_x"), ("qy", "quat_y"), ("qz", "quat_z"))
_DOT_EULER = (("roll", "euler_x"), ("pitch", "euler_y"), ("yaw", "euler_z"))  # conventions asked, as any log's
_ATTITUDES = (
    ("Quat_q0..q3", _QUATERNION),
    ("Mat[1][1]..Mat[3][3]", _MATRIX),
    ("Roll, Pitch, Yaw", _EULER),
    ("Quat_W..Z", _DOT_QUATERNION),
    ("Euler_X..Z", _DOT_EULER),
)
_DOT_NAMES = ("quat_w", "euler_x")  # names of an Xsens DOT's export, where MT Manager writes others
_GYROSCOPE = ("gyr_x", "gyr_y", "gyr_z")
# MT Manager's '// Update Rate: 100.0Hz', a DOT's 'OutputRate:,60Hz,,,'
_RATE = re.compile(r"^(?://\s*update rate|outputrate)\s*:[\s,]*([0-9.]+)\s*hz", re.IGNORECASE)
_HEAD = 64  # lines read to find the header and the first rows
# a preamble line of MT Manager ('// ...') or of a DOT ('sep=,', 'DeviceTag:,dot1,,,', a title and commas only)
_PREAMBLE = re.compile(r"^(//.*|sep=.|[A-Za-z][\w .()/-]*:,.*|[^,;\t]*[,;]*)$")


class _Head(NamedTuple):
    """What :func:`_head` found: the preamble's non-blank lines, the header's line number (1-based; 0: none), its
    names (normalised) and delimiter, and the data lines after it."""

    preamble: list[str]
    line: int
    names: list[str]
    delim: str
    rows: list[str]


_NO_HEADER = _Head([], 0, [], ",", [])


def _head(path: str) -> _Head:
    """The export's head (up to :data:`_HEAD` lines are read). The header is the first line naming
    ``PacketCounter`` or ``SampleTimeFine``; every line above it is the preamble (MT Manager's ``//`` lines, a DOT's
    ``sep=,`` and ``Key:,value`` lines)."""
    lines = head_lines(path, _HEAD)
    for k, line in enumerate(lines):
        if not re.search(r"packetcounter|sampletimefine", line, re.IGNORECASE):
            continue
        try:
            delim = delimiter(line, path, True)
            names = [normalise_name(n) for n in split_line(line, delim, path)]
        except LogFormatError:
            return _NO_HEADER
        if {"packetcounter", "sampletimefine"} & set(names):
            preamble = [p.strip() for p in lines[:k] if p.strip()]
            return _Head(preamble, k + 1, names, delim, [r for r in lines[k + 1 :] if r.strip()])
    return _NO_HEADER


def _is_dot(names: list[str]) -> bool:
    """Whether an export's header ``names`` (normalised) are an Xsens DOT's, not MT Manager's."""
    return any(n in names for n in _DOT_NAMES)


def _attitude(names: list[str]) -> tuple[str, tuple[tuple[str, str], ...]] | None:
    return next(((label, group) for label, group in _ATTITUDES if all(c in names for _, c in group)), None)


def is_xsens(path: str | os.PathLike[str]) -> bool:
    """Whether a text file is an Xsens export (MT Manager's or a DOT's): a header naming ``PacketCounter`` or
    ``SampleTimeFine``, under a preamble of Xsens' kind of lines, or with a whole attitude group of Xsens' names."""
    head = _head(os.fspath(path))
    own = bool(head.preamble) and all(_PREAMBLE.match(p) for p in head.preamble)
    return bool(head.line) and (own or _attitude(head.names) is not None)


def unwrapped(raw: np.ndarray, period: float, previous: float | None = None, offset: float = 0.0) -> np.ndarray:
    """Times ``raw`` of a counter that wraps every ``period`` (in the times' unit) made continuous: a step back by
    more than half a period is a wrap. ``previous`` is the raw time before ``raw[0]`` (the last chunk's; None:
    none) and ``offset`` what was added to it; a smaller step back is left as it is, for the timestamp policy to
    name."""
    steps = np.diff(raw, prepend=raw[0] if previous is None else previous)
    return raw + offset + period * np.cumsum(steps < -period / 2)


class ExportClock(NamedTuple):
    """Where an export's times come from (:func:`export_clock`): the ``column`` read (normalised), ``scale`` (s per
    unit: :data:`TICK` for SampleTimeFine; 1 for packet counts, divided by ``rate`` once unwrapped, as
    :meth:`seconds` does), ``rate`` (packets per second where the counter is read, else None), what ``said`` in the
    description, the ``notes``, whether the fields are separated by ``blanks``, the header's line number
    ``header_line`` (the lines above it are the preamble), and whether the export is a ``dot``'s."""

    column: str
    scale: float
    rate: float | None
    said: str
    notes: tuple[str, ...]
    blanks: bool
    header_line: int
    dot: bool

    @property
    def period(self) -> int:
        """The column's modulus, in its own units: the counter wraps there."""
        return _WRAP[self.column]

    def seconds(self, raw: np.ndarray) -> np.ndarray:
        """The whole column ``raw`` as written, unwrapped, in seconds."""
        t = unwrapped(np.asarray(raw, dtype=float), self.period) * self.scale
        return t if self.rate is None else t / self.rate


def export_clock(path: str, rate: float | None) -> ExportClock:
    """The times of the Xsens export at ``path`` (module docstring, **Time**), ``rate`` the one given (Hz, or
    None); refused, naming the line, where they cannot be read (also a space-separated export with empty fields)."""
    preamble, line, names, delim, first = _head(path)
    where = f"{path}, line {line} (header)"
    blanks = delim == WHITESPACE
    if blanks and first and len(first[0].split()) != len(names):
        raise LogFormatError(
            f"{path}, line {line + 1}: {len(first[0].split())} fields under {len(names)} names: this export is "
            "separated by single spaces, where an empty field cannot be told from the space beside it; export it "
            "with tabs (MT Manager's default), commas or semicolons"
        )
    stated = next((float(m.group(1)) for p in preamble if (m := _RATE.match(p))), None)
    if stated is not None and not (math.isfinite(stated) and stated > 0) and rate is None:
        raise LogFormatError(
            f"{path}: the preamble states a rate of {stated:g} Hz, no rate to count packets by; give the rate it "
            "was recorded at: --rate HZ"
        )
    ticks = _column(first, delim, names.index("sampletimefine"), path) if "sampletimefine" in names else None
    if ticks is not None and rate is None:
        tick, unit = (DOT_TICK, "µs, an Xsens DOT's") if _is_dot(names) else (TICK, "100 µs ticks, MT Manager's")
        _check_ticks(ticks, tick, stated, where)
        said = f"SampleTimeFine, the device's clock in {unit}"
        return ExportClock("sampletimefine", tick, None, said, (), blanks, line, _is_dot(names))
    if "packetcounter" not in names:
        raise LogFormatError(f"{path}, line {line + 1}: SampleTimeFine is empty and there is no PacketCounter")
    counted = rate if rate is not None else stated
    if counted is None:
        raise LogFormatError(
            f"{where}: the export does not state its rate (no '// Update Rate' or 'OutputRate' line, SampleTimeFine "
            "empty); give the rate it was recorded at: --rate HZ (MT Manager's update rate; the times are then "
            "PacketCounter / HZ, so dropped packets keep their places)"
        )
    notes = []
    if rate is not None and stated is not None and not np.isclose(rate, stated):
        notes.append(f"--rate {rate:g} Hz used, where the export states {stated:g} Hz")
    if ticks is not None:
        notes.append("SampleTimeFine not read: --rate counts the packets instead")
    said = f"PacketCounter at {counted:g} Hz" + (" (--rate)" if rate is not None else "")
    return ExportClock(
        "packetcounter", 1.0, counted, said, tuple(notes), blanks, line, _is_dot(names)
    )  # counts: exact once divided


def open_xsens(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """The sensor's attitude in an Xsens export, MT Manager's or a DOT's (module docstring)."""
    path = os.fspath(path)
    head = _head(path)
    line, names = head.line, head.names
    found = _attitude(names)
    if found is None:
        groups = ", ".join(label for label, _ in _ATTITUDES)
        raise LogFormatError(
            f"{path}, line {line} (header): an Xsens export without an orientation ({groups}); export it with one "
            "(MT Manager's exporter settings, the DOT's measurement mode)"
        )
    label, group = found
    where = f"{path}, line {line} (header)"
    if options.rotation != "body-to-inertial":
        raise LogFormatError(
            f"{where}: an Xsens orientation maps the sensor's axes into the global frame, as "
            "omegahat's R does; leave --rotation out"
        )
    clock = export_clock(path, options.rate)
    cmap: ColumnMap = (("t", names.index(clock.column) + 1), *((key, names.index(c) + 1) for key, c in group))
    gyro = all(c in names for c in _GYROSCOPE) and not clock.dot  # a DOT's file does not state its unit

    def describe(stream: LogStream, lay, _names) -> str:
        del stream, lay
        device = "DOT" if clock.dot else "MT Manager"
        return (
            f"Xsens {device} export: attitude from {label} (the sensor's axes into the global frame), time from "
            f"{clock.said}; rates in the sensor's axes"
        )

    fmt = TextFormat(
        columns=cmap,
        time_scale=clock.scale,
        describe=describe,
        blanks=clock.blanks,  # tabs, commas or semicolons keep an empty field's place
        preamble_lines=line - 1,
        extra=(("reference_rate", _GYROSCOPE),) if gyro else (),
    )
    stream = open_text(path, replace(options, rate=None), fmt)
    stream.notes.extend(clock.notes)
    if gyro:
        stream.meta["reference_rate"] = (
            "the export's gyroscope (Gyr_X..Z, sensor axes; the orientation was fused from it)"
        )
    _follow_counter(stream, clock.period * clock.scale, clock.rate)
    if group is _EULER:
        stream.notes.append("attitude: Roll, Pitch, Yaw in degrees, R = Rz(yaw) Ry(pitch) Rx(roll) (Xsens' sequence)")
        turned_into_matrices(stream, lambda angles: matrices(angles, "ZYX", True), np.abs, None)
    return stream


def _column(rows: list[str], delim: str, j: int, path: str) -> np.ndarray | None:
    """Field ``j`` of the data lines ``rows`` (separated by ``delim``) as numbers, where the first holds a finite
    one (else None); a field that is no number is NaN (the reader names it later)."""
    values = []
    for row in rows:
        try:
            values.append(float(split_line(row, delim, path)[j]))
        except (LogFormatError, IndexError, ValueError):
            values.append(math.nan)
    return np.array(values) if values and math.isfinite(values[0]) else None


def _check_ticks(ticks: np.ndarray, tick: float, stated: float | None, where: str) -> None:
    """SampleTimeFine's steps against the preamble's rate: a clock counting in another unit than ``tick`` (s) would
    give times off by that factor, so a step more than twice off the stated rate's is refused."""
    steps = np.diff(ticks[np.isfinite(ticks)])
    steps = steps[steps > 0]
    if stated is None or not steps.size:
        return
    implied = 1.0 / (float(np.median(steps)) * tick)
    if not 0.5 < implied / stated < 2.0:
        raise LogFormatError(
            f"{where}: SampleTimeFine steps by {float(np.median(steps)):g} ticks, {implied:.4g} Hz at {tick * 1e6:g} "
            f"µs a tick, where the preamble states {stated:g} Hz: its ticks are not the device's usual ones; count "
            f"the packets instead: --rate {stated:g}"
        )


@dataclass
class _Clock:
    """Where the counter stands between chunks: the last raw time, what was added to it, the packets missed."""

    raw: float | None = None
    offset: float = 0.0
    missing: int = 0
    skips: int = 0


def _follow_counter(stream: LogStream, period: float, rate: float | None) -> None:
    """Unwrap the clock's times as the chunks are read (:func:`unwrapped`). With ``rate`` (Hz) the times are packet
    counts, divided by it once unwrapped, and the packets the counter skips are counted in a note."""
    clock = _Clock()

    def chunks(raw: Iterator[LogChunk]) -> Iterator[LogChunk]:
        for chunk in raw:
            before = None if clock.raw is None else clock.raw + clock.offset
            t = unwrapped(chunk.t, period, clock.raw, clock.offset)
            clock.raw, clock.offset = float(chunk.t[-1]), float(t[-1] - chunk.t[-1])
            if rate is not None:
                steps = np.diff(t, prepend=t[0] if before is None else before)
                clock.missing += int(np.sum(np.maximum(steps - 1, 0)))
                clock.skips += int(np.sum(steps > 1))
                t = t / rate
            yield replace(chunk, t=t)
        if clock.missing:
            stream.notes.append(
                f"{clock.missing} packet(s) missing in {clock.skips} place(s) (PacketCounter skips): the times keep "
                "their places, so the rates across them are those of the time that passed"
            )

    stream.convert(chunks)
