"""Numba's on-disk cache for omegahat's kernels, invalidated by any change to any compiled module.

Numba keys a cached function on the source of *its own* file only. A kernel that inlines a primitive from
another file (the engine inlines :mod:`omegahat.kernels.observer`, the estimator inlines
:mod:`omegahat.kernels.rotation`) would keep the old primitive's machine code after an edit of that other file,
and two kernels could silently disagree. This module registers a cache locator, ahead of Numba's own, for the
functions defined in omegahat: its source stamp is one hash over every module of the package that compiles
anything (those that import Numba), so an edit anywhere in the compiled code invalidates every omegahat kernel
at once, and nothing stale is ever loaded. Functions of other packages are left to Numba's own locators.

It must be imported before any omegahat module defines a cached kernel: ``omegahat/kernels/__init__.py`` imports
it first, and every compiled module imports from :mod:`omegahat.kernels`.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

from numba.core import caching

__all__ = ["PACKAGE_ROOT", "compiled_sources", "source_stamp"]

#: The omegahat package directory.
PACKAGE_ROOT = Path(__file__).resolve().parents[1]


def compiled_sources(root: Path = PACKAGE_ROOT) -> list[Path]:
    """The package's Python files that compile something (they mention ``numba``), in a stable order."""
    return sorted(p for p in root.rglob("*.py") if "numba" in p.read_text(encoding="utf-8"))


@functools.cache
def source_stamp(root: Path = PACKAGE_ROOT) -> str:
    """SHA-256 over the names and contents of :func:`compiled_sources` (computed once per process)."""
    digest = hashlib.sha256()
    for path in compiled_sources(root):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def _in_package(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE_ROOT)
    except OSError:  # pragma: no cover - an unreadable path is not ours
        return False


class _PackageStampMixin:
    """A locator for omegahat's own functions whose source stamp is :func:`source_stamp`."""

    def get_source_stamp(self):
        return source_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _in_package(py_file):
            return None
        return super().from_function(py_func, py_file)


class UserProvidedPackageLocator(_PackageStampMixin, caching.UserProvidedCacheLocator):
    """Cache in ``NUMBA_CACHE_DIR`` when the user set it."""


class InTreePackageLocator(_PackageStampMixin, caching.InTreeCacheLocator):
    """Cache next to the source (``__pycache__``) when it is writable."""


class UserWidePackageLocator(_PackageStampMixin, caching.UserWideCacheLocator):
    """Cache in the user's cache directory otherwise (a read-only installation)."""


def _register() -> None:
    locators = caching.CacheImpl._locator_classes
    # Numba's own order: the user's cache directory if set, next to the source if writable, the user-wide one
    for cls in (UserWidePackageLocator, InTreePackageLocator, UserProvidedPackageLocator):
        if cls not in locators:
            locators.insert(0, cls)


_register()
