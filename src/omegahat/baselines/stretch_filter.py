r"""The causal filter of backward differences, stretch by stretch: (D4) and its coning correction (D5).

``omegahat estimate`` designs the taps from the log's spectrum ((C1)–(C3) of :mod:`omegahat.identification.causal`);
:class:`omegahat.baselines.differencing.DifferencingEstimator` runs them, by :func:`filtered_differences` over a
whole log and by :func:`next_in_stretch` sample by sample (the two equal, tested). Given taps ``c_0 … c_{L−1}`` per
body axis, over the last ``L`` backward differences ``b_k = Log(R_{k−1}ᵀ R_k) / h_k`` of one stretch (a skipped
sample, or an interval more than :data:`STRETCH_BREAK` times the one before, starts a new stretch: its first
``L − 1`` outputs are the differences themselves, as is the one across the break)::

    ω̃_k = Σ_j c_j · b_{k−j}                                                                          (D4)

Each difference is the interval's mean rate plus the coning term (M1) of :func:`omegahat.so3.coning` where the
rate's axis turns; the taps are designed for the mean rate, so they run twice: first on the differences as taken
(``ω̃_k``, (D4)), then on the differences less their coning term from the first pass (none at a stretch's first
difference; causal, since ``ω̃_k`` uses differences up to ``b_k`` only)::

    ω̂_k = Σ_j c_j · b'_{k−j},   b'_k = b_k − (h_k / 12) ω̃_{k−1} × ω̃_k                                 (D5)

Differencing alone (no taps) is not corrected: it is the peers' backward differencing. What (D5) gives on the
development recordings: ``docs/theory/identification.md``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3

__all__ = ["STRETCH_BREAK", "Stretch", "checked_taps", "filtered_differences", "next_in_stretch", "two_passes"]

STRETCH_BREAK = 1.5  #: (D4): an interval this many times the one before breaks the filter's stretch (a dropped sample)


def checked_taps(taps: ArrayLike) -> np.ndarray:
    """``taps`` as ``(L, 3)`` finite floats (one column per body axis)."""
    c = np.asarray(taps, dtype=float)
    c = np.repeat(c[:, None], 3, axis=1) if c.ndim == 1 else c
    if c.ndim != 2 or c.shape[1] != 3 or c.shape[0] < 1 or not np.all(np.isfinite(c)):
        raise ValueError(f"taps must be finite, shape (L,) or (L, 3); got shape {np.shape(taps)}")
    return c


class Stretch(NamedTuple):
    """The streaming state of (D4)–(D5) in the current stretch: its last ``L`` differences as taken (``raw``) and
    less their coning term (``corrected``), oldest first; the first pass's rate at the last one (``previous``, None
    at a stretch's start) and the last interval differenced (``span``, None before any)."""

    raw: list[np.ndarray]
    corrected: list[np.ndarray]
    previous: np.ndarray | None
    span: float | None


def two_passes(
    b: np.ndarray, spans: np.ndarray, taps: np.ndarray, before: Stretch | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(D4)–(D5) over one stretch's differences ``b (m, 3)`` and their intervals ``spans (m,)``: the first pass ω̃,
    the differences less their coning term ``b'``, and the second pass ω̂ (the differences themselves before ``L``
    of them), each ``(m, 3)``. ``before``: the state of the stretch these differences continue (None or empty: they
    start it), whose last differences fill the filters' windows as :func:`next_in_stretch` keeps them."""
    L = taps.shape[0]
    before = before or Stretch([], [], None, None)
    p = len(before.raw)  # at most L, and all of the stretch so far where fewer

    def filtered(x: np.ndarray, earlier: list[np.ndarray]) -> np.ndarray:
        xs = np.concatenate([np.reshape(earlier, (-1, 3)), x]) if p else x
        out = xs.copy()
        if xs.shape[0] >= L:
            out[L - 1 :] = np.stack([np.convolve(xs[:, j], taps[:, j], mode="valid") for j in range(3)], 1)
        return out[p:]

    first = filtered(b, before.raw)
    corrected = b.copy()
    corrected[1:] -= so3.coning(first[:-1], first[1:], spans[1:])  # (D5); none at a stretch's first difference
    if before.previous is not None and b.shape[0]:
        corrected[0] -= so3.coning(before.previous, first[0], spans[0])
    second = filtered(corrected, before.corrected)
    plain = max(0, L - 1 - p)
    second[:plain] = b[:plain]  # before L differences: the differences themselves, as (D4)
    return first, corrected, second


def filtered_differences(
    est: np.ndarray,
    valid: np.ndarray,
    clock: np.ndarray,
    taps: np.ndarray,
    before: Stretch | None = None,
    cut: np.ndarray | None = None,
) -> Stretch:
    """(D4)–(D5) over the backward differences ``est (T, 3)`` (rows at the ``valid`` samples after the first; the
    intervals from ``clock (T,)``), in place; the stretches as :func:`next_in_stretch` keeps them. ``before``: the
    state the first difference continues (None: the log starts here), as :func:`next_in_stretch` would take it;
    ``cut (T,)``: rows whose difference is left out, the next stretch starting after them. Returns the streaming
    state of the last one."""
    empty = Stretch([], [], None, None) if before is None else before
    iv = np.flatnonzero(valid)
    if iv.size < 2:
        return empty
    rows, spans = iv[1:], np.diff(clock[iv])
    previous_span = np.inf if before is None or before.span is None else before.span
    longer = spans > STRETCH_BREAK * np.concatenate([[previous_span], spans[:-1]])
    skipped = (np.diff(iv) > 1) | longer if cut is None else (np.diff(iv) > 1) | longer | cut[rows]
    breaks = np.flatnonzero(skipped)  # the differences that break a stretch
    L = taps.shape[0]
    start, state = 0, empty._replace(span=float(spans[-1]))
    for stop in [*breaks.tolist(), rows.size]:  # a break's own difference stays as it is, the stretch follows it
        run = rows[start:stop]
        if run.size:
            prior = before if start == 0 and before is not None and before.raw else None
            b = est[run]
            first, corrected, second = two_passes(b, spans[start:stop], taps, prior)
            est[run] = second
            raw_tail = [*(prior.raw if prior else []), *b][-L:]
            corrected_tail = [*(prior.corrected if prior else []), *corrected][-L:]
            state = Stretch(raw_tail, corrected_tail, first[-1].copy(), float(spans[-1]))
        start = stop + 1
    if breaks.size and breaks[-1] == rows.size - 1:  # the last difference broke a stretch: nothing kept
        return Stretch([], [], None, float(spans[-1]))
    return state


def next_in_stretch(
    stretch: Stretch, taps: np.ndarray, difference: np.ndarray, span: float, skipped: bool
) -> tuple[np.ndarray, Stretch]:
    """(D4)–(D5) with the newest ``difference`` over the interval ``span`` (``skipped``: a sample was skipped since
    the last one, which breaks the stretch): the rate, or the difference where its stretch has fewer than ``L`` of
    them (or it breaks the stretch), and the stretch's new state."""
    L = taps.shape[0]
    if skipped or (stretch.span is not None and span > STRETCH_BREAK * stretch.span):
        return difference, Stretch([], [], None, span)
    raw = [*stretch.raw, difference][-L:]
    first = np.einsum("lj,lj->j", taps, np.array(raw[::-1])) if len(raw) == L else difference
    coning = np.zeros(3) if stretch.previous is None else so3.coning(stretch.previous, first, span)  # (D5)
    corrected = [*stretch.corrected, difference - coning][-L:]
    rate = np.einsum("lj,lj->j", taps, np.array(corrected[::-1])) if len(corrected) == L else difference
    return rate, Stretch(raw, corrected, first, span)
