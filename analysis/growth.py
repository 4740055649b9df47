"""Curves of growth-to-jamming runs: the jump of ``<C>(phi)`` and rate independence.

Wouterse, Luding & Philipse (Sec. 3.1) grow particles at several rates and record, per
frame, the mean contact number ``<C>`` (rattlers included) and the fraction of non-caged
particles against the packing fraction ``phi`` (Figs. 2, 6). Two readings of those
curves, made exact here:

* rods: ``<C>`` rises sharply "from about three up to a value between 9 and 10" near
  jamming; :func:`jump_onset` finds where that rise starts and the ``<C>`` there
  (``c_mean_before_jump``);
* several rates: the curves agree above some ``phi`` (spheres: ``<C>`` near 0.60, the
  non-caged fraction near 0.61; ``alpha = 1.5``: the non-caged fraction above 0.68);
  :func:`phi_rate_independent` finds it.

The frames of a growing packing are those of the growth itself and the final, jammed
packing (:func:`growing_frames`); the relaxed unjammed packings of the bisection have
lost their contacts to the relaxation and are no point of these curves.
"""
from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

#: :func:`jump_onset`: a rise of ``<C>`` smaller than this is no jump (contacts)
MIN_RISE = 2.0
#: :func:`jump_onset`: width in ``phi`` of the stretch below the rise that gives the base
BASE_WIDTH = 0.02
#: :func:`jump_onset`: frames are grouped about this wide in ``phi`` (about the point
#: spacing of the paper's Fig. 2; a slow growth dumps frames much closer)
BIN_WIDTH = 0.004
#: :func:`phi_rate_independent`: curves agree within this many combined noise levels
NOISE_MULTIPLE = 3.0


def growing_frames(curves: pd.DataFrame) -> pd.DataFrame:
    """The frames of a growing packing, sorted by ``phi``: every frame of the growth
    (``relaxed`` false) and the jammed relaxed packing at ``phi_J`` (the lowest jammed
    one), the paper's final, mechanically stable point. Curves without the ``relaxed``
    and ``jammed`` flags of :func:`analysis.summary.analyse_growth` are taken whole."""
    if not {"relaxed", "jammed"} <= set(curves.columns):
        return curves.sort_values("phi", kind="stable").reset_index(drop=True)
    keep = ~curves["relaxed"].astype(bool)
    jam = curves[curves["jammed"].astype(bool)]
    if len(jam):
        keep |= curves["step"] == jam.loc[jam["phi"].idxmin(), "step"]
    return curves[keep].sort_values("phi", kind="stable").reset_index(drop=True)


def _ordered(phi, y) -> tuple[np.ndarray, np.ndarray]:
    """Finite points sorted by ``phi``; repeated ``phi`` averaged."""
    phi = np.asarray(phi, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    ok = np.isfinite(phi) & np.isfinite(y)
    u, inv = np.unique(phi[ok], return_inverse=True)
    return u, np.bincount(inv, weights=y[ok]) / np.bincount(inv)


def _median3(y: np.ndarray) -> np.ndarray:
    """Running median over three neighbouring frames (ends: the end value repeated):
    removes single-frame spikes, keeps steps and monotonic stretches as they are."""
    return median_filter(y, size=3, mode="nearest") if len(y) >= 3 else y.copy()


def _binned(x: np.ndarray, y: np.ndarray, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Frames in bins of ``k`` median frame spacings ``dx`` in ``phi`` (``k`` the nearest
    integer to ``width / dx``; ``k <= 1``: as they are): mean ``phi`` and median value of
    each bin. Bin edges sit half a spacing off the frames, so evenly spaced frames fill
    every bin with ``k``; a frame far from the others (the jammed end) keeps its own."""
    if len(x) < 2 or not width > 0:
        return x, y
    dx = float(np.median(np.diff(x)))
    k = int(round(width / dx))
    if k <= 1:
        return x, y
    label = np.floor(((x - x[0]) / dx + 0.5) / k).astype(np.int64)
    _u, start, count = np.unique(label, return_index=True, return_counts=True)
    xb = np.add.reduceat(x, start) / count
    yb = np.array([np.median(y[s:s + n]) for s, n in zip(start, count)])
    return xb, yb


def jump_onset(phi, c, min_rise: float = MIN_RISE, base_width: float = BASE_WIDTH,
               bin_width: float = BIN_WIDTH) -> tuple[float, float]:
    """``(phi_before, c_before)``: where the sharp rise of ``<C>(phi)`` towards its
    final value starts and the mean contact number there (``c_mean_before_jump``),
    from one run's growing frames; the onset construction of a step in a noisy curve:

    1. frames sorted by ``phi``, in bins about ``bin_width`` wide (median ``<C>``:
       dense frames average their noise), smoothed by a running median of three bins (a
       spike in one frame away from the rise is gone, a step kept as it is);
    2. the rise: the interval of steepest slope ``s_max`` among those that end in the
       upper half of the curve's range (the rise towards the final value, not a
       transient at the start of the growth), extended both ways over the neighbouring
       intervals at least half as steep, from point ``a`` to point ``b``; no jump (NaN)
       when ``<C>`` grows there by less than ``min_rise`` contacts (spheres: ``<C>``
       grows steadily, without a jump; the rods' jump is 6 to 7);
    3. the base: the least-squares line through the points within ``base_width`` below
       ``a`` (at least the two below it; the first point alone, as a constant, when the
       rise starts there); the onset: where the tangent of slope ``s_max`` through the
       middle of the steepest interval meets it (kept between ``base_width`` below
       ``a`` and that middle: a base no steeper than the rise is not extrapolated far);
    4. when the rise spans several intervals, again with the base ending as far below
       that onset as the onset lies below the middle of the steepest interval (at most
       ``base_width`` below ``a``): a smooth rise has left the base before point ``a``,
       and this keeps its foot out of the base line;
    5. ``c_before`` is the base line at the onset.

    A steepest interval across a gap of the frames (more than twice their median
    spacing: the growth's last frame and the jammed packing, when the growth stopped
    below the jump) is a step between two points: the onset is its lower point and
    ``c_before`` the least-squares line through the points within ``base_width`` up to
    it, there (however steep that base: it is not compared with the step).

    The value lies on the base, not on the rise, so the steepness of the rise (the
    paper: slower growth, a less steep rise) enters only through where the onset falls
    on the base. On a base of slope 30 per unit ``phi`` and a logistic rise of 6.5
    contacts and width ``w`` centred at ``phi_0`` (``tests/analysis/test_growth.py``,
    noise 0.02 to 0.05 per frame) it reads the base at ``phi_0 - 2 w`` within 0.2 for
    ``w <= 0.003`` (a rise over 0.015 in ``phi`` or less); a wider rise has no sharp
    foot and the value lies higher up the base: at ``w = 0.01`` by 0.3 to 0.7 from frames
    every 0.001, and by up to about 1.2 from noisier frames every 0.004.
    NaN, NaN without a jump or with fewer than three points.
    """
    x, y = _binned(*_ordered(phi, c), bin_width)
    nan = (float("nan"), float("nan"))
    if len(x) < 3:
        return nan
    ys = _median3(y)
    slope = np.diff(ys) / np.diff(x)
    upper = ys[1:] >= 0.5 * (ys.min() + ys.max())
    k = int(np.argmax(np.where(upper, slope, -np.inf)))
    s_max = slope[k]
    if not s_max > 0:
        return nan
    a, b = k, k + 1
    gap = x[k + 1] - x[k] > 2.0 * np.median(np.diff(x))
    if gap:
        # a step across a gap of the frames (the growth's end and the jammed packing):
        # the base read where it ends, however steep it is
        if ys[b] - ys[a] < min_rise:
            return nan
        idx = np.flatnonzero(x[:k + 1] >= x[k] - base_width)
        if len(idx) >= 2:
            b1, b0 = np.polyfit(x[idx], ys[idx], 1)
            return float(x[k]), float(b0 + b1 * x[k])
        return float(x[k]), float(ys[k])
    while a > 0 and slope[a - 1] >= 0.5 * s_max:
        a -= 1
    while b < len(slope) and slope[b] >= 0.5 * s_max:
        b += 1
    if ys[b] - ys[a] < min_rise:
        return nan
    xm, ym = 0.5 * (x[k] + x[k + 1]), 0.5 * (ys[k] + ys[k + 1])

    def onset_below(end: float) -> tuple[float, float]:
        idx = np.flatnonzero((x >= end - base_width) & (x < end))
        if len(idx) < 2:
            idx = np.flatnonzero(x < end)[-2:]
        if len(idx) >= 2:
            b1, b0 = np.polyfit(x[idx], ys[idx], 1)
        else:
            b1, b0 = 0.0, float(ys[idx[0]] if len(idx) else ys[0])
        if not s_max > b1:
            return nan
        on = float(np.clip((b0 - ym + s_max * xm) / (s_max - b1), lowest, xm))
        return on, float(b0 + b1 * on)

    lowest = max(x[0], x[a] - base_width)
    first, c_first = onset_below(x[a])
    if not np.isfinite(first) or a == k:  # a rise of one interval has no foot
        return first, c_first
    return onset_below(max(first - (xm - first), lowest))


def noise_level(phi, y) -> float:
    """Frame-to-frame noise ``sigma`` of a curve: from the second differences
    ``y_{k-1} - 2 y_k + y_{k+1}`` (variance ``6 sigma^2`` for independent noise; a
    smooth trend adds its curvature, negligible at the frame spacing of a growth run),
    by their median absolute deviation (``1.4826 MAD``, robust to the few frames of a
    jump). Triplets of equal values (a fraction pinned at 0 or 1) carry no noise and are
    left out; 0 when nothing else is left, NaN with fewer than three frames."""
    _x, v = _ordered(phi, y)
    if len(v) < 3:
        return float("nan")
    d2 = v[:-2] - 2.0 * v[1:-1] + v[2:]
    moving = ~((v[:-2] == v[1:-1]) & (v[1:-1] == v[2:]))
    d2 = d2[moving]
    if not len(d2):
        return 0.0
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(1.4826 * mad / np.sqrt(6.0))


def phi_rate_independent(curves, column: str, tol: float | None = None,
                         multiple: float = NOISE_MULTIPLE, dphi: float | None = None) -> float:
    """The packing fraction above which the curves ``column(phi)`` of runs at different
    growth rates agree (``phi_c_rate_independent`` with ``column = "z"``,
    ``phi_noncaged_rate_independent`` with ``"noncaged_fraction"``; Figs. 2a, 6a, 6b).

    ``curves``: one DataFrame per run (with ``phi`` and ``column``; pass the growing
    frames, :func:`growing_frames`). Rule:

    1. each curve sorted by ``phi``, smoothed by a running median of three frames;
    2. interpolated linearly onto a grid of step ``dphi`` (default: the coarsest run's
       median frame spacing) over the range every run covers;
    3. two runs agree at a grid point when they differ by at most ``tol``; by default
       ``multiple`` (3) times the noise of a difference of two runs, ``sqrt(2) sigma``,
       with ``sigma`` the frame-to-frame noise (:func:`noise_level` of the raw frames)
       pooled over the runs (root mean square: runs of one system at different rates
       are equally noisy, and one run's estimate from some 50 frames can be 40 % low).
       Two noisy samples of the same curve then differ by more in 0.3 % of single
       frames, and the median of three makes such a frame rarer still (its noise is
       about 0.7 ``sigma``), while a real difference of a few noise levels is kept;
    4. the answer is the lowest grid point from which on every pair agrees up to the
       end of the common range.

    NaN when the runs share no range or disagree at its top; the low end of the range
    when they agree throughout (then a bound: the runs agree wherever they overlap).
    Needs at least two runs and, without ``tol``, at least three frames per run.
    """
    if len(curves) < 2:
        raise ValueError(f"need curves of at least two runs to compare, got {len(curves)}")
    pts = []
    for k, cv in enumerate(curves):
        missing = {"phi", column} - set(cv.columns)
        if missing:
            raise ValueError(f"curve {k} lacks the column(s) {sorted(missing)}")
        x, y = _ordered(cv["phi"], cv[column])
        if len(x) < 2:
            raise ValueError(f"curve {k} has {len(x)} finite frame(s) of {column!r}; need 2 "
                             "or more")
        pts.append((x, y))
    lo = max(x[0] for x, _ in pts)
    hi = min(x[-1] for x, _ in pts)
    if not hi > lo:
        return float("nan")
    if dphi is None:
        dphi = max(float(np.median(np.diff(x))) for x, _ in pts)
    if not dphi > 0:
        raise ValueError(f"dphi must be > 0, got {dphi}")
    grid = np.linspace(lo, hi, max(int(np.ceil((hi - lo) / dphi)) + 1, 2))
    values = [np.interp(grid, x, _median3(y)) for x, y in pts]
    if tol is None:
        sigma = np.array([noise_level(x, y) for x, y in pts])
        if not np.all(np.isfinite(sigma)):
            raise ValueError("every curve needs three frames or more for its noise level; "
                             "or pass tol")
        tol = multiple * float(np.sqrt(2.0 * np.mean(sigma**2)))
    agree = np.ones(len(grid), bool)
    for a, b in combinations(range(len(pts)), 2):
        agree &= np.abs(values[a] - values[b]) <= tol
    if not agree[-1]:
        return float("nan")
    bad = np.flatnonzero(~agree)
    return float(grid[bad[-1] + 1] if len(bad) else grid[0])
