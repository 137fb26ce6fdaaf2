"""BROAD loader and in-band scorer: synthetic checks with known answers, then the real recordings (skipped when
``../shared/data/broad`` is absent)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, sosfreqz

from omegahat import so3
from omegahat.lab.evaluation import broad
from omegahat.lab.evaluation.broad import Score, Trial, score

FS = 2000 / 7  # 285.714 Hz, BROAD's rate
HAVE_DATA = all((broad.data_dir() / f).exists() for f in [*broad.TRIALS.values(), broad.CSV_CUT])
needs_data = pytest.mark.skipif(not HAVE_DATA, reason="BROAD recordings absent (../shared/data/broad)")


def synthetic_trial(N=6000, seed=0):
    """Smooth rotation, rest for the first and last 1000 samples, constant gyro bias (0.01, −0.02, 0.005)."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / FS
    movement = np.zeros(N, bool)
    movement[1000:-1000] = True
    omega = np.zeros((N, 3))
    omega[movement] = np.column_stack([np.sin(2 * t), np.cos(3 * t), 0.5 * np.sin(t)])[movement]
    bias = np.array([0.01, -0.02, 0.005])
    gyro = omega + bias
    R = so3.exp(0.1 * rng.standard_normal((N, 3)))  # attitude only matters through its gaps here
    return Trial("synthetic", t, R, gyro, FS, movement), omega, bias


def test_gyro_bias_is_the_rest_mean():
    trial, omega, bias = synthetic_trial()
    np.testing.assert_allclose(trial.gyro_bias, bias, atol=1e-15)
    np.testing.assert_allclose(trial.gyro_corrected, omega, atol=1e-15)


def test_perfect_estimate_scores_zero_at_shift_zero():
    trial, omega, _ = synthetic_trial()
    s = score(trial, omega)
    assert isinstance(s, Score)
    assert s.shift == 0
    assert s.rms < 1e-12
    assert s.rms_by_shift[1] > 1e-4  # a one-sample shift is visible


def test_a_leading_estimate_is_found_at_its_shift():
    # ω̂_k = ω_{k+2} (leads by two samples): ω̂_{k−2} = ω_k, so the best shift is +2 with zero error.
    trial, omega, _ = synthetic_trial()
    leading = np.vstack([omega[2:], np.repeat(omega[-1:], 2, axis=0)])
    s = score(trial, leading)
    assert s.shift == 2
    assert s.rms < 1e-12


def test_in_band_error_passes_and_out_of_band_error_is_removed():
    trial, omega, _ = synthetic_trial()
    t = trial.t
    A = 0.05
    for f_err in (2.0, 50.0):
        err = np.zeros_like(omega)
        err[:, 0] = A * np.sin(2 * np.pi * f_err * t)
        s = score(trial, omega + err, max_shift=0)
        # Expected: A/√2 times the zero-phase gain |H(f)|² of the order-4 Butterworth at 10 Hz (from SciPy).
        _, h = sosfreqz(butter(4, 10.0, fs=FS, output="sos"), worN=[f_err], fs=FS)
        expected = A / np.sqrt(2) * abs(h[0]) ** 2
        np.testing.assert_allclose(s.rms, expected, rtol=2e-3, atol=1e-6)
    assert expected < 1e-6  # 50 Hz: gone


def test_gaps_remove_the_margin_around_them():
    trial, omega, _ = synthetic_trial()
    base = score(trial, omega, max_shift=0, gap_margin_s=0.5)
    R = trial.R.copy()
    R[3000:3010] = np.nan  # a 10-sample gap in the middle of the motion
    gapped = Trial(trial.name, trial.t, R, trial.gyro, FS, trial.movement)
    est = omega.copy()
    est[3000:3010] = 100.0  # garbage in the gap must not count
    s = score(gapped, est, max_shift=0, gap_margin_s=0.5)
    margin = round(0.5 * FS)
    assert base.n_samples - s.n_samples == 10 + 2 * margin
    # The garbage passes the filter but the 0.5 s margin keeps its smear out: the Butterworth's impulse response
    # has decayed by far more than 1e-3 of its peak after 0.5 s.
    assert s.rms < 1e-3


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"estimate": np.zeros((10, 3))}, r"estimate must have shape \(6000, 3\), .* got \(10, 3\)"),
        ({"cutoff_hz": 200.0}, r"cutoff_hz must be in \(0, fs/2 = 142\.857\); got 200\.0"),
        ({"order": 0}, r"order must be a positive integer; got 0"),
        ({"gap_margin_s": -1.0}, r"gap_margin_s must be >= 0; got -1\.0"),
        ({"max_shift": -1.5}, r"max_shift must be >= 0 samples; got -1\.5"),
        ({"resolution": 2.0}, r"resolution must be in \(0, 1\] samples; got 2\.0"),
        ({"estimate": np.full((6000, 3), np.nan)}, r"the estimate has no finite row for trial 'synthetic'"),
    ],
)
def test_score_rejects_bad_arguments(kwargs, match):
    trial, omega, _ = synthetic_trial()
    args = {"estimate": omega} | kwargs
    with pytest.raises(ValueError, match=match):
        score(trial, **args)


def test_scoring_needs_movement_labels():
    trial, omega, _ = synthetic_trial()
    unlabeled = Trial("cut", trial.t, trial.R, trial.gyro, FS)
    with pytest.raises(ValueError, match=r"trial 'cut' has no movement labels: scoring needs them"):
        score(unlabeled, omega)
    with pytest.raises(ValueError, match=r"no movement labels: the gyro bias needs them"):
        _ = unlabeled.gyro_bias


def test_unknown_trial_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match=r"a BROAD trial is one of \['01', '06', '10'\] .* got '07'"):
        broad.load_trial("07")
    with pytest.raises(FileNotFoundError, match=r"BROAD trial not found: .*01_undisturbed_slow_rotation_A\.mat"):
        broad.load_trial("01", directory=tmp_path)


# --------------------------------------------------------------------------------------------- real data


@needs_data
@pytest.mark.parametrize("name", sorted(broad.TRIALS))
def test_differencing_bar_reproduces_notice(name):
    # NOTICE.md prints two significant digits: the scorer must land within one unit of the last digit, at the
    # one-sample lead NOTICE.md reports, and the reference's RMS must be NOTICE.md's "gyro RMS".
    gyro_rms = {"01": 1.68, "06": 5.21, "10": 0.85}
    trial = broad.load_trial(name)
    s = score(trial, broad.differencing_bar(trial), max_shift=5, resolution=1)  # NOTICE.md's whole-sample rule
    assert abs(s.rms - broad.NOTICE_DIFFERENCING_RMS[name]) < 1e-3
    assert s.shift == 1
    assert abs(s.gyro_rms - gyro_rms[name]) < 5e-3


@needs_data
def test_loaded_trial_matches_notice_description():
    trial = broad.load_trial("01")
    assert trial.fs == pytest.approx(285.714, abs=1e-3)
    ok = ~trial.gaps
    assert np.all(so3.orthogonality_error(trial.R[ok]) < 1e-6)
    assert 0.3 <= round(100 * trial.gaps.mean(), 1) <= 3.0  # "0.3 to 3 % of samples" (one decimal printed)
    assert np.all(np.abs(trial.gyro_bias) < 0.01)  # "biased by up to ~0.008 rad/s"
    # Gravity's reaction seen in the body at rest, rotated to ENU by R, is about (0, 0, 9.83) (NOTICE.md).
    rest = ~trial.movement & ok
    g_enu = np.einsum("nij,nj->ni", trial.R[rest], trial.acc[rest]).mean(axis=0)
    np.testing.assert_allclose(g_enu, [0, 0, 9.83], atol=0.15)


@needs_data
def test_csv_cut_is_trial_01_from_20_s():
    cut = broad.load_csv_cut()
    full = broad.load_trial("01")
    k0 = round(20.0 * full.fs)
    N = cut.t.size
    np.testing.assert_array_equal(cut.gaps, full.gaps[k0 : k0 + N])
    ok = ~cut.gaps
    np.testing.assert_allclose(cut.R[ok], full.R[k0 : k0 + N][ok], atol=1e-8)  # 9 digits in the text
    np.testing.assert_allclose(cut.gyro, full.gyro[k0 : k0 + N], atol=1e-8)
    np.testing.assert_allclose(cut.t, full.t[:N], atol=1e-9)


def smooth_trial(N=6000):
    """A rate that is smooth everywhere (no jump at the motion labels' edges), for fractional shifts."""
    t = np.arange(N) / FS
    movement = np.zeros(N, bool)
    movement[1000:-1000] = True
    R = np.repeat(np.eye(3)[None], N, axis=0)
    return Trial("smooth", t, R, _smooth_rate(t), FS, movement)


def _smooth_rate(t):
    return np.column_stack([np.sin(2 * t), np.cos(3 * t), 0.5 * np.sin(t)])


def _estimate(trial, t):
    """The exact rate at ``t`` minus the trial's gyro bias (the rest samples' mean of this smooth rate)."""
    return _smooth_rate(t) - trial.gyro_bias


def test_a_fractional_lag_is_found_continuously():
    # ω̂(t) = ω(t − 0.37 h): the score finds the shift to 0.01 sample with (almost) zero error, and the zero-shift
    # score is the lag's own error, |ω̇| 0.37 h in band (checked against a direct computation).
    trial = smooth_trial()
    h = 1 / FS
    lagging = _estimate(trial, trial.t - 0.37 * h)
    s = score(trial, lagging)
    assert abs(s.shift + 0.37) < 0.01  # a lagging estimate: negative shift
    assert s.rms < 5e-6 and s.rms < 1e-3 * s.zero_shift_rms  # left: the search stops within 0.001 sample
    direct = score(trial, lagging, max_shift=0)
    assert s.zero_shift_rms == pytest.approx(direct.rms, rel=1e-12)
    whole = score(trial, lagging, max_shift=3, resolution=1)  # whole samples only: the lag stays
    assert whole.shift == 0 and whole.rms > 100 * s.rms


def test_a_decimated_trial_is_scored_against_the_native_reference():
    trial = smooth_trial()
    low = trial.decimated(30)
    assert low.fs == pytest.approx(FS / 30) and low.t.size == 200 and low.native is trial
    np.testing.assert_array_equal(low.movement, trial.movement[::30])
    # the exact rate at the decimated instants scores zero; lagging by 0.4 decimated samples, shift −0.4
    assert score(low, _estimate(low, low.t), gap_margin_s=0.0).rms < 1e-9
    s = score(low, _estimate(low, low.t - 0.4 / low.fs), gap_margin_s=0.0)
    assert abs(s.shift + 0.4) < 0.01 and s.rms < 1e-6
    with pytest.raises(ValueError, match=r"step must be a positive integer; got 0"):
        trial.decimated(0)
