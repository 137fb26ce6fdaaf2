r"""Velocity-free attitude control: a saturated PD law on SO(3) fed omegahat's rate estimate instead of a gyro.

* :mod:`omegahat.lab.control.controller` — the attitude and rate errors, the PD tracking law with feed-forward and
  per-axis saturation, references (a fixed attitude, a rest-to-rest slew);
* :mod:`omegahat.lab.control.closed_loop` — the sampled loop (star tracker, rate source, zero-order-hold torque,
  plant) and its scores (settling time, pointing error, torque used);
* :mod:`omegahat.lab.control.scenarios` — the detumble and slew scenarios and the rate sources compared;
* :mod:`omegahat.lab.control.basin` — the Monte-Carlo over initial attitudes and rates (the measured basin);
* :mod:`omegahat.lab.control.mujoco_plant` — MuJoCo as an independent plant (extra ``omegahat[mujoco]``).

``docs/theory/control.md`` states the law, what is proven and what is only measured, with the measured tables.
"""

from omegahat.lab.control.closed_loop import (
    ClosedLoopRun,
    EstimatorFeed,
    GyroFeed,
    RateFeed,
    RigidBodyPlant,
    WrongSignFeed,
    pointing_error,
    settling_time,
    simulate_closed_loop,
    torque_used,
)
from omegahat.lab.control.controller import AttitudePD, Reference, SlewReference, attitude_error, error_angle, pd_gains
from omegahat.lab.control.scenarios import FEEDS, ControlScenario, detumble, make_feed, run_scenario, slew

__all__ = [
    "FEEDS",
    "AttitudePD",
    "ClosedLoopRun",
    "ControlScenario",
    "EstimatorFeed",
    "GyroFeed",
    "RateFeed",
    "Reference",
    "RigidBodyPlant",
    "SlewReference",
    "WrongSignFeed",
    "attitude_error",
    "detumble",
    "error_angle",
    "make_feed",
    "pd_gains",
    "pointing_error",
    "run_scenario",
    "settling_time",
    "simulate_closed_loop",
    "slew",
    "torque_used",
]
