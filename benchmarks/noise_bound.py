"""The most attitude noise a corpus recording can have, by its reference gyroscope, beside the noise omegahat assumes.

Run: ``python benchmarks/noise_bound.py CORPUS_DIR [NAME ...] [--decimate N ...]`` (all of the directory's
recordings without names; ``--decimate``: also at every N-th sample).
Prints one row per recording; writes nothing.

Each step's measured increment ``R_{k−1}ᵀ R_k`` is set beside the reference rate (the calibrated gyroscope, a cubic
spline through it) integrated over the step by the midpoint rule on 8 sub-steps. With white attitude noise ``n_k``
of ``σ`` per axis, the residual ``Log(Q_kᵀ R_{k−1}ᵀ R_k)`` is ``n_k − n_{k−1}`` plus the reference's own error over
the step, so per body axis::

    σ ≤ sqrt( mean_k r_k² / 2 )                                                                     (B1)

an upper bound, tight where the gyroscope is better than the attitude over one step. Beside it, the noise that
:func:`omegahat.identification.spectral.increment_spectrum` assumes (what ``--smooth`` and the causal filter use:
the quiet part's (N2), capped by the band's top (N3)), that cap itself, and what the band's top holds: the power of
the reference's interval means ``Log(Q_k) / h`` over that of the measured increments ``Log(R_{k−1}ᵀ R_k) / h`` at
``f ≥ 0.4`` cycles per step (Welch, over the longest run of consecutive steps). Both carry the motion alike (the
same interval mean), so a share near 0 says the band's top of the increments is noise, near 1 or above that it is
motion.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy import signal
from scipy.interpolate import CubicSpline

from omegahat import so3
from omegahat.identification.spectral import increment_spectrum, top_noise
from omegahat.lab.evaluation.corpus import load_recording, recordings

SUBSTEPS = 8


def noise_bound(rec) -> np.ndarray:
    """(B1) per body axis (rad) for a recording of :mod:`omegahat.lab.evaluation.corpus`."""
    return np.sqrt(np.mean(_residuals(rec)[3] ** 2, axis=0) / 2.0)


def top_share(rec) -> np.ndarray:
    """Per body axis, the reference's power over the measured increments' at ``f ≥ 0.4`` cycles per step (module
    docstring); NaN where the longest run of consecutive steps is shorter than 64."""
    k, reference, measured, _ = _residuals(rec)
    breaks = np.flatnonzero(np.diff(k) != 1)
    starts, ends = np.r_[0, breaks + 1], np.r_[breaks + 1, k.size]
    a, b = max(zip(starts, ends, strict=True), key=lambda r: r[1] - r[0])
    if b - a < 64:
        return np.full(3, np.nan)
    f, P_ref = signal.welch(reference[a:b], nperseg=min(256, (b - a) // 4), axis=0)
    _, P_meas = signal.welch(measured[a:b], nperseg=min(256, (b - a) // 4), axis=0)
    top = f >= 0.4
    return P_ref[top].sum(axis=0) / P_meas[top].sum(axis=0)


def _residuals(rec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The steps ``k`` the reference covers, and over them the reference's increments ``Log(Q_k)``, the measured
    ones ``Log(R_{k−1}ᵀ R_k)`` and the residuals ``Log(Q_kᵀ R_{k−1}ᵀ R_k)`` (rad, ``(n, 3)`` each)."""
    rate = CubicSpline(rec.reference_times, rec.reference_rates, axis=0)
    R, t = rec.R, rec.t
    k = np.flatnonzero(~rec.gaps[1:] & ~rec.gaps[:-1]) + 1
    k = k[(t[k - 1] >= rec.reference_times[0]) & (t[k] <= rec.reference_times[-1])]
    h = (t[k] - t[k - 1]) / SUBSTEPS
    Q = np.broadcast_to(np.eye(3), (k.size, 3, 3))
    for j in range(SUBSTEPS):
        Q = Q @ so3.exp(rate(t[k - 1] + (j + 0.5) * h) * h[:, None])
    measured = np.einsum("nji,njk->nik", R[k - 1], R[k])
    return k, so3.log(Q), so3.log(measured), so3.log(np.einsum("nji,njk->nik", Q, measured))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("names", nargs="*")
    ap.add_argument("--decimate", type=int, nargs="*", metavar="N", help="also every N-th sample (e.g. 10 30)")
    args = ap.parse_args(argv)
    paths = [args.corpus / f"{n}.npz" for n in args.names] or recordings(args.corpus)
    print(
        "| recording | assumed (mrad per body axis) | the band's top bounds it at (N3) | at most, by the reference "
        "(B1) | the reference's share of the band's top |"
    )
    print("| --- | --- | --- | --- | --- |")
    for path in paths:
        native = load_recording(path)
        if native.kind != "quaternion":
            continue
        for step in [1, *(args.decimate or [])]:
            rec = native.decimated(step)
            spectrum = increment_spectrum(rec.t, rec.R, ~rec.gaps)
            cap = top_noise(spectrum.freq, spectrum.P_b, spectrum.h, spectrum.segments)
            cells = [1e3 * spectrum.sigma, 1e3 * cap, 1e3 * noise_bound(rec)]
            text = " | ".join(", ".join(f"{s:.2g}" for s in c) for c in cells)
            print(f"| {rec.name} | {text} | {', '.join(f'{s:.2g}' for s in top_share(rec))} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
