r"""The estimator of ``omegahat estimate`` for a stream of attitudes or of two directions and more, from its head.

:func:`attitude_choice` is the picker the loop (:func:`omegahat.io.pipeline.estimate_stream`) calls for such a
stream (a stream of one direction has its own, :func:`omegahat.io.single_direction.single_direction_choice`). From
the head of the stream (its first :data:`omegahat.observer.autogain.HEAD_SAMPLES` rows, exactly: the same rows
whatever the reader's chunk size, so that the same data get the same gains in every format) it:

1. measures the sample rate, the attitude noise and the motion (:func:`omegahat.observer.autogain.measure_motion`),
   and warns when the sample spacing is implausible for the time unit (:func:`time_unit_warning`; refuses it
   beyond any sensor's rates);
2. chooses the gains (:func:`omegahat.observer.autogain.select_gains`: automatic unless gains or a bandwidth are
   given); with J and τ given, warns when Euler's equations fit the other rotation convention markedly better;
3. starts: ``fit`` (a least-squares rate over the first window: the fixed-gain observer's (D), or the identified
   filter's (W)), ``warm`` (from the first two samples) or ``zero``;
4. builds the estimator: by default what :func:`omegahat.identification.identify` chooses on the head (the
   identified model's supervised filter or backward differencing; for ``smooth`` of attitudes the model's two-filter
   smoother or the log's own Wiener smoother, whichever expects less, and the Wiener smoother where the model is
   declined; of directions the model's smoother); the fixed-gain observer when gains, a bandwidth or
   ``estimator="sarras"`` are given (or fewer than ``MIN_SAMPLES`` valid samples); or the ``mocap`` preset's (causal,
   or its zero-lag smoother: a batch estimator).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.baselines.spline import SplineEstimator
from omegahat.identification import MIN_SAMPLES, Identification, identify
from omegahat.identification.fold import fold_remark
from omegahat.identification.smoother import ChosenSmoother, ModelSmoother
from omegahat.identification.spectral import SpectralSmoother
from omegahat.identification.start import balanced_start, noise_window
from omegahat.interface import Estimator
from omegahat.io.columns import LogFormatError
from omegahat.io.registry import ROTATIONS, LogChunk, LogStream
from omegahat.io.settings import Choice, EstimateSettings, Spelling, naming
from omegahat.io.time_units import implausible_spacing
from omegahat.observer import autogain
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.gains import ObserverGains
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.presets import (
    MOCAP_SWITCH_HZ,
    MOCAP_TUNED_NOISE,
    MocapSmoother,
    log_differencing_error,
    mocap_estimator,
    mocap_model,
)
from omegahat.validation import as_directions, as_inertia

WAHBA = "each sample's least-squares attitude from its directions (Wahba's problem)"
#: the closing line on the Wiener smoother's reading (S8) of timestamps whose steps are uneven
JITTER = {
    "stamps": "; the timestamps' steps are uneven, but the increments follow the mean step: read as regular samples "
    "with jittered stamps",
    "sampling": "; the timestamps' steps are uneven and the increments follow them: read as samples taken at their "
    "stamps",
}
IDENTIFY_SAMPLES = 8192  #: rows of the head the identification fits (the noise bound needs a few seconds of log)

__all__ = ["attitude_choice", "inertia", "references", "time_unit_warning"]


def inertia(settings: EstimateSettings, spell: Spelling) -> np.ndarray:
    """The settings' inertia (default identity: a locally constant rate), checked."""
    if settings.inertia is None:
        return np.eye(3)
    return as_inertia(np.asarray(settings.inertia, dtype=float), name=spell("inertia", None))


def references(settings: EstimateSettings, stream: LogStream, spell: Spelling) -> np.ndarray:
    """The inertial directions of a direction stream (required, one per direction) or of the attitude's rows
    (default the three rows of R)."""
    refs = settings.references
    if stream.kind == "directions":
        n = stream.n_directions
        if refs is None:
            raise naming(
                ValueError(
                    f"{stream.source} holds {n} body-frame directions (b1..b{n}): give their inertial directions "
                    f"with {spell('references', 'X,Y,Z;X,Y,Z')} (one per direction, quoted)"
                ),
                ("references", None),
            )
        if len(refs) != n:
            raise ValueError(f"{stream.source} holds {n} directions but {spell('references', None)} gives {len(refs)}")
    if refs is None:
        return np.eye(3)
    return as_directions(np.array(refs, dtype=float), name=spell("references", None))


def time_unit_warning(h: float, t0: float, unit: str, spell: Spelling) -> str | None:
    """A warning when samples ``h`` s apart (first time ``t0``) are implausible in ``unit``, suggesting the unit
    that would make them plausible (:func:`omegahat.io.time_units.implausible_spacing`, which refuses beyond any
    sensor's rates)."""
    said = implausible_spacing(
        h, t0, unit, f"with {spell('time_unit', unit)}", lambda u: f"pass {spell('time_unit', u)}"
    )
    return None if said is None else f"warning: {said}"


def _head_arrays(head: list[LogChunk], stream: LogStream):
    """The first HEAD_SAMPLES rows of the head: times, data, torques (or None)."""
    n = autogain.HEAD_SAMPLES
    t = np.concatenate([c.t for c in head])[:n]
    data = np.concatenate([c.data for c in head])[:n]
    tau = np.concatenate([c.torque for c in head])[:n] if stream.has_torque else None
    return t, data, tau


def attitude_choice(
    stream: LogStream,
    settings: EstimateSettings,
    head: list[LogChunk],
    report: Callable[[str], None],
    spell: Spelling,
    head_done: int = 0,
) -> Choice:
    """The estimator for an attitude or multi-direction ``stream`` from its checked ``head`` (module docstring);
    ``head_done``: the stream's progress (``stream.done``: bytes of a text file) when the head had been read, from
    which the whole log's length is extrapolated when the stream does not know its rows in advance."""
    J, refs = inertia(settings, spell), references(settings, stream, spell)
    if stream.has_torque and settings.inertia is None:
        report(f"note: the torques are not used without {spell('inertia', None)}: Euler's equations need J")
    t_h, data_h, tau_h = _head_arrays(head, stream)
    n_head = t_h.size
    ok = np.all(np.isfinite(data_h.reshape(n_head, -1)), axis=1)
    if ok.sum() < 3:
        raise LogFormatError(
            f"{stream.source}: only {int(ok.sum())} usable samples in the first {n_head}; at least 3 "
            "are needed to estimate a rate"
        )
    tv, rot = autogain.log_rotations(t_h, data_h, stream.kind, refs)
    motion = autogain.measure_motion(tv, rot, J, None if tau_h is None else tau_h[ok])
    rows_read = sum(len(c) for c in head)
    if rows_read < autogain.HEAD_SAMPLES or stream.n_rows_hint == rows_read:  # the head is the whole log
        duration = float(head[-1].t[-1] - t_h[0])
    else:  # the whole log's duration, extrapolated from the head by its rows (or, for text, its bytes)
        total = stream.n_rows_hint or (stream.size / max(head_done, 1) * rows_read)
        duration = float(t_h[-1] - t_h[0]) * total / n_head
    options = stream.options
    unit = options.time_unit if options is not None else "s"
    # the rows' spacing, not the attitudes': a table whose rows are 10 ms apart with an attitude every 3 s (other
    # sensors' rows between) is in seconds, and ms would be wrong advice
    rows_h = float(np.median(np.diff(t_h))) if n_head > 1 else motion.h
    warning = time_unit_warning(rows_h if rows_h > 0 else motion.h, float(stream.t0 + t_h[0]), unit, spell)
    if warning:
        report(warning)
    fixed_gains = settings.estimator == "sarras" or settings.gains is not None or settings.bandwidth_hz is not None

    @functools.cache
    def observer_gains() -> tuple[ObserverGains, str, float]:
        """The fixed-gain observer's gains, their line and bandwidth (rad/s): chosen only on the paths that run
        that observer or its fit window (the fixed gains, the preset, a head too short to identify a model)."""
        return autogain.select_gains(
            motion, duration, settings.start, refs, gains=settings.gains, bandwidth_hz=settings.bandwidth_hz,
            flag=spell("bandwidth_hz", None),
        )  # fmt: skip

    if settings.preset is None:
        if fixed_gains:  # the identified path says its own choice
            report(observer_gains()[1])
    elif stream.has_torque:
        raise ValueError(
            f"{spell('preset', settings.preset)} is for bodies whose torque is unknown, but the log has torque "
            f"columns; to use them, drop the preset and give {spell('inertia', None)}"
        )
    elif settings.smooth and stream.kind == "directions":
        raise ValueError(
            f"{spell('smooth', True)} with {spell('preset', settings.preset)} takes attitudes (quaternions "
            "or rotation matrices); without the preset it takes directions too"
        )
    rotation = options.rotation if options is not None else ROTATIONS[0]
    if settings.inertia is not None and stream.has_torque and stream.kind != "directions":
        given, other = autogain.convention_check(motion)
        if other < 0.5 * given:
            flip = ROTATIONS[1 - ROTATIONS.index(rotation)]
            report(
                f"warning: Euler's equations with this J and torque fit the data {given / other:.1f}x better with "
                f"the attitude inverted (residual {other:.3g} against {given:.3g} N m): is the log {flip}? "
                f"(pass {spell('rotation', flip)})"
            )

    def fit_start(window: float | None = None) -> np.ndarray | None:
        """The ``fit`` start's rate, (F) over ``window`` seconds of the head (default: the fixed-gain observer's
        window (D)); None for the other starts (no estimate at the first valid sample)."""
        if settings.start != "fit":
            return None
        window = autogain.fit_window(observer_gains()[2], motion.rate_hz) if window is None else window
        return autogain.initial_rate(tv, rot, window, J, motion.torque)

    def identified_start(ident: Identification) -> tuple[np.ndarray, float] | None:
        """The identified filter's ``fit`` start and its expected error: (W) capped by the motion ((W') of
        :mod:`omegahat.identification.start`); None for the other starts."""
        if settings.start != "fit":
            return None
        sigma, e = ident.chosen.sigma, ident.expected_rms  # σ at least the floor (Candidate)
        window = noise_window(e, sigma, 1.0 / ident.rate_hz)
        rate, _, error = balanced_start(tv, rot, window, sigma, e, J, motion.torque)
        return rate, error

    est, described = _estimator(
        settings, motion, J, observer_gains, refs, stream, report, spell, (t_h, data_h, tau_h), fit_start,
        identified_start,
    )  # fmt: skip
    gains, text = observer_gains()[:2] if isinstance(described, SarrasEstimator) else (None, "")  # what it ran with
    return Choice(est, gains, text, _used(described, J, settings.inertia is not None, settings.start), spacing=motion.h)


def _estimator(
    settings, motion, J, observer_gains, refs, stream, report, spell, head, fit_start, identified_start
) -> tuple[Estimator, Estimator]:
    """The estimator, and the one the closing line describes (for the model's smoother: its causal filter): the
    preset's; the fixed-gain observer with ``observer_gains()[0]`` (asked for, or fewer than ``MIN_SAMPLES`` valid
    samples); else what the identification of the head chose (the model's supervised filter or backward
    differencing; for ``smooth`` its smoother, the log's own Wiener smoother, or the two with the choice between
    them). ``fit_start(window)``: the start's rate, ``identified_start(ident)`` the identified filter's and its
    expected error (None unless the start is ``fit``)."""
    common = {
        "references": refs,
        "measurement": "directions" if stream.kind == "directions" else "attitude",
        "warm_start": settings.start == "warm",
        "rotation_tol": settings.rotation_tol,
        "quat_norm_tol": settings.quat_norm_tol,
    }
    tols = {"rotation_tol": settings.rotation_tol, "quat_norm_tol": settings.quat_norm_tol}
    if settings.preset is not None:
        how = "forward and backward passes averaged (zero lag)" if settings.smooth else "causal"
        described = mocap_model(motion.rate_hz, motion.sigma).describe()
        report(f"estimator: {spell('preset', settings.preset)} ({how}): {described}")
        if motion.rate_hz >= MOCAP_SWITCH_HZ and motion.sigma > MOCAP_TUNED_NOISE:
            report(
                f"warning: the log's attitude noise ({motion.sigma:.2g} rad) is above that of the recordings the "
                f"preset was tuned on (optical motion capture of a hand, up to {MOCAP_TUNED_NOISE:g} rad): on a "
                "slow or smooth motion, omegahat without the preset (gains chosen from this log) may be more accurate"
            )
        scale = log_differencing_error(motion.t, motion.rot, motion.sigma)  # the supervisor's motion scale (P5)
        causal = mocap_estimator(motion.rate_hz, motion.sigma, differencing_rms=scale, omega_hat0=fit_start(), **common)
        if not settings.smooth:
            return causal, causal
        return MocapSmoother(rate_hz=motion.rate_hz, measurement_noise=motion.sigma, **tols), causal
    choice = settings.estimator
    if choice == "auto" and (settings.gains is not None or settings.bandwidth_hz is not None):
        choice = "sarras"  # gains or a bandwidth given: the fixed-gain observer they describe
    valid = int(np.count_nonzero(np.all(np.isfinite(head[1].reshape(head[1].shape[0], -1)), axis=1)))
    directions = {"references": refs} if stream.kind == "directions" else {}
    if choice == "auto" and valid < MIN_SAMPLES and settings.smooth:
        report(
            f"only {valid} valid samples: too few to identify a model or the log's spectrum (at least "
            f"{MIN_SAMPLES}); estimator: the rotation spline through "
            + (WAHBA if directions else "the attitudes")
            + " (zero lag; it interpolates, so the attitude noise passes to the rate)"
        )
        spline = SplineEstimator(**directions, **tols)
        return spline, spline
    if choice == "auto" and valid < MIN_SAMPLES:
        report(
            f"only {valid} valid samples: too few to identify a model (at least {MIN_SAMPLES}); the fixed-gain "
            "observer runs with the gains below"
        )
        choice = "sarras"
    if choice == "sarras":
        sarras = SarrasEstimator(J, gains=observer_gains()[0], omega_hat0=fit_start(), **common)
        return sarras, sarras
    ident = _identified(settings, stream, refs, head)
    report(ident.explain())
    # the fit start over the identified filter's own window (W) as far as the motion allows (W'), and its error the
    # EKF's prior
    start = identified_start(ident)
    common["omega_hat0"] = None if start is None else start[0]
    if start is not None:
        common["omega_hat0_noise"] = math.sqrt(2.0) * start[1]
    est = ident.estimator(**common) if choice == "auto" else ident.model_estimator(**common)
    if settings.smooth and choice == "omegahat":  # the model asked for: its smoother, whatever the identification says
        report(
            "estimator: the identified model's two-filter smoother (forward and backward passes; zero lag; "
            f"{spell('estimator', 'omegahat')} asks for the model)"
        )
        smoother = ModelSmoother(ident, **directions, **tols)
        return smoother, smoother
    if settings.smooth and not ident.use_model:
        # the model was declined (it does not describe the log, or predicts no gain): no model to smooth with; the
        # log's own spectrum and noise give the zero-lag Wiener estimate (omegahat.identification.spectral)
        report(
            "estimator: the log's own Wiener smoother (its increments' spectrum and noise; zero lag; no model to "
            "smooth with: see above)" + (f"; it filters {WAHBA}" if directions else "")
        )
        spectral = SpectralSmoother(**directions, **tols)
        return spectral, spectral
    if settings.smooth:
        report(
            "estimator: the identified model's two-filter smoother and the log's own Wiener smoother, the one "
            "expecting the lower error kept (zero lag)"
            + (f"; the Wiener smoother filters {WAHBA}" if directions else "")
        )
        chosen = ChosenSmoother(ident, **directions, **tols)
        return chosen, chosen
    return est, est


def _identified(settings: EstimateSettings, stream: LogStream, refs: np.ndarray, head) -> Identification:
    """:func:`omegahat.identification.identify` on the first :data:`IDENTIFY_SAMPLES` rows of the head."""
    t, data, tau = head
    n = min(t.size, IDENTIFY_SAMPLES)
    return identify(
        t[:n],
        data[:n],
        stream.kind,
        J=None if settings.inertia is None else np.asarray(settings.inertia, dtype=float),
        torque=None if tau is None else tau[:n],
        references=refs if stream.kind == "directions" else None,
    )


def _used(est: Estimator, J: np.ndarray, inertia_given: bool, start: str) -> Callable[[], str]:
    """The closing line saying what ran (after the run: the restarts counted)."""
    body = f"J diag = {np.diag(J).tolist()}" if inertia_given else "no inertia given (the observer's J = I)"

    def line() -> str:
        if isinstance(est, ChosenSmoother):
            kept = "the identified model's smoother" if est.chosen is est.model else "the log's own Wiener smoother"
            jitter = JITTER.get(est.spectrum.timestamps, "") if est.chosen is est.spectrum else ""
            model, spectrum = (
                f"{x:.2g} rad/s" if math.isfinite(x) else "not known"
                for x in (est.expected["model"], est.expected["spectrum"])
            )
            return (
                f"estimator used: {kept} (offline, zero lag; expected RMS error: the model's smoother "
                f"{model}, the Wiener smoother {spectrum}"
                f"{fold_remark(est.spectrum.expected_rms, est.spectrum.fold_rms)}{jitter}), {body}"
            )
        if isinstance(est, ModelSmoother):
            return (
                "estimator used: the identified model's smoother (offline, zero lag; expected RMS error "
                f"{est.expected_rms:.2g} rad/s (the model's account)), {body}"
            )
        if isinstance(est, SpectralSmoother):
            spline = (
                f"; {est.n_unfiltered} samples in stretches too short or too irregular to filter took the rotation "
                "spline through the attitudes"
                if est.n_unfiltered
                else ""
            )
            expected = (
                f"expected RMS error {est.expected_rms:.3g} rad/s by its spectrum's account"
                f"{fold_remark(est.expected_rms, est.fold_rms)}; "
                if math.isfinite(est.expected_rms)
                else ""
            )
            return (
                f"estimator used: the log's own Wiener smoother (offline, zero lag; {expected}attitude noise "
                f"{', '.join(f'{x:.2g}' for x in est.measurement_noise)} rad per body axis{spline}"
                f"{JITTER.get(est.timestamps, '')})"
            )
        if isinstance(est, SplineEstimator):
            return "estimator used: the rotation spline (offline, zero lag; too few samples for anything else)"
        if isinstance(est, DifferencingEstimator):
            through = "" if est.references is None else " of each sample's least-squares attitude"
            through += "" if est.taps is None else f" through the log's causal filter ({est.taps.shape[0]} taps, (C3))"
            why = "no model: see the identification above"
            return f"estimator used: backward differencing{through} ({why}), start: {start}"
        if isinstance(est, SupervisedKalmanEstimator):
            return (
                f"estimator used: omegahat (observer at {est.observer_rate:.4g} rad/s, EKF rate noise "
                f"{est.rate_noise:.3g} rad/s^1.5, {est.restarts} restarts), {body}, "
                f"start: {start}"
            )
        gains: ObserverGains = est.gains  # type: ignore[attr-defined]  # the fixed-gain observer
        k_text, l_text = (np.array2string(a, precision=4) for a in (gains.k, gains.l_offset))
        return f"gains used: k = {k_text}, l = {l_text}, {body}, start: {start}"

    return line
