"""The gyro-less MEKF: Jacobians against finite differences, discretisation against SciPy, NEES within χ²
bounds, noise-free convergence, gaps and bad input."""

import re

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from scipy.spatial.transform import Rotation
from scipy.stats import chi2

from omegahat.baselines.mekf import (
    MEKF,
    attitude_innovation,
    discretize,
    process_jacobian,
    substeps,
    vector_innovation,
)
from omegahat.kernels import rotation
from omegahat.simulation.rigid_body import RigidBody, integrate

J = np.array([[3.0, 0.2, -0.1], [0.2, 2.0, 0.15], [-0.1, 0.15, 1.2]])  # a real body: J1 + J2 >= J3
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
    F_fd = np.column_stack([(error_rate(d * e, model) - error_rate(-d * e, model)) / (2 * d) for e in np.eye(6)])
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


@pytest.mark.parametrize(("model", "q_a"), [("dynamic", None), ("kinematic", None), ("dynamic", 0.7)])
def test_discretisation_against_van_loan(model, q_a):
    """(K2), (K3) against the exact transition (SciPy's expm of F h) and the exact process covariance (the integral
    of e^{Fs} G Q Gᵀ e^{Fᵀs}, by quad_vec): errors at the orders the truncation states — Φ to (|F|h)⁴, Q_d to
    (|F|h)² relative — and shrinking at those orders when h halves."""
    F, G = process_jacobian(W_HAT, J, J_INV, model)
    q = 0.3
    if q_a is not None:  # (K5): the unknown acceleration a, δω̇ = A δω + δa, ȧ white with PSD q_a
        F9, G9 = np.zeros((9, 9)), np.zeros((9, 6))
        F9[:6, :6], F9[3:6, 6:] = F, np.eye(3)
        G9[:6, :3], G9[6:, 3:] = G * np.sqrt(1.0), np.eye(3) * np.sqrt(q_a / q)
        F, G = F9, G9
    errors = []
    for h in (0.04, 0.02):
        Phi, Qd = discretize(W_HAT, J, J_INV, model, q, h, q_a)
        integrand = lambda s: scipy.linalg.expm(F * s) @ (q * G @ G.T) @ scipy.linalg.expm(F * s).T  # noqa: E731
        Qd_ref, _ = scipy.integrate.quad_vec(integrand, 0.0, h, epsabs=1e-16, epsrel=1e-12)
        e_phi = np.abs(Phi - scipy.linalg.expm(F * h)).max()
        e_q = np.abs(Qd - Qd_ref).max() / np.abs(Qd_ref).max()
        errors.append((e_phi, e_q))
        fh = np.abs(F).sum(axis=0).max() * h
        assert e_phi < fh**4 / 24 and e_q < fh**2
    assert errors[1][0] < errors[0][0] / 12 and errors[1][1] < errors[0][1] / 3  # orders 4 and 2 (16, 4 ideal)


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
        f = MEKF(
            J_true,
            model=model,
            q=q,
            measurement_noise=sigma,
            omega_hat0=w0,
            sigma_omega0=sigma_w0,
            R0=R0,
            sigma_theta0=sigma_th0,
        )
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
    f = MEKF(body.J, model="dynamic", q=1e-10, measurement_noise=1e-6, omega_hat0=np.zeros(3), sigma_omega0=3.0)
    est = f.run(times, truth.R).omega
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
    f = MEKF(None, model="kinematic", q=1e-8, measurement_noise=1e-6, references=refs, sigma_omega0=2.0)
    est = f.run(times, b).omega
    assert np.linalg.norm(est[times >= 2.0] - w, axis=1).max() < 1e-5


def test_nan_sample_is_skipped_like_a_missing_one():
    times = np.arange(0.0, 0.5, 0.05)
    R = Exp(np.outer(times, [0.3, 0.2, -0.5]))
    a = MEKF(None, model="kinematic", q=1e-2, measurement_noise=1e-3)
    b = MEKF(None, model="kinematic", q=1e-2, measurement_noise=1e-3)
    meas = R.copy()
    meas[4] = np.nan
    out_a = a.run(times, meas).omega
    keep = np.arange(times.size) != 4
    out_b = b.run(times[keep], R[keep]).omega
    np.testing.assert_allclose(out_a[keep], out_b, rtol=1e-12, atol=1e-14)
    assert a.n_skipped == 1


def test_errors_and_state_kept_after_rejection():
    with pytest.raises(ValueError, match="model must be one of"):
        MEKF(J, model="ballistic")
    with pytest.raises(ValueError, match="J must be given for the dynamic model"):
        MEKF(None, model="dynamic")
    with pytest.raises(ValueError, match="q must be positive and finite"):
        MEKF(J, q=-1.0)
    with pytest.raises(ValueError, match="references are nearly collinear"):
        MEKF(J, references=[[1.0, 0, 0], [1.0, 1e-9, 0]])
    f = MEKF(J, measurement_noise=1e-3)
    ref = MEKF(J, measurement_noise=1e-3)
    for g in (f, ref):
        g.update(0.0, np.eye(3))
        g.update(0.1, Exp([0.01, 0.02, 0.0]))
    with pytest.raises(ValueError, match=r"a quaternion \(4,\) or a Rotation; got shape \(2, 3\)"):
        f.update(0.2, np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"the sample \(t = 0.2\): not a rotation matrix: \|R\^T R - I\| = 5.2"):
        f.update(0.2, 2 * np.eye(3))
    with pytest.raises(ValueError, match=r"the sample: time t = 0.1 is not after the previous sample's t = 0.1"):
        f.update(0.1, np.eye(3))
    with pytest.raises(ValueError, match=r"the sample \(t = 0.2\): torque must be finite; got nan"):
        f.update(0.2, np.eye(3), torque=[0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match=r"torque must be a 3-vector; got shape \(2,\)"):
        f.update(0.2, np.eye(3), torque=[0.0, 1.0])
    R2 = Exp([0.02, 0.04, 0.0])
    np.testing.assert_array_equal(f.update(0.2, R2).omega, ref.update(0.2, R2).omega)
    g = MEKF(None, model="kinematic", references=np.eye(3)[:2])
    with pytest.raises(ValueError, match=r"a direction sample must have shape \(2, 3\) \(one row per reference\)"):
        g.update(0.0, np.eye(3))
    with pytest.raises(ValueError, match=r"the sample \(t = 0.0\): measured direction b2 has zero length"):
        g.update(0.0, np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 0.0]]))
    with pytest.raises(ValueError, match=r"R0 is not a rotation matrix: ‖RᵀR − I‖_F = 0.00347 exceeds 0.001"):
        MEKF(J, R0=1.001 * np.eye(3))


# ------------------------------------------------------------------------------------------------------------
# The compiled MEKF.run against the NumPy reference path (a loop of MEKF.update)

J_DYN = np.array([[3.0, 0.2, -0.1], [0.2, 2.0, 0.15], [-0.1, 0.15, 1.2]])  # a real body: J1 + J2 >= J3
REFS = np.array([[0.0, 0.0, 1.0], [0.6, 0.8, 0.0], [1.0, 0.0, 0.0]])


def uneven_log(n, rng, gaps=False):
    """Times with uneven steps (2–30 ms), optionally with gaps of 0.13 s and 0.4 s (max_step 0.05: several
    sub-steps); truth from the dynamic model with a known torque; attitude fixes and direction samples."""
    times = np.cumsum(rng.uniform(0.002, 0.03, n))
    if gaps:
        times[n // 4 :] += 0.13
        times[n // 2 :] += 0.4
    tau = rng.normal(0.0, 0.2, (n, 3))
    truth = integrate(RigidBody(J_DYN), Exp([0.3, -0.2, 0.1]), [1.0, -0.5, 0.3], times, max_step=1e-3)
    R_meas = truth.R @ Exp(rng.normal(0.0, 1e-3, (n, 3)))
    b_meas = np.einsum("ij,tjk->tik", REFS, truth.R) + rng.normal(0.0, 1e-3, (n, 3, 3))
    return times, tau, R_meas, b_meas


def update_loop(f, times, meas, torques=None):
    return np.array(
        [f.update(times[j], meas[j], None if torques is None else torques[j]).omega for j in range(len(times))]
    )


def assert_same_state(a, b, rtol=1e-10):
    """Filter states equal to ``rtol`` relative (to the largest entry of ω̂ and of P)."""
    np.testing.assert_allclose(a.omega, b.omega, rtol=0, atol=rtol * np.abs(b.omega).max())
    np.testing.assert_allclose(a.P, b.P, rtol=0, atol=rtol * np.abs(b.P).max())
    np.testing.assert_allclose(a.accel, b.accel, rtol=0, atol=rtol * max(np.abs(b.accel).max(), 1.0))
    if b.R is None:
        assert a.R is None
    else:
        np.testing.assert_allclose(a.R, b.R, rtol=0, atol=rtol)
    assert (a.t, a.n_skipped) == (b.t, b.n_skipped)
    np.testing.assert_array_equal(a._tau, b._tau)


CASES = {
    # name: (model, directions, NaN samples, gaps, torque)
    "dynamic-attitude-torque": ("dynamic", False, False, False, True),
    "kinematic-directions": ("kinematic", True, False, False, False),
    "dynamic-attitude-nan": ("dynamic", False, True, False, True),
    "kinematic-directions-nan": ("kinematic", True, True, False, False),
    "dynamic-attitude-gaps": ("dynamic", False, False, True, True),
    "kinematic-directions-gaps": ("kinematic", True, False, True, False),
    "dynamic-attitude-linear-hold": ("dynamic", False, False, True, "linear"),
    "dynamic-directions-disturbance": ("dynamic", True, True, True, "disturbance"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_run_equals_update_loop(case):
    model, directions, nan, gaps, torque = CASES[case]
    times, tau, R_meas, b_meas = uneven_log(150, np.random.default_rng(7), gaps=gaps)
    meas = b_meas if directions else R_meas
    if nan:
        meas = meas.copy()
        meas[[0, 1, 40, 41, 42, 90]] = np.nan  # the first fix comes late; a run of missing samples
        meas[70, 1, 2] = np.inf
    tq = tau if torque else None

    def make():
        return MEKF(
            J_DYN if model == "dynamic" else None,
            model=model,
            q=1e-3,
            measurement_noise=1e-3,
            references=REFS if directions else None,
            omega_hat0=[0.5, 0.0, 0.0],
            sigma_omega0=1.0,
            torque_hold="linear" if torque == "linear" else "zero",
            disturbance_noise=0.05 if torque == "disturbance" else None,
        )

    compiled, oracle = make(), make()
    out = compiled.run(times, meas, tq).omega
    ref = update_loop(oracle, times, meas, tq)
    np.testing.assert_allclose(out, ref, rtol=0, atol=1e-10 * np.nanmax(np.abs(ref)))  # NaN: before the first fix
    assert_same_state(compiled, oracle)
    assert compiled.n_skipped == (7 if nan else 0)
    if gaps:  # the longest gap is propagated in several substeps
        assert substeps(np.diff(times).max(), compiled.omega, J_INV, tau[0], tau[0], np.inf, compiled.max_angle) >= 2


def test_update_after_run_continues_like_updates():
    times, tau, R_meas, _ = uneven_log(120, np.random.default_rng(3), gaps=True)
    f, g = MEKF(J_DYN, q=1e-3), MEKF(J_DYN, q=1e-3)
    first = f.run(times[:60], R_meas[:60], tau[:60]).omega  # the torque of sample 59 is held into the next step
    rest = update_loop(f, times[60:], R_meas[60:], tau[60:])
    ref = update_loop(g, times, R_meas, tau)
    np.testing.assert_allclose(np.vstack([first, rest]), ref, rtol=0, atol=1e-10 * np.nanmax(np.abs(ref)))
    assert_same_state(f, g)
    # ... and run after update continues too (no reset), starting with R unset for the kinematic model.
    h, k = MEKF(None, model="kinematic", references=REFS), MEKF(None, model="kinematic", references=REFS)
    _, _, _, b_meas = uneven_log(40, np.random.default_rng(4))
    b_meas[:3] = np.nan
    update_loop(h, times[:2], b_meas[:2])
    assert h.R is None and h.n_skipped == 2
    out = h.run(times[2:40], b_meas[2:40]).omega
    ref = update_loop(k, times[:40], b_meas[:40])
    np.testing.assert_allclose(out, ref[2:], rtol=0, atol=1e-10 * np.nanmax(np.abs(ref)))
    assert_same_state(h, k)


def test_run_accepts_quaternions_and_rotations_like_update():
    times, _, R_meas, _ = uneven_log(30, np.random.default_rng(5))
    quat = Rotation.from_matrix(R_meas).as_quat()
    ref = MEKF(J_DYN).run(times, R_meas).omega
    np.testing.assert_allclose(MEKF(J_DYN).run(times, Rotation.from_matrix(R_meas)).omega, ref, rtol=0, atol=1e-12)
    np.testing.assert_allclose(
        MEKF(J_DYN, scalar_first=True).run(times, np.roll(quat, 1, axis=1)).omega, ref, rtol=0, atol=1e-12
    )
    f = MEKF(J_DYN)
    np.testing.assert_allclose(update_loop(f, times, quat), ref, rtol=0, atol=1e-10)
    assert MEKF(J_DYN).run([], np.zeros((0, 3, 3))).omega.shape == (0, 3)


def test_run_rejects_a_bad_sample_and_keeps_the_state():
    times, tau, R_meas, b_meas = uneven_log(20, np.random.default_rng(6))
    f = MEKF(J_DYN)
    f.run(times[:5], R_meas[:5], tau[:5])
    before = (f.R.copy(), f.omega.copy(), f.P.copy(), f.t, f._tau.copy(), f.n_skipped)

    def unchanged():
        np.testing.assert_array_equal(f.R, before[0])
        np.testing.assert_array_equal(f.omega, before[1])
        np.testing.assert_array_equal(f.P, before[2])
        assert (f.t, f.n_skipped) == (before[3], before[5])
        np.testing.assert_array_equal(f._tau, before[4])

    bad = R_meas[5:].copy()
    bad[7] = 2 * np.eye(3)
    with pytest.raises(
        ValueError, match=rf"sample 7 \(t = {float(times[12])!r}\): not a rotation matrix: \|R\^T R - I\| = 5.2"
    ):
        f.run(times[5:], bad)
    unchanged()
    bad_t = times[5:].copy()
    bad_t[4] = bad_t[3]
    message = rf"sample 4: time t = {float(bad_t[4])!r} is not after the previous sample's t = {float(bad_t[3])!r}"
    with pytest.raises(ValueError, match=re.escape(message)):
        f.run(bad_t, R_meas[5:])
    bad_t[4] = np.nan
    with pytest.raises(ValueError, match=r"sample 4: time t = nan is not finite$"):
        f.run(bad_t, R_meas[5:])
    message = rf"sample 0: time t = {float(times[2])!r} is not after the previous sample's t = {float(times[4])!r}"
    with pytest.raises(ValueError, match=re.escape(message)):
        f.run(times[2:], R_meas[2:])
    bad_tau = tau[5:].copy()
    bad_tau[9, 1] = np.nan
    with pytest.raises(ValueError, match=rf"sample 9 \(t = {float(times[14])!r}\): torque must be finite; got nan"):
        f.run(times[5:], R_meas[5:], bad_tau)
    with pytest.raises(ValueError, match=r"shape \(T, 3, 3\) or \(T, 4\) with T = 15 samples; got shape \(14, 3, 3\)"):
        f.run(times[5:], R_meas[6:])
    unchanged()
    g = MEKF(None, model="kinematic", references=REFS[:2])
    with pytest.raises(ValueError, match=r"must have shape \(T, 2, 3\) with T = 20 samples; got shape \(20, 3, 3\)"):
        g.run(times, b_meas)
    assert g.t is None and g.R is None


def test_compiled_pieces_match_numpy_and_scipy():
    """The kernel primitives MEKF.run is built from, on the MEKF's own matrices, against its NumPy oracle and SciPy."""

    rng = np.random.default_rng(1)
    # Shepperd's quaternion: every pivot, near 180°, and a matrix 1e-6 off a rotation (projected, like SciPy).
    mats = [Exp(v) for v in rng.normal(size=(50, 3))]
    mats += [Exp(np.pi * np.eye(3)[i] * (1 - 1e-9)) for i in range(3)] + [np.eye(3)]
    mats += [Exp([0.3, 0.2, -1.0]) + 1e-6 * rng.normal(size=(3, 3))]
    for D in mats:
        ref = Rotation.from_matrix(D).as_quat(canonical=True)
        np.testing.assert_allclose(rotation.quat_from_matrix(D), ref, rtol=0, atol=1e-12)


@pytest.mark.parametrize("hold", ["zero", "linear"])
def test_torque_hold_against_a_ramp(hold):
    """Spin about the principal axis z under τ_z = a + b t (closed form ω = w0 + (a t + b t²/2)/J₃, angle
    w0 t + (a t²/2 + b t³/6)/J₃), noise-free fixes at 10 Hz: with the linear hold the propagation is exact, so the
    filter started on the truth stays on it; held, every interval misses b h²/(2 J₃)."""
    Jd = np.diag([1.0, 2.0, 3.0])
    t = 0.1 * np.arange(41)
    a, b = 0.3, 0.6
    w = 0.5 + (a * t + b * t**2 / 2) / 3.0
    theta = 0.5 * t + (a * t**2 / 2 + b * t**3 / 6) / 3.0
    R = Rotation.from_rotvec(theta[:, None] * np.array([0.0, 0.0, 1.0])).as_matrix()
    taus = np.zeros((t.size, 3))
    taus[:, 2] = a + b * t
    f = MEKF(Jd, q=1e-12, measurement_noise=1e-6, omega_hat0=[0.0, 0.0, 0.5], sigma_omega0=1e-9, torque_hold=hold)
    err = np.abs(f.run(t, R, taus).omega[:, 2] - w).max()
    assert err < 1e-8 if hold == "linear" else err > 1e-4


def test_the_attitude_stays_a_rotation_through_a_long_run():
    """(E8)'s polish: without it the product of ~10⁵ rotations drifts from orthogonality by rounding (5e-14 at
    10⁵ fixes, 1e-12 at 3.5·10⁶, where every fix then took the SVD path of the quaternion conversion); with it
    the attitude stays a rotation to rounding, and the step's arithmetic polishes a perturbed rotation to O(ε²)."""
    from omegahat.kernels.vec3 import polished

    T = 100_000
    t = np.arange(T) * 0.01
    rng = np.random.default_rng(3)
    rot = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * Rotation.from_rotvec(1e-3 * rng.standard_normal((T, 3)))
    est = MEKF(model="kinematic", q=1e-6, measurement_noise=1e-3)
    est.run(t, rot.as_matrix())
    assert np.abs(est.R.T @ est.R - np.eye(3)).max() < 5e-15

    R = Rotation.from_rotvec([0.4, -1.1, 2.0]).as_matrix() @ (np.eye(3) + 1e-6 * rng.standard_normal((3, 3)))
    eps = np.abs(R.T @ R - np.eye(3)).max()
    P = np.array(polished(tuple(R.ravel()))).reshape(3, 3)
    assert np.abs(P.T @ P - np.eye(3)).max() < eps**2


@pytest.mark.parametrize("model", ["dynamic", "kinematic"])
def test_the_kernel_propagates_an_unknown_acceleration_as_its_oracle(model):
    """(K5) with a large estimated acceleration â: the kernel and its NumPy oracle both count their substeps with
    the torque the nominal state integrates, known plus ``J â`` (the turn bound ``h(|ω̂| + h|J⁻¹τ + â|)`` is 0.61 rad
    at h = 0.1 s, |â| = 61 rad/s²: four substeps of at most 0.2 rad, where the known torque alone asks for one), so
    they agree to rounding."""
    from omegahat.baselines.mekf import propagate_with_transition
    from omegahat.kernels.ekf import ekf_propagate

    body = RigidBody(np.diag([3.0, 2.0, 1.0]))
    R0 = Exp([0.2, -0.4, 0.1])
    w0, a0 = np.array([0.05, -0.02, 0.03]), np.array([60.0, -10.0, 5.0])
    P0 = np.diag(np.r_[np.full(3, 1e-4), np.full(3, 1e-3), np.full(3, 1e-2)])
    tau = np.array([0.1, 0.0, -0.2])
    R_ref, x_ref, P_ref, _ = propagate_with_transition(
        R0, np.r_[w0, a0], P0, 0.1, tau, body, 1e-4, model, q_a=1e-2
    )  # fmt: skip
    R, w, a, P = R0.copy(), w0.copy(), a0.copy(), P0.copy()
    n = ekf_propagate(
        R, w, a, P, 0.1, tau, tau, body.J, body.J_inv, 1e-4, 1e-2, model == "dynamic", np.inf, 0.2
    )  # fmt: skip
    assert n == 4  # the turn with J â (with the known torque alone: one substep)
    np.testing.assert_allclose(R, R_ref, rtol=0, atol=1e-13)
    np.testing.assert_allclose(w, x_ref[:3], rtol=0, atol=1e-13)
    np.testing.assert_allclose(P, P_ref, rtol=1e-12, atol=1e-16)
