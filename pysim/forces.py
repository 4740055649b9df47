"""Contact laws: small scalar functions plugged into the one contact loop.

Sign convention: ``delta > 0`` is the overlap, ``ddelta`` its rate of change (``> 0``
while approaching); a normal force magnitude is repulsive when positive. The force on
particle ``i`` is ``-f_n n + F_t`` with ``n`` the unit normal from ``i`` to ``j``.

Parameters travel in one float array (indices below) so that kernels stay
monomorphic and cacheable; laws are selected by an integer id. The laws themselves take
scalars only (the contact loop unpacks the array once): a kernel helper that receives
arrays updates their reference counts atomically on every call, which would cost more
than the law itself.

==============  ==  ====================================================================
law             id  normal force (science.md section 3)
==============  ==  ====================================================================
``hooke``        0  linear spring-dashpot ``f_n = k_n delta + gamma_n d(delta)/dt``
``hertz``        1  ``f_n = k_n delta^(3/2) + gamma_n d(delta)/dt``
``harmonic``     2  soft harmonic ``f_n = (k_n / d_ij)(delta / d_ij)``, ``d_ij = R_i + R_j``
                    (``k_n`` is ``k_e``; energy ``k_e/2 (delta/d_ij)^2``) + damping
==============  ==  ====================================================================

Damping is absolute (force per velocity), as LAMMPS ``damping velocity`` and LIGGGHTS
``absolute_damping on``. By default the force is not limited: science.md's law
``f = -(k delta + gamma v_n) n`` pulls the grains together while a damped contact opens
fast. A law id with the bit :data:`NO_TENSION` added (``law | NO_TENSION``) clips the
contact force at zero instead, ``f_n = max(0, k delta + gamma d(delta)/dt)``, as LAMMPS'
``limit_damping`` keyword does; cohesion is added after the clip.

Tangential law (:func:`tangential_force`): a spring ``xi_t`` with history and a dashpot,
``F_t = -k_t xi_t - gamma_t v_t``, capped at ``mu |f_n|``. Past the cap the spring is by
default reset to the length that gives the capped force (Cundall-Strack, as LAMMPS and
LIGGGHTS do); with the bit :data:`KEEP_SPRING` added to the law id the force alone is
rescaled and the spring keeps the integral of ``v_t`` (Pournin et al. 2005, section 3.1:
``xi_t`` is the integral of eq. 6 from the start of the contact, and
``f_t <- mu |f_n| f_t / |f_t|`` whenever ``|f_t| > mu |f_n|``).
"""
from __future__ import annotations

import numpy as np

from pysim.jit import njit

HOOKE = 0
HERTZ = 1
HARMONIC = 2
LAW_IDS = {"hooke": HOOKE, "hertz": HERTZ, "harmonic": HARMONIC}
#: bit added to a law id: no tensile contact force (the damping cannot pull)
NO_TENSION = 8
#: bit added to a law id: the tangential spring is not reset at the Coulomb cap
KEEP_SPRING = 16

# indices into the contact parameter array (END_BONDS: the spine contact of rod pairs,
# SPINE_CONTACTS: 0 the closest points, 1 the four end bonds of pysim.contacts.end_bond,
# 2 those end bonds that are distinct, pysim.contacts.repeats_bond)
K_N, GAMMA_N, K_T, GAMMA_T, MU, F_COH, D_COH, END_BONDS = range(8)
N_PARAMS = 8
SPINE_CONTACTS = {"closest": 0.0, "end_bonds": 1.0, "end_bonds_distinct": 2.0}
#: the value of ``p[END_BONDS]`` that leaves out repeated end bonds
DISTINCT_BONDS = SPINE_CONTACTS["end_bonds_distinct"]


def contact_params(k_n, gamma_n=0.0, k_t=0.0, gamma_t=0.0, mu=0.0, f_coh=0.0, d_coh=0.0,
                   end_bonds=False):
    """Pack contact parameters in the order of the index constants; ``end_bonds`` a
    value of :data:`SPINE_CONTACTS` (True: all four end bonds)."""
    p = np.zeros(N_PARAMS)
    p[[K_N, GAMMA_N, K_T, GAMMA_T, MU, F_COH, D_COH, END_BONDS]] = [
        k_n, gamma_n, k_t, gamma_t, mu, f_coh, d_coh, float(end_bonds)]
    return p


@njit
def normal_force(law, kn, gn, delta, ddelta, dsum):
    """Normal force magnitude for overlap ``delta``, overlap rate ``ddelta`` and
    contact distance ``dsum = R_i + R_j`` (see the module table); ``kn``, ``gn`` the
    stiffness and damping; with the bit :data:`NO_TENSION` in ``law``, ``max(0, f_n)``."""
    base = law & (NO_TENSION - 1)
    if base == HOOKE:
        f = kn * delta + gn * ddelta
    elif base == HERTZ:
        f = kn * delta * np.sqrt(delta) + gn * ddelta
    else:
        f = kn * delta / (dsum * dsum) + gn * ddelta
    clip = (law & NO_TENSION) != 0 and f < 0.0
    return 0.0 if clip else f


@njit
def elastic_energy(law, kn, delta, dsum):
    """Elastic energy of one contact: ``k delta^2/2``, ``2/5 k delta^(5/2)`` or
    ``k_e/2 (delta/d_ij)^2`` (``law`` with or without :data:`NO_TENSION`)."""
    base = law & (NO_TENSION - 1)
    if base == HOOKE:
        return 0.5 * kn * delta * delta
    if base == HERTZ:
        return 0.4 * kn * delta * delta * np.sqrt(delta)
    x = delta / dsum
    return 0.5 * kn * x * x


@njit
def cohesion_force(f_coh, d_coh, delta):
    """Constant attraction ``F_c`` while the gap ``-delta`` is below ``d_c`` (science.md:
    cohesion of the deposits); returned as a (negative) normal force."""
    if f_coh != 0.0 and delta > -d_coh:
        return -f_coh
    return 0.0


@njit
def tangential_force(kt, gt, mu, fn, x0, x1, x2, n0, n1, n2, vt0, vt1, vt2, dt, keep_spring):
    """Tangential spring with history and Coulomb cap (science.md section 3).

    ``(x0, x1, x2)`` is the tangential spring ``xi_t`` of this contact: it is first rotated
    into the current tangent plane (keeping its length), then ``xi_t += v_t dt``,
    ``F_t = -k_t xi_t - gamma_t v_t``; if ``|F_t| > mu |f_n|`` the force is rescaled to
    ``mu |f_n|`` and, unless ``keep_spring``, the spring with it (``xi_t = -(F_t +
    gamma_t v_t)/k_t``). With ``keep_spring`` (Pournin et al. 2005, eqs. 4-6 and the cap
    of section 3.1) the spring stays the integral of ``v_t`` past the cap, so a contact
    that slid must slide back by the excess before its force drops below the cap. The
    paper assumes ``n`` constant during a contact, where the rotation does nothing; both
    variants rotate, so that ``F_t`` stays tangential when ``n`` turns.
    Returns ``(F_t (3), new xi_t (3))`` (``F_t`` the force on i).

    Written with selects, not branches, so that a loop over contacts that calls it can
    run on SIMD lanes (:func:`pysim.contacts.sphere_pass`); the values not selected may
    be inf or NaN and are discarded. The reset multiplies by ``1/k_t`` (a loop-invariant
    division, hoisted) rather than dividing three times per contact.
    """
    # rotate into the tangent plane, preserving the length
    xn = x0 * n0 + x1 * n1 + x2 * n2
    old = x0 * x0 + x1 * x1 + x2 * x2
    x0 -= xn * n0
    x1 -= xn * n1
    x2 -= xn * n2
    new = x0 * x0 + x1 * x1 + x2 * x2
    keep = (new > 0.0) & (old > 0.0)
    sc = np.sqrt(old / new)
    x0 = x0 * sc if keep else x0
    x1 = x1 * sc if keep else x1
    x2 = x2 * sc if keep else x2
    x0 += vt0 * dt
    x1 += vt1 * dt
    x2 += vt2 * dt
    f0 = -kt * x0 - gt * vt0
    f1 = -kt * x1 - gt * vt1
    f2 = -kt * x2 - gt * vt2
    fmag = np.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
    cap = mu * abs(fn)
    slip = fmag > cap
    sc = cap / fmag
    scale = slip & (fmag > 0.0)
    f0 = f0 * sc if scale else f0
    f1 = f1 * sc if scale else f1
    f2 = f2 * sc if scale else f2
    reset = slip & (kt > 0.0) & (not keep_spring)
    ikt = 1.0 / kt
    y0 = -(f0 + gt * vt0) * ikt
    y1 = -(f1 + gt * vt1) * ikt
    y2 = -(f2 + gt * vt2) * ikt
    x0 = y0 if reset else x0
    x1 = y1 if reset else x1
    x2 = y2 if reset else x2
    return f0, f1, f2, x0, x1, x2
