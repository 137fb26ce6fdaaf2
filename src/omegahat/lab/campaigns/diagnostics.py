r"""Per-run diagnostics of a campaign: the envelope ratio ρ, V, the peak of |ω| and the envelope fit.

For one run's states on the output grid ``t_k`` (the engine's layout ``[r (3n), ω, z, e (3n)]``),
:func:`diagnose_run` computes what :mod:`omegahat.lab.campaigns` defines: ``E = |z| + Σ|e_i|``, ``ρ = E/E(0)``,
``V = |J z| + ½ Σ|e_i|²``, the largest |ω|, the last output time ``t_f`` with ``ρ ≥ rho_floor``,
``λ_run = −ln ρ(t_f)/t_f``, ``c_run = max_{t_k ≤ t_f} ρ e^{λ_run t_k}`` and the largest relative increase of V
between consecutive output times up to ``t_f``. It is compiled, and performs the floating-point operations of
the NumPy reference :func:`diagnose_reference` in its order (norms as ((x0² + x1²) + x2²), sums over i from the
first term, J z row by row as ((z0 J_i0 + z1 J_i1) + z2 J_i2)); only exp, log and BLAS's J z (a non-diagonal J)
may differ from NumPy's in the last bit (``tests/test_montecarlo.py``).

A campaign has the engine call it on a run's states as soon as the run ends (:func:`integrate_diagnosed`: the
run's states stay in the worker's own rows, in cache), so that it never holds more than the runs in flight;
:func:`diagnose` does the same on a batch's states.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike

from omegahat.lab.campaigns.config import Campaign
from omegahat.simulation.coupled import BatchResult
from omegahat.simulation.envelope import diagnose_run

__all__ = [
    "GainSetResult",
    "diagnose",
    "diagnose_reference",
    "diagnose_runs",
    "diagnose_runs_parallel",
    "envelope_fit",
    "result_from_diagnostics",
]


@numba.njit(cache=True, error_model="numpy")
def diagnose_runs(Y, n, J, t, rho_floor, batch_ok, rho, out, ok):
    """:func:`diagnose_run` for every run of ``Y (N, T, m)`` (``batch_ok (N,)``), on the calling thread."""
    for j in range(Y.shape[0]):
        diagnose_run(Y[j], j, n, J, t, rho_floor, batch_ok[j], rho, out, ok, np.empty(Y.shape[1]))


@numba.njit(cache=True, parallel=True, error_model="numpy")
def diagnose_runs_parallel(Y, n, J, t, rho_floor, batch_ok, rho, out, ok):
    """:func:`diagnose_runs` on Numba's threads."""
    for j in numba.prange(Y.shape[0]):
        diagnose_run(Y[j], j, n, J, t, rho_floor, batch_ok[j], rho, out, ok, np.empty(Y.shape[1]))


def envelope_fit(t: np.ndarray, rho: ArrayLike, rho_floor: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    def concatenate(parts: Sequence[GainSetResult]) -> GainSetResult:
        return GainSetResult(
            **{f.name: np.concatenate([getattr(p, f.name) for p in parts]) for f in dataclasses.fields(GainSetResult)}
        )


def diagnose(campaign: Campaign, batch: BatchResult, indices: ArrayLike, parallel: bool = True) -> GainSetResult:
    """Envelope, V and ω-bound diagnostics of a batch (module docstring): one compiled pass over ``batch.Y``,
    run by run (:func:`diagnose_runs`; Numba threads if ``parallel``, ``parallel=False`` stays on the calling
    thread, as in :func:`omegahat.simulation.simulate_batch`). Its numbers are those of the NumPy reference
    :func:`diagnose_reference` to the last bit but for ``exp``, ``log`` and a non-diagonal ``J z``. A campaign
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
    return result_from_diagnostics(campaign, indices, batch.accepted, batch.rejected, ok, rho, out)


def result_from_diagnostics(
    campaign: Campaign,
    indices: ArrayLike,
    accepted: np.ndarray,
    rejected: np.ndarray,
    ok: np.ndarray,
    rho: np.ndarray,
    out: np.ndarray,
) -> GainSetResult:
    # out: the rows (E0, omega_peak, lam, c_run, t_f, v_increase) of omegahat.lab.campaigns.diagnostics.diagnose_run
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


def diagnose_reference(campaign: Campaign, batch: BatchResult, indices: ArrayLike) -> GainSetResult:
    """The NumPy reference of :func:`diagnose`, written with whole-array operations (slower)."""
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
