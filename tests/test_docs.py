"""The documentation site: it builds with ``mkdocs build --strict`` (no warning), its generated pages hold what they
must, and the tutorials' code runs and prints what the pages show.

The tutorials are Python scripts in ``docs/tutorials/`` that the pages include whole, next to the output they
printed (``docs/tutorials/NAME.out``). After a change that alters a tutorial's output on purpose, regenerate the
``.out`` files with ``python tests/test_docs.py`` and review the diff.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import io
import os
import re
import runpy
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = ROOT / "docs" / "tutorials"
NAMES = ["spacecraft", "motion_capture", "directions"]
PACKAGE_PAGES = {
    "omegahat.observer": "observer",
    "omegahat.simulation": "simulation",
    "omegahat.lab.campaigns": "campaigns",
    "omegahat.baselines": "baselines",
    "omegahat.lab.control": "control",
    "omegahat.lab.evaluation": "evaluation",
    "omegahat.io": "io",
    "omegahat.identification": "identification",
    "omegahat.so3": "so3",
    "omegahat.measurements": "measurements",
}
_TIMING = re.compile(r"(estimated in|compiled once in) \d+\.\d+ s")
# omegahat.kernels.compiling.wait_note: said only by a process that compiled the kernels (a cold cache)
_COMPILING = re.compile(r"; \d+\.\d s in all, \d+\.\d s of it compiling the kernels \(once: [^)]*\)")
_NUMBER = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


@functools.cache
def run_tutorial(name: str) -> tuple[str, dict]:
    """Run ``docs/tutorials/NAME.py`` in this process; its stdout (temporary folder shown as ``<workdir>``) and
    its globals."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the tutorials' skipped-sample warnings are part of the story, not output
        g = runpy.run_path(str(TUTORIALS / f"{name}.py"), run_name="__main__")
    text = out.getvalue()
    if "workdir" in g:
        text = text.replace(str(g["workdir"]), "<workdir>")
    text = _TIMING.sub(r"\1 <seconds> s", text)  # how long it took is not part of the tutorial's result
    text = _COMPILING.sub("", text)  # nor whether this process found the kernels compiled
    return text, g


def same_output(got: str, expected: str, rtol: float = 1e-4) -> bool:
    """Equal text, and numbers equal to ``rtol`` (last digits may differ between platforms' math libraries)."""
    if _NUMBER.split(got) != _NUMBER.split(expected):
        return False
    a, b = _NUMBER.findall(got), _NUMBER.findall(expected)
    return len(a) == len(b) and all(
        abs(float(x) - float(y)) <= rtol * max(abs(float(y)), 1e-12) for x, y in zip(a, b, strict=True)
    )


def test_site_builds_strictly_with_the_generated_references(tmp_path):
    site = tmp_path / "site"
    result = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        capture_output=True,
        text=True,
        env={**os.environ, "NO_MKDOCS_2_WARNING": "1"},
        timeout=240,
    )
    assert result.returncode == 0, result.stderr[-4000:]
    cli = (site / "reference" / "cli" / "index.html").read_text()
    for text in ("omegahat estimate", "--topic", "--child-frame", "omegahat montecarlo", "omegahat compare"):
        assert text in cli, text  # generated from omegahat.cli.build_parser at build time
    api = (site / "reference" / "io" / "index.html").read_text()
    for name in (
        "omegahat.io.rosbag.open_bag",
        "omegahat.io.mocap.open_motive_csv",
        "omegahat.io.frames.estimate_frame",
        "omegahat.io.pipeline.estimate_stream",
    ):
        assert f'id="{name}"' in api, name  # rendered from the docstrings
    for package, page in PACKAGE_PAGES.items():  # each package page documents the package's public names
        html = (site / "reference" / page / "index.html").read_text()
        for name in importlib.import_module(package).__all__:
            if not name.startswith("_"):
                assert f'id="{package}.{name}"' in html, f"{package}.{name}"
    top = (site / "reference" / "omegahat" / "index.html").read_text()
    import omegahat

    for name in omegahat._PUBLIC:  # linked to where it is rendered (--strict fails on a dangling link)
        assert f"<code>omegahat.{name}</code>" in top, name
    tutorial = (site / "tutorials" / "spacecraft" / "index.html").read_text()
    assert "classical Runge-Kutta, 4 steps per fix" in tutorial  # the script itself is on the page (a comment of it)
    assert 'tutorials/spacecraft.py"' not in tutorial  # not the include directive left unexpanded
    assert "predicted noise per axis" in tutorial  # and so is its output
    assert (site / "img" / "fig1_omega.png").is_file()


@pytest.mark.parametrize("name", NAMES)
def test_tutorial_runs_and_prints_what_its_page_shows(name):
    text, _ = run_tutorial(name)
    expected = (TUTORIALS / f"{name}.out").read_text()
    assert same_output(text, expected), (
        f"docs/tutorials/{name}.py printed\n{text}\nbut its page shows docs/tutorials/{name}.out:\n{expected}\n"
        "(regenerate with `python tests/test_docs.py` if the change is intended)"
    )


def test_tutorials_claims_hold():
    """What the tutorial pages say, checked on the runs' own variables."""
    import numpy as np

    _, g = run_tutorial("spacecraft")
    ratio = g["rms"] / g["predicted"]
    assert np.all((ratio > 0.8) & (ratio < 1.25)), ratio  # "the measured error matches the prediction per axis"
    assert np.all(g["rms"] * 15 < np.sqrt(2) * g["sigma"] * g["rate_hz"])  # "fifteen times less than differencing"
    _, g = run_tutorial("motion_capture")
    assert g["rms"] < 0.5 * g["rms_diff"]  # "less than half that of plain differencing"
    _, g = run_tutorial("directions")
    assert g["rms"] < 0.03


if __name__ == "__main__":  # regenerate the outputs the tutorial pages show
    for n in NAMES:
        (TUTORIALS / f"{n}.out").write_text(run_tutorial(n)[0])
        print(f"wrote docs/tutorials/{n}.out")
