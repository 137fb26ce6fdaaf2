"""The ``omegahat`` command: thin subcommands over the public API."""

from __future__ import annotations

import argparse
import importlib
import math
import sys
from collections.abc import Collection

# Subcommand name -> module in omegahat.cli.
SUBCOMMANDS = {
    "paper": "omegahat.lab.cli.paper",
    "estimate": "omegahat.cli.estimate",
    "calibrate": "omegahat.cli.calibrate",
    "compare": "omegahat.lab.cli.compare",
    "montecarlo": "omegahat.lab.cli.montecarlo",
    "control": "omegahat.lab.cli.control",
}


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"expected a positive number, got {text!r}")
    return value


def positive_int(text: str) -> int:
    """An argparse type: an integer ≥ 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def build_parser(commands: Collection[str] | None = None) -> argparse.ArgumentParser:
    """The parser; ``commands`` limits the subcommand modules imported (``omegahat estimate`` need not load the
    plotting and simulation stacks of the others: half a second and 40 MB)."""
    from omegahat import __version__

    parser = argparse.ArgumentParser(
        prog="omegahat",
        description="Angular velocity of a rigid body from attitude measurements, without gyroscopes.",
    )
    parser.add_argument("--version", action="version", version=f"omegahat {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in SUBCOMMANDS.items():
        if commands is not None and name not in commands:
            continue
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:  # a subcommand still under construction
            if exc.name != module_name:
                raise
            continue
        p = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else argv
    first = next((w for w in words if not w.startswith("-")), None)
    parser = build_parser([first] if first in SUBCOMMANDS else None)
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, OSError) as exc:
        print(f"omegahat {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
