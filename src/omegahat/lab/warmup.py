r"""Compile the kernels before a user needs them: every path of ``omegahat estimate``, ``paper`` and ``montecarlo``.

Run when the wheel is built (``build_support/omegahat_build.py``, the build step of ``pip install .``): in a child
process whose ``omegahat`` is the build's copy, so that Numba's cache files (``*.nbi``, ``*.nbc``) land in that
copy's ``__pycache__`` folders and are installed beside the sources (:mod:`omegahat.kernels.cache` loads them). It
runs the real code paths, each through :func:`omegahat.cli.main` on a small log of its own (100 Hz, 20 s, a body
turning at a constant rate; attitude noise 1e-3 rad), so that the compiled specialisations (argument types, literal
sizes, read-only flags) are those a user's run asks for:

* ``estimate`` on quaternions without a model; with ``--inertia 3 2 1``; with ``--smooth``; with ``--preset mocap``;
* ``estimate`` on two body-frame directions ``b1x..b2z`` with ``--references``; on one direction ``b1x..b1z`` with
  one reference and ``--inertia``;
* the paper's simulation (:func:`omegahat.simulation.simulate` on :func:`~omegahat.simulation.paper_problem`, a
  short horizon: the step count does not change what is compiled) — ``omegahat paper`` less its figures — and the
  same on the threaded lockstep engine (:func:`~omegahat.simulation.simulate_batch`, a public name whose first
  call otherwise compiles at length);
* a simulation with three directions (the three rows of R: a full attitude sensor);
* a chunk of ``omegahat montecarlo``'s campaign (``examples/campaign.toml``'s body, sensors and two torque terms),
  on Numba's threads and on the calling thread (as a Dask task runs it);
* the MEKF baseline's ``run`` and its smoother, the library's estimators not on the command's default paths;
* the gyro-free peers of ``omegahat compare`` (minimum-energy, predictive, Sun-line SEKF, differencing).

The simulation engine is compiled for each number of directions and of torque terms (literal sizes): the warm-up
covers the paper's, three directions, and the example campaign's; another problem's first simulation compiles its own
(30–50 s each; every size shipped lengthens every install by as much).

Any run can do the same (``python -m omegahat.lab.warmup``): it fills the cache the package uses. Each step's
seconds are printed; a failing step is reported and the others still run (exit status 1 then).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import tempfile
import time
import traceback
from collections.abc import Callable
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

__all__ = ["STEPS", "compiled_here", "main", "run", "write_logs"]

RATE_HZ = 100.0  #: the logs' sample rate
SECONDS = 20.0  #: the logs' length
OMEGA = (0.1, -0.2, 0.3)  #: the body's rate (rad/s, body axes)
NOISE = 1e-3  #: attitude noise (rad, per axis)


def _write(path: Path, header: str, columns: np.ndarray) -> Path:
    np.savetxt(path, columns, fmt="%.17g", delimiter=",", header=header, comments="")
    return path


def write_logs(folder: Path) -> dict[str, Path]:
    """The warm-up's logs in ``folder``: ``quaternions`` (``t,qw,qx,qy,qz``), ``directions`` (``t,b1x..b2z``: the
    body-frame images of x and y) and ``direction`` (``t,b1x,b1y,b1z``: of x alone)."""
    t = np.arange(int(SECONDS * RATE_HZ)) / RATE_HZ
    rng = np.random.default_rng(0)
    rot = (
        Rotation.from_rotvec([0.2, -0.3, 0.5])
        * Rotation.from_rotvec(np.outer(t, OMEGA))
        * Rotation.from_rotvec(rng.normal(0.0, NOISE, (len(t), 3)))
    )
    xyzw = rot.as_quat()
    R = rot.as_matrix()  # body → inertial: row j of R is Rᵀ e_j, the body-frame image of e_j
    return {
        "quaternions": _write(folder / "q.csv", "t,qx,qy,qz,qw", np.column_stack([t, xyzw])),
        "directions": _write(folder / "b.csv", "t,b1x,b1y,b1z,b2x,b2y,b2z", np.column_stack([t, R[:, 0], R[:, 1]])),
        "direction": _write(folder / "b1.csv", "t,b1x,b1y,b1z", np.column_stack([t, R[:, 0]])),
    }


def _estimate(log: str, *options: str) -> Callable[[dict[str, Path], Path], None]:
    def step(logs: dict[str, Path], folder: Path) -> None:
        from omegahat.cli import main

        status = main(["estimate", str(logs[log]), "-o", str(folder / "omega.csv"), *options])
        if status != 0:
            raise RuntimeError(f"omegahat estimate {log} {' '.join(options)} exited with {status}")

    return step


def _paper(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.simulation import paper_problem, simulate

    simulate(paper_problem(), horizon=0.2)


def _full_attitude(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.observer.gains import ObserverGains
    from omegahat.simulation import CoupledProblem, simulate

    problem = CoupledProblem(  # the three rows of R measured: a full attitude sensor's three directions
        J=np.diag([3.0, 2.0, 1.0]),
        gains=ObserverGains(k=np.full(3, 14.5), l_offset=np.ones(3)),
        omega0=np.array([2.0, -1.0, 0.6]),
        references=np.eye(3),
        r_hat0=-np.eye(3),
    )
    simulate(problem, horizon=0.2)


def _batch(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.simulation import paper_problem, simulate_batch

    simulate_batch([paper_problem(), paper_problem()], t_out=[0.0, 0.2])  # the lockstep engine, threaded (default)


def _campaign(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.lab import campaigns as mc
    from omegahat.observer.gains import theorem_gains

    J = np.diag([3.0, 2.0, 1.0])  # the example campaign's body and sensors, its two torque terms (the defaults)
    campaign = mc.Campaign(J=J, omega_max=3.0, gains={"theorem": theorem_gains(J, 3.0)}, runs=2, horizon=0.2)
    mc.run_chunk(campaign, 0, 2, parallel=True)  # omegahat montecarlo on this machine (Numba's threads)
    mc.run_chunk(campaign, 0, 2, parallel=False)  # the same, one chunk per Dask task


def _mekf(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.baselines.mekf import MEKF
    from omegahat.baselines.rts import RTSSmoother

    data = np.loadtxt(logs["quaternions"], delimiter=",", skiprows=1)
    t, q = data[:, 0], data[:, 1:]  # scalar last, as written
    MEKF(J=np.diag([3.0, 2.0, 1.0])).run(t, q)
    RTSSmoother(filter_factory=lambda: MEKF(J=np.diag([3.0, 2.0, 1.0]))).run(t, q)


def _peers(logs: dict[str, Path], folder: Path) -> None:
    from omegahat.baselines.differencing import DifferencingEstimator
    from omegahat.baselines.predictive_geom import PredictiveFilter
    from omegahat.baselines.sunline_sekf import SunlineSEKF
    from omegahat.baselines.tso3_min_energy import MinimumEnergyFilter

    data = np.loadtxt(logs["quaternions"], delimiter=",", skiprows=1)
    t, q = data[:, 0], data[:, 1:]  # scalar last, as written
    J = np.diag([3.0, 2.0, 1.0])
    for peer in (MinimumEnergyFilter(J), PredictiveFilter(J), DifferencingEstimator()):
        peer.run(t, q)
    direction = np.loadtxt(logs["direction"], delimiter=",", skiprows=1)
    SunlineSEKF().run(direction[:, 0], direction[:, 1:])


#: ``(name, step)``: what the warm-up runs, in order
STEPS: tuple[tuple[str, Callable[[dict[str, Path], Path], None]], ...] = (
    ("estimate, no model", _estimate("quaternions")),
    ("estimate --inertia", _estimate("quaternions", "--inertia", "3", "2", "1")),
    ("estimate --smooth", _estimate("quaternions", "--smooth")),
    ("estimate --preset mocap", _estimate("quaternions", "--preset", "mocap")),
    ("estimate, two directions", _estimate("directions", "--references=1,0,0;0,1,0")),
    ("estimate, one direction", _estimate("direction", "--references=1,0,0", "--inertia", "3", "2", "1")),
    ("paper's simulation", _paper),
    ("simulation, three directions", _full_attitude),
    ("simulate_batch", _batch),
    ("a Monte-Carlo campaign", _campaign),
    ("MEKF and its smoother", _mekf),
    ("the gyro-free peers", _peers),
)


def compiled_here() -> list[str]:
    """The omegahat kernels (module-level compiled functions) this process compiled rather than loaded from the cache,
    as ``"module.name(types)"``: a specialisation that is not among the cache hits. (A kernel that asks for literal
    arguments first tries, and discards, a non-literal compilation; that attempt leaves no specialisation.)"""
    from numba.core.dispatcher import Dispatcher

    found = []
    for name, module in list(sys.modules.items()):
        if name != "omegahat" and not name.startswith("omegahat."):
            continue
        for attr, value in list(vars(module).items()):
            if isinstance(value, Dispatcher) and value.__module__ == name:
                hits: dict = value.stats.cache_hits  # keyed by signature tuples (Numba's stubs say str)
                found += [f"{name}.{attr}{sig}" for sig in value.overloads if hits.get(sig, 0) == 0]
    return sorted(found)


def run(folder: Path, say: Callable[[str], None] = print) -> list[str]:
    """Run every step of :data:`STEPS` with its logs in ``folder`` (their messages swallowed); ``say`` one line per
    step with its CPU and wall seconds. Returns the names of the steps that failed (each said with its error)."""
    logs = write_logs(folder)
    failed = []
    for name, step in STEPS:
        cpu, wall = time.process_time(), time.perf_counter()
        chatter = io.StringIO()
        try:
            with contextlib.redirect_stdout(chatter), contextlib.redirect_stderr(chatter):
                step(logs, folder)
        except Exception:
            failed.append(name)
            say(f"warm-up: {name}: FAILED\n{chatter.getvalue()}{traceback.format_exc()}")
            continue
        say(f"warm-up: {name}: {time.process_time() - cpu:.1f} s CPU, {time.perf_counter() - wall:.1f} s")
    return failed


def main(argv: list[str] | None = None) -> int:
    """``python -m omegahat.lab.warmup``: :func:`run` in a temporary folder; 0 when every step ran, else 1."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="omegahat-warmup-") as folder:
        failed = run(Path(folder), say=lambda line: print(line, flush=True))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
