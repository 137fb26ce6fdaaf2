r"""Angular velocity from ONE measured direction: two observers and a run-time excitation monitor.

``docs/theory/single_direction.md`` explains the equations below at length. Model: a known inertial unit direction
``v`` (a sun sensor's Sun, a magnetometer's field) is seen in the body as ``b = Rᵀ v``, with ``R`` body→inertial,
ω in body axes, J known, τ known (default 0)::

    ḃ = b × ω,      J ω̇ = (J ω) × ω + τ                                                           (D1)

At one instant, b tells nothing about the component of ω along b (a spin about b leaves b unchanged): the rate is
observable only through the motion of b over time, i.e. under persistent excitation (PE) of the direction::

    G(t) = (1/T) ∫_{t−T}^{t} (I − b bᵀ) ds  ≥  g I     for some window T and some g > 0              (PE)

``λ_min(G) = 1 − λ_max(mean b bᵀ)`` is zero exactly when b stayed put over the window (a spin about b), and its
eigenvector is then the unobservable axis.

**The Sarras-type observer** (``method="sarras"``): the project's observer (``docs/theory/observer.md``, sign
corrected) with the single direction, state ``(ξ, r̂)``, gains ``k, l > 0``::

    ω̂  = ξ + J⁻¹ k b × r̂                                                                          (D2)
    ξ̇  = −J⁻¹ k (b × r̂) × ω̂ + J⁻¹ l k b × (r̂ − b) + J⁻¹((J ω̂) × ω̂ + τ)                          (D3)
    r̂̇ = r̂ × ω̂ − l (r̂ − b)                                                                       (D4)

with the error dynamics (z = ω̂ − ω, e = r̂ − b) of the n-direction observer at n = 1::

    ż = J⁻¹ k r̂ × (b × z) + J⁻¹((J ω̂) × ω̂ − (J ω) × ω),      ė = b × z + e × ω̂ − l e            (D5)

Once r̂ ≈ b the first term of ż is ``−J⁻¹ k (I − b bᵀ) z``: rank 2, blind along b; (PE) makes its average definite.

**The gradient observer** (``method="gradient"``), the baseline built here from first principles (a copy of (D1)
plus output injection, chosen so that the cross terms of a quadratic Lyapunov function cancel)::

    J ω̂̇ = (J ω̂) × ω̂ + τ + k b × b̂,      b̂̇ = b̂ × ω̂ − l (b̂ − b)                              (D6)
    V = ½ |b̂ − b|² + (1/2k) zᵀ J z,        V̇ = −l |b̂ − b|² + (1/k) zᵀ((J z) × ω)                  (D7)

For a spherical body (J = c I) the last term vanishes: V never increases, and under (PE) the error tends to zero
(the classical PE lemma of adaptive identification). It is *not* Magnis and Petit's observer (IEEE TAC 61(9),
2016), whose equations were not available to this project (``docs/theory/single_direction.md``).

**Sampled realisation** (both methods; here in plain NumPy, many runs at once: :func:`run_single_direction`, the
oracle of the compiled step :mod:`omegahat.observer.single_direction_step` that :class:`SingleDirectionEstimator`
runs). Between samples ``t_k`` and ``t_{k+1}`` the observer is integrated by classical RK4 in equal substeps
(``rate · substep ≤ 0.5`` with ``rate`` the largest of ``l``, ``k/J_m`` and the turning rates), with the measured
direction moved along the great circle from ``b_k`` to ``b_{k+1}`` at constant rate and the torque held at ``τ_k``; a
missing sample (NaN) instead moves b along the estimate, ``ḃ = b × ω̂``, and the next valid sample's great circle
starts from there (causal: the estimate at ``t_k`` uses samples up to ``t_k``)::

    ḃ = b × w,   w = −(θ_k / h_k) (b_k × b_{k+1}) / |b_k × b_{k+1}|,  θ_k = ∠(b_k, b_{k+1})          (D8)

**Excitation monitor.** The causal, exponentially weighted version of G, ``G_k = S_k / W_k`` with
``S_k = a S_{k−1} + (1 − a)(I − b_k b_kᵀ)``, ``W_k = a W_{k−1} + (1 − a)``, ``a = exp(−h_k / T)``: a sample is
flagged unobservable when ``λ_min(G_k) < threshold`` once a full window has elapsed. With sensor noise σ the floor
of ``λ_min`` is about ``2σ²`` (6e-6 at 0.1°), far below the default threshold 1e-3. For b on a cone of half-angle
α about an axis, ``λ_min(G) = sin²α`` (axis: the cone's): the threshold flags cones narrower than 1.8°.
"""

from __future__ import annotations

import math
import warnings
from typing import Literal, TypeAlias, get_args

import numpy as np
from numpy.typing import ArrayLike

from omegahat import measurements as ms
from omegahat import so3
from omegahat.interface import Estimate, Status, StreamingEstimator, one_of
from omegahat.observer import single_direction_step as step
from omegahat.observer.continuous import OUTPUT_SIGN_CORRECTED
from omegahat.validation import as_inertia, as_positive, as_vector3

__all__ = [
    "METHODS",
    "SUBSTEP_RATE",
    "LostExcitationWarning",
    "Method",
    "SingleDirectionEstimator",
    "default_gains",
    "excitation",
    "gradient_rhs",
    "run_single_direction",
    "sarras_output",
    "sarras_rhs",
]

#: the observer of (D2)–(D4), or the gradient one of (D6)
Method: TypeAlias = Literal["sarras", "gradient"]
METHODS: tuple[str, ...] = get_args(Method)
DEFAULT_WINDOW_S = 10.0  #: the excitation window T (s)
DEFAULT_BANDWIDTH_HZ = 0.5 / (2 * math.pi)  #: 0.5 rad/s: the gains' default bandwidth (Hz)
DEFAULT_THRESHOLD = 1e-3  #: λ_min(G) below this is flagged (a cone of half-angle 1.8°)
SUBSTEP_RATE = 0.5  #: rate · substep: RK4 is accurate to ~3e-4 per substep there, stable to 2.78


class LostExcitationWarning(UserWarning):
    """The measured direction stayed (nearly) fixed in the body: the rate about it cannot be estimated.

    Examples
    --------
    A spin about the measured direction (b does not move in the body; window about 1 s):

    >>> import warnings
    >>> import numpy as np
    >>> from omegahat import LostExcitationWarning, SingleDirectionEstimator
    >>> t = np.arange(0.0, 5.0, 0.05)
    >>> b = np.tile([0.0, 0.0, 1.0], (t.size, 1))
    >>> est = SingleDirectionEstimator(np.eye(3), window_s=0.99)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = est.run(t, b)
    >>> caught[0].category is LostExcitationWarning, int(est.unobservable.sum())  # from t = 1 s on
    (True, 80)
    >>> print(f"weak axis . b = {est.weak_axis[-1] @ b[-1]:.3f}")  # the unobservable axis: b itself
    weak axis . b = 1.000
    """


def _inv(J: np.ndarray) -> np.ndarray:
    return np.linalg.inv(J)


def sarras_output(
    xi: np.ndarray, b: np.ndarray, r_hat: np.ndarray, k: float, J_inv: np.ndarray, sign: float = 1.0
) -> np.ndarray:
    """(D2): ``ω̂ = ξ + sign · J⁻¹ k b × r̂``, batched over leading axes (``sign = −1``: the paper's misprint)."""
    return xi + sign * k * so3.cross(b, r_hat) @ J_inv.T


def sarras_rhs(
    xi: np.ndarray,
    r_hat: np.ndarray,
    b: np.ndarray,
    tau: np.ndarray,
    J: np.ndarray,
    J_inv: np.ndarray,
    k: float,
    l: float,
    sign: float = 1.0,
) -> tuple[np.ndarray, np.ndarray]:
    """(D3), (D4): ``(ξ̇, r̂̇)`` of the Sarras-type observer, batched ``(*B, 3)``; ``sign`` selects the output map."""
    w = sarras_output(xi, b, r_hat, k, J_inv, sign)
    bxr = so3.cross(b, r_hat)
    xi_dot = (-k * so3.cross(bxr, w) + l * k * so3.cross(b, r_hat - b) + so3.cross(w @ J.T, w) + tau) @ J_inv.T
    r_dot = so3.cross(r_hat, w) - l * (r_hat - b)
    return xi_dot, r_dot


def gradient_rhs(
    omega_hat: np.ndarray,
    b_hat: np.ndarray,
    b: np.ndarray,
    tau: np.ndarray,
    J: np.ndarray,
    J_inv: np.ndarray,
    k: float,
    l: float,
) -> tuple[np.ndarray, np.ndarray]:
    """(D6): ``(ω̂̇, b̂̇)`` of the gradient observer, batched ``(*B, 3)``."""
    w_dot = (so3.cross(omega_hat @ J.T, omega_hat) + tau + k * so3.cross(b, b_hat)) @ J_inv.T
    b_dot = so3.cross(b_hat, omega_hat) - l * (b_hat - b)
    return w_dot, b_dot


def default_gains(J: ArrayLike, method: Method, bandwidth_hz: float) -> tuple[float, float]:
    """``(k, l)`` for a bandwidth ``ω_b = 2π bandwidth_hz`` (rad/s): sarras ``k = ω_b J_M`` (every observable mode
    at least ``ω_b`` once r̂ ≈ b), ``l = 4 ω_b``; gradient ``k = ω_b² J_M`` (natural frequency at least ω_b),
    ``l = 2 ω_b`` (damping ratio 1 for the slowest axis)."""
    J = as_inertia(J)
    wb = 2 * math.pi * float(as_positive(bandwidth_hz, "bandwidth_hz")[0])
    J_M = float(np.linalg.eigvalsh(J)[-1])
    if method == "sarras":
        return wb * J_M, 4.0 * wb
    if method == "gradient":
        return wb * wb * J_M, 2.0 * wb
    raise ValueError(f"method must be one of {', '.join(METHODS)}; got {method!r}")


def _unit(b: np.ndarray, j: int) -> np.ndarray:
    """Rows of ``b`` normalised; a zero row raises naming sample ``j``."""
    n = np.linalg.norm(b, axis=-1, keepdims=True)
    if np.any(n == 0):
        raise ValueError(f"sample {j}: the measured direction b has zero length")
    return b / n


def _great_circle_rate(b0: np.ndarray, b1: np.ndarray, h: float) -> np.ndarray:
    """(D8): the constant rate ``w`` with ``ḃ = b × w`` that carries unit ``b0`` to unit ``b1`` in ``h``."""
    c = so3.cross(b0, b1)
    s = np.linalg.norm(c, axis=-1, keepdims=True)
    theta = np.arctan2(s, np.sum(b0 * b1, axis=-1, keepdims=True))
    # For s → 0 the axis is undefined but θ/s → 1: w = −c/h to first order.
    scale = np.where(s > 1e-12, theta / np.where(s > 1e-12, s, 1.0), 1.0)
    return -scale * c / h


def run_single_direction(
    t: ArrayLike,
    b: ArrayLike,
    J: ArrayLike,
    *,
    method: Method = "sarras",
    k: float,
    l: float,
    omega_hat0: ArrayLike | None = None,
    r_hat0: ArrayLike | None = None,
    torques: ArrayLike | None = None,
    sign: float = OUTPUT_SIGN_CORRECTED,
    state: dict | None = None,
) -> tuple[np.ndarray, dict]:
    """Run an observer over samples: ``t (T,)``, ``b (T, 3)`` or ``(T, B, 3)`` (B runs at once; NaN rows missing).

    Returns ``ω̂`` of b's shape (the estimate at every sample time) and the state to continue from (pass it back as
    ``state`` with the next samples). ``omega_hat0`` (default 0) and ``r_hat0`` (the filtered direction r̂ or b̂,
    default the first sample) broadcast to ``(B, 3)``; ``torques`` ``(T, 3)`` or ``(T, B, 3)``, held over each
    interval. The first sample must be valid unless ``state`` is given.
    """
    one_of("method", method, Method)
    J = as_inertia(J)
    J_inv = _inv(J)
    k = float(as_positive(k, "k")[0])
    l = float(as_positive(l, "l")[0])
    t = np.asarray(t, dtype=float)
    b = np.asarray(b, dtype=float)
    single = b.ndim == 2
    B3 = b[:, None, :] if single else b
    if B3.ndim != 3 or B3.shape[-1] != 3 or B3.shape[0] != t.size:
        raise ValueError(f"b must have shape (T, 3) or (T, B, 3) with T = len(t) = {t.size}; got shape {b.shape}")
    if t.size and np.any(np.diff(t) <= 0):
        raise ValueError("sample times t must be increasing")
    T, nb = B3.shape[:2]
    valid = np.all(np.isfinite(B3), axis=-1)
    tau = (
        np.zeros((T, nb, 3))
        if torques is None
        else np.broadcast_to(np.asarray(torques, float).reshape(T, -1, 3), (T, nb, 3))
    )
    out = np.full((T, nb, 3), np.nan)
    J_m = float(np.linalg.eigvalsh(J)[0])
    if state is None:
        if T == 0:
            raise ValueError("no samples")
        if not np.all(valid[0]):
            raise ValueError("the first sample must be a valid direction (finite)")
        b_cur = _unit(B3[0], 0)
        w0 = np.zeros((nb, 3)) if omega_hat0 is None else np.broadcast_to(np.asarray(omega_hat0, float), (nb, 3))
        r0 = b_cur.copy() if r_hat0 is None else np.broadcast_to(np.asarray(r_hat0, float), (nb, 3)).copy()
        if method == "sarras":  # ξ₀ so that the output map (D2) gives ω̂₀
            x1 = w0 - sign * k * so3.cross(b_cur, r0) @ J_inv.T
        else:
            x1 = w0.astype(float).copy()
        state = {"t": float(t[0]), "b": b_cur, "x1": x1, "x2": r0, "tau": tau[0].copy()}
        start = 0
    else:
        start = -1  # every sample is after the state's time
    t_prev, b_cur, x1, x2, tau_prev = state["t"], state["b"], state["x1"], state["x2"], state["tau"]

    def output(x1, x2, b):
        return sarras_output(x1, b, x2, k, J_inv, sign) if method == "sarras" else x1

    def rhs(x1, x2, bb, w_meas, use_meas, tq):
        what = output(x1, x2, bb)
        if method == "sarras":
            d1, d2 = sarras_rhs(x1, x2, bb, tq, J, J_inv, k, l, sign)
        else:
            d1, d2 = gradient_rhs(x1, x2, bb, tq, J, J_inv, k, l)
        w = np.where(use_meas, w_meas, what)  # (D8) toward the next sample, or along the estimate when missing
        return d1, d2, so3.cross(bb, w)

    for j in range(T):
        if j == start:
            out[0] = output(x1, x2, b_cur)
            continue
        h = float(t[j] - t_prev)
        if h <= 0:
            raise ValueError(f"sample {j}: time {float(t[j])!r} is not after the previous one ({t_prev!r})")
        ok = valid[j][:, None]
        b_next = _unit(np.where(ok, B3[j], b_cur), j)
        w_meas = _great_circle_rate(b_cur, b_next, h)
        what = output(x1, x2, b_cur)
        rate = max(
            l, k / J_m, float(np.max(np.linalg.norm(what, axis=-1))), float(np.max(np.linalg.norm(w_meas, axis=-1)))
        )
        if not math.isfinite(rate):
            n_sub = 1
        else:
            n_sub = max(1, math.ceil(h * rate / SUBSTEP_RATE))
        dt = h / n_sub
        bb = b_cur
        for _ in range(n_sub):  # classical RK4 on (x1, x2, b)
            a1 = rhs(x1, x2, bb, w_meas, ok, tau_prev)
            a2 = rhs(x1 + 0.5 * dt * a1[0], x2 + 0.5 * dt * a1[1], bb + 0.5 * dt * a1[2], w_meas, ok, tau_prev)
            a3 = rhs(x1 + 0.5 * dt * a2[0], x2 + 0.5 * dt * a2[1], bb + 0.5 * dt * a2[2], w_meas, ok, tau_prev)
            a4 = rhs(x1 + dt * a3[0], x2 + dt * a3[1], bb + dt * a3[2], w_meas, ok, tau_prev)
            x1 = x1 + dt / 6.0 * (a1[0] + 2 * a2[0] + 2 * a3[0] + a4[0])
            x2 = x2 + dt / 6.0 * (a1[1] + 2 * a2[1] + 2 * a3[1] + a4[1])
            bb = bb + dt / 6.0 * (a1[2] + 2 * a2[2] + 2 * a3[2] + a4[2])
        # A measured sample replaces the moved direction (they agree to RK4 accuracy); a predicted one is renormalised.
        b_cur = np.where(ok, b_next, bb / np.linalg.norm(bb, axis=-1, keepdims=True))
        t_prev = float(t[j])
        tau_prev = np.where(ok, tau[j], tau_prev)
        out[j] = output(x1, x2, b_cur)
    state = {"t": t_prev, "b": b_cur, "x1": x1, "x2": x2, "tau": tau_prev}
    return (out[:, 0] if single else out), state


def excitation(
    t: ArrayLike,
    b: ArrayLike,
    window_s: float = DEFAULT_WINDOW_S,
    *,
    state: dict | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The monitor of the module docstring over samples ``t (T,)``, ``b (T, 3)`` (NaN rows skipped).

    Returns ``λ_min(G_k)`` ``(T,)`` (NaN before any valid sample), the weakest axis ``(T, 3)`` (its eigenvector,
    the largest component positive: the unobservable axis when λ_min is small) and the state to continue from.
    ``G_k`` counts as established once ``window_s`` has elapsed since the first valid sample (``state["since"]``,
    per sample).
    """
    T_w = float(as_positive(window_s, "window_s")[0])
    t = np.asarray(t, dtype=float)
    b = np.asarray(b, dtype=float)
    if b.shape != (t.size, 3):
        raise ValueError(f"b must have shape (T, 3) with T = len(t) = {t.size}; got shape {b.shape}")
    if state is None:
        state = {"S": np.zeros((3, 3)), "W": 0.0, "t": None, "t0": None}
    S, W, t_last, t0 = state["S"], state["W"], state["t"], state["t0"]
    lam = np.full(t.size, np.nan)
    axis = np.full((t.size, 3), np.nan)
    since = np.full(t.size, 0.0)
    for j in range(t.size):
        if np.all(np.isfinite(b[j])):
            u = b[j] / np.linalg.norm(b[j])
            a = 0.0 if t_last is None else math.exp(-(t[j] - t_last) / T_w)
            S = a * S + (1.0 - a) * (np.eye(3) - np.outer(u, u))
            W = a * W + (1.0 - a)
            t_last = float(t[j])
            t0 = float(t[j]) if t0 is None else t0
        if W > 0:
            vals, vecs = np.linalg.eigh(S / W)
            v = vecs[:, 0]
            lam[j], axis[j] = vals[0], v if v[np.argmax(np.abs(v))] >= 0 else -v
        since[j] = 0.0 if t0 is None else t[j] - t0
    state = {"S": S, "W": W, "t": t_last, "t0": t0, "since": since, "window_s": T_w}
    return lam, axis, state


_CORRECTED, _PREDICTED, _UNAVAILABLE = int(Status.CORRECTED), int(Status.PREDICTED), int(Status.UNAVAILABLE)
_STATUS_OF_INT = {int(s): s for s in Status}  # a dict lookup: an enum's call is slow on update's per-sample path


class SingleDirectionEstimator(StreamingEstimator):
    """ω from one measured direction ``b = Rᵀ v``: the Sarras-type observer (default) or the gradient one.

    Samples ``(3,)`` (``run``: ``(T, 3)``; or ``(1, 3)`` and ``(T, 1, 3)``) go through the one input path
    (:mod:`omegahat.measurements`: a zero direction, a time not after the previous one, a non-finite torque are
    refused and change nothing; a NaN or inf makes the sample missing: predicted along the estimate, status
    ``predicted``). :meth:`run` and :meth:`update` set ``excitation`` (λ_min of the windowed Gramian per sample of
    the call), ``weak_axis`` and ``unobservable`` (bool per sample); ``run`` warns :class:`LostExcitationWarning`
    when some samples are unobservable. Successive calls continue from the last state.

    Parameters
    ----------
    J : array_like
        The inertia (as ``omegahat.RigidBody``; the identity means "a constant rate"); the one positional argument.
    reference : array_like, optional
        The inertial direction ``v`` (only its being one direction matters to the observer; it is kept for the
        caller). Default ``(0, 0, 1)``.
    method : {"sarras", "gradient"}, optional
        The observer (D2)–(D4) or the gradient one (D6).
    k, l : float, optional
        The gains (both or neither; default from ``bandwidth_hz``, :func:`default_gains`).
    bandwidth_hz : float, optional
        Sets ``k`` and ``l`` when they are not given (Hz; default :data:`DEFAULT_BANDWIDTH_HZ`, 0.5 rad/s).
    omega_hat0 : array_like, optional
        The initial estimate (default 0; given, it is the estimate at the first valid sample, else there is none
        there).
    r_hat0 : array_like, optional
        The initial r̂ (or b̂); default the first sample.
    window_s, threshold : float, optional
        The excitation monitor's window T (s, default 10) and threshold on ``λ_min(G_k)`` (default 1e-3).
    sign : float, optional
        Sign of the output map (−1: the paper's misprint, for tests only).

    Examples
    --------
    A constant rate (J = I) seen through one direction at 20 Hz; b sweeps a cone, so (PE) holds:

    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> from omegahat import SingleDirectionEstimator
    >>> w, v = np.array([0.5, 0.5, 0.5]), np.array([0.0, 0.0, 1.0])
    >>> t = np.arange(0.0, 40.0, 0.05)
    >>> b = Rotation.from_rotvec(np.outer(t, w)).inv().apply(v)  # b = Rᵀ v
    >>> est = SingleDirectionEstimator(np.eye(3), reference=v)
    >>> omega = est.run(t, b).omega
    >>> print(" ".join(f"{x:.3f}" for x in omega[-1]), bool(est.unobservable.any()))
    0.500 0.500 0.500 False
    """

    def __init__(
        self,
        J: ArrayLike,
        *,
        reference: ArrayLike = (0.0, 0.0, 1.0),
        method: Method = "sarras",
        k: float | None = None,
        l: float | None = None,
        bandwidth_hz: float = DEFAULT_BANDWIDTH_HZ,
        omega_hat0: ArrayLike | None = None,
        r_hat0: ArrayLike | None = None,
        window_s: float = DEFAULT_WINDOW_S,
        threshold: float = DEFAULT_THRESHOLD,
        sign: float = OUTPUT_SIGN_CORRECTED,
    ) -> None:
        self.J = as_inertia(J)
        v = as_vector3(reference, "reference")
        if not np.linalg.norm(v) > 0:
            raise ValueError("reference must be a non-zero vector")
        self.reference = v / np.linalg.norm(v)
        if (k is None) != (l is None):
            raise ValueError("give both k and l, or neither (then bandwidth_hz sets them)")
        k0, l0 = default_gains(self.J, method, bandwidth_hz)
        self.method: Method = method
        self.k = k0 if k is None else float(as_positive(k, "k")[0])
        self.l = l0 if l is None else float(as_positive(l, "l")[0])
        self.omega_hat0 = None if omega_hat0 is None else as_vector3(omega_hat0, "omega_hat0")
        self.r_hat0 = None if r_hat0 is None else as_vector3(r_hat0, "r_hat0")
        self.window_s = float(as_positive(window_s, "window_s")[0])
        self.threshold = float(as_positive(threshold, "threshold")[0])
        self.sign = float(sign)
        self._params = step.pack_params(
            self.J, gradient=method == "gradient", k=self.k, l=self.l, sign=self.sign, substep_rate=SUBSTEP_RATE,
            window_s=self.window_s, threshold=self.threshold, omega_hat0=self.omega_hat0, r_hat0=self.r_hat0,
        )  # fmt: skip
        self.reset()

    def reset(self) -> None:
        """Forget every sample."""
        self._state = step.initial_state()
        self._t_last: float | None = None
        self._n_valid = 0
        self.n_skipped = 0
        self.excitation = np.empty(0)
        self.weak_axis = np.empty((0, 3))
        self.unobservable = np.empty(0, dtype=bool)

    def _checks(self) -> dict:
        return {"references": self.reference[None], "t_prev": self._t_last}  # one reference: the n = 1 input path

    def update(self, t: float, sample: ArrayLike, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at ``t`` from the direction ``sample (3,)`` (``torque`` known from ``t`` on)."""
        s = ms.checked_sample(t, sample, torque, **self._checks())
        omega, status = self._advance(np.array([s.t]), s.value, s.torque[None])
        return Estimate(omega[0], _STATUS_OF_INT[int(status[0])])

    def run(self, t: ArrayLike, data: ArrayLike, torque: ArrayLike | None = None) -> Estimate:
        """The estimate at every sample of ``t (T,)``, ``data (T, 3)`` (NaN rows: missing, predicted through);
        atomic (a refused sample raises naming it, and nothing changes)."""
        log = ms.checked_log(t, data, torque, **self._checks())
        times = log.times
        omega, status = self._advance(times, log.values[:, 0], log.torques)
        if self.unobservable.any():
            j = int(np.flatnonzero(self.unobservable)[0])
            lam, axis = self.excitation[j], self.weak_axis[j]
            warnings.warn(
                f"{int(self.unobservable.sum())} of {times.size} samples (from t = {times[j]:.6g} s) without "
                f"excitation: the measured direction stayed within a cone of about "
                f"{math.degrees(math.sqrt(max(lam, 0.0))):.2g} deg over the last {self.window_s:g} s, so the rate "
                f"about the body axis {np.array2string(axis, precision=3)} is not observable (a spin about the "
                "measured direction)",
                LostExcitationWarning,
                stacklevel=2,
            )
        return Estimate(omega, status)

    def _advance(self, t: np.ndarray, b: np.ndarray, torques: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The checked samples (unit directions, NaN where missing) through the compiled observer and monitor
        (:func:`omegahat.observer.single_direction_step.advance`: NaN before the first valid sample)."""
        W, lam, axis, self.unobservable, self._state = step.advance(self._params, self._state, t, b, torques)
        if t.size:
            self._t_last = float(t[-1])
        self.excitation, self.weak_axis = lam, axis
        need = 1 if self.omega_hat0 is not None else 2  # one direction at one instant gives no rate
        if t.size == 1:  # update's sample: the same bookkeeping in scalars (NumPy's calls cost more than the step)
            ok1 = math.isfinite(b[0, 0] + b[0, 1] + b[0, 2])  # a NaN or inf entry, or none (no overflow: |b| = 1)
            seen1, self.n_skipped = self._n_valid + ok1, self.n_skipped + (not ok1)
            self._n_valid = min(seen1, 2)
            if seen1 < need:
                W[0] = np.nan
            return W, np.array([_UNAVAILABLE if seen1 < need else _CORRECTED if ok1 else _PREDICTED], dtype=np.int8)
        ok = np.all(np.isfinite(b), axis=1)
        status = np.where(ok, _CORRECTED, _PREDICTED).astype(np.int8)
        seen = self._n_valid + np.cumsum(ok)
        status[seen < need] = _UNAVAILABLE
        W[seen < need] = np.nan
        self._n_valid = min(self._n_valid + int(ok.sum()), 2)
        self.n_skipped += int((~ok).sum())
        return W, status
