"""Log-map differencing: order of accuracy on a closed-form trajectory, invariances, gaps, stream = batch."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.baselines.differencing import (
    DifferencingEstimator,
    log_difference,
    lowpass,
    lowpass_reference,
    whole_steps,
)
from omegahat.interface import Status

# Closed-form trajectory: R(t) = Exp(a t) Exp(b t), so RᵀṘ = (Exp(b t)ᵀ a)× + b×, i.e. ω(t) = Exp(−b t) a + b.
A = np.array([0.7, -0.3, 0.5])
B = np.array([0.2, 0.9, -0.4])


def attitude(t):
    t = np.atleast_1d(t)
    return (Rotation.from_rotvec(np.outer(t, A)) * Rotation.from_rotvec(np.outer(t, B))).as_matrix()


def omega(t):
    t = np.atleast_1d(t)
    return Rotation.from_rotvec(-np.outer(t, B)).apply(A) + B


def max_error(times, scheme, window=(0.5, 1.5)):
    est = log_difference(times, attitude(times), scheme)
    m = (times >= window[0]) & (times <= window[1])
    return np.abs(est[m] - omega(times[m])).max()


@pytest.mark.parametrize(("scheme", "order"), [("backward", 1.0), ("central", 2.0)])
def test_order_of_accuracy_uniform_steps(scheme, order):
    hs = np.array([0.02, 0.01, 0.005])
    errs = np.array([max_error(np.arange(0.0, 2.0 + h / 2, h), scheme) for h in hs])
    slopes = np.log(errs[:-1] / errs[1:]) / np.log(hs[:-1] / hs[1:])
    assert np.all(np.abs(slopes - order) < 0.1), (errs, slopes)


@pytest.mark.parametrize(("scheme", "order"), [("backward", 1.0), ("central", 2.0)])
def test_order_of_accuracy_variable_steps(scheme, order):
    rng = np.random.default_rng(1)
    jitter = rng.uniform(0.5, 1.5, size=4000)  # same relative pattern at every h
    errs = []
    hs = np.array([0.02, 0.01, 0.005])
    for h in hs:
        steps = h * jitter[: int(2.2 / h)]
        times = np.concatenate([[0.0], np.cumsum(steps)])
        errs.append(max_error(times, scheme))
    errs = np.array(errs)
    slopes = np.log(errs[:-1] / errs[1:]) / np.log(hs[:-1] / hs[1:])
    # The jitter pattern is not self-similar across h, so allow a little more spread than with uniform steps.
    assert np.all(np.abs(slopes - order) < 0.25), (errs, slopes)


def test_uniform_central_is_the_two_step_log_and_backward_is_scipy_rotvec():
    times = np.arange(0.0, 1.0, 0.05)
    R = attitude(times)
    rot = Rotation.from_matrix(R)
    back = log_difference(times, R, "backward")
    cen = log_difference(times, R, "central")
    ref_back = (rot[:-1].inv() * rot[1:]).as_rotvec() / 0.05
    ref_cen = (rot[:-2].inv() * rot[2:]).as_rotvec() / 0.1
    np.testing.assert_allclose(back[1:], ref_back, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(cen[1:-1], ref_cen, rtol=1e-9, atol=1e-12)
    assert np.all(np.isnan(back[0])) and np.all(np.isnan(cen[0])) and np.all(np.isnan(cen[-1]))


def test_constant_rate_is_exact():
    w = np.array([0.3, -1.2, 2.0])
    times = np.sort(np.random.default_rng(2).uniform(0, 3, 50))
    R = Rotation.from_rotvec(np.outer(times, w)).as_matrix()
    for scheme in ("backward", "central"):
        est = log_difference(times, R, scheme)
        ok = np.all(np.isfinite(est), axis=1)
        np.testing.assert_allclose(est[ok], np.broadcast_to(w, est[ok].shape), atol=1e-12)


def test_quaternion_sign_does_not_matter():
    times = np.arange(0.0, 2.0, 0.01)
    q = Rotation.from_matrix(attitude(times)).as_quat()
    flips = np.where(np.random.default_rng(3).random(times.size) < 0.5, -1.0, 1.0)
    for scheme in ("backward", "central"):
        ref = log_difference(times, attitude(times), scheme)
        got = log_difference(times, q * flips[:, None], scheme)
        np.testing.assert_allclose(got, ref, atol=1e-12)
        got_sf = log_difference(times, np.roll(q * flips[:, None], 1, axis=1), scheme, scalar_first=True)
        np.testing.assert_allclose(got_sf, ref, atol=1e-12)


def test_nan_samples_are_skipped_and_bridged():
    times = np.arange(0.0, 1.0, 0.05)
    R = attitude(times)
    R[7] = np.nan
    R[8, 0, 1] = np.inf
    est = log_difference(times, R, "backward")
    rot = Rotation.from_matrix(attitude(times))
    bridge = (rot[6].inv() * rot[9]).as_rotvec() / (times[9] - times[6])
    np.testing.assert_allclose(est[9], bridge, atol=1e-12)
    np.testing.assert_array_equal(est[7], est[6])  # held
    np.testing.assert_array_equal(est[8], est[6])
    cen = log_difference(times, R, "central")
    # Central at sample 6 uses samples 5 and 9 (unequal steps): second order, so closer to the truth than the
    # first-order backward estimate at the same sample.
    assert np.all(np.isfinite(cen[6]))
    assert np.abs(cen[6] - omega(times[6])[0]).max() < np.abs(est[6] - omega(times[6])[0]).max()


def test_noise_level_matches_the_stated_formulas():
    # Constant attitude, i.i.d. small rotation-vector noise σ per axis: backward ≈ √2σ/h, central ≈ σ/(√2 h).
    sigma, h, n = 1e-4, 0.01, 40000
    noise = np.random.default_rng(4).normal(0, sigma, (n, 3))
    times = h * np.arange(n)
    R = Rotation.from_rotvec(noise).as_matrix()
    back = log_difference(times, R, "backward")[1:]
    cen = log_difference(times, R, "central")[1:-1]
    np.testing.assert_allclose(back.std(axis=0), np.sqrt(2) * sigma / h, rtol=0.03)
    np.testing.assert_allclose(cen.std(axis=0), sigma / (np.sqrt(2) * h), rtol=0.03)


def test_lowpass_kernel_equals_the_plain_loop_and_the_step_response():
    rng = np.random.default_rng(5)
    times = np.cumsum(rng.uniform(0.001, 0.02, 500))
    x = rng.normal(size=(500, 3))
    x[[10, 11, 300]] = np.nan
    np.testing.assert_allclose(lowpass(x, times, 3.0), lowpass_reference(x, times, 3.0), rtol=1e-13, atol=1e-14)
    # Input 0 at times[0] then 1: y(t) = 1 − exp(−2π f_c (t − times[0])) (the ZOH discretisation is exact).
    step = np.ones((500, 3))
    step[0] = 0.0
    y = lowpass(step, times, 3.0)
    ref = 1.0 - np.exp(-2 * np.pi * 3.0 * (times[1:] - times[0]))
    np.testing.assert_allclose(y[1:, 0], ref, rtol=1e-12)


@pytest.mark.parametrize("scheme", ["backward", "central"])
@pytest.mark.parametrize("cutoff", [None, 4.0])
def test_stream_equals_batch(scheme, cutoff):
    rng = np.random.default_rng(6)
    times = np.cumsum(rng.uniform(0.005, 0.015, 200))
    R = attitude(times)
    R[[20, 21, 150]] = np.nan
    est = DifferencingEstimator(scheme=scheme, cutoff_hz=cutoff)
    batch, status = est.run(times, R)
    stream_est = DifferencingEstimator(scheme=scheme, cutoff_hz=cutoff)
    stream = np.array([stream_est.update(t, Rk).omega for t, Rk in zip(times, R, strict=True)])
    valid = np.flatnonzero(np.all(np.isfinite(R), axis=(1, 2)))
    d = stream_est.delay_samples
    # The estimate for valid sample valid[j] is returned by update at valid[j + d].
    np.testing.assert_allclose(stream[valid[d:]], batch[valid[: valid.size - d]], rtol=1e-12, atol=1e-12)
    assert stream_est.n_skipped == 3 and est.n_skipped == 3
    # run leaves the streaming state where update leaves it: the next update agrees.
    t_next = times[-1] + 0.01
    R_next = attitude(t_next)[0]
    np.testing.assert_allclose(est.update(t_next, R_next).omega, stream_est.update(t_next, R_next).omega, rtol=1e-12)
    assert np.all(status[[20, 21]] == Status.PREDICTED)  # the last estimate held through the skipped samples
    assert est.estimate_time == stream_est.estimate_time == (t_next if scheme == "backward" else times[-1])
    assert est.causal == (scheme == "backward")


def test_lowpass_reduces_noise_on_constant_rate():
    w = np.array([0.2, 0.1, -0.3])
    h = 0.01
    times = h * np.arange(3000)
    noise = np.random.default_rng(7).normal(0, 1e-4, (times.size, 3))
    R = (Rotation.from_rotvec(np.outer(times, w)) * Rotation.from_rotvec(noise)).as_matrix()
    raw = DifferencingEstimator(scheme="backward").run(times, R).omega
    filt = DifferencingEstimator(scheme="backward", cutoff_hz=2.0).run(times, R).omega
    # A 2 Hz first-order filter on 100 Hz differences: far less noise, no bias at constant rate.
    assert (filt[500:] - w).std() < 0.3 * (raw[500:] - w).std()
    np.testing.assert_allclose(filt[500:].mean(axis=0), w, atol=3e-4)


def test_errors_name_the_problem_and_keep_the_state():
    with pytest.raises(ValueError, match="scheme must be one of"):
        DifferencingEstimator(scheme="forward")
    with pytest.raises(ValueError, match="cutoff_hz must be a positive finite"):
        DifferencingEstimator(cutoff_hz=-1.0)
    with pytest.raises(ValueError, match=r"sample 2: time t = 1.0 is not after the previous sample's t = 1.0"):
        log_difference([0.0, 1.0, 1.0], attitude(np.array([0.0, 1.0, 2.0])))
    with pytest.raises(ValueError, match=r"shape \(T, 3, 3\) or \(T, 4\) with T = 2 samples; got shape \(3, 3, 3\)"):
        log_difference([0.0, 1.0], attitude(np.array([0.0, 1.0, 2.0])))
    bad = attitude(np.array([0.0, 1.0, 2.0]))
    bad[1] *= 1.1
    with pytest.raises(ValueError, match=r"sample 1 \(t = 1.0\): not a rotation matrix: \|R\^T R - I\| = 0.364"):
        log_difference([0.0, 1.0, 2.0], bad)
    with pytest.raises(ValueError, match=r"sample 0 \(t = 0.0\): a quaternion far from unit norm: \|q\| = 2,"):
        log_difference([0.0, 1.0], [[0.0, 0.0, 0.0, 2.0], [0.0, 0.0, 0.0, 1.0]])
    with pytest.raises(ValueError, match=r"measurements must have shape \(T, 3, 3\) or \(T, 4\)"):
        log_difference([0.0, 1.0], np.zeros((2, 3)))
    with pytest.raises(ValueError, match=r"rotation_tol must be positive and finite; got \[-1\.\]"):
        DifferencingEstimator(rotation_tol=-1.0)

    est = DifferencingEstimator(scheme="backward")
    assert est.update(0.0, attitude(0.0)[0]).status == Status.UNAVAILABLE  # one attitude gives no rate
    before, status = est.update(0.1, attitude(0.1)[0])
    assert status == Status.CORRECTED
    with pytest.raises(ValueError, match=r"a quaternion \(4,\) or a Rotation; got shape \(3,\)"):
        est.update(0.2, np.zeros(3))
    with pytest.raises(ValueError, match=r"the sample \(t = 0.2\): a quaternion far from unit norm: \|q\| = 0.707107"):
        est.update(0.2, [0.0, 0.0, 0.5, 0.5])
    with pytest.raises(ValueError, match=r"the sample: time t = 0.1 is not after the previous sample's t = 0.1"):
        est.update(0.1, attitude(0.1)[0])
    with pytest.raises(ValueError, match="the sample: time t = nan is not finite"):
        est.update(np.nan, attitude(0.2)[0])
    # The rejected samples changed nothing: the next estimate is the plain difference from the sample at 0.1.
    got = est.update(0.2, attitude(0.2)[0]).omega
    ref = Rotation.from_matrix(attitude(0.1)[0].T @ attitude(0.2)[0]).as_rotvec() / 0.1
    np.testing.assert_allclose(got, ref, atol=1e-12)
    assert np.all(np.isfinite(before))


def test_jittered_stamps_of_regular_samples_are_read_as_whole_steps():
    """(D3): regular 100 Hz samples of a closed-form turn, one dropped, stamped up to ±20 % of the step off: given
    the samples' step, both schemes equal differencing at the true times (streaming and batch alike), where
    differencing the stamps as they are errs by more than a rad/s."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 5.0, 0.01)
    theta = 0.5 * np.sin(2 * np.pi * 0.7 * t) + 0.3 * t**2
    R = Rotation.from_rotvec(np.outer(theta, [0.6, 0.0, 0.8])).as_matrix()
    keep = np.ones(t.size, dtype=bool)
    keep[100] = False  # a dropped sample: an interval of two steps
    t, R = t[keep], R[keep]
    stamps = t + rng.uniform(-0.2, 0.2, t.size) * 0.01
    for scheme in ("backward", "central"):
        truth = log_difference(t, R, scheme=scheme)
        batch = DifferencingEstimator(scheme=scheme, step=0.01).run(stamps, R).omega
        est = DifferencingEstimator(scheme=scheme, step=0.01)
        fed = np.array([est.update(stamps[k], R[k]).omega for k in range(t.size)])
        if scheme == "central":  # update answers for the previous sample
            fed = np.vstack([fed[1:], np.full((1, 3), np.nan)])
        np.testing.assert_allclose(batch, truth, atol=1e-11)
        np.testing.assert_allclose(fed, truth, atol=1e-11)
        assert np.nanmax(np.abs(log_difference(stamps, R, scheme=scheme) - truth)) > 1.0
    with pytest.raises(ValueError, match="step must be positive"):
        DifferencingEstimator(step=0.0)


def test_whole_steps_of_one_interval_are_those_of_an_array():
    """(D3) has two forms, a float for one streaming step and an array for a log: they agree, halves included (both
    round half to even), and never read less than one step."""
    intervals = [0.001, 0.004, 0.005, 0.006, 0.01, 0.015, 0.025, 0.0349, 0.035, 1.0]
    as_array = whole_steps(np.array(intervals), 0.01)
    one_by_one = [whole_steps(x, 0.01) for x in intervals]
    assert all(isinstance(x, float) for x in one_by_one)
    np.testing.assert_array_equal(one_by_one, as_array)
    assert min(one_by_one) == 0.01


@pytest.mark.parametrize("options", [{}, {"cutoff_hz": 3.0}, {"taps": [0.6, 0.3, 0.1], "cutoff_hz": 3.0}])
def test_no_difference_across_half_a_turn_of_the_last_rate(options):
    """(D6): a body at a constant 0.06 rad/s seen every 0.5 s, unseen for 940 s (56 rad, aliased: the difference
    across is 0.0015 rad/s) and then for 20 s (1.2 rad, no alias): the row after the long outage holds the last
    rate, ``predicted``, and the next rows are the body's; the short outage is differenced. ``update``, ``run`` and
    ``run`` in pieces (one cut just before the held row, one just after) give the same rows and statuses."""
    w = np.array([0.03, -0.02, 0.05])
    t = np.concatenate([0.5 * np.arange(120), 1000.0 + 0.5 * np.arange(60), 1050.0 + 0.5 * np.arange(60)])
    q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    aliased = (Rotation.from_quat(q[119]).inv() * Rotation.from_quat(q[120])).as_rotvec() / 940.5
    assert np.linalg.norm(aliased) < 0.03 * np.linalg.norm(w)  # what differencing across would give
    whole = DifferencingEstimator(**options).run(t, q)
    streamed = DifferencingEstimator(**options)
    one_by_one = [streamed.update(tk, qk) for tk, qk in zip(t, q, strict=True)]
    pieced = DifferencingEstimator(**options)
    pieces = [pieced.run(t[a:b], q[a:b]) for a, b in ((0, 119), (119, 120), (120, 125), (125, 240))]
    for rows, status in (
        (whole.omega, whole.status),
        (np.array([e.omega for e in one_by_one]), [e.status for e in one_by_one]),
        (np.vstack([p.omega for p in pieces]), np.concatenate([p.status for p in pieces])),
    ):
        np.testing.assert_allclose(rows[1:], np.tile(w, (239, 1)), atol=1e-9)
        assert np.flatnonzero(np.asarray(status) == Status.PREDICTED).tolist() == [120]
    plain = log_difference(t, q)  # the formula itself, as peers compute it
    np.testing.assert_allclose(plain[120], aliased, atol=1e-12)
