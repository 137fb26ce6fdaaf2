"""Throughput of Monte-Carlo campaigns: the lockstep batch engine beside the per-run kernels.

Unit: one **observer step** = one accepted step of the coupled integrator (``omegahat.simulation.coupled``): a trial
that passed the error test and advanced plant + observer; it is one ETDRK4 step with its embedded error estimate and
costs 4 evaluations of the right-hand side (three stages and the new point, which is also the next step's first
stage; a rejected trial costs the same 4; one more per run at the start). Rejected trials are reported but not
counted as steps. Also printed: right-hand-side evaluations/s. Steps/s alone flatters a scheme that takes more,
cheaper steps: compare wall times too.

    /tmp/venv/bin/python benchmarks/montecarlo_throughput.py                 # 10,000 runs, gain set "theorem"
    /tmp/venv/bin/python benchmarks/montecarlo_throughput.py --runs 1000 --gains slope --loop-runs 200

The lanes kernels and the campaign are timed ``--repeat`` times (default 5) over the same runs; the best and the
median are printed: on a shared virtual machine the same work takes up to 1.4 times as long from one minute to
the next.

Timings over the same runs (examples/campaign.toml, horizon 20 s, output every 0.05 s), chunk by chunk as a
campaign cuts them (``--chunk``, default the campaign's):
  lanes    omegahat.simulation.engine.integrate_diagnosed_lanes (what campaigns use): each thread steps its runs 24
           at a time in lockstep, SIMD over runs, and diagnoses each run as it ends;
  states   omegahat.simulation.engine.integrate_coupled_lanes: the same, returning every run's states instead (its
           step counts must equal the lanes', its states the prange engine's, bit for bit);
  prange   omegahat.simulation.coupled.integrate_coupled_batch: a Numba prange over runs, each run the scalar single-run
           kernel (the engine before the lockstep kernel);
  campaign run_campaign end to end (drawing the runs, the kernel, the diagnostics);
  loop     a Python loop calling omegahat.simulation.coupled.simulate once per run (one core).
Kernel timings exclude drawing and packing the runs (done before the clock starts). The machine load
(os.getloadavg) is printed: on a shared machine the numbers are lower bounds.
"""

from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numba
import numpy as np

from omegahat.campaigns import runner as mc
from omegahat.simulation.coupled import integrate_coupled_batch, simulate
from omegahat.simulation.engine import LANES, integrate_coupled_lanes, integrate_diagnosed_lanes

ROOT = Path(__file__).resolve().parents[1]


def _report(label, times, acc, rej, runs):
    best, median = min(times), float(np.median(times))
    if len(times) > 1:
        print(f"{label:9s} best of {len(times)}: {best:.2f} s, median {median:.2f} s ({acc / median:.3e} steps/s)")
    _rates(label, best, acc, rej, runs)


def _rates(label, seconds, acc, rej, runs):
    rhs = 4 * (acc + rej) + runs
    print(
        f"{label:9s} {seconds:8.2f} s  {acc / seconds:10.3e} steps/s  {rhs / seconds:10.3e} RHS evals/s  "
        f"({acc} steps, {rej} rejected, {runs} runs)"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=10_000)
    ap.add_argument("--gains", default="theorem", help="gain set of examples/campaign.toml (theorem)")
    ap.add_argument("--chunk", type=int, default=None, help="runs per kernel call (default: the campaign's)")
    ap.add_argument("--loop-runs", type=int, default=None, help="runs in the Python loop (default: all)")
    ap.add_argument("--skip-prange", action="store_true", help="do not time the per-run prange kernel")
    ap.add_argument("--repeat", type=int, default=5, help="timings of the lanes kernel and the campaign (5)")
    ap.add_argument("--config", default=str(ROOT / "examples" / "campaign.toml"))
    args = ap.parse_args()

    base = mc.load_campaign(args.config)
    campaign = mc.replace(base, runs=args.runs, gains={args.gains: base.gains[args.gains]})
    if args.chunk is not None:
        campaign = mc.replace(campaign, chunk_size=args.chunk)
    workers = numba.get_num_threads()
    print(
        f"threads: {workers} (numba), cores: {os.cpu_count()}, lanes: {LANES}, chunk: {campaign.chunk_size}, "
        f"load avg: {os.getloadavg()}"
    )
    # compile (and load the on-disk cache) outside the timings
    warm = mc.replace(campaign, runs=2, horizon=0.2)
    mc.run_campaign(warm)
    simulate(mc.draw_problem(warm, 0), t_out=warm.t_out, rtol=warm.rtol)
    c = campaign
    tol = (float(c.rtol), float(c.atol))
    steps = (float(c.h_max), int(c.max_steps))
    t_out = c.t_out

    # the kernels' inputs chunk by chunk, drawn and packed as run_chunk does
    t0 = time.perf_counter()
    gains = c.gains[args.gains]  # c.J and c.references are already checked arrays, as run_chunk uses them
    packed = [
        mc._kernel_inputs(c.J, c.references, gains, mc._draw_runs(c, np.arange(a, b)), c.h_max) for a, b in mc.chunks(c)
    ]
    print(f"drawing and packing {c.runs} runs: {time.perf_counter() - t0:.2f} s")
    Y0w, bw, tw, hw = packed[0]
    integrate_coupled_lanes(Y0w[:2], t_out[:3], *bw, *(x[:2] for x in tw), *tol, hw[:2], *steps, workers)
    integrate_coupled_batch(Y0w[:2], t_out[:3], *bw, *(x[:2] for x in tw), *tol, hw[:2], *steps, workers)

    def diagnosed(Y0, *a):
        rho, _, ok, acc, rej = integrate_diagnosed_lanes(Y0, *a, float(c.rho_floor))
        return rho[:, -1:], acc, rej, ok

    kernels = [("lanes", diagnosed), ("states", integrate_coupled_lanes)]
    kernels += [] if args.skip_prange else [("prange", integrate_coupled_batch)]
    results = {}
    for label, kernel in kernels:
        times = []
        for _ in range(args.repeat if label != "prange" else 1):
            t0 = time.perf_counter()
            acc = rej = 0
            out = []
            for Y0, body, torque, h0 in packed:
                Y, a, r, ok = kernel(Y0, t_out, *body, *torque, *tol, h0, *steps, workers)
                acc += int(a.sum())
                rej += int(r.sum())
                out.append((Y[:, -1].copy(), a, r, ok))
            times.append(time.perf_counter() - t0)
        _report(label, times, acc, rej, c.runs)
        results[label] = (min(times), acc, out)
    same_counts = all(
        np.array_equal(u[1], v[1]) and np.array_equal(u[2], v[2])
        for u, v in zip(results["lanes"][2], results["states"][2], strict=True)
    )
    print(f"lanes / states: step counts identical: {same_counts}")
    if "prange" in results:
        same = all(
            np.array_equal(x, y, equal_nan=True)
            for u, v in zip(results["states"][2], results["prange"][2], strict=True)
            for x, y in zip(u, v, strict=True)
        )
        print(
            f"lanes / prange: {results['prange'][0] / results['lanes'][0]:.2f}x faster; states (final), step "
            f"counts and flags of the states kernel and prange identical: {same}"
        )

    times = []
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        res = mc.run_campaign(c)[args.gains]
        times.append(time.perf_counter() - t0)
    _report("campaign", times, int(res.steps.sum()), int(res.rejected.sum()), c.runs)

    n_loop = c.runs if args.loop_runs is None else args.loop_runs
    if n_loop > 0:
        acc = rej = 0
        problems = [mc.draw_problem(c, j, args.gains) for j in range(n_loop)]
        t0 = time.perf_counter()
        for p in problems:
            tr = simulate(p, t_out=t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
            acc += tr.steps
            rej += tr.rejected
        t_loop = time.perf_counter() - t0
        _rates("loop", t_loop, acc, rej, n_loop)
        seconds, lanes_acc, _ = results["lanes"]
        print(f"lanes / loop speed-up: {(lanes_acc / seconds) / (acc / t_loop):.2f}x (steps/s)")
    print(f"load avg after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
