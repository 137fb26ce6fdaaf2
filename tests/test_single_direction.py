"""One measured direction (observer/single_direction.py) against independent facts: the continuous observer of
observer/continuous.py with n = 1 integrated by SciPy, the gradient observer's own equations integrated by SciPy,
convergence on a torque-free tumbling body, the invariance of the rate about b when the body spins about it, the
paper's misprinted sign, the Lyapunov function (D7) and the excitation monitor."""

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat.interface import Status
from omegahat.observer import continuous
from omegahat.observer.single_direction import (
    LostExcitationWarning,
    SingleDirectionEstimator,
    default_gains,
    excitation,
    gradient_rhs,
    run_single_direction,
)
from omegahat.simulation.rigid_body import RigidBody, integrate

J = np.diag([3.0, 2.0, 1.0])
V = np.array([0.6, 0.0, 0.8])  # the inertial direction measured


def _tumble(omega0, t, v=V, J=J):
    tr = integrate(RigidBody(J), np.eye(3), omega0, t)
    return tr, np.einsum("tji,j->ti", tr.R, v)


def _plant_rhs(R, w, J, J_inv):
    """Ṙ = R ω×, J ω̇ = (J ω) × ω (torque-free), written out here."""
    W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return R @ W, J_inv @ np.cross(J @ w, w)


def test_sampled_sarras_matches_continuous_observer_with_one_direction():
    """Fed exact samples at 100 Hz, the sampled realisation follows the paper's (ξ, r̂) equations with n = 1
    (continuous.observer_rhs) integrated with the plant by DOP853; halving h shrinks the gap (order ≥ 1.5)."""
    k, l = 2.0, 3.0
    J_inv = np.linalg.inv(J)
    w0, r_hat0 = np.array([0.4, -0.3, 0.5]), np.array([0.2, 0.9, 0.1])
    b0 = V.copy()  # R(0) = I
    xi0 = continuous.xi_for_omega_hat(np.zeros(3), b0[None], r_hat0[None], [k], J_inv)

    def f(_, y):
        R, w, xi, rh = y[:9].reshape(3, 3), y[9:12], y[12:15], y[15:18]
        b = R.T @ V
        dR, dw = _plant_rhs(R, w, J, J_inv)
        dxi, drh = continuous.observer_rhs(xi, rh[None], b[None], np.zeros(3), J, J_inv, [k], [l], [0.0])
        return np.concatenate([dR.ravel(), dw, dxi, drh[0]])

    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    y0 = np.concatenate([np.eye(3).ravel(), w0, xi0, r_hat0])
    sol = solve_ivp(f, (0, t[-1]), y0, t_eval=t, method="DOP853", rtol=1e-11, atol=1e-12)
    Rs = sol.y[:9].T.reshape(-1, 3, 3)
    b = np.einsum("tji,j->ti", Rs, V)
    w_hat = np.array(
        [
            continuous.output_map(x, bb[None], r[None], [k], J_inv)
            for x, bb, r in zip(sol.y[12:15].T, b, sol.y[15:18].T, strict=True)
        ]
    )
    gaps = []
    for stride in (2, 1):
        W, _ = run_single_direction(t[::stride], b[::stride], J, k=k, l=l, r_hat0=r_hat0)
        gaps.append(np.abs(W - w_hat[::stride]).max())
    assert gaps[1] < 1e-5  # measured 1.2e-6
    assert gaps[0] / gaps[1] > 3.0  # measured 4.0 (second order: the great-circle input (D8))


def test_gradient_observer_matches_its_equations_integrated_by_scipy():
    """(D6) integrated with the plant by DOP853 (the right-hand side written out here) against the sampled one."""
    k, l = 1.5, 2.0
    J_inv = np.linalg.inv(J)
    w0, wh0, bh0 = np.array([0.4, -0.3, 0.5]), np.array([0.1, 0.0, -0.2]), np.array([0.0, 1.0, 0.0])

    def f(_, y):
        R, w, wh, bh = y[:9].reshape(3, 3), y[9:12], y[12:15], y[15:18]
        b = R.T @ V
        dR, dw = _plant_rhs(R, w, J, J_inv)
        dwh = J_inv @ (np.cross(J @ wh, wh) + k * np.cross(b, bh))
        dbh = np.cross(bh, wh) - l * (bh - b)
        return np.concatenate([dR.ravel(), dw, dwh, dbh])

    t = np.arange(0.0, 4.0 + 1e-9, 0.01)
    sol = solve_ivp(f, (0, t[-1]), np.concatenate([np.eye(3).ravel(), w0, wh0, bh0]), t_eval=t, method="DOP853",
                    rtol=1e-11, atol=1e-12)  # fmt: skip
    b = np.einsum("tji,j->ti", sol.y[:9].T.reshape(-1, 3, 3), V)
    W, _ = run_single_direction(t, b, J, method="gradient", k=k, l=l, omega_hat0=wh0, r_hat0=bh0)
    assert np.abs(W - sol.y[12:15].T).max() < 1e-5  # measured 5.2e-7


@pytest.mark.parametrize("method", ["sarras", "gradient"])
def test_converges_on_torque_free_tumbling_body_from_rest(method):
    """J = diag(3, 2, 1), torque-free tumble (truth: omegahat's CF4 integrator, tested against closed forms), exact
    directions at 10 Hz, start ω̂ = 0 with |ω| = 0.54 rad/s: the error falls below 1e-3 rad/s and stays there."""
    t = np.arange(0.0, 80.0, 0.1)
    tr, b = _tumble([0.3, 0.2, -0.4], t)
    k, l = default_gains(J, method, 1.0 / (2 * np.pi))  # 1 rad/s
    W, _ = run_single_direction(t, b, J, method=method, k=k, l=l)
    err = np.linalg.norm(W - tr.omega, axis=1)
    assert err[0] > 0.5
    assert err[t > 40].max() < 1e-3  # measured 5.0e-4 (sarras), 1.8e-4 (gradient): the great-circle input's O(h²)


@pytest.mark.parametrize("method", ["sarras", "gradient"])
def test_known_torque_is_used_and_an_ignored_one_biases_the_estimate(method):
    """A constant torque (truth: the CF4 integrator with it): given to the observer, the error falls to the
    great-circle input's floor (which grows with |ω|² as the torque spins the body up); withheld, the estimate lags
    by far more (the torque is a disturbance J⁻¹ τ in ż)."""
    t = np.arange(0.0, 60.0, 0.1)
    tau = np.array([0.02, -0.01, 0.015])
    tr = integrate(RigidBody(J), np.eye(3), [0.3, 0.2, -0.4], t, torque=tau)
    b = np.einsum("tji,j->ti", tr.R, V)
    k, l = default_gains(J, method, 1.0 / (2 * np.pi))  # 1 rad/s
    given, _ = run_single_direction(t, b, J, method=method, k=k, l=l, torques=tr.torque)
    withheld, _ = run_single_direction(t, b, J, method=method, k=k, l=l)
    late = t > 40
    assert np.linalg.norm(given - tr.omega, axis=1)[late].max() < 2.5e-3  # measured 1.3e-3, 6.2e-4
    assert np.linalg.norm(withheld - tr.omega, axis=1)[late].max() > 0.02  # measured 0.044, 0.049


def test_batched_runs_equal_single_runs():
    """Several runs at once (T, B, 3) give what each gives alone."""
    t = np.arange(0.0, 5.0, 0.1)
    bs = np.stack([_tumble(w, t)[1] for w in ([0.3, 0.2, -0.4], [-0.5, 0.1, 0.2])], axis=1)
    W, _ = run_single_direction(t, bs, J, k=2.0, l=2.0, omega_hat0=[[0.1, 0, 0], [0, 0.2, 0]])
    for j, w0 in enumerate(([0.1, 0, 0], [0, 0.2, 0])):
        Wj, _ = run_single_direction(t, bs[:, j], J, k=2.0, l=2.0, omega_hat0=w0)
        np.testing.assert_allclose(W[:, j], Wj, rtol=0, atol=1e-13)


def test_printed_sign_fails_to_converge_where_corrected_sign_converges():
    """The paper's misprinted output map (sign −1) with one direction and moderate l does not converge."""
    t = np.arange(0.0, 60.0, 0.05)
    tr, b = _tumble([0.3, 0.2, -0.4], t)
    good, _ = run_single_direction(t, b, J, k=1.5, l=1.0, sign=continuous.OUTPUT_SIGN_CORRECTED)
    bad, _ = run_single_direction(t, b, J, k=1.5, l=1.0, sign=continuous.OUTPUT_SIGN_PRINTED)
    late = t > 30
    assert np.linalg.norm(good - tr.omega, axis=1)[late].max() < 1e-3  # measured 1.5e-4
    assert np.linalg.norm(bad - tr.omega, axis=1)[late].max() > 0.1  # measured 2.0


@pytest.mark.parametrize("method", ["sarras", "gradient"])
def test_spin_about_the_measured_direction_is_detected_and_its_rate_is_not_recovered(method):
    """A spin about the principal axis e3 with v = e3: b is constant, so the monitor flags every sample after the
    first window, names e3, and the estimate keeps its initial error about e3 (nothing can correct it)."""
    t = np.arange(0.0, 30.0, 0.1)
    _, b = _tumble([0.0, 0.0, 0.8], t, v=np.array([0.0, 0.0, 1.0]))
    est = SingleDirectionEstimator(J, reference=[0, 0, 1], method=method, omega_hat0=[0.0, 0.0, 0.3])
    with pytest.warns(LostExcitationWarning, match=r"rate about the body axis \[.*1\.\] is not observable"):
        W = est.run(t, b).omega
    assert est.unobservable[t >= 10.0].all() and not est.unobservable[t < 10.0].any()
    assert abs(abs(est.weak_axis[-1, 2]) - 1.0) < 1e-12
    np.testing.assert_allclose(W, np.tile([0.0, 0.0, 0.3], (t.size, 1)), rtol=0, atol=1e-12)  # the truth: 0.8 e3


def test_tumbling_body_is_not_flagged_even_with_sun_sensor_noise():
    """A tumble seen through 0.1° noise: λ_min of the windowed Gramian stays far above the threshold."""
    t = np.arange(0.0, 60.0, 0.1)
    _, b = _tumble([0.3, 0.2, -0.4], t)
    b = b + np.random.default_rng(3).normal(0.0, np.radians(0.1), b.shape)
    est = SingleDirectionEstimator(J, reference=V)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LostExcitationWarning)
        est.run(t, b)
    assert not est.unobservable.any()
    assert est.excitation[t >= 10].min() > 0.1  # measured 0.42


def test_excitation_gramian_closed_form_for_a_cone():
    """b on a cone of half-angle α about e3, sampled uniformly over whole turns: the mean of b bᵀ is
    diag(sin²α/2, sin²α/2, cos²α), so the mean of I − b bᵀ has λ_min = sin²α (for α < 54.7°) with eigenvector e3,
    the cone's axis; with a window much longer than the turn, the weighted mean approaches it."""
    alpha = np.radians(10.0)
    t = np.arange(0.0, 200.0, 0.01)
    phi = 2 * np.pi * t  # one turn a second
    b = np.stack([np.sin(alpha) * np.cos(phi), np.sin(alpha) * np.sin(phi), np.full_like(t, np.cos(alpha))], 1)
    lam, axis, _ = excitation(t, b, window_s=50.0)
    assert abs(lam[-1] - np.sin(alpha) ** 2) < 2e-3 * np.sin(alpha) ** 2
    assert abs(abs(axis[-1, 2]) - 1.0) < 1e-4


def test_lyapunov_function_never_increases_for_a_spherical_body():
    """(D7) with J = c I: V = ½|b̂ − b|² + (c/2k)|z|² is non-increasing along the continuous gradient observer."""
    c, k, l = 2.0, 1.0, 1.5
    Js, Js_inv = c * np.eye(3), np.eye(3) / c
    rng = np.random.default_rng(5)
    v = np.array([0.0, 0.0, 1.0])

    def f(_, y):
        R, w, wh, bh = y[:9].reshape(3, 3), y[9:12], y[12:15], y[15:18]
        b = R.T @ v
        dR, dw = _plant_rhs(R, w, Js, Js_inv)
        dwh, dbh = gradient_rhs(wh, bh, b, np.zeros(3), Js, Js_inv, k, l)
        return np.concatenate([dR.ravel(), dw, dwh, dbh])

    R0 = Rotation.random(random_state=rng).as_matrix()
    y0 = np.concatenate([R0.ravel(), rng.normal(size=3), np.zeros(3), rng.normal(size=3)])
    sol = solve_ivp(f, (0, 20), y0, t_eval=np.linspace(0, 20, 401), rtol=1e-10, atol=1e-12)
    b = np.einsum("tji,j->ti", sol.y[:9].T.reshape(-1, 3, 3), v)
    Vl = 0.5 * np.sum((sol.y[15:18].T - b) ** 2, 1) + c / (2 * k) * np.sum((sol.y[12:15] - sol.y[9:12]).T ** 2, 1)
    assert np.all(np.diff(Vl) <= 1e-9)
    assert Vl[-1] < 0.5 * Vl[0]


def test_missing_samples_are_predicted_through_and_state_continues_across_calls():
    """NaN rows are predicted along the estimate (a finite output there); two calls equal one call."""
    t = np.arange(0.0, 20.0, 0.1)
    tr, b = _tumble([0.3, 0.2, -0.4], t)
    b[50:55] = np.nan
    one = SingleDirectionEstimator(J, reference=V, bandwidth_hz=1.0 / (2 * np.pi))
    W1, status = one.run(t, b)
    two = SingleDirectionEstimator(J, reference=V, bandwidth_hz=1.0 / (2 * np.pi))
    W2 = np.concatenate([two.run(t[:100], b[:100]).omega, two.run(t[100:], b[100:]).omega])
    assert np.all(np.isfinite(W1[50:55])) and np.all(status[50:55] == Status.PREDICTED)
    assert status[0] == Status.UNAVAILABLE and np.all(np.isnan(W1[0]))  # one direction at one instant: no rate
    np.testing.assert_allclose(W1, W2, rtol=0, atol=1e-12)
    assert np.linalg.norm(W1[-1] - tr.omega[-1]) < 0.01


def test_one_reference_in_the_n_direction_api_points_to_the_single_direction_estimator():
    import omegahat

    with pytest.raises(ValueError, match=r"references holds one direction: .* use omegahat\.SingleDirectionEstimator"):
        omegahat.sensor_gains(J, rate_hz=10.0, measurement_noise=1e-3, bandwidth_hz=0.1, references=[[0.0, 0.0, 1.0]])
    assert omegahat.SingleDirectionEstimator is SingleDirectionEstimator


def test_errors():
    t = np.arange(3.0)
    b = np.tile([0.0, 0.0, 1.0], (3, 1))
    with pytest.raises(ValueError, match="method must be one of sarras, gradient; got 'x'"):
        run_single_direction(t, b, J, method="x", k=1.0, l=1.0)
    with pytest.raises(ValueError, match="method must be one of sarras, gradient; got 'x'"):
        default_gains(J, "x", 1.0)
    with pytest.raises(ValueError, match=r"b must have shape \(T, 3\) or \(T, B, 3\) with T = len\(t\) = 3"):
        run_single_direction(t, b[:2], J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="sample times t must be increasing"):
        run_single_direction(t[::-1], b, J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="the first sample must be a valid direction"):
        run_single_direction(t, np.vstack([[np.nan] * 3, b[1:]]), J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="no samples"):
        run_single_direction(t[:0], b[:0], J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="sample 0: the measured direction b has zero length"):
        run_single_direction(t, np.zeros((3, 3)), J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="sample 2: the measured direction b has zero length"):
        run_single_direction(t, np.vstack([b[:2], [0.0, 0.0, 0.0]]), J, k=1.0, l=1.0)
    with pytest.raises(ValueError, match="give both k and l, or neither"):
        SingleDirectionEstimator(J, k=1.0)
    with pytest.raises(ValueError, match="reference must be a non-zero vector"):
        SingleDirectionEstimator(J, reference=[0, 0, 0])
    none = SingleDirectionEstimator(J).run(t, np.full((3, 3), np.nan))  # no valid sample: no estimate, no error
    assert np.all(np.isnan(none.omega)) and np.all(none.status == Status.UNAVAILABLE)
    with pytest.raises(
        ValueError, match=r"^measurements must have shape \(T, 3\) or \(T, 1, 3\) with T = 3 samples; got shape"
    ):  # the one input path's message (measurements' n = 1 path), as for every estimator
        SingleDirectionEstimator(J).run(t, b[:2])
    with pytest.raises(ValueError, match=r"^a one-direction sample must have shape \(3,\) or \(1, 3\); got shape"):
        SingleDirectionEstimator(J).update(0.0, b[:2])
    with pytest.raises(ValueError, match=r"b must have shape \(T, 3\) with T = len\(t\) = 3"):
        excitation(t, b[:2])
    est = SingleDirectionEstimator(J)
    est.run(t, b)
    with pytest.raises(ValueError, match=r"sample 0: time t = 1\.0 is not after the previous sample's t = 2\.0"):
        est.run(t[1:], b[1:])
    with pytest.raises(ValueError, match=r"the sample \(t = 3\.0\): measured direction b1 has zero length"):
        est.update(3.0, [0.0, 0.0, 0.0])  # refused by the one input path, and nothing changes:
    np.testing.assert_allclose(
        est.update(3.0, b[0]).omega, SingleDirectionEstimator(J).run([*t, 3.0], [*b, b[0]]).omega[-1]
    )


@pytest.mark.parametrize("omega_hat0", [None, [0.1, 0.0, -0.2]])
def test_update_equals_run_through_missing_samples(omega_hat0):
    # update's scalar bookkeeping and run's array bookkeeping must agree: the first sample(s) unavailable (two valid
    # samples are needed without an initial rate), missing samples predicted and counted
    t = np.arange(40) * 0.05
    b = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).inv().apply(V)
    b[[0, 7, 8, 20]] = np.nan  # the very first one too: the availability count starts at the first valid sample
    batch = SingleDirectionEstimator(J, reference=V, omega_hat0=omega_hat0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = batch.run(t, b)
    est = SingleDirectionEstimator(J, reference=V, omega_hat0=omega_hat0)
    steps = [est.update(tk, bk) for tk, bk in zip(t, b, strict=True)]
    np.testing.assert_array_equal(np.array([s.status for s in steps], dtype=np.int8), whole.status)
    np.testing.assert_allclose(np.array([s.omega for s in steps]), whole.omega, rtol=0, atol=1e-12)
    assert est.n_skipped == batch.n_skipped == 4
    first_estimate = 1 if omega_hat0 is not None else 2  # the index of the first sample with an estimate
    assert whole.status[first_estimate] != Status.UNAVAILABLE and whole.status[first_estimate - 1] == Status.UNAVAILABLE
    assert all(isinstance(s.status, Status) for s in steps)
