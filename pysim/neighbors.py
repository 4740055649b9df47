"""Cell list and Verlet pair list with a skin, for boxes that change size.

Every particle has an *interaction radius* ``r_int = R + L/2 + d_c/2`` (the radius of
the sphere that encloses a spherocylinder and its cohesion range) and a *contact reach*
``r_c = r_int - L/2 = R + d_c/2``. Two particles are listed as a pair when the shortest
distance between their spines is below ``r_c_i + r_c_j + skin`` (for spheres: the centre
distance). The cell list finds candidates by the enclosing spheres
(``|x_i - x_j| < r_int_i + r_int_j + skin``); the spine test then keeps, for rods of
``L/D = 4`` at ``phi = 0.5``, about one candidate in eight.

The list is rebuilt when the motion since the last build (translations, rotations of
the spines, an affine box change, particle growth) could bring an unlisted pair into
contact (:func:`list_is_stale`).

Storage (:func:`build_list`): int32 arrays ``(pi, pj)`` with ``pi < pj``, sorted by
``pi`` then by ``pj``, the row starts ``istart`` (particle ``i``'s pairs are
``istart[i]:istart[i+1]``) and the transposed index ``jstart``/``jk`` (the pairs in
which particle ``p`` is the second member are ``jk[jstart[p]:jstart[p+1]]``, in
increasing pair order). The order is a pure function of the positions, so forces are
summed in the same order on every run and with any number of threads (bit-identical
results; :mod:`pysim.contacts`).
"""
from __future__ import annotations

import numpy as np

from pysim.contacts import min_image, spine_gap
from pysim.geometry import closest_params
from pysim.jit import njit, pnjit, prange

#: particles per block of the parallel loops (fixed: results never depend on threads)
BLOCK = 256
#: places per particle in the list build's buffer of pairs (a build whose pairs do not fit
#: runs again with the room they need); a rebuild gives 1.5 times the last list's mean row
ROW_ROOM = 16
#: cells per list range for rods (spheres: 1); finer cells visit fewer candidates
CELLS_PER_RANGE = 2


@njit
def minimum_image(d, box, periodic):
    """Apply the minimum-image convention in place to one separation vector ``d``."""
    for k in range(3):
        if periodic[k]:
            d[k] -= box[k] * np.floor(d[k] / box[k] + 0.5)


@njit
def _slowest_first(box):
    """The box axes from the longest to the shortest, ties in x, y, z order: the order,
    slowest first, of :func:`spatial_order`'s sort and of the list build's cells."""
    return np.argsort(-box, kind="mergesort")


@njit
def _longest_first(x, u, box, periodic):
    """Copies of positions, axes, box and periodic flags with the axes reordered
    :func:`_slowest_first`. A pair's distances are the same numbers in another order."""
    a = _slowest_first(box)
    n = x.shape[0]
    xs = np.empty((n, 3))
    us = np.empty((n, 3))
    for i in range(n):
        for c in range(3):
            xs[i, c] = x[i, a[c]]
            us[i, c] = u[i, a[c]]
    bs = np.empty(3)
    ps = np.empty(3, np.bool_)
    for c in range(3):
        bs[c] = box[a[c]]
        ps[c] = periodic[a[c]]
    return xs, us, bs, ps


@njit
def _grid(x, box, periodic, cell_min):
    """Counting sort of the particles into cells at least ``cell_min`` wide.
    Returns ``(nc (3,), cell_of (N,), start (ncell+1,), members (N,))``; the particles
    of cell ``c`` are ``members[start[c]:start[c+1]]`` in increasing index."""
    n = x.shape[0]
    nc = np.empty(3, np.int64)
    for k in range(3):
        m = int(box[k] // cell_min) if box[k] > 0 else 1
        nc[k] = max(m, 1)
    ncell = nc[0] * nc[1] * nc[2]
    cell_of = np.empty(n, np.int64)
    start = np.zeros(ncell + 1, np.int64)
    for i in range(n):
        c = 0
        for k in range(3):
            ck = int(x[i, k] / box[k] * nc[k]) if box[k] > 0 else 0
            if ck < 0:
                ck = ck % nc[k] if periodic[k] else 0
            if ck >= nc[k]:
                ck = ck % nc[k] if periodic[k] else nc[k] - 1
            c = c * nc[k] + ck
        cell_of[i] = c
        start[c + 1] += 1
    for c in range(ncell):
        start[c + 1] += start[c]
    fill = start[:ncell].copy()
    members = np.empty(n, np.int64)
    for i in range(n):
        c = cell_of[i]
        members[fill[c]] = i
        fill[c] += 1
    return nc, cell_of, start, members


@njit
def _stencil(nc, periodic_axis, k):
    """Cell offsets ``lo..hi`` along one axis for cells ``1/k`` of the range wide, and
    whether they form a stencil (``-k..k``; else every cell once, when a periodic axis
    has fewer than ``2k + 1`` cells)."""
    if periodic_axis and nc < 2 * k + 1:
        return 0, nc - 1, False
    return -k, k, True


@njit
def _image(d, b, hb, periodic_axis, stencil):
    """Minimum image of one separation component (``hb = b/2``). On a
    stencil axis the separation lies within ``1.5 b`` and one shift suffices; for pairs
    in range it is the shift of ``d - b floor(d/b + 1/2)`` (the same bits)."""
    if not periodic_axis:
        return d
    if stencil:
        if d > hb:
            return d - b
        if d < -hb:
            return d + b
        return d
    return d - b * np.floor(d / b + 0.5)


@njit
def _wrap_cell(c, nc):
    """``c mod nc`` for ``-nc <= c < 2 nc`` without an integer division."""
    if c < 0:
        return c + nc
    if c >= nc:
        return c - nc
    return c


@njit
def _off_spine(d0, d1, d2, u0, u1, u2, h, reach):
    """Whether the point ``d`` (relative to a spine's centre) is at least ``reach`` from
    the spine of half-length ``h`` along ``u``: then a spine of half-length ``h_j``
    through ``d`` is at least ``reach - h_j`` from it (a cheap test before
    :func:`closest_params`)."""
    s = min(max(d0 * u0 + d1 * u1 + d2 * u2, -h), h)
    e0 = d0 - s * u0
    e1 = d1 - s * u1
    e2 = d2 - s * u2
    return e0 * e0 + e1 * e1 + e2 * e2 >= reach * reach


@njit
def _forward_pairs(c0, c1, x, u, r_int, half, box, periodic, skin, rods, nc, k, start,
                   members, found, buf, lo, hi):
    """The partners of the particles in cells ``c0..c1-1`` that come later in cell
    order (member position ``q > qi``) and whose spines are closer than ``r_c_i + r_c_j +
    skin``: each pair once. Cells are at least ``1/k`` of the largest range wide; the
    stencil's cells along ``z`` are one range of ``members``, and the enclosing-sphere
    test runs on them without branches. The partners of the particle at member position
    ``qi`` go to ``buf`` one after the other from ``lo`` (as far as ``hi``), their
    number to ``found[qi]``. Returns how many places they needed."""
    lox, hix, stx = _stencil(nc[0], periodic[0], k)
    loy, hiy, sty = _stencil(nc[1], periodic[1], k)
    loz, hiz, stz = _stencil(nc[2], periodic[2], k)
    b0, b1, b2 = box[0], box[1], box[2]
    h0, h1, h2 = 0.5 * b0, 0.5 * b1, 0.5 * b2
    nseg = 2 * (hix - lox + 1) * (hiy - loy + 1)  # member ranges: columns of cells along z
    seg_lo = np.empty(nseg, np.int64)
    seg_hi = np.empty(nseg, np.int64)
    cand = np.empty(64, np.int32)
    at = lo
    for c in range(c0, c1):
        if start[c] == start[c + 1]:
            continue
        cz = c % nc[2]
        cy = (c // nc[2]) % nc[1]
        cx = c // (nc[1] * nc[2])
        ns = 0
        tot = 0
        for ax in range(lox, hix + 1):
            ccx = cx + ax
            if periodic[0]:
                ccx = _wrap_cell(ccx, nc[0])
            elif ccx < 0 or ccx >= nc[0]:
                continue
            for ay in range(loy, hiy + 1):
                ccy = cy + ay
                if periodic[1]:
                    ccy = _wrap_cell(ccy, nc[1])
                elif ccy < 0 or ccy >= nc[1]:
                    continue
                col = (ccx * nc[1] + ccy) * nc[2]
                if col + nc[2] <= c:  # the whole column comes before c
                    continue
                z0 = cz + loz
                z1 = cz + hiz
                if not stz:  # every cell of the column once
                    z0, z1 = 0, nc[2] - 1
                elif not periodic[2]:
                    z0 = max(z0, 0)
                    z1 = min(z1, nc[2] - 1)
                elif z0 < 0:
                    seg_lo[ns] = start[col + z0 + nc[2]]
                    seg_hi[ns] = start[col + nc[2]]
                    tot += seg_hi[ns] - seg_lo[ns]
                    ns += 1
                    z0 = 0
                elif z1 >= nc[2]:
                    seg_lo[ns] = start[col]
                    seg_hi[ns] = start[col + z1 - nc[2] + 1]
                    tot += seg_hi[ns] - seg_lo[ns]
                    ns += 1
                    z1 = nc[2] - 1
                seg_lo[ns] = start[col + z0]
                seg_hi[ns] = start[col + z1 + 1]
                tot += seg_hi[ns] - seg_lo[ns]
                ns += 1
        if cand.shape[0] < tot:
            cand = np.empty(2 * tot, np.int32)
        for qi in range(start[c], start[c + 1]):
            i = members[qi]
            xi0, xi1, xi2, ri = x[i, 0], x[i, 1], x[i, 2], r_int[i]
            hi_ = half[i]
            nk = 0  # later particles within the enclosing spheres' range, without branches
            for e in range(ns):
                for q in range(max(seg_lo[e], qi + 1), seg_hi[e]):
                    j = members[q]
                    d0 = _image(x[j, 0] - xi0, b0, h0, periodic[0], stx)
                    d1 = _image(x[j, 1] - xi1, b1, h1, periodic[1], sty)
                    d2 = _image(x[j, 2] - xi2, b2, h2, periodic[2], stz)
                    rc = ri + r_int[j] + skin
                    cand[nk] = j
                    nk += d0 * d0 + d1 * d1 + d2 * d2 < rc * rc
            m = 0
            for e in range(nk):
                j = cand[e]
                hj = half[j]
                if rods and (hi_ > 0.0 or hj > 0.0):
                    d0 = _image(x[j, 0] - xi0, b0, h0, periodic[0], stx)
                    d1 = _image(x[j, 1] - xi1, b1, h1, periodic[1], sty)
                    d2 = _image(x[j, 2] - xi2, b2, h2, periodic[2], stz)
                    rs = ri - hi_ + r_int[j] - hj + skin
                    if _off_spine(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2], hi_, rs + hj):
                        continue
                    if _off_spine(-d0, -d1, -d2, u[j, 0], u[j, 1], u[j, 2], hj, rs + hi_):
                        continue
                    s, t = closest_params(-d0, -d1, -d2, u[i, 0], u[i, 1], u[i, 2], hi_,
                                          u[j, 0], u[j, 1], u[j, 2], hj)
                    g0 = d0 + t * u[j, 0] - s * u[i, 0]
                    g1 = d1 + t * u[j, 1] - s * u[i, 1]
                    g2 = d2 + t * u[j, 2] - s * u[i, 2]
                    if g0 * g0 + g1 * g1 + g2 * g2 >= rs * rs:
                        continue
                if at + m < hi:
                    buf[at + m] = j
                m += 1
            found[qi] = m
            at += m
    return at - lo


@pnjit
def build_list(x, u, r_int, half, box, periodic, skin, row_room=ROW_ROOM, scratch=None):
    """Verlet pairs ``i < j`` whose spines are closer than ``r_c_i + r_c_j + skin``
    (``r_c = r_int - half``); positions on periodic axes in ``[0, box)``. Returns ``(pi,
    pj, istart, jstart, jk)`` (see the module doc): pairs as int32, sorted by ``pi`` then
    ``pj``.

    Cells ``1/k`` of the largest range wide (``k`` = :data:`CELLS_PER_RANGE` for rods, 1
    for spheres); each particle looks for the partners that come later in cell order
    (:func:`_forward_pairs`, one task per group of cells, into a buffer with
    ``row_room`` places per particle: ``scratch``, an int32 array, where it is large
    enough; if a task's pairs do not fit, all tasks run again with the room they
    needed). A counting sort puts each pair in the row of its lower index.

    The cells run in the order of :func:`spatial_order`, the longest box axis slowest
    (:func:`_longest_first`), so that in a sorted start a cell's neighbours lie close in
    memory (in x, y, z order a build was slower where the particles were sorted the other
    way: docs/performance.md)."""
    n = x.shape[0]
    rmax = 0.0
    rods = False
    for i in range(n):
        if r_int[i] > rmax:
            rmax = r_int[i]
        if half[i] > 0.0:
            rods = True
    k = CELLS_PER_RANGE if rods else 1
    x, u, box, periodic = _longest_first(x, u, box, periodic)
    nc, cell_of, start, members = _grid(x, box, periodic, (2.0 * rmax + skin) / k)
    ncell = start.shape[0] - 1
    cb = max(1, BLOCK * ncell // max(n, 1))  # cells per task: about BLOCK particles
    nb = (ncell + cb - 1) // cb
    lo = np.empty(nb + 1, np.int64)
    for b in range(nb + 1):
        lo[b] = start[min(ncell, b * cb)] * max(1, row_room)
    if scratch is not None and scratch.shape[0] >= lo[nb]:
        buf = scratch[:lo[nb]]
    else:
        buf = np.empty(lo[nb], np.int32)
    found = np.empty(n, np.int32)
    need = np.empty(nb, np.int64)
    for b in prange(nb):
        need[b] = _forward_pairs(b * cb, min(ncell, (b + 1) * cb), x, u, r_int, half, box,
                                 periodic, skin, rods, nc, k, start, members, found, buf, lo[b],
                                 lo[b + 1])
    fits = True
    for b in range(nb):
        fits = fits and need[b] <= lo[b + 1] - lo[b]
    if not fits:  # again, with the room each task needed
        for b in range(nb):
            lo[b + 1] = lo[b] + need[b]
        buf = np.empty(lo[nb], np.int32)
        for b in prange(nb):
            _forward_pairs(b * cb, min(ncell, (b + 1) * cb), x, u, r_int, half, box, periodic,
                           skin, rods, nc, k, start, members, found, buf, lo[b], lo[b + 1])
    istart = np.zeros(n + 1, np.int64)  # counting sort by the lower index
    for b in range(nb):
        at = lo[b]
        for qi in range(start[min(ncell, b * cb)], start[min(ncell, (b + 1) * cb)]):
            i = members[qi]
            for e in range(at, at + found[qi]):
                istart[min(i, buf[e]) + 1] += 1
            at += found[qi]
    for i in range(n):
        istart[i + 1] += istart[i]
    npair = istart[n]
    pi = np.empty(npair, np.int32)
    pj = np.empty(npair, np.int32)
    fill = istart[:n].copy()
    for b in range(nb):
        at = lo[b]
        for qi in range(start[min(ncell, b * cb)], start[min(ncell, (b + 1) * cb)]):
            i = members[qi]
            for e in range(at, at + found[qi]):
                j = buf[e]
                a = min(i, j)
                pj[fill[a]] = max(i, j)
                fill[a] += 1
            at += found[qi]
    for b in prange((n + BLOCK - 1) // BLOCK):
        for i in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            a = istart[i]
            for q in range(a, istart[i + 1]):  # insertion sort of the row by j
                v = pj[q]
                r = q - 1
                while r >= a and pj[r] > v:
                    pj[r + 1] = pj[r]
                    r -= 1
                pj[r + 1] = v
                pi[q] = i
    jstart, jk = transpose(pj, n)
    return pi, pj, istart, jstart, jk


@njit
def transpose(pj, n):
    """``(jstart, jk)``: the pairs in which particle ``p`` is the second member are
    ``jk[jstart[p]:jstart[p+1]]``, in increasing pair order (a stable counting sort)."""
    jstart = np.zeros(n + 1, np.int64)
    for k in range(pj.shape[0]):
        jstart[pj[k] + 1] += 1
    for p in range(n):
        jstart[p + 1] += jstart[p]
    fill = jstart[:n].copy()
    jk = np.empty(pj.shape[0], np.int32)
    for k in range(pj.shape[0]):
        p = pj[k]
        jk[fill[p]] = k
        fill[p] += 1
    return jstart, jk


@njit
def row_starts(pi, n):
    """``istart`` of a pair list sorted by ``pi``: row ``i`` is ``istart[i]:istart[i+1]``."""
    istart = np.zeros(n + 1, np.int64)
    for k in range(pi.shape[0]):
        istart[pi[k] + 1] += 1
    for i in range(n):
        istart[i + 1] += istart[i]
    return istart


@pnjit
def transfer_rows(old_start, old_pj, old_hist, new_start, new_pj):
    """Carry per-pair history (tangential springs) from an old pair list to a new one,
    row by row (both sorted by ``(i, j)``); pairs new to the list start at zero."""
    n = new_start.shape[0] - 1
    cols = old_hist.shape[1]
    new = np.zeros((new_pj.shape[0], cols))
    if old_start.shape[0] != new_start.shape[0] or cols == 0:
        return new
    for i in prange(n):
        a = old_start[i]
        ea = old_start[i + 1]
        for b in range(new_start[i], new_start[i + 1]):
            while a < ea and old_pj[a] < new_pj[b]:
                a += 1
            if a < ea and old_pj[a] == new_pj[b]:
                for c in range(cols):
                    new[b, c] = old_hist[a, c]
    return new


@pnjit
def motion_bound(x, x_ref, u, u_ref, half, box, box_ref, periodic, h_ref, growth, dl=None):
    """How far spines can have come closer since the last build: returns ``(sigma,
    shrink)`` such that every pair's spine distance now is at least
    ``sigma g_ref - shrink`` (``g_ref`` its spine distance at the build).

    Since the build (positions ``x_ref``, axes ``u_ref``, box ``box_ref``) the box was
    scaled per axis by ``a_k`` (``sigma = min(1, a_k)``, ``eps = max |1 - a_k|``), every
    reach and half-length grew by ``growth``, and a spine point of particle ``i`` moved by
    at most ``delta_i = |x_i - a x_ref_i| + h_i |u_i - u_ref_i|`` relative to the scaled
    reference; so ``shrink = 2 (eps + |growth - 1|) h_ref + 2 max delta`` (``h_ref`` the
    largest half-length at the build).

    With ``dl`` (n values) also each particle's own share, ``dl_i = (eps + |growth - 1|)
    h_ref + delta_i``: pair ``(i, j)``'s spine distance is at least ``sigma g_ref - dl_i -
    dl_j``, a bound as safe and tighter (``shrink = 2 max dl``, taken by the particles
    that moved most)."""
    n = x.shape[0]
    sigma = 1.0
    eps = 0.0
    scale = np.empty(3)
    for k in range(3):
        a = box[k] / box_ref[k] if box_ref[k] > 0 else 1.0
        scale[k] = a
        sigma = min(sigma, a)
        eps = max(eps, abs(1.0 - a))
    hscale = max(1.0, 1.0 / growth) if growth > 0 else 1.0
    s0, s1, s2 = scale[0], scale[1], scale[2]
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    nb = (n + BLOCK - 1) // BLOCK
    dmax = np.zeros(nb)
    share = (eps + abs(growth - 1.0)) * h_ref
    dlv = dl if dl is not None else np.empty(0)
    out = dlv.shape[0] == n
    for b in prange(nb):
        m = 0.0  # rods: translation plus the end's swing
        m2 = 0.0  # spheres: the squared translation (one square root per block)
        for i in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            d0 = x[i, 0] - x_ref[i, 0] * s0
            d1 = x[i, 1] - x_ref[i, 1] * s1
            d2 = x[i, 2] - x_ref[i, 2] * s2
            # minimum image, only where needed (the same value: within half a box the
            # floor is 0)
            if p0 and abs(d0) > 0.5 * b0:
                d0 -= b0 * np.floor(d0 / b0 + 0.5)
            if p1 and abs(d1) > 0.5 * b1:
                d1 -= b1 * np.floor(d1 / b1 + 0.5)
            if p2 and abs(d2) > 0.5 * b2:
                d2 -= b2 * np.floor(d2 / b2 + 0.5)
            dd = d0 * d0 + d1 * d1 + d2 * d2
            if half[i] > 0.0:
                e0 = u[i, 0] - u_ref[i, 0]
                e1 = u[i, 1] - u_ref[i, 1]
                e2 = u[i, 2] - u_ref[i, 2]
                di = np.sqrt(dd) + half[i] * hscale * np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
                m = max(m, di)
                if out:
                    dlv[i] = share + di
            else:
                m2 = max(m2, dd)
                if out:
                    dlv[i] = share + np.sqrt(dd)
        dmax[b] = max(m, np.sqrt(m2))
    worst = 0.0
    for b in range(nb):
        if dmax[b] > worst:
            worst = dmax[b]
    return sigma, 2.0 * (eps + abs(growth - 1.0)) * h_ref + 2.0 * worst


@njit
def stale_by_bound(sigma, shrink, rc_ref, skin, growth):
    """True when the bound of :func:`motion_bound` lets an unlisted pair (spine distance
    above ``r_cs + skin`` at the build, ``r_cs <= rc_ref``) come into contact, which needs
    less than ``growth r_cs``."""
    return sigma * skin - shrink <= max(growth - sigma, 0.0) * rc_ref


@njit
def list_is_stale(x, x_ref, u, u_ref, half, box, box_ref, periodic, rc_ref, h_ref, skin,
                  growth):
    """True when an unlisted pair could now be in contact.

    At the last build every unlisted pair had a spine distance above ``r_cs + skin``
    (``r_cs <= rc_ref``, twice the largest contact reach); by :func:`motion_bound` it is
    now at least ``sigma (r_cs + skin) - shrink``, while contact needs less than
    ``growth r_cs``: rebuild when the bound can fall below. For spheres this is the
    classic ``2 max |dx| > skin`` rule, corrected for box contraction.
    """
    sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box_ref, periodic, h_ref,
                                 growth)
    return stale_by_bound(sigma, shrink, rc_ref, skin, growth)


@pnjit
def spine_separations(x, u, half, box, periodic, pi, pj, out):
    """``out[k]``: the spine distance of pair ``k`` (centre distance for two spheres), for
    the bound of :func:`motion_bound` (the contact loop skips pairs that the bound keeps
    out of reach)."""
    for k in prange(pi.shape[0]):
        i = pi[k]
        j = pj[k]
        d0, d1, d2 = min_image(x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2],
                               box[0], box[1], box[2], periodic[0], periodic[1], periodic[2])
        _, _, _, g0, g1, g2 = spine_gap(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2], half[i],
                                        u[j, 0], u[j, 1], u[j, 2], half[j])
        out[k] = np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


def spatial_order(x, box, cell: float = 1.0) -> np.ndarray:
    """A permutation that sorts particles by cell (cells of edge ~``cell``, row-major with
    the longest box axis slowest and the shortest fastest): applied to an initial
    configuration it keeps neighbours close in memory, which the contact loop's speed for
    large N depends on (LAMMPS sorts its atoms likewise). A pair's second particle lies at
    most about a plane of cells (the two shorter axes) further on, so taking the longest
    axis slowest keeps the particles between the two of a pair the fewest (see
    ``docs/performance.md``)."""
    x = np.asarray(x, dtype=np.float64)
    box = np.asarray(box, dtype=np.float64)
    nc = np.maximum((box // cell).astype(np.int64), 1)
    c = np.clip((x / np.where(box > 0, box, 1.0) * nc).astype(np.int64), 0, nc - 1)
    a = _slowest_first(box)
    key = (c[:, a[0]] * nc[a[1]] + c[:, a[1]]) * nc[a[2]] + c[:, a[2]]
    return np.argsort(key, kind="stable")


# -- the sphere-bound list of the first version (kept as a simple, tested API) -------------
def build_pairs(x, r_int, box, periodic, skin):
    """Verlet pairs ``i < j`` with ``|x_i - x_j| < r_int_i + r_int_j + skin`` (the list
    of enclosing spheres). Returns ``(pi, pj)`` sorted by ``pi`` then ``pj``."""
    x = np.ascontiguousarray(x, dtype=np.float64)
    n = x.shape[0]
    pi, pj, *_ = build_list(x, np.zeros((n, 3)), np.ascontiguousarray(r_int, dtype=np.float64),
                            np.zeros(n), np.asarray(box, dtype=np.float64),
                            np.asarray(periodic, dtype=np.bool_), float(skin))
    return pi.astype(np.int64), pj.astype(np.int64)


@njit
def needs_rebuild(x, x_ref, box, box_ref, periodic, r_int_max, skin, growth):
    """Sphere form of :func:`list_is_stale` (``2 r_int_max`` the largest pair range)."""
    s = 1.0
    for k in range(3):
        if box_ref[k] > 0:
            ratio = box[k] / box_ref[k]
            if ratio < s:
                s = ratio
    dmax2 = 0.0
    for i in range(x.shape[0]):
        d2 = 0.0
        for k in range(3):
            scale = box[k] / box_ref[k] if box_ref[k] > 0 else 1.0
            dk = x[i, k] - x_ref[i, k] * scale
            if periodic[k]:
                dk -= box[k] * np.floor(dk / box[k] + 0.5)
            d2 += dk * dk
        if d2 > dmax2:
            dmax2 = d2
    rc = 2.0 * r_int_max
    return s * (rc + skin) - 2.0 * np.sqrt(dmax2) <= growth * rc


@njit
def transfer_history(old_pi, old_pj, old_hist, new_pi, new_pj):
    """Carry per-pair history from an old pair list to a new one (both sorted by
    ``(i, j)``) with one merge; pairs new to the list start with zero history."""
    new = np.zeros((new_pi.shape[0], old_hist.shape[1]))
    a = 0
    na = old_pi.shape[0]
    for b in range(new_pi.shape[0]):
        while a < na and (old_pi[a] < new_pi[b] or (old_pi[a] == new_pi[b] and old_pj[a] < new_pj[b])):
            a += 1
        if a < na and old_pi[a] == new_pi[b] and old_pj[a] == new_pj[b]:
            for c in range(old_hist.shape[1]):
                new[b, c] = old_hist[a, c]
    return new


def all_pairs(x, r_int, box, periodic, skin):
    """Slow NumPy reference for :func:`build_pairs` (tests only)."""
    n = len(x)
    i, j = np.triu_indices(n, k=1)
    d = x[j] - x[i]
    for k in range(3):
        if periodic[k]:
            d[:, k] -= box[k] * np.floor(d[:, k] / box[k] + 0.5)
    rc = r_int[i] + r_int[j] + skin
    keep = np.sum(d * d, axis=1) < rc * rc
    return i[keep].astype(np.int64), j[keep].astype(np.int64)
