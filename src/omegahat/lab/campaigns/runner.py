r"""Running a campaign: chunks of runs, each integrated for every gain set and diagnosed as its runs end.

:func:`run_chunk` is the unit of work, here (:func:`run_campaign`, chunk after chunk on Numba's threads) and on a
cluster (:mod:`omegahat.lab.campaigns.distributed`, one task per chunk): its result depends on the campaign and the
run indices only, so a campaign gives the same numbers, bit for bit, however it is cut and wherever it runs.
"""

from __future__ import annotations

from collections.abc import Iterable

import numba
import numpy as np

from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.diagnostics import GainSetResult, result_from_diagnostics
from omegahat.lab.campaigns.draws import draw_runs
from omegahat.simulation.engine import LANES, RunSet, StepControl, integrate_envelopes
from omegahat.simulation.problem import first_step, initial_states, model_of
from omegahat.validation import as_directions, as_inertia

__all__ = ["chunks", "merge", "run_campaign", "run_chunk"]


def run_chunk(campaign: Campaign, start: int, stop: int, parallel: bool = True) -> dict[str, GainSetResult]:
    """Runs ``start .. stop − 1`` of the campaign for every gain set: ``{gains name: GainSetResult}``.

    The unit of work of :func:`run_campaign` and of :mod:`omegahat.lab.campaigns.distributed`; its result depends on
    the run indices only, not on how the campaign is cut into chunks nor on ``parallel`` (``False``: on the
    calling thread, for Dask's worker threads). The engine diagnoses each run as it ends
    (:func:`omegahat.simulation.engine.integrate_envelopes`): the same numbers as
    :func:`omegahat.lab.campaigns.diagnostics.diagnose` on the runs' states, without holding them.
    """
    if not (0 <= start < stop <= campaign.runs):
        raise ValueError(f"chunk [{start}, {stop}) is not inside the campaign's {campaign.runs} runs")
    indices = np.arange(start, stop)
    d = draw_runs(campaign, indices)  # once per run, whatever the number of gain sets
    # J and the references as a CoupledProblem stores them (normalising twice may move a last bit): each run is then
    # what draw_problem and simulate give for it
    J, references = as_inertia(campaign.J), as_directions(campaign.references)
    y0 = initial_states(references, d["R0"], d["omega0"], d["omega_hat0"], d["r_hat0"])
    control = StepControl(campaign.rtol, campaign.atol, campaign.h_max, campaign.max_steps)
    results = {}
    for name, gains in campaign.gains.items():
        runs = RunSet(
            y0, first_step(gains, d["omega_hat0"], campaign.h_max), d["constant"], d["amplitudes"], d["frequencies"],
            d["phases"],
        )  # fmt: skip
        out = integrate_envelopes(
            model_of(J, gains), runs, campaign.t_out, control, campaign.rho_floor, numba.get_num_threads(),
            LANES, parallel,
        )  # fmt: skip
        results[name] = result_from_diagnostics(
            campaign, indices, out.accepted, out.rejected, out.ok, out.rho, out.diagnostics
        )
    return results


def chunks(campaign: Campaign, chunk_size: int | None = None) -> list[tuple[int, int]]:
    """``(start, stop)`` pairs covering the campaign's runs."""
    size = campaign.chunk_size if chunk_size is None else int(chunk_size)
    if size < 1:
        raise ValueError(f"chunk_size must be at least 1; got {chunk_size!r}")
    return [(s, min(s + size, campaign.runs)) for s in range(0, campaign.runs, size)]


def merge(campaign: Campaign, parts: Iterable[dict[str, GainSetResult]]) -> dict[str, GainSetResult]:
    """Chunk results (any order) into one ``{gains name: GainSetResult}`` ordered by run index."""
    merged = {}
    first = next(iter(campaign.gains))
    parts = sorted(parts, key=lambda p: int(p[first].index[0]))  # chunks are runs start..stop: concatenate in order
    for name in campaign.gains:
        merged[name] = GainSetResult.concatenate([p[name] for p in parts])
        if not np.array_equal(merged[name].index, np.arange(campaign.runs)):
            raise ValueError("chunk results do not cover every run exactly once")
    return merged


def run_campaign(campaign: Campaign, chunk_size: int | None = None, progress: bool = False) -> dict[str, GainSetResult]:
    """All runs of the campaign, chunk by chunk on this machine (Numba threads): ``{name: GainSetResult}``."""
    parts = []
    spans = chunks(campaign, chunk_size)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=campaign.runs, unit="run", desc="montecarlo")
    for start, stop in spans:
        parts.append(run_chunk(campaign, start, stop))
        if bar is not None:
            bar.update(stop - start)
    if bar is not None:
        bar.close()
    return merge(campaign, parts)
