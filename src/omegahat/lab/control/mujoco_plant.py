r"""MuJoCo as an independent plant for the closed loop (optional extra ``omegahat[mujoco]``).

The body is a free-floating MuJoCo body (E. Todorov, T. Erez, Y. Tassa, "MuJoCo: A physics engine for model-based
control", IROS 2012; https://mujoco.readthedocs.io) whose inertia about its centre of mass is ``J`` (MuJoCo's
``fullinertia``), with gravity off, contacts disabled and MuJoCo's classical fourth-order Runge–Kutta integrator
(``integrator="RK4"``) at a fixed ``timestep``. Three motors act on the free joint's rotational degrees of freedom
(``gear`` = a unit vector on the joint's angular part), which MuJoCo expresses in the body's own axes: the control
``ctrl = τ`` is a body-axes torque, held over each of MuJoCo's steps, so a torque held over ``[t_k, t_{k+1})``
is the loop's zero-order hold exactly. MuJoCo's state: ``qpos[3:7]`` the attitude as a unit quaternion, scalar
first, body → world (the same convention as :mod:`omegahat.so3` with ``scalar_first=True``); ``qvel[3:6]`` the
angular velocity in body axes.

Nothing of omegahat's integrator is shared: MuJoCo integrates the Newton–Euler equations of its own multibody
formulation and the quaternion with its own exponential map; ``tests/test_control_mujoco.py`` checks that the two
plants agree in torque-free and driven rotation and in closed loop.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from omegahat import so3
from omegahat.validation import as_inertia, as_positive

__all__ = ["MujocoPlant", "model_xml"]


def model_xml(J: ArrayLike, timestep: float) -> str:
    """The MJCF model of the module docstring for the inertia ``J`` and the step ``timestep`` (s)."""
    Jm = as_inertia(J)
    full = " ".join(f"{v:.17g}" for v in (Jm[0, 0], Jm[1, 1], Jm[2, 2], Jm[0, 1], Jm[0, 2], Jm[1, 2]))
    motors = "\n".join(
        f'    <motor name="tau_{a}" joint="free" gear="0 0 0 {" ".join("1" if i == j else "0" for j in range(3))}"/>'
        for i, a in enumerate("xyz")
    )
    return f"""<mujoco model="omegahat rigid body">
  <option gravity="0 0 0" integrator="RK4" timestep="{timestep:.17g}">
    <flag contact="disable"/>
  </option>
  <worldbody>
    <body name="body">
      <freejoint name="free"/>
      <inertial pos="0 0 0" mass="1" fullinertia="{full}"/>
    </body>
  </worldbody>
  <actuator>
{motors}
  </actuator>
</mujoco>
"""


class MujocoPlant:
    """The MuJoCo body of the module docstring; implements :class:`omegahat.lab.control.closed_loop.Plant`.

    ``timestep`` (s) must divide every hold interval ``h`` given to :meth:`advance` (to 1e-9 relative)."""

    def __init__(self, J: ArrayLike, timestep: float = 1e-3) -> None:
        import mujoco  # the optional extra: imported only when a MuJoCo plant is built

        self._mujoco = mujoco
        self.timestep = float(as_positive(timestep, "timestep")[0])
        self.model = mujoco.MjModel.from_xml_string(model_xml(J, self.timestep))
        self.data = mujoco.MjData(self.model)
        self.reset(np.eye(3), np.zeros(3))

    def reset(self, R0: np.ndarray, omega0: np.ndarray) -> None:
        self._mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[3:7] = so3.to_quat(np.asarray(R0, dtype=float), scalar_first=True)
        self.data.qvel[3:6] = np.asarray(omega0, dtype=float)
        self._mujoco.mj_forward(self.model, self.data)

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        R = so3.from_quat(np.array(self.data.qpos[3:7]), scalar_first=True)
        return R, np.array(self.data.qvel[3:6])

    def advance(self, tau: np.ndarray, h: float) -> None:
        steps = h / self.timestep
        n = round(steps)
        if n < 1 or not math.isclose(steps, n, rel_tol=1e-9):
            raise ValueError(f"the hold interval {h!r} s is not a whole number of MuJoCo steps of {self.timestep!r} s")
        self.data.ctrl[:] = np.asarray(tau, dtype=float)
        for _ in range(n):
            self._mujoco.mj_step(self.model, self.data)
