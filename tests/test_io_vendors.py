"""The files of other tools, written by the tests from their vendors' documentation (tests/vendor_files.py): EuRoC,
TUM, KITTI, Qualisys QTM 6D TSV and MAT exports and every OptiTrack Motive layout, each recognised with its one-line
message, read as the vendor documents it, and giving through ``omegahat estimate`` the rates of omegahat's own CSV of
the same numbers (< 1e-6 rad/s); absolute times kept exact; every error with its message."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, detect_format, read_log
from recording_files import read_omega_csv, torque_free_axisymmetric
from vendor_files import (
    decimal_seconds,
    write_euroc,
    write_kitti,
    write_motive,
    write_plain_csv,
    write_qtm_6d,
    write_qtm_mat,
    write_tum,
)

CLI = ["--inertia", "1", "1", "1.6", "--no-progress"]


def motion(n=400, rate=200.0):
    t = np.arange(n) / rate
    R, omega = torque_free_axisymmetric(t)
    return t, R, omega


def rates(path, tmp_path, capsys, *extra):
    """``(output table, what was printed)`` of ``omegahat estimate path``."""
    out = tmp_path / f"{path.stem}.out.csv"
    out.unlink(missing_ok=True)
    assert main(["estimate", str(path), "-o", str(out), *CLI, *extra]) == 0
    return read_omega_csv(out)[0], capsys.readouterr().out


def same_rates(a, b):
    assert a.shape == b.shape
    ok = np.all(np.isfinite(a[:, 1:]), axis=1)
    assert ok.sum() > 0.9 * len(a)
    np.testing.assert_array_less(np.abs(a[ok, 1:] - b[ok, 1:]).max(), 1e-6)


# ------------------------------------------------------------------------------------------- EuRoC and TUM


def test_euroc_and_tum_of_one_trajectory_give_the_plain_csv_rates(tmp_path, capsys):
    t, R, omega = motion()
    q = Rotation.from_matrix(R).as_quat()
    first_ns = 1403715524907143168  # EuRoC V1_02's first stamp: 1.4e18 ns, beyond a float's 2**53
    ns = [first_ns + round(x * 1e9) for x in t]
    secs = decimal_seconds(first_ns // 10**9, (np.array(ns) - first_ns // 10**9 * 10**9) * 1e-9)
    plain = write_plain_csv(tmp_path / "plain.csv", [f"{x:.9f}" for x in t], q, "{:.6f}")
    euroc = write_euroc(tmp_path / "data.csv", ns, q, "{:.6f}")
    truth = write_euroc(tmp_path / "gt.csv", ns, q, "{:.6f}", ground_truth=True)
    tum = write_tum(tmp_path / "traj.txt", secs, q, "{:.6f}")
    assert [detect_format(p).name for p in (euroc, truth, tum)] == ["euroc", "euroc", "tum"]
    base, _ = rates(plain, tmp_path, capsys)
    table, printed = rates(euroc, tmp_path, capsys)
    assert (
        "detected EuRoC / ASL CSV: quaternion q_RS_w,q_RS_x,q_RS_y,q_RS_z (scalar first), time from column "
        "'#timestamp [ns]' in ns, relative to 1403715524907143168 ns (exact), position columns not read"
    ) in printed
    same_rates(table, base)
    same_rates(rates(truth, tmp_path, capsys)[0], base)
    table, printed = rates(tum, tmp_path, capsys)
    assert (
        "detected TUM trajectory: 'timestamp tx ty tz qx qy qz qw', quaternion qx,qy,qz,qw (scalar last), time in "
        "s, relative to 1403715524 s (exact), position not read"
    ) in printed
    same_rates(table, base)
    np.testing.assert_allclose(base[20:, 1:], omega[20:], atol=2e-3)  # and the rates are the motion's


def test_tum_times_at_1_7e9_s_keep_their_precision(tmp_path):
    # ns-resolution stamps 1.7e9 s after 1970: as floats they would be rounded to 2.4e-7 s
    rng = np.random.default_rng(5)
    t = np.arange(500) * 0.01 + rng.integers(-2000, 2000, 500) * 1e-9  # jitter at the nanosecond
    t -= t[0]
    _, q = np.zeros(0), Rotation.from_rotvec(np.outer(t, [0.3, 0.2, 0.1])).as_quat()
    text = decimal_seconds(1_700_000_000, t)
    log = read_log(write_tum(tmp_path / "x.tum", text, q))
    assert log.t0 == 1.7e9
    np.testing.assert_allclose(log.t, t, rtol=0, atol=1e-12)
    naive = np.array([float(s) for s in text]) - 1.7e9  # what reading the stamps as floats would give
    assert np.abs(naive - t).max() > 1e-8


def test_euroc_stamps_are_exact_nanoseconds(tmp_path):
    q = Rotation.random(3, random_state=2).as_quat()
    ns = [1403715524907143168, 1403715524912143104, 1403715524917143040]  # EuRoC's spacing, not a float's
    log = read_log(write_euroc(tmp_path / "data.csv", ns, q, "{:.17g}"))
    np.testing.assert_array_equal(log.t, [0.0, 4999936e-9, 9999872e-9])
    np.testing.assert_allclose(log.data, q, rtol=0, atol=1e-16)  # scalar first in the file, last here


def test_trajectory_errors(tmp_path):
    q = Rotation.random(4, random_state=3).as_quat()
    bad = write_tum(tmp_path / "bad.txt", ["1.0", "1.1", "1.2", "1.3"], q)
    lines = bad.read_text().splitlines()
    lines[4] = lines[4].replace(lines[4].split()[5], "abc")
    bad.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFormatError, match=r"bad\.txt, line 5, column qy: 'abc' is not a number"):
        read_log(bad)
    short = tmp_path / "short.tum"
    short.write_text("1.0 0 0 0 0 0 0 1\n1.1 0 0 0 0 0 1\n")
    with pytest.raises(LogFormatError, match=r"short\.tum, line 2: 7 fields, but the first row has 8"):
        read_log(short)
    notum = tmp_path / "x.tum"
    notum.write_text("hello\n")
    with pytest.raises(LogFormatError, match=r"x\.tum, line 1: no ',' ';' or tab between the column names 'hello'"):
        read_log(notum)
    euroc = write_euroc(tmp_path / "e.csv", [1, 2, 3, 4], q)
    with pytest.raises(ValueError, match=r"e\.csv is an EuRoC / ASL trajectory CSV: --time-unit applies only to"):
        read_log(euroc, time_unit="ns")


# ---------------------------------------------------------------------------------------------------- KITTI


def test_kitti_poses_with_times_from_a_file_a_rate_or_a_column(tmp_path, capsys):
    t, R, _ = motion(200, 10.0)
    poses = write_kitti(tmp_path / "00.txt", R, times_path=tmp_path / "times.txt")
    assert detect_format(poses).name == "kitti"
    with pytest.raises(
        LogFormatError,
        match=r"00\.txt: a KITTI pose list has no times; give them with --times FILE .* or --rate HZ "
        r"\(times\.txt is beside it: --times .*times\.txt\)",
    ):
        read_log(poses)
    by_file = read_log(poses, times=str(tmp_path / "times.txt"))
    by_rate = read_log(poses, rate=10.0)
    np.testing.assert_allclose(by_file.t, by_rate.t, rtol=0, atol=1e-12)
    assert (
        by_rate.description
        == "KITTI pose list: rotation = left 3x3 of each 3x4 [R|t] (row-major), time frame / 10 Hz, 200 poses"
    )
    np.testing.assert_allclose(by_rate.data, R, atol=1e-6)  # written with 7 significant digits (%e)
    with_t = write_kitti(tmp_path / "t.txt", R, t=t)
    assert read_log(with_t).description.endswith("time from the first of 13 numbers, 200 poses")
    plain = tmp_path / "plain.csv"
    header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    rows = [",".join([f"{x:e}" for x in (t[k], *R[k].reshape(-1))]) for k in range(len(t))]
    plain.write_text(header + "\n" + "\n".join(rows) + "\n")
    same_rates(rates(poses, tmp_path, capsys, "--rate", "10")[0], rates(plain, tmp_path, capsys)[0])
    with pytest.raises(LogFormatError, match=r"t\.txt: the poses carry their times .*; leave --rate and --times out"):
        read_log(with_t, rate=10.0)
    with pytest.raises(LogFormatError, match=r"00\.txt: give the times once: --times FILE or --rate HZ"):
        read_log(poses, rate=10.0, times=str(tmp_path / "times.txt"))
    (tmp_path / "few.txt").write_text("0\n0.1\n")
    with pytest.raises(LogFormatError, match=r"few\.txt: 2 times for the 200 poses of .*00\.txt"):
        read_log(poses, times=str(tmp_path / "few.txt"))
    with pytest.raises(ValueError, match=r"rate must be a positive number of Hz; got -1"):
        read_log(poses, rate=-1)
    # a CSV log takes --rate only without a time column (test_io_columns); --times stays the pose lists' own
    with pytest.raises(LogFormatError, match=r"plain\.csv, line 1 \(header\): the log has a time column 't'"):
        read_log(plain, rate=10.0)
    with pytest.raises(ValueError, match=r"\.csv is an omegahat CSV log: --times applies only to a KITTI pose list"):
        read_log(plain, times=str(tmp_path / "few.txt"))


# ------------------------------------------------------------------------------------------------ Qualisys


def test_qtm_rot_elements_are_column_by_column_on_a_rotation_built_by_hand(tmp_path):
    # A body yawed by +90° (QTM's Yaw: about Z): its local x axis lies along global y, its local y along -x.
    # Column by column, Rot[0..2] is R e_x = (0, 1, 0) and Rot[3..5] is R e_y = (-1, 0, 0).
    head = (
        "NO_OF_FRAMES\t2\nNO_OF_CAMERAS\t4\nNO_OF_BODIES\t1\nFREQUENCY\t100\nDATA_INCLUDED\t6D\nBODY_NAMES\tcube\n"
        "Frame\tTime\tX\tY\tZ\tRoll\tPitch\tYaw\tResidual\t" + "\t".join(f"Rot[{k}]" for k in range(9)) + "\n"
    )
    row = "\t1.0\t2.0\t3.0\t0.000\t0.000\t90.000\t0.4\t0\t1\t0\t-1\t0\t0\t0\t0\t1\n"
    p = tmp_path / "cube_6d.tsv"
    p.write_text(head + "1\t0.00" + row + "2\t0.01" + row)
    log = read_log(p)
    np.testing.assert_array_equal(log.data[0] @ [1, 0, 0], [0, 1, 0])
    np.testing.assert_array_equal(log.data[0] @ [0, 1, 0], [-1, 0, 0])
    assert "element order checked against Roll, Pitch, Yaw" in log.description


def test_qtm_6d_export_gives_the_plain_csv_rates(tmp_path, capsys):
    t, R, _ = motion(300, 100.0)
    other = Rotation.random(len(t), random_state=4).as_matrix()
    path = write_qtm_6d(tmp_path / "take_6d.tsv", t, {"wand": other, "drone": R}, 100.0, missing={40})
    assert detect_format(path).name == "qtm6d"
    with pytest.raises(LogFormatError, match=r"2 bodies with rotations \(wand, drone\); choose one with --body"):
        read_log(path)
    log = read_log(path, body="drone")
    assert log.missing.tolist() == [k == 40 for k in range(len(t))]  # QTM's zeros: not tracked
    np.testing.assert_allclose(log.data[~log.missing], R[np.arange(len(t)) != 40], atol=2e-6)
    table, printed = rates(path, tmp_path, capsys, "--body", "drone")
    assert (
        "detected Qualisys QTM 6D TSV: body 'drone', rotation Rot[0..8] column by column (body -> global; element "
        "order checked against Roll, Pitch, Yaw (agree to"
    ) in printed
    assert "time from column 'Time', 300 frames at 100 Hz" in printed
    plain = tmp_path / "plain.csv"
    header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    rows = [f"{t[k]:.5f}," + ",".join(f"{v:.6f}" for v in R[k].reshape(-1)) for k in range(len(t))]
    rows[40] = f"{t[40]:.5f}" + "," * 9
    plain.write_text(header + "\n" + "\n".join(rows) + "\n")
    same_rates(table, rates(plain, tmp_path, capsys)[0])


def test_qtm_errors(tmp_path):
    t, R, _ = motion(30, 100.0)
    rows = write_qtm_6d(tmp_path / "rows_6d.tsv", t, {"b": R}, 100.0, row_major=True)
    with pytest.raises(LogFormatError, match=r"agree with its Roll, Pitch, Yaw only when read row by row"):
        read_log(rows)
    none = tmp_path / "x.tsv"
    none.write_text("NO_OF_FRAMES\t1\nDATA_INCLUDED\t3D\nFrame\tTime\tX\n1\t0\t1\n")
    assert detect_format(none).name == "csv"  # a 3D export is not 6D: read as columns, which it lacks
    with pytest.raises(LogFormatError, match=r"x\.tsv, line 1 \(header\): no time column 't'"):
        read_log(none)
    nobody = write_qtm_6d(tmp_path / "n_6d.tsv", t, {"b": R}, 100.0)
    with pytest.raises(LogFormatError, match=r"no body named 'c'; the file has b"):
        read_log(nobody, body="c")
    bare = write_qtm_6d(tmp_path / "bare_6d.tsv", t, {"b": R}, 100.0, labels=False)
    np.testing.assert_allclose(read_log(bare).data, R, atol=2e-6)  # no label row: 16 columns a body


def test_qtm_mat_export_gives_the_rotations_and_the_6d_tsv_rates(tmp_path, capsys):
    """The same capture exported as MAT and as 6D TSV: the MAT file's matrices are the attitudes themselves (doubles),
    its untracked frame a missing sample, its times (frame - 1) / rate from its StartFrame, and its rates those of
    a plain CSV of the same matrices written with every digit; the TSV names the same body."""
    t, R, _ = motion(300, 100.0)
    other = Rotation.random(len(t), random_state=4).as_matrix()
    mat = write_qtm_mat(tmp_path / "take.mat", {"wand": other, "drone": R}, 100.0, missing={40}, start=11)
    assert detect_format(mat).name == "qtm-mat"
    with pytest.raises(LogFormatError, match=r"2 rigid bodies with rotations \(wand, drone\); choose one with --body"):
        read_log(mat)
    log = read_log(mat, body="drone")
    assert log.missing.tolist() == [k == 40 for k in range(len(t))]
    np.testing.assert_allclose(log.data[~log.missing], R[np.arange(len(t)) != 40], rtol=0, atol=1e-15)
    np.testing.assert_allclose(log.t, (10 + np.arange(len(t))) / 100.0, rtol=0, atol=1e-15)
    assert "other bodies in the file: wand" in log.notes
    table, printed = rates(mat, tmp_path, capsys, "--body", "drone")
    assert (
        "detected Qualisys QTM MAT export (Measurement1): body 'drone', RigidBodies.Rotations column by column "
        "(body -> global; element order checked against Roll, Pitch, Yaw (agree to"
    ) in printed
    plain = tmp_path / "plain.csv"
    header = "t," + ",".join(f"r{i}{j}" for i in (1, 2, 3) for j in (1, 2, 3))
    rows = [f"{float(t[k] + 0.1)!r}," + ",".join(repr(float(v)) for v in R[k].reshape(-1)) for k in range(len(t))]
    rows[40] = f"{float(t[40] + 0.1)!r}" + "," * 9
    plain.write_text(header + "\n" + "\n".join(rows) + "\n")
    same_rates(table, rates(plain, tmp_path, capsys)[0])
    tsv = write_qtm_6d(tmp_path / "take_6d.tsv", t, {"wand": other, "drone": R}, 100.0, missing={40})
    assert read_log(tsv, body="drone").missing.tolist() == log.missing.tolist()


def test_qtm_mat_errors(tmp_path, monkeypatch):
    from scipy.io import savemat

    from omegahat.io import qtm_mat

    t, R, _ = motion(30, 100.0)
    rows = write_qtm_mat(tmp_path / "rows.mat", {"b": R}, 100.0, row_major=True)
    with pytest.raises(LogFormatError, match=r"agree with its Roll, Pitch, Yaw only when read row by row"):
        read_log(rows)
    with pytest.raises(LogFormatError, match=r"no rigid body named 'c'; the file has b"):
        read_log(write_qtm_mat(tmp_path / "one.mat", {"b": R}, 100.0), body="c")
    # UPenn ESE 650's layout: rots (3, 3, T), ts (1, T); the message's line writes the NPZ log omegahat reads
    savemat(tmp_path / "arrays.mat", {"ts": t, "rots": np.moveaxis(R, 0, -1)})
    with pytest.raises(LogFormatError) as refused:
        read_log(tmp_path / "arrays.mat")
    text = str(refused.value)
    assert "arrays.mat: no QTM measurement structs with RigidBodies (variables: ts 1x30, rots 3x3x30)" in text
    line = text.split('e.g. python -c "')[1].split('"')[0]
    subprocess.run([sys.executable, "-c", line], cwd=tmp_path, check=True)
    converted = read_log(tmp_path / "arrays.npz")
    np.testing.assert_array_equal(converted.t, t)
    np.testing.assert_allclose(converted.data, R, rtol=0, atol=1e-15)
    # one vector per component (the hinge recordings' all_imu2_q1 … q4), the scalar first; a second quaternion named
    q = Rotation.from_matrix(R).as_quat(scalar_first=True)
    parts = {f"imu_q{i + 1}": q[:, i : i + 1] for i in range(4)} | {
        f"ref_q{c}": q[:, [i]] for i, c in enumerate("wxyz")
    }
    savemat(tmp_path / "parts.mat", {"time": t[:, None], **parts})
    with pytest.raises(LogFormatError) as refused:
        read_log(tmp_path / "parts.mat")
    text = str(refused.value)
    assert "(the scalar taken as its first name's component: reorder the names if it is not); another quaternion: " \
        "ref_qw, ref_qx, ref_qy, ref_qz" in text  # fmt: skip
    subprocess.run([sys.executable, "-c", text.split('e.g. python -c "')[1].split('"')[0]], cwd=tmp_path, check=True)
    converted = read_log(tmp_path / "parts.npz")
    np.testing.assert_array_equal(converted.t, t)
    np.testing.assert_allclose(Rotation.from_quat(converted.data).as_matrix(), R, rtol=0, atol=1e-12)  # scalar last
    hdf5 = tmp_path / "v73.mat"  # MATLAB 7.3: a MAT header of version 0x0200 over an HDF5 file
    hdf5.write_bytes(b"MATLAB 7.3 MAT-file".ljust(116) + bytes(8) + b"\x00\x02IM" + b"\x89HDF\r\n\x1a\n" + bytes(64))
    with pytest.raises(
        LogFormatError, match=r"v73\.mat: a MATLAB 7\.3 MAT-file \(HDF5\), which omegahat does not read"
    ):
        read_log(hdf5)
    (tmp_path / "text.mat").write_text("t,qw,qx,qy,qz\n0,1,0,0,0\n")
    with pytest.raises(LogFormatError, match=r"text\.mat: not a MATLAB level 5 MAT-file"):
        read_log(tmp_path / "text.mat")
    # a few kilobytes that expand into more than the bound: refused before SciPy reads them
    monkeypatch.setattr(qtm_mat, "MAX_MAT_BYTES", 1 << 20)
    bomb = tmp_path / "bomb.mat"
    savemat(bomb, {"Measurement1": {"FrameRate": 100.0, "Pad": np.zeros(1 << 18)}}, do_compression=True)
    assert bomb.stat().st_size < 10_000
    with pytest.raises(LogFormatError, match=r"bomb\.mat: its arrays take more than .* once decompressed"):
        read_log(bomb)
    monkeypatch.setattr(qtm_mat, "MAX_MAT_BYTES", 1 << 30)
    damaged = bytearray(write_qtm_mat(tmp_path / "ok.mat", {"b": R}, 100.0).read_bytes())
    damaged[300:340] = bytes(40)  # inside the compressed struct
    (tmp_path / "damaged.mat").write_bytes(bytes(damaged))
    with pytest.raises(LogFormatError, match=r"damaged\.mat: not a readable MAT-file"):
        read_log(tmp_path / "damaged.mat")


# ---------------------------------------------------------------------------------------------------- Motive


@pytest.mark.parametrize(
    ("version", "labelled", "euler"),
    [("1.21", False, None), ("1.23", True, None), ("1.21", False, "XYZ"), ("1.23", True, "ZYX"), ("1.23", True, "YXZ")],
)
def test_motive_layouts_side_by_side(tmp_path, capsys, version, labelled, euler):
    t, R, omega = motion(480, 120.0)
    q = Rotation.from_matrix(R).as_quat()
    path = write_motive(tmp_path / "take.csv", t, q, version=version, euler=euler, name="hand", labelled=labelled)
    assert detect_format(path).name == "motive"
    table, printed = rates(path, tmp_path, capsys)
    layout = "" if labelled else ", header rows without labels"
    what = (
        "quaternions X,Y,Z,W (scalar last)"
        if euler is None
        else f"Euler angles X,Y,Z in degrees, order {euler} about the rotating axes"
    )
    assert f"detected OptiTrack Motive CSV (format {version}{layout}): rigid body 'hand' (ID 1), {what}" in printed
    time = "Time (Seconds)" if version >= "1.23" else "Time"
    assert f"time from column '{time}', 480 frames at 120 Hz" in printed
    np.testing.assert_allclose(table[60:, 1:], omega[60:], atol=2e-3)  # 6 decimals, as Motive writes them
    if euler is None:  # the same numbers as omegahat's CSV: the same rates
        plain = write_plain_csv(tmp_path / "plain.csv", [f"{x:.6f}" for x in t], q, "{:.6f}")
        same_rates(table, rates(plain, tmp_path, capsys)[0])
    else:  # the angles as written, composed by SciPy in the stated order about the rotating axes
        text = path.read_text().splitlines()[7:]
        ang = np.array([[float(v) for v in line.split(",")[2:5]] for line in text])
        Rm = Rotation.from_euler(euler, ang[:, ["XYZ".index(a) for a in euler]], degrees=True).as_matrix()
        np.testing.assert_allclose(read_log(path).data, Rm, rtol=0, atol=1e-15)


# ------------------------------------------------------------------------------------------- seeded mutations


def test_seeded_mutations_of_every_text_reader_give_the_rows_or_a_message(tmp_path):
    """Byte flips, truncations, stray quotes, other line ends, inserted characters, deleted lines (issue 23): each
    reader gives a LogFormatError (or ValueError) or rows; a stray quote or other line ends never lose a row
    silently."""
    import random

    t = np.arange(60) / 100.0
    R = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_matrix()
    q = Rotation.from_matrix(R).as_quat()
    seeds = {
        "e.csv": write_euroc(tmp_path / "s0.csv", [10**18 + k * 10**7 for k in range(60)], q),
        "t.txt": write_tum(tmp_path / "s1.txt", decimal_seconds(1_700_000_000, t), q),
        "k.txt": write_kitti(tmp_path / "s2.txt", R),
        "q_6d.tsv": write_qtm_6d(tmp_path / "s3_6d.tsv", t, {"b": R}, 100.0),
        "m.csv": write_motive(tmp_path / "s4.csv", t, q, version="1.21"),
        "me.csv": write_motive(tmp_path / "s5.csv", t, q, version="1.23", euler="ZYX"),
        "p.csv": write_plain_csv(tmp_path / "s6.csv", [f"{x:.3f}" for x in t], q),
    }
    rng = random.Random(23)
    outcomes = {"rows": 0, "message": 0}
    for name, seed in seeds.items():
        data = seed.read_bytes()
        for _ in range(60):
            b = bytearray(data)
            op = rng.randrange(6)
            if op == 0:
                for _ in range(rng.randint(1, 5)):
                    b[rng.randrange(len(b))] = rng.randrange(256)
            elif op == 1:
                b = b[: rng.randrange(len(b))]
            elif op == 2:
                at = rng.randrange(len(b))
                b[at:at] = b'"'
            elif op == 3:
                b = bytearray(bytes(b).replace(b"\n", rng.choice([b"\r", b"\r\n", b"\n\n"])))
            elif op == 4:
                at = rng.randrange(len(b))
                b[at:at] = rng.choice([b",", b"\t", b" ", b"nan", b"1e999", b"-"])
            else:
                lines = bytes(b).split(b"\n")
                del lines[rng.randrange(len(lines))]
                b = bytearray(b"\n".join(lines))
            path = tmp_path / name
            path.write_bytes(bytes(b))
            try:
                log = read_log(path, **({"rate": 100.0} if name == "k.txt" else {}))
            except (LogFormatError, ValueError):
                outcomes["message"] += 1
                continue
            outcomes["rows"] += 1
            if op in (2, 3):  # nothing removed: every row, or a note saying what the policy dropped
                assert len(log) == 60 or log.notes, (name, op, len(log))
    assert outcomes["rows"] > 100 and outcomes["message"] > 100  # both outcomes exercised


def test_reader_messages(tmp_path):
    t, R, _ = motion(10, 100.0)
    q = Rotation.from_matrix(R).as_quat()
    m = write_motive(tmp_path / "m.csv", t, q)
    lines = m.read_text().splitlines()
    lines[9] = lines[9].replace(",0.1,", ',"0.1,', 1)
    m.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFormatError, match=r"m\.csv, line 10: an unbalanced quote \('\"'\); the fields after it"):
        read_log(m)
    lines = write_motive(tmp_path / "m.csv", t, q).read_text().splitlines()
    m.write_text("\n".join([lines[0], "", lines[2], *lines[5:]]) + "\n")  # the kinds row only
    with pytest.raises(LogFormatError, match=r"m\.csv: no row of names above line 4 \(a Motive export has rows of"):
        read_log(m)
    qtm = write_qtm_6d(tmp_path / "a_6d.tsv", t, {"a": R}, 100.0)
    text = qtm.read_text()
    qtm.write_text(text.replace("BODY_NAMES\ta", "BODY_NAMES\ta\tb"))
    with pytest.raises(LogFormatError, match=r"BODY_NAMES lists 2 bodies but the columns hold 1 Rot\[0\.\.8\] blocks"):
        read_log(qtm)
    qtm.write_text(text.replace("FREQUENCY\t100", "FREQUENCY\tEXT").replace("Frame\tTime\t", "Frame\tTick\t"))
    with pytest.raises(LogFormatError, match=r"a_6d\.tsv: no Time column and no FREQUENCY in the header"):
        read_log(qtm)
    rows = text.splitlines()
    rows[12] = rows[12].replace(rows[12].split("\t")[9], "x", 1)
    qtm.write_text("\n".join(rows) + "\n")
    with pytest.raises(LogFormatError, match=r"a_6d\.tsv, line 13, column a Rot\[0\]: 'x' is not a number"):
        read_log(qtm)
    with pytest.raises(LogFormatError, match=r"m\.csv: not a QTM 6D export \(no 'DATA_INCLUDED<tab>6D'"):
        read_log(m, fmt="qtm6d")
    with pytest.raises(LogFormatError, match=r"m\.csv, line 1: not an EuRoC trajectory"):
        read_log(m, fmt="euroc")
    k = write_kitti(tmp_path / "k.txt", R)
    kl = k.read_text().splitlines()
    k.write_text("\n".join([kl[0], kl[1] + " 1.0", *kl[2:]]) + "\n")
    with pytest.raises(LogFormatError, match=r"k\.txt, line 2: 13 numbers, but the first line has 12"):
        read_log(k, rate=10.0)
    k.write_text("\n".join([kl[0], kl[1].replace(kl[1].split()[3], "abc"), *kl[2:]]) + "\n")
    with pytest.raises(LogFormatError, match=r"k\.txt, line 2, number 4: 'abc' is not a number"):
        read_log(k, rate=10.0)
    k.write_text("# nothing\n")
    with pytest.raises(LogFormatError, match=r"k\.txt: no poses"):
        read_log(k, fmt="kitti", rate=10.0)
    with pytest.raises(LogFormatError, match=r"cannot read the times \(No such file"):
        read_log(write_kitti(tmp_path / "k2.txt", R), times=str(tmp_path / "none.txt"))
