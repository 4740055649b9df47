"""Time integration kernels: velocity Verlet with rotation, overdamped Heun, FIRE.

All three share :func:`forces` (contacts, walls, gravity, drag) and
:func:`maybe_rebuild` (the Verlet list). Arrays are those of :class:`pysim.state.State`
plus ``half = L/2`` and ``r_int = R + L/2 + d_c/2`` (interaction radii), the pair list
``(pi, pj)`` with its per-pair tangential springs ``hist``, and the wall arrays of
:mod:`pysim.walls`. ``sys`` is a float array of the scalars below.

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

from pysim.contacts import REC_COLUMNS, pair_forces
from pysim.jit import njit
from pysim.neighbors import build_pairs, needs_rebuild, transfer_history
from pysim.rotation import axis_of, free_rotate
from pysim.walls import wall_forces

# indices into the 'sys' scalar array
GAMMA_BG, GAMMA_ROT, GX, GY, GZ, EPS_X, EPS_Y, EPS_Z, GROWTH, SKIN, RINT_BUILD, K_D = range(12)
SYS_SIZE = 12


@njit
def wrap(x, box, periodic):
    """Wrap positions into ``[0, box)`` along periodic axes (in place)."""
    for i in range(x.shape[0]):
        for k in range(3):
            if periodic[k]:
                x[i, k] -= box[k] * np.floor(x[i, k] / box[k])
                if x[i, k] >= box[k]:  # round-off at the upper edge
                    x[i, k] -= box[k]


@njit
def max_of(a):
    m = 0.0
    for i in range(a.shape[0]):
        if a[i] > m:
            m = a[i]
    return m


@njit
def maybe_rebuild(x, box, periodic, r_int, sys, pi, pj, hist, x_ref, box_ref):
    """Rebuild the pair list (carrying the tangential history) when an unlisted pair
    could come into range. Returns ``(pi, pj, hist, rebuilt)``."""
    rmax = max_of(r_int)
    growth = rmax / sys[RINT_BUILD] if sys[RINT_BUILD] > 0 else 1.0
    if not needs_rebuild(x, x_ref, box, box_ref, periodic, sys[RINT_BUILD], sys[SKIN], growth):
        return pi, pj, hist, False
    npi, npj = build_pairs(x, r_int, box, periodic, sys[SKIN])
    nhist = transfer_history(pi, pj, hist, npi, npj)
    x_ref[:, :] = x
    box_ref[:] = box
    sys[RINT_BUILD] = rmax
    return npi, npj, nhist, True


@njit
def forces(x, v, omega, u, radius, half, mass, box, periodic, pi, pj, hist, law, cp,
           friction, planes, cyls, wp, wfriction, whist, wall_force, sys, t, dt, f, torque,
           virial):
    """Zero and fill ``f``, ``torque``, ``virial``: pair contacts, walls, gravity
    ``m g``, drag ``-gamma_bg v`` and ``-gamma_rot omega``. Returns ``(elastic energy,
    pair contacts, wall contacts)``."""
    f[:, :] = 0.0
    torque[:, :] = 0.0
    virial[:, :] = 0.0
    no_ij = np.empty((0, 2), np.int64)
    no_rec = np.empty((0, REC_COLUMNS))
    pe, nc = pair_forces(x, v, omega, u, radius, half, box, periodic, pi, pj, hist, law, cp,
                         friction, dt, f, torque, virial, False, no_ij, no_rec)
    nw = 0
    if planes.shape[0] + cyls.shape[0] > 0:
        nw = wall_forces(x, v, omega, u, radius, half, planes, cyls, t, law, wp, wfriction,
                         whist, dt, f, torque, wall_force, False, no_ij, no_rec)
    gx, gy, gz = sys[GX], sys[GY], sys[GZ]
    gb = sys[GAMMA_BG]
    gr = sys[GAMMA_ROT]
    if gx != 0.0 or gy != 0.0 or gz != 0.0 or gb != 0.0 or gr != 0.0:
        for i in range(x.shape[0]):
            f[i, 0] += mass[i] * gx - gb * v[i, 0]
            f[i, 1] += mass[i] * gy - gb * v[i, 1]
            f[i, 2] += mass[i] * gz - gb * v[i, 2]
            torque[i, 0] -= gr * omega[i, 0]
            torque[i, 1] -= gr * omega[i, 1]
            torque[i, 2] -= gr * omega[i, 2]
    return pe, nc, nw


@njit
def _kick(v, omega, u, f, torque, mass, inertia, h):
    """``v += h F/m``, ``omega += h I^-1 tau``."""
    for i in range(v.shape[0]):
        a = h / mass[i]
        v[i, 0] += a * f[i, 0]
        v[i, 1] += a * f[i, 1]
        v[i, 2] += a * f[i, 2]
        ip = inertia[i, 0]
        ia = inertia[i, 1]
        tu = torque[i, 0] * u[i, 0] + torque[i, 1] * u[i, 1] + torque[i, 2] * u[i, 2]
        c = (1.0 / ia - 1.0 / ip) * tu
        omega[i, 0] += h * (torque[i, 0] / ip + c * u[i, 0])
        omega[i, 1] += h * (torque[i, 1] / ip + c * u[i, 1])
        omega[i, 2] += h * (torque[i, 2] / ip + c * u[i, 2])


@njit
def _rotate_free(q, u, omega, inertia, dt):
    """Exact free symmetric-top rotation over ``dt`` at constant angular momentum."""
    for i in range(q.shape[0]):
        ip = inertia[i, 0]
        ia = inertia[i, 1]
        wu = omega[i, 0] * u[i, 0] + omega[i, 1] * u[i, 1] + omega[i, 2] * u[i, 2]
        # L = I_perp omega + (I_axis - I_perp)(omega . u) u
        l0 = ip * omega[i, 0] + (ia - ip) * wu * u[i, 0]
        l1 = ip * omega[i, 1] + (ia - ip) * wu * u[i, 1]
        l2 = ip * omega[i, 2] + (ia - ip) * wu * u[i, 2]
        if l0 == 0.0 and l1 == 0.0 and l2 == 0.0:
            continue
        free_rotate(q, i, l0, l1, l2, u[i, 0], u[i, 1], u[i, 2], ip, ia, dt)
        axis_of(q, i, u)
        # omega = I^-1 L with the new axis
        lu = l0 * u[i, 0] + l1 * u[i, 1] + l2 * u[i, 2]
        c = (1.0 / ia - 1.0 / ip) * lu
        omega[i, 0] = l0 / ip + c * u[i, 0]
        omega[i, 1] = l1 / ip + c * u[i, 1]
        omega[i, 2] = l2 / ip + c * u[i, 2]


@njit
def _deform(x, box, radius, half, r_int, mass, inertia, sys, dt):
    """Affine box change and particle growth at the end of a step."""
    for k in range(3):
        eps = sys[EPS_X + k]
        if eps != 0.0:
            sc = np.exp(eps * dt)
            box[k] *= sc
            for i in range(x.shape[0]):
                x[i, k] *= sc
    g = sys[GROWTH]
    if g != 0.0:
        sc = np.exp(g * dt)
        sc3 = sc * sc * sc
        sc5 = sc3 * sc * sc
        for i in range(x.shape[0]):
            radius[i] *= sc
            half[i] *= sc
            r_int[i] *= sc
            mass[i] *= sc3
            inertia[i, 0] *= sc5
            inertia[i, 1] *= sc5


@njit
def verlet_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, box,
                 periodic, pi, pj, hist, x_ref, box_ref, law, cp, friction, planes, cyls, wp,
                 wfriction, whist, wall_force, sys, clock, dt, nsteps, virial):
    """Advance ``nsteps`` velocity-Verlet steps (see the module doc).

    ``clock = (t_seg, s_seg, step0)``: the time after step ``k`` of this call is
    ``t_seg + (step0 + k + 1 - s_seg) dt``, a function of the step number alone, so that
    results do not depend on how a run is cut into calls (restarts are bit-identical).
    ``f``/``torque`` must hold the forces of the current state on entry and hold those of
    the final state on exit. Returns ``(pi, pj, hist, elastic energy, pair contacts,
    wall contacts, rebuilds)``.
    """
    h = 0.5 * dt
    pe = 0.0
    nc = 0
    nw = 0
    rebuilds = 0
    for k in range(nsteps):
        t = clock[0] + (clock[2] + k + 1 - clock[1]) * dt
        _kick(v, omega, u, f, torque, mass, inertia, h)
        for i in range(x.shape[0]):
            x[i, 0] += dt * v[i, 0]
            x[i, 1] += dt * v[i, 1]
            x[i, 2] += dt * v[i, 2]
        _rotate_free(q, u, omega, inertia, dt)
        wrap(x, box, periodic)
        pi, pj, hist, rebuilt = maybe_rebuild(x, box, periodic, r_int, sys, pi, pj, hist,
                                              x_ref, box_ref)
        if rebuilt:
            rebuilds += 1
        pe, nc, nw = forces(x, v, omega, u, radius, half, mass, box, periodic, pi, pj, hist,
                            law, cp, friction, planes, cyls, wp, wfriction, whist, wall_force,
                            sys, t, dt, f, torque, virial)
        _kick(v, omega, u, f, torque, mass, inertia, h)
        _deform(x, box, radius, half, r_int, mass, inertia, sys, dt)
    return pi, pj, hist, pe, nc, nw, rebuilds


@njit
def _mobility_step(x0, q0, f, torque, mass, inertia, msize, kd, u, x, q, v, omega, dt, scale):
    """``x = scale (x0 + dt F/(k_d a))``, ``q = q0`` rotated by ``dt tau/(k_d a I/m)``."""
    for i in range(x.shape[0]):
        mt = 1.0 / (kd * msize[i])
        for k in range(3):
            v[i, k] = mt * f[i, k]
            x[i, k] = scale[k] * (x0[i, k] + dt * v[i, k])
        mr = mass[i] / (kd * msize[i] * inertia[i, 0])
        omega[i, 0] = mr * torque[i, 0]
        omega[i, 1] = mr * torque[i, 1]
        omega[i, 2] = mr * torque[i, 2]
        q[i, :] = q0[i, :]
        wn = np.sqrt(omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2)
        if wn > 0.0:
            # rotation by angle |omega| dt about omega (lab frame): free_rotate with
            # L = I_perp omega and equal moments rotates exactly that
            ip = inertia[i, 0]
            free_rotate(q, i, ip * omega[i, 0], ip * omega[i, 1], ip * omega[i, 2],
                        u[i, 0], u[i, 1], u[i, 2], ip, ip, dt)


@njit
def heun_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, msize, box,
               periodic, pi, pj, hist, x_ref, box_ref, law, cp, planes, cyls, wp, wall_force,
               sys, clock, dt, nsteps, virial):
    """Advance ``nsteps`` overdamped Heun steps (see the module doc). ``msize`` is the
    particle area (2-D) or volume (3-D); ``sys[K_D]`` the substrate drag ``k_d``; the box
    contracts at ``sys[EPS_*]`` (``-kappa``). ``v``/``omega`` return the last mobility
    velocities (non-affine). Returns ``(pi, pj, hist, elastic energy, contacts,
    rebuilds)``."""
    n = x.shape[0]
    x0 = np.empty((n, 3))
    q0 = np.empty((n, 4))
    f0 = np.empty((n, 3))
    t0_ = np.empty((n, 3))
    scale = np.empty(3)
    for k in range(3):
        scale[k] = np.exp(sys[EPS_X + k] * dt)
    kd = sys[K_D]
    whist = np.zeros((0, 3))
    pe = 0.0
    nc = 0
    rebuilds = 0
    for kk in range(nsteps):
        t = clock[0] + (clock[2] + kk - clock[1]) * dt
        x0[:, :] = x
        q0[:, :] = q
        f0[:, :] = f
        t0_[:, :] = torque
        # predictor
        _mobility_step(x0, q0, f0, t0_, mass, inertia, msize, kd, u, x, q, v, omega, dt, scale)
        for k in range(3):
            box[k] *= scale[k]
        for i in range(n):
            axis_of(q, i, u)
        wrap(x, box, periodic)
        pi, pj, hist, rebuilt = maybe_rebuild(x, box, periodic, r_int, sys, pi, pj, hist,
                                              x_ref, box_ref)
        if rebuilt:
            rebuilds += 1
        forces(x, v, omega, u, radius, half, mass, box, periodic, pi, pj, hist, law, cp,
               False, planes, cyls, wp, False, whist, wall_force, sys, t + dt, dt, f, torque,
               virial)
        # corrector: x = scale x0 + dt/2 (scale F0 + F1)/(k_d a)
        for i in range(n):
            mt = 0.5 * dt / (kd * msize[i])
            for k in range(3):
                x[i, k] = scale[k] * x0[i, k] + mt * (scale[k] * f0[i, k] + f[i, k])
                v[i, k] = 0.5 * (f0[i, k] + f[i, k]) / (kd * msize[i])
            mr = mass[i] / (kd * msize[i] * inertia[i, 0])
            omega[i, 0] = 0.5 * mr * (t0_[i, 0] + torque[i, 0])
            omega[i, 1] = 0.5 * mr * (t0_[i, 1] + torque[i, 1])
            omega[i, 2] = 0.5 * mr * (t0_[i, 2] + torque[i, 2])
            q[i, :] = q0[i, :]
            ip = inertia[i, 0]
            free_rotate(q, i, ip * omega[i, 0], ip * omega[i, 1], ip * omega[i, 2],
                        u[i, 0], u[i, 1], u[i, 2], ip, ip, dt)
            axis_of(q, i, u)
        wrap(x, box, periodic)
        t = clock[0] + (clock[2] + kk + 1 - clock[1]) * dt
        pi, pj, hist, rebuilt = maybe_rebuild(x, box, periodic, r_int, sys, pi, pj, hist,
                                              x_ref, box_ref)
        if rebuilt:
            rebuilds += 1
        pe, nc, _ = forces(x, v, omega, u, radius, half, mass, box, periodic, pi, pj, hist,
                           law, cp, False, planes, cyls, wp, False, whist, wall_force, sys, t,
                           dt, f, torque, virial)
    return pi, pj, hist, pe, nc, rebuilds


@njit
def fire_chunk(x, v, q, u, omega, f, torque, radius, half, r_int, mass, inertia, box,
               periodic, pi, pj, hist, x_ref, box_ref, law, cp, planes, cyls, wp, wall_force,
               sys, fire, nsteps, f_tol, virial):
    """Up to ``nsteps`` FIRE iterations at fixed box; stops early once every force and
    torque is below ``f_tol`` (in magnitude). ``fire`` is the float array
    ``[dt, alpha, n_positive, dt_max, dt_min]``, updated in place so that calls can be
    chained. Returns ``(pi, pj, hist, elastic energy, contacts, iterations, max |F|,
    max |tau|)``."""
    n = x.shape[0]
    f_inc, f_dec, alpha0, f_alpha, n_delay = 1.1, 0.5, 0.1, 0.99, 5
    whist = np.zeros((0, 3))
    pe = 0.0
    nc = 0
    fmax = 0.0
    tmax = 0.0
    it = 0
    for it in range(nsteps):
        dt = fire[0]
        # convergence and power
        fmax = 0.0
        tmax = 0.0
        power = 0.0
        vn2 = 0.0
        fn2 = 0.0
        wn2 = 0.0
        tn2 = 0.0
        for i in range(n):
            a = f[i, 0] ** 2 + f[i, 1] ** 2 + f[i, 2] ** 2
            b = torque[i, 0] ** 2 + torque[i, 1] ** 2 + torque[i, 2] ** 2
            fmax = max(fmax, a)
            tmax = max(tmax, b)
            fn2 += a
            tn2 += b
            vn2 += v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            wn2 += omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2
            power += (f[i, 0] * v[i, 0] + f[i, 1] * v[i, 1] + f[i, 2] * v[i, 2]
                      + torque[i, 0] * omega[i, 0] + torque[i, 1] * omega[i, 1]
                      + torque[i, 2] * omega[i, 2])
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
            for i in range(n):
                for k in range(3):
                    x[i, k] -= 0.5 * dt * v[i, k]
                    v[i, k] = 0.0
                    omega[i, k] = 0.0
            vn2 = 0.0
            wn2 = 0.0
        dt = fire[0]
        alpha = fire[1]
        # semi-implicit Euler: v += dt F/m, then mix, then move
        _kick(v, omega, u, f, torque, mass, inertia, dt)
        vn = 0.0
        wn = 0.0
        for i in range(n):
            vn += v[i, 0] ** 2 + v[i, 1] ** 2 + v[i, 2] ** 2
            wn += omega[i, 0] ** 2 + omega[i, 1] ** 2 + omega[i, 2] ** 2
        vn = np.sqrt(vn)
        wn = np.sqrt(wn)
        fnorm = np.sqrt(fn2)
        tnorm = np.sqrt(tn2)
        for i in range(n):
            for k in range(3):
                if fnorm > 0.0:
                    v[i, k] = (1.0 - alpha) * v[i, k] + alpha * vn * f[i, k] / fnorm
                if tnorm > 0.0:
                    omega[i, k] = (1.0 - alpha) * omega[i, k] + alpha * wn * torque[i, k] / tnorm
            x[i, 0] += dt * v[i, 0]
            x[i, 1] += dt * v[i, 1]
            x[i, 2] += dt * v[i, 2]
        _rotate_free(q, u, omega, inertia, dt)
        wrap(x, box, periodic)
        pi, pj, hist, _ = maybe_rebuild(x, box, periodic, r_int, sys, pi, pj, hist, x_ref,
                                        box_ref)
        pe, nc, _ = forces(x, v, omega, u, radius, half, mass, box, periodic, pi, pj, hist,
                           law, cp, False, planes, cyls, wp, False, whist, wall_force, sys, 0.0,
                           dt, f, torque, virial)
    return pi, pj, hist, pe, nc, it, fmax, tmax
