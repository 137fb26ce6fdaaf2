"""The README's Python examples run as printed, and give what the README says they give.

Each ``python`` block of README.md is executed in its own namespace; the checks below compare the names it leaves
with values derived independently of the estimator (the constant rate the data were made with, the rigid body's
own integration, the design's predicted noise quoted in the README's text).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


def python_blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), flags=re.S)


def run_block(index: int, capsys: pytest.CaptureFixture[str]) -> tuple[dict, str]:
    namespace: dict = {"__name__": f"readme_example_{index}"}
    exec(compile(python_blocks()[index], f"README.md python block {index}", "exec"), namespace)
    return namespace, capsys.readouterr().out


def test_the_readme_has_one_example_per_input_kind() -> None:
    blocks = python_blocks()
    assert len(blocks) == 4
    assert ".as_quat()" in blocks[0] and "truth.R" in blocks[1] and "references=V" in blocks[2]
    assert "estimate_frame(df)" in blocks[3]


def test_quaternion_example_meets_the_noise_the_readme_quotes(capsys: pytest.CaptureFixture[str]) -> None:
    ns, out = run_block(0, capsys)
    measured, predicted = float(out.split()[0]), ns["omegahat"].predicted_noise_std(np.eye(3), ns["gains"], 100, 1e-3)
    assert re.search(r"\(second\): 0\.0062 rad/s", README.read_text(encoding="utf-8"))
    assert measured == pytest.approx(0.0062, abs=5e-5)  # the figure the README quotes
    assert measured == pytest.approx(float(predicted[0]), rel=0.05)  # and the design's prediction
    rms = np.sqrt(np.mean((ns["W"][500:] - [0.3, -0.2, 0.5]) ** 2))  # against the rate the data were made with
    assert rms == pytest.approx(measured, rel=1e-12)


def test_star_tracker_example_follows_the_integrated_body(capsys: pytest.CaptureFixture[str]) -> None:
    ns, out = run_block(1, capsys)
    from scipy.integrate import solve_ivp

    J = np.diag([300.0, 250.0, 200.0])
    tau = np.array([0.5, 0.0, -0.2])

    def euler(_t: float, w: np.ndarray) -> np.ndarray:  # Euler's equations, integrated by SciPy
        return np.linalg.solve(J, np.cross(J @ w, w) + tau)

    ref = solve_ivp(euler, (0.0, 119.8), [0.01, -0.02, 0.015], rtol=1e-12, atol=1e-14, dense_output=True)
    t = ns["t"]
    truth = ref.sol(t).T
    assert float(out) < 1e-6
    assert np.abs(ns["W"][-100:] - truth[-100:]).max() < 1e-6


def test_directions_example_recovers_the_rate(capsys: pytest.CaptureFixture[str]) -> None:
    ns, out = run_block(2, capsys)
    assert float(out) < 1e-9
    ns["est"].reset()  # run continues from the current state; from a fresh start, the whole second half is on it
    W = ns["est"].run(ns["t"], ns["b"]).omega
    assert np.abs(W[ns["t"].size // 2 :] - [0.3, -0.2, 0.5]).max() < 1e-9


def test_dataframe_example_returns_the_rate_indexed_like_the_frame(capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("pandas", reason="pandas is in the test extra: pip install '.[test]'")
    ns, out = run_block(3, capsys)
    result = ns["out"]
    assert list(result.columns) == ["wx", "wy", "wz", "status"]
    assert result.index.equals(ns["df"].index)
    last = result.iloc[-1]
    assert np.allclose([last.wx, last.wy, last.wz], [0.3, -0.2, 0.5], atol=1e-9)
    assert "corrected" in out
