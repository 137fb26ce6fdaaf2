"""Identification from the log (issue 24): the likelihood's noise, the quiet-noise bound, the model's expected error,
the decision between the model's filter and differencing, and the two-filter smoother.

References are independent of the code under test: the simulated truth (the noise drawn, the motion integrated by
SciPy's ``Rotation``), the Kalman covariance recursion iterated by hand, and closed forms."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from logmaker import turning_axis_log, two_passes
from omegahat.baselines.differencing import DifferencingEstimator, log_difference
from omegahat.identification import identify, steps
from omegahat.identification.likelihood import Sums, log_likelihood, noise_intensity, steady_rate_error
from omegahat.identification.noise import quiet_noise, window_quantile
from omegahat.identification.smoother import ModelSmoother, combine
from omegahat.observer.kalman import SupervisedKalmanEstimator


def write_quaternions(path, t, q) -> None:
    """A CSV log ``t,qx,qy,qz,qw`` of the times and quaternions (scalar last), every digit kept."""
    np.savetxt(path, np.column_stack([t, q]), delimiter=",", header="t,qx,qy,qz,qw", comments="", fmt="%.17g")


def wandering(rate_hz: float, seconds: float, sigma: float, seed: int, q: float = 0.05):
    """A body whose rate is a random walk (PSD ``q``, (rad/s²)²/Hz), sampled at ``rate_hz`` with white attitude
    noise ``sigma`` (rad per axis): ``(t, R measured (T, 3, 3), ω true (T, 3))``. The motion is integrated on a
    grid 20 times finer than the samples (piecewise-constant rate: exact rotations). The product of the steps is
    taken in blocks of 20 and then by a prefix scan (composition is associative), all in SciPy's vectorised
    ``Rotation``: a loop over 120 000 steps took ten seconds."""
    rng = np.random.default_rng(seed)
    sub = 20
    h = 1.0 / rate_hz / sub
    samples = int(seconds * rate_hz)
    n = samples * sub + 1
    w = np.cumsum(rng.normal(0.0, np.sqrt(q * h), (n, 3)), axis=0) + np.array([0.3, -0.2, 0.4])
    steps = Rotation.from_rotvec(w[:-1] * h)  # step j turns the body from fine time j to j + 1
    block = steps[0::sub]
    for j in range(1, sub):  # each sample interval's 20 steps, in order
        block = block * steps[j::sub]
    R = Rotation.concatenate([Rotation.identity(), block])  # R[k] = block[0] ... block[k-1] once scanned
    d = 1
    while d < len(R):  # Hillis-Steele inclusive scan: R[k] <- R[k - d] R[k]
        R = Rotation.concatenate([R[:d], R[:-d] * R[d:]])
        d *= 2
    omega = w[::sub]
    t = np.arange(len(R)) / rate_hz
    noise = Rotation.from_rotvec(rng.normal(0.0, sigma, (len(R), 3)))
    return t, (R * noise).as_matrix(), omega


def rms(e):
    e = np.asarray(e)
    ok = np.all(np.isfinite(e), axis=1)
    return float(np.sqrt(np.mean(np.sum(e[ok] ** 2, axis=1))))


def test_the_concentrated_noise_maximises_the_likelihood():
    sums = Sums(logdet=-1234.5, nis=4321.0, dof=3000.0)
    ll_hat, s_hat = log_likelihood(sums)
    assert s_hat == pytest.approx(np.sqrt(4321.0 / 3000.0))
    for s in (0.5 * s_hat, 0.9 * s_hat, 1.1 * s_hat, 2.0 * s_hat):
        assert log_likelihood(sums, s)[0] < ll_hat
    assert log_likelihood(Sums(0.0, 1.0, 0.0))[0] == -np.inf  # no innovation: nothing to judge


def test_noise_intensity_is_the_tracking_index_relation():
    # (L2): q = Λ² σ² / h^(2p+1)
    assert noise_intensity("rate", 2.0, 1e-3, 0.01) == pytest.approx(4.0 * 1e-6 / 1e-6)
    assert noise_intensity("acceleration", 2.0, 1e-3, 0.01) == pytest.approx(4.0 * 1e-6 / 1e-10)


@pytest.mark.parametrize("w", [31, 71, 101])
def test_the_window_quantile_is_that_of_the_median_of_chi2_values(w):
    """c_W of (N1) by SciPy's distributions (the order statistic's law) and by sampling medians of χ²₃ draws."""
    from scipy.stats import beta, chi2

    m = (w + 1) // 2
    assert window_quantile(w) == pytest.approx(float(chi2.ppf(beta.ppf(0.1, m, w - m + 1), 3)), rel=1e-12)
    medians = np.median(np.random.default_rng(w).chisquare(3, size=(40_000, w)), axis=1)
    assert window_quantile(w) == pytest.approx(float(np.quantile(medians, 0.1)), rel=0.01)


def test_the_quiet_noise_is_the_noise_where_the_body_rests():
    """White noise of 1 mrad everywhere, fast motion over 60 % of the log: the quiet tenth gives the noise."""
    rng = np.random.default_rng(3)
    rate, n = 100.0, 6000
    t = np.arange(n) / rate
    w = np.zeros((n, 3))
    w[:3600] = np.sin(np.outer(t[:3600], [150.0, 130.0, 110.0])) * 3.0  # a vibration at 17-24 Hz
    R = [Rotation.identity()]
    for k in range(n - 1):
        R.append(R[-1] * Rotation.from_rotvec(w[k] / rate))
    R = Rotation.concatenate(R) * Rotation.from_rotvec(rng.normal(0.0, 1e-3, (n, 3)))
    phi = (R[:-1].inv() * R[1:]).as_rotvec()
    assert quiet_noise(t, phi) == pytest.approx(1e-3, rel=0.2)
    moving = (R[:3600][:-1].inv() * R[:3600][1:]).as_rotvec()
    assert quiet_noise(t[:3600], moving) > 3e-3  # no rest: an upper bound, far above the noise


def test_steady_rate_error_equals_the_kalman_recursion_iterated():
    """The DARE's filtered rate variance against the Kalman covariance recursion iterated to convergence."""
    h, sigma, lam = 0.01, 1e-3, 3.0
    q = noise_intensity("rate", lam, sigma, h)
    F = np.array([[1.0, h], [0.0, 1.0]])
    Q = q * np.array([[h**3 / 3, h**2 / 2], [h**2 / 2, h]])
    H = np.array([[1.0, 0.0]])
    P = np.eye(2)
    for _ in range(5000):
        P = F @ P @ F.T + Q
        K = P @ H.T / (H @ P @ H.T + sigma**2)
        P = (np.eye(2) - K @ H) @ P
    assert steady_rate_error("rate", lam, sigma, h) == pytest.approx(np.sqrt(3 * P[1, 1]), rel=1e-6)


def test_the_noise_of_a_noisy_log_is_identified_and_its_model_runs():
    """100 Hz, 3 mrad, a slowly wandering rate: σ identified within 10 %, the model's filter runs, and it is more
    accurate than backward differencing on the truth by far."""
    t, R, omega = wandering(100.0, 40.0, 3e-3, seed=1, q=0.02)
    ident = identify(t, R, "matrix")
    assert ident.chosen.model == "rate"
    assert ident.chosen.sigma == pytest.approx(3e-3, rel=0.1)
    assert ident.use_model, ident.reason
    est = ident.estimator()
    assert isinstance(est, SupervisedKalmanEstimator)
    W = est.run(t, R).omega
    diff = log_difference(t, R, scheme="backward")
    assert rms(W[200:] - omega[200:]) < 0.3 * rms(diff[200:] - omega[200:])
    assert "model identified from the log" in ident.explain() and "the model's filter runs" in ident.explain()


def test_a_log_without_measurement_noise_runs_backward_differencing():
    """Noise-free attitudes of a wandering rate at 30 Hz: no noise to remove, the model only extrapolates: backward
    differencing runs (and the explanation says why)."""
    t, R, _ = wandering(30.0, 60.0, 0.0, seed=2, q=2.0)
    ident = identify(t, R, "matrix")
    assert not ident.use_model
    assert isinstance(ident.estimator(), DifferencingEstimator)
    assert "backward differencing runs" in ident.explain()


def test_with_the_inertia_the_dynamic_model_wins_on_a_torque_free_body():
    """Euler's equations, no torque, J known, 2 mrad noise: the likelihood prefers a dynamic model to the kinematic
    ones, and its filter runs."""
    J = np.diag([3.0, 2.0, 1.0])
    from scipy.integrate import solve_ivp

    def rhs(_, y):
        w = y[:3]
        return np.linalg.solve(J, np.cross(J @ w, w))

    t = np.arange(0.0, 30.0, 0.01)
    sol = solve_ivp(rhs, (0, 30), [0.5, -1.0, 1.5], t_eval=t, rtol=1e-11, atol=1e-12)
    omega = sol.y.T
    R = [Rotation.identity()]
    for k in range(t.size - 1):  # the midpoint rate over each step (the rate changes slowly: 1e-6 accurate)
        R.append(R[-1] * Rotation.from_rotvec(0.5 * (omega[k] + omega[k + 1]) * 0.01))
    rng = np.random.default_rng(5)
    Rm = (Rotation.concatenate(R) * Rotation.from_rotvec(rng.normal(0, 2e-3, (t.size, 3)))).as_matrix()
    ident = identify(t, Rm, "matrix", J=J)
    assert ident.chosen.model in ("dynamic", "dynamic+disturbance")
    assert ident.use_model
    best_kinematic = min(c.bic for c in ident.candidates if c.model in ("rate", "acceleration"))
    assert ident.chosen.bic < best_kinematic


def test_combine_is_the_information_weighted_mean():
    rng = np.random.default_rng(7)
    A, B = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    Pf, Pb = A @ A.T + np.eye(3), B @ B.T + np.eye(3)
    wf, wb = rng.normal(size=3), rng.normal(size=3)
    by_hand = np.linalg.inv(np.linalg.inv(Pf) + np.linalg.inv(Pb)) @ (np.linalg.solve(Pf, wf) + np.linalg.solve(Pb, wb))
    out = combine(wf[None], Pf[None], wb[None], Pb[None])
    np.testing.assert_allclose(out[0], by_hand, rtol=1e-12)
    nan = np.full((1, 3), np.nan)
    np.testing.assert_array_equal(combine(nan, Pf[None], wb[None], Pb[None])[0], wb)  # one pass only: it alone
    assert np.all(np.isnan(combine(nan, Pf[None], nan, Pb[None])))


def test_the_smoother_has_no_lag_and_beats_the_filter():
    """A wandering rate, 2 mrad at 100 Hz: the two-filter smoother is more accurate than the causal filter, and its
    best time shift against the truth is zero (the filter's is a lag)."""
    t, R, omega = wandering(100.0, 30.0, 2e-3, seed=4, q=0.5)
    ident = identify(t, R, "matrix")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        causal = ident.model_estimator().run(t, R).omega
    smooth = ModelSmoother(ident).run(t, R).omega
    inner = slice(100, -100)
    assert rms(smooth[inner] - omega[inner]) < 0.8 * rms(causal[inner] - omega[inner])

    def best_shift(W):
        return min(range(-5, 6), key=lambda s: rms(W[inner] - np.roll(omega, s, axis=0)[inner]))

    assert best_shift(smooth) == 0
    assert best_shift(causal) > 0


def test_the_smoother_is_exact_on_a_constant_rate():
    t = np.arange(0.0, 10.0, 0.01)
    omega = np.array([0.2, -0.5, 0.3])
    R = Rotation.from_rotvec(np.outer(t, omega)).as_matrix()
    R_noisy = Rotation.from_matrix(R) * Rotation.from_rotvec(np.random.default_rng(0).normal(0, 1e-4, (t.size, 3)))
    ident = identify(t, R_noisy.as_matrix(), "matrix")
    W = ModelSmoother(ident).run(t, R).omega  # the noise-free attitudes through the identified smoother
    np.testing.assert_allclose(W[5:-5], np.tile(omega, (t.size - 10, 1)), atol=1e-8)


def test_smooth_without_a_model_is_the_logs_wiener_smoother_and_the_fit_start_is_kept(tmp_path, capsys):
    """Where the model is declined (noise-free attitudes: differencing runs), ``--smooth`` has no model to smooth
    with: it writes the log's own Wiener smoother (omegahat.identification.spectral, tested against closed forms
    in test_spectral.py) and says so; it once ran the declined model's smoother, which diverged after fast turns at
    a few hertz (estimates of 1e4 rad/s written as corrected). Its error against the true rate is within 15 % of
    SciPy's RotationSpline's on this rough (random-walk) rate. The causal default (backward differencing) writes
    the fit start's rate at the first sample instead of NaN."""
    from omegahat.cli import main
    from omegahat.identification.spectral import SpectralSmoother

    t, R, omega = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    q = Rotation.from_matrix(R).as_quat()
    src = tmp_path / "log.csv"
    write_quaternions(src, t, q)
    dst = tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), "--smooth", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "backward differencing runs" in out and "the log's own Wiener smoother" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    read_back = np.loadtxt(src, delimiter=",", skiprows=1)
    np.testing.assert_allclose(written, SpectralSmoother().run(read_back[:, 0], read_back[:, 1:]).omega, atol=1e-9)
    from scipy.spatial.transform import RotationSpline

    spline = RotationSpline(t, Rotation.from_quat(read_back[:, 1:]))(t, 1)
    assert rms(written - omega) < 1.15 * rms(spline - omega)
    assert main(["estimate", str(src), "-o", str(dst), "--no-progress"]) == 0
    causal = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    assert np.all(np.isfinite(causal[0])) and "estimator used: backward differencing" in capsys.readouterr().out
    taps = identify(read_back[:, 0], read_back[:, 1:], "quaternion").causal.taps  # (C3) of this log
    steps = np.diff(t, prepend=np.nan)[1:]
    np.testing.assert_allclose(
        causal[1:], two_passes(log_difference(t, R, scheme="backward")[1:], steps, taps), atol=1e-9
    )


def test_a_noise_free_log_with_the_inertia_is_not_restarted_at_every_sample():
    """Euler's equations integrated by SciPy, J known, a smooth torque the log does not give, no measurement noise:
    the identified dynamic model's filter runs and beats backward differencing against SciPy's rate. Its supervisor
    once measured the disagreement with the observer against the noise floor: the observer's lag exceeded it at
    every other sample (1499 restarts here; 2.0 times differencing's error on the plant's logs)."""
    J = np.diag([3.0, 2.0, 1.0])
    from scipy.integrate import solve_ivp

    def rhs(time, y):  # Euler's equations and dR/dt = R [ω]×, R flattened
        w, R = y[:3], y[3:].reshape(3, 3)
        wx = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
        tau = np.array([0.3 * np.sin(0.7 * time), 0.2 * np.cos(0.4 * time), -0.1])  # not in the log
        return np.concatenate([np.linalg.solve(J, np.cross(J @ w, w) + tau), (R @ wx).ravel()])

    t = np.arange(0.0, 30.0, 0.01)
    y0 = np.concatenate([[0.5, -1.0, 1.5], np.eye(3).ravel()])
    y = solve_ivp(rhs, (0, 30), y0, t_eval=t, method="DOP853", rtol=1e-13, atol=1e-14).y.T
    omega = y[:, :3]
    Rm = Rotation.from_matrix(y[:, 3:].reshape(-1, 3, 3)).as_matrix()  # orthonormalised: attitudes to ~1e-11 rad
    ident = identify(t, Rm, "matrix", J=J)
    assert ident.chosen.model in ("dynamic", "dynamic+disturbance") and ident.use_model
    est = ident.estimator()
    W = est.run(t, Rm).omega
    diff = log_difference(t, Rm, scheme="backward")
    assert est.restarts < 10
    assert rms(W[100:] - omega[100:]) < 0.2 * rms(diff[100:] - omega[100:])


def test_the_smoothers_expect_their_error_and_the_lower_expectation_is_kept():
    """A random-walk rate (the rate model's own motion) under 1 mrad of noise: the model's smoother (T1) and the
    log's own Wiener smoother (S7) each expect their measured error within a factor 2 (against the true rate,
    inside the log); ``ChosenSmoother`` returns exactly the one expecting less. A constant rate: the model's
    smoother (its expectation 2e-5 rad/s against the spectrum's 4e-2) is kept."""
    from omegahat.identification.smoother import ChosenSmoother
    from omegahat.identification.spectral import SpectralSmoother

    t, R, omega = wandering(100.0, 60.0, 1e-3, seed=3, q=0.05)
    ident = identify(t[:8192], R[:8192], "matrix")
    inner = slice(100, -100)
    for smoother in (ModelSmoother(ident), SpectralSmoother()):
        measured = rms(smoother.run(t, R).omega[inner] - omega[inner])
        assert 0.5 < smoother.expected_rms / measured < 2.0
    chosen = ChosenSmoother(ident)
    out = chosen.run(t, R).omega
    lower = min(chosen.expected, key=chosen.expected.get)
    assert chosen.chosen is {"model": chosen.model, "spectrum": chosen.spectrum}[lower]
    np.testing.assert_array_equal(out, chosen.chosen.run(t, R).omega)

    t = np.arange(0.0, 20.0, 0.01)
    w = np.array([0.3, -0.2, 0.5])
    R = (
        Rotation.from_rotvec(np.outer(t, w))
        * Rotation.from_rotvec(np.random.default_rng(4).normal(0, 1e-3, (t.size, 3)))
    ).as_matrix()
    chosen = ChosenSmoother(identify(t, R, "matrix"))
    out = chosen.run(t, R).omega
    assert chosen.chosen is chosen.model and chosen.expected["model"] < 1e-3 < chosen.expected["spectrum"]
    assert rms(out - w) < 1e-4


def test_smooth_with_a_model_says_which_smoother_it_kept(tmp_path, capsys):
    """``--smooth`` on a log whose model the identification accepts (a constant rate under 1 mrad of noise) runs
    both smoothers, keeps the model's (it expects far less error) and says so with both expectations."""
    from omegahat.cli import main

    t = np.arange(0.0, 20.0, 0.01)
    w = np.array([0.3, -0.2, 0.5])
    q = (
        Rotation.from_rotvec(np.outer(t, w))
        * Rotation.from_rotvec(np.random.default_rng(6).normal(0, 1e-3, (t.size, 3)))
    ).as_quat()
    src, dst = tmp_path / "log.csv", tmp_path / "o.csv"
    write_quaternions(src, t, q)
    assert main(["estimate", str(src), "-o", str(dst), "--smooth", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "the one expecting the lower error kept" in out
    assert "estimator used: the identified model's smoother" in out and "the Wiener smoother" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    assert rms(written - w) < 1e-4


def test_a_pass_that_ran_away_is_not_averaged_in():
    """(T1) where one pass's covariance is singular or indefinite (a pass that ran away: rounding leaves its huge
    covariance rank-deficient) takes the other pass alone; it once raised numpy's LinAlgError on a direction log."""
    Pb = np.diag([0.2, 0.3, 0.1])
    wf, wb = np.array([-421.0, 4884.0, 5568.0]), np.array([0.1, -0.2, 0.3])
    u = np.array([1.0, 11.0, 13.5])
    for Pf in (1e14 * np.outer(u, u), np.diag([1.0, -1.0, 1.0])):  # rank one; indefinite
        np.testing.assert_array_equal(combine(wf[None], Pf[None], wb[None], Pb[None])[0], wb)


def aligned_attitudes(b: np.ndarray, V: np.ndarray) -> np.ndarray:
    """Each sample's least-squares attitude ``(T, 3, 3)`` from its directions ``b (T, n, 3)`` of ``V (n, 3)``, by
    SciPy's ``align_vectors`` (the reference the project's own Wahba solver is checked against)."""
    unit_v = V / np.linalg.norm(V, axis=1, keepdims=True)
    return np.stack([
        Rotation.align_vectors(unit_v, bk / np.linalg.norm(bk, axis=1, keepdims=True))[0].as_matrix() for bk in b
    ])  # fmt: skip


def _directions_log(tmp_path, t, R):
    """A direction log of two inertial directions (gravity's reaction and a magnetic field), the CLI's npz."""
    V = np.array([[0.0, 0.0, 9.83], [-0.9, 15.5, -41.3]])
    src = tmp_path / "dirs.npz"
    np.savez(src, t=t, b=np.einsum("tji,nj->tni", R, V))
    return src, V, "--references=0,0,9.83;-0.9,15.5,-41.3"


def test_smooth_on_directions_without_a_model_is_the_wiener_smoother_of_their_attitudes(tmp_path, capsys):
    """Directions whose model is declined (noise-free: differencing runs): ``--smooth`` writes the log's own Wiener
    smoother of each sample's least-squares attitude, the same as the smoother run on the attitudes SciPy's
    ``align_vectors`` solves from the directions, and says so. It once ran the declined model's smoother there,
    which ran away on real motion-capture logs turned into directions (1e6 times the spline's error)."""
    from omegahat.cli import main
    from omegahat.identification.spectral import SpectralSmoother

    t, R, omega = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    src, V, refs = _directions_log(tmp_path, t, R)
    dst = tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), refs, "--smooth", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "backward differencing runs" in out and "the log's own Wiener smoother" in out
    assert "least-squares attitude from its directions" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    b = np.load(src)["b"]
    aligned = aligned_attitudes(b, V)
    np.testing.assert_allclose(written, SpectralSmoother().run(t, aligned).omega, atol=1e-9)
    from scipy.spatial.transform import RotationSpline

    spline = RotationSpline(t, Rotation.from_matrix(R))(t, 1)
    assert rms(written - omega) < 1.15 * rms(spline - omega)


def test_the_default_on_directions_without_a_model_differences_their_attitudes(tmp_path, capsys):
    """Directions whose model is declined: the default differences each sample's least-squares attitude through the
    log's causal filter, as it does attitudes, and says so: its rows equal (D4) on differencing of the attitudes
    SciPy's ``align_vectors`` solves from the directions. It once ran the declined model's filter there (on real
    motion-capture logs turned into directions, up to 3.7 times differencing's error at 9.5 Hz)."""
    from omegahat.cli import main

    t, R, _ = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    src, V, refs = _directions_log(tmp_path, t, R)
    dst = tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), refs, "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert (
        "backward differencing runs" in out and "backward differencing of each sample's least-squares attitude" in out
    )
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    b = np.load(src)["b"]
    aligned = aligned_attitudes(b, V)
    taps = identify(t, b, "directions", references=V).causal.taps
    steps = np.diff(t)
    np.testing.assert_allclose(
        written[1:], two_passes(log_difference(t, aligned, scheme="backward")[1:], steps, taps), atol=1e-9
    )


def test_directions_in_the_sensors_units_are_identified_as_unit_directions(tmp_path, capsys):
    """An accelerometer (m/s²) and a magnetometer (µT) as logged, each component with its own white noise: the
    identification is that of the same directions made unit by NumPy (every estimator reads them unit), and the
    default runs the model at a small fraction of backward differencing's error. It once fed the sensors' units to
    the likelihood: log-likelihood -3e10, the model declined, and here the default 2.7 rad/s off (1.0e-3 now,
    backward differencing 2.95)."""
    from omegahat.cli import main

    t = np.arange(0.0, 10.0, 0.01)
    w = np.array([0.3, -0.2, 0.4])
    R = Rotation.from_rotvec(np.outer(t, w)).as_matrix()
    src, V, refs = _directions_log(tmp_path, t, R)
    with np.load(src) as f:
        b = f["b"]
    rng = np.random.default_rng(3)
    b[:, 0] += rng.normal(0.0, 0.02, (t.size, 3))  # m/s²
    b[:, 1] += rng.normal(0.0, 0.3, (t.size, 3))  # µT
    np.savez(src, t=t, b=b)
    unit = identify(t, b / np.linalg.norm(b, axis=2, keepdims=True), "directions", references=V)
    ident = identify(t, b, "directions", references=V)
    assert ident.use_model and [c.log_likelihood for c in ident.candidates] == pytest.approx(
        [c.log_likelihood for c in unit.candidates], rel=1e-9
    )
    dst = tmp_path / "o.csv"
    assert main(["estimate", str(src), "-o", str(dst), refs, "--no-progress"]) == 0
    assert "the model's filter runs" in capsys.readouterr().out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    aligned = aligned_attitudes(b, V)
    backward = log_difference(t, aligned, scheme="backward")
    assert rms(written[100:] - w) < 0.05 * rms(backward[100:] - w)


def test_directions_of_attitudes_are_identified_as_the_attitudes(tmp_path, capsys):
    """Two directions computed from noisy attitudes carry the attitude's noise alone, in its three dimensions, which
    a fast enough model follows exactly: the likelihood on them ran off to the floor of the noise (1.1e-5 rad for
    1 mrad, tracking index 348), the model was declined and the default was 0.082 rad/s off where the attitudes give
    5.4e-5. (R0) finds them rigid and identifies them as their attitudes; directions with a sensor's own noise are
    not rigid."""
    from omegahat.cli import main
    from omegahat.identification.noise import rigid_directions

    t = np.arange(0.0, 20.0, 0.01)
    w = np.array([0.3, -0.2, 0.5])
    V = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    rng = np.random.default_rng(0)
    R = (Rotation.from_rotvec(np.outer(t, w)) * Rotation.from_rotvec(rng.normal(0.0, 1e-3, (t.size, 3)))).as_matrix()
    b = np.einsum("tji,nj->tni", R, V)
    by_attitude, by_directions = identify(t, R, "matrix"), identify(t, b, "directions", references=V)
    same = [(c.log_likelihood, c.sigma) for c in by_attitude.candidates]
    assert np.allclose([(c.log_likelihood, c.sigma) for c in by_directions.candidates], same, rtol=1e-9, atol=0.0)
    assert by_directions.use_model and by_directions.chosen.sigma == pytest.approx(1e-3, rel=0.15)
    own_noise = np.einsum("tji,nj->tni", R, V) + rng.normal(0.0, 1e-3, b.shape)
    own_noise /= np.linalg.norm(own_noise, axis=2, keepdims=True)
    assert rigid_directions(b, V, 1e-3) and not rigid_directions(own_noise, V, 1e-3)
    src, dst = tmp_path / "b.npz", tmp_path / "o.csv"
    np.savez(src, t=t, b=b)
    assert main(["estimate", str(src), "-o", str(dst), "--references=0,0,1;1,0,0", "--no-progress"]) == 0
    assert "identified as their least-squares attitudes (R0)" in capsys.readouterr().out
    assert by_directions.rigid and not identify(t, own_noise, "directions", references=V).rigid
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    assert rms(written[200:] - w) < 2e-4  # measured 6.0e-5; backward differencing 0.24


def test_smooth_on_directions_with_a_model_keeps_the_model_smoother(tmp_path):
    """Directions of a constant rate under noise: the model is accepted, both smoothers run on the directions (the
    Wiener smoother on their least-squares attitudes), and the model's, expecting far less error, is kept."""
    from omegahat.identification.smoother import ChosenSmoother

    t = np.arange(0.0, 20.0, 0.01)
    w = np.array([0.3, -0.2, 0.5])
    R = Rotation.from_rotvec(np.outer(t, w)).as_matrix()
    V = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    b = np.einsum("tji,nj->tni", R, V) + np.random.default_rng(2).normal(0, 1e-3, (t.size, 2, 3))
    ident = identify(t, b, "directions", references=V)
    assert ident.use_model
    chosen = ChosenSmoother(ident, references=V)
    out = chosen.run(t, b).omega
    assert chosen.chosen is chosen.model and chosen.expected["model"] < chosen.expected["spectrum"]
    assert rms(out[5:-5] - w) < 1e-3


def test_smooth_on_a_log_too_short_to_identify_is_scipys_spline_and_says_so(tmp_path, capsys):
    """12 samples (too few to identify a model or a spectrum): ``--smooth`` is honoured by the rotation spline
    through the attitudes (SciPy's RotationSpline) and the command says so; it once ran the causal fixed-gain
    observer without saying that the smoothing asked for was dropped."""
    from scipy.spatial.transform import RotationSpline

    from omegahat.cli import main

    t = np.arange(12) * 0.01
    q = Rotation.from_rotvec(np.outer(t**2, [0.3, -0.2, 0.5])).as_quat()
    src, dst = tmp_path / "short.csv", tmp_path / "o.csv"
    write_quaternions(src, t, q)
    assert main(["estimate", str(src), "-o", str(dst), "--smooth", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "too few to identify a model or the log's spectrum" in out and "the rotation spline" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    read_back = np.loadtxt(src, delimiter=",", skiprows=1)
    spline = RotationSpline(read_back[:, 0], Rotation.from_quat(read_back[:, 1:]))(read_back[:, 0], 1)
    np.testing.assert_allclose(written, spline, atol=1e-12)


def test_smooth_with_the_model_asked_for_is_the_models_smoother(tmp_path, capsys):
    """``--estimator omegahat --smooth`` (the model's filter always) runs the identified model's smoother even where
    the identification declines the model, and says so with its expected error; the rows equal
    :class:`ModelSmoother` on the identification of the same rows."""
    from omegahat.cli import main

    t, R, _ = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    src, dst = tmp_path / "log.csv", tmp_path / "o.csv"
    q = Rotation.from_matrix(R).as_quat()
    write_quaternions(src, t, q)
    args = ["estimate", str(src), "-o", str(dst), "--smooth", "--estimator", "omegahat", "--no-progress"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "backward differencing runs" in out and "--estimator omegahat asks for the model" in out
    assert "estimator used: the identified model's smoother (offline, zero lag; expected RMS error" in out
    read_back = np.loadtxt(src, delimiter=",", skiprows=1)
    ident = identify(read_back[:, 0], read_back[:, 1:], "quaternion")
    expected = ModelSmoother(ident).run(read_back[:, 0], read_back[:, 1:]).omega
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    np.testing.assert_allclose(written, expected, atol=1e-9)


def test_smooth_says_how_it_read_jittered_stamps(tmp_path, capsys):
    """A log sampled regularly at 30 Hz whose stamps are rounded to 10 ms (steps of 30 and 40 ms, as a coarse
    export writes them): ``--smooth`` says it read regular samples with jittered stamps (S8) and writes rates
    closer to the true ones than SciPy's spline through the rounded stamps."""
    from scipy.spatial.transform import RotationSpline

    from omegahat.cli import main

    t, R, omega = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    stamps = np.round(t, 2)
    q = Rotation.from_matrix(R).as_quat()
    src, dst = tmp_path / "log.csv", tmp_path / "o.csv"
    write_quaternions(src, stamps, q)
    assert main(["estimate", str(src), "-o", str(dst), "--smooth", "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "the log's own Wiener smoother" in out and "read as regular samples with jittered stamps" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    spline = RotationSpline(stamps, Rotation.from_matrix(R))(stamps, 1)
    inner = slice(30, -30)
    assert rms(written[inner] - omega[inner]) < 0.5 * rms(spline[inner] - omega[inner])


def test_the_default_reads_jittered_stamps_and_differences_over_whole_steps(tmp_path, capsys):
    """A noise-free 30 Hz log (differencing runs) whose stamps jitter by up to 20 % of the step: the identification
    reads regular samples with jittered stamps (S8), says so, and differencing takes each interval as whole steps
    (D3): the rows equal differencing at the true times, where the stamps as they are err by far more."""
    from omegahat.cli import main

    t, R, _ = wandering(30.0, 20.0, 0.0, seed=4, q=2.0)
    stamps = t + np.random.default_rng(3).uniform(-0.2, 0.2, t.size) / 30.0
    q = Rotation.from_matrix(R).as_quat()
    src, dst = tmp_path / "log.csv", tmp_path / "o.csv"
    write_quaternions(src, stamps, q)
    assert main(["estimate", str(src), "-o", str(dst), "--no-progress"]) == 0
    out = capsys.readouterr().out
    assert "backward differencing runs" in out and "read as regular samples with jittered stamps" in out
    written = np.loadtxt(dst, delimiter=",", skiprows=1, usecols=(1, 2, 3))
    taps = identify(stamps, q, "quaternion").causal.taps  # (C3) of this log, through which differencing runs
    truth = log_difference(t, R, scheme="backward")
    # the samples' step is the stamps' mean over 600 samples: off 1/30 s by at most 0.4 steps / 599 (6.7e-4)
    steps = np.full(t.size - 1, np.mean(np.diff(stamps)))  # (D3): whole steps of the samples' step
    np.testing.assert_allclose(written[1:], two_passes(truth[1:], steps, taps), rtol=7e-4, atol=1e-9)
    assert np.max(np.abs(log_difference(stamps, R, scheme="backward")[1:] - truth[1:])) > 0.1


@pytest.mark.parametrize("rate", [30.0, 100.0, 286.0])
def test_the_higher_differences_leave_white_noise_to_the_third(rate):
    """(N2) on white noise of 1 mrad alone: the orders agree, so (N1)'s value is kept (within 10 % of the noise)."""
    t = np.arange(0.0, 60.0, 1.0 / rate)
    R = Rotation.from_rotvec(1e-3 * np.random.default_rng(5).standard_normal((t.size, 3)))
    phi = (R[:-1].inv() * R[1:]).as_rotvec()
    assert quiet_noise(t, phi, higher=True) == quiet_noise(t, phi) == pytest.approx(1e-3, rel=0.1)


def test_the_higher_differences_see_the_noise_under_a_smooth_motion():
    """A smooth noise-free turn at 30 Hz has third differences ten times a noise of 0.1 µrad (computed here with
    (N1)'s normalisation over the whole log); under that noise (N1) is the motion's jerk and (N2) gives the noise
    back within 20 %."""
    t = np.arange(0.0, 60.0, 1.0 / 30.0)
    smooth = Rotation.from_rotvec(np.column_stack([np.sin(t), 0.5 * np.cos(1.3 * t), 0.2 * t]))
    clean = (smooth[:-1].inv() * smooth[1:]).as_rotvec()
    third = np.sum(np.diff(clean, n=2, axis=0) ** 2, axis=1)
    assert np.sqrt(np.median(third) / (20.0 * 2.3660)) > 1e-6
    R = smooth * Rotation.from_rotvec(1e-7 * np.random.default_rng(6).standard_normal((t.size, 3)))
    phi = (R[:-1].inv() * R[1:]).as_rotvec()
    assert quiet_noise(t, phi) > 1e-6
    assert quiet_noise(t, phi, higher=True) == pytest.approx(1e-7, rel=0.2)


def test_a_turn_faster_than_the_samples_can_follow_is_named_when_no_model_fits():
    """A body spinning 170° per sample (or flipping 180°): no likelihood is finite, and the error says why."""
    t = np.arange(200) * 0.01
    R = Rotation.from_rotvec(np.outer(t, [0.0, 0.0, np.radians(170.0) / 0.01])).as_matrix()
    with pytest.raises(ValueError, match=r"evaluation failed\): the attitude turns 170° per step \(median\), faster"):
        identify(t, R, "matrix")
    assert steps.too_fast(np.tile([0.0, 0.0, np.radians(80.0)], (5, 1))) == ""


def test_differencings_expected_error_leaves_out_the_step_across_a_gap():
    """(D1) read the increment across a 2 s dropout as one spacing's: on a 240 Hz log with 0.25 mrad of noise it
    expected 6.4 rad/s of backward differencing, where √6 σ / h is 0.15, and so set the model's supervision 40 times
    too loose (a first fix 7 rad/s off, unrestarted). The account with and without the gap is the same."""
    t = np.arange(0.0, 12.0, 1.0 / 240.0)
    w = np.array([0.8, -0.5, 1.2])
    noise = Rotation.from_rotvec(2.5e-4 * np.random.default_rng(5).standard_normal((t.size, 3)))
    q = (Rotation.from_rotvec(np.outer(t, w)) * noise).as_quat()
    whole = identify(t, q, "quaternion").differencing_rms
    q[1200:1680] = np.nan  # 5 s to 7 s
    gap = identify(t, q, "quaternion").differencing_rms
    assert whole == pytest.approx(np.sqrt(6.0) * 2.5e-4 * 240.0, rel=0.1)
    assert gap == pytest.approx(whole, rel=0.02)


def test_a_long_dropout_does_not_decide_the_process_noise():
    """The likelihood's pass restarts after a long dropout (RESTART_GAP): it had counted the fix after a 2 s
    dropout, many times its predicted spread, and the filter's ringing after it, which turned Λ from 0.36 into 224
    and sent the default to differencing at 3.7 times the model's error. With the dropout the identification is the
    gap-free log's."""
    t, q, _ = turning_axis_log(0.0)
    whole = identify(t, q, "quaternion")
    t, q, _ = turning_axis_log(2.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        gap = identify(t, q, "quaternion")
    assert whole.use_model and gap.use_model and gap.chosen.model == whole.chosen.model == "rate"
    assert gap.chosen.tracking_index == pytest.approx(whole.chosen.tracking_index, rel=0.05)


def test_a_glitch_right_after_a_long_dropout_bridges_the_gap_instead():
    """A restarted pass follows the samples after the gap from scratch: where they jump by up to 2.9 rad per step
    for a few samples (a phone's orientation re-converging, held-out TyrEx recordings), the fresh filter's rate passes
    half a turn per step and the pass ends (every Λ failed: 'no model could be fitted'). There the gap is bridged,
    as a settled filter weighs such a glitch."""
    t, q, _ = turning_axis_log(0.25, fs=60.0)
    first = np.flatnonzero(t >= 5.25 - 1e-9)[0]
    q[first + 3 : first + 5] = np.nan  # three fixes after the gap, two samples missing, then the glitch
    wild = Rotation.from_rotvec([[0.0, 2.9, 0.0], [0.3, 0.2, 0.0], [2.2, 0.0, 0.9], [0.4, -0.3, 0.1]])
    q[first + 5 : first + 9] = (wild * Rotation.from_quat(q[first + 5 : first + 9])).as_quat()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        glitch = identify(t, q, "quaternion")
    assert glitch.chosen.model in ("rate", "acceleration") and np.isfinite(glitch.chosen.log_likelihood)
