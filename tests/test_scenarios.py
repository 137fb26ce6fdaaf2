"""The scenario registry: the stated facts of each scenario hold in what simulate() returns."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.lab import scenarios as S


def test_registry_has_the_issue_scenarios():
    assert S.names() == [
        "paper",
        "slew",
        "slew-J10",
        "slew-disturbance",
        "slew-1Hz",
        "tumble",
        "tumble-fast",
        "broad-01",
        "broad-06",
        "broad-10",
        "broad-01-29hz",
        "broad-06-29hz",
        "broad-10-29hz",
        "broad-01-10hz",
        "broad-06-10hz",
        "broad-10-10hz",
    ]
    low = S.get("broad-06-10hz")  # every 30th sample of trial 06: its rate is the native one over 30
    assert (low.broad_trial, low.decimate) == ("06", 30)
    assert low.rate_hz == pytest.approx(S.get("broad-06").rate_hz / 30)
    with pytest.raises(ValueError, match="unknown scenario 'nope'; known: paper, slew"):
        S.get("nope")
    with pytest.raises(ValueError, match="scenario 'broad-01' is real data"):
        S.simulate(S.get("broad-01"), 0)


def test_paper_scenario_is_torque_free_with_the_papers_numbers():
    sc = S.get("paper")
    run = S.simulate(sc, seed=0, duration=2.0)
    np.testing.assert_allclose(run.omega[0], [2.0, -1.0, 0.6])
    np.testing.assert_allclose(np.diff(run.t), 0.01)
    # Torque-free: kinetic energy and |J ω| are conserved (independent of the integrator's construction).
    J = np.diag([3.0, 2.0, 1.0])
    energy = 0.5 * np.einsum("ti,ij,tj->t", run.omega, J, run.omega)
    np.testing.assert_allclose(energy, energy[0], rtol=1e-9)
    # No noise in this scenario: the measurements are the truth.
    np.testing.assert_array_equal(run.R_meas, run.R)


def test_slew_torque_profile_momentum_and_noise():
    sc = S.get("slew")
    assert np.all(np.linalg.eigvalsh(sc.J_true) > 150) and np.all(np.linalg.eigvalsh(sc.J_true) < 350)
    assert np.count_nonzero(sc.J_true - np.diag(np.diag(sc.J_true))) == 6  # products of inertia
    run = S.simulate(sc, seed=3)
    np.testing.assert_allclose(run.torque[run.t < 59.9], [[0.5, -0.5, 0.5]] * int(np.sum(run.t < 59.9)))
    np.testing.assert_allclose(run.torque[(run.t >= 60) & (run.t < 119.9)][0], [-0.5, 0.5, -0.5])
    np.testing.assert_array_equal(run.torque[run.t >= 120], 0.0)
    # Inertial angular momentum L = R J ω changes by ∫ R τ dt: over [0, 60] with constant body torque,
    # compare L(60) − L(0) with the trapezoid integral of R τ (sample spacing 0.2 s, smooth integrand).
    L = np.einsum("tij,jk,tk->ti", run.R, sc.J_true, run.omega)
    seg = run.t <= 60.0 + 1e-9
    Rtau = np.einsum("tij,tj->ti", run.R[seg], np.broadcast_to([0.5, -0.5, 0.5], (seg.sum(), 3)))
    np.testing.assert_allclose(L[seg][-1] - L[0], np.trapezoid(Rtau, run.t[seg], axis=0), rtol=1e-4)
    # After 120 s the body coasts: L constant.
    coast = run.t >= 120.0 - 1e-9
    np.testing.assert_allclose(L[coast], np.broadcast_to(L[coast][0], L[coast].shape), atol=1e-9)
    # Star-tracker noise: 10 arcsec per axis.
    nu = Rotation.from_matrix(np.swapaxes(run.R, 1, 2) @ run.R_meas).as_rotvec()
    np.testing.assert_allclose(nu.std(axis=0), 10 * np.pi / 180 / 3600, rtol=0.1)


def test_variants_differ_from_slew_only_where_stated():
    base = S.get("slew")
    wrong = S.get("slew-J10")
    np.testing.assert_allclose(np.diag(wrong.J_model) / np.diag(base.J_true), [1.1, 0.9, 1.1])
    np.testing.assert_array_equal(wrong.J_true, base.J_true)
    dist = S.get("slew-disturbance")
    np.testing.assert_array_equal(dist.disturbance, [4e-3, -3e-3, 2e-3])
    r0, r1 = S.simulate(base, 5, duration=30.0), S.simulate(dist, 5, duration=30.0)
    np.testing.assert_array_equal(r0.torque, r1.torque)  # the disturbance is not in the known torque
    # ... but it is in the truth: J Δω̇ ≈ disturbance at the start (ω small, so the gyroscopic terms are tiny).
    dw = (r1.omega[5] - r0.omega[5]) / r0.t[5]
    np.testing.assert_allclose(base.J_true @ dw, dist.disturbance, rtol=2e-2)
    assert S.get("slew-1Hz").rate_hz == 1.0


def test_seeded():
    sc = S.get("slew")
    a, b, c = (S.simulate(sc, s, duration=10.0) for s in (1, 1, 2))
    np.testing.assert_array_equal(a.R_meas, b.R_meas)
    assert not np.array_equal(a.R_meas, c.R_meas)
