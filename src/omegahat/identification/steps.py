r"""The steps of an attitude log, as the log's own Wiener smoother (:mod:`omegahat.identification.spectral`) and the
identification read them: its contiguous stretches, whether its uneven steps are the samples' or their stamps', and
the single missing samples bridged inside a stretch.

**Uneven steps.** A stretch's steps may differ because the samples were taken at uneven times, or because regular
samples were stamped unevenly (a message's arrival time, rounded stamps): ``b_k = φ_k / h_k`` is right for the
first and adds ``ε |ω|`` of noise for a jitter ``ε`` in the second, where ``φ_k / h̄`` (the stretch's mean step) is
right. The increments tell which: where the samples are regular, ``φ_k / h̄`` is the smoother sequence, so over the
stretches whose steps differ from their mean by more than 0.1 %::

    Σ_k |φ_{k+1}/h̄ − φ_k/h̄|²  <  Σ_k |φ_{k+1}/h_{k+1} − φ_k/h_k|²   ⇒   regular samples, jittered stamps    (S8)

and then every stretch (linked across steps within 50 % of the median: a dropped sample breaks it, unless (S9)
bridges it for the filter) is filtered with the samples' step ``h̄``, the mean step over the stretches, which is
also (S1)'s ``h``. Otherwise each step is used as stamped, and a step 5 % or more off the median ends the stretch
whose rates are kept (the rotation spline, exact at uneven times, takes what is too short to filter); the filter
runs on through it, as far as the samples are linked, so that a stretch's end is filtered with the increments
beyond it and not with an extension of its own (S8').

**A single missing sample.** Where sample ``k`` is missing and ``k − 1`` and ``k + 1`` are present, the smoother's
stretch would end at ``k − 1`` and start again at ``k + 1``: two ends, each extended by the smoother's (S4), which
errs more there than inside a stretch. The increment across the gap is known, and for the filter the sample is put
on the geodesic between its neighbours at its own time::

    R_k = R_{k−1} exp( s log(R_{k−1}ᵀ R_{k+1}) ),    s = (t_k − t_{k−1}) / (t_{k+1} − t_{k−1})                (S9)

so the two rates ``b_k``, ``b_{k+1}`` are the mean rate over the two steps: one sample's worth of low-pass where
there would otherwise be two ends. The spectrum, the noise bounds and the identification read the log as it is: a
bridged sample carries no motion above the two steps' mean, and where many samples are missing (a decimated log of
fast motion) it would lower the spectrum's top and make the filter cut motion. A bridged sample keeps its status
(``predicted``). Two or more consecutive missing samples are a gap, never bridged. Measured in
``docs/theory/identification.md``.
"""

from __future__ import annotations

import math

import numpy as np

from omegahat import so3

__all__ = ["JITTER_LINK", "UNEVEN_STEP", "bridged", "read_steps", "stamped_steps", "stretches", "too_fast"]

UNEVEN_STEP = 1e-3  #: a stretch whose steps differ from their mean by more than 0.1 % has jittered steps (S8)
JITTER_LINK = 0.5  #: a step within 50 % of the median joins two samples in a stretch (a dropped sample does not)


def stamped_steps(increments: list[np.ndarray], steps: list[np.ndarray]) -> bool:
    """(S8): True where the log's jittered steps are the stamps' and not the samples' (the samples regular): the
    increments ``φ_k`` (per stretch ``(m, 3)``) divided by the stretch's mean step vary less from one step to the
    next than divided by each stamped step (``steps``, per stretch ``(m,)``)."""
    pairs = list(zip(increments, steps, strict=True))
    by_stamp = sum(float(np.nansum(np.diff(phi / dt[:, None], axis=0) ** 2)) for phi, dt in pairs)
    by_mean = sum(float(np.nansum(np.diff(phi / np.mean(dt), axis=0) ** 2)) for phi, dt in pairs)
    return by_mean < by_stamp


def read_steps(t: np.ndarray, increments: np.ndarray, runs: list[tuple[int, int]]) -> tuple[str, float]:
    """(S8) over the stretches ``runs`` of the times ``t (T,)`` with the increments ``φ (T − 1, 3)`` between
    consecutive samples: ``("", nan)`` where every stretch's steps are within 0.1 % of their mean, else
    ``("stamps", h̄)`` (regular samples with jittered stamps; ``h̄`` the stretches' mean step) or
    ``("sampling", nan)`` (the samples taken at their stamps)."""
    steps = [np.diff(t[a:b]) for a, b in runs]
    uneven = [d.size > 1 and bool(np.any(np.abs(d / np.mean(d) - 1.0) > UNEVEN_STEP)) for d in steps]
    if not any(uneven):
        return "", math.nan
    chosen = [(run, d) for run, d, u in zip(runs, steps, uneven, strict=True) if u]
    if stamped_steps([increments[a : b - 1] for (a, b), _ in chosen], [d for _, d in chosen]):
        return "stamps", sum(float(np.sum(d)) for d in steps) / sum(d.size for d in steps)
    return "sampling", math.nan


def stretches(t: np.ndarray, valid: np.ndarray, tolerance: float = JITTER_LINK) -> list[tuple[int, int]]:
    """``[(a, b), ...]``: the maximal runs ``a ≤ k < b`` of valid samples whose steps are within ``tolerance`` of the
    log's median step (:data:`JITTER_LINK`: one sample follows the next; a dropped one, a step of two, does not)."""
    h = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    link = valid[:-1] & valid[1:] & (np.abs(np.diff(t) / h - 1.0) < tolerance)  # k and k + 1 in one run
    starts = np.flatnonzero(valid & np.concatenate([[True], ~link]))
    ends = np.flatnonzero(valid & np.concatenate([~link, [True]])) + 1
    return [(int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


def bridged(t: np.ndarray, R: np.ndarray, valid: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(S9): ``(R', valid')``, the attitudes ``R (T, 3, 3)`` at the times ``t (T,)`` with each single missing sample
    (not ``valid``, both neighbours ``valid``) put on the geodesic between its neighbours, and ``valid`` with those
    samples added. ``R`` and ``valid`` themselves where there is none."""
    T = t.size
    k = np.flatnonzero(~valid[1:-1] & valid[:-2] & valid[2:]) + 1 if T > 2 else np.zeros(0, dtype=np.int64)
    if k.size == 0:
        return R, valid
    across = so3.log(np.swapaxes(R[k - 1], -1, -2) @ R[k + 1])
    s = (t[k] - t[k - 1]) / (t[k + 1] - t[k - 1])
    filled, used = R.copy(), valid.copy()
    filled[k] = R[k - 1] @ so3.exp(s[:, None] * across)
    used[k] = True
    return filled, used


def too_fast(increments: np.ndarray) -> str:
    """Why no model fits a log whose steps ``increments`` (rotation vectors) turn more than 90° in the median (its
    words, after a colon), else "": beyond 90° a step's direction is not known, and at 180° not even its size."""
    turn = math.degrees(float(np.median(np.linalg.norm(increments, axis=1)))) if len(increments) else 0.0
    return (
        f": the attitude turns {turn:.0f}° per step (median), faster than the samples can follow" if turn > 90 else ""
    )
