"""The Dask extra gives the same numbers as the local run (skipped when dask.distributed is not installed)."""

import numpy as np
import pytest

distributed = pytest.importorskip(
    "distributed", reason='Dask is an extra: pip install ".[dask]" (the test extra includes it)'
)

from omegahat.lab import campaigns as mc  # noqa: E402
from omegahat.lab.campaigns.distributed import run_campaign_dask  # noqa: E402
from omegahat.observer.gains import ObserverGains, theorem_gains  # noqa: E402

J = np.diag([3.0, 2.0, 1.0])


def test_local_cluster_gives_the_local_numbers():
    c = mc.Campaign(
        J=J,
        omega_max=3.0,
        runs=9,
        seed=31,
        chunk_size=4,
        horizon=1.0,
        dt_out=0.1,
        gains={"theorem": theorem_gains(J, 3.0), "constant": ObserverGains.constant(14.5, 1.0)},
    )
    local = mc.run_campaign(c)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False, dashboard_address=None) as lc:
        with distributed.Client(lc) as client:
            remote = run_campaign_dask(c, client, chunk_size=2)
    for name in c.gains:
        np.testing.assert_array_equal(remote[name].index, np.arange(9))
        np.testing.assert_array_equal(remote[name].rho, local[name].rho)
        np.testing.assert_array_equal(remote[name].lam, local[name].lam)
        np.testing.assert_array_equal(remote[name].steps, local[name].steps)
    assert mc.summarize(c, remote) == mc.summarize(c, local)


def test_merge_refuses_missing_chunks():
    c = mc.Campaign(
        J=J, omega_max=3.0, runs=4, seed=1, horizon=0.2, dt_out=0.1, gains={"theorem": theorem_gains(J, 3.0)}
    )
    part = mc.run_chunk(c, 0, 2, parallel=False)
    with pytest.raises(ValueError, match="do not cover every run exactly once"):
        mc.merge(c, [part])
