"""``omegahat calibrate`` and :mod:`omegahat.calibration`: simulated offsets, rotations, biases and scales recovered
within the printed uncertainties, and bad inputs named.

The simulated logs are ``calibration_logs``'s: a body turning by three Euler angles with a closed-form rate, and a
gyroscope on its own clock and rate.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import spacecraft
from calibration_logs import euler_motion, simulated, z_scores
from omegahat.calibration import Calibration, calibrate
from omegahat.cli import main
from omegahat.cli.calibrate import table
from omegahat.io import LogFormatError
from omegahat.io.gyrolog import read_gyro


def test_euler_motion_rate_is_the_derivative_of_its_attitude():
    R, omega = euler_motion(3)
    t, h = np.linspace(0.0, 5.0, 501), 1e-5
    S = np.einsum("nji,njk->nik", R(t), (R(t + h) - R(t - h)) / (2 * h))  # Rᵀ Ṙ = ω×
    np.testing.assert_allclose(np.stack([S[:, 2, 1], S[:, 0, 2], S[:, 1, 0]], -1), omega(t), atol=1e-6)


@pytest.mark.parametrize("mode", ["none", "axes", "matrix"])
def test_recovers_offset_rotation_bias_and_scale_within_the_printed_uncertainties(mode):
    z = []
    for seed in range(8):
        data, truth = simulated(seed, mode)
        cal = calibrate(*data, scale=mode)
        z += z_scores(cal, truth)
        assert abs(cal.offset - truth["delta"]) < 1e-4  # the 100 Hz attitude's period is 1e-2 s
    z = np.array(z)
    # Coverage: the standard deviations are neither far too small (z² ≫ 1) nor useless (z² ≪ 1).
    assert 0.3 < np.mean(z**2) < 2.0, np.mean(z**2)
    assert np.mean(np.abs(z) < 3) >= 0.97


def test_apply_maps_the_gyro_onto_the_body_rate_and_the_attitude_clock():
    data, truth = simulated(5, "axes", gyro_noise=0.0)
    cal = calibrate(*data, scale="axes")
    t, w = cal.apply(data[2], data[3])
    inside = (t > 2) & (t < 29)
    np.testing.assert_allclose(w[inside], truth["omega"](t[inside]), atol=2e-3 * np.abs(w).max())


def test_a_permuted_mirrored_axis_set_is_found_by_the_matrix():
    rng = np.random.default_rng(2)
    R, omega = euler_motion(2)
    ta = np.arange(0, 30, 0.01)
    tg = np.arange(0, 31, 0.0095) + 0.04
    P = np.array([[0, 0, 1], [1, 0, 0], [0, 1, 0]], float)  # gx = +bz, gy = +bx, gz = +by (det +1)
    A = 60.0 * P * np.array([[1.0], [1.0], [-1.0]])  # and the third axis mirrored: det < 0
    g = omega(tg - 0.04) @ A.T + np.array([370.0, 373.0, 375.0]) + rng.normal(0, 1.0, (tg.size, 3))
    cal = calibrate(ta, R(ta), tg, np.round(g), scale="matrix")
    assert cal.axis_map() == "gx = +bz, gy = +bx, gz = -by"
    assert any("mirrors" in n for n in cal.notes)
    np.testing.assert_allclose(cal.matrix, A, atol=0.6)
    np.testing.assert_allclose(cal.bias, [370, 373, 375], atol=0.5)
    assert abs(cal.offset - 0.04) < 1e-3


def test_bad_inputs_are_named():
    (ta, Ra, tg, g), _ = simulated(0)
    with pytest.raises(ValueError, match=r"do not overlap in time at any clock offset within 0 ± 2 s"):
        calibrate(ta, Ra, tg + 100.0, g, max_offset=2.0)
    with pytest.raises(ValueError, match=r"do not overlap in time at any clock offset by enough samples"):
        calibrate(ta, Ra, tg[:40] + 100.0, g[:40])
    with pytest.raises(ValueError, match="too few samples to calibrate: 5 valid"):
        calibrate(ta[:5], Ra[:5], tg, g)
    with pytest.raises(ValueError, match=r"too few samples to calibrate: 300 valid attitude samples"):
        calibrate(ta[:300], Ra[:300], tg, g)
    with pytest.raises(ValueError, match=r"too few samples to calibrate: \d+ attitude samples overlap the gyro"):
        calibrate(ta, Ra, tg[:1000], g[:1000])
    with pytest.raises(ValueError, match="scale must be one of none, axes, matrix"):
        calibrate(ta, Ra, tg, g, scale="diagonal")
    with pytest.raises(ValueError, match=r"gyro must have shape \(\d+, 3\)"):
        calibrate(ta, Ra, tg, g[:, :2])
    with pytest.raises(ValueError, match="cutoff_hz must be in"):
        calibrate(ta, Ra, tg, g, cutoff_hz=60.0)
    still = np.repeat(np.eye(3)[None], ta.size, axis=0)
    with pytest.raises(ValueError, match="the body hardly rotates"):
        calibrate(ta, still, tg, 0.01 + 0 * g)


def test_a_turn_about_one_axis_gives_what_it_identifies_within_the_printed_uncertainties():
    """``euler_motion(single_axis=True)`` turns about the body's x axis only: the offset, the bias and the axis's
    direction in gyro axes are identified (the truth's ``R_c e_x``), the turn about it is not. The offset's and the
    bias's errors over their printed standard deviations have the coverage of the general case. The axis's (in the
    plane its covariance spans) are cautious: mean square 0.29 over 16 logs, 1.1 with 1e-5 rad of attitude noise
    instead of 1e-3. The attitude noise's rate is blue, and its product with the body rate sums over a batch of
    (C4) to its ends' values, not to a random walk, so the batch means overstate its long-run variance. The rotation
    is the least one taking the found body axis (e_x) onto the found gyro axis; the gyroscope applied gives the
    body rate to its own noise."""
    z, z_axis = [], []
    e_x = np.array([1.0, 0.0, 0.0])
    for seed in range(16):
        data, truth = simulated(seed, single_axis=True)
        cal = calibrate(*data)
        u_true = truth["Rc"] @ e_x
        assert cal.free_axis is not None and abs(np.linalg.norm(cal.free_axis) - 1.0) < 1e-12
        body_axis = cal.rotation.T @ cal.free_axis  # the body's axis as the data show it: e_x
        np.testing.assert_allclose(body_axis, e_x, atol=1e-3)
        phi = Rotation.from_matrix(cal.rotation).as_rotvec()  # the least rotation turns about body_axis × axis
        assert abs(phi @ body_axis) < 1e-9 and abs(phi @ cal.free_axis) < 1e-9
        error = np.cross(cal.free_axis, u_true)  # the small turn taking the found axis onto the truth's
        values, vectors = np.linalg.eigh(cal.covariance[1:4, 1:4])
        assert values[0] < 1e-12 * values[2] and np.allclose(np.abs(vectors[:, 0] @ cal.free_axis), 1.0)
        z_axis += list(vectors[:, 1:].T @ error / np.sqrt(values[1:]))
        z += [(cal.offset - truth["delta"]) / cal.offset_std, *((cal.bias - truth["b"]) / cal.bias_std)]
        t, w = cal.apply(data[2], data[3])
        inside = (t > 2) & (t < 29)
        rms = np.sqrt(np.mean(np.sum((w[inside] - truth["omega"](t[inside])) ** 2, axis=1)))
        assert rms < 1.1 * 0.01 * np.sqrt(3), rms  # the gyroscope's own noise (0.01 rad/s per axis)
        assert any("turned about one axis only" in n and "not identified" in n for n in cal.notes)
    z, z_axis = np.array(z), np.array(z_axis)
    assert 0.3 < np.mean(z**2) < 2.0, np.mean(z**2)
    assert np.mean(np.abs(z) < 3) >= 0.97
    assert 0.1 < np.mean(z_axis**2) < 1.0 and np.all(np.abs(z_axis) < 3), z_axis  # cautious, not useless


def test_a_turn_that_repeats_itself_is_named_and_a_narrower_search_finds_the_offset():
    """A shaft turning back and forth, ``θ = 1.5 (1 − cos(2π t / 2.4 s))`` rad, on one clock: shifted by half a
    period with its axis reversed the gyroscope fits as well as unshifted, and the norms the coarse search correlates
    repeat every half period. The search over ±2 s names another offset in a note; over ±0.1 s it finds the true one
    (zero) and has nothing to name."""
    ta = np.arange(0.0, 60.0, 0.01)
    theta = 1.5 * (1.0 - np.cos(2.0 * np.pi * ta / 2.4))
    R = Rotation.from_rotvec(np.outer(theta, [0.0, 0.0, 1.0])).as_matrix()
    Rc = Rotation.from_rotvec([0.3, -1.2, 0.4]).as_matrix()
    rate = 1.5 * 2.0 * np.pi / 2.4 * np.sin(2.0 * np.pi * ta / 2.4)
    g = np.outer(rate, Rc[:, 2]) + np.array([0.01, -0.02, 0.03])
    g += np.random.default_rng(3).normal(0.0, 0.005, g.shape)
    wide = calibrate(ta, R, ta, g)
    assert any("the motion repeats itself" in n and "--max-offset" in n for n in wide.notes), wide.notes
    narrow = calibrate(ta, R, ta, g, max_offset=0.1)
    assert not any("repeats itself" in n for n in narrow.notes) and abs(narrow.offset) < 1e-3
    assert abs(narrow.free_axis @ Rc[:, 2] - 1.0) < 1e-6


def test_an_offset_at_the_edge_of_the_search_is_named():
    data, truth = simulated(3)
    assert abs(truth["delta"]) > 0.1  # the search below cannot reach it (-0.187 s)
    narrow = calibrate(*data, max_offset=0.05)
    assert any("at the edge of the search" in n and "--max-offset" in n for n in narrow.notes), narrow.notes
    assert not any("edge of the search" in n for n in calibrate(*data).notes)


def test_a_calibration_file_without_free_axis_reads_as_a_whole_rotation(tmp_path):
    data, _ = simulated(4)
    cal = calibrate(*data)
    assert cal.free_axis is None and not any("one axis" in n for n in cal.notes)
    path = tmp_path / "cal.json"
    cal.save(path)
    d = json.loads(path.read_text())
    assert d["free_axis"] is None
    del d["free_axis"]  # as written before the field existed
    path.write_text(json.dumps(d))
    old = Calibration.load(path)
    assert old.free_axis is None
    np.testing.assert_array_equal(old.rotation, cal.rotation)
    (tmp_path / "one.json").write_text("{}")
    with pytest.raises(ValueError, match="not a calibration written by omegahat calibrate"):
        Calibration.load(tmp_path / "one.json")


def test_a_rotation_about_one_axis_cannot_identify_scale_factors_either():
    (ta, Ra, tg, g), _ = simulated(1, single_axis=True)
    with pytest.raises(ValueError, match=r"cannot identify scale factors.*three independent axes"):
        calibrate(ta, Ra, tg, g, scale="axes")


def _write_logs(tmp_path, data):
    ta, Ra, tg, g = data
    q = Rotation.from_matrix(Ra).as_quat()  # x, y, z, w
    att = tmp_path / "mocap.csv"
    np.savetxt(att, np.column_stack([ta, q[:, 3], q[:, :3]]), delimiter=",", header="t,qw,qx,qy,qz", comments="")
    gyro = tmp_path / "imu.csv"
    np.savetxt(gyro, np.column_stack([tg, np.degrees(g)]), delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.10g")
    return att, gyro


def test_command_prints_writes_json_and_plots(tmp_path, capsys):
    data, truth = simulated(4, "axes")
    att, gyro = _write_logs(tmp_path, data)
    out, png = tmp_path / "cal.json", tmp_path / "res.png"
    code = main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", "--scale", "axes", "-o", str(out),
                 "--plot", str(png)])  # fmt: skip
    text = capsys.readouterr().out
    assert code == 0
    assert "clock offset" in text and "scale" in text and f"wrote {out}" in text
    d = json.loads(out.read_text())
    assert abs(d["offset"] - truth["delta"]) < 5 * d["offset_std"] + 1e-6
    np.testing.assert_allclose(d["scale"], truth["s"], atol=5 * max(d["scale_std"]))
    loaded = Calibration.load(out)
    np.testing.assert_array_equal(loaded.matrix, np.array(d["matrix"]))
    assert table(loaded) == table(Calibration.load(out)) and loaded.scale_std is not None
    (tmp_path / "bad.json").write_text("{}")
    with pytest.raises(ValueError, match="not a calibration written by omegahat calibrate"):
        Calibration.load(tmp_path / "bad.json")
    assert png.stat().st_size > 10_000


def test_command_on_a_turn_about_one_axis_says_what_it_cannot_identify(tmp_path, capsys):
    data, truth = simulated(6, single_axis=True)
    att, gyro = _write_logs(tmp_path, data)
    out = tmp_path / "cal.json"
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", "-o", str(out)]) == 0
    text = capsys.readouterr().out
    assert "is not identified (one axis turned: note)" in text and "note: the body turned about one axis only" in text
    loaded = Calibration.load(out)
    assert loaded.free_axis is not None
    assert abs(abs(loaded.free_axis @ truth["Rc"][:, 0]) - 1.0) < 1e-6  # the gyro's image of the body's x axis
    assert "not identified" in table(loaded)


def test_command_messages(tmp_path, capsys):
    data, _ = simulated(4)
    att, gyro = _write_logs(tmp_path, data)
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "raw"]) == 2
    assert "--gyro-unit raw needs scale factors" in capsys.readouterr().err
    assert main(["calibrate", str(att), str(gyro), "--gyro-columns", "wx,wy,wz"]) == 2
    assert (
        "no column 'wx' (found: t, gx, gy, gz); name the gyroscope log's rate with --gyro-columns"
        in capsys.readouterr().err
    )
    assert main(["calibrate", str(att), str(tmp_path / "none.csv")]) == 2
    assert "No such file" in capsys.readouterr().err
    assert main(["calibrate", str(att), str(gyro), "--offset", "0.2"]) == 2  # a guess without its bound does nothing
    assert "a guess of the clock offset (0.2 s) centres a bounded search: give its bound too" in capsys.readouterr().err
    garbage = tmp_path / "garbage.csv"
    garbage.write_text("not,a,gyro,log\nat,all,,\n")
    assert main(["calibrate", str(att), str(garbage), "--offset", "0.2"]) == 2  # said before either log is read
    assert "a guess of the clock offset (0.2 s) centres a bounded search" in capsys.readouterr().err
    assert main(["calibrate", str(att), str(gyro), "--offset", "0.2", "--max-offset", "0.5"]) == 0
    lines = gyro.read_text().splitlines()
    lines[7] = lines[7].split(",")[0] + ",abc,1,2"
    gyro.write_text("\n".join(lines) + "\n")
    with pytest.raises(LogFormatError, match="line 8, column gx: 'abc' is not a number"):
        read_gyro(gyro)


def test_the_outputs_are_checked_before_the_fit_and_never_replace_an_input(tmp_path, capsys):
    """``-o`` or ``--plot`` naming an input log, each other, a missing folder or a type Matplotlib cannot write is
    refused before any log is read (nothing printed on standard output), and the inputs are left as they were."""
    data, _ = simulated(4)
    att, gyro = _write_logs(tmp_path, data)
    before = {p: p.read_bytes() for p in (att, gyro)}
    out, png = tmp_path / "cal.json", tmp_path / "res.png"
    for extra, said in (
        (["-o", str(gyro)], f"the output {gyro} is the input {gyro}; write the calibration to another file"),
        (["-o", str(att)], f"the output {att} is the input {att}"),
        (["--plot", str(att)], "write the plot to another file"),
        (["-o", str(out), "--plot", str(out)], "-o and --plot name the same file"),
        (["-o", str(tmp_path / "no" / "cal.json")], "does not exist; create it first"),
        (["-o", str(out), "--plot", str(tmp_path / "res.csv")], "not an image type Matplotlib writes; use .eps"),
    ):
        assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", *extra]) == 2, extra
        captured = capsys.readouterr()
        assert said in captured.err and captured.out == "", (extra, captured.err)
    assert {p: p.read_bytes() for p in (att, gyro)} == before and not out.exists()
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", "-o", str(out), "--plot", str(png)]) == 0
    assert Calibration.load(out).offset == json.loads(out.read_text())["offset"]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cal.json", "imu.csv", "mocap.csv", "res.png"]  # no .part


@pytest.mark.parametrize("delimiter", [",", " "])
def test_a_gyroscope_row_of_another_width_or_with_a_carriage_return_inside_is_refused(tmp_path, delimiter):
    # both were read before: the extra field ignored, and a CR splitting a blank-separated number shifted the
    # columns after it (0.2\r5 read as gy = 0.2, gz = 5)
    rows = [delimiter.join(("t", "gx", "gy", "gz"))] + [delimiter.join(("0.01", "0.1", "0.2", "0.3"))] * 4
    path = tmp_path / "gyro.txt"
    wide = rows.copy()
    wide[2] += delimiter + "0.9"
    path.write_text("\n".join(wide) + "\n")
    with pytest.raises(LogFormatError, match=r"gyro\.txt, line 3: 5 fields, but the header \(line 1\) names 4"):
        read_gyro(path)
    damaged = rows.copy()
    damaged[3] = damaged[3].replace("0.3", "0.\r3")
    path.write_text("\n".join(damaged) + "\n")
    with pytest.raises(LogFormatError, match=r"gyro\.txt, line 4: a carriage return \(CR\) inside the line"):
        read_gyro(path)
    path.write_text("\r\n".join(rows) + "\r\n")  # CRLF line ends are line ends
    assert read_gyro(path)[1].shape == (4, 3)


def test_read_gyro_npz(tmp_path):
    t = np.arange(5.0)
    np.savez(tmp_path / "g.npz", t=t, g=np.ones((5, 3)))
    tt, g = read_gyro(tmp_path / "g.npz")[:2]
    np.testing.assert_array_equal(tt, t)
    assert g.shape == (5, 3)
    np.savez(tmp_path / "h.npz", t=t, g=np.ones((4, 3)))
    with pytest.raises(LogFormatError, match=r"the gyro must be \(5, 3\)"):
        read_gyro(tmp_path / "h.npz")


@pytest.mark.parametrize(
    "header",
    ["time,wx,wy,wz,t", "T,Gyro_X,Gyro_Y,Gyro_Z", "t,angular_velocity_x,angular_velocity_y,angular_velocity_z"],
)
def test_gyro_columns_by_their_usual_names(tmp_path, header):
    """A header with one group of the usual rate names is read without --gyro-columns, in its own column order."""
    names = header.split(",")
    rows = np.arange(12.0).reshape(4, 3)
    table_ = {names.index("t") if "t" in names else names.index("T"): np.arange(4.0)}
    rate = [n for n in names if n.lower() not in ("t", "time")]
    for i, n in enumerate(rate):
        table_[names.index(n)] = rows[:, i]
    path = tmp_path / "imu.csv"
    np.savetxt(path, np.column_stack([table_.get(j, -np.ones(4)) for j in range(len(names))]), delimiter=",",
               header=header, comments="")  # fmt: skip
    t, g = read_gyro(path)[:2]
    np.testing.assert_array_equal(t, np.arange(4.0))
    np.testing.assert_array_equal(g, rows)
    np.savez(tmp_path / "imu.npz", t=np.arange(4.0), **{n: rows[:, i] for i, n in enumerate(rate)})
    np.testing.assert_array_equal(read_gyro(tmp_path / "imu.npz")[1], rows)


def test_gyro_columns_that_are_not_one_usual_group_are_named(tmp_path):
    """Two usual groups: refused, both named. None, but three columns ending in x, y, z: the line to pass."""
    both = tmp_path / "both.csv"
    both.write_text("t,gx,gy,gz,wx,wy,wz\n0,1,2,3,4,5,6\n")
    with pytest.raises(LogFormatError, match=r"several gyroscope columns \(gx,gy,gz and wx,wy,wz\)"):
        read_gyro(both)
    assert read_gyro(both, ("wx", "wy", "wz"))[1].tolist() == [[4.0, 5.0, 6.0]]
    other = tmp_path / "other.csv"
    other.write_text("t,acc_x,acc_y,angvel_x,angvel_y,angvel_z\n0,1,2,3,4,5\n")
    with pytest.raises(
        LogFormatError, match=r"no gyroscope columns .*perhaps --gyro-columns angvel_x,angvel_y,angvel_z"
    ):
        read_gyro(other)


def test_a_gyro_in_the_other_unit_is_named(tmp_path, capsys):
    """A gyroscope written in deg/s and read as rad/s (and the reverse) leaves most of its rate unexplained: a note
    names the unit to pass; read in its unit, no such note."""
    data, _ = simulated(4)
    att, gyro = _write_logs(tmp_path, data)  # deg/s
    assert main(["calibrate", str(att), str(gyro)]) == 0
    out = capsys.readouterr().out
    assert "times the attitude's rate, degrees per second given as radians; check its unit" in out
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s"]) == 0
    assert "residual is" not in capsys.readouterr().out
    _, _, tg, g = data
    np.savetxt(gyro, np.column_stack([tg, g]), delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.10g")
    out_json = tmp_path / "cal.json"
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", "-o", str(out_json)]) == 0
    assert "times the attitude's rate, radians given as degrees; check its unit" in capsys.readouterr().out
    assert any("radians given as degrees" in n for n in Calibration.load(out_json).notes)


def test_a_gyro_as_instruments_write_it_gives_the_calibration_of_the_plain_csv(tmp_path, capsys):
    """The gyroscope of one simulated log written four ways: the plain CSV; RepoIMU's layout (``;``, a group title
    over X, Y, Z in a two-row header, other columns around); no header, blank-separated (columns by position); and
    no usable time (``--gyro-rate``, the rows regular). Each gives the plain CSV's rows, and through the command the
    same calibration; the attitude in RepoIMU's layout too (``--header-rows 2 --columns``)."""
    data, truth = simulated(6)
    att, gyro = _write_logs(tmp_path, data)
    ta, Ra, tg, g = data
    deg = np.degrees(g)
    repo = tmp_path / "repo.csv"
    rows = [f"{t:.10g};1;0;0;0;{x:.10g};{y:.10g};{z:.10g};9.81" for t, (x, y, z) in zip(tg, deg, strict=True)]
    repo.write_text("Time;Vicon Orientation;;;;IMU Gyroscope;;;IMU Acceleration\ns;W;X;Y;Z;X;Y;Z;X\n" + "\n".join(rows))
    bare = tmp_path / "gyroscope.txt"
    np.savetxt(bare, np.column_stack([np.arange(tg.size), tg, deg]), fmt="%.10g")  # a sample counter first
    plain = read_gyro(gyro)
    from_repo = read_gyro(repo, header_rows=2, time_column="Time s")
    assert from_repo.names == ("time s", "imu gyroscope x", "imu gyroscope y", "imu gyroscope z")
    from_bare = read_gyro(bare, ("3", "4", "5"), "2", header_rows=0)
    for other in (from_repo, from_bare):
        np.testing.assert_array_equal(other.t, plain.t)
        np.testing.assert_array_equal(other.g, plain.g)
    np.testing.assert_array_equal(read_gyro(bare, ("3", "4", "5"), None, header_rows=0).t, np.arange(tg.size))
    with pytest.raises(
        LogFormatError, match=r"numbers where the header should name the columns .*--gyro-header-rows 0"
    ):
        read_gyro(bare)

    att_repo = tmp_path / "att_repo.csv"
    q = Rotation.from_matrix(Ra).as_quat()
    lines = [";".join(repr(float(v)) for v in (t, w, x, y, z)) for t, (x, y, z, w) in zip(ta, q, strict=True)]
    att_repo.write_text("Time;Vicon Orientation;;;\ns;W;X;Y;Z\n" + "\n".join(lines) + "\n")
    columns = "t=Time s,qw=Vicon Orientation W,qx=Vicon Orientation X,qy=Vicon Orientation Y,qz=Vicon Orientation Z"

    def table_of(*words):
        assert main(["calibrate", *words, "--gyro-unit", "deg/s"]) == 0
        out = capsys.readouterr().out
        return out[out.index("clock offset") :]

    reference = table_of(str(att), str(gyro))
    assert table_of(str(att_repo), str(repo), "--header-rows", "2", "--columns", columns, "--gyro-header-rows", "2",
                    "--gyro-time-column", "time s") == reference  # fmt: skip
    assert table_of(str(att), str(bare), "--gyro-header-rows", "0", "--gyro-time-column", "2",
                    "--gyro-columns", "3,4,5") == reference  # fmt: skip
    # the gyro's own rows at its nominal rate: its clock's start is then the offset's to find
    saved = _saved(tmp_path, att, bare, "--gyro-rate", "200", "--gyro-columns", "3,4,5", "--gyro-header-rows", "0")
    z = z_scores(Calibration.load(saved), {**truth, "delta": truth["delta"] - tg[0]})
    assert max(abs(v) for v in z) < 5, z


def _saved(tmp_path, att, gyro, *words):
    out = tmp_path / "cal.json"
    assert main(["calibrate", str(att), str(gyro), "--gyro-unit", "deg/s", "-o", str(out), *words]) == 0
    return out


def test_command_reads_euler_attitudes_and_a_gyro_time_in_the_unit_its_name_states(tmp_path, capsys):
    """The attitude as roll, pitch, yaw (degrees, ZYX) and the gyro's time in milliseconds (``time_ms``) give the
    offset of the quaternion log and the gyro in seconds."""
    data, truth = simulated(4)
    ta, Ra, tg, g = data
    att, gyro = _write_logs(tmp_path, data)
    ypr = Rotation.from_matrix(Ra).as_euler("ZYX", degrees=True)
    euler = tmp_path / "euler.csv"
    np.savetxt(euler, np.column_stack([ta, ypr[:, ::-1]]), delimiter=",", header="t,roll,pitch,yaw", comments="",
               fmt="%.17g")  # fmt: skip
    ms = tmp_path / "imu_ms.csv"
    np.savetxt(ms, np.column_stack([tg * 1000, np.degrees(g)]), delimiter=",", header="time_ms,gx,gy,gz", comments="",
               fmt="%.13g")  # fmt: skip
    offsets = []
    for a, gy, extra in (
        (att, gyro, []),
        (euler, ms, ["--euler", "ZYX", "--angle-unit", "deg", "--gyro-time-column", "time_ms"]),
    ):
        out = tmp_path / f"{a.stem}.json"
        assert main(["calibrate", str(a), str(gy), "--gyro-unit", "deg/s", "-o", str(out), *extra]) == 0
        offsets.append(json.loads(out.read_text())["offset"])
    text = capsys.readouterr().out
    assert "time unit: ms, as the time column's name says ('time_ms'; converted to s)" in text
    assert abs(offsets[1] - offsets[0]) < 1e-7
    assert abs(offsets[1] - truth["delta"]) < 1e-3


_DATES_START = np.datetime64("2026-01-01T00:00:00", "ns")


def _dates(t) -> list[str]:
    """ISO 8601 texts of the times ``t`` (s after 2026-01-01T00:00:00, to the nanosecond), without a zone."""
    return [str(_DATES_START + np.timedelta64(round(x * 1e9), "ns")) for x in t]


def _dated_gyro(tmp_path, tg, g):
    """The gyro log stamped with UTC dates (``Z``), rates in deg/s."""
    path = tmp_path / "imu_dates.csv"
    rows = [f"{d}Z,{a!r},{b!r},{c!r}" for d, (a, b, c) in zip(_dates(tg), np.degrees(g).tolist(), strict=True)]
    path.write_text("time,gx,gy,gz\n" + "\n".join(rows) + "\n")
    return path


def _offsets(tmp_path, pairs) -> list[float]:
    """The offset ``omegahat calibrate`` finds for each (attitude log, gyro log in deg/s)."""
    offsets = []
    for a, gy in pairs:
        out = tmp_path / f"{a.stem}.json"
        assert main(["calibrate", str(a), str(gy), "--gyro-unit", "deg/s", "-o", str(out)]) == 0
        offsets.append(json.loads(out.read_text())["offset"])
    return offsets


def test_command_reads_iso_dates_in_both_logs(tmp_path, capsys):
    """Both logs stamped with ISO 8601 dates (the attitude's without a zone, as pandas writes them; the gyro's in
    UTC with ``Z``) give the offset of the logs stamped in seconds: both are read as seconds since 1970 UTC."""
    data, truth = simulated(4)
    ta, Ra, tg, g = data
    att, gyro = _write_logs(tmp_path, data)
    q = Rotation.from_matrix(Ra).as_quat()
    dated_att = tmp_path / "mocap_dates.csv"
    rows = [
        f"{d.replace('T', ' ')},{w!r},{x!r},{y!r},{z!r}" for d, (x, y, z, w) in zip(_dates(ta), q.tolist(), strict=True)
    ]
    dated_att.write_text("Timestamp,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    dated_gyro = _dated_gyro(tmp_path, tg, g)
    offsets = _offsets(tmp_path, ((att, gyro), (dated_att, dated_gyro)))
    text = capsys.readouterr().out
    assert "time 'time'" in text and "dates read as seconds since 1970-01-01 UTC" in text
    # the gyro's stamps name their zone (Z), the attitude's do not, and the notes say which
    assert "(their time zone converted to UTC" in text and "(no time zone given, so read as if UTC" in text
    assert abs(offsets[1] - offsets[0]) < 1e-6
    assert abs(offsets[1] - truth["delta"]) < 1e-3
    assert main(["calibrate", str(dated_att), str(dated_gyro), "--gyro-time-unit", "ms"]) == 2
    assert "its times carry their own unit (dates read as seconds since 1970-01-01 UTC" in capsys.readouterr().err


def test_a_star_trackers_aem_against_a_gyro_log_stamped_in_utc(tmp_path, capsys):
    """A spacecraft's gyroscope calibrated against its attitude ephemeris: the attitude as a CCSDS AEM (UTC epochs
    from 2026-01-01, :func:`spacecraft.write_aem`) and the gyro log stamped with UTC dates give the offset of the
    same logs stamped in seconds."""
    data, truth = simulated(4)
    ta, Ra, tg, g = data
    att, gyro = _write_logs(tmp_path, data)
    aem = spacecraft.write_aem(tmp_path / "st.aem", ta, Rotation.from_matrix(Ra))
    offsets = _offsets(tmp_path, ((att, gyro), (aem, _dated_gyro(tmp_path, tg, g))))
    assert "st.aem; times in UTC, as seconds since 1970-01-01T00:00:00 UTC" in capsys.readouterr().out
    assert abs(offsets[1] - offsets[0]) < 1e-6
    assert abs(offsets[1] - truth["delta"]) < 1e-3


def test_a_log_in_milliseconds_read_as_seconds_is_named_with_the_option_that_reads_it(tmp_path, capsys):
    """Times in ms read as s made the fit fail on an overlap or a sample count, naming neither log's unit; the
    command now says which log's spacing is implausible and the option that reads it, before the fit."""
    data, _ = simulated(4)
    att, gyro = _write_logs(tmp_path, data)
    lines = gyro.read_text().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    gyro_ms = tmp_path / "imu_ms.csv"
    gyro_ms.write_text("\n".join([lines[0]] + [",".join([repr(float(r[0]) * 1000.0), *r[1:]]) for r in rows]) + "\n")
    main(["calibrate", str(att), str(gyro_ms), "--gyro-unit", "deg/s"])
    out = capsys.readouterr().out
    assert (
        "warning: the gyroscope's rows are" in out
        and "if the times are in ms, pass --gyro-time-unit ms (200 Hz)" in out
    )
    assert main(["calibrate", str(att), str(gyro_ms), "--gyro-unit", "deg/s", "--gyro-time-unit", "ms"]) == 0
    assert "warning" not in capsys.readouterr().out


def test_an_accelerometers_columns_are_not_offered_as_the_gyroscopes(tmp_path):
    for header, offered in (("t,ax,ay,az", False), ("t,acc_x,acc_y,acc_z", False), ("t,rate_x,rate_y,rate_z", True)):
        path = tmp_path / "g.csv"
        path.write_text(f"{header}\n0,1,2,3\n0.1,1,2,3\n")
        with pytest.raises(LogFormatError) as caught:
            read_gyro(path)
        assert ("(perhaps --gyro-columns" in str(caught.value)) == offered, header
