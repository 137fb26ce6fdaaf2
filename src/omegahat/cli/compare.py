"""``omegahat compare``: omegahat beside the baselines users would pick instead, scenario by scenario.

Methods (``shared/design/baselines.md``): the sampled Sarras estimator (:class:`omegahat.observer.estimator.
SarrasEstimator`, all three rows of R) twice, ``omegahat`` with its warm start (the rate from the first two
samples, as ``omegahat estimate`` does by default) and ``omegahat-cold`` started from the scenario's ω̂₀ (the
observer as published), log-map differencing (backward = causal, central = one sample late),
SciPy's ``RotationSpline`` (offline), and the gyro-less MEKF with the dynamic model (J, τ known) and with the
kinematic model (ω̇ white noise). Every method gets the same data: the attitude fixes, the known torque, the
model inertia, the same initial rate estimate ω̂₀ and the bound |ω| ≤ ω_M.

Tuning, the same procedure for every method: each method has one knob with a small grid (printed in the
output); the grid value with the least steady-state RMS error on the tuning seed (1) is chosen, then the method
is scored on a different seed (2). Metrics, per scenario and method, on the scored run:

* first below tolerance: the first sample time at which |ω̂ − ω| is below the scenario's tolerance;
* convergence time: the first sample time after which |ω̂ − ω| stays below the scenario's tolerance
  (``inf`` if it never does). A recursive method (omegahat, the EKFs) whose output becomes non-finite, or that
  fails numerically (an EKF whose covariance lost definiteness), has diverged: its error counts as infinite and
  the table lists it;
* steady-state RMS of |ω̂ − ω| over ``t ≥ steady_after`` (rows without an estimate are left out);
* for real data, the in-band RMS of :mod:`omegahat.evaluation.broad` (error against the bias-corrected gyroscope,
  low-passed at 10 Hz, over the motion samples);
* cost per sample of ``run`` (wall time; not seeded, so reported in its own table and file).

Outputs in ``--out``: ``results.md`` (the tables), ``results.csv`` (deterministic: two runs give the same bytes),
``cost.csv`` (timings) and ``<scenario>.png`` (error against time, log scale).
"""

from __future__ import annotations

import argparse
import csv
import math
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from omegahat.baselines.differencing import DifferencingEstimator
from omegahat.baselines.mekf import MEKF
from omegahat.baselines.spline import SplineEstimator
from omegahat.observer.estimator import SarrasEstimator
from omegahat.observer.tuning import bandwidth_gains
from omegahat.simulation import scenarios as S

HELP = "Compare omegahat with differencing, a spline and an EKF on the standard scenarios."

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


def _jbar(sc):
    return float(np.trace(np.asarray(sc.J_model))) / 3.0


def _meas_sigma(sc):
    return max(float(sc.attitude_sigma), 1e-6)  # a filter needs a positive measurement variance


def _sarras(warm_start):
    def make(sc, b_rel):
        # Three rows of R with equal k: the linearised error decays as J⁻¹ 2k, so k = b·J̄/2 gives bandwidth ≈ b,
        # here b = b_rel × sample rate (like the differencing cut-off, the grid follows the rate).
        gains = bandwidth_gains(sc.J_model, b_rel * sc.rate_hz)  # three rows: k = b tr(J)/6, l = 10 b
        return SarrasEstimator(sc.J_model, gains=gains, omega_hat0=sc.omega_hat0, warm_start=warm_start)

    return make


def _mekf(model):
    def make(sc, sigma_a):
        q = (_jbar(sc) * sigma_a) ** 2 if model == "dynamic" else sigma_a**2
        return MEKF(
            sc.J_model, model, q=q, measurement_sigma=_meas_sigma(sc), omega0=sc.omega_hat0, sigma_omega0=sc.omega_max
        )

    return make


_CUTOFFS = (None, 0.25, 0.1, 0.025, 0.01)  # × sample rate
_SIGMA_A = tuple(10.0**p for p in range(-6, 2))

_BANDWIDTHS = (0.001, 0.003, 0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0)
_SARRAS_KNOB = "bandwidth b (x rate, rad/s per Hz; k = b*tr(J)/6, l = 10 b)"

METHODS = (
    Method(
        "omegahat", True, _SARRAS_KNOB + "; warm start from the first two samples", _BANDWIDTHS, _sarras(True), True
    ),
    Method(
        "omegahat-cold", True, _SARRAS_KNOB + "; started from the scenario's w_hat0", _BANDWIDTHS, _sarras(False), True
    ),
    Method(
        "diff-backward",
        True,
        "low-pass cut-off (x rate; none = raw)",
        _CUTOFFS,
        lambda sc, c: DifferencingEstimator("backward", None if c is None else c * sc.rate_hz),
    ),
    Method(
        "diff-central",
        False,
        "low-pass cut-off (x rate; none = raw)",
        _CUTOFFS,
        lambda sc, c: DifferencingEstimator("central", None if c is None else c * sc.rate_hz),
    ),
    Method("spline", False, "none", (None,), lambda sc, _: SplineEstimator()),
    Method(
        "mekf-dynamic", True, "rate noise sigma_a rad/s^1.5 (q = (tr(J)/3 sigma_a)^2)", _SIGMA_A, _mekf("dynamic"), True
    ),
    Method("mekf-kinematic", True, "rate noise sigma_a rad/s^1.5 (q = sigma_a^2)", _SIGMA_A, _mekf("kinematic"), True),
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--scenario",
        action="append",
        choices=S.names(),
        metavar="NAME",
        help=f"scenario to run (repeatable; default: all). One of: {', '.join(S.names())}",
    )
    parser.add_argument("--out", type=Path, default=Path("compare-out"), help="output folder (compare-out/)")
    parser.add_argument(
        "--duration",
        type=float,
        default=None,
        help="override every simulated scenario's horizon, s (quick looks and tests)",
    )
    parser.add_argument(
        "--method",
        action="append",
        choices=[m.name for m in METHODS],
        metavar="NAME",
        help="method to run (repeatable; default: all)",
    )


# ---------------------------------------------------------------------------------------------------------
# Metrics


def convergence_time(t, err, tol):
    """First sample time after which ``err`` stays ≤ ``tol``; ``inf`` if never. NaN rows (no estimate) are left
    out; an infinite error (a diverged method) counts as above any tolerance."""
    ok = ~np.isnan(err)
    bad = np.flatnonzero(ok & (err > tol))
    if not ok.any():
        return math.inf
    if bad.size == 0:
        return float(t[np.flatnonzero(ok)[0]])
    after = np.flatnonzero(ok & (np.arange(t.size) > bad[-1]))
    return float(t[after[0]]) if after.size else math.inf


def first_below(t, err, tol):
    """First sample time at which ``err`` is ≤ ``tol`` (``inf`` if never): how fast the initial error is removed,
    whether or not the noise floor lets the error stay below (that is :func:`convergence_time`)."""
    hit = np.flatnonzero(err <= tol)
    return float(t[hit[0]]) if hit.size else math.inf


def steady_rms(t, err, t0):
    """RMS of ``err`` over ``t ≥ t0``, NaN rows (no estimate) left out; infinite if the method diverged."""
    m = (t >= t0) & ~np.isnan(err)
    return float(np.sqrt(np.mean(err[m] ** 2))) if m.any() else math.nan


def _errors(est, omega):
    return np.linalg.norm(est - omega, axis=1)


def _run_method(method, sc, value, run):
    """``(ω̂ (T, 3), cost per sample, failure)``; ``failure`` is None or what made the method diverge."""
    est = method.make(sc, value)
    t0 = time.perf_counter()
    failure = None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # skipped samples are expected on real data
        try:
            w = est.run(run.t, run.R_meas, run.torque)
        except (np.linalg.LinAlgError, FloatingPointError) as exc:  # e.g. an EKF whose state became NaN
            w = np.full((run.t.size, 3), np.inf)
            failure = f"{type(exc).__name__}: {exc}"
    cost = (time.perf_counter() - t0) / run.t.size
    if method.always_estimates:
        bad = ~np.all(np.isfinite(w), axis=1)
        if bad.any():
            w = np.where(bad[:, None], np.inf, w)
            failure = failure or f"non-finite estimate from t = {run.t[np.flatnonzero(bad)[0]]:g} s"
    return w, cost, failure


def _load_trial(trial_name, seconds=None):
    """A BROAD trial as a :class:`omegahat.simulation.scenarios.Run` (J = I, τ = 0 stand-ins; reference: the
    bias-corrected gyroscope), optionally cut to its first ``seconds`` (the cut's gyro bias is then estimated
    from the cut's own rest samples)."""
    from omegahat.evaluation import broad

    tr = broad.load_trial(trial_name)
    if seconds is not None:
        n = int(np.searchsorted(tr.t, seconds, side="right"))
        tr = broad.Trial(tr.name, tr.t[:n], tr.R[:n], tr.gyro[:n], tr.fs, tr.movement[:n])
    return S.Run(tr.t, tr.R, np.zeros((tr.t.size, 3)), tr.gyro_corrected, None, tr)


def _load(sc, seed, duration):
    if not sc.real:
        return S.simulate(sc, seed, duration)
    return _load_trial(sc.broad_trial)


def _score_real(run, w):
    """In-band RMS of :func:`omegahat.evaluation.broad.score` (10 Hz zero-phase low-pass of the error, motion samples
    away from gaps, best shift within ±5 samples)."""
    from omegahat.evaluation import broad

    return broad.score(run.extra, w).rms


def _fmt(x, digits=3):
    if x is None:
        return "none"
    if isinstance(x, float) and (math.isinf(x) or math.isnan(x)):
        return "inf" if math.isinf(x) else "n/a"
    return f"{x:.{digits}g}"


def compare_scenario(sc, methods, duration=None):
    """Tune (seed 1) and score (seed 2) every method on one scenario; returns rows and the scored errors."""
    if sc.real:
        # Real data has no seeds: tune on the first REAL_TUNING_SECONDS of another trial, score this one.
        tune_run = _load_trial(REAL_TUNING_TRIAL[sc.broad_trial], REAL_TUNING_SECONDS)
        run = _load(sc, None, None)
    else:
        tune_run = _load(sc, TUNING_SEED, duration)
        run = _load(sc, SCORED_SEED, duration)
    rows, curves = [], {}
    # A shortened horizon (--duration) moves the steady-state window to its second half.
    t_steady = min(sc.steady_after, 0.5 * run.t[-1])
    for m in methods:
        best = None
        for value in m.grid:
            w, _, _ = _run_method(m, sc, value, tune_run)
            if sc.real:
                score = _score_real(tune_run, w)
            else:
                score = steady_rms(tune_run.t, _errors(w, tune_run.omega), t_steady)
            if best is None or (np.isfinite(score) and not score >= best[1]):
                best = (value, score)
        w, cost, failure = _run_method(m, sc, best[0], run)
        err = _errors(w, run.omega)
        row = {
            "scenario": sc.name,
            "method": m.name,
            "causal": "yes" if m.causal else "no",
            "knob": m.knob,
            "tuned": _fmt(best[0]),
            "first_below_s": first_below(run.t, err, sc.converged_tol),
            "convergence_s": convergence_time(run.t, err, sc.converged_tol),
            "steady_rms": steady_rms(run.t, err, t_steady),
            "inband_rms": _score_real(run, w) if sc.real else math.nan,
            "cost_us": cost * 1e6,
            "failure": failure or "",
        }
        rows.append(row)
        curves[m.name] = err
    ref = next((r["steady_rms"] for r in rows if r["method"] == "omegahat"), math.nan)
    for r in rows:
        r["vs_omegahat"] = r["steady_rms"] / ref if ref > 0 else math.nan
    return rows, run.t, curves


def plot_errors(sc, t, curves):
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
    "vs_omegahat",
)


def markdown(rows, methods):
    lines = [
        "| scenario | method | causal | tuned knob | first below tol. (s) | convergence (s) | steady RMS (rad/s) "
        "| in-band RMS (rad/s) | steady RMS / omegahat's |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
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
    failed = [r for r in rows if r["failure"]]
    if failed:
        lines += ["", "Diverged on the scored run (error counted as infinite from then on):", ""]
        lines += [f"- {r['scenario']} / {r['method']}: {r['failure']}" for r in failed]
    return "\n".join(lines)


def run(args) -> int:
    names = args.scenario or S.names()
    methods = [m for m in METHODS if args.method is None or m.name in args.method]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, skipped = [], []
    for name in names:
        sc = S.get(name)
        if sc.real and not S.broad_data_dir().is_dir():
            skipped.append(f"{name}: data directory {S.broad_data_dir()} not found")
            continue
        if sc.real:
            try:
                from omegahat.evaluation import broad  # noqa: F401
            except ModuleNotFoundError:
                skipped.append(f"{name}: omegahat.evaluation.broad (loader and scorer) is not available")
                continue
        sc_rows, t, curves = compare_scenario(sc, methods, args.duration)
        rows += sc_rows
        plot_errors(sc, t, curves).savefig(out / f"{name}.png", dpi=110)
    table = markdown(rows, methods)
    if skipped:
        table += "\n\nNot run: " + "; ".join(skipped)
    cost_lines = ["| scenario | method | cost per sample of run() (us) |", "| --- | --- | --- |"]
    cost_lines += [f"| {r['scenario']} | {r['method']} | {r['cost_us']:.3g} |" for r in rows]
    cost = "\n".join(cost_lines)
    (out / "results.md").write_text(
        "# omegahat compare\n\n" + table + "\n\n## Cost (wall time: varies from run to run)\n\n" + cost + "\n"
    )
    with open(out / "results.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(COLUMNS)
        for r in rows:
            w.writerow([r[c] if isinstance(r[c], str) else repr(float(r[c])) for c in COLUMNS])
    with open(out / "cost.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["scenario", "method", "cost_us_per_sample"])
        for r in rows:
            w.writerow([r["scenario"], r["method"], f"{r['cost_us']:.6g}"])
    print(table)
    print(f"\nwrote {out / 'results.md'}, results.csv, cost.csv and one figure per scenario")
    return 0
