"""Gains for noisy sampled sensors: the bandwidth is what was asked, and the predicted noise matches simulated
noisy runs."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.tuning import predicted_noise_std, sensor_gains


def test_isotropic_prediction_equals_the_closed_form():
    """J = I, three orthogonal directions: J⁻¹M = 2k I, and the Lyapunov solution must equal (N)."""
    rate, sigma = 50.0, 2e-3
    g = sensor_gains(np.eye(3), rate, sigma, bandwidth_hz=3.0)
    h = 1 / rate
    a = h * 2 * g.k[0]
    gg = 1 / (1 + a)
    closed = sigma * (a / h) / (1 + a) * np.sqrt(2 / (1 + gg))
    np.testing.assert_allclose(predicted_noise_std(np.eye(3), g, rate, sigma), closed, rtol=1e-10)


def test_bandwidth_formula():
    g = sensor_gains(np.diag([3.0, 2.0, 1.0]), 100.0, 1e-3, convergence_time=0.5)
    # (K): the slowest mode λ = μ₁ k / J_M with μ₁ = 2 (three rows): per-sample contraction exp(−h/0.5)
    assert 1 / (1 + 0.01 * 2 * g.k[0] / 3.0) == pytest.approx(np.exp(-0.01 / 0.5), rel=1e-12)
    assert np.all(g.l_offset == 10 * g.k / 1.0)
    g_acc = sensor_gains(np.eye(3), 100.0, 1e-4, angular_accel=4.0)
    g_bw = sensor_gains(np.eye(3), 100.0, 1e-4, bandwidth_hz=np.sqrt(4.0 / 1e-4) / (2 * np.pi))
    np.testing.assert_allclose(g_acc.k, g_bw.k, rtol=1e-12)


def test_errors_are_named():
    with pytest.raises(ValueError, match=r"exactly one of bandwidth_hz, convergence_time or angular_accel; got none"):
        sensor_gains(np.eye(3), 100.0, 1e-3)
    with pytest.raises(ValueError, match=r"got bandwidth_hz=1.0, convergence_time=2.0"):
        sensor_gains(np.eye(3), 100.0, 1e-3, bandwidth_hz=1.0, convergence_time=2.0)
    with pytest.raises(ValueError, match=r"bandwidth 60 Hz \(from bandwidth_hz = 60.0\) must be below the Nyquist"):
        sensor_gains(np.eye(3), 100.0, 1e-3, bandwidth_hz=60.0)
    with pytest.raises(ValueError, match=r"measurement_noise must be positive and finite; got \[-1\.\]"):
        sensor_gains(np.eye(3), 100.0, -1.0, bandwidth_hz=1.0)


def _noisy_run(J, w, rate, sigma, gains, T, seed):
    h = 1 / rate
    times = np.arange(T) * h
    R = Rotation.from_rotvec(times[:, None] * w).as_matrix()  # constant rate: exact motion for these bodies
    delta = np.random.default_rng(seed).normal(0.0, sigma, (T, 3))
    R_meas = R @ Rotation.from_rotvec(delta).as_matrix()  # R exp(δ×): noise in body axes
    est = SarrasEstimator(J, gains=gains, omega_hat0=w)
    return est.run(times, R_meas).omega - w


@pytest.mark.parametrize(
    "J, w, rate, bw",
    [
        (np.eye(3), np.array([0.1, -0.2, 0.1]), 100.0, 2.0),
        (np.diag([3.0, 2.0, 1.0]), np.array([0.0, 0.0, 0.3]), 200.0, 1.0),  # spin about a principal axis
        (np.eye(3), np.array([0.1, 0.0, 0.05]), 50.0, 12.0),  # k h / J ≈ 6: far into the implicit regime
    ],
)
def test_predicted_noise_matches_simulation(J, w, rate, bw):
    """Measured per-axis std of ω̂ − ω over 20 000 noisy samples within 5 % of the prediction (the sampling
    error of a std over ~10⁴ correlated samples is a few %; the linearisation neglects h|ω| ≤ 0.006)."""
    sigma = 1e-3
    g = sensor_gains(J, rate, sigma, bandwidth_hz=bw)
    z = _noisy_run(J, w, rate, sigma, g, 20_000, seed=7)
    measured = z[2000:].std(axis=0)
    predicted = predicted_noise_std(J, g, rate, sigma)
    np.testing.assert_allclose(measured, predicted, rtol=0.05)
    # and the trade-off: ten times the bandwidth, (much) more noise
    assert np.all(
        predicted_noise_std(J, sensor_gains(J, rate, sigma, bandwidth_hz=bw / 10), rate, sigma) < predicted / 3
    )


def test_convergence_time_is_met_noise_free():
    J = np.diag([3.0, 2.0, 1.0])
    w = np.array([0.0, 0.0, 0.3])
    tc = 0.2
    g = sensor_gains(J, 100.0, 1e-3, convergence_time=tc)
    times = np.arange(101) * 0.01
    R = Rotation.from_rotvec(times[:, None] * w).as_matrix()
    z0 = np.array([0.01, 0.0, 0.0])  # along the slowest axis (largest inertia)
    z = SarrasEstimator(J, gains=g, omega_hat0=w + z0).run(times, R).omega - w
    # after 1 s = 5 time constants: |z| = 0.01 e^{-5}, to within 10 % (nonlinear terms are O(|z|²))
    assert np.linalg.norm(z[-1]) == pytest.approx(0.01 * np.exp(-1.0 / tc), rel=0.1)


def test_bandwidth_gains_give_the_bandwidth_as_decay_rate_for_an_isotropic_body():
    """J = c I: the continuous linearised error ż = −J⁻¹ M z, M = Σ k (I − v vᵀ), decays at exactly b for three
    rows (all eigenvalues of J⁻¹ M equal b) and at least b for two orthogonal rows (smallest eigenvalue b); the
    argument is in Hz, b = 2π bandwidth_hz rad/s."""
    from omegahat.observer.tuning import bandwidth_gains

    J = 2.5 * np.eye(3)
    for refs, lam_min in ((np.eye(3), 40.0), (np.eye(3)[:2], 40.0)):
        g = bandwidth_gains(J, 40.0 / (2 * np.pi), refs)  # b = 40 rad/s
        M = sum(k * (np.eye(3) - np.outer(v, v)) for k, v in zip(g.k, refs, strict=True))
        assert np.linalg.eigvalsh(M / 2.5)[0] == pytest.approx(lam_min, rel=1e-12)
        np.testing.assert_allclose(g.l_offset, 400.0)
    # three rows: isotropic, every mode at b
    g3 = bandwidth_gains(J, 40.0 / (2 * np.pi))
    np.testing.assert_allclose(np.linalg.eigvalsh(2 * g3.k[0] * np.eye(3) / 2.5), 40.0)
    with pytest.raises(ValueError, match="bandwidth_hz must be positive"):
        bandwidth_gains(J, -1.0)
