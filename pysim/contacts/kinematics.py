"""Pair kinematics: the minimum image of a separation and the contact points of two
spines, as scalars in and out.

Geometry (science.md section 2): closest points ``p_i = x_i + s u_i`` and
``p_j = x_j + t u_j`` of the spines (:func:`pysim.geometry.closest_params`), distance
``d = |p_j - p_i|``, overlap ``delta = R_i + R_j - d``, normal ``n = (p_j - p_i)/d``,
contact point in the middle of the overlap ``c = p_i + (R_i - delta/2) n``. With
``spine_contact = "end_bonds"`` (:func:`end_bond`) a rod pair is up to
four bonds, each a contact of the same law; with ``"end_bonds_distinct"`` a bond that
joins the same two points as another (:func:`repeats_bond`) counts once.
"""
from __future__ import annotations

import numpy as np

from pysim.geometry import closest_params
from pysim.jit import inline_njit, njit


@njit
def min_image(d0, d1, d2, b0, b1, b2, p0, p1, p2):
    """Minimum image of the separation ``(d0, d1, d2)`` in a box ``b`` periodic along
    the axes where ``p`` is True."""
    if p0:
        d0 -= b0 * np.floor(d0 / b0 + 0.5)
    if p1:
        d1 -= b1 * np.floor(d1 / b1 + 0.5)
    if p2:
        d2 -= b2 * np.floor(d2 / b2 + 0.5)
    return d0, d1, d2


@njit
def spine_gap(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj):
    """Closest points of two spines, ``d = x_j - x_i``: returns ``a = p_i - x_i`` (3) and
    the gap ``g = p_j - p_i`` (3) (science.md section 2)."""
    s, t = closest_params(-d0, -d1, -d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj)
    a0 = s * ui0
    a1 = s * ui1
    a2 = s * ui2
    return a0, a1, a2, d0 + t * uj0 - a0, d1 + t * uj1 - a1, d2 + t * uj2 - a2


@njit
def end_bond_st(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k):
    """Spine parameters ``(s, t)`` of bond ``k`` of the end-bond geometry (:func:`end_bond`),
    ``d = x_j - x_i``: ``k = 0, 1`` the end ``s = -h_i, +h_i`` of spine i and
    ``t = clamp(u_j . (s u_i - d))``, ``k = 2, 3`` the end ``t = -h_j, +h_j`` of spine j
    and ``s = clamp(u_i . (d + t u_j))``."""
    if k < 2:
        s = -hi if k == 0 else hi
        t = uj0 * (s * ui0 - d0) + uj1 * (s * ui1 - d1) + uj2 * (s * ui2 - d2)
        t = min(max(t, -hj), hj)
    else:
        t = -hj if k == 2 else hj
        s = ui0 * (d0 + t * uj0) + ui1 * (d1 + t * uj1) + ui2 * (d2 + t * uj2)
        s = min(max(s, -hi), hi)
    return s, t


@njit
def end_bond(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k):
    """Bond ``k`` of the end-bond geometry, ``d = x_j - x_i``: ``k = 0, 1`` the end
    ``s = -h_i, +h_i`` of spine i against the closest point of spine j, ``k = 2, 3`` the
    end ``t = -h_j, +h_j`` of spine j against spine i (:func:`end_bond_st`). Returns
    ``a = p_i - x_i`` and the gap ``g = p_j - p_i`` as :func:`spine_gap`.

    Summing the contact law over the four bonds gives an energy that is smooth where the
    closest-point law has a kink (parallel side contacts: the closest point jumps from one
    end of the overlap to the other); a parallel side contact becomes two bonds at the
    ends of the overlapping projection (science.md's two-bond count), a tip-side contact
    one bond, a tip-tip contact two coincident ones (one with :func:`repeats_bond`). In
    2-D the spines of a small overlap never cross, so the closest points are always among
    these bonds."""
    s, t = end_bond_st(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k)
    a0 = s * ui0
    a1 = s * ui1
    a2 = s * ui2
    return a0, a1, a2, d0 + t * uj0 - a0, d1 + t * uj1 - a1, d2 + t * uj2 - a2


@njit
def repeats_bond(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k):
    """Whether end bond ``k`` joins the same two spine points as a bond ``m < k``
    (:func:`end_bond_st`): an end of spine i against an end of spine j, found once from
    each side (a tip-tip contact), or the two ends of a spine of length zero. With
    ``spine_contact = "end_bonds_distinct"`` such a bond is left out, so that a tip-tip
    contact is one bond, as Marschall & Teitel's (2018) law has it. Clamped parameters
    are exact, so the comparison is exact."""
    s, t = end_bond_st(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k)
    for m in range(k):
        sm, tm = end_bond_st(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, m)
        if sm == s and tm == t:
            return True
    return False


@inline_njit
def normal_overlap(d0, d1, d2, dist2, rs):
    """Unit normal ``n = d / |d|`` of a sphere pair at separation ``d`` (``|d|^2 =
    dist2``), the overlap ``delta = rs - |d|`` (``rs = R_i + R_j``) and ``|d|``."""
    dist = np.sqrt(dist2)
    inv = 1.0 / dist
    return d0 * inv, d1 * inv, d2 * inv, rs - dist, dist


@inline_njit
def contact_motion(g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0, vi1, vi2, wi0,
                   wi1, wi2, vj0, vj1, vj2, wj0, wj1, wj2):
    """Normal, overlap and relative motion at the contact of a pair within reach: gap
    ``g = p_j - p_i`` (``|g|^2 = dist2``), ``a = p_i - x_i``, ``d = x_j - x_i``, radii,
    velocities and spins of both.

    ``n = g/|g|``, ``delta = R_i + R_j - |g|``, the contact point in the middle of the
    overlap relative to ``x_i``, ``c = a + (R_i - delta/2) n``, and to ``x_j``,
    ``e = c - d``; the relative velocity of the contact points ``v_rel = (v_i + w_i x c)
    - (v_j + w_j x e)`` and its normal part ``v_rel . n``. Returns ``(n (3), delta,
    R_i + R_j, c (3), e (3), v_rel (3), v_rel . n)``."""
    dist = np.sqrt(dist2)
    inv = 1.0 / dist
    n0 = g0 * inv
    n1 = g1 * inv
    n2 = g2 * inv
    rs = ri + rj
    delta = rs - dist
    # contact point relative to x_i, and relative to x_j
    ar = ri - 0.5 * delta
    c0 = a0 + ar * n0
    c1 = a1 + ar * n1
    c2 = a2 + ar * n2
    e0 = c0 - d0
    e1 = c1 - d1
    e2 = c2 - d2
    # relative velocity of the contact points (i minus j)
    vr0 = vi0 + (wi1 * c2 - wi2 * c1) - vj0 - (wj1 * e2 - wj2 * e1)
    vr1 = vi1 + (wi2 * c0 - wi0 * c2) - vj1 - (wj2 * e0 - wj0 * e2)
    vr2 = vi2 + (wi0 * c1 - wi1 * c0) - vj2 - (wj0 * e1 - wj1 * e0)
    vn = vr0 * n0 + vr1 * n1 + vr2 * n2
    return n0, n1, n2, delta, rs, c0, c1, c2, e0, e1, e2, vr0, vr1, vr2, vn
