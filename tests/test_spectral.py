"""The log's own Wiener smoother (omegahat.identification.spectral): exact where the motion is band-limited and
noise-free, far below differencing and the spline under noise, its gain test against SciPy's χ² quantile, a skipped
sample bridged by SciPy's rotation spline. References: closed forms and SciPy."""

import numpy as np
import pytest
from scipy import signal, stats
from scipy.spatial.transform import Rotation, RotationSpline, Slerp

from omegahat.baselines.differencing import log_difference
from omegahat.identification.fold import fold_remark, folded, rate_spectra
from omegahat.identification.spectral import (
    HANN_HALF_OVERLAP,
    SIGNIFICANCE,
    SpectralSmoother,
    expected_error,
    increment_spectrum,
    top_noise,
    welch_density,
    welch_segment,
    welch_segments,
    wiener_filter,
    wiener_gain,
)
from omegahat.identification.steps import bridged, stretches
from omegahat.interface import Status

H = 0.01
AXIS = np.array([1.0, 2.0, 2.0]) / 3.0
WAVES = ((0.8, 0.3, 0.1), (0.4, 1.1, 0.7), (0.2, 2.3, 1.9))  # amplitude rad, frequency Hz, phase rad


def turning(seconds: float = 30.0):
    """A body turning about a fixed axis by ``θ(t) = Σ a sin(2π f t + p)``: the attitudes and the rate ``θ'(t)``
    (closed form; up to 2.7 rad/s and 52 rad/s²)."""
    t = np.arange(0.0, seconds, H)
    theta = sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in WAVES)
    rate = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * t + p) for a, f, p in WAVES)
    return t, Rotation.from_rotvec(np.outer(theta, AXIS)), np.outer(rate, AXIS)


def rms(e):
    return float(np.sqrt(np.mean(np.sum(np.asarray(e) ** 2, axis=1))))


def noisy(R: Rotation, sigma: float, seed: int = 1) -> Rotation:
    return R * Rotation.from_rotvec(sigma * np.random.default_rng(seed).standard_normal((len(R), 3)))


def test_a_noise_free_band_limited_motion_is_recovered():
    """(S2) inverts the interval mean exactly on a band-limited motion: 1e-5 rad/s of a 2.7 rad/s turn inside the
    log, 1e-2 at its ends (where the reflection (S4) stands in for the unseen motion); measured 1.1e-7 and 3.0e-3
    (1.4e-6 and 3.5e-3 before the noise bound (N3), whose noise-free log's σ_q is the motion's fifth difference).
    Before the extension was brought to zero along a raised cosine (and F·sinc interpolated in place of F), the
    FFT's zero padding made a jump that rang through the filter's edge near the Nyquist frequency: 3.9e-4 and 0.052."""
    t, R, rate = turning()
    omega = SpectralSmoother().run(t, R.as_quat()).omega
    inner = slice(100, -100)
    assert rms(omega[inner] - rate[inner]) < 1e-5
    assert np.max(np.linalg.norm(omega - rate, axis=1)) < 1e-2


def test_under_noise_it_beats_central_differencing_and_the_spline():
    t, R, rate = turning()
    R = noisy(R, 1e-3)
    omega = SpectralSmoother().run(t, R.as_quat()).omega
    central = log_difference(t, R.as_matrix(), scheme="central")
    spline = RotationSpline(t, R)(t, 1)
    inner = slice(100, -100)
    best = min(rms(central[inner] - rate[inner]), rms(spline[inner] - rate[inner]))
    assert rms(omega[inner] - rate[inner]) < 0.5 * best
    assert rms(omega - rate) < 0.5 * best  # the ends included


def test_a_constant_rate_under_white_noise_is_below_a_third_of_differencings_noise():
    """Central differencing's noise is ``σ √3 / (h √2)`` rad/s (three axes, two samples σ apart over 2h); the
    smoother keeps only the frequencies where motion shows (S3): here the constant alone, and its false alarms."""
    t = np.arange(0.0, 20.0, H)
    w = np.array([0.3, -0.2, 0.5])
    R = noisy(Rotation.from_rotvec(np.outer(t, w)), 1e-3, seed=3)
    est = SpectralSmoother()
    omega = est.run(t, R.as_matrix()).omega
    assert rms(omega - w) < np.sqrt(3) * 1e-3 / (H * np.sqrt(2)) / 3
    assert est.measurement_noise == pytest.approx(1e-3, rel=0.2)


def test_the_gain_is_the_wiener_gain_where_the_motion_is_significant():
    freq = np.linspace(0.0, 0.5, 129)
    sigma, h = 1e-3, 0.01
    N_b = 8 * sigma**2 * np.sin(np.pi * freq) ** 2 / h**2  # (S1), one-sided, written out again
    for segments in (3, 30, 3000):
        dof = 2 * segments / (1 + 2 * HANN_HALF_OVERLAP**2)
        threshold = stats.chi2.ppf(SIGNIFICANCE, dof) / dof
        for ratio in (0.5, 1.0, 0.99 * threshold, 1.01 * threshold, 10.0):
            g = wiener_gain(freq, np.tile(ratio * N_b[:, None], (1, 3)), sigma, h, segments)
            expected = 1 - 1 / ratio if ratio > threshold else 0.0
            np.testing.assert_allclose(g[1:], expected, atol=1e-12)
    g = wiener_gain(freq, np.zeros((freq.size, 3)), sigma, h, 30)  # no power at all: nothing passes
    assert np.all(g == 0.0)


def test_a_single_skipped_sample_is_bridged_and_filtered():
    """(S9): a single missing sample is put on the geodesic between its neighbours (SciPy's ``Slerp`` at its time)
    for the spectrum and the filter: its stretch is not cut, its rate is the filter's (as accurate as its
    neighbours'), and its status stays ``predicted``."""
    t, R, rate = turning(10.0)
    q = noisy(R, 1e-4).as_quat()
    q[500] = np.nan
    keep = np.all(np.isfinite(q), axis=1)
    off = t.copy()
    off[500] += 0.3 * H  # off the middle: the geodesic's fraction is the sample's own time
    filled, used = bridged(off, Rotation.from_quat(np.where(keep[:, None], q, [0, 0, 0, 1])).as_matrix(), keep)
    slerp = Slerp(off[[499, 501]], Rotation.from_quat(q[[499, 501]]))(off[500]).as_matrix()
    np.testing.assert_allclose(filled[500], slerp, atol=1e-12)
    assert used.all() and not keep[500]
    est = SpectralSmoother()
    out = est.run(t, q)
    assert out.status[500] == Status.PREDICTED and est.n_skipped == 1 and est.n_unfiltered == 0
    assert np.all(out.status[keep] == Status.CORRECTED)
    assert np.linalg.norm(out.omega[500] - rate[500]) < 3.0 * rms(out.omega[100:900] - rate[100:900])


def test_two_skipped_samples_are_a_gap_bridged_by_the_rotation_spline():
    t, R, rate = turning(10.0)
    q = noisy(R, 1e-4).as_quat()
    q[500:502] = np.nan
    est = SpectralSmoother()
    out = est.run(t, q)
    keep = np.all(np.isfinite(q), axis=1)
    bridge = RotationSpline(t[keep], Rotation.from_quat(q[keep]))(t[500:502], 1)
    np.testing.assert_allclose(out.omega[500:502], bridge, atol=1e-12)
    assert np.all(out.status[500:502] == Status.PREDICTED) and est.n_skipped == 2
    assert np.all(out.status[keep] == Status.CORRECTED)
    inner = np.r_[100:450, 550:900]
    assert rms(out.omega[inner] - rate[inner]) < 0.05  # both stretches filtered


def test_a_log_too_short_to_filter_is_the_rotation_spline():
    t, R, _ = turning(0.1)  # 10 samples
    np.testing.assert_allclose(SpectralSmoother().run(t, R).omega, RotationSpline(t, R)(t, 1), atol=1e-12)


def test_an_irregularly_sampled_log_takes_the_spline_and_says_so():
    """Every step more than 5 % off the median: no stretch to filter, so every sample takes SciPy's rotation spline
    and ``n_unfiltered`` counts them (the command's closing line reports it)."""
    rng = np.random.default_rng(5)
    t = np.cumsum(H * (1.0 + rng.choice([-0.2, 0.2], 400)))
    R = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5]))
    est = SpectralSmoother()
    omega = est.run(t, R.as_quat()).omega
    np.testing.assert_allclose(omega, RotationSpline(t, R)(t, 1), atol=1e-12)
    assert est.n_unfiltered == t.size


def turning_at(times: np.ndarray):
    """:func:`turning`'s attitudes and rate at any ``times`` (closed form)."""
    theta = sum(a * np.sin(2 * np.pi * f * times + p) for a, f, p in WAVES)
    rate = sum(a * 2 * np.pi * f * np.cos(2 * np.pi * f * times + p) for a, f, p in WAVES)
    return Rotation.from_rotvec(np.outer(theta, AXIS)), np.outer(rate, AXIS)


def test_jittered_stamps_of_regular_samples_are_read_as_such():
    """(S8): regular samples (1 mrad of noise) whose stamps jitter by up to 20 % of the step: the increments over
    the mean step vary less than over each stamped step, so the stamps are read as jittered and the stretch filtered
    with its mean step; the error against the rate at the true times is within 20 % of the error with exact stamps,
    and below half of SciPy's spline through the stamps."""
    t, R, rate = turning()
    R = noisy(R, 1e-3)
    stamps = t + np.random.default_rng(7).uniform(-0.2, 0.2, t.size) * H
    est = SpectralSmoother()
    omega = est.run(stamps, R.as_quat()).omega
    assert est.timestamps == "stamps" and est.n_unfiltered == 0
    inner = slice(100, -100)
    exact = SpectralSmoother().run(t, R.as_quat()).omega
    assert rms(omega[inner] - rate[inner]) < 1.2 * rms(exact[inner] - rate[inner])
    spline = RotationSpline(stamps, R)(stamps, 1)
    assert rms(omega[inner] - rate[inner]) < 0.5 * rms(spline[inner] - rate[inner])


def test_samples_taken_where_their_stamps_say_are_read_as_such():
    """(S8): samples taken at jittered times (the stamps true): the increments over each step vary less, so each
    step is used as stamped. Jitter within 5 %: filtered, below half of the spline's error; up to 20 %: the steps
    5 % or more off the median take SciPy's spline, exactly."""
    t, _, _ = turning()
    times = t + np.random.default_rng(8).uniform(-0.02, 0.02, t.size) * H
    R, rate = turning_at(times)
    R = noisy(R, 1e-3)
    est = SpectralSmoother()
    omega = est.run(times, R.as_quat()).omega
    assert est.timestamps == "sampling" and est.n_unfiltered == 0
    inner = slice(100, -100)
    spline = RotationSpline(times, R)(times, 1)
    assert rms(omega[inner] - rate[inner]) < 0.5 * rms(spline[inner] - rate[inner])
    times = np.cumsum(H * (1.0 + np.random.default_rng(9).choice([-0.2, 0.2], 400)))
    R, _ = turning_at(times)
    est = SpectralSmoother()
    omega = est.run(times, R.as_quat()).omega
    assert est.timestamps == "sampling" and est.n_unfiltered == times.size
    np.testing.assert_allclose(omega, RotationSpline(times, R)(times, 1), atol=1e-12)


def swinging_hinge(times: np.ndarray):
    """A hinge swinging at 0.47 Hz, its rate a rounded square wave ``3 tanh(4 sin(2π 0.47 t))`` rad/s about z: the
    rate at ``times`` (closed form) and the attitudes (the angle by the trapezoid rule on a 0.5 ms grid)."""
    rate = lambda s: 3.0 * np.tanh(4.0 * np.sin(2 * np.pi * 0.47 * s))  # noqa: E731
    fine = np.linspace(0.0, times.max() + 1.0, int((times.max() + 1.0) * 2000) + 1)
    w = rate(fine)
    angle = np.concatenate([[0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(fine))])
    return Rotation.from_rotvec(np.outer(np.interp(times, fine, angle), [0.0, 0.0, 1.0])), np.outer(
        rate(times), [0.0, 0.0, 1.0]
    )


def test_the_filter_runs_through_an_uneven_step_that_ends_a_stretch():
    """(S8'): 10 Hz samples taken at their stamps, one frame in 400 taken 10 ms late (its two steps 10 % off the
    median: they end the stretches kept, and that frame takes the spline). The stretches' ends are filtered with the
    increments beyond the late frame: the error is below the rotation spline's (with each stretch's ends extended
    by (S4) instead, it was 2.7 times the spline's)."""
    t = np.arange(3000) * 0.1
    late = np.arange(150, 2850, 400)
    t[late] += 0.01
    R, rate = swinging_hinge(t)
    R = noisy(R, 2e-3, seed=3)
    est = SpectralSmoother()
    omega = est.run(t, R.as_quat()).omega
    assert est.timestamps == "sampling" and est.n_unfiltered == late.size
    inner = slice(50, -50)
    spline = RotationSpline(t, R)(t, 1)
    assert rms(omega[inner] - rate[inner]) < 0.85 * rms(spline[inner] - rate[inner])
    np.testing.assert_allclose(omega[late], spline[late], atol=1e-12)  # the late frames themselves: the spline


def test_a_body_at_rest_gets_a_zero_rate():
    t = np.arange(0.0, 10.0, H)
    q = np.tile(Rotation.from_rotvec([0.4, -1.0, 2.0]).as_quat(), (t.size, 1))
    est = SpectralSmoother()
    np.testing.assert_allclose(est.run(t, q).omega, 0.0, atol=1e-12)
    assert est.n_unfiltered == 0


def test_the_stretches_end_at_skipped_samples_and_irregular_steps():
    t = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.5, 6.5, 7.5, 8.5, 9.5])  # one step of 1.5
    valid = np.array([True, True, False, True, True, True, True, False, False, True])
    assert stretches(t, valid) == [(0, 2), (3, 5), (5, 7), (9, 10)]
    assert stretches(t, np.zeros(10, dtype=bool)) == []


def test_the_fold_is_bounded_from_the_spectrum_near_the_nyquist_frequency():
    """(S6) on written-out spectra: a rate spectrum ``S(ν) ∝ ν^−p`` sampled (``P_s = sinc²(f) S(f) + sinc²(1 − f)
    S(1 − f)``) gives a fold estimate between the true fold and twice it over the upper part of the band (the local
    decay read off the top of the band, where the fold flattens it: conservative), and never more than the
    frequency shows."""
    freq = np.linspace(0.0, 0.5, 129)
    upper = (freq >= 0.3) & (freq < 0.5)
    for p in (2.0, 4.0, 6.0):

        def S(nu, p=p):
            return 1e-2 * np.maximum(nu, 1e-3) ** -p

        P_s = np.sinc(freq) ** 2 * S(freq) + np.sinc(1 - freq) ** 2 * S(1 - freq)
        P_s[0] = 0.0
        fold = folded(freq, np.tile(P_s[:, None], (1, 3)))[:, 0]
        ratio = fold[upper] / S(1 - freq[upper])
        assert np.all(ratio >= 1.0) and np.all(ratio <= 2.0)
        with np.errstate(divide="ignore"):
            assert np.all(fold <= P_s / np.sinc(1 - freq) ** 2)


def test_the_filter_is_the_inverse_mean_without_a_fold_and_shrinks_with_one():
    """(S2) alone where nothing shows near the Nyquist frequency; with motion there, (S6) only lowers the response
    (towards zero, never below)."""
    h, freq = 0.01, np.linspace(0.0, 0.5, 129)
    N_b = 8 * np.sin(np.pi * freq) ** 2 / h**2 * 1e-6
    quiet_top = np.tile((N_b + 1e3 * np.exp(-freq / 0.02))[:, None], (1, 3))  # motion far below the Nyquist frequency
    g = wiener_gain(freq, quiet_top, 1e-3, h, 50)
    np.testing.assert_allclose(wiener_filter(freq, quiet_top, g, N_b[:, None]), g / np.sinc(freq)[:, None])
    busy_top = quiet_top + 50.0  # and motion up to the Nyquist frequency
    g = wiener_gain(freq, busy_top, 1e-3, h, 50)
    F = wiener_filter(freq, busy_top, g, N_b[:, None])
    assert np.all(F >= 0.0) and np.all(F <= g / np.sinc(freq)[:, None] + 1e-12)
    assert F[-2, 0] < 0.5 * g[-2, 0] / np.sinc(freq[-2])  # near the Nyquist frequency the fold halves it at least


def test_the_expected_error_is_the_error_within_a_factor_two():
    """(S7) against the error measured against the closed-form rate, inside the log (the ends are not in (S7))."""
    t, R, rate = turning()
    est = SpectralSmoother()
    omega = est.run(t, noisy(R, 1e-3).as_quat()).omega
    measured = rms(omega[100:-100] - rate[100:-100])
    assert 0.5 < est.expected_rms / measured < 2.0


def test_the_folds_part_of_the_expected_error_is_its_term_of_the_three():
    """(S7b) on written-out spectra. (S7)'s closed form is the sum of three errors of the filter ``F`` of (S6) on
    the rate in the band, on its fold and on the noise, ``S (sinc F − 1)² + S_a (sinc_a F + 1)² + N_b F²`` (where
    ``P_b = sinc² S + sinc_a² S_a + N_b``); the fold's part is the second: none where the motion stays far below the
    Nyquist frequency, most of the error where it reaches it."""
    h, freq = 0.01, np.linspace(0.0, 0.5, 129)
    N_b = np.tile((8 * np.sin(np.pi * freq) ** 2 / h**2 * 1e-6)[:, None], (1, 3))
    quiet_top = N_b + 1e3 * np.exp(-freq / 0.02)[:, None]
    for P_b, fold_share in ((quiet_top, (0.0, 1e-6)), (quiet_top + 50.0, (0.5, 1.0))):
        g = wiener_gain(freq, P_b, 1e-3, h, 50)
        S, S_a = rate_spectra(freq, P_b, g, N_b)
        F = wiener_filter(freq, P_b, g, N_b)
        sinc, sinc_a = np.sinc(freq)[:, None], np.sinc(1.0 - freq)[:, None]
        terms = [S * (sinc * F - 1) ** 2, S_a * (sinc_a * F + 1) ** 2, N_b * F**2]
        band, fold, noise = (np.sqrt(np.sum(x) * (freq[1] - freq[0])) for x in terms)
        total = expected_error(freq, P_b, g, N_b)
        assert total == pytest.approx(np.sqrt(band**2 + fold**2 + noise**2), rel=1e-9)
        assert expected_error(freq, P_b, g, N_b, fold_only=True) == pytest.approx(fold, rel=1e-12, abs=1e-15)
        assert fold_share[0] <= fold / total <= fold_share[1]


def test_the_command_names_the_folds_part_where_it_is_more_than_a_tenth():
    """``fold_remark``: nothing at a tenth or less (or without a figure), the part where it is more; the smoother
    keeps the part it expects, no more than the whole."""
    assert fold_remark(1.0, 0.1) == "" and fold_remark(1.0, float("nan")) == ""
    assert "0.5 of it from the rate above the Nyquist frequency" in fold_remark(1.0, 0.5)
    t, R, _ = turning()
    est = SpectralSmoother()
    est.run(t, noisy(R, 1e-3).as_quat())
    assert 0.0 <= est.fold_rms <= est.expected_rms


@pytest.mark.parametrize("rate", [10.0, 30.0])
def test_a_coning_motion_is_recovered_without_the_log_maps_bias(rate):
    """A noise-free coning motion ``R(t) = Rz(αt) Rx(β) Rz(γt)`` (body rate in closed form): differenced attitudes
    carry the coning term (M1), constant along the body's z here (5.3e-4 rad/s at 10 Hz, 5.8e-5 at 30 Hz). With
    (S1c) the smoother's mean error along z is below a tenth of the term (measured under 1e-6; without (S1c) it is
    the term) and its RMS error below a hundredth of the term's size (measured 5.1e-7 and 7.5e-9). Without the
    bound (N3) the noise taken was the motion's own higher differences and the filter cut real motion: 1.4e-4 and
    1.1e-5 with (N2) alone, 4.3e-4 and 2.7e-5 with (N1)."""
    alpha, beta, gamma = 1.3, 0.7, -0.9
    z = np.array([0.0, 0.0, 1.0])
    t = np.arange(0.0, 60.0, 1.0 / rate)
    R = (
        Rotation.from_rotvec(np.outer(alpha * t, z))
        * Rotation.from_rotvec([beta, 0, 0])
        * Rotation.from_rotvec(np.outer(gamma * t, z))
    )
    turn = (Rotation.from_rotvec(np.outer(gamma * t, z)).inv() * Rotation.from_rotvec([beta, 0, 0]).inv()).apply(z)
    truth = alpha * turn + gamma * z
    coning = np.linalg.norm(np.cross(truth[0], truth[1])) / (12.0 * rate)  # (M1)'s size, the same at every step
    omega = SpectralSmoother().run(t, R.as_quat()).omega
    inner = slice(t.size // 5, -t.size // 5)
    assert abs(np.mean(omega[inner, 2] - truth[inner, 2])) < 0.1 * coning
    assert rms(omega[inner] - truth[inner]) < 0.01 * coning


def test_the_bands_top_bounds_white_noise_at_95_percent():
    """(N3) is a one-sided 95 % upper bound on white attitude noise: over 200 logs of noise alone (2,000 samples, three
    axes) it falls below the true σ in about 5 % of the cases (measured 3.8 % on 300 with the 128-sample segments
    (S1') takes here, 3.6 % with 256; with the Nyquist frequency's bin, which Welch's one-sided estimate halves,
    9.9 %), and its mean square is σ² (the χ² mean, within 3 %)."""
    n, sigma = 2000, 1e-3
    t = np.arange(n) * H
    bounds = []
    for seed in range(200):
        R = Rotation.from_rotvec(sigma * np.random.default_rng(seed).standard_normal((n, 3))).as_matrix()
        spectrum = increment_spectrum(t, R, np.ones(n, dtype=bool))
        segments = spectrum.segments
        bounds.append(top_noise(spectrum.freq, spectrum.P_b, spectrum.h, segments))
    below = np.mean(np.asarray(bounds) < sigma)
    assert 0.01 < below < 0.08
    top = np.count_nonzero((spectrum.freq >= 0.45) & (spectrum.freq < 0.5))  # the top tenth's bins
    dof = 2.0 * segments / (1.0 + 2.0 * HANN_HALF_OVERLAP**2) * np.ceil(top / 2)  # every other one independent
    assert np.mean(np.asarray(bounds) ** 2) / (dof / stats.chi2.ppf(0.05, dof)) == pytest.approx(sigma**2, rel=0.03)


def test_a_noisy_log_keeps_the_quiet_parts_noise_and_a_noise_free_one_its_motion():
    """Where the noise shows, (N3) lies above σ_q and changes nothing; on the noise-free turn σ_q is the motion's
    fifth difference (3.3e-7 rad), which would cut the turn's fastest wave as noise, and (N3) allows 3.5e-8 at most.
    The turn is then recovered to 1.1e-7 rad/s inside the log (1.4e-6 with σ_q)."""
    t, R, rate = turning()
    est = SpectralSmoother()
    est.run(t, noisy(R, 1e-3).as_quat())
    assert est.measurement_noise == pytest.approx(1e-3, rel=0.1)
    omega = est.run(t, R.as_quat()).omega
    assert np.all(est.measurement_noise < 1e-7)
    assert rms(omega[100:-100] - rate[100:-100]) < 1e-6  # measured 1.1e-7; 1.4e-6 with σ_q


@pytest.mark.parametrize(
    ("lengths", "segment"),
    [([10_000], 256), ([3_584], 256), ([3_583], 128), ([2_000], 128), ([1_000], 64), ([300], 64), ([40], 40)],
)
def test_the_welch_segment_is_halved_until_27_segments_fit(lengths, segment):
    """(S1'): 256 samples where 27 half-overlapping segments fit ((n − 256)/128 + 1 ≥ 27 from n = 3,584), halved while
    they do not, down to 64; a stretch shorter than that is one segment of its own length."""
    assert welch_segment(lengths) == segment


def test_the_welch_segments_count_only_the_stretches_that_hold_one():
    assert welch_segment([3_000, 100, 100]) == 128  # 22 + 0 + 0 at 256; 45 at 128
    assert welch_segment([1_700, 1_700]) == 128  # 12 + 12 at 256; 25 + 25 at 128


@pytest.mark.parametrize(("n", "segment"), [(1_000, 256), (1_000, 255), (4_096, 512), (300, 64), (257, 256), (40, 40)])
def test_the_welch_density_is_scipys(n, segment):
    """The command's own Welch estimate (written to spare it the import of ``scipy.signal``) is SciPy's, for even
    and odd segments, with the mean of each segment removed; and it averages the segments ``welch_segments``
    counts (SciPy's too: a sum over one more or one fewer would scale the density)."""
    rng = np.random.default_rng(n + segment)
    x = rng.standard_normal((n, 3)) * [1.0, 0.1, 3.0] + np.linspace(0.0, 5.0, n)[:, None]
    freq, density = welch_density(x, segment)
    ref_freq, ref_density = signal.welch(x, nperseg=segment, axis=0, detrend="constant")
    np.testing.assert_array_equal(freq, ref_freq)
    np.testing.assert_allclose(density, ref_density, rtol=1e-12, atol=0.0)
    pieces = (n - segment) // (segment - segment // 2) + 1
    assert welch_segments([n, segment - 1], segment) == pieces
    assert welch_density(x[: segment + (segment - segment // 2) * (pieces - 1)], segment)[1] == pytest.approx(density)


@pytest.mark.parametrize("n", [17, 18, 21])
def test_a_log_whose_segment_has_no_top_band_keeps_the_quiet_parts_noise(n):
    """A log of 17 samples has one 16-sample segment, whose frequencies skip the band's top tenth (7/16 < 0.45 <
    8/16, the Nyquist bin left out): (N3) has nothing to read there and bounds nothing. Its noise was NaN."""
    t = np.arange(n) * H
    R = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5]))
    est = SpectralSmoother()
    omega = est.run(t, noisy(R, 1e-3).as_quat()).omega
    assert np.all(np.isfinite(est.measurement_noise)) and np.all(est.measurement_noise > 0)
    assert np.all(np.isfinite(omega))
