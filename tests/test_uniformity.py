"""Continuous observers on a campaign's draws (omegahat.lab.evaluation.uniformity).

References: the truth integrated on its own by SciPy (DOP853 on Euler's equations), the paper's erratum (the
printed output map does not converge with the paper's constant l = 1), closed forms for the rate (U2) and the
campaign's own draws (draw_problem, a second path to the same numbers); the sampled gyro-free peers on the same
draws, and on a spin they follow exactly.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.draws import draw_problem
from omegahat.lab.evaluation import peer_uniformity as PU
from omegahat.lab.evaluation import uniformity as u
from omegahat.observer import continuous as cont
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation.torque import Torque

J = np.diag([3.0, 2.0, 1.0])
REFS = np.eye(3)[:2]
OMEGA0 = np.array([2.0, -1.0, 0.6])  # the paper's scenario
R_HAT0 = np.array([[0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])


def paper_run(gains, sign=cont.OUTPUT_SIGN_CORRECTED, horizon=5.0):
    obs = u.SarrasObserver(J, gains, REFS, sign)
    x0 = obs.initial_state(np.eye(3), np.zeros(3), R_HAT0)
    t = np.linspace(0.0, horizon, round(horizon / 0.05) + 1)
    return obs, u.simulate_coupled(J, obs, np.eye(3), OMEGA0, x0, t)


@pytest.fixture(scope="module")
def theorem_run():
    return paper_run(theorem_gains(J, 3.0))


def test_sarras_converges_on_the_papers_scenario_against_an_independent_truth(theorem_run):
    obs, run = theorem_run
    assert np.allclose(obs.estimate(obs.initial_state(np.eye(3), np.zeros(3), R_HAT0), np.eye(3)), 0.0, atol=1e-12)
    J_inv = np.linalg.inv(J)
    truth = solve_ivp(
        lambda t, w: J_inv @ np.cross(J @ w, w), (0.0, run.t[-1]), OMEGA0, method="DOP853", t_eval=run.t,
        rtol=1e-12, atol=1e-14,
    )  # fmt: skip
    assert np.max(np.abs(run.omega - truth.y.T)) < 1e-6  # the coupled integration's truth is the body's motion
    assert np.max(np.abs(np.einsum("tij,tik->tjk", run.R, run.R) - np.eye(3))) < 1e-6  # R stays a rotation
    err = np.linalg.norm(run.omega_hat - truth.y.T, axis=1)
    assert err[0] == pytest.approx(np.linalg.norm(OMEGA0), rel=1e-12)  # ω̂₀ = 0
    assert not run.diverged
    assert np.max(err[run.t >= 3.0]) < 1e-3
    t_tol, rate = u.run_rate(run.t, err, 1e-3)
    assert t_tol < 3.0 and rate > math.log(np.linalg.norm(OMEGA0) / 1e-3) / 3.0


def test_the_proofs_lyapunov_function_decreases_along_the_trajectory(theorem_run):
    _, run = theorem_run
    V = run.V
    # V from its definition, recomputed from the sampled states: |J (ω̂ − ω)| + ½ Σ |r̂_i − r_i|²
    assert V[0] == pytest.approx(np.linalg.norm(J @ (-OMEGA0)) + 0.5 * np.sum((R_HAT0 - REFS) ** 2), rel=1e-9)
    live = V[:-1] > 1e-8 * V[0]
    assert live.sum() > 10
    assert np.all(np.diff(V)[live] <= 1e-6 * V[:-1][live])
    assert not u.v_increased(V)
    assert V[-1] < 1e-6 * V[0]
    assert u.v_increased(np.array([1.0, 0.5, 0.6, 0.1]))  # a rise is seen
    assert not u.v_increased(np.array([1.0, 1e-9, 2e-9]))  # below the floor it is rounding


def test_the_printed_output_map_is_flagged_where_the_corrected_one_converges():
    paper_gains = ObserverGains.constant(14.5, 1.0)  # the paper's simulation gains
    _, good = paper_run(paper_gains, horizon=2.5)
    # the printed map's run is stiff and slow to integrate: one second shows it growing
    _, bad = paper_run(paper_gains, cont.OUTPUT_SIGN_PRINTED, horizon=1.0)
    err_good = np.linalg.norm(good.omega_hat - good.omega, axis=1)
    err_bad = np.linalg.norm(bad.omega_hat - bad.omega, axis=1)
    assert err_good[-1] < 1e-3
    assert err_bad[-1] > max(1.0, 2.0 * err_bad[0])  # the erratum: the printed map does not converge (it grows)
    assert math.isinf(u.run_rate(bad.t, err_bad, 1e-3)[0])


def small_campaign(**kw):
    base = dict(
        J=J, omega_max=3.0, gains={"theorem": theorem_gains(J, 3.0)}, references=REFS, runs=2, seed=7,
        horizon=0.5, dt_out=0.05, omega_hat_max=5.0,
    )  # fmt: skip
    base.update(kw)
    return Campaign(**base)


def test_every_observer_starts_from_the_same_draws():
    c = small_campaign()
    rows = u.run_uniformity(c, ["sarras", "sarras-printed"])
    assert [(r.observer, r.index) for r in rows] == [
        ("sarras", 0), ("sarras-printed", 0), ("sarras", 1), ("sarras-printed", 1)
    ]  # fmt: skip
    assert u.same_draws(rows)
    for r in rows:  # the campaign's draw of that run, rebuilt by draw_problem (one run alone)
        p = draw_problem(c, r.index)
        assert np.array_equal(r.omega0, p.omega0) and np.array_equal(r.omega_hat0, p.omega_hat0)
        assert r.err0 == pytest.approx(np.linalg.norm(p.omega_hat0 - p.omega0), rel=1e-12)
    assert not u.same_draws([rows[0], dataclasses.replace(rows[1], omega_hat0=(0.0, 0.0, 0.0))])
    text = u.markdown(rows)
    assert "| sarras |" in text and "* **sarras-printed**: 2 runs" in text


def test_rate_and_time_of_an_exact_exponential():
    lam, e0, tol = 2.5, 40.0, 1e-3
    t = np.linspace(0.0, 10.0, 10001)
    t_tol, rate = u.run_rate(t, e0 * np.exp(-lam * t), tol)
    assert t_tol == pytest.approx(math.log(e0 / tol) / lam, abs=1e-3)
    assert rate == pytest.approx(lam, rel=1e-3)
    assert u.run_rate(t, np.full(t.size, 1.0), tol) == (math.inf, 0.0)
    assert u.run_rate(t, np.full(t.size, 1e-4), tol) == (0.0, math.inf)


def row(name, err0, t_tol, rate, index=0):
    return u.UniformityRow(
        name, index, (0.0,) * 3, (0.0,) * 3, (0.0, 0.0, 0.0, 1.0), err0, t_tol, rate, 0.0, False, None
    )


def test_bins_and_counterexamples_by_hand():
    rows = [row("a", 0.5, 1.0, 7.0), row("a", 2.0, 2.0, 4.0), row("a", 2.5, 3.0, 2.0), row("a", 50.0, math.inf, 0.0)]
    table = u.bin_table(rows, edges=(0.0, 1.0, 3.0, 100.0))
    assert [(b["runs"], b["converged"]) for b in table] == [(1, 1), (2, 2), (1, 0)]
    assert table[1]["median_t_tol"] == 2.5 and table[1]["worst_t_tol"] == 3.0 and table[1]["worst_rate"] == 2.0
    assert math.isinf(table[2]["worst_t_tol"]) and table[2]["worst_rate"] == 0.0
    assert [r.err0 for r in u.counterexamples(rows)] == [50.0]
    assert [r.err0 for r in u.counterexamples(rows, rate_floor=3.0)] == [2.5, 50.0]


def test_errors():
    with pytest.raises(ValueError, match="tolerance must be positive"):
        u.run_rate(np.arange(3.0), np.ones(3), 0.0)
    with pytest.raises(ValueError, match="bin edges must be at least two increasing numbers"):
        u.bin_table([], edges=(0.0, 3.0, 1.0))
    with pytest.raises(ValueError, match=r"unknown observer\(s\) \['salcudean'\]; available"):
        u.run_uniformity(small_campaign(), ["salcudean"])
    with pytest.raises(ValueError, match="the campaign has no gain set 'slope'"):
        u.run_uniformity(small_campaign(), gains="slope")
    with pytest.raises(ValueError, match=r"2 gains were given for references of shape \(3, 3\)"):
        u.SarrasObserver(J, theorem_gains(J, 3.0), np.eye(3))


def test_cli_montecarlo_observers(tmp_path, capsys):
    from pathlib import Path

    from omegahat.cli import main

    config = Path(__file__).resolve().parent.parent / "examples" / "campaign.toml"
    out = tmp_path / "o"
    argv = ["montecarlo", str(config), "--runs", "1", "--observers", "sarras", "--horizon", "0.5", "--no-progress"]
    assert main([*argv, "--out", str(out)]) == 0
    text = (out / "uniformity.md").read_text()
    assert text.startswith("| observer | initial error (rad/s) |") and "* **sarras**: 1 runs" in text
    assert "same draws for every observer: True" in capsys.readouterr().out
    assert main([*argv[:4], "--observers", "salcudean", "--out", str(out)]) == 2
    assert "unknown observer(s) ['salcudean']" in capsys.readouterr().err


def test_the_sampled_peers_start_from_the_same_draws():
    """The gyro-free peers (peer_uniformity) beside the observer: every row from the campaign's draw of that run
    (draw_problem), the initial error |ω̂₀ − ω₀| (the sun-line SEKF's across its one direction b₀ = R₀ᵀ v₁), the
    tuned knob in the name."""
    c = small_campaign(runs=1)
    rows = u.run_uniformity(c, ["sarras", "min-energy", "sunline-sekf"])
    assert u.same_draws(rows) and rows[0].observer == "sarras"
    assert rows[1].observer.startswith("min-energy (1/rho = ") and rows[2].observer.startswith("sunline-sekf, across b")
    p = draw_problem(c, 0)
    d = p.omega_hat0 - p.omega0
    b0 = np.asarray(p.R0).T @ REFS[0]
    assert rows[1].err0 == pytest.approx(np.linalg.norm(d), rel=1e-12)
    assert rows[2].err0 == pytest.approx(np.linalg.norm(d - (d @ b0) * b0), rel=1e-9)


def test_a_sampled_peer_started_on_a_spin_stays_on_it():
    """A torque-free spin about a principal axis, the minimum-energy filter started on it: the sampled truth and
    the filter agree at every output time (the filter is exact there, tests/test_tso3.py)."""
    t_out = np.linspace(0.0, 2.0, 41)
    w = np.array([0.0, 0.0, 0.8])
    peer = PU.TunedPeer(PU.SAMPLED["min-energy"], 1.0)
    err, restarts = PU.errors(small_campaign(), peer, np.eye(3), w, w, t_out, Torque.none())
    assert restarts == 0 and err.shape == t_out.shape and err.max() < 1e-9
