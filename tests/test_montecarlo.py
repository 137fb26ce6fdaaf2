"""Monte-Carlo campaigns: batch = loop of simulate, chunking and replay, seeds, envelope fit against closed forms,
the compiled diagnostics against their NumPy reference, the sampler's ranges, counterexamples, TOML errors and the
command."""

import dataclasses
import json
import math
import re
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.lab import campaigns as mc
from omegahat.lab.campaigns.diagnostics import diagnose_reference
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation import CoupledProblem, Torque, simulate, simulate_batch

J = np.diag([3.0, 2.0, 1.0])


def _small(runs=6, **kw):
    base = dict(
        J=J,
        omega_max=3.0,
        gains={"theorem": theorem_gains(J, 3.0), "constant": ObserverGains.constant(14.5, 1.0)},
        runs=runs,
        seed=123,
        chunk_size=4,
        horizon=1.0,
        dt_out=0.1,
    )
    base.update(kw)
    return mc.Campaign(**base)


def _random_problems(gains, count, seed):
    rng = np.random.default_rng(seed)
    problems = []
    for j in range(count):
        m = j % 3  # 0, 1 or 2 torque terms: the batch pads with zero terms
        problems.append(
            CoupledProblem(
                J=J,
                gains=gains,
                omega0=rng.normal(size=3),
                R0=Rotation.random(random_state=rng),
                r_hat0=rng.normal(size=(2, 3)) * 3,
                omega_hat0=rng.normal(size=3) * 20,
                torque=Torque.sinusoidal(
                    constant=rng.normal(size=3) * 0.1,
                    amplitudes=rng.normal(size=(m, 3)) * 0.3,
                    frequencies=rng.uniform(0.5, 4.0, m),
                    phases=rng.uniform(0, 6.0, (m, 3)),
                ),
            )
        )
    return problems


@pytest.mark.parametrize("gains", [theorem_gains(J, 3.0), ObserverGains.constant(5.0, 2.0)], ids=["theorem", "l2"])
def test_batch_equals_loop_of_simulate(gains):
    problems = _random_problems(gains, 7, seed=5)
    t = np.linspace(0.0, 1.5, 16)
    batch = simulate_batch(problems, t, rtol=1e-8, n_workers=2)
    assert batch.ok.all()
    for j, p in enumerate(problems):
        single = simulate(p, t_out=t, rtol=1e-8)
        n = 2
        np.testing.assert_allclose(batch.Y[j, :, 3 * n + 3 : 3 * n + 6], single.z, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.Y[j, :, 3 * n + 6 :].reshape(-1, n, 3), single.e, rtol=0, atol=1e-12)
        np.testing.assert_allclose(batch.Y[j, :, 3 * n : 3 * n + 3], single.omega, rtol=0, atol=1e-12)
        assert batch.accepted[j] == single.steps and batch.rejected[j] == single.rejected


def test_batch_does_not_depend_on_workers_or_order():
    problems = _random_problems(theorem_gains(J, 3.0), 5, seed=9)
    t = np.linspace(0.0, 0.5, 6)
    a = simulate_batch(problems, t, rtol=1e-7, n_workers=1)
    b = simulate_batch(problems[::-1], t, rtol=1e-7, n_workers=3)
    np.testing.assert_array_equal(a.Y, b.Y[::-1])


def test_batch_rejects_mixed_gains_and_bad_arguments():
    p = _random_problems(theorem_gains(J, 3.0), 1, 0) + _random_problems(ObserverGains.constant(1.0, 1.0), 1, 0)
    with pytest.raises(ValueError, match="problem 1 has another J, gains or references"):
        simulate_batch(p, [0.0, 1.0])
    with pytest.raises(ValueError, match="at least one problem"):
        simulate_batch([], [0.0, 1.0])
    with pytest.raises(ValueError, match="t_out must start at 0"):
        simulate_batch(p[:1], [0.5, 1.0])
    with pytest.raises(ValueError, match="n_workers must be at least 1; got 0"):
        simulate_batch(p[:1], [0.0, 1.0], n_workers=0)


def test_run_seed_is_the_spawned_child():
    children = np.random.SeedSequence(42).spawn(5)
    for j, child in enumerate(children):
        a = np.random.default_rng(child).random(4)
        b = np.random.default_rng(mc.run_seed(42, j)).random(4)
        np.testing.assert_array_equal(a, b)


def _draw_one(c, j):
    # the sampler's recipe (module docstring of omegahat.lab.campaigns.runner), written run by run with the
    # generator's own distributions and norms summed left to right
    rng = np.random.default_rng(mc.run_seed(c.seed, j))

    def unit(v):
        return v / math.sqrt(sum(x * x for x in v))

    q = unit(rng.normal(size=4))
    omega0 = unit(rng.normal(size=3)) * c.omega0_fraction * c.omega_max * rng.random() ** (1.0 / 3.0)
    R0 = Rotation.from_quat(q).as_matrix()
    r_hat0 = []
    for i in range(c.references.shape[0]):
        u = rng.random()
        ball = unit(rng.normal(size=3)) * c.r_hat_radius * rng.random() ** (1.0 / 3.0)
        r_i = c.references[i] @ R0
        r_hat0.append(np.zeros(3) if u < c.p_zero else -r_i if u < c.p_zero + c.p_opposite else ball)
    omega_hat0 = unit(rng.normal(size=3)) * c.omega_hat_max * rng.random()
    M = c.torque_terms
    amplitudes = rng.uniform(-c.torque_amplitude, c.torque_amplitude, size=(M, 3))
    frequencies = rng.uniform(*c.torque_frequency, size=M)
    phases = rng.uniform(0.0, 2.0 * np.pi, size=(M, 3))
    return dict(
        R0=R0,
        omega0=omega0,
        r_hat0=np.array(r_hat0),
        omega_hat0=omega_hat0,
        amplitudes=amplitudes,
        frequencies=frequencies,
        phases=phases,
    )


def test_draws_follow_the_recipe_run_by_run():
    c = _small(
        runs=40,
        p_zero=0.2,
        p_opposite=0.2,
        torque_terms=3,
        references=np.eye(3),
        gains={"three": ObserverGains.constant(5.0, 2.0, n=3)},
    )
    indices = [0, 3, 17, 39, 38, 5]
    got = draw_runs(c, indices)
    for row, j in enumerate(indices):
        want = _draw_one(c, j)
        for key, value in want.items():
            np.testing.assert_array_equal(got[key][row], value, err_msg=f"run {j} {key}")
    assert np.count_nonzero(np.all(got["r_hat0"] == 0.0, axis=-1)) > 0  # the special cases were drawn


def test_campaign_does_not_depend_on_chunking_and_runs_replay():
    c = _small(runs=7)
    a = mc.run_campaign(c, chunk_size=3)
    b = mc.run_campaign(c, chunk_size=7)
    for name in c.gains:
        np.testing.assert_array_equal(a[name].rho, b[name].rho)
        np.testing.assert_array_equal(a[name].lam, b[name].lam)
    # any run replays alone from (seed, index) through the single-run simulate
    tr = mc.replay(c, "theorem", 5)
    E = np.linalg.norm(tr.z, axis=-1) + np.linalg.norm(tr.e, axis=-1).sum(-1)
    np.testing.assert_allclose(E / E[0], a["theorem"].rho[5], rtol=1e-12, atol=0)
    # a single chunk in the middle gives the same rows
    mid = mc.run_chunk(c, 2, 5)["constant"]
    np.testing.assert_array_equal(mid.rho, a["constant"].rho[2:5])
    with pytest.raises(ValueError, match=r"chunk \[5, 9\) is not inside the campaign's 7 runs"):
        mc.run_chunk(c, 5, 9)


def test_run_chunk_equals_drawing_each_problem_per_gain_set():
    """run_chunk draws each run once for all gain sets; every field of its results is what drawing the problem per
    gain set with draw_problem, simulate_batch and diagnose gives (h0 differs between these gain sets)."""
    gains = {
        "theorem": theorem_gains(J, 3.0),
        "slope": ObserverGains(k=[5.0, 5.0], l_offset=5.0, l_slope=2.0),
        "constant": ObserverGains.constant(14.5, 1.0),
    }
    c = _small(
        runs=12,
        gains=gains,
        horizon=0.5,
        dt_out=0.05,
        p_zero=0.25,
        p_opposite=0.25,
        references=[[1.0, 1.0, 0.0], [0.0, 1.0, 2.0]],
    )
    for start, stop, parallel in [(0, 12, True), (3, 10, False)]:
        got = mc.run_chunk(c, start, stop, parallel=parallel)
        assert list(got) == list(gains)
        steps = []
        for name in gains:
            problems = [mc.draw_problem(c, j, name) for j in range(start, stop)]
            batch = simulate_batch(problems, c.t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
            want = mc.diagnose(c, batch, np.arange(start, stop))
            for f in dataclasses.fields(mc.GainSetResult):
                a, b = getattr(got[name], f.name), getattr(want, f.name)
                assert a.dtype == b.dtype and a.shape == b.shape, (name, f.name)
                assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), (name, f.name)
            steps.append(want.steps)
        assert not np.array_equal(steps[0], steps[2])  # the gain sets really are integrated differently


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # the reference's nanmax of failed runs' NaN rows
def test_compiled_diagnose_equals_numpy_reference():
    """diagnose (one Numba pass, threads or not) gives every field of _diagnose_numpy on runs of every kind: failed
    (step budget: NaN rows), leaving |ω| ≤ ω_M, reaching ρ_floor or not, V increasing (constant l), plus rows edited
    by hand: a NaN or infinite state in runs the kernel reported ok, a NaN ω alone (nanmax), E(0) = 0."""
    gains = {
        "theorem": theorem_gains(J, 3.0),
        "slope": ObserverGains(k=[5.0, 5.0], l_offset=5.0, l_slope=2.0),
        "constant": ObserverGains.constant(14.5, 1.0),
    }
    c = _small(
        runs=24,
        gains=gains,
        horizon=3.0,
        dt_out=0.05,
        omega0_fraction=1.0,
        torque_amplitude=1.0,
        p_zero=0.25,
        p_opposite=0.25,
        max_steps=2100,
    )
    indices = np.arange(c.runs)
    seen = dict.fromkeys(["failed", "out of bound", "floor reached", "floor not reached", "V increased"], 0)
    for name in gains:
        problems = [mc.draw_problem(c, j, name) for j in indices]
        batch = simulate_batch(problems, c.t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
        if name == "slope":
            Y = batch.Y.copy()
            Y[0, 7, 9] = np.nan  # z of run 0 (ok for the kernel): ok becomes False
            Y[3, 5, 12] = np.inf  # e_1 of run 3: ok becomes False too
            Y[1, [0, 1, -1], 6] = np.nan  # ω of run 1 only: it stays ok, its peak is the largest finite |ω|
            Y[2, :, 9:] = 0.0  # z = e = 0: E(0) = 0, ρ = NaN
            batch = dataclasses.replace(batch, Y=Y)
        want = diagnose_reference(c, batch, indices)
        for parallel in (True, False):
            got = mc.diagnose(c, batch, indices, parallel=parallel)
            for f in dataclasses.fields(mc.GainSetResult):
                a, b = getattr(got, f.name), getattr(want, f.name)
                assert a.dtype == b.dtype and a.shape == b.shape, (name, f.name)
                if a.dtype.kind == "f":
                    np.testing.assert_allclose(a, b, rtol=1e-12, atol=0, equal_nan=True, err_msg=f"{name} {f.name}")
                else:
                    np.testing.assert_array_equal(a, b, err_msg=f"{name} {f.name}")
        ok = want.ok
        seen["failed"] += int((~ok).sum())
        seen["out of bound"] += int((ok & ~want.in_bound).sum())
        seen["floor reached"] += int((ok & (want.t_f < c.t_out[-1])).sum())
        seen["floor not reached"] += int((ok & (want.t_f == c.t_out[-1])).sum())
        seen["V increased"] += int((ok & (want.v_increase > c.v_increase_tol)).sum())
    assert min(seen.values()) >= 3, seen


def test_sampler_ranges_and_special_initial_filters():
    c = _small(runs=400, p_zero=0.2, p_opposite=0.2, omega_hat_max=100.0, r_hat_radius=10.0, omega0_fraction=0.5)
    zero = opposite = 0
    traces = []
    for j in range(c.runs):
        p = mc.draw_problem(c, j)
        assert np.linalg.norm(p.omega0) <= 0.5 * 3.0
        assert np.linalg.norm(p.omega_hat0) <= 100.0
        assert np.all(np.linalg.norm(p.r_hat0, axis=1) <= 10.0)
        r0 = p.r0
        zero += int(np.sum(np.all(p.r_hat0 == 0.0, axis=1)))
        opposite += int(np.sum(np.all(p.r_hat0 == -r0, axis=1)))
        traces.append(np.trace(p.R0))
        assert p.torque.amplitudes.shape == (2, 3) and np.all(np.abs(p.torque.amplitudes) <= 0.3)
    # 800 filters, each zero / opposite with probability 0.2: expected 160, sd 11.3
    assert 110 < zero < 210 and 110 < opposite < 210
    # Haar measure on SO(3): E[trace R] = 0, Var[trace R] = 1 (trace = 1 + 2 cos θ, θ with density (1 - cos θ)/π)
    assert abs(np.mean(traces)) < 0.2 and abs(np.var(traces) - 1.0) < 0.25


def test_envelope_fit_of_pure_exponential_and_of_overshoot():
    t = np.linspace(0.0, 10.0, 1001)
    floor = 1e-8
    pure = np.exp(-3.0 * t)  # reaches the floor at t = ln(1e8)/3 = 6.14 s
    a, b, T = 4.0, 1.0, 10.0
    over = (1 + a * t) * np.exp(-b * t)  # never reaches the floor: λ_run = b − ln(1 + aT)/T
    lam, c_run, i_f = mc.envelope_fit(t, np.stack([pure, over]), floor)
    t_f_pure = t[np.flatnonzero(pure >= floor)[-1]]
    assert t_f_pure == pytest.approx(math.log(1e8) / 3.0, abs=0.01)
    assert lam[0] == pytest.approx(3.0, rel=1e-12)
    assert c_run[0] == pytest.approx(1.0, rel=1e-12)
    s = math.log(1 + a * T) / T
    assert lam[1] == pytest.approx(b - s, rel=1e-12)
    # c_run = max_t (1 + a t) e^{−s t}: the maximum is at t* = 1/s − 1/a
    t_star = 1 / s - 1 / a
    assert c_run[1] == pytest.approx((1 + a * t_star) * math.exp(-s * t_star), rel=1e-5)
    assert i_f[1] == t.size - 1


def test_worst_envelope_is_min_rate_and_max_constant():
    c = _small(runs=2, horizon=10.0, dt_out=0.01)
    t = c.t_out
    rho = np.stack([np.exp(-2.0 * t), (1 + 4 * t) * np.exp(-3.0 * t)])
    lam, c_run, i_f = mc.envelope_fit(t, rho, c.rho_floor)
    r = mc.GainSetResult(
        index=np.arange(2),
        ok=np.ones(2, bool),
        in_bound=np.ones(2, bool),
        omega_peak=np.zeros(2),
        rho=rho,
        E0=np.ones(2),
        lam=lam,
        c_run=c_run,
        t_f=t[i_f],
        v_increase=np.zeros(2),
        steps=np.zeros(2, int),
        rejected=np.zeros(2, int),
    )
    lam_star, c_star, slowest = mc.worst_envelope(c, r)
    assert lam_star == pytest.approx(2.0, rel=1e-12) and slowest == 0
    # max_t (1 + 4t) e^{−t}: at t = 3/4, value 4 e^{−3/4}
    assert c_star == pytest.approx(4 * math.exp(-0.75), rel=1e-4)


def test_theorem_gains_converge_and_v_decreases_on_wide_initial_conditions():
    """The claim itself on 12 runs with |ω̂₀| up to 100 and r̂ anywhere in the ball of radius 10, 0 and −r
    included (p = 0.25 each): every in-bound run converges and V never increases on the grid."""
    c = _small(
        runs=12,
        gains={"theorem": theorem_gains(J, 3.0)},
        horizon=4.0,
        p_zero=0.25,
        p_opposite=0.25,
        converged_below=1e-6,
    )
    res = mc.run_campaign(c)
    s = mc.summarize(c, res)["gain_sets"]["theorem"]
    assert s["satisfies_theorem"]
    assert s["runs_used"] >= 10
    assert s["counterexamples"] == 0 and s["v_increased_runs"] == 0
    assert s["worst_lambda"] > 3.0  # measured 4.86 on 10,000 runs of examples/campaign.toml


def test_campaign_runs_match_the_papers_equations_integrated_by_scipy():
    """The campaign's envelope ρ(t) of three runs against the same runs in the observer's own (ξ, r̂) coordinates
    (omegahat.observer.continuous, the paper's equations) integrated by solve_ivp: an independent check of what
    the campaign's engine integrates, not only that it agrees with itself."""
    from omegahat.simulation import simulate_reference

    c = _small(runs=3, gains={"slope": ObserverGains(k=[5.0, 5.0], l_offset=5.0, l_slope=2.0)}, horizon=2.0,
               rtol=1e-9)  # fmt: skip
    res = mc.run_campaign(c)["slope"]
    for j in range(c.runs):
        ref = simulate_reference(mc.draw_problem(c, j), c.t_out, method="DOP853", rtol=1e-12, atol=1e-14)
        E = np.linalg.norm(ref.z, axis=-1) + np.linalg.norm(ref.e, axis=-1).sum(axis=-1)
        np.testing.assert_allclose(res.rho[j], E / E[0], rtol=1e-6, atol=1e-9, err_msg=f"run {j}")


def test_constant_small_l_fails_globally_and_counterexamples_replay():
    """With constant l = 1 a large initial estimate gets stuck: run saved with its seed, replayed identically."""
    c = _small(runs=6, gains={"constant": ObserverGains.constant(14.5, 1.0)}, horizon=3.0, omega_hat_max=100.0)
    res = mc.run_campaign(c)
    s = mc.summarize(c, res)["gain_sets"]["constant"]
    assert not s["satisfies_theorem"]
    assert s["counterexamples"] >= 1
    cex = s["counterexample_list"][0]
    assert cex["seed"] == {"entropy": 123, "spawn_key": [cex["index"]]}
    tr = mc.replay(c, "constant", cex["index"])
    E = np.linalg.norm(tr.z, axis=-1) + np.linalg.norm(tr.e, axis=-1).sum(-1)
    assert E[-1] / E[0] == pytest.approx(cex["rho_end"], rel=1e-12)
    for cex in s["counterexample_list"]:  # saved initial conditions: those of draw_problem, to the bit
        p = mc.draw_problem(c, cex["index"])
        for f in ("omega0", "R0", "r_hat0", "omega_hat0"):
            np.testing.assert_array_equal(getattr(p, f), cex[f])
        for f in ("amplitudes", "frequencies", "phases"):
            np.testing.assert_array_equal(getattr(p.torque, f), cex["torque"][f])


def test_out_of_bound_runs_are_set_aside():
    c = _small(
        runs=6,
        gains={"theorem": theorem_gains(J, 3.0)},
        omega0_fraction=1.0,
        torque_amplitude=3.0,
        torque_frequency=(0.5, 0.6),
        horizon=2.0,
    )
    res = mc.run_campaign(c)["theorem"]
    s = mc.summarize(c, {"theorem": res})["gain_sets"]["theorem"]
    out = res.ok & (res.omega_peak > 3.0)
    assert out.sum() >= 1
    assert s["runs_out_of_bound"] == out.sum() and s["runs_used"] == (res.in_bound & np.isfinite(res.lam)).sum()


# ------------------------------------------------------------------------------------------ configuration

GOOD = """
[campaign]
runs = 3
seed = 7
horizon = 0.5
dt_out = 0.1

[body]
omega_max = 3.0

[gains.theorem]
kind = "theorem"

[gains.small]
kind = "affine"
k = 5.0
l_offset = 5.0
l_slope = 2.0
"""


def test_toml_builds_the_campaign():
    c = mc.campaign_from_toml(GOOD)
    assert c.runs == 3 and c.seed == 7 and c.omega_max == 3.0
    np.testing.assert_allclose(c.gains["theorem"].k, [14.5, 14.5])
    np.testing.assert_allclose(c.gains["small"].l_slope, [2.0, 2.0])


def test_example_campaign_parses():
    c = mc.load_campaign("examples/campaign.toml")
    assert c.runs == 10000 and set(c.gains) == {"theorem", "slope", "constant"}


@pytest.mark.parametrize(
    ("text", "match"),
    [
        ("[campaign]\nruns = \n", r"invalid TOML: .*line 2, column 8"),
        (GOOD.replace("seed = 7", "seeds = 7"), r"unknown key\(s\) \['seeds'\] in \[campaign\]"),
        (GOOD.replace("runs = 3", "runs = 0"), r"\[campaign\]: runs = 0 is out of range \[1, inf\)"),
        (GOOD.replace("runs = 3", "runs = 2.5"), r"\[campaign\]: runs must be an integer; got 2.5"),
        (GOOD.replace("horizon = 0.5", 'horizon = "long"'), r"horizon must be a number; got 'long'"),
        (GOOD.replace("rtol", "x") + "\n[campaign2]\n", r"unknown section\(s\) \['campaign2'\]"),
        (GOOD.replace("omega_max = 3.0", "omega_max = -1.0"), r"\[body\]: omega_max = -1.0 is out of range"),
        (GOOD.replace("omega_max = 3.0", "J = [1.0, -2.0, 1.0]\nomega_max = 3.0"), r"J = \[1.0, -2.0, 1.0\]"),
        (GOOD.replace('kind = "theorem"', 'kind = "magic"'), r"\[gains.theorem\]: kind must be one of"),
        (GOOD.replace("l_slope = 2.0", "l_slop = 2.0"), r"\[gains.small\]: unknown key\(s\) \['l_slop'\]"),
        (GOOD.replace("l_offset = 5.0", "l_offset = -5.0"), r"\[gains.small\]: l must be positive"),
        (GOOD.replace("omega_max = 3.0", ""), r"omega_max is required"),
        (GOOD + "\n[torque]\nfrequency = [2.0, 1.0]\n", r"frequency must be \[low, high\].*got \[2.0, 1.0\]"),
        (GOOD + "\n[initial]\np_zero = 0.7\np_opposite = 0.5\n", r"p_zero \+ p_opposite must not exceed 1"),
        (GOOD + "\n[initial]\np_zero = 1.5\n", r"\[initial\]: p_zero = 1.5 is out of range \[0, 1\]"),
    ],
)
def test_toml_errors_name_key_and_value(text, match):
    with pytest.raises(ValueError, match=match):
        mc.campaign_from_toml(text)


def test_campaign_constructor_checks_values():
    with pytest.raises(ValueError, match=r"Campaign: runs = -1 is out of range"):
        _small(runs=-1)
    with pytest.raises(ValueError, match=r"gains\['x'\] are for 3 directions, the campaign has 2"):
        _small(gains={"x": ObserverGains.constant(1.0, 1.0, n=3)})


def test_command_writes_summary_and_figures(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(GOOD)
    out = tmp_path / "out"
    assert main(["montecarlo", str(cfg), "--out", str(out), "--no-progress"]) == 0
    for f in ("summary.json", "counterexamples.json", "envelopes.png", "rates.png"):
        assert (out / f).stat().st_size > 0
    summary = json.loads((out / "summary.json").read_text())
    c = mc.campaign_from_toml(GOOD)
    expected = mc.summarize(c, mc.run_campaign(c))
    for name in ("theorem", "small"):
        assert summary["gain_sets"][name]["worst_lambda"] == expected["gain_sets"][name]["worst_lambda"]
    assert json.loads((out / "counterexamples.json").read_text()).keys() == {"theorem", "small"}


@pytest.mark.parametrize("progress", [False, True])
@pytest.mark.parametrize("observers", [False, True])
def test_command_announces_a_compilation_and_reports_it_apart(observers, progress, tmp_path, capsys, monkeypatch):
    """A campaign's first run compiles the engine for its sizes (50 s for the example's, which the wheel does not
    ship): the notice when it starts, once, on a line of its own; the closing line's runs time without it, and the
    run's whole time with the compilation's share. The same for ``--observers``. A stand-in compilation of 30 s on a
    stand-in clock, fired as Numba fires its own."""
    from numba.core import event

    from omegahat.kernels import compiling
    from omegahat.lab.evaluation import uniformity

    ticks = iter([100.0, 130.0])
    monkeypatch.setattr(compiling, "clock", lambda: next(ticks, None) or time.perf_counter())
    monkeypatch.setattr(compiling, "NOTICE_DELAY", 0.0)
    owner, name = (uniformity, "run_uniformity") if observers else (mc, "run_campaign")
    real = getattr(owner, name)

    def compiling_first(*a, **kw):
        with event.trigger_event("numba:compile", data={"dispatcher": None, "args": (), "return_type": None}):
            pass
        return real(*a, **kw)

    monkeypatch.setattr(owner, name, compiling_first)
    cfg = tmp_path / "c.toml"
    cfg.write_text(GOOD)
    extra = (["--observers", "sarras", "--runs", "1"] if observers else []) + ([] if progress else ["--no-progress"])
    assert main(["montecarlo", str(cfg), "--out", str(tmp_path / "out"), *extra]) == 0
    out, err = capsys.readouterr()
    # a line of its own: after the progress bar's where one is drawn, and no empty line before it where none is
    lines = err.splitlines()
    assert err.count(compiling.NOTICE) == 1 and compiling.NOTICE in lines
    if progress:
        assert f"\n{compiling.NOTICE}\n" in err
    else:
        assert "" not in lines[: lines.index(compiling.NOTICE)]
    whole, share = re.search(
        r"; (\d+\.\d) s in all, (\d+\.\d) s of it compiling the kernels \(once: later", out
    ).groups()
    assert float(share) >= 30.0 and float(whole) > 0.0
    if not observers:
        assert float(out.split(" runs in ")[1].split(" s")[0]) < 30.0  # the runs' own time


def test_command_reports_bad_config(tmp_path, capsys):
    cfg = tmp_path / "bad.toml"
    cfg.write_text("[campaign]\nruns = \n")
    assert main(["montecarlo", str(cfg), "--out", str(tmp_path / "o")]) == 2
    assert "line 2, column 8" in capsys.readouterr().err


def test_serial_loop_equals_parallel_batch():
    c = _small(runs=5)
    a = mc.run_chunk(c, 0, 5, parallel=True)
    b = mc.run_chunk(c, 0, 5, parallel=False)
    for name in c.gains:
        np.testing.assert_array_equal(a[name].rho, b[name].rho)
        np.testing.assert_array_equal(a[name].steps, b[name].steps)
