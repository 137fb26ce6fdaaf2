"""The chaos suite's longer seeded run (issue 23): the readers, the public API and the writer, many more cases than
the tests run in CI (``tests/test_chaos_*.py``, the same engines: ``tests/chaos_files.py``, ``tests/chaos_api.py``,
``tests/faults.py``), counted and written to ``benchmarks/RESULTS.md``.

Counts per part: cases; messages (an error naming the file, a refusal that changed nothing, a disk full or an
interruption reported in one line with the output as it was); the right result (the right rows, a call accepted
as its twin accepts it, a killed run cleaned up by the next); **tracebacks** and process crashes; **silent
losses** (rows lost or merged without a word, a refusal that changed the estimator, an output left partial);
messages without the file's name; temporary files left. Failures in code other changes are fixing
(issue 23's CSV items and item 5, the C3D reader) are listed by their cause, so that what remains is plain.

    python benchmarks/chaos.py                       # 100 files per (reader, mutation), 300 API sequences ...
    python benchmarks/chaos.py --files 20 --examples 50 --no-write   # a quick look
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import time
import warnings
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import seed as hypothesis_seed  # noqa: E402

import chaos_api  # noqa: E402
import chaos_files as chaos  # noqa: E402
import faults  # noqa: E402
from results_md import machine_line, write_section  # noqa: E402

#: failures whose cause another change is fixing: (part, what) -> the cause, as the tests' markers say
KNOWN = {
    ("csv", "flip"): "csvlog: a byte that is not UTF-8, UnicodeDecodeError without the file name",
    ("csv", "quote"): "csvlog: a stray quote folds later lines (issue 23 item 2)",
    ("csv", "quote_field"): "csvlog: a stray quote folds later lines (issue 23 item 2)",
    ("csv", "cr"): "csvlog: CR-only line ends, _csv.Error (issue 23 item 3)",
    ("motive", "quote"): "mocap: a stray quote folds later lines (as item 2)",
    ("motive", "quote_field"): "mocap: a stray quote folds later lines (as item 2)",
    ("vicon", "quote"): "mocap: a stray quote folds later lines (as item 2)",
    ("vicon", "quote_field"): "mocap: a stray quote folds later lines (as item 2)",
    ("c3d", "truncate"): "ezc3d aborts the process on a truncated C3D file",
    ("api", "sarras"): "SarrasEstimator.update('1.0', q) moves before refusing (issue 23 item 5)",
}
#: how each outcome is counted
GROUP = {
    "message": "messages", "rows": "right result", "accepted": "right result", "cleaned": "right result",
    "traceback": "tracebacks", "crash": "tracebacks",
    "silent": "silent losses", "changed": "silent losses", "partial": "silent losses",
    "unnamed": "unnamed", "leftover": "left behind",
}  # fmt: skip
COLUMNS = ("cases", "messages", "right result", "tracebacks", "silent losses", "unnamed", "left behind")


def readers(folder: Path, files: int, base: int) -> tuple[Counter, Counter, list[str], int]:
    """Every reader, ``files`` mutated files per mutation: (totals, known failures by cause, examples of the
    others, how many formats were seeded)."""
    totals, known, other = Counter(), Counter(), []
    seeds = chaos.make_seeds(folder / "seeds")
    for seed in seeds:
        for kind in seed.mutations:
            cases = chaos.run_cases(seed, folder / "cases", files, base_seed=base, mutations=(kind,))
            for c in cases:
                totals["cases"] += 1
                totals[GROUP[c.outcome]] += 1
                if c.outcome in chaos.FAILURES:
                    cause = KNOWN.get((seed.name, kind))
                    if cause:
                        known[cause] += 1
                    else:
                        other.append(f"{c.seed} {c.mutation} rng={c.rng_seed}: {c.outcome}: {c.detail[:200]}")
    return totals, known, other, len(seeds)


def api(examples: int, base: int) -> tuple[Counter, Counter, list[str]]:
    """Each estimator, ``examples`` Hypothesis sequences of calls (every call counted); ``estimate_frame``,
    ``examples`` frames."""
    totals, known, other = Counter(), Counter(), []
    opts = settings(max_examples=examples, database=None, deadline=None, suppress_health_check=list(HealthCheck))

    def sequences(name: str):
        @hypothesis_seed(base)
        @opts
        @given(sequence=chaos_api.calls())
        def probe(sequence):
            seen = chaos_api.twin_outcomes(name, sequence)
            for outcome, n in seen.items():
                totals["cases"] += n
                totals[GROUP[outcome]] += n
            bad = sum(seen[k] for k in ("changed", "unnamed", "traceback"))
            if bad and ("api", name) in KNOWN:
                known[KNOWN[("api", name)]] += bad
            elif bad:
                other.append(f"{name}: {dict(seen)}")

        probe()

    for name in chaos_api.ESTIMATORS:
        sequences(name)

    @hypothesis_seed(base)
    @opts
    @given(df=chaos_api.frames())
    def frame(df):
        import omegahat

        totals["cases"] += 1
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out = omegahat.estimate_frame(df, bandwidth_hz=2.0, start="warm")
        except (ValueError, TypeError) as exc:
            named = any(w in str(exc) for w in ("DataFrame", "row", "sample"))
            totals["messages" if named else "unnamed"] += 1
            if not named:
                other.append(f"estimate_frame: {exc}")
            return
        except Exception as exc:
            totals["tracebacks"] += 1
            other.append(f"estimate_frame: {type(exc).__name__}: {exc}")
            return
        ok = len(out) == len(df) and out.index.equals(df.index)
        totals["right result" if ok else "silent losses"] += 1

    frame()
    return totals, known, other


def writer(folder: Path, rows: int) -> tuple[Counter, list[str]]:
    """``omegahat estimate`` of a ``rows``-sample log with the disk full at every write, SIGINT and SIGTERM at every
    chunk, SIGKILL at every chunk and before the final rename."""
    from logmaker import constant_rate, write_csv

    t = np.arange(rows) / 100.0
    log = write_csv(folder / "log.csv", t, constant_rate(t, np.array([0.1, -0.2, 0.3]), 1e-4))
    out = folder / "out"
    out.mkdir()
    totals, other = Counter(), []
    with faults.many_chunks(1 << 15):
        cases = faults.disk_full_cases(log, out / "o.csv")
        for sig in (signal.SIGINT, signal.SIGTERM):
            cases += faults.signal_cases(log, out / "o.csv", sig)
        if hasattr(os, "fork"):
            cases += faults.kill_cases(log, out / "o.csv")
    for case, outcome in cases:
        totals["cases"] += 1
        totals[GROUP[outcome]] += 1
        if outcome not in ("message", "cleaned"):
            other.append(f"writer {case}: {outcome}")
    return totals, other


def table(parts: dict[str, Counter]) -> str:
    lines = ["| part | " + " | ".join(COLUMNS) + " |", "| --- |" + " ---: |" * len(COLUMNS)]
    total: Counter = Counter()
    for name, c in parts.items():
        total.update(c)
        lines.append(f"| {name} | " + " | ".join(f"{c[k]:,}" for k in COLUMNS) + " |")
    lines.append("| **all** | " + " | ".join(f"**{total[k]:,}**" for k in COLUMNS) + " |")
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--files", type=int, default=100, help="mutated files per (reader, mutation) (100)")
    ap.add_argument("--examples", type=int, default=300, help="Hypothesis sequences per estimator, and frames (300)")
    ap.add_argument("--rows", type=int, default=20_000, help="samples of the writer's log (20000)")
    ap.add_argument("--seed", type=int, default=23, help="the first random seed (23)")
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md alone")
    args = ap.parse_args()
    start = time.perf_counter()
    cpu0 = os.times()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        r_totals, r_known, r_other, n_formats = readers(folder, args.files, args.seed)
        a_totals, a_known, a_other = api(args.examples, args.seed)
        (folder / "w").mkdir()
        w_totals, w_other = writer(folder / "w", args.rows)
    cpu1 = os.times()
    cpu = (cpu1.user - cpu0.user) + (cpu1.system - cpu0.system) + (cpu1.children_user - cpu0.children_user)
    known = r_known + a_known
    parts = {f"readers ({n_formats} formats, mutated files)": r_totals, "API (calls; DataFrames)": a_totals,
             "writer (faults at every write, chunk, rename)": w_totals}  # fmt: skip
    text = [
        f"{machine_line()} Command: `python benchmarks/chaos.py --files {args.files} --examples {args.examples} "
        f"--rows {args.rows} --seed {args.seed}`; {time.perf_counter() - start:.0f} s wall, {cpu:.0f} s CPU.",
        "",
        table(parts),
        "",
        *(
            [
                "Failures of known causes (counted above; the tests mark them as expected failures):",
                "",
                *(f"* {n:,}: {cause}" for cause, n in sorted(known.items(), key=lambda kv: -kv[1])),
                "",
            ]
            if known
            else ["No failure of a known cause (the tests expect none)."]
        ),
        "",
        f"Other failures: {len(r_other) + len(a_other) + len(w_other)}"
        + "".join(f"\n\n* {line}" for line in (r_other + a_other + w_other)[:20]),
    ]
    body = "\n".join(text)
    print(body)
    if not args.no_write:
        write_section("## Chaos suite (benchmarks/chaos.py)", body)
    return 0


if __name__ == "__main__":
    sys.exit(main())
