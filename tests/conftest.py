"""Shared test settings and fixtures.

Hypothesis' per-example deadline is off: the first example of a test may include the one-time compilation of a
Numba kernel (hundreds of milliseconds), which says nothing about the code's correctness.
"""

import contextlib

import pytest
from hypothesis import settings

settings.register_profile("omegahat", deadline=None)
settings.load_profile("omegahat")

#: The files that take longest on a fresh clone, longest first (`benchmarks/first_run.py --suite`; measured with
#: ``--durations``): two compile engine sizes the wheel does not ship, the others run child processes or build the
#: docs. Run first, each worker starts on one of them while the other takes the next, so that the workers end
#: together instead of one compiling while the other waits (``--no-loadscope-reorder`` in ``pyproject.toml`` keeps
#: this order; the other files follow, most tests first, as pytest-xdist would order them).
SLOWEST_FILES = (
    "test_montecarlo.py",
    "test_simulate.py",
    "test_kernel_cache.py",
    "test_docs.py",
    "test_shipped_kernels.py",
    "test_control.py",
    "test_parquet_output.py",
)


def pytest_collection_modifyitems(items):
    """The slowest files first (:data:`SLOWEST_FILES`), then the rest by their number of tests, most first."""
    counts: dict[str, int] = {}
    for item in items:
        counts[item.path.name] = counts.get(item.path.name, 0) + 1

    def rank(item) -> tuple[int, int, str]:
        name = item.path.name
        first = SLOWEST_FILES.index(name) if name in SLOWEST_FILES else len(SLOWEST_FILES)
        return first, -counts[name], str(item.path)

    items.sort(key=rank)  # stable: a file's own tests keep their order


@pytest.fixture
def restart_warnings():
    """``restart_warnings(path)``: what a restart says besides its status — ``run`` warns once for the log (the
    compiled estimators' one ``RestartedWarning``), ``update`` says it by the status and ``n_restarts`` alone."""
    from omegahat.observer.compiled import RestartedWarning

    def expect(path: str):
        if path == "run":
            return pytest.warns(RestartedWarning, match=r"restarted 1 times in")
        return contextlib.nullcontext()

    return expect
