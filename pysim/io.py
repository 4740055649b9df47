"""Writers for rodpack's common on-disk format (``docs/formats.md``).

Every engine leaves, per run directory:

* ``particles.dump`` - LAMMPS text dump, ``ITEM: ATOMS id type x y z radius`` (rods
  add ``ux uy uz length`` and OVITO's :data:`OVITO_COLUMNS`), one block per output step;
* ``contacts.dump``  - LAMMPS *local* dump with ``ITEM: ENTRIES`` :data:`CONTACT_COLUMNS`,
  one block per output step, the same steps as ``particles.dump``;
* ``thermo.dat``     - whitespace table with a ``# step time phi ...`` header
  (:data:`THERMO_COLUMNS`).

Files are written to ``<name>.part`` and renamed when complete
(:func:`rodcase.files.finalize`).
Also here: LAMMPS data files, the shared initial configuration.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from rodcase.files import atomic_write_text, finalize, part_path  # noqa: F401 (used here too)

PARTICLE_COLUMNS = ("id", "type", "x", "y", "z", "radius")
ROD_COLUMNS = ("ux", "uy", "uz", "length")
#: what OVITO maps by name onto its Orientation and Aspherical Shape, so that it draws rods
#: as spherocylinders: the quaternion turning z onto the spine, and LAMMPS' ellipsoid
#: convention of shape columns, which OVITO halves on import: ``2R, 2R, 2L`` give its
#: spherocylinder of radius ``R`` and cylinder length ``L``
OVITO_COLUMNS = ("quatw", "quati", "quatj", "quatk", "shapex", "shapey", "shapez")
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
        cols += list(ROD_COLUMNS) + list(OVITO_COLUMNS)
        q = quaternion_from_z(axis)
        data += [axis[:, 0], axis[:, 1], axis[:, 2], length, q[:, 0], q[:, 1], q[:, 2], q[:, 3],
                 2 * np.asarray(radius), 2 * np.asarray(radius), 2 * np.asarray(length)]
    box_hi = np.asarray(box_lo) + np.asarray(box)
    fh.write(f"ITEM: TIMESTEP\n{step}\nITEM: NUMBER OF ATOMS\n{n}\n")
    fh.write(_bounds_line(box_lo, box_hi, periodic) + "\n")
    fh.write("ITEM: ATOMS " + " ".join(cols) + "\n")
    if n:
        table = np.column_stack([np.asarray(c, dtype=np.float64) for c in data])
        fmt = ["%d", "%d"] + [FLOAT_FMT] * (len(cols) - 2)
        np.savetxt(fh, table, fmt=fmt)


def quaternion_from_z(axis) -> np.ndarray:
    """Unit quaternions ``(w, x, y, z)`` (N, 4) of the rotations that turn the z axis onto
    the unit vectors ``axis`` (N, 3) by the shortest arc: ``q = (1 + u_z, -u_y, u_x, 0)``
    normalised (the half-angle form of ``(cos th/2, sin th/2 (z x u)/|z x u|)``); for
    ``u = -z`` a half turn about x."""
    u = np.asarray(axis, dtype=np.float64).reshape(-1, 3)
    q = np.column_stack([1.0 + u[:, 2], -u[:, 1], u[:, 0], np.zeros(len(u))])
    down = q[:, 0] < 1e-12
    q[down] = (0.0, 1.0, 0.0, 0.0)
    return q / np.linalg.norm(q, axis=1)[:, None]


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


def write_rod_data(path, x, axis, radius, length, box, density, dimension=3,
                   title="rodpack initial configuration", box_lo=(0.0, 0.0, 0.0), v=None):
    """Write spherocylinders as a LAMMPS data file for ``atom_style ellipsoid``.

    Each rod is an atom with an ``Ellipsoids`` entry ``id D D L+D qw qx qy qz``: the long
    (body z) axis is the spine, the quaternion rotates body into lab axes (the pysim
    convention), so LAMMPS, OVITO and pysim read the same orientations. The atom
    ``density`` column holds the material density (engines derive masses from their own
    representation of the rod). 2-D files have ``z = 0`` and ``zlo zhi = -0.5 0.5``; the
    box spans ``box_lo`` to ``box_lo + box``. ``v`` (N, 3), when given, is written as a
    ``Velocities`` section (``id vx vy vz lx ly lz``, no angular momentum).
    """
    from pysim.rotation import quaternions_from_axes

    x = np.asarray(x, dtype=np.float64)
    n = len(x)
    radius = np.broadcast_to(np.asarray(radius, dtype=np.float64), (n,))
    length = np.broadcast_to(np.asarray(length, dtype=np.float64), (n,))
    q = quaternions_from_axes(axis)
    lines = [f"# {title}", "", f"{n} atoms", "1 atom types", f"{n} ellipsoids", ""]
    for k, ax in enumerate("xyz"):
        if k == 2 and dimension == 2:
            lines.append("-0.5 0.5 zlo zhi")
        else:
            lines.append(f"{box_lo[k]:.16g} {box_lo[k] + box[k]:.16g} {ax}lo {ax}hi")
    lines += ["", "Atoms # ellipsoid", ""]
    lines += [f"{i + 1} 1 1 {density:.16g} {x[i, 0]:.16g} {x[i, 1]:.16g} {x[i, 2]:.16g}"
              for i in range(n)]
    lines += ["", "Ellipsoids", ""]
    lines += [f"{i + 1} {2 * radius[i]:.16g} {2 * radius[i]:.16g} {length[i] + 2 * radius[i]:.16g} "
              f"{q[i, 0]:.16g} {q[i, 1]:.16g} {q[i, 2]:.16g} {q[i, 3]:.16g}" for i in range(n)]
    if v is not None:
        v = np.asarray(v, dtype=np.float64)
        lines += ["", "Velocities", ""]
        lines += [f"{i + 1} {v[i, 0]:.16g} {v[i, 1]:.16g} {v[i, 2]:.16g} 0 0 0" for i in range(n)]
    atomic_write_text(path, "\n".join(lines) + "\n")


class DataFileError(ValueError):
    """An initial-configuration file cannot be read; the message is one line that names the
    file and what a valid one holds."""


#: what :func:`read_particle_data` reads, for its error messages
DATA_FILE_HINT = ("a LAMMPS data file of atom_style sphere or ellipsoid, as python -m pysim "
                  "init writes")


def _sections(path):
    """Header values and named sections (lists of number rows) of a LAMMPS data file."""
    header = {}
    sections = {}
    current = None
    try:
        with open(path) as fh:
            for lineno, raw in enumerate(fh, 1):
                line = raw.split("#")[0].strip()
                if not line:
                    continue
                word = line.split()[0]
                if word[0].isalpha():
                    current = word
                    sections[current] = []
                    continue
                if current is None:
                    parts = line.split()
                    key = " ".join(p for p in parts if not _is_number(p))
                    header[key] = [float(p) for p in parts if _is_number(p)]
                else:
                    try:
                        sections[current].append([float(v) for v in line.split()])
                    except ValueError:
                        raise DataFileError(f"{path}:{lineno}: not a number in "
                                            f"{raw.strip()!r}; the {current} section holds "
                                            "numbers only") from None
    except FileNotFoundError:
        raise DataFileError(f"{path}: no such file; give {DATA_FILE_HINT}") from None
    except UnicodeDecodeError:
        raise DataFileError(f"{path}: not a text file; give {DATA_FILE_HINT}") from None
    except OSError as exc:
        raise DataFileError(f"{path}: cannot be read ({exc.strerror}); give "
                            f"{DATA_FILE_HINT}") from None
    return header, sections


def _is_number(s):
    try:
        float(s)
        return True
    except ValueError:
        return False


def read_particle_data(path) -> dict:
    """Read an initial configuration written by :func:`write_sphere_data` (spheres) or
    :func:`write_rod_data` (spherocylinders).

    Returns a dict of arrays sorted by id: ``ids``, ``x`` (N, 3), ``radius``, ``length``,
    ``axis`` (N, 3), ``density`` (N,), ``v`` (N, 3; zero without a ``Velocities``
    section), and ``box_lo``, ``box`` (3,).
    """
    from pysim.rotation import axes

    header, sections = _sections(path)
    count = header.get("atoms", [])
    if len(count) != 1 or count[0] != int(count[0]) or count[0] < 1:
        raise DataFileError(f"{path}: not a LAMMPS data file (no 'N atoms' line with N >= 1 in "
                            f"its header); give {DATA_FILE_HINT}")
    n = int(count[0])
    rows = sections.get("Atoms", [])
    if len(rows) != n:
        raise DataFileError(f"{path}: the header says {n} atoms, the Atoms section has "
                            f"{len(rows)} lines; give {DATA_FILE_HINT}")
    if min(len(r) for r in rows) < 7:
        raise DataFileError(f"{path}: an Atoms line has {min(len(r) for r in rows)} columns; "
                            "atom_style sphere and ellipsoid lines have 7 or more (id type "
                            "diameter-or-flag density x y z)")
    atoms = np.array([r[:7] for r in rows])
    box = [header.get(f"{a}lo {a}hi", []) for a in "xyz"]
    if any(len(b) != 2 or not b[1] > b[0] for b in box):
        raise DataFileError(f"{path}: the header needs the box, lines 'lo hi xlo xhi', "
                            "'lo hi ylo yhi' and 'lo hi zlo zhi' with lo < hi")
    lo = np.array([b[0] for b in box])
    hi = np.array([b[1] for b in box])
    if not (np.all(np.isfinite(atoms)) and np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
        raise DataFileError(f"{path}: holds a value that is not finite (nan or inf); every "
                            "number of a data file must be finite")
    atoms = atoms[np.argsort(atoms[:, 0])]
    ids = atoms[:, 0].astype(np.int64)
    v = np.zeros((n, 3))
    for name, cols, what in (("Velocities", 4, "id vx vy vz"),
                             ("Ellipsoids", 8, "id D D L+D qw qx qy qz")):
        if any(len(r) < cols for r in sections.get(name, [])):
            raise DataFileError(f"{path}: a {name} line has fewer than {cols} columns ({what})")
    if "Velocities" in sections:
        vel = np.array([r[:4] for r in sections["Velocities"]])
        vel = vel[np.argsort(vel[:, 0])]
        if len(vel) != n or not np.array_equal(vel[:, 0].astype(np.int64), ids):
            raise DataFileError(f"{path}: the Velocities section must list every atom once")
        v = vel[:, 1:4].copy()
    if "Ellipsoids" in sections:
        ell = np.array([r[:8] for r in sections["Ellipsoids"]])
        ell = ell[np.argsort(ell[:, 0])]
        if len(ell) != n or not np.array_equal(ell[:, 0].astype(np.int64), ids):
            raise DataFileError(f"{path}: the Ellipsoids section must list every atom once")
        radius = ell[:, 1] / 2.0
        length = ell[:, 3] - ell[:, 1]
        q = np.ascontiguousarray(ell[:, 4:8])
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        u = np.empty((n, 3))
        axes(q, u)
        return {"ids": ids, "x": atoms[:, 4:7].copy(), "radius": radius, "length": length,
                "axis": u, "density": atoms[:, 3].copy(), "box_lo": lo, "box": hi - lo, "v": v}
    return {"ids": ids, "x": atoms[:, 4:7].copy(), "radius": atoms[:, 2] / 2.0,
            "length": np.zeros(n), "axis": np.tile([0.0, 0.0, 1.0], (n, 1)),
            "density": atoms[:, 3].copy(), "box_lo": lo, "box": hi - lo, "v": v}
