"""MkDocs hook: the command-line reference, generated from omegahat's argument parser at build time.

A page containing the marker ``<!-- omegahat-cli-reference -->`` gets, in its place, the ``--help`` text of
``omegahat`` and of every subcommand, produced by :func:`omegahat.cli.build_parser` itself, so the reference
cannot drift from the options the program accepts.
"""

from __future__ import annotations

import argparse
import os

MARKER = "<!-- omegahat-cli-reference -->"


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # argparse keeps its subcommands in a _SubParsersAction
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def cli_reference() -> str:
    """Markdown: one section per command, each with its ``--help`` as argparse prints it."""
    from omegahat.cli import build_parser

    os.environ["COLUMNS"] = "110"  # argparse wraps at the terminal width: fix it so the page is reproducible
    parser = build_parser()
    parts = ["## omegahat", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in _subcommands(parser).items():
        parts += [f"## omegahat {name}", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, cli_reference())
    return markdown
