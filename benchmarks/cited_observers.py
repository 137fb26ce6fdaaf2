"""Uniformity of the convergence rate in the initial error, continuous observers side by side (issue 16, part 3).

Run: ``python benchmarks/cited_observers.py [--runs 8] [--scales 1,3,10,30,100] [--horizon 10]``. For each scale
s, runs 0 … runs−1 of ``examples/campaign.toml`` (J = diag(3, 2, 1), two rows of R, ω_M = 3, a random bounded
torque) with ``omega_hat_max = s`` (|ω̂₀| uniform in [0, s]: the same draws, the initial estimate scaled, so that
every decade of initial error is represented), every observer from the same draws
(:mod:`omegahat.lab.evaluation.uniformity`), for the gain sets ``theorem`` and ``slope``. In the report, run
``k·runs + j`` is run j at the k-th scale. Observers: Sarras' (corrected output map) and the same with the
paper's printed map.
Salcudean's, Akella–Thakur–Mazenc's and Berkane–Abdessameud–Tayebi's observers are not implemented (their
equations could not be sourced: ``docs/related_observers.md``). Writes its section of ``benchmarks/RESULTS.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import time
from pathlib import Path

from omegahat.lab.campaigns import load_campaign, replace
from omegahat.lab.evaluation import peer_uniformity as PU
from omegahat.lab.evaluation import uniformity as u
from results_md import machine_line, write_section

CONFIG = Path(__file__).resolve().parent.parent / "examples" / "campaign.toml"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=8, help="runs per scale")
    ap.add_argument("--scales", default="1,3,10,30,100", help="omega_hat_max of each sub-campaign (rad/s)")
    ap.add_argument("--horizon", type=float, default=10.0)
    ap.add_argument("--gains", default="theorem,slope")
    ap.add_argument(
        "--observers", default="sarras,sarras-printed", help="comma-separated (uniformity.OBSERVERS and the sampled "
        "gyro-free peers min-energy, predictive, sunline-sekf: then the section of the peers is written)",
    )  # fmt: skip
    ap.add_argument("--tol", type=float, default=1e-3, help="the tolerance eps (rad/s)")
    args = ap.parse_args()
    observers = args.observers.split(",")
    peers = any(o in PU.SAMPLED for o in observers)
    campaign = load_campaign(CONFIG)
    parts = []
    for gains in args.gains.split(","):
        start = time.perf_counter()
        rows, same = [], True
        for k, scale in enumerate(float(x) for x in args.scales.split(",")):
            part = u.run_uniformity(
                replace(campaign, omega_hat_max=scale), observers, gains=gains, runs=args.runs, horizon=args.horizon,
                tol=args.tol,
                progress=lambda j, n, g=gains, s=scale: print(f"\r{g}, scale {s:g}: {j}/{n}", end="", flush=True),
            )  # fmt: skip
            same = same and u.same_draws(part)
            rows += [dataclasses.replace(r, index=k * args.runs + r.index) for r in part]
        elapsed = time.perf_counter() - start
        print()
        text = u.markdown(rows)
        print(text)
        parts.append(f"Gain set `{gains}` ({elapsed:.0f} s; same draws for every observer: {same}):\n\n{text}")
    command = (
        f"python benchmarks/cited_observers.py --runs {args.runs} --scales {args.scales} --horizon {args.horizon:g} "
        f"--gains {args.gains}" + (f" --observers {args.observers} --tol {args.tol:g}" if peers else "")
    )
    body = (
        f"Command: `{command}`. Runs 0–{args.runs - 1} of `examples/campaign.toml` with "
        f"|ω̂₀| uniform in [0, s] for each scale s (run k·{args.runs} + j is run j at the k-th scale), horizon "
        f"{args.horizon:g} s, output step 0.05 s, ε = {args.tol:g} rad/s; t_ε is the time after which |ω̂ − ω| "
        "stays ≤ ε, λ_run = ln(e(0)/ε)/t_ε. "
        "`sarras-printed` is the paper's printed output map (the erratum). Salcudean, Akella–Thakur–Mazenc and "
        "Berkane–Abdessameud–Tayebi: not implemented (equations not sourced).\n\n"
        + "\n".join(parts)
        + f"\n{machine_line()}"
    )
    if peers:
        body += (
            "\n\nThe gyro-free peers (`omegahat.lab.evaluation.peer_uniformity`): sampled at "
            f"{PU.PEER_RATE_HZ:g} Hz, exact directions, from the same draws; each knob tuned by the comparison's rule "
            f"on {PU.TUNING_RUNS} draws of the campaign re-seeded with |ω̂₀| ≤ ω_M (the value is in the name); the "
            "sun-line SEKF sees the first reference and is scored on the error across it."
        )
    title = "## Gyro-free peers: uniformity of the rate in the initial error" if peers else None
    write_section(title or "## Cited observers: uniformity of the rate in the initial error", body)


if __name__ == "__main__":
    main()
