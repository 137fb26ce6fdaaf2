"""Shared test settings and fixtures.

Hypothesis' per-example deadline is off: the first example of a test may include the one-time compilation of a
Numba kernel (hundreds of milliseconds), which says nothing about the code's correctness.
"""

import contextlib

import pytest
from hypothesis import settings

settings.register_profile("omegahat", deadline=None)
settings.load_profile("omegahat")


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
