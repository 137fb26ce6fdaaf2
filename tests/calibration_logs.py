"""Simulated attitude and gyroscope logs of one body on separate clocks, for the calibration's tests.

The body turns by three Euler angles (intrinsic x, y, z), each a sum of sinusoids; its body rate is the closed form
``ω = R_zᵀ R_yᵀ e₁ ȧ + R_zᵀ e₂ ḃ + e₃ ċ`` (independent of the code under test, which differentiates the attitude
samples by a spline). The gyroscope samples ``A ω(t) + b + noise`` at its own rate and clock.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from omegahat.calibration import Calibration


def euler_motion(seed: int, single_axis: bool = False):
    """``(R(t), ω(t))``: body → inertial and its body rate (module docstring)."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.1, 1.5, (3, 4))
    phase = rng.uniform(0, 2 * np.pi, (3, 4))
    amp = rng.uniform(0.2, 0.8, (3, 4))
    if single_axis:
        amp[1:] = 0.0

    def angles(t):
        arg = 2 * np.pi * f[None] * t[:, None, None] + phase[None]
        return (amp[None] * np.sin(arg)).sum(-1), (amp[None] * 2 * np.pi * f[None] * np.cos(arg)).sum(-1)

    def R(t):
        return Rotation.from_euler("XYZ", angles(t)[0]).as_matrix()

    def omega(t):
        a, ad = angles(t)
        Ry = Rotation.from_euler("Y", a[:, 1:2]).as_matrix()
        Rz = Rotation.from_euler("Z", a[:, 2:3]).as_matrix()
        e = np.eye(3)
        w = np.einsum("nji,nkj,nk->ni", Rz, Ry, ad[:, 0:1] * e[0])
        w += np.einsum("nji,nj->ni", Rz, ad[:, 1:2] * e[1])
        return w + ad[:, 2:3] * e[2]

    return R, omega


def simulated(seed, mode="none", fa=100.0, fg=200.0, duration=30.0, sigma=1e-3, gyro_noise=0.01, single_axis=False):
    """Attitude at ``fa`` Hz with ``sigma`` rad noise, gyro at ``fg`` Hz on a clock ``delta`` s ahead; the truth."""
    rng = np.random.default_rng(seed + 1000)
    R, omega = euler_motion(seed, single_axis)
    delta = rng.uniform(-0.3, 0.3)
    Rc = Rotation.random(random_state=seed).as_matrix()
    b = rng.normal(0, 0.05, 3)
    s = 1 + rng.normal(0, 0.05, 3) if mode != "none" else np.ones(3)
    A = s[:, None] * Rc
    if mode == "matrix":
        A = A + rng.normal(0, 0.02, (3, 3))
    ta = np.arange(0, duration, 1 / fa) + 1.0
    Ra = R(ta) @ Rotation.from_rotvec(rng.normal(0, sigma, (ta.size, 3))).as_matrix()
    tg_true = np.arange(0, duration + 2, 1 / fg) + rng.uniform(0, 1 / fg)
    g = omega(tg_true) @ A.T + b + rng.normal(0, gyro_noise, (tg_true.size, 3))
    return (ta, Ra, tg_true + delta, g), {"delta": delta, "A": A, "Rc": Rc, "b": b, "s": s, "omega": omega}


def z_scores(cal: Calibration, truth: dict) -> list[float]:
    z = [(cal.offset - truth["delta"]) / cal.offset_std, *((cal.bias - truth["b"]) / cal.bias_std)]
    if cal.mode == "matrix":
        return z + list(((cal.matrix - truth["A"]) / cal.matrix_std).ravel())
    phi = Rotation.from_matrix(truth["Rc"] @ cal.rotation.T).as_rotvec()  # truth = Exp(φ) estimate
    z += list(phi / cal.rotation_std)
    if cal.mode == "axes":
        z += list((cal.scale - truth["s"]) / cal.scale_std)
    return z
