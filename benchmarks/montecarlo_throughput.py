"""Throughput of Monte-Carlo campaigns on the lockstep engine, beside a loop of single-run simulations.

Unit: one **step** = one accepted step of the coupled integrator (:mod:`omegahat.simulation.engine`): one ETDRK4
step with its embedded error estimate, 4 evaluations of the right-hand side (a rejected trial costs the same 4 and
is reported, not counted). Timings over the same runs (``examples/campaign.toml``, horizon 20 s, output every
0.05 s), chunk by chunk as a campaign cuts them:

* ``engine``: ``integrate_envelopes`` (what a campaign calls: every thread steps its runs 24 at a time in
  lockstep and diagnoses each run as it ends), the runs drawn and packed before the clock starts;
* ``campaign``: ``run_chunk`` end to end (drawing the runs, the engine, the diagnostics);
* ``loop``: a Python loop calling ``simulate`` once per run (one lane, one core).

The engine and the campaign are timed ``--repeat`` times; best and median are reported (on a shared machine the same
work takes up to 1.4 times as long from one minute to the next). The script also checks, on the first runs, that
the engine's states equal ``simulate``'s bit for bit. Results go to ``benchmarks/RESULTS.md``.

    python benchmarks/montecarlo_throughput.py [--runs 10000] [--gains theorem] [--repeat 5] [--loop-runs 2000]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
from pathlib import Path

import numba
import numpy as np

from omegahat.lab import campaigns as mc
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.simulation import simulate, simulate_batch
from omegahat.simulation.engine import LANES, RunSet, StepControl, integrate_envelopes
from omegahat.simulation.problem import first_step, initial_states, model_of
from omegahat.validation import as_directions, as_inertia
from results_md import machine_line, write_section

ROOT = Path(__file__).resolve().parents[1]


def engine_inputs(c, name, start, stop):
    d = draw_runs(c, np.arange(start, stop))
    refs = as_directions(c.references)
    y0 = initial_states(refs, d["R0"], d["omega0"], d["omega_hat0"], d["r_hat0"])
    h0 = first_step(c.gains[name], d["omega_hat0"], c.h_max)
    runs = RunSet(y0, h0, d["constant"], d["amplitudes"], d["frequencies"], d["phases"])
    return model_of(as_inertia(c.J), c.gains[name]), runs


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--config", type=Path, default=ROOT / "examples" / "campaign.toml")
    parser.add_argument("--runs", type=int, default=10_000)
    parser.add_argument("--gains", default="theorem")
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--loop-runs", type=int, default=2000, help="runs for the simulate loop (0: skip it)")
    args = parser.parse_args(argv)
    c = mc.load_campaign(args.config)
    c = mc.replace(c, gains={args.gains: c.gains[args.gains]}, runs=args.runs)
    spans = mc.chunks(c)
    control = StepControl(c.rtol, c.atol, c.h_max, c.max_steps)
    threads = numba.get_num_threads()
    inputs = [engine_inputs(c, args.gains, a, b) for a, b in spans]

    def engine():
        acc = rej = 0
        for model, runs in inputs:
            out = integrate_envelopes(model, runs, c.t_out, control, c.rho_floor, threads)
            acc, rej = acc + int(out.accepted.sum()), rej + int(out.rejected.sum())
        return acc, rej

    def campaign():
        return mc.run_campaign(c)[args.gains]

    # warm up (compile or load the cache), and check bit-identity with simulate on the first runs
    probe = [mc.draw_problem(c, j, args.gains) for j in range(LANES + 3)]
    batch = simulate_batch(probe, c.t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
    for j, p in enumerate(probe):
        alone = simulate(p, t_out=c.t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
        assert np.array_equal(batch.Y[j, :, 3 * p.gains.n + 3 : 3 * p.gains.n + 6], alone.z), f"run {j} differs"
    engine()
    times = {"engine": [], "campaign": []}
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        acc, rej = engine()
        times["engine"].append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        result = campaign()
        times["campaign"].append(time.perf_counter() - t0)
    assert int(result.steps.sum()) == acc  # the campaign integrates exactly what the engine did
    rows = []
    for label, ts in times.items():
        best, med = min(ts), statistics.median(ts)
        rows.append(f"| {label} | {best:.2f} s / {med:.2f} s | {acc / best:.3g} / {acc / med:.3g} |")
    if args.loop_runs:
        problems = [mc.draw_problem(c, j, args.gains) for j in range(args.loop_runs)]  # drawn outside the timing
        t0 = time.perf_counter()
        loop_steps = 0
        for p in problems:
            tr = simulate(p, t_out=c.t_out, rtol=c.rtol, atol=c.atol, h_max=c.h_max, max_steps=c.max_steps)
            loop_steps += tr.steps
        dt = time.perf_counter() - t0
        rows.append(f"| loop of `simulate` ({args.loop_runs:,} runs, one core) | {dt:.2f} s | {loop_steps / dt:.3g} |")
    header = ["| what | wall time, best / median | accepted steps/s, best / median |", "| --- | --- | --- |"]
    table = "\n".join([*header, *rows])
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(table)
    write_section(
        "## Monte-Carlo throughput (benchmarks/montecarlo_throughput.py)",
        f"{machine_line()} Command: `python benchmarks/montecarlo_throughput.py --runs {args.runs} --gains "
        f"{args.gains} --repeat {args.repeat} --loop-runs {args.loop_runs}` ({threads} threads, {LANES} lanes per "
        f"thread; load average {load:.1f} at the end). {args.runs:,} runs of `{args.config.name}`, gain set "
        f"`{args.gains}`: {acc:,} accepted steps, {rej:,} rejected; the first {len(probe)} runs checked equal to "
        f"`simulate` bit for bit.\n\n{table}",
    )


if __name__ == "__main__":
    main()
