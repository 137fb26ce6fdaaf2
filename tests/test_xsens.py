"""Xsens MT Manager exports (omegahat.io.xsens).

The exports are written here as MT Manager writes them (a ``//`` preamble, then names and rows separated by tabs,
commas, semicolons or single spaces; empty fields where a value is not exported), for a body turning at a known rate
in its own axes, ``R(t) = R0 exp(S(ω) t)``, with SciPy's conversions, not omegahat's: the quaternion scalar first,
``Mat[i][j]`` the element of row i and column j (written column by column, as MT Manager orders them), Roll, Pitch,
Yaw in degrees of the sequence R = Rz(yaw) Ry(pitch) Rx(roll). A reader that transposed R, or took another
sequence, would get another rate than ω in the sensor's axes.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibration_logs import simulated, z_scores
from omegahat.calibration import Calibration
from omegahat.cli import main
from omegahat.io import read_log
from omegahat.io.gyrolog import read_gyro
from omegahat.io.xsens import TICK, is_xsens, unwrapped
from recording_files import estimate_file

OMEGA = np.array([0.5, -0.8, 0.6])  # rad/s, sensor axes
R0 = Rotation.from_rotvec([0.4, 2.2, -1.0])
OLD_PREAMBLE = "// Start Time: Unknown\n// Update Rate: {rate}Hz\n// Filter Profile: human (46.1)\n"
NEW_PREAMBLE = (
    "// General information: \n//  MT Manager version: 2022.2.0 \n// Device settings: \n"
    "//  Option Flags: Orientation Smoother Disabled, AHS Disabled, ICC Disabled\n// Coordinate system: ENU\n"
)
MATRIX_NAMES = [f"Mat[{i}][{j}]" for j in (1, 2, 3) for i in (1, 2, 3)]  # MT Manager's order: column by column


def _export(path, counter, *, rate=100.0, attitude="quat", sep="\t", preamble=OLD_PREAMBLE, fine=None, drop=()):
    """An MT Manager export of the body turning at OMEGA: one row per packet ``counter`` (wrapping at 2**16), times
    ``counter / rate`` (unwrapped) or SampleTimeFine ticks ``fine``; rows ``drop`` left out (lost packets)."""
    counts = np.asarray(counter, dtype=np.int64)
    s = (counts - counts[0]) / rate
    R = R0 * Rotation.from_rotvec(np.outer(s, OMEGA))
    names = ["PacketCounter", "SampleTimeFine", "Acc_X", "Acc_Y", "Acc_Z", "Gyr_X", "Gyr_Y", "Gyr_Z"]
    if attitude == "quat":
        names += ["Quat_q0", "Quat_q1", "Quat_q2", "Quat_q3"]
        q = R.as_quat()
        values = np.column_stack([q[:, 3], q[:, :3]])
    elif attitude == "matrix":
        names += MATRIX_NAMES
        m = R.as_matrix()
        values = np.column_stack([m[:, i - 1, j - 1] for j in (1, 2, 3) for i in (1, 2, 3)])
    else:
        names += ["Roll", "Pitch", "Yaw"]
        values = R.as_euler("ZYX", degrees=True)[:, ::-1]  # yaw, pitch, roll → roll, pitch, yaw
    lines = [sep.join(names)]
    for k, c in enumerate(counts % 2**16):
        if k in drop:
            continue
        time = "" if fine is None else str(int(fine[k]) % 2**32)
        fields = [f"{c:05d}", time, "0.1", "0.2", "9.8", *(repr(float(w)) for w in OMEGA)]
        lines.append(sep.join(fields + [repr(float(v)) for v in values[k]]))
    path.write_text(preamble.format(rate=rate) + "\n".join(lines) + "\n")
    return path, s, R


@pytest.mark.parametrize("attitude", ["quat", "matrix", "euler"])
def test_each_attitude_of_an_export_is_the_sensors_orientation(tmp_path, attitude):
    path, s, R = _export(tmp_path / "mt.txt", 1000 + np.arange(300), attitude=attitude)
    log = read_log(path)
    assert log.format == "xsens"
    assert log.description.startswith("Xsens MT Manager export")
    np.testing.assert_allclose(log.t + log.t0, 10.0 + s, atol=1e-12)  # counter 1000 at 100 Hz
    got = Rotation.from_quat(log.data) if log.kind == "quaternion" else Rotation.from_matrix(log.data)
    assert np.max((got.inv() * R).magnitude()) < 1e-9
    steps = (got[:-1].inv() * got[1:]).as_rotvec()  # increments in the sensor's axes
    np.testing.assert_allclose(steps, np.tile(OMEGA * 0.01, (len(s) - 1, 1)), atol=1e-9)
    np.testing.assert_allclose(log.extra["reference_rate"], np.tile(OMEGA, (len(s), 1)), atol=0)


def test_the_estimate_is_the_rate_in_the_sensors_axes_and_is_compared_with_the_gyroscope(tmp_path, capsys):
    path, s, _ = _export(tmp_path / "mt.txt", 500 + np.arange(600), attitude="matrix")
    table, printed = estimate_file(path, tmp_path, capsys)
    np.testing.assert_allclose(table[:, 0], 5.0 + s, atol=1e-12)
    np.testing.assert_allclose(table[50:, 1:], np.tile(OMEGA, (len(s) - 50, 1)), atol=1e-6)
    assert "against the export's gyroscope (Gyr_X..Z, sensor axes" in printed


def test_the_packet_counter_wraps_and_dropped_packets_keep_their_places(tmp_path, capsys):
    counter = 65536 - 150 + np.arange(400)  # wraps at 2**16 after 150 packets
    drop = {20, 21, 22, 200}
    path, *_ = _export(tmp_path / "mt.txt", counter, rate=60.0, drop=drop)
    # small chunks, so that the wrap and the gaps fall across chunk boundaries
    log = read_log(path, chunk_bytes=4096)
    kept = np.array([k for k in range(len(counter)) if k not in drop])
    np.testing.assert_allclose(log.t + log.t0, counter[kept] / 60.0, rtol=0, atol=1e-9)
    assert any("4 packet(s) missing in 2 place(s)" in n for n in log.notes)
    table, _ = estimate_file(path, tmp_path, capsys)
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(kept) - 30, 1)), atol=1e-6)


def test_a_newer_export_without_its_rate_asks_for_it_and_reads_with_it(tmp_path, capsys):
    path, s, _ = _export(tmp_path / "mt.csv", 51400 + np.arange(200), sep=",", preamble=NEW_PREAMBLE, rate=40.0)
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "does not state its rate" in err and "--rate HZ" in err and "Traceback" not in err
    assert not (tmp_path / "o.csv").exists()
    table, _ = estimate_file(path, tmp_path, capsys, "--rate", "40")
    np.testing.assert_allclose(table[:, 0], 51400 / 40 + s, atol=1e-9)
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)


def test_sample_time_fine_gives_the_times_in_100_us_ticks_across_its_wrap(tmp_path, capsys):
    ticks = 2**32 - 50 * 100 + np.arange(300) * 100  # a 100 Hz device clock wrapping after 50 samples
    path, *_ = _export(tmp_path / "mt.txt", 7 + np.arange(300), sep=";", fine=ticks, attitude="euler")
    log = read_log(path, chunk_bytes=4096)
    np.testing.assert_allclose(log.t + log.t0, ticks * TICK, rtol=0, atol=1e-6)
    assert "SampleTimeFine" in log.description
    # --rate counts the packets instead (here the same times: the clock and the counter agree)
    log = read_log(path, rate=100.0)
    np.testing.assert_allclose(log.t + log.t0, (7 + np.arange(300)) / 100.0, atol=1e-9)
    assert any("SampleTimeFine not read" in n for n in log.notes)


def test_sample_time_fine_in_other_ticks_than_the_stated_rate_is_refused(tmp_path, capsys):
    # a device clock in microseconds (as an Xsens DOT counts) under a preamble of 100 Hz: 100 times too slow
    path, s, _ = _export(tmp_path / "mt.txt", np.arange(300), fine=5_000_000 + np.arange(300) * 10_000)
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "SampleTimeFine steps by 10000 ticks, 1 Hz" in err and "--rate 100" in err
    table, _ = estimate_file(path, tmp_path, capsys, "--rate", "100")
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)


def test_single_spaces_are_read_without_empty_fields_and_refused_with_them(tmp_path, capsys):
    # with SampleTimeFine filled no field is empty: the blanks are read
    path, s, _ = _export(tmp_path / "full.txt", np.arange(200), sep=" ", fine=np.arange(200) * 100)
    table, _ = estimate_file(path, tmp_path, capsys)
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)
    path, *_ = _export(tmp_path / "empty.txt", np.arange(200), sep=" ")  # SampleTimeFine empty: "00001  0.1 ..."
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "single spaces" in err and "line 5" in err and "tabs" in err


def test_a_preamble_rate_of_zero_is_refused_and_rate_reads_the_export(tmp_path, capsys):
    path, s, _ = _export(tmp_path / "mt.txt", np.arange(200), preamble="// Update Rate: 0.0Hz\n")
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "the preamble states a rate of 0 Hz" in err and "--rate HZ" in err
    table, printed = estimate_file(path, tmp_path, capsys, "--rate", "100")
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)
    assert "--rate 100 Hz used, where the export states 0 Hz" in printed


def test_an_export_without_orientation_and_rotation_option_are_refused(tmp_path, capsys):
    path = tmp_path / "acc.txt"
    path.write_text(NEW_PREAMBLE + "PacketCounter\tSampleTimeFine\tAcc_X\tAcc_Y\tAcc_Z\n1\t\t0.1\t0.2\t9.8\n")
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "without an orientation" in err and "line 6" in err
    path, *_ = _export(tmp_path / "mt.txt", np.arange(100))
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--rotation", "inertial-to-body"])
    assert code == 2 and "leave --rotation out" in capsys.readouterr().err


def test_unwrapped_counts_equal_the_counts_before_the_modulus():
    counts = 65000 + np.arange(3000)  # two wraps of a 16-bit counter
    raw = (counts % 2**16).astype(float)
    np.testing.assert_array_equal(unwrapped(raw, 2**16), counts - 0)
    # in two pieces, the second told where the first ended
    first = unwrapped(raw[:1000], 2**16)
    second = unwrapped(raw[1000:], 2**16, float(raw[999]), float(first[-1] - raw[999]))
    np.testing.assert_array_equal(np.concatenate([first, second]), counts)
    # a small step back is no wrap: left for the timestamp policy
    np.testing.assert_array_equal(unwrapped(np.array([10.0, 12.0, 11.0]), 2**16), [10.0, 12.0, 11.0])


# ------------------------------------------------------------------------------ the export as a gyroscope log


def _gyro_export(path, counter, g, rate=200.0, drop=()):
    """An MT Manager export of ``Gyr_X..Z`` rows ``g`` (rad/s) only, one per packet ``counter`` (wrapping)."""
    lines = ["PacketCounter\tSampleTimeFine\tAcc_X\tAcc_Y\tAcc_Z\tGyr_X\tGyr_Y\tGyr_Z"]
    for k, c in enumerate(np.asarray(counter) % 2**16):
        if k not in drop:
            lines.append("\t".join([f"{c:05d}", "", "0.1", "0.2", "9.8", *(repr(float(v)) for v in g[k])]))
    path.write_text(OLD_PREAMBLE.format(rate=rate) + "\n".join(lines) + "\n")
    return path


def test_an_export_is_a_gyroscope_log_on_its_own_clock(tmp_path):
    counter = 2**16 - 40 + np.arange(200)  # wraps after 40 packets
    g = np.random.default_rng(3).normal(size=(200, 3))
    path = _gyro_export(tmp_path / "imu.txt", counter, g, drop={10, 11, 150})
    kept = np.array([k for k in range(200) if k not in {10, 11, 150}])
    log = read_gyro(path)
    np.testing.assert_allclose(log.t, counter[kept] / 200.0, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(log.g, g[kept])
    assert log.names == ("packetcounter", "gyr_x", "gyr_y", "gyr_z") and "PacketCounter at 200 Hz" in log.own_unit
    counted = read_gyro(path, time_column=None)  # --gyro-rate: the counts, for the command to divide
    np.testing.assert_array_equal(counted.t, counter[kept])
    assert not counted.own_unit


def test_calibrate_reads_an_export_as_the_plain_csv_at_the_same_times(tmp_path, capsys):
    data, truth = simulated(5)
    ta, Ra, tg, g = data
    start = max(round(tg[0] * 200), 0)  # the counter at the first packet (no counter is negative): near the gyro's
    counter = start + np.arange(tg.size)
    export = _gyro_export(tmp_path / "imu.txt", counter, g)
    att = tmp_path / "mocap.csv"
    q = Rotation.from_matrix(Ra).as_quat()
    np.savetxt(att, np.column_stack([ta, q[:, 3], q[:, :3]]), delimiter=",", header="t,qw,qx,qy,qz", comments="")
    plain = tmp_path / "imu.csv"
    np.savetxt(plain, np.column_stack([counter / 200.0, g]), delimiter=",", header="t,gx,gy,gz", comments="",
               fmt="%.17g")  # fmt: skip

    def run(gyro):
        out = tmp_path / f"{gyro.stem}.json"
        assert main(["calibrate", str(att), str(gyro), "-o", str(out)]) == 0
        text = capsys.readouterr().out
        return text[text.index("clock offset") :], Calibration.load(out)

    from_export, cal = run(export)
    assert from_export == run(plain)[0]
    z = z_scores(cal, {**truth, "delta": truth["delta"] + start / 200.0 - tg[0]})
    assert max(abs(v) for v in z) < 5, z


# ------------------------------------------------------------------------------ Xsens DOT exports

DOT_PREAMBLE = (
    "sep=,\nDeviceTag:,dot1,,,,,,,\nFirmwareVersion:,2.4.0,,,,,,,\nOutputRate:,{rate}Hz,,,,,,,\n"
    "FilterProfile:,General,,,,,,,\nStartTime:,2024-05-01 10:00:00.000 +0200,,,,,,,\n"
    "Movella Technologies B. V. 2005-2024,,,,,,,,,\n\n"
)


def _dot_export(path, fine, *, rate=60, euler=False, gyro=True):
    """A DOT's CSV (the DOT SDK's logger's layout): the body turning at OMEGA sampled at the device clock's
    microseconds ``fine`` (wrapping at 2**32), Quat_W..Z (or only Euler_X..Z, ZYX degrees), Gyr_X..Z in deg/s."""
    s = (np.asarray(fine, dtype=np.int64) - fine[0]) * 1e-6
    R = R0 * Rotation.from_rotvec(np.outer(s, OMEGA))
    att = R.as_euler("ZYX", degrees=True)[:, ::-1] if euler else R.as_quat()[:, [3, 0, 1, 2]]
    names = ["PacketCounter", "SampleTimeFine", *(("Euler_X", "Euler_Y", "Euler_Z") if euler else
             ("Quat_W", "Quat_X", "Quat_Y", "Quat_Z")), *(("Gyr_X", "Gyr_Y", "Gyr_Z") if gyro else ())]  # fmt: skip
    rows = [
        ", ".join([str(k), str(int(f) % 2**32), *(repr(float(v)) for v in att[k]),
                   *((repr(float(v)) for v in np.degrees(OMEGA)) if gyro else ())])
        for k, f in enumerate(fine)
    ]  # fmt: skip
    path.write_text(DOT_PREAMBLE.format(rate=rate) + ",".join(names) + "\n" + "\n".join(rows) + "\n")
    return path, s


def test_a_dot_export_is_read_on_its_microsecond_clock_across_its_wrap(tmp_path, capsys):
    fine = 2**32 - 100 * 16667 + np.arange(600) * 16667  # 60 Hz in µs, wrapping after 100 samples
    path, s = _dot_export(tmp_path / "dot.csv", fine)
    log = read_log(path, chunk_bytes=4096)
    assert log.format == "xsens" and log.description.startswith("Xsens DOT export")
    np.testing.assert_allclose(log.t + log.t0, fine * 1e-6, rtol=0, atol=1e-6)
    table, printed = estimate_file(path, tmp_path, capsys)
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)
    assert "gyroscope" not in printed  # a DOT's gyroscope unit is not compared


def test_a_dot_clock_in_other_ticks_than_its_stated_rate_is_refused_and_its_euler_angles_are_asked_for(
    tmp_path, capsys
):
    path, _ = _dot_export(tmp_path / "ticks.csv", 1000 + np.arange(300) * 167)  # 100 µs ticks at 60 Hz
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "5988 Hz at 1 µs a tick" in err and "--rate 60" in err
    path, s = _dot_export(tmp_path / "euler.csv", 1000 + np.arange(300) * 16667, euler=True)
    code = main(["estimate", str(path), "-o", str(tmp_path / "o.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "the attitude is Euler angles" in err and "--euler SEQ" in err
    table, _ = estimate_file(path, tmp_path, capsys, "--euler", "ZYX", "--angle-unit", "deg")
    np.testing.assert_allclose(table[30:, 1:], np.tile(OMEGA, (len(s) - 30, 1)), atol=1e-6)


def test_a_log_of_ones_own_with_a_packet_counter_is_not_taken_for_an_export(tmp_path):
    t = np.arange(100) * 0.01
    q = (R0 * Rotation.from_rotvec(np.outer(t, OMEGA))).as_quat()
    rows = "\n".join(",".join(repr(float(v)) for v in (t[k], k, q[k, 3], *q[k, :3])) for k in range(100))
    path = tmp_path / "own.csv"
    path.write_text("t,PacketCounter,qw,qx,qy,qz\n" + rows + "\n")
    assert not is_xsens(path)
    assert read_log(path).format == "csv"
    path.write_text("# my rig, 100 Hz, body frame\nt,PacketCounter,qw,qx,qy,qz\n" + rows + "\n")  # no Xsens line
    assert not is_xsens(path)
    assert is_xsens(_export(tmp_path / "mt.txt", np.arange(50))[0])


def test_a_dots_gyroscope_is_read_with_a_note_that_its_unit_is_the_callers(tmp_path, capsys):
    fine = 5_000_000 + np.arange(900) * 16667
    path, _ = _dot_export(tmp_path / "dot.csv", fine)
    log = read_gyro(path)
    np.testing.assert_allclose(log.t, fine * 1e-6, atol=1e-9)
    np.testing.assert_allclose(log.g, np.tile(np.degrees(OMEGA), (900, 1)))  # as written: the caller's unit
    assert "--gyro-unit" in log.note
    assert not read_gyro(_gyro_export(tmp_path / "mt.txt", np.arange(50), np.zeros((50, 3)))).note
    # the command prints what it read before it fits (a constant rate then has nothing to calibrate against)
    main(["calibrate", str(path), str(path), "--gyro-unit", "deg/s"])
    out = capsys.readouterr().out
    assert "rate gyr_x, gyr_y, gyr_z; s, from SampleTimeFine" in out and "in the unit --gyro-unit gives" in out
