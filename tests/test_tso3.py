"""The two gyro-free filters on TSO(3) (baselines/tso3_min_energy.py, baselines/predictive_geom.py) against
independent facts: finite differences, SciPy's root finder, solve_ivp of Euler's equations and of the continuous
minimum-energy filter, SciPy's CARE solver, least squares, exactness on a constant rate; and their compiled loop
against the NumPy steps to 1e-10."""

import warnings

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat.baselines.predictive_geom import PredictiveFilter, disturbance, predicted_change, predictive_step
from omegahat.baselines.tso3_min_energy import (
    MinimumEnergyFilter,
    gradient,
    hessian,
    min_energy_step,
    rate_jacobian,
    rate_residual,
)
from omegahat.interface import Status
from omegahat.measurements import MeasurementError
from omegahat.observer.compiled import SkippedSamplesWarning

J = np.array([[6.0, 0.3, -0.2], [0.3, 7.0, 0.1], [-0.2, 0.1, 9.0]])
J_INV = np.linalg.inv(J)
RNG = np.random.default_rng(26)


def hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def Exp(v):
    return Rotation.from_rotvec(v).as_matrix()


def euler_rhs(w, tau, J=J, J_inv=J_INV):
    """J ω̇ = (J ω) × ω + τ, written out here."""
    return J_inv @ (np.cross(J @ w, w) + tau)


# ------------------------------------------------------------------------------------------- minimum-energy


def test_rate_jacobian_is_the_derivative_of_the_implicit_step():
    """(M6) against central differences of (M4)'s residual."""
    w, c, h, eps = np.array([0.7, -1.2, 0.4]), np.array([0.1, 0.2, -0.3]), 0.05, 1e-6
    fd = np.column_stack(
        [(rate_residual(w + eps * e, c, J, h) - rate_residual(w - eps * e, c, J, h)) / (2 * eps) for e in np.eye(3)]
    )
    np.testing.assert_allclose(rate_jacobian(w, J, h), fd, atol=1e-8)


def test_implicit_rate_step_solves_its_equation_and_is_second_order():
    """Without a sample the rate step is (M4) alone: its result is the root SciPy finds for (M4) written out here,
    and as an integrator of Euler's equations its error at 1 s falls four times when h halves."""
    w0, tau = np.array([0.3, -0.8, 0.5]), np.array([0.2, -0.1, 0.3])
    h = 0.05

    def m4(w, w_prev):  # N(x) = I − x×/2 + (x×)²/12
        def N(x):
            return np.eye(3) - hat(x) / 2 + hat(x) @ hat(x) / 12

        return N(-h * w) @ J @ w - N(h * w_prev) @ J @ w_prev - h * tau

    _, w1, _ = min_energy_step(np.eye(3), w0, np.eye(6), None, np.eye(3), tau, h, J, J_INV, np.ones(3), np.ones(3),
                               0.0, 1.0)  # fmt: skip
    np.testing.assert_allclose(w1, scipy.optimize.fsolve(m4, w0, args=(w0,), xtol=1e-14), atol=1e-12)
    exact = solve_ivp(lambda t, w: euler_rhs(w, tau), (0, 1), w0, method="DOP853", rtol=1e-12, atol=1e-14).y[:, -1]
    errors = []
    for h in (0.02, 0.01):
        w = w0
        for _ in range(round(1 / h)):
            w = min_energy_step(np.eye(3), w, np.eye(6), None, np.eye(3), tau, h, J, J_INV, np.ones(3), np.ones(3),
                                0.0, 1.0)[1]  # fmt: skip
        errors.append(np.linalg.norm(w - exact))
    assert 3.6 < errors[0] / errors[1] < 4.4, errors


def test_gradient_and_hessian_are_the_derivatives_of_the_output_cost():
    """φ(η) = Σ (q_i/2)|a_i − (R̂ Exp(η))ᵀ v_i|²: (M1) is −∇φ(0) and (M5)'s E₁₁ is ∇²φ(0), by finite differences."""
    refs = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [0.6, 0.8, 0.0]])
    R = Exp([0.4, -0.3, 0.9])
    a = refs @ Exp([0.1, 0.05, -0.2]) + 0.05 * RNG.normal(size=(3, 3))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    q = np.array([0.1, 0.3, 0.7])

    def phi(eta):
        return sum(0.5 * qi * np.sum((ai - (R @ Exp(eta)).T @ vi) ** 2) for qi, ai, vi in zip(q, a, refs, strict=True))

    eps, E = 1e-4, np.eye(3)
    grad = np.array([(phi(eps * e) - phi(-eps * e)) / (2 * eps) for e in E])
    hess = np.array(
        [[(phi(eps * (ei + ej)) - phi(eps * (ei - ej)) - phi(eps * (ej - ei)) + phi(-eps * (ei + ej))) / (4 * eps**2)
          for ej in E] for ei in E]
    )  # fmt: skip
    np.testing.assert_allclose(gradient(R, a, refs, q), -grad, atol=1e-8)
    np.testing.assert_allclose(hessian(R, a, refs, q), hess, atol=1e-6)


def _static_samples(R, refs, T, h):
    t = h * np.arange(T)
    return t, np.broadcast_to(refs @ R, (T, *refs.shape)).copy()


def test_gain_settles_at_scipys_continuous_algebraic_riccati_solution():
    """At rest and at the truth (r = 0) the gain obeys (M5) with constant A and E; explicit Euler's fixed point is
    the CARE (A − α/2)K + K(A − α/2)ᵀ − K E K + BBᵀ/ρ = 0, solved here by SciPy."""
    refs = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    R, q, alpha, pw = Exp([0.3, 0.2, -0.5]), np.array([0.1, 0.2]), 0.01, 0.5
    f = MinimumEnergyFilter(J=J, references=refs, weights=q, alpha=alpha, process_weight=pw, R0=R)
    f.run(*_static_samples(R, refs, 20000, 0.01))
    b = refs @ R
    E11 = sum(qi * (np.eye(3) - np.outer(bi, bi)) for qi, bi in zip(q, b, strict=True))
    A = np.zeros((6, 6))
    A[:3, 3:] = np.eye(3)
    BB = np.zeros((6, 6))
    BB[3:, 3:] = pw * np.eye(3)
    care = scipy.linalg.solve_continuous_are(
        (A - alpha / 2 * np.eye(6)).T, np.vstack([np.eye(3), np.zeros((3, 3))]), BB, np.linalg.inv(E11)
    )
    np.testing.assert_allclose(f.gain, care, atol=1e-9)
    np.testing.assert_allclose(f.omega, 0.0, atol=1e-15)


@pytest.mark.parametrize("as_published", [False, True])
def test_exact_on_a_constant_rate_from_the_truth(as_published):
    """A spin about a principal axis is a torque-free motion; started on it with exact samples, the filter stays on
    it: (M4) keeps ω (ω × Jω = 0), (M3) turns R̂ by exactly h ω, r stays 0."""
    Jd = np.diag([6.0, 7.0, 9.0])
    w = np.array([0.0, 0.0, 0.8])
    refs = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    R0 = Exp([0.4, -1.1, 0.3])
    t = 0.01 * np.arange(2000)
    b = np.einsum("tji,nj->tni", R0 @ Exp(np.outer(t, w)), refs)
    f = MinimumEnergyFilter(Jd, references=refs, R0=R0, omega_hat0=w, as_published=as_published)
    np.testing.assert_allclose(f.run(t, b).omega, np.broadcast_to(w, (t.size, 3)), atol=1e-12)
    np.testing.assert_allclose(f.R, R0 @ Exp(t[-1] * w), atol=1e-11)


def test_discrete_filter_tends_to_the_continuous_filter():
    """The steps (M3)–(M5) are a first-order discretisation of Ṙ̂ = R̂ (ω̂ + K₁₁ r)×, ω̂̇ = J⁻¹((Jω̂) × ω̂ + τ) + K₂₁ r,
    K̇ = (M5): integrated here by solve_ivp on a spin about a principal axis, from a wrong start; the filter's
    distance to it at 1 s halves with h."""
    Jd, Jd_inv = np.diag([6.0, 7.0, 9.0]), np.diag([1 / 6, 1 / 7, 1 / 9])
    w, R0 = np.array([0.0, 0.0, 0.5]), Exp([0.2, 0.1, -0.3])
    refs, q, alpha, pw = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), np.array([0.1, 0.1]), 0.01, 1.0
    start_R, start_w = R0 @ Exp([0.3, -0.2, 0.1]), np.array([0.1, -0.1, 0.2])

    def rhs(t, y):
        Rh, wh, K = y[:9].reshape(3, 3), y[9:12], y[12:].reshape(6, 6)
        a = refs @ (R0 @ Exp(t * w))
        bh = refs @ Rh
        r = sum(qi * np.cross(ai, bi) for qi, ai, bi in zip(q, a, bh, strict=True))
        E11 = sum(
            qi / 2 * (2 * ai @ bi * np.eye(3) - np.outer(ai, bi) - np.outer(bi, ai))
            for qi, ai, bi in zip(q, a, bh, strict=True)
        )
        A = np.block([[-hat(wh), np.eye(3)], [np.zeros((3, 3)), Jd_inv @ (hat(Jd @ wh) - hat(wh) @ Jd)]])
        E = np.zeros((6, 6))
        E[:3, :3] = E11
        W = np.zeros((6, 6))
        W[:3, :3] = hat(K[:3, :3] @ r) / 2
        BB = np.diag([0, 0, 0, pw, pw, pw])
        Kd = -alpha * K + A @ K + K @ A.T - K @ E @ K + BB - W @ K - K @ W.T
        Rd = Rh @ hat(wh + K[:3, :3] @ r)
        wd = euler_rhs(wh, 0.0, Jd, Jd_inv) + K[3:, :3] @ r
        return np.concatenate([Rd.ravel(), wd, Kd.ravel()])

    y0 = np.concatenate([start_R.ravel(), start_w, np.eye(6).ravel()])
    cont = solve_ivp(rhs, (0, 1), y0, method="DOP853", rtol=1e-11, atol=1e-12).y[:, -1]
    gaps = []
    for h in (2e-3, 1e-3):
        t = h * np.arange(round(1 / h) + 1)
        b = np.einsum("tji,nj->tni", R0 @ Exp(np.outer(t, w)), refs)
        f = MinimumEnergyFilter(Jd, references=refs, weights=q, alpha=alpha, process_weight=pw, R0=start_R,
                                omega_hat0=start_w)  # fmt: skip
        wh = f.run(t, b).omega[-1]
        gaps.append(np.linalg.norm(wh - cont[9:12]))
        assert np.linalg.norm(f.gain - cont[12:].reshape(6, 6)) < 20 * h
    assert gaps[1] < 0.6 * gaps[0] and gaps[1] < 5e-3, gaps


# ------------------------------------------------------------------------------------------- predictive


def _flow(b, w, tau, h, accel=(0.0, 0.0, 0.0)):
    """b(h), ω(h) of ḃ = b × ω, ω̇ = J⁻¹((Jω) × ω + τ) + accel, by solve_ivp."""

    def rhs(t, y):
        return np.concatenate([np.cross(y[:3], y[3:]), euler_rhs(y[3:], tau) + accel])

    return solve_ivp(rhs, (0, h), np.concatenate([b, w]), method="DOP853", rtol=1e-13, atol=1e-15).y[:3, -1]


def test_predicted_change_is_the_second_order_expansion_of_the_motion():
    """(G2): b̂ + ζ misses the exact b(h) by O(h³) (the miss falls about 8× when h halves)."""
    b, w, tau = np.array([0.6, 0.0, 0.8]), np.array([0.5, -0.7, 0.9]), np.array([0.3, 0.1, -0.2])
    misses = []
    for h in (0.04, 0.02):
        zeta = predicted_change(b[None], w, euler_rhs(w, tau), h)[0]
        misses.append(np.linalg.norm(b + zeta - _flow(b, w, tau, h)))
    assert 6.5 < misses[0] / misses[1] < 9.5, misses


def test_disturbance_sensitivity_is_the_leading_order_of_the_motion():
    """(G3): ∂b(h)/∂δ for a constant extra angular acceleration δ is (h²/2) b× to leading order (miss O(h³))."""
    b, w, tau = np.array([0.0, 0.6, 0.8]), np.array([0.4, 0.2, -0.6]), np.zeros(3)
    misses = []
    for h in (0.04, 0.02):
        eps = 1e-3
        fd = np.column_stack(
            [(_flow(b, w, tau, h, eps * e) - _flow(b, w, tau, h, -eps * e)) / (2 * eps) for e in np.eye(3)]
        )
        misses.append(np.linalg.norm(fd - 0.5 * h * h * hat(b)))
    assert 6.5 < misses[0] / misses[1] < 9.5, misses


def test_disturbance_is_the_least_squares_minimiser():
    """(G5) is the minimiser of |α + β δ|²_Q + |δ|²_ρ: SciPy's least squares on the stacked system."""
    y = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]) + 0.01 * RNG.normal(size=(2, 3))
    b_hat = np.array([[0.1, 0.99, 0.0], [0.0, -0.1, 0.99]])
    zeta = 0.01 * RNG.normal(size=(2, 3))
    q, rho, h = 3e3, 2e-3, 0.05
    delta, alpha, beta = disturbance(y, b_hat, zeta, h, q, rho)
    stacked = np.vstack([np.sqrt(q) * beta, np.sqrt(rho) * np.eye(3)])
    rhs = np.concatenate([-np.sqrt(q) * alpha, np.zeros(3)])
    np.testing.assert_allclose(delta, scipy.linalg.lstsq(stacked, rhs)[0], rtol=1e-9)
    np.testing.assert_allclose(alpha, np.cross(y, b_hat + zeta).sum(axis=0), atol=1e-15)


@pytest.mark.parametrize("as_published", [False, True])
def test_predictive_rate_step_solves_the_trapezoidal_rule(as_published):
    """(G6)–(G8) from δ of (G5): the rate is SciPy's root of the trapezoidal rule written out here (δ as an
    acceleration in both halves; the source's second half: J⁻¹δ), the attitude turns by h(ω_½ + k_R r)."""
    refs = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    R, w, tau, h, q, rho, k = (
        Exp([0.2, -0.4, 0.1]),
        np.array([0.3, 0.2, 0.1]),
        np.array([0.5, -1.0, 0.2]),
        0.05,
        1e4,
        4e-3,
        0.7,
    )
    y = refs @ Exp([0.25, -0.35, 0.1]) + 0.01 * RNG.normal(size=(2, 3))
    b_hat = refs @ R
    delta = disturbance(y, b_hat, predicted_change(b_hat, w, euler_rhs(w, tau), h), h, q, rho)[0]
    half = w + h / 2 * (euler_rhs(w, tau) + delta)
    second = J_INV @ delta if as_published else delta
    w1 = scipy.optimize.fsolve(lambda v: half + h / 2 * (euler_rhs(v, tau) + second) - v, half, xtol=1e-14)
    r = np.cross(y, b_hat).sum(axis=0)
    R1, w_next = predictive_step(R, w, y, refs, tau, h, J, J_INV, q, rho, k, as_published)
    np.testing.assert_allclose(w_next, w1, atol=1e-12)
    np.testing.assert_allclose(R1, R @ Exp(h * (half + k * r)), atol=1e-14)


# ------------------------------------------------------------------------------------------- the shells


def _log(attitudes, T=400, h=0.02):
    """A tumbling body under torque, two noisy directions (or noisy quaternions), gaps and a bad sample."""
    t = h * np.arange(T) + 3.0
    R = Exp([0.3, 0.2, -0.1]) @ Exp(np.outer(t - 3.0, [0.4, -0.3, 0.6]) + 0.2 * np.sin(np.outer(t, [1, 2, 3])))
    taus = np.stack([np.sin(t), np.cos(2 * t), 0.5 * np.ones_like(t)], -1)
    if attitudes:
        m = Rotation.from_matrix(R).as_quat() + 1e-4 * RNG.normal(size=(T, 4))
        m[[0, 1, 50, 51, 200]] = np.nan
        return t, m, taus, None
    refs = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    m = np.einsum("tji,nj->tni", R, refs) + 0.01 * RNG.normal(size=(T, 2, 3))
    m[[0, 50, 51]] = np.nan
    m[120, 1] = m[120, 0]  # collinear: skipped
    return t, m, taus, refs


def _filters(kind, refs, R0):
    common = {"J": J, "references": refs, "R0": R0, "omega_hat0": (0.1, -0.2, 0.05)}
    if kind == "min-energy":
        return [MinimumEnergyFilter(weights=0.2, as_published=p, **common) for p in (False, True)]
    return [PredictiveFilter(as_published=p, **common) for p in (False, True)]


@pytest.mark.parametrize("kind", ["min-energy", "predictive"])
@pytest.mark.parametrize("attitudes", [False, True])
@pytest.mark.parametrize("R0", [None, "given"])
def test_compiled_run_equals_the_numpy_steps(kind, attitudes, R0):
    """``run`` (compiled, in two chunks) equals ``update`` sample by sample (NumPy) to 1e-10: estimates, statuses,
    attitude, gain; with torques, missing and collinear samples, quaternion input and the first-valid-sample start."""
    t, m, taus, refs = _log(attitudes)
    start = None if R0 is None else Exp([0.5, 0.1, -0.2])
    for fast, slow in zip(_filters(kind, refs, start), _filters(kind, refs, start), strict=True):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkippedSamplesWarning)
            got = [fast.run(t[:150], m[:150], taus[:150]), fast.run(t[150:], m[150:], taus[150:])]
            want = [slow.update(t[j], m[j], taus[j]) for j in range(t.size)]
            status = np.array([w.status for w in want])
            want_omega = np.array([w.omega for w in want])
            first = 2 if attitudes else 1  # the first valid sample: no estimate before it
            assert np.all(status[:first] == Status.UNAVAILABLE) and np.all(np.isfinite(want_omega[first:]))
            assert set(status[first:]) == {Status.CORRECTED, Status.PREDICTED}
            np.testing.assert_array_equal(np.concatenate([g.status for g in got]), status)
            np.testing.assert_allclose(np.vstack([g.omega for g in got]), want_omega, rtol=0, atol=1e-10)
            np.testing.assert_allclose(fast.R, slow.R, atol=1e-10)
            np.testing.assert_allclose(fast.gain, slow.gain, atol=1e-10)
            fast.reset()
            np.testing.assert_allclose(fast.run(t, m, taus).omega, want_omega, atol=1e-10)


def test_settings_and_input_are_checked():
    refs = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    with pytest.raises(ValueError, match="weights must be one number or 2 numbers"):
        MinimumEnergyFilter(J, references=refs, weights=[1, 2, 3])
    with pytest.raises(ValueError, match="K0 must be positive definite"):
        MinimumEnergyFilter(J, K0=-np.eye(6))
    with pytest.raises(ValueError, match="K0 must be one number or a symmetric finite 6x6 matrix"):
        MinimumEnergyFilter(J, K0=np.ones((3, 3)))
    with pytest.raises(ValueError, match="attitude_gain must be positive"):
        PredictiveFilter(J, attitude_gain=0.0)
    with pytest.raises(ValueError, match="references holds one direction"):
        PredictiveFilter(J, references=refs[:1])
    f = PredictiveFilter(J, references=refs)
    f.update(1.0, refs)
    with pytest.raises(MeasurementError, match="is not after the previous sample's"):
        f.run([1.5, 1.2], np.stack([refs, refs]))
    assert f.t == 1.0  # a rejected log leaves the state as it was


@pytest.mark.parametrize("path", ["update", "run"])
def test_a_step_that_cannot_be_taken_restarts_from_the_sample(path, restart_warnings):
    """(C5): Newton's failure on (M4) (here |h ω| = 10 rad) is never written as an estimate: that sample's estimate is
    NaN with the status RESTARTED, and the filter starts again from it (ω̂₀, K₀, the sample's attitude), giving what
    a fresh filter started at that sample gives; the compiled run and the NumPy steps agree on it."""
    Jd, w0 = np.diag([1.0, 2.0, 2.5]), (3.0, 10.0, -5.0)
    R = [np.eye(3), Exp([0.1, 0.0, 0.0]), Exp([0.2, 0.05, 0.0]), Exp([0.3, 0.1, 0.0])]
    f = MinimumEnergyFilter(Jd, R0=np.eye(3), omega_hat0=w0)
    with restart_warnings(path):
        if path == "update":
            out = [f.update(t, Rj) for t, Rj in zip([0.0, 1.0], R[:2], strict=True)]
            omega, status = np.array([o.omega for o in out]), np.array([o.status for o in out])
        else:
            omega, status = f.run([0.0, 1.0], np.stack(R[:2]))
    assert list(status) == [Status.CORRECTED, Status.RESTARTED] and f.n_restarts == 1
    assert np.all(np.isnan(omega[1])) and np.all(omega[0] == w0)
    np.testing.assert_array_equal(f.omega, w0)
    np.testing.assert_allclose(f.gain, np.eye(6))
    np.testing.assert_allclose(f.R, R[1], atol=1e-12)
    fresh = MinimumEnergyFilter(Jd, R0=R[1], omega_hat0=w0)
    fresh.update(1.0, R[1])
    assert f.update(1.01, R[2]).status == Status.CORRECTED
    np.testing.assert_allclose(f.omega, fresh.update(1.01, R[2]).omega, atol=1e-12)
