"""The compiled primitives of omegahat.kernels against independent references: SciPy, exact rational arithmetic,
the paper's own (ξ, r̂) equations (omegahat.observer.continuous) and finite differences.

The kernels are public names of the package (called here from Python: Numba compiles them for these calls)."""

from decimal import Decimal, getcontext
from fractions import Fraction

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.kernels import dynamics, expfn, observer, rotation, vec3
from omegahat.observer import continuous
from omegahat.simulation.etd import step_factor

RNG = np.random.default_rng(7)


def _m(t):
    return np.array(t).reshape(3, 3)


# --------------------------------------------------------------------------------------------------- vec3


def test_vec3_against_numpy():
    for _ in range(20):
        a, b = RNG.normal(size=3), RNG.normal(size=3)
        M = RNG.normal(size=(3, 3)) + 3 * np.eye(3)
        assert np.allclose(vec3.cross(*a, *b), np.cross(a, b), rtol=0, atol=1e-15)
        assert vec3.dot(*a, *b) == pytest.approx(a @ b, abs=1e-15)
        assert vec3.norm(*a) == pytest.approx(np.linalg.norm(a), rel=1e-15)
        assert np.allclose(vec3.matvec(vec3.mat3(M), *a), M @ a, rtol=1e-15, atol=1e-15)
        assert np.allclose(vec3.matvec_transposed(vec3.mat3(M), *a), M.T @ a, rtol=1e-15, atol=1e-15)
        assert np.allclose(vec3.solve(vec3.mat3(M), *a), np.linalg.solve(M, a), rtol=1e-13, atol=1e-14)


# ----------------------------------------------------------------------------------------------- rotation


@pytest.mark.parametrize("theta", [0.0, 1e-9, 1e-5, 0.3, 2.0, np.pi - 1e-6])
def test_exp_and_quaternion_match_scipy(theta):
    axis = RNG.normal(size=3)
    phi = theta * axis / np.linalg.norm(axis)
    ref = Rotation.from_rotvec(phi)
    q = rotation.quat_from_rotvec(*phi)
    assert np.allclose(q, ref.as_quat(), rtol=0, atol=2e-16)
    assert np.allclose(_m(rotation.exp_matrix(*phi)), ref.as_matrix(), rtol=0, atol=5e-16)


def test_quaternion_product_is_the_matrix_product():
    p, q = Rotation.random(2, random_state=3)
    out = rotation.quat_multiply(*p.as_quat(), *q.as_quat())
    assert np.allclose(_m(rotation.matrix_from_quat(*out)), (p * q).as_matrix(), atol=1e-15)


@pytest.mark.parametrize("theta", [0.0, 1e-8, 0.5, 3.0, np.pi - 1e-7])
def test_matrix_to_quaternion_and_log_match_scipy(theta):
    axis = RNG.normal(size=3)
    r = Rotation.from_rotvec(theta * axis / np.linalg.norm(axis))
    R = r.as_matrix()
    assert np.allclose(rotation.quat_from_matrix(R), r.as_quat(canonical=True), atol=2e-16)
    assert np.allclose(rotation.rotvec_from_matrix(R), r.as_rotvec(), rtol=1e-12, atol=1e-15)


def test_quaternion_of_a_slightly_non_orthogonal_matrix_is_that_of_its_nearest_rotation():
    R = Rotation.random(random_state=5).as_matrix() + 1e-6 * RNG.normal(size=(3, 3))
    U, _, Vt = np.linalg.svd(R)
    nearest = U @ Vt
    assert np.allclose(rotation.nearest_rotation(R), nearest, atol=1e-15)
    assert np.allclose(rotation.quat_from_matrix(R), Rotation.from_matrix(nearest).as_quat(canonical=True), atol=1e-15)


@pytest.mark.parametrize("deviation", [1e-11, 1e-7, 1e-5, 9e-4, 5e-3])
def test_near_rotations_and_near_reflections_take_the_nearest_rotation(deviation):
    """A matrix near a rotation (QTM, Vicon and C3D write theirs in single precision: 1e-7 off) takes Newton–Schulz
    steps to its polar factor, one further off or near a reflection takes the SVD: either way the nearest rotation
    is the SVD's (NumPy's), and the quaternion SciPy's of it, for 200 matrices each."""
    rng = np.random.default_rng(int(1e6 * deviation) + 3)
    for k in range(200):
        R = Rotation.random(random_state=k).as_matrix() * (1.0 if k % 4 else -1.0)  # every 4th a reflection
        D = R + deviation * rng.normal(size=(3, 3))
        U, _, Vt = np.linalg.svd(D)
        nearest = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
        want = Rotation.from_matrix(nearest).as_quat(canonical=True)
        np.testing.assert_allclose(rotation.nearest_rotation(D), nearest, rtol=0, atol=1e-14)  # the SVD rounds too
        np.testing.assert_allclose(rotation.quat_from_matrix(D), want, rtol=0, atol=5e-15)


def test_orthogonality_error_and_determinant():
    R = Rotation.random(random_state=1).as_matrix()
    assert rotation.orthogonality_error(R) < 1e-15
    assert rotation.det(R) == pytest.approx(1.0, abs=1e-15)
    D = R.copy()
    D[0] *= -1.0
    assert rotation.det(D) == pytest.approx(-1.0, abs=1e-15)
    assert rotation.orthogonality_error(2.0 * R) == pytest.approx(np.linalg.norm(3.0 * np.eye(3)))


def test_wahba_matches_scipy_align_vectors():
    A = Rotation.random(random_state=11)
    sources = RNG.normal(size=(4, 3))
    targets = A.apply(sources) + 1e-3 * RNG.normal(size=(4, 3))
    w = np.array([1.0, 2.0, 0.5, 3.0])
    ref, _ = Rotation.align_vectors(targets, sources, weights=w)
    assert np.allclose(rotation.wahba(w, targets, sources), ref.as_matrix(), atol=1e-12)


def test_dexpinv_leaves_a_rate_parallel_to_the_increment_alone():
    w = np.array([0.3, -0.2, 0.7])
    assert np.allclose(rotation.dexpinv(*(0.1 * w), *w, 0.01), 0.01 * w, rtol=0, atol=1e-17)


# ----------------------------------------------------------------------------------------------- dynamics


def _frac(v):
    return [Fraction(float(x)) for x in v]


def _exact_gyroscopic_difference(J, w, z):
    J = [_frac(row) for row in J]
    w, z = _frac(w), _frac(z)
    wh = [a + b for a, b in zip(w, z, strict=True)]

    def gyro(x):
        Jx = [sum(J[i][j] * x[j] for j in range(3)) for i in range(3)]
        return [Jx[1] * x[2] - Jx[2] * x[1], Jx[2] * x[0] - Jx[0] * x[2], Jx[0] * x[1] - Jx[1] * x[0]]

    return [float(a - b) for a, b in zip(gyro(wh), gyro(w), strict=True)]


@pytest.mark.parametrize("scale", [1.0, 1e-9])
def test_gyroscopic_difference_is_exact_to_rounding_of_the_error(scale):
    # (Jω̂) × ω̂ − (Jω) × ω in exact rational arithmetic: the kernel keeps the relative precision of z itself
    J = np.array([[3.0, 0.1, -0.2], [0.1, 2.0, 0.05], [-0.2, 0.05, 1.0]])
    w = np.array([2.0, -1.0, 0.6])
    z = scale * np.array([0.3, 0.2, -0.1])
    exact = np.array(_exact_gyroscopic_difference(J, w, z))
    got = np.array(dynamics.gyroscopic_difference(vec3.mat3(J), *w, *z))
    assert np.allclose(got, exact, rtol=1e-14, atol=1e-15 * np.abs(exact).max())


def test_euler_rate_is_eulers_equations():
    J = np.diag([3.0, 2.0, 1.0])
    w, tau = np.array([2.0, -1.0, 0.6]), np.array([0.1, 0.2, -0.3])
    expected = np.linalg.solve(J, np.cross(J @ w, w) + tau)
    got = dynamics.euler_rate(vec3.mat3(J), vec3.mat3(np.linalg.inv(J)), *w, *tau)
    assert np.allclose(got, expected, rtol=1e-15, atol=1e-15)


def test_cf4_increment_turns_an_axisymmetric_spin_exactly():
    # Spin about a principal axis: ω is constant and the attitude increment is exp(h ω) exactly
    J = np.diag([3.0, 2.0, 1.0])
    w = np.array([0.0, 0.0, 1.3])
    zero = np.zeros(3)
    p, w_next = dynamics.cf4_increment(vec3.mat3(J), vec3.mat3(np.linalg.inv(J)), *w, 0.1, zero, zero, zero)
    assert np.allclose(w_next, w, atol=1e-16)
    assert np.allclose(p, Rotation.from_rotvec(0.1 * w).as_quat(), atol=1e-16)


# ----------------------------------------------------------------------------------------------- observer


def test_innovation_and_euler_are_the_papers_equations_in_error_coordinates():
    """(O1)–(O2) against the paper's (ξ, r̂) equations: ω̂ = ξ + β(r, r̂) differentiated along the observer with
    ṙ = r × ω, by the chain rule, equals Euler's equations at ω̂ plus Σ innovation(k_i, r̂_i, r_i × (ω̂ − ω))."""
    J = np.array([[3.0, 0.1, 0.0], [0.1, 2.0, 0.0], [0.0, 0.0, 1.0]])
    Jinv = np.linalg.inv(J)
    k, l_off, l_slope = np.array([4.0, 6.0]), np.array([5.0, 3.0]), np.array([0.5, 1.5])
    r = Rotation.random(random_state=2).as_matrix()[:2]
    r_hat = r + 0.1 * RNG.normal(size=(2, 3))
    omega, xi, tau = np.array([0.4, -0.3, 0.9]), np.array([0.2, 0.1, -0.5]), np.array([0.05, 0.0, -0.02])
    # the paper's equations and the chain rule through the output map β = J⁻¹ Σ k_i r_i × r̂_i
    xi_dot, r_hat_dot = continuous.observer_rhs(xi, r_hat, r, tau, J, Jinv, k, l_off, l_slope)
    r_dot = np.cross(r, omega)
    beta_dot = Jinv @ np.sum(k[:, None] * (np.cross(r_dot, r_hat) + np.cross(r, r_hat_dot)), axis=0)
    omega_hat = continuous.output_map(xi, r, r_hat, k, Jinv)
    expected_w = xi_dot + beta_dot
    expected_e = r_hat_dot - r_dot
    # the kernels
    z = omega_hat - omega
    acc = np.array(dynamics.euler_rate(vec3.mat3(J), vec3.mat3(Jinv), *omega_hat, *tau))
    s = np.zeros(3)
    got_e = np.empty((2, 3))
    speed = np.linalg.norm(omega_hat)
    for i in range(2):
        out = observer.innovation(k[i], *r_hat[i], *np.cross(r[i], z))
        s += out[:3]
        e = r_hat[i] - r[i]
        l = observer.decay_rate(l_off[i], l_slope[i], speed)
        got_e[i] = observer.filter_rate(*out[3:], *e, *omega_hat, l)
    got_w = acc + Jinv @ s
    assert np.allclose(got_w, expected_w, rtol=1e-12, atol=1e-12)
    assert np.allclose(got_e, expected_e, rtol=1e-12, atol=1e-12)


def test_stiffness_is_minus_the_jacobian_of_the_innovation():
    k = 2.5
    r = np.array([0.3, -0.5, 0.8])
    entries = observer.stiffness(k, *r)
    M = np.array(
        [
            [entries[0], entries[3], entries[4]],
            [entries[3], entries[1], entries[5]],
            [entries[4], entries[5], entries[2]],
        ]
    )
    jac = np.column_stack([observer.innovation(k, *r, *np.cross(r, col))[:3] for col in np.eye(3)])
    assert np.allclose(M, -jac, atol=1e-15)


def test_output_map_matches_the_reference():
    J = np.diag([3.0, 2.0, 1.0])
    Jinv = np.linalg.inv(J)
    k = np.array([14.5, 14.5])
    r, r_hat = RNG.normal(size=(2, 3)), RNG.normal(size=(2, 3))
    expected = continuous.output_map(np.zeros(3), r, r_hat, k, Jinv)
    assert np.allclose(observer.output_map(vec3.mat3(Jinv), k, r, r_hat), expected, rtol=1e-15, atol=1e-15)


# -------------------------------------------------------------------------------------------------- expfn


def test_small_angle_sin_cos_agree_with_numpy_to_rounding():
    x = np.linspace(-0.25, 0.25, 20001)
    s, c = np.array([expfn.sin_cos_small(v) for v in x]).T
    # within one unit in the last place of libm's correctly rounded-or-nearly values
    assert np.all(np.abs(s - np.sin(x)) <= np.spacing(np.abs(np.sin(x))))
    assert np.all(np.abs(c - np.cos(x)) <= np.spacing(np.cos(x)))


def _phi_exact(k, x):
    # φ_k(x) = (e^x − Σ_{j<k} x^j/j!) / x^k in 60-digit decimal arithmetic
    getcontext().prec = 60
    X = Decimal(repr(x))
    acc = X.exp()
    term = Decimal(1)
    for j in range(k):
        acc -= term
        term = term * X / (j + 1)
    return float(acc / X**k)


@pytest.mark.parametrize("x", [-1e-8, -0.1, -0.4999, -0.5, -0.5001, -2.0, -30.0, -800.0])
def test_phi_functions_match_high_precision(x):
    p1, p2, p3, ex = expfn.phi123(x)
    # φ₁ at x as a step computes it for its half step x = (2x)/2: the Taylor series or (e^x − 1)·(2/(2x))
    q1, ex1 = expfn.phi1_taylor(x) if abs(x) < 0.5 else (expfn.phi1_half_closed(2.0 * x, ex), ex)
    for got, k in ((p1, 1), (p2, 2), (p3, 3), (q1, 1)):
        want = _phi_exact(k, x)
        assert abs(got - want) <= 4e-15 * abs(want), (k, x, got, want)
    assert ex == ex1 and abs(ex - np.exp(x)) <= 4e-16 * np.exp(x)


def test_step_factor_is_the_clipped_fourth_root_rule():
    for err in (1e-12, 0.01, 0.5, 0.999, 1.0, 3.0, 1e6):
        assert step_factor(err) == pytest.approx(min(4.0, max(0.2, 0.9 * err**-0.25)), rel=1e-15)
    assert step_factor(0.0) == 4.0
