r"""The estimator of ``omegahat estimate`` and :func:`omegahat.estimate_frame` for a log of ONE direction ``b1x..b1z``.

:func:`single_direction_choice` is the picker the loop (:func:`omegahat.io.pipeline.estimate_stream`) calls for such
a stream: the two-direction machinery (Wahba fits, the EKF, the gain selection from the attitude noise) needs a full
attitude, which one direction does not give. It picks
:class:`omegahat.observer.single_direction.SingleDirectionEstimator` (the Sarras-type observer with one direction,
``docs/theory/single_direction.md``) and says plainly what it cannot do: the rate about the measured direction is
observable only while that direction moves in the body (the body tumbles), the model needs the inertia (without it
J = I, a locally constant rate), and spans without excitation are reported with the unobservable axis.

The start is ω̂ = 0 (``start`` does not apply): there is no estimate at the first valid sample (one direction at
one instant gives no rate), as with ``start="zero"`` for attitudes.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from omegahat.interface import Estimate
from omegahat.io.choice import inertia
from omegahat.io.registry import LogChunk, LogStream
from omegahat.io.settings import Choice, EstimateSettings, Spelling, naming
from omegahat.observer.gains import ObserverGains
from omegahat.observer.single_direction import SingleDirectionEstimator
from omegahat.validation import as_vector3

__all__ = ["single_direction_choice"]


def _reference(settings: EstimateSettings, stream: LogStream, spell: Spelling) -> np.ndarray:
    refs = settings.references
    name = spell("references", None)
    if refs is None:
        how = spell("references", "X,Y,Z")
        raise naming(
            ValueError(f"{stream.source} holds 1 body-frame direction (b1): give its inertial direction with {how}"),
            ("references", None),
        )
    refs = np.asarray(refs, dtype=float)
    refs = refs[None] if refs.ndim == 1 else refs
    if refs.ndim != 2 or refs.shape[0] != 1:
        raise ValueError(f"{stream.source} holds 1 direction but {name} gives {len(refs)}")
    v = as_vector3(refs[0], name)
    if not np.linalg.norm(v) > 0:
        raise ValueError(f"{name} must be a non-zero vector; got {v.tolist()}")
    return v


def single_direction_choice(
    stream: LogStream, settings: EstimateSettings, report: Callable[[str], None], spell: Spelling
) -> Choice:
    """The one-direction observer for ``stream`` (module docstring), its gains from ``settings`` (``gains`` with
    one k and one l, or ``bandwidth_hz``; default :func:`omegahat.observer.single_direction.default_gains`)."""
    v = _reference(settings, stream, spell)
    J = inertia(settings, spell)
    report(
        "warning: one measured direction: the rate about it is not observable at an instant; it is estimated only "
        "while the direction moves in the body (the body tumbles, its rate not parallel to the direction), through "
        "Euler's equations with the inertia"
        + (
            ""
            if settings.inertia is not None
            else f" (none given: J = I, a constant rate; pass {spell('inertia', None)})"
        )
    )
    if settings.estimator == "omegahat" or settings.start != "fit":
        report(
            "note: with one direction the estimator is the single-direction observer, started from rest "
            f"({spell('estimator', None)} and {spell('start', None)} do not apply)"
        )
    kw: dict = {}
    if settings.gains is not None:
        if settings.gains.n != 1:
            raise ValueError(f"one direction takes one gain k and one l; got {settings.gains.n}")
        kw = {"k": float(settings.gains.k[0]), "l": float(settings.gains.l_offset[0])}
    elif settings.bandwidth_hz is not None:
        kw = {"bandwidth_hz": float(settings.bandwidth_hz)}
    est = SingleDirectionEstimator(J, reference=v, **kw)
    text = (
        f"estimator: single-direction observer (Sarras-type, docs/theory/single_direction.md), k = {est.k:.4g}, "
        f"l = {est.l:.4g}, start from rest; excitation monitored over {est.window_s:g} s windows"
    )
    report(text)
    monitor = _Excitation(est, stream)
    return Choice(
        est,
        ObserverGains.constant(est.k, est.l, n=1),
        text,
        lambda: f"gains used: k = {est.k:.4g}, l = {est.l:.4g}, J diag = {np.diag(J).tolist()}, start: zero",
        after_chunk=monitor.after_chunk,
        closing=monitor.closing,
    )


class _Excitation:
    """The spans without excitation, gathered chunk by chunk and reported once."""

    def __init__(self, est: SingleDirectionEstimator, stream: LogStream) -> None:
        self.est, self.stream = est, stream
        self.count, self.rows = 0, 0
        self.first: int | None = None
        self.axis: np.ndarray | None = None

    def after_chunk(self, chunk: LogChunk, estimate: Estimate) -> None:
        un = self.est.unobservable
        self.rows += len(chunk)
        if un.size == len(chunk) and un.any():
            if self.first is None:
                j = int(np.flatnonzero(un)[0])
                self.first, self.axis = int(chunk.labels[j]), self.est.weak_axis[j]
            self.count += int(un.sum())

    def closing(self) -> list[str]:
        if not self.count:
            return [f"excitation: the direction moved enough in every {self.est.window_s:g} s window (no span flagged)"]
        return [
            f"warning: no excitation on {self.count} of {self.rows} samples (first at {self.stream.label} "
            f"{self.first}): the direction stayed nearly fixed in the body, so the rate about the body axis "
            f"{np.array2string(np.asarray(self.axis), precision=3)} is not observable there (a spin about the "
            "measured direction); the estimate of that component is not corrected by the data"
        ]
