"""How far any filter of backward differences could go on a corpus, causal or zero-lag: the best one in hindsight.

Run: ``python benchmarks/filter_ceiling.py [DIR]`` (the development corpus's real recordings; ``$OMEGAHAT_CORPUS_DIR``
by default) or ``python benchmarks/filter_ceiling.py --heldout OUT`` (every recording of a held-out corpus).
Writes its section of ``benchmarks/RESULTS.md`` (one per corpus); skips cleanly without a corpus. Each run's time
is in its section of RESULTS.md.

The default ``omegahat estimate`` runs, on every real recording, backward differencing through the log's causal
filter ((C1)–(C5) of :mod:`omegahat.identification.causal`): a filter of the last ``L`` differences
``b_k = Log(R_{k−1}ᵀ R_k) / h`` designed from the log alone. Issue 24 asks it to be 0.95 of backward differencing's
error in geometric mean on recordings nobody tuned on. This benchmark measures what the **best** such filter would
reach, designed with the answer in hand: per recording, per body axis alike, the taps that fit the reference
rate ``g`` in the score's band by least squares::

    ĉ(s) = argmin_c Σ_{k scored} | B[g](t_k + s h) − Σ_{j<L} c_j B[b]_{k−j} |²                             (O1)

with ``B`` the score's zero-phase low-pass (linear, so it commutes with the filter) and ``s`` on a grid of shifts
(the score forgives a constant delay, so a filter may trade one for less noise); each ``ĉ(s)`` is applied to the
raw differences and scored by the fair score (:func:`omegahat.lab.evaluation.broad.score`), and the best is kept,
differencing itself (``c = e₀``) included: least squares in the band is not the score's criterion, and on a few
rows (bursts of large error) no ``ĉ(s)`` scores as well as differencing.
Two families:

- **free**: any taps. Its gain at 0 Hz is free too, so it also fits a scale error of the reference gyroscope,
  which no estimator from attitudes can know;
- **Σ c = 1**: the taps pass a constant rate as it is, as the default's filter does ((C3)'s ``H(0) = 1``): the
  ceiling of a filter that estimates the body's rate rather than the reference's reading of it.

Least squares in the band is not the score, so neither family is the score's exact minimum, and free taps may
score worse than taps summing to 1 (UPenn's rows do).

**Zero-lag, for ``--smooth``** (O2). ``--smooth`` is asked to beat the best of central differencing and
``RotationSpline``, both estimates of the rate *at the samples*. Its family's bound in hindsight: taps on the
differences on both sides of the sample, ``b_{k+j}`` for ``j = −15 … 16`` (``b_k`` is the mean over
``[t_{k−1}, t_k]``, so the window is centred on ``t_k``), summing to 1, fitted to the reference at the sample times
themselves (no shift: the calibration shared by every method has already aligned the clocks)::

    ĉ = argmin_{Σc = 1} Σ_{k scored} | B[g](t_k) − Σ_{j=−15}^{16} c_j B[b]_{k+j} |²                     (O2)

then scored like every method (the fair score still gives it its best shift), with central differencing itself
(``c_0 = c_1 = ½``) as one candidate. A target half a step earlier, the midpoint backward differencing estimates,
would score far better at 10 samples per second (``benchmarks/midpoint_target.py`` says why), but it is a
half-step lag, not a zero-lag rate. Ratios of (O2) are to the best of central differencing and ``RotationSpline``
scored on the same samples.

All are oracles (fitted on the very samples they are scored on, with the reference they are scored against): not
estimators, an upper bound on what a filter of ``L`` differences can show under this score. Samples where ``b``
is 10 times the median distance from ``g`` plus 1 rad/s (a reset or a spike), and two samples either side, are left
out of the fit and are NaN in every estimate, the peers' included, as are the samples within 16 of any of them
or of a missing one (the filters' windows), so that all are scored on the same samples.

**What the reference sees near the band's top** (M): the median over ``0.30 ≤ f < 0.45`` cycles per step of the
reference's power spectrum over the differences' (Welch, 256-sample Hann segments, the three axes summed; the
reference at the intervals' midpoints, where the body moves or not). Near 1 where the differences' power there is
the body's motion, which a gyroscope sees too; far below 1 where it is in the attitudes only (their noise, or a
marker body moving against the phone): what the attitude log alone cannot tell apart, and what a filter of
differences fitted in hindsight removes.

**The shape of what the differences carry beyond the reference** (M2): the median of the power spectrum of
``b − g`` (``g`` at the intervals' midpoints) over ``0.02 ≤ f < 0.07`` cycles per step, over its median near the
band's top (M). White attitude noise alone gives ``sin²(πf)`` there, ``mean sin²`` over the low band over that over
the top (:func:`white_noise_shape`: 0.026); a difference flat in rate (a random walk of the attitude, a jitter
that follows the motion) gives about 1. The reference's own errors (its noise, calibration, clock) count here too.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.ndimage import binary_dilation
from scipy.signal import butter, sosfiltfilt, welch

from midpoint_target import SOURCES
from omegahat.baselines.differencing import log_difference
from omegahat.baselines.spline import spline_rate
from omegahat.identification.causal import TAPS
from omegahat.lab.evaluation.broad import score, score_cutoff_hz
from omegahat.lab.evaluation.corpus import Recording, corpus_dir, group_of, load_recording, recordings
from results_md import geo, machine_line, write_section

SECTION = "## The best causal filter of differences in hindsight (benchmarks/filter_ceiling.py)"
HELDOUT_SECTION = (
    "## The best causal filter of differences in hindsight, held out (benchmarks/filter_ceiling.py --heldout)"
)
SHIFTS = np.arange(-3.0, 0.01, 0.5)  #: s of (O1), samples: the reference at t_k + s h
SEEN_BAND = (0.30, 0.45)  #: (M): cycles per step: 18-27 Hz at 60 Hz
LOW_BAND = (0.02, 0.07)  #: (M2): cycles per step: 1.2-4.2 Hz at 60 Hz
SPIKE_FACTOR, SPIKE_FLOOR = 10.0, 1.0  #: a sample with |b − g| above 10 × median + 1 rad/s is left out
SPIKE_REACH = 2  #: and this many samples either side (central differencing and the spline reach that far)
ZERO_LAG = np.arange(-15, 17)  #: j of (O2): b_{k+j}, a window centred on t_k


def _lagged(x: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """``(T, 3, len(lags))``: column i is ``x`` delayed by ``lags[i]`` samples (advanced if negative; zeros beyond
    the ends)."""
    out = np.zeros((*x.shape, lags.size))
    T = x.shape[0]
    for i, j in enumerate(lags):
        if j >= 0:
            out[j:, :, i] = x[: T - j]
        else:
            out[: T + j, :, i] = x[-j:]
    return out


def _sum_one_fit(A: np.ndarray, target: np.ndarray, anchor: np.ndarray) -> np.ndarray:
    """The taps ``c`` with ``Σ c = 1`` that fit ``A c`` (``A (n, 3, L)``) to ``target (n, 3)`` by least squares:
    ``c = anchor + Z z`` with ``Σ anchor = 1`` and ``Z``'s columns summing to 0 (``e_i − e_0``, ``i ≥ 1``)."""
    L = anchor.size
    basis = np.eye(L)[:, 1:] - np.eye(L)[:, :1]
    z, *_ = np.linalg.lstsq((A @ basis).reshape(-1, L - 1), (target - A @ anchor).reshape(-1), rcond=None)
    return anchor + basis @ z


def ceiling(rec: Recording, taps: int = TAPS) -> dict[str, float]:
    """Backward differencing's score on ``rec`` (rad/s) and (O1)'s two families' scores over it."""
    options = rec.score_options()
    b = log_difference(rec.t, rec.R, scheme="backward")
    ref_t = rec.reference_times
    reference = CubicSpline(ref_t, rec.reference_rates, axis=0)
    g0 = reference(np.clip(rec.t - 0.5 / rec.fs, ref_t[0], ref_t[-1]))
    distance = np.linalg.norm(b - g0, axis=1)
    finite = np.isfinite(distance)
    spike = finite & (distance > SPIKE_FACTOR * np.median(distance[finite]) + SPIKE_FLOOR)
    dropped = binary_dilation(spike, iterations=SPIKE_REACH) if spike.any() else spike
    b[dropped] = np.nan
    ok = np.all(np.isfinite(b), axis=1)
    steady = ok & (rec.t > ref_t[0] + 1) & (rec.t < ref_t[-1] - 1)

    def power(x: np.ndarray) -> np.ndarray:
        return welch(np.where(steady[:, None], x, 0.0), fs=rec.fs, nperseg=256, axis=0)[1].sum(axis=1)

    freq = welch(np.zeros(max(256, rec.t.size)), fs=rec.fs, nperseg=256)[0]
    # every estimate is scored on the same samples: those whose 16 differences either side are all there (the
    # windows of (O1) and (O2)); the score leaves out a second around what it does not get
    complete = ~binary_dilation(~ok, structure=np.ones(2 * taps + 1))

    def scored(estimate: np.ndarray) -> float:
        estimate = np.where(complete[:, None], estimate, np.nan)
        try:
            return score(rec, estimate, **options).rms
        except ValueError:
            return math.inf

    backward = scored(b)
    cutoff = score_cutoff_hz(rec.fs, options.get("cutoff_hz"))
    band = (
        (lambda x: x)
        if cutoff == math.inf
        else (lambda x: sosfiltfilt(butter(4, cutoff, fs=rec.fs, output="sos"), x, axis=0))
    )
    filled = np.where(ok[:, None], b, 0.0)
    filled_band = band(filled)
    # fitted where the differences and the reference are all there, a second from any gap
    inside = (rec.t > ref_t[0] + 1) & (rec.t < ref_t[-1] - 1)
    usable = complete & inside
    fit = rec.movement & ~binary_dilation(~usable, iterations=round(rec.fs))
    fit[:taps] = fit[-taps:] = False  # the windows of (O1) and (O2) reach 16 samples

    def reference_at(shift: float) -> np.ndarray:
        return band(reference(np.clip(rec.t + shift / rec.fs, ref_t[0], ref_t[-1])))[fit]  # (n, 3)

    causal_lags = np.arange(taps)
    X, A = _lagged(filled, causal_lags), _lagged(filled_band, causal_lags)[fit]  # (T, 3, L), (n, 3, L)
    best = {"free": backward, "sum1": backward}  # differencing itself is one of the filters (c = e_0)
    for s in SHIFTS:
        target = reference_at(s)
        free, *_ = np.linalg.lstsq(A.reshape(-1, taps), target.reshape(-1), rcond=None)
        for name, c in (("free", free), ("sum1", _sum_one_fit(A, target, np.eye(taps)[0]))):
            best[name] = min(best[name], scored(X @ c))

    # (O2): zero-lag, against the offline peers on the same samples
    central, spline = log_difference(rec.t, rec.R, scheme="central"), spline_rate(rec.t, rec.R)
    offline = min(scored(central), scored(spline))
    X, A = _lagged(filled, -ZERO_LAG), _lagged(filled_band, -ZERO_LAG)[fit]  # column i: b_{k + ZERO_LAG[i]}
    centred = np.where((ZERO_LAG == 0) | (ZERO_LAG == 1), 0.5, 0.0)  # central differencing: one candidate
    zero_lag = min(scored(X @ centred), scored(X @ _sum_one_fit(A, reference_at(0.0), centred)))
    # What the reference shows of the differences' power near the band's top (M: module docstring)
    near_top = (SEEN_BAND[0] * rec.fs <= freq) & (freq < SEEN_BAND[1] * rec.fs)
    seen = float(np.median(power(g0)[near_top] / power(b)[near_top]))
    low = (LOW_BAND[0] * rec.fs <= freq) & (freq < LOW_BAND[1] * rec.fs)
    error = power(b - g0)
    flat = float(np.median(error[low]) / np.median(error[near_top]))
    return {"backward": backward, **best, "offline": offline, "zero_lag": zero_lag, "seen": seen, "flat": flat}


def white_noise_shape() -> float:
    """(M2)'s value for white attitude noise alone: ``mean sin²(πf)`` over the low band over that near the top."""
    low, top = np.linspace(*LOW_BAND, 1001), np.linspace(*SEEN_BAND, 1001)
    return float(np.mean(np.sin(np.pi * low) ** 2) / np.mean(np.sin(np.pi * top) ** 2))


def spread(values: list[float]) -> str:
    """``median; lowest–highest``."""
    return f"{np.median(values):.3g}; {min(values):.3g}–{max(values):.3g}"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("directory", nargs="?", type=Path, default=None, help="the corpus (default: corpus_dir())")
    parser.add_argument("--heldout", action="store_true", help="every recording of a held-out corpus")
    args = parser.parse_args(argv)
    warnings.simplefilter("ignore")
    directory = args.directory or corpus_dir()
    heldout = args.heldout
    paths = [p for p in recordings(directory) if heldout or group_of(p.stem) in SOURCES]
    if not paths:
        print(f"no corpus in {directory} (benchmarks/corpus.py; $OMEGAHAT_CORPUS_DIR): skipped")
        return 0
    t0 = time.perf_counter()
    ratios: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for path in paths:
        native = load_recording(path)
        for step in [1, *native.meta.get("decimate", [])]:
            rec = native.decimated(step)
            try:
                found = ceiling(rec)
            except ValueError as exc:
                print(f"{rec.name}: not scored ({exc})")
                continue
            cells = ratios[group_of(rec.name)]
            for name in ("free", "sum1"):
                cells[name].append(found[name] / found["backward"])
            cells["zero_lag"].append(found["zero_lag"] / found["offline"])
            cells["seen"].append(found["seen"])
            cells["flat"].append(found["flat"])
            print(
                f"{rec.name}: ÷ backward: free {cells['free'][-1]:.3f}, Σc = 1 {cells['sum1'][-1]:.3f}; zero-lag ÷ "
                f"best offline {cells['zero_lag'][-1]:.3f}; reference "
                f"÷ differences near the top {found['seen']:.3g}; b − g low ÷ top {found['flat']:.3g}",
                flush=True,
            )
    lines = [
        "| group | n | best filter in hindsight, free taps | best filter in hindsight, Σ c = 1 | best zero-lag "
        "filter in hindsight (O2) ÷ best offline peer | reference ÷ differences near the band's top (M), median; "
        "lowest–highest | b − g, low band ÷ top (M2), median; lowest–highest |",
        "| --- | ---: | --- | --- | --- | --- | --- |",
    ]
    for group, cells in sorted(ratios.items()):
        lines.append(
            f"| {group} | {len(cells['free'])} | {geo(cells['free'])} | {geo(cells['sum1'])} | "
            f"{geo(cells['zero_lag'])} | {spread(cells['seen'])} | {spread(cells['flat'])} |"
        )
    names = ("free", "sum1", "zero_lag", "seen", "flat")
    every = {name: [x for cells in ratios.values() for x in cells[name]] for name in names}
    lines.append(
        f"| all | {len(every['free'])} | {geo(every['free'])} | {geo(every['sum1'])} | {geo(every['zero_lag'])} | "
        f"{spread(every['seen'])} | {spread(every['flat'])} |"
    )
    intro = (
        f"{machine_line()} Command: `python benchmarks/filter_ceiling.py{' --heldout OUT' if heldout else ''}` "
        f"({time.perf_counter() - t0:.0f} s). The real recordings of the {'held-out' if heldout else 'development'} "
        f"corpus; cells: the error of the best causal filter of {TAPS} backward differences fitted in hindsight on "
        "the reference ((O1) of the script), over backward differencing's, by the fair score (best shift, "
        "low-passed); geometric mean; lowest–highest. Oracles, not estimators: the bound a filter of differences "
        "can reach under this score. 'Free taps' also fits a scale error of the reference gyroscope; 'Σ c = 1' "
        "passes a constant rate as it is, as the default's filter does. Zero-lag (O2): the best filter of 32 "
        "differences centred on each sample, fitted to the reference at the samples, over the best of central "
        "differencing and RotationSpline on the same samples: the bound of `--smooth`'s family. (M), (M2): the "
        "script's docstring; white "
        f"attitude noise alone gives (M2) = {white_noise_shape():.4f}."
    )
    body = intro + "\n\n" + "\n".join(lines)
    print(body)
    write_section(HELDOUT_SECTION if heldout else SECTION, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
