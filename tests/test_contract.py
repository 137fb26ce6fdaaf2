"""One contract, every estimator (omegahat.interface): the same parametrised suite over all of them.

Shapes and statuses of ``run``, keyword-only constructors, ``update``/``reset`` exactly for the streaming ones,
stream = batch, ``run`` continuing from the state, ``reset``, missing samples (predicted or unavailable, never
corrected, counted by the one counter ``n_skipped``), refusals that leave the state exactly as it was (a sample
that is not a rotation, a time backwards, a time given as text, a complex sample: issue 23 item 5), ``run`` atomic,
and options that are one of a few words.

The logs are noise-free constant-rate turns (J = I, no torque), on which every estimator has an estimate; the
reference for every "state unchanged" check is a twin estimator fed the same good samples and never the bad one.
"""

from __future__ import annotations

import inspect
import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.rts import RTSSmoother
from omegahat.baselines.savgol import SavitzkyGolayEstimator
from omegahat.baselines.spline import SplineEstimator
from omegahat.baselines.sunline_sekf import SunlineSEKF
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter
from omegahat.identification.spectral import SpectralSmoother
from omegahat.interface import STATUS_WORDS, Estimate, Estimator, Status, StreamingEstimator
from omegahat.measurements import MeasurementError
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.presets import MocapPreset, MocapSmoother, mocap_estimator
from omegahat.observer.single_direction import SingleDirectionEstimator
from omegahat.observer.tuning import sensor_gains

RATE = 50.0
T = 60
W = np.array([0.4, -0.3, 0.5])  # rad/s, constant (J = I: torque-free)
V2 = np.array([[0.0, 0.0, 1.0], [0.8, 0.6, 0.0]])  # two inertial directions
V1 = np.array([0.6, 0.0, 0.8])  # one (not along W: the body's turn moves it)
J = np.eye(3)


def _log(kind: str, n: int = T, t0: float = 0.0):
    """Times and samples of the constant-rate turn: matrices, quaternions, two directions or one."""
    t = t0 + np.arange(n) / RATE
    rot = Rotation.from_rotvec(np.outer(t, W))
    if kind == "quaternion":
        return t, rot.as_quat()
    R = rot.as_matrix()
    if kind == "matrix":
        return t, R
    if kind == "directions":
        return t, np.einsum("tji,nj->tni", R, V2)  # b_i = Rᵀ v_i
    return t, np.einsum("tji,j->ti", R, V1)


#: name -> (factory, kind of sample)
ESTIMATORS = {
    "sarras": (lambda: SarrasEstimator(J, gains=ObserverGains.constant(2.0, 20.0, n=3)), "quaternion"),
    "sarras-directions": (
        lambda: SarrasEstimator(J, gains=ObserverGains.constant(2.0, 20.0, n=2), references=V2),
        "directions",
    ),
    "supervised-kalman": (
        lambda: SupervisedKalmanEstimator(J, rate_hz=RATE, measurement_noise=1e-4, rate_noise=1e-3),
        "matrix",
    ),
    "mocap-preset": (lambda: mocap_estimator(RATE, 1e-4), "quaternion"),
    "mocap-preset-shell": (lambda: MocapPreset(rate_hz=RATE, measurement_noise=1e-4), "matrix"),
    "mekf": (lambda: MEKF(J, q=1e-4, measurement_noise=1e-4), "matrix"),
    "mekf-directions": (lambda: MEKF(model="kinematic", q=1e-4, references=V2), "directions"),
    "differencing": (lambda: DifferencingEstimator(cutoff_hz=10.0), "quaternion"),
    "differencing-central": (lambda: DifferencingEstimator(scheme="central"), "matrix"),
    # started on the rate: one direction makes the rate observable only as the body turns, slower than this log
    "single-direction": (lambda: SingleDirectionEstimator(J, reference=V1, omega_hat0=W), "one-direction"),
    "spline": (lambda: SplineEstimator(), "matrix"),
    "spectral-smoother": (lambda: SpectralSmoother(), "quaternion"),
    "spectral-smoother-directions": (lambda: SpectralSmoother(references=V2), "directions"),
    "savitzky-golay": (lambda: SavitzkyGolayEstimator(window=5, order=2), "quaternion"),
    "mocap-smoother": (lambda: MocapSmoother(rate_hz=RATE, measurement_noise=1e-4), "quaternion"),
    "rts-smoother": (lambda: RTSSmoother(filter_factory=lambda: MEKF(J, q=1e-4, measurement_noise=1e-4)), "matrix"),
    # the gyro-free peers (issue 26), started on the rate like the one-direction observer
    "min-energy": (lambda: MinimumEnergyFilter(J, omega_hat0=W), "quaternion"),
    "min-energy-directions": (lambda: MinimumEnergyFilter(J, references=V2, omega_hat0=W), "directions"),
    "predictive": (lambda: PredictiveFilter(J, omega_hat0=W), "matrix"),
    # a kinematic filter: its rates a random walk brisk enough for this fast turn (noise-free samples)
    "sunline-sekf": (lambda: SunlineSEKF(omega_hat0=W, measurement_noise=1e-3, process_noise=1.0), "one-direction"),
}
#: estimators of the rate across the measured direction only (the rate about it is not estimated)
ACROSS_ONLY = {"sunline-sekf"}
NAMES = list(ESTIMATORS)
STREAMING = [n for n in NAMES if isinstance(ESTIMATORS[n][0](), StreamingEstimator)]
CLASSES = {type(ESTIMATORS[n][0]()) for n in NAMES}


def make(name: str) -> tuple[Estimator, str]:
    factory, kind = ESTIMATORS[name]
    return factory(), kind


def assert_same(a: Estimate, b: Estimate, atol: float = 1e-12) -> None:
    np.testing.assert_allclose(a.omega, b.omega, rtol=0, atol=atol)  # NaN where both have none
    np.testing.assert_array_equal(np.asarray(a.status), np.asarray(b.status))


def test_the_suite_covers_every_estimator():
    assert len(STREAMING) == 14 and len(NAMES) - len(STREAMING) == 6
    names = {c.__name__ for c in CLASSES}
    assert names == {
        "SarrasEstimator", "SupervisedKalmanEstimator", "MocapPreset", "MEKF", "DifferencingEstimator",
        "SingleDirectionEstimator", "SplineEstimator", "SpectralSmoother", "SavitzkyGolayEstimator", "MocapSmoother",
        "RTSSmoother", "MinimumEnergyFilter", "PredictiveFilter", "SunlineSEKF",
    }  # fmt: skip


@pytest.mark.parametrize("name", NAMES)
def test_run_gives_an_estimate_and_a_status_per_sample(name):
    est, kind = make(name)
    t, data = _log(kind)
    out = est.run(t, data)
    assert isinstance(out, Estimate)
    omega, status = out
    assert omega.shape == (T, 3) and omega.dtype == float
    assert status.shape == (T,) and set(np.unique(status)) <= {int(s) for s in Status}
    none = status == Status.UNAVAILABLE
    assert np.all(np.isnan(omega[none])) and np.all(np.isfinite(omega[~none]))  # NaN exactly where there is none
    assert not np.any(status == Status.PREDICTED)  # a clean log: nothing skipped
    assert none.sum() <= 2 and np.all(status[10:-10] == Status.CORRECTED)  # at the ends at most
    want = np.broadcast_to(W, (T, 3))
    if name in ACROSS_ONLY:  # the rate across the measured direction b
        b = data / np.linalg.norm(data, axis=-1, keepdims=True)
        want = W - (b @ W)[:, None] * b
    assert np.abs(omega[20:-20] - want[20:-20]).max() < 0.05  # and they are estimates of the rate
    assert est.n_skipped == 0
    assert [STATUS_WORDS[s] for s in (0, 1, 2, 3)] == ["unavailable", "corrected", "predicted", "restarted"]


@pytest.mark.parametrize("cls", sorted(CLASSES, key=lambda c: c.__name__), ids=lambda c: c.__name__)
def test_constructors_take_keywords_only_but_the_inertia(cls):
    params = list(inspect.signature(cls).parameters.values())
    positional = [p.name for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    assert positional in ([], ["J"]), positional


@pytest.mark.parametrize("name", NAMES)
def test_streaming_estimators_and_only_they_update_and_reset(name):
    est, _ = make(name)
    streaming = isinstance(est, StreamingEstimator)
    assert est.streaming is streaming
    assert hasattr(est, "update") is streaming and hasattr(est, "reset") is streaming
    if not streaming:
        assert est.causal is False  # offline: it looks at later samples


@pytest.mark.parametrize("name", STREAMING)
def test_stream_equals_batch(name):
    batch_est, kind = make(name)
    t, data = _log(kind)
    batch = batch_est.run(t, data)
    est, _ = make(name)
    stream = [est.update(t[j], data[j]) for j in range(T)]
    assert all(isinstance(s.status, Status) and s.omega.shape == (3,) for s in stream)
    d = getattr(est, "delay_samples", 0)  # central differencing: update returns the previous sample's estimate
    omega = np.array([s.omega for s in stream])[d:]
    np.testing.assert_allclose(omega[1:], batch.omega[: T - d][1:], rtol=0, atol=1e-12)
    if d == 0:
        assert_same(Estimate(np.array([s.omega for s in stream]), np.array([s.status for s in stream])), batch)


@pytest.mark.parametrize("name", STREAMING)
def test_run_continues_from_the_state_and_reset_forgets_it(name):
    est, kind = make(name)
    t, data = _log(kind)
    whole = fresh = est.run(t, data)
    est.reset()
    assert est.n_skipped == 0
    first, second = est.run(t[:25], data[:25]), est.run(t[25:], data[25:])
    if getattr(est, "delay_samples", 0):  # central differencing: the last row of the first part had no successor
        whole = Estimate(np.delete(whole.omega, 24, axis=0), np.delete(whole.status, 24))
        first = Estimate(first.omega[:-1], first.status[:-1])
    joined = Estimate(np.vstack([first.omega, second.omega]), np.concatenate([first.status, second.status]))
    assert_same(joined, whole)
    est.reset()
    assert_same(est.run(t, data), fresh, atol=0.0)


@pytest.mark.parametrize("name", NAMES)
def test_batch_runs_are_repeatable(name):
    est, kind = make(name)
    t, data = _log(kind)
    first = est.run(t, data)
    if isinstance(est, StreamingEstimator):
        est.reset()
    assert_same(est.run(t, data), first, atol=0.0)


@pytest.mark.parametrize("name", NAMES)
def test_missing_samples_are_skipped_counted_and_never_corrected(name):
    est, kind = make(name)
    t, data = _log(kind)
    data = data.copy()
    gone = [30, 31, 45]
    data[gone] = np.nan
    data[45].flat[0] = np.inf  # inf is missing too
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the compiled ones warn (tests/test_estimator.py); here: what they return
        omega, status = est.run(t, data)
    assert est.n_skipped == 3
    assert np.all(np.isin(status[gone], [Status.PREDICTED, Status.UNAVAILABLE]))
    assert np.all(np.isnan(omega[status == Status.UNAVAILABLE]))
    assert np.all(np.isfinite(omega[status == Status.PREDICTED]))
    keep = np.setdiff1d(np.arange(T), gone)
    assert np.all(status[keep][10:-10] == Status.CORRECTED)


@pytest.mark.parametrize("name", STREAMING)
@pytest.mark.parametrize(
    "bad",
    ["not a rotation", "time backwards", "time as text", "complex sample", "wrong shape"],
)
def test_a_refused_sample_leaves_the_state_exactly_as_it_was(name, bad):
    est, kind = make(name)
    twin, _ = make(name)
    t, data = _log(kind)
    for j in range(20):
        est.update(t[j], data[j])
        twin.update(t[j], data[j])
    sample, when = data[20].copy(), t[20]
    if bad == "not a rotation":
        if kind in ("directions", "one-direction"):
            sample = np.zeros_like(sample)  # a zero direction
        else:
            sample = 2.0 * sample
        error = MeasurementError
    elif bad == "time backwards":
        when = t[10]
        error = MeasurementError
    elif bad == "time as text":
        when = str(t[20])  # "0.4": refused, not converted (it used to move the state to t = 0.4 first)
        error = TypeError
    elif bad == "complex sample":
        sample = sample + 1e-3j  # its imaginary part is not dropped: the sample is refused
        error = TypeError
    else:
        sample = np.ones(7)
        error = ValueError
    with pytest.raises(error):
        est.update(when, sample)
    assert est.n_skipped == twin.n_skipped
    for j in range(20, T):  # the next good samples are taken as if the refused one had never come
        assert_same(est.update(t[j], data[j]), twin.update(t[j], data[j]), atol=0.0)


@pytest.mark.parametrize("name", STREAMING)
def test_run_is_atomic(name):
    est, kind = make(name)
    twin, _ = make(name)
    t, data = _log(kind)
    est.run(t[:20], data[:20])
    twin.run(t[:20], data[:20])
    bad = data[20:].copy()
    bad[5] = 2.0 * bad[5] if kind not in ("directions", "one-direction") else np.zeros_like(bad[5])
    with pytest.raises(MeasurementError, match=r"^sample 5 \(t = "):
        est.run(t[20:], bad)
    with pytest.raises(TypeError):
        est.run(t[20:], data[20:] + 0j)
    assert_same(est.run(t[20:], data[20:]), twin.run(t[20:], data[20:]), atol=0.0)


@pytest.mark.parametrize("name", sorted(set(NAMES) - set(STREAMING)))
def test_a_batch_estimator_refuses_a_bad_log_whole(name):
    est, kind = make(name)
    t, data = _log(kind)
    bad = data.copy()
    bad[5] = 2.0 * bad[5] if kind != "directions" else np.zeros_like(bad[5])  # a direction's length is free
    with pytest.raises(MeasurementError, match=r"^sample 5 \(t = "):
        est.run(t, bad)
    with pytest.raises(TypeError, match=r"must be real numbers; got complex"):
        est.run(t, data + 0j)
    with pytest.raises(TypeError, match=r"must be real numbers; got text"):
        est.run(t.astype(str), data)
    assert_same(est.run(t, data), make(name)[0].run(t, data), atol=0.0)


def test_a_time_given_as_text_is_refused_and_the_next_good_sample_accepted():
    """Issue 23, item 5, as reported: ``update("1.0", q)`` raised a NumPy type error after it had moved the estimator
    to t = 1.0, so that the next good sample (at 1.0) was refused as not after it."""
    est = SarrasEstimator(J, gains=ObserverGains.constant(2.0, 20.0, n=3))
    _, q = _log("quaternion")
    est.update(0.5, q[0])
    with pytest.raises(TypeError, match=r"a sample's time must be real numbers; got text: \['1.0'\]"):
        est.update("1.0", q[1])
    assert est.update(1.0, q[1]).status == Status.CORRECTED


def test_a_complex_sample_is_refused_not_truncated():
    """Issue 23, item 5: a complex quaternion was accepted with its imaginary part dropped."""
    est = SarrasEstimator(J, gains=ObserverGains.constant(2.0, 20.0, n=3))
    t, q = _log("quaternion")
    with pytest.raises(TypeError, match=r"a sample must be real numbers; got complex"):
        est.update(0.0, q[0] + 0.5j)
    with pytest.raises(TypeError, match=r"measurements must be real numbers; got complex"):
        est.run(t, q.astype(complex))
    with pytest.raises(TypeError, match=r"torque must be real numbers; got complex"):
        est.update(0.0, q[0], [0.0, 1j, 0.0])
    assert np.isnan(est.state.t)  # nothing was taken


@pytest.mark.parametrize(
    ("make_bad", "match"),
    [
        (lambda: SarrasEstimator(J, gains=ObserverGains.constant(1.0, 1.0, n=3), torque_hold="cubic"), "torque_hold"),
        (lambda: SarrasEstimator(J, gains=ObserverGains.constant(1.0, 1.0, n=3), measurement="gyro"), "measurement"),
        (lambda: MEKF(J, model="ballistic"), "model"),
        (lambda: DifferencingEstimator(scheme="forward"), "scheme"),
        (lambda: SingleDirectionEstimator(J, method="magic"), "method"),
    ],
)
def test_word_options_are_checked_against_their_literal_type(make_bad, match):
    with pytest.raises(ValueError, match=rf"^{match} must be one of [a-z, ]+; got '"):
        make_bad()


@pytest.mark.parametrize("angle", [90.0, -1.0, float("nan")])
@pytest.mark.parametrize(
    "make",
    [
        lambda a: SarrasEstimator(J, gains=ObserverGains.constant(1.0, 1.0, n=3), min_angle_deg=a),
        lambda a: SupervisedKalmanEstimator(J, rate_hz=RATE, measurement_noise=1e-3, min_angle_deg=a),
        lambda a: MEKF(J, min_angle_deg=a),
        lambda a: MinimumEnergyFilter(J, min_angle_deg=a),
    ],
)
def test_the_least_angle_between_directions_is_checked_alike(make, angle):
    with pytest.raises(ValueError, match=r"^min_angle_deg must be in \[0, 90\); got "):
        make(angle)


def test_a_missing_sample_right_after_a_restart_is_unavailable_not_predicted():
    """After a step that could not be taken (a finite but absurd torque: 'restarted'), the next sample missing had
    status 'predicted' with a NaN rate, in run and in update: NaN is 'unavailable' (the contract)."""
    t = np.arange(0.0, 0.2, 0.01)
    q = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_quat()
    tau = np.zeros((t.size, 3))
    tau[8] = 1e300
    q[10] = np.nan
    J = np.diag([1.0, 2.0, 3.0])
    gains = sensor_gains(np.eye(3), rate_hz=100.0, measurement_noise=1e-3, bandwidth_hz=1.0)
    for make in (
        lambda: SarrasEstimator(J, gains=gains),
        lambda: SupervisedKalmanEstimator(J, rate_hz=100.0, measurement_noise=1e-3),
    ):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            W, S = make().run(t, q, tau)
            one = make()
            by_update = [one.update(a, b, c) for a, b, c in zip(t, q, tau, strict=True)]
        assert [Status(s) for s in S[9:12]] == [Status.RESTARTED, Status.UNAVAILABLE, Status.CORRECTED]
        assert [e.status for e in by_update[9:12]] == [Status.RESTARTED, Status.UNAVAILABLE, Status.CORRECTED]
        no_rate = ~np.isfinite(W).all(axis=1)
        assert not np.isin(S[no_rate], [Status.CORRECTED, Status.PREDICTED]).any()
