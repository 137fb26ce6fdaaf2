"""The default's self-assessment on the real recordings of issue 24, in the whole band and in the score's band.

Run: ``OMEGAHAT_CORPUS_DIR=DIR python benchmarks/self_assessment.py`` after ``python benchmarks/real_world.py
--after`` (it reads the measured scores of ``benchmarks/real_world_after.csv``; a few minutes). Skips cleanly without a
corpus.

Where the identification declines the model (every real recording but two UPenn logs), ``omegahat estimate`` runs
backward differencing through the log's causal filter and prints the error that (C2) expects of it over the whole
band, ``0 … ½`` cycles per step (:class:`omegahat.identification.causal.CausalFilter`). The fair score compares the
error only below min(10 Hz, 0.4 × rate) (a zero-phase Butterworth low-pass), against a calibrated gyroscope.
This benchmark sets both of (C2)'s figures, the whole band's and the score's band's
(:func:`omegahat.identification.causal.expected_rms_below`), beside the measured score, for the default and for
backward differencing (the identification of the log's head, as the command runs it), and the whole band's figure
beside the same score without the low-pass (the default and differencing run again for it). Where even the score's
band's figure is far below the measured one for both, the score is not the estimate's error: it is the reference's
own (its noise, its calibration residual), which no attitude-only estimate can see or reduce.

It also shows why (C2) does not decide between the model and differencing: it cannot see what a model knows (on
noise-free logs of the plant it expects far less of differencing than differencing measures, its target being the
interval's midpoint). And it sets ``--smooth``'s printed figure beside both scores. Writes its section of RESULTS.md.
"""

from __future__ import annotations

import csv
import math
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from omegahat import so3
from omegahat.identification import identify
from omegahat.identification.causal import TAPS, causal_filter, expected_rms_below
from omegahat.identification.spectral import increment_spectrum
from omegahat.io.choice import IDENTIFY_SAMPLES
from omegahat.lab.evaluation.broad import score, score_cutoff_hz
from omegahat.lab.evaluation.corpus import METHODS, Recording, group_of, load_recording, recordings
from results_md import machine_line, write_section

SECTION = "## The default's self-assessment in the score's band (benchmarks/self_assessment.py)"
AFTER_CSV = Path(__file__).with_name("real_world_after.csv")
HEAD = IDENTIFY_SAMPLES  # the rows of the log the identification reads, as the command runs it
DEFAULT, BACKWARD, SMOOTH = "omegahat estimate", "backward diff.", "omegahat estimate --smooth"


def fold_split(rec: Recording) -> tuple[float, ...]:
    """A decimated BROAD recording's backward differences against the native reference at the intervals' midpoints
    (no shift, no low-pass), split by the reference's content below and above the log's Nyquist frequency (an ideal
    FFT split of the reference on its own clock): RMS of the whole error and of the part due to the rate above the
    Nyquist frequency (the interval means of that part less its value at the midpoint), over the scored samples;
    (C2)'s fold term for differencing, ``∫ S_a (1 − sinc_a)² df`` of the log's head; and the reference's RMS above
    the Nyquist frequency at the midpoints and at rest (its own noise there). Then the differences against the
    reference's own interval means, as they are and with the log map's second-order term taken out (for ``ω(t)`` in
    body axes the mean over a step is ``b − (h²/12) ω × ω̇`` to second order, here ``b_k − (h/24)(b_k × b_{k+1} +
    b_{k−1} × b_k)``): what the log map alone costs at this rate."""
    native = rec.native
    assert native is not None
    ok = np.all(np.isfinite(native.reference_rates), axis=1)
    spline = CubicSpline(native.reference_times[ok], native.reference_rates[ok])
    dt = float(np.median(np.diff(native.reference_times[ok])))
    grid = np.arange(native.reference_times[ok][0], native.reference_times[ok][-1], dt)
    h = 1.0 / rec.fs
    spectrum = np.fft.rfft(spline(grid), axis=0)
    spectrum[np.fft.rfftfreq(grid.size, dt) <= 0.5 / h] = 0.0
    above = np.fft.irfft(spectrum, n=grid.size, axis=0)  # the reference's rate above the log's Nyquist frequency
    integral = np.vstack([np.zeros((1, 3)), np.cumsum(0.5 * (above[1:] + above[:-1]) * dt, axis=0)])
    above_at, integral_at = CubicSpline(grid, above), CubicSpline(grid, integral)
    t, R = rec.t, rec.R
    k = np.arange(2, t.size - 1)
    inside = (t[k - 2] > grid[0] + 1.0) & (t[k + 1] < grid[-1] - 1.0)
    use = ~(rec.gaps[k - 2] | rec.gaps[k - 1] | rec.gaps[k] | rec.gaps[k + 1]) & inside & rec.movement[k].astype(bool)
    k, mid = k[use], t[k[use]] - h / 2

    def b(j: np.ndarray) -> np.ndarray:
        return so3.log(np.einsum("nji,njk->nik", R[j - 1], R[j])) / h

    differences = b(k)
    second_order = (h / 24.0) * (np.cross(differences, b(k + 1)) + np.cross(b(k - 1), differences))
    mean = spline.antiderivative()
    interval_mean = (mean(t[k]) - mean(t[k - 1])) / h
    fold_error = (integral_at(t[k]) - integral_at(t[k - 1])) / h - above_at(mid)
    head = R[:HEAD]
    valid = np.all(np.isfinite(head.reshape(len(head), -1)), axis=1)
    found = increment_spectrum(t[:HEAD], head, valid)
    identity = np.zeros((TAPS, 3))
    identity[0] = 1.0
    expected_fold = expected_rms_below(found, identity, 0.5, fold_only=True)
    rest = ~native.movement.astype(bool) & (native.t > grid[0] + 1.0) & (native.t < grid[-1] - 1.0)

    def rms(x: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum(x**2, axis=1))))

    return (
        rms(differences - spline(mid)),
        rms(fold_error),
        expected_fold,
        rms(above_at(mid)),
        rms(above_at(native.t[rest])),
        rms(differences - interval_mean),
        rms(differences - second_order - interval_mean),
    )


def main() -> int:
    paths = recordings()
    if not paths or not AFTER_CSV.exists():
        print("no corpus (OMEGAHAT_CORPUS_DIR) or no real_world_after.csv: nothing to measure")
        return 0
    scored = {(r["recording"], r["method"]): r for r in csv.DictReader(AFTER_CSV.open())}
    warnings.simplefilter("ignore")  # skipped samples etc., as real_world.py
    ratios: dict[str, list[tuple[float, ...]]] = {}
    method = {m.name: m for m in METHODS}
    model_rows, folds, smoothed, t0 = [], [], {}, time.perf_counter()
    for path in paths:
        native = load_recording(path)
        for rec in [native] + ([native.decimated(10), native.decimated(30)] if native.name.startswith("broad") else []):
            mine, theirs = scored.get((rec.name, DEFAULT)), scored.get((rec.name, BACKWARD))
            if mine is None or theirs is None:
                continue
            whole = rec.score_options() | {"cutoff_hz": math.inf}  # the same score without the low-pass
            if not rec.name.startswith("plant"):  # --smooth's printed figure against both scores
                ran, fair = method[SMOOTH].run(rec), scored.get((rec.name, SMOOTH))
                if ran.predicted and fair:
                    w_smooth = score(rec, ran.omega, **whole).rms
                    smoothed.setdefault(group_of(rec.name), []).append(
                        (ran.predicted / float(fair["rms_rad_s"]), ran.predicted / w_smooth)
                    )
            given = {"J": rec.inertia, "torque": None if rec.torque is None else rec.torque[:HEAD]}
            if rec.kind == "directions":
                given["references"] = rec.references
            ident = identify(rec.t[:HEAD], rec.data[:HEAD], rec.kind, **given)  # as the command runs it
            R = rec.R[:HEAD]
            valid = np.all(np.isfinite(R.reshape(len(R), -1)), axis=1)
            spectrum = increment_spectrum(rec.t[:HEAD], R, valid)  # as identify reads it
            m_mine, m_theirs = float(mine["rms_rad_s"]), float(theirs["rms_rad_s"])
            if ident.causal is None:  # the model's filter ran: its own account; what (C3) would have expected
                designed = causal_filter(spectrum).expected_rms
                model_rows.append((rec.name, ident.expected_rms, designed, m_mine, m_theirs))
                continue
            taps = ident.causal.taps
            identity = np.zeros_like(taps)
            identity[0] = 1.0
            rate = 1.0 / float(np.median(np.diff(rec.t)))
            band = score_cutoff_hz(rate) / rate  # cycles per step
            if rec.native is not None and rec.name.startswith("broad"):
                folds.append((group_of(rec.name), *fold_split(rec)))
            w_mine, w_theirs = (score(rec, method[m].run(rec).omega, **whole).rms for m in (DEFAULT, BACKWARD))
            printed, differencing = expected_rms_below(spectrum, taps, 0.5), expected_rms_below(spectrum, identity, 0.5)
            ratios.setdefault(group_of(rec.name), []).append(
                (
                    printed / m_mine,
                    expected_rms_below(spectrum, taps, band) / m_mine,
                    printed / w_mine,
                    expected_rms_below(spectrum, identity, band) / m_theirs,
                    differencing / w_theirs,
                )
            )
    elapsed = time.perf_counter() - t0

    def cell(x: np.ndarray) -> str:
        outside = int(np.sum((x < 0.5) | (x > 2.0)))
        return f"{math.exp(np.mean(np.log(x))):.2f}; {x.min():.2f}–{x.max():.2f}; {outside}"

    lines = [
        machine_line(),
        "",
        "Command: `python benchmarks/self_assessment.py` (after `real_world.py --after`). Every recording where the "
        "default ran differencing through the log's causal filter; (C2)'s expected RMS error over the whole band (what "
        "`omegahat estimate` prints) and below the score's cutoff, divided by the measured error: the fair score "
        '(low-passed), or the same score without the low-pass ("whole band"). Cells: geometric mean; lowest–highest; '
        "how many outside 0.5–2.",
        "",
        "| group | n | default: printed ÷ score | default: score's band ÷ score | default: printed ÷ whole band "
        "| differencing: score's band ÷ score | differencing: whole band ÷ whole band |",
        "| --- | ---: | --- | --- | --- | --- | --- |",
    ]
    every = []
    for name in sorted(ratios):
        a = np.array(ratios[name])
        every.append(a)
        lines.append(f"| {name} | {len(a)} | " + " | ".join(cell(a[:, k]) for k in range(a.shape[1])) + " |")
    a = np.vstack(every)
    lines.append(f"| all | {len(a)} | " + " | ".join(cell(a[:, k]) for k in range(a.shape[1])) + " |")
    flips = [r for r in model_rows if r[2] < 0.9 * r[1]]
    lines += [
        "",
        "Where the model's filter ran (its own expectation printed): the model's expected error beside what (C3) "
        "would have expected of differencing through its filter on the same head, and the measured scores. (C2) "
        f"expects less than 0.9 times the model's on {len(flips)} of {len(model_rows)}: a rule comparing the two "
        "would have dropped the model there, where it measured "
        + (f"{min(r[3] / r[4] for r in flips):.3g}–{max(r[3] / r[4] for r in flips):.3g}" if flips else "–")
        + " times differencing's error.",
        "",
        "| recording | model's filter, expected | (C3), expected by (C2) | default, measured "
        "| differencing, measured |",
        "| --- | ---: | ---: | ---: | ---: |",
    ]
    lines += [f"| {n} | {e:.3g} | {c:.3g} | {m:.3g} | {b:.3g} |" for n, e, c, m, b in model_rows]
    lines += [
        "",
        "BROAD below its native rate: backward differencing against the native gyroscope at the intervals' midpoints "
        "(no shift, no low-pass), and the part of that error due to the rate above the log's Nyquist frequency, "
        "which no estimate from the log's samples can recover (the reference is sampled at the log's instants, so "
        "the score keeps its alias); (C2)'s expectation of that part, from (S6)'s fold; and what the reference "
        "carries above the Nyquist frequency while the body moves and at rest (its own noise there). Then the "
        "differences against the reference's own interval means, as they are and with the log map's second-order "
        "term taken out (`fold_split`'s docstring). RMS in rad/s, geometric means over the group's recordings.",
        "",
        "| group | n | differencing's error | its part from above the Nyquist frequency | (C2)'s expectation of that "
        "part | reference above the Nyquist frequency: moving | at rest | differences against the interval means "
        "| the same, second-order term out |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for name in sorted({f[0] for f in folds}):
        x = np.array([f[1:] for f in folds if f[0] == name])
        lines.append(f"| {name} | {len(x)} | " + " | ".join(f"{math.exp(np.mean(np.log(c))):.3g}" for c in x.T) + " |")
    lines += [
        "",
        "`--smooth` on the real recordings: the expected error its closing line prints (the smoother kept) over the "
        "fair score and over the same score without the low-pass.",
        "",
        "| group | n | --smooth: printed ÷ score | --smooth: printed ÷ whole band |",
        "| --- | ---: | --- | --- |",
    ]
    for name in sorted(smoothed):
        x = np.array(smoothed[name])
        lines.append(f"| {name} | {len(x)} | {cell(x[:, 0])} | {cell(x[:, 1])} |")
    x = np.vstack([np.array(v) for v in smoothed.values()])
    lines.append(f"| all | {len(x)} | {cell(x[:, 0])} | {cell(x[:, 1])} |")
    lines += ["", f"{len(a) + len(model_rows)} recordings in {elapsed:.0f} s."]
    print("\n".join(lines))
    write_section(SECTION, "\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
