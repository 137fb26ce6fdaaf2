r"""The log's own causal filter of backward differences: the default where no model describes the log.

Backward differencing, ``b_k = Log(R_{k−1}ᵀ R_k) / h``, is the rate over the last interval, delayed by half a step:
the estimate a filter of the log's motion must beat, and the one the default ran wherever the identification
declines every model (every real recording of the development corpus). The spectrum the offline Wiener smoother
reads from the log (:mod:`omegahat.identification.spectral`, (S1)–(S6)) also says how much of ``b`` is noise at each
frequency; a causal filter of the last ``L`` differences can take some of it out without a model.

**The filter.** Per body axis, with the same target and delay as differencing, the rate at the last interval's
midpoint ``t_k − h/2``::

    ω̂_k = Σ_{j<L} c_j b_{k−j},     H(f) = Σ_j c_j e^{−2πi f j}                                          (C1)

**Its error, per frequency** ``f`` (cycles per step). At the intervals' midpoints ``b`` carries the rate in the band
with the interval mean's gain ``sinc(f)``, the rate folded from beyond the Nyquist frequency with ``sinc(1 − f)``
(the same sign there), and the noise of (S1); with ``S``, ``S_a`` of (S6) and the increments' measured spectrum
``P_b = sinc² S + sinc_a² S_a + N_b``::

    E_H(f) = S |sinc H − 1|² + S_a |sinc_a H − 1|² + N_b |H|²
           = |H|² P_b − 2 Re H · (sinc S + sinc_a S_a) + S + S_a                                           (C2)

and differencing's ``E_1`` is (C2) with ``H ≡ 1``.

**The design.** The least total error that is no worse than differencing's in any low-pass band, and that passes a
constant rate as it is (Welch's estimate is of the increments less their mean, so the spectrum alone does not see
the mean rate)::

    minimise ∫₀^½ E_H df   subject to   ∫₀^F E_H df ≤ ∫₀^F E_1 df  for every F,   H(0) = Σ_j c_j = 1       (C3)

The band constraint is what makes the filter safe to run by default. The unconstrained optimum (the causal Wiener
filter) lowers the error over the whole band by trading accuracy at low frequencies, where differencing's error is
small, for less noise at high ones: a user who low-passes the rate, or a score that compares it in a band, would
then see more error than differencing's. A constraint at every frequency instead (``E_H ≤ E_1`` for each ``f``)
leaves differencing itself. What each gives on the development recordings: ``docs/theory/identification.md``.

**Under every reading the log allows.** Two parts of (C2)'s spectra are read, not measured: the noise ``N_b``
(``σ`` of (N2) capped by (N3): the noise where part of the log is quiet, only an upper bound where the body never
rests, as a trembling hand's motion reads as noise), and the fold ``S_a``, which (S6) extrapolates from the band's
top. The samples cannot tell either from the motion in the band. So (C3)'s band constraint is imposed under each of
four readings of the same measured ``P_b``, the ends of what it allows, and the total error is minimised under the
identified one (the first)::

    (σ, S_a) ∈ { (σ, S_a of (S6)),  (σ, 0),  (σ_least, S_a of (S6)),  (σ_least, 0) }                       (C4)

(no fold: ``S = P_s / sinc²``, all the motion in the band). The noise cannot be bounded below without a premise
about the motion, and the premise taken is the one (S6) already makes: a body's rate spectrum does not leave the
band rising. White noise does (its rate equivalent rises as ``f²``), so the least noise is the least under which
what is left of the spectrum is shown to fall::

    σ_least = min{ σ' ∈ [0, σ] : β(σ') < −z₀.₉₅ s_β },   β(σ') the slope of log((P_b − σ'² N_b/σ²) / sinc²)
              against log f over 0.35 ≤ f < 0.5,   s_β² = 2 ψ'(ν/2) / Σ (log f − mean log f)²               (C5)

(``σ`` itself where no ``σ'`` is; ``s_β`` the slope's standard error under Welch's scatter: each bin's log-power
has the variance ``ψ'(ν/2)`` of ``log χ²_ν/ν``, and only every other bin is free). A filter that gains only by
calling motion noise, or by undoing a fold that is not there, is then not run. On a noise-free body trembling about
one axis at 30 Hz (forty lines from 3 Hz up) the quiet part reads 0.57 mrad of noise with lines up to 14.5 Hz and
0.30 mrad up to 13.5 Hz; under that reading alone the filter had 0.63 and 0.75 times differencing's error in total,
but 2.9 and 32 times in a low band; under (C4) it is no worse than differencing (to 0.5 % in total and 2 % in
every band). On a turn under 3 mrad of white noise
(C5) reads the identified 3 mrad and the filter keeps its gain (all tested). Without ``s_β``, a sign test of the
slope read 0.13 mrad and 0 on two axes of 2 s of white noise at 100 Hz (25 frequencies). Between the ends, (C2) is
linear in the noise's share for a fixed fold; (S6)'s fold is not linear in it, so the ends are what is checked.

Solved by SciPy's SLSQP from ``H ≡ 1`` (which satisfies (C3) with equality), one body axis at a time on Welch's
frequency grid, over ``c = e_0 + M z`` (``M``'s columns sum to zero: ``Σ_j c_j = 1`` for every ``z``, with no
equality constraint for SLSQP to meet). A solution that misses (C3) by more than 10⁻⁶ of differencing's error is
drawn towards ``H ≡ 1`` (its step from there halved, up to three times), else is differencing itself.

**What it expects.** (C2) over the whole band, ``expected_rms``, is the error ``omegahat estimate`` prints for what
runs; over ``0 … F`` (:func:`expected_rms_below`) it is what a user who low-passes the rate at ``F`` would see.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy import optimize
from scipy.special import ndtri, polygamma

from omegahat.identification.fold import UPPER, fold_remark, leaving_slope, rate_spectra
from omegahat.identification.spectral import SIGNIFICANCE, IncrementSpectrum, noise_shape, welch_dof

__all__ = [
    "TAPS",
    "CausalFilter",
    "causal_filter",
    "expected_rms_below",
    "least_noise",
    "model_to_differencing",
    "readings",
]

TAPS = 16  #: L of (C1): the differences the filter spans
BISECTIONS = 40  #: halvings of (C5)'s interval of noise variance: to 1e-12 of the identified one
_SLACK = 1e-6  #: (C3) is met where no band's error exceeds differencing's by more than this fraction of its total


class CausalFilter(NamedTuple):
    """What :func:`causal_filter` designs: ``taps (L, 3)`` of (C1) per body axis (``taps[0]`` the newest
    difference's), and the total error (C2) it expects, ``expected_rms``, and differencing's, ``differencing_rms``,
    by the same spectrum (rad/s, the three axes together); ``fold_rms``: the part of ``expected_rms`` from the rate
    above the Nyquist frequency (the ``S_a`` term of (C2)), which (S6) extrapolates from the band's top."""

    taps: np.ndarray
    expected_rms: float
    differencing_rms: float
    fold_rms: float = math.nan

    def describe(self) -> str:
        """The line ``omegahat estimate`` adds after "backward differencing runs (...)": what runs and the RMS error
        (C2) expects of it, the estimate's own self-assessment (the figures printed above it are the model's)."""
        if not math.isfinite(self.expected_rms):
            return "\n  the log gives no spectrum for a causal filter (C3): the differences as they are"
        expected = f"expected RMS error {self.expected_rms:.3g} rad/s by the log's spectrum"
        expected += fold_remark(self.expected_rms, self.fold_rms)  # the samples cannot show it: how much is read
        if self.is_differencing:
            return (
                "\n  the log's causal filter (C3) finds no band to gain in: the differences as they are, "
                f"{expected} (the figures above are the model's account)"
            )
        return (
            f"\n  through the log's causal filter (C3): {expected}, {self.expected_rms / self.differencing_rms:.2g} "
            f"times differencing's ({self.differencing_rms:.3g} rad/s) by the same account (the figures above are "
            "the model's), and no more in any band from 0 Hz up"
        )

    @property
    def is_differencing(self) -> bool:
        """True where the design kept differencing itself (``H ≡ 1``)."""
        return bool(np.all(self.taps[0] == 1.0) and np.all(self.taps[1:] == 0.0))


def _density(re: np.ndarray, im: np.ndarray, P_b: np.ndarray, cross: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(C2) at each frequency for ``H = re + i·im``, with ``cross = sinc S + sinc_a S_a`` and ``target = S + S_a``."""
    return (re**2 + im**2) * P_b - 2.0 * re * cross + target


def _cross_target(freq: np.ndarray, base: np.ndarray, fold: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``sinc S + sinc_a S_a`` and ``S + S_a`` of (C2), for the rate in the band ``base`` and folded ``fold``
    (``(F,)``, or ``(F, 3)`` per body axis)."""
    shape = (-1,) + (1,) * (np.ndim(base) - 1)
    return np.sinc(freq).reshape(shape) * base + np.sinc(1.0 - freq).reshape(shape) * fold, base + fold


def _trapezoid(freq: np.ndarray) -> np.ndarray:
    """The trapezoid rule's weights on Welch's grid, 0 … ½ cycles per step."""
    weight = np.full(freq.size, freq[1] - freq[0])
    weight[[0, -1]] *= 0.5
    return weight


def least_noise(spectrum: IncrementSpectrum) -> np.ndarray:
    """(C5): per body axis ``(3,)``, the least attitude noise (rad) the log's spectrum allows, up to its identified
    ``σ``: the smallest ``σ'`` under which the motion left, ``P_b − σ'² N_b/σ²``, is shown to leave the band falling
    (:func:`omegahat.identification.fold.leaving_slope` below zero by more than Welch's scatter allows at the 95 %
    level), by bisection on ``σ'²``; ``σ`` itself where none is."""
    freq, P_b = spectrum.freq, spectrum.P_b
    shape = noise_shape(freq, spectrum.h)
    upper = (freq >= UPPER[0]) & (freq < UPPER[1])
    spread = float(np.sum((np.log(freq[upper]) - np.mean(np.log(freq[upper]))) ** 2)) if upper.any() else 0.0
    # the slope's standard error: each bin's log-power has variance ψ'(ν/2) (Welch's χ²_ν/ν), every other bin free
    error = math.sqrt(2.0 * float(polygamma(1, welch_dof(spectrum.segments) / 2.0)) / spread) if spread else math.inf
    margin = float(ndtri(SIGNIFICANCE)) * error
    least = np.array(spectrum.sigma, dtype=float)
    for axis, sigma in enumerate(spectrum.sigma):

        def rising(variance: float, axis: int = axis) -> bool:  # not shown to fall
            motion = np.maximum(P_b[:, axis] - variance * shape, 0.0)
            return bool(leaving_slope(freq, motion[:, None])[0] > -margin)

        if not rising(0.0):  # all of the spectrum may be motion
            least[axis] = 0.0
            continue
        low, high = 0.0, float(sigma) ** 2
        if rising(high):  # not shown to fall even under the identified noise: none less is allowed
            continue
        for _ in range(BISECTIONS):
            low, high = (0.5 * (low + high), high) if rising(0.5 * (low + high)) else (low, 0.5 * (low + high))
        least[axis] = math.sqrt(high)
    return least


def readings(spectrum: IncrementSpectrum) -> list[tuple[np.ndarray, np.ndarray]]:
    """(C4): the rate's spectra ``(S, S_a)``, each ``(F, 3)``, of the four readings of the log's spectrum, the
    identified one first: with the identified noise or the least (C5), with the fold of (S6) or none."""
    least = spectrum.with_noise(least_noise(spectrum))
    return [rate_spectra(s.freq, s.P_b, s.g, s.N_b, fold=fold) for s in (spectrum, least) for fold in (True, False)]


def _design(
    freq: np.ndarray, P_b: np.ndarray, spectra: list[tuple[np.ndarray, np.ndarray]], length: int
) -> tuple[np.ndarray, float, float]:
    """(C3) under (C4) for one body axis, the readings ``spectra`` (``(S, S_a)``, each ``(F,)``, the identified one
    first): the taps ``(L,)`` and the integrals of (C2) over the band for them and for ``H ≡ 1`` by the first."""
    j = np.arange(length)
    cos, sin = np.cos(2 * np.pi * np.outer(freq, j)), np.sin(2 * np.pi * np.outer(freq, j))
    weight = _trapezoid(freq)
    terms = [_cross_target(freq, base, fold) for base, fold in spectra]
    total = float(np.sum(weight * _density(np.ones(1), np.zeros(1), P_b, *terms[0])))  # differencing's: H ≡ 1
    if not total > 0.0:
        return np.eye(length)[0], 0.0, 0.0
    weight = weight / total  # in units of differencing's error: SLSQP's tolerances are absolute

    def error(c: np.ndarray, cross: np.ndarray, target: np.ndarray) -> np.ndarray:  # (C2) at every frequency
        return weight * _density(cos @ c, sin @ c, P_b, cross, target)

    def error_gradient(c: np.ndarray, cross: np.ndarray) -> np.ndarray:  # (F, L)
        re, im = cos @ c, sin @ c
        return weight[:, None] * (
            2.0 * (cos * (re * P_b)[:, None] + sin * (im * P_b)[:, None]) - 2.0 * cos * cross[:, None]
        )

    identity = np.eye(length)[0]
    differencing = [np.cumsum(error(identity, *term)) for term in terms]
    # c = e_0 + M z: every z keeps Σ c_j = 1, H(0) = 1 (an equality constraint made SLSQP stall on real logs)
    M = np.vstack([-np.ones(length - 1), np.eye(length - 1)])
    bounds = [  # (C3) under each reading of (C4)
        {
            "type": "ineq",
            "fun": lambda z, term=term, limit=limit: limit - np.cumsum(error(identity + M @ z, *term)),
            "jac": lambda z, term=term: -np.cumsum(error_gradient(identity + M @ z, term[0]), axis=0) @ M,
        }
        for term, limit in zip(terms, differencing, strict=True)
    ]
    result = optimize.minimize(
        lambda z: float(np.sum(error(identity + M @ z, *terms[0]))),
        np.zeros(length - 1),
        jac=lambda z: np.sum(error_gradient(identity + M @ z, terms[0][0]), axis=0) @ M,
        constraints=bounds,
        method="SLSQP",
        options={"maxiter": 200, "ftol": 1e-10},
    )
    step = M @ np.asarray(result.x, dtype=float)
    for shrink in (1.0, 0.5, 0.25, 0.125, 0.0):  # a solution that stopped just outside (C3): drawn towards H ≡ 1
        c = identity + shrink * step
        met = all(
            np.all(np.cumsum(error(c, *term)) <= limit + _SLACK)
            for term, limit in zip(terms, differencing, strict=True)
        )
        if np.all(np.isfinite(c)) and met:
            break
    return c, float(np.sum(error(c, *terms[0]))) * total, float(differencing[0][-1]) * total


def causal_filter(spectrum: IncrementSpectrum, length: int = TAPS) -> CausalFilter:
    """(C3) for the log whose spectrum is ``spectrum`` (:func:`omegahat.identification.spectral.increment_spectrum`):
    differencing itself (``H ≡ 1``) where the log gives no spectrum, or where its samples were taken at uneven times
    ((S8) reads ``"sampling"``: (C1) weighs the differences as if one step apart)."""
    identity = np.zeros((length, 3))
    identity[0] = 1.0
    if spectrum.freq.size < 3 or spectrum.jitter == "sampling" or not np.all(np.isfinite(spectrum.P_b)):
        return CausalFilter(identity, math.nan, math.nan)
    spectra = readings(spectrum)
    taps, mine, theirs = identity.copy(), 0.0, 0.0
    for axis in range(3):
        axis_spectra = [(base[:, axis], fold[:, axis]) for base, fold in spectra]
        c, e_h, e_1 = _design(spectrum.freq, spectrum.P_b[:, axis], axis_spectra, length)
        taps[:, axis] = c
        mine, theirs = mine + e_h, theirs + e_1
    fold_rms = expected_rms_below(spectrum, taps, 0.5, fold_only=True)
    return CausalFilter(taps, math.sqrt(max(mine, 0.0)), math.sqrt(max(theirs, 0.0)), fold_rms)


def expected_rms_below(spectrum: IncrementSpectrum, taps: np.ndarray, band: float, fold_only: bool = False) -> float:
    """The RMS error (rad/s, the three axes together) that (C2) expects of the taps ``(L, 3)`` of (C1) in the band
    0 … ``band`` (cycles per step; ½ gives the filter's ``expected_rms``): the error a user who low-passes the
    rate, or a score that compares it in a band, would see by the log's spectrum. ``fold_only``: its ``S_a`` term
    alone, ``S_a |sinc_a H − 1|²``, the part from the rate above the Nyquist frequency. NaN without a spectrum."""
    if spectrum.freq.size < 3 or not np.all(np.isfinite(spectrum.P_b)):
        return math.nan
    freq = spectrum.freq
    base, fold = rate_spectra(freq, spectrum.P_b, spectrum.g, spectrum.N_b)
    weight = _trapezoid(freq) * (freq <= band)
    phase = 2 * np.pi * np.outer(freq, np.arange(taps.shape[0]))
    total = 0.0
    if fold_only:  # (C2) of the folded rate alone: its share of P_b and no rate in the band
        base, P_b = np.zeros_like(base), np.sinc(1.0 - freq)[:, None] ** 2 * fold
    else:
        P_b = spectrum.P_b
    for axis in range(3):
        cross, target = _cross_target(freq, base[:, axis], fold[:, axis])
        E = _density(np.cos(phase) @ taps[:, axis], np.sin(phase) @ taps[:, axis], P_b[:, axis], cross, target)
        total += float(np.sum(weight * E))
    return math.sqrt(max(total, 0.0))


def model_to_differencing(spectrum: IncrementSpectrum, response: np.ndarray) -> np.ndarray:
    """Per reading of (C4) ``(4,)``, the RMS error that a filter whose rate responds to the differences as
    ``response (F,)`` (complex, on ``spectrum.freq``: a model's steady-state filter, (K1) of
    :func:`omegahat.identification.likelihood.rate_response`) expects against the rate **at the samples**, as a
    multiple of differencing's against the rate at the intervals' midpoints (``E_1`` of (C2)), over the band::

        E_K(f) = S |sinc e^{−iπf} H_b − 1|² + S_a |sinc_a e^{−iπf} H_b + 1|² + N_b |H_b|²
               = |H_b|² P_b − 2 Re(e^{−iπf} H_b) · (sinc S − sinc_a S_a) + S + S_a                          (K2)

    (at the samples the fold has the opposite sign, (S6)). Each estimate is taken at its own target, as the fair
    score's best shift takes it. NaN without a spectrum or a response."""
    freq = spectrum.freq
    if freq.size < 3 or not np.all(np.isfinite(spectrum.P_b)) or not np.all(np.isfinite(response)):
        return np.full(4, math.nan)
    weight = _trapezoid(freq)[:, None]
    sinc, sinc_a = np.sinc(freq)[:, None], np.sinc(1.0 - freq)[:, None]
    at_samples = (np.exp(-1j * np.pi * freq) * response)[:, None]  # e^{−iπf} H_b
    ratios = []
    for base, fold in readings(spectrum):
        theirs = np.sum(weight * _density(np.ones(1), np.zeros(1), spectrum.P_b, *_cross_target(freq, base, fold)))
        mine = np.sum(
            weight * _density(at_samples.real, at_samples.imag, spectrum.P_b, sinc * base - sinc_a * fold, base + fold)
        )
        ratios.append(math.sqrt(max(float(mine), 0.0) / float(theirs)) if theirs > 0.0 else math.inf)
    return np.array(ratios)
