"""PX4 flight logs: ULog files written here byte by byte from the ULog specification (header, flag bits, formats,
subscriptions, data; an independent writer, not pyulog's) and ulog2csv's CSV files. The rates are checked against
the same float32 quaternions written as an omegahat CSV, and the body's known rate."""

from __future__ import annotations

import struct

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, ReadOptions, read_log
from recording_files import estimate_file, read_omega_csv

pytest.importorskip("pyulog", reason="PX4 ULog files need pyulog (the test extra installs it: omegahat[px4])")

CLI = ["--no-progress"]
OMEGA = np.array([0.3, -0.2, 0.5])  # rad/s, body (FRD) axes
RATE = 250.0
START_US = 123_456_789  # µs since the autopilot started

_ATTITUDE = (
    "uint64_t timestamp;uint64_t timestamp_sample;float[4] q;float[4] delta_q_reset;uint8_t quat_reset_counter;"
    "uint8_t[7] _padding0;"
)
_ODOMETRY = (
    "uint64_t timestamp;uint64_t timestamp_sample;float[3] position;float[4] q;uint8_t pose_frame;uint8_t[3] _padding0;"
)


def _message(kind: bytes, payload: bytes) -> bytes:
    return struct.pack("<HB", len(payload), kind[0]) + payload


def write_ulog(path, topics: dict[tuple[str, int], list[bytes]], formats: dict[str, str]) -> None:
    """A ULog file (version 1): header, flag bits, one format per message, then each topic's subscription and its
    messages (``topics[(name, multi_id)]``: each message's payload without the msg_id, and without the padding
    fields at its end, which the logger does not write)."""
    out = bytearray(b"ULog\x01\x12\x35" + bytes([1]) + struct.pack("<Q", START_US))
    out += _message(b"B", bytes(16) + struct.pack("<3Q", 0, 0, 0))
    for name, fields in formats.items():
        out += _message(b"F", f"{name}:{fields}".encode())
    for msg_id, ((name, multi_id), payloads) in enumerate(topics.items()):
        out += _message(b"A", struct.pack("<BH", multi_id, msg_id) + name.encode())
        for payload in payloads:
            out += _message(b"D", struct.pack("<H", msg_id) + payload)
    path.write_bytes(bytes(out))


def _quaternions(n: int, turn=(0.2, 0.0, 0.0)) -> np.ndarray:
    t = np.arange(n) / RATE
    xyzw = (Rotation.from_rotvec(turn) * Rotation.from_rotvec(np.outer(t, OMEGA))).as_quat()
    return xyzw[:, [3, 0, 1, 2]].astype(np.float32)  # w, x, y, z as PX4 logs them (float32)


def _stamps(n: int) -> np.ndarray:
    return START_US + np.round(np.arange(n) * 1e6 / RATE).astype(np.int64)


def _attitude(stamps, wxyz, lag_us=300) -> list[bytes]:
    return [
        struct.pack("<QQ4f4fB", int(s) + lag_us, int(s), *map(float, q), 1.0, 0.0, 0.0, 0.0, 0)
        for s, q in zip(stamps, wxyz, strict=True)
    ]


def _attitude_with_resets(stamps, wxyz, resets: dict[int, np.ndarray]) -> list[bytes]:
    """vehicle_attitude messages whose estimator reset its earth frame by ``resets[k]`` (w, x, y, z) at message
    ``k``: from ``k`` on, ``q = Δ ⊗ q̃`` (PX4's ``q_after = Δ ⊗ q_before``), the counter counting the resets."""
    total = Rotation.identity()
    out, count, last = [], 0, np.array([1.0, 0.0, 0.0, 0.0])
    for k, (s, q) in enumerate(zip(stamps, wxyz, strict=True)):
        if k in resets:
            total = Rotation.from_quat(resets[k], scalar_first=True) * total
            count, last = count + 1, resets[k]
        shown = (total * Rotation.from_quat(q.astype(float), scalar_first=True)).as_quat(scalar_first=True)
        out.append(struct.pack("<QQ4f4fB", int(s) + 300, int(s), *map(float, shown), *map(float, last), count))
    return out


def _odometry(stamps, wxyz) -> list[bytes]:
    return [
        struct.pack("<QQ3f4fB", int(s) + 100, int(s), 0.0, 0.0, 0.0, *map(float, q), 0)
        for s, q in zip(stamps, wxyz, strict=True)
    ]


def _reference_csv(path, stamps, wxyz) -> None:
    rows = [
        f"{(s - START_US) * 1e-6:.17g},{','.join(repr(float(v)) for v in q)}" for s, q in zip(stamps, wxyz, strict=True)
    ]
    path.write_text("t,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")


def test_a_ulogs_vehicle_attitude_gives_the_rates_of_its_quaternions(tmp_path, capsys):
    n = 1500
    stamps, q = _stamps(n), _quaternions(n)
    mocap = _quaternions(n, turn=(0.0, 0.1, 0.0))
    ulg = tmp_path / "flight.ulg"
    write_ulog(
        ulg,
        {("vehicle_attitude", 0): _attitude(stamps, q), ("vehicle_mocap_odometry", 0): _odometry(stamps, mocap)},
        {"vehicle_attitude": _ATTITUDE, "vehicle_mocap_odometry": _ODOMETRY},
    )
    log = read_log(ulg)
    np.testing.assert_allclose(log.absolute_times, stamps * 1e-6, rtol=0, atol=1e-9)  # the sample times, in s
    assert "topic vehicle_attitude (PX4's attitude estimate, made with its gyroscope); the log also has " in (
        " ".join(log.notes)
    )
    reference = tmp_path / "reference.csv"
    _reference_csv(reference, stamps, q)
    got, printed = estimate_file(ulg, tmp_path, capsys)
    want, _ = estimate_file(reference, tmp_path, capsys)
    assert "PX4 ULog: topic vehicle_attitude, 1500 messages" in printed
    np.testing.assert_allclose(got[:, 0], stamps * 1e-6, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 1:], want[:, 1:], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[100:, 1:], np.broadcast_to(OMEGA, (n - 100, 3)), atol=2e-3)  # float32 attitudes

    mocap_csv = tmp_path / "mocap.csv"
    _reference_csv(mocap_csv, stamps, mocap)
    got, _ = estimate_file(ulg, tmp_path, capsys, "--topic", "vehicle_mocap_odometry")
    want, _ = estimate_file(mocap_csv, tmp_path, capsys)
    np.testing.assert_allclose(got[:, 1:], want[:, 1:], rtol=0, atol=1e-9)


def test_topics_are_chosen_or_named(tmp_path):
    n = 50
    stamps, q = _stamps(n), _quaternions(n)
    ulg = tmp_path / "two.ulg"
    write_ulog(
        ulg,
        {("estimator_attitude", 0): _attitude(stamps, q), ("estimator_attitude", 1): _attitude(stamps, q[::-1])},
        {"estimator_attitude": _ATTITUDE},
    )
    with pytest.raises(
        LogFormatError, match=r"2 attitude topics \(estimator_attitude_0, estimator_attitude_1\); choose"
    ):
        read_log(ulg)
    second = read_log(ulg, options=ReadOptions(topic="estimator_attitude_1"))
    assert second.data.shape == (n, 4)
    with pytest.raises(LogFormatError, match=r"no topic 'gps' with an attitude; the log has estimator_attitude_0"):
        read_log(ulg, options=ReadOptions(topic="gps"))
    none = tmp_path / "none.ulg"
    write_ulog(
        none,
        {("battery_status", 0): [struct.pack("<Qf", START_US, 12.0)]},
        {"battery_status": "uint64_t timestamp;float voltage_v;uint8_t[4] _padding0;"},
    )
    with pytest.raises(LogFormatError, match=r"no attitude topic"):
        read_log(none)


def test_a_damaged_ulog_and_an_invalid_attitude(tmp_path, capsys):
    bad = tmp_path / "bad.ulg"
    bad.write_bytes(b"ULog\x01\x12\x35\x01" + b"\x00" * 3)  # the header cut short
    out = tmp_path / "o.csv"
    assert main(["estimate", str(bad), "-o", str(out), *CLI]) == 2
    err = capsys.readouterr().err
    assert "bad.ulg" in err and "Traceback" not in err
    assert not out.exists()

    n = 200
    stamps, q = _stamps(n), _quaternions(n)
    wild = stamps.astype(np.uint64)
    wild[7] = 2**63 + 5  # a damaged stamp, beyond what int64 holds
    broken = tmp_path / "broken.ulg"
    write_ulog(broken, {("vehicle_attitude", 0): _attitude(wild, q, lag_us=0)}, {"vehicle_attitude": _ATTITUDE})
    with pytest.raises(LogFormatError, match=r"topic vehicle_attitude, message 7: timestamp_sample \d+ µs is no time"):
        read_log(broken)
    q[50] = np.nan  # an odometry message whose attitude is invalid
    ulg = tmp_path / "gap.ulg"
    write_ulog(ulg, {("vehicle_visual_odometry", 0): _odometry(stamps, q)}, {"vehicle_visual_odometry": _ODOMETRY})
    table, status = read_omega_csv(out) if main(["estimate", str(ulg), "-o", str(out), *CLI]) == 0 else (None, None)
    assert table is not None and status[50] == "predicted"
    assert np.all(np.isfinite(table[:, 1:]))


def test_ulog2csv_files_are_read_in_microseconds_scalar_first(tmp_path, capsys):
    n = 1000
    stamps, q = _stamps(n), _quaternions(n)
    path = tmp_path / "flight_vehicle_attitude_0.csv"
    header = "timestamp,timestamp_sample,q[0],q[1],q[2],q[3],delta_q_reset[0],delta_q_reset[1],delta_q_reset[2],"
    rows = [
        f"{s + 300},{s},{','.join(f'{float(v):.9g}' for v in row)},1,0,0,0,0" for s, row in zip(stamps, q, strict=True)
    ]
    path.write_text(header + "delta_q_reset[3],quat_reset_counter\n" + "\n".join(rows) + "\n")
    log = read_log(path)
    np.testing.assert_allclose(log.absolute_times, stamps * 1e-6, rtol=0, atol=1e-9)
    reference = tmp_path / "reference.csv"
    _reference_csv(reference, stamps, q)
    got, printed = estimate_file(path, tmp_path, capsys)
    want, _ = estimate_file(reference, tmp_path, capsys)
    assert "PX4 ulog2csv CSV" in printed
    np.testing.assert_allclose(got[:, 1:], want[:, 1:], rtol=0, atol=1e-6)


def test_the_estimators_resets_are_undone_by_their_own_rotation(tmp_path, capsys):
    """Two resets of PX4's estimator (a 20° turn of its heading, then 5° about another axis) make the published
    attitude jump; read with their delta_q_reset undone, the rates are those of the log without resets, and no
    sample is lost to them."""
    n = 1000
    stamps, q = _stamps(n), _quaternions(n)
    yaw = Rotation.from_rotvec([0.0, 0.0, np.radians(20.0)]).as_quat(scalar_first=True)
    tilt = Rotation.from_rotvec(np.radians(5.0) * np.array([0.6, 0.8, 0.0])).as_quat(scalar_first=True)
    reset = tmp_path / "reset.ulg"
    write_ulog(reset, {("vehicle_attitude", 0): _attitude_with_resets(stamps, q, {400: yaw, 700: tilt})},
               {"vehicle_attitude": _ATTITUDE})  # fmt: skip
    plain = tmp_path / "plain.ulg"
    write_ulog(plain, {("vehicle_attitude", 0): _attitude(stamps, q)}, {"vehicle_attitude": _ATTITUDE})
    got, printed = estimate_file(reset, tmp_path, capsys)
    want, _ = estimate_file(plain, tmp_path, capsys)
    assert "undid 2 reset(s) of PX4's estimator by its delta_q_reset (the largest 20°)" in printed
    assert "resets:" not in printed  # no step is left for the generic detection
    np.testing.assert_allclose(got[:, 1:], want[:, 1:], rtol=0, atol=1e-4)  # float32 attitudes, turned
    np.testing.assert_allclose(got[100:, 1:], np.broadcast_to(OMEGA, (n - 100, 3)), atol=2e-3)


def test_calibrate_reads_a_ulogs_gyroscope(tmp_path, capsys):
    """``omegahat calibrate`` with the gyroscope in a ULog (sensor_combined by default, float32, µs since boot) finds
    the calibration of the same gyroscope written as a CSV; ``--gyro-topic`` chooses another topic."""
    import json

    from calibration_logs import simulated

    (ta, Ra, tg, g), truth = simulated(4)
    since_boot = np.round((tg + 1.0) * 1e6).astype(np.int64)  # µs: the boot one second before the attitude's 0
    q = Rotation.from_matrix(Ra).as_quat()
    attitude = tmp_path / "mocap.csv"
    np.savetxt(attitude, np.column_stack([ta, q[:, 3], q[:, :3]]), delimiter=",", header="t,qw,qx,qy,qz", comments="")
    g32 = g.astype(np.float32)
    SHIFT = np.array([0.1, 0.0, 0.0], dtype=np.float32)  # vehicle_angular_velocity's rates: the bias moved by it
    ulg = tmp_path / "flight.ulg"
    write_ulog(
        ulg,
        {
            ("sensor_combined", 0): [
                struct.pack("<Q3f", int(s), *map(float, r)) for s, r in zip(since_boot, g32, strict=True)
            ],
            ("vehicle_angular_velocity", 0): [
                struct.pack("<QQ3f", int(s), int(s), *map(float, r + SHIFT))
                for s, r in zip(since_boot, g32, strict=True)
            ],
        },
        {
            "sensor_combined": "uint64_t timestamp;float[3] gyro_rad;",
            "vehicle_angular_velocity": "uint64_t timestamp;uint64_t timestamp_sample;float[3] xyz;",
        },
    )
    csv = tmp_path / "imu.csv"
    np.savetxt(
        csv, np.column_stack([since_boot * 1e-6, g32]), delimiter=",", header="t,gx,gy,gz", comments="", fmt="%.17g"
    )
    found = {}
    for name, gyro, extra in (
        ("csv", csv, []),
        ("ulog", ulg, []),
        ("avel", ulg, ["--gyro-topic", "vehicle_angular_velocity"]),
    ):
        out = tmp_path / f"{name}.json"
        assert main(["calibrate", str(attitude), str(gyro), "-o", str(out), *extra]) == 0, capsys.readouterr().err
        found[name] = json.loads(out.read_text())
    printed = capsys.readouterr().out
    assert "PX4 ULog topic sensor_combined, timestamp in µs since boot (converted to s)" in printed
    assert abs(found["ulog"]["offset"] - found["csv"]["offset"]) < 1e-6
    assert abs(found["ulog"]["offset"] - (truth["delta"] + 1.0)) < 1e-3
    np.testing.assert_allclose(found["ulog"]["bias"], found["csv"]["bias"], atol=1e-6)
    np.testing.assert_allclose(found["avel"]["bias"], np.asarray(found["csv"]["bias"]) + SHIFT, atol=1e-5)
    assert main(["calibrate", str(attitude), str(ulg), "--gyro-time-unit", "ms"]) == 2
    assert "its times carry their own unit" in capsys.readouterr().err

    # both logs in one ULog: the attitude as motion-capture odometry, chosen with --topic, on the same boot clock
    wxyz = q[:, [3, 0, 1, 2]].astype(np.float32)
    both = tmp_path / "both.ulg"
    write_ulog(
        both,
        {
            ("sensor_combined", 0): [
                struct.pack("<Q3f", int(s), *map(float, r)) for s, r in zip(since_boot, g32, strict=True)
            ],
            ("vehicle_mocap_odometry", 0): _odometry(np.round((ta + 1.0) * 1e6).astype(np.int64), wxyz),
            ("vehicle_attitude", 0): _attitude(since_boot[:50], np.tile(wxyz[:1], (50, 1))),
        },
        {
            "sensor_combined": "uint64_t timestamp;float[3] gyro_rad;",
            "vehicle_mocap_odometry": _ODOMETRY,
            "vehicle_attitude": _ATTITUDE,
        },
    )
    out = tmp_path / "both.json"
    assert main(["calibrate", str(both), str(both), "--topic", "vehicle_mocap_odometry", "-o", str(out)]) == 0
    assert abs(json.loads(out.read_text())["offset"] - (found["csv"]["offset"] - 1.0)) < 1e-5


def test_damage_inside_a_ulog_is_said_once_in_a_note(tmp_path, capsys):
    """A message whose id names no subscription (a damaged byte): pyulog skips it and prints a warning per message;
    the command says it once, in a note, and reads the rest."""
    n = 300
    stamps, q = _stamps(n), _quaternions(n)
    ulg = tmp_path / "damaged.ulg"
    write_ulog(ulg, {("vehicle_attitude", 0): _attitude(stamps, q)}, {"vehicle_attitude": _ATTITUDE})
    data = bytearray(ulg.read_bytes())
    size = 3 + 2 + struct.calcsize("<QQ4f4fB")  # one data message: header, msg_id, payload
    first = len(data) - n * size
    for k in (100, 101, 102):
        data[first + k * size + 3 : first + k * size + 5] = struct.pack("<H", 77)  # an id nothing subscribed to
    ulg.write_bytes(bytes(data))
    table, printed = estimate_file(ulg, tmp_path, capsys)
    assert "pyulog found damaged parts in the file and skipped them" in printed
    assert "Warning" not in printed and "subscription" not in printed
    assert table.shape[0] == n - 3 and np.all(np.isfinite(table[20:, 1:]))
