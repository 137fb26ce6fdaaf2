"""The chaos suite's engine for the public API (issue 23), shared by ``tests/test_chaos_api.py`` and
``benchmarks/chaos.py``: the estimators, Hypothesis strategies of calls (good and bad samples and batches,
interleaved) and of DataFrames, and the twin check (a refused call must change nothing: an estimator that saw it
gives, bit for bit, what a twin that never saw it gives)."""

from __future__ import annotations

import warnings
from collections import Counter

import numpy as np
import pandas as pd
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from omegahat import MEKF, DifferencingEstimator, ObserverGains, SarrasEstimator, SupervisedKalmanEstimator

J = np.diag([3.0, 2.0, 1.0])
OMEGA = np.array([0.3, -0.2, 0.1])
R0 = Rotation.from_rotvec([0.2, -0.3, 0.5])

ESTIMATORS = {
    "sarras": lambda: SarrasEstimator(J, gains=ObserverGains.constant(2.0, 2.0, n=3)),
    "omegahat": lambda: SupervisedKalmanEstimator(J, rate_hz=100.0, measurement_noise=1e-3),
    "mekf": lambda: MEKF(J, measurement_noise=1e-3),
    "differencing": lambda: DifferencingEstimator(),
}


def attitude(t) -> Rotation:
    """The motion at a constant rate: ``R0 exp(t ω×)`` at a time or at times."""
    return R0 * Rotation.from_rotvec(np.multiply.outer(t, OMEGA))


# --- one call: ("update", t, measurement, torque) or ("run", times, measurements, torques)


def good_measurement(t: float, draw) -> object:
    rot = attitude(t)
    form = draw(st.sampled_from(["quat", "matrix", "rotation", "list", "float32"]))
    if form == "quat":
        return rot.as_quat() * draw(st.sampled_from([1.0, -1.0]))  # q and -q: the same rotation
    if form == "matrix":
        return rot.as_matrix()
    if form == "rotation":
        return rot
    if form == "list":
        return rot.as_quat().tolist()
    return rot.as_quat().astype(np.float32).astype(float)  # single precision, read back: still a rotation


BAD_TIMES = ["string", "nan", "inf", "same", "earlier", "complex", "none", "array", "bool"]
BAD_MEASUREMENTS = ["shape3", "shape5", "shape34", "text", "none", "complex", "norm2", "skew", "reflection", "object"]
BAD_TORQUES = ["shape2", "nan", "text", "complex"]


def bad_time(kind: str, t_next: float, t_last: float | None):
    return {
        "string": str(t_next),
        "nan": float("nan"),
        "inf": float("inf"),
        "same": t_last if t_last is not None else "x",
        "earlier": (t_last - 0.5) if t_last is not None else "x",
        "complex": complex(t_next, 1.0),
        "none": None,
        "array": np.array([t_next, t_next + 0.01]),
        "bool": True if t_last is None or t_last >= 1.0 else "x",  # True is 1.0: refused as a time, or in order
    }[kind]


def bad_measurement(kind: str, t: float):
    q = attitude(t).as_quat()
    R = attitude(t).as_matrix()
    return {
        "shape3": q[:3],
        "shape5": np.append(q, 0.0),
        "shape34": R[:, :3].T,
        "text": "1,0,0,0",
        "none": None,
        "complex": q + 0.5j,
        "norm2": 2.0 * q,
        "skew": R + 0.2 * np.eye(3)[[1, 2, 0]],
        "reflection": -R,
        "object": np.array([q[0], q[1], q[2], "w"], dtype=object),
    }[kind]


def bad_torque(kind: str):
    return {"shape2": np.zeros(2), "nan": np.array([0.0, np.nan, 0.0]), "text": "0,0,0", "complex": np.zeros(3) + 1j}[
        kind
    ]


@st.composite
def calls(draw):
    """A sequence of calls: good samples and batches interleaved with bad ones (module docstring)."""
    out, t_last = [], None
    t_next = draw(st.sampled_from([0.0, 0.5, 1e3]))
    for _ in range(draw(st.integers(4, 14))):
        what = draw(st.sampled_from(["good", "good", "good", "missing", "bad_time", "bad_measurement", "bad_torque",
                                     "batch", "bad_batch"]))  # fmt: skip
        dt = draw(st.sampled_from([0.01, 0.02, 0.1, 1.0]))
        if what in ("good", "missing", "bad_measurement", "bad_torque", "bad_time"):
            m = good_measurement(t_next, draw) if what != "missing" else np.full(4, np.nan)
            t, tau = t_next, None
            if what == "bad_time":
                t = bad_time(draw(st.sampled_from(BAD_TIMES)), t_next, t_last)
            elif what == "bad_measurement":
                m = bad_measurement(draw(st.sampled_from(BAD_MEASUREMENTS)), t_next)
            elif what == "bad_torque":
                tau = bad_torque(draw(st.sampled_from(BAD_TORQUES)))
            out.append(("update", t, m, tau))
            if what in ("good", "missing"):
                t_last, t_next = t_next, t_next + dt
        else:
            n = draw(st.integers(1, 6))
            times = t_next + dt * np.arange(n)
            qs = attitude(times).as_quat()
            tau = None
            if what == "bad_batch":
                k = draw(st.integers(0, n - 1))
                fault = draw(st.sampled_from(["time", "norm", "torque", "shape"]))
                if fault == "time" and n > 1:
                    times[k] = times[k - 1] if k else times[1]
                elif fault == "norm":
                    qs[k] *= 3.0
                elif fault == "torque":
                    tau = np.zeros((n, 3))
                    tau[k, 1] = np.nan
                else:
                    qs = qs[:, :3]
            out.append(("run", times, qs, tau))
            if what == "batch":
                t_last, t_next = float(times[-1]), float(times[-1]) + dt
    return out


def call(est, c) -> np.ndarray:
    """The call's estimate as one array: a row ``(ωx, ωy, ωz, status)`` per sample."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = est.update(c[1], c[2], c[3]) if c[0] == "update" else est.run(c[1], c[2], c[3])
    return np.column_stack([np.atleast_2d(got.omega), np.atleast_1d(np.asarray(got.status, dtype=float))])


def twin_outcomes(name: str, sequence) -> Counter:
    """Feed ``sequence`` to an estimator and the calls it accepts to its twin: counts of ``accepted``, ``message``
    (refused with a ValueError or TypeError with a message), ``unnamed`` (such an error without a message),
    ``traceback`` (another exception) and ``changed`` (a later estimate differs from the twin's: the refused call
    changed the state)."""
    first, twin = ESTIMATORS[name](), ESTIMATORS[name]()
    seen: Counter = Counter()
    t_last = -1.0
    for c in sequence:
        try:
            got = call(first, c)
        except (ValueError, TypeError) as exc:
            seen["message" if str(exc) else "unnamed"] += 1
            continue  # the twin never sees a refused call
        except Exception:
            seen["traceback"] += 1
            continue
        seen["accepted"] += 1
        if not np.array_equal(got, call(twin, c), equal_nan=True):
            seen["changed"] += 1
            return seen
        times = np.atleast_1d(np.asarray(c[1], dtype=float))
        t_last = float(times[-1]) if times.size else t_last
    last = ("update", t_last + 0.05, attitude(t_last + 0.05).as_quat(), None)  # and a good sample after all that
    try:
        same = np.array_equal(call(first, last), call(twin, last), equal_nan=True)
    except (ValueError, TypeError):  # the first refuses what the twin takes: a refused call moved it
        same = False
    seen["accepted" if same else "changed"] += 1
    return seen


@st.composite
def frames(draw):
    n = draw(st.integers(0, 40))
    t = np.arange(n) / 50.0
    q = attitude(t).as_quat() if n else np.zeros((0, 4))
    columns = {"qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}
    dtype = draw(st.sampled_from(["float64", "float64", "float32", "object", "string", "Float64", "int64"]))
    df = pd.DataFrame(columns)
    if n and draw(st.booleans()):  # a glitch in one value
        df.iloc[draw(st.integers(0, n - 1)), 0] = draw(st.sampled_from([np.nan, np.inf, 7.0]))
    if dtype == "int64":
        df = (df.fillna(0.0).clip(-1.0, 1.0) * 0).astype("int64")  # zeros: not rotations, a message
    elif dtype != "float64":
        df = df.astype(dtype)
    time = draw(st.sampled_from(["t", "t", "index-datetime", "index-aware", "index-int", "none", "t-text", "t-nan"]))
    if time == "t":
        df["t"] = t
    elif time == "index-datetime":
        df.index = pd.Timestamp("2024-01-01") + pd.to_timedelta(np.round(t * 1e9), unit="ns")
    elif time == "index-aware":
        utc = pd.Timestamp("2024-03-31 00:59:59", tz="UTC") + pd.to_timedelta(np.round(t * 1e9), unit="ns")
        df.index = pd.DatetimeIndex(utc).tz_convert("Europe/Paris")
    elif time == "index-int":
        df.index = np.arange(n)
    elif time == "t-text":
        df["t"] = [f"{x}s" for x in t]
    elif time == "t-nan":
        df["t"] = np.where(np.arange(n) == n // 2, np.nan, t)
    if n and draw(st.booleans()):
        df = df.iloc[draw(st.permutations(range(n)))]
    return df
