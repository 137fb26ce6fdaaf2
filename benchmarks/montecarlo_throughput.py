"""Throughput of Monte-Carlo campaigns: the batch engine (Numba prange over runs) beside a per-run Python loop.

Unit: one **observer step** = one accepted step of the coupled integrator (``omegahat.simulate``): a trial that
passed the error test and advanced plant + observer; it is one ETDRK4 step with its embedded error estimate and
costs 4 evaluations of the right-hand side (three stages and the new point, which is also the next step's first
stage; a rejected trial costs the same 4; one more per run at the start). Rejected trials are reported but not
counted as steps. Also printed: ETDRK4 steps/s (1 per trial, accepted or rejected) and right-hand-side
evaluations/s. Steps/s alone flatters a scheme that takes more, cheaper steps: compare wall times too.
(Before the embedded estimate, a trial was a full step and two half steps, 3 ETDRK4 steps and 11 evaluations.)

    /tmp/venv/bin/python benchmarks/montecarlo_throughput.py                 # 10,000 runs, gain set "theorem"
    /tmp/venv/bin/python benchmarks/montecarlo_throughput.py --runs 1000 --gains slope

Three timings over the same runs (examples/campaign.toml, horizon 20 s, output every 0.05 s):
  engine   simulate_batch on the pre-drawn problems, chunk by chunk (the kernel and its packing only);
  campaign run_campaign end to end (drawing the runs, the kernel, the diagnostics);
  loop     a Python loop calling omegahat.simulate.simulate once per run (one core).
The machine load (os.getloadavg) is printed: on a shared machine the numbers are lower bounds.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numba

from omegahat import montecarlo as mc
from omegahat.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]


def _rates(label, seconds, acc, rej, runs):
    trials = acc + rej
    rhs = 4 * trials + runs
    print(
        f"{label:9s} {seconds:8.2f} s  {acc / seconds:10.3e} steps/s  {trials / seconds:10.3e} ETDRK4 steps/s  "
        f"{rhs / seconds:10.3e} RHS evals/s  ({acc} steps, {rej} rejected, {runs} runs)"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--gains", default="theorem", help="gain set of examples/campaign.toml (theorem)")
    ap.add_argument("--loop-runs", type=int, default=None, help="runs in the Python loop (default: all)")
    ap.add_argument("--config", default=str(ROOT / "examples" / "campaign.toml"))
    args = ap.parse_args()

    base = mc.load_campaign(args.config)
    campaign = mc.replace(base, runs=args.runs, gains={args.gains: base.gains[args.gains]})
    print(f"threads: {numba.get_num_threads()} (numba), cores: {os.cpu_count()}, load avg: {os.getloadavg()}")
    # compile (and load the on-disk cache) outside the timings
    warm = mc.replace(campaign, runs=2, horizon=0.2)
    mc.run_campaign(warm)
    simulate(mc.draw_problem(warm, 0), t_out=warm.t_out, rtol=warm.rtol)

    t0 = time.perf_counter()
    problems = [mc.draw_problem(campaign, j, args.gains) for j in range(campaign.runs)]
    t_draw = time.perf_counter() - t0
    print(f"drawing {campaign.runs} problems: {t_draw:.2f} s")

    t0 = time.perf_counter()
    e_acc = e_rej = 0
    for start, stop in mc.chunks(campaign):  # chunked as in a campaign: (chunk, T, 6n + 6) states at a time
        batch = mc.simulate_batch(problems[start:stop], campaign.t_out, rtol=campaign.rtol, atol=campaign.atol,
                                  h_max=campaign.h_max, max_steps=campaign.max_steps)
        e_acc += int(batch.accepted.sum())
        e_rej += int(batch.rejected.sum())
    t_engine = time.perf_counter() - t0
    _rates("engine", t_engine, e_acc, e_rej, campaign.runs)

    t0 = time.perf_counter()
    res = mc.run_campaign(campaign)[args.gains]
    t_campaign = time.perf_counter() - t0
    _rates("campaign", t_campaign, int(res.steps.sum()), int(res.rejected.sum()), campaign.runs)

    n_loop = campaign.runs if args.loop_runs is None else args.loop_runs
    t0 = time.perf_counter()
    acc = rej = 0
    for p in problems[:n_loop]:
        tr = simulate(p, t_out=campaign.t_out, rtol=campaign.rtol, atol=campaign.atol, h_max=campaign.h_max,
                      max_steps=campaign.max_steps)
        acc += tr.steps
        rej += tr.rejected
    t_loop = time.perf_counter() - t0
    _rates("loop", t_loop, acc, rej, n_loop)
    speedup = (e_acc / t_engine) / (acc / t_loop)
    print(f"engine / loop speed-up: {speedup:.2f}x (steps/s); load avg after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
