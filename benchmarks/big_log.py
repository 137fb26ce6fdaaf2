"""Big logs end to end: ``omegahat estimate`` on a generated quaternion CSV, wall time and peak memory.

Generates (in a temporary directory) a 100 Hz quaternion log at constant rate with 1 mrad noise, written with
17 significant digits as a logging tool would (2 M rows: about 130 MB), and runs the installed command on it as
a child process, ``repeat`` times, measuring the wall time and the child's peak resident memory (``os.wait4``).
The 2 M-row log also written as Parquet (``-o omega.parquet``) and with ``--estimator sarras`` (the fixed-gain
observer alone, the default when the target was set). Then the default on 20 M rows: the peak memory must not grow
with the rows (the log is streamed in chunks).
Targets (issue 12): 2 M rows in at most 4 s and 300 MB; 20 M rows in the memory of 2 M.

Writes its section of ``benchmarks/RESULTS.md`` (machine, date, command, numbers).

    python benchmarks/big_log.py [--rows 2000000] [--big-rows 20000000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.csv as pacsv

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_md import machine_line, write_section

SARRAS = ("--estimator", "sarras")  #: the fixed-gain observer alone: the default when issue 12 set the 4 s target
SECTION = "## Big logs: `omegahat estimate` end to end (benchmarks/big_log.py)"


def write_log(path: Path, rows: int, rate: float = 100.0, sigma: float = 1e-3, block: int = 1_000_000) -> None:
    """Quaternion CSV ``t,qw,qx,qy,qz`` of a constant body rate (0.1, −0.2, 0.3) rad/s plus white noise."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(0)
    w = np.array([0.1, -0.2, 0.3])
    with open(path, "wb") as f:
        f.write(b"t,qw,qx,qy,qz\n")
        for a in range(0, rows, block):
            k = np.arange(a, min(rows, a + block))
            t = k / rate
            rot = Rotation.from_rotvec(t[:, None] * w) * Rotation.from_rotvec(rng.normal(0.0, sigma, (k.size, 3)))
            q = rot.as_quat()
            table = pa.table({"t": t, "qw": q[:, 3], "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2]})
            pacsv.write_csv(table, f, pacsv.WriteOptions(include_header=False))


def measure(cmd: list[str]) -> tuple[float, float, str]:
    """``(wall s, peak RSS MB, stdout)`` of one run, timed by ``/usr/bin/time`` (a small process forks the command,
    so the peak is the command's own, not inherited from this one) or else by ``os.wait4``."""
    timer = shutil.which("time") if Path("/usr/bin/time").exists() else None
    t0 = time.perf_counter()
    if timer:
        p = subprocess.run(["/usr/bin/time", "-f", "%e %M", *cmd], capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if p.returncode != 0:
            raise RuntimeError(f"{' '.join(cmd)} failed:\n{p.stdout}\n{p.stderr}")
        _, rss_kb = p.stderr.strip().splitlines()[-1].split()
        return wall, float(rss_kb) / 1024.0, p.stdout
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out = p.stdout.read()
    err = p.stderr.read()
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    if status != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{out}\n{err}")
    return wall, usage.ru_maxrss / 1024.0, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=2_000_000)
    ap.add_argument("--big-rows", type=int, default=20_000_000)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    exe = shutil.which("omegahat") or str(Path(sys.executable).with_name("omegahat"))
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        runs_of = (
            (args.rows, args.repeat, (), "omega.csv"),
            (args.rows, args.repeat, (), "omega.parquet"),
            (args.rows, args.repeat, SARRAS, "omega.csv"),
            (args.big_rows, 1, (), "omega.csv"),
        )
        for rows, repeat, options, output in runs_of:
            src = tmp / f"log{rows}.csv"
            if not src.exists():
                for old in tmp.glob("log*.csv"):
                    old.unlink()
                write_log(src, rows)
            mb = src.stat().st_size / 1e6
            cmd = [exe, "estimate", str(src), "-o", str(tmp / output), "--no-progress", *options]
            measure(cmd)  # the first run loads (or compiles) the kernels; not counted
            runs = [measure(cmd) for _ in range(repeat)]
            walls = sorted(r[0] for r in runs)
            peaks = sorted(r[1] for r in runs)
            est = [r[2] for r in runs][-1].splitlines()
            out_mb = (tmp / output).stat().st_size / 1e6
            line = (
                f"| {rows:,} | {' '.join(options) or '(none: the default)'} | {mb:.0f} MB | {output}, "
                f"{out_mb:.0f} MB | {walls[0]:.2f} s / {walls[len(walls) // 2]:.2f} s | {peaks[-1]:.0f} MB | {repeat} |"
            )
            print(line, flush=True)
            print("\n".join("    " + s for s in est if s.startswith(("gains", "wrote"))), flush=True)
            lines.append(line)
    body = (
        f"{SECTION}\n\n"
        f"{machine_line()} Command: `python benchmarks/big_log.py "
        f"--rows {args.rows} --big-rows {args.big_rows} --repeat {args.repeat}` (each run: `omegahat estimate LOG -o "
        "OUT --no-progress` as a child process, after one untimed run that loads the compiled kernels).\n\n"
        "| rows | options | CSV size | output, its size | wall time, best / median | peak memory (max RSS) | runs |\n"
        "| --- | --- | --- | --- | --- | --- | --- |\n"
        + "\n".join(lines)
        + "\n\nTargets (issue 12): 2 M rows in at most 4 s and 300 MB; 20 M rows in constant memory. The default "
        "runs the model identified from the log (here the rate model's filter: the observer supervising its EKF); "
        "`--estimator sarras` the fixed-gain observer alone, the default when issue 12 set its target.\n"
    )
    write_section(SECTION, body[len(SECTION) :])


if __name__ == "__main__":
    main()
