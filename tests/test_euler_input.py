"""Attitude logged as Euler angles (``roll, pitch, yaw`` columns; omegahat.io.euler).

The expected rotations are products of elementary rotation matrices written out here, not SciPy's ``from_euler``
(which the reader uses)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat import estimate_frame
from omegahat.cli import main
from omegahat.io import LogFormatError, read_log
from recording_files import read_omega_csv

RATE = np.array([0.3, -0.2, 0.5])  # rad/s, body axes


def elementary(axis: str, angle: np.ndarray) -> np.ndarray:
    """The rotations by ``angle (T,)`` rad about ``axis`` (x, y or z), ``(T, 3, 3)``, written out."""
    c, s = np.cos(angle), np.sin(angle)
    one, zero = np.ones_like(angle), np.zeros_like(angle)
    rows = {
        "x": [[one, zero, zero], [zero, c, -s], [zero, s, c]],
        "y": [[c, zero, s], [zero, one, zero], [-s, zero, c]],
        "z": [[c, -s, zero], [s, c, zero], [zero, zero, one]],
    }[axis]
    return np.moveaxis(np.array(rows), -1, 0)


def by_hand(seq: str, angles: np.ndarray) -> np.ndarray:
    """R of (E1) (upper case: R_a1 R_a2 R_a3) or (E2) (lower case: R_a3 R_a2 R_a1); ``angles (T, 3)`` rad about
    x, y, z."""
    factors = [elementary(a, angles[:, "xyz".index(a)]) for a in seq.lower()]
    if seq.islower():
        factors = factors[::-1]
    return factors[0] @ factors[1] @ factors[2]


def write(path, t, angles, header="t,roll,pitch,yaw"):
    np.savetxt(path, np.column_stack([t, angles]), delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def sample_angles(T: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Times and angles (rad, about x, y, z) sweeping every quadrant, pitch through ±80°."""
    t = np.arange(T) / 100.0
    angles = np.column_stack([2.5 * np.sin(3.1 * t), 1.4 * np.sin(2.3 * t + 0.4), 3.0 * np.cos(1.7 * t)])
    return t, angles


@pytest.mark.parametrize("seq", ["ZYX", "xyz", "YXZ", "zxy", "XZY"])
@pytest.mark.parametrize("unit", ["deg", "rad"])
def test_euler_columns_give_the_rotation_of_their_sequence(tmp_path, seq, unit):
    t, angles = sample_angles()
    logged = np.degrees(angles) if unit == "deg" else angles
    log = read_log(write(tmp_path / "e.csv", t, logged), euler=seq, angle_unit=unit)
    assert log.kind == "matrix"
    np.testing.assert_allclose(log.data, by_hand(seq, angles), atol=1e-12)


def test_upper_and_lower_case_are_the_same_rotation_read_in_reverse(tmp_path):
    """(E1) and (E2): ZYX about the rotating axes is xyz about the fixed ones."""
    t, angles = sample_angles()
    path = write(tmp_path / "e.csv", t, angles)
    a = read_log(path, euler="ZYX", angle_unit="rad").data
    b = read_log(path, euler="xyz", angle_unit="rad").data
    c = read_log(path, euler="XYZ", angle_unit="rad").data
    np.testing.assert_allclose(a, b, atol=1e-14)
    assert np.max(np.abs(a - c)) > 0.1  # a different convention, a different rotation


def test_the_command_estimates_from_euler_angles_what_it_estimates_from_quaternions(tmp_path, capsys):
    t = np.arange(1000) / 100.0
    truth = Rotation.from_rotvec([0.2, 0.5, -0.1]) * Rotation.from_rotvec(np.outer(t, RATE))  # rate in body axes
    truth = truth * Rotation.from_rotvec(1e-3 * np.random.default_rng(3).standard_normal((t.size, 3)))
    ypr = truth.as_euler("ZYX", degrees=True)  # yaw, pitch, roll
    euler = write(tmp_path / "e.csv", t, ypr[:, ::-1])
    quat = tmp_path / "q.csv"
    np.savetxt(quat, np.column_stack([t, truth.as_quat()]), delimiter=",", header="t,qx,qy,qz,qw", comments="")
    outputs = []
    for path, extra in ((euler, ["--euler", "ZYX", "--angle-unit", "deg"]), (quat, [])):
        out = tmp_path / f"{path.stem}.out.csv"
        assert main(["estimate", str(path), "-o", str(out), *extra]) == 0
        outputs.append(read_omega_csv(out)[0])
    printed = capsys.readouterr()
    assert "Euler angles roll, pitch, yaw in degrees, sequence ZYX (about the rotating axes)" in printed.out
    np.testing.assert_allclose(outputs[0], outputs[1], atol=1e-6)
    np.testing.assert_allclose(np.median(outputs[0][100:, 1:], axis=0), RATE, atol=2e-3)


@pytest.mark.parametrize(
    ("given", "missing"),
    [([], "--euler, --angle-unit"), (["--euler", "ZYX"], "--angle-unit"), (["--angle-unit", "deg"], "--euler")],
)
def test_the_conventions_are_asked_for_and_nothing_is_written(tmp_path, capsys, given, missing):
    t, angles = sample_angles()
    path = write(tmp_path / "e.csv", t, angles)
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), *given]) != 0
    err = capsys.readouterr().err
    assert "Euler angles (roll,pitch,yaw)" in err and f"(missing: {missing};" in err
    assert "Traceback" not in err
    assert not out.exists()


def test_conventions_for_a_log_without_euler_angles_are_not_used_and_said(tmp_path):
    # as --scalar-first for named quaternion columns; a folder run gives every log the same options
    t, angles = sample_angles()
    path = tmp_path / "q.csv"
    q = Rotation.from_rotvec(angles).as_quat()
    np.savetxt(path, np.column_stack([t, q]), delimiter=",", header="t,qx,qy,qz,qw", comments="")
    log = read_log(path, euler="ZYX", angle_unit="deg")
    np.testing.assert_allclose(log.data, q, atol=1e-15)  # the quaternions, as read without the options
    assert any("--euler and --angle-unit not used" in n and "qw,qx,qy,qz" in n for n in log.notes)


def test_a_folder_of_euler_and_quaternion_logs_runs_with_the_conventions(tmp_path, capsys):
    t, angles = sample_angles()
    folder = tmp_path / "logs"
    folder.mkdir()
    write(folder / "angles.csv", t, np.degrees(angles))
    R = by_hand("ZYX", angles)
    np.savetxt(folder / "quats.csv", np.column_stack([t, Rotation.from_matrix(R).as_quat()]), delimiter=",",
               header="t,qx,qy,qz,qw", comments="")  # fmt: skip
    out = tmp_path / "out"
    code = main(["estimate", str(folder), "-o", str(out), "--euler", "ZYX", "--angle-unit", "deg", "--no-progress"])
    printed = capsys.readouterr()
    assert code == 0, printed.out + printed.err
    rates = {name: read_omega_csv(out / name)[0][:, 1:] for name in ("angles.csv", "quats.csv")}
    np.testing.assert_allclose(rates["angles.csv"], rates["quats.csv"], atol=1e-6)  # the same rotations


@pytest.mark.parametrize("seq", ["ZXZ", "zyX", "abc", "ZY", "xyzx", ""])
def test_a_sequence_that_names_no_axis_once_each_is_refused(seq):
    with pytest.raises(ValueError, match="three letters naming x, y and z once each"):
        read_log("unused.csv", euler=seq, angle_unit="deg")


def test_an_unknown_angle_unit_is_refused():
    with pytest.raises(ValueError, match="angle unit must be deg or rad"):
        read_log("unused.csv", euler="ZYX", angle_unit="grad")


def test_a_sample_with_an_empty_angle_is_missing_and_its_row_still_gets_an_estimate(tmp_path, capsys):
    t, angles = sample_angles(400)
    path = tmp_path / "e.csv"
    lines = ["t,roll,pitch,yaw"] + [",".join(repr(float(v)) for v in (ti, *a)) for ti, a in zip(t, angles, strict=True)]
    lines[151] = f"{float(t[150])!r},{float(angles[150, 0])!r},,{float(angles[150, 2])!r}"
    path.write_text("\n".join(lines) + "\n")
    log = read_log(path, euler="ZYX", angle_unit="rad")
    assert np.flatnonzero(log.missing).tolist() == [150]
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), "--euler", "ZYX", "--angle-unit", "rad"]) == 0
    table, status = read_omega_csv(out)
    assert np.all(np.isfinite(table)) and len(table) == 400
    assert status[150] == "predicted" and status[149] == "corrected"  # said to be missing, not read as a sample


def test_npz_parquet_and_dataframes_read_euler_angles_as_csv_does(tmp_path):
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    t, angles = sample_angles(300)
    columns = {"t": t, "roll": angles[:, 0], "pitch": angles[:, 1], "yaw": angles[:, 2]}
    np.savez(tmp_path / "e.npz", **columns)
    pq.write_table(pa.table(columns), tmp_path / "e.parquet")
    expected = by_hand("ZYX", angles)
    for name in ("e.npz", "e.parquet"):
        np.testing.assert_allclose(read_log(tmp_path / name, euler="ZYX", angle_unit="rad").data, expected, atol=1e-14)
    csv = write(tmp_path / "e.csv", t, angles)
    assert main(["estimate", str(csv), "-o", str(tmp_path / "o.csv"), "--euler", "ZYX", "--angle-unit", "rad"]) == 0
    frame = estimate_frame(pd.DataFrame(columns), euler="ZYX", angle_unit="rad")
    np.testing.assert_allclose(frame[["wx", "wy", "wz"]].to_numpy(), read_omega_csv(tmp_path / "o.csv")[0][:, 1:])
    with pytest.raises(LogFormatError, match="missing: --euler, --angle-unit; in Python euler= and angle_unit="):
        estimate_frame(pd.DataFrame(columns))


def test_degrees_read_as_radians_are_pointed_out(tmp_path):
    t, angles = sample_angles()
    path = write(tmp_path / "e.csv", t, np.degrees(angles))
    log = read_log(path, euler="ZYX", angle_unit="rad")
    assert any("read as radians (--angle-unit rad): more than a turn" in n for n in log.notes)
    calm = read_log(path, euler="ZYX", angle_unit="deg")
    assert not any("more than a turn" in n for n in calm.notes)


def test_a_unit_the_names_state_against_the_one_given_is_said(tmp_path):
    """Columns named ``Roll (deg)`` read with --angle-unit rad (small angles: no turn exceeded) were read with no
    word; the note now says what the names state. Read in the unit they state, nothing more is said."""
    path = tmp_path / "named.csv"
    path.write_text("t,Roll (deg),Pitch (deg),Yaw (deg)\n0,1,2,3\n0.01,1.1,2.1,3.1\n")
    columns = "t=t,roll=Roll (deg),pitch=Pitch (deg),yaw=Yaw (deg)"
    said = "their names say deg (Roll (deg) (roll),Pitch (deg) (pitch),Yaw (deg) (yaw)): --angle-unit is what is read"
    assert any(said in n for n in read_log(path, columns=columns, euler="ZYX", angle_unit="rad").notes)
    assert not any("names say" in n for n in read_log(path, columns=columns, euler="ZYX", angle_unit="deg").notes)
    plain = write(tmp_path / "plain.csv", *sample_angles())
    assert not any("names say" in n for n in read_log(plain, euler="ZYX", angle_unit="rad").notes)


def test_euler_angles_beside_a_quaternion_leave_the_quaternion_read(tmp_path):
    """Exports often write both: the exact attitude is read, as before the angles were read at all."""
    t, angles = sample_angles()
    q = Rotation.from_rotvec(angles * 0.1).as_quat()
    path = tmp_path / "both.csv"
    header = "t,qx,qy,qz,qw,roll,pitch,yaw"
    np.savetxt(path, np.column_stack([t, q, angles]), delimiter=",", header=header, comments="", fmt="%.17g")
    log = read_log(path)
    assert log.kind == "quaternion"
    np.testing.assert_allclose(log.data, q * np.sign(q[:, 3:4]) * np.sign(log.data[:, 3:4]), atol=1e-15)


def test_column_map_names_euler_columns(tmp_path):
    t, angles = sample_angles()
    path = write(tmp_path / "e.csv", t, np.degrees(angles), header="Time,Roll (deg),Pitch (deg),Yaw (deg)")
    columns = "t=Time,roll=Roll (deg),pitch=Pitch (deg),yaw=Yaw (deg)"
    log = read_log(path, columns=columns, euler="ZYX", angle_unit="deg")
    np.testing.assert_allclose(log.data, by_hand("ZYX", angles), atol=1e-12)


def test_the_error_for_unknown_names_prints_the_euler_line_that_reads_them(tmp_path, capsys):
    t, angles = sample_angles()
    path = write(tmp_path / "e.csv", t, np.degrees(angles), header="Time (s),Roll (deg),Pitch (deg),Yaw (deg)")
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv")]) != 0
    err = capsys.readouterr().err
    line = "--columns 't=Time (s),roll=Roll (deg),pitch=Pitch (deg),yaw=Yaw (deg)' --euler SEQ --angle-unit deg"
    assert line in err
    filled = ["--columns", "t=Time (s),roll=Roll (deg),pitch=Pitch (deg),yaw=Yaw (deg)", "--euler", "ZYX"]
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), *filled, "--angle-unit", "deg"]) == 0
    unitless = write(tmp_path / "u.csv", t, angles, header="time,Roll,Pitch,Yaw")  # names read as they are
    assert main(["estimate", str(unitless), "-o", str(tmp_path / "o.csv")]) != 0
    assert "(missing: --euler, --angle-unit; in Python euler= and angle_unit=)" in capsys.readouterr().err
    assert (
        main(["estimate", str(unitless), "-o", str(tmp_path / "o.csv"), "--euler", "ZYX", "--angle-unit", "rad"]) == 0
    )
