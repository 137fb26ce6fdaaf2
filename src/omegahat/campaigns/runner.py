r"""Monte-Carlo campaigns: many independent plant + observer runs, and what they say about the theorem.

**Batch engine.** :func:`simulate_batch` integrates ``N`` coupled problems (same body, references and gains;
own initial conditions and torque) with :func:`omegahat.simulation.engine.integrate_coupled_lanes`: each of Numba's
threads steps its share of the runs 24 at a time in lockstep (SIMD), each run with its own step sizes and
performing exactly the operations of the single-run kernel :func:`omegahat.simulation.coupled.integrate_coupled`, so
every run is bit-for-bit what :func:`omegahat.simulation.coupled.simulate` gives for it, whatever the batch or chunk
it sits in. The per-run diagnostics below (:mod:`omegahat.campaigns.diagnostics`) are one compiled pass over a batch's
states (:func:`diagnose`; ``_diagnose_numpy`` is their NumPy reference); a campaign (:func:`run_chunk`) has the kernel
take them run by run as runs end (:func:`omegahat.simulation.engine.integrate_diagnosed_lanes`), the same numbers
without holding every run's states. A run's generator comes from :mod:`omegahat.campaigns.seeds` (SeedSequence's
states for all runs of a chunk at once) and its draws are combined for all runs at once.

**Seeds.** Run ``j`` of a campaign with seed ``s`` draws everything from
``numpy.random.default_rng(SeedSequence(s, spawn_key=(j,)))``: the ``j``-th child of
``SeedSequence(s).spawn(...)``. A run depends on ``(s, j)`` only; :func:`replay` rebuilds any run from them.
No draw depends on the gains: :func:`run_chunk` draws each run once and integrates it for every gain set.

**The claim under test** (observer.md; Sarras' theorem): with ``J_m I ≤ J ≤ J_M I``, ``|ω(t)| ≤ ω_M`` and gains
meeting the conditions of :mod:`omegahat.observer.gains`, the errors ``z = ω̂ − ω``, ``e_i = r̂_i − r_i`` converge
globally exponentially, and the proof's ``V = |J z| + ½ Σ |e_i|²`` decreases. Each run draws

* the attitude uniform on SO(3) (a normalised standard normal quaternion);
* ω₀ uniform in the ball ``|ω₀| ≤ omega0_fraction · ω_M``;
* each ``r̂_i0``: 0 with probability ``p_zero``, ``−r_i0`` with probability ``p_opposite``, otherwise uniform
  in the ball of radius ``r_hat_radius``;
* ω̂₀ with a uniform direction and ``|ω̂₀|`` uniform in ``[0, omega_hat_max]`` (uniform in magnitude, not in
  volume, so small and large initial errors are equally represented);
* a torque ``Σ_j a_j ∘ sin(ν_j t + φ_j)`` (:class:`~omegahat.simulation.coupled.SinusoidalTorque`, no constant term)
  with ``a_j`` uniform in ``[−amplitude, amplitude]³``, ν_j uniform in ``frequency``, φ_j uniform in ``[0, 2π)``.

A run whose ``|ω|`` exceeds ω_M at an output time breaks the assumption: it is counted and **set aside**.

**Envelope.** With ``E(t) = |z(t)| + Σ_i |e_i(t)|`` and ``ρ(t) = E(t)/E(0)`` on the output grid ``t_k``:

* a run's rate ``λ_run = −ln ρ(t_f) / t_f``, where ``t_f`` is the last output time with ``ρ ≥ rho_floor``
  (default 1e-8; below it the integrator's tolerance, not the observer, sets ρ). It is the average exponential
  rate at which the run loses its first ``−ln ρ(t_f)`` nepers (8 decades when the floor is reached);
* its own constant ``c_run = max_{t_k ≤ t_f} ρ(t_k) e^{λ_run t_k} ≥ 1`` (the overshoot above a pure exponential
  at its own rate);
* the campaign's worst rate ``λ* = min λ_run`` and worst constant ``c* = max_runs max_{t_k ≤ t_f}
  ρ(t_k) e^{λ* t_k}``: the smallest c for which ``E(t) ≤ c e^{−λ* t} E(0)`` holds for every run and output
  time down to the floor. ``(c*, λ*)`` is an envelope measured on the grid, not a proof.

**Counterexamples** (saved with their seed and index, one list per gain set): a run that failed to integrate
(non-finite state or step budget), did not converge (``ρ(horizon) > converged_below``), or along which ``V``
increased between two output times by more than the relative tolerance ``v_increase_tol`` (checked while
``ρ ≥ rho_floor``). ``V`` increasing is a counterexample to the proof only for gains that satisfy the theorem
(``satisfies_theorem`` in the summary); for practical gains it is reported as what it is.

**Result** of ``omegahat montecarlo examples/campaign.toml`` (10,000 runs, seed 20250101, J = diag(3, 2, 1), two
rows of R, ω_M = 3; 48 runs left |ω| ≤ ω_M and were set aside, 9,952 used per gain set):

* theorem's gains (k = 14.5, l = 1309 + 436 |ω̂|): λ* = 4.86/s, c* = 1.0, V never increased, no counterexample;
* k = 5, l = 5 + 2 |ω̂| (outside the theorem's conditions): λ* = 1.59/s, c* = 1.91, V never increased, none;
* k = 14.5, constant l = 1: **not globally convergent**: 6,793 runs still above 1e-6 of their initial error at
  20 s, V increased in 7,972 (all saved as counterexamples); λ* < 0. The l that grows with |ω̂| matters.

Accuracy (rtol 1e-6 against 1e-10, runs 7902 and 4731): λ_run of the theorem's and the slope gains agree to
1e-7 relative. The trapped runs of constant l are sensitive to perturbations: run 4731 ends at |ω̂ − ω| = 147
rad/s at rtol 1e-6 (151 with the former step-doubling control) but 47 rad/s at rtol 1e-10, 1e-12 and with DOP853
at rtol 1e-12 on the observer's own equations (λ_run −0.099 against −0.044/s). Their verdict (not converged) is
robust, their numbers are not: replay a counterexample at a tighter ``rtol`` before quoting its trajectory.
"""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numba
import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.campaigns.diagnostics import diagnose_runs, diagnose_runs_parallel
from omegahat.campaigns.seeds import generators
from omegahat.observer.gains import ObserverGains, check_gains, theorem_gains
from omegahat.simulation.coupled import (
    CoupledProblem,
    SinusoidalTorque,
    first_step,
    simulate,
)
from omegahat.simulation.engine import integrate_coupled_lanes, integrate_diagnosed_lanes
from omegahat.validation import as_directions, as_inertia

__all__ = [
    "BatchResult",
    "Campaign",
    "GainSetResult",
    "campaign_from_toml",
    "draw_problem",
    "envelope_fit",
    "kernel_inputs",
    "load_campaign",
    "plot_envelopes",
    "plot_rates",
    "replay",
    "run_campaign",
    "run_chunk",
    "run_seed",
    "simulate_batch",
    "summarize",
    "write_outputs",
]


# --------------------------------------------------------------------------------------------------------------
# Batch engine
# --------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class BatchResult:
    """States of ``N`` runs at the output times: ``Y (N, T, 6n + 6)`` in the kernel's layout
    ``[r (3n), ω, z, e (3n)]``; accepted and rejected steps ``(N,)``; ``ok (N,)`` False where a run failed."""

    t: np.ndarray
    Y: np.ndarray
    accepted: np.ndarray
    rejected: np.ndarray
    ok: np.ndarray


def _kernel_inputs(J, references, gains, runs: dict, h_max):
    # The kernel's inputs packed from stacked runs (the arrays of _draw_runs: R0, omega0, r_hat0, omega_hat0 and
    # the torque's constant, amplitudes, frequencies, phases, padded to a common number of terms). Y0 is
    # omegahat.simulation.coupled.initial_state and h0 the first step of omegahat.simulation.coupled.simulate, row by
    # row with the same floating-point operations, so each run is what simulate gives for it.
    omega0, omega_hat0 = runs["omega0"], runs["omega_hat0"]
    N = omega0.shape[0]
    r0 = references @ runs["R0"]  # (N, n, 3): r_i = R0ᵀ v_i of each run
    Y0 = np.concatenate([r0.reshape(N, -1), omega0, omega_hat0 - omega0, (runs["r_hat0"] - r0).reshape(N, -1)], axis=1)
    h0 = first_step(gains, omega_hat0, h_max)
    body = (gains.n, J, np.linalg.inv(J), gains.k, gains.l_offset, gains.l_slope)
    torque = (runs["constant"], runs["amplitudes"], runs["frequencies"], runs["phases"])
    return Y0, body, torque, h0


def _workers(n_workers) -> int:
    workers = numba.get_num_threads() if n_workers is None else int(n_workers)
    if workers < 1:
        raise ValueError(f"n_workers must be at least 1; got {n_workers!r}")
    return workers


def _run_kernel(inputs, t_out, rtol, atol, h_max, max_steps, n_workers, parallel) -> BatchResult:
    Y0, body, torque, h0 = inputs
    Y, acc, rej, ok = integrate_coupled_lanes(
        Y0,
        t_out,
        *body,
        *torque,
        float(rtol),
        float(atol),
        h0,
        float(h_max),
        int(max_steps),
        _workers(n_workers),
        parallel=parallel,
    )
    return BatchResult(t=t_out, Y=Y, accepted=acc, rejected=rej, ok=ok)


def kernel_inputs(problems, h_max: float = 0.05):
    """The batch kernels' inputs for ``problems`` (sharing J, gains and references): ``(Y0, body, torque, h0)``
    with ``body = (n, J, J⁻¹, k, l_offset, l_slope)`` and ``torque = (constant, amplitudes, frequencies,
    phases)`` stacked over runs (padded to a common number of terms), for
    :func:`omegahat.simulation.engine.integrate_coupled_lanes` or
    :func:`omegahat.simulation.coupled.integrate_coupled_batch` as ``kernel(Y0, t_out, *body, *torque, rtol, atol, h0,
    h_max, max_steps, n_workers)``."""
    problems = list(problems)
    if not problems:
        raise ValueError("a batch needs at least one problem")
    p0 = problems[0]
    for j, p in enumerate(problems):
        same = (
            np.array_equal(p.J, p0.J)
            and np.array_equal(p.references, p0.references)
            and all(np.array_equal(getattr(p.gains, a), getattr(p0.gains, a)) for a in ("k", "l_offset", "l_slope"))
        )
        if not same:
            raise ValueError(f"problem {j} has another J, gains or references than problem 0; batch them apart")
    N = len(problems)
    M = max(p.torque.frequencies.size for p in problems)
    # Padding with zero-amplitude terms adds exactly 0.0 to the torque: the padded run is the same run.
    runs = {
        "R0": np.stack([p.R0 for p in problems]),
        "omega0": np.stack([p.omega0 for p in problems]),
        "r_hat0": np.stack([p.r_hat0 for p in problems]),
        "omega_hat0": np.stack([p.omega_hat0 for p in problems]),
        "constant": np.stack([p.torque.constant for p in problems]),
        "amplitudes": np.zeros((N, M, 3)),
        "frequencies": np.zeros((N, M)),
        "phases": np.zeros((N, M, 3)),
    }
    for j, p in enumerate(problems):
        m = p.torque.frequencies.size
        runs["amplitudes"][j, :m] = p.torque.amplitudes
        runs["frequencies"][j, :m] = p.torque.frequencies
        runs["phases"][j, :m] = p.torque.phases
    return _kernel_inputs(p0.J, p0.references, p0.gains, runs, h_max)


def simulate_batch(
    problems,
    t_out,
    rtol: float = 1e-9,
    atol: float = 1e-15,
    h_max: float = 0.05,
    max_steps: int = 10_000_000,
    n_workers: int | None = None,
    parallel: bool = True,
) -> BatchResult:
    """Integrate ``problems`` (a sequence of :class:`~omegahat.simulation.coupled.CoupledProblem` sharing J, gains and
    references); each run equals ``simulate(problem, t_out=t_out, ...)`` bit for bit.

    ``parallel=True``: the lockstep kernel on ``n_workers`` threads (default: Numba's thread count).
    ``parallel=False``: the lockstep kernel on the calling thread, for callers that parallelise themselves (Dask
    workers running several tasks in threads; Numba's default threading layer must not be entered from two
    threads at once). A failed run does not raise: its ``ok`` is False and its rows after the failure are NaN.
    """
    t_out = np.asarray(t_out, dtype=float)
    if t_out.ndim != 1 or t_out.size < 1 or t_out[0] != 0.0 or np.any(np.diff(t_out) <= 0):
        raise ValueError("t_out must start at 0 and increase strictly")
    return _run_kernel(kernel_inputs(problems, h_max), t_out, rtol, atol, h_max, max_steps, n_workers, parallel)


# --------------------------------------------------------------------------------------------------------------
# Campaign definition
# --------------------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Campaign:
    """Everything that defines a campaign; two equal campaigns give the same numbers (module docstring)."""

    J: np.ndarray
    omega_max: float
    gains: dict  # name -> ObserverGains
    references: np.ndarray = field(default_factory=lambda: np.eye(3)[:2])
    runs: int = 1000
    seed: int = 0
    chunk_size: int = 256
    horizon: float = 20.0
    dt_out: float = 0.05
    rtol: float = 1e-6
    atol: float = 1e-15
    h_max: float = 0.05
    max_steps: int = 2_000_000
    omega0_fraction: float = 0.6
    r_hat_radius: float = 10.0
    p_zero: float = 0.05
    p_opposite: float = 0.05
    omega_hat_max: float = 100.0
    torque_terms: int = 2
    torque_amplitude: float = 0.3
    torque_frequency: tuple = (0.5, 5.0)
    rho_floor: float = 1e-8
    converged_below: float = 1e-6
    v_increase_tol: float = 1e-6

    def __post_init__(self):
        object.__setattr__(self, "J", as_inertia(self.J))
        object.__setattr__(self, "references", as_directions(self.references))
        for name, g in self.gains.items():
            if not isinstance(g, ObserverGains):
                raise TypeError(f"gains[{name!r}] must be an ObserverGains; got {type(g).__name__}")
            if g.n != self.references.shape[0]:
                raise ValueError(
                    f"gains[{name!r}] are for {g.n} directions, the campaign has {self.references.shape[0]}"
                )
        if not self.gains:
            raise ValueError("a campaign needs at least one gain set")
        for attr in _RANGES:
            _check_number(attr, attr, "Campaign", getattr(self, attr), attr in _INTEGER)
        lo, hi = self.torque_frequency
        if not 0 < lo <= hi < math.inf:
            raise ValueError(f"Campaign: torque_frequency must be (low, high) with 0 < low <= high; got {(lo, hi)!r}")
        if self.p_zero + self.p_opposite > 1:
            raise ValueError(f"Campaign: p_zero + p_opposite must not exceed 1; got {self.p_zero} + {self.p_opposite}")

    @property
    def t_out(self) -> np.ndarray:
        count = round(self.horizon / self.dt_out)
        return np.linspace(0.0, count * self.dt_out, count + 1)


def run_seed(seed: int, index: int) -> np.random.SeedSequence:
    """The seed sequence of run ``index``: equal to ``SeedSequence(seed).spawn(index + 1)[index]``."""
    return np.random.SeedSequence(seed, spawn_key=(int(index),))


def _unit_rows(v):
    """Rows of ``v`` divided by their norms, the squares summed left to right by NumPy's element-wise
    arithmetic (the same bits on every machine, unlike BLAS's dot, whose summation order depends on the CPU)."""
    sq = v[:, 0] * v[:, 0]
    for j in range(1, v.shape[1]):
        sq = sq + v[:, j] * v[:, j]
    return v / np.sqrt(sq)[:, None]


def _draw_runs(campaign: Campaign, indices) -> dict:
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
    d = _draw_runs(c, [index])
    torque = SinusoidalTorque(amplitudes=d["amplitudes"][0], frequencies=d["frequencies"][0], phases=d["phases"][0])
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


def replay(campaign: Campaign, gains_name: str, index: int):
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


# --------------------------------------------------------------------------------------------------------------
# Per-run diagnostics
# --------------------------------------------------------------------------------------------------------------


def envelope_fit(t, rho, rho_floor):
    """``(λ_run, c_run, i_f)`` of each run (module docstring) from ``ρ (N, T)`` on the grid ``t (T,)``.

    ``i_f`` is the index of ``t_f``; a run that never leaves ρ = 1 has ``i_f = 0`` and ``λ_run = NaN``.
    """
    rho = np.asarray(rho, dtype=float)
    above = rho >= rho_floor
    T = t.size
    i_f = T - 1 - np.argmax(above[:, ::-1], axis=1)  # last index with ρ ≥ floor (ρ(0) = 1 ≥ floor)
    rows = np.arange(rho.shape[0])
    t_f = t[i_f]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = np.where(t_f > 0, -np.log(rho[rows, i_f]) / np.where(t_f > 0, t_f, 1.0), np.nan)
    c_run = np.array([_worst_constant(t, rho[j], i_f[j], lam[j]) for j in range(rho.shape[0])])
    return lam, c_run, i_f


def _worst_constant(t, rho_row, i_f, lam):
    if not np.isfinite(lam):
        return np.nan
    return float(np.max(rho_row[: i_f + 1] * np.exp(lam * t[: i_f + 1])))


@dataclass
class GainSetResult:
    """Per-run diagnostics of one gain set over a range of runs (arrays indexed by run)."""

    index: np.ndarray  #: run indices
    ok: np.ndarray  #: integrated without failure
    in_bound: np.ndarray  #: max |ω| ≤ ω_M on the output grid
    omega_peak: np.ndarray  #: max |ω| on the grid
    rho: np.ndarray  #: (N, T) E(t)/E(0)
    E0: np.ndarray  #: E(0)
    lam: np.ndarray  #: λ_run
    c_run: np.ndarray  #: c_run
    t_f: np.ndarray  #: t_f
    v_increase: np.ndarray  #: largest relative increase of V between output times (≤ 0: V never increased)
    steps: np.ndarray  #: accepted steps
    rejected: np.ndarray  #: rejected steps

    @staticmethod
    def concatenate(parts):
        return GainSetResult(
            **{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(GainSetResult)}
        )


def diagnose(campaign: Campaign, batch: BatchResult, indices, parallel: bool = True) -> GainSetResult:
    """Envelope, V and ω-bound diagnostics of a batch (module docstring): one compiled pass over ``batch.Y``,
    run by run (:func:`omegahat.campaigns.diagnostics.diagnose_runs`; Numba threads if ``parallel``,
    ``parallel=False`` stays on the calling thread, as in :func:`simulate_batch`). Its numbers are those of the NumPy
    reference :func:`_diagnose_numpy` to the last bit but for ``exp``, ``log`` and a non-diagonal ``J z``. A campaign
    (:func:`run_chunk`) takes the same diagnostics inside the kernel, run by run as runs end."""
    Y = np.ascontiguousarray(batch.Y, dtype=float)
    t = np.ascontiguousarray(batch.t, dtype=float)
    N, T = Y.shape[:2]
    rho = np.empty((N, T))
    out = np.empty((6, N))
    ok = np.empty(N, dtype=bool)
    kernel = diagnose_runs_parallel if parallel else diagnose_runs
    kernel(
        Y,
        campaign.references.shape[0],
        np.ascontiguousarray(campaign.J, dtype=float),
        t,
        float(campaign.rho_floor),
        np.ascontiguousarray(batch.ok, dtype=bool),
        rho,
        out,
        ok,
    )
    return _from_diagnostics(campaign, indices, batch.accepted, batch.rejected, ok, rho, out)


def _from_diagnostics(campaign, indices, accepted, rejected, ok, rho, out) -> GainSetResult:
    # out: the rows (E0, omega_peak, lam, c_run, t_f, v_increase) of omegahat.campaigns.diagnostics.diagnose_run
    E0, omega_peak, lam, c_run, t_f, v_increase = out
    return _result(
        campaign,
        indices,
        accepted,
        rejected,
        ok,
        omega_peak,
        rho=rho,
        E0=E0,
        lam=lam,
        c_run=c_run,
        t_f=t_f,
        v_increase=v_increase,
    )


def _result(campaign, indices, accepted, rejected, ok, omega_peak, **fields) -> GainSetResult:
    # what diagnose and its reference assemble alike: the run indices, the ω bound and the step counts
    return GainSetResult(
        index=np.asarray(indices, dtype=np.int64),
        ok=ok,
        in_bound=ok & (omega_peak <= campaign.omega_max),
        omega_peak=omega_peak,
        steps=accepted,
        rejected=rejected,
        **fields,
    )


def _diagnose_numpy(campaign: Campaign, batch: BatchResult, indices) -> GainSetResult:
    """The NumPy reference of :func:`diagnose` (slower: ~0.1 s per 1024 runs of 401 output times)."""
    n = campaign.references.shape[0]
    Y = batch.Y
    z = Y[:, :, 3 * n + 3 : 3 * n + 6]
    e = Y[:, :, 3 * n + 6 :].reshape(Y.shape[0], Y.shape[1], n, 3)
    w = Y[:, :, 3 * n : 3 * n + 3]
    e_norm = np.linalg.norm(e, axis=-1)
    E = np.linalg.norm(z, axis=-1) + e_norm.sum(axis=-1)
    E0 = E[:, 0]
    rho = E / E0[:, None]
    V = np.linalg.norm(z @ campaign.J.T, axis=-1) + 0.5 * (e_norm**2).sum(axis=-1)
    t = batch.t
    ok = batch.ok & np.all(np.isfinite(rho), axis=1)
    rho_safe = np.where(ok[:, None], rho, 1.0)
    lam, c_run, i_f = envelope_fit(t, rho_safe, campaign.rho_floor)
    # relative increases of V between consecutive output times, while ρ ≥ floor
    rel = (V[:, 1:] - V[:, :-1]) / V[:, :-1]
    checked = np.arange(1, t.size)[None, :] <= i_f[:, None]
    v_increase = np.where(checked & ok[:, None], rel, -np.inf).max(axis=1)
    omega_peak = np.where(ok, np.nanmax(np.linalg.norm(w, axis=-1), axis=1), np.nan)
    return _result(
        campaign,
        indices,
        batch.accepted,
        batch.rejected,
        ok,
        omega_peak,
        rho=rho,
        E0=E0,
        lam=np.where(ok, lam, np.nan),
        c_run=np.where(ok, c_run, np.nan),
        t_f=t[i_f],
        v_increase=v_increase,
    )


def run_chunk(campaign: Campaign, start: int, stop: int, parallel: bool = True) -> dict:
    """Runs ``start .. stop − 1`` of the campaign for every gain set: ``{gains name: GainSetResult}``.

    The unit of work of :func:`run_campaign` and of :mod:`omegahat.campaigns.distributed`; its result depends on the run
    indices only, not on how the campaign is cut into chunks nor on ``parallel`` (see :func:`simulate_batch`).
    The kernel diagnoses each run as it ends (:func:`omegahat.simulation.engine.integrate_diagnosed_lanes`): the
    same numbers as :func:`diagnose` on :func:`simulate_batch`'s states, without holding them.
    """
    if not (0 <= start < stop <= campaign.runs):
        raise ValueError(f"chunk [{start}, {stop}) is not inside the campaign's {campaign.runs} runs")
    indices = np.arange(start, stop)
    runs = _draw_runs(campaign, indices)  # once per run, whatever the number of gain sets
    # J and the references as a CoupledProblem stores them (as draw_problem + simulate_batch would use them)
    J, references = as_inertia(campaign.J), as_directions(campaign.references)
    workers = _workers(None)
    results = {}
    for name, gains in campaign.gains.items():
        Y0, body, torque, h0 = _kernel_inputs(J, references, gains, runs, campaign.h_max)
        rho, out, ok, acc, rej = integrate_diagnosed_lanes(
            Y0,
            campaign.t_out,
            *body,
            *torque,
            float(campaign.rtol),
            float(campaign.atol),
            h0,
            float(campaign.h_max),
            int(campaign.max_steps),
            workers,
            float(campaign.rho_floor),
            parallel=parallel,
        )
        results[name] = _from_diagnostics(campaign, indices, acc, rej, ok, rho, out)
    return results


def chunks(campaign: Campaign, chunk_size: int | None = None):
    """``(start, stop)`` pairs covering the campaign's runs."""
    size = campaign.chunk_size if chunk_size is None else int(chunk_size)
    if size < 1:
        raise ValueError(f"chunk_size must be at least 1; got {chunk_size!r}")
    return [(s, min(s + size, campaign.runs)) for s in range(0, campaign.runs, size)]


def merge(campaign: Campaign, parts) -> dict:
    """Chunk results (any order) into one ``{gains name: GainSetResult}`` ordered by run index."""
    merged = {}
    first = next(iter(campaign.gains))
    parts = sorted(parts, key=lambda p: int(p[first].index[0]))  # chunks are runs start..stop: concatenate in order
    for name in campaign.gains:
        merged[name] = GainSetResult.concatenate([p[name] for p in parts])
        if not np.array_equal(merged[name].index, np.arange(campaign.runs)):
            raise ValueError("chunk results do not cover every run exactly once")
    return merged


def run_campaign(campaign: Campaign, chunk_size: int | None = None, progress: bool = False) -> dict:
    """All runs of the campaign, chunk by chunk on this machine (Numba threads): ``{name: GainSetResult}``."""
    parts = []
    spans = chunks(campaign, chunk_size)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=campaign.runs, unit="run", desc="montecarlo")
    for start, stop in spans:
        parts.append(run_chunk(campaign, start, stop))
        if bar is not None:
            bar.update(stop - start)
    if bar is not None:
        bar.close()
    return merge(campaign, parts)


# --------------------------------------------------------------------------------------------------------------
# Summary
# --------------------------------------------------------------------------------------------------------------


def _float(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _counterexamples(campaign: Campaign, name: str, r: GainSetResult) -> list:
    rho_end = r.rho[:, -1]
    found = []  # (row of r, reasons)
    for j in range(r.index.size):
        reasons = []
        if not r.ok[j]:
            reasons.append("integration failed (non-finite state or step budget)")
        elif not r.in_bound[j]:
            continue  # set aside: the assumption |ω| ≤ ω_M does not hold
        else:
            if not rho_end[j] <= campaign.converged_below:
                reasons.append(f"not converged: rho(horizon) = {rho_end[j]:.3g} > {campaign.converged_below:g}")
            if r.v_increase[j] > campaign.v_increase_tol:
                reasons.append(f"V increased by {r.v_increase[j]:.3g} (relative) between two output times")
        if reasons:
            found.append((j, reasons))
    # the initial conditions of all counterexamples in one draw (those of draw_problem for each)
    d = _draw_runs(campaign, [r.index[j] for j, _ in found])
    out = []
    for row, (j, reasons) in enumerate(found):
        out.append(
            {
                "gains": name,
                "index": int(r.index[j]),
                "seed": {"entropy": int(campaign.seed), "spawn_key": [int(r.index[j])]},
                "reasons": reasons,
                "lambda_run": _float(r.lam[j]),
                "rho_end": _float(rho_end[j]),
                "omega0": d["omega0"][row].tolist(),
                "R0": d["R0"][row].tolist(),
                "r_hat0": d["r_hat0"][row].tolist(),
                "omega_hat0": d["omega_hat0"][row].tolist(),
                "torque": {
                    "amplitudes": d["amplitudes"][row].tolist(),
                    "frequencies": d["frequencies"][row].tolist(),
                    "phases": d["phases"][row].tolist(),
                },
            }
        )
    return out


def worst_envelope(campaign: Campaign, r: GainSetResult):
    """``(λ*, c*, index of the slowest run)`` over the in-bound runs (module docstring)."""
    use = r.in_bound & np.isfinite(r.lam)
    if not np.any(use):
        return math.nan, math.nan, -1
    lam_star = float(np.min(r.lam[use]))
    t = campaign.t_out
    masked = np.where(t[None, :] <= r.t_f[use][:, None], r.rho[use] * np.exp(lam_star * t)[None, :], 0.0)
    c_star = float(masked.max())
    slowest = int(r.index[use][np.argmin(r.lam[use])])
    return lam_star, c_star, slowest


def summarize(campaign: Campaign, results: dict) -> dict:
    """A JSON-ready summary: per gain set the envelope, counts, counterexamples and step statistics."""
    summary = {
        "runs": campaign.runs,
        "seed": campaign.seed,
        "horizon": campaign.horizon,
        "dt_out": campaign.dt_out,
        "rtol": campaign.rtol,
        "omega_max": campaign.omega_max,
        "J": campaign.J.tolist(),
        "references": campaign.references.tolist(),
        "rho_floor": campaign.rho_floor,
        "gain_sets": {},
    }
    for name, r in results.items():
        g = campaign.gains[name]
        check = check_gains(g, campaign.J, campaign.omega_max, campaign.references, warn=False)
        lam_star, c_star, slowest = worst_envelope(campaign, r)
        use = r.in_bound & np.isfinite(r.lam)
        cex = _counterexamples(campaign, name, r)
        summary["gain_sets"][name] = {
            "k": g.k.tolist(),
            "l_offset": g.l_offset.tolist(),
            "l_slope": g.l_slope.tolist(),
            "satisfies_theorem": check.ok,
            "runs_integrated": int(r.ok.sum()),
            "runs_failed": int((~r.ok).sum()),
            "runs_out_of_bound": int((r.ok & ~r.in_bound).sum()),
            "runs_used": int(use.sum()),
            "worst_lambda": _float(lam_star),
            "worst_c": _float(c_star),
            "slowest_run": slowest,
            "lambda_quantiles": {
                q: _float(np.quantile(r.lam[use], float(q))) if use.any() else None for q in ("0.01", "0.5", "0.99")
            },
            "max_c_run": _float(np.max(r.c_run[use])) if use.any() else None,
            "v_increased_runs": int((use & (r.v_increase > campaign.v_increase_tol)).sum()),
            "not_converged_runs": int((use & ~(r.rho[:, -1] <= campaign.converged_below)).sum()),
            "counterexamples": len(cex),
            "counterexample_list": cex,
            "accepted_steps": int(r.steps.sum()),
            "rejected_steps": int(r.rejected.sum()),
        }
    return summary


# --------------------------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------------------------


def plot_envelopes(campaign: Campaign, results: dict, summary: dict, max_lines: int = 100):
    """One panel per gain set: ρ(t) of up to ``max_lines`` in-bound runs, the pointwise worst ρ over all of them
    and the envelope ``c* e^{−λ* t}`` (log scale). Returns the figure."""
    import matplotlib.pyplot as plt

    names = list(results)
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 4.2), squeeze=False)
    t = campaign.t_out
    for ax, name in zip(axes[0], names, strict=True):
        r = results[name]
        s = summary["gain_sets"][name]
        use = np.flatnonzero(r.in_bound)
        floor = campaign.rho_floor * 1e-2
        for j in use[:max_lines]:
            ax.semilogy(t, np.maximum(r.rho[j], floor), color="0.6", lw=0.5, alpha=0.6)
        if use.size:
            ax.semilogy(t, np.maximum(r.rho[use].max(axis=0), floor), color="C3", lw=1.5, label="worst ρ(t)")
        if s["worst_lambda"] is not None:
            env = s["worst_c"] * np.exp(-s["worst_lambda"] * t)
            ax.semilogy(
                t,
                np.maximum(env, floor),
                "k--",
                lw=1.2,
                label=f"c* e^(-λ* t): c* = {s['worst_c']:.3g}, λ* = {s['worst_lambda']:.3g}/s",
            )
        ax.axhline(campaign.rho_floor, color="C0", lw=0.8, ls=":", label="ρ floor")
        ax.set_ylim(floor, None)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("(|z| + Σ|e_i|) / initial")
        ax.set_title(f"{name}: {s['runs_used']} runs")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_rates(campaign: Campaign, results: dict):
    """Histogram of the per-run rates λ_run, one colour per gain set. Returns the figure."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, r in results.items():
        lam = r.lam[r.in_bound & np.isfinite(r.lam)]
        if lam.size:
            ax.hist(lam, bins=60, alpha=0.6, label=f"{name} (min {lam.min():.3g}/s)")
    ax.set_xlabel("λ_run (1/s)")
    ax.set_ylabel("runs")
    ax.legend()
    fig.tight_layout()
    return fig


def write_outputs(campaign: Campaign, results: dict, out_dir) -> dict:
    """Write ``summary.json``, ``counterexamples.json``, ``envelopes.png`` and ``rates.png``; return the summary
    (without the counterexample lists, which are in their own file)."""
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(campaign, results)
    cex = {name: s.pop("counterexample_list") for name, s in summary["gain_sets"].items()}
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "counterexamples.json").write_text(json.dumps(cex, indent=2) + "\n")
    full = {**summary, "gain_sets": {n: {**s, "counterexample_list": cex[n]} for n, s in summary["gain_sets"].items()}}
    fig = plot_envelopes(campaign, results, full)
    fig.savefig(out / "envelopes.png", dpi=120)
    plt.close(fig)
    fig = plot_rates(campaign, results)
    fig.savefig(out / "rates.png", dpi=120)
    plt.close(fig)
    return summary


# --------------------------------------------------------------------------------------------------------------
# Configuration (TOML)
# --------------------------------------------------------------------------------------------------------------

_SECTIONS = {
    "campaign": {
        "runs": "runs",
        "seed": "seed",
        "chunk_size": "chunk_size",
        "horizon": "horizon",
        "dt_out": "dt_out",
        "rtol": "rtol",
        "atol": "atol",
        "h_max": "h_max",
        "max_steps": "max_steps",
        "rho_floor": "rho_floor",
        "converged_below": "converged_below",
        "v_increase_tol": "v_increase_tol",
    },
    "body": {"J": "J", "references": "references", "omega_max": "omega_max"},
    "initial": {
        "omega0_fraction": "omega0_fraction",
        "r_hat_radius": "r_hat_radius",
        "p_zero": "p_zero",
        "p_opposite": "p_opposite",
        "omega_hat_max": "omega_hat_max",
    },
    "torque": {"terms": "torque_terms", "amplitude": "torque_amplitude", "frequency": "torque_frequency"},
}
_INTEGER = {"runs", "seed", "chunk_size", "max_steps", "torque_terms"}
# (lower, lower inclusive, upper, upper inclusive) for scalar settings
_RANGES = {
    "runs": (1, True, math.inf, False),
    "seed": (0, True, math.inf, False),
    "chunk_size": (1, True, math.inf, False),
    "max_steps": (1, True, math.inf, False),
    "horizon": (0, False, math.inf, False),
    "dt_out": (0, False, math.inf, False),
    "rtol": (0, False, 1, False),
    "atol": (0, False, math.inf, False),
    "h_max": (0, False, math.inf, False),
    "rho_floor": (0, False, 1, False),
    "converged_below": (0, False, 1, False),
    "v_increase_tol": (0, True, math.inf, False),
    "omega_max": (0, False, math.inf, False),
    "omega0_fraction": (0, True, 1, True),
    "r_hat_radius": (0, True, math.inf, False),
    "p_zero": (0, True, 1, True),
    "p_opposite": (0, True, 1, True),
    "omega_hat_max": (0, True, math.inf, False),
    "torque_terms": (0, True, math.inf, False),
    "torque_amplitude": (0, True, math.inf, False),
}
_GAIN_KEYS = {
    "theorem": {"kind", "margin", "l0"},
    "constant": {"kind", "k", "l"},
    "affine": {"kind", "k", "l_offset", "l_slope"},
}


def _check_number(key: str, attr: str, where: str, value, integer: bool) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{where}: {key} must be a number; got {value!r}")
    if integer and not isinstance(value, int):
        raise ValueError(f"{where}: {key} must be an integer; got {value!r}")
    lo, lo_in, hi, hi_in = _RANGES.get(attr, (-math.inf, False, math.inf, False))
    ok = math.isfinite(value) and (value >= lo if lo_in else value > lo) and (value <= hi if hi_in else value < hi)
    if not ok:
        lo_s = ("[" if lo_in else "(") + f"{lo:g}"
        hi_s = f"{hi:g}" + ("]" if hi_in else ")")
        raise ValueError(f"{where}: {key} = {value!r} is out of range {lo_s}, {hi_s}")
    return value


def _gains_from_table(name: str, table: dict, J, omega_max, references) -> ObserverGains:
    where = f"[gains.{name}]"
    if not isinstance(table, dict):
        raise ValueError(f"{where} must be a table; got {table!r}")
    kind = table.get("kind")
    if kind not in _GAIN_KEYS:
        raise ValueError(f"{where}: kind must be one of {sorted(_GAIN_KEYS)}; got {kind!r}")
    unknown = set(table) - _GAIN_KEYS[kind]
    if unknown:
        raise ValueError(
            f"{where}: unknown key(s) {sorted(unknown)} for kind {kind!r}; allowed: {sorted(_GAIN_KEYS[kind])}"
        )
    try:
        if kind == "theorem":
            return theorem_gains(J, omega_max, references, margin=table.get("margin", 1.0), l0=table.get("l0", 1.0))
        n = references.shape[0]
        if kind == "constant":
            return ObserverGains.constant(table["k"], table["l"], n=n)
        k = np.broadcast_to(np.asarray(table["k"], dtype=float), (n,)).copy()
        return ObserverGains(k=k, l_offset=table["l_offset"], l_slope=table.get("l_slope", 0.0))
    except KeyError as exc:
        raise ValueError(f"{where}: missing key {exc.args[0]!r}") from None
    except (ValueError, TypeError) as exc:
        raise ValueError(f"{where}: {exc}") from None


def campaign_from_dict(config: dict, source: str = "config") -> Campaign:
    """Build a :class:`Campaign` from a parsed TOML document; errors name the section, key and value."""
    unknown = set(config) - set(_SECTIONS) - {"gains"}
    if unknown:
        raise ValueError(f"{source}: unknown section(s) {sorted(unknown)}; allowed: {[*_SECTIONS, 'gains']}")
    kwargs = {}
    for section, keys in _SECTIONS.items():
        table = config.get(section, {})
        if not isinstance(table, dict):
            raise ValueError(f"{source}: [{section}] must be a table; got {table!r}")
        bad = set(table) - set(keys)
        if bad:
            raise ValueError(f"{source}: unknown key(s) {sorted(bad)} in [{section}]; allowed: {sorted(keys)}")
        for key, value in table.items():
            attr = keys[key]
            where = f"{source} [{section}]"
            if attr in ("J", "references"):
                try:
                    kwargs[attr] = as_inertia(value, "J") if attr == "J" else as_directions(value)
                except (ValueError, TypeError) as exc:
                    raise ValueError(f"{where}: {key} = {value!r}: {exc}") from None
            elif attr == "torque_frequency":
                if (
                    not isinstance(value, list)
                    or len(value) != 2
                    or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
                    or not 0 < value[0] <= value[1]
                    or not math.isfinite(value[1])
                ):
                    raise ValueError(f"{where}: frequency must be [low, high] with 0 < low <= high; got {value!r}")
                kwargs[attr] = (float(value[0]), float(value[1]))
            else:
                num = _check_number(key, attr, where, value, attr in _INTEGER)
                kwargs[attr] = num if attr in _INTEGER else float(num)
    if "omega_max" not in kwargs:
        raise ValueError(f"{source}: [body] omega_max is required (the bound |omega| <= omega_M of the theorem)")
    if kwargs.get("p_zero", 0.05) + kwargs.get("p_opposite", 0.05) > 1:
        raise ValueError(
            f"{source} [initial]: p_zero + p_opposite must not exceed 1; got "
            f"{kwargs.get('p_zero', 0.05)} + {kwargs.get('p_opposite', 0.05)}"
        )
    J = kwargs.setdefault("J", np.diag([3.0, 2.0, 1.0]))
    refs = kwargs.setdefault("references", np.eye(3)[:2])
    gains_table = config.get("gains")
    if not isinstance(gains_table, dict) or not gains_table:
        raise ValueError(
            f'{source}: at least one [gains.NAME] table is required (kind = "theorem", "constant" or "affine")'
        )
    kwargs["gains"] = {
        name: _gains_from_table(name, t, J, kwargs["omega_max"], refs) for name, t in gains_table.items()
    }
    return Campaign(**kwargs)


def campaign_from_toml(text: str, source: str = "config") -> Campaign:
    """Parse TOML text; a syntax error is reported with its line and column."""
    try:
        config = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{source}: invalid TOML: {exc}") from None
    return campaign_from_dict(config, source)


def load_campaign(path) -> Campaign:
    """Read a campaign from a TOML file (see ``examples/campaign.toml``)."""
    path = Path(path)
    return campaign_from_toml(path.read_text(), str(path))


def replace(campaign: Campaign, **changes) -> Campaign:
    """A copy of ``campaign`` with some settings changed (``dataclasses.replace``)."""
    return dataclasses.replace(campaign, **changes)
