r"""The robustness campaign of ``omegahat compare``: does each estimator converge from *any* start?

Many seeded runs of a tumbling spacecraft (``omegahat.lab.scenarios``' inertia, torque-free), each drawn
independently (:func:`draw_case`):

* the true initial rate uniform in the ball ``|ω₀| ≤ ω_M`` and every estimator started cold (no warm start) from
  ``ω̂₀`` uniform in the ball of radius ``omega_hat0_max`` (default 0: from rest), so the initial rate error is
  anything up to ``ω_M + omega_hat0_max``;
* the attitude uniform on SO(3); the sensor a star tracker (the attitude, ``measurement_noise`` per axis) or, for
  the other half of the runs, two direction sensors 90° apart (``direction_noise`` per component), where the
  observer's initial filtered directions ``r̂_i0`` carry an attitude error drawn uniformly up to 180°;
* the sample rate uniform in ``[rate_min, rate_max]`` Hz.

Methods, each with one fixed setting (no per-run tuning): omegahat's default estimator
(:class:`omegahat.observer.kalman.SupervisedKalmanEstimator`), the fixed-gain Sarras estimator (isotropic rate
``min(rate, 10)`` rad/s) and the gyro-less MEKF with the dynamic model, whose prior honestly covers the range,
``σ_ω0 = ω_M + omega_hat0_max`` (its attitude starts from the first fix). A run *converges* when its error stays
below ``tolerance`` from some time in the first three quarters of the run on ((S1) of
:mod:`omegahat.lab.evaluation.metrics`); the report gives, per method, the fraction converged, the worst and median
convergence times, and the seeds of the runs that did not converge (each replays with :func:`draw_case`).
"""

from __future__ import annotations

import csv
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import IO

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.baselines.mekf import MEKF
from omegahat.interface import Estimator
from omegahat.lab.evaluation.metrics import convergence_time, estimate_errors
from omegahat.lab.scenarios import SCENARIOS
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.simulation import sensors
from omegahat.simulation.rigid_body import RigidBody, integrate

__all__ = [
    "CAMPAIGN_LIKE",
    "METHODS",
    "Case",
    "RobustnessConfig",
    "draw_case",
    "markdown",
    "run_campaign",
    "run_case",
    "write_csv",
]

TWO_DIRECTIONS = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  #: the direction sensors' references


@dataclass(frozen=True)
class RobustnessConfig:
    """The campaign's ranges (rad/s, rad, Hz, s)."""

    runs: int = 100
    seed: int = 2026
    omega_max: float = 2.0
    rate_min: float = 1.0
    rate_max: float = 10.0
    duration: float = 120.0
    measurement_noise: float = math.radians(0.02)  # the star tracker's attitude noise, rad per axis
    direction_noise: float = math.radians(0.2)  # the direction sensors' noise, per component
    tolerance: float = 0.02
    rate_noise: float = 1e-4  # σ_a of both EKFs (omegahat's and the MEKF), rad/s^1.5
    omega_hat0_max: float = 0.0  # the estimators' initial rate: uniform in this ball (0: every run from rest)
    inertia: tuple[float, float, float] | None = None  # principal moments; None: the tumbling spacecraft's J
    name: str = "cold starts, 1-10 Hz"

    @property
    def J(self) -> np.ndarray:
        return SCENARIOS["tumble"].J_true if self.inertia is None else np.diag(self.inertia)


#: The paper's campaign (examples/campaign.toml) for the sampled estimators: the paper's body, |ω₀| ≤ 0.6 ω_M with
#: ω_M = 3, initial estimates anywhere up to 100 rad/s, sampled at 1 kHz so that they are not aliased
#: (|ω̂₀ − ω₀| h < π needs h < 31 ms at 100 rad/s: the data cannot tell a rate from its aliases otherwise).
CAMPAIGN_LIKE = RobustnessConfig(
    runs=100, omega_max=1.8, omega_hat0_max=100.0, rate_min=1000.0, rate_max=1000.0, duration=10.0,
    measurement_noise=1e-4, direction_noise=1e-4, inertia=(3.0, 2.0, 1.0), name="the paper's campaign, 1 kHz",
)  # fmt: skip


@dataclass(frozen=True)
class Case:
    """One run: ``seed``, rate (Hz), directions (else attitude), the truth and the measurements, and the
    observer's initial filtered directions (directions only)."""

    seed: int
    rate_hz: float
    directions: bool
    t: np.ndarray
    omega: np.ndarray
    measurements: np.ndarray
    r_hat0: np.ndarray | None
    sigma: float
    omega_hat0: np.ndarray


def draw_case(config: RobustnessConfig, index: int) -> Case:
    """Run ``index`` of the campaign (seeded by ``(config.seed, index)``), truth integrated by CF4."""
    seed = int(np.random.SeedSequence([config.seed, index]).generate_state(1)[0])
    rng = np.random.default_rng(seed)
    rate = float(rng.uniform(config.rate_min, config.rate_max))
    axis = rng.standard_normal(3)
    omega0 = config.omega_max * rng.random() ** (1.0 / 3.0) * axis / np.linalg.norm(axis)  # uniform in the ball
    R0 = Rotation.random(random_state=rng).as_matrix()
    directions = index % 2 == 1
    t = np.arange(round(config.duration * rate) + 1) / rate
    traj = integrate(RigidBody(config.J), R0, omega0, t, max_step=min(0.01, 0.5 / rate))
    if directions:
        meas = sensors.noisy_directions(traj.R, TWO_DIRECTIONS, config.direction_noise, rng)
        axis = rng.standard_normal(3)
        error = Rotation.from_rotvec(math.pi * rng.random() ** (1.0 / 3.0) * axis / np.linalg.norm(axis))
        r_true0 = sensors.directions(traj.R[0], TWO_DIRECTIONS)
        r_hat0 = error.apply(r_true0)  # the observer's initial directions, up to 180° away
        sigma = config.direction_noise
    else:
        meas = sensors.noisy_attitudes(traj.R, config.measurement_noise, rng)
        r_hat0, sigma = None, config.measurement_noise
    axis = rng.standard_normal(3)
    omega_hat0 = config.omega_hat0_max * rng.random() ** (1.0 / 3.0) * axis / np.linalg.norm(axis)
    return Case(seed, rate, directions, t, traj.omega, meas, r_hat0, sigma, omega_hat0)


def _omegahat(config: RobustnessConfig, case: Case) -> Estimator:
    refs = TWO_DIRECTIONS if case.directions else None
    return SupervisedKalmanEstimator(
        config.J, rate_hz=case.rate_hz, measurement_noise=case.sigma,
        rate_noise=config.rate_noise, references=refs, omega_hat0=case.omega_hat0, r_hat0=case.r_hat0, warm_start=False,
    )  # fmt: skip


def _sarras(config: RobustnessConfig, case: Case) -> Estimator:
    refs = TWO_DIRECTIONS if case.directions else None
    n = 2 if case.directions else 3
    b = min(case.rate_hz, 10.0)  # rad/s: the sample rate, up to 10 (its noise grows with b)
    return SarrasEstimator(
        config.J, gains=ObserverGains.constant(1.0, 10.0 * b, n=n), references=refs,
        omega_hat0=case.omega_hat0, r_hat0=case.r_hat0, warm_start=False, isotropic_rate=b,
    )  # fmt: skip


def _mekf(config: RobustnessConfig, case: Case) -> Estimator:
    return MEKF(
        config.J, model="dynamic", q=(np.trace(config.J) / 3.0 * config.rate_noise) ** 2,
        measurement_noise=case.sigma, references=TWO_DIRECTIONS if case.directions else None,
        omega_hat0=case.omega_hat0,
        sigma_omega0=config.omega_max + config.omega_hat0_max,
    )  # fmt: skip


#: name → (config, case) → a fresh estimator
METHODS: dict[str, Callable[[RobustnessConfig, Case], Estimator]] = {
    "omegahat": _omegahat,
    "sarras": _sarras,
    "mekf-dynamic": _mekf,
}


def run_case(config: RobustnessConfig, case: Case, method: str) -> tuple[float, float]:
    """One method on one run: the convergence time (s; inf when the error does not stay below the tolerance) and
    the RMS error over the last quarter of the run (rad/s; inf if it diverged)."""
    est = METHODS[method](config, case)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # nearly collinear or missing samples are not expected here
        try:
            w = est.run(case.t, case.measurements)
        except (np.linalg.LinAlgError, FloatingPointError):
            return math.inf, math.inf
    err = estimate_errors(w, case.omega, always_estimates=True)
    last = err[case.t >= 0.75 * config.duration]
    return convergence_time(case.t, err, config.tolerance), float(np.sqrt(np.mean(last**2)))


def run_campaign(config: RobustnessConfig, methods: Sequence[str] = tuple(METHODS)) -> dict[str, dict]:
    """Every run for every method: per method the convergence times ``(runs,)``, the fraction converged (by
    three quarters of the run), the worst and median convergence times, the failed runs' indices and the RMS error
    over each run's last quarter."""
    times = {m: np.empty(config.runs) for m in methods}
    final = {m: np.empty(config.runs) for m in methods}
    for i in range(config.runs):
        case = draw_case(config, i)
        for m in methods:
            times[m][i], final[m][i] = run_case(config, case, m)
    out = {}
    for m, tc in times.items():
        ok = tc <= 0.75 * config.duration
        out[m] = {
            "times": tc,
            "final_rms": final[m],
            "fraction": float(ok.mean()),
            "worst": float(tc[ok].max()) if ok.any() else math.inf,
            "median": float(np.median(tc[ok])) if ok.any() else math.inf,
            "failed": np.flatnonzero(~ok).tolist(),
        }
    return out


def markdown(config: RobustnessConfig, results: dict[str, dict]) -> str:
    """The campaign's table and its definition."""
    lines = [
        f"Robustness campaign ({config.name}): {config.runs} seeded runs (seed {config.seed}), a tumbling body "
        f"(principal moments {', '.join(f'{m:g}' for m in np.diag(config.J))} ...), "
        f"|w0| uniform in the ball of radius {config.omega_max:g} rad/s, every estimator started cold from w_hat0 "
        f"uniform in the ball of radius {config.omega_hat0_max:g} rad/s, "
        f"sample rate uniform in [{config.rate_min:g}, {config.rate_max:g}] Hz, {config.duration:g} s; even runs a "
        f"star tracker ({math.degrees(config.measurement_noise):g} deg/axis), odd runs two direction sensors 90 deg "
        f"apart ({math.degrees(config.direction_noise):g} deg) with the observer's initial directions up to 180 deg "
        f"off. Converged: |w_hat - w| stays below {config.tolerance:g} rad/s from a time within the first 75 % of "
        "the run. The MEKF's prior covers the range (sigma_w0 = w_M + the initial estimate's bound).",
        "",
        "| method | converged | worst convergence time (s) | median (s) | final RMS, median / worst (rad/s) "
        "| runs that did not converge |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for m, r in results.items():
        failed = r["failed"]
        shown = ", ".join(str(i) for i in failed[:10]) + (" …" if len(failed) > 10 else "")
        lines.append(
            f"| {m} | {100 * r['fraction']:.1f} % ({config.runs - len(failed)}/{config.runs}) | {r['worst']:.3g} | "
            f"{r['median']:.3g} | {np.median(r['final_rms']):.2g} / {np.max(r['final_rms']):.2g} | {shown or 'none'} |"
        )
    return "\n".join(lines)


def write_csv(f: IO[str], results: dict[str, dict], campaign: str = "", header: bool = True) -> None:
    """``robustness.csv``: one row per campaign, run and method: the campaign's name, run index, method,
    convergence time, final RMS (``repr(float)``: the same bytes every time)."""
    w = csv.writer(f)
    if header:
        w.writerow(["campaign", "run", "method", "convergence_s", "final_rms"])
    for m, r in results.items():
        for i, (tc, rms) in enumerate(zip(r["times"], r["final_rms"], strict=True)):
            w.writerow([campaign, i, m, repr(float(tc)), repr(float(rms))])
