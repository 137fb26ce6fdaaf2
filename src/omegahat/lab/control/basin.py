r"""The measured basin of the closed loop: a seeded Monte-Carlo over initial attitudes and rates, and a sweep of
initial error angles up to 180°.

No continuous feedback on SO(3) is globally stabilising (Bhat and Bernstein 2000, quoted in
:mod:`omegahat.lab.control.controller`), and with saturation and an estimated rate nothing about the loop is proven:
what it does is measured here.

**Monte-Carlo** (:func:`basin_campaign`). Run j draws from ``default_rng(SeedSequence(seed, spawn_key=(j,)))``,
in this order: the initial attitude, uniform on SO(3) (SciPy's ``Rotation.random``, Shoemake's uniform unit
quaternion); the initial rate ``ω₀ = s u`` with ``u`` uniform on the sphere and ``s`` uniform in
``[0, omega_max]``; then the star tracker's noise. Every rate source sees the same draws (the same initial
condition and the same noise sequence). Each run is scored with (M1)–(M3) of
:mod:`omegahat.lab.control.closed_loop` against a reference held at the identity: converged when it settled within the
horizon; *slow* when it settled later than ``slow_factor`` times the median settling time of its rate source. The
attitude at which the rate first drops below ``REST_RATE`` (the end of the detumble) is recorded: a run whose
rates die out more than ``NEAR_PI_DEG`` from the reference starts its attitude manoeuvre near the law's unstable
equilibrium, and those are the slow ones.

**Sweep near 180°** (:func:`angle_sweep`). From rest, the initial error is a rotation by θ₀ about a fixed axis: at
θ₀ = 180° the attitude error (C1) is zero and the rest state is an equilibrium of the PD law (unstable; with
noise-free measurements and the true rate the body would stay there), and near it the restoring torque
``k_R sin θ₀`` is small: the settling time grows as θ₀ → 180°.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.random import SeedSequence, default_rng
from scipy.spatial.transform import Rotation

from omegahat import so3
from omegahat.lab.control.closed_loop import pointing_error, settling_time, torque_used
from omegahat.lab.control.scenarios import ControlScenario, make_feed, run_scenario
from omegahat.validation import as_positive

__all__ = ["NEAR_PI_DEG", "REST_RATE", "BasinResult", "angle_sweep", "basin_campaign", "draw_initial_conditions"]

REST_RATE = 0.02  #: rad/s: below this the detumble is over (module docstring)
NEAR_PI_DEG = 150.0  #: deg: a run at rest farther than this from the reference starts near the unstable equilibrium


@dataclass(frozen=True)
class BasinResult:
    """Per run (rows) and rate source (columns, ``feeds``): the settling time ``settle`` (s, inf = not within the
    horizon), ``pointing`` (RMS error angle over the last 20 s, rad), ``impulse`` (N m s), ``diverged``; the
    initial error angle ``angle0`` (rad) and rate ``rate0`` (rad/s) of each run; ``rest_angle`` (runs, feeds):
    the error angle (rad) when the true rate first fell below ``REST_RATE`` (NaN if never)."""

    feeds: tuple[str, ...]
    seed: int
    horizon: float
    angle0: np.ndarray
    rate0: np.ndarray
    settle: np.ndarray
    pointing: np.ndarray
    impulse: np.ndarray
    diverged: np.ndarray
    rest_angle: np.ndarray

    def converged(self) -> np.ndarray:
        """``(runs, feeds)`` booleans: settled within the horizon."""
        return np.isfinite(self.settle)

    def slow(self, slow_factor: float = 2.0) -> np.ndarray:
        """``(runs, feeds)`` booleans: settled, but later than ``slow_factor`` times the source's median."""
        med = np.array([_median_finite(self.settle[:, f]) for f in range(len(self.feeds))])
        return self.converged() & (self.settle > slow_factor * med)

    def summary_rows(self, slow_factor: float = 2.0) -> list[dict[str, float | str | int]]:
        """One row per rate source: runs, fraction converged, median and worst settling time (converged runs),
        slow runs and the median initial angle of the slow ones, median pointing error, median impulse."""
        rows: list[dict[str, float | str | int]] = []
        slow = self.slow(slow_factor)
        near_pi = self.rest_angle > np.radians(NEAR_PI_DEG)  # NaN compares False
        for f, name in enumerate(self.feeds):
            conv = self.converged()[:, f]
            s = self.settle[conv, f]
            rows.append(
                {
                    "source": name,
                    "runs": int(conv.size),
                    "converged": float(conv.mean()),
                    "diverged": int(self.diverged[:, f].sum()),
                    "median_settle_s": float(np.median(s)) if s.size else math.nan,
                    "worst_settle_s": float(np.max(s)) if s.size else math.nan,
                    "slow_runs": int(slow[:, f].sum()),
                    "slow_median_angle0_deg": float(np.degrees(np.median(self.angle0[slow[:, f]])))
                    if slow[:, f].any()
                    else math.nan,
                    "near_pi_runs": int(near_pi[:, f].sum()),
                    "near_pi_median_settle_s": float(np.median(self.settle[near_pi[:, f], f]))
                    if near_pi[:, f].any()
                    else math.nan,
                    "median_pointing_rad": float(np.median(self.pointing[conv, f])) if s.size else math.nan,
                    "median_impulse_Nms": float(np.median(self.impulse[:, f])),
                }
            )
        return rows


def _median_finite(x: np.ndarray) -> float:
    x = x[np.isfinite(x)]
    return float(np.median(x)) if x.size else math.inf


def draw_initial_conditions(seed: int, j: int, omega_max: float) -> tuple[np.ndarray, np.ndarray, np.random.Generator]:
    """Run j's initial attitude ``(3, 3)`` and rate ``(3,)`` and the generator, left ready for the noise (module
    docstring)."""
    rng = default_rng(SeedSequence(int(seed), spawn_key=(int(j),)))
    R0 = Rotation.random(random_state=rng).as_matrix()
    u = rng.standard_normal(3)
    w0 = rng.uniform(0.0, float(omega_max)) * u / np.linalg.norm(u)
    return R0, w0, rng


def basin_campaign(
    scenario: ControlScenario,
    feeds: tuple[str, ...],
    runs: int,
    *,
    seed: int = 2026,
    omega_max: float = 2.0,
    tail: float = 20.0,
) -> BasinResult:
    """The Monte-Carlo of the module docstring: ``runs`` initial conditions, each with every rate source of
    ``feeds`` (names of :data:`omegahat.lab.control.scenarios.FEEDS`), the scenario's body, sensor, gains and
    horizon, the reference at rest at the identity."""
    if not (isinstance(runs, int) and runs >= 1):
        raise ValueError(f"runs must be a positive integer; got {runs!r}")
    omega_max = float(as_positive(omega_max, "omega_max")[0])
    scenario = scenario.with_(slew=None)
    nf = len(feeds)
    shape = (runs, nf)
    settle, pointing, impulse = np.empty(shape), np.empty(shape), np.empty(shape)
    diverged = np.zeros(shape, dtype=bool)
    rest_angle = np.full(shape, np.nan)
    angle0, rate0 = np.empty(runs), np.empty(runs)
    sources = [make_feed(name, scenario) for name in feeds]
    for j in range(runs):
        R0, w0, rng = draw_initial_conditions(seed, j, omega_max)
        angle0[j] = float(np.linalg.norm(so3.log(R0)))
        rate0[j] = float(np.linalg.norm(w0))
        noise_seed = int(rng.integers(2**63))  # the same noise sequence for every source
        for f, feed in enumerate(sources):
            run = run_scenario(scenario, feed, seed=noise_seed, R0=R0, omega0=w0)
            settle[j, f] = settling_time(run, scenario.angle_tol, scenario.rate_tol)
            pointing[j, f] = pointing_error(run, tail)
            impulse[j, f] = torque_used(run)
            diverged[j, f] = run.diverged
            at_rest = np.flatnonzero(np.linalg.norm(run.omega, axis=1) < REST_RATE)
            if at_rest.size:
                rest_angle[j, f] = run.angle[at_rest[0]]
    return BasinResult(
        tuple(feeds), int(seed), scenario.horizon, angle0, rate0, settle, pointing, impulse, diverged, rest_angle
    )


def angle_sweep(
    scenario: ControlScenario,
    feeds: tuple[str, ...],
    angles_deg: tuple[float, ...],
    *,
    axis: tuple[float, float, float] = (1.0, 1.0, 1.0),
    seed: int = 0,
) -> np.ndarray:
    """Settling times ``(len(angles_deg), len(feeds))`` (s, inf = not within the horizon) from rest at an error
    rotation by each angle about ``axis`` (module docstring), the same noise seed for every run."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    scenario = scenario.with_(slew=None, omega0=(0.0, 0.0, 0.0))
    out = np.empty((len(angles_deg), len(feeds)))
    for i, deg in enumerate(angles_deg):
        R0 = so3.exp(math.radians(deg) * a)
        for f, name in enumerate(feeds):
            run = run_scenario(scenario, name, seed=seed, R0=R0)
            out[i, f] = settling_time(run, scenario.angle_tol, scenario.rate_tol)
    return out
