"""The contact pass of all-sphere systems on SIMD lanes (:func:`sphere_pass`): the
same sums in the same order as :func:`pysim.contacts.pair.pair_pass`, with the contact
laws of a chunk of pairs evaluated together (gather, laws, scatter).
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.kinematics import normal_overlap
from pysim.contacts.law import contact_law, normal_part
from pysim.contacts.partition import (BLOCK, _close_part, _part_flags, _zero_rows,
                                      part_bounds)
from pysim.contacts.reactions import _finish_rows, _reaction, _store_chunk
from pysim.contacts.stats import (_STATS, _note_overlap, add_virial, block_totals,
                                  block_worst)
from pysim.forces import D_COH, F_COH, GAMMA_N, GAMMA_T, K_N, K_T, MU, elastic_energy
from pysim.jit import njit, pnjit, prange

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
    """The contact law (:func:`pysim.contacts.law.contact_law`) of the ``mc`` gathered
    pairs, one lane each (the law is inlined and written with selects, not branches on
    the pair, so that the loop runs on SIMD lanes). Writes the force on i, the torques on
    i and j, the new spring and the overlap into ``S``; on the first ``mc`` columns
    rounded up to a multiple of :data:`PAD`.

    The kinematics are those of spheres, not :func:`pysim.contacts.kinematics.
    contact_motion`: the contact point lies on the line of centres (``c = (R_i -
    delta/2) n`` from ``x_i``, ``e = c - d`` written ``(R_i - delta/2 - |d|) n``), so
    spins add no normal velocity and the overlap rate is ``(v_i - v_j) . n``, and the
    normal force exerts no torque: the torques are those of the tangential force."""
    mc = min(CAP, (mc + PAD - 1) // PAD * PAD)
    if not friction:
        for m in range(mc):
            d0 = S[np.uint64(_D * CAP + m)]
            d1 = S[np.uint64((_D + 1) * CAP + m)]
            d2 = S[np.uint64((_D + 2) * CAP + m)]
            rs = S[np.uint64(_RI * CAP + m)] + S[np.uint64(_RJ * CAP + m)]
            n0, n1, n2, delta, dist = normal_overlap(d0, d1, d2,
                                                     S[np.uint64(_DIST2 * CAP + m)], rs)
            dv0 = S[np.uint64(_VI * CAP + m)] - S[np.uint64(_VJ * CAP + m)]
            dv1 = S[np.uint64((_VI + 1) * CAP + m)] - S[np.uint64((_VJ + 1) * CAP + m)]
            dv2 = S[np.uint64((_VI + 2) * CAP + m)] - S[np.uint64((_VJ + 2) * CAP + m)]
            vn = dv0 * n0 + dv1 * n1 + dv2 * n2
            fn = normal_part(law, kn, gn, fcoh, dcoh, delta, vn, rs)
            S[np.uint64(_DELTA * CAP + m)] = delta
            # the normal part alone, -f_n n: contact_law would add a zero tangential force,
            # one more vector add per component (and -0.0 + 0.0 drops a zero's sign)
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
        n0, n1, n2, delta, dist = normal_overlap(d0, d1, d2, S[np.uint64(_DIST2 * CAP + m)], rs)
        vn = (vi0 - vj0) * n0 + (vi1 - vj1) * n1 + (vi2 - vj2) * n2
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
        F0, F1, F2, f0, f1, f2, x0, x1, x2 = contact_law(
            law, kn, gn, kt, gt, mu, fcoh, dcoh, True, dt, delta, rs, n0, n1, n2, vr0, vr1,
            vr2, vn, vt, S[np.uint64(_H * CAP + m)], S[np.uint64((_H + 1) * CAP + m)],
            S[np.uint64((_H + 2) * CAP + m)])
        S[np.uint64(_H * CAP + m)] = x0
        S[np.uint64((_H + 1) * CAP + m)] = x1
        S[np.uint64((_H + 2) * CAP + m)] = x2
        S[np.uint64(_F * CAP + m)] = F0
        S[np.uint64((_F + 1) * CAP + m)] = F1
        S[np.uint64((_F + 2) * CAP + m)] = F2
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
        # the rows before pair k's are complete (all lie below hi)
        i, s0, s1, s2, q0, q1, q2 = _finish_rows(i, hi, k, istart, f, torque, s0, s1, s2,
                                                 q0, q1, q2, solo, own)
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
            add_virial(blk, b, d0, d1, d2, F0, F1, F2)
    i, s0, s1, s2, q0, q1, q2 = _finish_rows(i, hi, k1, istart, f, torque, s0, s1, s2,
                                             q0, q1, q2, solo, own)
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
        s0 = s1 = s2 = q0 = q1 = q2 = 0.0
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
