"""Per-sample cost of the default's pieces on attitudes: the pipeline's screen of turns (spikes, resets, jumps:
``omegahat.io.screen.TurnScreen``), the model's filter (``SupervisedKalmanEstimator.run``, the observer supervising
its gyro-less EKF) and the fixed-gain observer alone (``SarrasEstimator.run``).

Run: ``python benchmarks/default_speed.py [--samples N] [--rounds R] [--before SRC]``. ``SRC``: the ``src`` folder of
another checkout (``git worktree add /tmp/before COMMIT``, then ``--before /tmp/before/src``), measured the same way
in alternate rounds. Each measurement runs in a child process with its source folder first on ``sys.path``, after
an untimed run that loads (or compiles) the kernels; the time is the best of 3 in that process, in µs per sample.
Data: ``N`` quaternions (default 400,000) at 100 Hz of a body turning at (0.3, −0.2, 0.5) rad/s with 1 mrad of
noise; the screen takes them in chunks of ``CHUNK_ROWS`` (its scales from the first 8,192). The machine may be
shared: the rounds' spread is shown. Writes its section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from results_md import machine_line, write_section

SECTION = "## The default's pieces per sample (benchmarks/default_speed.py)"
THIS_SRC = Path(__file__).resolve().parents[1] / "src"

CHILD = r"""
import inspect, json, sys, time
import numpy as np
from scipy.spatial.transform import Rotation
from omegahat.io.registry import CHUNK_ROWS, LogChunk
from omegahat.io.pipeline import EstimateSettings, RunSummary
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.tuning import bandwidth_gains
try:
    from omegahat.io.screen import TurnScreen
except ImportError:  # a checkout from before the screen had its own module
    from omegahat.io.pipeline import TurnScreen

n = int(sys.argv[1])
t = np.arange(n) * 0.01
noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((n, 3)))
q = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_quat()
chunks = [LogChunk(t[a:a + CHUNK_ROWS], q[a:a + CHUNK_ROWS], None, np.arange(a, min(n, a + CHUNK_ROWS)))
          for a in range(0, n, CHUNK_ROWS)]
takes_head = "head" in inspect.signature(TurnScreen).parameters
spacing = [0.01] if "spacing" in inspect.signature(TurnScreen).parameters else []  # older trees judge no gaps


def screen():
    s = TurnScreen(EstimateSettings(), RunSummary(), *([[q[:8192]]] if takes_head else []), *spacing)
    for c in chunks:
        s.feed(c)
    s.finish()


gains = bandwidth_gains(np.eye(3), 100.0 / (2.0 * np.pi))
cases = {
    "screen": screen,
    "model's filter": lambda: SupervisedKalmanEstimator(
        np.eye(3), rate_hz=100.0, measurement_noise=1e-3, rate_noise=1e-6).run(t, q),
    "observer alone": lambda: SarrasEstimator(np.eye(3), gains=gains).run(t, q),
}
out = {}
for name, run in cases.items():
    run()  # the kernels loaded or compiled, untimed
    best = float("inf")
    for _ in range(3):
        t0 = time.perf_counter()
        run()
        best = min(best, time.perf_counter() - t0)
    out[name] = best / n * 1e6
print(json.dumps(out))
"""


def measure(src: Path, samples: int) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(src)}
    done = subprocess.run([sys.executable, "-c", CHILD, str(samples)], env=env, capture_output=True, text=True)
    if done.returncode:
        raise RuntimeError(done.stderr[-2000:])
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--samples", type=int, default=400_000)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--before", type=Path, help="the src folder of another checkout, measured alike")
    args = parser.parse_args()
    versions = {"this checkout": THIS_SRC} | ({"before": args.before.resolve()} if args.before else {})
    got: dict[str, list[dict[str, float]]] = {v: [] for v in versions}
    for r in range(args.rounds):
        for name, src in versions.items():
            got[name].append(measure(src, args.samples))
            print(f"round {r + 1}, {name}: {got[name][-1]}", flush=True)
    pieces = list(got["this checkout"][0])
    head = "| piece | " + " | ".join(f"{v}: best / worst round (µs per sample)" for v in versions) + " |"
    lines = [head, "| --- |" + " --- |" * len(versions)]
    for piece in pieces:
        cells = []
        for v in versions:
            xs = [g[piece] for g in got[v]]
            cells.append(f"{min(xs):.3f} / {max(xs):.3f}")
        lines.append(f"| {piece} | " + " | ".join(cells) + " |")
    table = "\n".join(lines)
    print(table)
    before = f" --before {args.before}" if args.before else ""
    write_section(
        SECTION,
        f"{machine_line()} Command: `python benchmarks/default_speed.py --samples {args.samples} --rounds "
        f"{args.rounds}{before}` ({args.samples:,} quaternions at 100 Hz; each round a child process per checkout, "
        "best of 3 in it; the rounds alternate).\n\n" + table,
    )


if __name__ == "__main__":
    main()
