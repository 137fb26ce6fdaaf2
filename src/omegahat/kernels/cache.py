"""Numba's on-disk cache for omegahat's kernels: invalidated by any change to compiled code, private, never fatal.

**One stamp for all kernels.** Numba keys a cached function on the source of *its own* file only. A kernel that
inlines a primitive from another file (the engine inlines :mod:`omegahat.kernels.observer`, the estimator inlines
:mod:`omegahat.kernels.rotation`) would keep the old primitive's machine code after an edit of that other file, and
two kernels could silently disagree. This module registers cache locators, ahead of Numba's own, for the functions
defined in omegahat: their source stamp is one hash over every module of the package that compiles anything (those
that import Numba) and NumPy's version (Numba types some functions by it), so an edit anywhere in the compiled code
invalidates every omegahat kernel at once, and nothing stale is ever loaded. Functions of other packages are left to
Numba's own locators.

**Where.** As Numba: ``NUMBA_CACHE_DIR`` when set (that folder only), else the package's ``__pycache__`` folders
when writable, else the user's cache folder (``~/.cache/numba``). When none is writable (a read-only installation:
a container's image, a system package) the kernels are **compiled in memory** for the process (each run compiles
again) and a :class:`KernelCacheWarning` says so once.

**Shipped with the package.** ``pip install .`` compiles the kernels when it builds the wheel
(:mod:`omegahat.lab.warmup`, run by ``build_support/omegahat_build.py``) and installs Numba's cache files in the
package's ``__pycache__`` folders: a fresh installation's first run loads them. Where those folders cannot be
written (a system-wide or read-only installation), their kernels are still **read** (:func:`shipped_folder`, the
same trust rules): beside the user's cache folder, which holds what they lack, or alone, read-only, when nothing is
writable (a kernel not among them is then compiled in memory, with one warning). With ``NUMBA_CACHE_DIR`` set they
are not read. A file from another Numba (or NumPy, or machine) is a miss, as any stale file: compiled again.

**Trust.** Numba's cache files are pickles, and unpickling runs code: a cache that another user can write is a
way to run that user's code in every process that loads it. A folder or file is used only if it belongs to this
user (or root) and no one else can write it (group write only for the user's own private group), nor any folder
above it (unless sticky, as ``/tmp``); otherwise omegahat compiles in memory and warns once. Never share a cache
folder, nor point ``NUMBA_CACHE_DIR`` at a folder others can write.

**Damage.** A cache file that cannot be read back (truncated, garbage, from a crashed write) is a miss: the kernel
is compiled again and the file rewritten, never an ``UnpicklingError``.

It must be imported before any omegahat module defines a cached kernel: ``omegahat/kernels/__init__.py`` imports
it first, and every compiled module imports from :mod:`omegahat.kernels`.
"""

from __future__ import annotations

import functools
import grp
import hashlib
import os
import pwd
import stat
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from numba.core import caching, config

__all__ = [
    "IN_MEMORY",
    "PACKAGE_ROOT",
    "KernelCacheWarning",
    "compiled_sources",
    "shipped_folder",
    "source_stamp",
    "trusted",
    "trusted_folder",
]

#: The omegahat package directory.
PACKAGE_ROOT = Path(__file__).resolve().parents[1]
IN_MEMORY = "<omegahat kernels: compiled in memory, not cached>"  #: the cache path of kernels not cached on disk


class KernelCacheWarning(UserWarning):
    """The compiled kernels cannot be cached on disk (no writable private folder, or one others can write): they are
    compiled in memory, for this process only."""


def compiled_sources(root: Path = PACKAGE_ROOT) -> list[Path]:
    """The package's Python files that compile something (they mention ``numba``), in a stable order."""
    return sorted(p for p in root.rglob("*.py") if "numba" in p.read_text(encoding="utf-8"))


@functools.cache
def source_stamp(root: Path = PACKAGE_ROOT) -> str:
    """SHA-256 over NumPy's version and the names and contents of :func:`compiled_sources` (computed once per
    process)."""
    digest = hashlib.sha256(f"numpy {np.__version__}".encode())
    for path in compiled_sources(root):
        digest.update(str(path.relative_to(root)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


@functools.cache
def _own_private_group() -> int | None:
    """The user's primary group if it is private (named after the user, no other member), else None."""
    try:
        user = pwd.getpwuid(os.getuid()).pw_name
        group = grp.getgrgid(os.getgid())
    except (KeyError, OSError):
        return None
    return group.gr_gid if group.gr_name == user and set(group.gr_mem) <= {user} else None


def trusted(st: os.stat_result) -> bool:
    """Whether a cache folder or file with status ``st`` can be loaded: owned by this user or root, and writable
    by no one else (group write only when the group is the user's own private group)."""
    if st.st_uid not in (os.getuid(), 0):
        return False
    if st.st_mode & stat.S_IWOTH:
        return False
    return not (st.st_mode & stat.S_IWGRP) or st.st_gid == _own_private_group()


@functools.cache
def trusted_folder(path: str) -> bool:
    """Whether the folder ``path`` and every folder above it are :func:`trusted` (or sticky, as ``/tmp``: others
    may write there but not rename or replace what is ours), so that no one else can change what it holds."""
    folder = Path(path).resolve()
    for p in (folder, *folder.parents):
        st = os.stat(p)
        if not trusted(st) and not (p != folder and st.st_mode & stat.S_ISVTX):
            return False
    return True


_warned: set[str] = set()


def _warn_once(kind: str, message: str) -> None:
    if kind not in _warned:
        _warned.add(kind)
        warnings.warn(message, KernelCacheWarning, stacklevel=2)


def _in_package(py_file: str) -> bool:
    try:
        return Path(py_file).resolve().is_relative_to(PACKAGE_ROOT)
    except OSError:  # pragma: no cover - an unreadable path is not ours
        return False


@functools.cache
def shipped_folder(folder: str) -> bool:
    """Whether the package's cache folder ``folder`` (a ``__pycache__`` beside the sources) holds kernels (``*.nbi``:
    compiled when the wheel was built, or by an earlier run) that may be read: a folder no one else can write
    (:func:`trusted_folder`; each file is checked again when read). Only when ``NUMBA_CACHE_DIR`` is unset."""
    if getattr(config, "CACHE_DIR", "") or not os.path.isdir(folder) or not any(Path(folder).glob("*.nbi")):
        return False
    if not trusted_folder(folder):
        _warn_once(
            "untrusted-shipped",
            f"omegahat: the kernel cache folder {folder} can be written by another user; it is not read (loading it "
            "could run their code): the kernels are compiled again",
        )
        return False
    return True


#: cache folders whose files are read, never written: the in-memory "folder" and shipped folders read alone
_READ_ONLY: set[str] = {IN_MEMORY}
#: a writable cache folder -> the package's shipped folder for the same sources, read for what the first lacks
_SHIPPED_BESIDE: dict[str, str] = {}


def _beside(py_file: str) -> str:
    return os.path.join(os.path.dirname(py_file), "__pycache__")


class InMemoryLocator(caching._CacheLocator):
    """The last resort for omegahat's functions: no folder; :class:`_GuardedCacheFile` neither loads nor saves."""

    def __init__(self, py_func: Callable[..., Any], py_file: str) -> None:
        self._lineno = py_func.__code__.co_firstlineno

    def ensure_cache_path(self) -> None:
        """Nothing to make: no folder."""

    def get_cache_path(self) -> str:
        return IN_MEMORY

    def get_source_stamp(self) -> str:
        return source_stamp()

    def get_disambiguator(self) -> str:
        return str(self._lineno)

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> InMemoryLocator | None:
        if not _in_package(py_file):
            return None
        _warn_once(
            "unwritable",
            "omegahat: no writable cache folder for the compiled kernels (NUMBA_CACHE_DIR, the package's "
            "__pycache__, the user's cache folder): they are compiled in memory, again in every process",
        )
        return cls(py_func, py_file)


class _PackageStampMixin:
    """A locator for omegahat's own functions whose source stamp is :func:`source_stamp`, in a trusted folder."""

    def get_source_stamp(self):
        return source_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        if not _in_package(py_file):
            return None
        locator = super().from_function(py_func, py_file)  # None when the folder cannot be made or written
        if locator is not None and not trusted_folder(locator.get_cache_path()):
            _warn_once(
                "untrusted",
                f"omegahat: the kernel cache folder {locator.get_cache_path()} can be written by another user; it "
                "is not used (loading it could run their code): the kernels are compiled in memory",
            )
            return InMemoryLocator(py_func, py_file)
        return locator


class UserProvidedPackageLocator(_PackageStampMixin, caching.UserProvidedCacheLocator):
    """Cache in ``NUMBA_CACHE_DIR`` when the user set it."""


class InTreePackageLocator(_PackageStampMixin, caching.InTreeCacheLocator):
    """Cache next to the source (``__pycache__``) when it is writable (the kernels shipped there are loaded too)."""


class UserWidePackageLocator(_PackageStampMixin, caching.UserWideCacheLocator):
    """Cache in the user's cache directory otherwise (a read-only installation), the package's shipped kernels read
    beside it."""

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> caching._CacheLocator | None:
        locator = super().from_function(py_func, py_file)
        if isinstance(locator, cls) and shipped_folder(_beside(py_file)):
            _SHIPPED_BESIDE[locator.get_cache_path()] = _beside(py_file)
        return locator


class ShippedPackageLocator(_PackageStampMixin, caching.InTreeCacheLocator):
    """No writable folder, but kernels shipped beside the source: read them, write nothing (a kernel not there is
    compiled in memory)."""

    def ensure_cache_path(self) -> None:
        """Nothing to make: the folder is read only."""

    @classmethod
    def from_function(cls, py_func: Callable[..., Any], py_file: str) -> ShippedPackageLocator | None:
        if not _in_package(py_file) or not shipped_folder(_beside(py_file)):
            return None
        _READ_ONLY.add(_beside(py_file))
        return cls(py_func, py_file)


class _GuardedCacheFile(caching.IndexDataCacheFile):
    """Numba's index and data files, read with care for omegahat's folders (other packages' are untouched): nothing
    for kernels compiled in memory, nothing written to a folder read only; the shipped kernels read when the
    writable folder lacks one; a file another user can write is not loaded; a file that cannot be read back is a
    miss (the kernel is compiled again and the file rewritten)."""

    def __init__(self, cache_path, filename_base, source_stamp):
        super().__init__(cache_path, filename_base, source_stamp)
        self._filename_base = filename_base

    def _ours(self) -> bool:
        return self._source_stamp == source_stamp()

    def save(self, key, data):
        if self._cache_path not in _READ_ONLY:
            super().save(key, data)
        elif self._cache_path != IN_MEMORY:
            _warn_once(
                "read-only",
                f"omegahat: a kernel is not among those shipped in {self._cache_path} (compiled at install, or by "
                "another Numba or NumPy) and no cache folder is writable (NUMBA_CACHE_DIR, the package's "
                "__pycache__, the user's cache folder): it is compiled in memory, again in every process",
            )

    def flush(self):
        if self._cache_path not in _READ_ONLY:
            super().flush()

    def load(self, key):
        data = super().load(key)
        shipped = _SHIPPED_BESIDE.get(self._cache_path)
        if data is None and shipped is not None:
            data = _GuardedCacheFile(shipped, self._filename_base, self._source_stamp).load(key)
        return data

    def _load_index(self):
        if self._cache_path == IN_MEMORY:
            return {}
        if not self._ours():
            return super()._load_index()
        return self._guarded(super()._load_index, self._index_path, {})

    def _load_data(self, name):
        if not self._ours():
            return super()._load_data(name)
        return self._guarded(lambda: super(_GuardedCacheFile, self)._load_data(name), self._data_path(name), None)

    def _guarded(self, load, path, missing):
        try:
            st = os.stat(path)
        except FileNotFoundError:
            return missing
        if not trusted(st):
            _warn_once(
                "untrusted-file",
                f"omegahat: the kernel cache file {path} can be written by another user; it is not loaded (loading "
                "it could run their code): that kernel is compiled again",
            )
            return missing
        try:
            return load()
        except Exception:  # truncated, garbage, another format: a miss, and the next save rewrites it
            return missing


def _register() -> None:
    """Our locators first, in Numba's order (the user's folder if set, next to the source if writable, the
    user-wide one), then the shipped kernels read only, then compiling in memory; and the guarded files for every
    cache."""
    locators = caching.CacheImpl._locator_classes
    ours = [
        UserProvidedPackageLocator,
        InTreePackageLocator,
        UserWidePackageLocator,
        ShippedPackageLocator,
        InMemoryLocator,
    ]
    locators[:] = ours + [cls for cls in locators if cls not in ours]
    caching.IndexDataCacheFile = _GuardedCacheFile  # type: ignore[misc]  # Cache.__init__ looks it up at call time


_register()
