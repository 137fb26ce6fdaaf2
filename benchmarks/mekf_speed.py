"""Speed of the compiled gyro-less MEKF (``MEKF.run``), beside the plain NumPy per-sample path (``MEKF.update``).

Run: ``python benchmarks/mekf_speed.py [--seconds S] [--oracle-samples N]``. Prints one row per case,
dynamic / kinematic model × attitude fixes / three direction measurements, at 5 Hz and 285.7 Hz (the BROAD rate):

* ``run``: µs per sample of ``MEKF.run`` on a log of ``S`` seconds (default 300 s: 1,500 and 85,710 samples;
  best of 3, each on a fresh filter);
* ``update loop``: µs per sample of a Python loop of ``MEKF.update`` (the NumPy reference path) on the first
  ``N`` samples (default 200), and the largest |ω̂_run − ω̂_update| on them relative to max |ω̂|.

At 5 Hz the body turns up to 0.46 rad in a step of 0.2 s: 3 substeps (at most 0.2 rad each), at 285.7 Hz one.
Data: J = diag(3, 2, 1) tumbling from ω₀ = (2, −1, 0.6) rad/s with a small constant known torque (truth from
:func:`omegahat.simulation.rigid_body.integrate`), attitude noise 1e-3 rad, direction noise 1e-3; q = 1e-4.
Compilation is done (and cached) before any timing. The machine may be shared: numbers vary by tens of percent.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.baselines.mekf import MEKF
from omegahat.simulation.rigid_body import RigidBody, integrate
from results_md import machine_line, write_section

J = np.diag([3.0, 2.0, 1.0])
REFS = np.eye(3)
TAU = np.array([0.02, -0.01, 0.005])


def data(rate_hz, seconds, rng):
    times = np.arange(round(seconds * rate_hz)) / rate_hz
    truth = integrate(RigidBody(J), np.eye(3), [2.0, -1.0, 0.6], times, torque=TAU, max_step=2e-3)
    R_meas = truth.R @ Rotation.from_rotvec(rng.normal(0.0, 1e-3, (times.size, 3))).as_matrix()
    b_meas = np.einsum("ij,tjk->tik", REFS, truth.R) + rng.normal(0.0, 1e-3, (times.size, 3, 3))
    return times, np.tile(TAU, (times.size, 1)), R_meas, b_meas


def make(model, directions):
    return MEKF(J, model=model, q=1e-4, measurement_noise=1e-3, references=REFS if directions else None)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=300.0, help="log length for run, s (default 300)")
    parser.add_argument("--oracle-samples", type=int, default=200)
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    logs = {rate: data(rate, args.seconds, rng) for rate in (5.0, 285.7)}
    t, tau, R_meas, b_meas = logs[5.0]
    make("dynamic", False).run(t[:5], R_meas[:5], tau[:5])  # compile / load the cache

    lines = [
        "| model | measurements | rate (Hz) | samples | `run`, us per sample | `update` loop, us per sample | "
        "largest relative difference |",
        "| --- | --- | --- | --- | --- | --- | --- |",
    ]
    for model in ("dynamic", "kinematic"):
        for directions in (False, True):
            for rate, (t, tau, R_meas, b_meas) in logs.items():
                meas = b_meas if directions else R_meas
                best = np.inf
                for _ in range(3):
                    f = make(model, directions)
                    t0 = time.perf_counter()
                    W = f.run(t, meas, tau).omega
                    best = min(best, time.perf_counter() - t0)
                n = min(args.oracle_samples, t.size)
                g = make(model, directions)
                t0 = time.perf_counter()
                ref = np.array([g.update(t[j], meas[j], tau[j]).omega for j in range(n)])
                loop = time.perf_counter() - t0
                diff = np.nanmax(np.abs(W[:n] - ref)) / np.nanmax(np.abs(ref))  # NaN: no estimate yet
                lines.append(
                    f"| {model} | {'directions' if directions else 'attitude'} | {rate:.1f} | {t.size} | "
                    f"{best / t.size * 1e6:.1f} | {loop / n * 1e6:.0f} | {diff:.1e} |"
                )
    table = "\n".join(lines)
    print(table)
    write_section(
        "## The gyro-less MEKF (benchmarks/mekf_speed.py)",
        f"{machine_line()} Command: `python benchmarks/mekf_speed.py --seconds {args.seconds:g}` (`run` best of 3; the "
        f"NumPy `update` loop, the oracle, over the first {args.oracle_samples} samples).\n\n" + table,
    )


if __name__ == "__main__":
    main()
