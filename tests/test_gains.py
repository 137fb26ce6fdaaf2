"""Gain design and checks against the theorem's conditions (observer.md, "Gains")."""

import warnings

import numpy as np
import pytest

from omegahat.observer.gains import GainConditionWarning, ObserverGains, check_gains, inertia_bounds, mu, theorem_gains

J_PAPER = np.diag([3.0, 2.0, 1.0])


def test_theorem_gains_reproduce_the_papers_choice():
    """Paper: k = 1 + (ω_M + 3/2) J_M = 14.5 and l_i = 1 + (|ω̂| + 3)(1 + 14.5 (1 + 29)) = 1 + 436 (|ω̂| + 3)."""
    g = theorem_gains(J_PAPER, omega_max=3.0)
    np.testing.assert_allclose(g.k, [14.5, 14.5])
    np.testing.assert_allclose(g.l_slope, [436.0, 436.0])
    np.testing.assert_allclose(g.l_offset, [1.0 + 3.0 * 436.0] * 2)
    np.testing.assert_allclose(g.l([1.0, 0.0, 0.0]), [1.0 + 436.0 * 4.0] * 2)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the theorem's gains pass silently
        assert check_gains(g, J_PAPER, 3.0).ok


@pytest.mark.parametrize("theta_deg", [10.0, 45.0, 90.0, 120.0, 170.0])
def test_mu_for_two_directions_at_an_angle(theta_deg):
    """Closed form: two unit directions at angle θ with equal k give μ = k (1 − |cos θ|)."""
    th = np.radians(theta_deg)
    refs = np.array([[1.0, 0.0, 0.0], [np.cos(th), np.sin(th), 0.0]])
    assert mu([3.0, 3.0], refs) == pytest.approx(3.0 * (1.0 - abs(np.cos(th))), rel=1e-12)


def test_mu_is_attitude_invariant_and_three_rows_give_twice_k():
    from scipy.spatial.transform import Rotation

    R = Rotation.from_rotvec([0.3, -1.0, 2.0]).as_matrix()
    refs = np.array([[1.0, 2.0, 0.5], [0.0, 1.0, -1.0]])
    assert mu([2.0, 5.0], refs @ R) == pytest.approx(mu([2.0, 5.0], refs), rel=1e-12)
    assert mu([4.0, 4.0, 4.0], np.eye(3)) == pytest.approx(8.0)


def test_theorem_gains_for_nearly_collinear_directions_need_larger_k():
    refs = np.array([[1.0, 0.0, 0.0], [np.cos(0.2), np.sin(0.2), 0.0]])
    g = theorem_gains(J_PAPER, 3.0, references=refs)
    assert mu(g.k, refs) == pytest.approx(3.0 * 4.5 + 1.0, rel=1e-12)
    assert g.k[0] > 14.5 * 40


def test_check_gains_names_the_failing_condition_and_by_how_much():
    g = ObserverGains.constant(10.0, 1.0)  # μ = 10 < 13.5; l constant 1 far below the theorem's
    with pytest.warns(
        GainConditionWarning,
        match=r"mu = .* = 10 must exceed J_M \(omega_M \+ 3/2\) = 13.5 "
        r"\(short by 3.5\)",
    ):
        result = check_gains(g, J_PAPER, 3.0)
    assert not result.ok
    assert len(result.failures) == 1 + 2 * 2  # μ, and slope and offset for each of two directions
    assert any("l_2(0) = 1 must exceed" in f for f in result.failures)
    # the printed condition (without J_M) would accept μ = 10 > 4.5: the proof's condition does not
    assert result.mu == pytest.approx(10.0)
    assert result.mu_required == pytest.approx(3.0 * 4.5)


def test_check_gains_silent_mode_and_mismatched_directions():
    g = ObserverGains.constant(1.0, 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not check_gains(g, J_PAPER, 3.0, warn=False).ok
    with pytest.raises(ValueError, match="2 gains were given for 3 reference directions"):
        check_gains(g, J_PAPER, 3.0, references=np.eye(3))


def test_invalid_gains_and_inertia_are_named():
    with pytest.raises(ValueError, match="k must be positive and finite"):
        ObserverGains(k=[1.0, -2.0], l_offset=[1.0, 1.0])
    with pytest.raises(ValueError, match="l must be one number or 2 numbers"):
        ObserverGains(k=[1.0, 2.0], l_offset=[1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="l_slope must be 2 non-negative"):
        ObserverGains(k=[1.0, 2.0], l_offset=[1.0, 1.0], l_slope=[-1.0, 0.0])
    with pytest.raises(ValueError, match="J must be symmetric"):
        inertia_bounds([[1.0, 0.5, 0], [0, 1.0, 0], [0, 0, 1.0]])
    with pytest.raises(ValueError, match="nearly collinear"):
        theorem_gains(J_PAPER, 3.0, references=[[1.0, 0, 0], [2.0, 1e-4, 0]])
    assert inertia_bounds(J_PAPER) == (1.0, 3.0)
