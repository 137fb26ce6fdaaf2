"""The messages for rejected samples: one table of words, whichever estimator (or ``omegahat estimate``) rejects.

A sample that is present but wrong (not a rotation, a reflection, a quaternion far from unit norm, a zero
direction, a time that is not finite or not after the previous one, a torque that is not finite) is refused with a
:class:`MeasurementError` whose message :func:`describe_rejection` writes from the compiled check's status code and
the offending value (:mod:`omegahat.kernels.checks`). The message names the sample, its time, the quantity, its value
and the remedy: the option that would accept the sample with a suggested value (:func:`suggested_tolerance`), spelt
as the caller spells its options (:func:`python_option` for Python; the command passes its flags' spelling).
:mod:`omegahat.measurements` re-exports these names beside the checks that produce the status codes.
"""

from __future__ import annotations

from collections.abc import Callable

from omegahat.kernels.checks import (
    NOT_ORTHOGONAL,
    NOT_PROPER,
    QUAT_NORM,
    TIME_NOT_FINITE,
    TIME_ORDER,
    TORQUE_NOT_FINITE,
    ZERO_DIRECTION,
)

__all__ = ["MeasurementError", "describe_rejection", "python_option", "rejection_error", "suggested_tolerance"]


class MeasurementError(ValueError):
    """A sample that is present but invalid: not a rotation, a time going backwards, a torque that is not finite.

    Raised by every estimator's ``run`` and ``update`` and by the log readers, with the message of
    :func:`describe_rejection`: the sample, its time, the quantity, its value and the remedy. It is a
    ``ValueError``, so code that catches ``ValueError`` catches it too. A missing sample (NaN or inf in the
    measurement) is not an error: the estimators skip it.

    See Also
    --------
    describe_rejection : the message a rejected sample gets.

    Examples
    --------
    A reflection (``det R = -1``) is refused, whichever estimator meets it:

    >>> import numpy as np
    >>> from omegahat import DifferencingEstimator, MeasurementError
    >>> R = np.tile(np.eye(3), (4, 1, 1))
    >>> R[2] = np.diag([1.0, 1.0, -1.0])
    >>> try:
    ...     DifferencingEstimator().run(np.arange(4) * 0.01, R)
    ... except MeasurementError as error:
    ...     print(error)
    sample 2 (t = 0.02): a reflection, not a rotation: det R = -1 < 0
    """


def python_option(key: str, value: object = None) -> str:
    """An option as Python spells it in a message: ``rotation_tol`` (no value) or ``rotation_tol=0.02``."""
    return key if value is None else f"{key}={value!r}"


def suggested_tolerance(status: int, info: float) -> tuple[str, float] | None:
    """The tolerance option that would accept a sample rejected with ``(status, info)`` and a value for it (twice the
    sample's own excess, to 2 significant digits), or None when no tolerance would (a reflection, a zero direction,
    times and torques)."""
    if status == NOT_ORTHOGONAL:
        return "rotation_tol", float(f"{2 * float(info):.2g}")
    if status == QUAT_NORM:
        return "quat_norm_tol", float(f"{2 * abs(float(info) - 1):.2g}")
    return None


def describe_rejection(
    status: int,
    info: float,
    where: str,
    t: float | None = None,
    *,
    option: Callable[[str, object], str] = python_option,
    skip: bool = False,
    tolerances: tuple[float, float] | None = None,
) -> str:
    """The message for a rejected sample, the same whichever estimator (or ``omegahat estimate``) rejects it.

    ``where`` names the sample (``"sample 3"``, ``"the sample"``, ``"line 5, columns qw..qz"``); ``t`` is its time
    (needed for the time checks; for the others it is printed after ``where`` when given). The remedy names the
    options as ``option(key, value)`` spells them (default :func:`python_option`; the command passes its flags'
    spelling), with a suggested tolerance that would accept the sample; ``skip``: also name ``skip_bad_samples``;
    ``tolerances``: the ``(rotation_tol, quat_norm_tol)`` in force, printed with their names.
    """
    info = float(info)
    label = where if t is None else f"{where} (t = {float(t)!r})"
    t_text = repr(float(info if t is None else t))
    rot_tol, quat_tol = (None, None) if tolerances is None else tolerances
    other = f", or {option('skip_bad_samples', True)} to skip such samples" if skip else ", or fix the data"
    skips = f" ({option('skip_bad_samples', True)} skips such samples)" if skip else ""
    if status == TIME_ORDER:
        return (
            f"{where}: time t = {t_text} is not after the previous sample's t = {info!r} "
            "(timestamps must increase strictly)"
        )
    if status == TIME_NOT_FINITE:
        return f"{where}: time t = {t_text} is not finite"
    if status == TORQUE_NOT_FINITE:
        return f"{label}: torque must be finite; got {info!r}"
    accept = suggested_tolerance(status, info)
    pass_ = "" if accept is None else f"pass {option(*accept)} to accept it"
    if status == NOT_ORTHOGONAL:
        return (
            f"{label}: not a rotation matrix: |R^T R - I| = {info:.3g} exceeds {option('rotation_tol', rot_tol)} "
            f"({pass_}{other})"
        )
    if status == NOT_PROPER:
        return f"{label}: a reflection, not a rotation: det R = {info:.6g} < 0{skips}"
    if status == QUAT_NORM:
        return (
            f"{label}: a quaternion far from unit norm: |q| = {info:.6g}, |(|q| - 1)| exceeds "
            f"{option('quat_norm_tol', quat_tol)} ({pass_}{other}; is it a quaternion, and its order right: "
            f"{option('scalar_first', None)}?)"
        )
    if status == ZERO_DIRECTION:
        return f"{label}: measured direction b{int(info) + 1} has zero length{skips}"
    return f"{label}: rejected (status {status})"


def rejection_error(status: int, info: float, where: str, t: float | None = None) -> MeasurementError:
    """:class:`MeasurementError` carrying :func:`describe_rejection`'s message (raise it)."""
    return MeasurementError(describe_rejection(status, info, where, t))
