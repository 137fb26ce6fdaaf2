r"""``omegahat estimate`` (and :func:`omegahat.estimate_frame`) for a log of ONE body-frame direction ``b1x,b1y,b1z``.

:func:`omegahat.io.pipeline.estimate_stream` hands such a stream here: the two-direction machinery (Wahba fits,
the EKF, the gain selection from the attitude noise) needs a full attitude, which one direction does not give. This
runs :class:`omegahat.observer.single_direction.SingleDirectionEstimator` (the Sarras-type observer with one
direction, ``docs/theory/single_direction.md``) over the stream, chunk by chunk, and says plainly what it cannot
do: the rate about the measured direction is observable only while that direction moves in the body (the body
tumbles), the model needs the inertia (``--inertia``; without it J = I, a locally constant rate), and spans
without excitation are reported with the unobservable axis.

Rows: ``corrected`` where the sample was valid, ``predicted`` where it was missing (NaN: predicted along the
estimate), ``unavailable`` before the first valid sample. The start is ω̂ = 0 (``--start`` does not apply).
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Callable
from contextlib import AbstractContextManager
from typing import TYPE_CHECKING

import numpy as np

from omegahat.io.columns import LogFormatError
from omegahat.io.output import CORRECTED, PREDICTED, UNAVAILABLE
from omegahat.io.registry import LogStream
from omegahat.observer.gains import ObserverGains
from omegahat.observer.single_direction import LostExcitationWarning, SingleDirectionEstimator
from omegahat.validation import as_inertia, as_vector3

if TYPE_CHECKING:
    from omegahat.io.pipeline import ChunkWriter, EstimateSettings, RunSummary

__all__ = ["estimate_single_direction"]


def _reference(settings: EstimateSettings, stream: LogStream) -> np.ndarray:
    refs = settings.references
    if refs is None:
        how = '"--references=X,Y,Z" (quoted)' if settings.cli else "references=[(x, y, z)]"
        raise ValueError(f"{stream.source} holds 1 body-frame direction (b1): give its inertial direction with {how}")
    refs = np.asarray(refs, dtype=float)
    refs = refs[None] if refs.ndim == 1 else refs
    if refs.ndim != 2 or refs.shape[0] != 1:
        raise ValueError(f"{stream.source} holds 1 direction but {settings.name('references')} gives {len(refs)}")
    v = as_vector3(refs[0], settings.name("references"))
    if not np.linalg.norm(v) > 0:
        raise ValueError(f"{settings.name('references')} must be a non-zero vector; got {v.tolist()}")
    return v


def estimate_single_direction(
    stream: LogStream,
    settings: EstimateSettings,
    open_writer: Callable[[LogStream], AbstractContextManager[ChunkWriter]],
    summary: RunSummary,
    report: Callable[[str], None] = print,
    progress: Callable[[int], None] | None = None,
) -> RunSummary:
    """Estimate and write every sample of a one-direction ``stream`` (module docstring); fills ``summary``."""
    n_notes = len(stream.notes)  # printed already; later ones (the timestamp policy's) go to the summary
    v = _reference(settings, stream)
    J = (
        np.eye(3)
        if settings.inertia is None
        else as_inertia(np.asarray(settings.inertia, dtype=float), name=settings.name("inertia"))
    )
    report(
        "warning: one measured direction: the rate about it is not observable at an instant; it is estimated only "
        "while the direction moves in the body (the body tumbles, its rate not parallel to the direction), through "
        "Euler's equations with the inertia"
        + (
            ""
            if settings.inertia is not None
            else f" (none given: J = I, a constant rate; pass {settings.name('inertia')})"
        )
    )
    if settings.estimator == "omegahat" or settings.start != "fit":
        report(
            "note: with one direction the estimator is the single-direction observer, started from rest "
            f"({settings.name('estimator')} and {settings.name('start')} do not apply)"
        )
    kw: dict = {}
    if settings.gains is not None:
        if settings.gains.n != 1:
            raise ValueError(f"one direction takes one gain k and one l; got {settings.gains.n}")
        kw = {"k": float(settings.gains.k[0]), "l": float(settings.gains.l_offset[0])}
    elif settings.bandwidth_hz is not None:
        kw = {"bandwidth": 2 * math.pi * float(settings.bandwidth_hz)}
    est = SingleDirectionEstimator(J, v, **kw)
    summary.gains = ObserverGains.constant(est.k, est.l, n=1)
    summary.gains_text = (
        f"estimator: single-direction observer (Sarras-type, docs/theory/single_direction.md), k = {est.k:.4g}, "
        f"l = {est.l:.4g}, start from rest; excitation monitored over {est.window_s:g} s windows"
    )
    report(summary.gains_text)
    valid_seen = False
    n_unobs, first_unobs, axis = 0, None, None
    with open_writer(stream) as writer:
        for chunk in stream.chunks():
            b = np.asarray(chunk.data, dtype=float).reshape(len(chunk), 3).copy()
            zero = np.flatnonzero(np.all(np.isfinite(b), axis=1) & (np.linalg.norm(b, axis=1) == 0))
            if zero.size:
                if not settings.skip_bad_samples:
                    where = stream.where(int(chunk.labels[zero[0]]), stream.attitude_name)
                    raise LogFormatError(
                        f"{where}: measured direction b1 has zero length ({settings.opt('skip_bad_samples')} skips "
                        "such samples)"
                    )
                b[zero] = np.nan
            ok = np.all(np.isfinite(b), axis=1)
            t0 = time.perf_counter()
            if not valid_seen and not ok.any():
                W = np.full((len(chunk), 3), np.nan)
            else:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", LostExcitationWarning)  # summarised once, below
                    W = est.run(chunk.t, b, chunk.torque)
                un = est.unobservable
                if un.any():
                    if first_unobs is None:
                        j = int(np.flatnonzero(un)[0])
                        first_unobs, axis = (int(chunk.labels[j]), est.weak_axis[j])
                    n_unobs += int(un.sum())
            summary.elapsed += time.perf_counter() - t0
            status = np.where(ok, CORRECTED, PREDICTED).astype(np.int8)
            if not valid_seen:
                first = int(np.flatnonzero(ok)[0]) if ok.any() else len(chunk)
                status[:first] = UNAVAILABLE
                valid_seen = ok.any()
            W[status == UNAVAILABLE] = np.nan
            summary.n_missing += int((~ok).sum())
            writer.write(chunk, W, status)
            summary.rows += len(chunk)
            if progress is not None:
                progress(summary.rows)
    describe = getattr(writer, "describe", None)
    summary.output = describe() if describe is not None else f"{summary.rows} estimates"
    lines = [f"note: {note}" for note in stream.notes[n_notes:]]
    if summary.n_missing:
        lines.append(f"skipped {summary.n_missing} of {summary.rows} samples (missing): predicted through")
    if n_unobs:
        lines.append(
            f"warning: no excitation on {n_unobs} of {summary.rows} samples (first at {stream.label} {first_unobs}): "
            f"the direction stayed nearly fixed in the body, so the rate about the body axis "
            f"{np.array2string(np.asarray(axis), precision=3)} is not observable there (a spin about the measured "
            "direction); the estimate of that component is not corrected by the data"
        )
    else:
        lines.append(f"excitation: the direction moved enough in every {est.window_s:g} s window (no span flagged)")
    lines.append(f"gains used: k = {est.k:.4g}, l = {est.l:.4g}, J diag = {np.diag(J).tolist()}, start: zero")
    summary.lines = lines
    return summary
