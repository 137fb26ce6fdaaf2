r"""The gyro-free peers' rows of ``omegahat compare``, and omegahat's one-direction observer beside them (issue 26).

Each is a :class:`omegahat.lab.evaluation.comparison.Method`, tuned and scored by the comparison's one procedure
(one knob, a grid, the least steady RMS on the tuning seed, scored on another seed); every one starts cold, from the
scenario's ω̂₀ (the TSO(3) filters' attitude from the first valid sample, the one-direction filters' direction too),
and is told the scenario's inertia, known torque and, where it has such a setting, measurement noise:

* ``min-energy``: :class:`omegahat.baselines.tso3_min_energy.MinimumEnergyFilter`, corrected form, with its source's
  settings (output weights ``q_i = 0.1``, ``K₀ = I₆``, ``α = 0.01`` 1/s) but for the process weight ``1/ρ``, the knob
  (its gain's response rate grows as ``(q/ρ)^{1/4}``);
* ``predictive``: :class:`omegahat.baselines.predictive_geom.PredictiveFilter`, corrected form, ``k_R = 0.7`` 1/s
  (its source's), the knob the ratio ``q/ρ`` of (G5) (only the ratio matters);
* ``single-direction``, ``single-direction-gradient``: omegahat's one-direction observer
  (:class:`omegahat.observer.single_direction.SingleDirectionEstimator`, its two methods), the knob its bandwidth;
* ``sunline-sekf``: :class:`omegahat.baselines.sunline_sekf.SunlineSEKF`, corrected form, told the measurement noise
  and ``σ_rate0 = ω_M`` (as the MEKF's prior), the knob its process noise q (its rates' random walk).

The TSO(3) filters take attitudes (as three directions) and two or more directions; the last three take one
direction. Their equations and sources: ``docs/baselines.md``.
"""

from __future__ import annotations

from omegahat.baselines.predictive_geom import PredictiveFilter
from omegahat.baselines.sunline_sekf import SunlineSEKF
from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter
from omegahat.lab import peer_scenarios as P
from omegahat.lab.evaluation.comparison import Method, filter_noise
from omegahat.observer.single_direction import SingleDirectionEstimator

__all__ = ["METHODS", "MIN_ENERGY_GRID", "PREDICTIVE_GRID", "SEKF_GRID"]

_TSO3_INPUTS = ("attitude", "directions")
_ONE = ("one-direction",)


def _min_energy(sc, process_weight):
    return MinimumEnergyFilter(
        sc.J_model, references=P.references(sc), process_weight=process_weight, omega_hat0=sc.omega_hat0
    )


def _predictive(sc, ratio):
    return PredictiveFilter(
        sc.J_model, references=P.references(sc), residual_weight=ratio, disturbance_weight=1.0,
        omega_hat0=sc.omega_hat0,
    )  # fmt: skip


def _single_direction(method):
    def make(sc, bandwidth_hz):
        return SingleDirectionEstimator(
            sc.J_model, reference=sc.references[0], method=method, bandwidth_hz=bandwidth_hz, omega_hat0=sc.omega_hat0
        )

    return make


def _sekf(sc, q):
    return SunlineSEKF(
        measurement_noise=filter_noise(sc), process_noise=q, sigma_rate0=sc.omega_max, omega_hat0=sc.omega_hat0
    )


_BANDWIDTHS_HZ = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0)
MIN_ENERGY_GRID = tuple(10.0**p for p in range(-10, 9, 2))  #: the minimum-energy filter's process weight 1/ρ
PREDICTIVE_GRID = tuple(10.0**p for p in range(0, 17, 2))  #: the predictive filter's ratio q/ρ
SEKF_GRID = tuple(10.0**p for p in range(-10, 7, 2))  #: the sun-line SEKF's process noise q, (rad/s²)²

#: The peers' rows and the one-direction observer's (module docstring), after the comparison's own METHODS.
METHODS = (
    Method(
        "min-energy", True, "the process weight 1/rho (the source's q_i = 0.1, K0 = I6, alpha = 0.01/s)",
        MIN_ENERGY_GRID, _min_energy, True, _TSO3_INPUTS,
    ),
    Method(
        "predictive", True, "the ratio q/rho of residual to disturbance weights (the source's k_R = 0.7/s)",
        PREDICTIVE_GRID, _predictive, True, _TSO3_INPUTS,
    ),
    Method(
        "single-direction", True, "bandwidth_hz of omegahat's one-direction observer (Sarras-type)", _BANDWIDTHS_HZ,
        _single_direction("sarras"), True, _ONE,
    ),
    Method(
        "single-direction-gradient", True, "bandwidth_hz of omegahat's one-direction observer (gradient)",
        _BANDWIDTHS_HZ, _single_direction("gradient"), True, _ONE,
    ),
    Method(
        "sunline-sekf", True, "process noise q (rad/s^2)^2 of the rates' random walk (sigma_rate0 = w_M)",
        SEKF_GRID, _sekf, True, _ONE,
    ),
)  # fmt: skip
