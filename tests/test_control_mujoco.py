"""MuJoCo as an independent plant (extra ``omegahat[mujoco]``): its free-floating body against omegahat's CF4
integrator, open loop (torque-free and under a held torque) and in the closed loop of ``omegahat.lab.control``.

Independent references: MuJoCo integrates its own multibody equations (RK4, its quaternion exponential); the
torque-free motion conserves the inertial angular momentum ``R J ω`` and the kinetic energy.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco", reason="MuJoCo is the optional extra omegahat[mujoco]")

from omegahat import so3
from omegahat.lab.control import detumble, run_scenario, settling_time
from omegahat.lab.control.mujoco_plant import MujocoPlant
from omegahat.simulation.rigid_body import RigidBody, integrate

J = np.diag([300.0, 250.0, 200.0])


def _mujoco_run(plant, R0, w0, tau, h, steps):
    plant.reset(R0, w0)
    R, W = [], []
    for _ in range(steps):
        plant.advance(tau, h)
        r, w = plant.state()
        R.append(r)
        W.append(w)
    return np.array(R), np.array(W)


@pytest.mark.parametrize("inertia", [J, np.array([[300.0, 12.0, -5.0], [12.0, 250.0, 8.0], [-5.0, 8.0, 200.0]])])
def test_torque_free_rotation_agrees_with_our_integrator(inertia):
    """20 s of free tumbling at 1 rad/s (near the intermediate axis): attitudes within 1e-9 rad and rates within
    1e-10 rad/s of CF4; MuJoCo's own momentum R J ω and energy constant to 1e-9 relative."""
    R0 = so3.exp([0.3, -1.1, 0.7])
    w0 = np.array([0.05, 1.0, -0.1])
    plant = MujocoPlant(inertia, timestep=1e-3)
    R, W = _mujoco_run(plant, R0, w0, np.zeros(3), 0.5, 40)
    t = 0.5 * np.arange(41)
    ours = integrate(RigidBody(inertia), R0, w0, t, max_step=1e-3)
    angle = np.linalg.norm(so3.log(np.swapaxes(ours.R[1:], -1, -2) @ R), axis=-1)
    assert angle.max() < 1e-9
    np.testing.assert_allclose(W, ours.omega[1:], atol=1e-10)
    L = np.einsum("tij,jk,tk->ti", R, inertia, W)
    L0 = R0 @ inertia @ w0
    assert np.abs(L - L0).max() < 1e-9 * np.linalg.norm(L0)
    energy = 0.5 * np.einsum("ti,ij,tj->t", W, inertia, W)
    assert np.abs(energy / (0.5 * w0 @ inertia @ w0) - 1.0).max() < 1e-9


def test_held_body_torque_agrees_with_our_integrator():
    """A body-axes torque held over each interval (the loop's zero-order hold) moves both plants alike."""
    R0, w0 = so3.exp([1.0, 0.2, -0.4]), np.array([0.2, -0.3, 0.4])
    tau = np.array([2.0, -5.0, 3.0])
    plant = MujocoPlant(J, timestep=1e-3)
    R, W = _mujoco_run(plant, R0, w0, tau, 0.2, 50)
    ours = integrate(RigidBody(J), R0, w0, 0.2 * np.arange(51), torque=tau, max_step=1e-3)
    assert np.linalg.norm(so3.log(np.swapaxes(ours.R[1:], -1, -2) @ R), axis=-1).max() < 1e-9
    np.testing.assert_allclose(W, ours.omega[1:], atol=1e-10)


def test_closed_loop_detumble_settles_the_same_on_mujoco():
    """The detumble with omegahat's estimate in the loop: the same settling time on both plants (one star-tracker
    sample is 0.2 s) and error angles within 1e-6 rad all along."""
    scenario = detumble()
    ours = run_scenario(scenario, "omegahat", seed=4)
    theirs = run_scenario(scenario, "omegahat", seed=4, plant=MujocoPlant(scenario.J, timestep=1e-3))
    s_ours = settling_time(ours, scenario.angle_tol, scenario.rate_tol)
    s_theirs = settling_time(theirs, scenario.angle_tol, scenario.rate_tol)
    assert s_ours < 180.0 and abs(s_ours - s_theirs) <= 0.2 + 1e-9
    assert np.abs(ours.angle - theirs.angle).max() < 1e-6  # measured 4e-11


def test_hold_interval_must_be_whole_steps():
    plant = MujocoPlant(J, timestep=1e-3)
    with pytest.raises(ValueError, match="not a whole number of MuJoCo steps"):
        plant.advance(np.zeros(3), 0.0105)
