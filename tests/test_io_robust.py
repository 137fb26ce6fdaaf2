"""Issue 23, the CSV path: nothing dropped or merged silently, nothing unhandled, sizes checked before allocating.

Each case reproduces a failure found by attacking the reader (a stray quote folding the rest of the file into one
field, a field beyond Python's csv limit, CR-only line ends, ``--time-column`` naming an attitude column, headers of
10⁵ and 10⁶ columns, a line without end) and checks the rows read or the message."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, read_log, textlines

N = 2000


def num(x) -> str:
    return repr(float(x))


@pytest.fixture(scope="module")
def rows():
    t = np.arange(N) / 100.0
    q = Rotation.from_rotvec(np.outer(t, [0.1, 0.2, 0.3])).as_quat()
    return [f"{num(t[k])},note{k},{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}" for k in range(N)]


def write(path, rows, header="t,note,qw,qx,qy,qz", newline="\n"):
    path.write_bytes((header + newline + newline.join(rows) + newline).encode())
    return path


def test_a_stray_quote_in_an_ignored_column_loses_no_row(tmp_path, rows, capsys):
    # the case: the quote opens the last field of row 1501 (line 1502); the rest of the file was folded into it
    shifted = [",".join([r.split(",")[0], *r.split(",")[2:], r.split(",")[1]]) for r in rows]
    shifted[1500] = shifted[1500].replace("note1500", '"abc')
    src = write(tmp_path / "stray.csv", shifted, header="t,qw,qx,qy,qz,note")
    assert len(read_log(src)) == N
    out = tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(out), "--no-progress"]) == 0
    assert f"wrote {N} estimates" in capsys.readouterr().out
    assert len(out.read_text().splitlines()) == N + 1


def test_a_stray_quote_that_joins_fields_names_its_line(tmp_path, rows):
    bad = list(rows)
    bad[1500] = bad[1500].replace("note1500", '"abc')  # a middle column: the fields after it are joined
    with pytest.raises(
        LogFormatError,
        match=r"stray\.csv, line 1502: 2 fields, but the header \(line 1\) names 6 \(delimiter ','\) \(a stray quote "
        r"'\"' joins the fields after it\)",
    ):
        read_log(write(tmp_path / "stray.csv", bad))


def test_fields_over_128_kb(tmp_path, rows):
    big = "x" * 200_000  # beyond csv.field_size_limit(): a traceback from Python's csv before
    for name, field in (("plain", big), ("quoted", f'"{big}"')):
        wide = list(rows)
        wide[1500] = wide[1500].replace("note1500", field)
        assert len(read_log(write(tmp_path / f"{name}.csv", wide))) == N
    wide = list(rows)
    wide[1500] = wide[1500].replace("note1500", f'"{big}')  # a quote opening a huge field: parsed line by line
    with pytest.raises(LogFormatError, match=r"open\.csv, line 1502: field larger than field limit \(131072\)"):
        read_log(write(tmp_path / "open.csv", wide))


def test_cr_only_line_ends_are_read_as_line_ends(tmp_path, rows):
    src = write(tmp_path / "mac.csv", rows, newline="\r")  # Excel's "CSV (Macintosh)"
    log = read_log(src)
    assert len(log) == N
    np.testing.assert_array_equal(log.labels[[0, -1]], [2, N + 1])  # line numbers as the file counts them
    assert "line ends: CR only (classic Mac OS, Excel 'CSV (Macintosh)'), read as line ends" in log.notes
    np.testing.assert_array_equal(log.data, read_log(write(tmp_path / "unix.csv", rows)).data)


@pytest.mark.parametrize("delimiter", [",", " "])
def test_a_carriage_return_inside_a_line_is_named_not_taken_for_a_blank(tmp_path, delimiter):
    # a lone CR ends a line in some files: inside a row it is two rows run together or a damaged one. A
    # blank-separated log once read it as a blank, so that a row damaged so read as a whole one (found by the
    # chaos suite); CRLF line ends stay line ends
    lines = [delimiter.join(f"{x:.6f}" for x in (k * 0.01, 0.0, 0.0, 0.0, 1.0)) for k in range(50)]
    header = delimiter.join(("t", "qx", "qy", "qz", "qw"))
    crlf = tmp_path / "crlf.txt"
    crlf.write_bytes(("\r\n".join([header, *lines]) + "\r\n").encode())
    mapped = {"columns": "t=t,qx=qx,qy=qy,qz=qz,qw=qw"} if delimiter == " " else {}  # blanks need a column map
    assert len(read_log(crlf, **mapped)) == 50
    lines[20] = lines[20].replace(f"{delimiter}0.000000{delimiter}", f"{delimiter}0.0\r00{delimiter}", 1)
    damaged = tmp_path / "damaged.txt"
    damaged.write_bytes(("\n".join([header, *lines]) + "\n").encode())
    with pytest.raises(LogFormatError, match=r"damaged\.txt, line 22: a carriage return \(CR\) inside the line"):
        read_log(damaged, **mapped)


def test_time_column_naming_an_attitude_column(tmp_path, rows, capsys):
    src = write(tmp_path / "x.csv", rows[:10])
    with pytest.raises(
        LogFormatError, match=r"x\.csv, line 1 \(header\): the time column 'qw' is one of the attitude columns"
    ):
        read_log(src, time_column="qw")
    assert main(["estimate", str(src), "-o", str(tmp_path / "o.csv"), "--time-column", "qw"]) == 2
    assert "the time column 'qw' is one of the attitude columns (qx, qy, qz, qw)" in capsys.readouterr().err


def test_a_header_of_100000_columns_within_20_s_and_1e6_refused_with_the_limit(tmp_path):
    for n in (100_000, 1_000_000):
        names = ["t", "qw", "qx", "qy", "qz", *(f"c{i}" for i in range(5, n))]
        values = ["1", "0", "0", "0", *("0" for _ in range(5, n))]
        src = tmp_path / f"wide{n}.csv"
        src.write_text(",".join(names) + "\n" + "\n".join(",".join([f"{k / 100}", *values]) for k in range(3)) + "\n")
        start = time.process_time()
        if n == 100_000:
            assert len(read_log(src)) == 3
        else:
            with pytest.raises(
                LogFormatError, match=r"line 1 \(header\): 1000000 columns; at most 200000 are read \(the limit"
            ):
                read_log(src)
        assert time.process_time() - start < 20.0  # CPU seconds (the duplicate check was quadratic: 8 s at 30,000)


def test_a_line_without_end_beyond_the_limit(tmp_path, monkeypatch):
    monkeypatch.setattr(textlines, "MAX_LINE_BYTES", 1 << 16)
    src = tmp_path / "blob.csv"
    src.write_bytes(b"t,qw,qx,qy,qz\n0,1,0,0,0\n" + b"7" * (1 << 18))
    with pytest.raises(
        LogFormatError, match=r"blob\.csv, line 3: longer than 65536 bytes without a line end \(the limit"
    ):
        read_log(src, chunk_bytes=1 << 12)
