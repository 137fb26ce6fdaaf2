"""omegahat's build backend: setuptools', and the wheel carries its kernels compiled (a fresh install's first run
loads them instead of compiling them for a minute).

``pyproject.toml`` names this module as the build backend (``backend-path = ["build_support"]``) and its
:class:`BuildPy` as the ``build_py`` command. Building a wheel (``pip install .``, ``pip wheel .``,
``python -m build``):

1. the build environment gets the package's own dependencies besides setuptools (read from ``[project]
   dependencies``: one list), so that the package can run there;
2. after ``build_py`` has copied the sources into the build folder, a child process runs
   :mod:`omegahat.lab.warmup` on that copy (``PYTHONPATH``; no ``NUMBA_CACHE_DIR``, no ``.pyc``): every path of
   ``omegahat estimate`` and ``omegahat paper`` once, so that Numba writes its cache files (``*.nbi``, ``*.nbc``) into
   the copy's ``__pycache__`` folders, which go into the wheel and are installed beside the sources.

The cache files hold machine code for this machine's processor, this Python, Numba and NumPy: installed elsewhere
or beside other versions they are misses, and the kernels are compiled on first use as without them (correct,
slower) — :mod:`omegahat.kernels.cache` checks each. A warm-up that fails does not fail the build: it says why, and
the package compiles its kernels on first use.

``OMEGAHAT_SKIP_WARMUP=1`` skips both (packagers building for other machines; a quick local build). An editable
install (``pip install -e .``) has none: the kernels are compiled on first use into ``src/omegahat``'s
``__pycache__`` folders.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable
from pathlib import Path

from setuptools import build_meta
from setuptools.build_meta import (
    build_editable,
    build_sdist,
    build_wheel,
    get_requires_for_build_editable,
    get_requires_for_build_sdist,
    prepare_metadata_for_build_editable,
    prepare_metadata_for_build_wheel,
)
from setuptools.command.build_py import build_py

__all__ = [
    "SKIP",
    "BuildPy",
    "build_editable",
    "build_sdist",
    "build_wheel",
    "get_requires_for_build_editable",
    "get_requires_for_build_sdist",
    "get_requires_for_build_wheel",
    "prepare_metadata_for_build_editable",
    "prepare_metadata_for_build_wheel",
    "warm_up",
]

SKIP = "OMEGAHAT_SKIP_WARMUP"  #: set (not "" or "0") to build without compiling the kernels
PACKAGE = "omegahat"
#: the child's code: the copy being built must be the one imported (the warm-up fills that copy's caches)
CHILD = (
    "import sys, omegahat, pathlib\n"
    "where = pathlib.Path(omegahat.__file__).resolve()\n"
    "if not where.is_relative_to(pathlib.Path(sys.argv[1]).resolve()):\n"
    "    sys.exit(f'imported {where}, not the copy being built')\n"
    "from omegahat.lab.warmup import main\n"
    "sys.exit(main([]))\n"
)


def skipped() -> bool:
    """Whether :data:`SKIP` asks for a build without the warm-up."""
    return os.environ.get(SKIP, "") not in ("", "0")


def runtime_dependencies(pyproject: Path = Path("pyproject.toml")) -> list[str]:
    """``[project] dependencies`` of ``pyproject`` (the backend runs in the project's folder)."""
    with open(pyproject, "rb") as f:
        return list(tomllib.load(f)["project"]["dependencies"])


def get_requires_for_build_wheel(config_settings: dict | None = None) -> list[str]:
    """setuptools' requirements, and the package's dependencies for the warm-up (none when it is skipped)."""
    requires = build_meta.get_requires_for_build_wheel(config_settings)
    return requires if skipped() else requires + runtime_dependencies()


def warm_up(build_lib: Path, say: Callable[[str], None] = print) -> bool:
    """Run the warm-up on the package copied in ``build_lib`` (its stale cache files removed first); True when every
    step ran. ``say`` gets the child's report, or why it failed."""
    build_lib = build_lib.resolve()
    package = build_lib / PACKAGE
    for stale in [*package.rglob("*.nbi"), *package.rglob("*.nbc")]:  # an earlier build's, in a reused build folder
        stale.unlink()
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = os.pathsep.join([str(build_lib), *filter(None, [os.environ.get("PYTHONPATH")])])
    env["PYTHONDONTWRITEBYTECODE"] = "1"  # no .pyc of the build's interpreter in the wheel: the installer writes them
    start = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="omegahat-build-") as folder:
        p = subprocess.run(
            [sys.executable, "-c", CHILD, str(build_lib)], cwd=folder, env=env, capture_output=True, text=True
        )
    report = (p.stdout + p.stderr).strip()
    if p.returncode != 0:
        say(
            f"omegahat: WARNING: compiling the kernels for the wheel failed (exit {p.returncode}); the package works "
            f"and compiles them on first use instead.\n{report}"
        )
        return False
    shipped = len(list(package.rglob("*.nbc")))
    say(f"{report}\nomegahat: {shipped} compiled kernels in the wheel ({time.perf_counter() - start:.0f} s)")
    return True


class BuildPy(build_py):
    """``build_py``, then :func:`warm_up` on the built copy (not for an editable install, nor when :func:`skipped`)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False) or self.dry_run or skipped():
            return
        warm_up(Path(self.build_lib), say=lambda text: print(text, file=sys.stderr, flush=True))
