"""Reading what LAMMPS and LIGGGHTS write (dumps, local dumps, ``thermo.dat``) and the
conversion steps every engine's converter shares: sphere-pair geometry from a particle
frame, contact tables in the common format (``docs/formats.md``), flat-wall contact rows,
glued spheres written as rods."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pysim import io
from workflows.engines.common import EngineError


def _iter_local(path: Path):
    """Yield ``(step, box_lines, columns, table)`` of a LAMMPS-style local dump."""
    with open(path) as fh:
        lines = fh.read().splitlines()
    k = 0
    while k < len(lines):
        if not lines[k].startswith("ITEM: TIMESTEP"):
            k += 1
            continue
        step = int(lines[k + 1])
        n = int(lines[k + 3])
        box_lines = lines[k + 4:k + 8]
        cols = lines[k + 8].split()[2:]
        body = lines[k + 9:k + 9 + n]
        table = np.array([r.split() for r in body], dtype=np.float64).reshape(n, len(cols))
        yield step, box_lines, cols, table
        k += 9 + n


def _iter_dump(path: Path):
    """Yield ``(step, box_lines, periodic, columns, table)`` of a particle dump."""
    from analysis.io import _blocks

    for step, bounds, periodic, cols, table, _first in _blocks(path, "ITEM: NUMBER OF ATOMS"):
        yield step, bounds, periodic, cols, table


def _particle_frames(path: Path):
    """``{step: (ids, x, radius, box_lo, box)}`` of a particle dump, for conversion."""
    from analysis.io import read_particle_frames  # local import: analysis reads dumps

    return {f.step: f for f in read_particle_frames(path)}


def _geometry(frame, ids_i, ids_j):
    """Normal, overlap and contact point of sphere pairs from a particle frame."""
    index = {int(t): k for k, t in enumerate(frame.ids)}
    a = np.array([index[int(t)] for t in ids_i], dtype=np.int64)
    b = np.array([index[int(t)] for t in ids_j], dtype=np.int64)
    d = frame.x[b] - frame.x[a]
    d = frame.minimum_image(d)
    r = np.linalg.norm(d, axis=1)
    n = d / np.where(r > 0, r, 1.0)[:, None]
    delta = frame.radius[a] + frame.radius[b] - r
    point = frame.x[a] + (frame.radius[a] - 0.5 * delta)[:, None] * n
    return n, delta, point


def _write_converted(native: Path, particles: Path, out: Path, columns_of):
    frames = _particle_frames(particles)
    dropped = 0
    with open(io.part_path(out), "w") as fh:
        for step, _box, cols, table in _iter_local(native):
            if step not in frames:
                raise EngineError(f"{native}: contact frame at step {step} has no particle "
                                  f"frame in {particles}")
            fr = frames[step]
            ids_i, ids_j, force = columns_of(cols, table)
            n, delta, point = _geometry(fr, ids_i, ids_j)
            keep = delta > 0
            dropped += int(np.count_nonzero(~keep))
            rec = np.column_stack([point, n, delta, force])[keep]
            ij = np.column_stack([ids_i, ids_j]).astype(np.int64)[keep]
            io.write_contacts_frame(fh, step, fr.box, fr.periodic, ij, rec, box_lo=fr.box_lo)
    io.finalize(out)
    return {"dropped": dropped}


def _with_walls(pairs, walls):
    """One :class:`analysis.frame.Contacts` of sphere-sphere rows followed by wall rows."""
    from analysis.frame import Contacts

    return Contacts(pairs.step, *(np.concatenate([getattr(pairs, k), getattr(walls, k)])
                                  for k in ("i", "j", "point", "normal", "overlap", "force")))


def _plane_wall_contacts(frame, walls):
    """Sphere-wall rows of flat walls: ``walls`` lists, for wall id ``-(k + 1)``, ``(on,
    axis, far, gap, force)``: the touching spheres (indices into ``frame``), the wall's
    axis and side (``far``: at ``x = W``), each sphere's centre distance to the wall and
    the wall's force on it. Normal from the sphere to the wall, overlap ``R - gap``, point
    in the middle of the overlap. Returns a :class:`analysis.frame.Contacts`."""
    from analysis.frame import Contacts

    rows = []
    for w, (on, axis, far, gap, force) in enumerate(walls):
        normal = np.zeros((len(on), 3))
        normal[:, axis] = 1.0 if far else -1.0
        overlap = frame.radius[on] - gap
        point = frame.x[on] + (frame.radius[on] - 0.5 * overlap)[:, None] * normal
        rows.append((frame.ids[on], np.full(len(on), -(w + 1)), point, normal, overlap, force))
    i, j, point, normal, overlap, force = (np.concatenate(x) for x in zip(*rows))
    return Contacts(frame.step, i.astype(np.int64), j.astype(np.int64), point, normal, overlap,
                    force)


def _write_glued_frame(fp, fc, spheres, contacts, body):
    """Write one frame of glued spheres as rods (:func:`analysis.contacts.glued_bodies`,
    centres wrapped into a periodic box) and their sphere contacts merged per rod pair
    (:func:`analysis.contacts.merge_glued_contacts`) to the open particle and contact
    files; ``body`` (N,) is each sphere's rod id."""
    from analysis.contacts import glued_bodies, merge_glued_contacts

    rods, _ = glued_bodies(spheres, body)
    merged, _ = merge_glued_contacts(spheres, contacts, body)
    centre = np.where(rods.periodic, rods.box_lo + np.mod(rods.x - rods.box_lo, rods.box), rods.x)
    io.write_particles_frame(fp, spheres.step, rods.box, rods.periodic, rods.ids, rods.types,
                             centre, rods.radius, axis=rods.axis, length=rods.length,
                             box_lo=rods.box_lo)
    rec = np.column_stack([merged.point, merged.normal, merged.overlap, merged.force])
    io.write_contacts_frame(fc, spheres.step, rods.box, rods.periodic,
                            np.column_stack([merged.i, merged.j]), rec, box_lo=rods.box_lo)


def _last_step(thermo: Path) -> int:
    last = 0
    with open(thermo) as fh:
        for line in fh:
            if line.strip() and not line.startswith("#"):
                last = int(float(line.split()[0]))
    return last


def _count_atoms(dump: Path) -> int:
    with open(dump) as fh:
        for line in fh:
            if line.startswith("ITEM: NUMBER OF ATOMS"):
                return int(next(fh))
    return 0
