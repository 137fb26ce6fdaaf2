"""Real PX4 flight logs: the default ``omegahat estimate`` of a ``.ulg`` file against the autopilot's own gyroscope.

Run: ``python benchmarks/px4_logs.py PATH...`` with ``.ulg`` files or folders holding them (for instance a local
copy of the public `PX4/pyulog <https://github.com/PX4/pyulog>`_ repository's ``test/`` folder, whose sample logs
are real flights and simulations). Writes its section of ``benchmarks/RESULTS.md``; nothing is written without
logs (they are not part of this repository).

What it checks is the **reader's conventions**, not omegahat's accuracy against an independent reference:
``vehicle_attitude`` is PX4's estimate, made with the same gyroscope. The gyroscope (``vehicle_angular_velocity``,
else ``sensor_combined``'s ``gyro_rad``), in the body's FRD axes, is interpolated at the attitude's times; each
rate is compared at its best constant time shift within ±0.1 s (both come from one clock, but differencing lags by
half a step), as an RMS over the log after its first second. Beside omegahat's default: backward differencing
of the same attitudes (:class:`omegahat.DifferencingEstimator`), and the default's rate turned into the earth's
axes, which is what a reader that took PX4's quaternion the other way round would give. A log whose body barely
turns cannot tell the two frames apart; the table gives the gyroscope's own RMS so that this can be seen.
"""

from __future__ import annotations

import contextlib
import io
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat import DifferencingEstimator
from omegahat.cli import main
from omegahat.io import read_log
from results_md import machine_line, write_section

SECTION = "## Real PX4 flight logs against the autopilot's gyroscope (benchmarks/px4_logs.py)"
SHIFTS_S = np.linspace(-0.1, 0.1, 201)


def gyroscope(path: Path) -> tuple[np.ndarray, np.ndarray, str] | None:
    """``(times s, rates (M, 3) rad/s FRD, topic)`` of the log's gyroscope, or None."""
    from pyulog import ULog

    log = ULog(str(path), message_name_filter_list=["vehicle_angular_velocity", "sensor_combined"])
    data = {d.name: d.data for d in log.data_list if d.multi_id == 0}
    for topic, fields in (("vehicle_angular_velocity", "xyz"), ("sensor_combined", "gyro_rad")):
        if topic in data and f"{fields}[0]" in data[topic]:
            rates = np.column_stack([data[topic][f"{fields}[{k}]"] for k in range(3)])
            return data[topic]["timestamp"] * 1e-6, rates.astype(float), topic
    return None


def estimate(path: Path, folder: Path) -> np.ndarray:
    """``(T, 4)`` of ``t, wx, wy, wz`` from the default ``omegahat estimate`` (its messages swallowed)."""
    out = folder / "omega.csv"
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        if main(["estimate", str(path), "-o", str(out), "--no-progress"]) != 0:
            raise RuntimeError(f"omegahat estimate {path} failed")
    return np.loadtxt(out, delimiter=",", skiprows=1, usecols=(0, 1, 2, 3), ndmin=2)


def best_rms(t: np.ndarray, w: np.ndarray, t_g: np.ndarray, g: np.ndarray) -> float:
    """The RMS of ``|w − g|`` at the best shift of ``w``'s times (rows after the first second, finite)."""
    keep = (t > t[0] + 1.0) & np.all(np.isfinite(w), axis=1)
    best = np.inf
    for s in SHIFTS_S:
        gi = np.column_stack([np.interp(t[keep] - s, t_g, g[:, k]) for k in range(3)])
        best = min(best, float(np.sqrt(np.mean(np.sum((w[keep] - gi) ** 2, axis=1)))))
    return best


def row(path: Path) -> str | None:
    found = gyroscope(path)
    if found is None:
        print(f"{path.name}: no gyroscope topic, skipped")
        return None
    t_g, g, topic = found
    with tempfile.TemporaryDirectory() as folder:
        default = estimate(path, Path(folder))
    log = read_log(path)
    differencing = DifferencingEstimator().run(log.t, log.data).omega
    R = Rotation.from_quat(log.data)  # body FRD -> earth NED, per attitude sample (the output's rows)
    t, w = default[:, 0], default[:, 1:]
    earth = R.apply(np.nan_to_num(w)) if len(log.data) == len(w) else np.full_like(w, np.nan)
    moving = float(np.sqrt(np.mean(np.sum(np.column_stack([np.interp(t, t_g, g[:, k]) for k in range(3)]) ** 2, 1))))
    cells = [
        best_rms(t, w, t_g, g),
        best_rms(log.absolute_times, differencing, t_g, g),
        best_rms(t, earth, t_g, g),
    ]
    rate = (len(t) - 1) / (t[-1] - t[0])
    line = (
        f"| {path.name} | {len(t)} at {rate:.0f} Hz | {topic} | {moving:.3f} | "
        + " | ".join(f"{c:.4f}" for c in cells)
        + " |"
    )
    print(line)
    return line


def main_(paths: list[str]) -> int:
    logs = sorted({p for a in paths for p in ([Path(a)] if Path(a).is_file() else Path(a).glob("*.ulg"))})
    if not logs:
        print("no .ulg files given (python benchmarks/px4_logs.py PATH...): nothing measured")
        return 0
    rows = [r for r in (row(p) for p in logs) if r]
    body = "\n".join(
        [
            "Command: `python benchmarks/px4_logs.py PYULOG/test` (a local copy of PX4/pyulog's sample logs).",
            machine_line(),
            "",
            "`vehicle_attitude` was made with this gyroscope: the table checks the reader's conventions (quaternion "
            "order, body FRD axes, microseconds), not accuracy against an independent reference. RMS in rad/s at "
            "each rate's best shift within ±0.1 s, after the first second.",
            "",
            "| log | attitudes | gyroscope | gyro RMS | default − gyro | differencing − gyro "
            "| default in earth axes − gyro |",
            "| --- | --- | --- | ---: | ---: | ---: | ---: |",
            *rows,
        ]
    )
    write_section(SECTION, body)
    return 0


if __name__ == "__main__":
    sys.exit(main_(sys.argv[1:]))
