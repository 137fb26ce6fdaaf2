"""omegahat's laboratory: what the project uses to study and prove its estimators, apart from the library.

The library (``omegahat``: the estimators, their gains, identification, the readers and writers, the
``estimate`` command) never imports this package; ``import omegahat`` loads none of it. Here live:

* :mod:`omegahat.lab.campaigns` — Monte-Carlo campaigns (configuration, seeded draws, runner, diagnostics,
  report, Dask);
* :mod:`omegahat.lab.evaluation` — metrics, the comparison method, the BROAD recordings and their score, the
  uniformity harness of continuous observers;
* :mod:`omegahat.lab.control` — velocity-free attitude control in closed loop (and the MuJoCo plant);
* :mod:`omegahat.lab.scenarios` — the scenarios of ``omegahat compare``;
* :mod:`omegahat.lab.peer_scenarios` — the published peers' own simulation settings (issue 26's baselines);
* :mod:`omegahat.lab.gain_sweep` — the noise/convergence trade-off of the observer's gains, measured;
* :mod:`omegahat.lab.plots` — figures (Matplotlib, returning handles);
* :mod:`omegahat.lab.cli` — the commands ``paper``, ``compare``, ``montecarlo`` and ``control``.
"""
