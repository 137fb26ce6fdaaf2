r"""``omegahat calibrate ATTITUDE GYRO``: a gyroscope calibrated against an attitude log of the same body.

A thin shell over :func:`omegahat.calibration.calibrate` (the method: its docstring and ``docs/calibrate.md``). The
attitude log is read by :func:`omegahat.io.read_log` (every format ``omegahat estimate`` reads, with the same
conventions and column options); the gyroscope log is a text or NPZ log of a time and three rate columns
(:func:`omegahat.io.gyrolog.read_gyro`). Prints what it read, then the table (:func:`table`:
each quantity ± one standard deviation), writes it as JSON with ``-o``
(:meth:`omegahat.calibration.Calibration.save`), and draws the residuals with ``--plot FILE.png`` (Matplotlib,
imported only then).
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import BinaryIO

import numpy as np

from omegahat import so3
from omegahat.calibration import MODES, Calibration, band_limited, calibrate
from omegahat.cli import add_column_options, add_euler_conventions, add_quaternion_order, positive_float
from omegahat.clock_offset import check_search
from omegahat.io import ReadOptions, read_log
from omegahat.io.gyrolog import column_triple, read_gyro
from omegahat.io.output import check_output_path, target_of, write_whole
from omegahat.io.registry import ROTATIONS, TIME_UNITS
from omegahat.io.time_units import implausible_spacing, unit_stated

EPILOG = """\
model:  gyro(t + offset) = A omega(t) + bias,  A = R (rotation gyro <- body), diag(s) R (--scale axes) or any 3x3
        matrix (--scale matrix: raw counts, permuted or mirrored axes); omega in body axes, rad/s
gyro:   a CSV with a header t,gx,gy,gz (or wx,wy,wz, gyro_x,gyro_y,gyro_z, ...: one such group, or one triple
        of names ending in x, y, z that name a gyroscope; any order, any case; other columns ignored; ',' ';' tab
        or blanks between them) or an NPZ with such arrays or g (M, 3); its own clock and rate
motion: turns about two axes or more for the whole rotation; about one axis (a hinge, a pendulum) the offset, the
        bias and the axis's direction are fitted, and the turn about it is left out (free_axis); a motion that repeats
        itself may match at another offset (a note says so): narrow the search with --offset and --max-offset
example: omegahat calibrate vicon.csv imu.csv --scale axes -o calibration.json --plot residuals.png
         omegahat calibrate mocap.npz raw_imu.csv --gyro-unit raw --scale matrix
"""
GYRO_UNITS = {"rad/s": 1.0, "deg/s": math.pi / 180.0, "raw": 1.0}


def table(cal: Calibration, unit: str = "rad/s") -> str:
    """The printed table of a calibration: each quantity ± one standard deviation."""

    def vec(v, s, fmt):
        return "[" + ", ".join(f"{a:{fmt}} ± {e:.2g}" for a, e in zip(v, s, strict=True)) + "]"

    deg = np.degrees(so3.log(cal.rotation))
    lines = [
        f"clock offset   {cal.offset:+.5f} s ± {cal.offset_std:.2g} s (gyro clock - attitude clock)",
        f"rotation       gyro <- body: rotation vector {np.array2string(deg, precision=3)} deg, "
        f"± [{', '.join(f'{e:.2g}' for e in np.degrees(cal.rotation_std))}] deg about the gyro axes"
        + ("" if cal.mode != "matrix" else " (nearest rotation to the matrix)"),
        "               rows " + "; ".join(np.array2string(r, precision=5) for r in cal.rotation),
    ]
    if cal.free_axis is not None:
        axis = np.array2string(cal.free_axis, precision=4, suppress_small=True)
        lines.append(f"               the turn about the gyro axis {axis} is not identified (one axis turned: note)")
    lines.append(f"bias           {vec(cal.bias, cal.bias_std, '.5g')} {unit}")
    if cal.mode != "none":
        std = cal.scale_std if cal.scale_std is not None else np.full(3, np.nan)
        per = f"{unit} per rad/s" if unit != "rad/s" else "(1 = none)"
        lines.append(f"scale          {vec(cal.scale, std, '.6g')} {per}")
    if cal.matrix_std is not None:
        for i in range(3):
            lines.append(f"matrix row {i + 1}   {vec(cal.matrix[i], cal.matrix_std[i], '.5g')}")
        lines.append(f"axes           {cal.axis_map()}")
    lines.append(
        f"residual RMS   {np.array2string(cal.residual_rms, precision=3)} {unit} per axis, in band "
        f"(< {cal.cutoff_hz:.3g} Hz), {cal.n_samples} samples; rate varies by "
        f"{np.array2string(cal.excitation, precision=3)} rad/s along its principal axes"
    )
    return "\n".join(lines + [f"note: {n}" for n in cal.notes])


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = EPILOG
    parser.add_argument(
        "attitude", type=Path, metavar="ATTITUDE", help="attitude log (any format omegahat estimate reads)"
    )
    parser.add_argument(
        "gyro", type=Path, metavar="GYRO", help="gyroscope log: CSV t,gx,gy,gz, NPZ, PX4 ULog or Xsens export"
    )
    parser.add_argument("-o", "--output", type=Path, help="write the calibration as JSON (for benchmarks/corpus.py)")
    parser.add_argument("--plot", type=Path, metavar="FILE.png", help="draw the band-limited gyro, model and residuals")
    fit = parser.add_argument_group("the fit")
    fit.add_argument(
        "--scale",
        choices=MODES,
        default="none",
        help="scale factors: none (default), axes (one per gyro axis) or matrix (a general 3x3: raw counts, permuted "
        "or mirrored axes)",
    )
    fit.add_argument(
        "--gyro-unit", choices=list(GYRO_UNITS), default="rad/s", help="unit of the gyro columns (raw needs --scale)"
    )
    fit.add_argument(
        "--cutoff", type=positive_float, metavar="HZ", help="band of the fit (default min(10 Hz, 0.4 x slower rate))"
    )
    fit.add_argument(
        "--offset",
        type=float,
        default=0.0,
        metavar="S",
        help="guess of the offset, gyro - attitude time (with --max-offset)",
    )
    fit.add_argument(
        "--max-offset",
        type=positive_float,
        metavar="S",
        help="search the offset within the guess +- this (default: every offset at which the logs overlap)",
    )
    att = parser.add_argument_group("conventions of the attitude log (as omegahat estimate)")
    att.add_argument("--time-unit", choices=list(TIME_UNITS), default="s")
    att.add_argument("--time-column", default="t", metavar="NAME")
    att.add_argument("--rotation", choices=ROTATIONS, default="body-to-inertial")
    add_quaternion_order(att)
    add_euler_conventions(att)
    att.add_argument(
        "--body", metavar="NAME", help="rigid body of a Motive, Vicon, Qualisys or C3D file; spacecraft frame of an AEM"
    )
    att.add_argument("--topic", metavar="NAME", help="topic of a ROS bag or a PX4 ULog")
    add_column_options(att)
    att.add_argument(
        "--rate",
        type=positive_float,
        metavar="HZ",
        help="times of a log without a time column (or whose --columns leave it out): row / HZ",
    )
    gyr = parser.add_argument_group("the gyroscope log")
    gyr.add_argument(
        "--gyro-columns",
        metavar="X,Y,Z",
        help="its rate columns, by name or 1-based position (default: the header's one group of gx,gy,gz; "
        "wx,wy,wz; gyro_x,gyro_y,gyro_z; ...; or of names ending in x, y, z that name a gyroscope)",
    )
    gyr.add_argument(
        "--gyro-time-column",
        default="t",
        metavar="NAME",
        help="its time column, by name or 1-based position (default t)",
    )
    gyr.add_argument(
        "--gyro-rate",
        type=positive_float,
        metavar="HZ",
        help="times of a gyro log without a time column (or whose stamps cannot be used): row / HZ; its time "
        "column is then not read",
    )
    gyr.add_argument(
        "--gyro-header-rows",
        type=int,
        default=1,
        metavar="N",
        help="rows its header spans (default 1; names joined per column; 0: no header, columns by position)",
    )
    gyr.add_argument(
        "--gyro-topic",
        metavar="NAME",
        help="a PX4 ULog's gyroscope topic (default sensor_combined, else vehicle_angular_velocity; sensor_gyro_N)",
    )
    gyr.add_argument(
        "--gyro-time-unit",
        choices=list(TIME_UNITS),
        default="s",
        help="unit of its times (default s, or the unit its name states: time_ms)",
    )


def run(args: argparse.Namespace) -> int:
    for p in (args.attitude, args.gyro):
        if not p.exists():
            raise FileNotFoundError(f"[Errno 2] No such file or directory: '{p}'")
    if args.gyro_unit == "raw" and args.scale == "none":
        raise ValueError("--gyro-unit raw needs scale factors: add --scale axes or --scale matrix")
    check_search(args.offset, args.max_offset)  # before either log is read
    check_outputs(args)
    columns = column_triple(args.gyro_columns)
    options = ReadOptions(
        time_unit=args.time_unit,
        time_column=args.time_column,
        rotation=args.rotation,
        scalar_first=args.scalar_first,
        body=args.body,
        topic=args.topic,
        columns=args.columns,
        header_rows=args.header_rows,
        rate=args.rate,
        duplicate_times=args.duplicate_times,
        euler=args.euler,
        angle_unit=args.angle_unit,
    )
    log = read_log(args.attitude, options=options)
    if log.kind == "directions":
        raise ValueError(
            f"{args.attitude}: calibrate needs attitudes (quaternions or rotation matrices), not directions"
        )
    gyro = read_gyro(
        args.gyro,
        columns,
        None if args.gyro_rate is not None else args.gyro_time_column,
        args.gyro_header_rows,
        args.gyro_topic,
    )
    print(f"attitude: {log.t.size} samples of {args.attitude}" + "".join(f"; {n}" for n in log.notes))
    times = f"time {gyro.names[0]!r}" if args.gyro_rate is None else f"times row / {args.gyro_rate:g} Hz"
    stated, note = None, None  # the unit its name or size states, as an attitude log's
    if gyro.own_unit:
        if args.gyro_time_unit != "s":
            raise ValueError(
                f"{args.gyro}: its times carry their own unit ({gyro.own_unit}); leave --gyro-time-unit out"
            )
        note = gyro.own_unit
    elif args.gyro_rate is None:
        stated, note = unit_stated(gyro.names[0], args.gyro_time_unit, gyro.t[:64])
    time_unit = stated or args.gyro_time_unit
    said = f"; {note}" if note else ""
    unsure = f"; {gyro.note}" if gyro.note else ""
    print(f"gyroscope: {gyro.t.size} rows of {args.gyro}, {times}, rate {', '.join(gyro.names[1:])}{said}{unsure}")
    t_g = gyro.t / args.gyro_rate if args.gyro_rate is not None else gyro.t * TIME_UNITS[time_unit]
    g = gyro.g * GYRO_UNITS[args.gyro_unit]
    t_a = log.absolute_times
    warnings = spacing_warning("attitude log's samples", t_a, "--time-unit", args.time_unit)
    if args.gyro_rate is None:
        warnings += spacing_warning("gyroscope's rows", t_g, "--gyro-time-unit", time_unit)
    for line in warnings:
        print(line)
    cal = calibrate(t_a, log.data, t_g, g, scale=args.scale, cutoff_hz=args.cutoff, offset_guess=args.offset,
                    max_offset=args.max_offset)  # fmt: skip
    unit = "counts" if args.gyro_unit == "raw" else "rad/s"
    print(f"calibrated {args.gyro} against {args.attitude}: gyro(t + offset) = A omega_body(t) + bias")
    print(table(cal, unit))
    if args.output is not None:
        write_whole(args.output, lambda f: f.write(cal.to_json().encode()))
        print(f"wrote {args.output}")
    if args.plot is not None:
        series = band_limited(cal, t_a, log.data, t_g, g)
        write_whole(args.plot, lambda f: plot(cal, series, f, unit, args.plot.suffix[1:].lower()))
        print(f"wrote {args.plot}")
    return 0


def spacing_warning(rows: str, t: np.ndarray, flag: str, unit: str) -> list[str]:
    """The warning, as a list of at most one line, for a log whose ``rows`` (times ``t`` in s) are implausibly far
    apart in ``unit`` (:func:`~omegahat.io.time_units.implausible_spacing`, as ``estimate``'s)."""
    h = float(np.median(np.diff(t))) if t.size > 1 else math.nan
    said = (
        implausible_spacing(h, float(t[0]), unit, f"with {flag} {unit}", lambda u: f"pass {flag} {u}", rows)
        if h > 0
        else None
    )
    return [] if said is None else [f"warning: the {said}"]


def check_outputs(args: argparse.Namespace) -> None:
    """Before any work: ``-o`` and ``--plot`` are writable, neither is an input nor the other, and the plot's
    extension is a format Matplotlib writes."""
    for path, what in ((args.output, "the calibration"), (args.plot, "the plot")):
        if path is not None:
            check_output_path(path, [args.attitude, args.gyro], what)
    if args.plot is not None and args.output is not None and target_of(args.plot) == target_of(args.output):
        raise ValueError(f"-o and --plot name the same file, {args.output}; give each its own")
    if args.plot is not None:
        from matplotlib.backend_bases import FigureCanvasBase

        kinds = FigureCanvasBase.get_supported_filetypes()
        if args.plot.suffix[1:].lower() not in kinds:
            raise ValueError(f"--plot {args.plot}: not an image type Matplotlib writes; use .{', .'.join(kinds)}")


def plot(cal: Calibration, series: tuple, f: BinaryIO, unit: str, kind: str) -> None:
    """The band-limited gyro against the model, and their difference, on the samples the fit used, written to
    ``f`` as ``kind`` (png, pdf, svg, ...)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t, G, model, used = series
    t = t - t[0]
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(10, 6))
    for i, color in enumerate(("tab:red", "tab:green", "tab:blue")):
        top.plot(t, np.where(used, G[:, i], np.nan), color=color, lw=0.8, label=f"gyro {'xyz'[i]} (band-limited)")
        top.plot(t, np.where(used, model[:, i], np.nan), color=color, lw=0.8, ls="--", label=f"model {'xyz'[i]}")
        bottom.plot(t, np.where(used, G[:, i] - model[:, i], np.nan), color=color, lw=0.6, label=f"{'xyz'[i]}")
    top.set_ylabel(unit)
    top.legend(ncol=3, fontsize=7)
    sign = "+" if cal.offset >= 0 else "-"
    top.set_title(f"gyro(t {sign} {abs(cal.offset):.4f} s) against A omega(t) + b, below {cal.cutoff_hz:.3g} Hz")
    bottom.set_ylabel(f"residual, {unit}")
    bottom.set_xlabel("s from the attitude log's first sample")
    bottom.legend(ncol=3, fontsize=7)
    fig.tight_layout()
    fig.savefig(f, format=kind, dpi=120)
    plt.close(fig)
