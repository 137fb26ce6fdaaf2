"""Speed of the sampled Sarras estimator, beside the plain NumPy per-sample implementation.

Run: ``python benchmarks/estimator_speed.py [--samples N]``. Prints

* the median cost of one ``SarrasEstimator.update`` called from Python (goal ≤ 5 µs), for a rotation matrix and
  a quaternion sample (each call timed on its own with ``perf_counter_ns``; median over many calls);
* the throughput of ``run`` on whole arrays (goal ≥ 1e6 samples/s on one core; best of 3);
* the throughput of the plain NumPy per-sample oracle (:func:`omegahat.observer.reference.reference_step`) on a shorter
  log, and the largest difference between the two on that log.

Data: the paper's body J = diag(3, 2, 1) tumbling from ω₀ = (2, −1, 0.6) rad/s, sampled at 1 kHz (ground truth from
:func:`omegahat.simulation.rigid_body.integrate`), theorem gains, three rows of R (all three measured directions).
Compilation is done (and cached) before any timing. The machine may be shared: numbers vary by tens of percent.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.observer.estimator import EstimatorState, SarrasEstimator
from omegahat.observer.gains import theorem_gains
from omegahat.observer.reference import reference_step
from omegahat.simulation.rigid_body import RigidBody, integrate
from results_md import machine_line, write_section

J = np.diag([3.0, 2.0, 1.0])


def data(T, h=1e-3):
    times = np.arange(T) * h
    traj = integrate(RigidBody(J), np.eye(3), [2.0, -1.0, 0.6], times, max_step=h)
    return times, traj.R


def median_update_ns(est, times, meas, repeats):
    per_call = np.empty(repeats, dtype=np.int64)
    clock = time.perf_counter_ns
    for j in range(repeats):
        m = meas[j]
        t = times[j]
        t0 = clock()
        est.update(t, m)
        per_call[j] = clock() - t0
    return float(np.median(per_call)), float(np.percentile(per_call, 90))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--samples", type=int, default=1_000_000, help="log length for run (default 1e6)")
    parser.add_argument("--oracle-samples", type=int, default=5_000)
    args = parser.parse_args(argv)
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})  # one core
    g = theorem_gains(J, 3.0, references=np.eye(3))
    times, R = data(args.samples)
    q = Rotation.from_matrix(R).as_quat()

    SarrasEstimator(J, gains=g, warm_start=False).run(times[:10], R[:10])  # compile / load the cache
    SarrasEstimator(J, gains=g, warm_start=False).run(times[:10], q[:10])
    est = SarrasEstimator(J, gains=g, warm_start=False)
    est.update(times[0], R[0])
    est.update(times[1], q[1])

    reps = min(200_000, args.samples)
    est = SarrasEstimator(J, gains=g, warm_start=False)
    med_R, p90_R = median_update_ns(est, times, R, reps)
    est = SarrasEstimator(J, gains=g, warm_start=False)
    med_q, p90_q = median_update_ns(est, times, q, reps)
    lines = [
        "| measurement | result |",
        "| --- | --- |",
        f"| `update`, one rotation matrix | median {med_R / 1e3:.2f} us (90th percentile {p90_R / 1e3:.2f} us) |",
        f"| `update`, one quaternion | median {med_q / 1e3:.2f} us (90th percentile {p90_q / 1e3:.2f} us) |",
    ]

    for label, meas in (("rotation matrices", R), ("quaternions", q)):
        best = np.inf
        for _ in range(3):
            est = SarrasEstimator(J, gains=g, warm_start=False)
            t0 = time.perf_counter()
            W = est.run(times, meas).omega
            best = min(best, time.perf_counter() - t0)
        lines.append(
            f"| `run`, {args.samples:,} {label} | {best:.3f} s = {args.samples / best / 1e6:.2f} million samples/s |"
        )

    n = args.oracle_samples
    st = EstimatorState(np.nan, False, np.nan, np.zeros(3), np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3)))
    out = np.empty((n, 3))
    t0 = time.perf_counter()
    for j in range(n):
        st = reference_step(st, times[j], R[j], None, J, g)
        out[j] = st.omega_hat
    dt = time.perf_counter() - t0
    both = np.all(np.isfinite(W[:n]), axis=1)  # the compiled estimator has no estimate at the first sample
    lines.append(
        f"| plain NumPy oracle (`reference_step`) | {n / dt:.0f} samples/s; largest difference from the compiled "
        f"estimator over the {int(both.sum()):,} of {n:,} samples where it has an estimate "
        f"{np.abs(W[:n][both] - out[both]).max():.2e} rad/s |"
    )
    table = "\n".join(lines)
    print(table)
    write_section(
        "## The streaming estimator (benchmarks/estimator_speed.py)",
        f"{machine_line()} Command: `python benchmarks/estimator_speed.py --samples {args.samples}` (one core; the "
        f"paper's body at 1 kHz, theorem gains, three rows of R; `update` timed call by call over {reps:,} calls, "
        "`run` best of 3).\n\n" + table,
    )


if __name__ == "__main__":
    main()
