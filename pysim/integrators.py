"""Time integration kernels.

``verlet_chunk`` advances spheres by velocity Verlet for a number of steps, with a
background viscous drag and an optional affine change of the box (compression or
expansion at a constant true strain rate), rebuilding the Verlet list as needed.
The step order follows LAMMPS (``fix nve/sphere``, ``fix viscous``,
``fix deform ... remap x``) so that engines can be compared step for step:

1. ``v += dt/2 F/m``; ``x += dt v``; wrap into the box
2. rebuild the pair list if :func:`pysim.neighbors.needs_rebuild`
3. ``F = contact forces(x, v) - gamma_bg v``
4. ``v += dt/2 F/m``
5. box ``L_k *= exp(eps_k dt)`` and ``x_k *= exp(eps_k dt)`` (affine remap)
"""
from __future__ import annotations

import numpy as np

from pysim.contacts import REC_COLUMNS, sphere_contacts
from pysim.jit import njit
from pysim.neighbors import build_pairs, needs_rebuild


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
def compute_forces(x, v, radius, box, periodic, pi, pj, law, params, gamma_bg, f, virial):
    """Zero and fill ``f`` (contacts plus drag ``-gamma_bg v``) and ``virial``.

    Returns ``(elastic energy, number of contacts)``.
    """
    f[:, :] = 0.0
    virial[:, :] = 0.0
    dummy_ij = np.empty((0, 2), np.int64)
    dummy = np.empty((0, REC_COLUMNS))
    pe, nc = sphere_contacts(x, v, radius, box, periodic, pi, pj, law, params, f, virial,
                             False, dummy_ij, dummy)
    if gamma_bg != 0.0:
        for i in range(x.shape[0]):
            for k in range(3):
                f[i, k] -= gamma_bg * v[i, k]
    return pe, nc


@njit
def verlet_chunk(x, v, f, radius, mass, box, periodic, pi, pj, x_ref, box_ref, skin,
                 law, params, gamma_bg, strain_rate, dt, nsteps, virial):
    """Advance ``nsteps`` velocity-Verlet steps (see the module docstring).

    ``strain_rate`` (3,) is the true strain rate per axis (1/time; negative
    compresses). ``f`` must hold the forces of the current state on entry and holds
    those of the final state on exit; ``virial`` is the contact virial of the last
    force evaluation. The pair list ``(pi, pj)`` and its reference ``x_ref``,
    ``box_ref`` are updated when rebuilt.

    Returns ``(pi, pj, elastic energy, contacts, rebuilds)``.
    """
    n = x.shape[0]
    r_int_max = 0.0
    for i in range(n):
        if radius[i] > r_int_max:
            r_int_max = radius[i]
    scale = np.empty(3)
    for k in range(3):
        scale[k] = np.exp(strain_rate[k] * dt)
    pe = 0.0
    nc = 0
    rebuilds = 0
    for _ in range(nsteps):
        for i in range(n):
            h = 0.5 * dt / mass[i]
            for k in range(3):
                v[i, k] += h * f[i, k]
                x[i, k] += dt * v[i, k]
        wrap(x, box, periodic)
        if needs_rebuild(x, x_ref, box, box_ref, periodic, r_int_max, skin):
            pi, pj = build_pairs(x, radius, box, periodic, skin)
            x_ref[:, :] = x
            box_ref[:] = box
            rebuilds += 1
        pe, nc = compute_forces(x, v, radius, box, periodic, pi, pj, law, params, gamma_bg,
                                f, virial)
        for i in range(n):
            h = 0.5 * dt / mass[i]
            for k in range(3):
                v[i, k] += h * f[i, k]
        for k in range(3):
            box[k] *= scale[k]
        for i in range(n):
            for k in range(3):
                x[i, k] *= scale[k]
    return pi, pj, pe, nc, rebuilds
