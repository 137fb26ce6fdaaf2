"""Speed of the one-direction observer's compiled step (issue 22 item 3), beside its NumPy oracle; its compile cost.

Run: ``python benchmarks/single_direction_speed.py [--samples N] [--rounds R]``. Writes its section of RESULTS.md:

* the throughput of ``SingleDirectionEstimator.run`` on whole arrays, both methods (goal ≥ 1e6 samples/s; CPU time
  of this process pinned to one core, best of 3): the paper's body J = diag(3, 2, 1) tumbling from
  ω₀ = (2, −1, 0.6) rad/s seen at 1 kHz through the direction v = (0.6, 0, 0.8) (truth from
  :func:`omegahat.simulation.rigid_body.integrate`), and a 10 Hz sun sensor (0.1° noise, 2 % of samples missing);
* the cost of one call of ``update`` (the per-sample path; median over many calls);
* the throughput of the NumPy oracle (``run_single_direction`` and ``excitation``) on a shorter log and the largest
  difference of ω̂ and λ_min between the two;
* the compile cost: a fresh child process with an empty ``NUMBA_CACHE_DIR`` imports the estimator and runs it on
  five samples (CPU time of that first call, and the child's whole CPU time), then the same with the cache filled;
  and ``omegahat estimate`` on a one-direction log (60 s at 10 Hz, one reference, ``--inertia``), empty cache and
  filled, the child's CPU and wall time. ``--rounds`` rounds each (the machine is shared: best and median).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from omegahat.observer.single_direction import (
    DEFAULT_BANDWIDTH_HZ,
    SingleDirectionEstimator,
    default_gains,
    excitation,
    run_single_direction,
)
from omegahat.simulation.rigid_body import RigidBody, integrate
from results_md import machine_line, write_section

J = np.diag([3.0, 2.0, 1.0])
V = np.array([0.6, 0.0, 0.8])
FIRST_CALL = r"""
import time
c0 = time.process_time()
import numpy as np
from omegahat.observer.single_direction import SingleDirectionEstimator
c1 = time.process_time()
b = np.tile([0.0, 0.6, 0.8], (5, 1))
SingleDirectionEstimator(np.diag([3.0, 2.0, 1.0]), reference=[0.0, 0.6, 0.8]).run(np.arange(5) * 0.1, b)
print(time.process_time() - c1)
"""


def directions(times, omega0, sigma_deg=0.0, missing=0.0, seed=0):
    tr = integrate(RigidBody(J), np.eye(3), omega0, times, max_step=min(1e-2, float(np.diff(times[:2])[0])))
    b = np.einsum("tji,j->ti", tr.R, V)
    rng = np.random.default_rng(seed)
    b = b + rng.normal(0.0, np.radians(sigma_deg), b.shape)
    b[rng.random(times.size) < missing] = np.nan
    b[0] = np.einsum("ji,j->i", tr.R[0], V)
    return b, tr.omega


def best_throughput(times, b, method, reps=3):
    best = np.inf
    for _ in range(reps):
        est = SingleDirectionEstimator(J, reference=V, method=method)
        c0 = time.process_time()
        est.run(times, b)
        best = min(best, time.process_time() - c0)
    return times.size / best


def child(argv, cache):
    """``(child CPU s, wall s, stdout)`` of one child process with ``NUMBA_CACHE_DIR=cache``."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.perf_counter()
    p = subprocess.run(argv, env=env, capture_output=True, text=True)
    wall = time.perf_counter() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return cpu, wall, p.stdout


def spread(values):
    return f"best {min(values):.2f} s, median {float(np.median(values)):.2f} s"


def compile_rows(rounds, log):
    exe = shutil.which("omegahat") or str(Path(sys.executable).with_name("omegahat"))
    command = [exe, "estimate", str(log), "-o", str(log.with_suffix(".out.csv")), "--references=0.6,0,0.8"]
    command += ["--inertia", "3", "2", "1"]
    first, whole, first_cached, cli_cpu, cli_wall, cli_cached = [], [], [], [], [], []
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as cache:
            cpu, _, out = child([sys.executable, "-c", FIRST_CALL], cache)
            first.append(float(out.split()[-1]))
            whole.append(cpu)
            _, _, out = child([sys.executable, "-c", FIRST_CALL], cache)
            first_cached.append(float(out.split()[-1]))
        with tempfile.TemporaryDirectory() as cache:
            cpu, wall, _ = child(command, cache)
            cli_cpu.append(cpu)
            cli_wall.append(wall)
            cpu, _, _ = child(command, cache)
            cli_cached.append(cpu)
    return [
        f"| first call, empty cache (CPU time of the call; {rounds} fresh processes) | {spread(first)} |",
        f"| that child process in all (interpreter, imports, compilation) | CPU {spread(whole)} |",
        f"| first call, cache filled | {spread(first_cached)} |",
        f"| `omegahat estimate` one direction with `--inertia`, empty cache | CPU {spread(cli_cpu)}; wall "
        f"{spread(cli_wall)} |",
        f"| the same, cache filled | CPU {spread(cli_cached)} |",
    ]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000, help="log length for run (default 1e6)")
    parser.add_argument("--oracle-samples", type=int, default=2_000)
    parser.add_argument("--rounds", type=int, default=3, help="fresh processes for the compile cost")
    args = parser.parse_args(argv)
    load = os.getloadavg()
    lines = ["| measurement | result |", "| --- | --- |"]
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "sun.csv"
        t10 = np.arange(600) * 0.1
        b10, _ = directions(t10, [0.3, 0.2, -0.4])
        rows = [f"{float(t)!r},{float(x)!r},{float(y)!r},{float(z)!r}" for t, (x, y, z) in zip(t10, b10, strict=True)]
        log.write_text("t,b1x,b1y,b1z\n" + "\n".join(rows) + "\n")
        compile_lines = compile_rows(args.rounds, log)  # before this process loads the cache (no effect on it)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    fast = np.arange(args.samples) * 1e-3
    b_fast, _ = directions(fast, [2.0, -1.0, 0.6])
    slow = np.arange(args.samples // 10) * 0.1
    b_slow, _ = directions(slow, [0.3, 0.2, -0.4], sigma_deg=0.1, missing=0.02, seed=1)
    for method in ("sarras", "gradient"):
        SingleDirectionEstimator(J, reference=V, method=method).run(fast[:10], b_fast[:10])  # compile or load the cache
        rate = best_throughput(fast, b_fast, method)
        lines.append(f"| `run`, {method}, {fast.size:,} samples at 1 kHz | {rate / 1e6:.2f} million samples/s |")
        rate = best_throughput(slow, b_slow, method)
        lines.append(
            f"| `run`, {method}, {slow.size:,} samples at 10 Hz (0.1° noise, 2 % missing) | {rate / 1e6:.2f} "
            "million samples/s |"
        )
    est = SingleDirectionEstimator(J, reference=V)
    est.run(slow[:1], b_slow[:1])
    calls = min(50_000, slow.size - 1)
    per_call = np.empty(calls)
    clock = time.perf_counter_ns
    for j in range(1, calls + 1):
        tj, bj = float(slow[j]), b_slow[j]
        c0 = clock()
        est.update(tj, bj)
        per_call[j - 1] = clock() - c0
    lines.append(
        f"| `update`, one sample (the per-sample path), 10 Hz log | median {np.median(per_call) / 1e3:.1f} us "
        f"(90th percentile {np.percentile(per_call, 90) / 1e3:.1f} us) over {calls:,} calls |"
    )
    n = args.oracle_samples
    k, l = default_gains(J, "sarras", DEFAULT_BANDWIDTH_HZ)
    c0 = time.process_time()
    W0, _ = run_single_direction(slow[:n], b_slow[:n], J, k=k, l=l)
    lam0, _, _ = excitation(slow[:n], b_slow[:n])
    dt = time.process_time() - c0
    est = SingleDirectionEstimator(J, reference=V)
    W = est.run(slow[:n], b_slow[:n]).omega
    lines.append(
        f"| plain NumPy oracle (`run_single_direction` + `excitation`) | {n / dt:,.0f} samples/s; largest "
        f"difference from the compiled step over {n:,} samples: ω̂ {np.nanmax(np.abs(W - W0)):.1e} rad/s, λ_min "
        f"{np.nanmax(np.abs(est.excitation - lam0)):.1e} |"
    )
    table = "\n".join(lines + compile_lines)
    print(table)
    write_section(
        "## The one-direction observer, compiled (benchmarks/single_direction_speed.py)",
        f"{machine_line()} Command: `python benchmarks/single_direction_speed.py --samples {args.samples} --rounds "
        f"{args.rounds}` (throughputs: CPU time, one core, best of 3; default gains, bandwidth 0.5 rad/s; compile "
        "cost: fresh child processes, each with an empty `NUMBA_CACHE_DIR`). Load average of the machine (1 min) "
        f"at the start and the end: {load[0]:.1f} and {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores, hence wall "
        "times well above CPU times.\n\n" + table,
    )


if __name__ == "__main__":
    main()
