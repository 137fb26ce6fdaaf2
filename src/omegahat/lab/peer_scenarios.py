r"""The sources' own simulation settings for the three gyro-free peers, defined once for the benchmark and the tests.

* :func:`min_energy_scenario`, :func:`predictive_scenario`: the two scripts of ``NikolasKubis/
  attitude_estimation_TSO3`` (``min_energy_filter/second_order_minimum_symplectic.m``, ``geom_filter/
  predictive_filter_geom.m``): their J, torque, initial state, directions, noise, step and horizon, and their filters'
  settings (:func:`source_filter`). The truth is integrated by omegahat's CF4 integrator
  (:func:`omegahat.simulation.rigid_body.integrate`, steps of at most 1 ms) rather than by the scripts' own
  second-order schemes; the noise is white Gaussian (the minimum-energy script also removes its sample mean);
* :func:`basilisk_case`, :data:`BASILISK_CASES`: the full-filter test of Basilisk's sun-line SEKF
  (``_UnitTest/test_SunLineSEKF.py``, ``StateUpdateSunLine``): eight coarse sun sensors read every 0.5 s, a fixed
  Sun heading read from the 22nd update, a second heading from the 22nd update of the second half, and the test's
  own pass criteria (:func:`basilisk_passes`).

``benchmarks/peers.py`` runs them at length and several seeds; ``tests/test_peer_scenarios.py`` runs one seed of each.

* :data:`DIRECTION_SCENARIOS`: the scenarios of ``omegahat compare`` whose sensor gives directions instead of
  attitudes (:class:`DirectionScenario`, simulated by :func:`simulate_directions`): ``two-directions`` and
  ``two-directions-heavy``, the two TSO(3) scripts' problems (their J, torque, initial state, directions, noise,
  100 Hz for 100 s; every estimator cold, from ω̂₀ = 0 and the first sample's attitude), and ``one-direction``, a
  torque-free tumble of J = diag(3, 2, 1) seen by a sun sensor at 10 Hz with 0.1° of noise per component for
  300 s (the setting of ``benchmarks/single_direction.py``, one draw), from ω̂₀ = 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.sunline_kernel import run_log as sekf_run_log
from omegahat.baselines.tso3_common import TSO3Filter
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter
from omegahat.lab.scenarios import Run
from omegahat.simulation.rigid_body import RigidBody, Trajectory, integrate
from omegahat.simulation.torque import Torque

__all__ = [
    "BASILISK_CASES",
    "BASILISK_NORMALS",
    "DIRECTION_SCENARIOS",
    "BasiliskCase",
    "BasiliskRun",
    "DirectionScenario",
    "Scenario",
    "basilisk_case",
    "basilisk_passes",
    "error_across",
    "kind",
    "min_energy_scenario",
    "predictive_scenario",
    "references",
    "simulate",
    "simulate_directions",
    "source_filter",
]

#: The scripts' torque τ(t) = (sin(2πt/3), cos(2πt), sin(2πt/5)) N·m.
KUBIS_TORQUE = Torque.sinusoidal(
    amplitudes=np.eye(3),
    frequencies=[2 * np.pi / 3, 2 * np.pi, 2 * np.pi / 5],
    phases=[[0.0, 0.0, 0.0], [0.0, np.pi / 2, 0.0], [0.0, 0.0, 0.0]],
)


@dataclass(frozen=True)
class Scenario:
    """A source script's simulation: ``J``, the directions ``references`` (n, 3), the initial attitude (an angle
    about (1, 1, 1)/√3) and rate, the direction noise σ per component, the step h and the horizon; ``filter`` the
    filter's own settings (keywords of its class)."""

    name: str
    J: np.ndarray
    references: np.ndarray
    angle0: float
    omega0: np.ndarray
    sigma: float
    h: float
    horizon: float
    filter: dict = field(default_factory=dict)

    @property
    def R0(self) -> np.ndarray:
        return Rotation.from_rotvec(self.angle0 * np.ones(3) / np.sqrt(3.0)).as_matrix()


def min_energy_scenario() -> Scenario:
    """``second_order_minimum_symplectic.m``: J = diag(6, 7, 9), v = (e₃, e₂), R(0) = Exp(1.8 rad), σ = 0.01."""
    return Scenario(
        "minimum-energy", np.diag([6.0, 7.0, 9.0]), np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]]), 1.8,
        np.array([0.3, 0.2, 0.1]), 0.01, 0.01, 100.0,
        {"weights": 0.1, "process_weight": 1.0, "alpha": 0.01, "K0": 1.0},
    )  # fmt: skip


def predictive_scenario() -> Scenario:
    """``predictive_filter_geom.m``: J = diag(60, 70, 90), v = (e₂, e₃), R(0) = Exp(1.7 rad), σ = 0.001."""
    return Scenario(
        "predictive", np.diag([60.0, 70.0, 90.0]), np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]), 1.7,
        np.array([0.3, 0.2, 0.1]), 0.001, 0.01, 100.0,
        {"residual_weight": 1e4, "disturbance_weight": 4e-3, "attitude_gain": 0.7},
    )  # fmt: skip


def source_filter(scenario: Scenario, *, as_published: bool) -> TSO3Filter:
    """The scenario's filter with the source's settings, started where the source starts it (R̂ = I, ω̂ = 0)."""
    cls = MinimumEnergyFilter if scenario.name == "minimum-energy" else PredictiveFilter
    return cls(
        scenario.J, references=scenario.references, R0=np.eye(3), omega_hat0=np.zeros(3), as_published=as_published,
        **scenario.filter,
    )  # fmt: skip


def simulate(
    scenario: Scenario, seed: int, horizon: float | None = None, sigma: float | None = None
) -> tuple[Trajectory, np.ndarray]:
    """The truth at the samples ``t_k = k h`` up to ``horizon`` (default the scenario's) and the measured directions
    ``(T, n, 3)`` with white noise of ``sigma`` (default the scenario's) per component, seeded."""
    T = round((scenario.horizon if horizon is None else horizon) / scenario.h)
    t = scenario.h * np.arange(T + 1)
    truth = integrate(RigidBody(scenario.J), scenario.R0, scenario.omega0, t, KUBIS_TORQUE)
    b = np.einsum("tji,nj->tni", truth.R, scenario.references)
    noise = scenario.sigma if sigma is None else sigma
    return truth, b + noise * np.random.default_rng(seed).normal(size=b.shape)


# ------------------------------------------------------------------------------------ compare's direction scenarios


@dataclass(frozen=True)
class DirectionScenario:
    """A scenario of ``omegahat compare`` whose sensor measures ``n`` known inertial directions ``references``
    ``(n, 3)`` in the body (``n = 1``: one direction), each with white noise ``measurement_noise`` per component, at
    ``rate_hz`` for ``duration`` s; the body ``J`` (told to the estimators as it is) starts at ``R0``, ``omega0``
    under the known ``torque`` (None: none), sampled at the sample times and held. The other fields are those of
    :class:`omegahat.lab.scenarios.Scenario` that the comparison reads."""

    name: str
    description: str
    J: np.ndarray
    R0: np.ndarray
    omega0: np.ndarray
    references: np.ndarray
    torque: Torque | None
    rate_hz: float
    duration: float
    measurement_noise: float
    converged_tol: float
    steady_after: float
    omega_max: float
    omega_hat0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    real = False  # simulated

    @property
    def J_model(self) -> np.ndarray:
        return self.J

    @property
    def measurement(self) -> str:
        """``"directions"`` (n ≥ 2) or ``"one-direction"``."""
        return "one-direction" if self.references.shape[0] == 1 else "directions"


def _from_source(name: str, description: str, source: Scenario) -> DirectionScenario:
    return DirectionScenario(
        name, description, source.J, source.R0, source.omega0, source.references, KUBIS_TORQUE, 1.0 / source.h,
        source.horizon, source.sigma, np.radians(1.0), 50.0, 1.0,
    )  # fmt: skip


_SUN = np.array([[0.3, -0.5, 0.81]]) / np.linalg.norm([0.3, -0.5, 0.81])

#: name -> the direction scenarios of ``omegahat compare`` (module docstring)
DIRECTION_SCENARIOS: dict[str, DirectionScenario] = {
    s.name: s
    for s in (
        _from_source(
            "two-directions",
            "the minimum-energy script's problem: J = diag(6,7,9), two directions (e3, e2) with noise 0.01, known "
            "sinusoidal torque, 100 Hz",
            min_energy_scenario(),
        ),
        _from_source(
            "two-directions-heavy",
            "the predictive script's problem: J = diag(60,70,90), two directions (e2, e3) with noise 0.001, known "
            "sinusoidal torque, 100 Hz",
            predictive_scenario(),
        ),
        DirectionScenario(
            "one-direction",
            "one direction (a sun sensor, 0.1 deg per component) at 10 Hz, J = diag(3,2,1) tumbling torque-free at "
            "0.5 rad/s",
            J=np.diag([3.0, 2.0, 1.0]),
            R0=np.eye(3),
            omega0=0.5 * np.array([0.6, -0.5, 0.62]) / np.linalg.norm([0.6, -0.5, 0.62]),
            references=_SUN,
            torque=None,
            rate_hz=10.0,
            duration=300.0,
            measurement_noise=np.radians(0.1),
            converged_tol=0.02,  # rad/s, as benchmarks/single_direction.py
            steady_after=200.0,
            omega_max=1.0,
        ),
    )
}


def simulate_directions(sc: DirectionScenario, seed: int, duration: float | None = None) -> Run:
    """Truth and noisy directions of a :class:`DirectionScenario` (``duration`` overrides its own), noise drawn from
    ``numpy.random.default_rng(numpy.random.SeedSequence(seed))`` as the attitude scenarios': a
    :class:`omegahat.lab.scenarios.Run` whose ``R_meas`` holds the measured directions ``(T, n, 3)`` (one
    direction: ``(T, 3)``), with the torque at the samples, the true rate and attitude."""
    h = 1.0 / sc.rate_hz
    t = h * np.arange(round((sc.duration if duration is None else float(duration)) / h) + 1)
    truth = integrate(RigidBody(sc.J), sc.R0, sc.omega0, t, sc.torque)
    b = np.einsum("tji,nj->tni", truth.R, sc.references)
    b = b + sc.measurement_noise * np.random.default_rng(np.random.SeedSequence(seed)).normal(size=b.shape)
    return Run(t, b[:, 0] if sc.references.shape[0] == 1 else b, truth.torque, truth.omega, truth.R)


def kind(sc: object) -> str:
    """What a scenario's sensor gives: ``"attitude"`` (the attitude scenarios of :mod:`omegahat.lab.scenarios`),
    ``"directions"`` (n ≥ 2) or ``"one-direction"``."""
    return sc.measurement if isinstance(sc, DirectionScenario) else "attitude"


def references(sc: object) -> np.ndarray | None:
    """The inertial directions a direction scenario's sensor measures ``(n, 3)``; None for attitudes."""
    return sc.references if isinstance(sc, DirectionScenario) else None


def error_across(run: Run, sc: DirectionScenario, w: np.ndarray, err: np.ndarray) -> np.ndarray:
    """``|(I − b bᵀ)(ω̂ − ω)|``, the error across the true measured direction ``b = Rᵀ v`` of a one-direction
    scenario (the rate about b is not observable at an instant); where ``err`` (the whole error) is not finite
    (no estimate, or diverged) it is ``err``."""
    if run.R is None:
        raise ValueError("the error across the measured direction needs the true attitudes (a simulated run)")
    b = np.einsum("tji,j->ti", run.R, sc.references[0])
    d = w - run.omega
    with np.errstate(invalid="ignore"):
        across = np.linalg.norm(d - np.sum(d * b, axis=1, keepdims=True) * b, axis=1)
    return np.where(np.isfinite(err), across, err)


# --------------------------------------------------------------------------------------------- Basilisk's test

#: The unit test's eight coarse sun sensors' normals (body axes).
BASILISK_NORMALS = np.array(
    [
        [0.70710678118654746, -0.5, 0.5],
        [0.70710678118654746, -0.5, -0.5],
        [0.70710678118654746, 0.5, -0.5],
        [0.70710678118654746, 0.5, 0.5],
        [-0.70710678118654746, 0.0, 0.70710678118654757],
        [-0.70710678118654746, 0.70710678118654757, 0.0],
        [-0.70710678118654746, 0.0, -0.70710678118654757],
        [-0.70710678118654746, -0.70710678118654757, 0.0],
    ]
)


class BasiliskCase(NamedTuple):
    """One parametrisation of ``test_all_sunline_sekf``: updates per half, noise on, the two headings, the guess."""

    half: int
    noise: bool
    heading1: tuple[float, float, float]
    heading2: tuple[float, float, float]
    guess: tuple[float, float, float, float, float]


#: The five cases of the unit test's ``pytest.mark.parametrize``.
BASILISK_CASES = (
    BasiliskCase(200, True, (-0.7, 0.7, 0.0), (0.8, 0.9, 0.0), (0.7, 0.7, 0.0, 0.0, 0.0)),
    BasiliskCase(2000, True, (-0.7, 0.7, 0.0), (0.8, 0.9, 0.0), (0.7, 0.7, 0.0, 0.0, 0.0)),
    BasiliskCase(200, False, (-0.7, 0.7, 0.0), (0.8, 0.9, 0.0), (0.7, 0.7, 0.0, 0.0, 0.0)),
    BasiliskCase(200, False, (0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (0.3, 0.0, 0.6, 0.0, 0.0)),
    BasiliskCase(200, True, (0.5, 0.5, 0.0), (0.0, 1.0, 0.0), (0.7, 0.7, 0.0, 0.0, 0.0)),
)

_BASILISK_H = 0.5
_BASILISK_P0 = np.diag([0.4, 0.4, 0.4, 0.004, 0.004])
_BASILISK_PARAMS = (0.01, 0.001, (4.0 / 3.0) ** 2)  # q, σ², the EKF/CKF threshold


class BasiliskRun(NamedTuple):
    """The published state ``[d, −ω₂, −ω₃]`` and covariance at the end of each half, the initial covariance, the
    number of updates made in the CKF form and the largest rate estimate ``|(ω₂, ω₃)|`` (rad/s) along the run (the
    truth is 0)."""

    state1: np.ndarray
    state2: np.ndarray
    P1: np.ndarray
    P2: np.ndarray
    P0: np.ndarray
    ckf_updates: int
    peak_rate: float


def basilisk_case(case: BasiliskCase, seed: int = 42, *, as_published: bool = True) -> BasiliskRun:
    """Run one case through the compiled loop (:func:`omegahat.baselines.sunline_kernel.run_log`) with the sensors
    of :data:`BASILISK_NORMALS`, readings above 0 taken, as the unit test does; ``ckf_updates`` counts the updates
    made in the CKF form (P's largest entry above the threshold before the update)."""
    rng = np.random.default_rng(seed)
    q, meas_var, ekf_switch = _BASILISK_PARAMS
    X = np.array(case.guess, dtype=float)
    x, P = np.zeros(5), _BASILISK_P0.copy()
    state = np.array([np.nan, 0.0, 1.0, 0.0])
    params = np.array([q, meas_var, ekf_switch, 0.866, 1.0 if as_published else 0.0])
    results, ckf, peak = [], 0, 0.0
    for part, heading in enumerate((case.heading1, case.heading2)):
        k = np.arange(case.half)
        cos = np.tile(BASILISK_NORMALS @ np.array(heading), (case.half, 1))
        if case.noise:
            cos = cos + rng.normal(0.0, np.sqrt(meas_var), cos.shape)
        use = (cos > 0.0) & (k[:, None] > 20)
        times = _BASILISK_H * (k + part * case.half)
        for j in range(case.half):  # one update at a time, to count the CKF's updates (P before each)
            ckf += int(use[j].any() and np.max(np.abs(P)) > ekf_switch)
            sekf_run_log(times[j : j + 1], cos[j : j + 1], use[j : j + 1], BASILISK_NORMALS, np.zeros(3), params,
                         state, X, x, P, _BASILISK_P0)  # fmt: skip
            peak = max(peak, float(np.hypot(X[3], X[4])))
        results.append((np.concatenate([X[:3], -X[3:]]), P.copy()))
    return BasiliskRun(results[0][0], results[1][0], results[0][1], results[1][1], _BASILISK_P0.copy(), ckf, peak)


def basilisk_passes(case: BasiliskCase, run: BasiliskRun) -> tuple[float, float]:
    """The unit test's criteria, as ``(largest state error over both halves, largest covariance miss)``: it passes
    when both are at most 0.1 (state within 0.1 of ``[heading, 0, 0]``; each diagonal entry of P within 0.1 of its
    initial value / 100)."""
    err = 0.0
    for state, heading in ((run.state1, case.heading1), (run.state2, case.heading2)):
        err = max(err, float(np.max(np.abs(state - np.concatenate([heading, [0.0, 0.0]])))))
    miss = max(float(np.max(np.abs(np.diag(P) - np.diag(run.P0) / 100.0))) for P in (run.P1, run.P2))
    return err, miss
