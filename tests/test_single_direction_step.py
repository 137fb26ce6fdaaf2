"""The one-direction observer's compiled step (observer/single_direction_step.py) against its NumPy oracle
(observer/single_direction.py: ``run_single_direction`` and ``excitation``, written from the equations and tested
against SciPy in test_single_direction.py): ω̂, λ_min and the weak axis to 1e-10 and the monitor's flags identical,
on several seeds, both methods, missing samples, irregular times with long gaps (many RK4 substeps), known torques,
chunked and one-sample calls; the closed-form eigen-solver against LAPACK (NumPy's ``eigh``); the input checks."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.measurements import MeasurementError
from omegahat.observer import single_direction_step as step
from omegahat.observer.continuous import OUTPUT_SIGN_PRINTED
from omegahat.observer.single_direction import (
    LostExcitationWarning,
    SingleDirectionEstimator,
    default_gains,
    excitation,
    run_single_direction,
)

TOL = 1e-10


def _case(seed, T=400):
    """An arbitrary log: a random inertia (not diagonal), reference, smooth attitude path, irregular times (some
    gaps of seconds), noise, missing rows (leading ones too) and a piecewise constant torque."""
    rng = np.random.default_rng(seed)
    Q = Rotation.random(random_state=rng).as_matrix()
    J = Q @ np.diag(rng.uniform(2.0, 3.8, 3)) @ Q.T  # principal moments: a rigid body
    v = rng.normal(size=3)
    h = rng.uniform(0.02, 0.2, T)
    h[rng.choice(T, 4, replace=False)] = rng.uniform(1.0, 3.0, 4)  # long intervals: many substeps
    t = 5.0 + np.cumsum(h)
    w, a = rng.normal(0.0, 0.6, 3), rng.normal(0.0, 0.4, 3)
    R = Rotation.from_rotvec(np.outer(t, w) + np.outer(np.sin(0.3 * t), a)).as_matrix()
    b = np.einsum("tji,j->ti", R, v) + rng.normal(0.0, 2e-3, (T, 3))  # not unit: the step normalises
    b[rng.choice(np.arange(3, T), 25, replace=False)] = np.nan
    b[60:70] = np.nan  # a run of missing samples: predicted along the estimate
    b[:2] = np.nan  # nothing to estimate from before the first valid sample
    tau = np.repeat(rng.normal(0.0, 0.05, (T // 50 + 1, 3)), 50, axis=0)[:T]
    return J, v, t, b, tau


def _oracle(J, t, b, tau, method, k, l, omega_hat0=None, r_hat0=None, sign=1.0, window_s=10.0, threshold=1e-3):
    """The NumPy functions as SingleDirectionEstimator.run uses them: ω̂ from the first valid sample on (none there
    unless ``omega_hat0`` is given: the estimator contract's first sample), the monitor over every row."""
    f = int(np.flatnonzero(np.all(np.isfinite(b), axis=1))[0])
    W = np.full(b.shape, np.nan)
    W[f:], _ = run_single_direction(
        t[f:], b[f:], J, method=method, k=k, l=l, omega_hat0=omega_hat0, r_hat0=r_hat0,
        torques=None if tau is None else tau[f:], sign=sign,
    )  # fmt: skip
    if omega_hat0 is None:
        W[f] = np.nan
    lam, axis, st = excitation(t, b, window_s)
    flags = (st["since"] >= window_s) & (np.nan_to_num(lam, nan=0.0) < threshold)
    return W, lam, axis, flags


def _assert_same(est, W, oracle, gap_ok):
    W0, lam0, axis0, flags0 = oracle
    np.testing.assert_allclose(W, W0, rtol=0, atol=TOL)
    assert np.array_equal(np.isnan(W), np.isnan(W0))
    np.testing.assert_allclose(est.excitation, lam0, rtol=0, atol=TOL)
    np.testing.assert_array_equal(est.unobservable, flags0)
    np.testing.assert_allclose(est.weak_axis[gap_ok], axis0[gap_ok], rtol=0, atol=TOL)


def _separated(t, b, window_s=10.0):
    """Samples whose λ_min is at least 1e-3 from the next eigenvalue (there the weak axis is determined)."""
    S, W, t_last = np.zeros((3, 3)), 0.0, None
    ok = np.zeros(t.size, dtype=bool)
    for j in range(t.size):
        if np.all(np.isfinite(b[j])):
            u = b[j] / np.linalg.norm(b[j])
            a = 0.0 if t_last is None else np.exp(-(t[j] - t_last) / window_s)
            S, W, t_last = a * S + (1 - a) * (np.eye(3) - np.outer(u, u)), a * W + (1 - a), t[j]
        if W > 0:
            vals = np.linalg.eigvalsh(S / W)
            ok[j] = vals[1] - vals[0] > 1e-3
    return ok


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("method", ["sarras", "gradient"])
def test_compiled_step_equals_the_numpy_oracle(seed, method):
    J, v, t, b, tau = _case(seed)
    k, l = default_gains(J, method, 0.8)
    est = SingleDirectionEstimator(J, reference=v, method=method, k=k, l=l, omega_hat0=[0.1, -0.2, 0.05])
    W = est.run(t, b, tau).omega
    _assert_same(est, W, _oracle(J, t, b, tau, method, k, l, omega_hat0=[0.1, -0.2, 0.05]), _separated(t, b))
    assert np.isnan(W[:2]).all() and np.isfinite(W[2:]).all()
    assert _separated(t, b).mean() > 0.5  # the weak axis was compared on most samples


@pytest.mark.parametrize("method", ["sarras", "gradient"])
def test_compiled_step_in_chunks_and_sample_by_sample_equals_one_call(method):
    """The state carries over: three chunks, or one sample per call, give the one call's results (bit for bit:
    the same arithmetic), with a given r̂₀, without torques, through the printed sign."""
    J, v, t, b, _ = _case(7, T=300)
    kw = {"method": method, "r_hat0": [0.0, 1.0, 0.0], "sign": OUTPUT_SIGN_PRINTED, "bandwidth_hz": 1.5 / (2 * np.pi)}
    one = SingleDirectionEstimator(J, reference=v, **kw)
    W = one.run(t, b).omega
    k, l = one.k, one.l
    _assert_same(one, W, _oracle(J, t, b, None, method, k, l, r_hat0=[0.0, 1.0, 0.0], sign=-1.0), _separated(t, b))
    chunked = SingleDirectionEstimator(J, reference=v, **kw)
    parts = [chunked.run(t[a:c], b[a:c]).omega for a, c in ((0, 5), (5, 137), (137, 300))]
    np.testing.assert_array_equal(np.concatenate(parts), W)
    single = SingleDirectionEstimator(J, reference=v, **kw)
    rows = [single.run(t[:3], b[:3]).omega] + [single.run(t[j : j + 1], b[j : j + 1]).omega for j in range(3, t.size)]
    np.testing.assert_array_equal(np.concatenate(rows), W)
    np.testing.assert_array_equal(single.excitation, one.excitation[-1:])


def test_monitor_flags_equal_the_oracle_on_a_spin_about_the_measured_direction():
    """b nearly fixed in the body (a spin about it, 0.05° noise): most samples flagged after the first window, by
    both forms alike; the weak axis is the spin axis."""
    rng = np.random.default_rng(4)
    t = np.arange(0.0, 40.0, 0.1)
    R = Rotation.from_rotvec(np.outer(t, [0.0, 0.0, 0.8])).as_matrix()
    b = np.einsum("tji,j->ti", R, [0.0, 0.0, 1.0]) + rng.normal(0.0, np.radians(0.05), (t.size, 3))
    J = np.diag([3.0, 2.0, 1.0])
    est = SingleDirectionEstimator(J, reference=[0, 0, 1])
    with pytest.warns(LostExcitationWarning):
        W = est.run(t, b).omega
    k, l = est.k, est.l
    oracle = _oracle(J, t, b, None, "sarras", k, l)
    _assert_same(est, W, oracle, np.ones(t.size, dtype=bool))
    assert est.unobservable[t >= 10.0].all() and not est.unobservable[t < 10.0].any()
    np.testing.assert_allclose(est.weak_axis[-1], [0.0, 0.0, 1.0], atol=1e-3)  # measured 3e-5: the noise


def _sym(a00, a11, a22, a01, a02, a12):
    return np.array([[a00, a01, a02], [a01, a11, a12], [a02, a12, a22]])


@pytest.mark.parametrize(
    "eigenvalues",
    [(0.2, 0.7, 1.1), (0.0, 1.0, 1.0), (0.5, 0.5, 1.0), (1e-9, 1.0, 1.0 + 1e-9), (2.0, 2.0, 2.0 + 1e-12), (0, 0, 1)],
)
def test_smallest_eigenpair_equals_lapack(eigenvalues):
    """Random orientations of the given spectra (simple, double smallest, double largest, nearly degenerate, nearly
    a multiple of I, rank one): λ_min to 1e-14 of NumPy's eigh (LAPACK); the vector a unit eigenvector with its
    largest component positive, and NumPy's (same sign rule) where λ_min is separated from the next eigenvalue."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        Q = Rotation.random(random_state=rng).as_matrix()
        A = Q @ np.diag(eigenvalues) @ Q.T
        entries = (A[0, 0], A[1, 1], A[2, 2], A[0, 1], A[0, 2], A[1, 2])
        lam, *vec = step.smallest_eigenpair(*entries)
        vec = np.array(vec)
        vals, vecs = np.linalg.eigh(_sym(*entries))
        assert abs(lam - vals[0]) < 1e-14
        assert abs(np.linalg.norm(vec) - 1.0) < 1e-14 and vec[np.argmax(np.abs(vec))] > 0
        assert np.linalg.norm(_sym(*entries) @ vec - lam * vec) < 1e-14
        if vals[1] - vals[0] > 1e-6:
            ref = vecs[:, 0] * np.sign(vecs[np.argmax(np.abs(vecs[:, 0])), 0])
            np.testing.assert_allclose(vec, ref, rtol=0, atol=1e-14 / (vals[1] - vals[0]))
    assert step.smallest_eigenpair(2.0, 2.0, 2.0, 0.0, 0.0, 0.0) == (2.0, 1.0, 0.0, 0.0)


def test_rejected_samples_raise_the_input_paths_message_and_change_nothing():
    J, v, t, b, tau = _case(5, T=60)
    est = SingleDirectionEstimator(J, reference=v)
    first = est.run(t[:30], b[:30], tau[:30]).omega
    bad_t, bad_b, bad_tau = t[30:].copy(), b[30:].copy(), tau[30:].copy()
    bad_t[4] = bad_t[3]
    with pytest.raises(MeasurementError, match=r"sample 4: time t = .* is not after the previous sample's t = "):
        est.run(bad_t, b[30:], tau[30:])
    bad_t[4] = np.nan
    with pytest.raises(MeasurementError, match=r"sample 4: time t = nan is not finite"):
        est.run(bad_t, b[30:], tau[30:])
    bad_b[6] = 0.0
    with pytest.raises(MeasurementError, match=r"sample 6 \(t = .*\): measured direction b1 has zero length"):
        est.run(t[30:], bad_b, tau[30:])
    bad_tau[2, 1] = np.inf
    with pytest.raises(MeasurementError, match=r"sample 2 \(t = .*\): torque must be finite; got inf"):
        est.run(t[30:], b[30:], bad_tau)
    with pytest.raises(ValueError, match=r"torques must have shape \(30, 3\); got shape \(30, 2\)"):
        est.run(t[30:], b[30:], tau[30:, :2])
    rest = est.run(t[30:], b[30:], tau[30:]).omega  # the refused calls left the state as it was
    whole = SingleDirectionEstimator(J, reference=v).run(t, b, tau).omega
    np.testing.assert_array_equal(np.concatenate([first, rest]), whole)


def test_advance_returns_a_new_state_and_leaves_the_given_one():
    J, _, t, b, _ = _case(6, T=40)
    k, l = default_gains(J, "sarras", 0.5)
    params = step.pack_params(
        J, gradient=False, k=k, l=l, sign=1.0, substep_rate=0.5, window_s=10.0, threshold=1e-3, omega_hat0=None,
        r_hat0=None,
    )  # fmt: skip
    x0 = step.initial_state()
    kept = x0.copy()
    out = step.advance(params, x0, t, b, None)
    np.testing.assert_array_equal(x0, kept)
    assert out.state[step.STATE.stage] == step.RUNNING and out.state[step.STATE.t] == t[-1]
    np.testing.assert_allclose(np.linalg.norm(out.state[step.STATE.b : step.STATE.b + 3]), 1.0, rtol=0, atol=1e-15)
    again = step.advance(params, out.state, t[-1:] + 0.1, b[-1:], None)
    assert again.omega.shape == (1, 3) and np.isfinite(again.omega).all()
