"""The contact loop: forces, virial and the contact table from the Verlet pairs.

One loop serves force evaluation (every step) and the contact table written with
each dump (``record=True``). Pairs are visited in list order, so sums are
deterministic.
"""
from __future__ import annotations

import numpy as np

from pysim.forces import elastic_energy, normal_force
from pysim.jit import njit
from pysim.neighbors import minimum_image

#: columns of the per-contact record filled when ``record`` is true
REC_CX, REC_NX, REC_DELTA, REC_FX = 0, 3, 6, 7
REC_COLUMNS = 10


@njit
def sphere_contacts(x, v, radius, box, periodic, pi, pj, law, params, f, virial,
                    record, rec_ij, rec):
    """Add sphere-sphere contact forces to ``f`` and the virial to ``virial``.

    For each listed pair closer than ``R_i + R_j``: ``n = (x_j - x_i)/|x_j - x_i|``
    (minimum image), overlap ``delta = R_i + R_j - |x_j - x_i|``, overlap rate
    ``d(delta)/dt = (v_i - v_j) . n``, normal force ``f_n`` from
    :func:`pysim.forces.normal_force`; ``F_i = -f_n n``, ``F_j = +f_n n``.

    ``virial[a, b] += (x_j - x_i)_a F_i,b`` (the contact part of
    ``sum_c l_a F_b`` summed over both particles); divide by the volume for the
    stress tensor (tension positive). ``f`` and ``virial`` are accumulated, not
    zeroed. When ``record`` is true, contact ``c`` is stored in ``rec_ij[c] = (i, j)``
    and ``rec[c] = (contact point, normal, overlap, force on i)`` with the contact
    point in the middle of the overlap: ``x_i + (R_i - delta/2) n``.

    Returns ``(elastic energy, number of contacts)``.
    """
    d = np.empty(3)
    pe = 0.0
    nc = 0
    for p in range(pi.shape[0]):
        i = pi[p]
        j = pj[p]
        for k in range(3):
            d[k] = x[j, k] - x[i, k]
        minimum_image(d, box, periodic)
        r2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2]
        rs = radius[i] + radius[j]
        if r2 >= rs * rs:
            continue
        r = np.sqrt(r2)
        inv = 1.0 / r
        n0 = d[0] * inv
        n1 = d[1] * inv
        n2 = d[2] * inv
        delta = rs - r
        ddelta = ((v[i, 0] - v[j, 0]) * n0 + (v[i, 1] - v[j, 1]) * n1
                  + (v[i, 2] - v[j, 2]) * n2)
        fn = normal_force(law, params, delta, ddelta)
        f0 = -fn * n0
        f1 = -fn * n1
        f2 = -fn * n2
        f[i, 0] += f0
        f[i, 1] += f1
        f[i, 2] += f2
        f[j, 0] -= f0
        f[j, 1] -= f1
        f[j, 2] -= f2
        virial[0, 0] += d[0] * f0
        virial[0, 1] += d[0] * f1
        virial[0, 2] += d[0] * f2
        virial[1, 0] += d[1] * f0
        virial[1, 1] += d[1] * f1
        virial[1, 2] += d[1] * f2
        virial[2, 0] += d[2] * f0
        virial[2, 1] += d[2] * f1
        virial[2, 2] += d[2] * f2
        pe += elastic_energy(law, params, delta)
        if record:
            rec_ij[nc, 0] = i
            rec_ij[nc, 1] = j
            a = radius[i] - 0.5 * delta
            rec[nc, 0] = x[i, 0] + a * n0
            rec[nc, 1] = x[i, 1] + a * n1
            rec[nc, 2] = x[i, 2] + a * n2
            rec[nc, 3] = n0
            rec[nc, 4] = n1
            rec[nc, 5] = n2
            rec[nc, 6] = delta
            rec[nc, 7] = f0
            rec[nc, 8] = f1
            rec[nc, 9] = f2
        nc += 1
    return pe, nc
