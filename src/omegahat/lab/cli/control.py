"""``omegahat control [--out DIR]``: the attitude controller fed a gyro, omegahat's estimate or differenced
attitudes, in closed loop (detumble, 180° slew, the measured basin), with figures and a summary.

Checked before any work: ``--runs`` from 1 to :data:`MAX_RUNS`, ``--seed`` a non-negative integer (a
``SeedSequence`` entropy), the plant available, ``--out`` a folder (or absent). The files appear in ``--out`` only
when all are written."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from omegahat.cli import bounded_int, natural_int, positive_float
from omegahat.io.output import check_output_folder, staged_folder
from omegahat.lab.control import basin, report
from omegahat.lab.control.closed_loop import ClosedLoopRun, Plant
from omegahat.lab.control.scenarios import ARCSEC, ControlScenario, detumble, run_scenario, slew

FEEDS = ("gyro", "omegahat", "differencing")
SWEEP_DEG = (90.0, 150.0, 170.0, 179.0, 179.9, 180.0)
#: basin runs at most: every run's results, and a row of basin_runs.csv, are held in memory
MAX_RUNS = 100_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", type=Path, default=Path("control-out"), help="output folder (control-out/)")
    parser.add_argument(
        "--runs",
        type=bounded_int(1, MAX_RUNS, "every run's results are held in memory"),
        default=20,
        help="Monte-Carlo runs of the basin (20)",
    )
    parser.add_argument("--seed", type=natural_int, default=2026, help="the basin's SeedSequence entropy (2026)")
    parser.add_argument(
        "--sigma-arcsec",
        type=positive_float,
        default=10.0,
        help="star tracker noise per axis in arcseconds (10; 36 is 0.01 deg)",
    )
    parser.add_argument(
        "--natural-frequency",
        type=positive_float,
        default=0.2,
        help="the PD law's natural frequency in rad/s (0.2; damping 0.9)",
    )
    parser.add_argument(
        "--plant",
        choices=("rigid-body", "mujoco"),
        default="rigid-body",
        help="the scenarios' plant: omegahat's CF4 integrator (default) or MuJoCo (needs the 'mujoco' extra)",
    )


def _plant(name: str, scenario: ControlScenario) -> Plant | None:
    if name == "rigid-body":
        return None
    try:
        from omegahat.lab.control.mujoco_plant import MujocoPlant

        return MujocoPlant(scenario.J)
    except ModuleNotFoundError as exc:
        raise ValueError("--plant mujoco needs MuJoCo: pip install 'omegahat[mujoco]'") from exc


def run(args: argparse.Namespace) -> int:
    _plant(args.plant, detumble())  # refused now rather than after the first scenarios
    check_output_folder(args.out)
    with staged_folder(args.out) as stage:
        elapsed = _run(args, stage)
    print(f"done in {elapsed:.1f} s; figures, CSV files and summary.md in {args.out}/")
    return 0


def _run(args: argparse.Namespace, out: Path) -> float:
    start = time.perf_counter()
    table: list[dict] = []
    common = {"sigma": args.sigma_arcsec * ARCSEC, "natural_frequency": args.natural_frequency}
    for scenario in (detumble(**common), slew(**common)):
        runs: dict[str, ClosedLoopRun] = {
            name: run_scenario(scenario, name, seed=1, plant=_plant(args.plant, scenario)) for name in FEEDS
        }
        rows = report.scenario_rows(scenario, runs)
        table += rows
        figures = {
            f"{scenario.name}_error": report.plot_error_angle(scenario, runs),
            f"{scenario.name}_rates": report.plot_rates(scenario, runs["omegahat"], "omegahat"),
            f"{scenario.name}_torque": report.plot_torque(scenario, runs),
        }
        for name, fig in figures.items():
            fig.savefig(out / f"{name}.png", dpi=120)
        for row in rows:
            print(
                f"{row['scenario']:9s} {row['source']:13s} settled at {row['settle_s']:7.1f} s, pointing "
                f"{row['pointing_rad']:.2e} rad, torque used {row['impulse_Nms']:6.1f} N m s, "
                f"max |w_hat - w| {row['rate_error_tail']:.1e} rad/s (last {report.TAIL:g} s)"
            )
    report.write_csv(out / "scenarios.csv", table)

    campaign_scenario = detumble(horizon=300.0, **common)
    result = basin.basin_campaign(campaign_scenario, FEEDS, args.runs, seed=args.seed)
    sweep = basin.angle_sweep(campaign_scenario, FEEDS, SWEEP_DEG)
    basin_rows = result.summary_rows()
    report.write_csv(out / "basin.csv", basin_rows)
    per_run = [
        {"run": j, "angle0_rad": float(result.angle0[j]), "rate0": float(result.rate0[j])}
        | {f"settle_{name}": float(result.settle[j, f]) for f, name in enumerate(FEEDS)}
        | {f"rest_angle_{name}": float(result.rest_angle[j, f]) for f, name in enumerate(FEEDS)}
        for j in range(args.runs)
    ]
    report.write_csv(out / "basin_runs.csv", per_run)
    report.plot_basin(result, SWEEP_DEG, sweep).savefig(out / "basin.png", dpi=120)
    for row in basin_rows:
        print(
            f"basin {row['source']:13s} {row['converged']:.0%} of {row['runs']} settled within "
            f"{campaign_scenario.horizon:g} s; median {row['median_settle_s']:.1f} s, "
            f"worst {row['worst_settle_s']:.1f} s"
        )
    header = (
        f"# omegahat control (plant: {args.plant}; basin: {args.runs} runs, seed {args.seed})\n\n"
        "J = diag(300, 250, 200) kg m², |tau_i| <= 5 N m, star tracker 5 Hz with "
        f"{args.sigma_arcsec:g} arcsec per axis, "
        f"PD law w_n = {args.natural_frequency:g} rad/s, zeta = 0.9; "
        "settled: error angle <= 1e-3 rad and rate error <= 1e-3 rad/s."
    )
    (out / "summary.md").write_text(report.summary_markdown(table, basin_rows, SWEEP_DEG, sweep, FEEDS, header))
    return time.perf_counter() - start
