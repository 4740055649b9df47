"""The contact law, written once: every contact of pysim (pair passes, SIMD lanes of
spheres and rods, walls) takes its forces from :func:`contact_law`.

Given the unit normal ``n`` from ``i`` to the other body, the overlap ``delta``, the
relative velocity ``v_rel`` of the contact points (``i`` minus the other) and the
tangential spring ``xi_t``:

* normal part (:func:`normal_part`): ``f_n`` the normal law of :mod:`pysim.forces`
  while touching (``delta > 0``), zero otherwise, plus the cohesion ``-F_c`` within
  the gap ``d_c``;
* tangential part (:func:`tangential_part`): while touching, the spring with history,
  dashpot and Coulomb cap (:func:`pysim.forces.tangential_force`) on the tangential
  velocity ``v_t = v_rel - (v_rel . n) n``; out of contact no force and the spring
  restarts at zero;
* force on i ``F = -f_n n + F_t``, on the other body ``-F``.

The parts are written with selects, not branches on the contact, and inlined into their
callers (``inline='always'``), so that the loops of :mod:`pysim.contacts.spheres` and
:mod:`pysim.contacts.rods` that call them per lane still run on SIMD lanes. They take
and return scalars only (an array argument costs atomic reference-count updates per
call).
"""
from __future__ import annotations

from pysim.contacts.kinematics import contact_motion
from pysim.forces import KEEP_SPRING, cohesion_force, normal_force, tangential_force
from pysim.jit import inline_njit, njit


@inline_njit
def normal_part(law, kn, gn, fcoh, dcoh, delta, vn, rs):
    """Normal force magnitude (repulsive positive): :func:`pysim.forces.normal_force` of
    the overlap ``delta``, its rate ``vn`` and ``rs = R_i + R_j`` while ``delta > 0``,
    else 0; plus :func:`pysim.forces.cohesion_force` (``-F_c`` while ``-delta < d_c``)
    when ``fcoh`` is not zero."""
    fn = normal_force(law, kn, gn, delta, vn, rs) if delta > 0.0 else 0.0
    if fcoh != 0.0:
        fn += cohesion_force(fcoh, dcoh, delta)
    return fn


@inline_njit
def tangential_part(kt, gt, mu, fn, x0, x1, x2, n0, n1, n2, vr0, vr1, vr2, vt, dt, keep,
                    touch):
    """Tangential force on i and the new spring: :func:`pysim.forces.tangential_force`
    with the tangential velocity ``v_rel - vt n`` (``vt = v_rel . n``) while ``touch``;
    out of contact (a cohesive gap) no force and a zero spring. Returns ``(F_t (3),
    xi_t (3))``."""
    f0, f1, f2, y0, y1, y2 = tangential_force(kt, gt, mu, fn, x0, x1, x2, n0, n1, n2,
                                              vr0 - vt * n0, vr1 - vt * n1, vr2 - vt * n2,
                                              dt, keep)
    return (f0 if touch else 0.0, f1 if touch else 0.0, f2 if touch else 0.0,
            y0 if touch else 0.0, y1 if touch else 0.0, y2 if touch else 0.0)


@inline_njit
def contact_law(law, kn, gn, kt, gt, mu, fcoh, dcoh, friction, dt, delta, rs, n0, n1, n2,
                vr0, vr1, vr2, vn, vt, x0, x1, x2):
    """Force of one contact within reach (the module's law): ``n`` the unit normal from
    i, ``delta`` the overlap, ``rs`` the contact distance ``R_i + R_j`` of the normal law,
    ``v_rel`` the relative contact-point velocity, ``vn`` the overlap rate of the normal
    law, ``vt = v_rel . n`` (the same, except for spheres: :mod:`pysim.contacts.spheres`),
    ``x`` the tangential spring (used and updated with ``friction`` only).

    Returns ``(F (3), F_t (3), x (3))``: the force on i ``F = -f_n n + F_t``, its
    tangential part and the new spring."""
    fn = normal_part(law, kn, gn, fcoh, dcoh, delta, vn, rs)
    ft0 = 0.0
    ft1 = 0.0
    ft2 = 0.0
    if friction:
        ft0, ft1, ft2, x0, x1, x2 = tangential_part(kt, gt, mu, fn, x0, x1, x2, n0, n1, n2,
                                                    vr0, vr1, vr2, vt, dt,
                                                    (law & KEEP_SPRING) != 0, delta > 0.0)
    return -fn * n0 + ft0, -fn * n1 + ft1, -fn * n2 + ft2, ft0, ft1, ft2, x0, x1, x2


@njit
def pair_force(g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0, vi1, vi2, wi0, wi1,
               wi2, vj0, vj1, vj2, wj0, wj1, wj2, x0, x1, x2, law, kn, gn, kt, gt, mu, fcoh,
               dcoh, friction, dt):
    """Force of a pair within reach: gap ``g`` (``|g|^2 = dist2``), ``a = p_i - x_i``,
    ``d = x_j - x_i``, radii, velocities and spins of both, tangential spring ``x``.

    The contact point, normal and relative velocity of
    :func:`pysim.contacts.kinematics.contact_motion`, then :func:`contact_law` with the
    overlap rate ``v_rel . n`` and ``R_i + R_j``; force on i ``F = -f_n n + F_t``, on j
    ``-F``.

    Returns ``(F (3), c (3), e (3), n (3), delta, x (3))``: ``c`` and ``e`` the contact
    point relative to ``x_i`` and ``x_j``, ``n`` the unit normal, ``x`` the new spring.
    """
    (n0, n1, n2, delta, rs, c0, c1, c2, e0, e1, e2, vr0, vr1, vr2, vn) = contact_motion(
        g0, g1, g2, a0, a1, a2, d0, d1, d2, dist2, ri, rj, vi0, vi1, vi2, wi0, wi1, wi2, vj0,
        vj1, vj2, wj0, wj1, wj2)
    F0, F1, F2, _, _, _, x0, x1, x2 = contact_law(law, kn, gn, kt, gt, mu, fcoh, dcoh,
                                                  friction, dt, delta, rs, n0, n1, n2, vr0,
                                                  vr1, vr2, vn, vn, x0, x1, x2)
    return F0, F1, F2, c0, c1, c2, e0, e1, e2, n0, n1, n2, delta, x0, x1, x2
