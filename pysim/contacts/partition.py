"""The rows cut into blocks and parts, and which particles a part owns.

The threaded passes (:func:`pysim.contacts.spheres.sphere_pass`,
:func:`pysim.contacts.rods.rod_pass`) give each thread a contiguous part of the rows
(whole blocks, :func:`part_bounds`). A part adds each reaction to its second particle
at once, unless that particle also receives reactions from an earlier part (shared,
:func:`_own_part`): those are stored per pair and summed in pair order after the parts
(:func:`_close_part`), the same sum, so any number of parts gives the same bits.
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.reactions import _no_reaction, _reaction_sum
from pysim.jit import inline_njit, njit, pnjit, prange

#: rows per block of the parallel pair loop (fixed: results never depend on threads)
BLOCK = 64


@njit
def _zero_rows(f, torque, lo, hi):
    """Zero the forces and torques of rows ``lo:hi``. As slices, which compile to plain
    runs of stores, faster than a loop row by row."""
    f[lo:hi] = 0.0
    torque[lo:hi] = 0.0


@njit
def part_bounds(istart, nb, nparts):
    """Block bounds ``bounds[t]:bounds[t+1]`` of ``nparts`` contiguous parts of the rows
    (whole blocks of :data:`BLOCK` rows, so that a block's sums stay in one part), with
    about equal numbers of listed pairs; parts may be empty."""
    n = istart.shape[0] - 1
    total = istart[n]
    bounds = np.empty(nparts + 1, np.int64)
    bounds[0] = 0
    b = 0
    for t in range(1, nparts):
        target = total * t // nparts
        while b < nb and istart[b * BLOCK] < target:
            b += 1
        bounds[t] = b
    bounds[nparts] = nb
    return bounds


@njit
def _own_part(lo, hi, istart, jstart, jk, own):
    """Mark as ``own`` the particles of the part of rows ``lo:hi`` that are not the
    second member of a pair whose row lies before ``lo`` (in another part): their
    reactions all come from this part and are added at once. The reactions on the
    others ("shared") are stored per pair (``fj``) and added by :func:`_close_part`."""
    kb = istart[lo]  # the first pair of the part: rows before lo hold the pairs before it
    for i in range(lo, hi):
        own[i] = not _is_shared(i, kb, jstart, jk)


@pnjit
def own_flags(bounds, istart, jstart, jk, own):
    """:func:`_own_part` for every part (the ``own`` flags of all n particles), before any
    part runs: a part reads the flags of particles in later parts (their reactions are
    stored). They depend on the list and the parts alone, so
    :func:`pysim.integrators.forces` keeps them from step to step rather than finding
    them at every step."""
    n = own.shape[0]
    for t in prange(bounds.shape[0] - 1):
        _own_part(bounds[t] * BLOCK, min(n, bounds[t + 1] * BLOCK), istart, jstart, jk, own)


@njit
def _part_flags(bounds, istart, jstart, jk, n, own, own_ok):
    """The ``own`` flags for the parts ``bounds``: none with one part (every reaction is
    added at once); ``own`` itself when it holds n flags, computed unless ``own_ok``
    (they are this list's and these parts'); else new ones."""
    nt = bounds.shape[0] - 1
    if nt == 1:
        return np.empty(0, np.bool_)
    if own.shape[0] == n:
        if not own_ok:
            own_flags(bounds, istart, jstart, jk, own)
        return own
    fresh = np.empty(n, np.bool_)
    own_flags(bounds, istart, jstart, jk, fresh)
    return fresh


@inline_njit
def _is_shared(i, kb, jstart, jk):
    """Particle ``i`` is the second member of a pair before pair ``kb``. The transposed
    list holds each particle's pairs in pair order, so its first one decides; pairs are
    ordered by row, so with ``kb = istart[lo]`` this is a pair whose row lies before
    ``lo`` (faster than reading the row, ``pi``). Without a branch on the particle, which
    made a loop over particles slower."""
    last = jk.shape[0] - 1
    if last < 0:  # no pairs
        return False
    q = jstart[i]
    return (q != jstart[i + 1]) & (jk[min(q, last)] < kb)


@njit
def clear_slots(istart, jstart, jk, fj, parts, by_pair):
    """Zero the reaction records (:data:`FJ_COLUMNS`, one per pair) of the pairs of every
    particle that :func:`sphere_pass` and :func:`rod_pass` on ``parts`` parts store
    reactions for (the shared ones, :func:`_own_part`). The passes need these records at
    zero on entry and leave them so (:func:`_close_part`); after a list build they hold
    other pairs' values or garbage, and a new number of parts shares other particles.
    Only those records are touched, so the memory of the others is never made
    resident. ``by_pair``: the records of pairs (:func:`sphere_pass`), else of slots
    (:func:`rod_pass`; :func:`_store_chunk`)."""
    n = istart.shape[0] - 1
    if parts < 2:
        return
    bounds = part_bounds(istart, (n + BLOCK - 1) // BLOCK, parts)
    fr = fj.reshape(-1)
    for t in range(1, parts):
        lo = bounds[t] * BLOCK
        for i in range(lo, min(n, bounds[t + 1] * BLOCK)):
            if _is_shared(i, istart[lo], jstart, jk):
                for q in range(jstart[i], jstart[i + 1]):
                    _no_reaction(jk[q] if by_pair else q, fr)


@njit
def _close_part(lo, hi, jstart, jk, fr, f, torque, own, by_pair):
    """Complete the shared particles of rows ``lo:hi``: ``f_i = row sum + reaction sum``
    (as :func:`reduce_pass` does; :func:`_reaction_sum`), and zero the records read, so
    that those of pairs out of reach hold zero at the next pass (:func:`_store_chunk`)."""
    for i in range(lo, hi):
        if own[i]:
            continue
        g0, g1, g2, h0, h1, h2 = _reaction_sum(i, jstart, jk, fr, by_pair, True)
        f[i, 0] = f[i, 0] + g0
        f[i, 1] = f[i, 1] + g1
        f[i, 2] = f[i, 2] + g2
        torque[i, 0] = torque[i, 0] + h0
        torque[i, 1] = torque[i, 1] + h1
        torque[i, 2] = torque[i, 2] + h2
