"""Basilisk's sun-line switch-EKF (baselines/sunline_sekf.py) against independent facts: SciPy's discrete algebraic
Riccati solution, finite-difference Jacobians, the integral of the transition (SciPy's expm), the body rate's
invariance under a frame switch, convergence on a spin it models exactly; and its compiled loop against the NumPy
steps to 1e-10, with the interface's direction samples and with the source's coarse sun sensors."""

import warnings

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from scipy.spatial.transform import Rotation

from omegahat.baselines import sunline_kernel
from omegahat.baselines.sunline_sekf import (
    SWITCH_COS,
    SunlineSEKF,
    body_rate,
    dynamics_matrix,
    frame,
    noise_map,
    sekf_step,
    switch,
    time_update,
)
from omegahat.interface import Status
from omegahat.lab.peer_scenarios import BASILISK_NORMALS
from omegahat.measurements import MeasurementError
from omegahat.observer.compiled import SkippedSamplesWarning

RNG = np.random.default_rng(2026)


def hat(v):
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def test_frame_is_a_right_handed_orthonormal_frame_on_the_direction():
    d = np.array([0.3, -1.2, 0.5])
    for axis in (0, 1):
        C = frame(d, axis)
        np.testing.assert_allclose(C.T @ C, np.eye(3), atol=1e-15)
        assert np.linalg.det(C) == pytest.approx(1.0)
        np.testing.assert_allclose(C[:, 0], d / np.linalg.norm(d))
        assert abs(C[:, 1] @ np.eye(3)[axis]) < 1e-15  # s₂ ⊥ the axis
    np.testing.assert_array_equal(frame(np.array([2.0, 0.0, 0.0]), 0), np.eye(3))  # the source's fallback


def test_covariance_settles_at_scipys_discrete_algebraic_riccati_solution():
    """At rest with exact samples of d (X at the truth: innovations 0, nothing moves) Φ, Γ and H are constant: across
    d the prior covariance P⁻ converges to the DARE's solution (the posterior is its Kalman update); along d nothing
    drives the state, and its variance is that of a constant measured n times, 1/(1/P₀ + n/σ²)."""
    d = np.array([0.2, 0.5, 0.84])
    d /= np.linalg.norm(d)
    h, q, var = 0.5, 0.01, 1e-3
    t = h * np.arange(400)
    f = SunlineSEKF(measurement_noise=np.sqrt(var), process_noise=q, direction0=d, omega_hat0=np.zeros(3))
    np.testing.assert_allclose(f.run(t, np.broadcast_to(d, (t.size, 3))).omega, 0.0, atol=1e-15)
    X = np.concatenate([d, [0.0, 0.0]])
    Phi = np.eye(5) + h * dynamics_matrix(X, 0)
    G = noise_map(X, 0, h, False)
    H = np.hstack([np.eye(3), np.zeros((3, 2))])
    prior = scipy.linalg.solve_discrete_are(Phi.T, H.T, q * G @ G.T, var * np.eye(3))
    posterior = prior - prior @ H.T @ np.linalg.solve(H @ prior @ H.T + var * np.eye(3), H @ prior)
    M = np.eye(5)
    M[:3, :3] -= np.outer(d, d)
    np.testing.assert_allclose(M @ f.P @ M.T, M @ posterior @ M.T, atol=1e-12)
    assert d @ f.P[:3, :3] @ d == pytest.approx(1 / (1 / 0.4 + t.size / var), rel=1e-9)


def test_transition_is_the_jacobian_of_the_step_with_the_frame_held():
    """(S3)–(S4): Φ = I + hA is the derivative of the Euler step X ↦ [d − h (C(0, −ω₂, −ω₃)) × d; ω₂; ω₃] at fixed C;
    letting C turn with d changes it by a term of the same order (here a fifth of the d block's; the approximation
    the docstring names)."""
    X, h, axis = np.array([0.3, 0.5, 0.8, 0.07, -0.04]), 0.5, 0
    C = frame(X[:3], axis)

    def step(Y, C=None):
        Cy = frame(Y[:3], axis) if C is None else C
        w = Cy @ np.array([0.0, -Y[3], -Y[4]])
        return np.concatenate([Y[:3] - h * np.cross(w, Y[:3]), Y[3:]])

    eps = 1e-6
    held = np.column_stack([(step(X + eps * e, C) - step(X - eps * e, C)) / (2 * eps) for e in np.eye(5)])
    turning = np.column_stack([(step(X + eps * e) - step(X - eps * e)) / (2 * eps) for e in np.eye(5)])
    Phi = np.eye(5) + h * dynamics_matrix(X, axis)
    np.testing.assert_allclose(Phi, held, atol=1e-9)
    assert np.linalg.norm(turning - held) > 0.1 * np.linalg.norm(Phi[:3, :3] - np.eye(3))
    np.testing.assert_allclose(time_update(X, np.zeros(5), np.eye(5), axis, h, 0.0, False)[0], step(X, C))


def test_noise_map_is_the_integral_of_the_transition_to_leading_order():
    """Γ = ∫₀ʰ exp(A s) [0; I] ds (SciPy: expm and quad): the consistent Γ misses it by O(h³); the source's Γ has the
    opposite sign in its direction block."""
    X = np.array([0.3, 0.5, 0.8, 0.07, -0.04])
    A = dynamics_matrix(X, 0)
    B = np.vstack([np.zeros((3, 2)), np.eye(2)])
    misses = []
    for h in (0.2, 0.1):
        exact = np.column_stack(
            [[scipy.integrate.quad(lambda s, i=i, j=j: (scipy.linalg.expm(A * s) @ B)[i, j], 0, h, epsabs=1e-14)[0]
              for i in range(5)] for j in range(2)]
        )  # fmt: skip
        misses.append(np.abs(noise_map(X, 0, h, False) - exact).max())
        published = noise_map(X, 0, h, True)
        np.testing.assert_allclose(published[:3], -noise_map(X, 0, h, False)[:3])
        assert np.abs(published - exact).max() > 0.5 * np.abs(exact[:3]).max()
    assert misses[1] < misses[0] / 6, misses


def test_a_switch_keeps_the_body_rate_and_its_covariance():
    """(S2) changes coordinates only: ω̂ = C(0, −ω₂, −ω₃) and the covariance of ω̂ are the same before and after."""
    X = np.array([0.9, 0.2, 0.3, 0.05, -0.08])  # within 30° of e₁: switches to e₂
    P = np.diag([0.4, 0.3, 0.2, 0.004, 0.006]) + 0.001
    X2, P2, axis = switch(X, P, 0, SWITCH_COS)
    assert axis == 1
    np.testing.assert_allclose(body_rate(X2, 1), body_rate(X, 0), atol=1e-15)
    M1, M2 = frame(X[:3], 0)[:, 1:], frame(X2[:3], 1)[:, 1:]
    np.testing.assert_allclose(M2 @ P2[3:, 3:] @ M2.T, M1 @ P[3:, 3:] @ M1.T, atol=1e-15)
    np.testing.assert_array_equal(X2[:3], X[:3])
    assert switch(X2, P2, 1, SWITCH_COS)[2] == 1  # far from e₂: stays


def test_converges_on_a_spin_it_models_exactly():
    """A spin about e₁ with the Sun in the plane ⊥ e₁: (ω₂, ω₃) are constant in S, the model is exact but for the
    Euler step; from rest, exact samples give the rate to an error that falls at least as h² (order 2 or more)."""
    w, v = np.array([0.1, 0.0, 0.0]), np.array([0.0, 0.6, 0.8])
    errors = []
    for h in (0.1, 0.05):
        t = np.arange(0.0, 300.0, h)
        b = np.einsum("tji,j->ti", Rotation.from_rotvec(np.outer(t, w)).as_matrix(), v)
        est = SunlineSEKF(measurement_noise=1e-3, process_noise=1e-6).run(t, b)
        errors.append(np.linalg.norm(est.omega[-1] - w))
    assert errors[0] < 1e-4 and errors[1] < errors[0] / 3.5, errors


def _sequence(T=300, h=0.25):
    """A tumbling body seeing one direction with noise, gaps, and passes near e₁ and e₂ (frame switches)."""
    t = 1.0 + h * np.arange(T)
    R = Rotation.from_rotvec(np.outer(t, [0.05, 0.13, -0.08]) + 0.3 * np.sin(np.outer(t, [0.2, 0.3, 0.1])))
    b = R.inv().apply([0.6, 0.0, 0.8]) + 0.01 * RNG.normal(size=(T, 3))
    b[[0, 1, 40, 41, 42, 170]] = np.nan
    return t, b


@pytest.mark.parametrize("as_published", [False, True])
@pytest.mark.parametrize("direction0", [None, (0.0, 0.6, 0.8)])
def test_compiled_run_equals_the_numpy_steps(as_published, direction0):
    t, b = _sequence()
    fast = SunlineSEKF(as_published=as_published, direction0=direction0, omega_hat0=(0.02, -0.01, 0.03))
    slow = SunlineSEKF(as_published=as_published, direction0=direction0, omega_hat0=(0.02, -0.01, 0.03))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", SkippedSamplesWarning)
        got = [fast.run(t[:120], b[:120]), fast.run(t[120:], b[120:, None, :])]
        want, axes = [], []
        for j in range(t.size):
            want.append(slow.update(t[j], b[j]))
            axes.append(slow.axis)
    assert np.count_nonzero(np.diff(axes)) >= 1 and fast.axis == slow.axis  # the run switches frames
    status = np.array([w.status for w in want])
    assert np.all(status[:2] == Status.UNAVAILABLE) and set(status[2:]) == {Status.CORRECTED, Status.PREDICTED}
    np.testing.assert_array_equal(np.concatenate([g.status for g in got]), status)
    np.testing.assert_allclose(np.vstack([g.omega for g in got]), [w.omega for w in want], rtol=0, atol=1e-10)
    np.testing.assert_allclose(fast.P, slow.P, atol=1e-10)
    np.testing.assert_allclose(fast.X, slow.X, atol=1e-10)


def test_compiled_loop_equals_the_numpy_steps_with_the_sources_sun_sensors():
    """The source's eight coarse sun sensors, readings above 0 taken, a heading jump, the CKF engaged after a gap."""
    h, T = 0.5, 120
    headings = np.where(np.arange(T)[:, None] < 60, [-0.7, 0.7, 0.0], [0.8, 0.9, 0.0])
    cos = headings @ BASILISK_NORMALS.T + 0.03 * RNG.normal(size=(T, 8))
    use = (cos > 0) & ((np.arange(T) % 60) > 20)[:, None]
    X, x, P = np.array([0.7, 0.7, 0.0, 0.0, 0.0]), np.zeros(5), np.diag([0.4, 0.4, 0.4, 0.004, 0.004])
    params = np.array([0.01, 0.001, 16 / 9, SWITCH_COS, 1.0])
    state = np.array([np.nan, 0.0, 1.0, 0.0])
    Xc, xc, Pc = X.copy(), x.copy(), P.copy()
    out, restarted = sunline_kernel.run_log(
        h * np.arange(T), cos, use, BASILISK_NORMALS, np.zeros(3), params, state, Xc, xc, Pc, P.copy()
    )
    assert not restarted.any()
    axis, ckf = 0, 0
    for j in range(T):
        rows = np.flatnonzero(use[j])
        ckf += int(rows.size > 0 and np.abs(P).max() > 16 / 9)
        y = cos[j, rows] if rows.size else None
        X, x, P, axis = sekf_step(X, x, P, axis, None if j == 0 else h, y, BASILISK_NORMALS[rows], 0.01, 0.001,
                                  16 / 9, SWITCH_COS, True)  # fmt: skip
        np.testing.assert_allclose(out[j], body_rate(X, axis), atol=1e-10)
    np.testing.assert_allclose(Xc, X, atol=1e-10)
    np.testing.assert_allclose(Pc, P, atol=1e-10)
    np.testing.assert_allclose(xc, x, atol=1e-10)
    assert ckf >= 1  # the CKF form was exercised


def test_input_is_checked():
    f = SunlineSEKF()
    with pytest.raises(ValueError, match=r"measurements must have shape \(T, 3\) or \(T, 1, 3\) with T = 2 samples"):
        f.run([0.0, 1.0], np.ones((2, 2, 3)))
    with pytest.raises(MeasurementError, match=r"^sample 1 \(t = 1.0\): measured direction b1 has zero length"):
        f.run([0.0, 1.0], [[0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    f.update(2.0, [0.0, 0.0, 1.0])
    with pytest.raises(MeasurementError, match="is not after the previous sample's"):
        f.update(1.0, [0.0, 1.0, 0.0])
    with pytest.raises(MeasurementError, match="torque must be finite"):
        f.update(3.0, [0.0, 1.0, 0.0], [np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match="direction0 must be a non-zero vector"):
        SunlineSEKF(direction0=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="process_noise must be positive"):
        SunlineSEKF(process_noise=-1.0)
    assert f.t == 2.0


def test_one_sample_is_named_as_such():
    f = SunlineSEKF()
    with pytest.raises(
        ValueError, match=r"a one-direction sample must have shape \(3,\) or \(1, 3\); got shape \(2, 3\)"
    ):
        f.update(0.0, np.eye(3)[:2])
    with pytest.raises(MeasurementError, match=r"the sample \(t = 0.0\): torque must be finite"):
        f.update(0.0, [0.0, 0.0, 1.0], [0.0, np.inf, 0.0])
    assert f.t is None and f.X is None


def test_an_update_that_is_not_finite_restarts_from_the_sample(restart_warnings):
    """A state that cannot stay finite (here after a gap of 1e200 s: Φ P Φᵀ overflows) is never written as an
    estimate: that sample's estimate is NaN with the status RESTARTED and the filter starts again from it (the
    sample's direction, P₀); the compiled run and the NumPy steps agree."""
    t, b = np.array([0.0, 0.5, 1e200]), np.array([[0.0, 0.6, 0.8], [0.0, 0.8, 0.6], [0.6, 0.8, 0.0]])
    results = []
    for path in ("run", "update"):
        f = SunlineSEKF(omega_hat0=np.zeros(3))
        with restart_warnings(path):
            if path == "run":
                omega, status = f.run(t, b)
            else:
                out = [f.update(tj, bj) for tj, bj in zip(t, b, strict=True)]
                omega, status = np.array([o.omega for o in out]), np.array([o.status for o in out])
        assert list(status) == [Status.CORRECTED, Status.CORRECTED, Status.RESTARTED] and f.n_restarts == 1
        assert np.all(np.isfinite(omega[:2])) and np.all(np.isnan(omega[2]))
        np.testing.assert_array_equal(f.X, [0.6, 0.8, 0.0, 0.0, 0.0])  # from the sample and ω̂₀ = 0
        np.testing.assert_array_equal(f.P, f.P0)
        results.append(omega)
    np.testing.assert_allclose(results[0], results[1], atol=1e-12)
