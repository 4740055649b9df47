"""Walls: planes (optionally moving by a prescribed law) and a vertical cylinder.

A grain touches a wall when an end of its spine is within ``R`` of it; each end that is
makes its own contact, so a grain lying flat on a plane feels two wall forces
(science.md section 2). For convex containers this is exact: the distance of a spine
point to a plane is linear and to a cylinder axis convex along the spine, so the
deepest point is an end.

Planes are rows of a float array ``(n_planes, PLANE_COLUMNS)``:
``nx ny nz`` (unit normal pointing into the domain), ``px py pz`` (a point of the plane at
``t = 0``), ``v0`` (constant normal speed), ``amp``, ``omega_w``, ``phase`` of a sinusoidal
normal displacement: the plane sits at ``p + n (v0 t + amp sin(omega_w t + phase))``.
A tapped base is ``amp = a``, ``omega_w = 2 pi nu``. Cylinders are rows of
``(n_cyl, CYL_COLUMNS)``: axis ``x = cx, y = cy`` along ``z``, inner radius ``rc``; grains
are inside.

Wall contacts use the contact law of the pairs (:func:`pysim.contacts.law.contact_law`)
and a tangential history per grain, wall and spine end, with the same law bits
(:data:`pysim.forces.NO_TENSION`, :data:`pysim.forces.KEEP_SPRING`), with the wall's own
parameters; the force on each wall is summed
(``wall_force``), which gives wall stresses and the apparent mass on a base.
"""
from __future__ import annotations

import numpy as np

from pysim.contacts.law import contact_law
from pysim.forces import D_COH, F_COH, GAMMA_N, GAMMA_T, K_N, K_T, MU
from pysim.jit import njit

PLANE_COLUMNS = 10
CYL_COLUMNS = 3


def plane(normal, point, v0=0.0, amp=0.0, omega_w=0.0, phase=0.0) -> np.ndarray:
    """One plane row (see the module docstring); the normal is normalised."""
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    return np.r_[n, np.asarray(point, dtype=np.float64), v0, amp, omega_w, phase]


def cylinder(cx, cy, rc) -> np.ndarray:
    """One vertical cylinder row: axis at ``(cx, cy)``, inner radius ``rc``."""
    if not rc > 0:
        raise ValueError(f"cylinder radius must be > 0, got {rc}")
    return np.array([cx, cy, rc], dtype=np.float64)


@njit
def plane_offset(row, t):
    """Normal displacement and normal speed of a plane at time ``t``."""
    arg = row[8] * t + row[9]
    return row[6] * t + row[7] * np.sin(arg), row[6] + row[7] * row[8] * np.cos(arg)


@njit
def _wall_contact(i, e0, e1, e2, n0, n1, n2, delta, wv0, wv1, wv2, x, v, omega, radius,
                  law, wp, friction, whist, h, dt, f, torque):
    """Contact of one spine end ``e`` with a wall: ``n`` is the unit normal from the
    grain to the wall, ``wv`` the wall velocity. Adds force and torque to the grain and
    returns the force and the contact point."""
    ar = radius[i] - 0.5 * delta
    c0 = e0 - x[i, 0] + ar * n0
    c1 = e1 - x[i, 1] + ar * n1
    c2 = e2 - x[i, 2] + ar * n2
    w0, w1, w2 = omega[i, 0], omega[i, 1], omega[i, 2]
    vr0 = v[i, 0] + (w1 * c2 - w2 * c1) - wv0
    vr1 = v[i, 1] + (w2 * c0 - w0 * c2) - wv1
    vr2 = v[i, 2] + (w0 * c1 - w1 * c0) - wv2
    vn = vr0 * n0 + vr1 * n1 + vr2 * n2
    x0 = 0.0
    x1 = 0.0
    x2 = 0.0
    if friction:  # no springs are kept without friction
        x0, x1, x2 = whist[h, 0], whist[h, 1], whist[h, 2]
    F0, F1, F2, _, _, _, x0, x1, x2 = contact_law(
        law, wp[K_N], wp[GAMMA_N], wp[K_T], wp[GAMMA_T], wp[MU], wp[F_COH], wp[D_COH],
        friction, dt, delta, 2.0 * radius[i], n0, n1, n2, vr0, vr1, vr2, vn, vn, x0, x1, x2)
    if friction:
        whist[h, 0] = x0
        whist[h, 1] = x1
        whist[h, 2] = x2
    f[i, 0] += F0
    f[i, 1] += F1
    f[i, 2] += F2
    torque[i, 0] += c1 * F2 - c2 * F1
    torque[i, 1] += c2 * F0 - c0 * F2
    torque[i, 2] += c0 * F1 - c1 * F0
    return F0, F1, F2, c0 + x[i, 0], c1 + x[i, 1], c2 + x[i, 2]


@njit
def wall_forces(x, v, omega, u, radius, half, planes, cyls, t, law, wp, friction, whist,
                dt, f, torque, wall_force, record, rec_iw, rec):
    """Add the forces of all walls on all grains; sum the force on each wall.

    ``whist`` is ``(N * n_walls * 2, 3)``: the tangential spring of grain ``i``, wall
    ``w``, spine end ``e`` sits at row ``(i * n_walls + w) * 2 + e``. Returns the number
    of wall contacts; with ``record`` they go to ``rec_iw`` (grain index, wall index)
    and ``rec`` (point, normal grain to wall, overlap, force on the grain).
    """
    npl = planes.shape[0]
    nw = npl + cyls.shape[0]
    wall_force[:, :] = 0.0
    count = 0
    for w in range(npl):
        row = planes[w]
        off, speed = plane_offset(row, t)
        nx, ny, nz = row[0], row[1], row[2]
        px = row[3] + nx * off
        py = row[4] + ny * off
        pz = row[5] + nz * off
        wv0, wv1, wv2 = nx * speed, ny * speed, nz * speed
        for i in range(x.shape[0]):
            ends = 1 if half[i] == 0.0 else 2
            for e in range(ends):
                sg = -1.0 if e == 0 else 1.0
                e0 = x[i, 0] + sg * half[i] * u[i, 0]
                e1 = x[i, 1] + sg * half[i] * u[i, 1]
                e2 = x[i, 2] + sg * half[i] * u[i, 2]
                dist = (e0 - px) * nx + (e1 - py) * ny + (e2 - pz) * nz
                delta = radius[i] - dist
                h = (i * nw + w) * 2 + e
                if delta <= -wp[D_COH]:
                    if friction:
                        whist[h, 0] = 0.0
                        whist[h, 1] = 0.0
                        whist[h, 2] = 0.0
                    continue
                F0, F1, F2, q0, q1, q2 = _wall_contact(
                    i, e0, e1, e2, -nx, -ny, -nz, delta, wv0, wv1, wv2, x, v, omega,
                    radius, law, wp, friction, whist, h, dt, f, torque)
                wall_force[w, 0] -= F0
                wall_force[w, 1] -= F1
                wall_force[w, 2] -= F2
                if record:
                    rec_iw[count, 0] = i
                    rec_iw[count, 1] = w
                    rec[count, 0] = q0
                    rec[count, 1] = q1
                    rec[count, 2] = q2
                    rec[count, 3] = -nx
                    rec[count, 4] = -ny
                    rec[count, 5] = -nz
                    rec[count, 6] = delta
                    rec[count, 7] = F0
                    rec[count, 8] = F1
                    rec[count, 9] = F2
                count += 1
    for c in range(cyls.shape[0]):
        w = npl + c
        cx, cy, rc = cyls[c, 0], cyls[c, 1], cyls[c, 2]
        for i in range(x.shape[0]):
            ends = 1 if half[i] == 0.0 else 2
            for e in range(ends):
                sg = -1.0 if e == 0 else 1.0
                e0 = x[i, 0] + sg * half[i] * u[i, 0]
                e1 = x[i, 1] + sg * half[i] * u[i, 1]
                e2 = x[i, 2] + sg * half[i] * u[i, 2]
                r0 = e0 - cx
                r1 = e1 - cy
                rho = np.sqrt(r0 * r0 + r1 * r1)
                delta = radius[i] - (rc - rho)
                h = (i * nw + w) * 2 + e
                if delta <= -wp[D_COH] or rho == 0.0:
                    if friction:
                        whist[h, 0] = 0.0
                        whist[h, 1] = 0.0
                        whist[h, 2] = 0.0
                    continue
                n0 = r0 / rho
                n1 = r1 / rho
                F0, F1, F2, q0, q1, q2 = _wall_contact(
                    i, e0, e1, e2, n0, n1, 0.0, delta, 0.0, 0.0, 0.0, x, v, omega,
                    radius, law, wp, friction, whist, h, dt, f, torque)
                wall_force[w, 0] -= F0
                wall_force[w, 1] -= F1
                wall_force[w, 2] -= F2
                if record:
                    rec_iw[count, 0] = i
                    rec_iw[count, 1] = w
                    rec[count, 0] = q0
                    rec[count, 1] = q1
                    rec[count, 2] = q2
                    rec[count, 3] = n0
                    rec[count, 4] = n1
                    rec[count, 5] = 0.0
                    rec[count, 6] = delta
                    rec[count, 7] = F0
                    rec[count, 8] = F1
                    rec[count, 9] = F2
                count += 1
    return count
