"""``-o omega.parquet``: the CSV output's rows as Parquet, chunk by chunk, whole or absent (io.parquet_output)."""

from __future__ import annotations

import signal

import numpy as np
import pyarrow.csv as pacsv
import pyarrow.parquet as pq
import pytest

import faults
from logmaker import constant_rate, write_csv
from omegahat.cli import main
from omegahat.io.parquet_output import SCHEMA


@pytest.fixture(scope="module")
def log(tmp_path_factory):
    t = np.arange(2000) / 100.0
    path = write_csv(tmp_path_factory.mktemp("log") / "log.csv", t, constant_rate(t, np.array([0.1, -0.2, 0.3]), 1e-4))
    lines = path.read_text().splitlines()
    for k in (5, 700, 701):  # missing samples (line k is row k - 1): predicted rows
        lines[k] = lines[k].split(",")[0] + ",nan,nan,nan,nan"
    path.write_text("\n".join(lines) + "\n")
    return path


def test_the_parquet_file_holds_the_csv_files_rows(log, tmp_path, capsys):
    """The same run written as CSV and as Parquet: every float bit for bit, every status word, the schema; one row
    group per chunk read."""
    with faults.many_chunks():
        assert main(["estimate", str(log), "-o", str(tmp_path / "o.csv"), "--no-progress"]) == 0
        assert main(["estimate", str(log), "-o", str(tmp_path / "o.parquet"), "--no-progress"]) == 0
    assert "2000 estimates to" in capsys.readouterr().out
    csv = pacsv.read_csv(tmp_path / "o.csv")
    table = pq.read_table(tmp_path / "o.parquet")
    assert table.schema.equals(SCHEMA)
    for name in ("t", "wx", "wy", "wz"):
        np.testing.assert_array_equal(table[name].to_numpy(), csv[name].to_numpy())
    assert table["status"].to_pylist() == csv["status"].to_pylist()
    assert table["status"].to_pylist()[699:701] == ["predicted", "predicted"]
    assert pq.ParquetFile(tmp_path / "o.parquet").num_row_groups > 5


@pytest.fixture(scope="module")
def short_log(tmp_path_factory):
    return faults.short_log(tmp_path_factory.mktemp("short"))


def test_a_disk_full_at_every_write_leaves_the_previous_file(short_log, tmp_path):
    """At every write call of a run (the magic bytes, each column's pages, the footer: one chunk, as the many
    chunks' writes are the same calls over again)."""
    cases = faults.disk_full_cases(short_log, tmp_path / "o.parquet")
    assert len(cases) >= 5 and all(outcome == "message" for _, outcome in cases), cases


def test_an_interrupt_at_every_chunk_leaves_the_previous_file(short_log, tmp_path):
    with faults.many_chunks():
        cases = faults.signal_cases(short_log, tmp_path / "o.parquet", signal.SIGINT)
    assert len(cases) >= 8 and all(outcome == "message" for _, outcome in cases), cases
