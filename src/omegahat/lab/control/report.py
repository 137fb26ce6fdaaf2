r"""What ``omegahat control`` writes: the scenario runs compared across rate sources, the basin, the sweep near
180°, as figures (matplotlib, no pyplot state), CSV files and a Markdown summary.

Scores, per scenario and rate source (:mod:`omegahat.lab.control.closed_loop`): the settling time (M1), the pointing
error (M2, RMS error angle over the last ``TAIL`` seconds), the torque used (M3), and the rate source's error
``max |ω̂ − ω|`` over the same tail (zero for the gyro).
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from omegahat.lab.control.basin import BasinResult
from omegahat.lab.control.closed_loop import ClosedLoopRun, pointing_error, settling_time, torque_used
from omegahat.lab.control.scenarios import ControlScenario
from omegahat.lab.plots import ESTIMATE_COLOR, TRUE_COLOR

__all__ = [
    "TAIL",
    "plot_basin",
    "plot_error_angle",
    "plot_rates",
    "plot_torque",
    "scenario_rows",
    "summary_markdown",
    "write_csv",
]

TAIL = 20.0  #: the pointing error's window at the end of a run (s)
_AXES = ("x", "y", "z")


def scenario_rows(scenario: ControlScenario, runs: dict[str, ClosedLoopRun]) -> list[dict[str, float | str]]:
    """One row per rate source of one scenario (module docstring)."""
    rows: list[dict[str, float | str]] = []
    for name, run in runs.items():
        tail = run.t >= run.t[-1] - TAIL
        err = np.linalg.norm(run.omega_hat[tail] - run.omega[tail], axis=1)
        rows.append(
            {
                "scenario": scenario.name,
                "source": name,
                "settle_s": settling_time(run, scenario.angle_tol, scenario.rate_tol),
                "pointing_rad": pointing_error(run, TAIL),
                "peak_error_deg": float(np.degrees(np.max(run.angle))),
                "impulse_Nms": torque_used(run),
                "rate_error_tail": float(np.max(err)) if err.size else math.nan,
                "diverged": "yes" if run.diverged else "no",
            }
        )
    return rows


def write_csv(path: Path, rows: list[dict]) -> None:
    """Rows of equal keys to ``path`` (numbers with 10 significant digits)."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(list(rows[0]))
        for row in rows:
            writer.writerow([f"{v:.10g}" if isinstance(v, float) else v for v in row.values()])


def plot_error_angle(scenario: ControlScenario, runs: dict[str, ClosedLoopRun]) -> Figure:
    """The error angle θ_e (deg, log scale) against time, one line per rate source."""
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.subplots()
    for name, run in runs.items():
        ax.semilogy(run.t, np.degrees(np.maximum(run.angle, 1e-9)), label=name)
    ax.axhline(np.degrees(scenario.angle_tol), color="k", linestyle=":", linewidth=0.8, label="settling tolerance")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("attitude error (deg)")
    ax.set_title(f"{scenario.name}: attitude error")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return fig


def plot_rates(scenario: ControlScenario, run: ClosedLoopRun, source: str) -> Figure:
    """The true rate (blue) and the rate source's output (red, dashed), per axis."""
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    fig.suptitle(f"{scenario.name}: angular velocity, true (blue) and {source} (red)")
    for a, ax in enumerate(axes):
        ax.plot(run.t, run.omega[:, a], color=TRUE_COLOR, label=rf"$\omega_{_AXES[a]}$")
        ax.plot(run.t, run.omega_hat[:, a], color=ESTIMATE_COLOR, linestyle="--", label=rf"$\hat\omega_{_AXES[a]}$")
        ax.set_ylabel(rf"$\omega_{_AXES[a]}$ (rad/s)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time (s)")
    return fig


def plot_torque(scenario: ControlScenario, runs: dict[str, ClosedLoopRun]) -> Figure:
    """The commanded (held) torque per axis, one line per rate source, with the saturation limits."""
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    fig.suptitle(f"{scenario.name}: torque (limit ±{scenario.tau_max:g} N m)")
    for a, ax in enumerate(axes):
        for name, run in runs.items():
            ax.step(run.t, run.tau[:, a], where="post", label=name, linewidth=0.8)
        for s in (-1.0, 1.0):
            ax.axhline(s * scenario.tau_max, color="k", linestyle=":", linewidth=0.8)
        ax.set_ylabel(rf"$\tau_{_AXES[a]}$ (N m)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time (s)")
    return fig


def plot_basin(result: BasinResult, sweep_deg: tuple[float, ...], sweep: np.ndarray) -> Figure:
    """Left: settling time against the initial error angle, one marker per run and rate source (runs that did
    not settle at the top edge); right: the settling time from rest against the initial angle up to 180°."""
    fig = Figure(figsize=(10.0, 4.0), layout="constrained")
    left, right = fig.subplots(1, 2)
    top = result.horizon
    for f, name in enumerate(result.feeds):
        s = result.settle[:, f]
        left.scatter(np.degrees(result.angle0), np.where(np.isfinite(s), s, top), s=12, label=name, alpha=0.7)
        right.plot(sweep_deg, np.where(np.isfinite(sweep[:, f]), sweep[:, f], top), marker="o", label=name)
    for ax in (left, right):
        ax.axhline(top, color="k", linestyle=":", linewidth=0.8)
        ax.set_xlabel("initial attitude error (deg)")
        ax.set_ylabel("settling time (s)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize="small")
    left.set_title(f"Monte-Carlo: {result.settle.shape[0]} runs, |ω₀| ≤ 2 rad/s")
    right.set_title("from rest, error rotation about (1,1,1)")
    return fig


def _fmt(v: float | str) -> str:
    if isinstance(v, str):
        return v
    if math.isinf(v):
        return "never"
    if math.isnan(v):
        return "–"
    return f"{v:.3g}"


def _table(rows: list[dict], columns: dict[str, str]) -> list[str]:
    lines = ["| " + " | ".join(columns.values()) + " |", "|" + " --- |" * len(columns)]
    lines += ["| " + " | ".join(_fmt(row[key]) for key in columns) + " |" for row in rows]
    return lines


def summary_markdown(
    scenario_tables: list[dict],
    basin_rows: list[dict],
    sweep_deg: tuple[float, ...],
    sweep: np.ndarray,
    feeds: tuple[str, ...],
    header: str,
) -> str:
    """The Markdown summary: the scenario table, the basin table, the sweep table."""
    lines = [header, "", "## Scenarios", ""]
    lines += _table(
        scenario_tables,
        {
            "scenario": "scenario",
            "source": "rate source",
            "settle_s": "settling time (s)",
            "pointing_rad": f"pointing error, last {TAIL:g} s (rad)",
            "peak_error_deg": "peak error (deg)",
            "impulse_Nms": "torque used (N m s)",
            "rate_error_tail": f"max ‖ω̂ − ω‖, last {TAIL:g} s (rad/s)",
            "diverged": "diverged",
        },
    )
    lines += ["", "## Basin (Monte-Carlo over initial attitudes and rates)", ""]
    lines += _table(
        basin_rows,
        {
            "source": "rate source",
            "runs": "runs",
            "converged": "fraction settled",
            "diverged": "diverged",
            "median_settle_s": "median settling (s)",
            "worst_settle_s": "worst settling (s)",
            "slow_runs": "slow runs (> 2× median)",
            "slow_median_angle0_deg": "their median initial error (deg)",
            "near_pi_runs": "at rest > 150° off",
            "near_pi_median_settle_s": "their median settling (s)",
            "median_pointing_rad": "median pointing error (rad)",
        },
    )
    lines += ["", "## From rest, initial error up to 180°", ""]
    sweep_rows = [
        {"angle": f"{deg:g}", **{name: float(sweep[i, f]) for f, name in enumerate(feeds)}}
        for i, deg in enumerate(sweep_deg)
    ]
    lines += _table(sweep_rows, {"angle": "initial error (deg)", **{name: f"{name}: settling (s)" for name in feeds}})
    return "\n".join(lines) + "\n"
