"""The one integrator of plant + observer gives every run the same bits whether it is simulated alone (one lane,
:func:`simulate`) or among many (``LANES`` lanes per worker, any number of workers, threads or not); failed runs,
a single output time and wrong shapes are handled the same way in every path; a campaign's in-engine diagnostics
equal the diagnostics of the states. Accuracy against independent integrators is in test_simulate.py.

The many-lane engine is compiled once per (directions, torque terms) pair and per threading (about 30 s each on a
fresh machine): these tests use (2, 2), as the default campaign does, threaded and serial."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.lab.campaigns.diagnostics import diagnose_runs
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation import CoupledProblem, Torque, simulate, simulate_batch
from omegahat.simulation.engine import LANES, StepControl, integrate_envelopes, integrate_states
from omegahat.simulation.problem import batch_inputs, initial_state

J_PAPER = np.diag([3.0, 2.0, 1.0])
THEOREM = theorem_gains(J_PAPER, omega_max=3.0, margin=1.0, l0=1.0)


def _problems(n_runs, n_dirs, n_terms, seed, gains, freq=(0.5, 5.0), J=J_PAPER):
    rng = np.random.default_rng(seed)
    refs = np.eye(3)[:n_dirs]
    out = []
    for _ in range(n_runs):
        q = rng.normal(size=4)
        torque = Torque.sinusoidal(
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
                R0=Rotation.from_quat(q / np.linalg.norm(q)).as_matrix(),
                references=refs,
                r_hat0=rng.uniform(-3, 3, (n_dirs, 3)),
                omega_hat0=rng.uniform(-20, 20, 3),
                torque=torque,
            )
        )
    return out


def _states(traj):
    """A trajectory's states in the engine's layout [r, ω, z, e]."""
    T = traj.t.size
    return np.concatenate([traj.r.reshape(T, -1), traj.omega, traj.z, traj.e.reshape(T, -1)], axis=1)


def _each_run_alone_equals_the_batch(problems, t_out, rtol=1e-7, workers=2):
    batch = simulate_batch(problems, t_out, rtol=rtol, n_workers=workers)
    for i, p in enumerate(problems):
        alone = simulate(p, t_out=t_out, rtol=rtol)
        assert (batch.accepted[i], batch.rejected[i]) == (alone.steps, alone.rejected), f"run {i}"
        np.testing.assert_array_equal(batch.Y[i], _states(alone), err_msg=f"run {i}")
    return batch


def test_theorem_gains_more_runs_than_lanes_each_as_alone():
    problems = _problems(2 * LANES + 5, 2, 2, seed=1, gains=THEOREM)  # lanes are refilled, some idle at the end
    batch = _each_run_alone_equals_the_batch(problems, np.linspace(0.0, 2.0, 41))
    assert batch.ok.all() and batch.accepted.min() > 10


def test_unequal_small_gains_take_the_taylor_branches():
    # l_i differ per direction (no shared φ-weights) and are small, so −l h < 1/2: the Taylor branches
    gains = ObserverGains(k=np.array([2.0, 3.0]), l_offset=np.array([0.5, 2.0]), l_slope=np.array([0.1, 0.3]))
    problems = _problems(7, 2, 2, seed=2, gains=gains)  # fewer runs than lanes
    batch = _each_run_alone_equals_the_batch(problems, np.array([0.0, 0.3, 0.31, 1.5]), rtol=1e-8)
    assert batch.ok.all()


def test_fast_torque_takes_the_library_sin_cos_branch():
    # ν h/2 > 1/4 for h near h_max = 0.05 needs ν > 10
    problems = _problems(5, 2, 2, seed=3, gains=THEOREM, freq=(20.0, 40.0))
    _each_run_alone_equals_the_batch(problems, np.linspace(0.0, 1.0, 5), rtol=1e-5)


def test_non_diagonal_inertia():
    R = np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]])  # a rotation
    J = R @ J_PAPER @ R.T
    problems = _problems(LANES + 2, 2, 2, seed=9, gains=theorem_gains(J, omega_max=3.0), J=J)
    batch = _each_run_alone_equals_the_batch(problems, np.linspace(0.0, 1.0, 21))
    assert batch.ok.all() and batch.accepted.min() > 10


def test_split_over_workers_or_serial_does_not_change_any_bit():
    problems = _problems(LANES + 3, 2, 2, seed=4, gains=THEOREM)
    t = np.linspace(0.0, 1.0, 11)
    runs = [simulate_batch(problems, t, rtol=1e-7, n_workers=w) for w in (1, 3)]
    runs.append(simulate_batch(problems, t, rtol=1e-7, n_workers=2, parallel=False))
    for other in runs[1:]:
        for name in ("Y", "accepted", "rejected", "ok"):
            np.testing.assert_array_equal(getattr(runs[0], name), getattr(other, name))


def test_failed_runs_report_ok_false_and_keep_nan_rows_in_every_path():
    problems = _problems(4, 2, 2, seed=5, gains=THEOREM)
    model, runs = batch_inputs(problems, 0.05)
    t = np.linspace(0.0, 1.0, 11)
    # max_steps reached part way
    for lanes in (1, LANES):
        out = integrate_states(model, runs, t, StepControl(1e-7, 1e-15, 0.05, 30), n_workers=2, lanes=lanes)
        assert not out.ok.any() and np.isnan(out.Y[:, -1]).all() and np.isfinite(out.Y[:, 0]).all()
        assert (out.accepted + out.rejected == 30).all()
    # a non-finite state is rejected down to h < 1e-14, then the run stops
    runs.y0[1, 3 * 2 + 3] = np.inf  # z of run 1
    got = [integrate_states(model, runs, t, StepControl(1e-7, 1e-15, 0.05, 10**6), 2, lanes) for lanes in (1, LANES)]
    for out in got:
        assert list(out.ok) == [True, False, True, True]
        assert out.accepted[1] == 0 and out.rejected[1] > 0 and np.isnan(out.Y[1, 1:]).all()
    for a, b in zip(got[0], got[1], strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(RuntimeError, match=r"simulation stopped at t = 0.1 s after 30 steps"):
        simulate(problems[0], t_out=t, rtol=1e-7, max_steps=30)


def test_a_single_output_time_integrates_nothing():
    problems = _problems(2 * LANES + 5, 2, 2, seed=6, gains=THEOREM)
    batch = simulate_batch(problems, np.array([0.0]))
    assert batch.ok.all() and (batch.accepted == 0).all() and (batch.rejected == 0).all()
    assert batch.Y.shape == (2 * LANES + 5, 1, 18)
    np.testing.assert_array_equal(batch.Y[:, 0], np.array([initial_state(p) for p in problems]))


def test_inconsistent_shapes_are_named_before_the_unchecked_engine_runs():
    model, runs = batch_inputs(_problems(3, 2, 2, seed=7, gains=THEOREM), 0.05)
    t = np.linspace(0.0, 0.1, 3)
    control = StepControl(1e-7, 1e-15, 0.05, 100)
    cases = [
        (runs._replace(torque_amplitudes=runs.torque_amplitudes[:, :1]), r"amplitudes must have shape \(3, 2, 3\)"),
        (runs._replace(h0=runs.h0[:2]), r"h0 must have shape \(3,\)"),
        (runs._replace(y0=runs.y0[:, :12]), r"y0 must have shape \(3, 18\)"),
    ]  # fmt: skip
    for bad, match in cases:
        with pytest.raises(ValueError, match=match):
            integrate_states(model, bad, t, control)
    with pytest.raises(ValueError, match=r"l_offset must have shape \(2,\)"):
        integrate_states(model._replace(l_offset=np.ones(3)), runs, t, control)
    with pytest.raises(ValueError, match="t_out must be a non-empty 1-D array"):
        integrate_states(model, runs, t[:0], control)


def test_envelopes_in_the_engine_equal_diagnosing_its_states():
    """A campaign's mode (each run diagnosed as it ends, from the lane's own rows) gives, run by run, what
    diagnose_runs gives on the states: runs that finish, runs stopped by max_steps (NaN rows), a non-finite start,
    more runs than lanes, in threads and serially, and a single output time."""
    model, runs = batch_inputs(_problems(LANES + 9, 2, 2, seed=10, gains=THEOREM), 0.05)
    runs.y0[4, 3 * 2 + 3] = np.nan  # z of run 4: rejected down to h < 1e-14, then stopped
    flags = []
    for t, max_steps in [(np.linspace(0.0, 1.0, 21), 10**6), (np.linspace(0.0, 1.0, 21), 150), (np.array([0.0]), 10)]:
        control = StepControl(1e-7, 1e-15, 0.05, max_steps)
        states = integrate_states(model, runs, t, control, 2)
        N, T = states.Y.shape[:2]
        want = (np.empty((N, T)), np.empty((6, N)), np.empty(N, dtype=bool))
        diagnose_runs(states.Y, 2, J_PAPER, t, 1e-8, states.ok, *want)
        for parallel in (True, False):
            got = integrate_envelopes(model, runs, t, control, 1e-8, 2, parallel=parallel)
            np.testing.assert_array_equal(got.accepted, states.accepted)
            np.testing.assert_array_equal(got.rejected, states.rejected)
            np.testing.assert_array_equal(got.ok, want[2])
            np.testing.assert_array_equal(got.rho, want[0])
            np.testing.assert_array_equal(got.diagnostics, want[1])
        flags.append(want[2])
    others = np.arange(LANES + 9) != 4
    assert not any(f[4] for f in flags)  # the non-finite run fails in every case
    assert flags[0][others].all() and not flags[1][others].all() and flags[2][others].all()  # max_steps bites
