"""CSV / NPZ attitude logs: columns by name, missing samples, every error naming line and column."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.io import AttitudeLog, LogFormatError, read_csv, read_log, read_npz, write_omega_csv
from omegahat.lab.evaluation import broad

BROAD = broad.data_dir()


def write(tmp_path, text, name="log.csv"):
    p = tmp_path / name
    p.write_text(text)
    return p


def num(x) -> str:
    """Shortest text that reads back as the same float."""
    return repr(float(x))


def csv_text(header, rows):
    return ",".join(header) + "\n" + "".join(",".join(str(v) for v in row) + "\n" for row in rows)


# ---------------------------------------------------------------------------------------------------- CSV


def test_quaternion_columns_in_any_order(tmp_path):
    rot = Rotation.random(5, random_state=1)
    q = rot.as_quat()  # x, y, z, w
    t = 0.01 * np.arange(5)
    header = ["qz", "t", "qw", "gyr_x", "qy", "qx"]  # shuffled, with an extra column
    rows = [[num(q[k, 2]), num(t[k]), num(q[k, 3]), "0.5", num(q[k, 1]), num(q[k, 0])] for k in range(5)]
    log = read_csv(write(tmp_path, csv_text(header, rows)))
    assert isinstance(log, AttitudeLog)
    assert log.kind == "quaternion"
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.data, q)  # stored scalar last, exactly the numbers written
    assert log.torque is None
    assert len(log) == 5


def test_matrix_columns_and_torque(tmp_path):
    R = Rotation.random(4, random_state=2).as_matrix()
    tau = np.arange(12.0).reshape(4, 3)
    header = ["t"] + [f"r{i}{j}" for i in (3, 1, 2) for j in (2, 3, 1)] + ["tau_z", "tau_x", "tau_y"]
    rows = []
    for k in range(4):
        vals = [num(R[k, i - 1, j - 1]) for i in (3, 1, 2) for j in (2, 3, 1)]
        rows.append([str(k), *vals, num(tau[k, 2]), num(tau[k, 0]), num(tau[k, 1])])
    log = read_csv(write(tmp_path, csv_text(header, rows)))
    assert log.kind == "matrix"
    np.testing.assert_array_equal(log.data, R)
    np.testing.assert_array_equal(log.torque, tau)


def test_direction_columns(tmp_path):
    b = np.random.default_rng(0).standard_normal((3, 2, 3))
    header = ["t", "b2x", "b2y", "b2z", "b1x", "b1y", "b1z"]
    rows = [[str(k), *[num(v) for v in b[k, 1]], *[num(v) for v in b[k, 0]]] for k in range(3)]
    log = read_csv(write(tmp_path, csv_text(header, rows)))
    assert log.kind == "directions"
    np.testing.assert_array_equal(log.data, b)


def test_empty_fields_are_missing_samples(tmp_path):
    text = "t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,,,,\n0.2,1,0,,0\n\n0.3,1,0,0,0\n"
    log = read_csv(write(tmp_path, text))
    np.testing.assert_array_equal(log.missing, [False, True, True, False])
    assert np.all(np.isnan(log.data[1:3]))  # the whole sample, even if only one field is empty
    np.testing.assert_array_equal(log.data[3], [0, 0, 0, 1])
    np.testing.assert_array_equal(log.t, [0, 0.1, 0.2, 0.3])  # the blank line is skipped


def test_whitespace_around_names_and_values(tmp_path):
    log = read_csv(write(tmp_path, " t , qw ,qx,qy,qz\n 0 , 1 ,0,0,0\n"))
    np.testing.assert_array_equal(log.data, [[0, 0, 0, 1]])


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,1,abc,0,0\n", r"log\.csv, line 3, column qx: 'abc' is not a number"),
        ("t,qw,qx,qy,qz\n0,1,0,0,0\n0.1,1,0,0\n", r"line 3: 4 fields, but the header \(line 1\) names 5"),
        ("t,qw,qx,qy\n0,1,0,0\n", r"line 1 \(header\): missing quaternion column\(s\) qz"),
        ("t,r11,r12,r13,r21,r22,r23,r31,r32\n", r"missing matrix column\(s\) r33"),
        ("t,qw,qx,qy,qz,r11\n", r"attitude given more than one way \(quaternion and matrix\)"),
        (
            "t,qw,qx,qy,qz\n0,1,0,0,0\n0.2,1,0,0,0\n0.1,1,0,0,0\n",
            r"line 4, column t: time 0\.1 is not after 0\.2 \(line 3\); times must increase",
        ),
        (  # equal times with the same attitude are one sample (omegahat.io.timestamps); with different ones, an error
            "t,qw,qx,qy,qz\n0,1,0,0,0\n0,0,1,0,0\n",
            r"log\.csv, line 2 and line 3: two samples at the same time 0\.0 with attitudes 180° apart",
        ),
        ("t,qw,qx,qy,qz\n0,1,0,0,0\n,1,0,0,0\n", r"line 3, column t: empty time"),
        ("t,qw,qx,qy,qz\nnan,1,0,0,0\n", r"line 2, column t: time nan is not finite"),
        (
            "time,timestamp,qw,qx,qy,qz\n0,0,1,0,0,0\n",
            r"no time column 't' \(found: time, timestamp, qw, qx, qy, qz\); several columns are named as a time "
            r"\(time, timestamp\): pass --time-column with the one to read",
        ),
        ("t,x,y\n0,1,2\n", r"no attitude columns; expected qw,qx,qy,qz or r11\.\.r33"),
        ("", r"empty file, expected a header"),
        ("t,qw,qx,qy,qz\n", r"no data rows after the header \(line 1\)"),
        ("t,qw,qx,qy,qz,qx\n", r"duplicate column\(s\) qx"),
        ("t,qw,qx,qy,qz,tau_x,tau_y\n", r"torque needs tau_x, tau_y and tau_z; missing tau_z"),
        ("t,qw,qx,qy,qz,tau_x,tau_y,tau_z\n0,1,0,0,0,0,,0\n", r"line 2, column tau_y: empty torque"),
        ("t,qw,qx,qy,qz,tau_x,tau_y,tau_z\n0,1,0,0,0,0,inf,0\n", r"line 2, column tau_y: torque 'inf' is not finite"),
        ("t,b1x,b1y,b1z,b2x,b2y\n", r"missing direction column\(s\) b2z"),
        ("t,b1x,b1y,b1z,b3x,b3y,b3z\n", r"directions must be numbered b1, b2, \.\.\. without gaps; got b1, b3"),
    ],
)
def test_csv_errors_name_line_and_column(tmp_path, text, match):
    with pytest.raises(LogFormatError, match=match):
        read_csv(write(tmp_path, text))


def test_progress_callback_reaches_the_file_size(tmp_path):
    rows = [[f"{k * 0.01:.2f}", "1", "0", "0", "0"] for k in range(10000)]
    p = write(tmp_path, csv_text(["t", "qw", "qx", "qy", "qz"], rows))
    seen = []
    read_csv(p, progress=lambda done, total: seen.append((done, total)))
    done = [d for d, _ in seen]
    assert done == sorted(done)
    assert len(seen) >= 2
    assert seen[-1] == (p.stat().st_size, p.stat().st_size)  # ASCII file: characters = bytes


# ---------------------------------------------------------------------------------------------------- NPZ


def test_npz_columns_q_R_b_and_tau(tmp_path):
    rot = Rotation.random(6, random_state=3)
    t = np.linspace(0, 1, 6)
    q = rot.as_quat()
    tau = np.ones((6, 3))
    p = tmp_path / "cols.npz"
    np.savez(p, t=t, qw=q[:, 3], qx=q[:, 0], qy=q[:, 1], qz=q[:, 2], tau_x=tau[:, 0], tau_y=tau[:, 1], tau_z=tau[:, 2])
    log = read_npz(p)
    np.testing.assert_array_equal(log.data, q)
    np.testing.assert_array_equal(log.torque, tau)

    np.savez(p, t=t, q=q)
    np.testing.assert_array_equal(read_npz(p).data, q)
    np.savez(p, t=t, q=rot.as_quat(scalar_first=True), scalar_first=True)
    np.testing.assert_array_equal(read_npz(p).data, q)

    np.savez(p, t=t, R=rot.as_matrix(), tau=tau)
    log = read_log(p)
    assert log.kind == "matrix"
    np.testing.assert_array_equal(log.data, rot.as_matrix())
    np.testing.assert_array_equal(log.torque, tau)

    b = np.random.default_rng(0).standard_normal((6, 3, 3))
    b[2, 1, 0] = np.nan
    np.savez(p, t=t, b=b)
    log = read_npz(p)
    assert log.kind == "directions"
    np.testing.assert_array_equal(log.missing, [False, False, True, False, False, False])
    assert np.all(np.isnan(log.data[2]))


@pytest.mark.parametrize(
    ("arrays", "match"),
    [
        ({"q": np.zeros((3, 4))}, r"no array 't' \(found: q\)"),
        ({"t": np.arange(3.0), "q": np.zeros((3, 3))}, r"array q: expected shape \(3, 4\), got \(3, 3\)"),
        ({"t": np.arange(3.0), "R": np.zeros((3, 3))}, r"array R: expected shape \(3, 3, 3\), got \(3, 3\)"),
        (
            {"t": np.arange(3.0), "q": np.zeros((3, 4)), "R": np.zeros((3, 3, 3))},
            r"attitude given more than one way \(q, R\)",
        ),
        (
            {"t": np.array([0.0, 2.0, 1.0]), "q": np.zeros((3, 4))},
            r"array t, index 2: time 1\.0 is not after 2\.0 \(index 1\)",
        ),
        ({"t": np.zeros((3, 1)), "q": np.zeros((3, 4))}, r"array t: expected shape \(T,\), got \(3, 1\)"),
        ({"t": np.arange(3.0), "q": np.zeros((3, 4)), "tau": np.zeros(3)}, r"array tau: expected shape \(3, 3\)"),
        (
            {"t": np.arange(2.0), "q": np.zeros((2, 4)), "tau": np.array([[0, 0, 0], [0, np.nan, 0]])},
            r"torque at index 1: not finite",
        ),
        ({"t": np.arange(2.0), "qw": np.zeros(2), "qx": np.zeros(2)}, r"missing quaternion column\(s\) qy, qz"),
        ({"t": np.array(["a", "b"]), "q": np.zeros((2, 4))}, r"array t: expected numbers, got dtype <U1"),
    ],
)
def test_npz_errors_name_the_array(tmp_path, arrays, match):
    p = tmp_path / "bad.npz"
    np.savez(p, **arrays)
    with pytest.raises(LogFormatError, match=match):
        read_npz(p)


def test_npz_times_under_the_name_given_or_named_as_a_time(tmp_path):
    """The NPZ reader takes its times as a CSV's are taken: ``--time-column``'s array (it was ignored: "no array
    't'" with ``--time-column time``), else ``t``, else the one array named as a time, its unit from its name; names
    compared ignoring case. Each choice is said in a note; an ambiguous one is asked."""
    from omegahat.io import ReadOptions

    t = np.arange(6) * 0.01 + 100.0
    q = Rotation.from_rotvec(np.outer(t, [0.1, 0.2, 0.3])).as_quat()
    p = tmp_path / "a.npz"

    np.savez(p, stamp=t, time=t + 7.0, q=q)
    log = read_npz(p, ReadOptions(time_column="stamp"))
    np.testing.assert_array_equal(log.t, t)
    with pytest.raises(LogFormatError, match=r"arrays stamp, time could each be the time, or pass --time-column"):
        read_npz(p)

    np.savez(p, time=t, q=q)
    log = read_npz(p)
    np.testing.assert_array_equal(log.t, t)
    assert any("time array: 'time'" in n for n in log.notes)

    np.savez(p, time_ms=t * 1e3, q=q)  # floats, in the unit the name states
    np.testing.assert_allclose(read_npz(p).t, t, rtol=1e-15)
    np.savez(p, timestamp_ns=np.round(t * 1e9).astype(np.int64), q=q)  # integers, relative to the first exactly
    times = read_npz(p).t
    np.testing.assert_allclose(times - times[0], t - t[0], atol=1e-12)

    np.savez(p, T=t, q=q)
    log = read_npz(p)
    np.testing.assert_array_equal(log.t, t)
    assert any("time array: 'T'" in n for n in log.notes)
    np.savez(p, T=t, time=t, q=q)  # T may be a temperature: asked
    with pytest.raises(LogFormatError, match=r"columns 'T' and 'time' could each be the time"):
        read_npz(p)

    np.savez(p, time=t, quat=q)
    with pytest.raises(LogFormatError, match=r"no attitude array; expected q \(T, 4\), R .*\(found: time, quat\)"):
        read_npz(p)


def test_not_an_npz_and_unknown_extension(tmp_path):
    p = write(tmp_path, "hello", "x.npz")
    with pytest.raises(LogFormatError, match=r"x\.npz: not a readable \.npz file"):
        read_log(p)
    with pytest.raises(
        LogFormatError,
        match=r"unknown log format '\.dat'; use \.aem or \.bag or \.c3d or \.csv or \.db3 or \.kvn or \.mat or "
        r"\.mcap or \.npz or \.parquet or \.tsv or \.tum or \.txt or \.ulg or \.xml",
    ):
        read_log(write(tmp_path, "t\n", "x.dat"))  # (.txt is a format now: TUM, KITTI, or text read by columns)


# ------------------------------------------------------------------------------------------------- output


def test_write_omega_csv_round_trip(tmp_path):
    t = np.array([0.0, 0.1, 0.2])
    w = np.array([[1.0, -2.5, 1e-17], [np.nan, np.nan, np.nan], [np.pi, 0.0, -1.0]])
    p = tmp_path / "out.csv"
    write_omega_csv(p, t, w)
    lines = p.read_text().splitlines()
    assert lines[0] == "t,wx,wy,wz"
    assert lines[2] == "0.10000000000000001,nan,nan,nan"
    back = np.loadtxt(p, delimiter=",", skiprows=1)
    np.testing.assert_array_equal(back[:, 0], t)
    np.testing.assert_array_equal(back[:, 1:], w)  # exact: 17 significant digits


def test_write_omega_csv_checks_shapes(tmp_path):
    with pytest.raises(ValueError, match=r"needs t \(T,\) and omega \(T, 3\); got \(2,\) and \(3, 3\)"):
        write_omega_csv(tmp_path / "o.csv", [0.0, 1.0], np.zeros((3, 3)))


# ---------------------------------------------------------------------------------------------- real data


@pytest.mark.skipif(not (BROAD / "01_slow_rotation_A_60s.csv").exists(), reason="BROAD recordings absent")
def test_reads_the_broad_60s_csv():
    log = read_log(BROAD / "01_slow_rotation_A_60s.csv")
    assert log.kind == "quaternion"
    assert log.t.size == 17142  # wc -l minus the header
    np.testing.assert_allclose(np.diff(log.t), 0.0035, atol=1e-9)  # 285.714 Hz
    assert log.missing.sum() == 33
    ok = ~log.missing
    np.testing.assert_allclose(np.linalg.norm(log.data[ok], axis=1), 1.0, atol=1e-6)
    # First row of the file: qw = 0.999728671, qx = -0.019640312 (scalar first in the file, last here)
    np.testing.assert_array_equal(log.data[0, [3, 0]], [0.999728671, -0.019640312])


# ---------------------------------------------------------------------------------------------------- plug-ins


def test_a_registered_format_gets_the_one_path(tmp_path):
    """A format registered with a sniffer is recognised before the plain CSV of its extension, refuses options it
    does not take, and its stream gets the conventions and the timestamp policy of open_log like the built-in ones."""
    from omegahat.io import LogStream, ReadOptions, detect_format, register_format
    from omegahat.io.registry import unregister_format

    def sniff(path):
        with open(path) as f:
            return f.readline().startswith("#toy")

    def opener(path, options):
        rows = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)  # t, then a rotation vector
        q = Rotation.from_rotvec(rows[:, 1:]).as_quat()
        return LogStream.from_arrays(path, "quaternion", rows[:, 0], q, labels=np.arange(2, rows.shape[0] + 2),
                                     label="line", description="a toy log")  # fmt: skip

    register_format(".csv", opener, name="toy", title="a toy log", sniff=sniff, options=("time_unit",))
    try:
        p = write(tmp_path, "#toy\n0,0,0,0\n10,0,0,0.5\n10,0,0,0.5\n20,0,0,1.0\n", "toy.csv")
        assert detect_format(p).name == "toy"
        assert detect_format(write(tmp_path, "t,qx,qy,qz,qw\n0,0,0,0,1\n", "plain.csv")).name == "csv"
        log = read_log(p, time_unit="ms")
        assert log.description == "a toy log"
        np.testing.assert_array_equal(log.t, [0.0, 0.01, 0.02])  # ms → s; the repeated line dropped
        np.testing.assert_array_equal(log.labels, [2, 3, 5])
        assert "dropped 1 duplicated sample(s) (same time, same attitude)" in log.notes
        with pytest.raises(ValueError, match=r"toy\.csv is a toy log: --body applies only to an OptiTrack Motive"):
            read_log(p, options=ReadOptions(body="x"))
        write(tmp_path, "#toy\n0,0,0,0\n10,0,0,0.5\n5,0,0,1\n", "back.csv")
        with pytest.raises(LogFormatError, match=r"back\.csv, line 4, column t: time 5\.0 is not after 10\.0"):
            read_log(tmp_path / "back.csv")
    finally:
        unregister_format("toy")
    assert detect_format(p).name == "csv"


def test_npz_integer_epoch_nanoseconds_are_read_exactly_and_in_their_unit(tmp_path):
    """int64 ns since 1970 in an NPZ went through float64 before the first stamp was subtracted (steps of an exact
    1 ms off by up to 4.8e-4 of a step) and were read as seconds with no note; now as the CSV and Parquet readers
    do: relative to the first in integers, and in ns by their size."""
    n = 200
    ns = 1_700_000_000_123_456_789 + np.arange(n, dtype=np.int64) * 1_000_000  # exact 1 ms steps
    q = Rotation.from_rotvec(np.outer(np.arange(n) * 1e-3, [0.3, -0.2, 0.5])).as_quat()
    np.savez(tmp_path / "epoch.npz", t=ns, q=q)
    for given in ({}, {"time_unit": "ns"}):
        log = read_log(tmp_path / "epoch.npz", **given)
        np.testing.assert_allclose(np.diff(log.t), 1e-3, rtol=1e-12, atol=0)
        assert log.t0 == pytest.approx(1_700_000_000.123456789, abs=1e-6)
    assert any(n.startswith("time unit: ns, by the times themselves") for n in read_log(tmp_path / "epoch.npz").notes)
    np.savez(tmp_path / "small.npz", t=np.arange(n, dtype=np.int64), q=q)  # integer seconds: read as they are
    np.testing.assert_array_equal(read_log(tmp_path / "small.npz").t, np.arange(n, dtype=float))
