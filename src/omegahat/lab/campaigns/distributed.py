"""Monte-Carlo campaigns on a Dask cluster (``pip install "omegahat[dask]"``).

The campaign is cut into chunks of runs (:func:`omegahat.lab.campaigns.runner.chunks`); each chunk is one task,
:func:`omegahat.lab.campaigns.runner.run_chunk`, whose result depends only on the campaign (its seed) and the run
indices. The results are merged by run index exactly as on one machine, so a campaign gives the same numbers,
bit for bit, locally and on any cluster, whatever the number of workers or the order in which chunks finish.

Inside a task the runs of the chunk are integrated one after another (``parallel=False``): the cluster supplies
the parallelism (one task per worker thread), and Numba's parallel layer is never entered from two threads.

Pointing it at a real cluster::

    # on the scheduler host                 # on each worker host (same Python environment with omegahat)
    dask scheduler                          dask worker tcp://SCHEDULER:8786 --nthreads 1 --nworkers auto

    omegahat montecarlo examples/campaign.toml --dask tcp://SCHEDULER:8786 --out campaign-out

or from Python ``run_campaign_dask(campaign, distributed.Client("tcp://SCHEDULER:8786"))``. ``--dask local``
starts a ``LocalCluster`` on this machine. Workers need omegahat installed (same version); Numba compiles the
kernels once per worker process on first use (cached on disk afterwards).
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING

from omegahat.lab.campaigns.config import Campaign
from omegahat.lab.campaigns.diagnostics import GainSetResult
from omegahat.lab.campaigns.runner import chunks, merge, run_chunk

if TYPE_CHECKING:  # the optional "dask" extra: imported when a campaign runs (_require_distributed)
    import distributed

__all__ = ["run_campaign_dask", "run_campaign_on"]


def _require_distributed() -> ModuleType:
    try:
        import distributed
    except ModuleNotFoundError as exc:  # pragma: no cover - exercised only without the extra
        raise ModuleNotFoundError(
            "Dask campaigns need the 'dask' extra: pip install \"omegahat[dask]\" (dask[distributed])"
        ) from exc
    return distributed


def run_campaign_dask(
    campaign: Campaign, client: distributed.Client, chunk_size: int | None = None, progress: bool = False
) -> dict[str, GainSetResult]:
    """Run ``campaign`` on a ``distributed.Client``: one task per chunk, merged by run index.

    Returns what :func:`omegahat.lab.campaigns.runner.run_campaign` returns, with identical numbers.
    """
    distributed = _require_distributed()
    spans = chunks(campaign, chunk_size)
    scattered = client.scatter(campaign, broadcast=True)
    futures = [client.submit(run_chunk, scattered, start, stop, False, pure=False) for start, stop in spans]
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=campaign.runs, unit="run", desc="montecarlo (dask)")
    parts = []
    for future in distributed.as_completed(futures):
        part = future.result()
        parts.append(part)
        if bar is not None:
            bar.update(int(next(iter(part.values())).index.size))
    if bar is not None:
        bar.close()
    return merge(campaign, parts)


def run_campaign_on(
    campaign: Campaign, address: str, chunk_size: int | None = None, progress: bool = False
) -> dict[str, GainSetResult]:
    """Connect to the scheduler at ``address`` (``"local"``: start a ``LocalCluster`` here) and run there."""
    distributed = _require_distributed()
    if address == "local":
        with distributed.LocalCluster(threads_per_worker=1) as cluster, distributed.Client(cluster) as client:
            return run_campaign_dask(campaign, client, chunk_size, progress)
    with distributed.Client(address) as client:
        return run_campaign_dask(campaign, client, chunk_size, progress)
