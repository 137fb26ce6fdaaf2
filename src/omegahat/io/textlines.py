r"""Text logs as bytes, before any parser sees them: encodings, line ends, comments, delimiters, size limits.

What a text log (omegahat's CSV, EuRoC, TUM, a file read with a column map) may be:

* **encoding**: UTF-8, with or without a byte-order mark, or UTF-16 with its byte-order mark (transcoded on the
  fly); UTF-16 without a mark is refused with a message;
* **line ends**: ``\n`` or ``\r\n``, or ``\r`` alone (classic Mac OS; Excel's "CSV (Macintosh)"), which is read as
  line ends and noted;
* **comments** (formats that have them, e.g. TUM): a line whose first non-blank character is ``#`` is blank; above
  a header, a ``#`` or ``//`` line is a comment unless the data follow it (:func:`comment_above_header`);
* **delimiter**: ``,`` ``;`` or tab, whichever the header line holds most of outside quotes; runs of blanks for the
  whitespace-separated formats (TUM, KITTI) and for files read with a column map;
* **sizes**: a line longer than :data:`MAX_LINE_BYTES` or a header of more than
  :data:`omegahat.io.columns.MAX_COLUMNS` columns is refused before it is split (the limit is in the message).

Every buffer handed on ends at a line end and keeps every line end, so that line numbers count from the file.
"""

from __future__ import annotations

import codecs
import csv
import re
from collections.abc import Iterator, Sequence

from omegahat.io.columns import MAX_COLUMNS, LogFormatError

__all__ = [
    "DELIMITERS",
    "MAX_LINE_BYTES",
    "WHITESPACE",
    "clean",
    "comment_above_header",
    "cut_lines",
    "delimiter",
    "excel_separator",
    "head_lines",
    "header_fields",
    "is_number",
    "source_blocks",
    "split_line",
]

DELIMITERS = {",": "','", ";": "';'", "\t": "tab", " ": "blanks"}
WHITESPACE = " "  #: the delimiter of whitespace-separated text (runs of blanks are one separator)
MAX_LINE_BYTES = 64 << 20  #: a longer line is refused (a binary file, or one without line ends)
_COMMENT = re.compile(rb"(?m)^[ \t]*#[^\n]*")


def source_blocks(path: str, block: int, notes: list[str], progress: list[int]) -> Iterator[bytes]:
    """UTF-8 bytes of the file in blocks (BOM removed; UTF-16 transcoded; CR-only line ends turned into ``\\n``);
    ``progress[0]`` counts the raw bytes read; ``notes`` gets what was converted."""
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
        progress[0] = f.tell()
        cr_only: bool | None = None
        while True:
            raw = f.read(block)
            progress[0] = f.tell()
            if decoder is None:
                out = raw
            else:
                try:
                    out = decoder.decode(raw, final=not raw).encode("utf-8")
                except UnicodeDecodeError as exc:
                    raise LogFormatError(f"{path}: not valid UTF-16 text ({exc.reason})") from None
            if cr_only is None and out:
                cr_only = b"\n" not in out and b"\r" in out  # decided on the first block: a file has one convention
                if cr_only:
                    notes.append("line ends: CR only (classic Mac OS, Excel 'CSV (Macintosh)'), read as line ends")
            if out:
                yield out.replace(b"\r", b"\n") if cr_only else out
            if not raw:
                return


def head_lines(path: str, n: int = 12, size: int = 1 << 16) -> list[str]:
    """The first ``n`` lines of a text file as the readers see them (for the sniffers: never raises; an unreadable
    file gives no lines, and the reader then says what is wrong)."""
    try:
        blocks = source_blocks(path, size, [], [0])
        data = next(blocks, b"")
    except (OSError, LogFormatError):
        return []
    return [line.rstrip("\r") for line in data.decode("utf-8", errors="replace").split("\n")[:n]]


def header_fields(path: str) -> list[str]:
    """The first line's comma-separated fields, blanks trimmed (for the sniffers of CSV formats; never raises)."""
    lines = head_lines(path, 1)
    return [f.strip() for f in lines[0].split(",")] if lines else []


def cut_lines(blocks: Iterator[bytes], path: str) -> Iterator[bytes]:
    """Blocks cut after their last line end (the rest carried into the next block); a line longer than
    :data:`MAX_LINE_BYTES` is refused naming it."""
    carry = b""
    lines = 0
    for b in blocks:
        buf = carry + b
        cut = buf.rfind(b"\n")
        if cut < 0:
            if len(buf) > MAX_LINE_BYTES:
                raise LogFormatError(
                    f"{path}, line {lines + 1}: longer than {MAX_LINE_BYTES} bytes without a line end (the limit "
                    "for one line); is it a text log?"
                )
            carry = buf
            continue
        carry = buf[cut + 1 :]
        part = buf[: cut + 1]
        lines += part.count(b"\n")
        yield part
    if carry:
        yield carry


def clean(buf: bytes, comment: bool, blanks: bool) -> bytes:
    """``buf`` with comment lines emptied (``comment``) and runs of blanks made one space, none at the line ends
    (``blanks``: whitespace-separated text); line ends kept, so line numbers do not move. A carriage return that
    ends no line is kept: it is no blank, and the parser names its line (a lone CR ends a line in some files)."""
    if comment and b"#" in buf:
        buf = _COMMENT.sub(b"", buf)
    if blanks:  # bytes methods, not a regular expression: ten times faster on the usual single spaces
        buf = buf.replace(b"\t", b" ").replace(b"\r\n", b"\n")
        while b"  " in buf:
            buf = buf.replace(b"  ", b" ")
        buf = buf.replace(b"\n ", b"\n").replace(b" \n", b"\n").removeprefix(b" ").removesuffix(b" ")
    return buf


def delimiter(line: str, where: str, allow_blanks: bool) -> str:
    """The delimiter of a header (or first) line: ``,`` ``;`` or tab, the most frequent outside quotes; blanks if
    ``allow_blanks`` and there is none of them."""
    counts = {}
    for d in (",", ";", "\t"):
        if '"' not in line:
            counts[d] = line.count(d)
            continue
        inside, n = False, 0
        for ch in line:
            if ch == '"':
                inside = not inside
            elif ch == d and not inside:
                n += 1
        counts[d] = n
    best = max(counts, key=lambda d: counts[d])
    if counts[best] == 0:
        if allow_blanks and " " in line.strip():
            return WHITESPACE
        seen = (
            " (it has spaces: whitespace-separated files are read with a column map, --columns)"
            if " " in line.strip()
            else ""
        )
        raise LogFormatError(
            f"{where}: no ',' ';' or tab between the column names {line.strip()[:60]!r}{seen}; separate the columns "
            "with one of them"
        )
    return best


def excel_separator(line: str) -> bool:
    """Whether ``line`` is Excel's delimiter hint, ``sep=,`` (any one character after ``=``): a first line that
    names no column, the header following it."""
    text = line.strip()
    return len(text) == 5 and text.startswith("sep=")


def comment_above_header(line: str, following: Sequence[str]) -> bool:
    """Whether ``line``, above a header, is a comment: after ``#`` or ``//``, either prose without a delimiter
    (``// Update Rate: 100.0Hz``, as IMU exports write it), which cannot name columns, or any line that a line of
    names or another comment follows (``# exported by Tool, version 1.2`` above ``t,qx,...``). A ``#`` line with
    delimiters that the data follow, as EuRoC's ``#timestamp [ns],...``, is the header. ``following``: lines after
    ``line`` (the next non-blank one decides; none known: the header)."""
    text = line.strip()
    if not text.startswith(("#", "//")):
        return False
    if not any(d in text for d in (",", ";", "\t")):
        return True
    after = next((x.strip(" \t\r\"'") for x in following if x.strip(" \t\r,;\"'")), "")
    if is_number(re.split(r"[,;\t ]", after, maxsplit=1)[0], decimal_comma=False):  # data ('nan' too)
        return False
    return after.startswith(("#", "//")) or after[:1].isalpha()  # names start with a letter; dates do not


def refuse_inner_carriage_return(line: str, where: str) -> None:
    """Refuse a line (its line end removed) that still holds a carriage return: a lone CR ends a line in some files,
    so inside a row it is two rows run together or a damaged one, never a blank to skip."""
    if "\r" in line:
        raise LogFormatError(f"{where}: a carriage return (CR) inside the line, where only a line end may have one")


def wrong_width(where: str, fields: int, expected: int, delim: str, header_line: int, why: str = "") -> LogFormatError:
    """The error for a row of ``fields`` fields where the header (its last line ``header_line``; 0: none, then the
    first row) has ``expected``; ``why`` follows the message (a stray quote's part)."""
    against = (
        f"the header (line {header_line}) names {expected} (delimiter {DELIMITERS[delim]})"
        if header_line
        else f"the first row has {expected}"
    )
    return LogFormatError(f"{where}: {fields} fields, but {against}{why}")


def split_line(line: str, delim: str, where: str) -> list[str]:
    """The fields of one line (quotes honoured within the line); the number of fields is checked against
    :data:`~omegahat.io.columns.MAX_COLUMNS` before anything is split."""
    if delim == WHITESPACE:
        n = len(line.split()) if len(line) < (MAX_COLUMNS << 4) else line.count(" ") + 1
    else:
        n = line.count(delim) + 1
    if n > MAX_COLUMNS:
        raise LogFormatError(f"{where}: {n} columns; at most {MAX_COLUMNS} are read (the limit for one header)")
    if delim == WHITESPACE:
        return line.split()
    if '"' not in line:
        return line.split(delim)
    try:
        return next(csv.reader([line], delimiter=delim))
    except csv.Error as exc:  # a field beyond csv.field_size_limit()
        raise LogFormatError(f"{where}: {exc} (the limit for one quoted field)") from None


def is_number(text: str, decimal_comma: bool = True) -> bool:
    """Whether a field reads as a number (Python's ``float``; a decimal comma too where ``decimal_comma``): the
    readers tell a header of names from a row of numbers with it."""
    try:
        float(text.replace(",", ".") if decimal_comma else text)
    except ValueError:
        return False
    return True
