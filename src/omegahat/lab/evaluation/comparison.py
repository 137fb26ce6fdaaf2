r"""The comparison method: omegahat beside the baselines users would pick instead, scenario by scenario.

``omegahat compare`` (:mod:`omegahat.lab.cli.compare`) is a thin shell over this module: it picks the scenarios and
methods, calls :func:`compare_scenario`, and writes what :func:`markdown`, :func:`cost_markdown`,
:func:`write_results_csv`, :func:`write_cost_csv` and :func:`plot_errors` produce.

Methods (``docs/baselines.md``): omegahat's default estimator (:class:`omegahat.observer.kalman.
SupervisedKalmanEstimator`: the Sarras observer supervising a gyro-less EKF) twice, ``omegahat`` with its warm
start (the rate from the first two samples) and ``omegahat-cold`` started from the scenario's ω̂₀, and
``omegahat-unknown-torque`` with its EKF estimating the torque the model lacks (``disturbance_noise``); the fixed-gain
sampled Sarras estimator (:class:`omegahat.observer.estimator.SarrasEstimator`, all three rows of R, the
observer of the paper) likewise as ``sarras`` and ``sarras-cold``; log-map differencing (backward = causal,
central = one sample late), SciPy's ``RotationSpline`` (offline), and the gyro-less MEKF with the dynamic model
(J, τ known) and with the kinematic model (ω̇ white noise). Every method gets the same data: the attitude fixes,
the known torque, the model inertia, the same initial rate estimate ω̂₀ and the bound |ω| ≤ ω_M.

Direction scenarios (:data:`omegahat.lab.peer_scenarios.DIRECTION_SCENARIOS`) run the methods that take them
(``Method.inputs``) with their references; the gyro-free peers and the one-direction observer's rows are
:mod:`omegahat.lab.evaluation.peer_methods`'s; one direction adds the error across it (``steady_rms_across``).

Tuning, the same procedure for every method: each method has one knob with a small grid (printed in the
output); the grid value with the least steady-state RMS error on the tuning seed (1) is chosen, then the method
is scored on a different seed (2). Metrics, defined in :mod:`omegahat.lab.evaluation.metrics` ((S1)–(S3)), per
scenario and method, on the scored run:

* first below tolerance (S2): the first sample time at which |ω̂ − ω| is at or below the scenario's tolerance;
* convergence time (S1): the first sample time after which |ω̂ − ω| stays at or below the scenario's tolerance
  (``inf`` if it never does). A recursive method (omegahat, the EKFs) whose output becomes non-finite, or that
  fails numerically (an EKF whose covariance lost definiteness), has diverged: its error counts as infinite and
  the table lists it;
* steady-state RMS (S3) of |ω̂ − ω| over ``t ≥ steady_after`` (rows without an estimate are left out);
* for real data, the in-band RMS of :mod:`omegahat.lab.evaluation.broad` (error against the bias-corrected gyroscope,
  low-passed at 10 Hz, over the motion samples);
* cost per sample of ``run`` (wall time; not seeded, so reported in its own table and file).

The command's outputs: ``results.md`` (the tables), ``results.csv`` (deterministic: two runs give the same bytes),
``cost.csv`` (timings) and ``<scenario>.png`` (error against time, log scale).
"""

from __future__ import annotations

import csv
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import IO, TYPE_CHECKING

import numpy as np

from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.rts import RTSSmoother
from omegahat.baselines.savgol import SavitzkyGolayEstimator
from omegahat.baselines.spline import SplineEstimator
from omegahat.interface import Status
from omegahat.lab import peer_scenarios as P
from omegahat.lab import scenarios as S
from omegahat.lab.evaluation.metrics import convergence_time, estimate_errors, first_below, steady_rms
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.kalman import SupervisedKalmanEstimator
from omegahat.observer.presets import MocapPreset, MocapSmoother
from omegahat.observer.tuning import bandwidth_gains

if TYPE_CHECKING:  # matplotlib is imported when a figure is drawn, not with the command line
    from matplotlib.figure import Figure

__all__ = [
    "COLUMNS",
    "METHODS",
    "REAL_TUNING_SECONDS",
    "REAL_TUNING_TRIAL",
    "SCORED_SEED",
    "TUNING_SEED",
    "Method",
    "compare_scenario",
    "cost_markdown",
    "filter_noise",
    "markdown",
    "plot_errors",
    "unavailable",
    "write_cost_csv",
    "write_results_csv",
]

TUNING_SEED = 1
SCORED_SEED = 2
#: Real data: each trial's knobs are tuned on the first REAL_TUNING_SECONDS of another trial.
REAL_TUNING_TRIAL = {"01": "10", "06": "01", "10": "01"}
REAL_TUNING_SECONDS = 60.0


@dataclass(frozen=True)
class Method:
    name: str
    causal: bool
    knob: str  # what the one tuning parameter is
    grid: tuple  # its values (None = no knob)
    make: object  # (scenario, value) -> Estimator
    # True for the recursive estimators, which output a rate at every sample: a non-finite output (or a
    # numerical failure inside the method) is then divergence and counts as an infinite error, not as "no
    # estimate" (differencing and the spline have samples without one, e.g. at the ends and around gaps).
    always_estimates: bool = False
    inputs: tuple[str, ...] = ("attitude",)  # the measurement kinds it takes (kind(scenario))


def _jbar(sc):
    return float(np.trace(np.asarray(sc.J_model))) / 3.0


def filter_noise(sc: S.Scenario | P.DirectionScenario) -> float:
    """The measurement noise a filter is told: the scenario's, floored (a filter needs a positive variance)."""
    return max(float(sc.measurement_noise), 1e-6)


def _supervised(warm_start):
    def make(sc, sigma_a):
        # The default estimator: the observer (isotropic rate = the sample rate, aimed) supervising the dynamic EKF;
        # its one knob is the EKF's process noise, on the MEKF's grid and with the MEKF's meaning.
        return SupervisedKalmanEstimator(
            sc.J_model,
            rate_hz=sc.rate_hz,
            measurement_noise=filter_noise(sc),
            rate_noise=sigma_a,
            references=P.references(sc),
            omega_hat0=None if warm_start else sc.omega_hat0,
            warm_start=warm_start,
        )

    return make


def _unknown_torque(sc, sigma_d):
    # The default estimator with the unknown-acceleration state (K5): its knob is that state's random-walk noise;
    # the torque noise is then a floor (1e-6 rad/s^1.5), since the new state takes what the model lacks.
    return SupervisedKalmanEstimator(
        sc.J_model, rate_hz=sc.rate_hz, measurement_noise=filter_noise(sc), rate_noise=1e-6, disturbance_noise=sigma_d,
        references=P.references(sc),
    )  # fmt: skip


def _sarras(warm_start):
    def make(sc, b_rel):
        # Three rows of R with equal k: the linearised error decays as J⁻¹ 2k, so k = b·J̄/2 gives bandwidth ≈ b,
        # here b = b_rel × sample rate (like the differencing cut-off, the grid follows the rate).
        b = b_rel * sc.rate_hz  # rad/s; three rows: k = b tr(J)/6, l = 10 b
        gains = bandwidth_gains(sc.J_model, b / (2 * np.pi), P.references(sc))
        return SarrasEstimator(
            sc.J_model, gains=gains, references=P.references(sc), omega_hat0=sc.omega_hat0, warm_start=warm_start
        )

    return make


def _mekf(model):
    def make(sc, sigma_a):
        q = (_jbar(sc) * sigma_a) ** 2 if model == "dynamic" else sigma_a**2
        return MEKF(
            sc.J_model,
            model=model,
            q=q,
            measurement_noise=filter_noise(sc),
            references=P.references(sc),
            omega_hat0=sc.omega_hat0,
            sigma_omega0=sc.omega_max,
        )

    return make


def _mekf_rts(sc, sigma_a):
    return RTSSmoother(filter_factory=lambda: _mekf("dynamic")(sc, sigma_a))


_CUTOFFS = (None, 0.25, 0.1, 0.025, 0.01)  # × sample rate
_SAVGOL = ((3, 1), (5, 2), (5, 3), (5, 4), (7, 4), (7, 6), (9, 4), (9, 8), (11, 4), (15, 4), (21, 4))  # (window, order)
_SIGMA_A = tuple(10.0**p for p in range(-6, 2))

_BANDWIDTHS = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)
_SARRAS_KNOB = "bandwidth b (x rate, rad/s per Hz; k = b*tr(J)/6, l = 10 b)"

_BOTH = ("attitude", "directions")  # the methods that take attitudes or two or more directions

_SUPERVISED_KNOB = "the EKF's rate noise sigma_a rad/s^1.5 (q = (tr(J)/3 sigma_a)^2)"

_WARM, _COLD = "; warm start from the first two samples", "; started from the scenario's w_hat0"
_MEKF_KNOB = "rate noise sigma_a rad/s^1.5 (q = (tr(J)/3 sigma_a)^2)"

METHODS = (
    Method("omegahat", True, _SUPERVISED_KNOB + _WARM, _SIGMA_A, _supervised(True), True, _BOTH),
    Method("omegahat-cold", True, _SUPERVISED_KNOB + _COLD, _SIGMA_A, _supervised(False), True, _BOTH),
    Method(
        "omegahat-unknown-torque",
        True,
        "the unknown acceleration's random-walk noise sigma_d rad/s^2.5",
        tuple(10.0**p for p in range(-9, 0)),
        _unknown_torque,
        True,
        _BOTH,
    ),
    Method("sarras", True, _SARRAS_KNOB + _WARM, _BANDWIDTHS, _sarras(True), True, _BOTH),
    Method("sarras-cold", True, _SARRAS_KNOB + _COLD, _BANDWIDTHS, _sarras(False), True, _BOTH),
    Method(
        "diff-backward",
        True,
        "low-pass cut-off (x rate; none = raw)",
        _CUTOFFS,
        lambda sc, c: DifferencingEstimator(scheme="backward", cutoff_hz=None if c is None else c * sc.rate_hz),
    ),
    Method(
        "diff-central",
        False,
        "low-pass cut-off (x rate; none = raw)",
        _CUTOFFS,
        lambda sc, c: DifferencingEstimator(scheme="central", cutoff_hz=None if c is None else c * sc.rate_hz),
    ),
    Method("spline", False, "none", (None,), lambda sc, _: SplineEstimator()),
    Method(
        "savgol",
        False,
        "Savitzky-Golay on SO(3): (window samples, polynomial order)",
        _SAVGOL,
        lambda sc, wo: SavitzkyGolayEstimator(window=wo[0], order=wo[1]),
    ),
    Method("mekf-dynamic", True, _MEKF_KNOB, _SIGMA_A, _mekf("dynamic"), True, _BOTH),
    Method(
        "mekf-kinematic",
        True,
        "rate noise sigma_a rad/s^1.5 (q = sigma_a^2)",
        _SIGMA_A,
        _mekf("kinematic"),
        True,
        _BOTH,
    ),
    Method(
        "mekf-rts",
        False,
        "the dynamic MEKF's fixed-interval (RTS) smoother; rate noise sigma_a as mekf-dynamic",
        _SIGMA_A,
        _mekf_rts,
        True,
    ),
    Method(
        "omegahat-mocap",
        True,
        "none: the mocap preset (J and tau unknown; model and gains from the sample rate)",
        (None,),
        lambda sc, _: MocapPreset(rate_hz=sc.rate_hz),
        True,
    ),
    Method(
        "omegahat-mocap-smooth",
        False,
        "none: the mocap preset's zero-lag smoother (forward and backward passes averaged)",
        (None,),
        lambda sc, _: MocapSmoother(rate_hz=sc.rate_hz),
        True,
    ),
)


def _run_method(method, sc, value, run):
    """``(ω̂ (T, 3), cost per sample, failure)``; ``failure`` is None or what made the method diverge."""
    est = method.make(sc, value)
    t0 = time.perf_counter()
    failure = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # skipped samples are expected on real data
        try:
            w, status = est.run(run.t, run.R_meas, run.torque)
        except (np.linalg.LinAlgError, FloatingPointError) as exc:  # e.g. an EKF whose state became NaN
            w, status = np.full((run.t.size, 3), np.inf), np.full(run.t.size, Status.CORRECTED)
            failure = f"{type(exc).__name__}: {exc}"
    cost = (time.perf_counter() - t0) / run.t.size
    if method.always_estimates:  # a non-finite estimate where the method says it has one: diverged
        bad = ~np.all(np.isfinite(w), axis=1) & (status != Status.UNAVAILABLE)
        if bad.any():
            w = np.where(bad[:, None], np.inf, w)
            failure = failure or f"non-finite estimate from t = {run.t[np.flatnonzero(bad)[0]]:g} s"
    return w, cost, failure


def _load_trial(trial_name, seconds=None, decimate=1):
    """A BROAD trial as a :class:`omegahat.lab.scenarios.Run` (J = I, τ = 0 stand-ins; reference: the
    bias-corrected gyroscope), optionally cut to its first ``seconds`` (the cut's gyro bias is then estimated
    from the cut's own rest samples) and keeping every ``decimate``-th sample."""
    from omegahat.lab.evaluation import broad

    tr = broad.load_trial(trial_name)
    if seconds is not None:
        tr = tr.head(seconds)
    tr = tr.decimated(decimate)
    return S.Run(tr.t, tr.R, np.zeros((tr.t.size, 3)), tr.gyro_corrected, None, tr)


def _load(sc, seed, duration):
    if isinstance(sc, P.DirectionScenario):
        return P.simulate_directions(sc, seed, duration)
    if not sc.real:
        return S.simulate(sc, seed, duration)
    return _load_trial(sc.broad_trial, decimate=sc.decimate)


def _score_real(run, w):
    """The fair in-band score of :func:`omegahat.lab.evaluation.broad.score` (10 Hz zero-phase low-pass of the error,
    motion samples away from gaps, best continuous shift within ±3 samples), and the zero-shift RMS; infinite for
    an estimate that diverged (:func:`_run_method` marks its rows inf: they are not samples to score around)."""
    from omegahat.lab.evaluation import broad

    if np.isinf(w).any():
        return math.inf, math.inf
    s = broad.score(run.extra, w)
    return s.rms, s.zero_shift_rms


def _fmt(x, digits=3):
    if x is None:
        return "none"
    if isinstance(x, tuple):  # a knob of several numbers, e.g. (window, order)
        return "(" + ", ".join(_fmt(v, digits) for v in x) + ")"
    if isinstance(x, float) and (math.isinf(x) or math.isnan(x)):
        return "inf" if math.isinf(x) else "n/a"
    return f"{x:.{digits}g}"


def compare_scenario(
    sc: S.Scenario | P.DirectionScenario, methods: Sequence[Method], duration: float | None = None
) -> tuple[list[dict], np.ndarray, dict[str, np.ndarray]]:
    """Tune (seed 1) and score (seed 2) every method that takes the scenario's measurements (``Method.inputs``) on
    one scenario; returns rows and the scored errors."""
    if isinstance(sc, S.Scenario) and sc.real:
        # Real data has no seeds: tune on the first REAL_TUNING_SECONDS of another trial, score this one.
        tune_run = _load_trial(REAL_TUNING_TRIAL[str(sc.broad_trial)], REAL_TUNING_SECONDS, sc.decimate)
        run = _load(sc, None, None)
    else:
        tune_run = _load(sc, TUNING_SEED, duration)
        run = _load(sc, SCORED_SEED, duration)
    rows, curves = [], {}
    # A shortened horizon (--duration) moves the steady-state window to its second half.
    t_steady = min(sc.steady_after, 0.5 * run.t[-1])
    for m in (m for m in methods if P.kind(sc) in m.inputs):
        best = None
        for value in m.grid:
            w, _, _ = _run_method(m, sc, value, tune_run)
            if sc.real:
                score = _score_real(tune_run, w)[0]
            else:
                score = steady_rms(tune_run.t, estimate_errors(w, tune_run.omega), t_steady)
            if best is None or (np.isfinite(score) and not score >= best[1]):
                best = (value, score)
        w, cost, failure = _run_method(m, sc, best[0], run)  # type: ignore[index]  # None if m.grid is empty
        err = estimate_errors(w, run.omega)
        inband, zero_shift = _score_real(run, w) if sc.real else (math.nan, math.nan)
        row = {
            "scenario": sc.name,
            "method": m.name,
            "causal": "yes" if m.causal else "no",
            "knob": m.knob,
            "tuned": _fmt(best[0]),  # type: ignore[index]
            "first_below_s": first_below(run.t, err, sc.converged_tol),
            "convergence_s": convergence_time(run.t, err, sc.converged_tol),
            "steady_rms": steady_rms(run.t, err, t_steady),
            "steady_rms_across": (
                steady_rms(run.t, P.error_across(run, sc, w, err), t_steady)
                if isinstance(sc, P.DirectionScenario) and sc.measurement == "one-direction"
                else math.nan
            ),
            "inband_rms": inband,
            "zero_shift_rms": zero_shift,
            "cost_us": cost * 1e6,
            "failure": failure or "",
        }
        rows.append(row)
        curves[m.name] = err
    ref = next((r["steady_rms"] for r in rows if r["method"] == "omegahat"), math.nan)
    for r in rows:
        r["vs_omegahat"] = r["steady_rms"] / ref if ref > 0 else math.nan
    return rows, run.t, curves


def plot_errors(sc: S.Scenario | P.DirectionScenario, t: np.ndarray, curves: dict[str, np.ndarray]) -> Figure:
    """|ω̂ − ω| against time for every method of a scenario (log scale), with the convergence tolerance."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(8.0, 4.5), layout="constrained")
    ax = fig.subplots()
    for name, err in curves.items():
        ours = name == "omegahat"  # drawn on top: it coincides with omegahat-cold once both have converged
        ax.semilogy(t, np.where(err > 0, err, np.nan), label=name, lw=1.4 if ours else 1.0, zorder=3 if ours else 2)
    ax.axhline(sc.converged_tol, color="k", ls=":", lw=0.8, label="convergence tolerance")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(r"$|\hat\omega - \omega|$ (rad/s)")
    ax.set_title(f"{sc.name}: {sc.description}", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, ncol=2)
    return fig


COLUMNS = (
    "scenario",
    "method",
    "causal",
    "tuned",
    "first_below_s",
    "convergence_s",
    "steady_rms",
    "inband_rms",
    "zero_shift_rms",
    "vs_omegahat",
)


def markdown(rows: list[dict], methods: Sequence[Method]) -> str:
    """The results table, then the tuning procedure, every method's knob and grid, and the methods that diverged."""
    lines = [
        "| scenario | method | causal | tuned knob | first below tol. (s) | convergence (s) | steady RMS (rad/s) "
        "| in-band RMS (rad/s) | in-band, zero shift (rad/s) | steady RMS / omegahat's |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for r in rows:
        lines.append("| " + " | ".join(_fmt(r[c]) if not isinstance(r[c], str) else r[c] for c in COLUMNS) + " |")
    lines += [
        "",
        "Tuning: each method's one knob takes the grid value with the least steady-state RMS error on "
        f"seed {TUNING_SEED}; the table is seed {SCORED_SEED}. Real data (broad-*): the grid value with the "
        f"least in-band RMS on the first {REAL_TUNING_SECONDS:g} s of another trial "
        f"({', '.join(f'{k} tuned on {v}' for k, v in REAL_TUNING_TRIAL.items())}); there the steady RMS "
        "is against the raw bias-corrected gyroscope over the whole record. Knobs and grids:",
        "",
    ]
    for m in methods:
        lines.append(f"- {m.name}: {m.knob}; grid {', '.join(_fmt(v) for v in m.grid)}")
    one = [r for r in rows if not math.isnan(r["steady_rms_across"])]
    if one:
        lines += ["", "One direction: steady RMS of the error across the measured direction, |(I - b b^T)(w_hat - w)|:"]
        lines += ["", *(f"- {r['scenario']} / {r['method']}: {_fmt(r['steady_rms_across'])} rad/s" for r in one)]
    failed = [r for r in rows if r["failure"]]
    if failed:
        lines += ["", "Diverged on the scored run (error counted as infinite from then on):", ""]
        lines += [f"- {r['scenario']} / {r['method']}: {r['failure']}" for r in failed]
    return "\n".join(lines)


def cost_markdown(rows: list[dict]) -> str:
    """The cost table (wall time per sample of ``run``; varies from run to run)."""
    lines = ["| scenario | method | cost per sample of run() (us) |", "| --- | --- | --- |"]
    lines += [f"| {r['scenario']} | {r['method']} | {r['cost_us']:.3g} |" for r in rows]
    return "\n".join(lines)


def write_results_csv(f: IO[str], rows: list[dict]) -> None:
    """``results.csv``: the :data:`COLUMNS` of every row and ``steady_rms_across`` (NaN but for one-direction
    scenarios), numbers as ``repr(float)`` (the same bytes every run)."""
    w = csv.writer(f)
    columns = (*COLUMNS, "steady_rms_across")
    w.writerow(columns)
    for r in rows:
        w.writerow([r[c] if isinstance(r[c], str) else repr(float(r[c])) for c in columns])


def write_cost_csv(f: IO[str], rows: list[dict]) -> None:
    """``cost.csv``: scenario, method and the cost per sample in µs."""
    w = csv.writer(f)
    w.writerow(["scenario", "method", "cost_us_per_sample"])
    for r in rows:
        w.writerow([r["scenario"], r["method"], f"{r['cost_us']:.6g}"])


def unavailable(sc: S.Scenario | P.DirectionScenario) -> str | None:
    """Why a scenario cannot be run here (a real-data scenario without its data or loader), or None."""
    if sc.real and not S.broad_data_dir().is_dir():
        return f"{sc.name}: data directory {S.broad_data_dir()} not found"
    if sc.real:
        try:
            from omegahat.lab.evaluation import broad  # noqa: F401
        except ModuleNotFoundError:
            return f"{sc.name}: omegahat.lab.evaluation.broad (loader and scorer) is not available"
    return None
