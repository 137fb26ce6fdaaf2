r"""CSV logs, read in chunks with PyArrow's CSV parser: fast, memory bounded, every error naming line and column.

What a CSV log may look like (:mod:`omegahat.io.columns` says which names hold what):

* **encoding**: UTF-8, with or without a byte-order mark (spreadsheet programs write one), or UTF-16 with its
  byte-order mark (transcoded on the fly). Column names are compared ignoring case and surrounding whitespace;
  other, ignored columns may hold anything;
* **delimiter**: ``,`` ``;`` or tab, whichever the header line holds most of (outside quotes). With ``;`` or tab a
  decimal comma (``0,5``) is read as a decimal point;
* **header**: the first non-blank line; **rows**: numbers as C's ``strtod`` reads them (``1``, ``-2.5e-3``,
  ``nan``, ``inf``; surrounding blanks allowed; no digit grouping), blank lines skipped anywhere;
* an **empty field** in the attitude columns makes the whole sample missing (so does ``nan``); time and torque
  must be on every row.

How it is read. The file is cut at line ends into chunks of about ``ReadOptions.chunk_bytes``; the line number
of every row comes from counting the line ends in the chunk (NumPy over the bytes), so it stays exact across
blank lines and chunks. Each chunk goes through PyArrow's parser, reading only the needed columns as float64.
If PyArrow rejects a chunk, the chunk is read again as text (blanks trimmed, decimal commas turned into points)
and the first field that is not a number is located and named; a chunk whose structure PyArrow cannot follow
(a wrong number of fields, a quoted field spanning lines) is read by Python's :mod:`csv`, which names the line.
"""

from __future__ import annotations

import codecs
import csv
import io
import os
from collections.abc import Iterator

import numpy as np
import pyarrow as pa
import pyarrow.compute as pc
import pyarrow.csv as pacsv

from omegahat.io.columns import Layout, LogFormatError, layout, normalise_name
from omegahat.io.registry import LogChunk, LogStream, ReadOptions

__all__ = ["open_csv"]

_DELIMITERS = {",": "','", ";": "';'", "\t": "tab"}


def _source_blocks(path: str, block: int, stream: LogStream) -> Iterator[bytes]:
    """UTF-8 bytes of the file in blocks (BOM removed; UTF-16 transcoded); ``stream.done`` counts raw bytes."""
    with open(path, "rb") as f:
        head = f.read(4)
        if head.startswith(codecs.BOM_UTF8):
            f.seek(3)
            decoder = None
        elif head.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
            f.seek(2)
            decoder = codecs.getincrementaldecoder("utf-16-le" if head[:2] == codecs.BOM_UTF16_LE else "utf-16-be")()
        elif len(head) >= 2 and (head[0] == 0) != (head[1] == 0):
            raise LogFormatError(
                f"{path}: looks like UTF-16 text without a byte-order mark; save it as UTF-8 (or UTF-16 with BOM)"
            )
        else:
            f.seek(0)
            decoder = None
        stream.done = f.tell()
        while True:
            raw = f.read(block)
            stream.done = f.tell()
            if decoder is None:
                if not raw:
                    return
                yield raw
            else:
                try:
                    text = decoder.decode(raw, final=not raw)
                except UnicodeDecodeError as exc:
                    raise LogFormatError(f"{path}: not valid UTF-16 text ({exc.reason})") from None
                if text:
                    yield text.encode("utf-8")
                if not raw:
                    return


def _lines(blocks: Iterator[bytes]) -> Iterator[bytes]:
    """Blocks cut after their last line end (the rest is carried into the next block)."""
    carry = b""
    for b in blocks:
        buf = carry + b
        cut = buf.rfind(b"\n")
        if cut < 0:
            carry = buf
            continue
        carry = buf[cut + 1 :]
        yield buf[: cut + 1]
    if carry:
        yield carry


def _delimiter(line: str, where: str) -> str:
    counts = {}
    for d in _DELIMITERS:
        inside, n = False, 0
        for ch in line:
            if ch == '"':
                inside = not inside
            elif ch == d and not inside:
                n += 1
        counts[d] = n
    best = max(counts, key=lambda d: counts[d])
    if counts[best] == 0:
        seen = " (it has spaces: whitespace-separated files are not read)" if " " in line.strip() else ""
        raise LogFormatError(
            f"{where}: no ',' ';' or tab between the column names {line.strip()[:60]!r}{seen}; separate the columns "
            "with one of them"
        )
    return best


class _Parser:
    """Turns a buffer of whole lines into a :class:`LogChunk` (module docstring: the three tiers)."""

    def __init__(self, path: str, names: list[str], lay: Layout, delim: str, header_line: int):
        self.path, self.names, self.lay, self.delim, self.header_line = path, names, lay, delim, header_line
        self.n_fields = len(names)
        index = {n: i for i, n in enumerate(names)}
        self.cols = [f"c{index[c]}" for c in lay.columns]
        self.decimal_comma = delim != ","

    # -- line bookkeeping ------------------------------------------------------------------------------------

    def _line_table(self, buf: bytes, first_line: int):
        """Line numbers of the rows PyArrow will produce (it skips empty lines) with their byte spans, or
        ``None`` when a quoted field spans lines (then Python's csv takes over); and the number of lines."""
        a = np.frombuffer(buf, dtype=np.uint8)
        nl = np.flatnonzero(a == 10)
        ends = nl if buf.endswith(b"\n") else np.append(nl, a.size)
        starts = np.concatenate([[0], nl[: ends.size - 1] + 1])
        length = ends - starts
        cr = (length > 0) & (a[np.maximum(ends - 1, 0)] == 13)
        keep = (length - cr) > 0
        if b'"' in buf:  # each row must close its quotes on its own line
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
        typ = pa.string() if as_text else pa.float64()
        return pacsv.read_csv(
            io.BytesIO(buf),
            read_options=pacsv.ReadOptions(column_names=[f"c{i}" for i in range(self.n_fields)], use_threads=True),
            parse_options=pacsv.ParseOptions(delimiter=self.delim, ignore_empty_lines=True),
            convert_options=pacsv.ConvertOptions(
                include_columns=self.cols,
                column_types=dict.fromkeys(self.cols, typ),
                null_values=[""] if not as_text else [],
                strings_can_be_null=False,
                quoted_strings_can_be_null=not as_text,
                check_utf8=False,
            ),
        )

    def _python_rows(self, buf: bytes, first_line: int) -> tuple[dict[str, list[str]], np.ndarray]:
        """Python's csv over the buffer: the needed fields as text, and the line of each row."""
        text = buf.decode("utf-8", errors="replace")
        reader = csv.reader(io.StringIO(text, newline=""), delimiter=self.delim)
        idx = [int(c[1:]) for c in self.cols]
        out: dict[str, list[str]] = {c: [] for c in self.cols}
        lines = []
        for row in reader:
            line = first_line + reader.line_num - 1
            if not any(f.strip() for f in row):
                continue
            if len(row) != self.n_fields:
                raise LogFormatError(
                    f"{self.path}, line {line}: {len(row)} fields, but the header (line {self.header_line}) names "
                    f"{self.n_fields} (delimiter {_DELIMITERS[self.delim]})"
                )
            for c, i in zip(self.cols, idx, strict=True):
                out[c].append(row[i])
            lines.append(line)
        return out, np.array(lines, dtype=np.int64)

    def _numbers(self, text: pa.Array, lines: np.ndarray, col: str) -> pa.Array:
        """Text → float64 (blanks trimmed, empty → null); the first field that is no number is named."""
        s = pc.utf8_trim_whitespace(text)
        if self.decimal_comma:
            s = pc.replace_substring(s, ",", ".")
        s = pc.if_else(pc.equal(s, ""), pa.scalar(None, pa.string()), s)
        try:
            return pc.cast(s, pa.float64())
        except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
            lo, hi = 0, len(s)  # bisect for the first element that does not cast
            while hi - lo > 1:
                mid = (lo + hi) // 2
                try:
                    pc.cast(s[lo:mid], pa.float64())
                    lo = mid
                except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
                    hi = mid
            value = text[lo].as_py()
            name = self.names[int(col[1:])]
            hint = " (digit grouping is not read)" if "_" in value or (not self.decimal_comma and "," in value) else ""
            raise LogFormatError(
                f"{self.path}, line {int(lines[lo])}, column {name}: {value!r} is not a number{hint}"
            ) from None

    def parse(self, buf: bytes, first_line: int) -> tuple[LogChunk | None, int]:
        """``(chunk or None if no rows, number of lines in buf)``."""
        spans, n_lines = self._line_table(buf, first_line)
        values = None
        if spans is not None:
            lines = spans[0]
            try:
                table = self._arrow(buf, as_text=False)
                if table.num_rows == lines.size:
                    values = {c: table[c] for c in self.cols}
            except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
                try:
                    table = self._arrow(buf, as_text=True)
                    if table.num_rows == lines.size:  # _numbers raises naming the first field that is no number
                        values = {c: self._numbers(table[c].combine_chunks(), lines, c) for c in self.cols}
                except (pa.ArrowInvalid, pa.ArrowNotImplementedError):
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
                keep = ~blank
                lines = lines[keep]
                arrays = {c: a[keep] for c, a in arrays.items()}
                null = {c: a[keep] for c, a in null.items()}
        if lines.size == 0:
            return None, n_lines
        return self._chunk(arrays, null, lines), n_lines

    def _chunk(self, arrays, null, lines) -> LogChunk:
        lay = self.lay
        tc = f"c{self.names.index(lay.time)}"
        t = np.array(arrays[tc], dtype=float)
        empty_t = np.flatnonzero(null[tc])
        if empty_t.size:
            k = int(empty_t[0])
            raise LogFormatError(
                f"{self.path}, line {int(lines[k])}, column {lay.time}: empty time (every row needs one)"
            )
        att = np.column_stack([arrays[f"c{self.names.index(c)}"] for c in lay.attitude])
        att[~np.all(np.isfinite(att), axis=1)] = np.nan  # one empty or non-finite field: the whole sample missing
        torque = None
        if lay.torque:
            torque = np.column_stack([arrays[f"c{self.names.index(c)}"] for c in lay.torque])
            bad = np.argwhere(~np.isfinite(torque))
            if bad.size:
                k, j = (int(x) for x in bad[0])
                c = lay.torque[j]
                if null[f"c{self.names.index(c)}"][k]:
                    raise LogFormatError(
                        f"{self.path}, line {int(lines[k])}, column {c}: empty torque (fill the torque on every row)"
                    )
                raise LogFormatError(
                    f"{self.path}, line {int(lines[k])}, column {c}: torque {_text(torque[k, j])!r} is not finite"
                )
        if lay.kind == "matrix":
            att = att.reshape(-1, 3, 3)
        elif lay.kind == "directions":
            att = att.reshape(-1, lay.n_directions, 3)
        return LogChunk(t, att, torque, lines)


def _text(x: float) -> str:
    return "inf" if x == np.inf else "-inf" if x == -np.inf else "nan"


def open_csv(path: str | os.PathLike[str], options: ReadOptions) -> LogStream:
    """Open a CSV log (module docstring); its header is read now, its rows chunk by chunk."""
    path = os.fspath(path)
    size = os.path.getsize(path)
    stream = LogStream(path, "", 0, False, "line", lambda: iter(()), size=size)
    lines = _lines(_source_blocks(path, max(1 << 12, options.chunk_bytes), stream))
    first_line = 1
    header_text, rest = None, b""
    for buf in lines:
        text_lines = buf.split(b"\n")
        for i, raw in enumerate(text_lines):
            if raw.strip(b" \t\r,;\"'"):
                header_text = raw
                rest = b"\n".join(text_lines[i + 1 :])
                first_line += i
                break
        if header_text is not None:
            break
        first_line += buf.count(b"\n")
    if header_text is None:
        raise LogFormatError(f"{path}: empty file, expected a header line naming the columns")
    try:
        header = header_text.decode("utf-8").rstrip("\r")
    except UnicodeDecodeError:
        header = header_text.decode("cp1252", errors="replace").rstrip("\r")
    where = f"{path}, line {first_line} (header)"
    delim = _delimiter(header, where)
    names = [normalise_name(n) for n in next(csv.reader([header], delimiter=delim))]
    lay = layout(names, where, options.time_column, options.scalar_first)
    stream.kind, stream.has_torque, stream.n_directions = lay.kind, lay.torque is not None, lay.n_directions
    stream.time_name = lay.time
    stream.attitude_name = {"quaternion": "qw,qx,qy,qz", "matrix": "r11..r33"}.get(
        lay.kind, f"b1x..b{lay.n_directions}z"
    )
    if lay.kind == "quaternion" and not lay.quaternion_named:
        stream.attitude_name = ",".join(sorted(lay.attitude))
    if lay.kind == "quaternion" and options.scalar_first is not None and lay.quaternion_named:
        stream.notes.append(
            f"--scalar-{'first' if options.scalar_first else 'last'} not needed: the header names qw,qx,qy,qz say "
            "which is the scalar part"
        )
    if delim != ",":
        stream.notes.append(f"delimiter: {_DELIMITERS[delim]} (decimal comma accepted)")
    parser = _Parser(path, names, lay, delim, first_line)

    def chunks() -> Iterator[LogChunk]:
        line = first_line + 1
        seen = False
        for buf in _with_rest(rest, lines):
            chunk, n = parser.parse(buf, line)
            line += n
            if chunk is not None:
                seen = True
                yield chunk
        if not seen:
            raise LogFormatError(f"{path}: no data rows after the header (line {first_line})")

    stream._chunks = chunks
    return stream


def _with_rest(rest: bytes, lines: Iterator[bytes]) -> Iterator[bytes]:
    if rest:
        yield rest
    yield from lines
