r"""Gains for sampled, noisy sensors: pick ``k_i`` and ``l_i`` from the sample rate, the attitude noise and the
bandwidth (or convergence time) wanted, and predict the noise the estimate will carry.

Beside the theorem's gains (:func:`omegahat.observer.gains.theorem_gains`: sufficient for global convergence, very stiff
``l_i``) this module designs gains for the sampled estimator of :mod:`omegahat.observer.estimator` by linearisation.

**Linearised error map.** Near the truth (``z = ω̂ − ω`` small, ``e_i ≈ 0``), neglecting the body's rotation over
one sample (``h |ω| ≪ 1``) and the gyroscopic coupling (bandwidth ``≫ |ω|``), a sample at period ``h = 1/rate``
maps the error as (estimator module docstring, step 3)::

    z⁺ = G z + B (δ_{k+1} − δ_k),     G = (I + h J⁻¹ M)⁻¹,   B = G J⁻¹ M,   M = Σ k_i (I − r_i r_iᵀ)     (L)

where ``δ_k`` is the attitude noise of sample k (``R_meas = R exp(δ×)``: a measured direction is then
``r_i + r_i × δ`` and its innovation term ``Δ_i × r_i = (I − r_i r_iᵀ)(δ_{k+1} − δ_k)``). The noise enters
differenced: the estimator differentiates the attitude.

**Bandwidth.** The slowest mode of ``G`` contracts by ``1/(1 + h λ_min)`` per sample, ``λ_min`` the smallest
eigenvalue of ``J⁻¹ M ≥ μ₁ k / J_M`` (``μ₁ = λ_min Σ (I − v_i v_iᵀ)`` for unit gains: 2 for three orthogonal
directions, 1 for two). Equal gains ``k_i = k`` with::

    k = J_M (exp(ω_b h) − 1) / (h μ₁)                                                                  (K)

give every mode at least the continuous rate ``ω_b`` (rad/s): the error falls as ``exp(−ω_b t)`` or faster. The
bandwidth asked for is ``ω_b = 2π bandwidth_hz`` or ``1 / convergence_time``. With ``angular_accel`` α (a typical
|ω̇|, rad/s²) instead, ``ω_b`` balances the two errors of a first-order tracker: the lag ``α / ω_b`` (an
unknown torque, or an unmodelled acceleration, is followed with that delay) against the noise ``≈ ω_b σ``
(below): ``ω_b = √(α / σ)``, where both are equal.

**Geometry (I).** "At least" hides a spread when the directions are not a triad: with two directions at angle α,
``Σ (I − v_i v_iᵀ)`` has eigenvalues ``1 − cos α``, ``1 + cos α`` and 2, so for gravity and a mid-latitude
magnetic field (α = 27°) the modes other than the slowest run 17 times faster, with 17 times the noise. For such
geometries :func:`sensor_gains` sets the gains' ``isotropic_rate`` to ``(exp(ω_b h) − 1)/h``: the sampled
estimator's correction then uses the matrix rate gain ``b M⁻¹`` (``M`` at the measured directions, every sample)
instead of ``J⁻¹``, and (L) becomes ``G = (I + h b I)⁻¹``: **every** mode decays at ``ω_b``, as far as the
geometry allows (a weak direction of ``M`` is corrected as fast as a strong one, so its noise is the attitude
noise of that axis, which Wahba's problem makes larger for a poor geometry). A triad of rows keeps ``J⁻¹``.

**The trade-off.** Larger ``k`` (bandwidth) means faster convergence and less lag, but more noise: for
isotropic ``J⁻¹ M = λ I`` with white attitude noise of std σ per axis, (L) is a scalar recursion whose stationary
std per axis is::

    std(z) = σ (a / h) / (1 + a) · √(2 / (1 + g)),   a = h λ,  g = 1 / (1 + a)                         (N)

≈ ``λ σ`` (≈ ``ω_b σ``) when ``a ≪ 1``, and ``√2 σ / h`` (raw differencing) when ``a ≫ 1``.
:func:`predicted_noise_std` solves the general (anisotropic) case exactly as a discrete Lyapunov equation for
the state ``(z_k, δ_k)``; ``tests/test_tuning.py`` checks it against simulated noisy runs.

**l_i.** The sampled estimator integrates the decay of ``e_i = r̂_i − r_i`` exactly, so large ``l_i`` cost no
stability. ``l_i = l_factor · k_i / J_m`` (default 10) keeps ``r̂_i`` close to ``r_i`` when the correction acts,
which is what (L) assumes. These gains generally do not satisfy the theorem's conditions (``check_gains`` says by
how much): the guarantee is then local, which is what a tuned filter offers anyway.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike
from scipy.linalg import solve_discrete_lyapunov

from omegahat.observer.gains import ObserverGains, inertia_bounds
from omegahat.validation import as_directions, as_inertia, as_positive

__all__ = ["bandwidth_gains", "differencing_error", "isotropic_noise_std", "predicted_noise_std", "sensor_gains"]


def differencing_error(steps: ArrayLike, h: float, sigma: float) -> float:
    """Backward differencing's expected RMS rate error (rad/s) on a log, from the log itself.

    With ``φ_k`` the rotation vectors between consecutive samples (``steps``), ``ū_k = φ_k / h`` the differenced
    rates and ``σ`` the attitude noise per axis: the noise's share ``√6 σ / h`` and the motion's over half a sample
    (the change between consecutive differenced rates, less what the noise puts in it)::

        e_d² = 6 σ² / h² + max(0, E|ū_{k+1} − ū_k|² − 18 σ² / h²) / 4                                  (D1)

    Parameters
    ----------
    steps : array_like
        ``(K, 3)``: the rotation vectors between consecutive samples (rad); NaN rows are left out of the mean.
    h : float
        The sample spacing (s).
    sigma : float
        The attitude noise (rad per axis).

    Returns
    -------
    float
        The expected RMS error of backward differencing (rad/s, over the three axes).

    Examples
    --------
    A constant rate of 1 rad/s sampled at 100 Hz with no noise: differencing is exact, and with 1 mrad of noise
    its error is ``√6 · 1e-3 / 0.01``:

    >>> import numpy as np
    >>> from omegahat.observer.tuning import differencing_error
    >>> steps = np.tile([0.01, 0.0, 0.0], (100, 1))
    >>> print(f"{differencing_error(steps, 0.01, 0.0):.3f} {differencing_error(steps, 0.01, 1e-3):.3f}")
    0.000 0.245
    """
    du = np.diff(np.asarray(steps, dtype=float), axis=0) / h
    square = np.sum(du**2, axis=1)
    square = square[np.isfinite(square)]
    motion = float(np.mean(square)) - 18.0 * sigma**2 / h**2 if square.size else 0.0
    return float(np.sqrt(6.0 * sigma**2 / h**2 + max(motion, 0.0) / 4.0))


def _geometry(references: ArrayLike | None) -> np.ndarray:
    return as_directions(np.eye(3) if references is None else references)


def bandwidth_gains(
    J: ArrayLike, bandwidth_hz: float, references: ArrayLike | None = None, l_per_bandwidth: float = 10.0
) -> ObserverGains:
    """The simple rule ``omegahat compare`` tunes the fixed-gain observer with.

    ``omegahat estimate --bandwidth`` and ``estimate_frame(bandwidth_hz=…)`` use :func:`sensor_gains` instead,
    through :func:`omegahat.observer.autogain.gains_for_bandwidth`. With ``b = 2π bandwidth_hz`` (rad/s): equal
    ``k_i = b (tr J / 3) / μ₁`` with ``μ₁ = λ_min Σ (I − v_i v_iᵀ)`` (2 for the three rows of R, 1 for two orthogonal
    rows) and ``l_i = l_per_bandwidth · b``: the continuous linearised error ``ż = −J⁻¹ M z`` then decays at about
    ``b`` rad/s for a near-isotropic body. It ignores the sample rate; :func:`sensor_gains` is the rate- and
    noise-aware design (slowest mode at least ``b``, using ``J_M``).

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    bandwidth_hz : float
        The bandwidth wanted (Hz).
    references : array_like, optional
        The inertial directions ``(n, 3)`` (default: the three rows of R).
    l_per_bandwidth : float, optional
        ``l_i / b`` (default 10).

    Returns
    -------
    ObserverGains
        Constant gains for the ``n`` directions.

    Examples
    --------
    >>> from omegahat import bandwidth_gains, check_gains
    >>> J = [3.0, 2.0, 1.0]
    >>> g = bandwidth_gains(J, bandwidth_hz=1.0)  # b = 2π rad/s, tr J / 3 = 2, μ₁ = 2
    >>> print(f"n = {g.n}, k = {g.k[0]:.3f}, l = {g.l_offset[0]:.2f}")
    n = 3, k = 6.283, l = 62.83
    >>> check_gains(g, J, omega_max=1.0, warn=False).ok  # a tuned filter: no global guarantee
    False
    """
    J = as_inertia(J)
    b = 2 * np.pi * float(as_positive(bandwidth_hz, "bandwidth_hz")[0])
    v = _geometry(references)
    mu1 = float(np.linalg.eigvalsh(np.eye(3) * v.shape[0] - v.T @ v)[0])
    k = b * np.trace(J) / 3.0 / mu1
    l = float(as_positive(l_per_bandwidth, "l_per_bandwidth")[0]) * b
    return ObserverGains.constant(k, l, n=v.shape[0])


def sensor_gains(
    J: ArrayLike,
    rate_hz: float,
    measurement_noise: float,
    bandwidth_hz: float | None = None,
    convergence_time: float | None = None,
    angular_accel: float | None = None,
    references: ArrayLike | None = None,
    l_factor: float = 10.0,
) -> ObserverGains:
    """Equal gains for ``n`` directions from the sensor and the bandwidth wanted (module docstring: (K), l_i).

    Give exactly one of ``bandwidth_hz``, ``convergence_time`` or ``angular_accel``. For directions whose geometry
    makes the modes unequal (not a triad of rows) the gains' ``isotropic_rate`` is set to ``(exp(ω_b h) − 1)/h``
    ((I) of the module docstring). See :func:`predicted_noise_std` for the noise the result will give.

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    rate_hz : float
        The sample rate (Hz).
    measurement_noise : float
        The attitude noise (rad, one standard deviation per axis, white; for direction sensors, that of each
        direction component).
    bandwidth_hz : float, optional
        The bandwidth wanted (Hz), below Nyquist ``rate_hz / 2``.
    convergence_time : float, optional
        The time constant of the slowest linearised mode (s).
    angular_accel : float, optional
        A typical |ω̇| (rad/s²): the bandwidth then balances lag and noise, ``ω_b = √(α / σ)``.
    references : array_like, optional
        The inertial directions ``(n, 3)`` (default the three rows of R).
    l_factor : float, optional
        ``l_i = l_factor · k_i / J_m`` (default 10).

    Returns
    -------
    ObserverGains
        Equal ``k_i`` by (K), ``l_offset_i = l_factor · k_i / J_m``, and ``isotropic_rate`` by (I) or None.

    Raises
    ------
    ValueError
        If not exactly one of the three is given, or the bandwidth is not below the Nyquist frequency.

    Examples
    --------
    >>> import numpy as np
    >>> from omegahat import check_gains, predicted_noise_std, sensor_gains
    >>> J = [3.0, 2.0, 1.0]
    >>> g = sensor_gains(J, rate_hz=100.0, measurement_noise=1e-3, bandwidth_hz=2.0)
    >>> print(f"k = {g.k[0]:.2f}, l = {g.l_offset[0]:.1f}, isotropic_rate = {g.isotropic_rate}")
    k = 20.09, l = 200.9, isotropic_rate = None
    >>> std = predicted_noise_std(J, g, rate_hz=100.0, measurement_noise=1e-3)
    >>> print(" ".join(f"{s:.4f}" for s in std))  # rad/s per body axis
    0.0122 0.0175 0.0310
    >>> check_gains(g, J, omega_max=1.0, warn=False).ok  # the guarantee is local
    False

    Gravity and a magnetic field 27° apart: the isotropic rate gain is used.

    >>> a = np.radians(27.0)
    >>> refs = [[0.0, 0.0, 1.0], [np.sin(a), 0.0, np.cos(a)]]
    >>> g2 = sensor_gains(J, rate_hz=100.0, measurement_noise=1e-3, bandwidth_hz=2.0, references=refs)
    >>> print(f"n = {g2.n}, isotropic_rate = {g2.isotropic_rate:.2f} rad/s")
    n = 2, isotropic_rate = 13.39 rad/s
    """
    J = as_inertia(J)
    J_m, J_M = inertia_bounds(J)
    rate = float(as_positive(rate_hz, "rate_hz")[0])
    sigma = float(as_positive(measurement_noise, "measurement_noise")[0])
    given = {
        name: v
        for name, v in (
            ("bandwidth_hz", bandwidth_hz),
            ("convergence_time", convergence_time),
            ("angular_accel", angular_accel),
        )
        if v is not None
    }
    if len(given) != 1:
        raise ValueError(
            "give exactly one of bandwidth_hz, convergence_time or angular_accel; got "
            + (", ".join(f"{k}={v!r}" for k, v in given.items()) or "none")
        )
    ((name, value),) = given.items()
    value = float(as_positive(value, name)[0])
    if name == "bandwidth_hz":
        omega_b = 2 * np.pi * value
    elif name == "convergence_time":
        omega_b = 1.0 / value
    else:
        omega_b = np.sqrt(value / sigma)
    h = 1.0 / rate
    if omega_b / (2 * np.pi) >= rate / 2:
        raise ValueError(
            f"the bandwidth {omega_b / (2 * np.pi):.6g} Hz (from {name} = {value!r}) must be below the Nyquist "
            f"frequency rate_hz / 2 = {rate / 2:.6g} Hz"
        )
    v = _geometry(references)
    mu1 = float(np.linalg.eigvalsh(np.eye(3) * v.shape[0] - v.T @ v)[0])  # λ_min Σ (I − v_i v_iᵀ)
    k = J_M * np.expm1(omega_b * h) / (h * mu1)  # (K)
    l_factor = float(as_positive(l_factor, "l_factor")[0])
    n = v.shape[0]
    mus = np.linalg.eigvalsh(np.eye(3) * n - v.T @ v)
    # (I) Directions whose geometry makes the modes unequal (two directions 27° apart: 17-fold) get the isotropic
    # rate gain, every mode at the (K) rate; a triad of rows keeps the observer's J⁻¹ (modes equal up to J).
    iso = float(np.expm1(omega_b * h) / h) if mus[-1] > (1.0 + 1e-9) * mus[0] else None
    return ObserverGains(k=np.full(n, k), l_offset=np.full(n, l_factor * k / J_m), isotropic_rate=iso)


def predicted_noise_std(
    J: ArrayLike,
    gains: ObserverGains,
    rate_hz: float,
    measurement_noise: float,
    references: ArrayLike | None = None,
    R: ArrayLike | None = None,
) -> np.ndarray:
    """Predicted stationary std of each component of ``ω̂ − ω`` (rad/s, body axes) for white attitude noise.

    Solves (L) of the module docstring exactly: the stationary covariance of ``x_k = (z_k, δ_k)`` with
    ``x⁺ = [[G, −B], [0, 0]] x + [B; I] δ_{k+1}`` from ``scipy.linalg.solve_discrete_lyapunov``. With
    ``gains.isotropic_rate = b`` the map's ``J⁻¹ M`` is ``b I``.

    Parameters
    ----------
    J : array_like
        The inertia (3 numbers = diagonal, 9 numbers or 3×3), SPD.
    gains : ObserverGains
        The gains for ``n`` directions.
    rate_hz : float
        The sample rate (Hz).
    measurement_noise : float
        The attitude noise σ (rad per axis, white).
    references : array_like, optional
        The inertial directions ``(n, 3)`` (default: the first ``n`` rows of R).
    R : array_like, optional
        The attitude at which ``M = Σ k_i (I − r_i r_iᵀ)``, ``r_i = Rᵀ v_i``, is evaluated (default identity; M
        does not depend on it for three orthogonal directions with equal gains).

    Returns
    -------
    numpy.ndarray
        Shape ``(3,)``: the std of each body-axis component of ``ω̂ − ω`` (rad/s).

    Raises
    ------
    ValueError
        If the number of gains is not the number of reference directions.

    Examples
    --------
    >>> from omegahat import ObserverGains, isotropic_noise_std, predicted_noise_std
    >>> J = [3.0, 2.0, 1.0]
    >>> g = ObserverGains.constant(10.0, 100.0, n=3)
    >>> std = predicted_noise_std(J, g, rate_hz=100.0, measurement_noise=1e-3)
    >>> print(" ".join(f"{s:.4f}" for s in std))  # the light axis (J = 1) is the noisiest
    0.0064 0.0093 0.0174

    With the isotropic correction every axis has (N) of the module docstring:

    >>> iso = ObserverGains(k=[1.0, 1.0, 1.0], l_offset=[100.0] * 3, isotropic_rate=10.0)
    >>> std = predicted_noise_std(J, iso, rate_hz=100.0, measurement_noise=1e-3)
    >>> print(" ".join(f"{s:.5f}" for s in std), f"{isotropic_noise_std(100.0, 1e-3, 10.0):.5f}")
    0.00930 0.00930 0.00930 0.00930
    """
    J = as_inertia(J)
    h = 1.0 / float(as_positive(rate_hz, "rate_hz")[0])
    sigma = float(as_positive(measurement_noise, "measurement_noise")[0])
    v = _geometry(references if references is not None else np.eye(3)[: gains.n])
    if v.shape[0] != gains.n:
        raise ValueError(f"{gains.n} gains were given for {v.shape[0]} reference directions")
    r = v if R is None else v @ np.asarray(R, dtype=float)
    M = sum(gains.k[i] * (np.eye(3) - np.outer(r[i], r[i])) for i in range(gains.n))
    # The rate gain times M: J⁻¹ M for the observer's gain, b I for the isotropic one (b M⁻¹ M).
    GM = np.linalg.inv(J) @ M if gains.isotropic_rate is None else gains.isotropic_rate * np.eye(3)
    G = np.linalg.inv(np.eye(3) + h * GM)
    B = G @ GM
    A = np.block([[G, -B], [np.zeros((3, 3)), np.zeros((3, 3))]])
    C = np.vstack([B, np.eye(3)])
    P = solve_discrete_lyapunov(A, sigma**2 * C @ C.T)
    return np.sqrt(np.diag(P)[:3])


def isotropic_noise_std(rate_hz: float, measurement_noise: float, isotropic_rate: float) -> float:
    """Predicted stationary std per axis of ``ω̂ − ω`` (rad/s) for the isotropic correction.

    Every error mode decays at ``isotropic_rate`` b rad/s (``SarrasEstimator(isotropic_rate=…)``), with white
    attitude noise ``measurement_noise`` (rad per axis) at ``rate_hz``: (N) of the module docstring with
    ``a = h b``, ≈ ``b σ`` when ``a ≪ 1`` and ``√2 σ / h`` (raw differencing) when ``a ≫ 1``.

    Parameters
    ----------
    rate_hz : float
        The sample rate (Hz), ``1/h``.
    measurement_noise : float
        The attitude noise σ (rad per axis, white).
    isotropic_rate : float
        The rate b (rad/s) at which every error mode decays.

    Returns
    -------
    float
        The stationary standard deviation of each component of ``ω̂ − ω`` (rad/s).

    Examples
    --------
    >>> from omegahat import isotropic_noise_std
    >>> print(f"{isotropic_noise_std(100.0, 1e-3, 10.0):.5f}")  # about b σ = 0.01
    0.00930
    >>> print(f"{isotropic_noise_std(100.0, 1e-3, 1e6):.4f}")  # about √2 σ / h = 0.1414
    0.1414
    """
    h = 1.0 / float(as_positive(rate_hz, "rate_hz")[0])
    sigma = float(as_positive(measurement_noise, "measurement_noise")[0])
    a = h * float(as_positive(isotropic_rate, "isotropic_rate")[0])
    g = 1.0 / (1.0 + a)
    return float(sigma * (a / h) / (1.0 + a) * np.sqrt(2.0 / (1.0 + g)))
