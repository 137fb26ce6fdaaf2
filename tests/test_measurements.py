"""Checked conversion of user input: references from SciPy's own Rotation, errors named, NaN marked missing."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.measurements import (
    COLLINEAR,
    MISSING,
    OK,
    MeasurementError,
    attitude_directions,
    attitude_matrices,
    body_directions,
    checked_log,
    checked_sample,
    checked_times,
)

ROT = Rotation.random(12, random_state=3)


def test_matrices_quaternions_and_rotations_agree_with_scipy():
    R = ROT.as_matrix()
    np.testing.assert_allclose(attitude_matrices(ROT), R, atol=1e-15)
    np.testing.assert_allclose(attitude_matrices(ROT.as_quat()), R, atol=1e-15)
    np.testing.assert_allclose(attitude_matrices(ROT.as_quat(scalar_first=True), scalar_first=True), R, atol=1e-15)
    np.testing.assert_array_equal(attitude_matrices(R), R)


def test_q_and_minus_q_give_the_same_matrix():
    q = ROT.as_quat()
    np.testing.assert_array_equal(attitude_matrices(q), attitude_matrices(-q))


def test_directions_are_R_transpose_v_with_leading_batch_axes():
    V = np.array([[0.0, 0.0, 2.0], [1.0, 1.0, 0.0]])  # normalised on the way in
    q = ROT.as_quat().reshape(3, 4, 4)
    d = attitude_directions(q, V)
    assert d.r.shape == (3, 4, 2, 3) and d.status.shape == (3, 4) and d.valid.all()
    v = V / np.linalg.norm(V, axis=1, keepdims=True)
    expected = np.stack([ROT.inv().apply(v[i]) for i in range(2)], axis=1).reshape(3, 4, 2, 3)  # Rᵀ v_i
    np.testing.assert_allclose(d.r, expected, atol=1e-15)
    # the default references are the three axes: the rows of R
    np.testing.assert_allclose(attitude_directions(ROT[0]).r, ROT[0].as_matrix(), atol=1e-15)


def test_non_finite_samples_are_missing_not_errors():
    q = ROT.as_quat()
    q[3, 1] = np.nan
    q[7, 0] = np.inf
    d = attitude_directions(q)
    assert list(np.flatnonzero(d.status == MISSING)) == [3, 7]
    assert np.isnan(d.r[[3, 7]]).all() and np.isfinite(d.r[d.valid]).all()


def test_not_a_rotation_names_sample_and_error():
    R = ROT.as_matrix()
    R[5] *= 1.01
    err = np.linalg.norm(R[5].T @ R[5] - np.eye(3))  # = √3 (1.01² − 1)
    with pytest.raises(MeasurementError, match=rf"sample 5: not a rotation matrix: \|R\^T R - I\| = {err:.3g}"):
        attitude_matrices(R)
    assert attitude_matrices(R, rotation_tol=0.1).shape == (12, 3, 3)  # accepted with a looser tolerance
    with pytest.raises(MeasurementError, match=r"sample \(1, 2\): a reflection, not a rotation: det R = -1"):
        batch = np.tile(np.eye(3), (2, 3, 1, 1))
        batch[1, 2] = np.diag([1.0, 1.0, -1.0])
        attitude_matrices(batch)


def test_quaternion_far_from_unit_norm():
    q = ROT.as_quat()
    q[2] *= 2.0
    with pytest.raises(MeasurementError, match=r"sample 2: a quaternion far from unit norm: \|q\| = 2\b"):
        attitude_matrices(q)
    q[2] /= 2.0
    q[4] *= 1 + 5e-4  # within the default tolerance 1e-3: accepted and normalised
    np.testing.assert_allclose(attitude_matrices(q)[4], ROT[4].as_matrix(), atol=1e-15)


def test_wrong_shapes_are_named():
    with pytest.raises(
        ValueError, match=r"rotation matrix \(\.\.\., 3, 3\), a quaternion \(\.\.\., 4\).*shape \(5, 3\)"
    ):
        attitude_matrices(np.zeros((5, 3)))
    with pytest.raises(
        ValueError, match=r"direction measurements must have shape \(\.\.\., 2, 3\); got shape \(3, 3\)"
    ):
        body_directions(np.eye(3), n=2)
    with pytest.raises(ValueError, match=r"references must have shape \(n, 3\) with n >= 2; got shape \(3,\)"):
        attitude_directions(ROT, references=[1.0, 0, 0])


def test_body_directions_normalise_flag_collinear_and_reject_zero():
    b = np.array(
        [[[0.0, 0.0, 9.8], [20.0, 0.0, -40.0]], [[0.0, 0.0, 9.8], [0.0, 1e-3, 5.0]], [[np.nan, 0, 1], [1, 0, 0]]]
    )
    d = body_directions(b)
    assert list(d.status) == [OK, COLLINEAR, MISSING]  # second: 0.011° apart (< 1°)
    np.testing.assert_allclose(np.linalg.norm(d.r[0], axis=1), 1.0, rtol=1e-15)
    np.testing.assert_allclose(d.r[0, 1], np.array([1.0, 0, -2.0]) / np.sqrt(5), rtol=1e-15)
    assert body_directions(b[1], min_angle_deg=0.001).status == OK
    with pytest.raises(MeasurementError, match=r"sample 1: measured direction b1 has zero length"):
        body_directions(np.array([[[1.0, 0, 0], [0, 1, 0]], [[0.0, 0, 0], [0, 1, 0]]]))


def test_checked_log_reports_the_first_bad_sample_whatever_is_wrong_with_it():
    times = np.array([0.0, 0.5, 0.25, 1.0])
    R = ROT.as_matrix()[:4]
    R[3] = -R[3]  # a reflection after the time going backwards: the time, at sample 2, is reported
    with pytest.raises(MeasurementError, match=r"^sample 2: time t = 0.25 is not after the previous sample's t = 0.5"):
        checked_log(times, R)
    times[2] = 0.75
    with pytest.raises(MeasurementError, match=r"^sample 3 \(t = 1.0\): a reflection, not a rotation: det R = -1"):
        checked_log(times, R)
    # within one sample: time first, then the torque, then the measurement
    with pytest.raises(MeasurementError, match=r"^the sample: time t = 0.5 is not after the previous sample's t = 1.0"):
        checked_sample(0.5, -np.eye(3), [np.nan, 0, 0], t_prev=1.0)
    with pytest.raises(MeasurementError, match=r"^the sample \(t = 2.0\): torque must be finite; got nan$"):
        checked_sample(2.0, -np.eye(3), [np.nan, 0, 0], t_prev=1.0)


def test_checked_log_continues_a_chunked_log_and_marks_skipped_samples():
    q = ROT.as_quat()[:5]
    q[1, 2] = np.nan
    log = checked_log(np.arange(5.0), q, t_prev=-1.0)
    assert list(log.status) == [OK, MISSING, OK, OK, OK] and list(log.valid) == [True, False, True, True, True]
    assert np.isnan(log.values[1]).all()
    np.testing.assert_allclose(log.values[[0, 2, 3, 4]], ROT[[0, 2, 3, 4]].as_matrix(), atol=1e-15)
    np.testing.assert_array_equal(log.torques, np.zeros((5, 3)))
    with pytest.raises(MeasurementError, match=r"^sample 0: time t = 0.0 is not after the previous sample's t = 0.0"):
        checked_log(np.arange(5.0), q, t_prev=0.0)
    b = np.array([[[0.0, 0.0, 9.8], [20.0, 0.0, -40.0]], [[0.0, 0.0, 9.8], [0.0, 1e-3, 5.0]]])
    log = checked_log([0.0, 0.1], b, references=[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    assert list(log.status) == [OK, COLLINEAR] and np.isnan(log.values[1]).all()
    np.testing.assert_allclose(log.values[0, 1], np.array([1.0, 0, -2.0]) / np.sqrt(5), rtol=1e-15)
    s = checked_sample(0.2, b[0], [1.0, 2.0, 3.0], references=[[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]], t_prev=0.1)
    assert s.status == OK and s.t == 0.2
    np.testing.assert_array_equal(s.torque, [1.0, 2.0, 3.0])
    np.testing.assert_array_equal(s.value, log.values[0])


def test_checked_times_names_the_time():
    np.testing.assert_array_equal(checked_times([0.0, 1.0]), [0.0, 1.0])
    with pytest.raises(MeasurementError, match=r"^times\[1\]: time t = inf is not finite$"):
        checked_times([0.0, np.inf], where="times[{j}]")
    with pytest.raises(ValueError, match=r"^times must have shape \(T,\); got shape \(1, 2\)$"):
        checked_times([[0.0, 1.0]])
