r"""Monte-Carlo campaigns: many independent plant + observer runs, and what they say about the theorem.

**The claim under test** (Sarras' theorem, ``docs/theory/observer.md``): with ``J_m I ≤ J ≤ J_M I``, ``|ω(t)| ≤ ω_M``
and gains meeting the conditions of :mod:`omegahat.observer.gains`, the errors ``z = ω̂ − ω``, ``e_i = r̂_i − r_i``
converge globally exponentially, and the proof's ``V = |J z| + ½ Σ |e_i|²`` decreases. Each run draws its
initial conditions and a bounded torque from its own seed (:mod:`omegahat.lab.campaigns.draws`); a run whose ``|ω|``
exceeds ω_M at an output time breaks the assumption: it is counted and **set aside**.

**Envelope.** With ``E(t) = |z(t)| + Σ_i |e_i(t)|`` and ``ρ(t) = E(t)/E(0)`` on the output grid ``t_k``:

* a run's rate ``λ_run = −ln ρ(t_f) / t_f``, where ``t_f`` is the last output time with ``ρ ≥ rho_floor``
  (default 1e-8; below it the integrator's tolerance, not the observer, sets ρ): the average exponential rate at
  which the run loses its first ``−ln ρ(t_f)`` nepers;
* its own constant ``c_run = max_{t_k ≤ t_f} ρ(t_k) e^{λ_run t_k} ≥ 1`` (the overshoot above a pure exponential
  at its own rate);
* the campaign's worst rate ``λ* = min λ_run`` and worst constant ``c* = max_runs max_{t_k ≤ t_f}
  ρ(t_k) e^{λ* t_k}``: the smallest c for which ``E(t) ≤ c e^{−λ* t} E(0)`` holds for every run and output
  time down to the floor. ``(c*, λ*)`` is an envelope measured on the grid, not a proof.

**Counterexamples** (saved with their seed and index, one list per gain set): a run that failed to integrate
(non-finite state or step budget), did not converge (``ρ(horizon) > converged_below``), or along which ``V``
increased between two output times by more than the relative tolerance ``v_increase_tol`` (checked while
``ρ ≥ rho_floor``). ``V`` increasing is a counterexample to the proof only for gains that satisfy the theorem
(``satisfies_theorem`` in the summary); for practical gains it is reported as what it is.

Modules: :mod:`~omegahat.lab.campaigns.config` (the campaign and its TOML file), :mod:`~omegahat.lab.campaigns.draws`
and :mod:`~omegahat.lab.campaigns.seeds` (each run from its seed), :mod:`~omegahat.lab.campaigns.runner` (chunks on this
machine), :mod:`~omegahat.lab.campaigns.diagnostics` (per-run diagnostics, taken in the engine as runs end),
:mod:`~omegahat.lab.campaigns.report` (summary, counterexamples, figures), :mod:`~omegahat.lab.campaigns.distributed`
(Dask). Results of ``examples/campaign.toml``: ``docs/results.md``.
"""

from omegahat.lab.campaigns.config import (
    Campaign,
    campaign_from_dict,
    campaign_from_toml,
    load_campaign,
    replace,
    run_seed,
)
from omegahat.lab.campaigns.diagnostics import GainSetResult, diagnose, envelope_fit
from omegahat.lab.campaigns.draws import draw_problem, replay
from omegahat.lab.campaigns.report import plot_envelopes, plot_rates, summarize, worst_envelope, write_outputs
from omegahat.lab.campaigns.runner import chunks, merge, run_campaign, run_chunk

__all__ = [
    "Campaign",
    "GainSetResult",
    "campaign_from_dict",
    "campaign_from_toml",
    "chunks",
    "diagnose",
    "draw_problem",
    "envelope_fit",
    "load_campaign",
    "merge",
    "plot_envelopes",
    "plot_rates",
    "replace",
    "replay",
    "run_campaign",
    "run_chunk",
    "run_seed",
    "summarize",
    "worst_envelope",
    "write_outputs",
]
