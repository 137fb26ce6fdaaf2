"""``omegahat compare``: omegahat beside the baselines users would pick instead, scenario by scenario.

A thin shell over :mod:`omegahat.lab.evaluation.comparison` (the methods, the tuning and scoring procedure, the
tables): it picks the scenarios and methods, runs them and writes, in ``--out``, ``results.md`` (the tables),
``results.csv`` (deterministic: two runs give the same bytes), ``cost.csv`` (timings) and ``<scenario>.png``;
then the robustness campaign (:mod:`omegahat.lab.evaluation.robustness`: ``robustness.md`` and ``robustness.csv``).

Checked before any work: a scenario named with ``--scenario`` must be runnable here (a real-data scenario needs its
recordings: without them it is an error; when every scenario runs by default, it is listed as not run);
``--duration`` positive, finite and at most :data:`MAX_SAMPLES` samples in every simulated scenario;
``--robustness-runs`` from 0 to :data:`MAX_ROBUSTNESS_RUNS`; ``--out`` a folder (or absent). The files appear in
``--out`` only when all are written.
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from omegahat.cli import bounded_int, positive_float
from omegahat.io.output import check_output_folder, staged_folder
from omegahat.lab import peer_scenarios as P
from omegahat.lab import scenarios as S
from omegahat.lab.evaluation import comparison as C
from omegahat.lab.evaluation import peer_methods as PM
from omegahat.lab.evaluation import robustness as RB

#: every method (the comparison's, then the gyro-free peers' and the one-direction observer's)
METHODS = (*C.METHODS, *PM.METHODS)
#: every scenario: the attitude scenarios, then those whose sensor gives directions
SCENARIOS = [*S.names(), *P.DIRECTION_SCENARIOS]


def _scenario(name: str) -> S.Scenario | P.DirectionScenario:
    return P.DIRECTION_SCENARIOS[name] if name in P.DIRECTION_SCENARIOS else S.get(name)


#: samples of one simulated scenario at most (--duration times its rate): the truth, the fixes and every method's
#: estimates are held for the tuning run and the scored run, about 5 kB per sample at the peak (measured: 265 MB for
#: 10,001 samples, 695 MB for 100,001, ``omegahat compare --scenario paper --duration 100`` and ``1000``)
MAX_SAMPLES = 500_000
#: runs of each robustness campaign at most (each run's convergence time and error are held per method)
MAX_ROBUSTNESS_RUNS = 1_000_000


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scenario",
        action="append",
        choices=SCENARIOS,
        metavar="NAME",
        help=f"scenario to run (repeatable; default: all). One of: {', '.join(SCENARIOS)}",
    )
    parser.add_argument("--out", type=Path, default=Path("compare-out"), help="output folder (compare-out/)")
    parser.add_argument(
        "--duration",
        type=positive_float,
        default=None,
        help="override every simulated scenario's horizon, s (quick looks and tests)",
    )
    parser.add_argument(
        "--method",
        action="append",
        choices=[m.name for m in METHODS],
        metavar="NAME",
        help="method to run (repeatable; default: all)",
    )
    parser.add_argument(
        "--robustness-runs",
        type=bounded_int(0, MAX_ROBUSTNESS_RUNS, "each run's results are held in memory"),
        default=RB.RobustnessConfig.runs,
        metavar="N",
        help=f"runs of the robustness campaign (cold starts, 1-10 Hz; default {RB.RobustnessConfig.runs}; 0: skip)",
    )


def check_args(args: argparse.Namespace) -> tuple[list[str], list[str]]:
    """``(scenarios to run, reasons for those not run)``, after refusing, before any work, what the module
    docstring says is refused."""
    names = args.scenario or SCENARIOS
    runnable, skipped = [], []
    for name in names:
        reason = C.unavailable(_scenario(name))
        if reason is None:
            runnable.append(name)
        elif args.scenario:
            raise ValueError(f"--scenario {reason}; give the recordings' folder with OMEGAHAT_BROAD_DIR")
        else:
            skipped.append(reason)
    if args.duration is not None:
        for name in runnable:
            sc = _scenario(name)
            samples = args.duration * sc.rate_hz + 1
            if not sc.real and samples > MAX_SAMPLES:
                raise ValueError(
                    f"--duration {args.duration:g} s is {samples:.3g} samples of scenario {name} ({sc.rate_hz:g} Hz); "
                    f"omegahat compare simulates at most {MAX_SAMPLES:,}: at most "
                    f"{(MAX_SAMPLES - 1) / sc.rate_hz:g} s"
                )
    check_output_folder(args.out)
    return runnable, skipped


def run(args: argparse.Namespace) -> int:
    names, skipped = check_args(args)
    methods = [m for m in METHODS if args.method is None or m.name in args.method]
    out = Path(args.out)
    with staged_folder(out) as stage:
        _run(args, names, skipped, methods, stage)
    robust = " robustness.md, robustness.csv," if args.robustness_runs else ""
    print(f"\nwrote results.md, results.csv, cost.csv,{robust} one figure per scenario to {out}/")
    return 0


def _run(args: argparse.Namespace, names: list[str], skipped: list[str], methods, stage: Path) -> None:
    rows = []
    for name in names:
        sc = _scenario(name)
        sc_rows, t, curves = C.compare_scenario(sc, methods, args.duration)
        rows += sc_rows
        C.plot_errors(sc, t, curves).savefig(stage / f"{name}.png", dpi=110)
    table = C.markdown(rows, methods)
    if skipped:
        table += "\n\nNot run: " + "; ".join(skipped)
    (stage / "results.md").write_text(
        "# omegahat compare\n\n"
        + table
        + "\n\n## Cost (wall time: varies from run to run)\n\n"
        + C.cost_markdown(rows)
        + "\n"
    )
    with open(stage / "results.csv", "w", newline="") as f:
        C.write_results_csv(f, rows)
    with open(stage / "cost.csv", "w", newline="") as f:
        C.write_cost_csv(f, rows)
    print(table)
    if args.robustness_runs:
        texts = []
        with open(stage / "robustness.csv", "w", newline="") as f:
            for i, base in enumerate((RB.RobustnessConfig(), RB.CAMPAIGN_LIKE)):
                config = dataclasses.replace(base, runs=args.robustness_runs)
                results = RB.run_campaign(config)
                texts.append(RB.markdown(config, results))
                RB.write_csv(f, results, campaign=config.name, header=i == 0)
        text = "\n\n".join(texts)
        (stage / "robustness.md").write_text("# omegahat compare: robustness campaigns\n\n" + text + "\n")
        print("\n" + text)
