r"""The gyro-less MEKF over a whole log in one Numba call: :meth:`omegahat.baselines.mekf.MEKF.run`'s loop.

:meth:`omegahat.baselines.mekf.MEKF.run` checks the log (:func:`omegahat.measurements.checked_log`) and hands it to
:func:`run_log`, which applies, sample by sample, the compiled step of :mod:`omegahat.kernels.ekf` — the equations
(E3)–(E8) of :mod:`omegahat.baselines.mekf` ((K1)–(K4) there), the same functions omegahat's default estimator
runs. The first valid fix initialises R̂: the sample itself, or Wahba's least-squares attitude from the directions
(``wahba`` of :mod:`omegahat.kernels.rotation`, unit weights). ``tests/test_mekf.py`` checks that ``run`` equals a
loop of ``MEKF.update`` (the NumPy path) to 1e-10 relative, with torques (held and linear), directions, skipped
samples and gaps of several substeps. All arrays are C-contiguous float64.

**The guard.** A step whose result is not finite (a gap or a torque too large for the model, a diverged filter)
is not kept: the filter restarts from that sample (:func:`omegahat.kernels.ekf.ekf_finite`) with its prior
``(ω̂₀, P₀)``, its attitude from the sample when it is a valid fix (else from the next one), and that sample's
estimate is NaN (no estimate); the restarts are counted.
"""

from __future__ import annotations

import numba
import numpy as np

from omegahat.kernels.ekf import (
    EKF_SCRATCH,
    LOGDET_SLOT,
    ekf_attitude_update,
    ekf_finite,
    ekf_propagate,
    ekf_vector_update,
)
from omegahat.kernels.rotation import wahba

__all__ = ["run_log"]


@numba.njit(cache=True, error_model="numpy")
def run_log(
    times, meas, valid, torques, references, directions, dynamic, J, J_inv, q, meas_var, max_step, max_angle,
    linear_hold, q_a, state, R, P, tau, omega0, P0, likelihood, rate_covariances, max_rate=np.inf,
):  # fmt: skip
    """``MEKF.update`` over a checked log. ``meas``: rotation matrices ``(T, 3, 3)`` or unit directions
    ``(T, n, 3)``; ``valid`` the usable samples. The filter's state goes in and comes out: ``state = [t_prev,
    has_t, has_R, ω̂ (3), â (3)]`` (updated in place), ``R`` (ignored while ``has_R`` is 0), ``P`` (6×6, or 9×9
    with the unknown acceleration ``â`` of PSD ``q_a``), ``tau`` the torque given with the sample at ``t_prev``.
    ``omega0``, ``P0``: the prior a restart takes (module docstring). ``likelihood`` (4 floats, updated in place):
    ``[fixes to leave out, Σ log det S, Σ ν, degrees of freedom]`` of the fixes' innovations (the first
    ``likelihood[0]`` fixes, a diffuse prior's, are counted down and left out). Returns ``(ω̂ (T, 3), R, P,
    n_skipped, n_restarts)``; ``rate_covariances`` ``(T, 3, 3)`` receives the rate block of P after each sample
    (``(0, 3, 3)``: not kept; NaN where the filter restarted). ``max_rate`` (rad/s): a fix that leaves |ω̂| above it
    ends the run, the rest of ``ω̂`` NaN and ``likelihood[2]`` infinite (the identification's passes of a kinematic
    model: a rate beyond half a turn per step is an alias the filter has locked onto, not a model of the log)."""
    T = times.size
    out = np.empty((T, 3))
    R, P, tau = R.copy(), P.copy(), tau.copy()
    omega = state[3:6].copy()
    accel = state[6:9].copy()
    t_prev, has_t, has_R = state[0], state[1] != 0.0, state[2] != 0.0
    n_skipped = 0
    n_restarts = 0
    weights = np.ones(references.shape[0])
    scratch = np.empty(EKF_SCRATCH)
    for j in range(T):
        if has_t and has_R:  # (E4) with the previous sample's torque held, or the line to this sample's
            tau_end = torques[j] if linear_hold else tau
            ekf_propagate(
                R, omega, accel, P, times[j] - t_prev, tau, tau_end, J, J_inv, q, q_a, dynamic, max_step, max_angle
            )
        finite = ekf_finite(R, omega, accel, P)
        if finite:
            if not valid[j]:
                n_skipped += 1
            elif not has_R:  # the first fix initialises the attitude
                R = wahba(weights, references, meas[j]) if directions else meas[j].copy()
                has_R = True
            else:
                if directions:
                    nis = ekf_vector_update(R, omega, accel, P, meas[j], references, meas_var, scratch)
                else:
                    nis = ekf_attitude_update(R, omega, accel, P, meas[j], meas_var, scratch)
                if likelihood[0] > 0.0:
                    likelihood[0] -= 1.0
                else:
                    likelihood[1] += scratch[LOGDET_SLOT]
                    likelihood[2] += nis
                    likelihood[3] += 3.0 * (references.shape[0] if directions else 1)
            finite = ekf_finite(R, omega, accel, P)
            if finite and omega[0] ** 2 + omega[1] ** 2 + omega[2] ** 2 > max_rate * max_rate:
                likelihood[2] = np.inf
                for i in range(j, T):
                    for c in range(3):
                        out[i, c] = np.nan
                break
        t_prev = times[j]
        has_t = True
        tau = torques[j].copy()
        for c in range(3):
            out[j, c] = omega[c]
        if rate_covariances.shape[0] > 0:
            for a in range(3):
                for b in range(3):
                    rate_covariances[j, a, b] = P[3 + a, 3 + b] if finite else np.nan
        if not finite:  # the guard: restart from this sample with the prior
            n_restarts += 1
            for c in range(3):  # element loops, not slice assignments (which compile a shape check's message)
                omega[c] = omega0[c]
                accel[c] = 0.0
            for a in range(P.shape[0]):
                for b in range(P.shape[1]):
                    P[a, b] = P0[a, b]
            has_R = valid[j]
            if has_R:
                R = wahba(weights, references, meas[j]) if directions else meas[j].copy()
            out[j, :] = np.nan
    state[0], state[1], state[2] = t_prev, 1.0 if has_t else 0.0, 1.0 if has_R else 0.0
    for c in range(3):
        state[3 + c] = omega[c]
        state[6 + c] = accel[c]
    return out, R, P, n_skipped, n_restarts
