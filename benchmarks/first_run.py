"""First run of every ``omegahat estimate`` path and of ``omegahat paper``: on a fresh install, and on an empty cache.

Two measurements, each path a child process, each run timed for its wall time and its CPU time (user + sys of the
child and its children: less sensitive to the other users of a shared machine), with the lines in which the command
announces a wait:

* **fresh install** (what a user gets from ``pip install .``): a new virtual environment, ``pip install`` of this
  repository timed (the wheel's build compiles the kernels: ``build_support/omegahat_build.py``), then each path run
  twice with that environment's ``omegahat``, a new home folder (no cache of any kind: Numba's, Matplotlib's font
  list) and no ``NUMBA_CACHE_DIR``. For comparison, the install time of the same build without that step
  (``OMEGAHAT_SKIP_WARMUP=1``, as before it existed). ``--installs N`` repeats the whole;
* **empty cache** (an editable install, a wheel built with ``OMEGAHAT_SKIP_WARMUP=1``, or another Numba): this
  interpreter's ``omegahat`` with ``NUMBA_CACHE_DIR`` a fresh empty folder, then again with it filled.

Paths (100 Hz, 60 s logs): ``estimate`` no model (quaternions); ``--inertia 3 2 1``; two body-frame directions
``b1x..b2z`` with ``--references``; one direction ``b1x..b1z`` with one reference and ``--inertia``; ``--preset
mocap``; ``paper`` (the paper's simulation, 10 s, its figures). ``--suite``: also the README's test command's
``pip install ".[test]"`` and ``pytest`` on a fresh clone of this repository (its last commit), timed once.

Target (issue 22): every first run within 10 s on 2 cores. Writes its section of ``benchmarks/RESULTS.md``
(``--no-write``: print only; ``--label TEXT`` names the code measured; ``--paths a,b``: a subset; ``--skip
fresh|empty``: one measurement only).

    python benchmarks/first_run.py --installs 2
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

SUITE_SECTION = "## The test suite from a fresh clone (benchmarks/first_run.py --suite)"
SECTION = "## First run of `omegahat estimate` and `omegahat paper` (benchmarks/first_run.py)"
LEGACY = "## First run of `omegahat estimate` (benchmarks/first_run.py)"  # this section's title before issue 22
PATHS = ("no-model", "inertia", "directions", "one-direction", "preset", "paper")
REPO = Path(__file__).resolve().parents[1]
HEAD = "| path | cache | wall | CPU (user+sys) | what the command says |\n| --- | --- | --- | --- | --- |\n"


def _directions_log(path: Path, t: np.ndarray, n: int) -> Path:
    """``n`` body-frame directions ``r_i = Rᵀ v_i`` of the references (1,0,0) and (0,1,0)."""
    R = constant_rate(t, [0.1, -0.2, 0.3], sigma=1e-3).as_matrix()
    b = np.concatenate([R[:, 0, :], R[:, 1, :]][:n], axis=1)  # rows of R = Rᵀ e_x, Rᵀ e_y
    names = ",".join(f"b{i}{a}" for i in range(1, n + 1) for a in "xyz")
    np.savetxt(path, np.column_stack([t, b]), fmt="%.17g", delimiter=",", header=f"t,{names}", comments="")
    return path


def commands(tmp: Path, exe: str) -> dict[str, list[str]]:
    t = np.arange(6000) / 100.0
    quats = write_csv(tmp / "log.csv", t, constant_rate(t, [0.1, -0.2, 0.3], sigma=1e-3))
    dirs, one = _directions_log(tmp / "dirs.csv", t, 2), _directions_log(tmp / "dir1.csv", t, 1)
    out = str(tmp / "o.csv")
    return {
        "no-model": [exe, "estimate", str(quats), "-o", out],
        "inertia": [exe, "estimate", str(quats), "-o", out, "--inertia", "3", "2", "1"],
        "directions": [exe, "estimate", str(dirs), "-o", out, "--references=1,0,0;0,1,0"],
        "one-direction": [exe, "estimate", str(one), "-o", out, "--references=1,0,0", "--inertia", "3", "2", "1"],
        "preset": [exe, "estimate", str(quats), "-o", out, "--preset", "mocap"],
        "paper": [exe, "paper", "--out", str(tmp / "paper")],
    }


def timed(cmd: list[str], env: dict[str, str], cwd: Path | None = None) -> tuple[float, float, str]:
    """``(wall s, CPU s of the child and its children, the announcement lines)`` of one run; raises on failure."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {p.stdout[-3000:]}{p.stderr[-3000:]}")
    cpu = after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime
    said = [line.strip() for line in (p.stderr + p.stdout).splitlines() if "compil" in line or "simulated" in line]
    return wall, cpu, " / ".join(said)


def clean_env(**extra: str) -> dict[str, str]:
    """This environment less what would point a child at another omegahat or another cache."""
    drop = ("NUMBA_CACHE_DIR", "PYTHONPATH", "VIRTUAL_ENV", "MPLCONFIGDIR", "XDG_CACHE_HOME", "XDG_CONFIG_HOME")
    return {**{k: v for k, v in os.environ.items() if k not in drop}, **extra}


def venv(folder: Path) -> Path:
    """A new virtual environment of this Python (its ``bin`` folder)."""
    subprocess.run([sys.executable, "-m", "venv", str(folder)], check=True)
    return folder / "bin"


def install(tmp: Path, name: str, target: str, **env: str) -> tuple[Path, float, float]:
    """``pip install target`` into a new environment ``tmp/name``: ``(its bin folder, wall s, CPU s)``."""
    bin_ = venv(tmp / name)
    wall, cpu, _ = timed([str(bin_ / "pip"), "install", "--quiet", target], clean_env(**env))
    return bin_, wall, cpu


def fresh_install(tmp: Path, paths: list[str], round_: int) -> tuple[list[str], list[str]]:
    """One fresh install and each path's first and second run: ``(install rows, run rows)``."""
    bin_, wall, cpu = install(tmp, f"venv-{round_}", str(REPO))
    site = next((bin_.parent / "lib").glob("python3*/site-packages/omegahat"))
    kernels = len(list(site.rglob("*.nbc")))
    _, wall0, cpu0 = install(tmp, f"venv-skip-{round_}", str(REPO), OMEGAHAT_SKIP_WARMUP="1")
    installs = [
        f"| {round_} | `pip install .` (the build compiles the kernels: {kernels} shipped) | {wall:.0f} s "
        f"| {cpu:.0f} s |",
        f"| {round_} | `OMEGAHAT_SKIP_WARMUP=1 pip install .` (no such step) | {wall0:.0f} s | {cpu0:.0f} s |",
    ]
    home = tmp / f"home-{round_}"
    home.mkdir()
    cmds = commands(tmp, str(bin_ / "omegahat"))
    rows = []
    for name in paths:
        for run in ("first run", "second run"):
            w, c, said = timed(cmds[name], clean_env(HOME=str(home)), cwd=tmp)
            rows.append(f"| {name} | fresh install {round_}, {run} | {w:.1f} s | {c:.1f} s | {said} |")
            print(rows[-1], flush=True)
    return installs, rows


def empty_cache(tmp: Path, paths: list[str]) -> list[str]:
    """Each path with ``NUMBA_CACHE_DIR`` a fresh empty folder, then filled."""
    exe = shutil.which("omegahat") or str(Path(sys.executable).with_name("omegahat"))
    cmds = commands(tmp, exe)
    rows = []
    for name in paths:
        cache = tmp / f"cache-{name}"
        cache.mkdir()
        env = {**os.environ, "NUMBA_CACHE_DIR": str(cache)}
        for run in ("empty cache", "cached"):
            wall, cpu, said = timed(cmds[name], env)
            rows.append(f"| {name} | {run} | {wall:.1f} s | {cpu:.1f} s | {said} |")
            print(rows[-1], flush=True)
    return rows


def readme_test_command() -> str:
    """The README's test command: the second line of its first ``bash`` block (as ``.ci/run`` reads it)."""
    lines = (REPO / "README.md").read_text(encoding="utf-8").splitlines()
    start = lines.index("```bash") + 1
    return lines[start + 1]


def suite(tmp: Path) -> str:
    """The README's test command's install and ``pytest`` on a fresh clone: one table row."""
    clone = tmp / "clone"
    subprocess.run(["git", "clone", "--quiet", str(REPO), str(clone)], check=True)
    bin_ = venv(tmp / "venv-test")
    env = clean_env(PATH=f"{bin_}{os.pathsep}{os.environ['PATH']}")
    wall_i, cpu_i, _ = timed([str(bin_ / "pip"), "install", "--quiet", ".[test]"], env, cwd=clone)
    t0 = time.perf_counter()
    # pytest with the README test command's own options (its tail after "pytest"), so the figure is CI's
    pytest_options = readme_test_command().split("pytest", 1)[1].split()
    p = subprocess.run([str(bin_ / "pytest"), "-q", "-p", "no:cacheprovider", *pytest_options], env=env, cwd=clone,
                       capture_output=True)  # fmt: skip
    wall_t = time.perf_counter() - t0
    tail = p.stdout.decode(errors="replace").strip().splitlines()[-1]
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=clone, capture_output=True, text=True)
    return f"| {commit.stdout.strip()} | {wall_i:.0f} s ({cpu_i:.0f} s CPU) | {wall_t:.0f} s | {tail} |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--no-write", action="store_true")
    parser.add_argument("--label", default="")
    parser.add_argument("--paths", default=",".join(PATHS))
    parser.add_argument("--installs", type=int, default=1, help="fresh installs measured (each ~3 min)")
    parser.add_argument("--skip", choices=("fresh", "empty"), action="append", default=[],
                        help="leave a measurement out (twice: both, with --suite the suite alone)")  # fmt: skip
    parser.add_argument("--suite", action="store_true", help="also the test suite on a fresh clone (long)")
    args = parser.parse_args()
    paths = args.paths.split(",")
    installs, fresh, empty, suite_row = [], [], [], ""
    with tempfile.TemporaryDirectory(prefix="first-run-") as tmp_name:
        tmp = Path(tmp_name)
        if "fresh" not in args.skip:
            for round_ in range(1, args.installs + 1):
                i, r = fresh_install(tmp, paths, round_)
                installs += i
                fresh += r
        if "empty" not in args.skip:
            empty = empty_cache(tmp, paths)
        if args.suite:
            suite_row = suite(tmp)
            print(suite_row, flush=True)
    load = os.getloadavg()
    options = (f" --installs {args.installs}" if args.installs > 1 else "") + (" --suite" if args.suite else "")
    options += "".join(f" --skip {s}" for s in args.skip)  # the command as run, so that it reproduces the section
    body = (
        f"{machine_line()} Command: `python benchmarks/first_run.py{options}` ({args.label or 'this commit'}; "
        "load average at the end "
        f"{load[0]:.1f}, {load[1]:.1f}, {load[2]:.1f}: the machine is shared, CPU time is the steadier figure). "
        "100 Hz, 60 s logs; each run a child process.\n\n"
    )
    if installs:
        body += (
            "**Fresh install** (a new virtual environment, `pip install` of this repository, a new home folder: no "
            "cache of any kind, no `NUMBA_CACHE_DIR`). Install times (pip's own download cache warm):\n\n"
            "| round | install | wall | CPU (user+sys) |\n| --- | --- | --- | --- |\n" + "\n".join(installs) + "\n\n"
            "First runs:\n\n" + HEAD + "\n".join(fresh) + "\n\n"
        )
    if empty:
        body += (
            "**Empty cache** (a fresh install's first run before the wheel shipped its kernels; now an editable "
            "install's, a wheel's built with `OMEGAHAT_SKIP_WARMUP=1`, or beside another Numba: `NUMBA_CACHE_DIR` a "
            "fresh empty folder, then filled):\n\n" + HEAD + "\n".join(empty) + "\n\n"
        )
    body += "Target (issue 22): every first run within 10 s on 2 cores, the wait announced whole.\n"
    if installs or empty:
        print(body)
        if not args.no_write:
            write_section(SECTION, body)
            drop_section(LEGACY)
    if suite_row:
        text = (
            f"{machine_line()} Command: `python benchmarks/first_run.py --suite` ({args.label or 'this commit'}): on a "
            "fresh clone of the last commit, in a new virtual environment, the README's test command: `pip install "
            f'".[test]"` timed, then `pytest{readme_test_command().split("pytest", 1)[1]}` timed '
            "(target of issue 22: under about 5 minutes on 2 cores).\n\n| commit | install | pytest wall | pytest's "
            "last line |\n| --- | --- | --- | --- |\n" + suite_row + "\n"
        )
        print(text)
        if not args.no_write:
            write_section(SUITE_SECTION, text)


if __name__ == "__main__":
    main()
