"""The contact loop: forces, torques, virial and the contact table from the pairs.

One loop serves every particle shape (spheres are spherocylinders with ``L = 0``), every
normal law, friction and cohesion, for force evaluation (every step) and for the
contact table written with each dump (``record=True``). Pairs are visited in list order
(sorted by ``i`` then ``j``) and pairs out of contact add nothing, so the forces do not
depend on how many extra pairs the Verlet list holds: results are bit-identical
across list rebuilds and restarts.

Geometry (science.md section 2): closest points ``p_i = x_i + s u_i`` and
``p_j = x_j + t u_j`` of the spines (:func:`pysim.geometry.closest_params`), distance
``d = |p_j - p_i|``, overlap ``delta = R_i + R_j - d``, normal ``n = (p_j - p_i)/d``,
contact point in the middle of the overlap ``c = p_i + (R_i - delta/2) n``.
"""
from __future__ import annotations

import numpy as np

from pysim.forces import D_COH, cohesion_force, elastic_energy, normal_force, tangential_force
from pysim.geometry import closest_params
from pysim.jit import njit

#: columns of a recorded contact: point (3), normal (3), overlap, force on i (3)
REC_COLUMNS = 10


@njit
def pair_forces(x, v, omega, u, radius, half, box, periodic, pi, pj, hist, law, p,
                friction, dt, f, torque, virial, record, rec_ij, rec):
    """Add pair contact forces and torques to ``f``/``torque``, the virial to ``virial``.

    For each listed pair with ``delta > -d_c`` (touching, or within the cohesion range):
    contact-point velocity ``v_rel = (v_i + w_i x (c - x_i)) - (v_j + w_j x (c - x_j))``,
    overlap rate ``v_rel . n``, normal force from :func:`pysim.forces.normal_force`
    (when ``delta > 0``) plus cohesion, tangential force with history ``hist[pair]``
    when ``friction``; force on i ``F = -f_n n + F_t``, on j ``-F``; torques
    ``(c - x_i) x F`` and ``(c - x_j) x (-F)``. ``virial[a, b] += (x_j - x_i)_a F_b``
    (= the contact sum of ``l_a F_b`` over both particles). The history of pairs out of
    contact is reset to zero.

    Returns ``(elastic energy, number of contacts)``: contacts are the pairs that carry
    a force, touching (``delta > 0``) or, with cohesion, closer than ``d_c``
    (``delta > -d_c``). With ``record`` they are stored in ``rec_ij``/``rec`` (see
    :data:`REC_COLUMNS`; the point is absolute and may lie just outside the box).
    """
    pe = 0.0
    nc = 0
    dcoh = p[D_COH]
    for k in range(pi.shape[0]):
        i = pi[k]
        j = pj[k]
        d0 = x[j, 0] - x[i, 0]
        d1 = x[j, 1] - x[i, 1]
        d2 = x[j, 2] - x[i, 2]
        if periodic[0]:
            d0 -= box[0] * np.floor(d0 / box[0] + 0.5)
        if periodic[1]:
            d1 -= box[1] * np.floor(d1 / box[1] + 0.5)
        if periodic[2]:
            d2 -= box[2] * np.floor(d2 / box[2] + 0.5)
        hi_ = half[i]
        hj_ = half[j]
        s, t = closest_params(-d0, -d1, -d2, u[i, 0], u[i, 1], u[i, 2], hi_,
                              u[j, 0], u[j, 1], u[j, 2], hj_)
        # p_i and p_j relative to x_i
        a0 = s * u[i, 0]
        a1 = s * u[i, 1]
        a2 = s * u[i, 2]
        g0 = d0 + t * u[j, 0] - a0
        g1 = d1 + t * u[j, 1] - a1
        g2 = d2 + t * u[j, 2] - a2
        dist2 = g0 * g0 + g1 * g1 + g2 * g2
        rs = radius[i] + radius[j]
        reach = rs + dcoh
        if dist2 >= reach * reach:
            if friction:
                hist[k, 0] = 0.0
                hist[k, 1] = 0.0
                hist[k, 2] = 0.0
            continue
        dist = np.sqrt(dist2)
        inv = 1.0 / dist
        n0 = g0 * inv
        n1 = g1 * inv
        n2 = g2 * inv
        delta = rs - dist
        # contact point relative to x_i, and relative to x_j
        ar = radius[i] - 0.5 * delta
        c0 = a0 + ar * n0
        c1 = a1 + ar * n1
        c2 = a2 + ar * n2
        e0 = c0 - d0
        e1 = c1 - d1
        e2 = c2 - d2
        # relative velocity of the contact points (i minus j)
        w0, w1, w2 = omega[i, 0], omega[i, 1], omega[i, 2]
        z0, z1, z2 = omega[j, 0], omega[j, 1], omega[j, 2]
        vr0 = v[i, 0] + (w1 * c2 - w2 * c1) - v[j, 0] - (z1 * e2 - z2 * e1)
        vr1 = v[i, 1] + (w2 * c0 - w0 * c2) - v[j, 1] - (z2 * e0 - z0 * e2)
        vr2 = v[i, 2] + (w0 * c1 - w1 * c0) - v[j, 2] - (z0 * e1 - z1 * e0)
        vn = vr0 * n0 + vr1 * n1 + vr2 * n2
        fn = 0.0
        if delta > 0.0:
            fn = normal_force(law, p, delta, vn, rs)
            pe += elastic_energy(law, p, delta, rs)
        fn += cohesion_force(p, delta)
        ft0 = 0.0
        ft1 = 0.0
        ft2 = 0.0
        if friction:
            if delta > 0.0:
                ft0, ft1, ft2 = tangential_force(p, fn, hist, k, n0, n1, n2, vr0 - vn * n0,
                                                 vr1 - vn * n1, vr2 - vn * n2, dt)
            else:
                hist[k, 0] = 0.0
                hist[k, 1] = 0.0
                hist[k, 2] = 0.0
        F0 = -fn * n0 + ft0
        F1 = -fn * n1 + ft1
        F2 = -fn * n2 + ft2
        f[i, 0] += F0
        f[i, 1] += F1
        f[i, 2] += F2
        f[j, 0] -= F0
        f[j, 1] -= F1
        f[j, 2] -= F2
        torque[i, 0] += c1 * F2 - c2 * F1
        torque[i, 1] += c2 * F0 - c0 * F2
        torque[i, 2] += c0 * F1 - c1 * F0
        torque[j, 0] -= e1 * F2 - e2 * F1
        torque[j, 1] -= e2 * F0 - e0 * F2
        torque[j, 2] -= e0 * F1 - e1 * F0
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
            rec_ij[nc, 0] = i
            rec_ij[nc, 1] = j
            rec[nc, 0] = x[i, 0] + c0
            rec[nc, 1] = x[i, 1] + c1
            rec[nc, 2] = x[i, 2] + c2
            rec[nc, 3] = n0
            rec[nc, 4] = n1
            rec[nc, 5] = n2
            rec[nc, 6] = delta
            rec[nc, 7] = F0
            rec[nc, 8] = F1
            rec[nc, 9] = F2
        nc += 1
    return pe, nc
