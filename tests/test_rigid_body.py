"""Rigid body ground truth: invariants, order of accuracy against closed forms and DOP853, torques, sensors.

References used here are independent of the integrator: closed forms (axisymmetric free body, J = I under a
torque along a fixed axis, momentum decay under the torque −cJω) and SciPy's DOP853 on (R, ω), R flattened.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.simulation.rigid_body import RigidBody, cf4_step, integrate
from omegahat.simulation.sensors import directions, noisy_attitudes, noisy_directions
from omegahat.simulation.torque import Torque, as_torque

PAPER_J = [3.0, 2.0, 1.0]
PAPER_OMEGA0 = np.array([2.0, -1.0, 0.6])


def attitude_error(R_a, R_b):
    """Angle (rad) of R_aᵀ R_b, batched."""
    return np.linalg.norm(so3.log(np.swapaxes(R_a, -1, -2) @ R_b), axis=-1)


def axisymmetric_free_motion(a, c, R0, omega0, t):
    """Closed form for J = diag(a, a, c), τ = 0.

    Body: ω(t) = exp(Ω_p t e3×) ω0 with Ω_p = (c − a)/a ω3. Attitude: R(t) = exp(t L×/a) R0 exp(−Ω_p t e3×)
    with L = R0 J ω0; indeed Ṙ = R ((RᵀL)/a − Ω_p e3)× and RᵀL = J ω(t), J ω/a − Ω_p e3 = ω.
    """
    J = np.diag([a, a, c])
    e3 = np.array([0.0, 0.0, 1.0])
    Wp = (c - a) / a * omega0[2]
    L = R0 @ J @ omega0
    R = np.array([so3.exp(tk * L / a) @ R0 @ so3.exp(-Wp * tk * e3) for tk in t])
    omega = np.array([so3.exp(Wp * tk * e3) @ omega0 for tk in t])
    return R, omega


def dop853_reference(J, R0, omega0, t_eval, torque=lambda t, R, w: np.zeros(3)):
    """SciPy DOP853 on y = (vec R, ω) at rtol = atol = 1e-13, with the model written out independently."""
    J = np.asarray(J, float)
    J_inv = np.linalg.inv(J)

    def rhs(t, y):
        R = y[:9].reshape(3, 3)
        w = y[9:]
        W = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
        wdot = J_inv @ (np.cross(J @ w, w) + torque(t, R, w))
        return np.concatenate([(R @ W).ravel(), wdot])

    sol = solve_ivp(
        rhs,
        (t_eval[0], t_eval[-1]),
        np.concatenate([R0.ravel(), omega0]),
        method="DOP853",
        rtol=1e-13,
        atol=1e-13,
        t_eval=t_eval,
    )
    assert sol.success
    return sol.y[:9].T.reshape(-1, 3, 3), sol.y[9:].T


def fitted_order(steps, errors):
    return np.polyfit(np.log(steps), np.log(errors), 1)[0]


# ---------------------------------------------------------------------------------------------------------
# The body


def test_euler_equations_component_form():
    # J1 ω̇1 = (J2 − J3) ω2 ω3 + τ1, and cyclically (textbook component form for principal axes)
    J = np.array([3.0, 2.0, 1.0])
    body = RigidBody(J)
    w = np.array([0.7, -1.3, 2.1])
    tau = np.array([0.1, -0.2, 0.3])
    expected = np.array(
        [
            ((J[1] - J[2]) * w[1] * w[2] + tau[0]) / J[0],
            ((J[2] - J[0]) * w[2] * w[0] + tau[1]) / J[1],
            ((J[0] - J[1]) * w[0] * w[1] + tau[2]) / J[2],
        ]
    )
    np.testing.assert_allclose(body.omega_dot(w, tau), expected, rtol=1e-14)


def test_invariants_batched():
    body = RigidBody([[2.0, 0.1, 0.0], [0.1, 1.5, 0.2], [0.0, 0.2, 1.0]])
    w = np.random.default_rng(0).standard_normal((4, 5, 3))
    np.testing.assert_allclose(body.kinetic_energy(w), 0.5 * np.einsum("abi,ij,abj->ab", w, body.J, w))
    np.testing.assert_allclose(body.momentum_norm(w), np.linalg.norm(w @ body.J, axis=-1))
    R = so3.exp(np.random.default_rng(1).standard_normal((4, 5, 3)))
    L = body.inertial_momentum(R, w)
    np.testing.assert_allclose(np.linalg.norm(L, axis=-1), body.momentum_norm(w))


@pytest.mark.parametrize(
    ("J", "match"),
    [
        ([[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]], "J must be symmetric"),
        ([1.0, -2.0, 1.0], "J must be positive definite"),
        ([1.0, 2.0], r"J must be 3 numbers .* got shape \(2,\)"),
    ],
)
def test_rigid_body_rejects_bad_inertia(J, match):
    with pytest.raises(ValueError, match=match):
        RigidBody(J)


# ---------------------------------------------------------------------------------------------------------
# Torque-free motion


def test_torque_free_100s_stays_on_so3_and_conserves_invariants():
    body = RigidBody(PAPER_J)
    R0 = so3.exp([0.4, -1.1, 0.3])
    t = np.linspace(0.0, 100.0, 1001)
    traj = integrate(body, R0, PAPER_OMEGA0, t)  # default max_step 1e-3: 1e5 steps
    assert np.all(so3.orthogonality_error(traj.R) < 1e-12)
    assert np.all(np.linalg.det(traj.R) > 0)
    E = body.kinetic_energy(traj.omega)
    M = body.momentum_norm(traj.omega)
    assert np.max(np.abs(E / E[0] - 1)) < 1e-9
    assert np.max(np.abs(M / M[0] - 1)) < 1e-9
    # The inertial angular momentum is a constant vector (this tests the attitude, not only ω).
    L = body.inertial_momentum(traj.R, traj.omega)
    assert np.max(np.linalg.norm(L - L[0], axis=-1)) / np.linalg.norm(L[0]) < 1e-9
    np.testing.assert_array_equal(traj.t, t)
    np.testing.assert_array_equal(traj.R[0], R0)
    np.testing.assert_array_equal(traj.torque, 0.0)


def test_matches_axisymmetric_closed_form():
    R0 = so3.exp([0.3, -0.2, 0.1])
    w0 = np.array([1.0, -0.5, 2.0])
    t = np.linspace(0.0, 5.0, 51)
    traj = integrate(RigidBody([2.0, 2.0, 1.0]), R0, w0, t, max_step=1e-3)
    R_ref, w_ref = axisymmetric_free_motion(2.0, 1.0, R0, w0, t)
    assert np.max(attitude_error(R_ref, traj.R)) < 1e-11
    assert np.max(np.abs(traj.omega - w_ref)) < 1e-11


def test_fourth_order_against_axisymmetric_closed_form():
    R0 = so3.exp([0.3, -0.2, 0.1])
    w0 = np.array([1.0, -0.5, 2.0])
    R_ref, w_ref = axisymmetric_free_motion(2.0, 1.0, R0, w0, [2.0])
    steps = np.array([0.2, 0.1, 0.05, 0.025, 0.0125])
    err_R, err_w = [], []
    for h in steps:
        traj = integrate(RigidBody([2.0, 2.0, 1.0]), R0, w0, [0.0, 2.0], max_step=h)
        err_R.append(attitude_error(R_ref[0], traj.R[-1]))
        err_w.append(np.linalg.norm(traj.omega[-1] - w_ref[0]))
    assert 3.8 < fitted_order(steps, err_R) < 4.2
    assert 3.8 < fitted_order(steps, err_w) < 4.2


def test_fourth_order_against_dop853_triaxial():
    R0 = so3.exp([0.3, -0.2, 0.1])
    R_ref, w_ref = dop853_reference(np.diag(PAPER_J), R0, PAPER_OMEGA0, np.array([0.0, 2.0]))
    steps = np.array([0.1, 0.05, 0.025, 0.0125])
    err = []
    for h in steps:
        traj = integrate(RigidBody(PAPER_J), R0, PAPER_OMEGA0, [0.0, 2.0], max_step=h)
        err.append(attitude_error(R_ref[-1], traj.R[-1]) + np.linalg.norm(traj.omega[-1] - w_ref[-1]))
    assert 3.8 < fitted_order(steps, err) < 4.2
    fine = integrate(RigidBody(PAPER_J), R0, PAPER_OMEGA0, [0.0, 2.0], max_step=1e-3)
    assert attitude_error(R_ref[-1], fine.R[-1]) < 1e-11
    assert np.linalg.norm(fine.omega[-1] - w_ref[-1]) < 1e-11


def test_output_times_need_not_be_uniform_or_multiples_of_the_step():
    # Requested times off the step grid: the interval is split into equal steps ending exactly on each time.
    R0 = np.eye(3)
    w0 = np.array([1.0, -0.5, 2.0])
    t = np.array([0.0, 0.0123, 0.5, 0.50001, 1.7])
    traj = integrate(RigidBody([2.0, 2.0, 1.0]), R0, w0, t, max_step=1e-3)
    R_ref, w_ref = axisymmetric_free_motion(2.0, 1.0, R0, w0, t)
    assert np.max(attitude_error(R_ref, traj.R)) < 1e-12
    assert np.max(np.abs(traj.omega - w_ref)) < 1e-12


# ---------------------------------------------------------------------------------------------------------
# Torques


def test_torque_of_time_closed_form_fixed_axis():
    # J = I, τ(t) = c cos(t) a and ω0 = w a along a fixed unit axis a: ω(t) = (w + c sin t) a,
    # R(t) = R0 exp((w t + c (1 − cos t)) a).
    a = np.array([1.0, 2.0, -2.0]) / 3.0
    w, c = 0.8, 1.5
    R0 = so3.exp([0.1, 0.2, 0.3])
    t = np.linspace(0.0, 6.0, 31)
    torque = Torque.of_time(lambda s: c * np.cos(s) * a)
    traj = integrate(RigidBody([1.0, 1.0, 1.0]), R0, w * a, t, torque=torque, max_step=1e-3)
    theta = w * t + c * (1 - np.cos(t))
    R_ref = R0 @ so3.exp(theta[:, None] * a)
    assert np.max(attitude_error(R_ref, traj.R)) < 1e-11
    np.testing.assert_allclose(traj.omega, (w + c * np.sin(t))[:, None] * a, atol=1e-11)
    np.testing.assert_allclose(traj.torque, c * np.cos(t)[:, None] * a, atol=1e-15)


def test_constant_torque_against_dop853():
    tau = np.array([0.3, -0.1, 0.2])
    R0 = so3.exp([0.3, -0.2, 0.1])
    t = np.linspace(0.0, 3.0, 7)
    R_ref, w_ref = dop853_reference(np.diag(PAPER_J), R0, PAPER_OMEGA0, t, torque=lambda s, R, w: tau)
    for torque in (tau, Torque.constant(tau)):
        traj = integrate(RigidBody(PAPER_J), R0, PAPER_OMEGA0, t, torque=torque, max_step=1e-3)
        assert np.max(attitude_error(R_ref, traj.R)) < 1e-11
        assert np.max(np.abs(traj.omega - w_ref)) < 1e-11
        np.testing.assert_array_equal(traj.torque, np.broadcast_to(tau, (t.size, 3)))


def test_state_torque_damping_decays_momentum_in_closed_form():
    # τ = −c J ω: d(Jω)/dt = (Jω) × ω − c Jω, so |Jω| = e^{−ct} |Jω0|, and L = R J ω obeys L̇ = −c L:
    # the inertial momentum vector decays as e^{−ct} L0 (a closed form that checks the attitude too).
    c = 0.4
    body = RigidBody(PAPER_J)
    R0 = so3.exp([0.5, 0.1, -0.7])
    t = np.linspace(0.0, 5.0, 11)
    traj = integrate(body, R0, PAPER_OMEGA0, t, torque=Torque.of_state(lambda s, R, w: -c * body.J @ w), max_step=5e-3)
    L0 = body.inertial_momentum(R0, PAPER_OMEGA0)
    L = body.inertial_momentum(traj.R, traj.omega)
    np.testing.assert_allclose(L, np.exp(-c * t)[:, None] * L0, rtol=0, atol=1e-9 * np.linalg.norm(L0))
    np.testing.assert_allclose(traj.torque, -c * traj.omega @ body.J, rtol=1e-14)


def test_state_torque_damping_energy_for_unit_inertia():
    # J = I, τ = −c ω: ω = e^{−ct} ω0 and the energy is E0 e^{−2ct}.
    c = 0.7
    body = RigidBody(np.eye(3))
    t = np.linspace(0.0, 4.0, 9)
    traj = integrate(body, np.eye(3), PAPER_OMEGA0, t, torque=Torque.of_state(lambda s, R, w: -c * w), max_step=1e-2)
    E0 = body.kinetic_energy(PAPER_OMEGA0)
    np.testing.assert_allclose(body.kinetic_energy(traj.omega), E0 * np.exp(-2 * c * t), rtol=1e-9)


def test_compiled_kernel_agrees_with_numpy_step():
    # Same steps through the compiled kernel (time torque) and the plain NumPy cf4_step (the oracle).
    body = RigidBody([[2.0, 0.1, 0.0], [0.1, 1.5, 0.2], [0.0, 0.2, 1.0]])
    f = lambda s: np.array([np.sin(3 * s), 0.2, -np.cos(s)])  # noqa: E731
    R0 = so3.exp([0.3, -0.2, 2.9])
    h = 0.01
    t = np.arange(0, 201) * h
    fast = integrate(body, R0, PAPER_OMEGA0, t, torque=Torque.of_time(f), max_step=h)
    R, w = R0, PAPER_OMEGA0
    for k in range(200):
        R, w = cf4_step(body, R, w, t[k], h, Torque.of_time(f))
    assert attitude_error(R, fast.R[-1]) < 1e-12
    np.testing.assert_allclose(fast.omega[-1], w, atol=1e-12)


# ---------------------------------------------------------------------------------------------------------
# Errors


def test_bare_function_torque_is_refused():
    with pytest.raises(TypeError, match=r"wrap it as Torque.of_time\(f\)"):
        as_torque(lambda t: np.zeros(3))


def test_torque_function_returning_bad_value_names_the_time():
    bad = Torque.of_time(lambda t: [1.0, 2.0])
    with pytest.raises(ValueError, match=r"return 3 finite numbers; at t = 0.0 it returned \[1.0, 2.0\]"):
        integrate(RigidBody(PAPER_J), np.eye(3), PAPER_OMEGA0, [0.0, 1.0], torque=bad)
    nan = Torque.of_state(lambda t, R, w: [np.nan, 0, 0])
    with pytest.raises(ValueError, match="must return 3 finite numbers"):
        integrate(RigidBody(PAPER_J), np.eye(3), PAPER_OMEGA0, [0.0, 1.0], torque=nan)


def test_torque_constructors_check_their_input():
    with pytest.raises(ValueError, match=r"torque must be a 3-vector; got shape \(2,\)"):
        Torque.constant([1.0, 2.0])
    with pytest.raises(ValueError, match="torque must be finite"):
        as_torque([1.0, np.inf, 0.0])
    with pytest.raises(TypeError, match=r"Torque\.of_time needs a callable"):
        Torque.of_time(3.0)
    with pytest.raises(TypeError, match=r"Torque\.of_state needs a callable"):
        Torque.of_state(None)
    with pytest.raises(ValueError, match="torque kind must be"):
        Torque("sometimes")


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"R0": np.diag([1.0, 1.0, -1.0])}, r"R0: a reflection, not a rotation: det R = -1"),
        ({"R0": 1.01 * np.eye(3)}, r"R0 is not a rotation matrix: ‖RᵀR − I‖_F = 0.0348 exceeds 1e-09"),
        ({"R0": [0.0, 0.0, 0.0, 1.001]}, r"R0 is not a unit quaternion: ‖q‖ = 1.001, \|‖q‖ − 1\| exceeds 1e-09"),
        (
            {"R0": np.eye(2)},
            r"R0 must be a rotation matrix \(3, 3\), a quaternion \(4,\) or a Rotation; got shape \(2, 2\)",
        ),
        ({"omega0": [1.0, 2.0]}, r"omega0 must be a 3-vector; got shape \(2,\)"),
        ({"omega0": [1.0, np.nan, 2.0]}, "omega0 must be finite"),
        (
            {"times": [0.0, 1.0, 1.0]},
            r"times\[2\]: time t = 1.0 is not after the previous sample's t = 1.0 \(timestamps must increase",
        ),
        ({"times": [0.0, np.inf]}, r"times\[1\]: time t = inf is not finite"),
        ({"times": [[0.0, 1.0]]}, r"times must have shape \(T,\); got shape \(1, 2\)"),
        ({"times": []}, r"times must hold at least one time; got none"),
        ({"max_step": 0.0}, "max_step must be positive and finite"),
    ],
)
def test_integrate_rejects_bad_input(kwargs, match):
    args = {"R0": np.eye(3), "omega0": PAPER_OMEGA0, "times": [0.0, 1.0]} | kwargs
    with pytest.raises(ValueError, match=match):
        integrate(RigidBody(PAPER_J), **args)


def test_integrate_rejects_a_non_body():
    with pytest.raises(TypeError, match="body must be a RigidBody; got ndarray"):
        integrate(np.eye(3), np.eye(3), PAPER_OMEGA0, [0.0, 1.0])


# ---------------------------------------------------------------------------------------------------------
# Sensors


def test_directions_are_rows_of_R_for_the_inertial_axes():
    R = Rotation.random(7, random_state=3).as_matrix()
    np.testing.assert_allclose(directions(R, np.eye(3)), R, atol=1e-15)
    v = np.array([[0.0, 0.0, 9.81], [0.2, 0.4, -0.8]])
    r = directions(R, v)
    u = v / np.linalg.norm(v, axis=1, keepdims=True)
    for k in range(7):
        np.testing.assert_allclose(r[k], (R[k].T @ u.T).T, atol=1e-15)


def test_noisy_attitudes_have_the_requested_per_axis_spread():
    sigma = np.array([1e-3, 2e-3, 5e-4])
    R = np.broadcast_to(so3.exp([0.4, 0.2, -0.1]), (20000, 3, 3))
    Rm = noisy_attitudes(R, sigma, np.random.default_rng(11))
    nu = so3.log(np.swapaxes(R, -1, -2) @ Rm)  # = ν (body-frame perturbation)
    # Sample std of 20000 normals is within 3 % of σ with probability ≫ 0.999 (rel. sd 1/√(2N) = 0.5 %).
    np.testing.assert_allclose(nu.std(axis=0), sigma, rtol=0.03)
    assert np.all(np.abs(nu.mean(axis=0)) < 4 * sigma / np.sqrt(20000))
    assert np.all(so3.orthogonality_error(Rm) < 1e-14)
    again = noisy_attitudes(R, sigma, np.random.default_rng(11))
    np.testing.assert_array_equal(Rm, again)


def test_noisy_directions_spread_and_errors():
    R = np.broadcast_to(np.eye(3), (20000, 3, 3))
    b = noisy_directions(R, np.eye(3)[:2], [0.01, 0.02], np.random.default_rng(5))
    assert b.shape == (20000, 2, 3)
    np.testing.assert_allclose((b - np.eye(3)[:2]).std(axis=0), [[0.01] * 3, [0.02] * 3], rtol=0.03)
    with pytest.raises(ValueError, match=r"sigma must be one number or 2 numbers .* shape \(3,\)"):
        noisy_directions(R, np.eye(3)[:2], [0.1, 0.1, 0.1], np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"sigma must be non-negative and finite; got \[-1.0"):
        noisy_attitudes(R, [-1.0, 0.0, 0.0], np.random.default_rng(0))
    with pytest.raises(TypeError, match=r"rng must be a numpy\.random\.Generator .* got int"):
        noisy_attitudes(R, 0.1, 42)
    with pytest.raises(ValueError, match=r"R must be rotation matrices of shape .*; got shape \(3,\)"):
        directions(np.ones(3), np.eye(3))
