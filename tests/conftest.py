"""Shared test settings.

Hypothesis' per-example deadline is off: the first example of a test may include the one-time compilation of a
Numba kernel (hundreds of milliseconds), which says nothing about the code's correctness.
"""

from hypothesis import settings

settings.register_profile("omegahat", deadline=None)
settings.load_profile("omegahat")
