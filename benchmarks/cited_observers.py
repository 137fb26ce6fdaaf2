"""Uniformity of the convergence rate in the initial error, continuous observers side by side (issue 16, part 3).

Run: ``python benchmarks/cited_observers.py [--runs 24] [--horizon 10]``. Runs 0 … runs−1 of
``examples/campaign.toml`` (J = diag(3, 2, 1), two rows of R, ω_M = 3, |ω̂₀| uniform in [0, 100] rad/s, a random
bounded torque), every observer from the same draws (:mod:`omegahat.evaluation.uniformity`), for the gain sets
``theorem`` and ``slope``. Observers: Sarras' (corrected output map) and the same with the paper's printed map.
Salcudean's, Akella–Thakur–Mazenc's and Berkane–Abdessameud–Tayebi's observers are not implemented (their
equations could not be sourced: ``docs/related_observers.md``). Writes its section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from omegahat.campaigns import load_campaign
from omegahat.evaluation import uniformity as u
from results_md import machine_line, write_section

CONFIG = Path(__file__).resolve().parent.parent / "examples" / "campaign.toml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=24)
    ap.add_argument("--horizon", type=float, default=10.0)
    ap.add_argument("--gains", default="theorem,slope")
    args = ap.parse_args()
    campaign = load_campaign(CONFIG)
    parts = []
    for gains in args.gains.split(","):
        start = time.perf_counter()
        rows = u.run_uniformity(
            campaign, ["sarras", "sarras-printed"], gains=gains, runs=args.runs, horizon=args.horizon,
            progress=lambda j, n, g=gains: print(f"\r{g}: {j}/{n}", end="", flush=True),
        )  # fmt: skip
        elapsed = time.perf_counter() - start
        print()
        text = u.markdown(rows)
        print(text)
        parts.append(
            f"Gain set `{gains}` ({elapsed:.0f} s; same draws for every observer: {u.same_draws(rows)}):\n\n{text}"
        )
    body = (
        f"Command: `python benchmarks/cited_observers.py --runs {args.runs} --horizon {args.horizon:g} --gains "
        f"{args.gains}`. Runs 0–{args.runs - 1} of `examples/campaign.toml`, horizon {args.horizon:g} s, output step "
        "0.05 s, ε = 1e-3 rad/s; t_ε is the time after which |ω̂ − ω| stays ≤ ε, λ_run = ln(e(0)/ε)/t_ε. "
        "`sarras-printed` is the paper's printed output map (the erratum). Salcudean, Akella–Thakur–Mazenc and "
        "Berkane–Abdessameud–Tayebi: not implemented (equations not sourced).\n\n"
        + "\n".join(parts)
        + f"\n{machine_line()}"
    )
    write_section("## Cited observers: uniformity of the rate in the initial error", body)


if __name__ == "__main__":
    main()
