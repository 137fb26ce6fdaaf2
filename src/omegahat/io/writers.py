"""Output formats, recognised from the output's name: the writers' registry, beside the readers'
(:mod:`omegahat.io.registry`).

A :class:`WriterFormat` is a name, what it is (``noun``: "bag") and how to name it (``title``: ".bag (ROS 1)"), the
name endings it claims (``".csv"``; ``""`` for a name without extension), the input formats it needs (a bag output
needs a bag input: its stamps and frames) or none, the writer settings it takes (``frame_id``, ``topic``:
``--frame-id``, ``--output-topic``), whether it may replace an existing output, and an
``opener(path, stream, **settings)`` that returns the writer (an :class:`omegahat.io.output.AtomicOutput`:
a context manager with ``write(chunk, omega, status)``, whole or absent). :mod:`omegahat.io` registers ``csv``
(:class:`omegahat.io.output.OmegaWriter`), ``parquet`` (:class:`omegahat.io.parquet_output.ParquetOmegaWriter`),
``aem`` (:class:`omegahat.io.aem_output.AemWriter`, for an AEM input), ``rosbag1`` and ``rosbag2``
(:class:`omegahat.io.rosbag.TwistBagWriter`); another output plugs in the same way with :func:`register_writer`.

:func:`output_kind` says which format a name asks for (anything else is refused rather than guessed),
:func:`check_output` checks an output before any work, :func:`open_output` makes the writer.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegahat.io.output import AtomicOutput, check_output_path, target_of
from omegahat.io.registry import LogStream, detect_format

__all__ = [
    "WRITER_FLAGS",
    "WriterFormat",
    "check_output",
    "get_writer",
    "open_output",
    "output_kind",
    "register_writer",
    "unregister_writer",
]

#: writer setting -> its name on the command line
WRITER_FLAGS = {"frame_id": "--frame-id", "topic": "--output-topic"}


@dataclass(frozen=True)
class WriterFormat:
    """A writable format (module docstring): ``title`` says how to name it (".bag (ROS 1)"), ``noun`` what it is
    ("bag"), ``why_inputs`` why it needs the ``inputs`` it needs ("its stamps and frames")."""

    name: str
    title: str
    noun: str
    endings: tuple[str, ...]
    opener: Callable[..., AtomicOutput]
    inputs: tuple[str, ...] | None = None
    settings: tuple[str, ...] = ()
    overwrite: bool = True
    why_inputs: str = ""


_WRITERS: list[WriterFormat] = []


def register_writer(
    endings: str | Iterable[str],
    opener: Callable[..., AtomicOutput],
    *,
    name: str,
    title: str,
    noun: str,
    inputs: Iterable[str] | None = None,
    settings: Iterable[str] = (),
    overwrite: bool = True,
    why_inputs: str = "",
) -> WriterFormat:
    """Register ``opener(path, stream, **settings) -> writer`` for output names ending in ``endings``
    (case-insensitive; ``""``: no extension); ``inputs``: the input format names it needs (None: any). A writer
    of the same name is replaced."""
    ends = tuple(e.lower() for e in ([endings] if isinstance(endings, str) else endings))
    needs = None if inputs is None else tuple(inputs)
    fmt = WriterFormat(name, title, noun, ends, opener, needs, tuple(settings), overwrite, why_inputs)
    _WRITERS[:] = [w for w in _WRITERS if w.name != name]
    _WRITERS.append(fmt)
    return fmt


def unregister_writer(name: str) -> None:
    """Remove the writer registered under ``name``."""
    get_writer(name)
    _WRITERS[:] = [w for w in _WRITERS if w.name != name]


def get_writer(name: str) -> WriterFormat:
    """The writer registered under ``name``."""
    for w in _WRITERS:
        if w.name == name:
            return w
    raise ValueError(f"no output format named {name!r}; known: {', '.join(w.name for w in _WRITERS)}")


def _listing(writers: list[WriterFormat]) -> str:
    titles = [w.title for w in writers]
    return titles[0] if len(titles) == 1 else ", ".join(titles[:-1]) + " or " + titles[-1]


def output_kind(output: str | os.PathLike[str], input_format: str = "") -> str:
    """The name of the writer an output's name asks for, given the input's format name (module docstring);
    raises ValueError for a name no writer takes for that input."""
    out = Path(output)
    suffix = out.suffix.lower()
    claiming = [w for w in _WRITERS if suffix in w.endings]
    usable = [w for w in claiming if w.inputs is None or input_format in w.inputs]
    if usable:
        return usable[0].name
    if claiming and suffix:
        w = claiming[0]
        why = f" ({w.why_inputs})" if w.why_inputs else ""
        plain = [x for x in _WRITERS if x.inputs is None]
        raise ValueError(f"{out}: a {w.noun} output needs a {w.noun} input{why}; write {_listing(plain)} instead")
    takes = [w for w in _WRITERS if w.inputs is None or input_format in w.inputs]
    raise ValueError(f"{out}: unknown output type {suffix or '(no extension)'!r}; use {_listing(takes)}")


def check_output(
    output: str | os.PathLike[str],
    input_path: str | os.PathLike[str],
    *,
    frame_id: str | None = None,
    topic: str | None = None,
    also_read: Sequence[str | os.PathLike[str]] = (),
) -> tuple[Path, str]:
    """``(path, kind)`` of an output for the input at ``input_path``, checked before any work: its kind from its
    name and the input's format (:func:`output_kind`), the path (:func:`omegahat.io.output.check_output_path`),
    that an output its format may not replace does not exist, and that writer settings (``frame_id``,
    ``topic``) come with an output that takes them; ``also_read``: the other files the run reads (a torque log),
    which the output may not be either."""
    kind = output_kind(output, detect_format(input_path).name)
    w = get_writer(kind)
    given = [k for k, v in (("frame_id", frame_id), ("topic", topic)) if v is not None and k not in w.settings]
    if given:
        takers = [x for x in _WRITERS if all(k in x.settings for k in given)]
        flags = [WRITER_FLAGS[k] for k in WRITER_FLAGS if any(k in x.settings for x in takers)] or given
        raise ValueError(
            f"{' and '.join(flags)} appl{'y' if len(flags) > 1 else 'ies'} to "
            f"{' and '.join(sorted({x.noun for x in takers})) or 'other'} outputs only"
        )
    if not w.overwrite and (target_of(output).exists() or Path(output).exists()):
        raise FileExistsError(f"{output} exists; omegahat does not overwrite a {w.noun} (choose another output)")
    return check_output_path(output, [input_path, *also_read]), kind


def open_output(output: str | os.PathLike[str], kind: str, stream: LogStream, **settings: Any) -> AtomicOutput:
    """The writer of the output format ``kind`` (:func:`output_kind`) for ``stream``'s estimates; ``settings``
    (``frame_id``, ``topic``; None: the writer's default) go to formats that take them. Whole or absent."""
    w = get_writer(kind)
    return w.opener(output, stream, **{k: v for k, v in settings.items() if k in w.settings})
