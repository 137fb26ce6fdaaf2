"""Motion-capture exports written by the tests in the documented layouts: OptiTrack Motive CSV, Vicon CSV and
C3D (ezc3d); automatic detection with its message, body selection, missing frames, sign flips and wrap-around,
and every error with its message."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, detect_format, read_log
from recording_files import (
    J_AXI,
    flip_signs,
    read_omega_csv,
    torque_free_axisymmetric,
    write_motive_csv,
    write_vicon_csv,
)

RATE = 120.0
CLI = ["--inertia", "1", "1", "1.6", "--no-progress"]


def motion(n=240, rate=RATE):
    t = np.arange(n) / rate
    R, omega = torque_free_axisymmetric(t)
    return t, R, omega


def estimate(path, tmp_path, *extra):
    out = tmp_path / "omega.csv"
    if out.exists():
        out.unlink()
    assert main(["estimate", str(path), "-o", str(out), *CLI, *extra]) == 0
    return read_omega_csv(out)[0]


# ---------------------------------------------------------------------------------------------------- Motive


def test_motive_export_in_one_command_with_the_detection_message(tmp_path, capsys):
    t, R, omega = motion()
    q = Rotation.from_matrix(R).as_quat()
    other = Rotation.random(t.size, random_state=1).as_quat()
    path = write_motive_csv(tmp_path / "Take 2024-01-01.csv", t, {"drone": q, "wand": other}, missing={50, 51})
    assert detect_format(path).name == "motive"
    table = estimate(path, tmp_path, "--body", "drone")
    printed = capsys.readouterr().out
    assert (
        "detected OptiTrack Motive CSV (format 1.23): rigid body 'drone' (ID 1), quaternions X,Y,Z,W (scalar last), "
        "time from column 'Time (Seconds)', 240 frames at 120 Hz"
    ) in printed
    assert "other rigid bodies in the file: wand" in printed
    assert "skipped 2 of 240 samples (2 missing, 0 with nearly collinear directions): predicted through" in printed
    np.testing.assert_array_equal(table[:, 0], t)
    np.testing.assert_allclose(table[2:, 1:], omega[2:], atol=2e-4)  # through the two untracked frames too


def test_motive_reads_the_numbers_as_written_and_sign_flips_change_nothing(tmp_path):
    t, R, _ = motion(60)
    q = Rotation.from_matrix(R).as_quat()
    rng = np.random.default_rng(2)
    a = write_motive_csv(tmp_path / "a.csv", t, {"rb": q})
    b = write_motive_csv(tmp_path / "b.csv", t, {"rb": flip_signs(q, rng)})
    rec = read_log(a)  # one rigid body: no --body needed
    np.testing.assert_array_equal(rec.data, q)
    np.testing.assert_array_equal(rec.t, t)
    np.testing.assert_array_equal(estimate(a, tmp_path), estimate(b, tmp_path))


def test_motive_six_decimals_as_motive_writes_them(tmp_path):
    t, R, omega = motion(600)
    q = Rotation.from_matrix(R).as_quat()
    path = write_motive_csv(tmp_path / "take.csv", t, {"rb": q}, digits=6)
    table = estimate(path, tmp_path)  # gains chosen from the export: its rounding is its noise
    # 6 decimals = 5e-7 rad of rounding: differentiated at 120 Hz, about 1e-4 rad/s before filtering
    np.testing.assert_allclose(table[120:, 1:], omega[120:], atol=3e-4)


def test_motive_errors(tmp_path):
    t, R, _ = motion(5)
    q = Rotation.from_matrix(R).as_quat()
    two = write_motive_csv(tmp_path / "two.csv", t, {"a": q, "b": q})
    with pytest.raises(LogFormatError, match=r"2 rigid bodies with rotations \(a, b\); choose one with --body"):
        read_log(two)
    with pytest.raises(LogFormatError, match=r"no rigid body named 'c'; the file has a, b"):
        read_log(two, body="c")
    assert read_log(two, body="B").description.startswith("OptiTrack Motive CSV (format 1.23): rigid body 'b'")
    # Euler exports are read (tests/test_io_vendors.py); one whose header contradicts itself is refused
    euler = write_motive_csv(tmp_path / "e.csv", t, {"a": q}, rotation_type="XYZ")
    with pytest.raises(LogFormatError, match=r"e\.csv, line 7: Rotation Type is 'XYZ' .* columns X,Y,Z,W"):
        read_log(euler)
    odd = write_motive_csv(tmp_path / "o.csv", t, {"a": q}, rotation_type="Axis Angle")
    with pytest.raises(LogFormatError, match=r"o\.csv, line 1: Rotation Type 'Axis Angle' is neither Quaternion"):
        read_log(odd)
    bad = tmp_path / "bad.csv"
    lines = (tmp_path / "two.csv").read_text().splitlines()
    lines[9] = lines[9].replace(repr(float(q[2, 1])), "abc", 1)
    bad.write_text("\n".join(lines))
    with pytest.raises(LogFormatError, match=r"bad\.csv, line 10, column a Rotation Y: 'abc' is not a number"):
        read_log(bad, body="a")
    markers = tmp_path / "markers.csv"
    markers.write_text(
        "Format Version,1.23,Take Name,x,Rotation Type,Quaternion\n\n,Type,Marker,Marker,Marker\n,Name,m1,m1,m1\n"
        ",ID,1,1,1\n,,Position,Position,Position\nFrame,Time (Seconds),X,Y,Z\n0,0.0,1,2,3\n"
    )
    with pytest.raises(
        LogFormatError, match=r"no rigid body with quaternion columns .*found: Marker\).*define a rigid"
    ):
        read_log(markers)
    with pytest.raises(
        ValueError, match=r"log\.npz is an omegahat NPZ log: --body applies only to an OptiTrack Motive"
    ):
        read_log(tmp_path / "log.npz", body="a")


# ---------------------------------------------------------------------------------------------------- Vicon


@pytest.mark.parametrize("unit", ["deg", "rad"])
def test_vicon_segments_export_with_dropped_frames(tmp_path, capsys, unit):
    rate = 100.0
    frames = np.arange(1, 301)
    frames = np.delete(frames, [100, 101, 102, 200])  # dropped frames: gaps in the frame numbers
    R, omega = torque_free_axisymmetric(frames / rate)
    other = Rotation.random(frames.size, random_state=3).as_matrix()
    path = write_vicon_csv(tmp_path / "trial01.csv", frames, rate, {"drone:drone": R, "arm:upper": other}, unit=unit)
    assert detect_format(path).name == "vicon"
    table = estimate(path, tmp_path, "--body", "drone:drone")
    printed = capsys.readouterr().out
    assert (
        f"detected Vicon CSV, section 'Segments' at 100 Hz: 'drone:drone', helical angles RX,RY,RZ in {unit} "
        f"(rotation vector into the global frame), time = Frame / 100, {frames.size} frames"
    ) in printed
    np.testing.assert_allclose(table[:, 0], frames / rate, rtol=0, atol=1e-15)
    np.testing.assert_allclose(table[2:, 1:], omega[2:], atol=2e-4)


def test_vicon_helical_wrap_around_makes_no_spike(tmp_path):
    """A body turning steadily through 180°: the helical vector jumps from +π a to −π a (same rotation)."""
    rate = 100.0
    frames = np.arange(1, 201)
    w = np.array([0.0, 0.0, 2.0])
    R = Rotation.from_rotvec((frames / rate)[:, None] * w + np.array([0, 0, np.pi - 1.0])).as_matrix()
    rotvec = Rotation.from_matrix(R).as_rotvec()
    assert np.abs(np.diff(rotvec[:, 2])).max() > 6  # the export's vector does jump
    path = write_vicon_csv(tmp_path / "spin.csv", frames, rate, {"top": R}, trajectories=False)
    table = estimate(path, tmp_path, "--inertia", "1", "1", "1")
    np.testing.assert_allclose(table[2:, 1:], np.tile(w, (frames.size - 2, 1)), atol=1e-9)


def test_vicon_errors(tmp_path):
    frames = np.arange(1, 6)
    R = Rotation.random(5, random_state=4).as_matrix()
    only_markers = tmp_path / "markers.csv"
    only_markers.write_text("Trajectories\n100\n,,s:m1,,\nFrame,Sub Frame,X,Y,Z\n,,mm,mm,mm\n1,0,1,2,3\n2,0,1,2,3\n")
    assert detect_format(only_markers).name == "vicon"
    with pytest.raises(LogFormatError, match=r"no rotations \(sections: Trajectories\); .*export the 'Segments'"):
        read_log(only_markers)
    two = write_vicon_csv(tmp_path / "two.csv", frames, 100, {"a:a": R, "b:b": R})
    with pytest.raises(LogFormatError, match=r"2 objects/segments with rotations \(a:a, b:b\); choose one with --body"):
        read_log(two)
    grad = write_vicon_csv(tmp_path / "grad.csv", frames, 100, {"a:a": R}, unit="grad")
    with pytest.raises(LogFormatError, match=r"grad\.csv, line 5, column a:a RX: unit 'grad'; expected 'deg' or 'rad'"):
        read_log(grad)
    text = (tmp_path / "two.csv").read_text().replace("\n3,0,", "\n2,0,", 1)  # frame 2 twice, other angles
    (tmp_path / "dup.csv").write_text(text)
    with pytest.raises(LogFormatError, match=r"dup\.csv, line 7 and .*line 8: two samples at the same time 0\.02"):
        read_log(tmp_path / "dup.csv", body="a:a")


def test_a_plain_omegahat_csv_is_still_a_log(tmp_path):
    p = tmp_path / "log.csv"
    p.write_text("t,qx,qy,qz,qw\n0,0,0,0,1\n")
    assert detect_format(p).name == "csv"


# ---------------------------------------------------------------------------------------------------- C3D


def write_c3d(path, R_by_body: dict, rate, first_frame=0):
    import ezc3d

    names = list(R_by_body)
    T = next(iter(R_by_body.values())).shape[0]
    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([rate])
    c["parameters"]["POINT"]["LABELS"]["value"] = ["m1", "m2"]
    c["data"]["points"] = np.ones((4, 2, T))
    rot = np.zeros((4, 4, len(names), T))
    for i, name in enumerate(names):
        rot[:3, :3, i, :] = np.moveaxis(R_by_body[name], 0, -1)
        rot[3, 3, i, :] = 1.0
        rot[:, :, i, np.isnan(R_by_body[name][:, 0, 0])] = np.nan
    c.add_parameter("ROTATION", "LABELS", names)
    c.add_parameter("ROTATION", "USED", [len(names)])
    c.add_parameter("ROTATION", "RATE", [rate])
    c["data"]["rotations"] = rot
    c.write(str(path))
    return path


def test_c3d_rotations(tmp_path, capsys):
    t, R, omega = motion(240, 100.0)
    R = R.copy()
    R[30] = np.nan  # a frame the system could not solve
    other = Rotation.random(240, random_state=5).as_matrix()
    path = write_c3d(tmp_path / "trial.c3d", {"drone": R, "wand": other}, 100.0)
    assert detect_format(path).name == "c3d"
    with pytest.raises(LogFormatError, match=r"2 rigid bodies with rotations \(drone, wand\); choose one with --body"):
        read_log(path)
    rec = read_log(path, body="drone")
    np.testing.assert_allclose(rec.data[~rec.missing], R[np.arange(240) != 30], atol=1e-7)  # float32 file
    assert rec.missing.tolist() == [k == 30 for k in range(240)]
    table = estimate(path, tmp_path, "--body", "drone")
    assert "detected C3D file: rigid body 'drone' from the ROTATION group (2 bodies), 240 frames at 100 Hz" in (
        capsys.readouterr().out
    )
    np.testing.assert_allclose(table[:, 0], t, atol=1e-12)
    np.testing.assert_allclose(table[2:, 1:], omega[2:], atol=2e-3)  # float32 rotations, differentiated


def test_c3d_with_markers_only_says_what_is_needed(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = np.array([100.0])
    c["parameters"]["POINT"]["LABELS"]["value"] = ["LASI", "RASI", "LPSI"]
    c["data"]["points"] = np.ones((4, 3, 10))
    c.write(str(tmp_path / "markers.c3d"))
    with pytest.raises(
        LogFormatError, match=r"stores 3 marker trajectories \(LASI, RASI, LPSI\) but no rigid-body rot"
    ):
        read_log(tmp_path / "markers.c3d")
    (tmp_path / "junk.c3d").write_bytes(b"not a c3d file at all")
    with pytest.raises(LogFormatError, match=r"junk\.c3d: not a readable C3D file"):
        read_log(tmp_path / "junk.c3d")


def test_the_model_used_in_these_tests_is_the_truth():
    """J_AXI torque-free: the closed form satisfies Euler's equations (independent check of the helper)."""
    t = np.linspace(0.0, 2.0, 2001)
    _, omega = torque_free_axisymmetric(t)
    dw = np.gradient(omega, t, axis=0)[2:-2]
    rhs = np.cross(omega @ J_AXI.T, omega)[2:-2] @ np.linalg.inv(J_AXI).T
    np.testing.assert_allclose(dw, rhs, atol=1e-5)


def test_the_c3d_childs_reading_imports_nothing_of_omegahat(tmp_path):
    """The child process that reads a C3D file (``io/c3d_child.py``, loaded by its path) gives the rotations the
    file holds, and its interpreter never imported the package (its import is most of a child's start-up)."""
    import pickle
    import subprocess
    import sys

    from omegahat.io import c3d_child

    R = Rotation.random(20, random_state=3).as_matrix()
    path = write_c3d(tmp_path / "trial.c3d", {"drone": R}, 50.0)
    probe = "print(sorted(m for m in sys.modules if m.split('.')[0] == 'omegahat'), file=sys.stderr)\n"
    done = subprocess.run(
        [sys.executable, "-c", c3d_child.RUN + probe, c3d_child.__file__, str(path)], capture_output=True, check=True
    )
    assert done.stderr.decode().strip() == "[]"
    out = pickle.loads(done.stdout)
    np.testing.assert_allclose(np.moveaxis(out["data"]["rotations"][:3, :3, 0, :], -1, 0), R, atol=1e-6)
    assert list(out["parameters"]["ROTATION"]["LABELS"]["value"]) == ["drone"]
