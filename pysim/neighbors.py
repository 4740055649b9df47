"""Cell list and Verlet pair list with a skin, for boxes that change size.

Every particle has an *interaction radius* ``r_int = R + L/2`` (the radius of the
sphere that encloses a spherocylinder), so elongated particles are handled by the
same code as spheres. Two particles are listed as a pair when their centre distance
is below ``r_int_i + r_int_j + skin``. The list is rebuilt when the displacement
since the last build, together with any box contraction, could bring an unlisted
pair into contact (:func:`needs_rebuild`).

Pairs are stored as two int64 arrays ``(pi, pj)`` with ``pi < pj``, sorted by
``pi`` then by ``pj``: the order is a pure function of the positions, so forces are
summed in the same order on every run (bit-identical results).
"""
from __future__ import annotations

import numpy as np

from pysim.jit import njit


@njit
def minimum_image(d, box, periodic):
    """Apply the minimum-image convention in place to one separation vector ``d``."""
    for k in range(3):
        if periodic[k]:
            d[k] -= box[k] * np.floor(d[k] / box[k] + 0.5)


@njit
def _axis_cells(c, nc, periodic_axis, out):
    """Distinct neighbour cell indices of cell ``c`` along one axis; returns how many."""
    m = 0
    for dc in range(-1, 2):
        cc = c + dc
        if periodic_axis:
            cc = cc % nc
        elif cc < 0 or cc >= nc:
            continue
        dup = False
        for q in range(m):
            if out[q] == cc:
                dup = True
        if not dup:
            out[m] = cc
            m += 1
    return m


@njit
def build_pairs(x, r_int, box, periodic, skin):
    """Verlet pairs ``i < j`` with ``|x_i - x_j| < r_int_i + r_int_j + skin``.

    Uses a cell list with cells at least ``2 max(r_int) + skin`` wide. Returns
    ``(pi, pj)``, int64 arrays sorted by ``pi`` then ``pj``.
    """
    n = x.shape[0]
    rmax = 0.0
    for i in range(n):
        if r_int[i] > rmax:
            rmax = r_int[i]
    cell_min = 2.0 * rmax + skin
    nc = np.empty(3, np.int64)
    for k in range(3):
        m = int(box[k] // cell_min) if box[k] > 0 else 1
        nc[k] = max(m, 1)
    ncell = nc[0] * nc[1] * nc[2]
    # counting sort of particles into cells
    cell_of = np.empty(n, np.int64)
    count = np.zeros(ncell + 1, np.int64)
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
        count[c + 1] += 1
    for c in range(ncell):
        count[c + 1] += count[c]
    start = count.copy()
    members = np.empty(n, np.int64)
    for i in range(n):
        c = cell_of[i]
        members[start[c]] = i
        start[c] += 1

    cap = 8 * n + 16
    pi = np.empty(cap, np.int64)
    pj = np.empty(cap, np.int64)
    npair = 0
    ax = np.empty(3, np.int64)
    ay = np.empty(3, np.int64)
    az = np.empty(3, np.int64)
    d = np.empty(3)
    row = np.empty(64, np.int64)  # neighbours of one particle, sorted before storing
    for i in range(n):
        c = cell_of[i]
        cz = c % nc[2]
        cy = (c // nc[2]) % nc[1]
        cx = c // (nc[1] * nc[2])
        mx = _axis_cells(cx, nc[0], periodic[0], ax)
        my = _axis_cells(cy, nc[1], periodic[1], ay)
        mz = _axis_cells(cz, nc[2], periodic[2], az)
        nrow = 0
        for a in range(mx):
            for b in range(my):
                for e in range(mz):
                    cc = (ax[a] * nc[1] + ay[b]) * nc[2] + az[e]
                    for q in range(count[cc], count[cc + 1]):
                        j = members[q]
                        if j <= i:
                            continue
                        for k in range(3):
                            d[k] = x[j, k] - x[i, k]
                        minimum_image(d, box, periodic)
                        rc = r_int[i] + r_int[j] + skin
                        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] < rc * rc:
                            if nrow == row.shape[0]:
                                bigger = np.empty(2 * nrow, np.int64)
                                bigger[:nrow] = row
                                row = bigger
                            row[nrow] = j
                            nrow += 1
        row[:nrow].sort()
        if npair + nrow > cap:
            cap = 2 * (npair + nrow)
            pi2 = np.empty(cap, np.int64)
            pj2 = np.empty(cap, np.int64)
            pi2[:npair] = pi[:npair]
            pj2[:npair] = pj[:npair]
            pi = pi2
            pj = pj2
        for q in range(nrow):
            pi[npair] = i
            pj[npair] = row[q]
            npair += 1
    return pi[:npair].copy(), pj[:npair].copy()


@njit
def needs_rebuild(x, x_ref, box, box_ref, periodic, r_int_max, skin, growth):
    """True when an unlisted pair could now be within its interaction range.

    ``x_ref``/``box_ref`` are the positions and box at the last build, ``growth`` the
    factor by which every interaction radius has grown since (1 without growth). A pair
    that was unlisted had ``r_ref > r_c + skin``; after the box is scaled by ``s`` (the
    smallest per-axis ratio, at most 1) and each particle moved by at most ``d_max``
    relative to the affinely scaled reference, ``r >= s (r_c + skin) - 2 d_max``, while
    its range is now ``growth r_c``. Rebuild when the bound can fall below the range
    (with ``r_c <= 2 r_int_max``).
    """
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
    """Carry per-pair history (tangential springs) from an old pair list to a new one.

    Both lists are sorted by ``(i, j)``: a merge walks them once. Pairs new to the list
    start with zero history."""
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
