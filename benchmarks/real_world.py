"""Every method on every recording of the development corpus of issue 24, by one score: the "before" table.

Run: ``python benchmarks/corpus.py SRC_DIR OUT_DIR`` once, then ``OMEGAHAT_CORPUS_DIR=OUT_DIR python
benchmarks/real_world.py [--only PATTERN ...] [--methods NAME ...] [--no-decimate]``. Skips cleanly without a
corpus. ``--after``, ``--preset``, ``--directions`` and ``--heldout`` (the recordings of ``corpus.py --only
heldout``, kept out of development) run fewer methods and write their own sections.

Score: :func:`omegahat.lab.evaluation.broad.score` through :func:`omegahat.lab.evaluation.corpus.evaluate`: the
error against the recording's reference (a gyroscope calibrated once against the attitude by ``omegahat
calibrate``'s fit, shared by every method; or the plant's truth), zero-phase low-passed at min(10 Hz, 0.4 × rate),
RMS over the scored samples 1 s from gaps, at the best continuous shift within ±3 samples; the plant's logs without
the low-pass and without a shift. BROAD recordings are also scored at every 10th and 30th sample (29 and 10 Hz),
against the native gyroscope.

Methods: :data:`omegahat.lab.evaluation.corpus.METHODS` (differencing, RotationSpline, Savitzky-Golay, ``omegahat
estimate`` as it runs with no option, ``--estimator sarras``, the best ``--bandwidth`` in hindsight, ``--preset
mocap``, ``--preset mocap --smooth``, the MEKF), the omegahat ones through the pipeline of ``omegahat estimate``.
Ratios: every method to backward differencing; ``--smooth`` also to the best of central differencing and
RotationSpline; the default to the best bandwidth in hindsight. "predicted": the method's own expected RMS error
when it prints one. Writes ``benchmarks/real_world.csv`` (every row) and its section of RESULTS.md.
"""

from __future__ import annotations

import argparse
import csv
import fnmatch
import math
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

from omegahat.identification import identify
from omegahat.identification.smoother import ModelSmoother
from omegahat.lab.evaluation.broad import Score
from omegahat.lab.evaluation.corpus import (
    METHODS,
    Method,
    Outcome,
    Recording,
    Row,
    corpus_dir,
    evaluate,
    group_of,
    load_recording,
    pipeline_method,
    recordings,
)
from results_md import RESULTS, machine_line, write_section

CSV = Path(__file__).with_name("real_world.csv")
SUMMARY = (  # the ratio columns
    "omegahat estimate",
    "--estimator sarras",
    "--bandwidth, best in hindsight",
    "--preset mocap",
    "--preset mocap --smooth",
    "MEKF",
)
HINDSIGHT = "--bandwidth, best in hindsight"
SECTION = "## Real-world corpus of issue 24 (benchmarks/real_world.py)"


AFTER_SECTION = "## Real-world corpus of issue 24, the identified default (benchmarks/real_world.py --after)"
AFTER_METHODS = ("backward diff.", "central diff.", "RotationSpline", "omegahat estimate", "omegahat estimate --smooth")
AFTER_CSV = Path(__file__).with_name("real_world_after.csv")
PRESET_SECTION = (
    "## The mocap preset on the real-world corpus, after its divergence test (benchmarks/real_world.py --preset)"
)
PRESET_METHODS = ("backward diff.", "central diff.", "RotationSpline", "--preset mocap", "--preset mocap --smooth")
PRESET_CSV = Path(__file__).with_name("real_world_preset.csv")
PRESET_INTRO = (
    "`omegahat estimate --preset mocap` (causal) and `--preset mocap --smooth` after the preset's supervisor kept its "
    "divergence test in the motion's scale (P5) and the rotation's Nyquist bound (docs/theory/mocap.md), scored as "
    "above; per group the geometric mean and the worst ratio to backward differencing, and `--smooth`'s to the best "
    'of central differencing and RotationSpline. The same methods before the change are in the section "Real-world '
    'corpus of issue 24" (real_world.csv). Every row: `benchmarks/real_world_preset.csv`.'
)


def _fmt(x: float | None, spec: str = ".4g") -> str:
    return "–" if x is None or not math.isfinite(x) else format(x, spec)


def _geomean(xs: list[float]) -> float | None:
    xs = [x for x in xs if x is not None and math.isfinite(x) and x > 0]
    return math.exp(sum(map(math.log, xs)) / len(xs)) if xs else None


HEADER = ["recording", "samples", "method", "causal", "rms_rad_s", "shift_samples", "zero_shift_rms", "n_scored",
          "ratio_to_backward", "ratio_to_best_offline", "predicted_rad_s", "cpu_us_per_sample", "note"]  # fmt: skip


def _write_csv(rows: list[Row], path: Path = CSV) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(HEADER)
        for r in rows:
            s = r.score
            w.writerow([
                r.recording, r.samples, r.method, r.causal, _fmt(s and s.rms, ".6g"), _fmt(s and s.shift, ".3f"),
                _fmt(s and s.zero_shift_rms, ".6g"), s.n_samples if s else "", _fmt(r.ratio, ".4f"),
                _fmt(r.offline_ratio, ".4f"), _fmt(r.predicted, ".4g"), _fmt(r.cpu_s * 1e6 / max(r.samples, 1), ".3g"),
                r.note.replace("\n", " ")[:400],
            ])  # fmt: skip


def summary_table(rows: list[Row]) -> str:
    """One line per recording: backward differencing's score, each summary method's ratio to it, ``--smooth``'s
    ratio to the best offline peer, the default's ratio to the best bandwidth in hindsight and its predicted over
    measured error; then geometric means by group."""
    recs = list(dict.fromkeys(r.recording for r in rows))
    by = {(r.recording, r.method): r for r in rows}

    def rms(name: str, method: str) -> float | None:
        r = by.get((name, method))
        return r.score.rms if r is not None and r.score is not None else None

    short = {"omegahat estimate": "default", "--bandwidth, best in hindsight": "best --bandwidth"}
    head = ["recording", "backward diff. (rad/s)", *(f"{short.get(m, m)} ÷ bwd" for m in SUMMARY),
            "--smooth ÷ best offline", "default ÷ best --bandwidth", "default: predicted ÷ measured"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    groups: dict[str, list[list[float | None]]] = {}
    for name in recs:
        ratios = [by[(name, m)].ratio if (name, m) in by else None for m in SUMMARY]
        smooth = by.get((name, "--preset mocap --smooth"))
        default, hind = rms(name, "omegahat estimate"), rms(name, HINDSIGHT)
        extra = [
            smooth.offline_ratio if smooth else None,
            default / hind if default is not None and hind else None,
        ]
        est = by.get((name, "omegahat estimate"))
        pm = est.predicted / est.score.rms if est and est.predicted and est.score else None
        cells = [_fmt(rms(name, "backward diff."))] + [_fmt(x, ".3f") for x in ratios + extra] + [_fmt(pm, ".2f")]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
        group = group_of(name)
        groups.setdefault(group, []).append(ratios + extra)
    lines += ["", "| group (geometric mean) | n | " + " | ".join(head[2:-1]) + " |", "|" + " --- |" * (len(head) - 1)]
    for g, vals in groups.items():
        means = [_geomean([v[i] for v in vals]) for i in range(len(vals[0]))]  # type: ignore[misc]
        lines.append(f"| {g} | {len(vals)} | " + " | ".join(_fmt(m, ".3f") for m in means) + " |")
    return "\n".join(lines)


def after_table(rows: list[Row]) -> str:
    """The identified default against differencing: per recording the default's and ``--smooth``'s ratios to
    backward differencing, ``--smooth``'s to the best of central differencing and RotationSpline; then per group
    the geometric means and how many recordings exceed 1.02 (the default) and 1.0 (``--smooth`` to the best)."""
    by = {(r.recording, r.method): r for r in rows}
    recs = list(dict.fromkeys(r.recording for r in rows))
    head = ["recording", "backward diff. (rad/s)", "default ÷ bwd", "--smooth ÷ bwd", "--smooth ÷ best offline",
            "the default ran", "default: predicted ÷ measured"]  # fmt: skip
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    groups: dict[str, list[tuple[float | None, float | None, float | None]]] = {}
    assessments: dict[str, list[float | None]] = {}
    smoothed: dict[str, list[float | None]] = {}  # --smooth's own expected error over its measured score

    for name in recs:
        bwd, d, sm = (by.get((name, m)) for m in ("backward diff.", "omegahat estimate", "omegahat estimate --smooth"))
        vals = (d.ratio if d else None, sm.ratio if sm else None, sm.offline_ratio if sm else None)
        ran = "differencing" if d and "backward differencing runs" in d.note else "model's filter"
        pm = d.predicted / d.score.rms if d and d.predicted and d.score else None  # the self-assessment
        cells = [_fmt(bwd.score.rms if bwd and bwd.score else None)] + [_fmt(v, ".3f") for v in vals] + [ran]
        cells.append(_fmt(pm, ".2f"))
        assessments.setdefault(group_of(name), []).append(pm)
        smoothed.setdefault(group_of(name), []).append(
            sm.predicted / sm.score.rms if sm and sm.predicted and sm.score else None
        )
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
        groups.setdefault(group_of(name), []).append(vals)
    lines += ["", "| group | n | default ÷ bwd (geo. mean; worst; > 1.02) | --smooth ÷ bwd (geo. mean) | "
              "--smooth ÷ best offline (geo. mean; worst; > 1.0) |", "| --- | ---: | --- | --- | --- |"]  # fmt: skip
    everything: list[tuple[float | None, float | None, float | None]] = []
    for g, vals in [*groups.items(), ("all", None)]:
        vals = vals if vals is not None else everything
        if g != "all":
            everything += vals
        d = [v[0] for v in vals if v[0] is not None]
        o = [v[2] for v in vals if v[2] is not None]
        lines.append(
            f"| {g} | {len(vals)} | {_fmt(_geomean(d), '.3f')}; {_fmt(max(d, default=None), '.3f')}; "
            f"{sum(x > 1.02 for x in d)} | {_fmt(_geomean([v[1] for v in vals]), '.3f')} | "
            f"{_fmt(_geomean(o), '.3f')}; {_fmt(max(o, default=None), '.3f')}; {sum(x > 1.0 for x in o)} |"
        )
    lines += ["", "| group | n | default: predicted ÷ measured (geo. mean; lowest; highest; outside 0.5-2) |",
              "| --- | ---: | --- |"]  # fmt: skip
    for title, found in (("default", assessments), ("--smooth", smoothed)):
        if title != "default":
            lines += ["", f"| group | n | {title}: predicted ÷ measured (geo. mean; lowest; highest; outside 0.5-2) |",
                      "| --- | ---: | --- |"]  # fmt: skip
        every = [x for g in found.values() for x in g]
        for g, pms in [*found.items(), ("all", every)]:
            v = [x for x in pms if x is not None]
            lines.append(
                f"| {g} | {len(v)} | {_fmt(_geomean(v), '.2f')}; {_fmt(min(v, default=None), '.2f')}; "
                f"{_fmt(max(v, default=None), '.2f')}; {sum(not 0.5 <= x <= 2.0 for x in v)} |"
            )
    return "\n".join(lines)


def preset_table(rows: list[Row]) -> str:
    """Per group: the preset's and ``--smooth``'s ratios to backward differencing (geometric mean; worst), and
    ``--smooth``'s to the best offline peer."""
    groups: dict[str, list[Row]] = {}
    for r in rows:
        name = r.recording
        groups.setdefault(group_of(name), []).append(r)
    head = (
        "| group | n | --preset mocap ÷ bwd (geo. mean; worst) | --smooth ÷ bwd (geo. mean; worst) "
        "| --smooth ÷ best offline (geo. mean) |"
    )
    lines = [head, "| --- | ---: | --- | --- | --- |"]
    for g, rs in groups.items():
        causal = [r.ratio for r in rs if r.method == "--preset mocap" and r.ratio is not None]
        smooth = [r for r in rs if r.method == "--preset mocap --smooth" and r.ratio is not None]
        ratios = [r.ratio for r in smooth if r.ratio is not None]
        offline = [r.offline_ratio for r in smooth if r.offline_ratio is not None]
        lines.append(
            f"| {g} | {len(causal)} | {_fmt(_geomean(causal), '.3f')}; {_fmt(max(causal, default=None), '.3f')} | "
            f"{_fmt(_geomean(ratios), '.3f')}; {_fmt(max(ratios, default=None), '.3f')} | "
            f"{_fmt(_geomean(offline), '.3f')} |"
        )
    return "\n".join(lines)


def read_csv(path: Path = CSV) -> list[Row]:
    """The rows a previous run wrote (its scores as far as the CSV keeps them), to redo the table without rerunning."""

    def num(text: str) -> float | None:
        return None if text in ("", "–") else float(text)

    rows = []
    with open(path, newline="", encoding="utf-8") as f:
        for d in csv.DictReader(f):
            rms = num(d["rms_rad_s"])
            s = None
            if rms is not None:
                shift, zero = num(d["shift_samples"]) or 0.0, num(d["zero_shift_rms"]) or math.nan
                s = Score(rms, shift, zero, int(d["n_scored"]), {}, math.nan)
            cpu = (num(d["cpu_us_per_sample"]) or 0.0) * int(d["samples"]) * 1e-6
            rows.append(Row(d["recording"], int(d["samples"]), d["method"], d["causal"] == "True", s, cpu,
                            num(d["predicted_rad_s"]), num(d["ratio_to_backward"]), num(d["ratio_to_best_offline"]),
                            d["note"]))  # fmt: skip
    return rows


def _measured_line() -> str:
    """The machine-and-date line of this script's section in RESULTS.md (when the table was measured)."""
    text = RESULTS.read_text() if RESULTS.exists() else ""
    if SECTION in text:
        body = text[text.index(SECTION) + len(SECTION) :].lstrip()
        if body.startswith("Machine:"):
            return body.split(" Command:")[0]
    raise SystemExit(f"--from-csv: no measured section '{SECTION}' in {RESULTS} to take the date from")


INTRO = (
    "Fair score (rad/s) of backward differencing, and each method's score as a ratio to it (below 1: better); "
    "`--smooth` also to the best of central differencing and RotationSpline (on the plant's noise-free logs the "
    "spline is exact to 5e-9 rad/s, so that ratio means nothing there); the default over the best `--bandwidth` in "
    "hindsight; the default's own predicted RMS error over its measured score (printed only by the fixed-gain "
    "path). Ratios in the thousands are estimates that diverged (the preset and the MEKF after optical gaps, "
    "written as 'corrected' estimates of up to 1e7 rad/s): they dominate the geometric means of their group. "
    "Every method and figure per recording: `benchmarks/real_world.csv`."
)


AFTER_INTRO = (
    "`omegahat estimate` with no option (the model and noises identified from the log's first 8192 samples, then "
    "the model's supervised filter or backward differencing) and with `--smooth` (the identified model's two-filter "
    "smoother, or the log's own Wiener smoother where the model is declined), scored as above against backward "
    "differencing and, for `--smooth`, the best of central differencing and RotationSpline. Every row: "
    "`benchmarks/real_world_after.csv`."
)

HELDOUT_SECTION = "## Recordings of other labs that nothing was chosen on (benchmarks/real_world.py --heldout)"
HELDOUT_CSV = Path(__file__).with_name("real_world_heldout.csv")
HELDOUT_INTRO = (
    "The methods of `--after`, scored alike, on recordings converted by `python benchmarks/corpus.py SRC OUT --only "
    "heldout` and used for nothing but this table: RepoIMU's triple pendulum (Vicon at about 91 Hz with millisecond "
    "stamps, a gyroscope held over two rows; also at every 3rd and 9th sample), RING's five-segment chain (optical "
    "attitude at 30 Hz, gyroscopes at 40 Hz on their own clock; also at every 3rd sample) and OpenAXES's robot arm "
    "(two links' attitudes from the joint encoders at 125 Hz, their IMUs' gyroscopes resampled onto the robot's "
    "clock; also at every 3rd and 9th sample) and the Tyrex smartphones (a Qualisys rigid body on the phone at "
    "60 Hz, the phone's own gyroscope at 94-200 Hz on its clock; pedestrians holding, swinging, pocketing and "
    "running with it; also at every 6th sample) and a motor's hinge (the shaft's encoder angle and the gyroscope on "
    "the shaft, one clock, about 100 Hz; also at every 10th sample). Every row: `benchmarks/real_world_heldout.csv`."
)


def write_results(rows: list[Row], names: list[str], n_recordings: int, measured: str | None = None) -> None:
    """Write the section of RESULTS.md (``measured``: its machine-and-date line, default now)."""
    corpus = f"{n_recordings} recordings: {', '.join(names)}; BROAD also at every 10th and 30th sample"
    command = f"Command: `python benchmarks/real_world.py` on the corpus of `benchmarks/corpus.py` ({corpus})."
    write_section(SECTION, f"{measured or machine_line()} {command} {INTRO}\n\n" + summary_table(rows))


DIRECTIONS_SECTION = "## `--smooth` on direction logs of the real-world corpus (benchmarks/real_world.py --directions)"
DIRECTIONS_CSV = Path(__file__).with_name("real_world_directions.csv")
#: two inertial directions (gravity's reaction, and a horizontal one): each attitude R gives b_i = Rᵀ v_i
DIRECTIONS = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
BEFORE = "the model's smoother (before)"
DEFAULT_BEFORE = "the model's filter (the default before)"
DIRECTIONS_INTRO = (
    "Each real recording's attitudes (and every 10th and 30th sample of BROAD's) turned into the body-frame "
    "directions of two inertial ones (`b_i = Rᵀ v_i`, v = (0, 0, 1) and (1, 0, 0); the attitude noise is the "
    "recording's own), the plant's own direction logs as they are; `omegahat estimate --references … --smooth` "
    "(the log's own Wiener smoother of each sample's least-squares attitude where the model is declined, the choice "
    f'between it and the model\'s smoother where it is accepted) and "{BEFORE}": what `--smooth` ran on '
    "directions before, the identified model's two-filter smoother whether or not the model was accepted; both "
    "over the best of central differencing and RotationSpline through the least-squares attitudes, scored as "
    "above. Every row: `benchmarks/real_world_directions.csv`."
)


def as_direction_log(rec: Recording) -> Recording | None:
    """``rec`` as a log of two body-frame directions (:data:`DIRECTIONS`); a plant's direction log as it is, its
    quaternion logs None (the plant gives both kinds)."""
    if rec.kind == "directions":
        return rec
    if rec.name.startswith("plant"):
        return None
    b = np.einsum("tji,nj->tni", rec.R, DIRECTIONS)  # NaN where the attitude is missing
    return replace(rec, kind="directions", data=b, references=DIRECTIONS.copy())


def _model_smoother(rec: Recording) -> Outcome:
    """``--smooth`` on directions before: the identified model's smoother, accepted or not."""
    n = min(rec.t.size, 8192)
    torque = None if rec.torque is None else rec.torque[:n]
    ident = identify(rec.t[:n], rec.data[:n], rec.kind, J=rec.inertia, torque=torque, references=rec.references)
    est = ModelSmoother(ident, references=rec.references)
    return Outcome(est.run(rec.t, rec.data, rec.torque).omega, note=f"model accepted: {ident.use_model}")


def directions_table(rows: list[Row]) -> str:
    """Per group: ``--smooth`` and the model's smoother (before) over the best offline peer, and the default and the
    model's filter (what the default ran on directions before) over backward differencing of the least-squares
    attitudes (geometric mean; worst; how many above 1, and above 1.02 for the causal ones)."""
    groups: dict[str, dict[str, list[float]]] = {}
    columns = {"omegahat estimate --smooth": 1.0, BEFORE: 1.0, "omegahat estimate": 1.02, DEFAULT_BEFORE: 1.02}
    for r in rows:
        ratio = r.offline_ratio if not r.causal else r.ratio
        if ratio is None or r.method not in columns:
            continue
        name = r.recording
        group = group_of(name)
        for g in (group, "all real recordings") if group != "plant" else (group,):
            groups.setdefault(g, {}).setdefault(r.method, []).append(ratio)
    head = (
        "| group | n | --smooth ÷ best offline (geo. mean; worst; > 1) "
        "| before ÷ best offline (geo. mean; worst; > 1) "
        "| default ÷ backward diff. (geo. mean; worst; > 1.02) | before ÷ backward diff. (geo. mean; worst; > 1.02) |"
    )
    lines = [head, "| --- | ---: | --- | --- | --- | --- |"]
    order = [g for g in groups if g != "all real recordings"] + ["all real recordings"]
    for g in order:
        cells = []
        for m, limit in columns.items():
            v = groups[g].get(m, [])
            cells.append(
                f"{_fmt(_geomean(v), '.3f')}; {_fmt(max(v, default=None), '.4g')}; {sum(x > limit for x in v)}"
            )
        n = len(groups[g].get("omegahat estimate --smooth", []))
        lines.append(f"| {g} | {n} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("corpus", nargs="?", type=Path, help="corpus directory (default $OMEGAHAT_CORPUS_DIR or ../corpus)")
    ap.add_argument("--only", nargs="+", metavar="PATTERN", help="recordings whose name matches (fnmatch)")
    ap.add_argument("--methods", nargs="+", metavar="NAME", help="methods to run (default all)")
    ap.add_argument("--no-decimate", action="store_true", help="native rates only")
    ap.add_argument("--no-write", action="store_true", help="print only (no CSV, no RESULTS.md)")
    ap.add_argument("--from-csv", action="store_true", help="redo the table and section from real_world.csv")
    ap.add_argument(
        "--after", action="store_true",
        help="the identified default only (differencing, spline, the default and --smooth): its own section and CSV",
    )  # fmt: skip
    ap.add_argument(
        "--heldout", action="store_true",
        help="as --after, on the held-out corpus (corpus.py --only heldout): its own section and CSV",
    )  # fmt: skip
    ap.add_argument("--preset", action="store_true", help="the mocap preset only: its own section and CSV")
    ap.add_argument(
        "--directions", action="store_true",
        help="--smooth on the recordings turned into two-direction logs: its own section and CSV",
    )  # fmt: skip
    args = ap.parse_args(argv)
    if args.heldout:
        args.after = True
    if args.after:
        args.methods = list(AFTER_METHODS)
    if args.preset:
        args.methods = list(PRESET_METHODS)
    if args.directions:
        args.methods = [
            "backward diff.",
            "central diff.",
            "RotationSpline",
            "omegahat estimate",
            "omegahat estimate --smooth",
        ]
    if args.from_csv:
        rows = read_csv()
        recs = {r.recording.split("@")[0] for r in rows}
        write_results(rows, sorted({n.split("-")[0] for n in recs}), len(recs), _measured_line())
        print(summary_table(rows))
        return 0
    paths = recordings(args.corpus or corpus_dir())
    if args.only:
        paths = [p for p in paths if any(fnmatch.fnmatch(p.stem, pat) for pat in args.only)]
    if not paths:
        print(f"skipped: no corpus recordings in {args.corpus or corpus_dir()} (build it with benchmarks/corpus.py)")
        return 0
    methods = [m for m in METHODS if args.methods is None or m.name in args.methods]
    if args.directions:  # what ran on directions before: the model's smoother, and its filter by default
        methods += [Method(BEFORE, _model_smoother, False), pipeline_method(DEFAULT_BEFORE, estimator="omegahat")]
    warnings.simplefilter("ignore")  # skipped samples etc.: every method alike, counted in the notes
    rows: list[Row] = []
    t0 = time.perf_counter()
    for path in paths:
        rec = load_recording(path)
        steps = [1] + ([] if args.no_decimate else list(rec.meta.get("decimate", [])))
        if args.directions:
            found = as_direction_log(rec)
            if found is None:
                continue
            rec = found
        for step in steps:
            r = rec.decimated(step)
            got = evaluate(r, methods)
            rows += got
            line = "  ".join(f"{g.method}: {_fmt(g.score.rms if g.score else None)}" for g in got)
            print(f"{r.name} ({r.fs:.4g} Hz, {r.t.size} samples): {line}", flush=True)
    if args.directions:
        table = directions_table(rows)
    elif args.after:
        table = after_table(rows)
    else:
        table = preset_table(rows) if args.preset else summary_table(rows)
    print("\n" + table + f"\n\n{len(rows)} rows in {time.perf_counter() - t0:.0f} s")
    if args.no_write:
        return 0
    n = len(paths)
    of_corpus = f"({n} recordings of the corpus)"
    outputs = {  # option: (CSV, section, how it was run, intro)
        "directions": (DIRECTIONS_CSV, DIRECTIONS_SECTION, f"--directions` {of_corpus}", DIRECTIONS_INTRO),
        "preset": (PRESET_CSV, PRESET_SECTION, f"--preset` {of_corpus}", PRESET_INTRO),
        "heldout": (HELDOUT_CSV, HELDOUT_SECTION, f"--heldout OUT` ({n} recordings)", HELDOUT_INTRO),
        "after": (
            AFTER_CSV, AFTER_SECTION,
            f"--after` on the corpus of `benchmarks/corpus.py` ({n} recordings; BROAD also at every 10th and 30th "
            "sample)",
            AFTER_INTRO,
        ),
    }  # fmt: skip
    for option, (path, section, run, intro) in outputs.items():  # the first option given (heldout implies after)
        if getattr(args, option):
            _write_csv(rows, path)
            command = f"Command: `python benchmarks/real_world.py {run}."
            write_section(section, f"{machine_line()} {command} {intro}\n\n" + table)
            return 0
    _write_csv(rows)
    write_results(rows, sorted({p.stem.split("-")[0] for p in paths}), len(paths))
    return 0


if __name__ == "__main__":
    sys.exit(main())
