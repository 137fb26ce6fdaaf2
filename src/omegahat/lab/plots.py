"""Figures. Every function builds a :class:`matplotlib.figure.Figure` (no pyplot state, no ``show()``) and
returns it; the caller saves or shows it. Colours follow the paper: true signals blue, estimates red."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure
from numpy.typing import ArrayLike

__all__ = ["ESTIMATE_COLOR", "TRUE_COLOR", "plot_direction", "plot_filter_errors", "plot_omega"]

TRUE_COLOR = "tab:blue"
ESTIMATE_COLOR = "tab:red"
_AXES = ("x", "y", "z")


def _component_axes(title: str):
    fig = Figure(figsize=(7.0, 6.0), layout="constrained")
    axes = fig.subplots(3, 1, sharex=True)
    fig.suptitle(title)
    return fig, axes


def plot_omega(t: ArrayLike, omega: np.ndarray, omega_hat: np.ndarray) -> Figure:
    """Figure 1 of the paper: components of the true ω (blue) and the estimate ω̂ (red)."""
    fig, axes = _component_axes("Angular velocity: true (blue) and estimated (red)")
    for a, ax in enumerate(axes):
        ax.plot(t, omega[:, a], color=TRUE_COLOR, label=rf"$\omega_{_AXES[a]}$")
        ax.plot(t, omega_hat[:, a], color=ESTIMATE_COLOR, linestyle="--", label=rf"$\hat\omega_{_AXES[a]}$")
        ax.set_ylabel(rf"$\omega_{_AXES[a]}$ (rad/s)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time (s)")
    return fig


def plot_direction(t: ArrayLike, r: np.ndarray, r_hat: np.ndarray, index: int) -> Figure:
    """Figures 2 and 3 of the paper: components of the measured direction r_i (blue) and the filter r̂_i (red)."""
    i = index + 1
    fig, axes = _component_axes(f"Direction $r_{i}$ (blue) and its filter $\\hat r_{i}$ (red)")
    for a, ax in enumerate(axes):
        ax.plot(t, r[:, a], color=TRUE_COLOR, label=rf"$r_{{{i}{_AXES[a]}}}$")
        ax.plot(t, r_hat[:, a], color=ESTIMATE_COLOR, linestyle="--", label=rf"$\hat r_{{{i}{_AXES[a]}}}$")
        ax.set_ylabel(f"component {_AXES[a]} (-)")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="upper right", fontsize="small")
    axes[-1].set_xlabel("time (s)")
    return fig


def plot_filter_errors(t: ArrayLike, filter_errors: np.ndarray, omega_error: ArrayLike | None = None) -> Figure:
    """Figure 4 of the paper: |r̂_i − r_i| on a log scale (optionally with |ω̂ − ω| for the second time scale)."""
    fig = Figure(figsize=(7.0, 4.0), layout="constrained")
    ax = fig.subplots()
    floor = np.finfo(float).tiny
    for i in range(filter_errors.shape[1]):
        ax.semilogy(t, np.maximum(filter_errors[:, i], floor), label=rf"$|\hat r_{i + 1} - r_{i + 1}|$")
    if omega_error is not None:
        ax.semilogy(
            t,
            np.maximum(omega_error, floor),
            color="black",
            linestyle=":",
            label=r"$|\hat\omega - \omega|$ (rad/s)",
        )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("filtering error (-)")
    ax.set_title("Norm of the filtering errors")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small")
    return fig
