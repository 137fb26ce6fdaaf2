"""Kernels compiled when the wheel is built (issue 22, item 6): read where the package cannot be written, missed when
they come from another Numba, never loaded when others can write them; the warm-up that makes them; the backend.

The installed package is simulated by a copy of ``omegahat`` whose ``__pycache__`` a first child process fills (the
"shipped" kernels: :func:`omegahat.kernels.checks.check_time` for float arguments, compiled in a fraction of a
second), then made read-only: its folders lose their write bits, and — as root, whom write bits do not stop — the
child processes are told that Numba's probe of the folder failed (what it reports for a read-only file system).
"""

from __future__ import annotations

import os
import pickle
import shutil
import stat
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import omegahat
from omegahat.lab import warmup
from test_kernel_cache import PROBE, malicious_index

ROOT = Path(__file__).resolve().parents[1]
#: the probe for a signature that is not shipped (integer arguments)
PROBE_INT = PROBE.replace("check_time(2.0, 1.0)", "check_time(2, 1)")
#: as root, the package's folders are writable whatever their bits: say so to Numba as a read-only file system does
DENY_IN_TREE = (
    "import numba.core.caching as c\n"
    "def _deny(self):\n"
    "    raise PermissionError('read-only file system (simulated)')\n"
    "c.InTreeCacheLocator.ensure_cache_path = _deny\n"
)


def run(code: str, site: Path, home: Path, read_only: bool = False) -> subprocess.CompletedProcess:
    env = {
        **os.environ,
        "PYTHONPATH": str(site),
        "NUMBA_CACHE_DIR": "",
        "HOME": str(home),
        "XDG_CACHE_HOME": str(home / ".cache"),
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    if read_only and os.geteuid() == 0:
        code = DENY_IN_TREE + code
    p = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr
    return p


@pytest.fixture
def site(tmp_path):
    """A copy of the package whose kernel cache holds check_time(float, float), as a wheel built here ships it."""
    site = tmp_path / "site"
    shutil.copytree(Path(omegahat.__file__).parent, site / "omegahat", ignore=shutil.ignore_patterns("__pycache__"))
    first = run(PROBE, site, tmp_path / "builder")
    assert "{} {(float64, float64): 1}" in first.stdout  # compiled there, beside the sources
    assert shipped(site)
    yield site
    for folder in [site, *site.rglob("*")]:  # writable again, for the clean-up
        if folder.is_dir():
            folder.chmod(0o755)


def shipped(site: Path) -> dict[str, bytes]:
    folder = site / "omegahat" / "kernels" / "__pycache__"
    return {p.name: p.read_bytes() for p in sorted(folder.glob("checks.check_time-*.nb*"))}


def value(p: subprocess.CompletedProcess) -> str:
    """What the probe's kernel returned (before its cache statistics)."""
    return p.stdout.split(" {")[0]


def make_read_only(site: Path) -> None:
    for folder in [p for p in (site / "omegahat").rglob("*") if p.is_dir()] + [site / "omegahat"]:
        folder.chmod(0o555)


def blocked(tmp_path: Path) -> Path:
    """A home folder where no cache folder can be made (a file stands in its place)."""
    home = tmp_path / "blocked"
    home.write_text("")
    return home


def user_cache(home: Path) -> list[Path]:
    return sorted((home / ".cache").rglob("checks.check_time-*.nbi"))


def test_shipped_kernels_are_read_beside_the_users_cache(site, tmp_path):
    """A read-only package (a system-wide installation) and a writable home: the shipped kernel is loaded, one that
    is not shipped is compiled and cached in the user's folder (loaded from there next time), the package unchanged,
    nothing said."""
    before, home = shipped(site), tmp_path / "home"
    make_read_only(site)
    p = run(PROBE, site, home, read_only=True)
    assert "{(float64, float64): 1} {}" in p.stdout  # a hit: loaded from the package
    assert "KernelCacheWarning" not in p.stderr
    assert not user_cache(home)
    p = run(PROBE_INT, site, home, read_only=True)
    assert "{} {(int64, int64): 1}" in p.stdout and value(p) == value(run(PROBE, site, home))  # not shipped: compiled
    assert user_cache(home)  # and cached for this user
    assert "{(int64, int64): 1} {}" in run(PROBE_INT, site, home, read_only=True).stdout
    assert "{(float64, float64): 1} {}" in run(PROBE, site, home, read_only=True).stdout  # still from the package
    assert shipped(site) == before


def test_shipped_kernels_are_read_when_nothing_is_writable(site, tmp_path):
    """Nothing writable at all (a container's image): the shipped kernel is loaded silently; one that is not shipped
    is compiled in memory, correct, with one warning; nothing is written."""
    before, home = shipped(site), blocked(tmp_path)
    make_read_only(site)
    p = run(PROBE, site, home, read_only=True)
    assert "{(float64, float64): 1} {}" in p.stdout
    assert "KernelCacheWarning" not in p.stderr
    p = run(PROBE_INT, site, home, read_only=True)
    assert "{} {(int64, int64): 1}" in p.stdout and value(p) == value(run(PROBE, site, home))
    assert p.stderr.count("KernelCacheWarning") == 1
    assert "is not among those shipped" in p.stderr and "compiled in memory" in p.stderr
    assert shipped(site) == before


def test_kernels_shipped_by_another_numba_are_compiled_again(site, tmp_path):
    """The index says another Numba wrote it (a wheel built beside another version): a miss, compiled again,
    correct, no error — cached in the user's folder when the package is read-only, rewritten in the package when
    it is writable."""
    (index,) = (site / "omegahat" / "kernels" / "__pycache__").glob("checks.check_time-*.nbi")
    with open(index, "rb") as f:
        pickle.load(f)
        rest = f.read()
    index.write_bytes(pickle.dumps("0.0.0") + rest)
    home = tmp_path / "home"
    make_read_only(site)
    p = run(PROBE, site, home, read_only=True)
    assert "{} {(float64, float64): 1}" in p.stdout
    assert user_cache(home)
    for folder in [site, *site.rglob("*")]:
        if folder.is_dir():
            folder.chmod(0o755)
    p = run(PROBE, site, blocked(tmp_path))
    assert "{} {(float64, float64): 1}" in p.stdout  # writable package: compiled, and rewritten
    assert "{(float64, float64): 1} {}" in run(PROBE, site, blocked(tmp_path)).stdout


def test_shipped_kernel_others_can_write_is_not_loaded(site, tmp_path):
    """A shipped index that others can write (planted): not unpickled, the kernel compiled, one warning."""
    (index,) = (site / "omegahat" / "kernels" / "__pycache__").glob("checks.check_time-*.nbi")
    marker = tmp_path / "pwned"
    index.write_bytes(malicious_index(marker))
    index.chmod(0o666)
    make_read_only(site)
    p = run(PROBE, site, tmp_path / "home", read_only=True)
    assert not marker.exists()
    assert "{} {(float64, float64): 1}" in p.stdout
    assert p.stderr.count("can be written by another user") == 1


def test_the_warm_up_runs_every_path_and_a_new_process_compiles_nothing(tmp_path):
    """The warm-up's steps all run; afterwards a fresh process running them again loads every kernel (what a wheel's
    first run does): no compilation. The streaming estimators' ``update`` (a controller's per-sample call) runs the
    very compiled step their ``run`` loops over, so it compiles nothing either."""
    lines: list[str] = []
    assert warmup.run(tmp_path, say=lines.append) == []
    assert len(lines) == len(warmup.STEPS) and all("FAILED" not in line for line in lines)
    code = (
        "import sys, pathlib\n"
        "import numpy as np\n"
        "from omegahat import SarrasEstimator, SupervisedKalmanEstimator, theorem_gains\n"
        "from omegahat.lab import warmup\n"
        "failed = warmup.run(pathlib.Path(sys.argv[1]), say=lambda line: None)\n"
        "J = np.diag([3.0, 2.0, 1.0])\n"
        "for est in (SarrasEstimator(J, gains=theorem_gains(J, 3.0)),\n"
        "            SupervisedKalmanEstimator(J, rate_hz=100.0, measurement_noise=1e-3)):\n"
        "    for k in range(3):\n"
        "        est.update(0.01 * k, np.eye(3))\n"
        "        est.update(0.01 * k + 0.005, [0.0, 0.0, 0.0, 1.0])\n"
        "print(failed, warmup.compiled_here())\n"
    )
    (tmp_path / "again").mkdir()
    p = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path / "again")], capture_output=True, text=True, timeout=600
    )
    assert p.returncode == 0, p.stderr
    assert p.stdout.strip() == "[] []", p.stdout


def test_the_logs_of_the_warm_up_are_what_they_say(tmp_path):
    """The one-direction log is the first column of Rᵀ (the body-frame x reference), the two-direction log its first
    two, both unit vectors, and the quaternions' rotation maps one to the other."""
    from scipy.spatial.transform import Rotation

    logs = warmup.write_logs(tmp_path)
    q = np.loadtxt(logs["quaternions"], delimiter=",", skiprows=1)
    b = np.loadtxt(logs["directions"], delimiter=",", skiprows=1)
    b1 = np.loadtxt(logs["direction"], delimiter=",", skiprows=1)
    R = Rotation.from_quat(q[:, 1:5]).as_matrix()
    np.testing.assert_allclose(np.einsum("kij,kj->ki", R, b[:, 1:4]), np.tile([1.0, 0.0, 0.0], (len(q), 1)), atol=1e-12)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", R, b[:, 4:7]), np.tile([0.0, 1.0, 0.0], (len(q), 1)), atol=1e-12)
    np.testing.assert_array_equal(b1, b[:, :4])
    assert np.all(np.diff(q[:, 0]) > 0)


@pytest.mark.filterwarnings("ignore:Support for `\\[tool.setuptools\\]` in `pyproject.toml` is still \\*beta\\*")
def test_the_build_environment_gets_the_packages_dependencies(monkeypatch):
    """The wheel's build installs what the warm-up imports: setuptools' requirements and ``[project] dependencies``
    (none added when ``OMEGAHAT_SKIP_WARMUP`` is set)."""
    pytest.importorskip("setuptools")
    monkeypatch.syspath_prepend(str(ROOT / "build_support"))
    monkeypatch.chdir(ROOT)
    import omegahat_build

    with open(ROOT / "pyproject.toml", "rb") as f:
        dependencies = tomllib.load(f)["project"]["dependencies"]
    assert any(d.startswith("numba") for d in dependencies)
    monkeypatch.delenv(omegahat_build.SKIP, raising=False)
    requires = omegahat_build.get_requires_for_build_wheel()
    assert set(dependencies) <= set(requires)
    monkeypatch.setenv(omegahat_build.SKIP, "1")
    assert not set(dependencies) & set(omegahat_build.get_requires_for_build_wheel())


def test_a_failed_warm_up_does_not_fail_the_build(tmp_path, monkeypatch):
    """A build folder without the package (the warm-up cannot run on it): False and a warning, no exception; the
    child refuses an ``omegahat`` imported from anywhere but the copy being built."""
    pytest.importorskip("setuptools")
    monkeypatch.syspath_prepend(str(ROOT / "build_support"))
    import omegahat_build

    said: list[str] = []
    assert omegahat_build.warm_up(tmp_path, say=said.append) is False
    assert len(said) == 1 and "WARNING: compiling the kernels for the wheel failed" in said[0]
    assert "compiles them on first use" in said[0]
    assert "No module named 'omegahat'" in said[0] or "not the copy being built" in said[0]
    assert stat.S_ISDIR(tmp_path.stat().st_mode) and not list(tmp_path.rglob("*.nb?"))
