"""Right by default? ``omegahat estimate`` with its automatic gains against the best ``--bandwidth`` in hindsight.

Three logs with a closed-form rate (``tests/logmaker.py``): the issue's 100 Hz quaternion log at constant rate
(0.1, −0.2, 0.3) rad/s with 1 mrad noise (60 s); a 10 Hz star-tracker-like log of a slewing spacecraft with J and
the torque known (10 arcsec, 600 s); a 285.7 Hz motion-capture-like log of a hand turning at up to ~2 rad/s with no
model (1 mrad, 17.5 s). For each: RMS of |ω̂ − ω| over every row with an estimate, for the default run and for
``--bandwidth`` on a grid of 31 values from 1e-8 × to 0.45 × the sample rate, and the same over the second half of
the log only (steady state). Writes its section of ``benchmarks/RESULTS.md``.

    python benchmarks/default_gains.py
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from logmaker import Angle, attitude, constant_rate, noisy, read_output, torque, write_csv
from omegahat.cli import main

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_md import machine_line, write_section

SECTION = "## Automatic gains against the best bandwidth in hindsight (benchmarks/default_gains.py)"


def cases(tmp: Path):
    t = np.arange(6000) / 100.0
    w = np.tile([0.1, -0.2, 0.3], (t.size, 1))
    yield (
        "100 Hz, 1 mrad, constant rate (the issue's log)",
        write_csv(tmp / "a.csv", t, constant_rate(t, w[0], 1e-3)),
        w,
        100.0,
        [],
    )
    J = np.diag([300.0, 250.0, 200.0])
    yaw, pitch, roll = Angle(0.002, [(0.3, 1 / 200, 0.0)]), Angle(0.0, [(0.1, 1 / 150, 1.0)]), Angle(0.0)
    t = np.arange(6000) / 10.0
    rot, w = attitude(t, yaw, pitch, roll)
    src = write_csv(tmp / "b.csv", t, noisy(rot, 5e-5), torque(t, J, yaw, pitch, roll))
    yield "10 Hz star tracker, 10 arcsec, slews, J and torque given", src, w, 10.0, ["--inertia", "300", "250", "200"]
    yaw = Angle(0.0, [(0.8, 0.31, 0.0), (0.3, 0.73, 1.0)])
    pitch = Angle(0.0, [(0.4, 0.47, 2.0)])
    roll = Angle(0.0, [(0.6, 0.23, 0.5), (0.2, 1.37, 0.0)])
    t = np.arange(5000) / 285.7
    rot, w = attitude(t, yaw, pitch, roll)
    yield "285.7 Hz motion capture, 1 mrad, no model", write_csv(tmp / "c.csv", t, noisy(rot, 1e-3)), w, 285.7, []


def errors(src, dst, truth, *extra) -> tuple[float, float, str]:
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = main(["estimate", str(src), "-o", str(dst), "--no-progress", *extra])
    assert code == 0
    _, w, _ = read_output(dst)
    e = np.linalg.norm(w - truth, axis=1)
    ok = np.isfinite(e)
    half = ok & (np.arange(e.size) >= e.size // 2)
    chosen = next((line for line in out.getvalue().splitlines() if line.startswith("gains:")), "")
    return float(np.sqrt(np.mean(e[ok] ** 2))), float(np.sqrt(np.mean(e[half] ** 2))), chosen


def main_() -> None:
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name, src, truth, rate, extra in cases(tmp):
            dst = tmp / "o.csv"
            d_all, d_half, chosen = errors(src, dst, truth, *extra)
            grid = np.geomspace(1e-8 * rate, 0.45 * rate, 31)
            res = np.array([errors(src, dst, truth, "--bandwidth", f"{b:.6g}", *extra)[:2] for b in grid])
            i, j = int(np.argmin(res[:, 0])), int(np.argmin(res[:, 1]))
            bw = chosen.split("bandwidth ")[1].split(" Hz")[0] if "bandwidth " in chosen else "?"
            row = (
                f"| {name} | {bw} Hz | {d_all:.3g} | {res[i, 0]:.3g} at {grid[i]:.3g} Hz | "
                f"**{d_all / res[i, 0]:.2f}** | "
                f"{d_half:.3g} | {res[j, 1]:.3g} at {grid[j]:.3g} Hz | {d_half / res[j, 1]:.2f} |"
            )
            print(row, flush=True)
            rows.append(row)
    body = (
        f"{SECTION}\n\n"
        f"{machine_line()} "
        "Command: `python benchmarks/default_gains.py`. RMS of |ω̂ − ω| (rad/s) over every row with an estimate "
        '("whole") and over the second half ("steady"); hindsight: the best of 31 `--bandwidth` runs of the same '
        "command (same start-up: a least-squares fit over the first window).\n\n"
        "| log | default bandwidth | default, whole | best in hindsight, whole | ratio | default, steady | "
        "best in hindsight, steady | ratio |\n| --- | --- | --- | --- | --- | --- | --- | --- |\n"
        + "\n".join(rows)
        + "\n\nBefore issue 12 the default (`--bandwidth 450` rad/s, warm start) gave 0.183 rad/s on the first log.\n"
    )
    write_section(SECTION, body[len(SECTION) :])


if __name__ == "__main__":
    main_()
