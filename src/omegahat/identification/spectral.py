r"""The log's own Wiener smoother: the zero-lag rate where no model describes the log (``--smooth``'s fallback).

When :func:`omegahat.identification.identify` declines every model, the log still tells two things: its attitude
noise (its quietest part's, (N2) of :func:`omegahat.identification.noise.quiet_noise`) and the spectrum of its
increments: enough for the best linear zero-lag estimate of a stationary log, the Wiener filter, measured.

**The data.** ``b_k = φ_k / h`` with ``φ_k = log(R_{k−1}ᵀ R_k)`` the body-frame increment and ``h`` the step: the
mean rate over ``[t_{k−1}, t_k]`` plus the noise's difference. Per axis and at normalised frequency ``x = ωh``
(``|x| ≤ π``), for a rate spectrum ``S`` and white attitude noise of ``σ`` rad::

    b(x) = sinc(x/2) e^{−ix/2} ω(x) + (1 − e^{−ix}) n(x) / h,     N_b(x) = 4 σ² sin²(x/2) / h²              (S1)

— the interval mean is a half-sample delay and a ``sinc(x/2) = sin(x/2)/(x/2)`` low-pass of the rate; the noise
of the difference grows towards the Nyquist frequency. (S1) is exact for a rate of fixed axis; where the axis turns,
``φ_k / h`` is the interval mean plus the coning term ``(h/12) ω_{k−1} × ω_k`` (:func:`omegahat.so3.coning`, (M1)),
a bias of second order in ``h`` that no filter of ``b`` removes. So the filter below runs twice per stretch, the
second time on the increments less that term, computed from the first run's rates::

    b'_k = b_k − (h/12) ω̂_{k−1} × ω̂_k                                                               (S1c)

(on a noise-free coning motion at 10 and 30 samples per second, whose term is 5.3e-4 and 5.8e-5 rad/s along the
cone's axis, the mean error there is below a tenth of it; tested).

**The filter.** The estimate of the rate at the samples, ``ω̂(x) = F(x) b(x)``, that minimises the mean square error
for the spectra of (S1) is (Wiener; the rate's spectrum ``S = (P_b − N_b)/sinc²(x/2)`` by (S1))::

    F(x) = e^{ix/2} / sinc(x/2) · g(x),    g(x) = max(0, 1 − N_b(x) / P_b(x))                             (S2)

the half-sample advance and the inverse of the interval mean (exact on a noise-free band-limited motion), and the
spectral-subtraction gain ``g``: 1 where the motion dominates the noise, 0 where the noise does. ``P_b`` is
Welch's estimate of the increments' spectrum (half-overlapping Hann segments, per axis, pooled over the log's
contiguous stretches), ``σ`` the quiet part's noise (N2): a vibration that a noise estimate over the whole log would
take for noise stays signal where it shows above ``N_b``. The segment is :data:`SEGMENT` samples, halved (down to
64) while fewer than :data:`MIN_SEGMENTS` fit in the stretches: ``ν ≥ 50`` (below), each bin's power to ±20 % (S1').

**No more noise than the band's top shows.** ``P_b ≥ N_b`` at every frequency, up to Welch's error, so the top tenth
of the band (``0.45 ≤ f < 0.5`` cycles per step, where ``N_b`` is largest; Welch halves the Nyquist bin) bounds ``σ²``
per body axis. Over its ``n`` bins (``⌈n/2⌉`` independent: neighbouring Hann bins correlate) the mean of
``P_b / (N_b/σ²)`` has ``ν' = ν ⌈n/2⌉`` degrees of freedom, and its one-sided 95 % upper bound is::

    σ ≤ σ_top = sqrt( ν' / χ²_ν'⁻¹(0.05) · mean_{0.45 ≤ f < 0.5} P_b / (N_b/σ²) ),   σ = min(σ_q, σ_top)      (N3)

Where the noise shows, the bound lies above ``σ_q``; on a log cleaner than its motion's differences show (a
simulation), ``σ_q`` is the motion's own, and (N3) keeps the filter from cutting that motion as noise (tested).

**Only where the motion shows.** Welch's estimate is a noisy one: over ``K`` half-overlapping Hann segments a
frequency with noise alone has ``P_b ~ N_b χ²_ν / ν`` with ``ν = 2K / (1 + 2 · 0.167²)`` equivalent degrees of
freedom (Welch 1967), and ``g`` of (S2) would pass some of that noise wherever ``P_b`` happens to exceed ``N_b``.
So the gain is kept only where the motion is significant at the 95 % level::

    g(x) = 0   where   P_b(x) ≤ N_b(x) · χ²_ν⁻¹(0.95) / ν                                                (S3)

**Applied.** Per contiguous stretch of regularly spaced valid samples, by FFT, the stretch extended at both ends
by its point reflection about the rate there (the rate and its slope continue; a mirror image would bend the rate
at the ends), that rate ``ω̂_0`` from a quadratic fitted by least squares to the first ``⌈1/(2B)⌉`` rates (``B`` the
filter's equivalent bandwidth, cycles per step: the span it averages over anyway)::

    b_{−j} = 2 ω̂_0 − b_{j−1},   j = 1 … SEGMENT   (and likewise after the last sample)                  (S4)

The stretch's least-squares line is taken out before the FFT and added back after it, the extension's outer half
falls to zero along a raised cosine (no jump at the zero padding to ring through the filter's edge), and the filter
is interpolated from Welch's frequencies as ``F·sinc``, then divided by the exact ``sinc`` (tested).

Two or more skipped samples in a row, and a stretch too short to filter (fewer than :data:`MIN_STRETCH` samples),
get SciPy's ``RotationSpline`` through the valid attitudes (status ``predicted`` for the skipped ones).

**Uneven steps** are read by (S8) of :mod:`omegahat.identification.steps`: either every stretch is filtered with
the samples' mean step, or each step is used as stamped and a step 5 % or more off the median ends the stretch whose
rates are kept (the rotation spline, exact at uneven times, takes what is too short to filter). The filter runs on
through that step as far as the samples are linked (within 50 % of the median), so a kept stretch's end is filtered
with the log's own increments beyond it, not with (S4)'s extension (S8'). **A single missing sample**
between two present ones (a dropped frame, a spike treated as missing) is bridged (S9, same module) for the
filter, not for the spectrum: cutting the filter's stretch there would leave two ends, where the extension (S4)
errs more than the filter does inside.

**The fold.** Sampling folds the rate's spectrum above the Nyquist frequency onto the band: the component at
``2π − x`` shows in ``b`` at ``x`` with the gain ``sinc_a(x) = sinc((2π − x)/2)`` and, against the rate at the
samples, with the opposite sign, so (S2)'s inverse of the interval mean amplifies what it should shrink. Nothing in
the samples separates the fold from the motion at ``x``, but a body's rate spectrum leaves the band as it reaches
its edge: ``S_N = π²/8 · P_s(π)`` at the Nyquist frequency (base and fold alike there; ``P_s = P_b − N_b`` where
significant, the median over ``0.45 ≤ f < 0.5`` cycles per step), falling beyond it with the decay ``p ≥ 0`` of
``log(P_s/sinc²)`` against ``log f`` over ``0.35 ≤ f < 0.5``, and no more than the frequency shows::

    S_a(x) = min( S_N ((2π − x)/π)^−p, P_s(x)/sinc_a²(x) ),    S(x) = (P_s − sinc_a² S_a)/sinc²
    F(x) = e^{ix/2} max(0, sinc(x/2) S − sinc_a S_a) / P_b                                            (S6)

— (S2) where nothing shows near the Nyquist frequency (``S_a = 0``), shrunk towards zero (never inverted) where the
fold may dominate. On written-out power-law spectra the fold so read is 1.06–1.8 times the true one: conservative.

**What it expects.** Per frequency the rate's power less what the filter recovers, integrated over the band::

    E|ω̂ − ω|² = ∫₀^½ [ S + S_a − max(0, sinc S − sinc_a S_a)² / P_b ] df     (where significant)          (S7)

— the filter's own account, from the same spectrum; :class:`omegahat.identification.smoother.ChosenSmoother`
weighs it against the model's smoother's. For the filter ``F`` of (S6) (real, the advance aside) it is the sum of
the errors on the rate in the band, on its fold and on the noise, ``S (sinc F − 1)² + S_a (sinc_a F + 1)² + N_b F²``,
and the command names the fold's part where it is more than a tenth (a figure the samples cannot show,
extrapolated from the band's top)::

    E_a = ∫₀^½ S_a (sinc_a F + 1)² df                                                                   (S7b)

What (S2)–(S6) do not know: a motion whose spectrum changes along the log (filtered with its average spectrum), a
fold that does not continue the band's decay. Measured: ``docs/theory/identification.md``.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike
from scipy import fft
from scipy.spatial.transform import Rotation, RotationSpline
from scipy.special import gammaincinv

from omegahat import measurements as ms
from omegahat import so3
from omegahat.identification.fold import rate_spectra
from omegahat.identification.noise import REGULAR_STEP, quiet_noise
from omegahat.identification.steps import JITTER_LINK, bridged, read_steps, stretches
from omegahat.interface import Measurements

__all__ = [
    "HANN_HALF_OVERLAP",
    "MIN_SEGMENTS",
    "MIN_STRETCH",
    "SEGMENT",
    "SIGNIFICANCE",
    "IncrementSpectrum",
    "SpectralRate",
    "SpectralSmoother",
    "expected_error",
    "increment_spectrum",
    "noise_shape",
    "spectral_rate",
    "stretch_rates",
    "top_noise",
    "welch_density",
    "welch_dof",
    "welch_segment",
    "welch_segments",
    "wiener_filter",
    "wiener_gain",
]

SEGMENT = 256  #: samples per Welch segment at most (S1') (resolution 1/256 of the rate)
MIN_SEGMENTS = 27  #: (S1'): ν = 2K/(1 + 2·0.167²) ≥ 50 Welch segments' dof, each bin's power within ±20 % (1 s.e.)
SIGNIFICANCE = 0.95  #: (S3): a frequency counts as motion where its power is above the noise's 95th percentile
HANN_HALF_OVERLAP = 0.167  #: the correlation of half-overlapping Hann segments (Welch 1967), for (S3)'s ν
MIN_STRETCH = 16  #: the fewest contiguous samples a stretch must have to be filtered
TOP_BAND = 0.05  #: (N3): the band's top tenth, 0.45 … 0.5 cycles per step, bounds the noise


def noise_shape(freq: np.ndarray, h: float) -> np.ndarray:
    """``N_b / σ²`` of (S1) at the normalised frequencies ``freq`` (cycles per sample), one-sided (twice the
    two-sided density), for the step ``h`` s."""
    return 2.0 * 4.0 * np.sin(np.pi * freq) ** 2 / h**2


def _welch_step(segment: int) -> int:
    """Samples from one Welch segment's start to the next's: half overlapping, as SciPy cuts them."""
    return segment - segment // 2


def welch_segments(lengths: list[int], segment: int) -> int:
    """How many half-overlapping Welch segments of ``segment`` samples fit in stretches of ``lengths`` samples."""
    return sum((n - segment) // _welch_step(segment) + 1 for n in lengths if n >= segment)


def welch_density(x: np.ndarray, segment: int) -> tuple[np.ndarray, np.ndarray]:
    """Welch's one-sided spectral density of the columns of ``x (n, 3)`` (unit sampling rate): the mean over
    half-overlapping periodic-Hann segments of ``segment`` samples, each less its mean, of ``2|X(f)|²/Σw²``
    (the DC and Nyquist bins once); ``(freq, P)``. It is ``scipy.signal.welch(x, nperseg=segment, axis=0,
    detrend="constant")`` (the tests compare them), written here because importing ``scipy.signal`` costs a
    command half a second of start-up (it loads ``scipy.stats`` and parses their docstrings)."""
    starts = np.arange(0, x.shape[0] - segment + 1, _welch_step(segment))
    window = 0.5 - 0.5 * np.cos(2.0 * np.pi * np.arange(segment) / segment)
    P = np.zeros((segment // 2 + 1, x.shape[1]))
    for a in starts:  # one segment at a time: a log of millions of rates holds no copy of all its segments
        part = x[a : a + segment]
        P += np.abs(fft.rfft(window[:, None] * (part - part.mean(axis=0)), axis=0)) ** 2
    P *= 2.0 / (starts.size * np.sum(window**2))
    P[0] /= 2.0
    if segment % 2 == 0:
        P[-1] /= 2.0
    return fft.rfftfreq(segment), P


def welch_dof(segments: int) -> float:
    """``ν = 2K/(1 + 2·0.167²)``: the equivalent χ² degrees of freedom of a Welch estimate over ``K`` segments."""
    return 2.0 * segments / (1.0 + 2.0 * HANN_HALF_OVERLAP**2)


def welch_segment(lengths: list[int]) -> int:
    """(S1'): the samples per Welch segment for stretches of ``lengths`` rates: :data:`SEGMENT` (or the longest
    stretch, if shorter), halved while fewer than :data:`MIN_SEGMENTS` segments fit, down to a quarter of it."""
    segment = min(SEGMENT, max(lengths, default=0))
    while segment > SEGMENT // 4 and welch_segments(lengths, segment) < MIN_SEGMENTS:
        segment //= 2
    return segment


def top_noise(freq: np.ndarray, P_b: np.ndarray, h: float, segments: int) -> np.ndarray:
    """``σ_top (3,)`` of (N3): per body axis the most attitude noise (rad) that the spectrum ``P_b (F, 3)`` of
    increments at the normalised frequencies ``freq`` (cycles per sample), averaged over ``segments`` Welch segments
    of the step ``h`` s, allows at 95 % confidence (the mean over the band's top tenth); no bound (``inf``) where
    the segment is too short to have a frequency there."""
    top = (freq >= 0.5 - TOP_BAND) & (freq < 0.5)  # Welch's one-sided estimate halves the Nyquist frequency's bin
    if not top.any():  # segments of fewer than 20 samples (a log of 17 to 20 samples)
        return np.full(P_b.shape[1], np.inf)
    dof = welch_dof(segments) * math.ceil(np.count_nonzero(top) / 2)
    upper = dof / (2.0 * gammaincinv(dof / 2.0, 1.0 - SIGNIFICANCE))  # ν'/χ²_ν'⁻¹(0.05): 1.15 for ν' = 300
    return np.sqrt(upper * np.mean(P_b[top] / noise_shape(freq[top], h)[:, None], axis=0))


def wiener_gain(freq: np.ndarray, P_b: np.ndarray, sigma: ArrayLike, h: float, segments: int) -> np.ndarray:
    """``g`` of (S2)–(S3) at the normalised frequencies ``freq`` (cycles per sample, 0 … 0.5) for the spectrum
    ``P_b (F, 3)`` (one-sided, rad²/s² per cycle per sample) of the increments' rates, averaged over ``segments``
    Welch segments, the noise ``sigma`` rad (one, or one per axis), the step ``h`` s."""
    N_b = noise_shape(freq, h)[:, None] * np.asarray(sigma, dtype=float) ** 2  # (S1)
    dof = welch_dof(segments)
    significant = P_b > N_b * 2.0 * gammaincinv(dof / 2.0, SIGNIFICANCE) / dof  # (S3): the χ²_ν quantile
    with np.errstate(divide="ignore", invalid="ignore"):
        g = np.where(significant, 1.0 - N_b / P_b, 0.0)
    return np.clip(np.nan_to_num(g, nan=0.0, posinf=0.0, neginf=0.0), 0.0, 1.0)


def _cross(freq: np.ndarray, P_b: np.ndarray, g: np.ndarray, N_b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(S6): the rate's spectrum at each frequency (base and fold, ``S + S_a``) and its cross-spectrum with the
    increments (``sinc S − sinc_a S_a``), both ``(F, 3)``, zero where the motion is not significant."""
    sinc, sinc_a = np.sinc(freq)[:, None], np.sinc(1.0 - freq)[:, None]
    base, fold = rate_spectra(freq, P_b, g, N_b)
    return base + fold, sinc * base - sinc_a * fold


def wiener_filter(freq: np.ndarray, P_b: np.ndarray, g: np.ndarray, N_b: np.ndarray) -> np.ndarray:
    """The filter of (S2) with the fold of (S6) without its half-sample advance (which :func:`spectral_rate` applies):
    real and non-negative, ``(F, 3)``, from the spectrum ``P_b``, its gain ``g`` (S3) and the noise's ``N_b``."""
    _, cross = _cross(freq, P_b, g, N_b)
    with np.errstate(divide="ignore", invalid="ignore"):
        F = np.where(g > 0, np.maximum(cross, 0.0) / P_b, 0.0)
    return np.nan_to_num(F, nan=0.0, posinf=0.0, neginf=0.0)


def expected_error(freq: np.ndarray, P_b: np.ndarray, g: np.ndarray, N_b: np.ndarray, fold_only: bool = False) -> float:
    """(S7): the RMS error (rad/s, the three axes together) the filter of (S6) expects on the spectrum ``P_b``: per
    frequency the rate's power less what the filter recovers, ``S + S_a − max(0, sinc S − sinc_a S_a)² / P_b``,
    integrated over the band (Welch's one-sided density: the variance is its integral over 0 … 0.5 cycles per step).
    ``fold_only``: the part (S7b) from the rate above the Nyquist frequency, ``S_a (sinc_a F + 1)²``, which (S6)
    extrapolates from the band's top (module docstring).
    """
    if fold_only:
        _, fold = rate_spectra(freq, P_b, g, N_b)
        left = fold * (np.sinc(1.0 - freq)[:, None] * wiener_filter(freq, P_b, g, N_b) + 1.0) ** 2
    else:
        rate, cross = _cross(freq, P_b, g, N_b)
        with np.errstate(divide="ignore", invalid="ignore"):
            left = np.where(g > 0, rate - np.maximum(cross, 0.0) ** 2 / P_b, 0.0)
    left = np.nan_to_num(np.maximum(left, 0.0), nan=0.0, posinf=0.0)
    return float(np.sqrt(np.sum(left) * (freq[1] - freq[0])))


class SpectralRate(NamedTuple):
    """What :func:`spectral_rate` gives: ``omega (T, 3)`` (body frame, rad/s), the attitude ``noise`` per body axis
    ``(3,)`` it assumed (rad, (N2) capped by (N3)), ``filtered (T,)``: True where (S2) gave the rate (False: the
    rotation spline, for a gap or a stretch too short to filter), ``expected`` the RMS error (S7) expects
    (rad/s; NaN where nothing was filtered), ``jitter`` what (S8) read where a stretch's steps differ from their
    mean by more than 0.1 %: ``"stamps"`` (the samples regular, their stamps jittered), ``"sampling"`` (the samples
    at their stamps), or ``""`` (the steps even), and ``fold`` the part (S7b) of ``expected`` from the rate above
    the Nyquist frequency."""

    omega: np.ndarray
    noise: np.ndarray
    filtered: np.ndarray
    expected: float
    jitter: str = ""
    fold: float = math.nan


class IncrementSpectrum(NamedTuple):
    """What :func:`increment_spectrum` reads of a log: the normalised frequencies ``freq (F,)`` (cycles per step),
    the increments' spectrum ``P_b (F, 3)`` (S1), the gain ``g (F, 3)`` (S2)–(S3), the noise's spectrum
    ``N_b (F, 3)`` and its ``sigma (3,)`` ((N2) capped by (N3)), the step ``h`` (s), what (S8) read (``jitter``),
    the stretches filtered (``runs``) and their ``rates`` (the ``b_k`` of each, ``(m, 3)``), and how many Welch
    ``segments`` the spectrum averages (S1'); ``freq`` is empty where no stretch is long enough to give a spectrum."""

    freq: np.ndarray
    P_b: np.ndarray
    g: np.ndarray
    N_b: np.ndarray
    sigma: np.ndarray
    h: float
    jitter: str
    runs: list[tuple[int, int]]
    rates: list[np.ndarray]
    segments: int = 0

    def with_noise(self, sigma: ArrayLike) -> IncrementSpectrum:
        """The same spectrum read with the attitude noise ``sigma`` (rad, one or one per axis): its (S1) noise
        spectrum and its gain (S2)–(S3)."""
        noise = np.broadcast_to(np.asarray(sigma, dtype=float), self.sigma.shape).copy()
        g = wiener_gain(self.freq, self.P_b, noise, self.h, self.segments)
        return self._replace(g=g, N_b=noise_shape(self.freq, self.h)[:, None] * noise**2, sigma=noise)


def increment_spectrum(t: np.ndarray, R: np.ndarray, valid: np.ndarray) -> IncrementSpectrum:
    """(S1), (S3), (N2), (N3) and (S8) of the attitudes ``R (T, 3, 3)`` at the times ``t (T,)`` (used where
    ``valid``)."""
    R = np.where(valid[:, None, None], R, np.nan)
    phi = so3.increments(R)  # (T − 1, 3), NaN across a skipped sample
    quiet = quiet_noise(t[valid], so3.increments(R[valid]), higher=True)  # (N2)
    quiet = 0.0 if not math.isfinite(quiet) else quiet
    h = float(np.median(np.diff(t)))  # the step of the stretches (a gap does not lengthen it)
    jitter, mean_step = read_steps(t, phi, [(a, b) for a, b in stretches(t, valid) if b - a >= MIN_STRETCH])
    if jitter == "stamps":  # the samples' own step (a median of rounded stamps is one of the roundings)
        h = mean_step
    long_runs, rates = stretch_rates(t, phi, valid, h, jitter)
    segment = welch_segment([r.shape[0] for r in rates])
    usable = [r for r in rates if r.shape[0] >= segment]
    if not usable or segment < 8:
        none = np.zeros((0, 3))
        return IncrementSpectrum(np.zeros(0), none, none, none, np.full(3, quiet), h, jitter, long_runs, rates)
    spectra = [welch_density(r, segment) for r in usable]
    freq = spectra[0][0]
    weights = np.array([r.shape[0] for r in usable], dtype=float)
    P_b = np.einsum("s,sfj->fj", weights, np.stack([p for _, p in spectra])) / weights.sum()
    segments = welch_segments([r.shape[0] for r in usable], segment)
    sigma = np.minimum(quiet, top_noise(freq, P_b, h, segments))  # (N2) capped by (N3); (S5) retired (docstring)
    g = wiener_gain(freq, P_b, sigma, h, segments)
    N_b = noise_shape(freq, h)[:, None] * sigma**2
    return IncrementSpectrum(freq, P_b, g, N_b, sigma, h, jitter, long_runs, rates, segments)


def stretch_rates(
    t: np.ndarray, phi: np.ndarray, valid: np.ndarray, h: float, jitter: str
) -> tuple[list[tuple[int, int]], list[np.ndarray]]:
    """The stretches of at least :data:`MIN_STRETCH` ``valid`` samples, linked as (S8) reads the steps ``jitter``
    (``"sampling"``: each step as stamped, one 5 % or more off the median breaks the stretch; ``"linked"``: each
    step as stamped, linked as regular ones are, (S8')), and their ``b_k`` (S1) from the increments
    ``φ (T − 1, 3)``: over each step, or over the samples' step ``h`` (``"stamps"``)."""
    runs = [(a, b) for a, b in stretches(t, valid, REGULAR_STEP if jitter == "sampling" else JITTER_LINK)]
    runs = [(a, b) for a, b in runs if b - a >= MIN_STRETCH]
    return runs, [phi[a : b - 1] / (h if jitter == "stamps" else np.diff(t[a:b])[:, None]) for a, b in runs]


def spectral_rate(t: np.ndarray, R: np.ndarray, valid: np.ndarray) -> SpectralRate:
    """ω̂ of (S2) at the times ``t (T,)`` from the attitudes ``R (T, 3, 3)`` (used where ``valid``)."""
    T = t.size
    omega = np.full((T, 3), np.nan)
    if np.count_nonzero(valid) < 2:
        raise ValueError(f"the smoother needs at least 2 valid attitude samples; got {int(np.count_nonzero(valid))}")
    spectrum = increment_spectrum(t, R, valid)
    freq, P_b, g, N_b = spectrum.freq, spectrum.P_b, spectrum.g, spectrum.N_b
    expected = fold = math.nan
    covered = np.zeros(T, dtype=bool)
    if freq.size:
        F = wiener_filter(freq, P_b, g, N_b)
        expected = expected_error(freq, P_b, g, N_b)
        fold = expected_error(freq, P_b, g, N_b, fold_only=True)
        # the width the filter averages over, ~1 / (2B) steps for its equivalent bandwidth B (cycles per step)
        bandwidth = float(np.max(np.sum(g, axis=0) * (freq[1] - freq[0])))
        edge = int(np.clip(round(0.5 / max(bandwidth, 1e-9)), 3, SEGMENT))
        runs, rates = spectrum.runs, spectrum.rates
        filled, used = bridged(t, R, valid)  # (S9): the filter's stretches go through a single missing sample
        if used is not valid or spectrum.jitter == "sampling":
            phi = so3.increments(np.where(used[:, None, None], filled, np.nan))
            runs, rates = stretch_rates(t, phi, used, spectrum.h, spectrum.jitter)
        inside = np.zeros(T, dtype=bool)  # the stretches' samples: where the filter's rates are written
        for a, b in runs:
            inside[a:b] = True
        if spectrum.jitter == "sampling":  # (S8'): the filter runs on through the steps that end those stretches
            runs, rates = stretch_rates(t, phi, used, spectrum.h, "linked")
        for (a, b), r in zip(runs, rates, strict=True):
            if not inside[a:b].any():
                continue
            steps = np.full(r.shape[0], spectrum.h) if spectrum.jitter == "stamps" else np.diff(t[a:b])
            first = _filtered(r, freq, F, min(edge, r.shape[0]))
            # (S1c): the increments less their coning term (M1), from the first pass's rates, filtered again
            rate = _filtered(r - so3.coning(first[:-1], first[1:], steps), freq, F, min(edge, r.shape[0]))
            omega[a:b] = np.where(inside[a:b, None], rate, np.nan)
            covered[a:b] = inside[a:b]
    if not covered.all():  # skipped samples and short stretches: the rotation spline through the valid attitudes
        spline = RotationSpline(t[valid], Rotation.from_matrix(R[valid]))
        omega[~covered] = spline(t[~covered], 1)
    return SpectralRate(omega, spectrum.sigma, covered, expected, spectrum.jitter, fold)


def _filtered(rates: np.ndarray, freq: np.ndarray, F: np.ndarray, edge: int) -> np.ndarray:
    """(S2) on one stretch: ``rates (m, 3)`` the ``b_k`` between its ``m + 1`` samples; returns ω̂ at the samples
    ``(m + 1, 3)`` (the last ``m`` by the half-sample advance, the first by the half-sample delay). The stretch is
    extended at each end by its point reflection (S4) about the rate there (a quadratic fitted to ``edge`` rates)."""
    m = rates.shape[0]
    pad = min(m, SEGMENT)
    first = _edge_rate(rates[:edge])
    last = _edge_rate(rates[::-1][:edge])
    before = 2.0 * first - rates[pad - 1 :: -1]
    after = 2.0 * last - rates[::-1][:pad]
    extended = np.concatenate([before, rates, after])
    # the stretch's least-squares line is taken out and added back (at the samples, half a step after each rate):
    # the extension then ends near zero and the FFT's zero padding continues it without a jump in level, whose
    # ringing under a sharp gain would otherwise reach far into the stretch (measured: a bias of 1.6e-4 rad/s on the
    # constant axis of a coning motion); the filter's gain of 1 at low frequencies passes a line as is, and a line
    # fitted to the whole stretch is too quiet for its noise to matter where the gain is 1 at zero frequency alone
    slope, level = np.polyfit(np.arange(m, dtype=float), rates, 1) if m > 1 else (np.zeros(3), rates[0])
    start = level - slope * pad  # its value at the extension's first rate
    extended = extended - (start + slope * np.arange(extended.shape[0])[:, None])
    # and the extension's outer half falls to zero along a raised cosine, so the zero padding continues it smoothly
    ramp = np.sin(0.5 * np.pi * np.arange(pad // 2) / max(pad // 2, 1))[:, None] ** 2
    extended[: pad // 2] *= ramp
    extended[extended.shape[0] - pad // 2 :] *= ramp[::-1]
    n = fft.next_fast_len(extended.shape[0], real=True)
    spectrum = fft.rfft(extended, n=n, axis=0)
    f = fft.rfftfreq(n)
    # the filter's part beyond the inverse of the interval mean, F·sinc (1 where the motion dominates), interpolated
    # to this grid, and 1/sinc exactly: interpolating F itself between Welch's frequencies errs by ~(π Δf)²/24 at low
    # frequencies, where the motion is (4e-6 rad/s of a 1.2 rad/s turn at 100 Hz, noise-free)
    passed = F * np.sinc(freq)[:, None]
    gain = np.stack([np.interp(f, freq, passed[:, j]) for j in range(3)], axis=1) / np.sinc(f)[:, None] * spectrum
    half = np.exp(1j * np.pi * f)[:, None]  # e^{ix/2}: half a sample later
    later = fft.irfft(gain * half, n=n, axis=0)[pad : pad + m] + start + slope * (pad + 0.5 + np.arange(m))[:, None]
    earlier = fft.irfft(gain / half, n=n, axis=0)[pad : pad + 1] + start + slope * (pad - 0.5)
    return np.concatenate([earlier, later])


def _edge_rate(rates: np.ndarray) -> np.ndarray:
    """The rate at the sample before ``rates[0]`` (half a step before its midpoint): the least-squares quadratic
    through ``rates`` (one step apart), evaluated there."""
    k = np.arange(rates.shape[0]) + 0.5  # the midpoints, in steps after the sample
    if k.size < 3:
        return rates[0]
    A = np.column_stack([np.ones_like(k), k, k**2])
    coef = np.linalg.lstsq(A, rates, rcond=None)[0]
    return coef[0]


class SpectralSmoother(ms.AttitudeBatchEstimator):
    """The log's own Wiener smoother (S2) behind the estimator contract: offline only (``run``), ``causal = False``.

    After ``run``: ``measurement_noise`` (the σ per body axis it assumed, rad, (N2) capped by (N3)) and
    ``n_unfiltered`` (the valid samples in stretches too short to filter, which take the rotation spline) and
    ``timestamps`` (what (S8) read of uneven steps: ``"stamps"``, ``"sampling"`` or ``""`` for even ones). A
    single skipped sample is bridged by (S9) and filtered, a longer gap by the rotation spline (status ``predicted``).

    Parameters
    ----------
    references, scalar_first, rotation_tol, quat_norm_tol : optional
        As every batch estimator of attitudes (:class:`omegahat.measurements.AttitudeBatchEstimator`): the inertial
        directions of direction input (each sample's least-squares attitude is filtered), the quaternion order and
        the input checks' tolerances.

    Examples
    --------
    A body turning at a constant rate, sampled at 100 Hz with 1 mrad of attitude noise:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat.identification.spectral import SpectralSmoother
    >>> rng = np.random.default_rng(0)
    >>> t = np.arange(0.0, 20.0, 0.01)
    >>> noise = Rotation.from_rotvec(1e-3 * rng.standard_normal((t.size, 3)))  # 1 mrad
    >>> R = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise
    >>> est = SpectralSmoother()
    >>> omega = est.run(t, R.as_quat()).omega
    >>> print(" ".join(f"{x:.1f}" for x in omega[1000]), f"{1e3 * est.measurement_noise.max():.0f} mrad")
    0.3 -0.2 0.5 1 mrad
    """

    def __init__(
        self,
        *,
        references: ArrayLike | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
    ) -> None:
        super().__init__(
            references=references, scalar_first=scalar_first, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol
        )
        self.measurement_noise = np.full(3, math.nan)  # the σ per body axis the last ``run`` assumed (rad, (N2)/(N3))
        self.n_unfiltered = 0  # valid samples of the last ``run`` in stretches too short to filter
        self.timestamps = ""  # (S8) on the last ``run``'s uneven steps: "stamps", "sampling" or "" (even)
        self.expected_rms = math.nan  # the RMS error (S7) the last ``run`` expected (rad/s)
        self.fold_rms = math.nan  # its part (S7b) from the rate above the Nyquist frequency (rad/s)

    def rates(self, log: ms.CheckedLog, data: Measurements) -> np.ndarray:
        """(S2) at the log's times; sets :attr:`measurement_noise`, :attr:`n_unfiltered`, :attr:`expected_rms` and
        :attr:`fold_rms`."""
        found = spectral_rate(log.times, log.values, log.valid)
        self.measurement_noise = found.noise
        self.n_unfiltered = int(np.count_nonzero(log.valid & ~found.filtered))
        self.expected_rms, self.fold_rms = found.expected, found.fold
        self.timestamps = found.jitter
        return found.omega
