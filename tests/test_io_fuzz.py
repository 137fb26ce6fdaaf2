"""Property-based fuzz of the CSV reader (Hypothesis): random headers, delimiters, encodings, number formats, NaNs,
repeated rows and times (the timestamp policy), glitches and truncations. Every input either parses to the values an
independent reference parser (plain Python, below) reads from the same text, or raises :class:`LogFormatError`;
never another exception; and the command never leaves a partial output file."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from omegahat.cli import main
from omegahat.io import LogFormatError, read_log

NAMES = ("t", "qw", "qx", "qy", "qz")
ENCODINGS = ("utf-8", "utf-8-sig", "utf-16")


def _number(text: str, delim: str) -> float:
    """The reference number syntax: what float() reads, without digit grouping; a decimal comma unless ','."""
    s = text.strip()
    if delim != ",":
        s = s.replace(",", ".")
    if "_" in s or not s:
        raise ValueError(s)
    return float(s)


def reference(raw: bytes, encoding: str, delim: str):
    """``(t, q xyzw)`` as the documented format says, or None where the reader must refuse the file."""
    try:
        text = raw.decode(encoding)
    except UnicodeDecodeError:
        return None
    text = text.lstrip("\ufeff")
    lines = [line[:-1] if line.endswith("\r") else line for line in text.split("\n")]
    strip = " \t\r,;\"'"
    i = next((k for k, line in enumerate(lines) if line.strip(strip)), None)
    if i is None:
        return None
    names = [n.strip().lower() for n in lines[i].split(delim)]
    if not set(NAMES) <= set(names) or len(set(names)) != len(names):
        return None
    idx = [names.index(n) for n in NAMES]
    t, q = [], []
    for line in lines[i + 1 :]:
        fields = line.split(delim)
        if not any(f.strip() for f in fields):
            continue
        if len(fields) != len(names):
            return None
        vals = []
        for j in idx:
            f = fields[j]
            if not f.strip():
                vals.append(None)
                continue
            try:
                vals.append(_number(f, delim))
            except ValueError:
                return None
        if vals[0] is None or not math.isfinite(vals[0]):
            return None
        att = vals[1:]
        if any(v is None or not math.isfinite(v) for v in att):
            att = [math.nan] * 4
        t.append(vals[0])
        q.append([att[1], att[2], att[3], att[0]])
    if not t or _not_rotations(q):
        return None
    return _timestamp_policy(t, q)


def _not_rotations(q) -> bool:
    """The documented rule (3) of omegahat.io.precision, written out independently: the file is refused when more
    than half of its first 1000 valid quaternions are plainly no rotation, ``|‖q‖ − 1| > 0.1``."""
    valid = [v for v in q if all(math.isfinite(x) for x in v)][:1000]
    plain = sum(abs(math.sqrt(sum(x * x for x in v)) - 1.0) > 0.1 for v in valid)
    return 2 * plain > len(valid)


def _timestamp_policy(t, q):
    """The documented policy (omegahat.io.timestamps), written out independently: times must not decrease; at an
    equal time the same rotation (matrices within 1e-6, SciPy's) is dropped, a missing sample gives way to a valid
    one, different rotations refuse the file."""
    keep_t, keep_q = [], []
    for ti, qi in zip(t, q, strict=True):
        if keep_t and ti < keep_t[-1]:
            return None
        if keep_t and ti == keep_t[-1]:
            prev = keep_q[-1]
            if not all(math.isfinite(v) for v in qi):
                continue
            if not all(math.isfinite(v) for v in prev):
                keep_q[-1] = qi
                continue
            Ra, Rb = Rotation.from_quat(prev).as_matrix(), Rotation.from_quat(qi).as_matrix()
            if np.linalg.norm(Ra - Rb) <= 1e-6:
                continue
            return None
        keep_t.append(ti)
        keep_q.append(qi)
    return np.array(keep_t), np.array(keep_q)


def fmt(x: float, style: int, delim: str) -> str:
    s = [repr(x), f"{x:.6g}", f"{x:.4e}", f" {x!r} "][style]
    return s.replace(".", ",") if delim != "," and style == 1 else s


@st.composite
def logs(draw):
    delim = draw(st.sampled_from([",", ";", "\t"]))
    encoding = draw(st.sampled_from(ENCODINGS))
    order = draw(st.permutations([*NAMES, "note"]))
    header = delim.join(draw(st.sampled_from([n, n.upper(), f" {n} ", n.capitalize()])) for n in order)
    n = draw(st.integers(1, 12))
    rows = []
    t = 0.0
    q = None
    for _ in range(n):
        if q is not None and draw(st.integers(0, 9)) == 0:  # the same sample again (delivered twice)
            pass
        else:
            t += draw(st.sampled_from([0.01, 0.25, 1.0, -0.5, 0.0])) if draw(st.integers(0, 9)) == 0 else 0.01
            q = np.array(draw(st.lists(st.floats(-1, 1, allow_nan=False), min_size=4, max_size=4)))
            q = q + np.array([0, 0, 0, 2])
            q = q / np.linalg.norm(q)
        vals = {"t": t, "qx": q[0], "qy": q[1], "qz": q[2], "qw": q[3]}
        fields = []
        for name in order:
            if name == "note":
                fields.append(draw(st.sampled_from(["ok", "", "µ-glitch", "x y"])))
                continue
            kind = draw(st.integers(0, 29))
            if kind == 0:
                fields.append("")
            elif kind == 1:
                fields.append(draw(st.sampled_from(["nan", "NaN", "abc", "1_0", "--1", "inf"])))
            else:
                fields.append(fmt(float(vals[name]), draw(st.integers(0, 3)), delim))
        rows.append(delim.join(fields))
    newline = draw(st.sampled_from(["\n", "\r\n"]))
    blank = [""] if draw(st.booleans()) else []
    text = newline.join([header, *blank, *rows]) + newline
    raw = text.encode(encoding)
    if draw(st.integers(0, 3)) == 0:  # truncated anywhere (a copy cut short, a run killed while writing)
        raw = raw[: draw(st.integers(0, len(raw)))]
    return raw, encoding, delim


@settings(
    max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
@given(case=logs())
def test_reader_gives_the_right_values_or_its_own_error(tmp_path, case):
    raw, encoding, delim = case
    p = tmp_path / "f.csv"
    p.write_bytes(raw)
    ref = reference(raw, encoding, delim)
    try:
        log = read_log(p)
    except LogFormatError:
        assert ref is None, "the reference parser reads this file"
        return
    assert ref is not None, "the reference parser refuses this file"
    np.testing.assert_array_equal(log.t, ref[0])
    np.testing.assert_array_equal(log.data, precision_policy(ref[1], log.data))


def precision_policy(q, read):
    """The rows of ``q`` as the precision policy of ``docs/your-data.md`` hands them on: as written within the
    estimators' tolerance (1e-3); beyond it, either as written or divided by the norm, and the latter only up to
    the cap on the file tolerance (0.05), whichever the reader did (the exact tolerance follows the file's digits
    and is pinned by tests/test_io_columns.py)."""
    q = np.array(q, dtype=float)
    dev = np.abs(np.linalg.norm(q, axis=1) - 1.0)
    normalised = np.isfinite(dev) & (dev > 1e-3) & (dev <= 0.05) & ~np.all(read == q, axis=1)
    q[normalised] /= np.linalg.norm(q[normalised], axis=1, keepdims=True)
    return q


@settings(
    max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture]
)
@given(case=logs())
def test_the_command_writes_a_whole_file_or_none(tmp_path, case, capsys):
    raw, encoding, delim = case
    src, dst = tmp_path / "f.csv", tmp_path / "out" / "o.csv"
    dst.parent.mkdir(exist_ok=True)
    dst.unlink(missing_ok=True)
    src.write_bytes(raw)
    code = main(["estimate", str(src), "-o", str(dst), "--no-progress"])
    capsys.readouterr()
    leftovers = [q.name for q in dst.parent.iterdir() if q.name != "o.csv"]
    assert leftovers == []
    if code == 0:
        ref = reference(raw, encoding, delim)
        assert ref is not None
        assert len(dst.read_text().splitlines()) == 1 + ref[0].size
    else:
        assert code == 2
        assert not dst.exists()


@pytest.mark.parametrize("encoding", ENCODINGS)
def test_reference_parser_agrees_on_a_plain_file(tmp_path, encoding):
    # The oracle itself, on a file whose values are written out here by hand.
    text = "t,qw,qx,qy,qz\n0,1,0,0,0\n0.5,0,1,0,0\n"
    ref = reference(text.encode(encoding), encoding, ",")
    np.testing.assert_array_equal(ref[0], [0.0, 0.5])
    np.testing.assert_array_equal(ref[1], [[0, 0, 0, 1], [1, 0, 0, 0]])
