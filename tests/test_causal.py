"""The log's own causal filter of backward differences ((C1)–(C3), omegahat.identification.causal) and its
application (D4) in DifferencingEstimator, against closed forms and NumPy's convolution."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from logmaker import two_passes
from omegahat.baselines.differencing import DifferencingEstimator, log_difference
from omegahat.identification.causal import TAPS, CausalFilter, causal_filter, expected_rms_below, least_noise
from omegahat.identification.spectral import IncrementSpectrum, increment_spectrum
from omegahat.measurements import MeasurementError

RATE_HZ = 30.0
FREQS_HZ = (0.3, 1.1, 2.3, 4.0, 6.5)  # the rate's lines, up to 0.22 of the sample rate


def rate_about_z(t: np.ndarray) -> np.ndarray:
    """θ'(t) of the turn about the body's z axis (rad/s)."""
    return sum(np.sin(2 * np.pi * f * t + f) / (1.0 + f) for f in FREQS_HZ)


def angle_about_z(t: np.ndarray) -> np.ndarray:
    """θ(t), the closed-form integral of :func:`rate_about_z`."""
    return sum((np.cos(f) - np.cos(2 * np.pi * f * t + f)) / (2 * np.pi * f * (1.0 + f)) for f in FREQS_HZ)


def noisy_turn(seconds: float, sigma: float, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, attitudes (T, 3, 3) with ``sigma`` rad of white noise per axis, and the true body rate at each
    interval's midpoint (T − 1, 3)."""
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    turn = Rotation.from_rotvec(np.outer(angle_about_z(t), [0.0, 0.0, 1.0]))
    noise = Rotation.from_rotvec(sigma * np.random.default_rng(seed).standard_normal((t.size, 3)))
    mid = 0.5 * (t[1:] + t[:-1])
    truth = np.zeros((mid.size, 3))
    truth[:, 2] = rate_about_z(mid)
    return t, (turn * noise).as_matrix(), truth


def band_errors(error: np.ndarray) -> np.ndarray:
    """The error's power in every low-pass band 0 … F (cumulative over the periodogram's frequencies, all axes)."""
    return np.cumsum(np.sum(np.abs(np.fft.rfft(error, axis=0)) ** 2, axis=1))


def test_the_filter_beats_differencing_in_total_and_loses_in_no_band():
    """A turn of five sines under 3 mrad of noise at 30 Hz: the filtered differences have less error than the
    differences against the closed-form rate at the intervals' midpoints (their common target), in every band 0 … F
    no more (within the periodogram's scatter), and the filter's own expectations, of its error (the figure the
    command prints) and of the ratio, are near the measured."""
    t, R, truth = noisy_turn(200.0, 3e-3)
    found = causal_filter(increment_spectrum(t, R, np.ones(t.size, dtype=bool)))
    assert found.taps.shape == (TAPS, 3) and not found.is_differencing
    differences = log_difference(t, R, scheme="backward")[1:]
    filtered = DifferencingEstimator(taps=found.taps).run(t, Rotation.from_matrix(R).as_quat()).omega[1:]
    inner = slice(TAPS, None)
    err_d, err_f = differences[inner] - truth[inner], filtered[inner] - truth[inner]
    measured = np.sqrt(np.mean(err_f**2) / np.mean(err_d**2))
    assert measured < 0.8
    bands_d, bands_f = band_errors(err_d), band_errors(err_f)
    assert np.all(bands_f[5:] <= 1.1 * bands_d[5:])  # the first few bins hold a handful of periodogram values
    expected = found.expected_rms / found.differencing_rms
    assert abs(expected / measured - 1.0) < 0.2
    assert abs(found.expected_rms / np.sqrt(3.0 * np.mean(err_f**2)) - 1.0) < 0.05  # RMS over the three axes


@pytest.mark.parametrize("band", [0.05, 0.1, 0.25, 0.5])
def test_the_expected_error_in_a_band_is_the_error_low_passed_there(band):
    """(C2) summed over 0 … F, for the filter and for differencing, against their measured errors on the same turn
    (the closed-form rate at the midpoints) cut off at F by the FFT: the self-assessment in a user's band."""
    t, R, truth = noisy_turn(200.0, 3e-3)
    spectrum = increment_spectrum(t, R, np.ones(t.size, dtype=bool))
    found = causal_filter(spectrum)
    identity = np.zeros((TAPS, 3))
    identity[0] = 1.0
    filtered = DifferencingEstimator(taps=found.taps).run(t, Rotation.from_matrix(R).as_quat()).omega[1:]
    for taps, estimate in ((found.taps, filtered), (identity, log_difference(t, R, scheme="backward")[1:])):
        error = estimate[TAPS:] - truth[TAPS:]
        spectrum_of_error = np.fft.rfft(error, axis=0)
        spectrum_of_error[np.fft.rfftfreq(error.shape[0]) > band] = 0.0
        measured = np.sqrt(3.0 * np.mean(np.fft.irfft(spectrum_of_error, n=error.shape[0], axis=0) ** 2))
        assert abs(expected_rms_below(spectrum, taps, band) / measured - 1.0) < 0.1


@pytest.mark.parametrize("p", [2.0, 4.0, 6.0])
def test_the_part_from_above_the_nyquist_frequency_is_conservative_on_written_out_spectra(p):
    """A rate spectrum ``S(ν) ∝ ν^−p`` sampled without noise (``P_b = sinc² S(f) + sinc_a² S(1 − f)``): differencing's
    (C2) term from the folded rate, ``∫ S(1 − f) (1 − sinc(1 − f))² df`` in closed form on the same grid, against
    ``fold_only``: no less (the fold (S6) reads off the band's top is conservative on a power law) and at most
    twice it. Without ``fold_only`` the band's rate would count too (on ``p = 6``, 26 times the true fold's)."""
    freq = np.linspace(0.0, 0.5, 129)
    weight = np.full(freq.size, freq[1] - freq[0])
    weight[[0, -1]] *= 0.5

    def S(nu):
        return 1e-2 * np.maximum(nu, 1e-3) ** -p

    P_b = np.tile((np.sinc(freq) ** 2 * S(freq) + np.sinc(1.0 - freq) ** 2 * S(1.0 - freq))[:, None], (1, 3))
    P_b[0] = 0.0
    spectrum = IncrementSpectrum(freq, P_b, np.ones_like(P_b), np.zeros_like(P_b), np.zeros(3), 0.01, "", [], [])
    identity = np.zeros((TAPS, 3))
    identity[0] = 1.0
    true_fold = np.sqrt(3.0 * np.sum(weight * S(1.0 - freq) * (1.0 - np.sinc(1.0 - freq)) ** 2))
    assert 1.0 <= expected_rms_below(spectrum, identity, 0.5, fold_only=True) / true_fold <= 2.0


def test_the_printed_line_says_how_much_of_the_expected_error_is_extrapolated():
    """The part from above the Nyquist frequency is named where it is more than a tenth of the expected error."""
    taps = np.zeros((TAPS, 3))
    taps[0], taps[1] = 0.6, 0.4
    assert "0.5 of it from the rate above the Nyquist frequency" in CausalFilter(taps, 1.0, 1.1, 0.5).describe()
    assert "above the Nyquist" not in CausalFilter(taps, 1.0, 1.1, 0.05).describe()


def test_a_noise_free_slow_turn_keeps_the_differences_close():
    """Without noise and with the motion well inside the band, differencing at the midpoint is already exact to
    second order: whatever the filter does, it is no worse than the differences against the closed form."""
    t, R, truth = noisy_turn(120.0, 0.0)
    found = causal_filter(increment_spectrum(t, R, np.ones(t.size, dtype=bool)))
    filtered = DifferencingEstimator(taps=found.taps).run(t, Rotation.from_matrix(R).as_quat()).omega[1:]
    differences = log_difference(t, R, scheme="backward")[1:]
    inner = slice(TAPS, None)
    assert np.sqrt(np.mean((filtered[inner] - truth[inner]) ** 2)) <= 1.01 * np.sqrt(
        np.mean((differences[inner] - truth[inner]) ** 2)
    )


def test_without_a_spectrum_the_filter_is_differencing():
    t, R, _ = noisy_turn(0.3, 1e-3)  # 9 samples: no stretch long enough for Welch's estimate
    found = causal_filter(increment_spectrum(t, R, np.ones(t.size, dtype=bool)))
    assert found.is_differencing and np.isnan(found.expected_rms)


def test_samples_taken_at_uneven_times_keep_the_differences():
    """(C1) weighs the differences as if one step apart: where (S8) reads samples taken at uneven times (not only
    stamped so), the filter is differencing itself, and says nothing it cannot know."""
    t, R, _ = noisy_turn(60.0, 3e-3)
    uneven = t + np.random.default_rng(5).uniform(-0.1, 0.1, t.size) / RATE_HZ  # the samples themselves jitter

    def turn(times: np.ndarray) -> Rotation:
        return Rotation.from_rotvec(np.outer(angle_about_z(times), [0.0, 0.0, 1.0]))

    noise = turn(t).inv() * Rotation.from_matrix(R)  # the same 3 mrad, on the turn at the uneven times
    taken = (turn(uneven) * noise).as_matrix()
    regular = causal_filter(increment_spectrum(t, R, np.ones(t.size, dtype=bool)))
    spectrum = increment_spectrum(uneven, taken, np.ones(t.size, dtype=bool))
    found = causal_filter(spectrum)
    assert spectrum.jitter == "sampling" and found.is_differencing and not regular.is_differencing


def test_d4_restarts_at_a_skipped_sample_and_at_a_gap_and_streams_as_it_runs():
    """(D4)–(D5) against NumPy's convolution per stretch: a skipped sample and a 4-step gap in the stamps each start
    a new stretch (the difference across them as it is); ``update`` sample by sample and ``run`` in two chunks equal
    ``run`` on the whole log."""
    rng = np.random.default_rng(2)
    t = np.arange(300) * 0.01
    t[180:] += 0.03  # a gap of four steps before sample 180
    R = Rotation.from_rotvec(np.cumsum(0.01 * np.c_[np.sin(t), np.cos(3 * t), t], axis=0)).as_matrix()
    q = Rotation.from_matrix(R).as_quat()
    q[90] = np.nan  # skipped
    taps = np.vstack([np.ones(3), np.zeros((4, 3))]) + 0.2 * rng.standard_normal((5, 3))
    est = DifferencingEstimator(taps=taps).run(t, q).omega
    valid = np.isfinite(q).all(axis=1)
    raw = log_difference(t[valid], R[valid], scheme="backward")
    rows = np.flatnonzero(valid)
    expected = np.full((t.size, 3), np.nan)
    # stretches of differences (rows of raw): 1..89 | 90 (across the skipped sample) | 91..178 | 179 (the gap) | 180..
    pieces = [(1, 90), (91, 179), (180, raw.shape[0])]
    steps = np.diff(t[valid], prepend=np.nan)
    for a, b in pieces:
        expected[rows[a:b]] = two_passes(raw[a:b], steps[a:b], taps)
    for k in (90, 179):
        expected[rows[k]] = raw[k]
    expected[90] = expected[89]  # the skipped sample holds the last estimate
    np.testing.assert_allclose(est[1:], expected[1:], atol=1e-12)
    streamed = DifferencingEstimator(taps=taps)
    one_by_one = np.array([streamed.update(tk, qk).omega for tk, qk in zip(t, q, strict=True)])
    np.testing.assert_allclose(one_by_one[1:], est[1:], atol=1e-12)
    chunked = DifferencingEstimator(taps=taps)
    first, second = chunked.run(t[:185], q[:185]).omega, chunked.run(t[185:], q[185:]).omega
    np.testing.assert_allclose(np.vstack([first, second])[1:], est[1:], atol=1e-12)


def test_a_rejected_sample_leaves_the_filter_as_it_was():
    """A sample the checks refuse (its time before the last one's; a matrix that is no rotation) raises, and the
    filter's stretch goes on as if it had never come: the rows equal those of the log without it."""
    t = np.arange(60) * 0.01
    q = Rotation.from_rotvec(np.outer(np.sin(3 * t), [0.2, 0.1, 0.3])).as_quat()
    taps = np.array([0.5, 0.3, 0.2])
    clean = DifferencingEstimator(taps=taps).run(t, q).omega
    streamed, rows = DifferencingEstimator(taps=taps), []
    for k in range(t.size):
        if k == 30:
            with pytest.raises(MeasurementError):
                streamed.update(t[k - 2], q[k])  # earlier than the last sample
            with pytest.raises(MeasurementError):
                streamed.update(t[k], 2.0 * Rotation.from_quat(q[k]).as_matrix())  # not a rotation
        rows.append(streamed.update(t[k], q[k]).omega)
    np.testing.assert_allclose(np.array(rows)[1:], clean[1:], atol=1e-12)


def test_taps_are_checked():
    with pytest.raises(ValueError, match="taps must be finite"):
        DifferencingEstimator(taps=[[1.0, np.nan, 0.0]])
    with pytest.raises(ValueError, match="taps filter the backward differences"):
        DifferencingEstimator(scheme="central", taps=[1.0])


def test_direction_input_is_differenced_through_each_samples_least_squares_attitude():
    """Two body-frame directions of a noise-free turn: differencing them (``references``) is differencing the
    attitudes they come from (the least-squares attitude of exact directions is the attitude itself), in ``run`` and
    sample by sample, a sample of non-finite directions skipped as every estimator skips it."""
    t, R, _ = noisy_turn(5.0, 0.0)
    R = (Rotation.from_matrix(R) * Rotation.from_rotvec([0.3, -0.2, 0.1])).as_matrix()  # every axis moves
    V = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0], [0.0, 0.6, 0.8]])
    b = np.einsum("tji,nj->tni", R, V)  # b_i = Rᵀ v_i
    b[40] = np.nan
    q = Rotation.from_matrix(R).as_quat()
    q[40] = np.nan
    on_attitudes = DifferencingEstimator().run(t, q).omega
    on_directions = DifferencingEstimator(references=V).run(t, b).omega
    np.testing.assert_allclose(on_directions[1:], on_attitudes[1:], atol=1e-9)
    streamed = DifferencingEstimator(references=V)
    one_by_one = np.array([streamed.update(tk, bk).omega for tk, bk in zip(t, b, strict=True)])
    np.testing.assert_allclose(one_by_one[1:], on_attitudes[1:], atol=1e-9)
    with pytest.raises(ValueError, match="one direction"):
        DifferencingEstimator(references=[[0.0, 0.0, 1.0]])


def test_a_constant_rate_passes_as_it_is():
    """The spectrum is of the increments less their mean, blind to the mean rate: (C3) holds ``H(0) = 1`` so that a
    constant rate under noise is not scaled (it was, by 4e-6 of the rate, before that constraint)."""
    t = np.arange(0.0, 60.0, 1.0 / RATE_HZ)
    omega = np.array([0.3, -0.2, 0.5])
    noise = Rotation.from_rotvec(2e-3 * np.random.default_rng(7).standard_normal((t.size, 3)))
    R = (Rotation.from_rotvec(np.outer(t, omega)) * noise).as_matrix()
    found = causal_filter(increment_spectrum(t, R, np.ones(t.size, dtype=bool)))
    assert not found.is_differencing and abs(np.sum(found.taps, axis=0) - 1.0).max() < 1e-12
    exact = np.repeat(omega[None], t.size, axis=0)
    clean = (Rotation.from_rotvec(np.outer(t, omega))).as_quat()
    filtered = DifferencingEstimator(taps=found.taps).run(t, clean).omega
    np.testing.assert_allclose(filtered[1:], exact[1:], atol=1e-12)


def test_d5_takes_the_coning_term_off_a_causal_filter():
    """A noise-free coning motion ``R(t) = Rz(αt) Rx(β) Rz(γt)`` at 10 Hz, whose body rate is constant along z (closed
    form): the differences carry the coning term (M1), 5.3e-4 rad/s along z. A causal filter of unit gain at zero
    frequency (a 5-tap moving average) with (D5) has a mean error along z below a tenth of it; the differences alone
    (no taps) carry it whole."""
    alpha, beta, gamma, rate = 1.3, 0.7, -0.9, 10.0
    z = np.array([0.0, 0.0, 1.0])
    t = np.arange(0.0, 60.0, 1.0 / rate)
    R = (
        Rotation.from_rotvec(np.outer(alpha * t, z))
        * Rotation.from_rotvec([beta, 0, 0])
        * Rotation.from_rotvec(np.outer(gamma * t, z))
    )
    truth_z = alpha * np.cos(beta) + gamma  # the body rate along z: α (Rz(γt)ᵀ Rx(β)ᵀ z)_z + γ
    w0 = np.array([0.0, alpha * np.sin(beta), truth_z])  # the body rate at t = 0
    w1 = Rotation.from_rotvec(-gamma * z / rate).apply(w0 - truth_z * z) + truth_z * z  # one step later
    coning = abs(np.cross(w0, w1)[2]) / (12.0 * rate)
    filtered = DifferencingEstimator(taps=np.full((5, 3), 0.2)).run(t, R.as_quat()).omega
    alone = DifferencingEstimator().run(t, R.as_quat()).omega
    assert coning > 4e-4
    assert abs(np.mean(filtered[10:, 2]) - truth_z) < 0.1 * coning
    assert abs(np.mean(alone[10:, 2]) - truth_z) == pytest.approx(coning, rel=0.05)


TREMOR_PHASE = np.random.default_rng(7).uniform(0.0, 2.0 * np.pi, 40)


def trembling_turn(seconds: float, top_hz: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, noise-free attitudes (T, 3, 3) of a body trembling about its z axis (forty lines of 0.02 rad/s from 3
    to ``top_hz`` Hz, at 30 Hz: no part of it is quiet), and the closed-form rate at each interval's midpoint."""
    t = np.arange(0.0, seconds, 1.0 / RATE_HZ)
    w, p = 2.0 * np.pi * np.linspace(3.0, top_hz, TREMOR_PHASE.size), TREMOR_PHASE

    def angle(s: np.ndarray) -> np.ndarray:
        return np.sum(0.02 * (np.cos(p) - np.cos(np.outer(s, w) + p)) / w, axis=1)

    mid = 0.5 * (t[1:] + t[:-1])
    truth = np.zeros((mid.size, 3))
    truth[:, 2] = np.sum(0.02 * np.sin(np.outer(mid, w) + p), axis=1)
    return t, Rotation.from_rotvec(np.outer(angle(t), [0.0, 0.0, 1.0])).as_matrix(), truth


@pytest.mark.parametrize("top_hz", [14.5, 13.5])
def test_a_trembling_body_is_not_filtered_as_noise(top_hz):
    """(C4)–(C5): the noise-free trembling body's quiet part reads as noise (0.57 and 0.30 mrad; there is none).
    Under that reading alone (C3)'s filter had 0.63 times differencing's error in total against the closed-form
    rate but 2.9 times in a low band, with lines up to 14.5 Hz (the reading without a fold is what keeps it from
    that), and 0.75 times in total but 32 times in a low band with lines up to 13.5 Hz (only the least noise's
    readings keep it from that). Under every reading it is no worse than differencing, in total and in every band
    0 … F."""
    t, R, truth = trembling_turn(200.0, top_hz)
    spectrum = increment_spectrum(t, R, np.ones(t.size, dtype=bool))
    assert spectrum.sigma[2] > 1e-4  # the premise: the motion is read as noise
    assert least_noise(spectrum)[2] < 0.1 * spectrum.sigma[2]  # (C5): the motion leaves the band without rising
    found = causal_filter(spectrum)
    differences = log_difference(t, R, scheme="backward")[1:]
    filtered = DifferencingEstimator(taps=found.taps).run(t, Rotation.from_matrix(R).as_quat()).omega[1:]
    inner = slice(TAPS, None)
    err_d, err_f = differences[inner] - truth[inner], filtered[inner] - truth[inner]
    assert np.sqrt(np.mean(err_f**2) / np.mean(err_d**2)) <= 1.005
    bands_d, bands_f = band_errors(err_d), band_errors(err_f)
    assert np.all(bands_f[bands_f.size // 10 :] <= 1.02 * bands_d[bands_d.size // 10 :])


def test_the_least_noise_of_white_noise_is_the_noise():
    """(C5) on the turn under 3 mrad of white noise (200 s at 30 Hz): the spectrum less any smaller noise is not
    shown to fall at the band's top, so the least noise is the identified one, within Welch's scatter of the true
    3 mrad; and on 2 s at 100 Hz of a constant turn under 1 mrad (25 frequencies, whose slope alone could not tell
    white noise from motion) it is the identified noise too, where a bare sign test of the slope read 0.13 mrad on
    one axis and 0 on another."""
    t, R, _ = noisy_turn(200.0, 3e-3)
    spectrum = increment_spectrum(t, R, np.ones(t.size, dtype=bool))
    assert np.all(np.abs(least_noise(spectrum) / 3e-3 - 1.0) < 0.1)
    t = np.arange(0.0, 2.0, 0.01)
    noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))
    R = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_matrix()
    spectrum = increment_spectrum(t, R, np.ones(t.size, dtype=bool))
    assert np.array_equal(least_noise(spectrum), spectrum.sigma)


@pytest.mark.parametrize(
    ("options", "cuts"),
    [
        ({"taps": "filter"}, (0, 1, 2, 50, 100, 101, 181, 250, 252, 400)),
        ({"taps": "filter", "cutoff_hz": 5.0}, (0, 99, 100, 102, 102, 260, 400)),
        ({"taps": "filter", "step": 0.01}, (0, 3, 181, 182, 330, 400)),
        ({"cutoff_hz": 5.0, "omega_hat0": [0.1, 0.2, 0.3]}, (0, 1, 2, 3, 200, 400)),
        ({"taps": "filter", "references": "directions"}, (0, 70, 101, 400)),
    ],
)
def test_a_log_run_in_pieces_gives_the_rows_of_update(options, cuts):
    """``run`` after samples were fed continues from them without the ``update`` loop: the rows of a log run in
    pieces (cut on a skipped sample, before and after one, inside the filter's first ``L`` differences, an empty
    piece) equal those of ``update`` sample by sample, with the same statuses, and the state carries on alike."""
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.uniform(0.0095, 0.0105, 400))
    t[250:] += 0.03  # a gap of four steps: a new stretch
    turn = Rotation.from_rotvec(np.cumsum(0.02 * np.c_[np.sin(3 * t), np.cos(5 * t), t], axis=0))
    noisy = turn * Rotation.from_rotvec(1e-3 * rng.standard_normal((t.size, 3)))
    kw = dict(options)
    if kw.get("taps") == "filter":
        kw["taps"] = np.vstack([np.ones(3), np.zeros((5, 3))]) + 0.2 * rng.standard_normal((6, 3))
    if kw.get("references") == "directions":
        kw["references"] = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
        data = np.stack([noisy.inv().apply(v) for v in kw["references"]], axis=1)  # body-frame directions
    else:
        data = noisy.as_quat()
    # skipped samples, some at the pieces' ends; 251's interval, two steps after the gap's four, breaks the stretch
    # only because a sample was skipped
    data[[0, 99, 100, 101, 180, 251]] = np.nan
    streamed = DifferencingEstimator(**kw)
    one_by_one = [streamed.update(tk, dk) for tk, dk in zip(t, data, strict=True)]
    pieced = DifferencingEstimator(**kw)
    pieces = [pieced.run(t[a:b], data[a:b]) for a, b in itertools.pairwise(cuts)]
    np.testing.assert_allclose(
        np.vstack([p.omega for p in pieces]), np.array([e.omega for e in one_by_one]), atol=1e-12
    )
    np.testing.assert_array_equal(np.concatenate([p.status for p in pieces]), [e.status for e in one_by_one])
    assert pieced.n_skipped == streamed.n_skipped == 6
    t_next, d_next = t[-1] + 0.01, data[-1]
    np.testing.assert_allclose(pieced.update(t_next, d_next).omega, streamed.update(t_next, d_next).omega, atol=1e-12)


def test_a_refused_piece_leaves_the_stream_as_it_was():
    """``run`` after fed samples refuses a piece with a sample that is not a rotation, naming it, and changes nothing:
    the next pieces give the rows of the log without the refused piece."""
    t = np.arange(120) * 0.01
    q = Rotation.from_rotvec(np.outer(np.sin(3 * t), [0.2, 0.1, 0.3])).as_quat()
    taps = np.array([0.5, 0.3, 0.2])
    whole = DifferencingEstimator(taps=taps, cutoff_hz=8.0).run(t, q).omega
    pieced = DifferencingEstimator(taps=taps, cutoff_hz=8.0)
    first = pieced.run(t[:50], q[:50]).omega
    bad = q[50:80].copy()
    bad[7] *= 2.0  # not a unit quaternion
    with pytest.raises(MeasurementError, match="sample 7"):
        pieced.run(t[50:80], bad)
    rest = [pieced.run(t[a:b], q[a:b]).omega for a, b in ((50, 80), (80, 120))]
    np.testing.assert_allclose(np.vstack([first, *rest])[1:], whole[1:], atol=1e-12)
