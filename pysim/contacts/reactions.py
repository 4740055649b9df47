"""The reactions of the pairs on their second particles: per-pair records, the row
sums, and the gather that completes each particle's force.

Particle ``i`` owns its pairs ``(i, j > i)``; a pass sums the forces and torques on
``i`` in row order and either adds the reaction on ``j`` at once (:func:`_reaction`) or
stores it per pair (:func:`_store`, at the pair's place in the transposed list, so that
the reactions on ``j`` lie together in pair order); :func:`reduce_pass` then adds to
each particle the stored reactions on it, summed from zero in pair order, to its row sum
(``f_i = row sum + reaction sum``).
"""
from __future__ import annotations

import numpy as np

from pysim.jit import inline_njit, njit, pnjit, prange

#: components of a stored reaction on a pair's second particle: force (3), torque (3).
#: They are stored in the first :data:`FJ_COLUMNS` rows of the per-pair scratch ``fj``
#: read as one flat array ``fr = fj.reshape(-1)``, one record of 6 values per index
#: (``fr[6 q + c]``): a store writes one or two cache lines, not six rows far apart. The
#: general pass (:func:`pair_pass`) and :func:`rod_pass` index the records by the pair's
#: slot, its place in the transposed list (:func:`_slot`), :func:`sphere_pass` by the
#: pair itself: its stores then run in pair order, without a search, but the records
#: written spread over all pairs of the rows next to a part's ends, which for rods, with
#: many pairs per row, makes more memory resident (docs/performance.md). The other rows
#: (the rods' separations) lie beyond the records; memory pages that are never touched
#: take no memory
FJ_COLUMNS = 6
#: the row of ``fj`` (when it has one) that holds the pair's spine distance at the last
#: list build (:func:`pysim.neighbors.spine_separations`), for skipping pairs out of reach
SEP = 6
#: rows of the per-pair scratch the integrators keep: the reaction and the separation
PAIR_SCRATCH = 7


@njit
def _slot(k, j, jstart, jk):
    """Where pair ``k`` stores its reaction on its second particle ``j``: its place ``q``
    in the transposed list (``jk[q] = k``), so that the reactions on ``j`` lie together,
    in pair order, in the records ``jstart[j]:jstart[j+1]`` (:data:`FJ_COLUMNS`; a search
    of ``j``'s few pairs)."""
    q = jstart[j]
    while jk[q] != k:
        q += 1
    return q


@inline_njit
def _store(q, fr, F0, F1, F2, u0, u1, u2):
    """Store a reaction (force ``-F``, torque ``u``) in slot ``q`` of the records ``fr``
    (:data:`FJ_COLUMNS`)."""
    b = FJ_COLUMNS * q
    fr[b] = -F0
    fr[b + 1] = -F1
    fr[b + 2] = -F2
    fr[b + 3] = u0
    fr[b + 4] = u1
    fr[b + 5] = u2


@inline_njit
def _no_reaction(q, fr):
    """A zero reaction in slot ``q`` of the records ``fr`` (a pair out of contact)."""
    for c in range(FJ_COLUMNS):
        fr[FJ_COLUMNS * q + c] = 0.0


@inline_njit
def _reaction(j, solo, own, f, torque, F0, F1, F2, u0, u1, u2):
    """The reaction of a pair on its second particle ``j`` (force ``-F``, torque ``u``):
    added to ``f_j`` at once in the ``solo`` part or when ``own[j]`` (``j`` receives
    reactions from its own part only, :func:`_own_part`; returns True); else it is left
    for :func:`_store_chunk` (returns False)."""
    if solo or own[np.uint64(j)]:
        ju = np.uint64(j)
        f[ju, 0] -= F0
        f[ju, 1] -= F1
        f[ju, 2] -= F2
        torque[ju, 0] += u0
        torque[ju, 1] += u1
        torque[ju, 2] += u2
        return True
    return False


@njit
def _store_chunk(pj, jstart, jk, fr, X, cap, fo, uo, torques, kin, kl, nl, by_pair):
    """Store the reactions that :func:`_reaction` left out, for :func:`_close_part`: the
    pairs in reach of a chunk are ``kin``, those left out are the columns ``kl[:nl]``;
    their force on i is in rows ``fo:fo+3`` of the chunk's scratch ``X`` (``cap`` values
    per row) and, with ``torques``, their torque on j in rows ``uo:uo+3``. Each goes to
    the record of its pair ``k`` with ``by_pair``, else of its slot (:func:`_slot`).
    The records of pairs out of reach stay zero (:func:`_close_part` leaves every record
    it reads at zero)."""
    for q in range(nl):
        m = kl[q]
        k = kin[m]
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        if torques:
            u0 = X[np.uint64(uo * cap + m)]
            u1 = X[np.uint64((uo + 1) * cap + m)]
            u2 = X[np.uint64((uo + 2) * cap + m)]
        _store(k if by_pair else _slot(k, pj[k], jstart, jk), fr, X[np.uint64(fo * cap + m)],
               X[np.uint64((fo + 1) * cap + m)], X[np.uint64((fo + 2) * cap + m)], u0, u1, u2)


@njit
def _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, scatter):
    """Row ``i`` is complete: ``f_i = row sum + reaction sum`` with ``scatter`` (the
    reactions on ``i`` were added as its pairs with lower rows ran), else the row sum."""
    iu = np.uint64(i)  # unsigned: no negative-index wraparound
    if scatter:
        f[iu, 0] = s0 + f[iu, 0]
        f[iu, 1] = s1 + f[iu, 1]
        f[iu, 2] = s2 + f[iu, 2]
        torque[iu, 0] = q0 + torque[iu, 0]
        torque[iu, 1] = q1 + torque[iu, 1]
        torque[iu, 2] = q2 + torque[iu, 2]
    else:
        f[iu, 0] = s0
        f[iu, 1] = s1
        f[iu, 2] = s2
        torque[iu, 0] = q0
        torque[iu, 1] = q1
        torque[iu, 2] = q2


@inline_njit
def _finish_rows(i, hi, k1, istart, f, torque, s0, s1, s2, q0, q1, q2, solo, own):
    """Finish the rows below ``hi`` whose pairs end with pair ``k1`` (:func:`_finish_row`,
    the sums restarting at zero after each): returns the next row and its sums so far."""
    while i < hi and istart[i + 1] <= k1:
        _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, solo or own[i])
        s0 = s1 = s2 = q0 = q1 = q2 = 0.0
        i += 1
    return i, s0, s1, s2, q0, q1, q2


@inline_njit
def _reaction_sum(i, jstart, jk, fr, by_pair, zero):
    """The stored reactions on particle ``i`` (force, torque), summed from zero in pair
    order: its records in ``fr`` are those of its pairs with ``by_pair``, else of its
    slots (:func:`_slot`), both read through the transposed list. With ``zero`` each
    record is zeroed as it is read. Inlined, so that the flags are constants at each
    caller: called, or with the zeroing in a loop of its own, the closing pass was
    slower."""
    g0 = 0.0
    g1 = 0.0
    g2 = 0.0
    h0 = 0.0
    h1 = 0.0
    h2 = 0.0
    for q in range(jstart[i], jstart[i + 1]):
        b = FJ_COLUMNS * (jk[q] if by_pair else q)
        g0 += fr[b]
        g1 += fr[b + 1]
        g2 += fr[b + 2]
        h0 += fr[b + 3]
        h1 += fr[b + 4]
        h2 += fr[b + 5]
        if zero:
            for c in range(FJ_COLUMNS):
                fr[b + c] = 0.0
    return g0, g1, g2, h0, h1, h2


@pnjit
def reduce_pass(f, torque, jstart, fj, v, omega, mass, gx, gy, gz, gamma_bg, gamma_rot,
                body, gathered=False):
    """Complete each particle's force and torque: the row sums in ``f``/``torque`` plus the
    reactions of the pairs in which it is the second member (summed from zero in pair
    order, then added: ``f_i = row sum + reaction sum``), then, with ``body``, gravity
    ``m g`` and the drags ``-gamma_bg v``, ``-gamma_rot omega``. ``gathered``: the contact
    pass scattered the reactions already (one thread), only the body forces are added."""
    fr = fj.reshape(-1)  # the reaction records (FJ_COLUMNS), at slots
    no_jk = np.empty(0, np.int32)  # read only for records at pairs
    for i in prange(f.shape[0]):
        s0 = f[i, 0]
        s1 = f[i, 1]
        s2 = f[i, 2]
        q0 = torque[i, 0]
        q1 = torque[i, 1]
        q2 = torque[i, 2]
        if not gathered:
            g0, g1, g2, h0, h1, h2 = _reaction_sum(i, jstart, no_jk, fr, False, False)
            s0 = s0 + g0
            s1 = s1 + g1
            s2 = s2 + g2
            q0 = q0 + h0
            q1 = q1 + h1
            q2 = q2 + h2
        if body:
            s0 += mass[i] * gx - gamma_bg * v[i, 0]
            s1 += mass[i] * gy - gamma_bg * v[i, 1]
            s2 += mass[i] * gz - gamma_bg * v[i, 2]
            q0 -= gamma_rot * omega[i, 0]
            q1 -= gamma_rot * omega[i, 1]
            q2 -= gamma_rot * omega[i, 2]
        f[i, 0] = s0
        f[i, 1] = s1
        f[i, 2] = s2
        torque[i, 0] = q0
        torque[i, 1] = q1
        torque[i, 2] = q2
