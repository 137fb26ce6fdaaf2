r"""The coarse clock offset between an attitude log and a gyroscope log: step 2 of :mod:`omegahat.calibration`.

The norm of a centred body rate does not depend on the frame it is written in (a rotation keeps it, a scale
matrix nearly does), so the gyroscope's ``|g(t + δ) − ḡ|`` follows the attitude's ``|ω(t) − ω̄|`` whatever the
unknown frame rotation. With ``x_k`` the attitude's norms on its grid ``t_k = t₀ + k h`` and ``y(δ)_k`` the
gyroscope's at ``t_k + δ``, both masked where their log has a gap (or no sample), the offset is the lag
``δ_j = δ_lo + j h`` whose Pearson correlation over the samples both logs have there is the most significant::

    c_j = (Σxy − Σx Σy / n) / √((Σx² − (Σx)²/n)(Σy² − (Σy)²/n)),   sums over the n_j samples of the overlap   (O1)
    z_j = atanh(c_j) √n_j                                                                                      (O2)

(``z`` is Fisher's transform scaled to the overlap: where every lag overlaps equally it ranks as ``c`` does; where
the overlaps differ, a short overlap that correlates by chance does not beat the long one that correlates for a
reason.) Every sum of (O1) at every lag is one FFT cross-correlation, and each lag's own means are removed (the
correlation of the samples the two logs share there, as :func:`numpy.corrcoef` would compute it).

The lags searched are those at which the logs overlap by at least ``min_overlap`` samples, within
``guess ± max_offset`` where a bound is given (``None``: every such lag, whatever the clocks' origins). The lag is
refined by a parabola through its neighbours; the runner-up is the best other local maximum of ``z`` at least
``min_separation`` samples away (a motion that repeats itself has several), reported with its correlation over the
best's.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import NamedTuple

import numpy as np
from scipy.signal import correlate

__all__ = ["MAX_GRID", "OffsetSearch", "check_search", "search_offset"]

MAX_GRID = 20_000_000  #: samples: the longest grid of gyroscope rates the search builds (0.5 GB as 3 columns)


class OffsetSearch(NamedTuple):
    """The coarse offset (NaN where no lag overlaps enough), the runner-up's offset and its correlation over the
    best's (NaN where there is none), and whether the best lag is the last one a bound ``max_offset`` allowed."""

    offset: float
    runner_up: float
    likeness: float
    at_bound: bool


def _lags(t_first, t_last, tg_range, guess, max_offset, min_span):
    """``(δ_lo, δ_hi, bounded)``: the lags at which the logs overlap by ``min_span`` seconds or more, within
    ``guess ± max_offset`` where given; ``bounded`` tells whether that bound is the one that limits them."""
    lo, hi = tg_range[0] - t_last + min_span, tg_range[1] - t_first - min_span
    if max_offset is None:
        return lo, hi, (False, False)
    return max(lo, guess - max_offset), min(hi, guess + max_offset), (guess - max_offset > lo, guess + max_offset < hi)


def check_search(guess: float, max_offset: float | None) -> None:
    """Raise ``ValueError`` where the search's guess is not a finite number of seconds, its bound not a positive
    one, or a guess comes without a bound (it would change nothing: every lag is searched); called before anything
    is read or built."""
    if not math.isfinite(guess) or not (max_offset is None or max_offset > 0):  # NaN too
        raise ValueError(
            f"the guess of the clock offset must be a finite number of seconds and its bound a positive one; got "
            f"offset_guess={guess!r}, max_offset={max_offset!r}"
        )
    if max_offset is None and guess != 0.0:  # a guess alone would change nothing: every lag is searched
        raise ValueError(
            f"a guess of the clock offset ({guess:g} s) centres a bounded search: give its bound too (max_offset; "
            "--max-offset on the command line), or neither to search every offset"
        )


def search_offset(
    t: np.ndarray,
    norms: np.ndarray,
    norms_ok: np.ndarray,
    gyro_norms: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
    tg_range: tuple[float, float],
    guess: float,
    max_offset: float | None,
    min_overlap: int,
    min_separation: float,
) -> OffsetSearch:
    """(O1)–(O2) (module docstring). ``norms`` are the attitude's centred rate norms on the regular grid ``t``
    (step ``h``), ``norms_ok`` where they are usable; ``gyro_norms(u)`` gives the gyroscope's at the times ``u`` and
    where they are usable; ``tg_range`` the gyroscope log's first and last times. Raises ``ValueError`` where the
    search would need more than :data:`MAX_GRID` samples (clocks far apart need a guess and a bound), or where a
    guess comes without a bound."""
    check_search(guess, max_offset)
    nan = OffsetSearch(math.nan, math.nan, math.nan, False)
    h = float(t[1] - t[0])
    lo, hi, bounded = _lags(t[0], t[-1], tg_range, guess, max_offset, min_overlap * h)
    if not hi >= lo:
        return nan
    n_lags = math.floor((hi - lo) / h + 1e-9) + 1
    size = t.size + n_lags - 1
    if size > MAX_GRID:
        raise ValueError(
            f"searching the clock offset over every lag at which the logs overlap needs {size:,} samples of the gyro "
            f"log's rate at the attitude's rate ({1 / h:.4g} Hz), more than {MAX_GRID:,}: give a guess of the offset "
            "and a bound (offset_guess and max_offset; --offset and --max-offset on the command line)"
        )
    y, my = gyro_norms(t[0] + lo + h * np.arange(size))
    x, mx = norms, norms_ok
    if not (my.any() and mx.any()):
        return nan
    xt = np.where(mx, x - x[mx].mean(), 0.0)  # the global means out first: the per-lag sums then cancel less
    yt = np.where(my, y - y[my].mean(), 0.0)
    fx, fy = mx.astype(float), my.astype(float)

    def lagged(a, b):  # Σ_k a[k + j] b[k] for every lag j
        return correlate(a, b, mode="valid", method="fft")

    n = np.rint(lagged(fy, fx))
    sx, sy, sxy = lagged(fy, xt), lagged(yt, fx), lagged(yt, xt)
    sxx, syy = lagged(fy, xt**2), lagged(yt**2, fx)
    with np.errstate(divide="ignore", invalid="ignore"):
        vx, vy = sxx - sx**2 / n, syy - sy**2 / n
        floor = 1e-9 * n  # FFT rounding: a window whose norms barely vary has no correlation to speak of
        ok = (n >= min_overlap) & (vx > floor * np.mean(xt[mx] ** 2)) & (vy > floor * np.mean(yt[my] ** 2))
        c = np.where(ok, (sxy - sx * sy / n) / np.sqrt(vx * vy), np.nan)
        z = np.where(ok, np.arctanh(np.clip(c, -1 + 1e-12, 1 - 1e-12)) * np.sqrt(n), -np.inf)
    if not np.isfinite(z).any():
        return nan
    k = int(np.argmax(z))
    frac = 0.0
    if 0 < k < z.size - 1 and np.isfinite(z[k - 1]) and np.isfinite(z[k + 1]):
        den = z[k - 1] - 2 * z[k] + z[k + 1]
        frac = 0.5 * (z[k - 1] - z[k + 1]) / den if den < 0 else 0.0
    peaks = np.flatnonzero((z[1:-1] >= z[:-2]) & (z[1:-1] >= z[2:]) & np.isfinite(z[1:-1])) + 1
    peaks = peaks[np.abs(peaks - k) >= min_separation]
    runner_up, likeness = math.nan, math.nan
    if peaks.size and c[k] > 0:
        other = int(peaks[np.argmax(z[peaks])])
        runner_up, likeness = lo + other * h, float(c[other] / c[k])
    at_bound = (bounded[0] and k == 0) or (bounded[1] and k == z.size - 1)
    return OffsetSearch(lo + (k + frac) * h, runner_up, likeness, at_bound)
