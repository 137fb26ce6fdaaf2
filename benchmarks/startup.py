"""Start-up of the command line: how long a user waits for ``omegahat --version``, the overview ``omegahat --help``,
``omegahat estimate --help`` and the default ``omegahat estimate`` of a short log, where the work itself takes a
few milliseconds and the rest is the interpreter, the imports and the loading of the compiled kernels from their cache.

Run: ``python benchmarks/startup.py [--rounds N] [--before SRC]``. ``SRC``: the ``src`` folder of another checkout
of omegahat (``git worktree add /tmp/before COMMIT``, then ``--before /tmp/before/src``), measured the same way in
alternate rounds. Each run is a child process (``python -c`` putting the source folder first on ``sys.path`` and
calling the console script's function), after one untimed run of each command that fills the kernels' cache. Data:
a 30 s, 100 Hz log of quaternions (a body turning with a few incommensurate rates, 1 mrad of attitude noise).
Writes its section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from results_md import machine_line, write_section

SECTION = "## Start-up of the command line (benchmarks/startup.py)"
THIS_SRC = Path(__file__).resolve().parents[1] / "src"


def write_log(path: Path, seconds: float = 30.0, rate: float = 100.0) -> None:
    rng = np.random.default_rng(0)
    t = np.arange(0.0, seconds, 1.0 / rate)
    rates = np.c_[np.sin(1.3 * t), 0.5 * np.cos(2.9 * t + 1.0), 0.8 * np.sin(0.7 * t) + 0.3 * np.sin(7.1 * t)]
    turn = Rotation.from_rotvec(np.cumsum(rates / rate, axis=0)) * Rotation.from_rotvec(
        1e-3 * rng.standard_normal((t.size, 3))
    )
    q = turn.as_quat(scalar_first=True)
    np.savetxt(path, np.column_stack([t, q]), delimiter=",", header="t,qw,qx,qy,qz", comments="", fmt="%.9f")


def launcher(src: Path, words: list[str]) -> list[str]:
    code = f"import sys; sys.path.insert(0, {str(src)!r}); sys.argv = ['omegahat', *{words!r}]; "
    code += "from omegahat.cli import entry; entry()"
    return [sys.executable, "-c", code]


def wall(cmd: list[str]) -> float:
    t0 = time.perf_counter()
    done = subprocess.run(cmd, capture_output=True, text=True)
    seconds = time.perf_counter() - t0
    if done.returncode != 0:
        raise SystemExit(f"{cmd[-1]}: exit {done.returncode}\n{done.stderr}")
    return seconds


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--before", type=Path, help="the src folder of another checkout, measured alike")
    args = parser.parse_args()
    versions = {"this checkout": THIS_SRC} | ({"before": args.before.resolve()} if args.before else {})
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        write_log(tmp / "log.csv")
        commands = {
            "`omegahat --version`": ["--version"],
            "`omegahat --help`": ["--help"],
            "`omegahat estimate --help`": ["estimate", "--help"],
            "`omegahat estimate log.csv -o out.csv` (3,000 rows)": [
                "estimate", str(tmp / "log.csv"), "-o", str(tmp / "out.csv"), "--no-progress",
            ],
        }  # fmt: skip
        for src in versions.values():  # untimed: compiles what the cache lacks
            for words in commands.values():
                wall(launcher(src, words))
        times: dict[tuple[str, str], list[float]] = {(v, c): [] for v in versions for c in commands}
        for _ in range(args.rounds):
            for version, src in versions.items():
                for name, words in commands.items():
                    times[version, name].append(wall(launcher(src, words)))
    table = ["| command | " + " | ".join(f"{v}: best / median" for v in versions) + " |"]
    table.append("| --- |" + " --- |" * len(versions))
    for name in commands:
        cells = [f"{min(times[v, name]):.2f} s / {statistics.median(times[v, name]):.2f} s" for v in versions]
        table.append(f"| {name} | " + " | ".join(cells) + " |")
    before = f" --before {args.before}" if args.before else ""
    head = (
        f"{machine_line()} Command: `python benchmarks/startup.py --rounds {args.rounds}{before}` (wall time of a "
        f"child process per run, {args.rounds} rounds, the versions alternating; the kernels' cache warm)."
    )
    print(head, *table, sep="\n")
    write_section(SECTION, "\n".join([head, "", *table]))


if __name__ == "__main__":
    main()
