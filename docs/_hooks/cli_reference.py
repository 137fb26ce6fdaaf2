"""MkDocs hooks for omegahat's site.

* The command-line reference, generated from omegahat's argument parser at build time: a page containing the
  marker ``<!-- omegahat-cli-reference -->`` gets, in its place, the ``--help`` text of ``omegahat`` and of every
  subcommand, produced by :func:`omegahat.cli.build_parser` itself, so the reference cannot drift from the options
  the program accepts.
* The docstrings' Sphinx roles (``:func:`name```, ``:mod:`name```), which mkdocstrings renders as the role's
  name followed by the code, are shown as the code alone.
"""

from __future__ import annotations

import argparse
import os
import re

MARKER = "<!-- omegahat-cli-reference -->"
_ROLE = re.compile(r":(?:mod|func|class|meth|data|attr|exc|obj|const):(?=<code)")


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # argparse keeps its subcommands in a _SubParsersAction
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def cli_reference() -> str:
    """Markdown: one section per command, each with its ``--help`` as argparse prints it."""
    from omegahat.cli import build_parser

    os.environ["COLUMNS"] = "88"  # argparse wraps at the terminal width: fix it so the page is reproducible
    parser = build_parser()
    parts = ["## omegahat", "", "```text", parser.format_help().rstrip(), "```", ""]
    for name, sub in _subcommands(parser).items():
        parts += [f"## omegahat {name}", "", "```text", sub.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        return markdown.replace(MARKER, cli_reference())
    return markdown


def on_page_content(html: str, page, config, files) -> str:
    return _ROLE.sub("", html)
