r"""The comparison scenarios, as data: a registry shared by ``omegahat compare`` and the tests.

A :class:`Scenario` says what the true body does (inertia, initial state, commanded and disturbance torques),
what the sensor gives (attitude fixes at a rate, with Gaussian noise ``R_meas = R Exp(ν)``, ν ~ N(0, σ² I) per
body axis: :func:`omegahat.simulation.sensors.noisy_attitudes`), and what the estimators are told (the model
inertia, the known torque, an initial estimate and a bound on |ω|). Ground truth comes from
:func:`omegahat.simulation.rigid_body.integrate` (fourth-order Lie-group integrator) at every sample time.

Registered scenarios (:data:`SCENARIOS`):

* ``paper`` — Sarras' simulation (``docs/theory/observer.md``): J = diag(3, 2, 1) kg·m², ω₀ = (2, −1, 0.6)
  rad/s, torque-free, R₀ = I, initial estimate ω̂₀ = 0 (error 2.3 rad/s), here sampled at 100 Hz without noise.
* ``slew`` — a spacecraft: inertia with products of inertia (eigenvalues about 196–306 kg·m²), star tracker at
  5 Hz with 10 arcsec (4.85e-5 rad) of noise per axis, a known commanded bang–bang torque of 0.5 N·m per axis
  (0–60 s one sign, 60–120 s the other, then coasting), initially tumbling at |ω₀| = 0.027 rad/s with
  ω̂₀ = 0.
* ``slew-J10`` — the same, but the estimators are told principal moments wrong by ±10 %.
* ``slew-disturbance`` — the same, with an unknown constant disturbance torque of (4, −3, 2) mN·m.
* ``slew-1Hz`` — the same as ``slew`` with a slower star tracker at 1 Hz.
* ``tumble`` — the same spacecraft tumbling torque-free at |ω| = 1 rad/s (after a failure), coarse attitude
  fixes (0.1° per axis) at 1 Hz, every estimator started at ω̂₀ = 0: the initial error is the whole rate, and the
  body turns by 1 rad between fixes. ``tumble-fast`` — the same at 2 rad/s (2 rad between fixes, still below the
  π at which sampled attitudes become ambiguous).
* ``broad-01``, ``broad-06``, ``broad-10`` — real recordings (``../shared/data/broad/``, see its NOTICE.md):
  optical attitude at 285.7 Hz, J = I and τ = 0 as stand-ins; scored in band against the gyroscope by
  :mod:`omegahat.lab.evaluation.broad`. Available only where the data directory exists. ``broad-01-29hz``,
  ``broad-01-10hz`` (and likewise 06, 10): the same trials keeping every 10th / 30th sample (28.6 / 9.5 Hz),
  low-rate motion capture, scored against the native gyroscope.

A simulated scenario is reproducible from a seed: :func:`simulate` draws the noise from
``numpy.random.default_rng(numpy.random.SeedSequence(seed))``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from omegahat.simulation import sensors
from omegahat.simulation.rigid_body import RigidBody, integrate
from omegahat.simulation.torque import Torque

__all__ = ["SCENARIOS", "Run", "Scenario", "broad_data_dir", "get", "known_torque", "names", "simulate"]

ARCSEC = np.pi / (180.0 * 3600.0)


@dataclass(frozen=True)
class Scenario:
    """One comparison scenario. Simulated unless ``broad_trial`` is set (real data)."""

    name: str
    description: str
    J_true: np.ndarray = field(default_factory=lambda: np.eye(3))
    J_model: np.ndarray = field(default_factory=lambda: np.eye(3))  # what the estimators are told
    omega0: np.ndarray = field(default_factory=lambda: np.zeros(3))  # true initial rate, rad/s
    omega_hat0: np.ndarray = field(default_factory=lambda: np.zeros(3))  # every estimator's initial estimate
    omega_max: float = 1.0  # bound on |ω| given to the estimators (rad/s): the MEKF's prior σ_ω0
    duration: float = 10.0  # s
    rate_hz: float = 100.0
    measurement_noise: float = 0.0  # rad per axis
    # Commanded torque, known to the estimators: piecewise constant, ((t_start, (τx, τy, τz)), ...), N·m.
    known_torque: tuple = ()
    disturbance: np.ndarray = field(default_factory=lambda: np.zeros(3))  # unknown constant torque, N·m
    converged_tol: float = 0.05  # rad/s: convergence = error stays below this from then on
    steady_after: float = 5.0  # s: steady-state RMS over t ≥ steady_after
    broad_trial: str | None = None  # "01", "06", "10" for the real recordings
    decimate: int = 1  # real recordings: keep every decimate-th sample (low-rate motion capture)

    @property
    def real(self) -> bool:
        return self.broad_trial is not None


class Run(NamedTuple):
    """One realisation: ``t (T,)``, measured attitudes ``(T, 3, 3)`` (NaN rows = missing), known torque
    ``(T, 3)``, true rate ``(T, 3)`` (for real data: the bias-corrected gyroscope), true attitude ``(T, 3, 3)``
    (None for real data) and ``extra`` (the loader's own object for real data, used by the scorer)."""

    t: np.ndarray
    R_meas: np.ndarray
    torque: np.ndarray
    omega: np.ndarray
    R: np.ndarray | None = None
    extra: object = None


# 0.5 N·m per axis, signs (+, −, +) for 0–60 s, reversed for 60–120 s, zero afterwards.
_BANG_BANG = ((0.0, (0.5, -0.5, 0.5)), (60.0, (-0.5, 0.5, -0.5)), (120.0, (0.0, 0.0, 0.0)))


def known_torque(scenario: Scenario, t: ArrayLike) -> np.ndarray:
    """The commanded torque at times ``t`` ``(T,)``, shape ``(T, 3)``."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    out = np.zeros((t.size, 3))
    for start, tau in scenario.known_torque:
        out[t >= start - 1e-9] = tau  # switch times are sample times, up to rounding
    return out


_J_SC = np.array([[300.0, -12.0, 8.0], [-12.0, 250.0, 5.0], [8.0, 5.0, 200.0]])
_J_SC_WRONG = _J_SC.copy()
_J_SC_WRONG[np.diag_indices(3)] *= [1.1, 0.9, 1.1]
_SLEW: dict[str, Any] = dict(
    J_true=_J_SC,
    J_model=_J_SC,
    omega0=np.array([0.02, -0.015, 0.01]),
    omega_hat0=np.zeros(3),
    omega_max=0.3,
    duration=300.0,
    rate_hz=5.0,
    measurement_noise=10.0 * ARCSEC,
    known_torque=_BANG_BANG,
    converged_tol=2e-3,
    steady_after=150.0,
)

# A tumbling spacecraft (same inertia), torque-free, coarse attitude fixes at 1 Hz: the initial error is the whole
# rate, and the body turns by |ω| h = 1 (tumble) or 2 (tumble-fast) rad between fixes.
_TUMBLE_AXIS = np.array([0.6, -0.5, 0.62]) / np.linalg.norm([0.6, -0.5, 0.62])
_TUMBLE: dict[str, Any] = dict(
    J_true=_J_SC,
    J_model=_J_SC,
    omega_hat0=np.zeros(3),
    duration=300.0,
    rate_hz=1.0,
    measurement_noise=np.radians(0.1),
    converged_tol=1e-2,
    steady_after=150.0,
)

# Real data: 285.714 Hz optical attitude; σ assumed 0.05° (NOTICE.md: rest jitter 0.014°–0.085° RMS).
_BROAD: dict[str, Any] = dict(
    J_true=np.eye(3),
    J_model=np.eye(3),
    omega_max=10.0,
    converged_tol=0.1,
    steady_after=0.0,
    rate_hz=2000.0 / 7.0,
    measurement_noise=np.radians(0.05),
)

SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in [
        Scenario(
            "paper",
            "Sarras' simulation: J = diag(3,2,1), w0 = (2,-1,0.6) rad/s, torque-free, 100 Hz, no noise",
            J_true=np.diag([3.0, 2.0, 1.0]),
            J_model=np.diag([3.0, 2.0, 1.0]),
            omega0=np.array([2.0, -1.0, 0.6]),
            omega_max=3.0,
            duration=10.0,
            rate_hz=100.0,
            converged_tol=0.05,
            steady_after=5.0,
        ),
        Scenario("slew", "spacecraft slew, star tracker 5 Hz, 10 arcsec/axis, known torques", **_SLEW),
        Scenario(
            "slew-J10", "as slew, estimators told principal moments +10/-10/+10 %", **{**_SLEW, "J_model": _J_SC_WRONG}
        ),
        Scenario(
            "slew-disturbance",
            "as slew, unknown constant disturbance torque (4,-3,2) mN m",
            **{**_SLEW, "disturbance": np.array([4e-3, -3e-3, 2e-3])},
        ),
        Scenario("slew-1Hz", "as slew, star tracker at 1 Hz", **{**_SLEW, "rate_hz": 1.0}),
        Scenario(
            "tumble",
            "tumbling spacecraft, |w| = 1 rad/s, attitude 0.1 deg/axis at 1 Hz, no torque",
            omega0=1.0 * _TUMBLE_AXIS,
            omega_max=1.5,
            **_TUMBLE,
        ),
        Scenario(
            "tumble-fast",
            "as tumble at |w| = 2 rad/s: 2 rad between fixes",
            omega0=2.0 * _TUMBLE_AXIS,
            omega_max=3.0,
            **_TUMBLE,
        ),
        *(
            Scenario(
                f"broad-{trial}" + ("" if step == 1 else f"-{round(_BROAD['rate_hz'] / step)}hz"),
                f"BROAD trial {trial} ({what}), optical attitude"
                + ("" if step == 1 else f" decimated to {_BROAD['rate_hz'] / step:.3g} Hz (every {step}th sample)")
                + ", J = I, tau = 0 stand-ins",
                broad_trial=trial,
                decimate=step,
                **{**_BROAD, "rate_hz": _BROAD["rate_hz"] / step},
            )
            for step in (1, 10, 30)
            for trial, what in (("01", "slow rotation"), ("06", "fast rotation"), ("10", "slow translation"))
        ),
    ]
}


def names() -> list[str]:
    return list(SCENARIOS)


def get(name: str) -> Scenario:
    """The scenario called ``name`` (ValueError listing the known names otherwise)."""
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; known: {', '.join(SCENARIOS)}") from None


def broad_data_dir() -> Path:
    """Where the BROAD recordings are looked for (:func:`omegahat.lab.evaluation.broad.data_dir`; may not exist)."""
    from omegahat.lab.evaluation import broad

    return broad.data_dir()


def simulate(scenario: Scenario, seed: int, duration: float | None = None) -> Run:
    """Truth and noisy attitude fixes for a simulated scenario (``duration`` overrides the scenario's)."""
    if scenario.real:
        raise ValueError(f"scenario {scenario.name!r} is real data: load it with omegahat.lab.evaluation.broad")
    T_end = scenario.duration if duration is None else float(duration)
    h = 1.0 / scenario.rate_hz
    t = h * np.arange(round(T_end / h) + 1)
    tau_known = known_torque(scenario, t)
    dist = np.asarray(scenario.disturbance, dtype=float)
    body = RigidBody(scenario.J_true)
    # Integrate piece by piece between torque switches (switch times are sample times), each piece with its
    # constant torque: holding the sampled torque over the next interval is then exact for the estimators.
    starts = sorted({0.0, *(s for s, _ in scenario.known_torque if 0.0 < s < t[-1])})
    R, w = np.eye(3), np.asarray(scenario.omega0, dtype=float)
    R_all, w_all = [R[None]], [w[None]]
    for j, start in enumerate(starts):
        end = starts[j + 1] if j + 1 < len(starts) else np.inf
        idx = np.flatnonzero((t >= start - 1e-9) & (t <= end + 1e-9))
        tau = known_torque(scenario, [start])[0] + dist
        piece = integrate(body, R, w, t[idx], Torque.constant(tau), max_step=min(1e-2, h))
        R_all.append(piece.R[1:])
        w_all.append(piece.omega[1:])
        R, w = piece.R[-1], piece.omega[-1]
    R_true, w_true = np.concatenate(R_all), np.concatenate(w_all)
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    R_meas = sensors.noisy_attitudes(R_true, scenario.measurement_noise, rng)
    return Run(t, R_meas, tau_known, w_true, R_true)
