"""The data files the LAMMPS decks read, written from a case's ``init.data``: rods as glued
spheres (``fix rigid/small``; 2-D: glued disks) and rods as body particles (engine
``lammps-body``)."""
from __future__ import annotations

import numpy as np

from workflows.engines.common import glued_spheres

#: density per area of LAMMPS' 2-D rods: the overdamped limit needs m / (k_d A) = rho / k_d
#: well below the compression's time scales (rho / k_d = 0.05 t_0; damping ratio ~3)
RHO_2D = 0.05


def write_glued_data(init_path, out_path, case: dict) -> float:
    """Write the rods of an initial configuration as glued equal spheres for LAMMPS
    ``fix rigid/small molecule`` and return the total true rod volume.

    Each rod becomes :func:`glued_spheres` spheres of its diameter, centres evenly spaced
    from one spine end to the other (``atom_style sphere`` atoms plus a ``Molecules``
    section read with ``fix property/atom mol``). Every sphere gets the density that gives
    the rod the mass of the solid spherocylinder, ``rho V_rod / (n pi D^3 / 6)``. Spheres
    are written around the rod centre without wrapping, so LAMMPS sets image flags that
    keep each body whole. 2-D cases (``in.2d.compress``): disks in the plane ``z = 0`` of a
    unit-thick periodic box, atom type 1 for the smallest diameter and 2 for larger ones,
    masses set by the deck; the total true rod *area* is returned.
    """
    from pysim.io import read_particle_data
    from rodcase.files import atomic_write_text

    d = read_particle_data(init_path)
    spacing = case["particles"].get("glued_spacing", 0.25)
    rho = case["particles"].get("density", 1.0)
    two_d = case["particles"].get("dimension", 3) == 2
    rows, mols, vels = [], [], []
    vtot = 0.0
    k = 0
    d_small = float(2.0 * d["radius"].min())
    for i in range(len(d["ids"])):
        dia = 2.0 * d["radius"][i]
        length = d["length"][i]
        ns = glued_spheres(length, dia, spacing)
        if two_d:  # areas; masses are set by the 2-D deck (set density/disc)
            vrod = dia * length + np.pi * dia**2 / 4
            dens = 1.0
        else:
            vrod = np.pi * dia**2 * length / 4 + np.pi * dia**3 / 6
            dens = rho * vrod / (ns * np.pi * dia**3 / 6)
        vtot += vrod
        atype = 2 if two_d and dia > d_small * (1 + 1e-9) else 1
        offsets = np.linspace(-length / 2, length / 2, ns) if ns > 1 else np.zeros(1)
        for sk in offsets:
            k += 1
            p = d["x"][i] + sk * d["axis"][i]
            if two_d:
                p[2] = 0.0
            rows.append(f"{k} {atype} {dia:.16g} {dens:.16g} {p[0]:.16g} {p[1]:.16g} {p[2]:.16g}")
            mols.append(f"{k} {d['ids'][i]}")
            vi = d["v"][i]
            vels.append(f"{k} {vi[0]:.16g} {vi[1]:.16g} {vi[2]:.16g} 0 0 0")
    lo, hi = d["box_lo"].copy(), d["box_lo"] + d["box"]
    if two_d:  # a unit-thick periodic z for LAMMPS' 2-D box
        lo[2], hi[2] = -0.5, 0.5
    head = [f"# rodpack glued-sphere rods ({len(d['ids'])} rods, spacing <= {spacing} D)", "",
            f"{k} atoms", f"{2 if two_d else 1} atom types", ""]
    head += [f"{lo[a]:.16g} {hi[a]:.16g} {ax}lo {ax}hi" for a, ax in enumerate("xyz")]
    text = "\n".join(head + ["", "Atoms # sphere", ""] + rows + ["", "Molecules", ""] + mols)
    if np.any(d["v"] != 0.0):  # every sphere moves with its rod (no initial spin)
        text += "\n\nVelocities\n\n" + "\n".join(vels)
    atomic_write_text(out_path, text + "\n")
    return vtot


def write_body_data(init_path, out_path, case: dict) -> float:
    """Write the rods of an initial configuration as LAMMPS body particles and return
    their total area (2-D, ``in.2d.body.compress``) or volume (3-D,
    ``in.rods.body.compress``).

    Each rod is one body: two vertices at the spine ends ``x +- (L/2) u`` (one vertex for
    a sphere or disk) and rounded diameter ``D``. 2-D: ``body rounded/polygon`` of mass
    ``rho A`` with ``rho = RHO_2D`` per area and the lab-frame inertia tensor of the
    stadium lamina (:func:`pysim.state.inertia_2d` about the normal; about the spine
    ``rho (4 A R^3/3 + pi R^4/4)`` with ``A = L/2``; the in-plane perpendicular moment is
    the difference); atom type 1 for the smallest diameter, 2 for larger ones, as
    :func:`write_glued_data`. 3-D: ``body rounded/polyhedron`` (integers ``2 1 0``) of
    mass ``rho V`` with the case's density and the solid spherocylinder's moments
    (:func:`pysim.state.inertia_3d`), one atom type.
    """
    from pysim.io import read_particle_data
    from rodcase.files import atomic_write_text
    from pysim.state import area, inertia_2d, inertia_3d, volume

    two_d = case["particles"].get("dimension", 3) == 2
    d = read_particle_data(init_path)
    n = len(d["ids"])
    r = d["radius"]
    length = d["length"]
    small = float(r.min())
    rho = RHO_2D if two_d else case["particles"].get("density", 1.0)
    atoms, bodies = [], []
    total = 0.0
    for i in range(n):
        u = np.array(d["axis"][i], dtype=float)
        if two_d:
            u[2] = 0.0
        u /= np.linalg.norm(u)
        if two_d:
            measure = float(area(r[i], length[i]))
            i_z = float(inertia_2d(r[i], length[i], rho))
            i_u = rho * (4.0 * (length[i] / 2) * r[i]**3 / 3 + np.pi * r[i]**4 / 4)
            w = np.array([-u[1], u[0], 0.0])
            t = i_u * np.outer(u, u) + (i_z - i_u) * np.outer(w, w)
            t[2, 2] = i_z
        else:
            measure = float(volume(r[i], length[i]))
            i_perp, i_axis = (float(v) for v in inertia_3d(r[i], length[i], rho))
            t = i_perp * np.eye(3) + (i_axis - i_perp) * np.outer(u, u)
        total += measure
        atype = 2 if two_d and r[i] > small * (1 + 1e-9) else 1
        x = d["x"][i]
        z = 0.0 if two_d else x[2]
        atoms.append(f"{d['ids'][i]} {atype} 1 {rho * measure:.16g} {x[0]:.16g} {x[1]:.16g} "
                     f"{z:.16g}")
        ends = [0.5 * length[i] * u, -0.5 * length[i] * u] if length[i] > 0 else [np.zeros(3)]
        coords = " ".join(f"{c:.16g}" for e in ends for c in e)
        inertia = " ".join(f"{v:.16g}" for v in (t[0, 0], t[1, 1], t[2, 2], t[0, 1], t[0, 2],
                                                  t[1, 2]))
        ints = str(len(ends)) if two_d else f"{len(ends)} {len(ends) - 1} 0"
        bodies += [f"{d['ids'][i]} {1 if two_d else 3} {6 + 3 * len(ends) + 1}", ints, inertia,
                   coords, f"{2.0 * r[i]:.16g}"]
    lo, hi = d["box_lo"].copy(), d["box_lo"] + d["box"]
    if two_d:
        lo[2], hi[2] = -0.5, 0.5
    style = "rounded/polygon" if two_d else "rounded/polyhedron"
    head = [f"# rodpack rods as body {style} ({n} bodies)", "", f"{n} atoms", f"{n} bodies",
            f"{2 if two_d else 1} atom types", ""]
    head += [f"{lo[a]:.16g} {hi[a]:.16g} {ax}lo {ax}hi" for a, ax in enumerate("xyz")]
    text = "\n".join(head + ["", "Atoms # body", ""] + atoms + ["", "Bodies", ""] + bodies)
    if np.any(d["v"] != 0.0):
        text += "\n\nVelocities\n\n" + "\n".join(
            f"{d['ids'][i]} {d['v'][i][0]:.16g} {d['v'][i][1]:.16g} "
            f"{0.0 if two_d else d['v'][i][2]:.16g} 0 0 0" for i in range(n))
    atomic_write_text(out_path, text + "\n")
    return total
