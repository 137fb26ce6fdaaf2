"""The sampled estimator's options of issue 13: the torque hold, the isotropic (geometry-aware) rate gain and the
aim of the correction, each against a closed form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.reference import aim_step
from omegahat.observer.tuning import bandwidth_gains


def _spin_with_ramp_torque(times, J3, w0, a, b):
    """Spin about the principal axis z under ``τ_z = a + b t``: ``J₃ ω̇ = τ`` (no gyroscopic term), so
    ``ω(t) = w0 + (a t + b t²/2)/J₃`` and the angle ``θ(t) = w0 t + (a t²/2 + b t³/6)/J₃``."""
    omega = w0 + (a * times + b * times**2 / 2) / J3
    theta = w0 * times + (a * times**2 / 2 + b * times**3 / 6) / J3
    R = Rotation.from_rotvec(theta[:, None] * np.array([0.0, 0.0, 1.0])).as_matrix()
    return R, omega


@pytest.mark.parametrize("hold", ["zero", "linear"])
def test_torque_hold_against_a_ramp(hold):
    J = np.diag([1.0, 2.0, 3.0])
    times = 0.1 * np.arange(51)
    a, b = 0.3, 0.6
    R, omega = _spin_with_ramp_torque(times, 3.0, 0.5, a, b)
    taus = np.zeros((times.size, 3))
    taus[:, 2] = a + b * times
    est = SarrasEstimator(
        J, gains=bandwidth_gains(J, 5.0 / (2 * np.pi)), omega_hat0=[0.0, 0.0, 0.5], warm_start=False, torque_hold=hold
    )
    err = np.abs(est.run(times, R, taus).omega[:, 2] - omega).max()
    if hold == "linear":  # the line through the two samples is the torque: RK4 and RKMK4 are then exact
        assert err < 1e-10
    else:  # held, the prediction misses b h² / (2 J₃) = 1e-3 per interval before the correction
        assert err > 1e-4


def test_torque_hold_is_checked():
    with pytest.raises(ValueError, match=r"torque_hold must be one of zero, linear; got 'cubic'"):
        SarrasEstimator(np.eye(3), gains=bandwidth_gains(np.eye(3), 1.0), torque_hold="cubic")


def _one_step_map(est_factory, w, h, references):
    """The linearised one-sample error map z ↦ z⁺ from exact directions of a constant rate (J = I)."""
    times = np.array([0.0, h])
    R = Rotation.from_rotvec(times[:, None] * w).as_matrix()
    b = np.einsum("tji,kj->tki", R, references)  # b_k = Rᵀ v_k
    cols = []
    for e in np.eye(3):
        z = 1e-6 * e
        cols.append((est_factory(w + z).run(times, b).omega[1] - w) / 1e-6)
    return np.array(cols).T


def _right_jacobian(phi):
    th = np.linalg.norm(phi)
    P = np.array([[0, -phi[2], phi[1]], [phi[2], 0, -phi[0]], [-phi[1], phi[0], 0]])
    return np.eye(3) - (1 - np.cos(th)) / th**2 * P + (th - np.sin(th)) / th**3 * P @ P


def test_isotropic_gain_gives_every_mode_the_requested_rate():
    """Two directions 27° apart (gravity and a mid-latitude magnetic field). With the observer's gain J⁻¹ and equal
    k the modes differ 17-fold; with ``isotropic_rate = b`` the map is ``(I + b h J_r)⁻¹`` (closed form: J = I,
    constant ω, Γ = h J_r), every mode contracting as 1/(1 + b h) to O(h|ω|)."""
    g = np.array([0.0, 0.0, 1.0])
    m = np.array([np.sin(np.radians(27.0)), 0.0, np.cos(np.radians(27.0))])
    V = np.array([g, m])
    w, h, b = np.array([0.02, -0.01, 0.03]), 0.01, 5.0
    gains = ObserverGains.constant(1.0, 50.0, n=2)

    def iso(w0):
        return SarrasEstimator(np.eye(3), gains=gains, references=V, omega_hat0=w0, isotropic_rate=b)

    A = _one_step_map(iso, w, h, V)
    expected = np.linalg.inv(np.eye(3) + b * h * _right_jacobian(h * w))
    np.testing.assert_allclose(A, expected, atol=1e-5)
    rates = np.abs(1.0 / np.linalg.eigvals(A) - 1.0) / h  # the per-mode decay rate, rad/s
    assert rates.max() / rates.min() < 1.01

    plain = bandwidth_gains(np.eye(3), b / (2 * np.pi), references=V)

    def default(w0):
        return SarrasEstimator(np.eye(3), gains=plain, references=V, omega_hat0=w0)

    rates_plain = np.abs(1.0 / np.linalg.eigvals(_one_step_map(default, w, h, V)) - 1.0) / h
    assert rates_plain.min() == pytest.approx(b, rel=0.05)  # the rule sets the slowest mode
    assert rates_plain.max() / rates_plain.min() > 15  # and the others run about 17 times faster


def test_aim_integrates_the_linearised_error_dynamics():
    """Γ of (A1) against the 6×6 transition of δθ̇ = −ω̂×δθ + δω, δω̇ = Aδω by SciPy's expm: Γ = Φ_θω Φ_ωω⁻¹, over
    a turn of 2 rad at constant ω̂ (J = I: A = 0) and with gyroscopic coupling (J = diag(3, 2, 1), ω̂ frozen)."""
    for J, w in [(np.eye(3), np.array([1.2, -1.0, 1.1])), (np.diag([3.0, 2.0, 1.0]), np.array([0.4, -0.3, 0.5]))]:
        J_inv = np.linalg.inv(J)
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        A = J_inv @ (np.cross(J @ w, np.eye(3), axis=0) - W @ J)  # (Jω)× − ω× J, column by column
        F = np.block([[-W, np.eye(3)], [np.zeros((3, 3)), A]])
        h, n = 1.0, 200
        Phi = expm(F * h)
        exact = Phi[:3, 3:] @ np.linalg.inv(Phi[3:, 3:])
        G = np.zeros((3, 3))
        for _ in range(n):
            G = aim_step(G, w, J, J_inv, h / n)
        assert np.abs(G - exact).max() < 1e-4 * np.abs(exact).max()
        assert np.abs(exact - h * np.eye(3)).max() > 0.1  # far from the unaimed h I


def test_sensor_gains_for_two_directions_give_the_noise_they_predict():
    """Gravity and a mid-latitude field (27° apart) at 100 Hz, attitude noise 1 mrad, b = 2 Hz: ``sensor_gains``
    chooses the isotropic gain; the simulated noise of ω̂ matches ``predicted_noise_std`` (the discrete Lyapunov
    solution, an independent computation) and is far below the J⁻¹ design's at the same bandwidth, whose fast
    modes carry 17 times the noise."""
    from omegahat.observer.tuning import predicted_noise_std, sensor_gains

    V = np.array([[0.0, 0.0, 1.0], [np.sin(np.radians(27.0)), 0.0, np.cos(np.radians(27.0))]])
    rate, sigma, w = 100.0, 1e-3, np.array([0.3, -0.2, 0.1])
    gains = sensor_gains(np.eye(3), rate, sigma, bandwidth_hz=2.0, references=V)
    assert gains.isotropic_rate == pytest.approx(np.expm1(2 * np.pi * 2.0 / rate) * rate)
    times = np.arange(20_000) / rate
    R = Rotation.from_rotvec(times[:, None] * w) * Rotation.from_rotvec(
        np.random.default_rng(1).normal(0.0, sigma, (times.size, 3))
    )  # R_meas = R exp(δ×)
    b = np.einsum("tji,kj->tki", R.as_matrix(), V)
    est = SarrasEstimator(np.eye(3), gains=gains, references=V, omega_hat0=w, warm_start=False)
    measured = (est.run(times, b).omega - w)[2000:].std(axis=0)
    predicted = predicted_noise_std(np.eye(3), gains, rate, sigma, V)
    np.testing.assert_allclose(measured, predicted, rtol=0.1)
    plain = ObserverGains(k=gains.k, l_offset=gains.l_offset)  # the same k, the observer's J⁻¹ gain
    assert np.linalg.norm(predicted_noise_std(np.eye(3), plain, rate, sigma, V)) > 3 * np.linalg.norm(predicted)
