"""Many logs in one command: ``omegahat estimate DIR -o OUTDIR`` on one core and on every core, throughput.

Generates (in a temporary directory) ``--files`` quaternion logs (default 200; ``--rows`` rows each at 100 Hz,
default 6000, a one-minute take, then 20000, the size of the real recordings the tests use; each a different
constant rate with 1 mrad noise, 17 significant digits) and runs the installed command on the folder as a child
process, alternately with ``--jobs 1`` (one file after another in
the command's process) pinned to one core (``sched_setaffinity``: its reader and writer threads share that core),
and ``--jobs N`` (default: every core) on every core, ``--repeat`` rounds (default 3), each into a fresh output
directory. Each run is timed from start to exit (wall) with the child's CPU time (user + system, its
processes included: ``os.times`` of the children); the machine's load average is read before each run, since the
machine is shared; ``--boost`` (module ``main``'s help) gives each measured command a scheduling group of its own
at high priority, so that the neighbours' work does not set the result. Throughput = files per wall second; the
speed-up is that of the same round. Target (issue 25): at least 1.7x one core's throughput on 2 cores.

Writes its section of ``benchmarks/RESULTS.md``.

    python benchmarks/many_files.py [--files 200] [--rows 6000 20000] [--repeat 3] [--jobs N] [--boost]
                                    [-- extra options]
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
SECTION_BOOSTED = "## Many files in one command, the session at nice -20 (benchmarks/many_files.py --boost)"


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


def timed(cmd: list[str], cores: set[int], boost: bool) -> tuple[float, float, str]:
    """``(wall s, CPU s of the child and all its descendants, stdout)`` of ``cmd`` run on ``cores`` only (its
    processes inherit the affinity), in a session of its own whose scheduling group has nice -20 if ``boost``:
    the children's rusage before and after."""

    def setup() -> None:
        os.sched_setaffinity(0, cores)
        if boost:
            os.setsid()  # a new session is a new scheduling group (autogroup), shared by the command's processes
            Path("/proc/self/autogroup").write_text("-20")

    r0 = os.times()
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, preexec_fn=setup)
    wall = time.perf_counter() - t0
    r1 = os.times()
    if proc.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
    cpu = (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system)
    return wall, cpu, proc.stdout


def measure(a: argparse.Namespace, exe: str, tmp: Path, rows: int) -> list[tuple[int, float, float, float]]:
    """``(jobs, wall, CPU, load)`` of every run on a folder of ``a.files`` logs of ``rows`` rows."""
    folder = tmp / f"takes-{rows}"
    folder.mkdir()
    write_logs(folder, a.files, rows)
    everything = os.sched_getaffinity(0)
    runs = []
    for r in range(a.repeat):
        for jobs in (1, a.jobs):
            out = tmp / f"out-{rows}-{r}-{jobs}"
            load = os.getloadavg()[0]
            cmd = [exe, "estimate", str(folder), "-o", str(out), "--no-progress", "--jobs", str(jobs), *a.extra]
            wall, cpu, stdout = timed(cmd, {min(everything)} if jobs == 1 else everything, a.boost)
            last = stdout.strip().splitlines()[-1]
            if f"{a.files} files ({a.files} ok)" not in last:
                raise SystemExit(f"not every file ran: {last}")
            runs.append((jobs, wall, cpu, load))
            print(f"{rows} rows, round {r + 1}, --jobs {jobs}: {wall:.1f} s wall, {cpu:.1f} s CPU, load {load:.1f}")
            shutil.rmtree(out)
    shutil.rmtree(folder)
    return runs


def table(a: argparse.Namespace, rows: int, runs: list[tuple[int, float, float, float]]) -> tuple[list[str], str]:
    """The table's rows for one log size, and its speed-ups (one core's wall / the pool's, round by round)."""
    lines = []
    for jobs in (1, a.jobs):
        walls = [w for j, w, _, _ in runs if j == jobs]
        cpus = [c for j, _, c, _ in runs if j == jobs]
        loads = [ld for j, _, _, ld in runs if j == jobs]
        where = "1 core" if jobs == 1 else f"{len(os.sched_getaffinity(0))} cores"
        lines.append(
            f"| {rows} | `--jobs {jobs}`, {where} | {a.files / min(walls):.2f} | "
            f"{a.files / statistics.median(walls):.2f} | {min(walls):.1f} / {statistics.median(walls):.1f} | "
            f"{statistics.median(cpus):.1f} | {min(loads):.1f}–{max(loads):.1f} |"
        )
    one = [w for j, w, _, _ in runs if j == 1]
    pool = [w for j, w, _, _ in runs if j == a.jobs]
    ratios = [x / y for x, y in zip(one, pool, strict=True)]
    speed = f"{rows} rows: " + ", ".join(f"{x:.2f}x" for x in ratios) + f" (median {statistics.median(ratios):.2f}x)"
    return lines, speed


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--files", type=int, default=200)
    ap.add_argument("--rows", type=int, nargs="+", default=[6000, 20000], help="rows per log; several: one table each")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 2)
    ap.add_argument("--no-write", action="store_true", help="print only; leave RESULTS.md as it is")
    ap.add_argument(
        "--boost",
        action="store_true",
        help="run each measured command in a session of its own at autogroup nice -20 (root): on a machine whose "
        "kernel shares the CPU by session (sched_autogroup), a session gets the same share with one process or "
        "two while others are busy, so only then do the cores, not the neighbours, set the speed",
    )
    ap.add_argument("extra", nargs="*", help="options for every file (after --)")
    a = ap.parse_args()
    exe = shutil.which("omegahat")
    if exe is None:
        raise SystemExit("the omegahat command is not on PATH (pip install -e .)")
    lines, speeds = [], []
    with tempfile.TemporaryDirectory(prefix="omegahat-many-") as tmp:
        for rows in a.rows:
            part, speed = table(a, rows, measure(a, exe, Path(tmp), rows))
            lines += part
            speeds.append(speed)
    command = (
        f"python benchmarks/many_files.py --files {a.files} --rows {' '.join(map(str, a.rows))} --repeat {a.repeat} "
        f"--jobs {a.jobs}" + (" --boost" if a.boost else "") + (f" -- {' '.join(a.extra)}" if a.extra else "")
    )
    autogroup = Path("/proc/sys/kernel/sched_autogroup_enabled")
    shared_by_session = autogroup.exists() and autogroup.read_text().strip() == "1"
    how = (
        "each command in a session of its own at autogroup nice -20, so that the other sessions' work (load "
        "average below) takes little of the cores"
        if a.boost
        else "each command in this session, competing with the other sessions' work (load average below)"
        + (
            "; this kernel shares the CPU by session (sched_autogroup), so while others are busy a session gets "
            "the same share with one process or two: see --boost"
            if shared_by_session
            else ""
        )
    )
    body = "\n".join(
        [
            machine_line(),
            "",
            f"`{command}`: {a.files} quaternion logs (100 Hz, 1 mrad noise; 6000 rows: a one-minute take, 20000: "
            "the size of TUM's fr2_desk ground truth or a BROAD recording) in one folder, `omegahat estimate FOLDER "
            f"-o OUT` with `--jobs 1` (in the command's process) pinned to one core, and `--jobs {a.jobs}` (a pool of "
            f"{a.jobs} processes) on every core, alternately, {a.repeat} rounds; {how}. Wall time of the whole "
            "command (its start, the workers' start and their loading of the kernels included) and the CPU time of "
            "the command and its processes.",
            "",
            "| rows | run | files/s (best) | files/s (median) | wall s (best / median) | CPU s (median) | load avg. |",
            "| ---: | --- | ---: | ---: | ---: | ---: | ---: |",
            *lines,
            "",
            "Speed-up, one core's wall / the pool's, round by round: " + "; ".join(speeds) + ".",
        ]
    )
    print(body)
    if not a.no_write:
        write_section(SECTION_BOOSTED if a.boost else SECTION, body)


if __name__ == "__main__":
    main()
