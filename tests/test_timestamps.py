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


def tidy(t, kind, data, torque=None, cuts=()):
    """``(times, data, labels, notes)`` the one path hands on for these samples, given in chunks cut at ``cuts``
    (labels ``sample k``)."""
    t, data = np.asarray(t, dtype=float), np.asarray(data, dtype=float)
    edges = [0, *cuts, t.size]

    def chunks():
        for a, b in itertools.pairwise(edges):
            tau = None if torque is None else np.asarray(torque, dtype=float)[a:b]
            yield LogChunk(t[a:b], data[a:b], tau, np.arange(a, b))

    stream = LogStream("s", kind, 0, torque is not None, "sample", chunks)
    checked_stream(stream, ReadOptions())
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
