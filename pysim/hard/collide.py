"""Binary collisions of hard spheres whose diameters grow linearly in time
(Lubachevsky & Stillinger 1990; Baranau & Tallarek 2014, ref. 36, 37 and 40).

Two spheres with separation ``dr = x_j - x_i`` and relative velocity ``dv = v_j - v_i``
touch when ``|dr + dv tau| = s + sdot tau``, ``s`` their contact distance
``(D_i + D_j) / 2`` now and ``sdot`` its growth rate. Squared, that is

    a tau^2 + 2 b tau + c = 0,   a = dv.dv - sdot^2,  b = dr.dv - s sdot,  c = dr.dr - s^2,

and the collision is its first root with the gap closing. The roots are taken in the
forms that do not cancel: ``c / (-b + sqrt(b^2 - a c))`` when ``b < 0``, and
``(-b - sqrt(b^2 - a c)) / a`` when ``b >= 0 > a`` (the diameters outgrow a separating
pair).
"""
from __future__ import annotations

import math

from pysim.jit import inline_njit


@inline_njit
def collision_time(dx, dy, dz, dvx, dvy, dvz, s, sdot):
    """Time ``tau >= 0`` until two spheres touch with the gap closing, ``inf`` if never
    (module docstring). ``s`` (length) is the contact distance now, ``sdot``
    (length / time) its growth rate; a pair that already touches or overlaps by
    round-off collides now (``tau = 0``) if its gap is closing."""
    a = dvx * dvx + dvy * dvy + dvz * dvz - sdot * sdot
    b = dx * dvx + dy * dvy + dz * dvz - s * sdot
    c = dx * dx + dy * dy + dz * dz - s * s
    if c <= 0.0:  # touching, or overlapping by round-off
        if b < 0.0:
            return 0.0
        if a >= 0.0:
            return math.inf
        disc = b * b - a * c
        if disc < 0.0:  # the growth keeps the pair at contact: collide now
            return 0.0
        return (-b - math.sqrt(disc)) / a
    if b < 0.0:
        disc = b * b - a * c
        if disc < 0.0:
            return math.inf
        return c / (-b + math.sqrt(disc))
    if a >= 0.0:
        return math.inf
    return (-b - math.sqrt(b * b - a * c)) / a


@inline_njit
def collide(v, i, j, dx, dy, dz, sdot):
    """Collide spheres ``i`` and ``j`` (unit masses) that touch at separation
    ``dr = x_j - x_i``: exchange their normal velocities (elastic), then push each away
    from the other by ``2 sdot`` along the normal, so that the pair separates faster than
    the contact distance grows (``sdot`` = its growth rate; the authors' code, ref. 40,
    after Donev et al.). Updates ``v`` in place; returns the elastic impulse ``|J| =
    |dv . n|`` times the contact distance ``|dr|``, the pair's term of the virial
    (the push is left out, as in ref. 40)."""
    d = math.sqrt(dx * dx + dy * dy + dz * dz)
    nx = dx / d
    ny = dy / d
    nz = dz / d
    vn = (v[j, 0] - v[i, 0]) * nx + (v[j, 1] - v[i, 1]) * ny + (v[j, 2] - v[i, 2]) * nz
    kick = vn - 2.0 * sdot
    v[i, 0] += kick * nx
    v[i, 1] += kick * ny
    v[i, 2] += kick * nz
    v[j, 0] -= kick * nx
    v[j, 1] -= kick * ny
    v[j, 2] -= kick * nz
    return abs(vn) * d
