"""Time integration kernels: velocity Verlet with rotation, Euler, overdamped Heun, FIRE.

All of them share :func:`forces` (contacts, walls, gravity, drag) and
:func:`maybe_rebuild` (the Verlet list). Arrays are those of :class:`pysim.state.State`
plus ``half = L/2`` and ``r_int = R + L/2 + d_c/2`` (interaction radii); three tuples of
arrays travel together: ``pairs`` (:data:`PAIR_ARRAYS`, the Verlet list of
:mod:`pysim.neighbors` with its per-pair tangential springs), ``ref`` (:data:`REF_ARRAYS`,
the state at the list build) and ``walls`` (:data:`WALL_ARRAYS`, :mod:`pysim.walls`).
The scalars are two records (:mod:`pysim.records`): ``params``, the parameters (drag,
gravity, strain and growth rates, skin, threads; read only), and ``cache``, the cache the
kernels write (the list build, the motion bound, the threads' bookkeeping, the largest
overlap).

Every per-particle loop and the contact loop run on Numba threads (``prange``); each
thread writes only the particles or pairs it owns and global sums are taken over fixed
blocks (:mod:`pysim.contacts`), so results do not depend on the number of threads.
Spheres (``L = 0``) keep their orientation ``q``, ``u``: with equal principal moments it
enters no force, torque or kinetic term (LAMMPS ``nve/sphere`` does not track it either).

**Velocity Verlet** (``verlet_chunk``), step order as LAMMPS (``fix nve/sphere``,
``fix viscous``, ``fix deform ... remap x``):

1. ``v += dt/2 F/m``, ``omega += dt/2 I^-1 tau`` (``I`` the lab inertia of an
   axisymmetric body, ``I^-1 a = a/I_perp + (1/I_axis - 1/I_perp)(a.u)u``)
2. ``x += dt v``; the orientation follows the exact free rotation of a symmetric top for
   the angular momentum ``I omega`` (:func:`pysim.rotation.free_rotate`); wrap
3. rebuild the pair list if needed; ``F, tau`` at ``t + dt`` with half-step velocities
4. ``v += dt/2 F/m``, ``omega += dt/2 I^-1 tau``
5. box ``L_k *= exp(eps_k dt)`` with ``x_k`` remapped affinely; particles grow by
   ``exp(g dt)`` (``R``, ``L``; mass ``* exp(3 g dt)``, inertia ``* exp(5 g dt)``)

**Euler** (``euler_chunk``; Pournin et al. 2005 integrate with "the forward Euler
method"): explicit, every update from the old state (``x += dt v``, free rotation at the
old ``I omega``, then ``v += dt F/m``, ``I omega += dt tau``), or semi-implicit (the
velocities first, then the positions and orientations with them); then the list check
and ``F, tau`` at the new state. The explicit step adds energy to a damped contact
(docs/studies/tapping.md).

**Overdamped Heun** (``heun_chunk``; science.md, 2-D compression): mobility against an
affinely contracting substrate, ``F - k_d a_i (dr/dt + kappa r) = 0`` and
``tau - k_d a_i (I_i/m_i) dtheta/dt = 0`` (``a_i`` area in 2-D, volume in 3-D), box
``dL/dt = -kappa L``. In scaled coordinates ``s = r/L`` only ``F`` drives; Heun
(predictor-corrector) steps the scaled positions and the orientations.

**FIRE** (``fire_chunk``; Bitzek et al. 2006, with the semi-implicit Euler step and
back-off of FIRE 2.0, Guenole et al. 2020) minimises the elastic energy at fixed box.
"""
from __future__ import annotations

import numpy as np

from pysim.contacts import (BLOCK, PAIR_SCRATCH, SEP, clear_slots, pair_pass, reduce_pass,
                            rod_pass, sphere_pass)
from pysim.forces import END_BONDS
from pysim.jit import inline_njit, njit, pnjit, prange
from pysim.neighbors import (ROW_ROOM, build_list, motion_bound, spine_separations,
                             stale_by_bound, transfer_rows)
from pysim.records import WORST_UNKNOWN
from pysim.rotation import axes, axis_from, axis_of, free_rotate, top_rotation
from pysim.walls import wall_forces

SQRT_HALF = np.sqrt(0.5)

#: The pair arrays, passed and returned as one tuple in this order by the kernels: the
#: Verlet list (:func:`pysim.neighbors.build_list`: ``pi``, ``pj``, ``istart``, ``jstart``,
#: ``jk``), the tangential springs ``hist`` (npairs, 3; (npairs, 0) without friction) and
#: the per-pair scratch ``fj`` (:data:`pysim.contacts.PAIR_SCRATCH` rows of at least
#: npairs values: the stored reactions of :func:`pysim.contacts.pair_pass` and of the
#: threads' shared particles, and each pair's spine distance at the build, row
#: :data:`pysim.contacts.SEP`, which the motion bound in ``cache`` refers to).
PAIR_ARRAYS = ("pi", "pj", "istart", "jstart", "jk", "hist", "fj")
#: The state at the last list build, one tuple: positions, axes (rods only, else (0, 3))
#: and box, written by :func:`rebuild`; the motion bound is taken from them.
REF_ARRAYS = ("x_ref", "u_ref", "box_ref")
#: The walls, one tuple: the plane and cylinder rows (:mod:`pysim.walls`), the wall
#: contact parameters (:func:`pysim.forces.contact_params`), the wall springs ``whist``
#: and the force on each wall ``wall_force`` (written).
WALL_ARRAYS = ("planes", "cyls", "wp", "whist", "wall_force")


@njit
def wrap1(xk, b):
    """One coordinate wrapped into ``[0, b)``."""
    xk -= b * np.floor(xk / b)
    if xk >= b:  # round-off at the upper edge
        xk -= b
    return xk


@njit
def wrap(x, box, periodic):
    """Wrap positions into ``[0, box)`` along periodic axes (in place)."""
    for i in range(x.shape[0]):
        for k in range(3):
            if periodic[k]:
                x[i, k] = wrap1(x[i, k], box[k])


@njit
def all_finite(x, v):
    """True when every position and velocity is finite (one pass, no temporaries: the
    blow-up check after every run)."""
    for i in range(x.shape[0]):
        for k in range(3):
            if not (np.isfinite(x[i, k]) and np.isfinite(v[i, k])):
                return False
    return True


@njit
def max_of(a):
    m = 0.0
    for i in range(a.shape[0]):
        if a[i] > m:
            m = a[i]
    return m


@njit
def rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref):
    """A new pair list for the current state, carrying the tangential springs over from
    the old one (``pairs``); writes the build's state (``ref``, ``cache``). Returns the
    new pair arrays (:data:`PAIR_ARRAYS`)."""
    prm, cch = params[0], cache[0]  # the records (pysim.records)
    old_pj, old_istart, old_hist, fj = pairs[1], pairs[2], pairs[5], pairs[6]
    x_ref, u_ref, box_ref = ref
    n = max(x.shape[0], 1)  # room per row in the build: 1.5 times the old mean row
    room = 3 * old_pj.shape[0] // (2 * n) + 2 if old_pj.shape[0] else ROW_ROOM
    # the spine-separation row of the pair scratch is rewritten below: the build's buffer
    scratch = fj[SEP].view(np.int32) if fj.shape[0] > SEP else np.empty(0, np.int32)
    pi, pj, istart, jstart, jk = build_list(x, u, r_int, half, box, periodic, prm.skin, room,
                                            scratch)
    hist = transfer_rows(old_istart, old_pj, old_hist, istart, pj)
    if fj.shape[1] < pj.shape[0] or fj.shape[0] < PAIR_SCRATCH:  # scratch with 10 % to spare
        fj = np.empty((PAIR_SCRATCH, pj.shape[0] + pj.shape[0] // 10 + 16))
    if prm.rods:  # only the rod loop skips pairs by their separation
        spine_separations(x, u, half, box, periodic, pi, pj, fj[SEP])
    x_ref[:, :] = x
    if u_ref.shape[0] == u.shape[0]:
        u_ref[:, :] = u
    box_ref[:] = box
    rc = 0.0
    hm = 0.0
    for i in range(x.shape[0]):
        rc = max(rc, r_int[i] - half[i])
        hm = max(hm, half[i])
    cch.rint_build = max_of(r_int)
    cch.rc_build = 2.0 * rc
    cch.half_build = hm
    cch.sep_sigma = 1.0
    cch.sep_shrink = 0.0
    cch.slot_parts = 0
    cch.own_parts = 0
    return pi, pj, istart, jstart, jk, hist, fj


@njit
def maybe_rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref, dl=None):
    """Rebuild the pair list (carrying the tangential history) when an unlisted pair
    could come into contact (:func:`pysim.neighbors.list_is_stale`). Returns the pair
    arrays and whether it rebuilt. ``dl``: each particle's share of the motion bound,
    written here (:func:`pysim.neighbors.motion_bound`; zero after a build) for
    :func:`forces`."""
    prm, cch = params[0], cache[0]  # the records (pysim.records)
    x_ref, u_ref, box_ref = ref
    growth = max_of(r_int) / cch.rint_build if cch.rint_build > 0 else 1.0
    sigma, shrink = motion_bound(x, x_ref, u, u_ref, half, box, box_ref, periodic,
                                 cch.half_build, growth, dl)
    if not stale_by_bound(sigma, shrink, cch.rc_build, prm.skin, growth):
        cch.sep_sigma = sigma
        cch.sep_shrink = shrink
        return pairs, False
    pairs = rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref)
    if dl is not None:
        dl[:] = 0.0  # the state is the build's
    return pairs, True


@pnjit
def _body(f, torque, v, omega, mass, gx, gy, gz, gb, gr):
    for i in prange(f.shape[0]):
        f[i, 0] += mass[i] * gx - gb * v[i, 0]
        f[i, 1] += mass[i] * gy - gb * v[i, 1]
        f[i, 2] += mass[i] * gz - gb * v[i, 2]
        torque[i, 0] -= gr * omega[i, 0]
        torque[i, 1] -= gr * omega[i, 1]
        torque[i, 2] -= gr * omega[i, 2]


@njit
def forces(x, v, omega, u, radius, half, mass, box, periodic, pairs, law, cp, friction, walls,
           wfriction, params, cache, t, dt, f, torque, virial, stats, dl=None, own=None):
    """Overwrite ``f``, ``torque`` with pair contacts, walls, gravity ``m g``, drag
    ``-gamma_bg v`` and ``-gamma_rot omega`` (added in that order). With ``stats`` also
    the virial and the largest overlap (the cache's ``worst``), and returns ``(elastic energy,
    pair contacts, wall contacts)``; without, the virial and the overlap are left as they
    were and the first two are zero. ``wfriction``: the walls keep springs (``whist``).
    ``dl``: the particles' shares of the motion bound that :func:`maybe_rebuild` wrote
    with ``sep_sigma`` (rods skip the pairs it keeps out of reach; the same forces).
    ``own``: n flags kept from call to call, the shared particles of the parts
    (the cache's ``own_parts``), else they are found at every call."""
    prm, cch = params[0], cache[0]  # the records (pysim.records)
    pi, pj, istart, jstart, jk, hist, fj = pairs
    planes, cyls, wp, whist, wall_force = walls
    # the sphere and rod passes write complete pair forces on any number of threads (one
    # part of the rows per thread); the general pass does on one thread only (scatter),
    # else reduce_pass adds the stored reactions. The same bits either way.
    parts = prm.parts
    scatter = True
    ends = prm.rods and cp[END_BONDS] != 0.0
    if not ends and parts > 1 and cch.slot_parts != parts:
        clear_slots(istart, jstart, jk, fj, parts, not prm.rods)
        cch.slot_parts = parts
    ownv = own if own is not None else np.empty(0, np.bool_)
    own_ok = cch.own_parts == parts
    if ownv.shape[0] == x.shape[0] and not ends:
        cch.own_parts = parts  # the pass writes them now if they were not
    worst = cch.worst  # a view: the passes write the overlap there
    if ends:
        scatter = parts == 1
        pe, nc = pair_pass(x, v, omega, u, radius, half, box, periodic, pj, istart, jstart, jk,
                           hist, law, cp, friction, dt, True, f, torque, fj, stats, virial,
                           cch.sep_sigma, cch.sep_shrink, scatter)
        cch.slot_parts = 0  # it wrote every slot
        if stats:
            worst[1] = WORST_UNKNOWN
    elif prm.rods:
        pe, nc = rod_pass(x, v, omega, u, radius, half, box, periodic, pi, pj, istart, jstart,
                          jk, hist, law, cp, friction, dt, f, torque, fj, stats, virial,
                          cch.sep_sigma, cch.sep_shrink, parts, worst, dl, ownv, own_ok)
    else:
        pe, nc = sphere_pass(x, v, omega, radius, box, periodic, pi, pj, istart, jstart, jk,
                             hist, law, cp, friction, dt, f, torque, fj, stats, virial, parts,
                             worst, ownv, own_ok)
    g = prm.gravity
    gx, gy, gz = g[0], g[1], g[2]
    gb = prm.gamma_bg
    gr = prm.gamma_rot
    body = gx != 0.0 or gy != 0.0 or gz != 0.0 or gb != 0.0 or gr != 0.0
    any_walls = planes.shape[0] + cyls.shape[0] > 0
    if not scatter or (body and not any_walls):
        reduce_pass(f, torque, jstart, fj, v, omega, mass, gx, gy, gz, gb, gr,
                    body and not any_walls, scatter)
    nw = 0
    if any_walls:
        no_ij = np.empty((0, 2), np.int64)
        no_rec = np.empty((0, 10))
        nw = wall_forces(x, v, omega, u, radius, half, planes, cyls, t, law, wp, wfriction,
                         whist, dt, f, torque, wall_force, False, no_ij, no_rec)
        if body:
            _body(f, torque, v, omega, mass, gx, gy, gz, gb, gr)
    if prm.dim2:
        _planar_forces(f, torque)
    return pe, nc, nw


@pnjit
def _planar_forces(f, torque):
    """2-D: no force out of the plane, no torque in it (``fix enforce2d``)."""
    for i in prange(f.shape[0]):
        f[i, 2] = 0.0
        torque[i, 0] = 0.0
        torque[i, 1] = 0.0


@njit
def reciprocals(m, ip, ia):
    """``(1/m, 1/I_perp, 1/I_axis)`` of one particle: what :func:`inverses` stores, and
    what the growth in :func:`_half_and_half` stores again (the same values, so that a run
    cut into calls keeps its bits)."""
    return 1.0 / m, 1.0 / ip, 1.0 / ia


@pnjit
def inverses(mass, inertia, inv):
    """``inv[i] = (1/m_i, 1/I_perp,i, 1/I_axis,i)``, the reciprocals the kicks multiply
    by, so that the per-particle loops divide only when the particles grow (kept in
    step there): dividing, the two kicks of a step took 12 scalar divisions per
    particle.
    Taken from ``mass`` and ``inertia`` at the start of every call of the integrators,
    never kept between calls, so that a change to either is never missed."""
    for i in prange(mass.shape[0]):
        inv[i, 0], inv[i, 1], inv[i, 2] = reciprocals(mass[i], inertia[i, 0], inertia[i, 1])


@njit
def kick(v0, v1, v2, w0, w1, w2, f0, f1, f2, t0, t1, t2, u0, u1, u2, am, rp, ra, h):
    """``v += h F/m``, ``omega += h I^-1 tau`` for one particle (scalars in and out),
    with ``I^-1 tau = tau/I_perp + (1/I_axis - 1/I_perp)(tau . u) u``; ``am``, ``rp``,
    ``ra`` are ``1/m``, ``1/I_perp``, ``1/I_axis`` (:func:`inverses`)."""
    a = h * am
    tu = t0 * u0 + t1 * u1 + t2 * u2
    c = (ra - rp) * tu
    return (v0 + a * f0, v1 + a * f1, v2 + a * f2, w0 + h * (t0 * rp + c * u0),
            w1 + h * (t1 * rp + c * u1), w2 + h * (t2 * rp + c * u2))


@pnjit
def _kick(v, omega, u, f, torque, inv, h):
    """``v += h F/m``, ``omega += h I^-1 tau``."""
    for i in prange(v.shape[0]):
        (v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2]) = kick(
            v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2], f[i, 0], f[i, 1],
            f[i, 2], torque[i, 0], torque[i, 1], torque[i, 2], u[i, 0], u[i, 1], u[i, 2],
            inv[i, 0], inv[i, 1], inv[i, 2], h)


@inline_njit
def _free_ops(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt, series):
    """:func:`free_step` with the sines and cosines of :func:`pysim.rotation.sincos`
    (``series`` a constant) and no branch on the particle (SIMD lanes). Returns the new
    quaternion, axis and ``omega``, and whether the series held
    (:func:`pysim.rotation.top_rotation`)."""
    wu = w0 * u0 + w1 * u1 + w2 * u2
    # L = I_perp omega + (I_axis - I_perp)(omega . u) u
    l0 = ip * w0 + (ia - ip) * wu * u0
    l1 = ip * w1 + (ia - ip) * wu * u1
    l2 = ip * w2 + (ia - ip) * wu * u2
    q0, q1, q2, q3, small = top_rotation(q0, q1, q2, q3, l0, l1, l2, u0, u1, u2, rp, ra, dt,
                                         series)
    u0, u1, u2 = axis_from(q0, q1, q2, q3)
    # omega = I^-1 L with the new axis
    lu = l0 * u0 + l1 * u1 + l2 * u2
    c = (ra - rp) * lu
    return (q0, q1, q2, q3, u0, u1, u2, l0 * rp + c * u0, l1 * rp + c * u1, l2 * rp + c * u2,
            small)


@njit
def free_step(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt):
    """Exact free symmetric-top rotation of one particle over ``dt`` at constant angular
    momentum ``L = I omega`` (``ip``, ``ia``: ``I_perp``, ``I_axis``; ``rp``, ``ra``: their
    reciprocals). Returns the new quaternion (4), axis (3) and ``omega`` (3): the same
    bits as :func:`_rotate_lanes`, which takes the series path alone."""
    r = _free_ops(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt, True)
    if not r[10]:
        r = _free_ops(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt, False)
    return r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9]


#: rows per block of :func:`_half_and_half`, whose rods turn on SIMD lanes
#: (:func:`_rotate_lanes`) once the block's kicks and drifts are done
ROT_BLOCK = 64
# rows of the lanes' scratch, ROT_BLOCK values each: quaternion, axis, omega, I_perp,
# I_axis, 1/I_perp, 1/I_axis in; quaternion, axis, omega and whether the series held out
_TQ, _TU, _TW, _TIP, _TIA, _TRP, _TRA, _TOK = 0, 4, 7, 10, 11, 12, 13, 14
_NT = 15


@njit
def _rotate_lanes(T, m, dt):
    """:func:`free_step` of the ``m`` rods in the columns of scratch ``T`` (rows ``_TQ``
    to ``_TRA``), in place, on SIMD lanes: the series path alone; row ``_TOK`` says where
    it held (elsewhere :func:`free_step` must redo the rod). Unsigned column numbers: no
    negative-index wraparound, which would keep the loop scalar."""
    B = ROT_BLOCK
    for k in range(np.uint64(0), np.uint64(m)):
        (q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ok) = _free_ops(
            T[np.uint64(_TQ * B) + k], T[np.uint64((_TQ + 1) * B) + k],
            T[np.uint64((_TQ + 2) * B) + k], T[np.uint64((_TQ + 3) * B) + k],
            T[np.uint64(_TU * B) + k], T[np.uint64((_TU + 1) * B) + k],
            T[np.uint64((_TU + 2) * B) + k], T[np.uint64(_TW * B) + k],
            T[np.uint64((_TW + 1) * B) + k], T[np.uint64((_TW + 2) * B) + k],
            T[np.uint64(_TIP * B) + k], T[np.uint64(_TIA * B) + k], T[np.uint64(_TRP * B) + k],
            T[np.uint64(_TRA * B) + k], dt, True)
        T[np.uint64(_TQ * B) + k] = q0
        T[np.uint64((_TQ + 1) * B) + k] = q1
        T[np.uint64((_TQ + 2) * B) + k] = q2
        T[np.uint64((_TQ + 3) * B) + k] = q3
        T[np.uint64(_TU * B) + k] = u0
        T[np.uint64((_TU + 1) * B) + k] = u1
        T[np.uint64((_TU + 2) * B) + k] = u2
        T[np.uint64(_TW * B) + k] = w0
        T[np.uint64((_TW + 1) * B) + k] = w1
        T[np.uint64((_TW + 2) * B) + k] = w2
        T[np.uint64(_TOK * B) + k] = 1.0 if ok else 0.0


@pnjit
def _rotate_free(q, u, omega, inertia, inv, half, dt):
    """Exact free rotation of every rod over ``dt`` (spheres keep their orientation)."""
    for i in prange(q.shape[0]):
        if half[i] > 0.0:
            (q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], omega[i, 0],
             omega[i, 1], omega[i, 2]) = free_step(
                q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], omega[i, 0],
                omega[i, 1], omega[i, 2], inertia[i, 0], inertia[i, 1], inv[i, 1], inv[i, 2],
                dt)


@inline_njit
def _in_plane(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, dim2):
    """One rod's quaternion, axis and ``omega``, in 2-D (``dim2``) put back in the plane:
    the spine in the plane with unit length, the quaternion on the shortest arc from
    ``e_z`` to it, ``(1, -u_y, u_x, 0)/sqrt(2)``, and ``omega = (0, 0, w_z)``; else
    unchanged. Scalars only, so that the per-particle loops can call it at no cost."""
    if dim2:
        an = np.sqrt(u0 * u0 + u1 * u1)
        u0 /= an
        u1 /= an
        return SQRT_HALF, -u1 * SQRT_HALF, u0 * SQRT_HALF, 0.0, u0, u1, 0.0, 0.0, 0.0, w2
    return q0, q1, q2, q3, u0, u1, u2, w0, w1, w2


@inline_njit
def _turn(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt, dim2):
    """:func:`free_step` of one rod, kept in the plane in 2-D (:func:`_in_plane`)."""
    r = free_step(q0, q1, q2, q3, u0, u1, u2, w0, w1, w2, ip, ia, rp, ra, dt)
    return _in_plane(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], dim2)


@inline_njit
def _wrap3(x0, x1, x2, b0, b1, b2, p0, p1, p2):
    """A position wrapped into the box along its periodic axes (:func:`wrap1`)."""
    return (wrap1(x0, b0) if p0 else x0, wrap1(x1, b1) if p1 else x1,
            wrap1(x2, b2) if p2 else x2)


@pnjit
def _first_half(x, v, q, u, omega, f, torque, inertia, inv, half, box, periodic, h, dt, dim2):
    """Steps 1-2 of velocity Verlet for every particle: half kick, drift, free rotation
    (rods), wrap. In 2-D (``dim2``) the motion is kept in the plane exactly, as LAMMPS'
    ``fix enforce2d`` does: ``v_z = 0``, ``omega = (0, 0, w_z)``, spines in the plane (the
    quaternion rebuilt from the planar spine, rounding would tilt it slowly otherwise)."""
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    for i in prange(x.shape[0]):
        u0, u1, u2 = u[i, 0], u[i, 1], u[i, 2]
        rp = inv[i, 1]
        ra = inv[i, 2]
        v0, v1, v2, w0, w1, w2 = kick(v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1],
                                      omega[i, 2], f[i, 0], f[i, 1], f[i, 2], torque[i, 0],
                                      torque[i, 1], torque[i, 2], u0, u1, u2, inv[i, 0], rp, ra,
                                      h)
        v[i, 0] = v0
        v[i, 1] = v1
        v[i, 2] = v2
        x0 = x[i, 0] + dt * v0
        x1 = x[i, 1] + dt * v1
        x2 = x[i, 2] + dt * v2
        if dim2:
            v[i, 2] = 0.0
            x2 = 0.0
            w0 = 0.0
            w1 = 0.0
        if half[i] > 0.0:
            (q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], w0, w1,
             w2) = _turn(q[i, 0], q[i, 1], q[i, 2], q[i, 3], u0, u1, u2, w0, w1, w2,
                         inertia[i, 0], inertia[i, 1], rp, ra, dt, dim2)
        omega[i, 0] = w0
        omega[i, 1] = w1
        omega[i, 2] = w2
        x[i, 0], x[i, 1], x[i, 2] = _wrap3(x0, x1, x2, b0, b1, b2, p0, p1, p2)


@pnjit
def _second_half(x, v, omega, u, f, torque, mass, inertia, inv, radius, half, r_int, h, scale,
                 deform, sc, sc3, sc5):
    """Steps 4-5: half kick, affine remap of the positions (``scale`` per axis, when
    ``deform``), growth of every particle by ``sc`` (when ``sc != 1``; the call ends here,
    so ``inv`` is not kept in step)."""
    s0, s1, s2 = scale[0], scale[1], scale[2]
    for i in prange(x.shape[0]):
        (v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2]) = kick(
            v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1], omega[i, 2], f[i, 0], f[i, 1],
            f[i, 2], torque[i, 0], torque[i, 1], torque[i, 2], u[i, 0], u[i, 1], u[i, 2],
            inv[i, 0], inv[i, 1], inv[i, 2], h)
        if deform:
            if s0 != 1.0:
                x[i, 0] *= s0
            if s1 != 1.0:
                x[i, 1] *= s1
            if s2 != 1.0:
                x[i, 2] *= s2
        if sc != 1.0:
            radius[i] *= sc
            half[i] *= sc
            r_int[i] *= sc
            mass[i] *= sc3
            inertia[i, 0] *= sc5
            inertia[i, 1] *= sc5


@pnjit
def _half_and_half(x, v, q, u, omega, f, torque, mass, inertia, inv, radius, half, r_int, box,
                   periodic, h, dt, dim2, scale, deform, sc, sc3, sc5, parts, lanes):
    """:func:`_second_half` of one step and :func:`_first_half` of the next in one pass
    over the particles: the same operations in the same order per particle (the same
    bits), one sweep of the arrays instead of two. Its drift repeats :func:`_first_half`'s
    on purpose: a flag in one kernel choosing whether the second half runs first cost the
    whole gain (docs/performance.md).
    The rows are cut into ``parts`` contiguous runs of :data:`ROT_BLOCK` rows, one per
    thread (:func:`_half_and_half_part`; ``lanes``: the rods turn on SIMD lanes)."""
    n = x.shape[0]
    nb = (n + ROT_BLOCK - 1) // ROT_BLOCK
    nt = max(1, min(nb, parts))
    for t in prange(nt):
        _half_and_half_part(t * nb // nt * ROT_BLOCK, min(n, (t + 1) * nb // nt * ROT_BLOCK), x,
                            v, q, u, omega, f, torque, mass, inertia, inv, radius, half, r_int,
                            box, periodic, h, dt, dim2, scale, deform, sc, sc3, sc5, lanes)


@njit
def _half_and_half_part(lo, hi, x, v, q, u, omega, f, torque, mass, inertia, inv, radius, half,
                        r_int, box, periodic, h, dt, dim2, scale, deform, sc, sc3, sc5, lanes):
    """:func:`_half_and_half` on the rows ``lo:hi``. With ``lanes`` in blocks of
    :data:`ROT_BLOCK` rows: each block's kicks, drifts and wraps run first, one particle
    after the other, its rods are copied as they pass into a scratch, one column each,
    and turn there together (:func:`_rotate_lanes`, the bits of :func:`free_step`). Else
    (spheres) in one loop, a rod calling :func:`free_step` where it passes (the lanes
    turn rods faster, and the blocks barely slow the spheres: docs/performance.md). The
    body is written out, not a function called per particle with the arrays: each such
    call costs the reference counts of its array arguments."""
    s0, s1, s2 = scale[0], scale[1], scale[2]
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    B = ROT_BLOCK
    T = np.zeros(_NT * B if lanes else 0)
    rows = np.empty(B if lanes else 0, np.int64)
    for blo in range(lo, hi, B if lanes else max(1, hi - lo)):
        m = 0
        # unsigned: no negative-index wraparound
        for i in range(np.uint64(blo), np.uint64(min(hi, blo + B) if lanes else hi)):
            u0, u1, u2 = u[i, 0], u[i, 1], u[i, 2]
            f0, f1, f2 = f[i, 0], f[i, 1], f[i, 2]
            t0, t1, t2 = torque[i, 0], torque[i, 1], torque[i, 2]
            am = inv[i, 0]
            rp = inv[i, 1]
            ra = inv[i, 2]
            v0, v1, v2, w0, w1, w2 = kick(v[i, 0], v[i, 1], v[i, 2], omega[i, 0], omega[i, 1],
                                          omega[i, 2], f0, f1, f2, t0, t1, t2, u0, u1, u2, am,
                                          rp, ra, h)
            x0, x1, x2 = x[i, 0], x[i, 1], x[i, 2]
            if deform:
                if s0 != 1.0:
                    x0 *= s0
                if s1 != 1.0:
                    x1 *= s1
                if s2 != 1.0:
                    x2 *= s2
            if sc != 1.0:
                radius[i] *= sc
                half[i] *= sc
                r_int[i] *= sc
                mm = mass[i] * sc3
                mass[i] = mm
                ip = inertia[i, 0] * sc5
                ia = inertia[i, 1] * sc5
                inertia[i, 0] = ip
                inertia[i, 1] = ia
                am, rp, ra = reciprocals(mm, ip, ia)
                inv[i, 0] = am
                inv[i, 1] = rp
                inv[i, 2] = ra
            v0, v1, v2, w0, w1, w2 = kick(v0, v1, v2, w0, w1, w2, f0, f1, f2, t0, t1, t2, u0,
                                          u1, u2, am, rp, ra, h)
            v[i, 0] = v0
            v[i, 1] = v1
            v[i, 2] = v2
            x0 = x0 + dt * v0
            x1 = x1 + dt * v1
            x2 = x2 + dt * v2
            if dim2:
                v[i, 2] = 0.0
                x2 = 0.0
                w0 = 0.0
                w1 = 0.0
            if half[i] > 0.0:
                if lanes:  # to the scratch: the orientation and axis before the step
                    c = np.uint64(m)
                    rows[c] = i
                    for e in range(4):
                        T[np.uint64((_TQ + e) * B) + c] = q[i, e]
                    T[np.uint64(_TU * B) + c] = u0
                    T[np.uint64((_TU + 1) * B) + c] = u1
                    T[np.uint64((_TU + 2) * B) + c] = u2
                    T[np.uint64(_TW * B) + c] = w0
                    T[np.uint64((_TW + 1) * B) + c] = w1
                    T[np.uint64((_TW + 2) * B) + c] = w2
                    T[np.uint64(_TIP * B) + c] = inertia[i, 0]
                    T[np.uint64(_TIA * B) + c] = inertia[i, 1]
                    T[np.uint64(_TRP * B) + c] = rp
                    T[np.uint64(_TRA * B) + c] = ra
                    m += 1
                else:
                    (q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], w0, w1,
                     w2) = _turn(q[i, 0], q[i, 1], q[i, 2], q[i, 3], u0, u1, u2, w0, w1, w2,
                                 inertia[i, 0], inertia[i, 1], rp, ra, dt, dim2)
            omega[i, 0] = w0
            omega[i, 1] = w1
            omega[i, 2] = w2
            x[i, 0], x[i, 1], x[i, 2] = _wrap3(x0, x1, x2, b0, b1, b2, p0, p1, p2)
        if m > 0:
            _turn_rows(T, m, rows, q, u, omega, inertia, inv, dt, dim2)


@njit
def _turn_rows(T, m, rows, q, u, omega, inertia, inv, dt, dim2):
    """The ``m`` rods gathered in scratch ``T`` (rows ``rows``, ``omega`` after the
    kicks) turned on SIMD lanes (:func:`_rotate_lanes`) and stored; a rod whose
    half-angle lies past the series takes :func:`free_step` again, with the library's
    sine and cosine. In 2-D the spines go back into the plane (:func:`_in_plane`)."""
    B = ROT_BLOCK
    _rotate_lanes(T, m, dt)
    for c in range(m):
        i = rows[c]
        k = np.uint64(c)
        if T[np.uint64(_TOK * B) + k] != 0.0:
            r = (T[np.uint64(_TQ * B) + k], T[np.uint64((_TQ + 1) * B) + k],
                 T[np.uint64((_TQ + 2) * B) + k], T[np.uint64((_TQ + 3) * B) + k],
                 T[np.uint64(_TU * B) + k], T[np.uint64((_TU + 1) * B) + k],
                 T[np.uint64((_TU + 2) * B) + k], T[np.uint64(_TW * B) + k],
                 T[np.uint64((_TW + 1) * B) + k], T[np.uint64((_TW + 2) * B) + k])
        else:
            r = free_step(q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2],
                          omega[i, 0], omega[i, 1], omega[i, 2], inertia[i, 0], inertia[i, 1],
                          inv[i, 1], inv[i, 2], dt)
        (q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], omega[i, 0],
         omega[i, 1], omega[i, 2]) = _in_plane(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7],
                                               r[8], r[9], dim2)


#: pairs from which :func:`verlet_chunk` returns to its caller after a list rebuild, to
#: free the old list: a return costs a Python call of the kernel, small against a step
#: with a list of this size, and lists rebuild only every tens of steps
RETURN_PAIRS = 1 << 13


@inline_njit
def _list_and_forces(x, v, omega, u, radius, half, r_int, mass, box, periodic, pairs, ref, law,
                     cp, friction, walls, wfriction, params, cache, t, dt, f, torque, virial, dl,
                     own, final):
    """The second part of a step of :func:`verlet_chunk` and :func:`euler_chunk`: the list
    check (:func:`maybe_rebuild`), then the forces at the new state, with the global sums
    on the call's last step (``final``, or the step whose rebuild returns the call, see
    :data:`RETURN_PAIRS`). Returns ``(pairs, rebuilt (1 or 0), last, energy, pair contacts,
    wall contacts)``."""
    pairs, rebuilt = maybe_rebuild(x, u, box, periodic, r_int, half, params, cache, pairs,
                                   ref, dl)
    last = (rebuilt and pairs[1].shape[0] >= RETURN_PAIRS) or final
    pe, nc, nw = forces(x, v, omega, u, radius, half, mass, box, periodic, pairs, law, cp,
                        friction, walls, wfriction, params, cache, t, dt, f, torque, virial,
                        last, dl, own)
    return pairs, 1 if rebuilt else 0, last, pe, nc, nw


@njit
def verlet_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, box,
                 periodic, pairs, ref, law, cp, friction, walls, wfriction, params, cache, clock,
                 dt, nsteps, virial, dl, own):
    """Advance ``nsteps`` velocity-Verlet steps (see the module doc).

    ``clock = (t_seg, s_seg, step0)``: the time after step ``k`` of this call is
    ``t_seg + (step0 + k + 1 - s_seg) dt``, a function of the step number alone, so that
    results do not depend on how a run is cut into calls (restarts are bit-identical).
    ``f``/``torque`` must hold the forces of the current state on entry and hold those of
    the final state on exit (the virial too). With a list of at least
    :data:`RETURN_PAIRS` pairs it returns after the step that rebuilds the list, so that
    the caller drops the old list before the next rebuild (a call that rebuilt twice
    would hold three lists at once). ``dl``: scratch of n values for the particles' shares
    of the motion bound (:func:`maybe_rebuild`), or none (empty): the rods' contact pass
    then skips by the largest share alone. ``own``: n flags kept for :func:`forces` (or
    none). Returns ``(pairs, elastic energy, pair contacts, wall contacts, rebuilds, steps
    done)``.
    """
    prm = params[0]  # the record (pysim.records)
    h = 0.5 * dt
    inv = np.empty((x.shape[0], 3))  # from mass and inertia at every call: never stale
    inverses(mass, inertia, inv)
    parts = prm.parts
    lanes = prm.rods  # rods turn on SIMD lanes
    pe = 0.0
    nc = 0
    nw = 0
    rebuilds = 0
    scale = np.ones(3)
    deform = False
    rate = prm.strain_rate
    for k in range(3):
        if rate[k] != 0.0:
            scale[k] = np.exp(rate[k] * dt)
            deform = True
    dim2 = prm.dim2
    sc = 1.0
    if prm.growth != 0.0:
        sc = np.exp(prm.growth * dt)
    # mass grows with the volume (area in 2-D), inertia with mass times length squared
    sc3 = sc * sc if dim2 else sc * sc * sc
    sc5 = sc3 * sc * sc
    done = nsteps
    for k in range(nsteps):
        t = clock[0] + (clock[2] + k + 1 - clock[1]) * dt
        if k == 0:
            _first_half(x, v, q, u, omega, f, torque, inertia, inv, half, box, periodic, h,
                        dt, dim2)
        else:  # the previous step's second half with this one's first
            _half_and_half(x, v, q, u, omega, f, torque, mass, inertia, inv, radius, half, r_int,
                           box, periodic, h, dt, dim2, scale, deform, sc, sc3, sc5, parts,
                           lanes)
        pairs, rebuilt, last, pe, nc, nw = _list_and_forces(
            x, v, omega, u, radius, half, r_int, mass, box, periodic, pairs, ref, law, cp,
            friction, walls, wfriction, params, cache, t, dt, f, torque, virial, dl, own,
            k == nsteps - 1)
        rebuilds += rebuilt
        for kk in range(3):
            box[kk] *= scale[kk]
        if last:
            done = k + 1
            break
    if nsteps > 0:
        _second_half(x, v, omega, u, f, torque, mass, inertia, inv, radius, half, r_int, h, scale,
                     deform, sc, sc3, sc5)
    return pairs, pe, nc, nw, rebuilds, done


@pnjit
def _euler_step(x, v, q, u, omega, f, torque, inertia, inv, half, box, periodic, dt, dim2):
    """One explicit (forward) Euler step for every particle: ``x += dt v`` and the free
    rotation of the rods over ``dt`` at their old angular momentum ``L``, then
    ``v += dt F/m`` and ``L += dt tau`` (``omega = I^-1 L`` about the new axis), all
    from the old state; wrap. In 2-D kept in the plane as in :func:`_first_half`."""
    b0, b1, b2 = box[0], box[1], box[2]
    p0, p1, p2 = periodic[0], periodic[1], periodic[2]
    for i in prange(x.shape[0]):
        v0, v1, v2 = v[i, 0], v[i, 1], v[i, 2]
        x0 = x[i, 0] + dt * v0
        x1 = x[i, 1] + dt * v1
        x2 = x[i, 2] + dt * v2
        w0, w1, w2 = omega[i, 0], omega[i, 1], omega[i, 2]
        rp = inv[i, 1]
        ra = inv[i, 2]
        if half[i] > 0.0:
            (q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], w0, w1,
             w2) = _turn(q[i, 0], q[i, 1], q[i, 2], q[i, 3], u[i, 0], u[i, 1], u[i, 2], w0, w1,
                         w2, inertia[i, 0], inertia[i, 1], rp, ra, dt, dim2)
        v0, v1, v2, w0, w1, w2 = kick(v0, v1, v2, w0, w1, w2, f[i, 0], f[i, 1], f[i, 2],
                                      torque[i, 0], torque[i, 1], torque[i, 2], u[i, 0], u[i, 1],
                                      u[i, 2], inv[i, 0], rp, ra, dt)
        if dim2:
            v2 = 0.0
            x2 = 0.0
            w0 = 0.0
            w1 = 0.0
        v[i, 0], v[i, 1], v[i, 2] = v0, v1, v2
        omega[i, 0], omega[i, 1], omega[i, 2] = w0, w1, w2
        x[i, 0], x[i, 1], x[i, 2] = _wrap3(x0, x1, x2, b0, b1, b2, p0, p1, p2)


@njit
def euler_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, box,
                periodic, pairs, ref, law, cp, friction, walls, wfriction, params, cache, clock,
                dt, nsteps, virial, dl, own, explicit):
    """Advance ``nsteps`` Euler steps, explicit (``explicit``: :func:`_euler_step`) or
    semi-implicit (velocities first, ``v += dt F/m``, ``omega += dt I^-1 tau``, then the
    positions and orientations with the new ones: :func:`_first_half` with a whole step),
    each followed by the list check and the forces at the new state (the tangential
    springs grow inside the force pass, as in :func:`verlet_chunk`). The arguments,
    returns and contract of :func:`verlet_chunk`, without box deformation or growth."""
    prm = params[0]
    inv = np.empty((x.shape[0], 3))
    inverses(mass, inertia, inv)
    dim2 = prm.dim2
    pe = 0.0
    nc = 0
    nw = 0
    rebuilds = 0
    done = nsteps
    for k in range(nsteps):
        t = clock[0] + (clock[2] + k + 1 - clock[1]) * dt
        if explicit:
            _euler_step(x, v, q, u, omega, f, torque, inertia, inv, half, box, periodic, dt,
                        dim2)
        else:
            _first_half(x, v, q, u, omega, f, torque, inertia, inv, half, box, periodic, dt,
                        dt, dim2)
        pairs, rebuilt, last, pe, nc, nw = _list_and_forces(
            x, v, omega, u, radius, half, r_int, mass, box, periodic, pairs, ref, law, cp,
            friction, walls, wfriction, params, cache, t, dt, f, torque, virial, dl, own,
            k == nsteps - 1)
        rebuilds += rebuilt
        if last:
            done = k + 1
            break
    return pairs, pe, nc, nw, rebuilds, done


@pnjit
def _mobility_step(x0, q0, f, torque, mass, inertia, msize, kd, u, x, q, v, omega, dt, scale):
    """``x = scale (x0 + dt F/(k_d a))``, ``q = q0`` rotated by ``dt tau/(k_d a I/m)``."""
    for i in prange(x.shape[0]):
        mt = 1.0 / (kd * msize[i])
        for k in range(3):
            v[i, k] = mt * f[i, k]
            x[i, k] = scale[k] * (x0[i, k] + dt * v[i, k])
        mr = mass[i] / (kd * msize[i] * inertia[i, 0])
        omega[i, 0] = mr * torque[i, 0]
        omega[i, 1] = mr * torque[i, 1]
        omega[i, 2] = mr * torque[i, 2]
        for k in range(4):
            q[i, k] = q0[i, k]
        wn = np.sqrt(omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2)
        if wn > 0.0:
            # rotation by angle |omega| dt about omega (lab frame): free_rotate with
            # L = I_perp omega and equal moments rotates exactly that
            ip = inertia[i, 0]
            rp = 1.0 / ip
            free_rotate(q, i, ip * omega[i, 0], ip * omega[i, 1], ip * omega[i, 2],
                        u[i, 0], u[i, 1], u[i, 2], rp, rp, dt)


@pnjit
def _keep_rows(x, q, f, torque, x0, q0, f0, t0):
    """Copy positions, quaternions, forces and torques (the predictor's start)."""
    for i in prange(x.shape[0]):
        for k in range(3):
            x0[i, k] = x[i, k]
            f0[i, k] = f[i, k]
            t0[i, k] = torque[i, k]
        for k in range(4):
            q0[i, k] = q[i, k]


@pnjit
def _heun_correct(x, x0, f0, f, t0, torque, v, omega, q, q0, u, mass, inertia, msize, kd, scale,
                  dt):
    """Heun's corrector: ``x = scale x0 + dt/2 (scale F0 + F1)/(k_d a)``, the mean
    mobility velocities, and ``q = q0`` rotated by ``dt`` times the mean spin."""
    for i in prange(x.shape[0]):
        mt = 0.5 * dt / (kd * msize[i])
        for k in range(3):
            x[i, k] = scale[k] * x0[i, k] + mt * (scale[k] * f0[i, k] + f[i, k])
            v[i, k] = 0.5 * (f0[i, k] + f[i, k]) / (kd * msize[i])
        mr = mass[i] / (kd * msize[i] * inertia[i, 0])
        omega[i, 0] = 0.5 * mr * (t0[i, 0] + torque[i, 0])
        omega[i, 1] = 0.5 * mr * (t0[i, 1] + torque[i, 1])
        omega[i, 2] = 0.5 * mr * (t0[i, 2] + torque[i, 2])
        for k in range(4):
            q[i, k] = q0[i, k]
        ip = inertia[i, 0]
        rp = 1.0 / ip
        free_rotate(q, i, ip * omega[i, 0], ip * omega[i, 1], ip * omega[i, 2],
                    u[i, 0], u[i, 1], u[i, 2], rp, rp, dt)
        axis_of(q, i, u)


@njit
def heun_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, msize, box,
               periodic, pairs, ref, law, cp, walls, params, cache, clock, dt, nsteps, virial):
    """Advance ``nsteps`` overdamped Heun steps (see the module doc). ``msize`` is the
    particle area (2-D) or volume (3-D); the parameter ``k_d`` the substrate drag; the box
    contracts at the parameter ``strain_rate`` (``-kappa``). No tangential springs, of pairs or
    walls. ``v``/``omega`` return the last mobility velocities (non-affine). Returns
    ``(pairs, elastic energy, contacts, rebuilds)``."""
    prm = params[0]  # the record (pysim.records)
    n = x.shape[0]
    x0 = np.empty((n, 3))
    q0 = np.empty((n, 4))
    f0 = np.empty((n, 3))
    t0_ = np.empty((n, 3))
    scale = np.empty(3)
    rate = prm.strain_rate
    for k in range(3):
        scale[k] = np.exp(rate[k] * dt)
    kd = prm.k_d
    pe = 0.0
    nc = 0
    rebuilds = 0
    for kk in range(nsteps):
        t = clock[0] + (clock[2] + kk - clock[1]) * dt
        _keep_rows(x, q, f, torque, x0, q0, f0, t0_)
        # predictor
        _mobility_step(x0, q0, f0, t0_, mass, inertia, msize, kd, u, x, q, v, omega, dt, scale)
        for k in range(3):
            box[k] *= scale[k]
        axes(q, u)
        wrap(x, box, periodic)
        pairs, rebuilt = maybe_rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref)
        if rebuilt:
            rebuilds += 1
        forces(x, v, omega, u, radius, half, mass, box, periodic, pairs, law, cp, False, walls,
               False, params, cache, t + dt, dt, f, torque, virial, False)
        _heun_correct(x, x0, f0, f, t0_, torque, v, omega, q, q0, u, mass, inertia, msize, kd,
                      scale, dt)
        wrap(x, box, periodic)
        t = clock[0] + (clock[2] + kk + 1 - clock[1]) * dt
        pairs, rebuilt = maybe_rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref)
        if rebuilt:
            rebuilds += 1
        pe, nc, _ = forces(x, v, omega, u, radius, half, mass, box, periodic, pairs, law, cp,
                           False, walls, False, params, cache, t, dt, f, torque, virial,
                           kk == nsteps - 1)
    return pairs, pe, nc, rebuilds


#: per-block sums of :func:`_fire_sums`
_FIRE_SUMS = 7


@pnjit
def _fire_sums(f, torque, v, omega, part):
    """FIRE's sums over the particles: ``max |F|^2``, ``max |tau|^2``, ``sum |F|^2``,
    ``sum |tau|^2``, ``sum |v|^2``, ``sum |omega|^2`` and the power ``sum F.v +
    tau.omega``, taken per block of :data:`pysim.contacts.BLOCK` rows (``part``, one
    row per block) and the blocks added in order: the same for any number of threads."""
    n = f.shape[0]
    for b in prange(part.shape[0]):
        fm = 0.0
        tm = 0.0
        fs = 0.0
        ts = 0.0
        vs = 0.0
        ws = 0.0
        pw = 0.0
        for i in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            a = f[i, 0] ** 2 + f[i, 1] ** 2 + f[i, 2] ** 2
            c = torque[i, 0] ** 2 + torque[i, 1] ** 2 + torque[i, 2] ** 2
            fm = max(fm, a)
            tm = max(tm, c)
            fs += a
            ts += c
            vs += v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            ws += omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2
            pw += (f[i, 0] * v[i, 0] + f[i, 1] * v[i, 1] + f[i, 2] * v[i, 2]
                   + torque[i, 0] * omega[i, 0] + torque[i, 1] * omega[i, 1]
                   + torque[i, 2] * omega[i, 2])
        part[b, 0] = fm
        part[b, 1] = tm
        part[b, 2] = fs
        part[b, 3] = ts
        part[b, 4] = vs
        part[b, 5] = ws
        part[b, 6] = pw
    tot = _fold_blocks(part)
    return tot[0], tot[1], tot[2], tot[3], tot[4], tot[5], tot[6]


@njit
def _fold_blocks(part):
    """The totals of :func:`_fire_sums`' block rows, in block order: the largest value
    of the first two columns, the sum of the others."""
    tot = np.zeros(part.shape[1])
    for b in range(part.shape[0]):
        for c in range(part.shape[1]):
            tot[c] = max(tot[c], part[b, c]) if c < 2 else tot[c] + part[b, c]
    return tot


@pnjit
def _speed_sums(v, omega, part):
    """``sum |v|^2`` and ``sum |omega|^2`` per block, as :func:`_fire_sums`."""
    n = v.shape[0]
    for b in prange(part.shape[0]):
        vs = 0.0
        ws = 0.0
        for i in range(b * BLOCK, min(n, (b + 1) * BLOCK)):
            vs += v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            ws += omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2
        part[b, 4] = vs
        part[b, 5] = ws
    tot = _fold_blocks(part)
    return tot[4], tot[5]


@pnjit
def _fire_stop(x, v, omega, dt):
    """FIRE's stop on uphill motion: step back half a step, zero the velocities."""
    for i in prange(x.shape[0]):
        for k in range(3):
            x[i, k] -= 0.5 * dt * v[i, k]
            v[i, k] = 0.0
            omega[i, k] = 0.0


@pnjit
def _fire_mix(x, v, omega, f, torque, alpha, vn, wn, fnorm, tnorm, dt):
    """FIRE's mixing ``v = (1 - alpha) v + alpha |v| F/|F|`` (and the spins with the
    torques), then the drift ``x += dt v``."""
    for i in prange(x.shape[0]):
        for k in range(3):
            if fnorm > 0.0:
                v[i, k] = (1.0 - alpha) * v[i, k] + alpha * vn * f[i, k] / fnorm
            if tnorm > 0.0:
                omega[i, k] = (1.0 - alpha) * omega[i, k] + alpha * wn * torque[i, k] / tnorm
        x[i, 0] += dt * v[i, 0]
        x[i, 1] += dt * v[i, 1]
        x[i, 2] += dt * v[i, 2]


@njit
def fire_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, box,
               periodic, pairs, ref, law, cp, walls, params, cache, fire, nsteps, f_tol, virial):
    """Up to ``nsteps`` FIRE iterations at fixed box; stops early once every force and
    torque is below ``f_tol`` (in magnitude). No tangential springs, of pairs or walls.
    ``fire`` is the float array ``[dt, alpha, n_positive, dt_max, dt_min]``, updated in
    place so that calls can be chained. Returns ``(pairs, elastic energy, contacts,
    iterations, max |F|, max |tau|)``."""
    n = x.shape[0]
    f_inc, f_dec, alpha0, f_alpha, n_delay = 1.1, 0.5, 0.1, 0.99, 5
    part = np.zeros(((n + BLOCK - 1) // BLOCK, _FIRE_SUMS))
    inv = np.empty((n, 3))
    inverses(mass, inertia, inv)
    pe = 0.0
    nc = 0
    fmax = 0.0
    tmax = 0.0
    it = 0
    for it in range(nsteps):
        dt = fire[0]
        # convergence and power
        fmax, tmax, fn2, tn2, _, _, power = _fire_sums(f, torque, v, omega, part)
        fmax = np.sqrt(fmax)
        tmax = np.sqrt(tmax)
        if fmax < f_tol and tmax < f_tol:
            break
        if power > 0.0:
            fire[2] += 1
            if fire[2] > n_delay:
                fire[0] = min(dt * f_inc, fire[3])
                fire[1] *= f_alpha
        else:
            fire[2] = 0
            fire[0] = max(dt * f_dec, fire[4])
            fire[1] = alpha0
            _fire_stop(x, v, omega, dt)
        dt = fire[0]
        alpha = fire[1]
        # semi-implicit Euler: v += dt F/m, then mix, then move
        _kick(v, omega, u, f, torque, inv, dt)
        vn, wn = _speed_sums(v, omega, part)
        _fire_mix(x, v, omega, f, torque, alpha, np.sqrt(vn), np.sqrt(wn), np.sqrt(fn2),
                  np.sqrt(tn2), dt)
        _rotate_free(q, u, omega, inertia, inv, half, dt)
        wrap(x, box, periodic)
        pairs, _ = maybe_rebuild(x, u, box, periodic, r_int, half, params, cache, pairs, ref)
        pe, nc, _ = forces(x, v, omega, u, radius, half, mass, box, periodic, pairs, law, cp,
                           False, walls, False, params, cache, 0.0, dt, f, torque, virial, True)
    return pairs, pe, nc, it, fmax, tmax
