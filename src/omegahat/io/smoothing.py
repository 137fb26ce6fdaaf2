"""``omegahat estimate --preset mocap --smooth``: the whole log at once, written chunk by chunk.

The smoother (:func:`omegahat.observer.presets.smooth`: forward and backward passes averaged, zero lag) needs every
sample before it can give the first estimate, so this path reads the stream to its end, checks every chunk as the
causal path does (bad samples named by line and column, or missing with ``--skip-bad-samples``), smooths, and
writes each chunk's rows with the causal path's statuses: ``corrected`` where the sample was used, ``predicted``
where it is missing (bridged by both passes), ``unavailable`` where there is no estimate.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from omegahat.io.output import CORRECTED, PREDICTED, UNAVAILABLE
from omegahat.io.registry import LogChunk
from omegahat.observer.presets import smooth

__all__ = ["SmoothedLog", "write_smoothed"]


@dataclass(frozen=True)
class SmoothedLog:
    """What :func:`write_smoothed` did: rows written, samples missing, seconds spent smoothing."""

    rows: int
    n_missing: int
    elapsed: float


def write_smoothed(
    chunks: list[LogChunk],
    check: Callable[[LogChunk], None],
    write: Callable[[LogChunk, np.ndarray, np.ndarray], None],
    rate_hz: float,
    noise_std: float,
    rotation_tol: float,
    quat_norm_tol: float,
) -> SmoothedLog:
    """Check every chunk (``check`` raises on a bad sample or marks it missing), smooth the whole log, and
    ``write(chunk, omega, status)`` chunk by chunk. ``chunks`` is emptied (its memory released) on the way."""
    for chunk in chunks:
        check(chunk)
    t = np.concatenate([c.t for c in chunks])
    data = np.concatenate([c.data for c in chunks])
    t0 = time.perf_counter()
    W = smooth(t, data, rate_hz=rate_hz, noise_std=noise_std, rotation_tol=rotation_tol, quat_norm_tol=quat_norm_tol)
    elapsed = time.perf_counter() - t0
    valid = np.all(np.isfinite(data.reshape(t.size, -1)), axis=1)
    status = np.where(valid, CORRECTED, PREDICTED).astype(np.int8)
    status[~np.all(np.isfinite(W), axis=1)] = UNAVAILABLE
    start = 0
    while chunks:
        chunk = chunks.pop(0)
        stop = start + len(chunk)
        write(chunk, W[start:stop], status[start:stop])
        start = stop
    return SmoothedLog(int(t.size), int(np.count_nonzero(~valid)), elapsed)
