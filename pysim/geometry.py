"""Closest points of two spines (segments): the contact geometry of spherocylinders.

A spherocylinder is the set of points within ``R`` of its spine, the segment
``c + s u`` with ``s`` in ``[-h, h]`` (``u`` unit, half-length ``h = L/2``); a sphere has
``h = 0``. Two spherocylinders overlap when the shortest distance ``d`` between their
spines is below ``R_a + R_b`` (science.md section 2).

:func:`segment_closest` minimises ``|c_a + s u_a - c_b - t u_b|^2`` over the box
``[-h_a, h_a] x [-h_b, h_b]`` by clamping. When the spines are parallel (to a
tolerance) every point of the overlap of their projections is closest; the centre of
that overlap is returned, so that a side-by-side contact acts at the middle.
"""
from __future__ import annotations

import numpy as np

from pysim.jit import inline_njit, njit

#: |u_a x u_b|^2 below which two spines are treated as parallel
PARALLEL_TOL = 1e-10


@njit
def _clamp(v, lo, hi):
    if v < lo:
        return lo
    if v > hi:
        return hi
    return v


@inline_njit
def _clamped_pairs(s, t, b, d, e, ha, hb):
    """The two candidates of a clamped closest-point problem: ``s`` clamped, ``t``
    solved for it and clamped, ``s`` solved again; and the same from ``t`` clamped."""
    s1 = _clamp(s, -ha, ha)
    t1 = _clamp(b * s1 + e, -hb, hb)
    s1 = _clamp(b * t1 - d, -ha, ha)
    t2 = _clamp(t, -hb, hb)
    s2 = _clamp(b * t2 - d, -ha, ha)
    t2 = _clamp(b * s2 + e, -hb, hb)
    return s1, t1, s2, t2


@njit
def closest_params(r0, r1, r2, ua0, ua1, ua2, ha, ub0, ub1, ub2, hb):
    """Scalar core of :func:`segment_closest`: ``r = c_a - c_b`` and the directions as
    components (no arrays, so the contact loop allocates nothing)."""
    if ha == 0.0 and hb == 0.0:
        return 0.0, 0.0
    b = ua0 * ub0 + ua1 * ub1 + ua2 * ub2  # u_a . u_b
    d = ua0 * r0 + ua1 * r1 + ua2 * r2  # u_a . r
    e = ub0 * r0 + ub1 * r1 + ub2 * r2  # u_b . r
    if ha == 0.0:
        return 0.0, _clamp(e, -hb, hb)
    if hb == 0.0:
        return _clamp(-d, -ha, ha), 0.0
    denom = 1.0 - b * b
    if denom < PARALLEL_TOL:
        # parallel: b's spine projects onto a's axis at s = -d + t sgn, t in [-hb, hb]
        sgn = 1.0 if b >= 0.0 else -1.0
        lo = max(-ha, -hb - d)
        hi = min(ha, hb - d)
        if lo <= hi:
            s = 0.5 * (lo + hi)
        elif -hb - d > ha:
            s = ha
        else:
            s = -ha
        return s, _clamp(sgn * (s + d), -hb, hb)
    # unconstrained minimum of |r + s u_a - t u_b|^2
    s = (b * e - d) / denom
    t = (e - b * d) / denom
    if -ha <= s <= ha and -hb <= t <= hb:
        return s, t
    # clamp s and re-solve t (then s); clamp t and re-solve s (then t); keep the better
    s1, t1, s2, t2 = _clamped_pairs(s, t, b, d, e, ha, hb)
    q1 = _dist2s(r0, r1, r2, ua0, ua1, ua2, ub0, ub1, ub2, s1, t1)
    q2 = _dist2s(r0, r1, r2, ua0, ua1, ua2, ub0, ub1, ub2, s2, t2)
    if q1 <= q2:
        return s1, t1
    return s2, t2


@inline_njit
def closest_select(r0, r1, r2, ua0, ua1, ua2, ha, ub0, ub1, ub2, hb):
    """:func:`closest_params` without branches on the pair: every path is computed and the
    one :func:`closest_params` takes is selected (the same values, the same bits; the
    paths not taken may give inf or NaN), so that a loop over pairs can run on SIMD
    lanes (:func:`pysim.contacts.rod_pass`)."""
    b = ua0 * ub0 + ua1 * ub1 + ua2 * ub2
    d = ua0 * r0 + ua1 * r1 + ua2 * r2
    e = ub0 * r0 + ub1 * r1 + ub2 * r2
    t_sphere_a = _clamp(e, -hb, hb)  # spine a a point
    s_sphere_b = _clamp(-d, -ha, ha)  # spine b a point
    denom = 1.0 - b * b
    # parallel spines
    sgn = 1.0 if b >= 0.0 else -1.0
    lo = max(-ha, -hb - d)
    hi = min(ha, hb - d)
    s_par = 0.5 * (lo + hi) if lo <= hi else (ha if -hb - d > ha else -ha)
    t_par = _clamp(sgn * (s_par + d), -hb, hb)
    # the unconstrained minimum, else the better of the two clamped solutions (divided by
    # 1 where the spines are parallel and this path is not taken: no division by zero)
    q = denom if denom >= PARALLEL_TOL else 1.0
    s = (b * e - d) / q
    t = (e - b * d) / q
    inside = (-ha <= s) & (s <= ha) & (-hb <= t) & (t <= hb)
    s1, t1, s2, t2 = _clamped_pairs(s, t, b, d, e, ha, hb)
    first = (_dist2s(r0, r1, r2, ua0, ua1, ua2, ub0, ub1, ub2, s1, t1)
             <= _dist2s(r0, r1, r2, ua0, ua1, ua2, ub0, ub1, ub2, s2, t2))
    s_out = s if inside else (s1 if first else s2)
    t_out = t if inside else (t1 if first else t2)
    parallel = denom < PARALLEL_TOL
    s_out = s_par if parallel else s_out
    t_out = t_par if parallel else t_out
    s_out = s_sphere_b if hb == 0.0 else s_out
    t_out = 0.0 if hb == 0.0 else t_out
    s_out = 0.0 if ha == 0.0 else s_out
    t_out = t_sphere_a if ha == 0.0 else t_out
    points = (ha == 0.0) & (hb == 0.0)
    return (0.0 if points else s_out), (0.0 if points else t_out)


@njit
def _dist2s(r0, r1, r2, ua0, ua1, ua2, ub0, ub1, ub2, s, t):
    x = r0 + s * ua0 - t * ub0
    y = r1 + s * ua1 - t * ub1
    z = r2 + s * ua2 - t * ub2
    return x * x + y * y + z * z


@njit
def segment_closest(ca, ua, ha, cb, ub, hb):
    """Parameters ``(s, t)`` of the closest points ``c_a + s u_a`` and ``c_b + t u_b``.

    ``ca``, ``cb`` (3,) centres (``cb`` already the minimum image), ``ua``, ``ub`` (3,)
    unit directions, ``ha``, ``hb`` >= 0 half-lengths. Minimises
    ``|r + s u_a - t u_b|^2`` with ``r = c_a - c_b``: the unconstrained solution of the
    normal equations, else clamping one parameter and re-solving for the other (exact
    for a convex quadratic on a box). Parallel spines: centre of the overlap of the
    projections (or the nearest ends when the projections do not overlap).
    """
    return closest_params(ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2], ua[0], ua[1], ua[2],
                          ha, ub[0], ub[1], ub[2], hb)


@njit
def _dist2(r0, r1, r2, ua, ub, s, t):
    x = r0 + s * ua[0] - t * ub[0]
    y = r1 + s * ua[1] - t * ub[1]
    z = r2 + s * ua[2] - t * ub[2]
    return x * x + y * y + z * z


@njit
def segment_distance(ca, ua, ha, cb, ub, hb):
    """Shortest distance between two spines (length units)."""
    s, t = segment_closest(ca, ua, ha, cb, ub, hb)
    return np.sqrt(_dist2(ca[0] - cb[0], ca[1] - cb[1], ca[2] - cb[2], ua, ub, s, t))


@njit
def segment_closest_many(ca, ua, ha, cb, ub, hb):
    """:func:`segment_closest` over arrays of pairs: ``ca``, ``ua``, ``cb``, ``ub``
    (M, 3), ``ha``, ``hb`` (M,). Returns ``(s, t)`` arrays (M,)."""
    m = ca.shape[0]
    s = np.empty(m)
    t = np.empty(m)
    for k in range(m):
        s[k], t[k] = segment_closest(ca[k], ua[k], ha[k], cb[k], ub[k], hb[k])
    return s, t


def segment_distance_bruteforce(ca, ua, ha, cb, ub, hb, samples=2001):
    """Slow reference: minimum over a dense grid of both parameters (tests only)."""
    s = np.linspace(-ha, ha, samples if ha > 0 else 1)
    t = np.linspace(-hb, hb, samples if hb > 0 else 1)
    pa = ca[None, :] + s[:, None] * ua[None, :]
    pb = cb[None, :] + t[:, None] * ub[None, :]
    best = np.inf
    for k in range(0, len(pa), 256):
        d = pa[k:k + 256, None, :] - pb[None, :, :]
        best = min(best, float(np.sqrt(np.min(np.sum(d * d, axis=2)))))
    return best
