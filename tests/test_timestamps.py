"""The timestamp policy (omegahat.io.timestamps): duplicates dropped or refused, order, and jittery logs with
dropped frames giving the same rate as a clean log within the noise."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.spatial.transform import Rotation

from omegahat import estimate_frame
from omegahat.io import LogFormatError, tidy_samples
from omegahat.observer.tuning import predicted_noise_std, sensor_gains
from recording_files import J_AXI, noisy, torque_free_axisymmetric


def label(k):
    return f"sample {k}"


def test_exact_duplicates_are_dropped_also_with_the_quaternion_negated():
    q = Rotation.random(4, random_state=3).as_quat()
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.2, 0.3])
    data = np.array([q[0], q[1], -q[1], q[2], q[2], q[3]])
    r = tidy_samples(t, "quaternion", data, label=label, sort=False)
    np.testing.assert_array_equal(r.keep, [0, 1, 3, 5])
    np.testing.assert_array_equal(r.source_of, [0, 1, 1, 2, 2, 3])
    assert r.n_duplicates == 2
    assert r.notes() == ["dropped 2 duplicated sample(s) (same time, same attitude)"]


def test_a_missing_sample_at_the_time_of_a_valid_one_gives_way_to_it():
    q = Rotation.random(2, random_state=4).as_quat()
    t = np.array([0.0, 0.1, 0.1])
    data = np.array([q[0], [np.nan] * 4, q[1]])
    r = tidy_samples(t, "quaternion", data, label=label, sort=False)
    np.testing.assert_array_equal(r.keep, [0, 2])
    np.testing.assert_array_equal(r.source_of, [0, 1, 1])


def test_conflicting_duplicates_are_refused_naming_both_samples_and_the_angle():
    R = Rotation.from_rotvec([[0, 0, 0], [0, 0, 0.01], [0, 0, 0.03]]).as_matrix()
    t = np.array([0.0, 0.1, 0.1])
    with pytest.raises(LogFormatError, match=r"sample 1 and sample 2: two samples at the same time 0\.1 with "):
        tidy_samples(t, "matrix", R, label=label, sort=False)
    with pytest.raises(LogFormatError, match=r"attitudes 1\.146° apart"):
        tidy_samples(t, "matrix", R, label=label, sort=False)


def test_conflicting_torques_at_one_time_are_refused():
    R = np.repeat(np.eye(3)[None], 2, axis=0)
    with pytest.raises(LogFormatError, match="different torques"):
        tidy_samples(np.array([1, 1]), "matrix", R, np.array([[0, 0, 0], [0, 0, 1.0]]), label=label, sort=True)


def test_exports_must_be_in_time_order_and_streams_are_sorted():
    q = Rotation.random(3, random_state=5).as_quat()
    t = np.array([0.0, 0.2, 0.1])
    with pytest.raises(LogFormatError, match=r"sample 2: time 0\.1 is before 0\.2 \(sample 1\)"):
        tidy_samples(t, "quaternion", q, label=label, sort=False)
    r = tidy_samples(t, "quaternion", q, label=label, sort=True)
    np.testing.assert_array_equal(r.keep, [0, 2, 1])
    np.testing.assert_array_equal(r.source_of, [0, 2, 1])
    assert r.n_reordered == 1
    assert "1 sample(s) arrived after a later-stamped one: sorted by time" in r.notes()


def test_non_finite_time_is_refused():
    with pytest.raises(LogFormatError, match="sample 1: time nan is not finite"):
        tidy_samples(np.array([0.0, np.nan]), "matrix", np.zeros((2, 3, 3)), label=label, sort=True)


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
    W_clean = estimate_frame(clean, gains=gains, inertia=J_AXI).to_numpy()

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
    W_j = estimate_frame(jittery, gains=gains, inertia=J_AXI).to_numpy()

    err_clean = _rms_error(t_clean, W_clean, omega, 5.0)
    err_j = _rms_error(t_all[order], W_j, truth_all[order], 5.0)
    assert 0.8 * predicted < err_clean < 1.25 * predicted, (err_clean, predicted)
    assert 0.8 * predicted < err_j < 1.25 * predicted, (err_j, predicted)
    assert 0.8 < err_j / err_clean < 1.25, (err_j, err_clean)
    # the duplicated rows got exactly the estimate of the row kept in their place
    back = np.argsort(order)
    W_rows = W_j[back]
    np.testing.assert_array_equal(W_rows[t_j.size :], W_rows[dup])
