"""``omegahat compare``: omegahat beside the baselines users would pick instead, scenario by scenario.

A thin shell over :mod:`omegahat.lab.evaluation.comparison` (the methods, the tuning and scoring procedure, the
tables): it picks the scenarios and methods, runs them and writes, in ``--out``, ``results.md`` (the tables),
``results.csv`` (deterministic: two runs give the same bytes), ``cost.csv`` (timings) and ``<scenario>.png``;
then the robustness campaign (:mod:`omegahat.lab.evaluation.robustness`: ``robustness.md`` and ``robustness.csv``).
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from omegahat.lab import peer_scenarios as P
from omegahat.lab import scenarios as S
from omegahat.lab.evaluation import comparison as C
from omegahat.lab.evaluation import peer_methods as PM
from omegahat.lab.evaluation import robustness as RB

HELP = "Compare omegahat with differencing, a spline, an EKF and published gyro-free filters on standard scenarios."

#: every method (the comparison's, then the gyro-free peers' and the one-direction observer's)
METHODS = (*C.METHODS, *PM.METHODS)
#: every scenario: the attitude scenarios, then those whose sensor gives directions
SCENARIOS = [*S.names(), *P.DIRECTION_SCENARIOS]


def _scenario(name: str) -> S.Scenario | P.DirectionScenario:
    return P.DIRECTION_SCENARIOS[name] if name in P.DIRECTION_SCENARIOS else S.get(name)


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
        type=float,
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
        type=int,
        default=RB.RobustnessConfig.runs,
        metavar="N",
        help=f"runs of the robustness campaign (cold starts, 1-10 Hz; default {RB.RobustnessConfig.runs}; 0: skip)",
    )


def run(args: argparse.Namespace) -> int:
    names = args.scenario or SCENARIOS
    methods = [m for m in METHODS if args.method is None or m.name in args.method]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, skipped = [], []
    for name in names:
        sc = _scenario(name)
        reason = C.unavailable(sc)
        if reason is not None:
            skipped.append(reason)
            continue
        sc_rows, t, curves = C.compare_scenario(sc, methods, args.duration)
        rows += sc_rows
        C.plot_errors(sc, t, curves).savefig(out / f"{name}.png", dpi=110)
    table = C.markdown(rows, methods)
    if skipped:
        table += "\n\nNot run: " + "; ".join(skipped)
    (out / "results.md").write_text(
        "# omegahat compare\n\n"
        + table
        + "\n\n## Cost (wall time: varies from run to run)\n\n"
        + C.cost_markdown(rows)
        + "\n"
    )
    with open(out / "results.csv", "w", newline="") as f:
        C.write_results_csv(f, rows)
    with open(out / "cost.csv", "w", newline="") as f:
        C.write_cost_csv(f, rows)
    print(table)
    print(f"\nwrote {out / 'results.md'}, results.csv, cost.csv and one figure per scenario")
    if args.robustness_runs < 0:
        raise SystemExit(f"--robustness-runs must be 0 or more; got {args.robustness_runs}")
    if args.robustness_runs:
        texts = []
        with open(out / "robustness.csv", "w", newline="") as f:
            for i, base in enumerate((RB.RobustnessConfig(), RB.CAMPAIGN_LIKE)):
                config = dataclasses.replace(base, runs=args.robustness_runs)
                results = RB.run_campaign(config)
                texts.append(RB.markdown(config, results))
                RB.write_csv(f, results, campaign=config.name, header=i == 0)
        text = "\n\n".join(texts)
        (out / "robustness.md").write_text("# omegahat compare: robustness campaigns\n\n" + text + "\n")
        print("\n" + text + f"\n\nwrote {out / 'robustness.md'} and robustness.csv")
    return 0
