r"""Each run of a campaign drawn from its own seed, and replayed from it.

**Seeds.** Run ``j`` of a campaign with seed ``s`` draws everything from
``numpy.random.default_rng(SeedSequence(s, spawn_key=(j,)))``: the ``j``-th child of ``SeedSequence(s).spawn(...)``
(:mod:`omegahat.lab.campaigns.seeds` computes those generators for all runs of a chunk at once). A run depends on
``(s, j)`` only; :func:`replay` rebuilds any run from them. No draw depends on the gains: a chunk draws each run
once and integrates it for every gain set.

Each run draws, always in this order from its own generator:

* the attitude uniform on SO(3) (a normalised standard normal quaternion);
* ω₀ uniform in the ball ``|ω₀| ≤ omega0_fraction · ω_M``;
* each ``r̂_i0``: 0 with probability ``p_zero``, ``−r_i0`` with probability ``p_opposite``, otherwise uniform
  in the ball of radius ``r_hat_radius``;
* ω̂₀ with a uniform direction and ``|ω̂₀|`` uniform in ``[0, omega_hat_max]`` (uniform in magnitude, not in
  volume, so small and large initial errors are equally represented);
* a torque ``Σ_j a_j ∘ sin(ν_j t + φ_j)`` (:meth:`~omegahat.simulation.torque.Torque.sinusoidal`, no constant term)
  with ``a_j`` uniform in ``[−amplitude, amplitude]³``, ν_j uniform in ``frequency``, φ_j uniform in ``[0, 2π)``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.seeds import generators
from omegahat.simulation.coupled import simulate
from omegahat.simulation.problem import CoupledProblem, CoupledTrajectory
from omegahat.simulation.torque import Torque

__all__ = ["draw_problem", "draw_runs", "replay"]


def _unit_rows(v):
    """Rows of ``v`` divided by their norms, the squares summed left to right by NumPy's element-wise
    arithmetic (the same bits on every machine, unlike BLAS's dot, whose summation order depends on the CPU)."""
    sq = v[:, 0] * v[:, 0]
    for j in range(1, v.shape[1]):
        sq = sq + v[:, j] * v[:, j]
    return v / np.sqrt(sq)[:, None]


def draw_runs(campaign: Campaign, indices: ArrayLike) -> dict[str, np.ndarray]:
    """Runs ``indices`` drawn once each (module docstring), stacked by run: ``R0 (N, 3, 3)``, ``omega0 (N, 3)``,
    ``r_hat0 (N, n, 3)``, ``omega_hat0 (N, 3)`` and the torque's ``constant (N, 3)`` (zero), ``amplitudes
    (N, M, 3)``, ``frequencies (N, M)``, ``phases (N, M, 3)``."""
    # Runs `indices` drawn once each (module docstring), stacked by run: R0 (N, 3, 3), omega0 (N, 3), r_hat0
    # (N, n, 3), omega_hat0 (N, 3) and the torque's constant (N, 3; zero), amplitudes (N, M, 3), frequencies
    # (N, M), phases (N, M, 3). No draw depends on the gains: the source of draw_problem (one run) and of
    # run_chunk (a chunk, integrated for every gain set). The loop only takes each run's raw standard normal
    # and uniform numbers from its own generator, always in this order: 4 normals (attitude), 3 normals and a
    # uniform (ω₀), per direction a uniform (zero, opposite or ball), 3 normals and a uniform (r̂_i0), 3 normals
    # and a uniform (ω̂₀), then 7M uniforms (the torque's amplitudes, frequencies, phases); the arithmetic on
    # them is done for all runs at once (each element sees the same operations as a run drawn alone).
    c = campaign
    indices = np.asarray(indices, dtype=np.int64).reshape(-1)
    N, n, M = indices.size, c.references.shape[0], c.torque_terms
    normals = np.empty((N, 4 + 3 * (n + 2)))  # attitude, ω₀, r̂_i0, ω̂₀ directions
    uniforms = np.empty((N, 2 * n + 2))  # ω₀ radius, (choice, radius) per direction, |ω̂₀|
    torque_u = np.empty((N, 7 * M))
    for row, rng in enumerate(generators(c.seed, indices)):  # run_seed(c.seed, index)'s generators
        g, u = normals[row], uniforms[row]
        rng.standard_normal(out=g[0:7])  # attitude quaternion (4), ω₀'s direction (3): one call, the same numbers
        u[0] = rng.random()
        for i in range(n):
            u[1 + 2 * i] = rng.random()
            rng.standard_normal(out=g[7 + 3 * i : 10 + 3 * i])
            u[2 + 2 * i] = rng.random()
        rng.standard_normal(out=g[7 + 3 * n : 10 + 3 * n])
        u[1 + 2 * n] = rng.random()
        rng.random(out=torque_u[row])
    quat = _unit_rows(normals[:, 0:4])
    omega0 = _unit_rows(normals[:, 4:7]) * c.omega0_fraction * c.omega_max * (uniforms[:, [0]] ** (1.0 / 3.0))
    r_hat0 = np.empty((N, n, 3))
    choice = uniforms[:, 1 : 2 * n + 1 : 2]  # (N, n)
    for i in range(n):
        radius = uniforms[:, [2 + 2 * i]] ** (1.0 / 3.0)
        r_hat0[:, i] = _unit_rows(normals[:, 7 + 3 * i : 10 + 3 * i]) * c.r_hat_radius * radius
    r_hat0[choice < c.p_zero] = 0.0
    opposite = (choice >= c.p_zero) & (choice < c.p_zero + c.p_opposite)  # −r_i0, filled in once R0 is known
    omega_hat0 = _unit_rows(normals[:, 7 + 3 * n : 10 + 3 * n]) * c.omega_hat_max * uniforms[:, [1 + 2 * n]]
    # Generator.uniform(low, high) is low + (high − low)·U with the same U (tests/test_montecarlo.py checks it)
    a, (f_lo, f_hi) = c.torque_amplitude, c.torque_frequency
    amplitudes = -a + (a - -a) * torque_u[:, : 3 * M].reshape(N, M, 3)
    frequencies = f_lo + (f_hi - f_lo) * torque_u[:, 3 * M : 4 * M]
    phases = 0.0 + (2.0 * np.pi - 0.0) * torque_u[:, 4 * M :].reshape(N, M, 3)
    # one call for all runs: scipy converts quaternion by quaternion, the same numbers as one call per run
    R0 = Rotation.from_quat(quat).as_matrix() if N else np.empty((0, 3, 3))
    r0 = c.references @ R0
    r_hat0[opposite] = -r0[opposite]
    return {
        "R0": R0,
        "omega0": omega0,
        "r_hat0": r_hat0,
        "omega_hat0": omega_hat0,
        "constant": np.zeros((N, 3)),
        "amplitudes": amplitudes,
        "frequencies": frequencies,
        "phases": phases,
    }


def draw_problem(campaign: Campaign, index: int, gains_name: str | None = None) -> CoupledProblem:
    """Run ``index`` of the campaign as a :class:`~omegahat.simulation.coupled.CoupledProblem` (draws in the module
    docstring, always in the same order from the run's own generator)."""
    c = campaign
    d = draw_runs(c, [index])
    torque = Torque.sinusoidal(amplitudes=d["amplitudes"][0], frequencies=d["frequencies"][0], phases=d["phases"][0])
    name = next(iter(c.gains)) if gains_name is None else gains_name
    return CoupledProblem(
        J=c.J,
        gains=c.gains[name],
        omega0=d["omega0"][0],
        R0=d["R0"][0],
        references=c.references,
        r_hat0=d["r_hat0"][0],
        omega_hat0=d["omega_hat0"][0],
        torque=torque,
    )


def replay(campaign: Campaign, gains_name: str, index: int) -> CoupledTrajectory:
    """Run ``index`` again with :func:`omegahat.simulation.coupled.simulate` (identical to its campaign run)."""
    p = draw_problem(campaign, index, gains_name)
    return simulate(
        p,
        t_out=campaign.t_out,
        rtol=campaign.rtol,
        atol=campaign.atol,
        h_max=campaign.h_max,
        max_steps=campaign.max_steps,
    )
