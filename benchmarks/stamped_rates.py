"""The rates read at their stamps: each method's error at no shift, beside the fair score's best shift.

Run: ``python benchmarks/stamped_rates.py`` after ``python benchmarks/real_world.py --after`` and/or
``--heldout OUT`` (it reads ``real_world_after.csv`` and ``real_world_heldout.csv``, whichever exist).
Writes its section of ``benchmarks/RESULTS.md``; skips cleanly where neither CSV exists.

The fair score (:func:`omegahat.lab.evaluation.broad.score`) compares each method at its best constant shift
within ±3 samples, because the reference gyroscope's clock is not the attitudes' (the corpus's calibration aligns
them once, for every method alike). That forgives backward differencing's half-step delay: its ``b_k`` is the mean
rate over ``[t_{k−1}, t_k]``, stamped ``t_k``, and the score compares it with the reference half a step earlier
(its best shift is about −0.5 samples). A user who reads the rates at the times they are stamped with does not get
that shift. This table gives, per group of recordings, each method's RMS error at no shift
(``zero_shift_rms``, low-passed as the score is) over backward differencing's at no shift, and each method's
median best shift: where a zero-lag method's shift is near 0, the calibration left no clock offset for it to
absorb, and the comparison at no shift is the one a user of the stamped rates sees.
"""

from __future__ import annotations

import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path

from omegahat.lab.evaluation.corpus import group_of
from real_world import AFTER_CSV, HELDOUT_CSV, read_csv
from results_md import geo, machine_line, write_section

SECTION = "## The rates read at their stamps: the error at no shift (benchmarks/stamped_rates.py)"
METHODS = ("omegahat estimate", "omegahat estimate --smooth", "central diff.", "RotationSpline")
BASELINE = "backward diff."


def table(path: Path) -> list[str]:
    """The table's rows for one CSV: per group, the methods' zero-shift errors over differencing's, and their
    median best shifts (samples)."""
    scores: dict[str, dict[str, tuple[float, float]]] = defaultdict(dict)  # recording -> method -> (zero, shift)
    for row in read_csv(path):
        if row.score is not None and math.isfinite(row.score.zero_shift_rms) and row.score.zero_shift_rms > 0:
            scores[row.recording][row.method] = (row.score.zero_shift_rms, row.score.shift)
    ratios: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    shifts: dict[str, dict[str, list[float]]] = defaultdict(lambda: defaultdict(list))
    for name, found in scores.items():
        if BASELINE not in found or not all(m in found for m in METHODS):
            continue
        group = group_of(name)
        shifts[group][BASELINE].append(found[BASELINE][1])
        for method in METHODS:
            ratios[group][method].append(found[method][0] / found[BASELINE][0])
            shifts[group][method].append(found[method][1])
    lines = []
    for group in sorted(ratios):
        cells = [geo(ratios[group][m]) for m in METHODS]
        moved = " / ".join(f"{statistics.median(shifts[group][m]):+.2f}" for m in (BASELINE, *METHODS))
        lines.append(
            f"| {path.name} | {group} | {len(ratios[group][METHODS[0]])} | " + " | ".join(cells) + f" | {moved} |"
        )
    return lines


def main(argv: list[str] | None = None) -> int:
    paths = [p for p in (AFTER_CSV, HELDOUT_CSV) if p.exists()]
    if not paths:
        print(f"no {AFTER_CSV.name} or {HELDOUT_CSV.name} (benchmarks/real_world.py --after / --heldout): skipped")
        return 0
    head = (
        "| table | group | n | default ÷ bwd, no shift | `--smooth` ÷ bwd, no shift | central diff. ÷ bwd, no shift | "
        "RotationSpline ÷ bwd, no shift | median best shift (samples): bwd / default / `--smooth` / central / spline |"
    )
    lines = [head, "|" + " --- |" * 2 + " ---: |" + " --- |" * 5]
    for path in paths:
        lines += table(path)
    intro = (
        f"{machine_line()} Command: `python benchmarks/stamped_rates.py` (from "
        f"{' and '.join(f'`{p.name}`' for p in paths)}). Each method's in-band RMS error at no shift over backward "
        "differencing's at no shift (geometric mean; lowest–highest), and the median of each method's best shift "
        "under the fair score (the script's docstring): what a user who reads the rates at their stamps sees; "
        "the scores as the CSVs' last runs wrote them."
    )
    body = intro + "\n\n" + "\n".join(lines)
    print(body)
    write_section(SECTION, body)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
