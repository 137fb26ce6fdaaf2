"""Isolated spikes (:mod:`omegahat.identification.spikes`): found where they are put, never in motion or noise, and
left out of the identification, which without them declines a model it then accepts, and estimated through as
missing samples by ``omegahat estimate``, whatever the chunks.

The logs are integrated here from a closed-form rate with SciPy's rotations (independent of the code under test);
a spike is a sample turned by a fixed rotation, as a marker swap does."""

from __future__ import annotations

import importlib
import itertools

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from logmaker import DiscardWriter, KeepWriter
from omegahat.identification import identify
from omegahat.identification import spikes as spikes_module
from omegahat.identification.likelihood import filter_pass, log_likelihood
from omegahat.identification.spikes import isolated_spikes, stitched
from omegahat.interface import Status

H = 1.0 / 60.0
GLITCHES = (300, 700, 1500, 2900)


def rate(t: np.ndarray) -> np.ndarray:
    """A body rate (rad/s, body axes) whose axis and size keep changing."""
    s, f = np.sin(0.5 * t)[:, None], np.sin(2.3 * t)[:, None]
    return np.array([1.0, -2.0, 0.5]) * s + np.array([0.3, 0.1, 0.2]) + 0.5 * f * np.array([0.0, 1.0, 1.0])


def attitudes(w: np.ndarray, h: float, sigma: float, seed: int = 0) -> np.ndarray:
    """Body → inertial attitudes of the rate ``w`` (trapezoidal increments) with ``sigma`` rad of noise per axis."""
    steps = Rotation.from_rotvec(0.5 * (w[:-1] + w[1:]) * h).as_matrix()
    R = np.empty((w.shape[0], 3, 3))
    R[0] = np.eye(3)
    for k in range(1, w.shape[0]):
        R[k] = R[k - 1] @ steps[k - 1]
    noise = Rotation.from_rotvec(np.random.default_rng(seed).normal(0.0, sigma, (w.shape[0], 3))).as_matrix()
    return R @ noise


def spiked(R: np.ndarray, where=GLITCHES, turn=(1.1, 0.5, 0.0)) -> np.ndarray:
    out = R.copy()
    out[list(where)] = out[list(where)] @ Rotation.from_rotvec(turn).as_matrix()
    return out


def test_the_spikes_put_in_a_moving_log_are_found_and_nothing_else():
    t = H * np.arange(3600)
    R = attitudes(rate(t), H, 3e-4)
    valid = np.ones(t.size, bool)
    assert isolated_spikes(R, valid).samples.size == 0
    found = isolated_spikes(spiked(R), valid)
    assert found.samples.tolist() == list(GLITCHES)
    np.testing.assert_allclose(found.detour, np.linalg.norm([1.1, 0.5, 0.0]), atol=0.1)
    small = isolated_spikes(spiked(R, turn=(0.02, 0.0, 0.0)), valid)  # 1.1°: motion-sized, not judged a spike
    assert small.samples.size == 0
    gap = valid.copy()
    gap[GLITCHES[0] + 1] = False  # a spike beside a missing sample has one neighbour: not judged
    assert isolated_spikes(spiked(R), gap).samples.tolist() == list(GLITCHES[1:])


@pytest.mark.parametrize(
    "case",
    ["noise at rest", "a bounce", "a fast spin", "an impact", "a slow log's alternation"],
)
def test_motion_and_noise_are_not_spikes(case):
    """Noise alone (100,000 samples at rest), a turn reversed within one sample, half a radian per step, a rate that
    jumps by 20 rad/s between two samples, and a 1 rad oscillation at the log's Nyquist frequency: none is isolated."""
    rng = np.random.default_rng(1)
    if case == "noise at rest":
        R = Rotation.from_rotvec(rng.normal(0.0, 1e-3, (100_000, 3))).as_matrix()
    else:
        n = 400
        t = 0.01 * np.arange(n)
        if case == "a bounce":  # 3 rad/s about z, reversed at 2 s: back and forth, mirror images about the stop
            angle = 3.0 * np.minimum(t, 4.0 - t)
        elif case == "a fast spin":
            angle = 50.0 * t
        elif case == "an impact":
            angle = np.where(t < 2.0, 0.5 * t, 1.0 + 20.5 * (t - 2.0))
        else:
            angle = np.where(np.arange(n) % 2 == 0, 0.5, -0.5)
        axis = np.array([0.3, -0.4, 0.87]) / np.linalg.norm([0.3, -0.4, 0.87])
        R = Rotation.from_rotvec(np.outer(angle, axis) + rng.normal(0.0, 1e-4, (n, 3))).as_matrix()
    assert isolated_spikes(R, np.ones(R.shape[0], bool)).samples.size == 0
    assert stitched(R, np.ones(R.shape[0], bool), 0.01 * np.arange(R.shape[0]))[2].samples.size == 0  # nor a reset


@pytest.mark.parametrize("frame", ["inertial", "body"])
def test_a_reset_is_found_and_stitched_with_the_increments_beside_it(frame):
    """(P2)–(P3) on a log whose source restarts at sample 1,000 turned by 100° (of its inertial frame, ``T R``, or
    of the body's, ``R T``): the reset is found there and nowhere else, sample 1,000 is no longer valid, every
    increment away from it is the log's own (SciPy's, to 1e-12), the step across it the mean of its neighbours', and
    for an inertial reset the stitched log is the clean one turned by one rotation."""
    t = H * np.arange(2000)
    clean = attitudes(rate(t), H, 3e-4)
    T = Rotation.from_rotvec([0.0, 0.0, np.radians(100.0)]).as_matrix()
    R = clean.copy()
    R[1000:] = T @ R[1000:] if frame == "inertial" else R[1000:] @ T
    valid = np.ones(t.size, bool)
    out, used, resets = stitched(R, valid, t)
    assert resets.samples.tolist() == [1000] and np.degrees(resets.detour[0]) == pytest.approx(100.0, abs=1.0)
    assert used.sum() == t.size - 1 and not used[1000] and valid.all()  # the input is left as it was
    phi = (Rotation.from_matrix(R[:-1]).inv() * Rotation.from_matrix(R[1:])).as_rotvec()
    phi_out = (Rotation.from_matrix(out[:-1]).inv() * Rotation.from_matrix(out[1:])).as_rotvec()
    away = np.ones(t.size - 1, bool)
    away[999] = False
    np.testing.assert_allclose(phi_out[away], phi[away], rtol=0, atol=1e-12)
    np.testing.assert_allclose(phi_out[999], 0.5 * (phi[998] + phi[1000]), rtol=0, atol=1e-12)
    if frame == "inertial":
        offset = Rotation.from_matrix(out[1001:]) * Rotation.from_matrix(clean[1001:]).inv()
        assert np.ptp(offset.as_rotvec(), axis=0).max() < 1e-9


def test_an_estimate_through_a_reset_is_the_clean_logs():
    """A 100 s log at 60 Hz whose attitude source restarts from another heading (120° about its vertical) at
    sample 3,000: the default and ``--smooth`` give the clean log's rates away from the reset (both read the
    increments only), the row it reached predicted, the summary names it. Measured: RMS error away from the reset
    0.0300 and 0.0064 rad/s (clean: 0.0300, 0.0059), at most 0.074 and 0.038 anywhere; read as it was (before
    (P2)) the default wrote 126 rad/s at that row and declined the model (0.0456 away from it), ``--smooth`` wrote
    up to 57 rad/s over 13 rows (0.0217 away from them)."""
    t = H * np.arange(6000)
    w = rate(t)
    R = attitudes(w, H, 3e-4)
    reset = R.copy()
    reset[3000:] = Rotation.from_rotvec([0.0, 0.0, np.radians(120.0)]).as_matrix() @ reset[3000:]
    missing = Rotation.from_matrix(R).as_quat()
    missing[3000] = np.nan
    clean, stitched_ident = identify(t, R, "matrix"), identify(t, reset, "matrix")
    assert stitched_ident.use_model and clean.use_model and stitched_ident.chosen.model == clean.chosen.model
    assert abs(np.log(stitched_ident.chosen.tracking_index / clean.chosen.tracking_index)) < 0.1
    for smooth in (False, True):
        summary, (_, omega, status) = _estimated(t, Rotation.from_matrix(reset).as_quat(), [(0, t.size)], smooth=smooth)
        _, (_, omega_missing, status_missing) = _estimated(t, missing, [(0, t.size)], smooth=smooth)
        assert summary.resets == 1 and summary.jumps == 0 and summary.largest_reset[1] == 3002
        assert any(line.startswith("resets: 1 step") for line in summary.lines), summary.lines
        assert status[3000] == Status.PREDICTED and np.array_equal(status, status_missing)
        near = np.zeros(t.size, bool)
        near[2990:3011] = True
        assert np.abs(omega - omega_missing)[~near].max() < 1e-3
        assert np.linalg.norm(omega - w, axis=1)[near].max() < 0.15


def test_the_identification_leaves_the_spikes_out_and_keeps_the_model():
    """Four 69° spikes in a minute at 60 Hz: with them left out, the identification of the spiked log is the clean
    log's (the rate model at the same tracking index, run, differencing's expected error the same) and says so;
    without the screen (the same identification with it disabled) every fast filter is thrown onto an alias and the
    log's likelihood makes the model decline."""
    t = H * np.arange(3600)
    R = attitudes(rate(t), H, 3e-4)
    clean, bad = identify(t, R, "matrix"), identify(t, spiked(R), "matrix")
    assert clean.use_model and bad.use_model and bad.chosen.model == clean.chosen.model == "rate"
    assert abs(np.log(bad.chosen.tracking_index / clean.chosen.tracking_index)) < 0.1
    assert abs(bad.differencing_rms / clean.differencing_rms - 1.0) < 0.05
    assert [round(s[0], 6) for s in bad.spikes] == [round(t[k], 6) for k in GLITCHES] and not clean.spikes
    assert "spikes: 4 isolated samples far from both neighbours (the largest" in bad.explain()
    assert "at t = " in bad.explain() and "spikes" not in clean.explain()


def test_without_the_screen_the_spikes_make_the_model_decline(monkeypatch):
    t = H * np.arange(600)  # 10 s (the aliased passes take thousands of substeps per sample: slow)
    R = spiked(attitudes(rate(t), H, 3e-4), where=(300,))
    none = spikes_module.Spikes(np.zeros(0, dtype=np.int64), np.zeros(0))
    module = importlib.import_module("omegahat.identification.identify")  # the package's name is the function's
    monkeypatch.setattr(module, "isolated_spikes", lambda R, valid: none)
    unscreened = identify(t, R, "matrix")
    assert not unscreened.use_model


def test_a_kinematic_pass_ends_where_its_rate_passes_half_a_turn_per_step():
    """The alias itself: a fast pass of the rate model over a spiked log ends with rates far beyond π/h (the samples
    cannot tell them from the rate less 2π/h); given that bound, the pass stops at the first fix beyond it, its
    estimates NaN from there and its likelihood minus infinity, while a pass that stays below runs through."""
    t = H * np.arange(600)
    R = spiked(attitudes(rate(t), H, 3e-4), where=(300,))
    valid = np.ones(t.size, bool)
    free = filter_pass(t, R, valid, "rate", 1e3, sigma=3e-4, h=H)
    speed = np.linalg.norm(free.omega, axis=1)
    assert speed[:300].max() < 5.0 and speed[-1] > np.pi / H  # locked onto an alias after the spike
    bounded = filter_pass(t, R, valid, "rate", 1e3, sigma=3e-4, h=H, max_rate=np.pi / H)
    first = int(np.argmax(speed > np.pi / H))
    assert np.isnan(bounded.omega[first:]).all() and np.isfinite(bounded.omega[:first]).all()
    np.testing.assert_array_equal(bounded.omega[:first], free.omega[:first])
    assert bounded.sums.nis == np.inf and log_likelihood(bounded.sums)[0] == -np.inf
    slow = filter_pass(t, R, valid, "rate", 1.0, sigma=3e-4, h=H, max_rate=np.pi / H)
    assert np.isfinite(slow.omega).all() and np.isfinite(log_likelihood(slow.sums)[0])


@pytest.mark.parametrize("cut", [0, *range(148, 157)])  # the writer sees the chunks a row earlier (the time policy)
def test_the_summary_counts_the_spikes_of_the_whole_log_across_chunks(cut):
    """Spikes at samples 150 and 9,500 of a 10,000-sample log (the second beyond the identification's head), the log
    handed on in two chunks cut anywhere around the first (0: one chunk): each is counted once, the largest named
    by its label, the same samples as :func:`isolated_spikes` finds on the whole log."""
    from omegahat.io import LogChunk, LogStream, ReadOptions, pipeline
    from omegahat.io.registry import checked_stream

    t = H * np.arange(10_000)
    clean = attitudes(rate(t), H, 3e-4)
    R = spiked(spiked(clean, where=(150,)), where=(9500,), turn=(0.0, 1.4, 0.0))
    found = isolated_spikes(R, np.ones(t.size, bool))
    assert found.samples.tolist() == [150, 9500]
    q = Rotation.from_matrix(R).as_quat()
    cuts = [(0, t.size)] if cut == 0 else [(0, cut), (cut, t.size)]

    def chunks():
        for a, b in cuts:
            yield LogChunk(t[a:b], q[a:b], None, np.arange(a, b) + 2)  # labels: the lines of a file with a header

    stream = LogStream("spikes", "quaternion", 0, False, "line", chunks)
    checked_stream(stream, ReadOptions())
    summary = pipeline.estimate_stream(stream, pipeline.EstimateSettings(), lambda s: DiscardWriter(), report=print)
    assert summary.spikes == 2 and summary.largest_spike[1] == 9502
    assert abs(summary.largest_spike[0] - found.detour[1]) < 1e-6  # the quaternions' angle is the log map's
    assert abs(np.degrees(found.detour[1]) - 80.2) < 2.0  # 1.4 rad, less at most a step of the motion
    assert any(line.startswith("spikes: 2 isolated samples far from both neighbours") and "line 9502" in line
               for line in summary.lines), summary.lines  # fmt: skip
    t_clean = H * np.arange(2000)
    q_clean = Rotation.from_matrix(attitudes(rate(t_clean), H, 3e-4)).as_quat()
    stream = LogStream("clean", "quaternion", 0, False, "line",
                       lambda: iter([LogChunk(t_clean, q_clean, None, np.arange(t_clean.size) + 2)]))  # fmt: skip
    checked_stream(stream, ReadOptions())
    assert (
        pipeline.estimate_stream(stream, pipeline.EstimateSettings(), lambda s: DiscardWriter(), report=print).spikes
        == 0
    )


def _estimated(t, q, cuts, **settings):
    """The pipeline's run over the quaternions ``q`` handed on in the chunks ``cuts``: its summary and the rows
    written ``(labels, omega, status)``."""
    from omegahat.io import LogChunk, LogStream, ReadOptions, pipeline
    from omegahat.io.registry import checked_stream

    def chunks():
        for a, b in cuts:
            yield LogChunk(t[a:b], q[a:b], None, np.arange(a, b) + 2)

    stream = LogStream("spikes", "quaternion", 0, False, "line", chunks)
    checked_stream(stream, ReadOptions())
    writer = KeepWriter()
    summary = pipeline.estimate_stream(stream, pipeline.EstimateSettings(**settings), lambda s: writer, report=print)
    return summary, writer.rows()


@pytest.mark.parametrize("smooth", [False, True])
@pytest.mark.parametrize("cut", [0, 1499, 1500, 1501, 1502, 1503])
def test_a_spike_is_estimated_through_as_a_missing_sample(smooth, cut):
    """A 69° spike at sample 1,500 of a 50 s log at 60 Hz, the log cut into two chunks around it (0: one chunk):
    every row is written once, in order; the spike's row is predicted; every status equals that of the same log with
    the sample missing (NaN), and every rate too, to 1e-5 rad/s (the identification's account of differencing, which
    skips the two increments at a spike but reads the one across a missing sample, moves the filter's start by
    1e-6); near the spike the error against the closed-form rate stays below 0.15 rad/s (read, the spike turned the
    rates there by up to 53 rad/s, 35 smoothed)."""
    from omegahat.interface import Status

    t = H * np.arange(3000)
    w = rate(t)
    R = attitudes(w, H, 3e-4)
    q = Rotation.from_matrix(spiked(R, where=(1500,))).as_quat()
    missing = Rotation.from_matrix(R).as_quat()
    missing[1500] = np.nan
    cuts = [(0, t.size)] if cut == 0 else [(0, cut), (cut, t.size)]
    summary, (labels, omega, status) = _estimated(t, q, cuts, smooth=smooth)
    reference, (_, omega_missing, status_missing) = _estimated(t, missing, [(0, t.size)], smooth=smooth)
    assert labels.tolist() == list(range(2, t.size + 2))
    assert summary.spikes == 1 and summary.largest_spike[1] == 1502 and reference.spikes == 0
    assert status[1500] == Status.PREDICTED and np.array_equal(status, status_missing)
    assert np.allclose(omega, omega_missing, rtol=0.0, atol=1e-5, equal_nan=True)
    error = np.linalg.norm(omega - w, axis=1)
    assert error[1490:1511].max() < 0.15, error[1490:1511]
    assert not any(line.startswith("skipped") for line in summary.lines), summary.lines  # a spike is not "missing"
    assert any("treated as missing" in line for line in summary.lines if line.startswith("spikes:")), summary.lines


@pytest.mark.parametrize("cut", [0, 999, 1000, 1001, 1002, 1999, 2000, 2001, 2002])
def test_a_spike_is_not_a_jump_and_a_reset_is_stitched(cut):
    """A 100° spike at sample 1,000 is one spike and no jump (its two steps are not the body's); a reset of the
    attitude source (every sample from 2,000 on turned by 100°) is one reset, stitched, and no jump; the same reset
    at 2,500 beside a missing sample (2,498), which (P2) cannot judge, is one jump, whatever the chunks."""
    t = H * np.arange(3000)
    R = attitudes(rate(t), H, 3e-4)
    R = spiked(R, where=(1000,), turn=(0.0, 0.0, np.radians(100.0)))
    R = spiked(R, where=range(2000, 3000), turn=(np.radians(100.0), 0.0, 0.0))
    R = spiked(R, where=range(2500, 3000), turn=(np.radians(100.0), 0.0, 0.0))
    q = Rotation.from_matrix(R).as_quat()
    q[2498] = np.nan
    cuts = [(0, t.size)] if cut == 0 else [(0, cut), (cut, t.size)]
    summary, (_, _, status) = _estimated(t, q, cuts)
    assert (summary.spikes, summary.largest_spike[1]) == (1, 1002)
    assert (summary.resets, summary.largest_reset[1]) == (1, 2002)
    assert np.degrees(summary.largest_reset[0]) == pytest.approx(100.0, abs=1.0)
    assert (summary.jumps, summary.largest_jump[1]) == (1, 2502)
    assert status[2000] == Status.PREDICTED and status[2001] == Status.CORRECTED


def test_a_spike_that_is_not_a_rotation_is_named_as_a_bad_sample():
    """A quaternion of norm 1.5 that is also a spike is not hidden as one: the run stops naming its line, and with
    ``skip_bad_samples`` it is counted as a bad sample."""
    from omegahat.io import LogFormatError

    t = H * np.arange(2000)
    q = Rotation.from_matrix(spiked(attitudes(rate(t), H, 3e-4), where=(700,))).as_quat()
    q[700] *= 1.5
    with pytest.raises(LogFormatError, match="line 702"):
        _estimated(t, q, [(0, t.size)])
    summary, (_, omega, _) = _estimated(t, q, [(0, t.size)], skip_bad_samples=True)
    assert summary.n_bad == 1 and summary.spikes == 0 and np.isfinite(omega[1:]).all()


@pytest.mark.parametrize("smooth", [False, True])
def test_four_spikes_cost_the_estimate_nothing(smooth):
    """The identification's log (four 69° spikes in a minute at 60 Hz), estimated as ``omegahat estimate`` does, with
    and without ``--smooth``: its RMS error against the closed-form rate is within 10 % of the clean log's, and
    none above 0.15 rad/s (read, the spikes made it 1.76 and 1.72 rad/s RMS, 53 and 35 at worst)."""
    t = H * np.arange(3600)
    w = rate(t)
    R = attitudes(w, H, 3e-4)
    errors = []
    for log in (R, spiked(R)):
        summary, (_, omega, _) = _estimated(t, Rotation.from_matrix(log).as_quat(), [(0, t.size)], smooth=smooth)
        errors.append(np.linalg.norm(omega[1:] - w[1:], axis=1))
    clean, spikes = (float(np.sqrt(np.mean(e**2))) for e in errors)
    assert summary.spikes == 4 and spikes < 1.1 * clean and errors[1].max() < 0.15, (clean, spikes)


@pytest.mark.parametrize("cut", [0, *range(999, 1004)])  # the writer sees the chunks two rows earlier (the screen)
def test_a_gap_is_named_by_the_row_after_it_wherever_the_chunks_are_cut(cut):
    """Samples 1,000 … 1,009 dropped (a gap of 11 steps before the row that was sample 1,010, line 1,012), the log
    handed on whole or cut around the gap: one gap, its length and that line, as the summary's other records are."""
    t = H * np.arange(2000)
    q = Rotation.from_matrix(attitudes(rate(t), H, 3e-4)).as_quat()
    keep = np.r_[0:1000, 1010:2000]
    t, q = t[keep], q[keep]
    cuts = [(0, t.size)] if cut == 0 else [(0, cut), (cut, t.size)]
    from omegahat.io import LogChunk, LogStream, ReadOptions, pipeline
    from omegahat.io.registry import checked_stream

    def chunks():
        for a, b in cuts:
            yield LogChunk(t[a:b], q[a:b], None, keep[a:b] + 2)

    stream = LogStream("gap", "quaternion", 0, False, "line", chunks)
    checked_stream(stream, ReadOptions())
    summary = pipeline.estimate_stream(stream, pipeline.EstimateSettings(), lambda s: DiscardWriter(), report=print)
    assert summary.gaps == 1 and summary.largest_gap[1] == 1012
    assert abs(summary.largest_gap[0] - 11 * H) < 1e-9


def test_the_array_recipe_of_getting_started_screens_spikes_for_an_estimator_class():
    """docs/getting-started.md: an estimator given arrays reads a spike as it is; ``isolated_spikes`` and NaN make it
    a missing sample, and the estimate is then the clean log's where the spiked one was far off."""
    from omegahat import DifferencingEstimator

    t = H * np.arange(3000)
    w = rate(t)
    R = attitudes(w, H, 3e-4)
    bad = spiked(R)
    screened = bad.copy()
    screened[isolated_spikes(bad, np.ones(t.size, bool)).samples] = np.nan
    clean, raw, fixed = (DifferencingEstimator().run(t, x).omega for x in (R, bad, screened))
    near = np.zeros(t.size, bool)
    near[0] = True  # differencing has no estimate at the first sample
    for k in GLITCHES:
        near[k - 2 : k + 3] = True
    assert np.nanmax(np.abs(raw - clean)) > 30.0  # one step of 69 degrees read as a rate
    assert np.abs(fixed[~near] - clean[~near]).max() < 1e-12
    assert np.nanmax(np.abs(fixed[near] - w[near])) < 0.15  # predicted through the missing sample


@pytest.mark.parametrize("smooth", [False, True])
def test_any_chunks_give_the_rows_of_one_chunk(smooth):
    """Spikes next to each other's neighbourhoods, at the log's second and last-but-one samples, a single missing
    sample, a gap, a reset and a reset beside a missing sample (a jump), the log handed on in chunks of random
    lengths (chunks of one and two rows among them, shorter than the two rows the screen holds back): the rows
    written, their statuses and rates, and the summary's counts are those of one chunk."""
    t = H * np.arange(2400)
    R = spiked(attitudes(rate(t), H, 3e-4), where=(1, 400, 404, 900, 2398))
    R = spiked(R, where=range(1800, 2400), turn=(0.0, np.radians(120.0), 0.0))  # a reset: stitched
    R = spiked(R, where=range(2100, 2400), turn=(0.0, np.radians(120.0), 0.0))  # beside a missing sample: a jump
    q = Rotation.from_matrix(R).as_quat()
    q[[600, 2098]] = np.nan
    q[1200:1210] = np.nan
    whole, (labels0, omega0, status0) = _estimated(t, q, [(0, t.size)], smooth=smooth)
    assert (whole.spikes, whole.resets, whole.jumps) == (5, 1, 1)
    rng = np.random.default_rng(5)
    for _ in range(4):
        sizes = rng.choice([1, 2, 3, 7, 50, 333], size=200)
        edges = np.unique(np.clip(np.concatenate([[0], np.cumsum(sizes)]), 0, t.size))
        edges = edges if edges[-1] == t.size else np.append(edges, t.size)
        summary, (labels, omega, status) = _estimated(t, q, list(itertools.pairwise(edges)), smooth=smooth)
        assert labels.tolist() == labels0.tolist()
        assert np.array_equal(status, status0)
        np.testing.assert_array_equal(omega, omega0)
        assert (summary.spikes, summary.resets, summary.jumps) == (5, 1, 1)
        assert (summary.largest_spike, summary.largest_reset) == (whole.largest_spike, whole.largest_reset)


def test_a_sample_that_is_not_a_rotation_after_a_reset_is_named_as_read():
    """After a reset every attitude is turned back; a quaternion of norm 2 among them is still named by its line and
    its |q| = 2 (a turn keeps the norm), whichever chunk it arrives in."""
    from omegahat.io import LogFormatError

    t = H * np.arange(1200)
    R = spiked(attitudes(rate(t), H, 3e-4), where=range(400, 1200), turn=(0.0, 0.0, np.radians(120.0)))
    q = Rotation.from_matrix(R).as_quat()
    q[900] *= 2.0
    for cuts in ([(0, t.size)], [(0, 600), (600, t.size)]):
        with pytest.raises(LogFormatError, match=r"line 902: a quaternion far from unit norm: \|q\| = 2,"):
            _estimated(t, q, cuts)


def test_a_large_turn_across_a_gap_is_no_reset_and_no_jump(tmp_path, capsys):
    """A body turning at a constant 0.06 rad/s, seen every 0.5 s with an outage of 940 s (57 rad unobserved): the
    turn across the outage is no reset of the source (nothing is stitched, no sample set missing), neither in the
    command nor in the identification, and every rate after the outage is the body's."""
    from logmaker import write_csv
    from omegahat.cli import main

    omega = np.array([0.03, -0.02, 0.05])
    t = np.concatenate([0.5 * np.arange(120), 1000.0 + 0.5 * np.arange(120)])
    R = Rotation.from_rotvec(np.outer(t, omega))
    valid = np.ones(t.size, bool)
    _, used, resets = stitched(R.as_matrix(), valid, t)
    assert resets.samples.size == 0 and used.all()
    src, dst = write_csv(tmp_path / "outage.csv", t, R), tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "gaps: 1 intervals" in printed and "resets:" not in printed and "jumps:" not in printed
    rates = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    np.testing.assert_allclose(rates[120:], np.tile(omega, (120, 1)), atol=1e-6)  # from the first after it
    status = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=4, dtype=str)
    assert np.flatnonzero(status != "corrected").tolist() == [120]  # the turn across is unknown: (D6) holds the rate


def test_a_reset_after_frames_left_out_is_still_one(tmp_path, capsys):
    """100 Hz, three frames left out (an interval of 0.04 s), and the source re-aligned by 100° at the next frame:
    judged per spacing, the step is a reset, stitched; the rates on both sides are the body's."""
    from logmaker import write_csv
    from omegahat.cli import main

    omega = np.array([0.3, -0.2, 0.5])
    t = np.delete(0.01 * np.arange(1000), [500, 501, 502])
    R = Rotation.from_rotvec(np.outer(t, omega))
    R = Rotation.concatenate([R[:500], Rotation.from_rotvec([0.0, 0.0, np.radians(100.0)]) * R[500:]])
    _, used, resets = stitched(R.as_matrix(), np.ones(t.size, bool), t)
    assert resets.samples.tolist() == [500] and not used[500]
    src, dst = write_csv(tmp_path / "frames.csv", t, R), tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    assert "resets: 1 step far larger than the steps beside it; the largest 101° before line 502" in printed
    assert "model identified from the log" in printed and "rate: log-likelihood" in printed
    rates = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    np.testing.assert_allclose(np.delete(rates, 500, axis=0)[20:], np.tile(omega, (t.size - 21, 1)), atol=1e-6)
