"""``--smooth`` on real recordings whose timestamps jitter: the log's own Wiener smoother reading its steps (S8).

Run: ``OMEGAHAT_CORPUS_DIR=DIR python benchmarks/jitter.py [--only PATTERN ...]`` on the corpus of
``benchmarks/corpus.py`` (skips cleanly without it; about 15 minutes on 2 cores). Each real recording (BROAD at
286 Hz and at every 10th sample, 28.6 Hz; UPenn at 100 Hz) is given timestamps that jitter in one of four ways:

* ``stamps ±3 %`` and ``stamps ±10 %``: the samples as recorded (regular), each stamp moved by a uniform draw of up
  to 3 or 10 % of the step (a message's arrival time);
* ``stamps to 1 ms``: the stamps rounded to the millisecond (a coarse export: at 286 Hz steps of 3 and 4 ms);
* ``sampling ±10 %`` (BROAD only): the attitude taken at jittered times, each up to 10 % of the step off the grid,
  by SciPy's ``RotationSpline`` through the native 286 Hz log, and stamped with those times (the stamps true).

Every method sees the jittered log; the score (:func:`omegahat.lab.evaluation.broad.score`, as
``benchmarks/real_world.py``) compares each sample's estimate with the reference at the sample's true time. Columns:
the Wiener smoother (``omegahat estimate --smooth`` where the model is declined) over the best of central
differencing and RotationSpline through the jittered stamps, and ``omegahat estimate`` with no option over backward
differencing of the jittered stamps, each as it is now (the steps read by (S8); the default's identification and
differencing on the samples' clock (D3)) and as it was (each step as stamped; for the smoother a step 5 % or more
off the median breaking the stretch: emulated by answering (S8) "the samples are at their stamps"), and what (S8)
read. Writes its section of RESULTS.md.
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import time
import warnings
from collections.abc import Callable, Iterator
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation, RotationSpline

from omegahat.baselines.differencing import log_difference
from omegahat.baselines.spline import spline_rate
from omegahat.identification import steps
from omegahat.identification.spectral import SpectralSmoother
from omegahat.lab.evaluation.broad import score
from omegahat.lab.evaluation.corpus import Recording, corpus_dir, group_of, load_recording, pipeline_method, recordings
from results_md import gmean, machine_line, write_section

SECTION = "## `--smooth` and the default on jittered timestamps (benchmarks/jitter.py)"
DEFAULT = pipeline_method("omegahat estimate")


def stamps_moved(
    fraction: float,
) -> Callable[[Recording, np.random.Generator], tuple[np.ndarray, np.ndarray, Recording]]:
    """The samples as recorded, their stamps moved by up to ``fraction`` of the step."""

    def make(rec: Recording, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, Recording]:
        h = float(np.median(np.diff(rec.t)))
        return rec.t + rng.uniform(-fraction, fraction, rec.t.size) * h, rec.R, rec

    return make


def stamps_rounded(rec: Recording, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, Recording]:
    """The samples as recorded, their stamps rounded to 1 ms."""
    return np.round(rec.t, 3), rec.R, rec


def sampled_off_grid(rec: Recording, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, Recording]:
    """The attitude at times up to 10 % of the step off the grid, from the native log; stamped with those times."""
    native = rec.native or rec
    h = float(np.median(np.diff(rec.t)))
    times = rec.t + rng.uniform(-0.1, 0.1, rec.t.size) * h
    ok = ~native.gaps
    spline = RotationSpline(native.t[ok], Rotation.from_matrix(native.R[ok]))
    R = spline(np.clip(times, native.t[ok][0], native.t[ok][-1])).as_matrix()
    R[rec.gaps] = np.nan
    return times, R, replace(rec, t=times, data=_quaternions(R))


JITTERS = {
    "stamps ±3 %": stamps_moved(0.03),
    "stamps ±10 %": stamps_moved(0.10),
    "stamps to 1 ms": stamps_rounded,
    "sampling ±10 %": sampled_off_grid,
}


def as_stamped(runs: list[np.ndarray], steps: list[np.ndarray]) -> bool:
    """(S8) answered "the samples are at their stamps": the smoother as it was before (S8)."""
    return False


@contextlib.contextmanager
def without_s8(before: bool) -> Iterator[None]:
    """Within: (S8) answers "the samples are at their stamps" (the smoother and the identification as before)."""
    read = steps.stamped_steps
    if before:
        steps.stamped_steps = as_stamped
    try:
        yield
    finally:
        steps.stamped_steps = read


def smoothed(t: np.ndarray, R: np.ndarray, before: bool) -> tuple[np.ndarray, str]:
    with without_s8(before):
        est = SpectralSmoother()
        return est.run(t, R).omega, est.timestamps


def default(rec: Recording, before: bool) -> np.ndarray:
    """``omegahat estimate`` with no option on the (jittered) recording."""
    with without_s8(before):
        return DEFAULT.run(rec).omega


def _quaternions(R: np.ndarray) -> np.ndarray:
    """Quaternions (scalar last) of the attitudes ``R``, NaN where missing."""
    q = np.full((R.shape[0], 4), np.nan)
    ok = np.all(np.isfinite(R), axis=(1, 2))
    q[ok] = Rotation.from_matrix(R[ok]).as_quat()
    return q


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", nargs="+", metavar="PATTERN", help="recordings whose name matches (fnmatch)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    paths = [p for p in recordings(corpus_dir()) if not p.stem.startswith("plant")]
    if not paths:
        print(f"skipped: no real recordings in {corpus_dir()} (build the corpus with benchmarks/corpus.py)")
        return 0
    warnings.simplefilter("ignore")
    rng = np.random.default_rng(0)
    found: dict[tuple[str, str], list[tuple[float, float, str, float, float]]] = {}
    t0 = time.perf_counter()
    for path in paths:
        rec0 = load_recording(path)
        for rec in [rec0] + ([rec0.decimated(10)] if rec0.name.startswith("broad") else []):
            if args.only and not any(fnmatch.fnmatch(rec.name, p) for p in args.only):
                continue
            group = group_of(rec.name)
            options = rec.score_options()
            for name, jitter in JITTERS.items():
                if name.startswith("sampling") and not rec.name.startswith("broad"):
                    continue
                t, R, truth = jitter(rec, rng)
                peers = [log_difference(t, R, scheme="central"), spline_rate(t, R)]
                best = min(score(truth, w, **options).rms for w in peers)
                now, read = smoothed(t, R, before=False)
                was, _ = smoothed(t, R, before=True)
                seen = replace(truth, t=t, data=_quaternions(R))  # what the command reads: the jittered stamps
                bwd = score(truth, log_difference(t, R), **options).rms
                ratios = (
                    score(truth, now, **options).rms / best,
                    score(truth, was, **options).rms / best,
                    read,
                    score(truth, default(seen, before=False), **options).rms / bwd,
                    score(truth, default(seen, before=True), **options).rms / bwd,
                )
                found.setdefault((group, name), []).append(ratios)
                print(f"{rec.name} {name}: --smooth {ratios[0]:.3f} (before {ratios[1]:.3f}), read {read!r}, default "
                      f"{ratios[3]:.3f} (before {ratios[4]:.3f})", flush=True)  # fmt: skip
    lines = [
        "| group | timestamps | n | --smooth ÷ best offline: now (geo. mean; worst) | before | (S8) read "
        "| default ÷ backward diff.: now (geo. mean; worst) | before |",
        "| --- | --- | ---: | --- | --- | --- | --- | --- |",
    ]
    for (group, name), rows in found.items():
        cols = [[float(r[i]) for r in rows] for i in (0, 1, 3, 4)]
        reads = ", ".join(f"{k or 'even'} {sum(r[2] == k for r in rows)}" for k in sorted({r[2] for r in rows}))
        a, b, c, d = (f"{gmean(v):.3f}; {max(v):.3f}" for v in cols)
        lines.append(f"| {group} | {name} | {len(rows)} | {a} | {b} | {reads} | {c} | {d} |")
    table = "\n".join(lines)
    print("\n" + table + f"\n\n{sum(len(v) for v in found.values())} runs in {time.perf_counter() - t0:.0f} s")
    if not args.no_write:
        write_section(
            SECTION,
            f"{machine_line()} Command: `python benchmarks/jitter.py` ({len(paths)} real recordings of the corpus; "
            "module docstring: the four jitters, the score against the reference at the true times, 'before' the "
            "smoother without (S8)).\n\n" + table,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
