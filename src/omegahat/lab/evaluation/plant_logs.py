r"""Logs of an independent plant for the development corpus: a rigid body simulated by MuJoCo, with its truth.

The body (:class:`omegahat.lab.control.mujoco_plant.MujocoPlant`: MuJoCo's own Newton–Euler equations and RK4, no
code of omegahat's integrators) has the inertia :data:`J_PLANT` and is driven by a smooth known torque
(:func:`smooth_torque`: per axis a sum of four sinusoids between 0.05 and 0.5 Hz), evaluated at the midpoint of each
MuJoCo step of :data:`TIMESTEP`, so that the log's torque is a sample of a continuous signal, not the estimator's
zero-order hold. The truth is MuJoCo's body rate every millisecond.

:func:`plant_grid` makes, from one 60 s trajectory, the grid of issue 24: sample rates 1 kHz, 100 Hz and 10 Hz (every
1st, 10th, 100th millisecond); a quaternion, or two body-frame directions of :data:`REFERENCES`; clean, or noisy
(:data:`QUAT_NOISE` rad per axis on the attitude, :data:`DIRECTION_NOISE` rad per axis on the two directions, as
small rotations ``b̃ = Exp(σ n) b`` with ``n ~ N(0, I)``); the torque given to the estimator or not (the inertia always
given). Three of them are the issue's cases: (a) ``plant-100hz-dirs-noisy-tau``, (b) ``plant-1000hz-quat-clean-tau``,
(c) ``plant-100hz-quat-clean-tau``. :func:`varying_motion` is case (d): 100 Hz quaternions with 1 mrad noise of a
motion whose intensity changes every 10 s (quiet, brisk, a 12 Hz vibration on a slow turn, slow, brisk, quiet),
neither J nor the torque
given (a body whose model is unknown, as a user's).

Every log is scored from :data:`SETTLE_S` on (``movement``), without the low-pass and without a time shift.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3
from omegahat.lab.evaluation.corpus import Recording

__all__ = [
    "DIRECTION_NOISE",
    "DURATION_S",
    "J_PLANT",
    "QUAT_NOISE",
    "REFERENCES",
    "SETTLE_S",
    "TIMESTEP",
    "plant_grid",
    "simulate",
    "smooth_torque",
    "varying_motion",
]

J_PLANT = np.array([[3.0, 0.1, -0.05], [0.1, 2.0, 0.08], [-0.05, 0.08, 1.5]])  #: kg·m², not diagonal
TIMESTEP = 2.5e-4  #: s, MuJoCo's RK4 step (four per millisecond)
DURATION_S = 60.0
SETTLE_S = 5.0  #: samples before this are the start-up, not scored
QUAT_NOISE = 1e-3  #: rad per axis
DIRECTION_NOISE = (0.01, 0.005)  #: rad per axis, for the two directions (issue 24, case a)
#: the two inertial directions: up, and BROAD's magnetic field direction (NOTICE.md)
REFERENCES = np.array([[0.0, 0.0, 1.0], np.array([-0.9, 15.5, -41.3]) / np.linalg.norm([-0.9, 15.5, -41.3])])
RATES = {1000: 1, 100: 10, 10: 100}  #: log rate (Hz) → every n-th millisecond
_SCORE = {"cutoff_hz": "none", "max_shift": 0, "gap_margin_s": 1.0}
_SOURCE = "omegahat's independent plant: MuJoCo rigid body (omegahat.lab.evaluation.plant_logs)"


TorqueFunction = Callable[[ArrayLike], np.ndarray]  #: ``τ(t)``: times ``(T,)`` → torques ``(T, 3)``, N·m


def smooth_torque(seed: int, amplitude: float = 0.4) -> TorqueFunction:
    """``τ(t)`` (N·m, body axes), ``(T,) → (T, 3)``: per axis four sinusoids, 0.05–0.5 Hz, random phases."""
    rng = np.random.default_rng(seed)
    f = rng.uniform(0.05, 0.5, (3, 4))
    phase = rng.uniform(0.0, 2 * np.pi, (3, 4))
    a = amplitude * rng.uniform(0.5, 1.0, (3, 4))

    def tau(t: ArrayLike) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.sum(a[None] * np.sin(2 * np.pi * f[None] * t[:, None, None] + phase[None]), axis=-1)

    return tau


def _varying_torque(seed: int, inertia: float = 2.0) -> TorqueFunction:
    """Every 10 s a different motion (module docstring), each a sinusoid per axis of rate amplitude ``W`` at ``f``
    (torque ``W J̄ 2π f``), with a 12 Hz vibration of 0.3 rad/s in the third segment; the segments' envelopes
    overlap by 1 s raised cosines."""
    rng = np.random.default_rng(seed)
    segments = [(0.02, 0.2), (3.0, 2.0), (0.5, 0.3), (1.0, 0.1), (2.0, 3.0), (0.02, 0.2)]  # (W rad/s, f Hz)
    phase = rng.uniform(0.0, 2 * np.pi, (len(segments) + 1, 3))
    axes = np.array([1.0, 1.3, 0.7])  # a different frequency per axis

    def envelope(t, centre):
        return 0.5 * (1 + np.cos(np.pi * np.clip(np.abs(t - centre) - 4.5, 0, 1)))  # 1 within 4.5 s, 0 beyond 5.5

    def tau(t: ArrayLike) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.zeros((t.size, 3))
        for i, (W, f) in enumerate(segments):
            amp = W * inertia * 2 * np.pi * f * axes
            out += envelope(t, 10 * i + 5)[:, None] * amp * np.sin(2 * np.pi * f * axes * t[:, None] + phase[i])
        vib = 0.3 * inertia * 2 * np.pi * 12.0
        return out + envelope(t, 25)[:, None] * vib * np.sin(2 * np.pi * 12.0 * t[:, None] + phase[-1])

    return tau


def simulate(
    torque: TorqueFunction, J: ArrayLike = J_PLANT, duration: float = DURATION_S, seed: int = 0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The plant driven by ``torque(t)`` from a random attitude and rate ``(0.5, −0.3, 0.4)`` rad/s: ``(t, R, ω,
    τ)`` every millisecond (``τ`` sampled at those instants)."""
    from omegahat.lab.control.mujoco_plant import MujocoPlant

    rng = np.random.default_rng(seed)
    plant = MujocoPlant(J, timestep=TIMESTEP)
    plant.reset(so3.exp(rng.normal(0.0, 1.0, 3)), np.array([0.5, -0.3, 0.4]))
    n = round(duration * 1000) + 1
    per = round(1e-3 / TIMESTEP)
    t = np.arange(n) * 1e-3
    R, w = np.empty((n, 3, 3)), np.empty((n, 3))
    mid = torque((t[:-1, None] + (np.arange(per)[None, :] + 0.5) * TIMESTEP).ravel()).reshape(n - 1, per, 3)
    for k in range(n):
        R[k], w[k] = plant.state()
        if k < n - 1:
            for j in range(per):
                plant.advance(mid[k, j], TIMESTEP)
    return t, R, w, torque(t)


def _noisy_quaternions(R: np.ndarray, sigma: float, rng) -> np.ndarray:
    if sigma > 0:
        R = R @ so3.exp(rng.normal(0.0, sigma, (R.shape[0], 3)))
    return so3.to_quat(R)


def _directions(R: np.ndarray, sigmas, rng) -> np.ndarray:
    b = np.einsum("tji,nj->tni", R, REFERENCES)  # b_i = Rᵀ v_i
    for i, s in enumerate(sigmas):
        if s > 0:
            b[:, i] = np.einsum("tij,tj->ti", so3.exp(rng.normal(0.0, s, (R.shape[0], 3))), b[:, i])
    return b


def _recording(name, t, data, kind, truth_t, truth_w, meta, torque=None, inertia=None) -> Recording:
    return Recording(
        name, t, kind, data, truth_t, truth_w, t >= SETTLE_S, meta, REFERENCES if kind == "directions" else None,
        torque, inertia,
    )  # fmt: skip


def _command(name: str, kind: str, inertia: bool) -> str:
    refs = ' "--references=' + ";".join(",".join(f"{v:.17g}" for v in r) for r in REFERENCES) + '"'
    J = " --inertia " + " ".join(f"{v:g}" for v in J_PLANT.ravel())
    return f"omegahat estimate {name}.csv -o out.csv" + (J if inertia else "") + (refs if kind == "directions" else "")


def plant_grid(seed: int = 0) -> list[Recording]:
    """The 24 logs of the module docstring, from one trajectory."""
    t, R, w, tau = simulate(smooth_torque(seed), seed=seed)
    rng = np.random.default_rng(seed + 1)
    cases = {
        "plant-100hz-dirs-noisy-tau": "issue 24 case (a)",
        "plant-1000hz-quat-clean-tau": "issue 24 case (b)",
        "plant-100hz-quat-clean-tau": "issue 24 case (c)",
    }
    out = []
    for rate, step in RATES.items():
        pick = slice(None, None, step)
        for kind in ("quat", "dirs"):
            for noisy in (False, True):
                if kind == "quat":
                    data = _noisy_quaternions(R[pick], QUAT_NOISE if noisy else 0.0, rng)
                    noise = f"{QUAT_NOISE:g} rad per axis" if noisy else "none"
                else:
                    data = _directions(R[pick], DIRECTION_NOISE if noisy else (0.0, 0.0), rng)
                    noise = f"{DIRECTION_NOISE} rad per axis" if noisy else "none"
                for known in (True, False):
                    name = f"plant-{rate}hz-{kind}-{'noisy' if noisy else 'clean'}-{'tau' if known else 'notau'}"
                    meta = {
                        "source": _SOURCE,
                        "licence": "generated by omegahat (same licence as the project)",
                        "description": f"{rate} Hz {'quaternions' if kind == 'quat' else 'two directions'}, noise "
                        f"{noise}, J given, torque {'given' if known else 'applied but not given'}; "
                        + cases.get(name, "grid of issue 24's acceptance"),
                        "score": _SCORE,
                        "truth": True,
                        "command": _command(name, "quaternion" if kind == "quat" else "directions", True),
                    }
                    out.append(
                        _recording(
                            name,
                            t[pick],
                            data,
                            "quaternion" if kind == "quat" else "directions",
                            t,
                            w,
                            meta,
                            tau[pick] if known else None,
                            J_PLANT,
                        )
                    )
    return out


def varying_motion(seed: int = 0) -> Recording:
    """Case (d) of the module docstring."""
    t, R, w, _ = simulate(_varying_torque(seed), seed=seed + 100)
    rng = np.random.default_rng(seed + 101)
    name = "plant-100hz-quat-1mrad-varying"
    meta = {
        "source": _SOURCE,
        "licence": "generated by omegahat (same licence as the project)",
        "description": "issue 24 case (d): 100 Hz quaternions, 1 mrad per axis, motion changing every 10 s (quiet, "
        "brisk, 12 Hz vibration, slow, brisk, quiet); neither J nor the torque given",
        "score": _SCORE,
        "truth": True,
        "command": f"omegahat estimate {name}.csv -o out.csv",
    }
    return _recording(name, t[::10], _noisy_quaternions(R[::10], QUAT_NOISE, rng), "quaternion", t, w, meta)
