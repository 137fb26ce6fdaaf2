"""The ``omegahat`` command: thin subcommands over the public API.

Every subcommand ends in one of three ways, never with a traceback for what a user gave it:

* done: exit 0;
* refused (a bad option, an input it cannot read, an output it cannot write, a request beyond a stated limit):
  one line ``omegahat COMMAND: error: ...`` on standard error, exit 2; options are checked before any work;
* interrupted by SIGINT (Ctrl-C) or SIGTERM: one line ``omegahat COMMAND: interrupted by SIGINT ...``, exit
  ``128 + the signal's number`` (130 for SIGINT, 143 for SIGTERM, as a shell reports a process the signal
  stopped). Outputs are whole or absent (:mod:`omegahat.io.output`): the temporary files are removed.
"""

from __future__ import annotations

import argparse
import importlib
import math
import os
import signal
import sys
import threading
from collections.abc import Callable, Collection
from typing import Any

# Subcommand name -> module in omegahat.cli.
SUBCOMMANDS = {
    "paper": "omegahat.lab.cli.paper",
    "estimate": "omegahat.cli.estimate",
    "calibrate": "omegahat.cli.calibrate",
    "compare": "omegahat.lab.cli.compare",
    "montecarlo": "omegahat.lab.cli.montecarlo",
    "control": "omegahat.lab.cli.control",
}
#: each subcommand's one line, in the overview (``omegahat --help``, which imports no subcommand: their modules
#: load the plotting, simulation and reading stacks, 3 s) and atop its own ``--help``
SUMMARIES = {
    "paper": "Simulate the paper's scenario and write its four figures, trajectory.csv and a summary.",
    "estimate": "Estimate the angular velocity (rad/s, body axes) from attitude data (logs, exports, ROS bags).",
    "calibrate": (
        "Calibrate a gyroscope against an attitude log of the same body: clock offset, frame rotation, bias, scale."
    ),
    "compare": (
        "Compare omegahat with differencing, a spline, an EKF and published gyro-free filters on standard scenarios."
    ),
    "montecarlo": (
        "Run a Monte-Carlo campaign (TOML config, see examples/campaign.toml) and write summary.json, "
        "counterexamples.json, envelopes.png and rates.png."
    ),
    "control": (
        "Simulate velocity-free attitude control (detumble from 2 rad/s, 180 deg slew, a Monte-Carlo of the basin) "
        "with the true rate, omegahat's estimate and differenced attitudes; write figures, CSV files and summary.md."
    ),
}
#: the signals that interrupt a command (one message, exit 128 + their number)
INTERRUPTS = (signal.SIGINT, signal.SIGTERM)
EPILOG = """\
exit status: 0 done; 2 refused: an option, an input or an output it cannot take (one line on standard error,
  before any work where the options are wrong or beyond a stated limit); 130 interrupted by SIGINT (Ctrl-C),
  143 by SIGTERM.
outputs are whole or absent: written under a temporary name beside them (.NAME.TOKEN.part) and renamed when
  complete, so a failed or interrupted run leaves the previous output as it was; the temporary file of a killed
  run (SIGKILL, power loss) is removed by the next run writing the same output. An output that is a symbolic
  link is written through to the file it points to.
"""


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def add_column_options(group: Any) -> None:
    """``--columns``, ``--header-rows`` and ``--duplicate-times`` on ``group``: how a text log whose names are not
    omegahat's is read, and what samples at one time become (``omegahat estimate`` and ``calibrate``)."""
    from omegahat.io.timestamps import DUPLICATE_CHOICES  # here: `omegahat --version` loads no reader

    group.add_argument(
        "--columns",
        metavar="KEY=COL,...",
        help="which column holds what, for files whose names are not omegahat's: t=NAME,qw=NAME,qx=NAME,qy=NAME,"
        "qz=NAME (or r11..r33, b1x.., tau_x..) by header name or 1-based position (t=1,qw=2,...); see "
        "docs/your-data.md",
    )
    group.add_argument(
        "--header-rows",
        type=int,
        metavar="N",
        help="rows the header spans (names joined per column, e.g. a group title over W,X,Y,Z); 0: no header, "
        "columns by position",
    )
    group.add_argument(
        "--duplicate-times",
        choices=DUPLICATE_CHOICES,
        default="error",
        help="samples at one time whose attitudes differ: error (default: a broken time source; the message names "
        "both lines), or keep the first or the last of them (the others dropped, counted and reported)",
    )


def add_quaternion_order(group: Any, where: str = "") -> None:
    """``--scalar-first`` / ``--scalar-last`` (one of them, into ``scalar_first``: True, False or None when neither
    is given) on ``group`` (a parser or an argument group); ``where`` says, in the first one's help, which inputs
    need one."""
    order = group.add_mutually_exclusive_group()
    order.add_argument(
        "--scalar-first",
        dest="scalar_first",
        action="store_const",
        const=True,
        default=None,
        help="unnamed quaternions are w,x,y,z (SciPy's scalar_first=True)" + (f": {where}" if where else ""),
    )
    order.add_argument(
        "--scalar-last",
        dest="scalar_first",
        action="store_const",
        const=False,
        help="unnamed quaternions are x,y,z,w (SciPy's default)",
    )


def add_euler_conventions(group: Any) -> None:
    """``--euler SEQ`` and ``--angle-unit {deg,rad}`` (into ``euler`` and ``angle_unit``, None when not given) on
    ``group``: the conventions of ``roll, pitch, yaw`` columns (:mod:`omegahat.io.euler`), which no log shows."""
    from omegahat.io.euler import ANGLE_UNITS  # the commands that read logs load omegahat.io anyway

    group.add_argument(
        "--euler",
        metavar="SEQ",
        help="roll,pitch,yaw columns (angles about x, y, z): their sequence as SciPy writes it, upper case about the "
        "rotating axes, lower case about the fixed ones (ZYX = xyz: R = Rz(yaw) Ry(pitch) Rx(roll), the aerospace "
        "convention); required for such logs",
    )
    group.add_argument(
        "--angle-unit", choices=ANGLE_UNITS, help="unit of the roll,pitch,yaw columns; required for such logs"
    )


def _integer(text: str) -> int:
    """An integer written as one (``20``) or as an integral number (``1e6``)."""
    try:
        return int(text)
    except ValueError:
        pass
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not (math.isfinite(value) and value.is_integer()):
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}")
    return int(value)


def positive_int(text: str) -> int:
    """An argparse type: an integer ≥ 1."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def natural_int(text: str) -> int:
    """An argparse type: an integer ≥ 0 (a seed, a count that may be zero)."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0, got {text!r}")
    return value


def bounded_int(low: int, high: int, why: str) -> Callable[[str], int]:
    """An argparse type: an integer from ``low`` to ``high``; ``why`` says, in the message, what the upper limit
    protects (``"the results are held in memory"``)."""

    def parse(text: str) -> int:
        value = positive_int(text) if low == 1 else natural_int(text) if low == 0 else _integer(text)
        if value < low:
            raise argparse.ArgumentTypeError(f"expected an integer >= {low}, got {text!r}")
        if value > high:
            raise argparse.ArgumentTypeError(f"{text} is more than omegahat takes here: at most {high:,} ({why})")
        return value

    return parse


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The parser; ``commands`` limits the subcommand modules imported (``omegahat estimate`` need not load the
    plotting and simulation stacks of the others: half a second and 40 MB): the others are listed by name and
    :data:`SUMMARIES` line only, as the overview needs them. None: every subcommand with its options."""
    from omegahat import __version__

    parser = argparse.ArgumentParser(
        prog="omegahat",
        description="Angular velocity of a rigid body from attitude measurements, without gyroscopes.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"omegahat {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=SUMMARIES[name], description=SUMMARIES[name])
        if commands is not None and name not in commands:
            continue
        module = importlib.import_module(module_name)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


_received: list[KeyboardInterrupt] = []  #: the interrupts received while :func:`main` runs


def _interrupt(signum: int, frame: object) -> None:
    stop = KeyboardInterrupt(signal.Signals(signum).name)
    # kept as well as raised: raised inside a finalizer (a generator closed by the garbage collector, a __del__)
    # Python prints "Exception ignored" and goes on, and the command would finish as if never signalled
    _received.append(stop)
    raise stop


def pending_interrupt() -> KeyboardInterrupt | None:
    """The last SIGINT or SIGTERM received while :func:`main` runs (as its ``KeyboardInterrupt``), whether or not
    its raise reached the command: a loop over files checks it between files."""
    return _received[-1] if _received else None


def interrupted_by(exc: BaseException) -> KeyboardInterrupt | None:
    """The interrupt behind ``exc``: itself, or (an interrupt raised while a compiled function ran comes out as a
    ``SystemError`` of Numba's dispatcher) the one it was raised from."""
    seen: set[int] = set()
    e: BaseException | None = exc
    while e is not None and id(e) not in seen:
        if isinstance(e, KeyboardInterrupt):
            return e
        seen.add(id(e))
        e = e.__cause__ or e.__context__
    return None


def main(argv: list[str] | None = None) -> int:
    """Run ``omegahat COMMAND ...`` (module docstring); returns the exit status."""
    previous = {}
    if threading.current_thread() is threading.main_thread():  # signal handlers live in the main thread only
        previous = {s: signal.signal(s, _interrupt) for s in INTERRUPTS}
    words = sys.argv[1:] if argv is None else argv
    first = next((w for w in words if not w.startswith("-")), None)
    command = first if first in SUBCOMMANDS else "COMMAND"
    # the subcommand's module a word asks for: the one named, none for the version or the overview
    wanted = [first] if first in SUBCOMMANDS else []
    try:
        parser = build_parser(wanted)
        args = parser.parse_args(argv)
        command = args.command
        try:
            return int(args._run(args) or 0)
        except (ValueError, OSError) as exc:
            print(f"omegahat {command}: error: {exc}", file=sys.stderr)
            return 2
        except MemoryError as exc:
            print(f"omegahat {command}: error: out of memory ({exc or 'no details'})", file=sys.stderr)
            return 2
    except (KeyboardInterrupt, SystemError) as exc:
        stop = interrupted_by(exc)
        if stop is None:
            raise
        name = str(stop) if str(stop) in signal.Signals.__members__ else "SIGINT"
        print(f"omegahat {command}: interrupted by {name} (outputs are whole or absent)", file=sys.stderr)
        return 128 + int(signal.Signals[name])
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler)
        _received.clear()  # what this command received is not the next one's (a caller may run several in-process)


def entry() -> None:
    """The ``omegahat`` console script: :func:`main`, then the process's exit with its status. After an interrupt
    (130, 143) the process ends at once once stdout and stderr are flushed (``os._exit``): the outputs are whole or
    absent by then, and the interpreter's teardown would only meet work the signal stopped (PyArrow's thread pool
    aborted there now and then: "terminate called without an active exception", exit -6 instead of 143)."""
    code = main()
    if code in {128 + int(s) for s in INTERRUPTS}:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    entry()
