r"""The gyro-free peers in the uniformity comparison (issue 26): discrete-time filters on a campaign's draws.

:mod:`omegahat.lab.evaluation.uniformity` measures whether an observer's convergence rate degrades as the initial
error grows, every observer from the same draws of a campaign. The published gyro-free filters are discrete-time,
so they see the same true motion sampled:

* **The motion.** For run j, the truth integrated alone (:func:`omegahat.simulation.rigid_body.integrate`) from
  the draw's R₀, ω₀ under its torque, sampled at :data:`PEER_RATE_HZ`; the filter is fed the exact measured
  directions ``r_i = Rᵀ v_i`` of the campaign's references (no noise, as the continuous observers') and the torque
  at the samples, from ``omega_hat0 = ω̂₀`` (its attitude, or direction, from the first sample), and its error
  ``|ω̂ − ω|`` is read on the uniformity's output grid (infinite where a restart left no estimate).
* **The filters** (:data:`SAMPLED`; corrected forms; equations in ``docs/baselines.md``): ``min-energy``
  (:class:`omegahat.baselines.tso3_min_energy.MinimumEnergyFilter`, its source's settings but the rate block of
  ``K₀``, which covers the campaign's range, ``(ω_M + ω̂_max)²``, as the MEKF's prior in
  :mod:`omegahat.lab.evaluation.robustness`); ``predictive`` (:class:`omegahat.baselines.predictive_geom.
  PredictiveFilter`, its source's ``k_R``); ``sunline-sekf`` (:class:`omegahat.baselines.sunline_sekf.SunlineSEKF`,
  told ``σ_rate0 = ω_M + ω̂_max`` and the measurement noise floor of ``omegahat compare``, 1e-6): it sees the first
  reference alone and estimates no rate about it, so it is scored on the error across it,
  ``|(I − b bᵀ)(ω̂ − ω)|`` (its initial error too, for the bins).
* **One knob each, tuned by the comparison's rule** (:func:`tuned`): the knob and grid of
  :mod:`omegahat.lab.evaluation.peer_methods`, the grid value with the least steady-state RMS error — here the mean
  over :data:`TUNING_RUNS` draws of the campaign re-seeded (seed + 1) with ``|ω̂₀| ≤ ω_M`` (a knob is tuned for
  the steady state, near the truth), of the RMS over the horizon's second half (infinite if the filter
  restarted). The tuned value is part of the observer's name in the report.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.sunline_sekf import SunlineSEKF
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter
from omegahat.interface import StreamingEstimator
from omegahat.lab.campaigns.config import Campaign, replace
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.lab.evaluation.metrics import steady_rms
from omegahat.lab.evaluation.peer_methods import MIN_ENERGY_GRID, PREDICTIVE_GRID, SEKF_GRID
from omegahat.simulation.rigid_body import RigidBody, integrate
from omegahat.simulation.torque import Torque

__all__ = ["PEER_RATE_HZ", "SAMPLED", "TUNING_RUNS", "SampledPeer", "TunedPeer", "draw_torque", "errors", "tuned"]

PEER_RATE_HZ = 1000.0  #: the rate at which the peers sample the motion (the paper's campaign in robustness: 1 kHz)
TUNING_RUNS = 4  #: draws of the re-seeded campaign the knob is tuned on


@dataclass(frozen=True)
class SampledPeer:
    """A discrete-time filter of the comparison: ``make(campaign, omega_hat0, value)`` builds it with its knob at
    ``value`` (``knob`` names it, ``grid`` its values); ``one_direction``: it sees the campaign's first reference
    alone and is scored across it."""

    name: str
    knob: str
    grid: tuple[float, ...]
    make: Callable[[Campaign, np.ndarray, float], StreamingEstimator]
    one_direction: bool = False


@dataclass(frozen=True)
class TunedPeer:
    """A :class:`SampledPeer` with its knob tuned (:func:`tuned`)."""

    peer: SampledPeer
    value: float

    @property
    def name(self) -> str:
        return f"{self.peer.name} ({self.peer.knob} = {self.value:g})"


def _prior(c: Campaign) -> float:
    return c.omega_max + c.omega_hat_max  # a rate prior covering the campaign's range (module docstring)


#: name -> the sampled peers (module docstring)
SAMPLED: dict[str, SampledPeer] = {
    "min-energy": SampledPeer(
        "min-energy", "1/rho", MIN_ENERGY_GRID,
        lambda c, w0, pw: MinimumEnergyFilter(
            c.J, references=c.references, process_weight=pw, K0=np.diag([1.0] * 3 + [_prior(c) ** 2] * 3),
            omega_hat0=w0,
        ),
    ),
    "predictive": SampledPeer(
        "predictive", "q/rho", PREDICTIVE_GRID,
        lambda c, w0, r: PredictiveFilter(
            c.J, references=c.references, residual_weight=r, disturbance_weight=1.0, omega_hat0=w0
        ),
    ),
    "sunline-sekf": SampledPeer(
        "sunline-sekf, across b", "q", SEKF_GRID,
        lambda c, w0, q: SunlineSEKF(measurement_noise=1e-6, process_noise=q, sigma_rate0=_prior(c), omega_hat0=w0),
        one_direction=True,
    ),
}  # fmt: skip


def draw_torque(draws: dict, j: int) -> Torque:
    """The torque of run ``j`` of a campaign's draws (:func:`omegahat.lab.campaigns.draws.draw_runs`)."""
    return Torque.sinusoidal(
        amplitudes=draws["amplitudes"][j], frequencies=draws["frequencies"][j], phases=draws["phases"][j]
    )


def _motion(campaign: Campaign, one_direction: bool, R0, omega0, t_out: np.ndarray, torque: Torque):
    """``(t, measured directions, torques at the samples, true ω, b, output indices)`` of the sampled motion."""
    h = 1.0 / PEER_RATE_HZ
    t = t_out[0] + h * np.arange(round((t_out[-1] - t_out[0]) / h) + 1)
    truth = integrate(RigidBody(campaign.J), R0, omega0, t, torque)
    b = np.einsum("tji,nj->tni", truth.R, campaign.references[:1] if one_direction else campaign.references)
    k = np.rint((t_out - t_out[0]) / h).astype(int)
    return t, (b[:, 0] if one_direction else b), truth.torque, truth.omega, b[:, 0], k


def _errors(est: StreamingEstimator, one_direction: bool, motion) -> tuple[np.ndarray, int]:
    t, meas, taus, omega, b, k = motion
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # restarts: counted, and scored (no estimate: infinite)
        d = est.run(t, meas, taus).omega - omega
    if one_direction:  # across the measured direction
        d = d - np.sum(d * b, axis=1, keepdims=True) * b
    err = np.linalg.norm(d[k], axis=1)
    return np.where(np.isfinite(err), err, np.inf), int(getattr(est, "n_restarts", 0))


def errors(
    campaign: Campaign, tp: TunedPeer, R0: np.ndarray, omega0: np.ndarray, omega_hat0: np.ndarray,
    t_out: np.ndarray, torque: Torque,
) -> tuple[np.ndarray, int]:  # fmt: skip
    """The tuned filter's errors at the output times ``t_out`` (module docstring) and its number of restarts."""
    one = tp.peer.one_direction
    est = tp.peer.make(campaign, omega_hat0, tp.value)
    return _errors(est, one, _motion(campaign, one, R0, omega0, t_out, torque))


def tuned(campaign: Campaign, name: str, horizon: float | None = None, runs: int = TUNING_RUNS) -> TunedPeer:
    """The peer ``name`` with its knob tuned on ``runs`` draws of the campaign re-seeded (module docstring)."""
    peer = SAMPLED[name]
    tuning = replace(campaign, seed=campaign.seed + 1, omega_hat_max=campaign.omega_max)
    horizon = campaign.horizon if horizon is None else float(horizon)
    t_out = np.linspace(0.0, horizon, round(horizon / campaign.dt_out) + 1)
    draws = draw_runs(tuning, np.arange(runs))
    motions = [
        _motion(campaign, peer.one_direction, draws["R0"][j], draws["omega0"][j], t_out, draw_torque(draws, j))
        for j in range(runs)
    ]
    best = (peer.grid[0], np.inf)
    for value in peer.grid:
        scores = []
        for j, motion in enumerate(motions):
            err, restarts = _errors(peer.make(campaign, draws["omega_hat0"][j], value), peer.one_direction, motion)
            scores.append(np.inf if restarts else steady_rms(t_out, err, 0.5 * horizon))
        score = float(np.mean(scores))
        if score < best[1]:
            best = (value, score)
    return TunedPeer(peer, best[0])
