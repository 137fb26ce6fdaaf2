"""Why the causal filter (C3) can lose to differencing on a real log: two checks, per recording.

Run: ``python benchmarks/filter_loss_causes.py CORPUS_DIR NAME[/STEP] ...`` (recordings of ``benchmarks/corpus.py``;
``STEP`` decimates, as ``real_world.py`` does), or ``python benchmarks/filter_loss_causes.py --all CORPUS_DIR`` for
the first check over every attitude recording of the corpus at every rate it is scored at (below). Prints; writes
nothing. Skips cleanly when a recording is absent.

**Is the filter's expected gain optimistic because it is judged by the spectrum it was designed on?** (C3) of
:mod:`omegahat.identification.causal` designs the filter on the log's spectrum and prints what (C2) expects of it by
that same spectrum. Here each half of the log designs its own filter, and (C2) judges it by the other half's
spectrum (:func:`omegahat.identification.causal.expected_rms_below` over the whole band, against differencing's by
the same spectrum). Where the out-of-sample ratio matches the in-sample one, the design has not fitted the
spectrum's scatter, and a gap between the expected and the measured gain has another cause.

``--all`` does it for every recording as ``omegahat estimate`` designs the filter (on the head it identifies on,
:data:`omegahat.io.choice.IDENTIFY_SAMPLES` rows, split in two halves), beside the filter's measured error over
backward differencing's (the fair score of :func:`omegahat.lab.evaluation.broad.score`; the filter run alone, by
:class:`omegahat.baselines.differencing.DifferencingEstimator`, without the stitching of resets), and asks what a
rule would have done that ran differencing wherever the account by the other half expects no gain in the score's
band (``expected ≥ 1`` for either half's filter).

**Does the reference respond to the motion as the attitude does?** Backward differences ``b`` carry the rate at the
intervals' midpoints with the interval mean's gain ``sinc(f)`` (f in cycles per step) plus the attitude's noise; the
calibrated gyroscope ``g``, interpolated at the midpoints, carries the rate through its own response ``H_g`` plus
its noise. From Welch's spectra of the longest gap-free stretch::

    |H| = sinc(f) |P_gb| / P_bb  =  |H_g| · SNR_b / (1 + SNR_b),     γ² = |P_gb|² / (P_gg P_bb)                (R1)

Noise in the increments lowers ``|H|`` and ``γ²`` alike (to ``SNR_b/(1 + SNR_b)`` with a noise-free gyroscope) and
noise in the gyroscope lowers ``γ²`` only, so ``|H|`` well below ``γ²`` means the reference itself responds less
than the attitude's motion: its own filtering, or a marker body that moves against the sensor. A causal filter that
restores the interval mean's ``sinc`` loss is then scored against a rate that never had it.

**Where in the band is the loss?** Both modes also give the filter's error over differencing's with the score's
low-pass moved down to 8, 6 and 4 Hz (:data:`LOWER_CUTOFFS_HZ`, where below the row's own cut-off): a loss that
goes where the band stops short of the frequencies at which (R1) finds the reference responding less is the
reference's, not the estimate's.
"""

from __future__ import annotations

import itertools
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from scipy.signal import csd, welch

from omegahat.baselines.differencing import DifferencingEstimator, log_difference
from omegahat.identification.causal import TAPS, CausalFilter, causal_filter, expected_rms_below
from omegahat.identification.spectral import increment_spectrum
from omegahat.io.choice import IDENTIFY_SAMPLES
from omegahat.lab.evaluation.broad import score, score_cutoff_hz
from omegahat.lab.evaluation.corpus import load_recording, recordings
from results_md import gmean

BANDS_HZ = (0.5, 2.0, 4.0, 6.0, 8.0, 10.0, 12.0)
LOWER_CUTOFFS_HZ = (8.0, 6.0, 4.0)  #: the score's low-pass moved down (Hz), for where the loss lies


def lower_band_ratios(rec, estimate: np.ndarray, differences: np.ndarray) -> dict[float, float]:
    """The estimate's score over differencing's with the error low-passed at each of :data:`LOWER_CUTOFFS_HZ` below
    the recording's own cut-off."""
    options = rec.score_options()
    own = score_cutoff_hz(rec.fs, options.get("cutoff_hz"))
    return {
        cut: score(rec, estimate, **{**options, "cutoff_hz": cut}).rms
        / score(rec, differences, **{**options, "cutoff_hz": cut}).rms
        for cut in LOWER_CUTOFFS_HZ
        if cut < own
    }


def longest_run(ok: np.ndarray) -> slice:
    """The longest stretch of True in ``ok``."""
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    starts, ends = edges[::2], edges[1::2]
    k = int(np.argmax(ends - starts)) if starts.size else 0
    return slice(int(starts[k]), int(ends[k])) if starts.size else slice(0, 0)


def response(path: Path, step: int) -> list[tuple[float, float, float, float]]:
    """``(low, high, |H|, γ²)`` per band of (R1) for the recording at ``path`` decimated by ``step``."""
    rec = load_recording(path).decimated(step)
    h = 1.0 / rec.fs
    b = log_difference(rec.t, rec.R, scheme="backward")
    at = np.clip(rec.t - 0.5 * h, rec.reference_times[0], rec.reference_times[-1])
    g = CubicSpline(rec.reference_times, rec.reference_rates, axis=0)(at)
    run = longest_run(np.all(np.isfinite(b), axis=1))
    b, g = b[run], g[run]
    segment = min(256, b.shape[0] // 4)
    f, P_bb = welch(b, fs=rec.fs, nperseg=segment, axis=0)
    _, P_gg = welch(g, fs=rec.fs, nperseg=segment, axis=0)
    _, P_gb = csd(g, b, fs=rec.fs, nperseg=segment, axis=0)
    coherence = np.abs(P_gb) ** 2 / (P_gg * P_bb)
    total = P_bb.sum(axis=1)
    gain = np.sinc(f / rec.fs) * P_gb.sum(axis=1) / total
    rows = []
    for low, high in itertools.pairwise(BANDS_HZ):
        m = (f >= low) & (f < high)
        if not m.any() or high > 0.5 * rec.fs:
            continue
        weight = total[m] / total[m].sum()  # power-weighted over the band and the axes
        share = P_bb[m] / total[m][:, None]
        rows.append(
            (low, high, float(abs(np.sum(weight * gain[m]))), float(np.sum(weight[:, None] * share * coherence[m])))
        )
    return rows


def halves(t: np.ndarray, R: np.ndarray, valid: np.ndarray, band: float = 0.5) -> tuple[CausalFilter, list]:
    """(C3)'s filter of the log ``(t, R)`` (used where ``valid``), and per half of it ``(in-sample, judged)``: the
    ratio to differencing (C2) expects of the half's own filter by its own spectrum (the whole band), and by the other
    half's spectrum in the band 0 … ``band`` (cycles per step)."""
    identity = np.zeros((TAPS, 3))
    identity[0] = 1.0
    whole = causal_filter(increment_spectrum(t, R, valid))
    parts = [slice(0, t.size // 2), slice(t.size // 2, None)]
    spectra = [increment_spectrum(t[p], R[p], valid[p]) for p in parts]
    out = []
    for mine, other in ((0, 1), (1, 0)):
        design = causal_filter(spectra[mine])
        judged = expected_rms_below(spectra[other], design.taps, band) / expected_rms_below(
            spectra[other], identity, band
        )
        out.append((design.expected_rms / design.differencing_rms, judged))
    return whole, out


def cross_validated(corpus: Path) -> int:
    """``--all``: per scored rate of every attitude recording where (C3) keeps a filter, the measured ratio, the
    expected one (whole band) and the score's band's expected ratio by each half's filter judged by the other half;
    then the summary (geometric means, and the rule of the module docstring)."""
    rows, kept_differencing = [], 0
    lower: list[dict[float, float]] = []  # per row, the ratio with the low-pass moved down
    for path in recordings(corpus):
        rec = load_recording(path)
        if rec.kind != "quaternion" or rec.meta.get("truth"):  # a simulated plant is scored against its truth
            continue
        for step in [1, *rec.meta.get("decimate", [])]:
            r = rec.decimated(step)
            head = slice(0, IDENTIFY_SAMPLES)
            options = r.score_options()
            band = min(0.5, score_cutoff_hz(r.fs, options.get("cutoff_hz")) / r.fs)
            design, parts = halves(r.t[head], r.R[head], ~r.gaps[head], band)
            if design.is_differencing or not np.isfinite(design.expected_rms):
                kept_differencing += 1
                continue
            plain = DifferencingEstimator().run(r.t, r.data).omega
            filtered = DifferencingEstimator(taps=design.taps).run(r.t, r.data).omega
            mine = score(r, filtered, **options).rms / score(r, plain, **options).rms
            judged = [b for _, b in parts]
            rows.append((r.name, mine, design.expected_rms / design.differencing_rms, *judged))
            lower.append(lower_band_ratios(r, filtered, plain))
            print(f"{r.name:48s} measured {mine:.4f}  expected {rows[-1][2]:.3f}  "
                  f"by the other half, in the score's band {judged[0]:.3f} / {judged[1]:.3f}; "
                  + ", ".join(f"to {c:g} Hz {x:.4f}" for c, x in lower[-1].items()), flush=True)  # fmt: skip
    if not rows:
        print(f"skipped: no attitude recording with a filter in {corpus}")
        return 0
    a = np.array([row[1:] for row in rows], dtype=float)
    finite = np.all(np.isfinite(a), axis=1)
    lower = [x for x, ok in zip(lower, finite, strict=True) if ok]
    a = a[finite]
    measured, expected, first, second = a.T
    declined = (first >= 1.0) | (second >= 1.0)
    ruled = np.where(declined, 1.0, measured)
    print(f"\n{len(rows)} rows ran the filter ({kept_differencing} kept differencing); geometric means:")
    print(f"  measured {gmean(measured):.4f}, worst {measured.max():.4f}, above 1.02 on {np.sum(measured > 1.02)}")
    print(f"  expected (whole band, in-sample) {gmean(expected):.4f}")
    print(f"  by the other half, score's band {gmean(np.sqrt(first * second)):.4f}")
    print(f"  the rule declines {declined.sum()} rows, which measured {gmean(measured[declined]):.4f} "
          f"(worst {measured[declined].max() if declined.any() else float('nan'):.4f}), "
          f"{np.sum(declined & (measured > 1.02))} of the rows above 1.02")  # fmt: skip
    print(f"  with the rule: {gmean(ruled):.4f}, worst {ruled.max():.4f}, above 1.02 on {np.sum(ruled > 1.02)}")
    for cut in LOWER_CUTOFFS_HZ:  # the same rows, with the score's low-pass moved down where it is below theirs
        at = np.array([x[cut] for x in lower if cut in x])
        over = np.array([m for m, x in zip(measured, lower, strict=True) if cut in x])
        if at.size:
            print(f"  to {cut:g} Hz ({at.size} rows whose cut-off is higher): {gmean(at):.4f}, worst {at.max():.4f}, "
                  f"above 1.02 on {np.sum(at > 1.02)} (the same rows at their own cut-off: {gmean(over):.4f}, worst "
                  f"{over.max():.4f}, above 1.02 on {np.sum(over > 1.02)})")  # fmt: skip
    return 0


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "--all":
        warnings.simplefilter("ignore")
        if not Path(argv[1]).is_dir():
            print(f"skipped: {argv[1]} is not a folder")
            return 0
        return cross_validated(Path(argv[1]))
    if len(argv) < 2:
        print(__doc__.split("\n\n")[1])
        return 2
    warnings.simplefilter("ignore")
    corpus = Path(argv[0])
    for spec in argv[1:]:
        name, _, step = spec.partition("/")
        path = corpus / f"{name}.npz"
        if not path.is_file():
            print(f"{name}: skipped ({path} absent)")
            continue
        rec = load_recording(path).decimated(int(step or 1))
        design, parts = halves(rec.t, rec.R, ~rec.gaps)
        whole = design.expected_rms / design.differencing_rms
        judged = "; ".join(
            f"half {k + 1} in-sample {a:.3f}, by the other half {b:.3f}" for k, (a, b) in enumerate(parts)
        )
        print(f"{spec}\n  expected ÷ differencing: whole log {whole:.3f}; {judged}", flush=True)
        cells = [f"{lo:g}-{hi:g} Hz {gain:.2f} γ² {coh:.2f}" for lo, hi, gain, coh in response(path, int(step or 1))]
        print("  reference ÷ increments (R1): " + "; ".join(cells), flush=True)
        options = rec.score_options()
        plain = DifferencingEstimator().run(rec.t, rec.data).omega
        filtered = DifferencingEstimator(taps=design.taps).run(rec.t, rec.data).omega
        ratios = {score_cutoff_hz(rec.fs, options.get("cutoff_hz")): score(rec, filtered, **options).rms
                  / score(rec, plain, **options).rms, **lower_band_ratios(rec, filtered, plain)}  # fmt: skip
        print("  the filter ÷ differencing, the error low-passed at " + ", ".join(
            f"{c:g} Hz {x:.4f}" for c, x in ratios.items()), flush=True)  # fmt: skip
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
