"""Time columns as other tools write them: a column named as a time where the log has no ``t`` (``time``,
``Timestamp``, ``Time (s)``), and ISO 8601 dates and times (pandas' ``to_csv`` of a ``DatetimeIndex``, ``…Z``,
``…+02:00``). The reference instants come from Python's ``datetime`` (an independent clock arithmetic), the
reference rates from the same rotations logged with numeric times."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta, timezone

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, ReadOptions, read_log
from omegahat.io.gyrolog import read_gyro
from recording_files import estimate_file

CLI = ["--no-progress"]
OMEGA = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
START = datetime(2026, 3, 29, 0, 59, 59, tzinfo=UTC)  # one second before Europe's clocks jump from +01:00 to +02:00
RATE = 100.0


def _quaternions(n: int) -> np.ndarray:
    t = np.arange(n) / RATE
    return (Rotation.from_rotvec([0.2, 0.0, 0.0]) * Rotation.from_rotvec(np.outer(t, OMEGA))).as_quat()  # x,y,z,w


def _write(path, times: list[str], q: np.ndarray, name: str = "time") -> None:
    rows = [f"{s},{w:.17g},{x:.17g},{y:.17g},{z:.17g}" for s, (x, y, z, w) in zip(times, q, strict=True)]
    path.write_text(f"{name},qw,qx,qy,qz\n" + "\n".join(rows) + "\n")


def _instants(n: int) -> list[datetime]:
    return [START + timedelta(microseconds=10_000 * k) for k in range(n)]


def test_pandas_dates_are_read_as_seconds_since_1970_and_give_the_numeric_logs_rates(tmp_path, capsys):
    pd = pytest.importorskip("pandas")
    n = 400
    q = _quaternions(n)
    frame = pd.DataFrame(q[:, [3, 0, 1, 2]], columns=["qw", "qx", "qy", "qz"])
    frame.index = pd.DatetimeIndex([d.replace(tzinfo=None) for d in _instants(n)], name="time")
    dated = tmp_path / "dated.csv"
    frame.to_csv(dated)
    assert dated.read_text().splitlines()[1].startswith("2026-03-29 00:59:59.000,")  # pandas' text, no zone
    numeric = tmp_path / "numeric.csv"
    _write(numeric, [repr(k / RATE) for k in range(n)], q, name="t")

    log = read_log(dated)
    expected = np.array([d.timestamp() for d in _instants(n)])
    np.testing.assert_allclose(log.absolute_times, expected, rtol=0, atol=1e-6)
    np.testing.assert_allclose(np.diff(log.t), 0.01, rtol=0, atol=1e-12)  # from integer ns: no float rounding
    assert any("dates read as seconds since 1970-01-01 UTC (no time zone given" in note for note in log.notes)

    table_d, err = estimate_file(dated, tmp_path, capsys)
    table_n, _ = estimate_file(numeric, tmp_path, capsys)
    t_d, w_d, w_n = table_d[:, 0], table_d[:, 1:], table_n[:, 1:]
    assert "time column: 'time', the one named as a time" in err
    np.testing.assert_allclose(t_d, expected, rtol=0, atol=1e-6)  # the output's times: seconds since 1970
    np.testing.assert_allclose(w_d, w_n, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w_d[50:], np.broadcast_to(OMEGA, (n - 50, 3)), atol=1e-6)


def test_zoned_times_are_the_instants_they_name_across_a_clock_change(tmp_path):
    # Central European time: +01:00 until 01:00 UTC on 2026-03-29, then +02:00; the local clock jumps an hour,
    # the instants do not
    n = 300
    local = []
    for d in _instants(n):
        zone = timezone(timedelta(hours=1 if d < datetime(2026, 3, 29, 1, tzinfo=UTC) else 2))
        local.append(d.astimezone(zone).isoformat(timespec="milliseconds"))
    assert local[0].endswith("+01:00") and local[-1].endswith("+02:00")
    path = tmp_path / "zoned.csv"
    _write(path, local, _quaternions(n), name="Timestamp")
    log = read_log(path)
    np.testing.assert_allclose(log.absolute_times, [d.timestamp() for d in _instants(n)], rtol=0, atol=1e-6)
    assert any("their time zone converted to UTC" in note for note in log.notes)

    utc = tmp_path / "utc.csv"
    _write(utc, [d.strftime("%Y-%m-%dT%H:%M:%S.%fZ") for d in _instants(n)], _quaternions(n))
    np.testing.assert_allclose(read_log(utc).absolute_times, log.absolute_times, rtol=0, atol=1e-9)


@pytest.mark.parametrize(
    ("line", "text", "match"),
    [
        (
            51,
            "2026-03-29T00:59:59.490Z",
            r"line 51, column time: '2026-03-29T00:59:59\.490Z' is not a date and time without a time zone, as the "
            r"first row's",
        ),
        (61, "soon", r"line 61, column time: 'soon' is not a date and time without a time zone"),
        (
            71,
            "2026-03-29 00:59:58",
            r"line 71, column time: time 2026-03-29T00:59:58\.000000000 is not after 2026-03-29T00:59:59\.680000000 "
            r"\(line 70\); times must increase",
        ),
    ],
)
def test_a_bad_date_is_named_and_no_output_is_written(tmp_path, capsys, line, text, match):
    n = 100
    times = [d.strftime("%Y-%m-%d %H:%M:%S.%f")[:-3] for d in _instants(n)]
    times[line - 2] = text
    path = tmp_path / "bad.csv"
    _write(path, times, _quaternions(n))
    with pytest.raises(LogFormatError, match=match):
        read_log(path)
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), *CLI]) == 2
    assert "Traceback" not in capsys.readouterr().err
    assert not out.exists()


def test_dates_in_another_form_are_named_with_the_form_that_is_read(tmp_path):
    path = tmp_path / "us.csv"
    _write(path, [d.strftime("%m/%d/%Y %H:%M:%S.%f") for d in _instants(20)], _quaternions(20))
    with pytest.raises(
        LogFormatError,
        match=r"line 2, column time: '03/29/2026 00:59:59\.000000' is not a number \(dates and times are read in ISO "
        r"8601 form",
    ):
        read_log(path)


def test_dates_refuse_a_time_unit(tmp_path):
    path = tmp_path / "d.csv"
    _write(path, [d.isoformat() for d in _instants(20)], _quaternions(20))
    with pytest.raises(LogFormatError, match=r"the time column 'time' holds dates, which carry their own unit"):
        read_log(path, options=ReadOptions(time_unit="ms"))


@pytest.mark.parametrize(
    ("name", "scale"),
    [("time", 1.0), ("Time (s)", 1.0), ("timestamp_ms", 1e-3), ("Timestamp [ns]", 1e-9), ("seconds", 1.0)],
)
def test_the_one_column_named_as_a_time_is_read_in_the_unit_its_name_states(tmp_path, name, scale):
    n = 50
    written = np.arange(n) * (0.01 / scale)  # 100 Hz in the column's unit, from 0
    path = tmp_path / "named.csv"
    _write(path, [f"{v:.12g}" for v in written], _quaternions(n), name=name)
    log = read_log(path)
    np.testing.assert_allclose(log.t, np.arange(n) / RATE, rtol=0, atol=1e-12)
    column = name.lower()
    assert f"time column: {column!r}, the one named as a time (the log has no column 't')" in log.notes


def test_rostopics_csv_is_read_at_its_header_stamps(tmp_path, capsys):
    """``rostopic echo -p`` of a PoseStamped topic: its header stamps (ns since 1970, exact), as a bag is read, and
    the pose's quaternion named by its parts; ``--time-column %time`` reads the receive times."""
    n = 300
    q = _quaternions(n)
    stamp = 1_700_000_000_000_000_000 + np.arange(n) * 10_000_000  # 100 Hz
    received = stamp + 2_000_000 + (np.arange(n) % 7) * 300_000  # later, with jitter
    header = (
        "%time,field.header.seq,field.header.stamp,field.header.frame_id,field.pose.position.x,field.pose.position.y,"
        "field.pose.position.z,field.pose.orientation.x,field.pose.orientation.y,field.pose.orientation.z,"
        "field.pose.orientation.w"
    )
    rows = [
        f"{received[k]},{k},{stamp[k]},world,0,0,0," + ",".join(f"{q[k, j]:.17g}" for j in range(4)) for k in range(n)
    ]
    path = tmp_path / "rostopic.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    log = read_log(path)
    assert any("'field.header.stamp', the messages' header stamps, as for a ROS bag" in note for note in log.notes)
    np.testing.assert_allclose(log.t, np.arange(n) / RATE, rtol=0, atol=1e-12)  # exact: relative to 1.7e9 s
    assert log.t0 == 1.7e9
    reference = tmp_path / "reference.csv"
    _write(reference, [f"{k / RATE:.17g}" for k in range(n)], q, name="t")
    got, _ = estimate_file(path, tmp_path, capsys)
    want, _ = estimate_file(reference, tmp_path, capsys)
    np.testing.assert_allclose(got[:, 1:], want[:, 1:], rtol=0, atol=1e-12)
    np.testing.assert_allclose(read_log(path, time_column="%time").absolute_times, received * 1e-9, rtol=1e-15)


def test_a_column_t_is_read_whatever_else_is_named_as_a_time(tmp_path):
    both = tmp_path / "both.csv"
    both.write_text("t,time,qw,qx,qy,qz\n0.25,9,1,0,0,0\n")
    log = read_log(both)
    assert log.t.tolist() == [0.25]
    assert not any("time column" in note for note in log.notes)


def test_a_capital_t_beside_a_column_named_as_a_time_is_asked_about(tmp_path):
    """``Time,T,qw,...`` (T a temperature): T read as t gave rates ten times off with no word; now the CSV, the
    Parquet table and the gyroscope log ask which column is the time, and either choice is read as asked."""
    pd = pytest.importorskip("pandas")
    rows = "0.00,25.0,1,0,0,0\n0.01,25.1,1,0,0,0\n0.02,25.2,1,0,0,0\n"
    csv = tmp_path / "temp.csv"
    csv.write_text("Time,T,qw,qx,qy,qz\n" + rows)
    said = "columns 'T' and 'Time' could each be the time (names are compared ignoring case, so 'T' reads as t)"
    with pytest.raises(LogFormatError, match=rf"temp\.csv, line 1 \(header\): {re.escape(said)}: pass --time-column T"):
        read_log(csv)
    assert read_log(csv, options=ReadOptions(time_column="Time")).t.tolist() == [0.0, 0.01, 0.02]
    np.testing.assert_allclose(read_log(csv, options=ReadOptions(time_column="T")).t, [25.0, 25.1, 25.2])
    frame = pd.read_csv(csv)
    frame.to_parquet(tmp_path / "temp.parquet")
    with pytest.raises(LogFormatError, match=re.escape(said)):
        read_log(tmp_path / "temp.parquet")
    gyro = tmp_path / "gyro.csv"
    gyro.write_text("time,T,gx,gy,gz\n0.5,25,1,2,3\n0.6,25,4,5,6\n")
    with pytest.raises(LogFormatError, match="pass --gyro-time-column T or --gyro-time-column time"):
        read_gyro(gyro)
    alone = tmp_path / "alone.csv"
    alone.write_text("T,qw,qx,qy,qz\n0.5,1,0,0,0\n")
    assert read_log(alone).t.tolist() == [0.5]  # a capital T with no other time is the time, as before


def test_a_parquet_tables_time_named_column_and_a_gyro_logs(tmp_path):
    pd = pytest.importorskip("pandas")
    pytest.importorskip("pyarrow")
    n = 30
    q = _quaternions(n)
    frame = pd.DataFrame(q[:, [3, 0, 1, 2]], columns=["qw", "qx", "qy", "qz"])
    frame.insert(0, "Time", np.arange(n) / RATE)
    frame.to_parquet(tmp_path / "log.parquet")
    log = read_log(tmp_path / "log.parquet")
    np.testing.assert_allclose(log.t, np.arange(n) / RATE, rtol=0, atol=1e-15)
    assert "time column: 'time', the one named as a time (the log has no column 't')" in log.notes

    gyro = tmp_path / "gyro.csv"
    gyro.write_text("timestamp,gx,gy,gz\n0.5,1,2,3\n0.6,4,5,6\n")
    read = read_gyro(gyro)
    assert read.names[0] == "timestamp"
    np.testing.assert_array_equal(read.t, [0.5, 0.6])


@pytest.mark.parametrize("kind", ["pandas", "polars"])
def test_a_dataframes_column_of_date_texts_named_as_a_time(kind):
    pd = pytest.importorskip("pandas")
    import omegahat

    n = 200
    q = _quaternions(n)
    texts = [d.isoformat() for d in _instants(n)]  # '2026-03-29T00:59:59+00:00', then with microseconds
    frame = pd.DataFrame({"Timestamp": texts, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]})
    numeric = frame.drop(columns="Timestamp").assign(t=np.arange(n) / RATE)
    if kind == "polars":
        pl = pytest.importorskip("polars")
        frame, numeric = pl.from_pandas(frame), pl.from_pandas(numeric)
    got = omegahat.estimate_frame(frame)
    want = omegahat.estimate_frame(numeric)
    np.testing.assert_allclose(np.asarray(got[["wx", "wy", "wz"]]), np.asarray(want[["wx", "wy", "wz"]]), atol=1e-9)

    bad = frame.to_pandas() if kind == "polars" else frame.copy()
    bad.loc[7, "Timestamp"] = "later"
    if kind == "polars":
        bad = pl.from_pandas(bad)
    with pytest.raises(
        LogFormatError, match=r"DataFrame, row 7, column Timestamp: 'later' is not a date and time with a"
    ):
        omegahat.estimate_frame(bad)
    gap = frame.to_pandas() if kind == "polars" else frame.copy()
    gap.loc[9, "Timestamp"] = None
    with pytest.raises(LogFormatError, match=r"DataFrame, row 9, column Timestamp: missing time"):
        omegahat.estimate_frame(pl.from_pandas(gap) if kind == "polars" else gap)


def test_a_dataframes_time_index_wins_over_a_column_named_as_a_time():
    pd = pytest.importorskip("pandas")
    import omegahat

    n = 100
    q = _quaternions(n)
    frame = pd.DataFrame({"time": np.arange(n) * 7.0, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]})
    frame.index = pd.Index(np.arange(n) / RATE)  # float seconds: the index is the time, as before
    got = omegahat.estimate_frame(frame)
    np.testing.assert_allclose(np.asarray(got[["wx", "wy", "wz"]])[20:], np.broadcast_to(OMEGA, (n - 20, 3)), atol=1e-6)


@pytest.mark.parametrize(
    ("header", "order"),
    [
        ("time,quat_w,quat_x,quat_y,quat_z", "wxyz"),
        ("t,pos_x,pos_y,pos_z,orientation.x,orientation.y,orientation.z,orientation.w", "pppxyzw"),
        ("Time,Rotation X,Rotation Y,Rotation Z,Rotation W", "xyzw"),
        ("timestamp,q_w,q_x,q_y,q_z", "wxyz"),
    ],
)
def test_one_quaternion_named_by_its_parts_is_read(tmp_path, capsys, header, order):
    n = 300
    q = _quaternions(n)  # x, y, z, w
    part = {"x": 0, "y": 1, "z": 2, "w": 3}
    rows = [
        ",".join([f"{k / RATE:.17g}", *(f"{q[k, part[c]]:.17g}" if c in part else "0.5" for c in order)])
        for k in range(n)
    ]
    path = tmp_path / "named.csv"
    path.write_text(header + "\n" + "\n".join(rows) + "\n")
    reference = tmp_path / "reference.csv"
    _write(reference, [f"{k / RATE:.17g}" for k in range(n)], q, name="t")
    got, printed = estimate_file(path, tmp_path, capsys)
    want, _ = estimate_file(reference, tmp_path, capsys)
    assert "attitude: the one quaternion named so, --columns " in printed
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    pd = pytest.importorskip("pandas")
    pd.read_csv(path).to_parquet(tmp_path / "named.parquet")
    got, printed = estimate_file(tmp_path / "named.parquet", tmp_path, capsys)
    assert "attitude: the one quaternion named so" in printed
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("header", "match"),
    [
        (  # two quaternions: which is the body's is the user's choice
            "t,imu_quat_w,imu_quat_x,imu_quat_y,imu_quat_z,mocap_quat_w,mocap_quat_x,mocap_quat_y,mocap_quat_z",
            r"no attitude columns.*--columns t=t,qw=imu_quat_w",
        ),
        ("t,w,x,y,z", r"no attitude columns.*--columns t=t,qw=w,qx=x,qy=y,qz=z"),  # no attitude-like prefix
        (  # no time: the line for both is suggested
            "elapsed,field.pose.orientation.w,field.pose.orientation.x,field.pose.orientation.y,field.pose.orientation.z",
            r"no time column 't' \(found: elapsed, field\.pose\.orientation\.w.*name it t or pass --time-column NAME",
        ),
    ],
)
def test_quaternions_named_by_parts_that_are_not_one_are_left_to_the_user(tmp_path, header, match):
    path = tmp_path / "ambiguous.csv"
    width = header.count(",") + 1
    path.write_text(header + "\n" + ",".join(["0"] * (width - 4) + ["1", "0", "0", "0"]) + "\n")
    with pytest.raises(LogFormatError, match=match):
        read_log(path)


def test_omegahats_own_names_win_over_a_quaternion_named_by_its_parts(tmp_path):
    path = tmp_path / "both.csv"
    path.write_text("t,qw,qx,qy,qz,quat_w,quat_x,quat_y,quat_z\n0,1,0,0,0,0,1,0,0\n")
    log = read_log(path)
    np.testing.assert_allclose(log.data, [[0, 0, 0, 1]])  # qw = 1: the identity, scalar last
    assert not any("named so" in note for note in log.notes)


@pytest.mark.parametrize("kind", ["pandas", "polars"])
def test_a_dataframes_quaternion_named_by_its_parts(kind):
    pd = pytest.importorskip("pandas")
    import omegahat

    n = 200
    q = _quaternions(n)
    parts = {"orientation.w": q[:, 3], "orientation.x": q[:, 0], "orientation.y": q[:, 1], "orientation.z": q[:, 2]}
    frame = pd.DataFrame({"time": np.arange(n) / RATE, **parts})
    numeric = pd.DataFrame({"t": np.arange(n) / RATE, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]})
    indexed = pd.DataFrame(parts, index=pd.Index(np.arange(n) / RATE))  # the times in a float index
    if kind == "polars":
        pl = pytest.importorskip("polars")
        frame, numeric = pl.from_pandas(frame), pl.from_pandas(numeric)
    want = np.asarray(omegahat.estimate_frame(numeric)[["wx", "wy", "wz"]])
    np.testing.assert_allclose(np.asarray(omegahat.estimate_frame(frame)[["wx", "wy", "wz"]]), want, atol=1e-12)
    if kind == "pandas":
        np.testing.assert_allclose(np.asarray(omegahat.estimate_frame(indexed)[["wx", "wy", "wz"]]), want, atol=1e-12)
