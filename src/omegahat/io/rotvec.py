r"""Attitude logged as a rotation vector: columns ``rotvec_x, rotvec_y, rotvec_z`` (radians), axis times angle.

Robot controllers write an orientation this way (a Universal Robots pose is ``x, y, z, rx, ry, rz``, the last three
a rotation vector: :mod:`omegahat.io.ur_rtde`), as do SciPy's :meth:`~scipy.spatial.transform.Rotation.as_rotvec`
and Vicon's helical angles (:mod:`omegahat.io.mocap`). The vector :math:`\varphi = \theta\,a` (unit axis
:math:`a`, angle :math:`\theta = |\varphi|`) is the rotation

.. math::

   R = \exp(\varphi_\times) = I + \frac{\sin\theta}{\theta}\,\varphi_\times
       + \frac{1 - \cos\theta}{\theta^2}\,\varphi_\times^2 ,   \tag{V1}

which maps body to inertial (:math:`v_\text{inertial} = R\,v_\text{body}`) unless ``--rotation inertial-to-body``
says otherwise. Unlike Euler angles the vector needs no sequence, so nothing has to be asked; the unit is radians
(a log whose vectors reach beyond a turn gets a note that they may be degrees). Near a half turn a writer may jump
from :math:`\varphi` to :math:`\varphi - 2\pi a`: the vector changes, the rotation (V1) does not, so the jump is no
spike. A sample with an empty or non-finite component is a missing sample.

The names are explicit because ``rx, ry, rz`` say nothing of what they hold: Universal Robots and Vicon mean a
rotation vector, other exports Euler angles. A log with only those columns is refused with the two column maps that
read it (:func:`omegahat.io.columns.layout`).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omegahat import so3
from omegahat.io.euler import turned_into_matrices

__all__ = ["matrices", "vectors_as_matrices"]


def matrices(vectors: np.ndarray) -> np.ndarray:
    """(V1): the rotation matrices ``(T, 3, 3)`` of rotation vectors ``(T, 3)`` in radians; a row with a non-finite
    component gives a matrix of NaN (a missing sample)."""
    vectors = np.asarray(vectors, dtype=float)
    ok = np.all(np.isfinite(vectors), axis=1)
    out = np.full((len(vectors), 3, 3), np.nan)
    if ok.any():
        out[ok] = so3.exp(vectors[ok])
    return out


def vectors_as_matrices(stream: Any) -> None:
    """Make ``stream`` (a :class:`~omegahat.io.registry.LogStream`; that module imports this one) of kind
    ``"rotvec"`` (chunks of rotation vectors ``(m, 3)``) a stream of rotation matrices by (V1); other streams are
    left as they are."""
    if stream.kind != "rotvec":
        return
    stream.notes.append(f"attitude: rotation vector {stream.attitude_name} in radians (axis times angle)")
    turned_into_matrices(
        stream,
        matrices,
        lambda vectors: np.linalg.norm(vectors, axis=1),
        "rotation vectors up to {largest:.4g} long read as radians: more than a turn; a rotation vector's angle is "
        "in radians (if these are degrees, convert them first)",
    )
