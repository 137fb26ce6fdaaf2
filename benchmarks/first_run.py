"""First run of every ``omegahat estimate`` path and of ``omegahat paper``: on an empty Numba cache, then from it.

Each path runs as a child process with ``NUMBA_CACHE_DIR`` set to a fresh, empty folder (what a fresh install
has: nothing compiled), then a second time with that folder filled by the first run. Measured per run: wall time
and the child's CPU time (user + sys, less sensitive to the other users of a shared machine), and the line in
which the command announces the wait. Paths (100 Hz, 60 s logs):

* ``estimate`` no model (quaternions); ``--inertia 3 2 1``; two body-frame directions ``b1x..b2z`` with
  ``--references``; ``--preset mocap``;
* ``paper`` (the paper's simulation, 10 s, its figures).

Target (issue 22): every first run within 10 s on 2 cores. Writes its section of ``benchmarks/RESULTS.md``
(``--no-write``: print only; ``--label TEXT`` names the code measured; ``--paths a,b``: a subset; ``--before FILE``:
the rows printed by an earlier run, shown beside this run's, e.g. the same script run on the parent commit).

    python benchmarks/first_run.py
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

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from logmaker import constant_rate, write_csv
from results_md import drop_section, machine_line, write_section

SECTION = "## First run of `omegahat estimate` and `omegahat paper` (benchmarks/first_run.py)"
LEGACY = "## First run of `omegahat estimate` (benchmarks/first_run.py)"  # this section's title before issue 22
PATHS = ("no-model", "inertia", "directions", "preset", "paper")


def _directions_log(path: Path, t: np.ndarray) -> Path:
    """Two body-frame directions ``r_i = Rᵀ v_i`` of the references (1,0,0) and (0,1,0)."""
    R = constant_rate(t, [0.1, -0.2, 0.3], sigma=1e-3).as_matrix()
    b = np.concatenate([R[:, 0, :], R[:, 1, :]], axis=1)  # rows of R = Rᵀ e_x, Rᵀ e_y
    with open(path, "w") as f:
        f.write("t,b1x,b1y,b1z,b2x,b2y,b2z\n")
        for tk, row in zip(t, b, strict=True):
            f.write(",".join(repr(float(x)) for x in (tk, *row)) + "\n")
    return path


def commands(tmp: Path, exe: str) -> dict[str, list[str]]:
    t = np.arange(6000) / 100.0
    quats = write_csv(tmp / "log.csv", t, constant_rate(t, [0.1, -0.2, 0.3], sigma=1e-3))
    dirs = _directions_log(tmp / "dirs.csv", t)
    out = str(tmp / "o.csv")
    return {
        "no-model": [exe, "estimate", str(quats), "-o", out],
        "inertia": [exe, "estimate", str(quats), "-o", out, "--inertia", "3", "2", "1"],
        "directions": [exe, "estimate", str(dirs), "-o", out, "--references=1,0,0;0,1,0"],
        "preset": [exe, "estimate", str(quats), "-o", out, "--preset", "mocap"],
        "paper": [exe, "paper", "--out", str(tmp / "paper")],
    }


def timed(cmd: list[str], env: dict[str, str]) -> tuple[float, float, str]:
    """``(wall s, child CPU s, the announcement lines)`` of one run; raises on a non-zero exit."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {p.stderr}")
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    said = [line.strip() for line in (p.stderr + p.stdout).splitlines() if "compil" in line or "simulated" in line]
    return wall, cpu, " / ".join(said)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--label", default="")
    parser.add_argument("--paths", default=",".join(PATHS))
    parser.add_argument("--before", type=Path, help="rows printed by an earlier run (shown as 'before')")
    args = parser.parse_args()
    exe = shutil.which("omegahat") or str(Path(sys.executable).with_name("omegahat"))
    rows = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        cmds = commands(tmp, exe)
        for name in args.paths.split(","):
            cache = tmp / f"cache-{name}"
            cache.mkdir()
            env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
            for run in ("empty cache", "cached"):
                wall, cpu, said = timed(cmds[name], env)
                rows.append(f"| {name} | {run} | {wall:.1f} s | {cpu:.1f} s | {said} |")
                print(rows[-1], flush=True)
    head = "| path | cache | wall | CPU (user+sys) | what the command says |\n| --- | --- | --- | --- | --- |\n"
    before = ""
    if args.before is not None:
        lines = [line for line in args.before.read_text().splitlines() if line.startswith("| ")]
        before = (
            "Before (the same script on the code before the change):\n\n" + head + "\n".join(lines) + "\n\nAfter:\n\n"
        )
    body = (
        f"{machine_line()} Command: `python benchmarks/first_run.py` (each path in a child process with "
        "`NUMBA_CACHE_DIR` set to a fresh empty folder, then again with it filled; 100 Hz, 60 s logs; "
        f"{args.label or 'this commit'}). The machine is shared: CPU time is the steadier figure.\n\n"
        + before
        + head
        + "\n".join(rows)
        + "\n\nTarget (issue 22): every first run within 10 s on 2 cores, the wait announced whole.\n"
    )
    if not args.no_write:
        write_section(SECTION, body)
        drop_section(LEGACY)


if __name__ == "__main__":
    main()
