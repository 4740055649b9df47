"""The contact law of one pair within reach, as scalars in and out: normal
spring-dashpot, tangential spring with history and Coulomb cap, cohesion (the laws of
:mod:`pysim.forces`), at the contact point in the middle of the overlap
(:mod:`pysim.contacts.kinematics`). It takes and returns scalars only, so that the hot
loops pass no arrays to it (an array argument costs atomic reference-count updates per
call).
"""
from __future__ import annotations

import numpy as np

from pysim.forces import KEEP_SPRING, cohesion_force, normal_force, tangential_force
from pysim.jit import njit

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
