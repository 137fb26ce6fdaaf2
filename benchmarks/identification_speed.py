"""Cost of the identified default: ``identify`` on a log's head, and ``--smooth``'s two smoothers per sample.

Run: ``python benchmarks/identification_speed.py [--repeat N]``. A 100 Hz quaternion log of a body whose rate is a
random walk, 1 mrad of attitude noise; ``identify`` on its first 8192 samples (what ``omegahat estimate`` reads),
then :class:`omegahat.identification.smoother.ModelSmoother` and the log's own Wiener smoother
(:class:`omegahat.identification.spectral.SpectralSmoother`, ``--smooth`` where the model is declined) and both with
the choice between them (``ChosenSmoother``, ``--smooth`` where it is accepted) on 10,000 and 100,000 samples (the
checks of the input included), after one warm call (the kernels compiled); ``identify`` also with J and a torque,
with the torque's two holds (H1) and with one. CPU time of this process; issue 24 asks for at most 10 us per sample
of the smoother. Writes its section of RESULTS.md.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.identification import identify
from omegahat.identification.smoother import ChosenSmoother, ModelSmoother
from omegahat.identification.spectral import SpectralSmoother
from results_md import machine_line, write_section

SECTION = "## Identification and the model's smoother (benchmarks/identification_speed.py)"
RATE_HZ = 100.0


def wandering_log(n: int, seed: int = 0, roughness: float = 0.002) -> tuple[np.ndarray, np.ndarray]:
    """``(t, quaternions (x, y, z, w))``: n samples at 100 Hz of a random-walk rate (steps of ``roughness`` rad/s),
    1 mrad attitude noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / RATE_HZ
    omega = np.cumsum(rng.normal(0.0, roughness, (n, 3)), axis=0) + np.array([0.3, -0.2, 0.4])
    steps = Rotation.from_rotvec(omega / RATE_HZ)
    q = np.empty((n, 4))
    current = Rotation.identity()
    for k in range(n):
        q[k] = current.as_quat()
        current = current * steps[k]
    return t, (Rotation.from_quat(q) * Rotation.from_rotvec(rng.normal(0.0, 1e-3, (n, 3)))).as_quat()


def cpu(call) -> float:
    start = time.process_time()
    call()
    return time.process_time() - start


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=3, help="runs of each measurement (the best and the median kept)")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    t, q = wandering_log(100_000)
    head = 8192
    ident = identify(t[:head], q[:head], "quaternion")  # warm: the kernels compiled
    smoother = ModelSmoother(ident)
    smoother.run(t[:1000], q[:1000])
    rows = []
    times = [cpu(lambda: identify(t[:head], q[:head], "quaternion")) for _ in range(args.repeat)]
    rows.append(f"| `identify` on {head} samples (model {ident.chosen.model}) | {min(times):.2f} s | "
                f"{float(np.median(times)):.2f} s |")  # fmt: skip
    # a log whose model is declined (its rate a random walk 100 times rougher): the causal filter (C3) is designed too
    t_rough, q_rough = wandering_log(head, seed=1, roughness=0.2)
    declined = identify(t_rough, q_rough, "quaternion")
    times = [cpu(lambda: identify(t_rough, q_rough, "quaternion")) for _ in range(args.repeat)]
    designed = " (causal filter designed)" if declined.causal else ""
    rows.append(f"| `identify` on {head} samples, model declined{designed} | {min(times):.2f} s | "
                f"{float(np.median(times)):.2f} s |")  # fmt: skip
    # with J and a torque (not this motion's: the cost is the evaluations' number, not the fit) the two dynamic models
    # join; (H1) fits each with the torque held and interpolated, twice the passes of one hold
    J, tau = np.diag([3.0, 2.0, 1.0]), 0.1 * np.sin(np.outer(t[:head], [0.7, 1.1, 1.3]))
    for hold, label in ((None, "both holds (H1)"), (False, "the torque held only, as before (H1)")):
        times = [
            cpu(lambda hold=hold: identify(t[:head], q[:head], "quaternion", J=J, torque=tau, linear_hold=hold))
            for _ in range(args.repeat)
        ]
        rows.append(f"| `identify` on {head} samples with J and a torque, {label} | {min(times):.2f} s | "
                    f"{float(np.median(times)):.2f} s |")  # fmt: skip
    both = ChosenSmoother(ident)
    for name, est in (("ModelSmoother", smoother), ("SpectralSmoother", SpectralSmoother()), ("ChosenSmoother", both)):
        for n in (10_000, 100_000):
            per = [cpu(lambda n=n, est=est: est.run(t[:n], q[:n])) * 1e6 / n for _ in range(args.repeat)]
            rows.append(f"| `{name}.run`, {n:,} samples | {min(per):.2f} us/sample | "
                        f"{float(np.median(per)):.2f} us/sample |")  # fmt: skip
    table = "| what | CPU best | CPU median |\n| --- | --- | --- |\n" + "\n".join(rows)
    print(table)
    write_section(
        SECTION,
        f"{machine_line()} Command: `python benchmarks/identification_speed.py --repeat {args.repeat}` (100 Hz "
        "quaternions of a random-walk rate, 1 mrad noise; CPU time of the process, kernels compiled before).\n\n"
        + table,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
