"""The chaos suite, the public API (issue 23): Hypothesis interleaves good and bad samples (times, values, dtypes,
shapes, single samples and batches) into the estimators, and checks

* **a refusal changes nothing**: every call an estimator refuses is a ``ValueError`` or ``TypeError`` with a
  message, and afterwards the estimator gives, bit for bit, what a twin that never saw the refused call gives (the
  twin gets exactly the calls the first accepted). This is the strongest form of "state unchanged after every
  refusal": any change of state shows in a later estimate;
* **nothing is read approximately**: a complex number is refused, never converted with its imaginary part dropped;
  numbers written as text are read exactly, or refused.

Which estimators each property covers is said by :data:`ESTIMATORS` and the markers below: the sampled Sarras
estimator fails the first today (``update("1.0", q)`` moves it before refusing), and every estimator the second
(:mod:`omegahat.measurements`, their one input path, drops a complex ``q``'s imaginary part): issue 23, item 5,
being fixed elsewhere. Those cases are strict expected failures, which fail when the fix lands (then remove the
markers).

``estimate_frame`` gets the same treatment for DataFrames: any dtype, shape, time kind and order gives a frame of
one row per input row, or a message.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import omegahat
from chaos_api import ESTIMATORS, attitude, call, calls, frames, twin_outcomes
from omegahat import DifferencingEstimator

#: estimators that fail a property today, and why (strict: the marker must go when the fix lands)
KNOWN: dict[tuple[str, str], str] = {}
FAST = settings(
    max_examples=40, derandomize=True, database=None, suppress_health_check=[HealthCheck.too_slow], deadline=None
)


def check_refusals_change_nothing(name: str, sequence) -> None:
    seen = twin_outcomes(name, sequence)
    assert not (seen["changed"] or seen["unnamed"] or seen["traceback"]), (name, dict(seen), sequence)


def _marks(name: str, prop: str):
    why = KNOWN.get((name, prop))
    return [pytest.mark.xfail(strict=True, reason=why)] if why else []


@pytest.mark.parametrize("name", [pytest.param(n, marks=_marks(n, "refusal")) for n in ESTIMATORS])
@FAST
@given(sequence=calls())
def test_a_refused_call_changes_nothing(name, sequence):
    check_refusals_change_nothing(name, sequence)


def test_the_refusal_property_catches_a_change_of_state():
    # The property itself: an estimator that moves before refusing (as SarrasEstimator.update("1.0", q) does today)
    # is caught, with the calls below.
    q = attitude(0.0).as_quat()
    sequence = [("update", 0.0, q, None), ("update", "0.5", attitude(0.5).as_quat(), None),
                ("update", 1.0, attitude(1.0).as_quat(), None)]  # fmt: skip

    class MovesFirst(DifferencingEstimator):
        def update(self, t, measurement, torque=None):
            out = super().update(float(t), measurement, torque)
            if isinstance(t, str):
                raise TypeError("a time given as text")
            return out

    ESTIMATORS["moves-first"] = MovesFirst
    try:
        with pytest.raises(AssertionError):
            check_refusals_change_nothing("moves-first", sequence)
    finally:
        del ESTIMATORS["moves-first"]


def _started(name: str):
    est = ESTIMATORS[name]()
    call(est, ("update", 0.0, attitude(0.0).as_quat(), None))
    return est


@pytest.mark.parametrize("name", list(ESTIMATORS))
def test_a_complex_time_is_refused(name):
    with pytest.raises((ValueError, TypeError)):
        call(_started(name), ("update", 0.1 + 0.5j, attitude(0.1).as_quat(), None))


@pytest.mark.parametrize("name", [pytest.param(n, marks=_marks(n, "complex")) for n in ESTIMATORS])
@pytest.mark.parametrize("part", ["measurement", "torque"])
def test_a_complex_measurement_or_torque_is_refused(name, part):
    q = attitude(0.1).as_quat()
    args = (0.1, q + 0.5j, None) if part == "measurement" else (0.1, q, np.zeros(3) + 0.5j)
    with pytest.raises((ValueError, TypeError)):
        call(_started(name), ("update", *args))


@pytest.mark.parametrize("name", list(ESTIMATORS))
@pytest.mark.parametrize("part", ["time", "measurement", "torque"])
def test_numbers_as_text_are_read_exactly_or_refused(name, part):
    q, tau = attitude(0.1).as_quat(), np.array([0.0, 1e-3, 0.0])
    text = {"time": ("0.1", q, tau), "measurement": (0.1, q.astype(str), tau), "torque": (0.1, q, tau.astype(str))}
    try:
        got = call(_started(name), ("update", *text[part]))
    except (ValueError, TypeError):
        return
    np.testing.assert_array_equal(got, call(_started(name), ("update", 0.1, q, tau)))


# ------------------------------------------------------------------------------------------- estimate_frame


@settings(max_examples=40, derandomize=True, database=None, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])  # fmt: skip
@given(df=frames())
def test_estimate_frame_gives_one_row_per_row_or_a_message(df):
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            out = omegahat.estimate_frame(df, bandwidth_hz=2.0, start="warm")
    except (ValueError, TypeError) as exc:
        assert "DataFrame" in str(exc) or "row" in str(exc) or "sample" in str(exc), str(exc)
        return
    assert len(out) == len(df) and out.index.equals(df.index)
    assert set(out["status"].astype(str)) <= {"corrected", "predicted", "unavailable"}
    w = out[["wx", "wy", "wz"]].to_numpy()
    assert np.all(np.isfinite(w[out["status"].astype(str).to_numpy() != "unavailable"]))
