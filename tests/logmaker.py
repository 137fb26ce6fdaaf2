"""Logs with a known rate for the CLI tests: closed-form attitudes, written the way logging tools write them.

The attitude is ``R(t) = Rz(α) Ry(β) Rx(γ)`` (yaw, pitch, roll) with each angle a sum of sinusoids plus a ramp,
so the body rate has a closed form (the standard ZYX kinematics)::

    ω = (γ̇ − α̇ sin β,  β̇ cos γ + α̇ cos β sin γ,  −β̇ sin γ + α̇ cos β cos γ)

and, for a body of inertia J, the torque that makes this motion is ``τ = J ω̇ + ω × (J ω)`` (ω̇ by a central
difference of the closed form with step 1e-6 s: error ~1e-12).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


class Angle:
    """``c t + Σ a_i sin(2π f_i t + p_i)`` and its derivative."""

    def __init__(self, ramp=0.0, terms=()):
        self.ramp, self.terms = ramp, tuple(terms)

    def __call__(self, t):
        return self.ramp * t + sum(a * np.sin(2 * np.pi * f * t + p) for a, f, p in self.terms)

    def rate(self, t):
        return self.ramp + sum(2 * np.pi * f * a * np.cos(2 * np.pi * f * t + p) for a, f, p in self.terms)


def attitude(t, yaw: Angle, pitch: Angle, roll: Angle) -> tuple[Rotation, np.ndarray]:
    """``(R(t) body → inertial, ω(t) body axes)``."""
    a, b, g = yaw(t), pitch(t), roll(t)
    da, db, dg = yaw.rate(t), pitch.rate(t), roll.rate(t)
    rot = Rotation.from_euler("ZYX", np.column_stack([a, b, g]))
    w = np.column_stack(
        [dg - da * np.sin(b), db * np.cos(g) + da * np.cos(b) * np.sin(g), -db * np.sin(g) + da * np.cos(b) * np.cos(g)]
    )
    return rot, w


def torque(t, J, yaw, pitch, roll, eps=1e-6):
    """``J ω̇ + ω × (J ω)`` along the motion."""
    w = attitude(t, yaw, pitch, roll)[1]
    wd = (attitude(t + eps, yaw, pitch, roll)[1] - attitude(t - eps, yaw, pitch, roll)[1]) / (2 * eps)
    return wd @ J.T + np.cross(w, w @ J.T)


def noisy(rot: Rotation, sigma: float, seed: int = 0) -> Rotation:
    """``R exp(δ×)`` with δ white, std ``sigma`` per axis (body-frame attitude noise)."""
    rng = np.random.default_rng(seed)
    return rot * Rotation.from_rotvec(rng.normal(0.0, sigma, (len(rot), 3)))


def constant_rate(t, omega, sigma=0.0, seed=0) -> Rotation:
    """``R0 exp(t ω×)`` (exact motion of a body at constant rate), optionally noisy."""
    rot = Rotation.from_rotvec([0.2, -0.3, 0.5]) * Rotation.from_rotvec(np.outer(t, omega))
    return noisy(rot, sigma, seed) if sigma else rot


def write_csv(path, t, rot: Rotation, tau=None, header=("t", "qw", "qx", "qy", "qz"), sep=",", t_scale=1.0):
    """A quaternion log with 17 significant digits (``repr``), columns named by ``header`` (t, w, x, y, z order)."""
    q = rot.as_quat()  # x, y, z, w
    cols = [t * t_scale, q[:, 3], q[:, 0], q[:, 1], q[:, 2]]
    names = list(header)
    if tau is not None:
        cols += [tau[:, 0], tau[:, 1], tau[:, 2]]
        names += ["tau_x", "tau_y", "tau_z"]
    rows = np.column_stack(cols)
    with open(path, "w") as f:
        f.write(sep.join(names) + "\n")
        for r in rows:
            f.write(sep.join(repr(float(x)) for x in r) + "\n")
    return path


def read_output(path):
    """``(t, ω (T, 3), status words)`` of an ``omegahat estimate`` output."""
    lines = path.read_text().splitlines()
    assert lines[0] == "t,wx,wy,wz,status"
    fields = [line.split(",") for line in lines[1:]]
    t = np.array([float(f[0]) for f in fields])
    w = np.array([[float(x) for x in f[1:4]] for f in fields])
    return t, w, [f[4] for f in fields]


def rms(err) -> float:
    """RMS of ``|err|`` over rows that have an estimate."""
    e = np.linalg.norm(err, axis=1)
    return float(np.sqrt(np.mean(e[np.isfinite(e)] ** 2)))


def convolved(differences: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """(D4) over one stretch by NumPy's convolution; its first L − 1 rows as they are."""
    out = differences.copy()
    L = taps.shape[0]
    if differences.shape[0] >= L:
        for j in range(3):
            out[L - 1 :, j] = np.convolve(differences[:, j], taps[:, j], mode="valid")
    return out


def two_passes(differences: np.ndarray, h: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """(D5) over one stretch by NumPy's convolution: (D4) again over the differences less ``(h/12) ω̃_{k−1} × ω̃_k``
    of (D4)'s first pass (none at the stretch's first difference); its first L − 1 rows the differences."""
    first = convolved(differences, taps)
    corrected = differences.copy()
    corrected[1:] -= (h[1:, None] / 12.0) * np.cross(first[:-1], first[1:])
    out = convolved(corrected, taps)
    out[: taps.shape[0] - 1] = differences[: taps.shape[0] - 1]
    return out


class DiscardWriter:
    """A writer for :func:`omegahat.io.pipeline.estimate_stream` that keeps nothing: for tests of its summary."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def write(self, chunk, omega, status):
        pass


class KeepWriter(DiscardWriter):
    """A writer for :func:`omegahat.io.pipeline.estimate_stream` that keeps every row's label, rate and status."""

    def __init__(self):
        self.labels, self.omega, self.status = [], [], []

    def write(self, chunk, omega, status):
        self.labels.append(chunk.labels.copy())
        self.omega.append(omega.copy())
        self.status.append(status.copy())

    def rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(labels, omega, status)`` of every row written, in order."""
        return np.concatenate(self.labels), np.concatenate(self.omega), np.concatenate(self.status)


def turning_axis_log(gap_seconds: float, fs: float = 240.0):
    """12 s of ``R(t) = Exp(A t) Exp(B t)`` (rate ``Exp(−B t) A + B``, closed form: a smooth motion whose rate turns
    at 2 rad/s) at ``fs`` with 0.25 mrad of noise, the samples from 5 s on missing for ``gap_seconds``."""
    a, b = np.array([1.4, -0.6, 1.0]), np.array([0.4, 1.8, -0.8])
    t = np.arange(0.0, 12.0, 1.0 / fs)
    turn = Rotation.from_rotvec(np.outer(t, a)) * Rotation.from_rotvec(np.outer(t, b))
    noise = Rotation.from_rotvec(2.5e-4 * np.random.default_rng(3).standard_normal((t.size, 3)))
    q = (turn * noise).as_quat()
    q[(t >= 5.0) & (t < 5.0 + gap_seconds)] = np.nan
    return t, q, Rotation.from_rotvec(-np.outer(t, b)).apply(a) + b
