"""Speed of two versions of omegahat measured in one run: the paper scenario, the streaming estimator, campaigns.

Issue 11 (the restructuring into one kernel layer and one engine) may not slow any of these by more than 10 %.
On a shared machine whose speed drifts from minute to minute, the two versions are measured alternately, each
measurement in a fresh child process of its own interpreter, several rounds; best and median per version and their
ratios are printed and written to ``benchmarks/RESULTS.md``.

    python benchmarks/refactor_speed.py --before /path/to/old/venv/bin/python [--after python] [--rounds 5]

``--before`` is an interpreter with the older omegahat installed (for example a ``git worktree`` of commit
c0976b8 installed into its own venv). Each child imports whichever API its version has (before the restructuring:
``omegahat.simulate``, ``omegahat.estimator``, ``omegahat.montecarlo``; after: ``omegahat.simulation``,
``omegahat.observer``, ``omegahat.lab.campaigns``), warms the compiled kernels up, and times:

* ``paper``: ``simulate(paper_problem(), t_out=[0, .5, 1, 2, 5, 10])`` (the paper benchmark's call), best of 21;
* ``update``: one ``SarrasEstimator.update`` with a rotation matrix (the paper's body at 1 kHz, theorem gains,
  three rows), median over 20,000 calls;
* ``run``: ``SarrasEstimator.run`` on 200,000 matrices, best of 3 (samples/s);
* ``campaign``: ``run_chunk`` of ``examples/campaign.toml``'s theorem gains on 2,048 runs, best of 7 (accepted
  steps/s).
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

CHILD = r"""
import json, sys, time
import numpy as np
metric = sys.argv[1]
try:
    from omegahat.simulation import paper_problem, simulate
    from omegahat.observer.estimator import SarrasEstimator
    from omegahat.lab import campaigns as mc
    from omegahat.simulation.rigid_body import RigidBody, integrate
    from omegahat.observer.gains import theorem_gains
except ImportError:  # the layout before issue 11
    from omegahat.simulate import paper_problem, simulate
    from omegahat.estimator import SarrasEstimator
    from omegahat import montecarlo as mc
    from omegahat.rigid_body import RigidBody, integrate
    from omegahat.gains import theorem_gains
out = {}
if metric == "paper":
    t_out = np.array([0.0, 0.5, 1.0, 2.0, 5.0, 10.0])
    p = paper_problem()
    simulate(p, t_out=t_out)
    ts = []
    for _ in range(21):
        t0 = time.perf_counter(); simulate(p, t_out=t_out); ts.append(time.perf_counter() - t0)
    out["seconds"] = min(ts)
elif metric in ("update", "run"):
    J = np.diag([3.0, 2.0, 1.0])
    g = theorem_gains(J, 3.0, references=np.eye(3))
    N = 200_000
    times = np.arange(N) * 1e-3
    R = integrate(RigidBody(J), np.eye(3), [2.0, -1.0, 0.6], times, max_step=1e-3).R
    SarrasEstimator(J, gains=g, warm_start=False).run(times[:10], R[:10])
    est = SarrasEstimator(J, gains=g, warm_start=False)
    est.update(times[0], R[0])
    if metric == "update":
        est = SarrasEstimator(J, gains=g, warm_start=False)
        clock = time.perf_counter_ns
        per = np.empty(20_000)
        for j in range(per.size):
            t0 = clock(); est.update(times[j], R[j]); per[j] = clock() - t0
        out["seconds"] = float(np.median(per)) * 1e-9
    else:
        best = np.inf
        for _ in range(3):
            est = SarrasEstimator(J, gains=g, warm_start=False)
            t0 = time.perf_counter(); est.run(times, R); best = min(best, time.perf_counter() - t0)
        out["seconds"] = best / N  # per sample
elif metric == "campaign":
    c = mc.load_campaign(sys.argv[2])
    c = mc.replace(c, gains={"theorem": c.gains["theorem"]}, runs=2048)
    mc.run_chunk(c, 0, 48)
    best = np.inf
    for _ in range(7):
        t0 = time.perf_counter(); r = mc.run_chunk(c, 0, 2048); best = min(best, time.perf_counter() - t0)
    out["seconds"] = best / int(r["theorem"].steps.sum())  # per accepted step
print(json.dumps(out))
"""

METRICS = {
    "paper": "paper scenario, one `simulate` (s)",
    "update": "`update`, one matrix sample (s)",
    "run": "`run`, per sample (s)",
    "campaign": "campaign engine, per accepted step (s)",
}


def measure(python: str, metric: str) -> float:
    args = [python, "-c", CHILD, metric, str(ROOT / "examples" / "campaign.toml")]
    done = subprocess.run(args, capture_output=True, text=True, check=True, cwd="/")
    return json.loads(done.stdout.strip().splitlines()[-1])["seconds"]


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", required=True, help="interpreter with the older omegahat")
    parser.add_argument("--after", default=sys.executable, help="interpreter with this omegahat (default: this one)")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--metric", action="append", choices=list(METRICS), help="default: all")
    args = parser.parse_args(argv)
    metrics = args.metric or list(METRICS)
    for python in (args.before, args.after):  # compile or load every kernel once, untimed
        for metric in metrics:
            measure(python, metric)
    results = {m: {"before": [], "after": []} for m in metrics}
    for r in range(args.rounds):
        for metric in metrics:
            for label, python in (("before", args.before), ("after", args.after)):
                results[metric][label].append(measure(python, metric))
        print(f"round {r + 1} of {args.rounds} done", flush=True)
    rows = []
    for metric in metrics:
        b, a = results[metric]["before"], results[metric]["after"]
        row = (METRICS[metric], min(b), statistics.median(b), min(a), statistics.median(a))
        rows.append((*row, row[3] / row[1], row[4] / row[2]))
    lines = ["| quantity | before: best / median | after: best / median | after / before: best, median |",
             "| --- | --- | --- | --- |"]  # fmt: skip
    for name, bb, bm, ab, am, rb, rm in rows:
        lines.append(f"| {name} | {bb:.3g} / {bm:.3g} | {ab:.3g} / {am:.3g} | {rb:.3f}, {rm:.3f} |")
    table = "\n".join(lines)
    print(table)
    from results_md import machine_line, write_section

    write_section(
        "## Before and after the restructuring of issue 11 (benchmarks/refactor_speed.py)",
        f"{machine_line()} Command: `python benchmarks/refactor_speed.py --before <older venv>/bin/python "
        f"--rounds {args.rounds}`; before: {args.before}. Each number is one child process's measurement; "
        f"{args.rounds} rounds, the two versions alternating. Lower is faster; a ratio below 1 is a speed-up.\n\n"
        f"{table}\n",
    )


if __name__ == "__main__":
    t0 = time.perf_counter()
    main()
    print(f"({time.perf_counter() - t0:.0f} s; {platform.node()})")
