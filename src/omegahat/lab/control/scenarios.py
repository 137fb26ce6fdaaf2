r"""The closed-loop scenarios: a spacecraft detumbled from 2 rad/s and slewed by 180°, each rate source alike.

The spacecraft (the values of ``docs/theory/control.md``): ``J = diag(300, 250, 200)`` kg m², reaction torque
``|τ_i| ≤ 5`` N m per axis, a star tracker at 5 Hz with 10 arcsec (4.85e-5 rad) of noise per axis, the PD law of
:mod:`omegahat.lab.control.controller` with ``ω_n = 0.2`` rad/s and ``ζ = 0.9`` (:func:`pd_gains`: ``k_R = 10``
N m, ``k_ω = 90`` N m s), settled (M1) at ``θ_e ≤ 1e-3`` rad and ``|e_ω| ≤ 1e-3`` rad/s.

* **detumble**: ``|ω₀| = 2`` rad/s about a skewed axis, from a 130° attitude error, to the identity held at
  rest; the body's angular momentum, ``J ω₀ = (239, −298, 279)`` N m s, is 48 to 60 s of full torque per axis;
* **slew**: from rest at the identity, a 180° rest-to-rest cycloidal rotation of the reference about
  ``(1, 1, 1)/√3`` in 25 s, followed from start to end (tracking keeps the error small, where a 180° step would
  start at (C4)'s unstable equilibrium). Its peak reference acceleration, 2π²/25² = 0.0316 rad/s², needs 5.5 N m
  on the x axis: the feed-forward saturates there, and the loop falls behind the reference until it catches up.

Rate sources (:func:`make_feed`): ``gyro`` (the true rate), ``omegahat`` (the default estimator,
:class:`omegahat.observer.kalman.SupervisedKalmanEstimator` with the star tracker's σ and the commanded torque),
``observer`` (the fixed-gain Sarras observer, isotropic rate 5 rad/s), ``differencing`` (backward log-map
differences, :class:`omegahat.baselines.differencing.DifferencingEstimator`) and ``wrong-sign`` (the observer with
its correction reversed, :class:`omegahat.lab.control.closed_loop.WrongSignFeed`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from omegahat import so3
from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.lab.control.closed_loop import (
    ClosedLoopRun,
    EstimatorFeed,
    GyroFeed,
    Plant,
    RateFeed,
    RigidBodyPlant,
    WrongSignFeed,
    simulate_closed_loop,
)
from omegahat.lab.control.controller import AttitudePD, Reference, SlewReference, pd_gains
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator

__all__ = ["ARCSEC", "FEEDS", "ControlScenario", "detumble", "make_feed", "run_scenario", "slew"]

ARCSEC = math.pi / (180.0 * 3600.0)  #: one arcsecond in rad
#: The rate sources :func:`make_feed` builds; the first three are the comparison of the docs.
FEEDS = ("gyro", "omegahat", "differencing", "observer", "wrong-sign")


@dataclass(frozen=True)
class ControlScenario:
    """A closed-loop scenario (module docstring); ``slew`` is None (hold the identity) or
    ``(axis, angle, duration, start)`` of a :class:`SlewReference`."""

    name: str
    R0: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: initial attitude as a rotation vector (rad)
    omega0: tuple[float, float, float] = (0.0, 0.0, 0.0)  #: initial rate (rad/s, body axes)
    J: tuple[float, float, float] = (300.0, 250.0, 200.0)  #: principal inertia (kg m²)
    tau_max: float = 5.0  #: per-axis torque limit (N m)
    rate_hz: float = 5.0  #: star tracker rate (Hz)
    sigma: float = 10.0 * ARCSEC  #: star tracker noise per axis (rad)
    natural_frequency: float = 0.2  #: ω_n of the PD law (rad/s)
    damping: float = 0.9  #: ζ of the PD law
    horizon: float = 200.0  #: simulated time (s)
    angle_tol: float = 1e-3  #: settled: error angle at most this (rad) ...
    rate_tol: float = 1e-3  #: ... and rate error at most this (rad/s)
    slew: tuple[tuple[float, float, float], float, float, float] | None = None

    def controller(self) -> AttitudePD:
        """The PD law (C4)–(C5) with :func:`pd_gains`."""
        k_R, k_w = pd_gains(np.diag(self.J), self.natural_frequency, self.damping)
        return AttitudePD(np.diag(self.J), k_R=k_R, k_omega=k_w, tau_max=self.tau_max)

    def reference(self) -> Callable[[float], Reference]:
        """The reference as a function of time."""
        if self.slew is None:
            fixed = Reference.fixed()
            return lambda t: fixed
        axis, angle, duration, start = self.slew
        return SlewReference(axis, angle, duration, start)

    def initial_attitude(self) -> np.ndarray:
        return so3.exp(np.asarray(self.R0, dtype=float))

    def with_(self, **changes: Any) -> ControlScenario:
        """A copy with some fields changed."""
        return replace(self, **changes)


def detumble(**changes: Any) -> ControlScenario:
    """Detumble from ``|ω₀| = 2`` rad/s (module docstring)."""
    w = np.array([0.8, -1.2, 1.4])
    w0 = 2.0 * w / np.linalg.norm(w)
    axis = np.array([1.0, -2.0, 0.5])
    R0 = np.deg2rad(130.0) * axis / np.linalg.norm(axis)
    return ControlScenario("detumble", R0=(R0[0], R0[1], R0[2]), omega0=(w0[0], w0[1], w0[2]), horizon=200.0).with_(
        **changes
    )


def slew(**changes: Any) -> ControlScenario:
    """A 180° rest-to-rest slew in 25 s (module docstring)."""
    axis = (1.0, 1.0, 1.0)
    return ControlScenario("slew", slew=(axis, math.pi, 25.0, 0.0), horizon=100.0).with_(**changes)


def make_feed(name: str, scenario: ControlScenario) -> RateFeed:
    """The rate source ``name`` (one of :data:`FEEDS`) for the scenario's body and star tracker."""
    J = np.diag(scenario.J)
    bandwidth = scenario.rate_hz  # the default estimator's observer: every error mode decays at rate_hz rad/s
    if name == "gyro":
        return GyroFeed()
    if name == "omegahat":
        est = SupervisedKalmanEstimator(
            J, rate_hz=scenario.rate_hz, measurement_noise=scenario.sigma, rate_noise=1e-6, torque_hold="zero"
        )
        return EstimatorFeed(est, name="omegahat")
    if name == "differencing":
        return EstimatorFeed(DifferencingEstimator(scheme="backward"), name="differencing")
    if name in ("observer", "wrong-sign"):
        obs = SarrasEstimator(
            J,
            gains=ObserverGains.constant(1.0, 10.0 * bandwidth, n=3),
            isotropic_rate=bandwidth,
            torque_hold="zero",
            warm_start=name == "observer",
        )
        return EstimatorFeed(obs, name="observer") if name == "observer" else WrongSignFeed(obs)
    raise ValueError(f"unknown rate source {name!r}; choose one of {', '.join(FEEDS)}")


def run_scenario(
    scenario: ControlScenario,
    feed: str | RateFeed,
    seed: int = 0,
    plant: Plant | None = None,
    *,
    R0: np.ndarray | None = None,
    omega0: np.ndarray | None = None,
) -> ClosedLoopRun:
    """One closed-loop run of the scenario with the rate source ``feed`` (a name of :data:`FEEDS` or a feed), the
    star tracker's noise drawn from ``default_rng(seed)``, on ``plant`` (default :class:`RigidBodyPlant`); ``R0``
    and ``omega0`` override the scenario's start."""
    rate_feed = make_feed(feed, scenario) if isinstance(feed, str) else feed
    return simulate_closed_loop(
        RigidBodyPlant(np.diag(scenario.J)) if plant is None else plant,
        scenario.controller(),
        rate_feed,
        scenario.reference(),
        scenario.initial_attitude() if R0 is None else R0,
        np.asarray(scenario.omega0 if omega0 is None else omega0, dtype=float),
        horizon=scenario.horizon,
        rate_hz=scenario.rate_hz,
        sigma=scenario.sigma,
        rng=np.random.default_rng(seed),
    )
