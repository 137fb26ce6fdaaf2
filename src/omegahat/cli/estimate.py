r"""``omegahat estimate INPUT -o OUTPUT``: angular velocity from attitude data, in whatever format it is.

A thin shell: the options become :class:`omegahat.io.ReadOptions` (how to read the input) and
:class:`omegahat.io.settings.EstimateSettings` (what to estimate with), and :func:`omegahat.io.pipeline.estimate_stream`
does the work on the stream :func:`omegahat.io.open_log` opens, writing through :func:`omegahat.io.open_output`;
messages name the options as flags (:func:`cli_option`).

Input (:mod:`omegahat.io`, recognised from the file): omegahat's CSV (a header naming the columns: ``t`` plus a
quaternion ``qw,qx,qy,qz``, a rotation matrix ``r11..r33``, body-frame directions ``b1x,b1y,b1z,b2x,...`` with
``--references``, or Euler angles ``roll,pitch,yaw`` with ``--euler`` and ``--angle-unit``; optionally the torque
``tau_x,tau_y,tau_z``, N·m, body axes) or NPZ log; an OptiTrack Motive or Vicon CSV export or a C3D file
(``--body``); a ROS 1 bag (``.bag``) or ROS 2 bag (directory) with ``--topic`` and, for transforms,
``--parent-frame``/``--child-frame``. Conventions, each an option with a stated default: ``--time-unit s``,
``--rotation body-to-inertial`` (``v_inertial = R v_body``; spacecraft logs often store the inverse:
``inertial-to-body``), ``--scalar-first``/``--scalar-last`` (SciPy's name; only for unnamed quaternions: NPZ ``q``
arrays, default scalar last, or ``q0..q3``/``q1..q4`` columns).

Output: ``-o X.csv``: ``t,wx,wy,wz,status``: rad/s in **body axes**, one row per sample (duplicates dropped by
the timestamp policy have none); ``status`` is ``corrected``, ``predicted`` (no usable sample there: predicted
through), ``unavailable`` (no estimate yet: ``nan``) or ``restarted`` (``nan``: the step to that sample
could not be taken and the estimator started again from it). For a bag input also ``-o X.bag`` (ROS 1) or ``-o X``
(ROS 2): ``geometry_msgs/TwistStamped``, header stamps copied. Written under a temporary name beside the target
and renamed at the end: whole or absent. Several inputs, a directory or a glob: :mod:`omegahat.cli.many` runs
:func:`estimate_file` on each (``-o`` a directory, a summary table).

Estimator: by default the model (a random-walk rate or acceleration; with ``--inertia``, Euler's equations with or
without an unknown torque) and its noises identified from the log by their likelihood
(:func:`omegahat.identification.identify`), and then the observer supervising the model's gyro-less Kalman filter,
or backward differencing where the model predicts no gain over it (what was found and why is printed);
``--estimator omegahat`` runs the model's filter whatever the prediction; ``--estimator sarras`` (or ``--bandwidth``,
``--k``/``--l``) the fixed-gain observer, its gains automatic unless given
(:func:`omegahat.observer.autogain.select_gains`); ``--preset mocap`` the motion-capture preset
(:mod:`omegahat.observer.presets`). ``--smooth``: the offline, zero-lag estimate of the identified model (or the
preset's). The estimate starts
from a least-squares fit of the rate over the first window of the log (``--start fit``; ``warm``: from the first
two samples, as ``SarrasEstimator(warm_start=True)``; ``zero``: from rest).
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np
from tqdm import tqdm

from omegahat import measurements as ms
from omegahat.cli import add_column_options, add_euler_conventions, add_quaternion_order, many
from omegahat.io import ReadOptions, check_output, open_log, open_output
from omegahat.io.gyrolog import column_triple
from omegahat.io.output import AtomicOutput
from omegahat.io.pipeline import RunSummary, estimate_stream
from omegahat.io.registry import ROTATIONS, STAMPS, TIME_UNITS, LogStream
from omegahat.io.rosbag import DEFAULT_TWIST_TOPIC
from omegahat.io.settings import ESTIMATORS, PRESETS, STARTS, EstimateSettings
from omegahat.io.torque_log import TORQUE, attach_torque, read_torque_log
from omegahat.kernels import compiling
from omegahat.observer.gains import ObserverGains

EPILOG = """\
input:  a CSV whose header names the columns (any order, any case; ',' ';' or tab), or an NPZ of named arrays:
          t                   sample times (--time-unit, default s), in order
          qw,qx,qy,qz         attitude quaternion (names say which is the scalar), or
          r11,r12,...,r33     rotation matrix, row i column j, or
          b1x,b1y,b1z,b2x,... body-frame directions of known inertial ones (--references); one direction
                              alone (a sun sensor) needs a tumbling body and --inertia (its own observer), or
          roll,pitch,yaw      Euler angles about x, y, z, with --euler SEQ and --angle-unit deg|rad
          rotvec_x,rotvec_y,rotvec_z  a rotation vector (axis times angle), radians
          tau_x,tau_y,tau_z   optional known torque, N m, body axes
        an attitude with an empty field, nan or inf is a missing sample; other columns are ignored.
        other names: --columns t=NAME,qw=NAME,... (or positions t=1,qw=2,...), --header-rows N.
        Also, recognised from the file: OptiTrack Motive and Vicon CSV exports, Qualisys 6D TSV and MAT, C3D files
        with rigid-body rotations (--body), EuRoC CSV, TUM and KITTI (--rate/--times) trajectories, ROS 1
        bags (.bag) and ROS 2 bags (directory) (--topic, frames), PX4 flight logs (.ulg, --topic) and ulog2csv's CSV,
        CCSDS attitude ephemeris messages (AEM, text or XML: frames, direction and epochs as the file states them),
        Universal Robots RTDE recordings (the tool's actual_TCP_pose; rates in the tool's axes), Xsens MT Manager
        exports and DOT CSV files (Quat_q0..q3, Mat[i][j], Roll, Pitch, Yaw or Quat_W..Z; rates in the sensor's
        axes, compared with an MT Manager export's Gyr_X..Z; --rate HZ where the export does not state it).
        A time column named time, timestamp, Time (s)... is read where there is no t; ISO 8601 dates as seconds
        since 1970 UTC; one quaternion named by its parts (quat_w, orientation.x...) without --columns.
        Equal times: the same attitude is one sample (dropped), different attitudes are an error
        (--duplicate-times first|last keeps one, counted and reported).
output: t,wx,wy,wz,status  rad/s in body axes; status corrected | predicted (missing sample, gap) |
        unavailable (no estimate yet: nan) | restarted (nan: the step could not be taken, started
        again from that sample); for a bag input also -o X.bag (ROS 1) or -o X (ROS 2):
        geometry_msgs/TwistStamped in the body frame, header stamps copied; for an AEM input also -o X.aem:
        the attitudes and the rates (deg/s, spacecraft axes) as a CCSDS AEM of type QUATERNION/ANGVEL
many:   several inputs, a directory or a quoted glob: each log as alone, with the same options; -o OUTDIR gets
        one CSV per input (same name) and omegahat-summary.csv/.txt (file, format, rows, estimator, expected
        error, status); exit 0: all written, 1: some failed (named in the summary), 130/143: interrupted
example: omegahat estimate log.csv -o omega.csv --inertia 300 250 200
         omegahat estimate "Take 01.csv" --body hand --preset mocap --smooth -o omega.csv
         omegahat estimate dirs.csv -o omega.csv "--references=0,0,9.81;-0.9,15.5,-41.3"
         omegahat estimate run.bag --topic /vicon/body/pose -o twist.bag
         omegahat estimate takes/ 'more/**/*.tsv' -o omega/
"""

PROGRESS_MIN_BYTES = 4_000_000  # show progress bars from this input size on (unless told otherwise)

#: option keys (:class:`omegahat.io.settings.EstimateSettings`' fields, :class:`omegahat.io.ReadOptions`') whose flag
#: is not ``--`` and the key with dashes
FLAGS = {"bandwidth_hz": "--bandwidth", "gains": "--k/--l"}


def cli_option(key: str, value: object = None) -> str:
    """An option as the command line spells it in messages: ``--rotation-tol 0.02``, ``--skip-bad-samples`` (a
    switch: value None or True), ``"--references=X,Y,Z"`` (quoted: ``;`` ends a shell command)."""
    flag = FLAGS.get(key, "--" + key.replace("_", "-"))
    if key == "references" and value is not None:
        return f'"{flag}={value}"'
    if value is None or value is True:
        return flag
    return f"{flag} {value:g}" if isinstance(value, float) else f"{flag} {value}"


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
    parser.add_argument(
        "input",
        type=Path,
        nargs="+",
        metavar="INPUT",
        help="attitude data: an omegahat log (.csv, .npz, .parquet), a Motive or Vicon CSV export, a C3D file, a ROS "
        "1 bag (.bag) or a ROS 2 bag (directory); recognised from the file. Several files, a directory or a quoted "
        "glob ('logs/**/*.csv'): every log in them, -o then names a directory (see 'many files' below)",
    )
    parser.add_argument(
        "-o",
        "--output",
        type=Path,
        required=True,
        help="output: X.csv (t,wx,wy,wz,status; rad/s, body axes) or X.parquet (the same columns); for a bag input "
        "also X.bag (ROS 1) or X (ROS 2 directory) of geometry_msgs/TwistStamped; for a CCSDS AEM input also "
        "X.aem (QUATERNION/ANGVEL); with many inputs a directory (OUTDIR)",
    )
    many.add_arguments(parser)
    conv = parser.add_argument_group("conventions of the input")
    conv.add_argument(
        "--time-unit",
        choices=list(TIME_UNITS),
        default="s",
        help="unit of the time column (default s, or the unit its name states: timestamp_ns, Time (ms))",
    )
    conv.add_argument("--time-column", default="t", metavar="NAME", help="name of the time column (default t)")
    conv.add_argument(
        "--rotation",
        choices=ROTATIONS,
        default="body-to-inertial",
        help="what the attitude maps: body-to-inertial (default; v_inertial = R v_body, SciPy, ROS) or "
        "inertial-to-body (many spacecraft logs); the output is in body axes either way",
    )
    add_column_options(conv)
    add_quaternion_order(
        conv,
        "NPZ array q (default: scalar last) or columns q0..q3 / q1..q4 (one of --scalar-first/--scalar-last required "
        "there); named columns qw,qx,qy,qz need neither",
    )
    add_euler_conventions(conv)
    model = parser.add_argument_group("model and gains")
    model.add_argument(
        "--inertia",
        type=float,
        nargs="+",
        metavar="J",
        help="inertia: 3 numbers (diagonal) or 9 (row-major); default identity (then the model is a constant rate)",
    )
    model.add_argument(
        "--torque",
        type=Path,
        metavar="FILE",
        help="known torques from a log of their own (t and tau_x,tau_y,tau_z, N m, body axes, on the attitude's "
        "clock): each row held until the next, averaged over each interval between attitude samples; with --inertia",
    )
    model.add_argument(
        "--torque-columns",
        metavar="X,Y,Z",
        help="the torque log's three columns by name or 1-based position (default: tau_x,tau_y,tau_z or torque_x,...)",
    )
    model.add_argument(
        "--bandwidth",
        type=float,
        metavar="HZ",
        help="bandwidth in Hz, b (below half the sample rate), as tuning.sensor_gains(bandwidth_hz=...): every error "
        "mode of the estimate decays at least as exp(-2 pi b t) (for direction sensors every mode at that rate, "
        "whatever their geometry); default: chosen from the log (printed)",
    )
    model.add_argument(
        "--estimator",
        choices=ESTIMATORS,
        default="auto",
        help="auto (default): the model and noises identified from the log, then the observer supervising its "
        "gyro-less Kalman filter, or backward differencing where the model predicts no gain; omegahat: the model's "
        "filter (with --smooth its smoother) always; sarras: the fixed-gain observer (also what --bandwidth or "
        "--k/--l ask for)",
    )
    model.add_argument(
        "--preset",
        choices=PRESETS,
        help="mocap: motion capture of a body whose inertia and torques are unknown (a hand, a tool, a robot link), "
        "10-1000 Hz: the model and gains are chosen from the sample rate (docs/theory/mocap.md); causal",
    )
    model.add_argument(
        "--smooth",
        action="store_true",
        help="offline, zero-lag estimate of the whole log: the identified model's forward and backward passes "
        "combined or the log's own Wiener smoother (its spectrum and noise), whichever expects the lower error (the "
        "Wiener smoother where no model is chosen; for directions it filters their least-squares attitudes); with "
        "--preset: the preset's; any input kind, with or without --inertia; reads the whole log into memory",
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
    rec = parser.add_argument_group(
        "recordings (ROS bags, motion-capture exports)",
        "Bags: the orientation on one topic (PoseStamped, TransformStamped or tf2_msgs/TFMessage on /tf, Odometry, "
        "Imu). PX4 ULog: one attitude topic (vehicle_attitude by default). Motive, Vicon, C3D: one rigid body.",
    )
    rec.add_argument(
        "--topic",
        help="bag or ULog topic to read (optional when one topic carries an orientation; a ULog's vehicle_attitude)",
    )
    rec.add_argument("--parent-frame", metavar="FRAME", help="for /tf and transforms: the fixed (parent) frame")
    rec.add_argument("--child-frame", metavar="FRAME", help="for /tf and transforms: the body (child) frame")
    rec.add_argument(
        "--stamp",
        choices=STAMPS,
        default="header",
        help="bag time: the messages' header stamps (default) or the time the recorder received them",
    )
    rec.add_argument(
        "--body",
        metavar="NAME",
        help="rigid body / object / segment of a Motive, Vicon, Qualisys or C3D file; the spacecraft frame of an AEM",
    )
    rec.add_argument(
        "--rate",
        type=float,
        metavar="HZ",
        help="times of a log without any (a KITTI pose list, a CSV log without a time column, or one whose "
        "--columns leave it out): row / HZ",
    )
    rec.add_argument("--times", metavar="FILE", help="times of a pose list without any (KITTI): one time in s per line")
    rec.add_argument(
        "--output-topic",
        metavar="TOPIC",
        help=f"topic of the TwistStamped messages in a bag output (default {DEFAULT_TWIST_TOPIC})",
    )
    rec.add_argument(
        "--frame-id",
        metavar="FRAME",
        help="frame_id of the output messages (default: the body frame the input names, else 'body')",
    )
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


def _per_direction(values, n: int, name: str) -> np.ndarray:
    a = np.asarray(values, dtype=float)
    if a.size == 1:
        a = np.full(n, a.item())
    if a.shape != (n,):
        raise ValueError(f"--{name} takes one number or {n} (one per direction); got {a.size}: {values}")
    return a


def _given_gains(args, stream) -> ObserverGains | None:
    """``--k``/``--l`` as gains (one number, or one per direction of the input), checked against ``--bandwidth``."""
    if args.bandwidth is not None and (args.k is not None or args.l is not None):
        raise ValueError("give either --bandwidth or --k and --l, not both")
    if (args.k is None) != (args.l is None):
        raise ValueError("--k and --l go together (or use --bandwidth)")
    if args.k is None:
        return None
    n = stream.n_directions if stream.kind == "directions" else 3
    if args.references is not None and stream.kind != "directions":
        n = len(args.references)
    return ObserverGains(k=_per_direction(args.k, n, "k"), l_offset=_per_direction(args.l, n, "l"))


def run(args: argparse.Namespace) -> int:
    """One input (a file, or a ROS 2 bag directory): :func:`estimate_file`; several, a directory or a glob:
    :func:`omegahat.cli.many.run_many`, which runs :func:`estimate_file` on each."""
    if many.is_many(args.input):
        return many.run_many(args, estimate_file)
    many.refuse_batch_options(args)
    args.input = args.input[0]
    estimate_file(args)
    return 0


def estimate_file(
    args: argparse.Namespace,
    report: Callable[[str], None] = print,
    on_chunk: Callable[[int], None] | None = None,
    announce: Callable[[str], None] | None = None,
) -> tuple[LogStream, RunSummary]:
    """``omegahat estimate args.input -o args.output``: what was read and chosen, and the closing lines, go to
    ``report``; ``on_chunk(rows)`` after each chunk (a stop request may raise ``KeyboardInterrupt`` there: the
    output is then absent); ``announce``: the compilation notice (default standard error)."""
    compiled = compiling.seconds()
    if not args.input.exists():
        raise FileNotFoundError(f"[Errno 2] No such file or directory: '{args.input}'")
    options = ReadOptions(
        time_unit=args.time_unit,
        scalar_first=args.scalar_first,
        rotation=args.rotation,
        time_column=args.time_column,
        body=args.body,
        topic=args.topic,
        parent_frame=args.parent_frame,
        child_frame=args.child_frame,
        stamp=args.stamp,
        columns=args.columns,
        header_rows=args.header_rows,
        rate=args.rate,
        times=args.times,
        duplicate_times=args.duplicate_times,
        euler=args.euler,
        angle_unit=args.angle_unit,
    )
    torque_log = [] if args.torque is None else [args.torque]
    out, kind = check_output(
        args.output, args.input, frame_id=args.frame_id, topic=args.output_topic, also_read=torque_log
    )
    stream = open_log(args.input, options)
    if args.torque is not None and args.inertia is None:
        raise ValueError("--torque needs --inertia: the torques enter Euler's equations through J")
    if args.torque is not None:
        attach_torque(stream, read_torque_log(args.torque, args.time_unit, column_triple(args.torque_columns, TORQUE)))
    elif args.torque_columns is not None:
        raise ValueError("--torque-columns names the columns of a --torque FILE; give the file")
    settings = EstimateSettings(
        inertia=None if args.inertia is None else np.array(args.inertia),
        references=args.references,
        gains=_given_gains(args, stream),
        bandwidth_hz=args.bandwidth,
        start=args.start,
        estimator=args.estimator,
        skip_bad_samples=args.skip_bad_samples,
        rotation_tol=args.rotation_tol,
        quat_norm_tol=args.quat_norm_tol,
        preset=args.preset,
        smooth=args.smooth,
    )
    by_bytes = stream.label == "line" and stream.n_rows_hint is None
    show = args.progress if args.progress is not None else by_bytes and stream.size >= PROGRESS_MIN_BYTES
    unit = "B" if by_bytes else " rows"
    bar = tqdm(total=stream.size, unit=unit, unit_scale=True, desc="estimating", disable=not show, file=sys.stderr)

    def progress(rows: int) -> None:
        bar.n = min(stream.done, stream.size) if by_bytes else rows
        bar.refresh()
        if on_chunk is not None:
            on_chunk(rows)

    def writer(s: LogStream) -> AtomicOutput:
        return open_output(out, kind, s, frame_id=args.frame_id, topic=args.output_topic)

    with bar:
        summary = estimate_stream(
            stream, settings, writer, report=report, progress=progress, announce=announce, spell=cli_option
        )
        bar.n = bar.total
        bar.refresh()
    report(f"wrote {summary.output}; estimated in {summary.elapsed:.2f} s{compiling.wait_note(compiled)}")
    for line in summary.lines:
        report(line)
    return stream, summary
