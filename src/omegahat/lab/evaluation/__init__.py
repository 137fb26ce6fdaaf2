"""Measuring estimators: the metrics (one definition each), the comparison method of ``omegahat compare``, and the
BROAD real recordings with their in-band score."""

from omegahat.lab.evaluation.metrics import convergence_time, estimate_errors, first_below, steady_rms

__all__ = ["convergence_time", "estimate_errors", "first_below", "steady_rms"]
