"""One input path: the same bad log is rejected by every estimator (Sarras, MEKF, differencing, spline, the two TSO(3)
filters; with one direction the one-direction observer and the sun-line SEKF) with the same message, the one
omegahat.measurements.describe_rejection gives; the same tolerances hold everywhere; problem definitions go through
the same check with the stated tighter tolerance.

The expected messages are written out by hand below (numbers chosen to print exactly); the test also checks that
describe_rejection produces exactly those words, so that the estimators, measurements and this file agree. (Every
estimator's contract, refusals included, is tests/test_contract.py.)
"""

import inspect
import re

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.spline import SplineEstimator
from omegahat.baselines.sunline_sekf import SunlineSEKF
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter
from omegahat.identification.spectral import SpectralSmoother
from omegahat.interface import Status
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.single_direction import SingleDirectionEstimator
from omegahat.simulation import CoupledProblem
from omegahat.simulation.rigid_body import RigidBody, integrate

J = np.diag([3.0, 2.0, 1.0])
T = 6
TIMES = 0.125 * np.arange(T)  # exact binary fractions: t = 0.375 prints as 0.375
ROT = Rotation.from_rotvec(np.outer(TIMES, [0.4, -0.2, 0.3]))
REFS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])


def sarras(references=None):
    return SarrasEstimator(
        J, gains=ObserverGains.constant(10.0, 20.0, n=3 if references is None else 2), references=references
    )


def mekf(references=None):
    return MEKF(
        J if references is None else None,
        model="dynamic" if references is None else "kinematic",
        references=references,
    )


def min_energy(references=None):
    return MinimumEnergyFilter(J, references=references)


def predictive(references=None):
    return PredictiveFilter(J, references=references)


ATTITUDE_ESTIMATORS = {
    # Sarras: the estimator as it is today (its own wording for times and torques, the same words)
    "sarras": sarras,
    "mekf": mekf,
    "differencing": DifferencingEstimator,
    "spline": SplineEstimator,
    "spectral-smoother": SpectralSmoother,
    "min-energy": min_energy,
    "predictive": predictive,
}
STREAMING = (
    "sarras",
    "mekf",
    "differencing",
    "min-energy",
    "predictive",
)  # the spline and the smoother are offline: no update
DIRECTION_ESTIMATORS = {"sarras": sarras, "mekf": mekf, "min-energy": min_energy, "predictive": predictive}
CLASSES = {
    "sarras": SarrasEstimator, "mekf": MEKF, "differencing": DifferencingEstimator, "spline": SplineEstimator,
    "spectral-smoother": SpectralSmoother, "min-energy": MinimumEnergyFilter, "predictive": PredictiveFilter,
}  # fmt: skip
ONE_DIRECTION_ESTIMATORS = {  # one measured direction: the n = 1 path of omegahat.measurements
    "single-direction": lambda: SingleDirectionEstimator(J, reference=REFS[0]),
    "sunline-sekf": SunlineSEKF,
}


def not_a_rotation():
    R = ROT.as_matrix()
    R[3] *= 1.01  # ‖RᵀR − I‖_F = √3 (1.01² − 1) = 0.0348
    return TIMES, R


def reflection():
    R = ROT.as_matrix()
    R[3] = -R[3]  # orthogonal, det = −1
    return TIMES, R


def non_unit_quaternion():
    q = ROT.as_quat()
    q[3] *= 1.5
    return TIMES, q


def time_backwards():
    t = TIMES.copy()
    t[3] = 0.125
    return t, ROT.as_matrix()


def time_not_finite():
    t = TIMES.copy()
    t[3] = np.nan
    return t, ROT.as_matrix()


BAD_LOGS = {
    "not a rotation": (
        not_a_rotation,
        (ms.NOT_ORTHOGONAL, 0.0348, 0.375),
        "sample 3 (t = 0.375): not a rotation matrix: |R^T R - I| = 0.0348 exceeds rotation_tol (pass "
        "rotation_tol=0.07 to accept it, or fix the data)",
    ),
    "reflection": (
        reflection,
        (ms.NOT_PROPER, -1.0, 0.375),
        "sample 3 (t = 0.375): a reflection, not a rotation: det R = -1 < 0",
    ),
    "non-unit quaternion": (
        non_unit_quaternion,
        (ms.QUAT_NORM, 1.5, 0.375),
        "sample 3 (t = 0.375): a quaternion far from unit norm: |q| = 1.5, |(|q| - 1)| exceeds quat_norm_tol (pass "
        "quat_norm_tol=1.0 to accept it, or fix the data; is it a quaternion, and its order right: scalar_first?)",
    ),
    "time backwards": (
        time_backwards,
        (ms.TIME_ORDER, 0.25, 0.125),
        "sample 3: time t = 0.125 is not after the previous sample's t = 0.25 (timestamps must increase strictly)",
    ),
    "time not finite": (
        time_not_finite,
        (ms.TIME_NOT_FINITE, np.nan, np.nan),
        "sample 3: time t = nan is not finite",
    ),
}


@pytest.mark.parametrize("case", list(BAD_LOGS))
def test_describe_rejection_gives_the_words_every_estimator_uses(case):
    _, (status, info, t), expected = BAD_LOGS[case]
    assert ms.describe_rejection(status, info, "sample 3", t) == expected


@pytest.mark.parametrize("name", list(ATTITUDE_ESTIMATORS))
@pytest.mark.parametrize("case", list(BAD_LOGS))
def test_every_estimator_rejects_a_bad_log_with_the_same_message(case, name):
    make_log, _, expected = BAD_LOGS[case]
    times, attitudes = make_log()
    # ValueError: the Sarras estimator still raises a plain ValueError for times (MeasurementError is one)
    with pytest.raises(ValueError, match=f"^{re.escape(expected)}$"):
        ATTITUDE_ESTIMATORS[name]().run(times, attitudes)
    with pytest.raises(ms.MeasurementError, match=f"^{re.escape(expected)}$"):
        ms.checked_log(times, attitudes)


@pytest.mark.parametrize("name", STREAMING)
@pytest.mark.parametrize("case", list(BAD_LOGS))
def test_every_streaming_estimator_rejects_the_bad_sample_with_the_same_message(case, name):
    make_log, (status, info, t), _ = BAD_LOGS[case]
    times, attitudes = make_log()
    expected = ms.describe_rejection(status, info, "the sample", t)
    assert expected.startswith("the sample")
    est = ATTITUDE_ESTIMATORS[name]()
    for j in range(3):
        est.update(times[j], attitudes[j])
    with pytest.raises(ValueError, match=f"^{re.escape(expected)}$"):
        est.update(times[3], attitudes[3])


WRONG_SHAPES = [
    # (times, measurements, message)
    (
        TIMES,
        np.zeros((T, 3)),
        f"measurements must have shape (T, 3, 3) or (T, 4) with T = {T} samples; got shape (6, 3)",
    ),
    (
        TIMES[:5],
        ROT.as_matrix(),
        "measurements must have shape (T, 3, 3) or (T, 4) with T = 5 samples; got shape (6, 3, 3)",
    ),
    (TIMES.reshape(2, 3), ROT.as_matrix(), "times must have shape (T,); got shape (2, 3)"),
]


@pytest.mark.parametrize("name", list(ATTITUDE_ESTIMATORS))
@pytest.mark.parametrize(("times", "measurements", "message"), WRONG_SHAPES)
def test_every_estimator_names_a_wrong_shape_the_same_way(name, times, measurements, message):
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        ATTITUDE_ESTIMATORS[name]().run(times, measurements)


@pytest.mark.parametrize("name", STREAMING)
def test_every_streaming_estimator_names_a_wrong_sample_shape_the_same_way(name):
    message = "an attitude sample must be a 3x3 matrix, a quaternion (4,) or a Rotation; got shape (2, 3)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        ATTITUDE_ESTIMATORS[name]().update(0.0, np.zeros((2, 3)))


@pytest.mark.parametrize("name", list(DIRECTION_ESTIMATORS))
def test_direction_input_is_checked_the_same_way(name):
    b = np.einsum("ij,tjk->tik", REFS, ROT.as_matrix())  # rows Rᵀ v_i
    zero = b.copy()
    zero[3, 1] = 0.0
    expected = "sample 3 (t = 0.375): measured direction b2 has zero length"
    with pytest.raises(ms.MeasurementError, match=f"^{re.escape(expected)}$"):
        DIRECTION_ESTIMATORS[name](REFS).run(TIMES, zero)
    message = f"measurements must have shape (T, 2, 3) with T = {T} samples; got shape (6, 3, 3)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        DIRECTION_ESTIMATORS[name](REFS).run(TIMES, ROT.as_matrix())
    message = "a direction sample must have shape (2, 3) (one row per reference); got shape (3, 3)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        DIRECTION_ESTIMATORS[name](REFS).update(0.0, np.eye(3))


@pytest.mark.parametrize("name", list(ONE_DIRECTION_ESTIMATORS))
def test_one_direction_input_is_checked_the_same_way(name):
    b = ROT.inv().apply(REFS[0])  # (T, 3): one direction per sample, Rᵀ v
    zero = b.copy()
    zero[3] = 0.0
    expected = "sample 3 (t = 0.375): measured direction b1 has zero length"
    with pytest.raises(ms.MeasurementError, match=f"^{re.escape(expected)}$"):
        ONE_DIRECTION_ESTIMATORS[name]().run(TIMES, zero)
    message = f"measurements must have shape (T, 3) or (T, 1, 3) with T = {T} samples; got shape (6, 2, 3)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        ONE_DIRECTION_ESTIMATORS[name]().run(TIMES, np.stack([b, b], axis=1))
    message = "a one-direction sample must have shape (3,) or (1, 3); got shape (2, 3)"
    with pytest.raises(ValueError, match=f"^{re.escape(message)}$"):
        ONE_DIRECTION_ESTIMATORS[name]().update(0.0, np.eye(3)[:2])
    est = ONE_DIRECTION_ESTIMATORS[name]()
    whole = est.run(TIMES, b)  # (T, 3) and (T, 1, 3) are the same log; no sample is skipped as collinear
    assert est.n_skipped == 0 and np.all(whole.status[2:] == Status.CORRECTED)
    np.testing.assert_array_equal(ONE_DIRECTION_ESTIMATORS[name]().run(TIMES, b[:, None]).omega, whole.omega)


@pytest.mark.parametrize("name", ["sarras", "mekf", "min-energy", "predictive"])
def test_a_torque_that_is_not_finite_is_rejected_the_same_way(name):
    # differencing and the spline do not use torques: they are not checked there
    torques = np.zeros((T, 3))
    torques[3, 2] = np.inf
    expected = "sample 3 (t = 0.375): torque must be finite; got inf"
    with pytest.raises(ValueError, match=f"^{re.escape(expected)}$"):
        ATTITUDE_ESTIMATORS[name]().run(TIMES, ROT.as_matrix(), torques)


@pytest.mark.parametrize("name", list(ATTITUDE_ESTIMATORS))
def test_one_tolerance_policy(name):
    """Every estimator takes rotation_tol, quat_norm_tol and scalar_first with the library's defaults, and they
    decide alike: a matrix 5e-4 from orthogonal is accepted, one 2e-3 away is rejected."""
    params = inspect.signature(CLASSES[name]).parameters
    assert params["rotation_tol"].default == ms.ROTATION_TOL == 1e-3
    assert params["quat_norm_tol"].default == ms.QUAT_NORM_TOL == 1e-3
    assert params["scalar_first"].default is False
    R = ROT.as_matrix()
    ortho = lambda M: np.linalg.norm(M.T @ M - np.eye(3))  # noqa: E731
    R[3] = ROT[3].as_matrix() * (1 + 5e-4 / (2 * np.sqrt(3)))  # ‖RᵀR − I‖ ≈ 5e-4
    assert 4.9e-4 < ortho(R[3]) < 5.1e-4
    assert np.all(np.isfinite(ATTITUDE_ESTIMATORS[name]().run(TIMES, R).omega[4:]))
    R[3] = ROT[3].as_matrix() * (1 + 2e-3 / (2 * np.sqrt(3)))
    with pytest.raises(
        ms.MeasurementError, match=r"^sample 3 \(t = 0\.375\): not a rotation matrix: \|R\^T R - I\| = 0\.002 "
    ):
        ATTITUDE_ESTIMATORS[name]().run(TIMES, R)


@pytest.mark.filterwarnings("ignore:skipped 1 of 6 samples")
@pytest.mark.parametrize("name", list(ATTITUDE_ESTIMATORS))
def test_a_missing_sample_is_skipped_by_every_estimator(name):
    R = ROT.as_matrix()
    R[3, 1, 1] = np.nan
    assert np.all(np.isfinite(ATTITUDE_ESTIMATORS[name]().run(TIMES, R).omega[-2]))


def test_problem_definitions_share_the_check_and_its_tighter_tolerance():
    assert ms.PROBLEM_ROTATION_TOL == 1e-9
    R0 = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix() * (1 + 1e-6)  # fine as a measurement, not as a problem
    assert ms.attitude_matrices(R0).shape == (3, 3)
    expected = "R0 is not a rotation matrix: ‖RᵀR − I‖_F = 3.46e-06 exceeds 1e-09"
    with pytest.raises(ValueError, match=f"^{re.escape(expected)}$"):
        integrate(RigidBody(J), R0, [1.0, 0.0, 0.0], [0.0, 1.0])
    with pytest.raises(ValueError, match=f"^{re.escape(expected)}$"):
        CoupledProblem(J, ObserverGains.constant(1.0, 1.0, n=2), [1.0, 0.0, 0.0], R0=R0)
    with pytest.raises(ValueError, match=r"^R0: a reflection, not a rotation: det R = -1 < 0$"):
        CoupledProblem(J, ObserverGains.constant(1.0, 1.0, n=2), [1.0, 0.0, 0.0], R0=-np.eye(3))
