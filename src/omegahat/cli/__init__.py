"""The ``omegahat`` command: thin subcommands over the public API."""

from __future__ import annotations

import argparse
import importlib
import sys

# Subcommand name -> module in omegahat.cli.
SUBCOMMANDS = {
    "paper": "omegahat.cli.paper",
    "estimate": "omegahat.cli.estimate",
    "compare": "omegahat.cli.compare",
    "montecarlo": "omegahat.cli.montecarlo",
}


def build_parser() -> argparse.ArgumentParser:
    from omegahat import __version__

    parser = argparse.ArgumentParser(
        prog="omegahat",
        description="Angular velocity of a rigid body from attitude measurements, without gyroscopes.",
    )
    parser.add_argument("--version", action="version", version=f"omegahat {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in SUBCOMMANDS.items():
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
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args._run(args) or 0)
    except (ValueError, OSError) as exc:
        print(f"omegahat {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
