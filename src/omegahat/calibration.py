r"""A gyroscope calibrated against an attitude log of the same body: clock offset, frame rotation, bias and scale.

``omegahat calibrate ATTITUDE GYRO`` and :func:`calibrate`. The attitude log (any format :func:`omegahat.io.read_log`
reads; ``R(t)`` body → inertial) and the gyroscope log (``t, gx, gy, gz``: :func:`read_gyro`) have separate clocks and
rates. ``docs/calibrate.md`` has the method with its equations; in short, with ``ω(t)`` the body rate (body axes)::

    g(t + δ) = A ω(t) + b + n(t)                                                                       (C1)
    A = R_c (rotation only),  A = diag(s) R_c (per-axis scale, ``scale="axes"``),  A general (``"matrix"``)  (C2)

``δ`` (s) is the gyroscope's clock minus the attitude's for the same instant; ``R_c`` the rotation gyro frame ←
body frame; ``b`` the bias and ``s`` the scale factors in gyroscope units (rad/s, or raw counts with ``"matrix"``:
then ``A`` is counts per rad/s and may permute and mirror axes). Applied (:meth:`Calibration.apply`)::

    ω(t) = A⁻¹ (g(t + δ) − b)                                                                           (C3)

The fit, in the order that keeps it robust:

1. ``ω`` from a zero-lag estimate: SciPy's ``RotationSpline`` through the attitude samples
   (:func:`omegahat.baselines.spline.spline_rate`), so the fit absorbs no estimator's lag. Both sides are then
   low-passed by the same zero-phase Butterworth filter ``F`` (order 4, forward-backward, cut-off ``f_c``, default
   ``min(10 Hz, 0.4 × the slower rate)``) on the attitude's sample times; the gyroscope is first interpolated there
   (cubic spline, after an anti-alias low-pass at 0.45 × the attitude rate when it is sampled faster). ``F`` is
   linear with unit DC gain, so (C1) holds for ``F g`` and ``F ω`` with the same ``A``, ``b``, ``δ``: the fit uses
   the band where both sensors are accurate, and less noise in ``F ω`` means less attenuation of ``A`` (the
   regressor's noise biases a least-squares slope towards zero by its variance over the signal's).
2. ``δ`` coarsely from the cross-correlation of ``|F ω − mean|`` and ``|F g − mean|`` (frame-invariant: a rotation
   keeps the norm, a scale matrix nearly does; :mod:`omegahat.clock_offset`) at every lag at which the logs
   overlap, whatever their clocks' origins, or within ``±max_offset`` of a guess where a bound is given; then the
   ``δ`` on a grid of 0.1 sample that minimises the residual of the linear least-squares fit of ``A``, ``b``
   (C1). A motion that repeats itself matches at several lags; another local maximum, a period of the band or more
   away, with :data:`AMBIGUOUS_OFFSET` of the best's correlation is named in a note (a back-and-forth turn about one
   axis fits as well shifted by half its period with the axis reversed: only a narrower search can tell).
3. Starting values: ``R_c`` from Wahba's problem on the centred vectors, the rotation nearest to
   ``Σ (F g_k − ḡ)(F ω_k − ω̄)ᵀ`` (:func:`omegahat.so3.project`); ``b = ḡ − A ω̄``; ``s`` per axis by least squares;
   a general ``A`` by linear least squares.
4. All parameters jointly by nonlinear least squares (``scipy.optimize.least_squares``) on the residuals
   ``r_k = F g(t_k + δ) − A F ω(t_k) − b``, with the rotation as ``R_c = Exp(φ) R̂_c`` (``φ`` in gyro axes) and
   the analytic Jacobian (``∂r_k/∂δ = F ġ(t_k + δ)``, ``∂r_k/∂φ = diag(s) [R̂_c F ω_k]×``, ``∂r_k/∂b = −I``).
5. **A turn about one axis** (a hinge, a pendulum, a turntable; rotation only): where the centred rate varies along
   its second principal axis by less than :data:`MIN_EXCITATION` of its first, ``a`` (body axes), ``F ω ≈ w(t) a``
   and (C1) sees ``R_c`` only through ``u = R_c a``: a turn ``Exp(θ u)`` leaves every residual as it is. So ``φ`` is
   kept perpendicular to ``u`` (``x = T y``, ``T``'s rotation block an orthonormal basis of that plane), and each
   re-centring takes ``R̂_c`` to the least rotation with the same ``u``, about ``a × u`` by ``∠(a, u)``: the turn
   about ``u`` is a convention, said in a note and in ``free_axis``. The covariance is (C4)'s in ``y``, mapped by
   ``T`` (none along ``u``). Rates about ``a``, the offset and the bias are calibrated; others take that turn.

**Uncertainties.** The filtered residuals are correlated over about ``f/f_c`` samples, so the textbook
``σ² (JᵀJ)⁻¹`` would understate them. The covariance is the sandwich ``C = H⁻¹ Ω H⁻¹`` with ``H = Σ J_kᵀ J_k``
(``J_k`` the 3 × p Jacobian of sample k) and ``Ω`` the long-run covariance of the scores ``u_k = J_kᵀ r_k`` by
overlapping batch means over blocks of ``B = 8 f / f_c`` samples (a Bartlett-window Newey–West estimate)::

    Ω = N / ((N − B + 1) B) Σ_k U_k U_kᵀ,   U_k = Σ_{j=k}^{k+B−1} u_j                                     (C4)

Standard deviations of derived quantities (the rotation of a general ``A``, its rows' norms) propagate ``C``
through a finite-difference Jacobian. Samples within ``4/f_c`` seconds of an attitude gap, a gyroscope gap or either
log's end are left out (the spline and the filter bridge them).

**Identifiability.** The centred band-limited rate must vary along two independent axes for the whole ``R_c``
(along one, step 5), along three for scale factors or a matrix: the standard deviation along its weakest principal
axis must be at least :data:`MIN_EXCITATION` of the strongest, else a ``ValueError`` says so.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike
from scipy.interpolate import CubicSpline
from scipy.optimize import least_squares
from scipy.signal import butter, sosfiltfilt

from omegahat import measurements as ms
from omegahat import so3
from omegahat.baselines.spline import spline_rate
from omegahat.calibration_result import Calibration
from omegahat.clock_offset import OffsetSearch, check_search, search_offset

__all__ = [
    "DEFAULT_CUTOFF_HZ",
    "MIN_EXCITATION",
    "MODES",
    "Calibration",
    "band_limited",
    "calibrate",
]

MODES = ("none", "axes", "matrix")  #: scale factors: none (A = R_c), per gyro axis, or a general matrix
DEFAULT_CUTOFF_HZ = 10.0  #: the fit's band, lowered to 0.4 × the slower log's rate
MIN_EXCITATION = 0.05  #: weakest / strongest principal standard deviation of the rate that identifies R_c
AMBIGUOUS_OFFSET = 0.9  #: a second offset whose correlation is this share of the best's is named in a note
UNEXPLAINED = 0.5  #: a note where the residual's RMS is more than this share of the band-limited gyro's
_BLOCK_PERIODS = 8.0  # (C4): the batch length in periods of the cut-off
_MARGIN_PERIODS = 4.0  # samples this many cut-off periods from a gap or an end are left out
_GAP_FACTOR = 2.5  # a step longer than this × the median is a gap


# ------------------------------------------------------------------------------------------------------ the fit


def _rate(t: np.ndarray) -> float:
    return 1.0 / float(np.median(np.diff(t)))


class _Gaps:
    """Closed time intervals without data (merged, sorted): the long steps of a log and its missing samples."""

    def __init__(self, t: np.ndarray, missing: np.ndarray | None = None):
        h = np.diff(t)
        big = np.flatnonzero(h > _GAP_FACTOR * np.median(h))  # a step this long is a gap
        lo, hi = [t[big]], [t[big + 1]]
        if missing is not None:
            lo.append(t[missing])
            hi.append(t[missing])
        starts, ends = np.concatenate(lo), np.concatenate(hi)
        order = np.argsort(starts)
        self.starts, self.ends = starts[order], np.maximum.accumulate(ends[order]) if ends.size else ends

    def near(self, t: np.ndarray, margin: float) -> np.ndarray:
        """True where ``t`` is within ``margin`` of a gap (or inside one)."""
        if self.starts.size == 0:
            return np.zeros(t.shape, dtype=bool)
        i = np.searchsorted(self.starts - margin, t, side="right") - 1  # the last gap starting before t + margin
        return (i >= 0) & (t <= self.ends[np.maximum(i, 0)] + margin)


class _Problem:
    """The band-limited data of (C1) and the residual of a parameter vector (module docstring, step 4)."""

    def __init__(self, mode, t_a, W, valid_a, t_g, g, cutoff_hz):
        self.mode, self.t, self.fc = mode, t_a, cutoff_hz
        self.fa, self.fg = _rate(t_a), _rate(t_g)
        self.sos = butter(4, cutoff_hz, fs=self.fa, output="sos")
        self.g = g
        if self.fg > 1.25 * self.fa:  # anti-alias before the attitude's times pick the gyro's samples
            self.g = sosfiltfilt(butter(4, 0.45 * self.fa, fs=self.fg, output="sos"), g, axis=0)
        self.t_g = t_g
        self.rebase(0.0)
        self.W = sosfiltfilt(self.sos, W, axis=0)
        self.valid_a = valid_a
        self.gap_a = _Gaps(t_a, ~valid_a)
        self.margin = _MARGIN_PERIODS / cutoff_hz
        self.use = np.zeros(t_a.size, dtype=bool)

    def rebase(self, base: float) -> None:
        """Count offsets from ``base`` s: near zero, the fit's relative tolerances stay tight for clocks far apart."""
        self.base = base
        t_g = self.t_g - base
        self.gyro = CubicSpline(t_g, self.g, axis=0)
        self.gyro_dot = self.gyro.derivative()
        self.tg_range = (t_g[0], t_g[-1])
        self.gap_g = _Gaps(t_g)

    def usable(self, delta: float, slack: float) -> np.ndarray:
        """Attitude samples far enough (margin + ``slack``) from gaps and both logs' ends at offset ``delta``."""
        t, m = self.t, self.margin + slack
        ok = self.valid_a & (t >= t[0] + m) & (t <= t[-1] - m)
        ok &= (t + delta >= self.tg_range[0] + m) & (t + delta <= self.tg_range[1] - m)
        ok &= ~self.gap_a.near(t, m) & ~self.gap_g.near(t + delta, m)
        return ok

    def G(self, delta: float, derivative: bool = False) -> np.ndarray:
        f = self.gyro_dot if derivative else self.gyro
        return sosfiltfilt(self.sos, f(np.clip(self.t + delta, *self.tg_range)), axis=0)

    def linear_fit(self, delta: float) -> tuple[np.ndarray, np.ndarray, float]:
        """``A, b`` of (C1) by linear least squares at offset ``delta`` and the residual sum of squares."""
        G, W = self.G(delta)[self.use], self.W[self.use]
        X = np.column_stack([W, np.ones(W.shape[0])])
        coef, *_ = np.linalg.lstsq(X, G, rcond=None)
        r = G - X @ coef
        return coef[:3].T, coef[3], float(np.sum(r**2))

    def split(self, x: np.ndarray, R0: np.ndarray):
        """``(δ, A, b, R_c, s)`` of the parameter vector ``x``."""
        if self.mode == "matrix":
            A = x[1:10].reshape(3, 3)
            return x[0], A, x[10:13], None, None
        Rc = so3.exp(x[1:4]) @ R0
        s = x[7:10] if self.mode == "axes" else np.ones(3)
        return x[0], s[:, None] * Rc, x[4:7], Rc, s

    def residual(self, x, R0) -> np.ndarray:
        delta, A, b, _, _ = self.split(x, R0)
        return (self.G(delta)[self.use] - self.W[self.use] @ A.T - b).ravel()

    def reduced(self, y, R0, T) -> np.ndarray:
        """The residual of the parameters ``x = T y``."""
        return self.residual(T @ y, R0)

    def reduced_jacobian(self, y, R0, T) -> np.ndarray:
        return self.jacobian(T @ y, R0) @ T

    def jacobian(self, x, R0) -> np.ndarray:
        delta, _, _, Rc, s = self.split(x, R0)
        W = self.W[self.use]
        N = W.shape[0]
        cols = [self.G(delta, derivative=True)[self.use][:, :, None]]
        if self.mode == "matrix":
            Jm = np.zeros((N, 3, 9))
            for i in range(3):
                Jm[:, i, 3 * i : 3 * i + 3] = -W
            cols.append(Jm)
        else:
            RW = W @ Rc.T
            cols.append(s[None, :, None] * so3.hat(RW))  # ∂(−S Exp(φ) R W)/∂φ = S [R W]×
        cols.append(np.broadcast_to(-np.eye(3), (N, 3, 3)))
        if self.mode == "axes":
            cols.append(-np.einsum("ij,ni->nij", np.eye(3), RW))
        return np.concatenate(cols, axis=2).reshape(3 * N, -1)


def _coarse_offset(p: _Problem, guess: float, max_offset: float | None, min_overlap: int) -> OffsetSearch:
    """Step 2 (module docstring; :func:`omegahat.clock_offset.search_offset`) on the centred rates' norms."""
    step = 1.0 / p.fa
    grid = p.t[0] + step * np.arange(math.floor((p.t[-1] - p.t[0]) / step) + 1)
    Wc = p.W - p.W[p.valid_a].mean(axis=0)

    def gyro_norms(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        ok = (u >= p.tg_range[0]) & (u <= p.tg_range[1]) & ~p.gap_g.near(u, p.margin)
        g = p.gyro(np.clip(u, *p.tg_range))
        return np.linalg.norm(g - g[ok].mean(axis=0), axis=1) if ok.any() else g[:, 0], ok

    norms = np.interp(grid, p.t, np.linalg.norm(Wc, axis=1))
    usable = ~p.gap_a.near(grid, p.margin)
    return search_offset(grid, norms, usable, gyro_norms, p.tg_range, guess, max_offset, min_overlap, p.fa / p.fc)


def _sandwich(J: np.ndarray, r: np.ndarray, block: int) -> np.ndarray:
    """(C4): ``H⁻¹ Ω H⁻¹`` with overlapping batch means of the scores over ``block`` samples."""
    p = J.shape[1]
    Jk = J.reshape(-1, 3, p)
    u = np.einsum("nip,ni->np", Jk, r.reshape(-1, 3))
    N = u.shape[0]
    B = max(1, min(block, N // 4))
    c = np.concatenate([np.zeros((1, p)), np.cumsum(u, axis=0)])
    U = c[B:] - c[:-B]
    omega = U.T @ U * (N / ((N - B + 1) * B))
    Hinv = np.linalg.inv(J.T @ J)
    return Hinv @ omega @ Hinv


def _propagate(f, x: np.ndarray, C: np.ndarray) -> np.ndarray:
    """Standard deviations of ``f(x)`` under covariance ``C`` (central differences)."""
    y0 = np.asarray(f(x), dtype=float)
    Jf = np.zeros((y0.size, x.size))
    for j in range(x.size):
        e = np.zeros(x.size)
        e[j] = 1e-6 * max(1.0, abs(x[j]))
        Jf[:, j] = (np.asarray(f(x + e)) - np.asarray(f(x - e))).ravel() / (2 * e[j])
    return np.sqrt(np.maximum(np.diag(Jf @ C @ Jf.T), 0.0))


def _check_inputs(t_attitude, attitudes, t_gyro, gyro, mode, cutoff_hz):
    if mode not in MODES:
        raise ValueError(f"scale must be one of {', '.join(MODES)}; got {mode!r}")
    log = ms.checked_log(t_attitude, attitudes)
    t_g = ms.checked_times(t_gyro, where="gyro sample {j}")
    g = np.asarray(gyro, dtype=float)
    if g.shape != (t_g.size, 3):
        raise ValueError(f"gyro must have shape ({t_g.size}, 3), one row per gyro time; got {g.shape}")
    finite = np.all(np.isfinite(g), axis=1)
    notes = []
    if not finite.all():
        notes.append(f"{int((~finite).sum())} gyro samples not finite: left out")
        t_g, g = t_g[finite], g[finite]
    n_a = int(log.valid.sum())
    if n_a < 10 or t_g.size < 10:
        raise ValueError(
            f"too few samples to calibrate: {n_a} valid attitude samples and {t_g.size} gyro samples (at least 10 "
            "each, and several seconds of varied motion)"
        )
    fa, fg = _rate(log.times[log.valid]), _rate(t_g)
    fc = min(DEFAULT_CUTOFF_HZ, 0.4 * min(fa, fg)) if cutoff_hz is None else float(cutoff_hz)
    if not 0 < fc < 0.5 * min(fa, fg):
        raise ValueError(f"cutoff_hz must be in (0, {0.5 * min(fa, fg):g}) (half the slower rate); got {cutoff_hz!r}")
    return log, t_g, g, fc, notes


def _excitation(W: np.ndarray, mode: str) -> np.ndarray:
    """The principal standard deviations of the band-limited rate ``W`` (rad/s); raises where the motion cannot
    identify what ``mode`` fits (a rotation about one axis is fitted as such, step 5 of the module docstring)."""
    if W.shape[0] < 3:  # nothing left to judge: the count of usable samples is checked (and named) next
        return np.zeros(3)
    ex = np.linalg.svd(W - W.mean(axis=0), compute_uv=False) / math.sqrt(W.shape[0])
    if ex[0] < 1e-6:
        raise ValueError(
            f"the body hardly rotates (its band-limited rate varies by {ex[0]:.2g} rad/s): nothing to calibrate against"
        )
    if mode != "none" and ex[2] < MIN_EXCITATION * ex[0]:
        what = "scale factors" if mode == "axes" else "a scale matrix"
        raise ValueError(
            f"the motion cannot identify {what}: the rate varies along its principal axes by "
            f"{np.array2string(ex, precision=3)} rad/s, and {what} needs rotation about three independent axes (the "
            f"weakest at least {MIN_EXCITATION:g} of the strongest); record rotations about three independent axes"
        )
    return ex


def _least_rotation(a: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The rotation of least angle that takes the unit vector ``a`` onto the unit vector ``u``."""
    axis, cos = np.cross(a, u), float(a @ u)
    sin = float(np.linalg.norm(axis))
    if sin < 1e-12:  # parallel: none, or half a turn about any axis perpendicular to a
        return np.eye(3) if cos > 0 else so3.exp(math.pi * np.linalg.svd(a[None])[2][1])
    return so3.exp(axis / sin * math.atan2(sin, cos))


def _without_turn_about(u: np.ndarray) -> np.ndarray:
    """``T (7, 6)``: the parameters ``x = (δ, φ, b)`` of a rotation fit as ``T y``, ``φ`` perpendicular to ``u``
    (step 5: a turn about ``u``, the body's axis in gyro axes, moves no residual)."""
    T = np.zeros((7, 6))
    T[0, 0], T[4:, 3:] = 1.0, np.eye(3)
    T[1:4, 1:3] = np.linalg.svd(u[None])[2][1:].T  # an orthonormal basis of the plane perpendicular to u
    return T


def _prepare(t_attitude, attitudes, t_gyro, gyro, mode, cutoff_hz):
    """The checked inputs as a :class:`_Problem` on times relative to the first attitude sample (well-conditioned
    splines and filters), that origin, the logs' spans in words, and notes."""
    log, t_g, g, fc, notes = _check_inputs(t_attitude, attitudes, t_gyro, gyro, mode, cutoff_hz)
    origin = float(log.times[0])
    t_a, t_g = log.times - origin, t_g - origin
    span = (
        f"attitude t = {log.times[0]:.6g}..{log.times[-1]:.6g} s, gyro t = {t_g[0] + origin:.6g}.."
        f"{t_g[-1] + origin:.6g} s"
    )
    return _Problem(mode, t_a, spline_rate(t_a, log.values), log.valid, t_g, g, fc), origin, span, notes


def band_limited(
    cal: Calibration, t_attitude: ArrayLike, attitudes: ArrayLike, t_gyro: ArrayLike, gyro: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What ``cal`` was fitted on, for a residual plot: the attitude's times ``t (N,)`` (as given), the band-limited
    gyroscope ``F g(t + δ)`` and the model ``A F ω(t) + b`` ``(N, 3)``, and the samples used by the fit ``(N,)``."""
    p, origin, _, _ = _prepare(t_attitude, attitudes, t_gyro, gyro, cal.mode, cal.cutoff_hz)
    used = p.usable(cal.offset, 0.0)
    return p.t + origin, p.G(cal.offset), p.W @ cal.matrix.T + cal.bias, used


def calibrate(
    t_attitude: ArrayLike,
    attitudes: ArrayLike,
    t_gyro: ArrayLike,
    gyro: ArrayLike,
    scale: str = "none",
    cutoff_hz: float | None = None,
    offset_guess: float = 0.0,
    max_offset: float | None = None,
) -> Calibration:
    """Fit (C1) (module docstring). ``attitudes``: rotation matrices ``(T, 3, 3)`` or quaternions ``(T, 4)`` scalar
    last, body → inertial, NaN rows missing; ``gyro (M, 3)`` at ``t_gyro`` (its own clock, s). ``scale``: ``"none"``,
    ``"axes"`` or ``"matrix"``; the offset is searched at every lag at which the logs overlap, within
    ``offset_guess ± max_offset`` s where ``max_offset`` is given. Raises ``ValueError`` saying why when the search
    is ill-posed (:func:`check_search`, first), the logs do not overlap, hold too few samples, or the motion cannot
    identify the parameters."""
    check_search(offset_guess, max_offset)
    p, _, span, notes = _prepare(t_attitude, attitudes, t_gyro, gyro, scale, cutoff_hz)
    fc = p.fc
    n_params = {"none": 7, "axes": 10, "matrix": 13}[scale]
    block = max(1, math.ceil(_BLOCK_PERIODS * p.fa / fc))
    n_min = max(20 * n_params, 10 * block)
    n_valid = int(p.valid_a.sum())
    if n_valid < n_min:
        raise ValueError(
            f"too few samples to calibrate: {n_valid} valid attitude samples ({span}); at least {n_min} are needed "
            f"(the uncertainties need {_BLOCK_PERIODS * 10:g} periods of the {fc:.3g} Hz band)"
        )
    t = p.t
    _excitation(p.W[p.valid_a & ~p.gap_a.near(t, p.margin) & (t > t[0] + p.margin) & (t < t[-1] - p.margin)], scale)
    search = _coarse_offset(p, offset_guess, max_offset, n_min // 2)
    delta = search.offset
    where = (
        "at any clock offset"
        if max_offset is None
        else f"at any clock offset within {offset_guess:g} ± {max_offset:g} s"
    )
    if not math.isfinite(delta):
        raise ValueError(
            f"the logs do not overlap in time {where} by enough samples ({span}; at least {n_min // 2} needed)"
            + (
                ""
                if max_offset is None
                else ": give a better guess of the offset (gyro time - attitude time) or a wider search"
            )
        )
    if search.likeness >= AMBIGUOUS_OFFSET:  # a motion that repeats itself: say so, the fit below cannot tell
        notes.append(
            f"the motion repeats itself: a clock offset of {search.runner_up:+.4g} s matches the rates' norms nearly "
            f"as well ({search.likeness:.2f} of the correlation at the {delta:+.4g} s chosen); where the clocks are "
            "known to be closer, narrow the search (offset_guess and max_offset; --offset and --max-offset on the "
            "command line)"
        )
    if search.at_bound:  # the best lag is the search's last: it may lie beyond
        notes.append(
            f"the clock offset found, {delta:+.4g} s, is at the edge of the search ({offset_guess:g} ± {max_offset:g} "
            "s): the clocks may be further apart; widen the search (max_offset; --max-offset on the command line)"
        )
    h = 1.0 / p.fa
    p.rebase(delta)  # from here on δ is counted from the coarse offset
    p.use = p.usable(0.0, 2.5 * h)
    if p.use.sum() < n_min:
        raise ValueError(
            f"too few samples to calibrate: {int(p.use.sum())} attitude samples overlap the gyro log away from gaps "
            f"and ends at the offset found ({delta:+.4g} s; {span}); at least {n_min} are needed"
        )
    excitation = _excitation(p.W[p.use], scale)
    fine = h * np.linspace(-1.5, 1.5, 31)
    delta = float(fine[int(np.argmin([p.linear_fit(d)[2] for d in fine]))])
    A, b, _ = p.linear_fit(delta)
    Gc, Wc = p.G(delta)[p.use], p.W[p.use]
    R0 = so3.project((Gc - Gc.mean(axis=0)).T @ (Wc - Wc.mean(axis=0)))
    one_axis = scale == "none" and excitation[1] < MIN_EXCITATION * excitation[0]  # step 5
    axis = np.linalg.svd(Wc - Wc.mean(axis=0), full_matrices=False)[2][0]  # the body axis the rate varies along most
    axis *= np.sign(axis[np.argmax(np.abs(axis))])  # its sign: the largest component positive
    if one_axis:
        R0 = _least_rotation(axis, R0 @ axis)
    if scale == "matrix":
        x = np.concatenate([[delta], A.ravel(), b])
    else:
        RW = Wc @ R0.T
        s = np.ones(3)
        if scale == "axes":
            RWc, Gcc = RW - RW.mean(axis=0), Gc - Gc.mean(axis=0)
            s = np.sum(RWc * Gcc, axis=0) / np.sum(RWc**2, axis=0)
        b = Gc.mean(axis=0) - s * RW.mean(axis=0)
        x = np.concatenate([[delta], np.zeros(3), b] + ([s] if scale == "axes" else []))
    lo, hi = np.full(x.size, -np.inf), np.full(x.size, np.inf)
    lo[0], hi[0] = x[0] - 2 * h, x[0] + 2 * h
    T = np.eye(x.size)  # x = T y: every parameter free, or (step 5) no turn about the body's axis in the gyro's
    for _ in range(4):  # solve, then re-centre the rotation (φ = 0): the Jacobian is exact there
        if one_axis:
            T = _without_turn_about(R0 @ axis)
        bounds = (lo[: T.shape[1]], hi[: T.shape[1]])  # y₀ = δ, the one bounded parameter
        x = T @ least_squares(p.reduced, T.T @ x, p.reduced_jacobian, bounds, args=(R0, T), x_scale="jac").x
        if scale == "matrix":
            break
        turn = float(np.linalg.norm(x[1:4]))
        R0, x[1:4] = so3.exp(x[1:4]) @ R0, 0.0
        if one_axis:  # the turn about the axis is the data's to leave: the least rotation's, by convention
            R0 = _least_rotation(axis, R0 @ axis)
        if turn < 1e-9:
            break
    if one_axis:
        T = _without_turn_about(R0 @ axis)
    r = p.residual(x, R0)
    C = T @ _sandwich(p.jacobian(x, R0) @ T, r, block) @ T.T
    std = np.sqrt(np.diag(C))
    delta, A, b, Rc, s = p.split(x, R0)
    delta += p.base
    res_rms = np.sqrt(np.mean(r.reshape(-1, 3) ** 2, axis=0))
    notes.extend(_unexplained(p.G(delta - p.base)[p.use], r.reshape(-1, 3), scale))
    if scale == "matrix":
        names = ("offset", *(f"A{i + 1}{j + 1}" for i in range(3) for j in range(3)), "bx", "by", "bz")
        Rc = _orth(A)
        if np.linalg.det(A) < 0:
            notes.append("the matrix mirrors an axis (det < 0): 'rotation' is its nearest orthogonal matrix")
        rot_std = _propagate(lambda y: so3.log(_orth(y[1:10].reshape(3, 3)) @ Rc.T), x, C)
        s = np.linalg.norm(A, axis=1)
        s_std = _propagate(lambda y: np.linalg.norm(y[1:10].reshape(3, 3), axis=1), x, C)
        return Calibration(
            scale, delta, std[0], A, Rc, rot_std, b, std[10:13], s, s_std, std[1:10].reshape(3, 3), res_rms,
            int(p.use.sum()), fc, (p.fa, p.fg), excitation, C, names, tuple(notes),
        )  # fmt: skip
    names = ("offset", "phix", "phiy", "phiz", "bx", "by", "bz") + (("sx", "sy", "sz") if scale == "axes" else ())
    free = Rc @ axis if one_axis else None
    if free is not None:
        notes.append(
            f"the body turned about one axis only (body {np.array2string(axis, precision=3, suppress_small=True)}, "
            f"gyro {np.array2string(free, precision=3, suppress_small=True)}; the rate varies by "
            f"{np.array2string(excitation, precision=3)} rad/s along its principal axes): the rotation about it is not "
            "identified, and 'rotation' is the least one that takes the body's axis onto the gyroscope's (free_axis). "
            "Rates about that axis, the offset and the bias are calibrated; rates about other axes are not: record "
            "turns about a second axis for them"
        )
    return Calibration(
        scale, delta, std[0], A, Rc, std[1:4], b, std[4:7], s, std[7:10] if scale == "axes" else None, None,
        res_rms, int(p.use.sum()), fc, (p.fa, p.fg), excitation, C, names, tuple(notes), free,
    )  # fmt: skip


def _unexplained(G: np.ndarray, residual: np.ndarray, scale: str) -> list[str]:
    """A note where the residual's RMS (less its mean) is more than :data:`UNEXPLAINED` of the band-limited gyro's
    ``G``; with no scale fitted, a gyro reading 180/π (or π/180) times the attitude's rate (±10 %) names the unit."""
    rms = lambda x: float(np.sqrt(np.mean(np.sum((x - x.mean(axis=0)) ** 2, axis=1))))  # noqa: E731
    left, ratio = rms(residual) / max(rms(G), 1e-300), rms(G) / max(rms(G - residual), 1e-300)
    if left <= UNEXPLAINED:
        return []
    units = {180.0 / math.pi: "degrees per second given as radians", math.pi / 180.0: "radians given as degrees"}
    hint = next((f": it reads {ratio:.3g} times the attitude's rate, {u}" for f, u in units.items()
                 if scale == "none" and abs(ratio / f - 1) < 0.1), "")  # fmt: skip
    return [f"the fit's residual is {left:.2g} times the gyroscope's rate in band (RMS){hint}; check its unit "
            "(--gyro-unit), that the clocks' offset is within the search (--offset, --max-offset), and that both logs "
            "are of one body"]  # fmt: skip


def _orth(M: np.ndarray) -> np.ndarray:
    """The orthogonal polar factor of ``M`` (a rotation when det M > 0)."""
    U, _, Vt = np.linalg.svd(M)
    return U @ Vt
