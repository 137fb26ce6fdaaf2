"""The sampled Sarras estimator: prediction order, kernel == NumPy oracle, stream == batch, the acceptance grid
of issue 3.1, the linearised correction, and every bad-input behaviour (state intact afterwards)."""

from __future__ import annotations

import itertools
import re
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat.interface import Status
from omegahat.measurements import MeasurementError
from omegahat.observer.estimator import EstimatorState, SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.observer.reference import reference_predict, reference_step

PAPER_J = np.diag([3.0, 2.0, 1.0])
PAPER_W0 = np.array([2.0, -1.0, 0.6])
PAPER_RHAT0 = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])


def _hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def truth(J, w0, times, torque=lambda t: np.zeros(3), breaks=()):
    """Independent ground truth: (R, ω) at ``times`` by SciPy's DOP853 on (R, ω) ∈ R^12, rtol 1e-12.

    ``breaks`` are times where the (piecewise-constant) torque changes; integration restarts there.
    """
    J_inv = np.linalg.inv(J)

    def rhs(t, y, tau):
        R, w = y[:9].reshape(3, 3), y[9:]
        return np.concatenate([(R @ _hat(w)).ravel(), J_inv @ (np.cross(J @ w, w) + tau)])

    edges = [times[0], *[b for b in breaks if times[0] < b < times[-1]], times[-1]]
    y = np.concatenate([np.eye(3).ravel(), w0])
    Rs, Ws = [], []
    for a, b in itertools.pairwise(edges):
        sel = (times >= a) & ((times < b) if b < times[-1] else (times <= b))
        tau = torque(a)
        sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-12, atol=1e-12, t_eval=times[sel], args=(tau,))
        Rs.append(sol.y[:9].T.reshape(-1, 3, 3))
        Ws.append(sol.y[9:].T)
        y = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=1e-12, atol=1e-12, args=(tau,)).y[:, -1]
    return np.concatenate(Rs), np.concatenate(Ws)


def constant_rate_attitudes(w, times):
    return Rotation.from_rotvec(times[:, None] * w).as_matrix()  # R(t) = exp(t ω×): Ṙ = R ω× for constant ω


# ------------------------------------------------------------------------------------------------ prediction


def test_prediction_is_fourth_order_against_dop853():
    J, J_inv, tau = PAPER_J, np.linalg.inv(PAPER_J), np.array([0.3, -0.5, 0.2])
    h = 0.5
    R_ref, W_ref = truth(J, PAPER_W0, np.array([0.0, h]), torque=lambda t: tau)
    g = ObserverGains.constant(1.0, 1.0, n=3)
    errs = []
    angles = [0.2, 0.1, 0.05]
    for ang in angles:
        w, rp, _, _ = reference_predict(PAPER_W0, np.eye(3), np.zeros((3, 3)), tau, h, J, J_inv, g, ang)
        # predicted rows of R: r_i(h) = R(h)ᵀ e_i, i.e. the rows of R(h)
        errs.append(max(np.abs(w - W_ref[-1]).max(), np.abs(rp - R_ref[-1]).max()))
    order = np.polyfit(np.log(angles), np.log(errs), 1)[0]
    assert 3.6 < order < 4.4, (errs, order)


def test_prediction_decay_is_exact_for_constant_rate():
    """e_i = exp(−∫ l dt) ΔR̂ᵀ e_i0 with l = l_offset + l_slope |ω̂|; constant ω̂ (J = I): ΔR̂ = exp(h ω̂)."""
    w0 = np.array([0.4, -1.0, 2.0])
    g = ObserverGains(k=[1.0, 1.0], l_offset=[5.0, 50.0], l_slope=[0.0, 7.0])
    e0 = np.array([[0.1, 0.2, -0.3], [0.0, 0.5, 0.1]])
    h = 0.3
    _, _, e, _ = reference_predict(w0, np.eye(3)[:2], e0, np.zeros(3), h, np.eye(3), np.eye(3), g)
    D = Rotation.from_rotvec(h * w0).as_matrix()
    expected = np.exp(-(g.l_offset + g.l_slope * np.linalg.norm(w0)) * h)[:, None] * (e0 @ D)
    np.testing.assert_allclose(e, expected, rtol=1e-12, atol=1e-300)


# ------------------------------------------------------------------------------------ kernel, oracle, stream


def _tumbling_log(T=300, h=0.01, seed=0):
    rng = np.random.default_rng(seed)
    times = np.cumsum(np.r_[0.0, h * (0.5 + rng.random(T - 1))])  # irregular intervals
    R, W = truth(PAPER_J, PAPER_W0, times)
    return times, R, W


def test_compiled_step_matches_numpy_oracle():
    times, R, _ = _tumbling_log(T=200)
    taus = 0.3 * np.sin(np.arange(200))[:, None] * np.array([1.0, -2.0, 0.5])
    g = ObserverGains(k=[14.5, 14.5], l_offset=[40.0, 40.0], l_slope=[3.0, 3.0])
    est = SarrasEstimator(PAPER_J, gains=g, r_hat0=PAPER_RHAT0, omega_hat0=np.zeros(3))
    W = est.run(times, R, taus).omega
    st = EstimatorState(np.nan, False, np.nan, np.zeros(3), np.zeros(3), np.zeros((2, 3)), np.zeros((2, 3)))
    for j, t in enumerate(times):
        st = reference_step(st, t, R[j][:2], taus[j], PAPER_J, g, r_hat0=PAPER_RHAT0)
        np.testing.assert_allclose(W[j], st.omega_hat, rtol=0, atol=1e-12)
    final = est.state
    np.testing.assert_allclose(final.e, st.e, atol=1e-12)
    np.testing.assert_allclose(final.r, st.r, atol=1e-15)


def test_stream_equals_batch():
    times, R, _ = _tumbling_log(T=300)
    q = Rotation.from_matrix(R).as_quat()
    taus = np.tile([0.1, 0.0, -0.2], (300, 1))
    g = theorem_gains(PAPER_J, 3.0)
    batch = SarrasEstimator(PAPER_J, gains=g).run(times, q, taus)
    est = SarrasEstimator(PAPER_J, gains=g)
    stream = [est.update(t, q[j], taus[j]) for j, t in enumerate(times)]
    np.testing.assert_allclose([s.omega for s in stream], batch.omega, rtol=0, atol=1e-12)
    np.testing.assert_array_equal([s.status for s in stream], batch.status)
    assert batch.status[0] == Status.UNAVAILABLE and np.all(batch.status[1:] == Status.CORRECTED)  # warm start


# ------------------------------------------------------------------------------------------ acceptance (3.1)


@pytest.mark.parametrize("rate", [1.0, 10.0, 100.0, 1000.0])
def test_acceptance_grid_constant_rate(rate):
    """Noise-free constant rate, k h / J_m from 0.01 to 100, J = I and an axisymmetric spin: steady error < 1e-8,
    no divergence (the error never grows beyond its initial value and stays finite)."""
    h = 1.0 / rate
    bodies = [(np.eye(3), np.array([0.3, -0.2, 0.4])), (np.diag([1.0, 1.0, 2.0]), np.array([0.0, 0.0, 0.5]))]
    for J, w in bodies:
        J_m = np.linalg.eigvalsh(J)[0]
        for kh_J in [0.01, 0.1, 1.0, 10.0, 100.0]:
            k = kh_J * J_m / h
            for n, l in [(2, 1.0), (3, 1e4)]:
                # slowest linearised mode: z ← z / (1 + h μ / J_M) with μ = k (two rows) or 2k (three rows)
                mu = k * (1 if n == 2 else 2)
                contraction = 1.0 / (1.0 + h * mu / np.linalg.eigvalsh(J)[-1])
                T = int(min(20000, max(60, np.log(1e-11) / np.log(contraction))))
                times = np.arange(T) * h
                est = SarrasEstimator(J, gains=ObserverGains.constant(k, l, n=n))
                W, status = est.run(times, constant_rate_attitudes(w, times))
                assert status[0] == Status.UNAVAILABLE and np.all(np.isnan(W[0]))  # a warm start: from the 2nd
                err = np.linalg.norm(W[1:] - w, axis=1)
                assert np.all(np.isfinite(err))
                assert err.max() <= np.linalg.norm(w) * (1 + 1e-9), (J, kh_J, n, err.max())
                assert err[-1] < 1e-8, (rate, np.diag(J), kh_J, n, err[-1])


def _paper_run(torque_pieces=None):
    """The paper's body sampled at 1 kHz for 5 s from the paper's initial estimate (theorem gains)."""
    h = 1e-3
    times = np.arange(5001) * h
    if torque_pieces is None:
        R, W = truth(PAPER_J, PAPER_W0, times)
        taus = None
    else:  # piecewise-constant known torque, changing every 0.1 s (a digital controller's command)
        breaks = np.arange(0.1, 5.0, 0.1)
        R, W = truth(PAPER_J, PAPER_W0, times, torque=torque_pieces, breaks=breaks)
        taus = np.array([torque_pieces(np.floor(t / 0.1 + 1e-9) * 0.1) for t in times])
    est = SarrasEstimator(PAPER_J, gains=theorem_gains(PAPER_J, 3.0), r_hat0=PAPER_RHAT0, omega_hat0=np.zeros(3))
    W_hat = est.run(times, R, taus).omega
    return times, W, W_hat


def test_paper_tumbling_torque_free_1khz():
    times, W, W_hat = _paper_run()
    err = np.linalg.norm(W_hat - W, axis=1)
    assert err[0] == pytest.approx(np.linalg.norm(PAPER_W0))  # ω̂₀ = 0
    assert err[times >= 5.0 - 1e-12].max() < 1e-5, err[-1]


def test_paper_tumbling_known_torque_1khz():
    def torque(t):
        return np.array([0.5 * np.sin(t), -0.3, 0.2 * np.cos(2 * t)])

    times, W, W_hat = _paper_run(torque)
    err = np.linalg.norm(W_hat - W, axis=1)
    assert err[times >= 5.0 - 1e-12].max() < 1e-5, err[-1]
    assert np.abs(W - _paper_run()[1]).max() > 0.1  # the torque matters


def test_correction_linearises_to_the_implicit_map():
    """One sample from a small error z, e = 0, J = I, constant ω, two rows, k h = 30 (far beyond explicit Euler's
    limit 2). Derivation: ω̂ = ω + z is constant, so the prediction is exp(h ω̂) = exp(h ω) exp(h J_r z) + O(z²)
    (J_r the right Jacobian of SO(3) at h ω), hence Δ_i = −r_i × (h J_r z), y = −h M J_r z with
    M = Σ k_i (I − r_i r_iᵀ). The aim (A2) is Γ = Φ_θω = ∫₀ʰ exp(−ω×(h − s)) ds = h J_r (J = I: A = 0), so (C)
    gives z⁺ = z − (I + h M J_r)⁻¹ h M J_r z = (I + h M J_r)⁻¹ z + O(|z|²): the error is mapped as if the body
    did not turn. (A1)'s second-order substeps approximate Γ to O((h_s |ω|)²) relative (h_s |ω| = 0.027 here)."""
    w = np.array([0.3, -0.2, 0.4])
    h, k = 0.1, 300.0
    times = np.array([0.0, h])
    R = constant_rate_attitudes(w, times)
    M = sum(k * (np.eye(3) - np.outer(r, r)) for r in R[1][:2])
    phi = h * w
    th = np.linalg.norm(phi)
    P = _hat(phi)
    J_r = np.eye(3) - (1 - np.cos(th)) / th**2 * P + (th - np.sin(th)) / th**3 * P @ P
    for scale in [1e-4, 1e-5]:
        z = scale * np.array([1.0, -2.0, 0.5])
        est = SarrasEstimator(np.eye(3), gains=ObserverGains.constant(k, 1.0, n=2), omega_hat0=w + z)
        z_plus = est.run(times, R).omega[1] - w
        expected = np.linalg.solve(np.eye(3) + h * M @ J_r, z)
        aim_error = 1e-3 * scale  # |Γ − h J_r| / h ≈ (h_s|ω|)²/6 ≈ 1.2e-4
        assert np.linalg.norm(z_plus - expected) < 10 * scale**2 + aim_error, (scale, z_plus, expected)
        unaimed = z - np.linalg.solve(np.eye(3) + h * M, h * M @ J_r @ z)  # the correction before (A2)
        assert np.linalg.norm(z_plus - unaimed) > 0.02 * scale  # they differ at O(h|ω|) = 5 %
        # and the explicit jump would have overshot: z − h M J_r z is ~30 times larger
        assert np.linalg.norm(z - h * M @ J_r @ z) > 10 * np.linalg.norm(expected)


def test_equilibrium_is_exact_for_constant_rate_with_torque_free_axisymmetric_spin():
    J = np.diag([2.0, 2.0, 3.5])  # axisymmetric, and a real body (J1 + J2 >= J3)
    w = np.array([0.0, 0.0, 3.0])
    times = np.cumsum(np.r_[0, np.full(99, 0.05)])
    est = SarrasEstimator(J, gains=ObserverGains.constant(50.0, 3.0, n=3), omega_hat0=w)
    W = est.run(times, constant_rate_attitudes(w, times)).omega
    assert np.abs(W - w).max() < 1e-13


# ------------------------------------------------------------------------------------------------ bad input


def _setup(n_samples=40, h=0.01):
    times = np.arange(n_samples) * h
    R, _ = truth(PAPER_J, PAPER_W0, times)
    g = ObserverGains.constant(10.0, 20.0, n=3)
    return times, R, g


def _after_rejection(bad_call, match, times, R, g, j=20):
    """Feed samples 0..j-1, make a rejected call (must raise ``match``), continue: equals a clean stream."""
    est = SarrasEstimator(PAPER_J, gains=g)
    clean = SarrasEstimator(PAPER_J, gains=g)
    for i in range(j):
        est.update(times[i], R[i])
        clean.update(times[i], R[i])
    before = est.state.to_vector()
    with pytest.raises(ValueError, match=match):
        bad_call(est)
    np.testing.assert_array_equal(est.state.to_vector(), before)
    for i in range(j, len(times)):
        got, expected = est.update(times[i], R[i]), clean.update(times[i], R[i])
        np.testing.assert_array_equal(got.omega, expected.omega)
        assert got.status == expected.status == Status.CORRECTED


def test_rejects_non_rotation_and_keeps_state():
    times, R, g = _setup()
    bad = R[20] + 0.01 * np.arange(9).reshape(3, 3)
    err = np.linalg.norm(bad.T @ bad - np.eye(3))
    _after_rejection(
        lambda e: e.update(times[20], bad), rf"not a rotation matrix: \|R\^T R - I\| = {err:.3g}", times, R, g
    )


def test_rejects_reflection_and_keeps_state():
    times, R, g = _setup()
    bad = -R[20]
    _after_rejection(lambda e: e.update(times[20], bad), r"reflection, not a rotation: det R = -1", times, R, g)


def test_rejects_quaternion_far_from_unit_norm():
    times, R, g = _setup()
    q = 1.5 * Rotation.from_matrix(R[20]).as_quat()
    _after_rejection(lambda e: e.update(times[20], q), r"far from unit norm: \|q\| = 1\.5\b", times, R, g)


def test_rejects_time_equal_or_backwards_naming_both_times():
    times, R, g = _setup()
    t_prev = float(times[19])
    msg = rf"time t = {t_prev!r} is not after the previous sample's t = {t_prev!r}"
    _after_rejection(lambda e: e.update(t_prev, R[20]), re.escape(msg), times, R, g)
    msg = rf"time t = 0.05 is not after the previous sample's t = {t_prev!r}"
    _after_rejection(lambda e: e.update(0.05, R[20]), re.escape(msg), times, R, g)
    _after_rejection(lambda e: e.update(np.nan, R[20]), r"time t = nan is not finite", times, R, g)


def test_rejects_wrong_shapes_and_bad_torque():
    times, R, g = _setup()
    _after_rejection(lambda e: e.update(times[20], R[20][:2]), r"got shape \(2, 3\)", times, R, g)
    _after_rejection(lambda e: e.update(times[20], np.ones(5)), r"got shape \(5,\)", times, R, g)
    _after_rejection(
        lambda e: e.update(times[20], R[20], [1.0, 2.0]), r"torque must be a 3-vector; got shape \(2,\)", times, R, g
    )
    _after_rejection(
        lambda e: e.update(times[20], R[20], [1.0, np.inf, 0]), r"torque must be finite; got inf", times, R, g
    )


def test_run_is_atomic_and_names_the_sample():
    times, R, g = _setup()
    R_bad = R.copy()
    R_bad[25, 0, 0] += 0.5
    est = SarrasEstimator(PAPER_J, gains=g)
    est.run(times[:10], R[:10])
    before = est.state.to_vector()
    with pytest.raises(MeasurementError, match=r"sample 15 \(t = 0\.25\): not a rotation matrix"):
        est.run(times[10:], R_bad[10:])
    np.testing.assert_array_equal(est.state.to_vector(), before)
    with pytest.raises(ValueError, match=r"measurements must have shape \(T, 3, 3\) or \(T, 4\) with T = 30"):
        est.run(times[10:], R[10:, :2])
    with pytest.raises(ValueError, match=r"torques must have shape \(30, 3\); got shape \(30,\)"):
        est.run(times[10:], R[10:], np.zeros(30))


def test_missing_samples_are_skipped_predicted_through_and_reported():
    times, R, g = _setup(n_samples=80)
    R_nan = R.copy()
    gone = [10, 11, 12, 40]
    R_nan[gone] = np.nan
    R_nan[40, 1, 1] = np.inf  # inf counts as missing too
    est = SarrasEstimator(PAPER_J, gains=g)
    with pytest.warns(SkippedSamplesWarning, match=r"skipped 4 of 80 samples \(4 missing"):
        W, status = est.run(times, R_nan)
    assert est.n_skipped == 4 and est.n_collinear == 0 and est.skipped_times == [times[i] for i in gone]
    assert np.all(status[gone] == Status.PREDICTED)
    keep = np.setdiff1d(np.arange(80), gone)
    clean = SarrasEstimator(PAPER_J, gains=g)
    W_clean = clean.run(times[keep], R[keep]).omega
    # the prediction over a gap is split at the skipped times; RK4 substeps differ, so agreement is ~1e-12
    np.testing.assert_allclose(W[keep], W_clean, atol=1e-10)
    assert np.all(np.isfinite(W[1:])) and status[0] == Status.UNAVAILABLE  # a warm start: from the 2nd sample
    # and online: update returns the prediction and counts it
    est2 = SarrasEstimator(PAPER_J, gains=g)
    for i in range(10):
        est2.update(times[i], R[i])
    w_pred, st = est2.update(times[10], np.full((3, 3), np.nan))
    assert est2.n_skipped == 1 and st == Status.PREDICTED
    np.testing.assert_allclose(w_pred, W[10], atol=1e-12)


def test_quaternion_sign_flips_give_the_same_result():
    times, R, g = _setup(n_samples=60)
    q = Rotation.from_matrix(R).as_quat()
    flips = np.where(np.random.default_rng(1).random(60) < 0.5, -1.0, 1.0)
    W1 = SarrasEstimator(PAPER_J, gains=g).run(times, q).omega
    W2 = SarrasEstimator(PAPER_J, gains=g).run(times, q * flips[:, None]).omega
    np.testing.assert_array_equal(W1, W2)
    qs = np.roll(q * flips[:, None], 1, axis=1)  # scalar first
    W3 = SarrasEstimator(PAPER_J, gains=g, scalar_first=True).run(times, qs).omega
    W4 = SarrasEstimator(PAPER_J, gains=g).run(times, Rotation.from_matrix(R)).omega
    np.testing.assert_allclose(W3, W1, atol=1e-12)
    np.testing.assert_allclose(W4, W1, atol=1e-12)


def test_direction_input_and_collinear_measurements_are_skipped():
    """Accelerometer + magnetometer style input: two inertial directions 60° apart, measured in the body."""
    times = np.arange(60) * 0.01
    R, _ = truth(PAPER_J, PAPER_W0, times)
    V = np.array([[0.0, 0.0, 1.0], [0.0, np.sqrt(3) / 2, 0.5]])
    B = np.einsum("ij,tjk->tik", V, R) * np.array([9.81, 45.0])[None, :, None]  # r = V R, unnormalised
    g = ObserverGains.constant(8.0, 20.0, n=2)
    est = SarrasEstimator(PAPER_J, gains=g, references=V)
    W_dir = est.run(times, B).omega
    W_att = SarrasEstimator(PAPER_J, gains=g, references=V, measurement="attitude").run(times, R).omega
    np.testing.assert_allclose(W_dir, W_att, atol=1e-12)
    B_bad = B.copy()
    B_bad[30, 1] = B_bad[30, 0] * 2 + 1e-4  # magnetometer pulled onto gravity: 0.0006° apart
    est = SarrasEstimator(PAPER_J, gains=g, references=V)
    with pytest.warns(SkippedSamplesWarning, match=r"1 with nearly collinear directions"):
        est.run(times, B_bad)
    assert est.n_collinear == 1 and est.skipped_times == [times[30]]
    with pytest.raises(MeasurementError, match=r"measured direction b2 has zero length"):
        est.update(1.0, np.array([[0, 0, 1.0], [0, 0, 0]]))
    with pytest.raises(ValueError, match=r"must have shape \(2, 3\) \(one row per reference\); got shape \(3, 3\)"):
        est.update(1.0, np.eye(3))


def test_constructor_errors():
    g2 = ObserverGains.constant(1.0, 1.0, n=2)
    with pytest.raises(ValueError, match=r"2 gains were given for 3 reference directions"):
        SarrasEstimator(np.eye(3), gains=g2, references=np.eye(3))
    with pytest.raises(ValueError, match=r"measurement='directions' needs the inertial references"):
        SarrasEstimator(np.eye(3), gains=g2, measurement="directions")
    with pytest.raises(ValueError, match=r"r_hat0 must be 2 finite directions, shape \(2, 3\)"):
        SarrasEstimator(np.eye(3), gains=g2, r_hat0=np.zeros(3))
    with pytest.raises(TypeError, match=r"gains must be an omegahat.observer.gains.ObserverGains; got dict"):
        SarrasEstimator(np.eye(3), gains={"k": 1})
    with pytest.raises(ValueError, match=r"rotation_tol must be positive and finite; got \[-1\.\]"):
        SarrasEstimator(np.eye(3), gains=g2, rotation_tol=-1)


def test_reset_and_uninitialised_output():
    times, R, g = _setup()
    est = SarrasEstimator(PAPER_J, gains=g, omega_hat0=[1.0, 2.0, 3.0])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)
        w, status = est.run(times[:2], np.full((2, 3, 3), np.nan))
    assert np.all(np.isnan(w)) and np.all(status == Status.UNAVAILABLE)  # no estimate before a valid sample
    np.testing.assert_array_equal(est.omega_hat, [1.0, 2.0, 3.0])  # the state waits at ω̂₀
    assert not est.state.initialised
    first, status = est.run(times[2:], R[2:])
    assert np.all(status == Status.CORRECTED)  # ω̂₀ given: an estimate from the first valid sample on
    np.testing.assert_array_equal(first[0], [1.0, 2.0, 3.0])
    est.reset()
    assert est.n_skipped == 0 and np.isnan(est.state.t)
    np.testing.assert_array_equal(est.run(times[2:], R[2:]).omega, first)


def test_gap_to_the_continuous_observer_is_first_order_in_h():
    """Quick version of benchmarks/sampled_convergence.py: paper scenario, gap at t = 1 s for h = 4, 2, 1 ms."""
    from omegahat.simulation import paper_problem, simulate

    prob = paper_problem()
    hs = [4e-3, 2e-3, 1e-3]
    t_out = np.arange(1001) * 1e-3
    cont = simulate(prob, t_out=t_out, rtol=1e-10)
    gaps = []
    for h in hs:
        sel = slice(0, None, round(h / 1e-3))
        est = SarrasEstimator(prob.J, gains=prob.gains, references=prob.references, r_hat0=prob.r_hat0)
        W = est.run(t_out[sel], cont.r[sel]).omega
        gaps.append(np.linalg.norm(W[-1] - cont.omega_hat[-1]))
    order = np.polyfit(np.log(hs), np.log(gaps), 1)[0]
    assert 0.85 < order < 1.4, (gaps, order)
    assert gaps[-1] < 5e-4


# ----------------------------------------------------------------------------------------- warm start (W)


@pytest.mark.parametrize("angle_per_sample", [0.01, 1.0, 2.5])
def test_warm_start_is_exact_for_a_constant_rate(angle_per_sample):
    # J = I, torque-free: ω is constant, so log(ΔR)/h is the rate exactly, even for 2.5 rad between samples
    w = np.array([0.8, -1.2, 1.5])
    h = angle_per_sample / np.linalg.norm(w)
    times = h * np.arange(6)
    est = SarrasEstimator(np.eye(3), gains=ObserverGains.constant(0.5, 5.0, n=3), warm_start=True)
    W, status = est.run(times, constant_rate_attitudes(w, times))
    assert np.all(np.isnan(W[0])) and status[0] == Status.UNAVAILABLE  # no estimate until the second sample
    np.testing.assert_allclose(W[1:], np.tile(w, (5, 1)), rtol=0, atol=1e-13)


def test_warm_start_error_is_second_order_in_h():
    # torque-free tumbling of the paper's body against DOP853: the error at the second sample is O(h²)
    hs = np.array([0.04, 0.02, 0.01, 0.005])
    errs = []
    for h in hs:
        times = np.array([0.0, h])
        R, w = truth(PAPER_J, PAPER_W0, times)
        est = SarrasEstimator(PAPER_J, gains=theorem_gains(PAPER_J, 3.0), warm_start=True)
        errs.append(np.linalg.norm(est.run(times, R).omega[1] - w[1]))
    order = np.polyfit(np.log(hs), np.log(errs), 1)[0]
    assert 1.9 < order < 2.1, (order, errs)


def test_warm_start_compiled_matches_numpy_oracle_through_skips():
    times, R, _ = _tumbling_log(T=60)
    R = R.copy()
    R[1] = np.nan  # skipped while the warm start waits
    R[4] = np.nan  # skipped afterwards
    taus = 0.3 * np.sin(np.arange(60))[:, None] * np.array([1.0, -2.0, 0.5])
    g = ObserverGains(k=[14.5, 14.5], l_offset=[40.0, 40.0], l_slope=[3.0, 3.0])
    est = SarrasEstimator(PAPER_J, gains=g, r_hat0=PAPER_RHAT0, warm_start=True)
    with pytest.warns(SkippedSamplesWarning):
        W, status = est.run(times, R, taus)
    np.testing.assert_array_equal(status[:3], [Status.UNAVAILABLE, Status.UNAVAILABLE, Status.CORRECTED])
    st = EstimatorState(np.nan, False, np.nan, np.zeros(3), np.zeros(3), np.zeros((2, 3)), np.zeros((2, 3)))
    for j, t in enumerate(times):
        r_meas = None if np.isnan(R[j]).any() else R[j][:2]
        st = reference_step(st, t, r_meas, taus[j], PAPER_J, g, r_hat0=PAPER_RHAT0, warm_start=True)
        if status[j] != Status.UNAVAILABLE:  # the warm start's first sample and the skip while it waits: none
            np.testing.assert_allclose(W[j], st.omega_hat, rtol=0, atol=1e-12)
        if j == 1:
            assert st.warm_pending
    assert not est.state.warm_pending
    np.testing.assert_allclose(est.state.e, st.e, atol=1e-12)
    np.testing.assert_allclose(est.state.r, st.r, atol=1e-15)


def test_warm_start_keeps_state_on_rejection_and_round_trips():
    times, R, _ = _tumbling_log(T=3)
    est = SarrasEstimator(PAPER_J, gains=theorem_gains(PAPER_J, 3.0), warm_start=True)
    est.update(times[0], R[0])
    before = est.state.to_vector()
    assert est.state.warm_pending
    with pytest.raises(MeasurementError):
        est.update(times[1], 2.0 * R[1])
    np.testing.assert_array_equal(est.state.to_vector(), before)
    np.testing.assert_array_equal(EstimatorState.from_vector(before).to_vector(), before)  # stage 1 survives
    est.update(times[1], R[1])
    assert not est.state.warm_pending
    est.reset()
    assert not est.state.initialised and not est.state.warm_pending
