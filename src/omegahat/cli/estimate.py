r"""``omegahat estimate INPUT -o OUTPUT``: angular velocity from an attitude (or direction) log.

Input (:mod:`omegahat.io`): a CSV with a header naming the columns (any order, any case; ``,`` ``;`` or tab), or
an NPZ of named arrays. Columns: ``t`` plus one attitude group: a quaternion ``qw,qx,qy,qz``, a rotation matrix
``r11..r33``, or body-frame directions ``b1x,b1y,b1z,b2x,...`` (with ``--references``); optionally the torque
``tau_x,tau_y,tau_z`` (N·m, body axes). Empty fields are missing samples. Conventions, each an option with a
stated default: ``--time-unit s``, ``--rotation body-to-inertial`` (``v_inertial = R v_body``; spacecraft logs
often store the inverse: ``inertial-to-body``), ``--quaternion-order`` (needed only for unnamed quaternions: NPZ
``q`` arrays, default x,y,z,w, or ``q0..q3``/``q1..q4`` columns).

Output: ``t,wx,wy,wz,status``: rad/s in **body axes**, one row per input row; ``status`` is ``corrected``,
``predicted`` (no usable sample there: predicted through) or ``unavailable`` (no estimate yet: ``nan``).
Written to a temporary file beside the target and renamed at the end: whole or absent.

Gains: automatic unless ``--bandwidth`` (Hz, as ``tuning.sensor_gains(bandwidth_hz=...)``) or ``--k``/``--l``
are given: :func:`omegahat.observer.autogain.choose_gains` measures the log's rate, noise and unmodelled motion
and picks the bandwidth of least expected error; what was chosen and why is printed. The estimate starts from a
least-squares fit of the rate over the first window of the log (``--start fit``; ``warm``: from the first two
samples, what ``SarrasEstimator(warm_start=True)``, the library's default, does; ``zero``: from rest).

The log is streamed in chunks through the compiled estimator, so memory does not grow with its length.
"""

from __future__ import annotations

import argparse
import re
import signal
import sys
import threading
import time
import warnings
from pathlib import Path

import numpy as np
from tqdm import tqdm

from omegahat import measurements as ms
from omegahat.io import LogFormatError, OmegaWriter, ReadOptions, check_output_path, open_log
from omegahat.io.output import CORRECTED, PREDICTED, UNAVAILABLE
from omegahat.io.registry import ROTATIONS, TIME_UNITS, prefetch
from omegahat.observer import autogain
from omegahat.observer.estimator import SarrasEstimator, SkippedSamplesWarning
from omegahat.observer.gains import ObserverGains
from omegahat.observer.tuning import predicted_noise_std
from omegahat.validation import as_directions, as_inertia

HELP = "Estimate the angular velocity (rad/s, body axes) from an attitude log (CSV or NPZ)."
EPILOG = """\
input:  a CSV whose header names the columns (any order, any case; ',' ';' or tab), or an NPZ of named arrays:
          t                   sample times (--time-unit, default s), strictly increasing
          qw,qx,qy,qz         attitude quaternion (names say which is the scalar), or
          r11,r12,...,r33     rotation matrix, row i column j, or
          b1x,b1y,b1z,b2x,... body-frame directions of known inertial ones (--references)
          tau_x,tau_y,tau_z   optional known torque, N m, body axes
        empty fields (or nan) are missing samples; other columns are ignored.
output: t,wx,wy,wz,status  rad/s in body axes; status corrected | predicted (missing sample, gap) |
        unavailable (no estimate yet: nan)
example: omegahat estimate log.csv -o omega.csv --inertia 300 250 200
         omegahat estimate dirs.csv -o omega.csv "--references=0,0,9.81;-0.9,15.5,-41.3"
"""

PROGRESS_MIN_BYTES = 4_000_000  # show progress bars from this input size on (unless told otherwise)
STARTS = ("fit", "warm", "zero")


def _numbers(text: str) -> list[float]:
    try:
        values = [float(x) for x in text.replace(",", " ").split()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected numbers, got {text!r}") from None
    if not values:
        raise argparse.ArgumentTypeError("expected numbers, got nothing")
    return values


def _directions(text: str) -> list[list[float]]:
    """``"x,y,z;x,y,z;..."`` → one 3-vector per ``;``-separated direction."""
    out = []
    for part in text.split(";"):
        v = _numbers(part)
        if len(v) != 3:
            raise argparse.ArgumentTypeError(f"a reference direction is 3 numbers x,y,z; got {part.strip()!r}")
        out.append(v)
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument("input", type=Path, metavar="INPUT", help="attitude log, .csv or .npz")
    parser.add_argument(
        "-o", "--output", type=Path, required=True, help="output CSV: t,wx,wy,wz,status (rad/s, body axes)"
    )
    conv = parser.add_argument_group("conventions of the input")
    conv.add_argument("--time-unit", choices=list(TIME_UNITS), default="s", help="unit of the time column (default s)")
    conv.add_argument("--time-column", default="t", metavar="NAME", help="name of the time column (default t)")
    conv.add_argument(
        "--rotation",
        choices=ROTATIONS,
        default="body-to-inertial",
        help="what the attitude maps: body-to-inertial (default; v_inertial = R v_body, SciPy, ROS) or "
        "inertial-to-body (many spacecraft logs); the output is in body axes either way",
    )
    conv.add_argument(
        "--quaternion-order",
        choices=["wxyz", "xyzw"],
        help="order of unnamed quaternions: NPZ array q (default xyzw, SciPy) or columns q0..q3 / q1..q4 "
        "(required there); named columns qw,qx,qy,qz need none",
    )
    model = parser.add_argument_group("model and gains")
    model.add_argument(
        "--inertia",
        type=float,
        nargs="+",
        metavar="J",
        help="inertia: 3 numbers (diagonal) or 9 (row-major); default identity (then the model is a constant rate)",
    )
    model.add_argument(
        "--bandwidth",
        type=float,
        metavar="HZ",
        help="bandwidth in Hz (below half the sample rate), as tuning.sensor_gains(bandwidth_hz=...); default: "
        "chosen from the log (printed)",
    )
    model.add_argument("--k", type=float, nargs="+", help="gain k_i: one number or one per direction")
    model.add_argument("--l", type=float, nargs="+", help="gain l_i: one number or one per direction")
    model.add_argument(
        "--references",
        type=_directions,
        metavar="X,Y,Z;X,Y,Z",
        help="known inertial directions, ';' between directions, quoted and written with '=' (example below: "
        "unquoted, a shell takes ; as the end of the command); required for b1x.. direction input; for attitude "
        "input default: the three rows of R",
    )
    model.add_argument(
        "--start",
        choices=STARTS,
        default="fit",
        help="initial rate: fit (default; least-squares over the first window of the log), warm (from the first "
        "two samples, as SarrasEstimator(warm_start=True)) or zero",
    )
    model.add_argument("--warm-start", dest="start", action="store_const", const="warm", help="same as --start warm")
    model.add_argument("--no-warm-start", dest="start", action="store_const", const="zero", help="same as --start zero")
    bad = parser.add_argument_group("bad samples")
    bad.add_argument(
        "--skip-bad-samples",
        action="store_true",
        help="treat samples that are not rotations (or quaternions far from unit norm, zero directions) as missing, "
        "count and report them, instead of stopping at the first",
    )
    bad.add_argument(
        "--rotation-tol",
        type=float,
        default=ms.ROTATION_TOL,
        metavar="TOL",
        help=f"accept matrices with |R^T R - I| <= TOL (default {ms.ROTATION_TOL:g})",
    )
    bad.add_argument(
        "--quat-norm-tol",
        type=float,
        default=ms.QUAT_NORM_TOL,
        metavar="TOL",
        help=f"accept quaternions with |norm - 1| <= TOL (default {ms.QUAT_NORM_TOL:g})",
    )
    bar = parser.add_mutually_exclusive_group()
    bar.add_argument("--progress", dest="progress", action="store_true", default=None, help="always show progress")
    bar.add_argument("--no-progress", dest="progress", action="store_false", help="never show progress")


# ---------------------------------------------------------------------------------------------- helpers


def _per_direction(values, n: int, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.size == 1:
        a = np.full(n, a.item())
    if a.shape != (n,):
        raise ValueError(f"--{name} takes one number or {n} (one per direction); got {a.size}: {values}")
    return a


def _references(args, stream) -> np.ndarray:
    if stream.kind == "directions":
        n = stream.n_directions
        if args.references is None:
            raise ValueError(
                f"{stream.source} holds {n} body-frame directions (b1..b{n}): give their inertial "
                f'directions with "--references=X,Y,Z;X,Y,Z" (one per direction, quoted)'
            )
        if len(args.references) != n:
            raise ValueError(f"{stream.source} holds {n} directions but --references gives {len(args.references)}")
    if args.references is None:
        return np.eye(3)
    return as_directions(np.array(args.references), name="--references")


def _rejection(status: int, info: float, args) -> str:
    if status == ms.NOT_ORTHOGONAL:
        return (
            f"not a rotation matrix: |R^T R - I| = {info:.3g} exceeds --rotation-tol {args.rotation_tol:g} "
            f"(pass --rotation-tol {2 * info:.2g} to accept it, or --skip-bad-samples to skip such samples)"
        )
    if status == ms.NOT_PROPER:
        return f"a reflection, not a rotation: det R = {info:.6g} < 0 (--skip-bad-samples skips such samples)"
    if status == ms.QUAT_NORM:
        return (
            f"a quaternion far from unit norm: |q| = {info:.6g}, |(|q| - 1)| exceeds --quat-norm-tol "
            f"{args.quat_norm_tol:g} (pass --quat-norm-tol {2 * abs(info - 1):.2g} to accept it, "
            "--skip-bad-samples to skip such samples, or check --quaternion-order)"
        )
    if status == ms.ZERO_DIRECTION:
        return f"measured direction b{int(info) + 1} has zero length (--skip-bad-samples skips such samples)"
    return f"rejected (status {status})"


class _Bad:
    """Rejected samples: checked chunk by chunk, dropped (NaN) with --skip-bad-samples, else an error."""

    def __init__(self, args, stream):
        self.args, self.stream, self.count, self.first = args, stream, 0, []

    def check(self, chunk) -> None:
        st, info = ms.sample_status(
            chunk.data,
            directions=self.stream.kind == "directions",
            rotation_tol=self.args.rotation_tol,
            quat_norm_tol=self.args.quat_norm_tol,
        )
        bad = np.flatnonzero(st >= ms.ERROR)
        if not bad.size:
            return
        k = int(bad[0])
        text = _rejection(int(st[k]), float(info[k]), self.args)
        if not self.args.skip_bad_samples:
            raise LogFormatError(f"{self.stream.where(int(chunk.labels[k]), self.stream.attitude_name)}: {text}")
        chunk.data[bad] = np.nan
        self.count += bad.size
        for j in bad[: max(0, 5 - len(self.first))]:
            self.first.append((int(chunk.labels[j]), _rejection(int(st[j]), float(info[j]), self.args)))


def _gains(args, J, refs, motion, duration, start):
    """``(gains, explanation, bandwidth rad/s for the fit window)``: an override or :func:`choose_gains`."""
    n = refs.shape[0]
    if args.bandwidth is not None and (args.k is not None or args.l is not None):
        raise ValueError("give either --bandwidth or --k and --l, not both")
    if (args.k is None) != (args.l is None):
        raise ValueError("--k and --l go together (or use --bandwidth)")
    rate = motion.rate_hz
    if args.k is not None:
        g = ObserverGains(k=_per_direction(args.k, n, "k"), l_offset=_per_direction(args.l, n, "l"))
        M = sum(g.k[i] * (np.eye(3) - np.outer(refs[i], refs[i])) for i in range(n))
        lam = float(np.linalg.eigvals(np.linalg.solve(J, M)).real.min())  # slowest continuous mode, rad/s
        omega_b = np.log1p(lam / rate) * rate  # what the implicit correction makes of it per sample
        noise = float(np.linalg.norm(predicted_noise_std(J, g, rate, motion.sigma, refs)))
        text = f"k, l given: slowest mode {lam / (2 * np.pi):.3g} Hz, predicted noise {noise:.2g} rad/s"
        if lam / (2 * np.pi) >= rate / 2:
            text += (
                f"\nwarning: these gains act faster than the Nyquist frequency {rate / 2:.4g} Hz of this log: the "
                "estimate is close to raw differencing of the attitude; the automatic gains would filter it"
            )
        return g, text, omega_b
    if args.bandwidth is not None:
        b = args.bandwidth
        if not (np.isfinite(b) and b > 0):
            raise ValueError(f"--bandwidth must be a positive number of Hz; got {b!r}")
        if b >= rate / 2:
            raise ValueError(
                f"--bandwidth {b:g} Hz is not below the Nyquist frequency {rate / 2:.4g} Hz of this log ({rate:.4g} Hz "
                "samples); choose a lower one, or leave --bandwidth out for gains chosen from the log"
            )
        g = autogain.gains_for_bandwidth(J, rate, b, refs, motion.sigma)
        noise, lag, st = autogain.expected_error(motion, g, 2 * np.pi * b, duration, start, refs)
        text = (
            f"bandwidth {b:g} Hz given; expected RMS error {np.sqrt(noise**2 + lag**2 + st**2):.2g} rad/s "
            f"(noise {noise:.2g}, lag {lag:.2g}, start-up {st:.2g})"
        )
        return g, text, 2 * np.pi * b
    choice = autogain.choose_gains(motion, duration, start, refs)
    return choice.gains, "gains: " + choice.explain(), 2 * np.pi * choice.bandwidth_hz


def _time_unit_warning(args, h: float, t0: float) -> str | None:
    rate = 1.0 / h
    if abs(t0) > 1e11 or not (0.5 <= rate <= 5000.0):
        scale = TIME_UNITS[args.time_unit]
        better = [u for u, f in TIME_UNITS.items() if u != args.time_unit and 0.5 <= 1.0 / (h / scale * f) <= 5000.0]
        tip = "".join(
            f"; if the times are in {u}, pass --time-unit {u} ({1.0 / (h / scale * TIME_UNITS[u]):.4g} Hz)"
            for u in better[:1]
        )
        return f"warning: samples are {h:.4g} s apart ({rate:.4g} Hz) with --time-unit {args.time_unit}{tip}"
    return None


def _check_head(head, stream, refs, bad, args) -> float:
    """Validate the head of the log with the estimator's own compiled checks (a throwaway estimator: this also
    compiles, or loads from the cache, the kernels the run needs, and says so if it takes long); only if it
    rejects a sample are the samples checked one by one (:class:`_Bad`). Returns the seconds it took."""
    timer = threading.Timer(
        0.5, lambda: print("compiling kernels, once (later runs load them from the cache) ...", file=sys.stderr)
    )
    t0 = time.perf_counter()
    timer.start()
    try:
        probe = SarrasEstimator(
            np.eye(3),
            gains=ObserverGains.constant(1.0, 1.0, n=refs.shape[0]),
            references=refs,
            measurement="directions" if stream.kind == "directions" else "attitude",
            warm_start=False,
            rotation_tol=args.rotation_tol,
            quat_norm_tol=args.quat_norm_tol,
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkippedSamplesWarning)
            for c in head:
                try:
                    probe.run(c.t, c.data, c.torque)
                except ms.MeasurementError:
                    bad.check(c)  # raises naming the line, or (--skip-bad-samples) turns bad samples into missing
                    probe.run(c.t, c.data, c.torque)
    finally:
        timer.cancel()
    return time.perf_counter() - t0


def _row_status(est_status: np.ndarray, first_estimate: int) -> np.ndarray:
    """Output status per row: PREDICTED where the sample was skipped, UNAVAILABLE before ``first_estimate``."""
    out = np.where(est_status == ms.OK, CORRECTED, PREDICTED).astype(np.int8)
    out[:first_estimate] = UNAVAILABLE
    return out


class _Run:
    """One pass over the stream: bad samples, estimation, gaps, output (state kept across chunks)."""

    def __init__(self, est, stream, writer, bad, start: str, h: float):
        self.est, self.stream, self.writer, self.bad, self.start = est, stream, writer, bad, start
        self.valid_seen = 0  # valid samples so far (the estimate exists from the 1st (fit) or 2nd (warm, zero))
        self.rows = 0
        self.gap_limit, self.gaps, self.largest = 2.0 * h, 0, (0.0, None)
        self.t_prev = None
        self.elapsed = 0.0

    def _estimate(self, chunk) -> np.ndarray:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", SkippedSamplesWarning)  # counted and reported once, at the end
            return self.est.run(chunk.t, chunk.data, chunk.torque)

    def feed(self, chunk) -> None:
        t0 = time.perf_counter()
        try:
            W = self._estimate(chunk)
        except ms.MeasurementError:  # a sample is not a rotation: find it (line, column), skip it or stop there
            self.bad.check(chunk)  # run() is atomic: the estimator is as before the call
            W = self._estimate(chunk)
        except ValueError as exc:  # not expected after the reader's checks; name the line anyway
            lab = chunk.labels
            raise ValueError(
                re.sub(r"sample (\d+)", lambda m: f"{self.stream.label} {lab[int(m.group(1))]}", str(exc))
            ) from None
        self.elapsed += time.perf_counter() - t0
        st = self.est.last_status
        ok = np.flatnonzero(st == ms.OK)
        need = 1 if self.start == "fit" else 2  # the valid sample from which on there is an estimate
        first = len(chunk) if self.valid_seen + ok.size < need else int(ok[max(0, need - 1 - self.valid_seen)])
        if self.valid_seen >= need:
            first = 0
        self.valid_seen += ok.size
        status = _row_status(st, first)
        W[status == UNAVAILABLE] = np.nan
        self.writer.write(chunk.t, W, status)
        self.rows += len(chunk)
        dt = np.diff(chunk.t if self.t_prev is None else np.concatenate([[self.t_prev], chunk.t]))
        big = np.flatnonzero(dt > self.gap_limit)
        self.gaps += big.size
        if big.size:
            j = int(big[np.argmax(dt[big])])
            if dt[j] > self.largest[0]:
                self.largest = (float(dt[j]), int(chunk.labels[j + 1 if self.t_prev is None else j]))
        self.t_prev = float(chunk.t[-1])


def _head(stream, chunks) -> tuple[list, int]:
    """Chunks from the start until HEAD_SAMPLES rows (kept for the real pass), and the rows in them."""
    head, rows = [], 0
    for chunk in chunks:
        head.append(chunk)
        rows += len(chunk)
        if rows >= autogain.HEAD_SAMPLES:
            break
    return head, rows


def run(args) -> int:
    if not args.input.exists():
        raise FileNotFoundError(f"[Errno 2] No such file or directory: '{args.input}'")
    out = check_output_path(args.output, [args.input])
    options = ReadOptions(
        time_unit=args.time_unit,
        quaternion_order=args.quaternion_order,
        rotation=args.rotation,
        time_column=args.time_column,
    )
    stream = open_log(args.input, options)
    for note in stream.notes:
        print(f"note: {note}")
    J = np.eye(3) if args.inertia is None else as_inertia(np.array(args.inertia), name="--inertia")
    refs = _references(args, stream)
    bad = _Bad(args, stream)
    chunks = prefetch(stream.chunks())
    head, n_head = _head(stream, chunks)
    compile_s = _check_head(head, stream, refs, bad, args)
    t_h = np.concatenate([c.t for c in head])
    data_h = np.concatenate([c.data for c in head])
    tau_h = np.concatenate([c.torque for c in head]) if stream.has_torque else None
    ok = np.all(np.isfinite(data_h.reshape(t_h.size, -1)), axis=1)
    if ok.sum() < 3:
        raise LogFormatError(
            f"{stream.source}: only {int(ok.sum())} usable samples in the first {n_head}; at least 3 "
            "are needed to estimate a rate"
        )
    tv, rot = autogain.log_rotations(t_h, data_h, stream.kind, refs)
    motion = autogain.measure_motion(tv, rot, J, None if tau_h is None else tau_h[ok])
    finished = n_head < autogain.HEAD_SAMPLES or stream.n_rows_hint == n_head
    duration = float(t_h[-1] - t_h[0])
    if not finished:
        total = stream.n_rows_hint or (stream.size / max(stream.done, 1) * n_head)
        duration *= total / n_head
    warning = _time_unit_warning(args, motion.h, float(t_h[0]))
    if warning:
        print(warning)
    gains, text, omega_b = _gains(args, J, refs, motion, duration, args.start)
    print(text)
    if args.inertia is not None and stream.has_torque and stream.kind != "directions":
        given, other = autogain.convention_check(motion)
        if other < 0.5 * given:
            flip = ROTATIONS[1 - ROTATIONS.index(args.rotation)]
            print(
                f"warning: Euler's equations with this J and torque fit the data {given / other:.1f}x better with "
                f"the attitude inverted (residual {other:.3g} against {given:.3g} N m): is the log {flip}? "
                f"(pass --rotation {flip})"
            )
    omega0 = None
    if args.start == "fit":
        window = autogain.fit_window(omega_b, motion.rate_hz)
        omega0 = autogain.initial_rate(tv, rot, window, J, motion.torque)
    est_args = dict(
        J=J,
        gains=gains,
        references=refs,
        measurement="directions" if stream.kind == "directions" else "attitude",
        warm_start=args.start == "warm",
        omega_hat0=omega0,
        rotation_tol=args.rotation_tol,
        quat_norm_tol=args.quat_norm_tol,
    )
    est = SarrasEstimator(**est_args)
    show = args.progress if args.progress is not None else stream.size >= PROGRESS_MIN_BYTES and stream.label == "line"
    previous = (
        signal.signal(signal.SIGTERM, _terminate) if threading.current_thread() is threading.main_thread() else None
    )
    try:
        with (
            OmegaWriter(out) as writer,
            tqdm(
                total=stream.size,
                unit="B" if stream.label == "line" else " rows",
                unit_scale=True,
                desc="estimating",
                disable=not show,
                file=sys.stderr,
            ) as bar,
        ):
            job = _Run(est, stream, writer, bad, args.start, motion.h)
            del t_h, data_h, tau_h, tv, rot, motion
            while head:  # the head first (releasing it as it goes), then the rest of the stream
                job.feed(head.pop(0))
            for chunk in chunks:
                job.feed(chunk)
                bar.n = min(stream.done, stream.size) if stream.label == "line" else job.rows
                bar.refresh()
            bar.n = bar.total
            bar.refresh()
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    _summary(job, est, bad, out, compile_s)
    k_text, l_text = (np.array2string(a, precision=4) for a in (gains.k, gains.l_offset))
    print(f"gains used: k = {k_text}, l = {l_text}, J diag = {np.diag(J).tolist()}, start: {args.start}")
    return 0


def _terminate(signum, frame):
    raise KeyboardInterrupt("terminated")


def _summary(job, est, bad, out, compile_s) -> None:
    print(
        f"wrote {job.rows} estimates to {out} (t,wx,wy,wz,status; rad/s in body axes); estimated in "
        f"{job.elapsed:.2f} s" + (f" (kernels compiled once in {compile_s:.1f} s before)" if compile_s > 0.5 else "")
    )
    skipped = est.n_missing + est.n_collinear
    if skipped:
        print(
            f"skipped {skipped} of {job.rows} samples ({est.n_missing} missing, {est.n_collinear} with nearly "
            "collinear directions): predicted through (status 'predicted')"
        )
    if bad.count:
        lines = "; ".join(f"{job.stream.label} {lab}: {why.split(' (')[0]}" for lab, why in bad.first)
        print(f"--skip-bad-samples: {bad.count} bad samples treated as missing (first: {lines})")
    if job.gaps:
        print(
            f"gaps: {job.gaps} intervals longer than twice the median spacing; the longest {job.largest[0]:.4g} s "
            f"before {job.stream.label} {job.largest[1]} (predicted through)"
        )
