"""The RotationSpline wrapper equals SciPy's own call, gives the body-frame rate, and bridges gaps."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation, RotationSpline

from omegahat.baselines.spline import SplineEstimator, spline_rate

# Closed form (as in test_differencing): R(t) = Exp(a t) Exp(b t), ω(t) = Exp(−b t) a + b in the body frame.
A = np.array([0.7, -0.3, 0.5])
B = np.array([0.2, 0.9, -0.4])


def rotations(t):
    return Rotation.from_rotvec(np.outer(t, A)) * Rotation.from_rotvec(np.outer(t, B))


def omega(t):
    return Rotation.from_rotvec(-np.outer(t, B)).apply(A) + B


def test_equals_scipys_own_call():
    times = np.sort(np.random.default_rng(0).uniform(0, 3, 80))
    rot = rotations(times)
    ref = RotationSpline(times, rot)(times, 1)
    np.testing.assert_array_equal(SplineEstimator().run(times, rot).omega, ref)
    # Matrices and quaternions go through a conversion: equal to rounding.
    np.testing.assert_allclose(SplineEstimator().run(times, rot.as_matrix()).omega, ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(spline_rate(times, rot.as_quat()), ref, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(
        spline_rate(times, rot.as_quat(scalar_first=True), scalar_first=True), ref, rtol=1e-12, atol=1e-12
    )


def test_is_the_body_frame_rate():
    times = np.arange(0.0, 2.0, 0.01)
    w = spline_rate(times, rotations(times))
    inner = slice(20, -20)
    np.testing.assert_allclose(w[inner], omega(times[inner]), atol=1e-6)
    inertial = rotations(times[inner]).apply(omega(times[inner]))
    assert np.abs(w[inner] - inertial).max() > 0.1  # the inertial-frame rate is clearly different


def test_nan_samples_are_left_out_of_the_fit():
    times = np.linspace(0, 2, 60)
    R = rotations(times).as_matrix()
    R[[5, 30, 31]] = np.nan
    keep = np.ones(60, bool)
    keep[[5, 30, 31]] = False
    ref = RotationSpline(times[keep], Rotation.from_matrix(R[keep]))(times, 1)
    np.testing.assert_array_equal(spline_rate(times, R), ref)


def test_errors():
    est = SplineEstimator()
    assert est.causal is False and est.streaming is False  # offline: the contract gives it run alone
    assert not hasattr(est, "update")
    R = np.full((3, 3, 3), np.nan)
    R[0] = np.eye(3)
    with pytest.raises(ValueError, match="the spline needs at least 2 finite attitude samples; got 1"):
        spline_rate([0.0, 1.0, 2.0], R)
    with pytest.raises(ValueError, match=r"sample 1: time t = 0.0 is not after the previous sample's t = 0.0"):
        spline_rate([0.0, 0.0], np.stack([np.eye(3)] * 2))
