r"""What a campaign says: its summary (``summary.json``), counterexamples and figures.

Per gain set: the worst rate and constant of the envelope over the runs within the bound (the definitions are in
:mod:`omegahat.lab.campaigns`), the counts of runs used, set aside and failed, whether the gains satisfy the theorem
(:func:`omegahat.observer.gains.check_gains`), and every counterexample with its seed and initial conditions.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.diagnostics import GainSetResult
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.observer.gains import check_gains

if TYPE_CHECKING:  # matplotlib is imported when a figure is drawn
    from matplotlib.figure import Figure

__all__ = ["plot_envelopes", "plot_rates", "summarize", "worst_envelope", "write_outputs"]


def _float(x):
    x = float(x)
    return x if math.isfinite(x) else None


def _counterexamples(campaign: Campaign, name: str, r: GainSetResult) -> list:
    rho_end = r.rho[:, -1]
    found = []  # (row of r, reasons)
    for j in range(r.index.size):
        reasons = []
        if not r.ok[j]:
            reasons.append("integration failed (non-finite state or step budget)")
        elif not r.in_bound[j]:
            continue  # set aside: the assumption |ω| ≤ ω_M does not hold
        else:
            if not rho_end[j] <= campaign.converged_below:
                reasons.append(f"not converged: rho(horizon) = {rho_end[j]:.3g} > {campaign.converged_below:g}")
            if r.v_increase[j] > campaign.v_increase_tol:
                reasons.append(f"V increased by {r.v_increase[j]:.3g} (relative) between two output times")
        if reasons:
            found.append((j, reasons))
    # the initial conditions of all counterexamples in one draw (those of draw_problem for each)
    d = draw_runs(campaign, [r.index[j] for j, _ in found])
    out = []
    for row, (j, reasons) in enumerate(found):
        out.append(
            {
                "gains": name,
                "index": int(r.index[j]),
                "seed": {"entropy": int(campaign.seed), "spawn_key": [int(r.index[j])]},
                "reasons": reasons,
                "lambda_run": _float(r.lam[j]),
                "rho_end": _float(rho_end[j]),
                "omega0": d["omega0"][row].tolist(),
                "R0": d["R0"][row].tolist(),
                "r_hat0": d["r_hat0"][row].tolist(),
                "omega_hat0": d["omega_hat0"][row].tolist(),
                "torque": {
                    "amplitudes": d["amplitudes"][row].tolist(),
                    "frequencies": d["frequencies"][row].tolist(),
                    "phases": d["phases"][row].tolist(),
                },
            }
        )
    return out


def worst_envelope(campaign: Campaign, r: GainSetResult) -> tuple[float, float, int]:
    """``(λ*, c*, index of the slowest run)`` over the in-bound runs (module docstring)."""
    use = r.in_bound & np.isfinite(r.lam)
    if not np.any(use):
        return math.nan, math.nan, -1
    lam_star = float(np.min(r.lam[use]))
    t = campaign.t_out
    masked = np.where(t[None, :] <= r.t_f[use][:, None], r.rho[use] * np.exp(lam_star * t)[None, :], 0.0)
    c_star = float(masked.max())
    slowest = int(r.index[use][np.argmin(r.lam[use])])
    return lam_star, c_star, slowest


def summarize(campaign: Campaign, results: dict[str, GainSetResult]) -> dict[str, Any]:
    """A JSON-ready summary: per gain set the envelope, counts, counterexamples and step statistics."""
    summary = {
        "runs": campaign.runs,
        "seed": campaign.seed,
        "horizon": campaign.horizon,
        "dt_out": campaign.dt_out,
        "rtol": campaign.rtol,
        "omega_max": campaign.omega_max,
        "J": campaign.J.tolist(),
        "references": campaign.references.tolist(),
        "rho_floor": campaign.rho_floor,
        "gain_sets": {},
    }
    for name, r in results.items():
        g = campaign.gains[name]
        check = check_gains(g, campaign.J, campaign.omega_max, campaign.references, warn=False)
        lam_star, c_star, slowest = worst_envelope(campaign, r)
        use = r.in_bound & np.isfinite(r.lam)
        cex = _counterexamples(campaign, name, r)
        summary["gain_sets"][name] = {
            "k": g.k.tolist(),
            "l_offset": g.l_offset.tolist(),
            "l_slope": g.l_slope.tolist(),
            "satisfies_theorem": check.ok,
            "runs_integrated": int(r.ok.sum()),
            "runs_failed": int((~r.ok).sum()),
            "runs_out_of_bound": int((r.ok & ~r.in_bound).sum()),
            "runs_used": int(use.sum()),
            "worst_lambda": _float(lam_star),
            "worst_c": _float(c_star),
            "slowest_run": slowest,
            "lambda_quantiles": {
                q: _float(np.quantile(r.lam[use], float(q))) if use.any() else None for q in ("0.01", "0.5", "0.99")
            },
            "max_c_run": _float(np.max(r.c_run[use])) if use.any() else None,
            "v_increased_runs": int((use & (r.v_increase > campaign.v_increase_tol)).sum()),
            "not_converged_runs": int((use & ~(r.rho[:, -1] <= campaign.converged_below)).sum()),
            "counterexamples": len(cex),
            "counterexample_list": cex,
            "accepted_steps": int(r.steps.sum()),
            "rejected_steps": int(r.rejected.sum()),
        }
    return summary


def plot_envelopes(
    campaign: Campaign, results: dict[str, GainSetResult], summary: dict[str, Any], max_lines: int = 100
) -> Figure:
    """One panel per gain set: ρ(t) of up to ``max_lines`` in-bound runs, the pointwise worst ρ over all of them
    and the envelope ``c* e^{−λ* t}`` (log scale). Returns the figure."""
    import matplotlib.pyplot as plt

    names = list(results)
    fig, axes = plt.subplots(1, len(names), figsize=(6 * len(names), 4.2), squeeze=False)
    t = campaign.t_out
    for ax, name in zip(axes[0], names, strict=True):
        r = results[name]
        s = summary["gain_sets"][name]
        use = np.flatnonzero(r.in_bound)
        floor = campaign.rho_floor * 1e-2
        for j in use[:max_lines]:
            ax.semilogy(t, np.maximum(r.rho[j], floor), color="0.6", lw=0.5, alpha=0.6)
        if use.size:
            ax.semilogy(t, np.maximum(r.rho[use].max(axis=0), floor), color="C3", lw=1.5, label="worst ρ(t)")
        if s["worst_lambda"] is not None:
            env = s["worst_c"] * np.exp(-s["worst_lambda"] * t)
            ax.semilogy(
                t,
                np.maximum(env, floor),
                "k--",
                lw=1.2,
                label=f"c* e^(-λ* t): c* = {s['worst_c']:.3g}, λ* = {s['worst_lambda']:.3g}/s",
            )
        ax.axhline(campaign.rho_floor, color="C0", lw=0.8, ls=":", label="ρ floor")
        ax.set_ylim(floor, None)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("(|z| + Σ|e_i|) / initial")
        ax.set_title(f"{name}: {s['runs_used']} runs")
        ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def plot_rates(campaign: Campaign, results: dict[str, GainSetResult]) -> Figure:
    """Histogram of the per-run rates λ_run, one colour per gain set. Returns the figure."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4))
    for name, r in results.items():
        lam = r.lam[r.in_bound & np.isfinite(r.lam)]
        if lam.size:
            ax.hist(lam, bins=60, alpha=0.6, label=f"{name} (min {lam.min():.3g}/s)")
    ax.set_xlabel("λ_run (1/s)")
    ax.set_ylabel("runs")
    ax.legend()
    fig.tight_layout()
    return fig


def write_outputs(
    campaign: Campaign, results: dict[str, GainSetResult], out_dir: str | os.PathLike[str]
) -> dict[str, Any]:
    """Write ``summary.json``, ``counterexamples.json``, ``envelopes.png`` and ``rates.png``; return the summary
    (without the counterexample lists, which are in their own file)."""
    import matplotlib.pyplot as plt

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    summary = summarize(campaign, results)
    cex = {name: s.pop("counterexample_list") for name, s in summary["gain_sets"].items()}
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    (out / "counterexamples.json").write_text(json.dumps(cex, indent=2) + "\n")
    full = {**summary, "gain_sets": {n: {**s, "counterexample_list": cex[n]} for n, s in summary["gain_sets"].items()}}
    fig = plot_envelopes(campaign, results, full)
    fig.savefig(out / "envelopes.png", dpi=120)
    plt.close(fig)
    fig = plot_rates(campaign, results)
    fig.savefig(out / "rates.png", dpi=120)
    plt.close(fig)
    return summary
