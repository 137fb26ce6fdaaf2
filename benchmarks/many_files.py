"""Many logs in one command: ``omegahat estimate DIR -o OUTDIR`` on one core and on every core, throughput.

Generates (in a temporary directory) ``--files`` quaternion logs (default 200; ``--rows`` rows each at 100 Hz,
default 6000: a one-minute take; each a different constant rate with 1 mrad noise, 17 significant digits) and runs
the installed command on the folder as a child process, alternately with ``--jobs 1`` (one file after another in
the command's process) pinned to one core (``sched_setaffinity``: its reader and writer threads share that core),
and ``--jobs N`` (default: every core) on every core, ``--repeat`` rounds (default 3), each into a fresh output
directory. Each run is timed from start to exit (wall) with the child's CPU time (user + system, its
processes included, from ``os.wait4``); the machine's load average is read before each run, since the machine is
shared. Throughput = files per wall second; the speed-up is that of the same round. Target (issue 25): at least
1.7x one core's throughput on 2 cores.

Writes its section of ``benchmarks/RESULTS.md``.

    python benchmarks/many_files.py [--files 200] [--rows 6000] [--repeat 3] [--jobs N] [-- extra options]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_md import machine_line, write_section

SECTION = "## Many files in one command (benchmarks/many_files.py)"


def write_logs(folder: Path, files: int, rows: int) -> None:
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(25)
    t = np.arange(rows) / 100.0
    for k in range(files):
        w = rng.normal(0.0, 0.5, 3)
        rot = Rotation.from_rotvec(t[:, None] * w) * Rotation.from_rotvec(rng.normal(0.0, 1e-3, (rows, 3)))
        q = rot.as_quat()
        table = np.column_stack([t, q[:, 3], q[:, 0], q[:, 1], q[:, 2]])
        np.savetxt(folder / f"take{k:04d}.csv", table, fmt="%.17g", delimiter=",", header="t,qw,qx,qy,qz", comments="")


def timed(cmd: list[str], cores: set[int]) -> tuple[float, float, str]:
    """``(wall s, CPU s of the child and all its descendants, stdout)`` of ``cmd`` run on ``cores`` only (its
    processes inherit the affinity): the children's rusage before and after."""
    r0 = os.times()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=lambda: os.sched_setaffinity(0, cores))
    wall = time.perf_counter() - t0
    r1 = os.times()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    return wall, cpu, proc.stdout


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--files", type=int, default=200)
    ap.add_argument("--rows", type=int, default=6000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    ap.add_argument("extra", nargs="*", help="options for every file (after --)")
    a = ap.parse_args()
    exe = shutil.which("omegahat")
    if exe is None:
        raise SystemExit("the omegahat command is not on PATH (pip install -e .)")
    results: dict[int, list[tuple[float, float, float]]] = {1: [], a.jobs: []}
    with tempfile.TemporaryDirectory(prefix="omegahat-many-") as tmp:
        folder = Path(tmp) / "takes"
        folder.mkdir()
        write_logs(folder, a.files, a.rows)
        everything = os.sched_getaffinity(0)
        for r in range(a.repeat):
            for jobs in (1, a.jobs):
                out = Path(tmp) / f"out-{r}-{jobs}"
                load = os.getloadavg()[0]
                cmd = [exe, "estimate", str(folder), "-o", str(out), "--no-progress", "--jobs", str(jobs), *a.extra]
                wall, cpu, stdout = timed(cmd, {min(everything)} if jobs == 1 else everything)
                last = stdout.strip().splitlines()[-1]
                if f"{a.files} files ({a.files} ok)" not in last:
                    raise SystemExit(f"not every file ran: {last}")
                results[jobs].append((wall, cpu, load))
                print(f"round {r + 1}, --jobs {jobs}: {wall:.1f} s wall, {cpu:.1f} s CPU, load {load:.1f}", flush=True)
                shutil.rmtree(out)
    one, many = results[1], results[a.jobs]
    ratios = [a_[0] / b[0] for a_, b in zip(one, many, strict=True)]
    command = (
        f"python benchmarks/many_files.py --files {a.files} --rows {a.rows} --repeat {a.repeat} --jobs {a.jobs}"
        + (f" -- {' '.join(a.extra)}" if a.extra else "")
    )

    def row(jobs: int, runs: list[tuple[float, float, float]]) -> str:
        walls = [w for w, _, _ in runs]
        cpus = [c for _, c, _ in runs]
        loads = [ld for _, _, ld in runs]
        return (
            f"| `--jobs {jobs}` | {a.files / min(walls):.2f} | {a.files / statistics.median(walls):.2f} | "
            f"{min(walls):.1f} / {statistics.median(walls):.1f} | {statistics.median(cpus):.1f} | "
            f"{min(loads):.1f}–{max(loads):.1f} |"
        )

    body = "\n".join(
        [
            machine_line(),
            "",
            f"`{command}`: {a.files} quaternion logs of {a.rows} rows (100 Hz, 1 mrad noise) in one folder, "
            f"`omegahat estimate FOLDER -o OUT` with `--jobs 1` (in the command's process) pinned to one core, and "
            f"`--jobs {a.jobs}` (a pool of {a.jobs} processes) on {len(os.sched_getaffinity(0))} cores, alternately, "
            f"{a.repeat} rounds; wall time of the whole command (start, workers' start and kernel loading included) "
            "and the CPU time of the command and its processes.",
            "",
            "| run | files/s (best) | files/s (median) | wall s (best / median) | CPU s (median) | load average |",
            "| --- | ---: | ---: | ---: | ---: | ---: |",
            row(1, one),
            row(a.jobs, many),
            "",
            f"Speed-up (same round, one core's wall / {a.jobs} processes' wall on every core): "
            + ", ".join(f"{x:.2f}x" for x in ratios)
            + f"; median {statistics.median(ratios):.2f}x, best {max(ratios):.2f}x. The machine is shared (load "
            "average above): the processes compete with other work for the same cores.",
        ]
    )
    print(body)
    if not a.no_write:
        write_section(SECTION, body)


if __name__ == "__main__":
    main()
