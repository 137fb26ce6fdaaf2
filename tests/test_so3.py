"""Property tests of omegahat.so3, with samples placed on purpose near the identity and near θ = π.

Independent references: NumPy's cross product, SciPy's ``Rotation`` (quaternions, rotation vectors),
``scipy.linalg.polar`` (nearest orthogonal matrix) and the group laws themselves.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.linalg import polar
from scipy.spatial.transform import Rotation

from omegahat import so3

RNG_SEED = 20240611


def unit_vectors(rng, n):
    a = rng.standard_normal((n, 3))
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def random_rotations(n, seed):
    return Rotation.random(n, random_state=seed).as_matrix()


# Angles chosen on purpose: tiny (Taylor branch of exp/log), around the branch switch at 1e-4 rad, generic,
# around the near-π switch of log at 2 rad, around π − 1e-2 (the old switch) and within 1e-9 of π.
SMALL_ANGLES = [1e-12, 1e-10, 1e-8, 1e-6, 9.999e-5, 1e-4, 1.0001e-4, 1e-3]
GENERIC_ANGLES = [0.1, 1.0, 2.0 - 1e-9, 2.0 + 1e-9, 3.0]
NEAR_PI_ANGLES = [
    np.pi - 1e-1,
    np.pi - 1.01e-2,
    np.pi - 1e-2,
    np.pi - 0.99e-2,
    np.pi - 1e-5,
    np.pi - 1e-7,
    np.pi - 1e-9,
]

finite = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
vectors = st.tuples(finite, finite, finite).map(np.array)


# ---------------------------------------------------------------------------------------------------------
# hat / vee


@given(vectors, vectors)
def test_hat_is_the_cross_product(v, x):
    np.testing.assert_allclose(so3.hat(v) @ x, np.cross(v, x), rtol=1e-14, atol=1e-13)


@given(vectors, vectors)
def test_cross_is_numpys_cross_product(v, x):
    np.testing.assert_allclose(so3.cross(v, x), np.cross(v, x), rtol=1e-15, atol=0.0)


def test_cross_broadcasts_as_numpys_and_refuses_other_widths():
    rng = np.random.default_rng(RNG_SEED)
    a, b = rng.standard_normal((4, 1, 3)), rng.standard_normal((5, 3))
    np.testing.assert_array_equal(so3.cross(a, b), np.cross(a, b))
    np.testing.assert_array_equal(so3.cross(a[0, 0], b), np.cross(a[0, 0], b))
    assert so3.cross([1, 0, 0], [0, 1, 0]).tolist() == [0.0, 0.0, 1.0]  # integers come back as floats
    with pytest.raises(ValueError, match="3-vectors"):
        so3.cross(np.ones(2), np.ones(3))


@given(vectors)
def test_vee_inverts_hat_and_hat_is_skew(v):
    np.testing.assert_array_equal(so3.vee(so3.hat(v)), v)
    np.testing.assert_array_equal(so3.hat(v), -so3.hat(v).T)


def test_hat_vee_broadcast_over_leading_axes():
    v = np.random.default_rng(RNG_SEED).standard_normal((4, 5, 3))
    H = so3.hat(v)
    assert H.shape == (4, 5, 3, 3)
    np.testing.assert_array_equal(H[2, 3], so3.hat(v[2, 3]))
    np.testing.assert_array_equal(so3.vee(H), v)


# ---------------------------------------------------------------------------------------------------------
# exp / log


@pytest.mark.parametrize("theta", SMALL_ANGLES)
def test_log_exp_near_identity_has_full_relative_accuracy(theta):
    phi = theta * unit_vectors(np.random.default_rng(RNG_SEED), 200)
    back = so3.log(so3.exp(phi))
    rel = np.linalg.norm(back - phi, axis=1) / theta
    assert rel.max() < 1e-14
    # exp itself: the skew part carries sin θ/θ φ exactly enough (the diagonal rounds to 1 − θ²/2).
    R = so3.exp(phi)
    np.testing.assert_allclose(so3.vee(R), phi * (np.sin(theta) / theta), rtol=1e-15, atol=0)


@pytest.mark.parametrize("theta", GENERIC_ANGLES + NEAR_PI_ANGLES)
def test_log_exp_round_trip_below_pi(theta):
    phi = theta * unit_vectors(np.random.default_rng(RNG_SEED + 1), 200)
    R = so3.exp(phi)
    back = so3.log(R)
    assert np.max(np.linalg.norm(back - phi, axis=1)) < 5e-15
    # SciPy's independent rotation vector agrees.
    np.testing.assert_allclose(back, Rotation.from_matrix(R).as_rotvec(), atol=5e-14)


@pytest.mark.parametrize("theta", SMALL_ANGLES + GENERIC_ANGLES + NEAR_PI_ANGLES + [np.pi])
def test_exp_log_is_identity_on_rotations(theta):
    phi = theta * unit_vectors(np.random.default_rng(RNG_SEED + 2), 200)
    R = so3.exp(phi)
    # Regression: with the near-π switch at π − 1e-2 this was 1.4e-14 just below the switch.
    assert np.max(np.abs(so3.exp(so3.log(R)) - R)) < 5e-15
    assert np.all(np.linalg.norm(so3.log(R), axis=1) <= np.pi + 1e-15)


def test_log_at_exactly_pi_returns_one_of_the_two_valid_vectors():
    axes = np.vstack([np.eye(3), unit_vectors(np.random.default_rng(RNG_SEED + 3), 50)])
    R = so3.exp(np.pi * axes)
    phi = so3.log(R)
    np.testing.assert_allclose(np.linalg.norm(phi, axis=1), np.pi, rtol=1e-15)
    # ±π a: parallel to the axis.
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", phi, axes)), np.pi, rtol=1e-14)


def test_log_of_random_rotations_matches_scipy():
    R = random_rotations(2000, RNG_SEED)
    np.testing.assert_allclose(so3.log(R), Rotation.from_matrix(R).as_rotvec(), atol=5e-14)
    np.testing.assert_allclose(so3.exp(so3.log(R)), R, atol=5e-15)


def test_exp_matches_scipy_rotvec():
    phi = np.random.default_rng(RNG_SEED).uniform(-4, 4, (2000, 3))
    np.testing.assert_allclose(so3.exp(phi), Rotation.from_rotvec(phi).as_matrix(), atol=1e-14)


# ---------------------------------------------------------------------------------------------------------
# Group laws


@settings(max_examples=200)
@given(vectors, vectors)
def test_exp_is_a_rotation_and_inverse_is_transpose(a, b):
    R = so3.exp(a)
    assert so3.orthogonality_error(R) < 1e-14
    assert abs(np.linalg.det(R) - 1) < 1e-14
    np.testing.assert_allclose(so3.exp(-a), R.T, atol=1e-15)
    # closure: the product of two rotations is a rotation
    assert so3.is_rotation(R @ so3.exp(b), tol=1e-14)


@given(vectors, st.floats(-3, 3), st.floats(-3, 3))
def test_one_parameter_subgroup(a, s, t):
    np.testing.assert_allclose(so3.exp(s * a) @ so3.exp(t * a), so3.exp((s + t) * a), atol=1e-13)


def test_associativity_identity_and_inverse():
    R1, R2, R3 = random_rotations(3, RNG_SEED)
    np.testing.assert_allclose((R1 @ R2) @ R3, R1 @ (R2 @ R3), atol=1e-15)
    np.testing.assert_array_equal(so3.exp(np.zeros(3)), np.eye(3))
    np.testing.assert_array_equal(so3.log(np.eye(3)), np.zeros(3))
    np.testing.assert_allclose(R1 @ R1.T, np.eye(3), atol=1e-15)


def test_adjoint_identity():
    # R exp(φ) Rᵀ = exp(R φ): conjugation rotates the rotation vector.
    R = random_rotations(100, RNG_SEED)
    phi = np.random.default_rng(RNG_SEED).uniform(-3, 3, (100, 3))
    lhs = R @ so3.exp(phi) @ np.swapaxes(R, -1, -2)
    rhs = so3.exp(np.einsum("nij,nj->ni", R, phi))
    np.testing.assert_allclose(lhs, rhs, atol=1e-14)


def test_log_of_inverse_is_minus_log():
    angles = np.random.default_rng(1).uniform(0, 3.0, (100, 1))
    phi = angles * unit_vectors(np.random.default_rng(RNG_SEED), 100)
    R = so3.exp(phi)
    np.testing.assert_allclose(so3.log(np.swapaxes(R, -1, -2)), -so3.log(R), atol=1e-14)


# ---------------------------------------------------------------------------------------------------------
# Quaternions


@pytest.mark.parametrize("scalar_first", [False, True])
def test_from_quat_matches_scipy_for_q_and_minus_q(scalar_first):
    rot = Rotation.random(500, random_state=RNG_SEED)
    q = rot.as_quat(scalar_first=scalar_first)
    R = rot.as_matrix()
    np.testing.assert_allclose(so3.from_quat(q, scalar_first=scalar_first), R, atol=1e-15)
    np.testing.assert_allclose(so3.from_quat(-q, scalar_first=scalar_first), R, atol=1e-15)
    # not normalised: normalised inside
    np.testing.assert_allclose(so3.from_quat(3.5 * q, scalar_first=scalar_first), R, atol=1e-15)


@pytest.mark.parametrize("scalar_first", [False, True])
def test_to_quat_matches_scipy_canonical(scalar_first):
    rot = Rotation.random(500, random_state=RNG_SEED + 1)
    q = so3.to_quat(rot.as_matrix(), scalar_first=scalar_first)
    np.testing.assert_allclose(q, rot.as_quat(canonical=True, scalar_first=scalar_first), atol=1e-15)
    w = q[:, 0] if scalar_first else q[:, 3]
    assert np.all(w >= 0)
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-15)


@pytest.mark.parametrize("theta", [*SMALL_ANGLES, np.pi - 1e-9, np.pi])
def test_quaternion_round_trip_near_identity_and_pi(theta):
    phi = theta * unit_vectors(np.random.default_rng(RNG_SEED + 4), 100)
    R = so3.exp(phi)
    for scalar_first in (False, True):
        q = so3.to_quat(R, scalar_first=scalar_first)
        np.testing.assert_allclose(so3.from_quat(q, scalar_first=scalar_first), R, atol=5e-16 * 4)
        np.testing.assert_allclose(so3.from_quat(-q, scalar_first=scalar_first), R, atol=5e-16 * 4)


def test_scalar_orders_are_a_roll_of_each_other():
    rot = Rotation.random(10, random_state=RNG_SEED)
    R = rot.as_matrix()
    np.testing.assert_array_equal(so3.to_quat(R, scalar_first=True), np.roll(so3.to_quat(R), 1, axis=-1))


def test_as_matrix_accepts_rotation_matrices_and_quaternions():
    rot = Rotation.random(6, random_state=RNG_SEED)
    R = rot.as_matrix()
    np.testing.assert_array_equal(so3.as_matrix(rot), R)
    np.testing.assert_array_equal(so3.as_matrix(R), R)
    np.testing.assert_allclose(so3.as_matrix(rot.as_quat()), R, atol=1e-15)
    q_first = rot.as_quat(scalar_first=True)
    np.testing.assert_allclose(so3.as_matrix(q_first, scalar_first=True), R, atol=1e-15)


def test_batched_quaternion_shapes():
    q = Rotation.random(12, random_state=RNG_SEED).as_quat().reshape(3, 4, 4)
    R = so3.from_quat(q)
    assert R.shape == (3, 4, 3, 3)
    assert so3.to_quat(R).shape == (3, 4, 4)


# ---------------------------------------------------------------------------------------------------------
# project / is_rotation


def test_project_returns_the_nearest_rotation():
    rng = np.random.default_rng(RNG_SEED)
    R = random_rotations(300, RNG_SEED)
    M = R + 0.05 * rng.standard_normal((300, 3, 3))  # det > 0 for this small perturbation
    assert np.all(np.linalg.det(M) > 0)
    P = so3.project(M)
    assert np.all(so3.orthogonality_error(P) < 1e-14)
    assert np.all(np.linalg.det(P) > 0)
    # scipy.linalg.polar: M = U H with U the nearest orthogonal matrix (a rotation when det M > 0)
    U = np.array([polar(m)[0] for m in M])
    np.testing.assert_allclose(P, U, atol=1e-13)


def test_project_is_the_identity_on_rotations():
    R = random_rotations(300, RNG_SEED + 5)
    np.testing.assert_allclose(so3.project(R), R, atol=1e-15)


def test_project_maps_reflections_and_arbitrary_matrices_to_rotations():
    M = np.random.default_rng(RNG_SEED).standard_normal((300, 3, 3))
    M[0] = np.diag([1.0, 1.0, -1.0])
    P = so3.project(M)
    assert np.all(so3.is_rotation(P, tol=1e-13))
    # det M < 0: the best rotation flips the direction of the smallest singular value; it is no farther than
    # the rotation obtained from the orthogonal polar factor by flipping its last singular direction.
    for m, p in zip(M[:50], P[:50], strict=True):
        U, s, Vt = np.linalg.svd(m)
        d = np.sign(np.linalg.det(U @ Vt))
        best = np.sqrt(np.sum((s - np.array([1, 1, d])) ** 2))
        np.testing.assert_allclose(np.linalg.norm(m - p), best, rtol=1e-12)


def test_is_rotation_and_orthogonality_error():
    R = random_rotations(5, RNG_SEED)
    assert np.all(so3.is_rotation(R))
    assert not so3.is_rotation(np.diag([1.0, 1.0, -1.0]))  # a reflection
    assert not so3.is_rotation(1.001 * np.eye(3))
    # ‖(1+ε)²I − I‖_F = √3 ((1+ε)² − 1)
    expected = np.sqrt(3) * (1.001**2 - 1)
    np.testing.assert_allclose(so3.orthogonality_error(1.001 * np.eye(3)), expected, rtol=1e-12)


# ---------------------------------------------------------------------------------------------------------
# Wrong shapes


@pytest.mark.parametrize(
    ("func", "arg", "match"),
    [
        (so3.hat, np.ones(4), r"hat expects vectors of shape \(\.\.\., 3\), got shape \(4,\)"),
        (so3.exp, np.ones((2, 2)), r"exp expects vectors of shape \(\.\.\., 3\), got shape \(2, 2\)"),
        (so3.vee, np.ones((3, 4)), r"vee expects matrices of shape \(\.\.\., 3, 3\), got shape \(3, 4\)"),
        (so3.log, np.ones(9), r"log expects matrices of shape \(\.\.\., 3, 3\), got shape \(9,\)"),
        (so3.project, np.ones(3), r"project expects matrices .*, got shape \(3,\)"),
        (so3.orthogonality_error, np.ones((2, 3)), r"orthogonality_error expects matrices .* \(2, 3\)"),
        (so3.is_rotation, np.ones((3, 4)), r"is_rotation expects matrices .* \(3, 4\)"),
        (so3.to_quat, np.ones((2, 3)), r"to_quat expects matrices .* \(2, 3\)"),
        (so3.from_quat, np.ones(3), r"quaternions must have shape \(\.\.\., 4\), got shape \(3,\)"),
        (so3.as_matrix, np.ones(5), r"an attitude must be a scipy Rotation, .* got shape \(5,\)"),
    ],
)
def test_wrong_shapes_are_named(func, arg, match):
    with pytest.raises(ValueError, match=match):
        func(arg)


def test_increments_are_scipys_relative_rotations_and_nan_across_a_missing_one():
    R = Rotation.random(6, random_state=3).as_matrix()
    R[3] = np.nan
    phi = so3.increments(R)
    ref = (Rotation.from_matrix(R[[0, 1, 4]]).inv() * Rotation.from_matrix(R[[1, 2, 5]])).as_rotvec()
    np.testing.assert_allclose(phi[[0, 1, 4]], ref, atol=1e-12)
    assert np.all(np.isnan(phi[[2, 3]]))


def test_wahba_is_scipys_align_vectors_and_nan_where_a_sample_is_missing():
    """(W) on three noisy, unnormalised directions: SciPy's ``Rotation.align_vectors`` (an independent solution of
    Wahba's problem, Markley's) gives the same attitude; a sample with a non-finite entry gives NaN."""
    rng = np.random.default_rng(5)
    R = Rotation.random(5, random_state=6).as_matrix()
    V = np.array([[0.0, 0.0, 9.8], [0.3, 0.9, -0.4], [1.0, 0.0, 0.0]])
    b = np.einsum("tji,nj->tni", R, V) + 0.01 * rng.standard_normal((5, 3, 3))
    b *= rng.uniform(0.5, 2.0, (5, 3, 1))  # lengths do not matter: (W) normalises
    b[2, 1, 0] = np.nan
    got = so3.wahba(b, V)
    for k in (0, 1, 3, 4):
        unit_v = V / np.linalg.norm(V, axis=1, keepdims=True)
        unit_b = b[k] / np.linalg.norm(b[k], axis=1, keepdims=True)
        ref = Rotation.align_vectors(unit_v, unit_b)[0].as_matrix()  # the rotation taking b onto v
        np.testing.assert_allclose(got[k], ref, atol=1e-12)
    assert np.all(np.isnan(got[2]))
    with pytest.raises(ValueError, match="wahba needs directions"):
        so3.wahba(b[:, :2], V)


def test_the_coning_term_is_the_increments_departure_from_the_mean_rate():
    """(M1) on a coning motion ``R(t) = Rz(αt) Rx(β) Rz(γt)`` (body rate in closed form) at 10 Hz: the differenced
    attitude departs from the interval's mean rate (SciPy's ``quad_vec``) by 5e-4 rad/s, and by less than 1e-6
    once the coning term is taken off."""
    from scipy.integrate import quad_vec

    alpha, beta, gamma, h = 1.3, 0.7, -0.9, 0.1

    def attitude(t):
        t = np.atleast_1d(t)
        z = np.array([0.0, 0.0, 1.0])
        return (
            Rotation.from_rotvec(np.outer(alpha * t, z))
            * Rotation.from_rotvec([beta, 0, 0])
            * Rotation.from_rotvec(np.outer(gamma * t, z))
        )

    def rate(t):
        t = np.atleast_1d(t)
        z = np.array([0.0, 0.0, 1.0])
        turn = (Rotation.from_rotvec(np.outer(gamma * t, z)).inv() * Rotation.from_rotvec([beta, 0, 0]).inv()).apply(z)
        return alpha * turn + gamma * z

    t = np.arange(0.0, 3.0, h)
    b = so3.increments(attitude(t).as_matrix()) / h
    mean = np.array([quad_vec(lambda s: rate(s)[0], a, a + h)[0] / h for a in t[:-1]])
    w = rate(t)
    assert np.max(np.abs(b - mean)) > 4e-4
    assert np.max(np.abs(b - mean - so3.coning(w[:-1], w[1:], h))) < 1e-6


def test_angle_is_scipys_relative_magnitude_at_every_angle_for_quaternions_and_matrices():
    """``so3.angle`` against SciPy's ``(a⁻¹ b).magnitude()``: random pairs, turns of 1e-9 rad and of π − 1e-9 rad
    (where an arccosine of a dot product or a trace loses half its digits), quaternions of any norm and sign in
    either scalar order, matrices, and NaN for a missing sample."""
    rng = np.random.default_rng(3)
    a = Rotation.random(200, random_state=rng)
    turns = np.concatenate([rng.uniform(0.0, np.pi, 194), [1e-9, 3e-7, 1e-4, np.pi - 1e-9, np.pi - 1e-5, 0.0]])
    axes = rng.normal(size=(200, 3))
    b = a * Rotation.from_rotvec(axes / np.linalg.norm(axes, axis=1, keepdims=True) * turns[:, None])
    truth = (a.inv() * b).magnitude()
    assert np.allclose(truth, turns, rtol=1e-12, atol=1e-15)  # SciPy recovers the turns made
    qa, qb = a.as_quat(), b.as_quat() * rng.choice([-3.0, 0.5], (200, 1))  # any norm, either sign
    np.testing.assert_allclose(so3.angle(qa, qb), truth, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(so3.angle(np.roll(qa, 1, axis=1), np.roll(qb, 1, axis=1)), truth, rtol=1e-9, atol=1e-15)
    near_pi = truth > np.pi - 1e-4  # the sine of a matrix's turn is of its entries' rounding there: 1e-8 rad
    matrices = so3.angle(a.as_matrix(), b.as_matrix())
    np.testing.assert_allclose(matrices[~near_pi], truth[~near_pi], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(matrices[near_pi], truth[near_pi], atol=1e-7)
    assert so3.angle(a.as_matrix()[0], b.as_matrix()[0]).shape == ()
    qa[5] = np.nan
    assert np.isnan(so3.angle(qa, qb)[5]) and np.isfinite(np.delete(so3.angle(qa, qb), 5)).all()


@given(vectors, vectors, st.floats(1e-4, 1.0))
def test_the_coning_term_of_one_step_is_that_of_a_stack(a, b, h):
    """(M1) for one step (a float ``h``, a streaming filter's) and for a stack of one (an array ``h``) agree."""
    np.testing.assert_allclose(so3.coning(a, b, h), so3.coning(a[None], b[None], np.array([h]))[0], rtol=1e-15)
    np.testing.assert_allclose(so3.coning(a, b, h), h / 12.0 * np.cross(a, b), rtol=1e-12, atol=1e-13)


@given(st.integers(0, 2**31), st.floats(0.1, 10.0), st.floats(0.1, 10.0))
def test_quat_product_composes_rotations_and_keeps_the_norms(seed, a, b):
    """``p ⊗ q`` is SciPy's composition ``R(p) R(q)`` (the rows' quaternion up to sign), and with quaternions of
    norm ``a`` and ``b`` its norm is ``a b`` (nothing normalised)."""
    p, q = Rotation.random(2, random_state=seed).as_quat()
    pq = so3.quat_product(p, q[None])[0]
    np.testing.assert_allclose(
        so3.from_quat(pq), (Rotation.from_quat(p) * Rotation.from_quat(q)).as_matrix(), atol=1e-12
    )
    scaled = so3.quat_product(a * p, np.stack([b * q, q]))
    np.testing.assert_allclose(np.linalg.norm(scaled, axis=1), [a * b, a], rtol=1e-12)
    with pytest.raises(ValueError, match="quat_product"):
        so3.quat_product(p[:3], q)
