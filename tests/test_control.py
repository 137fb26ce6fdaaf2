"""Velocity-free attitude control (issue 16, part 2): the PD law against closed forms, its saturation, the closed
loop with omegahat's rate estimate (converges) and with the observer's correction reversed (fails), the basin's
slow-down near 180°, and ``omegahat control``.

References: the damped oscillator's closed form for a small rotation about a principal axis, Rodrigues' formula
for the attitude error of a rotation by θ about a, Euler's equations for the feed-forward torque, a central finite
difference for the slew reference's rate. Gains and scenarios are those of ``omegahat.lab.control.scenarios``.
"""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from omegahat import so3
from omegahat.cli import main
from omegahat.interface import Status
from omegahat.lab.cli import control as control_command
from omegahat.lab.control import (
    AttitudePD,
    EstimatorFeed,
    Reference,
    SlewReference,
    WrongSignFeed,
    attitude_error,
    detumble,
    error_angle,
    make_feed,
    pd_gains,
    run_scenario,
    settling_time,
    simulate_closed_loop,
    slew,
)
from omegahat.lab.control.basin import angle_sweep, basin_campaign
from omegahat.lab.control.closed_loop import RigidBodyPlant
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.simulation.rigid_body import RigidBody, integrate
from omegahat.simulation.torque import Torque

J = np.diag([300.0, 250.0, 200.0])


def test_attitude_error_and_angle_are_rodrigues():
    """For R_dᵀR = exp(θ a): e_R = sin θ a (C1) and the error angle is θ, with R_d anywhere."""
    rng = np.random.default_rng(7)
    for theta in (1e-6, 0.3, 2.0, math.pi - 1e-3):
        a = rng.standard_normal(3)
        a /= np.linalg.norm(a)
        R_d = so3.exp(rng.standard_normal(3))
        R = R_d @ so3.exp(theta * a)
        np.testing.assert_allclose(attitude_error(R, R_d), math.sin(theta) * a, atol=1e-14)
        assert error_angle(R, R_d) == pytest.approx(theta, abs=1e-14)


def test_pd_law_with_true_rate_matches_the_damped_oscillator():
    """About principal axis x, from θ₀ = 1e-3 at rest, the law with the true rate (evaluated continuously) gives
    J₁θ̈ + k_ω θ̇ + k_R sin θ = 0: the closed form of the linear oscillator to O(θ₀³) (|Δθ| ≲ 2e-10)."""
    k_R, k_w = pd_gains(J, 0.2, 0.5)
    assert (k_R, k_w) == pytest.approx((250.0 * 0.04, 2 * 0.5 * 0.2 * 250.0))
    law = AttitudePD(J, k_R=k_R, k_omega=k_w, feedforward=False)
    ref = Reference.fixed()
    theta0 = 1e-3
    t = np.linspace(0.0, 30.0, 61)
    traj = integrate(
        RigidBody(J),
        so3.exp([theta0, 0, 0]),
        np.zeros(3),
        t,
        torque=Torque.of_state(lambda s, R, w: law(R, w, ref)),
        max_step=0.01,
    )
    wn, zeta = math.sqrt(k_R / 300.0), k_w / (2.0 * math.sqrt(k_R * 300.0))
    wd = wn * math.sqrt(1.0 - zeta**2)
    expected = theta0 * np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t))
    phi = so3.log(traj.R)
    np.testing.assert_allclose(phi[:, 0], expected, rtol=0, atol=1e-9)
    np.testing.assert_allclose(phi[:, 1:], 0.0, atol=1e-15)
    assert abs(expected[-1]) < 0.1 * theta0  # the comparison covers the decay, not just the start


def test_torque_saturates_per_axis_and_is_linear_below_the_limit():
    law = AttitudePD(J, k_R=10.0, k_omega=90.0, tau_max=5.0, feedforward=False)
    ref = Reference.fixed()
    a = np.array([1.0, -2.0, 0.5]) / math.sqrt(5.25)
    R = so3.exp(2.0 * a)
    w = np.array([0.5, -0.4, 0.3])
    u = -10.0 * math.sin(2.0) * a - 90.0 * w  # Rodrigues + (C4) without feed-forward
    np.testing.assert_allclose(law.unsaturated(R, w, ref), u, atol=1e-12)
    np.testing.assert_array_equal(law(R, w, ref), 5.0 * np.sign(u))  # every |u_i| > 5: all at the limit
    small_R, small_w = so3.exp(1e-3 * a), np.array([1e-3, 0.0, -2e-3])
    u_small = -10.0 * math.sin(1e-3) * a - 90.0 * small_w
    np.testing.assert_allclose(law(small_R, small_w, ref), u_small, atol=1e-13)
    assert np.all(np.abs(u_small) < 5.0)


def test_slew_reference_rate_is_the_derivative_of_its_attitude_and_feedforward_tracks_it():
    """ω_d = vee(R_dᵀ Ṙ_d) by central differences; started on the reference, the law's feed-forward alone keeps
    the body on it (Euler's equations integrated by CF4 with the law evaluated continuously)."""
    ref = SlewReference((1.0, 1.0, 1.0), math.pi, 60.0)
    for t in (5.0, 20.0, 31.0, 55.0):
        d = 1e-5
        dR = (ref(t + d).R_d - ref(t - d).R_d) / (2 * d)
        np.testing.assert_allclose(so3.vee(ref(t).R_d.T @ dR), ref(t).omega_d, atol=1e-8)
        dw = (ref(t + d).omega_d - ref(t - d).omega_d) / (2 * d)
        np.testing.assert_allclose(dw, ref(t).omega_dot_d, atol=1e-8)
    assert error_angle(ref(60.0).R_d, np.eye(3)) == pytest.approx(math.pi, abs=1e-12)
    assert ref.peak_acceleration == pytest.approx(2 * math.pi**2 / 3600.0)
    law = AttitudePD(J, k_R=10.0, k_omega=90.0)
    t = np.linspace(0.0, 60.0, 31)
    tau = Torque.of_state(lambda s, R, w: law(R, w, ref(s)))
    traj = integrate(RigidBody(J), np.eye(3), np.zeros(3), t, torque=tau, max_step=0.01)
    errors = [error_angle(traj.R[j], ref(t[j]).R_d) for j in range(t.size)]
    assert max(errors) < 1e-7


def test_detumble_with_omegahat_converges_like_the_gyro():
    """From 2 rad/s and a 130° error, 5 Hz star tracker at 10 arcsec: with ω̂ the loop settles (error ≤ 1e-3 rad,
    rate ≤ 1e-3 rad/s) and ends pointed to 1e-4 rad and at rest to 1e-5 rad/s, within 5 s of the gyro's loop."""
    scenario = detumble()
    runs = {name: run_scenario(scenario, name, seed=1) for name in ("gyro", "omegahat")}
    settle = {name: settling_time(run, scenario.angle_tol, scenario.rate_tol) for name, run in runs.items()}
    assert settle["omegahat"] < 180.0  # measured 134.8 s
    assert abs(settle["omegahat"] - settle["gyro"]) < 5.0  # measured 0.4 s
    end = runs["omegahat"]
    assert end.angle[-1] < 1e-4 and np.linalg.norm(end.omega[-1]) < 1e-5
    assert np.abs(end.omega_hat[-50:] - end.omega[-50:]).max() < 1e-4  # the estimate followed the body
    assert np.max(np.abs(end.tau)) == pytest.approx(scenario.tau_max)  # the detumble used the full torque


def test_detumble_with_the_wrong_sign_observer_fails():
    """The same loop, the observer's correction reversed (the printed output map's sampled counterpart): it never
    settles, and the rate it feeds is wrong by more than the body's rate."""
    scenario = detumble()
    bad = run_scenario(scenario, "wrong-sign", seed=1)
    assert settling_time(bad, scenario.angle_tol, scenario.rate_tol) == math.inf
    assert bad.diverged or bad.angle[-20:].min() > 0.1  # measured: still 2.4 rad off at 200 s
    assert np.linalg.norm(bad.omega_hat[-1] - bad.omega[-1]) > 1.0
    good = run_scenario(scenario, "observer", seed=1)  # the same observer with the correct sign settles
    assert settling_time(good, scenario.angle_tol, scenario.rate_tol) < 180.0


def test_slew_with_omegahat_tracks_and_ends_at_180_degrees():
    scenario = slew()
    run = run_scenario(scenario, "omegahat", seed=2)
    assert settling_time(run, scenario.angle_tol, scenario.rate_tol) < 60.0  # settled on the moving reference
    final = so3.exp(math.pi * np.ones(3) / math.sqrt(3.0))
    assert error_angle(run.R[-1], final) < 1e-4


def test_basin_settles_everywhere_sampled_and_slows_down_towards_180_degrees():
    scenario = detumble(horizon=300.0)
    result = basin_campaign(scenario, ("gyro",), 4, seed=11)
    assert result.converged().all()
    assert np.all((result.rest_angle >= 0.0) & (result.rest_angle <= math.pi))  # every run came to rest
    again = basin_campaign(scenario, ("gyro",), 2, seed=11)  # the same seed, the same first runs
    np.testing.assert_array_equal(again.settle, result.settle[:2])
    sweep = angle_sweep(scenario, ("gyro",), (90.0, 170.0, 179.9))[:, 0]
    assert sweep[0] < sweep[1] < sweep[2] < scenario.horizon  # measured 50.6, 76.0, 128 s


def test_control_command_writes_figures_and_summary(tmp_path, capsys, monkeypatch):
    # one of the sweep's six angles and one basin run: the sweep and the basin are tested above; this test is the
    # command's files
    monkeypatch.setattr(control_command, "SWEEP_DEG", (179.9,))
    assert main(["control", "--out", str(tmp_path), "--runs", "1"]) == 0
    out = capsys.readouterr().out
    assert "detumble  omegahat" in out and "basin gyro" in out
    for name in ("detumble_error", "detumble_rates", "detumble_torque", "slew_error", "basin"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    summary = (tmp_path / "summary.md").read_text()
    assert "| slew | omegahat |" in summary and "## Basin" in summary
    rows = (tmp_path / "scenarios.csv").read_text().splitlines()
    assert rows[0].startswith("scenario,source,settle_s") and len(rows) == 7 and "peak_error_deg" in rows[0]


def test_control_command_without_mujoco_says_how_to_get_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if the extra were not installed
    assert main(["control", "--out", str(tmp_path), "--plant", "mujoco"]) == 2
    assert "pip install 'omegahat[mujoco]'" in capsys.readouterr().err


def test_error_messages():
    with pytest.raises(ValueError, match="natural_frequency"):
        pd_gains(J, -1.0, 0.5)
    with pytest.raises(ValueError, match="tau_max must be a positive number"):
        AttitudePD(J, k_R=1.0, k_omega=1.0, tau_max=0.0)
    with pytest.raises(ValueError, match="k_omega"):
        AttitudePD(J, k_R=1.0, k_omega=-1.0)
    with pytest.raises(ValueError, match="slew axis must not be zero"):
        SlewReference((0.0, 0.0, 0.0), 1.0, 10.0)
    with pytest.raises(ValueError, match="R_d must be a rotation matrix"):
        Reference.fixed(2.0 * np.eye(3))
    with pytest.raises(TypeError, match="estimator must be an omegahat Estimator"):
        EstimatorFeed("gyro")  # type: ignore[arg-type]
    gains = ObserverGains.constant(1.0, 10.0, n=3)
    with pytest.raises(ValueError, match="torque_hold='zero'"):
        EstimatorFeed(SarrasEstimator(J, gains=gains, torque_hold="linear"))
    with pytest.raises(TypeError, match="WrongSignFeed wraps a SarrasEstimator"):
        WrongSignFeed(make_feed("differencing", detumble()).estimator)  # type: ignore[attr-defined]
    with pytest.raises(ValueError, match="unknown rate source 'imu'"):
        make_feed("imu", detumble())
    with pytest.raises(ValueError, match="sigma must be a finite number >= 0"):
        simulate_closed_loop(
            RigidBodyPlant(J), AttitudePD(J, k_R=1.0, k_omega=1.0), make_feed("gyro", detumble()),
            lambda t: Reference.fixed(), np.eye(3), np.zeros(3), horizon=1.0, rate_hz=5.0, sigma=-1.0,
            rng=np.random.default_rng(0),
        )  # fmt: skip
    with pytest.raises(ValueError, match="runs must be a positive integer"):
        basin_campaign(detumble(), ("gyro",), 0)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--runs", "0"], "expected a positive integer, got '0'"),
        (["--runs", "two"], "expected an integer, got 'two'"),
        (["--sigma-arcsec", "-1"], "expected a positive number, got '-1'"),
        (["--natural-frequency", "fast"], "expected a number, got 'fast'"),
        (["--plant", "gazebo"], "invalid choice: 'gazebo'"),
    ],
)
def test_control_command_refuses_bad_arguments(argv, message, capsys):
    with pytest.raises(SystemExit, match="2"):
        main(["control", *argv])
    assert message in capsys.readouterr().err


def test_torque_handed_over_after_the_sample_equals_the_torque_given_with_it():
    """The loop tells the estimator τ_k after computing it from ω̂_k (EstimatorFeed.hold); the estimator's own
    ``run``, given τ_k with sample k, must produce the same estimates: the hand-over changes nothing but the
    order of the calls."""
    scenario = detumble()
    rng = np.random.default_rng(3)
    t = 0.2 * np.arange(60)
    taus = rng.uniform(-5.0, 5.0, (t.size, 3))
    plant = RigidBodyPlant(J)  # the torque held over each interval, as in the loop
    plant.reset(so3.exp([0.3, 0.2, -1.0]), np.array([0.4, -0.2, 0.3]))
    R, W = np.empty((t.size, 3, 3)), np.empty((t.size, 3))
    for k in range(t.size):
        R[k], W[k] = plant.state()
        plant.advance(taus[k], 0.2)
    for name in ("omegahat", "observer"):
        feed = make_feed(name, scenario)
        assert isinstance(feed, EstimatorFeed)
        streamed = np.empty((t.size, 3))
        for k in range(t.size):
            streamed[k] = feed.rate(t[k], R[k], W[k])
            feed.hold(taus[k])
        feed.estimator.reset()
        batch = feed.estimator.run(t, R, torque=taus)
        assert batch.status[0] == Status.UNAVAILABLE  # the feed's stand-in there: the state's ω̂₀ (module docstring)
        np.testing.assert_array_equal(batch.omega[1:], streamed[1:])
        np.testing.assert_array_equal(streamed[0], np.zeros(3))
        assert np.abs(streamed[-10:] - W[-10:]).max() < 1e-6  # and, noise-free, the estimates are right
