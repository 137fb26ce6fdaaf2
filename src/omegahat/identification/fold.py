r"""The rate folded onto the band from beyond the Nyquist frequency: (S6) of :mod:`omegahat.identification.spectral`.

Sampling folds the rate's spectrum above the Nyquist frequency onto the band, and nothing in the samples separates
that fold from the motion at the same frequency. (S6) reads it from how the motion's spectrum leaves the band: its
level at the band's top and its decay over the upper part of the band, ``0.35 ≤ f < 0.5`` cycles per step (the
equations are in :mod:`~omegahat.identification.spectral`'s docstring). The Wiener smoother and the log's causal
filter (:mod:`~omegahat.identification.causal`, which also checks the reading without a fold, (C4)) take it from
here.
"""

from __future__ import annotations

import numpy as np

__all__ = ["UPPER", "fold_remark", "folded", "leaving_slope", "rate_spectra"]

UPPER = (0.35, 0.5)  #: cycles per step: the upper part of the band, whose decay (S6) continues beyond it


def leaving_slope(freq: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Per body axis ``(3,)``, the least-squares slope of ``log(motion / sinc²)`` (the rate's spectrum, base and fold
    together) against ``log f`` over :data:`UPPER`, for the motion's share ``motion (F, 3)`` of the increments'
    spectrum at the frequencies ``freq`` (cycles per step): how the rate's spectrum leaves the band, negative where
    it falls. 0 where fewer than three of those frequencies show motion."""
    upper = (freq >= UPPER[0]) & (freq < UPPER[1])
    observed = motion / np.sinc(freq)[:, None] ** 2
    slope = np.zeros(motion.shape[1])
    for j in range(motion.shape[1]):
        seen = upper & (observed[:, j] > 0)
        if np.count_nonzero(seen) >= 3:
            slope[j] = np.polyfit(np.log(freq[seen]), np.log(observed[seen, j]), 1)[0]
    return slope


def folded(freq: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """``S_a (F, 3)`` of (S6): the rate spectrum folded onto each frequency ``freq`` (cycles per step) from beyond the
    Nyquist frequency, for the motion's share ``motion (F, 3)`` of the increments' spectrum (``P_b − N_b`` where
    significant)."""
    sinc_a = np.sinc(1.0 - freq)[:, None]
    top = (freq >= 0.45) & (freq < 0.5)  # below the Nyquist bin (Welch's half-weighted one)
    if not top.any() or np.count_nonzero((freq >= UPPER[0]) & (freq < UPPER[1])) < 3:
        return np.zeros_like(motion)
    at_nyquist = np.median(motion[top], axis=0) * np.pi**2 / 8.0  # S(π), base and fold alike: P_s = (8/π²) S(π)
    decay = np.maximum(0.0, -leaving_slope(freq, motion))  # a spectrum that leaves the band rising is held level
    envelope = at_nyquist * (np.maximum(1.0 - freq, 0.5)[:, None] / 0.5) ** (-decay)
    with np.errstate(divide="ignore"):
        return np.minimum(envelope, motion / sinc_a**2)  # no more than the frequency shows


def rate_spectra(
    freq: np.ndarray, P_b: np.ndarray, g: np.ndarray, N_b: np.ndarray, fold: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """(S6): the rate's spectrum in the band, ``S``, and folded onto it from beyond the Nyquist frequency, ``S_a``,
    both ``(F, 3)``, zero where the motion is not significant; ``fold=False``: ``S_a = 0``, all the motion in the band
    (the reading (C4) of :mod:`omegahat.identification.causal` checks beside this one)."""
    sinc, sinc_a = np.sinc(freq)[:, None], np.sinc(1.0 - freq)[:, None]
    motion = np.where(g > 0, np.maximum(P_b - N_b, 0.0), 0.0)
    above = folded(freq, motion) if fold else np.zeros_like(motion)
    return np.maximum(motion - sinc_a**2 * above, 0.0) / sinc**2, above


def fold_remark(expected_rms: float, fold_rms: float) -> str:
    """What ``omegahat estimate`` adds to an expected RMS error (rad/s) where more than a tenth of it, ``fold_rms``,
    is the rate above the Nyquist frequency: the part (S6) extrapolates from the band's top, which the samples
    cannot show (the log's causal filter's line and the Wiener smoother's). Empty otherwise."""
    if not fold_rms > 0.1 * expected_rms:
        return ""
    return (
        f" ({fold_rms:.3g} of it from the rate above the Nyquist frequency, which the samples cannot show: "
        "extrapolated from the band's top)"
    )
