"""Spherocylinders as rigid glued-sphere rods for LAMMPS (``fix rigid/small molecule``).

A rod of diameter ``D`` and spine length ``L`` becomes ``n_spheres`` equal spheres of
diameter ``D`` with centres evenly spaced along the spine from one end to the other
(9 spheres at spacing ``D/2`` for ``L/D = 4``). Every sphere gets the density that gives
the rod the mass of the solid spherocylinder, ``rho V_rod / (n pi D^3 / 6)``.

The data file is ``atom_style sphere`` (``id type diameter density x y z``) plus a
``Molecules`` section (one molecule per rod, id = rod index + 1), read with::

    fix       molecules all property/atom mol ghost yes
    read_data glued.data fix molecules NULL Molecules
    neigh_modify exclude molecule/intra all
    fix       rods all rigid/small molecule reinit no

Spheres are written around the rod centre without wrapping, so LAMMPS sets image flags
that keep each body whole across periodic faces.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def glued_offsets(length: float, n_spheres: int) -> np.ndarray:
    """Positions of the sphere centres along the spine, relative to the rod centre."""
    if n_spheres < 1:
        raise ValueError(f"n_spheres must be >= 1, got {n_spheres}")
    if n_spheres == 1:
        return np.zeros(1)
    return np.linspace(-length / 2, length / 2, n_spheres)


def glued_spheres(x, u, radius, length, n_spheres: int):
    """Sphere centres ``(N * n_spheres, 3)`` and molecule ids (1-based) of glued rods with
    centres ``x`` (N, 3), unit axes ``u`` (N, 3), radii and spine lengths (scalars or N)."""
    x = np.asarray(x, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    n = len(x)
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), (n,))
    off = np.stack([glued_offsets(length[i], n_spheres) for i in range(n)])  # (N, n_spheres)
    centres = x[:, None, :] + off[:, :, None] * u[:, None, :]
    mol = np.repeat(np.arange(1, n + 1), n_spheres)
    return centres.reshape(-1, 3), mol


def write_glued_rods_data(path, x, u, radius, length, box, n_spheres: int = 9,
                          density: float = 1.0, box_lo=(0.0, 0.0, 0.0)) -> float:
    """Write N rods as glued spheres (see the module doc) to the LAMMPS data file ``path``.

    ``x`` (N, 3) centres, ``u`` (N, 3) unit axes, ``radius``/``length`` scalars or (N,),
    ``box`` (3,) edges starting at ``box_lo``, ``density`` of the solid spherocylinder.
    Returns the total volume of the true spherocylinders (for the packing fraction)."""
    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    radius = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), (n,))
    dia = 2.0 * radius
    vrod = np.pi * dia**2 * length / 4 + np.pi * dia**3 / 6
    dens = density * vrod / (n_spheres * np.pi * dia**3 / 6)
    centres, mol = glued_spheres(x, u, radius, length, n_spheres)
    rows = [f"{k + 1} 1 {dia[m - 1]:.16g} {dens[m - 1]:.16g} {c[0]:.16g} {c[1]:.16g} {c[2]:.16g}"
            for k, (c, m) in enumerate(zip(centres, mol))]
    mols = [f"{k + 1} {m}" for k, m in enumerate(mol)]
    lo = np.asarray(box_lo, dtype=np.float64)
    hi = lo + np.asarray(box, dtype=np.float64)
    head = [f"# rodpack glued-sphere rods ({n} rods x {n_spheres} spheres)", "",
            f"{len(centres)} atoms", "1 atom types", ""]
    head += [f"{lo[a]:.16g} {hi[a]:.16g} {ax}lo {ax}hi" for a, ax in enumerate("xyz")]
    text = "\n".join(head + ["", "Atoms # sphere", ""] + rows + ["", "Molecules", ""] + mols)
    Path(path).write_text(text + "\n")
    return float(vrod.sum())
