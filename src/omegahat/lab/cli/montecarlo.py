"""``omegahat montecarlo CONFIG.toml [--out DIR]``: a Monte-Carlo campaign against the global exponential claim.

Checked before any work: the configuration (:func:`omegahat.lab.campaigns.load_campaign`: every value, and a
campaign whose results would exceed :data:`omegahat.lab.campaigns.config.MAX_RESULT_BYTES` in memory), ``--runs``,
``--horizon``, ``--out`` a folder (or absent). The files appear in ``--out`` only when all are written.

The simulation engine is compiled for each campaign's sizes (directions, torque terms) on its first run, as the
wheel's warm-up compiles only the paper's (:mod:`omegahat.lab.warmup`): about 50 s on 2 cores for the example's
sizes. That wait is announced when it starts and reported with the closing line, the runs' own time without it."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from omegahat.cli import positive_float, positive_int
from omegahat.io.output import check_output_folder, staged_folder
from omegahat.kernels import compiling
from omegahat.lab import campaigns


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="campaign configuration (TOML)")
    parser.add_argument("--out", type=Path, default=Path("montecarlo-out"), help="output folder (montecarlo-out/)")
    parser.add_argument("--runs", type=positive_int, default=None, help="override [campaign] runs")
    parser.add_argument(
        "--dask",
        metavar="ADDRESS",
        default=None,
        help="run on a dask.distributed scheduler at ADDRESS (needs the 'dask' extra); 'local' starts a "
        "LocalCluster on this machine",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument(
        "--observers",
        metavar="NAMES",
        default=None,
        help="instead of the campaign, compare continuous observers on its draws (comma-separated: sarras, "
        "sarras-printed; the gyro-free peers, sampled at 1 kHz: min-energy, predictive, sunline-sekf) and write "
        "uniformity.md: convergence time and rate per bin of initial error, counterexamples "
        "(omegahat.lab.evaluation.uniformity)",
    )
    parser.add_argument("--gains", default=None, help="with --observers: the gain set (default: the first)")
    parser.add_argument(
        "--horizon", type=positive_float, default=None, help="with --observers: override the horizon (s)"
    )
    parser.add_argument(
        "--tol",
        type=positive_float,
        default=1e-3,
        help="with --observers: the tolerance eps on |w_hat - w| (rad/s; 1e-3)",
    )


def _on_its_own_line(notice: str) -> None:
    """The compilation's notice after the progress bar's line (:func:`_notice`)."""
    print(f"\n{notice}", file=sys.stderr, flush=True)


def _notice(args: argparse.Namespace):
    """How the compilation's notice is said: on a line of its own, after the progress bar's where one is drawn
    (None: :func:`omegahat.kernels.compiling.announced`'s own, on standard error)."""
    return None if args.no_progress else _on_its_own_line


def run_observers(campaign: campaigns.Campaign, args: argparse.Namespace) -> int:
    """``--observers``: the uniformity comparison on the campaign's draws, written to ``OUT/uniformity.md``."""
    from omegahat.lab.evaluation import uniformity

    names = [n.strip() for n in args.observers.split(",") if n.strip()]
    show = None if args.no_progress else (lambda j, n: print(f"\r{j}/{n} runs", end="", flush=True))
    compiled = compiling.seconds()
    with compiling.announced(_notice(args)):
        rows = uniformity.run_uniformity(
            campaign, names, gains=args.gains, horizon=args.horizon, tol=args.tol, progress=show
        )
    if show is not None:
        print()
    text = uniformity.markdown(rows)
    with staged_folder(args.out) as stage:
        (stage / "uniformity.md").write_text(text)
    print(text, end="")
    print(
        f"same draws for every observer: {uniformity.same_draws(rows)}; written to {args.out}/uniformity.md"
        + compiling.wait_note(compiled)
    )
    return 0


def run(args: argparse.Namespace) -> int:
    campaign = campaigns.load_campaign(args.config)
    if args.runs is not None:
        campaign = campaigns.replace(campaign, runs=args.runs)
    check_output_folder(args.out)
    if args.observers is not None:
        return run_observers(campaign, args)
    compiled = compiling.seconds()
    start = time.perf_counter()
    with compiling.announced(_notice(args)):
        if args.dask is None:
            results = campaigns.run_campaign(campaign, progress=not args.no_progress)
        else:
            from omegahat.lab.campaigns import distributed

            results = distributed.run_campaign_on(campaign, args.dask, progress=not args.no_progress)
    elapsed = time.perf_counter() - start - (compiling.seconds() - compiled)  # compiling is not running
    with staged_folder(args.out) as stage:
        summary = campaigns.write_outputs(campaign, results, stage)
    print(f"{campaign.runs} runs in {elapsed:.1f} s; outputs in {args.out}/{compiling.wait_note(compiled)}")
    for name, s in summary["gain_sets"].items():
        lam = "n/a" if s["worst_lambda"] is None else f"{s['worst_lambda']:.4g}/s"
        c = "n/a" if s["worst_c"] is None else f"{s['worst_c']:.4g}"
        print(
            f"  {name}: {s['runs_used']} runs used ({s['runs_out_of_bound']} left |omega| <= omega_M, "
            f"{s['runs_failed']} failed); worst rate {lam}, worst c {c}; V increased in {s['v_increased_runs']}; "
            f"not converged {s['not_converged_runs']}; counterexamples {s['counterexamples']}"
            + ("" if s["satisfies_theorem"] else " (gains outside the theorem's conditions)")
        )
    return 0
