"""``omegahat estimate LOG.parquet``: Parquet tables read as omegahat's CSV logs are (io.parquet_input).

The tables are written here with PyArrow from rotations made by SciPy; what is read back is compared with those
rotations and times, and the estimate with the closed-form rate of the motion."""

from __future__ import annotations

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
import pytest
from scipy.spatial.transform import Rotation

from logmaker import read_output
from omegahat.cli import main
from omegahat.io import LogFormatError, read_log
from omegahat.io.registry import CHUNK_ROWS

RATE = np.array([0.3, -0.2, 0.5])


def turning(n: int, h: float = 0.01) -> tuple[np.ndarray, Rotation]:
    t = h * np.arange(n)
    return t, Rotation.from_rotvec(np.outer(t, RATE))


def quaternion_table(t, rot: Rotation, **extra) -> pa.Table:
    q = rot.as_quat()
    columns = {"Time": t, "QZ": q[:, 2], "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1]}  # any order, any case
    return pa.table({**columns, **extra})


def test_a_quaternion_table_reads_as_its_rotations_and_estimates_its_rate(tmp_path, capsys):
    t, rot = turning(3000)
    path = tmp_path / "log.parquet"
    pq.write_table(quaternion_table(t, rot), path, row_group_size=700)  # row groups that cut the batches
    log = read_log(path, time_column="Time")
    assert log.kind == "quaternion" and np.array_equal(log.t, t)
    assert np.allclose(Rotation.from_quat(log.data).as_matrix(), rot.as_matrix(), atol=1e-15, rtol=0.0)
    out = tmp_path / "omega.csv"
    assert main(["estimate", str(path), "-o", str(out), "--time-column", "Time"]) == 0
    assert "detected Parquet table: quaternion columns" in capsys.readouterr().out
    t_out, omega, words = read_output(out)
    status = np.asarray(words)
    assert np.array_equal(t_out, t) and np.all(status[1:] == "corrected")
    assert np.abs(omega[1:] - RATE).max() < 1e-9


def test_matrices_torque_and_a_column_map(tmp_path):
    t, rot = turning(500)
    R = rot.as_matrix()
    cols = {"time": t, **{f"m{i}{j}": R[:, i - 1, j - 1] for i in (1, 2, 3) for j in (1, 2, 3)}}
    cols |= {"tau_x": np.full(t.size, 0.1), "tau_y": np.zeros(t.size), "tau_z": np.arange(t.size, dtype=np.int32)}
    path = tmp_path / "m.parquet"
    pq.write_table(pa.table(cols), path)
    mapping = ",".join(["t=time", *(f"r{i}{j}=m{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))])
    log = read_log(path, columns=mapping)
    assert log.kind == "matrix" and np.allclose(log.data, R, atol=1e-15, rtol=0.0)
    assert np.array_equal(log.torque[:, 2], np.arange(t.size)) and np.all(log.torque[:, 0] == 0.1)


def test_timestamps_are_read_as_whole_nanoseconds_from_the_first(tmp_path):
    """An epoch of 1.7e9 s in nanoseconds, timezone-aware: the differences are exact (a float of seconds since
    1970 would keep only 0.2 µs), the absolute times are the instants, and a duplicated stamp stays a duplicate."""
    t, rot = turning(400)
    ns = 1_700_000_000_123_456_789 + np.arange(400, dtype=np.int64) * 10_000_000 + (np.arange(400) % 3)
    stamps = pa.array(ns, pa.timestamp("ns", tz="Europe/Paris"))
    path = tmp_path / "epoch.parquet"
    pq.write_table(quaternion_table(t, rot).drop(["Time"]).append_column("t", stamps), path)
    log = read_log(path)
    assert np.array_equal(log.t, (ns - ns[0]) * 1e-9)
    assert abs(log.t0 - 1_700_000_000.123456789) < 1e-6
    ms = pa.array((ns // 1_000_000).astype(np.int64), pa.duration("ms"))
    pq.write_table(quaternion_table(t, rot).drop(["Time"]).append_column("t", ms), path)
    assert np.array_equal(read_log(path).t, (ns // 1_000_000 - ns[0] // 1_000_000) * 1e-3)
    with pytest.raises(LogFormatError, match="carries its own unit; leave --time-unit out"):
        read_log(path, time_unit="ms")
    pq.write_table(quaternion_table(t, rot).drop(["Time"]).append_column("t", pa.array(ns)), path)  # plain int64
    log = read_log(path, time_unit="ns")  # as floats first, 1.7e18 ns would keep steps of 256 ns only
    assert np.array_equal(log.t, (ns - ns[0]) * 1e-9) and abs(log.t0 - 1_700_000_000.123456789) < 1e-6


def test_a_numeric_time_takes_the_time_unit(tmp_path):
    t, rot = turning(300)
    path = tmp_path / "ms.parquet"
    pq.write_table(quaternion_table(1000.0 * t + 5.0, rot), path)
    log = read_log(path, time_column="Time", time_unit="ms")
    assert np.allclose(log.t, t, atol=1e-12, rtol=0.0) and log.t0 == pytest.approx(5e-3)


def test_nulls_make_samples_missing_across_batches(tmp_path):
    """Nulls and NaN in the attitude, beyond the first batch too: those samples are missing, predicted through, and
    every row is written; a null time there is refused naming its row (its position in the table)."""
    n = CHUNK_ROWS + 5000
    t, rot = turning(n, h=0.001)
    q = rot.as_quat()
    qx = pa.array(q[:, 0], mask=np.isin(np.arange(n), [17, CHUNK_ROWS + 3]))
    table = pa.table({"t": t, "qw": q[:, 3], "qx": qx, "qy": q[:, 1], "qz": q[:, 2]})
    path = tmp_path / "gaps.parquet"
    pq.write_table(table, path)
    out = tmp_path / "omega.csv"
    assert main(["estimate", str(path), "-o", str(out)]) == 0
    t_out, omega, words = read_output(out)
    status = np.asarray(words)
    assert t_out.size == n and list(np.flatnonzero(status == "predicted")) == [17, CHUNK_ROWS + 3]
    assert np.isfinite(omega[1:]).all()
    times = pa.array(t, mask=np.arange(n) == CHUNK_ROWS + 9)
    pq.write_table(table.set_column(0, "t", times), path)
    with pytest.raises(LogFormatError, match=f"row {CHUNK_ROWS + 9}, column t: no time"):
        read_log(path)


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda tb: tb.set_column(2, "qw", pa.array(["a"] * tb.num_rows)), "column qw: holds string, not numbers"),
        (lambda tb: tb.drop(["qz"]), "qz"),
        (lambda tb: tb.slice(0, 0), "no rows"),
        (
            lambda tb: (
                tb.append_column("tau_x", pa.array(np.r_[np.zeros(5), np.nan, np.zeros(tb.num_rows - 6)]))
                .append_column("tau_y", pa.array(np.zeros(tb.num_rows)))
                .append_column("tau_z", pa.array(np.zeros(tb.num_rows)))
            ),
            "row 5, columns tau_x,tau_y,tau_z: torque",
        ),
    ],
)
def test_bad_tables_are_named(tmp_path, capsys, change, message):
    t, rot = turning(50)
    path = tmp_path / "bad.parquet"
    pq.write_table(change(quaternion_table(t, rot).rename_columns(["t", "qz", "qw", "qx", "qy"])), path)
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not (tmp_path / "o.csv").exists()


def test_a_file_that_is_not_parquet_and_options_it_does_not_take(tmp_path, capsys):
    path = tmp_path / "fake.parquet"
    path.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n")
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv")]) == 2
    assert "not a readable Parquet file" in capsys.readouterr().err
    t, rot = turning(50)
    pq.write_table(quaternion_table(t, rot), path)
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--header-rows", "2"]) == 2
    assert "--header-rows" in capsys.readouterr().err


def test_epoch_nanoseconds_in_an_integer_column_are_read_as_such(tmp_path):
    """An int64 ``t`` of epoch nanoseconds (1.7e18 cannot be seconds) is read in ns, as a CSV's, and said."""
    t = np.arange(50) * 0.01
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    stamps = 1_700_000_000_000_000_000 + np.arange(50, dtype=np.int64) * 10_000_000
    path = tmp_path / "ns.parquet"
    pq.write_table(pa.table({"t": stamps, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}), path)
    log = read_log(path)
    np.testing.assert_allclose(log.t, t, rtol=1e-15, atol=1e-17)
    assert log.t0 == 1_700_000_000.0
    assert any(n.startswith("time unit: ns, by the times themselves") for n in log.notes)


def test_unsigned_times_read_exactly_and_past_int64_named(tmp_path, capsys):
    """A uint64 time column past 2^63 ended in PyArrow's bare "Integer value ... not in range"; one within int64 is
    read as the int64 one is."""
    t = np.arange(50) * 0.01
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    cols = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    stamps = np.uint64(1_700_000_000_000_000_000) + np.arange(50, dtype=np.uint64) * np.uint64(10_000_000)
    path = tmp_path / "u.parquet"
    pq.write_table(pa.table({"t": pa.array(stamps, pa.uint64()), **cols}), path)
    np.testing.assert_allclose(read_log(path).t, t, rtol=1e-15, atol=1e-17)
    late = stamps.copy()
    late[40:] += np.uint64(2**63)  # past int64 in the second half
    pq.write_table(pa.table({"t": pa.array(late, pa.uint64()), **cols}), path)
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert f"row 40, column t: time {int(late[40])} beyond what int64 holds" in err and "Traceback" not in err


def test_a_time_that_goes_back_is_quoted_as_the_table_holds_it(tmp_path, capsys):
    """The message quoted the times less the first row's (-0.02 is not after 0.49) instead of the table's own."""
    t = 1000.0 + np.arange(100) * 0.01
    t[50] = t[48] - 0.5
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    cols = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    path = tmp_path / "back.parquet"
    for times, said in (
        (t, f"time {float(t[50])!r} is not after {float(t[49])!r} (row 49)"),
        ((t * 1e3).round().astype(np.int64), "time 999980 is not after 1000490 (row 49)"),
    ):
        pq.write_table(pa.table({"t": times, **cols}), path)
        assert (
            main(
                [
                    "estimate",
                    str(path),
                    "--time-unit",
                    "s" if times.dtype.kind == "f" else "ms",
                    "-o",
                    str(tmp_path / "o.csv"),
                ]
            )
            == 2
        )
        err = capsys.readouterr().err
        assert f"row 50, column t: {said}" in err, err
