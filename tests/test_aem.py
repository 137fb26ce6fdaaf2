"""CCSDS attitude ephemeris messages (AEM). The files are written here from a body turning at a known constant rate
in its own axes, ``R(t) = R0 exp(S(ω) t)``; what each file holds is pinned to the standard's own definitions, written
out in the test (the direction cosine matrix of a quaternion, (A1); successive rotations of the frame about its own
axes for an Euler sequence; the spin axis's right ascension and declination), not to the reader's formulas. The
reader's rotations must then turn at ω in body axes: ``log(R_kᵀ R_k+1) = ω Δt`` exactly."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, read_log
from omegahat.io.aem import epoch_nanoseconds
from recording_files import estimate_file

OMEGA = np.array([0.03, -0.02, 0.05])  # rad/s, body axes: a slow spacecraft slew
R0 = Rotation.from_rotvec([0.4, -1.1, 0.7])
START = datetime(2026, 3, 14, 23, 59, 50, 250000, tzinfo=UTC)
STEP = 0.5  # s: a 2 Hz star tracker
N = 120


def _truth() -> tuple[list[datetime], Rotation]:
    times = [START + timedelta(seconds=STEP * k) for k in range(N)]
    return times, R0 * Rotation.from_rotvec(np.outer(np.arange(N) * STEP, OMEGA))  # body -> external


def _dcm(q1, q2, q3, qc) -> np.ndarray:
    """The standard's direction cosine matrix of a quaternion (vector part first, scalar ``qc`` last): it maps a
    vector's components from the frame the attitude starts from to the frame it ends at."""
    return np.array(
        [
            [qc**2 + q1**2 - q2**2 - q3**2, 2 * (q1 * q2 + q3 * qc), 2 * (q1 * q3 - q2 * qc)],
            [2 * (q1 * q2 - q3 * qc), qc**2 - q1**2 + q2**2 - q3**2, 2 * (q2 * q3 + q1 * qc)],
            [2 * (q1 * q3 + q2 * qc), 2 * (q2 * q3 - q1 * qc), qc**2 - q1**2 - q2**2 + q3**2],
        ]
    )


def _frame_turn(axis: str, degrees: float) -> np.ndarray:
    """The components of a fixed vector in a frame turned by ``degrees`` about its own ``axis``, from the old
    frame's: the transpose of the rotation matrix about that axis."""
    c, s = np.cos(np.radians(degrees)), np.sin(np.radians(degrees))
    i = "XYZ".index(axis)
    j, k = (i + 1) % 3, (i + 2) % 3
    m = np.eye(3)
    m[j, j], m[j, k], m[k, j], m[k, k] = c, s, -s, c
    return m


def _header(version: str = "1.0") -> str:
    return f"CCSDS_AEM_VERS = {version}\nCOMMENT written by omegahat's tests\nCREATION_DATE = 2026-11-29T12:00:00\n"


def _meta(a: str, b: str, kind: str, extra: str = "", direction: str | None = "A2B", system: str = "UTC") -> str:
    lines = ["META_START", "OBJECT_NAME = TESTSAT", "OBJECT_ID = 2026-001A", f"REF_FRAME_A = {a}", f"REF_FRAME_B = {b}"]
    lines += [f"ATTITUDE_DIR = {direction}"] if direction else []
    lines += [f"TIME_SYSTEM = {system}", f"ATTITUDE_TYPE = {kind}", *filter(None, extra.split("\n")), "META_STOP"]
    return "\n".join(lines) + "\n"


def _epoch(t: datetime, day_of_year: bool = False) -> str:
    return t.strftime("%Y-%jT%H:%M:%S.%f" if day_of_year else "%Y-%m-%dT%H:%M:%S.%f")


def _data(times, rows, markers: bool = True, day_of_year: bool = False) -> str:
    body = "".join(
        f"{_epoch(t, day_of_year)} " + " ".join(f"{v:.15g}" for v in row) + "\n"
        for t, row in zip(times, rows, strict=True)
    )
    return f"DATA_START\n{body}DATA_STOP\n" if markers else body


def _rates_of(log) -> np.ndarray:
    r = Rotation.from_quat(log.data)
    return (r[:-1].inv() * r[1:]).as_rotvec() / np.diff(log.t)[:, None]


def _quaternions(external_to_body: bool) -> np.ndarray:
    """(q1, q2, q3, qc) per epoch whose (A1) matrix maps external → body (or body → external), checked here."""
    _, rot = _truth()
    q = rot.as_quat()  # x, y, z, w of body -> external
    if external_to_body:
        assert np.allclose(_dcm(*q[7]), rot[7].as_matrix().T, atol=1e-12)  # v_B = M v_E
    else:
        q = q * [-1, -1, -1, 1]
        assert np.allclose(_dcm(*q[7]), rot[7].as_matrix(), atol=1e-12)  # v_E = M v_B
    return q


@pytest.mark.parametrize(
    ("a", "b", "direction", "order", "external_to_body"),
    [
        ("EME2000", "SC_BODY_1", "A2B", "LAST", True),
        ("EME2000", "SC_BODY_1", "B2A", "FIRST", False),
        ("SC_BODY_1", "ICRF", "A2B", "LAST", False),
        ("STARTRACKER_2", "EME2000", "B2A", "FIRST", True),
    ],
)
def test_quaternions_in_every_direction_and_order_turn_at_the_bodys_rate(
    tmp_path, a, b, direction, order, external_to_body
):
    times, _ = _truth()
    q = _quaternions(external_to_body)
    rows = q[:, [3, 0, 1, 2]] if order == "FIRST" else q
    path = tmp_path / "slew.aem"
    path.write_text(_header() + _meta(a, b, "QUATERNION", f"QUATERNION_TYPE = {order}", direction) + _data(times, rows))
    log = read_log(path)
    assert log.format == "aem"
    np.testing.assert_allclose(_rates_of(log), np.tile(OMEGA, (N - 1, 1)), atol=1e-9)
    body = a if a.startswith(("SC_", "STAR")) else b
    assert f"rates of {body} in its own axes" in " ".join(log.notes)


def test_version_2_without_direction_or_data_markers_and_day_of_year_epochs(tmp_path):
    times, _ = _truth()
    q = _quaternions(True)
    rates = np.tile(np.degrees(OMEGA), (N, 1))  # the file's own rates: carried, not used
    text = _header("2.0") + _meta("EME2000", "SC_BODY_1", "QUATERNION/ANGVEL", "ANGVEL_FRAME = REF_FRAME_B", None)
    path = tmp_path / "v2.txt"
    path.write_text(text + _data(times, np.hstack([q, rates]), markers=False, day_of_year=True))
    log = read_log(path)
    np.testing.assert_allclose(_rates_of(log), np.tile(OMEGA, (N - 1, 1)), atol=1e-9)
    assert any("QUATERNION/ANGVEL" in n and "not used" in n for n in log.notes)


@pytest.mark.parametrize("sequence", ["321", "ZXZ", "SPIN"])
def test_euler_angles_and_spin_are_successive_turns_of_the_frame(tmp_path, sequence):
    times, rot = _truth()
    if sequence == "SPIN":
        a1, a2, a3 = rot.as_euler("ZXZ", degrees=True).T
        alpha, delta = a1 - 90.0, 90.0 - a2
        # the spin axis (body z) points at right ascension alpha, declination delta in the external frame
        axis = rot.apply([0.0, 0.0, 1.0])
        d, al = np.radians(delta), np.radians(alpha)
        np.testing.assert_allclose(
            axis, np.column_stack([np.cos(d) * np.cos(al), np.cos(d) * np.sin(al), np.sin(d)]), atol=1e-12
        )
        rows = np.column_stack([alpha, delta, a3, np.zeros(N)])
        meta = _meta("EME2000", "SC_BODY_1", "SPIN")
    else:
        axes = "".join("XYZ"[int(c) - 1] for c in sequence) if sequence.isdigit() else sequence
        rows = rot.as_euler(axes, degrees=True)
        k = 11
        turned = _frame_turn(axes[2], rows[k, 2]) @ _frame_turn(axes[1], rows[k, 1]) @ _frame_turn(axes[0], rows[k, 0])
        np.testing.assert_allclose(turned, rot[k].as_matrix().T, atol=1e-12)  # external -> body, turn by turn
        meta = _meta("EME2000", "SC_BODY_1", "EULER_ANGLE", f"EULER_ROT_SEQ = {sequence}")
    path = tmp_path / "angles.aem"
    path.write_text(_header() + meta + _data(times, rows))
    np.testing.assert_allclose(_rates_of(read_log(path)), np.tile(OMEGA, (N - 1, 1)), atol=1e-9)


def test_the_command_reads_an_aem_of_two_segments_and_writes_the_epochs(tmp_path, capsys):
    times, _ = _truth()
    q = _quaternions(True)
    meta = _meta("EME2000", "SC_BODY_1", "QUATERNION", "QUATERNION_TYPE = LAST")
    half = N // 2  # the second segment repeats the first one's last epoch, as segments often do
    text = _header() + meta + _data(times[:half], q[:half]) + "\n" + meta + _data(times[half - 1 :], q[half - 1 :])
    path = tmp_path / "two.aem"
    path.write_text(text)
    got, printed = estimate_file(path, tmp_path, capsys)
    assert "CCSDS AEM 1.0: 121 epochs in 2 segments, attitude of SC_BODY_1 relative to EME2000" in printed
    want = np.array([(t - datetime(1970, 1, 1, tzinfo=UTC)).total_seconds() for t in times])
    np.testing.assert_allclose(got[:, 0], want, rtol=0, atol=1e-6)  # the repeated epoch merged, said in a note
    assert "merged" in printed or "same time" in printed
    np.testing.assert_allclose(got[-20:, 1:], np.tile(OMEGA, (20, 1)), atol=1e-4)


def test_epochs_to_the_nanosecond():
    for text, want in [
        ("2026-03-14T23:59:50.25", datetime(2026, 3, 14, 23, 59, 50, 250000, tzinfo=UTC)),
        ("2024-366T00:00:01", datetime(2024, 12, 31, 0, 0, 1, tzinfo=UTC)),
        ("1996-11-28T21:29:07.2555Z", datetime(1996, 11, 28, 21, 29, 7, 255500, tzinfo=UTC)),
    ]:
        assert epoch_nanoseconds(text) == round(want.timestamp() * 1e6) * 1000
    assert epoch_nanoseconds("2026-01-01T00:00:00.1234567895") == 1767225600_123456790
    for bad in ["2025-366T00:00:00", "2026-02-30T00:00:00", "2026-01-01T23:59:60", "2026-01-01 00:00:00", "12.5"]:
        assert epoch_nanoseconds(bad) is None


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda s: s.replace("0.5 ", "0.5x ", 1), "field 2: '0.5x' is not a number"),
        (lambda s: s.replace("T23:59:50.250000", "T23:59:60.250000", 1), "a leap second"),
        (lambda s: s.replace("SC_BODY_1", "BCS"), "neither is named as a spacecraft frame of the standard"),
        (lambda s: s.replace("QUATERNION_TYPE = LAST\n", ""), "has no QUATERNION_TYPE"),
        (lambda s: s.replace("ATTITUDE_TYPE = QUATERNION", "ATTITUDE_TYPE = SPIN/NUTATION"), "is not read"),
        (lambda s: s.replace(" 0.5\n", "\n", 1), "3 numbers after the epoch; the segment's type has 4"),
        (lambda s: s.replace("DATA_STOP", "DATA_STOP\nJUNK"), "'JUNK' is out of place"),
        (
            lambda s: "<?xml version='1.0'?>\n<aem id='CCSDS_AEM_VERS' version='2.0'>\n</aem>\n",
            "without attitude states",
        ),
    ],
)
def test_bad_files_are_refused_naming_the_line(tmp_path, capsys, change, message):
    times = [START + timedelta(seconds=k) for k in range(3)]
    good = _header() + _meta("EME2000", "SC_BODY_1", "QUATERNION", "QUATERNION_TYPE = LAST")
    good += _data(times, [[0.5, 0.5, 0.5, 0.5]] * 3)
    path = tmp_path / ("bad.xml" if "states" in message else "bad.aem")
    path.write_text(change(good))
    with pytest.raises(LogFormatError, match=message.replace("(", r"\(").replace(")", r"\)")):
        read_log(path)
    out = tmp_path / "o.csv"
    assert main(["estimate", str(path), "-o", str(out), "--no-progress"]) == 2
    assert message.split(":")[0] in capsys.readouterr().err and not out.exists()


def test_segments_of_different_frames_are_refused(tmp_path):
    times = [START + timedelta(seconds=k) for k in range(3)]
    rows = [[0.5, 0.5, 0.5, 0.5]] * 3
    text = _header() + _meta("EME2000", "SC_BODY_1", "QUATERNION", "QUATERNION_TYPE = LAST") + _data(times, rows)
    text += _meta("ITRF2000", "SC_BODY_1", "QUATERNION", "QUATERNION_TYPE = LAST") + _data(times, rows)
    path = tmp_path / "frames.aem"
    path.write_text(text)
    with pytest.raises(LogFormatError, match="SC_BODY_1 relative to ITRF2000 in UTC, unlike the one before"):
        read_log(path)


def test_a_spacecraft_frame_of_another_name_is_named_with_body(tmp_path, capsys):
    times, _ = _truth()
    q = _quaternions(False)  # spacecraft -> external: B2A with B the spacecraft
    meta = _meta("J2000", "BCS", "QUATERNION", "QUATERNION_TYPE = LAST", "B2A")
    path = tmp_path / "bcs.aem"
    path.write_text(_header() + meta + _data(times, q))
    with pytest.raises(LogFormatError, match="--body BCS or --body J2000"):
        read_log(path)
    np.testing.assert_allclose(_rates_of(read_log(path, body="bcs")), np.tile(OMEGA, (N - 1, 1)), atol=1e-9)
    with pytest.raises(LogFormatError, match=r"states which way its attitude maps .*leave --rotation out"):
        read_log(path, body="BCS", rotation="inertial-to-body")
    with pytest.raises(LogFormatError, match="--body SC_BODY_1 is neither"):
        read_log(path, body="SC_BODY_1")
    _, printed = estimate_file(path, tmp_path, capsys, "--body", "BCS")
    assert "attitude of BCS relative to J2000" in printed


def test_an_aem_in_gives_an_aem_out_with_the_rates(tmp_path, capsys):
    times, _ = _truth()
    q = _quaternions(False)  # spacecraft -> external in the input: the output writes the other direction
    rows = q.copy()
    rows[40] = np.nan  # a missing sample: no line in the output, counted
    meta = _meta("J2000", "STARTRACKER_1", "QUATERNION", "QUATERNION_TYPE = LAST", "B2A")
    path = tmp_path / "in.aem"
    path.write_text(_header() + meta + _data(times, rows))
    want, _ = estimate_file(path, tmp_path, capsys)  # the same estimate as CSV
    out = tmp_path / "out.aem"
    assert main(["estimate", str(path), "-o", str(out), "--no-progress"]) == 0
    assert "119 epochs to" in capsys.readouterr().out
    text = out.read_text()
    assert "ATTITUDE_TYPE = QUATERNION/ANGVEL" in text and "ANGVEL_FRAME = STARTRACKER_1" in text
    assert "COMMENT 1 samples without an attitude or an estimate are left out" in text
    back = read_log(out)
    kept = np.delete(np.arange(N), 40)
    np.testing.assert_allclose(back.t + back.t0 - (want[kept, 0]), 0.0, atol=1e-6)
    assert [ln.split()[0] for ln in text.splitlines() if ln[:4] == "2026"] == [
        _epoch(times[k]).rstrip("0") for k in kept
    ]
    same = Rotation.from_quat(back.data).inv() * Rotation.from_quat(q[kept] * [-1, -1, -1, 1])
    assert np.max(same.magnitude()) < 1e-12  # the attitude as read, now written external -> spacecraft
    rates = np.array([[float(v) for v in ln.split()[5:]] for ln in text.splitlines() if ln[:4] == "2026"])
    np.testing.assert_allclose(np.radians(rates), want[kept, 1:], rtol=0, atol=1e-14)
    np.testing.assert_allclose(_rates_of(back), np.tile(OMEGA, (N - 2, 1))[: len(kept) - 1], atol=1e-9)


def test_an_aem_output_needs_an_aem_input(tmp_path, capsys):
    t = np.arange(30) / 10.0
    q = Rotation.from_rotvec(np.outer(t, OMEGA)).as_quat()
    src = tmp_path / "log.csv"
    src.write_text("t,qx,qy,qz,qw\n" + "".join(f"{a},{x},{y},{z},{w}\n" for a, (x, y, z, w) in zip(t, q, strict=True)))
    assert main(["estimate", str(src), "-o", str(tmp_path / "o.aem"), "--no-progress"]) == 2
    assert "its frames, time system and epochs" in capsys.readouterr().err
    assert not (tmp_path / "o.aem").exists()


def _compared(printed: str) -> float | None:
    import re

    m = re.search(r"against the rates the AEM's lines carry, in \w+ axes: RMS difference (\S+) rad/s", printed)
    return None if m is None else float(m.group(1))


@pytest.mark.parametrize(
    ("kind", "frame", "offset", "external_to_body"),
    [
        ("QUATERNION/ANGVEL", "SC_BODY_1", 0.0, True),
        ("QUATERNION/ANGVEL", "EME2000", 0.0, True),
        ("QUATERNION/ANGVEL", "SC_BODY_1", 0.01, True),
        ("QUATERNION/ANGVEL", "SC_BODY_1", 0.0, False),
        ("QUATERNION/ANGVEL", "EME2000", 0.0, False),
        ("QUATERNION/ANGVEL", "EME2000", 0.01, False),
        ("QUATERNION/DERIVATIVE", None, 0.0, True),
        ("QUATERNION/DERIVATIVE", None, 0.0, False),
    ],
)
def test_the_rates_an_aem_carries_are_compared_with_the_estimate(
    tmp_path, capsys, kind, frame, offset, external_to_body
):
    times, rot = _truth()
    q = _quaternions(external_to_body)
    if kind.endswith("ANGVEL"):
        # the rate of the attitude's end frame relative to its start frame (the CCSDS registry of attitude
        # elements: "the rotational rate of frame B with respect to frame A"): the spacecraft's relative to the
        # external frame from external to spacecraft, its opposite the other way; in the file's axes, deg/s
        body = np.tile(OMEGA + np.array([offset, 0.0, 0.0]), (N, 1)) * (1.0 if external_to_body else -1.0)
        rates = np.degrees(rot.apply(body) if frame == "EME2000" else body)
        extra = f"ANGVEL_FRAME = {frame}"
    else:  # dq/dt = q ⊗ (ω/2, 0) for the quaternion of R; the conjugate's derivative for the other direction
        qr = rot.as_quat()
        v, w = qr[:, :3], qr[:, 3:]
        dq = 0.5 * np.hstack([w * OMEGA + np.cross(v, OMEGA), -(v @ OMEGA)[:, None]])
        rates = dq if external_to_body else dq * [-1, -1, -1, 1]
        extra = "QUATERNION_TYPE = LAST"
    a, b = ("EME2000", "SC_BODY_1") if external_to_body else ("SC_BODY_1", "EME2000")
    path = tmp_path / "rates.aem"
    path.write_text(_header("2.0") + _meta(a, b, kind, extra, None) + _data(times, np.hstack([q, rates])))
    _, printed = estimate_file(path, tmp_path, capsys)
    got = _compared(printed)
    assert got is not None, printed
    assert abs(got - offset) < 1e-3 * max(offset, 1e-3), got


def _xml(a, b, direction, kind, states) -> str:
    """An AEM in its XML form: one segment, ``states`` the inner XML of each attitude state."""
    meta = f"<REF_FRAME_A>{a}</REF_FRAME_A><REF_FRAME_B>{b}</REF_FRAME_B><ATTITUDE_DIR>{direction}</ATTITUDE_DIR>"
    meta += (
        f"<TIME_SYSTEM>UTC</TIME_SYSTEM><ATTITUDE_TYPE>{kind}</ATTITUDE_TYPE><QUATERNION_TYPE>FIRST</QUATERNION_TYPE>"
    )
    body = "".join(f"<attitudeState>\n{s}</attitudeState>\n" for s in states)
    return (
        '<?xml version="1.0" encoding="UTF-8"?>\n<aem id="CCSDS_AEM_VERS" version="1.0">\n<header><ORIGINATOR>T'
        f"</ORIGINATOR></header>\n<body><segment><metadata>{meta}</metadata>\n<data>\n{body}</data></segment></body>"
        "</aem>\n"
    )


def test_the_xml_form_with_quaternion_derivatives(tmp_path, capsys):
    times, rot = _truth()
    q = _quaternions(False)  # spacecraft -> external (B2A, B the spacecraft), the scalar written first
    qr = rot.as_quat()
    v, w = qr[:, :3], qr[:, 3:]
    dq = 0.5 * np.hstack([w * OMEGA + np.cross(v, OMEGA), -(v @ OMEGA)[:, None]]) * [-1, -1, -1, 1]
    states = [
        f"<quaternionDerivative><EPOCH>{_epoch(t)}</EPOCH><quaternion><QC>{x[3]!r}</QC><Q1>{x[0]!r}</Q1>"
        f"<Q2>{x[1]!r}</Q2><Q3>{x[2]!r}</Q3></quaternion>\n<quaternionRate><QC_DOT>{d[3]!r}</QC_DOT>"
        f"<Q1_DOT>{d[0]!r}</Q1_DOT><Q2_DOT>{d[1]!r}</Q2_DOT><Q3_DOT>{d[2]!r}</Q3_DOT></quaternionRate>"
        "</quaternionDerivative>\n"
        for t, x, d in zip(times, q.tolist(), dq.tolist(), strict=True)
    ]
    path = tmp_path / "att.xml"
    path.write_text(_xml("EME2000", "SC_BODY_1", "B2A", "QUATERNION/DERIVATIVE", states))
    log = read_log(path)
    np.testing.assert_allclose(_rates_of(log), np.tile(OMEGA, (N - 1, 1)), atol=1e-9)
    _, printed = estimate_file(path, tmp_path, capsys)
    assert "CCSDS AEM 1.0: 120 epochs" in printed and (_compared(printed) or 1.0) < 1e-6
    bad = path.read_text().replace("<Q2_DOT>", "<Q2_DOTX>", 1).replace("</Q2_DOT>", "</Q2_DOTX>", 1)
    path.write_text(bad)
    with pytest.raises(LogFormatError, match=r"att\.xml, line 6: the attitude state has no Q2_DOT"):
        read_log(path)
    euler = '<eulerAngle><EPOCH>2026-01-01T00:00:00</EPOCH><rotationAngles><rotation1 angle="X_ANGLE">1</rotation1>'
    path.write_text(_xml("EME2000", "SC_BODY_1", "A2B", "EULER_ANGLE", [euler + "</rotationAngles></eulerAngle>"]))
    with pytest.raises(LogFormatError, match="Euler angles in the XML form are not read"):
        read_log(path)
    path.write_text("<aem id='CCSDS_AEM_VERS' version='1.0'><body><segment></aem>")
    with pytest.raises(LogFormatError, match="not well-formed XML"):
        read_log(path)
