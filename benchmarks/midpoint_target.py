"""Why zero-lag estimates lose to backward differencing at low rates: the rate at the samples against the rate at the
intervals' midpoints.

Run: ``OMEGAHAT_CORPUS_DIR=DIR python benchmarks/midpoint_target.py [DIR]`` after ``python benchmarks/real_world.py
--after`` (it reads `--smooth`'s and the offline peers' scores from ``benchmarks/real_world_after.csv``; about a
minute), or ``python benchmarks/midpoint_target.py --heldout OUT`` after ``real_world.py --heldout OUT`` (the
recordings nobody tuned on, and ``real_world_heldout.csv``). Writes its section of RESULTS.md (one per corpus);
skips cleanly without a corpus.

The increments ``b_k = Log(R_{k−1}ᵀ R_k) / h`` carry the rate folded from beyond the Nyquist frequency with the gain
``sinc_a = sinc(1 − f)`` ((S6) of :mod:`omegahat.identification.spectral`). Against the rate at the interval's
midpoint that fold has the same sign as in ``b``; against the rate at the samples, half a step away, it has the
opposite sign. So the fold is partly recoverable at the midpoints and not at all at the samples, where (S6)'s best
filter can only shrink it: whatever the filter, a zero-lag estimate keeps at least the fold's power as error, while
backward differencing, which the score compares at its best shift (about half a step), keeps only
``|sinc_a − 1|²`` of it.

To measure that, this benchmark runs the Wiener filter of the same spectrum (:func:`increment_spectrum`,
:func:`rate_spectra`) for the midpoint target (row ``k``: the rate at ``t_k − h/2``, as backward differencing)::

    F_mid(f) = max(0, sinc S + sinc_a S_a) / P_b   where the motion is significant (S3), else 0          (M-1)

applied to each stretch's increments by FFT (mean out and back, zero padding; no coning term and no edge extension:
the score keeps a second away from every end), and backward differencing itself on rows outside the stretches. It
is a measurement of the target, not an estimator of omegahat: ``--smooth`` writes the rate at the samples.
"""

from __future__ import annotations

import sys
import time
import warnings
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy import fft

from omegahat.baselines.differencing import log_difference
from omegahat.identification.fold import rate_spectra
from omegahat.identification.spectral import increment_spectrum, spectral_rate
from omegahat.lab.evaluation.broad import score
from omegahat.lab.evaluation.corpus import corpus_dir, group_of, load_recording, recordings
from real_world import read_csv
from results_md import geo, machine_line, write_section

SECTION = "## The rate at the samples or at the intervals' midpoints (benchmarks/midpoint_target.py)"
HELDOUT_SECTION = "## The rate at the samples or at the midpoints, held out (benchmarks/midpoint_target.py --heldout)"
AFTER_CSV = Path(__file__).with_name("real_world_after.csv")
HELDOUT_CSV = Path(__file__).with_name("real_world_heldout.csv")
SOURCES = ("broad", "upenn")  #: the real recordings of the development corpus (the plant's are simulated)


def midpoint_rate(t: np.ndarray, R: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """(M-1): row ``k`` the Wiener estimate of the rate at ``t_k − h/2`` (backward differencing's target), ``(T, 3)``;
    backward differencing on the rows no stretch covers (a stretch's first sample, skipped ones)."""
    sp = increment_spectrum(t, R, valid)
    omega = log_difference(t, np.where(valid[:, None, None], R, np.nan), scheme="backward")
    if not sp.freq.size:
        return omega
    S, S_a = rate_spectra(sp.freq, sp.P_b, sp.g, sp.N_b)
    sinc, sinc_a = np.sinc(sp.freq)[:, None], np.sinc(1.0 - sp.freq)[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        F = np.nan_to_num(np.where(sp.g > 0, np.maximum(sinc * S + sinc_a * S_a, 0.0) / sp.P_b, 0.0))
    for (a, b), r in zip(sp.runs, sp.rates, strict=True):
        mean = r.mean(axis=0)
        n = fft.next_fast_len(2 * r.shape[0], real=True)
        f = fft.rfftfreq(n)
        gain = np.stack([np.interp(f, sp.freq, F[:, j]) for j in range(3)], axis=1)
        gain[0] = 1.0  # the mean rate passes as it is (Welch's spectrum is of the increments less their mean)
        omega[a + 1 : b] = fft.irfft(fft.rfft(r - mean, n=n, axis=0) * gain, n=n, axis=0)[: r.shape[0]] + mean
    return omega


def measured(path: Path) -> dict[str, dict[str, float]]:
    """``{recording: {method: rms}}`` from a CSV of ``real_world.py`` (its reader), the methods that ran."""
    by: dict[str, dict[str, float]] = defaultdict(dict)
    for row in read_csv(path):
        if row.score is not None:
            by[row.recording][row.method] = row.score.rms
    return by


def main(argv: list[str] | None = None) -> int:
    warnings.simplefilter("ignore")
    argv = list(sys.argv[1:] if argv is None else argv)
    heldout = "--heldout" in argv
    argv = [a for a in argv if a != "--heldout"]
    directory = Path(argv[0]) if argv else corpus_dir()
    table, section = (HELDOUT_CSV, HELDOUT_SECTION) if heldout else (AFTER_CSV, SECTION)
    paths = [p for p in recordings(directory) if heldout or group_of(p.stem) in SOURCES]
    if not paths or not table.exists():
        print(f"no corpus in {directory} (benchmarks/corpus.py; $OMEGAHAT_CORPUS_DIR) or no {table.name}: skipped")
        return 0
    t0 = time.perf_counter()
    after = measured(table)
    ratios: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for path in paths:
        native = load_recording(path)
        for step in [1, *native.meta.get("decimate", [])]:
            rec = native.decimated(step)
            rows = after.get(rec.name, {})
            if "omegahat estimate --smooth" not in rows or "backward diff." not in rows:
                continue
            options = rec.score_options()
            backward = rows["backward diff."]  # the same score of the same method as the two filters'
            middle = score(rec, midpoint_rate(rec.t, rec.R, ~rec.gaps), **options).rms
            samples = score(rec, spectral_rate(rec.t, rec.R, ~rec.gaps).omega, **options).rms
            best = min(rows[m] for m in ("central diff.", "RotationSpline") if m in rows)
            cells = ratios[group_of(rec.name)]
            cells["mid"].append(middle / backward)
            cells["samples"].append(samples / backward)
            cells["smooth"].append(rows["omegahat estimate --smooth"] / backward)
            cells["peer"].append(best / backward)
            print(f"{rec.name}: ÷ backward: midpoints {middle / backward:.3f}, samples {samples / backward:.3f}")
    lines = [
        "| group | n | Wiener, midpoints (M-1) | Wiener, samples (S6) | `--smooth` | best of central diff. and "
        "RotationSpline |",
        "| --- | ---: | --- | --- | --- | --- |",
    ]
    for group, cells in sorted(ratios.items()):
        lines.append(
            f"| {group} | {len(cells['mid'])} | {geo(cells['mid'])} | {geo(cells['samples'])} | "
            f"{geo(cells['smooth'])} | {geo(cells['peer'])} |"
        )
    intro = (
        f"{machine_line()} Command: `python benchmarks/midpoint_target.py{' --heldout OUT' if heldout else ''}` "
        f"(after `real_world.py {'--heldout OUT' if heldout else '--after'}`; "
        f"{time.perf_counter() - t0:.0f} s). The real recordings of the {'held-out' if heldout else 'development'} "
        "corpus, scored by the fair score "
        "(best shift, low-passed); cells: each method's error over backward differencing's, geometric mean; "
        "lowest–highest. The two Wiener filters read the same spectrum and noise and differ only in their target; "
        "the midpoint target's is the benchmark's own (its docstring), the samples' is omegahat's "
        "(`spectral_rate`). `--smooth` (the model's smoother or the Wiener filter, whichever expects less) and the "
        f"peers: `{table.name}`."
    )
    body = intro + "\n\n" + "\n".join(lines)
    print(body)
    write_section(section, body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
