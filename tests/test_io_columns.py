"""The column map (``--columns``, ``columns=``), headers over several rows (``--header-rows``), and the precision
policy for what files carry (omegahat.io.precision): round trips through the map, the Vicon Nexus + IMU export of
issue 25 read with no tolerance option, imprecise rotations normalised and reported, what is no rotation named, and
every error with its message."""

from __future__ import annotations

import time

import numpy as np
import pytest
from scipy.linalg import polar
from scipy.spatial.transform import Rotation

import omegahat
from omegahat.cli import main
from omegahat.io import LogFormatError, read_log, suggest_columns
from omegahat.io.gyrolog import read_gyro
from omegahat.io.precision import file_tolerance, significant_digits
from recording_files import read_omega_csv

CLI = ["--no-progress"]
W = np.array([0.5, -3.4, 2.2])  # rad/s: fast enough for linear interpolation to shorten quaternions by 1e-3


def num(x) -> str:
    return repr(float(x))


def turning(t):
    return Rotation.from_rotvec(np.outer(t, W)) * Rotation.from_rotvec([0.2, 0.5, -0.1])


def run(path, tmp_path, capsys, *extra):
    out = tmp_path / "o.csv"
    out.unlink(missing_ok=True)
    code = main(["estimate", str(path), "-o", str(out), *CLI, *extra])
    printed = capsys.readouterr()
    return code, (read_omega_csv(out)[0] if code == 0 else None), printed.out, printed.err


# ------------------------------------------------------------------------------------------- the column map


def test_columns_by_name_and_by_position_read_what_the_names_read(tmp_path):
    t = np.arange(6) * 0.01
    q = turning(t).as_quat()
    rows = [f"{k},{num(t[k])},{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])},7" for k in range(6)]
    named = tmp_path / "named.csv"
    named.write_text("frame,t,qw,qx,qy,qz,temp\n" + "\n".join(rows) + "\n")
    other = tmp_path / "other.csv"
    other.write_text("Frame,Zeit [s],Quat W,Quat X,Quat Y,Quat Z,Temp\n" + "\n".join(rows) + "\n")
    ref = read_log(named)
    by_name = read_log(other, columns="t=Zeit [s],qw=quat w,qx=Quat X,qy=Quat Y,qz=Quat Z")  # any case
    by_position = read_log(other, columns={"t": 2, "qw": 3, "qx": 4, "qy": 5, "qz": 6})
    by_text_positions = read_log(other, columns="t=2,qw=3,qx=4,qy=5,qz=6")
    for log in (by_name, by_position, by_text_positions):
        np.testing.assert_array_equal(log.t, ref.t)
        np.testing.assert_array_equal(log.data, ref.data)
    assert "columns read: --columns 't=Zeit [s],qw=Quat W,qx=Quat X,qy=Quat Y,qz=Quat Z'" in by_position.notes
    # the map decides its groups: a file's own t and quaternion columns give way to the mapped ones
    swapped = read_log(named, columns="t=frame")
    np.testing.assert_array_equal(swapped.t, np.arange(6))
    np.testing.assert_array_equal(swapped.data, ref.data)  # keys not in the map: found by their names


def test_header_rows_and_no_header(tmp_path):
    t = np.arange(5) * 0.1
    q = turning(t).as_quat()
    body = "\n".join(f"{t[k]};{num(q[k, 3])};{num(q[k, 0])};{num(q[k, 1])};{num(q[k, 2])}" for k in range(5)) + "\n"
    two = tmp_path / "two.csv"
    two.write_text("Time;Orientation;;;\n;W;X;Y;Z\n" + body)
    log = read_log(
        two, header_rows=2, columns="t=Time,qw=Orientation W,qx=Orientation X,qy=Orientation Y,qz=Orientation Z"
    )
    np.testing.assert_array_equal(log.data, q)
    headless = tmp_path / "headless.txt"
    headless.write_text(body.replace(";", "  "))  # blank-separated, no header: positions
    log = read_log(headless, header_rows=0, columns="t=1,qw=2,qx=3,qy=4,qz=5")
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.data, q)
    with pytest.raises(LogFormatError, match=r"one\.csv: 1 line\(s\), but --header-rows 3 asks for 3"):
        (tmp_path / "one.csv").write_text("a;b\n")
        read_log(tmp_path / "one.csv", header_rows=3)


def test_prose_comment_lines_above_the_header_are_skipped_and_said(tmp_path):
    """RING's exports start with ``# sampling frequency: 30`` and ``# units are ...`` above the header: lines of
    prose after ``#`` (no delimiter in them) cannot name columns. A ``#`` line with delimiters stays the header."""
    t = np.arange(5) * 0.1
    q = turning(t).as_quat()
    rows = [f"{t[k]},{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}" for k in range(5)]
    path = tmp_path / "commented.csv"
    path.write_text("# sampling frequency: 10\n# units are seconds/radians\nt,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    log = read_log(path)
    np.testing.assert_array_equal(log.t, t)
    np.testing.assert_array_equal(log.data, q)
    assert "2 comment line(s) starting with '#' or '//' above the header skipped" in log.notes
    rows[2] = "0.2,nonsense,0,0,0"  # the line numbers still count the comment lines: this is line 6
    path.write_text("# sampling frequency: 10\n# units\nt,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    with pytest.raises(LogFormatError, match=r"commented\.csv, line 6\b"):
        read_log(path)
    slashes = tmp_path / "slashes.txt"  # an IMU export's preamble: '//' lines of prose, then a tab-separated header
    tabbed = [f"{t[k]}\t{num(q[k, 3])}\t{num(q[k, 0])}\t{num(q[k, 1])}\t{num(q[k, 2])}" for k in range(3)]
    preamble = "// Start Time: 2026-01-01 12:00:00\n// Update Rate: 10.0Hz\n// Firmware Version: 4.2.1\n"
    slashes.write_text(preamble + "t\tqw\tqx\tqy\tqz\n" + "\n".join(tabbed) + "\n")
    log = read_log(slashes)
    np.testing.assert_array_equal(log.data, q[:3])
    assert "3 comment line(s) starting with '#' or '//' above the header skipped" in log.notes
    header_with_hash = tmp_path / "hash_header.csv"  # '#' before names with delimiters: a header, not prose
    header_with_hash.write_text("#t,qw,qx,qy,qz\n" + "\n".join(rows[:2]) + "\n")
    with pytest.raises(LogFormatError, match=r"hash_header\.csv, line 1 \(header\)"):
        read_log(header_with_hash)


def test_rate_gives_the_times_of_a_csv_log_without_any(tmp_path, capsys):
    """RING's exports carry no time column, only a rate in a comment: ``--rate HZ`` puts row ``k`` at ``k / HZ``,
    across chunks; a row of nan is a missing frame at its own time; a line without data between rows (blank, or
    bare delimiters) is refused (its frame's time would be a guess), as is --rate beside a time column or a unit."""
    n, rate = 3000, 20.0
    t = np.arange(n) / rate
    q = turning(t).as_quat()
    rows = [f"{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}" for k in range(n)]
    rows[1234] = "nan,nan,nan,nan"  # a missing frame (a row of bare delimiters would be a blank line)
    path = tmp_path / "untimed.csv"
    path.write_text("qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    with pytest.raises(LogFormatError, match=r"no time column 't' .*; a log without times: --rate HZ"):
        read_log(path)  # without --rate the error says how to read it
    log = read_log(path, rate=rate, chunk_bytes=1 << 12)  # many buffers: the row count carries over
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-12)
    assert np.all(np.isnan(log.data[1234])) and np.array_equal(log.data[1235], q[1235])
    assert "times: row k at k / 20 s (--rate; the log has no time column)" in log.notes
    out = tmp_path / "omega.csv"
    assert main(["estimate", str(path), "--rate", "20", "-o", str(out)]) == 0
    written = np.genfromtxt(out, delimiter=",", names=True, dtype=None, encoding="utf-8")
    np.testing.assert_allclose(written["t"], t, atol=1e-9)
    gap = tmp_path / "blank_line.csv"
    for blank in ("", ",,,"):
        gap.write_text("qw,qx,qy,qz\n" + "\n".join(rows[:10]) + f"\n{blank}\n" + "\n".join(rows[10:20]) + "\n")
        with pytest.raises(LogFormatError, match=r"blank_line\.csv, line 12: a line without data between rows"):
            read_log(gap, rate=rate)
    timed = tmp_path / "timed.csv"
    timed.write_text("t,qw,qx,qy,qz\n" + "\n".join(f"{t[k]},{rows[k]}" for k in range(5)) + "\n")
    with pytest.raises(LogFormatError, match=r"has a time column 't'; leave --rate out"):
        read_log(timed, rate=rate)
    with pytest.raises(LogFormatError, match=r"--time-unit is the unit of a time column"):
        read_log(path, rate=rate, time_unit="ms")


def test_vicon_nexus_and_imu_export_with_a_two_row_header(tmp_path, capsys):
    """Issue 25's dataset: ';' separated, a group title over W;X;Y;Z, quaternions with 5 significant digits,
    linearly interpolated from 20 Hz motion capture to the IMU's 100 Hz (so up to ~1e-3 shorter than unit)."""
    k = np.arange(400)
    t = k / 100.0
    key = turning(np.arange(81) / 20.0).as_quat()  # the 20 Hz frames
    for j in range(1, len(key)):  # one hemisphere, as exporters blend
        key[j] *= np.sign(key[j] @ key[j - 1])
    i, frac = k // 5, (k % 5) / 5.0
    q = (1 - frac)[:, None] * key[i] + frac[:, None] * key[i + 1]  # linear blend: |q| < 1 between frames
    dev = np.abs(np.linalg.norm(q, axis=1) - 1)
    assert 1e-3 < dev.max() < 1e-2  # beyond the estimators' default tolerance, within the file tolerance
    fmt = lambda x: f"{x:.5g}".replace(".", ",")  # noqa: E731  5 significant digits, decimal comma
    rows = [
        ";".join([fmt(t[k]), *(fmt(v) for v in (q[k, 3], q[k, 0], q[k, 1], q[k, 2])), "0,12", "-0,3", "9,81"])
        for k in range(len(t))
    ]
    src = tmp_path / "vicon_imu.csv"
    src.write_text("Time (s);Vicon Orientation;;;;IMU Acceleration;;\n;W;X;Y;Z;X;Y;Z\n" + "\n".join(rows) + "\n")
    code, _, _, err = run(src, tmp_path, capsys)
    columns = "t=Time (s),qw=Vicon Orientation W,qx=Vicon Orientation X,qy=Vicon Orientation Y,qz=Vicon Orientation Z"
    # one retry: the two rows joined give the columns line too
    assert code == 2
    assert (
        f"the header seems to span 2 rows (names under empty cells): try --header-rows 2 --columns '{columns}'" in err
    )
    code, named, out, err = run(src, tmp_path, capsys, "--header-rows", "2")  # the one quaternion named so: read
    assert code == 0, err
    assert (
        "attitude: the one quaternion named so, --columns 'qw=Vicon Orientation W,qx=Vicon Orientation X,"
        "qy=Vicon Orientation Y,qz=Vicon Orientation Z'"
    ) in out
    code, table, out, err = run(src, tmp_path, capsys, "--header-rows", "2", "--columns", columns)
    assert code == 0, err
    np.testing.assert_array_equal(named, table)
    n = int((dev > 1e-3).sum())
    assert f"note: {n} quaternion(s) normalised: |‖q‖ − 1| above the estimators' 0.001 (largest " in out
    assert "within the file tolerance 0.01; the file's 5 significant digits explain up to 0.0001" in out
    plain = tmp_path / "plain.csv"  # the same numbers in omegahat's own CSV
    plain.write_text("t;qw;qx;qy;qz\n" + "\n".join(";".join(r.split(";")[:5]) for r in rows) + "\n")
    code, base, _, _ = run(plain, tmp_path, capsys)
    assert code == 0
    np.testing.assert_array_less(np.nanmax(np.abs(table[:, 1:] - base[:, 1:])), 1e-6)
    body_rate = np.array([r.inv().apply(W) for r in turning(t[100:])])
    err = np.abs(table[100:, 1:] - body_rate)
    assert np.median(err) < 0.01 and err.max() < 0.1  # the motion's rate, up to the 20 Hz interpolation


def test_dataframe_columns_and_multiindex_header(tmp_path):
    pd = pytest.importorskip("pandas")
    t = np.arange(60) / 100.0
    q = turning(t).as_quat()
    cols = pd.MultiIndex.from_tuples(
        [("Time (s)", ""), ("Orientation", "W"), ("Orientation", "X"), ("Orientation", "Y"), ("Orientation", "Z")]
    )
    df = pd.DataFrame(np.column_stack([t, q[:, 3], q[:, :3]]), columns=cols)
    out = omegahat.estimate_frame(
        df,
        header_rows=2,
        columns={"t": "Time (s)", "qw": "Orientation W", "qx": "Orientation X", "qy": "Orientation Y", "qz": 5},
    )
    flat = pd.DataFrame({"t": t, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]})
    ref = omegahat.estimate_frame(flat)
    np.testing.assert_array_equal(out[["wx", "wy", "wz"]].to_numpy(), ref[["wx", "wy", "wz"]].to_numpy())
    with pytest.raises(LogFormatError, match=r"DataFrame: header_rows=3, but its columns have 2 levels"):
        omegahat.estimate_frame(df, header_rows=3)


@pytest.mark.parametrize(
    ("columns", "error", "match"),
    [
        ("t=1,qw=2,qq=3", ValueError, r"columns: unknown key 'qq'; the keys are t, qw, qx, qy, qz, r11\.\.r33"),
        ("t=1,t=2", ValueError, r"columns: t given twice"),
        ("t=0,qw=2", ValueError, r"columns: t=0: positions count from 1"),
        ("t", ValueError, r"--columns: 't' is not KEY=COLUMN"),
        ({"t": 1.5}, ValueError, r"columns: t= takes a column name \(str\) or a 1-based position \(int\); got 1\.5"),
        (
            "t=9,qw=2,qx=3,qy=4,qz=5",
            LogFormatError,
            r"x\.csv, line 1 \(header\): --columns t=9, but the file has 6 col",
        ),
        ("t=Zeit,qw=2,qx=3,qy=4,qz=5", LogFormatError, r"--columns t='Zeit': no such column \(found: 1:time, 2:a, "),
        ("t=dup,qw=2,qx=3,qy=4,qz=5", LogFormatError, r"--columns t='dup' matches columns 5, 6; give the position"),
        ("t=1,qw=2,qx=2,qy=4,qz=5", LogFormatError, r"--columns gives column 2 \('a'\) to both qw and qx"),
        ("t=1,qw=2,qx=3,qy=4", LogFormatError, r"missing quaternion column\(s\) qz"),
    ],
)
def test_column_map_errors(tmp_path, columns, error, match):
    p = tmp_path / "x.csv"
    p.write_text("time,a,b,c,dup,dup\n0,1,0,0,0,0\n")
    with pytest.raises(error, match=match):
        read_log(p, columns=columns)


def test_errors_print_the_columns_line_that_would_read_the_file(tmp_path, capsys):
    p = tmp_path / "x.csv"
    p.write_text("Timestamp,Pos X,Pos Y,W,X,Y,Z\n0,1,2,1,0,0,0\n")  # w, x, y, z without an attitude-like name
    with pytest.raises(
        LogFormatError,
        match=r"no attitude columns.*; to read other columns: --columns t=Timestamp,qw=W,qx=X,qy=Y,qz=Z",
    ):
        read_log(p)
    p.write_text("Timestamp,Pos X,Pos Y,Orient W,Orient X,Orient Y,Orient Z\n0,1,2,1,0,0,0\n")  # one, named so: read
    assert "attitude: the one quaternion named so, --columns 'qw=Orient W,qx=Orient X,qy=Orient Y,qz=Orient Z'" in (
        read_log(p).notes
    )
    assert suggest_columns(["a", "b"]).startswith("--columns t=NAME,qw=NAME,qx=NAME,qy=NAME,qz=NAME (or by position")
    assert suggest_columns(["#timestamp [ns]", "q_RS_w []", "q_RS_x []", "q_RS_y []", "q_RS_z []"]) == (
        "--columns 't=#timestamp [ns],qw=q_RS_w [],qx=q_RS_x [],qy=q_RS_y [],qz=q_RS_z []'"
    )
    assert suggest_columns(["t", "a,b", "w", "x", "y", "z"]) == "--columns t=t,qw=w,qx=x,qy=y,qz=z"


def test_numbered_quaternion_columns_get_both_lines_and_each_says_its_scalar(tmp_path, capsys):
    """An export with ``TIME,QUATERNION_0..3`` (qmt's and OpenAXES's layout, scalar first): the error prints the
    line for each order, naming the column it takes for the scalar; the scalar-first line reads the file to the rate
    of the same attitudes in omegahat's own CSV."""
    t = np.arange(300) / 100.0
    q = turning(t).as_quat(scalar_first=True)
    src = tmp_path / "robot.csv"
    src.write_text("TIME,QUATERNION_0,QUATERNION_1,QUATERNION_2,QUATERNION_3\n")
    with src.open("a") as f:
        np.savetxt(f, np.column_stack([t, q]), delimiter=",", fmt="%.12g")
    first = "t=TIME,qw=QUATERNION_0,qx=QUATERNION_1,qy=QUATERNION_2,qz=QUATERNION_3"
    last = "t=TIME,qx=QUATERNION_0,qy=QUATERNION_1,qz=QUATERNION_2,qw=QUATERNION_3"
    code, _, _, err = run(src, tmp_path, capsys)
    assert code == 2
    assert (
        f"--columns {first} if QUATERNION_0 is the quaternion's scalar part, --columns {last} if QUATERNION_3 is"
    ) in err
    code, table, _, err = run(src, tmp_path, capsys, "--columns", first)
    assert code == 0, err
    plain = tmp_path / "plain.csv"
    plain.write_text("t,qw,qx,qy,qz\n")
    with plain.open("a") as f:
        np.savetxt(f, np.column_stack([t, q]), delimiter=",", fmt="%.12g")
    code, base, _, _ = run(plain, tmp_path, capsys)
    assert code == 0
    np.testing.assert_allclose(table, base, atol=1e-12)
    code, swapped, _, _ = run(src, tmp_path, capsys, "--columns", last)  # the other order reads another motion
    assert code == 0 and np.nanmax(np.abs(swapped[:, 1:] - base[:, 1:])) > 0.1


def test_a_map_of_the_wrong_columns_is_named(tmp_path, capsys):
    t = np.arange(300) / 100.0
    q = turning(t).as_quat()
    p = tmp_path / "pose.csv"
    p.write_text(
        "time,x,y,z,qw,qx,qy,qz\n"
        + "\n".join(
            f"{t[k]},{0.5 + t[k]},2.0,0.3,{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}"
            for k in range(300)
        )
        + "\n"
    )
    code, _, _, err = run(p, tmp_path, capsys, "--columns", "t=time,qw=x,qx=qx,qy=qy,qz=qz")  # qw= the position x
    assert code == 2
    dev = np.abs(np.sqrt(np.sum(q[:, :3] ** 2, axis=1) + (0.5 + t) ** 2) - 1)
    assert (
        f"pose.csv, line 2, columns qx,qy,qz,x (qw): a quaternion far from unit norm (|‖q‖ − 1| = {dev[0]:.3g}), and "
        f"so are {(dev > 0.1).sum()} of the first 300 samples: these columns do not hold a rotation; the columns read: "
        "--columns t=time,qw=x,qx=qx,qy=qy,qz=qz — correct it to name the attitude's columns"
    ) in err


# ------------------------------------------------------------------------------------------- precision policy


def test_significant_digits_and_the_file_tolerance():
    assert significant_digits(["0.12340", "-1.2e-03", "0", "1"]) == 5
    assert significant_digits(["0.000123", "abc", ""]) == 3
    assert significant_digits(["0", "0.000"]) is None
    assert file_tolerance("quaternion", 5) == (pytest.approx(1e-4), 1e-2)  # rounding ≤ 4 × ½·10⁻⁴ in quadrature
    assert file_tolerance("quaternion", 2) == (pytest.approx(0.1), 0.05)  # capped: |q| = 2 is never "rounding"
    assert file_tolerance("matrix", 3) == (pytest.approx(0.03), pytest.approx(0.03))
    assert file_tolerance("matrix", None) == (0.0, 1e-2)


def test_imprecise_matrices_are_projected_and_reflections_named(tmp_path, capsys):
    t = np.arange(40) / 100.0
    R = turning(t).as_matrix()
    rng = np.random.default_rng(1)
    bent = R + rng.normal(0, 5e-4, R.shape)  # ‖RᵀR − I‖ ≈ 2e-3: mostly above 1e-3, within 1e-2
    header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    p = tmp_path / "m.csv"
    p.write_text(
        header
        + "\n"
        + "\n".join(",".join(repr(float(v)) for v in (t[k], *bent[k].reshape(-1))) for k in range(40))
        + "\n"
    )
    log = read_log(p)
    err = np.linalg.norm(np.einsum("tki,tkj->tij", bent, bent) - np.eye(3), axis=(1, 2))
    fixed = (err > 1e-3) & (err <= 1e-2)
    assert fixed.sum() > 20 and err.max() <= 1e-2
    nearest = np.array([polar(m)[0] for m in bent[fixed]])  # SciPy's polar factor: the nearest orthogonal matrix
    np.testing.assert_allclose(log.data[fixed], nearest, atol=1e-12)
    np.testing.assert_array_equal(log.data[~fixed], bent[~fixed])  # within the estimators' tolerance: as written
    assert any(f"{fixed.sum()} matrices projected onto SO(3)" in n for n in log.notes)
    flip = bent * np.array([1.0, 1.0, -1.0])  # the third column negated: det R = -1
    p.write_text(
        header
        + "\n"
        + "\n".join(",".join(repr(float(v)) for v in (t[k], *flip[k].reshape(-1))) for k in range(40))
        + "\n"
    )
    with pytest.raises(
        LogFormatError,
        match=r"m\.csv, line 2, columns r11\.\.r33: a reflection \(det R < 0\), not a "
        r"rotation, and so are 40 of the first 40 samples: these columns do not hold a rotation",
    ):
        read_log(p)


def test_a_stray_sample_goes_to_the_estimators_check(tmp_path, capsys):
    t = np.arange(100) / 100.0
    q = turning(t).as_quat()
    q[30] *= 0.5  # |q| = 0.5 once: a bad sample, not wrong columns
    p = tmp_path / "q.csv"
    p.write_text(
        "t,qx,qy,qz,qw\n" + "\n".join(",".join(repr(float(v)) for v in (t[k], *q[k])) for k in range(100)) + "\n"
    )
    code, _, _, err = run(p, tmp_path, capsys)
    assert code == 2 and "q.csv, line 32, columns qw,qx,qy,qz: a quaternion far from unit norm: |q| = 0.5" in err
    code, _, out, _ = run(p, tmp_path, capsys, "--skip-bad-samples")
    assert code == 0 and "--skip-bad-samples: 1 bad samples treated as missing (first: line 32" in out


def test_few_digits_widen_the_tolerance(tmp_path):
    t = np.arange(50) / 100.0
    q = turning(t).as_quat() * 1.03  # |q| = 1.03: rounding for 2 digits, not for 4
    for digits, normalised in ((2, True), (4, False)):
        p = tmp_path / f"d{digits}.csv"
        p.write_text(
            "t,qx,qy,qz,qw\n"
            + "\n".join(",".join([repr(float(t[k]))] + [f"{v:.{digits}g}" for v in q[k]]) for k in range(50))
            + "\n"
        )
        log = read_log(p)
        norms = np.linalg.norm(log.data, axis=1)
        assert np.allclose(norms, 1.0, atol=1e-12) == normalised


def test_a_recognised_file_read_through_a_map_reads_the_same(tmp_path):
    from vendor_files import decimal_seconds, write_euroc, write_tum

    t = np.arange(50) / 200.0
    q = turning(t).as_quat()
    euroc = write_euroc(tmp_path / "data.csv", [1403715524907143168 + round(x * 1e9) for x in t], q, "{:.9f}")
    mapped = read_log(euroc, columns="t=1,qw=5,qx=6,qy=7,qz=8", time_unit="ns")
    assert "read column by column as the column map says, not as an EuRoC / ASL trajectory CSV" in mapped.notes
    ref = read_log(euroc)
    np.testing.assert_array_equal(mapped.t, ref.t)
    np.testing.assert_array_equal(mapped.data, ref.data)
    assert mapped.t0 == ref.t0
    tum = write_tum(tmp_path / "traj.txt", decimal_seconds(1_700_000_000, t), q)
    mapped = read_log(tum, header_rows=0, columns="t=1,qx=5,qy=6,qz=7,qw=8")  # '#' lines: comments
    np.testing.assert_array_equal(mapped.t, read_log(tum).t)
    np.testing.assert_array_equal(mapped.data, read_log(tum).data)


def test_text_messages(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("\n\n")
    with pytest.raises(LogFormatError, match=r"x\.csv: empty file, expected rows"):
        read_log(p, header_rows=0, columns="t=1,qw=2,qx=3,qy=4,qz=5")
    p.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"the time column is given twice \(--columns t= and --time-column\)"):
        read_log(p, columns="t=1", time_column="qw")
    with pytest.raises(ValueError, match=r"header rows must be a whole number >= 0; got -1"):
        read_log(p, header_rows=-1)
    p.write_text('t,qw,qx,qy,qz,"' + "n" * 200_000 + '"\n0,1,0,0,0,x\n')
    with pytest.raises(LogFormatError, match=r"line 1 \(header\): field larger than field limit .*quoted field"):
        read_log(p)
    t = np.arange(50) / 100.0
    M = turning(t).as_matrix() * 1.3  # every matrix scaled: no rotation
    header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    body = [",".join(num(v) for v in (t[k], *M[k].reshape(-1))) for k in range(50)]
    p.write_text(header + "\n" + "\n".join(body) + "\n")
    with pytest.raises(
        LogFormatError, match=r"line 2, columns r11\.\.r33: not a rotation matrix \(‖RᵀR − I‖ = 1\.2\), and so are 50"
    ):
        read_log(p)


def test_a_column_map_is_refused_where_it_cannot_apply(tmp_path):
    np.savez(tmp_path / "x.npz", t=np.arange(3.0), q=np.tile([0.0, 0.0, 0.0, 1.0], (3, 1)))
    with pytest.raises(ValueError, match=r"x\.npz is an omegahat NPZ log: --columns applies only to an omegahat CSV"):
        read_log(tmp_path / "x.npz", columns="t=1,qw=2,qx=3,qy=4,qz=5")
    with pytest.raises(ValueError, match=r"x\.npz is an omegahat NPZ log: --header-rows applies only to an omegahat"):
        read_log(tmp_path / "x.npz", header_rows=2)


def test_a_first_line_of_numbers_is_no_header(tmp_path):
    """A file without a header (an iPhone's attitude.txt: blank-separated t, w, x, y, z) would lose its first row to
    the header: it is refused with --header-rows 0 and the columns by position, which then read every row. Names
    that are numbers 0.. or 1.. (pandas' default names) are names, and get the usual message."""
    t = np.arange(50) / 100.0
    q = turning(t).as_quat()
    rows = [f"{num(t[k])} {num(q[k, 3])} {num(q[k, 0])} {num(q[k, 1])} {num(q[k, 2])}" for k in range(t.size)]
    bare = tmp_path / "attitude.txt"
    bare.write_text("\n".join(rows) + "\n")
    with pytest.raises(LogFormatError, match=r"attitude\.txt, line 1 \(header\): numbers where the header should name "
                       r"the columns \(0\.0, .*--header-rows 0 and --columns t=1,qw=2,qx=3,qy=4,qz=5"):  # fmt: skip
        read_log(bare)
    log = read_log(bare, header_rows=0, columns="t=1,qw=2,qx=3,qy=4,qz=5")
    assert log.t.size == t.size
    np.testing.assert_allclose(log.data, q, atol=1e-15)
    (tmp_path / "comma.csv").write_text("\n".join(r.replace(" ", ",") for r in rows) + "\n")
    with pytest.raises(LogFormatError, match=r"numbers where the header should name the columns"):
        read_log(tmp_path / "comma.csv")
    pandas = tmp_path / "frame.csv"
    pandas.write_text("0,1,2,3,4\n" + "\n".join(r.replace(" ", ",") for r in rows) + "\n")
    with pytest.raises(LogFormatError, match=r"frame\.csv, line 1 \(header\): no time column 't' \(found: 0, 1, 2"):
        read_log(pandas)


def test_a_time_column_whose_name_states_its_unit_is_read_in_it(tmp_path):
    """``timestamp_ns`` is nanoseconds without ``--time-unit ns``; a given ``--time-unit`` still decides."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    t = np.arange(6) * 0.01
    q = turning(t).as_quat()
    ns = 1_700_000_000_000_000_000 + np.arange(6) * 10_000_000  # epoch nanoseconds, exact integers
    rows = [f"{ns[k]},{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}" for k in range(6)]
    path = tmp_path / "stamped.csv"
    path.write_text("timestamp_ns,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    log = read_log(path, time_column="timestamp_ns")
    np.testing.assert_allclose(log.t, t, rtol=1e-15, atol=0)
    assert log.t0 == 1_700_000_000.0
    assert "time unit: ns, as the time column's name says ('timestamp_ns'; converted to s)" in log.notes
    given = read_log(path, time_column="timestamp_ns", time_unit="us")
    np.testing.assert_allclose(given.t, t * 1000, rtol=1e-12)
    assert "the time column's name says ns ('timestamp_ns'); read in us, as --time-unit says" in given.notes
    ms = tmp_path / "ms.parquet"
    columns = {"time [ms]": t * 1000, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]}
    pq.write_table(pa.table(columns), ms)
    np.testing.assert_allclose(read_log(ms, time_column="time [ms]").t, t, rtol=1e-12, atol=1e-15)
    seconds = tmp_path / "seconds.csv"
    seconds.write_text(
        "Time (s),qw,qx,qy,qz\n" + "\n".join(f"{t[k]}," + r.split(",", 1)[1] for k, r in enumerate(rows))
    )
    plain = read_log(seconds, time_column="Time (s)")
    np.testing.assert_array_equal(plain.t, t)
    assert not any("time unit" in n for n in plain.notes)


def test_epoch_stamps_that_cannot_be_seconds_are_read_in_the_one_unit_they_fit(tmp_path):
    """``rostopic echo -p`` writes ``%time`` in epoch nanoseconds: 1.7e18 s would be 5e10 years, and only as ns are
    the stamps both a plausible date and a plausible rate. Relative stamps (from 0) do not show their unit."""
    from omegahat.io.time_units import unit_by_magnitude

    assert unit_by_magnitude(1.7e18, 1e7) == "ns" and unit_by_magnitude(1.7e15, 1e4) == "us"
    assert unit_by_magnitude(1.7e12, 10.0) == "ms" and unit_by_magnitude(1.7e9, 0.01) is None  # seconds: as given
    assert unit_by_magnitude(0.0, 10.0) is None and unit_by_magnitude(1.7e18, 1.0) is None  # 1 GHz fits no unit
    t = np.arange(6) * 0.01
    q = turning(t).as_quat()
    for scale, unit in ((10**9, "ns"), (10**3, "ms")):
        stamps = 1_700_000_000 * scale + np.arange(6) * (scale // 100)
        path = tmp_path / f"ros_{unit}.csv"
        rows = [f"{stamps[k]},{k},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])},{num(q[k, 3])}" for k in range(6)]
        path.write_text("%time,field.seq,field.x,field.y,field.z,field.w\n" + "\n".join(rows) + "\n")
        columns = "t=%time,qx=field.x,qy=field.y,qz=field.z,qw=field.w"
        log = read_log(path, columns=columns)
        np.testing.assert_allclose(log.t, t, rtol=1e-15, atol=1e-17)
        assert log.t0 == 1_700_000_000.0
        assert any(n.startswith(f"time unit: {unit}, by the times themselves") for n in log.notes)
        said = read_log(path, columns=columns, time_unit="us")  # a given unit decides
        assert not any("by the times themselves" in n for n in said.notes)
    relative = tmp_path / "relative_ms.csv"
    rows = [f"{k * 10},{num(q[k, 3])},{num(q[k, 0])},{num(q[k, 1])},{num(q[k, 2])}" for k in range(6)]
    relative.write_text("t,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    plain = read_log(relative)
    np.testing.assert_array_equal(plain.t, np.arange(6) * 10.0)
    assert not any("time unit" in n for n in plain.notes)


def test_a_table_of_several_topics_is_estimated_at_every_row_and_says_why_most_are_predictions(tmp_path, capsys):
    # PlotJuggler's CSV export of a pose topic beside a faster IMU topic: one row per time of either, the pose's
    # cells empty at the IMU's times. The estimate at the pose's rows is its rate; the other rows are predictions
    n = 300
    t = 1_700_000_000 + np.arange(n) * 0.01
    omega = np.array([0.3, -0.2, 0.5])
    q = Rotation.from_rotvec(np.outer(np.arange(n) * 0.01, omega)).as_quat()
    rows = {round(float(x), 6): f",{','.join(f'{v:.12g}' for v in q[k])}" for k, x in enumerate(t)}
    imu = [round(float(x), 6) for x in t[0] + 0.003 + np.arange(3 * n) * (0.01 / 3)]
    for x in imu:
        rows[x] = "0.1,,,," if x not in rows else "0.1" + rows[x]
    names = "time,/imu/linear_acceleration/x," + ",".join(f"/vicon/pose/orientation/{a}" for a in "xyzw")
    path = tmp_path / "plotjuggler.csv"
    path.write_text(names + "\n" + "\n".join(f"{x:.6f},{rows[x]}" for x in sorted(rows)) + "\n")
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), "--no-progress"]) == 0
    captured = capsys.readouterr()
    printed = captured.out + captured.err
    assert f"skipped {len(imu)} of {len(imu) + n} samples" in printed and "most rows have no attitude at all" in printed
    table, status = read_omega_csv(out)
    at_pose = np.isin(np.round(table[:, 0], 6), np.round(t, 6))
    assert at_pose.sum() == n and np.all(status[~at_pose] == "predicted")
    np.testing.assert_allclose(table[at_pose][20:, 1:], np.tile(omega, (n - 20, 1)), atol=1e-6)


def test_excels_delimiter_hint_above_the_header_is_skipped_in_attitude_and_gyroscope_logs(tmp_path):
    t = np.arange(200) * 0.01
    q = Rotation.from_rotvec(np.outer(t, [0.2, 0.1, -0.4])).as_quat()
    rows = "\n".join(";".join(f"{v:.15g}" for v in (t[k], q[k, 3], *q[k, :3])) for k in range(t.size))
    path = tmp_path / "excel.csv"
    path.write_text("sep=;\nt;qw;qx;qy;qz\n" + rows + "\n")
    log = read_log(path)
    assert log.t.size == 200 and log.labels[0] == 3  # the first row is line 3
    assert any("'sep=;', Excel's delimiter hint, skipped" in n for n in log.notes)
    gyro = tmp_path / "gyro.csv"
    gyro.write_text("sep=,\nt,gx,gy,gz\n0,1,2,3\n0.01,4,5,6\n")
    np.testing.assert_array_equal(read_gyro(gyro).g, [[1, 2, 3], [4, 5, 6]])


def test_comment_lines_with_delimiters_above_the_header_are_comments_unless_the_data_follow(tmp_path):
    """``# exported by Tool, version 1.2`` above ``t,qw,...`` is a comment: a line of names follows it. A ``#`` line
    that the data follow names the columns (EuRoC's ``#timestamp [ns],...``), also where the first row is ``nan``
    or a date; the same rule holds in a gyroscope log."""
    t = np.arange(50) * 0.01
    q = Rotation.from_rotvec(np.outer(t, [0.2, 0.1, -0.4])).as_quat()
    rows = [",".join(f"{v:.17g}" for v in (t[k], q[k, 3], *q[k, :3])) for k in range(t.size)]
    path = tmp_path / "tool.csv"
    path.write_text("# exported by Tool, version 1.2\n\n# frame: world, units: s\nt,qw,qx,qy,qz\n" + "\n".join(rows))
    log = read_log(path)
    np.testing.assert_array_equal(log.data, q)
    assert log.labels[0] == 5  # the first row is line 5
    assert "2 comment line(s) starting with '#' or '//' above the header skipped" in log.notes
    banner = "# exported by Tool, " + "x" * (4096 - 21) + "\n"  # a comment that ends where the first 4 kB end:
    path.write_text(banner + "t,qw,qx,qy,qz\n" + "\n".join(rows))  # the line after it is still seen
    np.testing.assert_array_equal(read_log(path, chunk_bytes=4096).data, q)
    path.write_text("// Tool, 1.2\n#t,qw,qx,qy,qz\n" + "\n".join(rows))  # the second comment names the columns
    with pytest.raises(LogFormatError, match=r"tool\.csv, line 2 \(header\): no time column 't'"):
        read_log(path)  # '#t' is not 't' (--columns reads it), but the header is the line that the data follow
    path.write_text("#t,qw,qx,qy,qz\nnan,nan,nan,nan,nan\n" + "\n".join(rows))
    with pytest.raises(LogFormatError, match=r"tool\.csv, line 1 \(header\)"):
        read_log(path)
    path.write_text("# time,qw,qx,qy,qz\n2026-01-01T00:00:00,1,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"tool\.csv, line 1 \(header\)"):
        read_log(path)
    gyro = tmp_path / "gyro.csv"
    gyro.write_text("# gyroscope, rad/s\n# sensor: imu0, rate 100 Hz\nt,gx,gy,gz\n0,1,2,3\n0.01,4,5,6\n")
    np.testing.assert_array_equal(read_gyro(gyro).g, [[1, 2, 3], [4, 5, 6]])
    counted = tmp_path / "picoquake.csv"  # PicoQuake's layout (its documentation): '#' lines, then a counter
    counted.write_text(
        "# PLab PicoQuake Data\n# Time: 2024-04-21 15:54:46.333682, Device: D4E9 (E6632891E36F2029)\n"
        "# Config: data_rate = 100.0 Hz, filter = 42 Hz, acc_range = 4 g, gyro_range = 250.0 dps\n"
        "count,a_x,a_y,a_z,g_x,g_y,g_z\n0,0,0,1,1.5,2,3\n1,0,0,1,4,5,6.25\n"
    )
    with pytest.raises(LogFormatError, match=r"no column 't' .*; a log without times: --gyro-rate HZ"):
        read_gyro(counted)
    log = read_gyro(counted, time_column=None)  # what --gyro-rate reads: the rows' indices
    np.testing.assert_array_equal(log.g, [[1.5, 2, 3], [4, 5, 6.25]])
    np.testing.assert_array_equal(log.t, [0, 1])


def test_a_refusal_lists_a_wide_or_long_header_in_a_few_lines(tmp_path):
    """A header of 5,000 columns, or one long comment line with commas read as the header, is named by its first
    names (each cut to 40 characters) and its count: the message is not the whole header."""
    wide = tmp_path / "wide.csv"
    wide.write_text(",".join(f"c{j}" for j in range(5000)) + "\n" + ",".join("1" * 5000) + "\n")
    long_field = "x" * 4000
    long = tmp_path / "long.csv"
    long.write_text(f"time,{long_field}\n0,1\n0.01,1\n")
    for path, count in ((wide, 5000), (long, 2)):
        with pytest.raises(LogFormatError) as caught:
            read_log(path)
        text = str(caught.value)
        assert len(text) < 800, text[:200]
        assert (f"... ({count} in all)" in text) == (count > 24)
    with pytest.raises(LogFormatError, match=r"c23, \.\.\. \(5000 in all\)"):
        read_log(wide)
    with pytest.raises(LogFormatError, match=r"x{37}\.\.\."):
        read_log(long)
    with pytest.raises(LogFormatError, match=r"found: 1:c0, 2:c1, .* 24:c23, \.\.\. \(5000 in all\)"):
        read_log(wide, columns="t=c0,qw=zz,qx=c1,qy=c2,qz=c3")


def test_a_huge_field_is_named_by_its_start_and_length_and_a_quoted_decimal_comma_is_said(tmp_path):
    huge = tmp_path / "huge.csv"
    huge.write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n0.01," + "9" * 100_000 + "a,0,0,0\n")
    start = time.perf_counter()
    with pytest.raises(LogFormatError) as caught:
        read_log(huge)
    assert time.perf_counter() - start < 20.0  # linear: the digit count's regex took 267 s on this field (quadratic)
    text = str(caught.value)
    shown = text.replace(str(huge), "")  # the temporary path's length is pytest's, not the message's
    assert len(shown) < 160 and "line 3, column qw: '" + "9" * 57 + "'... (100001 characters) is not a number" in text
    for rows, said in (
        ('"0,00","1,0","0,0","0,0","0,0"', r"'0,00' is not a number \(a decimal comma: where ',' separates the col"),
        ('0,1,0,0,0\n"1,000",1,0,0,0', r"'1,000' is not a number \(digit grouping is not read\)"),
    ):
        (tmp_path / "commas.csv").write_text(f"t,qw,qx,qy,qz\n{rows}\n")
        with pytest.raises(LogFormatError, match=said):
            read_log(tmp_path / "commas.csv")


def test_rows_of_delimiters_only_are_counted_in_a_note(tmp_path):
    """A spreadsheet's empty rows (',,,,') are blank lines, no samples; they were left out without a word."""
    t = np.arange(12) / 100.0
    rows = [f"{x!r},1,0,0,0" for x in t.tolist()]
    rows[4:4] = [",,,,", " , ,,,", ",,,,"]
    path = tmp_path / "empty_rows.csv"
    path.write_text("t,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    log = read_log(path)
    assert log.t.size == 12
    assert (
        "3 rows of delimiters only (empty rows, as a spreadsheet exports them; the first at line 6) read as blank "
        "lines: no sample there" in log.notes
    )
