"""The general contact loops, one pair at a time, for any shape (spheres are
spherocylinders with ``L = 0``), any normal law, friction, cohesion and end bonds:
:func:`pair_pass` (the force evaluation of every step, with
:func:`pysim.contacts.reactions.reduce_pass`) and :func:`pair_forces` (serial, in pair
order, and can record the contact table).

With ``spine_contact = "end_bonds"`` (:func:`pysim.contacts.kinematics.end_bond`) a rod
pair is up to four bonds, each a contact of the same law with its own tangential spring
(columns ``3 k : 3 k + 3`` of the pair's history row for bond ``k``; with
``"end_bonds_distinct"`` a bond that repeats another's two points counts once,
:func:`pysim.contacts.kinematics.repeats_bond`): the vertex-edge contacts of
spheropolygons (Alonso-Marroquin's method, which Hidalgo et al. use). A pair's forces,
torques and virial are the sums over its bonds, and its recorded contact has the summed
force, the force-weighted mean point, and the normal and overlap of the deepest bond.
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.kinematics import end_bond, min_image, repeats_bond, spine_gap
from pysim.contacts.law import pair_force
from pysim.contacts.partition import BLOCK, _zero_rows
from pysim.contacts.reactions import (SEP, _finish_row, _no_reaction, _reaction, _slot,
                                      _store)
from pysim.contacts.stats import (_STATS, _note_overlap, add_virial, block_totals,
                                  block_worst)
from pysim.forces import (D_COH, DISTINCT_BONDS, END_BONDS, F_COH, GAMMA_N, GAMMA_T, K_N,
                          K_T, MU, elastic_energy)
from pysim.jit import njit, pnjit, prange

#: columns of a recorded contact: point (3), normal (3), overlap, force on i (3)
REC_COLUMNS = 10


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
    once = ends and p[END_BONDS] == DISTINCT_BONDS
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
            s0 = s1 = s2 = q0 = q1 = q2 = 0.0
            for k in range(istart[i], istart[i + 1]):
                j = pj[k]
                rj = radius[j]
                reach = ri + rj + dcoh
                # out of reach by the motion bound (a margin far above rounding): no force
                if use_sep and sep_sigma * fj[SEP, k] - sep_shrink > reach * (1.0 + 1e-9):
                    if friction:
                        hist[k, :] = 0.0
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
                    hb = 3 * kb  # the bond's spring in the pair's history row
                    if dist2 >= reach * reach or (
                            once and kb > 0 and repeats_bond(d0, d1, d2, ui0, ui1, ui2, hi,
                                                             uj0, uj1, uj2, hj, kb)):
                        if friction:
                            hist[k, hb:hb + 3] = 0.0
                        continue
                    touching = True
                    h0 = 0.0
                    h1 = 0.0
                    h2 = 0.0
                    if friction:
                        h0, h1, h2 = hist[k, hb], hist[k, hb + 1], hist[k, hb + 2]
                    (B0, B1, B2, c0, c1, c2, e0, e1, e2, n0, n1, n2, delta, h0, h1,
                     h2) = pair_force(g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0,
                                      vi1, vi2, wi0, wi1, wi2, v[j, 0], v[j, 1], v[j, 2],
                                      omega[j, 0], omega[j, 1], omega[j, 2], h0, h1, h2, law,
                                      kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt)
                    if friction:
                        hist[k, hb] = h0
                        hist[k, hb + 1] = h1
                        hist[k, hb + 2] = h2
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
                        hist[k, :] = 0.0
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
                    add_virial(blk, b, d0, d1, d2, F0, F1, F2)
            _finish_row(i, f, torque, s0, s1, s2, q0, q1, q2, scatter)
    if stats:
        if worst is not None and not ends:
            block_worst(blk, worst)
        return block_totals(blk, virial)
    return 0.0, 0


@njit
def pair_forces(x, v, omega, u, radius, half, box, periodic, pi, pj, hist, law, p,
                friction, dt, f, torque, virial, record, rec_ij, rec):
    """Serial form: add pair contact forces and torques to ``f``/``torque`` and the
    virial to ``virial``, visiting pairs in list order (``hist`` (npairs, 3) with
    friction, (npairs, 12) with end bonds: one spring per bond); with ``record`` store
    the contacts in ``rec_ij``/``rec`` (see :data:`REC_COLUMNS`; the point is absolute
    and may lie just outside the box).

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
    once = ends and p[END_BONDS] == DISTINCT_BONDS
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
            hb = 3 * kb  # the bond's spring in the pair's history row
            if dist2 >= reach * reach or (
                    once and kb > 0 and repeats_bond(d0, d1, d2, u[i, 0], u[i, 1], u[i, 2],
                                                     half[i], u[j, 0], u[j, 1], u[j, 2],
                                                     half[j], kb)):
                if friction:
                    hist[k, hb:hb + 3] = 0.0
                continue
            nbt += 1
            h0 = 0.0
            h1 = 0.0
            h2 = 0.0
            if friction:
                h0, h1, h2 = hist[k, hb], hist[k, hb + 1], hist[k, hb + 2]
            (B0, B1, B2, c0, c1, c2, e0, e1, e2, n0, n1, n2, delta, h0, h1, h2) = pair_force(
                g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, radius[i], radius[j], v[i, 0],
                v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2], v[j, 0], v[j, 1],
                v[j, 2], omega[j, 0], omega[j, 1], omega[j, 2], h0, h1, h2, law, kn, gn, kt,
                gt, mu, fcoh, dcoh, friction, dt)
            if friction:
                hist[k, hb] = h0
                hist[k, hb + 1] = h1
                hist[k, hb + 2] = h2
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
                hist[k, :] = 0.0
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
