"""Simulation: the rigid body, the one integrator of plant + observer, sensors and the comparison scenarios.

* :mod:`~omegahat.simulation.torque` — the torque acting on a body (one type for every simulator);
* :mod:`~omegahat.simulation.rigid_body` — ground truth: a fourth-order Lie-group integrator (CF4);
* :mod:`~omegahat.simulation.problem` — a coupled problem (body + observer) and its trajectory;
* :mod:`~omegahat.simulation.engine` — the lockstep ETDRK4 engine (:mod:`~omegahat.simulation.etd`,
  :mod:`~omegahat.simulation.rates`), for one run or many;
* :mod:`~omegahat.simulation.coupled` — :func:`simulate`, :func:`simulate_batch`, and :func:`simulate_reference`
  (SciPy on the paper's own equations, the independent oracle);
* :mod:`~omegahat.simulation.sensors` and :mod:`~omegahat.lab.scenarios` — noisy sensors and the
  scenarios of ``omegahat compare``.
"""

from omegahat.simulation.coupled import BatchResult, simulate, simulate_batch, simulate_reference
from omegahat.simulation.problem import PAPER_OMEGA_MAX, CoupledProblem, CoupledTrajectory, paper_problem
from omegahat.simulation.rigid_body import RigidBody, Trajectory, integrate
from omegahat.simulation.torque import Torque

__all__ = [
    "PAPER_OMEGA_MAX",
    "BatchResult",
    "CoupledProblem",
    "CoupledTrajectory",
    "RigidBody",
    "Torque",
    "Trajectory",
    "integrate",
    "paper_problem",
    "simulate",
    "simulate_batch",
    "simulate_reference",
]
