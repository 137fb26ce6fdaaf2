"""``benchmarks/RESULTS.md``: each benchmark script replaces its own section (created with a header if absent)."""

from __future__ import annotations

import datetime
import math
import os
import platform
import tempfile
from collections.abc import Callable
from pathlib import Path

RESULTS = Path(__file__).with_name("RESULTS.md")
HEADER = (
    "# Benchmark results\n\nEach section below is written by its own script in `benchmarks/`; rerun the script to "
    "update it.\n"
)


def write_section(title: str, body: str) -> None:
    """Replace (or append) the section whose first line is ``title`` with ``title`` + ``body``."""
    text = RESULTS.read_text() if RESULTS.exists() else HEADER
    block = f"{title}\n\n{body.strip()}\n"
    if title in text:
        start = text.index(title)
        nxt = text.find("\n## ", start + 1)
        text = text[:start] + block + (text[nxt:] if nxt >= 0 else "")
    else:
        text = text.rstrip("\n") + "\n\n" + block
    RESULTS.write_text(text)


def drop_section(title: str) -> None:
    """Remove the section whose first line is ``title`` (a section a script no longer writes under that title)."""
    if not RESULTS.exists():
        return
    text = RESULTS.read_text()
    if title in text:
        start = text.index(title)
        nxt = text.find("\n## ", start + 1)
        RESULTS.write_text(text[:start].rstrip("\n") + "\n" + (text[nxt:] if nxt >= 0 else ""))


def machine_line() -> str:
    """``Machine: … Python …; date.`` — where and when a result was measured."""
    cpu = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    now = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    return (
        f"Machine: {cpu or platform.machine()}, {os.cpu_count()} cores (shared), {platform.system()}; Python "
        f"{platform.python_version()}; {now}."
    )


def gmean(xs) -> float:
    """The geometric mean of positive numbers (NaN for none)."""
    xs = list(xs)
    return math.exp(sum(math.log(x) for x in xs) / len(xs)) if xs else math.nan


def geo(xs: list[float]) -> str:
    """A table cell for ratios: ``geometric mean; lowest–highest`` (three decimals)."""
    return f"{gmean(xs):.3f}; {min(xs):.3f}–{max(xs):.3f}"


def rows_of_files(paths: list[Path], one: Callable[[Path, Path], list[str] | None]) -> list[list[str]]:
    """A table's rows, ``one(path, scratch folder)`` for each of ``paths`` (None: skipped, as ``one`` says), each
    printed as it comes."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for path in paths:
            row = one(path, Path(tmp))
            if row is not None:
                rows.append(row)
                print(" | ".join(row))
    return rows


def write_table(title: str, command: str, text: str, head: list[str], rows: list[list[str]]) -> None:
    """Write the section ``title``: the machine, the ``command`` that measured it, ``text``, and a table of ``rows``
    under ``head`` (the first column left-aligned, the others right)."""
    align = "| --- |" + " ---: |" * (len(head) - 1)
    table = "\n".join([f"| {' | '.join(head)} |", align, *(f"| {' | '.join(r)} |" for r in rows)])
    write_section(title, f"{machine_line()}\n\nCommand: `{command}` {text}\n\n{table}\n")
