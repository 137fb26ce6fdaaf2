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

**Resets.** An attitude source that restarts from another reference (an orientation filter re-aligning its
heading, a rigid body re-fitted to its markers) turns every attitude after one step by the same rotation: one step
far larger than those beside it, and the body's increments on either side as they were. The step into sample ``j``
is a reset where ::

    d(j − 1, j) > ISOLATION · max(d(j − 2, j − 1), d(j, j + 1), q₉₉)   and   d(j − 1, j) > SCALE · median step  (P2)

(both neighbouring steps present; ``q₉₉`` the 99th percentile of the log's steps). Body motion does not do that:
the step is four times both of its neighbours, a rate that changes fourfold within a step and back, and four
times the fastest hundredth of the log's steps. The last test is what a log sampled slowly for its motion needs,
where a hand starts or stops within one step; it keeps that motion in the log's own range of steps
(``docs/theory/identification.md``, "Spikes and aliases", measures both kinds on real recordings).

The attitudes from ``j`` on are turned back by one rotation ``S`` (a turn of the inertial frame, which leaves every
later increment ``R_kᵀ R_{k+1}`` as it was), chosen so that the step across the reset turns at the mean rate of its
two neighbouring steps, and sample ``j`` is then treated as missing (the rate over the reset's step is not in the
samples)::

    S = R_{j−1} Exp(Δ_{j−1} (φ_{j−2}/Δ_{j−2} + φ_j/Δ_j)/2) R_jᵀ,   R_k ← S R_k  (k ≥ j),
    φ_k = Log(R_kᵀ R_{k+1}),   Δ_k = t_{k+1} − t_k                                                      (P3)

(for evenly spaced samples the mean of the two increments).

A reset that turns the body frame instead (``R_k T``) leaves its later increments turned by ``T``: the rates
after it are then in the source's new body axes, as the source gives them.

**Gaps.** Over an interval longer than the median spacing (a tracker's outage, frames left out, the time between
two segments of an attitude ephemeris) the body turns further than over one step. (P2) therefore judges each step
per median spacing, its angle times ``spacing / Δt`` where ``Δt`` is longer (:func:`per_spacing`): a reset after a
few frames left out is still one, while the turn across an outage of minutes (any angle up to π, over hundreds of
steps) is none. A step across a gap, longer than :data:`GAP` median spacings, is no spike's neighbour and no jump
(:func:`across_gaps`): the turn over it is unknown, and the command's summary counts the gap itself.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from omegahat import so3

__all__ = [
    "FASTEST",
    "GAP",
    "ISOLATION",
    "SCALE",
    "Spikes",
    "across_gaps",
    "describe_spikes",
    "isolated_spikes",
    "judged_resets",
    "judged_spikes",
    "per_spacing",
    "reset_turn",
    "step_scales",
    "stitched",
]

ISOLATION = 4.0  #: a spike's detour is at least this many times its neighbours' steps (P1)
SCALE = 20.0  #: and at least this many times the log's median step (P1), (P2)
FASTEST = 99.0  #: (P2): a reset's step is ISOLATION times this percentile of the log's steps
GAP = 2.0  #: an interval longer than this many median spacings is a gap (as the command's summary counts them)


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
    return judged_spikes(step, lambda k: so3.angle(Rv[k - 1], Rv[k + 1]), step_scales(step)[0])


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


def _intervals(t: np.ndarray, spacing: float | None) -> tuple[np.ndarray, float]:
    dt = np.diff(np.asarray(t, dtype=float))
    return dt, (float(np.median(dt)) if spacing is None and dt.size else spacing or 0.0)


def across_gaps(step: np.ndarray, t: np.ndarray, spacing: float | None = None) -> np.ndarray:
    """``step`` ``(T − 1,)``, the angles between the samples at times ``t`` ``(T,)``, with NaN across each gap (module
    docstring): where the interval is longer than :data:`GAP` times ``spacing`` (default the median interval)."""
    dt, h = _intervals(t, spacing)
    return np.where(dt > GAP * h, np.nan, step) if dt.size else step


def per_spacing(step: np.ndarray, t: np.ndarray, spacing: float | None = None) -> np.ndarray:
    """``step`` per ``spacing`` (default the median interval) where an interval is longer (module docstring):
    ``step · min(1, spacing / Δt)``, the scale (P2) judges resets on."""
    dt, h = _intervals(t, spacing)
    with np.errstate(divide="ignore", invalid="ignore"):
        return step * np.minimum(1.0, h / dt) if dt.size else step


def step_scales(step: np.ndarray) -> tuple[float, float]:
    """The scales (P1) and (P2) judge a log's steps ``step (T − 1,)`` (rad, NaN where a sample is missing) against:
    their median and their :data:`FASTEST` percentile (0 and 0 where no step is known)."""
    if not np.isfinite(step).any():
        return 0.0, 0.0
    return float(np.nanmedian(step)), float(np.nanpercentile(step, FASTEST))


def judged_resets(step: np.ndarray, typical: float, fastest: float, first: int = 2, last: int | None = None) -> Spikes:
    """(P2) from the angles ``step[k] = d(k, k + 1)`` ``(T − 1,)`` of a log (NaN where a sample is missing), its
    median step ``typical`` and its :data:`FASTEST` percentile ``fastest``: the samples ``j`` (``first … last``,
    default every one with a step on either side of the one into it, ``2 … T − 2``) reached by a reset, and the
    reset's angle ``d(j − 1, j)``."""
    T = step.size + 1
    j = np.arange(max(first, 2), min(T - 2 if last is None else last, T - 2) + 1)
    if j.size == 0 or not typical > 0:
        return Spikes(np.zeros(0, dtype=np.int64), np.zeros(0))
    into, before, after = step[j - 1], step[j - 2], step[j]
    with np.errstate(invalid="ignore"):  # NaN beside a missing sample: never a reset
        reset = (into > SCALE * typical) & (into > ISOLATION * np.maximum(np.maximum(before, after), fastest))
    return Spikes(j[reset], into[reset])


def reset_turn(
    before: np.ndarray, at: np.ndarray, phi_before: np.ndarray, phi_after: np.ndarray, intervals: np.ndarray
) -> np.ndarray:
    """``S`` of (P3): the rotation that turns the attitude ``at`` (3, 3), reached by a reset from ``before``, and
    every later one back, so that the step across the reset turns at the mean rate of the increments beside it;
    ``intervals``: the three steps' durations ``(Δ_{j−2}, Δ_{j−1}, Δ_j)``."""
    rate = 0.5 * (phi_before / intervals[0] + phi_after / intervals[2])
    return before @ so3.exp(rate * intervals[1]) @ at.T


def stitched(R: np.ndarray, valid: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, Spikes]:
    """(P2)–(P3) over a whole log of attitudes ``R (T, 3, 3)`` at times ``t`` used where ``valid``: ``(R', valid',
    resets)``, the attitudes after each reset turned back and the sample reached by it no longer valid; ``R`` and
    ``valid`` themselves where there is none. Each step is judged per median spacing (:func:`per_spacing`)."""
    Rv = np.where(valid[:, None, None], R, np.nan)
    step = per_spacing(so3.angle(Rv[:-1], Rv[1:]), t)
    resets = judged_resets(step, *step_scales(step))
    if resets.samples.size == 0:
        return R, valid, resets
    R, valid, phi = R.copy(), valid.copy(), so3.increments(Rv)  # a turn of the later ones leaves φ as it is
    dt = np.diff(np.asarray(t, dtype=float))
    for j in resets.samples:
        R[j:] = reset_turn(R[j - 1], R[j], phi[j - 2], phi[j], dt[j - 2 : j + 1]) @ R[j:]
        valid[j] = False
    return R, valid, resets


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
