"""How the mocap preset's model and constants were chosen: a sweep on BROAD trials 01, 06, 10 at six rates.

Run: ``python benchmarks/mocap_tuning.py`` (several minutes on a 2-core machine). Skips cleanly without
``<repository>/../shared/data/broad``.

For every rate (the native 285.7 Hz and every 2nd, 3rd, 5th, 10th, 30th sample) and every candidate, the in-band
score of :func:`omegahat.lab.evaluation.broad.score` (best continuous shift) divided by raw backward differencing's on
the same trial, for the three trials. Candidates: the preset's estimator
(:func:`omegahat.observer.presets.estimator_for`: J = I, τ = 0, the supervisor's consistency tests off) with

* the constant-acceleration model (P1), σ_m = 1e-3 rad, jerk noise σ_d in {300, 700, 1500, 3000} rad/s^2.5;
* the constant-rate model (P2), σ_m = 1e-3 rad, tracking index Λ = σ_a h^1.5/σ_m in {1, 3, 10, 30}.

The preset takes (P1) with σ_d = 1500 at and above 80 Hz and (P2) with Λ = 10 below (``docs/theory/mocap.md``).
"""

from __future__ import annotations

import sys
import warnings

import numpy as np

from omegahat.baselines.differencing import log_difference
from omegahat.lab.evaluation import broad
from omegahat.observer.estimator import SkippedSamplesWarning
from omegahat.observer.presets import MocapModel, estimator_for
from results_md import machine_line, write_section

STEPS = (1, 2, 3, 5, 10, 30)
SIGMA_M = 1e-3
CANDIDATES = [("P1", s) for s in (300.0, 700.0, 1500.0, 3000.0)] + [("P2", L) for L in (1.0, 3.0, 10.0, 30.0)]


def estimator(kind, value, fs):
    """The preset's estimator (:func:`omegahat.observer.presets.estimator_for`) with a candidate's constants."""
    h = 1.0 / fs
    if kind == "P1":
        model = MocapModel("constant-acceleration", fs, SIGMA_M, 1e-6, value)
    else:
        model = MocapModel("constant-rate", fs, SIGMA_M, value * SIGMA_M / h**1.5, None)
    return estimator_for(model)


def main() -> int:
    if not all((broad.data_dir() / f).exists() for f in broad.TRIALS.values()):
        print(f"skipped: BROAD recordings not found in {broad.data_dir()}")
        return 0
    warnings.simplefilter("ignore", SkippedSamplesWarning)
    native = {name: broad.load_trial(name) for name in broad.TRIALS}
    names = [f"(P1) σ_d={v:g}" if k == "P1" else f"(P2) Λ={v:g}" for k, v in CANDIDATES]
    rows = ["| rate | " + " | ".join(names) + " |", "|" + " --- |" * (len(names) + 1)]
    for step in STEPS:
        trials = {n: tr.decimated(step) for n, tr in native.items()}
        bars = {n: broad.score(tr, log_difference(tr.t, tr.R, scheme="backward")).rms for n, tr in trials.items()}
        cells = []
        for kind, value in CANDIDATES:
            ratios = []
            for n, tr in trials.items():
                w = estimator(kind, value, tr.fs).run(tr.t, tr.R).omega
                ratios.append(broad.score(tr, w).rms / bars[n] if np.all(np.isfinite(w)) else np.inf)
            cells.append("/".join(f"{r:.2f}" if r < 100 else "div." for r in ratios))
        fs = native["01"].fs / step
        rows.append(f"| {fs:.3g} Hz | " + " | ".join(cells) + " |")
        print(rows[-1], flush=True)
    table = "\n".join(rows)
    write_section(
        "## The mocap preset's sweep (benchmarks/mocap_tuning.py)",
        f"{machine_line()} Command: `python benchmarks/mocap_tuning.py`. In-band RMS over raw backward "
        "differencing's, trials 01/06/10 (best continuous shift; `div.`: the filter diverged).\n\n" + table,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
