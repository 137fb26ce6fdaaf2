"""The lockstep batch kernel gives, run by run, the very bits of the single-run kernel; and the small pieces both
share (small-angle sin/cos, φ-functions, step factor, NaN handling) against independent references.

The kernel is compiled once per (directions, torque terms) pair, about 20 s each on a fresh machine: the tests
use two pairs, (2, 2) as the default campaign does and (3, 2)."""

from decimal import Decimal, getcontext

import numpy as np
import pytest

from omegahat.campaigns.diagnostics import diagnose_runs
from omegahat.campaigns.runner import kernel_inputs
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation.coupled import (
    CoupledProblem,
    SinusoidalTorque,
    _phi1_half_closed,
    _phi1_taylor,
    _phi123,
    _sin_cos_small,
    _step_factor,
    initial_state,
    integrate_coupled,
    integrate_coupled_batch,
)
from omegahat.simulation.engine import LANES, integrate_coupled_lanes, integrate_diagnosed_lanes


def _problems(n_runs, n_dirs, n_terms, seed, gains, freq=(0.5, 5.0)):
    rng = np.random.default_rng(seed)
    J = np.diag([3.0, 2.0, 1.0])
    refs = np.eye(3)[:n_dirs] if n_dirs <= 3 else rng.normal(size=(n_dirs, 3))
    refs = refs / np.linalg.norm(refs, axis=1, keepdims=True)
    out = []
    for _ in range(n_runs):
        q = rng.normal(size=4)
        from scipy.spatial.transform import Rotation

        R0 = Rotation.from_quat(q / np.linalg.norm(q)).as_matrix()
        torque = SinusoidalTorque(
            constant=rng.uniform(-0.1, 0.1, 3),
            amplitudes=rng.uniform(-0.3, 0.3, (n_terms, 3)),
            frequencies=rng.uniform(*freq, n_terms),
            phases=rng.uniform(0, 2 * np.pi, (n_terms, 3)),
        )
        out.append(
            CoupledProblem(
                J=J,
                gains=gains,
                omega0=rng.uniform(-1, 1, 3),
                R0=R0,
                references=refs,
                r_hat0=rng.uniform(-3, 3, (n_dirs, 3)),
                omega_hat0=rng.uniform(-20, 20, 3),
                torque=torque,
            )
        )
    return out


def _compare(problems, t_out, rtol=1e-7, atol=1e-15, h_max=0.05, max_steps=1_000_000, workers=2):
    Y0, body, torque, h0 = kernel_inputs(problems, h_max)
    Y, acc, rej, ok = integrate_coupled_lanes(Y0, t_out, *body, *torque, rtol, atol, h0, h_max, max_steps, workers)
    for i in range(len(problems)):
        Yi, a, r, good = integrate_coupled(
            Y0[i], t_out, *body, *(x[i] for x in torque), rtol, atol, h0[i], h_max, max_steps
        )
        assert (acc[i], rej[i], ok[i]) == (a, r, good), f"run {i}"
        np.testing.assert_array_equal(Y[i], Yi, err_msg=f"run {i}")
    return Y, acc, rej, ok


def test_theorem_gains_more_runs_than_lanes_are_bit_identical_to_the_single_run_kernel():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    problems = _problems(2 * LANES + 5, 2, 2, seed=1, gains=gains)  # lanes are refilled, some idle at the end
    _, acc, _, ok = _compare(problems, np.linspace(0.0, 2.0, 41))
    assert ok.all() and acc.min() > 10


def test_unequal_small_gains_three_directions():
    # l_i differ per direction (no shared φ-weights) and are small, so −l h < 1/2: the Taylor branches
    gains = ObserverGains(
        k=np.array([2.0, 3.0, 4.0]), l_offset=np.array([0.5, 1.0, 2.0]), l_slope=np.array([0.1, 0.0, 0.3])
    )
    problems = _problems(7, 3, 2, seed=2, gains=gains)  # fewer runs than lanes
    _, _, _, ok = _compare(problems, np.array([0.0, 0.3, 0.31, 1.5]), rtol=1e-8)
    assert ok.all()


def test_fast_torque_takes_the_library_sin_cos_branch():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    # ν h/2 > 1/4 for h near h_max = 0.05 needs ν > 10
    problems = _problems(5, 2, 2, seed=3, gains=gains, freq=(20.0, 40.0))
    _compare(problems, np.linspace(0.0, 1.0, 5), rtol=1e-5)


def test_split_over_workers_or_serial_does_not_change_any_bit():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    problems = _problems(LANES + 3, 2, 2, seed=4, gains=gains)
    Y0, body, torque, h0 = kernel_inputs(problems, 0.05)
    t = np.linspace(0.0, 1.0, 11)
    runs = [integrate_coupled_lanes(Y0, t, *body, *torque, 1e-7, 1e-15, h0, 0.05, 10**6, w) for w in (1, 3)]
    runs.append(integrate_coupled_lanes(Y0, t, *body, *torque, 1e-7, 1e-15, h0, 0.05, 10**6, 2, parallel=False))
    # and the engine before it, a prange over runs of the single-run kernel (benchmarks/montecarlo_throughput.py)
    runs.append(integrate_coupled_batch(Y0, t, *body, *torque, 1e-7, 1e-15, h0, 0.05, 10**6, 2))
    for a, *others in zip(*runs, strict=True):
        for b in others:
            np.testing.assert_array_equal(a, b)


def test_failed_runs_report_ok_false_and_keep_nan_rows_like_the_single_run_kernel():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    problems = _problems(4, 2, 2, seed=5, gains=gains)
    t = np.linspace(0.0, 1.0, 11)
    # max_steps reached part way
    Y, acc, rej, ok = _compare(problems, t, max_steps=30)
    assert not ok.any() and np.isnan(Y[:, -1]).all() and np.isfinite(Y[:, 0]).all()
    # a non-finite state is rejected down to h < 1e-14, then the run stops (it used to be accepted silently)
    Y0, body, torque, h0 = kernel_inputs(problems, 0.05)
    Y0[1, 3 * 2 + 3] = np.inf  # z of run 1
    Y, acc, rej, ok = integrate_coupled_lanes(Y0, t, *body, *torque, 1e-7, 1e-15, h0, 0.05, 10**6, 2)
    assert list(ok) == [True, False, True, True]
    assert acc[1] == 0 and rej[1] > 0 and np.isnan(Y[1, 1:]).all()
    Yi, a, r, good = integrate_coupled(Y0[1], t, *body, *(x[1] for x in torque), 1e-7, 1e-15, h0[1], 0.05, 10**6)
    assert (a, r, good) == (acc[1], rej[1], False)
    np.testing.assert_array_equal(Yi, Y[1])


def test_a_single_output_time_integrates_nothing():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    problems = _problems(2 * LANES + 5, 2, 2, seed=6, gains=gains)  # more runs than a worker's lanes
    Y, acc, rej, ok = _compare(problems, np.array([0.0]))
    assert ok.all() and (acc == 0).all() and (rej == 0).all() and Y.shape == (2 * LANES + 5, 1, 18)
    np.testing.assert_array_equal(Y[:, 0], np.array([initial_state(p) for p in problems]))


def test_small_angle_sin_cos_agree_with_numpy_to_rounding():
    x = np.linspace(-0.25, 0.25, 20001)
    s, c = np.array([_sin_cos_small(v) for v in x]).T
    # within one unit in the last place of libm's correctly rounded-or-nearly values
    assert np.all(np.abs(s - np.sin(x)) <= np.spacing(np.abs(np.sin(x))))
    assert np.all(np.abs(c - np.cos(x)) <= np.spacing(np.cos(x)))


def _phi_exact(k, x):
    # φ_k(x) = (e^x − Σ_{j<k} x^j/j!) / x^k in 60-digit decimal arithmetic
    getcontext().prec = 60
    X = Decimal(repr(x))
    acc = X.exp()
    term = Decimal(1)
    for j in range(k):
        acc -= term
        term = term * X / (j + 1)
    return float(acc / X**k)


@pytest.mark.parametrize("x", [-1e-8, -0.1, -0.4999, -0.5, -0.5001, -2.0, -30.0, -800.0])
def test_phi_functions_match_high_precision(x):
    p1, p2, p3, ex = _phi123(x)
    # φ₁ at x as a step computes it for its half step x = (2x)/2: the Taylor series or (e^x − 1)·(2/(2x))
    q1, ex1 = _phi1_taylor(x) if abs(x) < 0.5 else (_phi1_half_closed(2.0 * x, ex), ex)
    for got, k in ((p1, 1), (p2, 2), (p3, 3), (q1, 1)):
        want = _phi_exact(k, x)
        assert abs(got - want) <= 4e-15 * abs(want), (k, x, got, want)
    assert ex == ex1 and abs(ex - np.exp(x)) <= 4e-16 * np.exp(x)


def test_step_factor_is_the_clipped_fourth_root_rule():
    for err in (1e-12, 0.01, 0.5, 0.999, 1.0, 3.0, 1e6):
        assert _step_factor(err) == pytest.approx(min(4.0, max(0.2, 0.9 * err**-0.25)), rel=1e-15)
    assert _step_factor(0.0) == 4.0


def test_inconsistent_shapes_are_named_before_the_unchecked_kernel_runs():
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    Y0, body, (tc, ta, tf, tp), h0 = kernel_inputs(_problems(3, 2, 2, seed=7, gains=gains), 0.05)
    t = np.linspace(0.0, 0.1, 3)
    with pytest.raises(ValueError, match=r"ta must have shape \(3, 2, 3\)"):
        integrate_coupled_lanes(Y0, t, *body, tc, ta[:, :1], tf, tp, 1e-7, 1e-15, h0, 0.05, 100, 2)
    with pytest.raises(ValueError, match=r"h0 must have shape \(3,\)"):
        integrate_coupled_lanes(Y0, t, *body, tc, ta, tf, tp, 1e-7, 1e-15, h0[:2], 0.05, 100, 2)
    with pytest.raises(ValueError, match=r"Y0 must have shape \(3, 18\)"):
        integrate_coupled_lanes(Y0[:, :12], t, *body, tc, ta, tf, tp, 1e-7, 1e-15, h0, 0.05, 100, 2)
    with pytest.raises(ValueError, match="t_out must be a non-empty 1-D array"):
        integrate_coupled_lanes(Y0, t[:0], *body, tc, ta, tf, tp, 1e-7, 1e-15, h0, 0.05, 100, 2)


def test_diagnosed_in_the_kernel_equals_diagnosing_its_states():
    """The campaign's kernel mode (each run diagnosed as it ends, from the lane's own rows) gives, run by run, what
    diagnose_runs gives on the states of the plain mode: runs that finish, runs stopped by max_steps (NaN rows),
    a non-finite start, more runs than lanes, in threads and serially, and a single output time."""
    J = np.diag([3.0, 2.0, 1.0])
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    Y0, body, torque, h0 = kernel_inputs(_problems(LANES + 9, 2, 2, seed=10, gains=gains), 0.05)
    Y0[4, 3 * 2 + 3] = np.nan  # z of run 4: rejected down to h < 1e-14, then stopped
    flags = []
    for t, max_steps in [(np.linspace(0.0, 1.0, 21), 10**6), (np.linspace(0.0, 1.0, 21), 150), (np.array([0.0]), 10)]:
        args = (Y0, t, *body, *torque, 1e-7, 1e-15, h0, 0.05, max_steps, 2)
        Y, acc, rej, ok = integrate_coupled_lanes(*args)
        N, T = Y.shape[:2]
        want = (np.empty((N, T)), np.empty((6, N)), np.empty(N, dtype=bool))
        diagnose_runs(Y, 2, J, t, 1e-8, ok, *want)
        for parallel in (True, False):
            rho, out, ok_d, acc_d, rej_d = integrate_diagnosed_lanes(*args, 1e-8, parallel=parallel)
            np.testing.assert_array_equal(acc_d, acc)
            np.testing.assert_array_equal(rej_d, rej)
            np.testing.assert_array_equal(ok_d, want[2])
            np.testing.assert_array_equal(rho, want[0])
            np.testing.assert_array_equal(out, want[1])
        flags.append(want[2])
    others = np.arange(LANES + 9) != 4
    assert not any(f[4] for f in flags)  # the non-finite run fails in every case
    assert flags[0][others].all() and not flags[1][others].all() and flags[2][others].all()  # max_steps bites


def test_non_diagonal_inertia_is_bit_identical_too():
    # every other test here uses a diagonal J; a full J exercises the off-diagonal products of both kernels
    R = np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]])  # a rotation
    J = R @ np.diag([3.0, 2.0, 1.0]) @ R.T
    gains = theorem_gains(J, omega_max=3.0, margin=1.0, l0=1.0)
    problems = [
        CoupledProblem(
            J=J, gains=gains, omega0=p.omega0, R0=p.R0, r_hat0=p.r_hat0, omega_hat0=p.omega_hat0, torque=p.torque
        )
        for p in _problems(LANES + 2, 2, 2, seed=9, gains=theorem_gains(np.diag([3.0, 2.0, 1.0]), 3.0))
    ]
    _, acc, _, ok = _compare(problems, np.linspace(0.0, 1.0, 21))
    assert ok.all() and acc.min() > 10
