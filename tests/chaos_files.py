"""The chaos suite's engine (issue 23), shared by ``tests/test_chaos_*.py`` (a small budget, in CI) and
``benchmarks/chaos.py`` (a longer seeded run): valid files of every reader, mutated, read, and each outcome classified.

**Seeds.** :func:`make_seeds` writes one valid file per reader (omegahat's CSV with an ignored column, the same
under comment lines, NPZ, Motive, Vicon, C3D, ROS 1 and ROS 2 bags, a CCSDS AEM...) and knows how many rows reading it
gives.

**Mutations** (:data:`TEXT_MUTATIONS`, :data:`BINARY_MUTATIONS`), seeded: byte flips, truncation, a block of
zeros, a duplicated block; for text also a stray quote (anywhere, or opening a field), CR-LF or CR-only line ends, a
deleted or doubled line, a line broken in two.

**Outcomes** (:func:`read_case`), each case exactly one of:

* ``rows``: read, with the right number of rows: every row of the file that is not blank, less those a note says
  were dropped (exact duplicates). For text formats the rows are counted independently, as the non-blank lines after
  the seed's header lines; for binary formats they are the seed's;
* ``message``: refused with an error the command prints as one line (``ValueError``, ``OSError``) naming the file;
* ``unnamed``: such an error that does not name the file (a failure: the user cannot tell which file);
* ``silent``: read, with a different number of rows and no note saying why (a failure: rows lost or merged
  without a word);
* ``traceback``: any other exception (a failure); ``crash``: the process died (a failure; subprocess readers only).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from omegahat.io import read_log

FAILURES = ("unnamed", "silent", "traceback", "crash")
TEXT_MUTATIONS = (
    "flip", "truncate", "zeros", "duplicate", "quote", "quote_field", "crlf", "cr", "drop_line", "double_line", "split",
)  # fmt: skip
BINARY_MUTATIONS = ("flip", "truncate", "zeros", "duplicate")
_DROPPED = re.compile(r"dropped (\d+) duplicated sample")


@dataclass
class Seed:
    """A valid file of one reader: ``files`` (relative path -> bytes; a ROS 2 bag is a folder of two), the file
    the mutations hit (``target``), what :func:`read_log` is given (``entry``, ``options``), the rows it reads,
    and for text formats the non-blank header lines before the rows."""

    name: str
    files: dict[str, bytes]
    target: str
    entry: str
    rows: int
    header_lines: int | None = None
    options: dict = field(default_factory=dict)
    subprocess: bool = False  # read in a child process (a reader that can take the process down)

    @property
    def mutations(self) -> tuple[str, ...]:
        return TEXT_MUTATIONS if self.header_lines is not None else BINARY_MUTATIONS


def make_seeds(folder: Path, rows: int = 120) -> list[Seed]:
    """One valid file per reader, written in ``folder`` (module docstring)."""
    from scipy.spatial.transform import Rotation

    from logmaker import constant_rate
    from recording_files import write_bag, write_motive_csv, write_vicon_csv
    from test_rosbag import motion, pose_messages

    if folder.exists():
        shutil.rmtree(folder)  # the bag writers never overwrite
    folder.mkdir(parents=True)
    t = np.arange(rows) / 100.0
    q = constant_rate(t, np.array([0.1, -0.2, 0.3])).as_quat()
    seeds = []

    csv = ["t,qw,qx,qy,qz,note"] + [
        ",".join(repr(float(x)) for x in (t[k], q[k, 3], q[k, 0], q[k, 1], q[k, 2])) + f",frame {k}"
        for k in range(rows)
    ]
    seeds.append(Seed("csv", {"log.csv": ("\n".join(csv) + "\n").encode()}, "log.csv", "log.csv", rows, 1))
    # comment lines with delimiters above the header (a tool's banner): comments, since names follow them
    banner = ["# exported by Tool, version 1.2", "# frame: world, units: s, quaternion", *csv]
    seeds.append(
        Seed("csv-comments", {"tool.csv": ("\n".join(banner) + "\n").encode()}, "tool.csv", "tool.csv", rows, 3)
    )

    np.savez(folder / "log.npz", t=t, q=q)
    seeds.append(Seed("npz", {"log.npz": (folder / "log.npz").read_bytes()}, "log.npz", "log.npz", rows))

    import pyarrow as pa
    import pyarrow.parquet as pq

    pq.write_table(
        pa.table({"t": t, "qx": q[:, 0], "qy": q[:, 1], "qz": q[:, 2], "qw": q[:, 3]}), folder / "log.parquet"
    )
    parquet = (folder / "log.parquet").read_bytes()
    seeds.append(Seed("parquet", {"log.parquet": parquet}, "log.parquet", "log.parquet", rows))

    write_motive_csv(folder / "take.csv", t, {"wand": q})
    motive = (folder / "take.csv").read_bytes()
    seeds.append(Seed("motive", {"take.csv": motive}, "take.csv", "take.csv", rows, 6, {"body": "wand"}))

    R = Rotation.from_quat(q).as_matrix()
    write_vicon_csv(folder / "trial.csv", np.arange(rows) + 1, 100.0, {"drone": R}, trajectories=False)
    vicon = (folder / "trial.csv").read_bytes()
    seeds.append(Seed("vicon", {"trial.csv": vicon}, "trial.csv", "trial.csv", rows, 5, {"body": "drone"}))

    from vendor_files import write_qtm_mat

    write_qtm_mat(folder / "take.mat", {"drone": R}, 100.0)
    seeds.append(Seed("qtm-mat", {"take.mat": (folder / "take.mat").read_bytes()}, "take.mat", "take.mat", rows))

    from test_mocap import write_c3d

    write_c3d(folder / "trial.c3d", {"drone": R}, 100.0)
    c3d = (folder / "trial.c3d").read_bytes()
    seeds.append(Seed("c3d", {"trial.c3d": c3d}, "trial.c3d", "trial.c3d", rows, subprocess=True))

    stamps, bag_q, _ = motion(rows)
    pose = ("geometry_msgs/msg/PoseStamped", pose_messages(stamps, bag_q))
    write_bag(folder / "run.bag", 1, {"/p": pose})
    seeds.append(Seed("rosbag1", {"run.bag": (folder / "run.bag").read_bytes()}, "run.bag", "run.bag", rows))
    write_bag(folder / "run2", 2, {"/p": pose})
    files = {f"run2/{p.name}": p.read_bytes() for p in sorted((folder / "run2").iterdir())}
    (db,) = [name for name in files if name.endswith(".db3")]
    seeds.append(Seed("rosbag2", files, db, "run2", rows))

    # a CCSDS AEM (version 2.0 leaves out DATA_START / DATA_STOP, so every line after the metadata is a row)
    head = ["CCSDS_AEM_VERS = 2.0", "ORIGINATOR = TEST", "META_START", "OBJECT_NAME = SAT", "REF_FRAME_A = EME2000"]
    head += ["REF_FRAME_B = SC_BODY_1", "TIME_SYSTEM = UTC", "ATTITUDE_TYPE = QUATERNION", "META_STOP"]
    epochs = [f"2026-01-01T00:00:{k // 100:02d}.{k % 100:02d}" for k in range(rows)]
    aem = head + [f"{e} " + " ".join(repr(float(x)) for x in q[k]) for k, e in enumerate(epochs)]
    seeds.append(Seed("aem", {"att.aem": ("\n".join(aem) + "\n").encode()}, "att.aem", "att.aem", rows, len(head)))

    # a Universal Robots RTDE recording (blank-separated; the tool's rotation vector in actual_TCP_pose_3..5)
    names = ["timestamp", *(f"actual_q_{i}" for i in range(6)), *(f"actual_TCP_pose_{i}" for i in range(6))]
    rv = Rotation.from_quat(q).as_rotvec()
    ur = [" ".join(names)] + [
        " ".join(repr(float(x)) for x in (12.5 + k * 0.008, *range(6), 0.1, 0.2, 0.3, *rv[k])) for k in range(rows)
    ]
    seeds.append(Seed("ur-rtde", {"robot_data.csv": ("\n".join(ur) + "\n").encode()}, "robot_data.csv",
                      "robot_data.csv", rows, 1))  # fmt: skip

    # the trajectories of robotics: TUM and KITTI (blank-separated, a '#' line above the poses), EuRoC (ns stamps)
    tum = ["# timestamp tx ty tz qx qy qz qw"]
    tum += [" ".join(repr(float(x)) for x in (1.7e9 + t[k], 1.0, 2.0, 3.0, *q[k])) for k in range(rows)]
    seeds.append(Seed("tum", {"traj.txt": ("\n".join(tum) + "\n").encode()}, "traj.txt", "traj.txt", rows, 1))
    kitti = ["# t r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz"]
    kitti += [
        " ".join(repr(float(x)) for x in (t[k], *np.column_stack([R[k], [1, 2, 3]]).ravel())) for k in range(rows)
    ]
    seeds.append(Seed("kitti", {"poses.txt": ("\n".join(kitti) + "\n").encode()}, "poses.txt", "poses.txt", rows, 1))
    euroc = ["#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],q_RS_z []"]
    euroc += [
        ",".join(
            [str(1403715524900000000 + 10_000_000 * k), "1.0", "2.0", "3.0", *map(repr, map(float, q[k, [3, 0, 1, 2]]))]
        )
        for k in range(rows)
    ]
    seeds.append(Seed("euroc", {"data.csv": ("\n".join(euroc) + "\n").encode()}, "data.csv", "data.csv", rows, 1))
    # an Xsens MT Manager export: a '//' preamble, tabs, empty SampleTimeFine fields, R column by column
    xsens = ["// Start Time: Unknown", "// Update Rate: 100.0Hz", "// Filter Profile: human (46.1)"]
    xsens += ["\t".join(["PacketCounter", "SampleTimeFine", *(f"Mat[{i}][{j}]" for j in "123" for i in "123")])]
    xsens += ["\t".join([f"{k:05d}", "", *(f"{x:.6f}" for x in R[k].T.ravel())]) for k in range(rows)]
    seeds.append(Seed("xsens", {"mt.txt": ("\n".join(xsens) + "\n").encode()}, "mt.txt", "mt.txt", rows, 4))
    # an Xsens DOT's CSV: 'sep=,' and 'Key:,value' lines, a blank line, the device clock in µs
    dot = ["sep=,", "DeviceTag:,dot1,,,,", "OutputRate:,100Hz,,,,", "", "PacketCounter,SampleTimeFine,Quat_W,Quat_X,"
           "Quat_Y,Quat_Z"]  # fmt: skip
    dot += [", ".join([str(k), str(5_000_000 + 10_000 * k), *map(repr, map(float, q[k, [3, 0, 1, 2]]))])
            for k in range(rows)]  # fmt: skip
    seeds.append(Seed("xsens-dot", {"dot.csv": ("\n".join(dot) + "\n").encode()}, "dot.csv", "dot.csv", rows, 4))
    return seeds


# ----------------------------------------------------------------------------------------------- mutations


def _lines(data: bytes) -> list[bytes]:
    return data.split(b"\n")


def _line_span(lines: list[bytes], i: int) -> tuple[int, int]:
    start = sum(len(line) + 1 for line in lines[:i])
    return start, start + len(lines[i]) + 1


def mutate(data: bytes, kind: str, rng: np.random.Generator) -> tuple[bytes, int, int]:
    """``(mutated, start, end)``: ``data`` with one mutation of ``kind`` (module docstring), drawn from ``rng``;
    ``[start, end)`` is the part of ``data`` it changed (an insertion: ``start == end``; a change of every line
    end: the whole)."""
    b = bytearray(data)
    n = len(b)
    if kind == "flip":  # 1 to 4 bytes within 8
        k = int(rng.integers(n))
        hit = sorted({min(n - 1, k + int(rng.integers(8))) for _ in range(int(rng.integers(1, 5)))} | {k})
        for j in hit:
            b[j] ^= int(rng.integers(1, 256))
        return bytes(b), hit[0], hit[-1] + 1
    if kind == "truncate":
        k = int(rng.integers(n))
        return bytes(b[:k]), k, n
    if kind == "zeros":
        k, m = int(rng.integers(n)), int(rng.integers(1, 64))
        b[k : k + m] = bytes(len(b[k : k + m]))
        return bytes(b), k, min(n, k + m)
    if kind == "duplicate":
        k, m = int(rng.integers(n)), int(rng.integers(1, 256))
        return bytes(b[: k + m] + b[k : k + m] + b[k + m :]), min(n, k + m), min(n, k + m)
    if kind == "crlf":
        return data.replace(b"\n", b"\r\n"), 0, n
    if kind == "cr":
        return data.replace(b"\n", b"\r"), 0, n
    lines = _lines(data)
    body = [i for i, line in enumerate(lines) if line.strip()]
    i = body[int(rng.integers(len(body)))]
    start, end = _line_span(lines, i)
    if kind == "quote":  # anywhere in a line
        line = lines[i]
        k = int(rng.integers(len(line) + 1))
        lines[i] = line[:k] + b'"' + line[k:]
    elif kind == "quote_field":  # opening a field: the start of a quoted field that never ends
        fields = lines[i].split(b",")
        j = int(rng.integers(len(fields)))
        fields[j] = b'"' + fields[j]
        lines[i] = b",".join(fields)
    elif kind == "drop_line":
        del lines[i]
    elif kind == "double_line":
        lines.insert(i, lines[i])
    elif kind == "split":
        line = lines[i]
        k = int(rng.integers(1, max(2, len(line))))
        lines[i : i + 1] = [line[:k], line[k:]]
    else:
        raise ValueError(f"unknown mutation {kind!r}")
    return b"\n".join(lines), start, end


def text_rows(data: bytes, header_lines: int) -> int:
    """The rows of a text file counted independently of the readers: its non-blank lines (any line end: LF, CR-LF,
    CR) after the first ``header_lines`` non-blank ones."""
    text = data.decode("latin-1").lstrip("\ufeff")
    lines = [line for line in re.split(r"\r\n|\r|\n", text) if line.strip()]
    return max(0, len(lines) - header_lines)


def header_end(data: bytes, header_lines: int) -> int:
    """The offset in a (seed) text file where its rows begin."""
    seen, pos = 0, 0
    for line in data.split(b"\n"):
        pos += len(line) + 1
        seen += bool(line.strip())
        if seen == header_lines:
            return pos
    return len(data)


def expected_rows(seed: Seed, mutated: bytes, kind: str, start: int, end: int) -> int | None:
    """The rows a mutated file holds (module docstring), None where that cannot be told from outside (a mutation
    across the end of a text file's header). Binary formats: the seed's (a damaged file must be refused)."""
    if seed.header_lines is None:
        return seed.rows
    h_end = header_end(seed.files[seed.target], seed.header_lines)
    if kind in ("crlf", "cr") or start >= h_end:
        return text_rows(mutated, seed.header_lines)  # the header's lines are as they were
    if kind == "truncate":
        return 0  # cut inside the header: no rows
    if end <= h_end:
        return seed.rows  # the header changed, not a row
    return None


# ------------------------------------------------------------------------------------------------- outcomes


@dataclass
class Case:
    """One mutated file: the seed, the mutation and its random seed, the outcome and what was seen."""

    seed: str
    mutation: str
    rng_seed: int
    outcome: str = ""
    detail: str = ""


def classify_read(entry: Path, name: str, expected: int | None, read: Callable[[], object]) -> tuple[str, str]:
    """``(outcome, detail)`` of reading a file (module docstring); ``name`` is what a message must mention."""
    try:
        log = read()
    except (ValueError, OSError) as exc:
        text = str(exc)
        return ("message" if name in text else "unnamed"), f"{type(exc).__name__}: {text[:300]}"
    except Exception as exc:
        return "traceback", f"{type(exc).__name__}: {str(exc)[:300]}"
    rows = len(log)  # type: ignore[arg-type]
    notes = " ".join(getattr(log, "notes", ()))
    dropped = sum(int(m) for m in _DROPPED.findall(notes))
    if expected is None or rows + dropped == expected:
        return "rows", f"{rows} rows" + (f" (+{dropped} dropped, said)" if dropped else "")
    return "silent", f"{rows} rows read (+{dropped} said dropped), {expected} in the file; notes: {notes[:200]}"


def write_case(seed: Seed, folder: Path, data: bytes) -> Path:
    """Write the seed's files in ``folder`` with the target replaced by ``data``; the path to read."""
    for rel, content in seed.files.items():
        p = folder / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(data if rel == seed.target else content)
    return folder / seed.entry


def run_cases(
    seed: Seed, folder: Path, n: int, base_seed: int = 0, mutations: tuple[str, ...] | None = None
) -> list[Case]:
    """``n`` mutated files of ``seed``, ``mutations`` (default: the seed's) in turn, each from its own seed
    ``base_seed + k`` (replayable: ``mutate(seed data, kind, np.random.default_rng(base_seed + k))``); the case
    folders are kept for replay."""
    kinds = seed.mutations if mutations is None else mutations
    cases = []
    for k in range(n):
        kind = kinds[k % len(kinds)]
        rng = np.random.default_rng(base_seed + k)
        data, start, end = mutate(seed.files[seed.target], kind, rng)
        case_dir = folder / f"{seed.name}-{base_seed + k}"
        entry = write_case(seed, case_dir, data)
        expected = expected_rows(seed, data, kind, start, end)
        cases.append(Case(seed.name, kind, base_seed + k, "", json.dumps([str(entry), expected])))
    if seed.subprocess:
        _classify_in_children(seed, cases)
    else:
        for case in cases:
            entry, expected = json.loads(case.detail)
            case.outcome, case.detail = classify_read(
                Path(entry), Path(entry).name, expected, lambda e=entry: read_log(e, **seed.options)
            )
    return cases


_CHILD = """
import json, sys
from pathlib import Path
from chaos_files import classify_read
from omegahat.io import read_log
options = json.loads(sys.argv[1])
for line in sys.stdin:
    entry, expected = json.loads(line)
    out = classify_read(Path(entry), Path(entry).name, expected, lambda: read_log(entry, **options))
    print(json.dumps(out), flush=True)
"""


def _classify_in_children(seed: Seed, cases: list[Case]) -> None:
    """Classify cases in a child process (a reader that can abort the process: C3D through ezc3d); a child that
    dies marks its case ``crash`` and a new child takes the rest."""
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), *sys.path])}
    todo = list(cases)
    while todo:
        child = subprocess.Popen(
            [sys.executable, "-c", _CHILD, json.dumps(seed.options)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env,
        )
        assert child.stdin is not None and child.stdout is not None
        while todo:
            case = todo[0]
            try:
                child.stdin.write(case.detail + "\n")
                child.stdin.flush()
            except BrokenPipeError:
                line = ""
            else:
                line = child.stdout.readline()
            if not line:  # the child died on this case
                child.wait()
                err = child.stderr.read() if child.stderr else ""
                case.outcome, case.detail = "crash", f"exit {child.returncode}: {err.strip()[-300:]}"
                todo.pop(0)
                break
            case.outcome, case.detail = json.loads(line)
            todo.pop(0)
        else:
            child.stdin.close()
            child.wait()


def counts(cases: list[Case]) -> Counter:
    """Outcomes counted (module docstring)."""
    return Counter(c.outcome for c in cases)


def failures(cases: list[Case]) -> list[Case]:
    """The cases with a failing outcome."""
    return [c for c in cases if c.outcome in FAILURES]


def describe(cases: list[Case]) -> str:
    """The failing cases, one per line, replayable (seed, mutation, random seed)."""
    return "\n".join(f"{c.seed} {c.mutation} rng={c.rng_seed}: {c.outcome}: {c.detail}" for c in failures(cases))
