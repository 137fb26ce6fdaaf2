"""Offline peers: Savitzky–Golay on SO(3) against closed forms, and the MEKF's RTS smoother against the batch
maximum a posteriori estimate of the same linear-Gaussian problem (solved directly by least squares)."""

from __future__ import annotations

import numpy as np
import pytest

from omegahat import so3
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.rts import RTSSmoother, smooth_log
from omegahat.baselines.savgol import SavitzkyGolayEstimator, right_jacobian, savgol_rate

W0 = 2.0  # the linear case's prior rate, near the truth: the EKF's first steps then stay linear
AXIS = np.array([0.36, -0.48, 0.8])  # unit


def polynomial_turn(t):
    """Rotation about a fixed axis by θ(t) = 0.7 t − 0.3 t² + 0.05 t³: body rate θ'(t) AXIS exactly."""
    theta = 0.7 * t - 0.3 * t**2 + 0.05 * t**3
    return so3.exp(np.outer(theta, AXIS)), np.outer(0.7 - 0.6 * t + 0.15 * t**2, AXIS)


def test_savgol_is_exact_on_a_cubic_turn_and_not_below_its_order():
    t = np.arange(0.0, 3.0, 0.02)
    R, omega = polynomial_turn(t)
    w3 = savgol_rate(t, R, window=9, order=3)
    inner = slice(4, -4)
    np.testing.assert_allclose(w3, omega, atol=1e-9)  # the ends too: one-sided windows, still a cubic fit
    w2 = savgol_rate(t, R, window=9, order=2)
    assert np.abs(w2[inner] - omega[inner]).max() > 1e-6  # a quadratic cannot follow the cubic's ω̈


def test_savgol_bridges_gaps_and_uneven_times():
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.01, 0.03, 150))
    R, omega = polynomial_turn(t)
    R[[40, 41, 90]] = np.nan
    w = savgol_rate(t, R, window=11, order=3)
    ok = np.isfinite(w[:, 0])
    assert not ok[[40, 41, 90]].any()  # a missing centre has no estimate
    assert ok.sum() == 150 - 3
    np.testing.assert_allclose(w[ok], omega[ok], atol=1e-9)


def test_savgol_on_a_two_axis_motion_converges_at_its_order():
    # R(t) = Exp(a t e_x) Exp(b t e_z): body rate Exp(−b t e_z) a e_x + b e_z (closed form).
    a, b = 1.1, 0.7

    def case(h):
        t = np.arange(0.0, 2.0, h)
        R = so3.exp(np.outer(a * t, [1, 0, 0])) @ so3.exp(np.outer(b * t, [0, 0, 1]))
        omega = np.einsum("tij,j->ti", so3.exp(np.outer(-b * t, [0, 0, 1])), [a, 0, 0]) + np.array([0, 0, b])
        w = savgol_rate(t, R, window=7, order=4)
        return np.nanmax(np.abs(w - omega))

    e1, e2 = case(0.02), case(0.01)
    assert e1 < 1e-6
    assert 12 < e1 / e2 < 20  # fourth order in h: 2⁴ = 16


def test_right_jacobian_against_finite_differences():
    u = np.array([0.3, -1.2, 0.5])
    dv = np.array([0.2, 0.1, -0.4])
    eps = 1e-6
    # d/ds Exp(u + s dv) at 0 = Exp(u) (J_r(u) dv)^ : compare the body-frame rate
    lhs = so3.log(so3.exp(u).T @ so3.exp(u + eps * dv)) / eps
    np.testing.assert_allclose(lhs, right_jacobian(u) @ dv, atol=1e-5)
    np.testing.assert_allclose(right_jacobian(np.zeros(3)), np.eye(3), atol=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"window": 4}, r"window must be an odd integer >= 3; got 4"),
        ({"window": 5, "order": 5}, r"order must be an integer in \[1, window\) = \[1, 5\); got 5"),
    ],
)
def test_savgol_rejects_bad_knobs(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SavitzkyGolayEstimator(**kwargs)
    assert not SavitzkyGolayEstimator().streaming and not hasattr(SavitzkyGolayEstimator(), "update")  # offline


# ------------------------------------------------------------------------------------------------- RTS


def _z_turn_log(T=80, h=0.02, sigma=1e-3, seed=5):
    """Rotation about z at a varying rate, attitude noise about z only: the filter's z-channel is then exactly the
    linear integrated random walk (θ, ω), whose smoother is the batch MAP estimate."""
    rng = np.random.default_rng(seed)
    t = np.arange(T) * h
    theta = 0.8 * t + 0.4 * np.sin(3 * t)
    psi = theta + sigma * rng.standard_normal(T)
    return t, so3.exp(np.outer(psi, [0, 0, 1])), psi


def _batch_map(t, psi, sigma, q, sigma_omega0, omega0):
    """argmin over (θ_k, ω_k) of the negative log posterior of the linear model, by dense least squares:
    prior θ_0 ~ N(ψ_0, σ²), ω_0 ~ N(ω_0 prior, σ_ω0²); x_k = Φ x_{k−1} + w, w ~ N(0, Q); ψ_k = θ_k + v, k ≥ 1."""
    T = t.size
    rows, rhs = [], []

    def row(entries, value, weight):
        r = np.zeros(2 * T)
        for j, c in entries:
            r[j] = c
        rows.append(r * weight)
        rhs.append(value * weight)

    row([(0, 1.0)], psi[0], 1 / sigma)
    row([(1, 1.0)], omega0, 1 / sigma_omega0)
    for k in range(1, T):
        h = t[k] - t[k - 1]
        Q = q * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
        L = np.linalg.cholesky(np.linalg.inv(Q))  # whitening: Lᵀ (x_k − Φ x_{k−1})
        Phi = np.array([[1.0, h], [0.0, 1.0]])
        M = np.zeros((2, 2 * T))
        M[:, 2 * k : 2 * k + 2] = np.eye(2)
        M[:, 2 * k - 2 : 2 * k] = -Phi
        W = L.T @ M
        rows.extend(W)
        rhs.extend([0.0, 0.0])
        row([(2 * k, 1.0)], psi[k], 1 / sigma)
    x = np.linalg.lstsq(np.array(rows), np.array(rhs), rcond=None)[0]
    return x[1::2]


def test_rts_equals_the_batch_map_on_the_linear_case():
    sigma, q, s0 = 1e-3, 4.0, 1.0
    t, R, psi = _z_turn_log(sigma=sigma)
    f = MEKF(None, model="kinematic", q=q, measurement_noise=sigma, omega_hat0=(0, 0, W0), sigma_omega0=s0)
    S = smooth_log(f, t, R)
    reference = _batch_map(t, psi, sigma, q, s0, W0)
    np.testing.assert_allclose(S.omega[:, 2], reference, atol=1e-6)
    np.testing.assert_allclose(S.omega[:, :2], 0.0, atol=1e-9)
    # the filter alone is not the MAP (it sees only the past): the smoother changed the estimate
    assert np.abs(S.omega_filtered[:, 2] - reference).max() > 100 * np.abs(S.omega[:, 2] - reference).max()
    np.testing.assert_allclose(S.omega[-1], S.omega_filtered[-1], atol=1e-15)  # the last sample is the filter's


def test_rts_smoother_beats_its_filter_on_a_noisy_tumble():
    from omegahat.simulation.rigid_body import RigidBody, integrate

    J = np.diag([3.0, 2.0, 1.0])
    t = np.arange(0.0, 20.0, 0.05)
    truth = integrate(RigidBody(J), np.eye(3), [0.4, -0.3, 0.6], t)
    rng = np.random.default_rng(11)
    R_meas = truth.R @ so3.exp(2e-3 * rng.standard_normal((t.size, 3)))
    smoother = RTSSmoother(filter_factory=lambda: MEKF(J, model="dynamic", q=1e-6, measurement_noise=2e-3))
    W = smoother.run(t, R_meas).omega
    e_s = np.sqrt(np.mean(np.sum((W - truth.omega)[100:] ** 2, axis=1)))
    e_f = np.sqrt(np.mean(np.sum((smoother.last.omega_filtered - truth.omega)[100:] ** 2, axis=1)))
    assert e_s < 0.6 * e_f
    assert not smoother.streaming and not hasattr(smoother, "update")  # offline: the contract gives it run alone


def test_rts_stops_on_a_diverged_filter():
    # A filter told the rate is 1e4 rad/s with no doubt left: it predicts turns no sampled attitude can tell apart.
    t = np.arange(0.0, 2.0, 0.1)
    f = MEKF(None, model="kinematic", q=1e-6, measurement_noise=1e-3, omega_hat0=(1e4, 0, 0), sigma_omega0=1e-9)
    with pytest.raises(FloatingPointError, match=r"the forward filter diverged at sample 0 \(t = 0 s\)"):
        smooth_log(f, t, np.tile(np.eye(3), (t.size, 1, 1)))
