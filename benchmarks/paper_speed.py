"""Issue 2.9: wall time to simulate the paper's 10 s to the accuracy of issue 2.6, beside a plain implementation
of the same equations integrated by ``solve_ivp(method="LSODA")`` — both timed in this one run.

Accuracy is measured against an independent high-accuracy reference (DOP853 at rtol 1e-13 on the observer's own
(ξ, r̂) equations; not timed). Run: ``python benchmarks/paper_speed.py``.
"""

import statistics
import time

import numpy as np

from omegahat.simulation import paper_problem, simulate, simulate_reference

T_OUT = np.array([0.0, 0.5, 1.0, 2.0, 5.0, 10.0])
CHECK = [1, 2, 3]  # t = 0.5, 1, 2 s


def timed(fn, repeat):
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main():
    problem = paper_problem()
    reference = simulate_reference(problem, T_OUT, method="DOP853", rtol=1e-13, atol=1e-16)
    simulate(problem, t_out=T_OUT)  # compile / load the Numba cache before timing
    t_fast, fast = timed(lambda: simulate(problem, t_out=T_OUT), 21)
    t_lsoda, lsoda = timed(lambda: simulate_reference(problem, T_OUT, method="LSODA", rtol=1e-10, atol=1e-14), 3)

    def rel(traj):
        return np.abs(traj.error[CHECK] / reference.error[CHECK] - 1.0)

    print("paper scenario, 10 s, |w_hat - w| at t = 0.5, 1, 2 s")
    print(f"reference (DOP853 rtol 1e-13): {', '.join(f'{v:.10e}' for v in reference.error[CHECK])}")
    print(f"{'method':<40}{'median wall time':>18}{'max rel. error':>16}")
    print(f"{'omegahat.simulation.coupled (ETDRK4, rtol 1e-9)':<40}{t_fast * 1e3:>15.2f} ms{rel(fast).max():>16.2e}")
    print(f"{'solve_ivp LSODA (rtol 1e-10, atol 1e-14)':<40}{t_lsoda * 1e3:>15.2f} ms{rel(lsoda).max():>16.2e}")
    print(f"speed-up: {t_lsoda / t_fast:.0f}x  (goal: at least 100x, both within 1e-6 relative)")


if __name__ == "__main__":
    main()
