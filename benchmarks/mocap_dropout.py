"""``--preset mocap`` (causal and ``--smooth``) and the default through a marker dropout, against a varying turn.

Run: ``python benchmarks/mocap_dropout.py [--before SRC]`` (about a minute; ``--before``: also a checkout's ``src``
directory, e.g. one made by ``git worktree add /tmp/before c7cbb48``, run in a child process). Writes its section of
``benchmarks/RESULTS.md``.

The body turns at ``ω(t) = (1.5 sin 2π·0.7t, cos 2π·1.1t, 0.8 sin(2π·0.4t + 1))`` rad/s; its attitude is SciPy's
``solve_ivp`` (DOP853, rtol 1e-11) of ``q̇ = ½ q ⊗ ω`` (independent of omegahat), with 0.2 mrad of white noise per
axis, sampled at 50, 100 and 200 Hz for 12 s. A dropout (rows missing) starts at 6 s. Cells: the largest ``|ω̂ − ω|``
over the half second after the dropout, and, for the log without it, over 2–6 s (rad/s); for the default (the
identification's estimator, :func:`omegahat.identification.identify`), also the same from the second fix after the
dropout on (the first gives the rate held through it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from results_md import machine_line, write_section

TITLE = "## `--preset mocap` through a marker dropout (benchmarks/mocap_dropout.py)"
RATES = (50.0, 100.0, 200.0)
GAPS = (0.05, 0.3, 1.0)  # s
START = 6.0  # s: where the dropout starts


def omega(t: float) -> np.ndarray:
    return np.array(
        [1.5 * np.sin(2 * np.pi * 0.7 * t), np.cos(2 * np.pi * 1.1 * t), 0.8 * np.sin(2 * np.pi * 0.4 * t + 1.0)]
    )


def _quaternion_rate(t: float, q: np.ndarray) -> np.ndarray:
    w = omega(t)
    x, y, z, s = q
    return 0.5 * np.array(
        [
            s * w[0] + y * w[2] - z * w[1],
            s * w[1] + z * w[0] - x * w[2],
            s * w[2] + x * w[1] - y * w[0],
            -x * w[0] - y * w[1] - z * w[2],
        ]
    )


def log(rate: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times, noisy quaternions (x, y, z, w) and the true rates at ``rate`` Hz."""
    t = np.arange(0.0, 12.0, 1.0 / rate)
    sol = solve_ivp(_quaternion_rate, (0.0, t[-1]), [0.0, 0.0, 0.0, 1.0], t_eval=t, method="DOP853", rtol=1e-11,
                    atol=1e-12)  # fmt: skip
    q = sol.y.T / np.linalg.norm(sol.y.T, axis=1)[:, None]
    noise = Rotation.from_rotvec(np.random.default_rng(1).normal(0.0, 2e-4, (t.size, 3)))
    return t, (Rotation.from_quat(q) * noise).as_quat(), np.array([omega(x) for x in t])


def measure() -> dict[str, float]:
    """Every cell (key ``"rate|gap|estimator"``, gap 0: the log without a dropout, over 2-6 s)."""
    from omegahat.identification import identify
    from omegahat.observer.presets import MocapPreset, MocapSmoother

    warnings.simplefilter("ignore")  # the skipped samples' warning
    out = {}
    for rate in RATES:
        t, q, W = log(rate)
        i0 = int(START * rate)
        for gap in (0.0, *GAPS):
            qq = q.copy()
            n = round(gap * rate)
            qq[i0 : i0 + n] = np.nan
            span = slice(int(2 * rate), i0) if gap == 0.0 else slice(i0 + n, i0 + n + int(0.5 * rate))
            default = identify(t, qq, "quaternion").estimator()
            for name, est in (("causal", MocapPreset(rate_hz=rate)), ("smooth", MocapSmoother()), ("default", default)):
                err = np.linalg.norm(est.run(t, qq).omega - W, axis=1)
                out[f"{rate:g}|{gap:g}|{name}"] = float(err[span].max())
            later = span if gap == 0.0 else slice(span.start + 1, span.stop)
            out[f"{rate:g}|{gap:g}|default2"] = float(err[later].max())
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--before", help="a checkout's src directory to measure as well (child process)")
    ap.add_argument("--json", action="store_true", help=argparse.SUPPRESS)  # the child's way of answering
    args = ap.parse_args(argv)
    if args.json:
        print(json.dumps(measure()))
        return 0
    start = time.perf_counter()
    now = measure()
    before = None
    if args.before:
        env_path = str(Path(args.before).resolve())
        child = subprocess.run(
            [sys.executable, __file__, "--json"], capture_output=True, text=True, check=True,
            env={**os.environ, "PYTHONPATH": env_path},
        )  # fmt: skip
        before = json.loads(child.stdout.strip().splitlines()[-1])
        commit = subprocess.run(
            ["git", "-C", args.before, "rev-parse", "--short", "HEAD"], capture_output=True, text=True
        )
        args.before = commit.stdout.strip() or args.before  # the commit measured, where SRC is a git checkout's
    kinds = ("causal", "smooth", "default", "default2")
    head = "causal | --smooth | default | default, 2nd fix on |"
    rows = ["| rate | dropout | " + head + (" " + head.replace(" |", ", before |") if before else "")]
    rows.append("| ---: | --- |" + " ---: |" * (8 if before else 4))
    for rate in RATES:
        for gap in (0.0, *GAPS):
            cells = [now[f"{rate:g}|{gap:g}|{k}"] for k in kinds]
            if before:
                cells += [before.get(f"{rate:g}|{gap:g}|{k}", np.nan) for k in kinds]
            what = "none (2-6 s)" if gap == 0.0 else f"{gap:g} s"
            rows.append(f"| {rate:g} Hz | {what} | " + " | ".join(f"{c:.3g}" for c in cells) + " |")
    command = "python benchmarks/mocap_dropout.py" + (" --before SRC" if before else "")
    body = (
        f"{machine_line()} Command: `{command}` ({time.perf_counter() - start:.0f} s). The module docstring's turn, "
        "0.2 mrad of attitude noise; cells: the largest error (rad/s) over the half second after the dropout (the "
        "log without one: over 2-6 s); causal and --smooth: `--preset mocap`'s; default: the identified estimator's, "
        "and the same from the second fix after the dropout on"
        + (f"; before: commit {args.before}" if before else "")
        + ".\n\n"
        + "\n".join(rows)
    )
    print(body)
    write_section(TITLE, body)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
