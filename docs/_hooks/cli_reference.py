"""MkDocs hooks for omegahat's site.

* The command-line reference, generated from omegahat's argument parser at build time: a page containing the
  marker ``<!-- omegahat-cli-reference -->`` gets, in its place, the ``--help`` text of ``omegahat`` and of every
  subcommand, produced by :func:`omegahat.cli.build_parser` itself, so the reference cannot drift from the options
  the program accepts.
* The top-level API, generated from ``omegahat._PUBLIC`` (the table the package's lazy ``__getattr__`` reads, which
  static documentation tools cannot see): the marker ``<!-- omegahat-public-api -->`` becomes a table of every
  public name with a cross-reference to where its package's page documents it; ``mkdocs build --strict`` fails if
  one of them is not rendered there.
* The docstrings' Sphinx roles (``:func:`name```, ``:mod:`name```), which mkdocstrings renders as the role's
  name followed by the code, are shown as the code alone.
"""

from __future__ import annotations

import argparse
import os
import re

MARKER = "<!-- omegahat-cli-reference -->"
API_MARKER = "<!-- omegahat-public-api -->"
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


def public_api() -> str:
    """Markdown: one row per name of ``omegahat._PUBLIC``, linked to its documentation in the package pages."""
    import omegahat

    rows = ["| name | defined in |", "| --- | --- |"]
    for name, module in sorted(omegahat._PUBLIC.items(), key=lambda kv: (kv[1], kv[0])):
        rows.append(f"| [`omegahat.{name}`][{module}.{name}] | `{module}` |")
    return "\n".join(rows)


def on_page_markdown(markdown: str, page, config, files) -> str:
    if MARKER in markdown:
        markdown = markdown.replace(MARKER, cli_reference())
    if API_MARKER in markdown:
        markdown = markdown.replace(API_MARKER, public_api())
    return markdown


def on_page_content(html: str, page, config, files) -> str:
    return _ROLE.sub("", html)
