r"""One buffer of whole text lines into a :class:`~omegahat.io.registry.LogChunk`: the parse of every text log.

Three tiers, fastest first, each checked against the line table (the line number and byte span of every non-blank
line, counted with NumPy over the bytes, so numbers stay exact across blank lines, comments and chunks):

1. PyArrow's CSV parser reads the needed columns as float64 (the time column as text where times are absolute:
   :class:`omegahat.io.timestamps.ExactTimes`), with a block size covering the buffer (rows of 10⁵ columns);
2. if it rejects a field, the columns are read as text (blanks trimmed, decimal commas turned into points) and the
   first field that is no number is named;
3. if the buffer's structure is not one row per line — a line with an odd number of quotes (a quoted field may not
   span lines: omegahat's logs never need it), or PyArrow's row count differing from the line table's — every line
   is parsed **on its own** by Python's :mod:`csv`, so that a stray quote can never fold later lines into one
   field: a line that then has the wrong number of fields is an error naming it (and the quote), and a field beyond
   Python's field size limit is a message, not a traceback.

Nothing is dropped or merged silently: every non-blank line is a row, or the parse stops naming its line.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Sequence

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from omegahat.io.columns import Layout, LogFormatError, shown_value
from omegahat.io.registry import LogChunk
from omegahat.io.textlines import WHITESPACE, clean, refuse_inner_carriage_return, wrong_width
from omegahat.io.timestamps import ARROW_ERRORS, ExactTimes, first_failure

__all__ = ["ChunkParser"]


class ChunkParser:
    """Parses buffers of whole lines of one log: ``names`` the columns' names as read (after a column map),
    ``labels`` as messages name them, ``lay`` what is read, ``delim`` (:data:`~omegahat.io.textlines.WHITESPACE` for
    blank-separated text), ``header_line`` the header's last line (0: none), ``times`` the time column's
    conversion, ``time_scale`` seconds per time unit the reader applies itself (EuRoC's ns), ``comment``: ``#``
    lines are blank; ``rate`` (Hz, for a log without a time column, ``lay.time`` empty): row ``k`` of the log (a line
    with fields, blank lines not counted) is at ``k / rate`` s, counted across the buffers parsed in order;
    ``extra``: further columns by key (positions in ``names``), read into each chunk's ``extra[key]`` ``(m, k)``
    with NaN for an empty field (they neither make a row a sample nor a blank line)."""

    def __init__(
        self,
        path: str,
        names: Sequence[str],
        labels: Sequence[str],
        lay: Layout,
        delim: str,
        header_line: int,
        times: ExactTimes,
        time_scale: float = 1.0,
        comment: bool = False,
        rate: float | None = None,
        extra: dict[str, list[int]] | None = None,
    ):
        self.path, self.names, self.labels, self.lay = path, list(names), list(labels), lay
        self.delim, self.header_line, self.times, self.time_scale, self.comment = (
            delim,
            header_line,
            times,
            time_scale,
            comment,
        )
        self.n_fields = len(names)
        self.empty_rows, self.first_empty = 0, 0  # rows of delimiters only (a spreadsheet's empty row): skipped, said
        index = {n: i for i, n in enumerate(names) if n}
        self.cols = [f"c{index[c]}" for c in lay.columns]
        self.extra = {key: [f"c{j}" for j in js] for key, js in (extra or {}).items()}
        self.read = self.cols + [c for cols in self.extra.values() for c in cols if c not in self.cols]
        self.time_col = f"c{index[lay.time]}" if lay.time else None
        # --rate: how many rows the earlier buffers held, and the last one's line (times from the rate)
        self.rate, self.rows, self.last_line = rate, 0, 0
        self.decimal_comma = delim not in (",",)
        self.column_names = [f"c{i}" for i in range(self.n_fields)]

    def _where(self, line: int, col: str | None = None) -> str:
        head = f"{self.path}, line {line}"
        return head if col is None else f"{head}, column {self.labels[int(col[1:])]}"

    # -- line bookkeeping ------------------------------------------------------------------------------------

    def _line_table(self, buf: bytes, first_line: int):
        """Line numbers of the non-blank lines with their byte spans, or ``None`` when a line has an odd number of
        quotes (then every line is parsed on its own); and the number of lines."""
        a = np.frombuffer(buf, dtype=np.uint8)
        nl = np.flatnonzero(a == 10)
        ends = nl if buf.endswith(b"\n") else np.append(nl, a.size)
        starts = np.concatenate([[0], nl[: ends.size - 1] + 1])
        length = ends - starts
        cr = (length > 0) & (a[np.maximum(ends - 1, 0)] == 13)
        keep = (length - cr) > 0
        if b'"' in buf:
            qpos = np.flatnonzero(a == 34)
            if np.any((np.searchsorted(qpos, ends) - np.searchsorted(qpos, starts)) % 2):
                return None, ends.size
        numbers = first_line + np.arange(ends.size)
        return (numbers[keep], starts[keep], ends[keep]), ends.size

    def _blank_rows(self, buf: bytes, spans, candidates: np.ndarray) -> np.ndarray:
        """Which of the candidate rows (no needed field filled) hold nothing at all (only delimiters, blanks)."""
        _, starts, ends = spans
        strip = b" \t\r\"'" + self.delim.encode()
        return np.array([not buf[starts[i] : ends[i]].strip(strip) for i in candidates], dtype=bool)

    # -- the tiers -------------------------------------------------------------------------------------------

    def _arrow(self, buf: bytes, as_text: bool) -> pa.Table:
        types = {
            c: pa.string() if as_text or (c == self.time_col and self.times.exact) else pa.float64() for c in self.read
        }
        return pacsv.read_csv(
            io.BytesIO(buf),
            read_options=pacsv.ReadOptions(
                column_names=self.column_names, use_threads=True, block_size=max(1 << 20, len(buf) + 1)
            ),
            parse_options=pacsv.ParseOptions(delimiter=self.delim, ignore_empty_lines=True),
            convert_options=pacsv.ConvertOptions(
                include_columns=self.read,
                column_types=types,
                null_values=[""] if not as_text else [],
                strings_can_be_null=not as_text,
                quoted_strings_can_be_null=not as_text,
                check_utf8=False,
            ),
        )

    def _python_rows(self, buf: bytes, first_line: int) -> tuple[dict[str, list[str]], np.ndarray]:
        """Each line on its own through Python's csv: the needed fields as text, and the line of each row."""
        idx = [int(c[1:]) for c in self.read]
        out: dict[str, list[str]] = {c: [] for c in self.read}
        lines = []
        for k, raw in enumerate(buf.split(b"\n")):
            line = first_line + k
            text = raw.decode("utf-8", errors="replace").rstrip("\r")
            if not text.strip():
                continue
            refuse_inner_carriage_return(text, self._where(line))
            try:
                row = next(csv.reader([text], delimiter=self.delim))
            except csv.Error as exc:  # a field beyond csv.field_size_limit()
                raise LogFormatError(f"{self._where(line)}: {exc} (the limit for one field)") from None
            if not any(f.strip() for f in row):
                continue
            if len(row) != self.n_fields:
                quote = " (a stray quote '\"' joins the fields after it)" if '"' in text else ""
                raise wrong_width(self._where(line), len(row), self.n_fields, self.delim, self.header_line, quote)
            for c, i in zip(self.read, idx, strict=True):
                out[c].append(row[i])
            lines.append(line)
        return out, np.array(lines, dtype=np.int64)

    def _numbers(self, text: pa.Array, lines: np.ndarray, col: str) -> pa.Array:
        """Text → float64 (blanks trimmed, empty → null); the first field that is no number is named."""
        s = pc.utf8_trim_whitespace(text)
        if self.decimal_comma:
            s = pc.replace_substring(s, ",", ".")
        s = pc.if_else(pc.equal(s, ""), pa.scalar(None, pa.string()), s)
        convert = self.times.convert if col == self.time_col else (lambda a: pc.cast(a, pa.float64()))
        try:
            return convert(s)
        except ARROW_ERRORS:
            lo = first_failure(convert, s)
            # the field's bytes, as text whatever they hold (a stray byte that is not UTF-8 is shown, not raised)
            value = text.cast(pa.binary())[lo].as_py().decode("utf-8", errors="replace")
            expected = self.times.expected if col == self.time_col else "a number"
            grouped = expected == "a number" and ("_" in value or (not self.decimal_comma and "," in value))
            hint = " (digit grouping is not read)" if grouped else ""
            if grouped and re.fullmatch(r"[+-]?\d*,\d+", value) and not re.fullmatch(r"[+-]?\d{1,3}(,\d{3})+", value):
                hint = " (a decimal comma: where ',' separates the columns, decimals are written with '.')"
            if col == self.time_col and expected == "a number" and any(ch in value for ch in "/:"):
                hint = " (dates and times are read in ISO 8601 form: 2026-01-31 12:00:00.010)"
            raise LogFormatError(
                f"{self._where(int(lines[lo]), col)}: {shown_value(value)} is not {expected}{hint}"
            ) from None

    def parse(self, buf: bytes, first_line: int) -> tuple[LogChunk | None, int]:
        """``(chunk or None if no rows, number of lines in buf)``."""
        buf = clean(buf, self.comment, self.delim == WHITESPACE)
        spans, n_lines = self._line_table(buf, first_line)
        values = None
        if spans is not None:
            lines = spans[0]
            try:
                table = self._arrow(buf, as_text=False)
                if table.num_rows == lines.size:
                    values = {c: table[c] for c in self.read}
                    if self.times.exact and self.time_col is not None:
                        values[self.time_col] = self._numbers(
                            table[self.time_col].combine_chunks(), lines, self.time_col
                        )
            except ARROW_ERRORS:
                try:
                    table = self._arrow(buf, as_text=True)
                    if table.num_rows == lines.size:  # _numbers raises naming the first field that is no number
                        values = {c: self._numbers(table[c].combine_chunks(), lines, c) for c in self.read}
                except ARROW_ERRORS:
                    values = None
        if values is None:
            text, lines = self._python_rows(buf, first_line)
            values = {c: self._numbers(pa.array(v, pa.string()), lines, c) for c, v in text.items()}
            spans = None
        null = {}
        arrays = {}
        for c, v in values.items():
            arr = v.combine_chunks() if isinstance(v, pa.ChunkedArray) else v
            null[c] = arr.is_null().to_numpy(zero_copy_only=False) if arr.null_count else np.zeros(len(arr), bool)
            arrays[c] = arr.to_numpy(zero_copy_only=False).astype(float, copy=False)
        all_null = np.logical_and.reduce([null[c] for c in self.cols])
        if all_null.any() and spans is not None:  # rows of nothing but delimiters are blank lines
            cand = np.flatnonzero(all_null)
            blank = np.zeros(lines.size, dtype=bool)
            blank[cand] = self._blank_rows(buf, spans, cand)
            if blank.any():
                self.empty_rows += int(blank.sum())  # said once the log is read (csvlog)
                self.first_empty = self.first_empty or int(lines[np.flatnonzero(blank)[0]])
                keep = ~blank
                lines = lines[keep]
                arrays = {c: a[keep] for c, a in arrays.items()}
                null = {c: a[keep] for c, a in null.items()}
        if lines.size == 0:
            return None, n_lines
        return self._chunk(arrays, null, lines), n_lines

    def _col(self, name: str) -> str:
        return f"c{self.names.index(name)}"

    def _chunk(self, arrays, null, lines) -> LogChunk:
        lay = self.lay
        tc = self.time_col
        if tc is None:  # no time column: the rate's
            assert self.rate is not None
            previous = np.concatenate([[self.last_line or lines[0] - 1], lines[:-1]])  # the first row: any line
            skipped = np.flatnonzero(lines - previous > 1)
            if skipped.size:  # a blank or comment line between rows: its frame's time is not known
                raise LogFormatError(
                    f"{self._where(int(lines[skipped[0]]) - 1)}: a line without data between rows; with --rate each "
                    "row is one frame, so every frame needs its row (a missing sample: nan in its fields)"
                )
            t = (self.rows + np.arange(lines.size)) / self.rate
            self.rows, self.last_line = self.rows + lines.size, int(lines[-1])
        else:
            t = np.array(arrays[tc], dtype=float)
            if self.time_scale != 1.0:
                t *= self.time_scale
            empty_t = np.flatnonzero(null[tc])
            if empty_t.size:
                k = int(empty_t[0])
                raise LogFormatError(f"{self._where(int(lines[k]), tc)}: empty time (every row needs one)")
        att = np.column_stack([arrays[self._col(c)] for c in lay.attitude])
        att[~np.all(np.isfinite(att), axis=1)] = np.nan  # one empty or non-finite field: the whole sample missing
        torque = None
        if lay.torque:
            torque = np.column_stack([arrays[self._col(c)] for c in lay.torque])
            bad = np.argwhere(~np.isfinite(torque))
            if bad.size:
                k, j = (int(x) for x in bad[0])
                c = self._col(lay.torque[j])
                if null[c][k]:
                    raise LogFormatError(
                        f"{self._where(int(lines[k]), c)}: empty torque (fill the torque on every row)"
                    )
                raise LogFormatError(f"{self._where(int(lines[k]), c)}: torque {_text(torque[k, j])!r} is not finite")
        if lay.kind == "matrix":
            att = att.reshape(-1, 3, 3)
        elif lay.kind == "directions":
            att = att.reshape(-1, lay.n_directions, 3)
        extra = {key: np.column_stack([arrays[c] for c in cols]) for key, cols in self.extra.items()}
        return LogChunk(t, att, torque, lines, extra or None)


def _text(x: float) -> str:
    return "inf" if x == np.inf else "-inf" if x == -np.inf else "nan"
