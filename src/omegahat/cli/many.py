r"""``omegahat estimate DIR_OR_GLOB... -o OUTDIR``: every log of a folder, a glob or a list, one output each.

A layer above the one-file command: each log is run by the function ``omegahat estimate LOG -o OUT`` runs
(:func:`omegahat.cli.estimate.estimate_file`, handed in by the caller), with the same options for every file, on
this machine's cores (:mod:`omegahat.cli.many_run`) or on a Dask cluster (``--dask``). What this module decides:

**Many or one.** One input that is a file, or a ROS 2 bag (a directory that is one), is the one-file command,
unchanged. Several inputs, a directory that is not a bag, or a glob (quoted, so that omegahat expands it:
``'takes/**/*.csv'`` goes down into folders, ``*`` does not) make a batch, and ``-o`` names a directory.

**Which files are logs.** A file named on the command line is always run (if no format reads it, its row says
so). In a directory or a glob's matches, the files whose extension a registered format reads
(:func:`omegahat.io.registry.registered_extensions`) and the ROS 2 bags are run; the rest is skipped, each with its
reason in the summary: hidden files, other extensions, subdirectories (a directory is not searched inside: a glob
with ``**`` is), an output of omegahat (a CSV whose header is ``t,wx,wy,wz,status``, or a Parquet file of those
columns) and the summaries of an earlier batch. A file reached twice (a directory and a glob over it) is run once.

**Output names.** ``OUTDIR`` mirrors each input's path below its root (the directory given; a glob's directory
before its first wildcard; a named file's own directory) with the log's extension replaced by ``.csv``:
``takes/day1/a.tsv`` from ``'takes/**/*.tsv'`` is written to ``OUTDIR/day1/a.csv``. Inputs that would share an
output are named by their paths below the directory they have in common (``a/x.csv``, ``b/x.csv``), and those
still equal keep their whole name (``run.csv`` and ``run.txt`` in one folder: ``run.csv`` and ``run.txt.csv``);
each rename is said before the run. An output that would be an input, or a summary, is refused before any work.
With ``--output-format parquet`` the outputs are Parquet files (``.parquet`` in place of ``.csv``).

**An OUTDIR that exists** is refused if it holds any of the outputs, unless ``--existing overwrite`` (each
replaced, and the count said) or ``--existing skip`` (kept, and not run again: resuming an interrupted batch).
Every output is written as by the one-file command: under a temporary name, renamed when whole.

**The summary**: a table printed at the end (file, format, rows, estimator, expected error, status with the
one-line message of a failure) and written beside the outputs: :data:`SUMMARY_CSV` (one row per input, every
note) and :data:`SUMMARY_TXT` (the table, the skipped files, and each file's full report). A file that fails
does not stop the others; the exit code is 0 when every file was written (or kept), 1 when some failed, 2 when
there is nothing to run, and that of an interrupted command (:mod:`omegahat.cli`: 130 for Ctrl-C, 143 for
SIGTERM) when stopped: the files running finish or stop, none is left half-written, the rest are not started,
and the summary, written all the same, says which is which.
"""

from __future__ import annotations

import argparse
import csv
import glob
import io
import os
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from omegahat.cli import positive_int
from omegahat.cli.many_run import STATUSES, SUMMARY_CSV, SUMMARY_TXT, Job, OneFile, Outcome, run_jobs
from omegahat.io.output import HEADER
from omegahat.io.registry import registered_extensions
from omegahat.io.rosbag import is_ros2_bag

__all__ = [
    "EXISTING",
    "OUTPUT_FORMATS",
    "SUMMARY_CSV",
    "SUMMARY_TXT",
    "add_arguments",
    "is_many",
    "refuse_batch_options",
    "run_many",
]

EXISTING = ("overwrite", "skip")  #: what --existing does with outputs already in OUTDIR (default: refuse)
OUTPUT_FORMATS = ("csv", "parquet")  #: the outputs' format with many inputs (--output-format; default the first)
_SHOWN = 5  # files named in a message before "and N more"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The batch options (they apply when the inputs are many; the one-file command refuses them)."""
    group = parser.add_argument_group(
        "many files (several inputs, a directory or a quoted glob; -o is then a directory)",
        "Every log is run with the options above, one output each, named as its input (extension .csv, or "
        ".parquet with --output-format parquet); a "
        "summary table is printed and written to OUTDIR/" + SUMMARY_CSV + " and " + SUMMARY_TXT + ". A file that "
        "fails is named there with its message and does not stop the others (exit code 1).",
    )
    group.add_argument(
        "--jobs",
        type=positive_int,
        metavar="N",
        help="files estimated at once, one process each (default: the cores of this machine)",
    )
    group.add_argument(
        "--dask",
        metavar="ADDRESS",
        help="run on a Dask cluster (pip install 'omegahat[dask]'): tcp://SCHEDULER:8786, or 'local' for a "
        "LocalCluster here; the workers read the inputs and write OUTDIR at the same paths (a shared file system)",
    )
    group.add_argument(
        "--output-format",
        choices=OUTPUT_FORMATS,
        help="the outputs' format: csv (default) or parquet (the same columns; omegahat.io.parquet_output)",
    )
    group.add_argument(
        "--existing",
        choices=EXISTING,
        help="outputs already in OUTDIR: overwrite them, or skip their inputs (resume a batch); default: refuse",
    )


def is_many(inputs: list[Path]) -> bool:
    """True for several inputs, a directory that is not a ROS 2 bag, or a pattern that is no existing path."""
    if len(inputs) != 1:
        return True
    path = inputs[0]
    if path.is_dir():
        return not is_ros2_bag(str(path))
    return not path.exists() and glob.has_magic(str(path))


def refuse_batch_options(args: argparse.Namespace) -> None:
    """The one-file command takes none of the batch options: refused rather than ignored."""
    batch = (("--jobs", args.jobs), ("--dask", args.dask), ("--existing", args.existing))
    given = [f for f, v in batch if v]
    if given:
        raise ValueError(f"{', '.join(given)}: for many inputs (several files, a directory or a quoted glob)")
    if args.output_format is not None:
        raise ValueError("--output-format: for many inputs; one output's format is its name's extension (-o X.parquet)")


@dataclass(frozen=True)
class Found:
    """A log to run: ``path`` as found, ``rel`` its path below its ``root`` (the output's name before renames)."""

    path: Path
    root: Path
    rel: Path


def _skip_reason(path: Path) -> str | None:
    """Why an entry of a directory or a glob is not a log, or None if it is one (module docstring)."""
    if path.name.startswith("."):
        return "hidden"
    if path.is_dir():
        if is_ros2_bag(str(path)):
            return None
        return "a directory (not searched inside: a quoted glob with ** is, e.g. 'DIR/**/*.csv')"
    if path.name in (SUMMARY_CSV, SUMMARY_TXT):
        return "the summary of an earlier batch"
    ext = path.suffix.lower()
    if ext not in registered_extensions():
        return f"no format reads {ext or 'files without extension'}"
    if ext == ".csv":
        with open(path, "rb") as f:
            if f.read(len(HEADER) + 1).rstrip(b"\r\n") == HEADER.encode():
                return f"an output of omegahat ({HEADER})"
    if ext == ".parquet" and _parquet_columns(path) == HEADER.split(","):
        return f"an output of omegahat ({HEADER}, as Parquet)"
    return None


def _parquet_columns(path: Path) -> list[str] | None:
    """The column names of a Parquet file (its footer alone), or None where it cannot be read as one."""
    import pyarrow as pa  # a batch without Parquet files does not load it
    import pyarrow.parquet as pq

    try:
        return [str(n) for n in pq.read_schema(path).names]
    except (OSError, pa.ArrowException):  # not Parquet, or damaged: the reader will say so, naming the file
        return None


def _glob_root(pattern: str) -> Path:
    """The directory of a glob before its first wildcard (``takes/**/*.csv`` → ``takes``)."""
    parts = Path(pattern).parts
    plain = parts[: next(i for i, p in enumerate(parts) if glob.has_magic(p))]
    return Path(*plain) if plain else Path(".")


def find_logs(inputs: Iterable[Path]) -> tuple[list[Found], list[tuple[str, str]]]:
    """``(logs, skipped)``: the logs the inputs name, in order, each once, and ``(entry, reason)`` of what was
    skipped (module docstring). A named path that does not exist is kept: its row will say so."""
    found: list[Found] = []
    skipped: list[tuple[str, str]] = []
    seen: dict[str, str] = {}

    def add(path: Path, root: Path, named: bool) -> None:
        why = None if named else _skip_reason(path)
        if why is not None:
            skipped.append((str(path), why))
            return
        key = os.path.realpath(path)
        if key in seen:
            skipped.append((str(path), f"the same file as {seen[key]} (run once)"))
            return
        seen[key] = str(path)
        found.append(Found(path, root, Path(os.path.relpath(path, root))))

    for given in inputs:
        text = str(given)
        if given.is_dir() and not is_ros2_bag(text):
            entries = sorted(given.iterdir())
            if not entries:
                skipped.append((text, "an empty directory"))
            for entry in entries:
                add(entry, given, named=False)
        elif not given.exists() and glob.has_magic(text):
            matches = sorted(glob.glob(text, recursive=True))
            if not matches:
                skipped.append((text, "the pattern matches nothing"))
            for m in matches:
                add(Path(m), _glob_root(text), named=False)
        else:
            add(given, given.parent, named=True)
    return found, skipped


def _output_name(rel: Path, keep_extension: bool = False, ending: str = ".csv") -> Path:
    """``rel`` with a log extension replaced by ``ending`` (or, ``keep_extension``, ``ending`` appended unless the
    extension is ``.csv``: ``run.txt`` → ``run.txt.csv``)."""
    ext = rel.suffix.lower()
    if ext == ".csv" or (not keep_extension and ext in registered_extensions()):
        return rel.with_suffix(ending)
    return rel.with_name(rel.name + ending)


def _common_dir(paths: list[Path]) -> Path:
    return Path(os.path.commonpath([os.path.abspath(p.parent) for p in paths]))


def plan_outputs(found: list[Found], outdir: Path, ending: str = ".csv") -> tuple[list[Job], list[str]]:
    """One :class:`Job` per log with its output below ``outdir`` (module docstring: names and collisions; the
    extension ``ending``), and a note for each group of inputs renamed apart. Raises ValueError when names still
    collide, or an output would be an input or a summary."""
    names = [_output_name(f.rel, ending=ending) for f in found]
    notes = []
    for name, n in Counter(names).items():
        if n < 2:
            continue
        group = [i for i, other in enumerate(names) if other == name]
        common = _common_dir([found[i].path for i in group])
        for i in group:
            names[i] = _output_name(Path(os.path.relpath(os.path.abspath(found[i].path), common)), ending=ending)
        clash = Counter(names[i] for i in group)
        for i in group:
            if clash[names[i]] > 1:  # same folder, same name, another extension: keep the whole name
                names[i] = _output_name(Path(os.path.relpath(os.path.abspath(found[i].path), common)), True, ending)
        shown = ", ".join(f"{found[i].path} -> {names[i]}" for i in group)
        notes.append(f"{n} inputs would write {name}; written as: {shown}")
    twice = [str(name) for name, n in Counter(names).items() if n > 1]
    if twice:
        raise ValueError(f"outputs still named alike after renaming: {', '.join(twice[:_SHOWN])}; run them apart")
    reserved = [str(n) for n in names if str(n) in (SUMMARY_CSV, SUMMARY_TXT)]
    if reserved:
        raise ValueError(f"an output would be named {reserved[0]}, the batch's summary; rename that input")
    inputs = {os.path.realpath(f.path): f.path for f in found}
    jobs = []
    for k, (f, name) in enumerate(zip(found, names, strict=True)):
        out = outdir / name
        clash_with = inputs.get(os.path.realpath(out))
        if clash_with is not None:
            raise ValueError(f"the output {out} would overwrite the input {clash_with}; choose another -o directory")
        jobs.append(Job(k, str(f.path), str(out), str(f.path), str(name)))
    return jobs, notes


def _check_outdir(outdir: Path) -> None:
    if outdir.exists() and not outdir.is_dir():
        raise ValueError(f"with many inputs -o names a directory, and {outdir} is a file")
    if not outdir.exists() and outdir.suffix.lower() in registered_extensions():
        raise ValueError(
            f"with many inputs -o names a directory (one output per input inside it); {outdir} looks like a file "
            f"name: give a directory, e.g. -o {outdir.with_suffix('')}"
        )


def _existing(jobs: list[Job], policy: str | None) -> tuple[list[Job], list[Outcome], str | None]:
    """``(jobs to run, outcomes of the outputs kept, a note)`` for outputs already there (module docstring)."""
    there = [j for j in jobs if os.path.lexists(j.output)]
    if not there:
        return jobs, [], None
    listing = ", ".join(j.name for j in there[:_SHOWN]) + (
        f" and {len(there) - _SHOWN} more" if len(there) > _SHOWN else ""
    )
    if policy is None:
        raise ValueError(
            f"the output directory already holds {len(there)} of the {len(jobs)} outputs ({listing}); pass "
            "--existing overwrite to replace them, or --existing skip to keep them and run the other inputs"
        )
    if policy == "overwrite":
        return jobs, [], f"replacing {len(there)} existing output(s): {listing}"
    kept = {j.index for j in there}
    outcomes = [Outcome(j.index, j.shown, j.name, "kept", "its output exists (--existing skip)") for j in there]
    return [j for j in jobs if j.index not in kept], outcomes, f"kept {len(there)} existing output(s): {listing}"


def run_many(args: argparse.Namespace, one: OneFile) -> int:
    """The batch (module docstring): ``one(args_for_a_file, report=..., on_chunk=..., announce=...)`` estimates
    one file, as ``omegahat estimate`` does; returns the exit code."""
    if args.frame_id is not None or args.output_topic is not None:
        raise ValueError(
            "with many inputs the outputs are CSV or Parquet files; --frame-id and --output-topic are for one bag"
        )
    if args.times is not None:
        raise ValueError("--times names the times of one pose list; with many inputs give --rate, or run them apart")
    if getattr(args, "torque", None) is not None:
        raise ValueError("--torque names the torques of one attitude log; with many inputs run them apart")
    if args.dask is not None and args.jobs is not None:
        raise ValueError("--jobs is for this machine; with --dask the cluster's workers run the files")
    outdir = args.output
    _check_outdir(outdir)
    found, skipped = find_logs(args.input)
    if not found:
        why = "; ".join(f"{p}: {r}" for p, r in skipped[:_SHOWN])
        raise ValueError(f"no logs found in {', '.join(map(str, args.input))}" + (f" ({why})" if why else ""))
    jobs, notes = plan_outputs(found, outdir, "." + (args.output_format or OUTPUT_FORMATS[0]))
    todo, kept, note = _existing(jobs, args.existing)
    if note:
        notes.append(note)
    for n in notes:
        print(f"note: {n}")
    if skipped:
        print(
            f"skipped {len(skipped)}: "
            + "; ".join(f"{p} ({r})" for p, r in skipped[:_SHOWN])
            + (" ..." if len(skipped) > _SHOWN else "")
        )
    outdir.mkdir(parents=True, exist_ok=True)
    for j in todo:
        Path(j.output).parent.mkdir(parents=True, exist_ok=True)
    outcomes, interrupt, where = run_jobs(todo, args, one)
    outcomes = sorted(kept + outcomes, key=lambda o: o.index)
    table = summary_table(outcomes)
    print(table)
    counts = Counter(o.status for o in outcomes)
    tally = ", ".join(f"{counts[s]} {s}" for s in STATUSES if counts[s])
    write_summary(outdir, outcomes, table, skipped, notes)
    print(f"{len(outcomes)} files ({tally}) {where}; summary: {outdir / SUMMARY_CSV}, {outdir / SUMMARY_TXT}")
    if interrupt is not None:
        raise interrupt  # the command's own ending: one line, exit 130 (SIGINT) or 143 (SIGTERM)
    return 1 if counts.get("failed") else 0


def summary_table(outcomes: list[Outcome]) -> str:
    """The printed table: one row per input, the status last (a failure's message can be long)."""
    head = ("file", "format", "rows", "estimator", "expected error", "status")
    rows = [
        (
            o.shown,
            o.format or "-",
            "-" if o.rows is None else str(o.rows),
            o.estimator or "-",
            "-" if o.expected is None else f"{o.expected:.2g} rad/s",
            o.status + (f": {o.message}" if o.message else ""),
        )
        for o in outcomes
    ]
    widths = [max(len(r[c]) for r in [head, *rows]) for c in range(len(head) - 1)]
    return "\n".join("  ".join(r[c].ljust(widths[c]) for c in range(len(widths))) + "  " + r[-1] for r in [head, *rows])


def write_summary(
    outdir: Path, outcomes: list[Outcome], table: str, skipped: list[tuple[str, str]], notes: list[str]
) -> None:
    """:data:`SUMMARY_CSV` and :data:`SUMMARY_TXT` in ``outdir``, each written whole (a temporary file renamed)."""
    rows = io.StringIO()
    w = csv.writer(rows, lineterminator="\n")
    w.writerow(
        [
            "input",
            "output",
            "format",
            "rows",
            "estimator",
            "expected_rms_rad_s",
            "status",
            "message",
            "notes",
            "seconds",
        ]
    )
    for o in outcomes:
        w.writerow(
            [
                o.shown,
                o.output,
                o.format,
                "" if o.rows is None else o.rows,
                o.estimator,
                "" if o.expected is None else f"{o.expected:.6g}",
                o.status,
                o.message,
                " | ".join(o.notes),
                f"{o.seconds:.3f}",
            ]
        )
    text = [table, ""]
    text += [f"note: {n}" for n in notes]
    text += [f"skipped {p}: {r}" for p, r in skipped]
    for o in outcomes:
        if o.report:
            text += ["", f"== {o.shown} -> {o.output}", *o.report]
    for name, content in ((SUMMARY_CSV, rows.getvalue()), (SUMMARY_TXT, "\n".join(text) + "\n")):
        tmp = outdir / f".{name}.part"
        tmp.write_text(content, encoding="utf-8")
        os.replace(tmp, outdir / name)
