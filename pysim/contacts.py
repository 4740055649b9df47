"""The contact loop: forces, torques, virial and the contact table from the pairs.

Two small scalar functions hold the physics of a pair for every particle shape
(spheres are spherocylinders with ``L = 0``), every normal law, friction and cohesion:
:func:`spine_gap` (closest points) and :func:`pair_force` (the laws of
:mod:`pysim.forces`). They take and return scalars only, so that the hot loops pass no
arrays to them (an array argument costs atomic reference-count updates per call). Two
loops call them:

* :func:`pair_pass` + :func:`reduce_pass`, the force evaluation of every step, on any
  number of threads. ``pair_pass`` walks the rows of the pair list (particle ``i``
  owns its pairs ``(i, j > i)`` and their tangential springs ``hist``), sums the forces
  and torques on ``i`` in row order and stores the reaction on ``j`` per pair (``fj``,
  at the pair's place in the transposed list, so that the reactions on ``j`` lie
  together in pair order); ``reduce_pass`` then adds to each particle ``p`` the
  reactions of the pairs in which it is the second member, summed from zero in pair
  order, to the row sum. On one
  thread (``scatter``) the rows run in order and the pass adds each reaction to the
  second particle at once: when row ``i`` is reached the reactions on ``i`` are
  complete, and ``f_i = row sum + reaction sum`` is the same sum in the same order, with
  no per-pair store and gather. Global sums (elastic energy, contacts, virial) are taken
  per fixed block of rows and the block sums added in block order. Nothing depends on
  how rows are shared among threads, so 1 and 2 threads give the same bits. Listed rod
  pairs that the motion since the list build keeps out of reach are skipped
  (:func:`pysim.neighbors.motion_bound`; they would add nothing).
  :func:`sphere_pass` replaces ``pair_pass`` when every particle is a sphere: the same
  sums in the same order, with the contact laws of a chunk of pairs evaluated together
  on SIMD lanes (gather, laws, scatter). :func:`rod_pass` replaces it for rods with one
  bond per pair: the closest points and the laws of a chunk on SIMD lanes, the same
  bits (``end_bonds`` rods keep ``pair_pass``). These two scatter on threads as well:
  each thread takes a contiguous part of the rows and adds the reactions at once, except
  on the few particles that also receive reactions from an earlier part, whose
  reactions are stored per pair and summed in pair order afterwards (the same sum).
* :func:`pair_forces`, a plain serial loop in pair order that can also record the
  contact table (used with each dump, and by the tests).

Pairs out of contact add nothing and every pair's contribution is a pure function of
its two particles, so forces do not depend on how many extra pairs the Verlet list
holds: results are bit-identical across list rebuilds and restarts.

With ``spine_contact = "end_bonds"`` (:func:`end_bond`, frictionless only) a rod pair is
up to four bonds, each a contact of the same law; a pair's forces, torques and virial
are the sums over its bonds, and its recorded contact has the summed force, the
force-weighted mean point, and the normal and overlap of the deepest bond.

Geometry (science.md section 2): closest points ``p_i = x_i + s u_i`` and
``p_j = x_j + t u_j`` of the spines (:func:`pysim.geometry.closest_params`), distance
``d = |p_j - p_i|``, overlap ``delta = R_i + R_j - d``, normal ``n = (p_j - p_i)/d``,
contact point in the middle of the overlap ``c = p_i + (R_i - delta/2) n``.
"""
from __future__ import annotations

import numpy as np

from pysim.forces import (D_COH, END_BONDS, F_COH, GAMMA_N, GAMMA_T, HERTZ, HOOKE, K_N, K_T,
                          KEEP_SPRING, MU, cohesion_force, elastic_energy, normal_force,
                          tangential_force)
from pysim.geometry import closest_params, closest_select
from pysim.jit import inline_njit, njit, pnjit, prange, prefetch_write

#: columns of a recorded contact: point (3), normal (3), overlap, force on i (3)
REC_COLUMNS = 10
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
#: rows per block of the parallel pair loop (fixed: results never depend on threads)
BLOCK = 64
#: columns of a block's partial sums: elastic energy, contacts, virial (9), then the block's
#: largest overlap fraction ``delta / (2 min(R_i, R_j))`` and its pair plus one (0: none)
_STATS = 13
_WORST, _WORST_K = 11, 12


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
def end_bond(d0, d1, d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj, k):
    """Bond ``k`` of the end-bond geometry, ``d = x_j - x_i``: ``k = 0, 1`` the end
    ``s = -h_i, +h_i`` of spine i against the closest point of spine j, ``k = 2, 3`` the
    end ``t = -h_j, +h_j`` of spine j against spine i. Returns ``a = p_i - x_i`` and the
    gap ``g = p_j - p_i`` as :func:`spine_gap`.

    Summing the contact law over the four bonds gives an energy that is smooth where the
    closest-point law has a kink (parallel side contacts: the closest point jumps from one
    end of the overlap to the other); a parallel side contact becomes two bonds at the
    ends of the overlapping projection (science.md's two-bond count), a tip-side contact
    one bond, a tip-tip contact two coincident ones. In 2-D the spines of a small overlap
    never cross, so the closest points are always among these bonds."""
    if k < 2:
        s = -hi if k == 0 else hi
        t = uj0 * (s * ui0 - d0) + uj1 * (s * ui1 - d1) + uj2 * (s * ui2 - d2)
        t = min(max(t, -hj), hj)
    else:
        t = -hj if k == 2 else hj
        s = ui0 * (d0 + t * uj0) + ui1 * (d1 + t * uj1) + ui2 * (d2 + t * uj2)
        s = min(max(s, -hi), hi)
    a0 = s * ui0
    a1 = s * ui1
    a2 = s * ui2
    return a0, a1, a2, d0 + t * uj0 - a0, d1 + t * uj1 - a1, d2 + t * uj2 - a2


@njit
def pair_force(g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0, vi1, vi2, wi0, wi1,
               wi2, vj0, vj1, vj2, wj0, wj1, wj2, x0, x1, x2, law, kn, gn, kt, gt, mu, fcoh,
               dcoh, friction, dt):
    """Force of a pair within reach: gap ``g`` (``|g|^2 = dist2``), ``a = p_i - x_i``,
    ``d = x_j - x_i``, radii, velocities and spins of both, tangential spring ``x``.

    Contact-point velocity ``v_rel = (v_i + w_i x (c - x_i)) - (v_j + w_j x (c - x_j))``,
    overlap rate ``v_rel . n``, normal force (when ``delta > 0``) plus cohesion,
    tangential force with the spring when ``friction`` (reset to zero when not
    touching); force on i ``F = -f_n n + F_t``, on j ``-F``.

    Returns ``(F (3), c (3), e (3), n (3), delta, x (3))``: ``c`` and ``e`` the contact
    point relative to ``x_i`` and ``x_j``, ``n`` the unit normal, ``x`` the new spring.
    """
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
    fn = 0.0
    if delta > 0.0:
        fn = normal_force(law, kn, gn, delta, vn, rs)
    if fcoh != 0.0:
        fn += cohesion_force(fcoh, dcoh, delta)
    ft0 = 0.0
    ft1 = 0.0
    ft2 = 0.0
    if friction:
        if delta > 0.0:
            ft0, ft1, ft2, x0, x1, x2 = tangential_force(
                kt, gt, mu, fn, x0, x1, x2, n0, n1, n2, vr0 - vn * n0, vr1 - vn * n1,
                vr2 - vn * n2, dt, (law & KEEP_SPRING) != 0)
        else:
            x0 = 0.0
            x1 = 0.0
            x2 = 0.0
    return (-fn * n0 + ft0, -fn * n1 + ft1, -fn * n2 + ft2, c0, c1, c2, e0, e1, e2, n0, n1,
            n2, delta, x0, x1, x2)


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


@pnjit
def pair_pass(x, v, omega, u, radius, half, box, periodic, pj, istart, jstart, jk, hist, law,
              p, friction, dt, rods, f, torque, fj, stats, virial, sep_sigma=0.0,
              sep_shrink=0.0, scatter=False, worst=None):
    """Forces and torques of every listed pair on its first particle, written to
    ``f``/``torque`` (overwritten: row sums), and the reaction on the second particle
    stored per pair in ``fj`` (force, torque; zero out of contact; at the pair's place in
    the transposed list ``jstart``/``jk``, :func:`_slot`) for :func:`reduce_pass`.
    ``rods`` False skips the spine geometry (all spheres). With ``stats`` also the virial
    ``virial[a, b] = sum (x_j - x_i)_a F_b`` (overwritten), and returns ``(elastic
    energy, contacts)``; otherwise ``(0.0, 0)``. Contacts are the pairs that carry a
    force: touching (``delta > 0``) or, with cohesion, closer than ``d_c``.

    With ``sep_sigma > 0`` and the separation row :data:`SEP` in ``fj``, a pair whose
    spine distance is bound to exceed its reach, ``sep_sigma g_ref - sep_shrink > R_i +
    R_j + d_c`` (:func:`pysim.neighbors.motion_bound`), is not evaluated: it would add
    nothing, so the results are the same bits, and listed rods that stay out of reach
    skip the closest-point search.

    ``scatter`` (the rows run in order, on one thread) adds the reactions straight
    to ``f``/``torque`` of the second particle instead of storing them in ``fj``: when row
    ``i`` is reached its reactions are complete, and it writes ``f_i = row sum + reaction
    sum``, the same bits as :func:`reduce_pass` gives (no ``reduce_pass`` gather needed).

    With ``stats`` and a ``worst`` array (2,), also writes the largest overlap and its
    pair (:func:`block_worst`); not with ``end_bonds``, whose bonds are not the closest
    points (``worst`` is then left as it was)."""
    n = x.shape[0]
    kn, gn, kt, gt, mu = p[K_N], p[GAMMA_N], p[K_T], p[GAMMA_T], p[MU]
    fcoh, dcoh = p[F_COH], p[D_COH]
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    use_sep = sep_sigma > 0.0 and fj.shape[0] > SEP
    ends = rods and p[END_BONDS] != 0.0
    nbond = 4 if ends else 1
    nb = (n + BLOCK - 1) // BLOCK
    blk = np.zeros((nb if stats else 0, _STATS))
    if scatter:
        _zero_rows(f, torque, 0, f.shape[0])
    no_parts = np.empty(0, np.bool_)  # no shared particles (reactions: all or none stored)
    fr = fj.reshape(-1)  # the reaction records (FJ_COLUMNS)
    # with scatter one loop iteration holds every row, so the rows run in order on one
    # thread whatever the number of threads (a race otherwise)
    nt = 1 if scatter else nb
    for t in prange(nt):
        i_end = n if scatter else min(n, (t + 1) * BLOCK)
        for i in range(0 if scatter else t * BLOCK, i_end):
            b = i // BLOCK
            xi0, xi1, xi2 = x[i, 0], x[i, 1], x[i, 2]
            ui0, ui1, ui2 = u[i, 0], u[i, 1], u[i, 2]
            vi0, vi1, vi2 = v[i, 0], v[i, 1], v[i, 2]
            wi0, wi1, wi2 = omega[i, 0], omega[i, 1], omega[i, 2]
            ri = radius[i]
            hi = half[i]
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            q0 = 0.0
            q1 = 0.0
            q2 = 0.0
            for k in range(istart[i], istart[i + 1]):
                j = pj[k]
                rj = radius[j]
                reach = ri + rj + dcoh
                # out of reach by the motion bound (a margin far above rounding): no force
                if use_sep and sep_sigma * fj[SEP, k] - sep_shrink > reach * (1.0 + 1e-9):
                    if friction:
                        hist[k, 0] = 0.0
                        hist[k, 1] = 0.0
                        hist[k, 2] = 0.0
                    if not scatter:
                        _no_reaction(_slot(k, j, jstart, jk), fr)
                    continue
                d0, d1, d2 = min_image(x[j, 0] - xi0, x[j, 1] - xi1, x[j, 2] - xi2, b0, b1, b2,
                                       p0, p1, p2)
                uj0, uj1, uj2, hj = u[j, 0], u[j, 1], u[j, 2], half[j]
                # sums over the bonds of the pair (one, or four end bonds)
                F0 = 0.0
                F1 = 0.0
                F2 = 0.0
                t0 = 0.0
                t1 = 0.0
                t2 = 0.0
                r0 = 0.0
                r1 = 0.0
                r2 = 0.0
                pe = 0.0
                touching = False
                for kb in range(nbond):
                    a0 = 0.0
                    a1 = 0.0
                    a2 = 0.0
                    g0, g1, g2 = d0, d1, d2
                    if ends:
                        a0, a1, a2, g0, g1, g2 = end_bond(d0, d1, d2, ui0, ui1, ui2, hi, uj0,
                                                          uj1, uj2, hj, kb)
                    elif rods:
                        a0, a1, a2, g0, g1, g2 = spine_gap(d0, d1, d2, ui0, ui1, ui2, hi, uj0,
                                                           uj1, uj2, hj)
                    dist2 = g0 * g0 + g1 * g1 + g2 * g2
                    if dist2 >= reach * reach:
                        continue
                    touching = True
                    h0 = 0.0
                    h1 = 0.0
                    h2 = 0.0
                    if friction:
                        h0, h1, h2 = hist[k, 0], hist[k, 1], hist[k, 2]
                    (B0, B1, B2, c0, c1, c2, e0, e1, e2, n0, n1, n2, delta, h0, h1,
                     h2) = pair_force(g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0,
                                      vi1, vi2, wi0, wi1, wi2, v[j, 0], v[j, 1], v[j, 2],
                                      omega[j, 0], omega[j, 1], omega[j, 2], h0, h1, h2, law,
                                      kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt)
                    if friction:
                        hist[k, 0] = h0
                        hist[k, 1] = h1
                        hist[k, 2] = h2
                    F0 += B0
                    F1 += B1
                    F2 += B2
                    t0 += c1 * B2 - c2 * B1
                    t1 += c2 * B0 - c0 * B2
                    t2 += c0 * B1 - c1 * B0
                    r0 -= e1 * B2 - e2 * B1
                    r1 -= e2 * B0 - e0 * B2
                    r2 -= e0 * B1 - e1 * B0
                    if stats and delta > 0.0:
                        pe += elastic_energy(law, kn, delta, ri + rj)
                        if not ends:
                            _note_overlap(blk, b, delta, ri, rj, k)
                if not touching:
                    if friction:
                        hist[k, 0] = 0.0
                        hist[k, 1] = 0.0
                        hist[k, 2] = 0.0
                    if not scatter:
                        _no_reaction(_slot(k, j, jstart, jk), fr)
                    continue
                s0 += F0
                s1 += F1
                s2 += F2
                q0 += t0
                q1 += t1
                q2 += t2
                if scatter:
                    _reaction(j, True, no_parts, f, torque, F0, F1, F2, r0, r1, r2)
                else:
                    _store(_slot(k, j, jstart, jk), fr, F0, F1, F2, r0, r1, r2)
                if stats:
                    blk[b, 0] += pe
                    blk[b, 1] += 1.0
                    blk[b, 2] += d0 * F0
                    blk[b, 3] += d0 * F1
                    blk[b, 4] += d0 * F2
                    blk[b, 5] += d1 * F0
                    blk[b, 6] += d1 * F1
                    blk[b, 7] += d1 * F2
                    blk[b, 8] += d2 * F0
                    blk[b, 9] += d2 * F1
                    blk[b, 10] += d2 * F2
            _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, scatter)
    if stats:
        if worst is not None and not ends:
            block_worst(blk, worst)
        return block_totals(blk, virial)
    return 0.0, 0


#: listed pairs per chunk of :func:`sphere_pass`. Its scratch holds ``_NS`` rows of ``CAP``
#: values; with a stride known at compile time the compiler can tell that the rows do not
#: overlap, and runs :func:`_sphere_laws` on SIMD lanes (it gives up on runtime strides:
#: too many arrays to check for overlap). The column indices into the scratches (``S``, and
#: the rods' ``A`` and ``R``) and the pair and particle numbers loaded from arrays in the hot
#: loops are cast to ``np.uint64``: Numba wraps a signed index that LLVM cannot prove
#: non-negative (``a[-1]``), three instructions per access, and it cannot prove it for a
#: chunk's columns (the small index lists ``kk``, ``ka``... are still written with signed
#: counters). 96, not 128: the scratch (31 rows, 23 KB) then leaves room in a 48 KB
#: first-level cache. The rods' chunks (:data:`RCAP`) gained nothing from 96 and lost with
#: 64 (docs/performance.md)
CAP = 96
# rows of the scratch: inputs (gap d, |d|^2, radii, velocities and spins of i and j, spring),
# then outputs (force on i, torque on i, torque on j, overlap); the spring is updated in place
_D, _DIST2, _RI, _RJ, _VI, _VJ, _WI, _WJ, _H = 0, 3, 4, 5, 6, 9, 12, 15, 18
_F, _T, _U, _DELTA = 21, 24, 27, 30
_NS = 31
#: the laws run on a multiple of this many columns (the columns past the pairs in reach
#: hold an earlier chunk's values, computed and ignored): LLVM runs the loop on 8-wide
#: vectors and the remainder one pair at a time, so a chunk's last pairs would each cost a
#: whole scalar law. 8 measured best with :data:`CAP`'s chunks of 96 (16 with the earlier
#: 128: docs/performance.md), so measure again when CAP changes
PAD = 8


@njit
def _sphere_gather(k0, k1, pi, pj, x, v, omega, radius, b0, b1, b2, p0, p1, p2, hist, dcoh,
                   friction, S, kk, ko):
    """Copy the listed pairs ``k0:k1`` within reach (``|d| < R_i + R_j + d_c``) into the
    scratch ``S``, one column each in pair order, ``kk`` their pair indices; zero the
    spring of every pair out of reach. Two loops: the first takes the gap of every pair
    without branches on the pair (each is copied to the next free column, which only a
    pair in reach keeps; ``ko`` collects the others), the second copies velocities, spins
    and springs of the pairs in reach only. Returns the number of pairs in reach. The
    minimum image is two selects per axis (the same values as an ``if``/``elif``, and
    faster: docs/performance.md). The first loop runs on unsigned pair numbers (no
    negative-index wraparound, see :data:`CAP`)."""
    hb0, hb1, hb2 = 0.5 * b0, 0.5 * b1, 0.5 * b2
    m = 0
    mo = 0
    for k in range(np.uint64(k0), np.uint64(k1)):
        i = np.uint64(pi[k])  # unsigned: no negative-index wraparound
        j = np.uint64(pj[k])
        d0 = x[j, 0] - x[i, 0]
        d1 = x[j, 1] - x[i, 1]
        d2 = x[j, 2] - x[i, 2]
        if p0:
            d0 = d0 - b0 if d0 > hb0 else d0
            d0 = d0 + b0 if d0 < -hb0 else d0
        if p1:
            d1 = d1 - b1 if d1 > hb1 else d1
            d1 = d1 + b1 if d1 < -hb1 else d1
        if p2:
            d2 = d2 - b2 if d2 > hb2 else d2
            d2 = d2 + b2 if d2 < -hb2 else d2
        dist2 = d0 * d0 + d1 * d1 + d2 * d2
        ri = radius[i]
        rj = radius[j]
        reach = ri + rj + dcoh
        kk[m] = k
        ko[mo] = k
        S[np.uint64(_D * CAP + m)] = d0
        S[np.uint64((_D + 1) * CAP + m)] = d1
        S[np.uint64((_D + 2) * CAP + m)] = d2
        S[np.uint64(_DIST2 * CAP + m)] = dist2
        S[np.uint64(_RI * CAP + m)] = ri
        S[np.uint64(_RJ * CAP + m)] = rj
        inside = dist2 < reach * reach
        m += inside
        mo += not inside
    for q in range(m):
        k = np.uint64(kk[q])
        i = np.uint64(pi[k])
        j = np.uint64(pj[k])
        for c in range(3):
            S[np.uint64((_VI + c) * CAP + q)] = v[i, c]
            S[np.uint64((_VJ + c) * CAP + q)] = v[j, c]
        if friction:
            for c in range(3):
                S[np.uint64((_WI + c) * CAP + q)] = omega[i, c]
                S[np.uint64((_WJ + c) * CAP + q)] = omega[j, c]
                S[np.uint64((_H + c) * CAP + q)] = hist[k, c]
    if friction:
        for q in range(mo):  # out of reach: the spring restarts
            k = np.uint64(ko[q])
            for c in range(3):
                hist[k, c] = 0.0
    return m


@njit
def _sphere_laws(S, mc, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt):
    """The contact laws (:func:`pair_force` for spheres) of the ``mc`` gathered pairs,
    written with selects instead of branches on the pair so that the loop runs on SIMD
    lanes: the same operations in the same order, so the same bits. Writes the force on
    i, the torques on i and j, the new spring and the overlap into ``S``; on the first
    ``mc`` columns rounded up to a multiple of :data:`PAD`."""
    cohesive = fcoh != 0.0
    keep_spring = (law & KEEP_SPRING) != 0
    mc = min(CAP, (mc + PAD - 1) // PAD * PAD)
    if not friction:
        for m in range(mc):
            d0 = S[np.uint64(_D * CAP + m)]
            d1 = S[np.uint64((_D + 1) * CAP + m)]
            d2 = S[np.uint64((_D + 2) * CAP + m)]
            rs = S[np.uint64(_RI * CAP + m)] + S[np.uint64(_RJ * CAP + m)]
            dist = np.sqrt(S[np.uint64(_DIST2 * CAP + m)])
            inv = 1.0 / dist
            n0 = d0 * inv
            n1 = d1 * inv
            n2 = d2 * inv
            delta = rs - dist
            dv0 = S[np.uint64(_VI * CAP + m)] - S[np.uint64(_VJ * CAP + m)]
            dv1 = S[np.uint64((_VI + 1) * CAP + m)] - S[np.uint64((_VJ + 1) * CAP + m)]
            dv2 = S[np.uint64((_VI + 2) * CAP + m)] - S[np.uint64((_VJ + 2) * CAP + m)]
            vn = dv0 * n0 + dv1 * n1 + dv2 * n2
            fn = normal_force(law, kn, gn, delta, vn, rs) if delta > 0.0 else 0.0
            if cohesive:
                fn += cohesion_force(fcoh, dcoh, delta)
            S[np.uint64(_DELTA * CAP + m)] = delta
            S[np.uint64(_F * CAP + m)] = -fn * n0
            S[np.uint64((_F + 1) * CAP + m)] = -fn * n1
            S[np.uint64((_F + 2) * CAP + m)] = -fn * n2
        return
    for m in range(mc):
        d0 = S[np.uint64(_D * CAP + m)]
        d1 = S[np.uint64((_D + 1) * CAP + m)]
        d2 = S[np.uint64((_D + 2) * CAP + m)]
        ri = S[np.uint64(_RI * CAP + m)]
        rs = ri + S[np.uint64(_RJ * CAP + m)]
        vi0 = S[np.uint64(_VI * CAP + m)]
        vi1 = S[np.uint64((_VI + 1) * CAP + m)]
        vi2 = S[np.uint64((_VI + 2) * CAP + m)]
        vj0 = S[np.uint64(_VJ * CAP + m)]
        vj1 = S[np.uint64((_VJ + 1) * CAP + m)]
        vj2 = S[np.uint64((_VJ + 2) * CAP + m)]
        dist = np.sqrt(S[np.uint64(_DIST2 * CAP + m)])
        inv = 1.0 / dist
        n0 = d0 * inv
        n1 = d1 * inv
        n2 = d2 * inv
        delta = rs - dist
        touch = delta > 0.0
        vn = (vi0 - vj0) * n0 + (vi1 - vj1) * n1 + (vi2 - vj2) * n2
        fn = normal_force(law, kn, gn, delta, vn, rs) if touch else 0.0
        if cohesive:
            fn += cohesion_force(fcoh, dcoh, delta)
        F0 = -fn * n0
        F1 = -fn * n1
        F2 = -fn * n2
        S[np.uint64(_DELTA * CAP + m)] = delta
        ar = ri - 0.5 * delta  # contact point c = ar n from x_i, e = c - d
        er = ar - dist
        c0 = ar * n0
        c1 = ar * n1
        c2 = ar * n2
        e0 = er * n0
        e1 = er * n1
        e2 = er * n2
        wi0 = S[np.uint64(_WI * CAP + m)]
        wi1 = S[np.uint64((_WI + 1) * CAP + m)]
        wi2 = S[np.uint64((_WI + 2) * CAP + m)]
        wj0 = S[np.uint64(_WJ * CAP + m)]
        wj1 = S[np.uint64((_WJ + 1) * CAP + m)]
        wj2 = S[np.uint64((_WJ + 2) * CAP + m)]
        vr0 = vi0 + (wi1 * c2 - wi2 * c1) - vj0 - (wj1 * e2 - wj2 * e1)
        vr1 = vi1 + (wi2 * c0 - wi0 * c2) - vj1 - (wj2 * e0 - wj0 * e2)
        vr2 = vi2 + (wi0 * c1 - wi1 * c0) - vj2 - (wj0 * e1 - wj1 * e0)
        vt = vr0 * n0 + vr1 * n1 + vr2 * n2
        t0 = vr0 - vt * n0
        t1 = vr1 - vt * n1
        t2 = vr2 - vt * n2
        f0, f1, f2, x0, x1, x2 = tangential_force(
            kt, gt, mu, fn, S[np.uint64(_H * CAP + m)], S[np.uint64((_H + 1) * CAP + m)],
            S[np.uint64((_H + 2) * CAP + m)], n0, n1, n2, t0, t1, t2, dt, keep_spring)
        # out of contact (a cohesive gap): no tangential force, the spring restarts
        f0 = f0 if touch else 0.0
        f1 = f1 if touch else 0.0
        f2 = f2 if touch else 0.0
        S[np.uint64(_H * CAP + m)] = x0 if touch else 0.0
        S[np.uint64((_H + 1) * CAP + m)] = x1 if touch else 0.0
        S[np.uint64((_H + 2) * CAP + m)] = x2 if touch else 0.0
        S[np.uint64(_F * CAP + m)] = F0 + f0
        S[np.uint64((_F + 1) * CAP + m)] = F1 + f1
        S[np.uint64((_F + 2) * CAP + m)] = F2 + f2
        S[np.uint64(_T * CAP + m)] = c1 * f2 - c2 * f1
        S[np.uint64((_T + 1) * CAP + m)] = c2 * f0 - c0 * f2
        S[np.uint64((_T + 2) * CAP + m)] = c0 * f1 - c1 * f0
        S[np.uint64(_U * CAP + m)] = -(e1 * f2 - e2 * f1)
        S[np.uint64((_U + 1) * CAP + m)] = -(e2 * f0 - e0 * f2)
        S[np.uint64((_U + 2) * CAP + m)] = -(e0 * f1 - e1 * f0)


@njit
def _sphere_scatter(k0, k1, i, hi, pj, istart, hist, law, kn, friction, f, torque, stats, blk,
                    b, S, kk, mc, solo, own, kl, s0, s1, s2, q0, q1, q2):
    """Add the forces of the ``mc`` pairs in reach of the chunk ``k0:k1`` in pair order, as
    :func:`pair_pass` does, and store their springs. ``i`` is the row of pair ``k0``, ``s``
    and ``q`` its partial force and torque sums; rows (of block ``b``, up to ``hi``) that
    end within the chunk are completed (:func:`_finish_row`). The reaction on ``j`` is
    added to ``f_j`` at once in the ``solo`` part or when ``own[j]`` (:func:`_own_part`),
    else stored after the chunk (:func:`_store_chunk`). Adds
    the block's energy, contacts and virial to ``blk[b]``. Returns the row and partial sums
    after the chunk, and the number of reactions left out (their columns in ``kl``)."""
    nl = 0
    for m in range(mc):
        k = kk[m]
        uk = np.uint64(k)  # unsigned: no negative-index wraparound
        while istart[i + 1] <= k:
            _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, solo or own[i])
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            q0 = 0.0
            q1 = 0.0
            q2 = 0.0
            i += 1
        F0 = S[np.uint64(_F * CAP + m)]
        F1 = S[np.uint64((_F + 1) * CAP + m)]
        F2 = S[np.uint64((_F + 2) * CAP + m)]
        t0 = 0.0
        t1 = 0.0
        t2 = 0.0
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        if friction:
            t0 = S[np.uint64(_T * CAP + m)]
            t1 = S[np.uint64((_T + 1) * CAP + m)]
            t2 = S[np.uint64((_T + 2) * CAP + m)]
            u0 = S[np.uint64(_U * CAP + m)]
            u1 = S[np.uint64((_U + 1) * CAP + m)]
            u2 = S[np.uint64((_U + 2) * CAP + m)]
            hist[uk, 0] = S[np.uint64(_H * CAP + m)]
            hist[uk, 1] = S[np.uint64((_H + 1) * CAP + m)]
            hist[uk, 2] = S[np.uint64((_H + 2) * CAP + m)]
        s0 += F0
        s1 += F1
        s2 += F2
        q0 += t0
        q1 += t1
        q2 += t2
        if not _reaction(pj[uk], solo, own, f, torque, F0, F1, F2, u0, u1, u2):
            kl[nl] = m
            nl += 1
        if stats:
            delta = S[np.uint64(_DELTA * CAP + m)]
            if delta > 0.0:
                ri = S[np.uint64(_RI * CAP + m)]
                rj = S[np.uint64(_RJ * CAP + m)]
                blk[b, 0] += elastic_energy(law, kn, delta, ri + rj)
                _note_overlap(blk, b, delta, ri, rj, k)
            blk[b, 1] += 1.0
            d0 = S[np.uint64(_D * CAP + m)]
            d1 = S[np.uint64((_D + 1) * CAP + m)]
            d2 = S[np.uint64((_D + 2) * CAP + m)]
            blk[b, 2] += d0 * F0
            blk[b, 3] += d0 * F1
            blk[b, 4] += d0 * F2
            blk[b, 5] += d1 * F0
            blk[b, 6] += d1 * F1
            blk[b, 7] += d1 * F2
            blk[b, 8] += d2 * F0
            blk[b, 9] += d2 * F1
            blk[b, 10] += d2 * F2
    while i < hi and istart[i + 1] <= k1:  # the rows that end with the chunk
        _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, solo or own[i])
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        i += 1
    return i, s0, s1, s2, q0, q1, q2, nl


@njit
def _sphere_part(bl, bh, nt, x, v, omega, radius, b0, b1, b2, p0, p1, p2, pi, pj, istart,
                 jstart, jk, hist, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt, f, torque,
                 fj, stats, blk, own):
    """The part of :func:`sphere_pass` on blocks ``bl:bh`` (of ``nt`` parts). With one part
    the scatter is called with ``solo`` a constant, so that it compiles without the
    per-pair test of the shared particles (a variable flag made the pass slower)."""
    n = x.shape[0]
    fr = fj.reshape(-1)  # the reaction records (FJ_COLUMNS)
    S = np.zeros(_NS * CAP)  # zeros: the padding columns never hold garbage
    kk = np.empty(CAP, np.int64)
    ko = np.empty(CAP, np.int64)
    kl = np.empty(CAP, np.int64)
    _zero_rows(f, torque, bl * BLOCK, min(n, bh * BLOCK))  # no other part adds to them
    for b in range(bl, bh):
        lo = b * BLOCK
        hi = min(n, lo + BLOCK)
        i = lo
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        k0 = istart[lo]
        k_end = istart[hi]
        while True:
            k1 = min(k_end, k0 + CAP)
            mc = _sphere_gather(k0, k1, pi, pj, x, v, omega, radius, b0, b1, b2, p0, p1,
                                p2, hist, dcoh, friction, S, kk, ko)
            _sphere_laws(S, mc, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt)
            if nt == 1:  # a constant: the one-part scatter compiles apart, without the test
                i, s0, s1, s2, q0, q1, q2, nl = _sphere_scatter(
                    k0, k1, i, hi, pj, istart, hist, law, kn, friction, f, torque, stats, blk,
                    b, S, kk, mc, True, own, kl, s0, s1, s2, q0, q1, q2)
            else:  # stats a constant too: each variant compiles without the stats branch
                if stats:
                    i, s0, s1, s2, q0, q1, q2, nl = _sphere_scatter(
                        k0, k1, i, hi, pj, istart, hist, law, kn, friction, f, torque, True,
                        blk, b, S, kk, mc, False, own, kl, s0, s1, s2, q0, q1, q2)
                else:
                    i, s0, s1, s2, q0, q1, q2, nl = _sphere_scatter(
                        k0, k1, i, hi, pj, istart, hist, law, kn, friction, f, torque, False,
                        blk, b, S, kk, mc, False, own, kl, s0, s1, s2, q0, q1, q2)
                _store_chunk(pj, jstart, jk, fr, S, CAP, _F, _U, friction, kk, kl, nl, True)
            k0 = k1
            if k0 >= k_end:
                break


@pnjit
def sphere_pass(x, v, omega, radius, box, periodic, pi, pj, istart, jstart, jk, hist, law, p,
                friction, dt, f, torque, fj, stats, virial, parts=1, worst=None, own=None,
                own_ok=False):
    """:func:`pair_pass` for spheres only (every ``L = 0``): the same equations and the
    same outputs, several times faster. The normal passes through both centres, so
    normal forces exert no torque; with friction the tangential force does, ``c x F_t``
    on i and ``-e x F_t`` on j (``c``, ``e`` the contact point relative to the centres).
    The minimum image is taken by comparison with half the box (positions are wrapped
    into the box). ``pi`` the first member of each pair, ``jstart``/``jk`` the
    transposed list (:func:`pysim.neighbors.transpose`). Writes the complete pair
    forces and torques (no :func:`reduce_pass` needed).

    The rows are cut into ``parts`` contiguous parts (:func:`part_bounds`, one per
    thread). A part adds each reaction to its second particle at once, as
    :func:`pair_pass` does on one thread, unless that particle lies past the part or
    also receives reactions from an earlier part (``shared``): those reactions are
    stored per pair (after each chunk, :func:`_store_chunk`, in the pair's record) and
    summed from zero in pair order after the parts (:func:`_close_part`). Which
    particles those are is found before the parts run (:func:`own_flags`; ``own``, n
    flags kept by the caller, holds them already with ``own_ok``, else they are written
    there), so that the scatter tests one flag per pair. Each part zeroes the forces of
    its rows as it starts: no other part adds to them. Either way ``f_i = row sum +
    reaction sum`` in pair order, so any number of parts gives the same bits; with
    spatially sorted particles few are shared, and the threads touch no more memory than
    one thread does. With more than one part the records of the shared particles' pairs
    in ``fj`` must hold zero on entry (:func:`clear_slots`); they are left at zero.

    Each block of rows runs in chunks of at most ``CAP`` listed pairs, in three loops:
    :func:`_sphere_gather` copies the pairs in reach into a scratch, one column each,
    :func:`_sphere_laws` evaluates their laws on SIMD lanes, and :func:`_sphere_scatter`
    adds the forces in pair order. The row sums carry over from chunk to chunk, so the
    sums, and the bits, do not depend on the chunks. ``worst`` as in :func:`pair_pass`."""
    n = x.shape[0]
    kn, gn, kt, gt, mu = p[K_N], p[GAMMA_N], p[K_T], p[GAMMA_T], p[MU]
    fcoh, dcoh = p[F_COH], p[D_COH]
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    nb = (n + BLOCK - 1) // BLOCK
    blk = np.zeros((nb if stats else 0, _STATS))
    nt = max(1, parts)
    bounds = part_bounds(istart, nb, nt)
    ownv = _part_flags(bounds, istart, jstart, jk, n,
                       own if own is not None else np.empty(0, np.bool_), own_ok)
    for t in prange(nt):
        _sphere_part(bounds[t], bounds[t + 1], nt, x, v, omega, radius, b0, b1, b2, p0, p1, p2,
                     pi, pj, istart, jstart, jk, hist, law, kn, gn, kt, gt, mu, fcoh, dcoh,
                     friction, dt, f, torque, fj, stats, blk, ownv)
    if nt > 1:
        for t in prange(nt):
            _close_part(bounds[t] * BLOCK, min(n, bounds[t + 1] * BLOCK), jstart, jk,
                        fj.reshape(-1), f, torque, ownv, True)
    if stats:
        if worst is not None:
            block_worst(blk, worst)
        return block_totals(blk, virial)
    return 0.0, 0


# -- rods on SIMD lanes -------------------------------------------------------------------------
#: listed pairs per chunk of :func:`rod_pass` (two scratches of :data:`_NA` and :data:`_NR`
#: rows of ``RCAP`` values: 58 KiB, within L2). 128 rather than 64: the copy of the pairs in
#: reach has twice the independent loads in flight, which counts once the particles no
#: longer fit in the last-level cache; 256 was slower (docs/performance.md)
RCAP = 128
# scratch A, one column per listed pair that the motion bound does not rule out: gap of the
# centres, both axes, half-lengths and radii; then the closest points (a = p_i - x_i, the
# gap g = p_j - p_i, |g|^2)
_AD, _AUI, _AUJ, _AHI, _AHJ, _ARI, _ARJ, _AA, _AG, _ADIST2 = 0, 3, 6, 9, 10, 11, 12, 13, 16, 19
_NA = 20
# scratch R, one column per pair in reach: the geometry, velocities, spins, spring; then
# the force on i, torques on i and j, overlap and elastic energy
_RD, _RA, _RG, _RDIST2, _RRI, _RRJ, _RVI, _RVJ, _RWI, _RWJ, _RH = (0, 3, 6, 9, 10, 11, 12, 15,
                                                                  18, 21, 24)
_RF, _RT, _RU, _RDELTA, _RPE = 27, 30, 33, 36, 37
_NR = 38


@njit
def _rod_gather(k0, k1, pi, pj, x, u, radius, half, b0, b1, b2, p0, p1, p2, use_sep,
                sep_sigma, sep_shrink, reach_max, fj, A, ka, kb, per, dl):
    """The listed pairs ``k0:k1`` that the motion bound does not rule out into the
    columns of scratch ``A``, ``ka`` their pair indices, ``kb`` the others. Returns the two
    counts.

    The bound is :func:`pair_pass`'s test with the largest reach ``reach_max`` (``2
    max R + d_c``) for every pair, so that it reads the pair's stored separation alone:
    the pairs it rules out are first sorted out on the pair stream, and only the pairs
    kept load their rods. It rules out a subset of what the pair's own reach would (the
    same for equal radii); a pair it keeps beyond reach drops out of :func:`_rod_select`
    with the same result (no force, a zero spring). With ``per``, the pairs it keeps are
    tested again with the shares of their own two rods, ``sigma g_ref - dl_i - dl_j``
    (:func:`pysim.neighbors.motion_bound`), before their rods are gathered: the largest
    share belongs to the few rods that moved most, so the rods' own shares rule out many
    more pairs."""
    m = 0
    mo = 0
    lim = reach_max * (1.0 + 1e-9)
    if use_sep:
        for k in range(k0, k1):  # every pair to the next free column of both lists
            keep = not (sep_sigma * fj[SEP, np.uint64(k)] - sep_shrink > lim)
            ka[m] = k
            kb[mo] = k
            m += keep
            mo += not keep
    else:
        for k in range(k0, k1):
            ka[m] = k
            m += 1
    if per:
        mk = m
        m = 0
        for q in range(mk):  # the pairs kept, again to the next free column of ka or kb
            k = np.uint64(ka[q])  # unsigned: no negative-index wraparound
            keep = not (sep_sigma * fj[SEP, k] - dl[np.uint64(pi[k])] - dl[np.uint64(pj[k])]
                        > lim)
            ka[m] = k
            kb[mo] = k
            m += keep
            mo += not keep
    for c in range(m):
        k = np.uint64(ka[c])  # unsigned: no negative-index wraparound
        i = np.uint64(pi[k])
        j = np.uint64(pj[k])
        d0, d1, d2 = min_image(x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2], b0,
                               b1, b2, p0, p1, p2)
        A[np.uint64(_AD * RCAP + c)] = d0
        A[np.uint64((_AD + 1) * RCAP + c)] = d1
        A[np.uint64((_AD + 2) * RCAP + c)] = d2
        for e in range(3):
            A[np.uint64((_AUI + e) * RCAP + c)] = u[i, e]
            A[np.uint64((_AUJ + e) * RCAP + c)] = u[j, e]
        A[np.uint64(_AHI * RCAP + c)] = half[i]
        A[np.uint64(_AHJ * RCAP + c)] = half[j]
        A[np.uint64(_ARI * RCAP + c)] = radius[i]
        A[np.uint64(_ARJ * RCAP + c)] = radius[j]
    return m, mo


@njit
def _rod_geometry(A, ma):
    """Closest points of the ``ma`` gathered pairs (:func:`spine_gap` with every path of
    :func:`pysim.geometry.closest_params` computed and the one it takes selected, so that
    the loop runs on SIMD lanes: the same values, the same bits)."""
    for m in range(ma):
        d0 = A[np.uint64(_AD * RCAP + m)]
        d1 = A[np.uint64((_AD + 1) * RCAP + m)]
        d2 = A[np.uint64((_AD + 2) * RCAP + m)]
        ui0 = A[np.uint64(_AUI * RCAP + m)]
        ui1 = A[np.uint64((_AUI + 1) * RCAP + m)]
        ui2 = A[np.uint64((_AUI + 2) * RCAP + m)]
        uj0 = A[np.uint64(_AUJ * RCAP + m)]
        uj1 = A[np.uint64((_AUJ + 1) * RCAP + m)]
        uj2 = A[np.uint64((_AUJ + 2) * RCAP + m)]
        hi = A[np.uint64(_AHI * RCAP + m)]
        hj = A[np.uint64(_AHJ * RCAP + m)]
        s, t = closest_select(-d0, -d1, -d2, ui0, ui1, ui2, hi, uj0, uj1, uj2, hj)
        a0 = s * ui0
        a1 = s * ui1
        a2 = s * ui2
        g0 = d0 + t * uj0 - a0
        g1 = d1 + t * uj1 - a1
        g2 = d2 + t * uj2 - a2
        A[np.uint64(_AA * RCAP + m)] = a0
        A[np.uint64((_AA + 1) * RCAP + m)] = a1
        A[np.uint64((_AA + 2) * RCAP + m)] = a2
        A[np.uint64(_AG * RCAP + m)] = g0
        A[np.uint64((_AG + 1) * RCAP + m)] = g1
        A[np.uint64((_AG + 2) * RCAP + m)] = g2
        A[np.uint64(_ADIST2 * RCAP + m)] = g0 * g0 + g1 * g1 + g2 * g2


@njit
def _rod_select(A, ma, ka, kb, mo, pi, pj, v, omega, hist, dcoh, friction, R, kr, f, torque):
    """Copy the pairs of ``A`` within reach (``|g| < R_i + R_j + d_c``) with their
    velocities, spins and springs into scratch ``R`` (``kr`` their pair indices); append
    the others to ``kb``. Returns the number in reach and the new length of ``kb``.

    Also prefetches ``f_j`` and ``torque_j``, which :func:`_rod_scatter` updates after the
    laws: at 10^6 rods they lie in the last-level cache or beyond, and the prefetch pays
    there (at 10^4 rods it changes nothing: docs/performance.md)."""
    mr = 0
    for m in range(ma):
        k = ka[m]
        ri = A[np.uint64(_ARI * RCAP + m)]
        rj = A[np.uint64(_ARJ * RCAP + m)]
        reach = ri + rj + dcoh
        dist2 = A[np.uint64(_ADIST2 * RCAP + m)]
        if dist2 >= reach * reach:
            kb[mo] = k
            mo += 1
            continue
        uk = np.uint64(k)  # unsigned: no negative-index wraparound
        i = np.uint64(pi[uk])
        js = pj[uk]
        j = np.uint64(js)
        prefetch_write(f, 3 * js)
        prefetch_write(torque, 3 * js)
        kr[mr] = k
        for c in range(3):
            R[np.uint64((_RD + c) * RCAP + mr)] = A[np.uint64((_AD + c) * RCAP + m)]
            R[np.uint64((_RA + c) * RCAP + mr)] = A[np.uint64((_AA + c) * RCAP + m)]
            R[np.uint64((_RG + c) * RCAP + mr)] = A[np.uint64((_AG + c) * RCAP + m)]
            R[np.uint64((_RVI + c) * RCAP + mr)] = v[i, c]
            R[np.uint64((_RVJ + c) * RCAP + mr)] = v[j, c]
            R[np.uint64((_RWI + c) * RCAP + mr)] = omega[i, c]
            R[np.uint64((_RWJ + c) * RCAP + mr)] = omega[j, c]
        if friction:
            for c in range(3):
                R[np.uint64((_RH + c) * RCAP + mr)] = hist[uk, c]
        R[np.uint64(_RDIST2 * RCAP + mr)] = dist2
        R[np.uint64(_RRI * RCAP + mr)] = ri
        R[np.uint64(_RRJ * RCAP + mr)] = rj
        mr += 1
    return mr, mo


@njit
def _rod_laws(R, mr, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt):
    """:func:`pair_force` of the ``mr`` pairs in reach of ``R``, with selects instead of
    branches on the pair (SIMD lanes), and :func:`pair_pass`'s sums of one bond: the
    force on i, the torques on i and j, the elastic energy (0 out of overlap), the spring
    (in place) and the overlap. On ``mr`` rounded up to :data:`PAD` columns."""
    cohesive = fcoh != 0.0
    keep_spring = (law & KEEP_SPRING) != 0
    mr = min(RCAP, (mr + PAD - 1) // PAD * PAD)
    for m in range(mr):
        g0 = R[np.uint64(_RG * RCAP + m)]
        g1 = R[np.uint64((_RG + 1) * RCAP + m)]
        g2 = R[np.uint64((_RG + 2) * RCAP + m)]
        a0 = R[np.uint64(_RA * RCAP + m)]
        a1 = R[np.uint64((_RA + 1) * RCAP + m)]
        a2 = R[np.uint64((_RA + 2) * RCAP + m)]
        d0 = R[np.uint64(_RD * RCAP + m)]
        d1 = R[np.uint64((_RD + 1) * RCAP + m)]
        d2 = R[np.uint64((_RD + 2) * RCAP + m)]
        ri = R[np.uint64(_RRI * RCAP + m)]
        rj = R[np.uint64(_RRJ * RCAP + m)]
        dist = np.sqrt(R[np.uint64(_RDIST2 * RCAP + m)])
        inv = 1.0 / dist
        n0 = g0 * inv
        n1 = g1 * inv
        n2 = g2 * inv
        rs = ri + rj
        delta = rs - dist
        ar = ri - 0.5 * delta
        c0 = a0 + ar * n0
        c1 = a1 + ar * n1
        c2 = a2 + ar * n2
        e0 = c0 - d0
        e1 = c1 - d1
        e2 = c2 - d2
        wi0 = R[np.uint64(_RWI * RCAP + m)]
        wi1 = R[np.uint64((_RWI + 1) * RCAP + m)]
        wi2 = R[np.uint64((_RWI + 2) * RCAP + m)]
        wj0 = R[np.uint64(_RWJ * RCAP + m)]
        wj1 = R[np.uint64((_RWJ + 1) * RCAP + m)]
        wj2 = R[np.uint64((_RWJ + 2) * RCAP + m)]
        vr0 = (R[np.uint64(_RVI * RCAP + m)] + (wi1 * c2 - wi2 * c1)
               - R[np.uint64(_RVJ * RCAP + m)] - (wj1 * e2 - wj2 * e1))
        vr1 = (R[np.uint64((_RVI + 1) * RCAP + m)] + (wi2 * c0 - wi0 * c2)
               - R[np.uint64((_RVJ + 1) * RCAP + m)] - (wj2 * e0 - wj0 * e2))
        vr2 = (R[np.uint64((_RVI + 2) * RCAP + m)] + (wi0 * c1 - wi1 * c0)
               - R[np.uint64((_RVJ + 2) * RCAP + m)] - (wj0 * e1 - wj1 * e0))
        vn = vr0 * n0 + vr1 * n1 + vr2 * n2
        touch = delta > 0.0
        fn = normal_force(law, kn, gn, delta, vn, rs) if touch else 0.0
        if cohesive:
            fn += cohesion_force(fcoh, dcoh, delta)
        ft0 = 0.0
        ft1 = 0.0
        ft2 = 0.0
        if friction:
            f0, f1, f2, x0, x1, x2 = tangential_force(
                kt, gt, mu, fn, R[np.uint64(_RH * RCAP + m)], R[np.uint64((_RH + 1) * RCAP + m)],
                R[np.uint64((_RH + 2) * RCAP + m)], n0, n1, n2, vr0 - vn * n0, vr1 - vn * n1,
                vr2 - vn * n2, dt, keep_spring)
            ft0 = f0 if touch else 0.0
            ft1 = f1 if touch else 0.0
            ft2 = f2 if touch else 0.0
            R[np.uint64(_RH * RCAP + m)] = x0 if touch else 0.0
            R[np.uint64((_RH + 1) * RCAP + m)] = x1 if touch else 0.0
            R[np.uint64((_RH + 2) * RCAP + m)] = x2 if touch else 0.0
        B0 = -fn * n0 + ft0
        B1 = -fn * n1 + ft1
        B2 = -fn * n2 + ft2
        R[np.uint64(_RF * RCAP + m)] = 0.0 + B0
        R[np.uint64((_RF + 1) * RCAP + m)] = 0.0 + B1
        R[np.uint64((_RF + 2) * RCAP + m)] = 0.0 + B2
        R[np.uint64(_RT * RCAP + m)] = 0.0 + (c1 * B2 - c2 * B1)
        R[np.uint64((_RT + 1) * RCAP + m)] = 0.0 + (c2 * B0 - c0 * B2)
        R[np.uint64((_RT + 2) * RCAP + m)] = 0.0 + (c0 * B1 - c1 * B0)
        R[np.uint64(_RU * RCAP + m)] = 0.0 - (e1 * B2 - e2 * B1)
        R[np.uint64((_RU + 1) * RCAP + m)] = 0.0 - (e2 * B0 - e0 * B2)
        R[np.uint64((_RU + 2) * RCAP + m)] = 0.0 - (e0 * B1 - e1 * B0)
        R[np.uint64(_RDELTA * RCAP + m)] = delta
        R[np.uint64(_RPE * RCAP + m)] = 0.0 + elastic_energy(law, kn, delta, rs) if touch else 0.0


@njit
def _rod_scatter(k1, i, hi, pj, istart, hist, friction, f, torque, stats, blk, b, R, kr, mr,
                 kb, mo, solo, own, kl, s0, s1, s2, q0, q1, q2):
    """As :func:`_sphere_scatter` for the pairs in reach of ``R``: row sums, reactions
    (added to j, or left to :func:`_store_chunk`), springs, and the block's energy,
    contacts and virial; zero the spring of the pairs ``kb`` out of reach. Returns the
    row and partial sums after the chunk, and the number of reactions left out (their
    columns in ``kl``). Kept apart from :func:`_sphere_scatter`, not
    one function with the scratch layout as arguments: with runtime row offsets the
    sphere steps ran slower."""
    nl = 0
    for q in range(mo):
        uk = np.uint64(kb[q])
        if friction:
            hist[uk, 0] = 0.0
            hist[uk, 1] = 0.0
            hist[uk, 2] = 0.0
    for m in range(mr):
        k = kr[m]
        uk = np.uint64(k)  # unsigned: no negative-index wraparound
        while istart[i + 1] <= k:
            _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, solo or own[i])
            s0 = 0.0
            s1 = 0.0
            s2 = 0.0
            q0 = 0.0
            q1 = 0.0
            q2 = 0.0
            i += 1
        F0 = R[np.uint64(_RF * RCAP + m)]
        F1 = R[np.uint64((_RF + 1) * RCAP + m)]
        F2 = R[np.uint64((_RF + 2) * RCAP + m)]
        r0 = R[np.uint64(_RU * RCAP + m)]
        r1 = R[np.uint64((_RU + 1) * RCAP + m)]
        r2 = R[np.uint64((_RU + 2) * RCAP + m)]
        if friction:
            hist[uk, 0] = R[np.uint64(_RH * RCAP + m)]
            hist[uk, 1] = R[np.uint64((_RH + 1) * RCAP + m)]
            hist[uk, 2] = R[np.uint64((_RH + 2) * RCAP + m)]
        s0 += F0
        s1 += F1
        s2 += F2
        q0 += R[np.uint64(_RT * RCAP + m)]
        q1 += R[np.uint64((_RT + 1) * RCAP + m)]
        q2 += R[np.uint64((_RT + 2) * RCAP + m)]
        if not _reaction(pj[uk], solo, own, f, torque, F0, F1, F2, r0, r1, r2):
            kl[nl] = m
            nl += 1
        if stats:
            blk[b, 0] += R[np.uint64(_RPE * RCAP + m)]
            blk[b, 1] += 1.0
            _note_overlap(blk, b, R[np.uint64(_RDELTA * RCAP + m)], R[np.uint64(_RRI * RCAP + m)],
                          R[np.uint64(_RRJ * RCAP + m)], k)
            d0 = R[np.uint64(_RD * RCAP + m)]
            d1 = R[np.uint64((_RD + 1) * RCAP + m)]
            d2 = R[np.uint64((_RD + 2) * RCAP + m)]
            blk[b, 2] += d0 * F0
            blk[b, 3] += d0 * F1
            blk[b, 4] += d0 * F2
            blk[b, 5] += d1 * F0
            blk[b, 6] += d1 * F1
            blk[b, 7] += d1 * F2
            blk[b, 8] += d2 * F0
            blk[b, 9] += d2 * F1
            blk[b, 10] += d2 * F2
    while i < hi and istart[i + 1] <= k1:  # the rows that end with the chunk
        _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, solo or own[i])
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        i += 1
    return i, s0, s1, s2, q0, q1, q2, nl


@njit
def _rod_part(bl, bh, nt, x, v, omega, u, radius, half, b0, b1, b2, p0, p1, p2, pi, pj, istart,
              jstart, jk, hist, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt, f, torque, fj,
              stats, blk, own, use_sep, sep_sigma, sep_shrink, reach_max, per, dl):
    """The part of :func:`rod_pass` on blocks ``bl:bh`` (of ``nt`` parts); the one-part
    scatter compiles apart as in :func:`_sphere_part`."""
    n = x.shape[0]
    fr = fj.reshape(-1)  # the reaction records (FJ_COLUMNS)
    A = np.zeros(_NA * RCAP)
    R = np.zeros(_NR * RCAP)  # zeros: the padding columns never hold garbage
    ka = np.empty(RCAP, np.int64)
    kb = np.empty(RCAP, np.int64)
    kr = np.empty(RCAP, np.int64)
    kl = np.empty(RCAP, np.int64)
    _zero_rows(f, torque, bl * BLOCK, min(n, bh * BLOCK))  # no other part adds to them
    for b in range(bl, bh):
        lo = b * BLOCK
        hi = min(n, lo + BLOCK)
        i = lo
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        q0 = 0.0
        q1 = 0.0
        q2 = 0.0
        k0 = istart[lo]
        k_end = istart[hi]
        while True:
            k1 = min(k_end, k0 + RCAP)
            ma, mo = _rod_gather(k0, k1, pi, pj, x, u, radius, half, b0, b1, b2, p0, p1,
                                 p2, use_sep, sep_sigma, sep_shrink, reach_max, fj, A, ka,
                                 kb, per, dl)
            _rod_geometry(A, ma)
            mr, mo = _rod_select(A, ma, ka, kb, mo, pi, pj, v, omega, hist, dcoh,
                                 friction, R, kr, f, torque)
            _rod_laws(R, mr, law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt)
            if nt == 1:  # a constant, as in _sphere_part
                i, s0, s1, s2, q0, q1, q2, nl = _rod_scatter(
                    k1, i, hi, pj, istart, hist, friction, f, torque, stats, blk, b, R, kr, mr,
                    kb, mo, True, own, kl, s0, s1, s2, q0, q1, q2)
            else:
                if stats:
                    i, s0, s1, s2, q0, q1, q2, nl = _rod_scatter(
                        k1, i, hi, pj, istart, hist, friction, f, torque, True, blk, b, R, kr,
                        mr, kb, mo, False, own, kl, s0, s1, s2, q0, q1, q2)
                else:
                    i, s0, s1, s2, q0, q1, q2, nl = _rod_scatter(
                        k1, i, hi, pj, istart, hist, friction, f, torque, False, blk, b, R, kr,
                        mr, kb, mo, False, own, kl, s0, s1, s2, q0, q1, q2)
                _store_chunk(pj, jstart, jk, fr, R, RCAP, _RF, _RU, True, kr, kl, nl, False)
            k0 = k1
            if k0 >= k_end:
                break


@pnjit
def rod_pass(x, v, omega, u, radius, half, box, periodic, pi, pj, istart, jstart, jk, hist, law,
             p, friction, dt, f, torque, fj, stats, virial, sep_sigma=0.0, sep_shrink=0.0,
             parts=1, worst=None, dl=None, own=None, own_ok=False):
    """:func:`pair_pass` for rods with one bond per pair (not ``end_bonds``): the same
    equations, sums and outputs in the same order (the same bits), in chunks of
    :data:`RCAP` listed pairs and five loops: gather the pairs the motion bound does not
    rule out (:func:`_rod_gather`), their closest points on SIMD lanes
    (:func:`_rod_geometry`), the pairs in reach with their velocities
    (:func:`_rod_select`), their laws on SIMD lanes (:func:`_rod_laws`), and the sums
    in pair order (:func:`_rod_scatter`). ``pi`` the first member of each pair; the
    parts, ``own`` and the complete forces as in :func:`sphere_pass`; ``worst`` as in
    :func:`pair_pass`; ``dl`` (n values, else none) the rods' shares of the motion bound
    that gave ``sep_sigma`` and ``sep_shrink``, for the pair test of
    :func:`_rod_gather`."""
    n = x.shape[0]
    kn, gn, kt, gt, mu = p[K_N], p[GAMMA_N], p[K_T], p[GAMMA_T], p[MU]
    fcoh, dcoh = p[F_COH], p[D_COH]
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    use_sep = sep_sigma > 0.0 and fj.shape[0] > SEP and n > 0
    reach_max = 2.0 * radius.max() + dcoh if use_sep else 0.0
    dlv = dl if dl is not None else np.empty(0)
    per = use_sep and dlv.shape[0] == n
    nb = (n + BLOCK - 1) // BLOCK
    blk = np.zeros((nb if stats else 0, _STATS))
    nt = max(1, parts)
    bounds = part_bounds(istart, nb, nt)
    ownv = _part_flags(bounds, istart, jstart, jk, n,
                       own if own is not None else np.empty(0, np.bool_), own_ok)
    for t in prange(nt):
        _rod_part(bounds[t], bounds[t + 1], nt, x, v, omega, u, radius, half, b0, b1, b2, p0, p1,
                  p2, pi, pj, istart, jstart, jk, hist, law, kn, gn, kt, gt, mu, fcoh, dcoh,
                  friction, dt, f, torque, fj, stats, blk, ownv, use_sep, sep_sigma,
                  sep_shrink, reach_max, per, dlv)
    if nt > 1:
        for t in prange(nt):
            _close_part(bounds[t] * BLOCK, min(n, bounds[t + 1] * BLOCK), jstart, jk,
                        fj.reshape(-1), f, torque, ownv, False)
    if stats:
        if worst is not None:
            block_worst(blk, worst)
        return block_totals(blk, virial)
    return 0.0, 0


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


@njit
def pair_forces(x, v, omega, u, radius, half, box, periodic, pi, pj, hist, law, p,
                friction, dt, f, torque, virial, record, rec_ij, rec):
    """Serial form: add pair contact forces and torques to ``f``/``torque`` and the
    virial to ``virial``, visiting pairs in list order (``hist`` (npairs, 3) with
    friction); with ``record`` store the contacts in ``rec_ij``/``rec`` (see
    :data:`REC_COLUMNS`; the point is absolute and may lie just outside the box).

    Returns ``(elastic energy, number of contacts)``: contacts are the pairs that carry
    a force, touching (``delta > 0``) or, with cohesion, closer than ``d_c``.
    """
    kn, gn, kt, gt, mu = p[K_N], p[GAMMA_N], p[K_T], p[GAMMA_T], p[MU]
    fcoh, dcoh = p[F_COH], p[D_COH]
    pe = 0.0
    nc = 0
    rods = False
    for k in range(half.shape[0]):
        if half[k] > 0.0:
            rods = True
    ends = rods and p[END_BONDS] != 0.0
    nbond = 4 if ends else 1
    for k in range(pi.shape[0]):
        i = pi[k]
        j = pj[k]
        d0, d1, d2 = min_image(x[j, 0] - x[i, 0], x[j, 1] - x[i, 1], x[j, 2] - x[i, 2],
                               box[0], box[1], box[2], periodic[0], periodic[1], periodic[2])
        reach = radius[i] + radius[j] + dcoh
        # sums over the bonds of the pair; the recorded point is the force-weighted mean of
        # the bond points, the normal and overlap those of the deepest bond
        F0 = 0.0
        F1 = 0.0
        F2 = 0.0
        w = 0.0
        pc0 = 0.0
        pc1 = 0.0
        pc2 = 0.0
        m0 = 0.0
        m1 = 0.0
        m2 = 0.0
        deepest = -np.inf
        nbt = 0
        for kb in range(nbond):
            a0 = 0.0
            a1 = 0.0
            a2 = 0.0
            g0, g1, g2 = d0, d1, d2
            if ends:
                a0, a1, a2, g0, g1, g2 = end_bond(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2],
                                                  half[i], u[j, 0], u[j, 1], u[j, 2], half[j],
                                                  kb)
            elif rods:
                a0, a1, a2, g0, g1, g2 = spine_gap(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2],
                                                   half[i], u[j, 0], u[j, 1], u[j, 2], half[j])
            dist2 = g0 * g0 + g1 * g1 + g2 * g2
            if dist2 >= reach * reach:
                continue
            nbt += 1
            h0 = 0.0
            h1 = 0.0
            h2 = 0.0
            if friction:
                h0, h1, h2 = hist[k, 0], hist[k, 1], hist[k, 2]
            (B0, B1, B2, c0, c1, c2, e0, e1, e2, n0, n1, n2, delta, h0, h1, h2) = pair_force(
                g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, radius[i], radius[j], v[i, 0],
                v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2], v[j, 0], v[j, 1],
                v[j, 2], omega[j, 0], omega[j, 1], omega[j, 2], h0, h1, h2, law, kn, gn, kt,
                gt, mu, fcoh, dcoh, friction, dt)
            if friction:
                hist[k, 0] = h0
                hist[k, 1] = h1
                hist[k, 2] = h2
            if delta > 0.0:
                pe += elastic_energy(law, kn, delta, radius[i] + radius[j])
            F0 += B0
            F1 += B1
            F2 += B2
            f[i, 0] += B0
            f[i, 1] += B1
            f[i, 2] += B2
            f[j, 0] -= B0
            f[j, 1] -= B1
            f[j, 2] -= B2
            torque[i, 0] += c1 * B2 - c2 * B1
            torque[i, 1] += c2 * B0 - c0 * B2
            torque[i, 2] += c0 * B1 - c1 * B0
            torque[j, 0] -= e1 * B2 - e2 * B1
            torque[j, 1] -= e2 * B0 - e0 * B2
            torque[j, 2] -= e0 * B1 - e1 * B0
            if record:
                fb = np.sqrt(B0 * B0 + B1 * B1 + B2 * B2)
                w += fb
                pc0 += fb * c0
                pc1 += fb * c1
                pc2 += fb * c2
                if nbt == 1:
                    m0, m1, m2 = c0, c1, c2
                if delta > deepest:
                    deepest = delta
                    rec[nc, 3] = n0
                    rec[nc, 4] = n1
                    rec[nc, 5] = n2
        if nbt == 0:
            if friction:
                hist[k, 0] = 0.0
                hist[k, 1] = 0.0
                hist[k, 2] = 0.0
            continue
        virial[0, 0] += d0 * F0
        virial[0, 1] += d0 * F1
        virial[0, 2] += d0 * F2
        virial[1, 0] += d1 * F0
        virial[1, 1] += d1 * F1
        virial[1, 2] += d1 * F2
        virial[2, 0] += d2 * F0
        virial[2, 1] += d2 * F1
        virial[2, 2] += d2 * F2
        if record:
            if nbt > 1 and w > 0.0:
                m0, m1, m2 = pc0 / w, pc1 / w, pc2 / w
            rec_ij[nc, 0] = i
            rec_ij[nc, 1] = j
            rec[nc, 0] = x[i, 0] + m0
            rec[nc, 1] = x[i, 1] + m1
            rec[nc, 2] = x[i, 2] + m2
            rec[nc, 6] = deepest
            rec[nc, 7] = F0
            rec[nc, 8] = F1
            rec[nc, 9] = F2
        nc += 1
    return pe, nc


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
