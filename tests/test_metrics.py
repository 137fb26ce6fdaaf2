"""The one definition of the scores (omegahat.lab.evaluation.metrics) on hand-made errors: convergence time as the last
crossing, first time below, steady RMS; NaN = no estimate, inf = diverged, never = inf."""

import math

import numpy as np
import pytest

from omegahat.lab.evaluation.metrics import convergence_time, estimate_errors, first_below, steady_rms


def test_convergence_time_first_below_and_steady_rms_on_hand_made_errors():
    t = np.arange(10.0)
    err = np.array([5.0, 3.0, 0.5, 2.0, 0.5, 0.4, 0.3, np.nan, 0.2, 0.1])
    assert convergence_time(t, err, 1.0) == 4.0  # last excursion above 1 is at t = 3
    assert first_below(t, err, 1.0) == 2.0  # ... but it first dips below at t = 2
    assert first_below(t, err, 0.01) == math.inf
    assert convergence_time(t, err, 10.0) == 0.0
    assert convergence_time(t, np.full(10, 2.0), 1.0) == math.inf
    assert convergence_time(t, np.r_[np.full(9, 0.5), 2.0], 1.0) == math.inf  # ends above: never settled
    assert steady_rms(t, err, 8.0) == pytest.approx(np.sqrt((0.2**2 + 0.1**2) / 2))
    diverged = np.r_[err[:5], np.full(5, np.inf)]  # NaN = no estimate, inf = a method that diverged
    assert convergence_time(t, diverged, 1.0) == math.inf
    assert steady_rms(t, diverged, 8.0) == math.inf


def test_convergence_time_is_the_last_crossing():
    # (formerly observer.gain_sweep.convergence_time and cli.paper.settling_time)
    t = np.arange(6.0)
    assert convergence_time(t, [5, 0.5, 2, 0.5, 0.1, 0.1], 1.0) == 3.0  # dips at t=1, settles at t=3
    assert convergence_time(t, [0.5] * 6, 1.0) == 0.0
    assert convergence_time(t, [0.5, 0.5, 0.5, 0.5, 0.5, 2.0], 1.0) == math.inf
    assert convergence_time(t, [5, 2, 1e-2, 1e-4, 2e-3, 1e-5], 1e-3) == 5.0
    assert convergence_time(t, [5, 2, 1e-2, 1e-4, 1e-4, 1e-5], 1e-3) == 3.0
    assert convergence_time(t, [5, 2, 1e-2, 1e-4, 1e-3, 1e-5], 1e-3) == 3.0  # at the tolerance counts as below
    assert convergence_time(t, np.ones(6), 1e-3) == math.inf  # never: inf (the paper command printed NaN)
    # a sample without an estimate is left out; a diverged one (inf) is above any tolerance
    assert convergence_time(t, [0.5, np.nan, 0.5, 0.5, 0.5, 0.5], 1.0) == 0.0
    assert convergence_time(t, [0.5, np.inf, 0.5, 0.5, 0.5, 0.5], 1.0) == 2.0
    assert convergence_time(t, [0.5, 2.0, np.nan, 0.5, 0.5, np.nan], 1.0) == 3.0
    assert convergence_time(t, np.full(6, np.nan), 1.0) == math.inf
    assert math.isnan(steady_rms(t, np.full(6, np.nan), 0.0))


def test_estimate_errors_say_no_estimate_or_diverged():
    truth = np.zeros((4, 3))
    est = np.array([[3.0, 4.0, 0.0], [np.nan, 0.0, 0.0], [np.inf, 0.0, 0.0], [0.0, 0.0, 1.0]])
    np.testing.assert_array_equal(estimate_errors(est, truth), [5.0, np.nan, np.inf, 1.0])
    np.testing.assert_array_equal(estimate_errors(est, truth, always_estimates=True), [5.0, np.inf, np.inf, 1.0])
