r"""How an angular-velocity estimate is scored against the truth, defined once for every caller.

For an estimate sampled at times ``t_k`` with error ``e_k = |ω̂(t_k) − ω(t_k)|`` (rad/s) and a tolerance ε::

    convergence time   t_c = min { t_k : e_j ≤ ε for every j ≥ k }                                 (S1)
    first below        t_b = min { t_k : e_k ≤ ε }                                                 (S2)
    steady RMS         s   = √( mean_{t_k ≥ t_0} e_k² )                                            (S3)

Conventions, the same in all three:

* a **NaN** error means *no estimate at that sample* (differencing needs neighbours, the spline stops at the ends,
  a method may not output anything around a gap): those samples are left out of (S1)–(S3), neither above nor
  below the tolerance;
* an **infinite** error means *diverged* (a recursive estimator whose output stopped being finite): above any
  tolerance, and it makes (S3) infinite. :func:`estimate_errors` gives these errors from an estimate, and turns
  any non-finite output of a method that always estimates into that infinite error;
* *never* is ``inf``: an error that is still above ε at the last sample with an estimate never converged
  (``t_c = inf``), one that never reaches ε has ``t_b = inf``, and a record without any estimate has ``t_c = inf``;
  (S3) over no estimate at all is NaN (nothing to average).

(S1) is the last crossing: ``t_c`` is the sample after the last one above ε (the first sample with an estimate
when none is above), so an error that dips below ε and comes back does not count as converged until it stays.
Used by ``omegahat compare`` (:mod:`omegahat.lab.evaluation.comparison`), the gain sweep
(:mod:`omegahat.lab.gain_sweep`: ``t_c`` with ε a fraction of the initial error) and ``omegahat paper``
(the time after which ``|ω̂ − ω|`` stays at or below 1e-3).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from omegahat.interface import Estimate, Status

__all__ = ["convergence_time", "estimate_errors", "first_below", "steady_rms"]


def estimate_errors(estimate: ArrayLike | Estimate, truth: ArrayLike, *, always_estimates: bool = False) -> np.ndarray:
    """``e_k = |ω̂_k − ω_k|`` for ``(T, 3)`` arrays: NaN where a row of ``estimate`` holds a NaN (no estimate), inf
    where it holds an inf (diverged). For a method that ``always_estimates`` (a recursive filter) every
    non-finite row is divergence: inf, but where an :class:`omegahat.interface.Estimate`'s status says there is
    no estimate yet (``unavailable``: NaN)."""
    status = None
    if isinstance(estimate, Estimate):
        estimate, status = estimate
    estimate = np.asarray(estimate, dtype=float)
    err = np.linalg.norm(estimate - np.asarray(truth, dtype=float), axis=-1)
    if always_estimates:
        err = np.where(np.all(np.isfinite(estimate), axis=-1), err, np.inf)
    if status is not None:
        err[np.asarray(status) == Status.UNAVAILABLE] = np.nan
    return err


def convergence_time(t: ArrayLike, err: ArrayLike, tol: float) -> float:
    """(S1): the first sample time after which ``err`` stays ≤ ``tol``; ``inf`` if never (module docstring:
    NaN rows are left out, inf rows are above any tolerance)."""
    t = np.asarray(t, dtype=float)
    err = np.asarray(err, dtype=float)
    ok = ~np.isnan(err)
    if not ok.any():
        return math.inf
    bad = np.flatnonzero(ok & (err > tol))
    if bad.size == 0:
        return float(t[np.flatnonzero(ok)[0]])
    after = np.flatnonzero(ok & (np.arange(t.size) > bad[-1]))
    return float(t[after[0]]) if after.size else math.inf


def first_below(t: ArrayLike, err: ArrayLike, tol: float) -> float:
    """(S2): the first sample time at which ``err`` ≤ ``tol`` (``inf`` if never): how fast the initial error is
    removed, whether or not the noise floor lets it stay below (that is :func:`convergence_time`)."""
    hit = np.flatnonzero(np.asarray(err, dtype=float) <= tol)
    return float(np.asarray(t, dtype=float)[hit[0]]) if hit.size else math.inf


def steady_rms(t: ArrayLike, err: ArrayLike, t0: float) -> float:
    """(S3): the RMS of ``err`` over ``t ≥ t0``, NaN rows left out; ``inf`` if the method diverged there, NaN if
    no sample there has an estimate."""
    err = np.asarray(err, dtype=float)
    m = (np.asarray(t, dtype=float) >= t0) & ~np.isnan(err)
    return float(np.sqrt(np.mean(err[m] ** 2))) if m.any() else math.nan
