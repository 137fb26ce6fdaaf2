r"""The contract every angular-velocity estimator in omegahat implements.

**Two kinds of estimator.** A :class:`StreamingEstimator` is fed samples one at a time with
:meth:`~StreamingEstimator.update` (online) and whole logs with :meth:`~Estimator.run`; the two are the same
computation (feeding a log to ``update`` sample by sample gives what one ``run`` gives), and both continue from the
current state until :meth:`~StreamingEstimator.reset`. A batch :class:`Estimator` (the spline, Savitzky–Golay, the
smoothers) needs the whole record: it has only ``run``, which starts afresh every time. ``causal`` says whether the
estimate at a sample uses only that sample and earlier ones.

**One signature.** ``run(t, data, torque=None)`` takes the sample times ``t (T,)`` (s, strictly increasing), the
measurements ``data`` and, for estimators with a model, the known torque ``(T, 3)`` (N·m, body axes); it returns an
:class:`Estimate`: ``omega (T, 3)``, the body-frame angular velocity in rad/s, and ``status (T,)``, one
:class:`Status` per sample. ``update(t, sample, torque=None)`` returns an :class:`Estimate` of one sample:
``omega (3,)`` and one ``Status``. Constructors take keyword arguments only, but for the inertia ``J`` of the
estimators that have a model. Options that are one of a few words are typed ``Literal`` below and checked with
:func:`one_of`.

**Measurements** are whatever the estimator was built for: attitudes (rotation matrices ``(3, 3)``, quaternions
``(4,)`` in SciPy's scalar-last order unless ``scalar_first=True``, or ``scipy.spatial.transform.Rotation``) or
body-frame measurements of known inertial directions ``(n, 3)``. Input is checked by
:mod:`omegahat.measurements` (one policy and one set of messages for every estimator). A sample that is refused
(not a rotation, a time not after the previous one, a string or a complex number where a real one is due, a wrong
shape) raises and leaves the estimator exactly as it was; ``run`` is atomic: it names the first refused sample and
leaves the state as it was before the call.

**Statuses** (per sample; :data:`STATUS_WORDS` are their names in output files)::

    UNAVAILABLE  no estimate: omega is NaN (before the first valid sample; at it, unless an initial rate was given,
                 since one attitude gives no rate; an offline method without enough samples around this one)
    CORRECTED    the estimate after a measured sample
    PREDICTED    no usable sample at that time (missing: NaN or inf, or nearly collinear directions): the estimate
                 was predicted through it; or the first fix after a long gap whose rate is the one held through it
    RESTARTED    the state could not be propagated to this sample (it would not stay finite): the estimator
                 restarted from it

**One skip counter.** ``n_skipped`` counts the samples that were skipped (missing, or nearly collinear
directions: status PREDICTED, or UNAVAILABLE when no estimate exists yet) since the last ``reset`` (a batch
estimator: in its last ``run``).
"""

from __future__ import annotations

import abc
import copy
import enum
from collections.abc import Sequence
from typing import Any, ClassVar, Literal, NamedTuple, TypeAlias, cast, get_args

import numpy as np
from numpy.typing import ArrayLike
from scipy.spatial.transform import Rotation

__all__ = [
    "STATUS_WORDS",
    "Estimate",
    "Estimator",
    "Measurement",
    "MeasurementKind",
    "Measurements",
    "Status",
    "StreamingEstimator",
    "TorqueHold",
    "batch_status",
    "one_of",
]

#: One sample: a rotation matrix ``(3, 3)``, a quaternion ``(4,)``, a single ``Rotation``, or ``(n, 3)`` directions.
Measurement: TypeAlias = ArrayLike | Rotation
#: A log of T samples: ``(T, 3, 3)``, ``(T, 4)``, ``(T, n, 3)``, a ``Rotation`` of T or a sequence of T Rotations.
Measurements: TypeAlias = ArrayLike | Rotation | Sequence[Rotation]
#: What a sample is: an attitude (matrix, quaternion, Rotation) or body-frame directions of known inertial ones.
MeasurementKind: TypeAlias = Literal["attitude", "directions"]
#: The known torque between two samples: held from the earlier one, or the line between the two.
TorqueHold: TypeAlias = Literal["zero", "linear"]


class Status(enum.IntEnum):
    """What an estimate at a sample is.

    One status per sample (module docstring); an ``IntEnum``, so ``Estimate.status`` from ``run`` holds its values
    as ``int8`` and ``Status(value)`` gives the member back. :data:`STATUS_WORDS` are the names in output files.

    * ``UNAVAILABLE`` (0): no estimate, omega is NaN (before the first valid sample; at it, unless an initial rate
      was given, since one attitude gives no rate; an offline method without enough samples around this one);
    * ``CORRECTED`` (1): the estimate after a measured sample;
    * ``PREDICTED`` (2): no usable sample at that time (missing: NaN or inf, or nearly collinear directions); the
      estimate was predicted through it; or the first fix after a long gap, whose rate is the one held through it
      (the supervised estimator's (S5));
    * ``RESTARTED`` (3): the state could not be propagated to this sample (it would not stay finite); the
      estimator restarted from it.

    Examples
    --------
    A constant-rate rotation with its third attitude missing (NaN):

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import DifferencingEstimator, Status
    >>> t = np.arange(5) * 0.1
    >>> q = Rotation.from_rotvec(t[:, None] * [0.1, -0.2, 0.3]).as_quat()
    >>> q[2] = np.nan
    >>> estimate = DifferencingEstimator().run(t, q)
    >>> print([Status(s).name for s in estimate.status])
    ['UNAVAILABLE', 'CORRECTED', 'PREDICTED', 'CORRECTED', 'CORRECTED']
    >>> print(int(Status.PREDICTED), Status.PREDICTED.name.lower())
    2 predicted
    """

    UNAVAILABLE = 0
    CORRECTED = 1
    PREDICTED = 2
    RESTARTED = 3


#: The statuses' names, indexed by their value (the ``status`` column of ``omegahat estimate``'s output).
STATUS_WORDS: tuple[str, ...] = tuple(s.name.lower() for s in Status)


class Estimate(NamedTuple):
    """What an estimator returns: the angular velocity and a :class:`Status` per sample.

    ``run`` returns it for every sample of a log, ``update`` for one sample. A named tuple:
    ``omega, status = estimator.run(t, data)`` unpacks it.

    Parameters
    ----------
    omega : numpy.ndarray
        The body-frame angular velocity (rad/s, body axes): ``(T, 3)`` from ``run``, ``(3,)`` from ``update``;
        NaN where there is no estimate.
    status : numpy.ndarray or Status
        ``(T,)`` int8 values of :class:`Status` from ``run``, or one ``Status`` from ``update``.

    Examples
    --------
    Attitudes of a body turning at a constant rate, differenced:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import DifferencingEstimator, Estimate, Status
    >>> t = np.arange(5) * 0.1
    >>> q = Rotation.from_rotvec(t[:, None] * [0.1, -0.2, 0.3]).as_quat()
    >>> estimate = DifferencingEstimator().run(t, q)
    >>> print(isinstance(estimate, Estimate), estimate.omega.shape, estimate.status.shape)
    True (5, 3) (5,)
    >>> omega, status = estimate
    >>> print(np.isnan(omega[0]).all(), Status(status[0]).name)
    True UNAVAILABLE
    >>> print(np.allclose(omega[1:], [0.1, -0.2, 0.3]), Status(status[1]).name)
    True CORRECTED
    """

    omega: np.ndarray
    status: Any  # np.ndarray (T,) from run, a Status from update


def one_of(name: str, value: object, options: Any) -> Any:
    """``value`` if it is one of ``options`` (a ``Literal`` type or a tuple of words), else ``ValueError`` naming
    ``name`` and the words allowed."""
    words = get_args(options) if not isinstance(options, tuple) else options
    if not isinstance(value, str) or value not in words:
        raise ValueError(f"{name} must be one of {', '.join(words)}; got {value!r}")
    return value


def batch_status(usable: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """The statuses of an offline estimate: CORRECTED where the sample was usable, PREDICTED where it was skipped
    (the estimate bridges it), UNAVAILABLE wherever ``omega`` has no finite estimate (there it is set to NaN)."""
    status = np.where(usable, Status.CORRECTED, Status.PREDICTED).astype(np.int8)
    none = ~np.all(np.isfinite(omega), axis=-1)
    status[none] = Status.UNAVAILABLE
    omega[none] = np.nan
    return status


class Estimator(abc.ABC):
    """The contract of every estimator: ``run`` a whole log.

    A batch estimator (the spline, Savitzky–Golay, the smoothers) implements this alone: it needs the whole record
    and starts afresh at every ``run`` (module docstring); :class:`StreamingEstimator` adds ``update`` and
    ``reset``. ``run(t, data, torque=None)`` takes the sample times ``t (T,)`` (s, strictly increasing), the
    measurements and, for estimators with a model, the known torque ``(T, 3)`` (N·m, body axes), and returns an
    :class:`Estimate`. Class attributes: ``causal`` (True when the estimate at a sample uses only that sample and
    earlier ones), ``streaming`` (True for :class:`StreamingEstimator`), ``n_skipped`` (samples skipped, missing
    or nearly collinear directions, since the last reset, or in the last batch run).

    Examples
    --------
    A batch estimator on attitudes of a body turning at a constant rate:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import Estimator, SplineEstimator
    >>> t = np.arange(50) * 0.01
    >>> q = Rotation.from_rotvec(t[:, None] * [0.1, -0.2, 0.3]).as_quat()
    >>> spline = SplineEstimator()
    >>> print(isinstance(spline, Estimator), spline.streaming, spline.causal)
    True False False
    >>> omega, status = spline.run(t, q)
    >>> print(np.allclose(omega, [0.1, -0.2, 0.3]), spline.n_skipped)
    True 0
    """

    #: True when the estimate at a sample uses only that sample and earlier ones.
    causal: bool = True
    #: True for estimators fed one sample at a time (:class:`StreamingEstimator`).
    streaming: ClassVar[bool] = False
    #: samples skipped (missing, or nearly collinear directions) since the last reset, or in the last batch run
    n_skipped: int = 0

    @abc.abstractmethod
    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at every sample of a log: ``omega (T, 3)`` and ``status (T,)``."""


class StreamingEstimator(Estimator):
    """An estimator fed one sample at a time; ``run`` is the same computation over a log.

    ``update(t, sample, torque=None)`` takes one sample (online) and returns its :class:`Estimate` (``omega (3,)``
    and one ``Status``); ``run`` feeds a whole log through the same computation (feeding a log to ``update``
    sample by sample gives what one ``run`` gives). Both continue from the current state until ``reset``, which
    forgets every sample. A refused sample raises and changes nothing; ``run`` is atomic (module docstring).

    Examples
    --------
    Differencing attitudes of a body turning at a constant rate, online and then as a log:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import DifferencingEstimator, StreamingEstimator
    >>> t = np.arange(5) * 0.1
    >>> q = Rotation.from_rotvec(t[:, None] * [0.1, -0.2, 0.3]).as_quat()
    >>> est = DifferencingEstimator()
    >>> print(isinstance(est, StreamingEstimator), est.streaming, est.causal)
    True True True
    >>> online = np.array([est.update(tj, qj).omega for tj, qj in zip(t, q)])
    >>> print(" ".join(f"{w:.3f}" for w in online[-1]))
    0.100 -0.200 0.300
    >>> est.reset()
    >>> print(np.array_equal(est.run(t, q).omega, online, equal_nan=True))
    True
    """

    streaming: ClassVar[bool] = True

    @abc.abstractmethod
    def update(self, t: float, sample: Measurement, torque: ArrayLike | None = None) -> Estimate:
        """Take the sample at time ``t`` (``torque`` known from ``t`` on; None: zero) and return the estimate
        there: ``omega (3,)`` and its :class:`Status`. A refused sample raises and changes nothing."""

    @abc.abstractmethod
    def reset(self) -> None:
        """Forget every sample: back to the initial state, counters cleared."""

    def run(self, t: ArrayLike, data: Measurements, torque: ArrayLike | None = None) -> Estimate:
        """:meth:`update` over every sample, continuing from the current state; atomic (a refused sample raises
        naming its index, and the estimator is left as it was before the call). Estimators with a compiled
        ``run`` override this with the same computation."""
        times = np.asarray(t)  # each time is checked by update (a real number)
        if times.ndim != 1:
            raise ValueError(f"times must have shape (T,); got shape {times.shape}")
        samples = cast("Sequence[Measurement]", data)  # indexable: an array, a Rotation or a sequence
        taus = cast("Sequence[ArrayLike] | None", torque)
        for name, values in (("measurements", samples), ("torques", taus)):
            if values is not None and len(values) != times.size:
                raise ValueError(f"{len(values)} {name} for {times.size} times")
        saved = copy.deepcopy(self.__dict__)
        omega = np.empty((times.size, 3))
        status = np.empty(times.size, dtype=np.int8)
        j = 0
        try:
            for j in range(times.size):
                omega[j], status[j] = self.update(times[j], samples[j], None if taus is None else taus[j])
        except Exception as exc:
            self.__dict__.clear()
            self.__dict__.update(saved)
            if isinstance(exc, ValueError):  # name the sample by its index in the log
                raise type(exc)(str(exc).replace("the sample", f"sample {j}", 1)) from None
            raise
        return Estimate(omega, status)
