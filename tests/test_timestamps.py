"""The timestamp policy (omegahat.io.timestamps): duplicates dropped or refused, order, and jittery logs with
dropped frames giving the same rate as a clean log within the noise."""

from __future__ import annotations

import itertools

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from omegahat import estimate_frame
from omegahat.io import LogChunk, LogFormatError, LogStream, ReadOptions, read_log
from omegahat.io.registry import checked_stream
from omegahat.io.timestamps import sort_by_time
from omegahat.observer.tuning import predicted_noise_std, sensor_gains
from recording_files import J_AXI, noisy, torque_free_axisymmetric


def tidy(t, kind, data, torque=None, cuts=(), duplicate_times="error"):
    """``(times, data, labels, notes)`` the one path hands on for these samples, given in chunks cut at ``cuts``
    (labels ``sample k``)."""
    t, data = np.asarray(t, dtype=float), np.asarray(data, dtype=float)
    edges = [0, *cuts, t.size]

    def chunks():
        for a, b in itertools.pairwise(edges):
            tau = None if torque is None else np.asarray(torque, dtype=float)[a:b]
            yield LogChunk(t[a:b], data[a:b], tau, np.arange(a, b))

    stream = LogStream("s", kind, 0, torque is not None, "sample", chunks)
    checked_stream(stream, ReadOptions(duplicate_times=duplicate_times))
    parts = list(stream.chunks())
    cat = [np.concatenate([getattr(c, f) for c in parts]) for f in ("t", "data", "labels")]
    return (*cat, stream.notes)


def test_exact_duplicates_are_dropped_also_with_the_quaternion_negated():
    q = Rotation.random(4, random_state=3).as_quat()
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.2, 0.3])
    data = np.array([q[0], q[1], -q[1], q[2], q[2], q[3]])
    for cuts in [(), (2,), (4,), (1, 2, 3, 4, 5)]:  # duplicates inside a chunk or straddling two
        _, d_out, labels, notes = tidy(t, "quaternion", data, cuts=cuts)
        np.testing.assert_array_equal(labels, [0, 1, 3, 5])
        np.testing.assert_array_equal(d_out, q)
        assert notes == ["dropped 2 duplicated sample(s) (same time, same attitude)"]


def test_a_missing_sample_at_the_time_of_a_valid_one_gives_way_to_it():
    q = Rotation.random(2, random_state=4).as_quat()
    t = np.array([0.0, 0.1, 0.1])
    for first, cuts in [([np.nan] * 4, ()), ([np.nan] * 4, (2,)), (q[1], (2,))]:
        data = np.array([q[0], first, [np.nan] * 4 if np.all(np.isfinite(first)) else q[1]])
        _, d_out, labels, _ = tidy(t, "quaternion", data, cuts=cuts)
        np.testing.assert_array_equal(d_out, q)  # the valid one stands, wherever the chunk boundary is
        assert labels.size == 2


def test_conflicting_duplicates_are_refused_naming_both_samples_and_the_angle():
    R = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.01], [0, 0, 0.03]]).as_matrix()
    t = np.array([0.0, 0.1, 0.1])
    for cuts in [(), (2,)]:
        with pytest.raises(LogFormatError, match=r"^s, sample 1 and sample 2: two samples at the same time 0\.1 with "):
            tidy(t, "matrix", R, cuts=cuts)
    with pytest.raises(LogFormatError, match=r"attitudes 1\.146° apart"):
        tidy(t, "matrix", R)


def test_conflicting_duplicates_message_offers_the_way_through():
    R = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.01], [0, 0, 0.03]]).as_matrix()
    with pytest.raises(LogFormatError, match=r"pass --duplicate-times first or last \(duplicate_times= in Python\)"):
        tidy([0.0, 0.1, 0.1], "matrix", R)
    with pytest.raises(ValueError, match=r"duplicate times must be one of error, first, last; got 'middle'"):
        ReadOptions(duplicate_times="middle")


@pytest.mark.parametrize("choice", ["first", "last"])
def test_conflicting_duplicates_keep_the_first_or_last_counted_with_the_largest_angle(choice):
    """Times 0.1 (three samples: two differ by 0.5°, the third is the same as the first) and 0.3 (two differ by 2°):
    ``first`` keeps the first sample of each time, ``last`` the last, wherever the chunks are cut; exact
    duplicates are counted as before; the note names the largest difference, its angle from SciPy."""
    rv = np.zeros((7, 3))
    rv[:, 2] = [0.0, 0.10, 0.10 + np.radians(0.5), 0.10, 0.20, 0.30, 0.30 + np.radians(2.0)]
    rv[:, 0] = np.arange(7) * 0.01  # every attitude distinct but the exact duplicate below
    rv[3] = rv[1]
    q = Rotation.from_rotvec(rv).as_quat()
    t = np.array([0.0, 0.1, 0.1, 0.1, 0.2, 0.3, 0.3])
    kept = [0, 1, 4, 5] if choice == "first" else [0, 3, 4, 6]
    dropped_exact = 1 if choice == "first" else 0  # "last": sample 3 is compared with sample 2, which it is not
    angle = Rotation.from_rotvec(rv[6]).inv() * Rotation.from_rotvec(rv[5])
    for cuts in [(), (2,), (3,), (6,), (1, 2, 3, 4, 5, 6)]:
        t_out, d_out, labels, notes = tidy(t, "quaternion", q, cuts=cuts, duplicate_times=choice)
        np.testing.assert_array_equal(labels, kept, err_msg=str(cuts))
        np.testing.assert_array_equal(d_out, q[kept])
        np.testing.assert_array_equal(t_out, t[kept])
        conflict_note = notes[-1]
        assert conflict_note.startswith(
            f"--duplicate-times {choice}: kept the {choice} sample at each of 2 time(s) whose samples differ, "
            f"dropped {3 - dropped_exact}; the largest difference: s, sample 5 and sample 6, time 0.3, attitudes "
        ), (cuts, notes)
        shown = float(conflict_note.split("attitudes ")[1].split("°")[0])
        assert shown == pytest.approx(np.degrees(angle.magnitude()), rel=1e-3)
        assert len(notes) == 1 + dropped_exact


def test_with_first_an_exact_copy_after_a_conflict_is_still_a_duplicate():
    q = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.1], [0, 0, 0.2], [0, 0, 0.1], [0, 0, 0.3]]).as_quat()
    _, _, labels, notes = tidy([0.0, 0.1, 0.1, 0.1, 0.2], "quaternion", q, duplicate_times="first")
    np.testing.assert_array_equal(labels, [0, 1, 4])
    assert notes[0] == "dropped 1 duplicated sample(s) (same time, same attitude)"
    assert "kept the first sample at each of 1 time(s) whose samples differ, dropped 1;" in notes[1]


def test_conflicting_torques_at_one_time_are_refused():
    R = np.repeat(np.eye(3)[None], 2, axis=0)
    with pytest.raises(LogFormatError, match="different torques"):
        tidy([1.0, 1.0], "matrix", R, np.array([[0, 0, 0], [0, 0, 1.0]]))


def test_times_must_not_go_back_and_streams_are_sorted_by_their_readers():
    q = Rotation.random(3, random_state=5).as_quat()
    t = np.array([0.0, 0.2, 0.1])
    for cuts in [(), (2,)]:
        with pytest.raises(LogFormatError, match=r"s, sample 2, column t: time 0\.1 is not after 0\.2 \(sample 1\)"):
            tidy(t, "quaternion", q, cuts=cuts)
    order, n_late = sort_by_time(t)
    np.testing.assert_array_equal(order, [0, 2, 1])
    assert n_late == 1
    order, n_late = sort_by_time(np.array([3, 1, 1, 2, 0]))  # stable: equal stamps keep arrival order
    np.testing.assert_array_equal(order, [4, 1, 2, 3, 0])
    assert n_late == 4


def test_non_finite_time_is_refused():
    with pytest.raises(LogFormatError, match="s, sample 1, column t: time nan is not finite"):
        tidy([0.0, np.nan], "matrix", np.zeros((2, 3, 3)))


def test_every_format_gets_the_policy_csv_and_npz_too(tmp_path):
    """The policy runs in the one path, so omegahat's own logs get it as bags and exports do."""
    q = Rotation.random(3, random_state=6).as_quat()
    rows = [(0.0, q[0]), (0.1, q[1]), (0.1, -q[1]), (0.2, q[2])]
    text = "t,qx,qy,qz,qw\n" + "".join(f"{t!r},{','.join(repr(float(v)) for v in x)}\n" for t, x in rows)
    (tmp_path / "d.csv").write_text(text)
    log = read_log(tmp_path / "d.csv")
    np.testing.assert_array_equal(log.t, [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(log.labels, [2, 3, 5])  # line numbers of the kept rows
    assert "dropped 1 duplicated sample(s) (same time, same attitude)" in log.notes
    np.savez(tmp_path / "d.npz", t=np.array([t for t, _ in rows]), q=np.array([x for _, x in rows]))
    np.testing.assert_array_equal(read_log(tmp_path / "d.npz").labels, [0, 1, 3])
    np.savez(tmp_path / "c.npz", t=np.array([0.0, 0.1, 0.1]), q=q)
    with pytest.raises(LogFormatError, match=r"c\.npz, index 1 and index 2: two samples at the same time"):
        read_log(tmp_path / "c.npz")


def _rms_error(t, W, truth, t_from):
    sel = t >= t_from
    return float(np.sqrt(np.mean(np.sum((W[sel] - truth[sel]) ** 2, axis=1)) / 3))


def test_jitter_dropped_frames_and_duplicates_leave_the_rate_unchanged_within_noise():
    """A 100 Hz attitude stream with 1 mrad noise (exact torque-free motion, J known), logged cleanly and as
    network-delivered mocap is: ±30 % jitter of the capture times, 10 % of the frames dropped, 5 % delivered
    twice (half of them with the quaternion negated), rows out of order. The rate estimated from both agrees
    with the truth to the noise level the gain design predicts, and the two errors are alike."""
    rng = np.random.default_rng(20240501)
    rate, sigma, duration = 100.0, 1e-3, 60.0
    h = 1.0 / rate
    gains = sensor_gains(J_AXI, rate, sigma, bandwidth_hz=1.0)
    predicted = float(np.sqrt(np.mean(predicted_noise_std(J_AXI, gains, rate, sigma) ** 2)))

    t_clean = h * np.arange(int(duration * rate))
    R, omega = torque_free_axisymmetric(t_clean)
    clean = pd.DataFrame(Rotation.from_matrix(noisy(R, sigma, rng)).as_quat(), columns=["qx", "qy", "qz", "qw"])
    clean["t"] = t_clean
    W_clean = estimate_frame(clean, gains=gains, inertia=J_AXI)[["wx", "wy", "wz"]].to_numpy()

    t_j = t_clean + rng.uniform(-0.3 * h, 0.3 * h, t_clean.size)
    t_j = t_j[rng.random(t_j.size) >= 0.10]  # dropped frames
    Rj, omega_j = torque_free_axisymmetric(t_j)
    qj = Rotation.from_matrix(noisy(Rj, sigma, rng)).as_quat()
    dup = np.flatnonzero(rng.random(t_j.size) < 0.05)
    sign = np.where(rng.random(dup.size) < 0.5, -1.0, 1.0)[:, None]
    t_all = np.concatenate([t_j, t_j[dup]])
    q_all = np.concatenate([qj, sign * qj[dup]])
    truth_all = np.concatenate([omega_j, omega_j[dup]])
    order = rng.permutation(t_all.size)  # rows in any order: estimate_frame sorts them
    jittery = pd.DataFrame(q_all[order], columns=["qx", "qy", "qz", "qw"])
    jittery["t"] = t_all[order]
    W_j = estimate_frame(jittery, gains=gains, inertia=J_AXI)[["wx", "wy", "wz"]].to_numpy()

    err_clean = _rms_error(t_clean, W_clean, omega, 5.0)
    err_j = _rms_error(t_all[order], W_j, truth_all[order], 5.0)
    assert 0.8 * predicted < err_clean < 1.25 * predicted, (err_clean, predicted)
    assert 0.8 * predicted < err_j < 1.25 * predicted, (err_j, predicted)
    assert 0.8 < err_j / err_clean < 1.25, (err_j, err_clean)
    # the duplicated rows got exactly the estimate of the row kept in their place
    back = np.argsort(order)
    W_rows = W_j[back]
    np.testing.assert_array_equal(W_rows[t_j.size :], W_rows[dup])


def test_tum_ground_truth_with_a_conflicting_stamp_through_the_command(tmp_path, capsys):
    """As in TUM's fr2_desk ground truth: absolute stamps (1.3e9 s, 4 decimals) and one stamp written twice with
    poses 0.61° apart. By default the command stops naming both lines and the option; with ``first`` the output
    is, bit for bit, that of the file without the second line; with ``last``, that of the file without the first."""
    from omegahat.cli import main
    from recording_files import read_omega_csv
    from vendor_files import decimal_seconds, write_tum

    t = np.arange(300) / 100.0
    R, _ = torque_free_axisymmetric(t)
    q = Rotation.from_matrix(R).as_quat()
    extra = (Rotation.from_quat(q[150]) * Rotation.from_rotvec([0.0, np.radians(0.61), 0.0])).as_quat()
    stamps = decimal_seconds(1311868163, t + 0.8697, decimals=4)
    both = write_tum(
        tmp_path / "gt.txt", [*stamps[:151], stamps[150], *stamps[151:]], np.vstack([q[:151], extra, q[151:]])
    )
    first = write_tum(tmp_path / "first.txt", stamps, q)
    last = write_tum(tmp_path / "last.txt", stamps, np.vstack([q[:150], extra, q[151:]]))
    cli = ["--inertia", "1", "1", "1.6", "--no-progress"]

    def run(path, *opts):
        out = tmp_path / f"{path.stem}-{'-'.join(opts) or 'plain'}.csv"
        code = main(["estimate", str(path), "-o", str(out), *cli, *opts])
        return code, out, capsys.readouterr()

    code, out, printed = run(both)
    assert code == 2 and not out.exists()
    # lines: 2 comments, then the samples; sample 150 is on line 153, its twin on line 154
    assert "gt.txt, line 153 and line 154: two samples at the same time 1311868165.3697 with" in printed.err
    assert "attitudes 0.61° apart" in printed.err and "--duplicate-times first or last" in printed.err
    for choice, reference in (("first", first), ("last", last)):
        code, out, printed = run(both, "--duplicate-times", choice)
        assert code == 0, printed.err
        assert (
            f"note: --duplicate-times {choice}: kept the {choice} sample at each of 1 time(s) whose samples differ, "
            "dropped 1; the largest difference: " in printed.out
        )
        assert "gt.txt, line 153 and line 154, time 1311868165.3697, attitudes 0.61° apart" in printed.out
        code, ref_out, _ = run(reference)
        assert code == 0
        np.testing.assert_array_equal(read_omega_csv(out)[0], read_omega_csv(ref_out)[0])


def test_estimate_frame_keeps_the_last_and_gives_the_dropped_row_its_estimate():
    t = np.arange(200) / 100.0
    R, _ = torque_free_axisymmetric(t)
    q = Rotation.from_matrix(R).as_quat()
    df = pd.DataFrame(q, columns=["qx", "qy", "qz", "qw"])
    df["t"] = t
    twin = df.iloc[[100]].copy()
    twin[["qx", "qy", "qz", "qw"]] = (Rotation.from_quat(q[100]) * Rotation.from_rotvec([0.01, 0, 0])).as_quat()
    doubled = pd.concat([df.iloc[:101], twin, df.iloc[101:]], ignore_index=True)
    with pytest.raises(LogFormatError, match=r"row 100 and row 101: two samples at the same time"):
        estimate_frame(doubled, inertia=J_AXI)
    with pytest.warns(UserWarning, match=r"--duplicate-times last: kept the last sample at each of 1 time\(s\)"):
        W = estimate_frame(doubled, inertia=J_AXI, duplicate_times="last")[["wx", "wy", "wz"]].to_numpy()
    clean = pd.concat([df.iloc[:100], twin, df.iloc[101:]], ignore_index=True)
    W_ref = estimate_frame(clean, inertia=J_AXI)[["wx", "wy", "wz"]].to_numpy()
    np.testing.assert_array_equal(np.delete(W, 100, axis=0), W_ref)
    np.testing.assert_array_equal(W[100], W[101])


def _turning_csv(path, times_text):
    """A CSV log of a body turning at 1 rad/s about z whose ``t`` column is ``times_text`` (one string per row)."""
    n = len(times_text)
    q = Rotation.from_rotvec(np.outer(np.arange(n) / 89.76, [0.0, 0.0, 1.0])).as_quat(scalar_first=True)
    rows = [f"{s},{a:.9f},{b:.9f},{c:.9f},{d:.9f}" for s, (a, b, c, d) in zip(times_text, q, strict=True)]
    path.write_text("t,qw,qx,qy,qz\n" + "\n".join(rows) + "\n")
    return path


def test_stamps_rounded_to_significant_digits_are_named_as_the_cause_and_the_rate_reads_them(tmp_path, capsys):
    """As in RepoIMU's CSVs: rows of an 89.76 Hz clock with 2 ms of jitter, stamps written with 5 significant
    digits (``%.5g``), so 0.001 s apart below 100 s and 0.01 s apart above, where two rows come to share a stamp.
    The command says the stamps were rounded onto each other (not a broken clock) and gives the rows' mean rate;
    following its advice, every row is read, at that rate."""
    from omegahat.cli import main
    from recording_files import read_omega_csv

    true_t = np.arange(12_000) / 89.76 + np.random.default_rng(5).uniform(-0.002, 0.002, 12_000)
    log = _turning_csv(tmp_path / "rounded.csv", [f"{x:.5g}" for x in true_t])
    stamps = np.array([float(f"{x:.5g}") for x in true_t])
    first = int(np.flatnonzero(np.diff(stamps) == 0)[0])  # reference: the first two rows sharing a stamp
    code = main(["estimate", str(log), "-o", str(tmp_path / "out.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2
    assert f"line {first + 2} and line {first + 3}: two samples at the same time {float(stamps[first])!r}" in err
    most = max(len(text.split(".")[1]) for text in (f"{x:.5g}" for x in true_t) if "." in text)  # 6: 0.012373
    assert f"lose decimals as they grow ({most} early on, 2 at {float(stamps[first])!r}: a step of 0.01 s)" in err
    rate = float(err.split("--rate ")[1].split()[0])
    assert rate == pytest.approx(89.76, rel=1e-3)
    columns = "qw=qw,qx=qx,qy=qy,qz=qz"
    code = main(["estimate", str(log), "-o", str(tmp_path / "out.csv"), "--columns", columns, "--rate", str(rate)])
    assert code == 0, capsys.readouterr().err
    table, status = read_omega_csv(tmp_path / "out.csv")
    assert table.shape[0] == true_t.size and set(status) <= {"corrected", "predicted"}
    np.testing.assert_allclose(table[:, 0], np.arange(true_t.size) / rate, rtol=1e-9)
    # the body turns 1/89.76 rad per row: 1 rad/s at the true rate, rate/89.76 at the one given
    assert np.abs(table[true_t.size // 2 :, 1:] - [0.0, 0.0, rate / 89.76]).max() < 2e-3


def test_a_conflicting_stamp_in_fixed_decimals_is_not_called_rounding(tmp_path, capsys):
    """Times written with the same two decimals throughout (a regular 100 Hz clock): a row written twice with
    another attitude is the broken time source of the usual message, whatever the step."""
    from omegahat.cli import main

    times = [f"{k / 100:.2f}" for k in range(600)]
    log = _turning_csv(tmp_path / "fixed.csv", [*times[:301], times[300], *times[301:-1]])
    code = main(["estimate", str(log), "-o", str(tmp_path / "out.csv"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2
    assert "two samples at the same time 3.0 with" in err and "broken time source" in err
    assert "lose decimals" not in err and "--rate" not in err


@pytest.mark.parametrize(
    ("column", "stamps", "said"),
    [
        (
            "time_ms",
            [1_700_000_001_980, 1_700_000_001_990, 1_700_000_001_945],
            "time 1700000001945 is not after 1700000001990",
        ),
        (
            "t",
            [1_700_000_001.98, 1_700_000_001.99, 1_700_000_001.945],
            "time 1700000001.945 is not after 1700000001.99",
        ),
    ],
)
def test_a_time_that_goes_back_is_quoted_as_the_file_writes_it(tmp_path, column, stamps, said):
    """The message added a time already in seconds to the file's base in milliseconds ("1700000000001.945 is not
    after 1700000000001.99"), and float noise to decimal ones ("1700000001.9900000000000002")."""
    q = Rotation.from_rotvec(np.outer(np.arange(40) * 0.01, [0.3, -0.2, 0.5])).as_quat()
    times = [stamps[0] - (stamps[1] - stamps[0]) * k for k in range(37, 0, -1)] + stamps
    path = tmp_path / "back.csv"
    rows = [f"{t!r},{x!r},{y!r},{z!r},{w!r}" for t, (x, y, z, w) in zip(times, q.tolist(), strict=True)]
    path.write_text(f"{column},qx,qy,qz,qw\n" + "\n".join(rows) + "\n")
    with pytest.raises(LogFormatError, match=f"line 41, column {column}: {said} \\(line 40\\)"):
        read_log(path)
