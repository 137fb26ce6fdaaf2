"""Attitude logged as a rotation vector (``rotvec_x..z`` columns; omegahat.io.rotvec) and Universal Robots RTDE
recordings (omegahat.io.ur_rtde).

A body turns at a known rate in its own axes, ``R(t) = R0 exp(S(ω) t)``; SciPy writes its rotation vectors. The
rotations read back are compared with Rodrigues' formula written out here, and their increments with ``ω Δt``."""

from __future__ import annotations

import csv

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from omegahat import estimate_frame
from omegahat.cli import main
from omegahat.io import LogFormatError, read_log
from recording_files import estimate_file

OMEGA = np.array([0.4, -0.7, 0.9])  # rad/s, body (tool) axes
R0 = Rotation.from_rotvec([2.6, 0.9, -0.5])  # near a half turn: the vectors wrap past π as the body turns
STEP = 0.008  # s: a UR controller's 125 Hz


def _truth(n: int = 1000) -> tuple[np.ndarray, Rotation]:
    s = np.arange(n) * STEP
    return s, R0 * Rotation.from_rotvec(np.outer(s, OMEGA))


def _rodrigues(phi: np.ndarray) -> np.ndarray:
    """(V1) written out: I + sin θ/θ Φ + (1 − cos θ)/θ² Φ², row by row."""
    out = []
    for p in phi:
        theta = np.linalg.norm(p)
        P = np.array([[0, -p[2], p[1]], [p[2], 0, -p[0]], [-p[1], p[0], 0]])
        out.append(np.eye(3) + np.sin(theta) / theta * P + (1 - np.cos(theta)) / theta**2 * P @ P)
    return np.array(out)


def _write(path, t, vectors, header="t,rotvec_x,rotvec_y,rotvec_z"):
    np.savetxt(path, np.column_stack([t, vectors]), delimiter=",", header=header, comments="", fmt="%.17g")
    return path


def test_rotation_vectors_are_the_rotations_they_name_across_the_wrap(tmp_path):
    t, R = _truth()
    phi = R.as_rotvec()
    jumps = np.linalg.norm(np.diff(phi, axis=0), axis=1)
    assert jumps.max() > 3.0  # the vector jumps at the half turn (the rotation does not)
    log = read_log(_write(tmp_path / "rv.csv", t, phi))
    assert log.kind == "matrix"
    np.testing.assert_allclose(log.data, _rodrigues(phi), atol=1e-12)
    steps = (Rotation.from_matrix(log.data[:-1]).inv() * Rotation.from_matrix(log.data[1:])).as_rotvec()
    np.testing.assert_allclose(steps, np.tile(OMEGA * STEP, (len(t) - 1, 1)), atol=1e-12)
    assert any("rotation vector rotvec_x,rotvec_y,rotvec_z in radians" in n for n in log.notes)


def test_the_estimate_turns_at_the_bodys_rate_with_no_spike_at_the_wrap(tmp_path, capsys):
    t, R = _truth()
    table, printed = estimate_file(_write(tmp_path / "rv.csv", t, R.as_rotvec()), tmp_path, capsys)
    w = table[:, 1:]
    assert np.all(np.isfinite(w))
    np.testing.assert_allclose(w[50:], np.tile(OMEGA, (len(t) - 50, 1)), atol=1e-6)
    assert "spike" not in printed


def test_a_body_at_rest_at_a_half_turn_written_as_either_vector_is_at_rest(tmp_path, capsys):
    # a UR controller at a half turn writes φ and −φ by turns (seen in a real recording): one rotation, exp(φ×) =
    # exp(−φ×) where |φ| = π
    axis = np.array([0.72, -0.69, 0.08]) / np.linalg.norm([0.72, -0.69, 0.08])
    t = np.arange(200) * STEP
    phi = np.pi * axis * np.where(np.arange(200) % 3 == 0, 1.0, -1.0)[:, None]
    table, _ = estimate_file(_write(tmp_path / "rest.csv", t, phi), tmp_path, capsys)
    assert np.abs(table[:, 1:]).max() < 1e-9


def test_a_missing_component_is_a_missing_sample_and_degrees_get_a_note(tmp_path):
    t, R = _truth(200)
    phi = R.as_rotvec()
    phi[40, 1] = np.nan
    log = read_log(_write(tmp_path / "gap.csv", t, phi))
    assert np.isnan(log.data[40]).all() and np.isfinite(np.delete(log.data, 40, axis=0)).all()
    degrees = read_log(_write(tmp_path / "deg.csv", t, np.degrees(R.as_rotvec())))
    assert any("more than a turn" in n and "radians" in n for n in degrees.notes)
    assert not any("more than a turn" in n for n in log.notes)


def test_rotation_vectors_in_npz_and_parquet_logs(tmp_path):
    t, R = _truth(300)
    phi = R.as_rotvec()
    np.savez(tmp_path / "whole.npz", t=t, rotvec=phi)
    np.savez(tmp_path / "columns.npz", t=t, rotvec_x=phi[:, 0], rotvec_y=phi[:, 1], rotvec_z=phi[:, 2])
    pd.DataFrame({"t": t, "rotvec_x": phi[:, 0], "rotvec_y": phi[:, 1], "rotvec_z": phi[:, 2]}).to_parquet(
        tmp_path / "log.parquet"
    )
    for name in ("whole.npz", "columns.npz", "log.parquet"):
        np.testing.assert_allclose(read_log(tmp_path / name).data, _rodrigues(phi), atol=1e-12)
    np.savez(tmp_path / "both.npz", t=t, rotvec=phi, q=R.as_quat())
    with pytest.raises(LogFormatError, match=r"attitude given more than one way \(q, rotvec\)"):
        read_log(tmp_path / "both.npz")
    np.savez(tmp_path / "short.npz", t=t, rotvec=phi[:-1])
    with pytest.raises(LogFormatError, match="rotvec"):
        read_log(tmp_path / "short.npz")


def test_rotation_vectors_in_a_dataframe_and_beside_another_attitude(tmp_path):
    t, R = _truth(300)
    frame = pd.DataFrame(R.as_rotvec(), columns=["rotvec_x", "rotvec_y", "rotvec_z"]).assign(t=t)
    w = estimate_frame(frame)[["wx", "wy", "wz"]].to_numpy()
    np.testing.assert_allclose(w[50:], np.tile(OMEGA, (len(t) - 50, 1)), atol=1e-6)
    both = np.column_stack([t, R.as_rotvec(), R.as_quat()])
    path = tmp_path / "both.csv"
    np.savetxt(path, both, delimiter=",", header="t,rotvec_x,rotvec_y,rotvec_z,qx,qy,qz,qw", comments="")
    with pytest.raises(LogFormatError, match="more than one way"):
        read_log(path)


def test_rx_ry_rz_are_refused_with_both_readings_and_the_rotation_vector_one_reads_them(tmp_path, capsys):
    t, R = _truth(300)
    path = _write(tmp_path / "pose.csv", t, R.as_rotvec(), header="timestamp,rx,ry,rz")
    assert main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    line = "--columns t=timestamp,rotvec_x=rx,rotvec_y=ry,rotvec_z=rz"
    assert line in err and "--columns t=timestamp,roll=rx,pitch=ry,yaw=rz --euler SEQ" in err
    assert not (tmp_path / "o.csv").exists()
    table, _ = estimate_file(path, tmp_path, capsys, *line.split())
    np.testing.assert_allclose(table[:, 1:][50:], np.tile(OMEGA, (250, 1)),
                               atol=1e-6)  # fmt: skip


def test_a_dataframe_with_rx_ry_rz_is_refused_with_the_columns_that_read_it(tmp_path):
    t, R = _truth(300)
    df = pd.DataFrame(np.column_stack([t, R.as_rotvec()]), columns=["timestamp", "rx", "ry", "rz"])
    with pytest.raises(LogFormatError) as err:
        estimate_frame(df)
    line = "t=timestamp,rotvec_x=rx,rotvec_y=ry,rotvec_z=rz"
    assert "columns= reads others" in str(err.value) and f"--columns {line}" in str(err.value)
    out = estimate_frame(df, columns=line)
    np.testing.assert_allclose(out[["wx", "wy", "wz"]].to_numpy()[50:], np.tile(OMEGA, (250, 1)), atol=1e-6)


# ------------------------------------------------------------------------------------- Universal Robots RTDE

_JOINTS = [f"{field}_{i}" for field in ("target_q", "actual_q") for i in range(6)]


def _ur_recording(path, delimiter=" ", poses=("actual_TCP_pose", "target_TCP_pose"), n=1000):
    """A recording as the RTDE recorder writes it (Python's csv writer, one column per vector component), the
    tool's pose in the base frame turning at ω in the tool's axes; the other fields hold noise."""
    s, R = _truth(n)
    rng = np.random.default_rng(5)
    names = ["timestamp", *_JOINTS]
    for pose in poses:
        names += [f"{pose}_{i}" for i in range(6)]
    names.append("robot_mode")
    with open(path, "w", newline="") as f:
        writer = csv.writer(f, delimiter=delimiter)
        writer.writerow(names)
        for k in range(n):
            row = [1843.272 + s[k], *rng.normal(size=len(_JOINTS))]
            for _ in poses:
                row += [*rng.normal(size=3), *R[k].as_rotvec()]
            writer.writerow([*row, 7])
    return path


@pytest.mark.parametrize("delimiter", [" ", ","])
def test_a_universal_robots_recording_gives_the_tools_rate_in_its_own_axes(tmp_path, capsys, delimiter):
    path = _ur_recording(tmp_path / "robot_data.csv", delimiter)
    table, printed = estimate_file(path, tmp_path, capsys)
    assert "Universal Robots RTDE recording" in printed and "actual_TCP_pose_3" in printed
    w = table[:, 1:]
    np.testing.assert_allclose(w[50:], np.tile(OMEGA, (len(w) - 50, 1)), atol=1e-6)
    np.testing.assert_allclose(table[:2, 0], [1843.272, 1843.28], atol=1e-9)


def test_a_recording_with_only_the_commanded_pose_is_refused_with_the_line_that_reads_it(tmp_path, capsys):
    path = _ur_recording(tmp_path / "robot_data.csv", poses=("target_TCP_pose",), n=300)
    with pytest.raises(LogFormatError, match="controller commanded") as refused:
        read_log(path)
    line = str(refused.value).split("to read it anyway: ")[1]
    assert line.startswith("--columns t=timestamp,rotvec_x=target_TCP_pose_3")
    table, printed = estimate_file(path, tmp_path, capsys, *line.split())
    assert "not as a Universal Robots RTDE recording" in printed
    np.testing.assert_allclose(table[:, 1:][50:], np.tile(OMEGA, (250, 1)),
                               atol=1e-6)  # fmt: skip


def test_a_pose_recording_of_ones_own_with_another_time_column(tmp_path, capsys):
    s, R = _truth(400)
    pose = {f"actual_TCP_pose_{i}": np.zeros(s.size) for i in range(3)}
    pose.update({f"actual_TCP_pose_{i + 3}": R.as_rotvec()[:, i] for i in range(3)})
    pd.DataFrame({"Time (ms)": 1000 * s, **pose}).to_csv(tmp_path / "mine.csv", index=False)
    table, printed = estimate_file(tmp_path / "mine.csv", tmp_path, capsys)
    assert "time from 'time (ms)'" in printed
    np.testing.assert_allclose(table[50:, 1:], np.tile(OMEGA, (350, 1)), atol=1e-6)
    pd.DataFrame(pose).to_csv(tmp_path / "timeless.csv", index=False)  # as some recordings are, at 125 Hz
    with pytest.raises(
        LogFormatError, match=r"without a time column .*--columns t=NAME,rotvec_x=actual_TCP_pose_3"
    ) as no:
        read_log(tmp_path / "timeless.csv")
    timeless = str(no.value).split("give the rate it was recorded at: ")[1].split(" (record.py")[0].replace("HZ", "125")
    table, _ = estimate_file(tmp_path / "timeless.csv", tmp_path, capsys, *timeless.split())
    np.testing.assert_allclose(table[50:, 1:], np.tile(OMEGA, (350, 1)), atol=1e-6)


def test_rotation_is_refused_for_a_universal_robots_recording(tmp_path, capsys):
    path = _ur_recording(tmp_path / "robot_data.csv", n=100)
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), "--rotation", "inertial-to-body", "--no-progress"]) == 2
    assert "leave --rotation out" in capsys.readouterr().err and not out.exists()
