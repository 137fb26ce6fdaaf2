"""Gain sweeps: convergence time and Pareto front on hand-made data, measured trade-off against the linearised
design of omegahat.observer.tuning, and the recommendation's contract."""

import math

import numpy as np
import pytest

from omegahat.lab import gain_sweep as gs
from omegahat.observer import tuning
from omegahat.observer.gains import ObserverGains

J = np.diag([3.0, 2.0, 1.0])


def test_pareto_front_by_hand():
    times = [1.0, 2.0, 3.0, 2.0, 4.0, np.inf, 1.0]
    noise = [5.0, 3.0, 1.0, 4.0, 1.0, 0.1, 5.0]
    # (2, 4) is dominated by (2, 3); (4, 1) by (3, 1); the infinite time is excluded; the two equal points
    # (1, 5) do not dominate each other
    np.testing.assert_array_equal(gs.pareto_front(times, noise), [True, True, True, False, False, False, True])


def test_measured_trade_off_follows_the_linearised_design():
    """sensor_gains at bandwidth b makes every linearised mode decay at least at ω_b = 2πb, so the error falls
    to 1 % within ln(100)/ω_b (plus a sample); the measured noise matches tuning.predicted_noise_std (a discrete
    Lyapunov solution, an independent computation) within 10 %; a larger bandwidth converges faster and is
    noisier."""
    rate, sigma = 100.0, 2e-3
    evs = []
    for b in (0.5, 2.0):
        g = tuning.sensor_gains(J, rate, sigma, bandwidth_hz=b)
        ev = gs.evaluate_gains(J, g, rate, sigma, seed=3, horizon=6.0)
        assert ev.convergence_time <= math.log(100) / (2 * math.pi * b) + 1 / rate
        assert ev.noise_rms == pytest.approx(ev.predicted_noise_rms, rel=0.1)
        evs.append(ev)
    assert evs[1].convergence_time < evs[0].convergence_time
    assert evs[1].noise_rms > evs[0].noise_rms


def test_sweep_uses_common_noise_per_sensor_and_covers_the_grid():
    evs = gs.sweep(J, [5.0, 20.0], [50.0], [50.0], [1e-3, 5e-3], seed=2, horizon=3.0)
    assert len(evs) == 4
    assert {(e.rate_hz, e.measurement_noise) for e in evs} == {(50.0, 1e-3), (50.0, 5e-3)}
    # common random numbers: re-evaluating one point with its (rate, noise) seed gives the same number
    again = gs.evaluate_gains(
        J,
        ObserverGains.constant(20.0, 50.0, n=3),
        50.0,
        5e-3,
        seed=np.random.SeedSequence(2, spawn_key=(0, 1)),
        horizon=3.0,
    )
    point = next(e for e in evs if e.measurement_noise == 5e-3 and e.gains.k[0] == 20.0)
    assert again.noise_rms == point.noise_rms
    # noise scales with σ for the same gains (linear filter of the same noise shape)
    low = next(e for e in evs if e.measurement_noise == 1e-3 and e.gains.k[0] == 20.0)
    assert point.noise_rms / low.noise_rms == pytest.approx(5.0, rel=0.25)


def test_recommendation_meets_its_goal_and_is_the_best_candidate():
    bws = [0.3, 1.0, 3.0, 10.0]
    rec = gs.recommend_gains(J, 100.0, 1e-3, max_noise=0.02, bandwidths_hz=bws, horizon=4.0)
    assert rec.noise_rms <= 0.02
    meeting = [ev for _, ev in rec.candidates if ev.noise_rms <= 0.02]
    assert rec.convergence_time == min(ev.convergence_time for ev in meeting)
    np.testing.assert_allclose(rec.gains.k, tuning.sensor_gains(J, 100.0, 1e-3, bandwidth_hz=rec.bandwidth_hz).k)
    fast = gs.recommend_gains(J, 100.0, 1e-3, max_convergence_time=1.0, bandwidths_hz=bws, horizon=4.0)
    assert fast.convergence_time <= 1.0
    assert fast.noise_rms == min(ev.noise_rms for _, ev in fast.candidates if ev.convergence_time <= 1.0)


def test_recommendation_errors_are_named():
    with pytest.raises(ValueError, match="give exactly one of max_noise or max_convergence_time"):
        gs.recommend_gains(J, 100.0, 1e-3)
    with pytest.raises(ValueError, match="no candidate meets max_noise = 1e-06 rad/s; the least noisy gives"):
        gs.recommend_gains(J, 100.0, 1e-3, max_noise=1e-6, bandwidths_hz=[1.0], horizon=2.0)
    with pytest.raises(ValueError, match=r"no candidate meets max_convergence_time = 0\.001 s"):
        gs.recommend_gains(J, 100.0, 1e-3, max_convergence_time=1e-3, bandwidths_hz=[1.0], horizon=2.0)
    with pytest.raises(ValueError, match="measurement_noise must be non-negative and finite; got -1"):
        gs.evaluate_gains(J, ObserverGains.constant(1.0, 1.0, n=3), 10.0, -1)
    with pytest.raises(ValueError, match=r"settle must be in \(0, 1\); got 2"):
        gs.evaluate_gains(J, ObserverGains.constant(1.0, 1.0, n=3), 10.0, 0.0, settle=2)


def test_plot_pareto_returns_axes():
    import matplotlib

    matplotlib.use("Agg")
    evs = gs.sweep(J, [5.0, 20.0], [50.0], [50.0], [1e-3], horizon=2.0)
    ax = gs.plot_pareto(evs)
    assert ax.get_xscale() == "log" and len(ax.get_lines()) == 2
