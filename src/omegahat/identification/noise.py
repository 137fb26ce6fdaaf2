r"""The attitude noise where the body is quietest: a bound on the white measurement noise that motion cannot inflate.

With ``φ_k = log(R_kᵀ R_{k+1})`` the body-frame increments of the attitude, the third difference of the attitude
``d_k = φ_{k+2} − 2 φ_{k+1} + φ_k`` is, per axis, the third difference of the noise (variance ``20 σ²`` for white
noise of ``σ`` rad per axis) plus ``h³`` times the angular jerk. Over a window where the body moves smoothly the
jerk's share is small; over one where it moves fast it dominates. The noise is white and the same everywhere, the
motion is not (a hand at rest and in a quick turn; a vehicle cruising and manoeuvring), so ::

    σ_q² = Q₁₀{ median_{k ∈ window} |d_k|² } / (20 · c_W),   c_W = F⁻¹_χ²₃( B⁻¹_{m,m}(0.1) )            (N1)

— the 10th percentile over windows of ``W = 2m − 1`` samples of the window's median ``|d|²`` — is the noise of the
quietest tenth of the log: the white noise where some of the log is quiet, an upper bound where none is. ``c_W`` is
what that percentile is for white noise alone: the median of ``W`` independent ``χ²₃`` values is their ``m``-th
order statistic, whose distribution function is ``F`` pushed through the regularised incomplete beta function
``I(m, m)``; its 10th percentile is ``F⁻¹(B⁻¹_{m,m}(0.1))`` (``scipy.special.betaincinv``; the χ²₃ quantile is
``F⁻¹(p) = 2 P⁻¹(3/2, p)``, ``gammaincinv``). So a log of white noise alone gets its σ back, not the low tail of its
windows.

**Higher differences.** Where no part of the log is quiet enough for its noise to show (a simulated log, a clean
one), (N1) is the motion's jerk, not the noise. The ``k``-th difference of the attitude has variance
``C(2k, k) σ²`` per axis for white noise (20, 70, 252 for ``k`` = 3, 4, 5), and ``(2 sin(πf))^{2k}`` times the
motion's spectrum at ``f`` cycles per step, which shrinks with ``k`` wherever the motion is slow against the
sampling. Each order gives an upper bound of the noise by (N1); on white noise alone the three agree (within 10 %,
and the higher orders a few per cent low: their differences are more correlated than (N1)'s ``c_W`` assumes), while
on a smooth noise-free motion at 30 Hz they fall by 35 and 36 times from one order to the next. So ::

    σ_q = min_k σ_q^{(k)}  where that is below half of σ_q^{(3)},  else σ_q^{(3)}                        (N2)

— a factor 2 (four in variance) that white noise never shows between the orders, and that leaves (N1) as it is on a
log whose noise does show. The log's own Wiener smoother (:mod:`omegahat.identification.spectral`) takes (N2): its
gain uses the noise's level at every frequency. The identification keeps (N1): a model of constant rate or
acceleration predicts one step ahead with an error of order ``h³`` times the jerk, which is what (N1) measures on a
noise-free log, so it is the least noise the likelihood can be asked to explain (with (N2) the likelihood ran off to
its fast limit on a noise-free log of Euler's equations).

:mod:`omegahat.identification.identify` bounds the
likelihood's noise by it: a stationary Gaussian model fitted by likelihood to a motion with bursts otherwise
explains the bursts' unpredictability as sensor noise (measured on BROAD at 28.6 Hz: 3.6 mrad from the likelihood
against 0.1 mrad at rest), and then smooths the motion away.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    "CHI2_3_MEDIAN",
    "DIFFERENCE_VARIANCE",
    "MOTION_APART",
    "QUANTILE",
    "REGULAR_STEP",
    "WINDOW_S",
    "quiet_noise",
    "rigid_directions",
    "window_quantile",
]

CHI2_3_MEDIAN = 2.3660  #: the median of χ² with 3 degrees of freedom
WINDOW_S = 0.25  #: s: the windows of (N1) (at least 31 samples)
QUANTILE = 0.1  #: the share of the quietest windows of (N1)
_MIN_WINDOW = 31
DIFFERENCE_VARIANCE = {3: 20.0, 4: 70.0, 5: 252.0}  #: (N2): per difference order k, C(2k, k): its variance / σ²
MOTION_APART = 0.5  #: (N2): a higher order's bound this far below the third's says the third's is motion
REGULAR_STEP = 0.05  #: a step more than 5 % off the median is irregular (a gap, a dropped or doubled sample)


@functools.cache
def window_quantile(w: int, quantile: float = QUANTILE) -> float:
    """``c_W`` of (N1): the ``quantile`` of the median of ``w`` (odd) independent ``χ²₃`` values."""
    # scipy.special's inverses, not scipy.stats' distributions (whose import takes 0.6 s of a command's run):
    # B⁻¹_{m,w−m+1} is betaincinv, and the χ²₃ quantile is 2·P⁻¹(3/2, ·) (the regularised lower gamma's inverse)
    from scipy.special import betaincinv, gammaincinv

    m = (w + 1) // 2
    return float(2.0 * gammaincinv(1.5, betaincinv(m, w - m + 1, quantile)))


def quiet_noise(t: np.ndarray, increments: np.ndarray, higher: bool = False) -> float:
    """``σ_q`` of (N1) (rad) from the times ``t (N,)`` and the body-frame increments ``φ (N − 1, 3)`` between
    consecutive valid samples (NaN where a sample is missing); differences across a gap or an irregular spacing (5 %
    off the median) are left out; NaN when there are fewer than 8 usable ones. ``higher``: (N2) instead."""
    t = np.asarray(t, dtype=float)
    phi = np.asarray(increments, dtype=float)
    if phi.shape[0] < 3:
        return float("nan")
    h_all = np.diff(t)
    h = float(np.median(h_all))
    regular = np.abs(h_all / h - 1.0) < REGULAR_STEP

    def bound(order: int) -> float:  # (N1) over the differences of this order (the third: d_k above)
        d2 = np.sum(np.diff(phi, n=order - 1, axis=0) ** 2, axis=1)
        spaced = np.all(np.lib.stride_tricks.sliding_window_view(regular, order), axis=1)  # every step regular
        return _quietest(np.where(spaced & np.isfinite(d2), d2, np.nan), h, DIFFERENCE_VARIANCE[order])

    third = bound(3)
    if not higher or not np.isfinite(third):
        return third
    lowest = float(np.nanmin([third, bound(4), bound(5)]))  # (N2)
    return lowest if lowest < MOTION_APART * third else third


def _quietest(d2: np.ndarray, h: float, white: float) -> float:
    """(N1) over the squared differences ``d2`` of one order, whose variance per axis is ``white · σ²`` for white
    noise alone: the noise of the log's quietest tenth of windows (NaN where fewer than 8 are usable)."""
    if np.count_nonzero(np.isfinite(d2)) < 8:
        return float("nan")
    w = max(_MIN_WINDOW, round(WINDOW_S / h)) | 1  # odd: a median is one sample
    n = d2.size // w
    windows = d2[: n * w].reshape(n, w)
    full = np.all(np.isfinite(windows), axis=1) if n else np.zeros(0, dtype=bool)
    if np.count_nonzero(full) < 5:  # too short (or gappy) for windows: the log's median
        return float(np.sqrt(float(np.nanmedian(d2)) / (white * CHI2_3_MEDIAN)))
    medians = np.median(windows[full], axis=1)
    return float(np.sqrt(float(np.quantile(medians, QUANTILE)) / (white * window_quantile(w))))


def rigid_directions(directions: np.ndarray, references: np.ndarray, noise: float) -> bool:
    """Whether unit body-frame ``directions (T, n, 3)`` of unit ``references (n, 3)`` carry no noise of their own
    beyond a rotation's: the angles between them are the references' to within a hundredth of the attitude noise
    ``noise`` (rad), in RMS over the samples and pairs ::

        √(mean_k |B_k B_kᵀ − V Vᵀ|²_F / n²) < noise / 100                                                  (R0)

    (``B_k`` the sample's directions as rows). Directions computed from attitudes are; a sensor's are not (each of
    its directions has its own noise, and the angle between them moves by about that much). The likelihood cannot
    identify rigid ones: the noise lies in the attitude's three dimensions alone, which a fast enough model follows
    exactly, and the innovations' other dimensions are noise-free (``docs/theory/identification.md``)."""
    b = np.asarray(directions, dtype=float)
    V = np.asarray(references, dtype=float)
    gram = np.einsum("tni,tmi->tnm", b, b) - V @ V.T
    n = V.shape[0]
    return bool(b.shape[0] > 0 and np.sqrt(np.mean(np.sum(gram**2, axis=(1, 2)))) / n < noise / 100.0)
