"""The finiteness guard (issue 23, item 1): a step that cannot be taken restarts the estimator, never NaN as estimate.

Repros: a 100 Hz constant-rate log of 2000 rows whose times jump by 1e6 s (or 3e5 s) after row 1000; torques of
1e10 N m with J = I; gains k = l = 1e300. The reference is the closed form of the motion (a constant rate: the body
turns by ``exp(t ω×)``), not the code under test. For each estimator: no row whose estimate is not finite carries
a status saying it is one, every estimate after the gap is finite from the restart's warm start on, and the last
500 rows are within 1e-3 rad/s of the true rate.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.baselines.mekf import MEKF
from omegahat.cli import main
from omegahat.interface import Status
from omegahat.observer.estimator import RestartedWarning, SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator

OMEGA = np.array([0.1, -0.2, 0.3])  # rad/s, body axes
SPIN = np.array([0.0, 0.0, 0.3])  # a spin about a principal axis of diag(3, 2, 1): also a constant rate


def gap_log(jump: float, omega=OMEGA, rows: int = 2000):
    """``(t, quaternions (x, y, z, w), true ω)``: 100 Hz, constant rate, times jumping by ``jump`` after row 1000."""
    t = np.arange(rows) / 100.0
    t[1000:] += jump
    R = Rotation.from_rotvec([0.2, -0.3, 0.5]) * Rotation.from_rotvec(np.outer(t, omega))
    return t, R.as_quat(), omega


def sarras(J=None, gains=None, **kw):
    return SarrasEstimator(np.eye(3) if J is None else J, gains=gains or ObserverGains.constant(1.0, 10.0, n=3), **kw)


def supervised(J=None):
    return SupervisedKalmanEstimator(np.eye(3) if J is None else J, rate_hz=100.0, measurement_noise=1e-3)


def check_honest(W, status):
    """No non-finite estimate with the status of one (corrected or predicted)."""
    bad = ~np.all(np.isfinite(W), axis=1) & np.isin(status, (Status.CORRECTED, Status.PREDICTED))
    assert not np.any(bad), np.flatnonzero(bad)[:5]


def run_quiet(est, t, q, tau=None):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RestartedWarning)
        return est.run(t, q, tau)


@pytest.mark.parametrize("jump", [1e6, 3e5])
@pytest.mark.parametrize("make", [sarras, supervised], ids=["sarras", "supervised"])
def test_long_gap_at_constant_rate_is_predicted_exactly(make, jump):
    """J = I, no torque: the model holds ω constant, so the gap is predicted exactly and nothing restarts."""
    t, q, omega = gap_log(jump)
    est = make()
    W, st = est.run(t, q)
    assert np.all(np.isfinite(W[2:]))
    assert not np.any(st == Status.RESTARTED)
    assert np.max(np.abs(W[-500:] - omega)) < 1e-3


@pytest.mark.parametrize("make", [sarras, supervised], ids=["sarras", "supervised"])
def test_long_gap_the_model_cannot_bridge_restarts(make):
    """J = diag(3, 2, 1): the gap needs more substeps than allowed, so the step to row 1000 restarts the estimator
    (status RESTARTED, NaN there), which warm-starts at row 1001 and converges again."""
    t, q, omega = gap_log(1e6, SPIN)
    est = make(np.diag([3.0, 2.0, 1.0]))
    with pytest.warns(RestartedWarning, match="restarted 1 times in 2000 samples"):
        W, st = est.run(t, q)
    assert np.flatnonzero(st == Status.RESTARTED).tolist() == [1000]
    assert np.all(np.isnan(W[1000])) and np.all(np.isfinite(W[1001:]))
    assert est.n_restarts == 1 and est.n_skipped == 0 and est.n_collinear == 0
    assert np.max(np.abs(W[-500:] - omega)) < 1e-3
    check_honest(W, st)


@pytest.mark.parametrize("make", [sarras, supervised], ids=["sarras", "supervised"])
def test_update_after_a_restart_recovers(make):
    """The same through ``update``: the call at the gap returns NaN with status RESTARTED, later calls recover."""
    t, q, _ = gap_log(1e6, SPIN, rows=1400)
    est = make(np.diag([3.0, 2.0, 1.0]))
    W = np.array([est.update(tk, qk).omega for tk, qk in zip(t, q, strict=True)])
    assert np.all(np.isnan(W[1000])) and np.all(np.isfinite(W[1001:]))
    assert est.n_restarts == 1
    assert np.max(np.abs(W[-200:] - SPIN)) < 1e-3


@pytest.mark.parametrize("make", [sarras, supervised], ids=["sarras", "supervised"])
def test_overflowing_torque_restarts_instead_of_nan(make):
    """1e10 N m with J = I on a constant-rate log: the steps cannot be taken; each restarts, none gives NaN as an
    estimate, and the run stays fast (the refused interval is not integrated)."""
    t, q, _ = gap_log(0.0, rows=300)
    tau = np.tile([1e10, 0.0, 0.0], (t.size, 1))
    est = make()
    W, st = run_quiet(est, t, q, tau)
    assert np.count_nonzero(st == Status.RESTARTED) > 50
    check_honest(W, st)
    assert np.all(np.isnan(W[st == Status.RESTARTED]))


def test_huge_gains_restart_instead_of_nan():
    """k = l = 1e300: the correction overflows; the estimator restarts instead of writing NaN as an estimate."""
    t, q, _ = gap_log(0.0, rows=200)
    est = sarras(gains=ObserverGains.constant(1e300, 1e300, n=3))
    W, st = run_quiet(est, t, q)
    assert np.count_nonzero(st == Status.RESTARTED) > 10
    check_honest(W, st)


def test_mekf_restarts_and_its_compiled_run_equals_update():
    """The MEKF baseline: a torque of 1e200 N m at one sample (J = I) overflows the next step; the filter restarts
    from its prior there (NaN at that sample) and recovers; ``run`` (compiled) and a loop of ``update`` (NumPy)
    agree sample by sample."""
    t, q, omega = gap_log(0.0, rows=600)
    tau = np.zeros((t.size, 3))
    tau[200] = [1e200, 0.0, 0.0]
    kw = {"q": 1e-6, "measurement_noise": 1e-3}
    a, b = MEKF(np.eye(3), **kw), MEKF(np.eye(3), **kw)
    with pytest.warns(RestartedWarning, match="restarted 1 times"):
        W = a.run(t, q, tau).omega
    U = np.array([b.update(tk, qk, tk_tau).omega for tk, qk, tk_tau in zip(t, q, tau, strict=True)])
    assert a.n_restarts == b.n_restarts == 1
    # row 0: the first fix gives no rate (the contract); row 201: the restart
    assert np.flatnonzero(np.isnan(W[:, 0])).tolist() == [0, 201] == np.flatnonzero(np.isnan(U[:, 0])).tolist()
    np.testing.assert_allclose(W[202:], U[202:], rtol=1e-9, atol=1e-12)
    assert np.max(np.abs(W[-100:] - omega)) < 1e-3


def write_log(path, t, q, tau=None):
    cols = [t, q[:, 3], q[:, 0], q[:, 1], q[:, 2]] + ([] if tau is None else [tau[:, 0], tau[:, 1], tau[:, 2]])
    head = "t,qw,qx,qy,qz" + ("" if tau is None else ",tau_x,tau_y,tau_z")
    np.savetxt(path, np.column_stack(cols), delimiter=",", header=head, comments="", fmt="%.17g")
    return path


def cli_rows(out):
    lines = out.read_text().splitlines()[1:]
    W = np.array([[float(v) for v in line.split(",")[1:4]] for line in lines])
    words = np.array([line.split(",")[4] for line in lines])
    return W, words


@pytest.mark.parametrize(
    ("jump", "options"),
    [
        (1e6, ["--estimator", "sarras"]),
        (3e5, ["--estimator", "sarras"]),
        (1e6, ["--inertia", "1", "1", "1"]),
        (1e6, ["--inertia", "3", "2", "1", "--estimator", "sarras"]),
    ],
)
def test_cli_gap_repro(tmp_path, capsys, jump, options):
    """The issue's repro through ``omegahat estimate``: exit 0, no NaN row labelled corrected, every row after the
    gap's restart finite, the last 500 within 1e-3 rad/s."""
    omega = SPIN if "3" in options else OMEGA
    t, q, _ = gap_log(jump, omega)
    log = write_log(tmp_path / "gap.csv", t, q)
    out = tmp_path / "o.csv"
    assert main(["estimate", str(log), "-o", str(out), *options]) == 0
    W, words = cli_rows(out)
    finite = np.all(np.isfinite(W), axis=1)
    assert not np.any(~finite & np.isin(words, ["corrected", "predicted"]))
    assert np.all(finite[1002:])
    assert np.max(np.abs(W[-500:] - omega)) < 1e-3
    capsys.readouterr()


@pytest.mark.parametrize("options", [["--k", "1e300", "--l", "1e300"], ["--inertia", "1", "1", "1", "--torque"]])
def test_cli_overflow_never_labels_nan_corrected(tmp_path, capsys, options):
    """``--k 1e300 --l 1e300`` and a 1e10 N m torque column: rows without an estimate say ``restarted`` or
    ``unavailable``; the summary counts the restarts."""
    t, q, _ = gap_log(0.0, rows=400)
    tau = np.tile([1e10, 0.0, 0.0], (t.size, 1)) if "--torque" in options else None
    log = write_log(tmp_path / "x.csv", t, q, tau)
    out = tmp_path / "o.csv"
    argv = ["estimate", str(log), "-o", str(out), *[o for o in options if o != "--torque"]]
    assert main(argv) == 0
    W, words = cli_rows(out)
    finite = np.all(np.isfinite(W), axis=1)
    assert not np.any(~finite & np.isin(words, ["corrected", "predicted"]))
    assert np.count_nonzero(words == "restarted") > 10
    assert "restarted" in capsys.readouterr().out


def test_an_interval_too_far_to_integrate_fails_at_once_in_both_filters():
    # h(|ω̂| + h|J⁻¹τ|) at or above MAX_SUBSTEPS · 0.2 rad (2000 rad in one interval; NaN too): the step is not
    # integrated in ten thousand substeps (a 1e10 N m torque column made a 400-row log take 40 s); ω̂ becomes NaN,
    # R and P are left as they were, and the filters' guard restarts. Just below the bound it is integrated.
    from omegahat.baselines.mekf import propagate_with_transition
    from omegahat.kernels.ekf import COVARIANCE_SUBSTEP_ANGLE, MAX_SUBSTEPS, ekf_propagate
    from omegahat.simulation.rigid_body import RigidBody

    bound = MAX_SUBSTEPS * COVARIANCE_SUBSTEP_ANGLE
    J = np.eye(3)
    h = 0.01
    for tau_x, fails in [(1e10, True), (0.99 * bound / h**2, False), (np.nan, True)]:
        tau = np.array([tau_x, 0.0, 0.0])
        R, w, a, P = np.eye(3), np.zeros(3), np.zeros(3), np.eye(6)
        n = ekf_propagate(R, w, a, P, h, tau, tau, J, J, 1e-4, 0.0, True, np.inf, 0.2)
        assert (n == 0) == fails and np.all(np.isnan(w)) == fails
        np.testing.assert_array_equal(R if fails else np.eye(3), np.eye(3))  # untouched when it fails
        _, w2, P2, _ = propagate_with_transition(
            np.eye(3), np.zeros(3), np.eye(6), h, tau, RigidBody(J), 1e-4, "dynamic"
        )
        assert np.all(np.isnan(w2)) == fails
        if fails:
            np.testing.assert_array_equal(P2, np.eye(6))
        else:
            np.testing.assert_allclose(w2, w, rtol=1e-9)  # the NumPy oracle and the kernel agree


@pytest.mark.parametrize("part", ["R", "w", "a", "P"])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_the_ekf_state_guard_finds_any_entry_that_is_not_finite(part, bad):
    """``ekf_finite``, the guard after every EKF step: False where any entry of R̂, ω̂, â or P (6×6 and 9×9) is NaN
    or ±inf, wherever it is; True for a state of finite entries as large as floats go."""
    from omegahat.kernels.ekf import ekf_finite

    rng = np.random.default_rng(3)
    for n in (6, 9):
        state = {"R": np.eye(3), "w": rng.normal(size=3), "a": rng.normal(size=3), "P": np.full((n, n), 1e308)}
        assert ekf_finite(state["R"], state["w"], state["a"], state["P"])
        for index in np.ndindex(state[part].shape):
            broken = {k: v.copy() for k, v in state.items()}
            broken[part][index] = bad
            assert not ekf_finite(broken["R"], broken["w"], broken["a"], broken["P"]), (part, index)
