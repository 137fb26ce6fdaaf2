"""docs/getting-started.md's Python examples run as printed, in order, in one namespace (the second uses the first's
log), and give the rate they are built on: a constant body rate, held by the torque Euler's equations need."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np

PAGE = Path(__file__).resolve().parents[1] / "docs" / "getting-started.md"


def test_the_getting_started_examples_run_and_recover_the_constant_rate() -> None:
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) == 2
    namespace: dict = {}
    for k, block in enumerate(blocks):
        exec(compile(block, f"getting-started.md python block {k}", "exec"), namespace)
    rate = np.array([0.01, -0.02, 0.015])  # the page's rate, written here independently
    W, w = namespace["W"], namespace["w"]
    assert np.abs(W[-1] - rate).max() < 1e-6  # offline, after two minutes at 0.05 Hz
    assert np.array_equal(w, W[-1])  # online, sample by sample: the same compiled step
    for frame in (namespace["out"], namespace["smoothed"]):
        assert list(frame.columns) == ["wx", "wy", "wz", "status"]
        assert np.abs(frame[["wx", "wy", "wz"]].to_numpy()[-100:] - rate).max() < 1e-6
    assert list(namespace["df"].columns) == ["t", "qx", "qy", "qz", "qw", "wx", "wy", "wz", "status"]
