"""The estimators' compiled loops over a log release the GIL (``nogil=True``).

``omegahat estimate`` reads the next chunk (a thread: PyArrow parses, then Python and the input checks convert) and
writes the last one (a thread) while the estimator runs over the current one; a compiled loop that held the GIL for
the whole chunk would stall both (``benchmarks/big_log.py`` times the whole). Each test captures the arguments a
public estimator's ``run`` gives its loop, calls the loop again in a thread, and checks that this thread's Python
code runs while the loop does.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from omegahat.observer import sampled, single_direction_step, supervised
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.single_direction import SingleDirectionEstimator

N = 200_000  # samples: a loop of 0.1-1 s


def _copy(a):
    """A copy of an argument of the same Numba type (read-only if it was: otherwise another signature)."""
    if not isinstance(a, np.ndarray):
        return a
    c = a.copy()
    c.flags.writeable = a.flags.writeable
    return c


def _log():
    t = np.arange(N) * 0.01
    R = Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])).as_matrix()
    return t, R


def _sarras():
    t, R = _log()
    SarrasEstimator(np.eye(3), gains=ObserverGains.constant(1.0, 10.0, n=3)).run(t, R)


def _supervised():
    t, R = _log()
    SupervisedKalmanEstimator(np.eye(3), rate_hz=100.0, measurement_noise=1e-3, rate_noise=0.1).run(t, R)


def _single_direction():
    t, R = _log()
    b = np.einsum("tji,j->ti", R, [0.0, 0.0, 1.0])  # the direction in body axes
    SingleDirectionEstimator(np.diag([3.0, 2.0, 1.0]), reference=[0.0, 0.0, 1.0]).run(t, b)


@pytest.mark.parametrize(
    "module, name, run",
    [
        (sampled, "run", _sarras),
        (supervised, "run", _supervised),
        (single_direction_step, "_advance", _single_direction),
    ],
    ids=["sampled.run", "supervised.run", "single_direction_step._advance"],
)
def test_the_loop_over_a_log_lets_other_threads_run(monkeypatch, module, name, run):
    kernel = getattr(module, name)
    captured: list[tuple] = []

    def capture(*args):
        captured.append(tuple(_copy(a) for a in args))  # the arguments as the call found them (it updates some)
        return kernel(*args)

    monkeypatch.setattr(module, name, capture)
    run()  # the estimator's own call (and the kernel loaded or compiled before the timing)
    monkeypatch.undo()
    args = max(captured, key=lambda a: sum(x.size for x in a if isinstance(x, np.ndarray)))
    kernel(*(_copy(a) for a in args))  # once here: a signature the copies' types need is compiled now, not below
    args = tuple(_copy(a) for a in args)

    started = threading.Event()
    span = [0.0, 0.0]  # the loop's start and end (perf_counter)

    def loop():
        started.set()
        span[0] = time.perf_counter()
        kernel(*args)
        span[1] = time.perf_counter()

    worker = threading.Thread(target=loop)
    worker.start()
    started.wait()
    time.sleep(0.01)  # the worker enters the loop meanwhile (a few microseconds)
    here = time.perf_counter()  # Python after the sleep: only with the GIL, so before the loop's end if it is free
    worker.join()
    assert span[1] - span[0] > 0.05, "the loop was too short to tell"
    assert here < span[1] - 0.02, f"{module.__name__}.{name} held the GIL for its whole {span[1] - span[0]:.2f} s loop"
