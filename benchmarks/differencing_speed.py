"""Speed of the default's causal differencing, (D1) through the log's filter (D4)–(D5), as ``omegahat estimate``
runs it: a whole log in one ``run``, the same log in the chunks a CSV is read in (one ``run`` per chunk, continuing
from the last), and ``update`` sample by sample.

Run: ``python benchmarks/differencing_speed.py [--samples N] [--chunk ROWS]``. Data: a body turning with a few
incommensurate rates plus 1 mrad of white attitude noise at 100 Hz (quaternions, scalar last), 1 % of the samples
missing; the taps (16 per axis) are the ones :func:`omegahat.identification.causal.causal_filter` designs from the
log's own spectrum, with the samples' step given as the command gives it ((D3)). ``run`` is timed best of 3, the
``update`` loop over its first 20,000 samples; the largest difference of the chunked and the sample-by-sample rows
from the whole run's is printed beside. Writes its section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.identification.causal import causal_filter
from omegahat.identification.spectral import increment_spectrum
from results_md import machine_line, write_section

SECTION = "## The default's causal differencing, whole and in chunks (benchmarks/differencing_speed.py)"
RATE_HZ = 100.0
LOOP_SAMPLES = 20_000


def log(samples: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    t = np.arange(samples) / RATE_HZ
    rates = np.c_[np.sin(1.3 * t), 0.5 * np.cos(2.9 * t + 1.0), 0.8 * np.sin(0.7 * t) + 0.3 * np.sin(7.1 * t)]
    turn = Rotation.from_rotvec(np.cumsum(rates / RATE_HZ, axis=0))
    q = (turn * Rotation.from_rotvec(1e-3 * rng.standard_normal((samples, 3)))).as_quat()
    q[rng.random(samples) < 0.01] = np.nan
    return t, q


def best_of(repeats: int, fn) -> tuple[float, object]:
    best, out = np.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=1_000_000)
    parser.add_argument("--chunk", type=int, default=1 << 17, help="rows per chunk (the pipeline's CHUNK_ROWS)")
    args = parser.parse_args()
    t, q = log(args.samples)
    valid = np.isfinite(q).all(axis=1)
    R = np.full((t.size, 3, 3), np.nan)
    R[valid] = Rotation.from_quat(q[valid]).as_matrix()
    taps = causal_filter(increment_spectrum(t[:20_000], R[:20_000], valid[:20_000])).taps
    kw = {"taps": taps, "step": 1.0 / RATE_HZ}
    DifferencingEstimator(**kw).run(t[:1000], q[:1000])  # compile the low-pass kernel before timing

    def chunked() -> np.ndarray:
        est = DifferencingEstimator(**kw)
        return np.vstack(
            [est.run(t[a : a + args.chunk], q[a : a + args.chunk]).omega for a in range(0, t.size, args.chunk)]
        )

    def looped() -> np.ndarray:
        est = DifferencingEstimator(**kw)
        return np.array([est.update(tk, qk).omega for tk, qk in zip(t[:LOOP_SAMPLES], q[:LOOP_SAMPLES], strict=True)])

    whole_s, whole = best_of(3, lambda: DifferencingEstimator(**kw).run(t, q).omega)
    chunk_s, pieces = best_of(3, chunked)
    loop_s, rows = best_of(1, looped)
    assert isinstance(whole, np.ndarray) and isinstance(pieces, np.ndarray) and isinstance(rows, np.ndarray)
    chunk_diff = float(np.nanmax(np.abs(pieces - whole)))
    loop_diff = float(np.nanmax(np.abs(rows - whole[:LOOP_SAMPLES])))
    us = lambda seconds, n: f"{1e6 * seconds / n:.2f} us per sample ({seconds:.3f} s)"  # noqa: E731
    table = [
        "| how | time | largest difference from the whole run (rad/s) |",
        "| --- | --- | --- |",
        f"| `run`, the whole log ({t.size:,} samples) | {us(whole_s, t.size)} | 0 |",
        f"| `run` per chunk of {args.chunk:,} rows, continuing | {us(chunk_s, t.size)} | {chunk_diff:.1e} |",
        f"| `update` sample by sample (first {LOOP_SAMPLES:,}) | {us(loop_s, LOOP_SAMPLES)} | {loop_diff:.1e} |",
    ]
    head = (
        f"{machine_line()} Command: `python benchmarks/differencing_speed.py --samples {args.samples} --chunk "
        f"{args.chunk}` (one core; 100 Hz quaternions with 1 mrad of noise and 1 % missing, {taps.shape[0]} taps "
        "per axis designed from the log's spectrum, the step given; `run` best of 3)."
    )
    print(head, *table, sep="\n")
    write_section(SECTION, "\n".join([head, "", *table]))


if __name__ == "__main__":
    main()
