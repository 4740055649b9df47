"""Global sums of the contact passes and the largest overlap.

Global sums (elastic energy, contacts, virial) are taken per fixed block of rows
(:data:`pysim.contacts.partition.BLOCK`) and the block sums added in block order, so
nothing depends on how rows are shared among threads. Each block also keeps its largest
overlap (:func:`_note_overlap`), read by :func:`block_worst`; :func:`worst_overlap` finds
it with a pass of its own.
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.kinematics import min_image, spine_gap
from pysim.jit import inline_njit, njit, pnjit, prange

#: columns of a block's partial sums: elastic energy, contacts, virial (9), then the block's
#: largest overlap fraction ``delta / (2 min(R_i, R_j))`` and its pair plus one (0: none)
_STATS = 13
_WORST, _WORST_K = 11, 12


@inline_njit
def _note_overlap(blk, b, delta, ri, rj, k):
    """Keep pair ``k``'s overlap as a fraction of the smaller diameter in block ``b``'s
    record when it is the block's largest so far (pairs run in pair order within a block,
    so the first pair of the largest is kept)."""
    if delta > 0.0:
        frac = delta / (2.0 * min(ri, rj))
        if frac > blk[b, _WORST]:
            blk[b, _WORST] = frac
            blk[b, _WORST_K] = k + 1.0


@inline_njit
def add_virial(blk, b, d0, d1, d2, F0, F1, F2):
    """Add a pair's virial ``d (x) F`` (centre separation ``d``, force ``F`` on ``j``) to
    block ``b``'s nine virial columns."""
    blk[b, 2] += d0 * F0
    blk[b, 3] += d0 * F1
    blk[b, 4] += d0 * F2
    blk[b, 5] += d1 * F0
    blk[b, 6] += d1 * F1
    blk[b, 7] += d1 * F2
    blk[b, 8] += d2 * F0
    blk[b, 9] += d2 * F1
    blk[b, 10] += d2 * F2


@njit
def block_worst(blk, worst):
    """The largest overlap fraction over the blocks and the first pair where it occurs,
    written to ``worst = (fraction, k)`` (``(-inf, -1)`` when no pair overlaps): what
    :func:`worst_overlap` returns for the pairs of the pass, with no pass of its own."""
    worst[0] = -np.inf
    worst[1] = -1.0
    for b in range(blk.shape[0]):
        if blk[b, _WORST_K] > 0.0 and blk[b, _WORST] > worst[0]:
            worst[0] = blk[b, _WORST]
            worst[1] = blk[b, _WORST_K] - 1.0


@njit
def block_totals(blk, virial):
    """Sum the per-block partial sums in block order (thread-independent): returns
    ``(elastic energy, contacts)`` and writes the virial."""
    tot = np.zeros(_STATS)
    for b in range(blk.shape[0]):
        for c in range(_STATS):
            tot[c] += blk[b, c]
    for a in range(3):
        for c in range(3):
            virial[a, c] = tot[2 + 3 * a + c]
    return tot[0], int(tot[1])


@pnjit
def worst_overlap(x, u, radius, half, box, periodic, pi, pj, rods):
    """The largest overlap as a fraction of the smaller diameter,
    ``delta / (2 min(R_i, R_j))``, over the listed pairs, and the first pair where it
    occurs: ``(fraction, k)`` (``(-inf, -1)`` when no pair touches). For the blow-up
    check."""
    m = pi.shape[0]
    nb = (m + 4095) // 4096
    best = np.full(nb, -np.inf)
    where = np.full(nb, -1, np.int64)
    for b in prange(nb):
        for k in range(b * 4096, min(m, (b + 1) * 4096)):
            i = pi[k]
            j = pj[k]
            d0, d1, d2 = min_image(x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2],
                                   box[0], box[1], box[2], periodic[0], periodic[1],
                                   periodic[2])
            g0, g1, g2 = d0, d1, d2
            if rods:
                _, _, _, g0, g1, g2 = spine_gap(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2], half[i],
                                                u[j, 0], u[j, 1], u[j, 2], half[j])
            delta = radius[i] + radius[j] - np.sqrt(g0 * g0 + g1 * g1 + g2 * g2)
            if delta <= 0.0:
                continue
            frac = delta / (2.0 * min(radius[i], radius[j]))
            if frac > best[b]:
                best[b] = frac
                where[b] = k
    fr = -np.inf
    kk = -1
    for b in range(nb):
        if best[b] > fr:
            fr = best[b]
            kk = where[b]
    return fr, kk
