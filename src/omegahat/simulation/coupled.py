r"""Simulate plant and observer together: one run, many runs, and an independent reference.

* :func:`simulate` — one :class:`~omegahat.simulation.problem.CoupledProblem`, on one lane of the lockstep
  engine (:mod:`omegahat.simulation.engine`: ETDRK4 in error coordinates, adaptive steps, the stiff decay
  integrated exactly, a continuous extension at the output times);
* :func:`simulate_batch` — many problems sharing J, gains and references, on the same engine with ``LANES``
  lanes per thread; every run is bit for bit what :func:`simulate` gives for it;
* :func:`simulate_reference` — the same coupled system in the observer's own coordinates ``(r_i, ω, ξ, r̂_i)``,
  right-hand side :func:`omegahat.observer.continuous.observer_rhs` (the paper's equations, plain NumPy),
  integrated by ``scipy.integrate.solve_ivp``: slow, independent of the engine, its test oracle.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import ArrayLike
from scipy.integrate import solve_ivp

from omegahat import so3
from omegahat.observer import continuous as sarras
from omegahat.simulation.engine import LANES, StepControl, integrate_states
from omegahat.simulation.problem import (
    CoupledProblem,
    CoupledTrajectory,
    batch_inputs,
    trajectory_from_states,
)

__all__ = ["BatchResult", "output_times", "simulate", "simulate_batch", "simulate_reference"]


def output_times(horizon: float, dt_out: float) -> np.ndarray:
    """``0, dt_out, 2 dt_out, …`` up to ``horizon`` (which is appended when it is not on the grid)."""
    if not (np.isfinite(horizon) and horizon > 0):
        raise ValueError(f"horizon must be positive and finite; got {horizon!r}")
    if not (np.isfinite(dt_out) and dt_out > 0):
        raise ValueError(f"dt_out must be positive and finite; got {dt_out!r}")
    count = round(horizon / dt_out)
    t_out = np.linspace(0.0, count * dt_out, count + 1)
    return np.append(t_out, horizon) if t_out[-1] < horizon else t_out


def _checked_times(t_out: ArrayLike) -> np.ndarray:
    t_out = np.asarray(t_out, dtype=float)
    if t_out.ndim != 1 or t_out.size < 1 or t_out[0] != 0.0 or np.any(np.diff(t_out) <= 0):
        raise ValueError("t_out must start at 0 and increase strictly")
    return t_out


def simulate(
    problem: CoupledProblem,
    horizon: float = 10.0,
    dt_out: float = 1e-3,
    t_out: ArrayLike | None = None,
    rtol: float = 1e-9,
    atol: float = 1e-15,
    h_max: float = 0.05,
    max_steps: int = 10_000_000,
) -> CoupledTrajectory:
    """Simulate plant and observer from t = 0 and sample them at ``t_out`` (default every ``dt_out`` to horizon).

    One lane of the lockstep engine (ETDRK4 in error coordinates, adaptive steps, module docstring). ``rtol``/
    ``atol`` bound the local error of each block ``(r_i, ω, z, e_i)`` relative to its size; the default
    reproduces ``|ω̂ − ω|`` of the paper's run at 0.5, 1 and 2 s to better than 1e-8 relative of a DOP853
    reference at rtol 1e-13 (``tests/test_simulate.py``). Output times inside a step are filled by its
    continuous extension (order 3), so a dense ``t_out`` costs no extra steps.

    Parameters
    ----------
    problem : CoupledProblem
        The body, its measured directions, the observer and the initial conditions.
    horizon : float, optional
        The final time (s) of the default output grid.
    dt_out : float, optional
        The spacing (s) of the default output grid ``0, dt_out, 2 dt_out, …`` up to ``horizon`` (which is
        appended when it is not on the grid).
    t_out : array_like, optional
        The output times (s), starting at 0 and strictly increasing; given, they replace ``horizon`` and
        ``dt_out``.
    rtol, atol : float, optional
        Relative and absolute bounds of the local error of each block.
    h_max : float, optional
        The longest step (s).
    max_steps : int, optional
        The most steps (accepted and rejected) before the run stops.

    Returns
    -------
    CoupledTrajectory
        The samples at the output times: ``t``, ``omega``, ``omega_hat``, ``r``, ``r_hat``, ``xi``, ``z``, ``e``,
        the accepted and rejected ``steps``, and the errors ``error`` (``|ω̂ − ω|``) and ``filter_error``.

    Raises
    ------
    ValueError
        If ``horizon`` or ``dt_out`` is not positive and finite, or ``t_out`` does not start at 0 and increase
        strictly.
    RuntimeError
        If the run stops (``max_steps`` reached or the state became non-finite).

    Examples
    --------
    The paper's run: the estimate converges to the true rate.

    >>> from omegahat import paper_problem, simulate
    >>> trajectory = simulate(paper_problem(), horizon=2.0, dt_out=0.5)
    >>> print(trajectory.t.tolist(), trajectory.omega_hat.shape)
    [0.0, 0.5, 1.0, 1.5, 2.0] (5, 3)
    >>> print(" ".join(f"{e:.2e}" for e in trajectory.error))  # |ω̂ − ω|
    2.32e+00 1.81e-01 1.42e-02 1.27e-03 1.08e-04
    """
    t_out = _checked_times(output_times(horizon, dt_out) if t_out is None else t_out)
    model, runs = batch_inputs([problem], h_max)
    out = integrate_states(model, runs, t_out, StepControl(rtol, atol, h_max, max_steps), lanes=1)
    if not out.ok[0]:
        raise RuntimeError(
            f"simulation stopped at t = {t_out[np.argmax(np.isnan(out.Y[0, :, 0]))]:.6g} s after "
            f"{out.accepted[0] + out.rejected[0]} steps (max_steps reached or the state became non-finite)"
        )
    return trajectory_from_states(problem, t_out, out.Y[0], out.accepted[0], out.rejected[0])


@dataclass(frozen=True)
class BatchResult:
    """States of ``N`` runs at the output times: ``Y (N, T, 6n + 6)`` in the engine's layout
    ``[r (3n), ω, z, e (3n)]``; accepted and rejected steps ``(N,)``; ``ok (N,)`` False where a run failed."""

    t: np.ndarray
    Y: np.ndarray
    accepted: np.ndarray
    rejected: np.ndarray
    ok: np.ndarray


def simulate_batch(
    problems: Iterable[CoupledProblem],
    t_out: ArrayLike,
    rtol: float = 1e-9,
    atol: float = 1e-15,
    h_max: float = 0.05,
    max_steps: int = 10_000_000,
    n_workers: int | None = None,
    parallel: bool = True,
) -> BatchResult:
    """Integrate many problems sharing J, gains and references on the lockstep engine.

    Each run equals ``simulate(problem, t_out=t_out, ...)`` bit for bit. ``parallel=True``: ``n_workers`` threads
    (default: Numba's thread count), ``LANES`` runs each in lockstep. ``parallel=False``: all on the calling
    thread, for callers that parallelise themselves (Dask workers running several tasks in threads; Numba's
    default threading layer must not be entered from two threads at once). A failed run does not raise: its
    ``ok`` is False and its rows after the failure are NaN.

    Parameters
    ----------
    problems : iterable of CoupledProblem
        The runs (:class:`~omegahat.simulation.problem.CoupledProblem` sharing J, gains and references; each its
        own initial state and torque).
    t_out : array_like
        The output times (s), starting at 0 and strictly increasing.
    rtol, atol : float, optional
        Relative and absolute bounds of the local error of each block ``(r_i, ω, z, e_i)``, as in :func:`simulate`.
    h_max : float, optional
        The longest step (s).
    max_steps : int, optional
        The most steps of a run before it fails.
    n_workers : int, optional
        Threads for ``parallel=True`` (at least 1; default: Numba's thread count).
    parallel : bool, optional
        Run on ``n_workers`` threads (True) or all on the calling thread (False).

    Returns
    -------
    BatchResult
        ``t``; the states ``Y (N, T, 6n + 6)`` in the engine's layout ``[r (3n), ω, z, e (3n)]``; accepted and
        rejected steps ``(N,)``; ``ok (N,)``, False where a run failed.

    Raises
    ------
    ValueError
        If there is no problem, the problems differ in J, gains or references, ``t_out`` does not start at 0 and
        increase strictly, or ``n_workers`` is less than 1.

    Examples
    --------
    The paper's problem without torque and with two constant torques; ``z = ω̂ − ω`` is ``Y[..., 9:12]``
    for two directions:

    >>> import numpy as np
    >>> from omegahat import paper_problem, simulate, simulate_batch
    >>> problems = [paper_problem(), paper_problem([0.1, 0.0, 0.0]), paper_problem([0.0, 0.2, 0.0])]
    >>> batch = simulate_batch(problems, t_out=[0.0, 1.0, 2.0])
    >>> print(batch.Y.shape, batch.ok.tolist())
    (3, 3, 18) [True, True, True]
    >>> print(np.array_equal(batch.Y[1, :, 9:12], simulate(problems[1], t_out=[0.0, 1.0, 2.0]).z))
    True
    """
    t_out = _checked_times(t_out)
    workers = numba.get_num_threads() if n_workers is None else int(n_workers)
    if workers < 1:
        raise ValueError(f"n_workers must be at least 1; got {n_workers!r}")
    model, runs = batch_inputs(problems, h_max)
    control = StepControl(rtol, atol, h_max, max_steps)
    out = integrate_states(model, runs, t_out, control, workers, LANES, parallel)
    return BatchResult(t=t_out, Y=out.Y, accepted=out.accepted, rejected=out.rejected, ok=out.ok)


def simulate_reference(
    problem: CoupledProblem,
    t_eval: ArrayLike,
    method: str = "Radau",
    rtol: float = 1e-10,
    atol: float = 1e-14,
    output_sign: float = sarras.OUTPUT_SIGN_CORRECTED,
) -> CoupledTrajectory:
    """The same coupled system in the observer's own coordinates ``(r_i, ω, ξ, r̂_i)``, right-hand side
    :func:`omegahat.observer.continuous.observer_rhs` term by term, integrated by ``scipy.integrate.solve_ivp``.

    Slow; it is the independent reference for :func:`simulate`, and with ``output_sign=OUTPUT_SIGN_PRINTED``
    it simulates the paper's printed (wrong) output map. ξ₀ is chosen for ω̂₀ under the chosen output map.
    """
    n = problem.gains.n
    J = problem.J
    Jinv = np.linalg.inv(J)
    g = problem.gains
    tq = problem.torque
    r0 = problem.r0
    xi0 = sarras.xi_for_omega_hat(problem.omega_hat0, r0, problem.r_hat0, g.k, Jinv, output_sign)

    def rhs(t, y):
        r = y[: 3 * n].reshape(n, 3)
        w = y[3 * n : 3 * n + 3]
        xi = y[3 * n + 3 : 3 * n + 6]
        r_hat = y[3 * n + 6 :].reshape(n, 3)
        tau = tq(t)
        r_dot = so3.cross(r, w)
        w_dot = Jinv @ (so3.cross(J @ w, w) + tau)
        xi_dot, r_hat_dot = sarras.observer_rhs(
            xi, r_hat, r, tau, J, Jinv, g.k, g.l_offset, g.l_slope, sign=output_sign
        )
        return np.concatenate([r_dot.ravel(), w_dot, xi_dot, r_hat_dot.ravel()])

    t_eval = np.asarray(t_eval, dtype=float)
    y0 = np.concatenate([r0.ravel(), problem.omega0, xi0, problem.r_hat0.ravel()])
    sol = solve_ivp(rhs, (0.0, float(t_eval[-1])), y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval)
    if not sol.success:
        raise RuntimeError(f"solve_ivp({method}) failed: {sol.message}")
    Y = sol.y.T
    r = Y[:, : 3 * n].reshape(-1, n, 3)
    omega = Y[:, 3 * n : 3 * n + 3]
    xi = Y[:, 3 * n + 3 : 3 * n + 6]
    r_hat = Y[:, 3 * n + 6 :].reshape(-1, n, 3)
    omega_hat = xi + output_sign * np.einsum("ij,tj->ti", Jinv, np.einsum("i,tia->ta", g.k, so3.cross(r, r_hat)))
    return CoupledTrajectory(
        t=sol.t,
        omega=omega,
        omega_hat=omega_hat,
        r=r,
        r_hat=r_hat,
        xi=xi,
        z=omega_hat - omega,
        e=r_hat - r,
        steps=int(sol.nfev),
        rejected=0,
    )
