"""Automatic gains: each measured quantity against an independent reference (closed forms, NumPy's polyfit)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from logmaker import constant_rate
from omegahat import measurements as ms
from omegahat.observer import autogain


def test_noise_estimate_matches_the_simulated_noise():
    t = np.arange(20000) / 100.0
    for sigma in (1e-3, 5e-5):
        rot = constant_rate(t, [0.1, -0.2, 0.3], sigma=sigma, seed=3)
        motion = autogain.measure_motion(t, rot)
        assert motion.rate_hz == pytest.approx(100.0, rel=1e-12)
        assert motion.sigma == pytest.approx(sigma, rel=0.05)


def test_initial_rate_is_the_least_squares_slope():
    # Rotation about one fixed axis: the angle adds up exactly, so the fit must equal numpy's line fit of the angle.
    rng = np.random.default_rng(0)
    t = np.arange(500) / 50.0
    axis = np.array([1.0, 2.0, 2.0]) / 3.0
    angle = 0.4 * t + rng.normal(0, 1e-3, t.size)
    rot = Rotation.from_rotvec(np.outer(angle, axis))
    w0 = autogain.initial_rate(t, rot, window=4.0)
    n = int(np.searchsorted(t, 4.0, side="right"))
    slope = np.polyfit(t[:n], angle[:n], 1)[0]
    np.testing.assert_allclose(w0, slope * axis, rtol=1e-9, atol=1e-12)


def test_initial_rate_is_moved_to_the_start_with_eulers_equations():
    # Constant angular acceleration about a principal axis under a constant torque (J ω̇ = τ): the fit's mean rate
    # belongs to the window's centre; half a window of Euler's equations brings it back to t0.
    J = np.diag([2.0, 3.0, 4.0])
    tau = np.array([0.0, 0.0, 0.8])  # ω̇ = 0.2 rad/s² about z
    t = np.arange(201) / 100.0
    rot = Rotation.from_rotvec(np.outer(0.5 * t + 0.1 * t**2, [0.0, 0.0, 1.0]))
    w0 = autogain.initial_rate(t, rot, window=2.0, J=J, torque=np.tile(tau, (t.size, 1)))
    np.testing.assert_allclose(w0, [0.0, 0.0, 0.5], atol=1e-9)


def test_lag_of_a_constant_acceleration_is_a_over_bandwidth():
    # (D) is exact for a constant acceleration a: the first-order tracker lags by a / ω_b.
    a = 0.05
    t = np.arange(60000) / 100.0
    rot = Rotation.from_rotvec(np.outer(0.5 * a * t**2, [0.0, 0.6, 0.8]))
    motion = autogain.measure_motion(t, rot)
    for omega_b in (0.5, 2.0, 8.0):
        g = autogain.gains_for_bandwidth(np.eye(3), 100.0, omega_b / (2 * np.pi))
        _, lag, _ = autogain.expected_error(motion, g, omega_b, 600.0, "warm")
        assert lag == pytest.approx(a / omega_b, rel=0.02)


def test_choice_is_below_nyquist_and_explained():
    t = np.arange(3000) / 100.0
    motion = autogain.measure_motion(t, constant_rate(t, [0.1, -0.2, 0.3], sigma=1e-3))
    choice = autogain.choose_gains(motion)
    assert 0 < choice.bandwidth_hz < 50.0
    assert choice.expected == pytest.approx(np.sqrt(choice.noise**2 + choice.lag**2 + choice.startup**2))
    assert min(total for _, total in choice.candidates) == choice.expected
    assert "chosen from the log: 100 Hz samples, attitude noise 0.001 rad" in choice.explain()


def test_bandwidth_at_nyquist_is_refused():
    with pytest.raises(ValueError, match=r"must be below the Nyquist frequency rate_hz / 2 = 50 Hz"):
        autogain.gains_for_bandwidth(np.eye(3), 100.0, 50.0)


def test_sample_status_reports_every_sample_without_raising():
    q = np.array([[0, 0, 0, 1.0], [0, 0, 0, 2.0], [np.nan, 0, 0, 1], [0, 0.6, 0, 0.8]])
    status, info = ms.sample_status(q)
    np.testing.assert_array_equal(status, [ms.OK, ms.QUAT_NORM, ms.MISSING, ms.OK])
    assert info[1] == 2.0
    R = np.stack([np.eye(3), np.diag([1.0, 1.0, -1.0]), 1.01 * np.eye(3)])
    status, info = ms.sample_status(R)
    np.testing.assert_array_equal(status, [ms.OK, ms.NOT_PROPER, ms.NOT_ORTHOGONAL])
    assert info[1] == -1.0
    assert info[2] == pytest.approx(np.sqrt(3) * (1.01**2 - 1), rel=1e-12)
    b = np.array([[[1.0, 0, 0], [0, 1, 0]], [[1.0, 0, 0], [0, 0, 0]], [[1.0, 0, 0], [2.0, 0, 0]]])
    status, info = ms.sample_status(b, directions=True)
    np.testing.assert_array_equal(status, [ms.OK, ms.ZERO_DIRECTION, ms.COLLINEAR])
    with pytest.raises(ValueError, match=r"direction samples must have shape \(T, n, 3\) with n >= 2"):
        ms.sample_status(np.zeros((3, 1, 3)), directions=True)
