"""The kernel cache (issue 23, item 7): a read-only installation works, damaged files are recompiled, a cache that
another user can write is never loaded.

Each case runs child processes (a fresh interpreter: the cache is read when a kernel is first called) with
``NUMBA_CACHE_DIR`` or the package's location pointing into a temporary folder. The kernel called is a cheap one
(:func:`omegahat.kernels.checks.check_time`, compiled in a fraction of a second); the read-only installation also
runs ``omegahat estimate``. Unwritable places are simulated by a regular file standing where a folder would be
created (so that the test holds when run as root, whom permission bits do not stop).
"""

from __future__ import annotations

import os
import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

import omegahat
from omegahat.kernels import cache

PROBE = (
    "import warnings; warnings.simplefilter('always')\n"
    "from omegahat.kernels.checks import check_time\n"
    "print(check_time(2.0, 1.0), dict(check_time.stats.cache_hits), dict(check_time.stats.cache_misses))\n"
)


def child(code: str, env: dict[str, str], *args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", code, *args], env={**os.environ, **env}, capture_output=True, text=True, timeout=600
    )


def probe(cache_dir: Path) -> subprocess.CompletedProcess:
    p = child(PROBE, {"NUMBA_CACHE_DIR": str(cache_dir)})
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    return p


def files(cache_dir: Path, suffix: str) -> list[Path]:
    return sorted(cache_dir.glob(f"*/checks.check_time-*{suffix}"))


def test_cache_is_used_from_a_private_folder(tmp_path):
    first, second = probe(tmp_path / "c"), probe(tmp_path / "c")
    assert "{} {(float64, float64): 1}" in first.stdout  # compiled: a miss
    assert "{(float64, float64): 1} {}" in second.stdout  # loaded: a hit
    assert files(tmp_path / "c", ".nbi") and files(tmp_path / "c", ".nbc")


def test_damaged_cache_files_are_recompiled(tmp_path):
    """Truncated data, garbage data, a garbage index, an empty index: each is a miss (compiled again, no
    UnpicklingError), and the file is rewritten so that the next run loads it."""
    c = tmp_path / "c"
    probe(c)
    (nbi,), (nbc,) = files(c, ".nbi"), files(c, ".nbc")
    good_index, good_data = nbi.read_bytes(), nbc.read_bytes()
    damages = [
        (nbc, good_data[: len(good_data) // 2]),
        (nbc, os.urandom(len(good_data))),
        (nbi, b"\x80\x04garbage" + os.urandom(64)),
        (nbi, b""),
    ]
    for path, damaged in damages:
        path.write_bytes(damaged)
        p = probe(c)
        assert "{} {(float64, float64): 1}" in p.stdout, (path.name, p.stdout)
        assert "Unpickling" not in p.stderr and "Error" not in p.stderr
        assert probe(c).stdout.endswith("{(float64, float64): 1} {}\n")  # rewritten: loaded again
    assert nbi.read_bytes()[:20] == good_index[:20]


def malicious_index(marker: Path) -> bytes:
    """An index file that creates ``marker`` when unpickled (what a hostile user could plant)."""

    class Payload:
        def __reduce__(self):
            return (open, (str(marker), "w"))

    import numba

    return pickle.dumps(numba.__version__) + pickle.dumps((Payload(), {}))


def test_cache_writable_by_others_is_not_loaded(tmp_path):
    """A folder others can write, or one file in a private folder that others can write: not unpickled (the
    planted payload does not run), the kernel compiled in memory or again, and a warning said once."""
    c = tmp_path / "c"
    probe(c)
    (nbi,) = files(c, ".nbi")
    marker = tmp_path / "pwned"
    nbi.write_bytes(malicious_index(marker))
    nbi.chmod(0o666)  # the file alone
    p = probe(c)
    assert not marker.exists()
    assert "{} {(float64, float64): 1}" in p.stdout
    assert p.stderr.count("can be written by another user") == 1
    nbi.write_bytes(malicious_index(marker))
    nbi.chmod(0o644)
    nbi.parent.chmod(0o777)  # the folder
    p = probe(c)
    assert not marker.exists()
    assert "{} {(float64, float64): 1}" in p.stdout
    assert p.stderr.count("KernelCacheWarning") == 1 and "compiled in memory" in p.stderr
    assert nbi.read_bytes() == malicious_index(marker)  # in memory: nothing written there either


def test_trust_rules():
    """Owner and write bits, as the module docstring states them (a status built by hand, no file needed)."""
    me = os.getuid()
    other = me + 12345

    def st(uid, mode):
        return os.stat_result((mode, 0, 0, 1, uid, os.getgid() + 54321, 0, 0, 0, 0))

    assert cache.trusted(st(me, 0o40755)) and cache.trusted(st(0, 0o40755))
    assert not cache.trusted(st(other, 0o40755))
    assert not cache.trusted(st(me, 0o40757)) and not cache.trusted(st(me, 0o100666))
    assert not cache.trusted(st(me, 0o40775))  # group write, a group that is not the user's own


def test_read_only_installation_imports_and_estimates(tmp_path):
    """The package copied where no ``__pycache__`` can be made, ``NUMBA_CACHE_DIR`` and the home folder unusable:
    ``import omegahat`` works, ``omegahat estimate`` writes its estimates, and a warning says once that the
    kernels are compiled in memory."""
    site = tmp_path / "site"
    shutil.copytree(Path(omegahat.__file__).parent, site / "omegahat", ignore=shutil.ignore_patterns("__pycache__"))
    for folder in [site / "omegahat", *(p for p in (site / "omegahat").rglob("*") if p.is_dir())]:
        (folder / "__pycache__").write_text("a file where the cache folder would go")
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    env = {
        "PYTHONPATH": str(site),
        "NUMBA_CACHE_DIR": str(blocker / "numba"),
        "HOME": str(blocker),
        "XDG_CACHE_HOME": str(blocker / "cache"),
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    t = np.arange(300) / 100.0
    rows = "\n".join(f"{tk!r},{float(np.cos(0.05 * tk))!r},0.0,0.0,{float(np.sin(0.05 * tk))!r}" for tk in t.tolist())
    log = tmp_path / "log.csv"
    log.write_text("t,qw,qx,qy,qz\n" + rows + "\n")
    code = (
        "import omegahat, sys; assert omegahat.__file__.startswith(sys.argv[1]), omegahat.__file__\n"
        "from omegahat.cli import main\n"
        # the fixed-gain observer: the compiled path with the fewest kernels (everything compiles in memory here)
        "sys.exit(main(['estimate', sys.argv[2], '-o', sys.argv[3], '--estimator', 'sarras']))\n"
    )
    p = child(code, env, str(site), str(log), str(tmp_path / "o.csv"))
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    assert p.stderr.count("compiled in memory, again in every process") == 1
    out = np.loadtxt(tmp_path / "o.csv", delimiter=",", skiprows=1, usecols=(1, 2, 3))
    np.testing.assert_allclose(out[-100:], np.tile([0.0, 0.0, 0.1], (100, 1)), atol=1e-6)
    assert not list(site.rglob("*.nbi"))
