"""The contact pass of rods with one bond per pair on SIMD lanes (:func:`rod_pass`):
the closest points and the laws of a chunk of pairs evaluated together, the same bits as
:func:`pysim.contacts.pair.pair_pass` (``end_bonds`` rods keep ``pair_pass``).
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.kinematics import contact_motion, min_image
from pysim.contacts.law import contact_law
from pysim.contacts.partition import (BLOCK, _close_part, _part_flags, _zero_rows,
                                      part_bounds)
from pysim.contacts.reactions import SEP, _finish_rows, _reaction, _store_chunk
from pysim.contacts.spheres import PAD
from pysim.contacts.stats import (_STATS, _note_overlap, add_virial, block_totals,
                                  block_worst)
from pysim.forces import D_COH, F_COH, GAMMA_N, GAMMA_T, K_N, K_T, MU, elastic_energy
from pysim.geometry import closest_select
from pysim.jit import njit, pnjit, prange, prefetch_write

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
    """:func:`pysim.contacts.law.pair_force` of the ``mr`` pairs in reach of ``R`` (its two
    parts, :func:`pysim.contacts.kinematics.contact_motion` and
    :func:`pysim.contacts.law.contact_law`), one lane each (both are inlined and written
    with selects, not branches on the pair, so that the loop runs on SIMD lanes), and :func:`pair_pass`'s sums of one bond: the force on
    i, the torques on i and j, the elastic energy (0 out of overlap), the spring (in
    place) and the overlap. On ``mr`` rounded up to :data:`PAD` columns."""
    mr = min(RCAP, (mr + PAD - 1) // PAD * PAD)
    for m in range(mr):
        ri = R[np.uint64(_RRI * RCAP + m)]
        rj = R[np.uint64(_RRJ * RCAP + m)]
        (n0, n1, n2, delta, rs, c0, c1, c2, e0, e1, e2, vr0, vr1, vr2, vn) = contact_motion(
            R[np.uint64(_RG * RCAP + m)], R[np.uint64((_RG + 1) * RCAP + m)],
            R[np.uint64((_RG + 2) * RCAP + m)], R[np.uint64(_RA * RCAP + m)],
            R[np.uint64((_RA + 1) * RCAP + m)], R[np.uint64((_RA + 2) * RCAP + m)],
            R[np.uint64(_RD * RCAP + m)], R[np.uint64((_RD + 1) * RCAP + m)],
            R[np.uint64((_RD + 2) * RCAP + m)], R[np.uint64(_RDIST2 * RCAP + m)], ri, rj,
            R[np.uint64(_RVI * RCAP + m)], R[np.uint64((_RVI + 1) * RCAP + m)],
            R[np.uint64((_RVI + 2) * RCAP + m)], R[np.uint64(_RWI * RCAP + m)],
            R[np.uint64((_RWI + 1) * RCAP + m)], R[np.uint64((_RWI + 2) * RCAP + m)],
            R[np.uint64(_RVJ * RCAP + m)], R[np.uint64((_RVJ + 1) * RCAP + m)],
            R[np.uint64((_RVJ + 2) * RCAP + m)], R[np.uint64(_RWJ * RCAP + m)],
            R[np.uint64((_RWJ + 1) * RCAP + m)], R[np.uint64((_RWJ + 2) * RCAP + m)])
        B0, B1, B2, _, _, _, x0, x1, x2 = contact_law(
            law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt, delta, rs, n0, n1, n2, vr0, vr1,
            vr2, vn, vn, R[np.uint64(_RH * RCAP + m)], R[np.uint64((_RH + 1) * RCAP + m)],
            R[np.uint64((_RH + 2) * RCAP + m)])
        if friction:
            R[np.uint64(_RH * RCAP + m)] = x0
            R[np.uint64((_RH + 1) * RCAP + m)] = x1
            R[np.uint64((_RH + 2) * RCAP + m)] = x2
        # 0.0 + ...: pair_pass's sums over the bonds start from zero (the same bits)
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
        R[np.uint64(_RPE * RCAP + m)] = (0.0 + elastic_energy(law, kn, delta, rs)
                                         if delta > 0.0 else 0.0)


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
        # the rows before pair k's are complete (all lie below hi)
        i, s0, s1, s2, q0, q1, q2 = _finish_rows(i, hi, k, istart, f, torque, s0, s1, s2,
                                                 q0, q1, q2, solo, own)
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
            add_virial(blk, b, d0, d1, d2, F0, F1, F2)
    i, s0, s1, s2, q0, q1, q2 = _finish_rows(i, hi, k1, istart, f, torque, s0, s1, s2,
                                             q0, q1, q2, solo, own)
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
        s0 = s1 = s2 = q0 = q1 = q2 = 0.0
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
