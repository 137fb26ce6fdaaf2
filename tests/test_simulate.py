"""The fast coupled simulator against the observer's own equations integrated by SciPy."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.observer.gains import ObserverGains, theorem_gains
from omegahat.simulation import CoupledProblem, Torque, paper_problem, simulate, simulate_reference


def _relative(a, b):
    return np.abs(a - b) / np.abs(b)


def test_paper_run_matches_stiff_reference_to_1e_6():
    """Issue 2.6: |ω̂ − ω| at t = 0.5, 1 and 2 s within 1e-6 relative of Radau at rtol 1e-10 (the reference
    integrates (r, ω, ξ, r̂) with the observer's own right-hand side; measured agreement ~1e-9)."""
    p = paper_problem()
    t = np.array([0.0, 0.5, 1.0, 2.0])
    ref = simulate_reference(p, t, method="Radau", rtol=1e-10, atol=1e-14)
    fast = simulate(p, t_out=t)
    assert np.all(_relative(fast.error[1:], ref.error[1:]) < 1e-6)
    np.testing.assert_allclose(fast.omega, ref.omega, rtol=0, atol=1e-9)
    np.testing.assert_allclose(fast.xi, ref.xi, rtol=0, atol=1e-8)


def test_output_times_inside_steps_come_from_the_continuous_extension():
    """Steps do not depend on the output grid (only the last one ends on t_out[-1]); output times inside a step are
    filled by its continuous extension, which must hold the same 1e-6 relative accuracy of |ω̂ − ω| (and of the
    filter states, whose stiff decay it integrates exactly) against the stiff reference at arbitrary times."""
    p = paper_problem()
    t = np.array([0.0, 0.0013, 0.0171, 0.1234, 0.5, 0.777, 1.0])
    sparse = simulate(p, t_out=[0.0, 1.0])
    fast = simulate(p, t_out=t)
    assert fast.steps == sparse.steps and fast.rejected == sparse.rejected
    np.testing.assert_array_equal(fast.z[-1], sparse.z[-1])
    ref = simulate_reference(p, t, method="Radau", rtol=1e-10, atol=1e-14)
    assert np.all(_relative(fast.error[1:], ref.error[1:]) < 1e-6)
    np.testing.assert_allclose(fast.r_hat, ref.r_hat, rtol=0, atol=1e-8)


def test_known_torque_and_three_general_directions_match_reference():
    """A full inertia, three non-orthogonal directions, a sinusoidal known torque, unequal constant gains."""
    rng = np.random.default_rng(7)
    Q = Rotation.random(random_state=rng).as_matrix()
    J = Q @ np.diag([1.5, 2.0, 3.5]) @ Q.T
    refs = np.array([[1.0, 0.2, 0.0], [0.3, 1.0, 0.5], [0.0, 0.4, 1.0]])
    torque = Torque.sinusoidal(
        constant=[0.1, -0.2, 0.05],
        amplitudes=[[0.5, 0.2, -0.3], [0.1, 0.1, 0.4]],
        frequencies=[1.3, 4.0],
        phases=[[0.0, 1.0, 2.0], [0.5, 0.5, 0.5]],
    )
    gains = ObserverGains(k=[6.0, 9.0, 7.0], l_offset=[20.0, 35.0, 50.0])
    p = CoupledProblem(
        J=J,
        gains=gains,
        omega0=[0.5, -1.2, 0.8],
        R0=Rotation.random(random_state=rng),
        references=refs,
        r_hat0=rng.normal(size=(3, 3)),
        omega_hat0=[1.0, 1.0, -1.0],
        torque=torque,
    )
    t = np.array([0.0, 0.25, 0.5, 1.0, 1.5])
    ref = simulate_reference(p, t, method="DOP853", rtol=1e-12, atol=1e-14)
    fast = simulate(p, t_out=t)
    assert np.all(_relative(fast.error[1:], ref.error[1:]) < 1e-6)
    np.testing.assert_allclose(fast.r_hat, ref.r_hat, atol=1e-8)


def test_stiff_gains_with_large_initial_estimate_match_reference():
    """|ω̂₀| = 40 makes the theorem's l_i ≈ 1.9e4: the exponential step must still be right."""
    J = np.diag([3.0, 2.0, 1.0])
    p = CoupledProblem(
        J=J,
        gains=theorem_gains(J, 3.0),
        omega0=[2.0, -1.0, 0.6],
        omega_hat0=[30.0, -20.0, 17.0],
        r_hat0=[[0.5, 0.5, 0.0], [-1.0, 2.0, 0.0]],
    )
    t = np.array([0.0, 0.05, 0.2, 0.5])
    ref = simulate_reference(p, t, method="Radau", rtol=1e-10, atol=1e-13)
    fast = simulate(p, t_out=t)
    assert ref.error[0] > 35
    assert np.all(_relative(fast.error[1:], ref.error[1:]) < 1e-6)


def test_torque_free_plant_conserves_energy_and_momentum():
    """The plant inside the coupled simulation is integrated to the requested tolerance (default rtol 1e-9):
    energy and |Jω| drift by ~1e-9 over 10 s (measured 1.2e-9). The 1e-9-over-100-s ground truth is
    omegahat.simulation.rigid_body, a separate Lie-group integrator."""
    p = paper_problem()
    tr = simulate(p, horizon=10.0, dt_out=0.5)
    J = p.J
    energy = 0.5 * np.einsum("ti,ij,tj->t", tr.omega, J, tr.omega)
    momentum = np.linalg.norm(tr.omega @ J, axis=1)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-8)
    np.testing.assert_allclose(momentum, momentum[0], rtol=1e-8)
    tight = simulate(p, horizon=10.0, dt_out=0.5, rtol=1e-11)
    energy_tight = 0.5 * np.einsum("ti,ij,tj->t", tight.omega, J, tight.omega)
    assert np.abs(energy_tight / energy_tight[0] - 1).max() < np.abs(energy / energy[0] - 1).max()
    np.testing.assert_allclose(np.linalg.norm(tr.r, axis=-1), 1.0, atol=1e-9)


def test_bad_arguments_are_named():
    p = paper_problem()
    with pytest.raises(ValueError, match="horizon must be positive"):
        simulate(p, horizon=-1.0)
    with pytest.raises(ValueError, match="t_out must start at 0"):
        simulate(p, t_out=[0.0, 1.0, 0.5])
    with pytest.raises(TypeError, match=r"wrap it as Torque.of_time\(f\)"):
        CoupledProblem(J=np.eye(3), gains=ObserverGains.constant(1.0, 1.0), omega0=[0, 0, 1], torque=lambda t: t)
    with pytest.raises(TypeError, match="the compiled engine needs a torque given as data"):
        CoupledProblem(
            J=np.eye(3), gains=ObserverGains.constant(1.0, 1.0), omega0=[0, 0, 1], torque=Torque.of_time(np.sin)
        )
    with pytest.raises(ValueError, match="2 gains were given for 3 reference directions"):
        CoupledProblem(J=np.eye(3), gains=ObserverGains.constant(1.0, 1.0), omega0=[0, 0, 1], references=np.eye(3))
    with pytest.raises(ValueError, match="J must be positive definite"):
        CoupledProblem(J=[1.0, -1.0, 1.0], gains=ObserverGains.constant(1.0, 1.0), omega0=[0, 0, 1])
    with pytest.raises(ValueError, match="r_hat0 must be finite"):
        CoupledProblem(J=np.eye(3), gains=ObserverGains.constant(1.0, 1.0), omega0=[0, 0, 1], r_hat0=np.zeros(3))


def test_sinusoidal_torque_evaluates_its_formula():
    tq = Torque.sinusoidal(constant=[1.0, 0, 0], amplitudes=[[0, 2.0, 0]], frequencies=[3.0], phases=[[0, 0.5, 0]])
    t = np.array([0.0, 0.7])
    expected = np.stack([np.ones(2), 2.0 * np.sin(3.0 * t + 0.5), np.zeros(2)], axis=1)
    np.testing.assert_allclose(tq(t), expected, atol=1e-15)
    np.testing.assert_allclose(tq(0.7), expected[1], atol=1e-15)
    assert tq.bound == pytest.approx(np.sqrt(5.0))
