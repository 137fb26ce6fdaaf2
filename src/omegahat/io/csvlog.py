r"""CSV logs, and every text log laid out as columns, read in chunks: fast, memory bounded, errors naming line and
column.

What a CSV log may look like (:mod:`omegahat.io.columns` says which names hold what; :mod:`omegahat.io.textlines`
the encodings, line ends, delimiters and size limits):

* **header**: the first non-blank line names the columns (compared ignoring case and surrounding whitespace; other,
  ignored columns may hold anything); a first line ``sep=,`` above it (Excel's delimiter hint) is skipped with a
  note; a header spanning N rows is read with ``--header-rows N``, a file without one with ``--header-rows 0``
  (:mod:`omegahat.io.colmap`);
* **columns** named otherwise are read with a column map, ``--columns t=NAME,qw=NAME,...`` by name or 1-based
  position; with one, blank-separated columns are read too;
* **rows**: numbers as C's ``strtod`` reads them (``1``, ``-2.5e-3``, ``nan``, ``inf``; surrounding blanks allowed;
  no digit grouping), a decimal comma where the delimiter is not ``,``; blank lines skipped anywhere;
* an **empty field** in the attitude columns makes the whole sample missing (so does ``nan``); time and torque
  must be on every row; times of ``2**20`` and more (seconds since 1970, nanoseconds) keep their precision
  (:class:`omegahat.io.timestamps.ExactTimes`).

How it is read: the file is cut at line ends into chunks of about ``ReadOptions.chunk_bytes`` and each chunk parsed
by :class:`omegahat.io.csvparse.ChunkParser` (PyArrow, then text, then line by line with Python's csv; nothing is
ever merged or dropped silently). :func:`open_text` is that engine for a :class:`TextFormat`; :func:`open_csv`
opens omegahat's CSV, and the trajectory formats of :mod:`omegahat.io.trajectories` (EuRoC, TUM) are
:class:`TextFormat` s too. The significant digits of the first rows' attitude fields go to the precision policy
(:mod:`omegahat.io.precision`).
"""

from __future__ import annotations

import os
import re
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace

from omegahat.io.colmap import (
    COLUMNS_TEMPLATE,
    ColumnMap,
    apply_columns,
    columns_line,
    join_header_rows,
    named_quaternion,
    named_quaternion_note,
    suggest_columns,
)
from omegahat.io.columns import Layout, LogFormatError, layout, normalise_name, time_column_by_name, time_or_capital_t
from omegahat.io.csvparse import ChunkParser
from omegahat.io.precision import significant_digits
from omegahat.io.registry import TIME_UNITS, LogChunk, LogStream, ReadOptions
from omegahat.io.textlines import (
    DELIMITERS,
    WHITESPACE,
    clean,
    comment_above_header,
    cut_lines,
    delimiter,
    excel_separator,
    header_fields,
    is_number,
    source_blocks,
    split_line,
)
from omegahat.io.time_units import unit_stated
from omegahat.io.timestamps import ExactTimes

__all__ = ["TextFormat", "open_by_header", "open_csv", "open_text"]

_DIGIT_ROWS = 200  # rows whose attitude fields say how many digits the file carries


@dataclass(frozen=True)
class TextFormat:
    """A text log's layout for :func:`open_text`: ``header_rows`` (0: none; ``--header-rows`` overrides),
    ``names`` of the columns when there is no header, ``comment`` (``#`` lines are blank), ``blanks`` (columns
    separated by blanks; None: only with a column map), the format's own column ``columns`` (``--columns``
    overrides), ``time_scale`` (seconds per time unit, for formats that state it; then ``--time-unit`` is not
    taken), ``describe(stream, lay, names) -> str`` saying what was recognised (None: omegahat's own columns, said
    as such), ``preamble_lines``: the first lines are the format's own and skipped (Xsens' preamble, whatever it
    holds), and ``extra``: pairs ``(key, names)`` of further columns read into each chunk's
    ``extra[key]`` ``(m, len(names))``, NaN where a field is empty (the rates a log carries, to compare with)."""

    header_rows: int = 1
    names: tuple[str, ...] | None = None
    comment: bool = False
    blanks: bool | None = None
    columns: ColumnMap | None = None
    time_scale: float | None = None
    describe: Callable[[LogStream, Layout, list[str]], str] | None = None
    preamble_lines: int = 0
    extra: tuple[tuple[str, tuple[str, ...]], ...] = ()


class _Lines:
    """The file's lines one by one until the data starts (header, blank and comment lines), then whole buffers."""

    def __init__(self, buffers: Iterator[bytes]):
        self.buffers, self.line = buffers, 0
        self.pending: list[bytes] = []  # the unread lines of the buffers read so far, last first

    def _read_buffer(self) -> bool:
        """Put the next buffer's lines after the unread ones; False at the end of the file."""
        buf = next(self.buffers, None)
        if buf is None:
            return False
        more = buf.split(b"\n")
        if buf.endswith(b"\n"):
            more.pop()
        self.pending[:0] = more[::-1]
        return True

    def next_line(self) -> bytes | None:
        while not self.pending:
            if not self._read_buffer():
                return None
        self.line += 1
        return self.pending.pop()

    def peek_rows(self, n: int) -> list[bytes]:
        """Up to ``n`` of the unread lines (not consumed), from further buffers where the current one ends sooner,
        so that what is seen does not depend on where the buffers end."""
        while len(self.pending) < n and self._read_buffer():
            pass
        return self.pending[::-1][:n]

    def rest(self) -> Iterator[bytes]:
        """Whole buffers from the first unread line on."""
        if self.pending:
            yield b"\n".join(self.pending[::-1]) + b"\n"
            self.pending = []
        yield from self.buffers


def _decode(raw: bytes) -> str:
    try:
        return raw.decode("utf-8").rstrip("\r")
    except UnicodeDecodeError:
        return raw.decode("cp1252", errors="replace").rstrip("\r")


def _blank(raw: bytes, comment: bool) -> bool:
    text = raw.strip(b" \t\r,;\"'")
    return not text or (comment and text.startswith(b"#"))


def open_csv(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """Open a CSV log (module docstring); its header is read now, its rows chunk by chunk."""
    return open_text(path, options, TextFormat())


def open_by_header(
    path: str | os.PathLike[str],
    options: ReadOptions,
    columns_of: Callable[[list[str]], ColumnMap | None],
    refusal: str,
    fmt: TextFormat,
) -> LogStream:
    """Open a text log of a format known by its header (EuRoC, PX4's ulog2csv): ``columns_of`` its first line's
    fields gives the format's column map, read as ``fmt`` says; None is refused with ``refusal``."""
    path = os.fspath(path)
    cmap = columns_of(header_fields(path))
    if cmap is None:
        raise LogFormatError(f"{path}, line 1: {refusal}")
    return open_text(path, options, replace(fmt, columns=cmap))


def open_text(path: str | os.PathLike[str], options: ReadOptions, fmt: TextFormat) -> LogStream:
    """Open a text log laid out as ``fmt`` says (module docstring)."""
    path = os.fspath(path)
    stream = LogStream(path, "", 0, False, "line", lambda: iter(()), size=os.path.getsize(path))
    progress = [0]
    lines = _Lines(cut_lines(source_blocks(path, max(1 << 12, options.chunk_bytes), stream.notes, progress), path))
    n_header = fmt.header_rows if options.header_rows is None else options.header_rows
    comment = fmt.comment or n_header == 0  # without a header, a '#' line can only be a comment
    header: list[bytes] = []
    first = None
    skipped_comments = 0
    while len(header) < max(n_header, 1):
        raw = lines.next_line()
        if raw is None:
            break
        if not header and _blank(clean(raw, comment, False), comment):
            continue
        if lines.line <= fmt.preamble_lines:  # the format's own preamble: no comment to mention
            continue
        if not header and n_header and excel_separator(_decode(raw)):  # Excel's hint: the header follows
            stream.notes.append(f"line {lines.line}: {_decode(raw.strip())!r}, Excel's delimiter hint, skipped")
            continue
        if not header and n_header and raw.lstrip().startswith((b"#", b"//")):  # '# sampling frequency: 30' above
            if comment_above_header(_decode(raw), [_decode(x) for x in lines.peek_rows(8)]):  # the next line decides
                skipped_comments += 1
                continue
        if n_header == 0:  # no header: the first row shows the layout, and is data
            first = raw
            lines.pending.append(raw)
            lines.line -= 1
            break
        header.append(raw)
        first = first or raw
    if first is None:
        raise LogFormatError(
            f"{path}: empty file, expected " + ("a header line naming the columns" if n_header else "rows")
        )
    if n_header and len(header) < n_header:
        raise LogFormatError(f"{path}: {len(header)} line(s), but --header-rows {n_header} asks for {n_header}")
    header_line = lines.line if n_header else 0
    where = f"{path}, line {header_line - len(header) + 1}" + (" (header)" if n_header else "")
    mapped = options.column_map or fmt.columns
    allow_blanks = fmt.blanks if fmt.blanks is not None else bool(mapped)
    first_text = _decode(clean(first, False, allow_blanks and fmt.blanks is not False))
    if n_header:
        _refuse_numbers_as_names(first_text, where)
    delim = delimiter(first_text, where, allow_blanks)
    rows = [split_line(_decode(clean(h, False, delim == WHITESPACE)), delim, where) for h in header]
    if n_header == 0:
        width = len(split_line(first_text, delim, where))
        original = list(fmt.names) if fmt.names and len(fmt.names) == width else [str(j + 1) for j in range(width)]
    else:
        original = rows[0] if n_header == 1 else join_header_rows(rows)
    if not mapped and n_header:  # no attitude columns of omegahat's names: the one quaternion named by its parts
        mapped = named_quaternion(original, options.time_column, options.rate is not None)
        stream.notes.extend([named_quaternion_note(mapped)] if mapped else [])
    names = apply_columns(original, mapped, where, options.time_column)
    time_column: str | None = "t" if mapped and "t" in dict(mapped) else options.time_column
    if "t" not in dict(mapped or ()) and options.rate is None:  # no column t: the one named as a time, if one is
        ask = time_or_capital_t(original, options.time_column) if n_header else None
        if ask:
            raise LogFormatError(f"{where}: {ask}")
        time_column, named = time_column_by_name(names, options.time_column)
        stream.notes.extend([named] if named else [])
    has_time = bool(time_column) and normalise_name(str(time_column)) in {normalise_name(n) for n in names}
    rate = options.rate  # --rate: a log without times (row k at k / rate)
    if rate is not None:
        if options.time_unit != "s":
            raise LogFormatError(
                f"{where}: --time-unit is the unit of a time column; with --rate the times are row / rate s"
            )
        # a column map that leaves the time out reads the rows as regular samples (stamps rounded onto each other)
        if has_time and not (options.column_map and "t" not in dict(options.column_map)):
            raise LogFormatError(
                f"{where}: the log has a time column {time_column!r}; leave --rate out (it gives the times of a log "
                "without any), or name the columns to read in --columns without t to replace the log's times"
            )
        time_column = None
    sample = [
        split_line(_decode(r), delim, where)
        for r in lines.peek_rows(_DIGIT_ROWS)
        if not _blank(clean(r, comment, False), comment)
    ]
    try:
        lay = layout(names, where, time_column, options.scalar_first)
    except LogFormatError as exc:
        own = fmt.describe is None  # omegahat's own CSV (the formats recognised by name take no --rate)
        untimed = "; a log without times: --rate HZ (row k at k / HZ)" if own and not has_time and rate is None else ""
        raise LogFormatError(f"{exc}{untimed}{_hint(original, rows, sample, mapped)}") from None
    labels = [_label(o, n) for o, n in zip(original, names, strict=True)]
    times = _first_time(sample, names.index(lay.time)) if lay.time else ExactTimes("0")
    digit_cols = [names.index(c) for c in lay.attitude]
    stream.digits = significant_digits(r[j] for r in sample for j in digit_cols if j < len(r))
    stream.kind, stream.has_torque, stream.n_directions = lay.kind, lay.torque is not None, lay.n_directions
    stream.time_name = labels[names.index(lay.time)] if lay.time else f"row / {rate:g} Hz"
    stream.attitude_name = _attitude_name(lay, labels, names)
    stream.columns = _columns_read(lay, original, names)
    j_time = names.index(lay.time) if lay.time else -1
    head_times = [r[j_time] for r in sample if 0 <= j_time < len(r)]
    if times.dates is not None:
        _read_dates(stream, options, where, times, labels[j_time])
        time_scale = None
    else:
        time_scale = _time_scale(stream, fmt, options, original[j_time].strip() if lay.time else "", head_times)
    scale = time_scale if time_scale is not None else TIME_UNITS[options.time_unit]
    stream.t0 = times.base * scale
    if times.exact:
        stream.meta["time_base"] = times.base  # in the file's unit, exactly (descriptions)
        stream.meta["time_scale"] = time_scale or 1.0  # the chunks' raw times: seconds where the unit is stated
    if lay.kind == "quaternion" and options.scalar_first is not None and lay.quaternion_named:
        stream.notes.append(
            f"--scalar-{'first' if options.scalar_first else 'last'} not needed: the header names qw,qx,qy,qz say "
            "which is the scalar part"
        )
    if delim != "," and fmt.blanks is None:
        stream.notes.append(
            f"delimiter: {DELIMITERS[delim]}" + (" (decimal comma accepted)" if delim != WHITESPACE else "")
        )
    if options.column_map:
        stream.notes.append(f"columns read: {stream.columns}")
    if rate is not None:
        stream.notes.append(f"times: row k at k / {rate:g} s (--rate; the log has no time column)")
    if skipped_comments:
        stream.notes.append(f"{skipped_comments} comment line(s) starting with '#' or '//' above the header skipped")
    extra = {key: [names.index(normalise_name(n)) for n in cols] for key, cols in fmt.extra}
    parser = ChunkParser(path, names, labels, lay, delim, header_line, times, time_scale or 1.0, comment, rate, extra)
    if fmt.describe is not None:
        stream.description = fmt.describe(stream, lay, original)
    else:  # omegahat's own columns: what each was read as, as every other reader says
        stream.description = f"CSV log: {lay.kind} columns {stream.attitude_name}, time {stream.time_name}"

    def chunks() -> Iterator[LogChunk]:
        line = lines.line + 1
        seen = False
        for buf in lines.rest():
            chunk, n = parser.parse(buf, line)
            stream.done = progress[0]
            line += n
            if chunk is not None:
                seen = True
                yield chunk
        if not seen:
            raise LogFormatError(
                f"{path}: no data rows" + (f" after the header (line {header_line})" if n_header else "")
            )
        if parser.empty_rows:
            stream.notes.append(
                f"{parser.empty_rows} rows of delimiters only (empty rows, as a spreadsheet exports them; the first at "
                f"line {parser.first_empty}) read as blank lines: no sample there"
            )

    stream._chunks = chunks
    return stream


def _time_scale(stream: LogStream, fmt: TextFormat, options: ReadOptions, column: str, head: list[str]):
    """Seconds per unit of the time ``column`` where the reader decides it (None: ``--time-unit``'s): the
    format's, or where ``--time-unit`` is s (its default) the unit the column's name states, or else the one its
    first times (``head``, as written) can be in (:func:`omegahat.io.time_units.unit_by_magnitude`); said in a
    note."""
    if fmt.time_scale is not None or not column:
        return fmt.time_scale
    unit, note = unit_stated(column, options.time_unit, [float(v) for v in head if is_number(v, decimal_comma=False)])
    if note:
        stream.notes.append(note)
    return TIME_UNITS[unit] if unit else None


def _read_dates(stream: LogStream, options: ReadOptions, where: str, times: ExactTimes, column: str) -> None:
    """A time column of dates (:class:`~omegahat.io.timestamps.ExactTimes`, (6)): its unit is the dates' own, and
    a note says how they are read and written back."""
    if options.time_unit != "s":
        raise LogFormatError(
            f"{where}: the time column {column!r} holds dates, which carry their own unit; leave --time-unit out"
        )
    stream.meta["time_dates"] = True
    stream.notes.append(f"times: {times.dates_note}; the output's times are written so")


def _columns_read(lay: Layout, original: list[str], names: list[str]) -> str:
    """The ``--columns`` line that reads what ``lay`` reads (its keys: t, then qw qx qy qz or the attitude's)."""
    att = list(lay.attitude)
    keys = ["qw", "qx", "qy", "qz"] if lay.kind == "quaternion" else att
    cols = [att[3], *att[:3]] if lay.kind == "quaternion" else att  # storage order x, y, z, w
    timed = [("t", lay.time)] if lay.time else []  # --rate: no time column
    pairs = [*timed, *zip(keys, cols, strict=True), *((c, c) for c in lay.torque or ())]
    return columns_line([(k, _column_ref(original, names.index(c))) for k, c in pairs])


def _column_ref(original: list[str], j: int) -> str | int:
    """A column as ``--columns`` names it: its name when that is unambiguous on a command line, else its position."""
    name = original[j].strip()
    ok = (
        name
        and not any(c in name for c in ",=")
        and (not name.isdigit() or name == str(j + 1))  # digits are read as a position
        and [o.strip() for o in original].count(name) == 1
    )
    return name if ok else j + 1


def _label(original: str, name: str) -> str:
    own = normalise_name(original)
    return own if own == name or not name else f"{original.strip()} ({name})"


def _attitude_name(lay: Layout, labels: list[str], names: list[str]) -> str:
    if any(labels[names.index(c)] != c for c in lay.attitude):
        return ",".join(labels[names.index(c)] for c in lay.attitude)
    if lay.kind == "quaternion" and lay.quaternion_named:
        return "qw,qx,qy,qz"
    if lay.kind == "quaternion":
        return ",".join(sorted(lay.attitude))
    if lay.kind in ("euler", "rotvec"):
        return ",".join(lay.attitude)
    return "r11..r33" if lay.kind == "matrix" else f"b1x..b{lay.n_directions}z"


def _first_time(sample: list[list[str]], j: int) -> ExactTimes:
    """The time conversion, decided on the first row's time (absolute times are kept exact)."""
    first = next((r[j] for r in sample if j < len(r) and r[j].strip()), "0")
    return ExactTimes(first)


def _refuse_numbers_as_names(text: str, where: str) -> None:
    """A header line of numbers only is the first row of a file without a header: read as names, that row would be
    lost, so it is refused with the options that read it (positions for the usual widths)."""
    fields = [f for f in re.split(r"[,;\t ]+", text.strip()) if f]
    if len(fields) < 2 or not all(is_number(f, decimal_comma=False) for f in fields):
        return
    if fields in ([str(j) for j in range(len(fields))], [str(j + 1) for j in range(len(fields))]):
        return  # columns numbered 0.. or 1.. (pandas writes a frame's default names so): names, not a row
    by_width = {
        5: "--columns t=1,qw=2,qx=3,qy=4,qz=5 (the quaternion's scalar first; t=1,qx=2,qy=3,qz=4,qw=5 if last)",
        10: "--columns t=1," + ",".join(f"r{i}{j}={3 * i + j - 2}" for i in (1, 2, 3) for j in (1, 2, 3)),
    }
    line = by_width.get(len(fields), "--columns t=1,qw=2,... (which column holds what, by position)")
    raise LogFormatError(
        f"{where}: numbers where the header should name the columns ({', '.join(fields[:5])}"
        f"{', ...' if len(fields) > 5 else ''}): a file without a header is read with --header-rows 0 and {line}"
    )


def _hint(original: list[str], rows: list[list[str]], sample: list[list[str]], mapped) -> str:
    """What to try when the columns are not found: more header rows, or the ``--columns`` line."""
    if len(rows) == 1 and sample and any(not f.strip() for f in original):
        first = sample[0]
        texts = [f for f in first if f.strip()]
        if texts and sum(not is_number(f) for f in texts) > len(texts) // 2:
            # the two rows joined as --header-rows 2 joins them: the columns line for them too, so one retry reads it
            line = COLUMNS_TEMPLATE if mapped else suggest_columns(join_header_rows([rows[0], first]))
            both = "" if line == COLUMNS_TEMPLATE else f" {line}"  # a line that reads the file, not the template
            return f"; the header seems to span 2 rows (names under empty cells): try --header-rows 2{both}"
    if mapped:
        return ""
    return f"; to read other columns: {suggest_columns(original)}"
