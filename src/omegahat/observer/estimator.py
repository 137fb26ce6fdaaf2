r"""The sampled, streaming Sarras estimator: one sample at a time (``update``) or whole logs (``run``).

The continuous observer (``docs/theory/observer.md``, :mod:`omegahat.kernels.observer`) realised for measurements that
arrive at sample times ``t_k`` (any, possibly irregular, spacing); ``docs/theory/sampled.md`` explains it at length.

**State** ``(ω̂, r_i, e_i)`` with ``e_i = r̂_i − r_i``, equivalent to the paper's ``(ξ, r̂_i)`` through the output
map ``ω̂ = ξ + J⁻¹ Σ k_i r_i × r̂_i``. With the directions moved along the estimate between samples
(``ṙ_i = r_i × ω̂``) every mismatch of (O3) is zero, so the observer reduces to::

    J ω̂̇ = (J ω̂) × ω̂ + τ                                                   (E1, Euler's equations)
    ė_i  = e_i × ω̂ − l_i(ω̂) e_i                                           (E2)

while a jump ``Δ_i`` of ``r_i`` (ξ and r̂ continuous) moves the output by ``J⁻¹ Σ k_i Δ_i × r̂_i``.

Between samples (``h = t_{k+1} − t_k``, torque ``τ_k`` held from its sample):

1. **Predict (P).** ω̂ follows (E1); the attitude increment ``ΔR̂`` of ``Ṙ = R ω̂×`` moves the directions,
   ``r_i^pred = ΔR̂ᵀ r_i,k``; (E2) is solved exactly, ``e_i = exp(−∫ l_i dt) ΔR̂ᵀ e_i,k`` (the stiff decay is never
   stepped explicitly). (E1) and ``ΔR̂`` are integrated together by the Runge–Kutta–Munthe-Kaas method of order 4
   in substeps of angle at most ``max_substep_angle``; a constant ω̂ is predicted exactly (``ΔR̂ = exp(h ω̂)``).
2. **Innovation (I)** ``Δ_i = r_i,meas − r_i^pred``: the mismatch accumulated over the interval is ``−Δ_i``.
3. **Correction (C), implicit.** The observer's response to it (:func:`omegahat.kernels.observer.innovation`),
   ``y = J⁻¹ Σ k_i r̂_i × (−Δ_i)``, linearises to ``y ≈ −h J⁻¹ M z`` (``z = ω̂ − ω``, M the stiffness (O6)):
   explicit Euler of ``ż = −J⁻¹ M z``, which overshoots for ``k h / J`` near 1 and diverges beyond 2. Applied::

       ω̂ ← ω̂ + (I + h J⁻¹ M_meas)⁻¹ y,      M_meas = Σ k_i (|r_i|² I − r_i r_iᵀ)  (measured r_i)     (C)

   whose linearised error map ``z ← (I + h J⁻¹ M)⁻¹ z`` is a contraction for every k and h; it is zero when
   ``Δ = 0`` (exact equilibrium) and tends to the continuous observer at first order as h → 0.
4. **Reset (R)** ``e_i ← e_i − Δ_i``, ``r_i ← r_i,meas`` (r̂ continuous, r jumps to the measurement).

Initialisation: the first valid sample sets ``r_i``; ``ω̂₀`` is given (default 0) and ``r̂_i0`` too (default the
first measurement, ``e = 0``). **Warm start (W).** The observer converges from any ω̂₀, but only at the rate its
gains allow. Since ξ₀ is free, the estimator may take it from the data: at the second valid sample (``h`` after the
first) it solves Wahba's problem for the rotation A that best carries the first sample's directions onto the
second's, takes the mean rate ``ω_avg = log(Aᵀ)/h`` (exact for a constant rate while ``|ω| h < π``) and moves it to
the interval's end with half a step of (E1): error ``O(h²)`` plus the noise (about ``√2 σ / h``). By default the
warm start is on unless an initial state (``omega_hat0`` or ``r_hat0``) is given.

Input is checked by :mod:`omegahat.measurements` (one policy for every estimator). Bad input, and what happens
(the state is left exactly as it was whenever a sample is rejected):

* a NaN or inf anywhere in the measurement → the sample is **skipped**: the state is predicted to its time,
  no correction (status ``predicted``); counted in ``n_skipped``, its time in ``skipped_times``;
  ``largest_interval`` reports the longest interval seen (gaps need nothing else: the prediction runs over them);
* direction measurements within ``min_angle_deg`` of collinear → skipped the same way (of ``n_skipped``, counted
  in ``n_collinear``);
* a step whose result is not finite (a gap too long for the model's substeps while the rate is not constant, a
  torque or gains beyond floating point) → status ``RESTARTED``: the state is discarded and the estimator starts
  again from that sample (a warm start at the next valid one); ω̂ is NaN there and until that warm start, never a
  diverged value; counted in ``n_restarts`` (:data:`omegahat.kernels.checks.RESTARTED`). A long gap at a constant
  rate (no torque, ``J = j I``) is predicted exactly, whatever its length;
* not a rotation, a quaternion far from unit norm, a zero direction, a time not after the previous one or not
  finite, a non-finite torque → :class:`omegahat.measurements.MeasurementError` (a ``ValueError``) naming the
  sample and the value; a wrong shape → ``ValueError``; a time or a value that is not a real number →
  ``TypeError``. ``run`` is atomic: it names the first rejected sample and leaves the state as it was before the
  call.

The compiled step is :mod:`omegahat.observer.sampled` (``update`` and ``run`` call the same function);
:mod:`omegahat.observer.reference` is its plain NumPy oracle. Conversion, refusal, counting, statuses and warnings
are the compiled estimators' shared base, :class:`omegahat.observer.compiled.CompiledEstimator`.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat.interface import MeasurementKind, TorqueHold, one_of
from omegahat.observer import sampled
from omegahat.observer.compiled import CompiledEstimator, RestartedWarning, SkippedSamplesWarning
from omegahat.observer.gains import ObserverGains
from omegahat.observer.prediction import MAX_SUBSTEP_ANGLE
from omegahat.observer.sampled import STATE, EstimatorState
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = ["EstimatorState", "RestartedWarning", "SarrasEstimator", "SkippedSamplesWarning"]


_OMEGA_HAT = slice(STATE.omega_hat, STATE.omega_hat + 3)  # ω̂ in the flat state


class SarrasEstimator(CompiledEstimator):
    """Sampled Sarras estimator: ω from attitudes or directions, one sample at a time or a whole log.

    The module docstring gives the equations, the input and the bad-input behaviour. ``update(t, sample, torque)``
    takes one sample, ``run(t, data, torques)`` a log (atomic); both return an
    :class:`~omegahat.interface.Estimate` (``omega`` rad/s in body axes, a status per sample).

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD; the one positional argument.
    gains : ObserverGains
        Gains for ``n`` directions (required): :func:`~omegahat.observer.gains.theorem_gains`,
        :func:`omegahat.observer.tuning.sensor_gains` or your own.
    references : array_like, optional
        Inertial directions ``v_i`` ``(n, 3)``. With ``measurement="attitude"`` they default to the first ``n``
        inertial axes (rows of R); with ``measurement="directions"`` they are required.
    measurement : {"attitude", "directions"}, optional
        What a sample is: an attitude (rotation matrix or quaternion, body → inertial; the default when no
        references are given) or the ``n`` directions measured in the body ``(n, 3)`` (the default when
        references are given).
    omega_hat0 : array_like, optional
        Initial estimate (default 0; given, it is the estimate at the first valid sample, else there is none
        there).
    r_hat0 : array_like, optional
        Initial ``r̂_i`` ``(n, 3)`` (default: the first sample).
    scalar_first : bool, optional
        Quaternion order (default False: SciPy's ``(x, y, z, w)``).
    rotation_tol, quat_norm_tol, min_angle_deg : float, optional
        Input checks (:mod:`omegahat.measurements`): bounds on ``‖RᵀR − I‖_F`` and ``|‖q‖ − 1|``, and the angle
        (degrees) within which measured directions are skipped as collinear.
    max_substep_angle : float, optional
        Bound on the prediction's substep angle (rad).
    warm_start : bool, optional
        Take ω̂ from the first two valid samples (W) instead of ``omega_hat0``. Default (None): on unless
        ``omega_hat0`` or ``r_hat0`` is given; False: the observer as published, started from ``omega_hat0``.
    torque_hold : {"zero", "linear"}, optional
        The known torque between samples: ``"zero"`` (default: the torque given with a sample is held until the
        next, exact for commands a controller holds between updates) or ``"linear"`` (the line from the previous
        sample's torque to the new sample's, causal since the new sample's torque comes with it: better for a
        smooth torque that is merely sampled, wrong at a held command's switch; ``docs/theory/sampled.md``).
    isotropic_rate : float, optional
        None (default: ``gains.isotropic_rate``, which is None for the observer's rate gain ``J⁻¹``) or a rate
        ``b`` in rad/s: the correction then uses the matrix gain ``b M⁻¹`` so that every error mode decays at
        about ``b`` whatever the directions' geometry (``docs/theory/tuning.md``); the gains' ``k_i`` then only
        weigh the directions.

    Raises
    ------
    TypeError
        If ``gains`` is not an :class:`~omegahat.observer.gains.ObserverGains`.
    ValueError
        If an argument is out of range, or the references do not match the gains.

    Examples
    --------
    A body turning at a constant rate (J = I: no torque keeps the rate constant), attitudes as quaternions at
    100 Hz; the observer as published, started from ω̂ = 0:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import SarrasEstimator, sensor_gains
    >>> w = np.array([0.3, -0.2, 0.5])  # rad/s, body axes
    >>> t = np.arange(0.0, 5.0, 0.01)
    >>> q = Rotation.from_rotvec(np.outer(t, w)).as_quat()
    >>> gains = sensor_gains(np.eye(3), rate_hz=100.0, measurement_noise=1e-3, bandwidth_hz=2.0)
    >>> est = SarrasEstimator(np.eye(3), gains=gains, omega_hat0=[0.0, 0.0, 0.0])
    >>> omega = est.run(t, q).omega
    >>> for k in (10, 50, -1):
    ...     print(f"t = {t[k]:.2f} s:", " ".join(f"{x:.3f}" for x in omega[k]))
    t = 0.10 s: 0.215 -0.143 0.358
    t = 0.50 s: 0.299 -0.200 0.499
    t = 4.99 s: 0.300 -0.200 0.500
    >>> est.update(5.0, Rotation.from_rotvec(5.0 * w).as_quat()).status.name  # then sample by sample
    'CORRECTED'
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        gains: ObserverGains,
        references: ArrayLike | None = None,
        measurement: MeasurementKind | None = None,
        omega_hat0: ArrayLike | None = None,
        r_hat0: ArrayLike | None = None,
        scalar_first: bool = False,
        rotation_tol: float = ms.ROTATION_TOL,
        quat_norm_tol: float = ms.QUAT_NORM_TOL,
        min_angle_deg: float = ms.MIN_ANGLE_DEG,
        max_substep_angle: float = MAX_SUBSTEP_ANGLE,
        warm_start: bool | None = None,
        torque_hold: TorqueHold = "zero",
        isotropic_rate: float | None = None,
    ) -> None:
        self.J = as_inertia(J)
        if not isinstance(gains, ObserverGains):
            raise TypeError(f"gains must be an omegahat.observer.gains.ObserverGains; got {type(gains).__name__}")
        self.gains = gains
        n = gains.n
        if measurement is None:
            measurement = "attitude" if references is None else "directions"
        self.measurement: MeasurementKind = one_of("measurement", measurement, MeasurementKind)
        if references is None:
            if measurement == "directions":
                raise ValueError("measurement='directions' needs the inertial references (n, 3)")
            if n not in (2, 3):
                raise ValueError(f"attitude input without references uses 2 or 3 rows of R; gains are for {n}")
        self.references = ms.as_references(references, n)
        if self.references.shape[0] != n:
            raise ValueError(f"{n} gains were given for {self.references.shape[0]} reference directions")
        self.omega_hat0 = np.zeros(3) if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        if r_hat0 is None:
            self.r_hat0 = None
        else:
            self.r_hat0 = np.asarray(r_hat0, dtype=float)
            if self.r_hat0.shape != (n, 3) or not np.all(np.isfinite(self.r_hat0)):
                raise ValueError(f"r_hat0 must be {n} finite directions, shape ({n}, 3); got {r_hat0!r}")
        self.scalar_first = bool(scalar_first)
        self.rotation_tol, self.quat_norm_tol = ms.tolerances(rotation_tol, quat_norm_tol)
        self.max_substep_angle = float(as_positive(max_substep_angle, "max_substep_angle")[0])
        self.min_angle_deg = ms.min_angle(min_angle_deg)
        self.warm_start = (omega_hat0 is None and r_hat0 is None) if warm_start is None else bool(warm_start)
        self.torque_hold: TorqueHold = one_of("torque_hold", torque_hold, TorqueHold)
        if isotropic_rate is None:
            isotropic_rate = gains.isotropic_rate
        self.isotropic_rate = (
            None if isotropic_rate is None else float(as_positive(isotropic_rate, "isotropic_rate")[0])
        )
        self._params = sampled.pack_params(
            self.J, gains, self.references, self.r_hat0, self.rotation_tol, self.quat_norm_tol, self.min_angle_deg,
            self.max_substep_angle, self.scalar_first, self.warm_start, torque_hold, self.isotropic_rate,
        )  # fmt: skip
        self._params.flags.writeable = False  # read-only everywhere: one compiled specialisation for every caller
        self._configure_input(
            n_directions=None if measurement == "attitude" else n,
            rate_given=omega_hat0 is not None and not self.warm_start,
        )
        self.reset()

    # -- state ------------------------------------------------------------------------------------------------

    def _reset_state(self) -> None:
        self._x = sampled.initial_state_vector(self.gains.n, self.omega_hat0)
        # the step's output and scratch, reused by every update (allocating them cost a sixth of an update)
        self._x_next = np.empty_like(self._x)
        self._work = np.empty((self.gains.n + 6, 3))

    @property
    def state(self) -> EstimatorState:
        """A readable copy of the current state."""
        return EstimatorState.from_vector(self._x)

    @property
    def omega_hat(self) -> np.ndarray:
        """The state's ω̂ (rad/s; ``omega_hat0`` before the first sample)."""
        return self._x[_OMEGA_HAT].copy()

    @property
    def params(self) -> np.ndarray:
        """The compiled step's flat parameters (:data:`omegahat.observer.sampled.PARAMS`), read-only."""
        view = self._params.view()
        view.flags.writeable = False
        return view

    @property
    def state_vector(self) -> np.ndarray:
        """A copy of the compiled step's flat state (:data:`omegahat.observer.sampled.STATE`)."""
        return self._x.copy()

    @state_vector.setter
    def state_vector(self, x: np.ndarray) -> None:
        if np.shape(x) != self._x.shape:
            raise ValueError(f"a state vector of shape {self._x.shape} is needed; got {np.shape(x)}")
        self._x = np.array(x, dtype=float)

    # -- the compiled step (the base converts, refuses, counts) -------------------------------------------------

    def _step(self, t: float, m: np.ndarray, kind: int, tau: np.ndarray) -> tuple[Any, np.ndarray, int, float]:
        x = self._x_next  # pure all the same: written here, the state only once committed
        status, info = sampled.step_into(self._x, self._params, t, m, kind, tau, x, self._work)
        return x, x[_OMEGA_HAT], status, info

    def _run(
        self, times: np.ndarray, m: np.ndarray, kind: int, taus: np.ndarray
    ) -> tuple[Any, np.ndarray, np.ndarray, int, float]:
        x, W, status, first_bad, info = sampled.run(self._x, self._params, times, m, kind, taus)
        return x, W, status, int(first_bad), float(info)

    def _commit(self, state: Any) -> None:
        if state is self._x_next:  # an update's: the old state becomes the next output
            self._x_next = self._x
        self._x = state
