"""The most attitude noise a corpus recording can have, by its reference gyroscope, beside the noise omegahat assumes.

Run: ``python benchmarks/noise_bound.py CORPUS_DIR [NAME ...]`` (all of the directory's recordings without names).
Prints one row per recording; writes nothing.

Each step's measured increment ``R_{k−1}ᵀ R_k`` is set beside the reference rate (the calibrated gyroscope, a cubic
spline through it) integrated over the step by the midpoint rule on 8 sub-steps. With white attitude noise ``n_k``
of ``σ`` per axis, the residual ``Log(Q_kᵀ R_{k−1}ᵀ R_k)`` is ``n_k − n_{k−1}`` plus the reference's own error over
the step, so per body axis::

    σ ≤ sqrt( mean_k r_k² / 2 )                                                                     (B1)

an upper bound, tight where the gyroscope is better than the attitude over one step. Beside it, the noise that
:func:`omegahat.identification.spectral.increment_spectrum` assumes (what ``--smooth`` and the causal filter use).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline

from omegahat import so3
from omegahat.identification.spectral import increment_spectrum
from omegahat.lab.evaluation.corpus import load_recording, recordings

SUBSTEPS = 8


def noise_bound(rec) -> np.ndarray:
    """(B1) per body axis (rad) for a recording of :mod:`omegahat.lab.evaluation.corpus`."""
    rate = CubicSpline(rec.reference_times, rec.reference_rates, axis=0)
    R, t = rec.R, rec.t
    k = np.flatnonzero(~rec.gaps[1:] & ~rec.gaps[:-1]) + 1
    k = k[(t[k - 1] >= rec.reference_times[0]) & (t[k] <= rec.reference_times[-1])]
    h = (t[k] - t[k - 1]) / SUBSTEPS
    Q = np.broadcast_to(np.eye(3), (k.size, 3, 3))
    for j in range(SUBSTEPS):
        Q = Q @ so3.exp(rate(t[k - 1] + (j + 0.5) * h) * h[:, None])
    measured = np.einsum("nji,njk->nik", R[k - 1], R[k])
    residual = so3.log(np.einsum("nji,njk->nik", Q, measured))
    return np.sqrt(np.mean(residual**2, axis=0) / 2.0)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("corpus", type=Path)
    ap.add_argument("names", nargs="*")
    args = ap.parse_args(argv)
    paths = [args.corpus / f"{n}.npz" for n in args.names] or recordings(args.corpus)
    print("| recording | assumed (mrad per body axis) | at most, by the reference (B1) |")
    print("| --- | --- | --- |")
    for path in paths:
        rec = load_recording(path)
        if rec.kind != "quaternion":
            continue
        assumed = increment_spectrum(rec.t, rec.R, ~rec.gaps).sigma
        bound = noise_bound(rec)
        print(
            f"| {rec.name} | {', '.join(f'{1e3 * s:.2g}' for s in assumed)} | "
            f"{', '.join(f'{1e3 * s:.2g}' for s in bound)} |",
            flush=True,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
