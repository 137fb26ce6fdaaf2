r"""Gain tuning by simulation: convergence time against steady-state noise, the Pareto front, and a recommendation.

:mod:`omegahat.observer.tuning` designs gains from a linearisation (``sensor_gains``: bandwidth → k, l;
``predicted_noise_std``: the noise that bandwidth costs). This module *measures* both sides of the trade-off with
the sampled estimator (:class:`omegahat.observer.estimator.SarrasEstimator`) on a simulated body, and picks
gains from the measured front. It does not design gains itself: :func:`recommend_gains` evaluates
``tuning.sensor_gains`` over a range of bandwidths.

**One evaluation** (:func:`evaluate_gains`) of gains at a sample rate ``1/h`` and white attitude noise σ (rad per
axis, ``R_meas = R exp(ν×)``, :func:`omegahat.simulation.sensors.noisy_attitudes`), on a torque-free body (J, ω₀,
R₀ fixed by the caller; ground truth from :func:`omegahat.simulation.rigid_body.integrate`):

* **convergence time** ``t_c``: noise-free measurements, estimate started at ``ω̂₀ = ω₀ + Δ`` (``|Δ|`` =
  ``initial_error``, direction (1, 1, 1)/√3); ``t_c`` is the first sample time after which ``|ω̂ − ω|`` stays at or
  below ``settle · |Δ|`` (default 1 %) up to the horizon (∞ if it never settles; a non-finite estimate counts as
  diverged): :func:`omegahat.lab.evaluation.metrics.convergence_time`, (S1);
* **steady-state noise** ``s``: noisy measurements, estimate started at the truth; ``s = √(mean |ω̂ − ω|²)``
  (rad/s, the norm over the three axes) over the samples after the burn-in ``min(5 t_c, horizon/2)``.

The noise realisation depends only on ``(seed, rate index, noise index)`` of the sweep (common random numbers:
every gain set at one rate and noise level sees the same noise), drawn from ``SeedSequence(seed, spawn_key=...)``.

**Pareto front**: the evaluations not dominated in (``t_c``, ``s``), both to be minimised (a point is dominated
when another is no worse in both and better in one).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from omegahat.lab.evaluation.metrics import convergence_time, estimate_errors, steady_rms
from omegahat.observer import tuning
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.simulation import sensors
from omegahat.simulation.rigid_body import RigidBody, Trajectory, integrate
from omegahat.validation import as_inertia, as_positive, as_vector3

if TYPE_CHECKING:  # matplotlib is imported when a figure is drawn
    from matplotlib.axes import Axes

__all__ = [
    "Evaluation",
    "Recommendation",
    "evaluate_gains",
    "pareto_front",
    "plot_pareto",
    "recommend_gains",
    "sweep",
]

DEFAULT_OMEGA0 = (0.4, -0.3, 0.6)  # rad/s, a generic tumble of the paper's body


@dataclass(frozen=True)
class Evaluation:
    """One evaluated gain set (module docstring): the gains, the sensor, ``t_c`` (s) and ``s`` (rad/s)."""

    gains: ObserverGains
    rate_hz: float
    measurement_noise: float
    convergence_time: float
    noise_rms: float
    predicted_noise_rms: float  #: tuning.predicted_noise_std (norm over the axes), the linearised prediction
    label: str = ""


def _truth(J, omega0, rate_hz, horizon):
    times = np.arange(round(horizon * rate_hz) + 1) / rate_hz
    traj = integrate(RigidBody(J), np.eye(3), omega0, times, max_step=min(1e-3, 0.5 / rate_hz))
    return traj


def evaluate_gains(
    J: ArrayLike,
    gains: ObserverGains,
    rate_hz: float,
    measurement_noise: float,
    seed: int | np.random.SeedSequence = 0,
    horizon: float = 10.0,
    omega0: ArrayLike = DEFAULT_OMEGA0,
    initial_error: float = 1.0,
    settle: float = 0.01,
    truth: Trajectory | None = None,
    label: str = "",
) -> Evaluation:
    """Measure ``t_c`` and ``s`` of ``gains`` (module docstring). ``seed``: an int or a ``SeedSequence``;
    ``truth``: a precomputed :func:`omegahat.simulation.rigid_body.integrate` trajectory at the sample times
    (for sweeps)."""
    J = as_inertia(J)
    rate = float(as_positive(rate_hz, "rate_hz")[0])
    sigma = float(measurement_noise)
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"measurement_noise must be non-negative and finite; got {measurement_noise!r}")
    horizon = float(as_positive(horizon, "horizon")[0])
    omega0 = as_vector3(omega0, "omega0")
    if not 0 < settle < 1:
        raise ValueError(f"settle must be in (0, 1); got {settle!r}")
    if gains.n not in (2, 3):
        raise ValueError(f"attitude measurements give 2 or 3 rows of R; the gains are for {gains.n} directions")
    tr = _truth(J, omega0, rate, horizon) if truth is None else truth
    delta = float(as_positive(initial_error, "initial_error")[0]) * np.ones(3) / np.sqrt(3.0)
    est = SarrasEstimator(J, gains=gains, omega_hat0=omega0 + delta)
    err = estimate_errors(est.run(tr.t, tr.R), tr.omega, always_estimates=True)  # a NaN estimate: diverged
    t_c = convergence_time(tr.t, err, float(settle * np.linalg.norm(delta)))
    rng = np.random.default_rng(seed)
    R_meas = sensors.noisy_attitudes(tr.R, sigma, rng)
    est = SarrasEstimator(J, gains=gains, omega_hat0=omega0)
    err = estimate_errors(est.run(tr.t, R_meas), tr.omega, always_estimates=True)
    s = steady_rms(tr.t, err, min(5 * t_c, 0.5 * horizon))
    predicted = np.nan
    if sigma > 0:
        predicted = float(np.linalg.norm(tuning.predicted_noise_std(J, gains, rate, sigma)))
    return Evaluation(gains, rate, sigma, t_c, s, predicted, label)


def sweep(
    J: ArrayLike,
    k_values: Collection[float],
    l_values: Collection[float],
    rates_hz: Collection[float],
    noise_stds: Collection[float],
    seed: int = 0,
    **kwargs: Any,
) -> list[Evaluation]:
    """Evaluate constant gains ``ObserverGains.constant(k, l, n=3)`` for every k, l, rate and noise level.

    Every (k, l) at rate index a and noise index b uses the noise of ``SeedSequence(seed, spawn_key=(a, b))``.
    ``kwargs`` go to :func:`evaluate_gains` (horizon, omega0, initial_error, settle).
    """
    out = []
    J = as_inertia(J)
    for a, rate in enumerate(rates_hz):
        truth = _truth(
            J,
            as_vector3(kwargs.get("omega0", DEFAULT_OMEGA0), "omega0"),
            float(rate),
            float(kwargs.get("horizon", 10.0)),
        )
        for b, sigma in enumerate(noise_stds):
            seq = np.random.SeedSequence(seed, spawn_key=(a, b))
            for k in k_values:
                for l in l_values:
                    g = ObserverGains.constant(k, l, n=3)
                    out.append(
                        evaluate_gains(J, g, rate, sigma, seed=seq, truth=truth, label=f"k={k:g}, l={l:g}", **kwargs)
                    )
    return out


def pareto_front(times: ArrayLike, noises: ArrayLike) -> np.ndarray:
    """Boolean mask of the points not dominated in (time, noise), both minimised; non-finite points excluded."""
    x = np.asarray(times, dtype=float)
    y = np.asarray(noises, dtype=float)
    finite = np.isfinite(x) & np.isfinite(y)
    mask = np.zeros(x.size, dtype=bool)
    for i in np.flatnonzero(finite):
        dominated = finite & (x <= x[i]) & (y <= y[i]) & ((x < x[i]) | (y < y[i]))
        mask[i] = not dominated.any()
    return mask


def plot_pareto(evaluations: Iterable[Evaluation], ax: Axes | None = None) -> Axes:
    """Convergence time against steady-state noise, one colour per (rate, noise) pair, front joined by a line.
    Returns the axes."""
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6.5, 4.5))
    groups: dict[tuple[float, float], list[Evaluation]] = {}
    for e in evaluations:
        groups.setdefault((e.rate_hz, e.measurement_noise), []).append(e)
    for (rate, sigma), evs in groups.items():
        x = np.array([e.convergence_time for e in evs])
        y = np.array([e.noise_rms for e in evs])
        front = pareto_front(x, y)
        (line,) = ax.plot(
            x[front][np.argsort(x[front])],
            y[front][np.argsort(x[front])],
            "-o",
            ms=4,
            label=f"{rate:g} Hz, σ = {sigma:g} rad",
        )
        ax.plot(x[~front], y[~front], "x", color=line.get_color(), alpha=0.4, ms=4)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("convergence time t_c (s, 1 % of the initial error)")
    ax.set_ylabel("steady-state noise (rad/s RMS)")
    ax.legend(fontsize=8)
    return ax


@dataclass(frozen=True)
class Recommendation:
    """The gains chosen by :func:`recommend_gains`, their measured performance and every candidate."""

    gains: ObserverGains
    bandwidth_hz: float
    convergence_time: float
    noise_rms: float
    candidates: tuple  #: (bandwidth_hz, Evaluation) for every bandwidth tried


def recommend_gains(
    J: ArrayLike,
    rate_hz: float,
    measurement_noise: float,
    max_noise: float | None = None,
    max_convergence_time: float | None = None,
    bandwidths_hz: ArrayLike | None = None,
    seed: int = 0,
    horizon: float | None = None,
    references: ArrayLike | None = None,
    **kwargs: Any,
) -> Recommendation:
    """Gains for an attitude sensor sampled at ``rate_hz`` with noise ``measurement_noise`` (rad per axis).

    Candidates are :func:`omegahat.observer.tuning.sensor_gains` at each bandwidth of ``bandwidths_hz`` (default 16
    bandwidths, geometric, from ``min(0.05 Hz, rate/500)`` to ``rate/5``), each measured by
    :func:`evaluate_gains` (same noise for all). Give exactly one goal: ``max_noise`` (rad/s RMS) → the
    fastest candidate within it; ``max_convergence_time`` (s) → the least noisy candidate within it.
    ``horizon`` defaults to enough time for the slowest candidate to settle (``3 ln(1/settle) / (2π b_min)``,
    at least 5 s).
    """
    J = as_inertia(J)
    rate = float(as_positive(rate_hz, "rate_hz")[0])
    sigma = float(as_positive(measurement_noise, "measurement_noise")[0])
    if (max_noise is None) == (max_convergence_time is None):
        raise ValueError(
            f"give exactly one of max_noise or max_convergence_time; got max_noise={max_noise!r}, "
            f"max_convergence_time={max_convergence_time!r}"
        )
    goal = "max_noise" if max_noise is not None else "max_convergence_time"
    given = max_noise if max_noise is not None else max_convergence_time  # not None: exactly one was given
    limit = float(as_positive(given, goal)[0])  # type: ignore[arg-type]
    if bandwidths_hz is None:
        bws = np.geomspace(min(0.05, rate / 500), rate / 5, 16)
    else:
        bws = as_positive(bandwidths_hz, "bandwidths_hz")
    settle = kwargs.get("settle", 0.01)
    if horizon is None:
        horizon = max(5.0, 3 * math.log(1 / settle) / (2 * math.pi * float(np.min(bws))))
    truth = _truth(J, as_vector3(kwargs.pop("omega0", DEFAULT_OMEGA0), "omega0"), rate, horizon)
    seq = np.random.SeedSequence(seed)
    candidates = []
    for b in bws:
        g = tuning.sensor_gains(J, rate, sigma, bandwidth_hz=float(b), references=references)
        ev = evaluate_gains(
            J,
            g,
            rate,
            sigma,
            seed=seq,
            horizon=horizon,
            omega0=truth.omega[0],
            truth=truth,
            label=f"{b:.4g} Hz",
            **kwargs,
        )
        candidates.append((float(b), ev))
    if goal == "max_noise":
        ok = [(ev.convergence_time, b, ev) for b, ev in candidates if ev.noise_rms <= limit]
        if not ok:
            best = min(ev.noise_rms for _, ev in candidates)
            raise ValueError(
                f"no candidate meets max_noise = {limit:g} rad/s; the least noisy gives {best:.4g} "
                f"rad/s (lower the bandwidths_hz, or accept more noise)"
            )
        _, b, ev = min(ok, key=lambda x: x[0])
    else:
        ok = [(ev.noise_rms, b, ev) for b, ev in candidates if ev.convergence_time <= limit]
        if not ok:
            best = min(ev.convergence_time for _, ev in candidates)
            raise ValueError(
                f"no candidate meets max_convergence_time = {limit:g} s; the fastest takes "
                f"{best:.4g} s (raise the bandwidths_hz or the sample rate)"
            )
        _, b, ev = min(ok, key=lambda x: x[0])
    return Recommendation(ev.gains, b, ev.convergence_time, ev.noise_rms, tuple(candidates))
