r"""The model and the noises of a log, chosen by the log's own likelihood: what every default of omegahat runs.

:func:`identify` takes the head of a log (times, attitudes or directions; J and τ when known) and returns an
:class:`Identification`: for each candidate model of :mod:`omegahat.identification.likelihood` its tracking index
``Λ`` and measurement noise ``σ`` of maximum likelihood, the model chosen, the expected RMS errors of the estimate
and of backward differencing, and the estimator to run (:meth:`Identification.estimator`).

1. **Noise bound.** ``σ_q`` of :mod:`omegahat.identification.noise` (the quietest tenth of the log), after the
   isolated spikes and the resets of :mod:`~omegahat.identification.spikes` are left out (of every step).
2. **Each model** (``rate`` and ``acceleration``; with J also ``dynamic`` and ``dynamic+disturbance``): ``Λ``
   maximising ``ℓ(Λ, σ)`` of (L3) with ``σ = min(σ̂(Λ), σ_q)`` — the likelihood's own noise, but never above what
   the quiet parts of the log show (see the noise module: a stationary model would otherwise take a bursty motion
   for noise). The search: ``Λ`` on a grid of decades from ``10⁻⁸`` (a constant rate) to ``10⁴``, then a
   golden-section refinement around the best (in ``log Λ``). With J and a torque, the dynamic models are fitted
   with the torque held over each step and interpolated between samples, and the likelier is kept (H1).
3. **Model order** by the Bayesian information criterion ``BIC = −2ℓ + k log d`` (``k`` = 2 parameters, ``Λ`` and
   ``σ``, for every model; ``d`` the innovations' degrees of freedom): the least BIC wins, and the summary prints
   every model's ``ℓ``, ``σ`` and noise. A ``Λ`` at the top of the grid is the model's fast limit: the data show no
   noise the model can tell from motion (then the rate model's filter is a differentiator of the attitude).
4. **Expected RMS errors** (full band, at the sample times), from the identified model: the estimate's is the
   steady-state Kalman filter's ``√(tr P_ωω)`` for the model's per-axis linear dynamics at the median spacing (the
   discrete algebraic Riccati equation, ``scipy.linalg.solve_discrete_are``), for Euler's equations (which couple
   the axes) the EKF's own over the head's second half; backward differencing's is its noise
   ``√6 σ / h`` with the motion's share over half a sample, ``√(max(0, E|Δū|² − 18 σ²/h²)) / 2`` (``ū_k`` the
   rates differenced over one spacing, not across gaps, ``Δ`` between consecutive ones; (D1),
   :func:`omegahat.observer.tuning.differencing_error`).
5. **The estimator.** The chosen model's filter (the observer supervising its gyro-less EKF) runs when the log
   supports it; otherwise backward differencing (the rate model's fast limit), through the log's own causal filter
   ((C1)–(C3) of :mod:`omegahat.identification.causal`: no more error than differencing's in any band). The model
   runs unless (a) its innovations at the identified noise are more than :data:`MISFIT_MAX` times what that noise
   explains (``σ̂/σ``: the filter lost track of the log), (b) its ``Λ`` is the grid's top (no measurement noise the
   log can tell from motion), (c) its own expected error (4) is not below :data:`GAIN_REQUIRED` times
   differencing's, or (d), for a kinematic model of attitudes, the log's spectrum expects otherwise: read with
   the model's own noise, under one of the readings (C4) of :mod:`omegahat.identification.causal` (noise and fold,
   which the samples cannot separate from the motion), the model's steady-state filter (K1) has more error (K2)
   than differencing. The model's own account (4) assumes its motion model, a random walk of the rate or of the
   acceleration; the spectrum's takes the motion the log shows, and where they disagree the motion is not the
   model's. Without J the acceleration model is fitted
   and reported but not run (on the development recordings it lost to differencing whenever it won the likelihood,
   ``docs/theory/identification.md``). Direction logs are differenced through each sample's least-squares
   attitude. Without J the supervisor's innovation test is off and its divergence test loose
   (:data:`~omegahat.observer.kalman.DIVERGENCE_FACTOR`, the rotation's Nyquist bound): a hand's are never white.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines.differencing import DifferencingEstimator, sample_clock
from omegahat.identification import likelihood, steps
from omegahat.identification.causal import CausalFilter, causal_filter, model_to_differencing
from omegahat.identification.likelihood import MODELS, ORDER, Sums, innovation_sums, log_likelihood, noise_intensity
from omegahat.identification.noise import quiet_noise, rigid_directions
from omegahat.identification.spectral import increment_spectrum
from omegahat.identification.spikes import describe_spikes, isolated_spikes, stitched
from omegahat.observer.kalman import DIVERGENCE_FACTOR, NYQUIST_RATE, SupervisedKalmanEstimator
from omegahat.observer.tuning import differencing_error
from omegahat.validation import as_directions, as_inertia

__all__ = ["MIN_SAMPLES", "Candidate", "Identification", "identify"]

KINEMATIC = ("rate", "acceleration")  #: the candidates when J is not given
LAMBDA_MAX = likelihood.GRID[-1]  #: the grid's top: the model's fast limit
SIGMA_FLOOR = 1e-9  #: rad: below any real sensor (float32 quaternions carry ~6e-8)
N_PARAMS = 2  #: Λ and σ, for every model
MIN_SAMPLES = 20  #: valid samples below which no model is identified (two parameters, a noise bound of windows)
MISFIT_MAX = 10.0  #: a model whose innovations exceed the identified noise's by more has lost track (step 5)
GAIN_REQUIRED = 0.9  #: the model runs only if it predicts at most this fraction of differencing's error (step 5)
_QUIET_RATE = 1e-6  # a second-order model's rate noise, relative: the acceleration state carries the motion
HOLDS = {"zero": "held", "linear": "interpolated"}  #: the torque between samples (step 2), in words
OTHER_HOLD = {"zero": "linear", "linear": "zero"}


@dataclass(frozen=True)
class Candidate:
    """One model at its maximum likelihood (module docstring, step 2): an entry of :class:`Identification`.

    Parameters
    ----------
    model : str
        The model's name, one of :data:`~omegahat.identification.likelihood.MODELS`.
    tracking_index : float
        Λ of (L2) at the maximum.
    sigma : float
        The measurement noise σ (rad): ``min(σ̂(Λ), σ_q)``, at least :data:`SIGMA_FLOOR`.
    log_likelihood : float
        ℓ of (L3) at ``(Λ, σ)``.
    bic : float
        ``−2ℓ + k log d``: the model with the least BIC is chosen.
    noise : float
        The process noise's PSD ``q`` of (L2).
    at_fast_limit : bool
        Whether Λ is the grid's top (:data:`LAMBDA_MAX`): no noise the model can tell from motion.
    misfit : float, optional
        σ̂ of (L3) over ``sigma``: how much larger the innovations are than the noise explains (default 1).
    torque_hold : {"zero", "linear"}, optional
        The torque between samples, held over each step or interpolated: the likelier where both were fitted (H1).
    other_hold : float, optional
        ℓ with the other hold, where both were fitted (else NaN).

    Examples
    --------
    The candidates fitted to a noisy constant-rate log (1 mrad, 100 Hz), and the one that wins:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat.identification import identify
    >>> t = np.arange(0.0, 3.0, 0.01)  # 100 Hz
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))  # 1 mrad
    >>> q = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_quat()  # rad/s, body axes
    >>> ident = identify(t, q, "quaternion")
    >>> for c in ident.candidates:
    ...     print(c.model, f"sigma {1e3 * c.sigma:.1f} mrad", c.at_fast_limit)
    rate sigma 0.9 mrad False
    acceleration sigma 0.9 mrad False
    >>> best = min(ident.candidates, key=lambda c: c.bic)
    >>> best.model, best is ident.chosen
    ('rate', True)
    """

    model: str
    tracking_index: float
    sigma: float
    log_likelihood: float
    bic: float
    noise: float
    at_fast_limit: bool
    misfit: float = 1.0  #: σ̂ of (L3) over ``sigma``: how much larger the innovations are than the noise explains
    torque_hold: str = "zero"  #: the torque between samples, held or interpolated (H1)
    other_hold: float = math.nan  #: ℓ with the other hold, where both were fitted

    def describe(self) -> str:
        if not math.isfinite(self.log_likelihood):  # every step of its filter failed (a torque it cannot follow)
            return f"{self.model}: its filter cannot follow the log (its steps fail: no likelihood, BIC inf)"
        unit = "rad/s^1.5" if ORDER[self.model] == 1 else "rad/s^2.5"
        limit = ", its fast limit" if self.at_fast_limit else ""
        hold = "" if math.isnan(self.other_hold) else (
            f", the torque {HOLDS[self.torque_hold]} between samples (log-likelihood {self.other_hold:.1f} "
            f"{HOLDS[OTHER_HOLD[self.torque_hold]]})"
        )  # fmt: skip
        return (
            f"{self.model}: log-likelihood {self.log_likelihood:.1f}, BIC {self.bic:.1f}, attitude noise "
            f"{self.sigma:.2g} rad, process noise {math.sqrt(self.noise):.3g} {unit} (tracking index "
            f"{self.tracking_index:.3g}{limit}){hold}"
        )


@dataclass(frozen=True)
class Identification:
    """What :func:`identify` found (module docstring): the model chosen, the expected errors, the estimator to run.

    Parameters
    ----------
    rate_hz : float
        The sample rate, ``1/h`` with ``h`` the median spacing of the valid samples (Hz).
    noise_bound : float
        ``σ_q`` of :mod:`omegahat.identification.noise` (rad; step 1), at least :data:`SIGMA_FLOOR`.
    chosen : Candidate
        The model of least BIC (step 3; without J among the models other than ``acceleration``).
    candidates : tuple of Candidate
        Every model fitted, in the order tried.
    expected_rms : float
        The chosen model's expected RMS rate error (rad/s; step 4).
    differencing_rms : float
        Backward differencing's expected RMS rate error (rad/s; step 4).
    J : numpy.ndarray
        The inertia ``(3, 3)`` (the identity when none was given).
    use_model : bool, optional
        Whether the model's filter runs (step 5), else backward differencing.
    reason : str, optional
        Why (step 5), in words.
    stamp_step : float or None, optional
        Where the steps are uneven but the samples regular and only their stamps jitter ((S8) of
        :mod:`omegahat.identification.spectral`), the samples' own step (s), which differencing takes ((D3) of
        :mod:`omegahat.baselines.differencing`); None otherwise.
    causal : CausalFilter or None, optional
        Where differencing runs (directions: on their least-squares attitudes), its causal filter (C3); else None.
    rigid : bool, optional
        Directions that are a rotation's, identified as their least-squares attitudes ((R0) of
        :func:`omegahat.identification.noise.rigid_directions`).
    spikes : tuple of (float, float), optional
        The isolated spikes left out (:mod:`omegahat.identification.spikes`): each one's time (s) and detour (rad).

    Examples
    --------
    A noisy constant-rate log (1 mrad, 100 Hz): the rate model is chosen and its filter predicts far less error
    than differencing, so it runs.

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat.identification import identify
    >>> t = np.arange(0.0, 3.0, 0.01)  # 100 Hz
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))  # 1 mrad
    >>> q = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_quat()  # rad/s, body axes
    >>> ident = identify(t, q, "quaternion")
    >>> print(f"{ident.rate_hz:.0f} Hz, noise at most {1e3 * ident.noise_bound:.1f} mrad")
    100 Hz, noise at most 0.9 mrad
    >>> print(f"expected {ident.expected_rms:.1e} rad/s, differencing {ident.differencing_rms:.2f} rad/s")
    expected 3.6e-04 rad/s, differencing 0.23 rad/s
    >>> ident.chosen.model, ident.use_model
    ('rate', True)
    >>> omega = ident.estimator().run(t, q).omega
    >>> print(" ".join(f"{x:.2f}" for x in omega[-1]))
    0.30 -0.20 0.50
    """

    rate_hz: float
    noise_bound: float
    chosen: Candidate
    candidates: tuple[Candidate, ...]
    expected_rms: float
    differencing_rms: float
    J: np.ndarray = field(repr=False)
    use_model: bool = True
    reason: str = ""
    stamp_step: float | None = None
    causal: CausalFilter | None = None
    rigid: bool = False
    spikes: tuple[tuple[float, float], ...] = ()

    def estimator(self, **options: object) -> SupervisedKalmanEstimator | DifferencingEstimator:
        """The default estimator for this identification (module docstring, step 5): the observer supervising the
        gyro-less EKF of the chosen model with its identified noises, or backward differencing. ``options``: the
        estimator's others (``references``, ``measurement``, ``omega_hat0``, ``warm_start``, ``rotation_tol``,
        ``quat_norm_tol``; the ones differencing does not take are left out for it)."""
        if not self.use_model:  # directions: each sample's least-squares attitude is differenced
            mine = ("rotation_tol", "quat_norm_tol", "scalar_first", "omega_hat0")
            keep = {k: v for k, v in options.items() if k in mine}
            if options.get("measurement") == "directions":  # (attitudes come with the observer's references)
                keep["references"] = options["references"]
            taps = None if self.causal is None or self.causal.is_differencing else self.causal.taps
            return DifferencingEstimator(scheme="backward", step=self.stamp_step, taps=taps, **keep)  # type: ignore[arg-type]
        return self.model_estimator(**options)

    def model_estimator(self, **options: object) -> SupervisedKalmanEstimator:
        """The observer supervising the gyro-less EKF of the chosen model, whatever step 5 decided. Without J the
        supervisor's consistency tests are off (a motion that is not the model, a hand, never gives white
        innovations: they would restart the EKF every few samples); with J they are on."""
        c = self.chosen
        dynamic = c.model in likelihood.DYNAMIC
        if not dynamic:
            options = {
                "nis_max": 1e6,
                "disagreement_factor": DIVERGENCE_FACTOR,
                "disagreement_yardstick": "observer",
                "max_rate": NYQUIST_RATE * self.rate_hz,
                "restart_after": likelihood.RESTART_GAP / self.rate_hz,  # where the likelihood's pass restarted
                **options,
            }
        J = self.J if dynamic else np.eye(3)
        # The filter's gains depend on Λ alone (L2); the covariances' scale σ is the supervisor's yardstick (the
        # observer's noise, the EKF's spread). At the noise of a quiet or noise-free log (micro-radians, or the floor)
        # that yardstick is far below what the motion makes the two estimates differ by (the observer's lag), and
        # the EKF was restarted every few samples or at every one (1717 times in 1930 samples on BROAD trial 06 at
        # 28.6 Hz: 6.2 times differencing's error; 29,999 of 30,000 on a noise-free 1 kHz log with J: 2.0 times).
        # So σ is at least the attitude noise that would give differencing's expected error (√6 σ / h), and q
        # follows it at the same Λ: the estimate is the same filter's, its supervision in the motion's scale.
        h = 1.0 / self.rate_hz
        sigma = max(c.sigma, SIGMA_FLOOR, self.differencing_rms * h / math.sqrt(6.0))
        noise = noise_intensity(c.model, c.tracking_index, sigma, h)
        root = math.sqrt(noise)
        second_order = ORDER[c.model] == 2
        options = {"torque_hold": c.torque_hold, **options}
        return SupervisedKalmanEstimator(
            J,
            rate_hz=self.rate_hz,
            measurement_noise=sigma,
            rate_noise=root * _QUIET_RATE if second_order else root,
            disturbance_noise=root if second_order else None,
            **options,  # type: ignore[arg-type]
        )

    def explain(self) -> str:
        """The lines ``omegahat estimate`` prints: the model chosen and why, and the expected errors."""
        others = "; ".join(c.describe() for c in self.candidates if c is not self.chosen)
        return (
            f"model identified from the log ({self.rate_hz:.4g} Hz samples, attitude noise at most "
            f"{self.noise_bound:.2g} rad where the body is quietest): {self.chosen.describe()}"
            + (f"\n  against {others}" if others else "")
            + f"\nexpected RMS error of the model's filter {self.expected_rms:.2g} rad/s, of backward differencing "
            f"{self.differencing_rms:.2g} rad/s: "
            + ("the model's filter runs" if self.use_model else "backward differencing runs")
            + f" ({self.reason})"
            + ("" if self.causal is None else self.causal.describe())
            + (
                "\ntimestamps: the steps are uneven but the increments follow their mean: read as regular samples "
                f"with jittered stamps, every {1e3 * self.stamp_step:.4g} ms"
                + ("; differencing takes each interval as whole steps" if not self.use_model else "")
                if self.stamp_step is not None
                else ""
            )
            + ("\ndirections: their angles are the references' (a rotation's, as if computed from attitudes): "
               "identified as their least-squares attitudes (R0)" if self.rigid else "")
            + describe_spikes(self.spikes)
        )  # fmt: skip


def _attitudes(data: np.ndarray, kind: str, refs: np.ndarray | None, t: np.ndarray) -> tuple[np.ndarray, ...]:
    """``(valid (T,), R (T, 3, 3), the filter's input)``: the attitudes (NaN where missing, a reset's step left out;
    of directions, Wahba's, for the noise bound only) or the directions made unit, a collinear sample skipped, as
    the estimators read them (a magnetometer's µT would otherwise weigh in the innovations)."""
    if refs is not None:
        checked = ms.body_directions(data)
        data = np.where((checked.status == ms.OK)[:, None, None], checked.r, np.nan)
    valid = np.all(np.isfinite(data.reshape(data.shape[0], -1)), axis=1)
    R = np.full((data.shape[0], 3, 3), np.nan)
    if refs is not None:
        R[valid] = so3.wahba(data[valid], refs)
        return valid, R, data
    if kind == "quaternion":
        valid &= np.linalg.norm(np.where(valid[:, None], data, 0.0), axis=1) > 0
        R[valid] = Rotation.from_quat(data[valid]).as_matrix()
    else:
        R[valid] = data[valid]
    R, valid, _ = stitched(R, valid, t)  # (P2)–(P3): the attitudes after a reset of their source turned back
    return valid, R, R


def _fitted(model, t, data, valid, h, bound, J, torque, refs, linear_hold) -> Candidate:
    """One model at its maximum likelihood (module docstring, step 2); ``linear_hold`` None: a dynamic model with
    a torque that varies is fitted with the torque held and interpolated, and the likelier is kept."""
    if linear_hold is None:
        tau = None if torque is None else np.asarray(torque, dtype=float)[valid]
        tau = None if tau is None else tau[np.all(np.isfinite(tau), axis=1)]
        varies = tau is not None and tau.size > 0 and bool(np.any(np.ptp(tau, axis=0) > 0.0))
        if not varies or model not in likelihood.DYNAMIC:  # the hold changes nothing: one fit
            return _fitted(model, t, data, valid, h, bound, J, torque, refs, False)
        held, line = (_fitted(model, t, data, valid, h, bound, J, torque, refs, lh) for lh in (False, True))
        best, other = (line, held) if line.log_likelihood > held.log_likelihood else (held, line)
        return replace(best, other_hold=other.log_likelihood)
    cache: dict[float, tuple[float, float]] = {}
    free: dict[float, float] = {}  # σ̂ of (L3) at each Λ
    dof = [0.0]

    def evaluate(lam: float) -> tuple[float, float]:
        if lam not in cache:
            sums: Sums = innovation_sums(
                t, data, valid, model, lam, h=h, J=J, torque=torque, references=refs, linear_hold=linear_hold
            )
            _, s_ml = log_likelihood(sums)
            free[lam] = s_ml
            sigma = max(min(s_ml, bound), SIGMA_FLOOR) if np.isfinite(s_ml) else bound
            cache[lam] = log_likelihood(sums, sigma) if np.isfinite(sigma) else (-np.inf, np.nan)
            dof[0] = max(dof[0], sums.dof)
        return cache[lam]

    lam, ll, sigma = likelihood.maximise(evaluate)
    bic = -2.0 * ll + N_PARAMS * math.log(max(dof[0], 2.0))
    misfit = free[lam] / sigma if np.isfinite(free.get(lam, np.nan)) and sigma > 0 else np.inf
    return Candidate(
        model, lam, sigma, ll, bic, noise_intensity(model, lam, sigma, h), lam >= LAMBDA_MAX, max(misfit, 1.0),
        "linear" if linear_hold else "zero",
    )  # fmt: skip


def identify(
    t: np.ndarray,
    data: np.ndarray,
    kind: str,
    *,
    J: np.ndarray | None = None,
    torque: np.ndarray | None = None,
    references: np.ndarray | None = None,
    linear_hold: bool | None = None,
    models: tuple[str, ...] | None = None,
) -> Identification:
    """The model and noises of a log, chosen by the log's own likelihood (module docstring, steps 1–5).

    Parameters
    ----------
    t : array_like
        The sample times ``(T,)`` (s).
    data : array_like
        Quaternions ``(T, 4)`` (scalar last), rotation matrices ``(T, 3, 3)`` (body → inertial) or directions
        ``(T, n, 3)`` (made unit, as the estimators read them); rows that are not finite are missing samples.
    kind : {"quaternion", "matrix", "directions"}
        Which of these ``data`` holds.
    J : array_like, optional
        The inertia, when known (then the dynamic models are candidates too).
    torque : array_like, optional
        The known torque ``(T, 3)`` (N·m, body axes), used by the dynamic models.
    references : array_like, optional
        The inertial directions ``(n, 3)``: required for directions.
    linear_hold : bool, optional
        The torque interpolated between samples in the filter's passes (``torque_hold="linear"``), or held; by
        default (None) the dynamic models are fitted both ways and the likelier is kept (step 2).
    models : tuple of str, optional
        The candidates (default: the kinematic ones, and the dynamic ones too when J is given).

    Returns
    -------
    Identification
        Every candidate at its maximum likelihood, the one chosen, the expected errors and the estimator to run.

    Raises
    ------
    ValueError
        With fewer than :data:`MIN_SAMPLES` valid samples, times that do not increase, a zero direction, an
        unknown model, or when no model could be fitted.

    Examples
    --------
    A short noisy log (3 s at 100 Hz, 1 mrad) of a body turning at a constant rate, no inertia known:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat.identification import identify
    >>> t = np.arange(0.0, 3.0, 0.01)  # 100 Hz
    >>> noise = Rotation.from_rotvec(1e-3 * np.random.default_rng(0).standard_normal((t.size, 3)))  # 1 mrad
    >>> q = (Rotation.from_rotvec(np.outer(t, [0.3, -0.2, 0.5])) * noise).as_quat()  # rad/s, body axes
    >>> ident = identify(t, q, "quaternion")
    >>> ident.chosen.model, [c.model for c in ident.candidates]
    ('rate', ['rate', 'acceleration'])
    >>> est = ident.estimator()  # the rate model's filter, as ident.use_model says
    >>> type(est).__name__, ident.use_model
    ('SupervisedKalmanEstimator', True)
    >>> print(" ".join(f"{x:.2f}" for x in est.run(t, q).omega[-1]))
    0.30 -0.20 0.50
    """
    t = np.asarray(t, dtype=float)
    data = np.asarray(data, dtype=float)
    refs = None if kind != "directions" else as_directions(references)  # type: ignore[arg-type]
    valid, R, filt_data = _attitudes(data, kind, refs, t)
    spikes = isolated_spikes(R, valid)  # left out: one such sample throws every fast filter onto an alias
    valid[spikes.samples] = False
    spiked = tuple((float(t[k]), float(d)) for k, d in zip(spikes.samples, spikes.detour, strict=True))  # as stamped
    if np.count_nonzero(valid) < MIN_SAMPLES:
        raise ValueError(
            f"at least {MIN_SAMPLES} valid samples are needed to identify a model; got {np.count_nonzero(valid)}"
        )
    # (S8): regular samples with jittered stamps are identified on the samples' clock (D3), every interval whole steps
    reading, step = steps.read_steps(t, so3.increments(R), [(a, b) for a, b in steps.stretches(t, valid) if b - a >= 3])
    stamp_step = step if reading == "stamps" else None
    t = t if stamp_step is None else sample_clock(t, stamp_step)
    tv = t[valid]
    h = float(np.median(np.diff(tv)))
    if not h > 0:
        raise ValueError("the sample times must increase")
    phi = so3.increments(R[valid])
    bound = max(float(np.nan_to_num(quiet_noise(tv, phi), nan=np.inf)), SIGMA_FLOOR)
    rigid = bool(refs is not None and np.isfinite(bound) and rigid_directions(filt_data[valid], refs, bound))
    if rigid:  # (R0): directions that are a rotation's are identified as their attitudes
        filt_data, refs = R, None
    J_ = np.eye(3) if J is None else as_inertia(J)
    if models is None:
        models = MODELS if J is not None else KINEMATIC
    unknown = [m for m in models if m not in MODELS]
    if unknown:
        raise ValueError(f"models must be among {', '.join(MODELS)}; got {unknown}")
    candidates = [_fitted(model, t, filt_data, valid, h, bound, J_, torque, refs, linear_hold) for model in models]
    finite = [c for c in candidates if np.isfinite(c.bic)]
    if not finite:
        why = steps.too_fast(phi)  # a turn the samples cannot follow
        raise ValueError(f"no model could be fitted to this log (every likelihood evaluation failed){why}")
    eligible = [c for c in finite if J is not None or c.model != "acceleration"] or finite  # without J: step 5
    chosen = min(eligible, key=lambda c: c.bic)
    expected = (  # (4): with Euler's equations, the filter's own covariance (their coupling of the axes)
        likelihood.coupled_rate_error(t, filt_data, valid, chosen.model, chosen.tracking_index, chosen.sigma, h=h,
                                      J=J_, torque=torque, references=refs, linear_hold=chosen.torque_hold == "linear")
        if chosen.model in likelihood.DYNAMIC
        else likelihood.steady_rate_error(chosen.model, chosen.tracking_index, chosen.sigma, h)
    )  # fmt: skip
    across = np.diff(tv) > 1.5 * h  # a step across missing samples is no one spacing's: (D1) would read a gap's turn
    differencing = differencing_error(np.where(across[:, None], np.nan, spikes.skipped(phi, valid)), h, chosen.sigma)
    if chosen.misfit > MISFIT_MAX:
        misfit = f"{chosen.misfit:.3g} times what the noise explains"
        use, why = False, f"the model does not describe this log: its innovations are {misfit}"
    elif chosen.at_fast_limit:
        use, why = False, "the model is at its fast limit: no measurement noise the log can tell from motion"
    elif not expected < GAIN_REQUIRED * differencing:
        use, why = False, f"the model predicts no {1 - GAIN_REQUIRED:.0%} gain over backward differencing"
    else:
        use, why = True, f"the model predicts {expected / differencing:.2g} times backward differencing's error"
    checked = use and chosen.model not in likelihood.DYNAMIC and refs is None  # (d): the spectrum's account
    spectrum = increment_spectrum(t, R, valid) if checked or not use else None  # directions: their attitudes (W)
    if checked and spectrum is not None:  # (K1)–(K2)
        response = likelihood.rate_response(chosen.model, chosen.tracking_index, chosen.sigma, h, spectrum.freq)
        worst = float(np.max(model_to_differencing(spectrum.with_noise(chosen.sigma), response)))
        if not worst < 1.0 and not math.isnan(worst):  # NaN: no spectrum to tell (a short log)
            use, why = (
                False,
                (
                    f"with its own noise the log's spectrum expects the model's filter to have {worst:.2g} times "
                    "backward differencing's error under one of its readings (C4), where the model's own account "
                    f"predicts {expected / differencing:.2g} times"
                ),
            )
    causal = None if use or spectrum is None else causal_filter(spectrum)
    return Identification(
        1.0 / h, bound, chosen, tuple(candidates), expected, differencing, J_, use, why, stamp_step, causal, rigid,
        spiked,
    )  # fmt: skip
