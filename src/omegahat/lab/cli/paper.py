"""``omegahat paper``: the paper's simulation (Section 4, typos fixed) with its four figures.

Checked before any work: ``--horizon`` and ``--dt`` positive and finite, at most :data:`MAX_SAMPLES` output samples
(the trajectory, its CSV and the figures hold every one), a horizon the integrator can reach within its step budget,
and an ``--out`` that is (or can be made) a folder. The files appear in ``--out`` only when all are written.
"""

from __future__ import annotations

import argparse
import csv
import inspect
import time
from pathlib import Path

import numpy as np

from omegahat.cli import positive_float
from omegahat.io.output import check_output_folder, staged_folder
from omegahat.kernels import compiling
from omegahat.lab.evaluation.metrics import convergence_time
from omegahat.lab.plots import plot_direction, plot_filter_errors, plot_omega
from omegahat.observer.gains import check_gains
from omegahat.simulation import PAPER_OMEGA_MAX, CoupledTrajectory, paper_problem, simulate

FIGURES = ("fig1_omega", "fig2_r1", "fig3_r2", "fig4_filter_errors")
#: output samples at most (horizon / dt + 1): each is in the trajectory, its CSV and the figures
MAX_SAMPLES = 2_000_000
#: the integrator's largest step and step budget (:func:`omegahat.simulation.simulate`'s, which this command
#: uses): a horizon beyond MAX_STEPS * H_MAX cannot be reached
H_MAX, MAX_STEPS = (inspect.signature(simulate).parameters[k].default for k in ("h_max", "max_steps"))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("paper-figures"), help="output folder (paper-figures/)")
    parser.add_argument("--horizon", type=positive_float, default=10.0, help="simulated time in s (10)")
    parser.add_argument("--dt", type=positive_float, default=1e-3, help="output sample period in s (0.001)")


def write_trajectory_csv(path: Path, traj: CoupledTrajectory) -> None:
    """Columns t, ω, ω̂, then r_i and r̂_i for each direction."""
    n = traj.r.shape[1]
    header = ["t", "wx", "wy", "wz", "wx_hat", "wy_hat", "wz_hat"]
    for i in range(1, n + 1):
        header += [f"r{i}{a}" for a in "xyz"]
    for i in range(1, n + 1):
        header += [f"r{i}{a}_hat" for a in "xyz"]
    rows = np.column_stack(
        [
            traj.t,
            traj.omega,
            traj.omega_hat,
            traj.r.reshape(len(traj.t), -1),
            traj.r_hat.reshape(len(traj.t), -1),
        ]
    )
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(header)
        writer.writerows([f"{v:.17g}" for v in row] for row in rows)  # row by row: no list of every row's text


def check_args(args: argparse.Namespace) -> None:
    """Refuse, before any work, a request beyond the limits of the module docstring."""
    samples = args.horizon / args.dt + 1
    if samples > MAX_SAMPLES:
        raise ValueError(
            f"--horizon {args.horizon:g} with --dt {args.dt:g} is {samples:.3g} output samples; omegahat paper "
            f"writes at most {MAX_SAMPLES:,} (each is in the trajectory, its CSV and the figures): raise --dt"
        )
    if args.horizon > H_MAX * MAX_STEPS:
        raise ValueError(
            f"--horizon {args.horizon:g} s is beyond what the integrator reaches in {MAX_STEPS:,} steps of at most "
            f"{H_MAX:g} s: at most {H_MAX * MAX_STEPS:g} s"
        )
    check_output_folder(args.out)


def _write(out: Path, traj: CoupledTrajectory) -> None:
    figures = {
        "fig1_omega": plot_omega(traj.t, traj.omega, traj.omega_hat),
        "fig2_r1": plot_direction(traj.t, traj.r[:, 0], traj.r_hat[:, 0], 0),
        "fig3_r2": plot_direction(traj.t, traj.r[:, 1], traj.r_hat[:, 1], 1),
        "fig4_filter_errors": plot_filter_errors(traj.t, traj.filter_error, traj.error),
    }
    for name, fig in figures.items():
        fig.savefig(out / f"{name}.png", dpi=150)
        fig.savefig(out / f"{name}.pdf")
    write_trajectory_csv(out / "trajectory.csv", traj)


def run(args: argparse.Namespace) -> int:
    compiled = compiling.seconds()
    check_args(args)
    problem = paper_problem()
    check_gains(problem.gains, problem.J, PAPER_OMEGA_MAX)  # warns if the theorem's conditions fail
    start, before = time.perf_counter(), compiling.seconds()
    with compiling.announced():
        try:
            traj = simulate(problem, horizon=args.horizon, dt_out=args.dt)
        except RuntimeError as exc:  # the step budget ran out before the horizon (tiny steps all along)
            raise ValueError(f"--horizon {args.horizon:g}: {exc}") from None
    elapsed = time.perf_counter() - start - (compiling.seconds() - before)  # compiling is not simulating
    out: Path = args.out
    with staged_folder(out) as stage:
        _write(stage, traj)
    speed = np.linalg.norm(traj.omega, axis=1)
    settle = convergence_time(traj.t, traj.error, 1e-3)  # (S1): stays at or below 1e-3 from then on
    print(
        f"paper scenario: J = diag(3, 2, 1), omega0 = (2, -1, 0.6) rad/s, k = {problem.gains.k[0]:g}, "
        f"l_i(w_hat) = {problem.gains.l_offset[0]:g} + {problem.gains.l_slope[0]:g} |w_hat|, "
        f"horizon {args.horizon:g} s"
    )
    print(f"simulated in {elapsed:.3f} s ({traj.steps} steps, {traj.rejected} rejected)")
    print(
        f"final |w_hat - w|                 = {traj.error[-1]:.3e} rad/s at t = {traj.t[-1]:g} s "
        "(integrated in error coordinates; an implementation holding w_hat itself floors near 1e-16 |w|)"
    )
    print(f"|w_hat - w| stays below 1e-3 after t = {settle:.3f} s")
    print(
        f"max |w| = {speed.max():.4f} rad/s against omega_M = {PAPER_OMEGA_MAX:g} rad/s "
        f"({'assumption A.2 holds' if speed.max() <= PAPER_OMEGA_MAX else 'A.2 VIOLATED'})"
    )
    print(f"wrote {', '.join(FIGURES)} (.png, .pdf) and trajectory.csv to {out}/{compiling.wait_note(compiled)}")
    return 0
