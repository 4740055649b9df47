"""Writers for rodpack's common on-disk format (``docs/formats.md``).

Every engine leaves, per run directory:

* ``particles.dump`` - LAMMPS text dump, ``ITEM: ATOMS id type x y z radius`` (rods
  add ``ux uy uz length``), one block per output step;
* ``contacts.dump``  - LAMMPS *local* dump with ``ITEM: ENTRIES`` :data:`CONTACT_COLUMNS`,
  one block per output step, the same steps as ``particles.dump``;
* ``thermo.dat``     - whitespace table with a ``# step time phi ...`` header
  (:data:`THERMO_COLUMNS`).

Files are written to ``<name>.part`` and renamed when complete (:func:`finalize`).
Also here: LAMMPS data files, the shared initial configuration.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

PARTICLE_COLUMNS = ("id", "type", "x", "y", "z", "radius")
ROD_COLUMNS = ("ux", "uy", "uz", "length")
CONTACT_COLUMNS = ("i", "j", "cx", "cy", "cz", "nx", "ny", "nz", "overlap", "fx", "fy", "fz")
THERMO_COLUMNS = ("step", "time", "phi", "pressure", "ke", "pe", "n_contacts")
FLOAT_FMT = "%.10g"


def _bounds_line(box_lo, box_hi, periodic):
    flags = " ".join("pp" if p else "ff" for p in periodic)
    lines = [f"ITEM: BOX BOUNDS {flags}"]
    lines += [f"{lo:.16g} {hi:.16g}" for lo, hi in zip(box_lo, box_hi)]
    return "\n".join(lines)


def write_particles_frame(fh, step, box, periodic, ids, types, x, radius, axis=None,
                          length=None, box_lo=(0.0, 0.0, 0.0)):
    """Append one frame to an open particle dump (LAMMPS ``dump custom`` text)."""
    n = len(ids)
    cols = list(PARTICLE_COLUMNS)
    data = [ids, types, x[:, 0], x[:, 1], x[:, 2], radius]
    if axis is not None:
        cols += list(ROD_COLUMNS)
        data += [axis[:, 0], axis[:, 1], axis[:, 2], length]
    box_hi = np.asarray(box_lo) + np.asarray(box)
    fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\n")
    fh.write(_bounds_line(box_lo, box_hi, periodic) + "\n")
    fh.write("ITEM: ATOMS " + " ".join(cols) + "\n")
    if n:
        table = np.column_stack([np.asarray(c, dtype=np.float64) for c in data])
        fmt = ["%d", "%d"] + [FLOAT_FMT] * (len(cols) - 2)
        np.savetxt(fh, table, fmt=fmt)


def write_contacts_frame(fh, step, box, periodic, ij_ids, rec, box_lo=(0.0, 0.0, 0.0)):
    """Append one frame to an open contact table (LAMMPS ``dump local`` text).

    ``ij_ids`` (C, 2) are particle *ids* (as in the particle dump), ``rec`` (C, 10):
    contact point, unit normal i->j, overlap, force on i.
    """
    c = len(ij_ids)
    box_hi = np.asarray(box_lo) + np.asarray(box)
    fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ENTRIES\n{c}\n")
    fh.write(_bounds_line(box_lo, box_hi, periodic) + "\n")
    fh.write("ITEM: ENTRIES " + " ".join(CONTACT_COLUMNS) + "\n")
    if c:
        table = np.column_stack([np.asarray(ij_ids, dtype=np.float64), rec])
        np.savetxt(fh, table, fmt=["%d", "%d"] + [FLOAT_FMT] * 10)


def thermo_header() -> str:
    return "# " + " ".join(THERMO_COLUMNS) + "\n"


def write_thermo_row(fh, row):
    """Append one thermo row ``(step, time, phi, pressure, ke, pe, n_contacts)``."""
    step, time, phi, p, ke, pe, nc = row
    fh.write(f"{int(step)} {time:.10g} {phi:.10g} {p:.10g} {ke:.10g} {pe:.10g} {int(nc)}\n")


def part_path(path) -> Path:
    """Temporary name a file is written under until :func:`finalize`."""
    path = Path(path)
    return path.with_name(path.name + ".part")


def finalize(path):
    """Atomically move ``<path>.part`` to ``path`` (after flushing it to disk)."""
    tmp = part_path(path)
    with open(tmp, "rb+") as fh:
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def atomic_write_text(path, text: str):
    """Write ``text`` to ``path`` atomically (temporary file, fsync, rename)."""
    tmp = part_path(path)
    with open(tmp, "w") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


# -- LAMMPS data files -------------------------------------------------------------------
def write_sphere_data(path, x, diameters, box, density, title="rodpack initial configuration"):
    """Write a LAMMPS data file for ``atom_style sphere`` (LIGGGHTS ``granular``).

    Atom lines: ``id type diameter density x y z``; ids are 1..N in array order.
    """
    n = len(x)
    lines = [f"# {title}", "", f"{n} atoms", "1 atom types", ""]
    for k, ax in enumerate("xyz"):
        lines.append(f"0.0 {box[k]:.16g} {ax}lo {ax}hi")
    lines += ["", "Atoms # sphere", ""]
    body = "\n".join(
        f"{i + 1} 1 {diameters[i]:.16g} {density:.16g} {x[i, 0]:.16g} {x[i, 1]:.16g} {x[i, 2]:.16g}"
        for i in range(n))
    atomic_write_text(path, "\n".join(lines) + "\n" + body + "\n")


def read_sphere_data(path):
    """Read a data file written by :func:`write_sphere_data`.

    Returns ``(ids, x (N, 3), diameters, density (N,), box_lo (3,), box (3,))`` sorted
    by id.
    """
    lo = np.zeros(3)
    hi = np.zeros(3)
    atoms = []
    n_atoms = None
    with open(path) as fh:
        lines = fh.read().splitlines()
    it = iter(enumerate(lines, 1))
    for lineno, line in it:
        s = line.split("#")[0].strip()
        if not s:
            continue
        parts = s.split()
        if parts[-1] == "atoms" and len(parts) == 2:
            n_atoms = int(parts[0])
        for k, ax in enumerate("xyz"):
            if parts[-2:] == [f"{ax}lo", f"{ax}hi"]:
                lo[k], hi[k] = float(parts[0]), float(parts[1])
        if parts[0] == "Atoms":
            for lineno2, line2 in it:
                s2 = line2.split("#")[0].strip()
                if not s2:
                    if atoms:
                        break
                    continue
                vals = s2.split()
                if len(vals) < 7:
                    raise ValueError(f"{path}:{lineno2}: expected 'id type diameter density x y z', got {line2!r}")
                atoms.append([float(v) for v in vals[:7]])
            break
    if n_atoms is None or len(atoms) != n_atoms:
        raise ValueError(f"{path}: header says {n_atoms} atoms, found {len(atoms)} atom lines")
    a = np.array(atoms)
    a = a[np.argsort(a[:, 0])]
    return a[:, 0].astype(np.int64), a[:, 4:7].copy(), a[:, 2].copy(), a[:, 3].copy(), lo, hi - lo
