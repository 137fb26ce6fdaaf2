"""``--smooth`` against the offline peers on a corpus's recordings decimated to a low rate: where the Wiener smoother
reads a fold that may not be there.

Run: ``python benchmarks/smooth_low_rate.py CORPUS_DIR [--only PATTERN] [--decimate N ...]`` (the development
corpus of ``benchmarks/corpus.py``; default ``--only 'upenn-*' --decimate 10``: UPenn's hand-held Vicon logs at
every 10th sample, 10 Hz, which ``real_world.py`` scores at their native rate only). Writes its section of
``benchmarks/RESULTS.md``; skips cleanly without a corpus.

Every recording, by the fair score of ``real_world.py``: central differencing, ``RotationSpline``, the default and
``--smooth``; the ratio of ``--smooth`` to the better of the two peers, and what ``--smooth`` kept (the model's
smoother or the log's Wiener smoother) with the expected error it printed and the part of it from the fold.
"""

from __future__ import annotations

import argparse
import fnmatch
import math
import re
import time
import warnings

from omegahat.lab.evaluation.corpus import METHODS, evaluate, load_recording, recordings
from results_md import machine_line, write_section

TITLE = "## `--smooth` on recordings decimated to a low rate (benchmarks/smooth_low_rate.py)"
NAMES = ("central diff.", "RotationSpline", "omegahat estimate", "omegahat estimate --smooth")
_FOLD = re.compile(r"expected RMS error ([0-9.eE+-]+) rad/s by its spectrum's account \(([0-9.eE+-]+) of it from")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("corpus", nargs="?", default=None)
    ap.add_argument("--only", default="upenn-*", help="recordings whose name matches (fnmatch)")
    ap.add_argument("--decimate", type=int, nargs="+", default=[10])
    args = ap.parse_args(argv)
    paths = [p for p in recordings(args.corpus) if fnmatch.fnmatch(p.stem, args.only)]
    if not paths:
        print("no corpus recordings (benchmarks/corpus.py; $OMEGAHAT_CORPUS_DIR): nothing to do")
        return 0
    warnings.simplefilter("ignore")  # skipped samples etc.: every method alike
    methods = [m for m in METHODS if m.name in NAMES]
    start = time.perf_counter()
    rows, ratios = [], []
    for path in paths:
        native = load_recording(path)
        for step in args.decimate:
            rec = native.decimated(step) if step > 1 else native
            scored = {r.method: r for r in evaluate(rec, methods)}
            rms = {name: scored[name].score.rms for name in NAMES if scored[name].score is not None}
            best = min(rms["central diff."], rms["RotationSpline"])
            ratio = rms["omegahat estimate --smooth"] / best
            ratios.append(ratio)
            note = scored["omegahat estimate --smooth"].note
            kept = "Wiener" if "estimator used: the log's own Wiener smoother" in note else "model"
            fold = _FOLD.search(note)
            said = f"{fold.group(1)} ({fold.group(2)} fold)" if fold else "–"
            cells = " | ".join(f"{rms[n]:.4g}" for n in NAMES)
            rows.append(f"| {rec.name} | {cells} | {ratio:.3f} | {kept} | {said} |")
            print(rows[-1], flush=True)
    gmean = math.exp(sum(map(math.log, ratios)) / len(ratios))
    head = (
        "| recording | central diff. | RotationSpline | default | --smooth | --smooth ÷ better peer | kept | "
        "--smooth's expected error (its fold part), rad/s |\n| --- | ---: | ---: | ---: | ---: | ---: | --- | --- |"
    )
    steps = " ".join(map(str, args.decimate))
    command = f"python benchmarks/smooth_low_rate.py CORPUS --only '{args.only}' --decimate {steps}"
    body = (
        f"{machine_line()} Command: `{command}` ({time.perf_counter() - start:.0f} s). The fair score of "
        "`real_world.py` (rad/s). `--smooth` ÷ the better of central differencing and RotationSpline: geometric "
        f"mean {gmean:.3f}, worst {max(ratios):.3f}, above 1.0 on {sum(r > 1.0 for r in ratios)} of {len(ratios)}."
        f"\n\n{head}\n" + "\n".join(rows)
    )
    print(body.splitlines()[0])
    write_section(TITLE, body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
