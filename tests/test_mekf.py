"""The gyro-less MEKF: Jacobians against finite differences, discretisation against SciPy, NEES within χ²
bounds, noise-free convergence, gaps and bad input."""

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from omegahat.observers.mekf import (
    MEKF,
    attitude_innovation,
    discretize,
    expm_small,
    process_jacobian,
    vector_innovation,
)
from omegahat.rigid_body import RigidBody, integrate

J = np.array([[3.0, 0.2, -0.1], [0.2, 2.0, 0.15], [-0.1, 0.15, 1.0]])
J_INV = np.linalg.inv(J)
W_HAT = np.array([0.8, -1.3, 0.5])


def Exp(v):
    return Rotation.from_rotvec(v).as_matrix()


def Log(R):
    return Rotation.from_matrix(R).as_rotvec()


def error_rate(dx, model, eps=1e-5):
    """d/dt of the error state [δθ; δω] (R = R̂ Exp(δθ), ω = ω̂ + δω) without process noise, computed from
    the nonlinear motions: δθ(s) = Log(Exp(−ω̂ s) Exp(δθ) Exp(ω s)) differenced in s, δω̇ from Euler's
    equations (RigidBody.omega_dot) or 0 for the kinematic model."""
    dth, dw = dx[:3], dx[3:]
    w = W_HAT + dw
    g = [Log(Exp(-W_HAT * s) @ Exp(dth) @ Exp(w * s)) for s in (eps, -eps)]
    dth_dot = (g[0] - g[1]) / (2 * eps)
    if model == "dynamic":
        body = RigidBody(J)
        dw_dot = body.omega_dot(w) - body.omega_dot(W_HAT)
    else:
        dw_dot = np.zeros(3)
    return np.concatenate([dth_dot, dw_dot])


@pytest.mark.parametrize("model", ["dynamic", "kinematic"])
def test_process_jacobian_matches_finite_differences(model):
    F, G = process_jacobian(W_HAT, J, J_INV, model)
    d = 1e-4
    F_fd = np.column_stack(
        [(error_rate(d * e, model) - error_rate(-d * e, model)) / (2 * d) for e in np.eye(6)]
    )
    np.testing.assert_allclose(F, F_fd, atol=1e-6)
    # G: torque noise enters through Euler's equations (ω̇ = J⁻¹(... + τ)); the kinematic noise is ω̇ itself.
    body = RigidBody(J)
    G_fd = np.column_stack(
        [(body.omega_dot(W_HAT, d * e) - body.omega_dot(W_HAT, -d * e)) / (2 * d) for e in np.eye(3)]
    )
    np.testing.assert_allclose(G[3:], G_fd if model == "dynamic" else np.eye(3), atol=1e-9)
    np.testing.assert_array_equal(G[:3], 0.0)


def test_measurement_jacobians_match_finite_differences():
    R_hat = Exp([0.3, -0.7, 1.1])
    d = 1e-6
    # Attitude fix: z(δθ) = 2 dq_vec / dq_w of R̂ᵀ R̂ Exp(δθ) = 2 tan(θ/2) axis, so dz/dδθ = I at 0.
    _, H = attitude_innovation(R_hat, R_hat)
    z_of = lambda dth: attitude_innovation(R_hat, R_hat @ Exp(dth))[0]  # noqa: E731
    H_fd = np.column_stack([(z_of(d * e) - z_of(-d * e)) / (2 * d) for e in np.eye(3)])
    np.testing.assert_allclose(H[:, :3], H_fd, atol=1e-8)
    np.testing.assert_array_equal(H[:, 3:], 0.0)
    phi = np.array([0.4, -0.2, 0.3])
    th = np.linalg.norm(phi)
    z, _ = attitude_innovation(R_hat, R_hat @ Exp(phi))
    np.testing.assert_allclose(z, 2 * np.tan(th / 2) * phi / th, rtol=1e-12)
    # Vector fix: b(δθ) = (R̂ Exp(δθ))ᵀ v_i.
    refs = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0]])
    b_of = lambda dth: refs @ (R_hat @ Exp(dth))  # noqa: E731  rows (R̂ Exp(δθ))ᵀ v_i
    _, Hv = vector_innovation(R_hat, b_of(np.zeros(3)), refs)
    Hv_fd = np.column_stack([(b_of(d * e) - b_of(-d * e)).ravel() / (2 * d) for e in np.eye(3)])
    np.testing.assert_allclose(Hv[:, :3], Hv_fd, atol=1e-8)
    np.testing.assert_array_equal(Hv[:, 3:], 0.0)


def test_expm_small_equals_scipy():
    rng = np.random.default_rng(0)
    for scale in (1e-3, 0.3, 3.0):
        M = rng.normal(size=(12, 12)) * scale
        ref = scipy.linalg.expm(M)
        np.testing.assert_allclose(expm_small(M), ref, rtol=0, atol=1e-13 * np.abs(ref).max())


@pytest.mark.parametrize("model", ["dynamic", "kinematic"])
def test_van_loan_equals_direct_integrals(model):
    F, G = process_jacobian(W_HAT, J, J_INV, model)
    q, h = 0.3, 0.07
    Phi, Qd = discretize(F, G, q, h)
    np.testing.assert_allclose(Phi, scipy.linalg.expm(F * h), atol=1e-13)
    integrand = lambda s: scipy.linalg.expm(F * s) @ (q * G @ G.T) @ scipy.linalg.expm(F * s).T  # noqa: E731
    Qd_ref, _ = scipy.integrate.quad_vec(integrand, 0.0, h, epsabs=1e-15, epsrel=1e-12)
    np.testing.assert_allclose(Qd, Qd_ref, atol=1e-14, rtol=1e-9)


def simulate_truth(model, J_true, q, h, steps, n_runs, rng, n_sub=20):
    """Truth for the NEES test: the filter's own stochastic model on a fine grid (Euler–Maruyama for ω, exact
    exponential for R). Returns R (steps+1, N, 3, 3), ω (steps+1, N, 3)."""
    J_inv = np.linalg.inv(J_true)
    dt = h / n_sub
    R = Exp(rng.normal(size=(n_runs, 3)))
    w = rng.normal(0.0, 0.1, size=(n_runs, 3))
    Rs, ws = [R], [w]
    for _ in range(steps):
        for _ in range(n_sub):
            R = R @ Exp(w * dt)
            noise = rng.normal(size=(n_runs, 3)) * np.sqrt(q * dt)
            if model == "dynamic":
                Jw = w @ J_true.T
                w = w + dt * np.cross(Jw, w) @ J_inv.T + noise @ J_inv.T
            else:
                w = w + noise
        Rs.append(R)
        ws.append(w)
    return np.array(Rs), np.array(ws)


@pytest.mark.parametrize(("model", "q"), [("kinematic", 1e-3), ("dynamic", 2e-3)])
def test_nees_within_chi2_bounds_near_linear(model, q):
    """Near-linear case (small rates, small noise, many fixes): averaged over N seeded runs, the NEES of the
    6-dimensional error is N⁻¹χ²(6N). We require the run-averaged NEES to lie inside the two-sided 99 %
    interval [χ²₀.₀₀₅(6N), χ²₀.₉₉₅(6N)]/N at ≥ 95 % of the sample times (99 % expected if the filter is
    consistent), and its average over all times within 10 % of 6. (Checked to fail when the filter's q is
    5 times too large or too small: 16 % and 8 % of the times inside, averages 4.0 and 15.5.)"""
    J_true = np.diag([1.0, 1.2, 0.9])
    h, steps, n_runs, sigma = 0.05, 80, 30, 0.01
    sigma_th0, sigma_w0 = 0.02, 0.1
    rng = np.random.default_rng(2024)
    R_true, w_true = simulate_truth(model, J_true, q, h, steps, n_runs, rng)
    times = h * np.arange(steps + 1)
    nees = np.empty((steps + 1, n_runs))
    for n in range(n_runs):
        # Initial estimate drawn from the filter's own prior around the truth.
        R0 = R_true[0, n] @ Exp(rng.normal(0, sigma_th0, 3))
        w0 = w_true[0, n] + rng.normal(0, sigma_w0, 3)
        f = MEKF(J_true, model, q=q, measurement_sigma=sigma, omega0=w0, sigma_omega0=sigma_w0,
                 R0=R0, sigma_theta0=sigma_th0)
        meas = R_true[:, n] @ Exp(rng.normal(0, sigma, (steps + 1, 3)))
        for k in range(steps + 1):
            f.update(times[k], meas[k])
            dx = np.concatenate([Log(f.R.T @ R_true[k, n]), w_true[k, n] - f.omega])
            nees[k, n] = dx @ np.linalg.solve(f.P, dx)
    anees = nees.mean(axis=1)
    lo, hi = chi2.ppf([0.005, 0.995], 6 * n_runs) / n_runs
    inside = (anees >= lo) & (anees <= hi)
    assert inside.mean() >= 0.95, (inside.mean(), anees.min(), anees.max(), lo, hi)
    assert abs(anees.mean() - 6.0) < 0.6, anees.mean()


def test_noise_free_convergence_dynamic_attitude_fixes():
    # The paper's tumbling body, attitude fixes at 100 Hz, from ω̂₀ = 0 (error |ω₀| = 2.3 rad/s).
    body = RigidBody([3.0, 2.0, 1.0])
    times = np.arange(0.0, 4.0, 0.01)
    truth = integrate(body, np.eye(3), [2.0, -1.0, 0.6], times)
    f = MEKF(body.J, "dynamic", q=1e-10, measurement_sigma=1e-6, sigma_omega0=3.0)
    est = f.run(times, truth.R)
    err = np.linalg.norm(est - truth.omega, axis=1)
    assert err[0] > 2.0
    assert err[times >= 1.0].max() < 1e-5, err[times >= 1.0].max()


def test_noise_free_convergence_kinematic_directions():
    # Constant rate seen through two directions (rows 1 and 2 of R): the kinematic model is exact here.
    w = np.array([0.4, -0.9, 1.5])
    times = np.arange(0.0, 5.0, 0.02)
    R = Exp(np.outer(times, w))
    refs = np.eye(3)[:2]
    b = np.einsum("ij,tjk->tik", refs, R)  # rows Rᵀ v_i
    f = MEKF(None, "kinematic", q=1e-8, measurement_sigma=1e-6, references=refs, sigma_omega0=2.0)
    est = f.run(times, b)
    assert np.linalg.norm(est[times >= 2.0] - w, axis=1).max() < 1e-5


def test_nan_sample_is_skipped_like_a_missing_one():
    times = np.arange(0.0, 0.5, 0.05)
    R = Exp(np.outer(times, [0.3, 0.2, -0.5]))
    a = MEKF(None, "kinematic", q=1e-2, measurement_sigma=1e-3)
    b = MEKF(None, "kinematic", q=1e-2, measurement_sigma=1e-3)
    meas = R.copy()
    meas[4] = np.nan
    out_a = a.run(times, meas)
    keep = np.arange(times.size) != 4
    out_b = b.run(times[keep], R[keep])
    np.testing.assert_allclose(out_a[keep], out_b, rtol=1e-12, atol=1e-14)
    assert a.n_skipped == 1


def test_errors_and_state_kept_after_rejection():
    with pytest.raises(ValueError, match="model must be one of"):
        MEKF(J, "ballistic")
    with pytest.raises(ValueError, match="J must be given for the dynamic model"):
        MEKF(None, "dynamic")
    with pytest.raises(ValueError, match="q must be positive and finite"):
        MEKF(J, q=-1.0)
    with pytest.raises(ValueError, match="references are nearly collinear"):
        MEKF(J, references=[[1.0, 0, 0], [1.0, 1e-9, 0]])
    f = MEKF(J, measurement_sigma=1e-3)
    ref = MEKF(J, measurement_sigma=1e-3)
    for g in (f, ref):
        g.update(0.0, np.eye(3))
        g.update(0.1, Exp([0.01, 0.02, 0.0]))
    with pytest.raises(ValueError, match=r"must be a rotation matrix \(3, 3\).*got shape \(2, 3\)"):
        f.update(0.2, np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"measurement\[0\] is not a rotation matrix"):
        f.update(0.2, 2 * np.eye(3))
    with pytest.raises(ValueError, match=r"t must increase strictly; got t = 0.1 after t = 0.1"):
        f.update(0.1, np.eye(3))
    with pytest.raises(ValueError, match=r"torque must be 3 finite numbers; got \[ 0. nan"):
        f.update(0.2, np.eye(3), torque=[0.0, np.nan, 0.0])
    R2 = Exp([0.02, 0.04, 0.0])
    np.testing.assert_array_equal(f.update(0.2, R2), ref.update(0.2, R2))
    g = MEKF(None, "kinematic", references=np.eye(3)[:2])
    with pytest.raises(ValueError, match=r"measurement must be 2 body-frame directions, shape \(2, 3\)"):
        g.update(0.0, np.eye(3))
