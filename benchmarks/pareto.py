"""Convergence time against steady-state noise of the sampled estimator: sweep k, l, sample rate and noise,
draw the Pareto fronts, and print what recommend_gains picks for each sensor.

    /tmp/venv/bin/python benchmarks/pareto.py [--out pareto.png]

Body: the paper's J = diag(3, 2, 1), torque-free tumble ω₀ = (0.4, −0.3, 0.6) rad/s, attitude measured (three
rows of R); convergence time = 1 % settling of a 1 rad/s initial error; noise = RMS of |ω̂ − ω| after the burn-in
(omegahat.lab.gain_sweep docstring). Seed 0.
"""

from __future__ import annotations

import argparse
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from omegahat.lab import gain_sweep as gs
from results_md import machine_line, write_section

J = np.diag([3.0, 2.0, 1.0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="pareto.png")
    args = ap.parse_args()
    ks = np.geomspace(1.0, 300.0, 10)
    ls = [1.0, 10.0, 100.0, 1000.0]
    rates = [50.0, 200.0]
    noises = [1e-3, 1e-2]
    t0 = time.perf_counter()
    evs = gs.sweep(J, ks, ls, rates, noises, seed=0, horizon=10.0)
    elapsed = time.perf_counter() - t0
    print(f"{len(evs)} evaluations in {elapsed:.1f} s")
    report = []
    for rate in rates:
        for sigma in noises:
            group = [e for e in evs if e.rate_hz == rate and e.measurement_noise == sigma]
            front = gs.pareto_front([e.convergence_time for e in group], [e.noise_rms for e in group])
            report += [
                f"\n{rate:g} Hz, σ = {sigma:g} rad — the Pareto front:\n",
                "| gains | convergence time (s) | noise RMS (rad/s) | predicted |",
                "| --- | --- | --- | --- |",
            ]
            for e in sorted((e for e, f in zip(group, front, strict=True) if f), key=lambda e: e.convergence_time):
                report.append(
                    f"| {e.label} | {e.convergence_time:.3f} | {e.noise_rms:.4g} | {e.predicted_noise_rms:.4g} |"
                )
            report.append("")
            for goal in (0.01, 0.05):
                try:
                    r = gs.recommend_gains(J, rate, sigma, max_noise=goal)
                    report.append(
                        f"- `recommend_gains(max_noise={goal})`: bandwidth {r.bandwidth_hz:.3g} Hz, k = "
                        f"{r.gains.k[0]:.4g}, l = {r.gains.l_offset[0]:.4g}: t_c {r.convergence_time:.3g} s, "
                        f"noise {r.noise_rms:.3g}"
                    )
                except ValueError as exc:
                    report.append(f"- `recommend_gains(max_noise={goal})`: {exc}")
    ax = gs.plot_pareto(evs)
    ax.set_title("sampled estimator: k in [1, 300], l in {1, 10, 100, 1000}")
    ax.figure.tight_layout()
    ax.figure.savefig(args.out, dpi=120)
    plt.close(ax.figure)
    print("\n".join(report))
    print(f"\nfigure: {args.out}")
    write_section(
        "## Gain tuning: convergence time against noise (benchmarks/pareto.py)",
        f"{machine_line()} Command: `python benchmarks/pareto.py --out {args.out}` ({len(evs)} evaluations of "
        f"constant gains on the paper's body, {elapsed:.0f} s).\n" + "\n".join(report),
    )


if __name__ == "__main__":
    main()
