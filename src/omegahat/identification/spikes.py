r"""Isolated spikes of an attitude log: samples that leave both neighbours, which agree with each other.

A marker swap or a misread frame of a motion-capture system puts one sample far from the body's attitude and the
next one back on it. To the identification's passes (:mod:`omegahat.identification.likelihood`) such a sample is
an innovation of thousands of standard deviations at any noise. The filters it kicks turn more than half a
revolution per step and lock onto an alias of the rate, which the samples cannot tell from the rate itself, and
the likelihood of every model collapses (``docs/theory/identification.md``, "Spikes and aliases", measures it).
The identification therefore leaves them out, and says so; ``omegahat estimate`` treats them as missing samples
(:class:`omegahat.io.pipeline.TurnScreen`), while an estimator given arrays directly reads them (the supervisor
restarts its filter, differencing's two intervals there are wrong). Faults longer than one sample are the
likelihood passes' to survive (:func:`omegahat.identification.likelihood.innovation_sums` ends a pass that follows
an alias).

With ``d(i, j)`` the angle between ``R_i`` and ``R_j``, a sample ``k`` whose neighbours ``k − 1`` and ``k + 1`` are
valid is an isolated spike where its detour ::

    s_k = min(d(k − 1, k), d(k, k + 1))                                                                  (P1)

exceeds :data:`ISOLATION` times each of ``d(k − 1, k + 1)``, ``d(k − 2, k − 1)`` and ``d(k + 1, k + 2)`` (those
present), and :data:`SCALE` times the log's median step ``d(j − 1, j)``. The first test is what makes a spike
isolated: any motion, even a bounce that reverses the turn within one step, moves the samples around ``k`` about
as far as it moves ``k`` itself (the steps before and after a reversal are the turn's), and a sample far from both
neighbours while they are close together is one the body did not take. The second keeps noise out: for a body at
rest the steps are ``√2 σ`` times a chi variable of 3 degrees of freedom (median 1.54), so a detour of
``SCALE`` median steps is ``43 σ`` or more, which Gaussian noise does not reach.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from omegahat import so3

__all__ = ["ISOLATION", "SCALE", "Spikes", "describe_spikes", "isolated_spikes", "judged_spikes"]

ISOLATION = 4.0  #: a spike's detour is at least this many times its neighbours' steps (P1)
SCALE = 20.0  #: and at least this many times the log's median step (P1)


class Spikes(NamedTuple):
    """The isolated spikes of a log: their samples (indices) and their detours ``s_k`` (rad), in the log's order."""

    samples: np.ndarray
    detour: np.ndarray

    def skipped(self, increments: np.ndarray, valid: np.ndarray) -> np.ndarray:
        """The increments ``φ (N − 1, 3)`` between consecutive samples of ``valid`` (which leaves the spikes out)
        with NaN where one spans a spike: two steps' turn, which differencing's account (D1) would read as one's."""
        kept = np.flatnonzero(valid)
        spans = np.searchsorted(self.samples, kept[:-1]) != np.searchsorted(self.samples, kept[1:])
        return np.where(spans[:, None], np.nan, increments)


def isolated_spikes(R: np.ndarray, valid: np.ndarray) -> Spikes:
    """(P1) on the attitudes ``R (T, 3, 3)`` (body → inertial), ``valid (T,)`` the usable samples (module
    docstring)."""
    Rv = np.where(valid[:, None, None], R, np.nan)
    step = so3.angle(Rv[:-1], Rv[1:])
    typical = float(np.nanmedian(step)) if np.isfinite(step).any() else 0.0
    return judged_spikes(step, lambda k: so3.angle(Rv[k - 1], Rv[k + 1]), typical)


def judged_spikes(
    step: np.ndarray,
    across: Callable[[np.ndarray], np.ndarray],
    typical: float,
    first: int = 1,
    last: int | None = None,
) -> Spikes:
    """(P1) from the angles of a log (or of a window of one): ``step[k] = d(k, k + 1)`` ``(T − 1,)``, NaN where a
    sample is missing; ``across(k)`` gives ``d(k − 1, k + 1)`` for the samples ``k``, asked only of those whose detour
    passes the scale test; ``typical`` the log's median step; the samples ``first … last`` judged (default every one
    with two neighbours, ``1 … T − 2``)."""
    T = step.size + 1
    k = np.arange(max(first, 1), min(T - 2 if last is None else last, T - 2) + 1)
    none = Spikes(np.zeros(0, dtype=np.int64), np.zeros(0))
    if k.size == 0 or not typical > 0:
        return none
    detour = np.minimum(step[k - 1], step[k])  # NaN where a neighbour or the sample is missing: never a spike
    with np.errstate(invalid="ignore"):
        far = detour > SCALE * typical
    k, detour = k[far], detour[far]  # the few candidates: the other tests on them alone
    if k.size == 0:
        return none
    outer = np.zeros(k.size)
    before, after = k - 2 >= 0, k + 1 < T - 1
    outer[before] = np.fmax(outer[before], np.nan_to_num(step[k[before] - 2]))  # a missing one is no motion
    outer[after] = np.fmax(outer[after], np.nan_to_num(step[k[after] + 1]))
    spike = (detour > ISOLATION * across(k)) & (detour > ISOLATION * outer)
    return Spikes(k[spike], detour[spike])


def describe_spikes(spikes: tuple[tuple[float, float], ...]) -> str:
    """The summary's line for the spikes left out, each ``(time (s), detour (rad))``; empty where there are none."""
    if not spikes:
        return ""
    t, d = max(spikes, key=lambda s: s[1])
    return (
        f"\nspikes: {len(spikes)} isolated sample{'s' if len(spikes) > 1 else ''} far from both neighbours (the "
        f"largest {np.degrees(d):.3g}° at t = {t:.6g} s) left out of the identification: a marker swap or a misread "
        "frame"
    )
