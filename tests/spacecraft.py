"""A spacecraft slewing under torques its controller commands, for the tests and benchmarks of ``--torque``: the
truth integrated by SciPy's ``solve_ivp`` over each command's interval (Euler's equations and the quaternion's
kinematics, an integrator independent of omegahat's), and the files a spacecraft engineer would have (the star
tracker's attitude as a CCSDS AEM, the commands as a CSV on the same clock)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp
from scipy.spatial.transform import Rotation

from omegahat.io.aem import epoch_text

J = np.diag([300.0, 250.0, 200.0])  #: kg m², the spacecraft's inertia
EPOCH_NS = 1_767_225_600 * 10**9  #: 2026-01-01T00:00:00 UTC, the logs' first time
COMMAND_STEP = 0.1  #: s between the controller's commands, each held until the next


def commands(seconds: float, amplitude: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """``(times (K,) s, torques (K, 3) N m)``: a bang-bang slew about x and slow sinusoids about y and z."""
    t = np.arange(0.0, seconds, COMMAND_STEP)
    tau = amplitude * np.column_stack(
        [np.sign(np.sin(2 * np.pi * t / 60)), np.sin(2 * np.pi * t / 45), np.cos(2 * np.pi * t / 80)]
    )
    return t, tau


def _rhs(_, y, u, Jd):
    q, w = y[:4], y[4:]
    x, yv, z, s = q  # scalar last; body rates: dq/dt = q ⊗ (w/2, 0)
    qdot = 0.5 * np.array(
        [
            s * w[0] + yv * w[2] - z * w[1],
            s * w[1] + z * w[0] - x * w[2],
            s * w[2] + x * w[1] - yv * w[0],
            -(x * w[0] + yv * w[1] + z * w[2]),
        ]
    )
    return np.concatenate([qdot, (u - np.cross(w, Jd * w)) / Jd])


def slew(samples: np.ndarray, command_t: np.ndarray, tau: np.ndarray) -> tuple[Rotation, np.ndarray]:
    """The true attitude (body → inertial) and body rate (rad/s) at ``samples`` (s, within the commands' span),
    each command ``tau[k]`` held over ``[command_t[k], command_t[k] + COMMAND_STEP)``."""
    y = np.concatenate([Rotation.from_rotvec([0.3, -0.2, 0.5]).as_quat(), [0.01, -0.02, 0.015]])
    out = np.full((samples.size, 7), np.nan)
    for a, u in zip(command_t, tau, strict=True):
        inside = np.flatnonzero((samples >= a - 1e-9) & (samples < a + COMMAND_STEP - 1e-9))
        sol = solve_ivp(_rhs, (a, a + COMMAND_STEP), y, args=(u, np.diag(J)), rtol=1e-11, atol=1e-13, dense_output=True)
        if inside.size:
            out[inside] = sol.sol(samples[inside]).T
        y = sol.y[:, -1]
        y[:4] /= np.linalg.norm(y[:4])
    return Rotation.from_quat(out[:, :4]), out[:, 4:]


def write_aem(path: Path, t: np.ndarray, attitude: Rotation) -> Path:
    """The attitude at ``t`` (s after :data:`EPOCH_NS`) as a CCSDS AEM 2.0: EME2000 → SC_BODY_1, scalar last."""
    lines = [
        "CCSDS_AEM_VERS = 2.0", "META_START", "REF_FRAME_A = EME2000", "REF_FRAME_B = SC_BODY_1", "TIME_SYSTEM = UTC",
        "ATTITUDE_TYPE = QUATERNION", "META_STOP",
        *(
            epoch_text(EPOCH_NS + round(s * 1e9)) + " " + " ".join(repr(float(v)) for v in q)
            for s, q in zip(t, attitude.as_quat(), strict=True)
        ),
    ]  # fmt: skip
    path.write_text("\n".join(lines) + "\n")
    return path


def write_torques(path: Path, t: np.ndarray, tau: np.ndarray, header: str = "t,tau_x,tau_y,tau_z") -> Path:
    """A torque log: ``header`` and one row per time ``t`` (as given) of ``tau (K, 3)``."""
    rows = (f"{a!r},{x!r},{y!r},{z!r}\n" for a, (x, y, z) in zip(t.tolist(), tau.tolist(), strict=True))
    path.write_text(header + "\n" + "".join(rows))
    return path
